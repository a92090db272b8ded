//! Integration tests of the Parquet sink: round trip, metadata, compression, row groups, the
//! `.partial` protocol, and (when installed) reading with pyarrow.

use arrow_array::{
    Array, DurationNanosecondArray, FixedSizeListArray, Float64Array, RecordBatch, StringArray, UInt64Array,
};
use gradtac_io::records::frame::TAXELS_KEY;
use gradtac_io::{CsvFrames, CsvSourceConfig, Error, FrameShape, ParquetSink};
use gradtac_stream::{Layout, SensorId, TaxelFrame, Timestamp};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::basic::Compression;
use proptest::prelude::*;
use std::collections::HashMap;
use std::fs::File;
use std::path::{Path, PathBuf};

mod common;
use common::{pyarrow_available, python_float_hex, run_python};

/// Frames whose values exercise every corner of f64: subnormals, −0.0, extremes, NaN with a
/// payload, and values that are not short decimals.
fn frames(n: usize, taxels: usize) -> Vec<TaxelFrame> {
    let specials =
        [f64::MIN_POSITIVE / 3.0, -0.0, f64::MAX, f64::MIN, f64::from_bits(0x7ff8_0000_dead_beef), 0.1 + 0.2];
    (0..n)
        .map(|k| {
            let values = (0..taxels)
                .map(|i| {
                    if (k + i) % 7 == 0 {
                        specials[(k + i) % specials.len()]
                    } else {
                        (k as f64 * 0.37 + i as f64).sin() * 1e3
                    }
                })
                .collect();
            let sensor = if k % 3 == 0 { "th" } else { "ff" };
            TaxelFrame::new(SensorId::new(sensor), Timestamp::from_nanos(k as i64 * 10_000_000 - 5), k as u64, values)
        })
        .collect()
}

fn read_back(path: &Path) -> (Vec<RecordBatch>, parquet::file::metadata::ParquetMetaData) {
    let builder = ParquetRecordBatchReaderBuilder::try_new(File::open(path).unwrap()).unwrap();
    let metadata = builder.metadata().as_ref().clone();
    let batches = builder.build().unwrap().collect::<Result<Vec<_>, _>>().unwrap();
    (batches, metadata)
}

fn frames_of(batches: &[RecordBatch]) -> Vec<TaxelFrame> {
    let mut out = Vec::new();
    for b in batches {
        let sensor = b.column_by_name("sensor").unwrap().as_any().downcast_ref::<StringArray>().unwrap();
        let time = b.column_by_name("time").unwrap().as_any().downcast_ref::<DurationNanosecondArray>().unwrap();
        let seq = b.column_by_name("seq").unwrap().as_any().downcast_ref::<UInt64Array>().unwrap();
        let values = b.column_by_name("values").unwrap().as_any().downcast_ref::<FixedSizeListArray>().unwrap();
        for r in 0..b.num_rows() {
            let v = values.value(r);
            let v = v.as_any().downcast_ref::<Float64Array>().unwrap();
            out.push(TaxelFrame::new(
                SensorId::new(sensor.value(r)),
                Timestamp::from_nanos(time.value(r)),
                seq.value(r),
                v.values().to_vec(),
            ));
        }
    }
    out
}

fn bits(f: &[TaxelFrame]) -> Vec<(String, i64, u64, Vec<u64>)> {
    f.iter()
        .map(|f| (f.sensor.to_string(), f.time.as_nanos(), f.seq, f.values.iter().map(|x| x.to_bits()).collect()))
        .collect()
}

fn kv(md: &parquet::file::metadata::ParquetMetaData) -> HashMap<String, String> {
    md.file_metadata()
        .key_value_metadata()
        .unwrap()
        .iter()
        .map(|kv| (kv.key.clone(), kv.value.clone().unwrap_or_default()))
        .collect()
}

#[test]
fn round_trip_is_bit_exact_with_metadata_zstd_and_row_groups() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("frames.parquet");
    let layout = Layout::biotac_sp();
    let input = frames(1050, layout.len());
    let mut sink = ParquetSink::<TaxelFrame>::try_new(&target, FrameShape::from_layout(&layout))
        .unwrap()
        .with_row_group_size(100)
        .unwrap()
        .with_metadata("gradtac.scene", "[[sensor]]\nname = \"ff\"\n")
        .with_metadata("gradtac.layout", layout.name());
    for f in &input {
        sink.push(f).unwrap();
    }
    assert_eq!(sink.rows(), 1050);
    assert!(!target.exists(), "nothing under the final name before finish");
    assert!(dir.path().join("frames.parquet.partial").exists());
    let done = sink.finish().unwrap();
    assert_eq!(done, target);
    assert!(!dir.path().join("frames.parquet.partial").exists());

    let (batches, md) = read_back(&target);
    assert_eq!(bits(&frames_of(&batches)), bits(&input));

    let kv = kv(&md);
    assert_eq!(kv["gradtac.schema"], "frame/2");
    assert_eq!(kv["gradtac.version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(kv["gradtac.scene"], "[[sensor]]\nname = \"ff\"\n");
    assert_eq!(kv["gradtac.layout"], "biotac-sp");
    assert!(kv.contains_key("ARROW:schema"));

    let sizes: Vec<i64> = md.row_groups().iter().map(|g| g.num_rows()).collect();
    assert_eq!(sizes, [vec![100; 10], vec![50]].concat());
    for g in md.row_groups() {
        for c in g.columns() {
            assert!(matches!(c.compression(), Compression::ZSTD(_)), "{:?}", c.compression());
        }
    }

    // The Arrow schema survives, field metadata included.
    let schema = batches[0].schema();
    let names: Vec<String> =
        serde_json::from_str(&schema.field_with_name("values").unwrap().metadata()[TAXELS_KEY]).unwrap();
    assert_eq!(names, layout.names());
    assert_eq!(
        schema.field_with_name("time").unwrap().data_type(),
        &arrow_schema::DataType::Duration(arrow_schema::TimeUnit::Nanosecond)
    );
    assert!(schema.fields().iter().all(|f| !f.is_nullable()));
}

/// String columns are dictionary-encoded (a few distinct names); numeric and time columns are
/// written plain (mostly distinct values, where a dictionary costs a hash per value and saves
/// nothing). Either way what a reader gets is what was pushed, bit for bit, over more rows
/// than a batch (8,192) and a row group.
#[test]
fn strings_use_a_dictionary_numbers_are_plain_and_the_round_trip_is_exact() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("enc.parquet");
    let input = frames(20_000, 3);
    let mut sink = ParquetSink::<TaxelFrame>::try_new(&target, FrameShape::unnamed(3).unwrap())
        .unwrap()
        .with_row_group_size(12_000)
        .unwrap();
    for f in &input {
        sink.push(f).unwrap();
    }
    sink.finish().unwrap();
    let (batches, md) = read_back(&target);
    assert_eq!(bits(&frames_of(&batches)), bits(&input));
    assert_eq!(md.row_groups().len(), 2);
    for g in md.row_groups() {
        for c in g.columns() {
            let name = c.column_path().string();
            let dictionary = c.dictionary_page_offset().is_some();
            assert_eq!(dictionary, name == "sensor", "column {name}: dictionary page {dictionary}");
        }
    }
}

#[test]
fn row_groups_larger_than_one_batch() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("big.parquet");
    let input = frames(20_000, 3);
    let mut sink = ParquetSink::<TaxelFrame>::try_new(&target, FrameShape::unnamed(3).unwrap())
        .unwrap()
        .with_row_group_size(9_000)
        .unwrap()
        .with_zstd_level(1)
        .unwrap();
    for f in &input {
        sink.push(f).unwrap();
    }
    sink.finish().unwrap();
    let (batches, md) = read_back(&target);
    let sizes: Vec<i64> = md.row_groups().iter().map(|g| g.num_rows()).collect();
    assert_eq!(sizes, [9_000, 9_000, 2_000]);
    assert_eq!(bits(&frames_of(&batches)), bits(&input));
}

#[test]
fn an_empty_stream_gives_a_valid_empty_file() {
    let dir = tempfile::tempdir().unwrap();
    let sink =
        ParquetSink::<TaxelFrame>::try_new(dir.path().join("e.parquet"), FrameShape::unnamed(4).unwrap()).unwrap();
    let path = sink.finish().unwrap();
    let (batches, md) = read_back(&path);
    assert_eq!(batches.iter().map(RecordBatch::num_rows).sum::<usize>(), 0);
    assert_eq!(md.file_metadata().num_rows(), 0);
    assert_eq!(kv(&md)["gradtac.schema"], "frame/2");
}

#[test]
fn abort_leaves_a_readable_partial_and_no_final_name() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("out.parquet");
    let input = frames(250, 5);
    let mut sink = ParquetSink::<TaxelFrame>::try_new(&target, FrameShape::unnamed(5).unwrap())
        .unwrap()
        .with_row_group_size(100)
        .unwrap();
    for f in &input {
        sink.push(f).unwrap();
    }
    let partial = sink.abort().unwrap();
    assert_eq!(partial, dir.path().join("out.parquet.partial"));
    assert!(!target.exists());
    let (batches, md) = read_back(&partial);
    assert_eq!(bits(&frames_of(&batches)), bits(&input), "every pushed row, pending ones included");
    assert_eq!(kv(&md)["gradtac.schema"], "frame/2");
}

#[test]
fn drop_without_finish_never_makes_the_final_name() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("out.parquet");
    // An older complete file under the final name is left alone, not replaced by a partial one.
    std::fs::write(&target, b"older").unwrap();
    {
        let mut sink = ParquetSink::<TaxelFrame>::try_new(&target, FrameShape::unnamed(2).unwrap())
            .unwrap()
            .with_row_group_size(10)
            .unwrap();
        for f in frames(95, 2) {
            sink.push(&f).unwrap();
        }
    }
    assert_eq!(std::fs::read(&target).unwrap(), b"older");
    let partial = dir.path().join("out.parquet.partial");
    assert!(partial.exists());
    assert!(
        ParquetRecordBatchReaderBuilder::try_new(File::open(&partial).unwrap()).is_err(),
        "no footer: not a complete file"
    );

    // A later run replaces the stale partial and, when finished, the older file.
    let mut sink = ParquetSink::<TaxelFrame>::try_new(&target, FrameShape::unnamed(2).unwrap()).unwrap();
    let input = frames(3, 2);
    for f in &input {
        sink.push(f).unwrap();
    }
    sink.finish().unwrap();
    assert!(!partial.exists());
    assert_eq!(bits(&frames_of(&read_back(&target).0)), bits(&input));
}

#[test]
fn another_taxel_count_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let mut sink =
        ParquetSink::<TaxelFrame>::try_new(dir.path().join("x.parquet"), FrameShape::unnamed(24).unwrap()).unwrap();
    let bad = TaxelFrame::new(SensorId::new("ff"), Timestamp::ZERO, 7, vec![0.0; 23]);
    let e = sink.push(&bad).unwrap_err();
    assert!(matches!(e, Error::Record { .. }));
    let msg = e.to_string();
    assert!(msg.contains("frame 7") && msg.contains("23") && msg.contains("24"), "{msg}");
}

/// CSV in, Parquet out, pyarrow reads it back (when pyarrow is installed): every value equal.
#[test]
fn pyarrow_reads_what_we_write() {
    if !pyarrow_available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("py.parquet");
    let input = frames(300, 4);
    let mut sink = ParquetSink::<TaxelFrame>::try_new(
        &target,
        FrameShape::new(vec!["a".into(), "b".into(), "c".into(), "d".into()]).unwrap(),
    )
    .unwrap()
    .with_row_group_size(128)
    .unwrap()
    .with_metadata("gradtac.scene", "test");
    for f in &input {
        sink.push(f).unwrap();
    }
    sink.finish().unwrap();
    let script = r#"
import json, sys
import pyarrow.parquet as pq
t = pq.read_table(sys.argv[1])
md = pq.read_metadata(sys.argv[1])
kv = {k.decode(): v.decode() for k, v in md.metadata.items() if k != b"ARROW:schema"}
out = {
    "kv": kv,
    "row_groups": [md.row_group(i).num_rows for i in range(md.num_row_groups)],
    "compression": sorted({md.row_group(i).column(j).compression for i in range(md.num_row_groups) for j in range(md.num_columns)}),
    "types": [str(f.type) for f in t.schema],
    "taxels": json.loads(t.schema.field("values").metadata[b"gradtac.taxels"]),
    "sensor": t.column("sensor").to_pylist(),
    "time": t.column("time").cast("int64").to_pylist(),
    "seq": t.column("seq").to_pylist(),
    "values": [[float.hex(x) for x in row] for row in t.column("values").to_pylist()],
}
print(json.dumps(out))
"#;
    let v = run_python(script, [&target]);
    assert_eq!(v["kv"]["gradtac.schema"], "frame/2");
    assert_eq!(v["kv"]["gradtac.scene"], "test");
    assert_eq!(v["row_groups"], serde_json::json!([128, 128, 44]));
    assert_eq!(v["compression"], serde_json::json!(["ZSTD"]));
    assert_eq!(
        v["types"],
        serde_json::json!(["string", "duration[ns]", "uint64", "fixed_size_list<item: double not null>[4]"])
    );
    assert_eq!(v["taxels"], serde_json::json!(["a", "b", "c", "d"]));
    for (k, f) in input.iter().enumerate() {
        assert_eq!(v["sensor"][k], f.sensor.as_str());
        assert_eq!(v["time"][k], f.time.as_nanos());
        assert_eq!(v["seq"][k], f.seq);
        for (i, x) in f.values.iter().enumerate() {
            let py = v["values"][k][i].as_str().unwrap();
            if x.is_nan() {
                assert_eq!(py, "nan", "frame {k} taxel {i}");
            } else {
                assert_eq!(py, python_float_hex(*x), "frame {k} taxel {i}");
            }
        }
    }
}

/// A whole BioTacSP-DoS recording through CSV source and Parquet sink, when present.
#[test]
fn biotacsp_dos_csv_to_parquet_when_present() {
    let csv = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/biotacsp-dos/n/bottle0.csv");
    let csv = if csv.exists() {
        csv
    } else {
        match std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/biotacsp-dos/n")) {
            Ok(mut d) => d.next().unwrap().unwrap().path(),
            Err(_) => {
                eprintln!("skipped: the BioTacSP-DoS recordings are absent");
                return;
            }
        }
    };
    let dir = tempfile::tempdir().unwrap();
    let config = CsvSourceConfig::new(&csv, "ff_e{1..24}".parse().unwrap()).with_rate_hz(100.0);
    let source = CsvFrames::open(&config, SensorId::new("ff")).unwrap();
    let names: Vec<String> = source.columns();
    let target: PathBuf = dir.path().join("rec.parquet");
    let mut sink = ParquetSink::<TaxelFrame>::try_new(&target, FrameShape::new(names).unwrap()).unwrap();
    let mut input = Vec::new();
    for f in source {
        let f = f.unwrap();
        sink.push(&f).unwrap();
        input.push(f);
    }
    sink.finish().unwrap();
    assert!(input.len() > 100);
    assert_eq!(bits(&frames_of(&read_back(&target).0)), bits(&input));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Whatever the row-group size and the values, the file holds exactly the pushed frames
    /// (bit for bit, in order) in row groups of the asked size.
    #[test]
    fn any_frames_and_row_group_size_round_trip(
        raw in prop::collection::vec((any::<i64>(), prop::collection::vec(any::<u64>(), 3)), 0..400),
        row_group in 1usize..150,
    ) {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("p.parquet");
        let input: Vec<TaxelFrame> = raw
            .iter()
            .enumerate()
            .map(|(k, (t, v))| {
                TaxelFrame::new(SensorId::new(["ff", "th", "mf"][k % 3]), Timestamp::from_nanos(*t), k as u64, v.iter().map(|b| f64::from_bits(*b)).collect())
            })
            .collect();
        let mut sink = ParquetSink::<TaxelFrame>::try_new(&target, FrameShape::unnamed(3).unwrap())
            .unwrap()
            .with_row_group_size(row_group)
            .unwrap();
        for f in &input {
            sink.push(f).unwrap();
        }
        sink.finish().unwrap();
        let (batches, md) = read_back(&target);
        prop_assert_eq!(bits(&frames_of(&batches)), bits(&input));
        let sizes: Vec<i64> = md.row_groups().iter().map(|g| g.num_rows()).collect();
        let mut want: Vec<i64> = vec![row_group as i64; input.len() / row_group];
        if input.len() % row_group != 0 {
            want.push((input.len() % row_group) as i64);
        }
        prop_assert_eq!(sizes, want);
    }
}
