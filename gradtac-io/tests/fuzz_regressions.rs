//! Inputs that once crashed a reader (found by the issue-12 audit or by the fuzz targets in
//! `fuzz/`, see `docs/fuzzing.md`), each pinned to a clean error or a correct result.
//! Crashing files live in `tests/fuzz_regressions/` under the name of the test that reads
//! them.

use arrow_array::builder::{FixedSizeListBuilder, Float64Builder, StringDictionaryBuilder};
use arrow_array::types::Int32Type;
use arrow_array::{ArrayRef, Int64Array, RecordBatch};
use gradtac_io::arrow_ipc::{open_reader, BatchLayout, IpcFormat};
use std::io::Cursor;
use std::path::Path;
use std::sync::Arc;

/// A crash input committed beside this file.
#[allow(dead_code)]
fn crash(name: &str) -> Vec<u8> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_regressions").join(name);
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Read IPC bytes in the long layout: the frames read, or the first error as text.
fn read_long(bytes: Vec<u8>) -> Result<usize, String> {
    let frames = open_reader(Cursor::new(bytes), "crash.arrow", IpcFormat::Auto, BatchLayout::Long { sensors: None })
        .map_err(|e| e.to_string())?;
    let mut n = 0;
    for f in frames {
        f.map_err(|e| e.to_string())?;
        n += 1;
    }
    Ok(n)
}

/// A long-layout batch of `rows` rows whose `sensor` column is dictionary-encoded.
fn dictionary_batch(rows: usize) -> RecordBatch {
    dictionary_batch_from(rows, 0)
}

/// As [`dictionary_batch`], with times starting at `t0_ns` (so batches can follow each other in
/// time: the source refuses a sensor's time going backwards).
fn dictionary_batch_from(rows: usize, t0_ns: i64) -> RecordBatch {
    let mut sensor = StringDictionaryBuilder::<Int32Type>::new();
    let mut values = FixedSizeListBuilder::new(Float64Builder::new(), 2);
    for k in 0..rows {
        sensor.append_value(if k % 2 == 0 { "ff" } else { "th" });
        values.values().append_slice(&[k as f64, 1.0]);
        values.append(true);
    }
    RecordBatch::try_from_iter([
        ("sensor", Arc::new(sensor.finish()) as ArrayRef),
        ("time_ns", Arc::new(Int64Array::from_iter_values((0..rows as i64).map(|k| t0_ns + k * 1000))) as ArrayRef),
        ("values", Arc::new(values.finish()) as ArrayRef),
    ])
    .unwrap()
}

fn ipc_file(batch: &RecordBatch) -> Vec<u8> {
    let mut buf = Vec::new();
    let mut w = arrow_ipc::writer::FileWriter::try_new(&mut buf, &batch.schema()).unwrap();
    w.write(batch).unwrap();
    w.finish().unwrap();
    drop(w);
    buf
}

/// An IPC stream (it may replace a dictionary from one batch to the next).
fn ipc_stream(batches: &[RecordBatch]) -> Vec<u8> {
    let mut buf = Vec::new();
    let mut w = arrow_ipc::writer::StreamWriter::try_new(&mut buf, &batches[0].schema()).unwrap();
    for b in batches {
        w.write(b).unwrap();
    }
    w.finish().unwrap();
    drop(w);
    buf
}

/// Issue 12: a valid zero-row IPC file whose `sensor` column is dictionary-encoded made
/// `AnyDictionaryArray::normalized_keys` assert (empty dictionary). It is an empty source.
#[test]
fn ipc_zero_row_dictionary_sensor_is_an_empty_source() {
    assert_eq!(read_long(ipc_file(&dictionary_batch(0))), Ok(0));
    // an empty batch (and its empty dictionary) between full ones changes nothing
    let b = [dictionary_batch(3), dictionary_batch(0), dictionary_batch_from(2, 10_000)];
    assert_eq!(read_long(ipc_stream(&b)), Ok(5));
}

/// Fuzz target `can_frames` (crash-1e336020…): CAN frame times come from the bus or a log
/// and may lie anywhere in i64; a set opened near `i64::MIN` and a frame near `i64::MAX`
/// overflowed `clock - first_time` in the reassembly timeout check (a panic with overflow
/// checks, a wrong timeout decision without). The set now times out.
#[test]
fn can_reassembly_times_at_the_ends_of_i64() {
    use gradtac_io::can::{CanCodec, CanDecoder, CanEncoder, CodecConfig, PresetConfig, PresetKind};
    use gradtac_stream::Timestamp;
    let codec = CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &["ff"]))).unwrap();
    let values = vec![1000.0; codec.taxels(0)];
    let mut frames = Vec::new();
    CanEncoder::new(codec.clone()).encode(0, &values, Timestamp::ZERO, &mut frames).unwrap();
    assert!(frames.len() > 1);
    let mut dec = CanDecoder::new(codec);
    let mut out = Vec::new();
    dec.push_decoded(frames[0].with_time(Timestamp(i64::MIN + 1)), &mut out);
    assert_eq!(dec.next_deadline().map(|t| t.0 < i64::MIN / 2), Some(true));
    for f in &frames[1..] {
        dec.push_decoded(f.with_time(Timestamp(i64::MAX)), &mut out);
    }
    assert!(out.iter().all(|d| !d.is_complete()), "the set opened at i64::MIN timed out");
    assert!(dec.stats().sets_dropped >= 1);
    // a set opened at the top of the range: its deadline saturates instead of wrapping
    let mut dec = CanDecoder::new(
        CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &["ff"]))).unwrap(),
    );
    dec.push_decoded(frames[0].with_time(Timestamp(i64::MAX - 1)), &mut out);
    assert_eq!(dec.next_deadline(), Some(Timestamp(i64::MAX)));
}

/// Replay a fuzz corpus of the `arrow_ipc` target on stable (`GRADTAC_REPLAY_IPC=<dir>
/// cargo test -p gradtac-io --test fuzz_regressions -- --ignored --nocapture`): every file in
/// every layout; prints where dependency panics were contained (for upstream reports) and
/// fails if a panic escaped.
#[test]
#[ignore = "needs a corpus directory in GRADTAC_REPLAY_IPC"]
fn replay_ipc_corpus() {
    use gradtac_io::arrow_ipc::WideTime;
    use gradtac_io::{ColumnSelector, TimeUnit};
    use std::collections::BTreeMap;
    use std::sync::Mutex;
    let Some(dir) = std::env::var_os("GRADTAC_REPLAY_IPC") else { return };
    // where → (how often, the first message, the first file)
    static SEEN: Mutex<BTreeMap<String, (usize, String, String)>> = Mutex::new(BTreeMap::new());
    static FILE: Mutex<String> = Mutex::new(String::new());
    // gradtac's quiet hook (installed once, by the first `contain`) would hide contained
    // panics from this one: install it now and replace it
    gradtac_io::contain::install_quiet_hook();
    std::panic::set_hook(Box::new(|info| {
        let at = info.location().map(|l| format!("{}:{}", l.file(), l.line())).unwrap_or_default();
        let at = at.rsplit("/registry/src/").next().unwrap_or(&at).to_string();
        let msg = info.payload_as_str().unwrap_or("").chars().take(100).collect::<String>();
        let file = FILE.lock().unwrap().clone();
        SEEN.lock().unwrap().entry(at).or_insert((0, msg, file)).0 += 1;
    }));
    let (mut files, mut errors) = (0, 0);
    for e in std::fs::read_dir(dir).unwrap() {
        let path = e.unwrap().path();
        *FILE.lock().unwrap() = path.display().to_string();
        let bytes = std::fs::read(&path).unwrap();
        let Some((_, body)) = bytes.split_first() else { continue };
        files += 1;
        for layout in [
            BatchLayout::Long { sensors: None },
            BatchLayout::Wide {
                sensor: gradtac_stream::SensorId::new("ff"),
                columns: ColumnSelector::Pattern("*".into()),
                time: WideTime::Column { name: "t".into(), unit: TimeUnit::Seconds },
            },
        ] {
            let r = std::panic::catch_unwind(|| {
                let frames = open_reader(Cursor::new(body.to_vec()), "corpus.arrow", IpcFormat::Auto, layout)?;
                frames.collect::<gradtac_io::Result<Vec<_>>>()
            });
            match r {
                Ok(Ok(_)) => {}
                Ok(Err(e)) => {
                    errors += 1;
                    if std::env::var_os("GRADTAC_REPLAY_VERBOSE").is_some() {
                        // did the arrow-ipc readers alone read every batch? (a check too strict)
                        let alone = std::panic::catch_unwind(|| -> Result<usize, arrow_schema::ArrowError> {
                            if body.starts_with(b"ARROW1") {
                                let r = arrow_ipc::reader::FileReader::try_new(Cursor::new(body.to_vec()), None)?;
                                r.map(|b| b.map(|b| b.num_rows())).sum()
                            } else {
                                let r = arrow_ipc::reader::StreamReader::try_new(Cursor::new(body.to_vec()), None)?;
                                r.map(|b| b.map(|b| b.num_rows())).sum()
                            }
                        });
                        let alone = if matches!(alone, Ok(Ok(_))) { "READ ALONE " } else { "" };
                        eprintln!("{alone}{}: {e}", FILE.lock().unwrap());
                    }
                }
                Err(_) => panic!("a panic escaped the IPC reader"),
            }
        }
    }
    let _ = std::panic::take_hook();
    eprintln!("{files} files, {errors} errors; contained panics:");
    for (at, (n, msg, file)) in SEEN.lock().unwrap().iter() {
        eprintln!("  {n:6}  {at}: {msg}\n          first in {file}");
    }
}

/// Fuzz target `arrow_ipc`: mutated IPC files whose footer blocks, message lengths or buffer
/// offsets point outside the data made arrow-ipc 60 panic — slicing a buffer past the body
/// (`arrow-buffer` `Buffer::slice_with_length`), `unwrap` on a negative block length
/// (`reader.rs` `read_block`), indexing a short message (`parse_message`), allocating the
/// body a footer block claims. The metadata is
/// now checked before the reader uses it: each ends in an error naming the file and the
/// block / message, not in a (contained) panic. The files keep the target's mode byte first.
#[test]
fn ipc_corrupt_metadata_is_a_file_error() {
    for (name, expect) in [
        ("ipc_buffer_slice_past_body.arrow", "lies outside its body"),
        ("ipc_reader_unwrap_967.arrow", "record batch"),
        ("ipc_reader_unwrap_968.arrow", "dictionary 0: block"),
        ("ipc_reader_short_block.arrow", "reading Arrow IPC"),
        // a footer block claiming a 4 GB body in a 1.6 kB file: arrow-ipc allocated it
        // (4.2 GB resident, libFuzzer's out-of-memory) before finding the file too short
        ("ipc_block_body_4gb.arrow", "ends past the end of the file"),
    ] {
        let bytes = crash(name);
        let e = read_long(bytes[1..].to_vec()).expect_err(name);
        assert!(e.contains("crash.arrow") && e.contains(expect), "{name}: {e}");
        assert!(!e.contains("panicked"), "{name}: caught by the check, not contained: {e}");
    }
}

/// `gradtac explain` reads an IPC file's schema through `ipc_schema`, whose reader also reads
/// the footer and the dictionaries: the same metadata check runs first.
#[test]
fn ipc_schema_checks_the_metadata_first() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("big.arrow");
    std::fs::write(&p, &crash("ipc_block_body_4gb.arrow")[1..]).unwrap();
    let e = gradtac_io::arrow_ipc::ipc_schema(&p).unwrap_err().to_string();
    assert!(e.contains("big.arrow") && e.contains("ends past the end of the file"), "{e}");
}

/// A dictionary-encoded `sensor` column holds at most `MAX_SENSOR_DICTIONARY` names.
#[test]
fn ipc_sensor_dictionary_is_bounded() {
    use gradtac_io::arrow_ipc::MAX_SENSOR_DICTIONARY;
    let n = MAX_SENSOR_DICTIONARY + 1;
    let mut sensor = StringDictionaryBuilder::<Int32Type>::new();
    let mut values = FixedSizeListBuilder::new(Float64Builder::new(), 1);
    for k in 0..n {
        sensor.append_value(format!("s{k}"));
        values.values().append_value(1.0);
        values.append(true);
    }
    let batch = RecordBatch::try_from_iter([
        ("sensor", Arc::new(sensor.finish()) as ArrayRef),
        ("time_ns", Arc::new(Int64Array::from_iter_values(0..n as i64)) as ArrayRef),
        ("values", Arc::new(values.finish()) as ArrayRef),
    ])
    .unwrap();
    let e = read_long(ipc_file(&batch)).unwrap_err();
    assert!(e.contains("crash.arrow: batch 0") && e.contains(&format!("a dictionary of {n} sensor names")), "{e}");
}

/// Every column chunk of the Parquet file at `path` passes `parquet_check`, with as many
/// pages as the parquet crate's own page reader finds: (column chunks, pages).
fn check_pages_like_parquet(path: &Path) -> (usize, usize) {
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let reader = SerializedFileReader::new(std::fs::File::open(path).unwrap()).unwrap();
    let mut file = std::fs::File::open(path).unwrap();
    let (mut chunks, mut pages) = (0, 0);
    for (i, rg) in reader.metadata().row_groups().iter().enumerate() {
        for (j, c) in rg.columns().iter().enumerate() {
            let (start, len) = c.byte_range();
            let got = gradtac_io::parquet_check::check_column_chunk(&mut file, start, len)
                .unwrap_or_else(|e| panic!("{}: row group {i} column {j}: {e}", path.display()));
            let expected = reader.get_row_group(i).unwrap().get_column_page_reader(j).unwrap().count();
            assert_eq!(got.pages, expected, "{}: row group {i} column {j}", path.display());
            chunks += 1;
            pages += got.pages;
        }
    }
    (chunks, pages)
}

/// The page-header check (`gradtac_io::parquet_check`, written for parquet 60's reader) passes
/// another writer's files: Arrow C++ through pyarrow 26, data pages v1 and v2 with page CRCs,
/// page statistics, dictionaries, nulls and a list column (`pyarrow_pages.py` writes them).
#[test]
fn parquet_check_passes_pyarrow_files() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_regressions");
    for v in [1, 2] {
        let (chunks, pages) = check_pages_like_parquet(&dir.join(format!("pyarrow_pages_v{v}.parquet")));
        assert_eq!((chunks, pages), (12, 66), "v{v}");
    }
}

/// Check the page headers of Parquet files from other writers
/// (`GRADTAC_CHECK_PARQUET=a.parquet:b.parquet cargo test -p gradtac-io --test fuzz_regressions
/// -- --ignored --nocapture`, absolute paths): as `parquet_check_passes_pyarrow_files`.
#[test]
#[ignore = "needs Parquet files in GRADTAC_CHECK_PARQUET"]
fn check_foreign_parquet_files() {
    let Some(files) = std::env::var_os("GRADTAC_CHECK_PARQUET") else { return };
    for path in std::env::split_paths(&files) {
        let (chunks, pages) = check_pages_like_parquet(&path);
        eprintln!("{}: {chunks} column chunks, {pages} pages: pass", path.display());
    }
}

/// Fuzz target `arrow_ipc` (the closing run's corpus, replayed by `replay_ipc_corpus`):
/// inputs on which arrow 60 still panics past gradtac's metadata check — arrow-buffer's
/// `ScalarBuffer` alignment assertion (`immutable.rs:334`, "prefix.is_empty() &&
/// suffix.is_empty()") and arrow-data's "integer overflow computing expected number of
/// expected values in FixedListSize" (`data.rs:1294`) while validating a record batch. Both
/// are contained at the reader (upstream bugs, see `docs/upstream-arrow-parquet.md`): an
/// error naming the file and the batch, never a panic out of the reader.
#[test]
fn ipc_remaining_dependency_panics_are_file_errors() {
    use gradtac_io::arrow_ipc::WideTime;
    use gradtac_io::{ColumnSelector, TimeUnit};
    for (name, expect) in [
        ("ipc_buffer_misaligned_view.arrow", "prefix.is_empty() && suffix.is_empty()"),
        ("ipc_fixed_size_list_overflow.arrow", "integer overflow computing expected number"),
    ] {
        let bytes = crash(name);
        let mut errors = Vec::new();
        for layout in [
            BatchLayout::Long { sensors: None },
            BatchLayout::Wide {
                sensor: gradtac_stream::SensorId::new("ff"),
                columns: ColumnSelector::Pattern("*".into()),
                time: WideTime::Column { name: "t".into(), unit: TimeUnit::Seconds },
            },
        ] {
            let r = open_reader(Cursor::new(bytes[1..].to_vec()), "crash.arrow", IpcFormat::Auto, layout)
                .and_then(|frames| frames.collect::<gradtac_io::Result<Vec<_>>>());
            errors.push(r.expect_err(name).to_string());
        }
        eprintln!("{name}: {errors:?}");
        assert!(errors.iter().all(|e| e.contains("crash.arrow")), "{name}: {errors:?}");
        assert!(errors.iter().any(|e| e.contains("panicked") && e.contains(expect)), "{name}: {errors:?}");
    }
}

/// Found by the `mcap` fuzz target (issue 24's run): a schema whose `builtin_interfaces/Time`
/// declares `int64 sec` let a stamp's seconds overflow `sec · 10⁹ + nsec` (a debug-build
/// panic, a wrapped time in release). Now the message is an error naming file, offset, topic
/// and message.
#[test]
fn mcap_int64_stamp_seconds_is_a_message_error() {
    use gradtac_io::rosbag::{BagSensor, McapFrames, StampSource};
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("stamp.mcap");
    std::fs::write(&p, crash("mcap_int64_stamp_seconds.mcap")).unwrap();
    let s = BagSensor {
        sensor: gradtac_stream::SensorId::new("x"),
        topic: "/rh/tactile".into(),
        finger: None,
        time: StampSource::Header,
    };
    let r: Result<Vec<_>, _> = McapFrames::open(&p, vec![s]).unwrap().collect();
    let e = r.unwrap_err().to_string();
    assert!(e.contains("stamp.mcap at byte") && e.contains("topic /rh/tactile"), "{e}");
    assert!(e.contains("does not fit in i64 nanoseconds"), "{e}");
}
