//! Arrow IPC sources: taxel frames from Arrow IPC files (`.arrow`, Feather v2) and streams,
//! and from any iterator of [`RecordBatch`](https://docs.rs/arrow-array/60/arrow_array/struct.RecordBatch.html)es (an in-memory table a host application hands
//! over).
//!
//! # Layouts
//! - **long** (the `frame/2` schema of `docs/schemas.md`, what the Parquet sink writes, and
//!   the older `frame/1`): one row per frame with columns
//!   - `sensor`: `Utf8`, `LargeUtf8`, `Utf8View` or a dictionary of `Utf8`;
//!   - `time` (`frame/2`: `Timestamp(Nanosecond)` or `Duration(Nanosecond)`) or `time_ns`
//!     (`frame/1`: `Int64`), the nanoseconds read as they are;
//!   - `seq` (optional): `UInt64` or non-negative `Int64`; without it frames are numbered
//!     from 0 per sensor;
//!   - `values`: `FixedSizeList<Float64>` (or `List`/`LargeList<Float64>`), the same length
//!     in every row.
//!
//!   Rows may mix sensors; `sensors = [...]` keeps some.
//! - **wide**: one row per frame of one sensor, one numeric column per taxel selected by name
//!   or pattern ([`ColumnSelector`], as for CSV: `columns = "ff_e{1..24}"`). Any integer or
//!   float column type is read as `f64` (64-bit integers beyond 2⁵³ round). Time from
//!   `time_column` (numeric in `time_unit`, or an Arrow `Timestamp` of any unit; must not
//!   decrease) or a fixed `rate_hz`; `seq` is the row index.
//!
//! Nulls and non-finite values are errors naming the file, batch and row.
//!
//! # Memory and copies
//! Batches are read one at a time (the IPC readers decode one record batch per step); values
//! are copied once, from the Arrow buffers into each frame's `Vec<f64>`.

use crate::csv_source::ColumnSelector;
use crate::{Error, Result, TimeUnit};
use arrow_array::cast::AsArray;
use arrow_array::types::*;
use arrow_array::{Array, ArrayRef, RecordBatch};
use arrow_schema::{ArrowError, DataType, TimeUnit as ArrowTimeUnit};
use gradtac_stream::{IteratorStageExt, SensorId, Stage, StageIter, TaxelFrame, Timestamp};
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// Which Arrow IPC framing a file uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum IpcFormat {
    /// Detect: the IPC *file* format starts with the magic `ARROW1`, anything else is read
    /// as a stream (`"auto"`).
    #[default]
    #[serde(rename = "auto")]
    Auto,
    /// The random-access file format (`.arrow`, Feather v2) (`"file"`).
    #[serde(rename = "file")]
    File,
    /// The streaming format (`.arrows`) (`"stream"`).
    #[serde(rename = "stream")]
    Stream,
}

/// A scene's Arrow IPC source.
///
/// ```toml
/// [sources.ff]
/// arrow = "frames.arrow"     # alias `path`
/// format = "auto"            # "auto" | "file" | "stream"
/// # long layout (sensor/time_ns/seq/values): optionally keep some sensors
/// sensors = ["ff"]
/// # wide layout instead: taxel columns, and a time column or a rate
/// # columns = "ff_e{1..24}"
/// # time_column = "t"
/// # time_unit = "s"
/// # rate_hz = 100.0
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArrowIpcConfig {
    /// The file.
    #[serde(rename = "arrow", alias = "path")]
    pub path: PathBuf,
    /// IPC framing.
    #[serde(default)]
    pub format: IpcFormat,
    /// Wide layout: the taxel columns in taxel order. Absent: the long layout.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub columns: Option<ColumnSelector>,
    /// Wide layout: the time column.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_column: Option<String>,
    /// Wide layout: unit of a numeric `time_column`.
    #[serde(default)]
    pub time_unit: TimeUnit,
    /// Wide layout: fixed rate (Hz) when there is no time column.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_hz: Option<f64>,
    /// Long layout: keep only rows of these sensors.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensors: Option<Vec<String>>,
}

impl ArrowIpcConfig {
    /// A long-layout source of `path`.
    pub fn long(path: impl Into<PathBuf>) -> Self {
        ArrowIpcConfig {
            path: path.into(),
            format: IpcFormat::Auto,
            columns: None,
            time_column: None,
            time_unit: TimeUnit::Seconds,
            rate_hz: None,
            sensors: None,
        }
    }

    /// A wide-layout source of `path` with these taxel columns; set the time with
    /// `time_column`/`time_unit` or `rate_hz`.
    pub fn wide(path: impl Into<PathBuf>, columns: ColumnSelector) -> Self {
        ArrowIpcConfig { columns: Some(columns), ..Self::long(path) }
    }

    /// The batch layout this config describes; wide frames belong to `sensor`.
    pub fn layout(&self, sensor: SensorId) -> Result<BatchLayout> {
        let bad = |s: String| Err(Error::InvalidConfig(format!("{}: {s}", self.path.display())));
        match &self.columns {
            None => {
                if self.time_column.is_some() || self.rate_hz.is_some() {
                    return bad(
                        "time_column / rate_hz apply to the wide layout (with `columns`); the long layout has time_ns"
                            .into(),
                    );
                }
                Ok(BatchLayout::Long { sensors: self.sensors.clone() })
            }
            Some(columns) => {
                if self.sensors.is_some() {
                    return bad("`sensors` filters the long layout; a wide layout is one sensor".into());
                }
                columns.validate()?;
                let time = match (&self.time_column, self.rate_hz) {
                    (Some(c), None) => WideTime::Column { name: c.clone(), unit: self.time_unit },
                    (None, Some(r)) => match Timestamp::check_rate_hz(r) {
                        Ok(()) => WideTime::Rate(r),
                        Err(e) => return bad(e),
                    },
                    (Some(_), Some(_)) => return bad("give either time_column or rate_hz, not both".into()),
                    (None, None) => return bad("the wide layout needs a time_column or a rate_hz".into()),
                };
                Ok(BatchLayout::Wide { sensor, columns: columns.clone(), time })
            }
        }
    }
}

/// How frames are laid out in record batches (see the [module docs](self)).
#[derive(Clone, Debug, PartialEq)]
pub enum BatchLayout {
    /// `sensor` / `time_ns` / `seq` / `values` rows; optionally only some sensors.
    Long {
        /// Sensors to keep (all when `None`).
        sensors: Option<Vec<String>>,
    },
    /// One numeric column per taxel.
    Wide {
        /// The sensor of every frame.
        sensor: SensorId,
        /// The taxel columns.
        columns: ColumnSelector,
        /// Where times come from.
        time: WideTime,
    },
}

/// Time of wide-layout rows.
#[derive(Clone, Debug, PartialEq)]
pub enum WideTime {
    /// A column in a unit (Arrow `Timestamp` columns carry their own unit).
    Column {
        /// Column name.
        name: String,
        /// Unit of a numeric column.
        unit: TimeUnit,
    },
    /// A fixed rate (Hz): row `k` at `round(k·10⁹/rate_hz)` ns.
    Rate(f64),
}

/// Column indices resolved on the first batch.
#[derive(Debug)]
enum Resolved {
    Long { sensor: usize, time: usize, seq: Option<usize>, values: usize, keep: Option<HashSet<String>> },
    Wide { sensor: SensorId, taxels: Vec<usize>, time: Option<usize>, rate: f64 },
}

/// Record batches → taxel frames, as a synchronous [`Stage`] (`In = RecordBatch`,
/// `Out = TaxelFrame`): the core of every Arrow source. Drive it over any iterator
/// ([`BatchFrames`], `IteratorStageExt::stage`) or any `Stream` of batches a host application
/// hands over (`StreamStageExt::stage`):
///
/// ```
/// use arrow_array::{ArrayRef, Float64Array, RecordBatch};
/// use futures::StreamExt;
/// use gradtac_io::arrow_ipc::{BatchDecoder, BatchLayout, WideTime};
/// use gradtac_io::ColumnSelector;
/// use gradtac_stream::{SensorId, StreamStageExt};
/// use std::sync::Arc;
///
/// let batch = RecordBatch::try_from_iter([
///     ("a", Arc::new(Float64Array::from(vec![1.0, 2.0])) as ArrayRef),
///     ("b", Arc::new(Float64Array::from(vec![3.0, 4.0])) as ArrayRef),
/// ])?;
/// let layout = BatchLayout::Wide {
///     sensor: SensorId::new("ff"),
///     columns: ColumnSelector::Names(vec!["a".into(), "b".into()]),
///     time: WideTime::Rate(100.0),
/// };
/// let batches = futures::stream::iter([Ok::<_, gradtac_io::Error>(batch)]);
/// let frames: Vec<_> = futures::executor::block_on(batches.stage(BatchDecoder::new("host", layout)).collect());
/// assert_eq!(frames[1].as_ref().unwrap().values, vec![2.0, 4.0]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
#[must_use = "a decoder does nothing until batches are pushed"]
pub struct BatchDecoder {
    origin: PathBuf,
    layout: BatchLayout,
    resolved: Option<Resolved>,
    batch_no: u64,
    rows: u64,
    taxels: Option<usize>,
    seqs: HashMap<SensorId, u64>,
    last_time: Option<i64>,
    /// Long layout: each sensor's last time (times must not decrease per sensor).
    long_times: HashMap<SensorId, i64>,
}

/// Taxel frames from an iterator of record batches (see the [module docs](self)): an
/// [`Iterator`] of `Result<TaxelFrame>` that stops after the first error. A batch that fails
/// to decode yields none of its frames; the frames of the batches before it are all yielded
/// first.
#[must_use = "iterators are lazy and do nothing unless consumed"]
pub struct BatchFrames<I> {
    /// The batches, their read errors tagged, driving the decoder.
    frames: StageIter<std::iter::Map<I, TagRead>, Decoding>,
}

/// A batch or the error reading it, tagged so [`BatchFrames`] can name the batch (which only
/// the decoder knows) when it yields the error.
type TagRead = fn(std::result::Result<RecordBatch, ArrowError>) -> std::result::Result<RecordBatch, Failed>;

/// Why [`BatchFrames`] stops: the batches could not be read, or a batch could not be decoded.
enum Failed {
    Read(ArrowError),
    Decode(Error),
}

impl From<Error> for Failed {
    fn from(e: Error) -> Self {
        Failed::Decode(e)
    }
}

/// [`BatchDecoder`] as [`BatchFrames`] drives it: `finish` does not reset it, so
/// [`BatchFrames::decoder`] still tells the taxel count after the last batch (the decoder
/// holds no frames back, so there is nothing to flush).
#[derive(Debug)]
struct Decoding(BatchDecoder);

impl Stage for Decoding {
    type In = RecordBatch;
    type Out = TaxelFrame;
    type Error = Error;

    fn push(&mut self, batch: RecordBatch, out: &mut Vec<TaxelFrame>) -> Result<()> {
        self.0.push(batch, out)
    }

    fn finish(&mut self, _out: &mut Vec<TaxelFrame>) -> Result<()> {
        Ok(())
    }

    fn reset(&mut self) {
        self.0.reset();
    }
}

impl<I> std::fmt::Debug for BatchFrames<I> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BatchFrames").field("decoder", &self.frames.stage_ref().0).finish_non_exhaustive()
    }
}

/// The batches of an IPC file or stream.
pub type IpcBatches = Box<dyn Iterator<Item = std::result::Result<RecordBatch, ArrowError>> + Send>;

/// Open the Arrow IPC source a scene describes; wide frames belong to `sensor`.
pub fn open(config: &ArrowIpcConfig, sensor: SensorId) -> Result<BatchFrames<IpcBatches>> {
    let layout = config.layout(sensor)?;
    let path = &config.path;
    let f = File::open(path).map_err(|source| Error::Io { path: path.clone(), source })?;
    open_reader(f, path, config.format, layout)
}

/// Frames from the Arrow IPC file or stream `reader` holds (a [`File`], or bytes in memory
/// through [`std::io::Cursor`]); `origin` names it in errors.
///
/// The metadata the arrow-ipc readers trust is checked first: every block of a file's
/// footer lies inside the file, every message's body inside the data, every buffer inside
/// its message's body (an error names the block or message). The readers then run with
/// their validation on (every array's buffers, offsets,
/// dictionary keys and UTF-8 are checked before use). A panic inside them on malformed
/// input (an upstream bug: they should return an error) is contained: it becomes an
/// [`Error::Arrow`] naming `origin` and the batch, and the reader is not used again (see
/// [`contain`](crate::contain)).
pub fn open_reader<R>(
    mut reader: R,
    origin: impl Into<PathBuf>,
    format: IpcFormat,
    layout: BatchLayout,
) -> Result<BatchFrames<IpcBatches>>
where
    R: Read + Seek + Send + 'static,
{
    let path: PathBuf = origin.into();
    let io = |source| Error::Io { path: path.clone(), source };
    let format = match format {
        IpcFormat::Auto => {
            let mut magic = [0u8; 6];
            let n = read_up_to(&mut reader, &mut magic).map_err(io)?;
            reader.seek(SeekFrom::Start(0)).map_err(io)?;
            if n == 6 && &magic == b"ARROW1" {
                IpcFormat::File
            } else {
                IpcFormat::Stream
            }
        }
        other => other,
    };
    // the metadata the readers would trust, checked first (see `ipc_check`)
    let len = reader.seek(SeekFrom::End(0)).map_err(io)?;
    reader.seek(SeekFrom::Start(0)).map_err(io)?;
    let checked = match format {
        IpcFormat::File => crate::ipc_check::check_file(&mut reader, len),
        _ => crate::ipc_check::check_stream(&mut reader, len),
    };
    checked.map_err(|reason| Error::Arrow { context: format!("{}: reading Arrow IPC", path.display()), reason })?;
    reader.seek(SeekFrom::Start(0)).map_err(io)?;
    let batches: IpcBatches = match format {
        IpcFormat::File => {
            let r = reader_call(&path, || arrow_ipc::reader::FileReader::try_new_buffered(reader, None))?;
            Box::new(Contained(Some(r)))
        }
        _ => {
            let r = reader_call(&path, || arrow_ipc::reader::StreamReader::try_new(BufReader::new(reader), None))?;
            Box::new(Contained(Some(r)))
        }
    };
    Ok(BatchFrames::new(batches, path, layout))
}

/// Fill `buf` as far as `reader` allows; the number of bytes read.
fn read_up_to(reader: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match reader.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

/// Open an IPC reader (it reads the schema, and for the file format the footer), its
/// errors and contained panics named after `path`.
fn reader_call<T>(path: &Path, open: impl FnOnce() -> std::result::Result<T, ArrowError>) -> Result<T> {
    let fail = |reason: String| Error::Arrow { context: format!("{}: reading Arrow IPC", path.display()), reason };
    match crate::contain::contain(open) {
        Ok(Ok(r)) => Ok(r),
        Ok(Err(e)) => Err(fail(one_line(&e.to_string()))),
        Err(panic) => Err(fail(format!("malformed IPC data (the arrow-ipc reader panicked: {})", one_line(&panic)))),
    }
}

/// A dependency's message on one line (arrow's flatbuffer verifier reports over 4–7 lines).
fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// An IPC batch reader whose panics are contained: a panic ends the iteration with one
/// error (the decoder names the batch).
struct Contained<I>(Option<I>);

impl<I> Iterator for Contained<I>
where
    I: Iterator<Item = std::result::Result<RecordBatch, ArrowError>>,
{
    type Item = std::result::Result<RecordBatch, ArrowError>;

    fn next(&mut self) -> Option<Self::Item> {
        let inner = self.0.as_mut()?;
        match crate::contain::contain(|| inner.next()) {
            Ok(item) => item,
            Err(panic) => {
                self.0 = None;
                Some(Err(ArrowError::IpcError(format!("malformed IPC data (the arrow-ipc reader panicked: {panic})"))))
            }
        }
    }
}

impl<I> BatchFrames<I>
where
    I: Iterator<Item = std::result::Result<RecordBatch, ArrowError>>,
{
    /// Frames from `batches`; `origin` names the source in errors.
    pub fn new(batches: I, origin: impl Into<PathBuf>, layout: BatchLayout) -> Self {
        let tag: TagRead = |r| r.map_err(Failed::Read);
        BatchFrames { frames: batches.map(tag).stage(Decoding(BatchDecoder::new(origin, layout))) }
    }

    /// The decoder (rows read, taxel count).
    pub fn decoder(&self) -> &BatchDecoder {
        &self.frames.stage_ref().0
    }
}

impl BatchDecoder {
    /// A decoder for batches of `layout`; `origin` names the source in errors.
    pub fn new(origin: impl Into<PathBuf>, layout: BatchLayout) -> Self {
        BatchDecoder {
            origin: origin.into(),
            layout,
            resolved: None,
            batch_no: 0,
            rows: 0,
            taxels: None,
            seqs: HashMap::new(),
            last_time: None,
            long_times: HashMap::new(),
        }
    }

    /// Rows read so far.
    pub fn rows_read(&self) -> u64 {
        self.rows
    }

    /// The taxel count, once the first frame was read.
    pub fn taxel_count(&self) -> Option<usize> {
        self.taxels
    }

    fn err(&self, row: Option<usize>, reason: impl Into<String>) -> Error {
        let at = match row {
            Some(r) => format!("batch {} row {r} (row {} of the source)", self.batch_no, self.rows + r as u64),
            None => format!("batch {}", self.batch_no),
        };
        Error::Arrow { context: format!("{}: {at}", self.origin.display()), reason: reason.into() }
    }

    fn resolve(&self, batch: &RecordBatch) -> Result<Resolved> {
        let schema = batch.schema();
        let names: Vec<String> = schema.fields().iter().map(|f| f.name().clone()).collect();
        let find = |n: &str| names.iter().position(|x| x == n);
        match &self.layout {
            BatchLayout::Long { sensors } => {
                let need = |n: &str| {
                    find(n).ok_or_else(|| {
                        self.err(
                            None,
                            format!(
                                "no column {n:?} (long layout needs sensor, time (or time_ns), values; columns: {})",
                                names.join(", ")
                            ),
                        )
                    })
                };
                Ok(Resolved::Long {
                    sensor: need("sensor")?,
                    time: find("time").map_or_else(|| need("time_ns"), Ok)?,
                    seq: find("seq"),
                    values: need("values")?,
                    keep: sensors.as_ref().map(|s| s.iter().cloned().collect()),
                })
            }
            BatchLayout::Wide { sensor, columns, time } => {
                let time_idx = match time {
                    WideTime::Column { name, .. } => Some(find(name).ok_or_else(|| {
                        self.err(None, format!("no time column {name:?} (columns: {})", names.join(", ")))
                    })?),
                    WideTime::Rate(_) => None,
                };
                let taxels = columns.resolve_excluding(&names, &self.origin, time_idx)?;
                let rate = if let WideTime::Rate(r) = time { *r } else { 1.0 };
                Ok(Resolved::Wide { sensor: sensor.clone(), taxels, time: time_idx, rate })
            }
        }
    }

    fn decode(&mut self, batch: &RecordBatch, out: &mut Vec<TaxelFrame>) -> Result<()> {
        let resolved = match self.resolved.take() {
            Some(r) => r,
            None => self.resolve(batch)?,
        };
        let r = self.decode_with(&resolved, batch, out);
        self.resolved = Some(resolved);
        r
    }

    fn decode_with(&mut self, resolved: &Resolved, batch: &RecordBatch, out: &mut Vec<TaxelFrame>) -> Result<()> {
        let n = batch.num_rows();
        match resolved {
            Resolved::Long { sensor, time, seq, values, keep } => {
                let (sensor, time, seq, values) = (*sensor, *time, *seq, *values);
                let names = strings(batch.column(sensor)).map_err(|r| self.err(None, format!("column sensor: {r}")))?;
                // errors name the time column by its name in the file (`time` in frame/2)
                let time_name = batch.schema().field(time).name().clone();
                let times = i64s(batch.column(time), &time_name).map_err(|r| self.err(None, r))?;
                let seqs = seq
                    .map(|s| u64s(batch.column(s)))
                    .transpose()
                    .map_err(|r| self.err(None, format!("column seq: {r}")))?;
                let vals = lists(batch.column(values)).map_err(|r| self.err(None, format!("column values: {r}")))?;
                for r in 0..n {
                    let name = names.get(r).ok_or_else(|| self.err(Some(r), "sensor is null"))?;
                    if keep.as_ref().is_some_and(|k| !k.contains(&name)) {
                        continue;
                    }
                    let t = times.get(r).ok_or_else(|| self.err(Some(r), format!("{time_name} is null")))?;
                    let v = vals.row(r).map_err(|e| self.err(Some(r), format!("values: {e}")))?;
                    self.check_values(r, &v)?;
                    let id = SensorId::new(name);
                    match self.long_times.insert(id.clone(), t) {
                        Some(prev) if t < prev => {
                            let reason =
                                format!("sensor {id}: {time_name} {t} is earlier than its row before ({prev} ns)");
                            return Err(self.err(Some(r), reason));
                        }
                        _ => {}
                    }
                    let s = match &seqs {
                        Some(s) => s.get(r).ok_or_else(|| self.err(Some(r), "seq is null or negative"))?,
                        None => self.seqs.get(&id).copied().unwrap_or(0),
                    };
                    self.seqs.insert(id.clone(), s.saturating_add(1));
                    out.push(TaxelFrame::new(id, Timestamp(t), s, v));
                }
            }
            Resolved::Wide { sensor, taxels, time, rate } => {
                let (sensor, rate) = (sensor.clone(), *rate);
                let cols: Vec<F64Col<'_>> = taxels
                    .iter()
                    .map(|&c| {
                        f64s(batch.column(c))
                            .map_err(|r| self.err(None, format!("column {:?}: {r}", batch.schema().field(c).name())))
                    })
                    .collect::<Result<_>>()?;
                let unit = match &self.layout {
                    BatchLayout::Wide { time: WideTime::Column { unit, .. }, .. } => *unit,
                    _ => TimeUnit::Seconds,
                };
                let times = time
                    .map(|c| time_col(batch.column(c), unit))
                    .transpose()
                    .map_err(|r| self.err(None, format!("time column: {r}")))?;
                for r in 0..n {
                    let v: Vec<f64> = cols
                        .iter()
                        .enumerate()
                        .map(|(j, c)| c.get(r).ok_or_else(|| self.err(Some(r), format!("taxel {j} is null"))))
                        .collect::<Result<_>>()?;
                    self.check_values(r, &v)?;
                    let k = self.rows + r as u64;
                    let t = match &times {
                        None => Timestamp::at_rate(k, rate),
                        Some(tc) => {
                            let ns = tc.get(r).map_err(|e| self.err(Some(r), format!("time: {e}")))?;
                            if let Some(prev) = self.last_time {
                                if ns < prev {
                                    return Err(self.err(
                                        Some(r),
                                        format!("time {ns} ns is earlier than the row before ({prev} ns)"),
                                    ));
                                }
                            }
                            self.last_time = Some(ns);
                            Timestamp(ns)
                        }
                    };
                    out.push(TaxelFrame::new(sensor.clone(), t, k, v));
                }
            }
        }
        self.rows += n as u64;
        self.batch_no += 1;
        Ok(())
    }

    fn check_values(&mut self, r: usize, v: &[f64]) -> Result<()> {
        if v.is_empty() {
            return Err(self.err(Some(r), "a frame with no taxels"));
        }
        match self.taxels {
            None => self.taxels = Some(v.len()),
            Some(t) if t != v.len() => {
                return Err(self.err(Some(r), format!("{} taxels; earlier frames have {t}", v.len())));
            }
            _ => {}
        }
        if let Some(j) = v.iter().position(|x| !x.is_finite()) {
            return Err(self.err(Some(r), format!("taxel {j}: value {} is not finite", v[j])));
        }
        Ok(())
    }
}

impl<I> Iterator for BatchFrames<I>
where
    I: Iterator<Item = std::result::Result<RecordBatch, ArrowError>>,
{
    type Item = Result<TaxelFrame>;

    fn next(&mut self) -> Option<Result<TaxelFrame>> {
        Some(self.frames.next()?.map_err(|e| match e {
            // named after the batches decoded so far, as the decoder's own errors
            Failed::Read(e) => self.frames.stage_ref().0.err(None, one_line(&e.to_string())),
            Failed::Decode(e) => e,
        }))
    }
}

impl Stage for BatchDecoder {
    type In = RecordBatch;
    type Out = TaxelFrame;
    type Error = Error;

    /// Decode one batch; on `Err` (a bad row) the frames of that batch are not emitted.
    fn push(&mut self, batch: RecordBatch, out: &mut Vec<TaxelFrame>) -> Result<()> {
        // not `num_rows()`: a batch header may claim billions of rows that no column holds
        let mut buf = Vec::with_capacity(batch.num_rows().min(4096));
        self.decode(&batch, &mut buf)?;
        out.append(&mut buf);
        Ok(())
    }

    /// Forget the resolved columns, taxel count, `seq` counters and the last time (a new
    /// table may follow); the row and batch counts keep counting.
    fn reset(&mut self) {
        self.resolved = None;
        self.taxels = None;
        self.seqs.clear();
        self.last_time = None;
        self.long_times.clear();
    }
}

// ---- column access --------------------------------------------------------------------------

/// The most entries a dictionary-encoded `sensor` column may hold (distinct sensor names).
pub const MAX_SENSOR_DICTIONARY: usize = 65_536;

/// A string column of any Arrow string type.
enum StrCol<'a> {
    Utf8(&'a arrow_array::StringArray),
    Large(&'a arrow_array::LargeStringArray),
    View(&'a arrow_array::StringViewArray),
    Dict { keys: Vec<usize>, array: &'a dyn Array, values: Box<StrCol<'a>> },
}

impl StrCol<'_> {
    fn get(&self, r: usize) -> Option<String> {
        match self {
            StrCol::Utf8(a) => a.is_valid(r).then(|| a.value(r).to_string()),
            StrCol::Large(a) => a.is_valid(r).then(|| a.value(r).to_string()),
            StrCol::View(a) => a.is_valid(r).then(|| a.value(r).to_string()),
            StrCol::Dict { keys, array, values } => {
                if array.is_null(r) {
                    return None;
                }
                values.get(*keys.get(r)?)
            }
        }
    }
}

fn strings(a: &ArrayRef) -> std::result::Result<StrCol<'_>, String> {
    str_col(a.as_ref())
}

fn str_col(a: &dyn Array) -> std::result::Result<StrCol<'_>, String> {
    if let Some(s) = a.as_string_opt::<i32>() {
        Ok(StrCol::Utf8(s))
    } else if let Some(s) = a.as_string_opt::<i64>() {
        Ok(StrCol::Large(s))
    } else if let Some(s) = a.as_string_view_opt() {
        Ok(StrCol::View(s))
    } else if let Some(d) = a.as_any_dictionary_opt() {
        let n = d.values().len();
        if n > MAX_SENSOR_DICTIONARY {
            return Err(format!("a dictionary of {n} sensor names (at most {MAX_SENSOR_DICTIONARY})"));
        }
        let values = Box::new(str_col(d.values().as_ref())?);
        // `normalized_keys` asserts a non-empty dictionary; with an empty one (a zero-row
        // batch, or every key null: validation rejects a valid key into it) no key is read.
        let keys = if n == 0 { Vec::new() } else { d.normalized_keys() };
        Ok(StrCol::Dict { keys, array: a, values })
    } else {
        Err(format!("type {} is not a string type", a.data_type()))
    }
}

/// An `Int64` or `Timestamp(ns)` column.
struct I64Col<'a>(&'a [i64], &'a dyn Array);

impl I64Col<'_> {
    fn get(&self, r: usize) -> Option<i64> {
        self.1.is_valid(r).then(|| self.0[r])
    }
}

fn i64s<'a>(a: &'a ArrayRef, name: &str) -> std::result::Result<I64Col<'a>, String> {
    if let Some(p) = a.as_primitive_opt::<Int64Type>() {
        Ok(I64Col(p.values(), p))
    } else if let Some(p) = a.as_primitive_opt::<TimestampNanosecondType>() {
        Ok(I64Col(p.values(), p))
    } else if let Some(p) = a.as_primitive_opt::<arrow_array::types::DurationNanosecondType>() {
        Ok(I64Col(p.values(), p))
    } else {
        Err(format!("column {name}: type {} (expected Int64, Timestamp(ns) or Duration(ns))", a.data_type()))
    }
}

/// A `UInt64` or `Int64` (non-negative) column.
enum U64Col<'a> {
    U(&'a arrow_array::UInt64Array),
    I(&'a arrow_array::Int64Array),
}

impl U64Col<'_> {
    fn get(&self, r: usize) -> Option<u64> {
        match self {
            U64Col::U(a) => a.is_valid(r).then(|| a.value(r)),
            U64Col::I(a) => a.is_valid(r).then(|| a.value(r)).and_then(|v| u64::try_from(v).ok()),
        }
    }
}

fn u64s(a: &ArrayRef) -> std::result::Result<U64Col<'_>, String> {
    if let Some(p) = a.as_primitive_opt::<UInt64Type>() {
        Ok(U64Col::U(p))
    } else if let Some(p) = a.as_primitive_opt::<Int64Type>() {
        Ok(U64Col::I(p))
    } else {
        Err(format!("type {} (expected UInt64 or Int64)", a.data_type()))
    }
}

/// A list-of-Float64 column.
struct ListCol<'a> {
    list: &'a dyn Array,
    offsets: Vec<usize>,
    child: &'a arrow_array::Float64Array,
}

impl ListCol<'_> {
    fn row(&self, r: usize) -> std::result::Result<Vec<f64>, String> {
        if self.list.is_null(r) {
            return Err("null list".into());
        }
        let (a, b) = (self.offsets[r], self.offsets[r + 1]);
        if self.child.null_count() > 0 && (a..b).any(|i| self.child.is_null(i)) {
            return Err("null value in the list".into());
        }
        Ok(self.child.values()[a..b].to_vec())
    }
}

fn lists(a: &ArrayRef) -> std::result::Result<ListCol<'_>, String> {
    if let Some(l) = a.as_fixed_size_list_opt() {
        let n = l.value_length() as usize;
        let child = l
            .values()
            .as_primitive_opt::<Float64Type>()
            .ok_or_else(|| format!("list items of type {} (expected Float64)", l.values().data_type()))?;
        let offsets = (0..=l.len()).map(|i| i * n).collect();
        Ok(ListCol { list: l, offsets, child })
    } else if let Some(l) = a.as_list_opt::<i32>() {
        let child = l
            .values()
            .as_primitive_opt::<Float64Type>()
            .ok_or_else(|| format!("list items of type {} (expected Float64)", l.values().data_type()))?;
        Ok(ListCol { list: l, offsets: l.value_offsets().iter().map(|&o| o as usize).collect(), child })
    } else if let Some(l) = a.as_list_opt::<i64>() {
        let child = l
            .values()
            .as_primitive_opt::<Float64Type>()
            .ok_or_else(|| format!("list items of type {} (expected Float64)", l.values().data_type()))?;
        Ok(ListCol { list: l, offsets: l.value_offsets().iter().map(|&o| o as usize).collect(), child })
    } else {
        Err(format!("type {} (expected FixedSizeList<Float64>, List<Float64> or LargeList<Float64>)", a.data_type()))
    }
}

/// A numeric column read as f64.
struct F64Col<'a> {
    array: &'a dyn Array,
    get: fn(&dyn Array, usize) -> f64,
}

impl F64Col<'_> {
    fn get(&self, r: usize) -> Option<f64> {
        self.array.is_valid(r).then(|| (self.get)(self.array, r))
    }
}

fn f64s(a: &ArrayRef) -> std::result::Result<F64Col<'_>, String> {
    macro_rules! num {
        ($t:ty) => {
            |a: &dyn Array, r: usize| a.as_primitive::<$t>().value(r) as f64
        };
    }
    let get: fn(&dyn Array, usize) -> f64 = match a.data_type() {
        DataType::Float64 => num!(Float64Type),
        DataType::Float32 => num!(Float32Type),
        DataType::Int8 => num!(Int8Type),
        DataType::Int16 => num!(Int16Type),
        DataType::Int32 => num!(Int32Type),
        DataType::Int64 => num!(Int64Type),
        DataType::UInt8 => num!(UInt8Type),
        DataType::UInt16 => num!(UInt16Type),
        DataType::UInt32 => num!(UInt32Type),
        DataType::UInt64 => num!(UInt64Type),
        other => return Err(format!("type {other} is not numeric")),
    };
    Ok(F64Col { array: a.as_ref(), get })
}

/// A time column converted to ns.
struct TimeCol<'a> {
    array: &'a dyn Array,
    kind: TimeKind,
}

enum TimeKind {
    Int(TimeUnit),
    Float(TimeUnit),
}

impl TimeCol<'_> {
    fn get(&self, r: usize) -> std::result::Result<i64, String> {
        if self.array.is_null(r) {
            return Err("null".into());
        }
        let a = self.array;
        match self.kind {
            TimeKind::Int(unit) => {
                let v: i128 = match a.data_type() {
                    DataType::Int64 | DataType::Timestamp(..) => i128::from(int64_value(a, r)),
                    DataType::Int32 => i128::from(a.as_primitive::<Int32Type>().value(r)),
                    DataType::UInt32 => i128::from(a.as_primitive::<UInt32Type>().value(r)),
                    DataType::UInt64 => i128::from(a.as_primitive::<UInt64Type>().value(r)),
                    _ => return Err("unsupported".into()),
                };
                unit.int_to_nanos(v).ok_or_else(|| format!("{v} does not fit i64 nanoseconds"))
            }
            TimeKind::Float(unit) => {
                let x = match a.data_type() {
                    DataType::Float32 => f64::from(a.as_primitive::<Float32Type>().value(r)),
                    _ => a.as_primitive::<Float64Type>().value(r),
                };
                unit.float_to_nanos(x).ok_or_else(|| format!("{x} is not finite or does not fit i64 nanoseconds"))
            }
        }
    }
}

fn int64_value(a: &dyn Array, r: usize) -> i64 {
    match a.data_type() {
        DataType::Timestamp(ArrowTimeUnit::Second, _) => a.as_primitive::<TimestampSecondType>().value(r),
        DataType::Timestamp(ArrowTimeUnit::Millisecond, _) => a.as_primitive::<TimestampMillisecondType>().value(r),
        DataType::Timestamp(ArrowTimeUnit::Microsecond, _) => a.as_primitive::<TimestampMicrosecondType>().value(r),
        DataType::Timestamp(ArrowTimeUnit::Nanosecond, _) => a.as_primitive::<TimestampNanosecondType>().value(r),
        _ => a.as_primitive::<Int64Type>().value(r),
    }
}

fn time_col(a: &ArrayRef, unit: TimeUnit) -> std::result::Result<TimeCol<'_>, String> {
    let kind = match a.data_type() {
        // an Arrow timestamp carries its own unit
        DataType::Timestamp(u, _) => TimeKind::Int(match u {
            ArrowTimeUnit::Second => TimeUnit::Seconds,
            ArrowTimeUnit::Millisecond => TimeUnit::Milliseconds,
            ArrowTimeUnit::Microsecond => TimeUnit::Microseconds,
            ArrowTimeUnit::Nanosecond => TimeUnit::Nanoseconds,
        }),
        DataType::Int64 | DataType::Int32 | DataType::UInt32 | DataType::UInt64 => TimeKind::Int(unit),
        DataType::Float64 | DataType::Float32 => TimeKind::Float(unit),
        other => return Err(format!("type {other} is not a time (use an integer, float or Timestamp column)")),
    };
    Ok(TimeCol { array: a.as_ref(), kind })
}

/// Read an Arrow IPC file's schema without reading its batches (for `gradtac explain`).
pub fn ipc_schema(path: &Path) -> Result<arrow_schema::SchemaRef> {
    let io = |source| Error::Io { path: path.to_owned(), source };
    let mut f = File::open(path).map_err(io)?;
    // the reader reads the footer and the dictionaries: their metadata checked first
    let len = f.seek(SeekFrom::End(0)).map_err(io)?;
    f.seek(SeekFrom::Start(0)).map_err(io)?;
    crate::ipc_check::check_file(&mut f, len)
        .map_err(|reason| Error::Arrow { context: format!("{}: reading Arrow IPC", path.display()), reason })?;
    f.seek(SeekFrom::Start(0)).map_err(io)?;
    let r = reader_call(path, || arrow_ipc::reader::FileReader::try_new_buffered(f, None))?;
    Ok(r.schema())
}
