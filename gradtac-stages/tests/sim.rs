//! The simulator: determinism by seed, ground truth consistent with the script, the model's
//! terms checked analytically (noise-free), 12-bit quantisation and saturation at the extremes,
//! a full-force press that saturates and still runs through the event chain, the CSV writer,
//! and the eight trajectories tracked in the right direction by the event pipeline.

use gradtac_stages::contour::{Contour, ContourConfig};
use gradtac_stages::events::{Events, EventsConfig, Threshold};
use gradtac_stages::interpolate::{GridConfig, Interpolate, InterpolateConfig};
use gradtac_stages::savgol::{SavGol, SavGolConfig};
use gradtac_stages::sim::{
    Finger, ForceProfile, GraspConfig, Path, Scene, SensorModel, Simulator, Trajectory, MOVE_END_S, MOVE_START_S,
    TRAJECTORY_HALF_MM, TRAJECTORY_RADIUS_MM,
};
use gradtac_stages::slip::SlipClass;
use gradtac_stages::track::{ContactState, Track, TrackConfig};
use gradtac_stages::window::{Aggregate, Window, WindowConfig};
use gradtac_stream::{Layout, StageExt, Timestamp};

fn sim(model: SensorModel, seed: u64) -> Simulator {
    Simulator::try_new(Layout::biotac_sp(), model, seed).unwrap()
}

fn quiet() -> SensorModel {
    SensorModel { noise_counts: 0.0, drift_counts_per_s: 0.0, damping_s: 0.0, ..Default::default() }
}

#[test]
fn same_seed_same_recording_and_fingers_are_independent() {
    let l = Layout::biotac_sp();
    let scene = Scene::grasp(SlipClass::RotationalCw, &GraspConfig::default(), &l);
    let a = sim(SensorModel::default(), 7).run(&scene).unwrap();
    let b = sim(SensorModel::default(), 7).run(&scene).unwrap();
    assert_eq!(a, b);
    let c = sim(SensorModel::default(), 8).run(&scene).unwrap();
    assert_ne!(a.frames[150].frame.values, c.frames[150].frame.values);
    // the first finger alone reads exactly what it reads beside the thumb
    let alone = Scene { fingers: vec![scene.fingers[1].clone()], ..scene.clone() };
    let one = sim(SensorModel::default(), 7).run(&alone).unwrap();
    let ff: Vec<_> = a.of_sensor("ff").map(|f| f.frame.clone()).collect();
    assert_eq!(ff, one.taxel_frames());
    // interleaved th, ff at each step, seq and time per step at 100 Hz
    assert_eq!(a.frames.len(), 2 * 200);
    for (k, pair) in a.frames.chunks(2).enumerate() {
        assert_eq!((pair[0].frame.sensor.as_str(), pair[1].frame.sensor.as_str()), ("th", "ff"));
        assert_eq!(pair[0].frame.seq, k as u64);
        assert_eq!(pair[1].frame.time, Timestamp::at_rate(k as u64, 100.0));
    }
}

#[test]
fn ground_truth_follows_the_script() {
    let l = Layout::biotac_sp();
    let [cx, cy] = l.extent().centre();
    let s = sim(SensorModel::default(), 1);
    for kind in Trajectory::ALL {
        let scene = Scene::trajectory(kind, 2.0, 3.0, &l);
        let rec = s.run(&scene).unwrap();
        assert_eq!(rec.frames.len(), 300);
        let at = |t: f64| rec.frames[(t * 100.0).round() as usize].truth.clone();
        assert_eq!(at(0.05).contact_mm, None);
        assert_eq!(at(0.05).force_n, 0.0);
        assert!((at(0.2).force_n - 1.5).abs() < 1e-9);
        assert!((at(1.0).force_n - 3.0).abs() < 1e-12);
        assert_eq!(at(2.95).contact_mm, None);
        let p0 = at(MOVE_START_S).contact_mm.unwrap();
        let p1 = at(MOVE_END_S).contact_mm.unwrap();
        let mid = at((MOVE_START_S + MOVE_END_S) / 2.0).contact_mm.unwrap();
        let d = [p1[0] - p0[0], p1[1] - p0[1]];
        let h = TRAJECTORY_HALF_MM;
        let want = match kind {
            Trajectory::Up => [0.0, 2.0 * h],
            Trajectory::Down => [0.0, -2.0 * h],
            Trajectory::Left => [-2.0 * h, 0.0],
            Trajectory::Right => [2.0 * h, 0.0],
            Trajectory::DiagonalUp => [2.0 * h / 2f64.sqrt(), 2.0 * h / 2f64.sqrt()],
            Trajectory::DiagonalDown => [2.0 * h / 2f64.sqrt(), -2.0 * h / 2f64.sqrt()],
            Trajectory::CircleCw | Trajectory::CircleCcw => [0.0, 0.0], // a full turn
        };
        assert!((d[0] - want[0]).abs() < 1e-9 && (d[1] - want[1]).abs() < 1e-9, "{kind:?}: {d:?}");
        if matches!(kind, Trajectory::CircleCw | Trajectory::CircleCcw) {
            // radius, and the sense of turning: a quarter turn in, CCW is above the centre
            for f in &rec.frames[50..250] {
                let p = f.truth.contact_mm.unwrap();
                assert!(((p[0] - cx).hypot(p[1] - cy) - TRAJECTORY_RADIUS_MM).abs() < 1e-9);
            }
            let q = at(MOVE_START_S + 0.5).contact_mm.unwrap();
            assert_eq!(q[1] > cy, kind == Trajectory::CircleCcw, "{kind:?}: {q:?}");
        } else {
            assert!((mid[0] - cx).abs() < 1e-9 && (mid[1] - cy).abs() < 1e-9, "{kind:?} passes the centre");
        }
        assert!(rec.frames.iter().all(|f| f.truth.slip == SlipClass::Stable && f.truth.slip_onset.is_none()));
    }
    // grasps: class inside the slip interval, onset on every frame
    let g = GraspConfig::default();
    let rec = s.run(&Scene::grasp(SlipClass::LongitudinalDown, &g, &l)).unwrap();
    let onset = Timestamp::from_secs_f64(g.onset_s).unwrap();
    for f in &rec.frames {
        let t = f.frame.time.as_secs_f64();
        let slipping = t >= g.onset_s && t < g.onset_s + g.slip_mm / g.slip_mm_s;
        assert_eq!(f.truth.slip, if slipping { SlipClass::LongitudinalDown } else { SlipClass::Stable }, "t = {t}");
        assert_eq!(f.truth.slip_onset, Some(onset));
    }
    assert_eq!(rec.truth("th", 150).unwrap().contact_mm.unwrap()[1], cy + g.slip_mm); // down is +y on the thumb
    assert_eq!(rec.truth("ff", 150).unwrap().contact_mm.unwrap()[1], cy - g.slip_mm);
}

/// Noise, drift and damping off: every value is `round(b + g·F·exp(−r²/2w²))` exactly.
#[test]
fn noise_free_model_matches_its_formula() {
    let l = Layout::biotac_sp();
    let s = sim(quiet(), 3);
    let scene = Scene::force_ramp(2.0, [1.0, -2.0], 1.0);
    let rec = s.run(&scene).unwrap();
    let p = s.params("ff");
    let w2 = 2.5f64.powi(2) + 1.0;
    for f in &rec.frames {
        let force = f.truth.force_n;
        for (i, pos) in l.positions().iter().enumerate() {
            let r2 = (pos[0] - 1.0).powi(2) + (pos[1] + 2.0).powi(2);
            let want = (p.baseline[i] + p.gain[i] * force * (-r2 / (2.0 * w2)).exp()).clamp(0.0, 4095.0).round();
            assert_eq!(f.frame.values[i], want, "t {} taxel {i}", f.frame.time);
        }
    }
    // the parameters are in their configured ranges, with both signs present
    assert!(p.baseline.iter().all(|b| (1800.0..3600.0).contains(b)));
    assert!(p.gain.iter().all(|g| (40.0..80.0).contains(&g.abs())));
    assert!(p.gain.iter().any(|&g| g > 0.0) && p.gain.iter().any(|&g| g < 0.0));
}

/// A force step through the fluid lag: after one time constant the change is 1 − 1/e of
/// the final one (to the quantisation), and it grows monotonically.
#[test]
fn damping_is_a_first_order_lag() {
    let model = SensorModel {
        damping_s: 0.1,
        noise_counts: 0.0,
        drift_counts_per_s: 0.0,
        gain_counts_per_n: [100.0, 100.0],
        flip_fraction: 0.0,
        ..Default::default()
    };
    let s = sim(model, 1);
    let at = Layout::biotac_sp().positions()[23];
    let scene = Scene {
        name: "step".into(),
        duration_s: 1.5,
        fingers: vec![Finger {
            sensor: "ff".into(),
            diameter_mm: 0.0,
            path: Path::Fixed(at),
            force: ForceProfile(vec![(0.095, 0.0), (0.1, 10.0)]),
        }],
        slip: None,
    };
    let rec = s.run(&scene).unwrap();
    let v: Vec<f64> = rec.frames.iter().map(|f| f.frame.values[23]).collect();
    let (rest, end) = (v[5], v[149]);
    assert!((rest - end - 1000.0).abs() <= 1.0, "{rest} → {end}"); // 100 counts/N · 10 N, falling
                                                                   // the target steps at frame 10, which is the lag's first update: after n updates the
                                                                   // fraction is 1 − e^{−n·Δt/τ}, so one time constant (10 updates) in is frame 19
    let frac = (rest - v[19]) / (rest - end);
    assert!((frac - (1.0 - (-1.0f64).exp())).abs() < 0.005, "{frac}");
    assert!(v[10..].windows(2).all(|w| w[1] <= w[0]));
}

#[test]
fn values_are_12_bit_counts_and_drift_is_slow() {
    let l = Layout::biotac_sp();
    let s = sim(SensorModel::default(), 11);
    let rec = s.run(&Scene::trajectory(Trajectory::CircleCcw, 5.0, 8.0, &l)).unwrap();
    for f in &rec.frames {
        assert_eq!(f.frame.values.len(), 24);
        assert!(f.frame.values.iter().all(|&v| (0.0..=4095.0).contains(&v) && v.fract() == 0.0));
    }
    // before the press the values sit at the baseline within noise (σ 2 counts) and drift
    let p = s.params("ff");
    for i in 0..24 {
        let mean = rec.frames[..10].iter().map(|f| f.frame.values[i]).sum::<f64>() / 10.0;
        assert!((mean - p.baseline[i]).abs() < 3.0, "taxel {i}: {mean} vs {}", p.baseline[i]);
    }
}

#[test]
fn quantisation_and_saturation_extremes() {
    let l = Layout::biotac_sp();
    let scene = Scene::force_ramp(2.0, l.extent().centre(), 1.0);
    // a baseline at full scale stays there; at zero it stays at zero; noise cannot leave the range
    for (b, want) in [(4095.0, 4095.0), (0.0, 0.0)] {
        let m = SensorModel {
            baseline_counts: [b, b],
            gain_counts_per_n: [0.0, 0.0],
            noise_counts: 50.0,
            drift_counts_per_s: 0.0,
            ..Default::default()
        };
        let rec = sim(m, 2).run(&scene).unwrap();
        let hits = rec.frames.iter().flat_map(|f| f.frame.values.iter()).filter(|&&v| v == want).count();
        assert!(rec.frames.iter().all(|f| f.frame.values.iter().all(|&v| (0.0..=4095.0).contains(&v))));
        assert!(hits > rec.frames.len() * 24 / 3, "{b}: {hits}"); // about half the samples clip
    }
    // a smaller ADC full scale is honoured; half a count rounds to the nearest integer
    let m = SensorModel { adc_max: 1023.0, baseline_counts: [1000.0, 1000.0], ..quiet() };
    let rec = sim(m, 2).run(&scene).unwrap();
    assert!(rec.frames.iter().all(|f| f.frame.values.iter().all(|&v| (0.0..=1023.0).contains(&v) && v.fract() == 0.0)));
    let m = SensorModel { baseline_counts: [2000.5, 2000.5], gain_counts_per_n: [0.0, 0.0], ..quiet() };
    let rec = sim(m, 2).run(&scene).unwrap();
    assert!(rec.frames.iter().all(|f| f.frame.values.iter().all(|&v| v == 2001.0)));
}

/// 80 N with a 5 mm indenter: taxels under it rail at 0 (falling) and 4095 (rising), and the
/// event chain runs through the railed values (ln of 0 is floored, never NaN) to a contact.
#[test]
fn full_force_press_saturates_and_the_chain_survives() {
    let l = Layout::biotac_sp();
    let c = l.extent().centre();
    let scene = Scene {
        name: "full_force".into(),
        duration_s: 1.0,
        fingers: vec![Finger {
            sensor: "ff".into(),
            diameter_mm: 5.0,
            path: Path::Fixed(c),
            force: ForceProfile(vec![(0.1, 0.0), (0.3, 80.0)]),
        }],
        slip: None,
    };
    let rec = sim(SensorModel::default(), 5).run(&scene).unwrap();
    let last = &rec.frames.last().unwrap().frame.values;
    assert!(last.contains(&0.0), "{last:?}");
    assert!(last.contains(&4095.0), "{last:?}");
    let sg = SavGol::try_with_rate(24, SavGolConfig::default(), 100.0).unwrap();
    let ev = Events::try_new(24, EventsConfig { threshold: Threshold::Uniform(0.002), ..Default::default() }).unwrap();
    let w = Window::try_new(&WindowConfig { frames: Some(100), aggregate: Aggregate::Count, ..Default::default() })
        .unwrap();
    let icfg = InterpolateConfig { grid: GridConfig { nx: 32, ..Default::default() }, ..Default::default() };
    let i = Interpolate::try_new(&icfg, &l).unwrap();
    let cc = Contour::try_new(&ContourConfig::default()).unwrap();
    let t = Track::try_new(&TrackConfig::default()).unwrap();
    let pts = sg.then(ev).then(w).then(i).then(cc).then(t).run_all(rec.taxel_frames()).unwrap();
    let p = pts.last().unwrap();
    assert_eq!(p.state, ContactState::Contact);
    assert!(p.x_mm.is_finite() && p.y_mm.is_finite() && p.area_mm2 > 0.0);
    assert!((p.x_mm - c[0]).hypot(p.y_mm - c[1]) < 6.0, "{p:?}");
}

#[test]
fn csv_has_the_documented_columns() {
    let l = Layout::biotac_sp();
    let rec = sim(SensorModel::default(), 1)
        .run(&Scene::grasp(SlipClass::RotationalCcw, &GraspConfig::default(), &l))
        .unwrap();
    let (mut data, mut truth) = (Vec::new(), Vec::new());
    rec.write_csv_to(&mut data, &mut truth).unwrap();
    let data = String::from_utf8(data).unwrap();
    let truth = String::from_utf8(truth).unwrap();
    let mut lines = data.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(head.len(), 48);
    assert_eq!((head[0], head[23], head[24], head[47]), ("th_e1", "th_e24", "ff_e1", "ff_e24"));
    let rows: Vec<Vec<f64>> = lines.map(|r| r.split(',').map(|v| v.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), 200);
    assert_eq!(rows[120][..24], rec.frames[240].frame.values[..]);
    assert_eq!(rows[120][24..], rec.frames[241].frame.values[..]);
    let mut tl = truth.lines();
    assert_eq!(tl.next().unwrap(), "time_s,th_x_mm,th_y_mm,th_force_n,ff_x_mm,ff_y_mm,ff_force_n,slip,slip_onset_s");
    let t: Vec<Vec<&str>> = tl.map(|r| r.split(',').collect()).collect();
    assert_eq!(t.len(), 200);
    assert_eq!(t[0][1], ""); // no contact yet
    assert_eq!(t[110][7], "rotational_ccw");
    assert_eq!(t[110][8], "1");
    assert_eq!(t[0][0], "0");
    assert_eq!(t[150][0], "1.5");
    // files on disk
    let dir = std::env::temp_dir().join(format!("gradtac-sim-csv-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    rec.write_csv(&dir.join("rec.csv"), &dir.join("truth.csv")).unwrap();
    assert_eq!(std::fs::read_to_string(dir.join("rec.csv")).unwrap(), data);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The eight trajectories through savgol → events → counts over 10 frames → natural
/// neighbour → contour (min area 30 mm²) → track: the track's net displacement during the
/// movement points along the scripted one (cosine > 0.8 — measured 0.88 worst, the diagonal
/// pulled toward the taxels' rows; circles: the signed area swept has
/// the scripted sense); mean distance to the true contact below 2.5 mm (measured 1.3–1.8 mm,
/// 0.05–0.07 of the sensor's ≈ 26 mm width; the paper's event contours: 0.09).
#[test]
fn trajectories_are_tracked_in_the_scripted_direction() {
    let l = Layout::biotac_sp();
    let s = sim(SensorModel::default(), 4);
    for kind in Trajectory::ALL {
        let rec = s.run(&Scene::trajectory(kind, 2.0, 4.0, &l)).unwrap();
        let sg = SavGol::try_with_rate(24, SavGolConfig::default(), 100.0).unwrap();
        let ev =
            Events::try_new(24, EventsConfig { threshold: Threshold::Uniform(0.002), ..Default::default() }).unwrap();
        let w = Window::try_new(&WindowConfig { frames: Some(10), aggregate: Aggregate::Count, ..Default::default() })
            .unwrap();
        let icfg = InterpolateConfig {
            grid: GridConfig { nx: 32, ..Default::default() },
            incremental: true,
            ..Default::default()
        };
        let i = Interpolate::try_new(&icfg, &l).unwrap();
        let cc = Contour::try_new(&ContourConfig { min_peak: 2.0, min_area_mm2: 30.0, ..Default::default() }).unwrap();
        let t = Track::try_new(&TrackConfig::default()).unwrap();
        let pts = sg.then(ev).then(w).then(i).then(cc).then(t).run_all(rec.taxel_frames()).unwrap();
        let moving: Vec<_> = pts
            .iter()
            .filter(|p| {
                let t = p.time.as_secs_f64();
                p.state == ContactState::Contact && t > MOVE_START_S + 0.1 && t < MOVE_END_S
            })
            .collect();
        assert!(moving.len() > 150, "{kind:?}: {} contact points", moving.len());
        let err = moving
            .iter()
            .map(|p| {
                let c = rec.truth("ff", p.seq).unwrap().contact_mm.unwrap();
                (p.x_mm - c[0]).hypot(p.y_mm - c[1])
            })
            .sum::<f64>()
            / moving.len() as f64;
        eprintln!("{:>13}: mean localisation error {err:.2} mm over {} points", kind.name(), moving.len());
        let (a, b) = (moving[0], moving[moving.len() - 1]);
        match kind {
            Trajectory::CircleCw | Trajectory::CircleCcw => {
                // shoelace over the track: positive = counter-clockwise
                let area: f64 = moving.windows(2).map(|w| w[0].x_mm * w[1].y_mm - w[1].x_mm * w[0].y_mm).sum();
                assert_eq!(area > 0.0, kind == Trajectory::CircleCcw, "{kind:?}: swept {area}");
            }
            _ => {
                let ta = rec.truth("ff", a.seq).unwrap().contact_mm.unwrap();
                let tb = rec.truth("ff", b.seq).unwrap().contact_mm.unwrap();
                let (d, want) = ([b.x_mm - a.x_mm, b.y_mm - a.y_mm], [tb[0] - ta[0], tb[1] - ta[1]]);
                let cos = (d[0] * want[0] + d[1] * want[1]) / (d[0].hypot(d[1]) * want[0].hypot(want[1]));
                eprintln!("{:>13}: direction cosine {cos:.3}", kind.name());
                assert!(cos > 0.8, "{kind:?}: track {d:?} vs truth {want:?}");
            }
        }
        assert!(err < 2.5, "{kind:?}: {err} mm");
    }
}

mod props {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

        /// Any valid model, seed, indenter and force: every value is an integer count in
        /// `[0, adc_max]`, and the same seed gives the same recording.
        #[test]
        fn any_model_gives_in_range_integers_deterministically(
            seed in any::<u64>(),
            adc_max in (1u32..8192).prop_map(f64::from),
            b in (0.0f64..1.0, 0.0f64..1.0),
            g in (0.0f64..500.0, 0.0f64..500.0),
            flip in 0.0f64..=1.0,
            noise in 0.0f64..100.0,
            drift in 0.0f64..50.0,
            damping in 0.0f64..0.5,
            force in 0.0f64..200.0,
            diameter in 0.0f64..20.0,
            at in (-30.0f64..30.0, -30.0f64..30.0),
        ) {
            let (b0, b1) = (b.0.min(b.1) * adc_max, b.0.max(b.1) * adc_max);
            let model = SensorModel {
                adc_max,
                baseline_counts: [b0, b1],
                gain_counts_per_n: [g.0.min(g.1), g.0.max(g.1)],
                flip_fraction: flip,
                noise_counts: noise,
                drift_counts_per_s: drift,
                damping_s: damping,
                ..Default::default()
            };
            let scene = Scene {
                name: "prop".into(),
                duration_s: 0.3,
                fingers: vec![Finger {
                    sensor: "ff".into(),
                    diameter_mm: diameter,
                    path: Path::Line { from: [at.0, at.1], to: [0.0, 0.0], t0_s: 0.0, t1_s: 0.3 },
                    force: ForceProfile(vec![(0.0, 0.0), (0.2, force)]),
                }],
                slip: None,
            };
            let s = Simulator::try_new(Layout::biotac_sp(), model, seed).unwrap();
            let a = s.run(&scene).unwrap();
            for f in &a.frames {
                for &v in &f.frame.values {
                    prop_assert!(v >= 0.0 && v <= adc_max && v.fract() == 0.0, "{v}");
                }
            }
            prop_assert_eq!(a, s.run(&scene).unwrap());
        }
    }
}
