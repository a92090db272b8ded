//! The `forward` force method: a member's forward model **identified from a gauge session**,
//! then inverted per frame (`gradtac calibrate force --method forward`, the default since
//! session 31).
//!
//! # The model
//! On the force stage's baseline-relative changes `Δᵢ` (counts) of electrode `i`:
//!
//! ```text
//! Δᵢ ≈ gᵢ · (F/F₀)^γ · K(ρᵢ(x, y); w·(F/F₀)^s),   F₀ = 2 N
//! K(ρ; w) = (1 + a)·E(ρ/w) − a·E(ρ/(m·w)),   E(u) = exp(−u^q/q),   m = 2.5
//! ρᵢ² = ‖eᵢ − skin(x, y)‖² − hᵢ²
//! ```
//!
//! - `gᵢ`: each electrode's **signed** gain (counts at `F₀` under the contact; the sign is the
//!   electrode's convention);
//! - `γ`: the response's exponent in force (a stiffening skin: < 1);
//! - `w`, `s`: the kernel's width at `F₀` and its growth with force (the patch spreads);
//! - `q` (1–2: exponential to Gaussian) and `a` (far lobe: > 0 a ring moving the other way,
//!   < 0 a heavier tail): the kernel's radial profile;
//! - geometry as the contact fit's ([`fit`](crate::fit)): on the built-in BioTac SP layout the
//!   electrodes' 3-D core positions `eᵢ`, their core-to-skin depths `hᵢ` and the fingertip
//!   ellipsoid; on any other layout the plane with cores 3 mm under the taxels.
//!
//! # Identification ([`identify`])
//! The gauge gives `F` on every calibration frame, so the frames pin the model: the contact's
//! place `(x, y)` of each press (unknown: a gauge does not say where it pressed; the frames of
//! one contact — a run of consecutive contact frames — share it), the 24 gains and
//! the five shape numbers `(γ, s, ln w, q, a)`. The fit alternates, for [`ROUNDS`] rounds:
//! 1. gains in closed form (linear given the rest), pulled toward the prior `ĝ` (the median
//!    gain of the well-excited electrodes, with their majority sign — a well-excited electrode
//!    of the other sign keeps its own) by a weight of
//!    [`GAIN_PRIOR`] × the best-excited electrode's: **an electrode no calibration press
//!    excited keeps the prior gain** (relative gain 1, the sign most electrodes have);
//! 2. each press's place: Levenberg–Marquardt on `(x, y)` over its frames from the last
//!    round's (the `Δ²`-weighted centroid of its strongest frame at the start);
//! 3. the five shape numbers: Levenberg–Marquardt (forward-difference Jacobian) with the gains
//!    and places fixed.
//!
//! The shape fit starts from `(γ, s, w)` = (0.75, 0.2, 3 mm) ([`Starts::Single`], session 31)
//! or from each of [`MULTI_STARTS`], keeping the lowest final cost ([`Starts::Multi`], what
//! `gradtac calibrate force` uses since session 32: chosen on the tuning members by a rule
//! stated first; held out it scored the same worst member as one start — `examples/force_parts/history.md`).
//!
//! Each frame's residuals are weighted by `1/max(max|Δ|, 5)²`, so every frame counts by its
//! *relative* error (what MAPE measures), not its size in counts. At most [`MAX_FRAMES`]
//! frames (evenly subsampled) of at least [`MIN_FORCE_N`] are used. Held fixed: the profile
//! `q` = 2 (Gaussian lobes; freeing it scored a worse tuning worst member, 38.6 % against
//! 32.1 %). Not identified: the saturation knee (switching it off in the forward-model family
//! moved the `placed` law's worst tuning member by under 1 point) and the fluid lag (a grid of
//! lags chosen by in-sample fit lowered the tuning mean, 16.6 → 15.0 %, but raised the worst
//! member, 32.1 → 36.5 %; the file's `lag_s`, 0 as calibrated, is inverted on the changes
//! when set — `examples/force_parts/history.md`).
//!
//! # Inversion ([`ForwardModel::invert`])
//! Per frame, `(x, y, ln F)` minimise `Σᵢ (Δᵢ − model)²`: a coarse search over `ln F` at the
//! `Δ²`-weighted centroid, then Levenberg–Marquardt (at most [`INVERT_ITERATIONS`]
//! iterations, forward-difference Jacobian), the place kept within the layout's extent grown
//! by 3 mm and `F` within [`F_RANGE_N`]. Since session 38's round 10 the identification also
//! stores each gain's doubt `rᵢ` ([`ForwardModel::gain_rel_sd`]: the prior's share in the gain
//! × [`PRIOR_REL_SD`]) and the inversion weighs residual `i` by `1/√(s₀² + (rᵢ Δᵢ)²)`
//! ([`INVERT_NOISE_COUNTS`]), so an electrode whose gain calibration left at the prior does not
//! drag the force (`examples/force_parts/rule_round10.md`); a model without doubts (a version-4
//! file) is inverted unweighted, as before. Stateless: every frame is solved from scratch (no
//! warm start, so a frame's force does not depend on the frames before it). Cost: ≈ 10–30 µs
//! per frame in contact (`examples/force_eval.rs`'s µs column).

use serde::{Deserialize, Serialize};

/// Reference force `F₀` (N): gains are counts at this force.
pub const F0_N: f64 = 2.0;
/// Ratio `m` of the far lobe's width to the near lobe's.
pub const LOBE_RATIO: f64 = 2.5;
/// Alternation rounds of [`identify`].
pub const ROUNDS: usize = 12;
/// Most calibration frames [`identify`] uses (evenly subsampled).
pub const MAX_FRAMES: usize = 400;
/// Lightest gauge force a frame needs to be used by [`identify`] (N).
pub const MIN_FORCE_N: f64 = 0.3;
/// Weight of the gain prior, relative to the best-excited electrode's sum of squares.
pub const GAIN_PRIOR: f64 = 0.02;
/// Most Levenberg–Marquardt iterations per frame of [`ForwardModel::invert`].
pub const INVERT_ITERATIONS: usize = 20;
/// The force range an inversion reports (N).
pub const F_RANGE_N: [f64; 2] = [1e-3, 1e3];
/// The prior gain's relative standard deviation: an electrode whose identified gain is all
/// prior has a gain doubt `rᵢ` of this (see [`ForwardModel::gain_rel_sd`]).
pub const PRIOR_REL_SD: f64 = 0.3;
/// `s₀` (counts): the floor of each residual's standard deviation in the gain-doubt weighted
/// inversion, `1/√(s₀² + (rᵢ Δᵢ)²)`. Chosen in session 38's exploration on the **tuning
/// members** (`examples/force_parts/forward_gap.md`, "(c2)"; disclosed in
/// `examples/force_parts/rule_round10.md`): a few counts, the order of the changes' noise.
pub const INVERT_NOISE_COUNTS: f64 = 3.0;

/// Which shape numbers [`identify`] holds fixed: the profile `q` stays at 2 (Gaussian lobes).
/// Freeing it (with the exponential members of the family in view) scored a worse tuning
/// worst member, 38.6 % against 32.1 % (`examples/force_parts/history.md`).
const FIXED: [bool; 5] = [false, false, false, true, false];
/// Bounds of the shape numbers `(γ, s, ln w, q, a)`.
const SHAPE_LO: [f64; 5] = [0.2, -0.3, -0.7, 1.0, -0.7];
const SHAPE_HI: [f64; 5] = [1.6, 0.7, 2.5, 2.0, 1.5];

/// The electrodes' geometry (see the [module docs](self)): the location fit's
/// [`fit::Geometry`](crate::fit::Geometry) (cores, depths, skin) with the taxel positions
/// and the bounds of a place.
#[derive(Clone, Debug)]
pub struct Geometry {
    shape: crate::fit::Geometry,
    positions: Vec<[f64; 2]>,
    /// x_min, x_max, y_min, y_max of a place (the positions' extent grown by 3 mm).
    bounds: [f64; 4],
}

impl Geometry {
    /// The BioTac SP's 3-D geometry when `positions` are the built-in BioTac SP layout's, a
    /// plane with cores 3 mm under the taxels otherwise.
    pub fn for_positions(positions: &[[f64; 2]]) -> Geometry {
        let mut bounds = [f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY];
        for p in positions {
            bounds[0] = bounds[0].min(p[0] - 3.0);
            bounds[1] = bounds[1].max(p[0] + 3.0);
            bounds[2] = bounds[2].min(p[1] - 3.0);
            bounds[3] = bounds[3].max(p[1] + 3.0);
        }
        if positions.is_empty() {
            bounds = [0.0; 4];
        }
        let shape = crate::fit::Geometry::for_positions(positions, bounds);
        Geometry { shape, positions: positions.to_vec(), bounds }
    }

    /// Number of electrodes.
    pub fn len(&self) -> usize {
        self.shape.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.shape.is_empty()
    }

    /// `ρᵢ²` (mm², at least 0) of every electrode for a contact at `(x, y)` into `out`.
    fn rho2(&self, x: f64, y: f64, out: &mut [f64]) {
        self.shape.rho2_into(x, y, out);
        for o in out.iter_mut() {
            *o = o.max(0.0);
        }
    }

    fn clamp(&self, x: f64, y: f64) -> (f64, f64) {
        (x.clamp(self.bounds[0], self.bounds[1]), y.clamp(self.bounds[2], self.bounds[3]))
    }

    /// The `Δ²`-weighted centroid of the positions (`None` without a finite change).
    pub fn centroid(&self, delta: &[f64]) -> Option<[f64; 2]> {
        // scaled by the largest change, so huge changes do not overflow
        let top = delta.iter().fold(0.0f64, |a, d| a.max(d.abs()));
        if !(top > 0.0 && top.is_finite()) {
            return None;
        }
        let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
        for (p, d) in self.positions.iter().zip(delta) {
            let q = (d / top) * (d / top);
            sx += q * p[0];
            sy += q * p[1];
            sw += q;
        }
        (sw > 0.0 && sw.is_finite() && sx.is_finite() && sy.is_finite()).then(|| [sx / sw, sy / sw])
    }
}

/// An identified forward model (see the [module docs](self)).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForwardModel {
    /// `gᵢ`: signed counts at `F₀` under the contact, one per taxel.
    pub gains: Vec<f64>,
    /// `γ`.
    pub exponent: f64,
    /// `s`.
    pub spread: f64,
    /// `w` (mm) at `F₀`.
    pub width_mm: f64,
    /// `q` (1–2).
    pub shape: f64,
    /// `a`.
    pub lobe: f64,
    /// `rᵢ`, one per taxel: how much of electrode `i`'s identified gain is the prior's
    /// (`λ/(denᵢ + λ)`, its share in the last round's closed-form gain) × [`PRIOR_REL_SD`]. When
    /// present, [`invert`](Self::invert) weighs residual `i` by `1/√(s₀² + (rᵢ Δᵢ)²)`
    /// ([`INVERT_NOISE_COUNTS`]), so an electrode calibration barely excited (its gain near the
    /// prior) does not drag the force; `None` (a file written before it): unweighted, exactly
    /// as before.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gain_rel_sd: Option<Vec<f64>>,
}

/// `E(u)` for `u = ρ²/w²` and shape `q`: `exp(−u^{q/2}/q)`.
fn lobe_of(u: f64, q: f64) -> f64 {
    if q >= 2.0 {
        (-0.5 * u).exp()
    } else {
        (-(u + 1e-3 * (2.0 - q)).powf(0.5 * q) / q).exp()
    }
}

/// `K` for `ρ²`, width `w`, shape `q`, lobe `a`.
fn kernel(r2: f64, w: f64, q: f64, a: f64) -> f64 {
    let w2 = w * w;
    (1.0 + a) * lobe_of(r2 / w2, q) - a * lobe_of(r2 / (LOBE_RATIO * LOBE_RATIO * w2), q)
}

/// The unit-gain response `(F/F₀)^γ K(ρ; w (F/F₀)^s)` for shape numbers `th = (γ, s, ln w, q, a)`.
fn unit(th: &[f64; 5], r2: f64, f: f64) -> f64 {
    let x = f / F0_N;
    let w = th[2].exp() * x.powf(th[1]);
    x.powf(th[0]) * kernel(r2, w, th[3], th[4])
}

impl ForwardModel {
    fn shape_numbers(&self) -> [f64; 5] {
        [self.exponent, self.spread, self.width_mm.ln(), self.shape, self.lobe]
    }

    /// The model's changes (counts) for a press of `f` N at `(x, y)` (layout plane, mm).
    pub fn predict(&self, geo: &Geometry, x: f64, y: f64, f: f64) -> Vec<f64> {
        let th = self.shape_numbers();
        let mut r2 = vec![0.0; geo.len()];
        geo.rho2(x, y, &mut r2);
        r2.iter().zip(&self.gains).map(|(&r, g)| g * unit(&th, r, f)).collect()
    }

    /// Whether every number is finite and within its bounds.
    pub fn is_valid(&self) -> bool {
        let th = self.shape_numbers();
        self.gains.iter().all(|g| g.is_finite() && g.abs() <= 1e9)
            && self
                .gain_rel_sd
                .as_ref()
                .is_none_or(|r| r.len() == self.gains.len() && r.iter().all(|v| (0.0..=1.0).contains(v)))
            && th.iter().all(|v| v.is_finite())
            && (0..5).all(|k| th[k] >= SHAPE_LO[k] - 1e-9 && th[k] <= SHAPE_HI[k] + 1e-9)
    }

    /// The sum of squared residuals at `p`, residual `i` multiplied by `w[i]` when weights are
    /// given (unweighted otherwise).
    fn cost(
        &self,
        th: &[f64; 5],
        geo: &Geometry,
        delta: &[f64],
        w: Option<&[f64]>,
        p: [f64; 3],
        r2: &mut [f64],
    ) -> f64 {
        geo.rho2(p[0], p[1], r2);
        let f = p[2].exp();
        (0..delta.len())
            .map(|i| {
                let r = delta[i] - self.gains[i] * unit(th, r2[i], f);
                w.map_or(r, |w| w[i] * r).powi(2)
            })
            .sum()
    }

    /// The inversion's residual weights for the changes `delta`: `1/√(s₀² + (rᵢ Δᵢ)²)` with
    /// `s₀` = [`INVERT_NOISE_COUNTS`] and `rᵢ` the gain doubts ([`gain_rel_sd`](Self::gain_rel_sd));
    /// `None` (the unweighted cost) without doubts or with doubts of another length.
    pub fn residual_weights(&self, delta: &[f64]) -> Option<Vec<f64>> {
        let s0 = INVERT_NOISE_COUNTS;
        self.gain_rel_sd
            .as_ref()
            .filter(|r| r.len() == delta.len())
            .map(|r| delta.iter().zip(r).map(|(d, r)| 1.0 / (s0 * s0 + (r * d).powi(2)).sqrt()).collect())
    }

    /// The contact `(x, y, F)` (mm, mm, N) that best explains the changes `delta`: `None` with
    /// a non-finite change or a taxel count other than the model's; `F` = 0 (at the centre of
    /// the layout) when nothing changed. With [`gain_rel_sd`](Self::gain_rel_sd), residual `i`
    /// is weighted by `1/√(s₀² + (rᵢ Δᵢ)²)` in both the coarse search and the
    /// Levenberg–Marquardt steps; without it (or with one of another length) unweighted. See
    /// the [module docs](self).
    pub fn invert(&self, geo: &Geometry, delta: &[f64]) -> Option<[f64; 3]> {
        let n = self.gains.len();
        if delta.len() != n || geo.len() != n || delta.iter().any(|d| !d.is_finite()) {
            return None;
        }
        let Some(c) = geo.centroid(delta) else {
            let b = geo.bounds;
            return Some([0.5 * (b[0] + b[1]), 0.5 * (b[2] + b[3]), 0.0]);
        };
        let th = self.shape_numbers();
        let mut r2 = vec![0.0; n];
        let (lo, hi) = (F_RANGE_N[0].ln(), F_RANGE_N[1].ln());
        // the gain-doubt weights (none: the unweighted cost, untouched)
        let sw = self.residual_weights(delta);
        let w = sw.as_deref();
        let cost = |p: [f64; 3], r2: &mut [f64]| self.cost(&th, geo, delta, w, p, r2);
        // residual i's weight (1: unweighted, exactly)
        let wi = |i: usize| w.map_or(1.0, |w| w[i]);
        // coarse search over ln F at the centroid
        let mut best = (f64::INFINITY, [c[0], c[1], 0.0]);
        for k in 0..=24 {
            let lf = -4.0 + 8.0 * k as f64 / 24.0;
            let p = [c[0], c[1], lf];
            let e = cost(p, &mut r2);
            if e < best.0 {
                best = (e, p);
            }
        }
        let (mut e, mut p) = best;
        let mut lambda = 1e-3;
        let mut jac = vec![[0.0f64; 3]; n];
        let mut res = vec![0.0; n];
        for _ in 0..INVERT_ITERATIONS {
            // residuals and forward-difference Jacobian
            let model = |q: [f64; 3], r2: &mut [f64], out: &mut [f64]| {
                geo.rho2(q[0], q[1], r2);
                let f = q[2].exp();
                for i in 0..n {
                    out[i] = self.gains[i] * unit(&th, r2[i], f);
                }
            };
            let mut m0 = vec![0.0; n];
            model(p, &mut r2, &mut m0);
            for i in 0..n {
                res[i] = (delta[i] - m0[i]) * wi(i);
            }
            let steps = [1e-4, 1e-4, 1e-5];
            let mut mk = vec![0.0; n];
            for (k, h) in steps.iter().enumerate() {
                let mut q = p;
                q[k] += h;
                model(q, &mut r2, &mut mk);
                for i in 0..n {
                    jac[i][k] = (mk[i] - m0[i]) / h * wi(i);
                }
            }
            let mut a = [[0.0; 3]; 3];
            let mut g = [0.0; 3];
            for i in 0..n {
                for u in 0..3 {
                    g[u] += jac[i][u] * res[i];
                    for v in 0..3 {
                        a[u][v] += jac[i][u] * jac[i][v];
                    }
                }
            }
            let mut improved = false;
            for _ in 0..8 {
                let mut m = a;
                for (u, row) in m.iter_mut().enumerate() {
                    row[u] += lambda * (a[u][u] + 1e-12);
                }
                let Some(step) = solve3(m, g) else { break };
                let (x, y) = geo.clamp(p[0] + step[0], p[1] + step[1]);
                let q = [x, y, (p[2] + step[2]).clamp(lo, hi)];
                let eq = cost(q, &mut r2);
                if eq < e {
                    let small = (eq - e).abs() <= 1e-10 * e.max(1e-300);
                    p = q;
                    e = eq;
                    lambda = (lambda * 0.3).max(1e-9);
                    improved = !small;
                    break;
                }
                lambda *= 10.0;
            }
            if !improved {
                break;
            }
        }
        Some([p[0], p[1], p[2].exp().clamp(F_RANGE_N[0], F_RANGE_N[1])])
    }
}

/// Solve the 3 × 3 system `a x = b` (Gaussian elimination with partial pivoting).
#[allow(clippy::needless_range_loop)]
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let mut m = [[0.0; 4]; 3];
    for i in 0..3 {
        m[i][..3].copy_from_slice(&a[i]);
        m[i][3] = b[i];
    }
    for c in 0..3 {
        let piv = (c..3).max_by(|&i, &j| m[i][c].abs().total_cmp(&m[j][c].abs()))?;
        if m[piv][c].is_nan() || m[piv][c].abs() <= 1e-300 {
            return None;
        }
        m.swap(c, piv);
        for r in 0..3 {
            if r != c {
                let f = m[r][c] / m[c][c];
                for k in c..4 {
                    m[r][k] -= f * m[c][k];
                }
            }
        }
    }
    let x = [m[0][3] / m[0][0], m[1][3] / m[1][1], m[2][3] / m[2][2]];
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Solve the symmetric `k × k` system `a x = b` by Cholesky (row-major; `None` if not
/// positive definite).
fn solve_spd(mut a: Vec<f64>, b: &[f64], k: usize) -> Option<Vec<f64>> {
    crate::force_model::cholesky_solve(&mut a, b, k).filter(|y| y.iter().all(|v| v.is_finite()))
}

/// Identify the forward model from calibration frames `(Δ, F)` (changes in counts, gauge
/// force in N) on the electrodes of `geo` (see the [module docs](self)). `None` when fewer
/// than 10 usable frames (finite, `F` ≥ [`MIN_FORCE_N`], some change) remain or the fit
/// fails.
pub fn identify(geo: &Geometry, frames: &[(&[f64], f64, usize)]) -> Option<ForwardModel> {
    identify_with(geo, frames, Starts::Single)
}

/// Where [`identify_with`] starts the shape fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Starts {
    /// One start, `(γ, s, w)` = (0.75, 0.2, 3 mm) (session 31).
    Single,
    /// Every start of [`MULTI_STARTS`]; the identification with the lowest cost (weighted
    /// squared residual) is kept.
    Multi,
}

/// The multi-start grid `(γ, w mm)` (`s` starts at 0.2, `a` at 0): a narrow kernel moves one or
/// two electrodes per press, and from one start the width, spread growth and `γ` can trade
/// into a wrong minimum (`examples/force_parts/history.md`, member 700).
pub const MULTI_STARTS: [[f64; 2]; 6] = [[0.6, 1.5], [0.9, 1.5], [0.6, 3.0], [0.9, 3.0], [0.6, 6.0], [0.9, 6.0]];

/// [`identify`] from `starts`.
pub fn identify_with(geo: &Geometry, frames: &[(&[f64], f64, usize)], starts: Starts) -> Option<ForwardModel> {
    match starts {
        Starts::Single => identify_from(geo, frames, ROUNDS, [0.75, 0.2, 3f64.ln(), 2.0, 0.0]).map(|r| r.0),
        Starts::Multi => MULTI_STARTS
            .iter()
            .filter_map(|st| identify_from(geo, frames, ROUNDS, [st[0], 0.2, st[1].ln(), 2.0, 0.0]))
            .filter(|r| r.1.is_finite())
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|r| r.0),
    }
}

/// [`identify`] with `rounds` alternation rounds (at least 1), from the single start.
pub fn identify_rounds(geo: &Geometry, frames: &[(&[f64], f64, usize)], rounds: usize) -> Option<ForwardModel> {
    identify_from(geo, frames, rounds, [0.75, 0.2, 3f64.ln(), 2.0, 0.0]).map(|r| r.0)
}

/// The identification from the shape numbers `start` `(γ, s, ln w, q, a)`: the model and its
/// final cost (the frames' weighted squared residual).
fn identify_from(
    geo: &Geometry,
    frames: &[(&[f64], f64, usize)],
    rounds: usize,
    start: [f64; 5],
) -> Option<(ForwardModel, f64)> {
    let n = geo.len();
    let usable: Vec<(&[f64], f64, usize)> = frames
        .iter()
        .filter(|(d, f, _)| {
            d.len() == n
                && f.is_finite()
                && *f >= MIN_FORCE_N
                && d.iter().all(|v| v.is_finite())
                && geo.centroid(d).is_some()
        })
        .copied()
        .collect();
    if usable.len() < 10 || n == 0 {
        return None;
    }
    let step = usable.len().div_ceil(MAX_FRAMES);
    let data: Vec<(&[f64], f64, usize)> = usable.into_iter().step_by(step).collect();
    let nf = data.len();
    let wf: Vec<f64> =
        data.iter().map(|(d, _, _)| 1.0 / d.iter().map(|v| v.abs()).fold(5.0, f64::max).powi(2)).collect();
    // one place per press: the frames of a group share it (the strongest frame's centroid to start)
    let mut presses: Vec<Vec<usize>> = Vec::new();
    for (k, fr) in data.iter().enumerate() {
        match presses.last_mut() {
            Some(v) if data[v[0]].2 == fr.2 => v.push(k),
            _ => presses.push(vec![k]),
        }
    }
    let mut place: Vec<[f64; 2]> = vec![[0.0; 2]; nf];
    for idx in &presses {
        let top = idx.iter().copied().max_by(|&a, &b| data[a].1.total_cmp(&data[b].1)).expect("a press has frames");
        let c = geo.centroid(data[top].0).expect("checked");
        for &k in idx {
            place[k] = c;
        }
    }
    let mut th = start;
    let mut gains = vec![-1.0; n];
    let mut cost = f64::INFINITY;
    let mut rel_sd = vec![PRIOR_REL_SD; n];
    let mut r2 = vec![0.0; n];
    // the unit responses m[f][i] at the current places and shape
    let units = |th: &[f64; 5], place: &[[f64; 2]], r2: &mut [f64]| -> Vec<f64> {
        let mut m = vec![0.0; nf * n];
        for (k, (p, (_, f, _))) in place.iter().zip(&data).enumerate() {
            geo.rho2(p[0], p[1], r2);
            for i in 0..n {
                m[k * n + i] = unit(th, r2[i], *f);
            }
        }
        m
    };
    for _round in 0..rounds.max(1) {
        // 1. gains in closed form, pulled toward the prior
        let m = units(&th, &place, &mut r2);
        let (mut num, mut den) = (vec![0.0; n], vec![0.0; n]);
        for (k, (d, _, _)) in data.iter().enumerate() {
            for i in 0..n {
                num[i] += wf[k] * d[i] * m[k * n + i];
                den[i] += wf[k] * m[k * n + i] * m[k * n + i];
            }
        }
        let dmax = den.iter().copied().fold(0.0, f64::max);
        if !(dmax > 0.0 && dmax.is_finite()) {
            return None;
        }
        let free: Vec<f64> = (0..n).map(|i| if den[i] > 0.0 { num[i] / den[i] } else { 0.0 }).collect();
        let well: Vec<usize> = (0..n).filter(|&i| den[i] >= 0.2 * dmax).collect();
        let neg = well.iter().filter(|&&i| free[i] < 0.0).count();
        let sign = if 2 * neg >= well.len() { -1.0 } else { 1.0 };
        let mut mags: Vec<f64> = well.iter().map(|&i| free[i].abs()).collect();
        mags.sort_by(f64::total_cmp);
        let prior = sign * mags.get(mags.len() / 2).copied().unwrap_or(1.0);
        let lam = GAIN_PRIOR * dmax;
        // a well-excited electrode keeps its own sign under the prior
        let priors: Vec<f64> =
            (0..n).map(|i| if den[i] >= 0.2 * dmax && free[i] * prior < 0.0 { -prior } else { prior }).collect();
        for i in 0..n {
            gains[i] = (num[i] + lam * priors[i]) / (den[i] + lam);
            // the gain doubt: the prior's share in this gain × the prior's relative sd
            rel_sd[i] = PRIOR_REL_SD * lam / (den[i] + lam);
        }
        // 2. each frame's place (Levenberg–Marquardt on (x, y), a few iterations)
        let unit_model = ForwardModel {
            gains: gains.clone(),
            exponent: th[0],
            spread: th[1],
            width_mm: th[2].exp(),
            shape: th[3],
            lobe: th[4],
            gain_rel_sd: None,
        };
        for idx in &presses {
            let p = fit_place(&unit_model, &th, geo, &data, &wf, idx, place[idx[0]], &mut r2);
            for &k in idx {
                place[k] = p;
            }
        }
        // 3. the shape numbers: Levenberg–Marquardt (forward differences) on the residuals with
        // the gains re-solved in closed form at every trial (variable projection: a gain and
        // the exponent trade, so holding the gains would crawl)
        let project = |t: &[f64; 5], r2: &mut [f64]| -> (Vec<f64>, Vec<f64>) {
            let m = units(t, &place, r2);
            let (mut num, mut den): (Vec<f64>, Vec<f64>) = (priors.iter().map(|p| lam * p).collect(), vec![lam; n]);
            for (k, (d, _, _)) in data.iter().enumerate() {
                for i in 0..n {
                    num[i] += wf[k] * d[i] * m[k * n + i];
                    den[i] += wf[k] * m[k * n + i] * m[k * n + i];
                }
            }
            let g: Vec<f64> = num.iter().zip(&den).map(|(a, b)| a / b).collect();
            let mut r = Vec::with_capacity(nf * n);
            for (k, (d, _, _)) in data.iter().enumerate() {
                let sw = wf[k].sqrt();
                for i in 0..n {
                    r.push(sw * (d[i] - g[i] * m[k * n + i]));
                }
            }
            (r, g)
        };
        let sq = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
        let (mut r0, mut g0) = project(&th, &mut r2);
        let mut e = sq(&r0);
        let mut lambda = 1e-3;
        for _ in 0..6 {
            let mut jac = vec![[0.0f64; 5]; nf * n];
            for c in 0..5 {
                if FIXED[c] {
                    continue;
                }
                // step inward at an upper bound
                let h = if th[c] + 1e-5 > SHAPE_HI[c] { -1e-5 } else { 1e-5 };
                let mut t = th;
                t[c] += h;
                let (rk, _) = project(&t, &mut r2);
                for j in 0..nf * n {
                    jac[j][c] = -(rk[j] - r0[j]) / h;
                }
            }
            let (mut a, mut g) = (vec![0.0; 25], vec![0.0; 5]);
            for (j, row) in jac.iter().enumerate() {
                for u in 0..5 {
                    g[u] += row[u] * r0[j];
                    for v in 0..5 {
                        a[u * 5 + v] += row[u] * row[v];
                    }
                }
            }
            for u in 0..5 {
                if FIXED[u] {
                    a[u * 5 + u] = 1.0;
                    g[u] = 0.0;
                }
            }
            let mut accepted = false;
            for _ in 0..8 {
                let mut ml = a.clone();
                for u in 0..5 {
                    ml[u * 5 + u] += lambda * (a[u * 5 + u] + 1e-12);
                }
                let Some(st) = solve_spd(ml, &g, 5) else {
                    lambda *= 10.0;
                    continue;
                };
                let mut t = th;
                for u in 0..5 {
                    t[u] = (th[u] + st[u]).clamp(SHAPE_LO[u], SHAPE_HI[u]);
                }
                let (rt, gt) = project(&t, &mut r2);
                let et = sq(&rt);
                if et < e {
                    th = t;
                    e = et;
                    r0 = rt;
                    g0 = gt;
                    lambda = (lambda * 0.3).max(1e-9);
                    accepted = true;
                    break;
                }
                lambda *= 10.0;
            }
            if !accepted {
                break;
            }
        }
        gains = g0;
        cost = e;
    }
    let model = ForwardModel {
        gains,
        exponent: th[0],
        spread: th[1],
        width_mm: th[2].exp(),
        shape: th[3],
        lobe: th[4],
        gain_rel_sd: Some(rel_sd),
    };
    model.is_valid().then_some((model, cost))
}

/// One press's place (the frames `idx` of `data`, their forces known): Levenberg–Marquardt on
/// `(x, y)` from `start`, each frame weighted by `wf`.
#[allow(clippy::too_many_arguments)]
fn fit_place(
    model: &ForwardModel,
    th: &[f64; 5],
    geo: &Geometry,
    data: &[(&[f64], f64, usize)],
    wf: &[f64],
    idx: &[usize],
    start: [f64; 2],
    r2: &mut [f64],
) -> [f64; 2] {
    let n = geo.len();
    let cost = |p: [f64; 2], r2: &mut [f64]| -> f64 {
        idx.iter().map(|&k| wf[k] * model.cost(th, geo, data[k].0, None, [p[0], p[1], data[k].1.ln()], r2)).sum()
    };
    let mut p = start;
    let mut e = cost(p, r2);
    let mut lambda = 1e-3;
    let mut m0 = vec![0.0; n];
    let mut mk = vec![0.0; n];
    for _ in 0..6 {
        let (mut a, mut g) = ([[0.0; 2]; 2], [0.0; 2]);
        for &k in idx {
            let (d, f, _) = data[k];
            let eval = |q: [f64; 2], r2: &mut [f64], out: &mut [f64]| {
                geo.rho2(q[0], q[1], r2);
                for i in 0..n {
                    out[i] = model.gains[i] * unit(th, r2[i], f);
                }
            };
            eval(p, r2, &mut m0);
            let mut jac = vec![[0.0f64; 2]; n];
            for c in 0..2 {
                let mut q = p;
                q[c] += 1e-4;
                eval(q, r2, &mut mk);
                for i in 0..n {
                    jac[i][c] = (mk[i] - m0[i]) / 1e-4;
                }
            }
            for i in 0..n {
                let r = d[i] - m0[i];
                for u in 0..2 {
                    g[u] += wf[k] * jac[i][u] * r;
                    for v in 0..2 {
                        a[u][v] += wf[k] * jac[i][u] * jac[i][v];
                    }
                }
            }
        }
        let mut accepted = false;
        for _ in 0..8 {
            let (a00, a11) = (a[0][0] * (1.0 + lambda) + 1e-12, a[1][1] * (1.0 + lambda) + 1e-12);
            let det = a00 * a11 - a[0][1] * a[1][0];
            if det.is_nan() || det.abs() <= 1e-300 {
                break;
            }
            let s = [(g[0] * a11 - a[0][1] * g[1]) / det, (a00 * g[1] - a[1][0] * g[0]) / det];
            let (x, y) = geo.clamp(p[0] + s[0], p[1] + s[1]);
            let eq = cost([x, y], r2);
            if eq.is_finite() && eq < e {
                p = [x, y];
                e = eq;
                lambda = (lambda * 0.3).max(1e-9);
                accepted = true;
                break;
            }
            lambda *= 10.0;
        }
        if !accepted {
            break;
        }
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use gradtac_stream::Layout;

    fn truth() -> ForwardModel {
        // signed gains: most fall under pressure, three rise; magnitudes vary ±30 %
        let gains = (0..24)
            .map(|i| {
                let m = 80.0 * (1.0 + 0.3 * ((i as f64) * 1.7).sin());
                if [4, 11, 19].contains(&i) {
                    m
                } else {
                    -m
                }
            })
            .collect();
        ForwardModel { gains, exponent: 0.7, spread: 0.25, width_mm: 3.2, shape: 2.0, lobe: 0.3, gain_rel_sd: None }
    }

    /// Noise-free frames of `m`: a ramp 0.3..9 N at each place.
    fn frames(m: &ForwardModel, geo: &Geometry, places: &[[f64; 2]]) -> Vec<(Vec<f64>, f64)> {
        let mut out = Vec::new();
        for p in places {
            for k in 0..40 {
                let f = 0.3 + 8.7 * k as f64 / 39.0;
                out.push((m.predict(geo, p[0], p[1], f), f));
            }
        }
        out
    }

    /// `(x, y, F)` of [`without_gain_doubts_the_readings_are_bit_identical_to_before`]'s four
    /// frames, as `f64::to_bits`, from commit `caedfbc` (before the gain doubts).
    const PINNED_BITS: [u64; 12] = [
        13805334404179181193,
        13793873050940861723,
        4613885746348040608,
        4617361560907407107,
        4614087124365150373,
        4609470529575088640,
        13841787608226489418,
        13839626669915833228,
        4618416595129096952,
        13825640083153166184,
        4619123701884386576,
        4594756959140405035,
    ];

    const PLACES: [[f64; 2]; 6] = [[-6.0, -4.0], [5.0, 3.0], [0.0, 0.0], [-3.0, 5.0], [7.0, -3.0], [-9.0, 1.0]];

    #[test]
    fn identification_recovers_its_own_model_without_noise() {
        let geo = Geometry::for_positions(Layout::biotac_sp().positions());
        let t = truth();
        let data = frames(&t, &geo, &PLACES);
        let refs: Vec<(&[f64], f64, usize)> =
            data.iter().enumerate().map(|(k, (d, f))| (d.as_slice(), *f, k / 40)).collect();
        let m = identify_rounds(&geo, &refs, 40).expect("identified");
        assert!((m.exponent - t.exponent).abs() < 0.02, "γ {}", m.exponent);
        assert!((m.spread - t.spread).abs() < 0.03, "s {}", m.spread);
        assert!((m.width_mm / t.width_mm - 1.0).abs() < 0.03, "w {}", m.width_mm);
        assert!((m.lobe - t.lobe).abs() < 0.05, "a {}", m.lobe);
        // every electrode a calibration press moved by half the strongest electrode's peak: its
        // gain within 10 % (the prior pulls every gain a little toward the median, by design)
        let mut peak = [0.0f64; 24];
        for (d, _) in &data {
            for i in 0..24 {
                peak[i] = peak[i].max(d[i].abs());
            }
        }
        let top = peak.iter().copied().fold(0.0, f64::max);
        for i in (0..24).filter(|&i| peak[i] > 0.5 * top) {
            assert!((m.gains[i] / t.gains[i] - 1.0).abs() < 0.1, "gain {i}: {} vs {}", m.gains[i], t.gains[i]);
        }
        // the gain doubts: one per taxel, within [0, PRIOR_REL_SD]; a well-excited electrode's small
        let r = m.gain_rel_sd.as_ref().expect("identification stores the gain doubts");
        assert_eq!(r.len(), 24);
        assert!(r.iter().all(|v| (0.0..=PRIOR_REL_SD).contains(v)), "{r:?}");
        for i in (0..24).filter(|&i| peak[i] > 0.5 * top) {
            assert!(r[i] < 0.1 * PRIOR_REL_SD, "electrode {i}: r {}", r[i]);
        }
        // and the (weighted) inversion gives back each frame's force, as the unweighted one does
        let bare = ForwardModel { gain_rel_sd: None, ..m.clone() };
        for (d, f) in data.iter().step_by(7) {
            let p = m.invert(&geo, d).unwrap();
            assert!((p[2] / f - 1.0).abs() < 0.05, "F {} vs {f}", p[2]);
            let q = bare.invert(&geo, d).unwrap();
            assert!((q[2] / f - 1.0).abs() < 0.05, "unweighted F {} vs {f}", q[2]);
        }
    }

    /// An electrode under the press whose gain is the prior's, and wrong (half its true gain):
    /// with its doubt stored the weighted inversion reads the force closer to the truth than the
    /// unweighted one, which the wrong gain drags.
    #[test]
    fn a_wrong_prior_gain_under_the_press_no_longer_drags_the_force() {
        let geo = Geometry::for_positions(Layout::biotac_sp().positions());
        let t = truth();
        for (place, f) in [([0.0, 0.0], 3.0), ([5.0, 3.0], 1.5), ([-6.0, -4.0], 6.0)] {
            let d = t.predict(&geo, place[0], place[1], f);
            let k = (0..24).max_by(|&a, &b| d[a].abs().total_cmp(&d[b].abs())).unwrap();
            let mut gains = t.gains.clone();
            gains[k] *= 0.5;
            let mut r = vec![0.0; 24];
            r[k] = PRIOR_REL_SD;
            let weighted = ForwardModel { gains: gains.clone(), gain_rel_sd: Some(r), ..t.clone() };
            let bare = ForwardModel { gains, gain_rel_sd: None, ..t.clone() };
            let fw = weighted.invert(&geo, &d).unwrap()[2];
            let fb = bare.invert(&geo, &d).unwrap()[2];
            let (ew, eb) = ((fw / f - 1.0).abs(), (fb / f - 1.0).abs());
            assert!(ew < eb, "at {place:?} ({f} N, electrode {k}): weighted {fw} ({ew}), unweighted {fb} ({eb})");
            assert!(eb > 0.05, "the wrong gain drags the unweighted force: {fb} vs {f}");
        }
    }

    /// Without gain doubts (a version-4 file) the inversion is the unweighted one of before
    /// round 10, bit for bit: readings pinned from commit `caedfbc`'s `invert`.
    #[test]
    fn without_gain_doubts_the_readings_are_bit_identical_to_before() {
        let geo = Geometry::for_positions(Layout::biotac_sp().positions());
        let t = truth();
        let mut got = Vec::new();
        for (place, f) in [([0.0, 0.0], 3.0), ([5.0, 3.0], 1.5), ([-6.0, -4.0], 6.0), ([8.0, 8.0], 0.4)] {
            let mut d = t.predict(&geo, place[0], place[1], f);
            for (i, v) in d.iter_mut().enumerate() {
                *v += 2.0 * ((i as f64) * 0.9).sin();
            }
            let p = t.invert(&geo, &d).unwrap();
            got.extend(p.iter().map(|v| v.to_bits()));
        }
        assert_eq!(got, PINNED_BITS.to_vec(), "{got:?}");
    }

    /// Member 700's shape numbers — a narrow kernel (1.6 mm: each press moves one or two
    /// electrodes), weak gains (≈ 30 counts at 2 N), one of the other sign, 3 counts of noise:
    /// the multi-start identification recovers them, and it is the lowest-cost start's.
    #[test]
    fn multi_start_identifies_a_narrow_noisy_kernel_and_keeps_the_lowest_cost() {
        let geo = Geometry::for_positions(Layout::biotac_sp().positions());
        let places = [[-6.5, -3.0], [4.0, 2.5], [1.0, -1.0], [-2.5, 5.5], [7.0, -4.0]];
        let gains: Vec<f64> =
            (0..24).map(|i| if i == 4 { 30.0 } else { -30.0 * (1.0 + 0.3 * ((i as f64) * 1.3).sin()) }).collect();
        let t = ForwardModel {
            gains,
            exponent: 0.57,
            spread: 0.22,
            width_mm: 1.6,
            shape: 2.0,
            lobe: 0.4,
            gain_rel_sd: None,
        };
        let mut data = frames(&t, &geo, &places);
        let mut seed = 12345u64;
        for (d, _) in data.iter_mut() {
            for v in d.iter_mut() {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                *v += 3.0 * 1.7 * (((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0);
            }
        }
        let refs: Vec<(&[f64], f64, usize)> =
            data.iter().enumerate().map(|(k, (d, f))| (d.as_slice(), *f, k / 40)).collect();
        let runs: Vec<(ForwardModel, f64)> = MULTI_STARTS
            .iter()
            .filter_map(|st| identify_from(&geo, &refs, ROUNDS, [st[0], 0.2, st[1].ln(), 2.0, 0.0]))
            .collect();
        assert_eq!(runs.len(), MULTI_STARTS.len());
        let best = runs.iter().min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
        let m = identify_with(&geo, &refs, Starts::Multi).expect("identified");
        assert_eq!(&m, &best.0, "the lowest-cost start is kept");
        assert!((m.exponent - 0.57).abs() < 0.03, "γ {}", m.exponent);
        assert!((m.spread - 0.22).abs() < 0.03, "s {}", m.spread);
        assert!((m.width_mm / 1.6 - 1.0).abs() < 0.05, "w {}", m.width_mm);
        let wrong = (0..24).filter(|&i| m.gains[i] * t.gains[i] < 0.0).count();
        assert_eq!(wrong, 0, "gains {:?}", m.gains);
    }

    #[test]
    fn a_force_at_a_place_no_calibration_press_visited() {
        let geo = Geometry::for_positions(Layout::biotac_sp().positions());
        // equal gain magnitudes: what the prior assumes for an electrode never excited
        let t = ForwardModel { gains: vec![-70.0; 24], ..truth() };
        let data = frames(&t, &geo, &PLACES[..5]);
        let refs: Vec<(&[f64], f64, usize)> =
            data.iter().enumerate().map(|(k, (d, f))| (d.as_slice(), *f, k / 40)).collect();
        let m = identify(&geo, &refs).expect("identified");
        for (place, f) in [([3.0, -5.0], 1.0), ([-9.0, 1.0], 4.0), ([2.0, 6.0], 8.0)] {
            let d = t.predict(&geo, place[0], place[1], f);
            let p = m.invert(&geo, &d).unwrap();
            assert!((p[2] / f - 1.0).abs() < 0.05, "at {place:?}: {} N for {f} N", p[2]);
            assert!((p[0] - place[0]).hypot(p[1] - place[1]) < 1.0, "place {p:?} for {place:?}");
        }
    }

    #[test]
    fn garbage_never_panics() {
        let geo = Geometry::for_positions(Layout::biotac_sp().positions());
        for r in [None, Some(vec![PRIOR_REL_SD; 24]), Some((0..24).map(|i| 0.0125 * i as f64).collect())] {
            garbage_never_panics_with(&geo, ForwardModel { gain_rel_sd: r, ..truth() });
        }
        // gain doubts of another length: skipped (unweighted), and not a valid model
        let odd = ForwardModel { gain_rel_sd: Some(vec![0.1; 5]), ..truth() };
        assert!(!odd.is_valid());
        let d = truth().predict(&geo, 1.0, 2.0, 2.5);
        assert_eq!(odd.invert(&geo, &d), truth().invert(&geo, &d));
        assert!(!ForwardModel { gain_rel_sd: Some(vec![f64::NAN; 24]), ..truth() }.is_valid());
    }

    fn garbage_never_panics_with(geo: &Geometry, m: ForwardModel) {
        let geo = geo.clone();
        let mut d = m.predict(&geo, 0.0, 0.0, 3.0);
        assert!(m.invert(&geo, &d).is_some());
        d[3] = f64::NAN;
        assert!(m.invert(&geo, &d).is_none());
        d[3] = f64::INFINITY;
        assert!(m.invert(&geo, &d).is_none());
        assert!(m.invert(&geo, &d[..5]).is_none());
        assert_eq!(m.invert(&geo, &[0.0; 24]).unwrap()[2], 0.0);
        // huge, tiny and wrong-signed changes: a force in range, no panic
        for scale in [1e300, 1e-300, -1e12, 5.0] {
            let d: Vec<f64> = (0..24).map(|i| scale * ((i as f64) - 11.5)).collect();
            let p = m.invert(&geo, &d).unwrap();
            assert!(p[2].is_finite() && p[2] >= F_RANGE_N[0] && p[2] <= F_RANGE_N[1], "{p:?}");
        }
        // identification refuses what it cannot use
        let bad: Vec<Vec<f64>> = vec![vec![f64::NAN; 24], vec![0.0; 24], vec![1.0; 3]];
        let refs: Vec<(&[f64], f64, usize)> = bad.iter().map(|d| (d.as_slice(), 2.0, 0)).collect();
        assert!(identify(&geo, &refs).is_none());
        assert!(identify(&geo, &[]).is_none());
        // constant changes on every electrode with varied forces: a valid model or none
        let flat: Vec<Vec<f64>> = (0..30).map(|k| vec![-(k as f64 + 1.0); 24]).collect();
        let refs: Vec<(&[f64], f64, usize)> =
            flat.iter().enumerate().map(|(k, d)| (d.as_slice(), 0.5 + k as f64, 0)).collect();
        if let Some(m) = identify(&geo, &refs) {
            assert!(m.is_valid());
        }
        // an empty geometry
        assert!(Geometry::for_positions(&[]).is_empty());
    }

    /// A poorly-excited electrode (a gain near 0, or of the wrong sign, as a calibration that
    /// never pressed near it can leave) under an out-of-range frame: the force stays in
    /// [`F_RANGE_N`], finite, with no panic.
    #[test]
    fn a_poorly_excited_electrode_gives_a_bounded_force() {
        let geo = Geometry::for_positions(Layout::biotac_sp().positions());
        for g in [1e-9, 0.0, 3.0, -1e-12] {
            let mut m = truth();
            m.gains[7] = g;
            for scale in [1.0, 1e3, 1e9, -1e9] {
                let mut d = vec![0.0; 24];
                d[7] = -60.0 * scale;
                let p = m.invert(&geo, &d).unwrap();
                assert!(p.iter().all(|v| v.is_finite()), "{p:?}");
                assert!(p[2] >= F_RANGE_N[0] && p[2] <= F_RANGE_N[1], "gain {g}, scale {scale}: {p:?}");
            }
        }
    }
}
