//! Tests of the tree model's inference ([`DosTrees`], [`TreeExtractor`], [`TreeVote`]) and, with
//! the `train` feature, of its trainer.

use super::tests_support::synthetic_values;
use super::*;
use proptest::prelude::*;

fn leaf(v: f64) -> Tree {
    Tree { feature: vec![0], threshold: vec![0.0], left: vec![0], right: vec![0], value: vec![v] }
}

/// A stump on input `f` at `thr`: left `a`, right `b`.
fn stump(f: usize, thr: f64, a: f64, b: f64) -> Tree {
    Tree {
        feature: vec![f, 0, 0],
        threshold: vec![thr, 0.0, 0.0],
        left: vec![1, 0, 0],
        right: vec![2, 0, 0],
        value: vec![0.0, a, b],
    }
}

fn small_inputs() -> TreeInputs {
    TreeInputs { window: WindowNetConfig::default(), lags: vec![2], slope_windows: 2, ..TreeInputs::default() }
}

/// A valid two-class model on the BioTac SP's 24 taxels (no mirror).
fn two_class() -> DosTrees {
    DosTrees::try_new(
        small_inputs(),
        24,
        vec![DosClass::N, DosClass::S],
        vec![0.0, 0.0],
        vec![stump(0, 0.0, 1.0, -1.0), leaf(0.0)],
        None,
        3,
    )
    .unwrap()
}

#[test]
fn a_valid_model_round_trips_through_json_with_the_same_logits() {
    let m = two_class();
    let json = serde_json::to_string(&m).unwrap();
    let back: DosTrees = serde_json::from_str(&json).unwrap();
    assert_eq!(back, m);
    let mut x = vec![0.5; m.input_count()];
    assert_eq!(m.logits(&x).unwrap(), vec![-1.0, 0.0]);
    x[0] = -0.5;
    assert_eq!(back.logits(&x).unwrap(), vec![1.0, 0.0]);
    x[0] = f64::NAN; // NaN goes right, no panic
    assert_eq!(back.logits(&x).unwrap(), vec![-1.0, 0.0]);
    assert!(m.logits(&x[1..]).is_err(), "a wrong input length is an error");
}

#[test]
fn malformed_models_are_refused() {
    let ok = two_class();
    let inputs = ok.input_count();
    let with = |f: &dyn Fn(&mut Vec<Tree>)| {
        let mut t = ok.trees().to_vec();
        f(&mut t);
        DosTrees::try_new(small_inputs(), 24, ok.classes().to_vec(), vec![0.0, 0.0], t, None, 0)
    };
    type Break = Box<dyn Fn(&mut Vec<Tree>)>;
    let cases: Vec<(&str, Break)> = vec![
        ("child before its parent", Box::new(|t| (t[0].left[2], t[0].right[2]) = (1, 1))),
        ("self loop", Box::new(|t| (t[0].left[1], t[0].right[1]) = (1, 2))),
        ("root as a right child", Box::new(|t| t[0].right[0] = 0)),
        ("child out of range", Box::new(|t| t[0].right[0] = 3)),
        ("both children one node", Box::new(|t| t[0].right[0] = 1)),
        (
            "a node with two parents",
            Box::new(|t| {
                // root → 1, 2; node 1 → 3, 4; node 2 → 4, 5: node 4 has two parents
                t[0] = Tree {
                    feature: vec![0; 6],
                    threshold: vec![0.0; 6],
                    left: vec![1, 3, 4, 0, 0, 0],
                    right: vec![2, 4, 5, 0, 0, 0],
                    value: vec![0.0; 6],
                }
            }),
        ),
        ("input out of range", Box::new(move |t| t[0].feature[0] = inputs)),
        ("NaN threshold", Box::new(|t| t[0].threshold[0] = f64::NAN)),
        ("infinite leaf", Box::new(|t| t[0].value[1] = f64::INFINITY)),
        ("ragged arrays", Box::new(|t| t[0].value.pop().map_or((), |_| ()))),
        (
            "empty tree",
            Box::new(|t| {
                t[1] = Tree { feature: vec![], threshold: vec![], left: vec![], right: vec![], value: vec![] }
            }),
        ),
        ("tree count not a multiple of the classes", Box::new(|t| t.push(leaf(0.0)))),
    ];
    for (name, f) in cases {
        assert!(with(&*f).is_err(), "{name} accepted");
    }
    // too deep: a chain of MAX_TREE_DEPTH + 1 splits
    let d = MAX_TREE_DEPTH + 1;
    // splits at even indices, each with a leaf after it
    let mut t = Tree { feature: vec![], threshold: vec![], left: vec![], right: vec![], value: vec![] };
    for i in 0..=d {
        let split = i < d;
        let at = t.left.len();
        t.feature.push(0);
        t.threshold.push(0.0);
        t.left.push(if split { at + 1 } else { 0 });
        t.right.push(if split { at + 2 } else { 0 });
        t.value.push(0.0);
        if split {
            t.feature.push(0);
            t.threshold.push(0.0);
            t.left.push(0);
            t.right.push(0);
            t.value.push(0.0);
        }
    }
    assert!(t.validate(inputs).is_err(), "a tree deeper than the bound is refused");
    let mut ok_depth = t.clone();
    ok_depth.left[2 * (d - 1)] = 0; // cut the last split
    assert!(ok_depth.validate(inputs).is_ok());
    let classes = ok.classes().to_vec();
    let trees = ok.trees().to_vec();
    let m = |classes: Vec<DosClass>, base: Vec<f64>, mirror: Option<Vec<usize>>, taxels: usize| {
        DosTrees::try_new(small_inputs(), taxels, classes, base, trees.clone(), mirror, 0)
    };
    assert!(m(vec![DosClass::N, DosClass::N], vec![0.0; 2], None, 24).is_err(), "duplicate classes");
    assert!(m(classes.clone(), vec![0.0], None, 24).is_err(), "base of the wrong length");
    assert!(m(classes.clone(), vec![0.0, f64::NAN], None, 24).is_err(), "NaN base");
    assert!(m(classes.clone(), vec![0.0; 2], None, 2).is_err(), "too few taxels");
    let identity: Vec<usize> = (0..24).collect();
    assert!(m(classes.clone(), vec![0.0; 2], Some(identity.clone()), 24).is_ok(), "n and s are their own mirrors");
    let mut bad = identity.clone();
    bad[0] = 1;
    assert!(m(classes.clone(), vec![0.0; 2], Some(bad), 24).is_err(), "a mirror that is not an involution");
    assert!(
        DosTrees::try_new(
            small_inputs(),
            24,
            vec![DosClass::E, DosClass::S],
            vec![0.0; 2],
            trees.clone(),
            Some(identity),
            0
        )
        .is_err(),
        "mirror averaging without w among the classes"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    /// Any byte changed in a valid model file: read or refused, never a panic; what is read
    /// evaluates without a panic.
    #[test]
    fn a_mutated_model_file_never_panics(at in 0usize..100_000, byte in any::<u8>(), x in -5.0f64..5.0) {
        let json = serde_json::to_vec(&two_class()).unwrap();
        let mut b = json.clone();
        let i = at % b.len();
        b[i] = byte;
        if let Ok(m) = serde_json::from_slice::<DosTrees>(&b) {
            let v = vec![x; m.input_count()];
            prop_assert!(m.logits(&v).is_ok());
            let layout = Layout::biotac_sp();
            if let Ok(mut vote) = m.vote(&layout) {
                for f in synthetic_values(DosClass::N, [0.0, 0.0], 0.3, 1).iter().take(30) {
                    prop_assert!(vote.push(f).is_ok());
                }
            }
        }
    }
}

#[test]
fn the_extractor_is_causal_restarts_on_reset_and_refuses_non_finite_frames() {
    for turn in [false, true] {
        extractor_is_causal(TreeInputs { turn, ..TreeInputs::default() });
        extractor_is_causal(TreeInputs { turn, energy: true, ..TreeInputs::default() });
    }
    extractor_is_causal(TreeInputs { turn: true, energy: true, dilation: true, ..TreeInputs::default() });
}

fn extractor_is_causal(inputs: TreeInputs) {
    let layout = Layout::biotac_sp();
    let frames = synthetic_values(DosClass::Cw, [0.0, 0.0], 0.3, 7);
    let run = |x: &mut TreeExtractor, frames: &[Vec<f64>]| -> Vec<Vec<f64>> {
        frames.iter().filter_map(|f| x.push(f).unwrap()).collect()
    };
    let mut x = TreeExtractor::try_new_on(&inputs, &layout).unwrap();
    let all = run(&mut x, &frames);
    assert_eq!(all.len(), frames.len() / 5);
    assert!(all.iter().all(|v| v.len() == inputs.inputs(24) && v.iter().all(|x| x.is_finite())));
    // causal: a prefix gives the same windows as the whole
    let mut y = TreeExtractor::try_new_on(&inputs, &layout).unwrap();
    let prefix = run(&mut y, &frames[..frames.len() / 2]);
    assert_eq!(prefix[..], all[..prefix.len()]);
    // a reset starts afresh, bit for bit
    y.reset();
    assert_eq!(run(&mut y, &frames), all);
    let mut bad = frames[0].clone();
    bad[3] = f64::NAN;
    assert!(y.push(&bad).is_err());
}

/// The layout's reflection across y = 0 as a taxel permutation (as `train::mirror_permutation`).
fn mirror_of(layout: &Layout) -> Vec<usize> {
    let p = layout.positions();
    p.iter().map(|a| p.iter().position(|b| (a[0] - b[0]).abs() < 0.1 && (a[1] + b[1]).abs() < 0.1).unwrap()).collect()
}

#[test]
fn the_mirror_map_maps_a_mirrored_recordings_inputs() {
    for (turn, class) in [(false, DosClass::E), (true, DosClass::E), (true, DosClass::Cw)] {
        mirror_map_maps(TreeInputs { turn, ..TreeInputs::default() }, class);
        mirror_map_maps(TreeInputs { turn, energy: true, ..TreeInputs::default() }, class);
    }
    for class in [DosClass::E, DosClass::Cw, DosClass::T] {
        mirror_map_maps(TreeInputs { turn: true, energy: true, dilation: true, ..TreeInputs::default() }, class);
    }
}

fn mirror_map_maps(inputs: TreeInputs, class: DosClass) {
    let layout = Layout::biotac_sp();
    let perm = mirror_of(&layout);
    let frames = synthetic_values(class, [0.0, 0.0], 0.3, 3);
    let mirrored: Vec<Vec<f64>> = frames.iter().map(|f| perm.iter().map(|&j| f[j]).collect()).collect();
    let mut a = TreeExtractor::try_new_on(&inputs, &layout).unwrap();
    let mut b = TreeExtractor::try_new_on(&inputs, &layout).unwrap();
    let map = inputs.mirror_map(&perm);
    for (f, g) in frames.iter().zip(&mirrored) {
        if let (Some(x), Some(y)) = (a.push(f).unwrap(), b.push(g).unwrap()) {
            for (j, &(src, sign)) in map.iter().enumerate() {
                assert!((y[j] - sign * x[src]).abs() <= 1e-9 * (1.0 + x[src].abs()), "input {j}");
            }
        }
    }
}

/// A smooth anisotropic bump on the layout (the level pattern of a pressed contact), turned by
/// `angle` (radians, `+x` toward `+y`) about its centre and shifted by `shift` (mm).
fn bump(layout: &Layout, angle: f64, shift: [f64; 2]) -> Vec<f64> {
    let c = [2.0 + shift[0], 1.0 + shift[1]];
    let (s, co) = angle.sin_cos();
    layout
        .positions()
        .iter()
        .map(|p| {
            let (x, y) = (p[0] - c[0], p[1] - c[1]);
            // the point in the bump's own axes: turned back by the angle
            let (u, v) = (co * x + s * y, -s * x + co * y);
            100.0 * (-(u * u) / (2.0 * 36.0) - (v * v) / (2.0 * 9.0)).exp()
        })
        .collect()
}

#[test]
fn the_rigid_flow_recovers_a_small_turn_and_shift_of_a_pattern() {
    let layout = Layout::biotac_sp();
    let g = super::trees::TurnGeometry::try_new(&layout).unwrap();
    let run = |angle: f64, shift: [f64; 2]| {
        let (a, b) = (bump(&layout, 0.0, [0.0; 2]), bump(&layout, angle, shift));
        let mid: Vec<f64> = a.iter().zip(&b).map(|(x, y)| 0.5 * (x + y)).collect();
        let change: Vec<f64> = b.iter().zip(&a).map(|(x, y)| x - y).collect();
        g.flow_inputs(&mid, &change, false).0
    };
    for sign in [1.0, -1.0] {
        // a turn: θ has its sign and roughly its size, the centre hardly moves
        let [vx, vy, th] = run(sign * 0.1, [0.0; 2]);
        assert!(th * sign > 0.03 && th * sign < 0.3, "turn {}: {vx} {vy} {th}", sign * 0.1);
        // a shift along x: vx has its sign, the turn is smaller than the shift's
        let [vx, _, th] = run(0.0, [sign * 0.5, 0.0]);
        assert!(vx * sign > 0.15 && vx * sign < 1.5 && th.abs() < 0.05, "shift {}: {vx} {th}", sign * 0.5);
    }
    // no change, or a flat pattern: zeros
    assert_eq!(run(0.0, [0.0; 2]), [0.0; 3]);
    assert_eq!(g.flow_inputs(&[0.0; 24], &[1.0; 24], false).0, [0.0; 3]);
    // the turn needs a source and the level pattern
    let no_source = TreeInputs { lags: vec![], slope_windows: 0, turn: true, ..TreeInputs::default() };
    assert!(no_source.validate().is_err());
    let mut since = TreeInputs { lags: vec![], turn: true, ..TreeInputs::default() };
    since.window.inputs = WindowInputs::SinceStart;
    assert!(since.validate().is_err());
    assert_eq!(TreeInputs { turn: true, ..TreeInputs::default() }.inputs(24), TreeInputs::default().inputs(24) + 9);
}

/// The dilation (stop 36's round 6, T15) is positive for a pattern that spreads, negative for one
/// that shrinks, and the dilating fit still finds a turn's sense and a shift's direction. The
/// three-term fit (without the dilation) reports a dilation of 0; no change or a flat pattern
/// gives zeros.
#[test]
fn the_dilation_reads_spreading() {
    let layout = Layout::biotac_sp();
    let g = super::trees::TurnGeometry::try_new(&layout).unwrap();
    let pair = |a: &[f64], b: &[f64]| -> (Vec<f64>, Vec<f64>) {
        (a.iter().zip(b).map(|(x, y)| 0.5 * (x + y)).collect(), b.iter().zip(a).map(|(x, y)| x - y).collect())
    };
    let base = bump(&layout, 0.0, [0.0; 2]);
    // a small shift along x: vx has its sign with and without the dilation; the three-term fit's
    // dilation is 0
    let (mid, change) = pair(&base, &bump(&layout, 0.0, [0.3, 0.0]));
    let ([vx, _, _], d) = g.flow_inputs(&mid, &change, false);
    assert!(vx > 0.0 && d == 0.0, "shift: vx {vx}, dilation {d}");
    let ([vx, _, _], _) = g.flow_inputs(&mid, &change, true);
    assert!(vx > 0.0, "shift, with the dilation: vx {vx}");
    let noise: Vec<f64> = (0..24).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
    assert_eq!(g.flow_inputs(&base, &[0.0; 24], true), ([0.0; 3], 0.0));
    assert_eq!(g.flow_inputs(&[0.0; 24], &noise, true), ([0.0; 3], 0.0));
    // a spreading and a shrinking bump (the same shape, scaled about its centre)
    let scaled = |k: f64| -> Vec<f64> {
        let c = [2.0, 1.0];
        layout
            .positions()
            .iter()
            .map(|p| {
                let (u, v) = ((p[0] - c[0]) / k, (p[1] - c[1]) / k);
                100.0 * (-(u * u) / (2.0 * 36.0) - (v * v) / (2.0 * 9.0)).exp()
            })
            .collect()
    };
    for (k, sign) in [(1.1, 1.0), (0.9, -1.0)] {
        let (mid, change) = pair(&base, &scaled(k));
        let (_, d) = g.flow_inputs(&mid, &change, true);
        assert!(d * sign > 0.0, "scale {k}: dilation {d}");
    }
    for sign in [1.0, -1.0] {
        let (mid, change) = pair(&base, &bump(&layout, sign * 0.1, [0.0; 2]));
        let ([_, _, th], _) = g.flow_inputs(&mid, &change, true);
        assert!(th * sign > 0.0, "turn {}: {th}", sign * 0.1);
    }
    // it needs the rotation-sense fit and adds one input per source
    assert!(TreeInputs { dilation: true, ..TreeInputs::default() }.validate().is_err());
    let t13 = TreeInputs { turn: true, energy: true, ..TreeInputs::default() };
    let t15 = TreeInputs { dilation: true, ..t13.clone() };
    assert!(t15.validate().is_ok());
    assert_eq!((t15.dilation_inputs(), t15.inputs(24)), (3, t13.inputs(24) + 3));
}

/// The flow-share inputs (stop 36's round-6 candidate T14) were removed in stop 37: a file that
/// spells them out as `false` (round 6's and 7's candidates files, `trees_t15.json`) reads as
/// before; `true` is refused, and the message says they were removed and names the commit that
/// has them. Every other field keeps its default when absent, and an unknown field is refused.
#[test]
fn the_removed_flow_share_inputs_read_as_off_and_are_refused_on() {
    let t15 = TreeInputs { turn: true, energy: true, dilation: true, ..TreeInputs::default() };
    let spelled = r#"{"window": {"frames": 5, "hidden": 16, "inputs": "both", "motion": true}, "lags": [6, 20],
        "slope_windows": 6, "turn": true, "energy": true, "flow_share": false, "dilation": true}"#;
    let read: TreeInputs = serde_json::from_str(spelled).unwrap();
    assert_eq!(read, t15);
    // what is written has no such key, and reads back as itself
    let written = serde_json::to_string(&t15).unwrap();
    assert!(!written.contains("flow_share"), "{written}");
    assert_eq!(serde_json::from_str::<TreeInputs>(&written).unwrap(), t15);
    let short: TreeInputs = serde_json::from_str(r#"{"turn": true, "energy": true, "dilation": true}"#).unwrap();
    assert_eq!(short, t15);
    assert_eq!(serde_json::from_str::<TreeInputs>("{}").unwrap(), TreeInputs::default());
    let on = spelled.replace(r#""flow_share": false"#, r#""flow_share": true"#);
    let e = serde_json::from_str::<TreeInputs>(&on).unwrap_err().to_string();
    assert!(e.contains("flow-share") && e.contains("removed") && e.contains("commit e43beac"), "{e}");
    assert!(serde_json::from_str::<TreeInputs>(r#"{"flow_shares": false}"#).is_err());
    // a model file's tree part reads its inputs the same way
    let classes = vec![DosClass::Cw, DosClass::Aw];
    let model =
        DosTrees::try_new(t15.clone(), 24, classes, vec![0.0; 2], vec![leaf(0.1), leaf(-0.1)], None, 0).unwrap();
    let mut file: serde_json::Value = serde_json::to_value(&model).unwrap();
    file["inputs"]["flow_share"] = false.into();
    assert_eq!(serde_json::from_value::<DosTrees>(file.clone()).unwrap(), model);
    file["inputs"]["flow_share"] = true.into();
    let e = serde_json::from_value::<DosTrees>(file).unwrap_err().to_string();
    assert!(e.contains("removed") && e.contains("commit e43beac"), "{e}");
}

/// The change-energy inputs (stop 35's round 5) are the root mean square of each lag's and the
/// slope's per-taxel change and of the since-start block, appended last; they need a source.
#[test]
fn the_energy_inputs_are_the_root_mean_square_of_each_change_block() {
    let layout = Layout::biotac_sp();
    let n = layout.len();
    let inputs = TreeInputs { turn: true, energy: true, ..TreeInputs::default() };
    assert_eq!(inputs.energy_inputs(), 4);
    assert_eq!(inputs.inputs(n), TreeInputs { turn: true, ..TreeInputs::default() }.inputs(n) + 4);
    let frames = synthetic_values(DosClass::N, [0.0, 0.0], 0.3, 5);
    let mut x = TreeExtractor::try_new_on(&inputs, &layout).unwrap();
    let windows: Vec<Vec<f64>> = frames.iter().filter_map(|f| x.push(f).unwrap()).collect();
    let rms = |v: &[f64]| (v.iter().map(|a| a * a).sum::<f64>() / n as f64).sqrt();
    let w = inputs.window.inputs(n);
    let e = inputs.inputs(n) - 4;
    assert_eq!(inputs.energy_at(n), Some(e));
    assert_eq!(inputs.turn_at(n), Some(e - 9));
    let mut moved = false;
    for v in &windows {
        for k in 0..3 {
            assert_eq!(v[e + k], rms(&v[w + k * n..w + (k + 1) * n]), "source {k}");
        }
        // window inputs `both`: the since-start block is the second
        assert_eq!(v[e + 3], rms(&v[n..2 * n]));
        moved |= v[e] > 0.0;
    }
    assert!(moved, "a sliding contact's pattern changes");
    // with the dilation inputs after them, the energy and turn blocks are no longer last:
    // `energy_at` and `turn_at` still find them (stop 36's round 7: the diagnosis read the
    // columns at the end of the vector and printed other inputs under their names)
    let all = TreeInputs { turn: true, energy: true, dilation: true, ..TreeInputs::default() };
    let (e, t) = (all.energy_at(n).unwrap(), all.turn_at(n).unwrap());
    assert_eq!(e, all.inputs(n) - 4 - 3);
    assert_eq!(t, e - 9);
    let mut x = TreeExtractor::try_new_on(&all, &layout).unwrap();
    let full: Vec<Vec<f64>> = frames.iter().filter_map(|f| x.push(f).unwrap()).collect();
    for (v, u) in full.iter().zip(&windows) {
        for k in 0..3 {
            assert_eq!(v[e + k], rms(&v[w + k * n..w + (k + 1) * n]), "source {k}");
        }
        assert_eq!(v[e + 3], u[inputs.energy_at(n).unwrap() + 3], "the since-start energy");
    }
    let map = all.mirror_map(&mirror_of(&layout));
    for k in 0..3 {
        let signs: Vec<f64> = (0..TURN_INPUTS).map(|j| map[t + k * TURN_INPUTS + j].1).collect();
        assert_eq!(signs, TURN_MIRROR_SIGNS, "the turn block of source {k}");
    }
    assert_eq!(TreeInputs::default().turn_at(n), None);
    assert_eq!(TreeInputs::default().energy_at(n), None);
    // nothing to measure: refused
    let mut none = TreeInputs { lags: vec![], slope_windows: 0, energy: true, ..TreeInputs::default() };
    none.window.inputs = WindowInputs::Levels;
    assert!(none.validate().is_err());
    none.slope_windows = 2;
    assert!(none.validate().is_ok());
    assert_eq!(none.energy_inputs(), 1);
}

#[cfg(feature = "train")]
mod trained {
    use super::*;
    use crate::dos::train_trees::{fit_trees, TreeTrainConfig};
    use crate::splitmix::SplitMix;

    /// The trainer's windows (`train_trees::tree_windows`) are, bit for bit, the inputs a
    /// model's streaming extractor (the one the `dos` stage's vote pushes frames through) gives
    /// on the same frames, the rotation-sense and change-energy inputs included.
    #[test]
    fn the_trainers_windows_are_the_streaming_extractors() {
        for energy in [false, true] {
            trainers_windows_are_the_streaming_extractors(TreeInputs { turn: true, energy, ..TreeInputs::default() });
        }
        let t15 = TreeInputs { turn: true, energy: true, dilation: true, ..TreeInputs::default() };
        trainers_windows_are_the_streaming_extractors(t15);
    }

    fn trainers_windows_are_the_streaming_extractors(inputs: TreeInputs) {
        let layout = Layout::biotac_sp();
        let frames = synthetic_values(DosClass::Aw, [0.0, 0.0], 0.3, 11);
        let trainer = crate::dos::train_trees::tree_windows(&frames, &inputs, &layout).unwrap();
        let classes = vec![DosClass::Cw, DosClass::Aw];
        let model =
            DosTrees::try_new(inputs.clone(), 24, classes, vec![0.0; 2], vec![leaf(0.1), leaf(-0.1)], None, 0).unwrap();
        let mut stage = TreeVoteState::try_new(&model, &layout).unwrap().fresh_extractor();
        let streamed: Vec<Vec<f64>> = frames.iter().filter_map(|f| stage.push(f).unwrap()).collect();
        assert_eq!(trainer, streamed);
        let turns = inputs.inputs(24) - 9 - inputs.energy_inputs() - inputs.dilation_inputs();
        assert!(trainer.iter().any(|x| x[turns..turns + 9].iter().any(|v| *v != 0.0)), "the turn inputs are computed");
        assert!(trainer.iter().any(|x| x[turns + 9..].iter().any(|v| *v != 0.0)) || !inputs.energy);
    }

    fn random_inputs(d: usize, rng: &mut SplitMix) -> Vec<f64> {
        (0..d).map(|_| rng.normal()).collect()
    }

    /// The toy problem's class of an input vector: four classes, separable on inputs 3 and 40.
    fn toy_label(x: &[f64]) -> DosClass {
        match (x[3] > 0.0, x[40] > 0.5) {
            (true, true) => DosClass::N,
            (true, false) => DosClass::E,
            (false, true) => DosClass::S,
            (false, false) => DosClass::T,
        }
    }

    /// `n` labelled random input vectors of length `d` for the toy problem ([`toy_label`]).
    fn toy_samples(d: usize, n: usize, rng: &mut SplitMix) -> Vec<(DosClass, Vec<f64>)> {
        (0..n)
            .map(|_| {
                let x = random_inputs(d, rng);
                (toy_label(&x), x)
            })
            .collect()
    }

    #[test]
    fn trees_learn_a_separable_toy_problem() {
        let layout = Layout::biotac_sp();
        // every input searched (colsample 1; the default's half since stop 35's round 4)
        let cfg = TreeTrainConfig {
            mirror_average: false,
            rounds: 30,
            colsample: 1.0,
            inputs: TreeInputs::default(),
            ..TreeTrainConfig::default()
        };
        let d = cfg.inputs.inputs(layout.len());
        let mut rng = SplitMix::new(5);
        let samples = toy_samples(d, 2000, &mut rng);
        let m = fit_trees(&samples, &layout, &cfg).unwrap();
        assert_eq!(m.classes(), &[DosClass::N, DosClass::E, DosClass::S, DosClass::T]);
        let mut ok = 0;
        for _ in 0..500 {
            let x = random_inputs(d, &mut rng);
            ok += usize::from(m.classify(&x).unwrap().class == toy_label(&x));
        }
        assert!(ok >= 490, "{ok} of 500");
        // the compact, interleaved walk adds exactly what the arrays' plain walk gives, in order
        for _ in 0..50 {
            let x = random_inputs(d, &mut rng);
            let mut want = m.base().to_vec();
            for (t, tree) in m.trees().iter().enumerate() {
                let k = want.len();
                want[t % k] += tree.eval(&x);
            }
            assert_eq!(m.logits(&x).unwrap(), want);
        }
        // deterministic for a seed
        assert_eq!(fit_trees(&samples, &layout, &cfg).unwrap(), m);
    }

    #[test]
    fn input_subsampling_limits_each_tree_to_its_drawn_inputs() {
        let layout = Layout::biotac_sp();
        let base = TreeTrainConfig {
            mirror_average: false,
            rounds: 12,
            colsample: 1.0,
            inputs: TreeInputs::default(),
            ..TreeTrainConfig::default()
        };
        let d = base.inputs.inputs(layout.len());
        let samples = toy_samples(d, 800, &mut SplitMix::new(11));
        let features = |m: &crate::dos::DosTrees| -> Vec<std::collections::BTreeSet<usize>> {
            m.trees()
                .iter()
                .map(|t| (0..t.left.len()).filter(|&i| t.left[i] != 0).map(|i| t.feature[i]).collect())
                .collect()
        };
        // the smallest share: every tree draws one input, so every split of a tree is on one input
        let one = fit_trees(&samples, &layout, &TreeTrainConfig { colsample: 1e-9, ..base.clone() }).unwrap();
        assert!(features(&one).iter().all(|f| f.len() <= 1));
        assert!(features(&one).iter().flatten().collect::<std::collections::BTreeSet<_>>().len() > 1, "drawn afresh");
        // 1 (the default before stop 35's round 4) draws nothing: the trees are those of the full search, and a share below
        // 1 changes them, deterministically for a seed
        let all = fit_trees(&samples, &layout, &base).unwrap();
        let half_cfg = TreeTrainConfig { colsample: 0.5, ..base.clone() };
        let half = fit_trees(&samples, &layout, &half_cfg).unwrap();
        assert_ne!(half, all);
        assert_eq!(fit_trees(&samples, &layout, &half_cfg).unwrap(), half);
        // the full search finds the two informative inputs first
        assert!(features(&all)[0].contains(&3) || features(&all)[0].contains(&40));
        for bad in [0.0, -0.5, 1.5, f64::NAN] {
            assert!(TreeTrainConfig { colsample: bad, ..base.clone() }.validate().is_err(), "{bad}");
        }
        // always written (a file without it reads the default's 0.5): a config round-trips
        for cfg in [base.clone(), half_cfg.clone(), TreeTrainConfig::default()] {
            let text = serde_json::to_string(&cfg).unwrap();
            assert!(text.contains("\"colsample\":"), "{text}");
            assert_eq!(serde_json::from_str::<TreeTrainConfig>(&text).unwrap(), cfg);
        }
        let absent: TreeTrainConfig = serde_json::from_str("{}").unwrap();
        assert_eq!(absent.colsample, 0.5);
    }

    #[test]
    fn a_mirror_averaged_model_gives_a_mirrored_input_the_mirrored_posterior() {
        let layout = Layout::biotac_sp();
        let cfg = TreeTrainConfig { rounds: 10, ..TreeTrainConfig::default() };
        let d = cfg.inputs.inputs(layout.len());
        let mut rng = SplitMix::new(9);
        let samples: Vec<(DosClass, Vec<f64>)> =
            (0..700).map(|k| (DosClass::ALL[k % 7], random_inputs(d, &mut rng))).collect();
        let m = fit_trees(&samples, &layout, &cfg).unwrap();
        let map = m.inputs().mirror_map(m.mirror().unwrap());
        for _ in 0..50 {
            let x = random_inputs(d, &mut rng);
            let y: Vec<f64> = map.iter().map(|&(j, s)| s * x[j]).collect();
            let (px, py) = (m.classify(&x).unwrap(), m.classify(&y).unwrap());
            assert_eq!(py.class, px.class.mirrored());
            for (c, class) in m.classes().iter().enumerate() {
                let mc = m.classes().iter().position(|k| *k == class.mirrored()).unwrap();
                assert!((px.posterior[c] - py.posterior[mc]).abs() < 1e-12);
            }
        }
    }
}
