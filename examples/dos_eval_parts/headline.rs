//! The held-out headline of `dos_eval`: nested leave-one-object-out, cross-object-set figures,
//! the published 5-frame-window protocol, accuracy by time since contact, and the baselines.

use super::sliding_cost::frame;
use gradtac::calibrate::{
    design_candidates, design_tables, held_out, object_set, spans_of, CalibrateOptions, Recording,
};
use gradtac::stages::dos::{DosClass, DosClassifier, DosFeatureConfig, DosModel, Feature, LabelledSpan};
use gradtac::stages::dos_select::{choose, Candidate};
use gradtac::stages::drift::DriftScale;
use gradtac::stream::{Layout, Stage};
use std::error::Error;

/// ν of the Student-t class densities (fixed, not chosen).
const DOF: Option<f64> = Some(DosModel::DEFAULT_STUDENT_T_DOF);

/// Floors every run with the data asserts (the CI run included): a few points under the
/// measured 80.2 % (nested, 167 recordings), 85.7 % (basic → solids, 56) and 66.7 %
/// (solids → basic, 111) — about three to five recordings' worth.
const FLOOR_NESTED: f64 = 0.77;
const FLOOR_BASIC_TO_SOLIDS: f64 = 0.80;
const FLOOR_SOLIDS_TO_BASIC: f64 = 0.63;

/// (correct, decided).
type Tally = (usize, usize);

fn pct(ok: usize, n: usize) -> String {
    format!("{:.1} % ({ok}/{n})", 100.0 * ok as f64 / n.max(1) as f64)
}

fn indices(recs: &[Recording], set: &str) -> Vec<usize> {
    (0..recs.len()).filter(|&i| object_set(&recs[i].object) == set).collect()
}

/// The cheapest reasonable baseline: the change of every taxel (mean of the last 20 frames
/// minus mean of the first 20), scaled to unit length (gain-, offset-invariant), and the nearest
/// class mean of those vectors.
fn mean_change(frames: &[Vec<f64>]) -> Vec<f64> {
    let k = 20.min(frames.len() / 2).max(1);
    let taxels = frames[0].len();
    let mean = |rows: &[Vec<f64>]| -> Vec<f64> {
        (0..taxels).map(|j| rows.iter().map(|r| r[j]).sum::<f64>() / rows.len() as f64).collect()
    };
    let (a, b) = (mean(&frames[..k]), mean(&frames[frames.len() - k..]));
    let d: Vec<f64> = b.iter().zip(&a).map(|(x, y)| x - y).collect();
    let norm = d.iter().map(|v| v * v).sum::<f64>().sqrt();
    d.iter().map(|v| if norm > 0.0 { v / norm } else { 0.0 }).collect()
}

fn nearest_mean(vecs: &[(DosClass, Vec<f64>)], train: &[usize], test: &[usize]) -> (usize, usize) {
    let d = vecs[0].1.len();
    let mut means = vec![(vec![0.0; d], 0usize); 7];
    for &i in train {
        let k = DosClass::ALL.iter().position(|&c| c == vecs[i].0).unwrap_or(0);
        means[k].1 += 1;
        for j in 0..d {
            means[k].0[j] += vecs[i].1[j];
        }
    }
    let mut ok = 0;
    for &i in test {
        let best = (0..7)
            .filter(|&k| means[k].1 > 0)
            .min_by(|&a, &b| {
                let dist = |k: usize| -> f64 {
                    (0..d).map(|j| (vecs[i].1[j] - means[k].0[j] / means[k].1 as f64).powi(2)).sum()
                };
                dist(a).total_cmp(&dist(b))
            })
            .unwrap_or(0);
        ok += usize::from(DosClass::ALL[best] == vecs[i].0);
    }
    (ok, test.len())
}

fn baseline(recs: &[Recording]) {
    let vecs: Vec<(DosClass, Vec<f64>)> = recs.iter().map(|r| (r.class, mean_change(&r.frames))).collect();
    let mut objects: Vec<&str> = recs.iter().map(|r| r.object.as_str()).collect();
    objects.sort_unstable();
    objects.dedup();
    let (mut ok, mut n) = (0, 0);
    for o in &objects {
        let test: Vec<usize> = (0..recs.len()).filter(|&i| recs[i].object == *o).collect();
        let train: Vec<usize> = (0..recs.len()).filter(|&i| recs[i].object != *o).collect();
        let r = nearest_mean(&vecs, &train, &test);
        ok += r.0;
        n += r.1;
    }
    let (b, s) = (indices(recs, "basic"), indices(recs, "solids"));
    let bs = nearest_mean(&vecs, &b, &s);
    let sb = nearest_mean(&vecs, &s, &b);
    println!(
        "| nearest class mean of the unit mean-change vector (24 taxels; no choice) | 168 | {} | {} | {} |",
        pct(ok, n),
        pct(bs.0, bs.1),
        pct(sb.0, sb.1)
    );
}

/// Sliding decisions of the streaming `dos` tap (early answers, hop 5 frames) of `model` on
/// every test recording: correct decisions at 25, 50, 100, 200 frames and at the end.
fn early(
    model: &DosModel,
    recs: &[Recording],
    test: &[usize],
    layout: &Layout,
) -> Result<Vec<(usize, usize)>, Box<dyn Error>> {
    let marks = [25u64, 50, 100, 200];
    let mut tally = vec![(0usize, 0usize); marks.len() + 1];
    for &i in test {
        let r = &recs[i];
        let mut tap =
            DosClassifier::try_new(model.clone(), layout, Some(100_000))?.with_hop(5)?.with_early_decisions()?;
        let mut out = Vec::new();
        for (seq, v) in r.frames.iter().enumerate() {
            tap.push(frame(seq, v), &mut out)?;
        }
        tap.finish(&mut out)?;
        for (k, &m) in marks.iter().enumerate() {
            if let Some(d) = out.iter().find(|d| d.frames == m) {
                tally[k].0 += usize::from(d.decision.class == r.class);
                tally[k].1 += 1;
            }
        }
        if let Some(d) = out.last() {
            tally[marks.len()].0 += usize::from(d.decision.class == r.class);
            tally[marks.len()].1 += 1;
        }
    }
    Ok(tally)
}

/// The published protocol: per non-overlapping 5-frame window of every test recording, the
/// decision from the window alone (a model of lags 1, 2, 4 frames fitted on the training
/// recordings' 5-frame windows) and from the causal history since contact (the chosen model,
/// fitted on whole training recordings).
fn windows(
    cand: &Candidate,
    recs: &[Recording],
    train: &[usize],
    test: &[usize],
    layout: &Layout,
) -> Result<[Tally; 2], Box<dyn Error>> {
    use gradtac::stages::dos::DosFeatureExtractor;
    // history: the candidate fitted on whole training recordings
    let whole = spans_of(recs, &cand.config, layout, usize::MAX)?;
    let model = cand.calibrate(train.iter().map(|&i| &whole[i]), DOF)?;
    let all = DosFeatureConfig { features: Feature::ALL.to_vec(), ..cand.config.clone() };
    let mut ex = DosFeatureExtractor::try_new(&all, layout)?;
    let mut hist = (0, 0);
    for &i in test {
        ex.reset();
        for (seq, v) in recs[i].frames.iter().enumerate() {
            ex.push(frame(seq, v))?;
            if (seq + 1) % 5 == 0 {
                let d = model.classify_vector(&ex.features())?;
                hist.0 += usize::from(d.class == recs[i].class);
                hist.1 += 1;
            }
        }
    }
    // window alone: 5-frame spans, lags 1, 2, 4
    let wcfg = DosFeatureConfig { drift_lags: vec![1, 2, 4], features: Feature::ALL.to_vec(), ..cand.config.clone() };
    let mut wx = DosFeatureExtractor::try_new(&wcfg, layout)?;
    let mut win_spans = |ix: &[usize]| -> Result<Vec<LabelledSpan>, Box<dyn Error>> {
        let mut out = Vec::new();
        for &i in ix {
            for (w, chunk) in recs[i].frames.chunks_exact(5).enumerate() {
                wx.reset();
                for (k, v) in chunk.iter().enumerate() {
                    wx.push(frame(5 * w + k, v))?;
                }
                out.push(LabelledSpan { class: recs[i].class, group: recs[i].object.clone(), features: wx.features() });
            }
        }
        Ok(out)
    };
    let (tr, te) = (win_spans(train)?, win_spans(test)?);
    let wcand =
        Candidate { config: DosFeatureConfig { drift_lags: vec![1, 2, 4], ..cand.config.clone() }, ..cand.clone() };
    let wmodel = wcand.calibrate(&tr, DOF)?;
    let mut alone = (0, 0);
    for s in &te {
        alone.0 += usize::from(wmodel.classify_vector(&s.features)?.class == s.class);
        alone.1 += 1;
    }
    Ok([alone, hist])
}

/// The headline; fails (an error) when a held-out figure is under its floor unless `no_floors`.
pub fn run(dir: &std::path::Path, layout: &Layout, no_floors: bool) -> Result<(), Box<dyn Error>> {
    let recs = gradtac::calibrate::read_recordings(dir, &CalibrateOptions::default())?;
    let base = DosFeatureConfig::default();
    println!("\n## Held-out headline (nothing below was chosen on the recordings it scores)\n");
    let tables = design_tables(&recs, &base, layout, usize::MAX)?;
    let cands = design_candidates(&base);
    let held = held_out(&tables, &cands, DOF)?;
    // today's classifier (before this design): nine features incl. the positive-event centroid,
    // log drift map, λ = 0.5, no mirror — one fixed candidate
    let old_cfg = DosFeatureConfig {
        drift_scale: DriftScale::Log,
        features: Feature::DEFAULT_BEFORE_INVARIANCE.to_vec(),
        drift_lags: vec![30, 60, 120],
        ..base.clone()
    };
    let old_tables = vec![spans_of(&recs, &old_cfg, layout, usize::MAX)?];
    let old = held_out(&old_tables, &[Candidate { table: 0, config: old_cfg, shrinkage: 0.5, mirror: false }], DOF)?;
    let fig = |h: &gradtac::calibrate::HeldOut| -> [String; 3] {
        let one = |s: &Option<gradtac::stages::dos_select::Selected>| {
            s.as_ref().map_or("—".into(), |s| pct(s.cv.folds[0].1, s.cv.folds[0].2))
        };
        let (ok, n) = h.nested.cv.folds.iter().fold((0, 0), |a, f| (a.0 + f.1, a.1 + f.2));
        [pct(ok, n), one(&h.basic_to_solids), one(&h.solids_to_basic)]
    };
    println!("| method (per recording; chance 14.3 %) | parameters | nested leave-one-object-out | basic → solids | solids → basic |");
    println!("|---|---|---|---|---|");
    baseline(&recs);
    let o = fig(&old);
    println!(
        "| the classifier before this design (9 features, log drift, λ 0.5; fixed — its choices were made on the \
         plain leave-one-object-out, so its first figure is that, in-sample for the choices) | 126 | {} | {} | {} |",
        o[0], o[1], o[2]
    );
    let n = fig(&held);
    println!(
        "| invariant drift design: {} candidates (lags × feature sets × λ × mirror) chosen inside every fold | ≤ 98 | {} | {} | {} |",
        cands.len(),
        n[0],
        n[1],
        n[2]
    );
    // For comparison only: the same nested choice with the earlier nine features (drift map on the
    // log scale + positive-event centroid: NOT invariant to an offset) added as candidates.
    let mut wide_tables = tables.clone();
    let ev_cfg = DosFeatureConfig {
        drift_scale: DriftScale::Log,
        features: Feature::DEFAULT_BEFORE_INVARIANCE.to_vec(),
        drift_lags: vec![30, 60, 120],
        ..base.clone()
    };
    wide_tables.push(spans_of(&recs, &ev_cfg, layout, usize::MAX)?);
    let mut wide = cands.clone();
    for shrinkage in gradtac::calibrate::DESIGN_SHRINKAGE {
        for mirror in [false, true] {
            wide.push(Candidate { table: tables.len(), config: ev_cfg.clone(), shrinkage, mirror });
        }
    }
    let w = fig(&held_out(&wide_tables, &wide, DOF)?);
    println!(
        "| (comparison, not a default) the same choice with the earlier nine features (log drift + positive-event \
         centroid, not offset-invariant) added: {} candidates | ≤ 126 | {} | {} | {} |",
        wide.len(),
        w[0],
        w[1],
        w[2]
    );
    println!("\nchoices per outer fold (nested leave-one-object-out, then the cross-set trainings):");
    for (g, k, inner) in held
        .nested
        .chosen
        .iter()
        .chain(held.basic_to_solids.iter().chain(&held.solids_to_basic).flat_map(|s| s.chosen.iter()))
    {
        println!("- {g}: {} (inner {:.1} %)", cands[*k].describe(), 100.0 * inner);
    }
    print!("\nnested leave-one-object-out, folds and confusion:\n\n{}", held.nested.cv);
    for s in held.basic_to_solids.iter().chain(&held.solids_to_basic) {
        print!("\ncross-set {}:\n\n{}", s.cv.folds[0].0, s.cv);
    }
    // The frozen default: what the same choice makes on all recordings.
    let all: Vec<usize> = (0..recs.len()).collect();
    let (k, acc) = choose(&tables, &all, &cands, DOF)?;
    println!(
        "\nthe choice on all {} recordings (the shipped default; inner leave-one-object-out {:.1} %, in-sample for \
         the choice): {}",
        recs.len(),
        100.0 * acc,
        cands[k].describe()
    );
    let opts = CalibrateOptions::default();
    println!(
        "the library's defaults: {} features [{}], lags {:?} ({:?}), λ = {}, mirror {}",
        opts.features.features.len(),
        opts.features.features.iter().map(|f| f.name()).collect::<Vec<_>>().join(", "),
        opts.features.drift_lags,
        opts.features.drift_scale,
        opts.shrinkage,
        if opts.mirror { "on" } else { "off" }
    );

    let (b, s) = (indices(&recs, "basic"), indices(&recs, "solids"));
    if !b.is_empty() && !s.is_empty() {
        // published protocol, trained on basic
        if let Some(bs) = &held.basic_to_solids {
            let cand = &cands[bs.chosen[0].1];
            let [alone, hist] = windows(cand, &recs, &b, &s, layout)?;
            println!(
                "\npublished protocol (trained on basic only, choice by leave-one-object-out on basic; accuracy per \
                 non-overlapping 5-frame window of the solids recordings): window alone {}; causal history since \
                 contact {}; the ConvLSTM: 82.56 % (window alone)",
                pct(alone.0, alone.1),
                pct(hist.0, hist.1)
            );
        }
        println!(
            "\naccuracy by time since contact — the streaming `dos` tap, sliding decisions every 5 frames with early \
             answers (each over all frames since contact), the model of the cross-set choice fitted on whole \
             training recordings:\n\n| split | 0.25 s | 0.5 s | 1 s | 2 s | whole |\n|---|---|---|---|---|---|"
        );
        for (sel, train, test) in [(&held.basic_to_solids, &b, &s), (&held.solids_to_basic, &s, &b)] {
            let Some(sel) = sel else { continue };
            let cand = &cands[sel.chosen[0].1];
            let model = cand.calibrate(train.iter().map(|&i| &tables[cand.table][i]), DOF)?;
            let t = early(&model, &recs, test, layout)?;
            println!(
                "| {} | {} |",
                sel.cv.folds[0].0,
                t.iter().map(|&(ok, n)| pct(ok, n)).collect::<Vec<_>>().join(" | ")
            );
        }
    }
    if !no_floors {
        let checks = [
            ("nested leave-one-object-out", Some(held.nested.cv.accuracy()), FLOOR_NESTED),
            ("basic → solids", held.basic_to_solids.as_ref().map(|s| s.cv.accuracy()), FLOOR_BASIC_TO_SOLIDS),
            ("solids → basic", held.solids_to_basic.as_ref().map(|s| s.cv.accuracy()), FLOOR_SOLIDS_TO_BASIC),
        ];
        for (name, got, floor) in checks {
            if let Some(got) = got {
                if got < floor {
                    return Err(
                        format!("{name}: {:.1} % is under the floor {:.1} %", 100.0 * got, 100.0 * floor).into()
                    );
                }
                println!("floor held: {name} {:.1} % ≥ {:.1} %", 100.0 * got, 100.0 * floor);
            }
        }
    }
    Ok(())
}
