//! The embedded default run by `gradtac demo`: a simulated two-finger grasp that slips,
//! through the whole pipeline, with outputs, plots and errors against ground truth.
//!
//! 1. [`gradtac_stages::sim`] simulates a first finger (`ff`) and a thumb (`th`) holding an
//!    object (5 N, 5 mm contacts) that slips down 6 mm at 20 mm/s from t = 1 s; the raw
//!    counts go to `recording.csv`, the ground truth to `truth.csv`.
//! 2. The embedded [`DEMO_SCENE`] reads the recording per sensor and writes events, surfaces,
//!    contours, tracks and slip events to Parquet (`out/`). It has no `[stages.*]` table:
//!    every stage runs with its defaults (the taxel-centroid locator; the displacement slip
//!    rule on the raw-frame pattern evidence; `gradtac explain` prints every value). Before
//!    the defaults took over, the scene carried the event-contour settings of the old slip
//!    tests and printed the same contact errors (the locator default was already the
//!    centroid) and a slip onset error of −0.040 s; the track-based displacement rule then
//!    printed −0.075 s; the pattern evidence printed −0.020 s, and the onset fit chosen for
//!    the widened grasp family (smooth starts tried, lead 0.045 s) printed −0.035 s; the
//!    next onset fit (cubic starts, a drift before the onset, the fingers weighted by their
//!    fits' clarity, lead 0.03 s) −0.020 s; the current one, which reads a per-frame model
//!    fit's contact point (lead 0.025 s), printed −0.074 s, and since stop 31, when the slip
//!    stage stopped depending on the order of same-time inputs, −0.051 s; since stop 31b,
//!    which dates a slip at the earliest clear finger (`onset_fingers = "clear_earliest"`,
//!    lead 0.010 s, chosen on the tuning members), it prints **−0.080 s** (over 500 held-out
//!    grasps of the widened model family the median onset error is 45 ms, mean signed −5 ms,
//!    against 43 / −1 ms for stop 31's `weighted`, 50 ms and −2 ms for the energy-position
//!    estimate and 160 ms for the track-velocity rule — `gradtac_stages::slip`).
//!
//!    **Why `slip_eval` once printed −0.050 s where the demo printed −0.074 s.** Not the CSV:
//!    its counts are integers written exactly, and its rate-timed rows carry the simulator's
//!    timestamps to the nanosecond (both checked frame by frame). The difference was the
//!    order of the two fingers' frames *at the same timestamp*. The simulator interleaves each
//!    time step as thumb, then first finger; the scene's runner merges its sources by time and
//!    breaks ties by the scene's sensor order (`ff` first). The slip stage used to decide at
//!    the first input that completed its condition, and the onset fit then read both
//!    fingers' position histories as they were at that moment — so on the deciding step one
//!    finger had one point more in one order than in the other, 24 ms of onset on this grasp.
//!    The stage now decides a time step once every input of it is in
//!    (`gradtac_stages::slip::Slip::push_input`, "Same-time inputs"), and both orders give
//!    the same onset: the test below checks that the scene run over the CSV, the stage fed the
//!    frames in the scene's order ([`frames_in_scene_order`]) and in the simulator's order
//!    give identical slip events.
//! 3. The demo reads the tracks and slip events back and compares them with the truth:
//!    contact localisation error (mm and fraction of sensor width) and slip class and onset.

use crate::plot::{
    plot_slip_timeline, plot_surface_with_contours, plot_trajectory_vs_truth, SurfacePanel, TimelineTrack,
};
use crate::run::{run_blocking, RunOptions, RunReport};
use crate::{Error, Plan, Scene};
use arrow_array::{Array, FixedSizeListArray, Float64Array, RecordBatch, StringArray, UInt64Array};
use gradtac_stages::interpolate::Grid;
use gradtac_stages::sim::{GraspConfig, Recording, Scene as SimScene, SensorModel, Simulator};
use gradtac_stages::slip::SlipClass;
use gradtac_stages::slip::SlipEvent;
use gradtac_stream::Layout;
use gradtac_stream::Timestamp;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Sample rate of the simulated recording (Hz).
pub const RATE_HZ: f64 = 100.0;

/// The seed of the demo's recording.
pub const DEMO_SEED: u64 = 7;

/// The slip the demo simulates.
pub const DEMO_SLIP: SlipClass = SlipClass::LongitudinalDown;

/// The demo's scene, over `recording.csv` in the same directory.
pub const DEMO_SCENE: &str = r#"# gradtac demo: a simulated two-finger grasp (first finger `ff`, thumb `th`) that slips.
[[sensor]]
name = "ff"
layout = "biotac-sp"
source = { csv = "recording.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }

[[sensor]]
name = "th"
layout = "biotac-sp"
source = { csv = "recording.csv", columns = "th_e{1..24}", rate_hz = 100.0 }

# no [stages.*] tables: every stage runs with its defaults (`gradtac explain scene.toml`
# prints them)

[[output]]
tap = "events"
path = "out/events.parquet"

[[output]]
tap = "surface"
path = "out/surfaces.parquet"

[[output]]
tap = "contour"
path = "out/contours.parquet"

[[output]]
tap = "track"
path = "out/tracks.parquet"

[[output]]
tap = "slip"
path = "out/slip.parquet"
"#;

/// What the demo did and how well.
#[derive(Clone, Debug)]
pub struct DemoReport {
    /// The run's report.
    pub run: RunReport,
    /// The scene file written.
    pub scene: PathBuf,
    /// The recording and its ground truth.
    pub recording: PathBuf,
    /// The ground-truth CSV.
    pub truth: PathBuf,
    /// Per sensor: contact frames compared, mean and worst localisation error (mm).
    pub localisation: Vec<(String, usize, f64, f64)>,
    /// Sensor width used for the ratios (mm).
    pub sensor_width_mm: f64,
    /// The first slip event: class and onset (s), if any.
    pub first_slip: Option<(String, f64)>,
    /// The simulated slip and its onset (s).
    pub true_slip: (SlipClass, f64),
    /// The PNG plots written.
    pub plots: Vec<PathBuf>,
}

impl std::fmt::Display for DemoReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.run)?;
        writeln!(f, "errors against ground truth (sensor width {:.1} mm):", self.sensor_width_mm)?;
        for (s, n, mean, worst) in &self.localisation {
            writeln!(
                f,
                "  {s}: contact location over {n} frames: mean {mean:.2} mm ({:.3} of width), worst {worst:.2} mm ({:.3})",
                mean / self.sensor_width_mm,
                worst / self.sensor_width_mm
            )?;
        }
        let (class, onset) = self.true_slip;
        match &self.first_slip {
            Some((c, t)) => writeln!(
                f,
                "  slip: detected {c} with onset {t:.3} s; truth {} at {onset:.3} s (onset error {:+.3} s){}",
                class.name(),
                t - onset,
                if c == class.name() { "" } else { "  <- wrong class" }
            ),
            None => writeln!(f, "  slip: none detected; truth {} at {onset:.3} s", class.name()),
        }
    }
}

/// The sensor width the demo and the trade-off table (`docs/tradeoff.md`) use: the layout's
/// extent along x, i.e. the taxels' bounding box plus the layout's 2 mm margin on each side
/// (26.6 mm for the BioTac SP; the taxels alone span 22.6 mm).
pub fn sensor_width_mm(layout: &Layout) -> f64 {
    layout.extent().width()
}

/// Simulate the demo's grasp (deterministic for `seed`).
pub fn simulate(seed: u64) -> Result<Recording, Error> {
    let layout = Layout::biotac_sp();
    let sim = Simulator::try_new(layout.clone(), SensorModel::default(), seed)?;
    Ok(sim.run(&SimScene::grasp(DEMO_SLIP, &GraspConfig::default(), &layout))?)
}

/// The recording's frames in the order the demo's scene hands them to its stages: by time,
/// ties broken by the scene's sensor order (`ff`, then `th`), as the runner's merge of the
/// two CSV sources does. The simulator interleaves each time step the other way round
/// (thumb first); until stop 31 the slip stage's onset depended on that tie order (see the
/// module docs), and it no longer does — replays that mean to reproduce every stage of
/// `gradtac demo` input for input still use this order.
pub fn frames_in_scene_order(rec: &Recording) -> Vec<gradtac_stream::TaxelFrame> {
    let rank = |f: &gradtac_stream::TaxelFrame| {
        SCENE_SENSORS.iter().position(|s| f.sensor.as_str() == *s).unwrap_or(usize::MAX)
    };
    let mut frames: Vec<gradtac_stream::TaxelFrame> = rec.frames.iter().map(|f| f.frame.clone()).collect();
    frames.sort_by_key(|f| (f.time, rank(f)));
    frames
}

/// The sensors of [`DEMO_SCENE`], in the scene's order.
pub const SCENE_SENSORS: [&str; 2] = ["ff", "th"];

/// Run the demo in `dir` (created if missing).
pub fn run_demo(dir: &Path, progress: bool) -> Result<DemoReport, Error> {
    run_demo_with(dir, &RunOptions { progress, ..RunOptions::default() })
}

/// [`run_demo`] with the run's options (a progress bar; with the `view` feature, a rerun view).
pub fn run_demo_with(dir: &Path, options: &RunOptions) -> Result<DemoReport, Error> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| Error::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    // the demo writes recording.csv, truth.csv and scene.toml: only into a fresh directory or
    // over an earlier demo's files, never over a user's files of those names
    let earlier_demo = std::fs::read_to_string(dir.join("scene.toml")).is_ok_and(|t| t == DEMO_SCENE);
    if !earlier_demo {
        for name in ["scene.toml", "recording.csv", "truth.csv"] {
            let p = dir.join(name);
            if std::fs::symlink_metadata(&p).is_ok() {
                return Err(Error::Io {
                    path: p,
                    source: std::io::Error::new(
                        std::io::ErrorKind::AlreadyExists,
                        "exists and is not from an earlier demo; the demo will not replace it (choose another --dir)",
                    ),
                });
            }
        }
    }
    let rec = simulate(DEMO_SEED)?;
    let (recording, truth) = (dir.join("recording.csv"), dir.join("truth.csv"));
    rec.write_csv(&recording, &truth).map_err(io(&recording))?;
    let scene_path = dir.join("scene.toml");
    std::fs::write(&scene_path, DEMO_SCENE).map_err(io(&scene_path))?;
    let scene = Scene::load(&scene_path)?;
    let plan = Plan::new(&scene)?;
    let run = run_blocking(&scene, &plan, options)?;

    let layout = Layout::biotac_sp();
    let mut localisation = Vec::new();
    let tracks = read_tracks(&dir.join("out/tracks.parquet"))?;
    for sensor in ["ff", "th"] {
        let errs: Vec<f64> = tracks
            .iter()
            .filter(|t| t.0 == sensor && t.3.is_finite())
            .filter_map(|(s, seq, _, x, y)| {
                let [tx, ty] = rec.truth(s, *seq)?.contact_mm?;
                Some((x - tx).hypot(y - ty))
            })
            .collect();
        let mean = errs.iter().sum::<f64>() / errs.len().max(1) as f64;
        let worst = errs.iter().copied().fold(0.0, f64::max);
        localisation.push((sensor.to_string(), errs.len(), mean, worst));
    }
    let slips = read_slip_events(&dir.join("out/slip.parquet"))?;
    let first_slip =
        slips.iter().find(|e| e.class.is_slip()).map(|e| (e.class.name().to_string(), e.onset.as_secs_f64()));
    let onset = GraspConfig::default().onset_s;
    let plots = draw_plots(dir, &scene, &rec, &tracks, &slips)?;
    Ok(DemoReport {
        run,
        scene: scene_path,
        recording,
        truth,
        localisation,
        sensor_width_mm: sensor_width_mm(&layout),
        first_slip,
        true_slip: (DEMO_SLIP, onset),
        plots,
    })
}

/// The demo's figures: ff's surface and maximal contour at four instants, each finger's track
/// against the truth, and the slip timeline.
fn draw_plots(
    dir: &Path,
    scene: &Scene,
    rec: &Recording,
    tracks: &[TrackRow],
    slips: &[SlipEvent],
) -> Result<Vec<PathBuf>, Error> {
    let layout = Layout::biotac_sp();
    let out = dir.join("plots");
    std::fs::create_dir_all(&out).map_err(|source| Error::Io { path: out.clone(), source })?;
    let mut written = Vec::new();

    // surfaces at a few instants around the slip
    let grid = Grid::from_config(&scene.stages.resolved().surface.grid, &layout)?;
    let surfaces = read_surfaces(&dir.join("out/surfaces.parquet"), "ff")?;
    let panels: Vec<SurfacePanel> = [0.6, 1.05, 1.2, 1.35]
        .iter()
        .filter_map(|&t| {
            let (seq, values) = surfaces.iter().min_by_key(|(q, _)| (*q as f64 - t * RATE_HZ).abs() as u64)?;
            let truth = rec.truth("ff", *seq).and_then(|tr| tr.contact_mm);
            Some(SurfacePanel {
                label: format!("t = {:.2} s", *seq as f64 / RATE_HZ),
                values: values.clone(),
                contour: None,
                truth,
            })
        })
        .collect();
    let p = out.join("surfaces_ff.png");
    plot_surface_with_contours(&grid, &panels, Some(&layout), "ff: event surface and maximal contour", &p)?;
    written.push(p);

    // each finger's track against the truth
    let mut per_sensor = Vec::new();
    for sensor in ["ff", "th"] {
        let track: Vec<(f64, f64, f64)> = tracks.iter().filter(|t| t.0 == sensor).map(|t| (t.2, t.3, t.4)).collect();
        let truth: Vec<(f64, f64, f64)> = rec
            .of_sensor(sensor)
            .map(|f| {
                let [x, y] = f.truth.contact_mm.unwrap_or([f64::NAN, f64::NAN]);
                (f.frame.time.as_secs_f64(), x, y)
            })
            .collect();
        let p = out.join(format!("trajectory_{sensor}.png"));
        plot_trajectory_vs_truth(&track, &truth, &layout, &p)?;
        written.push(p);
        per_sensor.push((sensor, track));
    }

    // the slip timeline
    let lines: Vec<TimelineTrack<'_>> =
        per_sensor.iter().map(|(s, points)| TimelineTrack { sensor: s, points }).collect();
    let truth: Vec<(f64, SlipClass)> =
        rec.of_sensor("ff").map(|f| (f.frame.time.as_secs_f64(), f.truth.slip)).collect();
    let p = out.join("slip_timeline.png");
    plot_slip_timeline(&lines, slips, &truth, &p)?;
    written.push(p);
    Ok(written)
}

fn parquet_batches(path: &Path) -> Result<Vec<arrow_array::RecordBatch>, Error> {
    let bad = |e: &dyn std::fmt::Display| Error::Scene { path: path.to_path_buf(), reason: e.to_string() };
    let file = std::fs::File::open(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    let reader = ParquetRecordBatchReaderBuilder::try_new(file).map_err(|e| bad(&e))?.build().map_err(|e| bad(&e))?;
    reader.map(|b| b.map_err(|e| bad(&e))).collect()
}

fn column<'a, T: 'static>(b: &'a arrow_array::RecordBatch, name: &str) -> &'a T {
    b.column_by_name(name).and_then(|c| c.as_any().downcast_ref::<T>()).expect("schema documented in docs/schemas.md")
}

/// (sensor, seq, t s, x mm, y mm) of one track point.
type TrackRow = (String, u64, f64, f64, f64);

/// The nanoseconds of a time column (`Duration(ns)` for the demo's rate-timed source, or
/// `Timestamp(ns)`).
fn nanos(b: &RecordBatch, name: &str) -> Vec<i64> {
    use arrow_array::cast::AsArray;
    use arrow_array::types::{DurationNanosecondType, TimestampNanosecondType};
    let c = b.column_by_name(name).expect("schema documented in docs/schemas.md");
    match c.as_primitive_opt::<DurationNanosecondType>() {
        Some(d) => d.values().to_vec(),
        None => c.as_primitive::<TimestampNanosecondType>().values().to_vec(),
    }
}

/// A float column's value, NaN where it is null (an absent value).
fn value_or_nan(a: &Float64Array, i: usize) -> f64 {
    if a.is_null(i) {
        f64::NAN
    } else {
        a.value(i)
    }
}

/// Every track point of a `track/2` or `track/3` file.
fn read_tracks(path: &Path) -> Result<Vec<TrackRow>, Error> {
    let mut out = Vec::new();
    for b in parquet_batches(path)? {
        let (s, q, t) = (column::<StringArray>(&b, "sensor"), column::<UInt64Array>(&b, "seq"), nanos(&b, "time"));
        let (x, y) = (column::<Float64Array>(&b, "x_mm"), column::<Float64Array>(&b, "y_mm"));
        out.extend(
            (0..b.num_rows()).map(|i| {
                (s.value(i).to_string(), q.value(i), t[i] as f64 * 1e-9, value_or_nan(x, i), value_or_nan(y, i))
            }),
        );
    }
    Ok(out)
}

/// (seq, row-major values) of one sensor's surfaces (`surface/2`).
fn read_surfaces(path: &Path, sensor: &str) -> Result<Vec<(u64, Vec<f64>)>, Error> {
    let mut out = Vec::new();
    for b in parquet_batches(path)? {
        let (s, q) = (column::<StringArray>(&b, "sensor"), column::<UInt64Array>(&b, "seq"));
        let v = column::<FixedSizeListArray>(&b, "values");
        for i in (0..b.num_rows()).filter(|&i| s.value(i) == sensor) {
            let row = v.value(i);
            let row = row.as_any().downcast_ref::<Float64Array>().expect("surface/1 values are f64");
            out.push((q.value(i), row.values().to_vec()));
        }
    }
    Ok(out)
}

/// The slip events (`slip/2`).
fn read_slip_events(path: &Path) -> Result<Vec<SlipEvent>, Error> {
    let class = |name: &str| SlipClass::ALL.into_iter().find(|c| c.name() == name).unwrap_or_default();
    let mut out = Vec::new();
    for b in parquet_batches(path)? {
        let (c, p) = (column::<StringArray>(&b, "class"), column::<StringArray>(&b, "previous"));
        let ns = |name: &str, i: usize| Timestamp(nanos(&b, name)[i]);
        let (l, r) = (column::<Float64Array>(&b, "common_mm_s"), column::<Float64Array>(&b, "differential_mm_s"));
        out.extend((0..b.num_rows()).map(|i| SlipEvent {
            time: ns("time", i),
            onset: ns("onset", i),
            first_seen: ns("first_seen", i),
            class: class(c.value(i)),
            previous: class(p.value(i)),
            common_mm_s: value_or_nan(l, i),
            differential_mm_s: value_or_nan(r, i),
        }));
    }
    Ok(out)
}

/// A fresh directory for a demo run under the system's temporary directory.
pub fn fresh_dir() -> Result<PathBuf, Error> {
    let stamp = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let base = std::env::temp_dir();
    for k in 0..1000u32 {
        let dir = base.join(format!("gradtac-demo-{stamp}-{}-{k}", std::process::id()));
        match std::fs::create_dir(&dir) {
            Ok(()) => return Ok(dir),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(source) => return Err(Error::Io { path: dir, source }),
        }
    }
    Err(Error::Io { path: base, source: std::io::Error::other("no fresh directory name left") })
}

/// The demo's closing lines: where everything is.
pub fn where_lines(r: &DemoReport, dir: &Path) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "demo directory: {}", dir.display());
    let _ = writeln!(s, "  scene:     {}", r.scene.display());
    let _ = writeln!(s, "  recording: {}", r.recording.display());
    let _ = writeln!(s, "  truth:     {}", r.truth.display());
    for (files, _) in &r.run.outputs {
        for f in files {
            let _ = writeln!(s, "  output:    {}", f.display());
        }
    }
    for p in &r.plots {
        let _ = writeln!(s, "  plot:      {}", p.display());
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use gradtac_stages::sim_grasp::{slip_inputs, track_points_per_frame};
    use gradtac_stages::slip::Slip;

    /// The demo's CLI path (the scene over `recording.csv`, read back from Parquet) and the
    /// slip stage fed the same frames in memory, in the scene's order, give the same events;
    /// so does the simulator's own order (thumb first), which until stop 31 dated the onset
    /// 24 ms differently (the module docs).
    #[test]
    fn the_scene_run_and_the_in_memory_stage_agree_on_the_demo_grasp() {
        let dir = tempfile::tempdir().unwrap();
        let rec = simulate(DEMO_SEED).unwrap();
        rec.write_csv(&dir.path().join("recording.csv"), &dir.path().join("truth.csv")).unwrap();
        let scene_path = dir.path().join("scene.toml");
        std::fs::write(&scene_path, DEMO_SCENE).unwrap();
        let scene = Scene::load(&scene_path).unwrap();
        run_blocking(&scene, &Plan::new(&scene).unwrap(), &RunOptions::default()).unwrap();
        let cli = read_slip_events(&dir.path().join("out/slip.parquet")).unwrap();

        let cfg = &scene.stages.slip;
        let replay = |frames: &[gradtac_stream::TaxelFrame]| {
            let tracks = track_points_per_frame(frames).unwrap();
            Slip::try_new(cfg).unwrap().run_inputs(slip_inputs(frames, &tracks, cfg).unwrap()).unwrap()
        };
        let frames = frames_in_scene_order(&rec);
        assert_eq!(frames.len(), rec.frames.len());
        assert!(frames.windows(2).all(|w| w[0].time <= w[1].time));
        let in_memory = replay(&frames);
        assert!(in_memory.iter().any(|e| e.class == DEMO_SLIP), "{in_memory:?}");
        assert_eq!(cli, in_memory);

        // the simulator's order (thumb first at each time step): the same events, onset
        // included — the slip stage decides once every input of a time step is in
        let sim_order: Vec<_> = rec.frames.iter().map(|f| f.frame.clone()).collect();
        assert_ne!(sim_order, frames, "the two orders differ");
        assert_eq!(replay(&sim_order), in_memory);
    }
}
