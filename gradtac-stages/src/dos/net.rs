//! [`DosNet`]: the learned slip-direction model — a per-taxel, multi-time-scale representation of
//! the span ([`NetExtractor`], streaming) and a one-hidden-layer network over it. Inference only:
//! the trainer is [`crate::dos::train`] (feature `train`), which a robot's build leaves out.
//!
//! # Representation ([`NetExtractor::input`])
//! For every taxel `i` of a span, with its frame-to-frame noise `n_i` (mean `|x_t − x_{t−1}|`):
//! - for every lag `S` of [`NetConfig::lags`] (default 0.3 and 0.6 s), the drift map's weight
//!   `w_{S,i}` (drift against noise over `S` frames, nepers) and signed weight `w_{S,i}·s_{S,i}`
//!   ([`crate::drift`], linear scale, one map per lag);
//! - the net change since the span's first frame against the noise, compressed:
//!   `asinh((x_t − x_0) / (4·n_i))`;
//!
//! then the seven drift moments of [`Feature::DRIFT`] over all lags (the location of the
//! drift on the layout). With 24 taxels and two lags: `24 × 5 + 7 = 127` inputs. Every input
//! is a ratio of changes of the same taxel in the same span, so it is exactly invariant to a
//! gain and an offset per taxel (tested) — which is what differs most between sensors and
//! between objects' stiffness.
//!
//! # Decision
//! The inputs are standardised with the training set's means and spreads, then
//! `h = tanh(W₁ x + b₁)`, `logits = W₂ h + b₂`, posterior `softmax(logits)`, class = argmax
//! (ties: the first in the model's order). [`Decision::distances`] holds `−2·ln posterior`
//! (the Student-t model's convention: smaller is likelier).
//!
//! # Cost
//! Per frame: one push into one drift map per lag and a few operations per taxel (the
//! representation is kept as running sums); per decision: `inputs × hidden + hidden × classes`
//! multiply-adds and `hidden` `tanh` — about 2 200 with the defaults. Memory: `max(lags) × taxels`
//! values per drift map.

use super::dense::{self, Dense};
use super::*;
use crate::drift::DriftSnapshot;

/// Settings of the learned model's representation and network, stored in the model file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NetConfig {
    /// Drift lags in frames, one drift map each (non-empty, each in `1..=100000`, no repeats).
    /// Default `[30, 60]`.
    pub lags: Vec<u64>,
    /// Hidden units (1..=256). Default 16.
    pub hidden: usize,
}

impl Default for NetConfig {
    fn default() -> Self {
        NetConfig { lags: vec![30, 60], hidden: 16 }
    }
}

/// Largest number of hidden units.
pub const MAX_HIDDEN: usize = 256;

impl NetConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        DriftMap::try_new(1, &self.lags, EventsConfig::default().floor).map_err(|e| invalid(format!("lags: {e}")))?;
        if !(1..=MAX_HIDDEN).contains(&self.hidden) {
            return Err(invalid(format!("hidden {} must be in 1..={MAX_HIDDEN}", self.hidden)));
        }
        Ok(())
    }

    /// Number of network inputs for `taxels` taxels: `(2·lags + 1)·taxels + 7`.
    pub fn inputs(&self, taxels: usize) -> usize {
        (2 * self.lags.len() + 1) * taxels + Feature::DRIFT.len()
    }
}

/// The streaming representation of [`DosNet`] (see the [module docs](crate::dos)): push raw frames,
/// read [`input`](Self::input) for the span so far. A plain state machine:
/// [`reset`](Self::reset) starts a new span.
#[derive(Clone, Debug)]
pub struct NetExtractor {
    config: NetConfig,
    positions: Vec<[f64; 2]>,
    centre: [f64; 2],
    /// One drift map per lag, and one over all lags (the moments).
    maps: Vec<DriftMap>,
    all: DriftMap,
    first: Vec<f64>,
    prev: Vec<f64>,
    noise_sum: Vec<f64>,
    noise_n: u64,
    frames: u64,
}

impl NetExtractor {
    /// An extractor for `layout`'s taxels (validating the configuration).
    pub fn try_new(config: &NetConfig, layout: &Layout) -> Result<Self> {
        config.validate()?;
        let n = layout.len();
        let floor = EventsConfig::default().floor;
        let maps = config
            .lags
            .iter()
            .map(|&l| DriftMap::try_new(n, &[l], floor).map(|m| m.with_scale(DriftScale::Linear)))
            .collect::<Result<Vec<_>>>()?;
        let all = DriftMap::try_new(n, &config.lags, floor)?.with_scale(DriftScale::Linear);
        Ok(NetExtractor {
            config: config.clone(),
            positions: layout.positions().to_vec(),
            centre: layout.extent().centre(),
            maps,
            all,
            first: vec![0.0; n],
            prev: vec![0.0; n],
            noise_sum: vec![0.0; n],
            noise_n: 0,
            frames: 0,
        })
    }

    /// Number of taxels.
    pub fn taxels(&self) -> usize {
        self.positions.len()
    }

    /// Frames in the span.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Push one frame of raw values (one per taxel, finite).
    pub fn push(&mut self, values: &[f64]) -> Result<()> {
        if values.len() != self.taxels() {
            return Err(invalid(format!("frame of {} values for {} taxels", values.len(), self.taxels())));
        }
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(invalid(format!("taxel {} is {} (finite values only)", i + 1, values[i])));
        }
        for m in &mut self.maps {
            m.push(values)?;
        }
        self.all.push(values)?;
        if self.frames == 0 {
            self.first.copy_from_slice(values);
        } else {
            // scaled by 2⁻⁶⁴ as the drift map does: differences of values near ±f64::MAX stay finite
            for ((acc, &x), &p) in self.noise_sum.iter_mut().zip(values).zip(&self.prev) {
                *acc += (x * SCALE - p * SCALE).abs();
            }
            self.noise_n += 1;
        }
        self.prev.copy_from_slice(values);
        self.frames += 1;
        Ok(())
    }

    /// Start a new span (everything forgotten).
    pub fn reset(&mut self) {
        for m in &mut self.maps {
            m.reset();
        }
        self.all.reset();
        self.noise_sum.iter_mut().for_each(|v| *v = 0.0);
        self.noise_n = 0;
        self.frames = 0;
    }

    /// The representation of the span so far (`config.inputs(taxels)` finite values; all at
    /// their no-change values before two frames).
    pub fn input(&self) -> Vec<f64> {
        let n = self.taxels();
        let mut out = Vec::with_capacity(self.config.inputs(n));
        for m in &self.maps {
            let s = m.snapshot();
            out.extend_from_slice(&s.weights);
            out.extend(s.weights.iter().zip(&s.signs).map(|(w, s)| w * s));
        }
        for i in 0..n {
            let noise = if self.noise_n > 0 { self.noise_sum[i] / self.noise_n as f64 } else { 0.0 };
            let change = (self.prev[i] * SCALE - self.first[i] * SCALE) * f64::from(u8::from(self.frames > 0));
            let z = if change == 0.0 {
                0.0
            } else if noise > 0.0 {
                (change / (NOISE_UNITS * noise)).asinh()
            } else {
                // a change without frame-to-frame jitter: as far as the scale goes
                change.signum() * MAX_Z
            };
            out.push(z.clamp(-MAX_Z, MAX_Z));
        }
        out.extend_from_slice(&drift_moments(&self.all.snapshot(), &self.positions, self.centre));
        out
    }
}

/// 2⁻⁶⁴ (see [`NetExtractor::push`]).
const SCALE: f64 = 1.0 / 18_446_744_073_709_551_616.0;
/// Noise units of the net change's compression.
const NOISE_UNITS: f64 = 4.0;
/// Largest net-change input (`asinh` of ~1e9).
const MAX_Z: f64 = 21.4;

/// The seven drift moments ([`Feature::DRIFT`] order) of a drift snapshot on `positions`;
/// without weight the centroid is `centre` and the moments are zero.
pub(super) fn drift_moments(snap: &DriftSnapshot, positions: &[[f64; 2]], centre: [f64; 2]) -> [f64; 7] {
    let total: f64 = snap.weights.iter().sum();
    let level = total.ln_1p();
    if !(total > 0.0 && total.is_finite()) {
        return [level, centre[0], centre[1], 0.0, 0.0, 0.0, 0.0];
    }
    let (mut cx, mut cy) = (0.0, 0.0);
    for (w, p) in snap.weights.iter().zip(positions) {
        cx += w * p[0];
        cy += w * p[1];
    }
    let (cx, cy) = (cx / total, cy / total);
    let (mut r2, mut aniso, mut cross, mut signed_y) = (0.0, 0.0, 0.0, 0.0);
    for ((w, s), p) in snap.weights.iter().zip(&snap.signs).zip(positions) {
        let (dx, dy) = (p[0] - cx, p[1] - cy);
        r2 += w * (dx * dx + dy * dy);
        aniso += w * (dx * dx - dy * dy);
        cross += w * dx * dy;
        signed_y += w * s * p[1];
    }
    [level, cx, cy, (r2 / total).ln_1p(), aniso / total, cross / total, signed_y / total]
}

/// The learned slip-direction model (see the [module docs](crate::dos)): representation settings,
/// input standardisation and the network's weights. Serialises to JSON (serde), validated when
/// read.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, try_from = "RawNet")]
pub struct DosNet {
    /// Representation and network settings.
    pub config: NetConfig,
    /// Taxels of the sensor the model was trained for.
    pub taxels: usize,
    /// The classes, in output order.
    pub classes: Vec<DosClass>,
    /// Mean of each input over the training set.
    pub input_mean: Vec<f64>,
    /// Spread of each input over the training set (> 0).
    pub input_scale: Vec<f64>,
    /// First layer, `hidden` rows of `inputs` values.
    pub w1: Vec<Vec<f64>>,
    /// First layer's biases (`hidden`).
    pub b1: Vec<f64>,
    /// Output layer, `classes` rows of `hidden` values.
    pub w2: Vec<Vec<f64>>,
    /// Output biases (`classes`).
    pub b2: Vec<f64>,
    /// Labelled recordings it was trained on (information only).
    pub recordings: usize,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawNet {
    config: NetConfig,
    taxels: usize,
    classes: Vec<DosClass>,
    input_mean: Vec<f64>,
    input_scale: Vec<f64>,
    w1: Vec<Vec<f64>>,
    b1: Vec<f64>,
    w2: Vec<Vec<f64>>,
    b2: Vec<f64>,
    #[serde(default)]
    recordings: usize,
}

impl TryFrom<RawNet> for DosNet {
    type Error = Error;
    fn try_from(r: RawNet) -> Result<Self> {
        let m = DosNet {
            config: r.config,
            taxels: r.taxels,
            classes: r.classes,
            input_mean: r.input_mean,
            input_scale: r.input_scale,
            w1: r.w1,
            b1: r.b1,
            w2: r.w2,
            b2: r.b2,
            recordings: r.recordings,
        };
        m.validate()?;
        Ok(m)
    }
}

/// Largest taxel count of a learned model.
pub const MAX_NET_TAXELS: usize = 4096;

impl DosNet {
    /// Number of inputs.
    pub fn inputs(&self) -> usize {
        self.config.inputs(self.taxels)
    }

    /// Number of fitted numbers (weights, biases, input means and spreads).
    pub fn parameter_count(&self) -> usize {
        dense::parameter_count(self.inputs(), self.config.hidden, self.classes.len())
    }

    /// The network's numbers, for [`dense`](super::dense)'s checks and evaluation.
    fn dense(&self) -> Dense<'_> {
        Dense {
            input_mean: &self.input_mean,
            input_scale: &self.input_scale,
            w1: &self.w1,
            b1: &self.b1,
            w2: &self.w2,
            b2: &self.b2,
        }
    }

    /// Checks shapes and values (done on deserialisation).
    pub fn validate(&self) -> Result<()> {
        self.config.validate()?;
        if !(3..=MAX_NET_TAXELS).contains(&self.taxels) {
            return Err(invalid(format!("taxels {} must be in 3..={MAX_NET_TAXELS}", self.taxels)));
        }
        self.dense().validate(&self.classes, self.inputs(), self.config.hidden)
    }

    /// The output logits for a representation (`inputs()` values, unchecked lengths are an error).
    pub fn logits(&self, input: &[f64]) -> Result<Vec<f64>> {
        self.dense().logits(input)
    }

    /// Classify a representation ([`NetExtractor::input`]).
    pub fn classify(&self, input: &[f64]) -> Result<Decision> {
        let logits = self.logits(input)?;
        let posterior = softmax(&logits);
        let mut best = 0;
        for (k, &p) in posterior.iter().enumerate() {
            if p > posterior[best] {
                best = k;
            }
        }
        let distances = posterior.iter().map(|p| -2.0 * p.max(f64::MIN_POSITIVE).ln()).collect();
        Ok(Decision { class: self.classes[best], posterior, distances })
    }

    /// An extractor for this model's representation on `layout` (which must have the model's
    /// taxel count).
    pub fn extractor(&self, layout: &Layout) -> Result<NetExtractor> {
        if layout.len() != self.taxels {
            return Err(invalid(format!(
                "the model was trained for {} taxels, the layout has {}",
                self.taxels,
                layout.len()
            )));
        }
        NetExtractor::try_new(&self.config, layout)
    }
}

/// `softmax(z)`, stable for any finite `z`.
pub fn softmax(z: &[f64]) -> Vec<f64> {
    let m = z.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let e: Vec<f64> = z.iter().map(|v| (v - m).exp()).collect();
    let s: f64 = e.iter().sum();
    e.iter().map(|v| v / s).collect()
}
