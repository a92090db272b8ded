//! The servo closing a loop through the whole event chain on a steppable simulated sensor
//! ([`Simulator::sensor`]): an object touches the pad off-centre; every frame the chain
//! (causal Savitzky–Golay → events → 10-frame event counts → natural neighbour 32 × 32 →
//! contour → track → servo) may command a motion, and a speed-limited "robot" moves the sensor
//! along it, which moves the stationary contact across the pad by the opposite amount.
//!
//! The event chain only sees *change*: the press and then the sensor's own motion keep the
//! contact visible; once the motion stops there is nothing to see and the servo holds (no
//! command, as data). Servo settings: deadband 1 mm, smoothing 0.3, gain 1; robot speed limit
//! 15 mm/s. The loop reaches the centre within ≈ 0.4 s and then hunts around it: the contour
//! of a *moving* contact is off by 1–2 mm (the same localisation error the trajectories
//! show), and every correction is itself a motion the events see. Stated tolerance, 8 seeds
//! from offsets of 4.2–5 mm: the true offset averaged over the last 2 s of 3 is below 3.5 mm
//! and below 0.7 of the start (measured means 1.3–3.0 mm, 1.9 mm on average; single frames
//! reach 2.7–5.1 mm). This is a loop that holds the contact near the centre, not one that
//! pins it: better localisation of a moving contact is what would tighten it.
//! A large deadband is a trap: once the estimate falls inside it the robot stops, the events
//! stop, and a real offset is never seen again (measured: deadband 1 mm without smoothing left
//! seed 2 at 4.3 mm).

use gradtac_stages::contour::{Contour, ContourConfig};
use gradtac_stages::events::{Events, EventsConfig, Threshold};
use gradtac_stages::interpolate::{GridConfig, Interpolate, InterpolateConfig};
use gradtac_stages::savgol::{SavGol, SavGolConfig, SavGolMode};
use gradtac_stages::servo::{Servo, ServoAction, ServoConfig};
use gradtac_stages::sim::{Contact, SensorModel, Simulator};
use gradtac_stages::track::{Track, TrackConfig};
use gradtac_stages::window::{Aggregate, Window, WindowConfig};
use gradtac_stream::{Layout, Stage, StageExt};

/// Robot speed limit (mm/s) and frame period (s).
const V_MAX: f64 = 15.0;
const DT: f64 = 0.01;

/// Runs the loop for 3 s from `offset` (mm from the centre); returns the true offset's mean
/// and worst length over the last 2 s, and how many frames commanded a motion.
fn close_the_loop(seed: u64, offset: [f64; 2]) -> (f64, f64, usize) {
    let layout = Layout::biotac_sp();
    let centre = layout.extent().centre();
    let sim = Simulator::try_new(layout.clone(), SensorModel::default(), seed).unwrap();
    let mut sensor = sim.sensor("ff");
    let sg = SavGol::try_with_rate(24, SavGolConfig { mode: SavGolMode::Causal, ..Default::default() }, 100.0).unwrap();
    let ev = Events::try_new(24, EventsConfig { threshold: Threshold::Uniform(0.002), ..Default::default() }).unwrap();
    let w =
        Window::try_new(&WindowConfig { frames: Some(10), aggregate: Aggregate::Count, ..Default::default() }).unwrap();
    let icfg = InterpolateConfig {
        grid: GridConfig { nx: 32, ..Default::default() },
        incremental: true,
        ..Default::default()
    };
    let i = Interpolate::try_new(&icfg, &layout).unwrap();
    let c = Contour::try_new(&ContourConfig { min_peak: 2.0, min_area_mm2: 30.0, ..Default::default() }).unwrap();
    let t = Track::try_new(&TrackConfig::default()).unwrap();
    let servo =
        Servo::try_new(&ServoConfig { deadband_mm: 1.0, smoothing: 0.3, ..Default::default() }, &layout).unwrap();
    let mut chain = sg.then(ev).then(w).then(i).then(c).then(t).then(servo);
    // the sensor's displacement (mm, its own frame); the contact sits at centre + offset − moved
    let mut moved = [0.0, 0.0];
    let mut commands = 0;
    let mut late = (0.0, 0.0f64);
    let mut out = Vec::new();
    for k in 0..300 {
        let force = (k as f64 / 20.0).min(1.0) * 4.0;
        let at = [centre[0] + offset[0] - moved[0], centre[1] + offset[1] - moved[1]];
        let frame = sensor.step(Some(Contact { at_mm: at, force_n: force, diameter_mm: 5.0 }));
        out.clear();
        chain.push(frame, &mut out).unwrap();
        for cmd in &out {
            if let ServoAction::Move(m) = cmd.action {
                let len = m.motion_mm[0].hypot(m.motion_mm[1]);
                if len > 0.0 {
                    commands += 1;
                    let step = len.min(V_MAX * DT);
                    moved[0] += step * m.motion_mm[0] / len;
                    moved[1] += step * m.motion_mm[1] / len;
                }
            }
        }
        if k >= 100 {
            let e = (offset[0] - moved[0]).hypot(offset[1] - moved[1]);
            late.0 += e / 200.0;
            late.1 = late.1.max(e);
        }
    }
    (late.0, late.1, commands)
}

#[test]
fn servo_brings_an_off_centre_contact_toward_the_centre() {
    for (seed, offset) in [
        (1, [4.0, 3.0]),
        (2, [-4.0, 2.0]),
        (3, [0.0, -5.0]),
        (4, [3.0, -3.0]),
        (5, [-3.0, -4.0]),
        (6, [5.0, 0.0]),
        (7, [-2.0, 4.0]),
        (8, [2.0, 4.5]),
    ] {
        let (mean, worst, commands) = close_the_loop(seed, offset);
        let start = offset[0].hypot(offset[1]);
        eprintln!(
            "seed {seed}: offset {start:.2} mm → over the last 2 s mean {mean:.2} mm, worst {worst:.2} mm \
             ({commands} commanded frames of 300)"
        );
        assert!(commands > 0, "seed {seed}: never moved");
        assert!(mean < 3.5 && mean < 0.7 * start, "seed {seed}: {start} → mean {mean}, worst {worst} mm");
    }
}
