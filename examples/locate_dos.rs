//! Plausibility of the default contact track on every BioTacSP-DoS dev recording.
//!
//! Runs two scenes through the real scene → plan → run path on each recording (`track`
//! output only): the **bare** scene (no `[stages.*]` table at all) and the **README's** scene
//! (`[stages.normalise] calibrate_frames = 20`). For each it reports, over all recordings:
//! the share of frames with a contact, per class; the per-frame jump of the contact point
//! between consecutive contact frames at 100 Hz (median, 99th percentile, largest; and the
//! largest per-recording 99th percentile); and the share of contact frames in which the raw
//! signal actually rises above noise (the 5-frame mean of some taxel ≥ 6 σ from its mean over
//! the first 20 frames, σ their standard deviation — an independent check computed here, not by the
//! stage).
//!
//! Data: BioTacSP-DoS (Zapata-Impata, Gil and Torres, "Learning Spatio Temporal Tactile
//! Features with a ConvLSTM for the Direction Of Slip Detection", Sensors 19(3):523, 2019),
//! read from `shared/data/biotacsp-dos` beside the repository or the directory given as
//! the first argument; the example exits quietly when it is absent.
//!
//! Run: `cargo run --release --example locate_dos [-- DIR] [--locate "contact_sigmas = 8; window_frames = 9"]`.
//!
//! Floors (CI runs this example, so a regression fails it; `--no-floors` skips them): for each
//! scene, at least [`FLOOR_ABOVE_NOISE`] of the contact frames have a raw signal above noise,
//! and the 99th percentile of the per-frame jump is at most [`FLOOR_P99_JUMP_MM`]. They sit a
//! little beyond what the defaults measured (97.0 % and 0.44 mm).

use arrow_array::{Array, Float64Array};
use gradtac::run::{run_blocking, RunOptions};
use gradtac::{Plan, Scene};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Least share of contact frames whose raw signal rises above noise (measured: 97.0 %).
const FLOOR_ABOVE_NOISE: f64 = 0.95;
/// Largest 99th percentile of the per-frame jump, mm at 100 Hz (measured: 0.44 mm).
const FLOOR_P99_JUMP_MM: f64 = 0.55;

fn recordings(root: &Path) -> Vec<(String, PathBuf)> {
    let mut out = Vec::new();
    let Ok(classes) = std::fs::read_dir(root) else { return out };
    for c in classes.flatten().filter(|c| c.path().is_dir()) {
        let class = c.file_name().to_string_lossy().into_owned();
        for f in std::fs::read_dir(c.path()).into_iter().flatten().flatten() {
            if f.path().extension().is_some_and(|e| e == "csv") {
                out.push((class.clone(), f.path()));
            }
        }
    }
    out.sort();
    out
}

fn track_xy(path: &Path) -> Vec<(f64, f64)> {
    let f = std::fs::File::open(path).expect("track output");
    let r = ParquetRecordBatchReaderBuilder::try_new(f).unwrap().build().unwrap();
    let mut out = Vec::new();
    for b in r {
        let b = b.unwrap();
        let col = |n: &str| b.column_by_name(n).unwrap().as_any().downcast_ref::<Float64Array>().unwrap().clone();
        let (x, y) = (col("x_mm"), col("y_mm"));
        out.extend((0..b.num_rows()).map(|i| (x.value(i), y.value(i))));
    }
    out
}

/// Per frame: does the raw signal rise above noise (independent check, see the docs)?
fn above_noise(csv: &Path) -> Vec<bool> {
    let text = std::fs::read_to_string(csv).unwrap();
    let rows: Vec<Vec<f64>> =
        text.lines().skip(1).map(|l| l.split(',').map(|v| v.trim().parse().unwrap_or(f64::NAN)).collect()).collect();
    let n = rows.first().map_or(0, Vec::len);
    let m = 20.min(rows.len());
    if m < 3 {
        return vec![false; rows.len()];
    }
    let base: Vec<f64> = (0..n).map(|i| rows[..m].iter().map(|r| r[i]).sum::<f64>() / m as f64).collect();
    // σ: the scatter of the first 20 frames about their mean (slow fluctuations included)
    let sig: Vec<f64> = (0..n)
        .map(|i| {
            let v: f64 = rows[..m].iter().map(|r| (r[i] - base[i]).powi(2)).sum::<f64>() / (m - 1) as f64;
            v.sqrt().max(0.5)
        })
        .collect();
    (0..rows.len())
        .map(|k| {
            let lo = k.saturating_sub(4);
            let w = (k - lo + 1) as f64;
            (0..n).any(|i| {
                let mean = rows[lo..=k].iter().map(|r| r[i]).sum::<f64>() / w;
                (mean - base[i]).abs() > 6.0 * sig[i]
            })
        })
        .collect()
}

fn pct(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

fn main() {
    let root = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/biotacsp-dos"));
    // the scenes live in a scratch directory and resolve relative paths against it
    let root = std::fs::canonicalize(&root).unwrap_or(root);
    let recs = recordings(&root);
    if recs.is_empty() {
        eprintln!("skipped: no recordings under {}", root.display());
        return;
    }
    let tmp = std::env::temp_dir().join(format!("gradtac-locate-dos-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    // `--locate "key = value; …"` adds a [stages.locate] table to both scenes (to explore settings)
    let args: Vec<String> = std::env::args().collect();
    let extra = args
        .windows(2)
        .find(|w| w[0] == "--locate")
        .map(|w| format!("[stages.locate]\n{}\n", w[1].replace(';', "\n")))
        .unwrap_or_default();
    let floors = !args.iter().any(|a| a == "--no-floors");
    let mut below = Vec::new();
    for (label, stages) in
        [("bare default scene", ""), ("README's scene", "[stages.normalise]\ncalibrate_frames = 20\n")]
    {
        let stages = format!("{stages}{extra}");
        let (mut frames, mut contact, mut real, mut contact_above) = (0usize, 0usize, 0usize, 0usize);
        let mut jumps = Vec::new();
        let mut worst_p99: (f64, String) = (0.0, String::new());
        let mut by_class: BTreeMap<String, (usize, usize)> = BTreeMap::new();
        let mut secs = 0.0;
        for (class, csv) in &recs {
            let scene_text = format!(
                "[[sensor]]\nname = \"ff\"\nsource = {{ csv = {:?}, columns = \"ff_e{{1..24}}\", rate_hz = 100.0 }}\n\n{stages}\n[[output]]\ntap = \"track\"\npath = \"track.parquet\"\n",
                csv.display().to_string()
            );
            let scene = Scene::from_toml(&scene_text, &tmp, Path::new("scene.toml")).unwrap();
            let plan = Plan::new(&scene).unwrap();
            let rep = run_blocking(&scene, &plan, &RunOptions::default()).unwrap();
            secs += rep.seconds;
            let xy = track_xy(&tmp.join("track.parquet"));
            let above = above_noise(csv);
            let mut rj = Vec::new();
            for (k, &(x, y)) in xy.iter().enumerate() {
                let c = x.is_finite();
                contact += c as usize;
                if c && above.get(k).copied().unwrap_or(false) {
                    contact_above += 1;
                }
                real += above.get(k).copied().unwrap_or(false) as usize;
                if k > 0 && c && xy[k - 1].0.is_finite() {
                    rj.push((x - xy[k - 1].0).hypot(y - xy[k - 1].1));
                }
            }
            let e = by_class.entry(class.clone()).or_default();
            e.0 += xy.iter().filter(|p| p.0.is_finite()).count();
            e.1 += xy.len();
            frames += xy.len();
            let p99 = pct(&mut rj.clone(), 0.99);
            if p99 > worst_p99.0 {
                worst_p99 = (p99, format!("{class}/{}", csv.file_name().unwrap().to_string_lossy()));
            }
            jumps.extend(rj);
        }
        let n = jumps.len();
        let above_share = contact_above as f64 / contact.max(1) as f64;
        let p99_jump = pct(&mut jumps.clone(), 0.99);
        if above_share < FLOOR_ABOVE_NOISE {
            below.push(format!(
                "{label}: {:.1} % of contact frames above noise < {:.0} %",
                100.0 * above_share,
                100.0 * FLOOR_ABOVE_NOISE
            ));
        }
        if !(p99_jump <= FLOOR_P99_JUMP_MM) {
            below.push(format!("{label}: p99 jump {p99_jump:.3} mm > {FLOOR_P99_JUMP_MM} mm"));
        }
        println!("## {label} on {} recordings ({frames} frames, {secs:.1} s wall)", recs.len());
        println!();
        println!(
            "- contact in {:.1} % of frames; of those, {:.1} % have a raw signal above noise (independent check); \
             frames with signal above noise: {:.1} %",
            100.0 * contact as f64 / frames as f64,
            100.0 * contact_above as f64 / contact.max(1) as f64,
            100.0 * real as f64 / frames as f64
        );
        println!(
            "- contact share by class: {}",
            by_class
                .iter()
                .map(|(c, (a, b))| format!("{c} {:.0} %", 100.0 * *a as f64 / *b as f64))
                .collect::<Vec<_>>()
                .join(", ")
        );
        println!(
            "- jump between consecutive contact frames ({n} pairs): median {:.3} mm, p99 {:.3} mm, max {:.3} mm; \
             worst recording's p99 {:.3} mm ({})",
            pct(&mut jumps.clone(), 0.5),
            pct(&mut jumps.clone(), 0.99),
            pct(&mut jumps, 1.0),
            worst_p99.0,
            worst_p99.1
        );
        println!();
    }
    let _ = std::fs::remove_dir_all(&tmp);
    if floors && !below.is_empty() {
        eprintln!("locate_dos: below the floors:\n  {}", below.join("\n  "));
        std::process::exit(1);
    }
}
