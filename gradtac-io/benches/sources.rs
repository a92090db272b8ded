//! Throughput of the CAN and NumPy sources.
//!
//! - `can/decode`: `CanDecoder` over a three-finger `biotac-mux` recording (9 frames per
//!   fingertip and cycle, 6 with electrodes), frames already in memory;
//! - `can/candump_parse`: `CandumpReader` over the same recording as `candump -l` text;
//! - `can/candump_source`: parse + decode (what `CandumpSource` does);
//! - `npy/read_f64` / `npy/read_i16`: `NpyFrames` over a 20 000 × 24 file (from the page cache).
//!
//! Run: `cargo bench -p gradtac-io --bench sources`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use gradtac_io::can::{
    CanCodec, CanDecoder, CanFrame, CandumpReader, CandumpSource, CodecConfig, PresetConfig, PresetKind,
};
use gradtac_io::npy::{NpyFrames, NpySourceConfig};
use gradtac_stream::{SensorId, StageExt, Timestamp};
use std::hint::black_box;
use std::time::Duration;

const CYCLES: usize = 2000;

fn recording() -> Vec<CanFrame> {
    let mut out = Vec::with_capacity(CYCLES * 27);
    for k in 0..CYCLES {
        for f in 0..3u32 {
            for m in 0..9u8 {
                let t = Timestamp(
                    1_700_000_000_000_000_000
                        + (k as i64) * 10_000_000
                        + i64::from(f) * 1_000_000
                        + i64::from(m) * 100_000,
                );
                let v = (1500 + k % 1000) as u16;
                let d = [
                    m,
                    (v >> 4) as u8,
                    ((v & 0xF) << 4) as u8 | (v >> 8) as u8,
                    v as u8,
                    (v >> 4) as u8,
                    ((v & 0xF) << 4) as u8 | (v >> 8) as u8,
                    v as u8,
                    0,
                ];
                out.push(CanFrame::standard(0x100 + f, &d, t).unwrap());
            }
        }
    }
    out
}

fn codec() -> CanCodec {
    CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &["ff", "mf", "th"]))).unwrap()
}

fn can(c: &mut Criterion) {
    let frames = recording();
    let text: String = frames.iter().map(|f| f.to_candump_line("can0") + "\n").collect();
    let mut g = c.benchmark_group("can");
    g.sample_size(20).measurement_time(Duration::from_secs(4));
    g.throughput(Throughput::Elements(frames.len() as u64));
    g.bench_function("decode", |b| {
        b.iter(|| {
            let mut d = CanDecoder::new(codec());
            let out = d.run_all(frames.iter().copied()).unwrap();
            assert_eq!(out.len(), 3 * CYCLES);
            black_box(out)
        })
    });
    g.bench_function("candump_parse", |b| {
        b.iter(|| {
            let n = CandumpReader::new("bench.log", text.as_bytes()).inspect(|r| assert!(r.is_ok())).count();
            assert_eq!(n, frames.len());
            black_box(n)
        })
    });
    g.bench_function("candump_source", |b| {
        b.iter(|| {
            let src = CandumpSource::new(CandumpReader::new("bench.log", text.as_bytes()), CanDecoder::new(codec()));
            let n = src.inspect(|r| assert!(r.is_ok())).count();
            assert_eq!(n, 3 * CYCLES);
            black_box(n)
        })
    });
    g.finish();
}

fn npy_file(dir: &std::path::Path, descr: &str, size: usize, frames: usize) -> std::path::PathBuf {
    let mut dict = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': ({frames}, 24), }}");
    while (10 + dict.len() + 1) % 64 != 0 {
        dict.push(' ');
    }
    dict.push('\n');
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend((dict.len() as u16).to_le_bytes());
    bytes.extend(dict.as_bytes());
    for i in 0..frames * 24 {
        let v = (i % 4000) as f64;
        match size {
            8 => bytes.extend(v.to_le_bytes()),
            _ => bytes.extend((v as i16).to_le_bytes()),
        }
    }
    let p = dir.join(format!("{}.npy", &descr[1..]));
    std::fs::write(&p, bytes).unwrap();
    p
}

fn npy(c: &mut Criterion) {
    const FRAMES: usize = 20_000;
    let dir = tempfile::tempdir().unwrap();
    let mut g = c.benchmark_group("npy");
    g.sample_size(20).measurement_time(Duration::from_secs(4));
    g.throughput(Throughput::Elements(FRAMES as u64));
    for (descr, size) in [("<f8", 8), ("<i2", 2)] {
        let p = npy_file(dir.path(), descr, size, FRAMES);
        g.bench_with_input(BenchmarkId::new("read", &descr[1..]), &p, |b, p| {
            b.iter(|| {
                let it = NpyFrames::open(&NpySourceConfig::with_rate(p, 100.0), SensorId::new("ff")).unwrap();
                let n = it.map(|r| r.unwrap().values.len()).sum::<usize>();
                assert_eq!(n, FRAMES * 24);
                black_box(n)
            })
        });
    }
    g.finish();
}

criterion_group!(benches, can, npy);
criterion_main!(benches);
