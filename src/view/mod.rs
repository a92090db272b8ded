//! A live (or recorded) [rerun](https://rerun.io) view of every stage (feature `view`).
//!
//! [`View`] owns a rerun [`RecordingStream`](rerun::RecordingStream) — a spawned or running
//! viewer ([`View::spawn`], [`View::connect`]), an `.rrd` file ([`View::save`]) or any stream
//! the embedding code built ([`View::from_stream`]) — and a thread that logs to it. Code that
//! produces records holds a [`ViewHandle`] (cheap to clone) and calls
//! [`ViewHandle::log`], or appends a [`ViewTap`] (a pass-through [`Stage`]) to any chain.
//!
//! **Rate discipline.** The handle copies each record into a compact form and offers it to a
//! bounded queue ([`DEFAULT_QUEUE`] messages, at most [`MAX_QUEUE_BYTES`] of data;
//! `try_send`): it never waits for the viewer. When the queue is full (the
//! viewer, the network or the disk is slower than the pipeline) the record is dropped and
//! counted; [`View::finish`] returns the counts ([`ViewReport`]) and the CLI prints them. All
//! rerun work (Arrow encoding, batching, the socket or file) runs on the view's thread and
//! rerun's own threads. [`ViewOptions::lossless`] makes the handle wait instead (for offline
//! replays and tests whose recording must be complete; never for a live robot).
//!
//! **Entities** (per sensor `s`; one blueprint panel per sensor: a 2-D view of `s/plane`
//! above a time-series view of `s/series`, and a slip panel when there are slip events):
//!
//! | entity | archetype | from |
//! |---|---|---|
//! | `s/series/raw`, `…/normalised`, `…/smoothed`, `…/window` | `Scalars`, one series per taxel (named by the layout) | frames, window aggregates |
//! | `s/plane/raw`, `…/normalised`, `…/smoothed`, `…/window` | `Points2D` at the layout's taxel positions (mm, static), coloured per record: blue–white–red for the change from the sensor's first frame (raw) or from 0, scaled by the largest change seen so far | same |
//! | `s/series/events` | `Scalars` `[+1 events, −1 events]` of each frame with events | events |
//! | `s/plane/surface` | `DepthImage` (viridis) on the grid, placed in mm by a `Transform3D` (pixel centres on the grid points) | surfaces |
//! | `s/plane/contour` | `LineStrips2D`, the closed maximal contour (cleared without contact) | contours |
//! | `s/series/contact_area` | `Scalars` area (mm²) | contours |
//! | `s/plane/contact` | `Points2D`, radius = the position uncertainty σ (mm) where the track has one, else 0.5 mm | track |
//! | `s/series/contact` | `Scalars` `[x, y]` (mm) | track |
//! | `s/series/force` | `Scalars` force (N) | force |
//! | `s/series/servo` | `Scalars` commanded motion `[x, y]` (mm) | servo |
//! | `s/log` | `TextLog` of the slip-direction decisions | dos |
//! | `slip/log` | `TextLog` of every change of the grasp's state | slip |
//! | `slip/class` | `Scalars` (class index 0–4, a marker per event) | slip |
//!
//! The layout plane is in mm with rerun's 2-D convention (x right, **y down**). Times are the
//! data's own: a sensor whose source has a Unix-epoch clock (CAN, ROS bags, MCAP; Parquet
//! `Timestamp` columns) logs on the **`utc`** timestamp timeline, any other on the
//! **`time`** duration timeline (since the source's origin); rerun's own `log_time` is the
//! wall clock of logging. Records of a sensor go to its `time` or `utc`, never both.
//!
//! rerun is pinned to one minor version (`=0.36`): its logging API changes between minors and
//! a viewer reads the recordings of its own minor. The matching viewer is rerun **0.36**
//! (`pip install rerun-sdk==0.36.3`, or `cargo install rerun-cli@0.36.3`).

mod logger;
pub(crate) mod rec;
#[cfg(feature = "plot")]
mod replay;

use crate::Error;
use rec::Rec;
pub use rec::{Clock, FrameKind};
#[cfg(feature = "plot")]
pub use replay::{replay, ReplaySummary};
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;

use gradtac_stages::contour::ContourFrame;
use gradtac_stages::dos::DosDecision;
use gradtac_stages::force::ForceEstimate;
use gradtac_stages::interpolate::Surface;
use gradtac_stages::servo::{ServoAction, ServoCommand};
use gradtac_stages::slip::SlipEvent;
use gradtac_stages::track::{ContactState, TrackPoint};
use gradtac_stages::window::WindowAggregate;
use gradtac_stages::EventBatch;
use gradtac_stream::{Delay, Layout, Stage, TaxelFrame};

/// The rerun application id of gradtac's recordings.
pub const APPLICATION_ID: &str = "gradtac";

/// Default capacity of the queue between the pipeline and the view's thread (messages; a
/// message is the records of one call, usually one frame's).
pub const DEFAULT_QUEUE: usize = 4096;
/// Largest queue capacity accepted.
pub const MAX_QUEUE: usize = 1 << 20;
/// At most this many bytes of record data wait in the queue, whatever the message count (a
/// 1024 × 1024 surface is 4 MiB): past it a record is dropped, or, lossless, waits.
pub const MAX_QUEUE_BYTES: u64 = 256 << 20;

/// Settings of a [`View`].
#[derive(Clone, Debug)]
pub struct ViewOptions {
    /// Queue capacity in messages (1 ..= [`MAX_QUEUE`]); default [`DEFAULT_QUEUE`].
    pub queue: usize,
    /// Wait for room in the queue instead of dropping (offline replays, tests). Default `false`:
    /// the pipeline never waits for the viewer.
    pub lossless: bool,
    /// Send a blueprint (one panel per sensor). Default `true`.
    pub blueprint: bool,
    /// How long [`View::finish`] waits for a viewer to take what is still buffered (a viewer
    /// that went away, or never listened, must not hang the end of a run). Default 10 s.
    /// An `.rrd` file ([`View::save`]) is always flushed completely.
    pub flush_timeout: std::time::Duration,
}

impl Default for ViewOptions {
    fn default() -> Self {
        ViewOptions {
            queue: DEFAULT_QUEUE,
            lossless: false,
            blueprint: true,
            flush_timeout: std::time::Duration::from_secs(10),
        }
    }
}

/// Where a [`View`] sends its recording.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ViewTarget {
    /// Spawn a viewer (the `rerun` executable on `PATH`) unless one already listens on the
    /// default port, and stream to it.
    Spawn,
    /// Stream to a running viewer or server at this URL (`rerun+http://127.0.0.1:9876/proxy`).
    Connect(String),
    /// Write an `.rrd` recording (no viewer needed).
    Save(PathBuf),
}

/// Counts shared by the handles and the view.
#[derive(Debug, Default)]
struct Counters {
    sent: AtomicU64,
    dropped: AtomicU64,
    logged: AtomicU64,
    /// Bytes of record data in the queue.
    queued_bytes: AtomicU64,
}

/// What a view logged (see [`View::finish`]).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ViewReport {
    /// Records offered to the queue.
    pub offered: u64,
    /// Records dropped because the queue was full (the viewer was slower than the pipeline),
    /// or offered after the view finished.
    pub dropped: u64,
    /// Records logged to rerun.
    pub logged: u64,
    /// Where the recording went.
    pub target: String,
}

impl fmt::Display for ViewReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "view: {} records logged to {}", self.logged, self.target)?;
        if self.dropped > 0 {
            write!(
                f,
                ", {} of {} dropped (the viewer was slower than the pipeline; the Parquet outputs are complete)",
                self.dropped, self.offered
            )?;
        } else {
            write!(f, ", none dropped")?;
        }
        writeln!(f)
    }
}

enum Msg {
    Recs(Vec<Rec>),
    Finish,
}

/// Bytes a message holds (for [`MAX_QUEUE_BYTES`]).
fn message_bytes(recs: &[Rec]) -> u64 {
    recs.iter().map(|r| (std::mem::size_of::<Rec>() + r.heap_bytes()) as u64).sum()
}

/// The producer side of a [`View`]: offer records to its queue (cheap to clone, `Send`).
#[derive(Clone)]
pub struct ViewHandle {
    tx: SyncSender<Msg>,
    counters: Arc<Counters>,
    lossless: bool,
}

impl fmt::Debug for ViewHandle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ViewHandle").field("lossless", &self.lossless).finish_non_exhaustive()
    }
}

impl ViewHandle {
    fn offer(&self, recs: Vec<Rec>) {
        if recs.is_empty() {
            return;
        }
        let n = recs.len() as u64;
        self.counters.sent.fetch_add(n, Ordering::Relaxed);
        let bytes = message_bytes(&recs);
        let queued = &self.counters.queued_bytes;
        if self.lossless {
            // wait for the view to take enough (the count bound waits in `send`)
            while queued.load(Ordering::Relaxed) + bytes > MAX_QUEUE_BYTES && queued.load(Ordering::Relaxed) > 0 {
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
        } else if queued.load(Ordering::Relaxed) + bytes > MAX_QUEUE_BYTES {
            self.counters.dropped.fetch_add(n, Ordering::Relaxed);
            return;
        }
        queued.fetch_add(bytes, Ordering::Relaxed);
        let msg = Msg::Recs(recs);
        let ok = if self.lossless {
            self.tx.send(msg).is_ok()
        } else {
            match self.tx.try_send(msg) {
                Ok(()) => true,
                Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => false,
            }
        };
        if !ok {
            queued.fetch_sub(bytes, Ordering::Relaxed);
            self.counters.dropped.fetch_add(n, Ordering::Relaxed);
        }
    }

    /// Declare a sensor: its layout (taxel positions and names; `None` when unknown) and its
    /// clock. Records of a sensor not declared are logged on the `time` duration timeline
    /// without a layout plane. Never dropped (it waits for room in the queue).
    pub fn sensor(&self, name: &str, layout: Option<&Layout>, clock: Clock) {
        let recs = vec![Rec::Sensor { sensor: name.to_string(), layout: layout.cloned(), clock }];
        // rare and small: wait for room so that the sensor's records find their layout
        let bytes = message_bytes(&recs);
        self.counters.queued_bytes.fetch_add(bytes, Ordering::Relaxed);
        if self.tx.send(Msg::Recs(recs)).is_err() {
            self.counters.queued_bytes.fetch_sub(bytes, Ordering::Relaxed);
        }
    }

    /// Log records (of any sensor). Frames log as [`FrameKind::Raw`]; see
    /// [`log_frames`](Self::log_frames) for the other kinds.
    pub fn log<T: Viewable>(&self, records: &[T]) {
        self.offer(records.iter().filter_map(|r| r.to_rec(FrameKind::Raw)).collect());
    }

    /// Log frames (or window aggregates) as `kind`.
    pub fn log_frames<T: Viewable>(&self, kind: FrameKind, records: &[T]) {
        self.offer(records.iter().filter_map(|r| r.to_rec(kind)).collect());
    }

    /// A pass-through stage that logs what crosses it (frames as [`FrameKind::Raw`]).
    pub fn tap<T: Viewable>(&self) -> ViewTap<T> {
        ViewTap { handle: self.clone(), kind: FrameKind::Raw, _t: std::marker::PhantomData }
    }

    /// A pass-through stage that logs frames as `kind`.
    pub fn tap_frames<T: Viewable>(&self, kind: FrameKind) -> ViewTap<T> {
        ViewTap { handle: self.clone(), kind, _t: std::marker::PhantomData }
    }
}

/// A record the view can draw (every output type of the pipeline).
pub trait Viewable: sealed::Sealed {}

mod sealed {
    /// The conversion into the queue's compact form.
    pub trait Sealed {
        /// `None`: nothing to draw (an event batch without events).
        fn to_rec(&self, kind: super::FrameKind) -> Option<super::Rec>;
    }
}
use sealed::Sealed;

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

impl Sealed for TaxelFrame {
    fn to_rec(&self, kind: FrameKind) -> Option<Rec> {
        let kind = if kind == FrameKind::Window { FrameKind::Raw } else { kind };
        Some(Rec::Frame { sensor: self.sensor.to_string(), kind, t: self.time.as_nanos(), values: self.values.clone() })
    }
}
impl Viewable for TaxelFrame {}

impl Sealed for EventBatch {
    fn to_rec(&self, _: FrameKind) -> Option<Rec> {
        if self.events.is_empty() {
            return None;
        }
        let positive = self.events.iter().filter(|e| e.polarity > 0).count() as u32;
        let negative = self.events.len() as u32 - positive;
        Some(Rec::Events { sensor: self.sensor.to_string(), t: self.time.as_nanos(), positive, negative })
    }
}
impl Viewable for EventBatch {}

impl Sealed for WindowAggregate {
    fn to_rec(&self, _: FrameKind) -> Option<Rec> {
        Some(Rec::Frame {
            sensor: self.sensor.to_string(),
            kind: FrameKind::Window,
            t: self.end.as_nanos(),
            values: self.values.clone(),
        })
    }
}
impl Viewable for WindowAggregate {}

impl Sealed for Surface {
    fn to_rec(&self, _: FrameKind) -> Option<Rec> {
        let g = &self.grid;
        let e = g.extent();
        Some(Rec::Surface {
            sensor: self.sensor.to_string(),
            t: self.end.as_nanos(),
            nx: g.nx(),
            ny: g.ny(),
            extent: [e.x_min, e.x_max, e.y_min, e.y_max],
            // row-major [row = y][col = x], as the schema stores it
            values: self.values.iter().map(|&v| v as f32).collect(),
        })
    }
}
impl Viewable for Surface {}

impl Sealed for ContourFrame {
    fn to_rec(&self, _: FrameKind) -> Option<Rec> {
        let c = self.outcome.contact();
        Some(Rec::Contour {
            sensor: self.sensor.to_string(),
            t: self.end.as_nanos(),
            polygon: c.map(|c| c.polygon.clone()),
            centroid: c.map(|c| c.centroid_mm),
            area: c.map(|c| c.area_mm2),
        })
    }
}
impl Viewable for ContourFrame {}

/// The position uncertainty σ (mm) of a track point, when the locating method gives one
/// (`[stages.locate] method = "fit"`: the fit's 1-σ major axis; the replay reads the same
/// value from the `track` file's `fit_sigma_mm` column).
fn track_sigma(p: &TrackPoint) -> Option<f64> {
    p.fit.as_ref().map(|f| f.sigma_mm).filter(|s| s.is_finite())
}

impl Sealed for TrackPoint {
    fn to_rec(&self, _: FrameKind) -> Option<Rec> {
        let xy = (self.state == ContactState::Contact && self.x_mm.is_finite() && self.y_mm.is_finite())
            .then_some([self.x_mm, self.y_mm]);
        Some(Rec::Contact {
            sensor: self.sensor.to_string(),
            t: self.time.as_nanos(),
            xy,
            sigma_mm: track_sigma(self).and_then(finite),
        })
    }
}
impl Viewable for TrackPoint {}

impl Sealed for ForceEstimate {
    fn to_rec(&self, _: FrameKind) -> Option<Rec> {
        Some(Rec::Force { sensor: self.sensor.to_string(), t: self.time.as_nanos(), force_n: self.force_n })
    }
}
impl Viewable for ForceEstimate {}

impl Sealed for ServoCommand {
    fn to_rec(&self, _: FrameKind) -> Option<Rec> {
        let motion_mm = match &self.action {
            ServoAction::Move(m) => Some(m.motion_mm),
            ServoAction::NoContact => None,
        };
        Some(Rec::Servo { sensor: self.sensor.to_string(), t: self.time.as_nanos(), motion_mm })
    }
}
impl Viewable for ServoCommand {}

/// Slip events name no sensor: [`ViewHandle::log`] files them under `slip/`.
impl Sealed for SlipEvent {
    fn to_rec(&self, _: FrameKind) -> Option<Rec> {
        Some(Rec::Slip {
            pair: String::new(),
            t: self.time.as_nanos(),
            onset: self.onset.as_nanos(),
            class: self.class.name().to_string(),
            previous: self.previous.name().to_string(),
        })
    }
}
impl Viewable for SlipEvent {}

impl Sealed for DosDecision {
    fn to_rec(&self, _: FrameKind) -> Option<Rec> {
        let d = &self.decision;
        let posterior = d.posterior.iter().copied().fold(None, |m: Option<f64>, p| Some(m.map_or(p, |m| m.max(p))));
        Some(Rec::Dos {
            sensor: self.sensor.to_string(),
            t: self.end.as_nanos(),
            class: d.class.to_string(),
            posterior,
        })
    }
}
impl Viewable for DosDecision {}

/// A pass-through [`Stage`] that logs every input to a view and passes it on unchanged:
/// append it to any chain (`.stage(handle.tap())`). No delay; never fails; never waits for
/// the viewer (unless the view is lossless).
#[must_use = "a stage does nothing until inputs are pushed"]
pub struct ViewTap<T> {
    handle: ViewHandle,
    kind: FrameKind,
    _t: std::marker::PhantomData<fn(T) -> T>,
}

impl<T> fmt::Debug for ViewTap<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ViewTap").field("kind", &self.kind).finish_non_exhaustive()
    }
}

impl<T: Viewable> Stage for ViewTap<T> {
    type In = T;
    type Out = T;
    type Error = std::convert::Infallible;

    fn push(&mut self, input: T, out: &mut Vec<T>) -> Result<(), Self::Error> {
        self.handle.offer(input.to_rec(self.kind).into_iter().collect());
        out.push(input);
        Ok(())
    }

    fn reset(&mut self) {}

    fn delay(&self) -> Delay {
        Delay::ZERO
    }
}

/// A rerun recording fed from a bounded queue by a thread of its own (see the
/// [module docs](self)).
pub struct View {
    handle: ViewHandle,
    counters: Arc<Counters>,
    thread: Option<JoinHandle<()>>,
    target: String,
}

impl fmt::Debug for View {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("View").field("target", &self.target).finish_non_exhaustive()
    }
}

fn view_error(what: &str, e: impl fmt::Display) -> Error {
    Error::View(format!("{what}: {e}"))
}

impl View {
    /// Open the recording `target` asks for.
    pub fn open(target: &ViewTarget, options: &ViewOptions) -> Result<View, Error> {
        match target {
            ViewTarget::Spawn => View::spawn(options),
            ViewTarget::Connect(url) => View::connect(url, options),
            ViewTarget::Save(path) => View::save(path, options),
        }
    }

    /// Spawn a rerun viewer (the `rerun` executable on `PATH`, e.g. from
    /// `pip install rerun-sdk==0.36.3`) unless one already listens on the default port, and
    /// stream to it.
    pub fn spawn(options: &ViewOptions) -> Result<View, Error> {
        let rec = rerun::RecordingStreamBuilder::new(APPLICATION_ID)
            .spawn()
            .map_err(|e| view_error("cannot spawn the rerun viewer (is `rerun` 0.36 on PATH?)", e))?;
        View::from_stream(rec, "a spawned viewer".into(), options)
    }

    /// Stream to a running viewer at `url` (e.g. `rerun+http://127.0.0.1:9876/proxy`).
    pub fn connect(url: &str, options: &ViewOptions) -> Result<View, Error> {
        let rec = rerun::RecordingStreamBuilder::new(APPLICATION_ID)
            .connect_grpc_opts(url)
            .map_err(|e| view_error(&format!("cannot connect to the viewer at {url}"), e))?;
        View::from_stream(rec, url.to_string(), options)
    }

    /// Write an `.rrd` recording at `path` (no viewer needed). The file is written as it goes
    /// and complete after [`finish`](Self::finish).
    pub fn save(path: &Path, options: &ViewOptions) -> Result<View, Error> {
        let rec = rerun::RecordingStreamBuilder::new(APPLICATION_ID)
            .save(path)
            .map_err(|e| view_error(&format!("cannot write the recording {}", path.display()), e))?;
        View::start(rec, path.display().to_string(), options, None)
    }

    /// Log into a stream the embedding code built (any sink: memory, a file, a viewer).
    /// `target` names it in the report.
    pub fn from_stream(rec: rerun::RecordingStream, target: String, options: &ViewOptions) -> Result<View, Error> {
        View::start(rec, target, options, Some(options.flush_timeout))
    }

    /// `flush`: how long to wait for the stream's sink at the end (`None`: until it is done).
    fn start(
        rec: rerun::RecordingStream,
        target: String,
        options: &ViewOptions,
        flush: Option<std::time::Duration>,
    ) -> Result<View, Error> {
        if options.queue == 0 || options.queue > MAX_QUEUE {
            return Err(Error::View(format!(
                "view queue must be within 1..={MAX_QUEUE} messages, got {}",
                options.queue
            )));
        }
        let (tx, rx) = std::sync::mpsc::sync_channel(options.queue);
        let counters = Arc::new(Counters::default());
        let c = counters.clone();
        let blueprint = options.blueprint;
        let thread = std::thread::Builder::new()
            .name("gradtac-view".into())
            .spawn(move || run_logger(rec, rx, &c, blueprint, flush))
            .map_err(|e| view_error("cannot start the view thread", e))?;
        let handle = ViewHandle { tx, counters: counters.clone(), lossless: options.lossless };
        Ok(View { handle, counters, thread: Some(thread), target })
    }

    /// A handle to offer records (clone it for every producer).
    pub fn handle(&self) -> ViewHandle {
        self.handle.clone()
    }

    /// Log everything queued, flush the recording (an `.rrd` is complete when this returns)
    /// and report the counts. Records offered through handles after this are dropped.
    pub fn finish(mut self) -> Result<ViewReport, Error> {
        let _ = self.handle.tx.send(Msg::Finish);
        if let Some(t) = self.thread.take() {
            t.join().map_err(|_| Error::View("the view thread panicked".into()))?;
        }
        Ok(self.report())
    }

    /// The counts so far.
    pub fn report(&self) -> ViewReport {
        ViewReport {
            offered: self.counters.sent.load(Ordering::Relaxed),
            dropped: self.counters.dropped.load(Ordering::Relaxed),
            logged: self.counters.logged.load(Ordering::Relaxed),
            target: self.target.clone(),
        }
    }
}

impl Drop for View {
    fn drop(&mut self) {
        if let Some(t) = self.thread.take() {
            let _ = self.handle.tx.send(Msg::Finish);
            let _ = t.join();
        }
    }
}

fn run_logger(
    rec: rerun::RecordingStream,
    rx: Receiver<Msg>,
    counters: &Counters,
    blueprint: bool,
    flush: Option<std::time::Duration>,
) {
    let mut logger = logger::Logger::new(rec, blueprint);
    while let Ok(msg) = rx.recv() {
        match msg {
            Msg::Recs(recs) => {
                counters.queued_bytes.fetch_sub(message_bytes(&recs), Ordering::Relaxed);
                for r in recs {
                    if !matches!(r, Rec::Sensor { .. }) {
                        counters.logged.fetch_add(1, Ordering::Relaxed);
                    }
                    logger.log(r);
                }
            }
            Msg::Finish => break,
        }
    }
    logger.finish(flush);
}

#[cfg(test)]
mod tests;
