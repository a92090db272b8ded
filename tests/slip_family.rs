//! Two-finger slip with the bare default scene's chain (raw frames → slip_pattern → slip, every
//! stage at its defaults) on grasps drawn from the **widened** family of forward models
//! (`gradtac_stages::sim_grasp`: step / linear / smooth starts, grips still ramping at the
//! onset, loads rising while slipping, slips that start on one finger first), members **not**
//! used for choosing the defaults: seeds 1000..1008 × 5 classes (the onset settings were chosen
//! on seeds 0..120 with Gaussian or difference-of-Gaussians kernels on both fingers,
//! `slip_eval -- tune onset`; the decision settings earlier on the same seeds).
//!
//! Stated bounds (measured values in the comments; the full held-out tables of 500 grasps are
//! in the slip module docs):
//! - no slip event on any stable grasp;
//! - at most one slipping grasp with a slip event before its onset (measured 1);
//! - at least 31 of the 32 slipping grasps classified right (measured 31);
//! - median |onset error| ≤ 75 ms (measured 46 ms on these few; 45 ms over the 400 held-out
//!   slips of `slip_eval`, 44–48 ms per start shape — above the 30 ms target);
//! - |mean signed onset error| ≤ 35 ms (measured −25 ms here; the previous default estimate —
//!   the energy-weighted position, `ramp_hinge`, `linear_cubic`, `weighted`, lead 0.03 s —
//!   gives +0 ms on these few; over the 400 held-out slips −5 against −2 ms). Stop 31's
//!   same-time decision (the slip module's "Same-time inputs") moved these from 46 / −18 ms
//!   to 49 / −17 ms, stop 31b's `onset_fingers = "clear_earliest"` (lead 0.010 s) to 46 / −25;
//! - the previous track-velocity rule does worse on the same grasps (the baseline).

use gradtac::stages::sim_grasp::{detect, score, GraspMember, GraspScore};
use gradtac::stages::slip::{OnsetFingers, OnsetModel, OnsetPosition, OnsetStarts, SlipConfig, SlipMethod};

fn scores(cfg: &SlipConfig) -> Vec<GraspScore> {
    GraspMember::grid(1000..1008)
        .into_iter()
        .map(|m| {
            let rec = m.simulate();
            let ev = detect(&rec, cfg).unwrap();
            score(&rec.truth, &ev)
        })
        .collect()
}

fn mean_signed(s: &[GraspScore]) -> f64 {
    let e: Vec<f64> = s.iter().filter(|r| r.right() && r.truth.class.is_slip()).map(|r| r.onset_error_s).collect();
    e.iter().sum::<f64>() / e.len() as f64
}

#[test]
fn defaults_hold_on_held_out_members() {
    let s = scores(&SlipConfig::default());
    for r in &s {
        eprintln!(
            "{:>17} {:5.1} mm/s {:>6} start: {:?} onset {:+.3} s decided {:+.3} s FA {}",
            r.truth.class.name(),
            r.truth.speed_mm_s,
            r.truth.start.name(),
            r.detected.map(|c| c.name()),
            r.onset_error_s,
            r.decided_s,
            r.false_alarms
        );
    }
    let stable_events = s.iter().filter(|r| !r.truth.class.is_slip()).map(|r| r.false_alarms).sum::<usize>();
    assert_eq!(stable_events, 0, "slip events on stable grasps");
    let slipping: Vec<_> = s.iter().filter(|r| r.truth.class.is_slip()).collect();
    let early = slipping.iter().filter(|r| r.false_alarms > 0).count();
    assert!(early <= 1, "{early} slipping grasps with a slip event before the onset");
    let right = slipping.iter().filter(|r| r.right()).count();
    let mut err: Vec<f64> = slipping.iter().filter(|r| r.right()).map(|r| r.onset_error_s.abs()).collect();
    err.sort_by(f64::total_cmp);
    let median = err[err.len() / 2];
    eprintln!("{right} of {} slips right, median onset error {:.0} ms", slipping.len(), median * 1e3);
    assert!(right >= 31, "{right} of {} right", slipping.len());
    assert!(median <= 0.075, "median onset error {median} s");

    // the previous default onset estimate
    let previous = SlipConfig {
        onset_position: OnsetPosition::Energy,
        onset_model: OnsetModel::RampHinge,
        onset_fingers: OnsetFingers::Weighted,
        onset_starts: OnsetStarts::LinearCubic,
        onset_lead_s: 0.03,
        ..Default::default()
    };
    let (def, prev) = (mean_signed(&s), mean_signed(&scores(&previous)));
    eprintln!("mean signed onset error: default {:+.0} ms, previous estimate {:+.0} ms", def * 1e3, prev * 1e3);
    assert!(def.abs() <= 0.035, "mean signed onset error {def} s (previous estimate {prev} s)");

    let base = scores(&SlipConfig { method: SlipMethod::Velocity, min_duration_s: 0.08, ..Default::default() });
    let base_right = base.iter().filter(|r| r.right()).count();
    let all_right = s.iter().filter(|r| r.right()).count();
    eprintln!("baseline (track velocity): {base_right} of {} right; default {all_right}", base.len());
    assert!(all_right > base_right);
}
