//! The real Shadow Hand bag (`shared/data/rosbag`) through a scene to Parquet, compared
//! value by value and stamp by stamp with an independent decode written here: a minimal
//! record walker for an uncompressed ROS bag 2.0 and the fixed layout of the old
//! `sr_robot_msgs/BiotacAll` (no `pac`) the bag's definition declares. Skips when the data
//! is absent.

use arrow_array::{Array, FixedSizeListArray, Float64Array, StringArray, UInt64Array};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::collections::HashMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

/// `shared` beside the repository, or the directory `GRADTAC_SHARED` names.
fn bag() -> Option<PathBuf> {
    let shared = std::env::var_os("GRADTAC_SHARED")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared"));
    let p = shared.join("data/rosbag/shadow-rh-tactile-untouched.bag");
    p.is_file().then_some(p)
}

fn u32_at(b: &[u8], i: usize) -> u32 {
    u32::from_le_bytes(b[i..i + 4].try_into().unwrap())
}

/// (header fields, data) of the record at `i`, and the next record's offset.
fn record(b: &[u8], i: usize) -> (HashMap<String, Vec<u8>>, &[u8], usize) {
    let hl = u32_at(b, i) as usize;
    let mut fields = HashMap::new();
    let mut j = i + 4;
    while j < i + 4 + hl {
        let fl = u32_at(b, j) as usize;
        let f = &b[j + 4..j + 4 + fl];
        let eq = f.iter().position(|&c| c == b'=').unwrap();
        fields.insert(String::from_utf8(f[..eq].to_vec()).unwrap(), f[eq + 1..].to_vec());
        j += 4 + fl;
    }
    let dl = u32_at(b, j) as usize;
    (fields, &b[j + 4..j + 4 + dl], j + 4 + dl)
}

/// Per message: stamp (ns) and the five slots' electrodes.
fn independent_decode(path: &Path) -> Vec<(i64, Vec<Vec<i16>>)> {
    let b = fs::read(path).unwrap();
    assert_eq!(&b[..13], b"#ROSBAG V2.0\n");
    let mut out = Vec::new();
    let mut i = 13;
    while i < b.len() {
        let (h, data, next) = record(&b, i);
        i = next;
        if h["op"] != [5] {
            continue;
        }
        assert_eq!(h["compression"], b"none");
        let mut k = 0;
        while k < data.len() {
            let (mh, m, n) = record(data, k);
            k = n;
            if mh["op"] != [2] {
                continue;
            }
            // Header: seq u32, stamp (sec u32, nsec u32), frame_id string
            let (sec, nsec) = (u32_at(m, 4) as i64, u32_at(m, 8) as i64);
            let mut p = 12 + 4 + u32_at(m, 12) as usize;
            let mut slots = Vec::new();
            for _ in 0..5 {
                p += 10; // pac0 pac1 pdc tac tdc
                let n = u32_at(m, p) as usize;
                p += 4;
                slots.push((0..n).map(|e| i16::from_le_bytes([m[p + 2 * e], m[p + 2 * e + 1]])).collect());
                p += 2 * n;
            }
            assert_eq!(p, m.len());
            out.push((sec * 1_000_000_000 + nsec, slots));
        }
    }
    out
}

fn read_frames(path: &Path) -> Vec<(String, i64, u64, Vec<f64>)> {
    let reader = ParquetRecordBatchReaderBuilder::try_new(fs::File::open(path).unwrap()).unwrap().build().unwrap();
    let mut rows = Vec::new();
    for batch in reader {
        let b = batch.unwrap();
        let col = |n: &str| b.column_by_name(n).unwrap().clone();
        let sensor = col("sensor");
        let sensor = sensor.as_any().downcast_ref::<StringArray>().unwrap();
        let time = col("time");
        let time = time.as_any().downcast_ref::<arrow_array::TimestampNanosecondArray>().unwrap();
        let seq = col("seq");
        let seq = seq.as_any().downcast_ref::<UInt64Array>().unwrap();
        let vals = col("values");
        let vals = vals.as_any().downcast_ref::<FixedSizeListArray>().unwrap();
        for i in 0..b.num_rows() {
            let v = vals.value(i);
            let v = v.as_any().downcast_ref::<Float64Array>().unwrap().values().to_vec();
            rows.push((sensor.value(i).to_string(), time.value(i), seq.value(i), v));
        }
    }
    rows
}

#[test]
fn the_shadow_bag_decodes_through_a_scene_to_parquet_exactly() {
    let Some(bag) = bag() else {
        eprintln!("skipped: ../shared/data/rosbag is absent");
        return;
    };
    let want = independent_decode(&bag);
    assert_eq!(want.len(), 977);
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    let src =
        |f: &str| format!("source = {{ rosbag = {:?}, topic = \"/rh/tactile\", finger = \"{f}\" }}", bag.display());
    fs::write(
        &scene,
        format!(
            "[[sensor]]\nname = \"ff\"\n{}\n[[sensor]]\nname = \"mf\"\n{}\n[[sensor]]\nname = \"thumb\"\n{}\n\
             [[output]]\ntap = \"source\"\npath = \"frames.parquet\"\n",
            src("ff"),
            src("mf"),
            src("th")
        ),
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_gradtac")).arg("run").arg(&scene).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let rows = read_frames(&dir.path().join("frames.parquet"));
    assert_eq!(rows.len(), 3 * 977);
    for (name, slot) in [("ff", 0), ("mf", 1), ("thumb", 4)] {
        let mine: Vec<_> = rows.iter().filter(|r| r.0 == name).collect();
        assert_eq!(mine.len(), 977, "{name}");
        for (k, (r, (t, slots))) in mine.iter().zip(&want).enumerate() {
            assert_eq!((r.1, r.2), (*t, k as u64), "{name} message {k}");
            let e: Vec<f64> = slots[slot].iter().map(|&v| f64::from(v)).collect();
            assert_eq!(e.len(), 24);
            assert_eq!(r.3, e, "{name} message {k}");
        }
    }
    // the data is real: the recorded fingertips are not constant
    assert!(want.iter().any(|(_, s)| s[0] != want[0].1[0]));
}

#[test]
fn a_bag_scene_with_a_wrong_topic_names_it() {
    let Some(bag) = bag() else {
        eprintln!("skipped: ../shared/data/rosbag is absent");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    fs::write(
        &scene,
        format!(
            "[[sensor]]\nname = \"ff\"\nsource = {{ rosbag = {:?}, topic = \"/rh/tactile\" }}\n\
             [[output]]\ntap = \"source\"\npath = \"frames.parquet\"\n",
            bag.display()
        ),
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_gradtac")).arg("run").arg(&scene).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("topic /rh/tactile (sr_robot_msgs/BiotacAll)") && err.contains("finger ="), "{err}");
    assert!(!dir.path().join("frames.parquet").exists());
}
