//! `gradtac::memory`: a scene run into Arrow batches holds exactly what `gradtac run`'s Parquet
//! files hold (values, schema, key-value metadata), and writes nothing.

use arrow_array::RecordBatch;
use gradtac::memory::MemoryOutputs;
use gradtac::run::{run_blocking, RunOptions};
use gradtac::{Plan, Scene};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::fs;
use std::path::Path;

/// Two fingertips, a quiet start then a press moving across the taxels.
fn write_recording(path: &Path, frames: usize) {
    let mut s = String::new();
    let names: Vec<String> = ["ff", "th"].iter().flat_map(|f| (1..=24).map(move |i| format!("{f}_e{i}"))).collect();
    s.push_str(&names.join(","));
    s.push('\n');
    for t in 0..frames {
        let row: Vec<String> = (0..48)
            .map(|j| {
                let (finger, taxel) = (j / 24, (j % 24) as f64);
                let noise = ((t * 7919 + j * 104_729) % 13) as f64 - 6.0;
                let phase = (t as f64 - frames as f64 / 4.0) / (frames as f64 / 2.0);
                let press = if (0.0..1.0).contains(&phase) {
                    let centre = 4.0 + 12.0 * phase + 2.0 * finger as f64;
                    250.0 * (std::f64::consts::PI * phase).sin() * (-0.5 * ((taxel - centre) / 2.5).powi(2)).exp()
                } else {
                    0.0
                };
                format!("{}", (2800.0 + 10.0 * taxel + noise + press).round())
            })
            .collect();
        s.push_str(&row.join(","));
        s.push('\n');
    }
    fs::write(path, s).unwrap();
}

const SCENE: &str = r#"
[[sensor]]
name = "ff"
source = { csv = "rec.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }

[[sensor]]
name = "th"
source = { csv = "rec.csv", columns = "th_e{1..24}", rate_hz = 100.0 }

[[output]]
tap = "track"
path = "out/tracks.parquet"

[[output]]
tap = "savgol"
path = "out/smoothed.parquet"
sensors = ["th"]

[[output]]
tap = "contour"
path = "out/contours.parquet"
"#;

fn read_parquet(files: &[std::path::PathBuf]) -> (Vec<RecordBatch>, Vec<(String, String)>) {
    let mut batches = Vec::new();
    let mut kv = Vec::new();
    for f in files {
        let b = ParquetRecordBatchReaderBuilder::try_new(fs::File::open(f).unwrap()).unwrap();
        kv = b
            .metadata()
            .file_metadata()
            .key_value_metadata()
            .unwrap()
            .iter()
            .filter(|k| k.key != "ARROW:schema")
            .map(|k| (k.key.clone(), k.value.clone().unwrap_or_default()))
            .collect();
        batches.extend(b.build().unwrap().map(Result::unwrap));
    }
    (batches, kv)
}

fn concat(batches: &[RecordBatch]) -> RecordBatch {
    let schema = batches[0].schema();
    let plain = std::sync::Arc::new(schema.as_ref().clone().with_metadata(std::collections::HashMap::new()));
    let b = arrow_select::concat::concat_batches(&schema, batches).unwrap();
    RecordBatch::try_new(plain, b.columns().to_vec()).unwrap()
}

#[test]
fn memory_batches_equal_the_files_of_a_run_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    write_recording(&dir.path().join("rec.csv"), 400);
    fs::write(dir.path().join("scene.toml"), SCENE).unwrap();
    let scene = Scene::load(&dir.path().join("scene.toml")).unwrap();
    let plan = Plan::new(&scene).unwrap();

    let (out, rx) = MemoryOutputs::channel(2);
    let reader = std::thread::spawn(move || rx.iter().collect::<Vec<_>>());
    let report = gradtac::memory::run(&scene, &plan, &out).unwrap();
    let schemas: Vec<_> = (0..3).map(|i| out.schema(i).unwrap()).collect();
    drop(out);
    let got = reader.join().unwrap();
    assert!(report.outputs.iter().all(|(files, _)| files.is_empty()));
    assert!(!dir.path().join("out").exists(), "an in-memory run writes nothing");

    let files = run_blocking(&scene, &plan, &RunOptions { threads: 2, ..Default::default() }).unwrap();
    for (i, (paths, rows)) in files.outputs.iter().enumerate() {
        let mine: Vec<RecordBatch> = got.iter().filter(|(o, _)| *o == i).map(|(_, b)| b.clone()).collect();
        assert!(mine.iter().all(|b| b.schema() == schemas[i]));
        assert_eq!(mine.iter().map(|b| b.num_rows() as u64).sum::<u64>(), *rows);
        let mut paths = paths.clone();
        paths.sort();
        let (from_files, kv) = read_parquet(&paths);
        assert_eq!(concat(&mine), concat(&from_files), "output #{}", i + 1);
        for (k, v) in kv {
            assert_eq!(schemas[i].metadata().get(&k), Some(&v), "output #{} key {k}", i + 1);
        }
    }
}
