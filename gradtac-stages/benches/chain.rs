//! The default event chain end to end, per raw frame: normalise → Savitzky–Golay → events →
//! window → natural neighbour 64 × 64 → maximal contour → track, every stage at its default
//! settings (those of a bare scene with `[stages.locate] method = "events"`: the event threshold
//! measured as 4 σ of each taxel's noise). `<input>_dense` is the stress case: the same chain
//! with a fixed event threshold τ = 0.05, which puts nearly every window of the real recording
//! in contact, so every window pays the full surface and contour.
//!
//! `cargo bench -p gradtac-stages --bench chain`
//!
//! - `chain/<input>/peak`: surface and contour fused ([`SurfaceContour`], what a scene runs
//!   when no output taps the surface): the whole surface into a reused buffer.
//! - `chain/<input>/peak_local`: the same, evaluating only the blocks of grid points the
//!   maximal contour reads.
//! - `chain/<input>/full`: a new 64 × 64 surface array every frame, then the contour
//!   (`Interpolate` → `Contour`, what a scene runs when the surface is tapped).
//! - `chain/<input>/full_incremental`: the same with `incremental = true`.
//! - `contour_of_window/<input>/{peak,full}`: the surface + contour part alone, per window.
//!
//! Inputs: `real` — one BioTacSP-DoS recording (`shared/data/biotacsp-dos/…`, beside the
//! workspace; skipped when absent) tiled 10 times (2,800 frames at 100 Hz); `sim` — a simulated
//! two-finger grasp's first finger (`gradtac_stages::sim`, seed 1). Each iteration builds the
//! chain (the weight table is shared, so that is cheap) and pushes every frame; throughput is
//! frames per second. The three variants give identical track points (checked before timing).
use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use gradtac_stages::contour::{Contour, ContourConfig};
use gradtac_stages::events::{Events, EventsConfig, Threshold};
use gradtac_stages::interpolate::{Interpolate, InterpolateConfig};
use gradtac_stages::normalise::{Normalise, NormaliseConfig};
use gradtac_stages::peak::SurfaceContour;
use gradtac_stages::savgol::{SavGol, SavGolConfig};
use gradtac_stages::sim::{GraspConfig, Scene, SensorModel, Simulator};
use gradtac_stages::slip::SlipClass;
use gradtac_stages::track::{Track, TrackConfig, TrackPoint};
use gradtac_stages::window::{Window, WindowConfig};
use gradtac_stream::{Layout, SensorId, Stage, StageExt, TaxelFrame, Timestamp};
use std::hint::black_box;
use std::path::{Path, PathBuf};

const RATE_HZ: f64 = 100.0;

/// The BioTacSP-DoS directory beside the workspace (`shared/data`; the environment
/// variable `GRADTAC_SHARED_DATA` names another data directory), if present.
fn dos_dir() -> Option<PathBuf> {
    let data = std::env::var_os("GRADTAC_SHARED_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"));
    let d = data.join("biotacsp-dos");
    d.is_dir().then_some(d)
}

/// One recording's rows (`ff_e1..ff_e24`), parsed with `str::split`.
fn read_csv(path: &Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.split(',').map(|x| x.trim().parse().unwrap()).collect())
        .collect()
}

/// Rows tiled `times` times into frames at 100 Hz with consecutive seq.
pub fn tile(rows: &[Vec<f64>], times: usize) -> Vec<TaxelFrame> {
    let sensor = SensorId::new("ff");
    (0..rows.len() * times)
        .map(|k| TaxelFrame {
            sensor: sensor.clone(),
            time: Timestamp((k as i64) * 10_000_000),
            seq: k as u64,
            values: rows[k % rows.len()].clone(),
        })
        .collect()
}

/// The stress case's fixed event threshold: on the real recording nearly every window holds a
/// contact (2,759 of 2,790), so every window pays the full surface and contour.
const DENSE_TAU: f64 = 0.05;

fn front(
    n: usize,
    dense: bool,
) -> impl Stage<In = TaxelFrame, Out = gradtac_stages::window::WindowAggregate, Error = gradtac_stream::Error> {
    let ecfg = if dense {
        EventsConfig { threshold: Threshold::Uniform(DENSE_TAU), ..Default::default() }
    } else {
        EventsConfig::default()
    };
    Normalise::try_new(n, &NormaliseConfig::default())
        .unwrap()
        .then(SavGol::try_with_rate(n, SavGolConfig::default(), RATE_HZ).unwrap())
        .then(Events::try_new(n, ecfg).unwrap())
        .then(Window::try_new(&WindowConfig::default()).unwrap())
}

fn run_peak(layout: &Layout, frames: Vec<TaxelFrame>, dense: bool, peak_local: bool) -> Vec<TrackPoint> {
    let sc = SurfaceContour::try_new(&InterpolateConfig::default(), &ContourConfig::default(), layout)
        .unwrap()
        .with_peak_local(peak_local);
    let mut c = front(layout.len(), dense).then(sc).then(Track::try_new(&TrackConfig::default()).unwrap());
    c.run_all(frames).unwrap()
}

fn run_full(layout: &Layout, frames: Vec<TaxelFrame>, dense: bool, incremental: bool) -> Vec<TrackPoint> {
    let icfg = InterpolateConfig { incremental, ..Default::default() };
    let mut c = front(layout.len(), dense)
        .then(Interpolate::try_new(&icfg, layout).unwrap())
        .then(Contour::try_new(&ContourConfig::default()).unwrap())
        .then(Track::try_new(&TrackConfig::default()).unwrap());
    c.run_all(frames).unwrap()
}

fn inputs(layout: &Layout) -> Vec<(&'static str, Vec<TaxelFrame>)> {
    let mut v = Vec::new();
    if let Some(d) = dos_dir() {
        let p = d.join("aw/bottle0.csv");
        if p.is_file() {
            v.push(("real", tile(&read_csv(&p), 10)));
        }
    } else {
        eprintln!("chain bench: ../shared/data/biotacsp-dos not found beside the workspace; real input skipped");
    }
    let sim = Simulator::try_new(layout.clone(), SensorModel::default(), 1).unwrap();
    let scene = Scene::grasp(SlipClass::LongitudinalDown, &GraspConfig::default(), layout);
    let rec = sim.run(&scene).unwrap();
    let mut frames = rec.taxel_frames();
    let first = frames[0].sensor.clone();
    frames.retain(|f| f.sensor == first);
    v.push(("sim", frames));
    v
}

fn bench(c: &mut Criterion) {
    let layout = Layout::biotac_sp();
    for (input, frames) in inputs(&layout) {
        for dense in [false, true] {
            let name = if dense { format!("{input}_dense") } else { input.to_string() };
            bench_one(c, &layout, &name, &frames, dense);
        }
    }
}

fn bench_one(c: &mut Criterion, layout: &Layout, name: &str, frames: &[TaxelFrame], dense: bool) {
    let frames = frames.to_vec();
    let peak = format!("{:?}", run_peak(layout, frames.clone(), dense, false));
    // Debug prints every float exactly (shortest round trip) and NaN as NaN
    let same = peak == format!("{:?}", run_full(layout, frames.clone(), dense, false));
    assert!(same, "{name}: fused and full grid disagree");
    assert!(peak == format!("{:?}", run_peak(layout, frames.clone(), dense, true)), "{name}: peak-local differs");
    let windows = front(layout.len(), dense).run_all(frames.clone()).unwrap();
    let mut sc = SurfaceContour::<gradtac_stages::window::WindowAggregate>::try_new(
        &InterpolateConfig::default(),
        &ContourConfig::default(),
        layout,
    )
    .unwrap()
    .with_peak_local(true);
    let contours = sc.run_all(windows.clone()).unwrap();
    let contacts = contours.iter().filter(|c| c.outcome.contact().is_some()).count();
    eprintln!(
        "chain/{name}: {} frames, {} windows, {contacts} contacts; peak-local evaluation: {:.0} grid points per window (of {})",
        frames.len(),
        windows.len(),
        sc.finder().points_evaluated() as f64 / windows.len() as f64,
        sc.finder().interpolator().grid().len()
    );
    // the surface → contour part alone, per window
    let mut g = c.benchmark_group(format!("contour_of_window/{name}"));
    g.throughput(Throughput::Elements(windows.len() as u64));
    g.bench_function("peak", |b| {
        b.iter_batched(
            || windows.clone(),
            |w| {
                let mut sc = SurfaceContour::<gradtac_stages::window::WindowAggregate>::try_new(
                    &InterpolateConfig::default(),
                    &ContourConfig::default(),
                    layout,
                )
                .unwrap();
                black_box(sc.run_all(w).unwrap())
            },
            BatchSize::LargeInput,
        )
    });
    g.bench_function("full", |b| {
        b.iter_batched(
            || windows.clone(),
            |w| {
                let mut st = Interpolate::try_new(&InterpolateConfig::default(), layout)
                    .unwrap()
                    .then(Contour::try_new(&ContourConfig::default()).unwrap());
                black_box(st.run_all(w).unwrap())
            },
            BatchSize::LargeInput,
        )
    });
    g.finish();
    let mut g = c.benchmark_group(format!("chain/{name}"));
    g.throughput(Throughput::Elements(frames.len() as u64));
    g.bench_function("peak", |b| {
        b.iter_batched(|| frames.clone(), |f| black_box(run_peak(layout, f, dense, false)), BatchSize::LargeInput)
    });
    g.bench_function("peak_local", |b| {
        b.iter_batched(|| frames.clone(), |f| black_box(run_peak(layout, f, dense, true)), BatchSize::LargeInput)
    });
    g.bench_function("full", |b| {
        b.iter_batched(|| frames.clone(), |f| black_box(run_full(layout, f, dense, false)), BatchSize::LargeInput)
    });
    g.bench_function("full_incremental", |b| {
        b.iter_batched(|| frames.clone(), |f| black_box(run_full(layout, f, dense, true)), BatchSize::LargeInput)
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(4));
    targets = bench
}
criterion_main!(benches);
