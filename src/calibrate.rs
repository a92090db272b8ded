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
use gradtac_stages::dos::{DosClass, DosFeatureConfig, DosFeatureExtractor, DosModel};
use gradtac_stream::{Layout, SensorId};
use std::path::{Path, PathBuf};

/// How recordings are read for calibration.
#[derive(Clone, Debug)]
pub struct CalibrateOptions {
    /// Taxel columns (default `ff_e{1..24}`).
    pub columns: ColumnSelector,
    /// Sample rate (Hz) of files without a time column (default 100).
    pub rate_hz: f64,
    /// Feature settings (default [`DosFeatureConfig::default`]).
    pub features: DosFeatureConfig,
}

impl Default for CalibrateOptions {
    fn default() -> Self {
        CalibrateOptions {
            columns: "ff_e{1..24}".parse().expect("valid pattern"),
            rate_hz: 100.0,
            features: DosFeatureConfig::default(),
        }
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

/// Fit a model on every labelled recording under `dir`; returns it with the number of
/// recordings used.
pub fn calibrate_dos(dir: &Path, layout: &Layout, opts: &CalibrateOptions) -> Result<(DosModel, usize), Error> {
    let files = labelled_files(dir)?;
    let mut extractor = DosFeatureExtractor::try_new(&opts.features, layout)?;
    let mut samples = Vec::with_capacity(files.len());
    for (class, path) in &files {
        let cfg = CsvSourceConfig::new(path, opts.columns.clone()).with_rate_hz(opts.rate_hz);
        extractor.reset();
        for frame in CsvFrames::open(&cfg, SensorId::new("ff"))? {
            extractor.push(frame?)?;
        }
        samples.push((*class, extractor.features().select(&opts.features.features)));
    }
    Ok((DosModel::calibrate(opts.features.clone(), &samples)?, files.len()))
}

/// Read a model file written by [`write_model`] (JSON), validated.
pub fn read_model(path: &Path) -> Result<DosModel, Error> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
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
