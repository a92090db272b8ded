//! Direction of slip on one fingertip: the seven BioTacSP-DoS classes from GradTac features
//! (method.md, stage 7 and "Real data at hand").
//!
//! # What it does
//! A recording (or a span of a stream) of one sensor's raw frames is turned into a short
//! feature vector and classified by the most likely class under a heavy-tailed (Student t)
//! density per class, fitted by [`DosModel::calibrate`] from labelled recordings. The features
//! come from two views of the same frames:
//! - the **drift map** ([`crate::drift`]): for every taxel, how far its log signal moves over
//!   0.3, 0.6 and 1.2 s measured in units of its own frame-to-frame noise, and in which
//!   direction — *where* on the layout the pressure is slowly changing, independent of each
//!   taxel's gain and of the object's stiffness;
//! - the GradTac chain: log-change [events](crate::events) on the raw counts → per-taxel event
//!   counts split by polarity (and, for the track features, tumbling [window](crate::window)
//!   aggregates) → where the counts lie on the layout, optionally through
//!   [natural-neighbour surfaces](crate::interpolate) and [maximal contours](crate::contour)
//!   ([`CentroidMethod`]).
//!
//! The classes ([`DosClass`]) are those of the BioTacSP-DoS dataset (Zapata-Impata, Gil and
//! Torres, "Learning Spatio Temporal Tactile Features with a ConvLSTM for the Direction Of Slip
//! Detection", Sensors 19(3):523, 2019): translational slip `n`, `e`, `s`, `w`, rotational slip
//! `cw`, `aw`, and stable touch `t`. [`DosFeatureExtractor`] is the plain state machine,
//! [`DosClassifier`] the [`Stage`], [`DosModel`] the fitted, serialisable parameters.
//!
//! # Features ([`Feature`])
//! Over the span, with `τ` = [`DosFeatureConfig::threshold`] on `ln(counts)`; "location" is
//! the configured [`CentroidMethod`] (default: the count-weighted mean of the taxel positions);
//! `w_i`, `s_i` are the drift map's weight and sign of taxel `i` at position `(x_i, y_i)` (lags
//! [`DosFeatureConfig::drift_lags`]), `W = Σ w_i` and `(x̄, ȳ) = Σ w_i (x_i, y_i) / W`. The
//! **default** set ([`Feature::DEFAULT`]) is the seven drift features, on the linear drift
//! scale ([`DriftScale::Linear`]): all of them exactly invariant to a gain and an offset per
//! recording, and odd or even under the layout's mirror ([`Feature::mirror_sign`]).
//!
//! | feature | unit | definition |
//! |---|---|---|
//! | `drift_level` | — | `ln(1 + W)`: how much slow change there is (touch is lowest) |
//! | `drift_x`, `drift_y` | mm | `(x̄, ȳ)`: where the slow change is (on the side the contact leaves, like the events) |
//! | `drift_spread` | — | `ln(1 + Σ w_i ((x_i − x̄)² + (y_i − ȳ)²) / W)` |
//! | `drift_anisotropy` | mm² | `Σ w_i ((x_i − x̄)² − (y_i − ȳ)²) / W`: translations spread their drift along the pad, rotations do not |
//! | `drift_cross` | mm² | `Σ w_i (x_i − x̄)(y_i − ȳ) / W` |
//! | `drift_signed_y` | mm | `Σ w_i s_i y_i / W`: which side of the pad rises and which falls |
//! | `rate` | — | `ln(1 + events per second)`, all taxels, both polarities: how much is happening (touch is quiet) |
//! | `positive_fraction` | — | positive events / all events (0.5 without events) |
//! | `positive_x`, `positive_y` | mm | location of the **positive**-event counts (counts rising: pressure leaving) |
//! | `negative_x`, `negative_y` | mm | location of the **negative**-event counts (pressure arriving) |
//! | `activity_x`, `activity_y` | mm | location of all events |
//! | `track_dx`, `track_dy` | mm | displacement of the contact track: the location of all events in tumbling windows of [`DosFeatureConfig::track_window_frames`], mean of the last third of the windows minus mean of the first third |
//! | `rotation` | rad | rotation of the event distribution: sum over consecutive track windows of the change of its principal-axis orientation (wrapped to `(−π/2, π/2]`, weighted by the smaller of the two eccentricities — a round distribution has no orientation) |
//!
//! A distribution without weight (no events; no contour reaching `min_peak`; no drift) is
//! located at the centre of the layout's extent (with zero drift moments); a span with fewer
//! than two track windows has zero displacement and rotation; a span shorter than a drift lag
//! averages the lags it has. Every computed feature is finite for any finite input (tested at
//! 0, negative, 1e±300 and saturating counts); the extractor computes only the parts its
//! configured features need (see [`DosFeatureExtractor`]) and leaves the others NaN. The
//! drift features agree with an independent numpy implementation to 1e-12
//! (`tests/dos_drift_reference.rs`, vectors and script in `tests/reference/`).
//!
//! **Measured — held out** (BioTacSP-DoS development subset: 167 recordings of ~2.8 s, object
//! sets *basic* = case, hd, pen, sponge and *solids* = bottle, cardboard; per-recording
//! accuracy, chance 14.3 %; `cargo run --release --example dos_eval`, which prints these tables
//! and fails when a held-out figure drops under its floor; `gradtac calibrate --cross-validate`
//! prints this design's three held-out figures for any labelled data):
//!
//! | method | parameters | nested leave-one-object-out | basic → solids | solids → basic |
//! |---|---|---|---|---|
//! | nearest class mean of the unit mean-change vector (24 taxels; the cheapest baseline) | 168 | 28.7 % | 19.6 % | 26.1 % |
//! | the classifier before this design (9 features: log drift map + positive-event centroid, λ 0.5, fixed) | 126 | 83.2 % ¹ | 82.1 % ¹ | 74.8 % ¹ |
//! | **this design**: 120 candidates chosen inside every fold (below) | 98 | **80.2 %** | **85.7 %** | **66.7 %** |
//! | (comparison) the same choice with the earlier nine features added as candidates | ≤ 126 | 82.0 % | 82.1 % | 66.7 % |
//!
//! ¹ Not held out for its choices: its features and lags were picked by looking at the
//! leave-one-object-out accuracy over all six objects, so its first column is that plain
//! figure, and its cross-set figures come from choices that saw the test objects.
//!
//! *Protocols.* **Nested leave-one-object-out**: for each of the six objects, every choice —
//! drift lags (`[30, 60, 120]`, `[60]`, `[30, 60]`, `[60, 120]`), drift-feature set
//! (`drift_level, drift_x, drift_y` / + `drift_spread, drift_anisotropy` / all seven),
//! shrinkage `λ` (1, 0.75, 0.5, 0.25, 0) and mirror augmentation (off / on) — is made by
//! leave-one-object-out over the *other five* objects only ([`crate::dos_select`]); the chosen
//! candidate is fitted on those five and decides the held-out object. **Cross-set**: the same
//! choice by leave-one-object-out inside the training set (four basic objects, or the two
//! solids), fitted on the whole set, decides every recording of the other set. Student-t `ν` = 3
//! was never tuned. The per-fold choices were almost always all seven drift features with
//! `λ` 0.25–0.5; lags and mirror varied (`dos_eval` lists them). **The shipped defaults** are
//! what the same procedure picks on all 167 recordings: the seven drift features, lags
//! `[30, 60]`, linear scale, `λ` = 0, mirror augmentation on (inner leave-one-object-out
//! 83.2 % — in-sample for that choice; not a held-out figure).
//!
//! *The published protocol* (ConvLSTM of Zapata-Impata et al.: trained on basic only, accuracy
//! per non-overlapping 5-frame = 50 ms window of unseen objects, 82.56 % on solids): the
//! basic-trained choice decides each 5-frame window of the solids recordings — from **the window
//! alone** (a model of the same features with lags 1, 2, 4 frames, fitted on the basic
//! recordings' 5-frame windows): **29.1 %**; from **the causal history since contact** (the
//! basic-trained model on all frames up to the window's end — what a streaming robot has):
//! **63.3 %**. A 50 ms window holds no slow drift: these features need time, the ConvLSTM's
//! per-window figure is out of their reach.
//!
//! *Early answers* — the streaming [`DosClassifier`] with sliding decisions every 5 frames and
//! early answers ([`with_early_decisions`](DosClassifier::with_early_decisions): each over all
//! frames since contact), the cross-set choice fitted on whole training recordings:
//!
//! | split | 0.25 s | 0.5 s | 1 s | 2 s | whole (2.7–2.8 s) |
//! |---|---|---|---|---|---|
//! | basic → solids (56 recordings) | 14.3 % | 14.3 % | 66.1 % | 78.6 % | 85.7 % |
//! | solids → basic (111 recordings) | 14.4 % | 59.5 % | 64.9 % | 68.5 % | 66.7 % |
//!
//! Before 0.3 s (0.6 s for a choice of lags `[60]`) no drift lag has a difference, every
//! feature is at its no-drift value and every recording gets the same class. At 1 s the answers
//! are right about two times in three; the issue's 85 % at 1 s is not reached.
//!
//! *Targets not reached, and why it stops here.* The issue asked for ≥ 90 % cross-set each
//! way, ≥ 90 % nested and ≥ 85 % at 1 s. Measured: 85.7 % / 66.7 %, 80.2 %, ~65 %. The
//! remaining errors are mostly `cw` ↔ `aw` (13 of 33 nested errors) and `n` → `cw`/`aw`: on
//! these recordings rotation is visible only as a weak side asymmetry of the drift
//! (`drift_signed_y`) that half a dozen recordings show reversed. Solids → basic trains on two
//! objects (56 recordings) and the choice inside it rests on a two-fold leave-one-object-out —
//! the weakest link. Every extension tried (log below) left the nested figure at or under
//! 80.2 %; a figure chosen on the test data would be easy to get and is not reported.
//!
//! *Design log* (nested leave-one-object-out unless marked; one recording = 0.6 points):
//!
//! | tried | nested |
//! |---|---|
//! | the design grid above (linear drift map, 120 candidates) — **shipped** | 80.2 % |
//! | log instead of linear drift scale (drift features only, λ 0.5, plain LOOO) | 80.2 % = linear |
//! | + centroid of the rising drift (`w·max(s, 0)`), as a fourth feature set | 79.0 % |
//! | + centroid of the falling drift (`w·max(−s, 0)`) | 80.2 % |
//! | + both | 80.2 % |
//! | + displacement of the drift centroid from the first to the second half of the span | 80.2 % |
//! | + flow of change across neighbouring taxels (pairs < 6.5 mm apart: asymmetry of the 50 ms lagged correlation of their smoothed, standardised first differences, summed along the pair's direction) — flow vector / curl / both | 79.6 / 79.6 / 80.2 % (class means indistinguishable) |
//! | + rotation of the drift pattern (principal-axis orientation of the first third's drift map to the last third's, weighted by anisotropy) | 79.6 % |
//! | sub-span voting: features of overlapping 1.4 s / 1 s / 2 s / 0.7 s sub-spans, summed class distances | 78.4 / 79.6 / 77.8 / 77.8 % |
//! | per-taxel maps `[w, w·s]` (48 values), L2 logistic regression with mirror augmentation (plain LOOO, 3 strengths) | 75.4–76.6 % |
//! | the seven drift moments, logistic regression (plain LOOO) | 71.9–76.6 % |
//! | model fitted on prefixes (1, 2 s and whole) for early answers (plain LOOO at 1 s / whole) | 68.9 / 82.6 % vs 70.1 / 83.2 % |
//!
//! The rows after the first were exploratory re-implementations (numpy) of the same features and
//! rule; none beat the grid, so none was ported. The cross-set figures of the shipped grid were
//! printed once before those explorations; nothing was changed after seeing them.
//!
//! *What changed, and what it buys.* The drift map now differences raw values
//! ([`DriftScale::Linear`]), which makes every default feature exactly invariant to a gain and
//! an offset per recording (tested, `tests/dos_invariance.rs`: ×0.5, ×2 and added offsets
//! change no decision, on synthetic and on all 167 real recordings); the log scale gave the same
//! accuracy. Calibration adds every recording's mirror image across `y = 0`
//! ([`mirror_augmented`]), so the model is symmetric: a recording mirrored on the layout gets the
//! mirrored class (`e` ↔ `w`, `cw` ↔ `aw`; all 167 real recordings). The event-centroid
//! features of the previous default are not offset-invariant and are no longer in it; with them
//! as candidates the nested choice gives the comparison row above — three recordings more in
//! the nested figure, two fewer basic → solids, the same solids → basic: no consistent gain
//! for losing the invariance.
//!
//! **Why it works, and what does not.** Slip on the BioTac shows as slow (< 3 Hz) drifts of the
//! electrode impedances, strongest where the contact is leaving; their signs differ between
//! objects (so signed net changes classify poorly, ≈ 40 %), their *amplitudes* relative to each
//! electrode's own noise do not. Events count the same drifts but in absolute log units, so a
//! noisy electrode looks busy. Vibration above 5 Hz, the event track's displacement and
//! rotation, and the maximal contour add little: rotational slip of a real object barely moves
//! or turns the activity on the 24 electrodes; `cw`/`aw` are told apart mainly by
//! `drift_signed_y` and `drift_anisotropy`, and 7 of the 48 rotation recordings have the side
//! asymmetry reversed — the main remaining error.
//!
//! # Decision rule
//! [`DosModel::calibrate`] fits class means `μ_c`, pooled within-class variances `σ²_j` and
//! per-class variances shrunk toward them, `σ²_{c,j} = λ·σ²_j + (1 − λ)·s²_{c,j}` with
//! `s²_{c,j}` the class's own variance and `λ` = [`DosModel::DEFAULT_SHRINKAGE`] = 0 (chosen by
//! the nested procedure above, not fitted; [`DosModel::calibrate_with_shrinkage`] takes
//! another; 0.5 before). With
//! `m_c = Σ_j (f_j − μ_{c,j})² / σ²_{c,j}` a feature vector `f` of `d` features gets the class
//! minimising `D_c = Σ_j ln σ²_{c,j} + (ν + d)·ln(1 + m_c/ν)` (ties: the first class in the
//! model's order): the maximum-likelihood class of a multivariate Student t per class with
//! diagonal scales, `ν` = [`DosModel::DEFAULT_STUDENT_T_DOF`] = 3 degrees of freedom and equal
//! priors. One feature far off its class mean costs logarithmically, not quadratically, so a
//! recording that is unusual in one feature (an object-specific offset) is not thrown out of
//! its class by it. [`DosModel::with_student_t_dof`]`(None)` (and model files without
//! `student_t_dof`) use the Gaussian `D_c = Σ_j ln σ²_{c,j} + m_c`. Where `m_c` overflows
//! (features near ±`f64::MAX`) it is evaluated as `ln m_c` by log-sum-exp, so the decision
//! and the posterior stay defined. With `λ = 1` (or a model
//! file without `class_variances`) every class shares `σ²_j`, the log terms drop and the rule is
//! the nearest class mean in `m_c`. [`Decision::posterior`] gives `softmax(−D_c/2)`.
//!
//! **Parameter count:** `2 × classes × features` numbers — a mean and a variance per class and
//! feature (the stored pooled variances only feed the shrinkage). With the 7 classes and the 7
//! default features: **98** (56 = `(7 + 1) × 7` for the pooled model). Configuration
//! (threshold, drift lags and scale, window, grid, contour settings, centroid method, the
//! feature list, `λ`, `ν`, mirror augmentation) is fixed, not fitted. Calibration with the
//! mirror images doubles the samples, not the parameters.
//!
//! # Class names → directions (layout axes of [`Layout::biotac_sp`](gradtac_stream::Layout::biotac_sp): x along the finger toward the tip, y across)
//! | class | contact motion | [`DosClass::direction`] / [`DosClass::rotation_sense`] |
//! |---|---|---|
//! | `n` | toward the tip | `+x` |
//! | `s` | toward the palm | `−x` |
//! | `e` | across | `+y` |
//! | `w` | across | `−y` |
//! | `cw` | rotation from `+x` toward `+y` | `+1` |
//! | `aw` | rotation from `+y` toward `+x` | `−1` |
//! | `t` | none | — |
//!
//! *How the translations were determined* (BioTacSP-DoS development subset, 167 recordings):
//! pressing the skin lowers a BioTac electrode's count — across recordings each electrode's
//! counts lie far below its largest value (≈ its rest value, 3 600–3 700) and never much above.
//! The class-mean change of counts (last 20 frames minus first 20) then shows where pressure
//! goes: for `n` the counts rise (pressure leaves) at the proximal electrodes (x ≈ −6…−11 mm:
//! e8–e10, e18–e20) and fall (pressure arrives) at the pad's middle and tip (e15, e23, e24,
//! x ≈ 0…5 mm): the contact moves toward `+x`. `s` is the mirror image (rise at e21–e24, fall at
//! e8/e18: `−x`); `e` rises on the `−y` side (e3–e7), so the contact moves toward `+y`; `w`
//! rises on the `+y` side (e11–e17): `−y`. The event features agree: the events concentrate
//! on the side the contact leaves (class-mean event centroids `n` x ≈ −4 mm, `s` x ≈ +2,
//! `e` y ≈ −5.5, `w` y ≈ +4.7), and so does the drift map (`drift_x` `n` −1.9 mm, `s` +1.4;
//! `drift_y` `e` −3.1, `w` +2.7). Viewed from outside the pad with the tip up, `+y` is to the
//! right, so this is the compass: north up, east right.
//! *Rotation sense* is the compass convention (clockwise = north toward east = `+x` toward
//! `+y`, the direction in which [`MaxContour::orientation_rad`](crate::contour::MaxContour)
//! and the `rotation` feature grow). It is **not** confirmed by the data: on the development
//! subset the `rotation` feature of `cw` and `aw` recordings does not differ (class means
//! −0.38 and +0.20 rad with spreads above 1 rad; see `dos_eval`'s printout). What does differ
//! is `drift_signed_y` (class means `cw` −1.2 mm, `aw` +2.3 mm, spreads ≈ 2.3 mm: in `cw` the
//! `−y` side's counts tend to rise and the `+y` side's to fall, in `aw` the reverse) — a
//! signature the classifier learns, not a geometric derivation of the sense.
//!
//! # Units, delay, cost
//! Input in raw sensor counts (> 0; a value ≤ 0 is raised to the events stage's floor,
//! 1e-3). The extractor has no delay of its own: a decision covers the span pushed so far
//! ([`DosClassifier`]: every `decision_frames` frames, or at `finish`), and needs more than
//! the shortest drift lag (0.3 s) of it to weigh anything — see the latency trade above.
//! Extracting the default features costs 0.26–0.28 µs per frame (`dos_eval`; criterion
//! `--bench tasks`: 0.28 µs, of which the drift map 0.14 µs), every feature with surface
//! locations of the track windows 0.65 µs (32 × 32 natural neighbour); the drift map keeps the last
//! `max(drift_lags)` frames (60 × 24 values with the default lags). A decision is `classes × features`
//! multiply-adds and `classes` logarithms (plus `classes × features` with per-class variances).
//!
//! # Trade-offs
//! | knob | lower | higher |
//! |---|---|---|
//! | `drift_lags` | sees fast, short slips; noise weighs more | sees slow drifts; needs longer spans |
//! | `threshold` τ (event features) | more noise events (quiet touch looks busy) | loses slow, small slips |
//! | `track_window_frames` | noisy track, more rotation samples | smeared track, few samples |
//! | `min_area_mm2` (max contour) | centroid snaps to the busiest taxel | centroid averages a larger region |
//! | [`CentroidMethod`] | `taxels`: cheapest, most accurate here | `surface` / `max_contour`: the paper's geometry, 2× the cost, less accurate here |
//! | features | fewer: fewer parameters, more robust on unseen objects | more: fits the seen objects better |
//! | shrinkage `λ` | 0: each class's own spread (e.g. quiet `t`), noisy with few recordings per class | 1: one pooled spread, fewest parameters |
//! | Student-t `ν` | heavier tails: one odd feature matters less | `∞`: the Gaussian, every deviation counts quadratically |
//! | `decision_frames` (stage) | faster answers from little evidence (1 s: ≈ 65 % cross-set) | later, surer answers (whole recordings: 67–86 % cross-set) |
//! | mirror augmentation | off: the model may learn a side preference of the training data | on (default): symmetric model, twice the samples, same parameter count |
//! | drift scale | `log`: the previous default, gain-invariant only | `linear` (default): gain- and offset-invariant, same accuracy |
//! | hop ([`DosClassifier::with_hop`]) | an answer every few frames; one `decision_frames` extraction each | fewer answers, less CPU |

use crate::contour::{ContourConfig, Levels, MaxContour, MaxContourFinder, Saddle};
use crate::drift::{DriftMap, DriftScale};
use crate::events::{Events, EventsConfig, Threshold};
use crate::interpolate::{GridConfig, Interpolator, Method, Outside};
use crate::window::{Aggregate, Window, WindowAggregate, WindowConfig, WindowKind};
use crate::{Error, EventBatch, Result};
use gradtac_stream::{Delay, HasSensor, Layout, SensorId, Stage, TaxelFrame, Timed, Timestamp};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;
use std::sync::Arc;

const STAGE: &str = "dos";

fn invalid(reason: impl Into<String>) -> Error {
    Error::InvalidConfig { stage: STAGE, reason: reason.into() }
}

// ---------------------------------------------------------------------------------------------
// Classes
// ---------------------------------------------------------------------------------------------

/// A BioTacSP-DoS class (see the [module docs](self) for the map to layout directions).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DosClass {
    /// Translational slip north: contact moves toward `+x` (the fingertip).
    N,
    /// Translational slip east: contact moves toward `+y`.
    E,
    /// Translational slip south: contact moves toward `−x`.
    S,
    /// Translational slip west: contact moves toward `−y`.
    W,
    /// Rotational slip clockwise (`+x` toward `+y`).
    Cw,
    /// Rotational slip anticlockwise (`+y` toward `+x`).
    Aw,
    /// Stable touch, no slip.
    T,
}

impl DosClass {
    /// All seven classes in the dataset's order (`n, e, s, w, cw, aw, t`).
    pub const ALL: [DosClass; 7] =
        [DosClass::N, DosClass::E, DosClass::S, DosClass::W, DosClass::Cw, DosClass::Aw, DosClass::T];

    /// The dataset's name (`"n"`, …, `"t"`).
    pub fn as_str(self) -> &'static str {
        match self {
            DosClass::N => "n",
            DosClass::E => "e",
            DosClass::S => "s",
            DosClass::W => "w",
            DosClass::Cw => "cw",
            DosClass::Aw => "aw",
            DosClass::T => "t",
        }
    }

    /// Unit vector of the contact's motion in the layout's axes for a translational class
    /// (`n` → `[1, 0]`, `e` → `[0, 1]`, `s` → `[−1, 0]`, `w` → `[0, −1]`); `None` otherwise.
    pub fn direction(self) -> Option<[f64; 2]> {
        match self {
            DosClass::N => Some([1.0, 0.0]),
            DosClass::E => Some([0.0, 1.0]),
            DosClass::S => Some([-1.0, 0.0]),
            DosClass::W => Some([0.0, -1.0]),
            _ => None,
        }
    }

    /// `+1` for `cw` (rotation from `+x` toward `+y`, growing orientation angle), `−1` for
    /// `aw`, `None` otherwise.
    pub fn rotation_sense(self) -> Option<f64> {
        match self {
            DosClass::Cw => Some(1.0),
            DosClass::Aw => Some(-1.0),
            _ => None,
        }
    }

    /// The class of the same slip seen in a layout mirrored across `y = 0` (the BioTac SP's
    /// electrodes 11–20 mirror 1–10): `e` ↔ `w` (the `y` component of the motion flips) and
    /// `cw` ↔ `aw` (a reflection reverses every rotation); `n`, `s` and `t` stay.
    pub fn mirrored(self) -> DosClass {
        match self {
            DosClass::E => DosClass::W,
            DosClass::W => DosClass::E,
            DosClass::Cw => DosClass::Aw,
            DosClass::Aw => DosClass::Cw,
            other => other,
        }
    }

    /// The translational class whose direction is closest to `v` (layout axes), `None` for a
    /// zero or non-finite vector.
    pub fn from_direction(v: [f64; 2]) -> Option<DosClass> {
        if !(v[0].is_finite() && v[1].is_finite()) || (v[0] == 0.0 && v[1] == 0.0) {
            return None;
        }
        [DosClass::N, DosClass::E, DosClass::S, DosClass::W].into_iter().max_by(|a, b| {
            let (da, db) = (a.direction().unwrap_or([0.0; 2]), b.direction().unwrap_or([0.0; 2]));
            (da[0] * v[0] + da[1] * v[1]).total_cmp(&(db[0] * v[0] + db[1] * v[1]))
        })
    }
}

impl fmt::Display for DosClass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for DosClass {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        DosClass::ALL
            .into_iter()
            .find(|c| c.as_str().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| invalid(format!("unknown class {s:?}; expected one of n, e, s, w, cw, aw, t")))
    }
}

// ---------------------------------------------------------------------------------------------
// Features
// ---------------------------------------------------------------------------------------------

/// One feature (see the table in the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Feature {
    /// `ln(1 + events per second)`.
    Rate,
    /// Positive events / all events.
    PositiveFraction,
    /// Positive-event contour centroid x (mm).
    PositiveX,
    /// Positive-event contour centroid y (mm).
    PositiveY,
    /// Negative-event contour centroid x (mm).
    NegativeX,
    /// Negative-event contour centroid y (mm).
    NegativeY,
    /// All-event contour centroid x (mm).
    ActivityX,
    /// All-event contour centroid y (mm).
    ActivityY,
    /// Track displacement along x (mm).
    TrackDx,
    /// Track displacement along y (mm).
    TrackDy,
    /// Contour rotation (rad).
    Rotation,
    /// `ln(1 + W)`, `W` the summed drift-to-noise weight of all taxels.
    DriftLevel,
    /// Drift-weighted centroid x (mm).
    DriftX,
    /// Drift-weighted centroid y (mm).
    DriftY,
    /// `ln(1 + weighted mean squared distance from the drift centroid in mm²)`.
    DriftSpread,
    /// Weighted mean of `(x − x̄)² − (y − ȳ)²` about the drift centroid (mm²).
    DriftAnisotropy,
    /// Weighted mean of `(x − x̄)(y − ȳ)` about the drift centroid (mm²).
    DriftCross,
    /// Weighted mean of `sign · y` (mm): the signed across-finger dipole of the drift.
    DriftSignedY,
}

impl Feature {
    /// Every feature, in the order of [`FeatureVector::all`].
    pub const ALL: [Feature; 18] = [
        Feature::Rate,
        Feature::PositiveFraction,
        Feature::PositiveX,
        Feature::PositiveY,
        Feature::NegativeX,
        Feature::NegativeY,
        Feature::ActivityX,
        Feature::ActivityY,
        Feature::TrackDx,
        Feature::TrackDy,
        Feature::Rotation,
        Feature::DriftLevel,
        Feature::DriftX,
        Feature::DriftY,
        Feature::DriftSpread,
        Feature::DriftAnisotropy,
        Feature::DriftCross,
        Feature::DriftSignedY,
    ];

    /// The default set: the seven drift features (chosen by the nested procedure of
    /// [`crate::dos_select`] on the BioTacSP-DoS development subset, see the [module docs](self);
    /// exactly invariant to a gain and an offset per recording on the linear drift scale).
    pub const DEFAULT: [Feature; 7] = Feature::DRIFT;

    /// The default before the invariant design: the seven drift features (then on the log
    /// scale) and the positive-event centroid.
    pub const DEFAULT_BEFORE_INVARIANCE: [Feature; 9] = [
        Feature::DriftLevel,
        Feature::DriftX,
        Feature::DriftY,
        Feature::DriftSpread,
        Feature::DriftAnisotropy,
        Feature::DriftCross,
        Feature::DriftSignedY,
        Feature::PositiveX,
        Feature::PositiveY,
    ];

    /// The default before the drift features: rate, positive fraction, positive- and negative-event
    /// centroids.
    pub const EVENTS: [Feature; 6] = [
        Feature::Rate,
        Feature::PositiveFraction,
        Feature::PositiveX,
        Feature::PositiveY,
        Feature::NegativeX,
        Feature::NegativeY,
    ];

    /// The seven drift features.
    pub const DRIFT: [Feature; 7] = [
        Feature::DriftLevel,
        Feature::DriftX,
        Feature::DriftY,
        Feature::DriftSpread,
        Feature::DriftAnisotropy,
        Feature::DriftCross,
        Feature::DriftSignedY,
    ];

    /// The snake_case name used in model files.
    pub fn name(self) -> &'static str {
        match self {
            Feature::Rate => "rate",
            Feature::PositiveFraction => "positive_fraction",
            Feature::PositiveX => "positive_x",
            Feature::PositiveY => "positive_y",
            Feature::NegativeX => "negative_x",
            Feature::NegativeY => "negative_y",
            Feature::ActivityX => "activity_x",
            Feature::ActivityY => "activity_y",
            Feature::TrackDx => "track_dx",
            Feature::TrackDy => "track_dy",
            Feature::Rotation => "rotation",
            Feature::DriftLevel => "drift_level",
            Feature::DriftX => "drift_x",
            Feature::DriftY => "drift_y",
            Feature::DriftSpread => "drift_spread",
            Feature::DriftAnisotropy => "drift_anisotropy",
            Feature::DriftCross => "drift_cross",
            Feature::DriftSignedY => "drift_signed_y",
        }
    }

    fn index(self) -> usize {
        Feature::ALL.iter().position(|&f| f == self).unwrap_or(0)
    }

    /// How the feature changes when the recording is mirrored across `y = 0` on a layout
    /// symmetric about that line: `−1` for the features odd in `y` (`*_y` locations,
    /// `drift_cross`, `drift_signed_y`, `track_dy`, and `rotation`, whose sense a reflection
    /// reverses), `+1` for the others.
    pub fn mirror_sign(self) -> f64 {
        match self {
            Feature::PositiveY
            | Feature::NegativeY
            | Feature::ActivityY
            | Feature::TrackDy
            | Feature::Rotation
            | Feature::DriftY
            | Feature::DriftCross
            | Feature::DriftSignedY => -1.0,
            _ => 1.0,
        }
    }
}

/// Every feature of one span (see [`Feature`]); select with [`FeatureVector::select`]. A
/// feature whose part the extractor did not build (see [`DosFeatureExtractor`]) is NaN.
///
/// Equality compares the values bit for bit: NaN (not computed) equals NaN, `0.0` and `−0.0`
/// differ — two vectors are equal when they would be stored identically.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct FeatureVector {
    /// The values in [`Feature::ALL`] order.
    pub all: [f64; 18],
    /// Number of frames in the span.
    pub frames: u64,
    /// Number of events in the span.
    pub events: u64,
}

impl PartialEq for FeatureVector {
    fn eq(&self, other: &Self) -> bool {
        self.frames == other.frames
            && self.events == other.events
            && self.all.iter().zip(&other.all).all(|(a, b)| a.to_bits() == b.to_bits())
    }
}

impl FeatureVector {
    /// Whether every feature was computed and is finite.
    pub fn is_complete(&self) -> bool {
        self.all.iter().all(|v| v.is_finite())
    }

    /// One feature's value.
    pub fn get(&self, f: Feature) -> f64 {
        self.all[f.index()]
    }

    /// The values of `features`, in that order.
    pub fn select(&self, features: &[Feature]) -> Vec<f64> {
        features.iter().map(|&f| self.get(f)).collect()
    }
}

/// Configuration of the feature extraction, stored in the model file (`[stages.dos.features]`).
///
/// ```toml
/// threshold = 0.005          # τ on ln(counts)
/// track_window_frames = 25   # frames per track window
/// grid_nx = 32               # surface grid points per axis
/// min_area_mm2 = 15.0        # smallest maximal-contour area
/// min_peak = 1.0             # events; below it a surface has no contact
/// centroid = "taxels"        # or "surface", "max_contour"
/// drift_lags = [30, 60]     # frames
/// drift_scale = "linear"     # or "log"
/// features = ["drift_level", "drift_x", "drift_y", "drift_spread", "drift_anisotropy",
///             "drift_cross", "drift_signed_y"]
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DosFeatureConfig {
    /// Event threshold `τ` on `ln(counts)` (dimensionless, ≥ 1e-12). Default 0.005 (≈ 17 counts
    /// at 3 500).
    pub threshold: f64,
    /// Frames per tumbling track window (≥ 2). Default 25 (0.25 s at 100 Hz).
    pub track_window_frames: u64,
    /// Grid points per axis of the natural-neighbour surfaces (≥ 4). Default 32.
    pub grid_nx: usize,
    /// Smallest area (mm²) of a maximal contour. Default 15.
    pub min_area_mm2: f64,
    /// Smallest surface peak (events) for a contour. Default 1.
    pub min_peak: f64,
    /// How a count surface's location is taken. Default [`CentroidMethod::Taxels`].
    pub centroid: CentroidMethod,
    /// Lags of the [drift map](crate::drift) in frames (non-empty, each in `1..=100000`, no
    /// repeats). Default `[30, 60]` (0.3, 0.6 s at 100 Hz).
    pub drift_lags: Vec<u64>,
    /// The values the drift map differences. Default [`DriftScale::Linear`] (exactly invariant to
    /// a gain and an offset per recording); [`DriftScale::Log`] is the scale of models written
    /// before the field existed (such files now compute the linear map: the weights differ by
    /// well under the spread between recordings, see the [module docs](self)).
    pub drift_scale: DriftScale,
    /// The features the classifier uses, in order (non-empty, no repeats). Default: the seven
    /// of [`Feature::DEFAULT`].
    pub features: Vec<Feature>,
}

impl Default for DosFeatureConfig {
    fn default() -> Self {
        DosFeatureConfig {
            threshold: 0.005,
            track_window_frames: 25,
            grid_nx: 32,
            min_area_mm2: 15.0,
            min_peak: 1.0,
            centroid: CentroidMethod::Taxels,
            drift_lags: vec![30, 60],
            drift_scale: DriftScale::Linear,
            features: Feature::DEFAULT.to_vec(),
        }
    }
}

impl DosFeatureConfig {
    /// Checks every field (see their docs).
    pub fn validate(&self) -> Result<()> {
        if !(self.threshold.is_finite() && self.threshold >= crate::events::MIN_THRESHOLD) {
            return Err(invalid(format!("threshold {} must be finite and ≥ 1e-12", self.threshold)));
        }
        if !(2..=crate::limits::MAX_DOS_FRAMES).contains(&self.track_window_frames) {
            return Err(invalid(format!(
                "track_window_frames {} must be in 2..={}",
                self.track_window_frames,
                crate::limits::MAX_DOS_FRAMES
            )));
        }
        if !(4..=1024).contains(&self.grid_nx) {
            return Err(invalid(format!("grid_nx {} must be in 4..=1024", self.grid_nx)));
        }
        if !(self.min_area_mm2.is_finite() && self.min_area_mm2 >= 0.0) {
            return Err(invalid(format!("min_area_mm2 {} must be finite and ≥ 0", self.min_area_mm2)));
        }
        if !self.min_peak.is_finite() {
            return Err(invalid(format!("min_peak {} must be finite", self.min_peak)));
        }
        DriftMap::try_new(1, &self.drift_lags, EventsConfig::default().floor)
            .map_err(|e| invalid(format!("drift_lags: {e}")))?;
        if self.features.is_empty() {
            return Err(invalid("features must not be empty"));
        }
        for (i, f) in self.features.iter().enumerate() {
            if self.features[..i].contains(f) {
                return Err(invalid(format!("feature {} appears twice", f.name())));
            }
        }
        Ok(())
    }
}

/// How the location of an event-count surface is taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CentroidMethod {
    /// The value-weighted centroid of the whole natural-neighbour surface (inside the taxels'
    /// hull): every event counts, weighted by the area it spreads over.
    Surface,
    /// The centroid of the maximal contour (the region of touch of method.md stage 6): the
    /// busiest region only.
    MaxContour,
    /// The count-weighted mean of the taxel positions (no interpolation): each taxel weighs
    /// by its own events, not by the area it covers. The default: it scored best on
    /// BioTacSP-DoS (see the [module docs](self)).
    #[default]
    Taxels,
}

/// One track window's activity contour.
#[derive(Clone, Copy, Debug)]
struct TrackSample {
    centroid: [f64; 2],
    orientation: f64,
    eccentricity: f64,
}

/// Extracts a [`FeatureVector`] from raw frames of one sensor: events → split counts → surfaces
/// → maximal contours, and the drift map. A plain state machine: [`push`](Self::push) frames,
/// read [`features`](Self::features) for the span so far, [`clear_span`](Self::clear_span) to
/// start a new span without losing the event references, [`reset`](Self::reset) on a
/// discontinuity.
///
/// It builds and runs only what its configured features need: the events always (they check
/// the input and give the event features), the track window and its per-window locations only
/// for `track_dx`, `track_dy` or `rotation`, the drift map only for a `drift_*` feature, and
/// surfaces and contours only for the `surface` and `max_contour` [`CentroidMethod`]s. The
/// features of a part that was not built are NaN in the [`FeatureVector`]; to compute every
/// feature (e.g. to compare feature sets), configure [`Feature::ALL`].
#[derive(Clone, Debug)]
pub struct DosFeatureExtractor {
    cfg: DosFeatureConfig,
    taxels: usize,
    events: Events,
    /// Track window (`None`: no track feature configured).
    window: Option<Window>,
    /// Surfaces and contours (`None` with [`CentroidMethod::Taxels`]).
    spatial: Option<(Interpolator, MaxContourFinder)>,
    centre: [f64; 2],
    positions: Vec<[f64; 2]>,
    seconds: (Option<Timestamp>, Option<Timestamp>),
    pos: Vec<f64>,
    neg: Vec<f64>,
    frames: u64,
    track: Vec<TrackSample>,
    batches: Vec<EventBatch>,
    windows: Vec<WindowAggregate>,
    /// Drift map (`None`: no drift feature configured).
    drift: Option<DriftMap>,
    /// The pushed frame's values (the frame itself moves into the events stage).
    values: Vec<f64>,
}

/// Whether `features` use any of `part`.
fn uses(features: &[Feature], part: &[Feature]) -> bool {
    features.iter().any(|f| part.contains(f))
}

/// The features computed from the track windows.
const TRACK: [Feature; 3] = [Feature::TrackDx, Feature::TrackDy, Feature::Rotation];

impl DosFeatureExtractor {
    /// An extractor for `layout`'s sensor (validating the configuration).
    pub fn try_new(cfg: &DosFeatureConfig, layout: &Layout) -> Result<Self> {
        cfg.validate()?;
        let taxels = layout.len();
        let events = Events::try_new(
            taxels,
            EventsConfig { threshold: Threshold::Uniform(cfg.threshold), ..Default::default() },
        )?;
        let window = if uses(&cfg.features, &TRACK) {
            Some(Window::try_new(&WindowConfig {
                kind: WindowKind::Tumbling,
                frames: Some(cfg.track_window_frames),
                duration_ms: None,
                step: 1,
                aggregate: Aggregate::Split,
            })?)
        } else {
            None
        };
        let spatial = if cfg.centroid == CentroidMethod::Taxels {
            None
        } else {
            let grid =
                crate::interpolate::Grid::from_config(&GridConfig { nx: cfg.grid_nx, ..Default::default() }, layout)?;
            let interp =
                Interpolator::try_new(layout, Arc::new(grid), Method::NaturalNeighbour, Outside::Nan, 2.0, 0.0)?;
            let finder = MaxContourFinder::try_new(&ContourConfig {
                levels: Levels::Count(10),
                min_area_mm2: cfg.min_area_mm2,
                min_peak: cfg.min_peak,
                saddle: Saddle::Centre,
                peak_only: true,
            })?;
            Some((interp, finder))
        };
        let drift = if uses(&cfg.features, &Feature::DRIFT) {
            Some(DriftMap::try_new(taxels, &cfg.drift_lags, EventsConfig::default().floor)?.with_scale(cfg.drift_scale))
        } else {
            None
        };
        Ok(DosFeatureExtractor {
            cfg: cfg.clone(),
            taxels,
            events,
            window,
            spatial,
            centre: layout.extent().centre(),
            positions: layout.positions().to_vec(),
            seconds: (None, None),
            pos: vec![0.0; taxels],
            neg: vec![0.0; taxels],
            frames: 0,
            track: Vec::new(),
            batches: Vec::new(),
            windows: Vec::new(),
            drift,
            values: vec![0.0; taxels],
        })
    }

    /// The configuration.
    pub fn config(&self) -> &DosFeatureConfig {
        &self.cfg
    }

    /// Frames in the current span.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Push one raw frame (counts). Errors name the sensor, frame and taxel (wrong taxel count,
    /// non-finite value, time going backwards).
    pub fn push(&mut self, frame: TaxelFrame) -> Result<()> {
        crate::error::check_taxel_count(STAGE, &frame.sensor, frame.seq, self.taxels, frame.values.len())?;
        self.batches.clear();
        let time = frame.time;
        if self.drift.is_some() {
            self.values.copy_from_slice(&frame.values);
        }
        self.events.push(frame, &mut self.batches)?;
        if let Some(drift) = &mut self.drift {
            // The events stage refuses non-finite values (its default policy), so this cannot fail.
            drift.push(&self.values)?;
        }
        self.seconds = (self.seconds.0.or(Some(time)), Some(time));
        self.frames += 1;
        for b in self.batches.drain(..) {
            for e in &b.events {
                let t = e.taxel as usize;
                if e.polarity > 0 {
                    self.pos[t] += 1.0;
                } else {
                    self.neg[t] += 1.0;
                }
            }
            if let Some(window) = &mut self.window {
                window.push(b, &mut self.windows)?;
            }
        }
        let mut windows = std::mem::take(&mut self.windows);
        for w in &windows {
            let Some(split) = &w.split else { continue };
            let counts: Vec<f64> = split.positive.iter().zip(&split.negative).map(|(p, n)| p + n).collect();
            if let Some(sample) = self.locate(&counts) {
                self.track.push(sample);
            }
        }
        windows.clear();
        self.windows = windows;
        Ok(())
    }

    /// The features of the span so far (see the [module docs](self)).
    pub fn features(&mut self) -> FeatureVector {
        let p: f64 = self.pos.iter().sum();
        let n: f64 = self.neg.iter().sum();
        let total = p + n;
        let mut all = [0.0; 18];
        all[Feature::Rate.index()] = (1.0 + total / self.span_seconds()).ln();
        all[Feature::PositiveFraction.index()] = if total > 0.0 { p / total } else { 0.5 };
        let pc = self.centroid(&self.pos.clone());
        let nc = self.centroid(&self.neg.clone());
        let activity: Vec<f64> = self.pos.iter().zip(&self.neg).map(|(a, b)| a + b).collect();
        let ac = self.centroid(&activity);
        all[Feature::PositiveX.index()] = pc[0];
        all[Feature::PositiveY.index()] = pc[1];
        all[Feature::NegativeX.index()] = nc[0];
        all[Feature::NegativeY.index()] = nc[1];
        all[Feature::ActivityX.index()] = ac[0];
        all[Feature::ActivityY.index()] = ac[1];
        let (d, rot) = if self.window.is_some() { track_motion(&self.track) } else { ([f64::NAN; 2], f64::NAN) };
        all[Feature::TrackDx.index()] = d[0];
        all[Feature::TrackDy.index()] = d[1];
        all[Feature::Rotation.index()] = rot;
        let drift = self.drift_features();
        for (f, v) in Feature::DRIFT.iter().zip(drift) {
            all[f.index()] = v;
        }
        FeatureVector { all, frames: self.frames, events: total as u64 }
    }

    /// Start a new span: counts, track and frame count restart, the event references (and the
    /// partly filled track window) are kept.
    pub fn clear_span(&mut self) {
        self.pos.iter_mut().for_each(|v| *v = 0.0);
        self.neg.iter_mut().for_each(|v| *v = 0.0);
        self.frames = 0;
        self.seconds = (None, None);
        self.track.clear();
        if let Some(d) = &mut self.drift {
            d.clear_span();
        }
    }

    /// Forget everything (a discontinuity in the stream).
    pub fn reset(&mut self) {
        self.clear_span();
        self.events.reset();
        if let Some(w) = &mut self.window {
            w.reset();
        }
        if let Some(d) = &mut self.drift {
            d.reset();
        }
    }

    /// The seven drift features ([`Feature::DRIFT`] order) of the span so far: the
    /// [drift map](crate::drift)'s weights `w_i` and signs `s_i` located on the layout. Without
    /// weight the centroid is the layout's centre and the moments are zero; NaN without a drift
    /// map.
    fn drift_features(&self) -> [f64; 7] {
        let Some(drift) = &self.drift else { return [f64::NAN; 7] };
        let snap = drift.snapshot();
        let total: f64 = snap.weights.iter().sum();
        let level = total.ln_1p();
        if !(total > 0.0 && total.is_finite()) {
            return [level, self.centre[0], self.centre[1], 0.0, 0.0, 0.0, 0.0];
        }
        let (mut cx, mut cy) = (0.0, 0.0);
        for (w, p) in snap.weights.iter().zip(&self.positions) {
            cx += w * p[0];
            cy += w * p[1];
        }
        let (cx, cy) = (cx / total, cy / total);
        let (mut r2, mut aniso, mut cross, mut signed_y) = (0.0, 0.0, 0.0, 0.0);
        for ((w, s), p) in snap.weights.iter().zip(&snap.signs).zip(&self.positions) {
            let (dx, dy) = (p[0] - cx, p[1] - cy);
            r2 += w * (dx * dx + dy * dy);
            aniso += w * (dx * dx - dy * dy);
            cross += w * dx * dy;
            signed_y += w * s * p[1];
        }
        [level, cx, cy, (r2 / total).ln_1p(), aniso / total, cross / total, signed_y / total]
    }

    /// The span's duration: `(t_last − t_first)·n/(n − 1)` for `n` frames (one mean frame
    /// interval per frame); 10 ms per frame when the times do not tell (fewer than two frames,
    /// equal times).
    pub fn span_seconds(&self) -> f64 {
        let n = self.frames as f64;
        match self.seconds {
            (Some(a), Some(b)) if self.frames >= 2 && b > a => (b - a) as f64 * 1e-9 * n / (n - 1.0),
            _ => 0.01 * n.max(1.0),
        }
    }

    fn centroid(&mut self, values: &[f64]) -> [f64; 2] {
        self.locate(values).map_or(self.centre, |s| s.centroid)
    }

    /// Location, orientation and eccentricity of a count distribution by the configured method.
    fn locate(&mut self, values: &[f64]) -> Option<TrackSample> {
        match (&mut self.spatial, self.cfg.centroid) {
            (Some((interp, finder)), CentroidMethod::MaxContour) => contour(interp, finder, values).map(|c| {
                TrackSample { centroid: c.centroid_mm, orientation: c.orientation_rad, eccentricity: c.eccentricity }
            }),
            (Some((interp, _)), CentroidMethod::Surface) => {
                let z = interp.surface(values);
                let g = interp.grid();
                weighted_moments(z.indexed_iter().map(|((j, i), &v)| (g.x(i), g.y(j), v)))
            }
            // Taxels (try_new builds the surfaces for every other method)
            _ => weighted_moments(values.iter().zip(&self.positions).map(|(&v, p)| (p[0], p[1], v))),
        }
    }
}

/// Centroid, principal-axis orientation (rad, `(−π/2, π/2]`) and eccentricity
/// `√(1 − λ_min/λ_max)` of positive finite weights at points; `None` without weight.
fn weighted_moments(points: impl Iterator<Item = (f64, f64, f64)> + Clone) -> Option<TrackSample> {
    let (mut w, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for (x, y, v) in points.clone() {
        if v.is_finite() && v > 0.0 {
            w += v;
            sx += v * x;
            sy += v * y;
        }
    }
    if !(w > 0.0 && w.is_finite()) {
        return None;
    }
    let c = [sx / w, sy / w];
    let (mut xx, mut yy, mut xy) = (0.0, 0.0, 0.0);
    for (x, y, v) in points {
        if v.is_finite() && v > 0.0 {
            let (dx, dy) = (x - c[0], y - c[1]);
            xx += v * dx * dx;
            yy += v * dy * dy;
            xy += v * dx * dy;
        }
    }
    let (xx, yy, xy) = (xx / w, yy / w, xy / w);
    let mut orientation = 0.5 * (2.0 * xy).atan2(xx - yy);
    if orientation <= -std::f64::consts::FRAC_PI_2 {
        orientation += std::f64::consts::PI;
    }
    let half = ((xx - yy).powi(2) / 4.0 + xy * xy).sqrt();
    let (hi, lo) = ((xx + yy) / 2.0 + half, ((xx + yy) / 2.0 - half).max(0.0));
    let eccentricity = if hi > 0.0 { (1.0 - lo / hi).clamp(0.0, 1.0).sqrt() } else { 0.0 };
    let finite = c[0].is_finite() && c[1].is_finite() && orientation.is_finite();
    finite.then_some(TrackSample { centroid: c, orientation, eccentricity })
}

fn contour(interp: &Interpolator, finder: &mut MaxContourFinder, values: &[f64]) -> Option<MaxContour> {
    let z = interp.surface(values);
    finder.find(z.view(), interp.grid()).contact().cloned()
}

/// `ln Σ_j (f_j − μ_j)² / v_j` without overflow for any finite `f`, `μ` and `v > 0`
/// (`−∞` when `f = μ`): each term's log from halved operands, summed by log-sum-exp.
fn ln_mahalanobis(means: &[f64], features: &[f64], vars: &[f64]) -> f64 {
    let terms: Vec<f64> = means
        .iter()
        .zip(features)
        .zip(vars)
        .map(|((mu, f), v)| 2.0 * ((f / 2.0 - mu / 2.0).abs().ln() + std::f64::consts::LN_2) - v.ln())
        .collect();
    let top = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if top == f64::NEG_INFINITY {
        return top;
    }
    top + terms.iter().map(|t| (t - top).exp()).sum::<f64>().ln()
}

/// Track displacement (last third minus first third of the samples) and eccentricity-weighted
/// rotation (sum of wrapped orientation changes).
fn track_motion(track: &[TrackSample]) -> ([f64; 2], f64) {
    let k = track.len();
    if k < 2 {
        return ([0.0; 2], 0.0);
    }
    let third = (k / 3).max(1);
    let mean = |s: &[TrackSample]| {
        let n = s.len() as f64;
        [s.iter().map(|t| t.centroid[0]).sum::<f64>() / n, s.iter().map(|t| t.centroid[1]).sum::<f64>() / n]
    };
    let (a, b) = (mean(&track[..third]), mean(&track[k - third..]));
    let mut rot = 0.0;
    for w in track.windows(2) {
        let d = wrap_half_pi(w[1].orientation - w[0].orientation);
        let weight = w[0].eccentricity.min(w[1].eccentricity);
        if d.is_finite() && weight.is_finite() {
            rot += weight * d;
        }
    }
    ([b[0] - a[0], b[1] - a[1]], rot)
}

/// An angle difference of axes (period π) wrapped to `(−π/2, π/2]`.
fn wrap_half_pi(d: f64) -> f64 {
    let pi = std::f64::consts::PI;
    let mut r = d.rem_euclid(pi);
    if r > pi / 2.0 {
        r -= pi;
    }
    r
}

// ---------------------------------------------------------------------------------------------
// Model
// ---------------------------------------------------------------------------------------------

/// The fitted classifier: feature configuration, class means, pooled and per-class variances.
/// Serialises to JSON / TOML (serde) and is validated when deserialised.
///
/// ```
/// use gradtac_stages::dos::{DosClass, DosFeatureConfig, DosModel};
/// let cfg = DosFeatureConfig { features: vec![gradtac_stages::dos::Feature::TrackDx], ..Default::default() };
/// let samples = vec![(DosClass::N, vec![2.0]), (DosClass::N, vec![3.0]), (DosClass::S, vec![-2.5]), (DosClass::S, vec![-3.5])];
/// let model = DosModel::calibrate(cfg, &samples)?;
/// assert_eq!(model.classify(&[1.0])?.class, DosClass::N);
/// assert_eq!(model.parameter_count(), 4); // a mean and a variance per class
/// # Ok::<(), gradtac_stages::Error>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, try_from = "RawModel")]
pub struct DosModel {
    /// How features are computed (and which are used).
    pub config: DosFeatureConfig,
    /// The classes the model knows, in decision order.
    pub classes: Vec<DosClass>,
    /// Class means, `classes.len()` rows of `config.features.len()` values.
    pub means: Vec<Vec<f64>>,
    /// Pooled within-class variance per feature (> 0): the decision's variances when
    /// `class_variances` is empty, otherwise what they were shrunk toward (information only).
    pub variances: Vec<f64>,
    /// Per-class variances, `classes.len()` rows of `config.features.len()` values (> 0):
    /// `λ·pooled + (1 − λ)·own` with `λ` = [`DosModel::DEFAULT_SHRINKAGE`] by
    /// [`DosModel::calibrate`]. Empty (or absent in the file, as in models written before they
    /// existed): every class uses the pooled `variances`.
    pub class_variances: Vec<Vec<f64>>,
    /// Number of labelled recordings the model was fitted on (information only).
    pub recordings: usize,
    /// Degrees of freedom `ν` of the class densities: `Some(ν)` (> 0) for a multivariate
    /// Student t with the diagonal scales above, `None` (or absent in the file, as in models
    /// written before it existed) for a Gaussian. Fixed, not fitted:
    /// [`DosModel::DEFAULT_STUDENT_T_DOF`] from [`calibrate`](DosModel::calibrate).
    pub student_t_dof: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawModel {
    config: DosFeatureConfig,
    classes: Vec<DosClass>,
    means: Vec<Vec<f64>>,
    variances: Vec<f64>,
    #[serde(default)]
    class_variances: Vec<Vec<f64>>,
    #[serde(default)]
    recordings: usize,
    #[serde(default)]
    student_t_dof: Option<f64>,
}

impl TryFrom<RawModel> for DosModel {
    type Error = Error;
    fn try_from(r: RawModel) -> Result<Self> {
        let m = DosModel {
            config: r.config,
            classes: r.classes,
            means: r.means,
            variances: r.variances,
            class_variances: r.class_variances,
            recordings: r.recordings,
            student_t_dof: r.student_t_dof,
        };
        m.validate()?;
        Ok(m)
    }
}

/// Smallest variance relative to a feature's total variance (keeps a constant feature from
/// dividing by zero).
const VARIANCE_FLOOR: f64 = 1e-6;

/// A decision: the class, and the distances and posteriors per class of the model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Decision {
    /// The chosen class.
    pub class: DosClass,
    /// `D_c` per model class (model order).
    pub distances: Vec<f64>,
    /// `softmax(−D_c/2)` per model class (model order).
    pub posterior: Vec<f64>,
}

impl DosModel {
    /// Shrinkage `λ` of [`calibrate`](Self::calibrate): each class keeps its own variances.
    /// Chosen by the nested procedure on all
    /// development recordings (see the [module docs](self)); 0.5 before.
    pub const DEFAULT_SHRINKAGE: f64 = 0.0;

    /// Degrees of freedom `ν` of the Student-t class densities of [`calibrate`](Self::calibrate)
    /// (a heavy-tailed density: one recording far from its class mean in one feature costs
    /// `ln(1 + m/ν)`, not `m`).
    pub const DEFAULT_STUDENT_T_DOF: f64 = 3.0;

    /// The same model with class densities of `dof` degrees of freedom (`Some(ν)`, `ν` > 0 and
    /// finite: Student t) or Gaussian (`None`); the fitted means and variances are unchanged.
    pub fn with_student_t_dof(mut self, dof: Option<f64>) -> Result<Self> {
        self.student_t_dof = dof;
        self.validate()?;
        Ok(self)
    }

    /// Fit class means, pooled within-class variances and per-class variances shrunk toward them
    /// by [`DEFAULT_SHRINKAGE`](Self::DEFAULT_SHRINKAGE) from labelled feature
    /// vectors (each of `config.features.len()` values, e.g. [`FeatureVector::select`]); see
    /// [`calibrate_with_shrinkage`](Self::calibrate_with_shrinkage).
    pub fn calibrate(config: DosFeatureConfig, samples: &[(DosClass, Vec<f64>)]) -> Result<DosModel> {
        Self::calibrate_with_shrinkage(config, samples, Self::DEFAULT_SHRINKAGE)
    }

    /// Fit class means and pooled within-class variances `σ²_j` from labelled feature vectors
    /// and, for `shrinkage` `λ < 1`, per-class variances `σ²_{c,j} = λ·σ²_j + (1 − λ)·s²_{c,j}`
    /// with `s²_{c,j}` the class's own (maximum-likelihood) variance. `λ = 1` gives the pooled
    /// model (no `class_variances`, `(classes + 1) × features` parameters).
    ///
    /// The model's classes are those present, in [`DosClass::ALL`] order. Refuses an invalid
    /// configuration, vectors of the wrong length or non-finite values, fewer than two classes,
    /// and data without any within-class spread (fewer samples than classes + 1).
    /// A feature whose within-class variance is below `1e-6` of its total variance gets that
    /// floor (and a floor of `1e-12` when constant).
    /// `shrinkage` must lie in `[0, 1]`.
    pub fn calibrate_with_shrinkage(
        config: DosFeatureConfig,
        samples: &[(DosClass, Vec<f64>)],
        shrinkage: f64,
    ) -> Result<DosModel> {
        config.validate()?;
        if !(0.0..=1.0).contains(&shrinkage) {
            return Err(invalid(format!("shrinkage {shrinkage} must lie in [0, 1]")));
        }
        let d = config.features.len();
        for (i, (c, f)) in samples.iter().enumerate() {
            if f.len() != d {
                return Err(invalid(format!("sample {i} ({c}) has {} values for {d} features", f.len())));
            }
            if let Some(j) = f.iter().position(|v| !v.is_finite()) {
                return Err(invalid(format!("sample {i} ({c}): feature {} is {}", config.features[j].name(), f[j])));
            }
        }
        let classes: Vec<DosClass> =
            DosClass::ALL.into_iter().filter(|c| samples.iter().any(|(s, _)| s == c)).collect();
        if classes.len() < 2 {
            return Err(invalid(format!("calibration needs at least two classes, got {}", classes.len())));
        }
        if samples.len() <= classes.len() {
            return Err(invalid(format!(
                "{} samples for {} classes: at least one class needs two samples",
                samples.len(),
                classes.len()
            )));
        }
        let mut means = vec![vec![0.0; d]; classes.len()];
        let mut counts = vec![0usize; classes.len()];
        for (c, f) in samples {
            let k = classes.iter().position(|x| x == c).unwrap_or(0);
            counts[k] += 1;
            for j in 0..d {
                means[k][j] += f[j];
            }
        }
        for (m, &n) in means.iter_mut().zip(&counts) {
            m.iter_mut().for_each(|v| *v /= n as f64);
        }
        let dof = (samples.len() - classes.len()) as f64;
        let grand: Vec<f64> =
            (0..d).map(|j| samples.iter().map(|(_, f)| f[j]).sum::<f64>() / samples.len() as f64).collect();
        let mut variances = vec![0.0; d];
        let mut total = vec![0.0; d];
        for (c, f) in samples {
            let k = classes.iter().position(|x| x == c).unwrap_or(0);
            for j in 0..d {
                variances[j] += (f[j] - means[k][j]).powi(2);
                total[j] += (f[j] - grand[j]).powi(2);
            }
        }
        let floors: Vec<f64> =
            total.iter().map(|t| (VARIANCE_FLOOR * t / (samples.len() - 1) as f64).max(1e-12)).collect();
        for j in 0..d {
            variances[j] = (variances[j] / dof).max(floors[j]);
        }
        let mut class_variances = Vec::new();
        if shrinkage < 1.0 {
            let mut own = vec![vec![0.0; d]; classes.len()];
            for (c, f) in samples {
                let k = classes.iter().position(|x| x == c).unwrap_or(0);
                for j in 0..d {
                    own[k][j] += (f[j] - means[k][j]).powi(2);
                }
            }
            for (row, &n) in own.iter_mut().zip(&counts) {
                for j in 0..d {
                    row[j] = (shrinkage * variances[j] + (1.0 - shrinkage) * row[j] / n as f64).max(floors[j]);
                }
            }
            class_variances = own;
        }
        let m = DosModel {
            config,
            classes,
            means,
            variances,
            class_variances,
            recordings: samples.len(),
            student_t_dof: Some(Self::DEFAULT_STUDENT_T_DOF),
        };
        m.validate()?;
        Ok(m)
    }

    /// Checks shapes and values (done on deserialisation).
    pub fn validate(&self) -> Result<()> {
        self.config.validate()?;
        let d = self.config.features.len();
        if self.classes.len() < 2 {
            return Err(invalid("a model needs at least two classes"));
        }
        for (i, c) in self.classes.iter().enumerate() {
            if self.classes[..i].contains(c) {
                return Err(invalid(format!("class {c} appears twice")));
            }
        }
        if self.means.len() != self.classes.len() {
            return Err(invalid(format!("{} rows of means for {} classes", self.means.len(), self.classes.len())));
        }
        for (c, m) in self.classes.iter().zip(&self.means) {
            if m.len() != d || m.iter().any(|v| !v.is_finite()) {
                return Err(invalid(format!("means of class {c} must be {d} finite values, got {m:?}")));
            }
        }
        if self.variances.len() != d || self.variances.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(invalid(format!("variances must be {d} finite values > 0, got {:?}", self.variances)));
        }
        if let Some(nu) = self.student_t_dof {
            if !(nu.is_finite() && nu > 0.0) {
                return Err(invalid(format!("student_t_dof {nu} must be finite and > 0")));
            }
        }
        if !self.class_variances.is_empty() {
            if self.class_variances.len() != self.classes.len() {
                return Err(invalid(format!(
                    "{} rows of class_variances for {} classes",
                    self.class_variances.len(),
                    self.classes.len()
                )));
            }
            for (c, v) in self.classes.iter().zip(&self.class_variances) {
                if v.len() != d || v.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
                    return Err(invalid(format!(
                        "class_variances of class {c} must be {d} finite values > 0, got {v:?}"
                    )));
                }
            }
        }
        Ok(())
    }

    /// Number of fitted numbers the decision uses: `2 × classes × features` with per-class
    /// variances (means and variances per class), `(classes + 1) × features` without.
    pub fn parameter_count(&self) -> usize {
        let rows = if self.class_variances.is_empty() { self.classes.len() + 1 } else { 2 * self.classes.len() };
        rows * self.config.features.len()
    }

    /// Classify one feature vector (the model's features, in order).
    pub fn classify(&self, features: &[f64]) -> Result<Decision> {
        let d = self.config.features.len();
        if features.len() != d {
            return Err(invalid(format!("{} feature values for a model of {d} features", features.len())));
        }
        if let Some(j) = features.iter().position(|v| !v.is_finite()) {
            return Err(invalid(format!("feature {} is {}", self.config.features[j].name(), features[j])));
        }
        // (D_c, ln m_c): ln m_c only where m_c overflows (features near ±f64::MAX), to keep
        // the decision and the posterior defined there.
        let scored: Vec<(f64, f64)> = self
            .means
            .iter()
            .enumerate()
            .map(|(k, m)| {
                let (vars, own) = match self.class_variances.get(k) {
                    Some(v) => (v, true),
                    None => (&self.variances, false),
                };
                let maha: f64 = m.iter().zip(features).zip(vars).map(|((mu, f), v)| (f - mu).powi(2) / v).sum();
                let log_det: f64 = if own { vars.iter().map(|v| v.ln()).sum() } else { 0.0 };
                let ln_maha = if maha.is_finite() { maha.ln() } else { ln_mahalanobis(m, features, vars) };
                let dist = match (self.student_t_dof, maha.is_finite()) {
                    (Some(nu), true) => log_det + (nu + d as f64) * (maha / nu).ln_1p(),
                    // m/ν ≥ 1e308/ν: ln(1 + m/ν) = ln m − ln ν to double precision
                    (Some(nu), false) => log_det + (nu + d as f64) * (ln_maha - nu.ln()),
                    (None, _) => log_det + maha,
                };
                (dist, ln_maha)
            })
            .collect();
        let mut best = 0;
        for (k, s) in scored.iter().enumerate() {
            let b = scored[best];
            if s.0 < b.0 || (s.0 == b.0 && s.0.is_infinite() && s.1 < b.1) {
                best = k;
            }
        }
        let distances: Vec<f64> = scored.iter().map(|s| s.0).collect();
        let dmin = distances[best];
        let posterior: Vec<f64> = if dmin.is_finite() {
            let w: Vec<f64> = distances.iter().map(|&dk| (-(dk - dmin) / 2.0).exp()).collect();
            let s: f64 = w.iter().sum();
            w.iter().map(|x| x / s).collect()
        } else {
            // every Gaussian distance overflowed: the decided class takes all the weight
            (0..distances.len()).map(|k| if k == best { 1.0 } else { 0.0 }).collect()
        };
        Ok(Decision { class: self.classes[best], posterior, distances })
    }

    /// Classify the full feature vector of a span.
    pub fn classify_vector(&self, fv: &FeatureVector) -> Result<Decision> {
        self.classify(&fv.select(&self.config.features))
    }
}

/// `samples` followed by their mirror images across `y = 0` (each vector's features times
/// [`Feature::mirror_sign`], its class [`DosClass::mirrored`]): the recordings the same slips
/// would have given on the mirrored side of a symmetric layout. Calibrating on them makes the
/// model itself symmetric — the class means of `e` and `w` (and of `cw` and `aw`) are mirror
/// images, those of `n`, `s`, `t` have zero odd features — and doubles the training data for
/// free; `features` are the vectors' features, in order.
pub fn mirror_augmented(features: &[Feature], samples: &[(DosClass, Vec<f64>)]) -> Vec<(DosClass, Vec<f64>)> {
    let signs: Vec<f64> = features.iter().map(|f| f.mirror_sign()).collect();
    let mirrored = samples.iter().map(|(c, f)| (c.mirrored(), f.iter().zip(&signs).map(|(v, s)| v * s).collect()));
    samples.iter().cloned().chain(mirrored).collect()
}

// ---------------------------------------------------------------------------------------------
// Cross-validation
// ---------------------------------------------------------------------------------------------

/// One labelled span for [`cross_validate`]: its class, its group (e.g. the object it was
/// recorded on) and its features.
#[derive(Clone, Debug, PartialEq)]
pub struct LabelledSpan {
    /// The true class.
    pub class: DosClass,
    /// The group held out together (an object, an object set, a session).
    pub group: String,
    /// The span's features (at least the configured ones computed).
    pub features: FeatureVector,
}

/// The result of [`cross_validate`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CrossValidation {
    /// Per held-out group, in sorted order: (group, correct, spans).
    pub folds: Vec<(String, usize, usize)>,
    /// Rows true class, columns decided class, both in [`DosClass::ALL`] order.
    pub confusion: [[usize; 7]; 7],
}

impl CrossValidation {
    /// Correct decisions over all spans (0 without spans).
    pub fn accuracy(&self) -> f64 {
        let ok: usize = self.folds.iter().map(|f| f.1).sum();
        let n: usize = self.folds.iter().map(|f| f.2).sum();
        if n == 0 {
            0.0
        } else {
            ok as f64 / n as f64
        }
    }

    /// Recall of `class` (`None` without spans of it).
    pub fn recall(&self, class: DosClass) -> Option<f64> {
        let i = DosClass::ALL.iter().position(|&c| c == class)?;
        let n: usize = self.confusion[i].iter().sum();
        (n > 0).then(|| self.confusion[i][i] as f64 / n as f64)
    }
}

impl fmt::Display for CrossValidation {
    /// Accuracy, the folds and the confusion matrix as markdown.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (ok, n) = self.folds.iter().fold((0, 0), |a, x| (a.0 + x.1, a.1 + x.2));
        writeln!(f, "leave-one-group-out accuracy: {:.1} % ({ok}/{n})", 100.0 * self.accuracy())?;
        writeln!(f, "\n| held out | correct | spans | accuracy |\n|---|---|---|---|")?;
        for (g, ok, n) in &self.folds {
            writeln!(f, "| {g} | {ok} | {n} | {:.1} % |", 100.0 * *ok as f64 / (*n).max(1) as f64)?;
        }
        let names = DosClass::ALL.map(|c| c.as_str());
        writeln!(f, "\n| true \\ decided | {} | recall |\n|---|{}---|", names.join(" | "), "---|".repeat(7))?;
        for (i, row) in self.confusion.iter().enumerate() {
            let cells: Vec<String> = row.iter().map(|v| v.to_string()).collect();
            let recall = self.recall(DosClass::ALL[i]).map_or("—".to_string(), |r| format!("{:.0} %", 100.0 * r));
            writeln!(f, "| {} | {} | {recall} |", names[i], cells.join(" | "))?;
        }
        Ok(())
    }
}

/// Leave-one-group-out cross-validation of the decision rule: for every group, a model is
/// calibrated ([`DosModel::calibrate_with_shrinkage`] with `shrinkage(group)`, then
/// [`DosModel::with_student_t_dof`]`(dof)`) on the other groups' spans and decides that group's.
/// Refuses fewer than two groups, and whatever calibration refuses (e.g. a fold whose training
/// spans hold a single class).
pub fn cross_validate(
    config: &DosFeatureConfig,
    spans: &[LabelledSpan],
    shrinkage: &dyn Fn(&str) -> f64,
    dof: Option<f64>,
) -> Result<CrossValidation> {
    let mut groups: Vec<&str> = spans.iter().map(|s| s.group.as_str()).collect();
    groups.sort_unstable();
    groups.dedup();
    if groups.len() < 2 {
        return Err(invalid(format!("cross-validation needs at least two groups, got {}", groups.len())));
    }
    let idx = |c: DosClass| DosClass::ALL.iter().position(|&x| x == c).unwrap_or(0);
    let mut folds = Vec::with_capacity(groups.len());
    let mut confusion = [[0usize; 7]; 7];
    for g in groups {
        let train: Vec<(DosClass, Vec<f64>)> =
            spans.iter().filter(|s| s.group != g).map(|s| (s.class, s.features.select(&config.features))).collect();
        let model = DosModel::calibrate_with_shrinkage(config.clone(), &train, shrinkage(g))
            .and_then(|m| m.with_student_t_dof(dof))
            .map_err(|e| match e {
                Error::InvalidConfig { reason, .. } => invalid(format!("fold without {g:?}: {reason}")),
                other => other,
            })?;
        let (mut ok, mut n) = (0, 0);
        for s in spans.iter().filter(|s| s.group == g) {
            let d = model.classify_vector(&s.features)?;
            confusion[idx(s.class)][idx(d.class)] += 1;
            ok += usize::from(d.class == s.class);
            n += 1;
        }
        folds.push((g.to_string(), ok, n));
    }
    Ok(CrossValidation { folds, confusion })
}

// ---------------------------------------------------------------------------------------------
// Stage
// ---------------------------------------------------------------------------------------------

/// One slip-direction decision of the [`DosClassifier`] stage.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DosDecision {
    /// The sensor.
    pub sensor: SensorId,
    /// Time of the span's first frame.
    pub start: Timestamp,
    /// Time of its last frame.
    pub end: Timestamp,
    /// Index of the last frame.
    pub seq: u64,
    /// Frames in the span.
    pub frames: u64,
    /// The decision.
    pub decision: Decision,
    /// The span's features (all of them, [`Feature::ALL`] order).
    pub features: FeatureVector,
}

impl Timed for DosDecision {
    fn time(&self) -> Timestamp {
        self.end
    }
}

impl HasSensor for DosDecision {
    fn sensor(&self) -> &SensorId {
        &self.sensor
    }
}

/// The classifier as a [`Stage`]: raw frames of one sensor in, [`DosDecision`]s out.
///
/// | mode | decisions | each covers |
/// |---|---|---|
/// | `decision_frames = None` | one per segment, at [`finish`](Stage::finish) | the whole recording |
/// | `decision_frames = Some(n)` | one per `n` frames (tumbling) | the last `n` frames, event references carried over |
/// | `Some(n)` + [`with_hop`](Self::with_hop)`(h)` | one every `h` frames once `n` have arrived (sliding) | the last `n` frames, **as a fresh recording** |
///
/// The sliding mode is the one for a robot: an answer every `h` frames (e.g. 10 = 0.1 s) about
/// the last `n` (e.g. 250 = 2.5 s; see the latency trade in the [module docs](self)), each
/// computed exactly as [`DosModel::calibrate`]'s labelled recordings were — from the window's
/// first frame, nothing carried over — so a model calibrated on recordings of `n` frames meets
/// the same features live. It costs one extraction of `n` frames per decision (≈ 0.28 µs × `n`,
/// 70 µs for 250 frames) on top of checking every frame as it arrives. At `finish`, frames
/// pushed since the last decision get one more decision over the last (up to) `n` frames.
///
/// [`reset`](Stage::reset) drops the open span (and the sliding window). Delay: `n − 1` frames;
/// with `None` the decision comes at `finish` and [`Stage::delay`] reports zero (no frame
/// count describes it).
#[derive(Clone, Debug)]
#[must_use = "a stage does nothing until frames are pushed"]
pub struct DosClassifier {
    model: DosModel,
    extractor: DosFeatureExtractor,
    decision_frames: Option<u64>,
    span: Option<(SensorId, Timestamp, Timestamp, u64)>,
    /// Sliding mode: the hop, the window of the last `decision_frames` frames, frames since the
    /// last decision, and the extractor the window is replayed through.
    sliding: Option<Sliding>,
}

#[derive(Clone, Debug)]
struct Sliding {
    hop: u64,
    /// Decide every `hop` frames from the first, before the window is full.
    early: bool,
    recent: std::collections::VecDeque<TaxelFrame>,
    since: u64,
    replay: DosFeatureExtractor,
}

impl DosClassifier {
    /// A classifier for `layout`'s sensor; `decision_frames` (≥ 1) or `None` for one decision
    /// per segment.
    pub fn try_new(model: DosModel, layout: &Layout, decision_frames: Option<u64>) -> Result<Self> {
        model.validate()?;
        if decision_frames == Some(0) {
            return Err(invalid("decision_frames must be ≥ 1"));
        }
        if let Some(n) = decision_frames.filter(|&n| n > crate::limits::MAX_DOS_FRAMES) {
            return Err(invalid(format!(
                "decision_frames = {n} exceeds the maximum of {}",
                crate::limits::MAX_DOS_FRAMES
            )));
        }
        let extractor = DosFeatureExtractor::try_new(&model.config, layout)?;
        Ok(DosClassifier { model, extractor, decision_frames, span: None, sliding: None })
    }

    /// Sliding decisions: one every `hop` frames (≥ 1) over the last `decision_frames` frames,
    /// each extracted as a fresh recording (see the table above). Needs `decision_frames`.
    pub fn with_hop(mut self, hop: u64) -> Result<Self> {
        let Some(n) = self.decision_frames else {
            return Err(invalid("a hop needs decision_frames (the window the sliding decisions cover)"));
        };
        if hop == 0 {
            return Err(invalid("hop must be ≥ 1 frame"));
        }
        if hop > crate::limits::MAX_DOS_FRAMES {
            return Err(invalid(format!(
                "hop_frames = {hop} exceeds the maximum of {}",
                crate::limits::MAX_DOS_FRAMES
            )));
        }
        let replay = self.extractor.clone();
        self.sliding = Some(Sliding {
            hop,
            early: false,
            recent: std::collections::VecDeque::with_capacity(usize::try_from(n).unwrap_or(0).min(1 << 20)),
            since: 0,
            replay,
        });
        Ok(self)
    }

    /// Sliding mode with early answers: a decision every `hop` frames from the first hop after
    /// contact (a [`reset`](Stage::reset) or the start), each over all frames since then until
    /// `decision_frames` have arrived, over the last `decision_frames` after that — what a robot
    /// that must act before the window fills sees (the accuracy by time since contact is in the
    /// [module docs](self)). Needs [`with_hop`](Self::with_hop) first.
    pub fn with_early_decisions(mut self) -> Result<Self> {
        match &mut self.sliding {
            Some(sl) => sl.early = true,
            None => return Err(invalid("early decisions need the sliding mode (with_hop)")),
        }
        Ok(self)
    }

    /// The hop of the sliding mode (`None`: tumbling spans or one decision per segment).
    pub fn hop(&self) -> Option<u64> {
        self.sliding.as_ref().map(|s| s.hop)
    }

    /// The model.
    pub fn model(&self) -> &DosModel {
        &self.model
    }

    fn emit(&mut self, out: &mut Vec<DosDecision>) -> Result<()> {
        if let Some((sensor, start, end, seq)) = self.span.take() {
            let features = self.extractor.features();
            let decision = self.model.classify_vector(&features)?;
            out.push(DosDecision { sensor, start, end, seq, frames: features.frames, decision, features });
            self.extractor.clear_span();
        }
        Ok(())
    }
}

impl DosClassifier {
    /// Sliding mode: one decision over the frames in the window, replayed as a fresh recording.
    fn decide_window(&mut self, out: &mut Vec<DosDecision>) -> Result<()> {
        let Some(sl) = &mut self.sliding else { return Ok(()) };
        let (Some(first), Some(last)) = (sl.recent.front(), sl.recent.back()) else { return Ok(()) };
        let (sensor, start, end, seq) = (last.sensor.clone(), first.time, last.time, last.seq);
        sl.replay.reset();
        for f in &sl.recent {
            sl.replay.push(f.clone())?;
        }
        let features = sl.replay.features();
        let decision = self.model.classify_vector(&features)?;
        out.push(DosDecision { sensor, start, end, seq, frames: features.frames, decision, features });
        sl.since = 0;
        Ok(())
    }

    fn push_sliding(&mut self, frame: TaxelFrame, out: &mut Vec<DosDecision>) -> Result<()> {
        let n = self.decision_frames.unwrap_or(1);
        // every frame is checked as it arrives (the same errors as the other modes)
        self.extractor.push(frame.clone())?;
        self.extractor.clear_span();
        let Some(sl) = &mut self.sliding else { return Ok(()) };
        if sl.recent.len() as u64 >= n {
            sl.recent.pop_front();
        }
        sl.recent.push_back(frame);
        sl.since += 1;
        if (sl.early || sl.recent.len() as u64 >= n) && sl.since >= sl.hop {
            self.decide_window(out)?;
        }
        Ok(())
    }
}

impl Stage for DosClassifier {
    type In = TaxelFrame;
    type Out = DosDecision;
    type Error = Error;

    fn push(&mut self, frame: TaxelFrame, out: &mut Vec<DosDecision>) -> Result<()> {
        if self.sliding.is_some() {
            return self.push_sliding(frame, out);
        }
        let (sensor, time, seq) = (frame.sensor.clone(), frame.time, frame.seq);
        self.extractor.push(frame)?;
        match &mut self.span {
            Some(s) => {
                s.2 = time;
                s.3 = seq;
            }
            None => self.span = Some((sensor, time, time, seq)),
        }
        if self.decision_frames.is_some_and(|n| self.extractor.frames() >= n) {
            self.emit(out)?;
        }
        Ok(())
    }

    fn finish(&mut self, out: &mut Vec<DosDecision>) -> Result<()> {
        if self.sliding.as_ref().is_some_and(|s| s.since > 0) {
            self.decide_window(out)?;
        }
        if let Some(sl) = &mut self.sliding {
            sl.recent.clear();
            sl.since = 0;
        }
        self.emit(out)
    }

    fn reset(&mut self) {
        self.extractor.reset();
        self.span = None;
        if let Some(sl) = &mut self.sliding {
            sl.recent.clear();
            sl.since = 0;
        }
    }

    fn delay(&self) -> Delay {
        match self.decision_frames {
            Some(n) => Delay::frames(n - 1),
            // the decision comes at `finish`, which no frame count describes
            None => Delay::ZERO,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gradtac_stream::StageExt;

    /// A deterministic pseudo-random source (64-bit LCG, top 53 bits).
    struct Lcg(u64);
    impl Lcg {
        fn uniform(&mut self) -> f64 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        }
        fn normal(&mut self) -> f64 {
            let (u, v) = (self.uniform(), self.uniform());
            (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
        }
    }

    /// A synthetic BioTac-like recording: per-taxel rest counts ~3500, an elliptical contact
    /// (σ 4 × 2 mm, depth 1000 counts — pressing lowers counts) whose centre moves from
    /// `c0` by `shift` mm and whose major axis turns from `phi0` by `turn` rad over the
    /// recording, plus ±2 counts of noise.
    fn recording(frames: usize, c0: [f64; 2], shift: [f64; 2], phi0: f64, turn: f64, seed: u64) -> Vec<TaxelFrame> {
        let layout = Layout::biotac_sp();
        let mut rng = Lcg(seed);
        let rest: Vec<f64> = (0..24).map(|i| 3400.0 + 10.0 * i as f64).collect();
        (0..frames)
            .map(|k| {
                let s = k as f64 / (frames - 1) as f64;
                let c = [c0[0] + s * shift[0], c0[1] + s * shift[1]];
                let phi = phi0 + s * turn;
                let (sn, cs) = phi.sin_cos();
                let values = layout
                    .positions()
                    .iter()
                    .zip(&rest)
                    .map(|(p, r)| {
                        let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
                        let (u, v) = (cs * dx + sn * dy, -sn * dx + cs * dy);
                        let depth = 1000.0 * (-(u * u) / (2.0 * 16.0) - (v * v) / (2.0 * 4.0)).exp();
                        (r - depth + 2.0 * (2.0 * rng.uniform() - 1.0)).round()
                    })
                    .collect();
                TaxelFrame::new("ff".into(), Timestamp::at_rate(k as u64, 100.0), k as u64, values)
            })
            .collect()
    }

    /// The synthetic motion of a class: translations of 8 mm along the class direction,
    /// rotations of 60° in the class sense, no motion for touch.
    fn synthetic(class: DosClass, c0: [f64; 2], phi0: f64, seed: u64) -> Vec<TaxelFrame> {
        let shift = class.direction().map_or([0.0; 2], |d| [8.0 * d[0], 8.0 * d[1]]);
        let turn = class.rotation_sense().map_or(0.0, |s| s * std::f64::consts::FRAC_PI_3);
        let start = [c0[0] - shift[0] / 2.0, c0[1] - shift[1] / 2.0];
        recording(200, start, shift, phi0, turn, seed)
    }

    fn features_of(frames: Vec<TaxelFrame>, cfg: &DosFeatureConfig) -> FeatureVector {
        let mut x = DosFeatureExtractor::try_new(cfg, &Layout::biotac_sp()).unwrap();
        for f in frames {
            x.push(f).unwrap();
        }
        x.features()
    }

    fn motion_config() -> DosFeatureConfig {
        DosFeatureConfig {
            features: vec![Feature::Rate, Feature::TrackDx, Feature::TrackDy, Feature::Rotation],
            ..Default::default()
        }
    }

    #[test]
    fn synthetic_tracks_give_the_mapped_classes() {
        let cfg = motion_config();
        let mut train = Vec::new();
        for (i, c0) in [[-1.0, 0.0], [1.0, 0.5], [0.0, -0.5]].into_iter().enumerate() {
            for class in DosClass::ALL {
                let fv = features_of(synthetic(class, c0, 0.3 * i as f64, 10 + i as u64), &cfg);
                train.push((class, fv.select(&cfg.features)));
            }
        }
        let model = DosModel::calibrate(cfg.clone(), &train).unwrap();
        assert_eq!(model.parameter_count(), 2 * 7 * 4);
        // fresh recordings: other positions, orientations and noise
        for (c0, phi0, seed) in [([0.5, 0.0], 0.15, 99), ([-0.5, 0.3], 0.5, 7)] {
            for class in DosClass::ALL {
                let fv = features_of(synthetic(class, c0, phi0, seed), &cfg);
                let d = model.classify_vector(&fv).unwrap();
                assert_eq!(
                    d.class,
                    class,
                    "{class} at {c0:?}: features {:?}, decision {d:?}",
                    fv.select(&cfg.features)
                );
                let s: f64 = d.posterior.iter().sum();
                assert!((s - 1.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn track_features_follow_the_contact() {
        let cfg = motion_config();
        let plus_x = features_of(synthetic(DosClass::N, [0.0, 0.0], 0.0, 1), &cfg);
        assert!(plus_x.get(Feature::TrackDx) > 2.0, "{plus_x:?}");
        assert!(plus_x.get(Feature::TrackDx).abs() > 3.0 * plus_x.get(Feature::TrackDy).abs(), "{plus_x:?}");
        let plus_y = features_of(synthetic(DosClass::E, [0.0, 0.0], 0.0, 2), &cfg);
        assert!(plus_y.get(Feature::TrackDy) > 2.0, "{plus_y:?}");
        let cw = features_of(synthetic(DosClass::Cw, [0.0, 0.0], 0.0, 3), &cfg);
        let aw = features_of(synthetic(DosClass::Aw, [0.0, 0.0], 0.0, 3), &cfg);
        assert!(cw.get(Feature::Rotation) > 0.2 && aw.get(Feature::Rotation) < -0.2, "{cw:?} {aw:?}");
        let still = features_of(synthetic(DosClass::T, [0.0, 0.0], 0.0, 4), &cfg);
        assert!(still.get(Feature::Rate) < 0.5 * plus_x.get(Feature::Rate), "{still:?} {plus_x:?}");
    }

    #[test]
    fn calibrate_recovers_planted_parameters() {
        let cfg = DosFeatureConfig {
            features: vec![Feature::Rate, Feature::PositiveX, Feature::NegativeY],
            ..Default::default()
        };
        let sd = [0.5, 2.0, 0.1];
        let planted: Vec<[f64; 3]> = (0..7).map(|k| [k as f64, 10.0 - 3.0 * k as f64, 0.01 * (k * k) as f64]).collect();
        let mut rng = Lcg(42);
        let n = 2000;
        let mut samples = Vec::new();
        for (k, class) in DosClass::ALL.into_iter().enumerate() {
            for _ in 0..n {
                samples.push((class, (0..3).map(|j| planted[k][j] + sd[j] * rng.normal()).collect::<Vec<_>>()));
            }
        }
        let m = DosModel::calibrate(cfg, &samples).unwrap();
        assert_eq!(m.classes, DosClass::ALL.to_vec());
        assert_eq!(m.recordings, 7 * n);
        for (k, (fitted, truth)) in m.means.iter().zip(&planted).enumerate() {
            for (j, (a, b)) in fitted.iter().zip(truth).enumerate() {
                let tol = 5.0 * sd[j] / (n as f64).sqrt();
                assert!((a - b).abs() < tol, "mean {k},{j}: {a} vs {b}");
            }
        }
        for (j, (v, s)) in m.variances.iter().zip(sd).enumerate() {
            assert!((v / (s * s) - 1.0).abs() < 0.05, "variance {j}: {v} vs {}", s * s);
        }
        // the planted means are classified as their classes
        for (k, class) in DosClass::ALL.into_iter().enumerate() {
            assert_eq!(m.classify(&planted[k]).unwrap().class, class);
        }
    }

    /// One feature (`rate`), class n spread 1 around 0 (own variance 1), class s spread 3
    /// around 10 (own variance 9).
    fn two_classes() -> (DosFeatureConfig, Vec<(DosClass, Vec<f64>)>) {
        let cfg = DosFeatureConfig { features: vec![Feature::Rate], ..Default::default() };
        let samples = vec![
            (DosClass::N, vec![-1.0]),
            (DosClass::N, vec![1.0]),
            (DosClass::S, vec![7.0]),
            (DosClass::S, vec![13.0]),
        ];
        (cfg, samples)
    }

    #[test]
    fn shrinkage_mixes_own_and_pooled_variances() {
        let (cfg, samples) = two_classes();
        // pooled: (2 + 18) / (4 − 2) = 10
        let pooled = DosModel::calibrate_with_shrinkage(cfg.clone(), &samples, 1.0).unwrap();
        assert_eq!(pooled.variances, [10.0]);
        assert!(pooled.class_variances.is_empty());
        assert_eq!(pooled.parameter_count(), 3);
        let own = DosModel::calibrate_with_shrinkage(cfg.clone(), &samples, 0.0).unwrap();
        assert_eq!(own.class_variances, [[1.0], [9.0]]);
        assert_eq!(DosModel::calibrate(cfg.clone(), &samples).unwrap(), own, "the default λ is 0");
        let half = DosModel::calibrate_with_shrinkage(cfg.clone(), &samples, 0.5).unwrap();
        assert_eq!(half.class_variances, [[5.5], [9.5]]);
        assert_eq!(half.parameter_count(), 4);
        // 3.5 is nearer n's mean, but s's wide spread claims it with its own variances.
        // Gaussian: pooled D = 1.225 vs 4.225; own D = 12.25 + 0 vs 4.69 + 2.20
        let (pooled_g, own_g) =
            (pooled.clone().with_student_t_dof(None).unwrap(), own.clone().with_student_t_dof(None).unwrap());
        assert_eq!(pooled_g.classify(&[3.5]).unwrap().class, DosClass::N);
        let d = own_g.classify(&[3.5]).unwrap();
        assert_eq!(d.class, DosClass::S);
        assert!((d.distances[0] - 12.25).abs() < 1e-12 && (d.distances[1] - (42.25 / 9.0 + 9f64.ln())).abs() < 1e-12);
        // Student t (ν = 3, d = 1, the calibrated default): D = ln σ² + (ν + d)·ln(1 + m/ν)
        assert_eq!(own.student_t_dof, Some(DosModel::DEFAULT_STUDENT_T_DOF));
        assert_eq!(pooled.classify(&[3.5]).unwrap().class, DosClass::N, "pooled: nearest mean either way");
        let d = own.classify(&[3.5]).unwrap();
        let (dn, ds) = (4.0 * (12.25f64 / 3.0).ln_1p(), 9f64.ln() + 4.0 * (42.25f64 / 27.0).ln_1p());
        assert!((d.distances[0] - dn).abs() < 1e-12 && (d.distances[1] - ds).abs() < 1e-12, "{d:?}");
        assert_eq!(d.class, DosClass::S);
        // far out, the t density costs logarithmically: at 100, n and s differ by less than
        // the Gaussian's quadratic gap
        let (t, g) = (own.classify(&[100.0]).unwrap(), own_g.classify(&[100.0]).unwrap());
        assert!((t.distances[0] - t.distances[1]).abs() < 10.0 && (g.distances[0] - g.distances[1]).abs() > 1000.0);
        assert!(own.clone().with_student_t_dof(Some(0.0)).is_err());
        assert!(own.clone().with_student_t_dof(Some(f64::INFINITY)).is_err());
        for bad in [-0.1, 1.1, f64::NAN] {
            assert!(DosModel::calibrate_with_shrinkage(cfg.clone(), &samples, bad).is_err(), "{bad}");
        }
        // a model file without class_variances (written by the pooled model) still loads
        let json = serde_json::to_string(&pooled).unwrap().replace(",\"class_variances\":[]", "");
        assert!(!json.contains("class_variances"), "{json}");
        assert_eq!(serde_json::from_str::<DosModel>(&json).unwrap(), pooled);
        // a model file without student_t_dof (written before it existed) decides as a Gaussian
        let json = serde_json::to_string(&own).unwrap().replace(",\"student_t_dof\":3.0", "");
        assert!(!json.contains("student_t_dof"), "{json}");
        assert_eq!(serde_json::from_str::<DosModel>(&json).unwrap(), own_g);
        let bad = serde_json::to_string(&own).unwrap().replace("\"student_t_dof\":3.0", "\"student_t_dof\":-1.0");
        assert!(serde_json::from_str::<DosModel>(&bad).unwrap_err().to_string().contains("student_t_dof"));
        // rows of the wrong shape or non-positive values are refused
        let json = serde_json::to_string(&half).unwrap();
        for bad in [json.replace("[[5.5],[9.5]]", "[[5.5]]"), json.replace("[[5.5],[9.5]]", "[[5.5],[0.0]]")] {
            let e = serde_json::from_str::<DosModel>(&bad).unwrap_err();
            assert!(e.to_string().contains("class_variances"), "{e}");
        }
    }

    #[test]
    fn model_round_trips_and_bad_files_are_refused() {
        let cfg = DosFeatureConfig { features: vec![Feature::TrackDx, Feature::Rotation], ..Default::default() };
        let samples =
            vec![(DosClass::N, vec![1.0, 0.0]), (DosClass::N, vec![2.0, 0.1]), (DosClass::Cw, vec![0.0, 1.0])];
        let m = DosModel::calibrate(cfg, &samples).unwrap();
        let json = serde_json::to_string(&m).unwrap();
        let back: DosModel = serde_json::from_str(&json).unwrap();
        assert_eq!(back, m);
        assert!(json.contains("\"track_dx\"") && json.contains("\"cw\""), "{json}");
        let bad = json.replace("\"variances\":[", "\"variances\":[0.0,");
        let e = serde_json::from_str::<DosModel>(&bad).unwrap_err();
        assert!(e.to_string().contains("variances"), "{e}");
        let unknown = json.replace("\"recordings\"", "\"colour\":1,\"recordings\"");
        assert!(serde_json::from_str::<DosModel>(&unknown).is_err());
        // classify checks its input
        assert!(m.classify(&[1.0]).is_err());
        assert!(m.classify(&[1.0, f64::NAN]).is_err());
    }

    #[test]
    fn invalid_input_is_refused() {
        let ok = DosFeatureConfig::default();
        let l = Layout::biotac_sp();
        for bad in [
            DosFeatureConfig { threshold: 0.0, ..ok.clone() },
            DosFeatureConfig { threshold: f64::NAN, ..ok.clone() },
            DosFeatureConfig { track_window_frames: 1, ..ok.clone() },
            DosFeatureConfig { grid_nx: 2, ..ok.clone() },
            DosFeatureConfig { min_area_mm2: -1.0, ..ok.clone() },
            DosFeatureConfig { features: vec![], ..ok.clone() },
            DosFeatureConfig { features: vec![Feature::Rate, Feature::Rate], ..ok.clone() },
            DosFeatureConfig { drift_lags: vec![], ..ok.clone() },
            DosFeatureConfig { drift_lags: vec![0], ..ok.clone() },
            DosFeatureConfig { drift_lags: vec![30, 30], ..ok.clone() },
        ] {
            let e = DosFeatureExtractor::try_new(&bad, &l).unwrap_err().to_string();
            assert!(e.contains("dos"), "{bad:?}: {e}");
        }
        let e = DosFeatureConfig { drift_lags: vec![0], ..ok.clone() }.validate().unwrap_err().to_string();
        assert!(e.contains("drift_lags") && e.contains("lag 0"), "{e}");
        // calibration: one class, too few samples, wrong length, non-finite
        let d = ok.features.len();
        let one = vec![(DosClass::N, vec![0.0; d]), (DosClass::N, vec![1.0; d])];
        assert!(DosModel::calibrate(ok.clone(), &one).unwrap_err().to_string().contains("two classes"));
        let few = vec![(DosClass::N, vec![0.0; d]), (DosClass::S, vec![1.0; d])];
        assert!(DosModel::calibrate(ok.clone(), &few).unwrap_err().to_string().contains("2 samples for 2 classes"));
        let short = vec![(DosClass::N, vec![0.0; d - 1]), (DosClass::S, vec![1.0; d]), (DosClass::S, vec![2.0; d])];
        assert!(DosModel::calibrate(ok.clone(), &short).unwrap_err().to_string().contains("sample 0"));
        let nan = vec![(DosClass::N, vec![0.0; d]), (DosClass::S, vec![1.0; d]), (DosClass::S, vec![f64::NAN; d])];
        assert!(DosModel::calibrate(ok.clone(), &nan).unwrap_err().to_string().contains("sample 2"));
        // frames: wrong taxel count and non-finite values name the frame
        let mut x = DosFeatureExtractor::try_new(&ok, &l).unwrap();
        let e = x.push(TaxelFrame::new("ff".into(), Timestamp(0), 3, vec![1.0; 23])).unwrap_err();
        assert!(e.to_string().contains("frame 3"), "{e}");
        let mut v = vec![3000.0; 24];
        v[5] = f64::INFINITY;
        let e = x.push(TaxelFrame::new("ff".into(), Timestamp(0), 4, v)).unwrap_err();
        assert!(e.to_string().contains("frame 4") && e.to_string().contains("taxel 5"), "{e}");
    }

    #[test]
    fn early_decisions_cover_everything_since_contact_until_the_window_fills() {
        let (cfg, model) = motion_model();
        let l = Layout::biotac_sp();
        let input = synthetic(DosClass::N, [0.0, 0.0], 0.1, 5);
        let (n, hop) = (80usize, 16u64);
        let mut early = DosClassifier::try_new(model.clone(), &l, Some(n as u64)).unwrap().with_hop(hop).unwrap();
        early = early.with_early_decisions().unwrap();
        let out = early.run_all(input.clone()).unwrap();
        // every 16 frames from the first hop: 15, 31, …, 191, then finish at 199
        let ends: Vec<u64> = out.iter().map(|d| d.seq).collect();
        let want: Vec<u64> = (1..=12).map(|k| 16 * k - 1).chain([199]).collect();
        assert_eq!(ends, want);
        for d in &out {
            let last = d.seq as usize;
            let first = (last + 1).saturating_sub(n);
            assert_eq!(d.frames as usize, last + 1 - first);
            assert_eq!(d.features, features_of(input[first..=last].to_vec(), &cfg), "window ending at {last}");
        }
        // once the window is full, the same decisions as the plain sliding mode
        let plain = DosClassifier::try_new(model.clone(), &l, Some(n as u64)).unwrap().with_hop(hop).unwrap();
        let plain = {
            let mut p = plain;
            p.run_all(input.clone()).unwrap()
        };
        for d in plain.iter().filter(|d| d.seq >= 95) {
            assert!(out.contains(d), "{}", d.seq);
        }
        // early decisions need the sliding mode
        assert!(DosClassifier::try_new(model, &l, Some(80)).unwrap().with_early_decisions().is_err());
    }

    #[test]
    fn sliding_decisions_are_fresh_recordings_of_their_window() {
        let (cfg, model) = motion_model();
        let l = Layout::biotac_sp();
        let input = synthetic(DosClass::N, [0.0, 0.0], 0.1, 5);
        let (n, hop) = (80usize, 16u64);
        let mut sliding = DosClassifier::try_new(model.clone(), &l, Some(n as u64)).unwrap().with_hop(hop).unwrap();
        assert_eq!(sliding.hop(), Some(hop));
        let out = sliding.run_all(input.clone()).unwrap();
        // the first decision once n frames are in (frame 79), then every 16 frames: 79, 95, …,
        // 191; frames 192..199 came after the last one, so finish decides once more, at 199
        let ends: Vec<u64> = out.iter().map(|d| d.seq).collect();
        assert_eq!(ends, [79, 95, 111, 127, 143, 159, 175, 191, 199]);
        // each decision is what a fresh extractor and the model make of that window alone
        for d in &out {
            let last = d.seq as usize;
            let window = &input[last + 1 - n..=last];
            let fresh = features_of(window.to_vec(), &cfg);
            assert_eq!(d.features, fresh, "window ending at {last}");
            assert_eq!(d.decision, model.classify_vector(&fresh).unwrap());
            assert_eq!((d.frames, d.start, d.end), (n as u64, window[0].time, window[n - 1].time));
        }
        // any chunking gives the same decisions
        for cut in [1, 7, 80, 199] {
            let mut s = DosClassifier::try_new(model.clone(), &l, Some(n as u64)).unwrap().with_hop(hop).unwrap();
            let mut got = Vec::new();
            for chunk in input.chunks(cut) {
                for f in chunk {
                    s.push(f.clone(), &mut got).unwrap();
                }
            }
            s.finish(&mut got).unwrap();
            assert_eq!(got, out, "chunks of {cut}");
        }
        // a stream shorter than the window: one decision over what there is, at finish
        let mut short = DosClassifier::try_new(model.clone(), &l, Some(n as u64)).unwrap().with_hop(hop).unwrap();
        let got = short.run_all(input[..30].to_vec()).unwrap();
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].features, features_of(input[..30].to_vec(), &cfg));
        // reset forgets the window; bad settings and bad frames are refused
        let mut s = DosClassifier::try_new(model.clone(), &l, Some(n as u64)).unwrap().with_hop(hop).unwrap();
        let mut got = Vec::new();
        for f in &input[..50] {
            s.push(f.clone(), &mut got).unwrap();
        }
        s.reset();
        s.finish(&mut got).unwrap();
        assert!(got.is_empty());
        assert!(DosClassifier::try_new(model.clone(), &l, None).unwrap().with_hop(5).is_err());
        assert!(DosClassifier::try_new(model.clone(), &l, Some(10)).unwrap().with_hop(0).is_err());
        let mut bad = input[3].clone();
        bad.values[2] = f64::NAN;
        let e = s.push(bad, &mut got).unwrap_err().to_string();
        assert!(e.contains("taxel 2"), "{e}");
    }

    #[test]
    fn decisions_stay_defined_for_features_near_the_largest_floats() {
        let (cfg, samples) = two_classes();
        let own_t = DosModel::calibrate_with_shrinkage(cfg, &samples, 0.0).unwrap();
        let own_g = own_t.clone().with_student_t_dof(None).unwrap();
        for model in [&own_t, &own_g] {
            for f in [1e300, -1e300, f64::MAX, f64::MIN, 1e154] {
                let d = model.classify(&[f]).unwrap();
                assert!(d.posterior.iter().all(|p| p.is_finite() && *p >= 0.0), "{f}: {d:?}");
                assert!((d.posterior.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{f}: {d:?}");
                assert!(d.distances.iter().all(|x| !x.is_nan()), "{f}: {d:?}");
                // far from both means, the wider class (s, variance 9 against 1) is the likelier
                assert_eq!(d.class, DosClass::S, "{f} {:?}", model.student_t_dof);
            }
            if model.student_t_dof.is_some() {
                assert!(model.classify(&[f64::MAX]).unwrap().distances.iter().all(|x| x.is_finite()));
            }
        }
        // the overflow-free log agrees with the direct sum where both work
        let (m, f, v): ([f64; 2], [f64; 2], [f64; 2]) = ([0.5, -3.0], [2.0, 4.0], [0.3, 7.0]);
        let direct: f64 = (0..2).map(|j| (f[j] - m[j]).powi(2) / v[j]).sum::<f64>().ln();
        assert!((ln_mahalanobis(&m, &f, &v) - direct).abs() < 1e-14);
        assert_eq!(ln_mahalanobis(&m, &m, &v), f64::NEG_INFINITY);
    }

    #[test]
    fn model_files_keep_every_bit() {
        // awkward values: a JSON parser without correct rounding is off by an ulp on some of them
        let mut x = 0.1f64;
        let samples: Vec<(DosClass, Vec<f64>)> = (0..40)
            .map(|k| {
                x = (x * 3.7 + 0.123_456_789).fract() + 1e-17 * k as f64;
                (DosClass::ALL[k % 3], vec![x * 1e-3, x.sqrt() * 7.0, (x + 1.0).ln() / 3.0])
            })
            .collect();
        let cfg =
            DosFeatureConfig { features: vec![Feature::Rate, Feature::DriftX, Feature::DriftY], ..Default::default() };
        let model = DosModel::calibrate(cfg, &samples).unwrap();
        let back: DosModel = serde_json::from_str(&serde_json::to_string_pretty(&model).unwrap()).unwrap();
        let bits = |m: &DosModel| -> Vec<u64> {
            m.means.iter().chain(&m.class_variances).flatten().chain(&m.variances).map(|v| v.to_bits()).collect()
        };
        assert_eq!(bits(&back), bits(&model));
        assert_eq!(back, model);
    }

    #[test]
    fn cross_validation_holds_each_group_out() {
        let cfg = DosFeatureConfig { features: vec![Feature::Rate], ..Default::default() };
        let span = |class: DosClass, group: &str, v: f64| {
            let mut all = [f64::NAN; 18];
            all[Feature::Rate.index()] = v;
            LabelledSpan { class, group: group.into(), features: FeatureVector { all, frames: 1, events: 0 } }
        };
        // n near 0, s near 10, three groups; group "c" holds one s recording that looks like n
        let mut spans = Vec::new();
        for (g, shift) in [("a", 0.0), ("b", 0.3), ("c", -0.2)] {
            spans.push(span(DosClass::N, g, shift));
            spans.push(span(DosClass::N, g, 1.0 + shift));
            spans.push(span(DosClass::S, g, 10.0 + shift));
            spans.push(span(DosClass::S, g, 11.0 + shift));
        }
        spans.push(span(DosClass::S, "c", 0.5));
        let cv = cross_validate(&cfg, &spans, &|_| 0.5, Some(3.0)).unwrap();
        assert_eq!(cv.folds, [("a".into(), 4, 4), ("b".into(), 4, 4), ("c".into(), 4, 5)]);
        assert_eq!(cv.confusion[0][0], 6);
        assert_eq!(cv.confusion[2][0], 1, "the odd s is decided n");
        assert!((cv.accuracy() - 12.0 / 13.0).abs() < 1e-15);
        assert_eq!(cv.recall(DosClass::N), Some(1.0));
        assert_eq!(cv.recall(DosClass::T), None);
        let text = cv.to_string();
        assert!(text.contains("92.3 % (12/13)") && text.contains("| c | 4 | 5 | 80.0 % |"), "{text}");
        // one group: refused; a fold left with one class: refused, naming the fold
        let one: Vec<LabelledSpan> = spans.iter().filter(|s| s.group == "a").cloned().collect();
        assert!(cross_validate(&cfg, &one, &|_| 0.5, None).unwrap_err().to_string().contains("two groups"));
        let lopsided = vec![span(DosClass::N, "a", 0.0), span(DosClass::N, "a", 1.0), span(DosClass::S, "b", 9.0)];
        let e = cross_validate(&cfg, &lopsided, &|_| 0.5, None).unwrap_err().to_string();
        assert!(e.contains("fold without \"a\": calibration needs at least two classes"), "{e}");
        assert_eq!(e.matches("invalid configuration").count(), 1, "{e}");
    }

    #[test]
    fn only_the_parts_the_features_need_are_built() {
        let l = Layout::biotac_sp();
        let run = |features: Vec<Feature>, centroid: CentroidMethod| {
            let cfg = DosFeatureConfig { features, centroid, ..Default::default() };
            let mut x = DosFeatureExtractor::try_new(&cfg, &l).unwrap();
            for k in 0..200u64 {
                let v = (0..24).map(|i| 3000.0 + 40.0 * ((k as f64 / 20.0) + i as f64).sin()).collect();
                x.push(TaxelFrame::new("ff".into(), Timestamp::at_rate(k, 100.0), k, v)).unwrap();
            }
            (x.window.is_some(), x.drift.is_some(), x.spatial.is_some(), x.features())
        };
        let (track, drift, spatial, fv) = run(Feature::DEFAULT.to_vec(), CentroidMethod::Taxels);
        assert!(!track && drift && !spatial);
        assert!(fv.get(Feature::TrackDx).is_nan() && fv.get(Feature::Rotation).is_nan());
        assert!(fv.select(&Feature::DEFAULT).iter().all(|v| v.is_finite()) && fv.get(Feature::Rate).is_finite());
        let (track, drift, spatial, fv) = run(vec![Feature::Rate, Feature::Rotation], CentroidMethod::Surface);
        assert!(track && !drift && spatial);
        assert!(fv.get(Feature::Rotation).is_finite() && fv.get(Feature::DriftLevel).is_nan());
        let (.., all) = run(Feature::ALL.to_vec(), CentroidMethod::Taxels);
        assert!(all.is_complete());
        // what is computed does not depend on what else is: the default's values are the same
        for f in Feature::DEFAULT {
            assert_eq!(all.get(f).to_bits(), run(Feature::DEFAULT.to_vec(), CentroidMethod::Taxels).3.get(f).to_bits());
        }
        assert_eq!(fv, fv, "NaN features compare equal bit for bit");
    }

    #[test]
    fn features_are_finite_at_the_extremes() {
        let l = Layout::biotac_sp();
        for centroid in [CentroidMethod::Taxels, CentroidMethod::Surface, CentroidMethod::MaxContour] {
            let cfg = DosFeatureConfig { centroid, features: Feature::ALL.to_vec(), ..Default::default() };
            type Signal = Box<dyn Fn(usize, usize) -> f64>;
            let cases: Vec<(&str, Signal)> = vec![
                ("constant", Box::new(|_, _| 3000.0)),
                ("zero", Box::new(|_, _| 0.0)),
                ("negative", Box::new(|k, i| -((k + i) as f64))),
                ("huge", Box::new(|k, i| 1e300 * (1.0 + ((k * 7 + i) % 5) as f64))),
                ("tiny", Box::new(|k, i| 1e-300 * (1.0 + ((k * 3 + i) % 4) as f64))),
                ("saturating", Box::new(|k, i| if (k / 10 + i) % 2 == 0 { 4095.0 } else { 1.0 })),
            ];
            for (name, f) in cases {
                let mut x = DosFeatureExtractor::try_new(&cfg, &l).unwrap();
                assert!(x.features().all.iter().all(|v| v.is_finite()), "{name}: empty span");
                for k in 0..60 {
                    let v = (0..24).map(|i| f(k, i)).collect();
                    x.push(TaxelFrame::new("ff".into(), Timestamp::at_rate(k as u64, 100.0), k as u64, v)).unwrap();
                }
                let fv = x.features();
                assert!(fv.all.iter().all(|v| v.is_finite()), "{name} {centroid:?}: {fv:?}");
                if name == "constant" {
                    assert_eq!(fv.events, 0);
                    assert_eq!(fv.get(Feature::Rate), 0.0);
                    assert_eq!(fv.get(Feature::PositiveFraction), 0.5);
                    assert_eq!([fv.get(Feature::PositiveX), fv.get(Feature::PositiveY)], l.extent().centre());
                }
            }
        }
    }

    /// A model of the motion features calibrated on synthetic recordings of every class.
    fn motion_model() -> (DosFeatureConfig, DosModel) {
        let cfg = motion_config();
        let mut train = Vec::new();
        for (i, c0) in [[-1.0, 0.0], [1.0, 0.5]].into_iter().enumerate() {
            for class in DosClass::ALL {
                train.push((class, features_of(synthetic(class, c0, 0.2, 20 + i as u64), &cfg).select(&cfg.features)));
            }
        }
        let model = DosModel::calibrate(cfg.clone(), &train).unwrap();
        (cfg, model)
    }

    #[test]
    fn stage_decides_per_span_and_chunking_does_not_matter() {
        let (_, model) = motion_model();
        let l = Layout::biotac_sp();
        let input = synthetic(DosClass::N, [0.0, 0.0], 0.1, 5);
        // one decision for the whole recording at finish
        let mut whole = DosClassifier::try_new(model.clone(), &l, None).unwrap();
        let out = whole.run_all(input.clone()).unwrap();
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].decision.class, DosClass::N);
        assert_eq!((out[0].frames, out[0].seq, out[0].start, out[0].end), (200, 199, input[0].time, input[199].time));
        // tumbling spans of 64 frames: 3 full spans and a remainder at finish
        let mut spans = DosClassifier::try_new(model.clone(), &l, Some(64)).unwrap();
        let all = spans.run_all(input.clone()).unwrap();
        assert_eq!(all.iter().map(|d| d.frames).collect::<Vec<_>>(), [64, 64, 64, 8]);
        for cut in [1, 5, 63, 64, 65, 199] {
            let mut s = DosClassifier::try_new(model.clone(), &l, Some(64)).unwrap();
            let mut out = Vec::new();
            for chunk in input.chunks(cut) {
                let mut part = Vec::new();
                for f in chunk {
                    s.push(f.clone(), &mut part).unwrap();
                }
                out.extend(part);
            }
            s.finish(&mut out).unwrap();
            assert_eq!(out, all, "chunks of {cut}");
        }
        // reset drops the open span
        let mut s = DosClassifier::try_new(model.clone(), &l, None).unwrap();
        let mut out = Vec::new();
        for f in input.iter().take(50) {
            s.push(f.clone(), &mut out).unwrap();
        }
        s.reset();
        s.finish(&mut out).unwrap();
        assert!(out.is_empty());
        assert!(DosClassifier::try_new(model, &l, Some(0)).is_err());
    }

    #[test]
    fn class_names_and_directions() {
        for c in DosClass::ALL {
            assert_eq!(c.as_str().parse::<DosClass>().unwrap(), c);
            assert_eq!(c.to_string(), c.as_str());
            if let Some(d) = c.direction() {
                assert_eq!(DosClass::from_direction(d), Some(c));
                assert_eq!(DosClass::from_direction([3.0 * d[0] + 0.5 * d[1], 3.0 * d[1] - 0.5 * d[0]]), Some(c));
            }
        }
        assert_eq!(DosClass::from_direction([0.0, 0.0]), None);
        assert_eq!(DosClass::from_direction([f64::NAN, 1.0]), None);
        assert!("north".parse::<DosClass>().is_err());
        assert_eq!(serde_json::to_string(&DosClass::Aw).unwrap(), "\"aw\"");
        assert_eq!(wrap_half_pi(3.0), 3.0 - std::f64::consts::PI);
        assert_eq!(wrap_half_pi(-0.25), -0.25);
    }
}
