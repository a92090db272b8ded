//! The rerun view (feature `view`): replaying Parquet outputs of every schema version, read
//! back with rerun's own chunk decoder from a memory recording. The end-to-end check of a
//! scene's `.rrd` against its Parquet outputs (rerun-sdk) is `scripts/view-check`.

use arrow_array::{ArrayRef, BooleanArray, Float64Array, Int64Array, Int8Array, StringArray, UInt16Array, UInt64Array};
use arrow_schema::{Field, Schema};
use gradtac::view::{replay, View, ViewOptions};
use parquet::arrow::ArrowWriter;
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

fn write(path: &Path, schema_id: &str, columns: Vec<(&str, ArrayRef)>) {
    let fields: Vec<Field> = columns.iter().map(|(n, c)| Field::new(*n, c.data_type().clone(), true)).collect();
    let schema = Arc::new(Schema::new(fields));
    let batch = arrow_array::RecordBatch::try_new(schema.clone(), columns.into_iter().map(|c| c.1).collect()).unwrap();
    let props = WriterProperties::builder()
        .set_key_value_metadata(Some(vec![KeyValue::new("gradtac.schema".into(), schema_id.to_string())]))
        .set_max_row_group_row_count(Some(64))
        .build();
    let mut w = ArrowWriter::try_new(std::fs::File::create(path).unwrap(), schema, Some(props)).unwrap();
    w.write(&batch).unwrap();
    w.close().unwrap();
}

/// (rows, times on `time`) per entity of a memory recording, decoded by rerun.
fn entities(msgs: Vec<rerun::log::LogMsg>) -> BTreeMap<String, (usize, Vec<i64>)> {
    let mut out: BTreeMap<String, (usize, Vec<i64>)> = BTreeMap::new();
    for m in msgs {
        if let rerun::log::LogMsg::ArrowMsg(store, msg) = m {
            let chunk = rerun::log::Chunk::from_arrow_msg(&msg).unwrap();
            if store.is_blueprint() || chunk.is_static() {
                continue;
            }
            let e = out.entry(chunk.entity_path().to_string()).or_default();
            e.0 += chunk.num_rows();
            if let Some(c) = chunk.timelines().get(&rerun::TimelineName::from("time")) {
                e.1.extend_from_slice(c.times_raw());
            }
        }
    }
    for v in out.values_mut() {
        v.1.sort_unstable();
    }
    out
}

#[test]
fn version_1_outputs_replay_with_their_times_and_counts() {
    let dir = tempfile::tempdir().unwrap();
    let n = 200i64;
    let t: ArrayRef = Arc::new(Int64Array::from_iter_values((0..n).map(|k| k * 10_000_000)));
    let sensor: ArrayRef = Arc::new(StringArray::from(vec!["ff"; n as usize]));
    let seq: ArrayRef = Arc::new(UInt64Array::from_iter_values(0..n as u64));
    // track/1: Int64 `*_ns` times, NaN without contact (every 7th point), no `state` column
    let x: ArrayRef =
        Arc::new(Float64Array::from_iter_values((0..n).map(|k| if k % 7 == 0 { f64::NAN } else { k as f64 * 0.01 })));
    let v: ArrayRef = Arc::new(Float64Array::from_iter((0..n).map(|k| (k > 0).then_some(1.0))));
    write(
        &dir.path().join("track.parquet"),
        "track/1",
        vec![
            ("sensor", sensor.clone()),
            ("time_ns", t.clone()),
            ("start_ns", t.clone()),
            ("seq", seq.clone()),
            ("x_mm", x.clone()),
            ("y_mm", x),
            ("vx_mm_s", v.clone()),
            ("vy_mm_s", v),
            ("gated", Arc::new(BooleanArray::from(vec![false; n as usize]))),
        ],
    );
    // event/1: one row per event, 0-based taxels; two events per frame of 100 frames
    let frame_t: ArrayRef = Arc::new(Int64Array::from_iter_values((0..n).map(|k| (k / 2) * 10_000_000)));
    write(
        &dir.path().join("events.parquet"),
        "event/1",
        vec![
            ("sensor", sensor),
            ("time_ns", frame_t.clone()),
            ("frame_time_ns", frame_t),
            ("seq", seq),
            ("taxel", Arc::new(UInt16Array::from_iter_values((0..n).map(|k| (k % 24) as u16)))),
            ("polarity", Arc::new(Int8Array::from_iter_values((0..n).map(|k| if k % 4 == 0 { 1 } else { -1 })))),
        ],
    );
    let (rec, storage) = rerun::RecordingStreamBuilder::new("gradtac-test").memory().unwrap();
    let view = View::from_stream(rec, "memory".into(), &ViewOptions { lossless: true, ..Default::default() }).unwrap();
    let summary = replay(dir.path(), &view.handle()).unwrap();
    assert_eq!((summary.files, summary.rows), (2, 2 * n as u64), "{summary}");
    assert_eq!(summary.schemas, ["event/1", "track/1"]);
    let report = view.finish().unwrap();
    assert_eq!(report.dropped, 0, "{report}");
    let e = entities(storage.take());
    let contacts: Vec<i64> = (0..n).filter(|k| k % 7 != 0).map(|k| k * 10_000_000).collect();
    assert_eq!(e["/ff/series/contact"], (contacts.len(), contacts), "a point per finite position, at its time");
    assert_eq!(e["/ff/plane/contact"].0, n as usize, "points and clears");
    let frames: Vec<i64> = (0..n / 2).map(|k| k * 10_000_000).collect();
    assert_eq!(e["/ff/series/events"], (frames.len(), frames), "one row of counts per frame with events");
}

#[test]
fn replaying_what_is_not_a_gradtac_output_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("x.parquet");
    std::fs::write(&p, b"not parquet").unwrap();
    let (rec, _s) = rerun::RecordingStreamBuilder::new("gradtac-test").memory().unwrap();
    let view = View::from_stream(rec, "memory".into(), &ViewOptions::default()).unwrap();
    let e = replay(&p, &view.handle()).unwrap_err().to_string();
    assert!(e.contains("x.parquet") && e.contains("not a readable Parquet file"), "{e}");
    let e = replay(&dir.path().join("missing"), &view.handle()).unwrap_err().to_string();
    assert!(e.contains("no such file"), "{e}");
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let e = replay(&empty, &view.handle()).unwrap_err().to_string();
    assert!(e.contains("no finished Parquet file"), "{e}");
}
