//! Servo: the contact's offset from the sensor centre as a motion vector, for edge following
//! (method.md, stage 7; the paper's tactile servoing keeps the contact at the centre).
//!
//! # What it does
//! For every [`TrackPoint`] the [`Servo`] stage emits a [`ServoCommand`]:
//! - with contact: `offset = contact − centre` (mm, in the sensor's layout plane), its length
//!   and unit direction, and `motion = gain · offset` clipped to `max_step_mm`. Moving the
//!   *sensor* by `motion` (expressed in its own layout frame) brings a stationary contact back
//!   toward the centre. Inside `deadband_mm` the motion is zero (the offset is still reported);
//! - the contact position may be smoothed first (`smoothing`, an exponential filter that
//!   restarts with each contact);
//! - without contact (or a gated, repeated point when `hold_gated = false`): no command, as
//!   data ([`ServoAction::NoContact`]) — the controller decides what "lost the edge" means.
//!
//! The centre is `centre_mm` when configured, else the layout extent's centre
//! ([`Servo::try_new`] takes the layout for that).
//!
//! # Units
//! mm (offsets, motions), dimensionless (gain, directions).
//!
//! # Delay
//! None.
//!
//! # Trade-offs
//! | knob | lower | higher |
//! |---|---|---|
//! | `gain` | slow, steady convergence | fast; overshoots with a lagging track |
//! | `deadband_mm` | reacts to contour jitter | ignores small real offsets |
//! | `max_step_mm` | safe, slow recovery from large offsets | large jumps on a spurious contour |
//! | `smoothing` | steady commands, lagging the contact | immediate, jittery commands |

use crate::track::{ContactState, TrackPoint};
use crate::{Error, Result};
use gradtac_stream::{Delay, HasSensor, Layout, SensorId, Stage, Timed, Timestamp};
use serde::{Deserialize, Serialize};

const STAGE: &str = "servo";

/// Configuration of the [`Servo`] stage (`[stages.servo]` in a scene).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ServoConfig {
    /// The point to keep the contact at (mm, layout plane); `None` = the layout extent's
    /// centre. Default `None`.
    pub centre_mm: Option<[f64; 2]>,
    /// Proportional gain (dimensionless, > 0): `motion = gain · offset`. Default 1.
    pub gain: f64,
    /// Offsets shorter than this (mm, ≥ 0) give zero motion. Default 0.5.
    pub deadband_mm: f64,
    /// Longest motion (mm, > 0). Default 5.
    pub max_step_mm: f64,
    /// Whether a gated track point (the tracker repeating its last accepted position after a
    /// jump) still commands a motion. Default false.
    pub hold_gated: bool,
    /// Smoothing `α` in `(0, 1]` of the contact position within one contact:
    /// `p ← α·p_new + (1 − α)·p` (1 = none); restarts after a point without contact.
    /// Default 1.
    pub smoothing: f64,
}

impl Default for ServoConfig {
    fn default() -> Self {
        ServoConfig {
            centre_mm: None,
            gain: 1.0,
            deadband_mm: 0.5,
            max_step_mm: 5.0,
            hold_gated: false,
            smoothing: 1.0,
        }
    }
}

/// A motion toward re-centring the contact.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Motion {
    /// Contact minus centre (mm).
    pub offset_mm: [f64; 2],
    /// Length of the offset (mm).
    pub distance_mm: f64,
    /// Unit vector along the offset (`[0, 0]` when the offset is zero).
    pub direction: [f64; 2],
    /// The commanded sensor motion (mm): `gain · offset`, clipped to `max_step_mm`, zero
    /// inside the deadband.
    pub motion_mm: [f64; 2],
}

/// What the servo says for one track point.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ServoAction {
    /// No contact (or a gated point): no command.
    NoContact,
    /// A motion (possibly zero inside the deadband).
    Move(Motion),
}

/// The servo's output for one [`TrackPoint`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ServoCommand {
    /// The sensor.
    pub sensor: SensorId,
    /// The track point's time.
    pub time: Timestamp,
    /// Index of the newest source frame.
    pub seq: u64,
    /// The command.
    pub action: ServoAction,
}

impl ServoCommand {
    /// The motion, if any.
    pub fn motion(&self) -> Option<&Motion> {
        match &self.action {
            ServoAction::Move(m) => Some(m),
            ServoAction::NoContact => None,
        }
    }
}

impl Timed for ServoCommand {
    fn time(&self) -> Timestamp {
        self.time
    }
}

impl HasSensor for ServoCommand {
    fn sensor(&self) -> &SensorId {
        &self.sensor
    }
}

/// The servo stage (see the [module docs](self)).
#[derive(Clone, Debug)]
#[must_use = "a stage does nothing until inputs are pushed"]
pub struct Servo {
    cfg: ServoConfig,
    centre: [f64; 2],
    smoothed: Option<[f64; 2]>,
}

impl Servo {
    /// A servo for a sensor with `layout` (whose extent centre is the default centre).
    pub fn try_new(cfg: &ServoConfig, layout: &Layout) -> Result<Self> {
        let bad = |reason: String| Err(Error::InvalidConfig { stage: STAGE, reason });
        if !(cfg.gain.is_finite() && cfg.gain > 0.0) {
            return bad(format!("`gain` = {} must be finite and > 0", cfg.gain));
        }
        crate::limits::check_mm(STAGE, "deadband_mm", cfg.deadband_mm, false)?;
        if !(cfg.smoothing > 0.0 && cfg.smoothing <= 1.0) {
            return bad(format!("`smoothing` = {} must be in (0, 1]", cfg.smoothing));
        }
        crate::limits::check_mm(STAGE, "max_step_mm", cfg.max_step_mm, true)?;
        let centre = match cfg.centre_mm {
            Some(c) if c[0].is_finite() && c[1].is_finite() => {
                crate::limits::check_coord(STAGE, "centre_mm", c)?;
                c
            }
            Some(c) => return bad(format!("`centre_mm` = {c:?} must be finite")),
            None => layout.extent().centre(),
        };
        Ok(Servo { cfg: cfg.clone(), centre, smoothed: None })
    }

    /// The point the servo keeps the contact at (mm).
    pub fn centre(&self) -> [f64; 2] {
        self.centre
    }

    /// The command for a contact at `contact` (mm).
    pub fn motion(&self, contact: [f64; 2]) -> Motion {
        let offset_mm = [contact[0] - self.centre[0], contact[1] - self.centre[1]];
        let distance_mm = offset_mm[0].hypot(offset_mm[1]);
        let direction =
            if distance_mm > 0.0 { [offset_mm[0] / distance_mm, offset_mm[1] / distance_mm] } else { [0.0, 0.0] };
        let motion_mm = if distance_mm <= self.cfg.deadband_mm {
            [0.0, 0.0]
        } else {
            let len = (self.cfg.gain * distance_mm).min(self.cfg.max_step_mm);
            [len * direction[0], len * direction[1]]
        };
        Motion { offset_mm, distance_mm, direction, motion_mm }
    }
}

impl Stage for Servo {
    type In = TrackPoint;
    type Out = ServoCommand;
    type Error = Error;

    fn push(&mut self, p: TrackPoint, out: &mut Vec<ServoCommand>) -> Result<()> {
        let usable = p.state == ContactState::Contact
            && p.x_mm.is_finite()
            && p.y_mm.is_finite()
            && (!p.gated || self.cfg.hold_gated);
        let action = if usable {
            let a = self.cfg.smoothing;
            let q = match self.smoothed {
                Some(s) => [a * p.x_mm + (1.0 - a) * s[0], a * p.y_mm + (1.0 - a) * s[1]],
                None => [p.x_mm, p.y_mm],
            };
            self.smoothed = Some(q);
            ServoAction::Move(self.motion(q))
        } else {
            if p.state != ContactState::Contact {
                self.smoothed = None;
            }
            ServoAction::NoContact
        };
        out.push(ServoCommand { sensor: p.sensor, time: p.time, seq: p.seq, action });
        Ok(())
    }

    fn reset(&mut self) {
        self.smoothed = None;
    }

    fn delay(&self) -> Delay {
        Delay::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gradtac_stream::StageExt;

    fn point(seq: u64, at: Option<[f64; 2]>, gated: bool) -> TrackPoint {
        let [x, y] = at.unwrap_or([f64::NAN, f64::NAN]);
        TrackPoint {
            sensor: "ff".into(),
            time: Timestamp(seq as i64 * 10_000_000),
            start: Timestamp(0),
            seq,
            state: if at.is_some() { ContactState::Contact } else { ContactState::NoContact },
            no_contact: None,
            track: at.map(|_| 0),
            x_mm: x,
            y_mm: y,
            area_mm2: 10.0,
            orientation_rad: 0.0,
            peak: 3.0,
            velocity_mm_s: None,
            gated,
            fit: None,
        }
    }

    #[test]
    fn offset_direction_deadband_and_clipping() {
        let l = Layout::biotac_sp();
        let c = l.extent().centre();
        let s = Servo::try_new(&ServoConfig::default(), &l).unwrap();
        assert_eq!(s.centre(), c);
        let m = s.motion([c[0] + 3.0, c[1] - 4.0]);
        assert!((m.distance_mm - 5.0).abs() < 1e-12);
        assert!((m.direction[0] - 0.6).abs() < 1e-12 && (m.direction[1] + 0.8).abs() < 1e-12);
        assert!((m.motion_mm[0] - 3.0).abs() < 1e-12 && (m.motion_mm[1] + 4.0).abs() < 1e-12);
        // inside the deadband: reported offset, zero motion
        let m = s.motion([c[0] + 0.3, c[1]]);
        assert_eq!(m.motion_mm, [0.0, 0.0]);
        assert!((m.offset_mm[0] - 0.3).abs() < 1e-12);
        // exactly at the centre: zero direction, no NaN
        assert_eq!(s.motion(c).direction, [0.0, 0.0]);
        // clipped to max_step_mm along the direction
        let cfg = ServoConfig { centre_mm: Some([0.0, 0.0]), gain: 2.0, max_step_mm: 3.0, ..Default::default() };
        let s = Servo::try_new(&cfg, &l).unwrap();
        let m = s.motion([0.0, 10.0]);
        assert_eq!(m.motion_mm, [0.0, 3.0]);
        assert_eq!(m.offset_mm, [0.0, 10.0]);
    }

    #[test]
    fn no_contact_and_gated_points_give_no_command() {
        let l = Layout::biotac_sp();
        let cfg = ServoConfig { centre_mm: Some([0.0, 0.0]), deadband_mm: 0.0, ..Default::default() };
        let mut s = Servo::try_new(&cfg, &l).unwrap();
        let out = s
            .run_all([point(0, None, false), point(1, Some([1.0, 0.0]), false), point(2, Some([1.0, 0.0]), true)])
            .unwrap();
        assert_eq!(out.len(), 3);
        assert_eq!(out[0].action, ServoAction::NoContact);
        assert_eq!(out[1].motion().unwrap().motion_mm, [1.0, 0.0]);
        assert_eq!(out[2].action, ServoAction::NoContact);
        let mut s = Servo::try_new(&ServoConfig { hold_gated: true, ..cfg }, &l).unwrap();
        assert!(s.run_all([point(2, Some([1.0, 0.0]), true)]).unwrap()[0].motion().is_some());
    }

    #[test]
    fn smoothing_filters_within_a_contact_and_restarts_after() {
        let l = Layout::biotac_sp();
        let cfg = ServoConfig { centre_mm: Some([0.0, 0.0]), deadband_mm: 0.0, smoothing: 0.5, ..Default::default() };
        let mut s = Servo::try_new(&cfg, &l).unwrap();
        let out = s
            .run_all([
                point(0, Some([2.0, 0.0]), false),
                point(1, Some([4.0, 0.0]), false),
                point(2, None, false),
                point(3, Some([4.0, 0.0]), false),
            ])
            .unwrap();
        assert_eq!(out[0].motion().unwrap().offset_mm, [2.0, 0.0]);
        assert_eq!(out[1].motion().unwrap().offset_mm, [3.0, 0.0]);
        assert_eq!(out[3].motion().unwrap().offset_mm, [4.0, 0.0]);
        assert!(Servo::try_new(&ServoConfig { smoothing: 0.0, ..Default::default() }, &l).is_err());
    }

    #[test]
    fn invalid_configuration_is_refused() {
        let l = Layout::biotac_sp();
        for cfg in [
            ServoConfig { gain: 0.0, ..Default::default() },
            ServoConfig { deadband_mm: -1.0, ..Default::default() },
            ServoConfig { max_step_mm: f64::INFINITY, ..Default::default() },
            ServoConfig { centre_mm: Some([f64::NAN, 0.0]), ..Default::default() },
        ] {
            assert!(Servo::try_new(&cfg, &l).is_err(), "{cfg:?}");
        }
        let cfg: ServoConfig = serde_json::from_str(r#"{"gain": 0.5, "centre_mm": [1.0, 2.0]}"#).unwrap();
        assert_eq!((cfg.gain, cfg.centre_mm, cfg.deadband_mm), (0.5, Some([1.0, 2.0]), 0.5));
        assert!(serde_json::from_str::<ServoConfig>(r#"{"kp": 0.5}"#).is_err());
    }
}
