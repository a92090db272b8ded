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
//! | onset | first frame of motion (truth) | `t₀ ∈ [1.0, 2.5]` s |
//! | speed | object's slip speed `v` (mm/s) | log-uniform in `[2, 30]` |
//! | slow start | the speed ramps linearly from 0 to `v` over `ramp` | `ramp ∈ [0, 0.3]` s |
//! | distance | travel of each contact | `D ∈ [3, 8]` mm, at most `v · 1.5 s` (so slow slips last ≤ 1.5 s + ramp), shrunk to fit the pad |
//! | direction | each contact moves along its finger's world up (`±y`) turned by a misalignment | `θ ∈ [−15°, 15°]` per finger |
//! | rotation axis | rotational classes: the contacts' speeds are `v·2k` and `v·2(1−k)` (an axis off the middle) | `k ∈ [0.35, 0.65]` |
//! | start point | anywhere on the pad: uniform until the whole path lies in [`crate::sim_family::pad_region`] | — |
//! | grip force | one force `F` on both pads (the object is in equilibrium between them: the normal forces are equal and opposite), times `1 + a·sin(2πf t + φ)` from the press on (squeeze changes, all classes); it replaces the fingers' own force draws, their sensitivity (amplitude, gains, kernel, width) stays their own | `F ∈ [0.5, 10]` N (the family's range), `a ∈ [0, 0.3]`, `f ∈ [0.2, 1]` Hz |
//! | end | 0.6–1.0 s of stillness after the motion (stable: the same length as a slip would have) | — |
//!
//! Classes ([`SlipClass`]): longitudinal up / down (both contacts move the same world way),
//! rotational cw / ccw (opposite world ways; cw moves the surface *down* at `ff`), stable (drift
//! and force changes, no motion). A stable member has the same timeline without motion.
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
    /// Length of the slow start (s).
    pub ramp_s: f64,
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

/// Progress (fraction of the distance) at `t` s after the onset for a motion of `total_s`
/// seconds whose speed ramps up over `ramp_s`.
fn progress(t: f64, ramp_s: f64, total_s: f64) -> f64 {
    if t <= 0.0 {
        return 0.0;
    }
    if t >= total_s {
        return 1.0;
    }
    // distance at full speed 1: ramp part t²/(2r), then linear
    let d = |t: f64| if t < ramp_s { t * t / (2.0 * ramp_s) } else { t - ramp_s / 2.0 };
    d(t) / d(total_s)
}

impl GraspMember {
    /// The members `seeds × classes`.
    pub fn grid(seeds: impl IntoIterator<Item = u64>) -> Vec<GraspMember> {
        seeds.into_iter().flat_map(|seed| SlipClass::ALL.map(|class| GraspMember { seed, class })).collect()
    }

    /// Draw every parameter (see the [module docs](self)).
    pub fn draw(&self) -> Grasp {
        let mut rng = StdRng::seed_from_u64(mix(self.seed, 11 + self.class as u64));
        let mut u = |lo: f64, hi: f64| rng.random_range(lo..hi);
        let onset_s = u(1.0, 2.5);
        let speed = u(2f64.ln(), 30f64.ln()).exp();
        let ramp_s = u(0.0, 0.3);
        let k = u(0.35, 0.65);
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
        let move_s = (dist / (speed * fmax)) + ramp_s / 2.0;
        let region = pad_region();
        let (x0, x1) = region.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| (a.0.min(p[0]), a.1.max(p[0])));
        let (y0, y1) = region.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| (a.0.min(p[1]), a.1.max(p[1])));
        // one grip force and squeeze for both pads: the object is in equilibrium between them
        let grip_n = u(0.5, 10.0);
        let (force_mod, force_hz, force_phase) = (u(0.0, 0.3), u(0.2, 1.0), u(0.0, 2.0 * PI));
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
            fingers.push(GraspFinger { sensor: name.into(), physics, from, to, force_mod, force_hz, force_phase });
        }
        let end_s = if self.class.is_slip() { onset_s + move_s } else { onset_s };
        let duration_s = onset_s + move_s + u(0.6, 1.0);
        let [ff, th]: [GraspFinger; 2] = fingers.try_into().expect("two fingers");
        Grasp {
            member: *self,
            fingers: [ff, th],
            truth: GraspTruth { class: self.class, onset_s, end_s, speed_mm_s: speed, ramp_s, duration_s },
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
        let u = if truth.class.is_slip() {
            progress(t - truth.onset_s, truth.ramp_s, truth.end_s - truth.onset_s)
        } else {
            0.0
        };
        [self.from[0] + u * (self.to[0] - self.from[0]), self.from[1] + u * (self.to[1] - self.from[1])]
    }

    /// Force at `t` (s): 0 before the press, ramped over [`PRESS_RAMP_S`], modulated.
    pub fn force_at(&self, t: f64) -> f64 {
        let ramp = ((t - PRESS_S) / PRESS_RAMP_S).clamp(0.0, 1.0);
        let m = 1.0 + self.force_mod * (2.0 * PI * self.force_hz * (t - PRESS_S) + self.force_phase).sin();
        self.physics.force_n * ramp * if t > PRESS_S { m } else { 1.0 }
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
                let force = f.force_at(t);
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
                assert!((0.0..0.3).contains(&t.ramp_s) && t.end_s >= t.onset_s && t.duration_s > t.end_s + 0.5);
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
        let g = GraspMember { seed: 3, class: SlipClass::LongitudinalUp }.draw();
        let (t0, t1) = (g.truth.onset_s, g.truth.end_s);
        let f = &g.fingers[0];
        assert_eq!(f.contact_at(t0 - 0.01, &g.truth), f.from);
        assert_eq!(f.contact_at(t0, &g.truth), f.from);
        assert_eq!(f.contact_at(t1 + 0.01, &g.truth), f.to);
        assert!(
            (progress(0.01, 0.2, 1.0) - progress(0.0, 0.2, 1.0)) < progress(0.5, 0.2, 1.0) - progress(0.49, 0.2, 1.0)
        );
        let rec = g.simulate();
        assert_eq!(rec.frames.len(), 2 * (g.truth.duration_s * RATE_HZ).ceil() as usize);
        assert!(rec.frames.iter().all(|f| f.values.iter().all(|v| (0.0..=4095.0).contains(v) && v.fract() == 0.0)));
        assert_eq!(rec.frames[0].sensor.as_str(), "th");
        assert_eq!(rec.frames[1].sensor.as_str(), "ff");
    }
}
