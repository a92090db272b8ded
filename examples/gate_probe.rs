//! Probe of the force gate's returns (`examples/force_parts/history.md`, "The force gate's returns"): per press
//! of a force-family member, the peak total change `Σ|Δᵢ|`, the total change and the largest
//! `|Δᵢ|/σᵢ` at the end of the rest that follows, and whether the contact had ended (the
//! return rule fired) by then. Without arguments: the tuning members 0–7 and
//! `tests/cli_force.rs`'s member 700; any seed may be named except the held-out seeds 100–115
//! and the fresh held-out seeds 9000–9015 (`examples/fresh_check.md`), which it refuses.
//!
//! Since session 35 the detector gets the layout's positions (as the force stage gives them:
//! the drift-shape return needs them), and each rest also prints the magnitude shape fraction,
//! whether the frame is steady (every taxel's window mean within 2 σ of 0.3 s before) and the
//! cosine of its pattern with its contact's peak pattern. `GATE_TRACE=1` prints every frame
//! (Σ|Δᵢ|, the largest 0.3-s move in σ, the shape fraction, the cosine); `GATE_SLOPE=1` the
//! learned drift slope against the simulator's true one, and the change, once a second.
//!
//! Run: `cargo run --release --example gate_probe [-- 700 0 1 …]`; `GATE_DRIFT='{…}'` (a
//! `DriftModel` in JSON) probes another gate.

use gradtac::stages::force_model::force_detector;
use gradtac::stages::locate::{press_shaped_magnitude, ChangeDetector, LocateConfig};
use gradtac::stages::sim_force::{is_held_out, ForceSession};
use gradtac::stream::Layout;

fn main() {
    let seeds: Vec<u64> = std::env::args().skip(1).filter_map(|s| s.parse().ok()).collect();
    let seeds = if seeds.is_empty() { vec![700, 0, 1, 2, 3, 4, 5, 6, 7] } else { seeds };
    for seed in seeds {
        assert!(!is_held_out(seed), "held-out seeds are not probed");
        let session = ForceSession::presses(seed, 10);
        let rec = session.simulate();
        let ph = &session.physics;
        let slope = ph.drift_slope.iter().map(|s| s.abs()).fold(0.0, f64::max);
        println!(
            "seed {seed}: A {:.1} counts/N, w {:.2} mm, noise {:.1}, max |slope| {:.2} counts/s, walk {:.2}, lag {:.0} ms",
            ph.amplitude,
            ph.width_mm,
            ph.noise_counts,
            slope,
            ph.drift_walk,
            ph.lag_s * 1e3
        );
        let mut det = match std::env::var("GATE_DRIFT") {
            Ok(j) => ChangeDetector::try_new(24, &LocateConfig::default())
                .unwrap()
                .with_drift_model(serde_json::from_str(&j).expect("GATE_DRIFT: a DriftModel in JSON"))
                .unwrap(),
            Err(_) => force_detector(24, &LocateConfig::default()).unwrap(),
        }
        // the layout's positions, as the force stage gives them (the drift-shape return)
        .with_positions(Layout::biotac_sp().positions())
        .unwrap();
        let positions = Layout::biotac_sp().positions().to_vec();
        // the window means 0.3 s ago (steadiness as the drift model tests it: every taxel
        // within 2 σ), kept to report why a rest's last frame did not return
        let mut means: std::collections::VecDeque<Vec<f64>> = std::collections::VecDeque::new();
        // per segment: peak total, last frame's total, max |Δ|/σ, contact, first uncontact frame
        let nseg = session.segments.len();
        let mut peak = vec![0.0f64; nseg];
        let mut last = vec![(0.0f64, 0.0f64, false); nseg];
        // per segment at its last frame: press-shaped fraction (magnitude fit), steady
        let mut shape = vec![(f64::NAN, false); nseg];
        let mut returned_at = vec![None::<usize>; nseg];
        let mut idx = vec![0usize; nseg];
        let mut run_peak: (f64, Vec<f64>) = (0.0, Vec::new());
        let mut cos_at = vec![f64::NAN; nseg];
        for (k, f) in rec.frames.iter().enumerate() {
            let c = det.push(f, "force").unwrap();
            let s = rec.segment[k];
            let total: f64 = det.change().iter().map(|d| d.abs()).sum();
            let z = det.change().iter().zip(det.noise()).map(|(d, s)| d.abs() / s).fold(0.0, f64::max);
            let mean: Vec<f64> = det.change().iter().zip(det.baseline()).map(|(d, b)| d + b).collect();
            means.push_back(mean);
            if means.len() > 31 {
                means.pop_front();
            }
            // the largest 0.3-s move of a window mean, in σ (steady: below 2 on every taxel)
            let mv = if means.len() == 31 {
                means[30]
                    .iter()
                    .zip(&means[0])
                    .zip(det.noise())
                    .map(|((x, o), s)| (x - o).abs() / s)
                    .fold(0.0, f64::max)
            } else {
                f64::INFINITY
            };
            let steady = mv < 2.0;
            // the contact run's peak pattern (Δᵢ/σᵢ at its largest Σ|Δᵢ|), and the cosine of
            // this frame's pattern with it (a press still held repeats its peak's pattern)
            let e: Vec<f64> = det.change().iter().zip(det.noise()).map(|(d, s)| d / s).collect();
            if !c.contact {
                run_peak = (0.0, Vec::new());
            } else if total > run_peak.0 {
                run_peak = (total, e.clone());
            }
            let cos = {
                let (a, b) = (&e, &run_peak.1);
                let ab: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
                let aa: f64 = a.iter().map(|x| x * x).sum();
                let bb: f64 = b.iter().map(|x| x * x).sum();
                ab / (aa * bb).sqrt()
            };
            if std::env::var_os("GATE_TRACE").is_some() && !det.noise().is_empty() {
                // per frame: time, segment, contact, Σ|Δ|, largest 0.3-s move in σ, shape F
                println!(
                    "    t {:.2} seg {s} c {} tot {total:.0} move {mv:.2} F {:.2} cos {cos:.2}",
                    k as f64 * 0.01,
                    u8::from(c.contact),
                    press_shaped_magnitude(det.change(), det.noise(), &positions)
                );
            }
            if std::env::var_os("GATE_SLOPE").is_some() && k % 100 == 0 {
                // the learned drift slope against the truth (counts/s), and the change (counts)
                let f = |v: &[f64]| v.iter().map(|x| format!("{x:.1}")).collect::<Vec<_>>().join(" ");
                println!(
                    "    t {:.1} c {} slope {}\n      truth {}\n      change {}",
                    k as f64 * 0.01,
                    u8::from(c.contact),
                    f(det.drift_slope()),
                    f(&ph.drift_slope),
                    f(det.change())
                );
            }
            if !det.noise().is_empty() {
                shape[s] = (press_shaped_magnitude(det.change(), det.noise(), &positions), steady);
            }
            cos_at[s] = cos;
            peak[s] = peak[s].max(total);
            last[s] = (total, z, c.contact);
            if !c.contact && returned_at[s].is_none() {
                returned_at[s] = Some(idx[s]);
            }
            idx[s] += 1;
        }
        let ss: f64 = det.noise().iter().sum();
        println!("  Σσᵢ {ss:.0} counts; the return rule's bound is {:.1} × the peak", det_fraction());
        println!("  press  peak Σ|Δ|  bound  end-of-rest Σ|Δ|  ratio  max z  contact at rest end  no contact after  shape F  steady  cos to the run's peak");
        let (mut blocked, mut stuck) = (0, 0);
        for p in 0..(nseg - 1) / 2 {
            let (press, rest) = (1 + 2 * p, 2 + 2 * p);
            let (t, z, c) = last[rest];
            let bound = det_fraction() * peak[press];
            blocked += usize::from(t >= bound);
            stuck += usize::from(c);
            println!(
                "  {p:>5}  {:>9.0}  {:>5.0}  {:>16.0}  {:>5.2}  {:>5.1}  {:>19}  {:>16}  {:>7.2}  {}  {:.2}",
                peak[press],
                bound,
                t,
                t / peak[press].max(1e-9),
                z,
                if c { "CONTACT" } else { "no" },
                returned_at[rest].map_or("never".to_string(), |k| format!("{:.2} s", k as f64 * 0.01)),
                shape[rest].0,
                shape[rest].1,
                cos_at[rest],
            );
        }
        println!("  rests ending above the bound: {blocked} of {}; in contact at their end: {stuck}", (nseg - 1) / 2);
    }
}

/// The probed gate's return fraction.
fn det_fraction() -> f64 {
    match std::env::var("GATE_DRIFT") {
        Ok(j) => {
            serde_json::from_str::<gradtac::stages::locate::DriftModel>(&j).map_or(f64::NAN, |m| m.release_fraction)
        }
        Err(_) => gradtac::stages::force_model::FORCE_GATE.release_fraction,
    }
}
