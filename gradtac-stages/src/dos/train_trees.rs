//! Training of the tree model [`DosTrees`] (cargo feature `train`; inference needs none of this):
//! a small hand-written histogram gradient-boosting trainer with the softmax loss, on the window
//! model's augmented recordings ([`train_window::versions`]).
//!
//! # Why hand-written
//! The pure-Rust crates checked (crates.io, stop 33): `gbdt` 0.1.3 (Apache-2.0; its losses are
//! regression and binary log-likelihood, so seven classes would be seven one-vs-rest models, and
//! its trees are its own structs to convert), `forust-ml` 0.8.0 (no licence field on crates.io)
//! and `perpetual` (the current release a 3.0 release candidate). None gives softmax boosting
//! with a stable release and a clear licence, and each would still need its trees converted to
//! our own file format, which must be read without it. The trainer here is ≈ 200 lines, std only,
//! deterministic for a seed, and writes [`DosTrees`] directly.
//!
//! # Algorithm
//! Inputs binned once per fit at up to [`TreeTrainConfig::bins`] quantiles of the training
//! values (cut `c_b`; bin `b` holds `c_{b−1} < x ≤ c_b`). Logits start at the log class
//! frequencies. Each round: softmax probabilities `p`, per class gradient `g = p_c − y_c` and
//! hessian `h = max(p_c (1 − p_c), 1e-6)`; a random [`TreeTrainConfig::subsample`] share of the
//! rows; per class one tree grown level by level to [`TreeTrainConfig::depth`]: each node's best
//! split over all inputs (with [`TreeTrainConfig::colsample`] below 1: over the tree's own random
//! share of the inputs) and cuts maximises `G_L²/(H_L+λ) + G_R²/(H_R+λ) − G²/(H+λ)` with
//! `H_L, H_R ≥` [`TreeTrainConfig::min_hessian`]; leaves get `−η·G/(H+λ)` (`η` the learning
//! rate); every row's logits (not only the drawn ones) move by the new trees.

use super::net::softmax;
use super::train::{mirror_permutation, SplitMix, TrainRecording};
use super::train_window::WindowAugment;
use super::*;

/// Settings of a tree-model fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TreeTrainConfig {
    /// Representation.
    pub inputs: TreeInputs,
    /// Boosting rounds (one tree per class each; 1..=2000).
    pub rounds: usize,
    /// Largest tree depth (1..=[`MAX_TREE_DEPTH`]).
    pub depth: usize,
    /// Learning rate `η` (`(0, 1]`).
    pub learning_rate: f64,
    /// Leaf L2 `λ` (≥ 0, finite).
    pub lambda: f64,
    /// Smallest hessian sum per leaf (≥ 0, finite).
    pub min_hessian: f64,
    /// Quantile bins per input (2..=255).
    pub bins: usize,
    /// Share of the rows drawn per round (`(0, 1]`).
    pub subsample: f64,
    /// Seed of the augmentation and the row draws.
    pub seed: u64,
    /// Augmentation (the window model's).
    pub augment: WindowAugment,
    /// Average every window's logits with its mirror image's (store the layout's mirror
    /// permutation in the model).
    pub mirror_average: bool,
    /// Share of the inputs each tree may split on (`(0, 1]`; 1: all, the trainer before stop
    /// 35). Below 1, every tree (one per class per round) draws each input with this probability
    /// (at least one input) from its own seeded stream, independent of the row draws: the trees
    /// cannot all lean on the few taxels one object's pattern singles out (random forests' and
    /// XGBoost's `colsample_bytree`). Always written: a file without it reads the default's
    /// (0.5 since stop 35's round 4).
    pub colsample: f64,
}

impl Default for TreeTrainConfig {
    /// T15 of stop 36's round 6 (`examples/dos_eval_parts/trees_rule_round6.md`), the default of
    /// `gradtac calibrate dos`: round 5's T13 with the rotation-sense fit's flow fitted jointly
    /// with an isotropic **dilation** about the contact's centre and the dilation as an input
    /// ([`TreeInputs::dilation`]: a spreading pattern no longer leaks into the turn). T13 was round 4's T12 — round 3's T9 (stop 34's T4: 60 rounds, depth ≤ 3,
    /// λ = 5, minimum hessian 5, with two random copies per recording, each with an **object
    /// imprint** of spread 0.5, [`WindowAugment::imprint`]) with the **rotation-sense inputs**
    /// ([`TreeInputs::turn`]) and each tree splitting on a random half of the inputs
    /// ([`colsample`](Self::colsample) 0.5) — with the **change-energy inputs**
    /// ([`TreeInputs::energy`]: how much the whole pattern changed, aimed at touches read as
    /// slips).
    fn default() -> Self {
        TreeTrainConfig {
            inputs: TreeInputs { turn: true, energy: true, dilation: true, ..TreeInputs::default() },
            rounds: 60,
            depth: 3,
            learning_rate: 0.1,
            lambda: 5.0,
            min_hessian: 5.0,
            bins: 32,
            subsample: 0.5,
            seed: 1,
            augment: WindowAugment { copies: 2, imprint: 0.5, ..WindowAugment::default() },
            mirror_average: true,
            colsample: 0.5,
        }
    }
}

impl TreeTrainConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        self.inputs.validate()?;
        self.augment.validate()?;
        let ok = (1..=2000).contains(&self.rounds)
            && (1..=MAX_TREE_DEPTH).contains(&self.depth)
            && self.learning_rate > 0.0
            && self.learning_rate <= 1.0
            && self.lambda.is_finite()
            && self.lambda >= 0.0
            && self.min_hessian.is_finite()
            && self.min_hessian >= 0.0
            && (2..=255).contains(&self.bins)
            && self.subsample > 0.0
            && self.subsample <= 1.0
            && self.colsample > 0.0
            && self.colsample <= 1.0;
        if !ok {
            return Err(invalid(format!(
                "tree training out of range: rounds {} (1..=2000), depth {} (1..={MAX_TREE_DEPTH}), learning rate {} \
                 ((0, 1]), lambda {} (≥ 0), min hessian {} (≥ 0), bins {} (2..=255), subsample {} ((0, 1]), \
                 colsample {} ((0, 1])",
                self.rounds,
                self.depth,
                self.learning_rate,
                self.lambda,
                self.min_hessian,
                self.bins,
                self.subsample,
                self.colsample
            )));
        }
        Ok(())
    }
}

/// One recording's training windows: every window of every version, (class, inputs).
pub type TreeSamples = Vec<(DosClass, Vec<f64>)>;

/// The input vectors of every window of `frames`.
pub fn tree_windows(frames: &[Vec<f64>], inputs: &TreeInputs, layout: &Layout) -> Result<Vec<Vec<f64>>> {
    let mut x = TreeExtractor::try_new_on(inputs, layout)?;
    let mut out = Vec::new();
    for f in frames {
        if let Some(v) = x.push(f)? {
            out.push(v);
        }
    }
    Ok(out)
}

/// Every recording's training windows under `cfg` (seeded per recording as the window model's).
pub fn tree_samples(recs: &[TrainRecording], layout: &Layout, cfg: &TreeTrainConfig) -> Result<Vec<TreeSamples>> {
    cfg.validate()?;
    super::train_window::augmented_windows(recs, layout, &cfg.augment, cfg.seed, |f| {
        tree_windows(f, &cfg.inputs, layout)
    })
}

/// A node being grown: its rows, index and depth.
struct Grow {
    rows: Vec<u32>,
    node: usize,
    depth: usize,
}

/// Fit the tree model on samples (see the [module docs](self)). Classes: those present, in
/// [`DosClass::ALL`] order.
pub fn fit_trees(samples: &[(DosClass, Vec<f64>)], layout: &Layout, cfg: &TreeTrainConfig) -> Result<DosTrees> {
    cfg.validate()?;
    let taxels = layout.len();
    let d = cfg.inputs.inputs(taxels);
    let classes: Vec<DosClass> = DosClass::ALL.into_iter().filter(|c| samples.iter().any(|s| s.0 == *c)).collect();
    if classes.len() < 2 {
        return Err(invalid("tree training needs at least two classes"));
    }
    if samples.iter().any(|s| s.1.len() != d || s.1.iter().any(|v| !v.is_finite())) {
        return Err(invalid(format!("tree training samples must be {d} finite inputs")));
    }
    let (n, k) = (samples.len(), classes.len());
    let label: Vec<usize> = samples.iter().map(|s| classes.iter().position(|c| *c == s.0).unwrap_or(0)).collect();
    // quantile cuts per input, and every value's bin (row-major)
    let mut cuts: Vec<Vec<f64>> = Vec::with_capacity(d);
    for j in 0..d {
        let mut v: Vec<f64> = samples.iter().map(|s| s.1[j]).collect();
        v.sort_by(f64::total_cmp);
        let mut c: Vec<f64> = (1..cfg.bins).map(|b| v[(b * (n - 1)) / cfg.bins]).collect();
        c.dedup();
        if c.last() == v.last() {
            c.pop(); // a cut at the maximum splits nothing off
        }
        cuts.push(c);
    }
    let bins = cfg.bins;
    let mut binned = vec![0u8; n * d];
    for (r, s) in samples.iter().enumerate() {
        for j in 0..d {
            binned[r * d + j] = cuts[j].partition_point(|&c| c < s.1[j]) as u8;
        }
    }
    let mut base = vec![0.0; k];
    for &l in &label {
        base[l] += 1.0;
    }
    base.iter_mut().for_each(|b| *b = (*b / n as f64).max(1e-9).ln());
    let mut logits: Vec<f64> = (0..n).flat_map(|_| base.iter().copied()).collect();
    let mut rng = SplitMix::new(cfg.seed ^ 0x7EE5);
    // the inputs' draws per tree: their own stream, so that colsample = 1 draws nothing and the
    // row draws stay those of the trainer without it
    let mut col_rng = SplitMix::new(cfg.seed ^ 0xC015);
    let mut allowed = vec![true; d];
    let mut trees = Vec::with_capacity(cfg.rounds * k);
    let (mut g, mut h) = (vec![0.0; n], vec![0.0; n]);
    let mut hist = vec![0.0; 2 * d * bins];
    for _ in 0..cfg.rounds {
        let rows: Vec<u32> = (0..n as u32).filter(|_| rng.uniform() < cfg.subsample).collect();
        let probs: Vec<Vec<f64>> = (0..n).map(|r| softmax(&logits[r * k..(r + 1) * k])).collect();
        let mut round = Vec::with_capacity(k);
        for c in 0..k {
            for r in 0..n {
                let p = probs[r][c];
                g[r] = p - f64::from(u8::from(label[r] == c));
                h[r] = (p * (1.0 - p)).max(1e-6);
            }
            if cfg.colsample < 1.0 {
                draw_inputs(&mut allowed, cfg.colsample, &mut col_rng);
            }
            let tree = grow(&binned, d, bins, &cuts, &g, &h, rows.clone(), cfg, &allowed, &mut hist);
            for r in 0..n {
                logits[r * k + c] += walk_binned(&tree.0, &tree.1, &binned[r * d..(r + 1) * d]);
            }
            round.push(tree.0);
        }
        trees.extend(round);
    }
    let mirror = if cfg.mirror_average {
        Some(
            mirror_permutation(layout)
                .ok_or_else(|| invalid("mirror averaging needs a layout symmetric about y = 0"))?,
        )
    } else {
        None
    };
    DosTrees::try_new(cfg.inputs.clone(), taxels, classes, base, trees, mirror, 0)
}

/// Each input allowed with probability `share` (at least one: if none is drawn, one at random).
fn draw_inputs(allowed: &mut [bool], share: f64, rng: &mut SplitMix) {
    allowed.iter_mut().for_each(|a| *a = rng.uniform() < share);
    if !allowed.iter().any(|&a| a) && !allowed.is_empty() {
        let j = ((rng.uniform() * allowed.len() as f64) as usize).min(allowed.len() - 1);
        allowed[j] = true;
    }
}

/// A tree and the bin of each internal node's split.
type Grown = (Tree, Vec<usize>);

fn walk_binned(tree: &Tree, split_bin: &[usize], row: &[u8]) -> f64 {
    let mut i = 0;
    while tree.left[i] != 0 {
        i = if (row[tree.feature[i]] as usize) <= split_bin[i] { tree.left[i] } else { tree.right[i] };
    }
    tree.value[i]
}

#[allow(clippy::too_many_arguments)]
fn grow(
    binned: &[u8],
    d: usize,
    bins: usize,
    cuts: &[Vec<f64>],
    g: &[f64],
    h: &[f64],
    rows: Vec<u32>,
    cfg: &TreeTrainConfig,
    allowed: &[bool],
    hist: &mut [f64],
) -> Grown {
    let mut t = Tree { feature: vec![0], threshold: vec![0.0], left: vec![0], right: vec![0], value: vec![0.0] };
    let mut split_bin = vec![0usize];
    let leaf = |gs: f64, hs: f64| -cfg.learning_rate * gs / (hs + cfg.lambda);
    let mut queue = vec![Grow { rows, node: 0, depth: 0 }];
    while let Some(Grow { rows, node, depth }) = queue.pop() {
        let (gs, hs) = rows.iter().fold((0.0, 0.0), |a, &r| (a.0 + g[r as usize], a.1 + h[r as usize]));
        t.value[node] = leaf(gs, hs);
        if depth >= cfg.depth || hs < 2.0 * cfg.min_hessian || rows.len() < 2 {
            continue;
        }
        hist.iter_mut().for_each(|v| *v = 0.0);
        for &r in &rows {
            let (gr, hr) = (g[r as usize], h[r as usize]);
            let row = &binned[r as usize * d..(r as usize + 1) * d];
            for (j, &b) in row.iter().enumerate() {
                let at = 2 * (j * bins + b as usize);
                hist[at] += gr;
                hist[at + 1] += hr;
            }
        }
        let parent = gs * gs / (hs + cfg.lambda);
        let mut best = (1e-9, 0usize, 0usize);
        for (j, cut) in cuts.iter().enumerate() {
            if !allowed[j] {
                continue;
            }
            let (mut gl, mut hl) = (0.0, 0.0);
            for b in 0..cut.len() {
                let at = 2 * (j * bins + b);
                gl += hist[at];
                hl += hist[at + 1];
                let (gr, hr) = (gs - gl, hs - hl);
                if hl < cfg.min_hessian || hr < cfg.min_hessian {
                    continue;
                }
                let gain = gl * gl / (hl + cfg.lambda) + gr * gr / (hr + cfg.lambda) - parent;
                if gain > best.0 {
                    best = (gain, j, b);
                }
            }
        }
        if best.0 <= 1e-9 {
            continue;
        }
        let (_, j, b) = best;
        let (l, r) = (t.left.len(), t.left.len() + 1);
        for _ in 0..2 {
            t.feature.push(0);
            t.threshold.push(0.0);
            t.left.push(0);
            t.right.push(0);
            t.value.push(0.0);
            split_bin.push(0);
        }
        t.feature[node] = j;
        t.threshold[node] = cuts[j][b];
        t.left[node] = l;
        t.right[node] = r;
        split_bin[node] = b;
        let (lr, rr): (Vec<u32>, Vec<u32>) = rows.into_iter().partition(|&x| binned[x as usize * d + j] as usize <= b);
        queue.push(Grow { rows: rr, node: r, depth: depth + 1 });
        queue.push(Grow { rows: lr, node: l, depth: depth + 1 });
    }
    (t, split_bin)
}

/// Fit on the windows of the recordings `train` (all their versions).
pub fn fit_on(samples: &[TreeSamples], train: &[usize], layout: &Layout, cfg: &TreeTrainConfig) -> Result<DosTrees> {
    let s: Vec<(DosClass, Vec<f64>)> = train.iter().flat_map(|&i| samples[i].iter().cloned()).collect();
    let mut m = fit_trees(&s, layout, cfg)?;
    m.recordings = train.len();
    Ok(m)
}

/// Per test recording: (correct windows, windows, whether the vote over all its windows is right).
pub fn score(
    model: &DosTrees,
    recs: &[TrainRecording],
    test: &[usize],
    layout: &Layout,
) -> Result<Vec<(usize, usize, bool)>> {
    super::train_window::score_vote(&mut model.vote(layout)?, recs, test)
}

/// Leave-one-group-out over the recordings `idx`: ((correct windows, windows), (recordings whose
/// vote is right, recordings)).
pub fn inner_score(
    recs: &[TrainRecording],
    samples: &[TreeSamples],
    idx: &[usize],
    layout: &Layout,
    cfg: &TreeTrainConfig,
) -> Result<super::train_window::InnerScore> {
    let groups = super::train_window::groups_of(recs, idx);
    if groups.len() < 2 {
        return Err(invalid(format!("leave-one-group-out needs at least two groups, got {}", groups.len())));
    }
    let (mut w, mut r) = ((0, 0), (0, 0));
    for g in &groups {
        let train: Vec<usize> = idx.iter().copied().filter(|&i| recs[i].group != *g).collect();
        let test: Vec<usize> = idx.iter().copied().filter(|&i| recs[i].group == *g).collect();
        let m = fit_on(samples, &train, layout, cfg)?;
        for s in score(&m, recs, &test, layout)? {
            w = (w.0 + s.0, w.1 + s.1);
            r = (r.0 + usize::from(s.2), r.1 + 1);
        }
    }
    Ok((w, r))
}
