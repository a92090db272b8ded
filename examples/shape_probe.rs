//! Probe of the drift model's shape test (`examples/force_parts/history.md`, "Session 34"): on force-family
//! members, the press-shaped fraction of the force gate's changes — over frames in contact
//! with a true force above 2 N and between 0.5 and 2 N, and over untouched frames (no force in
//! the last 0.5 s) that the gate holds in contact (a stale baseline) — its quantiles and the
//! share below 0.2 / 0.25 / 0.3. The signed fit by default; `MAG=1` the magnitude fit. Tuning
//! members only (never the held-out seeds 100–115, the fresh 9000–9015 or the tare's 600–605). `GATE_DRIFT='{…}'` (a
//! `DriftModel` in JSON) probes another gate.
//!
//! Run: `cargo run --release --example shape_probe -- 0 1 2 … 212`.

use gradtac::stages::force_model::force_detector;
use gradtac::stages::locate::{press_shaped_fraction, press_shaped_magnitude, ChangeDetector, LocateConfig};
use gradtac::stages::sim_force::{is_held_out, ForceSession};
use gradtac::stream::Layout;

/// The `p` quantile (NaN when empty).
fn q(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    v[((v.len() - 1) as f64 * p) as usize]
}

/// The share (%) of `v` below `b`.
fn below(v: &[f64], b: f64) -> f64 {
    100.0 * v.iter().filter(|x| **x < b).count() as f64 / v.len().max(1) as f64
}

fn main() {
    let layout = Layout::biotac_sp();
    let magnitude = std::env::var_os("MAG").is_some();
    let seeds: Vec<u64> = std::env::args().skip(1).filter_map(|s| s.parse().ok()).collect();
    for seed in seeds {
        assert!(!is_held_out(seed) && !(600..606).contains(&seed), "held-out seeds are not probed");
        let session = ForceSession::presses(seed, 10);
        let rec = session.simulate();
        let ph = &session.physics;
        let positive = ph.gain.iter().filter(|g| **g > 0.0).count();
        let det = match std::env::var("GATE_DRIFT") {
            Ok(j) => ChangeDetector::try_new(24, &LocateConfig::default())
                .unwrap()
                .with_drift_model(serde_json::from_str(&j).expect("GATE_DRIFT: a DriftModel in JSON"))
                .unwrap(),
            Err(_) => force_detector(24, &LocateConfig::default()).unwrap(),
        };
        let mut det = det.with_positions(layout.positions()).unwrap();
        let (mut press, mut light, mut stale) = (Vec::new(), Vec::new(), Vec::new());
        let mut last_force = f64::NEG_INFINITY;
        for (k, f) in rec.frames.iter().enumerate() {
            let c = det.push(f, "probe").unwrap();
            let t = k as f64 * 0.01;
            if rec.force[k] > 0.0 {
                last_force = t;
            }
            let fr = if magnitude {
                press_shaped_magnitude(det.change(), det.noise(), layout.positions())
            } else {
                press_shaped_fraction(det.change(), det.noise(), layout.positions())
            };
            if rec.force[k] > 2.0 && c.contact {
                press.push(fr);
            } else if rec.force[k] > 0.5 && c.contact {
                light.push(fr);
            }
            if t - last_force > 0.5 && c.contact {
                stale.push(fr);
            }
        }
        let pressed: Vec<f64> = press.iter().chain(&light).copied().collect();
        println!(
            "seed {seed}: kernel {:?} w {:.2} mm, noise {:.1}, walk {:.2}, positive gains {positive}",
            ph.kernel, ph.width_mm, ph.noise_counts, ph.drift_walk
        );
        println!(
            "  pressed > 2 N: n {} q05 {:.2} q25 {:.2} q50 {:.2} | 0.5–2 N: n {} q05 {:.2} q25 {:.2} | stale contact: n {} q50 {:.2} q95 {:.2}",
            press.len(),
            q(&mut press, 0.05),
            q(&mut press, 0.25),
            q(&mut press, 0.5),
            light.len(),
            q(&mut light, 0.05),
            q(&mut light, 0.25),
            stale.len(),
            q(&mut stale, 0.5),
            q(&mut stale, 0.95)
        );
        println!(
            "  pressed below 0.2 / 0.25 / 0.3: {:.1} / {:.1} / {:.1} % | stale below: {:.0} / {:.0} / {:.0} %",
            below(&pressed, 0.2),
            below(&pressed, 0.25),
            below(&pressed, 0.3),
            below(&stale, 0.2),
            below(&stale, 0.25),
            below(&stale, 0.3)
        );
    }
}
