//! The one-fingertip slip-direction classifier on the real BioTacSP-DoS recordings
//! (Zapata-Impata, Gil and Torres, Sensors 19(3):523, 2019), read from `shared/data` when
//! present; the test passes (with a printed note) without it.
//!
//! Leave-one-object-out over the six objects with the default features and decision rule: the
//! accuracy must be well above chance (1/7) and above the 73.1 % of the event-only features
//! that were the default before the drift map. The
//! full evaluation with the confusion matrix is the root package's
//! `cargo run --release --example dos_eval`.

use gradtac_stages::dos::{
    mirror_augmented, DosClass, DosFeatureConfig, DosFeatureExtractor, DosModel, Feature, FeatureVector,
};
use gradtac_stream::{Layout, TaxelFrame, Timestamp};
use std::path::Path;

mod common;
use common::{data_dir, read};

/// (class, object, features) of every recording.
fn load(root: &Path, cfg: &DosFeatureConfig) -> Vec<(DosClass, String, FeatureVector)> {
    let layout = Layout::biotac_sp();
    let mut x = DosFeatureExtractor::try_new(cfg, &layout).unwrap();
    let mut out = Vec::new();
    for class in DosClass::ALL {
        let mut files: Vec<_> =
            std::fs::read_dir(root.join(class.as_str())).unwrap().map(|e| e.unwrap().path()).collect();
        files.sort();
        for f in files {
            let stem = f.file_stem().unwrap().to_string_lossy().into_owned();
            let object: String = stem.chars().take_while(|c| c.is_ascii_alphabetic()).collect();
            x.reset();
            for (k, v) in read(&f).into_iter().enumerate() {
                x.push(TaxelFrame::new("ff".into(), Timestamp::at_rate(k as u64, 100.0), k as u64, v))
                    .unwrap_or_else(|e| panic!("{}: {e}", f.display()));
            }
            let fv = x.features();
            assert!(fv.select(&cfg.features).iter().all(|v| v.is_finite()), "{}: {fv:?}", f.display());
            out.push((class, object, fv));
        }
    }
    out
}

#[test]
fn leave_one_object_out_is_well_above_chance() {
    let Some(root) = data_dir() else { return };
    let cfg = DosFeatureConfig::default();
    let recs = load(&root, &cfg);
    assert_eq!(recs.len(), 167);
    let mut objects: Vec<&str> = recs.iter().map(|r| r.1.as_str()).collect();
    objects.sort();
    objects.dedup();
    assert_eq!(objects, ["bottle", "cardboard", "case", "hd", "pen", "sponge"]);
    let (mut ok, mut n) = (0, 0);
    for obj in &objects {
        let train: Vec<_> = recs.iter().filter(|r| r.1 != *obj).map(|r| (r.0, r.2.select(&cfg.features))).collect();
        // as `gradtac calibrate` does: the training recordings and their mirror images
        let model = DosModel::calibrate(cfg.clone(), &mirror_augmented(&cfg.features, &train)).unwrap();
        assert_eq!(model.parameter_count(), 98);
        let (mut fold_ok, mut fold_n) = (0, 0);
        for r in recs.iter().filter(|r| r.1 == *obj) {
            fold_ok += usize::from(model.classify_vector(&r.2).unwrap().class == r.0);
            fold_n += 1;
        }
        eprintln!("held out {obj}: {fold_ok}/{fold_n}");
        assert!(fold_ok as f64 / fold_n as f64 > 2.0 / 7.0, "{obj}: {fold_ok}/{fold_n}");
        ok += fold_ok;
        n += fold_n;
    }
    let acc = ok as f64 / n as f64;
    eprintln!("leave-one-object-out accuracy {:.1} % ({ok}/{n})", 100.0 * acc);
    // measured 83.2 % (139/167) with the defaults (chosen by the nested procedure on all six
    // objects, so this figure is in-sample for those choices); chance is 14.3 %
    assert!(acc > 0.80, "accuracy {acc}");
}

/// The data behind the class → direction map: events gather on the side the contact leaves,
/// so the event centroid of `n` (toward +x) lies at smaller x than that of `s`, and the one of
/// `e` (toward +y) at smaller y than that of `w`; touch is the quietest class.
#[test]
fn class_means_support_the_direction_map() {
    let Some(root) = data_dir() else { return };
    let cfg = DosFeatureConfig::default();
    let recs = load(&root, &cfg);
    let mean = |c: DosClass, f: Feature| {
        let v: Vec<f64> = recs.iter().filter(|r| r.0 == c).map(|r| r.2.get(f)).collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    for f in [Feature::PositiveX, Feature::NegativeX, Feature::ActivityX] {
        assert!(mean(DosClass::N, f) + 2.0 < mean(DosClass::S, f), "{f:?}");
    }
    for f in [Feature::PositiveY, Feature::NegativeY, Feature::ActivityY] {
        assert!(mean(DosClass::E, f) + 5.0 < mean(DosClass::W, f), "{f:?}");
    }
    let t = mean(DosClass::T, Feature::Rate);
    for c in DosClass::ALL.into_iter().filter(|&c| c != DosClass::T) {
        assert!(mean(c, Feature::Rate) > t + 0.5, "{c}");
    }
}

/// The drift map agrees with the events (class means measured: `drift_x` n −1.9 / s +1.4 mm,
/// `drift_y` e −3.1 / w +2.7 mm, `drift_level` touch 2.7 against ≥ 3.5 for every slip), and its
/// signed across-finger dipole separates the rotations on average (cw −1.2, aw +2.3 mm; spreads
/// ≈ 2.3 mm), while the translations spread their drift along their axis (anisotropy ≥ 3 mm²)
/// and the rotations do not (≤ 0.5 mm²).
#[test]
fn drift_class_means_support_the_direction_map() {
    let Some(root) = data_dir() else { return };
    let recs = load(&root, &DosFeatureConfig::default());
    let mean = |c: DosClass, f: Feature| {
        let v: Vec<f64> = recs.iter().filter(|r| r.0 == c).map(|r| r.2.get(f)).collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    assert!(mean(DosClass::N, Feature::DriftX) + 2.0 < mean(DosClass::S, Feature::DriftX));
    assert!(mean(DosClass::E, Feature::DriftY) + 4.0 < mean(DosClass::W, Feature::DriftY));
    let t = mean(DosClass::T, Feature::DriftLevel);
    for c in DosClass::ALL.into_iter().filter(|&c| c != DosClass::T) {
        assert!(mean(c, Feature::DriftLevel) > t + 0.5, "{c}");
    }
    assert!(mean(DosClass::Cw, Feature::DriftSignedY) + 2.0 < mean(DosClass::Aw, Feature::DriftSignedY));
    for c in [DosClass::N, DosClass::E, DosClass::S, DosClass::W] {
        for r in [DosClass::Cw, DosClass::Aw] {
            assert!(mean(c, Feature::DriftAnisotropy) > mean(r, Feature::DriftAnisotropy) + 2.0, "{c} vs {r}");
        }
    }
}
