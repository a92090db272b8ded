//! Cost per frame of the default event chain (raw frames → track points, natural neighbour
//! 64 × 64), one variant per run, for measuring under `perf stat` (cycles and instructions do
//! not depend on how loaded the machine is, wall time does).
//!
//! ```text
//! cargo run --release -p gradtac-stages --example chain_cost -- <peak|peak_local|full|full_incremental|front|contour_peak|contour_peak_local|contour_full|digest> [repeats] [recording.csv]
//! ```
//! The recording defaults to `shared/data/biotacsp-dos/aw/bottle0.csv` beside the
//! workspace (or under `$GRADTAC_SHARED_DATA`), tiled 10 times; without it a simulated grasp
//! is used. Prints frames, windows, contacts, wall ns per frame. Every variant runs the stage
//! defaults (the event threshold measured as 4 σ of each taxel's noise); with the suffix
//! `_dense` (`peak_dense`, `digest_dense`, …) the events use a fixed τ = 0.05 instead, the
//! stress case in which nearly every window of the real recording holds a contact.
use gradtac_stages::contour::{Contour, ContourConfig};
use gradtac_stages::events::{Events, EventsConfig, Threshold};
use gradtac_stages::interpolate::{Interpolate, InterpolateConfig};
use gradtac_stages::normalise::{Normalise, NormaliseConfig};
use gradtac_stages::peak::SurfaceContour;
use gradtac_stages::savgol::{SavGol, SavGolConfig};
use gradtac_stages::sim::{GraspConfig, Scene, SensorModel, Simulator};
use gradtac_stages::slip::SlipClass;
use gradtac_stages::track::{Track, TrackConfig};
use gradtac_stages::window::{Window, WindowAggregate, WindowConfig};
use gradtac_stream::{Layout, SensorId, Stage, StageExt, TaxelFrame, Timestamp};
use std::hint::black_box;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The stress case's fixed event threshold (the `_dense` variants): nearly every window of the
/// real recording holds a contact.
const DENSE_TAU: f64 = 0.05;

fn front(n: usize, dense: bool) -> impl Stage<In = TaxelFrame, Out = WindowAggregate, Error = gradtac_stream::Error> {
    let ecfg = if dense {
        EventsConfig { threshold: Threshold::Uniform(DENSE_TAU), ..Default::default() }
    } else {
        EventsConfig::default()
    };
    Normalise::try_new(n, &NormaliseConfig::default())
        .unwrap()
        .then(SavGol::try_with_rate(n, SavGolConfig::default(), 100.0).unwrap())
        .then(Events::try_new(n, ecfg).unwrap())
        .then(Window::try_new(&WindowConfig::default()).unwrap())
}

fn frames(layout: &Layout, path: Option<PathBuf>) -> Vec<TaxelFrame> {
    let data = std::env::var_os("GRADTAC_SHARED_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"));
    let p = path.unwrap_or_else(|| data.join("biotacsp-dos/aw/bottle0.csv"));
    if let Ok(text) = std::fs::read_to_string(&p) {
        let rows: Vec<Vec<f64>> = text
            .lines()
            .skip(1)
            .filter(|l| !l.trim().is_empty())
            .map(|l| l.split(',').map(|x| x.trim().parse().unwrap()).collect())
            .collect();
        let sensor = SensorId::new("ff");
        return (0..rows.len() * 10)
            .map(|k| TaxelFrame {
                sensor: sensor.clone(),
                time: Timestamp(k as i64 * 10_000_000),
                seq: k as u64,
                values: rows[k % rows.len()].clone(),
            })
            .collect();
    }
    eprintln!("{} not found: a simulated grasp instead", p.display());
    let sim = Simulator::try_new(layout.clone(), SensorModel::default(), 1).unwrap();
    let rec = sim.run(&Scene::grasp(SlipClass::LongitudinalDown, &GraspConfig::default(), layout)).unwrap();
    let mut f = rec.taxel_frames();
    let first = f[0].sensor.clone();
    f.retain(|x| x.sensor == first);
    f
}

fn main() {
    let mut args = std::env::args().skip(1);
    let arg = args.next().unwrap_or_else(|| "peak".into());
    let (variant, dense) = match arg.strip_suffix("_dense") {
        Some(v) => (v.to_string(), true),
        None => (arg.clone(), false),
    };
    let repeats: usize = args.next().map_or(20, |s| s.parse().expect("repeats"));
    let layout = Layout::biotac_sp();
    let input = frames(&layout, args.next().map(PathBuf::from));
    let windows = front(layout.len(), dense).run_all(input.clone()).unwrap();
    let icfg = InterpolateConfig::default();
    let ccfg = ContourConfig::default();
    let t0 = Instant::now();
    let mut outputs = 0usize;
    for _ in 0..repeats {
        let f = input.clone();
        outputs += match variant.as_str() {
            "peak" => front(layout.len(), dense)
                .then(SurfaceContour::try_new(&icfg, &ccfg, &layout).unwrap())
                .then(Track::try_new(&TrackConfig::default()).unwrap())
                .run_all(f)
                .unwrap()
                .len(),
            "full" | "full_incremental" => front(layout.len(), dense)
                .then(
                    Interpolate::try_new(
                        &InterpolateConfig { incremental: variant != "full", ..icfg.clone() },
                        &layout,
                    )
                    .unwrap(),
                )
                .then(Contour::try_new(&ccfg).unwrap())
                .then(Track::try_new(&TrackConfig::default()).unwrap())
                .run_all(f)
                .unwrap()
                .len(),
            "front" => front(layout.len(), dense).run_all(f).unwrap().len(),
            "peak_local" => front(layout.len(), dense)
                .then(SurfaceContour::try_new(&icfg, &ccfg, &layout).unwrap().with_peak_local(true))
                .then(Track::try_new(&TrackConfig::default()).unwrap())
                .run_all(f)
                .unwrap()
                .len(),
            "contour_peak_local" => {
                let mut s =
                    SurfaceContour::<WindowAggregate>::try_new(&icfg, &ccfg, &layout).unwrap().with_peak_local(true);
                s.run_all(windows.clone()).unwrap().len()
            }
            "contour_peak" => {
                let mut s = SurfaceContour::<WindowAggregate>::try_new(&icfg, &ccfg, &layout).unwrap();
                s.run_all(windows.clone()).unwrap().len()
            }
            "contour_full" => {
                let mut s = Interpolate::try_new(&icfg, &layout).unwrap().then(Contour::try_new(&ccfg).unwrap());
                s.run_all(windows.clone()).unwrap().len()
            }
            "digest" => {
                // a fingerprint of every output (Debug prints each float exactly): compare it
                // across commits to check that a speed-up changed no bit
                use std::hash::{Hash, Hasher};
                let track = front(layout.len(), dense)
                    .then(SurfaceContour::try_new(&icfg, &ccfg, &layout).unwrap())
                    .then(Track::try_new(&TrackConfig::default()).unwrap())
                    .run_all(f)
                    .unwrap();
                let mut s = Interpolate::try_new(&icfg, &layout).unwrap().then(Contour::try_new(&ccfg).unwrap());
                let contours = s.run_all(windows.clone()).unwrap();
                let mut h = std::collections::hash_map::DefaultHasher::new();
                format!("{track:?}{contours:?}").hash(&mut h);
                let contacts = contours.iter().filter(|c| c.outcome.contact().is_some()).count();
                // a closed stdout (`| head -1`) is not an error of this measurement
                let _ = writeln!(
                    std::io::stdout(),
                    "digest: {:016x} ({} track points, {} contours, {contacts} in contact)",
                    h.finish(),
                    track.len(),
                    contours.len()
                );
                track.len()
            }
            v => panic!("unknown variant {v}"),
        };
        black_box(outputs);
    }
    let per = t0.elapsed().as_nanos() as f64 / (repeats * input.len()) as f64;
    let _ = writeln!(
        std::io::stdout(),
        "{arg}: {} frames × {repeats}, {} windows, {outputs} outputs, {per:.0} ns/frame wall ({:.0} frames/s)",
        input.len(),
        windows.len(),
        1e9 / per
    );
}
