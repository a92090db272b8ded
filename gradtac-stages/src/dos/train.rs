//! Training of the learned slip-direction model [`DosNet`] (cargo feature `train`; inference
//! needs none of this): augmentation of raw recordings ([`Augment`], [`augment`]), the
//! representation of each copy ([`represent`]) and the network's fit ([`fit`]).
//!
//! # Augmentation — what changes between objects and sensors
//! Each training recording gives itself, its mirror image (taxel permutation of the layout's
//! reflection across `y = 0`, class `e ↔ w`, `cw ↔ aw`; [`mirror_permutation`]) and
//! [`Augment::copies`] random copies of either, each drawing:
//! - **noise**: white noise of `U(0, noise)` times each taxel's own frame-to-frame noise;
//! - **speed and time warp**: resampled at a speed `exp(U(−ln speed, ln speed))` with a smooth
//!   warp (one sine period, `warp` of the span at most) — a slip faster or slower than the
//!   recording's;
//! - **taxel dropout**: each taxel with probability `dropout` replaced by its first value plus
//!   its own noise (a dead or unloaded electrode);
//! - **rotation**: the layout turned by `U(−rotation, rotation)` degrees about its centre, every
//!   taxel's signal resampled from its neighbours (Gaussian kernel of 2.5 mm) at its rotated position;
//! - **vibration**: with probability ½, a sinusoid of 8–30 Hz of `U(0, vibration)` taxel-noise
//!   amplitudes (random phase per taxel) added; otherwise, with probability ½, the signal
//!   smoothed by a 5-frame moving average (vibration removed);
//! - **crop**: with probability `crop`, only the first `U(100, n)` frames (early answers).
//!
//! A per-taxel gain and offset is not drawn: the representation is exactly invariant to it
//! (tested), so such copies would be identical.
//!
//! # Fit
//! Inputs standardised (training mean and spread, spread floored), then full-batch Adam
//! (learning rate 0.01) on the mean cross-entropy plus `l2 · Σ w²` over the weight matrices,
//! `epochs` steps, Xavier-uniform initial weights from `seed`. Deterministic for a seed.

use super::dense::dot;
use super::net::softmax;
use super::*;

/// Augmentation strengths (see the [module docs](self)). The strengths were set a priori (not
/// tuned); the number of copies (0 or 2) is chosen per fold.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Augment {
    /// Add every recording's mirror image.
    pub mirror: bool,
    /// Random copies per recording (0: none).
    pub copies: usize,
    /// Largest added white noise, in units of each taxel's noise.
    pub noise: f64,
    /// Largest speed factor (≥ 1; copies run at `1/speed ..= speed`).
    pub speed: f64,
    /// Largest smooth time warp, as a fraction of the span (`[0, 0.3]`).
    pub warp: f64,
    /// Probability of dropping each taxel.
    pub dropout: f64,
    /// Largest layout rotation, degrees.
    pub rotation: f64,
    /// Largest added vibration, in units of each taxel's noise.
    pub vibration: f64,
    /// Probability of cropping a copy to a prefix.
    pub crop: f64,
}

impl Default for Augment {
    fn default() -> Self {
        Augment {
            mirror: true,
            copies: 2,
            noise: 1.0,
            speed: 1.3,
            warp: 0.1,
            dropout: 0.05,
            rotation: 10.0,
            vibration: 3.0,
            crop: 0.3,
        }
    }
}

impl Augment {
    /// Mirror images only (no random copies).
    pub fn mirror_only() -> Self {
        Augment { copies: 0, ..Default::default() }
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        let ok = self.copies <= 1000
            && (0.0..=100.0).contains(&self.noise)
            && (1.0..=4.0).contains(&self.speed)
            && (0.0..=0.3).contains(&self.warp)
            && (0.0..=0.9).contains(&self.dropout)
            && (0.0..=90.0).contains(&self.rotation)
            && (0.0..=100.0).contains(&self.vibration)
            && (0.0..=1.0).contains(&self.crop);
        if ok {
            Ok(())
        } else {
            Err(invalid(format!(
                "augmentation out of range: {self:?} (copies ≤ 1000, noise and vibration in [0, 100], speed in [1, 4], \
                 warp in [0, 0.3], dropout in [0, 0.9], rotation in [0, 90]°, crop in [0, 1])"
            )))
        }
    }
}

/// Settings of a fit. The defaults (16 hidden units, lags 0.3 and 0.6 s, `l2` 0.01, 300 steps,
/// mirror images and two random copies per recording at the [`Augment`] defaults) are what the
/// nested procedure of `dos_eval` picks on all 167 development recordings (in-sample for that
/// choice; the held-out figures are in the [module docs](crate::dos)).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrainConfig {
    /// Representation and network.
    pub net: NetConfig,
    /// Weight decay `l2` on the weight matrices.
    pub l2: f64,
    /// Adam steps (full batch, 1..=100000).
    pub epochs: usize,
    /// Adam's learning rate.
    pub learning_rate: f64,
    /// Seed of the augmentation and the initial weights.
    pub seed: u64,
    /// Augmentation.
    pub augment: Augment,
}

impl Default for TrainConfig {
    fn default() -> Self {
        TrainConfig {
            net: NetConfig::default(),
            l2: 1e-2,
            epochs: 300,
            learning_rate: 0.01,
            seed: 1,
            augment: Augment::default(),
        }
    }
}

impl TrainConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        self.net.validate()?;
        self.augment.validate()?;
        check_optimiser(self.l2, self.epochs, 100_000, self.learning_rate)
    }
}

/// The optimiser settings both trainers share: `l2` finite and ≥ 0, `epochs` in
/// `1..=max_epochs`, `learning_rate` in (0, 1].
pub(super) fn check_optimiser(l2: f64, epochs: usize, max_epochs: usize, learning_rate: f64) -> Result<()> {
    if !(l2.is_finite() && l2 >= 0.0) {
        return Err(invalid(format!("l2 {l2} must be finite and ≥ 0")));
    }
    if !(1..=max_epochs).contains(&epochs) {
        return Err(invalid(format!("epochs {epochs} must be in 1..={max_epochs}")));
    }
    if !(learning_rate.is_finite() && learning_rate > 0.0 && learning_rate <= 1.0) {
        return Err(invalid(format!("learning_rate {learning_rate} must be in (0, 1]")));
    }
    Ok(())
}

pub use crate::splitmix::SplitMix;

/// The permutation of `layout`'s taxels under its reflection across `y = 0` (`p[i]` is the taxel
/// at `(x_i, −y_i)`, within 0.1 mm), or `None` when the layout is not symmetric.
pub fn mirror_permutation(layout: &Layout) -> Option<Vec<usize>> {
    let pos = layout.positions();
    pos.iter()
        .map(|a| pos.iter().position(|b| (a[0] - b[0]).abs() < 0.1 && (a[1] + b[1]).abs() < 0.1))
        .collect::<Option<Vec<_>>>()
        .filter(|p| (0..p.len()).all(|i| p[p[i]] == i))
}

/// `frames` with taxel `i` taking taxel `perm[i]`'s values.
pub fn permute(frames: &[Vec<f64>], perm: &[usize]) -> Vec<Vec<f64>> {
    frames.iter().map(|f| perm.iter().map(|&j| f[j]).collect()).collect()
}

/// Mean `|x_t − x_{t−1}|` per taxel (0 for fewer than two frames).
fn noise_of(frames: &[Vec<f64>]) -> Vec<f64> {
    let n = frames.first().map_or(0, Vec::len);
    let mut s = vec![0.0; n];
    for w in frames.windows(2) {
        for i in 0..n {
            s[i] += (w[1][i] - w[0][i]).abs();
        }
    }
    let k = frames.len().saturating_sub(1).max(1) as f64;
    s.iter().map(|v| v / k).collect()
}

/// One random copy of `frames` (see the [module docs](self)); `positions` are the layout's.
pub fn augment(frames: &[Vec<f64>], positions: &[[f64; 2]], a: &Augment, rng: &mut SplitMix) -> Vec<Vec<f64>> {
    if frames.len() < 2 {
        return frames.to_vec();
    }
    let n = frames[0].len();
    let noise = noise_of(frames);
    // speed and warp: output frame k reads input time t(k)
    let speed = (rng.range(-1.0, 1.0) * a.speed.ln()).exp();
    let len = frames.len();
    let out_len = ((len as f64 / speed).round() as usize).clamp(2, 4 * len);
    let warp = rng.range(-a.warp, a.warp);
    let mut out: Vec<Vec<f64>> = (0..out_len)
        .map(|k| {
            let u = k as f64 / (out_len - 1) as f64;
            let u = u + warp * (std::f64::consts::PI * u).sin() / std::f64::consts::PI;
            let t = (u * (len - 1) as f64).clamp(0.0, (len - 1) as f64);
            let (i, f) = (t.floor() as usize, t.fract());
            let j = (i + 1).min(len - 1);
            (0..n).map(|c| frames[i][c] * (1.0 - f) + frames[j][c] * f).collect()
        })
        .collect();
    // rotation about the layout's centroid, Gaussian-kernel resampling
    if a.rotation > 0.0 {
        let th = rng.range(-a.rotation, a.rotation).to_radians();
        let cx = positions.iter().map(|p| p[0]).sum::<f64>() / n as f64;
        let cy = positions.iter().map(|p| p[1]).sum::<f64>() / n as f64;
        let (s, c) = th.sin_cos();
        // weights of taxel j for the value at taxel i's position rotated back, applied to
        // each taxel's change from its first value (each taxel keeps its own baseline)
        let kernel: Vec<Vec<f64>> = positions
            .iter()
            .map(|p| {
                let (dx, dy) = (p[0] - cx, p[1] - cy);
                let q = [cx + c * dx + s * dy, cy - s * dx + c * dy];
                let w: Vec<f64> = positions
                    .iter()
                    .map(|r| (-((q[0] - r[0]).powi(2) + (q[1] - r[1]).powi(2)) / (2.0 * 2.5 * 2.5)).exp())
                    .collect();
                let t: f64 = w.iter().sum();
                w.iter().map(|v| v / t).collect()
            })
            .collect();
        let first = out[0].clone();
        for f in &mut out {
            let d: Vec<f64> = f.iter().zip(&first).map(|(v, b)| v - b).collect();
            for i in 0..n {
                f[i] = first[i] + dot(&kernel[i], &d);
            }
        }
    }
    // vibration added, or removed
    let r = rng.uniform();
    if r < 0.5 && a.vibration > 0.0 {
        let hz = rng.range(8.0, 30.0);
        let amp = rng.range(0.0, a.vibration);
        let phases: Vec<f64> = (0..n).map(|_| rng.range(0.0, std::f64::consts::TAU)).collect();
        for (k, f) in out.iter_mut().enumerate() {
            let t = k as f64 / 100.0;
            for i in 0..n {
                f[i] += amp * noise[i] * (std::f64::consts::TAU * hz * t + phases[i]).sin();
            }
        }
    } else if r >= 0.75 {
        let src = out.clone();
        for (k, f) in out.iter_mut().enumerate() {
            let (lo, hi) = (k.saturating_sub(2), (k + 3).min(src.len()));
            for i in 0..n {
                f[i] = src[lo..hi].iter().map(|g| g[i]).sum::<f64>() / (hi - lo) as f64;
            }
        }
    }
    // white noise
    let sigma = rng.range(0.0, a.noise);
    if sigma > 0.0 {
        for f in &mut out {
            for i in 0..n {
                f[i] += sigma * noise[i] * rng.normal();
            }
        }
    }
    // taxel dropout
    for i in 0..n {
        if rng.uniform() < a.dropout {
            let base = out[0][i];
            for f in &mut out {
                f[i] = base + noise[i] * rng.normal();
            }
        }
    }
    // crop
    if rng.uniform() < a.crop && out.len() > 100 {
        let keep = rng.range(100.0, out.len() as f64) as usize;
        out.truncate(keep.max(100));
    }
    out
}

/// The representation ([`NetExtractor::input`]) of a whole recording.
pub fn represent(frames: &[Vec<f64>], layout: &Layout, net: &NetConfig) -> Result<Vec<f64>> {
    let mut ex = NetExtractor::try_new(net, layout)?;
    for f in frames {
        ex.push(f)?;
    }
    Ok(ex.input())
}

/// The training representations of labelled recordings: each recording, its mirror image
/// (with `augment.mirror`; refused on a layout that is not symmetric) and `augment.copies`
/// random copies of either; `recordings` are (class, frames).
pub fn training_set(
    recordings: &[(DosClass, &[Vec<f64>])],
    layout: &Layout,
    cfg: &TrainConfig,
) -> Result<Vec<(DosClass, Vec<f64>)>> {
    cfg.validate()?;
    let perm = if cfg.augment.mirror {
        Some(
            mirror_permutation(layout)
                .ok_or_else(|| invalid("mirror augmentation needs a layout symmetric about y = 0"))?,
        )
    } else {
        None
    };
    let mut rng = SplitMix::new(cfg.seed);
    let mut out = Vec::new();
    for (class, frames) in recordings {
        let mut versions = vec![(*class, frames.to_vec())];
        if let Some(p) = &perm {
            versions.push((class.mirrored(), permute(frames, p)));
        }
        for (c, f) in &versions {
            out.push((*c, represent(f, layout, &cfg.net)?));
        }
        for k in 0..cfg.augment.copies {
            let (c, f) = &versions[k % versions.len()];
            let copy = augment(f, layout.positions(), &cfg.augment, &mut rng);
            out.push((*c, represent(&copy, layout, &cfg.net)?));
        }
    }
    Ok(out)
}

/// What both trainers start from ([`fit`] and the window trainer's `fit_windows`): the classes
/// present (in [`DosClass::ALL`] order, at least two), the inputs standardised by their mean
/// and spread (at least 1e-3), each sample's class index, and the flattened parameters — `w1`
/// (`hidden × d`), `b1`, `w2` (`classes × hidden`), `b2` — with Glorot-uniform weights and
/// zero biases drawn from the seed's generator, which the trainer goes on using.
pub(super) struct Prepared {
    pub classes: Vec<DosClass>,
    pub mean: Vec<f64>,
    pub scale: Vec<f64>,
    pub xs: Vec<Vec<f64>>,
    pub ys: Vec<usize>,
    pub p: Vec<f64>,
    pub rng: SplitMix,
}

/// [`Prepared`] for `samples` of `d` values each; an error for fewer than two classes or a
/// sample of the wrong length or with a non-finite value.
pub(super) fn prepare(samples: &[(DosClass, Vec<f64>)], d: usize, hidden: usize, seed: u64) -> Result<Prepared> {
    let classes: Vec<DosClass> = DosClass::ALL.into_iter().filter(|c| samples.iter().any(|(s, _)| s == c)).collect();
    if classes.len() < 2 {
        return Err(invalid(format!("training needs at least two classes, got {}", classes.len())));
    }
    for (i, (_, x)) in samples.iter().enumerate() {
        if x.len() != d || x.iter().any(|v| !v.is_finite()) {
            return Err(invalid(format!("sample {i} must be {d} finite values")));
        }
    }
    let n = samples.len() as f64;
    let mean: Vec<f64> = (0..d).map(|j| samples.iter().map(|s| s.1[j]).sum::<f64>() / n).collect();
    let scale: Vec<f64> = (0..d)
        .map(|j| {
            let v = samples.iter().map(|s| (s.1[j] - mean[j]).powi(2)).sum::<f64>() / n;
            v.sqrt().max(1e-3)
        })
        .collect();
    let xs: Vec<Vec<f64>> =
        samples.iter().map(|(_, x)| x.iter().zip(&mean).zip(&scale).map(|((v, m), s)| (v - m) / s).collect()).collect();
    let ys: Vec<usize> = samples.iter().map(|(c, _)| classes.iter().position(|k| k == c).unwrap_or(0)).collect();
    let (h, c) = (hidden, classes.len());
    let mut rng = SplitMix::new(seed.wrapping_add(0x5EED));
    let a1 = (6.0 / (d + h) as f64).sqrt();
    let a2 = (6.0 / (h + c) as f64).sqrt();
    let (o_w2, o_b2) = (h * d + h, h * d + h + c * h);
    let mut p = vec![0.0; o_b2 + c];
    for v in &mut p[..h * d] {
        *v = rng.range(-a1, a1);
    }
    for v in &mut p[o_w2..o_b2] {
        *v = rng.range(-a2, a2);
    }
    Ok(Prepared { classes, mean, scale, xs, ys, p, rng })
}

/// Fit the network on representations (each `net.inputs(taxels)` values) — see the
/// [module docs](self). The model's classes are those present, in [`DosClass::ALL`] order.
pub fn fit(samples: &[(DosClass, Vec<f64>)], taxels: usize, cfg: &TrainConfig) -> Result<DosNet> {
    cfg.validate()?;
    let d = cfg.net.inputs(taxels);
    let Prepared { classes, mean, scale, xs, ys, mut p, .. } = prepare(samples, d, cfg.net.hidden, cfg.seed)?;
    let n = samples.len() as f64;
    let mut opt = Optimiser::new(d, cfg.net.hidden, classes.len());
    for step in 1..=cfg.epochs {
        opt.zero_grad();
        for (x, &y) in xs.iter().zip(&ys) {
            opt.accumulate(&p, x, y, n);
        }
        opt.step(&mut p, cfg.l2, cfg.learning_rate, step as i32);
    }
    let (w1, b1, w2, b2) = opt.unpack(&p);
    let net = DosNet {
        config: cfg.net.clone(),
        taxels,
        classes,
        input_mean: mean,
        input_scale: scale,
        w1,
        b1,
        w2,
        b2,
        recordings: samples.len(),
    };
    net.validate()?;
    Ok(net)
}

const MAX_PRE: f64 = 40.0;

/// The one-hidden-layer network's full-batch or mini-batch training step that both trainers
/// share ([`fit`] and the window trainer's `fit_windows`): the gradient of the mean
/// cross-entropy over the flattened parameters of [`Prepared::p`] (tanh hidden units,
/// pre-activations clamped to ±40), L2 weight decay on the weights (not the biases) and an Adam
/// step (β₁ 0.9, β₂ 0.999, ε 1e-8), with its moments and scratch buffers.
pub(super) struct Optimiser {
    d: usize,
    h: usize,
    c: usize,
    m1: Vec<f64>,
    m2: Vec<f64>,
    g: Vec<f64>,
    hid: Vec<f64>,
    dh: Vec<f64>,
}

impl Optimiser {
    const BETA1: f64 = 0.9;
    const BETA2: f64 = 0.999;
    const EPS: f64 = 1e-8;

    /// For `d` inputs, `h` hidden units and `c` classes.
    pub fn new(d: usize, h: usize, c: usize) -> Optimiser {
        let total = h * d + h + c * h + c;
        Optimiser {
            d,
            h,
            c,
            m1: vec![0.0; total],
            m2: vec![0.0; total],
            g: vec![0.0; total],
            hid: vec![0.0; h],
            dh: vec![0.0; h],
        }
    }

    /// Offsets of `b1`, `w2` and `b2` in the flattened parameters (`w1` starts at 0).
    fn offsets(&self) -> (usize, usize, usize) {
        let (d, h, c) = (self.d, self.h, self.c);
        (h * d, h * d + h, h * d + h + c * h)
    }

    /// Start a new batch's gradient.
    pub fn zero_grad(&mut self) {
        self.g.iter_mut().for_each(|v| *v = 0.0);
    }

    /// Add one standardised sample's cross-entropy gradient, divided by `n` (the batch size).
    pub fn accumulate(&mut self, p: &[f64], x: &[f64], y: usize, n: f64) {
        let (d, h, c) = (self.d, self.h, self.c);
        let (o_b1, o_w2, o_b2) = self.offsets();
        let (g, hid, dh) = (&mut self.g, &mut self.hid, &mut self.dh);
        for k in 0..h {
            hid[k] = (p[o_b1 + k] + dot(&p[k * d..(k + 1) * d], x)).clamp(-MAX_PRE, MAX_PRE).tanh();
        }
        let logits: Vec<f64> =
            (0..c).map(|k| p[o_b2 + k] + dot(&p[o_w2 + k * h..o_w2 + (k + 1) * h], &hid[..])).collect();
        let prob = softmax(&logits);
        dh.iter_mut().for_each(|v| *v = 0.0);
        for k in 0..c {
            let e = (prob[k] - f64::from(u8::from(k == y))) / n;
            g[o_b2 + k] += e;
            for j in 0..h {
                g[o_w2 + k * h + j] += e * hid[j];
                dh[j] += e * p[o_w2 + k * h + j];
            }
        }
        for k in 0..h {
            let e = dh[k] * (1.0 - hid[k] * hid[k]);
            g[o_b1 + k] += e;
            for (r, v) in g[k * d..(k + 1) * d].iter_mut().zip(x) {
                *r += e * v;
            }
        }
    }

    /// Weight decay `l2` on the weights, then Adam step number `step` (from 1) at `learning_rate`.
    // four arrays indexed alike read most clearly by index
    #[allow(clippy::needless_range_loop)]
    pub fn step(&mut self, p: &mut [f64], l2: f64, learning_rate: f64, step: i32) {
        let (o_b1, o_w2, o_b2) = self.offsets();
        let (beta1, beta2) = (Self::BETA1, Self::BETA2);
        for (i, gi) in self.g.iter_mut().enumerate() {
            if i < o_b1 || (o_w2..o_b2).contains(&i) {
                *gi += 2.0 * l2 * p[i];
            }
        }
        let (b1t, b2t) = (1.0 - beta1.powi(step), 1.0 - beta2.powi(step));
        for i in 0..self.g.len() {
            let gi = self.g[i];
            self.m1[i] = beta1 * self.m1[i] + (1.0 - beta1) * gi;
            self.m2[i] = beta2 * self.m2[i] + (1.0 - beta2) * gi * gi;
            p[i] -= learning_rate * (self.m1[i] / b1t) / ((self.m2[i] / b2t).sqrt() + Self::EPS);
        }
    }

    /// The flattened parameters as `(w1, b1, w2, b2)`.
    #[allow(clippy::type_complexity)]
    pub fn unpack(&self, p: &[f64]) -> (Vec<Vec<f64>>, Vec<f64>, Vec<Vec<f64>>, Vec<f64>) {
        let (d, h, c) = (self.d, self.h, self.c);
        let (o_b1, o_w2, o_b2) = self.offsets();
        (
            (0..h).map(|k| p[k * d..(k + 1) * d].to_vec()).collect(),
            p[o_b1..o_w2].to_vec(),
            (0..c).map(|k| p[o_w2 + k * h..o_w2 + (k + 1) * h].to_vec()).collect(),
            p[o_b2..].to_vec(),
        )
    }
}

/// A recording's training representations: itself first, then its mirror image and copies.
pub type Versions = Vec<(DosClass, Vec<f64>)>;

/// Every recording's [`Versions`], in the recordings' order.
pub type Representations = Vec<Versions>;

/// One labelled recording for training and held-out scoring.
#[derive(Clone, Debug)]
pub struct TrainRecording {
    /// The labelled class.
    pub class: DosClass,
    /// Its group (the object; held out together).
    pub group: String,
    /// Raw values, one row per frame.
    pub frames: Vec<Vec<f64>>,
}

/// Every recording's training representations under `cfg` ([`training_set`] of each alone: the
/// recording first, then its mirror image and copies). They do not depend on which recordings
/// a fold trains on, so folds share them.
pub fn represent_recordings(recs: &[TrainRecording], layout: &Layout, cfg: &TrainConfig) -> Result<Representations> {
    recs.iter()
        .enumerate()
        .map(|(i, r)| {
            let c = TrainConfig { seed: cfg.seed.wrapping_add(1_000_003 * i as u64), ..cfg.clone() };
            training_set(&[(r.class, &r.frames)], layout, &c)
        })
        .collect()
}

/// Fit on the representations of the recordings `train` (all their versions) and count the
/// correct decisions on the recordings `test` (their first version, the recording itself):
/// (correct, decided, the model).
pub fn fit_and_score(
    reps: &[Vec<(DosClass, Vec<f64>)>],
    train: &[usize],
    test: &[usize],
    taxels: usize,
    cfg: &TrainConfig,
) -> Result<(usize, usize, DosNet)> {
    let samples: Vec<(DosClass, Vec<f64>)> = train.iter().flat_map(|&i| reps[i].iter().cloned()).collect();
    let net = fit(&samples, taxels, cfg)?;
    let mut ok = 0;
    for &i in test {
        let (c, x) = &reps[i][0];
        ok += usize::from(net.classify(x)?.class == *c);
    }
    Ok((ok, test.len(), net))
}

/// The groups of `idx`, sorted.
fn groups_of<'a>(recs: &'a [TrainRecording], idx: &[usize]) -> Vec<&'a str> {
    let mut g: Vec<&str> = idx.iter().map(|&i| recs[i].group.as_str()).collect();
    g.sort_unstable();
    g.dedup();
    g
}

/// Leave-one-group-out over the recordings `idx` of one candidate (representations `reps`):
/// (correct, decided).
pub fn leave_one_group_out(
    recs: &[TrainRecording],
    reps: &[Vec<(DosClass, Vec<f64>)>],
    idx: &[usize],
    taxels: usize,
    cfg: &TrainConfig,
) -> Result<(usize, usize)> {
    let groups = groups_of(recs, idx);
    if groups.len() < 2 {
        return Err(invalid(format!("leave-one-group-out needs at least two groups, got {}", groups.len())));
    }
    let (mut ok, mut n) = (0, 0);
    for g in groups {
        let train: Vec<usize> = idx.iter().copied().filter(|&i| recs[i].group != g).collect();
        let test: Vec<usize> = idx.iter().copied().filter(|&i| recs[i].group == g).collect();
        let r = fit_and_score(reps, &train, &test, taxels, cfg)?;
        ok += r.0;
        n += r.1;
    }
    Ok((ok, n))
}

/// The candidate with the best leave-one-group-out accuracy over the recordings `idx` (ties:
/// the earlier one): (index, accuracy). `reps[k]` are candidate `k`'s representations.
pub fn choose(
    recs: &[TrainRecording],
    reps: &[&[Versions]],
    idx: &[usize],
    taxels: usize,
    candidates: &[TrainConfig],
) -> Result<(usize, f64)> {
    let mut best = (0, f64::NEG_INFINITY);
    for (k, cfg) in candidates.iter().enumerate() {
        let (ok, n) = leave_one_group_out(recs, reps[k], idx, taxels, cfg)?;
        let acc = ok as f64 / n.max(1) as f64;
        if acc > best.1 {
            best = (k, acc);
        }
    }
    Ok(best)
}

/// A held-out split's outcome: per test recording (index, decided class), and the choice made.
#[derive(Clone, Debug)]
pub struct NetHeldOut {
    /// (test recording, decided class).
    pub decisions: Vec<(usize, DosClass)>,
    /// Per outer fold: (held-out group or split name, chosen candidate, inner accuracy).
    pub chosen: Vec<(String, usize, f64)>,
}

impl NetHeldOut {
    /// (correct, decided) against `recs`' labels.
    pub fn tally(&self, recs: &[TrainRecording]) -> (usize, usize) {
        (self.decisions.iter().filter(|(i, c)| recs[*i].class == *c).count(), self.decisions.len())
    }
}

/// Train on `train` with the candidate chosen by leave-one-group-out inside `train`, decide
/// every recording of `test`.
pub fn train_test(
    recs: &[TrainRecording],
    reps: &[&[Versions]],
    train: &[usize],
    test: &[usize],
    name: &str,
    taxels: usize,
    candidates: &[TrainConfig],
) -> Result<NetHeldOut> {
    let (k, acc) = if candidates.len() == 1 { (0, f64::NAN) } else { choose(recs, reps, train, taxels, candidates)? };
    let (_, _, net) = fit_and_score(reps[k], train, &[], taxels, &candidates[k])?;
    let decisions =
        test.iter().map(|&i| net.classify(&reps[k][i][0].1).map(|d| (i, d.class))).collect::<Result<Vec<_>>>()?;
    Ok(NetHeldOut { decisions, chosen: vec![(name.to_string(), k, acc)] })
}

/// Nested leave-one-group-out: for every group, the choice by leave-one-group-out on the other
/// groups, fitted on them, decides the held-out group.
pub fn nested(
    recs: &[TrainRecording],
    reps: &[&[Versions]],
    taxels: usize,
    candidates: &[TrainConfig],
) -> Result<NetHeldOut> {
    let all: Vec<usize> = (0..recs.len()).collect();
    let mut out = NetHeldOut { decisions: Vec::new(), chosen: Vec::new() };
    for g in groups_of(recs, &all) {
        let train: Vec<usize> = all.iter().copied().filter(|&i| recs[i].group != g).collect();
        let test: Vec<usize> = all.iter().copied().filter(|&i| recs[i].group == g).collect();
        let r = train_test(recs, reps, &train, &test, g, taxels, candidates)?;
        out.decisions.extend(r.decisions);
        out.chosen.extend(r.chosen);
    }
    Ok(out)
}
