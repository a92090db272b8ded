//! Leave-one-group-out cross-validation of a model's settings ([`cross_validate`]).

use super::*;

/// One labelled span for [`cross_validate`]: its class, its group (e.g. the object it was
/// recorded on) and its features.
#[derive(Clone, Debug, PartialEq)]
pub struct LabelledSpan {
    /// The true class.
    pub class: DosClass,
    /// The group held out together (an object, an object set, a session).
    pub group: String,
    /// The span's features (at least the configured ones computed).
    pub features: FeatureVector,
}

/// The result of [`cross_validate`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CrossValidation {
    /// Per held-out group, in sorted order: (group, correct, spans).
    pub folds: Vec<(String, usize, usize)>,
    /// Rows true class, columns decided class, both in [`DosClass::ALL`] order.
    pub confusion: [[usize; 7]; 7],
}

impl CrossValidation {
    /// Correct decisions over all spans (0 without spans).
    pub fn accuracy(&self) -> f64 {
        let ok: usize = self.folds.iter().map(|f| f.1).sum();
        let n: usize = self.folds.iter().map(|f| f.2).sum();
        if n == 0 {
            0.0
        } else {
            ok as f64 / n as f64
        }
    }

    /// Recall of `class` (`None` without spans of it).
    pub fn recall(&self, class: DosClass) -> Option<f64> {
        let i = DosClass::ALL.iter().position(|&c| c == class)?;
        let n: usize = self.confusion[i].iter().sum();
        (n > 0).then(|| self.confusion[i][i] as f64 / n as f64)
    }
}

impl fmt::Display for CrossValidation {
    /// Accuracy, the folds and the confusion matrix as markdown.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (ok, n) = self.folds.iter().fold((0, 0), |a, x| (a.0 + x.1, a.1 + x.2));
        writeln!(f, "leave-one-group-out accuracy: {:.1} % ({ok}/{n})", 100.0 * self.accuracy())?;
        writeln!(f, "\n| held out | correct | spans | accuracy |\n|---|---|---|---|")?;
        for (g, ok, n) in &self.folds {
            writeln!(f, "| {g} | {ok} | {n} | {:.1} % |", 100.0 * *ok as f64 / (*n).max(1) as f64)?;
        }
        let names = DosClass::ALL.map(|c| c.as_str());
        writeln!(f, "\n| true \\ decided | {} | recall |\n|---|{}---|", names.join(" | "), "---|".repeat(7))?;
        for (i, row) in self.confusion.iter().enumerate() {
            let cells: Vec<String> = row.iter().map(|v| v.to_string()).collect();
            let recall = self.recall(DosClass::ALL[i]).map_or("—".to_string(), |r| format!("{:.0} %", 100.0 * r));
            writeln!(f, "| {} | {} | {recall} |", names[i], cells.join(" | "))?;
        }
        Ok(())
    }
}

/// Leave-one-group-out cross-validation of the decision rule: for every group, a model is
/// calibrated ([`DosModel::calibrate_with_shrinkage`] with `shrinkage(group)`, then
/// [`DosModel::with_student_t_dof`]`(dof)`) on the other groups' spans and decides that group's.
/// Refuses fewer than two groups, and whatever calibration refuses (e.g. a fold whose training
/// spans hold a single class).
pub fn cross_validate(
    config: &DosFeatureConfig,
    spans: &[LabelledSpan],
    shrinkage: &dyn Fn(&str) -> f64,
    dof: Option<f64>,
) -> Result<CrossValidation> {
    let mut groups: Vec<&str> = spans.iter().map(|s| s.group.as_str()).collect();
    groups.sort_unstable();
    groups.dedup();
    if groups.len() < 2 {
        return Err(invalid(format!("cross-validation needs at least two groups, got {}", groups.len())));
    }
    let idx = |c: DosClass| DosClass::ALL.iter().position(|&x| x == c).unwrap_or(0);
    let mut folds = Vec::with_capacity(groups.len());
    let mut confusion = [[0usize; 7]; 7];
    for g in groups {
        let train: Vec<(DosClass, Vec<f64>)> =
            spans.iter().filter(|s| s.group != g).map(|s| (s.class, s.features.select(&config.features))).collect();
        let model = DosModel::calibrate_with_shrinkage(config.clone(), &train, shrinkage(g))
            .and_then(|m| m.with_student_t_dof(dof))
            .map_err(|e| match e {
                Error::InvalidConfig { reason, .. } => invalid(format!("fold without {g:?}: {reason}")),
                other => other,
            })?;
        let (mut ok, mut n) = (0, 0);
        for s in spans.iter().filter(|s| s.group == g) {
            let d = model.classify_vector(&s.features)?;
            confusion[idx(s.class)][idx(d.class)] += 1;
            ok += usize::from(d.class == s.class);
            n += 1;
        }
        folds.push((g.to_string(), ok, n));
    }
    Ok(CrossValidation { folds, confusion })
}
