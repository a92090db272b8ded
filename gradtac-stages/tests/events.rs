//! Log-change events: invariants (proptest) and the extremes named in the issue.

use gradtac_stages::events::{EventGapPolicy, Events, EventsConfig, NonFinitePolicy, Threshold};
use gradtac_stages::savgol::{SavGol, SavGolConfig, SavGolMode};
use gradtac_stages::{Error, EventBatch, TactileEvent};
use gradtac_stream::{Stage, StageExt, TaxelFrame, Timestamp};
use proptest::prelude::*;

const PERIOD_NS: i64 = 10_000_000; // 100 Hz

fn frame(k: u64, values: Vec<f64>) -> TaxelFrame {
    TaxelFrame::new("ff".into(), Timestamp(k as i64 * PERIOD_NS), k, values)
}

fn frames(rows: &[Vec<f64>]) -> Vec<TaxelFrame> {
    rows.iter().enumerate().map(|(k, v)| frame(k as u64, v.clone())).collect()
}

fn cfg(tau: f64) -> EventsConfig {
    EventsConfig { threshold: Threshold::Uniform(tau), ..Default::default() }
}

/// Push every frame without `finish` (which resets), so the state can be inspected after.
fn push_all(ev: &mut Events, fs: Vec<TaxelFrame>) -> Vec<EventBatch> {
    let mut out = Vec::new();
    for f in fs {
        ev.push(f, &mut out).unwrap();
    }
    out
}

fn all_events(batches: &[EventBatch]) -> Vec<TactileEvent> {
    batches.iter().flat_map(|b| b.events.iter().copied()).collect()
}

fn check_order(batches: &[EventBatch], input: &[TaxelFrame]) {
    assert_eq!(batches.len(), input.len(), "one batch per frame");
    let mut last = i64::MIN;
    for (b, f) in batches.iter().zip(input) {
        assert_eq!((b.time, b.seq, b.taxels as usize), (f.time, f.seq, f.values.len()));
        for e in &b.events {
            assert!(e.time.as_nanos() >= last, "events out of order");
            assert!(e.time <= b.time, "event after the frame that closed its interval");
            assert!(e.polarity == 1 || e.polarity == -1);
            last = e.time.as_nanos();
        }
    }
}

// ---------------------------------------------------------------- named extremes

#[test]
fn constant_signal_gives_no_events() {
    let rows: Vec<Vec<f64>> = (0..200).map(|_| (0..24).map(|i| 0.1 + 0.03 * i as f64).collect()).collect();
    let mut ev = Events::try_new(24, cfg(1e-3)).unwrap();
    let out = ev.run_all(frames(&rows)).unwrap();
    check_order(&out, &frames(&rows));
    assert!(all_events(&out).is_empty());
    // …also after Savitzky–Golay, whose output is constant only to rounding
    let mut chain = SavGol::try_new(24, SavGolConfig::default()).unwrap().then(Events::try_new(24, cfg(1e-9)).unwrap());
    let out = chain.run_all(frames(&rows)).unwrap();
    assert_eq!(out.len(), 200);
    assert!(all_events(&out).is_empty());
}

#[test]
fn full_scale_12_bit_step_up_and_back() {
    // raw counts 0 → 4095 → 0 (floor 1e-3 stands in for 0): ln(4095/1e-3) = 15.2252 → 152 crossings of 0.1
    let rows = vec![vec![0.0], vec![4095.0], vec![0.0]];
    let crossings = ((4095.0f64 / 1e-3).ln() / 0.1).floor() as usize;
    assert_eq!(crossings, 152);
    let mut c = cfg(0.1);
    c.max_events_per_step = 1000;
    let mut ev = Events::try_new(1, c.clone()).unwrap();
    let out = ev.run_all(frames(&rows)).unwrap();
    check_order(&out, &frames(&rows));
    let (up, down) = (&out[1].events, &out[2].events);
    assert_eq!((up.len(), down.len()), (crossings, crossings));
    assert!(up.iter().all(|e| e.polarity == 1) && down.iter().all(|e| e.polarity == -1));
    // linear in value: the level e^{r0+kτ} is crossed at fraction (e^{r0+kτ} − y0)/(y1 − y0)
    for (k, e) in up.iter().enumerate() {
        let level = (1e-3f64.ln() + (k + 1) as f64 * 0.1).exp();
        let t = PERIOD_NS as f64 * (level - 1e-3) / (4095.0 - 1e-3);
        assert_eq!(e.time.as_nanos(), t.round() as i64, "up crossing {k}");
    }
    // geometric levels: crossings crowd the start of a rise (the paper's "higher initially")…
    assert!(up[75].time.as_nanos() < PERIOD_NS / 1000);
    // …and the end of a fall
    assert!(2 * PERIOD_NS - down[75].time.as_nanos() < PERIOD_NS / 1000);
    assert_eq!(ev.counters().floored, 2);
    assert_eq!(ev.counters().overflow, 0);

    // with the default cap of 64 the rest is counted, and the reference still tracks the signal
    let mut ev = Events::try_new(1, cfg(0.1)).unwrap();
    let out = ev.run_all(frames(&[vec![0.0], vec![4095.0], vec![4095.0], vec![0.0]])).unwrap();
    assert_eq!(out[1].events.len(), 64);
    assert!(out[2].events.is_empty(), "a capped step must not spill into the next frame");
    assert_eq!(out[3].events.len(), 64);
    assert_eq!(ev.overflow(), 2 * (152 - 64));
    assert_eq!(ev.overflow_per_taxel(), &[2 * (152 - 64)]);
}

#[test]
fn exact_zero_and_one() {
    let rows: Vec<Vec<f64>> = (0..6).map(|k| vec![(k % 2) as f64, 1.0]).collect();
    let mut ev = Events::try_new(2, cfg(0.5)).unwrap();
    let out = push_all(&mut ev, frames(&rows));
    check_order(&out, &frames(&rows));
    // ln(1/1e-3) = 6.9078 → 13 crossings of 0.5 per flip; the constant 1 (ln = 0) is silent
    for (k, b) in out.iter().enumerate().skip(1) {
        assert_eq!(b.events.len(), 13, "frame {k}");
        assert!(b.events.iter().all(|e| e.taxel == 0 && e.polarity == if k % 2 == 1 { 1 } else { -1 }));
    }
    assert_eq!(ev.counters().floored, 3);
    assert_eq!(ev.reference(1), Some(0.0));
    assert!(ev.reference(0).unwrap().is_finite());
}

#[test]
fn tiny_threshold_is_capped_and_counted() {
    let mut c = cfg(1e-6);
    c.max_events_per_step = 50;
    let mut ev = Events::try_new(2, c).unwrap();
    let out = ev.run_all(frames(&[vec![1.0, 1.0], vec![2.0, 1.0], vec![2.0, 1.0]])).unwrap();
    let n = (2f64.ln() / 1e-6).floor() as u64; // 693 147 crossings
    assert_eq!(out[1].events.len(), 50);
    assert!(out[2].events.is_empty());
    assert_eq!(ev.overflow(), n - 50);
    assert_eq!(ev.overflow_per_taxel(), &[n - 50, 0]);
    // the 50 emitted are the earliest
    let first_level = 1e-6f64.exp();
    let t = ((first_level - 1.0) * PERIOD_NS as f64).round() as i64;
    assert_eq!(out[1].events[0].time.as_nanos(), t);
}

#[test]
fn large_threshold_gives_no_events() {
    // normalised values in [0, 1], floor 1e-3: the whole log range is 6.9 < τ = 10
    let rows: Vec<Vec<f64>> =
        (0..100).map(|k| (0..24).map(|i| ((k * 7 + i * 13) % 11) as f64 / 10.0).collect()).collect();
    let mut ev = Events::try_new(24, cfg(10.0)).unwrap();
    let out = ev.run_all(frames(&rows)).unwrap();
    assert!(all_events(&out).is_empty());
}

#[test]
fn time_gap_interpolate_or_reset() {
    // frames 0, 1, then 2..=9 dropped, then 10: a seq jump
    let fs = vec![frame(0, vec![1.0]), frame(1, vec![1.0]), frame(10, vec![2.0]), frame(11, vec![2.0])];
    let mut ev = Events::try_new(1, cfg(0.1)).unwrap();
    let out = ev.run_all(fs.clone()).unwrap();
    check_order(&out, &fs);
    let e = &out[2].events;
    assert_eq!(e.len(), 6); // ln 2 / 0.1 = 6.93
                            // interpolated across the whole gap 10 ms .. 100 ms
    assert!(e[0].time > Timestamp(PERIOD_NS) && e[5].time < Timestamp(10 * PERIOD_NS));
    assert!(e[5].time > Timestamp(5 * PERIOD_NS));

    let mut c = cfg(0.1);
    c.gap = EventGapPolicy::Reset;
    let mut ev = Events::try_new(1, c.clone()).unwrap();
    let out = ev.run_all(fs.clone()).unwrap();
    assert!(all_events(&out).is_empty(), "reset: the change across the gap is not an event");

    // a time-only gap (contiguous seq) needs max_gap_s
    let mut fs2 = fs.clone();
    for (k, f) in fs2.iter_mut().enumerate() {
        f.seq = k as u64;
    }
    let mut ev = Events::try_new(1, c.clone()).unwrap();
    assert_eq!(all_events(&ev.run_all(fs2.clone()).unwrap()).len(), 6);
    c.max_gap_s = Some(0.015);
    let mut ev = Events::try_new(1, c).unwrap();
    assert!(all_events(&ev.run_all(fs2).unwrap()).is_empty());

    // time going backwards always resets
    let back = vec![frame(5, vec![1.0]), TaxelFrame::new("ff".into(), Timestamp(0), 6, vec![3.0])];
    let mut ev = Events::try_new(1, cfg(0.1)).unwrap();
    assert!(all_events(&ev.run_all(back).unwrap()).is_empty());
}

#[test]
fn non_finite_values_error_or_skip() {
    let rows = [vec![1.0, 1.0], vec![1.0, f64::NAN], vec![2.0, 2.0]];
    let mut ev = Events::try_new(2, cfg(0.1)).unwrap();
    let mut out = Vec::new();
    ev.push(frame(0, rows[0].clone()), &mut out).unwrap();
    let err = ev.push(frame(1, rows[1].clone()), &mut out).unwrap_err();
    assert!(matches!(err, Error::BadValue { seq: 1, taxel: 1, .. }), "{err:?}");
    let msg = err.to_string();
    assert!(msg.contains("frame 1") && msg.contains("taxel 1") && msg.contains("ff"), "{msg}");

    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let mut c = cfg(0.1);
        c.non_finite = NonFinitePolicy::Skip;
        let mut ev = Events::try_new(2, c).unwrap();
        let rows = vec![vec![1.0, 1.0], vec![1.5, bad], vec![2.0, 2.0], vec![bad, bad]];
        let out = push_all(&mut ev, frames(&rows));
        check_order(&out, &frames(&rows));
        assert_eq!(ev.counters().skipped, 3, "{bad}");
        // taxel 1 interpolates 1.0 → 2.0 over frames 0..2 (0–20 ms), clamped to ≥ frame 1's time
        let t1: Vec<_> = out[2].events.iter().filter(|e| e.taxel == 1).collect();
        assert_eq!(t1.len(), 6);
        assert!(t1.iter().all(|e| e.time >= Timestamp(PERIOD_NS)));
        assert!(ev.reference(0).unwrap().is_finite() && ev.reference(1).unwrap().is_finite());
    }
    // a non-finite first sample leaves the taxel without a reference until a finite one comes
    let mut c = cfg(0.1);
    c.non_finite = NonFinitePolicy::Skip;
    let mut ev = Events::try_new(1, c).unwrap();
    let out = ev.run_all(frames(&[vec![f64::NAN], vec![1.0], vec![1.0]])).unwrap();
    assert!(all_events(&out).is_empty());
}

#[test]
fn wrong_taxel_count_names_the_frame() {
    let mut ev = Events::try_new(24, cfg(0.1)).unwrap();
    let err = ev.push(frame(7, vec![1.0; 3]), &mut Vec::new()).unwrap_err();
    assert!(matches!(err, Error::TaxelCount { seq: 7, expected: 24, got: 3, .. }));
}

#[test]
fn per_taxel_thresholds() {
    let c = EventsConfig { threshold: Threshold::PerTaxel(vec![0.1, 0.2]), ..Default::default() };
    let mut ev = Events::try_new(2, c).unwrap();
    let out = ev.run_all(frames(&[vec![1.0, 1.0], vec![2.0, 2.0]])).unwrap();
    let count = |t: u16| out[1].events.iter().filter(|e| e.taxel == t).count();
    assert_eq!((count(0), count(1)), (6, 3));
}

// ---------------------------------------------------------------- properties

/// Positive signals: a random walk in log space, per taxel.
fn log_walk(taxels: usize, len: std::ops::Range<usize>) -> impl Strategy<Value = Vec<Vec<f64>>> {
    prop::collection::vec(prop::collection::vec(-0.8f64..0.8, taxels), len).prop_map(move |steps| {
        let mut ln = vec![0.0; taxels];
        steps
            .into_iter()
            .map(|s| {
                ln.iter_mut().zip(s).for_each(|(l, d)| *l = (*l + d).clamp(-12.0, 12.0));
                ln.iter().map(|l| l.exp()).collect()
            })
            .collect()
    })
}

/// The rule of method.md stage 3, written the slow obvious way: step the reference one level
/// at a time (`L(j) = e^{r₀ + jτ}`, `y ≥ L(k+1)` → up, `y ≤ L(k−1)` → down), interpolate each
/// crossing linearly in value, drop crossings within `refractory_ns` of the taxel's last
/// emitted event, stop emitting after `cap` per taxel and step, order a frame's events by
/// (time, taxel, crossing). Returns the events per frame, and (overflow, suppressed).
fn naive_events(
    rows: &[Vec<f64>],
    tau: f64,
    floor: f64,
    cap: u32,
    refractory_ns: i64,
) -> (Vec<Vec<TactileEvent>>, (u64, u64)) {
    let n = rows[0].len();
    let (mut overflow, mut suppressed) = (0u64, 0u64);
    let mut last_event = vec![i64::MIN; n];
    let y = |x: f64| if x >= floor { x } else { floor };
    let r0: Vec<f64> = rows[0].iter().map(|&x| y(x).ln()).collect();
    let mut k = vec![0i64; n];
    let mut out = vec![Vec::new()];
    for f in 1..rows.len() {
        let (pt, now) = ((f as i64 - 1) * PERIOD_NS, f as i64 * PERIOD_NS);
        let mut evs = Vec::new();
        for i in 0..n {
            let l = |j: i64| (r0[i] + j as f64 * tau).exp();
            let (p, v) = (y(rows[f - 1][i]), y(rows[f][i]));
            let time = |level: f64| {
                let frac = ((level - p) / (v - p)).clamp(0.0, 1.0);
                Timestamp(pt + (frac * (now - pt) as f64 + 0.5).floor() as i64)
            };
            let mut crossings = Vec::new();
            while v >= l(k[i] + 1) {
                k[i] += 1;
                crossings.push((time(l(k[i])), 1));
            }
            while v <= l(k[i] - 1) {
                k[i] -= 1;
                crossings.push((time(l(k[i])), -1));
            }
            let mut emitted = 0;
            for (c, &(t, polarity)) in crossings.iter().enumerate() {
                if emitted == cap {
                    overflow += (crossings.len() - c) as u64;
                    break;
                }
                if t.as_nanos() < last_event[i].saturating_add(refractory_ns) {
                    suppressed += 1;
                    continue;
                }
                evs.push(TactileEvent { time: t, taxel: i as u16, polarity });
                last_event[i] = t.as_nanos();
                emitted += 1;
            }
        }
        evs.sort_by_key(|e| e.time);
        out.push(evs);
    }
    (out, (overflow, suppressed))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    /// The optimised stage (cached linear-domain bounds, jump to the final level, one exp per
    /// single crossing, binary search past a refractory period, packed-key sort) emits exactly
    /// the events of the naive rule, and counts the same overflow and suppressions.
    #[test]
    fn matches_the_naive_rule(rows in log_walk(3, 1..40), tau in 0.01f64..1.0,
                              cap in prop_oneof![Just(gradtac_stages::limits::MAX_EVENTS_PER_STEP), 1u32..6],
                              refractory_ms in prop_oneof![Just(0.0), 0.0f64..25.0]) {
        let config = EventsConfig {
            threshold: Threshold::Uniform(tau),
            max_events_per_step: cap,
            refractory_s: refractory_ms * 1e-3,
            ..Default::default()
        };
        let mut ev = Events::try_new(3, config).unwrap();
        let out = push_all(&mut ev, frames(&rows));
        let refractory_ns = (refractory_ms * 1e-3 * 1e9).round() as i64; // as the stage rounds it
        let (want, (overflow, suppressed)) = naive_events(&rows, tau, 1e-3, cap, refractory_ns);
        for (f, (b, w)) in out.iter().zip(&want).enumerate() {
            prop_assert_eq!(&b.events, w, "frame {}", f);
        }
        prop_assert_eq!((ev.counters().overflow, ev.counters().suppressed), (overflow, suppressed));
    }

    /// Σ polarity·τ up to each frame reconstructs ln y − ln y₀ within τ, at every sample.
    #[test]
    fn running_sum_reconstructs_log_within_tau(rows in log_walk(3, 1..60), tau in 0.01f64..1.0) {
        let config = EventsConfig {
            threshold: Threshold::Uniform(tau),
            max_events_per_step: gradtac_stages::limits::MAX_EVENTS_PER_STEP,
            floor: 1e-300,
            ..Default::default()
        };
        let mut ev = Events::try_new(3, config).unwrap();
        let mut sums = [0.0f64; 3];
        let mut out = Vec::new();
        for (k, row) in rows.iter().enumerate() {
            out.clear();
            ev.push(frame(k as u64, row.clone()), &mut out).unwrap();
            for e in &out[0].events {
                sums[e.taxel as usize] += e.polarity as f64 * tau;
            }
            for i in 0..3 {
                let d = row[i].ln() - rows[0][i].ln();
                prop_assert!((d - sums[i]).abs() < tau * (1.0 + 1e-9) + 1e-12,
                    "frame {k} taxel {i}: ln change {d}, sum {}", sums[i]);
            }
        }
        prop_assert_eq!(ev.counters().overflow, 0);
    }

    /// One batch per frame, batch stamps are the frames', event times non-decreasing across the
    /// whole stream and inside the interval each batch closes.
    #[test]
    fn times_are_non_decreasing(rows in log_walk(4, 1..50), tau in 0.02f64..0.5, cap in 1u32..8,
                                refractory in prop_oneof![Just(0.0), 0.0f64..0.02]) {
        let config = EventsConfig {
            threshold: Threshold::Uniform(tau),
            max_events_per_step: cap,
            refractory_s: refractory,
            ..Default::default()
        };
        let fs = frames(&rows);
        let out = Events::try_new(4, config).unwrap().run_all(fs.clone()).unwrap();
        check_order(&out, &fs);
        for (b, prev) in out.iter().skip(1).zip(&fs) {
            prop_assert!(b.events.iter().all(|e| e.time >= prev.time));
        }
    }

    /// Savitzky–Golay → events fed in any chunking gives the same batches as one run; with
    /// `gap = reset` a stream with dropped frames equals separate runs over its segments.
    #[test]
    fn any_chunking_gives_identical_events(rows in log_walk(3, 1..80),
                                           cuts in prop::collection::vec(0usize..80, 0..6),
                                           drops in prop::collection::vec(1usize..80, 0..3),
                                           causal in any::<bool>()) {
        // frames with some seq (and time) jumps
        let mut fs = Vec::new();
        let mut k = 0u64;
        for (i, row) in rows.iter().enumerate() {
            if drops.contains(&i) {
                k += 3;
            }
            fs.push(frame(k, row.clone()));
            k += 1;
        }
        let sg = SavGolConfig {
            window: 7, polyorder: 2,
            mode: if causal { SavGolMode::Causal } else { SavGolMode::Centred },
            ..Default::default()
        };
        let events = EventsConfig { threshold: Threshold::Uniform(0.05), gap: EventGapPolicy::Reset, ..Default::default() };
        let build = || SavGol::try_with_rate(3, sg.clone(), 100.0).unwrap().then(Events::try_new(3, events.clone()).unwrap());

        let whole = build().run_all(fs.clone()).unwrap();
        prop_assert_eq!(whole.len(), fs.len());

        // chunked pushes, finish only at the end
        let mut chunked = Vec::new();
        let mut p = build();
        let mut cuts = cuts.clone();
        cuts.sort_unstable();
        let mut start = 0;
        for c in cuts.into_iter().chain([fs.len()]) {
            let c = c.min(fs.len()).max(start);
            for f in &fs[start..c] {
                p.push(f.clone(), &mut chunked).unwrap();
            }
            start = c;
        }
        p.finish(&mut chunked).unwrap();
        prop_assert_eq!(&chunked, &whole);

        // separate runs over the segments between drops
        let mut separate = Vec::new();
        let mut seg_start = 0;
        for i in 1..=fs.len() {
            if i == fs.len() || fs[i].seq != fs[i - 1].seq + 1 {
                separate.extend(build().run_all(fs[seg_start..i].to_vec()).unwrap());
                seg_start = i;
            }
        }
        prop_assert_eq!(&separate, &whole);
    }
}

/// Two interleaved sensors through `Keyed` (one SG → events chain per sensor) give each sensor
/// exactly the batches it gets alone.
#[test]
fn keyed_sensors_do_not_mix() {
    use gradtac_stream::{Keyed, SensorId};
    let sg = SavGolConfig { window: 7, polyorder: 2, ..Default::default() };
    let build = |_: &SensorId| {
        SavGol::try_with_rate(2, sg.clone(), 100.0).unwrap().then(Events::try_new(2, cfg(0.05)).unwrap())
    };
    let stream = |name: &str, phase: f64| -> Vec<TaxelFrame> {
        (0..50u64)
            .map(|k| {
                let v = (0..2).map(|i| 1.5 + (k as f64 * 0.3 + phase + i as f64).sin()).collect();
                TaxelFrame::new(SensorId::new(name), Timestamp(k as i64 * PERIOD_NS), k, v)
            })
            .collect()
    };
    let (ff, th) = (stream("ff", 0.0), stream("th", 1.0));
    let interleaved: Vec<TaxelFrame> = ff.iter().zip(&th).flat_map(|(a, b)| [a.clone(), b.clone()]).collect();
    let mixed = Keyed::new(build).run_all(interleaved).unwrap();
    let alone = |fs: Vec<TaxelFrame>| build(&SensorId::new("x")).run_all(fs).unwrap();
    let of = |name: &str| mixed.iter().filter(|b| b.sensor.as_str() == name).cloned().collect::<Vec<_>>();
    assert_eq!(of("ff"), alone(ff));
    assert_eq!(of("th"), alone(th));
    assert!(!all_events(&of("ff")).is_empty());
}
