//! The outputs of a run: one Parquet sink per scene output, typed by the stage it taps.
//!
//! Every file encodes, compresses and writes on a thread of its own
//! ([`ParquetSink::with_writer_thread`]): the runner's thread only appends rows and hands
//! over finished batches, so closing a row group (milliseconds of zstd) never stalls the
//! frames of a live run, and a file run overlaps encoding with the chains on a second core.
//! The exception is an archive rolled by bytes (`roll_bytes`), which encodes on the runner's
//! thread so that its size estimate counts every batch and its files overshoot the limit by
//! at most one batch.

use crate::memory::MemoryOutputs;
use crate::plan::{Plan, Tap};
use crate::scene::{OutputSpec, Scene, SourceSpec};
use crate::Error;
use gradtac_io::archive::{ParquetArchive, RecordSink};
use gradtac_io::records::{DosShape, SlipShape, SurfaceShape};
use gradtac_io::{ArrowRecord, FrameShape, ParquetSink, TimeBase};
use gradtac_stages::contour::ContourFrame;
use gradtac_stages::dos::DosDecision;
use gradtac_stages::force::ForceEstimate;
use gradtac_stages::interpolate::{Grid, Surface};
use gradtac_stages::servo::ServoCommand;
use gradtac_stages::slip::SlipEvent;
use gradtac_stages::track::TrackPoint;
use gradtac_stages::window::WindowAggregate;
use gradtac_stages::EventBatch;
use gradtac_stream::{HasSensor, Layout, TaxelFrame, Timed};
use std::path::{Path, PathBuf};

/// A sink of one output; one variant per output type (schemas in `docs/schemas.md`).
///
/// Each holds a single file ([`ParquetSink`]) or an archive directory ([`ParquetArchive`]:
/// rolling files, optional hive partitioning by sensor) behind [`RecordSink`].
pub enum OutputSink {
    /// Frames (`source`, `normalise`, `savgol` taps), `frame/2`.
    Frames(Box<dyn RecordSink<TaxelFrame>>),
    /// Events, one row per event, `event/2`.
    Events(Box<dyn RecordSink<EventBatch>>),
    /// Window aggregates, `window/2`.
    Windows(Box<dyn RecordSink<WindowAggregate>>),
    /// Surfaces, `surface/2`.
    Surfaces(Box<dyn RecordSink<Surface>>),
    /// Maximal contours, `contour/2`.
    Contours(Box<dyn RecordSink<ContourFrame>>),
    /// Track points, `track/3`.
    Tracks(Box<dyn RecordSink<TrackPoint>>),
    /// Force estimates, `force/2`.
    Forces(Box<dyn RecordSink<ForceEstimate>>),
    /// Servo commands, `servo/2`.
    Servo(Box<dyn RecordSink<ServoCommand>>),
    /// Two-finger slip events, `slip/2` (always one file: the events belong to a pair).
    Slip(Box<dyn RecordSink<SlipEvent>>),
    /// One-fingertip slip-direction decisions, `dos/3`.
    Dos(Box<dyn RecordSink<DosDecision>>),
}

/// An output type the runner can write: finds its own sink among the variants.
pub trait Record: ArrowRecord + Clone + Send + 'static {
    /// The typed sink, when `s` writes this type.
    fn sink(s: &mut OutputSink) -> Option<&mut Box<dyn RecordSink<Self>>>;
    /// The records as [`Rows`] (copied), for a [`Collected`] buffer.
    fn rows(records: &[Self]) -> Rows;
    /// Offer records of `tap` to the rerun view (feature `view`).
    #[cfg(feature = "view")]
    fn view(v: &crate::view::ViewHandle, tap: Tap, records: &[Self]);
}

/// Records of one output type, owned: what a [`Collected`] buffer holds per write.
#[derive(Clone, Debug)]
#[allow(missing_docs)] // one variant per output type, named as in [`OutputSink`]
pub enum Rows {
    Frames(Vec<TaxelFrame>),
    Events(Vec<EventBatch>),
    Windows(Vec<WindowAggregate>),
    Surfaces(Vec<Surface>),
    Contours(Vec<ContourFrame>),
    Tracks(Vec<TrackPoint>),
    Forces(Vec<ForceEstimate>),
    Servo(Vec<ServoCommand>),
    Slip(Vec<SlipEvent>),
    Dos(Vec<DosDecision>),
}

macro_rules! record {
    ($t:ty, $variant:ident) => {
        impl Record for $t {
            fn sink(s: &mut OutputSink) -> Option<&mut Box<dyn RecordSink<Self>>> {
                match s {
                    OutputSink::$variant(s) => Some(s),
                    _ => None,
                }
            }
            fn rows(records: &[Self]) -> Rows {
                Rows::$variant(records.to_vec())
            }
            #[cfg(feature = "view")]
            fn view(v: &crate::view::ViewHandle, tap: Tap, records: &[Self]) {
                v.log_frames(crate::view::FrameKind::of_tap(tap), records)
            }
        }
    };
}
record!(TaxelFrame, Frames);
record!(EventBatch, Events);
record!(WindowAggregate, Windows);
record!(Surface, Surfaces);
record!(ContourFrame, Contours);
record!(TrackPoint, Tracks);
record!(ForceEstimate, Forces);
record!(ServoCommand, Servo);
record!(SlipEvent, Slip);
record!(DosDecision, Dos);

macro_rules! each_sink {
    ($s:expr, $v:ident => $e:expr) => {
        match $s {
            OutputSink::Frames($v) => $e,
            OutputSink::Events($v) => $e,
            OutputSink::Windows($v) => $e,
            OutputSink::Surfaces($v) => $e,
            OutputSink::Contours($v) => $e,
            OutputSink::Tracks($v) => $e,
            OutputSink::Forces($v) => $e,
            OutputSink::Servo($v) => $e,
            OutputSink::Slip($v) => $e,
            OutputSink::Dos($v) => $e,
        }
    };
}

impl OutputSink {
    fn rows(&self) -> u64 {
        each_sink!(self, s => s.rows())
    }
    fn finish(self) -> Result<Vec<PathBuf>, Error> {
        each_sink!(self, s => Ok(s.finish()?))
    }
    fn abort(self) -> Result<Vec<PathBuf>, Error> {
        each_sink!(self, s => Ok(s.abort()?))
    }
    fn set_metadata(&mut self, k: String, v: String) {
        each_sink!(self, s => s.set_metadata(k, v))
    }
}

/// Where a sensor's chain writes its records: the [`Sinks`] themselves (one thread), or a
/// [`Collected`] buffer that a chain on a thread of its own fills and the runner's thread
/// replays into the sinks in the frames' order (so the files are the same byte for byte).
pub trait RecordWriter {
    /// Write `records` to each output in `outputs` (indices into the scene's outputs).
    fn write_all<T: Record>(&mut self, outputs: &[usize], records: &[T]) -> Result<(), Error>;

    /// Raw frames no output taps, for a view (nothing by default: only [`Sinks`] holds one,
    /// and a run with a view runs its chains serially into the sinks).
    fn view_source(&self, _outputs: &[usize], _frames: &[TaxelFrame]) {}
}

impl RecordWriter for Sinks {
    fn write_all<T: Record>(&mut self, outputs: &[usize], records: &[T]) -> Result<(), Error> {
        Sinks::write_all(self, outputs, records)
    }

    fn view_source(&self, outputs: &[usize], frames: &[TaxelFrame]) {
        Sinks::view_source(self, outputs, frames)
    }
}

/// Writes recorded in order, to be [replayed](Collected::replay) into the sinks later.
#[derive(Clone, Debug, Default)]
pub struct Collected {
    /// The output indices of every write, one after the other.
    outputs: Vec<usize>,
    /// Per write: its range in `outputs` and its records.
    writes: Vec<(usize, usize, Rows)>,
}

impl RecordWriter for Collected {
    fn write_all<T: Record>(&mut self, outputs: &[usize], records: &[T]) -> Result<(), Error> {
        if !outputs.is_empty() && !records.is_empty() {
            let start = self.outputs.len();
            self.outputs.extend_from_slice(outputs);
            self.writes.push((start, self.outputs.len(), T::rows(records)));
        }
        Ok(())
    }
}

impl Collected {
    /// True when nothing was written.
    pub fn is_empty(&self) -> bool {
        self.writes.is_empty()
    }

    /// The number of writes recorded (a mark for [`replay_range`](Self::replay_range)).
    pub fn len(&self) -> usize {
        self.writes.len()
    }

    /// Write the writes `range` (marks from [`len`](Self::len)) into `sinks`, in order.
    pub fn replay_range(&self, range: std::ops::Range<usize>, sinks: &mut Sinks) -> Result<(), Error> {
        for (start, end, rows) in &self.writes[range] {
            let outputs = &self.outputs[*start..*end];
            match rows {
                Rows::Frames(r) => sinks.write_all(outputs, r)?,
                Rows::Events(r) => sinks.write_all(outputs, r)?,
                Rows::Windows(r) => sinks.write_all(outputs, r)?,
                Rows::Surfaces(r) => sinks.write_all(outputs, r)?,
                Rows::Contours(r) => sinks.write_all(outputs, r)?,
                Rows::Tracks(r) => sinks.write_all(outputs, r)?,
                Rows::Forces(r) => sinks.write_all(outputs, r)?,
                Rows::Servo(r) => sinks.write_all(outputs, r)?,
                Rows::Slip(r) => sinks.write_all(outputs, r)?,
                Rows::Dos(r) => sinks.write_all(outputs, r)?,
            }
        }
        Ok(())
    }

    /// Write everything recorded into `sinks`, in the order it was written (emptying the buffer).
    pub fn replay(&mut self, sinks: &mut Sinks) -> Result<(), Error> {
        let all = self.replay_range(0..self.writes.len(), sinks);
        self.outputs.clear();
        self.writes.clear();
        all
    }
}

/// Every output of a run, open as `<path>.partial` until [`Sinks::finish`].
pub struct Sinks {
    sinks: Vec<Option<OutputSink>>,
    /// The tap of each output (read by the view).
    #[cfg_attr(not(feature = "view"), allow(dead_code))]
    taps: Vec<Tap>,
    /// The rerun view every written record is offered to (feature `view`).
    #[cfg(feature = "view")]
    view: Option<crate::view::ViewHandle>,
}

impl Sinks {
    /// Open every output of the scene. Outputs shared by several sensors need layouts of one size.
    pub fn open(scene: &Scene, plan: &Plan) -> Result<Sinks, Error> {
        Sinks::open_in(scene, plan, None)
    }

    /// [`Sinks::open`], every output in `memory` (and nothing on disk) when given.
    pub fn open_in(scene: &Scene, plan: &Plan, memory: Option<&MemoryOutputs>) -> Result<Sinks, Error> {
        let mut sinks = Vec::new();
        let mut taps = Vec::new();
        for (i, o) in scene.outputs.iter().enumerate() {
            let dest = Dest { memory, output: i };
            let tap = Tap::parse(&o.tap).expect("validated by Scene");
            taps.push(tap);
            let users: Vec<&Layout> =
                plan.sensors.iter().filter(|p| p.outputs.contains(&i)).map(|p| &p.layout).collect();
            let bad = |reason: String| Error::Scene { path: scene.origin.clone(), reason };
            let Some(&layout) = users.first() else {
                return Err(bad(format!("output #{} covers no sensor", i + 1)));
            };
            if let Some(other) = users.iter().find(|l| l.len() != layout.len()) {
                return Err(bad(format!(
                    "output #{} mixes layouts of {} and {} taxels; give each its own output (sensors = [...])",
                    i + 1,
                    layout.len(),
                    other.len()
                )));
            }
            let path = scene.resolve(&o.path);
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty() && memory.is_none()) {
                std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.to_path_buf(), source })?;
            }
            let taxels = FrameShape::from_layout(layout);
            let names: Vec<&str> =
                plan.sensors.iter().filter(|p| p.outputs.contains(&i)).map(|p| p.name.as_str()).collect();
            let time = time_base(scene, &names);
            let mut sink = match tap {
                Tap::Source | Tap::Normalise | Tap::Savgol => OutputSink::Frames(open(&path, taxels, o, time, dest)?),
                Tap::Events => OutputSink::Events(open(&path, taxels, o, time, dest)?),
                Tap::Window => OutputSink::Windows(open(&path, taxels, o, time, dest)?),
                Tap::Surface => {
                    let grid = scene.stages.resolved().surface.grid;
                    let grids = users.iter().map(|l| Grid::from_config(&grid, l)).collect::<Result<Vec<_>, _>>()?;
                    if grids.iter().any(|g| g != &grids[0]) {
                        return Err(bad(format!(
                            "output #{}: the sensors' layouts give different surface grids; give each its own output",
                            i + 1
                        )));
                    }
                    OutputSink::Surfaces(open(&path, SurfaceShape::new(grids[0].clone()), o, time, dest)?)
                }
                Tap::Contour => OutputSink::Contours(open(&path, (), o, time, dest)?),
                Tap::Track => OutputSink::Tracks(open(&path, (), o, time, dest)?),
                Tap::Force => OutputSink::Forces(open(&path, (), o, time, dest)?),
                Tap::Servo => OutputSink::Servo(open(&path, (), o, time, dest)?),
                Tap::Dos => {
                    let d =
                        scene.stages.dos.as_ref().ok_or_else(|| bad("the dos tap needs [stages.dos] model".into()))?;
                    let model = crate::calibrate::read_model(&scene.resolve(&d.model))?;
                    OutputSink::Dos(open(&path, DosShape::from_model(&model)?, o, time, dest)?)
                }
                Tap::Slip => {
                    if o.archive.is_some() {
                        return Err(bad(format!(
                            "output #{}: slip events belong to a sensor pair; write one file (no archive)",
                            i + 1
                        )));
                    }
                    let c = &scene.stages.slip;
                    OutputSink::Slip(open_file(&path, SlipShape::new(&c.first, &c.second), o, time, dest)?)
                }
            };
            sink.set_metadata("gradtac.scene".into(), scene.text.clone());
            sink.set_metadata("gradtac.tap".into(), tap.name().into());
            sink.set_metadata("gradtac.layout".into(), layout.to_csv());
            for p in plan.sensors.iter().filter(|p| p.outputs.contains(&i)) {
                sink.set_metadata(format!("gradtac.layout.{}", p.name), p.layout.to_csv());
            }
            sinks.push(Some(sink));
        }
        Ok(Sinks {
            sinks,
            taps,
            #[cfg(feature = "view")]
            view: None,
        })
    }

    /// Offer every record written from now on (once per stage, whatever the number of outputs
    /// tapping it) to a rerun view, and the raw frames of [`view_source`](Self::view_source).
    #[cfg(feature = "view")]
    pub fn set_view(&mut self, view: Option<crate::view::ViewHandle>) {
        self.view = view;
    }

    /// Raw frames no output taps: offered to the view (if any), so that it always shows the
    /// electrodes. Nothing without the `view` feature.
    pub fn view_source(&self, outputs: &[usize], frames: &[TaxelFrame]) {
        #[cfg(feature = "view")]
        if let (Some(v), true) = (&self.view, outputs.is_empty()) {
            v.log_frames(crate::view::FrameKind::Raw, frames);
        }
        #[cfg(not(feature = "view"))]
        let _ = (outputs, frames);
    }

    /// Write `records` to each output in `outputs` (indices into the scene's outputs).
    pub fn write_all<T: Record>(&mut self, outputs: &[usize], records: &[T]) -> Result<(), Error> {
        #[cfg(feature = "view")]
        if let (Some(v), Some(&o)) = (&self.view, outputs.first()) {
            T::view(v, self.taps[o], records);
        }
        for &o in outputs {
            let sink = self.sinks[o].as_mut().and_then(T::sink).expect("the planner opened a sink of the tap's type");
            for r in records {
                sink.push(r)?;
            }
        }
        Ok(())
    }

    /// Rows written so far per output (in the scene's order; 0 for a closed one).
    pub fn rows(&self) -> Vec<u64> {
        self.sinks.iter().map(|s| s.as_ref().map_or(0, OutputSink::rows)).collect()
    }

    /// Close and rename every output; returns (final files, rows) per output.
    pub fn finish(mut self) -> Result<Vec<(Vec<PathBuf>, u64)>, Error> {
        let mut done = Vec::new();
        let mut first_err = None;
        for s in self.sinks.iter_mut().filter_map(Option::take) {
            let rows = s.rows();
            match s.finish() {
                Ok(p) => done.push((p, rows)),
                Err(e) => {
                    first_err.get_or_insert(e);
                }
            }
        }
        first_err.map_or(Ok(done), Err)
    }

    /// Close every output as a valid file under its `.partial` name; returns those paths.
    pub fn abort(mut self) -> Vec<PathBuf> {
        self.sinks.iter_mut().filter_map(Option::take).filter_map(|s| s.abort().ok()).flatten().collect()
    }
}

/// Rows per row group of surface outputs unless the scene says otherwise: a 64×64 surface is
/// 32 KiB, and a sink buffers up to a row group (at most 8192 rows) before writing.
const SURFACE_ROW_GROUP: usize = 256;

/// The time base of an output's records: UTC when every sensor it covers reads a source
/// whose clock is the Unix epoch (a CAN bus, live or a candump log; a ROS bag; MCAP),
/// relative otherwise (files timed by a rate or by a time column of their own origin).
fn time_base(scene: &Scene, sensors: &[&str]) -> TimeBase {
    let utc = |s: &SourceSpec| matches!(s, SourceSpec::Bus { .. } | SourceSpec::Rosbag(_) | SourceSpec::Mcap(_));
    let all_utc =
        !sensors.is_empty() && sensors.iter().all(|n| scene.sensors.iter().any(|s| s.name == *n && utc(&s.source)));
    if all_utc {
        TimeBase::Utc
    } else {
        TimeBase::Relative
    }
}

fn row_group(o: &OutputSpec) -> Option<usize> {
    o.row_group_size.or((o.tap == Tap::Surface.name()).then_some(SURFACE_ROW_GROUP))
}

/// Where an output goes: a file or archive, or `memory` when given (`output`: its index).
#[derive(Clone, Copy)]
struct Dest<'a> {
    memory: Option<&'a MemoryOutputs>,
    output: usize,
}

/// One output's sink: an archive directory when the output has `archive` settings, else one file.
fn open<T: Record + HasSensor + Timed>(
    path: &Path,
    shape: T::Shape,
    o: &OutputSpec,
    time: TimeBase,
    dest: Dest<'_>,
) -> Result<Box<dyn RecordSink<T>>, Error> {
    if let Some(m) = dest.memory {
        return Ok(m.sink(dest.output, shape, time));
    }
    Ok(match &o.archive {
        Some(cfg) => {
            // rolled by bytes, the size estimate must include every batch pushed: encode inline
            let threads = cfg.roll_bytes.is_none();
            let mut a =
                ParquetArchive::from_config(path, shape, cfg)?.with_time_base(time)?.with_writer_thread(threads)?;
            if let Some(n) = row_group(o) {
                a = a.with_row_group_size(n)?;
            }
            Box::new(a)
        }
        None => open_file(path, shape, o, time, dest)?,
    })
}

/// One output's sink as a single file.
fn open_file<T: Record>(
    path: &Path,
    shape: T::Shape,
    o: &OutputSpec,
    time: TimeBase,
    dest: Dest<'_>,
) -> Result<Box<dyn RecordSink<T>>, Error> {
    if let Some(m) = dest.memory {
        return Ok(m.sink(dest.output, shape, time));
    }
    let mut s = ParquetSink::try_new(path, shape)?.with_time_base(time)?.with_writer_thread(true)?;
    if let Some(n) = row_group(o) {
        s = s.with_row_group_size(n)?;
    }
    Ok(Box::new(s))
}
