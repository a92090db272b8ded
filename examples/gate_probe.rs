//! Probe of the force gate's returns (`docs/force.md`, "The force gate's returns"): per press
//! of a force-family member, the peak total change `Σ|Δᵢ|`, the total change and the largest
//! `|Δᵢ|/σᵢ` at the end of the rest that follows, and whether the contact had ended (the
//! return rule fired) by then. Only tuning members (seeds 0–7) and `tests/cli_force.rs`'s
//! member 700 — never the held-out seeds.
//!
//! Run: `cargo run --release --example gate_probe [-- 700 0 1 …]`; `GATE_DRIFT='{…}'` (a
//! `DriftModel` in JSON) probes another gate.

use gradtac::stages::force_model::force_detector;
use gradtac::stages::locate::{ChangeDetector, LocateConfig};
use gradtac::stages::sim_force::ForceSession;

fn main() {
    let seeds: Vec<u64> = std::env::args().skip(1).filter_map(|s| s.parse().ok()).collect();
    let seeds = if seeds.is_empty() { vec![700, 0, 1, 2, 3, 4, 5, 6, 7] } else { seeds };
    for seed in seeds {
        assert!(!(100..116).contains(&seed), "held-out seeds are not probed");
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
        };
        // per segment: peak total, last frame's total, max |Δ|/σ, contact, first uncontact frame
        let nseg = session.segments.len();
        let mut peak = vec![0.0f64; nseg];
        let mut last = vec![(0.0f64, 0.0f64, false); nseg];
        let mut returned_at = vec![None::<usize>; nseg];
        let mut idx = vec![0usize; nseg];
        for (k, f) in rec.frames.iter().enumerate() {
            let c = det.push(f, "force").unwrap();
            let s = rec.segment[k];
            let total: f64 = det.change().iter().map(|d| d.abs()).sum();
            let z = det.change().iter().zip(det.noise()).map(|(d, s)| d.abs() / s).fold(0.0, f64::max);
            peak[s] = peak[s].max(total);
            last[s] = (total, z, c.contact);
            if !c.contact && returned_at[s].is_none() {
                returned_at[s] = Some(idx[s]);
            }
            idx[s] += 1;
        }
        let ss: f64 = det.noise().iter().sum();
        println!("  Σσᵢ {ss:.0} counts; the return rule's bound is {:.1} × the peak", det_fraction());
        println!("  press  peak Σ|Δ|  bound  end-of-rest Σ|Δ|  ratio  max z  contact at rest end  no contact after");
        let (mut blocked, mut stuck) = (0, 0);
        for p in 0..(nseg - 1) / 2 {
            let (press, rest) = (1 + 2 * p, 2 + 2 * p);
            let (t, z, c) = last[rest];
            let bound = det_fraction() * peak[press];
            blocked += usize::from(t >= bound);
            stuck += usize::from(c);
            println!(
                "  {p:>5}  {:>9.0}  {:>5.0}  {:>16.0}  {:>5.2}  {:>5.1}  {:>19}  {}",
                peak[press],
                bound,
                t,
                t / peak[press].max(1e-9),
                z,
                if c { "CONTACT" } else { "no" },
                returned_at[rest].map_or("never".to_string(), |k| format!("{:.2} s", k as f64 * 0.01)),
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
