//! [`DosModel`]: per-class densities over the features, fitting (with mirror augmentation) and decisions.

use super::*;

/// The fitted classifier: feature configuration, class means, pooled and per-class variances.
/// Serialises to JSON / TOML (serde) and is validated when deserialised.
///
/// ```
/// use gradtac_stages::dos::{DosClass, DosFeatureConfig, DosModel};
/// let cfg = DosFeatureConfig { features: vec![gradtac_stages::dos::Feature::TrackDx], ..Default::default() };
/// let samples = vec![(DosClass::N, vec![2.0]), (DosClass::N, vec![3.0]), (DosClass::S, vec![-2.5]), (DosClass::S, vec![-3.5])];
/// let model = DosModel::calibrate(cfg, &samples)?;
/// assert_eq!(model.classify(&[1.0])?.class, DosClass::N);
/// assert_eq!(model.parameter_count(), 4); // a mean and a variance per class
/// # Ok::<(), gradtac_stages::Error>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, try_from = "RawModel")]
pub struct DosModel {
    /// How features are computed (and which are used).
    pub config: DosFeatureConfig,
    /// The classes the model knows, in decision order.
    pub classes: Vec<DosClass>,
    /// Class means, `classes.len()` rows of `config.features.len()` values.
    pub means: Vec<Vec<f64>>,
    /// Pooled within-class variance per feature (> 0): the decision's variances when
    /// `class_variances` is empty, otherwise what they were shrunk toward (information only).
    pub variances: Vec<f64>,
    /// Per-class variances, `classes.len()` rows of `config.features.len()` values (> 0):
    /// `λ·pooled + (1 − λ)·own` with `λ` = [`DosModel::DEFAULT_SHRINKAGE`] by
    /// [`DosModel::calibrate`]. Empty (or absent in the file, as in models written before they
    /// existed): every class uses the pooled `variances`.
    pub class_variances: Vec<Vec<f64>>,
    /// Number of labelled recordings the model was fitted on (information only).
    pub recordings: usize,
    /// Degrees of freedom `ν` of the class densities: `Some(ν)` (> 0) for a multivariate
    /// Student t with the diagonal scales above, `None` (or absent in the file, as in models
    /// written before it existed) for a Gaussian. Fixed, not fitted:
    /// [`DosModel::DEFAULT_STUDENT_T_DOF`] from [`calibrate`](DosModel::calibrate).
    pub student_t_dof: Option<f64>,
    /// The window part ([`DosWindowPart`]): with it, decisions combine this model's log
    /// posterior with the causal vote of a [`DosWindowNet`] ([`combine`](Self::combine)).
    /// `None` (or absent in the file, as in models written before it existed, and then not
    /// written): the Student-t model alone, exactly as before.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub window: Option<DosWindowPart>,
    /// The tree part ([`DosTreesPart`], stop 33): like the window part, with a [`DosTrees`]
    /// vote instead of the net's; a model has at most one of the two. `None` (or absent in the
    /// file, and then not written): as before.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trees: Option<DosTreesPart>,
}

/// The tree part of a [`DosModel`]: a [`DosTrees`] window model and the weight `a` of the
/// combined score `a·ln p_t + (1 − a)·(mean ln p per window of the trees' vote)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DosTreesPart {
    /// Weight `a` of the Student-t log posterior, in `[0, 1]`.
    pub weight: f64,
    /// The tree model (validated when read).
    pub trees: DosTrees,
}

impl DosTreesPart {
    /// Checks the weight and the trees; the error names the field.
    pub fn validate(&self) -> Result<()> {
        if !(self.weight.is_finite() && (0.0..=1.0).contains(&self.weight)) {
            return Err(invalid(format!("trees.weight {} must lie in [0, 1]", self.weight)));
        }
        self.trees.validate().map_err(in_field("trees.trees"))
    }
}

/// The window part of a [`DosModel`]: a [`DosWindowNet`] and the weight `a` of the combined
/// score `a·ln p_t + (1 − a)·(mean ln p per window of the net's vote)` (see the
/// [module docs](crate::dos)).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, try_from = "RawWindowPart")]
pub struct DosWindowPart {
    /// Weight `a` of the Student-t log posterior, in `[0, 1]` (0: the window vote alone; 1: the
    /// Student-t model alone).
    pub weight: f64,
    /// The window model.
    pub net: DosWindowNet,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWindowPart {
    weight: f64,
    net: super::window::RawWindowNet,
}

/// An invalid-configuration error with its reason prefixed by `field` (`window.net: …`): where
/// in the model file the invalid part is. Other errors pass unchanged.
pub(crate) fn in_field(field: &'static str) -> impl Fn(Error) -> Error {
    move |e| match e {
        Error::InvalidConfig { stage, reason } => Error::InvalidConfig { stage, reason: format!("{field}: {reason}") },
        other => other,
    }
}

impl TryFrom<RawWindowPart> for DosWindowPart {
    type Error = Error;
    fn try_from(r: RawWindowPart) -> Result<Self> {
        let part =
            DosWindowPart { weight: r.weight, net: DosWindowNet::try_from(r.net).map_err(in_field("window.net"))? };
        part.validate()?;
        Ok(part)
    }
}

impl DosWindowPart {
    /// Checks the weight and the net; the error names the field (`window.weight`, `window.net`).
    pub fn validate(&self) -> Result<()> {
        if !(self.weight.is_finite() && (0.0..=1.0).contains(&self.weight)) {
            return Err(invalid(format!("window.weight {} must lie in [0, 1]", self.weight)));
        }
        self.net.validate().map_err(in_field("window.net"))
    }
}

/// Floor of a log posterior in the combined score (a class one model does not know, or a
/// posterior that underflowed).
const MIN_LOG_P: f64 = -1e3;

/// The combined scores, in `classes` order: `a·ln p_t + (1 − a)·w` with `posterior` the
/// Student-t model's (over `classes`) and `window_log_p` the window vote's mean log posterior
/// per window (over `window_classes`); each log floored at −1000, a class the net does not know
/// gets −1000 from it.
pub fn combined_scores(
    classes: &[DosClass],
    posterior: &[f64],
    window_classes: &[DosClass],
    window_log_p: &[f64],
    a: f64,
) -> Vec<f64> {
    classes
        .iter()
        .zip(posterior)
        .map(|(c, p)| {
            let lt = p.max(1e-300).ln().max(MIN_LOG_P);
            let lw = window_classes
                .iter()
                .position(|x| x == c)
                .and_then(|k| window_log_p.get(k))
                .map_or(MIN_LOG_P, |w| w.max(MIN_LOG_P));
            a * lt + (1.0 - a) * lw
        })
        .collect()
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawModel {
    config: DosFeatureConfig,
    classes: Vec<DosClass>,
    means: Vec<Vec<f64>>,
    variances: Vec<f64>,
    #[serde(default)]
    class_variances: Vec<Vec<f64>>,
    #[serde(default)]
    recordings: usize,
    #[serde(default)]
    student_t_dof: Option<f64>,
    #[serde(default)]
    window: Option<DosWindowPart>,
    #[serde(default)]
    trees: Option<DosTreesPart>,
}

impl TryFrom<RawModel> for DosModel {
    type Error = Error;
    fn try_from(r: RawModel) -> Result<Self> {
        let m = DosModel {
            config: r.config,
            classes: r.classes,
            means: r.means,
            variances: r.variances,
            class_variances: r.class_variances,
            recordings: r.recordings,
            student_t_dof: r.student_t_dof,
            window: r.window,
            trees: r.trees,
        };
        m.validate()?;
        Ok(m)
    }
}

/// Smallest variance relative to a feature's total variance (keeps a constant feature from
/// dividing by zero).
const VARIANCE_FLOOR: f64 = 1e-6;

/// A decision: the class, and the distances and posteriors per class of the model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Decision {
    /// The chosen class.
    pub class: DosClass,
    /// `D_c` per model class (model order).
    pub distances: Vec<f64>,
    /// `softmax(−D_c/2)` per model class (model order).
    pub posterior: Vec<f64>,
}

impl DosModel {
    /// Shrinkage `λ` of [`calibrate`](Self::calibrate): each class keeps its own variances.
    /// Chosen by the nested procedure on all
    /// development recordings (see the [module docs](crate::dos)); 0.5 before.
    pub const DEFAULT_SHRINKAGE: f64 = 0.0;

    /// Degrees of freedom `ν` of the Student-t class densities of [`calibrate`](Self::calibrate)
    /// (a heavy-tailed density: one recording far from its class mean in one feature costs
    /// `ln(1 + m/ν)`, not `m`).
    pub const DEFAULT_STUDENT_T_DOF: f64 = 3.0;

    /// The same model with class densities of `dof` degrees of freedom (`Some(ν)`, `ν` > 0 and
    /// finite: Student t) or Gaussian (`None`); the fitted means and variances are unchanged.
    pub fn with_student_t_dof(mut self, dof: Option<f64>) -> Result<Self> {
        self.student_t_dof = dof;
        self.validate()?;
        Ok(self)
    }

    /// Fit class means, pooled within-class variances and per-class variances shrunk toward them
    /// by [`DEFAULT_SHRINKAGE`](Self::DEFAULT_SHRINKAGE) from labelled feature
    /// vectors (each of `config.features.len()` values, e.g. [`FeatureVector::select`]); see
    /// [`calibrate_with_shrinkage`](Self::calibrate_with_shrinkage).
    pub fn calibrate(config: DosFeatureConfig, samples: &[(DosClass, Vec<f64>)]) -> Result<DosModel> {
        Self::calibrate_with_shrinkage(config, samples, Self::DEFAULT_SHRINKAGE)
    }

    /// Fit class means and pooled within-class variances `σ²_j` from labelled feature vectors
    /// and, for `shrinkage` `λ < 1`, per-class variances `σ²_{c,j} = λ·σ²_j + (1 − λ)·s²_{c,j}`
    /// with `s²_{c,j}` the class's own (maximum-likelihood) variance. `λ = 1` gives the pooled
    /// model (no `class_variances`, `(classes + 1) × features` parameters).
    ///
    /// The model's classes are those present, in [`DosClass::ALL`] order. Refuses an invalid
    /// configuration, vectors of the wrong length or non-finite values, fewer than two classes,
    /// and data without any within-class spread (fewer samples than classes + 1).
    /// A feature whose within-class variance is below `1e-6` of its total variance gets that
    /// floor (and a floor of `1e-12` when constant).
    /// `shrinkage` must lie in `[0, 1]`.
    pub fn calibrate_with_shrinkage(
        config: DosFeatureConfig,
        samples: &[(DosClass, Vec<f64>)],
        shrinkage: f64,
    ) -> Result<DosModel> {
        config.validate()?;
        if !(0.0..=1.0).contains(&shrinkage) {
            return Err(invalid(format!("shrinkage {shrinkage} must lie in [0, 1]")));
        }
        let d = config.features.len();
        for (i, (c, f)) in samples.iter().enumerate() {
            if f.len() != d {
                return Err(invalid(format!("sample {i} ({c}) has {} values for {d} features", f.len())));
            }
            if let Some(j) = f.iter().position(|v| !v.is_finite()) {
                return Err(invalid(format!("sample {i} ({c}): feature {} is {}", config.features[j].name(), f[j])));
            }
        }
        let classes: Vec<DosClass> =
            DosClass::ALL.into_iter().filter(|c| samples.iter().any(|(s, _)| s == c)).collect();
        if classes.len() < 2 {
            return Err(invalid(format!("calibration needs at least two classes, got {}", classes.len())));
        }
        if samples.len() <= classes.len() {
            return Err(invalid(format!(
                "{} samples for {} classes: at least one class needs two samples",
                samples.len(),
                classes.len()
            )));
        }
        let mut means = vec![vec![0.0; d]; classes.len()];
        let mut counts = vec![0usize; classes.len()];
        for (c, f) in samples {
            let k = classes.iter().position(|x| x == c).unwrap_or(0);
            counts[k] += 1;
            for j in 0..d {
                means[k][j] += f[j];
            }
        }
        for (m, &n) in means.iter_mut().zip(&counts) {
            m.iter_mut().for_each(|v| *v /= n as f64);
        }
        let dof = (samples.len() - classes.len()) as f64;
        let grand: Vec<f64> =
            (0..d).map(|j| samples.iter().map(|(_, f)| f[j]).sum::<f64>() / samples.len() as f64).collect();
        let mut variances = vec![0.0; d];
        let mut total = vec![0.0; d];
        for (c, f) in samples {
            let k = classes.iter().position(|x| x == c).unwrap_or(0);
            for j in 0..d {
                variances[j] += (f[j] - means[k][j]).powi(2);
                total[j] += (f[j] - grand[j]).powi(2);
            }
        }
        let floors: Vec<f64> =
            total.iter().map(|t| (VARIANCE_FLOOR * t / (samples.len() - 1) as f64).max(1e-12)).collect();
        for j in 0..d {
            variances[j] = (variances[j] / dof).max(floors[j]);
        }
        let mut class_variances = Vec::new();
        if shrinkage < 1.0 {
            let mut own = vec![vec![0.0; d]; classes.len()];
            for (c, f) in samples {
                let k = classes.iter().position(|x| x == c).unwrap_or(0);
                for j in 0..d {
                    own[k][j] += (f[j] - means[k][j]).powi(2);
                }
            }
            for (row, &n) in own.iter_mut().zip(&counts) {
                for j in 0..d {
                    row[j] = (shrinkage * variances[j] + (1.0 - shrinkage) * row[j] / n as f64).max(floors[j]);
                }
            }
            class_variances = own;
        }
        let m = DosModel {
            config,
            classes,
            means,
            variances,
            class_variances,
            recordings: samples.len(),
            student_t_dof: Some(Self::DEFAULT_STUDENT_T_DOF),
            window: None,
            trees: None,
        };
        m.validate()?;
        Ok(m)
    }

    /// Checks shapes and values (done on deserialisation).
    pub fn validate(&self) -> Result<()> {
        self.config.validate()?;
        let d = self.config.features.len();
        if self.classes.len() < 2 {
            return Err(invalid("a model needs at least two classes"));
        }
        for (i, c) in self.classes.iter().enumerate() {
            if self.classes[..i].contains(c) {
                return Err(invalid(format!("class {c} appears twice")));
            }
        }
        if self.means.len() != self.classes.len() {
            return Err(invalid(format!("{} rows of means for {} classes", self.means.len(), self.classes.len())));
        }
        for (c, m) in self.classes.iter().zip(&self.means) {
            if m.len() != d || m.iter().any(|v| !v.is_finite()) {
                return Err(invalid(format!("means of class {c} must be {d} finite values, got {m:?}")));
            }
        }
        if self.variances.len() != d || self.variances.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(invalid(format!("variances must be {d} finite values > 0, got {:?}", self.variances)));
        }
        if let Some(nu) = self.student_t_dof {
            if !(nu.is_finite() && nu > 0.0) {
                return Err(invalid(format!("student_t_dof {nu} must be finite and > 0")));
            }
        }
        if !self.class_variances.is_empty() {
            if self.class_variances.len() != self.classes.len() {
                return Err(invalid(format!(
                    "{} rows of class_variances for {} classes",
                    self.class_variances.len(),
                    self.classes.len()
                )));
            }
            for (c, v) in self.classes.iter().zip(&self.class_variances) {
                if v.len() != d || v.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
                    return Err(invalid(format!(
                        "class_variances of class {c} must be {d} finite values > 0, got {v:?}"
                    )));
                }
            }
        }
        if let Some(w) = &self.window {
            w.validate()?;
        }
        if let Some(t) = &self.trees {
            if self.window.is_some() {
                return Err(invalid("a model has a window part or a tree part, not both"));
            }
            t.validate()?;
        }
        Ok(())
    }

    /// The same model with a tree part (validated; needs no window part), or without one.
    pub fn with_trees(mut self, trees: Option<DosTreesPart>) -> Result<Self> {
        self.trees = trees;
        self.validate()?;
        Ok(self)
    }

    /// The same model with a window part (validated), or without one (`None`).
    pub fn with_window(mut self, window: Option<DosWindowPart>) -> Result<Self> {
        self.window = window;
        self.validate()?;
        Ok(self)
    }

    /// The decision of the combined score ([`combined_scores`]) from this model's decision
    /// `student` and the window vote's mean log posterior per window (in the net's class order):
    /// the class of the largest score (ties: the first in model order), `posterior`
    /// `softmax(score)`, `distances` `−2·score`. `student` unchanged when the model has no
    /// window part or the vote has no completed window yet.
    pub fn combine(&self, student: Decision, window_log_p: Option<&[f64]>) -> Decision {
        let (weight, classes) = match (&self.window, &self.trees) {
            (Some(p), _) => (p.weight, p.net.classes.as_slice()),
            (None, Some(t)) => (t.weight, t.trees.classes()),
            (None, None) => return student,
        };
        let Some(w) = window_log_p else { return student };
        let s = combined_scores(&self.classes, &student.posterior, classes, w, weight);
        let mut best = 0;
        for (k, v) in s.iter().enumerate() {
            if *v > s[best] {
                best = k;
            }
        }
        let top = s[best];
        let e: Vec<f64> = s.iter().map(|v| (v - top).exp()).collect();
        let sum: f64 = e.iter().sum();
        Decision {
            class: self.classes[best],
            posterior: e.iter().map(|v| v / sum).collect(),
            distances: s.iter().map(|v| -2.0 * v).collect(),
        }
    }

    /// Number of fitted numbers the decision uses: `2 × classes × features` with per-class
    /// variances (means and variances per class), `(classes + 1) × features` without; plus,
    /// with a window part, the net's [`DosWindowNet::parameter_count`] and the weight; with a
    /// tree part, its nodes, its base logits and the weight.
    pub fn parameter_count(&self) -> usize {
        let rows = if self.class_variances.is_empty() { self.classes.len() + 1 } else { 2 * self.classes.len() };
        rows * self.config.features.len()
            + self.window.as_ref().map_or(0, |w| w.net.parameter_count() + 1)
            + self.trees.as_ref().map_or(0, |t| t.trees.nodes() + t.trees.classes().len() + 1)
    }

    /// Classify one feature vector (the model's features, in order).
    pub fn classify(&self, features: &[f64]) -> Result<Decision> {
        let d = self.config.features.len();
        if features.len() != d {
            return Err(invalid(format!("{} feature values for a model of {d} features", features.len())));
        }
        if let Some(j) = features.iter().position(|v| !v.is_finite()) {
            return Err(invalid(format!("feature {} is {}", self.config.features[j].name(), features[j])));
        }
        // (D_c, ln m_c): ln m_c only where m_c overflows (features near ±f64::MAX), to keep
        // the decision and the posterior defined there.
        let scored: Vec<(f64, f64)> = self
            .means
            .iter()
            .enumerate()
            .map(|(k, m)| {
                let (vars, own) = match self.class_variances.get(k) {
                    Some(v) => (v, true),
                    None => (&self.variances, false),
                };
                let maha: f64 = m.iter().zip(features).zip(vars).map(|((mu, f), v)| (f - mu).powi(2) / v).sum();
                let log_det: f64 = if own { vars.iter().map(|v| v.ln()).sum() } else { 0.0 };
                let ln_maha = if maha.is_finite() { maha.ln() } else { ln_mahalanobis(m, features, vars) };
                let dist = match (self.student_t_dof, maha.is_finite()) {
                    (Some(nu), true) => log_det + (nu + d as f64) * (maha / nu).ln_1p(),
                    // m/ν ≥ 1e308/ν: ln(1 + m/ν) = ln m − ln ν to double precision
                    (Some(nu), false) => log_det + (nu + d as f64) * (ln_maha - nu.ln()),
                    (None, _) => log_det + maha,
                };
                (dist, ln_maha)
            })
            .collect();
        let mut best = 0;
        for (k, s) in scored.iter().enumerate() {
            let b = scored[best];
            if s.0 < b.0 || (s.0 == b.0 && s.0.is_infinite() && s.1 < b.1) {
                best = k;
            }
        }
        let distances: Vec<f64> = scored.iter().map(|s| s.0).collect();
        let dmin = distances[best];
        let posterior: Vec<f64> = if dmin.is_finite() {
            let w: Vec<f64> = distances.iter().map(|&dk| (-(dk - dmin) / 2.0).exp()).collect();
            let s: f64 = w.iter().sum();
            w.iter().map(|x| x / s).collect()
        } else {
            // every Gaussian distance overflowed: the decided class takes all the weight
            (0..distances.len()).map(|k| if k == best { 1.0 } else { 0.0 }).collect()
        };
        Ok(Decision { class: self.classes[best], posterior, distances })
    }

    /// Classify the full feature vector of a span.
    pub fn classify_vector(&self, fv: &FeatureVector) -> Result<Decision> {
        self.classify(&fv.select(&self.config.features))
    }
}

/// `samples` followed by their mirror images across `y = 0` (each vector's features times
/// [`Feature::mirror_sign`], its class [`DosClass::mirrored`]): the recordings the same slips
/// would have given on the mirrored side of a symmetric layout. Calibrating on them makes the
/// model itself symmetric — the class means of `e` and `w` (and of `cw` and `aw`) are mirror
/// images, those of `n`, `s`, `t` have zero odd features — and doubles the training data for
/// free; `features` are the vectors' features, in order.
pub fn mirror_augmented(features: &[Feature], samples: &[(DosClass, Vec<f64>)]) -> Vec<(DosClass, Vec<f64>)> {
    let signs: Vec<f64> = features.iter().map(|f| f.mirror_sign()).collect();
    let mirrored = samples.iter().map(|(c, f)| (c.mirrored(), f.iter().zip(&signs).map(|(v, s)| v * s).collect()));
    samples.iter().cloned().chain(mirrored).collect()
}
