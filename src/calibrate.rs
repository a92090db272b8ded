//! `gradtac calibrate`: fit the one-fingertip slip-direction classifier
//! ([`gradtac_stages::dos`]) from labelled recordings and write the model a scene loads.
//!
//! Labelled recordings are laid out as BioTacSP-DoS is: `<dir>/<class>/<name>.csv` with a
//! class directory per [`DosClass`] (`n`, `e`, `s`, `w`, `cw`, `aw`, `t`), one recording per
//! file. Each recording's features are extracted by the same [`DosFeatureExtractor`] the
//! scene's `dos` stage runs (by default the seven drift-map features on the linear scale, lags
//! 0.3 and 0.6 s); [`DosModel::calibrate`] then fits, per class and feature, a mean and a
//! variance (`λ` = 0: each class its own) on the recordings **and their mirror images** across
//! `y = 0` ([`mirror_augmented`]; `--no-mirror` turns it off): `2 × classes × features` numbers
//! (98 with the default seven features and seven classes; [`DosModel::parameter_count`] says
//! which). Fitting takes milliseconds. The model decides with Student-t class densities
//! (`ν` = 3, fixed); it is written as JSON with its feature configuration, so a scene computes
//! exactly the features it was fitted on.
//!
//! By default the model also carries a **window part** ([`calibrate_window_part`]): the window
//! model [`gradtac_stages::dos::DosWindowNet`] trained on the same recordings and the weight `a`
//! of the combined score `a·ln p_t + (1 − a)·(mean ln p per window)`, chosen by
//! leave-one-object-out — the combination that beats the Student-t model alone on every held-out
//! protocol of `dos_eval` (nested 91.6 % vs 80.2 %, basic → solids 92.9 % vs 85.7 %,
//! solids → basic 79.3 % vs 66.7 %; the window part is three networks each averaged with its
//! mirror image, [`window_candidates`]). It trains that net 7 times (≈ 30 s on two cores for
//! the 167 development recordings); `CalibrateOptions::window = false` (`--no-window`) writes
//! the Student-t model alone.
//!
//! These defaults are what the nested choice ([`gradtac_stages::dos_select`] over
//! [`design_candidates`]) picks on the BioTacSP-DoS development subset; [`held_out`] gives the
//! figures that say what that choice does on objects it has not seen (nested
//! leave-one-object-out, and train on one object set → test on the other), and
//! `gradtac calibrate --cross-validate` prints them for the data it is given.

use crate::Error;
use gradtac_io::{ColumnSelector, CsvFrames, CsvSourceConfig};
use gradtac_stages::contour::ContourFrame;
use gradtac_stages::dos::train_window::{self, WindowAugment, WindowTrainConfig};
use gradtac_stages::dos::{
    cross_validate, mirror_augmented, CrossValidation, DosClass, DosFeatureConfig, DosFeatureExtractor, DosModel,
    DosWindowPart, Feature, LabelledSpan,
};
use gradtac_stages::dos_select::{nested_cross_validate, train_test, Candidate, Selected};
use gradtac_stages::drift::DriftScale;
use gradtac_stream::{Layout, SensorId, TaxelFrame};
use std::path::{Path, PathBuf};

/// How recordings are read and the model is fitted.
#[derive(Clone, Debug)]
pub struct CalibrateOptions {
    /// Taxel columns (default `ff_e{1..24}`).
    pub columns: ColumnSelector,
    /// Sample rate (Hz) of files without a time column (default 100).
    pub rate_hz: f64,
    /// Feature settings (default [`DosFeatureConfig::default`]).
    pub features: DosFeatureConfig,
    /// Variance shrinkage `λ` in `[0, 1]` (default [`DosModel::DEFAULT_SHRINKAGE`]).
    pub shrinkage: f64,
    /// Student-t degrees of freedom, `None` for Gaussian class densities (default
    /// [`DosModel::DEFAULT_STUDENT_T_DOF`]).
    pub student_t_dof: Option<f64>,
    /// Calibrate on the recordings and their mirror images across `y = 0`
    /// ([`mirror_augmented`]; default on).
    pub mirror: bool,
    /// Add a window part to the model (default on; `gradtac calibrate --no-window` turns it
    /// off): the tree part ([`gradtac_stages::dos::DosTreesPart`], [`calibrate_trees_part`];
    /// the default since stop 34, see [`window_trees`](Self::window_trees)) or the window net
    /// ([`DosWindowPart`]: a [`gradtac_stages::dos::DosWindowNet`] and the weight of the
    /// combination, [`calibrate_window_part`]).
    pub window: bool,
    /// Give the window net (with `window_trees` off) the motion inputs about the contact's own
    /// centre ([`gradtac_stages::dos::WindowNetConfig::motion`]; default on since stop 32: chosen
    /// by the rule stated on the inner folds, then scored held out — the `dos` module docs;
    /// `gradtac calibrate --no-window-motion` turns it off, giving stop 31's window net).
    pub window_motion: bool,
    /// Write the window part as gradient-boosted trees ([`gradtac_stages::dos::DosTreesPart`],
    /// [`calibrate_trees_part`]) rather than the window net. **Default on since stop 34**: the
    /// tree model won its rule on the inner views and held out kept every met target (stop 33,
    /// the `dos` module docs); it became the default once the `dos` stage's sliding mode ran it
    /// within 20 µs per frame. `gradtac calibrate dos --window-net` (or `--no-window-motion`)
    /// writes the window net instead, stop 32's default.
    pub window_trees: bool,
}

impl Default for CalibrateOptions {
    fn default() -> Self {
        CalibrateOptions {
            columns: "ff_e{1..24}".parse().expect("valid pattern"),
            rate_hz: 100.0,
            features: DosFeatureConfig::default(),
            shrinkage: DosModel::DEFAULT_SHRINKAGE,
            student_t_dof: Some(DosModel::DEFAULT_STUDENT_T_DOF),
            mirror: true,
            window: true,
            window_motion: true,
            window_trees: true,
        }
    }
}

impl CalibrateOptions {
    /// Read feature settings from a TOML file holding the fields of [`DosFeatureConfig`] (the
    /// `[stages.dos.features]` table of a model, e.g. `drift_lags = [30, 60, 120]`,
    /// `features = ["drift_level", …]`); fields it omits keep their defaults. Validated.
    pub fn with_settings_file(mut self, path: &Path) -> Result<Self, Error> {
        let text = crate::guard::read_text_capped(path, crate::guard::MAX_SCENE_BYTES)?;
        let features: DosFeatureConfig = toml::from_str(&text)
            .map_err(|e| Error::Scene { path: path.to_path_buf(), reason: format!("not dos feature settings: {e}") })?;
        features.validate().map_err(|e| Error::Scene { path: path.to_path_buf(), reason: e.to_string() })?;
        self.features = features;
        Ok(self)
    }
}

/// The group of a recording for cross-validation: the leading letters of its file name, the
/// object it was recorded on in BioTacSP-DoS's naming (`bottle12.csv` → `bottle`); the whole
/// stem when it does not start with a letter.
pub fn object_of(path: &Path) -> String {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let letters: String = stem.chars().take_while(|c| c.is_alphabetic()).collect();
    if letters.is_empty() {
        stem
    } else {
        letters
    }
}

/// The labelled recordings under `dir`: (class, file), sorted.
pub fn labelled_files(dir: &Path) -> Result<Vec<(DosClass, PathBuf)>, Error> {
    let mut out = Vec::new();
    for class in DosClass::ALL {
        let d = dir.join(class.as_str());
        if !d.is_dir() {
            continue;
        }
        let mut files: Vec<PathBuf> = std::fs::read_dir(&d)
            .map_err(|source| Error::Io { path: d.clone(), source })?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "csv"))
            .collect();
        files.sort();
        out.extend(files.into_iter().map(|f| (class, f)));
    }
    if out.is_empty() {
        return Err(Error::Scene {
            path: dir.to_path_buf(),
            reason: format!(
                "no labelled recordings: expected <class>/<name>.csv with classes {}",
                DosClass::ALL.map(|c| c.as_str()).join(", ")
            ),
        });
    }
    Ok(out)
}

/// The features of every labelled recording under `dir` (one span per recording, grouped by
/// [`object_of`]).
pub fn labelled_spans(dir: &Path, layout: &Layout, opts: &CalibrateOptions) -> Result<Vec<LabelledSpan>, Error> {
    let files = labelled_files(dir)?;
    let mut extractor = DosFeatureExtractor::try_new(&opts.features, layout)?;
    let mut spans = Vec::with_capacity(files.len());
    // recordings a model cannot learn from: shorter than the longest drift lag, or constant
    let longest = opts.features.drift_lags.iter().copied().max().unwrap_or(0);
    let mut unfit = Vec::new();
    for (class, path) in &files {
        let cfg = CsvSourceConfig::new(path, opts.columns.clone()).with_rate_hz(opts.rate_hz);
        extractor.reset();
        let (mut frames, mut first, mut varies) = (0u64, None::<Vec<f64>>, false);
        for frame in CsvFrames::open(&cfg, SensorId::new("ff"))? {
            let frame = frame?;
            frames += 1;
            match &first {
                None => first = Some(frame.values.clone()),
                Some(f) => varies |= *f != frame.values,
            }
            extractor.push(frame)?;
        }
        if frames <= longest {
            unfit.push(format!(
                "{} has {frames} frame{}, not more than the longest drift lag ({longest} frames)",
                path.display(),
                if frames == 1 { "" } else { "s" }
            ));
        } else if !varies {
            unfit.push(format!("{} does not vary: every taxel is constant over its {frames} frames", path.display()));
        }
        spans.push(LabelledSpan { class: *class, group: object_of(path), features: extractor.features() });
    }
    if !unfit.is_empty() {
        let n = unfit.len();
        let mut list: Vec<String> = unfit.into_iter().take(5).collect();
        if n > 5 {
            list.push(format!("and {} more", n - 5));
        }
        return Err(Error::Scene {
            path: dir.to_path_buf(),
            reason: format!(
                "{n} recording{} cannot be calibrated on (a model fitted on them would be degenerate): {}",
                if n == 1 { "" } else { "s" },
                list.join("; ")
            ),
        });
    }
    Ok(spans)
}

/// Fit a model on labelled spans with `opts`' shrinkage and class density (and their mirror
/// images with `opts.mirror`).
pub fn calibrate_spans(spans: &[LabelledSpan], opts: &CalibrateOptions) -> Result<DosModel, Error> {
    let samples: Vec<(DosClass, Vec<f64>)> =
        spans.iter().map(|s| (s.class, s.features.select(&opts.features.features))).collect();
    let samples = if opts.mirror { mirror_augmented(&opts.features.features, &samples) } else { samples };
    let mut model = DosModel::calibrate_with_shrinkage(opts.features.clone(), &samples, opts.shrinkage)?
        .with_student_t_dof(opts.student_t_dof)?;
    // recordings, not recordings and their mirror images
    model.recordings = spans.len();
    Ok(model)
}

/// Leave-one-object-out cross-validation ([`cross_validate`]) of `opts`' model on labelled
/// spans: what to expect on an object the model has not seen.
/// (`opts.mirror` augments each fold's training spans.)
pub fn cross_validate_spans(spans: &[LabelledSpan], opts: &CalibrateOptions) -> Result<CrossValidation, Error> {
    if !opts.mirror {
        return Ok(cross_validate(&opts.features, spans, &|_| opts.shrinkage, opts.student_t_dof)?);
    }
    let cand = Candidate { table: 0, config: opts.features.clone(), shrinkage: opts.shrinkage, mirror: true };
    let groups: std::collections::BTreeSet<&str> = spans.iter().map(|s| s.group.as_str()).collect();
    if groups.len() < 2 {
        return Err(gradtac_stages::Error::InvalidConfig {
            stage: "dos",
            reason: format!("cross-validation needs at least two groups, got {}", groups.len()),
        }
        .into());
    }
    let mut cv = CrossValidation { folds: Vec::new(), confusion: [[0; 7]; 7] };
    let idx = |c: DosClass| DosClass::ALL.iter().position(|&x| x == c).unwrap_or(0);
    for g in groups {
        let model = cand.calibrate(spans.iter().filter(|s| s.group != g), opts.student_t_dof)?;
        let (mut ok, mut n) = (0, 0);
        for s in spans.iter().filter(|s| s.group == g) {
            let got = model.classify_vector(&s.features)?.class;
            cv.confusion[idx(s.class)][idx(got)] += 1;
            ok += usize::from(got == s.class);
            n += 1;
        }
        cv.folds.push((g.to_string(), ok, n));
    }
    Ok(cv)
}

/// Fit a model on every labelled recording under `dir` (with `opts.window`, its window part
/// too: [`calibrate_window_part`]); returns it with the number of recordings used.
pub fn calibrate_dos(dir: &Path, layout: &Layout, opts: &CalibrateOptions) -> Result<(DosModel, usize), Error> {
    let spans = labelled_spans(dir, layout, opts)?;
    let model = calibrate_spans(&spans, opts)?;
    if !opts.window {
        return Ok((model, spans.len()));
    }
    let recs = read_recordings(dir, opts)?;
    if opts.window_trees {
        let (part, _) = calibrate_trees_part(&spans, &recs, layout, opts)?;
        return Ok((model.with_trees(Some(part))?, spans.len()));
    }
    let (part, _) = calibrate_window_part(&spans, &recs, layout, opts)?;
    Ok((model.with_window(Some(part))?, spans.len()))
}

/// The weights `a` of the combined score `a·ln p_t + (1 − a)·(mean ln p per window)` that
/// [`calibrate_window_part`] chooses among (ties: the earlier).
pub const WINDOW_WEIGHTS: [f64; 5] = [0.0, 0.25, 0.5, 0.75, 1.0];

/// The weight used when the recordings hold fewer than two objects (no leave-one-object-out
/// possible): the value the nested procedure of `dos_eval` chose in seven of its eight folds.
pub const FALLBACK_WINDOW_WEIGHT: f64 = 0.75;

/// The window model's candidates (one, so no choice among them): mirror images and one random
/// copy of each recording (noise, speed, warp, dropout, rotation, vibration, per-taxel gain and
/// offset), three networks of [`WindowTrainConfig::default`]'s settings (16 hidden, 20 epochs;
/// seeds 1, 2, 3), each averaged with its own mirror image
/// ([`WindowTrainConfig::mirror_average`]): one network of 96 hidden units, symmetric under
/// the layout's mirror by construction. Chosen by leave-one-object-out *inside* basic and
/// *inside* solids only, among twelve configurations (logged in `examples/dos_eval_parts/history.md`); before
/// it, the choice per fold between mirror images only and mirror images with one random copy
/// of a single 16-unit network ([`previous_window_candidates`]). Since stop 32 the network also
/// has the four motion inputs about the contact's own centre
/// ([`gradtac_stages::dos::WindowNetConfig::motion`], reference the contact's first 10 frames;
/// chosen by a rule stated beforehand on the same inner views, then scored held out once: the
/// `dos` module docs); [`CalibrateOptions::window_motion`] `= false` gives stop 31's network.
pub fn window_candidates() -> Vec<WindowTrainConfig> {
    let mut c = WindowTrainConfig { members: 3, mirror_average: true, ..WindowTrainConfig::default() };
    c.net.motion = true;
    vec![c]
}

/// The window candidates of the previous default (chosen between per fold by leave-one-object-out
/// accuracy per window): mirror images only / mirror images and one random copy, one network of
/// [`WindowTrainConfig::default`]'s settings — the baseline row of `dos_eval`'s window model.
pub fn previous_window_candidates() -> Vec<WindowTrainConfig> {
    [WindowAugment::mirror_only(), WindowAugment::default()]
        .into_iter()
        .map(|augment| WindowTrainConfig { augment, ..WindowTrainConfig::default() })
        .collect()
}

/// How [`calibrate_window_part`] chose.
#[derive(Clone, Debug)]
pub struct WindowChoice {
    /// Index of the chosen [`window_candidates`] entry.
    pub candidate: usize,
    /// Its leave-one-object-out accuracy per window (NaN without a choice).
    pub candidate_accuracy: f64,
    /// Per weight of [`WINDOW_WEIGHTS`]: recordings right by leave-one-object-out (empty
    /// without a choice: fewer than two objects).
    pub weight_tally: Vec<(f64, usize, usize)>,
    /// The chosen weight.
    pub weight: f64,
}

/// The window part of the model `gradtac calibrate` writes, from the labelled `spans` and the
/// same recordings' raw frames `recs` (same order, e.g. [`labelled_spans`] and
/// [`read_recordings`] of one directory) — the procedure `dos_eval` holds out:
/// 1. the window candidate ([`window_candidates`]) of the best leave-one-object-out accuracy
///    per window (no choice when there is one candidate, as now);
/// 2. the weight `a` ∈ [`WINDOW_WEIGHTS`] with the most recordings right by
///    leave-one-object-out: for every object, the Student-t model (`opts`' settings,
///    [`calibrate_spans`]) and the chosen window net fitted on the other objects, the object's
///    recordings decided by the combined score ([`DosModel::combine`] over the whole recording);
/// 3. the net fitted on every recording.
///
/// With fewer than two objects, the last candidate and `a` = [`FALLBACK_WINDOW_WEIGHT`].
/// One fit of the net per object and one on all (7 on the 167 BioTacSP-DoS development
/// recordings, ≈ 4–6 s each).
pub fn calibrate_window_part(
    spans: &[LabelledSpan],
    recs: &[Recording],
    layout: &Layout,
    opts: &CalibrateOptions,
) -> Result<(DosWindowPart, WindowChoice), Error> {
    check_spans_match(spans, recs)?;
    let tr = train_recordings(recs);
    let mut cands = window_candidates();
    for c in &mut cands {
        c.net.motion = opts.window_motion;
    }
    let all: Vec<usize> = (0..tr.len()).collect();
    let groups: std::collections::BTreeSet<&str> = tr.iter().map(|r| r.group.as_str()).collect();
    if groups.len() < 2 {
        let k = cands.len() - 1;
        let samples = train_window::window_samples(&tr, layout, &cands[k])?;
        let mut net = train_window::fit_on(&samples, &all, layout, &cands[k])?;
        net.recordings = tr.len();
        let part = DosWindowPart { weight: FALLBACK_WINDOW_WEIGHT, net };
        let choice = WindowChoice {
            candidate: k,
            candidate_accuracy: f64::NAN,
            weight_tally: Vec::new(),
            weight: FALLBACK_WINDOW_WEIGHT,
        };
        return Ok((part, choice));
    }
    let samples: Vec<Vec<train_window::WindowSamples>> =
        cands.iter().map(|c| train_window::window_samples(&tr, layout, c)).collect::<Result<_, _>>()?;
    let views: Vec<&[train_window::WindowSamples]> = samples.iter().map(|s| s.as_slice()).collect();
    let (k, acc) =
        if cands.len() == 1 { (0, f64::NAN) } else { train_window::choose_window(&tr, &views, &all, layout, &cands)? };
    let (weight, tally) = choose_weight(
        spans,
        &tr,
        &groups,
        opts,
        |train| Ok(train_window::fit_on(views[k], train, layout, &cands[k])?),
        |net, test| Ok(train_window::mean_log_posteriors(&mut net.vote(layout)?, &tr, test)?),
        |model, weight, net| Ok(model.with_window(Some(DosWindowPart { weight, net: net.clone() }))?),
    )?;
    let mut net = train_window::fit_on(views[k], &all, layout, &cands[k])?;
    net.recordings = tr.len();
    let part = DosWindowPart { weight, net };
    Ok((part, WindowChoice { candidate: k, candidate_accuracy: acc, weight_tally: tally, weight }))
}

/// The tree part of the model `gradtac calibrate dos` writes by default: the procedure of
/// [`calibrate_window_part`] with the tree model (`train_trees::TreeTrainConfig::default()`, T15,
/// the winner of stop 36's round 6 over round 5's T13, which won over round 4's T12, which won over round 3's T9 — T9 won over stop 34's T4, itself round 2's
/// winner over stop 33's T1) in place of the net: the weight `a` ∈ [`WINDOW_WEIGHTS`] with
/// the most recordings right by leave-one-object-out (the Student-t model and the trees refitted
/// without each object), then the trees fitted on every recording; with fewer than two objects
/// `a` = [`FALLBACK_WINDOW_WEIGHT`]. One fit per object and one on all (7 on the 167 development
/// recordings, ≈ 3–10 s each). The returned choice's `candidate` is 0.
pub fn calibrate_trees_part(
    spans: &[LabelledSpan],
    recs: &[Recording],
    layout: &Layout,
    opts: &CalibrateOptions,
) -> Result<(gradtac_stages::dos::DosTreesPart, WindowChoice), Error> {
    use gradtac_stages::dos::train_trees::{self, TreeTrainConfig};
    use gradtac_stages::dos::DosTreesPart;
    check_spans_match(spans, recs)?;
    let tr = train_recordings(recs);
    let cfg = TreeTrainConfig::default();
    let samples = train_trees::tree_samples(&tr, layout, &cfg)?;
    let all: Vec<usize> = (0..tr.len()).collect();
    let groups: std::collections::BTreeSet<&str> = tr.iter().map(|r| r.group.as_str()).collect();
    let (weight, tally) = if groups.len() >= 2 {
        choose_weight(
            spans,
            &tr,
            &groups,
            opts,
            |train| Ok(train_trees::fit_on(&samples, train, layout, &cfg)?),
            |trees, test| Ok(train_window::mean_log_posteriors(&mut trees.vote(layout)?, &tr, test)?),
            |model, weight, trees| Ok(model.with_trees(Some(DosTreesPart { weight, trees: trees.clone() }))?),
        )?
    } else {
        (FALLBACK_WINDOW_WEIGHT, Vec::new())
    };
    let trees = train_trees::fit_on(&samples, &all, layout, &cfg)?;
    let part = DosTreesPart { weight, trees };
    Ok((part, WindowChoice { candidate: 0, candidate_accuracy: f64::NAN, weight_tally: tally, weight }))
}

/// Per weight of [`WINDOW_WEIGHTS`]: `(weight, recordings right, recordings decided)`.
type WeightTally = Vec<(f64, usize, usize)>;

/// Refuse labelled spans that do not match the recordings one for one.
fn check_spans_match(spans: &[LabelledSpan], recs: &[Recording]) -> Result<(), Error> {
    if spans.len() != recs.len() || spans.iter().zip(recs).any(|(s, r)| s.class != r.class || s.group != r.object) {
        return Err(gradtac_stages::Error::InvalidConfig {
            stage: "dos",
            reason: "the labelled spans and the recordings do not match (same directory, same order)".into(),
        }
        .into());
    }
    Ok(())
}

/// Step 2 of [`calibrate_window_part`] for any window model `M`: for every object of `groups`,
/// the Student-t model ([`calibrate_spans`]) and `fit` on the other objects' recordings, each of
/// the object's recordings decided by the combined score for every weight of [`WINDOW_WEIGHTS`]
/// (`with_part` puts `M` in the model at a weight; `mean_log_posteriors` gives `M`'s vote per
/// recording). Returns the weight with the most recordings right (the first on a tie) and the
/// tally `(weight, right, decided)`.
fn choose_weight<M>(
    spans: &[LabelledSpan],
    tr: &[train::TrainRecording],
    groups: &std::collections::BTreeSet<&str>,
    opts: &CalibrateOptions,
    fit: impl Fn(&[usize]) -> Result<M, Error>,
    mean_log_posteriors: impl Fn(&M, &[usize]) -> Result<Vec<Option<Vec<f64>>>, Error>,
    with_part: impl Fn(DosModel, f64, &M) -> Result<DosModel, Error>,
) -> Result<(f64, WeightTally), Error> {
    let all: Vec<usize> = (0..tr.len()).collect();
    let mut tally: Vec<(f64, usize, usize)> = WINDOW_WEIGHTS.iter().map(|&a| (a, 0, 0)).collect();
    for g in groups {
        let train: Vec<usize> = all.iter().copied().filter(|&i| tr[i].group != *g).collect();
        let test: Vec<usize> = all.iter().copied().filter(|&i| tr[i].group == *g).collect();
        let part_spans: Vec<LabelledSpan> = train.iter().map(|&i| spans[i].clone()).collect();
        let model = calibrate_spans(&part_spans, opts)?;
        let part = fit(&train)?;
        for (&i, w) in test.iter().zip(mean_log_posteriors(&part, &test)?) {
            let student = model.classify_vector(&spans[i].features)?;
            for t in tally.iter_mut() {
                let d = with_part(model.clone(), t.0, &part)?.combine(student.clone(), w.as_deref());
                t.1 += usize::from(d.class == tr[i].class);
                t.2 += 1;
            }
        }
    }
    let mut best = (WINDOW_WEIGHTS[0], 0usize);
    for &(a, ok, _) in &tally {
        if ok > best.1 {
            best = (a, ok);
        }
    }
    Ok((best.0, tally))
}

/// Read a model file written by [`write_model`] (JSON), validated.
pub fn read_model(path: &Path) -> Result<DosModel, Error> {
    let text = crate::guard::read_text_capped(path, crate::guard::MAX_MODEL_BYTES)?;
    let model: DosModel = serde_json::from_str(&text)
        .map_err(|e| Error::Scene { path: path.to_path_buf(), reason: format!("not a dos model: {e}") })?;
    model.validate()?;
    Ok(model)
}

/// Write a model as JSON.
pub fn write_model(model: &DosModel, path: &Path) -> Result<(), Error> {
    let json = serde_json::to_string_pretty(model).expect("models serialise");
    std::fs::write(path, json).map_err(|source| Error::Io { path: path.to_path_buf(), source })
}

// ---------------------------------------------------------------------------------------------
// Held-out evaluation: nested leave-one-object-out and cross-object-set figures
// ---------------------------------------------------------------------------------------------

/// One labelled recording's raw frames (one `Vec` of taxel values per frame).
#[derive(Clone, Debug)]
pub struct Recording {
    /// The labelled class.
    pub class: DosClass,
    /// The object it was recorded on ([`object_of`]).
    pub object: String,
    /// Raw values, one row per frame.
    pub frames: Vec<Vec<f64>>,
}

/// Read every labelled recording under `dir` ([`labelled_files`]) with `opts`' columns.
pub fn read_recordings(dir: &Path, opts: &CalibrateOptions) -> Result<Vec<Recording>, Error> {
    let mut out = Vec::new();
    for (class, path) in labelled_files(dir)? {
        let cfg = CsvSourceConfig::new(&path, opts.columns.clone()).with_rate_hz(opts.rate_hz);
        let frames =
            CsvFrames::open(&cfg, SensorId::new("ff"))?.map(|f| f.map(|f| f.values)).collect::<Result<Vec<_>, _>>()?;
        out.push(Recording { class, object: object_of(&path), frames });
    }
    Ok(out)
}

/// The BioTacSP-DoS object set of an object: `basic` (case, hd, pen, sponge), `solids`
/// (bottle, cardboard); any other object is its own set.
pub fn object_set(object: &str) -> String {
    match object {
        "case" | "hd" | "pen" | "sponge" => "basic".into(),
        "bottle" | "cardboard" => "solids".into(),
        other => other.into(),
    }
}

/// The features (all of them, [`Feature::ALL`]) of the first `span` frames of every recording
/// with `cfg`'s extraction settings, grouped by object.
pub fn spans_of(
    recs: &[Recording],
    cfg: &DosFeatureConfig,
    layout: &Layout,
    span: usize,
) -> Result<Vec<LabelledSpan>, Error> {
    let all = DosFeatureConfig { features: Feature::ALL.to_vec(), ..cfg.clone() };
    let mut extractor = DosFeatureExtractor::try_new(&all, layout)?;
    let mut out = Vec::with_capacity(recs.len());
    for r in recs {
        extractor.reset();
        for (seq, values) in r.frames.iter().take(span).enumerate() {
            let time = gradtac_stream::Timestamp::from_nanos(seq as i64 * 10_000_000);
            extractor.push(TaxelFrame::new(SensorId::new("ff"), time, seq as u64, values.clone()))?;
        }
        out.push(LabelledSpan { class: r.class, group: r.object.clone(), features: extractor.features() });
    }
    Ok(out)
}

/// The drift-lag sets (frames at 100 Hz) the design chooses among: one feature table each.
pub const DESIGN_LAGS: [&[u64]; 4] = [&[30, 60, 120], &[60], &[30, 60], &[60, 120]];

/// The drift-feature sets the design chooses among, simplest first.
pub const DESIGN_FEATURES: [&[Feature]; 3] = [
    &[Feature::DriftLevel, Feature::DriftX, Feature::DriftY],
    &[Feature::DriftLevel, Feature::DriftX, Feature::DriftY, Feature::DriftSpread, Feature::DriftAnisotropy],
    &Feature::DRIFT,
];

/// The shrinkages `λ` the design chooses among (1 first: the fewest parameters).
pub const DESIGN_SHRINKAGE: [f64; 5] = [1.0, 0.75, 0.5, 0.25, 0.0];

/// The feature tables of the design: one per [`DESIGN_LAGS`] entry, linear drift scale, the
/// rest of `base`.
pub fn design_tables(
    recs: &[Recording],
    base: &DosFeatureConfig,
    layout: &Layout,
    span: usize,
) -> Result<Vec<Vec<LabelledSpan>>, Error> {
    DESIGN_LAGS
        .iter()
        .map(|lags| {
            let cfg = DosFeatureConfig { drift_lags: lags.to_vec(), drift_scale: DriftScale::Linear, ..base.clone() };
            spans_of(recs, &cfg, layout, span)
        })
        .collect()
}

/// The design's candidates over [`design_tables`]: every lag set × drift-feature set ×
/// shrinkage × mirror augmentation (off first), 120 in all, all exactly invariant to a gain and
/// an offset per recording (linear drift map, no event feature).
pub fn design_candidates(base: &DosFeatureConfig) -> Vec<Candidate> {
    let mut out = Vec::new();
    for (table, lags) in DESIGN_LAGS.iter().enumerate() {
        for features in DESIGN_FEATURES {
            for shrinkage in DESIGN_SHRINKAGE {
                for mirror in [false, true] {
                    let config = DosFeatureConfig {
                        drift_lags: lags.to_vec(),
                        drift_scale: DriftScale::Linear,
                        features: features.to_vec(),
                        ..base.clone()
                    };
                    out.push(Candidate { table, config, shrinkage, mirror });
                }
            }
        }
    }
    out
}

/// Held-out figures of a choice procedure: nested leave-one-object-out over every recording and,
/// when the data holds both object sets, train on one set → test on the other (the choice made
/// by leave-one-object-out inside the training set).
#[derive(Clone, Debug)]
pub struct HeldOut {
    /// Nested leave-one-object-out.
    pub nested: Selected,
    /// Trained on *basic*, tested on *solids* (per recording).
    pub basic_to_solids: Option<Selected>,
    /// Trained on *solids*, tested on *basic* (per recording).
    pub solids_to_basic: Option<Selected>,
}

/// [`HeldOut`] figures of choosing among `candidates` (Student-t densities of `dof`).
pub fn held_out(tables: &[Vec<LabelledSpan>], candidates: &[Candidate], dof: Option<f64>) -> Result<HeldOut, Error> {
    let nested = nested_cross_validate(tables, candidates, dof)?;
    let spans = tables.first().map(Vec::as_slice).unwrap_or(&[]);
    let of = |set: &str| -> Vec<usize> { (0..spans.len()).filter(|&i| object_set(&spans[i].group) == set).collect() };
    let (basic, solids) = (of("basic"), of("solids"));
    let split = |train: &[usize], test: &[usize], name: &str| -> Result<Option<Selected>, Error> {
        let objects = |ix: &[usize]| {
            let mut o: Vec<&str> = ix.iter().map(|&i| spans[i].group.as_str()).collect();
            o.sort_unstable();
            o.dedup();
            o.len()
        };
        if objects(train) < 2 || test.is_empty() {
            return Ok(None);
        }
        Ok(Some(train_test(tables, train, test, name, candidates, dof)?))
    };
    Ok(HeldOut {
        nested,
        basic_to_solids: split(&basic, &solids, "basic → solids")?,
        solids_to_basic: split(&solids, &basic, "solids → basic")?,
    })
}

impl std::fmt::Display for HeldOut {
    /// The three figures with their protocols, the choices made per fold, and the nested
    /// confusion matrix.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "nested leave-one-object-out (every choice made inside each fold by leave-one-object-out on its \
             training objects): {:.1} %",
            100.0 * self.nested.cv.accuracy()
        )?;
        for (name, s) in [("basic → solids", &self.basic_to_solids), ("solids → basic", &self.solids_to_basic)] {
            match s {
                Some(s) => {
                    let (_, ok, n) = &s.cv.folds[0];
                    writeln!(
                        f,
                        "cross-set {name} (choice by leave-one-object-out on the training set, per recording): \
                         {:.1} % ({ok}/{n})",
                        100.0 * s.cv.accuracy()
                    )?;
                }
                None => writeln!(f, "cross-set {name}: not available (needs both object sets in the data)")?,
            }
        }
        write!(f, "\n{}", self.nested.cv)
    }
}

/// The held-out figures of the design choice on the labelled recordings under `dir`
/// ([`design_candidates`] over [`design_tables`], Student-t densities of `opts`): nested
/// leave-one-object-out and, when both object sets are present, the cross-set figures — what
/// `gradtac calibrate --cross-validate` prints after the plain cross-validation of the chosen
/// settings.
pub fn held_out_report(dir: &Path, layout: &Layout, opts: &CalibrateOptions) -> Result<HeldOut, Error> {
    let recs = read_recordings(dir, opts)?;
    let tables = design_tables(&recs, &opts.features, layout, usize::MAX)?;
    held_out(&tables, &design_candidates(&opts.features), opts.student_t_dof)
}

// ---------------------------------------------------------------------------------------------
// `gradtac calibrate force` and `gradtac calibrate baseline`
// ---------------------------------------------------------------------------------------------

/// Most frames a force or baseline calibration reads (a bound on its memory: ≈ 200 bytes per
/// frame for a 24-taxel sensor); later frames are not read.
pub const MAX_CALIBRATION_FRAMES: u64 = 2_000_000;

/// Where the gauge's newtons come from.
#[derive(Clone, Debug)]
pub enum GaugeSource {
    /// A column of the sensor's own CSV recording (same rows, same times).
    SameCsv {
        /// The column's name.
        column: String,
    },
    /// A CSV of its own, matched to the frames by time.
    File {
        /// The file.
        path: PathBuf,
        /// The force column.
        column: String,
        /// The time column (on the recording's clock).
        time_column: String,
        /// Its unit.
        time_unit: gradtac_io::TimeUnit,
    },
}

/// Options of `gradtac calibrate force`.
#[derive(Clone, Debug)]
pub struct ForceCalibration {
    /// The sensor (default: the scene's only sensor).
    pub sensor: Option<String>,
    /// The gauge.
    pub gauge: GaugeSource,
    /// The method (default [`force_model::DEFAULT_METHOD`](gradtac_stages::force_model::DEFAULT_METHOD)).
    pub method: gradtac_stages::force_model::CalibrationMethod,
}

/// The one sensor a calibration reads: `name`, or the scene's only sensor.
pub fn calibration_sensor(scene: &crate::Scene, name: Option<&str>) -> Result<usize, Error> {
    let bad = |reason: String| Error::Scene { path: scene.origin.clone(), reason };
    match name {
        Some(n) => scene.sensors.iter().position(|s| s.name == n).ok_or_else(|| bad(format!("no sensor {n:?}"))),
        None if scene.sensors.len() == 1 => Ok(0),
        None => {
            Err(bad(format!("the scene has {} sensors; name the one to calibrate with --sensor", scene.sensors.len())))
        }
    }
}

/// A gauge's readings `(time ns, N)`, in time order.
pub fn read_gauge(scene: &crate::Scene, sensor: usize, gauge: &GaugeSource) -> Result<Vec<(i64, f64)>, Error> {
    let spec = &scene.sensors[sensor];
    let cfg = match gauge {
        GaugeSource::SameCsv { column } => match &spec.source {
            crate::scene::SourceSpec::Csv(c) => CsvSourceConfig {
                path: scene.resolve(&c.path),
                columns: ColumnSelector::Names(vec![column.clone()]),
                ..c.clone()
            },
            other => {
                return Err(Error::Scene {
                    path: scene.origin.clone(),
                    reason: format!(
                        "sensor {:?} reads a {} source: give the gauge's CSV with --force-file (matched by time)",
                        spec.name,
                        other.kind()
                    ),
                })
            }
        },
        GaugeSource::File { path, column, time_column, time_unit } => {
            CsvSourceConfig::new(path, ColumnSelector::Names(vec![column.clone()]))
                .with_time_column(time_column.clone(), *time_unit)
        }
    };
    let frames = CsvFrames::open(&cfg, SensorId::new("gauge"))?;
    let mut out = Vec::new();
    for (row, f) in frames.enumerate() {
        let f = f?;
        if out.len() as u64 >= MAX_CALIBRATION_FRAMES {
            break;
        }
        let v = f.values[0];
        if !v.is_finite() {
            return Err(Error::Scene {
                path: cfg.path.clone(),
                reason: format!("gauge reading {} (data row {}) is not a finite number", v, row + 1),
            });
        }
        out.push((f.time.0, v));
    }
    if out.is_empty() {
        return Err(Error::Scene { path: cfg.path.clone(), reason: "no gauge readings".into() });
    }
    Ok(out)
}

/// The gauge at time `t` (ns): linear between readings; `None` outside them or across a gap
/// of more than 5 × the median reading interval.
fn gauge_at(g: &[(i64, f64)], t: i64, max_gap: i64) -> Option<f64> {
    let j = g.partition_point(|r| r.0 <= t);
    if j == 0 {
        return None;
    }
    let (t0, f0) = g[j - 1];
    if t0 == t {
        return Some(f0);
    }
    let &(t1, f1) = g.get(j)?;
    if t1 - t0 > max_gap {
        return None;
    }
    Some(f0 + (f1 - f0) * (t - t0) as f64 / (t1 - t0) as f64)
}

/// Raw frames in, contours out (one scene's contact location, boxed).
type ContourFront = Box<dyn FnMut(TaxelFrame, &mut Vec<ContourFrame>) -> Result<(), Error>>;

/// Contact location as a scene builds it (`[stages.locate] method`), raw frames to contours,
/// for the area method's calibration.
fn contour_front(scene: &crate::Scene, layout: &Layout, rate_hz: Option<f64>) -> Result<ContourFront, Error> {
    use gradtac_stages::locate::LocateMethod;
    use gradtac_stream::{Stage, StageExt};
    let st = &scene.stages.resolved();
    let n = layout.len();
    let tare = scene.loaded.tare.clone();
    fn boxed<S>(mut s: S) -> ContourFront
    where
        S: Stage<In = TaxelFrame, Out = ContourFrame> + 'static,
        S::Error: Into<Error>,
    {
        Box::new(move |f, out| s.push(f, out).map_err(Into::into))
    }
    Ok(match st.locate.method {
        LocateMethod::Centroid => {
            let mut c = gradtac_stages::centroid::Centroid::try_new(&st.locate, layout)?;
            if let Some(t) = &tare {
                c = c.with_tare(t)?;
            }
            boxed(c)
        }
        LocateMethod::RawContour => {
            let mut r = gradtac_stages::raw_contour::RawChange::try_new(n, &st.locate)?;
            if let Some(t) = &tare {
                r = r.with_tare(t)?;
            }
            let contour = crate::chain::effective_contour(st);
            boxed(r.then(gradtac_stages::peak::SurfaceContour::try_new(&st.surface, &contour, layout)?))
        }
        LocateMethod::Fit => {
            let mut f = gradtac_stages::fit::Fit::try_new(&st.locate, layout)?;
            if let Some(t) = &tare {
                f = f.with_tare(t)?;
            }
            boxed(f)
        }
        LocateMethod::Events => boxed(crate::chain::event_contour_stages(st, layout, rate_hz)?),
    })
}

/// What a force calibration did.
#[derive(Clone, Debug)]
pub struct ForceCalibrationReport {
    /// Frames read.
    pub frames: u64,
    /// Frames with a gauge reading at their time.
    pub with_gauge: u64,
    /// Frames the gauge calls untouched (below 0.05 N) and, of those, how many the fitted
    /// model puts above 0.5 N (in sample).
    pub untouched: (u64, u64),
}

/// Calibrate a force model from a scene's one sensor and a gauge (`gradtac calibrate force`):
/// the scene's detector settings (and stored baseline) or contact location, each frame's
/// features matched with the gauge at the centre of the frames it averages.
pub fn calibrate_force(
    scene: &crate::Scene,
    opts: &ForceCalibration,
) -> Result<(gradtac_stages::force_model::ForceFile, ForceCalibrationReport), Error> {
    use gradtac_stages::force_model::{self, CalibrationMethod, GaugeSample};
    let index = calibration_sensor(scene, opts.sensor.as_deref())?;
    let spec = &scene.sensors[index];
    let layout = scene.layout(spec)?;
    let gauge = read_gauge(scene, index, &opts.gauge)?;
    let mut dts: Vec<i64> = gauge.windows(2).map(|w| w[1].0 - w[0].0).collect();
    dts.sort_unstable();
    let max_gap = dts.get(dts.len() / 2).copied().unwrap_or(0).saturating_mul(5).max(1);
    let mut samples: Vec<GaugeSample> = Vec::new();
    let frames;
    let centre = |s: gradtac_stream::Timestamp, e: gradtac_stream::Timestamp| s.0 + (e.0 - s.0) / 2;
    match opts.method {
        CalibrationMethod::Forward
        | CalibrationMethod::Placed
        | CalibrationMethod::Total
        | CalibrationMethod::Ridge => {
            // the force stage's own detector, so the model sees the changes it will be given
            // with the layout's positions, as the force stage runs it (the drift model's shape test)
            let mut det =
                force_model::force_detector(layout.len(), &scene.stages.locate)?.with_positions(layout.positions())?;
            if let Some(t) = &scene.loaded.tare {
                det = det.with_tare(t)?;
            }
            frames = crate::run::for_each_frame(scene, &spec.name, MAX_CALIBRATION_FRAMES, |f| {
                let ch = det.push(&f, "calibrate force")?;
                if let Some(force_n) = gauge_at(&gauge, centre(ch.start, ch.end), max_gap) {
                    samples.push(GaugeSample {
                        change: det.change().to_vec(),
                        contact: ch.contact,
                        area_mm2: None,
                        amplitude: None,
                        force_n,
                        time_s: centre(ch.start, ch.end) as f64 * 1e-9,
                    });
                }
                Ok(true)
            })?;
        }
        CalibrationMethod::Area | CalibrationMethod::Amplitude => {
            if opts.method == CalibrationMethod::Amplitude
                && scene.stages.locate.method != gradtac_stages::locate::LocateMethod::Fit
            {
                return Err(Error::Scene {
                    path: scene.origin.clone(),
                    reason: "--method amplitude reads the contact fit: set [stages.locate] method = \"fit\"".into(),
                });
            }
            let mut front = contour_front(scene, &layout, spec.source.rate_hz())?;
            let mut out = Vec::new();
            let push = |out: &mut Vec<ContourFrame>, samples: &mut Vec<GaugeSample>| {
                for c in out.drain(..) {
                    if let Some(force_n) = gauge_at(&gauge, centre(c.start, c.end), max_gap) {
                        let (area, amplitude) = match &c.outcome {
                            gradtac_stages::contour::ContourOutcome::Contact(m) => {
                                (Some(m.area_mm2), m.fit.as_ref().map(|f| f.amplitude))
                            }
                            _ => (None, None),
                        };
                        samples.push(GaugeSample {
                            change: Vec::new(),
                            contact: area.is_some(),
                            area_mm2: area,
                            amplitude,
                            force_n,
                            time_s: centre(c.start, c.end) as f64 * 1e-9,
                        });
                    }
                }
            };
            frames = crate::run::for_each_frame(scene, &spec.name, MAX_CALIBRATION_FRAMES, |f| {
                front(f, &mut out)?;
                push(&mut out, &mut samples);
                Ok(true)
            })?;
        }
    }
    let file = force_model::calibrate(
        &samples,
        opts.method,
        force_model::DEFAULT_RIDGE_LAMBDA,
        force_model::DEFAULT_AREA_CURVE,
        &layout,
    )
    .map_err(|e| Error::Scene { path: scene.origin.clone(), reason: format!("sensor {:?}: {e}", spec.name) })?;
    let predict = |s: &GaugeSample| file.model.predict_sample(s);
    let quiet: Vec<&GaugeSample> = samples.iter().filter(|s| s.force_n < force_model::MIN_CALIBRATION_N).collect();
    let over = quiet.iter().filter(|s| predict(s).is_some_and(|p| p > 0.5)).count() as u64;
    let report =
        ForceCalibrationReport { frames, with_gauge: samples.len() as u64, untouched: (quiet.len() as u64, over) };
    Ok((file, report))
}

/// Measure a stored untouched baseline (`gradtac calibrate baseline`) from the frames of the
/// scene's one sensor between `from_s` and `to_s` seconds after its first frame (`to_s`
/// `None`: to the end), refusing a stretch with a contact in it.
pub fn calibrate_baseline(
    scene: &crate::Scene,
    sensor: Option<&str>,
    from_s: f64,
    to_s: Option<f64>,
) -> Result<gradtac_stages::tare::Tare, Error> {
    let index = calibration_sensor(scene, sensor)?;
    let spec = &scene.sensors[index];
    let layout = scene.layout(spec)?;
    let bad = |reason: String| Error::Scene { path: scene.origin.clone(), reason };
    if !(from_s.is_finite() && from_s >= 0.0 && to_s.is_none_or(|t| t.is_finite() && t > from_s)) {
        return Err(bad(format!("--from {from_s} --to {to_s:?}: want 0 ≤ from < to")));
    }
    let (mut first, mut values, mut times) = (None, Vec::new(), Vec::new());
    crate::run::for_each_frame(scene, &spec.name, MAX_CALIBRATION_FRAMES, |f| {
        let t0 = *first.get_or_insert(f.time.0);
        let s = (f.time.0 - t0) as f64 * 1e-9;
        if to_s.is_some_and(|to| s > to) {
            return Ok(false);
        }
        if s >= from_s {
            if f.values.len() != layout.len() {
                return Err(bad(format!(
                    "frame {} has {} taxels, the layout {} has {}",
                    f.seq,
                    f.values.len(),
                    layout.name(),
                    layout.len()
                )));
            }
            times.push(f.time.0);
            values.push(f.values);
        }
        Ok(true)
    })?;
    gradtac_stages::tare::Tare::measure(&values, &times, layout.name(), &spec.name, &scene.stages.locate)
        .map_err(|e| bad(format!("sensor {:?}: {e}", spec.name)))
}

/// Write any model as pretty JSON (after [`guard::check_output_file`](crate::guard::check_output_file)).
pub fn write_json<T: serde::Serialize>(value: &T, path: &Path) -> Result<(), Error> {
    let json = serde_json::to_string_pretty(value).expect("models serialise");
    std::fs::write(path, json).map_err(|source| Error::Io { path: path.to_path_buf(), source })
}

// ---------------------------------------------------------------------------------------------
// The learned model (gradtac_stages::dos::DosNet): candidates, held-out figures, training
// ---------------------------------------------------------------------------------------------

pub use gradtac_stages::dos::train::{Augment, NetHeldOut, Representations, TrainConfig, TrainRecording, Versions};
use gradtac_stages::dos::{train, DosNet};

/// The learned model's candidates, simplest first: weight decay `l2` ∈ {0.01, 0.1} × augmentation
/// (mirror images only / mirror images and two random copies of each recording with the default
/// [`Augment`] strengths); 16 hidden units, lags 0.3 and 0.6 s, 300 Adam steps. Chosen by
/// leave-one-object-out inside the training objects ([`net_held_out`]).
pub fn net_candidates() -> Vec<TrainConfig> {
    let mut out = Vec::new();
    for augment in [Augment::mirror_only(), Augment { copies: 2, ..Augment::default() }] {
        for l2 in [1e-2, 1e-1] {
            out.push(TrainConfig { l2, augment: augment.clone(), ..TrainConfig::default() });
        }
    }
    out
}

/// One line describing a candidate.
pub fn describe_net(c: &TrainConfig) -> String {
    format!(
        "{} hidden, lags {:?}, l2 {}, {} steps, mirror {}, {} random copies",
        c.net.hidden,
        c.net.lags,
        c.l2,
        c.epochs,
        if c.augment.mirror { "on" } else { "off" },
        c.augment.copies
    )
}

/// Recordings as the trainer takes them (grouped by object).
pub fn train_recordings(recs: &[Recording]) -> Vec<TrainRecording> {
    recs.iter().map(|r| TrainRecording { class: r.class, group: r.object.clone(), frames: r.frames.clone() }).collect()
}

/// Held-out figures of the learned model's choice among `candidates`: nested
/// leave-one-object-out and, with both object sets, basic → solids and solids → basic (choice
/// by leave-one-object-out inside the training set), per recording.
#[derive(Clone, Debug)]
pub struct NetReport {
    /// Nested leave-one-object-out.
    pub nested: NetHeldOut,
    /// Trained on basic, tested on solids.
    pub basic_to_solids: Option<NetHeldOut>,
    /// Trained on solids, tested on basic.
    pub solids_to_basic: Option<NetHeldOut>,
}

/// Every candidate's training representations (candidates with the same representation and
/// augmentation share them).
pub fn net_representations(
    recs: &[TrainRecording],
    layout: &Layout,
    candidates: &[TrainConfig],
) -> Result<Vec<std::sync::Arc<Representations>>, Error> {
    let mut done: Vec<(TrainConfig, std::sync::Arc<Representations>)> = Vec::new();
    let mut out = Vec::new();
    for c in candidates {
        let key = TrainConfig { l2: 0.0, epochs: 1, learning_rate: 0.01, net: c.net.clone(), ..c.clone() };
        let key = TrainConfig { net: gradtac_stages::dos::NetConfig { hidden: 1, ..key.net.clone() }, ..key };
        if let Some((_, r)) = done.iter().find(|(k, _)| *k == key) {
            out.push(r.clone());
            continue;
        }
        let r = std::sync::Arc::new(train::represent_recordings(recs, layout, c)?);
        done.push((key, r.clone()));
        out.push(r);
    }
    Ok(out)
}

/// [`NetReport`] of choosing among `candidates` on `recs`.
pub fn net_held_out(recs: &[Recording], layout: &Layout, candidates: &[TrainConfig]) -> Result<NetReport, Error> {
    let tr = train_recordings(recs);
    let reps = net_representations(&tr, layout, candidates)?;
    let views: Vec<&[Versions]> = reps.iter().map(|r| r.as_slice()).collect();
    let taxels = layout.len();
    let nested = train::nested(&tr, &views, taxels, candidates)?;
    let of = |set: &str| -> Vec<usize> { (0..recs.len()).filter(|&i| object_set(&recs[i].object) == set).collect() };
    let (basic, solids) = (of("basic"), of("solids"));
    let objects =
        |ix: &[usize]| ix.iter().map(|&i| recs[i].object.as_str()).collect::<std::collections::BTreeSet<_>>().len();
    let split = |a: &[usize], b: &[usize], name: &str| -> Result<Option<NetHeldOut>, Error> {
        if objects(a) < 2 || b.is_empty() {
            return Ok(None);
        }
        Ok(Some(train::train_test(&tr, &views, a, b, name, taxels, candidates)?))
    };
    Ok(NetReport {
        nested,
        basic_to_solids: split(&basic, &solids, "basic → solids")?,
        solids_to_basic: split(&solids, &basic, "solids → basic")?,
    })
}

/// Train the learned model with `cfg` on every recording (and the augmentation `cfg` asks for).
pub fn train_net(recs: &[Recording], layout: &Layout, cfg: &TrainConfig) -> Result<DosNet, Error> {
    let tr = train_recordings(recs);
    let reps = train::represent_recordings(&tr, layout, cfg)?;
    let all: Vec<usize> = (0..tr.len()).collect();
    let (_, _, mut net) = train::fit_and_score(&reps, &all, &[], layout.len(), cfg)?;
    net.recordings = tr.len();
    Ok(net)
}
