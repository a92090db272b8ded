//! `gradtac batch` and `gradtac::batch`: one scene per recording into one hive-partitioned
//! archive; per-recording failures that do not stop the others; refusals up front.

use arrow_array::{Array, RecordBatch};
use gradtac::batch::{batch_layout_dir, run_recording, FIRST_FILE};
use gradtac::stages::sim::{GraspConfig, Scene as SimScene, SensorModel, Simulator};
use gradtac::stages::slip::SlipClass;
use gradtac::stream::Layout;
use gradtac::Scene;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

fn gradtac() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gradtac"))
}

/// A simulated two-finger grasp (`ff_e*`, `th_e*` columns) at `path`.
fn grasp_csv(path: &Path, seed: u64) {
    let layout = Layout::biotac_sp();
    let sim = Simulator::try_new(layout.clone(), SensorModel::default(), seed).unwrap();
    let rec = sim.run(&SimScene::grasp(SlipClass::LongitudinalDown, &GraspConfig::default(), &layout)).unwrap();
    rec.write_csv(path, &path.with_extension("truth")).unwrap();
}

const SCENE: &str = r#"
[[sensor]]
name = "ff"
source = { csv = "recording.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }
[[sensor]]
name = "th"
source = { csv = "recording.csv", columns = "th_e{1..24}", rate_hz = 100.0 }
[stages.slip]
first = "ff"
second = "th"
[[output]]
tap = "track"
path = "out/tracks.parquet"
[[output]]
tap = "normalise"
path = "out/frames.parquet"
sensors = ["th"]
[[output]]
tap = "slip"
path = "out/slip.parquet"
"#;

/// A directory with the scene and `n` recordings `rec<k>.csv` (seeds differ).
fn setup(n: u64) -> (tempfile::TempDir, PathBuf, Vec<PathBuf>) {
    let dir = tempfile::tempdir().unwrap();
    let sc = dir.path().join("scene.toml");
    fs::write(&sc, SCENE).unwrap();
    fs::create_dir(dir.path().join("data")).unwrap();
    let recs: Vec<PathBuf> = (0..n)
        .map(|k| {
            let p = dir.path().join(format!("data/rec{k}.csv"));
            grasp_csv(&p, 11 + k);
            p
        })
        .collect();
    (dir, sc, recs)
}

fn read(path: &Path) -> RecordBatch {
    let file = fs::File::open(path).unwrap();
    let reader = ParquetRecordBatchReaderBuilder::try_new(file).unwrap().build().unwrap();
    let batches: Vec<RecordBatch> = reader.map(Result::unwrap).collect();
    arrow_select::concat::concat_batches(&batches[0].schema(), &batches).unwrap()
}

/// The rows of `b` whose `sensor` is `name`, without the `sensor` column.
fn of_sensor(b: &RecordBatch, name: &str) -> RecordBatch {
    use arrow_array::StringArray;
    let s = b.column_by_name("sensor").unwrap().as_any().downcast_ref::<StringArray>().unwrap();
    let mask: arrow_array::BooleanArray = s.iter().map(|v| Some(v == Some(name))).collect();
    let kept = arrow_select::filter::filter_record_batch(b, &mask).unwrap();
    let i = kept.schema().index_of("sensor").unwrap();
    let mut kept = kept;
    kept.remove_column(i);
    kept
}

fn columns_equal(a: &RecordBatch, b: &RecordBatch) {
    let names = |x: &RecordBatch| x.schema().fields().iter().map(|f| f.name().clone()).collect::<Vec<_>>();
    assert_eq!(names(a), names(b));
    assert_eq!(a.num_rows(), b.num_rows());
    for (x, y) in a.columns().iter().zip(b.columns()) {
        assert_eq!(x.to_data(), y.to_data());
    }
}

#[test]
fn batch_writes_one_hive_archive_equal_to_separate_runs_and_reports_failures() {
    let (dir, sc, recs) = setup(3);
    // a recording with a bad cell, and one that does not exist
    let bad = dir.path().join("data/broken.csv");
    let text = fs::read_to_string(&recs[0]).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    lines[50] = lines[50].replacen(',', ",x", 1);
    fs::write(&bad, lines.join("\n")).unwrap();
    let missing = dir.path().join("data/missing.csv");
    let arch = dir.path().join("arch");
    let out = gradtac()
        .arg("batch")
        .arg(&sc)
        .args(&recs)
        .arg(&bad)
        .arg(&missing)
        .arg("--out")
        .arg(&arch)
        .args(["--jobs", "2"])
        .output()
        .unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert_eq!(out.status.code(), Some(1), "a failed recording fails the batch: {stdout} {stderr}");
    assert!(stdout.contains("batch: 3 recordings ran, 2 failed"), "{stdout}");
    let failed: Vec<&str> = stderr.lines().filter(|l| l.starts_with("gradtac: failed: ")).collect();
    assert_eq!(failed.len(), 2, "{stderr}");
    assert!(failed.iter().any(|l| l.contains("broken.csv") && l.contains(":51")), "{stderr}");
    assert!(failed.iter().any(|l| l.contains("missing.csv")), "{stderr}");
    // every good recording: the archive's files hold what a plain run of the recording writes,
    // split by sensor, without the sensor column
    for rec in &recs {
        let stem = rec.file_stem().unwrap().to_str().unwrap();
        let one = tempfile::tempdir().unwrap();
        fs::copy(rec, one.path().join("recording.csv")).unwrap();
        fs::write(one.path().join("scene.toml"), SCENE).unwrap();
        let st = gradtac().arg("run").arg("-q").arg("--threads=1").arg(one.path().join("scene.toml")).status().unwrap();
        assert!(st.success());
        let tracks = read(&one.path().join("out/tracks.parquet"));
        for sensor in ["ff", "th"] {
            let f = batch_layout_dir(&arch, "tracks", stem, sensor).join(FIRST_FILE);
            let b = read(&f);
            assert!(b.column_by_name("sensor").is_none() && b.column_by_name("recording").is_none());
            columns_equal(&b, &of_sensor(&tracks, sensor));
        }
        let frames = read(&one.path().join("out/frames.parquet"));
        columns_equal(
            &read(&batch_layout_dir(&arch, "frames", stem, "th").join(FIRST_FILE)),
            &of_sensor(&frames, "th"),
        );
        assert!(!batch_layout_dir(&arch, "frames", stem, "ff").exists(), "the output covers th only");
        // slip: one file per recording, no sensor level
        let slip = arch.join("slip").join(format!("recording={stem}")).join(FIRST_FILE);
        columns_equal(&read(&slip), &read(&one.path().join("out/slip.parquet")));
    }
    // the failed recording left its files under temporary names only
    let broken = arch.join("tracks/recording=broken");
    let finals: Vec<PathBuf> = walk(&arch).into_iter().filter(|p| p.starts_with(&broken)).collect();
    assert!(finals.iter().all(|p| p.to_string_lossy().ends_with(".partial")), "{finals:?}");
    assert!(!walk(&arch).iter().any(|p| p.to_string_lossy().contains("missing")));

    // run again into the same archive: every recording is refused, nothing replaced
    let before: Vec<(PathBuf, Vec<u8>)> = walk(&arch).into_iter().map(|p| (p.clone(), fs::read(&p).unwrap())).collect();
    let out = gradtac().arg("batch").arg(&sc).arg(&recs[0]).arg("-o").arg(&arch).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("already holds this recording's outputs"), "{stderr}");
    let after: Vec<(PathBuf, Vec<u8>)> = walk(&arch).into_iter().map(|p| (p.clone(), fs::read(&p).unwrap())).collect();
    assert_eq!(before, after);
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(rd) = fs::read_dir(dir) else { return out };
    for e in rd {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out.sort();
    out
}

#[test]
fn recordings_are_globs_and_the_api_returns_the_final_files() {
    let (dir, sc, recs) = setup(2);
    let arch = dir.path().join("arch");
    let pattern = dir.path().join("data/rec*.csv");
    let out = gradtac().arg("batch").arg(&sc).arg(&pattern).arg("--out").arg(&arch).arg("-q").output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.stdout.is_empty(), "quiet");
    for rec in &recs {
        let stem = rec.file_stem().unwrap().to_str().unwrap();
        assert!(batch_layout_dir(&arch, "tracks", stem, "ff").join(FIRST_FILE).is_file());
    }
    // a pattern that matches nothing is an error
    let out =
        gradtac().arg("batch").arg(&sc).arg(dir.path().join("data/none*.csv")).arg("-o").arg(&arch).output().unwrap();
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("matches no file"));

    // the API: one recording, its final files
    let scene = Scene::load(&sc).unwrap();
    let arch2 = dir.path().join("arch2");
    let s = run_recording(&scene, &recs[1], &arch2).unwrap();
    assert_eq!(s.recording, recs[1]);
    assert!(s.frames > 0);
    let mut files = s.files.clone();
    files.sort();
    assert_eq!(files, walk(&arch2));
    assert_eq!(files.len(), 4, "tracks ff + th, frames th, slip: {files:?}");
    assert_eq!(
        batch_layout_dir(Path::new("o"), "t r", "a/b", "ff"),
        Path::new("o/t r/recording=a%2Fb/sensor=ff"),
        "partition values percent-encoded"
    );
}

#[test]
fn batch_refuses_what_it_cannot_run_before_anything_runs() {
    let (dir, sc, recs) = setup(1);
    let arch = dir.path().join("arch");
    // two recordings with one stem
    fs::create_dir(dir.path().join("other")).unwrap();
    let twin = dir.path().join("other/rec0.csv");
    fs::copy(&recs[0], &twin).unwrap();
    let out = gradtac().arg("batch").arg(&sc).arg(&recs[0]).arg(&twin).arg("-o").arg(&arch).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("data/rec0.csv") && err.contains("other/rec0.csv") && err.contains("same stem"), "{err}");
    assert!(!arch.exists(), "nothing written");

    // sensors reading two files
    let two = dir.path().join("two.toml");
    fs::write(&two, SCENE.replacen("recording.csv", "other.csv", 1)).unwrap();
    let out = gradtac().arg("batch").arg(&two).arg(&recs[0]).arg("-o").arg(&arch).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("sensor \"ff\" source.csv") && err.contains("sensor \"th\" source.csv"), "{err}");
    assert!(!arch.exists(), "nothing written");

    // two outputs that would be one table
    let dup = dir.path().join("dup.toml");
    fs::write(&dup, format!("{SCENE}\n[[output]]\ntap = \"contour\"\npath = \"elsewhere/tracks.parquet\"\n")).unwrap();
    let out = gradtac().arg("batch").arg(&dup).arg(&recs[0]).arg("-o").arg(&arch).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("batch table \"tracks\""), "{err}");
    assert!(!arch.exists(), "nothing written");

    // a layout inside the archive-to-be: refused (the recording's directory exists), nothing read
    let layout_dir = dir.path().join("arch4/tracks/recording=rec0");
    fs::create_dir_all(&layout_dir).unwrap();
    let out = gradtac().arg("batch").arg(&sc).arg(&recs[0]).arg("-o").arg(dir.path().join("arch4")).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("already holds"), "{err}");
    assert_eq!(fs::read_dir(&layout_dir).unwrap().count(), 0);
}

#[cfg(unix)]
#[test]
fn ctrl_c_starts_no_more_recordings_and_leaves_only_whole_ones() {
    let (dir, sc, recs) = setup(1);
    // 200 copies of one recording
    let mut all = Vec::new();
    for k in 0..200 {
        let p = dir.path().join(format!("data/copy{k}.csv"));
        fs::copy(&recs[0], &p).unwrap();
        all.push(p);
    }
    let arch = dir.path().join("arch");
    let child = gradtac()
        .arg("batch")
        .arg(&sc)
        .args(&all)
        .args(["--jobs", "2", "-o"])
        .arg(&arch)
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    // wait for a first final file (not only the first jobs' `.partial` files: under load, 2 jobs × 4
    // outputs can be 8 partials before any recording finishes, and then nothing would be whole)
    let any_final = |arch: &Path| walk(arch).iter().any(|p| !p.to_string_lossy().ends_with(".partial"));
    while !any_final(&arch) && t0.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    assert!(Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap().success());
    let out = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    if out.status.success() {
        eprintln!("the batch finished before the signal arrived: {stdout}");
        return;
    }
    assert_eq!(out.status.code(), Some(130), "{stdout}");
    assert!(stdout.contains("not started (interrupted)"), "{stdout}");
    // every recording with a final file has all four, each a valid Parquet file
    let finals: Vec<PathBuf> = walk(&arch).into_iter().filter(|p| !p.to_string_lossy().ends_with(".partial")).collect();
    let mut stems: Vec<String> = finals
        .iter()
        .filter_map(|p| {
            p.components().find_map(|c| c.as_os_str().to_str()?.strip_prefix("recording=").map(str::to_string))
        })
        .collect();
    stems.sort();
    stems.dedup();
    assert!(!stems.is_empty() && stems.len() < 200, "{}", stems.len());
    for stem in &stems {
        for f in [
            batch_layout_dir(&arch, "tracks", stem, "ff").join(FIRST_FILE),
            batch_layout_dir(&arch, "tracks", stem, "th").join(FIRST_FILE),
            batch_layout_dir(&arch, "frames", stem, "th").join(FIRST_FILE),
            arch.join("slip").join(format!("recording={stem}")).join(FIRST_FILE),
        ] {
            assert!(read(&f).num_rows() > 0 || f.to_string_lossy().contains("slip"), "{}", f.display());
        }
    }
}
