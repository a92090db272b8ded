//! A learned correction of the model fit's position bias (`[stages.locate]
//! fit_learned_correction = true`, issue #22, round 6).
//!
//! # What it does
//! The fit ([`crate::fit`]) explains the electrodes' changes by one kernel shape; on a sensor
//! whose response is another shape (a difference of Gaussians, an exponential) its position is
//! biased by an amount that depends on where the contact sits between electrodes and on the
//! shape — the one-term budget of `docs/tradeoff.md` puts 0.020 of the width's 0.032 there.
//! This module learns that bias: per fitted frame, a fixed vector of [`INPUTS`] numbers —
//!
//! - the fitted position, scaled to `[−1, 1]` over the layout's extent (2);
//! - the fitted log-spread, far-lobe weight and relative residual (3);
//! - the velocity (÷ 30 mm/s) of the fit's last raw positions in this contact (least squares
//!   over `fit_velocity_frames`, before the current frame; 0 at a contact's start) (2);
//! - the **amplitude-normalised, gain-corrected changes** `nᵢ = (Δᵢ/gᵢ) / maxⱼ|Δⱼ/gⱼ|` (24);
//! - the **residual pattern** `nᵢ − Â·Kᵢ` (the fit's kernel at the solution, amplitude in the
//!   same units) (24);
//!
//! (each clamped to ±3, electrodes left out of the fit at 0). The fit records [`GAIN_INPUTS`]
//! more after these ([`gain_inputs`]: the learned log-gains and the self-calibration's
//! shrinkage), which only weights trained with them read (round 8's candidate C; the shipped
//! weights read the 55 above). The vector is standardised and mapped to a
//! correction `(δx, δy)` mm by ridge regression on `1 + INPUTS + RANDOM` terms: a constant,
//! the inputs, and [`RANDOM`] random cosine features `√(2/R)·cos(ωₖ·z + bₖ)` whose
//! frequencies are drawn from a fixed seed ([`SEED`]; position dimensions at bandwidth
//! `bandwidth[0]`, the others at `bandwidth[1] / √(INPUTS − 2)`). The correction
//! is clamped to [`MAX_CORRECTION_MM`] and added to the fit's raw position, before the lag lead, the
//! motion prior and the position memory (which see the corrected point). The fit itself —
//! its warm start, gains and shape learning — never sees the correction.
//!
//! # Training (what it was tuned on)
//! `examples/train_fit_correction.rs` writes the weights file `fit_learned_weights.rs`
//! deterministically: simulated recordings of [`sim_family`](crate::sim_family)'s **tuning**
//! physics only (no Mexican hat, lags ≤ 30 ms) at seeds 10 000+ (training) and 20 000+
//! (validation for the ridge's λ and bandwidths), disjoint from the tuning members (seeds 0–7)
//! and the held-out members (100–115). The samples come from the `accurate` preset's fit (since
//! round 10: the lag estimated online and the folded kernel behind its 2 mm ring-fit guard), so
//! the shipped weights belong to that fit; on another fit they read inputs they were not
//! trained on. [`Design`] accumulates the regression per subset of the samples, which
//! `examples/fit_lopo.rs` uses to re-train without one physics group at a time
//! (`examples/fit_parts/history.md`, round 10). The target of a frame is the truth at the frame's
//! middle time minus the fit's raw position (`train_fit_correction`'s default; `--lagged`
//! subtracts the member's lag first), so the correction also takes up part of the lag — the
//! part that round 10's leave-one-physics-out view found does not carry to lags it was not
//! trained on, which is why the preset now undoes the lag by its online estimate.
//!
//! # Limits
//! Trained on the built-in BioTac SP layout: on any other layout the fit does not apply it. A learned model knows only the physics it was shown; `docs/tradeoff.md`
//! (round 6) reports it on held-out physics (the Mexican hat, longer lags) and on the real
//! recordings (`examples/locate_dos.rs`). Cost: one `RANDOM × INPUTS` product and `RANDOM`
//! cosines per fitted frame.

use crate::splitmix::SplitMix;
use crate::{Error, Result};

/// Number of inputs per frame (see the module docs).
pub const INPUTS: usize = 7 + 2 * 24;
/// Number of optional inputs telling how far the gains are learned (round 8, candidate C):
/// per electrode the learned log-gain and the self-calibration's shrinkage
/// `Σ w m² / (Σ w m² + prior)` ([`gain_inputs`]). Weights trained with them have
/// [`INPUTS_WITH_GAINS`] means; the shipped weights have [`INPUTS`].
pub const GAIN_INPUTS: usize = 48;
/// [`INPUTS`] and the [`GAIN_INPUTS`]: the size of the fit's recorded input vector.
pub const INPUTS_WITH_GAINS: usize = INPUTS + GAIN_INPUTS;
/// Number of random cosine features.
pub const RANDOM: usize = 256;
/// Number of regression terms: a constant, the inputs, the cosines.
pub const TERMS: usize = 1 + INPUTS + RANDOM;

/// Number of regression terms for `n` inputs.
fn terms_for(n: usize) -> usize {
    1 + n + RANDOM
}

/// Whether `n` is an input count weights may have ([`INPUTS`] or [`INPUTS_WITH_GAINS`]).
fn known_inputs(n: usize) -> bool {
    n == INPUTS || n == INPUTS_WITH_GAINS
}
/// Seed of the random features' frequencies and phases.
pub const SEED: u64 = 0x22_6C_65_61_72_6E;
/// Largest correction applied (mm).
pub const MAX_CORRECTION_MM: f64 = 2.0;

mod weights {
    include!("fit_learned_weights.rs");
}

/// The trained weights as the generated file holds them.
#[derive(Clone, Debug, PartialEq)]
pub struct Trained {
    /// Input means (standardisation).
    pub mean: Vec<f64>,
    /// Input standard deviations (standardisation; > 0).
    pub scale: Vec<f64>,
    /// Bandwidths of the random features: position dimensions, the rest.
    pub bandwidth: [f64; 2],
    /// Ridge weights per axis (x, y), [`TERMS`] each (`1 + n + RANDOM` for `n` inputs).
    pub w: [Vec<f64>; 2],
    /// The ridge penalty the weights were fitted with (reported only).
    pub lambda: f64,
}

impl Trained {
    /// The weights shipped in the library (`fit_learned_weights.rs`).
    pub fn builtin() -> Trained {
        Trained {
            mean: weights::MEAN.to_vec(),
            scale: weights::SCALE.to_vec(),
            bandwidth: weights::BANDWIDTH,
            w: [weights::WX.to_vec(), weights::WY.to_vec()],
            lambda: weights::LAMBDA,
        }
    }

    /// Rust source of the weights file (what the training example writes).
    pub fn to_rust(&self, provenance: &str) -> String {
        let arr = |v: &[f64]| v.iter().map(|x| format!("{x:e}")).collect::<Vec<_>>().join(", ");
        let mut s = String::new();
        s.push_str("// @generated by `cargo run --release --example train_fit_correction` — do not edit.\n");
        for l in provenance.lines() {
            s.push_str(&format!("// {l}\n"));
        }
        s.push_str(&format!("pub(super) const LAMBDA: f64 = {:e};\n", self.lambda));
        s.push_str(&format!(
            "pub(super) const BANDWIDTH: [f64; 2] = [{:e}, {:e}];\n",
            self.bandwidth[0], self.bandwidth[1]
        ));
        s.push_str(&format!("pub(super) const MEAN: [f64; {}] = [{}];\n", self.mean.len(), arr(&self.mean)));
        s.push_str(&format!("pub(super) const SCALE: [f64; {}] = [{}];\n", self.scale.len(), arr(&self.scale)));
        s.push_str(&format!("pub(super) const WX: [f64; {}] = [{}];\n", self.w[0].len(), arr(&self.w[0])));
        s.push_str(&format!("pub(super) const WY: [f64; {}] = [{}];\n", self.w[1].len(), arr(&self.w[1])));
        s
    }
}

impl Trained {
    /// The weights from the text of a weights file ([`Trained::to_rust`]'s format); `None`
    /// when a constant is missing or does not parse, or when the file carries output limits
    /// (round 11's `CLAMP` / `NOVELTY` lists, since removed: such weights cannot be applied as
    /// trained; files whose lists are empty, as every shipped one, read as before). Sizes are
    /// checked by [`Correction::try_new`], not here.
    pub fn from_rust(src: &str) -> Option<Trained> {
        let body = |name: &str| -> Option<&str> {
            let line = src.lines().find(|l| l.contains(&format!("const {name}:")))?;
            let rhs = line[line.find('=')? + 1..].trim().trim_end_matches(';').trim();
            Some(rhs)
        };
        let list = |name: &str| -> Option<Vec<f64>> {
            let b = body(name)?;
            let inner = b.strip_prefix('[')?.strip_suffix(']')?;
            inner.split(',').map(|v| v.trim().parse().ok()).collect()
        };
        // round 11's output limits (removed): absent or empty lists only
        if ["CLAMP", "NOVELTY"]
            .iter()
            .any(|n| body(n).is_some_and(|b| b.trim_start_matches('[').trim_end_matches(']').trim() != ""))
        {
            return None;
        }
        let bw = list("BANDWIDTH")?;
        Some(Trained {
            mean: list("MEAN")?,
            scale: list("SCALE")?,
            bandwidth: [*bw.first()?, *bw.get(1)?],
            w: [list("WX")?, list("WY")?],
            lambda: body("LAMBDA")?.parse().ok()?,
        })
    }
}

/// The correction at inference: the trained weights and the random features' frequencies.
#[derive(Clone, Debug)]
pub struct Correction {
    t: Trained,
    /// `RANDOM × n` frequencies (`n` inputs), row-major, and `RANDOM` phases.
    omega: Vec<f64>,
    phase: Vec<f64>,
    z: Vec<f64>,
}

impl Correction {
    /// The correction from trained weights; an error when their sizes or values are not usable.
    pub fn try_new(t: Trained) -> Result<Correction> {
        let n = t.mean.len();
        let ok = known_inputs(n)
            && t.scale.len() == n
            && t.w.iter().all(|w| w.len() == terms_for(n) && w.iter().all(|v| v.is_finite()))
            && t.mean.iter().all(|v| v.is_finite())
            && t.scale.iter().all(|v| v.is_finite() && *v > 0.0)
            && t.bandwidth.iter().all(|v| v.is_finite() && *v >= 0.0);
        if !ok {
            return Err(Error::InvalidConfig {
                stage: "locate",
                reason: "the learned correction's weights have the wrong sizes or non-finite values".into(),
            });
        }
        let (omega, phase) = frequencies(t.bandwidth, n);
        Ok(Correction { t, omega, phase, z: vec![0.0; n] })
    }

    /// The library's shipped correction.
    pub fn builtin() -> Result<Correction> {
        Correction::try_new(Trained::builtin())
    }

    /// The weights.
    pub fn trained(&self) -> &Trained {
        &self.t
    }

    /// The number of inputs the weights read ([`INPUTS`] or [`INPUTS_WITH_GAINS`]).
    pub fn inputs(&self) -> usize {
        self.z.len()
    }

    /// The correction (mm; clamped to [`MAX_CORRECTION_MM`]) for one frame's inputs `x`
    /// ([`INPUTS`] values from [`inputs`], then the [`GAIN_INPUTS`] from [`gain_inputs`]; the
    /// weights read the first [`Correction::inputs`]); `[0, 0]` when `x` is shorter or
    /// anything is not finite.
    pub fn apply(&mut self, x: &[f64]) -> [f64; 2] {
        let n = self.z.len();
        if x.len() != INPUTS && x.len() != INPUTS_WITH_GAINS || x.len() < n {
            return [0.0, 0.0];
        }
        for (i, z) in self.z.iter_mut().enumerate() {
            *z = (x[i] - self.t.mean[i]) / self.t.scale[i];
        }
        let (wx, wy) = (&self.t.w[0], &self.t.w[1]);
        let (mut cx, mut cy) = (wx[0], wy[0]);
        for i in 0..n {
            cx += wx[1 + i] * self.z[i];
            cy += wy[1 + i] * self.z[i];
        }
        let norm = (2.0 / RANDOM as f64).sqrt();
        for k in 0..RANDOM {
            let row = &self.omega[k * n..(k + 1) * n];
            let mut a = self.phase[k];
            for (o, z) in row.iter().zip(&self.z) {
                a += o * z;
            }
            let f = norm * a.cos();
            cx += wx[1 + n + k] * f;
            cy += wy[1 + n + k] * f;
        }
        let m = cx.hypot(cy);
        if !m.is_finite() {
            return [0.0, 0.0];
        }
        if m > MAX_CORRECTION_MM {
            let s = MAX_CORRECTION_MM / m;
            [cx * s, cy * s]
        } else {
            [cx, cy]
        }
    }
}

/// The random features' frequencies (`RANDOM × n`, row-major, for `n` inputs) and phases,
/// from [`SEED`].
fn frequencies(bandwidth: [f64; 2], n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut rng = SplitMix::new(SEED);
    let other = bandwidth[1] / ((n - 2) as f64).sqrt();
    let mut omega = vec![0.0; RANDOM * n];
    let mut phase = vec![0.0; RANDOM];
    for k in 0..RANDOM {
        for i in 0..n {
            omega[k * n + i] = rng.normal() * if i < 2 { bandwidth[0] } else { other };
        }
        phase[k] = rng.range(0.0, std::f64::consts::TAU);
    }
    (omega, phase)
}

/// The regression terms of standardised inputs `z` (`n` values) into `out` (`1 + n + RANDOM`).
fn terms(z: &[f64], omega: &[f64], phase: &[f64], out: &mut [f64]) {
    let n = z.len();
    out[0] = 1.0;
    out[1..1 + n].copy_from_slice(z);
    let norm = (2.0 / RANDOM as f64).sqrt();
    for k in 0..RANDOM {
        let a = phase[k] + omega[k * n..(k + 1) * n].iter().zip(z).map(|(o, z)| o * z).sum::<f64>();
        out[1 + n + k] = norm * a.cos();
    }
}

/// One fitted frame's inputs into `out` ([`INPUTS`] values, see the module docs): fitted
/// position `pos` within `bounds` (x_min, x_max, y_min, y_max), log-spread `ln_w`, far lobe
/// `lobe`, relative residual, the raw positions' velocity `vel` (mm/s), amplitude `amp` (gain
/// units), and per electrode the change
/// `d`, gain `gain`, kernel at the solution `kk` and whether it was `used`. `false` (and
/// `out` untouched in part) when the sizes are not the BioTac SP's or nothing is finite.
#[allow(clippy::too_many_arguments)]
pub fn inputs(
    pos: [f64; 2],
    bounds: [f64; 4],
    ln_w: f64,
    lobe: f64,
    residual: f64,
    vel: [f64; 2],
    amp: f64,
    d: &[f64],
    gain: &[f64],
    kk: &[f64],
    used: impl Fn(usize) -> bool,
    out: &mut [f64],
) -> bool {
    let n = 24;
    if d.len() != n || gain.len() != n || kk.len() != n || out.len() != INPUTS {
        return false;
    }
    let c = |v: f64| if v.is_finite() { v.clamp(-3.0, 3.0) } else { 0.0 };
    let scale = |v: f64, lo: f64, hi: f64| if hi > lo { 2.0 * (v - lo) / (hi - lo) - 1.0 } else { 0.0 };
    out[0] = c(scale(pos[0], bounds[0], bounds[1]));
    out[1] = c(scale(pos[1], bounds[2], bounds[3]));
    out[2] = c(ln_w);
    out[3] = c(lobe);
    out[4] = c(residual);
    out[5] = c(vel[0] / 30.0);
    out[6] = c(vel[1] / 30.0);
    let corrected = |i: usize| d[i] / if gain[i].abs() > 0.2 { gain[i].abs() } else { 1.0 };
    let mut top: f64 = 0.0;
    for i in 0..n {
        if used(i) {
            top = top.max(corrected(i).abs());
        }
    }
    if !(top.is_finite() && top > 0.0) {
        return false;
    }
    let a = amp.abs() / top;
    for i in 0..n {
        let (v, r) = if used(i) {
            let v = corrected(i) / top;
            (v, v - a * kk[i])
        } else {
            (0.0, 0.0)
        };
        out[7 + i] = c(v);
        out[7 + n + i] = c(r);
    }
    true
}

/// The [`GAIN_INPUTS`] of one fitted frame into `out`: per electrode the learned log-gain
/// `ln|gᵢ|`, then the self-calibration's shrinkage `eᵢ / (eᵢ + prior)` of its evidence `eᵢ =
/// Σ w m²` (0 before any key, → 1 when the keys outweigh the prior); each clamped to ±3,
/// non-finite values at 0. `false` (nothing written) when the sizes are not 24 / 24 /
/// [`GAIN_INPUTS`].
pub fn gain_inputs(gain: &[f64], evidence: &[f64], prior: f64, out: &mut [f64]) -> bool {
    let n = 24;
    if gain.len() != n || evidence.len() != n || out.len() != GAIN_INPUTS {
        return false;
    }
    let c = |v: f64| if v.is_finite() { v.clamp(-3.0, 3.0) } else { 0.0 };
    for i in 0..n {
        out[i] = c(gain[i].abs().ln());
        let (e, p) = (evidence[i].max(0.0), prior.max(0.0));
        out[n + i] = if e + p > 0.0 { c(e / (e + p)) } else { 0.0 };
    }
    true
}

/// Ridge regression of targets `y` (mm, per sample) on the terms of inputs `x` (per sample,
/// [`INPUTS`] or [`INPUTS_WITH_GAINS`] each, the same for all) with penalty `lambda` (per sample, on standardised terms) and random
/// features at `bandwidth`: the trained weights, or `None` if the system is singular.
pub fn train(x: &[Vec<f64>], y: &[[f64; 2]], lambda: f64, bandwidth: [f64; 2]) -> Option<Trained> {
    train_path(x, y, &[lambda], bandwidth).pop().flatten()
}

/// [`train`] at every penalty of `lambdas` (one pass over the samples): one entry per penalty.
pub fn train_path(x: &[Vec<f64>], y: &[[f64; 2]], lambdas: &[f64], bandwidth: [f64; 2]) -> Vec<Option<Trained>> {
    let m = x.len();
    let n = x.first().map_or(0, |s| s.len());
    if m == 0 || y.len() != m || !known_inputs(n) || x.iter().any(|s| s.len() != n) {
        return lambdas.iter().map(|_| None).collect();
    }
    let (mean, scale) = standardisation(x);
    let Some(mut d) = Design::new(mean, scale, bandwidth) else {
        return lambdas.iter().map(|_| None).collect();
    };
    for (s, yy) in x.iter().zip(y) {
        d.add(s, *yy);
    }
    d.solve(lambdas)
}

/// The standardisation [`train`] uses for samples `x` (all of one length): per input the mean
/// and the standard deviation (at least 1e-6).
pub fn standardisation(x: &[Vec<f64>]) -> (Vec<f64>, Vec<f64>) {
    let m = x.len();
    let n = x.first().map_or(0, |s| s.len());
    let mut mean = vec![0.0; n];
    for s in x {
        for i in 0..n {
            mean[i] += s[i] / m as f64;
        }
    }
    let mut scale = vec![0.0; n];
    for s in x {
        for i in 0..n {
            scale[i] += (s[i] - mean[i]).powi(2) / m as f64;
        }
    }
    scale.iter_mut().for_each(|v| *v = v.sqrt().max(1e-6));
    (mean, scale)
}

/// The ridge regression's normal equations, accumulated sample by sample under a fixed
/// standardisation and bandwidth: what [`train`] solves. Designs over disjoint sample sets
/// with the same standardisation add up ([`Design::merge`]), so a regression on any union of
/// them is solved without a second pass over the samples (`examples/fit_lopo.rs`'s
/// leave-one-physics-out view, round 10).
#[derive(Clone, Debug)]
pub struct Design {
    mean: Vec<f64>,
    scale: Vec<f64>,
    bandwidth: [f64; 2],
    omega: Vec<f64>,
    phase: Vec<f64>,
    /// `terms × terms`, lower triangle (row `p`, columns `0..=p`) until [`Design::solve`].
    a: Vec<f64>,
    b: [Vec<f64>; 2],
    m: usize,
    z: Vec<f64>,
    f: Vec<f64>,
}

impl Design {
    /// An empty design for inputs standardised by `mean` / `scale` ([`INPUTS`] or
    /// [`INPUTS_WITH_GAINS`] values each, scales finite and > 0) with random features at
    /// `bandwidth`; `None` for other sizes or values.
    pub fn new(mean: Vec<f64>, scale: Vec<f64>, bandwidth: [f64; 2]) -> Option<Design> {
        let n = mean.len();
        let ok = known_inputs(n)
            && scale.len() == n
            && mean.iter().all(|v| v.is_finite())
            && scale.iter().all(|v| v.is_finite() && *v > 0.0)
            && bandwidth.iter().all(|v| v.is_finite() && *v >= 0.0);
        if !ok {
            return None;
        }
        let (omega, phase) = frequencies(bandwidth, n);
        let t = terms_for(n);
        Some(Design {
            mean,
            scale,
            bandwidth,
            omega,
            phase,
            a: vec![0.0; t * t],
            b: [vec![0.0; t], vec![0.0; t]],
            m: 0,
            z: vec![0.0; n],
            f: vec![0.0; t],
        })
    }

    /// The number of samples added.
    pub fn samples(&self) -> usize {
        self.m
    }

    /// Add one sample: inputs `x` (the design's input count; ignored otherwise) and target
    /// `y` (mm).
    pub fn add(&mut self, x: &[f64], y: [f64; 2]) {
        let n = self.mean.len();
        if x.len() != n {
            return;
        }
        for ((z, v), (m, s)) in self.z.iter_mut().zip(x).zip(self.mean.iter().zip(&self.scale)) {
            *z = (v - m) / s;
        }
        terms(&self.z, &self.omega, &self.phase, &mut self.f);
        let t = self.f.len();
        for p in 0..t {
            let fp = self.f[p];
            let row = &mut self.a[p * t..p * t + p + 1];
            for (q, r) in row.iter_mut().enumerate() {
                *r += fp * self.f[q];
            }
            self.b[0][p] += fp * y[0];
            self.b[1][p] += fp * y[1];
        }
        self.m += 1;
    }

    /// Add another design's samples; `false` (nothing changed) unless it has the same
    /// standardisation and bandwidth.
    pub fn merge(&mut self, other: &Design) -> bool {
        if self.mean != other.mean || self.scale != other.scale || self.bandwidth != other.bandwidth {
            return false;
        }
        self.a.iter_mut().zip(&other.a).for_each(|(a, b)| *a += b);
        for k in 0..2 {
            self.b[k].iter_mut().zip(&other.b[k]).for_each(|(a, b)| *a += b);
        }
        self.m += other.m;
        true
    }

    /// The ridge weights at every penalty of `lambdas` (per sample, on standardised terms; the
    /// constant not penalised): one entry per penalty, `None` when there is no sample or the
    /// system is singular.
    pub fn solve(&self, lambdas: &[f64]) -> Vec<Option<Trained>> {
        let (t, m) = (self.f.len(), self.m);
        if m == 0 {
            return lambdas.iter().map(|_| None).collect();
        }
        let mut a = self.a.clone();
        for p in 0..t {
            for q in 0..p {
                a[q * t + p] = a[p * t + q];
            }
        }
        lambdas
            .iter()
            .map(|&lambda| {
                let mut a = a.clone();
                for p in 0..t {
                    a[p * t + p] += if p > 0 { lambda * m as f64 } else { 1e-9 * m as f64 };
                }
                let wx = crate::force_model::cholesky_solve(&mut a.clone(), &self.b[0], t)?;
                let wy = crate::force_model::cholesky_solve(&mut a, &self.b[1], t)?;
                Some(Trained {
                    mean: self.mean.clone(),
                    scale: self.scale.clone(),
                    bandwidth: self.bandwidth,
                    w: [wx, wy],
                    lambda,
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(rng: &mut SplitMix) -> Vec<f64> {
        (0..INPUTS).map(|_| rng.normal()).collect()
    }

    #[test]
    fn builtin_weights_load_and_non_finite_inputs_give_no_correction() {
        let mut c = Correction::builtin().unwrap();
        let mut x = vec![0.0; INPUTS];
        x[3] = f64::NAN;
        let v = c.apply(&x);
        assert!(v[0].is_finite() && v[1].is_finite());
        assert_eq!(c.apply(&[f64::INFINITY; INPUTS]), [0.0, 0.0]);
        assert_eq!(c.apply(&[1.0; 3]), [0.0, 0.0]);
        for s in 0..50 {
            let mut rng = SplitMix::new(s);
            let x: Vec<f64> = (0..INPUTS).map(|_| 1e6 * rng.normal()).collect();
            let v = c.apply(&x);
            assert!(v[0].hypot(v[1]) <= MAX_CORRECTION_MM + 1e-12);
        }
    }

    #[test]
    fn designs_over_disjoint_samples_merge_into_the_design_of_their_union() {
        let mut rng = SplitMix::new(7);
        let xs: Vec<Vec<f64>> = (0..600).map(|_| sample(&mut rng)).collect();
        let ys: Vec<[f64; 2]> = xs.iter().map(|x| [(x[0] * 1.3).sin(), 0.2 * x[7] - x[1]]).collect();
        let whole = train_path(&xs, &ys, &[1e-4, 1e-2], [0.25, 0.25]);
        let (mean, scale) = standardisation(&xs);
        let mut a = Design::new(mean.clone(), scale.clone(), [0.25, 0.25]).unwrap();
        let mut b = Design::new(mean.clone(), scale.clone(), [0.25, 0.25]).unwrap();
        for (i, (x, y)) in xs.iter().zip(&ys).enumerate() {
            if i % 3 == 0 {
                a.add(x, *y)
            } else {
                b.add(x, *y)
            }
        }
        assert!(a.merge(&b));
        assert_eq!(a.samples(), 600);
        for (w, m) in whole.iter().zip(a.solve(&[1e-4, 1e-2])) {
            let (w, m) = (w.as_ref().unwrap(), m.unwrap());
            let top = w.w[0].iter().chain(&w.w[1]).fold(0.0f64, |t, v| t.max(v.abs()));
            for k in 0..2 {
                for (p, q) in w.w[k].iter().zip(&m.w[k]) {
                    assert!((p - q).abs() <= 1e-9 * top, "{p} {q}");
                }
            }
        }
        // another standardisation or bandwidth does not merge; bad sizes are refused
        let other = Design::new(mean.clone(), scale.iter().map(|s| 2.0 * s).collect(), [0.25, 0.25]).unwrap();
        assert!(!a.merge(&other));
        assert!(!a.merge(&Design::new(mean.clone(), scale.clone(), [0.5, 0.25]).unwrap()));
        assert!(Design::new(mean[..5].to_vec(), scale[..5].to_vec(), [0.25, 0.25]).is_none());
        assert!(Design::new(mean.clone(), vec![0.0; INPUTS], [0.25, 0.25]).is_none());
        let empty = Design::new(mean, scale, [0.25, 0.25]).unwrap();
        assert!(empty.solve(&[1e-4]).iter().all(Option::is_none));
        // a sample of the wrong length is ignored
        let mut c = empty.clone();
        c.add(&[1.0; 3], [1.0, 1.0]);
        assert_eq!(c.samples(), 0);
    }

    #[test]
    fn ridge_recovers_a_smooth_function_and_round_trips_through_the_file_format() {
        let mut rng = SplitMix::new(7);
        let f = |x: &[f64]| [0.3 * x[0] - 0.2 * x[5], 0.4 * (1.5 * x[1]).sin()];
        let xs: Vec<Vec<f64>> = (0..3000).map(|_| sample(&mut rng)).collect();
        let ys: Vec<[f64; 2]> = xs.iter().map(|x| f(x)).collect();
        let t = train(&xs, &ys, 1e-5, [1.5, 0.5]).unwrap();
        let mut c = Correction::try_new(t.clone()).unwrap();
        let (mut err, mut sig) = (0.0, 0.0);
        for _ in 0..200 {
            let x = sample(&mut rng);
            let (p, q) = (c.apply(&x), f(&x));
            err += ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)) / 200.0;
            sig += (q[0].powi(2) + q[1].powi(2)) / 200.0;
        }
        // the linear part exactly, the sine well: a fifth of the target's size left at most
        assert!(err.sqrt() < 0.2 * sig.sqrt(), "rms {} of {}", err.sqrt(), sig.sqrt());
        // the text format parses back to the same numbers
        let src = t.to_rust("test");
        let nums = |name: &str| -> Vec<f64> {
            let l = src.lines().find(|l| l.contains(&format!("const {name}:"))).unwrap();
            let body = &l[l.find("= [").unwrap() + 3..l.rfind(']').unwrap()];
            body.split(", ").map(|v| v.parse().unwrap()).collect()
        };
        assert_eq!(nums("WX"), t.w[0]);
        assert_eq!(nums("MEAN"), t.mean);
        assert_eq!(Trained::from_rust(&src), Some(t.clone()));
        assert_eq!(Trained::from_rust(&src.replace("const WY", "const WZ")), None);
        assert_eq!(Trained::from_rust(&src.replace("const LAMBDA: f64 = ", "const LAMBDA: f64 = x")), None);
        // never a panic on other text; non-finite numbers parse but the correction refuses them
        for bad in ["", "const MEAN:", "const MEAN: [f64; 1] = [", "= ] [ ;", "const WX: = [1, 2"] {
            assert_eq!(Trained::from_rust(bad), None);
        }
        let mut t2 = t.clone();
        t2.w[0][0] = f64::NAN;
        let nan = Trained::from_rust(&t2.to_rust("nan")).unwrap();
        assert!(nan.w[0][0].is_nan() && nan.w[0].len() == t.w[0].len() && Correction::try_new(nan).is_err());
    }

    #[test]
    fn gain_inputs_are_bounded_and_weights_with_them_train_and_apply() {
        let mut out = vec![0.0; GAIN_INPUTS];
        let mut g = vec![1.0; 24];
        g[0] = 0.0;
        g[1] = f64::NAN;
        g[2] = -2.0;
        let mut e = vec![0.0; 24];
        e[3] = 3.0;
        e[4] = f64::INFINITY;
        assert!(gain_inputs(&g, &e, 0.3, &mut out));
        assert!(out.iter().all(|v| v.is_finite() && v.abs() <= 3.0), "{out:?}");
        // ln 0 and NaN are not finite: 0, as is ∞/∞
        assert_eq!(out[0], 0.0);
        assert_eq!(out[1], 0.0);
        assert_eq!(out[24 + 4], 0.0);
        assert!((out[2] - 2f64.ln()).abs() < 1e-15);
        assert!((out[24 + 3] - 3.0 / 3.3).abs() < 1e-15 && out[24 + 5] == 0.0);
        assert!(gain_inputs(&g, &e, 0.0, &mut out) && out[24 + 5] == 0.0 && out[24 + 3] == 1.0);
        assert!(!gain_inputs(&g[..3], &e, 0.3, &mut out));
        // weights over the longer input vector train, load and read its last inputs
        let mut rng = SplitMix::new(3);
        let xs: Vec<Vec<f64>> = (0..2000).map(|_| (0..INPUTS_WITH_GAINS).map(|_| rng.normal()).collect()).collect();
        let ys: Vec<[f64; 2]> = xs.iter().map(|x| [0.3 * x[INPUTS + 5], 0.0]).collect();
        let t = train(&xs, &ys, 1e-6, [0.25, 0.25]).unwrap();
        assert_eq!(t.w[0].len(), 1 + INPUTS_WITH_GAINS + RANDOM);
        let mut c = Correction::try_new(t).unwrap();
        assert_eq!(c.inputs(), INPUTS_WITH_GAINS);
        let mut x = vec![0.0; INPUTS_WITH_GAINS];
        x[INPUTS + 5] = 1.0;
        assert!((c.apply(&x)[0] - 0.3).abs() < 0.05, "{:?}", c.apply(&x));
        assert_eq!(c.apply(&x[..INPUTS]), [0.0, 0.0], "too short for these weights");
        // the shipped weights read the first INPUTS of the longer vector
        let mut b = Correction::builtin().unwrap();
        assert_eq!(b.apply(&x), b.apply(&x[..INPUTS]));
        // mixed sizes are refused
        let mut mixed = xs[..10].to_vec();
        mixed[3].truncate(INPUTS);
        assert!(train(&mixed, &ys[..10], 1e-6, [0.25, 0.25]).is_none());
    }

    #[test]
    fn weights_files_round_trip_and_older_files_with_empty_limits_still_load() {
        let mut rng = SplitMix::new(11);
        let f = |x: &[f64]| [0.3 * x[0] - 0.2 * x[5], 0.4 * (1.5 * x[1]).sin()];
        let xs: Vec<Vec<f64>> = (0..2000).map(|_| sample(&mut rng)).collect();
        let ys: Vec<[f64; 2]> = xs.iter().map(|x| f(x)).collect();
        let t = train(&xs, &ys, 1e-5, [1.5, 0.5]).unwrap();
        let src = t.to_rust("round trip");
        assert!(!src.contains("CLAMP") && !src.contains("NOVELTY"), "{src}");
        assert_eq!(Trained::from_rust(&src), Some(t.clone()));
        // a file written before round 11's limits were removed carries them as empty lists (the
        // shipped file did): it reads as the same weights
        let old = format!("{src}pub(super) const CLAMP: [f64; 0] = [];\npub(super) const NOVELTY: [f64; 0] = [];\n");
        assert_eq!(Trained::from_rust(&old), Some(t.clone()));
        let shipped = include_str!("fit_learned_weights.rs");
        let shipped_old =
            format!("{shipped}pub(super) const CLAMP: [f64; 0] = [];\npub(super) const NOVELTY: [f64; 0] = [];\n");
        assert_eq!(Trained::from_rust(shipped), Some(Trained::builtin()));
        assert_eq!(Trained::from_rust(&shipped_old), Some(Trained::builtin()));
        // a file with limits (round 11's candidates, never shipped) cannot be applied as trained: refused
        for limits in [
            "pub(super) const CLAMP: [f64; 4] = [-1e0, 1e0, -1e0, 1e0];\npub(super) const NOVELTY: [f64; 0] = [];\n",
            "pub(super) const CLAMP: [f64; 0] = [];\npub(super) const NOVELTY: [f64; 1] = [2e0];\n",
        ] {
            assert_eq!(Trained::from_rust(&format!("{src}{limits}")), None, "{limits}");
        }
        // non-finite inputs give no correction, never a panic
        let mut c = Correction::try_new(t).unwrap();
        assert_eq!(c.apply(&[f64::INFINITY; INPUTS]), [0.0, 0.0]);
        let mut nan: Vec<f64> = (0..INPUTS).map(|i| if i % 2 == 0 { 3.0 } else { -3.0 }).collect();
        nan[4] = f64::NAN;
        assert_eq!(c.apply(&nan), [0.0, 0.0]);
    }

    #[test]
    fn bad_weights_are_refused() {
        let mut t = Trained::builtin();
        t.w[0].pop();
        assert!(Correction::try_new(t).is_err());
        let mut t = Trained::builtin();
        t.scale[0] = 0.0;
        assert!(Correction::try_new(t).is_err());
    }

    #[test]
    fn inputs_are_bounded_and_refuse_other_sizes() {
        let mut out = vec![0.0; INPUTS];
        let d: Vec<f64> = (0..24).map(|i| i as f64 * 10.0).collect();
        let g = vec![1.0; 24];
        let kk = vec![0.5; 24];
        assert!(inputs(
            [0.0, 0.0],
            [-10.0, 10.0, -5.0, 5.0],
            1.0,
            0.1,
            0.2,
            [3.0, -1.0],
            230.0,
            &d,
            &g,
            &kk,
            |_| true,
            &mut out
        ));
        assert!(out.iter().all(|v| v.is_finite() && v.abs() <= 3.0));
        assert!(!inputs([0.0, 0.0], [0.0; 4], 0.0, 0.0, 0.0, [0.0; 2], 1.0, &d[..5], &g, &kk, |_| true, &mut out));
        assert!(!inputs([0.0, 0.0], [0.0; 4], 0.0, 0.0, 0.0, [0.0; 2], 1.0, &[0.0; 24], &g, &kk, |_| true, &mut out));
    }
}
