//! `gradtac calibrate`: fit the one-fingertip slip-direction classifier
//! ([`gradtac_stages::dos`]) from labelled recordings and write the model a scene loads.
//!
//! Labelled recordings are laid out as BioTacSP-DoS is: `<dir>/<class>/<name>.csv` with a
//! class directory per [`DosClass`] (`n`, `e`, `s`, `w`, `cw`, `aw`, `t`), one recording per
//! file. Each recording's features are extracted by the same [`DosFeatureExtractor`] the
//! scene's `dos` stage runs (by default the seven drift-map features and the positive-event
//! centroid); [`DosModel::calibrate`] then fits, per class and feature, a mean and a variance
//! shrunk halfway toward the pooled within-class variance: `2 × classes × features` numbers
//! (126 with the default nine features and seven classes; [`DosModel::parameter_count`] says
//! which). The model decides with Student-t class densities (`ν` = 3, fixed); it is written as
//! JSON with its feature configuration, so a scene computes exactly the features it was fitted
//! on.

use crate::Error;
use gradtac_io::{ColumnSelector, CsvFrames, CsvSourceConfig};
use gradtac_stages::dos::{
    cross_validate, CrossValidation, DosClass, DosFeatureConfig, DosFeatureExtractor, DosModel, LabelledSpan,
};
use gradtac_stream::{Layout, SensorId};
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
}

impl Default for CalibrateOptions {
    fn default() -> Self {
        CalibrateOptions {
            columns: "ff_e{1..24}".parse().expect("valid pattern"),
            rate_hz: 100.0,
            features: DosFeatureConfig::default(),
            shrinkage: DosModel::DEFAULT_SHRINKAGE,
            student_t_dof: Some(DosModel::DEFAULT_STUDENT_T_DOF),
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
    for (class, path) in &files {
        let cfg = CsvSourceConfig::new(path, opts.columns.clone()).with_rate_hz(opts.rate_hz);
        extractor.reset();
        for frame in CsvFrames::open(&cfg, SensorId::new("ff"))? {
            extractor.push(frame?)?;
        }
        spans.push(LabelledSpan { class: *class, group: object_of(path), features: extractor.features() });
    }
    Ok(spans)
}

/// Fit a model on labelled spans with `opts`' shrinkage and class density.
pub fn calibrate_spans(spans: &[LabelledSpan], opts: &CalibrateOptions) -> Result<DosModel, Error> {
    let samples: Vec<(DosClass, Vec<f64>)> =
        spans.iter().map(|s| (s.class, s.features.select(&opts.features.features))).collect();
    Ok(DosModel::calibrate_with_shrinkage(opts.features.clone(), &samples, opts.shrinkage)?
        .with_student_t_dof(opts.student_t_dof)?)
}

/// Leave-one-object-out cross-validation ([`cross_validate`]) of `opts`' model on labelled
/// spans: what to expect on an object the model has not seen.
pub fn cross_validate_spans(spans: &[LabelledSpan], opts: &CalibrateOptions) -> Result<CrossValidation, Error> {
    Ok(cross_validate(&opts.features, spans, &|_| opts.shrinkage, opts.student_t_dof)?)
}

/// Fit a model on every labelled recording under `dir`; returns it with the number of
/// recordings used.
pub fn calibrate_dos(dir: &Path, layout: &Layout, opts: &CalibrateOptions) -> Result<(DosModel, usize), Error> {
    let spans = labelled_spans(dir, layout, opts)?;
    Ok((calibrate_spans(&spans, opts)?, spans.len()))
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
