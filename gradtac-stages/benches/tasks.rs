//! Cost of the simulator and the task stages (slip, force, servo), and of a whole simulated
//! two-finger grasp through the chain.
//!
//! Run: `cargo bench -p gradtac-stages --bench tasks`. Inputs are built outside the timed
//! region (`iter_batched`); `Throughput::Elements` gives frames (or points) per second.
//!
//! - `sim/grasp`: simulating a 2 s two-finger grasp (2 × 200 frames of 24 taxels);
//! - `slip/points`: the slip classifier over that grasp's 400 track points;
//! - `force/<method>`: predicting 4096 areas with each fitted model; `force/forward-invert`:
//!   the `forward` model (`force_ident`) inverted for 256 noisy frames, one `(x, y, F)`
//!   solve each (what `[stages.force]` with a `forward` file pays per contact frame);
//! - `servo/points`: the servo over the 400 track points;
//! - `dos/extract-*`: the one-fingertip slip-direction feature extractor over the grasp's first
//!   sensor (200 frames) with the default features, every feature, every feature with surface
//!   centroids; `dos/drift-map` the drift map alone; `dos/classify` one decision;
//!   `dos/sliding-100-hop-10` the classifier stage deciding every 10 frames about the last 100;
//! - `chain/grasp`: raw frames → savgol → events → window → natural neighbour 32 × 32 →
//!   contour → track (per sensor) → slip, for the whole grasp, building both sensors' chains
//!   (natural-neighbour weight tables included) inside the timed region.
//!
//! Medians measured on the 2-core development machine (criterion, 3 s measurement):
//!
//! | bench | median | per item |
//! |---|---|---|
//! | `sim/grasp` (400 frames) | 169 µs | 0.42 µs per frame |
//! | `slip/points` (400 points) | 14.3 µs | 36 ns per point |
//! | `servo/points` (400 points) | 5.6 µs | 14 ns per point |
//! | `force/Linear` (4096 areas) | 24.1 µs | 5.9 ns |
//! | `force/PowerLaw` | 52.3 µs | 12.8 ns |
//! | `force/Exponential` | 29.8 µs | 7.3 ns |
//! | `force/Isotonic` (≈ 200 knots) | 42.0 µs | 10.2 ns |
//! | `force/forward-invert` (256 frames; measured 2026-11-27 with the machine loaded ≈ 5, where `force/Linear` took 43 µs) | 14.3 ms | 56 µs per frame |
//! | `chain/grasp` (400 frames) | 3.17 ms | 7.9 µs per frame (≈ 1/1260 of the 10 ms frame period) |
//! | `dos/extract-default` (200 frames, events + drift map) | 56.7 µs | 0.28 µs per frame |
//! | `dos/extract-all-taxels` (every feature) | 60.6 µs | 0.30 µs per frame |
//! | `dos/extract-all-surface` (every feature, 32 × 32 surfaces per track window) | 129 µs | 0.65 µs per frame |
//! | `dos/drift-map` (200 frames, lags 30/60/120) | 28.0 µs | 0.14 µs per frame |
//! | `dos/classify` (one decision, 7 classes × the then 9 default features, Student t; 667 ns loaded with today's 7) | 347 ns | |
//! | `dos/sliding-100-hop-10` (200 frames: 11 decisions over 100-frame windows) | 295 µs | 1.5 µs per frame, 27 µs per decision |
//!
//! The task stages cost nothing next to the chain before them: slip adds < 0.5 % to a frame.
use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use gradtac_stages::contour::{Contour, ContourConfig};
use gradtac_stages::dos::{
    CentroidMethod, DosClass, DosClassifier, DosFeatureConfig, DosFeatureExtractor, DosModel, Feature,
};
use gradtac_stages::drift::DriftMap;
use gradtac_stages::events::{Events, EventsConfig, Threshold};
use gradtac_stages::force::{ForceMethod, ForceModel, ForceSample};
use gradtac_stages::force_ident::{ForwardModel, Geometry};
use gradtac_stages::force_model::forward_force;
use gradtac_stages::interpolate::{GridConfig, Interpolate, InterpolateConfig};
use gradtac_stages::savgol::{SavGol, SavGolConfig};
use gradtac_stages::servo::{Servo, ServoConfig};
use gradtac_stages::sim::{GraspConfig, Scene, SensorModel, Simulator};
use gradtac_stages::slip::{Slip, SlipClass, SlipConfig, SlipEvidence};
use gradtac_stages::track::{Track, TrackConfig, TrackPoint};
use gradtac_stages::window::{Aggregate, Window, WindowConfig};
use gradtac_stream::{Keyed, Layout, SensorId, Stage, StageExt, TaxelFrame};
use std::hint::black_box;

/// The displacement rule on its track path (these benches feed track points).
fn track_slip() -> SlipConfig {
    SlipConfig { evidence: SlipEvidence::Track, ..SlipConfig::default() }
}

fn track_chain(layout: &Layout) -> impl Stage<In = TaxelFrame, Out = TrackPoint, Error = gradtac_stream::Error> {
    let sg = SavGol::try_with_rate(layout.len(), SavGolConfig::default(), 100.0).unwrap();
    let ev = Events::try_new(layout.len(), EventsConfig { threshold: Threshold::Uniform(0.002), ..Default::default() })
        .unwrap();
    let w =
        Window::try_new(&WindowConfig { frames: Some(10), aggregate: Aggregate::Count, ..Default::default() }).unwrap();
    let icfg = InterpolateConfig {
        grid: GridConfig { nx: 32, ..Default::default() },
        incremental: true,
        ..Default::default()
    };
    let i = Interpolate::try_new(&icfg, layout).unwrap();
    let c = Contour::try_new(&ContourConfig { min_peak: 2.0, min_area_mm2: 60.0, ..Default::default() }).unwrap();
    let t = Track::try_new(&TrackConfig::default()).unwrap();
    sg.then(ev).then(w).then(i).then(c).then(t)
}

fn bench(c: &mut Criterion) {
    let layout = Layout::biotac_sp();
    let sim = Simulator::try_new(layout.clone(), SensorModel::default(), 1).unwrap();
    let scene = Scene::grasp(SlipClass::LongitudinalDown, &GraspConfig::default(), &layout);
    let rec = sim.run(&scene).unwrap();
    let frames = rec.taxel_frames();
    let points = Keyed::new(|_: &SensorId| track_chain(&layout)).run_all(frames.clone()).unwrap();

    let mut g = c.benchmark_group("sim");
    g.throughput(Throughput::Elements(frames.len() as u64));
    g.bench_function("grasp", |b| b.iter(|| black_box(sim.run(black_box(&scene)).unwrap())));
    g.finish();

    let mut g = c.benchmark_group("slip");
    g.throughput(Throughput::Elements(points.len() as u64));
    g.bench_function("points", |b| {
        b.iter_batched(
            || points.clone(),
            |p| black_box(Slip::try_new(&track_slip()).unwrap().run_all(p).unwrap()),
            BatchSize::SmallInput,
        )
    });
    g.finish();

    let mut g = c.benchmark_group("servo");
    g.throughput(Throughput::Elements(points.len() as u64));
    g.bench_function("points", |b| {
        b.iter_batched(
            || points.clone(),
            |p| black_box(Servo::try_new(&ServoConfig::default(), &layout).unwrap().run_all(p).unwrap()),
            BatchSize::SmallInput,
        )
    });
    g.finish();

    let samples: Vec<ForceSample> =
        (1..=200).map(|k| ForceSample { area_mm2: k as f64, force_n: (k as f64 / 40.0).exp() }).collect();
    let areas: Vec<f64> = (0..4096).map(|k| k as f64 * 0.05).collect();
    let mut g = c.benchmark_group("force");
    g.throughput(Throughput::Elements(areas.len() as u64));
    for m in ForceMethod::ALL {
        let model = ForceModel::fit(m, &samples).unwrap();
        g.bench_function(format!("{m:?}"), |b| {
            b.iter(|| areas.iter().map(|&a| model.predict(black_box(a))).sum::<f64>())
        });
    }
    g.finish();

    // The `forward` force model inverted per frame: 256 presses of 0.3–9 N at places over the
    // pad, each the model's own changes plus ±2 counts of deterministic noise.
    let geo = Geometry::for_positions(layout.positions());
    let gains = (0..24)
        .map(|i| -80.0 * (1.0 + 0.3 * (i as f64 * 1.7).sin()) * if [4, 11, 19].contains(&i) { -1.0 } else { 1.0 });
    let model = ForwardModel {
        gains: gains.collect(),
        exponent: 0.7,
        spread: 0.25,
        width_mm: 3.2,
        shape: 2.0,
        lobe: 0.3,
        gain_rel_sd: None,
    };
    let deltas: Vec<Vec<f64>> = (0..256)
        .map(|k| {
            let (x, y, f) = (
                -5.0 + 10.0 * ((k * 37) % 256) as f64 / 255.0,
                -8.0 + (k % 16) as f64,
                0.3 + 8.7 * (k % 29) as f64 / 28.0,
            );
            model
                .predict(&geo, x, y, f)
                .iter()
                .enumerate()
                .map(|(i, d)| d + 2.0 * ((i * 7 + k * 13) as f64).sin())
                .collect()
        })
        .collect();
    let mut g = c.benchmark_group("force");
    g.throughput(Throughput::Elements(deltas.len() as u64));
    g.bench_function("forward-invert", |b| {
        b.iter(|| deltas.iter().map(|d| forward_force(&model, &geo, black_box(d))).sum::<f64>())
    });
    g.finish();

    // One fingertip's raw frames (the grasp's first sensor) through the slip-direction
    // extractor, and one decision.
    let ff: Vec<TaxelFrame> = frames.iter().filter(|f| f.sensor == frames[0].sensor).cloned().collect();
    let mut g = c.benchmark_group("dos");
    g.throughput(Throughput::Elements(ff.len() as u64));
    for (name, features, centroid) in [
        ("extract-default", Feature::DEFAULT.to_vec(), CentroidMethod::Taxels),
        ("extract-all-taxels", Feature::ALL.to_vec(), CentroidMethod::Taxels),
        ("extract-all-surface", Feature::ALL.to_vec(), CentroidMethod::Surface),
    ] {
        let cfg = DosFeatureConfig { features, centroid, ..Default::default() };
        g.bench_function(name, |b| {
            b.iter_batched(
                || (DosFeatureExtractor::try_new(&cfg, &layout).unwrap(), ff.clone()),
                |(mut x, f)| {
                    for fr in f {
                        x.push(fr).unwrap();
                    }
                    black_box(x.features())
                },
                BatchSize::SmallInput,
            )
        });
    }
    let values: Vec<Vec<f64>> = ff.iter().map(|f| f.values.to_vec()).collect();
    g.bench_function("drift-map", |b| {
        b.iter_batched(
            || DriftMap::try_new(24, &[30, 60, 120], 1e-3).unwrap(),
            |mut m| {
                for v in &values {
                    m.push(v).unwrap();
                }
                black_box(m.snapshot())
            },
            BatchSize::SmallInput,
        )
    });
    // one value per default feature (the model refuses any other count)
    let nf = DosFeatureConfig::default().features.len();
    let samples: Vec<(DosClass, Vec<f64>)> = (0..70)
        .map(|k| (DosClass::ALL[k % 7], (0..nf).map(|j| ((k * 7 + j * 3) % 11) as f64 + (k % 7) as f64).collect()))
        .collect();
    let model = DosModel::calibrate(DosFeatureConfig::default(), &samples).unwrap();
    g.bench_function("sliding-100-hop-10", |b| {
        b.iter_batched(
            || {
                let c = DosClassifier::try_new(model.clone(), &layout, Some(100)).unwrap();
                (c.with_hop(10).unwrap(), ff.clone())
            },
            |(c, f)| black_box({ c }.run_all(f).unwrap()),
            BatchSize::SmallInput,
        )
    });
    g.throughput(Throughput::Elements(1));
    let probe: Vec<f64> = (0..nf).map(|j| j as f64 * 0.7).collect();
    g.bench_function("classify", |b| b.iter(|| black_box(model.classify(black_box(&probe)).unwrap())));
    g.finish();

    let mut g = c.benchmark_group("chain");
    g.throughput(Throughput::Elements(frames.len() as u64));
    g.sample_size(20);
    g.bench_function("grasp", |b| {
        b.iter_batched(
            || frames.clone(),
            |f| {
                let keyed = Keyed::new(|_: &SensorId| track_chain(&layout));
                black_box(keyed.then(Slip::try_new(&track_slip()).unwrap()).run_all(f).unwrap())
            },
            BatchSize::SmallInput,
        )
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
