//! Windows: incremental sums against brute force, chunking invariance, reset.

use gradtac_stages::window::{Aggregate, Window, WindowAggregate, WindowConfig, WindowKind};
use gradtac_stages::{EventBatch, TactileEvent};
use gradtac_stream::{Stage, StageExt, Timestamp};
use proptest::prelude::*;

const TAXELS: u16 = 5;
const FRAME_NS: i64 = 10_000_000; // 100 Hz

/// Batches at 100 Hz (with jitter in event times inside each frame interval).
fn arb_batches() -> impl Strategy<Value = Vec<EventBatch>> {
    prop::collection::vec(prop::collection::vec((0u16..TAXELS, any::<bool>(), 0i64..FRAME_NS), 0..6), 1..60).prop_map(
        |frames| {
            frames
                .into_iter()
                .enumerate()
                .map(|(k, evs)| {
                    let t = (k as i64 + 1) * FRAME_NS;
                    let mut events: Vec<TactileEvent> = evs
                        .into_iter()
                        .map(|(taxel, up, dt)| TactileEvent {
                            time: Timestamp(t - dt),
                            taxel,
                            polarity: if up { 1 } else { -1 },
                        })
                        .collect();
                    events.sort_by_key(|e| (e.time, e.taxel));
                    EventBatch { sensor: "ff".into(), time: Timestamp(t), seq: k as u64, taxels: TAXELS, events }
                })
                .collect()
        },
    )
}

fn brute(events: impl Iterator<Item = TactileEvent>, agg: Aggregate) -> Vec<f64> {
    let mut v = vec![0.0; TAXELS as usize];
    for e in events {
        v[e.taxel as usize] += match agg {
            Aggregate::Count => 1.0,
            _ => e.polarity as f64,
        };
    }
    v
}

fn agg() -> impl Strategy<Value = Aggregate> {
    prop::sample::select(vec![Aggregate::Signed, Aggregate::Count, Aggregate::Split])
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn sliding_by_frames_equals_brute_force(b in arb_batches(), n in 1u64..8, step in 1u64..4, a in agg()) {
        let cfg = WindowConfig { frames: Some(n), step, aggregate: a, ..Default::default() };
        let out = Window::try_new(&cfg).unwrap().run_all(b.clone()).unwrap();
        let emitted: Vec<usize> = (0..b.len()).filter(|k| (k + 1) as u64 % step == 0).collect();
        prop_assert_eq!(out.len(), emitted.len());
        for (o, &k) in out.iter().zip(&emitted) {
            let lo = (k + 1).saturating_sub(n as usize);
            let want = brute(b[lo..=k].iter().flat_map(|x| x.events.iter().copied()), a);
            prop_assert_eq!(&o.values, &want);
            prop_assert_eq!((o.start, o.end, o.seq, o.frames), (b[lo].time, b[k].time, k as u64, (k + 1 - lo) as u64));
            if a == Aggregate::Split {
                let s = o.split.as_ref().unwrap();
                for t in 0..TAXELS as usize {
                    prop_assert_eq!(s.positive[t] - s.negative[t], o.values[t]);
                }
            }
        }
    }

    #[test]
    fn sliding_by_duration_equals_brute_force(b in arb_batches(), ms in 1u32..80, a in agg()) {
        let d = ms as i64 * 1_000_000;
        let cfg = WindowConfig { duration_ms: Some(ms as f64), aggregate: a, ..Default::default() };
        let out = Window::try_new(&cfg).unwrap().run_all(b.clone()).unwrap();
        prop_assert_eq!(out.len(), b.len());
        for (o, x) in out.iter().zip(&b) {
            let t = x.time.as_nanos();
            let want = brute(b.iter().flat_map(|y| y.events.iter().copied()).filter(|e| e.time.as_nanos() > t - d && e.time.as_nanos() <= t), a);
            prop_assert_eq!(&o.values, &want);
            prop_assert_eq!((o.start, o.end), (Timestamp(t - d), x.time));
        }
    }

    /// Tumbling windows partition the stream: every event is counted exactly once, in the
    /// window that holds its time (duration) or its frame (frames).
    #[test]
    fn tumbling_windows_partition_the_events(b in arb_batches(), n in 1u64..8, ms in 5u32..60) {
        let total = brute(b.iter().flat_map(|x| x.events.iter().copied()), Aggregate::Count);
        for cfg in [
            WindowConfig { kind: WindowKind::Tumbling, frames: Some(n), aggregate: Aggregate::Count, ..Default::default() },
            WindowConfig { kind: WindowKind::Tumbling, duration_ms: Some(ms as f64), aggregate: Aggregate::Count, ..Default::default() },
        ] {
            let out = Window::try_new(&cfg).unwrap().run_all(b.clone()).unwrap();
            let mut sum = vec![0.0; TAXELS as usize];
            for o in &out {
                for (s, v) in sum.iter_mut().zip(&o.values) { *s += v; }
            }
            prop_assert_eq!(&sum, &total, "{:?}", cfg);
            if cfg.duration_ms.is_some() {
                // windows are disjoint, ordered and each event lies in its window's span
                for w in out.windows(2) { prop_assert!(w[0].end <= w[1].start); }
                for o in &out {
                    let inside = brute(b.iter().flat_map(|x| x.events.iter().copied()).filter(|e| e.time >= o.start && e.time < o.end), Aggregate::Count);
                    prop_assert_eq!(&o.values, &inside);
                }
            } else {
                let full = b.len() as u64 / n;
                prop_assert_eq!(out.len() as u64, full + u64::from(b.len() as u64 % n != 0));
            }
        }
    }

    #[test]
    fn decaying_equals_brute_force(b in arb_batches(), tau in 1u64..10, a in agg(), by_time in any::<bool>()) {
        let cfg = if by_time {
            WindowConfig { kind: WindowKind::Decaying, duration_ms: Some(tau as f64 * 10.0), aggregate: a, ..Default::default() }
        } else {
            WindowConfig { kind: WindowKind::Decaying, frames: Some(tau), aggregate: a, ..Default::default() }
        };
        let out = Window::try_new(&cfg).unwrap().run_all(b.clone()).unwrap();
        for (k, o) in out.iter().enumerate() {
            let mut want = vec![0.0; TAXELS as usize];
            for (j, x) in b[..=k].iter().enumerate() {
                for e in &x.events {
                    let w = if by_time {
                        (-((b[k].time - e.time) as f64) / (tau as f64 * 1e7)).exp()
                    } else {
                        (-((k - j) as f64) / tau as f64).exp()
                    };
                    want[e.taxel as usize] += w * if a == Aggregate::Count { 1.0 } else { e.polarity as f64 };
                }
            }
            for (x, y) in o.values.iter().zip(&want) {
                prop_assert!((x - y).abs() < 1e-9, "{} vs {}", x, y);
            }
        }
    }

    /// Feeding batches one at a time (outputs collected per push) equals feeding them all at
    /// once, for every kind; after `finish` (or `reset`) a second run gives the same output.
    #[test]
    fn chunking_and_reset_invariance(b in arb_batches(), kind in prop::sample::select(vec![WindowKind::Tumbling, WindowKind::Sliding, WindowKind::Decaying]),
                                     by_time in any::<bool>(), cut in 0usize..60) {
        let cfg = WindowConfig {
            kind,
            frames: if by_time { None } else { Some(4) },
            duration_ms: if by_time { Some(35.0) } else { None },
            ..Default::default()
        };
        let mut w = Window::try_new(&cfg).unwrap();
        let all = w.run_all(b.clone()).unwrap();
        let mut pieces: Vec<WindowAggregate> = Vec::new();
        let cut = cut.min(b.len());
        let mut out = Vec::new();
        for x in &b[..cut] { w.push(x.clone(), &mut out).unwrap(); pieces.append(&mut out); }
        for x in &b[cut..] { let mut o2 = Vec::new(); w.push(x.clone(), &mut o2).unwrap(); pieces.extend(o2); }
        w.finish(&mut pieces).unwrap();
        prop_assert_eq!(&pieces, &all);
        // reset mid-stream forgets everything
        let mut junk = Vec::new();
        w.push(b[0].clone(), &mut junk).unwrap();
        w.reset();
        prop_assert_eq!(w.run_all(b.clone()).unwrap(), all);
    }
}

#[test]
fn delays_are_documented_values() {
    let t = |f: Option<u64>, d: Option<f64>, kind| {
        Window::try_new(&WindowConfig { kind, frames: f, duration_ms: d, ..Default::default() }).unwrap().delay()
    };
    assert_eq!(t(Some(5), None, WindowKind::Tumbling).frames, 4);
    assert_eq!(t(None, Some(50.0), WindowKind::Tumbling).nanos, 50_000_000);
    assert_eq!(t(Some(5), None, WindowKind::Sliding), gradtac_stream::Delay::ZERO);
    assert_eq!(t(Some(5), None, WindowKind::Decaying), gradtac_stream::Delay::ZERO);
}

#[test]
fn config_from_scene_table() {
    let c: WindowConfig =
        serde_json::from_str(r#"{"kind": "tumbling", "duration_ms": 50.0, "aggregate": "split"}"#).unwrap();
    assert_eq!((c.kind, c.aggregate, c.step), (WindowKind::Tumbling, Aggregate::Split, 1));
    assert!(serde_json::from_str::<WindowConfig>(r#"{"size": 3}"#).is_err());
    assert!(Window::try_new(&WindowConfig { kind: WindowKind::Tumbling, step: 2, ..Default::default() }).is_err());
}

/// Regression (proptest): an event in a frameless window before the first frame's window was
/// counted in the frame's window; it now gets its own window (`frames = 0`).
#[test]
fn regression_event_before_the_first_frames_duration_window() {
    let cfg = WindowConfig {
        kind: WindowKind::Tumbling,
        duration_ms: Some(9.0),
        aggregate: Aggregate::Count,
        ..Default::default()
    };
    let b = EventBatch {
        sensor: "ff".into(),
        time: Timestamp(10_000_000),
        seq: 0,
        taxels: TAXELS,
        events: vec![TactileEvent { time: Timestamp(8_999_999), taxel: 0, polarity: -1 }],
    };
    let out = Window::try_new(&cfg).unwrap().run_all([b]).unwrap();
    assert_eq!(out.len(), 2);
    assert_eq!((out[0].start, out[0].end, out[0].frames), (Timestamp(0), Timestamp(9_000_000), 0));
    assert_eq!(out[0].values, vec![1.0, 0.0, 0.0, 0.0, 0.0]);
    assert_eq!((out[1].frames, out[1].values[0]), (1, 0.0));
}
