//! Development probe for the model fit's settings (`[stages.locate]`, method `fit`): the
//! worst kind's mean error (fraction of the 26.6 mm width) on the family's **tuning** members
//! (seeds 0–7 × 4 kinds, `PhysicsSet::Tuning`), scored exactly as `examples/tradeoff.rs` scores
//! (every contact track point during the movement against the truth at the middle of its
//! span). Faster than `tradeoff` for exploring one key at a time.
//!
//! Run: `cargo run --release --example fit_probe -- [options] [TOML lines]`, e.g.
//! `-- 'fit_gain_memory = 300.0' 'window_frames = 5'`: each line is added to a
//! `[stages.locate]` table that starts from `preset = "accurate"`.
//!
//! Options: `--seeds N` (tuning seeds 0..N, default 8); `--only TERM` (an ideal sensor —
//! Gaussian kernel, 1 ms lag, no drift, 0.5 counts of noise, no saturation, unit gains that keep
//! each electrode's sign, its polarity (`Physics::idealise`) — with one term of the member's
//! physics kept: `gains`, `lag`, `kernel`, `drift`, `noise`, `knee`;
//! `none` keeps none); `--without TERM` (the member's physics with that term made ideal);
//! `--heldout` (score the held-out members, seeds 100–115 × 4 kinds, `PhysicsSet::HeldOut`,
//! instead: for a final candidate only, never for a choice); `--fresh` (score the `accurate`
//! preset as it is on the **fresh** held-out members, seeds 9000–9015 × 4 kinds,
//! `PhysicsSet::HeldOut`, stop 39: only for the adopted default, after adoption, reported in
//! `examples/fresh_check.md`; never for a choice, never inside a round's rule; refused with any
//! other argument); `--verbose` (each member's
//! kernel, learned shape exponent `q̂`, polarities decided right / wrong / undecided, and
//! error); `--weights PATH` (the learned correction's weights read from a file in
//! `train_fit_correction`'s format, e.g. one written with its `--out`, instead of the built-in
//! ones; the correction is then on whatever the TOML lines say). `--seeds N` above 100 is
//! refused (it would reach the held-out seeds). The held-out runs print how many of their 64
//! recordings have physics no choice saw (a Mexican-hat kernel or a lag over 30 ms).

use gradtac::stages::fit::Fit;
use gradtac::stages::fit_learned::{Correction, Trained};
use gradtac::stages::locate::LocateConfig;
use gradtac::stages::sim_family::{
    KernelShape, Member, PathKind, Physics, PhysicsSet, FRESH_SEEDS as FRESH, HELD_OUT_SEEDS as HELD_OUT, IDEAL_TERMS,
};
use gradtac::stages::track::{Track, TrackConfig};
use gradtac::stream::{Layout, Stage, StageExt};
use std::collections::HashMap;

fn ideal(p: &mut Physics, term: &str, keep: bool) {
    for t in IDEAL_TERMS {
        if (t == term) == keep {
            p.idealise(t);
        }
    }
}

/// Why the arguments are refused: `--fresh` with any other argument (the fresh set scores the
/// `accurate` preset as it is, one summary line, no member shown), or `--seeds N` reaching the
/// held-out seeds.
fn refusal(args: &[String]) -> Option<String> {
    if args.iter().any(|a| a == "--fresh") {
        if let Some(a) = args.iter().find(|a| *a != "--fresh") {
            return Some(format!("--fresh scores the `accurate` preset as it is: not with `{a}`"));
        }
    }
    let n = args.iter().position(|a| a == "--seeds").and_then(|i| args.get(i + 1)?.parse::<u64>().ok());
    match n {
        Some(n) if n > HELD_OUT.start => Some(format!("--seeds {n} reaches the held-out seeds {HELD_OUT:?}")),
        _ => None,
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let Some(e) = refusal(&args) {
        eprintln!("fit_probe: {e}");
        std::process::exit(2);
    }
    let fresh = args.iter().any(|a| a == "--fresh");
    let mut seeds = 8u64;
    let mut heldout = false;
    let mut verbose = false;
    let mut only: Option<String> = None;
    let mut without: Option<String> = None;
    let mut weights: Option<Trained> = None;
    let mut toml = String::from("preset = \"accurate\"\n");
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--seeds" => seeds = it.next().and_then(|v| v.parse().ok()).expect("--seeds N"),
            "--heldout" => heldout = true,
            "--fresh" => {}
            "--verbose" => verbose = true,
            "--only" => only = it.next().cloned(),
            "--without" => without = it.next().cloned(),
            "--weights" => {
                let path = it.next().expect("--weights PATH");
                let src = std::fs::read_to_string(path).expect("a weights file");
                weights = Some(Trained::from_rust(&src).expect("a weights file in train_fit_correction's format"));
            }
            line => {
                toml.push_str(line);
                toml.push('\n');
            }
        }
    }
    let cfg: LocateConfig = toml::from_str(&toml).expect("a [stages.locate] table");
    cfg.validate().expect("valid settings");
    let (set, members) = if fresh {
        (PhysicsSet::HeldOut, Member::grid(FRESH))
    } else if heldout {
        (PhysicsSet::HeldOut, Member::grid(HELD_OUT))
    } else {
        (PhysicsSet::Tuning, Member::grid(0..seeds))
    };
    let layout = Layout::biotac_sp();
    let width = layout.extent().width();
    let mut by_kind: HashMap<PathKind, Vec<f64>> = HashMap::new();
    let (mut contact, mut total) = (0usize, 0usize);
    if set == PhysicsSet::HeldOut {
        // held-out physics no choice saw: a Mexican-hat kernel or a fluid lag over 30 ms
        let novel = members
            .iter()
            .map(|m| m.physics_in(set))
            .filter(|p| matches!(p.kernel, KernelShape::MexicanHat { .. }) || p.lag_s > 0.030)
            .count();
        let hats =
            members.iter().filter(|m| matches!(m.physics_in(set).kernel, KernelShape::MexicanHat { .. })).count();
        let lags = members.iter().filter(|m| m.physics_in(set).lag_s > 0.030).count();
        println!(
            "{} recordings, {novel} with held-out physics ({hats} Mexican hat, {lags} lag over 30 ms)",
            members.len()
        );
    }
    for m in &members {
        let mut p = m.physics_in(set);
        if let Some(t) = &only {
            ideal(&mut p, t, false);
        }
        if let Some(t) = &without {
            ideal(&mut p, t, true);
        }
        let rec = p.simulate(m.seed);
        // the fit pushed by hand so that its learned kernel shape can be read before `finish`
        let mut fit = Fit::try_new(&cfg, &layout).unwrap();
        if let Some(w) = &weights {
            fit = fit.with_correction(Some(Correction::try_new(w.clone()).expect("usable weights")));
        }
        let mut contours = Vec::new();
        for f in rec.frames.iter().cloned() {
            fit.push(f, &mut contours).unwrap();
        }
        let shape = fit.shape();
        // polarity learning (`fit_polarity_votes`): decided polarities that agree with the
        // truth's signs / that disagree (up to the overall sign), and the undecided
        let pol = fit.polarity();
        let agree = pol.iter().zip(&p.gain).filter(|(q, g)| **q != 0.0 && q.signum() == -g.signum()).count();
        let against = pol.iter().zip(&p.gain).filter(|(q, g)| **q != 0.0 && q.signum() == g.signum()).count();
        let polarity = format!(
            "polarity {} / {} / {} unset",
            agree.max(against),
            agree.min(against),
            pol.iter().filter(|q| **q == 0.0).count()
        );
        fit.finish(&mut contours).unwrap();
        let pts = Track::try_new(&TrackConfig::default()).unwrap().run_all(contours).unwrap();
        // every track point during the movement; the contact ones scored against the truth
        // (with none, the truth's mean distance from the pad centre, as `tradeoff` scores it)
        let (t0, t1) = rec.moving_s;
        total += pts
            .iter()
            .filter(|q| {
                let mid = 0.5 * (q.start.as_secs_f64() + q.time.as_secs_f64());
                mid > t0 && mid < t1
            })
            .count();
        let errs = rec.track_errors_mm(&pts);
        contact += errs.len();
        let mean = rec.mean_track_error_mm(&errs);
        if verbose {
            println!(
                "  seed {:3} {:10} kernel {:12} q̂ {shape:.2} {polarity} | {:.4}",
                m.seed,
                m.kind.name(),
                rec.physics.kernel.name(),
                mean / width
            );
        }
        by_kind.entry(m.kind).or_default().push(mean / width);
    }
    let mut worst = (0.0, "");
    let mut all = Vec::new();
    let mut per = Vec::new();
    for k in PathKind::ALL {
        let v = &by_kind[&k];
        let mk = v.iter().sum::<f64>() / v.len() as f64;
        all.extend_from_slice(v);
        per.push(format!("{} {mk:.4}", k.name()));
        if mk > worst.0 {
            worst = (mk, k.name());
        }
    }
    println!(
        "{} | worst {:.4} ({}) | mean {:.4} | contact {:.1} % | {} | {}",
        if fresh {
            "FRESH HELD OUT (seeds 9000–9015, never used for a choice)"
        } else if heldout {
            "HELD OUT"
        } else {
            "tuning"
        },
        worst.0,
        worst.1,
        all.iter().sum::<f64>() / all.len() as f64,
        100.0 * contact as f64 / total.max(1) as f64,
        per.join(", "),
        args.join(" ")
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(a: &[&str]) -> Vec<String> {
        a.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn fresh_scores_the_preset_alone() {
        assert_eq!(refusal(&args(&["--fresh"])), None);
        for other in
            [&["--heldout"][..], &["--verbose"], &["--seeds", "4"], &["--only", "gains"], &["window_frames = 5"]]
        {
            let mut a = args(other);
            a.push("--fresh".into());
            assert!(refusal(&a).is_some_and(|e| e.contains("--fresh")), "{a:?}");
        }
    }

    #[test]
    fn the_tuning_seeds_stop_before_the_held_out_ones() {
        assert_eq!(refusal(&args(&["--seeds", "24"])), None);
        assert_eq!(refusal(&args(&["--seeds", "100"])), None);
        assert!(refusal(&args(&["--seeds", "101"])).is_some());
        assert!(refusal(&args(&["--seeds", "9016"])).is_some());
    }
}
