//! Per-taxel drift-to-noise activity: where on the sensor the signal *moves*, measured in units of
//! each taxel's own frame-to-frame noise.
//!
//! # What it does
//! For every taxel `i` with values `r_t` over a span of frames — the raw values `r_t = x_t`
//! ([`DriftScale::Linear`], the default) or their logarithms `r_t = ln(max(x_t, floor))`
//! ([`DriftScale::Log`], [`DriftMap::with_scale`]) — and each lag `S` of
//! [`DriftMap::try_new`]'s `lags` (in frames):
//!
//! | quantity | definition | meaning |
//! |---|---|---|
//! | noise `n_i` | mean of `|r_t − r_{t−1}|` | how much the taxel jitters from frame to frame |
//! | drift `D_{S,i}` | mean of `|r_t − r_{t−S}|` | how far it moves over `S` frames |
//! | weight `w_{S,i}` | `max(0, ln(D_{S,i} / (n_i + 1e-9)))` (log scale); `min(`[`MAX_LINEAR_WEIGHT`]`, max(0, ln(D_{S,i} / n_i)))` (linear) | drift against noise, in nepers; 0 for a taxel that only jitters |
//! | sign `s_{S,i}` | `2·Σ max(0, r_t − r_{t−S}) / Σ |r_t − r_{t−S}| − 1` | `+1`: the value only rose over lag `S`, `−1`: only fell (0 without change) |
//!
//! [`DriftMap::snapshot`] returns `w_i` and `s_i`, each the mean over the lags that have at least
//! one difference in the span. White noise has `D_S ≈ n` and weighs ≈ 0; a random walk has
//! `D_S ≈ √S·n` (weight `≈ ½ ln S`); a slow, steady change (a contact sliding over the taxel)
//! has `D_S ≈ S·n` or more and weighs `≈ ln S` or more. Both terms are measured on the same taxel
//! in the same span, so the weight does not depend on the taxel's gain or baseline, nor on how
//! hard the object presses. On the linear scale this is exact for any gain `a > 0` and offset
//! `b` (`a·x + b`: every difference scales by `a`, the offset cancels, the ratio and the sign
//! are unchanged; bit for bit when `a` is a power of two and the values and `b` are integers
//! below 2⁵²); on the log scale it is exact for the gain and only approximate for an offset
//! (`d ln x ≈ dx / x`, with `x` nearly constant per taxel). The two scales give the same
//! accuracy on BioTacSP-DoS ([`crate::dos`]), so the linear one is the default. This is the evidence the one-fingertip slip classifier
//! ([`crate::dos`]) locates on the layout.
//!
//! # State, units, delay, cost
//! A plain state machine: [`push`](DriftMap::push) one frame of raw values (any positive unit;
//! values below `floor` are raised to it), read [`snapshot`](DriftMap::snapshot) for the span so
//! far, [`clear_span`](DriftMap::clear_span) to start a new span (the last `max(lags)` frames are
//! kept, so the next span's first differences reach back into the previous one, as event
//! references do), [`reset`](DriftMap::reset) on a discontinuity (everything forgotten). Weights
//! are dimensionless; no delay of its own (a snapshot covers the frames pushed so far). Memory:
//! `max(lags) × taxels` values; cost per frame: one `ln` and `1 + lags` differences per taxel.
//!
//! # Trade-offs
//! | knob | lower | higher |
//! |---|---|---|
//! | lags | sees fast, short slips; noise weighs more | sees slow drifts; a span needs more than the lag to weigh anything |
//! | span length | earlier answer, fewer differences averaged | surer weights, later answer |
//!
//! ```
//! use gradtac_stages::drift::DriftMap;
//! let mut m = DriftMap::try_new(2, &[5], 1e-3).unwrap();
//! for t in 0..50 {
//!     let jitter = if t % 2 == 0 { 1.0 } else { -1.0 };
//!     // taxel 0 only jitters, taxel 1 rises steadily by 1 % per frame on top of the same jitter
//!     m.push(&[1000.0 + jitter, 1000.0 * 1.01f64.powi(t) + jitter]).unwrap();
//! }
//! let s = m.snapshot();
//! assert_eq!(s.weights[0], 0.0);
//! assert!(s.weights[1] > 1.0 && s.signs[1] == 1.0);
//! ```

use crate::{Error, Result};

const STAGE: &str = "drift";

/// The values the drift map differences (see the [module docs](self)).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DriftScale {
    /// The raw values: weights and signs exactly invariant to a gain and an offset per
    /// recording (the default).
    #[default]
    Linear,
    /// `ln(max(x, floor))`: invariant to a gain only (the scale before the linear default).
    Log,
}

/// Added to the noise before dividing by it (log units): keeps a taxel that never changed from
/// dividing by zero.
pub const NOISE_EPSILON: f64 = 1e-9;

/// Factor applied to raw values on the linear scale (a power of two: exact, and keeps differences
/// of values near ±`f64::MAX` finite).
const LINEAR_SCALE: f64 = 1.0 / 18_446_744_073_709_551_616.0;

/// Largest weight on the linear scale (nepers): a taxel that moved over a lag but had no
/// frame-to-frame change in the span (possible when the lag reaches back before
/// [`DriftMap::clear_span`]) weighs this instead of infinity. `ln 10⁹`, what the log scale's
/// [`NOISE_EPSILON`] allows for a change of one unit.
pub const MAX_LINEAR_WEIGHT: f64 = 20.723_265_836_946_41;

/// Longest lag accepted, in frames.
pub const MAX_LAG: u64 = 100_000;

/// Per-taxel drift-to-noise weights and signs of a span (see the [module docs](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct DriftSnapshot {
    /// `w_i ≥ 0` per taxel (nepers of drift over noise, mean over the lags with data).
    pub weights: Vec<f64>,
    /// `s_i ∈ [−1, 1]` per taxel (mean over the lags with data).
    pub signs: Vec<f64>,
    /// Frames pushed in the span.
    pub frames: u64,
}

/// The drift-to-noise accumulator (see the [module docs](self)).
#[derive(Clone, Debug)]
pub struct DriftMap {
    taxels: usize,
    floor: f64,
    scale: DriftScale,
    lags: Vec<usize>,
    /// The last `cap` log frames, slot-major (`slot × taxels + taxel`).
    ring: Vec<f64>,
    cap: usize,
    /// Slot of the next write.
    head: usize,
    /// Frames held in `ring` (≤ `cap`).
    filled: usize,
    noise_sum: Vec<f64>,
    noise_n: u64,
    /// Per lag, per taxel: `Σ |d|` and `Σ max(0, d)`.
    abs_sum: Vec<Vec<f64>>,
    pos_sum: Vec<Vec<f64>>,
    lag_n: Vec<u64>,
    frames: u64,
    scratch: Vec<f64>,
}

impl DriftMap {
    /// A map over `taxels` taxels (≥ 1) with `lags` in frames (non-empty, each in
    /// `1..=`[`MAX_LAG`], no repeats) and `floor` (> 0, finite) for values at or below zero.
    pub fn try_new(taxels: usize, lags: &[u64], floor: f64) -> Result<Self> {
        let invalid = |reason: String| Error::InvalidConfig { stage: STAGE, reason };
        if taxels == 0 {
            return Err(invalid("taxels must be ≥ 1".into()));
        }
        if lags.is_empty() {
            return Err(invalid("lags must not be empty".into()));
        }
        for (i, &l) in lags.iter().enumerate() {
            if !(1..=MAX_LAG).contains(&l) {
                return Err(invalid(format!("lag {l} must lie in 1..={MAX_LAG} frames")));
            }
            if lags[..i].contains(&l) {
                return Err(invalid(format!("lag {l} appears twice")));
            }
        }
        if !(floor.is_finite() && floor > 0.0) {
            return Err(invalid(format!("floor {floor} must be finite and > 0")));
        }
        let lags: Vec<usize> = lags.iter().map(|&l| l as usize).collect();
        let cap = lags.iter().copied().max().unwrap_or(1).max(1);
        Ok(DriftMap {
            taxels,
            floor,
            scale: DriftScale::Log,
            ring: vec![0.0; cap * taxels],
            cap,
            head: 0,
            filled: 0,
            noise_sum: vec![0.0; taxels],
            noise_n: 0,
            abs_sum: vec![vec![0.0; taxels]; lags.len()],
            pos_sum: vec![vec![0.0; taxels]; lags.len()],
            lag_n: vec![0; lags.len()],
            lags,
            frames: 0,
            scratch: vec![0.0; taxels],
        })
    }

    /// The same map differencing `scale` values ([`try_new`](Self::try_new) gives
    /// [`DriftScale::Log`], the scale of the map's first version; the slip classifier
    /// configures [`DriftScale::Linear`]). Forgets the frames pushed so far.
    pub fn with_scale(mut self, scale: DriftScale) -> Self {
        self.scale = scale;
        self.reset();
        self
    }

    /// The scale the map differences.
    pub fn scale(&self) -> DriftScale {
        self.scale
    }

    /// Number of taxels.
    pub fn taxels(&self) -> usize {
        self.taxels
    }

    /// Frames pushed in the current span.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Push one frame of raw values (one per taxel). Refuses a frame of the wrong length or with a
    /// non-finite value (naming the taxel); nothing is changed then.
    pub fn push(&mut self, values: &[f64]) -> Result<()> {
        if values.len() != self.taxels {
            return Err(Error::InvalidConfig {
                stage: STAGE,
                reason: format!("frame of {} values for {} taxels", values.len(), self.taxels),
            });
        }
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(Error::InvalidConfig {
                stage: STAGE,
                reason: format!("taxel {i} is {} (finite values only)", values[i]),
            });
        }
        let n = self.taxels;
        match self.scale {
            DriftScale::Log => {
                for (r, &x) in self.scratch.iter_mut().zip(values) {
                    *r = x.max(self.floor).ln();
                }
            }
            // scaled by 2⁻⁶⁴ (exact for every normal value above 2⁻⁹⁵⁸): differences and their
            // sums stay finite for any finite input
            DriftScale::Linear => {
                for (r, &x) in self.scratch.iter_mut().zip(values) {
                    *r = x * LINEAR_SCALE;
                }
            }
        }
        if self.filled >= 1 {
            let last = (self.head + self.cap - 1) % self.cap;
            let prev = &self.ring[last * n..(last + 1) * n];
            for ((acc, r), p) in self.noise_sum.iter_mut().zip(&self.scratch).zip(prev) {
                *acc += (r - p).abs();
            }
            self.noise_n += 1;
        }
        for (k, &lag) in self.lags.iter().enumerate() {
            if lag > self.filled {
                continue;
            }
            let slot = (self.head + self.cap - lag) % self.cap;
            let old = &self.ring[slot * n..(slot + 1) * n];
            for (i, (r, o)) in self.scratch.iter().zip(old).enumerate() {
                let d = r - o;
                self.abs_sum[k][i] += d.abs();
                self.pos_sum[k][i] += d.max(0.0);
            }
            self.lag_n[k] += 1;
        }
        self.ring[self.head * n..(self.head + 1) * n].copy_from_slice(&self.scratch);
        self.head = (self.head + 1) % self.cap;
        self.filled = (self.filled + 1).min(self.cap);
        self.frames += 1;
        Ok(())
    }

    /// Weights and signs of the span so far (all zero before any lag has a difference).
    pub fn snapshot(&self) -> DriftSnapshot {
        let n = self.taxels;
        let mut weights = vec![0.0; n];
        let mut signs = vec![0.0; n];
        let used: Vec<usize> = (0..self.lags.len()).filter(|&k| self.lag_n[k] > 0).collect();
        if self.noise_n > 0 && !used.is_empty() {
            let m = used.len() as f64;
            for i in 0..n {
                let noise = self.noise_sum[i] / self.noise_n as f64;
                let (mut w, mut s) = (0.0, 0.0);
                for &k in &used {
                    let abs = self.abs_sum[k][i];
                    let drift = abs / self.lag_n[k] as f64;
                    if drift > 0.0 {
                        w += match self.scale {
                            DriftScale::Log => (drift / (noise + NOISE_EPSILON)).ln().max(0.0),
                            DriftScale::Linear if noise > 0.0 => (drift / noise).ln().clamp(0.0, MAX_LINEAR_WEIGHT),
                            DriftScale::Linear => MAX_LINEAR_WEIGHT,
                        };
                        s += 2.0 * self.pos_sum[k][i] / abs - 1.0;
                    }
                }
                weights[i] = w / m;
                signs[i] = s / m;
            }
        }
        DriftSnapshot { weights, signs, frames: self.frames }
    }

    /// Start a new span: the sums restart, the last `max(lags)` frames are kept.
    pub fn clear_span(&mut self) {
        self.noise_sum.iter_mut().for_each(|v| *v = 0.0);
        self.noise_n = 0;
        for row in self.abs_sum.iter_mut().chain(self.pos_sum.iter_mut()) {
            row.iter_mut().for_each(|v| *v = 0.0);
        }
        self.lag_n.iter_mut().for_each(|v| *v = 0);
        self.frames = 0;
    }

    /// Forget everything (a discontinuity).
    pub fn reset(&mut self) {
        self.clear_span();
        self.head = 0;
        self.filled = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Straightforward batch computation of the module docs' formulas.
    fn oracle(frames: &[Vec<f64>], lags: &[usize], floor: f64) -> (Vec<f64>, Vec<f64>) {
        let r: Vec<Vec<f64>> = frames.iter().map(|f| f.iter().map(|x| x.max(floor).ln()).collect()).collect();
        let taxels = frames[0].len();
        let mut w = vec![0.0; taxels];
        let mut s = vec![0.0; taxels];
        let used: Vec<usize> = lags.iter().copied().filter(|&l| l < r.len()).collect();
        if r.len() < 2 || used.is_empty() {
            return (w, s);
        }
        for i in 0..taxels {
            let noise = (1..r.len()).map(|t| (r[t][i] - r[t - 1][i]).abs()).sum::<f64>() / (r.len() - 1) as f64;
            for &l in &used {
                let d: Vec<f64> = (l..r.len()).map(|t| r[t][i] - r[t - l][i]).collect();
                let abs: f64 = d.iter().map(|v| v.abs()).sum();
                let drift = abs / d.len() as f64;
                if drift > 0.0 {
                    w[i] += (drift / (noise + NOISE_EPSILON)).ln().max(0.0) / used.len() as f64;
                    s[i] += (2.0 * d.iter().map(|v| v.max(0.0)).sum::<f64>() / abs - 1.0) / used.len() as f64;
                }
            }
        }
        (w, s)
    }

    fn frames(n: usize, taxels: usize, seed: u64) -> Vec<Vec<f64>> {
        let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        (0..n).map(|t| (0..taxels).map(|i| 3000.0 + 5.0 * next() + (i as f64) * 0.3 * t as f64).collect()).collect()
    }

    #[test]
    fn matches_the_batch_definition() {
        let f = frames(200, 5, 7);
        let lags = [30u64, 60, 120];
        let mut m = DriftMap::try_new(5, &lags, 1e-3).unwrap();
        for fr in &f {
            m.push(fr).unwrap();
        }
        let (w, s) = oracle(&f, &[30, 60, 120], 1e-3);
        let snap = m.snapshot();
        for i in 0..5 {
            approx::assert_relative_eq!(snap.weights[i], w[i], max_relative = 1e-12, epsilon = 1e-15);
            approx::assert_relative_eq!(snap.signs[i], s[i], max_relative = 1e-12, epsilon = 1e-15);
        }
        // taxel 0 only jitters (white noise: a lagged difference is as large as an adjacent one,
        // the ratio ≈ 1 and the weight ≈ 0), the others rise steadily (more so the higher the index)
        assert!(snap.weights[0] < 0.1, "{}", snap.weights[0]);
        assert!(snap.weights[1] > 0.5 && snap.weights[4] > snap.weights[1]);
        assert!(snap.signs[4] > 0.99);
    }

    #[test]
    fn short_spans_use_only_the_lags_with_data() {
        let f = frames(45, 3, 1);
        let mut m = DriftMap::try_new(3, &[30, 60, 120], 1e-3).unwrap();
        for fr in &f {
            m.push(fr).unwrap();
        }
        let (w, _) = oracle(&f, &[30, 60, 120], 1e-3);
        let snap = m.snapshot();
        for (got, want) in snap.weights.iter().zip(&w) {
            approx::assert_relative_eq!(*got, *want, max_relative = 1e-12, epsilon = 1e-15);
        }
        let mut fresh = DriftMap::try_new(3, &[30, 60, 120], 1e-3).unwrap();
        assert_eq!(fresh.snapshot().weights, vec![0.0; 3]);
        fresh.push(&f[0]).unwrap();
        assert_eq!(fresh.snapshot().weights, vec![0.0; 3], "one frame has no difference");
    }

    #[test]
    fn linear_scale_is_exactly_invariant_to_gain_and_offset() {
        // integer counts, power-of-two gains, integer offsets: every difference is exact
        let f: Vec<Vec<f64>> = frames(150, 4, 11).iter().map(|r| r.iter().map(|v| v.round()).collect()).collect();
        let snap = |g: f64, b: f64| {
            let mut m = DriftMap::try_new(4, &[10, 30], 1e-3).unwrap().with_scale(DriftScale::Linear);
            for fr in &f {
                m.push(&fr.iter().map(|v| g * v + b).collect::<Vec<_>>()).unwrap();
            }
            m.snapshot()
        };
        let base = snap(1.0, 0.0);
        assert!(base.weights.iter().any(|&w| w > 0.5), "{base:?}");
        for (g, b) in [(0.5, 0.0), (2.0, 0.0), (1.0, 731.0), (2.0, -4096.0), (0.5, 12_345.0)] {
            assert_eq!(snap(g, b), base, "gain {g}, offset {b}");
        }
        // and close to the log scale (d ln x ≈ dx / x for x nearly constant per taxel)
        let mut log = DriftMap::try_new(4, &[10, 30], 1e-3).unwrap();
        for fr in &f {
            log.push(fr).unwrap();
        }
        for (a, b) in log.snapshot().weights.iter().zip(&base.weights) {
            assert!((a - b).abs() < 0.05, "{a} vs {b}");
        }
    }

    #[test]
    fn linear_scale_stays_finite_at_the_extremes() {
        let mut m = DriftMap::try_new(3, &[1, 2], 1e-3).unwrap().with_scale(DriftScale::Linear);
        for t in 0..20 {
            let s = if t % 2 == 0 { 1.0 } else { -1.0 };
            m.push(&[s * f64::MAX, -s * 1e300, f64::MIN_POSITIVE * t as f64]).unwrap();
        }
        let s = m.snapshot();
        assert!(s.weights.iter().chain(&s.signs).all(|v| v.is_finite()), "{s:?}");
        assert!(s.weights.iter().all(|&w| (0.0..=MAX_LINEAR_WEIGHT).contains(&w)));
        // a taxel that moved only across clear_span: no frame-to-frame change in the span
        let mut m = DriftMap::try_new(1, &[3], 1e-3).unwrap().with_scale(DriftScale::Linear);
        for v in [0.0, 0.0, 5.0] {
            m.push(&[v]).unwrap();
        }
        m.clear_span();
        for _ in 0..3 {
            m.push(&[5.0]).unwrap();
        }
        assert_eq!(m.snapshot().weights, vec![MAX_LINEAR_WEIGHT]);
    }

    #[test]
    fn constant_input_weighs_nothing() {
        let mut m = DriftMap::try_new(4, &[1, 3], 1e-3).unwrap();
        for _ in 0..20 {
            m.push(&[3500.0, 0.0, -7.0, 1e-300]).unwrap();
        }
        let s = m.snapshot();
        assert_eq!(s.weights, vec![0.0; 4]);
        assert_eq!(s.signs, vec![0.0; 4]);
    }

    #[test]
    fn extremes_stay_finite() {
        let mut m = DriftMap::try_new(3, &[1, 2, 5], 1e-3).unwrap();
        for t in 0..30 {
            let big = if t % 3 == 0 { 1e300 } else { 1e-300 };
            m.push(&[big, f64::MAX / (t as f64 + 1.0), f64::MIN_POSITIVE * t as f64]).unwrap();
        }
        let s = m.snapshot();
        assert!(s.weights.iter().chain(&s.signs).all(|v| v.is_finite()), "{s:?}");
        assert!(s.signs.iter().all(|v| (-1.0..=1.0).contains(v)));
    }

    #[test]
    fn clear_span_keeps_history_and_reset_forgets_it() {
        let f = frames(100, 2, 3);
        let mut a = DriftMap::try_new(2, &[10], 1e-3).unwrap();
        for fr in &f[..50] {
            a.push(fr).unwrap();
        }
        a.clear_span();
        for fr in &f[50..] {
            a.push(fr).unwrap();
        }
        // the second span's differences reach back into the first: 50 noise terms, 50 lag terms
        let r: Vec<Vec<f64>> = f.iter().map(|v| v.iter().map(|x| x.ln()).collect()).collect();
        let noise = (50..100).map(|t| (r[t][1] - r[t - 1][1]).abs()).sum::<f64>() / 50.0;
        let drift = (50..100).map(|t| (r[t][1] - r[t - 10][1]).abs()).sum::<f64>() / 50.0;
        approx::assert_relative_eq!(a.snapshot().weights[1], (drift / (noise + NOISE_EPSILON)).ln().max(0.0));
        a.reset();
        assert_eq!(a.frames(), 0);
        for fr in &f[50..] {
            a.push(fr).unwrap();
        }
        let (w, _) = oracle(&f[50..], &[10], 1e-3);
        approx::assert_relative_eq!(a.snapshot().weights[1], w[1], max_relative = 1e-12);
    }

    #[test]
    fn invalid_configuration_and_input_are_refused() {
        assert!(DriftMap::try_new(0, &[1], 1e-3).is_err());
        assert!(DriftMap::try_new(2, &[], 1e-3).is_err());
        assert!(DriftMap::try_new(2, &[0], 1e-3).is_err());
        assert!(DriftMap::try_new(2, &[3, 3], 1e-3).is_err());
        assert!(DriftMap::try_new(2, &[MAX_LAG + 1], 1e-3).is_err());
        assert!(DriftMap::try_new(2, &[1], 0.0).is_err());
        assert!(DriftMap::try_new(2, &[1], f64::NAN).is_err());
        let mut m = DriftMap::try_new(2, &[1], 1e-3).unwrap();
        let e = m.push(&[1.0, f64::NAN]).unwrap_err().to_string();
        assert!(e.contains("taxel 1"), "{e}");
        assert!(m.push(&[1.0]).is_err());
        assert_eq!(m.frames(), 0, "a refused frame changes nothing");
    }
}
