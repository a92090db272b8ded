//! Tests of the learned model's inference ([`DosNet`], [`NetExtractor`]) and, with the `train`
//! feature, of its trainer.

use super::tests_support::{recording_values, synthetic_values};
use super::*;

fn input_of(frames: &[Vec<f64>], cfg: &NetConfig) -> Vec<f64> {
    let mut x = NetExtractor::try_new(cfg, &Layout::biotac_sp()).unwrap();
    for f in frames {
        x.push(f).unwrap();
    }
    x.input()
}

#[test]
fn representation_is_exactly_invariant_to_a_gain_and_offset_per_taxel() {
    let cfg = NetConfig::default();
    for class in DosClass::ALL {
        let frames = synthetic_values(class, [0.0, 0.0], 0.3, 7);
        let a = input_of(&frames, &cfg);
        assert_eq!(a.len(), cfg.inputs(24));
        // a power-of-two gain and an integer offset per taxel: every difference scales exactly
        let scaled: Vec<Vec<f64>> = frames
            .iter()
            .map(|f| {
                f.iter().enumerate().map(|(i, v)| v * [0.5, 2.0, 4.0][i % 3] + (i as f64 * 37.0 - 400.0)).collect()
            })
            .collect();
        let b = input_of(&scaled, &cfg);
        for (j, (x, y)) in a.iter().zip(&b).enumerate() {
            // the drift moments combine taxels with different gains only through ratios of
            // their own weights: exact as well
            assert_eq!(x.to_bits(), y.to_bits(), "{class} input {j}: {x} vs {y}");
        }
    }
}

#[test]
fn representation_is_finite_at_the_extremes() {
    let cfg = NetConfig::default();
    for scale in [0.0, -1.0, 1e-300, 1e300, f64::MAX / 2.0, -f64::MAX / 2.0] {
        let frames: Vec<Vec<f64>> =
            (0..80).map(|t| (0..24).map(|i| scale * (1.0 + ((t * 7 + i) % 5) as f64 * 0.1)).collect()).collect();
        let x = input_of(&frames, &cfg);
        assert!(x.iter().all(|v| v.is_finite()), "{scale}: {x:?}");
    }
    // empty and one-frame spans
    assert!(input_of(&[], &cfg).iter().all(|v| v.is_finite()));
    assert!(input_of(&[vec![3000.0; 24]], &cfg).iter().all(|v| *v == 0.0 || v.is_finite()));
}

#[test]
fn bad_input_and_settings_are_refused() {
    let layout = Layout::biotac_sp();
    assert!(NetExtractor::try_new(&NetConfig { lags: vec![], ..Default::default() }, &layout).is_err());
    assert!(NetExtractor::try_new(&NetConfig { hidden: 0, ..Default::default() }, &layout).is_err());
    assert!(NetExtractor::try_new(&NetConfig { hidden: MAX_HIDDEN + 1, ..Default::default() }, &layout).is_err());
    let mut x = NetExtractor::try_new(&NetConfig::default(), &layout).unwrap();
    assert!(x.push(&[1.0; 23]).is_err());
    let mut bad = vec![1.0; 24];
    bad[4] = f64::NAN;
    let e = x.push(&bad).unwrap_err().to_string();
    assert!(e.contains("taxel 5"), "{e}");
}

/// A hand-made net: two classes, the decision the sign of input 0.
fn tiny_net() -> DosNet {
    let cfg = NetConfig { lags: vec![30], hidden: 1 };
    let d = cfg.inputs(3);
    let mut w1 = vec![vec![0.0; d]];
    w1[0][0] = 1.0;
    DosNet {
        config: cfg,
        taxels: 3,
        classes: vec![DosClass::N, DosClass::S],
        input_mean: vec![0.0; d],
        input_scale: vec![1.0; d],
        w1,
        b1: vec![0.0],
        w2: vec![vec![5.0], vec![-5.0]],
        b2: vec![0.0, 0.0],
        recordings: 0,
    }
}

#[test]
fn decisions_follow_the_weights_and_stay_defined_at_the_extremes() {
    let net = tiny_net();
    let d = net.inputs();
    assert_eq!(net.parameter_count(), 2 * d + d + 1 + 2 + 2);
    let mut x = vec![0.0; d];
    x[0] = 1.0;
    assert_eq!(net.classify(&x).unwrap().class, DosClass::N);
    x[0] = -1.0;
    assert_eq!(net.classify(&x).unwrap().class, DosClass::S);
    for v in [f64::MAX, -f64::MAX, 1e-300] {
        x[0] = v;
        let dec = net.classify(&x).unwrap();
        assert!(dec.posterior.iter().all(|p| p.is_finite()) && dec.distances.iter().all(|p| p.is_finite()));
        assert!((dec.posterior.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }
    x[0] = f64::NAN;
    assert!(net.classify(&x).is_err());
    assert!(net.classify(&x[1..]).is_err());
}

#[test]
fn model_files_round_trip_and_bad_ones_are_refused() {
    let net = tiny_net();
    let json = serde_json::to_string(&net).unwrap();
    let back: DosNet = serde_json::from_str(&json).unwrap();
    assert_eq!(back, net);
    let mut bad = net.clone();
    bad.w1[0].pop();
    assert!(serde_json::from_str::<DosNet>(&serde_json::to_string(&bad).unwrap()).is_err());
    let mut bad = net.clone();
    bad.input_scale[2] = 0.0;
    assert!(bad.validate().is_err());
    let mut bad = net.clone();
    bad.classes = vec![DosClass::N, DosClass::N];
    assert!(bad.validate().is_err());
    let mut bad = net;
    bad.b2[1] = f64::INFINITY;
    assert!(bad.validate().is_err());
    assert!(tiny_net().extractor(&Layout::biotac_sp()).is_err(), "3-taxel model on a 24-taxel layout");
}

#[test]
fn synthetic_slips_have_distinct_representations() {
    let cfg = NetConfig::default();
    let n = input_of(&synthetic_values(DosClass::N, [0.0, 0.0], 0.0, 1), &cfg);
    let s = input_of(&synthetic_values(DosClass::S, [0.0, 0.0], 0.0, 1), &cfg);
    let t = input_of(&synthetic_values(DosClass::T, [0.0, 0.0], 0.0, 1), &cfg);
    // touch: little drift anywhere; n and s: opposite net changes at the same taxels
    let level = |x: &[f64]| x[cfg.inputs(24) - 7];
    assert!(level(&t) < level(&n) && level(&t) < level(&s));
    let z = |x: &[f64]| x[4 * 24..5 * 24].to_vec();
    let dot: f64 = z(&n).iter().zip(z(&s)).map(|(a, b)| a * b).sum();
    assert!(dot < 0.0, "n and s move the counts oppositely: {dot}");
    let _ = recording_values;
}

#[cfg(feature = "train")]
mod training {
    use super::super::train::*;
    use super::*;

    fn synthetic_set(seed: u64) -> Vec<TrainRecording> {
        let mut out = Vec::new();
        for (k, class) in DosClass::ALL.into_iter().enumerate() {
            for j in 0..4u64 {
                let c0 = [(j as f64 - 1.5) * 1.5, ((j * 7 + k as u64) % 3) as f64 - 1.0];
                let frames = synthetic_values(class, c0, 0.2 * j as f64, seed + 31 * j + k as u64);
                out.push(TrainRecording { class, group: format!("obj{}", j % 2), frames });
            }
        }
        out
    }

    #[test]
    fn the_layout_mirror_is_an_involution_and_matches_the_class_mirror() {
        let layout = Layout::biotac_sp();
        let p = mirror_permutation(&layout).unwrap();
        for (i, &pi) in p.iter().enumerate().take(10) {
            assert_eq!(pi, i + 10);
        }
        assert_eq!((p[20], p[21], p[22], p[23]), (20, 22, 21, 23));
        // mirrored e recording looks like a w recording
        let e = synthetic_values(DosClass::E, [0.0, 0.0], 0.0, 3);
        let w = synthetic_values(DosClass::W, [0.0, 0.0], 0.0, 3);
        let cfg = NetConfig::default();
        let (me, w) = (input_of(&permute(&e, &p), &cfg), input_of(&w, &cfg));
        let k = cfg.inputs(24) - 7;
        assert!((me[k + 2] - w[k + 2]).abs() < 0.5, "drift_y {} vs {}", me[k + 2], w[k + 2]);
        // an asymmetric layout has no mirror
        let skew = Layout::try_new(
            "skew",
            vec!["a".into(), "b".into(), "c".into()],
            vec![[0.0, 1.0], [1.0, 0.0], [2.0, 3.0]],
            None,
        )
        .unwrap();
        assert!(mirror_permutation(&skew).is_none());
    }

    #[test]
    fn augmentation_is_deterministic_finite_and_keeps_the_shape() {
        let frames = synthetic_values(DosClass::Cw, [0.0, 0.0], 0.0, 5);
        let layout = Layout::biotac_sp();
        let a = Augment { crop: 0.0, ..Default::default() };
        let one = augment(&frames, layout.positions(), &a, &mut SplitMix::new(9));
        let two = augment(&frames, layout.positions(), &a, &mut SplitMix::new(9));
        assert_eq!(one, two);
        assert!(one.iter().all(|f| f.len() == 24 && f.iter().all(|v| v.is_finite())));
        let ratio = one.len() as f64 / frames.len() as f64;
        assert!((1.0 / 1.31..=1.31).contains(&ratio), "{ratio}");
        // no randomness asked: only the smoothing / nothing
        let none =
            Augment { noise: 0.0, speed: 1.0, warp: 0.0, dropout: 0.0, rotation: 0.0, vibration: 0.0, crop: 0.0, ..a };
        let same = augment(&frames, layout.positions(), &none, &mut SplitMix::new(2));
        assert_eq!(same.len(), frames.len());
        assert!(Augment { speed: 0.5, ..Default::default() }.validate().is_err());
        assert!(Augment { copies: 5000, ..Default::default() }.validate().is_err());
    }

    #[test]
    fn training_separates_synthetic_slips_and_transfers_across_groups() {
        let recs = synthetic_set(11);
        let layout = Layout::biotac_sp();
        let cfg =
            TrainConfig { epochs: 150, augment: Augment { copies: 2, ..Default::default() }, ..Default::default() };
        let reps = represent_recordings(&recs, &layout, &cfg).unwrap();
        let all: Vec<usize> = (0..recs.len()).collect();
        let (ok, n) = leave_one_group_out(&recs, &reps, &all, 24, &cfg).unwrap();
        assert!(ok as f64 >= 0.8 * n as f64, "{ok}/{n}");
        // deterministic for a seed
        let (_, _, a) = fit_and_score(&reps, &all, &[], 24, &cfg).unwrap();
        let (_, _, b) = fit_and_score(&reps, &all, &[], 24, &cfg).unwrap();
        assert_eq!(a, b);
        // the trained model streams: the extractor's input over the recording decides as the batch did
        let mut x = a.extractor(&layout).unwrap();
        for f in &recs[0].frames {
            x.push(f).unwrap();
        }
        assert_eq!(a.classify(&x.input()).unwrap().class, a.classify(&reps[0][0].1).unwrap().class);
    }

    #[test]
    fn training_refuses_what_it_cannot_fit() {
        let cfg = TrainConfig::default();
        assert!(fit(&[(DosClass::N, vec![0.0; cfg.net.inputs(24)])], 24, &cfg).is_err());
        assert!(fit(&[(DosClass::N, vec![0.0; 3]), (DosClass::S, vec![0.0; 3])], 24, &cfg).is_err());
        assert!(TrainConfig { epochs: 0, ..Default::default() }.validate().is_err());
        assert!(TrainConfig { l2: -1.0, ..Default::default() }.validate().is_err());
    }
}
