//! Force models a user calibrates from a gauge (`gradtac calibrate force`), stored as a
//! versioned JSON file a scene names (`[stages.force] model = "force.json"`).
//!
//! # Methods
//! | method | input | model |
//! |---|---|---|
//! | `forward` (default; [`calibrate`] falls back to `placed` when the identification fits worse) | the signed changes `Δᵢ` | the member's forward model `Δᵢ ≈ gᵢ (F/F₀)^γ K(ρᵢ(x, y); w (F/F₀)^s)` identified from the gauge session (24 signed gains, γ, spread growth, width, far lobe; [`force_ident`](crate::force_ident)), inverted per frame for `(x, y, F)` |
//! | `placed` | `S₁`, `S₂` below, each divided by `R(x̂) = Σⱼ exp(−|x̂ − pⱼ|²/2w²)`: the layout's unit-gain response at the contact's place `x̂` (the `Δ²`-weighted centroid of the electrode positions `pⱼ`), `w` = [`DEFAULT_PLACE_WIDTH_MM`] | `F = e^c · (S₁/R)^p · (S₂/R)^q`: least squares on `ln F` (3 numbers, `w` and the layout's positions stored with them): a press at a place few electrodes see is not read as light ([`place_response`]) |
//! | `total` | the total change `S₁ = Σ|Δᵢ|` and its root-sum-square `S₂ = √ΣΔᵢ²` (counts) | `F = e^c · S₁^p · S₂^q`: least squares on `ln F` (3 numbers, blind to which taxels moved and to their signs) |
//! | `ridge` | the change detector's signed baseline-relative changes `Δᵢ = x̄ᵢ − x₀ᵢ` (counts) of every taxel | `F = b + Σ wᵢ Δᵢ`, ridge on standardised changes (the cheapest baseline) |
//! | `area` | the contact location's contour area (mm²; the paper's feature) | a monotone curve ([`ForceModel`]) |
//! | `amplitude` | the contact fit's amplitude (`[stages.locate] method = "fit"`) | a monotone curve ([`ForceModel`]) |
//!
//! Which is best, measured on held-out places of held-out members of the forward-model family
//! ([`sim_force`](crate::sim_force)), is in `docs/force.md` (`examples/force_eval.rs`); the
//! best is what `gradtac calibrate force` fits by default ([`DEFAULT_METHOD`]).
//!
//! # The stage
//! [`ChangeForce`] runs a model on changes: raw frames in, one
//! [`ForceEstimate`] per frame out — no force (`None`) while the detector sees no contact (so
//! untouched frames report none) or is still calibrating. It owns a
//! [`ChangeDetector`] with the scene's `[stages.locate]`
//! detector settings (and its stored baseline, [`ChangeForce::with_tare`]), so it needs no
//! other stage: a bare scene with a `force` output runs source → force.
//! Its detector ([`force_detector`]) runs the force gate [`FORCE_GATE`]
//! ([`DriftModel`] with holds): it carries each taxel's drift slope
//! through contacts, freezes the baseline of a frame with some taxel beyond 2 σ (a contact
//! until the excursion returns: steady below 0.3 of its peak total change, when the baseline
//! settles fast), follows at 5 s outside excursions and takes a level steady for 10 s as the new
//! rest — so a drifting, untouched sensor does not read as pressed and a light press is not
//! absorbed into the baseline during its hold (its lift then read as a contact that never
//! ends, the session-29 model's failure). The price: a press rising slower than the noise is
//! partly taken by the slope, and a press held still for 10 s ends.
//!
//! # Units, delay
//! Newtons; counts in, like the detector. Delay `(window_frames − 1)/2` frames (the mean of the
//! last `window_frames` frames is compared with the baseline; the estimate describes the
//! window's centre). Cost: O(taxels) per frame.
//!
//! # File
//! [`ForceFile`] is validated on read ([`ForceFile::validate`]): format tag and version,
//! taxel count within bounds and equal to the weights' (and to a `placed` model's positions;
//! its width within [`PLACE_WIDTH_RANGE_MM`]), finite numbers, a valid curve with at
//! most [`MAX_KNOTS`] knots.

use crate::force::{ForceEstimate, ForceMethod, ForceModel, ForceSample};
use crate::force_ident::{identify_with, ForwardModel, Geometry, Starts};
use crate::locate::{ChangeDetector, DriftModel, LocateConfig, ReturnAnchors, RiseGuard, ShapeFit};
use crate::{Error, Result};
use gradtac_stream::{Delay, Stage, TaxelFrame};
use serde::{Deserialize, Serialize};

const STAGE: &str = "force";

/// The `format` tag of a force model file.
pub const FORCE_FORMAT: &str = "gradtac-force";
/// The newest version this build reads (and writes, for a `forward` model): version 2 added the
/// `total` method, version 3 the `placed` method, version 4 the `forward` method, version 5 the
/// `forward` model's `gain_rel_sd` (a `forward` file without it is still written as version 4); `placed`
/// models are still written as version 3, `total` models as version 2 and `ridge`, `area` and
/// `amplitude` models as version 1, so older builds keep reading them. Every version up to
/// this one is read.
pub const FORCE_VERSION: u32 = 5;
/// Most taxels a model may hold.
pub const MAX_TAXELS: usize = 65_536;
/// Most knots of an isotonic curve in a file.
pub const MAX_KNOTS: usize = 100_000;

/// How a model is calibrated (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CalibrationMethod {
    /// The member's forward model identified from the gauge session, inverted per frame
    /// ([`force_ident`](crate::force_ident)).
    Forward,
    /// A power law in the total change divided by the layout's response at the contact's place.
    Placed,
    /// A power law in the total change.
    Total,
    /// Ridge on the signed changes.
    Ridge,
    /// A curve over the contour area.
    Area,
    /// A curve over the contact fit's amplitude (`[stages.locate] method = "fit"`).
    Amplitude,
}

impl CalibrationMethod {
    /// The name on the command line and in files.
    pub fn name(self) -> &'static str {
        match self {
            CalibrationMethod::Forward => "forward",
            CalibrationMethod::Placed => "placed",
            CalibrationMethod::Total => "total",
            CalibrationMethod::Ridge => "ridge",
            CalibrationMethod::Area => "area",
            CalibrationMethod::Amplitude => "amplitude",
        }
    }

    /// Every method.
    pub const ALL: [CalibrationMethod; 6] = [
        CalibrationMethod::Forward,
        CalibrationMethod::Placed,
        CalibrationMethod::Total,
        CalibrationMethod::Ridge,
        CalibrationMethod::Area,
        CalibrationMethod::Amplitude,
    ];

    /// Whether it reads the change detector's changes (raw frames) rather than contours.
    pub fn reads_changes(self) -> bool {
        matches!(
            self,
            CalibrationMethod::Forward
                | CalibrationMethod::Placed
                | CalibrationMethod::Total
                | CalibrationMethod::Ridge
        )
    }

    /// Parse a name.
    pub fn parse(s: &str) -> Option<CalibrationMethod> {
        CalibrationMethod::ALL.into_iter().find(|m| m.name() == s)
    }
}

/// What `gradtac calibrate force` fits without `--method`: `forward` with its guard (the rule's
/// choice on the tuning members, session 31; `examples/force_parts/history.md`) — on a sensor whose identification
/// fails, [`calibrate`] writes the `placed` law instead.
pub const DEFAULT_METHOD: CalibrationMethod = CalibrationMethod::Forward;
/// The width (mm) of the `placed` method's nominal response, chosen on the tuning members
/// (`examples/force_eval.rs`, `docs/force.md`).
pub const DEFAULT_PLACE_WIDTH_MM: f64 = 2.5;
/// Bounds of a `placed` model's width (mm).
pub const PLACE_WIDTH_RANGE_MM: std::ops::RangeInclusive<f64> = 0.1..=1000.0;
/// The ridge penalty (relative to the standardised features' scale) chosen on the tuning
/// members (`examples/force_eval.rs`).
pub const DEFAULT_RIDGE_LAMBDA: f64 = 0.1;
/// The area curve chosen on the tuning members for the default (centroid) chain.
pub const DEFAULT_AREA_CURVE: ForceMethod = ForceMethod::PowerLaw;

/// A calibrated model (tagged by `method`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "method", rename_all = "snake_case", deny_unknown_fields)]
pub enum CalibratedForce {
    /// The identified forward model ([`force_ident`](crate::force_ident)):
    /// `Δᵢ ≈ gᵢ (F/F₀)^γ K(ρᵢ(x, y); w (F/F₀)^s)`, inverted per frame for `(x, y, F)`.
    Forward {
        /// `gᵢ`: signed counts at `F₀` = 2 N under the contact, one per taxel.
        gains: Vec<f64>,
        /// `γ`.
        exponent: f64,
        /// `s`: the kernel width's growth with force.
        spread: f64,
        /// `w` (mm) at `F₀`.
        width_mm: f64,
        /// `q` (1–2): the kernel's profile, exponential to Gaussian.
        shape: f64,
        /// `a`: the far lobe's weight.
        lobe: f64,
        /// `τ` (s): the fluid lag inverted on the changes before the model is.
        lag_s: f64,
        /// The layout's electrode positions (layout plane, mm), one per taxel.
        positions: Vec<[f64; 2]>,
        /// `rᵢ`, one per taxel: each gain's doubt (the prior's share × its relative sd,
        /// [`ForwardModel::gain_rel_sd`]), weighing the inversion's residuals; absent in a
        /// version-4 file (then the inversion is unweighted, as before version 5).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        gain_rel_sd: Option<Vec<f64>>,
    },
    /// The `total` law on the changes divided by `R(x̂) = Σⱼ exp(−|x̂ − pⱼ|²/2w²)`, the
    /// layout's unit-gain response at the contact's place `x̂` (the `Δ²`-weighted centroid of
    /// the electrode positions `pⱼ`): `F = exp(c + p · ln(S₁/R) + q · ln(S₂/R))`, so a press
    /// at a place few electrodes see is not read as a light one ([`place_response`]).
    Placed {
        /// `c`: ln of the force at `S₁/R = S₂/R = 1` count.
        log_scale: f64,
        /// `p`, the exponent of `S₁/R`.
        sum_exponent: f64,
        /// `q`, the exponent of `S₂/R`.
        norm_exponent: f64,
        /// `w`: the nominal response's width (mm).
        width_mm: f64,
        /// The layout's electrode positions (layout plane, mm), one per taxel.
        positions: Vec<[f64; 2]>,
    },
    /// `F = exp(log_scale + sum_exponent · ln S₁ + norm_exponent · ln S₂)` with `S₁ = Σ|Δᵢ|`,
    /// `S₂ = √ΣΔᵢ²` (counts); 0 N when nothing changed.
    Total {
        /// `c`: ln of the force at `S₁ = S₂ = 1` count.
        log_scale: f64,
        /// `p`, the exponent of `S₁`.
        sum_exponent: f64,
        /// `q`, the exponent of `S₂`.
        norm_exponent: f64,
    },
    /// `F = intercept_n + Σ weights[i] · Δᵢ` (Δ in counts).
    Ridge {
        /// Force at no change (N).
        intercept_n: f64,
        /// N per count, per taxel.
        weights: Vec<f64>,
        /// The penalty it was fitted with.
        lambda: f64,
    },
    /// A curve over the contour area (mm²) of the scene's contact location.
    Area {
        /// The curve.
        curve: ForceModel,
    },
    /// A curve over the contact fit's amplitude (input units; the curve's `area_mm2` axis
    /// holds amplitudes) — needs `[stages.locate] method = "fit"`.
    Amplitude {
        /// The curve.
        curve: ForceModel,
    },
}

impl CalibratedForce {
    /// Its method.
    pub fn method(&self) -> CalibrationMethod {
        match self {
            CalibratedForce::Forward { .. } => CalibrationMethod::Forward,
            CalibratedForce::Placed { .. } => CalibrationMethod::Placed,
            CalibratedForce::Total { .. } => CalibrationMethod::Total,
            CalibratedForce::Ridge { .. } => CalibrationMethod::Ridge,
            CalibratedForce::Area { .. } => CalibrationMethod::Area,
            CalibratedForce::Amplitude { .. } => CalibrationMethod::Amplitude,
        }
    }

    /// The prediction for one calibration sample (N; `None` without a contact or the
    /// model's feature).
    pub fn predict_sample(&self, s: &GaugeSample) -> Option<f64> {
        if !s.contact {
            return None;
        }
        match self {
            CalibratedForce::Area { curve } => s.area_mm2.map(|a| curve.predict(a)),
            CalibratedForce::Amplitude { curve } => s.amplitude.map(|a| curve.predict(a)),
            m => m.predict_changes(&s.change),
        }
    }

    /// Whether it reads the changes (raw frames) rather than contours.
    pub fn reads_changes(&self) -> bool {
        self.method().reads_changes()
    }

    /// The file version a model of this method is written with: 5 for `forward` with gain
    /// doubts (4 without), 3 for
    /// `placed`, 2 for `total` (a build that reads only older versions refuses it by its
    /// version), 1 for the others.
    pub fn version(&self) -> u32 {
        match self {
            CalibratedForce::Forward { gain_rel_sd: Some(_), .. } => 5,
            CalibratedForce::Forward { .. } => 4,
            CalibratedForce::Placed { .. } => 3,
            CalibratedForce::Total { .. } => 2,
            _ => 1,
        }
    }

    /// The `forward` model and its geometry (`None` for another method).
    pub fn forward(&self) -> Option<(ForwardModel, Geometry)> {
        match self {
            CalibratedForce::Forward {
                gains, exponent, spread, width_mm, shape, lobe, positions, gain_rel_sd, ..
            } => Some((
                ForwardModel {
                    gains: gains.clone(),
                    exponent: *exponent,
                    spread: *spread,
                    width_mm: *width_mm,
                    shape: *shape,
                    lobe: *lobe,
                    gain_rel_sd: gain_rel_sd.clone(),
                },
                Geometry::for_positions(positions),
            )),
            _ => None,
        }
    }

    /// The prediction for changes `delta` (N, ≥ 0; NaN in, NaN out); `None` for a curve model.
    /// (The `forward` model builds its geometry on each call; [`ChangeForce`] keeps it.)
    pub fn predict_changes(&self, delta: &[f64]) -> Option<f64> {
        match self {
            CalibratedForce::Forward { .. } => {
                let (m, geo) = self.forward().expect("a forward model");
                Some(forward_force(&m, &geo, delta))
            }
            CalibratedForce::Placed { log_scale, sum_exponent, norm_exponent, width_mm, positions } => {
                let (s1, s2) = total_change(delta);
                if s1.is_nan() {
                    return Some(f64::NAN);
                }
                if s1 <= 0.0 {
                    return Some(0.0);
                }
                let r = place_response(positions, delta, *width_mm).ln();
                let f = (log_scale + sum_exponent * (s1.ln() - r) + norm_exponent * (s2.ln() - r)).exp();
                Some(if f.is_nan() { f } else { f.max(0.0) })
            }
            CalibratedForce::Total { log_scale, sum_exponent, norm_exponent } => {
                let (s1, s2) = total_change(delta);
                if s1.is_nan() {
                    return Some(f64::NAN);
                }
                if s1 <= 0.0 {
                    return Some(0.0);
                }
                let f = (log_scale + sum_exponent * s1.ln() + norm_exponent * s2.ln()).exp();
                Some(if f.is_nan() { f } else { f.max(0.0) })
            }
            CalibratedForce::Ridge { intercept_n, weights, .. } => {
                let f = intercept_n + weights.iter().zip(delta).map(|(w, d)| w * d).sum::<f64>();
                Some(if f.is_nan() { f } else { f.max(0.0) })
            }
            CalibratedForce::Area { .. } | CalibratedForce::Amplitude { .. } => None,
        }
    }
}

/// Bounds of a `forward` model's fluid lag (s).
pub const LAG_RANGE_S: std::ops::RangeInclusive<f64> = 0.0..=0.5;

/// The inverse of a first-order lag `τ` for changes `delta` that follow `prev` by `dt` s:
/// `Δ*ₖ = Δₖ₋₁ + (Δₖ − Δₖ₋₁)/α`, `α = 1 − e^{−Δt/τ}`; `τ = 0`, a gap over 0.5 s or an unknown
/// time keep `delta`.
fn lead(delta: &[f64], prev: &[f64], dt: f64, tau: f64) -> Vec<f64> {
    if !(tau > 0.0 && dt > 0.0 && dt <= 0.5) || prev.len() != delta.len() {
        return delta.to_vec();
    }
    let alpha = 1.0 - (-dt / tau).exp();
    delta.iter().zip(prev).map(|(d, p)| p + (d - p) / alpha).collect()
}

/// A model's predictions frame by frame (the `forward` model's lag inverse needs the previous
/// frame's changes): what [`ChangeForce`] runs and what `calibrate` scores in sample.
#[derive(Clone, Debug)]
pub struct ForcePredictor {
    model: CalibratedForce,
    forward: Option<(ForwardModel, Geometry, f64)>,
    prev: Option<(f64, Vec<f64>)>,
}

impl ForcePredictor {
    /// For `model`.
    pub fn new(model: &CalibratedForce) -> Self {
        let forward = match model {
            CalibratedForce::Forward { lag_s, .. } => model.forward().map(|(m, g)| (m, g, *lag_s)),
            _ => None,
        };
        ForcePredictor { model: model.clone(), forward, prev: None }
    }

    /// The next frame's force (N; `None` without a contact or the model's feature): frames
    /// must come in time order.
    pub fn push(&mut self, s: &GaugeSample) -> Option<f64> {
        let Some((m, geo, tau)) = &self.forward else { return self.model.predict_sample(s) };
        let led = match &self.prev {
            Some((t, p)) => lead(&s.change, p, s.time_s - t, *tau),
            None => s.change.clone(),
        };
        self.prev = Some((s.time_s, s.change.clone()));
        s.contact.then(|| forward_force(m, geo, &led))
    }

    /// Forget the previous frame (a gap).
    pub fn reset(&mut self) {
        self.prev = None;
    }
}

/// The `forward` model's force for `delta` (N; NaN for a non-finite change or a wrong length,
/// 0 without a change).
pub fn forward_force(model: &ForwardModel, geo: &Geometry, delta: &[f64]) -> f64 {
    model.invert(geo, delta).map_or(f64::NAN, |p| if delta.iter().all(|d| *d == 0.0) { 0.0 } else { p[2] })
}

/// The total change of `delta`: `(Σ|Δᵢ|, √ΣΔᵢ²)` — the `total` method's features.
pub fn total_change(delta: &[f64]) -> (f64, f64) {
    let s1 = delta.iter().map(|d| d.abs()).sum::<f64>();
    let s2 = delta.iter().map(|d| d * d).sum::<f64>().sqrt();
    (s1, s2)
}

/// The layout's unit-gain response at the contact's place: `R(x̂) = Σⱼ exp(−|x̂ − pⱼ|²/2w²)`
/// with `x̂` the `Δ²`-weighted centroid of the positions `pⱼ` (the `placed` method's
/// normaliser; ≥ 1e-6). Without a change (or with a non-finite one) it is 1. Positions beyond
/// `delta`'s length are ignored.
pub fn place_response(positions: &[[f64; 2]], delta: &[f64], width_mm: f64) -> f64 {
    let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
    for (p, d) in positions.iter().zip(delta) {
        let q = d * d;
        sx += q * p[0];
        sy += q * p[1];
        sw += q;
    }
    if !(sw > 0.0 && sw.is_finite() && sx.is_finite() && sy.is_finite()) {
        return 1.0;
    }
    let x = [sx / sw, sy / sw];
    let k = 1.0 / (2.0 * width_mm * width_mm);
    positions.iter().map(|p| (-((p[0] - x[0]).powi(2) + (p[1] - x[1]).powi(2)) * k).exp()).sum::<f64>().max(1e-6)
}

/// The force stage's contact gate ([`DriftModel`] with holds; chosen on the tuning members of
/// `examples/force_eval.rs`, `docs/force.md`): a frame with some taxel beyond 2 σ of its
/// baseline is *held* — its baseline frozen (moved only along the drift slope), and a contact
/// of an excursion that has not returned (hysteresis down to 2 σ); an excursion *returns* when
/// it is steady below 0.3 of its peak total change, and only then does the baseline settle
/// fast (0.2 s); outside excursions the baseline follows at 5 s; a held stretch steady for
/// 10 s is a new resting level. Unlike the session-29 model ([`DriftModel::default`]) a light
/// press below the contact threshold is not absorbed into the baseline during its hold, so its
/// lift does not read as a contact that never ends.
///
/// Known limit (measured, `examples/force_parts/history.md` "the force gate's returns"): the return bound is
/// relative to the peak only, so a residual of a few σ left by a light press on a noisy sensor
/// (whose window means' noise alone fills `Σ|Δᵢ|` above 0.3 of that peak) is no return and stays
/// a contact until the stale time; on the tuning members 32 of 80 rests of 0.6 s end in contact
/// (most on residuals of several σ after firm presses). The noise return
/// ([`DriftModel::release_sigmas`]) ends such contacts but absorbs light presses during their
/// rise, and lost on the tuning members: it is off.
///
/// Since session 32 (second round) the gate also has the *shape return*
/// ([`DriftModel::release_excess`] 0.5, flatness as the range of `Σ|Δᵢ|` over 0.3 s): an
/// excursion that is steady, flat, and has fallen to half its peak's change above the
/// untouched floor returns — a press rising or held sits near its peak, so it is not absorbed.
/// Chosen by the rule of `examples/force_parts/history.md` on the tuning members (worst of 14 members 67.5 →
/// 40.1 %). Known limit: on a weak, noisy sensor (σ 4.4 counts over 24 taxels) the range of
/// `Σ|Δᵢ|` over 0.3 s exceeds 0.1 `Σσᵢ` by noise alone, so a light press's residual there still
/// stays a contact until the stale time.
///
/// Since session 33 the drift slope's anchors are *shifted* to the new level on the frame an
/// excursion returns by the shape return alone ([`ReturnAnchors::ShiftAtShapeReturn`]): the
/// residual step that return leaves behind is no longer learned as drift (which ran the baseline
/// off and brought the contact back), and the slope learned before it is kept. Chosen by the
/// rule of `examples/force_parts/history.md` ("Session 33") on the tuning members (worst of 14 members 40.1 →
/// 36.3 %, untouched frames above 0.5 N 75 → 57 of 2800).
///
/// Since session 34 the gate has the *drift-shape return* ([`DriftModel::drift_shape`] 0.25 with
/// [`ShapeFit::Magnitude`]; needs the layout's positions, which the scene chain, `calibrate
/// force` and `force_eval` give): a steady excursion whose change is not shaped like a press
/// (one smooth bump explains under 0.25 of its magnitudes' variance) returns, so a stale
/// baseline under drift no longer holds a contact that never ends. Ranked first by the rule
/// of `examples/force_parts/history.md` ("Session 34") over the 62 tuning members (worst tied, 151.1 against
/// 150.6 %; mean 22.11 → 18.74 %; untouched frames above 0.5 N 547 → 367 of 12400). Held out
/// (scored once, after the choice): worst member 76.6 % against 55.7 %, mean 17.6 against
/// 18.9 %, untouched 3.00 against 3.03 %.
///
/// Since session 35 the drift-shape return has a *rise test* ([`DriftModel::drift_shape_rise_s`]
/// 2 s with [`RiseGuard::ShiftAnchorsUndo`]): a return on a frame whose total change 2 s before
/// was under half its own — a press's rise and hold, taken for drift when a broad or narrow
/// press's magnitudes fit no bump — shifts the slope's anchors instead of keeping them (so the
/// press is not learned as a slope that runs the baseline off), and is undone once the sensor
/// comes back to the level before it (the press lifted). Ranked first by the rule of
/// `examples/force_parts/history.md` ("Session 35") over the 62 tuning members (worst tied at 151.1 %, mean
/// 18.74 → 18.71 %, untouched frames above 0.5 N 367 → 193 of 12400). Held out (scored once,
/// after the choice): unchanged to the printed decimal, worst member 76.6 %, mean 17.6 %,
/// untouched 3.00 %.
///
/// Since session 37 a held frame *starts* a contact only once some taxel is beyond 3 σ
/// ([`DriftModel::hold_start_sigmas`]); the 2-σ hold still freezes the baseline and keeps a
/// contact going. With 24 taxels one beyond 2 σ is most noise frames, so the 2-σ hold alone
/// restarted contacts inside the rests after a return. Chosen by round 8's rule
/// (`examples/force_parts/rule_round8.md`) over the 62 tuning members (worst tied at 151.1 %,
/// mean 18.71 → 19.17 %, untouched frames above 0.5 N 193 → 145 of 12 400; G 13, M 34). Held
/// out (scored once, after the choice): worst member 76.6 → 75.3 %, mean 17.6 → 17.5 %,
/// untouched 3.00 → 2.97 %. Trade-off: a light press is reported from its 3-σ crossing, not
/// its 2-σ one (more pressed frames without a force on the tuning members).
pub const FORCE_GATE: DriftModel = DriftModel {
    steady_s: 0.3,
    steady_sigmas: 2.0,
    settle_s: 0.2,
    slope_memory_s: 20.0,
    slope_prior_s3: 5.0,
    release_fraction: 0.3,
    hold_sigmas: 2.0,
    hold_total: 0.0,
    hold_contact: true,
    hold_start_sigmas: 3.0,
    release_moving: 0.0,
    quiet_s: 5.0,
    stale_s: 10.0,
    release_sigmas: 0.0,
    release_excess: 0.5,
    release_flat_s: 0.0,
    release_flat_range: true,
    release_flat_sigmas: 0.1,
    return_anchors: ReturnAnchors::ShiftAtShapeReturn,
    quiet_taxel_s: 0.0,
    drift_shape: 0.25,
    drift_shape_fit: ShapeFit::Magnitude,
    drift_shape_rise_s: 2.0,
    drift_shape_rise: RiseGuard::ShiftAnchorsUndo,
};

/// The force stage's change detector for `taxels` taxels: the `[stages.locate]` detector
/// settings `locate` with the force stage's gate [`FORCE_GATE`].
pub fn force_detector(taxels: usize, locate: &LocateConfig) -> Result<ChangeDetector> {
    ChangeDetector::try_new(taxels, locate)?.with_drift_model(FORCE_GATE)
}

/// The session-29 force detector (the drift model's defaults, without holds): kept for the
/// reference row of `examples/force_eval.rs`.
pub fn force_detector_s29(taxels: usize, locate: &LocateConfig) -> Result<ChangeDetector> {
    ChangeDetector::try_new(taxels, locate)?.with_drift_model(DriftModel::default())
}

/// How the model was calibrated (informational; shown by `explain`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationInfo {
    /// Frames with a contact and a gauge reading used.
    pub samples: u64,
    /// Smallest and largest gauge force used (N).
    pub force_range_n: [f64; 2],
    /// In-sample MAPE (%) above 0.5 N.
    pub in_sample_mape_pct: f64,
}

/// A force model file (see the [module docs](self)).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForceFile {
    /// Always [`FORCE_FORMAT`].
    pub format: String,
    /// [`FORCE_VERSION`].
    pub version: u32,
    /// The layout's name.
    pub layout: String,
    /// Number of taxels.
    pub taxels: usize,
    /// The model.
    pub model: CalibratedForce,
    /// How it was calibrated.
    pub calibration: CalibrationInfo,
}

fn invalid(reason: String) -> Error {
    Error::InvalidConfig { stage: STAGE, reason }
}

/// Check a force file's format tag and version (read first, before the model: a file newer
/// than this build is refused by its version, not by a field it does not know).
pub fn check_header(format: &str, version: u32) -> Result<()> {
    if format != FORCE_FORMAT {
        return Err(invalid(format!("format {format:?} is not {FORCE_FORMAT:?}")));
    }
    if version == 0 || version > FORCE_VERSION {
        return Err(invalid(format!(
            "version {version} (this build reads versions 1 to {FORCE_VERSION}; a newer gradtac wrote it — \
             update gradtac, or calibrate again with this one)"
        )));
    }
    Ok(())
}

impl ForceFile {
    /// Check a (read) file: format, version, bounds, finite numbers, the curve's validity.
    pub fn validate(&self) -> Result<()> {
        check_header(&self.format, self.version)?;
        if self.taxels == 0 || self.taxels > MAX_TAXELS {
            return Err(invalid(format!("{} taxels (want 1..={MAX_TAXELS})", self.taxels)));
        }
        match &self.model {
            CalibratedForce::Forward { gains, positions, lag_s, gain_rel_sd, .. } => {
                if gain_rel_sd.is_some() && self.version < 5 {
                    return Err(invalid(format!(
                        "gain_rel_sd in a version-{} file (it came with version 5)",
                        self.version
                    )));
                }
                if gain_rel_sd.as_ref().is_some_and(|r| r.len() != self.taxels) {
                    return Err(invalid(format!("{} taxels but a gain_rel_sd of another length", self.taxels)));
                }
                if !LAG_RANGE_S.contains(lag_s) {
                    return Err(invalid(format!(
                        "lag_s {lag_s} (want {}..={} s)",
                        LAG_RANGE_S.start(),
                        LAG_RANGE_S.end()
                    )));
                }
                if gains.len() != self.taxels || positions.len() != self.taxels {
                    return Err(invalid(format!(
                        "{} taxels but {} gains and {} positions",
                        self.taxels,
                        gains.len(),
                        positions.len()
                    )));
                }
                if !positions.iter().flatten().all(|x| x.is_finite() && x.abs() <= 1e6) {
                    return Err(invalid("a position is not finite (or beyond 1e6 mm)".into()));
                }
                let (m, _) = self.model.forward().expect("a forward model");
                if !m.is_valid() {
                    return Err(invalid(
                        "a forward-model parameter is not finite or out of its bounds (gains within 1e9 counts, \
                         exponent 0.2–1.6, spread −0.3–0.7, width e^−0.7–e^2.5 mm, shape 1–2, lobe −0.7–1.5)"
                            .into(),
                    ));
                }
            }
            CalibratedForce::Placed { log_scale, sum_exponent, norm_exponent, width_mm, positions } => {
                if ![log_scale, sum_exponent, norm_exponent].iter().all(|x| x.is_finite()) {
                    return Err(invalid("a placed-law parameter is not finite".into()));
                }
                if !PLACE_WIDTH_RANGE_MM.contains(width_mm) {
                    return Err(invalid(format!(
                        "width_mm {width_mm} (want {}..={} mm)",
                        PLACE_WIDTH_RANGE_MM.start(),
                        PLACE_WIDTH_RANGE_MM.end()
                    )));
                }
                if positions.len() != self.taxels {
                    return Err(invalid(format!("{} taxels but {} positions", self.taxels, positions.len())));
                }
                if !positions.iter().flatten().all(|x| x.is_finite() && x.abs() <= 1e6) {
                    return Err(invalid("a position is not finite (or beyond 1e6 mm)".into()));
                }
            }
            CalibratedForce::Total { log_scale, sum_exponent, norm_exponent } => {
                if ![log_scale, sum_exponent, norm_exponent].iter().all(|x| x.is_finite()) {
                    return Err(invalid("a total-change parameter is not finite".into()));
                }
            }
            CalibratedForce::Ridge { intercept_n, weights, lambda } => {
                if weights.len() != self.taxels {
                    return Err(invalid(format!("{} taxels but {} weights", self.taxels, weights.len())));
                }
                if !(intercept_n.is_finite() && lambda.is_finite() && weights.iter().all(|w| w.is_finite())) {
                    return Err(invalid("a ridge parameter is not finite".into()));
                }
            }
            CalibratedForce::Area { curve } | CalibratedForce::Amplitude { curve } => {
                if let ForceModel::Isotonic { area_mm2, .. } = curve {
                    if area_mm2.len() > MAX_KNOTS {
                        return Err(invalid(format!("{} knots (at most {MAX_KNOTS})", area_mm2.len())));
                    }
                }
                curve.validate()?;
            }
        }
        let c = &self.calibration;
        if !c.force_range_n.iter().all(|f| f.is_finite()) || c.in_sample_mape_pct.is_nan() {
            return Err(invalid("calibration figures are not finite".into()));
        }
        Ok(())
    }

    /// Check the file against a sensor's layout (name and taxel count).
    pub fn check_layout(&self, layout: &gradtac_stream::Layout) -> Result<()> {
        if self.taxels != layout.len() {
            return Err(invalid(format!(
                "the model was calibrated on {} taxels ({}), the sensor's layout {} has {}",
                self.taxels,
                self.layout,
                layout.name(),
                layout.len()
            )));
        }
        Ok(())
    }
}

/// Ridge regression of `y` on features, accumulated one sample at a time (sums and the
/// cross-product matrix), solved on standardised features.
#[derive(Clone, Debug)]
pub struct RidgeAccumulator {
    n: usize,
    count: f64,
    sx: Vec<f64>,
    sxx: Vec<f64>,
    sy: f64,
    sxy: Vec<f64>,
}

impl RidgeAccumulator {
    /// For `n` features.
    pub fn new(n: usize) -> Self {
        RidgeAccumulator { n, count: 0.0, sx: vec![0.0; n], sxx: vec![0.0; n * n], sy: 0.0, sxy: vec![0.0; n] }
    }

    /// Samples so far.
    pub fn count(&self) -> u64 {
        self.count as u64
    }

    /// Add one sample (non-finite samples are skipped).
    pub fn push(&mut self, x: &[f64], y: f64) {
        if x.len() != self.n || !y.is_finite() || x.iter().any(|v| !v.is_finite()) {
            return;
        }
        self.count += 1.0;
        self.sy += y;
        for i in 0..self.n {
            self.sx[i] += x[i];
            self.sxy[i] += x[i] * y;
            for j in 0..=i {
                self.sxx[i * self.n + j] += x[i] * x[j];
            }
        }
    }

    /// Solve with penalty `lambda` (relative: `λ · count` on the standardised features):
    /// `(intercept, weights)`. `None` with fewer than two samples.
    pub fn solve(&self, lambda: f64) -> Option<(f64, Vec<f64>)> {
        let (n, m) = (self.n, self.count);
        if m < 2.0 || !(lambda.is_finite() && lambda >= 0.0) {
            return None;
        }
        let mean: Vec<f64> = self.sx.iter().map(|s| s / m).collect();
        let my = self.sy / m;
        let cov = |i: usize, j: usize| {
            let (a, b) = if j <= i { (i, j) } else { (j, i) };
            self.sxx[a * n + b] - m * mean[a] * mean[b]
        };
        let sd: Vec<f64> = (0..n).map(|i| (cov(i, i).max(0.0) / m).sqrt()).collect();
        let live: Vec<usize> = (0..n).filter(|&i| sd[i] > 1e-12 * (1.0 + mean[i].abs())).collect();
        let k = live.len();
        let mut a = vec![0.0; k * k];
        let mut b = vec![0.0; k];
        for (p, &i) in live.iter().enumerate() {
            for (q, &j) in live.iter().enumerate() {
                a[p * k + q] = cov(i, j) / (sd[i] * sd[j]);
            }
            a[p * k + p] += lambda * m + 1e-12 * m;
            b[p] = (self.sxy[i] - m * mean[i] * my) / sd[i];
        }
        let beta = cholesky_solve(&mut a, &b, k)?;
        let mut w = vec![0.0; n];
        for (p, &i) in live.iter().enumerate() {
            w[i] = beta[p] / sd[i];
        }
        let intercept = my - w.iter().zip(&mean).map(|(w, m)| w * m).sum::<f64>();
        Some((intercept, w))
    }
}

/// Solve `A x = b` for symmetric positive definite `A` (k × k, row-major; overwritten) by
/// Cholesky; `None` if `A` is not positive definite (the result may be non-finite).
pub(crate) fn cholesky_solve(a: &mut [f64], b: &[f64], k: usize) -> Option<Vec<f64>> {
    for j in 0..k {
        let mut d = a[j * k + j];
        for p in 0..j {
            d -= a[j * k + p] * a[j * k + p];
        }
        if d.is_nan() || d <= 0.0 {
            return None;
        }
        let d = d.sqrt();
        a[j * k + j] = d;
        for i in j + 1..k {
            let mut s = a[i * k + j];
            for p in 0..j {
                s -= a[i * k + p] * a[j * k + p];
            }
            a[i * k + j] = s / d;
        }
    }
    let mut y = vec![0.0; k];
    for i in 0..k {
        let mut s = b[i];
        for p in 0..i {
            s -= a[i * k + p] * y[p];
        }
        y[i] = s / a[i * k + i];
    }
    for i in (0..k).rev() {
        let mut s = y[i];
        for p in i + 1..k {
            s -= a[p * k + i] * y[p];
        }
        y[i] = s / a[i * k + i];
    }
    Some(y)
}

/// One calibration frame: the detector's changes and contact, the contour area (when the
/// contact location made one), and the gauge's force at the window's centre.
#[derive(Clone, Debug, PartialEq)]
pub struct GaugeSample {
    /// Signed changes (counts).
    pub change: Vec<f64>,
    /// The detector's contact decision.
    pub contact: bool,
    /// Contour area (mm²), when there is a contour.
    pub area_mm2: Option<f64>,
    /// The contact fit's amplitude, when the location is a fit.
    pub amplitude: Option<f64>,
    /// Time of the window's centre (s; NaN when unknown): the `forward` model's fluid-lag
    /// inverse reads the spacing of consecutive samples.
    pub time_s: f64,
    /// Measured force (N).
    pub force_n: f64,
}

/// Smallest gauge force a calibration sample needs (N): lighter frames are not used.
pub const MIN_CALIBRATION_N: f64 = 0.05;

/// How a `forward` calibration decides between the identified model and the `placed` law.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ForwardGuard {
    /// `placed` when the identified model's in-sample MAPE above 0.5 N is higher (session 31).
    InSample,
    /// `placed` when the identified model predicts held-aside presses worse: each contact run
    /// (a press) of the calibration is predicted by both methods fitted without it, and the
    /// pooled MAPE above 0.5 N of those predictions decides (fewer than 3 runs with a frame above
    /// 0.5 N: the in-sample decision).
    HeldAside,
}

/// The `forward` calibration's settings: where the identification starts and its guard.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ForwardSettings {
    /// The identification's starts.
    pub starts: Starts,
    /// The guard.
    pub guard: ForwardGuard,
}

impl Default for ForwardSettings {
    fn default() -> Self {
        ForwardSettings { starts: Starts::Multi, guard: ForwardGuard::HeldAside }
    }
}

/// Fit `method` on gauge samples (contact frames with at least [`MIN_CALIBRATION_N`]):
/// ridge with `lambda`, the area curve with `curve`. The error says why a fit is impossible.
///
/// **The `forward` guard:** a `forward` calibration also fits the `placed` law on the same
/// samples and returns the `placed` file instead when the identified model predicts the
/// calibration's contact runs (presses), each held aside and predicted by both methods fitted
/// on the others, worse than the two-number law does ([`ForwardGuard::HeldAside`], the default
/// since session 32; with fewer than 3 runs above 0.5 N, or with [`ForwardGuard::InSample`]:
/// when it explains its own calibration frames worse, session 31's guard). No tuned threshold.
/// The identification starts from [`Starts::Multi`] by default. The returned file's method says
/// which was written; [`calibrate_unguarded`] skips the guard. With the
/// [default settings](ForwardSettings::default); [`calibrate_with`] takes others
/// (`examples/force_parts/history.md`, sessions 31 and 32).
pub fn calibrate(
    samples: &[GaugeSample],
    method: CalibrationMethod,
    lambda: f64,
    curve: ForceMethod,
    layout: &gradtac_stream::Layout,
) -> Result<ForceFile> {
    calibrate_with(samples, method, lambda, curve, layout, ForwardSettings::default())
}

/// [`calibrate`] with the `forward` settings `fwd` (its starts and guard).
pub fn calibrate_with(
    samples: &[GaugeSample],
    method: CalibrationMethod,
    lambda: f64,
    curve: ForceMethod,
    layout: &gradtac_stream::Layout,
    fwd: ForwardSettings,
) -> Result<ForceFile> {
    let file = calibrate_unguarded_with(samples, method, lambda, curve, layout, fwd.starts)?;
    if method != CalibrationMethod::Forward {
        return Ok(file);
    }
    let Ok(placed) = calibrate_unguarded(samples, CalibrationMethod::Placed, lambda, curve, layout) else {
        return Ok(file);
    };
    if fwd.guard == ForwardGuard::HeldAside {
        let aside = |m| held_aside_mape_pct(samples, m, lambda, curve, layout, fwd.starts);
        if let (Some(f), Some(p)) = (aside(CalibrationMethod::Forward), aside(CalibrationMethod::Placed)) {
            return Ok(if f.is_finite() && f <= p { file } else { placed });
        }
    }
    Ok(forward_guard(file, placed))
}

/// Whether a sample is used for a calibration: a contact frame of a finite gauge force of at
/// least [`MIN_CALIBRATION_N`].
fn used_for_calibration(s: &GaugeSample) -> bool {
    s.contact && s.force_n >= MIN_CALIBRATION_N && s.force_n.is_finite()
}

/// Whether a calibration sample is scored: a contact frame of a finite gauge force above 0.5 N.
fn scored(s: &GaugeSample) -> bool {
    s.contact && s.force_n.is_finite() && s.force_n > 0.5
}

/// A scored sample's relative error for the prediction `p` (none: 1, i.e. 100 %).
fn relative_error(p: Option<f64>, s: &GaugeSample) -> f64 {
    p.map_or(1.0, |p| (p - s.force_n).abs() / s.force_n)
}

/// The pooled MAPE above 0.5 N (%) of `method` on each contact run (a press) of `samples`
/// predicted by `method` fitted on the other runs (a run it cannot be fitted without counts
/// 100 % per frame); `None` when fewer than 3 runs have a contact frame above 0.5 N.
pub fn held_aside_mape_pct(
    samples: &[GaugeSample],
    method: CalibrationMethod,
    lambda: f64,
    curve: ForceMethod,
    layout: &gradtac_stream::Layout,
    starts: Starts,
) -> Option<f64> {
    // each sample's run (0: no contact)
    let (mut runs, mut run, mut was) = (Vec::with_capacity(samples.len()), 0usize, false);
    for s in samples {
        if s.contact && !was {
            run += 1;
        }
        was = s.contact;
        runs.push(if s.contact { run } else { 0 });
    }
    let pressed: Vec<usize> =
        (1..=run).filter(|&r| samples.iter().zip(&runs).any(|(s, &k)| k == r && scored(s))).collect();
    if pressed.len() < 3 {
        return None;
    }
    let (mut sum, mut n) = (0.0, 0usize);
    for &r in &pressed {
        let train: Vec<GaugeSample> =
            samples.iter().zip(&runs).filter(|(_, &k)| k != r).map(|(s, _)| s.clone()).collect();
        let fitted = fit_model(&train, method, lambda, curve, layout, starts).ok();
        let mut predictor = fitted.as_ref().map(ForcePredictor::new);
        for (s, _) in samples.iter().zip(&runs).filter(|(_, &k)| k == r) {
            let p = predictor.as_mut().and_then(|p| p.push(s)).filter(|v| v.is_finite());
            if scored(s) {
                sum += relative_error(p, s);
                n += 1;
            }
        }
    }
    Some(100.0 * sum / n.max(1) as f64)
}

/// The `forward` guard's decision (see [`calibrate`]): `forward` unless it fits its own
/// calibration frames worse than `placed` (or its in-sample figure is not finite).
#[must_use]
pub fn forward_guard(forward: ForceFile, placed: ForceFile) -> ForceFile {
    let f = forward.calibration.in_sample_mape_pct;
    let p = placed.calibration.in_sample_mape_pct;
    if f.is_finite() && f <= p {
        forward
    } else {
        placed
    }
}

/// [`calibrate`] without the `forward` guard: the method asked for, whatever its fit.
pub fn calibrate_unguarded(
    samples: &[GaugeSample],
    method: CalibrationMethod,
    lambda: f64,
    curve: ForceMethod,
    layout: &gradtac_stream::Layout,
) -> Result<ForceFile> {
    calibrate_unguarded_with(samples, method, lambda, curve, layout, ForwardSettings::default().starts)
}

/// [`calibrate_unguarded`] with the `forward` identification's `starts`.
pub fn calibrate_unguarded_with(
    samples: &[GaugeSample],
    method: CalibrationMethod,
    lambda: f64,
    curve: ForceMethod,
    layout: &gradtac_stream::Layout,
    starts: Starts,
) -> Result<ForceFile> {
    let model = fit_model(samples, method, lambda, curve, layout, starts)?;
    let used: Vec<&GaugeSample> = samples.iter().filter(|s| used_for_calibration(s)).collect();
    let n = layout.len();
    let mut predictor = ForcePredictor::new(&model);
    let scored: Vec<f64> = samples
        .iter()
        .map(|s| (predictor.push(s), s))
        .filter(|(_, s)| scored(s))
        .map(|(p, s)| relative_error(p, s))
        .collect();
    let lo = used.iter().map(|s| s.force_n).fold(f64::INFINITY, f64::min);
    let hi = used.iter().map(|s| s.force_n).fold(f64::NEG_INFINITY, f64::max);
    let file = ForceFile {
        format: FORCE_FORMAT.into(),
        version: model.version(),
        layout: layout.name().to_string(),
        taxels: n,
        model,
        calibration: CalibrationInfo {
            samples: used.len() as u64,
            force_range_n: [lo, hi],
            in_sample_mape_pct: 100.0 * scored.iter().sum::<f64>() / scored.len().max(1) as f64,
        },
    };
    file.validate()?;
    Ok(file)
}

/// The model of `method` fitted on `samples` (see [`calibrate_unguarded_with`]), without the
/// in-sample score.
fn fit_model(
    samples: &[GaugeSample],
    method: CalibrationMethod,
    lambda: f64,
    curve: ForceMethod,
    layout: &gradtac_stream::Layout,
    starts: Starts,
) -> Result<CalibratedForce> {
    let used: Vec<&GaugeSample> = samples.iter().filter(|s| used_for_calibration(s)).collect();
    if used.len() < 10 {
        return Err(invalid(format!(
            "{} frames in contact with a gauge force ≥ {MIN_CALIBRATION_N} N (of {}); at least 10 are needed — \
             press the sensor while the gauge records",
            used.len(),
            samples.len()
        )));
    }
    let n = layout.len();
    if method.reads_changes() {
        if let Some(s) = used.iter().find(|s| s.change.len() != n) {
            return Err(invalid(format!("a sample of {} taxels, the layout has {n}", s.change.len())));
        }
    }
    let model = match method {
        CalibrationMethod::Forward => {
            let positions = layout.positions().to_vec();
            let geo = Geometry::for_positions(&positions);
            // the fluid lag is not identified (`lag_s` = 0): a grid of lags chosen by in-sample
            // fit scored a worse tuning worst member (36.5 % against 32.1 %, examples/force_parts/history.md)
            let tau = 0.0;
            let no_model = || {
                invalid(format!(
                    "the forward model could not be identified: it needs at least 10 frames in contact with a gauge \
                     force ≥ {} N that moved the taxels",
                    crate::force_ident::MIN_FORCE_N
                ))
            };
            // a press is a run of consecutive contact samples
            let mut press = 0usize;
            let mut was = false;
            let mut frames: Vec<(&[f64], f64, usize)> = Vec::new();
            for s in samples {
                if s.contact && !was {
                    press += 1;
                }
                was = s.contact;
                if used_for_calibration(s) {
                    frames.push((s.change.as_slice(), s.force_n, press));
                }
            }
            let m = identify_with(&geo, &frames, starts).ok_or_else(no_model)?;
            CalibratedForce::Forward {
                gains: m.gains,
                exponent: m.exponent,
                spread: m.spread,
                width_mm: m.width_mm,
                shape: m.shape,
                lobe: m.lobe,
                lag_s: tau,
                positions,
                gain_rel_sd: m.gain_rel_sd,
            }
        }
        CalibrationMethod::Placed => {
            let positions = layout.positions().to_vec();
            let w = DEFAULT_PLACE_WIDTH_MM;
            let mut acc = RidgeAccumulator::new(2);
            for s in &used {
                let (s1, s2) = total_change(&s.change);
                if s1 > 0.0 {
                    let r = place_response(&positions, &s.change, w).ln();
                    acc.push(&[s1.ln() - r, s2.ln() - r], s.force_n.ln());
                }
            }
            if acc.count() < 10 {
                return Err(invalid(format!(
                    "{} frames in contact moved the taxels; at least 10 are needed",
                    acc.count()
                )));
            }
            let (c, w2) = acc.solve(0.0).ok_or_else(|| invalid("the placed-law fit is singular".into()))?;
            CalibratedForce::Placed { log_scale: c, sum_exponent: w2[0], norm_exponent: w2[1], width_mm: w, positions }
        }
        CalibrationMethod::Total => {
            let mut acc = RidgeAccumulator::new(2);
            for s in &used {
                let (s1, s2) = total_change(&s.change);
                if s1 > 0.0 {
                    acc.push(&[s1.ln(), s2.ln()], s.force_n.ln());
                }
            }
            if acc.count() < 10 {
                return Err(invalid(format!(
                    "{} frames in contact moved the taxels; at least 10 are needed",
                    acc.count()
                )));
            }
            let (c, w) = acc.solve(0.0).ok_or_else(|| invalid("the total-change fit is singular".into()))?;
            CalibratedForce::Total { log_scale: c, sum_exponent: w[0], norm_exponent: w[1] }
        }
        CalibrationMethod::Ridge => {
            let mut acc = RidgeAccumulator::new(n);
            for s in &used {
                acc.push(&s.change, s.force_n);
            }
            let (intercept_n, weights) =
                acc.solve(lambda).ok_or_else(|| invalid("the ridge system is singular".into()))?;
            CalibratedForce::Ridge { intercept_n, weights, lambda }
        }
        CalibrationMethod::Area | CalibrationMethod::Amplitude => {
            let x = |s: &GaugeSample| if method == CalibrationMethod::Area { s.area_mm2 } else { s.amplitude };
            // a power law is 0 at x ≤ 0 (a single-taxel centroid has no area): fitted on x > 0
            let pairs: Vec<ForceSample> = used
                .iter()
                .filter_map(|s| x(s).map(|a| ForceSample { area_mm2: a, force_n: s.force_n }))
                .filter(|p| curve != ForceMethod::PowerLaw || p.area_mm2 > 0.0)
                .collect();
            let c = ForceModel::fit(curve, &pairs)?;
            if method == CalibrationMethod::Area {
                CalibratedForce::Area { curve: c }
            } else {
                CalibratedForce::Amplitude { curve: c }
            }
        }
    };
    Ok(model)
}

/// Force from the changes (see the [module docs](self)): raw frames in, one
/// [`ForceEstimate`] per frame (`area_mm2` is NaN: this model reads no contour).
#[derive(Clone, Debug)]
#[must_use = "a stage does nothing until inputs are pushed"]
pub struct ChangeForce {
    det: ChangeDetector,
    model: CalibratedForce,
    predictor: ForcePredictor,
}

impl ChangeForce {
    /// The stage for a validated file whose model reads changes, with the detector settings
    /// of `locate` (validated). When the file names a built-in layout
    /// ([`Layout::builtin`](gradtac_stream::Layout::builtin)) of its taxel count, the detector
    /// gets that layout's positions, which the gate's drift-shape return needs
    /// ([`FORCE_GATE`]); for another layout give them with [`with_positions`](Self::with_positions)
    /// (without them that return is off).
    pub fn try_new(file: &ForceFile, locate: &LocateConfig) -> Result<Self> {
        file.validate()?;
        if !file.model.reads_changes() {
            return Err(invalid(format!(
                "the {} model reads contours, not raw frames (use the contour force stage)",
                file.model.method().name()
            )));
        }
        let mut det = force_detector(file.taxels, locate)?;
        if let Ok(layout) = gradtac_stream::Layout::builtin(&file.layout) {
            if layout.len() == file.taxels {
                det = det.with_positions(layout.positions())?;
            }
        }
        Ok(ChangeForce { det, model: file.model.clone(), predictor: ForcePredictor::new(&file.model) })
    }

    /// The taxels' positions (mm) for the drift model's shape test
    /// ([`ChangeDetector::with_positions`]; the scene's chain gives its layout's, which replace
    /// a built-in layout's that [`try_new`](Self::try_new) attached).
    pub fn with_positions(mut self, positions: &[[f64; 2]]) -> Result<Self> {
        self.det = self.det.with_positions(positions)?;
        Ok(self)
    }

    /// Measure against a stored untouched baseline.
    pub fn with_tare(mut self, tare: &crate::tare::Tare) -> Result<Self> {
        self.det = self.det.with_tare(tare)?;
        Ok(self)
    }

    /// The model.
    pub fn model(&self) -> &CalibratedForce {
        &self.model
    }

    /// The change detector.
    pub fn detector(&self) -> &ChangeDetector {
        &self.det
    }
}

impl Stage for ChangeForce {
    type In = TaxelFrame;
    type Out = ForceEstimate;
    type Error = Error;

    fn push(&mut self, f: TaxelFrame, out: &mut Vec<ForceEstimate>) -> Result<()> {
        let ch = self.det.push(&f, STAGE)?;
        let sample = GaugeSample {
            change: self.det.change().to_vec(),
            contact: ch.contact,
            area_mm2: None,
            amplitude: None,
            force_n: f64::NAN,
            time_s: 0.5 * (ch.start.as_secs_f64() + ch.end.as_secs_f64()),
        };
        let force_n = self.predictor.push(&sample);
        out.push(ForceEstimate { sensor: f.sensor, time: f.time, seq: f.seq, area_mm2: f64::NAN, force_n });
        Ok(())
    }

    fn reset(&mut self) {
        self.det.reset();
        self.predictor.reset();
    }

    fn delay(&self) -> Delay {
        Delay::frames(u64::from((self.det.config().window_frames - 1) / 2))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gradtac_stream::{Layout, StageExt, Timestamp};

    #[test]
    fn ridge_recovers_a_linear_law_and_the_penalty_shrinks() {
        let mut acc = RidgeAccumulator::new(3);
        for k in 0..200 {
            let x = [k as f64 % 7.0, (k * k) as f64 % 11.0, 5.0];
            acc.push(&x, 1.0 + 0.5 * x[0] - 0.25 * x[1]);
        }
        let (b, w) = acc.solve(0.0).unwrap();
        assert!((b - 1.0).abs() < 1e-6 && (w[0] - 0.5).abs() < 1e-8 && (w[1] + 0.25).abs() < 1e-8, "{b} {w:?}");
        assert_eq!(w[2], 0.0); // constant feature: no weight
        let (_, ws) = acc.solve(10.0).unwrap();
        assert!(ws[0].abs() < 0.5 * w[0].abs());
        assert!(RidgeAccumulator::new(2).solve(0.0).is_none());
    }

    fn file() -> ForceFile {
        ForceFile {
            format: FORCE_FORMAT.into(),
            version: FORCE_VERSION,
            layout: "biotac-sp".into(),
            taxels: 2,
            model: CalibratedForce::Ridge { intercept_n: 0.0, weights: vec![-0.01, 0.0], lambda: 0.0 },
            calibration: CalibrationInfo { samples: 10, force_range_n: [0.1, 5.0], in_sample_mape_pct: 3.0 },
        }
    }

    #[test]
    fn a_file_of_a_built_in_layout_gives_the_gate_its_positions() {
        // the drift-shape return of the gate needs positions: a file of the built-in layout
        // gets them at construction; another layout (or a taxel count that does not match)
        // runs without them until `with_positions`
        let sp = ForceFile {
            taxels: 24,
            model: CalibratedForce::Ridge { intercept_n: 0.0, weights: vec![-0.01; 24], lambda: 0.0 },
            ..file()
        };
        let f = ChangeForce::try_new(&sp, &LocateConfig::default()).unwrap();
        assert_eq!(f.detector().positions(), Some(gradtac_stream::Layout::biotac_sp().positions()));
        let custom = ForceFile { layout: "my-hand".into(), ..sp.clone() };
        let f = ChangeForce::try_new(&custom, &LocateConfig::default()).unwrap();
        assert!(f.detector().positions().is_none());
        let f = f.with_positions(gradtac_stream::Layout::biotac_sp().positions()).unwrap();
        assert!(f.detector().positions().is_some());
        // `file()`: the built-in name with 2 taxels, not its 24
        assert!(ChangeForce::try_new(&file(), &LocateConfig::default()).unwrap().detector().positions().is_none());
    }

    /// Samples whose gauge force is an exact power law of the total change.
    fn power_law_samples() -> Vec<GaugeSample> {
        (0..60)
            .map(|k| {
                let a = 1.0 + k as f64;
                // patterns of changing shape (so S₁ and S₂ are not proportional), mixed signs
                let change: Vec<f64> = (0..24)
                    .map(|i| if i < 3 + k % 5 { -a * (1.0 + i as f64) } else { 0.1 * a * (i % 3) as f64 })
                    .collect();
                let (s1, s2) = total_change(&change);
                let force_n = (-3.0 + 0.8 * s1.ln() + 0.3 * s2.ln()).exp();
                GaugeSample { change, contact: true, area_mm2: None, amplitude: None, force_n, time_s: f64::NAN }
            })
            .collect()
    }

    #[test]
    fn placed_recovers_its_own_law_exactly() {
        let layout = Layout::biotac_sp();
        let mut s = power_law_samples();
        for x in &mut s {
            let (s1, s2) = total_change(&x.change);
            let r = place_response(layout.positions(), &x.change, DEFAULT_PLACE_WIDTH_MM).ln();
            x.force_n = (-2.0 + 0.7 * (s1.ln() - r) + 0.2 * (s2.ln() - r)).exp();
        }
        let file = calibrate(&s, CalibrationMethod::Placed, 0.0, ForceMethod::Linear, &layout).unwrap();
        assert_eq!(file.version, 3, "a placed file is version 3");
        let CalibratedForce::Placed { log_scale, sum_exponent, norm_exponent, width_mm, ref positions } = file.model
        else {
            panic!()
        };
        assert!((log_scale + 2.0).abs() < 1e-9 && (sum_exponent - 0.7).abs() < 1e-9, "{log_scale} {sum_exponent}");
        assert!((norm_exponent - 0.2).abs() < 1e-9 && width_mm == DEFAULT_PLACE_WIDTH_MM);
        assert_eq!(positions.as_slice(), layout.positions());
        assert!(file.calibration.in_sample_mape_pct < 1e-6);
        for x in &s {
            let p = file.model.predict_sample(x).unwrap();
            assert!((p - x.force_n).abs() < 1e-9 * x.force_n, "{p} {}", x.force_n);
        }
        // the file round-trips; no change is no force; NaN in, NaN out
        let json = serde_json::to_string(&file).unwrap();
        assert_eq!(serde_json::from_str::<ForceFile>(&json).unwrap(), file);
        assert_eq!(file.model.predict_changes(&[0.0; 24]), Some(0.0));
        assert!(file.model.predict_changes(&[f64::NAN; 24]).unwrap().is_nan());
        // validation: width, positions
        let bad = |m: CalibratedForce| ForceFile { model: m, ..file.clone() }.validate().is_err();
        let placed = |w: f64, p: Vec<[f64; 2]>| CalibratedForce::Placed {
            log_scale: 0.0,
            sum_exponent: 1.0,
            norm_exponent: 0.0,
            width_mm: w,
            positions: p,
        };
        let pos = layout.positions().to_vec();
        assert!(!bad(placed(2.5, pos.clone())));
        assert!(bad(placed(0.0, pos.clone())) && bad(placed(f64::NAN, pos.clone())) && bad(placed(1e9, pos.clone())));
        assert!(bad(placed(2.5, pos[..23].to_vec())));
        let mut inf = pos.clone();
        inf[3][1] = f64::INFINITY;
        assert!(bad(placed(2.5, inf)));
    }

    /// A Gaussian press of amplitude `a` and width `w` at `x` on `positions`.
    fn gaussian_press(positions: &[[f64; 2]], x: [f64; 2], a: f64, w: f64) -> Vec<f64> {
        positions
            .iter()
            .map(|p| -a * (-((p[0] - x[0]).powi(2) + (p[1] - x[1]).powi(2)) / (2.0 * w * w)).exp())
            .collect()
    }

    #[test]
    fn place_normalisation_is_exact_where_the_press_is_symmetric() {
        // a square grid of 4 mm pitch; a press on an electrode (strongly coupled) and one at the
        // centre of a cell (between four electrodes, weakly coupled): same force, same amplitude
        let grid = |xs: &[f64]| -> Vec<[f64; 2]> { xs.iter().flat_map(|&y| xs.iter().map(move |&x| [x, y])).collect() };
        let on = grid(&[-4.0, 0.0, 4.0]); // pressed at (0, 0), an electrode
        let between = grid(&[-6.0, -2.0, 2.0, 6.0]); // pressed at (0, 0), between electrodes
        let w = 1.5;
        let (a_on, a_between) =
            (gaussian_press(&on, [0.0, 0.0], 100.0, w), gaussian_press(&between, [0.0, 0.0], 100.0, w));
        let (s_on, s_between) = (total_change(&a_on).0, total_change(&a_between).0);
        assert!(s_on > 1.2 * s_between, "the electrode sees more: {s_on} {s_between}");
        // S₁ / R(x̂) is the amplitude itself at both places (the centroid is the place)
        for (pos, d) in [(&on, &a_on), (&between, &a_between)] {
            let r = place_response(pos, d, w);
            assert!((total_change(d).0 / r - 100.0).abs() < 1e-9, "{}", total_change(d).0 / r);
        }
        // so a `placed` model (p = 1, q = 0) reads the same force at both places
        let model = |p: &Vec<[f64; 2]>| CalibratedForce::Placed {
            log_scale: (0.05f64).ln(),
            sum_exponent: 1.0,
            norm_exponent: 0.0,
            width_mm: w,
            positions: p.clone(),
        };
        let f_on = model(&on).predict_changes(&a_on).unwrap();
        let f_between = model(&between).predict_changes(&a_between).unwrap();
        assert!((f_on - 5.0).abs() < 1e-9 && (f_between - 5.0).abs() < 1e-9, "{f_on} {f_between}");
        // an all-zero change: the normaliser is 1, not a division by zero
        assert_eq!(place_response(&on, &[0.0; 9], w), 1.0);
        assert_eq!(place_response(&on, &[f64::NAN; 9], w), 1.0);
        // a far place still gives a finite, positive normaliser
        let far = gaussian_press(&on, [1e5, 0.0], 1.0, w);
        assert!(place_response(&on, &far, w) >= 1e-6);
    }

    #[test]
    fn total_recovers_a_power_law_exactly() {
        let s = power_law_samples();
        let file = calibrate(&s, CalibrationMethod::Total, 0.0, ForceMethod::Linear, &Layout::biotac_sp()).unwrap();
        let CalibratedForce::Total { log_scale, sum_exponent, norm_exponent } = file.model else { panic!() };
        assert!((log_scale + 3.0).abs() < 1e-9, "{log_scale}");
        assert!((sum_exponent - 0.8).abs() < 1e-9 && (norm_exponent - 0.3).abs() < 1e-9);
        assert!(file.calibration.in_sample_mape_pct < 1e-6, "{:?}", file.calibration);
        // no change, no force; a NaN change is passed on as NaN (the detector refuses NaN input)
        assert_eq!(file.model.predict_changes(&[0.0; 24]), Some(0.0));
        assert!(file.model.predict_changes(&[f64::NAN; 24]).unwrap().is_nan());
        // the file round-trips and a non-finite parameter is refused
        let json = serde_json::to_string(&file).unwrap();
        assert!(json.contains(r#""method":"total""#), "{json}");
        assert_eq!(serde_json::from_str::<ForceFile>(&json).unwrap(), file);
        let bad = ForceFile {
            model: CalibratedForce::Total { log_scale: f64::INFINITY, sum_exponent: 1.0, norm_exponent: 0.0 },
            ..file
        };
        assert!(bad.validate().is_err());
    }

    #[test]
    fn total_refuses_too_few_moving_frames() {
        let mut s = power_law_samples();
        s.iter_mut().for_each(|x| x.change = vec![0.0; 24]);
        let e = calibrate(&s, CalibrationMethod::Total, 0.0, ForceMethod::Linear, &Layout::biotac_sp()).unwrap_err();
        assert!(e.to_string().contains("moved"), "{e}");
        assert_eq!(CalibrationMethod::parse("total"), Some(CalibrationMethod::Total));
        assert_eq!(DEFAULT_METHOD, CalibrationMethod::Forward);
        assert_eq!(CalibrationMethod::parse("placed"), Some(CalibrationMethod::Placed));
    }

    #[test]
    fn the_total_stage_reports_no_force_on_constant_input_and_refuses_nan() {
        let file =
            calibrate(&power_law_samples(), CalibrationMethod::Total, 0.0, ForceMethod::Linear, &Layout::biotac_sp())
                .unwrap();
        let mut s = ChangeForce::try_new(&file, &LocateConfig::default()).unwrap();
        let frame = |k: u64, v: f64| TaxelFrame::new("ff".into(), Timestamp::at_rate(k, 100.0), k, vec![v; 24]);
        let out = s.run_all((0..300).map(|k| frame(k, 2000.0))).unwrap();
        assert!(out.iter().all(|e| e.force_n.is_none()));
        let mut bad = frame(300, 2000.0);
        bad.values[7] = f64::NAN;
        let mut sink = Vec::new();
        let e = s.push(bad, &mut sink).unwrap_err();
        assert!(e.to_string().contains("300") || e.to_string().contains("7"), "{e}");
    }

    /// Gauge samples drawn from a `forward` model: presses at three places, ramps 0.3..8 N,
    /// a frame without contact between presses.
    fn forward_samples() -> Vec<GaugeSample> {
        let geo = Geometry::for_positions(Layout::biotac_sp().positions());
        let m = ForwardModel {
            gains: vec![-60.0; 24],
            exponent: 0.7,
            spread: 0.2,
            width_mm: 3.0,
            shape: 2.0,
            lobe: 0.2,
            gain_rel_sd: None,
        };
        let mut out = Vec::new();
        for (j, p) in [[-5.0, -3.0], [4.0, 2.0], [0.0, 5.0]].iter().enumerate() {
            for k in 0..30 {
                let f = 0.3 + 7.7 * k as f64 / 29.0;
                let t = (j * 31 + k) as f64 * 0.01;
                out.push(GaugeSample {
                    change: m.predict(&geo, p[0], p[1], f),
                    contact: true,
                    area_mm2: None,
                    amplitude: None,
                    force_n: f,
                    time_s: t,
                });
            }
            out.push(GaugeSample {
                change: vec![0.0; 24],
                contact: false,
                area_mm2: None,
                amplitude: None,
                force_n: 0.0,
                time_s: (j * 31 + 30) as f64 * 0.01,
            });
        }
        out
    }

    /// The `forward` guard: a `forward` file that fits its own calibration worse than the
    /// `placed` law (or not at all) is replaced by the `placed` file; one that fits better stays.
    #[test]
    fn the_forward_guard_falls_back_to_placed_when_the_identification_fits_worse() {
        let layout = Layout::biotac_sp();
        let fwd = calibrate(&forward_samples(), CalibrationMethod::Forward, 0.0, ForceMethod::Linear, &layout).unwrap();
        assert_eq!(fwd.model.method(), CalibrationMethod::Forward, "its own model: the guard keeps it");
        let placed =
            calibrate(&forward_samples(), CalibrationMethod::Placed, 0.0, ForceMethod::Linear, &layout).unwrap();
        assert!(fwd.calibration.in_sample_mape_pct <= placed.calibration.in_sample_mape_pct);
        for worse in [placed.calibration.in_sample_mape_pct + 1.0, f64::NAN, f64::INFINITY] {
            let mut bad = fwd.clone();
            bad.calibration.in_sample_mape_pct = worse;
            assert_eq!(forward_guard(bad, placed.clone()), placed, "in-sample {worse}");
        }
        // samples of a law the forward model does not describe: with the in-sample guard whatever
        // is written fits its own calibration no worse than `placed`, and is valid
        let s = power_law_samples();
        let in_sample = ForwardSettings { guard: ForwardGuard::InSample, ..ForwardSettings::default() };
        let file =
            calibrate_with(&s, CalibrationMethod::Forward, 0.0, ForceMethod::Linear, &layout, in_sample).unwrap();
        let raw = calibrate_unguarded_with(
            &s,
            CalibrationMethod::Forward,
            0.0,
            ForceMethod::Linear,
            &layout,
            in_sample.starts,
        );
        let placed = calibrate(&s, CalibrationMethod::Placed, 0.0, ForceMethod::Linear, &layout).unwrap();
        assert!(file.calibration.in_sample_mape_pct <= placed.calibration.in_sample_mape_pct + 1e-9);
        file.validate().unwrap();
        if let Ok(raw) = raw {
            let chose_placed = file.model.method() == CalibrationMethod::Placed;
            assert_eq!(chose_placed, raw.calibration.in_sample_mape_pct > placed.calibration.in_sample_mape_pct);
        }
    }

    /// The held-aside-press guard (the default since session 32): each contact run is
    /// predicted by both methods fitted without it; `forward` stays when its pooled error is no
    /// higher; with fewer than 3 runs above 0.5 N the in-sample guard decides.
    #[test]
    fn the_held_aside_guard_predicts_each_press_from_the_others() {
        let layout = Layout::biotac_sp();
        let fwd = ForwardSettings::default();
        assert_eq!(fwd, ForwardSettings { starts: Starts::Multi, guard: ForwardGuard::HeldAside });
        let aside = |s: &[GaugeSample], m| held_aside_mape_pct(s, m, 0.0, ForceMethod::Linear, &layout, fwd.starts);
        // its own model, three presses at three places: the forward model predicts a press it
        // never saw (the third place's electrodes keep the prior gain, here the true one)
        let s = forward_samples();
        let (f, p) = (aside(&s, CalibrationMethod::Forward).unwrap(), aside(&s, CalibrationMethod::Placed).unwrap());
        assert!(f < 5.0 && f < p, "held aside: forward {f} %, placed {p} %");
        let file = calibrate(&s, CalibrationMethod::Forward, 0.0, ForceMethod::Linear, &layout).unwrap();
        assert_eq!(file.model.method(), CalibrationMethod::Forward);
        // a law the forward model does not describe: the written file is the one with the lower
        // held-aside error
        let s: Vec<GaugeSample> = forward_samples()
            .into_iter()
            .map(|mut g| {
                g.force_n = 0.1 * g.force_n * g.force_n + 0.3 * g.force_n.sqrt();
                g
            })
            .collect();
        let file = calibrate(&s, CalibrationMethod::Forward, 0.0, ForceMethod::Linear, &layout).unwrap();
        file.validate().unwrap();
        let (f, p) = (aside(&s, CalibrationMethod::Forward).unwrap(), aside(&s, CalibrationMethod::Placed).unwrap());
        assert!(f.is_finite() && p.is_finite());
        assert_eq!(file.model.method() == CalibrationMethod::Placed, f > p, "forward {f} %, placed {p} %");
        // two presses: no held-aside figure, the in-sample guard's file
        let two: Vec<GaugeSample> = forward_samples().into_iter().take(62).collect();
        assert!(aside(&two, CalibrationMethod::Forward).is_none());
        let in_sample = ForwardSettings { guard: ForwardGuard::InSample, ..fwd };
        assert_eq!(
            calibrate(&two, CalibrationMethod::Forward, 0.0, ForceMethod::Linear, &layout).unwrap(),
            calibrate_with(&two, CalibrationMethod::Forward, 0.0, ForceMethod::Linear, &layout, in_sample).unwrap()
        );
        // a run the method cannot be fitted without counts 100 % per frame, never a panic
        let few: Vec<GaugeSample> = forward_samples().into_iter().take(40).collect();
        assert!(aside(&few, CalibrationMethod::Forward).is_none_or(|v| v.is_finite()));
    }

    #[test]
    fn forward_files_are_version_5_fit_their_own_model_and_survive_garbage() {
        let layout = Layout::biotac_sp();
        let file =
            calibrate(&forward_samples(), CalibrationMethod::Forward, 0.0, ForceMethod::Linear, &layout).unwrap();
        assert_eq!(file.version, 5, "a forward file with gain doubts is version 5");
        let CalibratedForce::Forward { gain_rel_sd: Some(r), .. } = &file.model else { panic!("gain doubts stored") };
        assert_eq!(r.len(), 24);
        assert!(file.calibration.in_sample_mape_pct < 5.0, "{:?}", file.calibration);
        let json = serde_json::to_string(&file).unwrap();
        assert_eq!(serde_json::from_str::<ForceFile>(&json).unwrap(), file);
        // older versions still load; a newer one is refused by its version
        let placed =
            calibrate(&power_law_samples(), CalibrationMethod::Placed, 0.0, ForceMethod::Linear, &layout).unwrap();
        assert_eq!(placed.version, 3);
        placed.validate().unwrap();
        assert!(ForceFile { version: 6, ..file.clone() }.validate().unwrap_err().to_string().contains("version 6"));
        // a version-4 forward file (no gain doubts) loads, is written back as version 4 without
        // the field, and reads exactly what the unweighted inversion reads
        let mut v4: serde_json::Value = serde_json::to_value(&file).unwrap();
        v4["version"] = 4.into();
        v4["model"].as_object_mut().unwrap().remove("gain_rel_sd");
        let old: ForceFile = serde_json::from_value(v4).unwrap();
        old.validate().unwrap();
        let CalibratedForce::Forward { gain_rel_sd: None, .. } = &old.model else { panic!("no gain doubts") };
        assert_eq!(old.model.version(), 4);
        assert!(!serde_json::to_string(&old).unwrap().contains("gain_rel_sd"));
        let (m, geo) = file.model.forward().unwrap();
        let bare = ForwardModel { gain_rel_sd: None, ..m.clone() };
        let mut differ = 0;
        for s in forward_samples().iter().filter(|s| s.contact).step_by(5) {
            let o = old.model.predict_changes(&s.change).unwrap();
            assert_eq!(o.to_bits(), forward_force(&bare, &geo, &s.change).to_bits());
            let n = file.model.predict_changes(&s.change).unwrap();
            assert_eq!(n.to_bits(), forward_force(&m, &geo, &s.change).to_bits());
            differ += usize::from(o != n);
        }
        assert!(differ > 0, "the gain doubts weigh the inversion");
        // gain doubts in a version-4 file, or of another length, are refused
        assert!(ForceFile { version: 4, ..file.clone() }.validate().unwrap_err().to_string().contains("version-4"));
        let mut short = file.clone();
        if let CalibratedForce::Forward { gain_rel_sd, .. } = &mut short.model {
            *gain_rel_sd = Some(vec![0.1; 3]);
        }
        assert!(short.validate().is_err());
        let mut nan = file.clone();
        if let CalibratedForce::Forward { gain_rel_sd, .. } = &mut nan.model {
            *gain_rel_sd = Some(vec![f64::NAN; 24]);
        }
        assert!(nan.validate().is_err());
        // out-of-bounds parameters are refused
        let CalibratedForce::Forward { gains, positions, .. } = file.model.clone() else { panic!() };
        for bad in [
            CalibratedForce::Forward {
                gains: gains.clone(),
                exponent: f64::NAN,
                spread: 0.2,
                width_mm: 3.0,
                shape: 2.0,
                lobe: 0.0,
                lag_s: 0.0,
                positions: positions.clone(),
                gain_rel_sd: None,
            },
            CalibratedForce::Forward {
                gains: gains.clone(),
                exponent: 0.7,
                spread: 0.2,
                width_mm: 3.0,
                shape: 2.0,
                lobe: 0.0,
                lag_s: -1.0,
                positions: positions.clone(),
                gain_rel_sd: None,
            },
            CalibratedForce::Forward {
                gains: gains[..3].to_vec(),
                exponent: 0.7,
                spread: 0.2,
                width_mm: 3.0,
                shape: 2.0,
                lobe: 0.0,
                lag_s: 0.0,
                positions: positions.clone(),
                gain_rel_sd: None,
            },
        ] {
            assert!(ForceFile { model: bad, ..file.clone() }.validate().is_err());
        }
        // predictions: NaN in, NaN out; no change, no force; the lag inverse needs a time
        assert!(file.model.predict_changes(&[f64::NAN; 24]).unwrap().is_nan());
        assert_eq!(file.model.predict_changes(&[0.0; 24]), Some(0.0));
        assert!(file.model.predict_changes(&[1.0; 3]).unwrap().is_nan());
        let mut lagged = file.clone();
        if let CalibratedForce::Forward { lag_s, .. } = &mut lagged.model {
            *lag_s = 0.05;
        }
        let mut p = ForcePredictor::new(&lagged.model);
        for s in forward_samples().iter().take(5) {
            let f = p.push(&GaugeSample { time_s: f64::NAN, ..s.clone() }).unwrap();
            assert!(f.is_finite());
        }
        // the stage: constant input gives no force, NaN is an error naming where, never a panic
        let mut s = ChangeForce::try_new(&file, &LocateConfig::default()).unwrap();
        let frame = |k: u64, v: f64| TaxelFrame::new("ff".into(), Timestamp::at_rate(k, 100.0), k, vec![v; 24]);
        let out = s.run_all((0..300).map(|k| frame(k, 2000.0))).unwrap();
        assert!(out.iter().all(|e| e.force_n.is_none()));
        let mut bad = frame(300, 2000.0);
        bad.values[7] = f64::NAN;
        assert!(s.push(bad, &mut Vec::new()).is_err());
        let mut huge = frame(301, 1e300);
        huge.values[3] = -1e300;
        let _ = s.push(huge, &mut Vec::new());
    }

    /// Two taxels at 100 Hz with ±1 count alternating noise; `press(k)` counts are subtracted
    /// from taxel 1 at frame `k`.
    fn two_taxels(k: u64, press: f64) -> TaxelFrame {
        two_taxels_with_noise(k, press, if k % 2 == 0 { 1.0 } else { -1.0 })
    }

    /// Frames of a quiet sensor (σ √2: ±1 alternation) whose taxels 0–3 drift at ±2 counts/s
    /// while taxel 4 is pressed (a 4 s, 150-count plateau every 4.6 s after 1 s of rest), as
    /// the stuck tuning-side members 201/212 of `examples/force_parts/history.md` (session 33, second round).
    fn drifting_quiet_presses(k: u64) -> (TaxelFrame, bool) {
        let t = k as f64 / 100.0;
        let e = if k % 2 == 0 { 1.0 } else { -1.0 };
        let phase = (t - 1.0).rem_euclid(4.6);
        let pressed = t >= 1.0 && phase < 4.0;
        let press = if pressed { 150.0 } else { 0.0 };
        let v = vec![
            1000.0 + 2.0 * t + e,
            2000.0 - 2.0 * t - e,
            1500.0 + 1.5 * t + e,
            1800.0 - 1.5 * t - e,
            2500.0 + press + e,
        ];
        (TaxelFrame::new("ff".into(), Timestamp::at_rate(k, 100.0), k, v), pressed)
    }

    #[test]
    fn quiet_taxels_follow_their_drift_through_a_press() {
        // with the current gate the quiet taxels lag their drift (follow_s 2 s: 4 counts at
        // 2 counts/s, beyond 2 σ), escape, and the rests after the presses stay in contact;
        // with `quiet_taxel_s` they follow through the presses and every rest is untouched
        let count = |gate: DriftModel| {
            let mut det = ChangeDetector::try_new(5, &LocateConfig::default()).unwrap().with_drift_model(gate).unwrap();
            let (mut rest_contact, mut press_missed) = (0usize, 0usize);
            for k in 0..4700u64 {
                let (f, pressed) = drifting_quiet_presses(k);
                let c = det.push(&f, "t").unwrap();
                let phase = (k as f64 / 100.0 - 1.0).rem_euclid(4.6);
                // the last 0.3 s of each rest, and the press's plateau after its first 0.1 s
                if k >= 100 && !pressed && phase >= 4.3 {
                    rest_contact += usize::from(c.contact);
                }
                if pressed && phase >= 0.1 {
                    press_missed += usize::from(!c.contact);
                }
            }
            (rest_contact, press_missed)
        };
        let (old_rest, old_missed) = count(FORCE_GATE);
        let (new_rest, new_missed) = count(DriftModel { quiet_taxel_s: 0.3, ..FORCE_GATE });
        assert_eq!(
            (new_rest, new_missed),
            (0, 0),
            "quiet taxels followed (old gate: {old_rest} rest frames in contact)"
        );
        // the defect this setting addresses (measured: 16 of the 300 rest frames in contact)
        assert!(old_rest >= 10 && old_missed == 0, "the current gate: {old_rest}, {old_missed}");
        for bad in [-0.1, 61.0, f64::NAN, f64::INFINITY] {
            assert!(DriftModel { quiet_taxel_s: bad, ..FORCE_GATE }.validate().is_err(), "{bad}");
        }
    }

    /// [`two_taxels`] with the noise `e` (added to taxel 0, subtracted from taxel 1) at frame `k`.
    fn two_taxels_with_noise(k: u64, press: f64, e: f64) -> TaxelFrame {
        TaxelFrame::new("ff".into(), Timestamp::at_rate(k, 100.0), k, vec![1000.0 + e, 2000.0 - press - e])
    }

    #[test]
    fn the_gate_does_not_absorb_a_light_press_below_the_contact_threshold() {
        // a light press: a 2 s ramp to 8 counts (≈ 5 σ of one frame, below the 10 σ contact
        // threshold), held 1.5 s, lifted over 1 s, then 3 s at rest
        let press = |k: u64| match k {
            0..=299 => 0.0,
            300..=499 => 8.0 * (k - 300) as f64 / 200.0,
            500..=649 => 8.0,
            650..=749 => 8.0 * (750 - k) as f64 / 100.0,
            _ => 0.0,
        };
        let cfg = LocateConfig::default();
        let mut gate = force_detector(2, &cfg).unwrap();
        let mut s29 = force_detector_s29(2, &cfg).unwrap();
        let (mut held_gate, mut held_s29) = (f64::INFINITY, f64::INFINITY);
        let mut contact_in_hold = 0;
        for k in 0..1050u64 {
            let f = two_taxels(k, press(k));
            let a = gate.push(&f, "t").unwrap();
            s29.push(&f, "t").unwrap();
            if (560..650).contains(&k) {
                // how much of the press the change still shows at the end of its hold
                held_gate = held_gate.min(-gate.change()[1]);
                held_s29 = held_s29.min(-s29.change()[1]);
                contact_in_hold += usize::from(a.contact);
            }
            if k >= 900 {
                assert!(!a.contact, "frame {k}: the lift read as a contact");
                assert!(gate.change()[1].abs() < 2.0, "frame {k}: {:?}", gate.change());
            }
        }
        eprintln!("the press's 8 counts at the end of its hold: gate {held_gate:.2}, session 29 {held_s29:.2}");
        assert!(held_gate > 5.0, "the gate absorbed the press: {held_gate}");
        assert!(held_s29 < 0.5 * held_gate, "the session-29 model kept it: {held_s29}");
        // held beyond 2 σ: a contact by the hold although below 10 σ
        assert_eq!(contact_in_hold, 90);
    }

    #[test]
    fn a_contact_returns_and_its_residual_settles() {
        // a 200-count press; after it the taxel rests 6 counts off its old level (a residual
        // the drift slope did not predict)
        let press = |k: u64| match k {
            0..=299 => 0.0,
            300..=599 => 200.0,
            _ => 6.0,
        };
        let mut gate = force_detector(2, &LocateConfig::default()).unwrap();
        for k in 0..1000u64 {
            let c = gate.push(&two_taxels(k, press(k)), "t").unwrap();
            if (320..600).contains(&k) {
                assert!(c.contact, "frame {k}");
            }
            if k >= 700 {
                assert!(!c.contact, "frame {k}: the residual reads as a contact");
            }
        }
        // the baseline took the residual
        assert!(gate.change()[1].abs() < 1.0, "{:?}", gate.change());
    }

    /// A weak, noisy 24-taxel sensor drifting 2 counts/s (σ ≈ 4.4 counts, like
    /// `tests/cli_force.rs`'s member 700): `press` counts on taxel 0 at frame `k` (100 Hz).
    fn weak_drifting(k: u64, press: f64, state: &mut u64) -> TaxelFrame {
        let t = k as f64 * 0.01;
        let values = (0..24)
            .map(|i| {
                // a sum of four uniforms (xorshift): σ ≈ 4.4 counts
                let mut n = 0.0;
                for _ in 0..4 {
                    *state ^= *state << 13;
                    *state ^= *state >> 7;
                    *state ^= *state << 17;
                    n += (*state >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                }
                let slope = if i % 2 == 0 { 2.0 } else { -1.5 };
                1000.0 + slope * t + 7.6 * n - if i == 0 { press } else { 0.0 }
            })
            .collect();
        TaxelFrame::new("ff".into(), Timestamp::at_rate(k, 100.0), k, values)
    }

    /// Frames in contact in the last second of a light press (peak `peak` counts on taxel 0)
    /// on [`weak_drifting`] that leaves `residual` counts behind, and its hold's frames in
    /// contact (of 50), under `gate`.
    fn light_press_on_a_weak_sensor(gate: DriftModel, peak: f64, residual: f64) -> (usize, usize) {
        slow_press_on_a_weak_sensor(gate, peak, residual, 200)
    }

    /// [`light_press_on_a_weak_sensor`] with a rise of `rise` frames (100 Hz): 10 s untouched,
    /// the rise, 0.5 s hold, 1.5 s fall, 3 s rest; (frames in contact in the last second, of
    /// 100; hold frames in contact, of 50).
    fn slow_press_on_a_weak_sensor(gate: DriftModel, peak: f64, residual: f64, rise: u64) -> (usize, usize) {
        let (top, down) = (1000 + rise, 1050 + rise);
        let press = |k: u64| {
            if k < 1000 {
                0.0
            } else if k < top {
                peak * (k - 1000) as f64 / rise as f64
            } else if k < down {
                peak
            } else if k < down + 150 {
                residual + (peak - residual) * (down + 150 - k) as f64 / 150.0
            } else {
                residual
            }
        };
        let mut det = ChangeDetector::try_new(24, &LocateConfig::default()).unwrap().with_drift_model(gate).unwrap();
        let (mut state, mut late, mut held) = (0x9e37_79b9_7f4a_7c15u64, 0, 0);
        for k in 0..down + 450 {
            let c = det.push(&weak_drifting(k, press(k), &mut state), "t").unwrap();
            late += usize::from(k >= down + 350 && c.contact);
            held += usize::from((top..down).contains(&k) && c.contact);
        }
        (late, held)
    }

    /// The shape-return candidates of examples/force_parts/history.md (session 32, second round): (g1)–(g8)
    /// (g9 and g10's rise guard lost by far and was removed after the choice).
    fn shape_gates() -> Vec<DriftModel> {
        let mut gates = Vec::new();
        for range in [true, false] {
            for (e, f) in [(0.3, 0.0), (0.3, 0.5), (0.5, 0.0), (0.5, 0.5)] {
                gates.push(DriftModel {
                    release_excess: e,
                    release_flat_s: f,
                    release_flat_range: range,
                    ..FORCE_GATE
                });
            }
        }
        gates
    }

    #[test]
    fn the_shape_return_does_not_absorb_a_slow_light_press() {
        // a light press (60 counts on one taxel of a σ 4.4 sensor drifting ±2 counts/s) rising
        // over 2 s and over 6 s: the gate's shape return must not fire while it rises or holds
        // (the noise return did, 'a_light_press_on_a_weak_drifting_sensor_and_the_return_rules'),
        // and its lift leaves no contact behind
        const _: () = assert!(FORCE_GATE.release_excess > 0.0 && FORCE_GATE.release_flat_range);
        for rise in [200, 600] {
            let (late, held) = slow_press_on_a_weak_sensor(FORCE_GATE, 60.0, 0.0, rise);
            assert_eq!((late, held), (0, 50), "rise {rise} frames");
        }
        // a firm press too
        assert_eq!(slow_press_on_a_weak_sensor(FORCE_GATE, 600.0, 0.0, 200), (0, 50));
        // measured: with flatness as an end-to-end difference (candidates g5-g8) the 6 s rise is
        // settled into the baseline and its lift reads as a contact that stays
        let ends = DriftModel { release_flat_range: false, ..FORCE_GATE };
        let (late, held) = slow_press_on_a_weak_sensor(ends, 60.0, 0.0, 600);
        assert!(late > 50 && held < 25, "{late} late, {held} held");
    }

    #[test]
    fn the_shape_return_releases_a_flat_residual_after_a_press() {
        // a 200-count press that drops to 80 counts and stays there (a residual at 0.4 of its
        // peak: the peak return, 0.3, never fires): without the shape return it is a contact
        // until the stale time (10 s); with it, it returns once flat and the baseline takes it
        let press = |k: u64| match k {
            0..=299 => 0.0,
            300..=549 => 200.0,
            _ => 80.0,
        };
        let run = |gate: DriftModel| {
            let mut det = ChangeDetector::try_new(2, &LocateConfig::default()).unwrap().with_drift_model(gate).unwrap();
            let (mut held, mut rest, mut late) = (0, 0, 0);
            for k in 0..1000u64 {
                // noise of period 9 frames (the detector's window): σ ≈ 1.3 counts per frame,
                // window means without noise, so the residual's Σ|Δᵢ| is flat
                let c = det.push(&two_taxels_with_noise(k, press(k), ((k % 9) as f64 - 4.0) * 0.5), "t").unwrap();
                held += usize::from((330..550).contains(&k) && c.contact);
                rest += usize::from((620..690).contains(&k) && c.contact);
                late += usize::from(k >= 900 && c.contact);
            }
            (held, rest, late)
        };
        assert_eq!(
            run(DriftModel { release_excess: 0.0, ..FORCE_GATE }),
            (220, 70, 100),
            "without it the residual stays"
        );
        let (held, rest, late) = run(FORCE_GATE);
        assert_eq!((held, rest), (220, 0), "the residual returned within 0.7 s of the drop");
        // session 33: the slope's anchors are shifted to the residual at its return, so the step
        // is not learned as drift and no contact comes back
        assert_eq!(late, 0, "{late} of 100 late frames in contact");
        // the defect session 32's gate (anchors kept) had: the slope learned the step, the
        // baseline ran off and a contact came back
        let (_, _, late) = run(FORCE_GATE_S32);
        assert_eq!(late, 100, "the slope learned the step: {late} of 100 late frames in contact");
    }

    /// Session 32's gate: [`FORCE_GATE`] with the anchors kept at a return.
    const FORCE_GATE_S32: DriftModel = DriftModel { return_anchors: ReturnAnchors::Keep, ..FORCE_GATE };

    /// The return-anchor candidates of examples/force_parts/history.md (session 33): (a1)–(a4).
    fn anchor_gates() -> Vec<DriftModel> {
        [
            ReturnAnchors::RestartAtShapeReturn,
            ReturnAnchors::ShiftAtShapeReturn,
            ReturnAnchors::RestartAtAnyReturn,
            ReturnAnchors::ShiftAtAnyReturn,
        ]
        .into_iter()
        .map(|a| DriftModel { return_anchors: a, ..FORCE_GATE })
        .collect()
    }

    /// The pinned residual step (a 200-count press that drops to 80 counts at frame 550 and
    /// stays), both taxels then drifting `drift` counts/s from frame 1000, and a second
    /// 150-count press on top of the residual from frame `at` (0.3 s ramps, 1.4 s hold) that
    /// returns to it: (frames in contact from 1.5 s after the drop until the second press,
    /// frames of the second press's hold in contact (of 140), frames in contact from 1 s after
    /// the second press's end, 2 s long (of 200)).
    fn residual_then_drift_then_press(gate: DriftModel, drift: f64, at: u64) -> (usize, usize, usize) {
        let press = |k: u64| {
            if k < 300 {
                0.0
            } else if k < 550 {
                200.0
            } else if (at..at + 30).contains(&k) {
                80.0 + 150.0 * (k - at) as f64 / 30.0
            } else if (at + 30..at + 170).contains(&k) {
                230.0
            } else if (at + 170..at + 200).contains(&k) {
                80.0 + 150.0 * (at + 200 - k) as f64 / 30.0
            } else {
                80.0
            }
        };
        let mut det = ChangeDetector::try_new(2, &LocateConfig::default()).unwrap().with_drift_model(gate).unwrap();
        let (mut between, mut second, mut after) = (0, 0, 0);
        for k in 0..at + 500 {
            // the pinned test's noise (period 9: window means without noise) and a drift
            let e = ((k % 9) as f64 - 4.0) * 0.5;
            let d = drift * k.saturating_sub(1000) as f64 * 0.01;
            let values = vec![1000.0 + e + d, 2000.0 - press(k) - e + d];
            let c = det.push(&TaxelFrame::new("ff".into(), Timestamp::at_rate(k, 100.0), k, values), "t").unwrap();
            between += usize::from((700..at).contains(&k) && c.contact);
            second += usize::from((at + 30..at + 170).contains(&k) && c.contact);
            after += usize::from(k >= at + 300 && c.contact);
        }
        (between, second, after)
    }

    #[test]
    fn after_a_shape_return_the_step_is_not_learned_as_drift() {
        // session 33 (examples/force_parts/history.md): the residual step a shape return leaves behind, then drift
        // (±1 count/s from 4.5 s after the drop, 19 s long), then a real second press. With the
        // anchors kept (the session-32 gate) the slope learns the step, the baseline runs off
        // and a contact comes back; restarting or shifting the anchors at the return keeps the
        // baseline on the residual and still follows the drift
        for drift in [0.0, 1.0, -1.0] {
            let (between, second, _) = residual_then_drift_then_press(FORCE_GATE_S32, drift, 2500);
            assert!(between > 500, "the pinned defect (anchors kept): {between} frames in contact");
            assert_eq!(second, 140, "drift {drift}");
            for gate in anchor_gates() {
                let got = residual_then_drift_then_press(gate, drift, 2500);
                assert_eq!(got, (0, 140, 0), "{:?}, drift {drift}", gate.return_anchors);
            }
        }
        // a second press soon after the return (1.5 s after the drop) is a contact through its
        // hold, and returns (with the anchors kept, the learned step keeps it a contact)
        assert_eq!(residual_then_drift_then_press(FORCE_GATE_S32, 0.0, 700), (0, 140, 200));
        for gate in anchor_gates() {
            assert_eq!(residual_then_drift_then_press(gate, 0.0, 700), (0, 140, 0), "{:?}", gate.return_anchors);
        }
    }

    #[test]
    fn the_shape_return_never_panics_on_non_finite_or_huge_frames() {
        for gate in shape_gates().into_iter().chain(anchor_gates()) {
            let mut det =
                ChangeDetector::try_new(24, &LocateConfig::default()).unwrap().with_drift_model(gate).unwrap();
            let mut state = 7u64;
            for k in 0..400u64 {
                let mut f = weak_drifting(k, if (200..260).contains(&k) { 80.0 } else { 0.0 }, &mut state);
                match k % 97 {
                    13 => f.values[3] = f64::NAN,
                    29 => f.values[5] = f64::INFINITY,
                    41 => f.values[7] = f64::NEG_INFINITY,
                    _ => {}
                }
                let r = det.push(&f, "t");
                assert_eq!(r.is_err(), f.values.iter().any(|v| !v.is_finite()), "frame {k}");
            }
            // huge finite values (window sums and Σ|Δᵢ| overflow to ±∞ or NaN), then ordinary
            // frames again: an answer or an error for each, never a panic
            for k in 400..460u64 {
                let v = [f64::MAX, -f64::MAX, 1e300, -1e300][(k % 4) as usize];
                let f = if k < 420 {
                    TaxelFrame::new("ff".into(), Timestamp::at_rate(k, 100.0), k, vec![v; 24])
                } else {
                    weak_drifting(k, 0.0, &mut state)
                };
                let _ = det.push(&f, "t");
            }
        }
        assert!(DriftModel { release_excess: 1.0, ..FORCE_GATE }.validate().is_err());
        assert!(DriftModel { release_excess: f64::NAN, ..FORCE_GATE }.validate().is_err());
        assert!(DriftModel { release_flat_s: -0.1, ..FORCE_GATE }.validate().is_err());
        assert!(DriftModel { release_flat_s: f64::INFINITY, ..FORCE_GATE }.validate().is_err());
        for bad in [0.0, -0.1, 10.5, f64::NAN, f64::INFINITY] {
            assert!(DriftModel { release_flat_sigmas: bad, ..FORCE_GATE }.validate().is_err(), "{bad}");
        }
        // the anchors' setting reads from JSON by name, and an unknown name is refused
        let m: DriftModel = serde_json::from_str(r#"{"return_anchors": "restart_at_shape_return"}"#).unwrap();
        assert_eq!(m.return_anchors, ReturnAnchors::RestartAtShapeReturn);
        assert!(serde_json::from_str::<DriftModel>(r#"{"return_anchors": "sometimes"}"#).is_err());
    }

    #[test]
    fn a_light_press_on_a_weak_drifting_sensor_and_the_return_rules() {
        // (examples/force_parts/history.md, "The force gate's returns") the gate's return bound, 0.3 of the
        // press's peak total change Σ|Δᵢ|, sits below what the window means' noise alone adds
        // to Σ|Δᵢ| on a weak sensor (σ 4.4 counts: ≈ 28 counts over 24 taxels), so a residual
        // of 4.5 σ left by a light press (60 counts on one taxel) is never a return: the
        // contact lasts until the stale time. The same residual after a firm press returns.
        // The shape return (in FORCE_GATE since session 32's second round) does not fix this
        // case: on this noisy sensor the range of Σ|Δᵢ| over 0.3 s exceeds 0.1 Σσᵢ by noise
        // alone, so the residual is never flat (measured: 98 of 100; 100 without it).
        let (late, held) = light_press_on_a_weak_sensor(FORCE_GATE, 60.0, 20.0);
        assert_eq!(held, 50, "the light press is a contact through its hold");
        assert!(late >= 90, "the known failure: the residual stays a contact ({late} of 100)");
        let no_shape = DriftModel { release_excess: 0.0, ..FORCE_GATE };
        assert_eq!(light_press_on_a_weak_sensor(no_shape, 60.0, 20.0), (100, 50));
        let (late, held) = light_press_on_a_weak_sensor(FORCE_GATE, 600.0, 20.0);
        assert_eq!((late, held), (0, 50), "a firm press's residual returns");
        // the drift alone (a line the slope follows) leaves no contact behind
        assert_eq!(light_press_on_a_weak_sensor(FORCE_GATE, 60.0, 0.0), (0, 50));
        // the noise return (`release_sigmas`) ends that contact, but it also returns during
        // the light press itself (absorbing it) — why it is measured and off (examples/force_parts/history.md)
        let noise = DriftModel { release_sigmas: 0.5, ..FORCE_GATE };
        let (late, held) = light_press_on_a_weak_sensor(noise, 60.0, 20.0);
        assert_eq!(late, 0, "the noise return ends the residual's contact");
        assert!(held < 25, "measured: the light press returns during its rise ({held} of 50 held)");
        // absorbed during its rise, the press's lift reads as a contact that stays
        let (late, held) = light_press_on_a_weak_sensor(noise, 60.0, 0.0);
        assert!(held < 25 && late > 50, "measured: {held} of 50 held, {late} of 100 late");
    }

    #[test]
    fn a_steady_step_becomes_the_resting_level_after_the_stale_time() {
        // an offset step of 30 counts (a temperature jump, not a press) that stays
        let mut gate = force_detector(2, &LocateConfig::default()).unwrap();
        let stale = (FORCE_GATE.stale_s * 100.0) as u64;
        let mut last_contact = 0;
        for k in 0..(400 + stale + 300) {
            let c = gate.push(&two_taxels(k, if k >= 300 { 30.0 } else { 0.0 }), "t").unwrap();
            if c.contact {
                last_contact = k;
            }
        }
        assert!(last_contact > 300 + stale / 2, "the step was never a contact: {last_contact}");
        assert!(last_contact < 400 + stale, "the step stayed a contact: {last_contact}");
        assert!(gate.change()[1].abs() < 2.0, "{:?}", gate.change());
    }

    #[test]
    fn the_gate_and_its_settings_are_validated() {
        FORCE_GATE.validate().unwrap();
        for bad in [
            DriftModel { hold_sigmas: -1.0, ..FORCE_GATE },
            DriftModel { hold_total: f64::NAN, ..FORCE_GATE },
            DriftModel { release_moving: 1.0, ..FORCE_GATE },
            DriftModel { quiet_s: -0.5, ..FORCE_GATE },
            DriftModel { stale_s: f64::INFINITY, ..FORCE_GATE },
            DriftModel { release_sigmas: -0.5, ..FORCE_GATE },
            DriftModel { release_sigmas: f64::NAN, ..FORCE_GATE },
        ] {
            assert!(bad.validate().is_err(), "{bad:?}");
        }
        // a partial JSON drift model takes the defaults for the rest
        let m: DriftModel = serde_json::from_str(r#"{"hold_sigmas": 3}"#).unwrap();
        assert_eq!(m, DriftModel { hold_sigmas: 3.0, ..DriftModel::default() });
    }

    #[test]
    fn total_files_are_version_2_others_version_1_and_newer_files_are_refused_by_version() {
        let total =
            calibrate(&power_law_samples(), CalibrationMethod::Total, 0.0, ForceMethod::Linear, &Layout::biotac_sp())
                .unwrap();
        assert_eq!(total.version, 2, "a total file stays readable by builds before `placed`");
        let ridge =
            calibrate(&power_law_samples(), CalibrationMethod::Ridge, 0.1, ForceMethod::Linear, &Layout::biotac_sp())
                .unwrap();
        assert_eq!(ridge.version, 1, "a ridge file stays readable by builds before `total`");
        // a version-1 `total` file (written by the build that introduced `total`) is read
        ForceFile { version: 1, ..total.clone() }.validate().unwrap();
        let e = check_header(FORCE_FORMAT, FORCE_VERSION + 1).unwrap_err().to_string();
        assert!(e.contains("newer gradtac") && e.contains(&format!("1 to {FORCE_VERSION}")), "{e}");
        assert!(check_header(FORCE_FORMAT, 0).is_err());
        assert!(check_header("gradtac-tare", 1).unwrap_err().to_string().contains("format"));
    }

    #[test]
    fn files_are_validated() {
        file().validate().unwrap();
        let json = serde_json::to_string(&file()).unwrap();
        assert_eq!(serde_json::from_str::<ForceFile>(&json).unwrap(), file());
        for bad in [
            ForceFile { version: 9, ..file() },
            ForceFile { format: "f".into(), ..file() },
            ForceFile { taxels: 3, ..file() },
            ForceFile { taxels: 0, ..file() },
            ForceFile {
                model: CalibratedForce::Ridge { intercept_n: f64::NAN, weights: vec![0.0, 0.0], lambda: 0.0 },
                ..file()
            },
            ForceFile {
                model: CalibratedForce::Area {
                    curve: ForceModel::Isotonic { area_mm2: vec![2.0, 1.0], force_n: vec![0.0, 1.0] },
                },
                ..file()
            },
        ] {
            assert!(bad.validate().is_err(), "{bad:?}");
        }
        assert!(file().check_layout(&Layout::biotac_sp()).unwrap_err().to_string().contains("24"));
    }

    #[test]
    fn the_stage_reports_no_force_without_contact() {
        let cfg = LocateConfig { window_frames: 1, ..Default::default() };
        let mut s = ChangeForce::try_new(&file(), &cfg).unwrap();
        let frame = |k: u64, v: f64| {
            let e = if k % 2 == 0 { 1.0 } else { -1.0 };
            TaxelFrame::new("ff".into(), Timestamp::at_rate(k, 100.0), k, vec![v + e, 500.0 - e])
        };
        let mut frames: Vec<TaxelFrame> = (0..40).map(|k| frame(k, 1000.0)).collect();
        frames.extend((40..45).map(|k| frame(k, 700.0)));
        let out = s.run_all(frames).unwrap();
        assert!(out[..40].iter().all(|e| e.force_n.is_none()));
        // Δ ≈ −300 counts × −0.01 N/count = 3 N
        assert!(out[40..].iter().all(|e| (e.force_n.unwrap() - 3.0).abs() < 0.05), "{:?}", &out[40..]);
    }

    /// Session 34's shape-test candidate (d3), the gate since then: the drift-shape return with
    /// the magnitude fit (and, since session 35, the gate's rise test; [`GATE_S34`] is without it).
    const SHAPE_GATE: DriftModel = DriftModel { drift_shape: 0.25, drift_shape_fit: ShapeFit::Magnitude, ..FORCE_GATE };
    /// Session 33's gate: [`FORCE_GATE`] without the drift-shape return.
    const GATE_S33: DriftModel = DriftModel { drift_shape: 0.0, drift_shape_fit: ShapeFit::Signed, ..FORCE_GATE };

    /// xorshift64: a uniform in [0, 1).
    fn uniform(state: &mut u64) -> f64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A quiet BioTac SP sensor at 100 Hz (σ ≈ 1 count: ±1 alternation, each taxel's phase its
    /// own) whose taxels drift independently by `drift[i]` counts, pressed by `press` counts at
    /// taxel `at`, spread over its neighbours as a Gaussian of 3 mm (every electrode's value
    /// falls, as on the sensor).
    fn shaped_frame(k: u64, press: f64, at: usize, drift: &[f64]) -> TaxelFrame {
        let layout = Layout::biotac_sp();
        let pos = layout.positions();
        let c = pos[at];
        let values = (0..24)
            .map(|i| {
                let e = if (k + i as u64) % 2 == 0 { 1.0 } else { -1.0 };
                let d2 = (pos[i][0] - c[0]).powi(2) + (pos[i][1] - c[1]).powi(2);
                1500.0 + 37.0 * i as f64 + drift[i] + e - press * (-d2 / 18.0).exp()
            })
            .collect();
        TaxelFrame::new("ff".into(), Timestamp::at_rate(k, 100.0), k, values)
    }

    /// Under `gate`: constant input (500 frames) gives no contact and no change; then a press
    /// (frames 200..400 of 600) with a bad value at frame `k` where `k % period` is one of
    /// `bad`'s slots (`(slot, taxel, value)`): exactly the non-finite frames are errors, never a
    /// panic; then `huge_frames` frames of the `huge` values in turn are answered without one.
    fn constant_and_non_finite_input(
        gate: DriftModel,
        (period, bad): (u64, [(u64, usize, f64); 2]),
        huge: &[f64],
        huge_frames: u64,
    ) {
        let mut det = shaped_detector(gate);
        for k in 0..500u64 {
            let f = TaxelFrame::new("ff".into(), Timestamp::at_rate(k, 100.0), k, vec![1800.0; 24]);
            assert!(!det.push(&f, "t").unwrap().contact);
        }
        assert!(det.change().iter().all(|d| d.abs() < 1e-9), "{:?}", det.change());
        let mut det = shaped_detector(gate);
        for k in 0..600u64 {
            let mut f = shaped_frame(k, if (200..400).contains(&k) { 80.0 } else { 0.0 }, 9, &[0.0; 24]);
            for &(slot, taxel, v) in &bad {
                if k % period == slot {
                    f.values[taxel] = v;
                }
            }
            assert_eq!(det.push(&f, "t").is_err(), !f.values.iter().all(|v| v.is_finite()), "frame {k}");
        }
        for k in 600..600 + huge_frames {
            let v = huge[(k % huge.len() as u64) as usize];
            let _ = det.push(&TaxelFrame::new("ff".into(), Timestamp::at_rate(k, 100.0), k, vec![v; 24]), "t");
        }
    }

    /// A detector on the BioTac SP layout with `gate`.
    fn shaped_detector(gate: DriftModel) -> ChangeDetector {
        ChangeDetector::try_new(24, &LocateConfig::default())
            .unwrap()
            .with_drift_model(gate)
            .unwrap()
            .with_positions(Layout::biotac_sp().positions())
            .unwrap()
    }

    /// 1 s untouched, a press (`peak` counts at taxel 9: 1 s rise, 3 s hold, 0.5 s fall), then
    /// 6 s untouched, on [`shaped_frame`] whose taxels drift independently (draw `draw`: a
    /// slope in ±2 counts/s and a random walk of 1.5 counts/√s each, as the stuck tuning-side
    /// members of `examples/force_parts/history.md`): (frames in contact in the last 3 s, frames in contact
    /// during the hold's last 2.5 s, of 250).
    fn press_then_rest(gate: DriftModel, peak: f64, draw: u64) -> (usize, usize) {
        let mut state = 0x2545_f491_4f6c_dd1d ^ draw.wrapping_mul(0x9e37_79b9_7f4a_7c15);
        let slopes: Vec<f64> = (0..24).map(|_| 4.0 * uniform(&mut state) - 2.0).collect();
        let mut drift = vec![0.0; 24];
        let mut det = shaped_detector(gate);
        let press = |k: u64| match k {
            0..=99 => 0.0,
            100..=199 => peak * (k - 100) as f64 / 100.0,
            200..=499 => peak,
            500..=549 => peak * (550 - k) as f64 / 50.0,
            _ => 0.0,
        };
        let (mut late, mut held) = (0, 0);
        for k in 0..1150u64 {
            for (d, s) in drift.iter_mut().zip(&slopes) {
                // a step of σ 0.15 counts per frame (1.5 counts/√s): a sum of 3 uniforms
                let n = (0..3).map(|_| uniform(&mut state) - 0.5).sum::<f64>();
                *d += s * 0.01 + 0.3 * n;
            }
            let c = det.push(&shaped_frame(k, press(k), 9, &drift), "t").unwrap();
            late += usize::from(k >= 850 && c.contact);
            held += usize::from((250..500).contains(&k) && c.contact);
        }
        (late, held)
    }

    /// 1 s untouched, a light change rising over 3 s to `peak` counts and held 3 s, lifted at
    /// once, then 3 s untouched, on [`shaped_frame`] without drift: the change is a press at
    /// taxel 9 (`coherent`) or the same peak scattered over every taxel with mixed signs (a
    /// drift's shape). (frames in contact during the hold's last 2.5 s of 300, frames
    /// in contact in the last 2 s, largest |slope| learned in counts/s.)
    fn ramp_then_lift(gate: DriftModel, peak: f64, coherent: bool) -> (usize, usize, f64) {
        let layout = Layout::biotac_sp();
        let pos = layout.positions();
        let bump: Vec<f64> =
            (0..24).map(|i| ((pos[i][0] - pos[9][0]).powi(2) + (pos[i][1] - pos[9][1]).powi(2)) / 18.0).collect();
        let bump: Vec<f64> = bump.iter().map(|d2| (-d2).exp()).collect();
        // the same peak scattered over every taxel: magnitudes 0.3–1 of it (golden-ratio
        // steps), every other one rising
        let scattered: Vec<f64> = (0..24)
            .map(|i| (0.3 + 0.7 * (i as f64 * 0.618_034).fract()) * if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let pattern = if coherent { bump } else { scattered };
        let mut det = shaped_detector(gate);
        let (mut held, mut late, mut slope) = (0, 0, 0.0f64);
        for k in 0..1000u64 {
            let a = match k {
                0..=99 => 0.0,
                100..=399 => peak * (k - 100) as f64 / 300.0,
                400..=699 => peak,
                _ => 0.0,
            };
            let drift: Vec<f64> = pattern.iter().map(|p| -a * p).collect();
            let c = det.push(&shaped_frame(k, 0.0, 9, &drift), "t").unwrap();
            held += usize::from((450..700).contains(&k) && c.contact);
            late += usize::from(k >= 800 && c.contact);
            slope = det.drift_slope().iter().fold(slope, |m, s| m.max(s.abs()));
        }
        (held, late, slope)
    }

    #[test]
    fn the_drift_shape_return_keeps_a_press_and_follows_a_drift_without_shape() {
        // a press's slow ramp and hold (smooth over neighbouring taxels) is never returned as
        // drift: held through its hold, nothing left after its lift, no slope learned from
        // it — as session 33's gate
        for gate in [GATE_S33, SHAPE_GATE] {
            let (held, late, slope) = ramp_then_lift(gate, 40.0, true);
            assert_eq!((held, late), (250, 0), "{gate:?}");
            assert!(slope < 0.1, "{slope} counts/s learned from a press");
        }
        // the same peak without a shape (scattered, mixed signs): session 33's gate holds
        // it as a contact; the drift-shape return takes it as the new level during the hold
        assert_eq!(ramp_then_lift(GATE_S33, 40.0, false).0, 250);
        let (held, late, _) = ramp_then_lift(SHAPE_GATE, 40.0, false);
        assert!(held < 50 && late == 0, "{held} of 250 hold frames in contact, {late} late");
        // without the layout's positions the setting is off
        let mut det =
            ChangeDetector::try_new(24, &LocateConfig::default()).unwrap().with_drift_model(SHAPE_GATE).unwrap();
        assert!(det.positions().is_none());
        let _ = det.push(&shaped_frame(0, 0.0, 9, &[0.0; 24]), "t").unwrap();
        assert!(ChangeDetector::try_new(24, &LocateConfig::default())
            .unwrap()
            .with_positions(&[[0.0; 2]; 23])
            .is_err());
        let mut bad = Layout::biotac_sp().positions().to_vec();
        bad[3][1] = f64::NAN;
        assert!(ChangeDetector::try_new(24, &LocateConfig::default()).unwrap().with_positions(&bad).is_err());
    }

    #[test]
    fn a_drift_without_shape_under_a_long_contact_is_followed_and_the_contact_ends() {
        // the stuck tuning-side members' mechanism (examples/force_parts/history.md, session 33, second round):
        // a quiet sensor whose taxels drift independently (slope and walk each); the press
        // freezes the baseline, so after it the stale offsets hold the contact. Session 33's
        // gate stays in contact through the rest in every draw and press (4769 of 4800 late
        // frames); the drift-shape return ends it in 14 of the 16 (2758 of 4800: the contact
        // ends, the walk beyond 2 σ brings one back until the next drift-shaped steady frame),
        // and every press is still held through its hold.
        let (mut old, mut new, mut freed) = (0, 0, 0);
        for draw in 0..8 {
            for peak in [30.0, 150.0] {
                let (late, held) = press_then_rest(GATE_S33, peak, draw);
                assert_eq!(held, 250);
                old += late;
                let (late, held) = press_then_rest(SHAPE_GATE, peak, draw);
                assert_eq!(held, 250, "the press is kept (draw {draw}, peak {peak})");
                new += late;
                freed += usize::from(late < 300);
            }
        }
        assert!(old >= 16 * 290, "session 33's gate: {old} late frames of 4800");
        assert!(
            5 * new < 3 * old && freed >= 14,
            "the drift-shape return: {new} late frames against {old}, {freed} of 16 freed"
        );
    }

    /// Session 34's gate: the drift-shape return with its anchors always kept (no rise test).
    const GATE_S34: DriftModel = DriftModel { drift_shape_rise_s: 0.0, ..SHAPE_GATE };
    /// Session 35's (e4): the drift-shape return's rise test shifts the anchors of a return on
    /// a frame that rose within 2 s.
    const RISE_GATE: DriftModel =
        DriftModel { drift_shape_rise_s: 2.0, drift_shape_rise: RiseGuard::ShiftAnchors, ..SHAPE_GATE };

    #[test]
    fn the_rise_test_keeps_a_press_taken_for_drift_from_teaching_the_slope() {
        // tuning members 204 and 205 (examples/force_parts/history.md, session 35): a press whose change has no
        // press's shape by the magnitude fit is taken for drift during its hold; with the
        // anchors kept (session 34) the hold's frames join the anchors from before the press,
        // the slope learns the press, and the baseline then runs along it. Here: a change
        // without a press's shape rising over 3 s and held 3 s, then lifted at once.
        let (held, late, slope) = ramp_then_lift(GATE_S34, 40.0, false);
        assert!(held < 50 && late == 0, "{held} {late}");
        assert!(slope > 3.0, "session 34's gate learns the held change as a slope: {slope} counts/s");
        // the rise test: the return fires on the same frames (the contact decisions are the
        // same), but the frame rose within 2 s, so the anchors are shifted and no slope is learned
        let (held, late, slope) = ramp_then_lift(RISE_GATE, 40.0, false);
        assert!(held < 50 && late == 0, "{held} {late}");
        assert!(slope < 0.1, "{slope} counts/s learned from a change that rose within the look-back");
        // blocking the return instead (session 35's (e2), not eligible): the lift, a sudden
        // drift-shaped step, stays a contact for the look-back, and the hold still teaches
        // the slope once the look-back has passed
        let block = DriftModel { drift_shape_rise: RiseGuard::Block, ..RISE_GATE };
        let (_, late, slope) = ramp_then_lift(block, 40.0, false);
        assert!(late > 50 && slope > 3.0, "{late} {slope}");
        // a press with a press's shape: never returned, as before
        let (held, late, slope) = ramp_then_lift(RISE_GATE, 40.0, true);
        assert_eq!((held, late), (250, 0));
        assert!(slope < 0.1, "{slope}");
        // a stale level left after a press's fall on a drifting quiet sensor (the drift-shape
        // return's own case) was higher 2 s before, so its anchors are kept as in session 34:
        // the contacts are freed as well (14 of 16 draws), and every press is held through its hold
        let (mut old, mut new, mut freed) = (0, 0, 0);
        for draw in 0..8 {
            for peak in [30.0, 150.0] {
                old += press_then_rest(GATE_S34, peak, draw).0;
                let (late, held) = press_then_rest(RISE_GATE, peak, draw);
                assert_eq!(held, 250, "the press is kept (draw {draw}, peak {peak})");
                new += late;
                freed += usize::from(late < 300);
            }
        }
        assert!(freed >= 14 && new <= old + old / 20, "{new} late frames against {old}, {freed} of 16 freed");
    }

    /// Session 35's (e5): (e4), and a drift-shape return on a recent rise undone once the
    /// sensor comes back to the level before it.
    const UNDO_GATE: DriftModel = DriftModel { drift_shape_rise: RiseGuard::ShiftAnchorsUndo, ..RISE_GATE };

    #[test]
    fn the_undo_restores_the_level_before_a_press_taken_for_drift() {
        // the change without a press's shape, held and lifted at once (as above): the hold is
        // taken for drift on a recent rise; when the lift brings the sensor back, the level
        // before the return is the baseline again (the change is the noise's, not the
        // absorbed hold's), no slope is learned, and nothing stays in contact
        let scattered: Vec<f64> = (0..24)
            .map(|i| (0.3 + 0.7 * (i as f64 * 0.618_034).fract()) * if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let run = |gate: DriftModel| {
            let mut det = shaped_detector(gate);
            let mut base0 = Vec::new();
            let mut first_after_lift = None;
            for k in 0..1000u64 {
                let a = match k {
                    0..=99 => 0.0,
                    100..=399 => 40.0 * (k - 100) as f64 / 300.0,
                    400..=699 => 40.0,
                    _ => 0.0,
                };
                let drift: Vec<f64> = scattered.iter().map(|p| -a * p).collect();
                let c = det.push(&shaped_frame(k, 0.0, 9, &drift), "t").unwrap();
                if k == 99 {
                    base0 = det.baseline().to_vec();
                }
                if k >= 700 && !c.contact && first_after_lift.is_none() {
                    first_after_lift = Some(k);
                }
            }
            let off: f64 = det.baseline().iter().zip(&base0).map(|(b, o)| (b - o).abs()).fold(0.0, f64::max);
            let slope = det.drift_slope().iter().fold(0.0f64, |m, s| m.max(s.abs()));
            (off, slope, first_after_lift)
        };
        let (off, slope, first) = run(UNDO_GATE);
        assert!(off < 0.3 && slope < 0.1, "baseline {off} counts off the level before, slope {slope}");
        assert!(first.is_some_and(|k| k < 760), "{first:?}");
        // without the undo the baseline settles to the lifted sensor instead: the window means'
        // noise of that moment stays in it (measured 0.62 against 0.11 counts)
        let (settled, _, _) = run(RISE_GATE);
        assert!(settled > 2.0 * off, "{settled} against {off}");
        // a press with a press's shape is untouched by it; the drift-shape return's own case
        // (a stale level after a press's fall on a drifting sensor) is freed as before
        let (held, late, slope) = ramp_then_lift(UNDO_GATE, 40.0, true);
        assert_eq!((held, late), (250, 0));
        assert!(slope < 0.1, "{slope}");
        let mut freed = 0;
        for draw in 0..8 {
            for peak in [30.0, 150.0] {
                let (late, held) = press_then_rest(UNDO_GATE, peak, draw);
                assert_eq!(held, 250, "the press is kept (draw {draw}, peak {peak})");
                freed += usize::from(late < 300);
            }
        }
        assert!(freed >= 14, "{freed} of 16 freed");
    }

    #[test]
    fn the_rise_test_on_constant_and_non_finite_input_and_its_settings() {
        // constant input: no contact, no change, whatever the guard does
        // non-finite frames are errors, never a panic; huge ones are answered without one
        for gate in [RISE_GATE, UNDO_GATE, DriftModel { drift_shape_rise: RiseGuard::Block, ..RISE_GATE }] {
            constant_and_non_finite_input(
                gate,
                (41, [(5, 3, f64::NAN), (17, 20, f64::NEG_INFINITY)]),
                &[f64::MAX, -f64::MAX, 1e300, 0.0],
                100,
            );
        }
        // the look-back is bounded and validated; the names parse; older files load unchanged
        for bad in [-0.1, 60.5, f64::NAN, f64::INFINITY] {
            assert!(DriftModel { drift_shape_rise_s: bad, ..RISE_GATE }.validate().is_err(), "{bad}");
        }
        for ok in [0.0, 60.0] {
            assert!(DriftModel { drift_shape_rise_s: ok, ..RISE_GATE }.validate().is_ok(), "{ok}");
        }
        let m: DriftModel =
            serde_json::from_str(r#"{"drift_shape_rise_s": 2.0, "drift_shape_rise": "shift_anchors"}"#).unwrap();
        assert_eq!((m.drift_shape_rise_s, m.drift_shape_rise), (2.0, RiseGuard::ShiftAnchors));
        let m: DriftModel = serde_json::from_str(r#"{"drift_shape_rise": "shift_anchors_undo"}"#).unwrap();
        assert_eq!(m.drift_shape_rise, RiseGuard::ShiftAnchorsUndo);
        let m: DriftModel = serde_json::from_str(r#"{"drift_shape": 0.25}"#).unwrap();
        assert_eq!((m.drift_shape_rise_s, m.drift_shape_rise), (0.0, RiseGuard::Block));
        assert!(serde_json::from_str::<DriftModel>(r#"{"drift_shape_rise": "sometimes"}"#).is_err());
    }

    #[test]
    fn the_drift_shape_return_on_constant_and_non_finite_input() {
        // constant input: no contact, no change; non-finite frames are errors naming the frame,
        // never a panic, and ordinary frames after them are answered
        constant_and_non_finite_input(
            SHAPE_GATE,
            (53, [(7, 2, f64::NAN), (19, 9, f64::INFINITY)]),
            &[f64::MAX, -f64::MAX, 1e300],
            40,
        );
        // the setting's range, and its fit read from JSON by name
        for bad in [-0.1, 1.0, f64::NAN, f64::INFINITY] {
            assert!(DriftModel { drift_shape: bad, ..FORCE_GATE }.validate().is_err(), "{bad}");
        }
        let m: DriftModel = serde_json::from_str(r#"{"drift_shape": 0.25, "drift_shape_fit": "magnitude"}"#).unwrap();
        assert_eq!((m.drift_shape, m.drift_shape_fit), (0.25, ShapeFit::Magnitude));
        assert!(serde_json::from_str::<DriftModel>(r#"{"drift_shape_fit": "curly"}"#).is_err());
    }
}
