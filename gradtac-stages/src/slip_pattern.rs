//! Per-finger slip evidence read from the raw frames: where the noise-calibrated,
//! baseline-relative change pattern of each finger of a two-finger grasp lies, with a contact
//! test far more sensitive than the contact locator's (the second input path of the
//! [`slip`](crate::slip) stage).
//!
//! # What it does
//! Raw [`TaxelFrame`]s of the two sensors of [`SlipConfig`] (`first`, `second`; frames of any
//! other sensor are ignored) in, one [`PatternPoint`] out per frame of those two. Per finger:
//! 1. **Calibration.** The first `pattern_calibrate_frames` frames (no contact; a grasp starts
//!    open) give each taxel's baseline `x₀ᵢ` (mean) and noise `σᵢ` of one frame
//!    ([`crate::events::noise_sigma`]: the larger of the first-difference and the
//!    line-scatter estimates). They yield points without contact.
//! 2. **Change pattern.** The mean `x̄ᵢ` of the last `pattern_window_frames` frames, and
//!    `zᵢ = (x̄ᵢ − x₀ᵢ)/σᵢ` — the change in σ of one frame, whatever the taxel's gain or sign.
//! 3. **Weights and the energy test.** `wᵢ = max(0, zᵢ² − f²)` with `f` =
//!    `pattern_floor_sigmas`: the change's energy above the noise floor, continuous in the
//!    pattern (a taxel enters the sum from 0). The frame is a **contact** when the summed
//!    energy `E = Σ wᵢ ≥ c²`, `c` = `pattern_contact_sigmas` — one taxel `c` σ above the floor,
//!    or several weaker ones together (a light touch spread between electrodes, which no
//!    taxel alone lifts above the locator's per-taxel `contact_sigmas`).
//! 4. **Position.** The weighted mean `Σ wᵢ pᵢ / Σ wᵢ` of the taxel positions `pᵢ` (mm, the
//!    layout's plane) — scale-free in the pattern: a force change that scales every change by
//!    the same factor moves it only through the floor `f` (the test below bounds it), so the
//!    point moves when the pattern **shifts** across the layout. The [`slip`](crate::slip)
//!    stage projects it on the finger's world-up vector.
//! 5. **Baseline follow.** Taxels below the floor (`|zᵢ| ≤ f`) let their baseline follow slow
//!    drift with time constant `pattern_follow_s` (0 = never), as the contact locator does
//!    (with `f` = 0 no taxel is below it: the baseline stays the calibration's).
//! 6. **Onset position** (`onset_x_mm`, `onset_y_mm`; what the slip stage's change-point fit
//!    dates the onset from, `onset_position`; the decision always reads step 4's point):
//!    - `fit` (default): the contact point of a per-frame model fit of the finger's change
//!      pattern ([`crate::fit::Fit`] with [`onset_fit_config`]: the same calibration and
//!      averaging as the pattern, contact at [`ONSET_FIT_CONTACT_SIGMAS`] σ, the raw fitted
//!      point without the locator's position memory or motion prior). NaN on frames where the
//!      fit finds no contact (the slip stage then leaves a gap in the onset history only). The
//!      energy-weighted point sticks to the strongest taxel while the contact crosses it; the
//!      fitted point follows the contact evenly (on the tuning members, given the true start
//!      shape, 29–31 / 32–34 / 35–38 ms per shape against 45 / 50 / 41 — the [`slip`](crate::slip)
//!      docs);
//!    - `energy`: step 4's point;
//!    - `linear`: the mean weighted by `max(0, |zᵢ| − f)` (in between: sticks less than the
//!      energy point, but did not date onsets better).
//!
//! # Parameters (in [`SlipConfig`], `[stages.slip]`)
//! | name | unit | default | meaning |
//! |---|---|---|---|
//! | `pattern_calibrate_frames` | frames (2–100 000) | 20 | baseline and noise at start-up / after a reset |
//! | `pattern_window_frames` | frames (1–1000) | 3 | frames averaged before comparing with the baseline |
//! | `pattern_floor_sigmas` | σ of one frame (≥ 0) | 1 | noise floor removed from each taxel's energy |
//! | `pattern_contact_sigmas` | σ of one frame (> 0) | 3 | contact when the energy above the floor reaches its square |
//! | `pattern_follow_s` | s (≥ 0) | 2 | baseline follow of taxels below the floor |
//! | `onset_position` | `fit`, `energy`, `linear` | `fit` | the point the slip stage's onset fit reads (step 6) |
//!
//! The defaults were chosen with the slip rule on tuning members of the model family (the
//! [`slip`](crate::slip) docs: protocol, search, held-out figures).
//!
//! # Delay
//! `(pattern_window_frames − 1)/2` frames: each point's `start..time` covers the frames
//! averaged; the slip stage dates it at the middle. The onset position's model fit averages the
//! same frames (the same delay) and sees no later frame: the stage is causal, one point per
//! frame at the frame's push. Start-up: `pattern_calibrate_frames` frames.
//!
//! # Units
//! Positions mm (the layout's plane), energies in σ² of one frame, times ns.
//!
//! # Cost
//! O(taxels) per frame, no allocation in steady state beyond the window's frame copy, with
//! `onset_position = "energy"` or `"linear"`. The default `fit` adds one warm-started
//! Levenberg–Marquardt fit (3 iterations on 5 parameters over the electrodes) per frame in
//! contact and a copy of the frame: measured in-process (`slip_eval`, every frame of the 500
//! held-out grasps, 327 488 frames of two fingers, one thread on a loaded 2-core machine) p50
//! 6.0 µs, p99 32 µs per frame against 0.14 µs and 0.45 µs with `energy` — the price of the
//! onset's accuracy; `energy` is the cheap setting at the previous round's onset error.
//!
//! # Trade-offs
//! | knob | lower | higher |
//! |---|---|---|
//! | `pattern_contact_sigmas` | light touches and weak fingers count; more frames of pure drift count as contact (their point wanders) | misses light grips (the locator's problem) |
//! | `pattern_floor_sigmas` | weak taxels place the point (noisier, pulled to the pad centre) | scale-dependent: force changes move the point more; fewer taxels |
//! | `pattern_window_frames` | immediate, noisier | smoother, more delay |
//! | `pattern_follow_s` | drift absorbed quickly; a still weak contact's edge fades | drift accumulates into the pattern |
//! | `onset_position` (slip) | `energy`: O(taxels) per frame; onsets of the previous round (held out 49 ms median, per shape 52 / 46 / 47 ms) | `fit` (default): a model fit per frame; held out 42 ms median, per shape 42 / 43 / 40 ms |
//!
//! # Example
//! ```
//! use gradtac_stages::slip::SlipConfig;
//! use gradtac_stages::slip_pattern::SlipPattern;
//! use gradtac_stream::{Layout, Stage, SensorId, TaxelFrame, Timestamp};
//! let layout = Layout::biotac_sp();
//! let mut s = SlipPattern::try_new(&SlipConfig::default(), [&layout, &layout])?;
//! let mut out = Vec::new();
//! for k in 0..40u64 {
//!     // noise-free rest at 2000 counts, then a press on taxel 3
//!     let mut v = vec![2000.0 + (k % 2) as f64; 24];
//!     if k >= 30 { v[3] += 50.0; }
//!     s.push(TaxelFrame::new(SensorId::new("ff"), Timestamp::at_rate(k, 100.0), k, v), &mut out)?;
//! }
//! assert!(!out[20].contact && out[39].contact);
//! assert_eq!([out[39].x_mm, out[39].y_mm], layout.positions()[3]);
//! # Ok::<(), gradtac_stages::Error>(())
//! ```

use crate::contour::ContourFrame;
use crate::fit::Fit;
use crate::locate::LocateConfig;
use crate::slip::{OnsetPosition, SlipConfig};
use crate::{Error, Result};
use gradtac_stream::{Delay, Layout, SensorId, Stage, TaxelFrame, Timed, Timestamp};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

const STAGE: &str = "slip_pattern";

/// Where one finger's change pattern lies at one frame ([`SlipPattern`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PatternPoint {
    /// The sensor.
    pub sensor: SensorId,
    /// Time of the newest frame averaged.
    pub time: Timestamp,
    /// Time of the oldest frame averaged.
    pub start: Timestamp,
    /// Index of the newest frame.
    pub seq: u64,
    /// Whether the energy test found a contact (false while calibrating).
    pub contact: bool,
    /// Energy above the floor `Σ max(0, zᵢ² − f²)` (σ² of one frame; 0 while calibrating).
    pub energy: f64,
    /// Weighted mean x of the pattern (mm; NaN without contact).
    pub x_mm: f64,
    /// Weighted mean y of the pattern (mm; NaN without contact).
    pub y_mm: f64,
    /// The position the slip stage's onset fit reads (mm; NaN without contact): with
    /// `onset_position = "energy"` the same as `x_mm`, with `"linear"` the mean weighted by the
    /// change above the floor, `max(0, |zᵢ| − f)`, with `"fit"` the model fit's contact point
    /// (NaN where the fit finds no contact) (step 6 of the [module docs](self)).
    pub onset_x_mm: f64,
    /// The onset fit's y (mm; NaN without contact), as `onset_x_mm`.
    pub onset_y_mm: f64,
}

impl Timed for PatternPoint {
    fn time(&self) -> Timestamp {
        self.time
    }
}

#[derive(Clone, Debug, Default)]
struct FingerPattern {
    calib: Vec<Vec<f64>>,
    baseline: Vec<f64>,
    sigma: Vec<f64>,
    ring: VecDeque<(Timestamp, Vec<f64>)>,
    sum: Vec<f64>,
    last: Option<(Timestamp, u64)>,
}

/// The per-finger pattern-evidence stage (see the [module docs](self)).
#[derive(Clone, Debug)]
#[must_use = "a stage does nothing until inputs are pushed"]
pub struct SlipPattern {
    sensors: [SensorId; 2],
    positions: [Vec<[f64; 2]>; 2],
    calibrate: usize,
    window: usize,
    floor2: f64,
    contact2: f64,
    follow_s: f64,
    floor: f64,
    linear_onset: bool,
    /// `onset_position = "fit"`: one model-fit stage per finger, and its output buffer.
    fits: Option<Box<[Fit; 2]>>,
    fit_out: Vec<ContourFrame>,
    fingers: [FingerPattern; 2],
}

impl SlipPattern {
    /// The stage for the two sensors of `cfg`, with their layouts (`[first, second]`); the
    /// pattern settings are validated.
    pub fn try_new(cfg: &SlipConfig, layouts: [&Layout; 2]) -> Result<Self> {
        let bad = |reason: String| Err(Error::InvalidConfig { stage: STAGE, reason });
        if cfg.first == cfg.second {
            return bad(format!("`first` and `second` are both {:?}", cfg.first));
        }
        if !(2..=100_000).contains(&cfg.pattern_calibrate_frames) {
            return bad(format!("`pattern_calibrate_frames` = {} must be in 2..=100000", cfg.pattern_calibrate_frames));
        }
        if !(1..=1000).contains(&cfg.pattern_window_frames) {
            return bad(format!("`pattern_window_frames` = {} must be in 1..=1000", cfg.pattern_window_frames));
        }
        if !(cfg.pattern_floor_sigmas.is_finite() && (0.0..=1000.0).contains(&cfg.pattern_floor_sigmas)) {
            return bad(format!("`pattern_floor_sigmas` = {} must be in [0, 1000]", cfg.pattern_floor_sigmas));
        }
        if !(cfg.pattern_contact_sigmas.is_finite()
            && cfg.pattern_contact_sigmas > 0.0
            && cfg.pattern_contact_sigmas <= 1e4)
        {
            return bad(format!("`pattern_contact_sigmas` = {} must be in (0, 10000]", cfg.pattern_contact_sigmas));
        }
        if !(cfg.pattern_follow_s.is_finite() && cfg.pattern_follow_s >= 0.0 && cfg.pattern_follow_s <= 1e6) {
            return bad(format!("`pattern_follow_s` = {} must be in [0, 1e6] s", cfg.pattern_follow_s));
        }
        for l in layouts {
            if l.is_empty() || l.len() > 65_536 {
                return bad(format!("a layout of {} taxels (want 1..=65536)", l.len()));
            }
        }
        Ok(SlipPattern {
            sensors: [SensorId::new(&cfg.first), SensorId::new(&cfg.second)],
            positions: layouts.map(|l| l.positions().to_vec()),
            calibrate: cfg.pattern_calibrate_frames as usize,
            window: cfg.pattern_window_frames as usize,
            floor2: cfg.pattern_floor_sigmas * cfg.pattern_floor_sigmas,
            contact2: cfg.pattern_contact_sigmas * cfg.pattern_contact_sigmas,
            follow_s: cfg.pattern_follow_s,
            floor: cfg.pattern_floor_sigmas,
            linear_onset: cfg.onset_position == OnsetPosition::Linear,
            fits: match cfg.onset_position {
                OnsetPosition::Fit => {
                    let lc = onset_fit_config(cfg);
                    Some(Box::new([Fit::try_new(&lc, layouts[0])?, Fit::try_new(&lc, layouts[1])?]))
                }
                _ => None,
            },
            fit_out: Vec::new(),
            fingers: Default::default(),
        })
    }

    /// Per-taxel noise σ (one frame) of finger `i` (0 = first); empty while calibrating.
    pub fn noise(&self, i: usize) -> &[f64] {
        self.fingers.get(i).map_or(&[], |f| &f.sigma)
    }

    /// [`Stage::push`] by reference: a runner that also hands the frame to the sensor's chain
    /// needs no copy of it (the averaging ring reuses its oldest buffer).
    pub fn push_frame(&mut self, frame: &TaxelFrame, out: &mut Vec<PatternPoint>) -> Result<()> {
        let Some(i) = self.sensors.iter().position(|s| *s == frame.sensor) else { return Ok(()) };
        let pos = &self.positions[i];
        let n = pos.len();
        let f = &mut self.fingers[i];
        let bad_input =
            |reason: String| Error::BadInput { stage: STAGE, sensor: frame.sensor.to_string(), seq: frame.seq, reason };
        crate::error::check_taxel_count(STAGE, &frame.sensor, frame.seq, n, frame.values.len())?;
        crate::error::check_finite(STAGE, frame)?;
        let dt = match f.last {
            Some((t, _)) if frame.time < t => {
                return Err(bad_input(format!("time {:?} is before the previous frame's {t:?}", frame.time)))
            }
            Some((t, _)) => (frame.time.0 - t.0) as f64 * 1e-9,
            None => 0.0,
        };
        f.last = Some((frame.time, frame.seq));
        // the model fit's point of this frame (`onset_position = "fit"`)
        let fitted = match self.fits.as_mut() {
            Some(fits) => {
                self.fit_out.clear();
                fits[i].push(frame.clone(), &mut self.fit_out)?;
                self.fit_out.last().and_then(|c| c.outcome.contact()).map(|c| c.peak_mm)
            }
            None => None,
        };
        if f.sum.len() != n {
            f.sum = vec![0.0; n];
        }
        for (s, v) in f.sum.iter_mut().zip(&frame.values) {
            *s += v;
        }
        // the ring holds the last `window` frames: the oldest leaves the sum, its buffer
        // takes the new frame's values
        let mut buf = match f.ring.len() >= self.window {
            true => f.ring.pop_front().map(|(_, old)| {
                for (s, v) in f.sum.iter_mut().zip(&old) {
                    *s -= v;
                }
                old
            }),
            false => None,
        }
        .unwrap_or_default();
        buf.clear();
        buf.extend_from_slice(&frame.values);
        f.ring.push_back((frame.time, buf));
        // a running sum drifts by rounding over millions of frames: recompute now and then
        if frame.seq % 4096 == 0 {
            for (k, s) in f.sum.iter_mut().enumerate() {
                *s = f.ring.iter().map(|r| r.1[k]).sum();
            }
        }
        let start = f.ring.front().map_or(frame.time, |r| r.0);
        let mut p = PatternPoint {
            sensor: frame.sensor.clone(),
            time: frame.time,
            start,
            seq: frame.seq,
            contact: false,
            energy: 0.0,
            x_mm: f64::NAN,
            y_mm: f64::NAN,
            onset_x_mm: f64::NAN,
            onset_y_mm: f64::NAN,
        };
        if f.baseline.is_empty() {
            f.calib.push(frame.values.clone());
            if f.calib.len() >= self.calibrate {
                // the contact locator's calibration; σ also kept from 0 (z divides by it)
                (f.baseline, f.sigma) = crate::locate::baseline_and_noise(&f.calib, n);
                f.sigma.iter_mut().for_each(|s| *s = s.max(1e-12));
                f.calib = Vec::new();
            }
            out.push(p);
            return Ok(());
        }
        let k = f.ring.len() as f64;
        let beta = if self.follow_s > 0.0 { 1.0 - (-dt / self.follow_s).exp() } else { 0.0 };
        let (mut e, mut mx, mut my) = (0.0, 0.0, 0.0);
        let (mut l, mut lx, mut ly) = (0.0, 0.0, 0.0);
        for ((sum, base), (sigma, at)) in f.sum.iter().zip(f.baseline.iter_mut()).zip(f.sigma.iter().zip(pos)) {
            let mean = sum / k;
            let z = (mean - *base) / sigma;
            let w = (z * z - self.floor2).max(0.0);
            if w == 0.0 {
                *base += beta * (mean - *base);
            }
            e += w;
            mx += w * at[0];
            my += w * at[1];
            if self.linear_onset {
                let v = (z.abs() - self.floor).max(0.0);
                l += v;
                lx += v * at[0];
                ly += v * at[1];
            }
        }
        p.energy = e;
        if e >= self.contact2 && e > 0.0 && e.is_finite() {
            p.contact = true;
            p.x_mm = mx / e;
            p.y_mm = my / e;
            // every taxel with energy above the floor has |z| above it: l > 0 here
            (p.onset_x_mm, p.onset_y_mm) = match (self.linear_onset, self.fits.is_some()) {
                (true, _) if l > 0.0 && l.is_finite() => (lx / l, ly / l),
                (_, true) => fitted.map_or((f64::NAN, f64::NAN), |q| (q[0], q[1])),
                _ => (p.x_mm, p.y_mm),
            };
        }
        out.push(p);
        Ok(())
    }
}

/// The contact test of the model fit behind `onset_position = "fit"` (σ of one frame on the
/// largest electrode change): chosen on the tuning members from {10 (the locator's default), 6,
/// 4} (the [`slip`](crate::slip) docs) — a lower test fits light grips too.
pub const ONSET_FIT_CONTACT_SIGMAS: f64 = 4.0;

/// The model fit behind `onset_position = "fit"`: the locator's defaults (magnitudes, 3
/// iterations per frame warm-started, unit gains, the BioTac SP's rails) with the pattern's
/// calibration and averaging, so its point describes the same frames as the pattern's, and a
/// contact test of [`ONSET_FIT_CONTACT_SIGMAS`], and the fluid lag estimated and undone when
/// `onset_fit_lag` is set. Its position memory and motion prior are not read (the raw fitted
/// point is).
pub fn onset_fit_config(cfg: &SlipConfig) -> LocateConfig {
    LocateConfig {
        calibrate_frames: cfg.pattern_calibrate_frames,
        window_frames: cfg.pattern_window_frames,
        contact_sigmas: ONSET_FIT_CONTACT_SIGMAS,
        fit_lag_estimate: cfg.onset_fit_lag,
        ..Default::default()
    }
}

impl Stage for SlipPattern {
    type In = TaxelFrame;
    type Out = PatternPoint;
    type Error = Error;

    fn push(&mut self, frame: TaxelFrame, out: &mut Vec<PatternPoint>) -> Result<()> {
        self.push_frame(&frame, out)
    }

    fn reset(&mut self) {
        self.fingers = Default::default();
        if let Some(fits) = self.fits.as_mut() {
            fits.iter_mut().for_each(Stage::reset);
        }
    }

    fn delay(&self) -> Delay {
        Delay::frames(((self.window - 1) / 2) as u64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gradtac_stream::StageExt;

    /// A Gaussian bump of `amp` counts centred at `c` over the layout, on 2000 counts with
    /// deterministic ±1 count noise.
    fn frame(sensor: &str, k: u64, layout: &Layout, c: Option<[f64; 2]>, amp: f64) -> TaxelFrame {
        let v = layout
            .positions()
            .iter()
            .enumerate()
            .map(|(j, p)| {
                let noise = if (k * 7 + j as u64 * 3) % 5 < 2 { 1.0 } else { -1.0 };
                let bump = c.map_or(0.0, |c| amp * (-((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2)) / 18.0).exp());
                2000.0 + noise + bump
            })
            .collect();
        TaxelFrame::new(SensorId::new(sensor), Timestamp::at_rate(k, 100.0), k, v)
    }

    fn stage() -> SlipPattern {
        let l = Layout::biotac_sp();
        SlipPattern::try_new(&SlipConfig::default(), [&l, &l]).unwrap()
    }

    #[test]
    fn a_shifted_pattern_moves_the_point_by_the_shift_along_up() {
        // a wide pattern (σ 3 mm) away from the layout's edge; the weighted mean follows a
        // shift of the whole pattern by the same amount where the taxels sample it densely
        // enough — checked against the same mean of the noise-free pattern
        let l = Layout::biotac_sp();
        let c0 = [0.0, 0.0];
        let mut s = stage();
        let mut pts = Vec::new();
        for k in 0..60 {
            s.push(frame("ff", k, &l, (k >= 25).then_some(c0), 400.0), &mut pts).unwrap();
        }
        let before = pts.last().unwrap().clone();
        for k in 60..120 {
            s.push(frame("ff", k, &l, Some([c0[0], c0[1] + 1.5]), 400.0), &mut pts).unwrap();
        }
        let after = pts.last().unwrap();
        assert!(before.contact && after.contact);
        let ideal = |c: [f64; 2], axis: usize| {
            let w: Vec<f64> =
                l.positions().iter().map(|p| (-((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2)) / 18.0).exp()).collect();
            let w: Vec<f64> = w.iter().map(|w| (w * 400.0).powi(2)).collect();
            let sw: f64 = w.iter().sum();
            l.positions().iter().zip(&w).map(|(p, w)| w * p[axis]).sum::<f64>() / sw
        };
        let moved = |axis: usize| ideal([c0[0], c0[1] + 1.5], axis) - ideal(c0, axis);
        let (want, got) = (moved(1), after.y_mm - before.y_mm);
        assert!(want > 0.5, "the layout samples the shift: {want}");
        assert!((got - want).abs() < 0.05 * want, "moved {got} mm along up, the pattern's mean moved {want}");
        let (want_x, got_x) = (moved(0), after.x_mm - before.x_mm);
        assert!((got_x - want_x).abs() < 0.05, "across: {got_x} against {want_x}");
        // a still pattern then: no motion
        let mut still = Vec::new();
        for k in 120..200 {
            s.push(frame("ff", k, &l, Some([c0[0], c0[1] + 1.5]), 400.0), &mut still).unwrap();
        }
        assert!(still.iter().all(|p| (p.y_mm - after.y_mm).abs() < 0.01));
    }

    #[test]
    fn a_still_pattern_with_gain_drift_does_not_move() {
        // the force (every taxel's change) drifts by ±30 %: the point stays within 0.05 mm
        let l = Layout::biotac_sp();
        let mut s = stage();
        let mut pts = Vec::new();
        for k in 0..300u64 {
            let gain = 1.0 + 0.3 * (k as f64 * 0.05).sin();
            s.push(frame("th", k, &l, (k >= 25).then_some([1.0, -2.0]), 300.0 * gain), &mut pts).unwrap();
        }
        let ys: Vec<f64> = pts[40..].iter().map(|p| p.y_mm).collect();
        assert!(pts[40..].iter().all(|p| p.contact));
        let (lo, hi) = ys.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, &y| (a.0.min(y), a.1.max(y)));
        assert!(hi - lo < 0.05, "wandered {} mm", hi - lo);
        // and pure noise is no contact
        let mut s = stage();
        let quiet = s.run_all((0..200).map(|k| frame("th", k, &l, None, 0.0))).unwrap();
        assert!(quiet.iter().all(|p| !p.contact && p.x_mm.is_nan()));
    }

    #[test]
    fn the_energy_test_finds_a_touch_below_any_single_taxel_threshold() {
        // a light, wide touch: no taxel reaches 10 σ (σ = 1 count), the sum does
        let l = Layout::biotac_sp();
        let mut s = stage();
        let pts = s.run_all((0..60).map(|k| frame("ff", k, &l, (k >= 25).then_some([0.0, 0.0]), 10.0))).unwrap();
        let sigma = s.noise(0).iter().copied().fold(f64::INFINITY, f64::min);
        assert!(10.0 < 10.0 * sigma, "no taxel changes by 10 σ (σ ≥ {sigma})");
        assert!(pts[59].contact, "energy {}", pts[59].energy);
    }

    #[test]
    fn chunking_reset_and_other_sensors() {
        let l = Layout::biotac_sp();
        let input: Vec<TaxelFrame> = (0..150u64)
            .flat_map(|k| {
                let c = (k >= 30).then_some([0.0, (k as f64 - 60.0).max(0.0) * 0.05]);
                [frame("th", k, &l, c, 200.0), frame("mf", k, &l, c, 200.0), frame("ff", k, &l, c, 100.0)]
            })
            .collect();
        // NaN ≠ NaN: compare the printed points
        let show = |v: &[PatternPoint]| format!("{v:?}");
        let all = stage().run_all(input.clone()).unwrap();
        assert_eq!(all.len(), 300, "mf is ignored");
        let mut s = stage();
        let again = s.run_all(input.clone()).unwrap();
        assert_eq!(show(&again), show(&all));
        assert!(all.iter().any(|p| p.contact) && all.iter().any(|p| !p.contact));
        s.reset();
        assert_eq!(show(&s.run_all(input.clone()).unwrap()), show(&all), "reset starts afresh");
        proptest::proptest!(|(cut in 1usize..100)| {
            let mut s = stage();
            let mut out = crate::test_util::push_in_chunks(&input, cut, |f, part| s.push(f.clone(), part));
            s.finish(&mut out).unwrap();
            proptest::prop_assert_eq!(show(&out), show(&all));
        });
    }

    #[test]
    fn every_onset_position_follows_a_shift_and_the_decision_point_is_the_same() {
        // a wide pattern moves 1.5 mm along y: each onset position moves the same way by about
        // the shift; the decision's point (x_mm, y_mm) does not depend on the onset setting
        let l = Layout::biotac_sp();
        let frames: Vec<TaxelFrame> = (0..160u64)
            .map(|k| {
                let c = match k {
                    0..25 => None,
                    25..80 => Some([0.0, 0.0]),
                    _ => Some([0.0, 1.5]),
                };
                frame("ff", k, &l, c, 400.0)
            })
            .collect();
        let run = |onset_position| {
            let cfg = SlipConfig { onset_position, ..Default::default() };
            SlipPattern::try_new(&cfg, [&l, &l]).unwrap().run_all(frames.clone()).unwrap()
        };
        let energy = run(OnsetPosition::Energy);
        for p in &energy {
            assert!(p.onset_x_mm.to_bits() == p.x_mm.to_bits() && p.onset_y_mm.to_bits() == p.y_mm.to_bits());
        }
        for pos in [OnsetPosition::Linear, OnsetPosition::Fit] {
            let pts = run(pos);
            for (a, b) in pts.iter().zip(&energy) {
                assert_eq!(
                    format!("{:?}", (a.contact, a.energy, a.x_mm, a.y_mm)),
                    format!("{:?}", (b.contact, b.energy, b.x_mm, b.y_mm))
                );
            }
            let (before, after) = (&pts[75], &pts[155]);
            assert!(before.contact && after.contact && before.onset_y_mm.is_finite() && after.onset_y_mm.is_finite());
            let moved = after.onset_y_mm - before.onset_y_mm;
            assert!((1.0..=2.0).contains(&moved), "{pos:?}: moved {moved} mm for a 1.5 mm shift");
            assert!(
                (after.onset_x_mm - before.onset_x_mm).abs() < 0.3,
                "{pos:?}: across {}",
                after.onset_x_mm - before.onset_x_mm
            );
            // still: the point holds (the fit's warm start and noise: within 0.1 mm)
            let still: Vec<f64> = pts[100..160].iter().map(|p| p.onset_y_mm).collect();
            let (lo, hi) = still.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, &y| (a.0.min(y), a.1.max(y)));
            assert!(hi - lo < 0.1, "{pos:?}: wandered {} mm", hi - lo);
            // no contact: no position
            assert!(pts[..25].iter().all(|p| p.onset_x_mm.is_nan() && p.onset_y_mm.is_nan()));
        }
        // the moved energy point is what the decision reads, and it moved too
        assert!(energy[155].y_mm - energy[75].y_mm > 0.5);
    }

    #[test]
    fn bad_config_and_input() {
        let l = Layout::biotac_sp();
        for cfg in [
            SlipConfig { pattern_calibrate_frames: 1, ..Default::default() },
            SlipConfig { pattern_window_frames: 0, ..Default::default() },
            SlipConfig { pattern_floor_sigmas: -1.0, ..Default::default() },
            SlipConfig { pattern_contact_sigmas: 0.0, ..Default::default() },
            SlipConfig { pattern_follow_s: f64::NAN, ..Default::default() },
            SlipConfig { second: "ff".into(), ..Default::default() },
        ] {
            assert!(SlipPattern::try_new(&cfg, [&l, &l]).is_err(), "{cfg:?}");
        }
        let mut s = stage();
        let mut out = Vec::new();
        let short = TaxelFrame::new(SensorId::new("ff"), Timestamp(0), 0, vec![1.0; 3]);
        assert!(matches!(s.push(short, &mut out), Err(Error::TaxelCount { stage: STAGE, .. })));
        s.push(frame("ff", 5, &l, None, 0.0), &mut out).unwrap();
        let e = s.push(frame("ff", 4, &l, None, 0.0), &mut out).unwrap_err();
        assert!(matches!(e, Error::BadInput { stage: STAGE, .. }), "{e}");
        let mut nan = frame("ff", 6, &l, None, 0.0);
        nan.values[2] = f64::NAN;
        assert!(matches!(s.push(nan, &mut out), Err(Error::BadValue { taxel: 2, .. })));
    }
}
