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
//! - the inner views' touch recordings: the share of windows decided `t` per third of each
//!   recording and the vote's margin (stop 35's round 5: is a touch read as a slip only after
//!   contact, while the object settles, or throughout?);
//! - the change-energy inputs ([`TreeInputs::energy`]) per object, touches against slips (no
//!   model);
//! - stop 36's round 6 (no model): the dilation ([`TreeInputs::dilation`]) per object, touches
//!   against slips, and the rotation sense of the turn fitted beside the dilation. (Round 6's
//!   printout also had the flow share of candidate T14, removed in stop 37; commit `e43beac` still
//!   prints it, `trees_round6_diagnosis.txt` keeps it.)

use gradtac::calibrate::{object_set, train_recordings, CalibrateOptions};
use gradtac::stages::dos::train::TrainRecording;
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
    let mut touch_rows: Vec<String> = Vec::new();
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
                let mut per_window = Vec::new();
                for f in &tr[i].frames {
                    if let Some(w) = v.push(f)? {
                        per_window.push(w.class);
                    }
                }
                let d = v.decision().ok_or("a recording without a window")?.class;
                if tr[i].class == DosClass::T {
                    touch_rows.push(touch_row(
                        set,
                        obj,
                        d,
                        &per_window,
                        &v.mean_log_posterior().unwrap_or_default(),
                        m.classes(),
                    ));
                }
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
    println!("## Touch recordings of the inner views: share of windows decided `t` per third of the recording (causal per-window decisions), and the vote's mean log posterior margin (t minus the decided class)\n");
    println!("| fold | decided | windows | t in 1st third | 2nd third | 3rd third | margin t − decided |");
    println!("|---|---|---|---|---|---|---|");
    for r in &touch_rows {
        println!("{r}");
    }
    println!();

    // 2. rotation sense of the inputs (no model)
    let inputs = TreeInputs { turn: true, ..cfg.inputs.clone() };
    let w = inputs.window.inputs(n);
    let src = inputs.sources();
    // not `inputs(n) − src × TURN_INPUTS`: the turn blocks are last only without the
    // change-energy and dilation inputs
    let turn_at = inputs.turn_at(n).ok_or("the turn inputs are on")?;
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
    let per_rec = column_means(&tr, &inputs, &layout, &cols)?;
    let mut objects: Vec<&str> = recs.iter().map(|r| r.object.as_str()).collect();
    objects.sort();
    objects.dedup();
    for (c, name) in names.iter().enumerate() {
        for obj in objects.iter().copied().chain(["all"]) {
            let cells = rotation_sense_cells(&tr, &per_rec, c, |i| obj == "all" || recs[i].object == obj);
            println!("| {name} | {obj} | {cells} |");
        }
    }

    // 3. how much the whole pattern changes (the change-energy inputs, no model)
    let inputs = TreeInputs { energy: true, ..cfg.inputs.clone() };
    let k = inputs.energy_inputs();
    // not `inputs(n) − k`: the dilation inputs follow the change-energy inputs
    let at = inputs.energy_at(n).ok_or("the energy inputs are on")?;
    let mut names: Vec<String> = inputs.lags.iter().map(|l| format!("lag {l}")).collect();
    if inputs.slope_windows > 0 {
        names.push(format!("slope ({} windows)", inputs.slope_windows));
    }
    names.push("since start".into());
    println!(
        "\n## Change energy (RMS over taxels) per recording, mean over its windows: touches against slips (no model)\n"
    );
    println!("| object | source | mean on t | mean on slips | min on slips | t below every slip of the object |");
    println!("|---|---|---|---|---|---|");
    let per_rec = column_means(&tr, &inputs, &layout, &(at..at + k).collect::<Vec<_>>())?;
    for obj in objects.iter().copied() {
        for (c, name) in names.iter().enumerate() {
            let of = |touch: bool| -> Vec<f64> {
                (0..tr.len())
                    .filter(|&i| recs[i].object == obj && (tr[i].class == DosClass::T) == touch)
                    .map(|i| per_rec[i][c])
                    .collect()
            };
            let (t, s) = (of(true), of(false));
            let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
            let min = s.iter().copied().fold(f64::INFINITY, f64::min);
            let below = t.iter().filter(|&&v| v < min).count();
            println!("| {obj} | {name} | {:.3} | {:.3} | {:.3} | {below}/{} |", mean(&t), mean(&s), min, t.len());
        }
    }

    // 4. stiffness-free touch inputs (stop 36's round 6, no model): the dilation per source
    //    ([`TreeInputs::dilation`]), with the rotation sense of the turn fitted beside it
    let inputs = TreeInputs { turn: true, dilation: true, ..cfg.inputs.clone() };
    let d = inputs.dilation_inputs();
    // the dilation inputs are the last block
    let at = inputs.inputs(n) - d;
    let turn_at = inputs.turn_at(n).ok_or("the turn inputs are on")?;
    let mut srcs: Vec<String> = inputs.lags.iter().map(|l| format!("lag {l}")).collect();
    if inputs.slope_windows > 0 {
        srcs.push(format!("slope ({} windows)", inputs.slope_windows));
    }
    let mut names: Vec<String> = srcs.iter().map(|s| format!("dilation, {s}")).collect();
    names.extend(srcs.iter().map(|s| format!("|dilation|, {s}")));
    let mut cols: Vec<usize> = (at..at + d).collect();
    cols.extend(at..at + d);
    println!("\n## Dilation per recording, mean over its windows: touches against slips (no model)\n");
    println!("| object | input | mean on t | mean on slips | t below every slip | t below the slips' median |");
    println!("|---|---|---|---|---|---|");
    let per_rec = column_means(&tr, &inputs, &layout, &cols)?;
    let abs_from = d;
    for obj in objects.iter().copied().chain(["all"]) {
        for (c, name) in names.iter().enumerate() {
            let of = |touch: bool| -> Vec<f64> {
                (0..tr.len())
                    .filter(|&i| (obj == "all" || recs[i].object == obj) && (tr[i].class == DosClass::T) == touch)
                    .map(|i| if c >= abs_from { per_rec[i][c].abs() } else { per_rec[i][c] })
                    .collect()
            };
            let (t, mut s) = (of(true), of(false));
            s.sort_by(f64::total_cmp);
            let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
            let min = s.first().copied().unwrap_or(f64::INFINITY);
            let median = s.get(s.len() / 2).copied().unwrap_or(f64::INFINITY);
            let below = t.iter().filter(|&&v| v < min).count();
            let below_median = t.iter().filter(|&&v| v < median).count();
            println!(
                "| {obj} | {name} | {:.3} | {:.3} | {below}/{} | {below_median}/{} |",
                mean(&t),
                mean(&s),
                t.len(),
                t.len()
            );
        }
    }
    println!(
        "\n## Rotation sense of the turn fitted beside the dilation (per recording: mean over its windows; sign right = cw +, aw −; no model)\n"
    );
    println!("| input | cw/aw sign right | mean |·| on cw/aw | mean |·| on n/e/s/w/t |");
    println!("|---|---|---|---|");
    let cols: Vec<usize> = (0..src).map(|k| turn_at + k * TURN_INPUTS + 2).collect();
    let per_rec = column_means(&tr, &inputs, &layout, &cols)?;
    for (c, name) in srcs.iter().enumerate() {
        println!("| fitted θ with dilation, {name} | {} |", rotation_sense_cells(&tr, &per_rec, c, |_| true));
    }
    Ok(())
}

/// The rotation-sense table's cells for column `c` of the per-recording means `per_rec`, over
/// the recordings `keep` selects: how many rotation recordings (cw, aw) have the class's sign
/// of all of them, the mean |value| on them, and on the other classes.
fn rotation_sense_cells(tr: &[TrainRecording], per_rec: &[Vec<f64>], c: usize, keep: impl Fn(usize) -> bool) -> String {
    let (mut right, mut rot, mut rot_abs, mut other_abs, mut other) = (0, 0, 0.0, 0.0, 0);
    for (i, r) in tr.iter().enumerate().filter(|(i, _)| keep(*i)) {
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
    format!("{right}/{rot} | {:.4} | {:.4}", rot_abs / rot.max(1) as f64, other_abs / other.max(1) as f64)
}

/// One row of the touch table: a `t` recording's per-window decisions by thirds.
fn touch_row(
    set: &str,
    obj: &str,
    decided: DosClass,
    per_window: &[DosClass],
    mlp: &[f64],
    classes: &[DosClass],
) -> String {
    let k = per_window.len().max(1);
    let third = |a: usize, b: usize| {
        let w = &per_window[a.min(k)..b.min(per_window.len())];
        let t = w.iter().filter(|&&c| c == DosClass::T).count();
        format!("{t}/{}", w.len())
    };
    let at = |c: DosClass| classes.iter().position(|&x| x == c).and_then(|j| mlp.get(j)).copied().unwrap_or(f64::NAN);
    format!(
        "| {set}, {obj} | {} | {} | {} | {} | {} | {:.2} |",
        decided.as_str(),
        per_window.len(),
        third(0, k / 3),
        third(k / 3, 2 * k / 3),
        third(2 * k / 3, k),
        at(DosClass::T) - at(decided)
    )
}

/// Per recording, the mean over its tree windows (`inputs`) of each input column in `cols`.
fn column_means(
    tr: &[TrainRecording],
    inputs: &TreeInputs,
    layout: &Layout,
    cols: &[usize],
) -> Result<Vec<Vec<f64>>, Box<dyn Error>> {
    tr.iter()
        .map(|r| {
            let x = tree_windows(&r.frames, inputs, layout)?;
            let k = x.len().max(1) as f64;
            Ok(cols.iter().map(|&c| x.iter().map(|v| v[c]).sum::<f64>() / k).collect())
        })
        .collect()
}
