//! Simulator: a BioTac-like forward model with ground truth, deterministic by seed.
//!
//! # What it models
//! One **indenter** per sensor (an object's contact on a fingertip): a diameter `d` (mm), a
//! [`Path`] of its centre `c(t)` over the layout plane (mm) and a [`ForceProfile`] `F(t)` (N).
//! Every taxel `i` at position `pᵢ` (mm, the [`Layout`]'s plane) of sensor `s` reads, at frame
//! `k` (time `t = k / rate_hz`):
//!
//! | term | formula | unit | config ([`SensorModel`]) |
//! |---|---|---|---|
//! | spatial kernel | `K(r) = exp(−r² / 2w²)`, `w = √(w_skin² + (d/2)²)` | 1 | `skin_spread_mm` = `w_skin` |
//! | deformation | `uᵢ(t) = F(t) · K(‖pᵢ − c(t)‖)` | N | — |
//! | fluid damping | first-order lag `ũᵢ[k] = ũᵢ[k−1] + (1 − e^{−Δt/τ})(uᵢ[k] − ũᵢ[k−1])`, `ũᵢ[−1] = 0` | N | `damping_s` = `τ` |
//! | baseline | `bᵢ ~ U[baseline_counts]` | counts | `baseline_counts` |
//! | gain | `gᵢ = σᵢ·Gᵢ`, `Gᵢ ~ U[gain_counts_per_n]`, sign `σᵢ = −1` (value falls under pressure) except a fraction `flip_fraction` of taxels with `+1` | counts/N | `gain_counts_per_n`, `flip_fraction` |
//! | drift | `δᵢ · t`, `δᵢ ~ N(0, drift_counts_per_s²)` | counts | `drift_counts_per_s` |
//! | noise | `nᵢ[k] ~ N(0, noise_counts²)`, independent | counts | `noise_counts` |
//! | ADC | `round(clamp(bᵢ + gᵢ·ũᵢ + δᵢ·t + nᵢ, 0, adc_max))`, `adc_max` = 4095 (12 bit) by default | counts | `adc_max` |
//!
//! The sign of a taxel's change depends on the electrode (method.md): here a per-taxel sign
//! drawn once per sensor. Pipelines that must not care about it aggregate events by
//! [`Count`](crate::window::Aggregate::Count). Deliberately *not* modelled (no scene needs it):
//! shear, a surround of opposite sign, hysteresis, temperature, the pressure channel, skin
//! stiffening (the log-change events already compress large forces).
//!
//! Per-sensor parameters (baselines, gains, signs, drift) come from a generator seeded by
//! `seed` and the sensor's name, the noise from a second one: the same seed gives the same
//! recording (with the `rand` version in `Cargo.lock`: `StdRng` is not portable across `rand`
//! releases), and adding a finger to a scene does not change another finger's numbers.
//!
//! # Scenes
//! - [`Scene::trajectory`]: the paper's eight trajectories ([`Trajectory`]) with one indenter;
//! - [`Scene::force_ramp`]: a press ramped from 1 to 12 N (1, 2, 5 mm indenters in the paper);
//! - [`Scene::grasp`]: two fingertips (`th`, `ff`) facing each other, stable or slipping
//!   ([`SlipClass`]).
//!
//! For closed loops (a servo moving the sensor) [`Simulator::sensor`] gives a [`SimSensor`]
//! advanced one frame at a time with the contact the caller decides; [`Simulator::run`] is
//! built on it, so both produce the same numbers.
//!
//! Orientation on the layout plane: **right = +x, up = +y** (the plane as plots draw it),
//! angles from +x toward +y (counter-clockwise positive).
//!
//! ## Two-finger convention (mirror)
//! The thumb and the first finger hold an object between their pads, fingers pointing the same
//! way. The grasp frame has a world **up** axis along which the object slips. In the first
//! finger's layout up is `+y` ([`GRASP_UP_FF`]); the thumb is the first finger turned half a
//! turn about its long axis (x), so its `y` is mirrored and up is `−y` ([`GRASP_UP_TH`]).
//! The contact on each pad moves with the object (the skin is dragged along):
//! - longitudinal slip **up/down**: the object moves up/down at both pads — the two tracks move
//!   *the same way in the world*, i.e. in opposite `y` directions in the two layouts;
//! - rotational slip about an axis between the pads, parallel to the fingers: the surfaces at
//!   the two pads move oppositely. **Clockwise** is defined as seen by an observer looking
//!   along that axis with the first finger on their right, the thumb on their left and up
//!   pointing up: CW moves the object's surface *down* at the first finger and *up* at the
//!   thumb; CCW the reverse. In layout coordinates both tracks then move the same `y` way.
//!
//! [`slip::SlipConfig`](crate::slip::SlipConfig)'s defaults use the same convention.
//!
//! # Example
//! ```
//! use gradtac_stages::sim::{Scene, SensorModel, Simulator, Trajectory};
//! use gradtac_stream::Layout;
//!
//! let layout = Layout::biotac_sp();
//! let sim = Simulator::try_new(layout.clone(), SensorModel::default(), 7)?;
//! let scene = Scene::trajectory(Trajectory::CircleCw, 2.0, 3.0, &layout);
//! let rec = sim.run(&scene)?;
//! assert_eq!(rec.frames.len(), scene.frames_at(100.0)); // one finger, 3 s at 100 Hz
//! let f = &rec.frames[150];
//! assert!(f.truth.contact_mm.is_some() && f.truth.force_n > 0.0);
//! assert!(f.frame.values.iter().all(|&v| (0.0..=4095.0).contains(&v) && v == v.round()));
//! # Ok::<(), gradtac_stages::Error>(())
//! ```

use crate::slip::SlipClass;
use crate::{Error, Result};
use gradtac_stream::{HasSensor, Layout, SensorId, TaxelFrame, Timed, Timestamp};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::io::Write;
use std::path::Path as FsPath;

const STAGE: &str = "sim";

/// World up in the first finger's (`ff`) layout plane in a two-finger grasp (see the
/// [module docs](self)).
pub const GRASP_UP_FF: [f64; 2] = [0.0, 1.0];
/// World up in the thumb's (`th`) layout plane: mirrored, the pads face each other.
pub const GRASP_UP_TH: [f64; 2] = [0.0, -1.0];

/// Parameters of the forward model (see the [module docs](self) for every term).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SensorModel {
    /// Frame rate (Hz, > 0). Default 100 (the BioTac SP).
    pub rate_hz: f64,
    /// Range `[lo, hi]` of per-taxel baselines (counts, `0 ≤ lo ≤ hi ≤ adc_max`).
    /// Default `[1800, 3600]`.
    pub baseline_counts: [f64; 2],
    /// Range `[lo, hi]` of per-taxel gain magnitudes (counts per N at the kernel's centre,
    /// `0 ≤ lo ≤ hi`). Default `[40, 80]`.
    pub gain_counts_per_n: [f64; 2],
    /// Fraction of taxels (each independently, `[0, 1]`) whose value rises under pressure
    /// instead of falling. Default 0.25.
    pub flip_fraction: f64,
    /// Skin spread `w_skin` (mm, > 0) of the kernel; the kernel's width is
    /// `√(w_skin² + (d/2)²)` for an indenter of diameter `d`. Default 2.5.
    pub skin_spread_mm: f64,
    /// Fluid damping time constant `τ` (s, ≥ 0; 0 = none). Default 0.03.
    pub damping_s: f64,
    /// Standard deviation of per-taxel drift rates (counts/s, ≥ 0). Default 0.5.
    pub drift_counts_per_s: f64,
    /// Standard deviation of the Gaussian noise (counts, ≥ 0). Default 2.
    pub noise_counts: f64,
    /// Full scale of the ADC (counts, a whole number ≥ 1); values are clamped to
    /// `[0, adc_max]`. Default 4095 (12 bit).
    pub adc_max: f64,
}

impl Default for SensorModel {
    fn default() -> Self {
        SensorModel {
            rate_hz: 100.0,
            baseline_counts: [1800.0, 3600.0],
            gain_counts_per_n: [40.0, 80.0],
            flip_fraction: 0.25,
            skin_spread_mm: 2.5,
            damping_s: 0.03,
            drift_counts_per_s: 0.5,
            noise_counts: 2.0,
            adc_max: 4095.0,
        }
    }
}

impl SensorModel {
    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<()> {
        let bad = |reason: String| Err(Error::InvalidConfig { stage: STAGE, reason });
        let fin = |x: f64| x.is_finite();
        if !(fin(self.rate_hz) && self.rate_hz > 0.0) {
            return bad(format!("`rate_hz` = {} must be finite and > 0", self.rate_hz));
        }
        if !(fin(self.adc_max) && self.adc_max >= 1.0 && self.adc_max.fract() == 0.0) {
            return bad(format!("`adc_max` = {} must be a whole number of counts ≥ 1", self.adc_max));
        }
        let [b0, b1] = self.baseline_counts;
        if !(fin(b0) && fin(b1) && 0.0 <= b0 && b0 <= b1 && b1 <= self.adc_max) {
            return bad(format!("`baseline_counts` = {:?} must satisfy 0 ≤ lo ≤ hi ≤ adc_max", self.baseline_counts));
        }
        let [g0, g1] = self.gain_counts_per_n;
        if !(fin(g0) && fin(g1) && 0.0 <= g0 && g0 <= g1) {
            return bad(format!("`gain_counts_per_n` = {:?} must satisfy 0 ≤ lo ≤ hi", self.gain_counts_per_n));
        }
        if !(0.0..=1.0).contains(&self.flip_fraction) {
            return bad(format!("`flip_fraction` = {} must be in [0, 1]", self.flip_fraction));
        }
        if !(fin(self.skin_spread_mm) && self.skin_spread_mm > 0.0) {
            return bad(format!("`skin_spread_mm` = {} must be finite and > 0", self.skin_spread_mm));
        }
        for (name, v) in [
            ("damping_s", self.damping_s),
            ("drift_counts_per_s", self.drift_counts_per_s),
            ("noise_counts", self.noise_counts),
        ] {
            if !(fin(v) && v >= 0.0) {
                return bad(format!("`{name}` = {v} must be finite and ≥ 0"));
            }
        }
        Ok(())
    }
}

/// The path of an indenter's centre over the layout plane (mm); times in seconds from the
/// recording's start. Before its start a path is at its first point, after its end at its last.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Path {
    /// A fixed point (mm).
    Fixed([f64; 2]),
    /// A straight line from `from` to `to` (mm) at constant speed during `[t0_s, t1_s]`.
    Line {
        /// Start point (mm).
        from: [f64; 2],
        /// End point (mm).
        to: [f64; 2],
        /// Start time (s).
        t0_s: f64,
        /// End time (s), ≥ `t0_s`.
        t1_s: f64,
    },
    /// An arc around `centre` (mm) of radius `radius_mm`, from angle `start_rad` through
    /// `sweep_rad` (positive counter-clockwise, from +x toward +y) at constant angular speed
    /// during `[t0_s, t1_s]`.
    Arc {
        /// Centre (mm).
        centre: [f64; 2],
        /// Radius (mm).
        radius_mm: f64,
        /// Start angle (rad).
        start_rad: f64,
        /// Swept angle (rad): 2π is one counter-clockwise turn, −2π one clockwise turn.
        sweep_rad: f64,
        /// Start time (s).
        t0_s: f64,
        /// End time (s), ≥ `t0_s`.
        t1_s: f64,
    },
}

fn progress(t: f64, t0: f64, t1: f64) -> f64 {
    if t1 <= t0 {
        if t < t0 {
            0.0
        } else {
            1.0
        }
    } else {
        ((t - t0) / (t1 - t0)).clamp(0.0, 1.0)
    }
}

impl Path {
    /// The position (mm) at time `t` (s).
    pub fn at(&self, t: f64) -> [f64; 2] {
        match *self {
            Path::Fixed(p) => p,
            Path::Line { from, to, t0_s, t1_s } => {
                let a = progress(t, t0_s, t1_s);
                [from[0] + a * (to[0] - from[0]), from[1] + a * (to[1] - from[1])]
            }
            Path::Arc { centre, radius_mm, start_rad, sweep_rad, t0_s, t1_s } => {
                let th = start_rad + sweep_rad * progress(t, t0_s, t1_s);
                [centre[0] + radius_mm * th.cos(), centre[1] + radius_mm * th.sin()]
            }
        }
    }

    fn validate(&self) -> std::result::Result<(), String> {
        let ok = |xs: &[f64]| xs.iter().all(|x| x.is_finite());
        match *self {
            Path::Fixed(p) if ok(&p) => Ok(()),
            Path::Line { from, to, t0_s, t1_s }
                if ok(&[from[0], from[1], to[0], to[1], t0_s, t1_s]) && t1_s >= t0_s =>
            {
                Ok(())
            }
            Path::Arc { centre, radius_mm, start_rad, sweep_rad, t0_s, t1_s }
                if ok(&[centre[0], centre[1], radius_mm, start_rad, sweep_rad, t0_s, t1_s])
                    && radius_mm >= 0.0
                    && t1_s >= t0_s =>
            {
                Ok(())
            }
            _ => Err(format!("invalid path {self:?} (non-finite value, negative radius or t1 < t0)")),
        }
    }
}

/// Indenter force over time: keyframes `(t_s, newtons)`, linear in between, held before the
/// first and after the last.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct ForceProfile(pub Vec<(f64, f64)>);

impl ForceProfile {
    /// The force (N) at time `t` (s).
    pub fn at(&self, t: f64) -> f64 {
        let k = &self.0;
        match k.iter().position(|&(tk, _)| tk > t) {
            None => k.last().map_or(0.0, |&(_, f)| f),
            Some(0) => k[0].1,
            Some(j) => {
                let ((t0, f0), (t1, f1)) = (k[j - 1], k[j]);
                f0 + (f1 - f0) * (t - t0) / (t1 - t0)
            }
        }
    }

    fn validate(&self) -> std::result::Result<(), String> {
        if self.0.is_empty() {
            return Err("empty force profile".into());
        }
        for w in self.0.windows(2) {
            if w[1].0 < w[0].0 {
                return Err(format!("force keyframe times go backwards: {} after {}", w[1].0, w[0].0));
            }
        }
        if let Some(&(t, f)) = self.0.iter().find(|&&(t, f)| !(t.is_finite() && f.is_finite() && f >= 0.0)) {
            return Err(format!("force keyframe ({t}, {f}) must be finite with force ≥ 0"));
        }
        Ok(())
    }
}

/// One fingertip of a scene: its sensor and the indenter (the object's contact) on it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Finger {
    /// The sensor (`ff`, `th`, …).
    pub sensor: SensorId,
    /// Indenter diameter (mm, ≥ 0).
    pub diameter_mm: f64,
    /// Path of the indenter's centre (mm, layout plane).
    pub path: Path,
    /// Force (N).
    pub force: ForceProfile,
}

/// Scripted slip: the ground-truth class during `[onset_s, end_s)`; [`SlipClass::Stable`]
/// outside it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SlipScript {
    /// The class while slipping.
    pub class: SlipClass,
    /// Slip onset (s).
    pub onset_s: f64,
    /// Slip end (s).
    pub end_s: f64,
}

/// A scripted recording: fingers, duration and (for grasps) the slip.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    /// A short name (`"circle_cw"`, `"grasp_longitudinal_down"`, …).
    pub name: String,
    /// Duration (s, > 0); the recording has `round(duration_s · rate_hz)` frames per sensor.
    pub duration_s: f64,
    /// The fingertips, in the order their frames are interleaved.
    pub fingers: Vec<Finger>,
    /// The slip ground truth, if the scene slips.
    pub slip: Option<SlipScript>,
}

/// The paper's eight trajectories (on the layout plane: right = +x, up = +y).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Trajectory {
    /// Bottom to top (+y).
    Up,
    /// Top to bottom (−y).
    Down,
    /// Right to left (−x).
    Left,
    /// Left to right (+x).
    Right,
    /// Bottom-left to top-right.
    DiagonalUp,
    /// Top-left to bottom-right.
    DiagonalDown,
    /// One clockwise turn.
    CircleCw,
    /// One counter-clockwise turn.
    CircleCcw,
}

impl Trajectory {
    /// All eight.
    pub const ALL: [Trajectory; 8] = [
        Trajectory::Up,
        Trajectory::Down,
        Trajectory::Left,
        Trajectory::Right,
        Trajectory::DiagonalUp,
        Trajectory::DiagonalDown,
        Trajectory::CircleCw,
        Trajectory::CircleCcw,
    ];

    /// The snake_case name.
    pub fn name(self) -> &'static str {
        match self {
            Trajectory::Up => "up",
            Trajectory::Down => "down",
            Trajectory::Left => "left",
            Trajectory::Right => "right",
            Trajectory::DiagonalUp => "diagonal_up",
            Trajectory::DiagonalDown => "diagonal_down",
            Trajectory::CircleCw => "circle_cw",
            Trajectory::CircleCcw => "circle_ccw",
        }
    }
}

/// Half the length (mm) of the straight trajectories; the circles' radius is
/// [`TRAJECTORY_RADIUS_MM`]. Both stay inside the BioTac SP's taxel hull around its centre.
pub const TRAJECTORY_HALF_MM: f64 = 6.0;
/// Radius (mm) of the circular trajectories.
pub const TRAJECTORY_RADIUS_MM: f64 = 5.0;

/// Timeline of [`Scene::trajectory`] (s): press during `[0.1, 0.3]`, move during
/// `[MOVE_START_S, MOVE_END_S]`, lift during `[2.7, 2.9]`, end at 3.0.
pub const MOVE_START_S: f64 = 0.5;
/// End of the movement in [`Scene::trajectory`] (s).
pub const MOVE_END_S: f64 = 2.5;

impl Scene {
    /// Frames per sensor at `rate_hz`.
    pub fn frames_at(&self, rate_hz: f64) -> usize {
        (self.duration_s * rate_hz).round() as usize
    }

    /// One indenter (sensor `ff`) of diameter `diameter_mm` pressing at `force_n` and moving
    /// along a [`Trajectory`] around the layout's extent centre: no contact for 0.1 s, press
    /// (0 → `force_n` over 0.2 s), hold 0.2 s, move for 2 s ([`MOVE_START_S`]..[`MOVE_END_S`]),
    /// hold 0.2 s, lift over 0.2 s; 3 s in all. Straight paths are `2·`[`TRAJECTORY_HALF_MM`]
    /// long, circles of radius [`TRAJECTORY_RADIUS_MM`] start and end at angle 0 (right of
    /// the centre).
    pub fn trajectory(kind: Trajectory, diameter_mm: f64, force_n: f64, layout: &Layout) -> Scene {
        let [cx, cy] = layout.extent().centre();
        let h = TRAJECTORY_HALF_MM;
        let d = h / std::f64::consts::SQRT_2;
        let (t0_s, t1_s) = (MOVE_START_S, MOVE_END_S);
        let line = |from: [f64; 2], to: [f64; 2]| Path::Line {
            from: [cx + from[0], cy + from[1]],
            to: [cx + to[0], cy + to[1]],
            t0_s,
            t1_s,
        };
        let arc = |sweep_rad: f64| Path::Arc {
            centre: [cx, cy],
            radius_mm: TRAJECTORY_RADIUS_MM,
            start_rad: 0.0,
            sweep_rad,
            t0_s,
            t1_s,
        };
        let path = match kind {
            Trajectory::Up => line([0.0, -h], [0.0, h]),
            Trajectory::Down => line([0.0, h], [0.0, -h]),
            Trajectory::Left => line([h, 0.0], [-h, 0.0]),
            Trajectory::Right => line([-h, 0.0], [h, 0.0]),
            Trajectory::DiagonalUp => line([-d, -d], [d, d]),
            Trajectory::DiagonalDown => line([-d, d], [d, -d]),
            Trajectory::CircleCw => arc(-2.0 * PI),
            Trajectory::CircleCcw => arc(2.0 * PI),
        };
        let force = ForceProfile(vec![(0.1, 0.0), (0.3, force_n), (2.7, force_n), (2.9, 0.0)]);
        Scene {
            name: kind.name().to_string(),
            duration_s: 3.0,
            fingers: vec![Finger { sensor: "ff".into(), diameter_mm, path, force }],
            slip: None,
        }
    }

    /// A force ramp on sensor `ff` at point `at` (mm): no contact for 0.1 s, press to 1 N over
    /// 0.2 s, ramp linearly 1 → 12 N over `ramp_s`, hold 0.2 s, lift over 0.2 s, 0.1 s without
    /// contact.
    pub fn force_ramp(diameter_mm: f64, at: [f64; 2], ramp_s: f64) -> Scene {
        let t1 = 0.3 + ramp_s;
        let force = ForceProfile(vec![(0.1, 0.0), (0.3, 1.0), (t1, 12.0), (t1 + 0.2, 12.0), (t1 + 0.4, 0.0)]);
        Scene {
            name: format!("force_ramp_{diameter_mm}mm"),
            duration_s: t1 + 0.5,
            fingers: vec![Finger { sensor: "ff".into(), diameter_mm, path: Path::Fixed(at), force }],
            slip: None,
        }
    }

    /// A two-finger grasp ([`GraspConfig`]): thumb `th` and first finger `ff` facing each other
    /// (mirror convention in the [module docs](self)), each touched at its layout's extent
    /// centre; the grasp closes (0 → `force_n`) during `[0.1, 0.4]` s; with a slip class other
    /// than [`SlipClass::Stable`] the contacts move `slip_mm` along world up (or down) from
    /// `onset_s` at `slip_mm_s`, then rest until the end.
    pub fn grasp(class: SlipClass, cfg: &GraspConfig, layout: &Layout) -> Scene {
        let c = layout.extent().centre();
        // world-up displacement of the contact on (ff, th)
        let (s_ff, s_th) = match class {
            SlipClass::Stable => (0.0, 0.0),
            SlipClass::LongitudinalUp => (1.0, 1.0),
            SlipClass::LongitudinalDown => (-1.0, -1.0),
            SlipClass::RotationalCw => (-1.0, 1.0),
            SlipClass::RotationalCcw => (1.0, -1.0),
        };
        let t0_s = cfg.onset_s;
        let t1_s = cfg.onset_s + cfg.slip_mm / cfg.slip_mm_s;
        let finger = |name: &str, up: [f64; 2], s: f64| {
            let to = [c[0] + s * cfg.slip_mm * up[0], c[1] + s * cfg.slip_mm * up[1]];
            Finger {
                sensor: name.into(),
                diameter_mm: cfg.diameter_mm,
                path: Path::Line { from: c, to, t0_s, t1_s },
                force: ForceProfile(vec![(0.1, 0.0), (0.4, cfg.force_n)]),
            }
        };
        let slip = (class != SlipClass::Stable).then_some(SlipScript { class, onset_s: t0_s, end_s: t1_s });
        Scene {
            name: format!("grasp_{}", class.name()),
            duration_s: cfg.duration_s,
            fingers: vec![finger("th", GRASP_UP_TH, s_th), finger("ff", GRASP_UP_FF, s_ff)],
            slip,
        }
    }

    fn validate(&self) -> Result<()> {
        let bad = |reason: String| {
            Err(Error::InvalidConfig { stage: STAGE, reason: format!("scene {:?}: {reason}", self.name) })
        };
        if !(self.duration_s.is_finite() && self.duration_s > 0.0) {
            return bad(format!("duration {} s must be finite and > 0", self.duration_s));
        }
        if self.fingers.is_empty() {
            return bad("no fingers".into());
        }
        for (i, f) in self.fingers.iter().enumerate() {
            if self.fingers[..i].iter().any(|g| g.sensor == f.sensor) {
                return bad(format!("sensor {} appears twice", f.sensor));
            }
            if !(f.diameter_mm.is_finite() && f.diameter_mm >= 0.0) {
                return bad(format!("{}: diameter {} mm must be finite and ≥ 0", f.sensor, f.diameter_mm));
            }
            if let Err(e) = f.path.validate().and_then(|()| f.force.validate()) {
                return bad(format!("{}: {e}", f.sensor));
            }
        }
        Ok(())
    }

    /// The ground-truth slip class at time `t` (s).
    pub fn slip_at(&self, t: f64) -> SlipClass {
        match self.slip {
            Some(s) if t >= s.onset_s && t < s.end_s => s.class,
            _ => SlipClass::Stable,
        }
    }
}

/// Parameters of [`Scene::grasp`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GraspConfig {
    /// Grasp force on each finger (N). Default 5.
    pub force_n: f64,
    /// Contact diameter (mm). Default 5.
    pub diameter_mm: f64,
    /// Slip onset (s). Default 1.0.
    pub onset_s: f64,
    /// Slip distance on each pad (mm, > 0). Default 6.
    pub slip_mm: f64,
    /// Slip speed (mm/s, > 0). Default 20.
    pub slip_mm_s: f64,
    /// Recording length (s). Default 2.0.
    pub duration_s: f64,
}

impl Default for GraspConfig {
    fn default() -> Self {
        GraspConfig { force_n: 5.0, diameter_mm: 5.0, onset_s: 1.0, slip_mm: 6.0, slip_mm_s: 20.0, duration_s: 2.0 }
    }
}

/// Ground truth of one sensor frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    /// Where the indenter's centre is (mm, layout plane); `None` while the force is 0.
    pub contact_mm: Option<[f64; 2]>,
    /// Applied force (N).
    pub force_n: f64,
    /// Indenter diameter (mm).
    pub diameter_mm: f64,
    /// The scene's slip class at this time ([`SlipClass::Stable`] outside the slip).
    pub slip: SlipClass,
    /// The scene's slip onset, if it slips at all (the same for every frame).
    pub slip_onset: Option<Timestamp>,
}

/// One simulated frame and its ground truth.
#[derive(Clone, Debug, PartialEq)]
pub struct SimFrame {
    /// Raw counts of one sensor.
    pub frame: TaxelFrame,
    /// What really happened.
    pub truth: Truth,
}

impl Timed for SimFrame {
    fn time(&self) -> Timestamp {
        self.frame.time
    }
}

impl HasSensor for SimFrame {
    fn sensor(&self) -> &SensorId {
        &self.frame.sensor
    }
}

/// A simulated recording: frames of every finger interleaved in time order (at each time step
/// one frame per finger, in the scene's finger order).
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    /// The scene's name.
    pub scene: String,
    /// Frame rate (Hz).
    pub rate_hz: f64,
    /// The sensors in the scene's order.
    pub sensors: Vec<SensorId>,
    /// The taxels' names (`e1`..`e24` for the BioTac SP).
    pub taxel_names: Vec<String>,
    /// All frames, interleaved.
    pub frames: Vec<SimFrame>,
}

impl Recording {
    /// The frames of one sensor, in time order.
    pub fn of_sensor<'a>(&'a self, sensor: &'a str) -> impl Iterator<Item = &'a SimFrame> + 'a {
        self.frames.iter().filter(move |f| f.frame.sensor.as_str() == sensor)
    }

    /// The raw frames of every sensor, interleaved (a clone, ready for a pipeline).
    pub fn taxel_frames(&self) -> Vec<TaxelFrame> {
        self.frames.iter().map(|f| f.frame.clone()).collect()
    }

    /// Ground truth of `sensor` for the frame with index `seq`.
    pub fn truth(&self, sensor: &str, seq: u64) -> Option<&Truth> {
        let n = self.sensors.len();
        let i = self.sensors.iter().position(|s| s.as_str() == sensor)?;
        self.frames.get(seq as usize * n + i).map(|f| &f.truth)
    }

    /// Write the recording as CSV: `data` gets a header `<sensor>_<taxel>` for every sensor
    /// and taxel (`ff_e1..ff_e24` for the BioTac SP) and one row of integer counts per time
    /// step (no time column: the fixed rate [`Recording::rate_hz`], first row at t = 0);
    /// `truth` gets `time_s`, per sensor `<sensor>_x_mm,<sensor>_y_mm,<sensor>_force_n`
    /// (empty x/y without contact), then `slip` (class name) and `slip_onset_s` (empty when
    /// the scene does not slip).
    pub fn write_csv(&self, data: &FsPath, truth: &FsPath) -> std::io::Result<()> {
        let mut d = std::io::BufWriter::new(std::fs::File::create(data)?);
        let mut t = std::io::BufWriter::new(std::fs::File::create(truth)?);
        self.write_csv_to(&mut d, &mut t)?;
        d.flush()?;
        t.flush()
    }

    /// [`Recording::write_csv`] to any writers.
    pub fn write_csv_to(&self, data: &mut impl Write, truth: &mut impl Write) -> std::io::Result<()> {
        let n = self.sensors.len();
        let head: Vec<String> =
            self.sensors.iter().flat_map(|s| self.taxel_names.iter().map(move |t| format!("{s}_{t}"))).collect();
        writeln!(data, "{}", head.join(","))?;
        let mut th = vec!["time_s".to_string()];
        for s in &self.sensors {
            th.extend([format!("{s}_x_mm"), format!("{s}_y_mm"), format!("{s}_force_n")]);
        }
        th.extend(["slip".to_string(), "slip_onset_s".to_string()]);
        writeln!(truth, "{}", th.join(","))?;
        for step in self.frames.chunks(n) {
            let row: Vec<String> = step.iter().flat_map(|f| f.frame.values.iter().map(|v| format!("{v}"))).collect();
            writeln!(data, "{}", row.join(","))?;
            let mut r = vec![format!("{}", step[0].frame.time.as_secs_f64())];
            for f in step {
                match f.truth.contact_mm {
                    Some([x, y]) => r.extend([format!("{x}"), format!("{y}")]),
                    None => r.extend([String::new(), String::new()]),
                }
                r.push(format!("{}", f.truth.force_n));
            }
            r.push(step[0].truth.slip.name().to_string());
            r.push(step[0].truth.slip_onset.map_or(String::new(), |o| format!("{}", o.as_secs_f64())));
            writeln!(truth, "{}", r.join(","))?;
        }
        Ok(())
    }
}

/// Per-sensor parameters drawn from the seed.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorParams {
    /// Baseline per taxel (counts).
    pub baseline: Vec<f64>,
    /// Signed gain per taxel (counts/N).
    pub gain: Vec<f64>,
    /// Drift rate per taxel (counts/s).
    pub drift: Vec<f64>,
}

/// The simulator: a layout, a [`SensorModel`] and a seed.
#[derive(Clone, Debug)]
pub struct Simulator {
    layout: Layout,
    model: SensorModel,
    seed: u64,
}

/// FNV-1a of a sensor name, mixed into the seed.
fn name_hash(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3))
}

impl Simulator {
    /// A simulator (the model is validated).
    pub fn try_new(layout: Layout, model: SensorModel, seed: u64) -> Result<Self> {
        model.validate()?;
        Ok(Simulator { layout, model, seed })
    }

    /// The layout.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// The model.
    pub fn model(&self) -> &SensorModel {
        &self.model
    }

    /// The parameters of sensor `name` (a function of the seed and the name only).
    pub fn params(&self, name: &str) -> SensorParams {
        let m = &self.model;
        let mut rng = StdRng::seed_from_u64(self.seed ^ name_hash(name));
        let n = self.layout.len();
        let mut uni = |[lo, hi]: [f64; 2]| if hi > lo { rng.random_range(lo..hi) } else { lo };
        let baseline: Vec<f64> = (0..n).map(|_| uni(m.baseline_counts)).collect();
        let mag: Vec<f64> = (0..n).map(|_| uni(m.gain_counts_per_n)).collect();
        let gain = mag.into_iter().map(|g| if rng.random::<f64>() < m.flip_fraction { g } else { -g }).collect();
        let drift = match Normal::new(0.0, m.drift_counts_per_s) {
            Ok(d) => (0..n).map(|_| d.sample(&mut rng)).collect(),
            Err(_) => vec![0.0; n],
        };
        SensorParams { baseline, gain, drift }
    }

    /// A steppable sensor (for closed loops: the caller decides the contact frame by frame).
    /// Its parameters and noise are those [`Simulator::run`] uses for a finger of that name.
    pub fn sensor(&self, name: impl Into<SensorId>) -> SimSensor {
        let name = name.into();
        let m = &self.model;
        SimSensor {
            params: self.params(name.as_str()),
            lag: vec![0.0; self.layout.len()],
            rng: StdRng::seed_from_u64(self.seed ^ name_hash(name.as_str()) ^ 0x9e37_79b9_7f4a_7c15),
            noise: Normal::new(0.0, m.noise_counts).expect("validated: finite, ≥ 0"),
            alpha: if m.damping_s > 0.0 { 1.0 - (-1.0 / (m.rate_hz * m.damping_s)).exp() } else { 1.0 },
            positions: self.layout.positions().to_vec(),
            model: m.clone(),
            name,
            k: 0,
        }
    }

    /// Simulate a scene.
    pub fn run(&self, scene: &Scene) -> Result<Recording> {
        scene.validate()?;
        let n_steps = scene.frames_at(self.model.rate_hz);
        let onset = scene.slip.and_then(|s| Timestamp::from_secs_f64(s.onset_s));
        let mut sensors: Vec<SimSensor> = scene.fingers.iter().map(|f| self.sensor(f.sensor.clone())).collect();
        let mut frames = Vec::with_capacity(n_steps * scene.fingers.len());
        for k in 0..n_steps {
            let t = Timestamp::at_rate(k as u64, self.model.rate_hz).as_secs_f64();
            let slip = scene.slip_at(t);
            for (f, s) in scene.fingers.iter().zip(&mut sensors) {
                let contact = Contact { at_mm: f.path.at(t), force_n: f.force.at(t), diameter_mm: f.diameter_mm };
                frames.push(SimFrame {
                    frame: s.step(Some(contact)),
                    truth: Truth {
                        contact_mm: (contact.force_n > 0.0).then_some(contact.at_mm),
                        force_n: contact.force_n,
                        diameter_mm: f.diameter_mm,
                        slip,
                        slip_onset: onset,
                    },
                });
            }
        }
        Ok(Recording {
            scene: scene.name.clone(),
            rate_hz: self.model.rate_hz,
            sensors: scene.fingers.iter().map(|f| f.sensor.clone()).collect(),
            taxel_names: self.layout.names().to_vec(),
            frames,
        })
    }
}

/// One indenter's contact at one instant (for [`SimSensor::step`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Contact {
    /// Indenter centre (mm, layout plane).
    pub at_mm: [f64; 2],
    /// Force (N, ≥ 0; negative or NaN counts as 0).
    pub force_n: f64,
    /// Indenter diameter (mm).
    pub diameter_mm: f64,
}

/// One simulated sensor advanced a frame at a time ([`Simulator::sensor`]): the same model
/// and numbers as [`Simulator::run`], for loops whose contact depends on the output (a servo
/// moving the sensor).
#[derive(Debug)]
pub struct SimSensor {
    name: SensorId,
    model: SensorModel,
    params: SensorParams,
    positions: Vec<[f64; 2]>,
    lag: Vec<f64>,
    rng: StdRng,
    noise: Normal<f64>,
    alpha: f64,
    k: u64,
}

impl SimSensor {
    /// The sensor's parameters.
    pub fn params(&self) -> &SensorParams {
        &self.params
    }

    /// Index of the next frame.
    pub fn next_seq(&self) -> u64 {
        self.k
    }

    /// The next frame (time `k / rate_hz`), with `contact` (or none) applied.
    pub fn step(&mut self, contact: Option<Contact>) -> TaxelFrame {
        let m = &self.model;
        let time = Timestamp::at_rate(self.k, m.rate_hz);
        let t = time.as_secs_f64();
        let (c, force, w2) = match contact {
            Some(c) if c.force_n > 0.0 => {
                (c.at_mm, c.force_n, m.skin_spread_mm.powi(2) + (c.diameter_mm.max(0.0) / 2.0).powi(2))
            }
            _ => ([0.0, 0.0], 0.0, 1.0),
        };
        let values = self
            .positions
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let r2 = (p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2);
                let u = force * (-r2 / (2.0 * w2)).exp();
                self.lag[i] += self.alpha * (u - self.lag[i]);
                let v = self.params.baseline[i]
                    + self.params.gain[i] * self.lag[i]
                    + self.params.drift[i] * t
                    + self.noise.sample(&mut self.rng);
                v.clamp(0.0, m.adc_max).round()
            })
            .collect();
        let frame = TaxelFrame::new(self.name.clone(), time, self.k, values);
        self.k += 1;
        frame
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_and_profiles_interpolate_and_hold() {
        let p = Path::Line { from: [0.0, 0.0], to: [2.0, 4.0], t0_s: 1.0, t1_s: 3.0 };
        assert_eq!(p.at(0.0), [0.0, 0.0]);
        assert_eq!(p.at(2.0), [1.0, 2.0]);
        assert_eq!(p.at(9.0), [2.0, 4.0]);
        let a = Path::Arc { centre: [1.0, 1.0], radius_mm: 2.0, start_rad: 0.0, sweep_rad: PI, t0_s: 0.0, t1_s: 1.0 };
        let q = a.at(0.5);
        assert!((q[0] - 1.0).abs() < 1e-12 && (q[1] - 3.0).abs() < 1e-12, "{q:?}"); // CCW: through +y
        let f = ForceProfile(vec![(1.0, 0.0), (2.0, 4.0), (2.0, 6.0)]);
        assert_eq!(f.at(0.0), 0.0);
        assert_eq!(f.at(1.5), 2.0);
        assert_eq!(f.at(2.0), 6.0); // a step keyframe: the later value from its time on
        assert_eq!(f.at(5.0), 6.0);
    }

    #[test]
    fn invalid_models_and_scenes_are_refused() {
        let l = Layout::biotac_sp();
        for m in [
            SensorModel { rate_hz: 0.0, ..Default::default() },
            SensorModel { baseline_counts: [3000.0, 5000.0], ..Default::default() },
            SensorModel { gain_counts_per_n: [50.0, 10.0], ..Default::default() },
            SensorModel { flip_fraction: 1.5, ..Default::default() },
            SensorModel { noise_counts: f64::NAN, ..Default::default() },
            // proptest regression: a fractional full scale let round() exceed it (311.84 → 312)
            SensorModel { adc_max: 311.84, baseline_counts: [0.0, 100.0], ..Default::default() },
        ] {
            assert!(Simulator::try_new(l.clone(), m, 0).is_err());
        }
        let sim = Simulator::try_new(l.clone(), SensorModel::default(), 0).unwrap();
        let mut s = Scene::trajectory(Trajectory::Up, 2.0, 3.0, &l);
        s.fingers[0].force = ForceProfile(vec![(0.0, -1.0)]);
        let e = sim.run(&s).unwrap_err().to_string();
        assert!(e.contains("force ≥ 0"), "{e}");
        let mut s = Scene::grasp(SlipClass::Stable, &GraspConfig::default(), &l);
        s.fingers[1].sensor = "th".into();
        assert!(sim.run(&s).unwrap_err().to_string().contains("twice"));
    }

    #[test]
    fn grasp_truth_follows_the_mirror_convention() {
        let l = Layout::biotac_sp();
        let c = l.extent().centre();
        let cfg = GraspConfig::default();
        let d = cfg.slip_mm;
        for (class, ff_dy, th_dy) in [
            (SlipClass::LongitudinalUp, d, -d),
            (SlipClass::LongitudinalDown, -d, d),
            (SlipClass::RotationalCw, -d, -d),
            (SlipClass::RotationalCcw, d, d),
            (SlipClass::Stable, 0.0, 0.0),
        ] {
            let s = Scene::grasp(class, &cfg, &l);
            let end = |name: &str| s.fingers.iter().find(|f| f.sensor.as_str() == name).unwrap().path.at(10.0);
            assert!((end("ff")[1] - c[1] - ff_dy).abs() < 1e-12, "{class:?}");
            assert!((end("th")[1] - c[1] - th_dy).abs() < 1e-12, "{class:?}");
            assert_eq!(s.slip_at(1.2), class);
            assert_eq!(s.slip_at(0.9), SlipClass::Stable);
        }
    }
}
