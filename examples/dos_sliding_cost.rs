//! Per-frame cost of the `dos` stage in the sliding mode a robot runs (the last 250 frames, a
//! decision every 10) on labelled recordings, with the model's window part and with the
//! Student-t model alone. Every frame's `push` is timed; the decision frames are the costly
//! ones, so the p99 and the maximum are what this measures. Prints a table of the median, p99
//! and maximum per frame (µs), and the mean (µs) over all frames.
//!
//! `cargo run --release --example dos_sliding_cost -- MODEL.json DIR [--frames N] [--hop H] [--early]`
//!
//! `MODEL.json` is a `gradtac calibrate dos` model (with its window part), `DIR` the labelled
//! recordings (`DIR/<class>/<name>.csv`, e.g. the BioTacSP-DoS development recordings).

#[path = "dos_eval_parts/sliding_cost.rs"]
mod sliding_cost;

use gradtac::calibrate::{read_model, read_recordings, CalibrateOptions};
use gradtac::stream::Layout;
use std::error::Error;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn Error>> {
    let mut args = std::env::args().skip(1);
    let (mut model, mut dir, mut n, mut hop, mut early) = (None, None, 250u64, 10u64, false);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--frames" => n = args.next().ok_or("--frames needs a value")?.parse()?,
            "--hop" => hop = args.next().ok_or("--hop needs a value")?.parse()?,
            "--early" => early = true,
            _ if model.is_none() => model = Some(PathBuf::from(a)),
            _ if dir.is_none() => dir = Some(PathBuf::from(a)),
            _ => return Err(format!("unexpected argument {a}").into()),
        }
    }
    let usage = "usage: dos_sliding_cost MODEL.json DIR [--frames N] [--hop H] [--early]";
    let model = read_model(&model.ok_or(usage)?)?;
    let recs = read_recordings(&dir.ok_or(usage)?, &CalibrateOptions::default())?;
    let layout = Layout::biotac_sp();
    let frames: usize = recs.iter().map(|r| r.frames.len()).sum();
    println!(
        "sliding mode: the last {n} frames, a decision every {hop}{}; {} recordings, {frames} frames",
        if early { ", early answers" } else { "" },
        recs.len()
    );
    println!("| model | median µs | p99 µs | max µs | mean µs |");
    println!("|---|---|---|---|---|");
    let alone = model.clone().with_window(None)?;
    for (name, m) in [("Student-t + window part", &model), ("Student-t alone", &alone)] {
        let mut cost = sliding_cost::push_costs(m, recs.iter().map(|r| r.frames.as_slice()), &layout, (n, hop, early))?;
        let mean = cost.iter().sum::<f64>() / cost.len().max(1) as f64;
        cost.sort_by(f64::total_cmp);
        let q = |p: f64| cost[((cost.len() - 1) as f64 * p).round() as usize];
        println!("| {name} | {:.2} | {:.2} | {:.0} | {mean:.2} |", q(0.5), q(0.99), q(1.0));
    }
    Ok(())
}
