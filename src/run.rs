//! Running a planned scene: sources → the stages each sensor needs → Parquet outputs.
//!
//! [`Runner`] is the synchronous core: push frames of any sensor, in time order, and it runs
//! each sensor's planned chain and writes every tapped output. [`run`] is the async shell
//! the CLI uses: it opens the sources, reads each on tokio's blocking pool, merges them by
//! time, feeds the runner, and handles Ctrl-C.
//!
//! **Outputs are all-or-nothing under their final name.** Each is written as
//! `<path>.partial` and renamed when the run finishes. When the run fails (bad input, a
//! stage error), every output is closed as a valid Parquet file of what was written before
//! the error and left under its `.partial` name; the final name never appears. On Ctrl-C the
//! outputs are finished (renamed): they hold everything read so far.

use crate::chain::SensorChain;
use crate::memory::MemoryOutputs;
use crate::plan::{Plan, SensorPlan, Tap};
use crate::scene::{BusSource, BusSpec, Scene, SourceSpec};
use crate::sinks::Sinks;
use crate::Error;
use futures::StreamExt;
use gradtac_io::arrow_ipc::ArrowIpcConfig;
use gradtac_io::can::{CandumpConfig, StatsHandle};
use gradtac_io::npy::{NpyFrames, NpySourceConfig};
use gradtac_io::{CsvFrames, CsvProgress, CsvSourceConfig};
use gradtac_stages::slip::{Slip, SlipEvent, SlipInput};
use gradtac_stages::slip_pattern::{PatternPoint, SlipPattern};
use gradtac_stages::track::TrackPoint;
use gradtac_stream::{merge_streams, SensorId, Stage, TaxelFrame};
use std::fmt;
use std::path::PathBuf;
use std::pin::Pin;
use std::time::Instant;

/// Options of a run.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Draw a progress bar (on stderr) over the sources' bytes (with the `cli` feature; without
    /// it nothing is drawn).
    pub progress: bool,
    /// Threads for the sensors' chains: `0` the available cores, `1` everything on the calling
    /// thread (the single-threaded path), `n` up to `n` chain threads. The outputs are byte
    /// for byte the same whatever the number (see the [module docs](self)).
    pub threads: usize,
    /// Offer the raw frames and every record written to a rerun view (feature `view`; see
    /// [`crate::view`]). The run declares each sensor it reads (layout, clock) first.
    #[cfg(feature = "view")]
    pub view: Option<crate::view::ViewHandle>,
}

/// What a run did.
#[derive(Clone, Debug, Default)]
pub struct RunReport {
    /// Frames read per sensor (sensors that were read).
    pub frames: Vec<(String, u64)>,
    /// Final files and rows written per output (one file, or an archive's files).
    pub outputs: Vec<(Vec<PathBuf>, u64)>,
    /// Per CAN bus: its name and fault counts (one line).
    pub buses: Vec<(String, String)>,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// True when Ctrl-C ended the run early.
    pub interrupted: bool,
}

impl fmt::Display for RunReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let total: u64 = self.frames.iter().map(|(_, n)| n).sum();
        writeln!(
            f,
            "{}read {total} frames in {:.3} s ({:.0} frames/s)",
            if self.interrupted { "interrupted: " } else { "" },
            self.seconds,
            total as f64 / self.seconds.max(1e-9)
        )?;
        for (s, n) in &self.frames {
            writeln!(f, "  sensor {s}: {n} frames")?;
        }
        for (b, stats) in &self.buses {
            writeln!(f, "  bus {b}: {stats}")?;
        }
        for (files, n) in &self.outputs {
            match files.as_slice() {
                [one] => writeln!(f, "  wrote {} ({n} rows)", one.display())?,
                many => writeln!(
                    f,
                    "  wrote {} files under {} ({n} rows)",
                    many.len(),
                    many.first().and_then(|p| p.parent()).map_or(String::new(), |d| d.display().to_string())
                )?,
            }
        }
        Ok(())
    }
}

/// What a run is built from, in the order a run opens them: the chain of every sensor the
/// plan reads, the cross-sensor slip stage when the plan runs one, and the sinks (each output
/// in `memory` instead of a file when given). The serial [`Runner`] and the chain threads
/// (`crate::parallel`) both start here.
pub(crate) fn build_parts(
    scene: &Scene,
    plan: &Plan,
    memory: Option<&MemoryOutputs>,
) -> Result<(Vec<SensorChain>, Option<SlipNode>, Sinks), Error> {
    let chains = plan
        .sensors
        .iter()
        .filter(|p| p.is_read())
        .map(|p| SensorChain::build(scene, p))
        .collect::<Result<Vec<_>, _>>()?;
    let slip = SlipNode::build(scene, plan)?;
    let sinks = Sinks::open_in(scene, plan, memory)?;
    Ok((chains, slip, sinks))
}

/// The cross-sensor two-finger slip stage and the outputs that tap it.
pub(crate) struct SlipNode {
    stage: Slip,
    /// The raw-frame evidence of the two sensors, when the slip settings read it.
    pattern: Option<SlipPattern>,
    patterns: Vec<PatternPoint>,
    first: SensorId,
    second: SensorId,
    outputs: Vec<usize>,
    events: Vec<SlipEvent>,
}

/// The synchronous core of a run (see the [module docs](self)).
pub struct Runner {
    chains: Vec<SensorChain>,
    slip: Option<SlipNode>,
    sinks: Sinks,
    last: usize,
}

impl SlipNode {
    /// The slip stage of the scene, when an output taps it.
    pub(crate) fn build(scene: &Scene, plan: &Plan) -> Result<Option<SlipNode>, Error> {
        let slip_outputs: Vec<usize> =
            scene.outputs.iter().enumerate().filter(|(_, o)| o.tap == Tap::Slip.name()).map(|(i, _)| i).collect();
        Ok(if slip_outputs.is_empty() {
            None
        } else {
            let c = &scene.stages.slip;
            let layout = |name: &str| plan.sensors.iter().find(|p| p.name == name).map(|p| &p.layout);
            let pattern = match (c.reads_frames(), layout(&c.first), layout(&c.second)) {
                (true, Some(a), Some(b)) => Some(SlipPattern::try_new(c, [a, b])?),
                _ => None,
            };
            Some(SlipNode {
                stage: Slip::try_new(c)?,
                pattern,
                patterns: Vec::new(),
                first: SensorId::new(&c.first),
                second: SensorId::new(&c.second),
                outputs: slip_outputs,
                events: Vec::new(),
            })
        })
    }

    /// True when the raw frames of `sensor` are evidence of the slip stage.
    pub(crate) fn reads_frames_of(&self, sensor: &SensorId) -> bool {
        self.pattern.is_some() && (sensor == &self.first || sensor == &self.second)
    }

    /// A raw frame of one of the two sensors: its evidence into the stage (events kept for
    /// [`write_events`](Self::write_events)).
    pub(crate) fn push_frame(&mut self, frame: &TaxelFrame) -> Result<(), Error> {
        if let Some(pat) = &mut self.pattern {
            if frame.sensor == self.first || frame.sensor == self.second {
                pat.push_frame(frame, &mut self.patterns)?;
                for p in self.patterns.drain(..) {
                    self.stage.push_input(SlipInput::Pattern(p), &mut self.events)?;
                }
            }
        }
        Ok(())
    }

    /// The track points a sensor's chain just made (ignored unless it is one of the two);
    /// with `finish`, then the end of the stage.
    pub(crate) fn push_points(
        &mut self,
        sensor: &SensorId,
        points: impl Iterator<Item = TrackPoint>,
        finish: bool,
    ) -> Result<(), Error> {
        if sensor == &self.first || sensor == &self.second {
            for p in points {
                self.stage.push(p, &mut self.events)?;
            }
        }
        if finish {
            self.stage.finish(&mut self.events)?;
        }
        Ok(())
    }

    /// Write the events made so far to the slip outputs.
    pub(crate) fn write_events(&mut self, sinks: &mut Sinks) -> Result<(), Error> {
        sinks.write_all(&self.outputs, &self.events)?;
        self.events.clear();
        Ok(())
    }
}

impl Runner {
    /// Build every planned stage and open (as `.partial`) every output.
    pub fn new(scene: &Scene, plan: &Plan) -> Result<Runner, Error> {
        Runner::new_in(scene, plan, None)
    }

    /// [`Runner::new`] with every output in `memory` instead of a file when given.
    pub fn new_in(scene: &Scene, plan: &Plan, memory: Option<&MemoryOutputs>) -> Result<Runner, Error> {
        let (chains, slip, sinks) = build_parts(scene, plan, memory)?;
        Ok(Runner { chains, slip, sinks, last: 0 })
    }

    /// Hand the track points chain `i` just produced to the slip stage, if its sensor is one
    /// of the pair.
    fn feed_slip(&mut self, i: usize, finish: bool) -> Result<(), Error> {
        let Some(node) = &mut self.slip else { return Ok(()) };
        let chain = &mut self.chains[i];
        let sensor = chain.sensor().clone();
        node.push_points(&sensor, chain.take_points(), finish)?;
        node.write_events(&mut self.sinks)
    }

    fn chain_index(&mut self, s: &SensorId) -> Option<usize> {
        let c = self.chains.get(self.last)?;
        if c.sensor().ptr_eq(s) || c.sensor() == s {
            return Some(self.last);
        }
        let i = self.chains.iter().position(|c| c.sensor() == s)?;
        self.last = i;
        Some(i)
    }

    /// Push one frame. Frames of sensors the plan does not run are ignored.
    pub fn push(&mut self, frame: TaxelFrame) -> Result<(), Error> {
        let Some(i) = self.chain_index(&frame.sensor) else { return Ok(()) };
        // the slip stage's raw-frame evidence first, then the track points the frame makes
        if let Some(node) = &mut self.slip {
            node.push_frame(&frame)?;
        }
        self.chains[i].process(Some(frame), false, &mut self.sinks)?;
        self.feed_slip(i, false)
    }

    /// Frames pushed so far, per sensor.
    pub fn frames_in(&self) -> Vec<(String, u64)> {
        self.chains.iter().map(|c| (c.sensor().to_string(), c.frames_in())).collect()
    }

    /// Rows written so far per output, in the scene's order (e.g. to see which pushes made a
    /// slip decision).
    pub fn rows(&self) -> Vec<u64> {
        self.sinks.rows()
    }

    /// End of input: flush every stage, finish every output (rename to its final name). On a
    /// flush error the outputs are left as `.partial` files.
    pub fn finish(mut self) -> Result<Vec<(Vec<PathBuf>, u64)>, Error> {
        let n = self.chains.len();
        for i in 0..n {
            let flushed =
                self.chains[i].process(None, true, &mut self.sinks).and_then(|()| self.feed_slip(i, i + 1 == n));
            if let Err(e) = flushed {
                self.sinks.abort();
                return Err(e);
            }
        }
        self.sinks.finish()
    }

    /// Offer the raw frames and every record written from now on to a rerun view, after
    /// declaring each sensor the plan reads (its layout; its clock: `utc` for CAN buses, ROS
    /// bags and MCAP files, the `time` duration otherwise).
    #[cfg(feature = "view")]
    pub fn set_view(&mut self, scene: &Scene, plan: &Plan, view: Option<crate::view::ViewHandle>) {
        if let Some(v) = &view {
            for p in plan.sensors.iter().filter(|p| p.is_read()) {
                let utc = matches!(
                    scene.sensors[p.index].source,
                    SourceSpec::Bus { .. } | SourceSpec::Rosbag(_) | SourceSpec::Mcap(_)
                );
                let clock = if utc { crate::view::Clock::Utc } else { crate::view::Clock::Relative };
                v.sensor(&p.name, Some(&p.layout), clock);
            }
        }
        self.sinks.set_view(view);
    }

    /// After an error: close every output as a valid `.partial` file; returns their paths.
    pub fn abort(self) -> Vec<PathBuf> {
        self.sinks.abort()
    }
}

type FrameStream = Pin<Box<dyn futures::Stream<Item = Result<TaxelFrame, gradtac_stream::Error>> + Send>>;
type FrameIter = Box<dyn Iterator<Item = Result<TaxelFrame, gradtac_stream::Error>> + Send>;

/// Open one sensor's source as an iterator; returns it with its taxel count (when known
/// before reading) and, for CSV, a progress handle.
fn open_source(scene: &Scene, p: &SensorPlan) -> Result<(FrameIter, Option<usize>, Option<CsvProgress>), Error> {
    let sensor = SensorId::new(&p.name);
    let err = |e: gradtac_io::Error| gradtac_stream::Error::from(e);
    Ok(match &scene.sensors[p.index].source {
        SourceSpec::Csv(cfg) => {
            let cfg = CsvSourceConfig { path: scene.resolve(&cfg.path), ..cfg.clone() };
            let frames = CsvFrames::open(&cfg, sensor)?;
            let (n, progress) = (frames.taxel_count(), frames.progress());
            (Box::new(frames.map(move |r| r.map_err(err))), Some(n), Some(progress))
        }
        SourceSpec::Npy(cfg) => {
            let cfg = NpySourceConfig {
                path: scene.resolve(&cfg.path),
                timestamps: cfg.timestamps.as_ref().map(|t| scene.resolve(t)),
                ..cfg.clone()
            };
            let frames = NpyFrames::open(&cfg, sensor)?;
            let n = frames.taxel_count();
            (Box::new(frames.map(move |r| r.map_err(err))), Some(n), None)
        }
        SourceSpec::Bus { .. } | SourceSpec::Rosbag(_) | SourceSpec::Mcap(_) => {
            unreachable!("bus and bag sources are opened per bus / file by open_sources")
        }
        SourceSpec::Arrow(cfg) => {
            let mut cfg = ArrowIpcConfig { path: scene.resolve(&cfg.path), ..cfg.clone() };
            if cfg.columns.is_none() && cfg.sensors.is_none() {
                cfg.sensors = Some(vec![p.name.clone()]);
            }
            let frames = gradtac_io::arrow_ipc::open(&cfg, sensor)?;
            let n = frames.decoder().taxel_count();
            if n.is_some() {
                (Box::new(frames.map(move |r| r.map_err(err))), n, None)
            } else {
                // values of a list type: the taxel count is each row's; checked here, at the
                // source with its file, not by the first stage
                let (want, layout, path) = (p.layout.len(), p.layout.name().to_string(), cfg.path.clone());
                let checked = frames.map(move |r| {
                    let f = r.map_err(err)?;
                    if f.values.len() != want {
                        return Err(err(gradtac_io::Error::Arrow {
                            context: format!("{}: sensor {} frame {}", path.display(), f.sensor, f.seq),
                            reason: format!("{} taxel values, but layout {layout} has {want} taxels", f.values.len()),
                        }));
                    }
                    Ok(f)
                });
                (Box::new(checked), n, None)
            }
        }
    })
}

/// A bus being read, and where its fault counts go.
struct OpenBus {
    name: String,
    stats_path: Option<PathBuf>,
    stats: StatsHandle,
}

/// Open one CAN bus as a stream of the frames of every sensor it carries.
fn open_bus(scene: &Scene, bus: &BusSpec) -> Result<(FrameStream, OpenBus), Error> {
    // a malformed line of the log names the bus besides its file and line
    let name = bus.name.clone();
    let err = move |e: gradtac_io::Error| {
        gradtac_stream::Error::from(match e {
            gradtac_io::Error::Parse { path, line, column, reason } => {
                gradtac_io::Error::Parse { path, line, column, reason: format!("bus {name:?}: {reason}") }
            }
            other => other,
        })
    };
    // an error opening the bus names the scene file and the bus
    let at =
        |e: gradtac_io::Error| Error::Scene { path: scene.origin.clone(), reason: format!("bus {:?}: {e}", bus.name) };
    let (stream, stats): (FrameStream, StatsHandle) = match &bus.source {
        BusSource::Candump(cfg) => {
            let cfg = CandumpConfig { path: scene.resolve(&cfg.path), ..cfg.clone() };
            let s = gradtac_io::can::candump::replay(&cfg).map_err(at)?;
            let h = s.stats_handle();
            (Box::pin(s.map(move |r| r.map_err(&err))), h)
        }
        #[cfg(target_os = "linux")]
        BusSource::Live(cfg) => {
            let s = gradtac_io::can::socketcan::open(cfg).map_err(at)?;
            let h = s.stats_handle();
            (Box::pin(s.map(move |r| r.map_err(&err))), h)
        }
    };
    let stats_path = bus.stats.as_ref().map(|p| scene.resolve(p));
    Ok((stream, OpenBus { name: bus.name.clone(), stats_path, stats }))
}

/// Open the sources of the sensors the plan runs: a stream per file source and per bus
/// (opened once, whatever the number of its sensors), plus progress handles.
fn open_sources(scene: &Scene, plan: &Plan) -> Result<OpenSources, Error> {
    let mut streams: Vec<FrameStream> = Vec::new();
    let mut progress = Vec::new();
    let mut buses: Vec<OpenBus> = Vec::new();
    let mut bags: Vec<PathBuf> = Vec::new();
    for p in plan.sensors.iter().filter(|p| p.is_read()) {
        if let SourceSpec::Bus { bus } = &scene.sensors[p.index].source {
            if !buses.iter().any(|b| &b.name == bus) {
                let spec = scene.buses.iter().find(|b| &b.name == bus).expect("validated by Scene");
                let (stream, open) = open_bus(scene, spec)?;
                streams.push(stream);
                buses.push(open);
            }
            continue;
        }
        if let SourceSpec::Rosbag(cfg) | SourceSpec::Mcap(cfg) = &scene.sensors[p.index].source {
            let path = scene.resolve(&cfg.path);
            if !bags.contains(&path) {
                streams.push(crate::recorded::open(scene, plan, &path)?);
                bags.push(path);
            }
            continue;
        }
        let (it, taxels, prog) = open_source(scene, p)?;
        if let Some(n) = taxels.filter(|&n| n != p.layout.len()) {
            return Err(Error::Scene {
                path: scene.resolve(scene.sensors[p.index].source.path()),
                reason: format!(
                    "sensor {}: the source has {n} taxel columns but layout {} has {} taxels",
                    p.name,
                    p.layout.name(),
                    p.layout.len()
                ),
            });
        }
        progress.extend(prog);
        streams.push(Box::pin(gradtac_io::blocking_stream_chunked(it, 1024, 256)));
    }
    Ok(OpenSources { streams, progress, buses })
}

/// What [`open_sources`] opened.
struct OpenSources {
    /// One stream per file source and per bus.
    streams: Vec<FrameStream>,
    /// Progress of the CSV sources.
    progress: Vec<CsvProgress>,
    /// The buses, for their fault counts.
    buses: Vec<OpenBus>,
}

/// Report each bus's fault counts, and write them where the scene asks.
fn report_buses(buses: &[OpenBus]) -> Result<Vec<(String, String)>, Error> {
    let mut lines = Vec::new();
    for b in buses {
        let stats = b.stats.snapshot();
        if let Some(p) = &b.stats_path {
            let json = serde_json::to_string_pretty(&stats).expect("stats serialise");
            std::fs::write(p, json).map_err(|source| Error::Io { path: p.clone(), source })?;
        }
        lines.push((b.name.clone(), stats.to_string()));
    }
    Ok(lines)
}

/// The run's progress bar: indicatif's with the `cli` feature, nothing without it.
mod progress_bar {
    #[cfg(feature = "cli")]
    pub(super) use indicatif::ProgressBar as Bar;

    /// A bar over `total` bytes.
    #[cfg(feature = "cli")]
    pub(super) fn new(total: u64) -> Bar {
        let bar = indicatif::ProgressBar::new(total);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {wide_bar} {bytes}/{total_bytes} {msg}",
            )
            .expect("valid template"),
        );
        bar
    }

    /// Without the `cli` feature a bar draws nothing.
    #[cfg(not(feature = "cli"))]
    pub(super) struct Bar;

    #[cfg(not(feature = "cli"))]
    impl Bar {
        pub(super) fn set_position(&self, _: u64) {}
        pub(super) fn abandon_with_message(&self, _: &'static str) {}
        pub(super) fn finish_and_clear(&self) {}
    }

    #[cfg(not(feature = "cli"))]
    pub(super) fn new(_total: u64) -> Bar {
        Bar
    }
}

/// The runner of a run: every chain on the runner's thread, or on chain threads
/// ([`crate::parallel`]); the outputs are the same byte for byte.
enum Engine {
    Serial(Runner),
    Parallel(crate::parallel::Parallel),
}

impl Engine {
    fn new(scene: &Scene, plan: &Plan, threads: usize, memory: Option<&MemoryOutputs>) -> Result<Engine, Error> {
        let threads = if threads == 0 { crate::batch::available_threads() } else { threads };
        let chains = plan.sensors.iter().filter(|p| p.is_read()).count();
        Ok(if threads > 1 && chains > 1 {
            Engine::Parallel(crate::parallel::Parallel::new(scene, plan, threads, memory)?)
        } else {
            Engine::Serial(Runner::new_in(scene, plan, memory)?)
        })
    }

    /// Hand the view to the runner (the engine is serial whenever a view is set).
    #[cfg(feature = "view")]
    fn set_view(&mut self, scene: &Scene, plan: &Plan, view: Option<crate::view::ViewHandle>) {
        match self {
            Engine::Serial(r) => r.set_view(scene, plan, view),
            Engine::Parallel(_) => debug_assert!(view.is_none(), "a view runs the chains serially"),
        }
    }

    /// Push frames in time order (the serial runner stops at the first error).
    fn push_batch(&mut self, frames: Vec<TaxelFrame>) -> Result<(), Error> {
        match self {
            Engine::Serial(r) => frames.into_iter().try_for_each(|f| r.push(f)),
            Engine::Parallel(p) => p.push_batch(frames),
        }
    }

    /// Write everything pushed so far before waiting for input.
    fn drain(&mut self) -> Result<(), Error> {
        match self {
            Engine::Serial(_) => Ok(()),
            Engine::Parallel(p) => p.drain(),
        }
    }

    fn frames_in(&self) -> Vec<(String, u64)> {
        match self {
            Engine::Serial(r) => r.frames_in(),
            Engine::Parallel(p) => p.frames_in(),
        }
    }

    fn finish(self) -> Result<Vec<(Vec<PathBuf>, u64)>, Error> {
        match self {
            Engine::Serial(r) => r.finish(),
            Engine::Parallel(p) => p.finish(),
        }
    }

    fn abort(self) -> Vec<PathBuf> {
        match self {
            Engine::Serial(r) => r.abort(),
            Engine::Parallel(p) => p.abort(),
        }
    }
}

/// Frames taken from the merged stream at once while it has them ready (one hand-over to the
/// chain threads per batch).
const BATCH_FRAMES: usize = 512;

/// Run a scene on a tokio runtime (see the [module docs](self)).
pub async fn run(scene: &Scene, plan: &Plan, opts: &RunOptions) -> Result<RunReport, Error> {
    run_in(scene, plan, opts, None).await
}

/// [`run`], with the outputs (and no bus statistics file) in `memory` when given.
pub async fn run_in(
    scene: &Scene,
    plan: &Plan,
    opts: &RunOptions,
    memory: Option<&MemoryOutputs>,
) -> Result<RunReport, Error> {
    use futures::FutureExt as _;
    let start = Instant::now();
    let OpenSources { streams, progress, mut buses } = open_sources(scene, plan)?;
    if memory.is_some() {
        buses.iter_mut().for_each(|b| b.stats_path = None);
    }
    // a rerun view is fed from the runner's thread: with a view the chains run there too
    #[cfg(feature = "view")]
    let threads = if opts.view.is_some() { 1 } else { opts.threads };
    #[cfg(not(feature = "view"))]
    let threads = opts.threads;
    let mut runner = Engine::new(scene, plan, threads, memory)?;
    #[cfg(feature = "view")]
    runner.set_view(scene, plan, opts.view.clone());
    let bar = opts.progress.then(|| progress_bar::new(progress.iter().filter_map(CsvProgress::total_bytes).sum()));
    let mut merged = merge_streams(streams, 256);
    let ctrl_c = tokio::signal::ctrl_c();
    tokio::pin!(ctrl_c);
    let mut interrupted = false;
    let mut n: u64 = 0;
    let mut batch: Vec<TaxelFrame> = Vec::with_capacity(BATCH_FRAMES);
    let mut ended = false;
    while !ended {
        // wait for a frame (writing out what is in flight first), then take what else is ready
        let mut waited = None;
        if let Err(e) = runner.drain() {
            waited = Some(Err(e));
        } else {
            let item = tokio::select! {
                biased;
                _ = &mut ctrl_c => { interrupted = true; break; }
                item = merged.next() => item,
            };
            let mut next = item;
            loop {
                match next {
                    Some(Ok(frame)) => batch.push(frame),
                    Some(Err(e)) => {
                        waited = Some(Err(Error::from_pipeline(e)));
                        break;
                    }
                    None => {
                        ended = true;
                        break;
                    }
                }
                if batch.len() >= BATCH_FRAMES {
                    break;
                }
                match merged.next().now_or_never() {
                    Some(item) => next = item,
                    None => break,
                }
            }
        }
        let taken = batch.len() as u64;
        // the frames before a source error are processed, as one frame at a time would
        let mut pushed = runner.push_batch(std::mem::take(&mut batch));
        if pushed.is_ok() {
            if let Some(e) = waited {
                pushed = e;
            }
        }
        if let Err(e) = pushed {
            if let Some(b) = &bar {
                b.abandon_with_message("failed");
            }
            let _ = report_buses(&buses);
            let partial = runner.abort();
            tracing::warn!(?partial, "run failed; outputs left under their temporary names");
            return Err(e);
        }
        let before = n;
        n += taken;
        if let Some(b) = bar.as_ref().filter(|_| n / 4096 != before / 4096) {
            b.set_position(progress.iter().map(CsvProgress::bytes_read).sum());
        }
    }
    if let Some(b) = &bar {
        b.set_position(progress.iter().map(CsvProgress::bytes_read).sum());
        b.finish_and_clear();
    }
    let frames = runner.frames_in();
    let outputs = runner.finish()?;
    let buses = report_buses(&buses)?;
    Ok(RunReport { frames, outputs, buses, seconds: start.elapsed().as_secs_f64(), interrupted })
}

/// [`run`] on a fresh tokio runtime, for synchronous callers (the CLI).
pub fn run_blocking(scene: &Scene, plan: &Plan, opts: &RunOptions) -> Result<RunReport, Error> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .map_err(|source| Error::Io { path: PathBuf::from("<tokio runtime>"), source })?;
    rt.block_on(run(scene, plan, opts))
}

/// [`run_blocking`] with the outputs in `memory` when given ([`crate::memory::run`]).
pub fn run_blocking_in(
    scene: &Scene,
    plan: &Plan,
    opts: &RunOptions,
    memory: Option<&MemoryOutputs>,
) -> Result<RunReport, Error> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .map_err(|source| Error::Io { path: PathBuf::from("<tokio runtime>"), source })?;
    rt.block_on(run_in(scene, plan, opts, memory))
}

/// Read the frames of one sensor of `scene` (any source kind: files, a bus, a bag) in time
/// order and hand each to `each`, which returns `false` to stop; stops after `max_frames`.
/// Returns the number of frames handed over. Used by `gradtac calibrate` and `explain`.
pub fn for_each_frame(
    scene: &Scene,
    sensor: &str,
    max_frames: u64,
    mut each: impl FnMut(TaxelFrame) -> Result<bool, Error>,
) -> Result<u64, Error> {
    let index = scene.sensors.iter().position(|s| s.name == sensor).ok_or_else(|| Error::Scene {
        path: scene.origin.clone(),
        reason: format!("no sensor {sensor:?} in the scene"),
    })?;
    let layout = scene.layout(&scene.sensors[index])?;
    let plan = Plan {
        sensors: vec![SensorPlan {
            index,
            name: sensor.to_string(),
            layout,
            needed: vec![Tap::Source],
            outputs: Vec::new(),
        }],
    };
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .map_err(|source| Error::Io { path: PathBuf::from("<tokio runtime>"), source })?;
    rt.block_on(async {
        let OpenSources { streams, .. } = open_sources(scene, &plan)?;
        let mut merged = merge_streams(streams, 256);
        let id = SensorId::new(sensor);
        let mut n = 0u64;
        while n < max_frames {
            match merged.next().await {
                Some(Ok(f)) if f.sensor == id => {
                    n += 1;
                    if !each(f)? {
                        break;
                    }
                }
                Some(Ok(_)) => {}
                Some(Err(e)) => return Err(Error::from_pipeline(e)),
                None => break,
            }
        }
        Ok(n)
    })
}
