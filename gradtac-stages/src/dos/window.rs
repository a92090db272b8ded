//! The window model of slip direction ([`DosWindowNet`]): the published ConvLSTM's protocol —
//! one answer per short window of raw frames — with a per-recording answer by a causal vote.
//!
//! # Why a window of levels
//! The drift features of [`DosModel`] and [`DosNet`] measure how the signals *move since
//! contact*; a 50 ms window holds almost none of that (29 % per window). The ConvLSTM of
//! Zapata-Impata et al. classifies a 5-frame window of the *raw* electrode values: the static
//! pattern of the electrode impedances, i.e. how the skin is sheared by the slipping object,
//! already encodes the direction. This model does the same with one hidden layer.
//!
//! # Representation ([`WindowExtractor::input`])
//! For a window of `F` frames (default 5 = 50 ms at 100 Hz) of `n` taxels, with `S_i` the sum of
//! taxel `i` over the window, `T = Σ_i S_i`, `dev_i = n·S_i − T` (the taxel's level against the
//! window's mean level over all taxels) and `s = √(Σ_i dev_i² / n)`:
//! - the **level pattern** `z_i = dev_i / s` (`n` values);
//! - the **change across the window** `d_i = n·F·(x_{last,i} − x_{first,i}) / s` (`n` values),
//!
//! `2n` inputs (48 for the BioTac SP), zero when every taxel has the same level (`s = 0`).
//! Both are exactly invariant to one gain and one offset common to all taxels: computed from
//! integer counts (what the sensor gives) the sums and `dev_i` are exact, so an integer offset
//! and a power-of-two gain change no bit (tested); for other values they change only rounding.
//! They are *not* invariant to a gain or an offset per taxel — the pattern across taxels is the
//! signal — so the trainer draws per-taxel gains and offsets as augmentation
//! (`train_window`).
//!
//! # Decision
//! Standardised inputs (training mean and spread), `h = tanh(W₁ x + b₁)`,
//! `logits = W₂ h + b₂`; per window, the class of the largest posterior. Per recording (or since
//! contact on a stream), [`WindowVote`] sums the log posteriors of every completed
//! non-overlapping window so far — causal: at frame `t` only windows ending at or before `t`.
//!
//! # Cost
//! Per frame: one copy of the frame into a ring of `F` frames. Per window: `F·n` additions for
//! the sums, `inputs × hidden + hidden × classes` multiply-adds and `hidden` `tanh` (≈ 900 with
//! 16 hidden units). Memory: `F × n` values.

use super::dense::{self, Dense};
use super::net::softmax;
use super::*;

/// Settings of the window model's representation and network, stored in the model file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WindowNetConfig {
    /// Frames per window (2..=1000). Default 5 (50 ms at 100 Hz, the published protocol's).
    pub frames: usize,
    /// Hidden units (1..=256). Default 16.
    pub hidden: usize,
}

impl Default for WindowNetConfig {
    fn default() -> Self {
        WindowNetConfig { frames: 5, hidden: 16 }
    }
}

/// Largest window of [`WindowNetConfig::frames`].
pub const MAX_WINDOW_FRAMES: usize = 1000;

impl WindowNetConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        if !(2..=MAX_WINDOW_FRAMES).contains(&self.frames) {
            return Err(invalid(format!("window frames {} must be in 2..={MAX_WINDOW_FRAMES}", self.frames)));
        }
        if !(1..=MAX_HIDDEN).contains(&self.hidden) {
            return Err(invalid(format!("hidden {} must be in 1..={MAX_HIDDEN}", self.hidden)));
        }
        Ok(())
    }

    /// Number of network inputs for `taxels` taxels: `2·taxels`.
    pub fn inputs(&self, taxels: usize) -> usize {
        2 * taxels
    }
}

/// 2⁻⁶⁴: values are scaled by it (exactly, a power of two) so that sums of values near
/// `±f64::MAX` stay finite.
const SCALE: f64 = 1.0 / 18_446_744_073_709_551_616.0;
/// Largest `|d_i|` (a change across the window far larger than the spread of levels).
const MAX_CHANGE: f64 = 1e3;

/// The streaming representation of [`DosWindowNet`] (see the [module docs](crate::dos)): push raw
/// frames; [`input`](Self::input) is the representation of the last `frames` frames. A plain
/// state machine: [`reset`](Self::reset) starts a new span.
#[derive(Clone, Debug)]
pub struct WindowExtractor {
    frames: usize,
    taxels: usize,
    /// Ring of the last `frames` frames (scaled by [`SCALE`]).
    ring: Vec<Vec<f64>>,
    /// Frames pushed since the last reset.
    count: u64,
}

impl WindowExtractor {
    /// An extractor of `config`'s windows for `taxels` taxels (1..=4096).
    pub fn try_new(config: &WindowNetConfig, taxels: usize) -> Result<Self> {
        config.validate()?;
        if !(1..=MAX_NET_TAXELS).contains(&taxels) {
            return Err(invalid(format!("taxels {taxels} must be in 1..={MAX_NET_TAXELS}")));
        }
        Ok(WindowExtractor { frames: config.frames, taxels, ring: vec![vec![0.0; taxels]; config.frames], count: 0 })
    }

    /// Frames pushed since the last reset.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// Push one frame of raw values (one per taxel, finite). Returns whether a non-overlapping
    /// window (frames `k·F .. (k+1)·F` since the reset) has just completed.
    pub fn push(&mut self, values: &[f64]) -> Result<bool> {
        if values.len() != self.taxels {
            return Err(invalid(format!("frame of {} values for {} taxels", values.len(), self.taxels)));
        }
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(invalid(format!("taxel {} is {} (finite values only)", i + 1, values[i])));
        }
        let slot = (self.count % self.frames as u64) as usize;
        for (r, v) in self.ring[slot].iter_mut().zip(values) {
            *r = v * SCALE;
        }
        self.count += 1;
        Ok(self.count % self.frames as u64 == 0)
    }

    /// Whether a full window has been pushed since the reset.
    pub fn ready(&self) -> bool {
        self.count >= self.frames as u64
    }

    /// Start a new span.
    pub fn reset(&mut self) {
        self.count = 0;
    }

    /// The representation of the last `frames` frames (`2·taxels` finite values); `None` before
    /// a full window.
    pub fn input(&self) -> Option<Vec<f64>> {
        if !self.ready() {
            return None;
        }
        let (n, f) = (self.taxels, self.frames);
        let newest = ((self.count - 1) % f as u64) as usize;
        let oldest = (self.count % f as u64) as usize;
        let mut sums = vec![0.0; n];
        // chronological order, so that the sums do not depend on where the ring starts
        for k in 0..f {
            let row = &self.ring[(oldest + k) % f];
            for (s, v) in sums.iter_mut().zip(row) {
                *s += v;
            }
        }
        let total: f64 = sums.iter().sum();
        let nf = n as f64;
        let dev: Vec<f64> = sums.iter().map(|s| nf * s - total).collect();
        let s = (dev.iter().map(|d| d * d).sum::<f64>() / nf).sqrt();
        let mut out = vec![0.0; 2 * n];
        if s > 0.0 && s.is_finite() {
            let nff = nf * f as f64;
            for i in 0..n {
                let z = dev[i] / s;
                let d = nff * (self.ring[newest][i] - self.ring[oldest][i]) / s;
                out[i] = if z.is_finite() { z } else { 0.0 };
                out[n + i] = if d.is_finite() { d.clamp(-MAX_CHANGE, MAX_CHANGE) } else { 0.0 };
            }
        }
        Some(out)
    }
}

/// The window model of slip direction (see the [module docs](crate::dos)): representation settings,
/// input standardisation and the network's weights. Serialises to JSON (serde), validated when
/// read.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, try_from = "RawWindowNet")]
pub struct DosWindowNet {
    /// Representation and network settings.
    pub config: WindowNetConfig,
    /// Taxels of the sensor the model was trained for.
    pub taxels: usize,
    /// The classes, in output order.
    pub classes: Vec<DosClass>,
    /// Mean of each input over the training windows.
    pub input_mean: Vec<f64>,
    /// Spread of each input over the training windows (> 0).
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

/// A window net as read, before validation (the [`DosWindowPart`] of a model validates it with
/// the field's name).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawWindowNet {
    config: WindowNetConfig,
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

impl TryFrom<RawWindowNet> for DosWindowNet {
    type Error = Error;
    fn try_from(r: RawWindowNet) -> Result<Self> {
        let m = DosWindowNet {
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

impl DosWindowNet {
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

    /// Checks shapes and values (done on deserialisation); the error names the field.
    pub fn validate(&self) -> Result<()> {
        self.config.validate()?;
        if !(3..=MAX_NET_TAXELS).contains(&self.taxels) {
            return Err(invalid(format!("taxels {} must be in 3..={MAX_NET_TAXELS}", self.taxels)));
        }
        self.dense().validate(&self.classes, self.inputs(), self.config.hidden)
    }

    /// The output logits for a window's representation ([`WindowExtractor::input`]).
    pub fn logits(&self, input: &[f64]) -> Result<Vec<f64>> {
        self.dense().logits(input)
    }

    /// The log posterior of one window's representation (net class order).
    pub fn log_posterior(&self, input: &[f64]) -> Result<Vec<f64>> {
        Ok(log_softmax(&self.logits(input)?))
    }

    /// Classify one window's representation.
    pub fn classify(&self, input: &[f64]) -> Result<Decision> {
        let posterior = softmax(&self.logits(input)?);
        Ok(decision(&self.classes, posterior))
    }

    /// An extractor of this model's windows for `layout` (which must have the model's taxel
    /// count).
    pub fn extractor(&self, layout: &Layout) -> Result<WindowExtractor> {
        if layout.len() != self.taxels {
            return Err(invalid(format!(
                "the model was trained for {} taxels, the layout has {}",
                self.taxels,
                layout.len()
            )));
        }
        WindowExtractor::try_new(&self.config, self.taxels)
    }

    /// A streaming per-span answer of this model on `layout` ([`WindowVote`]).
    pub fn vote(&self, layout: &Layout) -> Result<WindowVote<'_>> {
        Ok(WindowVote { net: self, state: WindowVoteState::try_new(self, layout)? })
    }
}

/// `l − ln Σ exp l` per logit.
fn log_softmax(logits: &[f64]) -> Vec<f64> {
    let top = logits.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let lse = top + logits.iter().map(|l| (l - top).exp()).sum::<f64>().ln();
    logits.iter().map(|l| l - lse).collect()
}

/// The decision of a posterior (argmax, ties: the first in model order).
fn decision(classes: &[DosClass], posterior: Vec<f64>) -> Decision {
    let mut best = 0;
    for (k, &p) in posterior.iter().enumerate() {
        if p > posterior[best] {
            best = k;
        }
    }
    let distances = posterior.iter().map(|p| -2.0 * p.max(f64::MIN_POSITIVE).ln()).collect();
    Decision { class: classes[best], posterior, distances }
}

/// The causal per-span answer of a [`DosWindowNet`]: the sum of the log posteriors of every
/// completed non-overlapping window since the last [`reset`](Self::reset) (the contact).
#[derive(Clone, Debug)]
pub struct WindowVote<'a> {
    net: &'a DosWindowNet,
    state: WindowVoteState,
}

impl WindowVote<'_> {
    /// Push one raw frame; when it completes a window, that window's decision (the window
    /// alone) is returned and added to the vote.
    pub fn push(&mut self, values: &[f64]) -> Result<Option<Decision>> {
        self.state.push(self.net, values)
    }

    /// Completed windows in the vote.
    pub fn windows(&self) -> u64 {
        self.state.windows
    }

    /// The vote's decision so far (`None` before the first window); its posterior is the
    /// normalised product of the windows' posteriors.
    pub fn decision(&self) -> Option<Decision> {
        self.state.decision(self.net)
    }

    /// The mean log posterior per window so far, in model class order (`None` before the first
    /// window): the vote on the scale of one window, to combine with another model's log
    /// posterior.
    pub fn mean_log_posterior(&self) -> Option<Vec<f64>> {
        self.state.mean_log_posterior()
    }

    /// Start a new span (a new contact).
    pub fn reset(&mut self) {
        self.state.reset();
    }
}

/// The state of a [`WindowVote`] without the borrow of its net, for an owner of the net (the
/// `dos` stage keeps both): every call takes the net the state was made for.
#[derive(Clone, Debug)]
pub struct WindowVoteState {
    extractor: WindowExtractor,
    sum: Vec<f64>,
    windows: u64,
}

impl WindowVoteState {
    /// An empty vote of `net` on `layout` (which must have the net's taxel count).
    pub fn try_new(net: &DosWindowNet, layout: &Layout) -> Result<Self> {
        Ok(WindowVoteState { extractor: net.extractor(layout)?, sum: vec![0.0; net.classes.len()], windows: 0 })
    }

    /// [`WindowVote::push`] with `net` (the net this state was made for).
    pub fn push(&mut self, net: &DosWindowNet, values: &[f64]) -> Result<Option<Decision>> {
        if !self.extractor.push(values)? {
            return Ok(None);
        }
        let Some(x) = self.extractor.input() else { return Ok(None) };
        let logits = net.logits(&x)?;
        self.add_log_posterior(&log_softmax(&logits));
        Ok(Some(decision(&net.classes, softmax(&logits))))
    }

    /// Add one window's log posterior ([`DosWindowNet::log_posterior`], net class order) to the
    /// vote, as [`push`](Self::push) does when a window completes (the same sum, bit for bit).
    pub fn add_log_posterior(&mut self, log_p: &[f64]) {
        for (s, l) in self.sum.iter_mut().zip(log_p) {
            *s += l;
        }
        self.windows += 1;
    }

    /// Completed windows in the vote.
    pub fn windows(&self) -> u64 {
        self.windows
    }

    /// [`WindowVote::decision`] with `net`.
    pub fn decision(&self, net: &DosWindowNet) -> Option<Decision> {
        (self.windows > 0).then(|| decision(&net.classes, softmax(&self.sum)))
    }

    /// [`WindowVote::mean_log_posterior`].
    pub fn mean_log_posterior(&self) -> Option<Vec<f64>> {
        (self.windows > 0).then(|| self.sum.iter().map(|s| s / self.windows as f64).collect())
    }

    /// Start a new span (a new contact).
    pub fn reset(&mut self) {
        self.extractor.reset();
        self.sum.iter_mut().for_each(|v| *v = 0.0);
        self.windows = 0;
    }
}
