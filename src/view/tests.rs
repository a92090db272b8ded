use super::*;
use gradtac_stages::slip::SlipClass;
use gradtac_stages::track::ContactState;
use gradtac_stream::{IteratorStageExt, SensorId, Timestamp};
use std::collections::BTreeMap;

/// Per recording entity: (temporal rows, their times on `timeline`), from the messages a
/// memory sink caught, decoded by rerun's own chunk reader.
fn entities(msgs: Vec<rerun::log::LogMsg>, timeline: &'static str) -> (BTreeMap<String, (usize, Vec<i64>)>, usize) {
    let mut out: BTreeMap<String, (usize, Vec<i64>)> = BTreeMap::new();
    let mut blueprint_msgs = 0;
    for m in msgs {
        if let rerun::log::LogMsg::ArrowMsg(store, msg) = m {
            if store.is_blueprint() {
                blueprint_msgs += 1;
                continue;
            }
            let chunk = rerun::log::Chunk::from_arrow_msg(&msg).expect("a chunk rerun can decode");
            if chunk.is_static() {
                continue;
            }
            let e = out.entry(chunk.entity_path().to_string()).or_default();
            e.0 += chunk.num_rows();
            if let Some(col) = chunk.timelines().get(&rerun::TimelineName::from(timeline)) {
                e.1.extend_from_slice(col.times_raw());
            }
        }
    }
    for v in out.values_mut() {
        v.1.sort_unstable();
    }
    (out, blueprint_msgs)
}

fn frame(sensor: &str, k: i64, values: Vec<f64>) -> TaxelFrame {
    TaxelFrame::new(SensorId::new(sensor), Timestamp(k * 10_000_000), k as u64, values)
}

fn point(sensor: &str, k: i64, contact: bool) -> TrackPoint {
    TrackPoint {
        sensor: SensorId::new(sensor),
        time: Timestamp(k * 10_000_000),
        start: Timestamp(k * 10_000_000),
        seq: k as u64,
        state: if contact { ContactState::Contact } else { ContactState::NoContact },
        no_contact: None,
        track: contact.then_some(1),
        x_mm: if contact { 1.0 + k as f64 } else { f64::NAN },
        y_mm: if contact { -2.0 } else { f64::NAN },
        area_mm2: if contact { 4.0 } else { f64::NAN },
        orientation_rad: 0.0,
        peak: 1.0,
        velocity_mm_s: None,
        gated: false,
        fit: None,
    }
}

#[test]
fn a_memory_recording_holds_every_entity_at_the_data_times() {
    let (rec, storage) = rerun::RecordingStreamBuilder::new("gradtac-test").memory().unwrap();
    let view = View::from_stream(rec, "memory".into(), &ViewOptions { lossless: true, ..Default::default() }).unwrap();
    let h = view.handle();
    let layout = Layout::biotac_sp();
    h.sensor("ff", Some(&layout), Clock::Relative);
    h.sensor("th", Some(&layout), Clock::Utc);
    let frames: Vec<TaxelFrame> = (0..5).map(|k| frame("ff", k, vec![k as f64; 24])).collect();
    // the stage-shaped logger: a pass-through appended to a chain
    let out: Vec<TaxelFrame> =
        frames.clone().into_iter().stage_plain(h.tap_frames(FrameKind::Normalised)).collect::<Result<_, _>>().unwrap();
    assert_eq!(out, frames, "the tap passes every frame on unchanged");
    h.log(&frames[..3]);
    h.log(&[point("th", 1_000_000_000, true), point("th", 1_000_000_001, false)]);
    h.log(&[SlipEvent {
        time: Timestamp(30_000_000),
        onset: Timestamp(10_000_000),
        first_seen: Timestamp(20_000_000),
        class: SlipClass::LongitudinalDown,
        previous: SlipClass::Stable,
        common_mm_s: -3.0,
        differential_mm_s: 0.0,
    }]);
    let report = view.finish().unwrap();
    assert_eq!((report.offered, report.dropped, report.logged), (11, 0, 11), "{report}");
    let (ents, blueprint) = entities(storage.take(), logger::TIME);
    assert!(blueprint > 0, "a blueprint was sent");
    let at = |k: i64| k * 10_000_000;
    assert_eq!(ents["/ff/series/normalised"], (5, (0..5).map(at).collect()));
    assert_eq!(ents["/ff/plane/normalised"].0, 5, "one colour update per frame");
    assert_eq!(ents["/ff/series/raw"], (3, (0..3).map(at).collect()));
    // th runs on the utc timeline: nothing of it on `time`
    assert_eq!(ents["/th/plane/contact"].0, 2, "a point, then a clear");
    assert!(ents["/th/plane/contact"].1.is_empty());
    assert_eq!(ents["/th/series/contact"].0, 1, "only the contact point has a position");
    assert_eq!(ents["/slip/log"], (1, vec![30_000_000]));
    assert_eq!(ents["/slip/class"].0, 1);
    let (utc, _) = {
        let (rec, storage) = rerun::RecordingStreamBuilder::new("gradtac-test").memory().unwrap();
        let view =
            View::from_stream(rec, "memory".into(), &ViewOptions { lossless: true, ..Default::default() }).unwrap();
        view.handle().sensor("th", None, Clock::Utc);
        view.handle().log(&[point("th", 7, true)]);
        view.finish().unwrap();
        entities(storage.take(), logger::UTC)
    };
    assert_eq!(utc["/th/plane/contact"], (1, vec![70_000_000]));
}

#[test]
fn a_full_queue_drops_and_counts_without_waiting() {
    // a consumer that never reads: the handle must not block
    let (tx, _rx) = std::sync::mpsc::sync_channel(2);
    let counters = Arc::new(Counters::default());
    let h = ViewHandle { tx, counters: counters.clone(), lossless: false };
    let frames: Vec<TaxelFrame> = (0..5).map(|k| frame("ff", k, vec![0.0; 24])).collect();
    let start = std::time::Instant::now();
    for f in &frames {
        h.log(std::slice::from_ref(f));
    }
    assert!(start.elapsed() < std::time::Duration::from_secs(5), "offering never waits");
    assert_eq!(counters.sent.load(Ordering::Relaxed), 5);
    assert_eq!(counters.dropped.load(Ordering::Relaxed), 3, "two fit, three are dropped and counted");
}

#[test]
fn a_slow_view_drops_instead_of_stalling_and_reports_it() {
    let (rec, _storage) = rerun::RecordingStreamBuilder::new("gradtac-test").memory().unwrap();
    let view = View::from_stream(rec, "memory".into(), &ViewOptions { queue: 1, ..Default::default() }).unwrap();
    let h = view.handle();
    let frames: Vec<TaxelFrame> = (0..20_000).map(|k| frame("ff", k, vec![k as f64; 24])).collect();
    for f in &frames {
        h.log(std::slice::from_ref(f));
    }
    let r = view.finish().unwrap();
    assert_eq!(r.offered, 20_000);
    assert_eq!(r.logged + r.dropped, 20_000, "{r}");
    if r.dropped > 0 {
        assert!(r.to_string().contains("dropped"), "{r}");
    }
}

#[test]
fn settings_are_checked_and_nothing_empty_is_offered() {
    let (rec, _s) = rerun::RecordingStreamBuilder::new("gradtac-test").memory().unwrap();
    let e = View::from_stream(rec, "m".into(), &ViewOptions { queue: 0, ..Default::default() }).unwrap_err();
    assert!(e.to_string().contains("view queue"), "{e}");
    let batch = EventBatch { sensor: SensorId::new("ff"), time: Timestamp(0), seq: 0, taxels: 24, events: vec![] };
    assert!(batch.to_rec(FrameKind::Raw).is_none(), "a frame without events logs nothing");
}

#[test]
fn large_records_are_bounded_by_bytes_too() {
    let (tx, _rx) = std::sync::mpsc::sync_channel(1 << 16);
    let counters = Arc::new(Counters::default());
    let h = ViewHandle { tx, counters: counters.clone(), lossless: false };
    // 1024 × 1024 surfaces (4 MiB each as f32): at most MAX_QUEUE_BYTES of them wait
    let grid = gradtac_stages::interpolate::Grid::try_new(
        gradtac_stream::Extent { x_min: 0.0, x_max: 1.0, y_min: 0.0, y_max: 1.0 },
        1024,
        1024,
    )
    .unwrap();
    let surface = Surface {
        sensor: SensorId::new("ff"),
        start: Timestamp(0),
        end: Timestamp(0),
        seq: 0,
        grid: Arc::new(grid),
        values: ndarray::Array2::zeros((1024, 1024)),
    };
    for _ in 0..100 {
        h.log(std::slice::from_ref(&surface));
    }
    let kept = 100 - counters.dropped.load(Ordering::Relaxed);
    assert!(counters.queued_bytes.load(Ordering::Relaxed) <= MAX_QUEUE_BYTES);
    assert_eq!(kept, MAX_QUEUE_BYTES / (4 << 20) - 1, "the rest are dropped, not queued");
}
