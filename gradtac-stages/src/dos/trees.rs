//! Gradient-boosted trees over a per-taxel time representation of the contact ([`DosTrees`]): a
//! window model of slip direction like [`DosWindowNet`], whose classifier is a softmax ensemble of
//! regression trees — a plain tree walk at inference, no dependency; the trainer
//! (`train_trees`, cargo feature `train`) is hand-written and never linked by a robot.
//!
//! # Representation ([`TreeExtractor`], causal)
//! Every non-overlapping window of [`TreeInputs::window`]`.frames` frames (5 = 50 ms) gives:
//! - the window model's inputs ([`WindowExtractor::input`] of [`TreeInputs::window`]: the level
//!   pattern across taxels, the pattern since the contact's first 0.1 s, the change across the
//!   window, the motion inputs — as configured);
//! - for every lag `L` of [`TreeInputs::lags`] (in windows): each taxel's level pattern now minus
//!   its level pattern `L` windows earlier (the span's first window while the span is younger),
//!   `n` values per lag: how the shear pattern moved over 0.3 s, 1 s, …;
//! - with [`TreeInputs::slope_windows`] `k > 0`: the mean of the change across the window over
//!   the last `k` windows (fewer while younger), `n` values: a windowed slope per taxel.
//! - with [`TreeInputs::turn`] (the default of the trainer since stop 35's round 4), the
//!   **rotation-sense inputs**, [`TURN_INPUTS`] per lag and per slope: the rigid motion of the
//!   level pattern `z` about the contact's centre `c` (its loaded taxels' weighted centre, as the
//!   motion inputs') that best explains a change `Δ` to first order,
//!   `Δ_i ≈ −v·∇z_i − θ·((x_i − c_x) ∂_y z_i − (y_i − c_y) ∂_x z_i)`, fitted by least squares
//!   over the taxels (ridge 1e-3 of the normal equations' mean diagonal): `(vx, vy, θ)`. For a
//!   lag `Δ` is the lag's change and `z` the mean of the two patterns; for the slope `Δ` is the
//!   mean change across the window and `z` the current pattern. Each taxel's gradient `∇z_i` is a
//!   Gaussian-weighted least-squares fit over its layout neighbours (width the mean
//!   nearest-neighbour distance, neighbours within three widths; fixed, not tuned). `θ > 0`
//!   turns `+x` toward `+y`; mirror signs [`TURN_MIRROR_SIGNS`]. The translation-only inputs
//!   above carry no sense of rotation that does not depend on where the object presses; this
//!   one is a rotation of the change field itself about the contact. Cost per window: one
//!   gradient per taxel (≈ 10 neighbours) and a 3 × 3 solve per source.
//! - with [`TreeInputs::energy`] (the default of the trainer since stop 35's round 5), the
//!   **change-energy inputs**, appended last: the root mean square over the taxels of each lag's
//!   change, of the slope, and of the pattern since the contact's first 0.1 s (with window
//!   inputs `both` or `since_start`) — how much the *whole* pattern changed, which a tree of
//!   depth ≤ 3 over per-taxel inputs cannot sum. Aimed at a stable touch read as a slip (the
//!   largest group of round 4's inner errors). Cost per window: `n` multiply-adds per block.
//! - with [`TreeInputs::dilation`] (the default of the trainer since stop 36's round 6, T15): the
//!   flow above is fitted with a fourth unknown, an isotropic dilation `δ` about the contact's
//!   centre (`Δ_i ≈ … − δ·((x_i − c_x) ∂_x z_i + (y_i − c_y) ∂_y z_i)`), and `δ` per lag and slope
//!   is appended last (mirror sign +1). A spreading pattern (a press, creep on a soft object)
//!   otherwise leaks into `(vx, vy, θ)`. Over lag 20 the fitted `θ` is negative for `cw` and
//!   positive for `aw` on 33 of the 48 inner rotations without the dilation (T13) and on 35/48
//!   with it (stop 36's round 7, corrected diagnosis; round 6 had read 24/48 for T13 from wrong
//!   columns). Cost: a 4 × 4
//!   solve instead of 3 × 3 per source.
//!
//! Units: the level pattern's (deviation across taxels over their spread: dimensionless), so
//! exactly as invariant as the window model's inputs (one gain and offset common to all taxels).
//!
//! # Decision
//! `logits_c = base_c + Σ_t value_t(x)` over the trees of class `c` (tree `t` belongs to class
//! `t mod classes`), each tree walked from its root: at node `i`, `x[feature_i] ≤ threshold_i`
//! goes to `left_i`, anything else (larger, or NaN) to `right_i`; `left_i = 0` marks a leaf.
//! With [`DosTrees::mirror`] (a taxel permutation, the layout's reflection) the logits are the
//! mean of the input's and of its mirror image's, classes mirrored ([`DosClass::mirrored`]): a
//! mirrored recording gets exactly the mirrored posterior. Per recording (or since contact on a
//! stream) [`TreeVote`] sums the windows' log posteriors, as [`WindowVote`] does.
//!
//! # Validation (on load, [`DosTrees::validate`])
//! Every tree's arrays have one length (1..=[`MAX_TREE_NODES`]); a child index is larger than its
//! parent's and inside the tree (so every walk ends within the tree's length), and no node has
//! two parents; a feature index is
//! below the representation's input count; thresholds, leaf values and the base are finite; the
//! depth is at most [`MAX_TREE_DEPTH`]; the tree count is a multiple of the classes and at most
//! [`MAX_TREES`]; a mirror is an involution of the taxels with every class's mirror present.
//!
//! # Cost
//! Per frame: the window extractor's copy of the frame; per window: its inputs, `n` subtractions
//! per lag, the slope's running sum, and one root-to-leaf walk per tree (≤ depth comparisons),
//! twice with the mirror. With 80 rounds × 7 classes of depth 4 (stop 33's T1): ≈ 2 240
//! comparisons per window (4 480 mirrored); with the default since stop 34's round 2 (T4,
//! and stop 35's T9 and T12 with the same shape: 60 rounds, depth 3) ≈ 1 260 (2 520). The walk runs on a compact copy made at load: 16 bytes a node (threshold,
//! input, left child; the right child is the next node, a leaf's value in the threshold's place),
//! laid out breadth first per tree, 4 trees walked side by side, the child chosen without a
//! branch — bit-identical to the plain walk of the arrays (tested). Against stop 33's 32-byte
//! nodes with a branch this halved the `dos` stage's p99 per frame in the sliding mode (19.5–20.0
//! → 9.7 µs, back to back, `examples/dos_sliding_cost`, load ≈ 7 on 2 cores). A file whose
//! "tree" gives a node two parents is refused (the compact copy of such a graph could be far
//! larger than the file).

use super::net::softmax;
use super::window::{decision, log_softmax, LogVote};
use super::*;
use std::collections::VecDeque;

/// Deepest tree [`DosTrees`] accepts.
pub const MAX_TREE_DEPTH: usize = 16;
/// Most nodes of one tree.
pub const MAX_TREE_NODES: usize = 1 << 17;
/// Most trees of one model.
pub const MAX_TREES: usize = 100_000;
/// Largest lag (and slope length), in windows.
pub const MAX_TREE_LAG: usize = 1000;

/// The tree model's representation (see the [`dos` module docs](crate::dos) and the `trees` source file).
///
/// Read from a file with every field optional (the default when absent); besides these fields, a file may carry
/// `"flow_share": false` (configs and candidates files written in stop 36 spell it out); `true`
/// is refused with an error naming the commit that still has the removed flow-share inputs
/// ([`FLOW_SHARE_COMMIT`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawTreeInputs")]
pub struct TreeInputs {
    /// The window representation (its `hidden` is not used).
    pub window: WindowNetConfig,
    /// Lags in windows of the level pattern's change (each 1..=[`MAX_TREE_LAG`]; needs the
    /// level pattern: window inputs `levels` or `both`).
    pub lags: Vec<usize>,
    /// Windows of the mean change across the window (0: none; ≤ [`MAX_TREE_LAG`]).
    pub slope_windows: usize,
    /// Add the **rotation-sense inputs** ([`TURN_INPUTS`] per lag and per slope, see the `trees`
    /// source file's module docs): the rigid motion `(vx, vy, θ)` of the level pattern about the
    /// contact's centre that best explains each lag's change of the pattern (and the slope's),
    /// fitted by least squares over the taxels with the pattern's spatial gradient on the
    /// layout. Needs the layout's taxel positions. Default off (not written when off, so older
    /// model files read unchanged).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub turn: bool,
    /// Add the **change-energy inputs** (stop 35's round 5, touch against slip): one per lag and
    /// per slope, the root mean square over the taxels of that source's per-taxel change, and,
    /// with a since-start block (window inputs `both` or `since_start`), the root mean square of
    /// the pattern since the contact's first 0.1 s ([`energy_inputs`](Self::energy_inputs)
    /// values, appended last, mirror sign +1). A depth-3 tree sees at most three taxels of a
    /// change; "the whole pattern hardly moved" (a touch) is a sum over all taxels, which one
    /// input gives directly. Same units as the changes (dimensionless). Default off (not
    /// written when off, so older model files read unchanged).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub energy: bool,
    /// Fit the rigid flow of the rotation-sense inputs **jointly with an isotropic dilation**
    /// about the contact's centre and add the dilation rate as one more input per lag and slope
    /// (stop 36's round 6 candidate T15): a press or creep on a soft object spreads the pattern
    /// (dilation), a slip moves it (translation, turn); without the term, a spreading pattern
    /// leaks into the fitted `(vx, vy, θ)`. Changes the rotation-sense inputs' values. Needs
    /// [`turn`](Self::turn). Appended last, mirror sign +1. Default off (not written when off).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub dilation: bool,
}

/// The commit that still has the **flow-share inputs** (`TreeInputs::flow_share`, stop 36's
/// round-6 candidate T14, not adopted): they were removed in stop 37, and a file that asks for
/// them is refused with this commit in the message, where round 6's figures can be re-run.
pub const FLOW_SHARE_COMMIT: &str = "e43beac";

/// [`TreeInputs`] as a file spells it: every field of it (each with its default when absent) and
/// the removed `flow_share` switch, read only to refuse `true`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, default)]
struct RawTreeInputs {
    window: WindowNetConfig,
    lags: Vec<usize>,
    slope_windows: usize,
    turn: bool,
    energy: bool,
    flow_share: bool,
    dilation: bool,
}

impl Default for RawTreeInputs {
    fn default() -> Self {
        let TreeInputs { window, lags, slope_windows, turn, energy, dilation } = TreeInputs::default();
        RawTreeInputs { window, lags, slope_windows, turn, energy, flow_share: false, dilation }
    }
}

impl TryFrom<RawTreeInputs> for TreeInputs {
    type Error = Error;
    fn try_from(r: RawTreeInputs) -> Result<Self> {
        if r.flow_share {
            return Err(invalid(format!(
                "the flow-share inputs (\"flow_share\": true, stop 36's round-6 candidates T14 and T16) were \
                 removed in stop 37 (only false is read); commit {FLOW_SHARE_COMMIT} still has them"
            )));
        }
        let RawTreeInputs { window, lags, slope_windows, turn, energy, flow_share: _, dilation } = r;
        Ok(TreeInputs { window, lags, slope_windows, turn, energy, dilation })
    }
}

/// Rotation-sense inputs per source (a lag or the slope): the pattern's fitted velocity `vx`,
/// `vy` (mm per change) and turn `θ` (radians per change) ([`TreeInputs::turn`]).
pub const TURN_INPUTS: usize = 3;

/// The sign each rotation-sense input takes under the layout's reflection across `y = 0`
/// (`vx`, `vy`, `θ`).
pub const TURN_MIRROR_SIGNS: [f64; TURN_INPUTS] = [1.0, -1.0, -1.0];

impl Default for TreeInputs {
    /// The rich representation: window inputs `both` with motion, lags 6 and 20 windows (0.3 s,
    /// 1 s), slope over 6 windows.
    fn default() -> Self {
        TreeInputs {
            window: WindowNetConfig { inputs: WindowInputs::Both, motion: true, ..WindowNetConfig::default() },
            lags: vec![6, 20],
            slope_windows: 6,
            turn: false,
            energy: false,
            dilation: false,
        }
    }
}

impl TreeInputs {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        self.window.validate()?;
        if self.lags.len() > 16 || self.lags.iter().any(|l| !(1..=MAX_TREE_LAG).contains(l)) {
            return Err(invalid(format!("tree lags {:?}: at most 16, each in 1..={MAX_TREE_LAG}", self.lags)));
        }
        if !self.lags.is_empty() && self.window.inputs == WindowInputs::SinceStart {
            return Err(invalid("tree lags need the level pattern (window inputs levels or both)"));
        }
        if self.turn && (self.sources() == 0 || self.window.inputs == WindowInputs::SinceStart) {
            return Err(invalid(
                "the rotation-sense inputs (turn) need a lag or a slope and the level pattern (window inputs levels or both)",
            ));
        }
        if self.energy && self.energy_inputs() == 0 {
            return Err(invalid("the change-energy inputs (energy) need a lag, a slope or a since-start block"));
        }
        if self.dilation && !self.turn {
            return Err(invalid("the dilation inputs (dilation) need the rotation-sense inputs (turn)"));
        }
        if self.slope_windows > MAX_TREE_LAG {
            return Err(invalid(format!("slope windows {} must be ≤ {MAX_TREE_LAG}", self.slope_windows)));
        }
        Ok(())
    }

    /// Number of per-taxel change sources: the lags and the slope.
    pub fn sources(&self) -> usize {
        self.lags.len() + usize::from(self.slope_windows > 0)
    }

    /// Whether the window inputs carry the pattern since the contact's start.
    fn since_start(&self) -> bool {
        self.window.inputs != WindowInputs::Levels
    }

    /// Number of change-energy inputs ([`energy`](Self::energy)): one per lag and slope, one for
    /// the since-start block; 0 when off.
    pub fn energy_inputs(&self) -> usize {
        if self.energy {
            self.sources() + usize::from(self.since_start())
        } else {
            0
        }
    }

    /// Number of dilation inputs ([`dilation`](Self::dilation)): one per lag and slope.
    pub fn dilation_inputs(&self) -> usize {
        if self.dilation {
            self.sources()
        } else {
            0
        }
    }

    /// Number of inputs for `taxels` taxels.
    pub fn inputs(&self, taxels: usize) -> usize {
        self.window.inputs(taxels)
            + self.sources() * taxels
            + if self.turn { self.sources() * TURN_INPUTS } else { 0 }
            + self.energy_inputs()
            + self.dilation_inputs()
    }

    /// Where the rotation-sense inputs start for `taxels` taxels ([`TURN_INPUTS`] per lag, then
    /// the slope's; `(vx, vy, θ)` each), `None` without [`turn`](Self::turn). The input order is:
    /// the window inputs, the per-taxel lag and slope blocks, the rotation-sense inputs, the
    /// change-energy and dilation inputs — so the turn block is the last one only when neither
    /// of those two is on (a reader that assumed so read the wrong columns).
    pub fn turn_at(&self, taxels: usize) -> Option<usize> {
        self.turn.then(|| self.window.inputs(taxels) + self.sources() * taxels)
    }

    /// Where the change-energy inputs start for `taxels` taxels ([`energy_inputs`](Self::energy_inputs)
    /// of them, after the rotation-sense inputs), `None` without [`energy`](Self::energy).
    pub fn energy_at(&self, taxels: usize) -> Option<usize> {
        self.energy.then(|| {
            self.window.inputs(taxels)
                + self.sources() * taxels
                + if self.turn { self.sources() * TURN_INPUTS } else { 0 }
        })
    }

    /// The mirror image of an input vector under the taxel permutation `perm` (an involution):
    /// `out[j] = sign_j · x[source_j]` for the `(source_j, sign_j)` this returns.
    pub fn mirror_map(&self, perm: &[usize]) -> Vec<(usize, f64)> {
        let n = perm.len();
        let mut out = Vec::with_capacity(self.inputs(n));
        let per_taxel = |out: &mut Vec<(usize, f64)>, at: usize| out.extend(perm.iter().map(|&p| (at + p, 1.0)));
        let blocks = self.window.taxel_blocks();
        for b in 0..blocks {
            per_taxel(&mut out, b * n);
        }
        let mut at = blocks * n;
        if self.window.motion {
            out.extend(MOTION_MIRROR_SIGNS.iter().enumerate().map(|(k, &s)| (at + k, s)));
            at += MOTION_INPUTS;
        }
        for _ in 0..self.sources() {
            per_taxel(&mut out, at);
            at += n;
        }
        if self.turn {
            for _ in 0..self.sources() {
                out.extend(TURN_MIRROR_SIGNS.iter().enumerate().map(|(k, &s)| (at + k, s)));
                at += TURN_INPUTS;
            }
        }
        let scalars = self.energy_inputs() + self.dilation_inputs();
        out.extend((0..scalars).map(|k| (at + k, 1.0)));
        out
    }
}

/// The streaming representation of [`DosTrees`]: push raw frames; a completed window gives its
/// input vector. A plain state machine; [`reset`](Self::reset) starts a new span.
#[derive(Clone, Debug)]
pub struct TreeExtractor {
    window: WindowExtractor,
    lags: Vec<usize>,
    slope_windows: usize,
    taxels: usize,
    /// Where the change across the window starts in the window inputs.
    change_at: usize,
    /// Whether the level pattern is the first block.
    levels: bool,
    /// The last `max lag + 1` windows' level patterns (front: oldest kept; the span's first while
    /// younger).
    history: VecDeque<Vec<f64>>,
    /// The last `slope_windows` windows' change across the window.
    changes: VecDeque<Vec<f64>>,
    /// The rotation-sense inputs' geometry ([`TreeInputs::turn`]; `None` when off).
    turn: Option<TurnGeometry>,
    /// Where the since-start block starts in the window inputs, with the change-energy inputs
    /// ([`TreeInputs::energy`]).
    energy_since: Option<usize>,
    /// Whether the change-energy inputs are on.
    energy: bool,
    /// Whether the flow is fitted with a dilation ([`TreeInputs::dilation`]).
    dilation: bool,
}

impl TreeExtractor {
    /// An extractor of `inputs` for `layout`'s taxels.
    pub fn try_new_on(inputs: &TreeInputs, layout: &Layout) -> Result<Self> {
        inputs.validate()?;
        let window = WindowExtractor::try_new_on(&inputs.window, layout)?;
        let n = layout.len();
        let turn = if inputs.turn { Some(TurnGeometry::try_new(layout)?) } else { None };
        Ok(TreeExtractor {
            window,
            lags: inputs.lags.clone(),
            slope_windows: inputs.slope_windows,
            taxels: n,
            change_at: (inputs.window.taxel_blocks() - 1) * n,
            levels: inputs.window.inputs != WindowInputs::SinceStart,
            history: VecDeque::new(),
            changes: VecDeque::new(),
            turn,
            energy_since: (inputs.energy && inputs.since_start())
                .then_some(if inputs.window.inputs == WindowInputs::Both { n } else { 0 }),
            energy: inputs.energy,
            dilation: inputs.dilation,
        })
    }

    /// Push one frame (one finite value per taxel); when it completes a window, that window's
    /// input vector.
    pub fn push(&mut self, values: &[f64]) -> Result<Option<Vec<f64>>> {
        if !self.window.push(values)? {
            return Ok(None);
        }
        let Some(mut x) = self.window.input() else { return Ok(None) };
        let n = self.taxels;
        if !self.lags.is_empty() && self.levels {
            let keep = self.lags.iter().copied().max().unwrap_or(0) + 1;
            if self.history.len() == keep {
                self.history.pop_front();
            }
            self.history.push_back(x[..n].to_vec());
        }
        let change: Vec<f64> = x[self.change_at..self.change_at + n].to_vec();
        let mut extra = Vec::with_capacity((self.lags.len() + 1) * (n + TURN_INPUTS));
        let mut turns = Vec::new();
        let mut dilations = Vec::new();
        for &lag in &self.lags {
            let len = self.history.len();
            let then = &self.history[if len > lag { len - 1 - lag } else { 0 }];
            extra.extend(x[..n].iter().zip(then).map(|(a, b)| a - b));
            if let Some(g) = &self.turn {
                // the change from then to now, against the gradient of the pattern halfway
                let mid: Vec<f64> = x[..n].iter().zip(then).map(|(a, b)| 0.5 * (a + b)).collect();
                let (flow, dil) = g.flow_inputs(&mid, &extra[extra.len() - n..], self.dilation);
                turns.extend(flow);
                dilations.push(dil);
            }
        }
        if self.slope_windows > 0 {
            if self.changes.len() == self.slope_windows {
                self.changes.pop_front();
            }
            self.changes.push_back(change);
            // summed afresh from the kept windows (in order): no drift of a running sum
            let k = self.changes.len() as f64;
            let mut mean = vec![0.0; n];
            for c in &self.changes {
                mean.iter_mut().zip(c).for_each(|(m, v)| *m += v);
            }
            mean.iter_mut().for_each(|m| *m /= k);
            if let Some(g) = &self.turn {
                // validated: the turn needs the level pattern, the first block
                let (flow, dil) = g.flow_inputs(&x[..n], &mean, self.dilation);
                turns.extend(flow);
                dilations.push(dil);
            }
            extra.extend(mean);
        }
        let rms = |v: &[f64]| (v.iter().map(|a| a * a).sum::<f64>() / n as f64).sqrt();
        let energies: Vec<f64> = if self.energy {
            let mut e: Vec<f64> = extra.chunks(n).map(rms).collect();
            if let Some(at) = self.energy_since {
                e.push(rms(&x[at..at + n]));
            }
            e
        } else {
            Vec::new()
        };
        x.extend(extra);
        x.extend(turns);
        x.extend(energies);
        if self.dilation {
            x.extend(dilations);
        }
        Ok(Some(x))
    }

    /// Start a new span.
    pub fn reset(&mut self) {
        self.window.reset();
        self.history.clear();
        self.changes.clear();
    }
}

/// Ridge of the rigid-flow fit, as a share of the mean diagonal of its normal equations (fixed,
/// not tuned): keeps the fit finite for a pattern without gradient along some motion.
const TURN_RIDGE: f64 = 1e-3;

/// The layout's geometry for the rotation-sense inputs ([`TreeInputs::turn`]): positions
/// (symmetric about `y = 0` as the motion inputs', so the mirror image's inputs are the
/// mirrored inputs) and each taxel's least-squares gradient weights over its neighbours.
#[derive(Clone, Debug)]
pub(super) struct TurnGeometry {
    positions: Vec<[f64; 2]>,
    /// Per taxel `i`: `(j, c_ij)` with `∇z_i = Σ_j c_ij (z_j − z_i)`.
    gradient: Vec<Vec<(usize, [f64; 2])>>,
}

impl TurnGeometry {
    /// The geometry of `layout`: Gaussian-weighted least-squares gradients with the width the
    /// mean nearest-neighbour distance `h` between taxels, neighbours within `3h` (fixed).
    pub(super) fn try_new(layout: &Layout) -> Result<Self> {
        let positions = super::window::symmetrised(layout.positions());
        let n = positions.len();
        if n < 3 || positions.iter().flatten().any(|v| !v.is_finite()) {
            return Err(invalid("the rotation-sense inputs need at least 3 finite taxel positions"));
        }
        let dist = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
        let h = (0..n)
            .map(|i| (0..n).filter(|&j| j != i).map(|j| dist(positions[i], positions[j])).fold(f64::INFINITY, f64::min))
            .sum::<f64>()
            / n as f64;
        if !(h > 0.0 && h.is_finite()) {
            return Err(invalid("the rotation-sense inputs need distinct taxel positions"));
        }
        let gradient = (0..n)
            .map(|i| {
                let near: Vec<(usize, [f64; 2], f64)> = (0..n)
                    .filter(|&j| j != i && dist(positions[i], positions[j]) <= 3.0 * h)
                    .map(|j| {
                        let d = [positions[j][0] - positions[i][0], positions[j][1] - positions[i][1]];
                        (j, d, (-(d[0] * d[0] + d[1] * d[1]) / (2.0 * h * h)).exp())
                    })
                    .collect();
                let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
                for (_, d, w) in &near {
                    a += w * d[0] * d[0];
                    b += w * d[0] * d[1];
                    c += w * d[1] * d[1];
                }
                let det = a * c - b * b;
                if det.is_nan() || det <= 1e-9 * (a * c).max(f64::MIN_POSITIVE) {
                    return Vec::new();
                }
                near.iter()
                    .map(|&(j, d, w)| (j, [w * (c * d[0] - b * d[1]) / det, w * (a * d[1] - b * d[0]) / det]))
                    .collect()
            })
            .collect();
        Ok(TurnGeometry { positions, gradient })
    }

    /// The flow inputs of one source: the rigid motion `(vx, vy, θ)` about the centre of
    /// `pattern` (its loaded taxels' weighted centre, as the motion inputs') that best explains
    /// the change `change` to first order, `change_i ≈ −v·∇z_i − θ·∂_φ z_i` with
    /// `∂_φ z_i = (x_i − c_x) ∂_y z_i − (y_i − c_y) ∂_x z_i`: least squares over the taxels with a
    /// small ridge ([`TURN_RIDGE`]). `θ > 0` turns `+x` toward `+y` (the `cw` class's sense).
    /// With `dilation` ([`TreeInputs::dilation`]) the same least squares has a fourth unknown, an
    /// isotropic dilation `δ` about the centre (`… − δ·((x_i − c_x) ∂_x z_i + (y_i − c_y) ∂_y
    /// z_i)`; > 0: the pattern spreads), fitted jointly. Returns `(vx, vy, θ)` and `δ` (0
    /// without `dilation`). Zeros for a flat pattern.
    pub(super) fn flow_inputs(&self, pattern: &[f64], change: &[f64], dilation: bool) -> ([f64; TURN_INPUTS], f64) {
        if dilation {
            let f = self.flow_fit::<4>(pattern, change);
            ([f[0], f[1], f[2]], f[3])
        } else {
            (self.flow_fit::<3>(pattern, change), 0.0)
        }
    }

    /// The least-squares flow with `N` = 3 (translation, turn) or 4 (and dilation) unknowns.
    fn flow_fit<const N: usize>(&self, pattern: &[f64], change: &[f64]) -> [f64; N] {
        let Some((c, _, _)) = super::window::moments(&self.positions, pattern) else {
            return [0.0; N];
        };
        let mut ata = [[0.0; N]; N];
        let mut atb = [0.0; N];
        for (i, coefs) in self.gradient.iter().enumerate() {
            let mut g = [0.0; 2];
            for &(j, w) in coefs {
                let dz = pattern[j] - pattern[i];
                g[0] += w[0] * dz;
                g[1] += w[1] * dz;
            }
            let (x, y) = (self.positions[i][0] - c[0], self.positions[i][1] - c[1]);
            let full = [-g[0], -g[1], -(x * g[1] - y * g[0]), -(x * g[0] + y * g[1])];
            let mut a = [0.0; N];
            a.copy_from_slice(&full[..N]);
            for r in 0..N {
                atb[r] += a[r] * change[i];
                for k in 0..N {
                    ata[r][k] += a[r] * a[k];
                }
            }
        }
        let ridge = TURN_RIDGE * (0..N).map(|r| ata[r][r]).sum::<f64>() / N as f64;
        if !(ridge > 0.0 && ridge.is_finite()) {
            return [0.0; N];
        }
        (0..N).for_each(|r| ata[r][r] += ridge);
        let tidy = |v: f64| {
            if v.is_finite() {
                v.clamp(-super::window::MAX_CHANGE, super::window::MAX_CHANGE)
            } else {
                0.0
            }
        };
        solve(ata, atb).map(tidy)
    }
}

/// The solution of a symmetric positive definite `N × N` system (Cholesky; zeros if it fails).
fn solve<const N: usize>(a: [[f64; N]; N], b: [f64; N]) -> [f64; N] {
    let mut l = [[0.0; N]; N];
    for i in 0..N {
        for j in 0..=i {
            let s = a[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>();
            if i == j {
                if s.is_nan() || s <= 0.0 {
                    return [0.0; N];
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    let mut y = [0.0; N];
    for i in 0..N {
        y[i] = (b[i] - (0..i).map(|k| l[i][k] * y[k]).sum::<f64>()) / l[i][i];
    }
    let mut x = [0.0; N];
    for i in (0..N).rev() {
        x[i] = (y[i] - (i + 1..N).map(|k| l[k][i] * x[k]).sum::<f64>()) / l[i][i];
    }
    x
}

/// One regression tree as arrays (see the [`dos` module docs](crate::dos) and the `trees` source file): node `i` is a leaf when
/// `left[i] == 0`, else it sends `x[feature[i]] ≤ threshold[i]` to `left[i]`, the rest to
/// `right[i]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tree {
    /// Input index per node (unused at leaves).
    pub feature: Vec<usize>,
    /// Threshold per node (unused at leaves).
    pub threshold: Vec<f64>,
    /// Left child per node (0 at a leaf).
    pub left: Vec<usize>,
    /// Right child per node.
    pub right: Vec<usize>,
    /// Leaf value per node (unused at internal nodes).
    pub value: Vec<f64>,
}

impl Tree {
    /// Checks shape, indices, depth and values against `inputs` inputs.
    pub fn validate(&self, inputs: usize) -> Result<()> {
        let len = self.left.len();
        if !(1..=MAX_TREE_NODES).contains(&len)
            || [self.feature.len(), self.threshold.len(), self.right.len(), self.value.len()].iter().any(|&l| l != len)
        {
            return Err(invalid(format!("a tree's arrays must share one length in 1..={MAX_TREE_NODES}")));
        }
        let mut depth = vec![0usize; len];
        let mut has_parent = vec![false; len];
        for i in 0..len {
            if !self.value[i].is_finite() {
                return Err(invalid(format!("tree node {i}: leaf value {} is not finite", self.value[i])));
            }
            if self.left[i] == 0 {
                continue;
            }
            let (l, r) = (self.left[i], self.right[i]);
            if l <= i || r <= i || l >= len || r >= len {
                return Err(invalid(format!("tree node {i}: children {l}, {r} must be after it and below {len}")));
            }
            if l == r || has_parent[l] || has_parent[r] {
                return Err(invalid(format!("tree node {i}: a child {l} or {r} with two parents (not a tree)")));
            }
            has_parent[l] = true;
            has_parent[r] = true;
            if self.feature[i] >= inputs {
                return Err(invalid(format!("tree node {i}: input {} of {inputs}", self.feature[i])));
            }
            if !self.threshold[i].is_finite() {
                return Err(invalid(format!("tree node {i}: threshold {} is not finite", self.threshold[i])));
            }
            let d = depth[i] + 1;
            if d > MAX_TREE_DEPTH {
                return Err(invalid(format!("tree deeper than {MAX_TREE_DEPTH}")));
            }
            depth[l] = depth[l].max(d);
            depth[r] = depth[r].max(d);
        }
        Ok(())
    }

    /// The leaf value for `x` (validated tree; `x` at least as long as the inputs).
    pub fn eval(&self, x: &[f64]) -> f64 {
        let mut i = 0;
        // children are after their parent, so this ends within the tree's length
        while self.left[i] != 0 {
            i = if x[self.feature[i]] <= self.threshold[i] { self.left[i] } else { self.right[i] };
        }
        self.value[i]
    }
}

/// The tree model of slip direction (see the [`dos` module docs](crate::dos) and the `trees` source file). Serialises to JSON (serde),
/// validated when read or built ([`try_new`](Self::try_new)); read-only after that (the walk
/// uses a compact copy of the trees made then).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, try_from = "RawDosTrees")]
pub struct DosTrees {
    /// Representation.
    pub(super) inputs: TreeInputs,
    /// Taxels of the sensor the model was trained for.
    pub(super) taxels: usize,
    /// The classes, in output order.
    pub(super) classes: Vec<DosClass>,
    /// Initial logit per class.
    pub(super) base: Vec<f64>,
    /// The trees, class `t mod classes` for tree `t`.
    pub(super) trees: Vec<Tree>,
    /// The layout's mirror permutation of the taxels: average with the mirror image (`None`:
    /// no averaging).
    pub(super) mirror: Option<Vec<usize>>,
    /// Labelled recordings it was trained on (information only).
    pub(super) recordings: usize,
    /// The walk's compact form, made by `try_new`.
    #[serde(skip)]
    compiled: Compiled,
}

/// One node of the compact form (16 bytes): an internal node's threshold, input and left child
/// (an absolute index; the right child is the next node), or a leaf (`left` 0; no root is a
/// child) whose value is in `threshold`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Node {
    threshold: f64,
    feature: u32,
    left: u32,
}

impl Node {
    /// The child `x` goes to (NaN goes right: the negated `≤` is meant).
    #[inline(always)]
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    fn child(&self, x: &[f64]) -> u32 {
        self.left + u32::from(!(x[self.feature as usize] <= self.threshold))
    }
}

/// The compact form of a validated model: every tree's nodes in one array, its roots, the input
/// mirror map and each class's mirror's index.
#[derive(Clone, Debug, Default, PartialEq)]
struct Compiled {
    nodes: Vec<Node>,
    roots: Vec<u32>,
    mirror_map: Vec<(u32, f64)>,
    mirror_class: Vec<usize>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDosTrees {
    inputs: TreeInputs,
    taxels: usize,
    classes: Vec<DosClass>,
    base: Vec<f64>,
    trees: Vec<Tree>,
    mirror: Option<Vec<usize>>,
    #[serde(default)]
    recordings: usize,
}

impl TryFrom<RawDosTrees> for DosTrees {
    type Error = Error;
    fn try_from(r: RawDosTrees) -> Result<Self> {
        DosTrees::try_new(r.inputs, r.taxels, r.classes, r.base, r.trees, r.mirror, r.recordings)
    }
}

impl DosTrees {
    /// A model of these parts (see the fields' docs), validated ([`validate`](Self::validate)).
    pub fn try_new(
        inputs: TreeInputs,
        taxels: usize,
        classes: Vec<DosClass>,
        base: Vec<f64>,
        trees: Vec<Tree>,
        mirror: Option<Vec<usize>>,
        recordings: usize,
    ) -> Result<Self> {
        let mut m =
            DosTrees { inputs, taxels, classes, base, trees, mirror, recordings, compiled: Compiled::default() };
        m.validate()?;
        let mut c = Compiled::default();
        let leaf = Node { threshold: 0.0, feature: 0, left: 0 };
        for t in &m.trees {
            // breadth first, each node's children side by side (validated: a tree, so every node
            // is placed once; unreachable nodes are left out)
            let root = c.nodes.len();
            c.roots.push(root as u32);
            c.nodes.push(leaf);
            let mut queue = VecDeque::from([(0usize, root)]);
            while let Some((i, at)) = queue.pop_front() {
                if t.left[i] == 0 {
                    c.nodes[at] = Node { threshold: t.value[i], feature: 0, left: 0 };
                    continue;
                }
                let l = c.nodes.len();
                c.nodes.extend([leaf, leaf]);
                queue.extend([(t.left[i], l), (t.right[i], l + 1)]);
                c.nodes[at] = Node { threshold: t.threshold[i], feature: t.feature[i] as u32, left: l as u32 };
            }
        }
        if let Some(p) = &m.mirror {
            c.mirror_map = m.inputs.mirror_map(p).into_iter().map(|(j, s)| (j as u32, s)).collect();
            c.mirror_class =
                m.classes.iter().map(|cl| m.classes.iter().position(|d| *d == cl.mirrored()).unwrap_or(0)).collect();
        }
        m.compiled = c;
        Ok(m)
    }

    /// Number of inputs.
    pub fn input_count(&self) -> usize {
        self.inputs.inputs(self.taxels)
    }

    /// The representation.
    pub fn inputs(&self) -> &TreeInputs {
        &self.inputs
    }

    /// Taxels of the sensor the model was trained for.
    pub fn taxels(&self) -> usize {
        self.taxels
    }

    /// The classes, in output order.
    pub fn classes(&self) -> &[DosClass] {
        &self.classes
    }

    /// Initial logit per class.
    pub fn base(&self) -> &[f64] {
        &self.base
    }

    /// The trees (class `t mod classes` for tree `t`).
    pub fn trees(&self) -> &[Tree] {
        &self.trees
    }

    /// The mirror permutation, when the model averages with the mirror image.
    pub fn mirror(&self) -> Option<&[usize]> {
        self.mirror.as_deref()
    }

    /// Labelled recordings it was trained on (information only).
    pub fn recordings(&self) -> usize {
        self.recordings
    }

    /// Number of tree nodes.
    pub fn nodes(&self) -> usize {
        self.trees.iter().map(|t| t.left.len()).sum()
    }

    /// Checks shapes, indices, depths and values (done on deserialisation).
    pub fn validate(&self) -> Result<()> {
        self.inputs.validate()?;
        if !(3..=MAX_NET_TAXELS).contains(&self.taxels) {
            return Err(invalid(format!("taxels {} must be in 3..={MAX_NET_TAXELS}", self.taxels)));
        }
        let k = self.classes.len();
        if k == 0 || (0..k).any(|i| self.classes[..i].contains(&self.classes[i])) {
            return Err(invalid("the tree model's classes must be distinct and not empty"));
        }
        if self.base.len() != k || self.base.iter().any(|b| !b.is_finite()) {
            return Err(invalid(format!("the tree model's base must be {k} finite values")));
        }
        if self.trees.len() % k != 0 || self.trees.len() > MAX_TREES {
            return Err(invalid(format!(
                "{} trees: a multiple of the {k} classes, at most {MAX_TREES}",
                self.trees.len()
            )));
        }
        let inputs = self.input_count();
        if inputs > u32::MAX as usize / 2 {
            return Err(invalid("too many inputs"));
        }
        let nodes = self.nodes();
        if nodes > u32::MAX as usize / 2 {
            return Err(invalid("too many tree nodes"));
        }
        for (t, tree) in self.trees.iter().enumerate() {
            tree.validate(inputs).map_err(|e| invalid(format!("tree {t}: {e}")))?;
        }
        if let Some(p) = &self.mirror {
            let n = self.taxels;
            if p.len() != n || (0..n).any(|i| p[i] >= n || p[p[i]] != i) {
                return Err(invalid(format!("the mirror must be an involution of the {n} taxels")));
            }
            if self.classes.iter().any(|c| !self.classes.contains(&c.mirrored())) {
                return Err(invalid("mirror averaging needs every class's mirror among the classes"));
            }
        }
        Ok(())
    }

    fn raw_logits(&self, x: &[f64]) -> Vec<f64> {
        const LANES: usize = 4;
        let k = self.classes.len();
        let nodes = &self.compiled.nodes;
        let roots = &self.compiled.roots;
        let mut out = self.base.clone();
        // LANES trees walked side by side (independent loads overlap); each class's values are
        // still added in tree order. Children are after their parent: every walk ends.
        let mut t = 0;
        while t + LANES <= roots.len() {
            let mut at = [0usize; LANES];
            for (a, r) in at.iter_mut().zip(&roots[t..t + LANES]) {
                *a = *r as usize;
            }
            loop {
                let mut moved = false;
                for a in at.iter_mut() {
                    let n = &nodes[*a];
                    if n.left != 0 {
                        *a = n.child(x) as usize;
                        moved = true;
                    }
                }
                if !moved {
                    break;
                }
            }
            for (j, a) in at.iter().enumerate() {
                out[(t + j) % k] += nodes[*a].threshold;
            }
            t += LANES;
        }
        for (t, &root) in roots.iter().enumerate().skip(t) {
            let mut n = &nodes[root as usize];
            while n.left != 0 {
                n = &nodes[n.child(x) as usize];
            }
            out[t % k] += n.threshold;
        }
        out
    }

    /// The logits of one window's input vector ([`TreeExtractor::push`]).
    pub fn logits(&self, x: &[f64]) -> Result<Vec<f64>> {
        if x.len() != self.input_count() {
            return Err(invalid(format!("{} inputs for a tree model of {}", x.len(), self.input_count())));
        }
        let own = self.raw_logits(x);
        if self.mirror.is_none() {
            return Ok(own);
        }
        let m: Vec<f64> = self.compiled.mirror_map.iter().map(|&(j, s)| s * x[j as usize]).collect();
        let mirrored = self.raw_logits(&m);
        Ok(own.iter().zip(&self.compiled.mirror_class).map(|(o, &mc)| 0.5 * (o + mirrored[mc])).collect())
    }

    /// The log posterior of one window (model class order).
    pub fn log_posterior(&self, x: &[f64]) -> Result<Vec<f64>> {
        Ok(log_softmax(&self.logits(x)?))
    }

    /// Classify one window's input vector.
    pub fn classify(&self, x: &[f64]) -> Result<Decision> {
        Ok(decision(&self.classes, softmax(&self.logits(x)?)))
    }

    /// An extractor of this model's inputs on `layout` (the model's taxel count).
    pub fn extractor(&self, layout: &Layout) -> Result<TreeExtractor> {
        if layout.len() != self.taxels {
            return Err(invalid(format!(
                "the model was trained for {} taxels, the layout has {}",
                self.taxels,
                layout.len()
            )));
        }
        TreeExtractor::try_new_on(&self.inputs, layout)
    }

    /// A streaming per-span answer on `layout` ([`TreeVote`]).
    pub fn vote(&self, layout: &Layout) -> Result<TreeVote<'_>> {
        Ok(TreeVote { model: self, state: TreeVoteState::try_new(self, layout)? })
    }
}

/// The causal per-span answer of a [`DosTrees`]: the sum of the log posteriors of every completed
/// window since the last [`reset`](Self::reset).
#[derive(Clone, Debug)]
pub struct TreeVote<'a> {
    model: &'a DosTrees,
    state: TreeVoteState,
}

impl TreeVote<'_> {
    /// Push one raw frame; when it completes a window, that window's decision (alone).
    pub fn push(&mut self, values: &[f64]) -> Result<Option<Decision>> {
        self.state.push(self.model, values)
    }

    /// Completed windows in the vote.
    pub fn windows(&self) -> u64 {
        self.state.windows()
    }

    /// The vote's decision so far (`None` before the first window).
    pub fn decision(&self) -> Option<Decision> {
        self.state.decision(self.model)
    }

    /// The mean log posterior per window so far (model class order).
    pub fn mean_log_posterior(&self) -> Option<Vec<f64>> {
        self.state.mean_log_posterior()
    }

    /// Start a new span.
    pub fn reset(&mut self) {
        self.state.reset();
    }
}

impl SpanVote for TreeVote<'_> {
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

/// The state of a [`TreeVote`] without the borrow of its model (the `dos` stage keeps both):
/// every call takes the model the state was made for.
#[derive(Clone, Debug)]
pub struct TreeVoteState {
    extractor: TreeExtractor,
    votes: LogVote,
}

impl TreeVoteState {
    /// An empty vote of `model` on `layout` (the model's taxel count).
    pub fn try_new(model: &DosTrees, layout: &Layout) -> Result<Self> {
        Ok(TreeVoteState { extractor: model.extractor(layout)?, votes: LogVote::new(model.classes.len()) })
    }

    /// [`TreeVote::push`] with `model`.
    pub fn push(&mut self, model: &DosTrees, values: &[f64]) -> Result<Option<Decision>> {
        let Some(x) = self.extractor.push(values)? else { return Ok(None) };
        let logits = model.logits(&x)?;
        self.votes.add(&log_softmax(&logits));
        Ok(Some(decision(&model.classes, softmax(&logits))))
    }

    /// Completed windows in the vote.
    pub fn windows(&self) -> u64 {
        self.votes.windows()
    }

    /// [`TreeVote::decision`] with `model`.
    pub fn decision(&self, model: &DosTrees) -> Option<Decision> {
        self.votes.decision(&model.classes)
    }

    /// [`TreeVote::mean_log_posterior`].
    pub fn mean_log_posterior(&self) -> Option<Vec<f64>> {
        self.votes.mean_log_posterior()
    }

    /// A fresh extractor of this vote's windows (the same representation and layout).
    pub fn fresh_extractor(&self) -> TreeExtractor {
        let mut x = self.extractor.clone();
        x.reset();
        x
    }

    /// Start a new span.
    pub fn reset(&mut self) {
        self.extractor.reset();
        self.votes.reset();
    }
}
