//! Leave-one-physics-out view of the model fit's learned bias correction, **inside the tuning
//! side** (issue #22, round 10; `examples/fit_parts/history.md`, "Round 10").
//!
//! The held-out members differ from the tuning members by physics (a kernel shape and a lag
//! range no choice ever sees). This example builds the same kind of gap inside the tuning
//! physics, so that candidates can be ranked on how they transfer without touching held-out
//! data. The tuning physics (`PhysicsSet::Tuning`) is cut into five groups: each of its three
//! kernel shapes (Gaussian, difference of Gaussians, exponential) and two lag ranges
//! (10–20 ms, 20–30 ms). For each group `g`:
//! - the correction is re-trained on the training recordings (seeds 10 000.., as
//!   `train_fit_correction`) whose physics is **not** in `g`, its standardisation from those
//!   alone, its bandwidth and ridge penalty chosen on validation recordings (seeds 20 000..)
//!   not in `g` (`--select pooled`, the shipped procedure) or by an inner leave-one-group-out
//!   over the remaining groups (`--select groups`: the largest of the remaining groups'
//!   validation distances, each from weights trained without that group);
//! - it is scored on the tuning-physics members (seeds `0..--members`, default 24, × 4 kinds)
//!   whose physics **is** in `g`, exactly as `fit_probe` scores: per kind the mean error (÷ the
//!   26.6 mm width), the group's worst kind and mean.
//!
//! Beside it, the same members scored with weights trained on every group ("in-sample"): the
//! difference is the tuning-side generalisation gap. The protocol's figure is the worst over
//! the five left-out groups of the group's worst kind. Held-out members (100–115) and held-out
//! physics are never simulated here.
//!
//! Candidates (`--cand NAME`, repeatable): `R0` the shipped correction's procedure; `off` no
//! correction; `R2` only the first 7 inputs (position, log-spread, far lobe, relative residual,
//! velocity: the 48 per-electrode patterns left out) with a wider bandwidth grid; `R3` the
//! shipped inputs with a wider grid (λ to 1e-2) chosen by `--select groups`. `--locate 'TOML
//! line'` (repeatable) changes the fit, on top of `preset = "accurate"`.
//!
//! Run: `nice -n 10 cargo run --release --example fit_lopo -- --cand R0 --cand off`
//! (`--train N --val M --members S`; defaults 2000, 200, 24).

use gradtac::stages::fit::Fit;
use gradtac::stages::fit_learned::{self, Correction, Design, Trained};
use gradtac::stages::locate::LocateConfig;
use gradtac::stages::sim_family::{KernelShape, Member, PathKind, PhysicsSet};
use gradtac::stages::track::{Track, TrackConfig};
use gradtac::stream::{Layout, Stage, StageExt};
use std::collections::HashMap;
use std::time::Instant;

#[path = "fit_parts/fitted.rs"]
mod fitted;

/// Inputs kept by `R2` (the rest are left out: zero in training, a scale that makes them 0).
const KEPT_R2: usize = 7;
/// A left-out input's scale: its standardised value is below 3e-12 (inputs are clamped to ±3).
const OFF_SCALE: f64 = 1e12;

/// A physics cell: kernel (0 Gaussian, 1 difference of Gaussians, 2 exponential) × lag range.
fn cell(kernel: KernelShape, lag_s: f64) -> usize {
    let k = match kernel {
        KernelShape::Gaussian => 0,
        KernelShape::DifferenceOfGaussians { .. } => 1,
        KernelShape::Exponential => 2,
        KernelShape::MexicanHat { .. } => unreachable!("tuning physics never draws a Mexican hat"),
    };
    2 * k + usize::from(lag_s >= 0.020)
}

const CELLS: usize = 6;
/// The five groups and their cells.
const GROUPS: [(&str, [bool; CELLS]); 5] = [
    ("gaussian", [true, true, false, false, false, false]),
    ("dog", [false, false, true, true, false, false]),
    ("exponential", [false, false, false, false, true, true]),
    ("lag 10-20 ms", [true, false, true, false, true, false]),
    ("lag 20-30 ms", [false, true, false, true, false, true]),
];

struct Samples {
    x: Vec<Vec<f64>>,
    y: Vec<[f64; 2]>,
    cell: Vec<usize>,
}

/// Every `every`-th fitted frame of the seeds' recordings (tuning physics), as
/// `train_fit_correction` takes them (target: the truth at the frame's middle time).
fn samples(seeds: std::ops::Range<u64>, every: usize, layout: &Layout, cfg: &LocateConfig) -> Samples {
    let mut s = Samples { x: Vec::new(), y: Vec::new(), cell: Vec::new() };
    for m in Member::grid(seeds) {
        let p = m.physics_in(PhysicsSet::Tuning);
        let c = cell(p.kernel, p.lag_s);
        let rec = p.simulate(m.seed);
        let mut k = 0usize;
        fitted::each_fitted_frame(&rec, cfg, layout, |x, p, mid| {
            let Some(t) = rec.truth_at(mid) else { return };
            k += 1;
            if k % every == 0 {
                s.x.push(x[..fit_learned::INPUTS].to_vec());
                s.y.push([t[0] - p[0], t[1] - p[1]]);
                s.cell.push(c);
            }
        });
    }
    s
}

#[derive(Clone, Copy, PartialEq)]
enum Select {
    Pooled,
    Groups,
}

struct Cand {
    name: &'static str,
    kept: usize,
    bandwidths: Vec<[f64; 2]>,
    lambdas: Vec<f64>,
    select: Select,
}

fn candidate(name: &str) -> Option<Cand> {
    let round6 = (vec![[0.125, 0.125], [0.25, 0.25]], vec![1e-6, 1e-5]);
    Some(match name {
        "R0" => Cand { name: "R0", kept: 55, bandwidths: round6.0, lambdas: round6.1, select: Select::Pooled },
        "R2" => Cand {
            name: "R2",
            kept: KEPT_R2,
            // the non-position frequencies are bandwidth[1]/√53 per input; with 5 inputs left
            // 0.8 ≈ 0.25·√(53/5) gives them round 6's per-input scale
            bandwidths: vec![[0.125, 0.25], [0.25, 0.25], [0.125, 0.8], [0.25, 0.8]],
            lambdas: vec![1e-6, 1e-5],
            select: Select::Pooled,
        },
        "R3" => Cand {
            name: "R3",
            kept: 55,
            bandwidths: vec![[0.125, 0.125], [0.25, 0.25], [0.5, 0.5]],
            lambdas: vec![1e-6, 1e-5, 1e-4, 1e-3, 1e-2],
            select: Select::Groups,
        },
        _ => return None,
    })
}

/// Standardisation of the samples in `cells`, with inputs from `kept` on left out.
fn standardise(s: &Samples, cells: &[bool; CELLS], kept: usize) -> (Vec<f64>, Vec<f64>) {
    let xs: Vec<Vec<f64>> = s.x.iter().zip(&s.cell).filter(|(_, c)| cells[**c]).map(|(x, _)| x.clone()).collect();
    let (mut mean, mut scale) = fit_learned::standardisation(&xs);
    for i in kept..mean.len() {
        mean[i] = 0.0;
        scale[i] = OFF_SCALE;
    }
    (mean, scale)
}

fn mean_dist(t: &Trained, s: &Samples, cells: &[bool; CELLS]) -> f64 {
    let mut c = Correction::try_new(t.clone()).expect("finite weights");
    let (mut sum, mut n) = (0.0, 0usize);
    for ((x, y), k) in s.x.iter().zip(&s.y).zip(&s.cell) {
        if cells[*k] {
            let v = c.apply(x);
            sum += (y[0] - v[0]).hypot(y[1] - v[1]);
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

fn union(designs: &[Option<Design>], cells: &[bool; CELLS]) -> Option<Design> {
    let mut acc: Option<Design> = None;
    for (c, d) in designs.iter().enumerate() {
        if !cells[c] {
            continue;
        }
        let Some(d) = d else { continue };
        match &mut acc {
            None => acc = Some(d.clone()),
            Some(a) => assert!(a.merge(d), "same standardisation"),
        }
    }
    acc
}

/// Weights for the training cells `train` (left-out group `g`'s complement, or all):
/// trained and chosen by the candidate's rule. Returns the weights and a description.
fn weights(cand: &Cand, tr: &Samples, va: &Samples, train: &[bool; CELLS]) -> (Trained, String) {
    let (mean, scale) = standardise(tr, train, cand.kept);
    let mut best: Option<(f64, Trained)> = None;
    for &bw in &cand.bandwidths {
        // one design per cell under this standardisation
        let mut designs: Vec<Option<Design>> = (0..CELLS).map(|_| None).collect();
        for (c, d) in designs.iter_mut().enumerate() {
            if train[c] {
                *d = Some(Design::new(mean.clone(), scale.clone(), bw).expect("valid design"));
            }
        }
        for ((x, y), c) in tr.x.iter().zip(&tr.y).zip(&tr.cell) {
            if let Some(d) = &mut designs[*c] {
                if cand.kept < x.len() {
                    let mut x = x.clone();
                    x[cand.kept..].iter_mut().for_each(|v| *v = 0.0);
                    d.add(&x, *y);
                } else {
                    d.add(x, *y);
                }
            }
        }
        let all = union(&designs, train).expect("training samples");
        let full = all.solve(&cand.lambdas);
        match cand.select {
            Select::Pooled => {
                for t in full.into_iter().flatten() {
                    let v = mean_dist(&t, va, train);
                    if best.as_ref().is_none_or(|b| v < b.0) {
                        best = Some((v, t));
                    }
                }
            }
            Select::Groups => {
                // inner leave-one-group-out over the groups left in `train`
                let mut worst = vec![0.0f64; cand.lambdas.len()];
                for (_, gc) in GROUPS {
                    let held: [bool; CELLS] = std::array::from_fn(|c| gc[c] && train[c]);
                    if !held.iter().any(|h| *h) || held == *train {
                        continue;
                    }
                    let rest: [bool; CELLS] = std::array::from_fn(|c| train[c] && !gc[c]);
                    let Some(d) = union(&designs, &rest) else { continue };
                    for (i, t) in d.solve(&cand.lambdas).into_iter().enumerate() {
                        let v = t.map_or(f64::INFINITY, |t| mean_dist(&t, va, &held));
                        worst[i] = worst[i].max(v);
                    }
                }
                for (t, w) in full.into_iter().zip(worst) {
                    let Some(t) = t else { continue };
                    if best.as_ref().is_none_or(|b| w < b.0) {
                        best = Some((w, t));
                    }
                }
            }
        }
    }
    let (v, t) = best.expect("a solvable regression");
    let what = format!(
        "bandwidth {:?} λ {:e}, {} {v:.4} mm",
        t.bandwidth,
        t.lambda,
        if cand.select == Select::Pooled { "validation" } else { "inner worst group" },
    );
    (t, what)
}

/// One member scored as `fit_probe` scores it: (kind, mean error ÷ width).
fn score(m: &Member, cfg: &LocateConfig, layout: &Layout, w: Option<&Trained>) -> (PathKind, f64) {
    let width = layout.extent().width();
    let rec = m.physics_in(PhysicsSet::Tuning).simulate(m.seed);
    let cfg = LocateConfig { fit_learned_correction: w.is_some(), ..cfg.clone() };
    let mut fit = Fit::try_new(&cfg, layout).expect("valid fit settings");
    if let Some(w) = w {
        fit = fit.with_correction(Some(Correction::try_new(w.clone()).expect("usable weights")));
    }
    let mut contours = Vec::new();
    for f in rec.frames.iter().cloned() {
        fit.push(f, &mut contours).expect("simulated frames are finite");
    }
    fit.finish(&mut contours).expect("finish");
    let pts = Track::try_new(&TrackConfig::default()).unwrap().run_all(contours).unwrap();
    let mean = rec.mean_track_error_mm(&rec.track_errors_mm(&pts));
    (m.kind, mean / width)
}

/// Worst kind (mean per kind) and mean over the scored members.
fn summary(scores: &[(PathKind, f64)]) -> (f64, &'static str, f64) {
    let mut by: HashMap<PathKind, Vec<f64>> = HashMap::new();
    for (k, e) in scores {
        by.entry(*k).or_default().push(*e);
    }
    let mut worst = (0.0, "");
    for k in PathKind::ALL {
        if let Some(v) = by.get(&k) {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            if m > worst.0 {
                worst = (m, k.name());
            }
        }
    }
    let mean = scores.iter().map(|s| s.1).sum::<f64>() / scores.len().max(1) as f64;
    (worst.0, worst.1, mean)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |name: &str, d: u64| {
        args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(d)
    };
    let mut toml = String::from("preset = \"accurate\"\n");
    let mut cands: Vec<String> = Vec::new();
    for (i, a) in args.iter().enumerate() {
        if a == "--locate" {
            toml.push_str(args.get(i + 1).expect("--locate 'TOML line'"));
            toml.push('\n');
        }
        if a == "--cand" {
            cands.push(args.get(i + 1).expect("--cand NAME").clone());
        }
    }
    if cands.is_empty() {
        cands = vec!["R0".into(), "off".into()];
    }
    let cfg: LocateConfig = toml::from_str(&toml).expect("a [stages.locate] table");
    cfg.validate().expect("valid settings");
    let (n_train, n_val, n_mem) = (arg("--train", 2000), arg("--val", 200), arg("--members", 24));
    let layout = Layout::biotac_sp();
    let t0 = Instant::now();
    let members = Member::grid(0..n_mem);
    let mcell: Vec<usize> = members
        .iter()
        .map(|m| {
            let p = m.physics_in(PhysicsSet::Tuning);
            cell(p.kernel, p.lag_s)
        })
        .collect();
    let learned = cands.iter().any(|c| c != "off");
    let (tr, va) = if learned {
        let tr = samples(10_000..10_000 + n_train, 8, &layout, &cfg);
        let va = samples(20_000..20_000 + n_val, 8, &layout, &cfg);
        (tr, va)
    } else {
        (Samples { x: vec![], y: vec![], cell: vec![] }, Samples { x: vec![], y: vec![], cell: vec![] })
    };
    let count = |s: &Samples| (0..CELLS).map(|c| s.cell.iter().filter(|k| **k == c).count()).collect::<Vec<_>>();
    println!(
        "fit_lopo: {} training / {} validation frames (per cell G<20 G≥20 D<20 D≥20 E<20 E≥20: {:?} / {:?}), \
         members seeds 0..{n_mem} × 4 (per cell {:?}); {:.0} s",
        tr.x.len(),
        va.x.len(),
        count(&tr),
        count(&va),
        (0..CELLS).map(|c| mcell.iter().filter(|k| **k == c).count()).collect::<Vec<_>>(),
        t0.elapsed().as_secs_f64()
    );
    let all = [true; CELLS];
    for name in &cands {
        let cand =
            if name == "off" { None } else { Some(candidate(name).unwrap_or_else(|| panic!("candidate {name}"))) };
        let full = cand.as_ref().map(|c| weights(c, &tr, &va, &all));
        // in-sample: every member with the weights trained on every group
        let ins: Vec<(PathKind, f64)> =
            members.iter().map(|m| score(m, &cfg, &layout, full.as_ref().map(|f| &f.0))).collect();
        let (w, wk, mn) = summary(&ins);
        println!(
            "\n== {} (fit: {}): all groups in training ({}): members' worst kind {w:.4} ({wk}), mean {mn:.4}",
            cand.as_ref().map_or("off", |c| c.name),
            toml.trim().replace('\n', "; "),
            full.as_ref().map_or("no correction".to_string(), |f| f.1.clone())
        );
        println!("| left-out group | members | left out: worst kind | mean | in-sample: worst kind | mean | gap (worst) | chosen |");
        println!("|---|---|---|---|---|---|---|---|");
        let mut protocol: (f64, &str) = (0.0, "");
        let mut gap_max = 0.0f64;
        let mut sum_worst = 0.0;
        for (g, gc) in GROUPS {
            let train: [bool; CELLS] = std::array::from_fn(|c| !gc[c]);
            let lo = cand.as_ref().map(|c| weights(c, &tr, &va, &train));
            let idx: Vec<usize> = (0..members.len()).filter(|i| gc[mcell[*i]]).collect();
            let out: Vec<(PathKind, f64)> =
                idx.iter().map(|&i| score(&members[i], &cfg, &layout, lo.as_ref().map(|l| &l.0))).collect();
            let inn: Vec<(PathKind, f64)> = idx.iter().map(|&i| ins[i]).collect();
            let (ow, ok, om) = summary(&out);
            let (iw, ik, im) = summary(&inn);
            if ow > protocol.0 {
                protocol = (ow, g);
            }
            gap_max = gap_max.max(ow - iw);
            sum_worst += ow / GROUPS.len() as f64;
            println!(
                "| {g} | {} | {ow:.4} ({ok}) | {om:.4} | {iw:.4} ({ik}) | {im:.4} | {:+.4} | {} |",
                idx.len(),
                ow - iw,
                lo.as_ref().map_or("—".to_string(), |l| l.1.clone())
            );
        }
        println!(
            "{name}: PROTOCOL worst over left-out groups {:.4} ({}); mean of the groups' worst kinds {sum_worst:.4}; \
             largest gap {gap_max:+.4}; {:.0} s",
            protocol.0,
            protocol.1,
            t0.elapsed().as_secs_f64()
        );
    }
}
