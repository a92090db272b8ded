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
//! ## Measured against the span's own start ([`WindowInputs`])
//! The level pattern carries the object: its shape and stiffness set which taxels are loaded,
//! so a model trained on few objects learns their patterns. [`WindowInputs::SinceStart`] and
//! [`WindowInputs::Both`] add a **causal per-recording normalisation**: each taxel's window
//! sum against its own mean over the span's first [`WindowNetConfig::reference_frames`]
//! frames (default 10 = 0.1 s after contact; fewer while the span is younger — only frames
//! already seen), `u_i = S_i − F·r_i`, as a pattern across taxels on the same scale as the
//! levels, `(n·u_i − Σ_j u_j) / s`. A robot can do this online: the reference is the contact's
//! own first 0.1 s. The pattern's shape is exactly invariant to an offset per taxel (a static
//! pattern such as the object's shape; up to rounding, tested); only its scale `s` (the level
//! spread) still depends on the levels. [`WindowInputs::Both`] keeps the level pattern beside
//! it (`3n` inputs, 72 for the BioTac SP): measured inside basic and inside solids by
//! leave-one-object-out, the change since contact alone is weak (44–46 % / 33–34 % per window,
//! levels 61–62 % / 65–66 %) and the two together the best (66–71 % / 66–69 %). Held out
//! (`dos` module docs; the log in `examples/dos_eval_parts/history.md`) a five-member ensemble of `Both` with the Student-t design gains nested
//! and basic → solids and loses solids → basic against the default, so the default stays
//! [`WindowInputs::Levels`]. Cost: `n` more additions per frame for the first
//! `reference_frames` frames, `n` more inputs per window; in the `dos` stage's sliding mode no
//! net window can be kept across decisions (the reference moves with the replayed window), so
//! every decision recomputes all of its net windows (p99 230 µs per frame at 250 frames, hop
//! 10, five members; one decision per span: p99 5 µs).
//!
//! ## Motion inputs about the contact's own centre ([`WindowNetConfig::motion`], calibrate's default)
//! Four more inputs aimed at the rotation–translation confusion (see the `dos` module docs for
//! the figures, `examples/dos_eval_parts/history.md` for the measurement). With `w_i` the window's deviation `dev_i` on the side of its largest
//! deviation (the loaded taxels; others 0), the contact's centre `c = Σ w_i p_i / Σ w_i`, its
//! second moments `C` about `c`, `tr = Cxx + Cyy` and `z = (Cxx − Cyy) + 2i·Cxy` (the principal
//! axis as a double angle); the same of the span's reference (its first `reference_frames`
//! frames, as for [`WindowInputs::SinceStart`]) give `c_r`, `tr_r`, `z_r`. The inputs are the
//! centre's drift `(c − c_r)/√tr_r` (two values, in contact radii), the turn of the principal
//! axis `rot = Im(z·z̄_r)/(tr·tr_r)` (the sine of twice the turn times both anisotropies, in
//! −1..=1, zero for a round contact) and the rotation's share `|rot|/(|rot| + |drift| + 0.01)`.
//! A ratio of moments: the contact's size and one gain and offset common to all taxels cancel
//! (tested to rounding). The positions are made exactly symmetric about `y = 0` when they are
//! within 0.1 mm, so a mirrored window's motion inputs are exactly the mirrored ones (signs
//! [`MOTION_MIRROR_SIGNS`]) and the mirror average stays exact. Causal: only the span's first
//! frames and the current window. Cost: two weighted moment sums over the taxels per window
//! (≈ 10·n operations) and the reference sums of the first `reference_frames` frames.
//!
//! An ensemble of networks over seeds is one network here: the trainer merges them by
//! averaging their logits into one hidden layer of `members × hidden` units
//! (`train_window::merge_members`, `WindowTrainConfig::members`), so inference and the file
//! format are unchanged; the cost per window grows with the hidden units (five members of 16:
//! ≈ 6 500 multiply-adds and 80 `tanh` per window, p99 4.7 µs per frame measured). Inside
//! basic, the seed alone moved a single network's accuracy per window from 60.5 to 69.9 %; the
//! ensemble is what makes a choice between candidates meaningful.
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
    /// What the window's pattern is measured against ([`WindowInputs`]). Default
    /// [`WindowInputs::Levels`] (the representation of model files written before this field;
    /// not written when it is the default, so such files stay as they were).
    #[serde(skip_serializing_if = "WindowInputs::is_levels")]
    pub inputs: WindowInputs,
    /// Frames since the span's start (the contact) whose mean is the span's own reference
    /// level per taxel, for [`WindowInputs::SinceStart`] and [`WindowInputs::Both`]
    /// (1..=1000). Default 10 (0.1 s at 100 Hz; not written when it is the default).
    #[serde(skip_serializing_if = "is_default_reference")]
    pub reference_frames: usize,
    /// Add the four **motion inputs** of the contact about its own tracked centre since the
    /// span's start ([`MOTION_INPUTS`]; see [`WindowExtractor::input`]): the centre's drift
    /// (two values, in contact radii), the rotation of the pattern's principal axis (a signed
    /// value in −1..=1 that vanishes for a round pattern) and the share of rotation in the
    /// motion. Needs the layout's taxel positions. Default off here (not written when off, so
    /// older model files read unchanged); `gradtac calibrate` turns it on since stop 32.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub motion: bool,
}

/// Number of motion inputs ([`WindowNetConfig::motion`]).
pub const MOTION_INPUTS: usize = 4;

/// The sign each motion input takes under the layout's reflection across `y = 0`
/// (drift x, drift y, rotation, rotation share).
pub const MOTION_MIRROR_SIGNS: [f64; MOTION_INPUTS] = [1.0, -1.0, -1.0, 1.0];

impl Default for WindowNetConfig {
    fn default() -> Self {
        WindowNetConfig { frames: 5, hidden: 16, inputs: WindowInputs::Levels, reference_frames: 10, motion: false }
    }
}

/// Whether `frames` is the default reference length (10).
fn is_default_reference(frames: &usize) -> bool {
    *frames == 10
}

impl WindowInputs {
    /// Whether these are [`WindowInputs::Levels`].
    pub fn is_levels(&self) -> bool {
        *self == WindowInputs::Levels
    }
}

/// The window model's inputs (see the [module docs](crate::dos)).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WindowInputs {
    /// The level pattern across taxels and the change across the window (`2n` inputs).
    #[default]
    Levels,
    /// The pattern of the change since the span's start (each taxel against its own mean over
    /// the span's first [`WindowNetConfig::reference_frames`] frames: a causal per-recording
    /// normalisation) and the change across the window (`2n` inputs). Exactly invariant to an
    /// offset per taxel (a static pattern such as an object's shape), up to rounding.
    SinceStart,
    /// The level pattern, the pattern since the span's start and the change across the window
    /// (`3n` inputs).
    Both,
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
        if !(1..=MAX_WINDOW_FRAMES).contains(&self.reference_frames) {
            return Err(invalid(format!(
                "reference frames {} must be in 1..={MAX_WINDOW_FRAMES}",
                self.reference_frames
            )));
        }
        Ok(())
    }

    /// Number of network inputs for `taxels` taxels: `2·taxels` (`3·taxels` for
    /// [`WindowInputs::Both`]), [`MOTION_INPUTS`] more with [`motion`](Self::motion).
    pub fn inputs(&self, taxels: usize) -> usize {
        self.taxel_blocks() * taxels + if self.motion { MOTION_INPUTS } else { 0 }
    }

    /// Number of per-taxel input blocks (2, or 3 for [`WindowInputs::Both`]).
    pub fn taxel_blocks(&self) -> usize {
        match self.inputs {
            WindowInputs::Levels | WindowInputs::SinceStart => 2,
            WindowInputs::Both => 3,
        }
    }

    /// Whether the representation needs the span's own reference (the first
    /// [`reference_frames`](Self::reference_frames) frames).
    pub fn needs_reference(&self) -> bool {
        self.inputs != WindowInputs::Levels || self.motion
    }
}

/// 2⁻⁶⁴: values are scaled by it (exactly, a power of two) so that sums of values near
/// `±f64::MAX` stay finite.
const SCALE: f64 = 1.0 / 18_446_744_073_709_551_616.0;
/// Largest `|d_i|` (a change across the window far larger than the spread of levels).
pub(super) const MAX_CHANGE: f64 = 1e3;

/// The streaming representation of [`DosWindowNet`] (see the [module docs](crate::dos)): push raw
/// frames; [`input`](Self::input) is the representation of the last `frames` frames. A plain
/// state machine: [`reset`](Self::reset) starts a new span.
#[derive(Clone, Debug)]
pub struct WindowExtractor {
    frames: usize,
    taxels: usize,
    inputs: WindowInputs,
    reference_frames: usize,
    /// Taxel positions for the motion inputs (empty without them).
    positions: Vec<[f64; 2]>,
    /// Whether the reference is gathered ([`WindowNetConfig::needs_reference`]).
    needs_reference: bool,
    /// Ring of the last `frames` frames (scaled by [`SCALE`]).
    ring: Vec<Vec<f64>>,
    /// Sum of the span's first `reference_frames` frames (scaled), per taxel.
    reference: Vec<f64>,
    /// Frames in `reference`.
    reference_count: u64,
    /// Whether `reference` was given ([`WindowExtractor::reset_with_reference`]) rather than
    /// gathered from the pushed frames.
    reference_fixed: bool,
    /// Frames pushed since the last reset.
    count: u64,
}

impl WindowExtractor {
    /// An extractor of `config`'s windows for `taxels` taxels (1..=4096). A configuration with
    /// [`WindowNetConfig::motion`] needs the taxel positions: [`try_new_on`](Self::try_new_on).
    pub fn try_new(config: &WindowNetConfig, taxels: usize) -> Result<Self> {
        if config.motion {
            return Err(invalid("the motion inputs need the layout's taxel positions (try_new_on)"));
        }
        Self::with_positions(config, taxels, Vec::new())
    }

    /// An extractor of `config`'s windows for `layout`'s taxels (1..=4096).
    pub fn try_new_on(config: &WindowNetConfig, layout: &Layout) -> Result<Self> {
        let positions = if config.motion { symmetrised(layout.positions()) } else { Vec::new() };
        if positions.iter().flatten().any(|v| !v.is_finite()) {
            return Err(invalid("the motion inputs need finite taxel positions"));
        }
        Self::with_positions(config, layout.len(), positions)
    }

    fn with_positions(config: &WindowNetConfig, taxels: usize, positions: Vec<[f64; 2]>) -> Result<Self> {
        config.validate()?;
        if !(1..=MAX_NET_TAXELS).contains(&taxels) {
            return Err(invalid(format!("taxels {taxels} must be in 1..={MAX_NET_TAXELS}")));
        }
        Ok(WindowExtractor {
            frames: config.frames,
            taxels,
            inputs: config.inputs,
            reference_frames: config.reference_frames,
            positions,
            needs_reference: config.needs_reference(),
            ring: vec![vec![0.0; taxels]; config.frames],
            reference: vec![0.0; taxels],
            reference_count: 0,
            reference_fixed: false,
            count: 0,
        })
    }

    /// Frames pushed since the last reset.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// Number of values of [`input`](Self::input).
    pub fn config_inputs(&self) -> usize {
        WindowNetConfig { inputs: self.inputs, motion: !self.positions.is_empty(), ..WindowNetConfig::default() }
            .inputs(self.taxels)
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
        if self.needs_reference && !self.reference_fixed && self.reference_count < self.reference_frames as u64 {
            for (r, v) in self.reference.iter_mut().zip(values) {
                *r += v * SCALE;
            }
            self.reference_count += 1;
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
        self.reference.iter_mut().for_each(|r| *r = 0.0);
        self.reference_count = 0;
        self.reference_fixed = false;
    }

    /// Start a new span whose reference level is the mean of `frames` (raw values, one per
    /// taxel each; at most [`WindowNetConfig::reference_frames`] are used, the first ones):
    /// for a replay of a span's tail that must see the reference its span had (the `dos`
    /// stage's sliding mode). Then push the frames the windows are made of.
    pub fn reset_with_reference<'a>(&mut self, frames: impl IntoIterator<Item = &'a [f64]>) -> Result<()> {
        self.reset();
        let mut used = 0u64;
        for f in frames.into_iter().take(self.reference_frames) {
            if f.len() != self.taxels || f.iter().any(|v| !v.is_finite()) {
                return Err(invalid("a reference frame of the wrong length or with a non-finite value"));
            }
            for (r, v) in self.reference.iter_mut().zip(f) {
                *r += v * SCALE;
            }
            used += 1;
        }
        self.reference_count = used;
        self.reference_fixed = true;
        Ok(())
    }

    /// The representation of the last `frames` frames ([`WindowNetConfig::inputs`] finite
    /// values); `None` before a full window.
    pub fn input(&self) -> Option<Vec<f64>> {
        if !self.ready() {
            return None;
        }
        let (n, f) = (self.taxels, self.frames);
        let newest = ((self.count - 1) % f as u64) as usize;
        let oldest = (self.count % f as u64) as usize;
        let (sums, dev, s) = self.window_sums();
        let nf = n as f64;
        let mut out = vec![0.0; self.config_inputs()];
        if !(s > 0.0 && s.is_finite()) {
            return Some(out);
        }
        let nff = nf * f as f64;
        let tidy = |v: f64| if v.is_finite() { v.clamp(-MAX_CHANGE, MAX_CHANGE) } else { 0.0 };
        let mut at = 0;
        if self.inputs != WindowInputs::SinceStart {
            for i in 0..n {
                out[i] = tidy(dev[i] / s);
            }
            at = n;
        }
        if self.inputs != WindowInputs::Levels && self.reference_count > 0 {
            // each taxel's window sum against F × its reference mean, as a pattern across taxels
            let ff = f as f64 / self.reference_count as f64;
            let since: Vec<f64> = sums.iter().zip(&self.reference).map(|(s, r)| s - ff * r).collect();
            let st: f64 = since.iter().sum();
            for i in 0..n {
                out[at + i] = tidy((nf * since[i] - st) / s);
            }
        }
        if self.inputs != WindowInputs::Levels {
            at += n;
        }
        for i in 0..n {
            out[at + i] = tidy(nff * (self.ring[newest][i] - self.ring[oldest][i]) / s);
        }
        if !self.positions.is_empty() && self.reference_count > 0 {
            out[at + n..].copy_from_slice(&self.motion_inputs(&dev));
        }
        Some(out)
    }

    /// [`input`](Self::input) without the motion inputs (their places zero), and the window's
    /// level deviations `dev_i = n·S_i − T` they are computed from (`None` for a flat pattern,
    /// whose inputs are all zero, the motion inputs too): with
    /// [`motion_inputs`](Self::motion_inputs) against a reference given later, the same values
    /// as `input` (for a replay that moves only the reference: the `dos` stage's sliding mode).
    pub fn input_and_deviations(&self) -> Option<(Vec<f64>, Option<Vec<f64>>)> {
        let mut out = self.input()?;
        let motion = !self.positions.is_empty();
        if motion {
            let at = out.len() - MOTION_INPUTS;
            out[at..].iter_mut().for_each(|v| *v = 0.0);
        }
        let (_, dev, s) = self.window_sums();
        Some((out, (s > 0.0 && s.is_finite()).then_some(dev)))
    }

    /// The window's sums per taxel `S_i`, deviations `dev_i = n·S_i − T` and their spread `s`
    /// (see the [module docs](crate::dos)); the ring summed in chronological order, so that the
    /// sums do not depend on where the ring starts.
    fn window_sums(&self) -> (Vec<f64>, Vec<f64>, f64) {
        let (n, f) = (self.taxels, self.frames);
        let oldest = (self.count % f as u64) as usize;
        let mut sums = vec![0.0; n];
        for k in 0..f {
            for (s, v) in sums.iter_mut().zip(&self.ring[(oldest + k) % f]) {
                *s += v;
            }
        }
        let total: f64 = sums.iter().sum();
        let nf = n as f64;
        let dev: Vec<f64> = sums.iter().map(|s| nf * s - total).collect();
        let s = (dev.iter().map(|d| d * d).sum::<f64>() / nf).sqrt();
        (sums, dev, s)
    }

    /// The motion inputs ([`WindowNetConfig::motion`]) of a window's level deviations `dev`
    /// (from [`input_and_deviations`](Self::input_and_deviations)) against this extractor's
    /// current reference (e.g. set by [`reset_with_reference`](Self::reset_with_reference)),
    /// as [`input`](Self::input) gives them; zeros without the motion inputs or a reference.
    pub fn motion_inputs(&self, dev: &[f64]) -> [f64; MOTION_INPUTS] {
        if self.positions.is_empty() || self.reference_count == 0 || dev.len() != self.taxels {
            return [0.0; MOTION_INPUTS];
        }
        let tidy = |v: f64| if v.is_finite() { v.clamp(-MAX_CHANGE, MAX_CHANGE) } else { 0.0 };
        motion(&self.positions, dev, &self.reference).map(tidy)
    }
}

/// `positions` made exactly symmetric about `y = 0` when they are within 0.1 mm (each taxel and
/// its mirror taxel moved to the mean of the two), so that the motion inputs of mirrored frames
/// are exactly the mirrored motion inputs (the mirror average relies on it); otherwise as
/// given.
pub(super) fn symmetrised(positions: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mirror: Option<Vec<usize>> = positions
        .iter()
        .map(|a| positions.iter().position(|b| (a[0] - b[0]).abs() < 0.1 && (a[1] + b[1]).abs() < 0.1))
        .collect();
    match mirror {
        Some(m) if (0..m.len()).all(|i| m[m[i]] == i) => positions
            .iter()
            .zip(&m)
            .map(|(a, &j)| [(a[0] + positions[j][0]) / 2.0, (a[1] - positions[j][1]) / 2.0])
            .collect(),
        _ => positions.to_vec(),
    }
}

/// Motion below which the rotation's share is damped toward zero (in contact radii and
/// anisotropy units; fixed, not tuned): noise on a still contact gives no share.
const MOTION_FLOOR: f64 = 0.01;

/// The contact's centre, spread and orientation of a pattern across taxels, weighted by each
/// taxel's deviation from the mean level on the side of the largest deviation (the loaded
/// taxels, whatever the sensor's polarity; the others weigh 0): (centre, trace of the second
/// moments, `(Cxx − Cyy, 2·Cxy)` — the principal axis as a double angle). `None` for a flat
/// pattern.
pub(super) fn moments(positions: &[[f64; 2]], dev: &[f64]) -> Option<([f64; 2], f64, [f64; 2])> {
    let top = dev.iter().copied().fold(0.0f64, |a, d| if d.abs() > a.abs() { d } else { a });
    let side = top.signum();
    let weight = |d: f64| (side * d).max(0.0);
    let total: f64 = dev.iter().map(|&d| weight(d)).sum();
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    let mut c = [0.0; 2];
    for (p, d) in positions.iter().zip(dev) {
        let w = weight(*d) / total;
        c[0] += w * p[0];
        c[1] += w * p[1];
    }
    let (mut xx, mut yy, mut xy) = (0.0, 0.0, 0.0);
    for (p, d) in positions.iter().zip(dev) {
        let w = weight(*d) / total;
        let (x, y) = (p[0] - c[0], p[1] - c[1]);
        xx += w * x * x;
        yy += w * y * y;
        xy += w * x * y;
    }
    Some((c, xx + yy, [xx - yy, 2.0 * xy]))
}

/// The motion inputs ([`WindowNetConfig::motion`]) of a window's level deviations `dev` against
/// the span's reference sums `reference` (any common scale): the drift of the weighted centre
/// since the reference in reference contact radii (`√` of the trace of the second moments; x,
/// y), the rotation of the principal axis `Im(z·z̄_r) / (tr·tr_r)` with `z = Cxx − Cyy + 2i·Cxy`
/// (the sine of twice the turn times both anisotropies: in −1..=1, zero for a round
/// pattern; size and overall level cancel), and the rotation's share of the motion
/// `|rot| / (|rot| + |drift| + 0.01)` ([`MOTION_FLOOR`]: near zero when neither moved).
fn motion(positions: &[[f64; 2]], dev: &[f64], reference: &[f64]) -> [f64; MOTION_INPUTS] {
    let n = reference.len() as f64;
    let rt: f64 = reference.iter().sum();
    let rdev: Vec<f64> = reference.iter().map(|r| n * r - rt).collect();
    let (Some((c, tr, z)), Some((cr, trr, zr))) = (moments(positions, dev), moments(positions, &rdev)) else {
        return [0.0; MOTION_INPUTS];
    };
    if !(tr > 0.0 && trr > 0.0) {
        return [0.0; MOTION_INPUTS];
    }
    let radius = trr.sqrt();
    let drift = [(c[0] - cr[0]) / radius, (c[1] - cr[1]) / radius];
    let rot = (z[1] * zr[0] - z[0] * zr[1]) / (tr * trr);
    let share = rot.abs() / (rot.abs() + drift[0].hypot(drift[1]) + MOTION_FLOOR);
    [drift[0], drift[1], rot, share]
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

    /// The hidden units' sums over the first `prefix.len()` inputs of a window's
    /// representation, for [`log_posterior_from_prefix`](Self::log_posterior_from_prefix): a
    /// replay that changes only the last inputs (the motion inputs, against a new reference)
    /// keeps them.
    pub fn prefix_sums(&self, prefix: &[f64]) -> Result<Vec<f64>> {
        self.dense().prefix_sums(prefix)
    }

    /// The log posterior of the representation `prefix ++ tail` from the
    /// [`prefix_sums`](Self::prefix_sums) of `prefix`: bit-identical to
    /// [`log_posterior`](Self::log_posterior) of the whole representation.
    pub fn log_posterior_from_prefix(&self, sums: &[f64], tail: &[f64]) -> Result<Vec<f64>> {
        Ok(log_softmax(&self.dense().logits_from_prefix(sums, tail)?))
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
        WindowExtractor::try_new_on(&self.config, layout)
    }

    /// A streaming per-span answer of this model on `layout` ([`WindowVote`]).
    pub fn vote(&self, layout: &Layout) -> Result<WindowVote<'_>> {
        Ok(WindowVote { net: self, state: WindowVoteState::try_new(self, layout)? })
    }
}

/// `l − ln Σ exp l` per logit.
pub(super) fn log_softmax(logits: &[f64]) -> Vec<f64> {
    let top = logits.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let lse = top + logits.iter().map(|l| (l - top).exp()).sum::<f64>().ln();
    logits.iter().map(|l| l - lse).collect()
}

/// The decision of a posterior (argmax, ties: the first in model order).
pub(super) fn decision(classes: &[DosClass], posterior: Vec<f64>) -> Decision {
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
        self.state.windows()
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

/// A causal per-span vote of a window model ([`WindowVote`], [`TreeVote`]): what scoring and
/// calibration need, whichever model votes.
pub trait SpanVote {
    /// Push one raw frame; when it completes a window, that window's decision (alone).
    fn push_frame(&mut self, values: &[f64]) -> Result<Option<Decision>>;
    /// The vote's decision so far (`None` before the first window).
    fn vote_decision(&self) -> Option<Decision>;
    /// The mean log posterior per window so far (model class order; `None` before the first
    /// window).
    fn vote_mean_log_posterior(&self) -> Option<Vec<f64>>;
    /// Start a new span.
    fn restart(&mut self);
}

impl SpanVote for WindowVote<'_> {
    fn push_frame(&mut self, values: &[f64]) -> Result<Option<Decision>> {
        self.push(values)
    }
    fn vote_decision(&self) -> Option<Decision> {
        self.decision()
    }
    fn vote_mean_log_posterior(&self) -> Option<Vec<f64>> {
        self.mean_log_posterior()
    }
    fn restart(&mut self) {
        self.reset();
    }
}

/// The state of a [`WindowVote`] without the borrow of its net, for an owner of the net (the
/// `dos` stage keeps both): every call takes the net the state was made for.
#[derive(Clone, Debug)]
pub struct WindowVoteState {
    extractor: WindowExtractor,
    votes: LogVote,
}

/// The running sum of the windows' log posteriors of a vote ([`WindowVoteState`],
/// [`TreeVoteState`]), in the model's class order.
#[derive(Clone, Debug)]
pub(crate) struct LogVote {
    sum: Vec<f64>,
    windows: u64,
}

impl LogVote {
    /// An empty vote over `classes` classes.
    pub(crate) fn new(classes: usize) -> Self {
        LogVote { sum: vec![0.0; classes], windows: 0 }
    }

    /// Add one window's log posterior.
    pub(crate) fn add(&mut self, log_p: &[f64]) {
        for (s, l) in self.sum.iter_mut().zip(log_p) {
            *s += l;
        }
        self.windows += 1;
    }

    /// Windows added.
    pub(crate) fn windows(&self) -> u64 {
        self.windows
    }

    /// The normalised product of the windows' posteriors (`None` before the first window).
    pub(crate) fn decision(&self, classes: &[DosClass]) -> Option<Decision> {
        (self.windows > 0).then(|| decision(classes, softmax(&self.sum)))
    }

    /// The mean log posterior per window (`None` before the first window).
    pub(crate) fn mean_log_posterior(&self) -> Option<Vec<f64>> {
        (self.windows > 0).then(|| self.sum.iter().map(|s| s / self.windows as f64).collect())
    }

    /// Forget every window.
    pub(crate) fn reset(&mut self) {
        self.sum.iter_mut().for_each(|v| *v = 0.0);
        self.windows = 0;
    }
}

impl WindowVoteState {
    /// An empty vote of `net` on `layout` (which must have the net's taxel count).
    pub fn try_new(net: &DosWindowNet, layout: &Layout) -> Result<Self> {
        Ok(WindowVoteState { extractor: net.extractor(layout)?, votes: LogVote::new(net.classes.len()) })
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
        self.votes.add(log_p);
    }

    /// Completed windows in the vote.
    pub fn windows(&self) -> u64 {
        self.votes.windows()
    }

    /// [`WindowVote::decision`] with `net`.
    pub fn decision(&self, net: &DosWindowNet) -> Option<Decision> {
        self.votes.decision(&net.classes)
    }

    /// [`WindowVote::mean_log_posterior`].
    pub fn mean_log_posterior(&self) -> Option<Vec<f64>> {
        self.votes.mean_log_posterior()
    }

    /// A fresh extractor of this vote's windows (the same settings and layout).
    pub fn fresh_extractor(&self) -> WindowExtractor {
        let mut x = self.extractor.clone();
        x.reset();
        x
    }

    /// Start a new span (a new contact).
    pub fn reset(&mut self) {
        self.extractor.reset();
        self.votes.reset();
    }
}
