//! Issue #16: when no output taps the surface, the chain runs surface and contour fused
//! (`gradtac_stages::peak::SurfaceContour`, no surface array per window). Its contours and
//! track points must be those of the two stages run separately — which is what runs when the
//! surface is tapped — value for value in the written files.

use arrow_array::{Array, RecordBatch};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::fs;
use std::path::Path;
use std::process::Command;

/// Every record batch of a parquet file (its data; the file's metadata holds the scene text,
/// which differs between the two runs).
fn batches(path: &Path) -> Vec<RecordBatch> {
    let reader = ParquetRecordBatchReaderBuilder::try_new(fs::File::open(path).unwrap()).unwrap().build().unwrap();
    reader.map(Result::unwrap).collect()
}

fn rows(b: &[RecordBatch]) -> usize {
    b.iter().map(RecordBatch::num_rows).sum()
}

/// A 24-taxel recording: a press moving over the pad on a noisy baseline, so the event
/// contours find contacts that move.
fn recording(path: &Path, rows: usize) {
    let mut s: String = (1..=24).map(|i| format!("ff_e{i}")).collect::<Vec<_>>().join(",");
    s.push('\n');
    for k in 0..rows {
        let centre = (k / 15) % 24;
        let row: Vec<String> = (0..24)
            .map(|j| {
                let d = (j as i64 - centre as i64).abs();
                let press = if d <= 2 { (3 - d) * 40 * ((k % 15) as i64 + 1) } else { 0 };
                format!("{}", 2000 + ((k * 37 + j * 101) % 7) as i64 + press)
            })
            .collect();
        s.push_str(&row.join(","));
        s.push('\n');
    }
    fs::write(path, s).unwrap();
}

fn run(dir: &Path, surface_tapped: bool) -> (Vec<RecordBatch>, Vec<RecordBatch>) {
    let surface = if surface_tapped { "[[output]]\ntap = \"surface\"\npath = \"out/surface.parquet\"\n" } else { "" };
    let text = format!(
        r#"
[[sensor]]
name = "ff"
layout = "biotac-sp"
source = {{ csv = "{}", columns = "ff_e{{1..24}}", rate_hz = 100.0 }}

[stages.locate]
method = "events"

[stages.normalise]
calibrate_frames = 20

[[output]]
tap = "contour"
path = "out/contour.parquet"

[[output]]
tap = "track"
path = "out/track.parquet"
{surface}
"#,
        dir.join("rec.csv").display()
    );
    let sc = dir.join("scene.toml");
    fs::write(&sc, text).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_gradtac")).arg("run").arg("--quiet").arg(&sc).output().unwrap();
    assert!(out.status.success(), "stderr: {}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(dir.join("out/surface.parquet").is_file(), surface_tapped);
    (batches(&dir.join("out/contour.parquet")), batches(&dir.join("out/track.parquet")))
}

#[test]
fn fused_surface_and_contour_write_the_same_files_as_the_two_stages() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    recording(&a.path().join("rec.csv"), 400);
    recording(&b.path().join("rec.csv"), 400);
    let fused = run(a.path(), false);
    let separate = run(b.path(), true);
    // the test means something only if contacts were found and tracked
    assert!(rows(&fused.0) > 300, "{} contour rows", rows(&fused.0));
    assert!(rows(&fused.1) > 10, "{} track rows", rows(&fused.1));
    let area = fused.0[0].column_by_name("area_mm2").expect("an area column");
    assert!(area.len() - area.null_count() > 100, "{} contacts", area.len() - area.null_count());
    assert_eq!(fused.0, separate.0, "contour files differ");
    assert_eq!(fused.1, separate.1, "track files differ");
}
