//! `gradtac run` on several threads writes the same bytes as on one: the same scene run with
//! `threads = 1` (every chain on the runner's thread) and with 2, 3 and 8 threads, every output
//! file compared byte for byte. Scenes: a simulated two-finger grasp that slips, read by four
//! sensors from one CSV (two chain kinds, the two-finger slip, shared and per-sensor outputs, an
//! archive), the same on the events chain, and two sensors on a candump CAN log.

use gradtac::run::{run_blocking, RunOptions};
use gradtac::stages::sim::{GraspConfig, Recording, Scene as SimScene, SensorModel, Simulator};
use gradtac::stages::slip::SlipClass;
use gradtac::stream::{Layout, Timestamp};
use gradtac::{Plan, Scene};
use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};

fn grasp(seed: u64) -> Recording {
    let layout = Layout::biotac_sp();
    let sim = Simulator::try_new(layout.clone(), SensorModel::default(), seed).unwrap();
    sim.run(&SimScene::grasp(SlipClass::LongitudinalDown, &GraspConfig::default(), &layout)).unwrap()
}

/// Every file under `dir`, by its path relative to `dir`.
fn files(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<PathBuf, Vec<u8>>) {
        for e in fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                out.insert(p.strip_prefix(root).unwrap().to_path_buf(), fs::read(&p).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

/// Run `scene_text` over the files `data` (name, bytes) in a fresh directory with `threads`;
/// returns the outputs (`out/…`) and the frames read.
fn run_in(scene_text: &str, data: &[(&str, &[u8])], threads: usize) -> (BTreeMap<PathBuf, Vec<u8>>, u64) {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in data {
        fs::write(dir.path().join(name), bytes).unwrap();
    }
    let sc = dir.path().join("scene.toml");
    fs::write(&sc, scene_text).unwrap();
    let scene = Scene::load(&sc).unwrap();
    let plan = Plan::new(&scene).unwrap();
    let report = run_blocking(&scene, &plan, &RunOptions { threads, ..Default::default() }).unwrap();
    let frames = report.frames.iter().map(|(_, n)| n).sum();
    (files(&dir.path().join("out")), frames)
}

/// The scene on 1 thread and on 2, 3 and 8: the same files, byte for byte.
fn same_bytes_on_any_threads(scene_text: &str, data: &[(&str, &[u8])], want_files: usize) {
    let (one, frames) = run_in(scene_text, data, 1);
    assert_eq!(one.len(), want_files, "{:?}", one.keys().collect::<Vec<_>>());
    assert!(frames > 0);
    for threads in [2, 3, 8] {
        let (many, n) = run_in(scene_text, data, threads);
        assert_eq!(n, frames);
        assert_eq!(many.keys().collect::<Vec<_>>(), one.keys().collect::<Vec<_>>(), "{threads} threads");
        for (path, bytes) in &one {
            assert!(many[path] == *bytes, "{} differs on {threads} threads", path.display());
        }
    }
}

fn grasp_csv() -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let (csv, truth) = (dir.path().join("g.csv"), dir.path().join("t.csv"));
    grasp(5).write_csv(&csv, &truth).unwrap();
    fs::read(csv).unwrap()
}

const SENSORS: &str = r#"
[[sensor]]
name = "ff"
source = { csv = "grasp.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }
[[sensor]]
name = "th"
source = { csv = "grasp.csv", columns = "th_e{1..24}", rate_hz = 100.0 }
[[sensor]]
name = "ff2"
source = { csv = "grasp.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }
[[sensor]]
name = "th2"
source = { csv = "grasp.csv", columns = "th_e{1..24}", rate_hz = 100.0 }
"#;

const OUTPUTS: &str = r#"
[[output]]
tap = "source"
path = "out/source.parquet"
[[output]]
tap = "normalise"
path = "out/normalise.parquet"
sensors = ["ff", "th2"]
[[output]]
tap = "contour"
path = "out/contour.parquet"
[[output]]
tap = "track"
path = "out/track.parquet"
row_group_size = 64
[[output]]
tap = "track"
path = "out/track-th.parquet"
sensors = ["th"]
[[output]]
tap = "servo"
path = "out/servo.parquet"
sensors = ["ff2", "th"]
[[output]]
tap = "slip"
path = "out/slip.parquet"
[[output]]
tap = "contour"
path = "out/arch"
archive = { partition = "sensor", roll_rows = 200 }
"#;

#[test]
fn a_four_sensor_csv_scene_writes_the_same_bytes_on_any_number_of_threads() {
    let csv = grasp_csv();
    let scene = format!("{SENSORS}\n[stages.slip]\nfirst = \"ff\"\nsecond = \"th\"\n{OUTPUTS}");
    // 7 files + the archive's 4 sensors × ceil(frames / 200) files
    let (one, frames) = run_in(&scene, &[("grasp.csv", &csv)], 1);
    let per_sensor = (frames / 4).div_ceil(200) as usize;
    assert!(one.keys().any(|k| k.ends_with("slip.parquet")));
    same_bytes_on_any_threads(&scene, &[("grasp.csv", &csv)], 7 + 4 * per_sensor);
}

#[test]
fn the_events_chain_writes_the_same_bytes_on_any_number_of_threads() {
    let csv = grasp_csv();
    let scene = format!(
        "{SENSORS}\n[stages.slip]\nfirst = \"ff\"\nsecond = \"th\"\nevidence = \"both\"\n\
         [stages.locate]\nmethod = \"events\"\n[stages.surface]\ngrid = {{ nx = 16 }}\n{OUTPUTS}\n\
         [[output]]\ntap = \"events\"\npath = \"out/events.parquet\"\n\
         [[output]]\ntap = \"surface\"\npath = \"out/surface.parquet\"\nsensors = [\"th\"]\n"
    );
    let (one, frames) = run_in(&scene, &[("grasp.csv", &csv)], 1);
    let per_sensor = (frames / 4).div_ceil(200) as usize;
    assert_eq!(one.len(), 9 + 4 * per_sensor);
    same_bytes_on_any_threads(&scene, &[("grasp.csv", &csv)], 9 + 4 * per_sensor);
}

#[test]
fn a_can_bus_scene_writes_the_same_bytes_on_any_number_of_threads() {
    use gradtac::io::can::{write_candump, CanCodec, CodecConfig, PresetConfig, PresetKind};
    let rec = grasp(9);
    let codec =
        CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &["ff", "th"]))).unwrap();
    let mut frames = Vec::new();
    let mut set = Vec::new();
    for f in &rec.frames {
        let finger = usize::from(f.frame.sensor.as_str() == "th");
        let t = 1_700_000_000_000_000_000 + f.frame.time.0 + finger as i64 * 1_000_000;
        set.clear();
        codec.encode(finger, &f.frame.values, Timestamp(t), &mut set).unwrap();
        frames.extend(set.iter().enumerate().map(|(mux, c)| c.with_time(Timestamp(t + mux as i64 * 100_000))));
    }
    let mut log = Vec::new();
    write_candump(frames, "can0", &mut log).unwrap();
    let scene = r#"
[[bus]]
name = "hand"
candump = "hand.log"
codec = { preset = { kind = "biotac-mux", sensors = ["ff", "th"] } }

[[sensor]]
name = "ff"
source = { bus = "hand" }
[[sensor]]
name = "th"
source = { bus = "hand" }

[stages.slip]
first = "ff"
second = "th"

[[output]]
tap = "source"
path = "out/raw.parquet"
[[output]]
tap = "track"
path = "out/track.parquet"
[[output]]
tap = "slip"
path = "out/slip.parquet"
"#;
    same_bytes_on_any_threads(scene, &[("hand.log", &log)], 3);
}

#[test]
fn a_bad_cell_fails_the_run_on_any_number_of_threads() {
    // the second sensor's column holds a cell that is not a number: the run fails naming the
    // file and line, and no final output appears, on 1 thread as on 4
    let mut csv = String::from("a1,a2,a3,b1,b2,b3\n");
    for k in 0..300 {
        let bad = if k == 200 { "x".to_string() } else { (k + 7).to_string() };
        csv.push_str(&format!("{k},{},{},{},{},{bad}\n", k + 1, k + 2, k + 3, k + 4));
    }
    let layout = "name,x_mm,y_mm\nt1,0,0\nt2,1,0\nt3,0,1\n";
    let scene = r#"
[[sensor]]
name = "a"
layout = "tri.csv"
source = { csv = "d.csv", columns = "a{1..3}", rate_hz = 100.0 }
[[sensor]]
name = "b"
layout = "tri.csv"
source = { csv = "d.csv", columns = "b{1..3}", rate_hz = 100.0 }
[[output]]
tap = "normalise"
path = "out/n.parquet"
"#;
    for threads in [1, 4] {
        let dir = tempfile::tempdir().unwrap();
        fs::write(dir.path().join("d.csv"), &csv).unwrap();
        fs::write(dir.path().join("tri.csv"), layout).unwrap();
        fs::write(dir.path().join("scene.toml"), scene).unwrap();
        let scene = Scene::load(&dir.path().join("scene.toml")).unwrap();
        let plan = Plan::new(&scene).unwrap();
        let err = run_blocking(&scene, &plan, &RunOptions { threads, ..Default::default() }).unwrap_err().to_string();
        assert!(err.contains("d.csv") && err.contains("202"), "{threads} threads: {err}");
        assert!(!dir.path().join("out/n.parquet").exists(), "{threads} threads");
        assert!(dir.path().join("out/n.parquet.partial").exists(), "{threads} threads");
    }
}
