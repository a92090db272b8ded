//! End-to-end tests of the `gradtac` binary: scenes over CSV recordings to Parquet.

use arrow_array::{Array, FixedSizeListArray, Float64Array, StringArray, UInt64Array};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

fn gradtac() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gradtac"))
}

fn dos_dir() -> Option<PathBuf> {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/biotacsp-dos");
    d.is_dir().then_some(d)
}

/// Rows of a parquet frame file: (sensor, time ns, seq, values). The sensor comes from the
/// `sensor` column, or for a file of a sensor-partitioned archive (which leaves the column out)
/// from its `sensor=<name>` directory; the time from a `Duration(ns)` (file sources) or a
/// `Timestamp(ns, UTC)` column (CAN buses).
fn read_frames(path: &Path) -> Vec<(String, i64, u64, Vec<f64>)> {
    use arrow_array::cast::AsArray;
    use arrow_array::types::{DurationNanosecondType, TimestampNanosecondType};
    let file = fs::File::open(path).unwrap();
    let reader = ParquetRecordBatchReaderBuilder::try_new(file).unwrap().build().unwrap();
    let partition = path
        .parent()
        .and_then(|d| d.file_name())
        .and_then(|n| n.to_str())
        .and_then(|n| n.strip_prefix("sensor="))
        .map(str::to_string);
    let mut rows = Vec::new();
    for batch in reader {
        let b = batch.unwrap();
        let sensor: Vec<String> = match b.column_by_name("sensor") {
            Some(c) => {
                c.as_any().downcast_ref::<StringArray>().unwrap().iter().map(|s| s.unwrap().to_string()).collect()
            }
            None => vec![partition.clone().expect("a file without sensor column lies in sensor=<name>"); b.num_rows()],
        };
        let t = b.column_by_name("time").unwrap();
        let time: Vec<i64> = match t.as_primitive_opt::<DurationNanosecondType>() {
            Some(d) => d.values().to_vec(),
            None => t.as_primitive::<TimestampNanosecondType>().values().to_vec(),
        };
        let seq = b.column_by_name("seq").unwrap().as_any().downcast_ref::<UInt64Array>().unwrap().clone();
        let vals = b.column_by_name("values").unwrap().as_any().downcast_ref::<FixedSizeListArray>().unwrap().clone();
        for i in 0..b.num_rows() {
            let v = vals.value(i);
            let v = v.as_any().downcast_ref::<Float64Array>().unwrap();
            rows.push((sensor[i].clone(), time[i], seq.value(i), v.values().to_vec()));
        }
    }
    rows
}

/// The CSV's numbers, parsed here with nothing but `str::split` and `parse`.
fn read_csv_numbers(path: &Path) -> Vec<Vec<f64>> {
    fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.split(',').map(|c| c.trim().parse::<f64>().unwrap()).collect())
        .collect()
}

/// min–max normalisation with bounds from the first `n` rows, span floored at 1 count,
/// written out independently of the library.
fn expected_normalised(rows: &[Vec<f64>], n: usize) -> Vec<Vec<f64>> {
    let taxels = rows[0].len();
    let lo: Vec<f64> = (0..taxels).map(|j| rows[..n].iter().map(|r| r[j]).fold(f64::INFINITY, f64::min)).collect();
    let hi: Vec<f64> = (0..taxels).map(|j| rows[..n].iter().map(|r| r[j]).fold(f64::NEG_INFINITY, f64::max)).collect();
    rows.iter().map(|r| (0..taxels).map(|j| (r[j] - lo[j]) / (hi[j] - lo[j]).max(1.0)).collect()).collect()
}

fn scene(dir: &Path, csv: &Path, extra_outputs: &str) -> PathBuf {
    let text = format!(
        r#"
[[sensor]]
name = "ff"
layout = "biotac-sp"
source = {{ csv = "{}", columns = "ff_e{{1..24}}", rate_hz = 100.0 }}

[stages.normalise]
calibrate_frames = 20

[[output]]
tap = "normalise"
path = "out/normalised.parquet"
row_group_size = 100
{extra_outputs}
"#,
        csv.display()
    );
    let p = dir.join("scene.toml");
    fs::write(&p, text).unwrap();
    p
}

fn synthetic_csv(path: &Path, rows: usize) {
    let mut s: String = (1..=24).map(|i| format!("ff_e{i}")).collect::<Vec<_>>().join(",");
    s.push('\n');
    for k in 0..rows {
        let row: Vec<String> = (0..24).map(|j| format!("{}", 2000 + ((k * 37 + j * 101) % 997))).collect();
        s.push_str(&row.join(","));
        s.push('\n');
    }
    fs::write(path, s).unwrap();
}

fn check_normalised_run(csv: &Path) {
    let dir = tempfile::tempdir().unwrap();
    let sc = scene(dir.path(), csv, "");
    let out = gradtac().arg("run").arg("--quiet").arg(&sc).output().unwrap();
    assert!(out.status.success(), "stderr: {}", String::from_utf8_lossy(&out.stderr));
    let rows = read_frames(&dir.path().join("out/normalised.parquet"));
    let input = read_csv_numbers(csv);
    let expected = expected_normalised(&input, 20);
    assert_eq!(rows.len(), input.len(), "every input frame is present");
    for (k, (sensor, t, seq, values)) in rows.iter().enumerate() {
        assert_eq!(sensor, "ff");
        assert_eq!(*seq, k as u64);
        assert_eq!(*t, (k as i64) * 10_000_000, "100 Hz");
        assert_eq!(values, &expected[k], "frame {k} of {}", csv.display());
    }
    assert!(!dir.path().join("out/normalised.parquet.partial").exists());
}

#[test]
fn run_normalises_a_synthetic_recording_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("rec.csv");
    synthetic_csv(&csv, 333);
    check_normalised_run(&csv);
}

#[test]
fn run_normalises_every_biotacsp_dos_class_exactly() {
    let Some(dos) = dos_dir() else {
        eprintln!("skipped: ../shared/data/biotacsp-dos is not present");
        return;
    };
    // one recording of each class
    for class in ["n", "e", "s", "w", "cw", "aw", "t"] {
        let mut files: Vec<_> = fs::read_dir(dos.join(class)).unwrap().map(|e| e.unwrap().path()).collect();
        files.sort();
        check_normalised_run(&files[0]);
    }
}

#[test]
fn a_bad_cell_fails_naming_file_and_line_and_leaves_no_final_output() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("broken.csv");
    synthetic_csv(&csv, 100);
    // line 1 is the header, so line 57 is data row 56
    let mut lines: Vec<String> = fs::read_to_string(&csv).unwrap().lines().map(String::from).collect();
    lines[56] = lines[56].replacen("20", "2x0", 1);
    fs::write(&csv, lines.join("\n") + "\n").unwrap();
    let sc = scene(dir.path(), &csv, "[[output]]\ntap = \"source\"\npath = \"out/raw.parquet\"\n");
    let out = gradtac().arg("run").arg(&sc).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("broken.csv:57"), "stderr: {stderr}");
    for name in ["normalised.parquet", "raw.parquet"] {
        assert!(!dir.path().join("out").join(name).exists(), "{name} must not appear under its final name");
    }
    // what was read before the error is kept, valid, under the temporary name
    let raw = read_frames(&dir.path().join("out/raw.parquet.partial"));
    assert_eq!(raw.len(), 55, "rows before the bad line");
}

#[test]
fn explain_lists_only_what_outputs_need() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("rec.csv");
    synthetic_csv(&csv, 10);
    let sc = scene(dir.path(), &csv, "");
    let out = gradtac().arg("explain").arg(&sc).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let running: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with("  ") && !l.starts_with("  #"))
        .map(|l| l.split_whitespace().next().unwrap())
        .collect();
    let later = gradtac::Tap::ALL.into_iter().filter(|t| *t > gradtac::Tap::Normalise);
    for t in later {
        assert!(!running.contains(&t.name()), "{} must not be built:\n{text}", t.name());
    }
    assert!(running.contains(&"normalise"), "{text}");
    // a second sensor no output uses is not read
    let two = fs::read_to_string(&sc).unwrap().replace(
        "[stages.normalise]",
        &format!("[[sensor]]\nname = \"th\"\nsource = {{ csv = \"{}\", columns = \"ff_e{{1..24}}\", rate_hz = 100.0 }}\n\n[stages.normalise]", csv.display()),
    ) + "sensors = [\"ff\"]\n";
    fs::write(&sc, two).unwrap();
    let text = String::from_utf8(gradtac().arg("explain").arg(&sc).output().unwrap().stdout).unwrap();
    assert!(text.contains("sensor th") && text.contains("not read: no output uses this sensor"), "{text}");
}

#[test]
fn demo_runs_without_arguments_and_says_where() {
    let dir = tempfile::tempdir().unwrap();
    let out = gradtac().args(["demo", "--quiet", "--dir"]).arg(dir.path()).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains(&format!("demo directory: {}", dir.path().display())), "{text}");
    for f in ["events", "surfaces", "contours", "tracks", "slip"] {
        assert!(dir.path().join(format!("out/{f}.parquet")).is_file(), "{f}\n{text}");
    }
    // the simulated slip is found, with the right class, and contacts are located
    assert!(text.contains("slip: detected longitudinal_down"), "{text}");
    let fractions: Vec<f64> = text
        .lines()
        .filter(|l| l.contains("contact location over"))
        .map(|l| l.split("mm (").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(fractions.len(), 2, "{text}");
    assert!(fractions.iter().all(|&f| f < 0.1), "mean error as a fraction of sensor width: {fractions:?}");
}

#[test]
fn scene_errors_are_reported_not_panicked() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.toml");
    fs::write(&p, "[[sensor]]\nname = \"ff\"\nsource = { csv = \"nope.csv\", rate_hz = 100.0, columns = \"a\" }\n[[output]]\ntap = \"normalise\"\npath = \"o.parquet\"\n").unwrap();
    let out = gradtac().arg("run").arg(&p).output().unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("nope.csv"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// A minimal `.npy` (v1.0, little-endian f64, C order) of `rows`.
fn write_npy(path: &Path, rows: &[Vec<f64>]) {
    let header = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': ({}, {}), }}", rows.len(), rows[0].len());
    let mut h = header.into_bytes();
    while (10 + h.len() + 1) % 64 != 0 {
        h.push(b' ');
    }
    h.push(b'\n');
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend((h.len() as u16).to_le_bytes());
    bytes.extend(h);
    for r in rows {
        for v in r {
            bytes.extend(v.to_le_bytes());
        }
    }
    fs::write(path, bytes).unwrap();
}

fn rows_for_test(n: usize) -> Vec<Vec<f64>> {
    (0..n).map(|k| (0..24).map(|j| 1800.0 + ((k * 53 + j * 17) % 409) as f64).collect()).collect()
}

fn run_source_scene(dir: &Path, source: &str) -> Vec<(String, i64, u64, Vec<f64>)> {
    let text = format!(
        "[[sensor]]\nname = \"ff\"\nsource = {source}\n[[output]]\ntap = \"source\"\npath = \"out/raw.parquet\"\n"
    );
    let sc = dir.join("scene.toml");
    fs::write(&sc, text).unwrap();
    let out = gradtac().arg("run").arg("--quiet").arg(&sc).output().unwrap();
    assert!(out.status.success(), "stderr: {}", String::from_utf8_lossy(&out.stderr));
    read_frames(&dir.join("out/raw.parquet"))
}

#[test]
fn npy_sources_run_in_scenes() {
    let dir = tempfile::tempdir().unwrap();
    let rows = rows_for_test(50);
    write_npy(&dir.path().join("rec.npy"), &rows);
    let got = run_source_scene(dir.path(), "{ npy = \"rec.npy\", rate_hz = 50.0 }");
    assert_eq!(got.len(), 50);
    for (k, (_, t, seq, v)) in got.iter().enumerate() {
        assert_eq!((*seq, *t, v), (k as u64, k as i64 * 20_000_000, &rows[k]));
    }
}

#[test]
fn arrow_ipc_sources_run_in_scenes() {
    use arrow_array::{ArrayRef, Float64Array, Int64Array, RecordBatch};
    use arrow_schema::{DataType, Field, Schema};
    use std::sync::Arc;
    let dir = tempfile::tempdir().unwrap();
    let rows = rows_for_test(30);
    let mut fields = vec![Field::new("t", DataType::Int64, false)];
    let mut cols: Vec<ArrayRef> = vec![Arc::new(Int64Array::from_iter_values((0..30).map(|k| k * 1_000_000)))];
    for j in 0..24 {
        fields.push(Field::new(format!("ff_e{}", j + 1), DataType::Float64, false));
        cols.push(Arc::new(Float64Array::from_iter_values(rows.iter().map(|r| r[j]))));
    }
    let schema = Arc::new(Schema::new(fields));
    let batch = RecordBatch::try_new(schema.clone(), cols).unwrap();
    let f = fs::File::create(dir.path().join("rec.arrow")).unwrap();
    let mut w = arrow_ipc::writer::FileWriter::try_new(f, &schema).unwrap();
    w.write(&batch).unwrap();
    w.finish().unwrap();
    let got = run_source_scene(
        dir.path(),
        "{ arrow = \"rec.arrow\", columns = \"ff_e{1..24}\", time_column = \"t\", time_unit = \"ns\" }",
    );
    assert_eq!(got.len(), 30);
    for (k, (_, t, _, v)) in got.iter().enumerate() {
        assert_eq!((*t, v), (k as i64 * 1_000_000, &rows[k]));
    }
}

#[test]
fn every_stage_can_be_tapped_and_explain_counts_latency() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("rec.csv");
    synthetic_csv(&csv, 120);
    let mut extra = String::new();
    for tap in ["savgol", "events", "window", "surface", "contour", "track"] {
        extra.push_str(&format!("[[output]]\ntap = \"{tap}\"\npath = \"out/{tap}.parquet\"\n"));
    }
    let sc = scene(dir.path(), &csv, &extra);
    let text = fs::read_to_string(&sc).unwrap().replace(
        "[stages.normalise]",
        // the event-contour chain (the default centroid would take the contour from the raw frames)
        "[stages.locate]\nmethod = \"events\"\n\n[stages.surface]\ngrid = { nx = 16 }\n\n[stages.savgol]\nwindow = 7\npolyorder = 2\n\n[stages.normalise]",
    );
    fs::write(&sc, text).unwrap();
    let out = gradtac().arg("explain").arg(&sc).output().unwrap();
    let explain = String::from_utf8(out.stdout).unwrap();
    assert!(explain.contains("latency: 3 frames"), "{explain}");
    let out = gradtac().arg("run").arg("--quiet").arg(&sc).output().unwrap();
    assert!(out.status.success(), "stderr: {}", String::from_utf8_lossy(&out.stderr));
    for tap in ["normalised", "savgol", "events", "window", "surface", "contour", "track"] {
        let p = dir.path().join(format!("out/{tap}.parquet"));
        let meta = ParquetRecordBatchReaderBuilder::try_new(fs::File::open(&p).unwrap()).unwrap();
        let kv = meta.metadata().file_metadata().key_value_metadata().unwrap();
        assert!(kv.iter().any(|k| k.key == "gradtac.scene"), "{tap}");
        assert!(kv.iter().any(|k| k.key == "gradtac.schema"), "{tap}");
    }
    // one smoothed frame per input frame, one window aggregate per frame (sliding, step 1)
    assert_eq!(read_frames(&dir.path().join("out/savgol.parquet")).len(), 120);
}

#[test]
fn archive_outputs_roll_and_partition_by_sensor() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("rec.csv");
    synthetic_csv(&csv, 120);
    let text = format!(
        r#"
[[sensor]]
name = "ff"
source = {{ csv = "{c}", columns = "ff_e{{1..24}}", rate_hz = 100.0 }}
[[sensor]]
name = "th"
source = {{ csv = "{c}", columns = "ff_e{{1..24}}", rate_hz = 100.0 }}
[[output]]
tap = "source"
path = "archive"
archive = {{ partition = "sensor", roll_rows = 50 }}
"#,
        c = csv.display()
    );
    let sc = dir.path().join("scene.toml");
    fs::write(&sc, text).unwrap();
    let out = gradtac().arg("run").arg("--quiet").arg(&sc).output().unwrap();
    assert!(out.status.success(), "stderr: {}", String::from_utf8_lossy(&out.stderr));
    for sensor in ["ff", "th"] {
        let part = dir.path().join(format!("archive/sensor={sensor}"));
        let mut files: Vec<_> = fs::read_dir(&part).unwrap().map(|e| e.unwrap().path()).collect();
        files.sort();
        assert_eq!(files.len(), 3, "120 rows in files of 50: {files:?}");
        let rows: Vec<_> = files.iter().flat_map(|f| read_frames(f)).collect();
        assert_eq!(rows.len(), 120);
        assert!(rows.iter().all(|r| r.0 == sensor));
        assert_eq!(rows.iter().map(|r| r.2).collect::<Vec<_>>(), (0..120).collect::<Vec<u64>>());
    }
}

#[cfg(unix)]
#[test]
fn ctrl_c_finishes_outputs_with_what_was_read() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("long.csv");
    synthetic_csv(&csv, 400_000);
    let sc = scene(dir.path(), &csv, "");
    let mut child = gradtac().arg("run").arg("--quiet").arg(&sc).spawn().unwrap();
    // wait until the run has started writing, then interrupt it
    let partial = dir.path().join("out/normalised.parquet.partial");
    let t0 = std::time::Instant::now();
    while !partial.exists() && t0.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    std::thread::sleep(std::time::Duration::from_millis(200));
    let killed = Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    assert!(killed.success());
    let status = child.wait().unwrap();
    let done = dir.path().join("out/normalised.parquet");
    if status.success() {
        // the run finished before the signal arrived: nothing to check about interruption
        assert!(done.exists());
        return;
    }
    assert_eq!(status.code(), Some(130), "interrupted runs exit with 130");
    assert!(done.exists() && !partial.exists(), "an interrupted run finishes its outputs");
    let rows = read_frames(&done);
    assert!(!rows.is_empty() && rows.len() < 400_000, "{} rows", rows.len());
    assert_eq!(rows.iter().map(|r| r.2).collect::<Vec<_>>(), (0..rows.len() as u64).collect::<Vec<_>>());
}

#[test]
fn candump_bus_feeds_several_sensors_and_reports_faults() {
    use gradtac::io::can::{write_candump, CanCodec, CanFrame, CodecConfig, PresetConfig, PresetKind};
    use gradtac::stream::Timestamp;
    let dir = tempfile::tempdir().unwrap();
    let value = |cycle: usize, finger: usize, taxel: usize| (1000 + cycle * 7 + finger * 300 + taxel * 11) as f64;
    // the biotac-mux frames of docs/can.md, from the crate's encoder (its byte layout is
    // checked against hand-packed frames in gradtac-io's tests)
    let codec =
        CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &["ff", "th"]))).unwrap();
    let mut frames = Vec::new();
    let mut set = Vec::new();
    for cycle in 0..40 {
        for finger in 0..2 {
            let t = 1_700_000_000_000_000_000 + cycle as i64 * 10_000_000 + finger as i64 * 1_000_000;
            let v: Vec<f64> = (0..24).map(|k| value(cycle, finger, k)).collect();
            set.clear();
            codec.encode(finger, &v, Timestamp(t), &mut set).unwrap();
            // mux 0 … 5, 0.1 ms apart
            frames.extend(set.iter().enumerate().map(|(mux, f)| f.with_time(Timestamp(t + mux as i64 * 100_000))));
        }
        if cycle == 10 {
            // unknown id
            frames.push(CanFrame::standard(0x7FF, &[0], Timestamp(1_700_000_000_105_500_000)).unwrap());
        }
    }
    write_candump(frames, "can0", fs::File::create(dir.path().join("hand.log")).unwrap()).unwrap();
    let text = r#"
[[bus]]
name = "hand"
candump = "hand.log"
codec = { preset = { kind = "biotac-mux", sensors = ["ff", "th"] } }
stats = "can-stats.json"

[[sensor]]
name = "ff"
source = { bus = "hand" }
[[sensor]]
name = "th"
source = { bus = "hand" }

[[output]]
tap = "source"
path = "out/raw.parquet"
"#;
    let sc = dir.path().join("scene.toml");
    fs::write(&sc, text).unwrap();
    let out = gradtac().arg("run").arg(&sc).output().unwrap();
    assert!(out.status.success(), "stderr: {}", String::from_utf8_lossy(&out.stderr));
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(report.contains("bus hand:"), "{report}");
    let rows = read_frames(&dir.path().join("out/raw.parquet"));
    assert_eq!(rows.len(), 80, "40 cycles × 2 fingertips");
    for (name, finger) in [("ff", 0), ("th", 1)] {
        let mine: Vec<_> = rows.iter().filter(|r| r.0 == name).collect();
        assert_eq!(mine.len(), 40);
        for (cycle, r) in mine.iter().enumerate() {
            let want: Vec<f64> = (0..24).map(|k| value(cycle, finger, k)).collect();
            assert_eq!(r.3, want, "{name} cycle {cycle}");
        }
    }
    let stats: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(dir.path().join("can-stats.json")).unwrap()).unwrap();
    assert_eq!(stats["unknown_id"]["count"], 1, "{stats}");
    assert_eq!(stats["sets_complete"], 80, "{stats}");
}

#[test]
fn live_can_fails_clearly_naming_the_interface() {
    let dir = tempfile::tempdir().unwrap();
    let text = r#"
[[bus]]
name = "hand"
interface = "can0"
codec = { preset = { kind = "biotac-mux", sensors = ["ff"] } }
[[sensor]]
name = "ff"
source = { bus = "hand" }
[[output]]
tap = "source"
path = "out/raw.parquet"
"#;
    let sc = dir.path().join("scene.toml");
    fs::write(&sc, text).unwrap();
    let out = gradtac().arg("run").arg(&sc).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    if out.status.success() {
        eprintln!("this machine has a can0 interface; the failure path was not exercised");
        return;
    }
    assert!(stderr.contains("\"can0\""), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// Write simulated one-fingertip recordings as `<class>/<name>.csv` (columns ff_e1..ff_e24).
fn simulated_labelled(dir: &Path, seeds: std::ops::Range<u64>) {
    use gradtac::stages::sim::{Scene as SimScene, SensorModel, Simulator, Trajectory};
    let layout = gradtac::stream::Layout::biotac_sp();
    // the classes' contact motions in the layout's axes (gradtac_stages::dos): n = +x, e = +y
    for (class, kind) in
        [("n", Trajectory::Right), ("s", Trajectory::Left), ("e", Trajectory::Up), ("w", Trajectory::Down)]
    {
        fs::create_dir_all(dir.join(class)).unwrap();
        for seed in seeds.clone() {
            // every electrode's count falls under pressure, as on the BioTac (no flipped taxels)
            let model = SensorModel { flip_fraction: 0.0, ..Default::default() };
            let sim = Simulator::try_new(layout.clone(), model, seed).unwrap();
            let rec = sim.run(&SimScene::trajectory(kind, 5.0, 5.0, &layout)).unwrap();
            let mut text: String = (1..=24).map(|i| format!("ff_e{i}")).collect::<Vec<_>>().join(",");
            text.push('\n');
            for f in rec.of_sensor(rec.sensors[0].as_str()) {
                text.push_str(&f.frame.values.iter().map(|v| format!("{v}")).collect::<Vec<_>>().join(","));
                text.push('\n');
            }
            fs::write(dir.join(class).join(format!("sim{seed}.csv")), text).unwrap();
        }
    }
}

#[test]
fn calibrate_writes_a_model_that_a_dos_scene_uses() {
    use gradtac::stages::dos::DosClassifier;
    use gradtac::stream::{Layout, SensorId, StageExt};
    let dir = tempfile::tempdir().unwrap();
    let train = dir.path().join("train");
    simulated_labelled(&train, 0..3);
    let model_path = dir.path().join("model.json");
    let out = gradtac().arg("calibrate").arg(&train).arg("--out").arg(&model_path).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("calibrated on 12 recordings: 4 classes"), "{text}");
    // one object ("sim"): no leave-one-object-out choice, the (default) tree part with a = 0.75
    assert!(
        text.contains("tree part (") && text.contains("fewer than two objects") && text.contains("a = 0.75"),
        "{text}"
    );
    let model = gradtac::calibrate::read_model(&model_path).unwrap();
    assert!(model.window.is_none());
    assert_eq!(model.trees.as_ref().map(|w| w.weight), Some(gradtac::calibrate::FALLBACK_WINDOW_WEIGHT));
    let test = dir.path().join("test");
    simulated_labelled(&test, 10..11);
    for class in ["n", "s", "e", "w"] {
        let csv = test.join(class).join("sim10.csv");
        let scene = format!(
            "[[sensor]]\nname = \"ff\"\nsource = {{ csv = \"{}\", columns = \"ff_e{{1..24}}\", rate_hz = 100.0 }}\n\
             [stages.dos]\nmodel = \"{}\"\n[[output]]\ntap = \"dos\"\npath = \"out/{class}.parquet\"\n",
            csv.display(),
            model_path.display()
        );
        let sc = dir.path().join("scene.toml");
        fs::write(&sc, scene).unwrap();
        let out = gradtac().arg("run").arg("--quiet").arg(&sc).output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        // explain shows the model's window part (the trees by default) and its weight
        let text = String::from_utf8(gradtac().arg("explain").arg(&sc).output().unwrap().stdout).unwrap();
        let trees = model.trees.as_ref().unwrap().trees.trees().len();
        assert!(
            text.contains(&format!(
                "Student t + gradient-boosted trees (5-frame windows, 164 inputs with the rotation-sense (fitted with a dilation), dilation and change-energy ones, {trees} trees), \
                 weight a = 0.75"
            )),
            "{text}"
        );
        let file = fs::File::open(dir.path().join(format!("out/{class}.parquet"))).unwrap();
        let batch = ParquetRecordBatchReaderBuilder::try_new(file).unwrap().build().unwrap().next().unwrap().unwrap();
        assert_eq!(batch.num_rows(), 1, "one decision per recording");
        let got = batch.column_by_name("class").unwrap().as_any().downcast_ref::<StringArray>().unwrap().value(0);
        // the scene's decision is the library's decision on the same frames
        let frames: Vec<_> = read_csv_numbers(&csv)
            .into_iter()
            .enumerate()
            .map(|(k, v)| {
                gradtac::stream::TaxelFrame::new(
                    SensorId::new("ff"),
                    gradtac::stream::Timestamp::at_rate(k as u64, 100.0),
                    k as u64,
                    v,
                )
            })
            .collect();
        let mut direct = DosClassifier::try_new(model.clone(), &Layout::biotac_sp(), None).unwrap();
        let want = direct.run_all(frames).unwrap();
        assert_eq!(got, want[0].decision.class.as_str(), "{class}");
    }
}

#[test]
fn an_events_only_scene_builds_no_interpolation() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("rec.csv");
    synthetic_csv(&csv, 10);
    let sc = dir.path().join("scene.toml");
    fs::write(
        &sc,
        format!(
            "[[sensor]]\nname = \"ff\"\nsource = {{ csv = \"{}\", columns = \"ff_e{{1..24}}\", rate_hz = 100.0 }}\n\
             [[output]]\ntap = \"events\"\npath = \"out/events.parquet\"\n",
            csv.display()
        ),
    )
    .unwrap();
    let plan = gradtac::Plan::new(&gradtac::Scene::load(&sc).unwrap()).unwrap();
    let built: Vec<&str> = plan.sensors[0].stages().map(|t| t.name()).collect();
    assert_eq!(built, ["source", "normalise", "savgol", "events"]);
    let text = String::from_utf8(gradtac().arg("explain").arg(&sc).output().unwrap().stdout).unwrap();
    assert!(text.contains("not built: window, surface, contour, track, force, servo, slip, dos"), "{text}");
}

#[test]
fn a_slip_only_scene_builds_what_its_evidence_reads() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("rec.csv");
    synthetic_csv(&csv, 10);
    let sc = dir.path().join("scene.toml");
    let scene = |stages: &str| {
        format!(
            "[[sensor]]\nname = \"ff\"\nsource = {{ csv = \"{0}\", columns = \"ff_e{{1..24}}\", rate_hz = 100.0 }}\n\
             [[sensor]]\nname = \"th\"\nsource = {{ csv = \"{0}\", columns = \"ff_e{{1..24}}\", rate_hz = 100.0 }}\n\
             {stages}[[output]]\ntap = \"slip\"\npath = \"out/slip.parquet\"\n",
            csv.display()
        )
    };
    // the default evidence (the raw-frame pattern): no locator, no track
    fs::write(&sc, scene("")).unwrap();
    let plan = gradtac::Plan::new(&gradtac::Scene::load(&sc).unwrap()).unwrap();
    for p in &plan.sensors {
        assert_eq!(p.stages().map(|t| t.name()).collect::<Vec<_>>(), ["source", "slip"]);
    }
    let text = String::from_utf8(gradtac().arg("explain").arg(&sc).output().unwrap().stdout).unwrap();
    assert!(text.contains("feeds slip") && text.contains("evidence pattern"), "{text}");
    // the latency counts the pattern's centred average (3 frames: 1) and the slip's persistence
    assert!(text.contains("latency to the slip decision: 1 frames + 100.000 ms"), "{text}");
    assert!(gradtac().arg("run").arg(&sc).output().unwrap().status.success());
    // the track evidence: the locator and the track
    fs::write(&sc, scene("[stages.slip]\nevidence = \"track\"\n")).unwrap();
    let plan = gradtac::Plan::new(&gradtac::Scene::load(&sc).unwrap()).unwrap();
    assert_eq!(plan.sensors[0].stages().map(|t| t.name()).collect::<Vec<_>>(), ["source", "contour", "track", "slip"]);
    // the track path's delay (the centroid's averaging) plus the persistence
    let text = String::from_utf8(gradtac().arg("explain").arg(&sc).output().unwrap().stdout).unwrap();
    let line = text.lines().find(|l| l.contains("latency to the slip decision")).expect("a slip latency line");
    assert!(line.contains("+ 100.000 ms") && !line.contains(": 0 frames"), "{text}");
}

#[test]
fn calibrate_cross_validates_and_takes_settings() {
    let dir = tempfile::tempdir().unwrap();
    let train = dir.path().join("train");
    simulated_labelled(&train, 0..3);
    // three "objects": the leading letters of the file names group the recordings
    for class in ["n", "s", "e", "w"] {
        for (seed, object) in [(0, "alpha"), (1, "beta"), (2, "gamma")] {
            let d = train.join(class);
            fs::rename(d.join(format!("sim{seed}.csv")), d.join(format!("{object}{seed}.csv"))).unwrap();
        }
    }
    let settings = dir.path().join("settings.toml");
    fs::write(&settings, "drift_lags = [20, 40]\nfeatures = [\"drift_level\", \"drift_x\", \"drift_y\"]\n").unwrap();
    let model_path = dir.path().join("model.json");
    // `gradtac calibrate FLAGS --gaussian --shrinkage 0.25 --settings … TRAIN --out model.json`: its stdout
    let calibrate = |flag: &str| {
        let out = gradtac()
            .args(["calibrate", flag, "--gaussian", "--shrinkage", "0.25", "--settings"])
            .arg(&settings)
            .arg(&train)
            .arg("--out")
            .arg(&model_path)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8(out.stdout).unwrap()
    };
    let text = calibrate("--cross-validate");
    assert!(text.contains("leave-one-group-out accuracy"), "{text}");
    // the held-out figures of the design choice (no BioTacSP-DoS object sets here: no cross-set)
    assert!(
        text.contains("nested leave-one-object-out") && text.contains("cross-set basic → solids: not available"),
        "{text}"
    );
    for object in ["| alpha | ", "| beta | ", "| gamma | "] {
        assert!(text.contains(object), "{object}: {text}");
    }
    assert!(text.contains("calibrated on 12 recordings: 4 classes, 3 features, "), "{text}");
    // the tree part (the default since stop 34), its weight chosen by leave-one-object-out
    // (three objects)
    assert!(text.contains("tree part (") && text.contains("a = 0.75: "), "{text}");
    let model = gradtac::calibrate::read_model(&model_path).unwrap();
    assert_eq!(model.config.drift_lags, [20, 40]);
    assert_eq!(model.student_t_dof, None, "--gaussian");
    assert!(model.window.is_none());
    let part = model.trees.clone().expect("a tree part by default");
    assert!(gradtac::calibrate::WINDOW_WEIGHTS.contains(&part.weight), "{}", part.weight);
    assert_eq!((part.trees.taxels(), part.trees.recordings()), (24, 12));
    assert_eq!(model.parameter_count(), 24 + part.trees.nodes() + 4 + 1);
    // calibrate's trees are round 6's rule winner T15 (stop 36), exactly as it was scored held out
    let t15: gradtac::stages::dos::train_trees::TreeTrainConfig =
        serde_json::from_str(include_str!("../examples/dos_eval_parts/trees_t15.json")).unwrap();
    assert_eq!(t15, gradtac::stages::dos::train_trees::TreeTrainConfig::default(), "T15 is the default");
    assert_eq!(part.trees.inputs(), &t15.inputs);
    let i = part.trees.inputs();
    assert!(i.turn && i.energy && i.dilation, "T15: rotation-sense, change-energy and dilation inputs");
    assert!(part.trees.trees().len() <= 60 * 7, "T15: 60 rounds of at most 7 trees");
    // round 5's default stays readable as what was scored: T15 without the dilation
    let t13: gradtac::stages::dos::train_trees::TreeTrainConfig =
        serde_json::from_str(include_str!("../examples/dos_eval_parts/trees_t13.json")).unwrap();
    let i = &t13.inputs;
    assert_eq!((t13.colsample, i.turn, i.energy, i.dilation), (0.5, true, true, false));
    // round 6's candidates file: T13 (its baseline row) and T15 read as themselves; T14 and T16
    // asked for the flow-share inputs, removed in stop 37: refused, naming the commit that has them
    // (the file stays as the record; `trees_rule_round6.md` says so)
    let round6: Vec<serde_json::Value> =
        serde_json::from_str(include_str!("../examples/dos_eval_parts/trees_round6_candidates.json")).unwrap();
    assert_eq!(round6.len(), 4);
    let read =
        |v: &serde_json::Value| serde_json::from_value::<gradtac::stages::dos::train_trees::TreeTrainConfig>(v.clone());
    assert_eq!((&read(&round6[0]).unwrap(), &read(&round6[2]).unwrap()), (&t13, &t15));
    for (k, name) in [(1, "T14"), (3, "T16")] {
        assert_eq!(round6[k]["inputs"]["flow_share"], true, "{name}");
        let e = read(&round6[k]).unwrap_err().to_string();
        assert!(e.contains("flow-share") && e.contains("removed") && e.contains("commit e43beac"), "{name}: {e}");
    }
    assert!(serde_json::from_str::<Vec<gradtac::stages::dos::train_trees::TreeTrainConfig>>(include_str!(
        "../examples/dos_eval_parts/trees_round6_candidates.json"
    ))
    .is_err());
    // round 7's candidates (T15 as the baseline row, T17–T19) spell the switch out as false: they read,
    // the baseline row as T15
    let round7: Vec<gradtac::stages::dos::train_trees::TreeTrainConfig> =
        serde_json::from_str(include_str!("../examples/dos_eval_parts/trees_round7_candidates.json")).unwrap();
    assert_eq!((round7.len(), &round7[0]), (4, &t15));
    // round 4's default stays readable as what was scored: T13 without the change-energy inputs
    let t12: gradtac::stages::dos::train_trees::TreeTrainConfig =
        serde_json::from_str(include_str!("../examples/dos_eval_parts/trees_t12.json")).unwrap();
    assert_eq!((t12.colsample, t12.inputs.turn, t12.inputs.energy), (0.5, true, false));
    // the earlier defaults' files are spelled out: they keep meaning what was scored
    let t9: gradtac::stages::dos::train_trees::TreeTrainConfig =
        serde_json::from_str(include_str!("../examples/dos_eval_parts/trees_t9.json")).unwrap();
    assert_eq!((t9.colsample, t9.inputs.turn, t9.augment.copies, t9.augment.imprint), (1.0, false, 2, 0.5));
    let t4: gradtac::stages::dos::train_trees::TreeTrainConfig =
        serde_json::from_str(include_str!("../examples/dos_eval_parts/trees_t4.json")).unwrap();
    assert_eq!((t4.colsample, t4.inputs.turn, t4.augment.copies, t4.augment.imprint), (1.0, false, 1, 0.0));
    // the CLI passed every option on: the library, given the same options, fits the same model
    let opts = gradtac::calibrate::CalibrateOptions { shrinkage: 0.25, student_t_dof: None, ..Default::default() }
        .with_settings_file(&settings)
        .unwrap();
    let layout = gradtac::stream::Layout::biotac_sp();
    let spans = gradtac::calibrate::labelled_spans(&train, &layout, &opts).unwrap();
    let student = gradtac::calibrate::calibrate_spans(&spans, &opts).unwrap();
    assert_eq!(student, model.clone().with_trees(None).unwrap());
    assert_eq!(gradtac::calibrate::calibrate_dos(&train, &layout, &opts).unwrap().0, model, "deterministic");
    // --no-window: the Student-t model alone, as before the window part existed
    let text = calibrate("--no-window");
    assert!(text.contains("calibrated on 12 recordings: 4 classes, 3 features, 24 parameters"), "{text}");
    assert!(!text.contains("window part"), "{text}");
    assert_eq!(gradtac::calibrate::read_model(&model_path).unwrap(), student);
    assert!(!fs::read_to_string(&model_path).unwrap().contains("\"window\""));
    // --window-net: the window net with the motion inputs (stop 32's default); --no-window-motion:
    // stop 31's net without them
    let text = calibrate("--window-net");
    assert!(text.contains("window part: candidate") && text.contains("a = 0.75: "), "{text}");
    let with_net = gradtac::calibrate::read_model(&model_path).unwrap();
    assert!(with_net.trees.is_none());
    let net = &with_net.window.as_ref().expect("a window part").net;
    assert!(net.config.motion, "motion inputs by default");
    assert_eq!(net.inputs(), 48 + gradtac::stages::dos::MOTION_INPUTS);
    assert_eq!((net.taxels, net.recordings), (24, 12));
    assert_eq!(with_net.clone().with_window(None).unwrap(), student, "only the window part changes");
    let text = calibrate("--no-window-motion");
    assert!(text.contains("window part: candidate"), "{text}");
    let still = gradtac::calibrate::read_model(&model_path).unwrap();
    let net = &still.window.as_ref().expect("a window part").net;
    assert!(!net.config.motion);
    assert_eq!(net.inputs(), 48);
    assert_eq!(still.clone().with_window(None).unwrap(), student, "only the window part changes");
    // --window-trees: the default, named
    calibrate("--window-trees");
    assert_eq!(gradtac::calibrate::read_model(&model_path).unwrap(), model);
    let default = gradtac::calibrate::CalibrateOptions { shrinkage: 0.5, ..opts.clone() };
    assert_ne!(gradtac::calibrate::calibrate_spans(&spans, &default).unwrap().class_variances, model.class_variances);

    // errors name what is wrong
    fs::write(&settings, "drift_lag = [20]\n").unwrap();
    let out =
        gradtac().arg("calibrate").arg("--settings").arg(&settings).arg(&train).arg("--out").arg(&model_path).output();
    let out = out.unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("settings.toml") && err.contains("drift_lag"), "{err}");
    let one = dir.path().join("one");
    simulated_labelled(&one, 0..2);
    let out = gradtac().arg("calibrate").arg("--cross-validate").arg(&one).arg("--out").arg(&model_path).output();
    let out = out.unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("at least two groups"), "{err}");
}

#[test]
fn dos_scene_decides_on_a_sliding_window() {
    let dir = tempfile::tempdir().unwrap();
    let train = dir.path().join("train");
    simulated_labelled(&train, 0..2);
    let opts = gradtac::calibrate::CalibrateOptions::default();
    let (model, _) = gradtac::calibrate::calibrate_dos(&train, &gradtac::stream::Layout::biotac_sp(), &opts).unwrap();
    let model_path = dir.path().join("model.json");
    gradtac::calibrate::write_model(&model, &model_path).unwrap();
    let csv = train.join("n").join("sim0.csv");
    let frames = read_csv_numbers(&csv).len();
    let scene = |extra: &str| {
        format!(
            "[[sensor]]\nname = \"ff\"\nsource = {{ csv = \"{}\", columns = \"ff_e{{1..24}}\", rate_hz = 100.0 }}\n\
             [stages.dos]\nmodel = \"{}\"\n{extra}\n[[output]]\ntap = \"dos\"\npath = \"out/dos.parquet\"\n",
            csv.display(),
            model_path.display()
        )
    };
    let sc = dir.path().join("scene.toml");
    fs::write(&sc, scene("decision_frames = 60\nhop_frames = 20")).unwrap();
    let out = gradtac().arg("explain").arg(&sc).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("a decision every 20 frames over the last 60"), "{text}");
    // the default model's tree part runs in the sliding mode (since stop 34)
    assert!(model.trees.is_some());
    assert!(text.contains("gradient-boosted trees") && text.contains("the trees' windows counted from the contact"));
    let out = gradtac().arg("run").arg("--quiet").arg(&sc).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let file = fs::File::open(dir.path().join("out/dos.parquet")).unwrap();
    let rows: usize =
        ParquetRecordBatchReaderBuilder::try_new(file).unwrap().build().unwrap().map(|b| b.unwrap().num_rows()).sum();
    // decisions at frames 59, 79, …, and one more at the end if frames came after the last
    let hops = (frames - 60) / 20 + 1;
    let want = hops + usize::from((frames - 60) % 20 != 0);
    assert_eq!(rows, want, "{frames} frames");
    // a hop without the window it slides over is a scene error
    fs::write(&sc, scene("hop_frames = 20")).unwrap();
    let out = gradtac().arg("run").arg("--quiet").arg(&sc).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("hop needs decision_frames"), "{err}");
    // early answers: a decision every 20 frames from frame 19 on, and one more at the end if
    // frames came after the last
    fs::write(&sc, scene("decision_frames = 60\nhop_frames = 20\nearly = true")).unwrap();
    let text = String::from_utf8(gradtac().arg("explain").arg(&sc).output().unwrap().stdout).unwrap();
    assert!(text.contains("(early: over all frames until 60)"), "{text}");
    let out = gradtac().arg("run").arg("--quiet").arg(&sc).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let file = fs::File::open(dir.path().join("out/dos.parquet")).unwrap();
    let rows: usize =
        ParquetRecordBatchReaderBuilder::try_new(file).unwrap().build().unwrap().map(|b| b.unwrap().num_rows()).sum();
    assert_eq!(rows, frames / 20 + usize::from(frames % 20 != 0), "{frames} frames");
    fs::write(&sc, scene("early = true")).unwrap();
    let out = gradtac().arg("run").arg("--quiet").arg(&sc).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("early = true needs hop_frames"));
}

#[test]
fn calibrate_also_trains_the_learned_model_and_guards_its_output() {
    use gradtac::stages::dos::DosNet;
    let dir = tempfile::tempdir().unwrap();
    let train = dir.path().join("train");
    simulated_labelled(&train, 0..2);
    let (model, net) = (dir.path().join("model.json"), dir.path().join("net.json"));
    let out = gradtac()
        .arg("calibrate")
        .arg(&train)
        .arg("--out")
        .arg(&model)
        .arg("--learned-out")
        .arg(&net)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("learned model") && text.contains("trained on 8 recordings"), "{text}");
    let learned: DosNet = serde_json::from_str(&fs::read_to_string(&net).unwrap()).unwrap();
    assert_eq!(learned.taxels, 24);
    assert_eq!(learned.classes.len(), 4);
    // the learned model decides a recording streamed through its own extractor
    let layout = gradtac::stream::Layout::biotac_sp();
    let mut x = learned.extractor(&layout).unwrap();
    let csv = fs::read_to_string(train.join("n").join("sim0.csv")).unwrap();
    for line in csv.lines().skip(1) {
        let v: Vec<f64> = line.split(',').map(|s| s.parse().unwrap()).collect();
        x.push(&v).unwrap();
    }
    let d = learned.classify(&x.input()).unwrap();
    assert!((d.posterior.iter().sum::<f64>() - 1.0).abs() < 1e-9);
    // the learned model's file may not replace the other output
    let before = fs::read(&model).unwrap();
    let out = gradtac()
        .arg("calibrate")
        .arg(&train)
        .arg("--out")
        .arg(&model)
        .arg("--learned-out")
        .arg(&model)
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("refusing"), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(fs::read(&model).unwrap(), before, "the refused run wrote nothing");
}
