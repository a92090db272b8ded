//! An **information floor** for force calibrated from a gauge (issue #22, item 4): the MAPE of
//! the Bayes-optimal per-frame force estimate of an observer told everything about a member
//! except its per-electrode gain magnitudes `|gᵢ|` and the scored frames' force, on
//! `force_eval`'s protocol. If even this oracle misses 10 % on a sizeable share of members, no
//! estimator of that kind reaches the target as defined; if it stays well under, the floor says
//! how much room an estimator has. `examples/force_parts/floor.md` has the figures.
//!
//! **Members.** A member is a seed: `ForceSession::presses(seed, 10)`, as `force_eval` draws it
//! (standard physics, kind = seed mod 4), made into the **easiest sensor that keeps the gains**
//! with [`Physics::idealise`]: `"lag"` (1 ms: the frame keeps `e^{−10}` ≈ 5·10⁻⁵ of the last
//! step, < 10⁻³ counts here), `"drift"` (no slope, no walk) and `"knee"` (10⁶ counts: `S tanh(u/S)`
//! differs from `u` by < 2·10⁻³ counts here). Kept as drawn: the kernel's shape, width and far
//! lobe, γ, s, the amplitude `A`, the signed gains, the baselines, the white noise σ (counts) and
//! the 12-bit ADC (rounding and clamping to 0…4095). The oracle neglects the two residuals
//! above (both ≪ the noise, σ ≥ 1 count). Seeds: the 62 tuning members of `force_eval`'s
//! rounds (0–7, 700–705, 200–247) and 200 fresh seeds 5000–5199 (no other evaluation or test
//! uses them); the held-out seeds 100–115 and the fresh held-out seeds 9000–9015
//! (`examples/fresh_check.md`) are refused.
//!
//! **Told**: the true place of every frame (`ForceRecording::contact`), the kernel, γ, s, `F_ref`,
//! `A`, the baselines, the noise σ, each gain's **sign**, and the calibration frames' **true**
//! force (not the gauge's reading). **Not told**: `|gᵢ|` (prior: independent, uniform on
//! [0.5, 1.5], the family's draw) and the force of the frame being scored.
//!
//! **Likelihood** of a frame's count `xᵢ` at force `F`: `μᵢ = bᵢ + |gᵢ| hᵢ(F)` with
//! `hᵢ(F) = σᵢ A F_ref (F/F_ref)^γ K(ρᵢ; w(F))` (`sim_force`'s response, ρᵢ from the 3-D core
//! geometry), Gaussian with variance `σ² + 1/12` (noise plus rounding); a count clamped to 4095
//! (or 0) is censored: `P(b + |g| h + noise ≥ 4094.5)` (or `< 0.5`). Electrodes are independent
//! given `F` and the gains.
//!
//! **Calibration**: each `|gᵢ|`'s exact posterior given every calibration-half frame with force
//! (the frames before the rest that follows the 5th press: `force_eval`'s split), independent
//! per electrode because everything else is told. The Gaussian part is quadratic in `|gᵢ|`; the
//! posterior is put on a 64-point grid over the part of [0.5, 1.5] where its log density is
//! within 50 nats of its maximum (the whole interval for an electrode no calibration press
//! excited, where it stays the prior), so a sharp posterior is resolved, not rounded to a fixed
//! grid.
//!
//! **Scored frame** (scored half, true force > 0.5 N, as `force_eval` scores): the posterior of
//! `F` on a log grid (300 points over 0.05–20 N, flat prior in ln F), each electrode's likelihood
//! marginalised over its gain posterior grid (Σₖ wₖ N(xᵢ; bᵢ + gₖ hᵢ(F))); then a second grid of
//! 200 points over the coarse points within 100 nats of the coarse maximum (± one coarse step),
//! and the estimate that minimises the expected `|F̂ − F|/F`: the median of the posterior weighted
//! by `1/F` (density taken constant within each grid cell in ln F). Three observers: gains
//! **told** (the posterior a point at the truth: the noise-only floor), **calibrated** (the
//! floor), **prior** (no calibration: an upper reference).
//!
//! The floor is per frame: it uses the calibration frames and the frame being scored, nothing
//! else. An estimator that pools frames over time (the force's smooth profile) or learns gains
//! from the unlabelled scored frames is not bounded by it (`floor.md` says what that means).
//!
//! Run: `cargo run --release --example force_floor` (summary table; `FORCE_FLOOR_DEBUG=1` adds a
//! line per member; `FORCE_FLOOR_SEEDS=a..b` replaces both seed sets by one range;
//! `FORCE_FLOOR_STRIDE=k` scores every k-th scored frame (default 1: all); `FORCE_FLOOR_THREADS`
//! (default 2); `FORCE_FLOOR_FORWARD_LOG=examples/force_parts/round8_k1.log` puts `forward`'s
//! per-member scored-half MAPE from that `force_eval` log beside the floor; `FORCE_FLOOR_S31=1`
//! runs the oracle on session 31's "ideal + gains" sensor instead, see [`idealised`];
//! `FORCE_FLOOR_ONLY_ML=1` runs only the two place-unknown references, the Bayes columns NaN).

use gradtac::stages::sim_family::{skin_point, Physics, CORE_MM, RATE_HZ, SKIN_MM};
use gradtac::stages::sim_force::{is_held_out as held_out, ForceRecording, ForceResponse, ForceSession};
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

const PRESSES: usize = 10;
/// Gain posterior grid points per electrode.
const G_POINTS: usize = 64;
/// The gain posterior's grid covers log density within this many nats of its maximum.
const G_SUPPORT_NATS: f64 = 50.0;
/// The force grid (N) and its two passes.
const F_LO: f64 = 0.05;
const F_HI: f64 = 20.0;
const F_COARSE: usize = 300;
const F_FINE: usize = 200;
/// The fine pass covers the coarse points within this many nats of the coarse maximum.
const F_SUPPORT_NATS: f64 = 100.0;
/// Prior range of `|gᵢ|`.
const G_MIN: f64 = 0.5;
const G_MAX: f64 = 1.5;
/// The ADC's range.
const ADC_MAX: f64 = 4095.0;
/// The force detector's window (`window_frames`, frames): the second observer sees these.
const WINDOW: usize = 9;

/// What the oracle is told about a member.
#[derive(Clone, Debug)]
struct Oracle {
    /// Sign σᵢ of each gain.
    sign: [f64; 24],
    /// True |gᵢ| (used only by the `told` observer and the tests).
    abs_gain: [f64; 24],
    baseline: [f64; 24],
    amplitude: f64,
    kernel: gradtac::stages::sim_family::KernelShape,
    width_mm: f64,
    response: ForceResponse,
    /// Variance of a count about its mean: σ² + 1/12 (counts²).
    var: f64,
    depth: [f64; 24],
}

/// The member's sensor made ideal in every term but the gains (see the module docs); with
/// `s31`, session 31's "ideal + gains" sensor instead (`force_eval`'s `FORCE_EVAL_ON=gains`:
/// also a Gaussian kernel, every sign −1, no noise, γ = 1, s = 0, lag 0.1 ms, knee 10⁹ counts), the sensor on
/// which `forward` scored 29.9 % worst over seeds 0–7.
fn idealised(seed: u64, s31: bool) -> ForceSession {
    assert!(!held_out(seed), "seed {seed} is a held-out member of force_eval: not computed here");
    let mut s = ForceSession::presses(seed, PRESSES);
    for t in ["lag", "drift", "knee"] {
        assert!(s.physics.idealise(t));
    }
    if s31 {
        let p = &mut s.physics;
        p.kernel = gradtac::stages::sim_family::KernelShape::Gaussian;
        p.gain.iter_mut().for_each(|g| *g = -g.abs());
        p.lag_s = 1e-4;
        p.knee_counts = 1e9;
        p.noise_counts = 0.0;
        s.response.gauge_noise_n = 0.0;
        s.response.exponent = 1.0;
        s.response.spread = 0.0;
    }
    s
}

impl Oracle {
    fn new(s: &ForceSession) -> Oracle {
        let p: &Physics = &s.physics;
        let mut o = Oracle {
            sign: [0.0; 24],
            abs_gain: [0.0; 24],
            baseline: [0.0; 24],
            amplitude: p.amplitude,
            kernel: p.kernel,
            width_mm: p.width_mm,
            response: s.response,
            var: p.noise_counts.max(0.0).powi(2) + 1.0 / 12.0,
            depth: [0.0; 24],
        };
        for i in 0..24 {
            o.sign[i] = if p.gain[i] < 0.0 { -1.0 } else { 1.0 };
            o.abs_gain[i] = p.gain[i].abs();
            o.baseline[i] = p.baseline[i];
            let (e, k) = (CORE_MM[i], SKIN_MM[i]);
            o.depth[i] = ((e[0] - k[0]).powi(2) + (e[1] - k[1]).powi(2) + (e[2] - k[2]).powi(2)).sqrt();
        }
        o
    }

    /// Depth-corrected 3-D distances ρᵢ (mm) of a layout-plane place, as `sim_force` computes them.
    fn rho(&self, place: [f64; 2]) -> [f64; 24] {
        let sp = skin_point(place);
        let mut r = [0.0; 24];
        for (i, ri) in r.iter_mut().enumerate() {
            let e = CORE_MM[i];
            let d2 = (e[0] - sp[0]).powi(2) + (e[1] - sp[1]).powi(2) + (e[2] - sp[2]).powi(2);
            *ri = (d2 - self.depth[i] * self.depth[i]).max(0.0).sqrt();
        }
        r
    }

    /// `hᵢ(F)`: the mean change of electrode i per unit |gᵢ| at force `f` (counts).
    fn unit(&self, rho: &[f64; 24], f: f64, out: &mut [f64; 24]) {
        let amp = self.response.gain(f) * self.amplitude;
        let w = self.response.width(self.width_mm, f);
        for i in 0..24 {
            out[i] = if amp > 0.0 { self.sign[i] * amp * self.kernel.eval(rho[i], w) } else { 0.0 };
        }
    }
}

/// `ln erfc(x)` (Numerical Recipes' `erfcc`, relative error < 1.2·10⁻⁷; stable far in the tail).
fn ln_erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let ln_pos = t.ln() + poly;
    if x >= 0.0 {
        ln_pos
    } else {
        (2.0 - ln_pos.exp()).ln()
    }
}

/// ln P(N(0,1) ≥ z).
fn ln_upper_tail(z: f64) -> f64 {
    ln_erfc(z / std::f64::consts::SQRT_2) - std::f64::consts::LN_2
}

/// ln P(observing the censored count `x` (0 or 4095) | mean `mu`).
fn ln_censored(x: f64, mu: f64, sd: f64) -> f64 {
    if x >= ADC_MAX {
        ln_upper_tail((ADC_MAX - 0.5 - mu) / sd)
    } else {
        ln_upper_tail(-(0.5 - mu) / sd)
    }
}

fn censored(x: f64) -> bool {
    x <= 0.0 || x >= ADC_MAX
}

/// A posterior (or prior) of one |gᵢ| on a uniform grid: `gₖ = lo + (k + ½) step`, weights
/// `w` with maximum 1.
#[derive(Clone, Debug)]
struct GainPost {
    lo: f64,
    step: f64,
    w: Vec<f64>,
}

impl GainPost {
    fn prior() -> GainPost {
        GainPost { lo: G_MIN, step: (G_MAX - G_MIN) / G_POINTS as f64, w: vec![1.0; G_POINTS] }
    }

    fn told(g: f64) -> GainPost {
        GainPost { lo: g, step: 0.0, w: vec![1.0] }
    }

    fn g(&self, k: usize) -> f64 {
        self.lo + (k as f64 + 0.5) * self.step
    }

    /// Posterior mean and standard deviation.
    fn mean_sd(&self) -> (f64, f64) {
        let s: f64 = self.w.iter().sum();
        let m = self.w.iter().enumerate().map(|(k, w)| w * self.g(k)).sum::<f64>() / s;
        // a grid cell is uniform over its width: add step²/12
        let v = self.w.iter().enumerate().map(|(k, w)| w * (self.g(k) - m).powi(2)).sum::<f64>() / s
            + self.step * self.step / 12.0;
        (m, v.sqrt())
    }

    #[cfg(test)]
    /// Total-variation distance from the uniform prior on [0.5, 1.5] (grid cells as masses).
    fn tv_from_prior(&self) -> f64 {
        let s: f64 = self.w.iter().sum();
        // mass of the prior in each cell, and outside the grid
        let inside = self.step * self.w.len() as f64 / (G_MAX - G_MIN);
        let per = self.step / (G_MAX - G_MIN);
        0.5 * (self.w.iter().map(|w| (w / s - per).abs()).sum::<f64>() + (1.0 - inside))
    }
}

/// Sufficient statistics of one electrode's calibration frames.
#[derive(Clone, Debug, Default)]
struct GainStats {
    /// Σ h², Σ h (x − b) over uncensored frames.
    hh: f64,
    hr: f64,
    /// Censored frames: (count, h).
    cens: Vec<(f64, f64)>,
}

/// Each |gᵢ|'s posterior given the frames `frames` of `rec` (true force told).
fn calibrate(o: &Oracle, rec: &ForceRecording, frames: impl Iterator<Item = usize>) -> (Vec<GainPost>, Vec<GainStats>) {
    let mut stats = vec![GainStats::default(); 24];
    let mut h = [0.0; 24];
    for k in frames {
        let (f, Some(place)) = (rec.force[k], rec.contact[k]) else { continue };
        if f <= 0.0 {
            continue;
        }
        o.unit(&o.rho(place), f, &mut h);
        for i in 0..24 {
            let x = rec.frames[k].values[i];
            if censored(x) {
                stats[i].cens.push((x, h[i]));
            } else {
                stats[i].hh += h[i] * h[i];
                stats[i].hr += h[i] * (x - o.baseline[i]);
            }
        }
    }
    let sd = o.var.sqrt();
    let posts = stats
        .iter()
        .enumerate()
        .map(|(i, st)| {
            let lp = |g: f64| {
                -(st.hh * g * g - 2.0 * st.hr * g) / (2.0 * o.var)
                    + st.cens.iter().map(|&(x, h)| ln_censored(x, o.baseline[i] + g * h, sd)).sum::<f64>()
            };
            // the Gaussian part's support: |g − m| ≤ √((ĝ − m)² + 2·50·sd²), ĝ its maximum in range
            let (mut lo, mut hi) = (G_MIN, G_MAX);
            if st.hh > 0.0 {
                let (m, s2) = (st.hr / st.hh, o.var / st.hh);
                let gm = m.clamp(G_MIN, G_MAX);
                let r = ((gm - m).powi(2) + 2.0 * G_SUPPORT_NATS * s2).sqrt();
                lo = (m - r).max(G_MIN);
                hi = (m + r).min(G_MAX);
                if hi <= lo {
                    (lo, hi) = (gm, gm);
                }
            }
            // two passes: the censored frames can narrow the support further
            let mut post = GainPost { lo, step: 0.0, w: vec![] };
            for pass in 0..2 {
                let step = (hi - lo) / G_POINTS as f64;
                let lps: Vec<f64> = (0..G_POINTS).map(|k| lp(lo + (k as f64 + 0.5) * step)).collect();
                let max = lps.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                post = GainPost { lo, step, w: lps.iter().map(|l| (l - max).exp()).collect() };
                if pass == 0 && step > 0.0 {
                    let keep: Vec<usize> = (0..G_POINTS).filter(|&k| lps[k] >= max - G_SUPPORT_NATS).collect();
                    let (a, b) = (keep[0], *keep.last().unwrap());
                    if a > 0 || b + 1 < G_POINTS {
                        let (nlo, nhi) =
                            (lo + a.saturating_sub(1) as f64 * step, lo + (b + 2).min(G_POINTS) as f64 * step);
                        (lo, hi) = (nlo, nhi);
                        continue;
                    }
                }
                break;
            }
            post
        })
        .collect();
    (posts, stats)
}

/// ln Σₖ wₖ N(r; gₖ h, var) (up to the constant −½ ln 2π var): one electrode's likelihood of
/// its baseline-relative count `r` when its mean per unit gain is `h`, marginalised over `p`.
fn ln_marginal(r: f64, h: f64, p: &GainPost, var: f64) -> f64 {
    let n = p.w.len();
    let d = p.step * h;
    // the grid point whose mean is nearest the count
    let kc = if d != 0.0 { ((r / h - p.lo) / p.step - 0.5).round().clamp(0.0, (n - 1) as f64) as usize } else { 0 };
    let e = r - p.g(kc) * h;
    let base = -e * e / (2.0 * var);
    // exponent of point kc + j relative to kc: j·a − j²·b
    let (a, b) = (d * e / var, d * d / (2.0 * var));
    let mut s = p.w[kc];
    if b < 1.0 {
        // multiplicative recurrence (no exp per point): ratio j−1 → j is e^{a − (2j−1) b}
        let (ea, q) = (a.exp(), (-b).exp());
        let (mut f, mut qp) = (1.0, q);
        for k in kc + 1..n {
            f *= ea * qp;
            qp *= q * q;
            s += p.w[k] * f;
            if f < 1e-40 {
                break;
            }
        }
        let ea = (-a).exp();
        let (mut f, mut qp) = (1.0, q);
        for k in (0..kc).rev() {
            f *= ea * qp;
            qp *= q * q;
            s += p.w[k] * f;
            if f < 1e-40 {
                break;
            }
        }
    } else {
        for k in kc + 1..n {
            let j = (k - kc) as f64;
            let x = j * a - j * j * b;
            if x < -92.0 {
                break;
            }
            s += p.w[k] * x.exp();
        }
        for k in (0..kc).rev() {
            let j = (kc - k) as f64;
            let x = -j * a - j * j * b;
            if x < -92.0 {
                break;
            }
            s += p.w[k] * x.exp();
        }
    }
    base + s.ln()
}

/// The same for a censored count (direct sum).
fn ln_marginal_censored(x: f64, b0: f64, h: f64, p: &GainPost, sd: f64) -> f64 {
    let lps: Vec<f64> = (0..p.w.len()).map(|k| p.w[k].ln() + ln_censored(x, b0 + p.g(k) * h, sd)).collect();
    let max = lps.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    max + lps.iter().map(|l| (l - max).exp()).sum::<f64>().ln()
}

/// What an observer sees of one scored frame: the counts of the frames of its window (one frame,
/// or the 9 of the force detector's window, all at the same place) with each frame's force as a
/// told ratio to the scored frame's, `F_j = r_j F`.
struct Window<'a> {
    frames: Vec<(&'a [f64], f64)>,
    rho: [f64; 24],
}

/// ln p(window | F) for each force of `grid` (ln F), up to a constant. Per electrode the
/// window's Gaussian terms are quadratic in |gᵢ|: with `S_hh = Σ h²`, `S_hr = Σ h r`, `S_rr = Σ r²`
/// (r the baseline-relative counts) they are one observation `r' = S_hr/√S_hh` of `g √S_hh` plus
/// `−(S_rr − S_hr²/S_hh)/2v`, so [`ln_marginal`] serves any window; a window with a censored
/// count sums over the gain grid directly.
fn log_lik(o: &Oracle, posts: &[GainPost], win: &Window<'_>, grid: &[f64]) -> Vec<f64> {
    let sd = o.var.sqrt();
    let mut h = vec![[0.0; 24]; win.frames.len()];
    grid.iter()
        .map(|&lf| {
            let f = lf.exp();
            for (hj, (_, r)) in h.iter_mut().zip(&win.frames) {
                o.unit(&win.rho, f * r, hj);
            }
            (0..24)
                .map(|i| {
                    let b = o.baseline[i];
                    if win.frames.iter().any(|(x, _)| censored(x[i])) {
                        if let [(x, _)] = win.frames[..] {
                            return ln_marginal_censored(x[i], b, h[0][i], &posts[i], sd);
                        }
                        let p = &posts[i];
                        let l: Vec<f64> = (0..p.w.len())
                            .map(|k| {
                                let g = p.g(k);
                                p.w[k].ln()
                                    + win
                                        .frames
                                        .iter()
                                        .zip(&h)
                                        .map(|((x, _), hj)| {
                                            if censored(x[i]) {
                                                ln_censored(x[i], b + g * hj[i], sd)
                                            } else {
                                                -(x[i] - b - g * hj[i]).powi(2) / (2.0 * o.var)
                                            }
                                        })
                                        .sum::<f64>()
                            })
                            .collect();
                        let m = l.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                        return m + l.iter().map(|v| (v - m).exp()).sum::<f64>().ln();
                    }
                    if let [(x, _)] = win.frames[..] {
                        return ln_marginal(x[i] - b, h[0][i], &posts[i], o.var);
                    }
                    let (mut hh, mut hr, mut rr) = (0.0, 0.0, 0.0);
                    for ((x, _), hj) in win.frames.iter().zip(&h) {
                        let r = x[i] - b;
                        hh += hj[i] * hj[i];
                        hr += hj[i] * r;
                        rr += r * r;
                    }
                    if hh > 0.0 {
                        let s = hh.sqrt();
                        ln_marginal(hr / s, s, &posts[i], o.var) - (rr - hr * hr / hh).max(0.0) / (2.0 * o.var)
                    } else {
                        ln_marginal(0.0, 0.0, &posts[i], o.var) - rr / (2.0 * o.var)
                    }
                })
                .sum()
        })
        .collect()
}

/// The force minimising the expected `|F̂ − F|/F` under a posterior given on a uniform grid in
/// ln F (`lp`: log density in ln F): the median weighted by `1/F`, the density constant within
/// each cell.
fn weighted_median(grid: &[f64], lp: &[f64]) -> f64 {
    let max = lp.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let w: Vec<f64> = grid.iter().zip(lp).map(|(g, l)| (l - max - g).exp()).collect();
    let total: f64 = w.iter().sum();
    let delta = if grid.len() > 1 { grid[1] - grid[0] } else { 0.0 };
    let mut acc = 0.0;
    for (k, wk) in w.iter().enumerate() {
        if acc + wk >= 0.5 * total {
            let u = if *wk > 0.0 { (0.5 * total - acc) / wk } else { 0.5 };
            return (grid[k] - 0.5 * delta + u * delta).exp();
        }
        acc += wk;
    }
    grid.last().unwrap().exp()
}

fn ln_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n).map(|k| lo + (hi - lo) * k as f64 / (n - 1) as f64).collect()
}

/// The observer's estimate of one frame's force: a coarse pass, then a fine one over the support.
fn estimate(o: &Oracle, posts: &[GainPost], win: &Window<'_>) -> f64 {
    let coarse = ln_grid(F_LO.ln(), F_HI.ln(), F_COARSE);
    let lp = log_lik(o, posts, win, &coarse);
    let max = lp.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let keep: Vec<usize> = (0..F_COARSE).filter(|&k| lp[k] >= max - F_SUPPORT_NATS).collect();
    let (a, b) = (keep[0].saturating_sub(1), (keep[keep.len() - 1] + 1).min(F_COARSE - 1));
    if b - a + 1 >= F_FINE {
        return weighted_median(&coarse, &lp);
    }
    let fine = ln_grid(coarse[a], coarse[b], F_FINE);
    let lp = log_lik(o, posts, win, &fine);
    weighted_median(&fine, &lp)
}

/// Starting places for [`mle_place_unknown`]: a 2.5-mm grid over the pad region's bounding box.
fn start_places() -> Vec<[f64; 2]> {
    let region = gradtac::stages::sim_family::pad_region();
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in &region {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let mut v = Vec::new();
    let mut x = lo[0];
    while x <= hi[0] + 1e-9 {
        let mut y = lo[1];
        while y <= hi[1] + 1e-9 {
            v.push([x, y]);
            y += 2.5;
        }
        x += 2.5;
    }
    v
}

/// **Not a floor — a reference with the place unknown**: the maximum-likelihood `(x, y, ln F)` of
/// a window (one frame, or the 9-frame window with the forces told as ratios and one place), the
/// gains at their calibrated posterior means, everything else told (censored counts left out;
/// the window's place is ignored). Started from the best of `starts` × 40 forces (0.05–20 N),
/// then Levenberg–Marquardt from the three best starts; the lowest cost wins. Returns F̂ (N).
fn mle_place_unknown(o: &Oracle, gains: &[f64; 24], win: &Window<'_>, starts: &[[f64; 2]]) -> f64 {
    let sd = o.var.sqrt();
    let n = 24 * win.frames.len();
    let resid = |p: [f64; 3], out: &mut Vec<f64>| {
        out.clear();
        let rho = o.rho([p[0], p[1]]);
        let mut h = [0.0; 24];
        for (x, r) in &win.frames {
            o.unit(&rho, p[2].exp() * r, &mut h);
            for i in 0..24 {
                out.push(if censored(x[i]) { 0.0 } else { (x[i] - o.baseline[i] - gains[i] * h[i]) / sd });
            }
        }
    };
    let cost = |p: [f64; 3]| {
        let mut r = Vec::with_capacity(n);
        resid(p, &mut r);
        r.iter().map(|v| v * v).sum::<f64>()
    };
    let lf = ln_grid(F_LO.ln(), F_HI.ln(), 40);
    let mut cands: Vec<(f64, [f64; 3])> =
        starts.iter().flat_map(|q| lf.iter().map(move |&l| [q[0], q[1], l])).map(|p| (cost(p), p)).collect();
    cands.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut best = (f64::INFINITY, [0.0; 3]);
    for &(c0, p0) in cands.iter().take(3) {
        let (mut p, mut c, mut lambda) = (p0, c0, 1e-3);
        let (mut r, mut rp) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for _ in 0..100 {
            resid(p, &mut r);
            // forward-difference Jacobian
            let mut j = vec![[0.0; 3]; n];
            for (a, eps) in [(0usize, 1e-4), (1, 1e-4), (2, 1e-5)] {
                let mut q = p;
                q[a] += eps;
                resid(q, &mut rp);
                for i in 0..n {
                    j[i][a] = (rp[i] - r[i]) / eps;
                }
            }
            let mut jtj = [[0.0; 3]; 3];
            let mut jtr = [0.0; 3];
            for i in 0..n {
                for a in 0..3 {
                    jtr[a] += j[i][a] * r[i];
                    for b in 0..3 {
                        jtj[a][b] += j[i][a] * j[i][b];
                    }
                }
            }
            let mut improved = false;
            for _ in 0..20 {
                let mut m = jtj;
                for a in 0..3 {
                    m[a][a] += lambda * jtj[a][a].max(1e-12);
                }
                let Some(step) = solve3(m, [-jtr[0], -jtr[1], -jtr[2]]) else { break };
                let mut q = [p[0] + step[0], p[1] + step[1], p[2] + step[2]];
                q[2] = q[2].clamp((0.01f64).ln(), (50.0f64).ln());
                let cq = cost(q);
                if cq < c {
                    let done = c - cq < 1e-12 * c.max(1.0);
                    (p, c) = (q, cq);
                    lambda = (lambda / 3.0).max(1e-12);
                    improved = !done;
                    break;
                }
                lambda *= 4.0;
            }
            if !improved {
                break;
            }
        }
        if c < best.0 {
            best = (c, p);
        }
    }
    best.1[2].exp()
}

/// Solve a 3×3 system by Cramer's rule (`None` if singular).
fn solve3(m: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(&m);
    if !d.is_finite() || d.abs() < 1e-300 {
        return None;
    }
    let mut out = [0.0; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let mut mk = m;
        for r in 0..3 {
            mk[r][k] = b[r];
        }
        *o = det(&mk) / d;
    }
    Some(out)
}

/// One member's figures.
#[derive(Clone, Debug)]
struct MemberFloor {
    seed: u64,
    /// MAPE (%) of the told, calibrated and prior observers on the scored frames.
    told: f64,
    floor: f64,
    prior: f64,
    /// MAPE (%) of [`mle_place_unknown`] (place not told; not a floor).
    mle: f64,
    /// The same on the 9-frame window (one place, forces told as ratios).
    mle9: f64,
    /// MAPE (%) of the told and calibrated observers of the 9-frame window.
    told9: f64,
    floor9: f64,
    /// Scored frames used.
    frames: usize,
    /// Floor MAPE (%) per scored press.
    per_press: Vec<f64>,
    kernel: &'static str,
    width_mm: f64,
    amplitude: f64,
    noise: f64,
    gamma: f64,
    spread: f64,
    /// Electrodes whose calibrated |g| posterior sd is below 0.01.
    measured: usize,
    /// The calibrated gains' relative sd (%) at the scored places: Σ eᵢ (sdᵢ/|gᵢ|) / Σ eᵢ with
    /// eᵢ = (∂(|gᵢ| hᵢ)/∂ln F)² at 1 N (what each electrode tells about F), mean over the 5 places.
    gain_sd: f64,
    /// The Cramér–Rao sd (%) of ln F at 1 N with the gains told, mean over the 5 scored places.
    cr_sd: f64,
    /// Mean over scored places of the distance (mm, layout plane) to the nearest calibration place.
    dist_mm: f64,
}

fn member_floor(seed: u64, stride: usize, s31: bool, only_ml: bool) -> MemberFloor {
    let session = idealised(seed, s31);
    let rec = session.simulate();
    let o = Oracle::new(&session);
    let split_k = (session.after_press_s(PRESSES / 2) * RATE_HZ).round() as usize;
    let (posts, _) = calibrate(&o, &rec, 0..split_k.min(rec.frames.len()));
    let prior: Vec<GainPost> = (0..24).map(|_| GainPost::prior()).collect();
    let told: Vec<GainPost> = o.abs_gain.iter().map(|&g| GainPost::told(g)).collect();
    let scored: Vec<usize> =
        (split_k..rec.frames.len()).filter(|&k| rec.force[k] > 0.5).step_by(stride.max(1)).collect();
    let mut sums = [0.0f64; 7];
    let starts = start_places();
    let mut gains = [0.0; 24];
    for (g, p) in gains.iter_mut().zip(&posts) {
        *g = p.mean_sd().0;
    }
    let mut press: BTreeMap<usize, (f64, usize)> = BTreeMap::new();
    let mut rho_cache: BTreeMap<usize, [f64; 24]> = BTreeMap::new();
    for &k in &scored {
        let place = rec.contact[k].expect("a scored frame has a place");
        let rho = *rho_cache.entry(rec.segment[k]).or_insert_with(|| o.rho(place));
        let x = &rec.frames[k].values;
        let f = rec.force[k];
        let one = Window { frames: vec![(&x[..], 1.0)], rho };
        // the detector's window: the frames k − 4 … k + 4 of the same press, forces told as ratios
        let half = WINDOW / 2;
        let nine = Window {
            frames: (k.saturating_sub(half)..(k + half + 1).min(rec.frames.len()))
                .filter(|&j| rec.segment[j] == rec.segment[k])
                .map(|j| (&rec.frames[j].values[..], rec.force[j] / f))
                .collect(),
            rho,
        };
        let bayes = [(0, &told, &one), (1, &posts, &one), (2, &prior, &one), (4, &told, &nine), (5, &posts, &nine)];
        for (v, p, w) in bayes.into_iter().filter(|_| !only_ml) {
            let e = (estimate(&o, p, w) - f).abs() / f;
            sums[v] += e;
            if v == 1 {
                let c = press.entry(rec.segment[k]).or_default();
                c.0 += e;
                c.1 += 1;
            }
        }
        sums[3] += (mle_place_unknown(&o, &gains, &one, &starts) - f).abs() / f;
        sums[6] += (mle_place_unknown(&o, &gains, &nine, &starts) - f).abs() / f;
    }
    if only_ml {
        [0, 1, 2, 4, 5].iter().for_each(|&v| sums[v] = f64::NAN);
    }
    let n = scored.len().max(1) as f64;
    // diagnostics: which electrodes calibration measured, and what the scored places excite
    let sd: Vec<f64> = posts.iter().map(|p| p.mean_sd().1).collect();
    let places = session.places();
    let (cal, sco) = places.split_at(PRESSES / 2);
    let (mut up, mut dn) = ([0.0; 24], [0.0; 24]);
    let (mut gain_sd, mut cr_sd, mut dist) = (0.0, 0.0, 0.0);
    for q in sco {
        let rho = o.rho(*q);
        o.unit(&rho, 1.001, &mut up);
        o.unit(&rho, 1.0 / 1.001, &mut dn);
        let e: Vec<f64> = (0..24).map(|i| (o.abs_gain[i] * (up[i] - dn[i]) / 0.002).powi(2)).collect();
        let tot: f64 = e.iter().sum();
        gain_sd += 100.0 * (0..24).map(|i| e[i] * sd[i] / o.abs_gain[i]).sum::<f64>() / tot.max(1e-300);
        cr_sd += 100.0 * (o.var / tot.max(1e-300)).sqrt();
        dist += cal.iter().map(|c| (c[0] - q[0]).hypot(c[1] - q[1])).fold(f64::INFINITY, f64::min);
    }
    MemberFloor {
        seed,
        told: 100.0 * sums[0] / n,
        floor: 100.0 * sums[1] / n,
        prior: 100.0 * sums[2] / n,
        mle: 100.0 * sums[3] / n,
        mle9: 100.0 * sums[6] / n,
        told9: 100.0 * sums[4] / n,
        floor9: 100.0 * sums[5] / n,
        frames: scored.len(),
        per_press: press.values().map(|(s, c)| 100.0 * s / *c as f64).collect(),
        kernel: o.kernel.name(),
        width_mm: o.width_mm,
        amplitude: o.amplitude,
        noise: session.physics.noise_counts,
        gamma: o.response.exponent,
        spread: o.response.spread,
        measured: sd.iter().filter(|&&s| s < 0.01).count(),
        gain_sd: gain_sd / sco.len() as f64,
        cr_sd: cr_sd / sco.len() as f64,
        dist_mm: dist / sco.len() as f64,
    }
}

/// `forward`'s scored-half MAPE per seed from a `force_eval` `FORCE_EVAL_DEBUG` log.
fn forward_log(path: &str) -> BTreeMap<u64, f64> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("FORCE_FLOOR_FORWARD_LOG {path}: {e}"));
    text.lines()
        .filter_map(|l| {
            let rest = l.strip_prefix("seed ")?;
            let (seed, rest) = rest.split_once(' ')?;
            let rest = rest.strip_prefix("Forward: ")?;
            let v = rest.split("held-out ").nth(1)?.split(' ').next()?;
            Some((seed.parse().ok()?, v.parse().ok()?))
        })
        .collect()
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn main() {
    let debug = std::env::var_os("FORCE_FLOOR_DEBUG").is_some();
    let stride: usize = std::env::var("FORCE_FLOOR_STRIDE").ok().and_then(|s| s.parse().ok()).unwrap_or(1);
    let threads: usize = std::env::var("FORCE_FLOOR_THREADS").ok().and_then(|s| s.parse().ok()).unwrap_or(2).max(1);
    let s31 = std::env::var_os("FORCE_FLOOR_S31").is_some();
    let only_ml = std::env::var_os("FORCE_FLOOR_ONLY_ML").is_some();
    // the log's figures are the full sensor's: not put beside session 31's sensor
    let forward = std::env::var("FORCE_FLOOR_FORWARD_LOG").ok().filter(|_| !s31).map(|p| forward_log(&p));
    let tuning: Vec<u64> = (0..8).chain(700..706).chain(200..248).collect();
    let fresh: Vec<u64> = (5000..5200).collect();
    let mut sets: Vec<(String, Vec<u64>)> =
        vec![("tuning (0–7, 700–705, 200–247)".into(), tuning), ("fresh (5000–5199)".into(), fresh)];
    if let Some((a, b)) = std::env::var("FORCE_FLOOR_SEEDS").ok().and_then(|s| {
        let (a, b) = s.split_once("..")?;
        Some((a.parse::<u64>().ok()?, b.parse::<u64>().ok()?))
    }) {
        sets = vec![(format!("seeds {a}..{b}"), (a..b).collect())];
    }
    for (_, seeds) in &sets {
        if let Some(s) = seeds.iter().find(|s| held_out(**s)) {
            panic!("seed {s} is a held-out member of force_eval: not computed here");
        }
    }
    let sensor = if s31 {
        "session 31's ideal + gains sensor (Gaussian, no noise, γ = 1, s = 0)"
    } else {
        "ideal sensor but the gains"
    };
    println!(
        "information floor: per-frame Bayes-optimal force (MAPE-optimal) on force_eval's protocol, {sensor}; scored frames stride {stride}, {threads} threads"
    );
    for (name, seeds) in &sets {
        let t0 = Instant::now();
        let next = AtomicUsize::new(0);
        let out: Mutex<Vec<(MemberFloor, f64)>> = Mutex::new(Vec::new());
        std::thread::scope(|sc| {
            for _ in 0..threads {
                sc.spawn(|| loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(&seed) = seeds.get(i) else { break };
                    let t = Instant::now();
                    let m = member_floor(seed, stride, s31, only_ml);
                    out.lock().unwrap().push((m, t.elapsed().as_secs_f64()));
                });
            }
        });
        let mut rows = out.into_inner().unwrap();
        rows.sort_by_key(|r| r.0.seed);
        let wall = t0.elapsed().as_secs_f64();
        if debug {
            println!("\n{name}: per member (MAPE % on the scored half, true force > 0.5 N)");
            println!("| seed | told | **floor** | prior | told, 9 frames | **floor, 9 frames** | place unknown (ML) | place unknown, 9 frames (ML) | forward (log) | floor per scored press | kernel | w mm | A | σ | γ | s | gains sd < 0.01 | gain rel. sd at scored places | CR sd at 1 N | dist mm | frames | s |");
            println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
            for (m, secs) in &rows {
                let fw = forward.as_ref().and_then(|f| f.get(&m.seed)).map_or("—".into(), |v| format!("{v:.1}"));
                let pp: Vec<String> = m.per_press.iter().map(|v| format!("{v:.1}")).collect();
                println!(
                    "| {} | {:.2} | **{:.2}** | {:.1} | {:.2} | **{:.2}** | {:.2} | {:.2} | {fw} | {} | {} | {:.2} | {:.0} | {:.2} | {:.2} | {:.2} | {} | {:.2} % | {:.2} % | {:.1} | {} | {secs:.1} |",
                    m.seed,
                    m.told,
                    m.floor,
                    m.prior,
                    m.told9,
                    m.floor9,
                    m.mle,
                    m.mle9,
                    pp.join(" "),
                    m.kernel,
                    m.width_mm,
                    m.amplitude,
                    m.noise,
                    m.gamma,
                    m.spread,
                    m.measured,
                    m.gain_sd,
                    m.cr_sd,
                    m.dist_mm,
                    m.frames
                );
            }
        }
        println!("\n{name}: {} members, {:.0} s wall ({threads} threads, shared machine)", rows.len(), wall);
        println!("| observer | worst member | median | mean | members > 10 % | P(all 16 of a random 16 ≤ 10 %) |");
        println!("|---|---|---|---|---|---|");
        type Pick = fn(&MemberFloor) -> f64;
        let picks: [(&str, Pick); 7] = [
            ("one frame: gains told", |m| m.told),
            ("**one frame: calibrated (the floor)**", |m| m.floor),
            ("one frame: prior (no calibration)", |m| m.prior),
            ("9-frame window: gains told", |m| m.told9),
            ("**9-frame window: calibrated (the floor)**", |m| m.floor9),
            ("place unknown, ML with calibrated gains (not a floor)", |m| m.mle),
            ("place unknown, 9-frame window, ML with calibrated gains (not a floor)", |m| m.mle9),
        ];
        for (label, f) in picks {
            let mut v: Vec<f64> = rows.iter().map(|r| f(&r.0)).collect();
            if v.iter().all(|x| x.is_nan()) {
                continue; // not run (FORCE_FLOOR_ONLY_ML)
            }
            let worst = rows.iter().max_by(|a, b| f(&a.0).total_cmp(&f(&b.0))).map(|r| r.0.seed).unwrap_or(0);
            let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
            let over = v.iter().filter(|&&x| x > 10.0).count();
            let p = over as f64 / v.len().max(1) as f64;
            let max = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let med = median(&mut v);
            println!(
                "| {label} | {max:.1} % (seed {worst}) | {med:.2} % | {mean:.2} % | {over} of {} ({:.1} %) | {:.3} |",
                rows.len(),
                100.0 * p,
                (1.0 - p).powi(16)
            );
        }
        if let Some(fw) = &forward {
            let pairs: Vec<(f64, f64)> =
                rows.iter().filter_map(|(m, _)| fw.get(&m.seed).map(|&v| (m.floor, v))).collect();
            if !pairs.is_empty() {
                let n = pairs.len() as f64;
                let above = pairs.iter().filter(|p| p.1 > 10.0).count();
                println!(
                    "forward (log) on the same {} members: worst {:.1} %, mean {:.2} %, > 10 %: {above}; floor mean {:.2} %; forward − floor: mean {:.2} points",
                    pairs.len(),
                    pairs.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max),
                    pairs.iter().map(|p| p.1).sum::<f64>() / n,
                    pairs.iter().map(|p| p.0).sum::<f64>() / n,
                    pairs.iter().map(|p| p.1 - p.0).sum::<f64>() / n
                );
            }
        }
        let mut secs: Vec<f64> = rows.iter().map(|r| r.1).collect();
        println!("per member: median {:.1} s (one thread each)", median(&mut secs));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gradtac::stages::sim_force::Segment;

    /// A small member: `n` presses, ideal but the gains, with the given noise.
    fn small(seed: u64, n: usize, noise: f64) -> (ForceSession, ForceRecording, Oracle) {
        let mut s = ForceSession::presses(seed, n);
        for t in ["lag", "drift", "knee"] {
            assert!(s.physics.idealise(t));
        }
        s.physics.noise_counts = noise;
        let r = s.simulate();
        let o = Oracle::new(&s);
        (s, r, o)
    }

    #[test]
    fn held_out_and_fresh_seeds_are_refused() {
        for seed in [100, 115, 9000, 9015] {
            assert!(held_out(seed), "{seed}");
            assert!(std::panic::catch_unwind(|| idealised(seed, false)).is_err(), "{seed}");
        }
        for seed in [0, 99, 116, 5000, 8999, 9016] {
            assert!(!held_out(seed), "{seed}");
        }
    }

    #[test]
    fn the_marginal_matches_a_direct_sum() {
        // the recurrences against ln Σ wₖ exp(−(r − gₖh)²/2v), both regimes and the clamped ends
        let mut p = GainPost::prior();
        p.w.iter_mut().enumerate().for_each(|(k, w)| *w = (-(k as f64 - 20.0).powi(2) / 50.0).exp().max(1e-12));
        for &(r, h, var) in &[
            (-300.0, -250.0, 4.0),
            (-300.0, -250.0, 0.2),
            (10.0, -3.0, 9.0),
            (500.0, -100.0, 1.0),
            (-500.0, -100.0, 1.0),
            (3.0, 0.0, 2.0),
            (-40.0, -30.0, 25.0),
        ] {
            let direct = {
                let l: Vec<f64> =
                    (0..p.w.len()).map(|k| p.w[k].ln() - (r - p.g(k) * h).powi(2) / (2.0 * var)).collect();
                let m = l.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                m + l.iter().map(|x| (x - m).exp()).sum::<f64>().ln()
            };
            let fast = ln_marginal(r, h, &p, var);
            assert!((fast - direct).abs() < 1e-9 * direct.abs().max(1.0), "{r} {h} {var}: {fast} vs {direct}");
        }
        // the tail of erfc is right far out (ln Φc(10) = −53.23…)
        assert!((ln_upper_tail(10.0) + 53.231_285).abs() < 1e-5, "{}", ln_upper_tail(10.0));
        assert!((ln_upper_tail(0.0) - 0.5f64.ln()).abs() < 1e-6);
    }

    #[test]
    fn with_every_gain_told_a_noise_free_member_is_read_within_its_rounding() {
        // noise 0: only the ADC's rounding is left; the oracle's model must be the simulator's
        for seed in [3u64, 6, 9] {
            let (_, rec, o) = small(seed, 2, 0.0);
            let told: Vec<GainPost> = o.abs_gain.iter().map(|&g| GainPost::told(g)).collect();
            let mut n = 0;
            for k in (0..rec.frames.len()).filter(|&k| rec.force[k] > 0.5).step_by(23) {
                let (f0, rho) = (rec.force[k], o.rho(rec.contact[k].unwrap()));
                let f = estimate(&o, &told, &Window { frames: vec![(&rec.frames[k].values[..], 1.0)], rho });
                // the Cramér–Rao bound of ln F with the gains known: Σ (∂μᵢ/∂ln F)² / var
                let (mut up, mut dn) = ([0.0; 24], [0.0; 24]);
                o.unit(&rho, f0 * 1.001, &mut up);
                o.unit(&rho, f0 / 1.001, &mut dn);
                let info: f64 = (0..24).map(|i| (o.abs_gain[i] * (up[i] - dn[i]) / 0.002).powi(2)).sum::<f64>() / o.var;
                let sd = info.sqrt().recip();
                assert!((f / f0).ln().abs() < 4.0 * sd + 1e-3, "seed {seed} frame {k}: {f} vs {f0} (sd of ln F {sd})");
                n += 1;
            }
            assert!(n > 10);
        }
    }

    #[test]
    fn a_gain_excited_in_calibration_concentrates_at_the_truth_and_an_unexcited_one_keeps_its_prior() {
        let (mut s, _, _) = small(4, 1, 2.0);
        // one press over electrode 1 (the tip's side), a narrow Gaussian kernel: the far end of
        // the pad (electrode 10, ≈ 20 mm away) sees nothing
        s.physics.kernel = gradtac::stages::sim_family::KernelShape::Gaussian;
        s.physics.width_mm = 1.5;
        let e1 = gradtac::stream::Layout::biotac_sp().positions()[0];
        if let Segment::Press { at, .. } = &mut s.segments[1] {
            *at = e1;
        }
        let rec = s.simulate();
        let o = Oracle::new(&s);
        let (posts, stats) = calibrate(&o, &rec, 0..rec.frames.len());
        let best = (0..24).max_by(|&a, &b| stats[a].hh.total_cmp(&stats[b].hh)).unwrap();
        let (m, sd) = posts[best].mean_sd();
        assert!(sd < 0.01, "electrode {} sd {sd}", best + 1);
        assert!(
            (m - o.abs_gain[best]).abs() < 4.0 * sd + 1e-4,
            "electrode {}: {m} ± {sd} vs {}",
            best + 1,
            o.abs_gain[best]
        );
        // electrode 10: the prior, untouched
        assert!(stats[9].hh < 1e-12, "{}", stats[9].hh);
        let (m, sd) = posts[9].mean_sd();
        assert!(posts[9].tv_from_prior() < 1e-6, "{}", posts[9].tv_from_prior());
        assert!((m - 1.0).abs() < 1e-6 && (sd - 1.0 / 12f64.sqrt()).abs() < 1e-6, "{m} {sd}");
    }

    #[test]
    fn a_window_s_likelihood_is_the_product_of_its_frames_marginalised_once() {
        // the window's collapsed form against Σₖ wₖ Πⱼ N(xⱼ; b + gₖ hⱼ) summed directly, with a
        // calibrated posterior (first press) on a window of the second press
        let (_, rec, o) = small(2, 2, 3.0);
        let first_end = rec.segment.iter().position(|&s| s == 3).unwrap();
        let (posts, _) = calibrate(&o, &rec, 0..first_end);
        let k = (first_end..rec.frames.len()).find(|&k| rec.force[k] > 3.0).unwrap();
        let rho = o.rho(rec.contact[k].unwrap());
        let win = Window {
            frames: (k - 4..=k + 4).map(|j| (&rec.frames[j].values[..], rec.force[j] / rec.force[k])).collect(),
            rho,
        };
        let grid = ln_grid(0.5f64.ln(), 8f64.ln(), 7);
        let fast = log_lik(&o, &posts, &win, &grid);
        for (n, &lf) in grid.iter().enumerate() {
            let direct: f64 = (0..24)
                .map(|i| {
                    let p = &posts[i];
                    let l: Vec<f64> = (0..p.w.len())
                        .map(|q| {
                            p.w[q].ln()
                                + win
                                    .frames
                                    .iter()
                                    .map(|(x, r)| {
                                        let mut h = [0.0; 24];
                                        o.unit(&rho, lf.exp() * r, &mut h);
                                        -(x[i] - o.baseline[i] - p.g(q) * h[i]).powi(2) / (2.0 * o.var)
                                    })
                                    .sum::<f64>()
                        })
                        .collect();
                    let m = l.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                    m + l.iter().map(|v| (v - m).exp()).sum::<f64>().ln()
                })
                .sum();
            assert!((fast[n] - direct).abs() < 1e-6 * direct.abs().max(1.0), "F {}: {} vs {direct}", lf.exp(), fast[n]);
        }
    }

    #[test]
    fn the_place_unknown_reference_finds_place_and_force_on_a_noise_free_member() {
        // gains told, noise 0: the maximum-likelihood force with the place searched, one frame and
        // a 9-frame window, is the truth within 1 % (the rounding's reach on these presses)
        let (_, rec, o) = small(3, 2, 0.0);
        let starts = start_places();
        for k in (0..rec.frames.len()).filter(|&k| rec.force[k] > 1.0).step_by(97) {
            let (f0, rho) = (rec.force[k], o.rho(rec.contact[k].unwrap()));
            let one = Window { frames: vec![(&rec.frames[k].values[..], 1.0)], rho };
            let nine = Window {
                frames: (k - 4..=k + 4).map(|j| (&rec.frames[j].values[..], rec.force[j] / f0)).collect(),
                rho,
            };
            for w in [&one, &nine] {
                let f = mle_place_unknown(&o, &o.abs_gain, w, &starts);
                assert!((f / f0 - 1.0).abs() < 0.01, "frame {k} ({} frames): {f} vs {f0}", w.frames.len());
            }
        }
    }

    #[test]
    fn the_weighted_median_minimises_the_expected_relative_error() {
        // a two-point posterior: mass ⅔ at 1 N, ⅓ at 4 N; weights ∝ p/F give ⅔ vs 1/12: 1 N
        let grid = ln_grid(0.0, 4f64.ln(), 3);
        let lp = [(2.0f64 / 3.0).ln(), -1e9, (1.0f64 / 3.0).ln()];
        let f = weighted_median(&grid, &lp);
        assert!(f > 0.5 && f < 2.0, "{f}");
        // and a posterior flat in ln F over one cell gives the cell's centre
        let g = ln_grid(1.0, 1.0 + 1e-9, 2);
        assert!((weighted_median(&g, &[0.0, 0.0]).ln() - 1.0).abs() < 1e-6);
    }
}
