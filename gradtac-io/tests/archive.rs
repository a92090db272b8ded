//! Integration tests of `ParquetArchive`: round trips of frames and tracks through partitioned
//! and rolled archives (bit-exact, in order), rolling by bytes, metadata on every file, the
//! async handle's finish / abort / drop, a child process killed with SIGKILL mid-write, and
//! (when installed) `pyarrow.dataset` reading an archive as one hive-partitioned table.

use arrow_array::cast::AsArray;
use arrow_array::types::{DurationNanosecondType, UInt64Type};
use arrow_array::RecordBatch;
use gradtac_io::archive::{ArchiveConfig, ParquetArchive, Partitioning};
use gradtac_io::records::{to_batch, ArrowRecord};
use gradtac_io::{blocking_archive, FrameShape, ParquetSink};
use gradtac_stages::contour::NoContact;
use gradtac_stages::track::{ContactState, TrackPoint};
use gradtac_stream::{HasSensor, SensorId, TaxelFrame, Timestamp};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::basic::Compression;
use proptest::prelude::*;
use std::collections::{BTreeMap, HashMap};
use std::fs::{self, File};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

// ---------------------------------------------------------------------------------------------
// helpers

const SPECIALS: [f64; 7] = [
    f64::MIN_POSITIVE / 3.0,
    -0.0,
    f64::MAX,
    f64::MIN,
    f64::NEG_INFINITY,
    0.1 + 0.2,
    f64::from_bits(0x7ff8_0000_dead_beef),
];

/// Taxel `i` of frame `seq`: deterministic, with every f64 corner now and then.
fn value(seq: u64, i: usize) -> f64 {
    let k = seq as usize + i;
    if k % 7 == 0 {
        SPECIALS[(k / 7) % SPECIALS.len()]
    } else {
        (seq as f64 * 0.37 + i as f64).sin() * 1e3
    }
}

fn frame(sensor: &str, seq: u64, taxels: usize) -> TaxelFrame {
    let values = (0..taxels).map(|i| value(seq, i)).collect();
    TaxelFrame::new(SensorId::new(sensor), Timestamp(seq as i64 * 1_000_000 - 3), seq, values)
}

fn track(sensor: &str, k: u64) -> TrackPoint {
    let contact = k % 5 != 3;
    let nan = f64::NAN;
    TrackPoint {
        sensor: SensorId::new(sensor),
        time: Timestamp(k as i64 * 10_000_000),
        start: Timestamp(k as i64 * 10_000_000 - 90_000_000),
        seq: k,
        state: if contact { ContactState::Contact } else { ContactState::NoContact },
        no_contact: (!contact).then_some(NoContact::TooSmall),
        track: contact.then_some(k / 10),
        x_mm: if contact { value(k, 0) } else { nan },
        y_mm: if contact { k as f64 * 0.1 } else { nan },
        area_mm2: if contact { 12.5 } else { f64::from_bits(0x7ff8_0000_dead_beef) },
        orientation_rad: if contact { -std::f64::consts::FRAC_PI_2 + 1e-16 } else { nan },
        peak: if contact { value(k, 3) } else { nan },
        velocity_mm_s: (contact && k % 10 != 0).then_some([value(k, 5), -3.25]),
        gated: k % 7 == 0,
        fit: None,
    }
}

struct FileBack {
    batches: Vec<RecordBatch>,
    rows: i64,
    kv: HashMap<String, String>,
    compressions: Vec<Compression>,
}

/// Read a whole Parquet file with the `parquet` crate; panics (naming the file) if it is not
/// complete and valid.
fn read(path: &Path) -> FileBack {
    let builder = ParquetRecordBatchReaderBuilder::try_new(File::open(path).unwrap())
        .unwrap_or_else(|e| panic!("{} is not a valid Parquet file: {e}", path.display()));
    let md = builder.metadata().clone();
    let kv = md
        .file_metadata()
        .key_value_metadata()
        .map(|kv| kv.iter().map(|kv| (kv.key.clone(), kv.value.clone().unwrap_or_default())).collect())
        .unwrap_or_default();
    let compressions = md.row_groups().iter().flat_map(|g| g.columns().iter().map(|c| c.compression())).collect();
    let batches =
        builder.build().unwrap().collect::<Result<Vec<_>, _>>().unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    FileBack { batches, rows: md.file_metadata().num_rows(), kv, compressions }
}

/// Every file under `dir` (recursively), relative, sorted.
fn tree(dir: &Path) -> Vec<String> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<String>) {
        for e in fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                out.push(p.strip_prefix(root).unwrap().to_string_lossy().into_owned());
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

/// Each batch read back equals, bit for bit (arrays compare their buffers), the matching
/// slice of `expected` written as one batch — every column of it, except a `sensor` column
/// left out of sensor-partitioned files (`partitioned`), which must then be absent.
fn assert_batches_equal<T: ArrowRecord>(
    shape: &T::Shape,
    expected: &[T],
    got: &[RecordBatch],
    what: &str,
    partitioned: bool,
) {
    let want = to_batch(shape, expected).unwrap();
    let rows: usize = got.iter().map(|b| b.num_rows()).sum();
    assert_eq!(rows, expected.len(), "{what}: row count");
    let mut offset = 0;
    for b in got {
        let w = want.slice(offset, b.num_rows());
        assert_eq!(b.num_columns() + usize::from(partitioned), w.num_columns(), "{what}");
        assert_eq!(
            b.column_by_name("sensor").is_none(),
            partitioned,
            "{what}: the partition column is not in the file"
        );
        for field in w.schema().fields().iter().filter(|f| !(partitioned && f.name() == "sensor")) {
            let (g, e) = (b.column_by_name(field.name()).unwrap(), w.column_by_name(field.name()).unwrap());
            assert_eq!(g.to_data(), e.to_data(), "{what}: column {} at row {offset}", field.name());
        }
        offset += b.num_rows();
    }
}

fn pyarrow() -> bool {
    Command::new("python3").args(["-c", "import pyarrow.dataset"]).output().map(|o| o.status.success()).unwrap_or(false)
}

// ---------------------------------------------------------------------------------------------
// round trips

/// Frames of three sensors, partitioned by sensor and rolled every 100 rows: each sensor's
/// directory, read in file-name order, gives back exactly its frames in order.
#[test]
fn frames_round_trip_through_a_partitioned_archive() {
    let dir = tempfile::tempdir().unwrap();
    let taxels = 5;
    let shape = FrameShape::unnamed(taxels).unwrap();
    let sensors = ["ff", "th", "left hand/mf"];
    let input: Vec<TaxelFrame> = (0..1000u64).map(|k| frame(sensors[(k % 7 % 3) as usize], k, taxels)).collect();
    let mut a = ParquetArchive::<TaxelFrame>::try_new(dir.path(), shape.clone())
        .unwrap()
        .with_partitioning(Partitioning::Sensor)
        .unwrap()
        .with_roll_rows(100)
        .unwrap()
        .with_row_group_size(32)
        .unwrap()
        .with_metadata("gradtac.scene", "scene text")
        .with_metadata("gradtac.layout", "e1,e2");
    for f in &input {
        a.push(f).unwrap();
    }
    assert_eq!(a.rows(), 1000);
    assert_eq!(a.open_files().len(), 3, "one open file per sensor");
    let files = a.finish().unwrap();
    let listing = tree(dir.path());
    assert!(listing.iter().all(|f| !f.contains(".partial")), "{listing:?}");
    assert_eq!(listing.len(), files.len());

    for sensor in sensors {
        let want: Vec<TaxelFrame> = input.iter().filter(|f| f.sensor.as_str() == sensor).cloned().collect();
        let sub = dir.path().join(gradtac_io::archive::hive_segment("sensor", sensor));
        let mut names: Vec<String> =
            fs::read_dir(&sub).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
        names.sort();
        let expected_names: Vec<String> =
            (0..want.len().div_ceil(100)).map(|i| format!("part-{i:06}.parquet")).collect();
        assert_eq!(names, expected_names, "{sensor}");
        let mut batches = Vec::new();
        for (i, name) in names.iter().enumerate() {
            let back = read(&sub.join(name));
            assert_eq!(back.rows, (want.len() - 100 * i).min(100) as i64, "{sensor} {name:?}");
            assert_eq!(back.kv["gradtac.schema"], "frame/2");
            assert_eq!(back.kv["gradtac.version"], env!("CARGO_PKG_VERSION"));
            assert_eq!(back.kv["gradtac.scene"], "scene text");
            assert_eq!(back.kv["gradtac.layout"], "e1,e2");
            assert!(back.compressions.iter().all(|c| matches!(c, Compression::ZSTD(_))));
            batches.extend(back.batches);
        }
        assert_batches_equal(&shape, &want, &batches, sensor, true);
    }
}

/// Tracks rolled by time spans of 100 ms (aligned to the epoch), not partitioned: the files
/// in name order give back every point in order, and each file covers one span.
#[test]
fn tracks_round_trip_through_an_archive_rolled_by_time() {
    let dir = tempfile::tempdir().unwrap();
    // 10 ms apart, two sensors interleaved: 300 points over 3 s → 30 spans of 100 ms
    let input: Vec<TrackPoint> = (0..300u64).map(|k| track(if k % 2 == 0 { "ff" } else { "th" }, k)).collect();
    let cfg: ArchiveConfig = toml::from_str("roll_seconds = 0.1\nrow_group_size = 7\nprefix = \"tracks\"").unwrap();
    let mut a = ParquetArchive::<TrackPoint>::from_config(dir.path(), (), &cfg).unwrap();
    for p in &input {
        a.push(p).unwrap();
    }
    let files = a.finish().unwrap();
    assert_eq!(files.len(), 30);
    let mut batches = Vec::new();
    for (i, f) in files.iter().enumerate() {
        assert_eq!(f, &dir.path().join(format!("tracks-{i:06}.parquet")));
        let back = read(f);
        assert_eq!(back.kv["gradtac.schema"], "track/3");
        let times: Vec<i64> = back
            .batches
            .iter()
            .flat_map(|b| b.column_by_name("time").unwrap().as_primitive::<DurationNanosecondType>().values().to_vec())
            .collect();
        assert!(times.iter().all(|t| t.div_euclid(100_000_000) == i as i64), "file {i}: {times:?}");
        batches.extend(back.batches);
    }
    assert_batches_equal(&(), &input, &batches, "tracks", false);
    assert_eq!(tree(dir.path()).len(), 30);
}

/// Rolling by size: every file but the last reached `roll_bytes` (by the writer's estimate)
/// and overshoots it by at most about one batch; no rows are lost.
#[test]
fn bytes_roll_files_near_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let taxels = 16;
    let shape = FrameShape::unnamed(taxels).unwrap();
    let roll_bytes = 64 * 1024;
    let batch_rows = 128;
    let mut a = ParquetArchive::<TaxelFrame>::try_new(dir.path(), shape.clone())
        .unwrap()
        .with_roll_bytes(roll_bytes)
        .unwrap()
        .with_row_group_size(batch_rows)
        .unwrap();
    let input: Vec<TaxelFrame> = (0..6000u64).map(|k| frame("ff", k, taxels)).collect();
    for f in &input {
        a.push(f).unwrap();
    }
    let files = a.finish().unwrap();
    assert!(files.len() >= 3, "{} files", files.len());
    // one batch of rows, uncompressed, plus the footer: the most a file can exceed the limit
    let slack = (batch_rows * (taxels * 8 + 32)) as u64 + 8 * 1024;
    let mut batches = Vec::new();
    for (i, f) in files.iter().enumerate() {
        let size = fs::metadata(f).unwrap().len();
        eprintln!("file {i}: {size} bytes");
        assert!(size <= roll_bytes + slack, "file {i}: {size} bytes");
        if i + 1 < files.len() {
            assert!(size >= roll_bytes / 2, "file {i} rolled early: {size} bytes");
        }
        batches.extend(read(f).batches);
    }
    assert_batches_equal(&shape, &input, &batches, "frames", false);
}

// ---------------------------------------------------------------------------------------------
// the async handle: finish, abort, drop

#[tokio::test]
async fn blocking_archive_finishes_on_error_cancel_and_drop() {
    let dir = tempfile::tempdir().unwrap();
    let shape = FrameShape::unnamed(2).unwrap();
    let new = |name: &str| {
        ParquetArchive::<TaxelFrame>::try_new(dir.path().join(name), shape.clone())
            .unwrap()
            .with_partitioning(Partitioning::Sensor)
            .unwrap()
            .with_roll_rows(10)
            .unwrap()
    };

    // An upstream error (or a Ctrl-C) ends the stream early: `finish` keeps every record sent.
    let w = blocking_archive(new("cancelled"), 4);
    for k in 0..25 {
        w.send(frame(if k < 20 { "ff" } else { "th" }, k, 2)).await.unwrap();
    }
    let files = w.finish().await.unwrap();
    assert_eq!(
        tree(&dir.path().join("cancelled")),
        ["sensor=ff/part-000000.parquet", "sensor=ff/part-000001.parquet", "sensor=th/part-000000.parquet"]
    );
    assert_eq!(files.len(), 3);
    assert_eq!(read(&dir.path().join("cancelled/sensor=th/part-000000.parquet")).rows, 5);

    // A record that does not fit stops the writer; what was sent before is finished.
    let w = blocking_archive(new("bad"), 1);
    for k in 0..12 {
        w.send(frame("ff", k, 2)).await.unwrap();
    }
    let _ = w.send(frame("ff", 12, 3)).await;
    let mut refused = false;
    for k in 13..20 {
        refused |= w.send(frame("ff", k, 2)).await.is_err();
    }
    assert!(refused, "sends fail once the writer stopped");
    let e = w.finish().await.unwrap_err();
    assert!(matches!(e, gradtac_io::Error::Record { .. }), "{e}");
    assert_eq!(tree(&dir.path().join("bad")), ["sensor=ff/part-000000.parquet", "sensor=ff/part-000001.parquet"]);
    assert_eq!(read(&dir.path().join("bad/sensor=ff/part-000001.parquet")).rows, 2);

    // abort: closed valid, left under the hidden temporary name.
    let w = blocking_archive(new("aborted"), 4);
    for k in 0..13 {
        w.send(frame("ff", k, 2)).await.unwrap();
    }
    let kept = w.abort().await.unwrap();
    assert_eq!(kept, [dir.path().join("aborted/sensor=ff/.part-000001.parquet.partial")]);
    assert_eq!(read(&kept[0]).rows, 3);
    assert_eq!(
        tree(&dir.path().join("aborted")),
        ["sensor=ff/.part-000001.parquet.partial", "sensor=ff/part-000000.parquet"]
    );
}

/// Files written through writer threads (one per open file) are the inline files, byte for
/// byte: partitioned by sensor, rolled by rows, several row groups per file.
#[test]
fn writer_threads_write_the_same_archive() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, thread: bool| {
        let mut a = ParquetArchive::<TaxelFrame>::try_new(dir.path().join(name), FrameShape::unnamed(3).unwrap())
            .unwrap()
            .with_partitioning(Partitioning::Sensor)
            .unwrap()
            .with_roll_rows(2_500)
            .unwrap()
            .with_row_group_size(1_000)
            .unwrap()
            .with_writer_thread(thread)
            .unwrap();
        for k in 0..12_000 {
            a.push(&frame(if k % 4 == 0 { "th" } else { "ff" }, k, 3)).unwrap();
        }
        a.finish().unwrap();
        let files = tree(&dir.path().join(name));
        let bytes: Vec<Vec<u8>> = files.iter().map(|f| fs::read(dir.path().join(name).join(f)).unwrap()).collect();
        (files, bytes)
    };
    let (inline_files, inline) = write("inline", false);
    let (thread_files, threaded) = write("thread", true);
    assert_eq!(inline_files, thread_files);
    assert_eq!(inline_files.len(), 4 + 2, "ff: 9000 rows in 4 files, th: 3000 in 2");
    assert!(inline == threaded, "a writer thread changed a file");
}

/// Dropping the handle (a cancelled task) finishes the open files on the writer's thread;
/// the runtime waits for it on shutdown.
#[test]
fn dropping_the_async_handle_finishes_the_open_files() {
    let dir = tempfile::tempdir().unwrap();
    let a = ParquetArchive::<TaxelFrame>::try_new(dir.path(), FrameShape::unnamed(2).unwrap())
        .unwrap()
        .with_roll_rows(10)
        .unwrap();
    let rt = tokio::runtime::Builder::new_current_thread().enable_time().build().unwrap();
    rt.block_on(async {
        let w = blocking_archive(a, 4);
        // The task says when its 15th send is in the channel; aborting on a timer instead
        // raced the writer thread on a loaded machine (the task was still waiting on a full
        // channel at send 14, so only 14 records were sent).
        let (sent, all_sent) = tokio::sync::oneshot::channel::<()>();
        let task = tokio::spawn(async move {
            let mut sent = Some(sent);
            for k in 0.. {
                w.send(frame("ff", k, 2)).await.unwrap();
                if k == 14 {
                    let _ = sent.take().expect("signalled once").send(());
                    std::future::pending::<()>().await; // cancelled here, holding the handle
                }
            }
        });
        all_sent.await.unwrap();
        task.abort();
        let _ = task.await;
    });
    drop(rt); // waits for the blocking writer
    assert_eq!(tree(dir.path()), ["part-000000.parquet", "part-000001.parquet"]);
    assert_eq!(read(&dir.path().join("part-000001.parquet")).rows, 5);
}

// ---------------------------------------------------------------------------------------------
// killed mid-write

/// Set (to the archive directory) when this test binary runs as the writer child.
const CHILD_DIR: &str = "GRADTAC_ARCHIVE_KILL_CHILD_DIR";
const KILL_TAXELS: usize = 4;
const KILL_ROWS_PER_FILE: u64 = 200;
/// `th` starts this many frames ahead, so the two sensors never roll at the same moment
/// and one file is always being written.
const KILL_TH_HEAD_START: u64 = 77;
/// The child gives up (exits without finishing) after this many files: bounds time and size
/// (≈ 6 MB) if the parent never kills it.
const KILL_MAX_FILES: usize = 600;
/// Rows of the single file the child finishes before it starts the archive.
const KILL_SINGLE_ROWS: u64 = 321;

fn kill_archive(dir: &Path) -> ParquetArchive<TaxelFrame> {
    ParquetArchive::try_new(dir, FrameShape::unnamed(KILL_TAXELS).unwrap())
        .unwrap()
        .with_partitioning(Partitioning::Sensor)
        .unwrap()
        .with_roll_rows(KILL_ROWS_PER_FILE)
        .unwrap()
        .with_row_group_size(50)
        .unwrap()
        .with_metadata("gradtac.scene", "kill test")
}

/// The child: writes frames of `ff` and `th` forever (within bounds), never finishing.
#[test]
#[ignore = "the writer process of `killed_writer_leaves_every_finished_file_valid`"]
fn kill_child_writer() {
    let dir =
        PathBuf::from(std::env::var_os(CHILD_DIR).expect("run by killed_writer_leaves_every_finished_file_valid"));
    let mut a = kill_archive(&dir);
    // Single-file sinks beside the archive: one finished before the loop, one written in it.
    let single = |name: &str| {
        ParquetSink::<TaxelFrame>::try_new(dir.with_file_name(name), FrameShape::unnamed(KILL_TAXELS).unwrap())
            .unwrap()
            .with_row_group_size(50)
            .unwrap()
    };
    let mut done = single("single-done.parquet");
    for k in 0..KILL_SINGLE_ROWS {
        done.push(&frame("ff", k, KILL_TAXELS)).unwrap();
    }
    done.finish().unwrap();
    let mut live = single("single-live.parquet");
    for k in 0..KILL_TH_HEAD_START {
        a.push(&frame("th", k, KILL_TAXELS)).unwrap();
    }
    for k in 0.. {
        a.push(&frame("ff", k, KILL_TAXELS)).unwrap();
        a.push(&frame("th", k + KILL_TH_HEAD_START, KILL_TAXELS)).unwrap();
        live.push(&frame("ff", k, KILL_TAXELS)).unwrap();
        if k % 16 == 0 {
            std::thread::sleep(Duration::from_millis(1)); // pace: the parent polls
        }
        if a.finished().len() >= KILL_MAX_FILES {
            break;
        }
    }
    std::process::exit(3); // not killed in time: leave the files as a crash would
}

/// Kills the child if the test fails before it does.
struct KillOnDrop(std::process::Child);
impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Final files per partition directory, and temporary files.
fn scan(dir: &Path) -> (BTreeMap<String, Vec<String>>, Vec<String>) {
    let (mut finished, mut partial) = (BTreeMap::<String, Vec<String>>::new(), Vec::new());
    for f in tree(dir) {
        let (part, name) = f.split_once('/').unwrap_or(("", &f));
        if name.ends_with(".partial") {
            partial.push(f.clone());
        } else {
            finished.entry(part.to_string()).or_default().push(name.to_string());
        }
    }
    (finished, partial)
}

/// SIGKILL a process writing an archive (and two single-file sinks): every file under a final
/// name reads back complete and valid, in sequence; the only unfinished files are the open
/// ones, under their (hidden) temporary names; a dataset reader sees exactly the finished files.
#[cfg(unix)]
#[test]
fn killed_writer_leaves_every_finished_file_valid() {
    let dir = tempfile::tempdir().unwrap();
    let archive = dir.path().join("archive");
    let log = dir.path().join("child.log");
    let child = Command::new(std::env::current_exe().unwrap())
        .args(["kill_child_writer", "--exact", "--ignored", "--nocapture", "--test-threads=1"])
        .env(CHILD_DIR, &archive)
        .stdout(Stdio::null())
        .stderr(File::create(&log).unwrap())
        .spawn()
        .unwrap();
    let mut child = KillOnDrop(child);

    // Wait until both sensors have finished at least two files, then kill mid-write.
    let deadline = Instant::now() + Duration::from_secs(120);
    loop {
        if let Some(status) = child.0.try_wait().unwrap() {
            panic!("the writer exited ({status}) before it was killed: {}", fs::read_to_string(&log).unwrap());
        }
        let (finished, _) = if archive.exists() { scan(&archive) } else { Default::default() };
        if finished.len() == 2 && finished.values().all(|f| f.len() >= 2) {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "the writer finished no files in 120 s: {}",
            fs::read_to_string(&log).unwrap()
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    std::thread::sleep(Duration::from_millis(25)); // into the next files
    child.0.kill().unwrap(); // SIGKILL
    let status = child.0.wait().unwrap();
    assert!(!status.success(), "{status}");

    let (finished, partial) = scan(&archive);
    assert_eq!(finished.keys().collect::<Vec<_>>(), ["sensor=ff", "sensor=th"]);
    let mut total = 0;
    for (part, names) in &finished {
        let sensor = part.strip_prefix("sensor=").unwrap();
        // names are 0, 1, 2, … with no gap: nothing finished was lost
        let want: Vec<String> = (0..names.len()).map(|i| format!("part-{i:06}.parquet")).collect();
        assert_eq!(names, &want, "{part}");
        for (i, name) in names.iter().enumerate() {
            let back = read(&archive.join(part).join(name));
            assert_eq!(back.rows, KILL_ROWS_PER_FILE as i64, "{part}/{name}");
            assert_eq!(back.kv["gradtac.scene"], "kill test");
            assert_eq!(back.kv["gradtac.schema"], "frame/2");
            let first = i as u64 * KILL_ROWS_PER_FILE;
            let want: Vec<TaxelFrame> =
                (first..first + KILL_ROWS_PER_FILE).map(|k| frame(sensor, k, KILL_TAXELS)).collect();
            assert_batches_equal(&FrameShape::unnamed(KILL_TAXELS).unwrap(), &want, &back.batches, name, true);
            total += back.rows;
        }
        // at most one unfinished file here: the next one, under its temporary name only
        let next = format!("part-{:06}.parquet", names.len());
        let mine: Vec<&String> = partial.iter().filter(|p| p.starts_with(&format!("{part}/"))).collect();
        assert!(mine.len() <= 1, "{mine:?}");
        if let Some(p) = mine.first() {
            assert_eq!(**p, format!("{part}/.{next}.partial"));
            assert!(!archive.join(part).join(&next).exists());
            // If the kill came after its footer was written, it holds the next rows.
            if let Ok(b) = ParquetRecordBatchReaderBuilder::try_new(File::open(archive.join(p)).unwrap()) {
                if let Ok(batches) = b.build().and_then(|r| r.collect::<Result<Vec<_>, _>>().map_err(Into::into)) {
                    let seqs: Vec<u64> = batches
                        .iter()
                        .flat_map(|b| b.column_by_name("seq").unwrap().as_primitive::<UInt64Type>().values().to_vec())
                        .collect();
                    let first = names.len() as u64 * KILL_ROWS_PER_FILE;
                    assert_eq!(seqs, (first..first + seqs.len() as u64).collect::<Vec<_>>());
                }
            }
        }
    }
    eprintln!("killed after {total} finished rows; finished {finished:?}; temporary {partial:?}");
    assert!(!partial.is_empty(), "killed while writing, so one file was open");
    assert_eq!(partial.len() + finished.values().map(Vec::len).sum::<usize>(), tree(&archive).len());

    // The single-file sinks: the finished one is complete; the live one exists only as `.partial`.
    let single = read(&dir.path().join("single-done.parquet"));
    assert_eq!(single.rows, KILL_SINGLE_ROWS as i64);
    let want: Vec<TaxelFrame> = (0..KILL_SINGLE_ROWS).map(|k| frame("ff", k, KILL_TAXELS)).collect();
    assert_batches_equal(&FrameShape::unnamed(KILL_TAXELS).unwrap(), &want, &single.batches, "single-done", false);
    assert!(!dir.path().join("single-live.parquet").exists());
    assert!(dir.path().join("single-live.parquet.partial").exists());

    // A dataset reader skips the hidden temporary files and sees every finished row.
    if pyarrow() {
        let out = Command::new("python3")
            .arg("-c")
            .arg("import sys, pyarrow.dataset as ds; print(ds.dataset(sys.argv[1], format='parquet', partitioning='hive').count_rows())")
            .arg(&archive)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), total.to_string());
    } else {
        eprintln!("pyarrow check skipped: python3 with pyarrow is not available");
    }
}

// ---------------------------------------------------------------------------------------------
// pyarrow

/// `pyarrow.dataset` reads a partitioned, rolled archive as one table: the hive `sensor`
/// field (percent-decoded) equals every row's sensor column, and every row is there.
#[test]
fn pyarrow_reads_a_partitioned_archive_as_one_table() {
    if !pyarrow() {
        eprintln!("skipped: python3 with pyarrow is not available");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let sensors = ["ff", "th", "left hand/mf=1"];
    let mut a = ParquetArchive::<TaxelFrame>::try_new(dir.path(), FrameShape::unnamed(3).unwrap())
        .unwrap()
        .with_partitioning(Partitioning::Sensor)
        .unwrap()
        .with_roll_rows(64)
        .unwrap();
    let input: Vec<TaxelFrame> = (0..500u64).map(|k| frame(sensors[(k % 3) as usize], k, 3)).collect();
    for f in &input {
        a.push(f).unwrap();
    }
    a.finish().unwrap();
    let script = r#"
import sys, json, pyarrow.dataset as ds, pyarrow.compute as pc
d = ds.dataset(sys.argv[1], format="parquet", partitioning="hive")
t = d.to_table()
out = {}
for s in sorted(set(t.column("sensor").to_pylist())):
    rows = d.to_table(filter=ds.field("sensor") == s)
    out[s] = rows.column("seq").to_pylist()
print(json.dumps({"rows": t.num_rows, "by_sensor": out}))
"#;
    let out = Command::new("python3").arg("-c").arg(script).arg(dir.path()).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let got: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(got["rows"], 500);
    for s in sensors {
        let mut want: Vec<u64> = input.iter().filter(|f| f.sensor() == &SensorId::new(s)).map(|f| f.seq).collect();
        let mut seqs: Vec<u64> = serde_json::from_value(got["by_sensor"][s].clone()).unwrap();
        // a dataset scan does not promise file order; the set of rows per sensor is the claim
        want.sort();
        seqs.sort();
        assert_eq!(seqs, want, "{s}");
    }
}

// ---------------------------------------------------------------------------------------------
// invariant: any records, any rolling — nothing lost, nothing reordered

/// The `seq` and `time` of every row of the files in `dir` (not recursive), files in name
/// order, one list per file.
fn files_in(dir: &Path) -> Vec<Vec<(u64, i64)>> {
    let mut names: Vec<PathBuf> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file() && p.extension().is_some_and(|x| x == "parquet"))
        .collect();
    names.sort();
    names
        .iter()
        .map(|p| {
            read(p)
                .batches
                .iter()
                .flat_map(|b| {
                    let seq = b.column_by_name("seq").unwrap().as_primitive::<UInt64Type>().values().to_vec();
                    let time =
                        b.column_by_name("time").unwrap().as_primitive::<DurationNanosecondType>().values().to_vec();
                    seq.into_iter().zip(time)
                })
                .collect()
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Whatever the records (times in any order) and the rolling: each partition's files,
    /// read in name order, hold exactly its records in push order; no file is empty; a file
    /// holds at most `roll_rows` rows, and no record of a later time span than its first.
    #[test]
    fn any_records_any_rolling_lose_and_reorder_nothing(
        records in proptest::collection::vec((0usize..3, -50i64..50), 0..120),
        roll_rows in proptest::option::of(1u64..20),
        span in proptest::option::of(1u64..30),
        by_sensor in any::<bool>(),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let sensors = ["ff", "th", "mf"];
        let mut a = ParquetArchive::<TaxelFrame>::try_new(dir.path(), FrameShape::unnamed(1).unwrap()).unwrap();
        if by_sensor {
            a = a.with_partitioning(Partitioning::Sensor).unwrap();
        }
        if let Some(r) = roll_rows {
            a = a.with_roll_rows(r).unwrap();
        }
        if let Some(s) = span {
            a = a.with_roll_span(Duration::from_nanos(s)).unwrap();
        }
        for (k, &(s, t)) in records.iter().enumerate() {
            a.push(&TaxelFrame::new(SensorId::new(sensors[s]), Timestamp(t), k as u64, vec![t as f64])).unwrap();
        }
        let files = a.finish().unwrap();
        let groups: Vec<(PathBuf, Vec<usize>)> = if by_sensor {
            sensors
                .iter()
                .enumerate()
                .map(|(i, s)| (dir.path().join(format!("sensor={s}")), (0..records.len()).filter(|&k| records[k].0 == i).collect()))
                .collect()
        } else {
            vec![(dir.path().to_path_buf(), (0..records.len()).collect())]
        };
        let mut count = 0;
        for (sub, want) in groups {
            let got = if sub.exists() { files_in(&sub) } else { Vec::new() };
            count += got.len();
            let flat: Vec<u64> = got.iter().flatten().map(|&(seq, _)| seq).collect();
            prop_assert_eq!(flat, want.iter().map(|&k| k as u64).collect::<Vec<_>>());
            for f in &got {
                prop_assert!(!f.is_empty());
                if let Some(r) = roll_rows {
                    prop_assert!(f.len() as u64 <= r);
                }
                if let Some(s) = span {
                    let first = f[0].1.div_euclid(s as i64);
                    prop_assert!(f.iter().all(|&(_, t)| t.div_euclid(s as i64) <= first));
                }
            }
            // consecutive files: a roll happened for a reason
            for w in got.windows(2) {
                let full = roll_rows.is_some_and(|r| w[0].len() as u64 == r);
                let later = span.is_some_and(|s| w[1][0].1.div_euclid(s as i64) > w[0][0].1.div_euclid(s as i64));
                prop_assert!(full || later);
            }
        }
        prop_assert_eq!(count, files.len());
        prop_assert!(tree(dir.path()).iter().all(|f| !f.contains(".partial")));
    }
}
