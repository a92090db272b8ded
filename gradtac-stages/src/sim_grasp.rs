//! Two-finger grasps drawn from the [`sim_family`](crate::sim_family) of forward models, with
//! the slip ground truth travelling with the recording — for tuning the [`slip`](crate::slip)
//! stage on some members and scoring it on others.
//!
//! # A member
//! A member is `(seed, class)` ([`GraspMember`]); [`GraspMember::draw`] turns it into every
//! parameter below ([`Grasp`]), [`Grasp::simulate`] into frames. Deterministic by seed (with the
//! `rand` version in `Cargo.lock`).
//!
//! The first finger (`ff`) and the thumb (`th`) hold an object between their pads in the
//! documented two-finger convention ([`crate::sim`], "Two-finger convention": world up is
//! `+y` in `ff`'s layout, `−y` in `th`'s). **Each finger draws its own physics**
//! ([`Physics::draw`](crate::sim_family::Physics::draw) with its own sub-seed): kernel shape
//! (Gaussian, difference of Gaussians, exponential), indenter diameter and kernel width, force,
//! amplitude, per-electrode gains and signs, fluid lag, saturation knee, baselines, drift
//! (linear and random walk), white noise, 12-bit ADC — every term and range of the family's
//! table — except the force, which is the grasp's grip force below. The contact moves on the pad as below; the electrodes respond through the family's
//! forward model (3-D distance from the core electrodes to the contact lifted on the skin).
//!
//! | term | what | range drawn per member |
//! |---|---|---|
//! | timeline | no contact 0–0.5 s (calibration room), press 0.5–0.7 s, still until the onset, motion, still until the end | — |
//! | onset | first frame of motion of the first finger to move (truth) | `t₀ ∈ [1.0, 2.5]` s |
//! | speed | object's slip speed `v` (mm/s) | log-uniform in `[2, 30]` |
//! | start shape | the speed is `v · g(τ) · (1 + α τ)`, `τ` since the finger's onset ([`StartShape`]): **step** `g = 1`; **linear** `g = min(τ/r, 1)`; **smooth** `g = 3x² − 2x³`, `x = min(τ/r, 1)` | one of the three, equally likely; linear `r ∈ [0.05, 0.3]` s, smooth `r ∈ [0.1, 0.4]` s |
//! | load rise | a load that rises while slipping: `α` (1/s) above | `α = 0` (½) or `α ∈ [0.5, 3]` (½) |
//! | one finger first | the other finger's motion starts `λ` later (which finger: ½ each) | `λ = 0` (½) or `λ ∈ [0.03, 0.2]` s (½) |
//! | distance | travel of each contact | `D ∈ [3, 8]` mm, at most `v · 1.5 s` (so slow slips last ≤ 1.5 s + the start), shrunk to fit the pad |
//! | direction | each contact moves along its finger's world up (`±y`) turned by a misalignment | `θ ∈ [−15°, 15°]` per finger |
//! | rotation axis | rotational classes: the contacts' speeds are `v·2k` and `v·2(1−k)` (an axis off the middle) | `k ∈ [0.35, 0.65]` |
//! | start point | anywhere on the pad: uniform until the whole path lies in [`crate::sim_family::pad_region`] | — |
//! | grip force | one force `F` on both pads (the object is in equilibrium between them: the normal forces are equal and opposite), times `1 + a·sin(2πf t + φ)` from the press on (squeeze changes, all classes); it replaces the fingers' own force draws, their sensitivity (amplitude, gains, kernel, width) stays their own | `F ∈ [0.5, 10]` N (the family's range), `a ∈ [0, 0.3]`, `f ∈ [0.2, 1]` Hz |
//! | grip still ramping | the grip is `γ F` at the end of the press and moves linearly to `F` at `t₀ + o` (so it is still changing when the slip starts; stable grasps alike) | `γ = 1` (½) or `γ ∈ [0.4, 1.6]`, `o ∈ [0, 0.3]` s (½) |
//! | end | 0.6–1.0 s of stillness after the motion (stable: the same length as a slip would have) | — |
//!
//! Classes ([`SlipClass`]): longitudinal up / down (both contacts move the same world way),
//! rotational cw / ccw (opposite world ways; cw moves the surface *down* at `ff`), stable (drift
//! and force changes, no motion). A stable member has the same timeline without motion.
//!
//! The start shape, load rise, finger lag and grip ramp are the **widened** properties
//! ([`GraspFamily::widened`], what [`GraspMember::draw`] uses): every member draws them, tuning
//! and held-out alike, from a random stream of their own, so [`GraspFamily::narrow`] (a linear
//! start of 0–0.3 s, nothing else widened) gives the first family's members exactly.
//! [`GraspFamily::held_out_variant`] draws exponential starts (`g = 1 − e^{−3τ/r}`) and wider
//! ramps, load rises and lags: members of it are for scoring only, never for a choice.
//!
//! Not modelled: shear stretch of the skin before the contact slides, stick-slip, incipient
//! (partial) slip, several contacts, the pressure channel.
//!
//! # Example
//! ```
//! use gradtac_stages::sim_grasp::GraspMember;
//! use gradtac_stages::slip::SlipClass;
//! let rec = GraspMember { seed: 5, class: SlipClass::RotationalCw }.simulate();
//! assert_eq!(rec.truth.class, SlipClass::RotationalCw);
//! assert!(rec.frames.len() % 2 == 0); // th, ff interleaved
//! assert!((1.0..=2.5).contains(&rec.truth.onset_s));
//! // the grasp names how its slip starts (step, linear or smooth)
//! println!("{} start over {:.2} s", rec.truth.start.name(), rec.truth.ramp_s);
//! ```

use crate::sim::{GRASP_UP_FF, GRASP_UP_TH};
use crate::sim_family::{pad_region, skin_point, PathKind, Physics, CORE_MM, RATE_HZ, SKIN_MM};
use crate::slip::SlipClass;
use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Start of the press (s).
pub const PRESS_S: f64 = 0.5;
/// Length of the press ramp (s).
pub const PRESS_RAMP_S: f64 = 0.2;

/// How a slip's speed starts (`τ` = time since the finger's onset, `r` = the start's length,
/// [`GraspTruth::ramp_s`]); the speed is `v · g(τ) · (1 + α τ)` with `α` the load rise.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StartShape {
    /// `g = 1`: full speed from the first frame (a sudden break-away).
    Step,
    /// `g = min(τ/r, 1)`: the speed rises linearly over `r` (the first family's slow start).
    Linear,
    /// `g = 3x² − 2x³`, `x = min(τ/r, 1)`: a smooth (C¹) rise over `r`.
    Smooth,
    /// `g = 1 − e^{−3τ/r}` (95 % at `r`): a first-order approach. Never drawn by
    /// [`GraspFamily::widened`]: only [`GraspFamily::held_out_variant`] draws it.
    Exponential,
}

impl StartShape {
    /// The shapes of the widened family (each drawn with probability ⅓).
    pub const FAMILY: [StartShape; 3] = [StartShape::Step, StartShape::Linear, StartShape::Smooth];

    /// The snake_case name.
    pub fn name(self) -> &'static str {
        match self {
            StartShape::Step => "step",
            StartShape::Linear => "linear",
            StartShape::Smooth => "smooth",
            StartShape::Exponential => "exponential",
        }
    }

    /// The relative speed `g(τ)` for a start of length `r` (s).
    pub fn speed(self, tau: f64, r: f64) -> f64 {
        if tau <= 0.0 {
            return 0.0;
        }
        let x = if r > 0.0 { (tau / r).min(1.0) } else { 1.0 };
        match self {
            StartShape::Step => 1.0,
            StartShape::Linear => x,
            StartShape::Smooth => x * x * (3.0 - 2.0 * x),
            StartShape::Exponential => {
                if r > 0.0 {
                    1.0 - (-3.0 * tau / r).exp()
                } else {
                    1.0
                }
            }
        }
    }
}

/// The ranges the widened properties of a grasp are drawn from ([`GraspMember::draw_in`]).
/// Each property is present with probability `p_*` and then drawn uniformly in its range.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GraspFamily {
    /// Start shapes, drawn with equal probability.
    pub starts: Vec<StartShape>,
    /// Length `r` (s) of a [`StartShape::Linear`] start.
    pub linear_s: [f64; 2],
    /// Length `r` (s) of a [`StartShape::Smooth`] or [`StartShape::Exponential`] start.
    pub smooth_s: [f64; 2],
    /// Probability of a grip force still ramping at the onset.
    pub p_grip_ramp: f64,
    /// Grip force at the end of the press as a fraction of `F` (it then moves linearly to `F`).
    pub grip_start: [f64; 2],
    /// How long (s) after the onset the grip ramp ends.
    pub grip_over_s: [f64; 2],
    /// Probability of a load rising while slipping.
    pub p_load_rise: f64,
    /// Load rise `α` (1/s): the speed grows by the factor `1 + α τ` while slipping.
    pub load_rise: [f64; 2],
    /// Probability that one finger starts slipping before the other.
    pub p_finger_lag: f64,
    /// How long (s) the other finger starts after the first.
    pub finger_lag_s: [f64; 2],
}

impl GraspFamily {
    /// The first family: linear slow starts of 0–0.3 s, grip settled, constant speed, both
    /// fingers together.
    pub fn narrow() -> GraspFamily {
        GraspFamily {
            starts: vec![StartShape::Linear],
            linear_s: [0.0, 0.3],
            smooth_s: [0.1, 0.4],
            p_grip_ramp: 0.0,
            grip_start: [1.0, 1.0],
            grip_over_s: [0.0, 0.0],
            p_load_rise: 0.0,
            load_rise: [0.0, 0.0],
            p_finger_lag: 0.0,
            finger_lag_s: [0.0, 0.0],
        }
    }

    /// The widened family (the default of [`GraspMember::draw`]; tuning and held-out members
    /// alike): step, linear or smooth starts; half the grasps with the grip still ramping
    /// (from 0.4–1.6 × `F` at the end of the press to `F`, 0–0.3 s after the onset); half with
    /// a load rising while slipping (`α` ∈ [0.5, 3] /s); half with one finger starting
    /// 0.03–0.2 s before the other.
    pub fn widened() -> GraspFamily {
        GraspFamily {
            starts: StartShape::FAMILY.to_vec(),
            linear_s: [0.05, 0.3],
            smooth_s: [0.1, 0.4],
            p_grip_ramp: 0.5,
            grip_start: [0.4, 1.6],
            grip_over_s: [0.0, 0.3],
            p_load_rise: 0.5,
            load_rise: [0.5, 3.0],
            p_finger_lag: 0.5,
            finger_lag_s: [0.03, 0.2],
        }
    }

    /// A variant never used for a choice (scored only): exponential starts, every grip
    /// ramping over wider ranges (0.3–2 × `F`), a steeper load rise (up to 4 /s) and finger
    /// lags up to 0.3 s, each present with probability ½ but the start.
    pub fn held_out_variant() -> GraspFamily {
        GraspFamily {
            starts: vec![StartShape::Exponential],
            linear_s: [0.05, 0.3],
            smooth_s: [0.1, 0.4],
            p_grip_ramp: 0.5,
            grip_start: [0.3, 2.0],
            grip_over_s: [0.0, 0.5],
            p_load_rise: 0.5,
            load_rise: [0.5, 4.0],
            p_finger_lag: 0.5,
            finger_lag_s: [0.03, 0.3],
        }
    }
}

/// One member of the grasp family: a seed and the class it slips in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct GraspMember {
    /// Seed of every draw.
    pub seed: u64,
    /// The class (stable: no motion).
    pub class: SlipClass,
}

/// One finger of a drawn grasp.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GraspFinger {
    /// The sensor (`ff` or `th`).
    pub sensor: String,
    /// The finger's physics (its `path`, `kind` and `speed_mm_s` fields are not used: the
    /// motion is [`GraspFinger::from`] → [`GraspFinger::to`]).
    pub physics: Physics,
    /// Contact position before the motion (mm, layout plane).
    pub from: [f64; 2],
    /// Contact position after the motion (mm, layout plane); `from` when stable.
    pub to: [f64; 2],
    /// Force modulation depth `a`.
    pub force_mod: f64,
    /// Force modulation frequency (Hz).
    pub force_hz: f64,
    /// Force modulation phase (rad).
    pub force_phase: f64,
    /// This finger's first frame of motion (s): the grasp's onset, or later when the other
    /// finger starts first ([`GraspTruth::finger_lag_s`]).
    pub onset_s: f64,
}

/// Ground truth of a grasp.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GraspTruth {
    /// The class.
    pub class: SlipClass,
    /// First frame of motion (s); for a stable grasp where the onset would have been.
    pub onset_s: f64,
    /// End of the motion (s).
    pub end_s: f64,
    /// Slip speed `v` of the object after the ramp (mm/s).
    pub speed_mm_s: f64,
    /// Length `r` of the start (s; 0 for a step).
    pub ramp_s: f64,
    /// How the speed starts.
    pub start: StartShape,
    /// Load rise `α` (1/s): the speed grows by `1 + α τ` while slipping (0: constant).
    pub load_rise: f64,
    /// How long (s) after the onset the later finger starts to move (0: both at once).
    pub finger_lag_s: f64,
    /// Grip force at the end of the press as a fraction of `F` (1: settled).
    pub grip_start: f64,
    /// When the grip ramp from `grip_start · F` reaches `F` (s).
    pub grip_end_s: f64,
    /// How long each finger moves (s).
    pub move_s: f64,
    /// Recording length (s).
    pub duration_s: f64,
}

impl GraspTruth {
    /// The true class at time `t` (s).
    pub fn class_at(&self, t: f64) -> SlipClass {
        if t >= self.onset_s && t < self.end_s {
            self.class
        } else {
            SlipClass::Stable
        }
    }
}

/// Every drawn parameter of a grasp member.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Grasp {
    /// The member.
    pub member: GraspMember,
    /// `[ff, th]`.
    pub fingers: [GraspFinger; 2],
    /// Ground truth.
    pub truth: GraspTruth,
}

/// A simulated grasp: frames of `th` and `ff` interleaved per time step, and the truth.
#[derive(Clone, Debug, PartialEq)]
pub struct GraspRecording {
    /// What was drawn.
    pub grasp: Grasp,
    /// Raw counts, `th` then `ff` at each time step (100 Hz).
    pub frames: Vec<TaxelFrame>,
    /// The truth (a copy of `grasp.truth`).
    pub truth: GraspTruth,
}

fn mix(seed: u64, tag: u64) -> u64 {
    let mut z = seed ^ tag.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ 0x5851_f42d_4c95_7f2d;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

fn inside(poly: &[[f64; 2]], q: [f64; 2]) -> bool {
    (0..poly.len()).all(|i| {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        (b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0]) >= 0.0
    })
}

/// Distance (s × v) travelled `tau` s after a finger's onset: `∫₀^τ g(s)(1 + α s) ds`
/// (Simpson on the start and on the rest; exact for the polynomial shapes past the start).
fn travel(shape: StartShape, r: f64, alpha: f64, tau: f64) -> f64 {
    if tau <= 0.0 {
        return 0.0;
    }
    // the speed's right limit at 0 (a step is at full speed from its first instant)
    let f = |s: f64| shape.speed(s.max(f64::MIN_POSITIVE), r) * (1.0 + alpha * s);
    let simpson = |a: f64, b: f64| {
        if b <= a {
            return 0.0;
        }
        const N: usize = 64;
        let h = (b - a) / N as f64;
        let mut acc = f(a) + f(b);
        for k in 1..N {
            acc += f(a + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
        }
        acc * h / 3.0
    };
    let m = tau.min(r);
    simpson(0.0, m) + simpson(m, tau)
}

/// The motion time `T` with `travel(T) = d` (bisection).
fn motion_time(shape: StartShape, r: f64, alpha: f64, d: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, d + r + 1.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if travel(shape, r, alpha, mid) < d {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// Progress (fraction of the distance) `tau` s after a finger's onset for a motion of
/// `total_s` seconds.
fn progress(truth: &GraspTruth, tau: f64) -> f64 {
    if tau <= 0.0 {
        return 0.0;
    }
    if tau >= truth.move_s {
        return 1.0;
    }
    let total = travel(truth.start, truth.ramp_s, truth.load_rise, truth.move_s);
    (travel(truth.start, truth.ramp_s, truth.load_rise, tau) / total).clamp(0.0, 1.0)
}

impl GraspMember {
    /// The members `seeds × classes`.
    pub fn grid(seeds: impl IntoIterator<Item = u64>) -> Vec<GraspMember> {
        seeds.into_iter().flat_map(|seed| SlipClass::ALL.map(|class| GraspMember { seed, class })).collect()
    }

    /// Draw every parameter in the widened family ([`GraspFamily::widened`]; see the
    /// [module docs](self)).
    pub fn draw(&self) -> Grasp {
        self.draw_in(&GraspFamily::widened())
    }

    /// Draw every parameter with the widened properties from `family`. The first family's
    /// terms come from their own random stream, so [`GraspFamily::narrow`] gives the first
    /// family's members (the linear start's length is its slow start) and every family shares
    /// a seed's physics, force, path and timeline.
    pub fn draw_in(&self, family: &GraspFamily) -> Grasp {
        let mut rng = StdRng::seed_from_u64(mix(self.seed, 11 + self.class as u64));
        let mut u = |lo: f64, hi: f64| rng.random_range(lo..hi);
        let onset_s = u(1.0, 2.5);
        let speed = u(2f64.ln(), 30f64.ln()).exp();
        let ramp0 = u(0.0, 0.3);
        let k = u(0.35, 0.65);
        // the widened properties: their own stream
        let mut wrng = StdRng::seed_from_u64(mix(self.seed, 900 + self.class as u64));
        let mut w = |r: [f64; 2]| if r[1] > r[0] { wrng.random_range(r[0]..r[1]) } else { r[0] };
        let pick = w([0.0, 1.0]);
        let start = family.starts[((pick * family.starts.len() as f64) as usize).min(family.starts.len() - 1)];
        let ramp_s = match start {
            StartShape::Step => 0.0,
            StartShape::Linear => {
                let [a, b] = family.linear_s;
                a + (b - a) * (ramp0 / 0.3)
            }
            StartShape::Smooth | StartShape::Exponential => w(family.smooth_s),
        };
        let mut present = |p: f64, r: [f64; 2], none: f64| {
            let on = w([0.0, 1.0]) < p;
            let v = w(r);
            if on {
                v
            } else {
                none
            }
        };
        let grip_start = present(family.p_grip_ramp, family.grip_start, 1.0);
        let grip_over = present(family.p_grip_ramp, family.grip_over_s, 0.0);
        let load_rise = present(family.p_load_rise, family.load_rise, 0.0);
        let finger_lag_s = present(family.p_finger_lag, family.finger_lag_s, 0.0);
        let late_finger = usize::from(w([0.0, 1.0]) < 0.5);
        // world-up sign and speed factor of the contact on (ff, th)
        let (s, f) = match self.class {
            SlipClass::Stable => ([0.0, 0.0], [1.0, 1.0]),
            SlipClass::LongitudinalUp => ([1.0, 1.0], [1.0, 1.0]),
            SlipClass::LongitudinalDown => ([-1.0, -1.0], [1.0, 1.0]),
            SlipClass::RotationalCw => ([-1.0, 1.0], [2.0 * k, 2.0 * (1.0 - k)]),
            SlipClass::RotationalCcw => ([1.0, -1.0], [2.0 * k, 2.0 * (1.0 - k)]),
        };
        let dist = u(3.0, 8.0).min(speed * 1.5);
        // motion time at the object's speed (the faster contact sets the distance)
        let fmax = f[0].max(f[1]);
        let move_s = motion_time(start, ramp_s, load_rise, dist / (speed * fmax));
        let region = pad_region();
        let (x0, x1) = region.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| (a.0.min(p[0]), a.1.max(p[0])));
        let (y0, y1) = region.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| (a.0.min(p[1]), a.1.max(p[1])));
        // one grip force and squeeze for both pads: the object is in equilibrium between them
        let grip_n = u(0.5, 10.0);
        let (force_mod, force_hz, force_phase) = (u(0.0, 0.3), u(0.2, 1.0), u(0.0, 2.0 * PI));
        let slip = self.class.is_slip();
        let mut fingers = Vec::new();
        for (i, (name, up)) in [("ff", GRASP_UP_FF), ("th", GRASP_UP_TH)].into_iter().enumerate() {
            let mut physics = Physics::draw(mix(self.seed, 100 + i as u64), PathKind::Vertical);
            physics.force_n = grip_n;
            let theta = u(-15.0, 15.0).to_radians();
            let (sn, cs) = theta.sin_cos();
            let dir = [cs * up[0] - sn * up[1], sn * up[0] + cs * up[1]];
            let d = s[i] * dist * f[i] / fmax;
            let mut from = [0.0, 0.0];
            let mut to = from;
            for attempt in 0..2000 {
                let shrink = if attempt > 1000 { 0.5 } else { 1.0 };
                let a = [u(x0, x1), u(y0, y1)];
                let b = [a[0] + shrink * d * dir[0], a[1] + shrink * d * dir[1]];
                if inside(&region, a) && inside(&region, b) {
                    (from, to) = (a, b);
                    break;
                }
            }
            let lag = if i == late_finger && slip { finger_lag_s } else { 0.0 };
            fingers.push(GraspFinger {
                sensor: name.into(),
                physics,
                from,
                to,
                force_mod,
                force_hz,
                force_phase,
                onset_s: onset_s + lag,
            });
        }
        let finger_lag_s = if slip { finger_lag_s } else { 0.0 };
        let end_s = if slip { onset_s + finger_lag_s + move_s } else { onset_s };
        let duration_s = onset_s + finger_lag_s + move_s + u(0.6, 1.0);
        let [ff, th]: [GraspFinger; 2] = fingers.try_into().expect("two fingers");
        Grasp {
            member: *self,
            fingers: [ff, th],
            truth: GraspTruth {
                class: self.class,
                onset_s,
                end_s,
                speed_mm_s: speed,
                ramp_s,
                start,
                load_rise,
                finger_lag_s,
                grip_start,
                grip_end_s: onset_s + grip_over,
                move_s,
                duration_s,
            },
        }
    }

    /// Draw and simulate.
    pub fn simulate(&self) -> GraspRecording {
        self.draw().simulate()
    }
}

impl GraspFinger {
    /// Contact position at `t` (s) given the truth's motion.
    pub fn contact_at(&self, t: f64, truth: &GraspTruth) -> [f64; 2] {
        let u = if truth.class.is_slip() { progress(truth, t - self.onset_s) } else { 0.0 };
        [self.from[0] + u * (self.to[0] - self.from[0]), self.from[1] + u * (self.to[1] - self.from[1])]
    }

    /// Force at `t` (s): 0 before the press, ramped to `grip_start · F` over
    /// [`PRESS_RAMP_S`], then linearly to `F` at `grip_end_s`, modulated.
    pub fn force_at(&self, t: f64, truth: &GraspTruth) -> f64 {
        let ramp = ((t - PRESS_S) / PRESS_RAMP_S).clamp(0.0, 1.0);
        let t1 = PRESS_S + PRESS_RAMP_S;
        let grip = if truth.grip_end_s > t1 {
            let x = ((t - t1) / (truth.grip_end_s - t1)).clamp(0.0, 1.0);
            truth.grip_start + (1.0 - truth.grip_start) * x
        } else {
            1.0
        };
        let m = 1.0 + self.force_mod * (2.0 * PI * self.force_hz * (t - PRESS_S) + self.force_phase).sin();
        self.physics.force_n * grip * ramp * if t > PRESS_S { m } else { 1.0 }
    }
}

impl Grasp {
    /// Simulate both fingers (noise from the member's seed).
    pub fn simulate(&self) -> GraspRecording {
        let n = (self.truth.duration_s * RATE_HZ).ceil() as usize;
        let dt = 1.0 / RATE_HZ;
        let depth: Vec<f64> = (0..24)
            .map(|i| {
                let (e, s) = (CORE_MM[i], SKIN_MM[i]);
                ((e[0] - s[0]).powi(2) + (e[1] - s[1]).powi(2) + (e[2] - s[2]).powi(2)).sqrt()
            })
            .collect();
        struct St {
            rng: StdRng,
            noise: Normal<f64>,
            walk: Normal<f64>,
            lag: [f64; 24],
            rw: [f64; 24],
            alpha: f64,
            id: SensorId,
        }
        let mut st: Vec<St> = self
            .fingers
            .iter()
            .enumerate()
            .map(|(i, f)| St {
                rng: StdRng::seed_from_u64(mix(self.member.seed, 500 + 7 * self.member.class as u64 + i as u64)),
                noise: Normal::new(0.0, f.physics.noise_counts.max(0.0)).expect("finite σ"),
                walk: Normal::new(0.0, f.physics.drift_walk.max(0.0) * dt.sqrt()).expect("finite q"),
                lag: [0.0; 24],
                rw: [0.0; 24],
                alpha: 1.0 - (-dt / f.physics.lag_s).exp(),
                id: SensorId::new(&f.sensor),
            })
            .collect();
        let mut frames = Vec::with_capacity(2 * n);
        for k in 0..n {
            let t = k as f64 * dt;
            // th first, then ff (as sim::Scene::grasp)
            for i in [1, 0] {
                let f = &self.fingers[i];
                let s = &mut st[i];
                let p = &f.physics;
                let force = f.force_at(t, &self.truth);
                let sp = skin_point(f.contact_at(t, &self.truth));
                let values = (0..24)
                    .map(|j| {
                        let e = CORE_MM[j];
                        let d2 = (e[0] - sp[0]).powi(2) + (e[1] - sp[1]).powi(2) + (e[2] - sp[2]).powi(2);
                        let rho = (d2 - depth[j] * depth[j]).max(0.0).sqrt();
                        let u = p.gain[j] * p.amplitude * force * p.kernel.eval(rho, p.width_mm);
                        s.lag[j] += s.alpha * (u - s.lag[j]);
                        s.rw[j] += s.walk.sample(&mut s.rng);
                        let delta = p.knee_counts * (s.lag[j] / p.knee_counts).tanh();
                        let v = p.baseline[j] + delta + p.drift_slope[j] * t + s.rw[j] + s.noise.sample(&mut s.rng);
                        v.clamp(0.0, 4095.0).round()
                    })
                    .collect();
                frames.push(TaxelFrame::new(s.id.clone(), Timestamp::at_rate(k as u64, RATE_HZ), k as u64, values));
            }
        }
        GraspRecording { grasp: self.clone(), frames, truth: self.truth }
    }
}

/// How the [`slip`](crate::slip) stage did on one grasp ([`score`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GraspScore {
    /// The truth.
    pub truth: GraspTruth,
    /// The class of the first slip event decided at or after the true onset (`None`: none).
    pub detected: Option<SlipClass>,
    /// Its onset minus the true onset (s; NaN without one).
    pub onset_error_s: f64,
    /// Its decision time minus the true onset (s; NaN without one).
    pub decided_s: f64,
    /// Slip events decided before the true onset (stable grasps: all of them) — false alarms.
    pub false_alarms: usize,
    /// Seconds of still grasp the recording holds (from the end of the press to the onset;
    /// stable grasps: to the end).
    pub still_s: f64,
}

impl GraspScore {
    /// True when the grasp was classified right: a slipping grasp's first slip event after the
    /// onset has its class and nothing fired before; a stable grasp fired nothing.
    pub fn right(&self) -> bool {
        self.false_alarms == 0
            && (self.truth.class.is_slip() == self.detected.is_some())
            && self.detected.is_none_or(|c| c == self.truth.class)
    }
}

/// The track points of both fingers in time order, from the default chain a bare scene (no
/// `[stages.*]` table) runs: the default contact locator
/// ([`Centroid`](crate::centroid::Centroid) with [`LocateConfig::default`](crate::locate::LocateConfig))
/// and [`Track`](crate::track::Track) with its defaults, per sensor.
pub fn track_points(rec: &GraspRecording) -> crate::Result<Vec<crate::track::TrackPoint>> {
    Ok(track_points_per_frame(&rec.frames)?.into_iter().flatten().collect())
}

/// [`track_points`] of `ff` and `th` frames (any others are skipped) grouped by the frame whose
/// push produced them: one group per frame, then one for the chains' `finish`.
pub fn track_points_per_frame(frames: &[TaxelFrame]) -> crate::Result<Vec<Vec<crate::track::TrackPoint>>> {
    use crate::centroid::Centroid;
    use crate::locate::LocateConfig;
    use crate::track::{Track, TrackConfig};
    use gradtac_stream::{Layout, Stage};
    let layout = Layout::biotac_sp();
    let mk = || -> crate::Result<(Centroid, Track)> {
        Ok((Centroid::try_new(&LocateConfig::default(), &layout)?, Track::try_new(&TrackConfig::default())?))
    };
    let mut chains = [mk()?, mk()?];
    let mut contours = Vec::new();
    let mut groups = Vec::with_capacity(frames.len() + 1);
    for f in frames {
        let mut points = Vec::new();
        if !matches!(f.sensor.as_str(), "ff" | "th") {
            groups.push(points);
            continue;
        }
        let (c, t) = &mut chains[usize::from(f.sensor.as_str() == "th")];
        c.push(f.clone(), &mut contours)?;
        for x in contours.drain(..) {
            t.push(x, &mut points)?;
        }
        groups.push(points);
    }
    let mut points = Vec::new();
    for (c, t) in &mut chains {
        c.finish(&mut contours)?;
        for x in contours.drain(..) {
            t.push(x, &mut points)?;
        }
        t.finish(&mut points)?;
    }
    groups.push(points);
    Ok(groups)
}

/// The inputs of the [`Slip`](crate::slip::Slip) stage in the order a scene's runner hands them
/// over: per frame, its [`SlipPattern`](crate::slip_pattern::SlipPattern) point (when `cfg`'s
/// evidence reads frames), then the track points that frame produced (`tracks`, from
/// [`track_points_per_frame`]). The sensors are `cfg`'s `first` and `second`, BioTac SP layouts.
pub fn slip_inputs(
    frames: &[TaxelFrame],
    tracks: &[Vec<crate::track::TrackPoint>],
    cfg: &crate::slip::SlipConfig,
) -> crate::Result<Vec<crate::slip::SlipInput>> {
    use crate::slip::SlipInput;
    use gradtac_stream::Layout;
    let layout = Layout::biotac_sp();
    let mut pattern =
        cfg.reads_frames().then(|| crate::slip_pattern::SlipPattern::try_new(cfg, [&layout, &layout])).transpose()?;
    let mut out = Vec::with_capacity(3 * frames.len());
    let mut pts = Vec::new();
    for (k, f) in frames.iter().enumerate() {
        if let Some(p) = &mut pattern {
            p.push_frame(f, &mut pts)?;
            out.extend(pts.drain(..).map(SlipInput::Pattern));
        }
        out.extend(tracks.get(k).into_iter().flatten().cloned().map(SlipInput::Track));
    }
    out.extend(tracks.get(frames.len()).into_iter().flatten().cloned().map(SlipInput::Track));
    Ok(out)
}

/// The [`Slip`](crate::slip::Slip) stage with `cfg` over [`slip_inputs`] — what a bare scene
/// with a `slip` output runs.
pub fn detect(rec: &GraspRecording, cfg: &crate::slip::SlipConfig) -> crate::Result<Vec<crate::slip::SlipEvent>> {
    let tracks = track_points_per_frame(&rec.frames)?;
    crate::slip::Slip::try_new(cfg)?.run_inputs(slip_inputs(&rec.frames, &tracks, cfg)?)
}

/// Score the events of one grasp against its truth (see [`GraspScore`]).
pub fn score(truth: &GraspTruth, events: &[crate::slip::SlipEvent]) -> GraspScore {
    let t0 = truth.onset_s;
    let slips = events.iter().filter(|e| e.class.is_slip());
    let (early, late): (Vec<_>, Vec<_>) =
        slips.partition(|e| truth.class.is_slip() && e.time.as_secs_f64() < t0 || !truth.class.is_slip());
    let first = late.first();
    let still_s = if truth.class.is_slip() { t0 } else { truth.duration_s } - (PRESS_S + PRESS_RAMP_S);
    GraspScore {
        truth: *truth,
        detected: first.map(|e| e.class),
        onset_error_s: first.map_or(f64::NAN, |e| e.onset.as_secs_f64() - t0),
        decided_s: first.map_or(f64::NAN, |e| e.time.as_secs_f64() - t0),
        false_alarms: early.len(),
        still_s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deterministic_in_range_and_following_the_convention() {
        for seed in 0..10 {
            for class in SlipClass::ALL {
                let m = GraspMember { seed, class };
                let g = m.draw();
                assert_eq!(g, m.draw());
                let t = g.truth;
                assert!((1.0..2.5).contains(&t.onset_s) && (2.0..30.0).contains(&t.speed_mm_s));
                assert!((0.0..=0.4).contains(&t.ramp_s) && t.end_s >= t.onset_s && t.duration_s > t.end_s + 0.5);
                assert!((0.4..=1.6).contains(&t.grip_start) && (0.0..=0.2).contains(&t.finger_lag_s));
                assert!(StartShape::FAMILY.contains(&t.start) && (0.0..=3.0).contains(&t.load_rise));
                // one finger starts at the onset, the other at most the lag later
                let on = [g.fingers[0].onset_s, g.fingers[1].onset_s];
                assert_eq!(on[0].min(on[1]), t.onset_s);
                assert!((on[0].max(on[1]) - t.onset_s - t.finger_lag_s).abs() < 1e-12);
                let region = pad_region();
                for f in &g.fingers {
                    assert!(inside(&region, f.from) && inside(&region, f.to), "{seed} {class:?}");
                }
                // world-up displacement of each contact
                let up = |i: usize| {
                    let f = &g.fingers[i];
                    let u = if i == 0 { GRASP_UP_FF } else { GRASP_UP_TH };
                    (f.to[0] - f.from[0]) * u[0] + (f.to[1] - f.from[1]) * u[1]
                };
                let (a, b) = (up(0), up(1));
                match class {
                    SlipClass::Stable => assert!(a == 0.0 && b == 0.0),
                    SlipClass::LongitudinalUp => assert!(a > 0.0 && b > 0.0),
                    SlipClass::LongitudinalDown => assert!(a < 0.0 && b < 0.0),
                    SlipClass::RotationalCw => assert!(a < 0.0 && b > 0.0),
                    SlipClass::RotationalCcw => assert!(a > 0.0 && b < 0.0),
                }
                assert_eq!(t.class_at(t.onset_s - 0.01), SlipClass::Stable);
            }
        }
    }

    #[test]
    fn motion_starts_at_the_onset_slowly_and_ends_at_the_end() {
        let g = GraspMember { seed: 3, class: SlipClass::LongitudinalUp }.draw_in(&GraspFamily::narrow());
        let (t0, t1) = (g.truth.onset_s, g.truth.end_s);
        let f = &g.fingers[0];
        assert_eq!(f.contact_at(t0 - 0.01, &g.truth), f.from);
        assert_eq!(f.contact_at(t0, &g.truth), f.from);
        assert_eq!(f.contact_at(t1 + 0.01, &g.truth), f.to);
        let p = |tau: f64| progress(&g.truth, tau);
        assert!(g.truth.ramp_s > 0.02 && p(0.01) - p(0.0) < p(0.5) - p(0.49));
        let rec = g.simulate();
        assert_eq!(rec.frames.len(), 2 * (g.truth.duration_s * RATE_HZ).ceil() as usize);
        assert!(rec.frames.iter().all(|f| f.values.iter().all(|v| (0.0..=4095.0).contains(v) && v.fract() == 0.0)));
        assert_eq!(rec.frames[0].sensor.as_str(), "th");
        assert_eq!(rec.frames[1].sensor.as_str(), "ff");
    }

    #[test]
    fn start_shapes_travel_and_the_narrow_family_is_the_first() {
        // the linear start with no load rise: the first family's closed form t − r/2
        for (tau, r) in [(0.05, 0.2), (0.5, 0.2), (1.0, 0.0), (0.3, 0.3)] {
            let closed = if tau < r { tau * tau / (2.0 * r) } else { tau - r / 2.0 };
            assert!((travel(StartShape::Linear, r, 0.0, tau) - closed).abs() < 1e-12, "{tau} {r}");
        }
        // a step is at full speed at once, a smooth start slower than a linear one early on
        assert!((travel(StartShape::Step, 0.0, 0.0, 0.1) - 0.1).abs() < 1e-12);
        assert!(travel(StartShape::Smooth, 0.3, 0.0, 0.05) < travel(StartShape::Linear, 0.3, 0.0, 0.05));
        assert!(travel(StartShape::Exponential, 0.3, 0.0, 2.0) < 2.0);
        // a rising load: ∫(1 + α s) ds = τ + α τ²/2
        assert!((travel(StartShape::Step, 0.0, 2.0, 0.5) - (0.5 + 0.25)).abs() < 1e-12);
        let d = 0.8;
        for shape in [StartShape::Step, StartShape::Linear, StartShape::Smooth, StartShape::Exponential] {
            let t = motion_time(shape, 0.2, 1.0, d);
            assert!((travel(shape, 0.2, 1.0, t) - d).abs() < 1e-9, "{shape:?}");
        }
        // the narrow family: nothing widened
        for seed in 0..5 {
            let t = GraspMember { seed, class: SlipClass::RotationalCw }.draw_in(&GraspFamily::narrow()).truth;
            assert_eq!((t.start, t.grip_start, t.load_rise, t.finger_lag_s), (StartShape::Linear, 1.0, 0.0, 0.0));
        }
        // the held-out variant draws only exponential starts
        let v = GraspFamily::held_out_variant();
        assert!((0..5).all(|seed| {
            GraspMember { seed, class: SlipClass::LongitudinalUp }.draw_in(&v).truth.start == StartShape::Exponential
        }));
    }

    #[test]
    fn the_grip_ramps_to_its_force_and_the_later_finger_waits() {
        let fam = GraspFamily { p_grip_ramp: 1.0, p_finger_lag: 1.0, ..GraspFamily::widened() };
        let g = GraspMember { seed: 7, class: SlipClass::LongitudinalDown }.draw_in(&fam);
        let t = g.truth;
        assert!(t.grip_start != 1.0 && t.grip_end_s >= t.onset_s && t.finger_lag_s > 0.0);
        let f = &g.fingers[0];
        let press_end = PRESS_S + PRESS_RAMP_S;
        let no_mod = GraspFinger { force_mod: 0.0, ..f.clone() };
        assert!((no_mod.force_at(press_end, &t) - t.grip_start * f.physics.force_n).abs() < 1e-9);
        assert!((no_mod.force_at(t.grip_end_s + 0.1, &t) - f.physics.force_n).abs() < 1e-9);
        let late = g.fingers.iter().find(|f| f.onset_s > t.onset_s).expect("a later finger");
        assert_eq!(late.contact_at(t.onset_s + t.finger_lag_s / 2.0, &t), late.from);
        let early = g.fingers.iter().find(|f| f.onset_s == t.onset_s).expect("a first finger");
        assert_ne!(early.contact_at(t.onset_s + t.finger_lag_s, &t), early.from);
    }
}
