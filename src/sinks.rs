//! The outputs of a run: one Parquet sink per scene output, typed by the stage it taps.
//!
//! Every file encodes, compresses and writes on a thread of its own
//! ([`ParquetSink::with_writer_thread`]): the runner's thread only appends rows and hands
//! over finished batches, so closing a row group (milliseconds of zstd) never stalls the
//! frames of a live run, and a file run overlaps encoding with the chains on a second core.
//! The exception is an archive rolled by bytes (`roll_bytes`), which encodes on the runner's
//! thread so that its size estimate counts every batch and its files overshoot the limit by
//! at most one batch.

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
pub trait Record: ArrowRecord + Send + 'static {
    /// The typed sink, when `s` writes this type.
    fn sink(s: &mut OutputSink) -> Option<&mut Box<dyn RecordSink<Self>>>;
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

/// Every output of a run, open as `<path>.partial` until [`Sinks::finish`].
pub struct Sinks {
    sinks: Vec<Option<OutputSink>>,
}

impl Sinks {
    /// Open every output of the scene. Outputs shared by several sensors need layouts of one size.
    pub fn open(scene: &Scene, plan: &Plan) -> Result<Sinks, Error> {
        let mut sinks = Vec::new();
        for (i, o) in scene.outputs.iter().enumerate() {
            let tap = Tap::parse(&o.tap).expect("validated by Scene");
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
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.to_path_buf(), source })?;
            }
            let taxels = FrameShape::from_layout(layout);
            let names: Vec<&str> =
                plan.sensors.iter().filter(|p| p.outputs.contains(&i)).map(|p| p.name.as_str()).collect();
            let time = time_base(scene, &names);
            let mut sink = match tap {
                Tap::Source | Tap::Normalise | Tap::Savgol => OutputSink::Frames(open(&path, taxels, o, time)?),
                Tap::Events => OutputSink::Events(open(&path, taxels, o, time)?),
                Tap::Window => OutputSink::Windows(open(&path, taxels, o, time)?),
                Tap::Surface => {
                    let grids = users
                        .iter()
                        .map(|l| Grid::from_config(&scene.stages.surface.grid, l))
                        .collect::<Result<Vec<_>, _>>()?;
                    if grids.iter().any(|g| g != &grids[0]) {
                        return Err(bad(format!(
                            "output #{}: the sensors' layouts give different surface grids; give each its own output",
                            i + 1
                        )));
                    }
                    OutputSink::Surfaces(open(&path, SurfaceShape::new(grids[0].clone()), o, time)?)
                }
                Tap::Contour => OutputSink::Contours(open(&path, (), o, time)?),
                Tap::Track => OutputSink::Tracks(open(&path, (), o, time)?),
                Tap::Force => OutputSink::Forces(open(&path, (), o, time)?),
                Tap::Servo => OutputSink::Servo(open(&path, (), o, time)?),
                Tap::Dos => {
                    let d =
                        scene.stages.dos.as_ref().ok_or_else(|| bad("the dos tap needs [stages.dos] model".into()))?;
                    let model = crate::calibrate::read_model(&scene.resolve(&d.model))?;
                    OutputSink::Dos(open(&path, DosShape::from_model(&model)?, o, time)?)
                }
                Tap::Slip => {
                    if o.archive.is_some() {
                        return Err(bad(format!(
                            "output #{}: slip events belong to a sensor pair; write one file (no archive)",
                            i + 1
                        )));
                    }
                    let c = &scene.stages.slip;
                    OutputSink::Slip(open_file(&path, SlipShape::new(&c.first, &c.second), o, time)?)
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
        Ok(Sinks { sinks })
    }

    /// Write `records` to each output in `outputs` (indices into the scene's outputs).
    pub fn write_all<T: Record>(&mut self, outputs: &[usize], records: &[T]) -> Result<(), Error> {
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

/// One output's sink: an archive directory when the output has `archive` settings, else one file.
fn open<T: Record + HasSensor + Timed>(
    path: &Path,
    shape: T::Shape,
    o: &OutputSpec,
    time: TimeBase,
) -> Result<Box<dyn RecordSink<T>>, Error> {
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
        None => open_file(path, shape, o, time)?,
    })
}

/// One output's sink as a single file.
fn open_file<T: Record>(
    path: &Path,
    shape: T::Shape,
    o: &OutputSpec,
    time: TimeBase,
) -> Result<Box<dyn RecordSink<T>>, Error> {
    let mut s = ParquetSink::try_new(path, shape)?.with_time_base(time)?.with_writer_thread(true)?;
    if let Some(n) = row_group(o) {
        s = s.with_row_group_size(n)?;
    }
    Ok(Box::new(s))
}
