//! Running a scene into memory: each output's records as Arrow [`RecordBatch`]es instead of
//! Parquet files — the engine behind the Python package (`gradtac.run(scene)`,
//! `gradtac.Pipeline`) and any host that wants the data, not files.
//!
//! The run is the one `gradtac run` does — the same plan, stages, sources and record
//! builders — with every output's sink replaced by a [`MemoryOutputs`] sink: rows are
//! appended to the same Arrow builders the Parquet sink uses and handed over as batches, so
//! a batch holds exactly the rows, values and Arrow schema that the CLI's Parquet file holds
//! (the schema's metadata carries the file's key-value pairs too: `gradtac.version`,
//! `gradtac.schema`, `gradtac.time`, `gradtac.scene`, `gradtac.tap`, `gradtac.layout…`).
//! Nothing is written: no output, no `.partial` file, no CAN bus statistics file.
//!
//! Two ways to take the batches:
//! - [`MemoryOutputs::channel`]: batches of up to 8192 rows (fewer for wide records, as the
//!   Parquet sink cuts them) cross a bounded channel while the run goes on (constant memory:
//!   a slow reader stalls the run; a reader that hangs up ends it with an error).
//! - [`MemoryOutputs::queue`]: rows are held until [`MemoryOutputs::flush`], which cuts one
//!   batch per output with pending rows; [`MemoryOutputs::take`] drains them. [`Pipeline`]
//!   uses it to return one batch per push.
//!
//! ```
//! use gradtac::memory::{MemoryOutputs, Pipeline};
//! # use gradtac::stream::{Layout, SensorId, TaxelFrame, Timestamp};
//! // a streaming single-sensor pipeline: settings use the scene's `[stages.*]` keys
//! let settings: toml::Table = toml::from_str("[savgol]\nwindow = 7\n")?;
//! let mut p = Pipeline::new("biotac-sp", "savgol", &settings, Some(100.0), "ff")?;
//! let (times, values): (Vec<i64>, Vec<f64>) = ((0..50).map(|k| k * 10_000_000).collect(), vec![1.0; 50 * 24]);
//! let batch = p.push_frames(&times, &values)?;
//! let rest = p.finish()?;
//! assert_eq!(batch.num_rows() + rest.num_rows(), 50, "one smoothed frame per frame in");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::plan::{Plan, Tap};
use crate::run::{RunOptions, RunReport, Runner};
use crate::scene::Scene;
use crate::sinks::Record;
use crate::Error;
use arrow_array::RecordBatch;
use arrow_schema::{DataType, Schema, SchemaRef};
use gradtac_io::archive::RecordSink;
use gradtac_io::records::SCHEMA_KEY;
use gradtac_io::{ArrowRecord, RecordBuilder, TimeBase};
use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::{Arc, Mutex, MutexGuard};

/// Key of the writing crate's version in the batches' schema metadata (as in the files).
const VERSION_KEY: &str = gradtac_io::parquet_sink::VERSION_KEY;
/// Most rows of a streamed batch (the Parquet sink hands its writer batches of this size).
const MAX_BATCH_ROWS: usize = 8192;
/// Most bytes of records in one streamed batch (wide records, e.g. surfaces, cut sooner).
const MAX_BATCH_BYTES: usize = 32 << 20;

/// Where the records of an in-memory run go (see the [module docs](self)); cheap to clone,
/// one handle shared by every output's sink.
#[derive(Clone)]
pub struct MemoryOutputs {
    shared: Arc<Shared>,
}

enum Deliver {
    Channel(SyncSender<(usize, RecordBatch)>),
    Queue(Mutex<Vec<(usize, RecordBatch)>>),
}

struct Shared {
    deliver: Deliver,
    /// Cut a batch when a builder holds this many rows (streaming); `false`: only on flush.
    stream: bool,
    /// Every output's builder, for [`MemoryOutputs::flush`].
    pending: Mutex<Vec<Arc<Mutex<dyn Cut>>>>,
    /// Every output's schema (with its metadata), by output index.
    schemas: Mutex<HashMap<usize, SchemaRef>>,
}

fn lock<T: ?Sized>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // a panic elsewhere never leaves a builder half-appended (append is all-or-nothing)
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl MemoryOutputs {
    /// Batches stream over a channel of `capacity` (≥ 1) batches as the run makes them; the
    /// receiver gets `(output index in the scene, batch)`. The run ends with an error when
    /// the receiver is dropped.
    pub fn channel(capacity: usize) -> (MemoryOutputs, Receiver<(usize, RecordBatch)>) {
        let (tx, rx) = sync_channel(capacity.max(1));
        (MemoryOutputs::new(Deliver::Channel(tx), true), rx)
    }

    /// Rows are held until [`flush`](Self::flush); [`take`](Self::take) returns the batches.
    pub fn queue() -> MemoryOutputs {
        MemoryOutputs::new(Deliver::Queue(Mutex::new(Vec::new())), false)
    }

    fn new(deliver: Deliver, stream: bool) -> MemoryOutputs {
        MemoryOutputs {
            shared: Arc::new(Shared {
                deliver,
                stream,
                pending: Mutex::new(Vec::new()),
                schemas: Mutex::new(HashMap::new()),
            }),
        }
    }

    /// Cut every output's pending rows into one batch each (outputs in the order they were
    /// opened) and deliver them.
    pub fn flush(&self) -> Result<(), Error> {
        let pending: Vec<_> = lock(&self.shared.pending).clone();
        for p in pending {
            let cut = lock(&*p).cut()?;
            if let Some((i, b)) = cut {
                self.shared.deliver(i, b)?;
            }
        }
        Ok(())
    }

    /// The batches delivered so far and not yet taken (always empty for a channel).
    pub fn take(&self) -> Vec<(usize, RecordBatch)> {
        match &self.shared.deliver {
            Deliver::Queue(q) => std::mem::take(&mut *lock(q)),
            Deliver::Channel(_) => Vec::new(),
        }
    }

    /// Drop every pending row (not yet in a batch) and every batch not yet taken.
    pub fn clear(&self) {
        let pending: Vec<_> = lock(&self.shared.pending).clone();
        for p in pending {
            lock(&*p).clear();
        }
        let _ = self.take();
    }

    /// The Arrow schema (with its metadata) of the output at `index` in the scene, once the
    /// run has opened it.
    pub fn schema(&self, index: usize) -> Option<SchemaRef> {
        lock(&self.shared.schemas).get(&index).cloned()
    }

    /// A sink of output `index` (records of type `T`, `shape`, times of `time`); used by
    /// [`Sinks::open_in`](crate::sinks::Sinks::open_in).
    pub(crate) fn sink<T: Record>(&self, index: usize, shape: T::Shape, time: TimeBase) -> Box<dyn RecordSink<T>> {
        let builder = T::builder(&shape, time, 1024);
        let base = builder.schema();
        let batch_rows = (MAX_BATCH_BYTES / row_bytes(&base)).clamp(1, MAX_BATCH_ROWS);
        let mut pending = Pending::<T> { output: index, builder, base, schema: None, metadata: Vec::new() };
        pending.set(VERSION_KEY.into(), env!("CARGO_PKG_VERSION").into());
        pending.set(SCHEMA_KEY.into(), T::SCHEMA_ID.into());
        lock(&self.shared.schemas).insert(index, pending.schema());
        let pending = Arc::new(Mutex::new(pending));
        lock(&self.shared.pending).push(pending.clone() as Arc<Mutex<dyn Cut>>);
        Box::new(MemorySink::<T> {
            pending,
            shared: self.shared.clone(),
            rows: 0,
            batch_rows: self.shared.stream.then_some(batch_rows),
        })
    }
}

impl Shared {
    fn deliver(&self, output: usize, batch: RecordBatch) -> Result<(), Error> {
        match &self.deliver {
            Deliver::Channel(tx) => tx.send((output, batch)).map_err(|_| {
                Error::Io2(gradtac_io::Error::Io {
                    path: PathBuf::from("<memory>"),
                    source: std::io::Error::new(
                        std::io::ErrorKind::BrokenPipe,
                        "the reader of the in-memory outputs has gone",
                    ),
                })
            }),
            Deliver::Queue(q) => {
                lock(q).push((output, batch));
                Ok(())
            }
        }
    }
}

/// Bytes one row of `schema` takes at least (fixed-width columns; 16 per string or list).
fn row_bytes(schema: &Schema) -> usize {
    fn width(dt: &DataType) -> usize {
        match dt {
            DataType::FixedSizeList(f, n) => (*n).max(0) as usize * width(f.data_type()),
            DataType::Struct(fs) => fs.iter().map(|f| width(f.data_type())).sum(),
            other => other.primitive_width().unwrap_or(16),
        }
    }
    schema.fields().iter().map(|f| width(f.data_type())).sum::<usize>().max(1)
}

/// One output's rows not yet in a batch.
struct Pending<T: ArrowRecord> {
    output: usize,
    builder: T::Builder,
    /// The builder's schema.
    base: SchemaRef,
    /// `base` with `metadata` added (built on first use after a change).
    schema: Option<SchemaRef>,
    metadata: Vec<(String, String)>,
}

impl<T: ArrowRecord> Pending<T> {
    fn set(&mut self, key: String, value: String) {
        match self.metadata.iter_mut().find(|(k, _)| *k == key) {
            Some((_, v)) => *v = value,
            None => self.metadata.push((key, value)),
        }
        self.schema = None;
    }

    fn schema(&mut self) -> SchemaRef {
        self.schema
            .get_or_insert_with(|| {
                let mut md = self.base.metadata().clone();
                md.extend(self.metadata.iter().cloned());
                Arc::new(Schema::new_with_metadata(self.base.fields().clone(), md))
            })
            .clone()
    }

    fn batch(&mut self) -> Result<RecordBatch, Error> {
        let schema = self.schema();
        let b = self.builder.finish()?;
        b.with_schema(schema).map_err(|e| {
            Error::Io2(gradtac_io::Error::InvalidConfig(format!("in-memory output #{}: {e}", self.output + 1)))
        })
    }
}

/// Cut a batch of whatever type.
trait Cut: Send {
    fn cut(&mut self) -> Result<Option<(usize, RecordBatch)>, Error>;
    fn clear(&mut self);
}

impl<T: ArrowRecord + Send> Cut for Pending<T> {
    fn cut(&mut self) -> Result<Option<(usize, RecordBatch)>, Error> {
        if self.builder.is_empty() {
            return Ok(None);
        }
        Ok(Some((self.output, self.batch()?)))
    }
    fn clear(&mut self) {
        if !self.builder.is_empty() {
            let _ = self.builder.finish();
        }
    }
}

/// The sink of one output in memory.
struct MemorySink<T: ArrowRecord> {
    pending: Arc<Mutex<Pending<T>>>,
    shared: Arc<Shared>,
    rows: u64,
    /// Streaming: cut a batch at this many rows.
    batch_rows: Option<usize>,
}

fn io_err(e: Error) -> gradtac_io::Error {
    match e {
        Error::Io2(e) => e,
        other => gradtac_io::Error::InvalidConfig(other.to_string()),
    }
}

impl<T: ArrowRecord + Send + 'static> RecordSink<T> for MemorySink<T> {
    fn push(&mut self, record: &T) -> gradtac_io::Result<()> {
        let full = {
            let mut p = lock(&self.pending);
            p.builder.append(record)?;
            match self.batch_rows {
                Some(n) if p.builder.len() >= n => Some((p.output, p.batch().map_err(io_err)?)),
                _ => None,
            }
        };
        self.rows += 1;
        if let Some((i, b)) = full {
            self.shared.deliver(i, b).map_err(io_err)?;
        }
        Ok(())
    }
    fn rows(&self) -> u64 {
        self.rows
    }
    fn set_metadata(&mut self, key: String, value: String) {
        let mut p = lock(&self.pending);
        p.set(key, value);
        let (i, s) = (p.output, p.schema());
        lock(&self.shared.schemas).insert(i, s);
    }
    fn finish(self: Box<Self>) -> gradtac_io::Result<Vec<PathBuf>> {
        let cut = lock(&self.pending).cut().map_err(io_err)?;
        if let Some((i, b)) = cut {
            self.shared.deliver(i, b).map_err(io_err)?;
        }
        Ok(Vec::new())
    }
    fn abort(self: Box<Self>) -> gradtac_io::Result<Vec<PathBuf>> {
        Ok(Vec::new())
    }
}

/// Run a scene into `out` on the calling thread (a tokio runtime of its own reads the
/// sources, as [`run::run_blocking`](crate::run::run_blocking)); writes nothing.
pub fn run(scene: &Scene, plan: &Plan, out: &MemoryOutputs) -> Result<RunReport, Error> {
    crate::run::run_blocking_in(scene, plan, &RunOptions { threads: 0, ..Default::default() }, Some(out))
}

/// A streaming single-sensor chain in memory: frames in, one [`RecordBatch`] of the tapped
/// stage's records out per push (see the [module docs](self)).
///
/// It is a one-sensor scene run by the same [`Runner`] as `gradtac run`: the settings table
/// uses the scene's `[stages.*]` keys (`{"savgol": {"window": 7}}`), so a pipeline in code and
/// a scene on the command line agree, and only the stages the tap needs are built. Frames go
/// in pushed order; the records a push completes come back from it (a stage's delay holds
/// the rest until later pushes or [`finish`](Self::finish)).
pub struct Pipeline {
    scene: Scene,
    plan: Plan,
    runner: Option<Runner>,
    out: MemoryOutputs,
    sensor: SensorId,
    taxels: usize,
    seq: u64,
    /// Frames pushed since the last reset (for times from `rate_hz`).
    frames: u64,
    rate_hz: Option<f64>,
    /// Set by an error: the stages' state is unknown until [`reset`](Self::reset).
    failed: bool,
}

fn unreachable_runner() -> Error {
    Error::Scene { path: PathBuf::from(PIPELINE_PATH), reason: "no runner; call reset()".into() }
}

/// The name of a pipeline's (never opened) source and output in its scene.
const PIPELINE_PATH: &str = "<pipeline>";

impl Pipeline {
    /// A pipeline of `layout` (a built-in layout name such as `biotac-sp`, or a layout CSV)
    /// up to `tap` (a stage name of the scene vocabulary: `source`, `normalise`, `savgol`,
    /// `events`, `window`, `surface`, `contour`, `track`, `force`, `servo`, `dos`), with
    /// `settings` as the scene's `[stages]` table and frames at `rate_hz` (the rate stages
    /// with settings in seconds use; `None`: settings in frames). The sensor column holds
    /// `sensor`. Invalid settings fail here, naming the key.
    pub fn new(
        layout: &str,
        tap: &str,
        settings: &toml::Table,
        rate_hz: Option<f64>,
        sensor: &str,
    ) -> Result<Pipeline, Error> {
        let at = |reason: String| Error::Scene { path: PathBuf::from(PIPELINE_PATH), reason };
        match Tap::parse(tap) {
            None => return Err(at(format!("unknown tap {tap:?}; one of {}", Tap::names().join(", ")))),
            Some(Tap::Slip) => {
                return Err(at("the slip tap joins two sensors; run a scene with both (gradtac.run)".into()))
            }
            Some(_) => {}
        }
        let mut source = toml::Table::new();
        source.insert("npy".into(), PIPELINE_PATH.into());
        match rate_hz {
            Some(r) => source.insert("rate_hz".into(), r.into()),
            None => source.insert("timestamps".into(), PIPELINE_PATH.into()),
        };
        let mut s = toml::Table::new();
        s.insert("name".into(), sensor.into());
        s.insert("layout".into(), layout.into());
        s.insert("source".into(), source.into());
        let mut o = toml::Table::new();
        o.insert("tap".into(), tap.into());
        o.insert("path".into(), format!("{PIPELINE_PATH}.parquet").into());
        let mut doc = toml::Table::new();
        doc.insert("sensor".into(), toml::Value::Array(vec![s.into()]));
        doc.insert("stages".into(), settings.clone().into());
        doc.insert("output".into(), toml::Value::Array(vec![o.into()]));
        let text = toml::to_string(&doc).map_err(|e| at(e.to_string()))?;
        // relative paths (a dos model) resolve against the working directory
        let scene = Scene::from_toml(&text, PathBuf::new(), Path::new(PIPELINE_PATH))?;
        let plan = Plan::new(&scene)?;
        let taxels = plan.sensors[0].layout.len();
        let out = MemoryOutputs::queue();
        let runner = Runner::new_in(&scene, &plan, Some(&out))?;
        Ok(Pipeline {
            scene,
            plan,
            runner: Some(runner),
            out,
            sensor: SensorId::new(sensor),
            taxels,
            seq: 0,
            frames: 0,
            rate_hz,
            failed: false,
        })
    }

    /// Taxels per frame (the layout's).
    pub fn taxels(&self) -> usize {
        self.taxels
    }

    /// The schema of every batch (with the metadata a Parquet output of the scene carries).
    pub fn schema(&self) -> SchemaRef {
        self.out.schema(0).expect("the runner opened the output")
    }

    /// The plan as `gradtac explain` prints it: each stage's effective settings.
    pub fn explain(&self) -> String {
        self.plan.explain(&self.scene)
    }

    /// The scene the pipeline runs (TOML).
    pub fn scene_text(&self) -> &str {
        &self.scene.text
    }

    fn runner(&mut self) -> Result<&mut Runner, Error> {
        if self.failed || self.runner.is_none() {
            return Err(Error::Scene {
                path: PathBuf::from(PIPELINE_PATH),
                reason: "an earlier push failed; call reset() before pushing again".into(),
            });
        }
        self.runner.as_mut().ok_or_else(unreachable_runner)
    }

    /// Push one frame (its `values` must have [`taxels`](Self::taxels) entries).
    pub fn push(&mut self, time: Timestamp, values: Vec<f64>) -> Result<(), Error> {
        let frame = TaxelFrame::new(self.sensor.clone(), time, self.seq, values);
        let pushed = self.runner()?.push(frame);
        self.failed |= pushed.is_err();
        self.seq += 1;
        self.frames += 1;
        pushed
    }

    /// Push `times.len()` frames (times in ns; `values` row-major, `times.len()` × taxels) and
    /// return the records they completed as one batch (possibly empty).
    pub fn push_frames(&mut self, times: &[i64], values: &[f64]) -> Result<RecordBatch, Error> {
        self.check_shape(times.len(), values.len())?;
        for (t, row) in times.iter().zip(values.chunks_exact(self.taxels.max(1))) {
            self.push(Timestamp(*t), row.to_vec())?;
        }
        self.take()
    }

    /// Push `n` frames timed by the pipeline's `rate_hz` (frame k of the stream at k / rate).
    pub fn push_frames_at_rate(&mut self, values: &[f64]) -> Result<RecordBatch, Error> {
        let Some(rate) = self.rate_hz else {
            return Err(Error::Scene {
                path: PathBuf::from(PIPELINE_PATH),
                reason: "frames without times need the pipeline's rate_hz".into(),
            });
        };
        let n = values.len() / self.taxels.max(1);
        self.check_shape(n, values.len())?;
        for row in values.chunks_exact(self.taxels.max(1)) {
            let t = Timestamp::checked_at_rate(self.frames, rate).ok_or_else(|| Error::Scene {
                path: PathBuf::from(PIPELINE_PATH),
                reason: format!("frame {}: its time at {rate} Hz does not fit in i64 nanoseconds", self.frames),
            })?;
            self.push(t, row.to_vec())?;
        }
        self.take()
    }

    fn check_shape(&self, n: usize, values: usize) -> Result<(), Error> {
        if n.checked_mul(self.taxels) != Some(values) {
            return Err(Error::Scene {
                path: PathBuf::from(PIPELINE_PATH),
                reason: format!(
                    "{values} values for {n} frames of {} taxels: give values of shape (frames, {})",
                    self.taxels, self.taxels
                ),
            });
        }
        Ok(())
    }

    /// The records completed since the last call, as one batch.
    pub fn take(&mut self) -> Result<RecordBatch, Error> {
        self.out.flush()?;
        let batches: Vec<RecordBatch> = self.out.take().into_iter().map(|(_, b)| b).collect();
        let schema = self.schema();
        match batches.len() {
            0 => Ok(RecordBatch::new_empty(schema)),
            1 => Ok(batches.into_iter().next().expect("one")),
            _ => arrow_select::concat::concat_batches(&schema, &batches)
                .map_err(|e| Error::Scene { path: PathBuf::from(PIPELINE_PATH), reason: e.to_string() }),
        }
    }

    /// End of the stream: flush every stage, return the last records, and start afresh (the
    /// next push begins a new stream, as after [`reset`](Self::reset)).
    pub fn finish(&mut self) -> Result<RecordBatch, Error> {
        self.runner()?;
        let runner = self.runner.take().ok_or_else(unreachable_runner)?;
        self.failed = true; // until the reset below succeeds
        let finished = runner.finish();
        let batch = finished.and_then(|_| self.take());
        self.reset()?;
        batch
    }

    /// Drop every stage's state and every pending record (a gap in the stream): the next push
    /// begins a new stream. Fails only if the stages cannot be built again (a model file
    /// removed since); the pipeline then refuses pushes until a reset succeeds.
    pub fn reset(&mut self) -> Result<(), Error> {
        self.out.clear();
        self.runner = None;
        self.failed = true;
        let out = MemoryOutputs::queue();
        self.runner = Some(Runner::new_in(&self.scene, &self.plan, Some(&out))?);
        self.out = out;
        self.seq = 0;
        self.frames = 0;
        self.failed = false;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(s: &str) -> toml::Table {
        toml::from_str(s).unwrap()
    }

    fn frames(n: usize, taxels: usize) -> (Vec<i64>, Vec<f64>) {
        let times = (0..n as i64).map(|k| k * 10_000_000).collect();
        let values = (0..n * taxels).map(|i| 2000.0 + ((i * 7919) % 101) as f64 + (i / taxels) as f64).collect();
        (times, values)
    }

    #[test]
    fn pushes_in_chunks_give_the_records_of_one_push() {
        let (times, values) = frames(300, 24);
        let mut one = Pipeline::new("biotac-sp", "track", &table(""), Some(100.0), "ff").unwrap();
        let mut all = vec![one.push_frames(&times, &values).unwrap()];
        all.push(one.finish().unwrap());
        let whole = arrow_select::concat::concat_batches(&one.schema(), &all).unwrap();
        for chunk in [1, 7, 64] {
            let mut p = Pipeline::new("biotac-sp", "track", &table(""), Some(100.0), "ff").unwrap();
            let mut parts = Vec::new();
            for (t, v) in times.chunks(chunk).zip(values.chunks(chunk * 24)) {
                parts.push(p.push_frames(t, v).unwrap());
            }
            parts.push(p.finish().unwrap());
            let got = arrow_select::concat::concat_batches(&p.schema(), &parts).unwrap();
            assert_eq!(got, whole, "chunks of {chunk}");
        }
        assert!(whole.num_rows() > 0);
    }

    #[test]
    fn finish_and_reset_start_a_new_stream_and_errors_name_the_key() {
        let (times, values) = frames(40, 24);
        let mut p = Pipeline::new("biotac-sp", "savgol", &table(""), Some(100.0), "ff").unwrap();
        let a = [p.push_frames(&times, &values).unwrap(), p.finish().unwrap()];
        let b = [p.push_frames(&times, &values).unwrap(), p.finish().unwrap()];
        assert_eq!(a, b);
        assert_eq!(a[0].num_rows() + a[1].num_rows(), 40);
        let e = Pipeline::new("biotac-sp", "savgol", &table("[savgol]\nwindw = 3\n"), None, "ff").err().unwrap();
        assert!(e.to_string().contains("windw"), "{e}");
        let e = p.push_frames(&times[..2], &values[..47]).unwrap_err();
        assert!(e.to_string().contains("shape (frames, 24)"), "{e}");
        let e = Pipeline::new("biotac-sp", "slip", &table(""), None, "ff").err().unwrap();
        assert!(e.to_string().contains("two sensors"), "{e}");
    }
}
