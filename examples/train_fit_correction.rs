//! Trains the model fit's learned bias correction (`[stages.locate] fit_learned_correction`,
//! `gradtac_stages::fit_learned`) and writes its weights file
//! `gradtac-stages/src/fit_learned_weights.rs`, deterministically.
//!
//! Data: simulated recordings of `sim_family`'s **tuning** physics only (`PhysicsSet::Tuning`:
//! no Mexican hat, lags ≤ 30 ms) — training seeds 10 000.. and validation seeds 20 000..
//! (× 4 trajectory kinds), disjoint from the tuning members (0–7) and the held-out members
//! (100–115), which this example never simulates. Each recording runs through the `accurate`
//! fit (correction off, inputs recorded; since round 10 that fit estimates the lag online and
//! folds its kernel behind the 2 mm guard); a fitted frame's sample is its inputs and the
//! truth at the frame's middle time (less the member's fluid lag with `--lagged`), minus the
//! fit's raw position. Every 8th fitted frame is kept (`--every`). `examples/fit_lopo.rs`
//! re-trains the same way without one physics group at a time (round 10).
//!
//! Choice: the random features' bandwidths and the ridge penalty with the lowest mean
//! corrected distance on the validation recordings (training-distribution data, no family
//! member); then written.
//!
//! Run: `cargo run --release --example train_fit_correction [-- --train N --val M --dry --check]`
//! (N, M seeds; defaults 2000 and 200; `--dry` prints without writing; `--check` compares the
//! result with the committed file instead of writing it, every number within 1e-6 of the
//! largest weight, and fails otherwise — `scripts/fit_learned_check.sh`, in CI). ≈ 100 s on
//! one core after the build.
//!
//! Round 8's experiment options (none is the default): `--out PATH` writes (or `--check`s)
//! that file instead; `--locate 'TOML line'` (repeatable) changes the fit the samples come
//! from (a `[stages.locate]` line on top of `preset = "accurate"`); `--wide` draws every
//! training and validation recording's physics wider (see `widen`); `--gain-inputs` trains
//! weights that also read the fit's gain inputs (`fit_learned::GAIN_INPUTS`); `--grid wide`
//! chooses over bandwidths {0.25, 0.5, 1} × λ {1e-7, 1e-6, 1e-5} instead of round 6's
//! {0.125, 0.25} × {1e-6, 1e-5}. A file written with
//! `--out` is scored without rebuilding by `fit_probe --weights PATH`.

use gradtac::stages::fit_learned::{self, Correction};
use gradtac::stages::locate::LocateConfig;
use gradtac::stages::sim_family::{Member, Physics, PhysicsSet, IDEAL_TERMS};
use gradtac::stages::splitmix::SplitMix;
use gradtac::stream::Layout;
use std::time::Instant;

#[path = "fit_parts/fitted.rs"]
mod fitted;

/// Inputs, targets and the score's truth (at the middle time, not less the lag), each minus the
/// raw position.
type Samples = (Vec<Vec<f64>>, Vec<[f64; 2]>, Vec<[f64; 2]>);

/// `--wide` (round 8, candidate A): a wider draw of the tuning physics. With probability ½ the
/// member's physics as drawn; otherwise each of the six terms of [`IDEAL_TERMS`] is made ideal
/// with probability ½, and kept gains have their spread about 1 scaled by a factor in [0, 1].
/// From a sub-stream of the seed (deterministic); never a Mexican hat nor a lag over 30 ms.
fn widen(p: &mut Physics, m: &Member) {
    let mut rng = SplitMix::new(m.seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ (0x5749_4445 + m.kind as u64));
    if rng.uniform() < 0.5 {
        return;
    }
    for t in IDEAL_TERMS {
        if rng.uniform() < 0.5 {
            p.idealise(t);
        } else if t == "gains" {
            let s = rng.uniform();
            p.gain.iter_mut().for_each(|g| *g = g.signum() * (1.0 + s * (g.abs() - 1.0)));
        }
    }
}

fn samples(seeds: std::ops::Range<u64>, every: usize, lagged: bool, layout: &Layout, opts: &Opts) -> Samples {
    let (mut xs, mut ys, mut us) = (Vec::new(), Vec::new(), Vec::new());
    for m in Member::grid(seeds) {
        let mut p = m.physics_in(PhysicsSet::Tuning);
        if opts.wide {
            widen(&mut p, &m);
        }
        let rec = p.simulate(m.seed);
        let mut k = 0usize;
        fitted::each_fitted_frame(&rec, &opts.cfg, layout, |x, p, mid| {
            let shift = if lagged { rec.physics.lag_s } else { 0.0 };
            let Some(t) = rec.truth_at(mid - shift) else { return };
            let Some(u) = rec.truth_at(mid) else { return };
            k += 1;
            if k % every == 0 {
                xs.push(
                    x[..if opts.gain_inputs { fit_learned::INPUTS_WITH_GAINS } else { fit_learned::INPUTS }].to_vec(),
                );
                ys.push([t[0] - p[0], t[1] - p[1]]);
                us.push([u[0] - p[0], u[1] - p[1]]);
            }
        });
    }
    (xs, ys, us)
}

fn mean_dist(c: Option<&mut Correction>, xs: &[Vec<f64>], ys: &[[f64; 2]]) -> f64 {
    let mut c = c;
    let mut s = 0.0;
    for (x, y) in xs.iter().zip(ys) {
        let v = c.as_mut().map_or([0.0, 0.0], |c| c.apply(x));
        s += (y[0] - v[0]).hypot(y[1] - v[1]);
    }
    s / xs.len().max(1) as f64
}

/// Experiment options (round 8): the fit's settings and the wider draw.
struct Opts {
    /// The fit the samples come from: `preset = "accurate"` and the `--locate` lines.
    cfg: LocateConfig,
    /// `--wide`: [`widen`] every training and validation recording.
    wide: bool,
    /// `--gain-inputs` (round 8, candidate C): the weights read the fit's gain inputs too.
    gain_inputs: bool,
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut toml = String::from("preset = \"accurate\"\n");
    for (i, a) in args.iter().enumerate() {
        if a == "--locate" {
            toml.push_str(args.get(i + 1).expect("--locate 'TOML line'"));
            toml.push('\n');
        }
    }
    let cfg: LocateConfig = toml::from_str(&toml).expect("a [stages.locate] table");
    cfg.validate().expect("valid settings");
    let flag = |name: &str| args.iter().any(|a| a == name);
    let opts = Opts { cfg, wide: flag("--wide"), gain_inputs: flag("--gain-inputs") };
    let arg = |name: &str, d: u64| {
        args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(d)
    };
    let (n_train, n_val) = (arg("--train", 2000), arg("--val", 200));
    let dry = args.iter().any(|a| a == "--dry");
    let layout = Layout::biotac_sp();
    let t0 = Instant::now();
    let every = arg("--every", 8) as usize;
    // `--lagged`: targets at the middle time less the member's lag (the static bias only);
    // otherwise at the middle time (the score's truth: the correction may learn the lag too)
    let lagged = args.iter().any(|a| a == "--lagged");
    let (xt, yt, _) = samples(10_000..10_000 + n_train, every.max(1), lagged, &layout, &opts);
    let (xv, _, yv) = samples(20_000..20_000 + n_val, every.max(1), lagged, &layout, &opts);
    println!(
        "samples: {} training ({} seeds × 4), {} validation ({} seeds × 4); simulated and fitted in {:.1} s",
        xt.len(),
        n_train,
        xv.len(),
        n_val,
        t0.elapsed().as_secs_f64()
    );
    println!("validation mean distance without correction: {:.4} mm", mean_dist(None, &xv, &yv));
    // `--grid wide` (round 8, candidate E): past round 6's corner (0.25, 1e-6)
    let wide_grid = args.windows(2).any(|w| w[0] == "--grid" && w[1] == "wide");
    let (lambdas, bandwidths): (Vec<f64>, Vec<[f64; 2]>) = if wide_grid {
        (vec![1e-7, 1e-6, 1e-5], vec![[0.25, 0.25], [0.5, 0.5], [1.0, 1.0]])
    } else {
        (vec![1e-6, 1e-5], vec![[0.125, 0.125], [0.25, 0.25]])
    };
    let mut best: Option<(f64, fit_learned::Trained)> = None;
    for bw in bandwidths {
        let t1 = Instant::now();
        for t in fit_learned::train_path(&xt, &yt, &lambdas, bw).into_iter().flatten() {
            let mut c = Correction::try_new(t.clone()).expect("finite weights");
            let v = mean_dist(Some(&mut c), &xv, &yv);
            let tr = mean_dist(Some(&mut c), &xt, &yt);
            println!(
                "bandwidth {:?} lambda {:e}: validation {v:.4} mm, training {tr:.4} mm ({:.1} s)",
                bw,
                t.lambda,
                t1.elapsed().as_secs_f64()
            );
            if best.as_ref().is_none_or(|b| v < b.0) {
                best = Some((v, t));
            }
        }
    }
    let (v, t) = best.expect("at least one fit");
    println!("chosen: bandwidth {:?} lambda {:e}, validation {v:.4} mm", t.bandwidth, t.lambda);
    let prov = format!(
        "Training: sim_family tuning physics{}, seeds 10000..{} and validation seeds 20000..{} (× 4 kinds);\n\
         {} training / {} validation frames; chosen bandwidth {:?}, lambda {:e} (validation mean distance {:.4} mm).",
        if opts.wide { " (wider draw, --wide)" } else { "" },
        10_000 + n_train,
        20_000 + n_val,
        xt.len(),
        xv.len(),
        t.bandwidth,
        t.lambda,
        v
    );
    let default_path = concat!(env!("CARGO_MANIFEST_DIR"), "/gradtac-stages/src/fit_learned_weights.rs");
    let out = args.iter().position(|a| a == "--out").and_then(|i| args.get(i + 1));
    let path = out.map_or(default_path, |s| s.as_str());
    if args.iter().any(|a| a == "--check") {
        let committed = std::fs::read_to_string(path).expect("the committed weights file");
        let fresh = t.to_rust(&prov);
        let nums = |src: &str, name: &str| -> Vec<f64> {
            let line = src.lines().find(|l| l.contains(&format!("const {name}:"))).unwrap_or("");
            let body = line.find("= [").and_then(|a| line.rfind(']').map(|b| &line[a + 3..b])).unwrap_or("");
            body.split(", ").filter_map(|v| v.parse().ok()).collect()
        };
        let top = t.w.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs())).max(1.0);
        let mut worst = 0.0f64;
        let mut same = true;
        for name in ["MEAN", "SCALE", "WX", "WY"] {
            let (a, b) = (nums(&committed, name), nums(&fresh, name));
            same &= a.len() == b.len();
            for (x, y) in a.iter().zip(&b) {
                worst = worst.max((x - y).abs() / top);
            }
        }
        println!("check against {path}: largest difference {worst:.3e} of the largest weight ({top:.3e})");
        if !same || worst > 1e-6 {
            eprintln!("train_fit_correction: the committed weights are not what this example produces");
            std::process::exit(1);
        }
        println!("check passed");
    } else if !dry {
        std::fs::write(path, t.to_rust(&prov)).expect("write the weights file");
        println!("wrote {path}");
    }
    println!("total {:.1} s", t0.elapsed().as_secs_f64());
}
