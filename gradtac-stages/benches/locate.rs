//! Benchmarks of the default contact-location chain (`[stages.locate]` defaults: taxel
//! centroid → track) against the event-contour chain in the same run.
//!
//! `cargo bench -p gradtac-stages --bench locate`
//!
//! - `locate/<chain>/<recording>`: raw counts → track points, per input frame (throughput in
//!   frames), on a simulated family member (`sim`, always) and on a BioTacSP-DoS recording
//!   (`dos`, `cw/bottle4.csv` from `shared/data` beside the repository or `$GRADTAC_DOS_DIR`;
//!   skipped when absent).
//!   `<chain>` is `centroid` (the default: speed-bounded centroid → track), `events`
//!   (Savitzky–Golay → events τ = 0.001 → 10-frame count window → natural neighbour 16×16 →
//!   contour (min area 60 mm²) → track) or `events_noise` (the same with the events method's
//!   default noise-adaptive τ = `event_tau_sigmas` σ, calibrated over `calibrate_frames`).
//!   `fit` is the model fit (`[stages.locate] method = "fit"` with the `accurate` preset's
//!   settings and the method forced to `fit`) → track; `fit_polarity` the same with
//!   `fit_polarity_votes = 10` (an option, not in the preset); `fit_unlearned` the preset
//!   with `fit_learned_correction = false` (the preset before round 6).
//! - After the criterion groups, per-frame latency percentiles (p50, p99) of the default chain
//!   and of the fit pushed one frame at a time, printed (not asserted).
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use gradtac_stages::centroid::Centroid;
use gradtac_stages::contour::{Contour, ContourConfig};
use gradtac_stages::events::{Events, EventsConfig, Threshold};
use gradtac_stages::fit::Fit;
use gradtac_stages::interpolate::{GridConfig, Interpolate, InterpolateConfig};
use gradtac_stages::locate::{LocateConfig, LocateMethod, Preset};
use gradtac_stages::savgol::{SavGol, SavGolConfig};
use gradtac_stages::sim_family::{Member, PathKind};
use gradtac_stages::track::{Track, TrackConfig};
use gradtac_stages::window::{Aggregate, Window, WindowConfig};
use gradtac_stream::{Layout, Stage, StageExt, TaxelFrame, Timestamp};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

fn dos_recording() -> Option<Vec<TaxelFrame>> {
    // GRADTAC_DOS_DIR overrides where the dataset is (a worktree away from the shared data)
    let root = std::env::var_os("GRADTAC_DOS_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/biotacsp-dos"));
    let p = root.join("cw/bottle4.csv");
    let text = std::fs::read_to_string(&p).ok()?;
    Some(
        text.lines()
            .skip(1)
            .filter(|l| !l.trim().is_empty())
            .enumerate()
            .map(|(k, l)| {
                let v = l.split(',').map(|x| x.trim().parse().unwrap_or(0.0)).collect();
                TaxelFrame::new("ff".into(), Timestamp::at_rate(k as u64, 100.0), k as u64, v)
            })
            .collect(),
    )
}

fn recordings() -> Vec<(&'static str, Vec<TaxelFrame>)> {
    let mut out = vec![("sim", Member { seed: 900, kind: PathKind::Circle }.simulate().frames)];
    match dos_recording() {
        Some(r) => out.push(("dos", r)),
        None => eprintln!("locate bench: BioTacSP-DoS not present, real-data rows skipped"),
    }
    out
}

fn centroid_chain(
    l: &Layout,
) -> impl Stage<In = TaxelFrame, Out = gradtac_stages::track::TrackPoint, Error = gradtac_stream::Error> {
    Centroid::try_new(&LocateConfig::default(), l).unwrap().then(Track::try_new(&TrackConfig::default()).unwrap())
}

fn fit_chain(
    l: &Layout,
    polarity_votes: u32,
    learned: bool,
) -> impl Stage<In = TaxelFrame, Out = gradtac_stages::track::TrackPoint, Error = gradtac_stream::Error> {
    let cfg = LocateConfig {
        method: LocateMethod::Fit,
        fit_polarity_votes: polarity_votes,
        fit_learned_correction: learned,
        ..LocateConfig::preset(Preset::Accurate)
    };
    Fit::try_new(&cfg, l).unwrap().then(Track::try_new(&TrackConfig::default()).unwrap())
}

fn events_chain(
    l: &Layout,
    threshold: Threshold,
) -> impl Stage<In = TaxelFrame, Out = gradtac_stages::track::TrackPoint, Error = gradtac_stream::Error> {
    let icfg = InterpolateConfig {
        grid: GridConfig { nx: 16, ..Default::default() },
        incremental: true,
        ..Default::default()
    };
    SavGol::try_with_rate(l.len(), SavGolConfig::default(), 100.0)
        .unwrap()
        .then(Events::try_new(l.len(), EventsConfig { threshold, ..Default::default() }).unwrap())
        .then(
            Window::try_new(&WindowConfig { frames: Some(10), aggregate: Aggregate::Count, ..Default::default() })
                .unwrap(),
        )
        .then(Interpolate::try_new(&icfg, l).unwrap())
        .then(Contour::try_new(&ContourConfig { min_peak: 2.0, min_area_mm2: 60.0, ..Default::default() }).unwrap())
        .then(Track::try_new(&TrackConfig::default()).unwrap())
}

fn bench(c: &mut Criterion) {
    let l = Layout::biotac_sp();
    let recs = recordings();
    let mut g = c.benchmark_group("locate");
    for (name, frames) in &recs {
        g.throughput(Throughput::Elements(frames.len() as u64));
        g.bench_with_input(BenchmarkId::new("centroid", name), frames, |b, f| {
            b.iter(|| black_box(centroid_chain(&l).run_all(f.iter().cloned()).unwrap().len()))
        });
        g.bench_with_input(BenchmarkId::new("fit", name), frames, |b, f| {
            b.iter(|| black_box(fit_chain(&l, 0, true).run_all(f.iter().cloned()).unwrap().len()))
        });
        g.bench_with_input(BenchmarkId::new("fit_polarity", name), frames, |b, f| {
            b.iter(|| black_box(fit_chain(&l, 10, true).run_all(f.iter().cloned()).unwrap().len()))
        });
        g.bench_with_input(BenchmarkId::new("fit_unlearned", name), frames, |b, f| {
            b.iter(|| black_box(fit_chain(&l, 0, false).run_all(f.iter().cloned()).unwrap().len()))
        });
        g.bench_with_input(BenchmarkId::new("events", name), frames, |b, f| {
            b.iter(|| black_box(events_chain(&l, Threshold::Uniform(0.001)).run_all(f.iter().cloned()).unwrap().len()))
        });
        let d = LocateConfig::default();
        let noise = Threshold::Noise { noise_sigmas: d.event_tau_sigmas, calibrate_frames: d.calibrate_frames };
        g.bench_with_input(BenchmarkId::new("events_noise", name), frames, |b, f| {
            b.iter(|| black_box(events_chain(&l, noise.clone()).run_all(f.iter().cloned()).unwrap().len()))
        });
    }
    g.finish();
    // per-frame latency of the default chain and of the fit, one frame at a time (printed, not
    // asserted)
    for (name, frames) in &recs {
        latency("centroid", name, frames, || centroid_chain(&l));
        latency("fit", name, frames, || fit_chain(&l, 0, true));
        latency("fit_polarity", name, frames, || fit_chain(&l, 10, true));
        latency("fit_unlearned", name, frames, || fit_chain(&l, 0, false));
    }
}

fn latency<S: Stage<In = TaxelFrame>>(chain: &str, name: &str, frames: &[TaxelFrame], make: impl Fn() -> S)
where
    S::Error: std::fmt::Debug,
{
    let mut lat = Vec::new();
    let mut out = Vec::new();
    for _ in 0..20 {
        let mut ch = make();
        for f in frames.iter().cloned() {
            let t0 = Instant::now();
            ch.push(f, &mut out).unwrap();
            lat.push(t0.elapsed().as_nanos() as f64 * 1e-3);
            out.clear();
        }
    }
    lat.sort_by(f64::total_cmp);
    let q = |p: f64| lat[((lat.len() - 1) as f64 * p) as usize];
    println!(
        "locate/{chain}/{name}: per-frame latency p50 {:.2} µs, p99 {:.2} µs, max {:.1} µs",
        q(0.5),
        q(0.99),
        q(1.0)
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
