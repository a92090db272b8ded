//! The features ([`Feature`]), their vector ([`FeatureVector`]) and the extractor's settings ([`DosFeatureConfig`], [`CentroidMethod`]).

use super::*;

/// One feature (see the table in the [module docs](crate::dos)).
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
    /// [`crate::dos_select`] on the BioTacSP-DoS development subset, see the [module docs](crate::dos);
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

    pub(super) fn index(self) -> usize {
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
    /// well under the spread between recordings, see the [module docs](crate::dos)).
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
    /// BioTacSP-DoS (see the [module docs](crate::dos)).
    #[default]
    Taxels,
}
