//! The Rust side of the Python `Pipeline.push` overhead benchmark: time
//! `gradtac::memory::Pipeline::push_frames` (the engine `gradtac.Pipeline` calls) on the frames
//! of a raw file, pushed in batches of `B` frames, and print the median time per frame.
//!
//! ```text
//! cargo run --release --example pipeline_push -- FRAMES.f64 TAXELS TAP REPEATS BATCH...
//! ```
//!
//! `FRAMES.f64` holds little-endian f64 values, frames × taxels, row-major (the Python benchmark
//! `python/bench/push_overhead.py` writes it and runs this). Frames are timed at 100 Hz. Output:
//! one line per batch size, `batch=<B> median_ns_per_frame=<x> rows=<records out>`.

use gradtac::memory::Pipeline;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 5 {
        return Err("usage: pipeline_push FRAMES.f64 TAXELS TAP REPEATS BATCH...".into());
    }
    let bytes = std::fs::read(&args[0])?;
    let taxels: usize = args[1].parse()?;
    let tap = &args[2];
    let repeats: usize = args[3].parse()?;
    let values: Vec<f64> = bytes.chunks_exact(8).map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes"))).collect();
    let frames = values.len() / taxels;
    let times: Vec<i64> = (0..frames as i64).map(|k| k * 10_000_000).collect();
    for b in &args[4..] {
        let batch: usize = b.parse()?;
        let mut per_frame = Vec::with_capacity(repeats);
        let mut rows = 0;
        for _ in 0..repeats {
            let mut p = Pipeline::new("biotac-sp", tap, &toml::Table::new(), Some(100.0), "ff")?;
            rows = 0;
            let start = Instant::now();
            for (t, v) in times.chunks(batch).zip(values.chunks(batch * taxels)) {
                rows += std::hint::black_box(p.push_frames(t, v)?).num_rows();
            }
            rows += p.finish()?.num_rows();
            per_frame.push(start.elapsed().as_nanos() as f64 / frames as f64);
        }
        per_frame.sort_by(f64::total_cmp);
        println!("batch={batch} median_ns_per_frame={:.1} rows={rows}", per_frame[per_frame.len() / 2]);
    }
    Ok(())
}
