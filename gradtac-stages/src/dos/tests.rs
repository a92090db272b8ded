//! Tests of the `dos` module.

use super::window::LogVote;
use super::*;
use gradtac_stream::StageExt;

/// A deterministic pseudo-random source (64-bit LCG, top 53 bits).
struct Lcg(u64);
impl Lcg {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// A synthetic BioTac-like recording: per-taxel rest counts ~3500, an elliptical contact
/// (σ 4 × 2 mm, depth 1000 counts — pressing lowers counts) whose centre moves from
/// `c0` by `shift` mm and whose major axis turns from `phi0` by `turn` rad over the
/// recording, plus ±2 counts of noise.
fn recording(frames: usize, c0: [f64; 2], shift: [f64; 2], phi0: f64, turn: f64, seed: u64) -> Vec<TaxelFrame> {
    let layout = Layout::biotac_sp();
    let mut rng = Lcg(seed);
    let rest: Vec<f64> = (0..24).map(|i| 3400.0 + 10.0 * i as f64).collect();
    (0..frames)
        .map(|k| {
            let s = k as f64 / (frames - 1) as f64;
            let c = [c0[0] + s * shift[0], c0[1] + s * shift[1]];
            let phi = phi0 + s * turn;
            let (sn, cs) = phi.sin_cos();
            let values = layout
                .positions()
                .iter()
                .zip(&rest)
                .map(|(p, r)| {
                    let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
                    let (u, v) = (cs * dx + sn * dy, -sn * dx + cs * dy);
                    let depth = 1000.0 * (-(u * u) / (2.0 * 16.0) - (v * v) / (2.0 * 4.0)).exp();
                    (r - depth + 2.0 * (2.0 * rng.uniform() - 1.0)).round()
                })
                .collect();
            TaxelFrame::new("ff".into(), Timestamp::at_rate(k as u64, 100.0), k as u64, values)
        })
        .collect()
}

/// The synthetic motion of a class: translations of 8 mm along the class direction,
/// rotations of 60° in the class sense, no motion for touch.
fn synthetic(class: DosClass, c0: [f64; 2], phi0: f64, seed: u64) -> Vec<TaxelFrame> {
    let shift = class.direction().map_or([0.0; 2], |d| [8.0 * d[0], 8.0 * d[1]]);
    let turn = class.rotation_sense().map_or(0.0, |s| s * std::f64::consts::FRAC_PI_3);
    let start = [c0[0] - shift[0] / 2.0, c0[1] - shift[1] / 2.0];
    recording(200, start, shift, phi0, turn, seed)
}

fn features_of(frames: Vec<TaxelFrame>, cfg: &DosFeatureConfig) -> FeatureVector {
    let mut x = DosFeatureExtractor::try_new(cfg, &Layout::biotac_sp()).unwrap();
    for f in frames {
        x.push(f).unwrap();
    }
    x.features()
}

fn motion_config() -> DosFeatureConfig {
    DosFeatureConfig {
        features: vec![Feature::Rate, Feature::TrackDx, Feature::TrackDy, Feature::Rotation],
        ..Default::default()
    }
}

#[test]
fn synthetic_tracks_give_the_mapped_classes() {
    let cfg = motion_config();
    let mut train = Vec::new();
    for (i, c0) in [[-1.0, 0.0], [1.0, 0.5], [0.0, -0.5]].into_iter().enumerate() {
        for class in DosClass::ALL {
            let fv = features_of(synthetic(class, c0, 0.3 * i as f64, 10 + i as u64), &cfg);
            train.push((class, fv.select(&cfg.features)));
        }
    }
    let model = DosModel::calibrate(cfg.clone(), &train).unwrap();
    assert_eq!(model.parameter_count(), 2 * 7 * 4);
    // fresh recordings: other positions, orientations and noise
    for (c0, phi0, seed) in [([0.5, 0.0], 0.15, 99), ([-0.5, 0.3], 0.5, 7)] {
        for class in DosClass::ALL {
            let fv = features_of(synthetic(class, c0, phi0, seed), &cfg);
            let d = model.classify_vector(&fv).unwrap();
            assert_eq!(d.class, class, "{class} at {c0:?}: features {:?}, decision {d:?}", fv.select(&cfg.features));
            let s: f64 = d.posterior.iter().sum();
            assert!((s - 1.0).abs() < 1e-12);
        }
    }
}

#[test]
fn track_features_follow_the_contact() {
    let cfg = motion_config();
    let plus_x = features_of(synthetic(DosClass::N, [0.0, 0.0], 0.0, 1), &cfg);
    assert!(plus_x.get(Feature::TrackDx) > 2.0, "{plus_x:?}");
    assert!(plus_x.get(Feature::TrackDx).abs() > 3.0 * plus_x.get(Feature::TrackDy).abs(), "{plus_x:?}");
    let plus_y = features_of(synthetic(DosClass::E, [0.0, 0.0], 0.0, 2), &cfg);
    assert!(plus_y.get(Feature::TrackDy) > 2.0, "{plus_y:?}");
    let cw = features_of(synthetic(DosClass::Cw, [0.0, 0.0], 0.0, 3), &cfg);
    let aw = features_of(synthetic(DosClass::Aw, [0.0, 0.0], 0.0, 3), &cfg);
    assert!(cw.get(Feature::Rotation) > 0.2 && aw.get(Feature::Rotation) < -0.2, "{cw:?} {aw:?}");
    let still = features_of(synthetic(DosClass::T, [0.0, 0.0], 0.0, 4), &cfg);
    assert!(still.get(Feature::Rate) < 0.5 * plus_x.get(Feature::Rate), "{still:?} {plus_x:?}");
}

#[test]
fn calibrate_recovers_planted_parameters() {
    let cfg = DosFeatureConfig {
        features: vec![Feature::Rate, Feature::PositiveX, Feature::NegativeY],
        ..Default::default()
    };
    let sd = [0.5, 2.0, 0.1];
    let planted: Vec<[f64; 3]> = (0..7).map(|k| [k as f64, 10.0 - 3.0 * k as f64, 0.01 * (k * k) as f64]).collect();
    let mut rng = Lcg(42);
    let n = 2000;
    let mut samples = Vec::new();
    for (k, class) in DosClass::ALL.into_iter().enumerate() {
        for _ in 0..n {
            samples.push((class, (0..3).map(|j| planted[k][j] + sd[j] * rng.normal()).collect::<Vec<_>>()));
        }
    }
    let m = DosModel::calibrate(cfg, &samples).unwrap();
    assert_eq!(m.classes, DosClass::ALL.to_vec());
    assert_eq!(m.recordings, 7 * n);
    for (k, (fitted, truth)) in m.means.iter().zip(&planted).enumerate() {
        for (j, (a, b)) in fitted.iter().zip(truth).enumerate() {
            let tol = 5.0 * sd[j] / (n as f64).sqrt();
            assert!((a - b).abs() < tol, "mean {k},{j}: {a} vs {b}");
        }
    }
    for (j, (v, s)) in m.variances.iter().zip(sd).enumerate() {
        assert!((v / (s * s) - 1.0).abs() < 0.05, "variance {j}: {v} vs {}", s * s);
    }
    // the planted means are classified as their classes
    for (k, class) in DosClass::ALL.into_iter().enumerate() {
        assert_eq!(m.classify(&planted[k]).unwrap().class, class);
    }
}

/// One feature (`rate`), class n spread 1 around 0 (own variance 1), class s spread 3
/// around 10 (own variance 9).
fn two_classes() -> (DosFeatureConfig, Vec<(DosClass, Vec<f64>)>) {
    let cfg = DosFeatureConfig { features: vec![Feature::Rate], ..Default::default() };
    let samples =
        vec![(DosClass::N, vec![-1.0]), (DosClass::N, vec![1.0]), (DosClass::S, vec![7.0]), (DosClass::S, vec![13.0])];
    (cfg, samples)
}

#[test]
fn shrinkage_mixes_own_and_pooled_variances() {
    let (cfg, samples) = two_classes();
    // pooled: (2 + 18) / (4 − 2) = 10
    let pooled = DosModel::calibrate_with_shrinkage(cfg.clone(), &samples, 1.0).unwrap();
    assert_eq!(pooled.variances, [10.0]);
    assert!(pooled.class_variances.is_empty());
    assert_eq!(pooled.parameter_count(), 3);
    let own = DosModel::calibrate_with_shrinkage(cfg.clone(), &samples, 0.0).unwrap();
    assert_eq!(own.class_variances, [[1.0], [9.0]]);
    assert_eq!(DosModel::calibrate(cfg.clone(), &samples).unwrap(), own, "the default λ is 0");
    let half = DosModel::calibrate_with_shrinkage(cfg.clone(), &samples, 0.5).unwrap();
    assert_eq!(half.class_variances, [[5.5], [9.5]]);
    assert_eq!(half.parameter_count(), 4);
    // 3.5 is nearer n's mean, but s's wide spread claims it with its own variances.
    // Gaussian: pooled D = 1.225 vs 4.225; own D = 12.25 + 0 vs 4.69 + 2.20
    let (pooled_g, own_g) =
        (pooled.clone().with_student_t_dof(None).unwrap(), own.clone().with_student_t_dof(None).unwrap());
    assert_eq!(pooled_g.classify(&[3.5]).unwrap().class, DosClass::N);
    let d = own_g.classify(&[3.5]).unwrap();
    assert_eq!(d.class, DosClass::S);
    assert!((d.distances[0] - 12.25).abs() < 1e-12 && (d.distances[1] - (42.25 / 9.0 + 9f64.ln())).abs() < 1e-12);
    // Student t (ν = 3, d = 1, the calibrated default): D = ln σ² + (ν + d)·ln(1 + m/ν)
    assert_eq!(own.student_t_dof, Some(DosModel::DEFAULT_STUDENT_T_DOF));
    assert_eq!(pooled.classify(&[3.5]).unwrap().class, DosClass::N, "pooled: nearest mean either way");
    let d = own.classify(&[3.5]).unwrap();
    let (dn, ds) = (4.0 * (12.25f64 / 3.0).ln_1p(), 9f64.ln() + 4.0 * (42.25f64 / 27.0).ln_1p());
    assert!((d.distances[0] - dn).abs() < 1e-12 && (d.distances[1] - ds).abs() < 1e-12, "{d:?}");
    assert_eq!(d.class, DosClass::S);
    // far out, the t density costs logarithmically: at 100, n and s differ by less than
    // the Gaussian's quadratic gap
    let (t, g) = (own.classify(&[100.0]).unwrap(), own_g.classify(&[100.0]).unwrap());
    assert!((t.distances[0] - t.distances[1]).abs() < 10.0 && (g.distances[0] - g.distances[1]).abs() > 1000.0);
    assert!(own.clone().with_student_t_dof(Some(0.0)).is_err());
    assert!(own.clone().with_student_t_dof(Some(f64::INFINITY)).is_err());
    for bad in [-0.1, 1.1, f64::NAN] {
        assert!(DosModel::calibrate_with_shrinkage(cfg.clone(), &samples, bad).is_err(), "{bad}");
    }
    // a model file without class_variances (written by the pooled model) still loads
    let json = serde_json::to_string(&pooled).unwrap().replace(",\"class_variances\":[]", "");
    assert!(!json.contains("class_variances"), "{json}");
    assert_eq!(serde_json::from_str::<DosModel>(&json).unwrap(), pooled);
    // a model file without student_t_dof (written before it existed) decides as a Gaussian
    let json = serde_json::to_string(&own).unwrap().replace(",\"student_t_dof\":3.0", "");
    assert!(!json.contains("student_t_dof"), "{json}");
    assert_eq!(serde_json::from_str::<DosModel>(&json).unwrap(), own_g);
    let bad = serde_json::to_string(&own).unwrap().replace("\"student_t_dof\":3.0", "\"student_t_dof\":-1.0");
    assert!(serde_json::from_str::<DosModel>(&bad).unwrap_err().to_string().contains("student_t_dof"));
    // rows of the wrong shape or non-positive values are refused
    let json = serde_json::to_string(&half).unwrap();
    for bad in [json.replace("[[5.5],[9.5]]", "[[5.5]]"), json.replace("[[5.5],[9.5]]", "[[5.5],[0.0]]")] {
        let e = serde_json::from_str::<DosModel>(&bad).unwrap_err();
        assert!(e.to_string().contains("class_variances"), "{e}");
    }
}

#[test]
fn model_round_trips_and_bad_files_are_refused() {
    let cfg = DosFeatureConfig { features: vec![Feature::TrackDx, Feature::Rotation], ..Default::default() };
    let samples = vec![(DosClass::N, vec![1.0, 0.0]), (DosClass::N, vec![2.0, 0.1]), (DosClass::Cw, vec![0.0, 1.0])];
    let m = DosModel::calibrate(cfg, &samples).unwrap();
    let json = serde_json::to_string(&m).unwrap();
    let back: DosModel = serde_json::from_str(&json).unwrap();
    assert_eq!(back, m);
    assert!(json.contains("\"track_dx\"") && json.contains("\"cw\""), "{json}");
    let bad = json.replace("\"variances\":[", "\"variances\":[0.0,");
    let e = serde_json::from_str::<DosModel>(&bad).unwrap_err();
    assert!(e.to_string().contains("variances"), "{e}");
    let unknown = json.replace("\"recordings\"", "\"colour\":1,\"recordings\"");
    assert!(serde_json::from_str::<DosModel>(&unknown).is_err());
    // classify checks its input
    assert!(m.classify(&[1.0]).is_err());
    assert!(m.classify(&[1.0, f64::NAN]).is_err());
}

#[test]
fn invalid_input_is_refused() {
    let ok = DosFeatureConfig::default();
    let l = Layout::biotac_sp();
    for bad in [
        DosFeatureConfig { threshold: 0.0, ..ok.clone() },
        DosFeatureConfig { threshold: f64::NAN, ..ok.clone() },
        DosFeatureConfig { track_window_frames: 1, ..ok.clone() },
        DosFeatureConfig { grid_nx: 2, ..ok.clone() },
        DosFeatureConfig { min_area_mm2: -1.0, ..ok.clone() },
        DosFeatureConfig { features: vec![], ..ok.clone() },
        DosFeatureConfig { features: vec![Feature::Rate, Feature::Rate], ..ok.clone() },
        DosFeatureConfig { drift_lags: vec![], ..ok.clone() },
        DosFeatureConfig { drift_lags: vec![0], ..ok.clone() },
        DosFeatureConfig { drift_lags: vec![30, 30], ..ok.clone() },
    ] {
        let e = DosFeatureExtractor::try_new(&bad, &l).unwrap_err().to_string();
        assert!(e.contains("dos"), "{bad:?}: {e}");
    }
    let e = DosFeatureConfig { drift_lags: vec![0], ..ok.clone() }.validate().unwrap_err().to_string();
    assert!(e.contains("drift_lags") && e.contains("lag 0"), "{e}");
    // calibration: one class, too few samples, wrong length, non-finite
    let d = ok.features.len();
    let one = vec![(DosClass::N, vec![0.0; d]), (DosClass::N, vec![1.0; d])];
    assert!(DosModel::calibrate(ok.clone(), &one).unwrap_err().to_string().contains("two classes"));
    let few = vec![(DosClass::N, vec![0.0; d]), (DosClass::S, vec![1.0; d])];
    assert!(DosModel::calibrate(ok.clone(), &few).unwrap_err().to_string().contains("2 samples for 2 classes"));
    let short = vec![(DosClass::N, vec![0.0; d - 1]), (DosClass::S, vec![1.0; d]), (DosClass::S, vec![2.0; d])];
    assert!(DosModel::calibrate(ok.clone(), &short).unwrap_err().to_string().contains("sample 0"));
    let nan = vec![(DosClass::N, vec![0.0; d]), (DosClass::S, vec![1.0; d]), (DosClass::S, vec![f64::NAN; d])];
    assert!(DosModel::calibrate(ok.clone(), &nan).unwrap_err().to_string().contains("sample 2"));
    // frames: wrong taxel count and non-finite values name the frame
    let mut x = DosFeatureExtractor::try_new(&ok, &l).unwrap();
    let e = x.push(TaxelFrame::new("ff".into(), Timestamp(0), 3, vec![1.0; 23])).unwrap_err();
    assert!(e.to_string().contains("frame 3"), "{e}");
    let mut v = vec![3000.0; 24];
    v[5] = f64::INFINITY;
    let e = x.push(TaxelFrame::new("ff".into(), Timestamp(0), 4, v)).unwrap_err();
    assert!(e.to_string().contains("frame 4") && e.to_string().contains("taxel 5"), "{e}");
}

#[test]
fn early_decisions_cover_everything_since_contact_until_the_window_fills() {
    let (cfg, model) = motion_model();
    let l = Layout::biotac_sp();
    let input = synthetic(DosClass::N, [0.0, 0.0], 0.1, 5);
    let (n, hop) = (80usize, 16u64);
    let mut early = DosClassifier::try_new(model.clone(), &l, Some(n as u64)).unwrap().with_hop(hop).unwrap();
    early = early.with_early_decisions().unwrap();
    let out = early.run_all(input.clone()).unwrap();
    // every 16 frames from the first hop: 15, 31, …, 191, then finish at 199
    let ends: Vec<u64> = out.iter().map(|d| d.seq).collect();
    let want: Vec<u64> = (1..=12).map(|k| 16 * k - 1).chain([199]).collect();
    assert_eq!(ends, want);
    for d in &out {
        let last = d.seq as usize;
        let first = (last + 1).saturating_sub(n);
        assert_eq!(d.frames as usize, last + 1 - first);
        assert_eq!(d.features, features_of(input[first..=last].to_vec(), &cfg), "window ending at {last}");
    }
    // once the window is full, the same decisions as the plain sliding mode
    let plain = DosClassifier::try_new(model.clone(), &l, Some(n as u64)).unwrap().with_hop(hop).unwrap();
    let plain = {
        let mut p = plain;
        p.run_all(input.clone()).unwrap()
    };
    for d in plain.iter().filter(|d| d.seq >= 95) {
        assert!(out.contains(d), "{}", d.seq);
    }
    // early decisions need the sliding mode
    assert!(DosClassifier::try_new(model, &l, Some(80)).unwrap().with_early_decisions().is_err());
}

#[test]
fn sliding_decisions_are_fresh_recordings_of_their_window() {
    let (cfg, model) = motion_model();
    let l = Layout::biotac_sp();
    let input = synthetic(DosClass::N, [0.0, 0.0], 0.1, 5);
    let (n, hop) = (80usize, 16u64);
    let mut sliding = DosClassifier::try_new(model.clone(), &l, Some(n as u64)).unwrap().with_hop(hop).unwrap();
    assert_eq!(sliding.hop(), Some(hop));
    let out = sliding.run_all(input.clone()).unwrap();
    // the first decision once n frames are in (frame 79), then every 16 frames: 79, 95, …,
    // 191; frames 192..199 came after the last one, so finish decides once more, at 199
    let ends: Vec<u64> = out.iter().map(|d| d.seq).collect();
    assert_eq!(ends, [79, 95, 111, 127, 143, 159, 175, 191, 199]);
    // each decision is what a fresh extractor and the model make of that window alone
    for d in &out {
        let last = d.seq as usize;
        let window = &input[last + 1 - n..=last];
        let fresh = features_of(window.to_vec(), &cfg);
        assert_eq!(d.features, fresh, "window ending at {last}");
        assert_eq!(d.decision, model.classify_vector(&fresh).unwrap());
        assert_eq!((d.frames, d.start, d.end), (n as u64, window[0].time, window[n - 1].time));
    }
    // any chunking gives the same decisions
    for cut in [1, 7, 80, 199] {
        let mut s = DosClassifier::try_new(model.clone(), &l, Some(n as u64)).unwrap().with_hop(hop).unwrap();
        let mut got = Vec::new();
        for chunk in input.chunks(cut) {
            for f in chunk {
                s.push(f.clone(), &mut got).unwrap();
            }
        }
        s.finish(&mut got).unwrap();
        assert_eq!(got, out, "chunks of {cut}");
    }
    // a stream shorter than the window: one decision over what there is, at finish
    let mut short = DosClassifier::try_new(model.clone(), &l, Some(n as u64)).unwrap().with_hop(hop).unwrap();
    let got = short.run_all(input[..30].to_vec()).unwrap();
    assert_eq!(got.len(), 1);
    assert_eq!(got[0].features, features_of(input[..30].to_vec(), &cfg));
    // reset forgets the window; bad settings and bad frames are refused
    let mut s = DosClassifier::try_new(model.clone(), &l, Some(n as u64)).unwrap().with_hop(hop).unwrap();
    let mut got = Vec::new();
    for f in &input[..50] {
        s.push(f.clone(), &mut got).unwrap();
    }
    s.reset();
    s.finish(&mut got).unwrap();
    assert!(got.is_empty());
    assert!(DosClassifier::try_new(model.clone(), &l, None).unwrap().with_hop(5).is_err());
    assert!(DosClassifier::try_new(model.clone(), &l, Some(10)).unwrap().with_hop(0).is_err());
    let mut bad = input[3].clone();
    bad.values[2] = f64::NAN;
    let e = s.push(bad, &mut got).unwrap_err().to_string();
    assert!(e.contains("taxel 2"), "{e}");
}

#[test]
fn decisions_stay_defined_for_features_near_the_largest_floats() {
    let (cfg, samples) = two_classes();
    let own_t = DosModel::calibrate_with_shrinkage(cfg, &samples, 0.0).unwrap();
    let own_g = own_t.clone().with_student_t_dof(None).unwrap();
    for model in [&own_t, &own_g] {
        for f in [1e300, -1e300, f64::MAX, f64::MIN, 1e154] {
            let d = model.classify(&[f]).unwrap();
            assert!(d.posterior.iter().all(|p| p.is_finite() && *p >= 0.0), "{f}: {d:?}");
            assert!((d.posterior.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{f}: {d:?}");
            assert!(d.distances.iter().all(|x| !x.is_nan()), "{f}: {d:?}");
            // far from both means, the wider class (s, variance 9 against 1) is the likelier
            assert_eq!(d.class, DosClass::S, "{f} {:?}", model.student_t_dof);
        }
        if model.student_t_dof.is_some() {
            assert!(model.classify(&[f64::MAX]).unwrap().distances.iter().all(|x| x.is_finite()));
        }
    }
    // the overflow-free log agrees with the direct sum where both work
    let (m, f, v): ([f64; 2], [f64; 2], [f64; 2]) = ([0.5, -3.0], [2.0, 4.0], [0.3, 7.0]);
    let direct: f64 = (0..2).map(|j| (f[j] - m[j]).powi(2) / v[j]).sum::<f64>().ln();
    assert!((ln_mahalanobis(&m, &f, &v) - direct).abs() < 1e-14);
    assert_eq!(ln_mahalanobis(&m, &m, &v), f64::NEG_INFINITY);
}

#[test]
fn model_files_keep_every_bit() {
    // awkward values: a JSON parser without correct rounding is off by an ulp on some of them
    let mut x = 0.1f64;
    let samples: Vec<(DosClass, Vec<f64>)> = (0..40)
        .map(|k| {
            x = (x * 3.7 + 0.123_456_789).fract() + 1e-17 * k as f64;
            (DosClass::ALL[k % 3], vec![x * 1e-3, x.sqrt() * 7.0, (x + 1.0).ln() / 3.0])
        })
        .collect();
    let cfg =
        DosFeatureConfig { features: vec![Feature::Rate, Feature::DriftX, Feature::DriftY], ..Default::default() };
    let model = DosModel::calibrate(cfg, &samples).unwrap();
    let back: DosModel = serde_json::from_str(&serde_json::to_string_pretty(&model).unwrap()).unwrap();
    let bits = |m: &DosModel| -> Vec<u64> {
        m.means.iter().chain(&m.class_variances).flatten().chain(&m.variances).map(|v| v.to_bits()).collect()
    };
    assert_eq!(bits(&back), bits(&model));
    assert_eq!(back, model);
}

#[test]
fn cross_validation_holds_each_group_out() {
    let cfg = DosFeatureConfig { features: vec![Feature::Rate], ..Default::default() };
    let span = |class: DosClass, group: &str, v: f64| {
        let mut all = [f64::NAN; 18];
        all[Feature::Rate.index()] = v;
        LabelledSpan { class, group: group.into(), features: FeatureVector { all, frames: 1, events: 0 } }
    };
    // n near 0, s near 10, three groups; group "c" holds one s recording that looks like n
    let mut spans = Vec::new();
    for (g, shift) in [("a", 0.0), ("b", 0.3), ("c", -0.2)] {
        spans.push(span(DosClass::N, g, shift));
        spans.push(span(DosClass::N, g, 1.0 + shift));
        spans.push(span(DosClass::S, g, 10.0 + shift));
        spans.push(span(DosClass::S, g, 11.0 + shift));
    }
    spans.push(span(DosClass::S, "c", 0.5));
    let cv = cross_validate(&cfg, &spans, &|_| 0.5, Some(3.0)).unwrap();
    assert_eq!(cv.folds, [("a".into(), 4, 4), ("b".into(), 4, 4), ("c".into(), 4, 5)]);
    assert_eq!(cv.confusion[0][0], 6);
    assert_eq!(cv.confusion[2][0], 1, "the odd s is decided n");
    assert!((cv.accuracy() - 12.0 / 13.0).abs() < 1e-15);
    assert_eq!(cv.recall(DosClass::N), Some(1.0));
    assert_eq!(cv.recall(DosClass::T), None);
    let text = cv.to_string();
    assert!(text.contains("92.3 % (12/13)") && text.contains("| c | 4 | 5 | 80.0 % |"), "{text}");
    // one group: refused; a fold left with one class: refused, naming the fold
    let one: Vec<LabelledSpan> = spans.iter().filter(|s| s.group == "a").cloned().collect();
    assert!(cross_validate(&cfg, &one, &|_| 0.5, None).unwrap_err().to_string().contains("two groups"));
    let lopsided = vec![span(DosClass::N, "a", 0.0), span(DosClass::N, "a", 1.0), span(DosClass::S, "b", 9.0)];
    let e = cross_validate(&cfg, &lopsided, &|_| 0.5, None).unwrap_err().to_string();
    assert!(e.contains("fold without \"a\": calibration needs at least two classes"), "{e}");
    assert_eq!(e.matches("invalid configuration").count(), 1, "{e}");
}

#[test]
fn only_the_parts_the_features_need_are_built() {
    let l = Layout::biotac_sp();
    let run = |features: Vec<Feature>, centroid: CentroidMethod| {
        let cfg = DosFeatureConfig { features, centroid, ..Default::default() };
        let mut x = DosFeatureExtractor::try_new(&cfg, &l).unwrap();
        for k in 0..200u64 {
            let v = (0..24).map(|i| 3000.0 + 40.0 * ((k as f64 / 20.0) + i as f64).sin()).collect();
            x.push(TaxelFrame::new("ff".into(), Timestamp::at_rate(k, 100.0), k, v)).unwrap();
        }
        (x.window.is_some(), x.drift.is_some(), x.spatial.is_some(), x.features())
    };
    let (track, drift, spatial, fv) = run(Feature::DEFAULT.to_vec(), CentroidMethod::Taxels);
    assert!(!track && drift && !spatial);
    assert!(fv.get(Feature::TrackDx).is_nan() && fv.get(Feature::Rotation).is_nan());
    assert!(fv.select(&Feature::DEFAULT).iter().all(|v| v.is_finite()) && fv.get(Feature::Rate).is_finite());
    let (track, drift, spatial, fv) = run(vec![Feature::Rate, Feature::Rotation], CentroidMethod::Surface);
    assert!(track && !drift && spatial);
    assert!(fv.get(Feature::Rotation).is_finite() && fv.get(Feature::DriftLevel).is_nan());
    let (.., all) = run(Feature::ALL.to_vec(), CentroidMethod::Taxels);
    assert!(all.is_complete());
    // what is computed does not depend on what else is: the default's values are the same
    for f in Feature::DEFAULT {
        assert_eq!(all.get(f).to_bits(), run(Feature::DEFAULT.to_vec(), CentroidMethod::Taxels).3.get(f).to_bits());
    }
    assert_eq!(fv, fv, "NaN features compare equal bit for bit");
}

#[test]
fn features_are_finite_at_the_extremes() {
    let l = Layout::biotac_sp();
    for centroid in [CentroidMethod::Taxels, CentroidMethod::Surface, CentroidMethod::MaxContour] {
        let cfg = DosFeatureConfig { centroid, features: Feature::ALL.to_vec(), ..Default::default() };
        type Signal = Box<dyn Fn(usize, usize) -> f64>;
        let cases: Vec<(&str, Signal)> = vec![
            ("constant", Box::new(|_, _| 3000.0)),
            ("zero", Box::new(|_, _| 0.0)),
            ("negative", Box::new(|k, i| -((k + i) as f64))),
            ("huge", Box::new(|k, i| 1e300 * (1.0 + ((k * 7 + i) % 5) as f64))),
            ("tiny", Box::new(|k, i| 1e-300 * (1.0 + ((k * 3 + i) % 4) as f64))),
            ("saturating", Box::new(|k, i| if (k / 10 + i) % 2 == 0 { 4095.0 } else { 1.0 })),
        ];
        for (name, f) in cases {
            let mut x = DosFeatureExtractor::try_new(&cfg, &l).unwrap();
            assert!(x.features().all.iter().all(|v| v.is_finite()), "{name}: empty span");
            for k in 0..60 {
                let v = (0..24).map(|i| f(k, i)).collect();
                x.push(TaxelFrame::new("ff".into(), Timestamp::at_rate(k as u64, 100.0), k as u64, v)).unwrap();
            }
            let fv = x.features();
            assert!(fv.all.iter().all(|v| v.is_finite()), "{name} {centroid:?}: {fv:?}");
            if name == "constant" {
                assert_eq!(fv.events, 0);
                assert_eq!(fv.get(Feature::Rate), 0.0);
                assert_eq!(fv.get(Feature::PositiveFraction), 0.5);
                assert_eq!([fv.get(Feature::PositiveX), fv.get(Feature::PositiveY)], l.extent().centre());
            }
        }
    }
}

/// A model of the motion features calibrated on synthetic recordings of every class.
fn motion_model() -> (DosFeatureConfig, DosModel) {
    let cfg = motion_config();
    let mut train = Vec::new();
    for (i, c0) in [[-1.0, 0.0], [1.0, 0.5]].into_iter().enumerate() {
        for class in DosClass::ALL {
            train.push((class, features_of(synthetic(class, c0, 0.2, 20 + i as u64), &cfg).select(&cfg.features)));
        }
    }
    let model = DosModel::calibrate(cfg.clone(), &train).unwrap();
    (cfg, model)
}

#[test]
fn stage_decides_per_span_and_chunking_does_not_matter() {
    let (_, model) = motion_model();
    let l = Layout::biotac_sp();
    let input = synthetic(DosClass::N, [0.0, 0.0], 0.1, 5);
    // one decision for the whole recording at finish
    let mut whole = DosClassifier::try_new(model.clone(), &l, None).unwrap();
    let out = whole.run_all(input.clone()).unwrap();
    assert_eq!(out.len(), 1);
    assert_eq!(out[0].decision.class, DosClass::N);
    assert_eq!((out[0].frames, out[0].seq, out[0].start, out[0].end), (200, 199, input[0].time, input[199].time));
    // tumbling spans of 64 frames: 3 full spans and a remainder at finish
    let mut spans = DosClassifier::try_new(model.clone(), &l, Some(64)).unwrap();
    let all = spans.run_all(input.clone()).unwrap();
    assert_eq!(all.iter().map(|d| d.frames).collect::<Vec<_>>(), [64, 64, 64, 8]);
    for cut in [1, 5, 63, 64, 65, 199] {
        let mut s = DosClassifier::try_new(model.clone(), &l, Some(64)).unwrap();
        let mut out = crate::test_util::push_in_chunks(&input, cut, |f, part| s.push(f.clone(), part));
        s.finish(&mut out).unwrap();
        assert_eq!(out, all, "chunks of {cut}");
    }
    // reset drops the open span
    let mut s = DosClassifier::try_new(model.clone(), &l, None).unwrap();
    let mut out = Vec::new();
    for f in input.iter().take(50) {
        s.push(f.clone(), &mut out).unwrap();
    }
    s.reset();
    s.finish(&mut out).unwrap();
    assert!(out.is_empty());
    assert!(DosClassifier::try_new(model, &l, Some(0)).is_err());
}

#[test]
fn class_names_and_directions() {
    for c in DosClass::ALL {
        assert_eq!(c.as_str().parse::<DosClass>().unwrap(), c);
        assert_eq!(c.to_string(), c.as_str());
        if let Some(d) = c.direction() {
            assert_eq!(DosClass::from_direction(d), Some(c));
            assert_eq!(DosClass::from_direction([3.0 * d[0] + 0.5 * d[1], 3.0 * d[1] - 0.5 * d[0]]), Some(c));
        }
    }
    assert_eq!(DosClass::from_direction([0.0, 0.0]), None);
    assert_eq!(DosClass::from_direction([f64::NAN, 1.0]), None);
    assert!("north".parse::<DosClass>().is_err());
    assert_eq!(serde_json::to_string(&DosClass::Aw).unwrap(), "\"aw\"");
    assert_eq!(wrap_half_pi(3.0), 3.0 - std::f64::consts::PI);
    assert_eq!(wrap_half_pi(-0.25), -0.25);
}

/// Frames of [`recording`] / [`synthetic`] as plain value rows, for the learned model's tests.
pub(super) mod support {
    use super::*;
    /// [`recording`]'s values.
    pub fn recording_values(
        frames: usize,
        c0: [f64; 2],
        shift: [f64; 2],
        phi0: f64,
        turn: f64,
        seed: u64,
    ) -> Vec<Vec<f64>> {
        recording(frames, c0, shift, phi0, turn, seed).into_iter().map(|f| f.values).collect()
    }
    /// [`synthetic`]'s values.
    pub fn synthetic_values(class: DosClass, c0: [f64; 2], phi0: f64, seed: u64) -> Vec<Vec<f64>> {
        synthetic(class, c0, phi0, seed).into_iter().map(|f| f.values).collect()
    }
}

/// A hand-made window net over all seven classes (no trainer needed).
fn tiny_window_net() -> DosWindowNet {
    tiny_window_net_of(WindowInputs::Levels)
}

/// [`tiny_window_net`] on `inputs` (reference of 7 frames: the first net window's reference is
/// partial, the second's complete).
fn tiny_window_net_of(inputs: WindowInputs) -> DosWindowNet {
    tiny_window_net_with(inputs, false)
}

/// [`tiny_window_net_of`], with the motion inputs when `motion`.
fn tiny_window_net_with(inputs: WindowInputs, motion: bool) -> DosWindowNet {
    let config = WindowNetConfig { frames: 5, hidden: 2, inputs, reference_frames: 7, motion };
    let d = config.inputs(24);
    DosWindowNet {
        config,
        taxels: 24,
        classes: DosClass::ALL.to_vec(),
        input_mean: vec![0.0; d],
        input_scale: vec![1.0; d],
        w1: vec![
            (0..d).map(|j| if j < 24 { 0.1 * (j as f64 - 11.5) } else { 0.0 }).collect(),
            (0..d).map(|j| if j < 48 { 0.01 } else { 0.05 * ((j % 24) as f64 - 11.5) }).collect(),
        ],
        b1: vec![0.0, 0.1],
        w2: (0..7).map(|k| vec![0.3 * k as f64 - 1.0, 0.2]).collect(),
        b2: (0..7).map(|k| 0.05 * k as f64).collect(),
        recordings: 14,
    }
}

#[test]
fn a_model_file_without_a_window_part_reads_writes_and_decides_as_before() {
    let (cfg, model) = motion_model();
    assert!(model.window.is_none());
    let json = serde_json::to_string(&model).unwrap();
    // the file format of a model without a window part is unchanged: no `window` key
    assert!(!json.contains("\"window\""), "{json}");
    let back: DosModel = serde_json::from_str(&json).unwrap();
    assert_eq!(back, model);
    assert_eq!(back.parameter_count(), model.parameter_count());
    let l = Layout::biotac_sp();
    for class in [DosClass::N, DosClass::Cw, DosClass::T] {
        let input = synthetic(class, [0.0, 0.0], 0.1, 9);
        let whole = features_of(input.clone(), &cfg);
        let got = DosClassifier::try_new(back.clone(), &l, None).unwrap().run_all(input.clone()).unwrap();
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].decision, model.classify_vector(&whole).unwrap(), "{class}");
        // combining without a window part is the identity
        assert_eq!(model.combine(got[0].decision.clone(), Some(&[0.0; 7])), got[0].decision);
        let tumbling = DosClassifier::try_new(back.clone(), &l, Some(50)).unwrap().run_all(input.clone()).unwrap();
        let reference = DosClassifier::try_new(model.clone(), &l, Some(50)).unwrap().run_all(input).unwrap();
        assert_eq!(tumbling, reference);
    }
}

#[test]
fn a_window_part_round_trips_and_bad_ones_are_refused_by_field() {
    let (_, model) = motion_model();
    let m = model.clone().with_window(Some(DosWindowPart { weight: 0.75, net: tiny_window_net() })).unwrap();
    let json = serde_json::to_string_pretty(&m).unwrap();
    let back: DosModel = serde_json::from_str(&json).unwrap();
    assert_eq!(back, m);
    assert_eq!(m.parameter_count(), model.parameter_count() + tiny_window_net().parameter_count() + 1);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let broken = |f: &dyn Fn(&mut serde_json::Value)| {
        let mut w = v.clone();
        f(&mut w);
        serde_json::from_value::<DosModel>(w).unwrap_err().to_string()
    };
    for bad in [-0.1, 1.5] {
        let e = broken(&|w| w["window"]["weight"] = serde_json::json!(bad));
        assert!(e.contains("window.weight"), "{e}");
    }
    let e = broken(&|w| w["window"]["net"]["b1"] = serde_json::json!([0.0]));
    assert!(e.contains("window.net") && e.contains("b1"), "{e}");
    let e = broken(&|w| w["window"]["surprise"] = serde_json::json!(1));
    assert!(e.contains("surprise"), "{e}");
    let e = broken(&|w| w["window"].as_object_mut().unwrap().retain(|k, _| k != "weight"));
    assert!(e.contains("weight"), "{e}");
    assert!(model.clone().with_window(Some(DosWindowPart { weight: f64::NAN, net: tiny_window_net() })).is_err());
    // the taxel count must match the layout
    let three = Layout::try_new(
        "three",
        vec!["a".into(), "b".into(), "c".into()],
        vec![[0.0, 1.0], [1.0, 0.0], [2.0, 3.0]],
        None,
    )
    .unwrap();
    let mut small = model.clone();
    small.config.features = vec![Feature::Rate];
    small.means.iter_mut().for_each(|r| r.truncate(1));
    small.variances.truncate(1);
    small.class_variances.iter_mut().for_each(|r| r.truncate(1));
    let small = small.with_window(Some(DosWindowPart { weight: 0.5, net: tiny_window_net() })).unwrap();
    let e = DosClassifier::try_new(small, &three, None).unwrap_err().to_string();
    assert!(e.contains("window.net") && e.contains("24 taxels"), "{e}");
}

/// The vote's mean log posterior over `frames` (raw values), streamed from the first.
fn vote_over(net: &DosWindowNet, frames: &[TaxelFrame]) -> Option<Vec<f64>> {
    let mut v = net.vote(&Layout::biotac_sp()).unwrap();
    for f in frames {
        v.push(&f.values).unwrap();
    }
    v.mean_log_posterior()
}

#[test]
fn the_stage_decides_by_the_combined_score_over_the_frames_each_decision_covers() {
    for inputs in [WindowInputs::Levels, WindowInputs::SinceStart, WindowInputs::Both] {
        stage_decides_by_the_combined_score(tiny_window_net_of(inputs));
    }
    // the motion inputs need the span's reference as the pattern since the start does
    stage_decides_by_the_combined_score(tiny_window_net_with(WindowInputs::Levels, true));
}

/// The stage's decisions with `net` as its window part are the combination of the Student-t
/// decision and a fresh vote over the frames each decision covers (a net measured against the
/// span's start sees the covered frames' own start: the sliding replay gives each replayed net
/// window the reference it has in a fresh vote).
fn stage_decides_by_the_combined_score(net: DosWindowNet) {
    let (cfg, model) = motion_model();
    let l = Layout::biotac_sp();
    let input = synthetic(DosClass::E, [0.0, 0.0], 0.1, 11);
    for a in [0.0, 0.25, 0.75, 1.0] {
        let m = model.clone().with_window(Some(DosWindowPart { weight: a, net: net.clone() })).unwrap();
        // one decision per segment: the Student-t features and the vote over every frame
        let got = DosClassifier::try_new(m.clone(), &l, None).unwrap().run_all(input.clone()).unwrap();
        let student = model.classify_vector(&features_of(input.clone(), &cfg)).unwrap();
        let w = vote_over(&net, &input).unwrap();
        let want = m.combine(student.clone(), Some(&w));
        assert_eq!(got[0].decision, want, "a = {a}");
        let s = combined_scores(&m.classes, &student.posterior, &net.classes, &w, a);
        let best = (0..s.len()).fold(0, |b, k| if s[k] > s[b] { k } else { b });
        assert_eq!(want.class, m.classes[best]);
        if a == 1.0 {
            assert_eq!(want.class, student.class, "a = 1: the Student-t model alone");
        }
        // tumbling spans: each span's vote starts at the span
        let tumbling = DosClassifier::try_new(m.clone(), &l, Some(50)).unwrap().run_all(input.clone()).unwrap();
        let plain = DosClassifier::try_new(model.clone(), &l, Some(50)).unwrap().run_all(input.clone()).unwrap();
        assert_eq!(tumbling.len(), plain.len());
        for (k, (t, p)) in tumbling.iter().zip(&plain).enumerate() {
            let frames = &input[50 * k..(50 * k + t.frames as usize)];
            assert_eq!(t.features, p.features);
            assert_eq!(t.decision, m.combine(p.decision.clone(), vote_over(&net, frames).as_deref()), "span {k}");
        }
        // sliding: each decision replays its window through the vote as a fresh recording
        let (n, hop) = (80usize, 16u64);
        let sliding = DosClassifier::try_new(m.clone(), &l, Some(n as u64)).unwrap().with_hop(hop).unwrap();
        let out = { sliding }.run_all(input.clone()).unwrap();
        for d in &out {
            let last = d.seq as usize;
            let window = &input[last + 1 - n..=last];
            let student = model.classify_vector(&features_of(window.to_vec(), &cfg)).unwrap();
            assert_eq!(d.decision, m.combine(student, vote_over(&net, window).as_deref()), "window ending at {last}");
        }
        // early answers (every 7 frames: net windows of a decision start off the previous ones'
        // grid), and after a reset
        let mut early = DosClassifier::try_new(m.clone(), &l, Some(n as u64))
            .unwrap()
            .with_hop(7)
            .unwrap()
            .with_early_decisions()
            .unwrap();
        let mut out = Vec::new();
        for f in &input[..33] {
            early.push(f.clone(), &mut out).unwrap();
        }
        early.reset();
        out.clear();
        for f in &input[33..] {
            early.push(f.clone(), &mut out).unwrap();
        }
        early.finish(&mut out).unwrap();
        assert!(out.len() > 10);
        for d in &out {
            let last = d.seq as usize;
            let window = &input[(last + 1).saturating_sub(n).max(33)..=last];
            let student = model.classify_vector(&features_of(window.to_vec(), &cfg)).unwrap();
            assert_eq!(d.decision, m.combine(student, vote_over(&net, window).as_deref()), "early, ending at {last}");
        }
    }
    // fewer frames than one window: the Student-t decision
    let m = model.clone().with_window(Some(DosWindowPart { weight: 0.0, net })).unwrap();
    let got = DosClassifier::try_new(m, &l, None).unwrap().run_all(input[..4].to_vec()).unwrap();
    assert_eq!(got[0].decision, model.classify_vector(&features_of(input[..4].to_vec(), &cfg)).unwrap());
}

/// The sliding mode over `n` frames with hop `hop` (and early answers if `early`): the input up
/// to `cut` pushed, then `reset` (a gap), then the rest; the reset's frame index and the
/// decisions after it (never none).
fn slide_after_reset(
    m: &DosModel,
    l: &Layout,
    input: &[TaxelFrame],
    n: u64,
    hop: u64,
    early: bool,
    cut: Option<usize>,
) -> (usize, Vec<DosDecision>) {
    let mut s = DosClassifier::try_new(m.clone(), l, Some(n)).unwrap().with_hop(hop).unwrap();
    if early {
        s = s.with_early_decisions().unwrap();
    }
    let mut out = Vec::new();
    let from = cut.unwrap_or(0);
    for f in &input[..from] {
        s.push(f.clone(), &mut out).unwrap();
    }
    s.reset();
    out.clear();
    for f in &input[from..] {
        s.push(f.clone(), &mut out).unwrap();
    }
    s.finish(&mut out).unwrap();
    assert!(!out.is_empty());
    (from, out)
}

/// The sliding mode prepares each decision's replay (and a net measured against the window's
/// start) a share per frame ahead of it; a prediction missed (a reset, `finish`, a window not
/// yet full) replays from scratch. Every decision, for any window, hop, early answers, a reset
/// anywhere and any net, is what a fresh replay of its frames gives.
#[test]
fn sliding_decisions_prepared_ahead_are_fresh_replays_for_any_window_hop_and_reset() {
    let (cfg, model) = motion_model();
    let l = Layout::biotac_sp();
    let input = synthetic(DosClass::Cw, [0.0, 0.0], 0.1, 13);
    let nets = [
        None,
        Some(tiny_window_net_of(WindowInputs::Levels)),
        Some(tiny_window_net_with(WindowInputs::Levels, true)),
        Some(tiny_window_net_with(WindowInputs::Both, true)),
    ];
    for net in nets {
        let m = model.clone().with_window(net.clone().map(|net| DosWindowPart { weight: 0.5, net })).unwrap();
        for (n, hop) in [(1u64, 1u64), (5, 3), (13, 13), (40, 7), (80, 16), (80, 100), (300, 10)] {
            for early in [false, true] {
                for cut in [None, Some(1), Some(37), Some(120)] {
                    let (from, out) = slide_after_reset(&m, &l, &input, n, hop, early, cut);
                    for d in &out {
                        let last = d.seq as usize;
                        let window = &input[(last + 1).saturating_sub(n as usize).max(from)..=last];
                        let student = model.classify_vector(&features_of(window.to_vec(), &cfg)).unwrap();
                        let want = match &net {
                            Some(net) => m.combine(student, vote_over(net, window).as_deref()),
                            None => student,
                        };
                        assert_eq!(d.decision, want, "n {n}, hop {hop}, early {early}, cut {cut:?}, ending at {last}");
                        assert_eq!(d.frames as usize, window.len());
                    }
                }
            }
        }
    }
}

/// A hand-made tree model of every class: one stump per class on a different input (classes
/// 0–2 on the rotation-sense inputs' turns, [`TreeInputs::turn`]).
fn stump_trees(l: &Layout) -> DosTrees {
    let inputs = TreeInputs { turn: true, ..TreeInputs::default() };
    let d = inputs.inputs(l.len());
    let trees: Vec<Tree> = (0..7)
        .map(|c| Tree {
            feature: vec![if c < 3 { d - TURN_INPUTS * (3 - c) + 2 } else { (c * 13) % d }, 0, 0],
            threshold: vec![if c < 3 { 0.0 } else { 0.1 * c as f64 - 0.3 }, 0.0, 0.0],
            left: vec![1, 0, 0],
            right: vec![2, 0, 0],
            value: vec![0.0, -0.5 + 0.1 * c as f64, 0.4],
        })
        .collect();
    let p = l.positions();
    let mirror: Vec<usize> = p
        .iter()
        .map(|a| p.iter().position(|b| (a[0] - b[0]).abs() < 0.1 && (a[1] + b[1]).abs() < 0.1).unwrap())
        .collect();
    DosTrees::try_new(inputs, l.len(), DosClass::ALL.to_vec(), vec![0.0; 7], trees, Some(mirror), 0).unwrap()
}

#[test]
fn the_stage_runs_a_tree_part_and_chunking_does_not_matter() {
    let (cfg, model) = motion_model();
    let l = Layout::biotac_sp();
    let trees = stump_trees(&l);
    let model = model.with_trees(Some(DosTreesPart { weight: 0.5, trees: trees.clone() })).unwrap();
    let input = synthetic(DosClass::E, [0.0, 0.0], 0.1, 9);
    // one decision per segment: the Student-t decision combined with the trees' vote
    let out = DosClassifier::try_new(model.clone(), &l, None).unwrap().run_all(input.clone()).unwrap();
    assert_eq!(out.len(), 1);
    let mut vote = trees.vote(&l).unwrap();
    for f in &input {
        vote.push(&f.values).unwrap();
    }
    let student = model.classify_vector(&features_of(input.clone(), &cfg)).unwrap();
    let want = model.combine(student.clone(), vote.mean_log_posterior().as_deref());
    assert_eq!(out[0].decision, want);
    assert_ne!(want.posterior, student.posterior, "the tree part takes part");
    // tumbling spans: any chunking gives the same decisions; each span starts a fresh vote
    let mut spans = DosClassifier::try_new(model.clone(), &l, Some(64)).unwrap();
    let all = spans.run_all(input.clone()).unwrap();
    assert_eq!(all.len(), 4);
    for cut in [1, 5, 63, 64, 65, 199] {
        let mut s = DosClassifier::try_new(model.clone(), &l, Some(64)).unwrap();
        let mut out = crate::test_util::push_in_chunks(&input, cut, |f, part| s.push(f.clone(), part));
        s.finish(&mut out).unwrap();
        assert_eq!(out, all, "chunks of {cut}");
    }
    // the model file round-trips; a second part is refused
    let back: DosModel = serde_json::from_str(&serde_json::to_string(&model).unwrap()).unwrap();
    assert_eq!(back, model);
    let mut bad = serde_json::to_value(&model).unwrap();
    bad["trees"]["weight"] = serde_json::json!(1.5);
    assert!(serde_json::from_value::<DosModel>(bad).is_err());
    // a mirrored recording gets the mirrored class from the tree part alone (weight 0)
    let alone = model.clone().with_trees(Some(DosTreesPart { weight: 0.0, trees: trees.clone() })).unwrap();
    let perm = trees.mirror().unwrap().to_vec();
    let mirrored: Vec<TaxelFrame> = input
        .iter()
        .map(|f| TaxelFrame::new(f.sensor.clone(), f.time, f.seq, perm.iter().map(|&j| f.values[j]).collect()))
        .collect();
    // each tumbling span starts a fresh vote (the tree part alone: as a fresh run of the span)
    let spans = DosClassifier::try_new(alone.clone(), &l, Some(64)).unwrap().run_all(input.clone()).unwrap();
    let second = DosClassifier::try_new(alone.clone(), &l, None).unwrap().run_all(input[64..128].to_vec()).unwrap();
    assert_eq!(second[0].decision, spans[1].decision);
    let a = DosClassifier::try_new(alone.clone(), &l, None).unwrap().run_all(input).unwrap();
    let b = DosClassifier::try_new(alone, &l, None).unwrap().run_all(mirrored).unwrap();
    assert_eq!(b[0].decision.class, a[0].decision.class.mirrored());
}

/// Every tree window since `from` of `frames` (its first frame's index, its log posterior), as
/// a vote since `from` computes them.
fn tree_windows_since(trees: &DosTrees, frames: &[TaxelFrame], from: usize) -> Vec<(usize, Vec<f64>)> {
    let mut x = trees.extractor(&Layout::biotac_sp()).unwrap();
    let f = trees.inputs().window.frames;
    frames[from..]
        .iter()
        .enumerate()
        .filter_map(|(i, fr)| x.push(&fr.values).unwrap().map(|v| (from + i + 1 - f, trees.log_posterior(&v).unwrap())))
        .collect()
}

/// The sliding mode with a tree part: every decision, for any window, hop, early answers and a
/// reset anywhere, combines a fresh replay's Student-t decision over its frames with the mean log
/// posterior of the tree windows since the reset that lie inside its frames, each as a vote
/// since the reset computes it (kept across decisions, not replayed) — bit for bit. While the
/// frames start at the reset (early answers; a contact shorter than the window) that is a fresh
/// recording of them exactly; after that the windows keep the contact's history, and some
/// decisions differ from a fresh recording's (the stated approximation, not hidden).
#[test]
fn the_sliding_mode_runs_a_tree_part_over_the_windows_since_the_reset() {
    let (cfg, model) = motion_model();
    let l = Layout::biotac_sp();
    let trees = stump_trees(&l);
    let m = model.clone().with_trees(Some(DosTreesPart { weight: 0.5, trees: trees.clone() })).unwrap();
    let input = synthetic(DosClass::Cw, [0.0, 0.0], 0.1, 13);
    let f = trees.inputs().window.frames;
    let (mut fresh_checked, mut slid, mut differs) = (0, 0, 0);
    for (n, hop) in [(1u64, 1u64), (5, 3), (13, 13), (40, 7), (80, 16), (80, 100), (300, 10), (50, 10)] {
        for early in [false, true] {
            for cut in [None, Some(1), Some(37), Some(120)] {
                let (from, out) = slide_after_reset(&m, &l, &input, n, hop, early, cut);
                let since = tree_windows_since(&trees, &input, from);
                for d in &out {
                    let last = d.seq as usize;
                    let first = (last + 1).saturating_sub(n as usize).max(from);
                    let window = &input[first..=last];
                    let student = model.classify_vector(&features_of(window.to_vec(), &cfg)).unwrap();
                    let mut vote = LogVote::new(7);
                    for (_, lp) in since.iter().filter(|(at, _)| *at >= first && *at + f <= last + 1) {
                        vote.add(lp);
                    }
                    let want = m.combine(student, vote.mean_log_posterior().as_deref());
                    let at = format!("n {n}, hop {hop}, early {early}, cut {cut:?}, ending at {last}");
                    assert_eq!(d.decision, want, "{at}");
                    assert_eq!(d.frames as usize, window.len());
                    let fresh = DosClassifier::try_new(m.clone(), &l, None).unwrap().run_all(window.to_vec()).unwrap();
                    if first == from {
                        assert_eq!(d.decision, fresh[0].decision, "a fresh recording: {at}");
                        fresh_checked += 1;
                    } else if window.len() >= 3 * f {
                        slid += 1;
                        differs += usize::from(d.decision != fresh[0].decision);
                    }
                }
            }
        }
    }
    assert!(fresh_checked > 100 && slid > 100, "{fresh_checked} fresh, {slid} slid");
    assert!(differs > 0, "the windows' history since the reset changes some slid decisions");
}

/// The sliding mode with a tree part: chunking changes nothing; a non-finite frame is an
/// error that leaves the stage as it was; `reset` (a gap) starts afresh.
#[test]
fn the_sliding_tree_part_ignores_chunking_refuses_nan_and_restarts_on_a_gap() {
    let l = Layout::biotac_sp();
    let (_, model) = motion_model();
    let m = model.with_trees(Some(DosTreesPart { weight: 0.25, trees: stump_trees(&l) })).unwrap();
    let input = synthetic(DosClass::N, [0.0, 0.0], 0.1, 5);
    let stage = || DosClassifier::try_new(m.clone(), &l, Some(60)).unwrap().with_hop(10).unwrap();
    let all = stage().run_all(input.clone()).unwrap();
    assert!(all.len() > 10);
    for cut in [1, 4, 5, 9, 10, 11, 59, 61, 199] {
        let mut s = stage();
        let mut out = crate::test_util::push_in_chunks(&input, cut, |fr, part| s.push(fr.clone(), part));
        s.finish(&mut out).unwrap();
        assert_eq!(out, all, "chunks of {cut}");
    }
    // a NaN (or infinite) frame: an error, no panic, and the decisions as without it
    let mut s = stage();
    let mut out = Vec::new();
    for (i, fr) in input.iter().enumerate() {
        if i == 77 {
            for bad in [f64::NAN, f64::INFINITY] {
                let mut b = fr.clone();
                b.values[3] = bad;
                assert!(s.push(b, &mut out).is_err());
            }
        }
        s.push(fr.clone(), &mut out).unwrap();
    }
    s.finish(&mut out).unwrap();
    assert_eq!(out, all);
    // a reset after 90 frames: the decisions after it are a fresh stage's over the rest
    let mut s = stage();
    let mut out = Vec::new();
    for fr in &input[..90] {
        s.push(fr.clone(), &mut out).unwrap();
    }
    s.reset();
    out.clear();
    for fr in &input[90..] {
        s.push(fr.clone(), &mut out).unwrap();
    }
    s.finish(&mut out).unwrap();
    let fresh = stage().run_all(input[90..].to_vec()).unwrap();
    assert_eq!(out, fresh);
}
