//! Held-out figures of one tree candidate (`dos_trees --held-out CANDIDATE.json`), run once for
//! the rule's winner (`examples/dos_eval_parts/trees_rule.md`), and since stop 34 `dos_eval`'s
//! section of the default model's tree part (T12 since stop 35's round 4, T9 in round 3, T4 in stop 34, the cross-set splits; the nested protocol too
//! with `--trees-nested`): the combination with the
//! Student-t design exactly as the window net's (`dos_eval`'s window part): per outer fold the
//! Student-t candidate its own procedure chose on the fold's training objects, the weight `a` by
//! leave-one-object-out per recording inside the training objects (both models refitted on
//! each inner training part), both fitted on the training objects, deciding the test objects.

use gradtac::calibrate::{design_candidates, design_tables, held_out, object_set, train_recordings, CalibrateOptions};
use gradtac::stages::dos::train::TrainRecording;
use gradtac::stages::dos::train_trees::{fit_on, tree_samples, TreeSamples, TreeTrainConfig};
use gradtac::stages::dos::{DosClass, DosFeatureConfig, DosModel, DosTrees, LabelledSpan};
use gradtac::stages::dos_select::Candidate;
use gradtac::stream::Layout;
use std::collections::BTreeMap;
use std::error::Error;
use std::time::Instant;

use super::combination::{best_weight, combined_class, log_over_all, Pair};

fn pct((ok, n): (usize, usize)) -> String {
    format!("{:.1} % ({ok}/{n})", 100.0 * ok as f64 / n.max(1) as f64)
}

fn add(a: &mut (usize, usize), b: (usize, usize)) {
    a.0 += b.0;
    a.1 += b.1;
}

struct Ctx<'a> {
    tr: &'a [TrainRecording],
    tables: &'a [Vec<LabelledSpan>],
    early: &'a [Vec<LabelledSpan>],
    tcands: &'a [Candidate],
    samples: &'a [TreeSamples],
    cfg: &'a TreeTrainConfig,
    layout: &'a Layout,
}

/// Per outer fold: the combination's tallies (whole, at 1 s), its weight, the trees alone
/// (vote per recording, at 1 s, per window, vote at every window's end), and (object, true, decided).
#[derive(Default)]
struct Fold {
    whole: (usize, usize),
    at1: (usize, usize),
    a: f64,
    vote: (usize, usize),
    vote_at1: (usize, usize),
    window: (usize, usize),
    history: (usize, usize),
    decided: Vec<(String, DosClass, DosClass)>,
}

impl Ctx<'_> {
    fn fit(&self, tk: usize, train: &[usize]) -> Result<(DosModel, DosTrees), Box<dyn Error>> {
        let tc = &self.tcands[tk];
        let model =
            tc.calibrate(train.iter().map(|&i| &self.tables[tc.table][i]), Some(DosModel::DEFAULT_STUDENT_T_DOF))?;
        Ok((model, fit_on(self.samples, train, self.layout, self.cfg)?))
    }

    fn pairs(
        &self,
        m: &(DosModel, DosTrees),
        tk: usize,
        test: &[usize],
        span: usize,
    ) -> Result<Vec<Pair>, Box<dyn Error>> {
        let tables = if span == usize::MAX { self.tables } else { self.early };
        let tc = &self.tcands[tk];
        let mut vote = m.1.vote(self.layout)?;
        test.iter()
            .map(|&i| {
                let p = m.0.classify_vector(&tables[tc.table][i].features)?.posterior;
                let lp: Vec<f64> = p.iter().map(|v| v.max(1e-300).ln()).collect();
                vote.reset();
                for f in self.tr[i].frames.iter().take(span) {
                    vote.push(f)?;
                }
                let w = vote.mean_log_posterior().unwrap_or_else(|| vec![0.0; m.1.classes().len()]);
                Ok((log_over_all(&m.0.classes, &lp), log_over_all(m.1.classes(), &w)))
            })
            .collect()
    }

    fn groups(&self, idx: &[usize]) -> Vec<String> {
        let mut g: Vec<String> = idx.iter().map(|&i| self.tr[i].group.clone()).collect();
        g.sort();
        g.dedup();
        g
    }

    fn fold(&self, tk: usize, train: &[usize], test: &[usize]) -> Result<Fold, Box<dyn Error>> {
        let mut inner: Vec<(Pair, DosClass)> = Vec::new();
        for g in self.groups(train) {
            let a: Vec<usize> = train.iter().copied().filter(|&i| self.tr[i].group != g).collect();
            let b: Vec<usize> = train.iter().copied().filter(|&i| self.tr[i].group == g).collect();
            let m = self.fit(tk, &a)?;
            let p = self.pairs(&m, tk, &b, usize::MAX)?;
            inner.extend(p.into_iter().zip(b.iter().map(|&i| self.tr[i].class)));
        }
        let a = best_weight(&inner);
        let m = self.fit(tk, train)?;
        let whole = self.pairs(&m, tk, test, usize::MAX)?;
        let at1 = self.pairs(&m, tk, test, 100)?;
        let mut out = Fold { a, ..Fold::default() };
        for (k, &i) in test.iter().enumerate() {
            let class = self.tr[i].class;
            let d = combined_class(&whole[k], a);
            add(&mut out.whole, (usize::from(d == class), 1));
            add(&mut out.at1, (usize::from(combined_class(&at1[k], a) == class), 1));
            out.decided.push((self.tr[i].group.clone(), class, d));
        }
        let mut vote = m.1.vote(self.layout)?;
        for &i in test {
            let class = self.tr[i].class;
            vote.reset();
            for (t, f) in self.tr[i].frames.iter().enumerate() {
                if let Some(w) = vote.push(f)? {
                    add(&mut out.window, (usize::from(w.class == class), 1));
                    let h = vote.decision().ok_or("no vote after a window")?;
                    add(&mut out.history, (usize::from(h.class == class), 1));
                }
                if t + 1 == 100 {
                    add(&mut out.vote_at1, (usize::from(vote.decision().is_some_and(|d| d.class == class)), 1));
                }
            }
            add(&mut out.vote, (usize::from(vote.decision().is_some_and(|d| d.class == class)), 1));
        }
        Ok(out)
    }
}

/// The held-out figures `dos_eval` checks against its floors: the combination per recording
/// (nested when run, basic → solids, solids → basic) and the ConvLSTM protocol (trees trained on
/// basic, each 5-frame window of solids), as (right, decided).
#[allow(dead_code)]
pub struct Figures {
    /// Nested leave-one-object-out (`None` when not run).
    pub nested: Option<(usize, usize)>,
    /// Basic → solids.
    pub basic_to_solids: (usize, usize),
    /// Solids → basic.
    pub solids_to_basic: (usize, usize),
    /// The ConvLSTM protocol, per window.
    pub convlstm: (usize, usize),
}

/// Run the held-out protocols for `cfg` and print them (every protocol).
#[allow(dead_code)]
pub fn run(dir: &std::path::Path, layout: &Layout, cfg: &TreeTrainConfig) -> Result<(), Box<dyn Error>> {
    run_with(dir, layout, cfg, true).map(|_| ())
}

/// Run the held-out protocols for `cfg` (the nested one only if `nested`: ≈ 36 of the ≈ 44
/// tree fits) and print them.
pub fn run_with(
    dir: &std::path::Path,
    layout: &Layout,
    cfg: &TreeTrainConfig,
    nested_too: bool,
) -> Result<Figures, Box<dyn Error>> {
    let t0 = Instant::now();
    let recs = gradtac::calibrate::read_recordings(dir, &CalibrateOptions::default())?;
    let tr = train_recordings(&recs);
    let base = DosFeatureConfig::default();
    let tables = design_tables(&recs, &base, layout, usize::MAX)?;
    let early = design_tables(&recs, &base, layout, 100)?;
    let tcands = design_candidates(&base);
    let held = held_out(&tables, &tcands, Some(DosModel::DEFAULT_STUDENT_T_DOF))?;
    let samples = tree_samples(&tr, layout, cfg)?;
    let ctx = Ctx { tr: &tr, tables: &tables, early: &early, tcands: &tcands, samples: &samples, cfg, layout };
    let all: Vec<usize> = (0..tr.len()).collect();
    let pick = |chosen: &[(String, usize, f64)], g: &str| chosen.iter().find(|c| c.0 == g).map(|c| c.1);
    let mut nested = Fold::default();
    let mut weights = Vec::new();
    for g in ctx.groups(&all).into_iter().filter(|_| nested_too) {
        let tk = pick(&held.nested.chosen, &g).ok_or_else(|| format!("no Student-t choice for {g}"))?;
        let train: Vec<usize> = all.iter().copied().filter(|&i| tr[i].group != g).collect();
        let test: Vec<usize> = all.iter().copied().filter(|&i| tr[i].group == g).collect();
        let f = ctx.fold(tk, &train, &test)?;
        add(&mut nested.whole, f.whole);
        add(&mut nested.vote, f.vote);
        add(&mut nested.window, f.window);
        weights.push(format!("{g} {}", f.a));
        nested.decided.extend(f.decided);
    }
    let of = |set: &str| -> Vec<usize> { (0..recs.len()).filter(|&i| object_set(&recs[i].object) == set).collect() };
    let (b, s) = (of("basic"), of("solids"));
    let mut cross = Vec::new();
    for (name, sel, train, test) in
        [("basic → solids", &held.basic_to_solids, &b, &s), ("solids → basic", &held.solids_to_basic, &s, &b)]
    {
        let sel = sel.as_ref().ok_or("no cross-set Student-t choice")?;
        let f = ctx.fold(sel.chosen[0].1, train, test)?;
        weights.push(format!("{name} {}", f.a));
        cross.push((name, f));
    }
    let st =
        |sel: &gradtac::stages::dos_select::Selected| sel.cv.folds.iter().fold((0, 0), |a, f| (a.0 + f.1, a.1 + f.2));
    println!("\n## Tree candidate, held out\n\ncandidate: {}\n", serde_json::to_string(cfg)?);
    let pct_nested = |t: (usize, usize)| if nested_too { pct(t) } else { "— (`--trees-nested`)".into() };
    println!("| per recording unless marked | nested leave-one-object-out | basic → solids | solids → basic |");
    println!("|---|---|---|---|");
    println!(
        "| **combination with Student t** (a chosen inside the training objects) | {} | {} | {} |",
        pct_nested(nested.whole),
        pct(cross[0].1.whole),
        pct(cross[1].1.whole)
    );
    println!(
        "| trees alone, vote | {} | {} | {} |",
        pct_nested(nested.vote),
        pct(cross[0].1.vote),
        pct(cross[1].1.vote)
    );
    println!(
        "| trees alone, per 5-frame window (inputs: the window and the causal history the representation holds) | {} | {} | {} |",
        pct_nested(nested.window),
        pct(cross[0].1.window),
        pct(cross[1].1.window)
    );
    println!(
        "| Student t alone (baseline) | {} | {} | {} |",
        pct(st(&held.nested)),
        held.basic_to_solids.as_ref().map_or("—".into(), |x| pct(st(x))),
        held.solids_to_basic.as_ref().map_or("—".into(), |x| pct(st(x)))
    );
    println!(
        "\nConvLSTM protocol (trained on basic only, per non-overlapping 5-frame window of solids): each window's own \
         answer {}; the vote so far at every window's end (causal history) {}",
        pct(cross[0].1.window),
        pct(cross[0].1.history)
    );
    println!(
        "early answers at 1 s into contact: combination basic → solids {}, solids → basic {}; trees' vote {}, {}",
        pct(cross[0].1.at1),
        pct(cross[1].1.at1),
        pct(cross[0].1.vote_at1),
        pct(cross[1].1.vote_at1)
    );
    println!("weights chosen per outer fold: {}", weights.join(", "));
    for (name, f) in &cross {
        let mut per = BTreeMap::<&str, (usize, usize)>::new();
        let mut conf = BTreeMap::<String, usize>::new();
        for (o, t, d) in &f.decided {
            add(per.entry(o.as_str()).or_default(), (usize::from(t == d), 1));
            if t != d {
                *conf.entry(format!("{t}→{d}")).or_default() += 1;
            }
        }
        println!(
            "(combination, {name}, per test object: {}; errors true → decided: {})",
            per.iter().map(|(o, t)| format!("{o} {}", pct(*t))).collect::<Vec<_>>().join(", "),
            conf.iter().map(|(k, n)| format!("{k} {n}")).collect::<Vec<_>>().join(", ")
        );
    }
    println!("(all held-out figures: {:.0} s)", t0.elapsed().as_secs_f64());
    Ok(Figures {
        nested: nested_too.then_some(nested.whole),
        basic_to_solids: cross[0].1.whole,
        solids_to_basic: cross[1].1.whole,
        convlstm: cross[0].1.window,
    })
}
