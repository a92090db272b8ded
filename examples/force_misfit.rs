//! Diagnosis (#22, session 39; `examples/force_parts/misfit.md`): can the **identified forward
//! model** tell a stuck contact (a drift change the force gate holds as a contact) from a press?
//!
//! Per tuning member (never the held-out seeds 100–115 or 9000–9015: refused), exactly as
//! `force_eval` does: one session of 10 presses ([`ForceSession::presses`]), the force stage's
//! detector and gate (`force_detector`, the layout's positions) over the whole session, the
//! default `forward` calibration (`calibrate_with`, `ForwardSettings::default()`) on the gauge
//! during presses 1–5. When the guard writes `placed`, the unguarded identification
//! (`calibrate_unguarded_with`) gives the forward model used for the misfit (the force read is
//! still the written file's). For every frame the gate holds as contact:
//!
//! - **misfit** `Σᵢ (wᵢ(Δᵢ − mᵢ))² / Σᵢ (wᵢΔᵢ)²`: `mᵢ` the model's prediction at the inversion's
//!   `(x, y, F)` ([`ForwardModel::invert`], [`ForwardModel::predict`]), `wᵢ` the inversion's
//!   own residual weights `1/√(s₀² + (rᵢΔᵢ)²)` (round 10; 1 without gain doubts) — the share of
//!   the change one press of the model cannot explain;
//! - two cheap baselines: `1 − F` with `F` the gate's magnitude shape fraction
//!   (`locate::press_shaped_magnitude`), and `1 − cos` with `cos` the cosine of the frame's
//!   `Δᵢ/σᵢ` with its contact's peak pattern (as `gate_probe` prints).
//!
//! Labels (the true force at the frame's centre, as `force_eval` scores): `press` (> 0.5 N),
//! `light` (0 < F ≤ 0.5 N), `lifted` (0 N, but force within the last 0.5 s) and
//! `untouched` (0 N for the last 0.5 s: `force_eval`'s untouched frames) — here only those the
//! gate holds as contact ("untouched-but-held"), and among them those read above 0.5 N.
//!
//! Run: `cargo run --release --example force_misfit [-- 0..8 700..706 200..248 212] [--threads 2]`
//! (no seed: the 62 tuning members). Prints markdown tables on stdout.

use gradtac::stages::force::ForceMethod;
use gradtac::stages::force_ident::{ForwardModel, Geometry};
use gradtac::stages::force_model::{
    calibrate_unguarded_with, calibrate_with, force_detector, CalibratedForce, CalibrationMethod, ForcePredictor,
    ForwardSettings, GaugeSample,
};
use gradtac::stages::locate::{press_shaped_magnitude, LocateConfig};
use gradtac::stages::sim_force::{is_held_out, ForceRecording, ForceSession};
use gradtac::stream::Layout;

const PRESSES: usize = 10;
/// The 62 tuning members.
const TUNING: [std::ops::Range<u64>; 3] = [0..8, 700..706, 200..248];
/// Frame period (s): the simulator runs at 100 Hz.
const DT: f64 = 0.01;

/// A frame's label by its true force.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Label {
    /// True force above 0.5 N.
    Press,
    /// 0 < F ≤ 0.5 N.
    Light,
    /// 0 N, but a force within the last 0.5 s.
    Lifted,
    /// 0 N for the last 0.5 s (`force_eval`'s untouched frames).
    Untouched,
}

/// One frame the gate holds as contact.
#[derive(Clone, Debug)]
struct Held {
    t: f64,
    label: Label,
    /// The written file's force (N; NaN without).
    read: f64,
    misfit: f64,
    /// 1 − the magnitude shape fraction.
    shape: f64,
    /// 1 − the cosine with the contact's peak pattern.
    cos: f64,
    /// Index of the contact run (per member).
    run: usize,
    /// Index of the session segment.
    seg: usize,
}

/// A member's result.
struct MemberOut {
    seed: u64,
    placed: bool,
    held: Vec<Held>,
    untouched: usize,
    /// `force_eval`'s scored frames (presses 6–10, true force > 0.5 N): the relative error of
    /// the written file's reading (1 without one) and the frame's index in `held` if held.
    scored: Vec<(f64, Option<usize>)>,
    /// Untouched frames (held or not) read above 0.5 N.
    over: usize,
}

/// The relative misfit `Σ (wᵢ(Δᵢ − mᵢ))² / Σ (wᵢΔᵢ)²` (1 when nothing changed or inputs differ in length).
fn relative_misfit(delta: &[f64], model: &[f64], w: Option<&[f64]>) -> f64 {
    if delta.len() != model.len() || w.is_some_and(|w| w.len() != delta.len()) {
        return 1.0;
    }
    let wi = |i: usize| w.map_or(1.0, |w| w[i]);
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..delta.len() {
        num += (wi(i) * (delta[i] - model[i])).powi(2);
        den += (wi(i) * delta[i]).powi(2);
    }
    if den > 0.0 && num.is_finite() {
        num / den
    } else {
        1.0
    }
}

/// The forward model's relative misfit of one frame's changes.
fn frame_misfit(model: &ForwardModel, geo: &Geometry, delta: &[f64]) -> f64 {
    let Some([x, y, f]) = model.invert(geo, delta) else { return f64::NAN };
    let pred = model.predict(geo, x, y, f);
    relative_misfit(delta, &pred, model.residual_weights(delta).as_deref())
}

/// The `q`-quantile (0–1) of `v` by the nearest rank (NaN for an empty slice); sorts `v`.
fn quantile(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let k = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
    v[k]
}

/// Share of `v` strictly above `t` (NaN when empty).
fn share_above(v: &[f64], t: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.iter().filter(|x| **x > t).count() as f64 / v.len() as f64
}

/// Per frame of a contact run (in order): whether the rule "release once the statistic has
/// stayed above `t` for `n` consecutive frames" has released the run by that frame (the `n`-th
/// frame above `t` is the first released one).
fn released(stat: &[f64], t: f64, n: usize) -> Vec<bool> {
    let (mut count, mut gone) = (0usize, false);
    stat.iter()
        .map(|&s| {
            count = if s > t { count + 1 } else { 0 };
            gone |= n > 0 && count >= n;
            gone
        })
        .collect()
}

/// Runs one member.
fn member(seed: u64) -> MemberOut {
    let layout = Layout::biotac_sp();
    let positions = layout.positions().to_vec();
    let session = ForceSession::presses(seed, PRESSES);
    let rec: ForceRecording = session.simulate();
    let mut det = force_detector(24, &LocateConfig::default()).unwrap().with_positions(&positions).unwrap();
    // per frame: the sample, its noise σ
    let mut rows: Vec<(GaugeSample, Vec<f64>)> = Vec::with_capacity(rec.frames.len());
    for f in &rec.frames {
        let ch = det.push(f, "force").unwrap();
        let t = 0.5 * (ch.start.as_secs_f64() + ch.end.as_secs_f64());
        rows.push((
            GaugeSample {
                change: det.change().to_vec(),
                contact: ch.contact,
                area_mm2: None,
                amplitude: None,
                force_n: 0.0,
                time_s: t,
            },
            det.noise().to_vec(),
        ));
    }
    // calibrate as force_eval does: the gauge during presses 1–5
    let split = session.after_press_s(PRESSES / 2);
    let train: Vec<GaugeSample> = rows
        .iter()
        .filter(|r| r.0.time_s < split)
        .map(|r| GaugeSample { force_n: rec.gauge_at(r.0.time_s), ..r.0.clone() })
        .collect();
    let (method, lambda, curve) = (CalibrationMethod::Forward, 0.0, ForceMethod::Linear);
    let fwd = ForwardSettings::default();
    let file = calibrate_with(&train, method, lambda, curve, &layout, fwd).expect("calibration");
    let placed = !matches!(file.model, CalibratedForce::Forward { .. });
    let fmodel = if placed {
        calibrate_unguarded_with(&train, method, lambda, curve, &layout, fwd.starts).expect("unguarded").model
    } else {
        file.model.clone()
    };
    let CalibratedForce::Forward { lag_s, .. } = &fmodel else { unreachable!("a forward model") };
    assert!(*lag_s == 0.0, "the calibration writes lag 0; a lagged model needs the lead inverse");
    let (model, geo) = fmodel.forward().unwrap();
    let mut predictor = ForcePredictor::new(&file.model);
    let (mut held, mut untouched, mut scored, mut over) = (Vec::new(), 0usize, Vec::new(), 0usize);
    let (mut run, mut was, mut peak) = (0usize, false, (0.0f64, Vec::<f64>::new()));
    for (k, (s, sigma)) in rows.iter().enumerate() {
        let read = predictor.push(s).unwrap_or(f64::NAN);
        let t = s.time_s;
        let f = rec.force_at(t);
        let quiet = rec.untouched_at(t);
        untouched += usize::from(quiet);
        over += usize::from(quiet && read > 0.5);
        if t >= split && f > 0.5 {
            let err = if read.is_finite() { (read - f).abs() / f } else { 1.0 };
            scored.push((err, s.contact.then_some(held.len())));
        }
        if !s.contact {
            was = false;
            continue;
        }
        if !was {
            run += 1;
            peak = (0.0, Vec::new());
        }
        was = true;
        let e: Vec<f64> = s.change.iter().zip(sigma).map(|(d, g)| if *g > 0.0 { d / g } else { 0.0 }).collect();
        let total: f64 = s.change.iter().map(|d| d.abs()).sum();
        if total > peak.0 {
            peak = (total, e.clone());
        }
        let cos = {
            let ab: f64 = e.iter().zip(&peak.1).map(|(x, y)| x * y).sum();
            let aa: f64 = e.iter().map(|x| x * x).sum();
            let bb: f64 = peak.1.iter().map(|x| x * x).sum();
            if aa > 0.0 && bb > 0.0 {
                ab / (aa * bb).sqrt()
            } else {
                1.0
            }
        };
        let label = if f > 0.5 {
            Label::Press
        } else if f > 0.0 {
            Label::Light
        } else if quiet {
            Label::Untouched
        } else {
            Label::Lifted
        };
        held.push(Held {
            t,
            label,
            read,
            misfit: frame_misfit(&model, &geo, &s.change),
            shape: 1.0 - press_shaped_magnitude(&s.change, sigma, &positions),
            cos: 1.0 - cos,
            run,
            seg: rec.segment.get(k).copied().unwrap_or(0),
        });
    }
    MemberOut { seed, placed, held, untouched, scored, over }
}

/// The seeds named on the command line (`a..b` ranges or single seeds), or the 62 tuning members.
fn seeds(args: &[String]) -> Vec<u64> {
    let mut out = Vec::new();
    let mut skip = false;
    for a in args {
        if skip {
            skip = false;
            continue;
        }
        if a == "--threads" {
            skip = true;
            continue;
        }
        if let Some((x, y)) = a.split_once("..") {
            out.extend(x.parse::<u64>().expect("a seed range a..b")..y.parse::<u64>().expect("a seed range a..b"));
        } else {
            out.push(a.parse::<u64>().expect("a seed"));
        }
    }
    if out.is_empty() {
        out = TUNING.iter().flat_map(|r| r.clone()).collect();
    }
    for s in &out {
        assert!(!is_held_out(*s), "seed {s} is held out (100–115, 9000–9015): refused");
    }
    out
}

/// The drift-side statistic by name.
fn stat(h: &Held, k: usize) -> f64 {
    [h.misfit, h.shape, h.cos][k]
}
const STATS: [&str; 3] = ["misfit (forward model)", "1 − shape fraction", "1 − cos to the contact's peak"];

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let threads: usize = args
        .iter()
        .position(|a| a == "--threads")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse().ok())
        .unwrap_or(1)
        .max(1);
    let seeds = seeds(&args);
    let t0 = std::time::Instant::now();
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut outs: Vec<MemberOut> = std::thread::scope(|sc| {
        let hs: Vec<_> = (0..threads)
            .map(|_| {
                sc.spawn(|| {
                    let mut v = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(&s) = seeds.get(i) else { break };
                        let m = member(s);
                        eprintln!(
                            "seed {s}: {} held frames, {} untouched-but-held{} ({:.0} s)",
                            m.held.len(),
                            m.held.iter().filter(|h| h.label == Label::Untouched).count(),
                            if m.placed { ", placed: unguarded model for the misfit" } else { "" },
                            t0.elapsed().as_secs_f64()
                        );
                        v.push(m);
                    }
                    v
                })
            })
            .collect();
        hs.into_iter().flat_map(|h| h.join().unwrap()).collect()
    });
    outs.sort_by_key(|m| m.seed);
    report(&outs);
    eprintln!("{} members in {:.0} s", outs.len(), t0.elapsed().as_secs_f64());
}

/// A frame selection.
type Pick = fn(&Held) -> bool;

/// Median, p90, p99 of a statistic over frames.
fn dist(v: &[f64]) -> String {
    let mut v: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    format!("{:.3} / {:.3} / {:.3}", quantile(&mut v, 0.5), quantile(&mut v, 0.9), quantile(&mut v, 0.99))
}

fn report(outs: &[MemberOut]) {
    let all: Vec<&Held> = outs.iter().flat_map(|m| &m.held).collect();
    let untouched: usize = outs.iter().map(|m| m.untouched).sum();
    let placed: Vec<u64> = outs.iter().filter(|m| m.placed).map(|m| m.seed).collect();
    println!("members {}; `placed` (unguarded model for the misfit): {placed:?}", outs.len());
    println!(
        "untouched frames {untouched}; held as contact {}; of those read > 0.5 N {}\n",
        all.iter().filter(|h| h.label == Label::Untouched).count(),
        all.iter().filter(|h| h.label == Label::Untouched && h.read > 0.5).count()
    );
    // 1. per label
    println!("| label | frames | misfit median / p90 / p99 | 1 − shape F | 1 − cos |");
    println!("|---|---|---|---|---|");
    let labels: [(&str, Pick); 5] = [
        ("true press (> 0.5 N)", (|h: &Held| h.label == Label::Press)),
        ("true light (0–0.5 N)", (|h: &Held| h.label == Label::Light)),
        ("lifted < 0.5 s (0 N)", (|h: &Held| h.label == Label::Lifted)),
        ("untouched-but-held", (|h: &Held| h.label == Label::Untouched)),
        ("untouched-but-held, read > 0.5 N", (|h: &Held| h.label == Label::Untouched && h.read > 0.5)),
    ];
    for (name, f) in &labels {
        let sel: Vec<&&Held> = all.iter().filter(|h| f(h)).collect();
        let col = |k: usize| dist(&sel.iter().map(|h| stat(h, k)).collect::<Vec<_>>());
        println!("| {name} | {} | {} | {} | {} |", sel.len(), col(0), col(1), col(2));
    }
    // 2. per member: untouched-but-held frames
    println!("\n| member | untouched-but-held (read > 0.5 N) | misfit median / p90 / p99 | its presses' misfit median / p90 | 1 − shape F median | 1 − cos median |");
    println!("|---|---|---|---|---|---|");
    for m in outs {
        let u: Vec<&Held> = m.held.iter().filter(|h| h.label == Label::Untouched).collect();
        if u.is_empty() {
            continue;
        }
        let mut p: Vec<f64> = m.held.iter().filter(|h| h.label == Label::Press).map(|h| h.misfit).collect();
        let (p50, p90) = (quantile(&mut p, 0.5), quantile(&mut p, 0.9));
        let mut sh: Vec<f64> = u.iter().map(|h| h.shape).collect();
        let mut co: Vec<f64> = u.iter().map(|h| h.cos).collect();
        println!(
            "| {}{} | {} ({}) | {} | {p50:.3} / {p90:.3} | {:.3} | {:.3} |",
            m.seed,
            if m.placed { " (placed)" } else { "" },
            u.len(),
            u.iter().filter(|h| h.read > 0.5).count(),
            dist(&u.iter().map(|h| h.misfit).collect::<Vec<_>>()),
            quantile(&mut sh, 0.5),
            quantile(&mut co, 0.5)
        );
    }
    // 3. separation at fixed thresholds, per statistic
    for (k, name) in STATS.iter().enumerate() {
        println!("\n**{name}**: share above t (pooled; worst member = lowest untouched share among members with ≥ 10 untouched-but-held frames, highest press share)\n");
        println!("| t | untouched-but-held > t | read > 0.5 N > t | worst member (untouched) | true press > t | worst member (press) |");
        println!("|---|---|---|---|---|---|");
        for t in [0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.9] {
            let pick =
                |f: &dyn Fn(&Held) -> bool| -> Vec<f64> { all.iter().filter(|h| f(h)).map(|h| stat(h, k)).collect() };
            let u = pick(&|h| h.label == Label::Untouched);
            let r = pick(&|h| h.label == Label::Untouched && h.read > 0.5);
            let p = pick(&|h| h.label == Label::Press);
            let mut worst_u = (f64::INFINITY, 0u64);
            let mut worst_p = (f64::NEG_INFINITY, 0u64);
            for m in outs {
                let u: Vec<f64> = m.held.iter().filter(|h| h.label == Label::Untouched).map(|h| stat(h, k)).collect();
                if u.len() >= 10 && share_above(&u, t) < worst_u.0 {
                    worst_u = (share_above(&u, t), m.seed);
                }
                let p: Vec<f64> = m.held.iter().filter(|h| h.label == Label::Press).map(|h| stat(h, k)).collect();
                if !p.is_empty() && share_above(&p, t) > worst_p.0 {
                    worst_p = (share_above(&p, t), m.seed);
                }
            }
            println!(
                "| {t} | {:.1} % | {:.1} % | {:.1} % ({}) | {:.2} % | {:.1} % ({}) |",
                100.0 * share_above(&u, t),
                100.0 * share_above(&r, t),
                100.0 * worst_u.0,
                worst_u.1,
                100.0 * share_above(&p, t),
                100.0 * worst_p.0,
                worst_p.1
            );
        }
    }
    // 4. matched cost: the threshold at which a given share of true-press frames is above, per statistic
    println!("\n**Matched cost** (per statistic, t set so that the pooled share of true-press frames above t is c; the untouched-but-held share above that t)\n");
    println!("| c (press frames above t) | {} | {} | {} |", STATS[0], STATS[1], STATS[2]);
    println!("|---|---|---|---|");
    for c in [0.001, 0.01, 0.05, 0.1, 0.2] {
        let cells: Vec<String> = (0..3)
            .map(|k| {
                let mut p: Vec<f64> = all.iter().filter(|h| h.label == Label::Press).map(|h| stat(h, k)).collect();
                let t = quantile(&mut p, 1.0 - c);
                let u: Vec<f64> = all.iter().filter(|h| h.label == Label::Untouched).map(|h| stat(h, k)).collect();
                let r: Vec<f64> =
                    all.iter().filter(|h| h.label == Label::Untouched && h.read > 0.5).map(|h| stat(h, k)).collect();
                format!(
                    "t {t:.3}: {:.1} % ({:.1} % of read > 0.5 N)",
                    100.0 * share_above(&u, t),
                    100.0 * share_above(&r, t)
                )
            })
            .collect();
        println!("| {c} | {} |", cells.join(" | "));
    }
    // 5. how the misfit evolves in the stuck members, rest by rest
    for seed in [212u64, 205] {
        let Some(m) = outs.iter().find(|m| m.seed == seed) else { continue };
        println!("\n**Member {seed}{}**: per segment held as contact (odd: press k, even: the rest after it), misfit median (p10–p90), 1 − cos median, read median\n", if m.placed { " (placed; misfit from the unguarded model)" } else { "" });
        println!("| segment | time (s) | run | frames held | label mix (press/light/lifted/untouched) | misfit median (p10–p90) | 1 − shape F | 1 − cos | read N |");
        println!("|---|---|---|---|---|---|---|---|---|");
        let nseg = m.held.iter().map(|h| h.seg).max().unwrap_or(0) + 1;
        for s in 0..nseg {
            let h: Vec<&Held> = m.held.iter().filter(|h| h.seg == s).collect();
            if h.is_empty() {
                continue;
            }
            let c = |l: Label| h.iter().filter(|x| x.label == l).count();
            let mut mf: Vec<f64> = h.iter().map(|x| x.misfit).collect();
            let mut sh: Vec<f64> = h.iter().map(|x| x.shape).collect();
            let mut co: Vec<f64> = h.iter().map(|x| x.cos).collect();
            let mut rd: Vec<f64> = h.iter().map(|x| x.read).filter(|x| x.is_finite()).collect();
            let runs: std::collections::BTreeSet<usize> = h.iter().map(|x| x.run).collect();
            println!(
                "| {s} | {:.2}–{:.2} | {runs:?} | {} | {}/{}/{}/{} | {:.3} ({:.3}–{:.3}) | {:.3} | {:.3} | {:.2} |",
                h[0].t,
                h[h.len() - 1].t,
                h.len(),
                c(Label::Press),
                c(Label::Light),
                c(Label::Lifted),
                c(Label::Untouched),
                quantile(&mut mf, 0.5),
                quantile(&mut mf, 0.1),
                quantile(&mut mf, 0.9),
                quantile(&mut sh, 0.5),
                quantile(&mut co, 0.5),
                quantile(&mut rd, 0.5)
            );
        }
    }
    // 6. the rule "release a contact whose statistic stays above t for T s", offline
    println!("\n**Offline rule** \"release a contact once its statistic has stayed above t for T s\" (per contact run; frames from the release on read no force; the gate's state after a release — its baseline settling to the released level — is not simulated)\n");
    println!("| statistic | t | T (s) | untouched read > 0.5 N (of {untouched}) | untouched-but-held released | true-press frames released | members losing press frames (most: member, share) | offline worst MAPE | offline mean MAPE |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let n_u = all.iter().filter(|h| h.label == Label::Untouched).count();
    let n_p = all.iter().filter(|h| h.label == Label::Press).count();
    let base = rule_row(outs, None, false);
    println!(
        "| none (today) | | | {} | 0 of {n_u} | 0 of {n_p} | 0 | {:.1} % ({}) | {:.2} % |",
        base.over, base.worst.0, base.worst.1, base.mean
    );
    for k in 0..3 {
        for t in [0.3, 0.4, 0.5, 0.7, 0.9] {
            for tt in [0.1, 0.3, 0.5, 1.0, 2.0, 3.0] {
                let r = rule_row(outs, Some((k, t, (tt / DT).round() as usize)), false);
                println!(
                    "| {} | {t} | {tt} | {} | {} of {n_u} | {} of {n_p} ({:.2} %) | {} ({}, {:.1} %) | {:.1} % ({}) | {:.2} % |",
                    ["misfit", "1 − shape", "1 − cos"][k],
                    r.over,
                    r.released_untouched,
                    r.released_press,
                    100.0 * r.released_press as f64 / n_p.max(1) as f64,
                    r.losing,
                    r.most.1,
                    100.0 * r.most.0,
                    r.worst.0,
                    r.worst.1,
                    r.mean
                );
            }
        }
    }
    // 7. a few rules member by member
    println!("\n**Rules member by member** (offline; members whose MAPE moves by more than 1 point, and the release times of 212 and 205's runs)\n");
    println!("| rule | MAPE up (member: today → rule) | MAPE down | 212 released at (s) | 205 released at (s) | on `forward` files only: untouched > 0.5 N, worst, mean |");
    println!("|---|---|---|---|---|---|");
    for (k, t, tt) in [
        (0usize, 0.3, 1.0),
        (0, 0.3, 2.0),
        (0, 0.3, 3.0),
        (0, 0.4, 2.0),
        (0, 0.5, 2.0),
        (0, 0.7, 2.0),
        (1, 0.7, 1.0),
        (2, 0.5, 2.0),
        (2, 0.7, 2.0),
    ] {
        let n = (tt / DT).round() as usize;
        let (mut up, mut down, mut rel) = (Vec::new(), Vec::new(), [String::new(), String::new()]);
        for m in outs {
            let base = 100.0 * member_mape(&m.scored, &vec![false; m.held.len()]);
            let (mape, times) = rule_detail(m, k, t, n);
            if mape > base + 1.0 {
                up.push(format!("{} {base:.1} → {mape:.1}", m.seed));
            } else if mape < base - 1.0 {
                down.push(format!("{} {base:.1} → {mape:.1}", m.seed));
            }
            if let Some(j) = [212u64, 205].iter().position(|s| *s == m.seed) {
                rel[j] = times.iter().map(|x| format!("{x:.2}")).collect::<Vec<_>>().join(", ");
            }
        }
        let f = rule_row(outs, Some((k, t, n)), true);
        println!(
            "| {} > {t} for {tt} s | {} | {} | {} | {} | {}, {:.1} % ({}), {:.2} % |",
            ["misfit", "1 − shape", "1 − cos"][k],
            up.join("; "),
            down.join("; "),
            rel[0],
            rel[1],
            f.over,
            f.worst.0,
            f.worst.1,
            f.mean
        );
    }
}

/// The offline rule's per-member MAPE (%) and release times (s) of each released run, for one rule.
fn rule_detail(m: &MemberOut, k: usize, t: f64, n: usize) -> (f64, Vec<f64>) {
    let mut gone = vec![false; m.held.len()];
    let mut times = Vec::new();
    let mut start = 0;
    while start < m.held.len() {
        let run = m.held[start].run;
        let end = start + m.held[start..].iter().take_while(|h| h.run == run).count();
        let st: Vec<f64> = m.held[start..end].iter().map(|h| stat(h, k)).collect();
        let rel = released(&st, t, n);
        if let Some(i) = rel.iter().position(|g| *g) {
            times.push(m.held[start + i].t);
        }
        gone[start..end].copy_from_slice(&rel);
        start = end;
    }
    (100.0 * member_mape(&m.scored, &gone), times)
}

/// The offline rule's figures over the members.
struct RuleRow {
    over: usize,
    released_untouched: usize,
    released_press: usize,
    losing: usize,
    most: (f64, u64),
    worst: (f64, u64),
    mean: f64,
}

/// Applies the offline rule `(statistic, t, frames)` (none: today) to every member.
/// With `forward_only`, members whose file is `placed` keep today's frames (a `placed` file stores
/// no forward model, so a run-time misfit cannot be computed for them).
fn rule_row(outs: &[MemberOut], rule: Option<(usize, f64, usize)>, forward_only: bool) -> RuleRow {
    let mut r = RuleRow {
        over: 0,
        released_untouched: 0,
        released_press: 0,
        losing: 0,
        most: (0.0, 0),
        worst: (0.0, 0),
        mean: 0.0,
    };
    for m in outs {
        let mut gone = vec![false; m.held.len()];
        if let Some((k, t, n)) = rule.filter(|_| !(forward_only && m.placed)) {
            let mut start = 0;
            while start < m.held.len() {
                let run = m.held[start].run;
                let end = start + m.held[start..].iter().take_while(|h| h.run == run).count();
                let st: Vec<f64> = m.held[start..end].iter().map(|h| stat(h, k)).collect();
                gone[start..end].copy_from_slice(&released(&st, t, n));
                start = end;
            }
        }
        let mut lost = 0usize;
        let mut freed_over = 0usize;
        for (h, g) in m.held.iter().zip(&gone) {
            if *g {
                r.released_untouched += usize::from(h.label == Label::Untouched);
                freed_over += usize::from(h.label == Label::Untouched && h.read > 0.5);
                lost += usize::from(h.label == Label::Press);
            }
        }
        r.over += m.over - freed_over;
        r.released_press += lost;
        r.losing += usize::from(lost > 0);
        let np = m.held.iter().filter(|h| h.label == Label::Press).count().max(1);
        if lost as f64 / np as f64 > r.most.0 {
            r.most = (lost as f64 / np as f64, m.seed);
        }
        let mape = 100.0 * member_mape(&m.scored, &gone);
        if mape > r.worst.0 {
            r.worst = (mape, m.seed);
        }
        r.mean += mape / outs.len() as f64;
    }
    r
}

/// MAPE (fraction) over scored frames `(error, index in the held frames)`: a released frame counts 1.
fn member_mape(scored: &[(f64, Option<usize>)], gone: &[bool]) -> f64 {
    let sum: f64 = scored.iter().map(|(e, i)| if i.is_some_and(|i| gone[i]) { 1.0 } else { *e }).sum();
    sum / scored.len().max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn misfit_is_zero_for_a_perfect_prediction_and_one_for_none() {
        let d = [3.0, -4.0, 0.5];
        assert_eq!(relative_misfit(&d, &d, None), 0.0);
        assert_eq!(relative_misfit(&d, &[0.0; 3], None), 1.0);
        // half the change explained on every taxel: a quarter of the energy is left
        let half: Vec<f64> = d.iter().map(|x| 0.5 * x).collect();
        assert!((relative_misfit(&d, &half, None) - 0.25).abs() < 1e-12);
        // weights: a zero-weight taxel does not count
        let w = [1.0, 1.0, 0.0];
        assert_eq!(relative_misfit(&d, &[3.0, -4.0, 99.0], Some(&w)), 0.0);
        // degenerate input
        assert_eq!(relative_misfit(&[0.0; 3], &[0.0; 3], None), 1.0);
        assert_eq!(relative_misfit(&d, &[0.0; 2], None), 1.0);
    }

    #[test]
    fn a_model_explains_its_own_press_and_not_scattered_offsets() {
        let layout = Layout::biotac_sp();
        let geo = Geometry::for_positions(layout.positions());
        let model = ForwardModel {
            gains: (0..24).map(|i| if i % 5 == 0 { 40.0 } else { -60.0 }).collect(),
            exponent: 0.8,
            spread: 0.2,
            width_mm: 2.5,
            shape: 2.0,
            lobe: 0.0,
            gain_rel_sd: Some(vec![0.05; 24]),
        };
        let c = geo.centroid(&[1.0; 24]).unwrap();
        let press = model.predict(&geo, c[0] + 1.0, c[1] - 0.5, 3.0);
        assert!(frame_misfit(&model, &geo, &press) < 1e-3);
        // offsets of mixed sign and no spatial shape, as large as the press
        let scattered: Vec<f64> = (0..24).map(|i| if (i * 7) % 3 == 0 { 30.0 } else { -25.0 }).collect();
        assert!(frame_misfit(&model, &geo, &scattered) > 0.3);
    }

    #[test]
    fn a_released_frame_counts_one() {
        let scored = [(0.1, Some(0)), (0.3, Some(1)), (0.5, None)];
        assert!((member_mape(&scored, &[false, false]) - 0.3).abs() < 1e-12);
        assert!((member_mape(&scored, &[false, true]) - 1.6 / 3.0).abs() < 1e-12);
        assert_eq!(member_mape(&[], &[]), 0.0);
    }

    #[test]
    fn quantiles_and_shares() {
        let mut v = vec![5.0, 1.0, 3.0, 2.0, 4.0];
        assert_eq!(quantile(&mut v, 0.5), 3.0);
        assert_eq!(quantile(&mut v, 0.9), 5.0);
        assert_eq!(quantile(&mut v, 0.0), 1.0);
        assert!(quantile(&mut [], 0.5).is_nan());
        assert_eq!(share_above(&[0.1, 0.5, 0.9, 0.5], 0.5), 0.25);
        assert!(share_above(&[], 0.5).is_nan());
    }

    #[test]
    fn release_needs_consecutive_frames_above() {
        let s = [0.9, 0.9, 0.1, 0.9, 0.9, 0.9, 0.1];
        assert_eq!(released(&s, 0.5, 3), [false, false, false, false, false, true, true]);
        assert_eq!(released(&s, 0.5, 1), [true; 7]);
        assert_eq!(released(&s, 0.95, 1), [false; 7]);
        assert_eq!(released(&s, 0.5, 0), [false; 7]);
    }

    #[test]
    fn held_out_seeds_are_refused_and_the_default_is_the_62() {
        assert_eq!(seeds(&[]).len(), 62);
        assert_eq!(seeds(&["--threads".into(), "2".into(), "212".into()]), [212]);
        for s in ["100", "115", "9000", "9015", "99..101"] {
            let r = std::panic::catch_unwind(|| seeds(&[s.to_string()]));
            assert!(r.is_err(), "{s} must be refused");
        }
    }
}
