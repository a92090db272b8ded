//! Throughput of the signal stages on 24-taxel frames: normalise, Savitzky–Golay (11, 3)
//! centred and causal, events, and normalise → SG → events together.
//!
//! Run: `cargo bench -p gradtac-stages --bench signal`. Criterion reports time per batch of
//! `FRAMES` frames and, via `Throughput::Elements`, frames per second. Input frames are cloned
//! outside the timed region (`iter_batched`); dropping the outputs is inside it.
//!
//! The input is synthetic but BioTac-like: per-taxel baselines 1500–3800 counts, slow
//! touch-like swings of ±200 counts with different periods per taxel, and ±3 counts of noise;
//! normalised with given bounds (baseline ± 250) to about [0, 1]; events with τ = 0.05.
use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use gradtac_stages::events::{Events, EventsConfig, Threshold};
use gradtac_stages::normalise::{Normalise, NormaliseConfig};
use gradtac_stages::savgol::{SavGol, SavGolConfig, SavGolMode};
use gradtac_stream::{Stage, StageExt, TaxelFrame, Timestamp};
use std::hint::black_box;

const TAXELS: usize = 24;
const FRAMES: usize = 4096;

fn baseline(i: usize) -> f64 {
    1500.0 + 100.0 * i as f64
}

fn input() -> Vec<TaxelFrame> {
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut noise = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 6.0 - 3.0
    };
    (0..FRAMES)
        .map(|k| {
            let values = (0..TAXELS)
                .map(|i| {
                    let period = 150.0 + 7.0 * i as f64;
                    baseline(i) + 200.0 * (2.0 * std::f64::consts::PI * k as f64 / period).sin() + noise()
                })
                .collect();
            TaxelFrame::new("ff".into(), Timestamp::at_rate(k as u64, 100.0), k as u64, values)
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
    Events::try_new(TAXELS, EventsConfig { threshold: Threshold::Uniform(0.05), ..Default::default() }).unwrap()
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
    let frames = input();
    // Event density of this input, for the record.
    {
        let mut chain = normalise().then(savgol(SavGolMode::Centred)).then(events());
        let out = chain.run_all(frames.clone()).unwrap();
        let n: usize = out.iter().map(|b| b.events.len()).sum();
        eprintln!("input: {FRAMES} frames × {TAXELS} taxels; normalise → SG(11,3) → events(τ=0.05): {n} events");
    }
    let normalised = normalise().run_all(frames.clone()).unwrap();

    let mut g = c.benchmark_group("signal_24_taxels");
    g.throughput(Throughput::Elements(FRAMES as u64));

    let mut out = Vec::with_capacity(128);
    let mut s = normalise();
    g.bench_function("normalise", |b| {
        b.iter_batched(|| frames.clone(), |fs| run(&mut s, fs, &mut out), BatchSize::LargeInput)
    });
    for (name, mode) in [("savgol_11_3_centred", SavGolMode::Centred), ("savgol_11_3_causal", SavGolMode::Causal)] {
        let mut out = Vec::with_capacity(128);
        let mut s = savgol(mode);
        g.bench_function(name, |b| {
            b.iter_batched(|| normalised.clone(), |fs| run(&mut s, fs, &mut out), BatchSize::LargeInput)
        });
    }
    let mut out = Vec::with_capacity(128);
    let mut s = events();
    g.bench_function("events_tau_0.05", |b| {
        b.iter_batched(|| normalised.clone(), |fs| run(&mut s, fs, &mut out), BatchSize::LargeInput)
    });
    for (name, mode) in [
        ("normalise_savgol_centred_events", SavGolMode::Centred),
        ("normalise_savgol_causal_events", SavGolMode::Causal),
    ] {
        let mut out = Vec::with_capacity(128);
        let mut s = normalise().then(savgol(mode)).then(events());
        g.bench_function(name, |b| {
            b.iter_batched(|| frames.clone(), |fs| run(&mut s, fs, &mut out), BatchSize::LargeInput)
        });
    }
    g.finish();
}

criterion_group!(group, benches);
criterion_main!(group);
