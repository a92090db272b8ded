//! Arrow IPC sources: the long `frame/1` layout (as the record builders write it) and wide
//! numeric columns, through IPC files and streams and from in-memory batches.

use arrow_array::builder::{FixedSizeListBuilder, Float64Builder, ListBuilder, StringDictionaryBuilder};
use arrow_array::types::Int8Type;
use arrow_array::{
    ArrayRef, Float32Array, Float64Array, Int16Array, Int64Array, RecordBatch, StringArray, TimestampMillisecondArray,
    UInt16Array,
};
use arrow_schema::ArrowError;
use gradtac_io::arrow_ipc::{open, ArrowIpcConfig, BatchFrames, BatchLayout, IpcFormat, WideTime};
use gradtac_io::records::{to_batch, FrameShape};
use gradtac_io::{ColumnSelector, TimeUnit};
use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
use std::path::Path;
use std::sync::Arc;

fn frames() -> Vec<TaxelFrame> {
    (0..7u64)
        .map(|k| {
            let s = if k % 3 == 2 { "th" } else { "ff" };
            TaxelFrame::new(
                SensorId::new(s),
                Timestamp(1_700_000_000_000_000_000 + k as i64 * 10_000_000),
                k,
                vec![k as f64 + 0.5, -(k as f64), 1e-300 * k as f64],
            )
        })
        .collect()
}

fn write_file(path: &Path, batches: &[RecordBatch]) {
    let f = std::fs::File::create(path).unwrap();
    let mut w = arrow_ipc::writer::FileWriter::try_new(f, &batches[0].schema()).unwrap();
    for b in batches {
        w.write(b).unwrap();
    }
    w.finish().unwrap();
}

fn write_stream(path: &Path, batches: &[RecordBatch]) {
    let f = std::fs::File::create(path).unwrap();
    let mut w = arrow_ipc::writer::StreamWriter::try_new(f, &batches[0].schema()).unwrap();
    for b in batches {
        w.write(b).unwrap();
    }
    w.finish().unwrap();
}

fn read(cfg: &ArrowIpcConfig) -> Result<Vec<TaxelFrame>, gradtac_io::Error> {
    open(cfg, SensorId::new("wide"))?.collect()
}

#[test]
fn long_layout_round_trips_the_frame_schema_through_files_and_streams() {
    let dir = tempfile::tempdir().unwrap();
    let fr = frames();
    let shape = FrameShape::unnamed(3).unwrap();
    let batches =
        [to_batch::<TaxelFrame>(&shape, &fr[..4]).unwrap(), to_batch::<TaxelFrame>(&shape, &fr[4..]).unwrap()];
    let file = dir.path().join("f.arrow");
    let stream = dir.path().join("f.arrows");
    write_file(&file, &batches);
    write_stream(&stream, &batches);
    for (p, fmt) in
        [(&file, IpcFormat::Auto), (&file, IpcFormat::File), (&stream, IpcFormat::Auto), (&stream, IpcFormat::Stream)]
    {
        let mut cfg = ArrowIpcConfig::long(p);
        cfg.format = fmt;
        assert_eq!(read(&cfg).unwrap(), fr, "{p:?} {fmt:?}");
    }
    let mut cfg = ArrowIpcConfig::long(&file);
    cfg.sensors = Some(vec!["th".into()]);
    let th = read(&cfg).unwrap();
    assert_eq!(th.iter().map(|f| f.seq).collect::<Vec<_>>(), vec![2, 5]);
    // a stream read as a file is an Arrow error naming the file
    cfg = ArrowIpcConfig::long(&stream);
    cfg.format = IpcFormat::File;
    let e = read(&cfg).unwrap_err().to_string();
    assert!(e.contains("f.arrows: reading Arrow IPC"), "{e}");
}

#[test]
fn long_layout_variants_dictionary_sensor_list_values_no_seq() {
    let mut sensors = StringDictionaryBuilder::<Int8Type>::new();
    let mut values = ListBuilder::new(Float64Builder::new());
    for (s, v) in [("ff", [1.0, 2.0]), ("mf", [3.0, 4.0]), ("ff", [5.0, 6.0])] {
        sensors.append_value(s);
        values.values().append_slice(&v);
        values.append(true);
    }
    let b = RecordBatch::try_from_iter([
        ("sensor", Arc::new(sensors.finish()) as ArrayRef),
        ("time_ns", Arc::new(Int64Array::from(vec![10, 20, 30])) as ArrayRef),
        ("values", Arc::new(values.finish()) as ArrayRef),
    ])
    .unwrap();
    let got: Vec<TaxelFrame> = BatchFrames::new([Ok(b)].into_iter(), "mem", BatchLayout::Long { sensors: None })
        .collect::<Result<_, _>>()
        .unwrap();
    let summary: Vec<(String, i64, u64, Vec<f64>)> =
        got.into_iter().map(|f| (f.sensor.to_string(), f.time.as_nanos(), f.seq, f.values)).collect();
    assert_eq!(
        summary,
        vec![
            ("ff".into(), 10, 0, vec![1.0, 2.0]),
            ("mf".into(), 20, 0, vec![3.0, 4.0]),
            ("ff".into(), 30, 1, vec![5.0, 6.0])
        ]
    );
}

fn wide_batch(t0: f64, rows: usize) -> RecordBatch {
    let t: Vec<f64> = (0..rows).map(|k| t0 + k as f64 * 0.01).collect();
    RecordBatch::try_from_iter([
        ("t", Arc::new(Float64Array::from(t)) as ArrayRef),
        ("ff_e1", Arc::new(Float32Array::from((0..rows).map(|k| k as f32 + 0.25).collect::<Vec<_>>())) as ArrayRef),
        ("ff_e2", Arc::new(Int16Array::from((0..rows).map(|k| -(k as i16)).collect::<Vec<_>>())) as ArrayRef),
        ("other", Arc::new(StringArray::from(vec!["x"; rows])) as ArrayRef),
        ("ff_e3", Arc::new(UInt16Array::from((0..rows).map(|k| 60000 + k as u16).collect::<Vec<_>>())) as ArrayRef),
    ])
    .unwrap()
}

#[test]
fn wide_layout_with_time_column_or_rate() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("w.arrow");
    write_file(&p, &[wide_batch(1.0, 3), wide_batch(1.03, 2)]);
    let mut cfg = ArrowIpcConfig::wide(&p, ColumnSelector::Pattern("ff_e{1..3}".into()));
    cfg.time_column = Some("t".into());
    let got = read(&cfg).unwrap();
    assert_eq!(got.len(), 5);
    assert_eq!(got[1].values, vec![1.25, -1.0, 60001.0]);
    assert_eq!(got[4].seq, 4);
    assert_eq!(got[4].sensor.as_str(), "wide");
    assert_eq!(got[3].time, Timestamp(1_030_000_000));
    cfg.time_column = None;
    cfg.rate_hz = Some(200.0);
    let got = read(&cfg).unwrap();
    assert_eq!(got[4].time, Timestamp(20_000_000));
    // both or neither time options, a non-numeric column, a missing column
    cfg.time_column = Some("t".into());
    assert!(read(&cfg).unwrap_err().to_string().contains("not both"));
    cfg.rate_hz = None;
    cfg.columns = Some(ColumnSelector::Names(vec!["ff_e1".into(), "other".into()]));
    let e = read(&cfg).unwrap_err().to_string();
    assert!(e.contains("w.arrow: batch 0: column \"other\": type Utf8 is not numeric"), "{e}");
    cfg.columns = Some(ColumnSelector::Names(vec!["ff_e9".into()]));
    assert!(read(&cfg).unwrap_err().to_string().contains("ff_e9"));
}

#[test]
fn wide_layout_with_an_arrow_timestamp_column() {
    let b = RecordBatch::try_from_iter([
        ("ts", Arc::new(TimestampMillisecondArray::from(vec![5, 6])) as ArrayRef),
        ("a", Arc::new(Float64Array::from(vec![1.0, 2.0])) as ArrayRef),
    ])
    .unwrap();
    let layout = BatchLayout::Wide {
        sensor: SensorId::new("s"),
        columns: ColumnSelector::Names(vec!["a".into()]),
        time: WideTime::Column { name: "ts".into(), unit: TimeUnit::Seconds }, // the type's unit wins
    };
    let got: Vec<TaxelFrame> = BatchFrames::new([Ok(b)].into_iter(), "mem", layout).collect::<Result<_, _>>().unwrap();
    assert_eq!(got[1].time, Timestamp(6_000_000));
}

fn long_err(batches: Vec<Result<RecordBatch, ArrowError>>) -> String {
    BatchFrames::new(batches.into_iter(), "bad.arrow", BatchLayout::Long { sensors: None })
        .find_map(|r| r.err())
        .expect("an error")
        .to_string()
}

fn long_batch(values: Vec<Option<Vec<Option<f64>>>>, n: i32, times: Vec<i64>) -> RecordBatch {
    let mut vb = FixedSizeListBuilder::new(Float64Builder::new(), n);
    for row in values {
        match row {
            Some(v) => {
                for x in v {
                    vb.values().append_option(x);
                }
                vb.append(true);
            }
            None => {
                for _ in 0..n {
                    vb.values().append_null();
                }
                vb.append(false);
            }
        }
    }
    let rows = times.len();
    RecordBatch::try_from_iter([
        ("sensor", Arc::new(StringArray::from(vec!["ff"; rows])) as ArrayRef),
        ("time_ns", Arc::new(Int64Array::from(times)) as ArrayRef),
        ("values", Arc::new(vb.finish()) as ArrayRef),
    ])
    .unwrap()
}

#[test]
fn bad_batches_are_errors_naming_batch_and_row() {
    let ok = long_batch(vec![Some(vec![Some(1.0), Some(2.0)])], 2, vec![0]);
    let e = long_err(vec![Ok(ok.clone()), Ok(long_batch(vec![Some(vec![Some(1.0), None])], 2, vec![1]))]);
    assert_eq!(e, "bad.arrow: batch 1 row 0 (row 1 of the source): values: null value in the list");
    let e = long_err(vec![Ok(long_batch(vec![Some(vec![Some(1.0), Some(2.0)]), None], 2, vec![0, 1]))]);
    assert!(e.contains("batch 0 row 1") && e.contains("null list"), "{e}");
    let e = long_err(vec![Ok(long_batch(vec![Some(vec![Some(f64::NAN), Some(2.0)])], 2, vec![0]))]);
    assert!(e.contains("taxel 0: value NaN is not finite"), "{e}");
    let e =
        long_err(vec![Ok(ok.clone()), Ok(long_batch(vec![Some(vec![Some(1.0), Some(2.0), Some(3.0)])], 3, vec![1]))]);
    assert!(e.contains("3 taxels; earlier frames have 2"), "{e}");
    let e = long_err(vec![Ok(ok), Err(ArrowError::IpcError("truncated".into()))]);
    assert!(e.contains("bad.arrow: batch 1") && e.contains("truncated"), "{e}");
    let wide = wide_batch(0.0, 2);
    let e = long_err(vec![Ok(wide)]);
    assert!(e.contains("no column \"sensor\""), "{e}");
    // decreasing wide time
    let layout = BatchLayout::Wide {
        sensor: SensorId::new("s"),
        columns: ColumnSelector::Names(vec!["ff_e1".into()]),
        time: WideTime::Column { name: "t".into(), unit: TimeUnit::Seconds },
    };
    let e = BatchFrames::new([Ok(wide_batch(1.0, 2)), Ok(wide_batch(0.5, 1))].into_iter(), "w", layout)
        .find_map(|r| r.err())
        .unwrap()
        .to_string();
    assert!(e.contains("w: batch 1 row 0 (row 2 of the source): time 500000000 ns is earlier"), "{e}");
}

/// The frames of the batches before an error are all yielded first, none of the failing
/// batch's; the error comes once, then nothing. After a clean end the decoder still tells the
/// taxel count and the rows read.
#[test]
fn errors_come_once_after_the_frames_before_them() {
    let ok = |t: i64| {
        long_batch(vec![Some(vec![Some(1.0), Some(2.0)]), Some(vec![Some(3.0), Some(4.0)])], 2, vec![t, t + 1])
    };
    let bad = long_batch(vec![Some(vec![Some(5.0), Some(6.0)]), Some(vec![Some(f64::NAN), Some(0.0)])], 2, vec![4, 5]);
    for (third, msg) in [
        (Ok(bad), "bad.arrow: batch 2 row 1 (row 5 of the source): taxel 0: value NaN is not finite"),
        (Err(ArrowError::IpcError("truncated".into())), "bad.arrow: batch 2"),
    ] {
        let batches = vec![Ok(ok(0)), Ok(ok(2)), third, Ok(ok(6))];
        let mut it = BatchFrames::new(batches.into_iter(), "bad.arrow", BatchLayout::Long { sensors: None });
        let items: Vec<Result<TaxelFrame, gradtac_io::Error>> = it.by_ref().collect();
        assert_eq!(items.len(), 5, "four frames, then the error");
        let firsts: Vec<f64> = items[..4].iter().map(|r| r.as_ref().unwrap().values[0]).collect();
        assert_eq!(firsts, vec![1.0, 3.0, 1.0, 3.0]);
        let e = items[4].as_ref().unwrap_err().to_string();
        assert!(e.starts_with(msg), "{e}");
        assert!(it.next().is_none() && it.next().is_none());
    }
    let mut it = BatchFrames::new([Ok(ok(0)), Ok(ok(2))].into_iter(), "ok.arrow", BatchLayout::Long { sensors: None });
    assert_eq!(it.by_ref().count(), 4);
    assert_eq!((it.decoder().taxel_count(), it.decoder().rows_read()), (Some(2), 4));
}

/// Issue #12: long-layout times going backwards are caught at the source, naming the file,
/// batch and row (they used to surface later, in the window stage, without either).
#[test]
fn long_layout_time_going_back_names_file_batch_and_row() {
    let row = || Some(vec![Some(1.0), Some(2.0)]);
    let e =
        long_err(vec![Ok(long_batch(vec![row(), row()], 2, vec![10, 20])), Ok(long_batch(vec![row()], 2, vec![15]))]);
    assert!(e.starts_with("bad.arrow: batch 1 row 0 (row 2 of the source)"), "{e}");
    assert!(e.contains("time_ns 15 is earlier than its row before (20 ns)"), "{e}");
    // equal times are not refused here (the window stage decides), and sensors are separate
    let two = RecordBatch::try_from_iter([
        ("sensor", Arc::new(StringArray::from(vec!["ff", "th", "ff"])) as ArrayRef),
        ("time_ns", Arc::new(Int64Array::from(vec![5, 1, 5])) as ArrayRef),
        ("values", long_batch(vec![row(), row(), row()], 2, vec![0, 0, 0]).column(2).clone()),
    ])
    .unwrap();
    let n = BatchFrames::new([Ok(two)].into_iter(), "two.arrow", BatchLayout::Long { sensors: None })
        .collect::<Result<Vec<_>, _>>()
        .unwrap()
        .len();
    assert_eq!(n, 3);
}

#[test]
fn garbage_files_and_config_errors() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("junk.arrow");
    std::fs::write(&p, b"ARROW1\0\0not really").unwrap();
    let e = read(&ArrowIpcConfig::long(&p)).unwrap_err().to_string();
    assert!(e.contains("junk.arrow: reading Arrow IPC"), "{e}");
    let p2 = dir.path().join("junk.arrows");
    std::fs::write(&p2, b"\x01\x02\x03").unwrap();
    assert!(read(&ArrowIpcConfig::long(&p2)).unwrap_err().to_string().contains("junk.arrows"));
    let mut cfg = ArrowIpcConfig::long(&p);
    cfg.rate_hz = Some(1.0);
    assert!(read(&cfg).unwrap_err().to_string().contains("wide layout"));
    let cfg: ArrowIpcConfig =
        toml::from_str("arrow = \"x.arrow\"\nformat = \"stream\"\ncolumns = \"ff_e{1..24}\"\nrate_hz = 100.0\n")
            .unwrap();
    assert_eq!(cfg.format, IpcFormat::Stream);
    assert!(matches!(cfg.layout(SensorId::new("ff")).unwrap(), BatchLayout::Wide { .. }));
    assert!(toml::from_str::<ArrowIpcConfig>("arrow = \"x\"\nbogus = 1\n").is_err());
}
