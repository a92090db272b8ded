//! Track: per-sensor contact trajectory from the maximal contours (method.md, stage 7).
//!
//! # What it does
//! Turns each [`ContourFrame`] into a [`TrackPoint`]: the contact's position (the maximal
//! contour's centroid), area, orientation and peak, its state ([`ContactState`]), the id of
//! the track it belongs to, and its velocity. "No contact" is data — a point with
//! `state = NoContact`, NaN geometry and the reason — never an error.
//!
//! - **Tracks.** A contact after no contact starts a new track (ids count from 0 per stage
//!   instance). Up to `release_frames − 1` consecutive no-contact frames inside a track are
//!   bridged: the next contact continues the same track.
//! - **Jump gating.** A contact farther than `max_jump_mm` from the track's last accepted
//!   position is a jump (a spurious peak, or a second contact taking over). With
//!   `gate = "hold"` the point repeats the last accepted geometry and is flagged `gated`;
//!   after `max_gated_frames` consecutive gated frames the track restarts at the new position.
//!   With `gate = "restart"` a jump immediately starts a new track.
//! - **Velocity** (mm/s): the displacement between consecutive accepted points of a track over
//!   their time difference, exponentially smoothed with `velocity_alpha` (1 = raw).
//!   `None` on a track's first point.
//!
//! # Example: events to contact track
//! ```
//! use gradtac_stages::contour::{Contour, ContourConfig};
//! use gradtac_stages::interpolate::{Interpolate, InterpolateConfig};
//! use gradtac_stages::track::{ContactState, Track, TrackConfig};
//! use gradtac_stages::window::{Window, WindowConfig};
//! use gradtac_stages::{EventBatch, TactileEvent};
//! use gradtac_stream::{Layout, StageExt, Timestamp};
//!
//! let layout = Layout::biotac_sp();
//! let mut chain = Window::try_new(&WindowConfig::default())?
//!     .then(Interpolate::try_new(&InterpolateConfig::default(), &layout)?)
//!     .then(Contour::try_new(&ContourConfig::default())?)
//!     .then(Track::try_new(&TrackConfig::default())?);
//! // three frames of events on electrode 24 (index 23, mid-pad), 10 ms apart
//! let batches = (0..3u64).map(|k| EventBatch {
//!     sensor: "ff".into(),
//!     time: Timestamp((k as i64 + 1) * 10_000_000),
//!     seq: k,
//!     taxels: 24,
//!     events: vec![TactileEvent { time: Timestamp(k as i64 * 10_000_000 + 5), taxel: 23, polarity: 1 }; 2],
//! });
//! let track = chain.run_all(batches)?;
//! assert_eq!(track.len(), 3);
//! assert_eq!(track[2].state, ContactState::Contact);
//! let e24 = layout.positions()[23];
//! assert!((track[2].x_mm - e24[0]).hypot(track[2].y_mm - e24[1]) < 1.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Units
//! Positions mm, areas mm², angles rad, velocities mm/s, times ns.
//!
//! # Delay
//! None.
//!
//! # Trade-offs
//! | option | lower | higher |
//! |---|---|---|
//! | `max_jump_mm` | rejects fast real motion | lets spurious peaks through |
//! | `velocity_alpha` | smoother, lagging velocity | noisy, immediate velocity |
//! | `release_frames` | tracks split at dropouts | separate touches merge into one track |

use crate::contour::{ContourFrame, ContourOutcome, NoContact};
use crate::{Error, Result};
use gradtac_stream::{Delay, HasSensor, SensorId, Stage, Timed, Timestamp};
use serde::{Deserialize, Serialize};

const STAGE: &str = "track";

/// What the tracker does with a jump.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Gate {
    /// Repeat the last accepted point (flagged `gated`) for up to `max_gated_frames` frames.
    #[default]
    Hold,
    /// Start a new track at the new position.
    Restart,
}

/// Configuration of the [`Track`] stage (`[stages.track]` in a scene).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrackConfig {
    /// Largest accepted displacement (mm) between consecutive points of a track; `None` = no
    /// gating. Default 6 mm (a quarter of a BioTac SP's width).
    pub max_jump_mm: Option<f64>,
    /// What a jump does. Default `hold`.
    pub gate: Gate,
    /// With `gate = "hold"`: after this many consecutive gated frames (≥ 1) the track restarts
    /// at the new position. Default 3.
    pub max_gated_frames: u32,
    /// A track ends after this many consecutive no-contact frames (≥ 1). Default 1.
    pub release_frames: u32,
    /// Velocity smoothing `α` in `(0, 1]`: `v ← α·v_raw + (1 − α)·v`. Default 1 (raw).
    pub velocity_alpha: f64,
}

impl Default for TrackConfig {
    fn default() -> Self {
        TrackConfig {
            max_jump_mm: Some(6.0),
            gate: Gate::Hold,
            max_gated_frames: 3,
            release_frames: 1,
            velocity_alpha: 1.0,
        }
    }
}

/// Contact or not.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactState {
    /// A maximal contour was found.
    Contact,
    /// None was; see [`TrackPoint::no_contact`].
    NoContact,
}

/// One point of a sensor's contact track.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrackPoint {
    /// The sensor.
    pub sensor: SensorId,
    /// The time the point describes: the end of the surface's span.
    pub time: Timestamp,
    /// Start of the surface's span (the window's start).
    pub start: Timestamp,
    /// Index of the newest source frame.
    pub seq: u64,
    /// Contact or not.
    pub state: ContactState,
    /// Why there is no contact (with `state = NoContact`).
    pub no_contact: Option<NoContact>,
    /// The track the point belongs to (`None` without contact).
    pub track: Option<u64>,
    /// Contact location x (mm); NaN without contact.
    pub x_mm: f64,
    /// Contact location y (mm); NaN without contact.
    pub y_mm: f64,
    /// Maximal-contour area (mm²); NaN without contact.
    pub area_mm2: f64,
    /// Principal-axis orientation (rad); NaN without contact.
    pub orientation_rad: f64,
    /// Surface peak (surface units); NaN without contact.
    pub peak: f64,
    /// Velocity (mm/s) along x and y; `None` on a track's first point and without contact.
    pub velocity_mm_s: Option<[f64; 2]>,
    /// True when the point repeats the last accepted one because the contour jumped.
    pub gated: bool,
    /// The model fit's amplitude, spread, residual and position uncertainty
    /// (`[stages.locate] method = "fit"`); `None` for the other methods and without contact.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit: Option<crate::fit::FitSummary>,
}

impl Timed for TrackPoint {
    fn time(&self) -> Timestamp {
        self.time
    }
}

impl HasSensor for TrackPoint {
    fn sensor(&self) -> &SensorId {
        &self.sensor
    }
}

#[derive(Clone, Copy, Debug)]
struct Accepted {
    time: Timestamp,
    x: f64,
    y: f64,
    area: f64,
    orientation: f64,
    peak: f64,
    velocity: Option<[f64; 2]>,
    fit: Option<crate::fit::FitSummary>,
}

/// The tracker stage (see the [module docs](self)). One instance per sensor.
#[derive(Clone, Debug)]
#[must_use = "a stage does nothing until inputs are pushed"]
pub struct Track {
    cfg: TrackConfig,
    next_id: u64,
    track: Option<u64>,
    last: Option<Accepted>,
    misses: u32,
    gated: u32,
    last_time: Option<Timestamp>,
}

impl Track {
    /// A tracker from its configuration (validated).
    pub fn try_new(cfg: &TrackConfig) -> Result<Self> {
        let bad = |reason: String| Err(Error::InvalidConfig { stage: STAGE, reason });
        if let Some(j) = cfg.max_jump_mm {
            crate::limits::check_mm(STAGE, "max_jump_mm", j, true)?;
        }
        let most = u64::from(crate::limits::MAX_TRACK_FRAMES);
        crate::limits::check_count(STAGE, "max_gated_frames", cfg.max_gated_frames.into(), most)?;
        crate::limits::check_count(STAGE, "release_frames", cfg.release_frames.into(), most)?;
        if cfg.max_gated_frames == 0 {
            return bad("`max_gated_frames` must be ≥ 1".into());
        }
        if cfg.release_frames == 0 {
            return bad("`release_frames` must be ≥ 1".into());
        }
        if !(cfg.velocity_alpha > 0.0 && cfg.velocity_alpha <= 1.0) {
            return bad(format!("`velocity_alpha` = {} must be in (0, 1]", cfg.velocity_alpha));
        }
        Ok(Track { cfg: cfg.clone(), next_id: 0, track: None, last: None, misses: 0, gated: 0, last_time: None })
    }

    fn start_track(&mut self) -> u64 {
        let id = self.next_id;
        self.next_id += 1;
        self.track = Some(id);
        self.gated = 0;
        id
    }
}

impl Stage for Track {
    type In = ContourFrame;
    type Out = TrackPoint;
    type Error = Error;

    fn push(&mut self, f: ContourFrame, out: &mut Vec<TrackPoint>) -> Result<()> {
        if let Some(t) = self.last_time {
            if f.end < t {
                return Err(Error::BadInput {
                    stage: STAGE,
                    sensor: f.sensor.to_string(),
                    seq: f.seq,
                    reason: format!("time {:?} is before the previous point's {t:?}", f.end),
                });
            }
        }
        self.last_time = Some(f.end);
        let mut p = TrackPoint {
            sensor: f.sensor,
            time: f.end,
            start: f.start,
            seq: f.seq,
            state: ContactState::NoContact,
            no_contact: None,
            track: None,
            x_mm: f64::NAN,
            y_mm: f64::NAN,
            area_mm2: f64::NAN,
            orientation_rad: f64::NAN,
            peak: f64::NAN,
            velocity_mm_s: None,
            gated: false,
            fit: None,
        };
        match f.outcome {
            ContourOutcome::NoContact(reason) => {
                p.no_contact = Some(reason);
                self.misses += 1;
                if self.misses >= self.cfg.release_frames {
                    self.track = None;
                    self.last = None;
                    self.gated = 0;
                }
            }
            ContourOutcome::Contact(c) => {
                self.misses = 0;
                p.state = ContactState::Contact;
                let [x, y] = c.centroid_mm;
                let mut new = Accepted {
                    time: f.end,
                    x,
                    y,
                    area: c.area_mm2,
                    orientation: c.orientation_rad,
                    peak: c.peak,
                    velocity: None,
                    fit: c.fit,
                };
                let mut accept = true;
                match (self.track, self.last) {
                    (Some(_), Some(prev)) => {
                        let d = (x - prev.x).hypot(y - prev.y);
                        let jump = self.cfg.max_jump_mm.is_some_and(|j| d > j);
                        if jump && self.cfg.gate == Gate::Hold && self.gated < self.cfg.max_gated_frames {
                            self.gated += 1;
                            accept = false;
                            p.gated = true;
                            new = prev;
                        } else if jump {
                            self.start_track();
                        } else {
                            self.gated = 0;
                            let dt = (f.end - prev.time) as f64 * 1e-9;
                            if dt > 0.0 {
                                let raw = [(x - prev.x) / dt, (y - prev.y) / dt];
                                let a = self.cfg.velocity_alpha;
                                new.velocity = Some(match prev.velocity {
                                    Some(v) => [a * raw[0] + (1.0 - a) * v[0], a * raw[1] + (1.0 - a) * v[1]],
                                    None => raw,
                                });
                            } else {
                                new.velocity = prev.velocity;
                            }
                        }
                    }
                    _ => {
                        self.start_track();
                    }
                }
                if accept {
                    self.last = Some(new);
                }
                p.track = self.track;
                p.x_mm = new.x;
                p.y_mm = new.y;
                p.area_mm2 = new.area;
                p.orientation_rad = new.orientation;
                p.peak = new.peak;
                p.velocity_mm_s = new.velocity;
                p.fit = new.fit;
            }
        }
        out.push(p);
        Ok(())
    }

    fn reset(&mut self) {
        self.track = None;
        self.last = None;
        self.misses = 0;
        self.gated = 0;
        self.last_time = None;
    }

    fn delay(&self) -> Delay {
        Delay::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contour::MaxContour;
    use gradtac_stream::StageExt;

    fn frame(t: i64, at: Option<[f64; 2]>) -> ContourFrame {
        let outcome = match at {
            None => ContourOutcome::NoContact(NoContact::BelowMinPeak),
            Some(c) => ContourOutcome::Contact(MaxContour {
                level: 1.0,
                polygon: vec![],
                holes: vec![],
                area_mm2: 2.0,
                centroid_mm: c,
                orientation_rad: 0.0,
                eccentricity: 0.0,
                peak: 3.0,
                peak_mm: c,
                clipped: false,
                fit: None,
            }),
        };
        ContourFrame { sensor: "th".into(), start: Timestamp(t), end: Timestamp(t), seq: t as u64, outcome }
    }

    #[test]
    fn velocity_tracks_and_no_contact() {
        let mut tr = Track::try_new(&TrackConfig::default()).unwrap();
        let ms = 1_000_000;
        let pts = tr
            .run_all([
                frame(0, Some([0.0, 0.0])),
                frame(10 * ms, Some([1.0, 0.5])),
                frame(20 * ms, None),
                frame(30 * ms, Some([1.0, 0.5])),
            ])
            .unwrap();
        assert_eq!(pts[0].track, Some(0));
        assert_eq!(pts[0].velocity_mm_s, None);
        let v = pts[1].velocity_mm_s.unwrap();
        assert!((v[0] - 100.0).abs() < 1e-9 && (v[1] - 50.0).abs() < 1e-9, "{v:?}");
        assert_eq!(pts[2].state, ContactState::NoContact);
        assert!(pts[2].x_mm.is_nan());
        assert_eq!(pts[2].no_contact, Some(NoContact::BelowMinPeak));
        assert_eq!(pts[3].track, Some(1)); // release_frames = 1: a new track
    }

    #[test]
    fn jump_is_held_then_restarts() {
        let cfg = TrackConfig { max_jump_mm: Some(2.0), max_gated_frames: 2, ..Default::default() };
        let mut tr = Track::try_new(&cfg).unwrap();
        let pts = tr
            .run_all([
                frame(0, Some([0.0, 0.0])),
                frame(1, Some([5.0, 0.0])),
                frame(2, Some([5.0, 0.0])),
                frame(3, Some([5.0, 0.0])),
                frame(4, Some([5.5, 0.0])),
            ])
            .unwrap();
        assert!(pts[1].gated && pts[2].gated && !pts[3].gated);
        assert_eq!((pts[1].x_mm, pts[2].x_mm), (0.0, 0.0));
        assert_eq!(pts[3].track, Some(1));
        assert_eq!(pts[3].x_mm, 5.0);
        assert_eq!(pts[4].track, Some(1));
        let restart = TrackConfig { max_jump_mm: Some(2.0), gate: Gate::Restart, ..Default::default() };
        let mut tr = Track::try_new(&restart).unwrap();
        let pts = tr.run_all([frame(0, Some([0.0, 0.0])), frame(1, Some([5.0, 0.0]))]).unwrap();
        assert_eq!(pts[1].track, Some(1));
        assert!(Track::try_new(&TrackConfig { velocity_alpha: 0.0, ..Default::default() }).is_err());
    }
}
