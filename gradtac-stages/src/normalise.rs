//! Per-taxel min–max normalisation (method.md, stage 1).
//!
//! Every taxel `i` is mapped by `yᵢ = (xᵢ − minᵢ) / spanᵢ` with
//! `spanᵢ = max(maxᵢ − minᵢ, min_span)`, so a taxel's calibrated range lands on `[0, 1]`.
//!
//! | bounds ([`Bounds`]) | where min/max come from | delay | trade-off |
//! |---|---|---|---|
//! | `calibrate` (default, 20 frames) | the first N frames of the stream (and again after a [`reset`](Stage::reset)) | N frames once, at start-up; then none | one fixed scale: comparable over a recording; later values may leave `[0, 1]` |
//! | `given` | numbers from the user (a calibration file) | none | reproducible across recordings; needs a prior calibration |
//! | `running` | every frame so far, including the current one | none | always within `[0, 1]`, but the scale drifts as new extremes arrive |
//!
//! **Units:** input in sensor units (raw counts); output dimensionless.
//!
//! **A constant taxel** (`max == min`) never divides by zero: the span is floored at
//! `min_span` (default 1.0 input unit — one count of a 12-bit ADC), so it maps to
//! `(x − min) / min_span`, i.e. 0 while it stays constant. The division is done as a
//! division (not a multiplication by a reciprocal), so outputs equal `(x − min) / span`
//! exactly as IEEE 754 rounds it.
//!
//! **Bad input:** a non-finite value is an error naming sensor, frame index and taxel.
//! `clamp = true` clips the output to `[0, 1]`. `bypass = true` passes frames through
//! unchanged (log-change events are scale-free, so they may act on raw counts directly).

use crate::{Error, Result};
use gradtac_stream::{Delay, Stage, TaxelFrame};
use serde::{Deserialize, Serialize};

const STAGE: &str = "normalise";

/// Where the normalisation bounds come from (see the [module docs](self)).
#[derive(Clone, Debug, PartialEq)]
pub enum Bounds {
    /// min/max of the first `frames` frames (≥ 1); those frames are held back and emitted
    /// once the bounds are known.
    Calibrate {
        /// Number of calibration frames.
        frames: usize,
    },
    /// Fixed per-taxel bounds.
    Given {
        /// Per-taxel minimum.
        min: Vec<f64>,
        /// Per-taxel maximum (≥ min).
        max: Vec<f64>,
    },
    /// min/max over every frame so far.
    Running,
}

/// Scene / builder configuration of [`Normalise`]. Exactly one of `calibrate_frames`,
/// `min`+`max`, `running = true` may be given; none means `calibrate_frames = 20`.
///
/// ```toml
/// [stages.normalise]
/// calibrate_frames = 20   # or: min = [...], max = [...]   or: running = true
/// min_span = 1.0          # counts; floor of max − min
/// clamp = false
/// ```
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NormaliseConfig {
    /// Calibrate on the first N frames.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibrate_frames: Option<usize>,
    /// Given per-taxel minima (input units); requires `max`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min: Option<Vec<f64>>,
    /// Given per-taxel maxima (input units); requires `min`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max: Option<Vec<f64>>,
    /// Running bounds.
    #[serde(default)]
    pub running: bool,
    /// Smallest span (input units, > 0); default 1.0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_span: Option<f64>,
    /// Clip outputs to `[0, 1]`; default false.
    #[serde(default)]
    pub clamp: bool,
    /// Pass frames through unchanged (still checking taxel count and finiteness): for
    /// pipelines whose events act on the log of raw counts. Default false.
    #[serde(default)]
    pub bypass: bool,
}

/// Default number of calibration frames.
pub const DEFAULT_CALIBRATE_FRAMES: usize = 20;

impl NormaliseConfig {
    /// The bounds this configuration selects, validated for `taxels` taxels.
    pub fn bounds(&self, taxels: usize) -> Result<Bounds> {
        let bad = |reason: String| Error::InvalidConfig { stage: STAGE, reason };
        let given = self.min.is_some() || self.max.is_some();
        let chosen = usize::from(self.calibrate_frames.is_some()) + usize::from(given) + usize::from(self.running);
        if chosen > 1 {
            return Err(bad("choose one of calibrate_frames, min/max, running".into()));
        }
        if given {
            let (Some(min), Some(max)) = (&self.min, &self.max) else {
                return Err(bad("min and max must be given together".into()));
            };
            return Ok(Bounds::Given { min: min.clone(), max: max.clone() });
        }
        if self.running {
            return Ok(Bounds::Running);
        }
        let _ = taxels;
        Ok(Bounds::Calibrate { frames: self.calibrate_frames.unwrap_or(DEFAULT_CALIBRATE_FRAMES) })
    }
}

/// The normalisation stage (see the [module docs](self)).
#[derive(Clone, Debug)]
pub struct Normalise {
    taxels: usize,
    bounds: Bounds,
    min_span: f64,
    clamp: bool,
    bypass: bool,
    lo: Vec<f64>,
    hi: Vec<f64>,
    /// True once `lo`/`hi` hold usable bounds.
    ready: bool,
    held: Vec<TaxelFrame>,
}

impl Normalise {
    /// A stage for frames of `taxels` values, validating the configuration.
    pub fn try_new(taxels: usize, config: &NormaliseConfig) -> Result<Self> {
        let bad = |reason: String| Error::InvalidConfig { stage: STAGE, reason };
        let bounds = config.bounds(taxels)?;
        let min_span = config.min_span.unwrap_or(1.0);
        if !(min_span > 0.0 && min_span.is_finite()) {
            return Err(bad(format!("min_span must be finite and > 0, got {}", gradtac_stream::num::Short(min_span))));
        }
        if taxels == 0 {
            return Err(bad("a frame needs at least one taxel".into()));
        }
        let (mut lo, mut hi, mut ready) = (vec![f64::INFINITY; taxels], vec![f64::NEG_INFINITY; taxels], false);
        match &bounds {
            Bounds::Calibrate { frames: 0 } => return Err(bad("calibrate_frames must be ≥ 1".into())),
            Bounds::Given { min, max } => {
                if min.len() != taxels || max.len() != taxels {
                    return Err(bad(format!("min has {} and max {} values for {taxels} taxels", min.len(), max.len())));
                }
                for (i, (a, b)) in min.iter().zip(max).enumerate() {
                    if !(a.is_finite() && b.is_finite() && a <= b) {
                        return Err(bad(format!("taxel {i}: bounds [{a}, {b}] are not finite with min ≤ max")));
                    }
                    if !(b - a).is_finite() {
                        return Err(bad(format!(
                            "taxel {i}: the span of bounds [{a}, {b}] overflows f64 (max − min must be ≤ {:e})",
                            f64::MAX
                        )));
                    }
                }
                lo.clone_from(min);
                hi.clone_from(max);
                ready = true;
            }
            _ => {}
        }
        Ok(Normalise {
            taxels,
            bounds,
            min_span,
            clamp: config.clamp,
            bypass: config.bypass,
            lo,
            hi,
            ready,
            held: Vec::new(),
        })
    }

    /// Number of frames held back at start-up (calibration), 0 for other bounds.
    pub fn startup_frames(&self) -> usize {
        if self.bypass {
            return 0;
        }
        match self.bounds {
            Bounds::Calibrate { frames } => frames,
            _ => 0,
        }
    }

    /// The current per-taxel bounds `(min, max)`, once known.
    pub fn current_bounds(&self) -> Option<(&[f64], &[f64])> {
        self.ready.then_some((&self.lo[..], &self.hi[..]))
    }

    fn check(&self, f: &TaxelFrame) -> Result<()> {
        crate::error::check_taxel_count(STAGE, &f.sensor, f.seq, self.taxels, f.values.len())?;
        crate::error::check_finite(STAGE, f)
    }

    fn widen(&mut self, values: &[f64]) {
        for ((lo, hi), &v) in self.lo.iter_mut().zip(&mut self.hi).zip(values) {
            *lo = lo.min(v);
            *hi = hi.max(v);
        }
    }

    /// Normalise `f` in place. Where `v − lo` or `hi − lo` overflow (bounds or values near
    /// ±1.8e308) both are halved first — exact for normal numbers, so the quotient is the same
    /// — and a result that still is not finite (a value more than 1.8e308 spans outside the
    /// bounds) is an error rather than a NaN or ±inf passed on.
    fn apply(&self, f: &mut TaxelFrame) -> Result<()> {
        for (i, ((v, &lo), &hi)) in f.values.iter_mut().zip(&self.lo).zip(&self.hi).enumerate() {
            let (d, span) = (*v - lo, hi - lo);
            let y = if d.is_finite() && span.is_finite() {
                d / span.max(self.min_span)
            } else {
                (*v * 0.5 - lo * 0.5) / (hi * 0.5 - lo * 0.5).max(self.min_span * 0.5)
            };
            if !y.is_finite() {
                return Err(Error::BadValue {
                    stage: STAGE,
                    sensor: f.sensor.to_string(),
                    seq: f.seq,
                    taxel: i,
                    value: *v,
                    reason: "its normalised value overflows f64 (the value is far outside the bounds)",
                });
            }
            *v = if self.clamp { y.clamp(0.0, 1.0) } else { y };
        }
        Ok(())
    }

    fn release_held(&mut self, out: &mut Vec<TaxelFrame>) -> Result<()> {
        self.ready = true;
        let mut held = std::mem::take(&mut self.held);
        for mut f in held.drain(..) {
            self.apply(&mut f)?;
            out.push(f);
        }
        self.held = held; // keep the allocation
        Ok(())
    }
}

impl Stage for Normalise {
    type In = TaxelFrame;
    type Out = TaxelFrame;
    type Error = Error;

    fn push(&mut self, mut f: TaxelFrame, out: &mut Vec<TaxelFrame>) -> Result<()> {
        self.check(&f)?;
        if self.bypass {
            out.push(f);
            return Ok(());
        }
        match self.bounds {
            Bounds::Given { .. } => {}
            Bounds::Running => {
                self.widen(&f.values);
                self.ready = true;
            }
            Bounds::Calibrate { frames } => {
                if !self.ready {
                    self.widen(&f.values);
                    self.held.push(f);
                    if self.held.len() == frames {
                        self.release_held(out)?;
                    }
                    return Ok(());
                }
            }
        }
        self.apply(&mut f)?;
        out.push(f);
        Ok(())
    }

    /// Flushes frames still held for calibration (a stream shorter than the calibration
    /// window is normalised by the bounds of what arrived), then resets.
    fn finish(&mut self, out: &mut Vec<TaxelFrame>) -> Result<()> {
        if !self.held.is_empty() {
            self.release_held(out)?;
        }
        self.reset();
        Ok(())
    }

    /// Calibrate: forget the bounds and held frames (the next N frames recalibrate).
    /// Running: restart the bounds. Given: nothing to forget.
    fn reset(&mut self) {
        self.held.clear();
        if !matches!(self.bounds, Bounds::Given { .. }) {
            self.lo.fill(f64::INFINITY);
            self.hi.fill(f64::NEG_INFINITY);
            self.ready = false;
        }
    }

    /// Zero in steady state; calibration holds the first N frames once (see
    /// [`Normalise::startup_frames`]).
    fn delay(&self) -> Delay {
        Delay::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gradtac_stream::{SensorId, StageExt, Timestamp};
    use proptest::prelude::*;

    fn frames(rows: &[Vec<f64>]) -> Vec<TaxelFrame> {
        rows.iter()
            .enumerate()
            .map(|(k, v)| TaxelFrame::new(SensorId::new("ff"), Timestamp(k as i64), k as u64, v.clone()))
            .collect()
    }

    fn cfg_cal(n: usize) -> NormaliseConfig {
        NormaliseConfig { calibrate_frames: Some(n), ..Default::default() }
    }

    /// Issue #12: bounds of ±1e308 (span 2e308 overflows) used to write NaN. Given bounds
    /// whose span overflows are refused; bounds found in the data near ±1.8e308 normalise
    /// exactly (computed halved), never to NaN.
    #[test]
    fn extreme_bounds_never_give_nan() {
        let given = NormaliseConfig { min: Some(vec![-1e308]), max: Some(vec![1e308]), ..Default::default() };
        let e = Normalise::try_new(1, &given).unwrap_err().to_string();
        assert!(e.contains("overflows f64"), "{e}");
        for cfg in [cfg_cal(2), NormaliseConfig { running: true, ..Default::default() }] {
            let out = Normalise::try_new(1, &cfg)
                .unwrap()
                .run_all(frames(&[vec![-1e308], vec![1e308], vec![0.0], vec![f64::MAX]]))
                .unwrap();
            let got: Vec<f64> = out.iter().map(|f| f.values[0]).collect();
            assert!(got.iter().all(|v| v.is_finite()), "{got:?}");
            assert_eq!(&got[..3], &[0.0, 1.0, 0.5]);
        }
        // a value 1.8e308 spans outside tight bounds: an error naming frame and taxel, no inf
        let tight = NormaliseConfig { min: Some(vec![-f64::MAX]), max: Some(vec![-f64::MAX]), ..Default::default() };
        let e = Normalise::try_new(1, &tight).unwrap().run_all(frames(&[vec![0.0], vec![f64::MAX]])).unwrap_err();
        assert!(matches!(e, Error::BadValue { seq: 1, taxel: 0, .. }), "{e}");
    }

    #[test]
    fn calibrate_maps_calibration_range_to_unit_interval_and_holds_frames() {
        let mut n = Normalise::try_new(2, &cfg_cal(3)).unwrap();
        let mut out = Vec::new();
        n.push(frames(&[vec![10.0, 5.0]])[0].clone(), &mut out).unwrap();
        n.push(frames(&[vec![20.0, 5.0]])[0].clone(), &mut out).unwrap();
        assert!(out.is_empty(), "calibration frames are held");
        let all = Normalise::try_new(2, &cfg_cal(3))
            .unwrap()
            .run_all(frames(&[vec![10.0, 5.0], vec![20.0, 5.0], vec![15.0, 5.0], vec![30.0, 7.0]]))
            .unwrap();
        let v: Vec<_> = all.iter().map(|f| f.values.clone()).collect();
        // taxel 1 is constant during calibration: span floors at 1 count, no division by zero.
        assert_eq!(v, vec![vec![0.0, 0.0], vec![1.0, 0.0], vec![0.5, 0.0], vec![2.0, 2.0]]);
        assert_eq!(all.iter().map(|f| f.seq).collect::<Vec<_>>(), [0, 1, 2, 3]);
    }

    #[test]
    fn short_stream_is_flushed_with_partial_calibration() {
        let out = Normalise::try_new(1, &cfg_cal(100)).unwrap().run_all(frames(&[vec![1.0], vec![3.0]])).unwrap();
        assert_eq!(out.iter().map(|f| f.values[0]).collect::<Vec<_>>(), [0.0, 1.0]);
    }

    #[test]
    fn running_and_given_and_clamp() {
        let cfg = NormaliseConfig { running: true, ..Default::default() };
        let out = Normalise::try_new(1, &cfg).unwrap().run_all(frames(&[vec![4.0], vec![8.0], vec![6.0]])).unwrap();
        assert_eq!(out.iter().map(|f| f.values[0]).collect::<Vec<_>>(), [0.0, 1.0, 0.5]);
        let cfg = NormaliseConfig { min: Some(vec![0.0]), max: Some(vec![10.0]), clamp: true, ..Default::default() };
        let out = Normalise::try_new(1, &cfg).unwrap().run_all(frames(&[vec![5.0], vec![20.0], vec![-1.0]])).unwrap();
        assert_eq!(out.iter().map(|f| f.values[0]).collect::<Vec<_>>(), [0.5, 1.0, 0.0]);
    }

    #[test]
    fn invalid_configuration_fails_at_construction() {
        let e = |c: NormaliseConfig| Normalise::try_new(2, &c).unwrap_err().to_string();
        assert!(e(cfg_cal(0)).contains("≥ 1"));
        assert!(e(NormaliseConfig { min: Some(vec![0.0, 0.0]), ..Default::default() }).contains("together"));
        assert!(e(NormaliseConfig { min: Some(vec![0.0]), max: Some(vec![1.0]), ..Default::default() })
            .contains("for 2 taxels"));
        assert!(e(NormaliseConfig { min: Some(vec![2.0, 0.0]), max: Some(vec![1.0, 1.0]), ..Default::default() })
            .contains("taxel 0"));
        assert!(e(NormaliseConfig { running: true, calibrate_frames: Some(3), ..Default::default() })
            .contains("choose one"));
        assert!(e(NormaliseConfig { min_span: Some(0.0), ..Default::default() }).contains("min_span"));
    }

    #[test]
    fn bad_input_names_frame_and_taxel() {
        let mut n = Normalise::try_new(2, &cfg_cal(1)).unwrap();
        let mut out = Vec::new();
        let mut f = frames(&[vec![1.0, f64::NAN]]).remove(0);
        f.seq = 41;
        let e = n.push(f, &mut out).unwrap_err().to_string();
        assert_eq!(e, "normalise: sensor ff frame 41 taxel 1: not a finite number (value NaN)");
        let e = n.push(frames(&[vec![1.0]]).remove(0), &mut out).unwrap_err().to_string();
        assert!(e.contains("expected 2 taxels, got 1"), "{e}");
    }

    #[test]
    fn bypass_passes_frames_through_but_still_checks_them() {
        let cfg = NormaliseConfig { bypass: true, ..Default::default() };
        let rows = [vec![3000.0, 12.5], vec![0.0, 4095.0]];
        let out = Normalise::try_new(2, &cfg).unwrap().run_all(frames(&rows)).unwrap();
        assert_eq!(out, frames(&rows));
        assert!(Normalise::try_new(2, &cfg).unwrap().run_all(frames(&[vec![f64::INFINITY, 0.0]])).is_err());
    }

    #[test]
    fn extremes_stay_finite() {
        // full 12-bit range, huge and tiny magnitudes
        let rows = [vec![0.0, 1e-300, -1e300], vec![4095.0, 2e-300, 1e300], vec![2047.5, 0.0, 0.0]];
        let out = Normalise::try_new(3, &cfg_cal(2)).unwrap().run_all(frames(&rows)).unwrap();
        for f in &out {
            assert!(f.values.iter().all(|v| v.is_finite()), "{:?}", f.values);
        }
        assert_eq!(out[2].values[0], 0.5);
        assert_eq!(out[1].values[2], 1.0);
    }

    proptest! {
        /// Feeding frames one by one in any split, with `finish` only at the end, equals one pass.
        #[test]
        fn any_chunking_gives_one_pass_output(
            rows in prop::collection::vec(prop::collection::vec(-5000.0f64..5000.0, 3), 0..60),
            cuts in prop::collection::vec(0usize..60, 0..6),
            mode in 0u8..3,
        ) {
            let cfg = match mode {
                0 => cfg_cal(7),
                1 => NormaliseConfig { running: true, ..Default::default() },
                _ => NormaliseConfig { min: Some(vec![-5000.0; 3]), max: Some(vec![5000.0; 3]), ..Default::default() },
            };
            let input = frames(&rows);
            let whole = Normalise::try_new(3, &cfg).unwrap().run_all(input.clone()).unwrap();
            let mut st = Normalise::try_new(3, &cfg).unwrap();
            let mut out = Vec::new();
            let mut cuts = cuts; cuts.sort();
            let mut start = 0;
            for c in cuts.into_iter().chain([input.len()]) {
                let c = c.min(input.len()).max(start);
                let mut chunk_out = Vec::new();
                for f in &input[start..c] { st.push(f.clone(), &mut chunk_out).unwrap(); }
                out.extend(chunk_out);
                start = c;
            }
            st.finish(&mut out).unwrap();
            prop_assert_eq!(whole, out);
        }
    }
}
