//! `dos_eval`'s section of the default window part since stop 34: the gradient-boosted trees
//! (T15 since stop 36's round 6, T13 in stop 35's round 5, T12 in round 4, T9 in round 3, T4 in stop 34, before it T1; [`TreeTrainConfig::default`], the model
//! `gradtac calibrate dos` writes), combined with
//! the Student-t design exactly as the held-out run of stop 33 did
//! (`trees_held_out.rs`): per split the Student-t candidate its own procedure chose, the
//! weight `a` by leave-one-object-out per recording inside the training objects (both models
//! refitted), both fitted on the training objects. CI runs the two cross-set splits and the
//! ConvLSTM protocol (≈ 8 tree fits); `--trees-nested` adds the nested leave-one-object-out
//! (≈ 36 fits more, 4–6 min at load ≈ 7–8; the section without it ≈ 40 s), which CI leaves
//! out for time. Then the sliding mode's per-frame cost with the default's parts, its p99
//! printed beside the 20 µs (reported, not a floor: a timing on a shared machine).

use gradtac::calibrate::{calibrate_spans, labelled_spans, read_recordings, train_recordings, CalibrateOptions};
use gradtac::stages::dos::train_trees::{fit_on, tree_samples, TreeTrainConfig};
use gradtac::stages::dos::DosTreesPart;
use gradtac::stream::Layout;
use std::error::Error;

/// Floors, a few recordings (or ~80 windows) under what the held-out run of stop 36's round 6
/// measured with T15 (`examples/dos_eval_parts/trees_round6_held_out.txt`): nested 88.6 %
/// (148/167), basic → solids 92.9 % (52/56), solids → basic 82.9 % (92/111), the ConvLSTM
/// protocol 90.6 % (2 788/3 076 windows; the ConvLSTM's own 82.56 %). Before (T13, stop 35's
/// round 5): 0.86 / 0.87 / 0.80 / 0.87 over 88.6 / 91.1 / 82.9 / 89.7 %; (T12, round 4):
/// 0.87 / 0.87 / 0.79 / 0.86 over 89.2 / 91.1 / 81.1 / 88.7 %; (T9, round 3):
/// 0.87 / 0.89 / 0.80 / 0.87 over 89.8 / 92.9 / 82.9 / 89.5 %; (T4, stop 34):
/// 0.86 / 0.89 / 0.79 / 0.86 over 89.2 / 92.9 / 82.0 / 89.0 %; (T1, stop 33) 0.86 / 0.87 /
/// 0.76 / 0.87 over 89.2 / 91.1 / 79.3 / 90.0 %.
const FLOOR_NESTED: f64 = 0.86;
const FLOOR_BASIC_TO_SOLIDS: f64 = 0.89;
const FLOOR_SOLIDS_TO_BASIC: f64 = 0.80;
const FLOOR_CONVLSTM: f64 = 0.88;
/// Largest p99 cost of one frame (µs) the issue allows, here of the sliding mode a robot runs.
const MAX_P99_US: f64 = 20.0;

/// The section; fails when a figure is under its floor (unless `no_floors`).
pub fn run(dir: &std::path::Path, layout: &Layout, no_floors: bool, nested: bool) -> Result<(), Box<dyn Error>> {
    println!(
        "\n## The default window part: gradient-boosted trees (T15, `dos::DosTrees`; the default of `gradtac calibrate \
         dos` since stop 34, T15 since stop 36's round 6), combined with the Student-t design"
    );
    let f = super::trees_held_out::run_with(dir, layout, &TreeTrainConfig::default(), nested)?;
    let p99 = sliding_p99(dir, layout)?;
    if no_floors {
        return Ok(());
    }
    // speed is reported, not enforced here: a timing on a shared CI machine is not a test
    // (`examples/dos_sliding_cost` measures it, a table of medians and p99)
    if p99 > MAX_P99_US {
        println!(
            "note: trees, sliding-mode p99 cost per frame {p99:.1} µs is over the issue's {MAX_P99_US} µs on this run"
        );
    }
    let mut checks = vec![
        ("trees + Student t, basic → solids per recording", f.basic_to_solids, FLOOR_BASIC_TO_SOLIDS),
        ("trees + Student t, solids → basic per recording", f.solids_to_basic, FLOOR_SOLIDS_TO_BASIC),
        ("trees, ConvLSTM protocol per 5-frame window", f.convlstm, FLOOR_CONVLSTM),
    ];
    if let Some(n) = f.nested {
        checks.push(("trees + Student t, nested per recording", n, FLOOR_NESTED));
    }
    for (name, (ok, n), floor) in checks {
        let got = ok as f64 / n.max(1) as f64;
        if got < floor {
            return Err(format!("{name}: {:.1} % is under the floor {:.1} %", 100.0 * got, 100.0 * floor).into());
        }
        println!("floor held: {name} {:.1} % ≥ {:.1} %", 100.0 * got, 100.0 * floor);
    }
    Ok(())
}

/// The `dos` stage's per-frame cost in the sliding mode (the last 250 frames, a decision every
/// 10) with the default's parts fitted on every recording (the weight, which costs nothing, set
/// to 0.5 rather than chosen: this measures time, not accuracy); prints it and returns the p99.
fn sliding_p99(dir: &std::path::Path, layout: &Layout) -> Result<f64, Box<dyn Error>> {
    let opts = CalibrateOptions::default();
    let recs = read_recordings(dir, &opts)?;
    let student = calibrate_spans(&labelled_spans(dir, layout, &opts)?, &opts)?;
    let tr = train_recordings(&recs);
    let cfg = TreeTrainConfig::default();
    let all: Vec<usize> = (0..tr.len()).collect();
    let trees = fit_on(&tree_samples(&tr, layout, &cfg)?, &all, layout, &cfg)?;
    let model = student.with_trees(Some(DosTreesPart { weight: 0.5, trees }))?;
    let mut cost =
        super::sliding_cost::push_costs(&model, tr.iter().map(|r| r.frames.as_slice()), layout, (250, 10, false))?;
    cost.sort_by(f64::total_cmp);
    let q = |p: f64| cost[((cost.len() - 1) as f64 * p).round() as usize];
    println!(
        "\n(sliding mode with the tree part, a decision every 10 frames over the last 250, {} frames: median {:.2} µs, \
         p99 {:.2} µs (bound {MAX_P99_US} µs), max {:.0} µs)",
        cost.len(),
        q(0.5),
        q(0.99),
        q(1.0)
    );
    Ok(q(0.99))
}
