//! Force: maximal-contour area (mm²) → newtons, calibrated from labelled pairs (method.md,
//! stage 7).
//!
//! # What it does
//! [`ForceModel::fit`] fits one of four regressions ([`ForceMethod`]) to labelled
//! [`ForceSample`]s `(area_mm2, force_n)`; the fitted [`ForceModel`] serialises (JSON, TOML) and
//! is what a scene's `[stages.force]` table holds. The [`Force`] stage maps each
//! [`ContourFrame`] to a [`ForceEstimate`]: the model's prediction at the maximal contour's
//! area, clamped at 0 N, or no force (as data) without contact.
//!
//! | method | model | fit | parameters |
//! |---|---|---|---|
//! | `linear` | `F = a + b·A` | least squares | 2 |
//! | `power_law` | `F = a·A^p` | least squares on `ln F` vs `ln A` (needs `A, F > 0`) | 2 |
//! | `exponential` | `F = a·e^{b·A}` | least squares on `ln F` vs `A` (needs `F > 0`) | 2 |
//! | `isotonic` | non-decreasing; flat over each pooled block's areas, linear between blocks, flat beyond | pool-adjacent-violators on `F` sorted by `A` (equal areas pooled) | ≤ 2 knots per block |
//!
//! Least squares run on centred data (no normal-equation cancellation); the log fits minimise
//! *relative* error, which is what MAPE measures.
//!
//! # Which method
//! Measured by `tests/force.rs` on simulated 1 → 12 N ramps ([`crate::sim::Scene::force_ramp`],
//! default [`SensorModel`](crate::sim::SensorModel)): savgol → events (τ = 0.002 on ln counts)
//! → cumulative event counts → natural-neighbour 32 × 32 → maximal contour at one explicit
//! level (5 events). Each simulated sensor is calibrated on its own 3 ramps at three points of
//! the pad and tested on 2 held-out ramps at two other points; held-out MAPE (%) averaged over
//! 3 sensors (1.5 s ramps, ≈ 450 training and 300 test pairs per sensor):
//!
//! | indenter | linear | power law | exponential | isotonic |
//! |---|---|---|---|---|
//! | 1 mm | 23.1 | 25.6 | **11.5** | 12.6 |
//! | 2 mm | 21.9 | 23.2 | **10.1** | 10.4 |
//! | 5 mm | 21.0 | 18.1 | 7.9 | **6.8** |
//!
//! The log-change events make the cumulative count at a taxel grow like `ln F`, so the area
//! above a fixed level grows roughly like `ln F` too: `exponential` (`ln F` linear in area)
//! fits that shape with two numbers, `isotonic` follows it without assuming it, `linear` and
//! `power_law` bend the wrong way and leave ≈ 20 % error. The remaining ≈ 10 % is position:
//! the same force gives different areas where taxels are dense or sparse. (The paper fitted a
//! 7-layer MLP to 200 pairs and reported MAPE curves only; these are not comparable numbers.)
//! Higher levels cut noise but lose the light touches (below the level there is no contour).

//! # Units
//! Areas mm², forces N.
//!
//! # Delay
//! None.
//!
//! # Trade-offs
//! | method | strength | weakness |
//! |---|---|---|
//! | `linear` | extrapolates, 2 numbers | biased where area saturates or grows like `ln F` |
//! | `power_law` / `exponential` | relative-error fit, 2 numbers | assumes the curve's shape |
//! | `isotonic` | any monotone curve | flat beyond the calibrated range; as many knots as blocks |

use crate::contour::{ContourFrame, ContourOutcome};
use crate::{Error, Result};
use gradtac_stream::{Delay, HasSensor, SensorId, Stage, Timed, Timestamp};
use serde::{Deserialize, Serialize};

const STAGE: &str = "force";

/// One labelled calibration pair.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ForceSample {
    /// Maximal-contour area (mm²).
    pub area_mm2: f64,
    /// Measured force (N).
    pub force_n: f64,
}

/// A regression method (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ForceMethod {
    /// `F = a + b·A`.
    Linear,
    /// `F = a·A^p`.
    PowerLaw,
    /// `F = a·e^{b·A}`.
    Exponential,
    /// Monotone piecewise linear (pool adjacent violators).
    Isotonic,
}

impl ForceMethod {
    /// All four.
    pub const ALL: [ForceMethod; 4] =
        [ForceMethod::Linear, ForceMethod::PowerLaw, ForceMethod::Exponential, ForceMethod::Isotonic];
}

/// A fitted area → force model. Serialised with a `method` tag, e.g.
/// `{ method = "power_law", scale = 0.05, exponent = 1.4 }`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "method", rename_all = "snake_case", deny_unknown_fields)]
pub enum ForceModel {
    /// `F = intercept_n + slope_n_per_mm2 · A`.
    Linear {
        /// Force at zero area (N).
        intercept_n: f64,
        /// N per mm².
        slope_n_per_mm2: f64,
    },
    /// `F = scale · A^exponent`.
    PowerLaw {
        /// N at 1 mm².
        scale: f64,
        /// Dimensionless exponent.
        exponent: f64,
    },
    /// `F = scale_n · exp(rate_per_mm2 · A)`.
    Exponential {
        /// Force at zero area (N).
        scale_n: f64,
        /// Growth rate (1/mm²).
        rate_per_mm2: f64,
    },
    /// Piecewise linear through the knots, constant beyond the first and last.
    Isotonic {
        /// Knot areas (mm²), strictly increasing.
        area_mm2: Vec<f64>,
        /// Knot forces (N), non-decreasing.
        force_n: Vec<f64>,
    },
}

fn invalid(reason: String) -> Error {
    Error::InvalidConfig { stage: STAGE, reason }
}

/// A pooled block of the isotonic fit: force sum and count over the areas `a_min..=a_max`.
#[derive(Clone, Copy)]
struct Block {
    sum: f64,
    n: f64,
    a_min: f64,
    a_max: f64,
}

/// Least-squares line `y = a + b·x` on centred data; `None` when all x are equal.
fn line(xs: &[f64], ys: &[f64]) -> Option<(f64, f64)> {
    let n = xs.len() as f64;
    let mx = xs.iter().sum::<f64>() / n;
    let my = ys.iter().sum::<f64>() / n;
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for (x, y) in xs.iter().zip(ys) {
        sxx += (x - mx) * (x - mx);
        sxy += (x - mx) * (y - my);
    }
    if sxx > 0.0 {
        let b = sxy / sxx;
        Some((my - b * mx, b))
    } else {
        None
    }
}

impl ForceModel {
    /// Fit `method` to `samples` (at least two distinct finite areas; the log fits need the
    /// logged quantities > 0).
    pub fn fit(method: ForceMethod, samples: &[ForceSample]) -> Result<ForceModel> {
        if let Some((i, s)) =
            samples.iter().enumerate().find(|(_, s)| !(s.area_mm2.is_finite() && s.force_n.is_finite()))
        {
            return Err(invalid(format!("sample {i} is not finite: {s:?}")));
        }
        let need_pos = |i: usize, s: &ForceSample, area: bool| {
            if s.force_n <= 0.0 || (area && s.area_mm2 <= 0.0) {
                Err(invalid(format!(
                    "{method:?} needs positive {}: sample {i} is {s:?}",
                    if area { "areas and forces" } else { "forces" }
                )))
            } else {
                Ok(())
            }
        };
        let too_few = || invalid(format!("{method:?} needs at least two distinct areas ({} samples)", samples.len()));
        let area: Vec<f64> = samples.iter().map(|s| s.area_mm2).collect();
        let force: Vec<f64> = samples.iter().map(|s| s.force_n).collect();
        Ok(match method {
            ForceMethod::Linear => {
                let (a, b) = line(&area, &force).ok_or_else(too_few)?;
                ForceModel::Linear { intercept_n: a, slope_n_per_mm2: b }
            }
            ForceMethod::PowerLaw => {
                for (i, s) in samples.iter().enumerate() {
                    need_pos(i, s, true)?;
                }
                let la: Vec<f64> = area.iter().map(|a| a.ln()).collect();
                let lf: Vec<f64> = force.iter().map(|f| f.ln()).collect();
                let (a, b) = line(&la, &lf).ok_or_else(too_few)?;
                ForceModel::PowerLaw { scale: a.exp(), exponent: b }
            }
            ForceMethod::Exponential => {
                for (i, s) in samples.iter().enumerate() {
                    need_pos(i, s, false)?;
                }
                let lf: Vec<f64> = force.iter().map(|f| f.ln()).collect();
                let (a, b) = line(&area, &lf).ok_or_else(too_few)?;
                ForceModel::Exponential { scale_n: a.exp(), rate_per_mm2: b }
            }
            ForceMethod::Isotonic => {
                let mut pairs: Vec<(f64, f64)> = area.iter().copied().zip(force.iter().copied()).collect();
                pairs.sort_by(|p, q| p.0.total_cmp(&q.0));
                // pool adjacent violators; samples of equal area always share a block
                let mut blocks: Vec<Block> = Vec::new();
                for (a, f) in pairs {
                    match blocks.last_mut() {
                        Some(b) if b.a_max == a => {
                            b.sum += f;
                            b.n += 1.0;
                        }
                        _ => blocks.push(Block { sum: f, n: 1.0, a_min: a, a_max: a }),
                    }
                    while blocks.len() >= 2 {
                        let (p, q) = (blocks[blocks.len() - 2], blocks[blocks.len() - 1]);
                        if p.sum / p.n > q.sum / q.n {
                            blocks.pop();
                            *blocks.last_mut().expect("two blocks") =
                                Block { sum: p.sum + q.sum, n: p.n + q.n, a_min: p.a_min, a_max: q.a_max };
                        } else {
                            break;
                        }
                    }
                }
                if blocks.first().is_none_or(|b| b.a_min == blocks[blocks.len() - 1].a_max) {
                    return Err(too_few());
                }
                // a block is flat from its smallest to its largest area; linear between blocks
                let (mut area_mm2, mut force_n) = (Vec::new(), Vec::new());
                for b in &blocks {
                    area_mm2.push(b.a_min);
                    force_n.push(b.sum / b.n);
                    if b.a_max > b.a_min {
                        area_mm2.push(b.a_max);
                        force_n.push(b.sum / b.n);
                    }
                }
                ForceModel::Isotonic { area_mm2, force_n }
            }
        })
    }

    /// The method of this model.
    pub fn method(&self) -> ForceMethod {
        match self {
            ForceModel::Linear { .. } => ForceMethod::Linear,
            ForceModel::PowerLaw { .. } => ForceMethod::PowerLaw,
            ForceModel::Exponential { .. } => ForceMethod::Exponential,
            ForceModel::Isotonic { .. } => ForceMethod::Isotonic,
        }
    }

    /// Checks a (deserialised) model: finite parameters, isotonic knots strictly increasing in
    /// area and non-decreasing in force.
    pub fn validate(&self) -> Result<()> {
        let fin = |xs: &[f64]| xs.iter().all(|x| x.is_finite());
        let ok = match self {
            ForceModel::Linear { intercept_n, slope_n_per_mm2 } => fin(&[*intercept_n, *slope_n_per_mm2]),
            ForceModel::PowerLaw { scale, exponent } => fin(&[*scale, *exponent]),
            ForceModel::Exponential { scale_n, rate_per_mm2 } => fin(&[*scale_n, *rate_per_mm2]),
            ForceModel::Isotonic { area_mm2, force_n } => {
                !area_mm2.is_empty()
                    && area_mm2.len() == force_n.len()
                    && fin(area_mm2)
                    && fin(force_n)
                    && area_mm2.windows(2).all(|w| w[0] < w[1])
                    && force_n.windows(2).all(|w| w[0] <= w[1])
            }
        };
        if ok {
            Ok(())
        } else {
            Err(invalid(format!("invalid model {self:?}")))
        }
    }

    /// The force (N, ≥ 0) at contour area `area_mm2`. Power law at area ≤ 0 gives 0.
    pub fn predict(&self, area_mm2: f64) -> f64 {
        let f = match self {
            ForceModel::Linear { intercept_n, slope_n_per_mm2 } => intercept_n + slope_n_per_mm2 * area_mm2,
            ForceModel::PowerLaw { scale, exponent } => {
                if area_mm2 > 0.0 {
                    scale * area_mm2.powf(*exponent)
                } else {
                    0.0
                }
            }
            ForceModel::Exponential { scale_n, rate_per_mm2 } => scale_n * (rate_per_mm2 * area_mm2).exp(),
            ForceModel::Isotonic { area_mm2: xs, force_n: ys } => {
                let j = xs.partition_point(|&x| x <= area_mm2);
                if j == 0 {
                    ys[0]
                } else if j == xs.len() {
                    ys[j - 1]
                } else {
                    let (x0, x1, y0, y1) = (xs[j - 1], xs[j], ys[j - 1], ys[j]);
                    y0 + (y1 - y0) * (area_mm2 - x0) / (x1 - x0)
                }
            }
        };
        if f.is_nan() {
            f
        } else {
            f.max(0.0)
        }
    }

    /// Mean absolute percentage error (%) on `samples`: `100 · mean(|F − F̂| / max(ε, |F|))`
    /// with `ε` = 1e-9 N (the paper's definition).
    pub fn mape(&self, samples: &[ForceSample]) -> f64 {
        let n = samples.len() as f64;
        100.0
            * samples
                .iter()
                .map(|s| (s.force_n - self.predict(s.area_mm2)).abs() / s.force_n.abs().max(1e-9))
                .sum::<f64>()
            / n
    }
}

/// Configuration of the [`Force`] stage (`[stages.force]` in a scene):
///
/// ```toml
/// [stages.force]
/// model = { method = "power_law", scale = 0.05, exponent = 1.4 }
/// min_area_mm2 = 0.0
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForceConfig {
    /// The calibrated model ([`ForceModel::fit`]).
    pub model: ForceModel,
    /// Contours smaller than this (mm²) give no force. Default 0.
    #[serde(default)]
    pub min_area_mm2: f64,
}

/// The force of one contour frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ForceEstimate {
    /// The sensor.
    pub sensor: SensorId,
    /// The time the estimate describes (the contour's span end).
    pub time: Timestamp,
    /// Index of the newest source frame.
    pub seq: u64,
    /// The maximal contour's area (mm²); NaN without contact.
    pub area_mm2: f64,
    /// The estimate (N); `None` without contact or below `min_area_mm2`.
    pub force_n: Option<f64>,
}

impl Timed for ForceEstimate {
    fn time(&self) -> Timestamp {
        self.time
    }
}

impl HasSensor for ForceEstimate {
    fn sensor(&self) -> &SensorId {
        &self.sensor
    }
}

/// The force stage (see the [module docs](self)): one [`ForceEstimate`] per [`ContourFrame`].
///
/// ```
/// use gradtac_stages::force::{Force, ForceConfig, ForceMethod, ForceModel, ForceSample};
/// let pairs: Vec<ForceSample> =
///     (1..=12).map(|f| ForceSample { area_mm2: 10.0 * (f as f64).sqrt(), force_n: f as f64 }).collect();
/// let model = ForceModel::fit(ForceMethod::PowerLaw, &pairs)?;
/// assert!(model.mape(&pairs) < 1e-9); // F = A²/100 exactly
/// let toml = toml::to_string(&ForceConfig { model, min_area_mm2: 0.0 }).unwrap();
/// let back: ForceConfig = toml::from_str(&toml).unwrap();
/// let stage = Force::try_new(&back)?;
/// assert!((stage.model().predict(20.0) - 4.0).abs() < 1e-9);
/// # Ok::<(), gradtac_stages::Error>(())
/// ```
#[derive(Clone, Debug)]
#[must_use = "a stage does nothing until inputs are pushed"]
pub struct Force {
    cfg: ForceConfig,
    /// The curve reads the contact fit's amplitude instead of the area ([`Force::on_fit_amplitude`]).
    amplitude: bool,
}

impl Force {
    /// The stage (the model and `min_area_mm2` are validated).
    pub fn try_new(cfg: &ForceConfig) -> Result<Self> {
        cfg.model.validate()?;
        if !(cfg.min_area_mm2.is_finite() && cfg.min_area_mm2 >= 0.0) {
            return Err(invalid(format!("`min_area_mm2` = {} must be finite and ≥ 0", cfg.min_area_mm2)));
        }
        Ok(Force { cfg: cfg.clone(), amplitude: false })
    }

    /// Read the contact fit's amplitude ([`FitSummary`](crate::fit::FitSummary)) instead of the
    /// contour area (a model calibrated with `gradtac calibrate force --method amplitude`); a
    /// contour without a fit gives no force.
    pub fn on_fit_amplitude(mut self) -> Self {
        self.amplitude = true;
        self
    }

    /// The model.
    pub fn model(&self) -> &ForceModel {
        &self.cfg.model
    }
}

impl Stage for Force {
    type In = ContourFrame;
    type Out = ForceEstimate;
    type Error = Error;

    fn push(&mut self, f: ContourFrame, out: &mut Vec<ForceEstimate>) -> Result<()> {
        let (area_mm2, force_n) = match &f.outcome {
            ContourOutcome::Contact(c) if self.amplitude => {
                (c.area_mm2, c.fit.as_ref().map(|f| self.cfg.model.predict(f.amplitude)))
            }
            ContourOutcome::Contact(c) if c.area_mm2 >= self.cfg.min_area_mm2 => {
                (c.area_mm2, Some(self.cfg.model.predict(c.area_mm2)))
            }
            ContourOutcome::Contact(c) => (c.area_mm2, None),
            ContourOutcome::NoContact(_) => (f64::NAN, None),
        };
        out.push(ForceEstimate { sensor: f.sensor, time: f.end, seq: f.seq, area_mm2, force_n });
        Ok(())
    }

    fn reset(&mut self) {}

    fn delay(&self) -> Delay {
        Delay::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn samples(f: impl Fn(f64) -> f64) -> Vec<ForceSample> {
        (1..=40).map(|k| k as f64 * 2.5).map(|a| ForceSample { area_mm2: a, force_n: f(a) }).collect()
    }

    #[test]
    fn each_method_recovers_its_own_curve() {
        let lin = ForceModel::fit(ForceMethod::Linear, &samples(|a| 0.5 + 0.1 * a)).unwrap();
        let ForceModel::Linear { intercept_n, slope_n_per_mm2 } = lin else { panic!() };
        assert!((intercept_n - 0.5).abs() < 1e-12 && (slope_n_per_mm2 - 0.1).abs() < 1e-12);
        let pow = ForceModel::fit(ForceMethod::PowerLaw, &samples(|a| 0.02 * a.powf(1.5))).unwrap();
        let ForceModel::PowerLaw { scale, exponent } = pow else { panic!() };
        assert!((scale - 0.02).abs() < 1e-12 && (exponent - 1.5).abs() < 1e-12);
        let exp = ForceModel::fit(ForceMethod::Exponential, &samples(|a| 0.8 * (0.03 * a).exp())).unwrap();
        let ForceModel::Exponential { scale_n, rate_per_mm2 } = exp else { panic!() };
        assert!((scale_n - 0.8).abs() < 1e-12 && (rate_per_mm2 - 0.03).abs() < 1e-14);
        // isotonic passes any increasing curve through its samples exactly
        let s = samples(|a| (a / 10.0).ln_1p());
        let iso = ForceModel::fit(ForceMethod::Isotonic, &s).unwrap();
        assert!(iso.mape(&s) < 1e-12);
        // and interpolates linearly between them, flat outside
        assert!((iso.predict(3.75) - ((0.25f64).ln_1p() + (0.5f64).ln_1p()) / 2.0).abs() < 1e-12);
        assert_eq!(iso.predict(0.0), s[0].force_n);
        assert_eq!(iso.predict(1e6), s[39].force_n);
    }

    proptest::proptest! {
        /// Any finite samples: isotonic knots are strictly increasing in area and
        /// non-decreasing in force, predictions stay within the samples' force range and are
        /// monotone, and pooling preserves the total force. No method panics.
        #[test]
        fn isotonic_is_monotone_and_preserves_the_mean(
            pts in proptest::collection::vec((-50.0f64..50.0, 0.01f64..20.0), 2..60),
            probes in proptest::collection::vec(-100.0f64..100.0, 1..20),
        ) {
            let s: Vec<ForceSample> = pts.iter().map(|&(a, f)| ForceSample { area_mm2: a.round(), force_n: f }).collect();
            for m in ForceMethod::ALL {
                let _ = ForceModel::fit(m, &s);
            }
            let Ok(model) = ForceModel::fit(ForceMethod::Isotonic, &s) else { return Ok(()) };
            model.validate().unwrap();
            let lo = s.iter().map(|x| x.force_n).fold(f64::INFINITY, f64::min);
            let hi = s.iter().map(|x| x.force_n).fold(f64::NEG_INFINITY, f64::max);
            let mut probes = probes;
            probes.sort_by(f64::total_cmp);
            let ys: Vec<f64> = probes.iter().map(|&a| model.predict(a)).collect();
            for w in ys.windows(2) {
                proptest::prop_assert!(w[0] <= w[1] + 1e-12);
            }
            for &y in &ys {
                proptest::prop_assert!(y >= lo - 1e-9 && y <= hi + 1e-9);
            }
            // each sample's fitted value is its block's mean: the totals agree
            let fitted: f64 = s.iter().map(|x| model.predict(x.area_mm2)).sum();
            let total: f64 = s.iter().map(|x| x.force_n).sum();
            proptest::prop_assert!((fitted - total).abs() < 1e-9 * total.max(1.0), "{fitted} vs {total}");
        }
    }

    #[test]
    fn isotonic_pools_violators_and_ties() {
        let s = [(1.0, 1.0), (2.0, 3.0), (3.0, 2.0), (4.0, 4.0), (4.0, 6.0)]
            .map(|(a, f)| ForceSample { area_mm2: a, force_n: f });
        let m = ForceModel::fit(ForceMethod::Isotonic, &s).unwrap();
        assert_eq!(m, ForceModel::Isotonic { area_mm2: vec![1.0, 2.0, 3.0, 4.0], force_n: vec![1.0, 2.5, 2.5, 5.0] });
        m.validate().unwrap();
    }

    #[test]
    fn bad_samples_and_models_are_refused() {
        let one = [ForceSample { area_mm2: 3.0, force_n: 1.0 }; 3];
        for m in ForceMethod::ALL {
            assert!(ForceModel::fit(m, &one).is_err(), "{m:?}");
            assert!(ForceModel::fit(m, &[]).is_err(), "{m:?}");
        }
        let nan = [ForceSample { area_mm2: f64::NAN, force_n: 1.0 }, ForceSample { area_mm2: 1.0, force_n: 2.0 }];
        assert!(ForceModel::fit(ForceMethod::Linear, &nan).is_err());
        let zero = [ForceSample { area_mm2: 0.0, force_n: 1.0 }, ForceSample { area_mm2: 1.0, force_n: 2.0 }];
        assert!(ForceModel::fit(ForceMethod::PowerLaw, &zero).unwrap_err().to_string().contains("positive"));
        assert!(ForceModel::fit(ForceMethod::Exponential, &zero).is_ok());
        let bad = ForceModel::Isotonic { area_mm2: vec![2.0, 1.0], force_n: vec![1.0, 2.0] };
        assert!(Force::try_new(&ForceConfig { model: bad, min_area_mm2: 0.0 }).is_err());
        let lin = ForceModel::Linear { intercept_n: -5.0, slope_n_per_mm2: 1.0 };
        assert_eq!(lin.predict(1.0), 0.0); // clamped at 0 N
        assert!(Force::try_new(&ForceConfig { model: lin, min_area_mm2: -1.0 }).is_err());
    }

    #[test]
    fn stage_maps_contours_and_no_contact_is_data() {
        use crate::contour::{MaxContour, NoContact};
        use gradtac_stream::StageExt;
        let frame = |seq: u64, area: Option<f64>| ContourFrame {
            sensor: "ff".into(),
            start: Timestamp(0),
            end: Timestamp(seq as i64),
            seq,
            outcome: match area {
                None => ContourOutcome::NoContact(NoContact::BelowMinPeak),
                Some(a) => ContourOutcome::Contact(MaxContour {
                    level: 1.0,
                    polygon: vec![],
                    holes: vec![],
                    area_mm2: a,
                    centroid_mm: [0.0, 0.0],
                    orientation_rad: 0.0,
                    eccentricity: 0.0,
                    peak: 2.0,
                    peak_mm: [0.0, 0.0],
                    clipped: false,
                    fit: None,
                }),
            },
        };
        let model = ForceModel::Linear { intercept_n: 0.0, slope_n_per_mm2: 0.1 };
        let mut s = Force::try_new(&ForceConfig { model, min_area_mm2: 5.0 }).unwrap();
        let out = s.run_all([frame(0, None), frame(1, Some(2.0)), frame(2, Some(30.0))]).unwrap();
        assert_eq!(out[0].force_n, None);
        assert!(out[0].area_mm2.is_nan());
        assert_eq!(out[1].force_n, None);
        assert!((out[2].force_n.unwrap() - 3.0).abs() < 1e-12);
        assert_eq!((out[2].seq, out[2].time), (2, Timestamp(2)));
        let json = serde_json::to_string(s.model()).unwrap();
        assert_eq!(json, r#"{"method":"linear","intercept_n":0.0,"slope_n_per_mm2":0.1}"#);
    }
}
