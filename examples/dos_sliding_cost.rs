//! Per-frame cost of the `dos` stage in the sliding mode a robot runs (the last 250 frames, a
//! decision every 10) on labelled recordings, with the model's window part (the net or the
//! trees) and with the Student-t model alone. Every frame's `push` is timed; the decision frames
//! are the costly ones, so the p99 and the maximum are what this measures. Prints a table of the
//! median, p99 and maximum per frame (µs), and the mean (µs) over all frames.
//!
//! `cargo run --release --example dos_sliding_cost -- MODEL.json DIR [--frames N] [--hop H] [--early] [--compare-fresh]`
//!
//! `MODEL.json` is a `gradtac calibrate dos` model (with its window part), `DIR` the labelled
//! recordings (`DIR/<class>/<name>.csv`, e.g. the BioTacSP-DoS development recordings).
//! `--compare-fresh` also counts how many sliding decisions have the class a fresh recording of
//! their frames gets (one decision per segment over the same frames): with a tree part, whose
//! windows keep the contact's history in the sliding mode, that measures the sliding mode's
//! approximation (see the `dos` stage's docs); with the net or without a window part every
//! decision is a fresh replay, so all agree.

#[path = "dos_eval_parts/sliding_cost.rs"]
mod sliding_cost;

use gradtac::calibrate::{read_model, read_recordings, CalibrateOptions, Recording};
use gradtac::stages::dos::{DosClassifier, DosModel};
use gradtac::stream::{Layout, StageExt, TaxelFrame};
use std::error::Error;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn Error>> {
    let mut args = std::env::args().skip(1);
    let (mut model, mut dir, mut n, mut hop, mut early, mut compare) = (None, None, 250u64, 10u64, false, false);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--frames" => n = args.next().ok_or("--frames needs a value")?.parse()?,
            "--hop" => hop = args.next().ok_or("--hop needs a value")?.parse()?,
            "--early" => early = true,
            "--compare-fresh" => compare = true,
            _ if model.is_none() => model = Some(PathBuf::from(a)),
            _ if dir.is_none() => dir = Some(PathBuf::from(a)),
            _ => return Err(format!("unexpected argument {a}").into()),
        }
    }
    let usage = "usage: dos_sliding_cost MODEL.json DIR [--frames N] [--hop H] [--early] [--compare-fresh]";
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
    let alone = model.clone().with_window(None)?.with_trees(None)?;
    let part = match (&model.window, &model.trees) {
        (Some(_), _) => "Student-t + window part (net)",
        (_, Some(_)) => "Student-t + tree part",
        _ => "Student-t (the model has no window part)",
    };
    for (name, m) in [(part, &model), ("Student-t alone", &alone)] {
        let mut cost = sliding_cost::push_costs(m, recs.iter().map(|r| r.frames.as_slice()), &layout, (n, hop, early))?;
        let mean = cost.iter().sum::<f64>() / cost.len().max(1) as f64;
        cost.sort_by(f64::total_cmp);
        let q = |p: f64| cost[((cost.len() - 1) as f64 * p).round() as usize];
        println!("| {name} | {:.2} | {:.2} | {:.0} | {mean:.2} |", q(0.5), q(0.99), q(1.0));
    }
    if compare {
        compare_fresh(&model, &recs, &layout, (n, hop, early))?;
    }
    Ok(())
}

/// Sliding decisions against a fresh recording of each decision's frames: how many have the
/// fresh recording's class, and how many the recording's label (in-sample when `model` was
/// calibrated on these recordings), split by whether the decision's frames start at the
/// recording's first frame (then the two are the same by construction) or later.
fn compare_fresh(
    model: &DosModel,
    recs: &[Recording],
    layout: &Layout,
    (n, hop, early): (u64, u64, bool),
) -> Result<(), Box<dyn Error>> {
    // [from the first frame, slid]: (decisions, same class as fresh, sliding right, fresh right)
    let mut tally = [(0usize, 0usize, 0usize, 0usize); 2];
    for r in recs {
        let frames: Vec<TaxelFrame> = r.frames.iter().enumerate().map(|(seq, v)| sliding_cost::frame(seq, v)).collect();
        let mut stage = DosClassifier::try_new(model.clone(), layout, Some(n))?.with_hop(hop)?;
        if early {
            stage = stage.with_early_decisions()?;
        }
        for d in stage.run_all(frames.clone())? {
            let last = d.seq as usize;
            let first = last + 1 - d.frames as usize;
            let fresh = DosClassifier::try_new(model.clone(), layout, None)?.run_all(frames[first..=last].to_vec())?;
            let t = &mut tally[usize::from(first > 0)];
            t.0 += 1;
            t.1 += usize::from(fresh[0].decision.class == d.decision.class);
            t.2 += usize::from(d.decision.class == r.class);
            t.3 += usize::from(fresh[0].decision.class == r.class);
        }
    }
    println!("\nsliding decisions against a fresh recording of their frames (labels in-sample if the model saw them):");
    println!("| decisions | count | same class as fresh | sliding right | fresh right |");
    println!("|---|---|---|---|---|");
    for (name, (k, same, s, f)) in ["frames from the recording's start", "slid past it"].iter().zip(tally) {
        println!("| {name} | {k} | {same} | {s} | {f} |");
    }
    Ok(())
}
