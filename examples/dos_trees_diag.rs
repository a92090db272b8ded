//! Diagnosis of the tree model's slip-direction errors on the **inner views only** (folds inside
//! basic and inside solids, never across sets; stop 35's round 4,
//! `examples/dos_eval_parts/trees_rule_round4.md`).
//!
//! `cargo run --release --example dos_trees_diag -- [DATA_DIR] [--config FILE.json]` prints:
//! - for the tree config (default: `TreeTrainConfig::default()`), each inner fold's held-out
//!   object's recordings right (the causal vote) and the confusions `true → decided`;
//! - whether the representation carries a **rotation sense**: for every recording of the tuning
//!   objects, each rotation-like input's mean over the recording's windows (the motion inputs'
//!   turn of the principal axis, and the rotation-sense inputs' fitted turn `θ` per lag and
//!   slope, [`TreeInputs::turn`]); per object, the share of `cw` / `aw` recordings whose mean has
//!   the class's sign (`cw` +, `aw` −; 50 % = no sense), and the mean `|θ|` of rotations against
//!   translations. No model is involved in this part.

use gradtac::calibrate::{object_set, train_recordings, CalibrateOptions};
use gradtac::stages::dos::train_trees::{fit_on, tree_samples, tree_windows, TreeTrainConfig};
use gradtac::stages::dos::{DosClass, TreeInputs, MOTION_INPUTS, TURN_INPUTS};
use gradtac::stream::Layout;
use std::collections::BTreeMap;
use std::error::Error;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn Error>> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut dir = root.join("../shared/data/biotacsp-dos");
    let mut cfg = TreeTrainConfig::default();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--config" => {
                cfg = serde_json::from_str(&std::fs::read_to_string(args.next().ok_or("--config needs a file")?)?)?
            }
            other => dir = PathBuf::from(other),
        }
    }
    if !dir.is_dir() {
        println!("skipped: data not present ({})", dir.display());
        return Ok(());
    }
    cfg.validate()?;
    let layout = Layout::biotac_sp();
    let recs = gradtac::calibrate::read_recordings(&dir, &CalibrateOptions::default())?;
    let tr = train_recordings(&recs);
    let n = layout.len();

    // 1. the inner views' errors per held-out object
    println!("## Inner views of {}\n", serde_json::to_string(&cfg)?);
    let samples = tree_samples(&tr, &layout, &cfg)?;
    let mut confusion: BTreeMap<(DosClass, DosClass), usize> = BTreeMap::new();
    for set in ["basic", "solids"] {
        let idx: Vec<usize> = (0..recs.len()).filter(|&i| object_set(&recs[i].object) == set).collect();
        let mut objects: Vec<&str> = idx.iter().map(|&i| recs[i].object.as_str()).collect();
        objects.sort();
        objects.dedup();
        for obj in objects {
            let train: Vec<usize> = idx.iter().copied().filter(|&i| recs[i].object != obj).collect();
            let test: Vec<usize> = idx.iter().copied().filter(|&i| recs[i].object == obj).collect();
            let m = fit_on(&samples, &train, &layout, &cfg)?;
            let mut ok = 0;
            let mut errs: BTreeMap<(DosClass, DosClass), usize> = BTreeMap::new();
            for &i in &test {
                let mut v = m.vote(&layout)?;
                for f in &tr[i].frames {
                    v.push(f)?;
                }
                let d = v.decision().ok_or("a recording without a window")?.class;
                if d == tr[i].class {
                    ok += 1;
                } else {
                    *errs.entry((tr[i].class, d)).or_default() += 1;
                    *confusion.entry((tr[i].class, d)).or_default() += 1;
                }
            }
            let e: Vec<String> = errs.iter().map(|((t, d), k)| format!("{}→{} {k}", t.as_str(), d.as_str())).collect();
            println!("inside {set}, {obj} held out: {ok}/{} ({})", test.len(), e.join(", "));
        }
    }
    let e: Vec<String> = confusion.iter().map(|((t, d), k)| format!("{}→{} {k}", t.as_str(), d.as_str())).collect();
    println!("all inner errors (true→decided): {}\n", e.join(", "));

    // 2. rotation sense of the inputs (no model)
    let inputs = TreeInputs { turn: true, ..cfg.inputs.clone() };
    let w = inputs.window.inputs(n);
    let src = inputs.lags.len() + usize::from(inputs.slope_windows > 0);
    let turn_at = inputs.inputs(n) - src * TURN_INPUTS;
    let mut names = vec!["motion: turn of the principal axis".to_string()];
    names.extend(inputs.lags.iter().map(|l| format!("fitted θ over lag {l}")));
    if inputs.slope_windows > 0 {
        names.push(format!("fitted θ of the slope ({} windows)", inputs.slope_windows));
    }
    let mut cols: Vec<usize> = vec![w - MOTION_INPUTS + 2];
    cols.extend((0..src).map(|k| turn_at + k * TURN_INPUTS + 2));
    println!("## Rotation sense of the inputs (per recording: mean over its windows; sign right = cw +, aw −)\n");
    println!("| input | object | cw/aw sign right | mean |·| on cw/aw | mean |·| on n/e/s/w/t |");
    println!("|---|---|---|---|---|");
    let per_rec: Vec<Vec<f64>> = tr
        .iter()
        .map(|r| {
            let x = tree_windows(&r.frames, &inputs, &layout)?;
            let k = x.len().max(1) as f64;
            Ok(cols.iter().map(|&c| x.iter().map(|v| v[c]).sum::<f64>() / k).collect())
        })
        .collect::<Result<_, Box<dyn Error>>>()?;
    let mut objects: Vec<&str> = recs.iter().map(|r| r.object.as_str()).collect();
    objects.sort();
    objects.dedup();
    for (c, name) in names.iter().enumerate() {
        for obj in objects.iter().copied().chain(["all"]) {
            let (mut right, mut rot, mut rot_abs, mut other_abs, mut other) = (0, 0, 0.0, 0.0, 0);
            for (i, r) in tr.iter().enumerate() {
                if obj != "all" && recs[i].object != obj {
                    continue;
                }
                let v = per_rec[i][c];
                match r.class.rotation_sense() {
                    Some(s) => {
                        rot += 1;
                        rot_abs += v.abs();
                        right += usize::from(v * s > 0.0);
                    }
                    None => {
                        other += 1;
                        other_abs += v.abs();
                    }
                }
            }
            println!(
                "| {name} | {obj} | {right}/{rot} | {:.4} | {:.4} |",
                rot_abs / rot.max(1) as f64,
                other_abs / other.max(1) as f64
            );
        }
    }
    Ok(())
}
