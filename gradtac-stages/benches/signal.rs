//! Throughput of the signal stages on 24-taxel frames: normalise, Savitzky–Golay (11, 3)
//! centred and causal, events, and normalise → SG → events together.
//!
//! Run: `cargo bench -p gradtac-stages --bench signal`. Criterion reports time per batch of
//! `FRAMES` frames and, via `Throughput::Elements`, frames per second. Input frames are cloned
//! outside the timed region (`iter_batched`); dropping the outputs is inside it.
//!
//! The input is synthetic but BioTac-like: per-taxel baselines 1500–3800 counts, slow
//! touch-like swings with different periods per taxel, and ±3 counts of noise; normalised with
//! given bounds (baseline ± 250) to about [0, 1]; events with τ = 0.05. Two inputs: `touch`
//! (swings of ±200 counts: ≈ 9.3 events per frame after SG, dense — real BioTacSP-DoS data gives
//! 5–60 per frame depending on τ and calibration) and `quiet` (±20 counts: ≈ 0.44 events per
//! frame). The event stage's cost is ≈ 30–40 ns per event on top of ≈ 3 ns per taxel, so its
//! throughput depends on the event density far more than on anything else.
//!
//! Group `real_biotacsp_dos` runs the chain over the real BioTacSP-DoS recordings when the
//! shared data directory is present (`$GRADTAC_DATA`, default `shared/data` beside the repository), and is
//! skipped otherwise.
use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use gradtac_stages::events::{Events, EventsConfig, Polarity, Threshold};
use gradtac_stages::normalise::{Normalise, NormaliseConfig};
use gradtac_stages::savgol::{SavGol, SavGolConfig, SavGolMode};
use gradtac_stream::{SensorId, Stage, StageExt, TaxelFrame, Timestamp};
use std::hint::black_box;

const TAXELS: usize = 24;
const FRAMES: usize = 4096;

fn baseline(i: usize) -> f64 {
    1500.0 + 100.0 * i as f64
}

fn input(amplitude: f64) -> Vec<TaxelFrame> {
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut noise = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 6.0 - 3.0
    };
    // one shared id, as a source hands out clones of its sensor's id
    let sensor: SensorId = "ff".into();
    (0..FRAMES)
        .map(|k| {
            let values = (0..TAXELS)
                .map(|i| {
                    let period = 150.0 + 7.0 * i as f64;
                    baseline(i) + amplitude * (2.0 * std::f64::consts::PI * k as f64 / period).sin() + noise()
                })
                .collect();
            TaxelFrame::new(sensor.clone(), Timestamp::at_rate(k as u64, 100.0), k as u64, values)
        })
        .collect()
}

fn normalise() -> Normalise {
    let config = NormaliseConfig {
        min: Some((0..TAXELS).map(|i| baseline(i) - 250.0).collect()),
        max: Some((0..TAXELS).map(|i| baseline(i) + 250.0).collect()),
        ..Default::default()
    };
    Normalise::try_new(TAXELS, &config).unwrap()
}

fn savgol(mode: SavGolMode) -> SavGol {
    SavGol::try_with_rate(TAXELS, SavGolConfig { window: 11, polyorder: 3, mode, ..Default::default() }, 100.0).unwrap()
}

fn events() -> Events {
    events_with(Polarity::Both)
}

fn events_with(polarity: Polarity) -> Events {
    Events::try_new(TAXELS, EventsConfig { threshold: Threshold::Uniform(0.05), polarity, ..Default::default() })
        .unwrap()
}

/// Push every frame through `stage`, draining outputs every 64 frames (as an adapter would).
fn run<S: Stage<In = TaxelFrame>>(stage: &mut S, frames: Vec<TaxelFrame>, out: &mut Vec<S::Out>)
where
    S::Error: std::fmt::Debug,
{
    for (k, f) in frames.into_iter().enumerate() {
        stage.push(f, out).unwrap();
        if k % 64 == 63 {
            black_box(&out);
            out.clear();
        }
    }
    stage.finish(out).unwrap();
    black_box(&out);
    out.clear();
}

fn benches(c: &mut Criterion) {
    let touch = input(200.0);
    let quiet = input(20.0);
    for (name, frames) in [("touch", &touch), ("quiet", &quiet)] {
        let mut chain = normalise().then(savgol(SavGolMode::Centred)).then(events());
        let out = chain.run_all(frames.clone()).unwrap();
        let n: usize = out.iter().map(|b| b.events.len()).sum();
        eprintln!(
            "input {name}: {FRAMES} frames × {TAXELS} taxels → {n} events ({:.2} per frame)",
            n as f64 / FRAMES as f64
        );
    }
    let touch_n = normalise().run_all(touch.clone()).unwrap();
    let quiet_n = normalise().run_all(quiet.clone()).unwrap();

    let mut g = c.benchmark_group("signal_24_taxels");
    g.throughput(Throughput::Elements(FRAMES as u64));

    let mut out = Vec::with_capacity(128);
    let mut s = normalise();
    g.bench_function("normalise", |b| {
        b.iter_batched(|| touch.clone(), |fs| run(&mut s, fs, &mut out), BatchSize::LargeInput)
    });
    for (name, mode) in [("savgol_11_3_centred", SavGolMode::Centred), ("savgol_11_3_causal", SavGolMode::Causal)] {
        let mut out = Vec::with_capacity(128);
        let mut s = savgol(mode);
        g.bench_function(name, |b| {
            b.iter_batched(|| touch_n.clone(), |fs| run(&mut s, fs, &mut out), BatchSize::LargeInput)
        });
    }
    // `press_release` (the scene's event-chain default): the touch input swings through each
    // taxel's baseline, so one taxel's step may hold releases then presses
    for (name, frames, polarity) in [
        ("events_touch", &touch_n, Polarity::Both),
        ("events_quiet", &quiet_n, Polarity::Both),
        ("events_touch_press_release", &touch_n, Polarity::PressRelease),
        ("events_quiet_press_release", &quiet_n, Polarity::PressRelease),
    ] {
        let mut out = Vec::with_capacity(128);
        let mut s = events_with(polarity);
        g.bench_function(name, |b| {
            b.iter_batched(|| frames.clone(), |fs| run(&mut s, fs, &mut out), BatchSize::LargeInput)
        });
    }
    for (name, mode, frames) in [
        ("chain_centred_touch", SavGolMode::Centred, &touch),
        ("chain_centred_quiet", SavGolMode::Centred, &quiet),
        ("chain_causal_touch", SavGolMode::Causal, &touch),
        ("chain_causal_quiet", SavGolMode::Causal, &quiet),
    ] {
        let mut out = Vec::with_capacity(128);
        let mut s = normalise().then(savgol(mode)).then(events());
        g.bench_function(name, |b| {
            b.iter_batched(|| frames.clone(), |fs| run(&mut s, fs, &mut out), BatchSize::LargeInput)
        });
    }
    g.finish();
}

/// BioTacSP-DoS recordings (Zapata-Impata, Gil and Torres, Sensors 19(3):523, 2019) from the
/// shared data directory (`$GRADTAC_DATA` or `shared/data` beside the repository), if present:
/// every sequence as its own stream of raw counts at 100 Hz.
fn real_recordings() -> Option<Vec<Vec<TaxelFrame>>> {
    let root = std::env::var_os("GRADTAC_DATA")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"))
        .join("biotacsp-dos");
    let mut paths = Vec::new();
    for class in std::fs::read_dir(&root).ok()? {
        let class = class.ok()?.path();
        if class.is_dir() {
            for f in std::fs::read_dir(&class).ok()? {
                let f = f.ok()?.path();
                if f.extension().is_some_and(|e| e == "csv") {
                    paths.push(f);
                }
            }
        }
    }
    paths.sort();
    let sensor: SensorId = "ff".into();
    let recordings: Vec<Vec<TaxelFrame>> = paths
        .iter()
        .filter_map(|p| {
            let text = std::fs::read_to_string(p).ok()?;
            let rows: Option<Vec<Vec<f64>>> = text
                .lines()
                .skip(1)
                .map(|l| l.split(',').map(|v| v.trim().parse().ok()).collect::<Option<Vec<f64>>>())
                .collect();
            let frames = rows?
                .into_iter()
                .enumerate()
                .map(|(k, v)| TaxelFrame::new(sensor.clone(), Timestamp::at_rate(k as u64, 100.0), k as u64, v))
                .collect::<Vec<_>>();
            (frames.first()?.values.len() == TAXELS).then_some(frames)
        })
        .collect();
    (!recordings.is_empty()).then_some(recordings)
}

/// normalise (calibrated on each recording's first 20 frames) → SG(11, 3) centred → events,
/// over every recording of the real data set.
fn real_data(c: &mut Criterion) {
    let Some(recordings) = real_recordings() else {
        eprintln!("real-data benches skipped: no BioTacSP-DoS under $GRADTAC_DATA or ../../shared/data");
        return;
    };
    let frames: usize = recordings.iter().map(Vec::len).sum();
    let mut g = c.benchmark_group("real_biotacsp_dos");
    g.throughput(Throughput::Elements(frames as u64));
    g.sample_size(10);
    for tau in [0.05, 0.2, 0.5] {
        let build = || {
            let events =
                Events::try_new(TAXELS, EventsConfig { threshold: Threshold::Uniform(tau), ..Default::default() })
                    .unwrap();
            Normalise::try_new(TAXELS, &NormaliseConfig::default())
                .unwrap()
                .then(savgol(SavGolMode::Centred))
                .then(events)
        };
        let n: usize = recordings
            .iter()
            .map(|r| build().run_all(r.clone()).unwrap().iter().map(|b| b.events.len()).sum::<usize>())
            .sum();
        eprintln!(
            "real data: {} recordings, {frames} frames; τ = {tau}: {n} events ({:.2} per frame)",
            recordings.len(),
            n as f64 / frames as f64
        );
        let mut chain = build();
        let mut out = Vec::with_capacity(128);
        g.bench_function(format!("chain_centred_tau_{tau}"), |b| {
            b.iter_batched(
                || recordings.clone(),
                |recs| {
                    for r in recs {
                        run(&mut chain, r, &mut out);
                    }
                },
                BatchSize::LargeInput,
            )
        });
    }
    g.finish();
}

criterion_group!(group, benches, real_data);
criterion_main!(group);
