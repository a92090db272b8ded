//! Tests of the window model's inference ([`DosWindowNet`], [`WindowExtractor`], [`WindowVote`])
//! and, with the `train` feature, of its trainer.

use super::tests_support::synthetic_values;
use super::*;

/// Synthetic frames rounded to integer counts (what the sensor gives).
fn counts(class: DosClass, seed: u64) -> Vec<Vec<f64>> {
    synthetic_values(class, [0.0, 0.0], 0.3, seed).into_iter().map(|f| f.iter().map(|v| v.round()).collect()).collect()
}

fn inputs(frames: &[Vec<f64>], cfg: &WindowNetConfig) -> Vec<Vec<f64>> {
    let layout = Layout::biotac_sp();
    let mut x = if frames[0].len() == layout.len() {
        WindowExtractor::try_new_on(cfg, &layout).unwrap()
    } else {
        WindowExtractor::try_new(cfg, frames[0].len()).unwrap()
    };
    let mut out = Vec::new();
    for f in frames {
        if x.push(f).unwrap() {
            out.push(x.input().unwrap());
        }
    }
    out
}

#[test]
fn window_input_is_exactly_invariant_to_a_common_integer_offset_and_power_of_two_gain() {
    let cfg = WindowNetConfig::default();
    for class in DosClass::ALL {
        let frames = counts(class, 7);
        let a = inputs(&frames, &cfg);
        assert_eq!(a.len(), frames.len() / 5);
        for (gain, offset) in [(2.0, 0.0), (0.5, 0.0), (1.0, 1234.0), (4.0, -3000.0), (0.25, 77.0)] {
            let moved: Vec<Vec<f64>> = frames.iter().map(|f| f.iter().map(|v| v * gain + offset).collect()).collect();
            let b = inputs(&moved, &cfg);
            for (w, (x, y)) in a.iter().zip(&b).enumerate() {
                for (j, (u, v)) in x.iter().zip(y).enumerate() {
                    assert_eq!(u.to_bits(), v.to_bits(), "{class} ×{gain} +{offset} window {w} input {j}: {u} vs {v}");
                }
            }
        }
    }
}

#[test]
fn window_input_permutes_exactly_with_the_taxels() {
    let cfg = WindowNetConfig::default();
    let frames = counts(DosClass::Cw, 3);
    let p: Vec<usize> = (0..24).map(|i| (i * 7 + 5) % 24).collect();
    let permuted: Vec<Vec<f64>> = frames.iter().map(|f| p.iter().map(|&j| f[j]).collect()).collect();
    for (x, y) in inputs(&frames, &cfg).iter().zip(inputs(&permuted, &cfg)) {
        for (i, &j) in p.iter().enumerate() {
            assert_eq!(y[i].to_bits(), x[j].to_bits());
            assert_eq!(y[24 + i].to_bits(), x[24 + j].to_bits());
        }
    }
}

#[test]
fn window_input_is_finite_and_defined_at_the_extremes() {
    let cfg = WindowNetConfig::default();
    let mut x = WindowExtractor::try_new(&cfg, 24).unwrap();
    assert!(x.input().is_none());
    for k in 0..4 {
        assert!(!x.push(&[3000.0; 24]).unwrap(), "frame {k}");
        assert!(x.input().is_none());
    }
    assert!(x.push(&[3000.0; 24]).unwrap());
    // all taxels at one level: no pattern
    assert!(x.input().unwrap().iter().all(|v| *v == 0.0));
    for scale in [0.0, -1.0, 1e-300, 1e300, f64::MAX, -f64::MAX, f64::MIN_POSITIVE] {
        x.reset();
        for t in 0..5 {
            let f: Vec<f64> = (0..24).map(|i| scale * (1.0 - ((t * 7 + i) % 5) as f64 * 0.1)).collect();
            x.push(&f).unwrap();
        }
        let v = x.input().unwrap();
        assert!(v.iter().all(|v| v.is_finite()), "{scale}: {v:?}");
    }
    assert!(x.push(&[1.0; 23]).is_err());
    let mut bad = vec![1.0; 24];
    bad[4] = f64::NAN;
    let e = x.push(&bad).unwrap_err().to_string();
    assert!(e.contains("taxel 5"), "{e}");
    assert!(WindowExtractor::try_new(&WindowNetConfig { frames: 1, ..Default::default() }, 24).is_err());
    assert!(WindowExtractor::try_new(&WindowNetConfig { hidden: 0, ..Default::default() }, 24).is_err());
    assert!(
        WindowExtractor::try_new(&WindowNetConfig { frames: MAX_WINDOW_FRAMES + 1, ..Default::default() }, 24).is_err()
    );
    assert!(WindowExtractor::try_new(&cfg, 0).is_err());
}

#[test]
fn the_since_start_pattern_ignores_an_offset_per_taxel_and_levels_inputs_are_as_before() {
    let frames = counts(DosClass::Aw, 5);
    let levels = inputs(&frames, &WindowNetConfig::default());
    for reference_frames in [1, 10, 40] {
        let both = WindowNetConfig { inputs: WindowInputs::Both, reference_frames, ..Default::default() };
        let since = WindowNetConfig { inputs: WindowInputs::SinceStart, ..both.clone() };
        let (b, s) = (inputs(&frames, &both), inputs(&frames, &since));
        assert_eq!(b.len(), levels.len());
        for ((l, b), s) in levels.iter().zip(&b).zip(&s) {
            assert_eq!((b.len(), s.len()), (72, 48));
            // the level pattern and the change across the window are the Levels inputs, bit for bit
            assert_eq!(&b[..24], &l[..24]);
            assert_eq!(&b[48..], &l[24..]);
            assert_eq!(&s[24..], &l[24..]);
            assert_eq!(&s[..24], &b[24..48]);
        }
        // the first window's pattern since the start sums to zero across taxels
        assert!(s[0][..24].iter().sum::<f64>().abs() < 1e-9);
        // an offset per taxel (a static pattern, e.g. the object's shape) changes the
        // since-start pattern only through its common scale (the level spread `s`)
        let offsets: Vec<f64> = (0..24).map(|i| ((i * 37) % 11) as f64 * 40.0 - 200.0).collect();
        let moved: Vec<Vec<f64>> =
            frames.iter().map(|f| f.iter().zip(&offsets).map(|(v, o)| v + o).collect()).collect();
        let m = inputs(&moved, &since);
        let unit = |v: &[f64]| {
            let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            v.iter().map(|x| x / n.max(1e-300)).collect::<Vec<f64>>()
        };
        for (w, (x, y)) in s.iter().zip(&m).enumerate().skip(1) {
            for (u, v) in unit(&x[..24]).iter().zip(unit(&y[..24])) {
                assert!((u - v).abs() < 1e-9, "reference {reference_frames}, window {w}: {u} vs {v}");
            }
        }
    }
    // the reference is causal: a prefix gives the same windows as the whole recording did
    let cfg = WindowNetConfig { inputs: WindowInputs::Both, reference_frames: 23, ..Default::default() };
    let whole = inputs(&frames, &cfg);
    assert_eq!(inputs(&frames[..30], &cfg), whole[..6].to_vec());
    // a given reference equals the one gathered from the same frames
    let mut x = WindowExtractor::try_new(&cfg, 24).unwrap();
    x.reset_with_reference(frames[..23].iter().map(|f| f.as_slice())).unwrap();
    for f in &frames[25..30] {
        x.push(f).unwrap();
    }
    assert_eq!(x.input().unwrap(), whole[5]);
    assert!(x.reset_with_reference([&[1.0; 23][..]]).is_err());
    assert!(x.reset_with_reference([&[f64::NAN; 24][..]]).is_err());
    assert!(WindowNetConfig { reference_frames: 0, ..cfg.clone() }.validate().is_err());
    assert!(WindowNetConfig { reference_frames: MAX_WINDOW_FRAMES + 1, ..cfg }.validate().is_err());
    // a model file written before the field reads as the level representation
    let old: WindowNetConfig = serde_json::from_str(r#"{"frames": 5, "hidden": 16}"#).unwrap();
    assert_eq!(old, WindowNetConfig::default());
    assert_eq!(old.inputs, WindowInputs::Levels);
    // and a default one is written as before; other settings are written and read back
    assert_eq!(serde_json::to_string(&old).unwrap(), r#"{"frames":5,"hidden":16}"#);
    let both = WindowNetConfig { inputs: WindowInputs::Both, reference_frames: 25, ..Default::default() };
    let json = serde_json::to_string(&both).unwrap();
    assert!(json.contains(r#""inputs":"both""#) && json.contains(r#""reference_frames":25"#), "{json}");
    assert_eq!(serde_json::from_str::<WindowNetConfig>(&json).unwrap(), both);
}

/// A small hand-made model (no trainer needed).
/// A 9 × 9 grid of taxels 1 mm apart, centred on the origin (symmetric about `y = 0`).
fn grid() -> Layout {
    let positions: Vec<[f64; 2]> = (0..81).map(|k| [(k % 9) as f64 - 4.0, (k / 9) as f64 - 4.0]).collect();
    Layout::try_new("grid", (0..81).map(|k| format!("g{k}")).collect(), positions, None).unwrap()
}

/// Frames of an elongated blob on [`grid`]: 10 frames at the origin and angle 0.5 rad (the
/// span's reference), then 10 frames at `shift` (mm) and angle `0.5 + turn`; levels
/// `base + 100·blob`.
fn blob_frames(shift: [f64; 2], turn: f64, base: f64) -> Vec<Vec<f64>> {
    let layout = grid();
    let frame = |d: [f64; 2], angle: f64| -> Vec<f64> {
        let (s, co) = f64::sin_cos(angle);
        layout
            .positions()
            .iter()
            .map(|p| {
                let (x, y) = (p[0] - d[0], p[1] - d[1]);
                let (u, v) = (co * x + s * y, -s * x + co * y);
                base + 100.0 * (-(u / 2.5).powi(2) - (v / 1.0).powi(2)).exp()
            })
            .collect()
    };
    let mut out = vec![frame([0.0; 2], 0.5); 10];
    out.extend(vec![frame(shift, 0.5 + turn); 10]);
    out
}

#[test]
fn motion_inputs_tell_a_turn_from_a_shift_and_ignore_a_common_gain_and_offset() {
    let cfg = WindowNetConfig { motion: true, ..Default::default() };
    let layout = grid();
    let n = layout.len();
    assert_eq!(cfg.inputs(n), 2 * n + MOTION_INPUTS);
    assert!(cfg.needs_reference());
    // the last window (frames 15..20) against the reference (frames 0..10)
    let last = |frames: &[Vec<f64>]| -> [f64; MOTION_INPUTS] {
        let mut x = WindowExtractor::try_new_on(&cfg, &layout).unwrap();
        let mut out = None;
        for f in frames {
            if x.push(f).unwrap() {
                out = x.input();
            }
        }
        let out = out.unwrap();
        assert_eq!(out.len(), 2 * n + MOTION_INPUTS);
        out[2 * n..].try_into().unwrap()
    };
    let still = last(&blob_frames([0.0; 2], 0.0, 1000.0));
    assert!(still.iter().all(|v| v.abs() < 1e-9), "{still:?}");
    for turn in [0.3f64, -0.3] {
        let m = last(&blob_frames([0.0; 2], turn, 1000.0));
        assert_eq!(m[2].signum(), turn.signum(), "{m:?}");
        assert!(m[3] > 0.6, "a turn is mostly rotation: {m:?}");
    }
    for shift in [[0.5, 0.0], [0.0, -0.5], [0.4, 0.4]] {
        let m = last(&blob_frames(shift, 0.0, 1000.0));
        assert!(m[0] * shift[0] + m[1] * shift[1] > 0.0, "the drift follows the shift: {m:?}");
        assert!(m[3] < 0.4, "a shift is mostly translation: {m:?}");
    }
    // one gain and one offset common to all taxels change only rounding
    let a = last(&blob_frames([0.3, 0.2], 0.2, 1000.0));
    let scaled: Vec<Vec<f64>> =
        blob_frames([0.3, 0.2], 0.2, 1000.0).iter().map(|f| f.iter().map(|v| 3.0 * v - 77.0).collect()).collect();
    let b = last(&scaled);
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() < 1e-9, "{a:?} vs {b:?}");
    }
    // the reflection across y = 0 changes their signs as MOTION_MIRROR_SIGNS says
    let mirror: Vec<usize> = (0..n).map(|k| (8 - k / 9) * 9 + k % 9).collect();
    let flipped: Vec<Vec<f64>> =
        blob_frames([0.3, 0.2], 0.2, 1000.0).iter().map(|f| mirror.iter().map(|&j| f[j]).collect()).collect();
    let m = last(&flipped);
    for k in 0..MOTION_INPUTS {
        assert!((m[k] - MOTION_MIRROR_SIGNS[k] * a[k]).abs() < 1e-9, "{m:?} vs {a:?}");
    }
    // a flat span and the extremes give finite values; without positions, refused
    assert_eq!(last(&vec![vec![5.0; n]; 20]), [0.0; MOTION_INPUTS]);
    assert!(last(&blob_frames([0.0; 2], 0.3, 1e300)).iter().all(|v| v.is_finite()));
    assert!(last(&blob_frames([1e300, 0.0], 0.3, -1e300)).iter().all(|v| v.is_finite()));
    assert!(WindowExtractor::try_new(&cfg, n).is_err());
    // not written when off; read back when on
    let json = serde_json::to_string(&WindowNetConfig::default()).unwrap();
    assert!(!json.contains("motion"), "{json}");
    let on: WindowNetConfig = serde_json::from_str(&serde_json::to_string(&cfg).unwrap()).unwrap();
    assert_eq!(on, cfg);
}

fn tiny_model() -> DosWindowNet {
    let d = 48;
    DosWindowNet {
        config: WindowNetConfig { frames: 5, hidden: 2, ..Default::default() },
        taxels: 24,
        classes: vec![DosClass::N, DosClass::S, DosClass::T],
        input_mean: vec![0.0; d],
        input_scale: vec![1.0; d],
        w1: vec![(0..d).map(|j| if j < 24 { 0.1 * (j as f64 - 11.5) } else { 0.0 }).collect(), vec![0.01; d]],
        b1: vec![0.0, 0.1],
        w2: vec![vec![1.0, 0.0], vec![-1.0, 0.0], vec![0.0, 0.5]],
        b2: vec![0.0, 0.0, 0.1],
        recordings: 3,
    }
}

#[test]
fn window_model_round_trips_through_json_and_refuses_bad_files() {
    let m = tiny_model();
    m.validate().unwrap();
    let json = serde_json::to_string(&m).unwrap();
    let back: DosWindowNet = serde_json::from_str(&json).unwrap();
    assert_eq!(back, m);
    assert_eq!(m.parameter_count(), 2 * 48 + 2 * 48 + 2 + 3 * 2 + 3);
    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let broken = |f: &dyn Fn(&mut serde_json::Value)| {
        let mut w = v.clone();
        f(&mut w);
        serde_json::from_value::<DosWindowNet>(w).unwrap_err().to_string()
    };
    assert!(broken(&|w| w["b1"] = serde_json::json!([0.0])).contains("b1"));
    assert!(broken(&|w| w["w2"] = serde_json::json!([[1.0, 0.0]])).contains("w2"));
    assert!(broken(&|w| w["input_scale"][3] = serde_json::json!(0.0)).contains("input_scale"));
    assert!(broken(&|w| w["config"]["hidden"] = serde_json::json!(0)).contains("hidden"));
    assert!(broken(&|w| w["classes"] = serde_json::json!(["n", "n", "t"])).contains("twice"));
    assert!(broken(&|w| w["surprise"] = serde_json::json!(1)).contains("surprise"));
    v["taxels"] = serde_json::json!(2);
    assert!(serde_json::from_value::<DosWindowNet>(v).is_err());
    // the layout must match
    let skew = Layout::try_new(
        "three",
        vec!["a".into(), "b".into(), "c".into()],
        vec![[0.0, 1.0], [1.0, 0.0], [2.0, 3.0]],
        None,
    )
    .unwrap();
    assert!(m.extractor(&skew).is_err());
    assert!(m.logits(&[0.0; 47]).is_err());
    assert!(m.logits(&[f64::NAN; 48]).is_err());
}

#[test]
fn the_vote_is_causal_and_sums_the_windows_log_posteriors() {
    let m = tiny_model();
    let layout = Layout::biotac_sp();
    let frames = counts(DosClass::N, 5);
    let mut vote = m.vote(&layout).unwrap();
    assert!(vote.decision().is_none());
    let mut sum = [0.0f64; 3];
    let mut decisions = Vec::new();
    for f in &frames {
        if let Some(w) = vote.push(f).unwrap() {
            for (s, p) in sum.iter_mut().zip(&w.posterior) {
                *s += p.ln();
            }
            let best = (0..3).fold(0, |b, k| if sum[k] > sum[b] { k } else { b });
            assert_eq!(vote.decision().unwrap().class, m.classes[best]);
        }
        decisions.push(vote.decision().map(|d| d.class));
    }
    assert_eq!(vote.windows(), (frames.len() / 5) as u64);
    // a prefix streamed alone decides as the whole stream did at that point (nothing later is seen)
    for cut in [5, 23, 100] {
        let mut v = m.vote(&layout).unwrap();
        for f in &frames[..cut] {
            v.push(f).unwrap();
        }
        assert_eq!(v.decision().map(|d| d.class), decisions[cut - 1]);
    }
    vote.reset();
    assert!(vote.decision().is_none());
}

#[cfg(feature = "train")]
mod training {
    use super::super::train::{mirror_permutation, SplitMix, TrainRecording};
    use super::super::train_window::*;
    use super::*;

    #[test]
    fn mirror_augmentation_permutes_taxels_and_mirrors_classes() {
        let layout = Layout::biotac_sp();
        let p = mirror_permutation(&layout).unwrap();
        let aug = WindowAugment::mirror_only();
        for class in DosClass::ALL {
            let frames = counts(class, 9);
            let v = versions(class, &frames, &layout, &aug, &mut SplitMix::new(1)).unwrap();
            assert_eq!(v.len(), 2);
            assert_eq!(v[0], (class, frames.clone()));
            let expected = match class {
                DosClass::E => DosClass::W,
                DosClass::W => DosClass::E,
                DosClass::Cw => DosClass::Aw,
                DosClass::Aw => DosClass::Cw,
                other => other,
            };
            assert_eq!(v[1].0, expected, "{class}");
            for (m, f) in v[1].1.iter().zip(&frames) {
                for (i, &j) in p.iter().enumerate() {
                    assert_eq!(m[i], f[j]);
                }
            }
            // the mirror's windows are the permuted windows, exactly
            let (a, b) = (inputs(&frames, &WindowNetConfig::default()), inputs(&v[1].1, &WindowNetConfig::default()));
            for (x, y) in a.iter().zip(&b) {
                for (i, &j) in p.iter().enumerate() {
                    assert_eq!(y[i].to_bits(), x[j].to_bits());
                }
            }
        }
        // random copies keep the shape, are finite and deterministic
        let frames = counts(DosClass::S, 2);
        let aug = WindowAugment { copies: 3, ..Default::default() };
        let a = versions(DosClass::S, &frames, &layout, &aug, &mut SplitMix::new(4)).unwrap();
        let b = versions(DosClass::S, &frames, &layout, &aug, &mut SplitMix::new(4)).unwrap();
        assert_eq!(a, b);
        assert_eq!(a.len(), 5);
        assert!(a.iter().all(|(_, f)| f.iter().all(|r| r.len() == 24 && r.iter().all(|v| v.is_finite()))));
        assert!(WindowAugment { gain: 2.0, ..Default::default() }.validate().is_err());
        assert!(WindowAugment { copies: 101, ..Default::default() }.validate().is_err());
    }

    #[test]
    fn an_object_imprint_is_one_static_smooth_bump_and_off_changes_nothing() {
        let layout = Layout::biotac_sp();
        let frames = counts(DosClass::N, 3);
        // spread 0 (the default): nothing drawn, nothing changed — the augmentation before it
        let mut rng = SplitMix::new(7);
        let mut same = frames.clone();
        imprint(&mut same, layout.positions(), 0.0, &mut rng);
        assert_eq!(same, frames);
        assert_eq!(rng.uniform(), SplitMix::new(7).uniform(), "no draw when off");
        let off = WindowAugment { copies: 2, ..Default::default() };
        let with = WindowAugment { imprint: 0.0, ..off.clone() };
        assert_eq!(
            versions(DosClass::N, &frames, &layout, &off, &mut SplitMix::new(3)).unwrap(),
            versions(DosClass::N, &frames, &layout, &with, &mut SplitMix::new(3)).unwrap()
        );
        // on: the same added vector at every frame (every change over time kept), largest at one
        // taxel and falling off smoothly with the distance from it; deterministic for a seed
        let mut seen_nonzero = false;
        for seed in 0..20 {
            let mut a = frames.clone();
            imprint(&mut a, layout.positions(), 0.5, &mut SplitMix::new(seed));
            let mut b = frames.clone();
            imprint(&mut b, layout.positions(), 0.5, &mut SplitMix::new(seed));
            assert_eq!(a, b);
            let bump: Vec<f64> = a[0].iter().zip(&frames[0]).map(|(x, y)| x - y).collect();
            for (fa, f) in a.iter().zip(&frames) {
                for ((x, y), d) in fa.iter().zip(f).zip(&bump) {
                    assert!((x - y - d).abs() <= 1e-9 * (1.0 + y.abs()), "seed {seed}: not static");
                }
            }
            let top = (0..24).max_by(|&i, &j| bump[i].abs().total_cmp(&bump[j].abs())).unwrap();
            let c = layout.positions()[top];
            let dist = |i: usize| {
                let p = layout.positions()[i];
                (p[0] - c[0]).hypot(p[1] - c[1])
            };
            // one Gaussian of the distance from the peak taxel: |bump| never grows with distance
            let mut order: Vec<usize> = (0..24).collect();
            order.sort_by(|&i, &j| dist(i).total_cmp(&dist(j)));
            for w in order.windows(2) {
                assert!(bump[w[1]].abs() <= bump[w[0]].abs() * (1.0 + 1e-9) + 1e-9, "seed {seed}: not one bump");
            }
            seen_nonzero |= bump[top].abs() > 0.0;
        }
        assert!(seen_nonzero);
        // with imprint the copies differ from those without, the originals and mirror do not
        let on = WindowAugment { imprint: 0.5, ..off.clone() };
        let (a, b) = (
            versions(DosClass::N, &frames, &layout, &off, &mut SplitMix::new(3)).unwrap(),
            versions(DosClass::N, &frames, &layout, &on, &mut SplitMix::new(3)).unwrap(),
        );
        assert_eq!(a[..2], b[..2]);
        assert_ne!(a[2..], b[2..]);
        assert!(WindowAugment { imprint: 11.0, ..Default::default() }.validate().is_err());
        assert!(WindowAugment { imprint: -0.1, ..Default::default() }.validate().is_err());
        // empty input, or positions that do not match the taxels: nothing done, no panic
        let mut none: Vec<Vec<f64>> = Vec::new();
        imprint(&mut none, layout.positions(), 0.5, &mut SplitMix::new(1));
        let mut short = frames.clone();
        imprint(&mut short, &layout.positions()[..3], 0.5, &mut SplitMix::new(1));
        assert_eq!(short, frames);
    }

    #[test]
    fn mirroring_a_recording_twice_gives_it_back() {
        let layout = Layout::biotac_sp();
        let aug = WindowAugment::mirror_only();
        for class in DosClass::ALL {
            let frames = counts(class, 5);
            let once = versions(class, &frames, &layout, &aug, &mut SplitMix::new(1)).unwrap();
            let twice = versions(once[1].0, &once[1].1, &layout, &aug, &mut SplitMix::new(1)).unwrap();
            assert_eq!(twice[1], (class, frames), "{class}");
        }
    }

    #[test]
    fn window_training_separates_synthetic_slips_and_round_trips() {
        let layout = Layout::biotac_sp();
        let mut recs = Vec::new();
        for (k, class) in DosClass::ALL.into_iter().enumerate() {
            for j in 0..4u64 {
                let frames = counts(class, 100 + 31 * j + k as u64);
                recs.push(TrainRecording { class, group: format!("obj{}", j % 2), frames });
            }
        }
        let cfg = WindowTrainConfig { epochs: 10, ..Default::default() };
        let samples = window_samples(&recs, &layout, &cfg).unwrap();
        let all: Vec<usize> = (0..recs.len()).collect();
        let net = fit_on(&samples, &all, &layout, &cfg).unwrap();
        assert_eq!(net, fit_on(&samples, &all, &layout, &cfg).unwrap(), "deterministic for a seed");
        let s = score(&net, &recs, &all, &layout).unwrap();
        let right = s.iter().filter(|x| x.2).count();
        assert!(right * 2 > recs.len(), "{right}/{}", recs.len());
        let back: DosWindowNet = serde_json::from_str(&serde_json::to_string(&net).unwrap()).unwrap();
        assert_eq!(back, net);
        assert!(fit_windows(&[(DosClass::N, vec![0.0; 48])], &layout, &cfg).is_err());
        assert!(WindowTrainConfig { epochs: 0, ..Default::default() }.validate().is_err());
        assert!(WindowTrainConfig { batch: 0, ..Default::default() }.validate().is_err());
    }

    #[test]
    fn merged_members_average_the_members_logits_in_one_network() {
        let layout = Layout::biotac_sp();
        let mut recs = Vec::new();
        for (k, class) in DosClass::ALL.into_iter().enumerate() {
            for j in 0..2u64 {
                recs.push(TrainRecording {
                    class,
                    group: format!("obj{j}"),
                    frames: counts(class, 300 + 7 * j + k as u64),
                });
            }
        }
        let net = WindowNetConfig { inputs: WindowInputs::Both, hidden: 4, ..Default::default() };
        // one random copy each: the members' windows differ (their standardisations are folded)
        let cfg = WindowTrainConfig { net, epochs: 3, members: 3, ..Default::default() };
        let all: Vec<usize> = (0..recs.len()).collect();
        let members: Vec<DosWindowNet> = (0..3u64)
            .map(|k| {
                let c = WindowTrainConfig { seed: 1 + k, members: 1, ..cfg.clone() };
                fit_on(&window_samples(&recs, &layout, &c).unwrap(), &all, &layout, &c).unwrap()
            })
            .collect();
        assert_ne!(members[0].input_mean, members[1].input_mean);
        let merged = merge_members(&members).unwrap();
        assert_eq!(merged.config.hidden, 12);
        assert_eq!(merged.parameter_count(), dense_count(72, 12, 7));
        let x = inputs(&recs[3].frames, &merged.config);
        for w in &x {
            let want: Vec<f64> =
                (0..7).map(|c| members.iter().map(|m| m.logits(w).unwrap()[c]).sum::<f64>() / 3.0).collect();
            for (a, b) in merged.logits(w).unwrap().iter().zip(&want) {
                assert!((a - b).abs() < 1e-9 * (1.0 + b.abs()), "{a} vs {b}");
            }
        }
        // one member merges to itself; the trainer's members are the same merge
        assert_eq!(merge_members(&members[..1]).unwrap(), members[0]);
        let same = WindowTrainConfig { augment: WindowAugment::mirror_only(), ..cfg.clone() };
        let samples = window_samples(&recs, &layout, &same).unwrap();
        let one: Vec<DosWindowNet> = (0..3u64)
            .map(|k| {
                fit_on(&samples, &all, &layout, &WindowTrainConfig { seed: 1 + k, members: 1, ..same.clone() }).unwrap()
            })
            .collect();
        let mut want = merge_members(&one).unwrap();
        want.recordings = all.len();
        assert_eq!(fit_on(&samples, &all, &layout, &same).unwrap(), want);
        // refused: nothing, mixed representations, too many hidden units
        assert!(merge_members(&[]).is_err());
        let mut other = members[1].clone();
        other.config.inputs = WindowInputs::SinceStart;
        assert!(merge_members(&[members[0].clone(), other]).is_err());
        assert!(WindowTrainConfig { members: 17, ..Default::default() }.validate().is_err());
        assert!(WindowTrainConfig { members: 0, ..Default::default() }.validate().is_err());
        let wide = WindowNetConfig { hidden: 64, ..Default::default() };
        assert!(WindowTrainConfig { net: wide, members: 5, ..Default::default() }.validate().is_err());
    }

    #[test]
    fn inner_scores_tally_every_held_out_window_and_the_choice_is_their_best() {
        let layout = Layout::biotac_sp();
        let mut recs = Vec::new();
        for (k, class) in DosClass::ALL.into_iter().enumerate() {
            for j in 0..3u64 {
                let frames = counts(class, 500 + 11 * j + k as u64)[..40].to_vec();
                recs.push(TrainRecording { class, group: format!("obj{j}"), frames });
            }
        }
        let small = |inputs| WindowNetConfig { inputs, hidden: 3, ..Default::default() };
        let cands = [
            WindowTrainConfig {
                net: small(WindowInputs::Levels),
                epochs: 2,
                augment: WindowAugment::mirror_only(),
                ..Default::default()
            },
            WindowTrainConfig {
                net: small(WindowInputs::Both),
                epochs: 2,
                augment: WindowAugment::mirror_only(),
                ..Default::default()
            },
        ];
        let samples: Vec<Vec<WindowSamples>> =
            cands.iter().map(|c| window_samples(&recs, &layout, c).unwrap()).collect();
        let views: Vec<&[WindowSamples]> = samples.iter().map(|s| s.as_slice()).collect();
        let idx: Vec<usize> = (0..recs.len()).collect();
        let scores = inner_scores(&recs, &views, &idx, &layout, &cands).unwrap();
        assert_eq!(scores.len(), 2);
        for ((ok, n), (rok, rn)) in &scores {
            // every recording held out once: 40 frames = 8 windows each
            assert_eq!((*n, *rn), (8 * recs.len(), recs.len()));
            assert!(ok <= n && rok <= rn);
        }
        let (k, acc) = choose_window(&recs, &views, &idx, &layout, &cands).unwrap();
        let accs: Vec<f64> = scores.iter().map(|((ok, n), _)| *ok as f64 / *n as f64).collect();
        assert_eq!(acc, accs[k]);
        assert!(accs.iter().all(|a| *a <= acc));
        assert!(accs[..k].iter().all(|a| *a < acc), "ties go to the earlier");
        let one: Vec<usize> = idx.iter().copied().filter(|&i| recs[i].group == "obj0").collect();
        assert!(inner_scores(&recs, &views, &one, &layout, &cands).is_err());
    }

    #[test]
    fn the_mirror_average_gives_a_mirrored_window_the_mirrored_posterior() {
        use super::super::train::permute;
        let layout = Layout::biotac_sp();
        let p = mirror_permutation(&layout).unwrap();
        let mut recs = Vec::new();
        for (k, class) in DosClass::ALL.into_iter().enumerate() {
            for j in 0..2u64 {
                recs.push(TrainRecording {
                    class,
                    group: format!("obj{j}"),
                    frames: counts(class, 500 + 7 * j + k as u64),
                });
            }
        }
        let all: Vec<usize> = (0..recs.len()).collect();
        for (kind, motion) in [(WindowInputs::Levels, false), (WindowInputs::Both, false), (WindowInputs::Levels, true)]
        {
            let net = WindowNetConfig { inputs: kind, hidden: 4, motion, ..Default::default() };
            let plain = WindowTrainConfig { net, epochs: 3, members: 2, ..Default::default() };
            let sym = WindowTrainConfig { mirror_average: true, ..plain.clone() };
            let samples = window_samples(&recs, &layout, &plain).unwrap();
            let a = fit_on(&samples, &all, &layout, &plain).unwrap();
            let b = fit_on(&samples, &all, &layout, &sym).unwrap();
            assert_eq!(b.config.hidden, 2 * a.config.hidden);
            // the plain ensemble is not symmetric; the mirror average is, to rounding
            let m = mirrored_net(&a, &p).unwrap();
            let mut plain_gap: f64 = 0.0;
            for r in &recs[..6] {
                let x = inputs(&r.frames, &b.config);
                let xm = inputs(&permute(&r.frames, &p), &b.config);
                for (w, wm) in x.iter().zip(&xm) {
                    let (l, lm) = (b.logits(w).unwrap(), b.logits(wm).unwrap());
                    for (c, class) in b.classes.iter().enumerate() {
                        let cm = b.classes.iter().position(|x| *x == class.mirrored()).unwrap();
                        assert!((l[c] - lm[cm]).abs() < 1e-9 * (1.0 + l[c].abs()), "{} vs {}", l[c], lm[cm]);
                    }
                    // the mirrored net on the mirrored window is the net on the window, mirrored
                    let (la, lma) = (a.logits(w).unwrap(), m.logits(wm).unwrap());
                    for (c, class) in a.classes.iter().enumerate() {
                        let cm = a.classes.iter().position(|x| *x == class.mirrored()).unwrap();
                        assert!((la[cm] - lma[c]).abs() < 1e-9 * (1.0 + la[cm].abs()), "{} vs {}", la[cm], lma[c]);
                        plain_gap = plain_gap.max((la[c] - a.logits(wm).unwrap()[cm]).abs());
                    }
                    // and the average is the mean of the two
                    let mb = m.logits(w).unwrap();
                    for c in 0..l.len() {
                        assert!((l[c] - (la[c] + mb[c]) / 2.0).abs() < 1e-9 * (1.0 + l[c].abs()));
                    }
                }
            }
            assert!(plain_gap > 1e-6, "the plain ensemble is not symmetric by construction");
        }
        // refused: a permutation that is not an involution, a class without its mirror, too wide
        let cfg = WindowTrainConfig { epochs: 1, ..Default::default() };
        let net = fit_on(&window_samples(&recs, &layout, &cfg).unwrap(), &all, &layout, &cfg).unwrap();
        let mut bad = p.clone();
        bad.swap(0, 1);
        assert!(mirrored_net(&net, &bad).is_err());
        assert!(mirrored_net(&net, &p[..23]).is_err());
        let only_e: Vec<TrainRecording> =
            recs.iter().filter(|r| r.class == DosClass::E || r.class == DosClass::N).cloned().collect();
        let one = WindowTrainConfig {
            augment: WindowAugment { mirror: false, copies: 0, ..Default::default() },
            ..cfg.clone()
        };
        let s = window_samples(&only_e, &layout, &one).unwrap();
        let idx: Vec<usize> = (0..only_e.len()).collect();
        let e_only = fit_on(&s, &idx, &layout, &one).unwrap();
        assert!(mirrored_net(&e_only, &p).is_err());
        let wide = WindowNetConfig { hidden: 32, ..Default::default() };
        assert!(WindowTrainConfig { net: wide.clone(), members: 4, ..Default::default() }.validate().is_ok());
        assert!(WindowTrainConfig { net: wide, members: 5, mirror_average: true, ..Default::default() }
            .validate()
            .is_err());
    }

    /// Fitted numbers of a network of `d` inputs, `h` hidden units and `c` classes.
    fn dense_count(d: usize, h: usize, c: usize) -> usize {
        2 * d + h * d + h + c * h + c
    }
}

#[test]
fn the_motion_inputs_split_off_the_level_inputs_bit_for_bit() {
    // what the `dos` stage's sliding mode keeps across decisions: the level inputs' hidden sums
    // and the deviations; the motion inputs recomputed against a reference given afterwards
    let cfg = WindowNetConfig { motion: true, hidden: 3, ..Default::default() };
    let layout = grid();
    let n = layout.len();
    let d = cfg.inputs(n);
    let net = DosWindowNet {
        config: cfg.clone(),
        taxels: n,
        classes: DosClass::ALL.to_vec(),
        input_mean: (0..d).map(|j| 0.01 * (j % 7) as f64).collect(),
        input_scale: (0..d).map(|j| 0.5 + 0.1 * (j % 5) as f64).collect(),
        w1: (0..3).map(|h| (0..d).map(|j| 0.03 * ((h * 5 + j * 3) % 11) as f64 - 0.15).collect()).collect(),
        b1: vec![0.1, -0.2, 0.05],
        w2: (0..7).map(|k| (0..3).map(|h| 0.2 * ((k + 2 * h) % 5) as f64 - 0.4).collect()).collect(),
        b2: (0..7).map(|k| 0.01 * k as f64).collect(),
        recordings: 1,
    };
    net.validate().unwrap();
    for (frames, flat) in [(blob_frames([0.3, -0.2], 0.25, 1000.0), false), (vec![vec![5.0; n]; 20], true)] {
        let mut whole = WindowExtractor::try_new_on(&cfg, &layout).unwrap();
        let mut single = WindowExtractor::try_new_on(&cfg, &layout).unwrap();
        for (t, f) in frames.iter().enumerate() {
            if !whole.push(f).unwrap() {
                continue;
            }
            let x = whole.input().unwrap();
            // the window's frames alone, then the reference a fresh span has at its end
            single.reset();
            for g in &frames[t + 1 - cfg.frames..=t] {
                single.push(g).unwrap();
            }
            let (levels, dev) = single.input_and_deviations().unwrap();
            assert_eq!(dev.is_none(), flat);
            assert_eq!(levels[..d - MOTION_INPUTS], x[..d - MOTION_INPUTS]);
            assert!(levels[d - MOTION_INPUTS..].iter().all(|&v| v == 0.0));
            let seen = (t + 1).min(cfg.reference_frames);
            single.reset_with_reference(frames[..seen].iter().map(|f| f.as_slice())).unwrap();
            let m = dev.as_deref().map_or([0.0; MOTION_INPUTS], |dev| single.motion_inputs(dev));
            assert_eq!(m[..], x[d - MOTION_INPUTS..], "frame {t}");
            if !flat && t >= 10 {
                // the blob moved after the reference's 10 frames
                assert!(m.iter().any(|&v| v != 0.0), "frame {t}");
            }
            let sums = net.prefix_sums(&levels[..d - MOTION_INPUTS]).unwrap();
            let lp = net.log_posterior_from_prefix(&sums, &m).unwrap();
            assert_eq!(lp, net.log_posterior(&x).unwrap(), "bit for bit, frame {t}");
        }
    }
    // wrong sizes and non-finite inputs are errors, not panics
    assert!(net.prefix_sums(&vec![0.0; d + 1]).is_err());
    assert!(net.prefix_sums(&[f64::NAN]).is_err());
    assert!(net.log_posterior_from_prefix(&[0.0; 2], &[0.0; 4]).is_err());
    assert!(net.log_posterior_from_prefix(&[0.0; 3], &vec![0.0; d + 1]).is_err());
    assert!(net.log_posterior_from_prefix(&[0.0; 3], &[f64::INFINITY]).is_err());
    let plain = WindowExtractor::try_new(&WindowNetConfig::default(), n).unwrap();
    assert_eq!(plain.motion_inputs(&vec![1.0; n]), [0.0; MOTION_INPUTS]);
}
