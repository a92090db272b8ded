//! `gradtac run … | head -1`: a closed stdout ends the program quietly, outputs finished.

use std::fs;
use std::io::Read;
use std::process::{Command, Stdio};

#[test]
fn a_closed_stdout_ends_quietly_with_outputs_finished() {
    let dir = tempfile::tempdir().unwrap();
    let mut csv: String = (1..=24).map(|i| format!("ff_e{i}")).collect::<Vec<_>>().join(",");
    csv.push('\n');
    for k in 0..300usize {
        let row: Vec<String> = (0..24).map(|j| format!("{}", 2000 + ((k * 37 + j * 101) % 997))).collect();
        csv.push_str(&row.join(","));
        csv.push('\n');
    }
    fs::write(dir.path().join("in.csv"), csv).unwrap();
    let scene = dir.path().join("scene.toml");
    fs::write(
        &scene,
        r#"
[[sensor]]
name = "ff"
layout = "biotac-sp"
source = { csv = "in.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }

[[output]]
tap = "track"
path = "out/track.parquet"

[[output]]
tap = "events"
path = "out/events.parquet"
"#,
    )
    .unwrap();
    // stdout is a pipe whose reader has gone: every write fails with EPIPE
    let mut child = Command::new(env!("CARGO_BIN_EXE_gradtac"))
        .arg("run")
        .arg(&scene)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    let status = child.wait().unwrap();
    assert!(status.success(), "status {status:?}, stderr: {err}");
    assert!(!err.contains("panicked") && !err.contains("Broken pipe"), "stderr: {err}");
    for f in ["out/track.parquet", "out/events.parquet"] {
        let p = dir.path().join(f);
        assert!(p.is_file(), "{f} finished");
        assert!(!dir.path().join(format!("{f}.partial")).exists(), "{f} not left partial");
    }
}
