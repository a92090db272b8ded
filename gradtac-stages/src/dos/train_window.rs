//! Training of the window model [`DosWindowNet`] (cargo feature `train`; inference needs none
//! of this): augmentation of raw recordings, their windows, the network's fit by minibatch
//! Adam, and the leave-one-group-out choice among candidates.
//!
//! # Augmentation
//! Each training recording gives itself, with [`WindowAugment::mirror`] its mirror image (taxel
//! permutation of the layout's reflection across `y = 0`, class `e ↔ w`, `cw ↔ aw`), and
//! [`WindowAugment::copies`] random copies of either: [`train::augment`]'s noise, speed and time
//! warp, taxel dropout, layout rotation and vibration (no crop), then a **gain and an offset per
//! taxel**: every value of taxel `i` times `exp(g_i)` plus `o_i`, `g_i ~ N(0, gain)`,
//! `o_i ~ N(0, offset · σ)` with `σ` the spread of the first frame's levels across taxels —
//! what differs between two sensors, or one sensor before and after a re-mount. (The window
//! representation is not invariant to those, unlike the drift models'.) With
//! [`WindowAugment::imprint`] each copy also gets an **object imprint** ([`imprint`]): a static
//! smooth bump over neighbouring taxels, what a differently shaped object presses into the skin.
//!
//! Every non-overlapping window of every version is one training sample.
//!
//! # Fit
//! Inputs standardised (training mean and spread, spread floored at 1e-3), then minibatch Adam
//! (batches of [`WindowTrainConfig::batch`], shuffled every epoch, learning rate
//! [`WindowTrainConfig::learning_rate`]) on the mean cross-entropy plus `l2 · Σ w²` over the
//! weight matrices, Xavier-uniform initial weights; deterministic for a seed.

use super::train::{self, mirror_permutation, permute, Augment, SplitMix, TrainRecording};
use super::*;

/// Augmentation of the window model's training recordings (see the [module docs](self)).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WindowAugment {
    /// Add every recording's mirror image.
    pub mirror: bool,
    /// Random copies per recording (≤ 100).
    pub copies: usize,
    /// Spread of the per-taxel log gain (`[0, 1]`).
    pub gain: f64,
    /// Spread of the per-taxel offset, in units of the spread of levels across taxels (`[0, 10]`).
    pub offset: f64,
    /// Noise, speed, warp, dropout, rotation and vibration of the copies ([`Augment`]; its
    /// `mirror`, `copies` and `crop` are not used).
    pub base: Augment,
    /// Spread of the **object imprint** added to every random copy ([`imprint`]), in units of
    /// the spread of levels across taxels (`[0, 10]`; 0: none, the augmentation before stop 35,
    /// bit for bit). Not written when 0.
    #[serde(skip_serializing_if = "is_zero")]
    pub imprint: f64,
}

/// Whether `v` is exactly 0.
fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl Default for WindowAugment {
    fn default() -> Self {
        WindowAugment {
            mirror: true,
            copies: 1,
            gain: 0.01,
            offset: 0.1,
            base: Augment { crop: 0.0, ..Augment::default() },
            imprint: 0.0,
        }
    }
}

impl WindowAugment {
    /// Mirror images only.
    pub fn mirror_only() -> Self {
        WindowAugment { copies: 0, ..Default::default() }
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        self.base.validate()?;
        if self.copies > 100
            || !(0.0..=1.0).contains(&self.gain)
            || !(0.0..=10.0).contains(&self.offset)
            || !(0.0..=10.0).contains(&self.imprint)
        {
            return Err(invalid(format!(
                "window augmentation out of range: copies {} (≤ 100), gain {} (in [0, 1]), offset {} (in [0, 10]), \
                 imprint {} (in [0, 10])",
                self.copies, self.gain, self.offset, self.imprint
            )));
        }
        Ok(())
    }
}

/// Settings of a window-model fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WindowTrainConfig {
    /// Representation and network.
    pub net: WindowNetConfig,
    /// Weight decay on the weight matrices.
    pub l2: f64,
    /// Passes over the training windows (1..=1000).
    pub epochs: usize,
    /// Minibatch size (1..=100000).
    pub batch: usize,
    /// Adam's learning rate (`(0, 1]`).
    pub learning_rate: f64,
    /// Seed of the augmentation, the initial weights and the batches.
    pub seed: u64,
    /// Augmentation.
    pub augment: WindowAugment,
    /// Networks fitted with the seeds `seed, seed + 1, …` on the same windows and merged into
    /// one by averaging their logits ([`merge_members`]: one network of `members × hidden`
    /// hidden units, the same arithmetic at inference) (1..=16, `members × hidden` ≤ 256).
    /// Default 1.
    pub members: usize,
    /// Make the network mirror-symmetric by construction: after the fit, every member is merged
    /// with its own mirror image ([`mirrored_net`]: the inputs permuted by the layout's mirror
    /// permutation, the outputs by [`DosClass::mirrored`]), so a recording mirrored on the layout
    /// gets exactly the mirrored posterior (up to rounding). One network of `2 × members ×
    /// hidden` units (≤ 256) at inference. Needs a layout symmetric about `y = 0` and every
    /// class's mirror among the classes. Default off.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub mirror_average: bool,
}

impl Default for WindowTrainConfig {
    fn default() -> Self {
        WindowTrainConfig {
            net: WindowNetConfig::default(),
            l2: 1e-4,
            epochs: 20,
            batch: 64,
            learning_rate: 0.003,
            seed: 1,
            augment: WindowAugment::default(),
            members: 1,
            mirror_average: false,
        }
    }
}

impl WindowTrainConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        self.net.validate()?;
        self.augment.validate()?;
        train::check_optimiser(self.l2, self.epochs, 1000, self.learning_rate)?;
        if !(1..=100_000).contains(&self.batch) {
            return Err(invalid(format!("batch {} must be in 1..=100000", self.batch)));
        }
        let copies = if self.mirror_average { 2 } else { 1 };
        if !(1..=16).contains(&self.members) || copies * self.members * self.net.hidden > MAX_HIDDEN {
            return Err(invalid(format!(
                "members {} must be in 1..=16 with members × hidden ({}){} ≤ {MAX_HIDDEN}",
                self.members,
                self.net.hidden,
                if self.mirror_average { " × 2 (mirror_average)" } else { "" }
            )));
        }
        Ok(())
    }
}

/// The representations of every non-overlapping window of `frames`.
pub fn windows_of(frames: &[Vec<f64>], net: &WindowNetConfig, layout: &Layout) -> Result<Vec<Vec<f64>>> {
    let mut x = WindowExtractor::try_new_on(net, layout)?;
    let mut out = Vec::with_capacity(frames.len() / net.frames);
    for f in frames {
        if x.push(f)? {
            out.extend(x.input());
        }
    }
    Ok(out)
}

/// A gain and an offset per taxel (see the [module docs](self)).
pub fn gain_offset(frames: &mut [Vec<f64>], gain: f64, offset: f64, rng: &mut SplitMix) {
    let Some(first) = frames.first() else { return };
    let n = first.len() as f64;
    let mean = first.iter().sum::<f64>() / n;
    let sigma = (first.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    let g: Vec<f64> = first.iter().map(|_| (gain * rng.normal()).exp()).collect();
    let o: Vec<f64> = first.iter().map(|_| offset * sigma * rng.normal()).collect();
    for f in frames {
        for ((v, g), o) in f.iter_mut().zip(&g).zip(&o) {
            *v = *v * g + o;
        }
    }
}

/// Narrowest and widest object imprint ([`imprint`]), mm (the BioTac SP's electrodes are 4–6 mm
/// apart: from one or two electrodes to about a third of the skin).
pub const IMPRINT_WIDTH_MM: [f64; 2] = [3.0, 8.0];

/// The **object imprint** (see [`WindowAugment::imprint`]): a static, spatially smooth bump added
/// to every frame, `a · σ · exp(−|p_i − c|² / (2 w²))` on taxel `i` at `positions[i]`, with
/// `a ~ N(0, spread)`, `σ` the spread of the first frame's levels across taxels, the centre `c`
/// a random taxel's position and the width `w` uniform in [`IMPRINT_WIDTH_MM`]. What a different
/// object plausibly changes: where and how hard its shape presses the skin, smoothly over
/// neighbouring taxels (unlike [`gain_offset`]'s independent per-taxel offsets, a sensor's). The
/// same bump at every frame, so every change over time is untouched. Nothing drawn when `spread`
/// is 0 or there are no frames; `positions` must have one entry per taxel (otherwise nothing is
/// done).
pub fn imprint(frames: &mut [Vec<f64>], positions: &[[f64; 2]], spread: f64, rng: &mut SplitMix) {
    let Some(first) = frames.first() else { return };
    if spread <= 0.0 || positions.len() != first.len() || positions.is_empty() {
        return;
    }
    let n = first.len() as f64;
    let mean = first.iter().sum::<f64>() / n;
    let sigma = (first.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    let a = spread * sigma * rng.normal();
    let at = ((rng.uniform() * n) as usize).min(positions.len() - 1);
    let c = positions[at];
    let w = rng.range(IMPRINT_WIDTH_MM[0], IMPRINT_WIDTH_MM[1]);
    let bump: Vec<f64> = positions
        .iter()
        .map(|p| a * (-((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2)) / (2.0 * w * w)).exp())
        .collect();
    for f in frames {
        for (v, b) in f.iter_mut().zip(&bump) {
            *v += b;
        }
    }
}

/// The versions of one labelled recording: itself, its mirror image (with `augment.mirror`;
/// refused on a layout that is not symmetric) and `augment.copies` random copies of either.
pub fn versions(
    class: DosClass,
    frames: &[Vec<f64>],
    layout: &Layout,
    augment: &WindowAugment,
    rng: &mut SplitMix,
) -> Result<Vec<(DosClass, Vec<Vec<f64>>)>> {
    augment.validate()?;
    let mut out = vec![(class, frames.to_vec())];
    if augment.mirror {
        let p = mirror_permutation(layout)
            .ok_or_else(|| invalid("mirror augmentation needs a layout symmetric about y = 0"))?;
        out.push((class.mirrored(), permute(frames, &p)));
    }
    let base = Augment { crop: 0.0, ..augment.base.clone() };
    let originals = out.len();
    for k in 0..augment.copies {
        let (c, f) = &out[k % originals];
        let mut copy = train::augment(f, layout.positions(), &base, rng);
        gain_offset(&mut copy, augment.gain, augment.offset, rng);
        if augment.imprint > 0.0 {
            imprint(&mut copy, layout.positions(), augment.imprint, rng);
        }
        out.push((*c, copy));
    }
    Ok(out)
}

/// One recording's training windows: every window of every version, (class, representation).
pub type WindowSamples = Vec<(DosClass, Vec<f64>)>;

/// Every recording's training windows under `cfg` (seeded per recording, so folds share them).
pub fn window_samples(recs: &[TrainRecording], layout: &Layout, cfg: &WindowTrainConfig) -> Result<Vec<WindowSamples>> {
    cfg.validate()?;
    augmented_windows(recs, layout, &cfg.augment, cfg.seed, |f| windows_of(f, &cfg.net, layout))
}

/// Every recording's `windows` of each of its [`versions`] under `augment` (the random draws
/// seeded per recording from `seed`, so folds share them), with the version's class.
pub(crate) fn augmented_windows(
    recs: &[TrainRecording],
    layout: &Layout,
    augment: &WindowAugment,
    seed: u64,
    windows: impl Fn(&[Vec<f64>]) -> Result<Vec<Vec<f64>>>,
) -> Result<Vec<WindowSamples>> {
    recs.iter()
        .enumerate()
        .map(|(i, r)| {
            let mut rng = SplitMix::new(seed.wrapping_add(1_000_003 * i as u64));
            let mut out = Vec::new();
            for (c, f) in versions(r.class, &r.frames, layout, augment, &mut rng)? {
                out.extend(windows(&f)?.into_iter().map(|x| (c, x)));
            }
            Ok(out)
        })
        .collect()
}

/// Fit the window network on samples (each [`WindowNetConfig::inputs`] values for the
/// layout's taxels; see the [module docs](self)): [`WindowTrainConfig::members`] networks of
/// seeds `seed, seed + 1, …`, merged ([`merge_members`]), each with its mirror image when
/// [`WindowTrainConfig::mirror_average`]. The model's classes are those present, in
/// [`DosClass::ALL`] order.
pub fn fit_windows(samples: &[(DosClass, Vec<f64>)], layout: &Layout, cfg: &WindowTrainConfig) -> Result<DosWindowNet> {
    cfg.validate()?;
    let taxels = layout.len();
    let perm = if cfg.mirror_average {
        Some(mirror_permutation(layout).ok_or_else(|| invalid("mirror_average needs a layout symmetric about y = 0"))?)
    } else {
        None
    };
    if cfg.members == 1 && perm.is_none() {
        return fit_one(samples, taxels, cfg);
    }
    let mut nets = Vec::with_capacity(2 * cfg.members);
    for k in 0..cfg.members as u64 {
        let net =
            fit_one(samples, taxels, &WindowTrainConfig { seed: cfg.seed.wrapping_add(k), members: 1, ..cfg.clone() })?;
        if let Some(p) = &perm {
            let m = mirrored_net(&net, p)?;
            nets.push(net);
            nets.push(m);
        } else {
            nets.push(net);
        }
    }
    merge_members(&nets)
}

/// The mirror image of `net` under the layout permutation `perm` (taxel `i` ↔ `perm[i]`, an
/// involution, e.g. [`mirror_permutation`]): the network that gives a window the posterior
/// `net` gives the mirrored window, with every class mirrored ([`DosClass::mirrored`]). Every
/// block of per-taxel inputs (level pattern, pattern since the start, change across the window)
/// is permuted — the window representation of mirrored frames is the permuted representation,
/// because its sums and spread do not depend on the taxels' order — and so are the input
/// standardisation, the first layer's columns and the output rows. Fails when `perm` is not an
/// involution of the net's taxels or a class's mirror is not among the net's classes.
pub fn mirrored_net(net: &DosWindowNet, perm: &[usize]) -> Result<DosWindowNet> {
    let n = net.taxels;
    if perm.len() != n || (0..n).any(|i| perm[i] >= n || perm[perm[i]] != i) {
        return Err(invalid(format!("a mirror permutation of {n} taxels must be an involution of 0..{n}")));
    }
    let d = net.input_mean.len();
    // the per-taxel blocks are permuted; the motion inputs stay in place and change sign as the
    // reflection across y = 0 changes them (MOTION_MIRROR_SIGNS)
    let per_taxel = net.config.taxel_blocks() * n;
    let src: Vec<usize> = (0..d).map(|j| if j < per_taxel { (j / n) * n + perm[j % n] } else { j }).collect();
    let sign: Vec<f64> =
        (0..d).map(|j| if j < per_taxel { 1.0 } else { super::window::MOTION_MIRROR_SIGNS[j - per_taxel] }).collect();
    let out_src = net
        .classes
        .iter()
        .map(|c| net.classes.iter().position(|x| *x == c.mirrored()))
        .collect::<Option<Vec<usize>>>()
        .ok_or_else(|| invalid("mirroring a window network needs every class's mirror among its classes"))?;
    let m = DosWindowNet {
        config: net.config.clone(),
        taxels: n,
        classes: net.classes.clone(),
        input_mean: src.iter().zip(&sign).map(|(&j, g)| g * net.input_mean[j]).collect(),
        input_scale: src.iter().map(|&j| net.input_scale[j]).collect(),
        w1: net.w1.iter().map(|row| src.iter().zip(&sign).map(|(&j, g)| g * row[j]).collect()).collect(),
        b1: net.b1.clone(),
        w2: out_src.iter().map(|&c| net.w2[c].clone()).collect(),
        b2: out_src.iter().map(|&c| net.b2[c]).collect(),
        recordings: net.recordings,
    };
    m.validate()?;
    Ok(m)
}

/// One network ([`fit_windows`] with one member).
fn fit_one(samples: &[(DosClass, Vec<f64>)], taxels: usize, cfg: &WindowTrainConfig) -> Result<DosWindowNet> {
    let d = cfg.net.inputs(taxels);
    let train::Prepared { classes, mean, scale, xs, ys, mut p, mut rng } =
        train::prepare(samples, d, cfg.net.hidden, cfg.seed)?;
    let n = samples.len();
    let mut opt = train::Optimiser::new(d, cfg.net.hidden, classes.len());
    let mut order: Vec<usize> = (0..n).collect();
    let mut step = 0i32;
    for _ in 0..cfg.epochs {
        for i in (1..n).rev() {
            let j = (rng.next_u64() % (i as u64 + 1)) as usize;
            order.swap(i, j);
        }
        for chunk in order.chunks(cfg.batch) {
            step = step.saturating_add(1);
            let bn = chunk.len() as f64;
            opt.zero_grad();
            for &s in chunk {
                opt.accumulate(&p, &xs[s], ys[s], bn);
            }
            opt.step(&mut p, cfg.l2, cfg.learning_rate, step);
        }
    }
    let (w1, b1, w2, b2) = opt.unpack(&p);
    let net = DosWindowNet {
        config: cfg.net.clone(),
        taxels,
        classes,
        input_mean: mean,
        input_scale: scale,
        w1,
        b1,
        w2,
        b2,
        recordings: 0,
    };
    net.validate()?;
    Ok(net)
}

/// Merge window networks of one representation and one class list into one whose logits are
/// the mean of theirs (a logit-averaging ensemble): the hidden layers side by side, every
/// member's input standardisation folded into its rows against the first member's
/// (`w' = w·σ₀/σ_m`, `b' = b + Σ_j w_j (μ₀_j − μ_m_j)/σ_m_j`), the output rows divided by the
/// member count. Equal to the mean of the members' logits up to rounding (tested); one network
/// at inference, with `Σ hidden` units (≤ 256).
pub fn merge_members(nets: &[DosWindowNet]) -> Result<DosWindowNet> {
    let first = nets.first().ok_or_else(|| invalid("merging no window networks"))?;
    let k = nets.len() as f64;
    let shape = |c: &WindowNetConfig| WindowNetConfig { hidden: 0, ..c.clone() };
    let mut out = DosWindowNet {
        config: shape(&first.config),
        taxels: first.taxels,
        classes: first.classes.clone(),
        input_mean: first.input_mean.clone(),
        input_scale: first.input_scale.clone(),
        w1: Vec::new(),
        b1: Vec::new(),
        w2: vec![Vec::new(); first.classes.len()],
        b2: vec![0.0; first.classes.len()],
        recordings: first.recordings,
    };
    for n in nets {
        if n.taxels != first.taxels || n.classes != first.classes || shape(&n.config) != shape(&first.config) {
            return Err(invalid("merged window networks must share taxels, classes and representation"));
        }
        let same = n.input_mean == first.input_mean && n.input_scale == first.input_scale;
        for (row, b) in n.w1.iter().zip(&n.b1) {
            if same {
                // the same standardisation (members fitted on the same windows): rows unchanged
                out.w1.push(row.clone());
                out.b1.push(*b);
                continue;
            }
            let mut bias = *b;
            let mut r = Vec::with_capacity(row.len());
            for (j, w) in row.iter().enumerate() {
                r.push(w * first.input_scale[j] / n.input_scale[j]);
                bias += w * (first.input_mean[j] - n.input_mean[j]) / n.input_scale[j];
            }
            out.w1.push(r);
            out.b1.push(bias);
        }
        for (c, row) in n.w2.iter().enumerate() {
            if nets.len() == 1 {
                out.w2[c].extend_from_slice(row);
                out.b2[c] = n.b2[c];
            } else {
                out.w2[c].extend(row.iter().map(|w| w / k));
                out.b2[c] += n.b2[c] / k;
            }
        }
        out.config.hidden += n.config.hidden;
    }
    out.validate()?;
    Ok(out)
}

/// Fit on the windows of the recordings `train` (all their versions).
pub fn fit_on(
    samples: &[WindowSamples],
    train: &[usize],
    layout: &Layout,
    cfg: &WindowTrainConfig,
) -> Result<DosWindowNet> {
    let s: Vec<(DosClass, Vec<f64>)> = train.iter().flat_map(|&i| samples[i].iter().cloned()).collect();
    let mut net = fit_windows(&s, layout, cfg)?;
    net.recordings = train.len();
    Ok(net)
}

/// Per test recording: (correct windows, windows, whether the vote over all its windows is right).
pub fn score(
    net: &DosWindowNet,
    recs: &[TrainRecording],
    test: &[usize],
    layout: &Layout,
) -> Result<Vec<(usize, usize, bool)>> {
    score_vote(&mut net.vote(layout)?, recs, test)
}

/// [`score`] for any window model's vote (restarted for each recording of `test`).
pub fn score_vote(v: &mut impl SpanVote, recs: &[TrainRecording], test: &[usize]) -> Result<Vec<(usize, usize, bool)>> {
    test.iter()
        .map(|&i| {
            v.restart();
            let (mut ok, mut n) = (0, 0);
            for f in &recs[i].frames {
                if let Some(d) = v.push_frame(f)? {
                    ok += usize::from(d.class == recs[i].class);
                    n += 1;
                }
            }
            Ok((ok, n, v.vote_decision().is_some_and(|d| d.class == recs[i].class)))
        })
        .collect()
}

/// Each recording of `idx`'s mean log posterior per window over all its frames (`None` for one
/// shorter than a window), the vote restarted for each.
pub fn mean_log_posteriors(
    v: &mut impl SpanVote,
    recs: &[TrainRecording],
    idx: &[usize],
) -> Result<Vec<Option<Vec<f64>>>> {
    idx.iter()
        .map(|&i| {
            v.restart();
            for f in &recs[i].frames {
                v.push_frame(f)?;
            }
            Ok(v.vote_mean_log_posterior())
        })
        .collect()
}

/// The groups of `idx`, sorted.
pub(crate) fn groups_of<'a>(recs: &'a [TrainRecording], idx: &[usize]) -> Vec<&'a str> {
    let mut g: Vec<&str> = idx.iter().map(|&i| recs[i].group.as_str()).collect();
    g.sort_unstable();
    g.dedup();
    g
}

/// A held-out outcome of the window model: per test recording (index, correct windows, windows,
/// vote right), and per outer fold (name, chosen candidate, inner window accuracy).
#[derive(Clone, Debug, Default)]
pub struct WindowHeldOut {
    /// (recording, correct windows, windows, vote right).
    pub scores: Vec<(usize, usize, usize, bool)>,
    /// (fold, chosen candidate, inner accuracy per window).
    pub chosen: Vec<(String, usize, f64)>,
}

impl WindowHeldOut {
    /// (correct, decided) per window.
    pub fn windows(&self) -> (usize, usize) {
        self.scores.iter().fold((0, 0), |a, s| (a.0 + s.1, a.1 + s.2))
    }
    /// (correct, decided) per recording (the vote over all its windows).
    pub fn recordings(&self) -> (usize, usize) {
        (self.scores.iter().filter(|s| s.3).count(), self.scores.len())
    }
}

/// One candidate's inner tallies: ((correct windows, windows), (recordings whose vote is
/// right, recordings)).
pub type InnerScore = ((usize, usize), (usize, usize));

/// Leave-one-group-out over the recordings `idx` for each candidate (`samples[k]` are
/// candidate `k`'s windows): per candidate ((correct windows, windows), (recordings whose vote
/// is right, recordings)).
pub fn inner_scores(
    recs: &[TrainRecording],
    samples: &[&[WindowSamples]],
    idx: &[usize],
    layout: &Layout,
    candidates: &[WindowTrainConfig],
) -> Result<Vec<InnerScore>> {
    let groups = groups_of(recs, idx);
    if groups.len() < 2 {
        return Err(invalid(format!("leave-one-group-out needs at least two groups, got {}", groups.len())));
    }
    let mut out = Vec::with_capacity(candidates.len());
    for (k, cfg) in candidates.iter().enumerate() {
        let (mut w, mut r) = ((0, 0), (0, 0));
        for g in &groups {
            let train: Vec<usize> = idx.iter().copied().filter(|&i| recs[i].group != *g).collect();
            let test: Vec<usize> = idx.iter().copied().filter(|&i| recs[i].group == *g).collect();
            let net = fit_on(samples[k], &train, layout, cfg)?;
            for s in score(&net, recs, &test, layout)? {
                w = (w.0 + s.0, w.1 + s.1);
                r = (r.0 + usize::from(s.2), r.1 + 1);
            }
        }
        out.push((w, r));
    }
    Ok(out)
}

/// Leave-one-group-out accuracy per window over the recordings `idx` for each candidate
/// ([`inner_scores`]); the best (ties: the earlier): (index, accuracy).
pub fn choose_window(
    recs: &[TrainRecording],
    samples: &[&[WindowSamples]],
    idx: &[usize],
    layout: &Layout,
    candidates: &[WindowTrainConfig],
) -> Result<(usize, f64)> {
    let mut best = (0, f64::NEG_INFINITY);
    for (k, (w, _)) in inner_scores(recs, samples, idx, layout, candidates)?.into_iter().enumerate() {
        let acc = w.0 as f64 / w.1.max(1) as f64;
        if acc > best.1 {
            best = (k, acc);
        }
    }
    Ok(best)
}

/// Choose among `candidates` inside `train` (leave-one-group-out; no choice with one
/// candidate), fit the choice on `train`, score `test`.
#[allow(clippy::too_many_arguments)]
pub fn train_test_window(
    recs: &[TrainRecording],
    samples: &[&[WindowSamples]],
    train: &[usize],
    test: &[usize],
    name: &str,
    layout: &Layout,
    candidates: &[WindowTrainConfig],
) -> Result<(WindowHeldOut, DosWindowNet)> {
    let (k, acc) =
        if candidates.len() == 1 { (0, f64::NAN) } else { choose_window(recs, samples, train, layout, candidates)? };
    let net = fit_on(samples[k], train, layout, &candidates[k])?;
    let scores = score(&net, recs, test, layout)?.into_iter().zip(test).map(|((ok, n, v), &i)| (i, ok, n, v)).collect();
    Ok((WindowHeldOut { scores, chosen: vec![(name.to_string(), k, acc)] }, net))
}

/// Nested leave-one-group-out: for every group, the choice by leave-one-group-out on the other
/// groups, fitted on them, scores the held-out group.
pub fn nested_window(
    recs: &[TrainRecording],
    samples: &[&[WindowSamples]],
    layout: &Layout,
    candidates: &[WindowTrainConfig],
) -> Result<WindowHeldOut> {
    let all: Vec<usize> = (0..recs.len()).collect();
    let mut out = WindowHeldOut::default();
    for g in groups_of(recs, &all) {
        let train: Vec<usize> = all.iter().copied().filter(|&i| recs[i].group != g).collect();
        let test: Vec<usize> = all.iter().copied().filter(|&i| recs[i].group == g).collect();
        let (r, _) = train_test_window(recs, samples, &train, &test, g, layout, candidates)?;
        out.scores.extend(r.scores);
        out.chosen.extend(r.chosen);
    }
    Ok(out)
}
