//! Leave-one-group-out view of a force-gate change **inside the tuning members** (issue #22,
//! force round 6; `examples/force_parts/history.md`, "Session 36").
//!
//! The held-out members (seeds 100–115) are drawn from the same family as the tuning members,
//! so a gain that does not transfer is a gain carried by a few tuning members whose physics
//! the 16 held-out members happen not to share. This example makes that visible without any
//! held-out data: it reads `force_eval`'s per-member lines (`FORCE_EVAL_DEBUG=1 force_eval
//! --tuning-only --only forward`, one log per gate, the first the baseline) and splits the
//! tuning members by their physics along five axes, each cut into three groups at bounds fixed
//! here (not chosen on any figure):
//! - `kernel`: Gaussian / difference of Gaussians / exponential;
//! - `width`: the kernel's width < 2.5 / 2.5–4 / ≥ 4 mm (a broad press spreads over many
//!   electrodes of mixed sign: its shape fraction is low);
//! - `lag`: the fluid lag 10–33 / 33–57 / 57–80 ms;
//! - `walk`: the drift's random walk 0.2–0.8 / 0.8–1.4 / 1.4–2.0 counts/√s;
//! - `walk/σ`: that walk over the member's noise σ, < 0.2 / 0.2–0.5 / ≥ 0.5 (the gate's
//!   steadiness test is in σ, so this is the walk as the gate sees it).
//!
//! For each log: per group, the members, worst and mean MAPE and the untouched frames above
//! 0.5 N. For each log after the first (a candidate against the baseline), per axis: the
//! change per group, and the **leave-one-group-out gain** — for each group, the untouched
//! frames the candidate saves on the members *outside* that group; the axis's figure is the
//! smallest of the three (a gain carried by one group is near 0 there). Beside it, the gain
//! without the single member it helps most. A seed of the held-out ranges (100–115, fresh 9000–9015) is refused.
//!
//! Run: `cargo run --release --example force_groups -- base.log cand.log [more.log]`
//! (`--members` also prints each member's physics and figures).

use gradtac::stages::sim_family::KernelShape;
use gradtac::stages::sim_force::{is_held_out, ForceSession};
use std::collections::BTreeMap;

/// One member's figures from a log.
#[derive(Clone, Copy, Debug)]
struct Figures {
    mape: f64,
    over: u64,
    untouched: u64,
}

/// The per-member lines of one `force_eval` log (`FORCE_EVAL_DEBUG`): `seed S Forward:
/// in-sample … held-out M % on … untouched O/U; …`.
fn read_log(path: &str) -> BTreeMap<u64, Figures> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut out = BTreeMap::new();
    for line in text.lines() {
        let Some(rest) = line.strip_prefix("seed ") else { continue };
        if !rest.contains(": in-sample ") {
            continue;
        }
        let seed: u64 = rest.split_whitespace().next().and_then(|s| s.parse().ok()).expect("seed");
        assert!(!is_held_out(seed), "{path}: held-out seed {seed}: this view reads tuning members only");
        let mape: f64 = rest
            .split("held-out ")
            .nth(1)
            .and_then(|s| s.split_whitespace().next())
            .and_then(|s| s.parse().ok())
            .expect("held-out figure");
        let (o, u) = rest
            .split("untouched ")
            .nth(1)
            .and_then(|s| s.split(';').next())
            .and_then(|s| s.split_once('/'))
            .expect("untouched figure");
        out.insert(
            seed,
            Figures { mape, over: o.trim().parse().expect("over"), untouched: u.trim().parse().expect("untouched") },
        );
    }
    out
}

/// The axes: name, group names, and the group of a seed.
type Axis = (&'static str, [&'static str; 3], fn(u64) -> usize);

fn kernel(seed: u64) -> usize {
    match ForceSession::presses(seed, 10).physics.kernel {
        KernelShape::Gaussian => 0,
        KernelShape::DifferenceOfGaussians { .. } => 1,
        KernelShape::Exponential => 2,
        KernelShape::MexicanHat { .. } => unreachable!("the force family draws no Mexican hat"),
    }
}

fn width(seed: u64) -> usize {
    let w = ForceSession::presses(seed, 10).physics.width_mm;
    usize::from(w >= 2.5) + usize::from(w >= 4.0)
}

fn lag(seed: u64) -> usize {
    let l = ForceSession::presses(seed, 10).physics.lag_s;
    usize::from(l >= 0.033) + usize::from(l >= 0.057)
}

fn walk(seed: u64) -> usize {
    let w = ForceSession::presses(seed, 10).physics.drift_walk;
    usize::from(w >= 0.8) + usize::from(w >= 1.4)
}

fn walk_sigma(seed: u64) -> usize {
    let p = ForceSession::presses(seed, 10).physics;
    let r = p.drift_walk / p.noise_counts;
    usize::from(r >= 0.2) + usize::from(r >= 0.5)
}

const AXES: [Axis; 5] = [
    ("kernel", ["gaussian", "dog", "exponential"], kernel),
    ("width", ["< 2.5 mm", "2.5-4 mm", ">= 4 mm"], width),
    ("lag", ["10-33 ms", "33-57 ms", "57-80 ms"], lag),
    ("walk", ["0.2-0.8", "0.8-1.4", "1.4-2.0"], walk),
    ("walk/σ", ["< 0.2", "0.2-0.5", ">= 0.5"], walk_sigma),
];

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let list_members = args.iter().any(|a| a == "--members");
    let paths: Vec<&String> = args.iter().filter(|a| !a.starts_with("--")).collect();
    assert!(!paths.is_empty(), "usage: force_groups [--members] base.log [candidate.log …]");
    let logs: Vec<BTreeMap<u64, Figures>> = paths.iter().map(|p| read_log(p)).collect();
    let seeds: Vec<u64> = logs[0].keys().copied().collect();
    for (p, l) in paths.iter().zip(&logs) {
        assert_eq!(l.keys().copied().collect::<Vec<_>>(), seeds, "{p}: not the baseline's members");
    }
    if list_members {
        println!(
            "| seed | kernel | width mm | lag ms | noise σ | walk | walk/σ | {} |",
            paths.iter().map(|p| format!("{p} MAPE / over")).collect::<Vec<_>>().join(" | ")
        );
        for &s in &seeds {
            let p = ForceSession::presses(s, 10).physics;
            let cells: Vec<String> = logs.iter().map(|l| format!("{:.1} / {}", l[&s].mape, l[&s].over)).collect();
            println!(
                "| {s} | {} | {:.2} | {:.0} | {:.2} | {:.2} | {:.2} | {} |",
                AXES[0].1[kernel(s)],
                p.width_mm,
                p.lag_s * 1e3,
                p.noise_counts,
                p.drift_walk,
                p.drift_walk / p.noise_counts,
                cells.join(" | ")
            );
        }
        println!();
    }
    let groups: Vec<Vec<usize>> = AXES.iter().map(|a| seeds.iter().map(|&s| (a.2)(s)).collect()).collect();
    for (p, l) in paths.iter().zip(&logs) {
        let (o, u): (u64, u64) = seeds.iter().fold((0, 0), |(o, u), s| (o + l[s].over, u + l[s].untouched));
        let worst = seeds.iter().map(|s| l[s].mape).fold(0.0, f64::max);
        let mean = seeds.iter().map(|s| l[s].mape).sum::<f64>() / seeds.len() as f64;
        println!("{p}: {} members, worst {worst:.1} %, mean {mean:.2} %, untouched > 0.5 N {o} of {u}", seeds.len());
        println!("| axis | group | members | worst | mean | untouched > 0.5 N |");
        println!("|---|---|---|---|---|---|");
        for (a, g) in AXES.iter().zip(&groups) {
            for (k, name) in a.1.iter().enumerate() {
                let m: Vec<u64> = seeds.iter().zip(g).filter(|(_, &gk)| gk == k).map(|(s, _)| *s).collect();
                let w = m.iter().map(|s| l[s].mape).fold(0.0, f64::max);
                let mn = m.iter().map(|s| l[s].mape).sum::<f64>() / m.len().max(1) as f64;
                let (o, u): (u64, u64) = m.iter().fold((0, 0), |(o, u), s| (o + l[s].over, u + l[s].untouched));
                println!("| {} | {name} | {} | {w:.1} % | {mn:.2} % | {o} of {u} |", a.0, m.len());
            }
        }
        println!();
    }
    let base = &logs[0];
    for (p, l) in paths.iter().zip(&logs).skip(1) {
        let gain = |s: &u64| base[s].over as i64 - l[s].over as i64;
        let total: i64 = seeds.iter().map(gain).sum();
        let best = seeds.iter().max_by_key(|s| gain(s)).copied().unwrap_or(0);
        println!(
            "{p} against {}: untouched saved {total}; without the member it helps most ({best}: {}) {}",
            paths[0],
            gain(&best),
            total - gain(&best).max(0)
        );
        println!("| axis | saved per group | mean change per group (points) | leave-one-group-out gain (smallest) |");
        println!("|---|---|---|---|");
        let mut lowest = i64::MAX;
        for (a, g) in AXES.iter().zip(&groups) {
            let per: Vec<i64> =
                (0..3).map(|k| seeds.iter().zip(g).filter(|(_, &gk)| gk == k).map(|(s, _)| gain(s)).sum()).collect();
            let dm: Vec<String> = (0..3)
                .map(|k| {
                    let m: Vec<&u64> = seeds.iter().zip(g).filter(|(_, &gk)| gk == k).map(|(s, _)| s).collect();
                    let d = m.iter().map(|s| l[*s].mape - base[*s].mape).sum::<f64>() / m.len().max(1) as f64;
                    format!("{}: {d:+.2}", a.1[k])
                })
                .collect();
            let logo = (0..3).map(|k| total - per[k]).min().unwrap_or(0);
            lowest = lowest.min(logo);
            let cells: Vec<String> = (0..3).map(|k| format!("{}: {}", a.1[k], per[k])).collect();
            println!("| {} | {} | {} | {logo} |", a.0, cells.join(", "), dm.join(", "));
        }
        println!("leave-one-group-out gain over the five axes: {lowest}\n");
    }
}
