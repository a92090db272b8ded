//! The gradient-boosted tree model of slip direction ([`gradtac::stages::dos::DosTrees`]):
//! development views and costs, never a held-out figure unless asked for.
//!
//! `cargo run --release --example dos_trees -- [DATA_DIR] [--candidates FILE.json]` prints, for the
//! current default window part (the baseline row, re-run) and each tree candidate (default:
//! `examples/dos_eval_parts/trees_candidates.json`, the candidates of
//! `examples/dos_eval_parts/trees_rule.md`), the leave-one-object-out accuracy *inside* basic and
//! *inside* solids only (per window and per recording, the causal vote) and the rule's pick; then
//! each candidate's fit time on all recordings and its per-frame cost through the causal vote.
//!
//! `--tree-baseline` makes the file's first candidate the baseline row instead of the window net
//! (stop 34's round 2, `examples/dos_eval_parts/trees_rule_round2.md`: T1, the default, re-run);
//! `--first N` numbers the other candidates from `N` (default 1, or 3 with `--tree-baseline`).
//! Stop 35's round 3 (`examples/dos_eval_parts/trees_rule_round3.md`): `--candidates
//! examples/dos_eval_parts/trees_round3_candidates.json --tree-baseline --first 7` (T4 re-run,
//! then T7–T9). Round 4 (`trees_rule_round4.md`): `--candidates
//! examples/dos_eval_parts/trees_round4_candidates.json --tree-baseline --first 10` (T9 re-run,
//! then T10–T12). Round 5 (`trees_rule_round5.md`): `--candidates
//! examples/dos_eval_parts/trees_round5_candidates.json --tree-baseline --first 13` (T12 re-run,
//! then T13). Round 6 (stop 36, `trees_rule_round6.md`): `--candidates
//! examples/dos_eval_parts/trees_round6_candidates.json --tree-baseline --first 14` (T13 re-run,
//! then T14–T16; T14's and T16's flow-share inputs were removed in stop 37, so that file runs at
//! commit `e43beac`, not at HEAD). Round 7 (`trees_rule_round7.md`): `--candidates
//! examples/dos_eval_parts/trees_round7_candidates.json --tree-baseline --first 17` (T15 re-run,
//! then T17–T19). `examples/dos_trees_diag.rs` prints the inner views' errors per object.

use gradtac::calibrate::{object_set, train_recordings, CalibrateOptions};
use gradtac::stages::dos::train_trees::{fit_on, inner_score, tree_samples, TreeTrainConfig};
use gradtac::stages::dos::train_window::{inner_scores, window_samples, InnerScore};
use gradtac::stream::Layout;
use std::error::Error;
use std::path::PathBuf;
use std::time::Instant;

#[path = "dos_eval_parts/combination.rs"]
mod combination;
#[path = "dos_eval_parts/trees_held_out.rs"]
mod held_out;
#[path = "dos_eval_parts/sliding_cost.rs"]
#[allow(dead_code)]
mod sliding_cost;

fn pct((ok, n): (usize, usize)) -> String {
    format!("{:.1} % ({ok}/{n})", 100.0 * ok as f64 / n.max(1) as f64)
}

fn frac((ok, n): (usize, usize)) -> f64 {
    ok as f64 / n.max(1) as f64
}

fn main() -> Result<(), Box<dyn Error>> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut dir = root.join("../shared/data/biotacsp-dos");
    let mut cands_path = root.join("examples/dos_eval_parts/trees_candidates.json");
    let mut held: Option<PathBuf> = None;
    let mut cost_only = false;
    let mut tree_baseline = false;
    let mut first: Option<usize> = None;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--candidates" => cands_path = args.next().ok_or("--candidates needs a JSON file")?.into(),
            "--cost-only" => cost_only = true,
            "--tree-baseline" => tree_baseline = true,
            "--first" => first = Some(args.next().ok_or("--first needs a number")?.parse()?),
            "--held-out" => {
                held = Some(args.next().ok_or("--held-out needs a JSON file of one TreeTrainConfig")?.into())
            }
            "-h" | "--help" => {
                println!(
                    "usage: dos_trees [DATA_DIR] [--candidates FILE.json] [--tree-baseline] [--first N] [--cost-only] [--held-out CANDIDATE.json]"
                );
                return Ok(());
            }
            other => dir = PathBuf::from(other),
        }
    }
    if !dir.is_dir() {
        println!("skipped: data not present ({})", dir.display());
        return Ok(());
    }
    let cands: Vec<TreeTrainConfig> = serde_json::from_str(&std::fs::read_to_string(&cands_path)?)?;
    for c in &cands {
        c.validate()?;
    }
    let layout = Layout::biotac_sp();
    if let Some(p) = held {
        let c: TreeTrainConfig = serde_json::from_str(&std::fs::read_to_string(p)?)?;
        c.validate()?;
        return held_out::run(&dir, &layout, &c);
    }
    let recs = gradtac::calibrate::read_recordings(&dir, &CalibrateOptions::default())?;
    let tr = train_recordings(&recs);
    let of = |set: &str| -> Vec<usize> { (0..recs.len()).filter(|&i| object_set(&recs[i].object) == set).collect() };
    let (basic, solids) = (of("basic"), of("solids"));
    if cost_only {
        costs(&tr, &layout, &cands, 1)?;
        return stage_cost(&dir, &layout, &tr);
    }
    if tree_baseline && cands.len() < 2 {
        return Err("--tree-baseline needs the baseline and at least one candidate in the file".into());
    }
    let first = first.unwrap_or(if tree_baseline { 3 } else { 1 });
    // the rows' names after the baseline row: T{first}, T{first + 1}, …
    let name = |k: usize| format!("T{}", first + k);
    let mut rows: Vec<(String, InnerScore, InnerScore)> = Vec::new();
    let t = Instant::now();
    let tree_cands: &[TreeTrainConfig] = if tree_baseline {
        let c = &cands[0];
        let samples = tree_samples(&tr, &layout, c)?;
        let b = inner_score(&tr, &samples, &basic, &layout, c)?;
        let s = inner_score(&tr, &samples, &solids, &layout, c)?;
        rows.push((format!("baseline (the default, re-run): {}", serde_json::to_string(c)?), b, s));
        &cands[1..]
    } else {
        let wc = gradtac::calibrate::window_candidates();
        let ws = window_samples(&tr, &layout, &wc[0])?;
        let b = inner_scores(&tr, &[ws.as_slice()], &basic, &layout, &wc[..1])?;
        let s = inner_scores(&tr, &[ws.as_slice()], &solids, &layout, &wc[..1])?;
        rows.push(("the window net part (stop 33's baseline)".into(), b[0], s[0]));
        &cands
    };
    println!("(baseline inner views: {:.0} s)", t.elapsed().as_secs_f64());
    for (k, c) in tree_cands.iter().enumerate() {
        let t = Instant::now();
        let samples = tree_samples(&tr, &layout, c)?;
        let b = inner_score(&tr, &samples, &basic, &layout, c)?;
        let s = inner_score(&tr, &samples, &solids, &layout, c)?;
        println!("({} inner views: {:.0} s)", name(k), t.elapsed().as_secs_f64());
        rows.push((format!("{}: {}", name(k), serde_json::to_string(c)?), b, s));
    }
    println!("\n| candidate (inner views only) | inside basic, per window | per recording | inside solids, per window | per recording | recordings, both | mean per window |");
    println!("|---|---|---|---|---|---|---|");
    for (name, b, s) in &rows {
        println!(
            "| {name} | {} | {} | {} | {} | {} | {:.1} % |",
            pct(b.0),
            pct(b.1),
            pct(s.0),
            pct(s.1),
            b.1 .0 + s.1 .0,
            50.0 * (frac(b.0) + frac(s.0))
        );
    }
    // the rule (examples/dos_eval_parts/trees_rule.md)
    let (_, b0, s0) = rows[0];
    let mut best = 0;
    for (k, (_, b, s)) in rows.iter().enumerate().skip(1) {
        let excluded = b.1 .0 + 2 < b0.1 .0 || s.1 .0 + 2 < s0.1 .0;
        let key = |b: &InnerScore, s: &InnerScore| (b.1 .0 + s.1 .0, frac(b.0) + frac(s.0));
        let (kb, ks) = (&rows[best].1, &rows[best].2);
        println!(
            "{}: {}",
            name(k - 1),
            if excluded { "excluded (loses > 2 recordings in a view)" } else { "eligible" }
        );
        if !excluded {
            let (a, am) = key(b, s);
            let (c, cm) = key(kb, ks);
            if a > c || (a == c && am > cm) {
                best = k;
            }
        }
    }
    println!(
        "rule's pick: {}",
        if best == 0 { "the baseline (no candidate scored held out)".into() } else { name(best - 1) }
    );
    costs(&tr, &layout, tree_cands, first)
}

/// `gradtac calibrate dos --window-trees`'s procedure on all recordings (its time), and the
/// `dos` stage on that model, one decision per recording: every push timed.
fn stage_cost(
    dir: &std::path::Path,
    layout: &Layout,
    tr: &[gradtac::stages::dos::train::TrainRecording],
) -> Result<(), Box<dyn Error>> {
    use gradtac::stages::dos::DosClassifier;
    use gradtac::stream::Stage;
    let opts = CalibrateOptions { window_trees: true, ..CalibrateOptions::default() };
    let t = Instant::now();
    let (model, n) = gradtac::calibrate::calibrate_dos(dir, layout, &opts)?;
    let calib_s = t.elapsed().as_secs_f64();
    let part = model.trees.as_ref().ok_or("no tree part")?;
    let (mut cost, mut out, mut ok) = (Vec::new(), Vec::new(), 0);
    for r in tr {
        let mut stage = DosClassifier::try_new(model.clone(), layout, None)?;
        out.clear();
        for (seq, v) in r.frames.iter().enumerate() {
            cost.push(sliding_cost::push_timed(&mut stage, seq, v, &mut out)?);
        }
        stage.finish(&mut out)?;
        ok += usize::from(out.last().is_some_and(|d| d.decision.class == r.class));
    }
    cost.sort_by(f64::total_cmp);
    let q = |p: f64| cost[((cost.len() - 1) as f64 * p).round() as usize];
    println!(
        "calibrate dos --window-trees on {n} recordings: {calib_s:.1} s (weight a = {}); the dos stage, one decision per \
         recording, per frame median {:.2} µs, p99 {:.2} µs, max {:.0} µs ({} frames; in-sample decisions {ok}/{n})",
        part.weight,
        q(0.5),
        q(0.99),
        q(1.0),
        cost.len()
    );
    Ok(())
}

/// Each candidate's fit on all recordings and its causal vote's per-frame cost (every push timed).
fn costs(
    tr: &[gradtac::stages::dos::train::TrainRecording],
    layout: &Layout,
    cands: &[TreeTrainConfig],
    first: usize,
) -> Result<(), Box<dyn Error>> {
    let all: Vec<usize> = (0..tr.len()).collect();
    for (k, c) in cands.iter().enumerate() {
        let t = Instant::now();
        let samples = tree_samples(tr, layout, c)?;
        let m = fit_on(&samples, &all, layout, c)?;
        let fit_s = t.elapsed().as_secs_f64();
        let mut v = m.vote(layout)?;
        let mut cost = Vec::new();
        for r in tr {
            v.reset();
            for f in &r.frames {
                let t = Instant::now();
                let d = v.push(f)?;
                cost.push(t.elapsed().as_secs_f64() * 1e6);
                std::hint::black_box(d);
            }
        }
        cost.sort_by(f64::total_cmp);
        let q = |p: f64| cost[((cost.len() - 1) as f64 * p).round() as usize];
        // the window frames alone: each is one window's inputs and two walks of every tree
        println!(
            "T{}: fit on all {} recordings (with augmentation) {fit_s:.1} s; {} trees, {} nodes; causal vote per frame median {:.2} µs, p99 {:.2} µs ({} frames)",
            k + first,
            tr.len(),
            m.trees().len(),
            m.nodes(),
            q(0.5),
            q(0.99),
            cost.len()
        );
    }
    Ok(())
}
