//! Choosing the slip-direction classifier's settings without flattering it: every choice is
//! made by leave-one-group-out on the *training* spans only, and scored on spans no choice saw.
//!
//! # What it does
//! A [`Candidate`] is one complete set of choices for [`crate::dos`]: the feature
//! configuration (which features, which drift lags and scale — each distinct extraction is one
//! *table* of [`LabelledSpan`]s, all tables holding the same recordings in the same order), the
//! variance shrinkage `λ`, and whether the training set is [mirror-augmented](mirror_augmented).
//! [`choose`] scores every candidate by leave-one-group-out over the spans it is given and
//! returns the best (ties: the earlier candidate, so list them simplest first).
//! [`nested_cross_validate`] runs [`choose`] *inside* every outer fold on the other groups only,
//! fits the chosen candidate on them and decides the held-out group: the figure that says what
//! the whole procedure (choices included) does on an object it has not seen.
//! [`train_test`] does the same for one split (e.g. train on one object set, test on another).
//!
//! # Cost
//! `candidates × groups` calibrations per choice (each a pass over the spans' features, a few
//! microseconds); a nested run multiplies that by the number of outer folds. The features are
//! extracted once per table by the caller.

use crate::dos::{mirror_augmented, CrossValidation, DosClass, DosFeatureConfig, DosModel, LabelledSpan};
use crate::{Error, Result};

fn invalid(reason: impl Into<String>) -> Error {
    Error::InvalidConfig { stage: "dos_select", reason: reason.into() }
}

/// One complete set of choices (see the [module docs](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    /// Index of the feature table the candidate's features come from.
    pub table: usize,
    /// The feature configuration (its `features` are selected from the table's vectors; its
    /// lags and scale must be those the table was extracted with).
    pub config: DosFeatureConfig,
    /// Variance shrinkage `λ` in `[0, 1]`.
    pub shrinkage: f64,
    /// Calibrate on the spans and their mirror images ([`mirror_augmented`]).
    pub mirror: bool,
}

impl Candidate {
    /// Fit this candidate on `spans` (Student-t densities of `dof`, `None` Gaussian).
    pub fn calibrate<'a>(
        &self,
        spans: impl IntoIterator<Item = &'a LabelledSpan>,
        dof: Option<f64>,
    ) -> Result<DosModel> {
        let samples: Vec<(DosClass, Vec<f64>)> =
            spans.into_iter().map(|s| (s.class, s.features.select(&self.config.features))).collect();
        let samples = if self.mirror { mirror_augmented(&self.config.features, &samples) } else { samples };
        DosModel::calibrate_with_shrinkage(self.config.clone(), &samples, self.shrinkage)?.with_student_t_dof(dof)
    }

    /// A short description: features, lags, scale, `λ`, mirror.
    pub fn describe(&self) -> String {
        format!(
            "{} features [{}], lags {:?} ({:?}), λ = {}, mirror {}",
            self.config.features.len(),
            self.config.features.iter().map(|f| f.name()).collect::<Vec<_>>().join(", "),
            self.config.drift_lags,
            self.config.drift_scale,
            self.shrinkage,
            if self.mirror { "on" } else { "off" }
        )
    }
}

/// The outcome of [`nested_cross_validate`] or [`train_test`].
#[derive(Clone, Debug, PartialEq)]
pub struct Selected {
    /// Decisions on the held-out spans.
    pub cv: CrossValidation,
    /// Per outer fold (held-out group, in `cv.folds` order): the index of the chosen candidate
    /// and its inner leave-one-group-out accuracy on the fold's training spans.
    pub chosen: Vec<(String, usize, f64)>,
}

fn check_tables(tables: &[Vec<LabelledSpan>], candidates: &[Candidate]) -> Result<()> {
    let Some(first) = tables.first() else { return Err(invalid("no feature tables")) };
    if tables.iter().any(|t| t.len() != first.len()) {
        return Err(invalid("feature tables must hold the same spans"));
    }
    if candidates.is_empty() {
        return Err(invalid("no candidates"));
    }
    if let Some(c) = candidates.iter().find(|c| c.table >= tables.len()) {
        return Err(invalid(format!("candidate uses table {} of {}", c.table, tables.len())));
    }
    Ok(())
}

fn groups_of<'a>(spans: impl Iterator<Item = &'a LabelledSpan>) -> Vec<String> {
    let mut g: Vec<String> = spans.map(|s| s.group.clone()).collect();
    g.sort_unstable();
    g.dedup();
    g
}

/// Leave-one-group-out of one candidate over the spans whose indices are in `members`:
/// (correct, decided).
fn score(
    tables: &[Vec<LabelledSpan>],
    members: &[usize],
    cand: &Candidate,
    dof: Option<f64>,
) -> Result<(usize, usize)> {
    let table = &tables[cand.table];
    let groups = groups_of(members.iter().map(|&i| &table[i]));
    if groups.len() < 2 {
        return Err(invalid(format!("choosing needs at least two groups, got {}", groups.len())));
    }
    let (mut ok, mut n) = (0, 0);
    for g in &groups {
        let model = cand.calibrate(members.iter().map(|&i| &table[i]).filter(|s| &s.group != g), dof)?;
        for s in members.iter().map(|&i| &table[i]).filter(|s| &s.group == g) {
            ok += usize::from(model.classify_vector(&s.features)?.class == s.class);
            n += 1;
        }
    }
    Ok((ok, n))
}

/// The candidate with the best leave-one-group-out accuracy over the spans with indices
/// `members` (every table's spans at those indices): (index, accuracy). Ties go to the earlier
/// candidate; a candidate that cannot be calibrated in some inner fold is passed over. Refuses
/// fewer than two groups, and fails when no candidate can be calibrated.
pub fn choose(
    tables: &[Vec<LabelledSpan>],
    members: &[usize],
    candidates: &[Candidate],
    dof: Option<f64>,
) -> Result<(usize, f64)> {
    check_tables(tables, candidates)?;
    let mut best = (0, -1.0);
    let mut last_error = None;
    for (k, c) in candidates.iter().enumerate() {
        // a candidate that cannot be fitted in some inner fold (e.g. too few spans per class
        // without the mirror images) is not chosen
        let (ok, n) = match score(tables, members, c, dof) {
            Ok(r) => r,
            Err(e) => {
                last_error = Some(e);
                continue;
            }
        };
        let acc = ok as f64 / n.max(1) as f64;
        if acc > best.1 {
            best = (k, acc);
        }
    }
    match last_error {
        Some(e) if best.1 < 0.0 => Err(e),
        _ => Ok(best),
    }
}

fn tally(cv: &mut CrossValidation, group: &str, decided: &[(DosClass, DosClass)]) {
    let idx = |c: DosClass| DosClass::ALL.iter().position(|&x| x == c).unwrap_or(0);
    let mut ok = 0;
    for &(truth, got) in decided {
        cv.confusion[idx(truth)][idx(got)] += 1;
        ok += usize::from(truth == got);
    }
    cv.folds.push((group.to_string(), ok, decided.len()));
}

/// Choose on `train` (indices; [`choose`] by leave-one-group-out over their groups), fit the
/// chosen candidate on all of them and decide `test`, reported as one fold named `name`.
pub fn train_test(
    tables: &[Vec<LabelledSpan>],
    train: &[usize],
    test: &[usize],
    name: &str,
    candidates: &[Candidate],
    dof: Option<f64>,
) -> Result<Selected> {
    let (k, inner) = choose(tables, train, candidates, dof)?;
    let cand = &candidates[k];
    let table = &tables[cand.table];
    let model = cand.calibrate(train.iter().map(|&i| &table[i]), dof)?;
    let mut decided = Vec::with_capacity(test.len());
    for &i in test {
        decided.push((table[i].class, model.classify_vector(&table[i].features)?.class));
    }
    let mut cv = CrossValidation { folds: Vec::new(), confusion: [[0; 7]; 7] };
    tally(&mut cv, name, &decided);
    Ok(Selected { cv, chosen: vec![(name.to_string(), k, inner)] })
}

/// Nested leave-one-group-out: for every group, [`choose`] on the other groups (by their own
/// leave-one-group-out), fit the chosen candidate on them, decide the held-out group. Needs at
/// least three groups (two left to choose on).
pub fn nested_cross_validate(
    tables: &[Vec<LabelledSpan>],
    candidates: &[Candidate],
    dof: Option<f64>,
) -> Result<Selected> {
    check_tables(tables, candidates)?;
    let all: Vec<usize> = (0..tables[0].len()).collect();
    let groups = groups_of(tables[0].iter());
    if groups.len() < 3 {
        return Err(invalid(format!("nested cross-validation needs at least three groups, got {}", groups.len())));
    }
    let mut out = Selected { cv: CrossValidation { folds: Vec::new(), confusion: [[0; 7]; 7] }, chosen: Vec::new() };
    for g in &groups {
        let train: Vec<usize> = all.iter().copied().filter(|&i| &tables[0][i].group != g).collect();
        let test: Vec<usize> = all.iter().copied().filter(|&i| &tables[0][i].group == g).collect();
        let one = train_test(tables, &train, &test, g, candidates, dof)?;
        for (i, row) in one.cv.confusion.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                out.cv.confusion[i][j] += v;
            }
        }
        out.cv.folds.extend(one.cv.folds);
        out.chosen.extend(one.chosen);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dos::{Feature, FeatureVector};

    /// Spans whose `drift_x` separates `n` (+) from `s` (−) in every group; `drift_y` is noise.
    fn spans(groups: usize) -> Vec<LabelledSpan> {
        let mut out = Vec::new();
        for g in 0..groups {
            for k in 0..6 {
                let (class, x) = if k % 2 == 0 { (DosClass::N, 2.0) } else { (DosClass::S, -2.0) };
                let mut all = [0.0; 18];
                all[Feature::ALL.iter().position(|&f| f == Feature::DriftX).unwrap()] = x + 0.1 * k as f64;
                all[Feature::ALL.iter().position(|&f| f == Feature::DriftY).unwrap()] =
                    ((g * 7 + k * 3) % 5) as f64 - 2.0;
                out.push(LabelledSpan {
                    class,
                    group: format!("g{g}"),
                    features: FeatureVector { all, frames: 100, events: 0 },
                });
            }
        }
        out
    }

    fn cand(features: Vec<Feature>) -> Candidate {
        Candidate {
            table: 0,
            config: DosFeatureConfig { features, ..Default::default() },
            shrinkage: 1.0,
            mirror: false,
        }
    }

    #[test]
    fn nested_choice_finds_the_informative_feature_and_scores_held_out_groups() {
        let tables = vec![spans(4)];
        let cands = vec![cand(vec![Feature::DriftY]), cand(vec![Feature::DriftX])];
        let r = nested_cross_validate(&tables, &cands, Some(3.0)).unwrap();
        assert_eq!(r.cv.folds.len(), 4);
        assert!(r.chosen.iter().all(|c| c.1 == 1), "{:?}", r.chosen);
        assert_eq!(r.cv.accuracy(), 1.0);
        let n: usize = r.cv.confusion.iter().flatten().sum();
        assert_eq!(n, 24);
    }

    #[test]
    fn train_test_chooses_on_the_training_spans_only() {
        let tables = vec![spans(4)];
        let cands = vec![cand(vec![Feature::DriftY]), cand(vec![Feature::DriftX])];
        let train: Vec<usize> = (0..12).collect();
        let test: Vec<usize> = (12..24).collect();
        let r = train_test(&tables, &train, &test, "rest", &cands, None).unwrap();
        assert_eq!(r.cv.folds, vec![("rest".to_string(), 12, 12)]);
        assert_eq!(r.chosen[0].1, 1);
    }

    #[test]
    fn refuses_what_it_cannot_do() {
        let tables = vec![spans(2)];
        let cands = vec![cand(vec![Feature::DriftX])];
        assert!(nested_cross_validate(&tables, &cands, None).is_err(), "two groups leave one to choose on");
        assert!(nested_cross_validate(&tables, &[], None).is_err());
        let bad = Candidate { table: 3, ..cands[0].clone() };
        assert!(nested_cross_validate(&[spans(3)], &[bad], None).is_err());
        assert!(choose(&[spans(3), spans(2)], &[0], &cands, None).is_err(), "tables of different spans");
    }
}
