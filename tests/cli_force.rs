//! `gradtac calibrate force`, `gradtac calibrate baseline` and the scenes that use their files,
//! end to end on a simulated gauge session (a member of the force family, seed 700, that no
//! choice was made on); and the warning for stage tables a plan will not run.

use arrow_array::cast::AsArray;
use arrow_array::types::Float64Type;
use gradtac::stages::sim_force::{ForceRecording, ForceSession};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

fn gradtac() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gradtac"))
}

/// The session as a CSV: 24 taxel columns, the gauge's newtons and a time column (s).
fn write_csv(path: &Path, rec: &ForceRecording) {
    let mut s = String::from("t");
    for i in 1..=24 {
        s.push_str(&format!(",ff_e{i}"));
    }
    s.push_str(",force_n\n");
    for (f, g) in rec.frames.iter().zip(&rec.gauge) {
        s.push_str(&format!("{}", f.time.as_secs_f64()));
        for v in &f.values {
            s.push_str(&format!(",{v}"));
        }
        s.push_str(&format!(",{g}\n"));
    }
    fs::write(path, s).unwrap();
}

fn scene(dir: &Path, name: &str, csv: &str, extra: &str, tap: &str) -> PathBuf {
    let p = dir.join(name);
    fs::write(
        &p,
        format!(
            "[[sensor]]\nname = \"ff\"\nsource = {{ csv = \"{csv}\", columns = \"ff_e{{1..24}}\", time_column = \"t\" }}\n\
             [[output]]\ntap = \"{tap}\"\npath = \"{name}.parquet\"\n{extra}"
        ),
    )
    .unwrap();
    p
}

fn forces(path: &Path) -> Vec<Option<f64>> {
    let reader = ParquetRecordBatchReaderBuilder::try_new(fs::File::open(path).unwrap()).unwrap().build().unwrap();
    let mut out = Vec::new();
    for b in reader {
        let b = b.unwrap();
        let c = b.column_by_name("force_n").unwrap().as_primitive::<Float64Type>().clone();
        out.extend(c.iter());
    }
    out
}

/// MAPE (%) above 0.5 N of the estimates `f` against the truth `force` (each estimate describes
/// the centre of its 9 frames); a frame with no estimate counts as 100 %.
fn mape_above_half_newton(f: &[Option<f64>], force: &[f64]) -> f64 {
    let errs: Vec<f64> = (0..f.len())
        .filter(|&k| force[k.saturating_sub(4)] > 0.5)
        .map(|k| f[k].map_or(1.0, |e| (e - force[k - 4]).abs() / force[k - 4]))
        .collect();
    100.0 * errs.iter().sum::<f64>() / errs.len() as f64
}

fn ok(out: std::process::Output) -> String {
    let text = String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{text}");
    text
}

#[test]
fn calibrate_force_then_a_bare_scene_reports_force_and_none_when_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let rec = ForceSession::presses(700, 6).simulate();
    write_csv(&dir.path().join("cal.csv"), &rec);
    let cal = scene(dir.path(), "cal.toml", "cal.csv", "", "source");
    let model = dir.path().join("force.json");
    let text = ok(gradtac()
        .args(["calibrate", "force"])
        .arg(&cal)
        .args(["--force-column", "force_n", "--out"])
        .arg(&model)
        .output()
        .unwrap());
    // the default method is `forward` (session 31) with the multi-start identification and the
    // held-aside-press guard (session 32): on member 700 the forward model predicts each
    // calibration press held aside better than the placed law, so a version-5 forward file (with
    // its gains' doubts, round 10) is
    // written (session 31's single start failed here — γ 1.16, w 3.2 mm, 11 of 24 gains of the
    // wrong sign — and its in-sample guard wrote the placed law)
    assert!(text.contains("calibrated forward force on") && !text.contains("note:"), "{text}");
    assert_eq!(gradtac::scene::read_force_file(&model).unwrap().version, 5);
    // a second session of the same sensor (other noise), through the bare default chain
    let test = ForceSession { noise_stream: 9, ..ForceSession::presses(700, 6) }.simulate();
    write_csv(&dir.path().join("test.csv"), &test);
    let run = scene(dir.path(), "run.toml", "test.csv", "[stages.force]\nmodel = \"force.json\"\n", "force");
    let explain = ok(gradtac().arg("explain").arg(&run).output().unwrap());
    assert!(explain.contains("the identified forward model"), "{explain}");
    // round 10: the version-5 file's gain doubts weigh the inversion, and explain says so
    assert!(
        explain.contains("weighted by its gain's calibration doubt (1/√(s₀² + (rᵢΔᵢ)²), s₀ = 3 counts"),
        "{explain}"
    );
    assert!(explain.contains("drift model: settle 0.2 s"), "{explain}");
    // the hold's start bound (session 37): a contact starts beyond 3 σ, the 2-σ hold keeps it
    assert!(
        explain.contains("hold beyond 2 σ: baseline frozen and a contact until it returns, started only beyond 3 σ"),
        "{explain}"
    );
    // the gate's shape return, with its flatness test
    assert!(explain.contains("(range within 0.1 Σσ), at most 0.5 of the peak above the untouched floor"), "{explain}");
    // and what the slope's anchors do at such a return (session 33)
    assert!(
        explain.contains("the slope's anchors shifted to the new level at a return by the shape alone"),
        "{explain}"
    );
    // the drift-shape return's rise test and its undo (session 35), with their effective values
    assert!(
        explain.contains("when its total change 2 s before was below 0.5 of its own")
            && explain.contains("undone when the sensor comes back to the level before it within 10 s"),
        "{explain}"
    );
    assert!(!explain.contains("centroid"), "the force alone needs no contact location: {explain}");
    ok(gradtac().args(["run", "-q"]).arg(&run).output().unwrap());
    let f = forces(&dir.path().join("run.toml.parquet"));
    assert_eq!(f.len(), test.frames.len());
    let (mut quiet, mut over, mut errs) = (0, 0, Vec::new());
    for (k, est) in f.iter().enumerate() {
        // the estimate describes the centre of its 9 frames
        let truth = test.force[k.saturating_sub(4)];
        if (k.saturating_sub(50)..=k).all(|j| test.force[j] == 0.0) {
            quiet += 1;
            over += usize::from(est.is_some_and(|e| e > 0.5));
        }
        if truth > 0.5 {
            errs.push(est.map_or(1.0, |e| (e - truth).abs() / truth));
        }
    }
    // before the first press (1 s at rest, after the detector's 20 calibration frames) no
    // frame reports a force
    assert!(f[..100].iter().all(Option::is_none), "a force before the first press");
    // Between presses this member shows what is left of the force gate's known failure
    // (docs/force.md, "Untouched frames"): with the session-29 drift model its second press
    // (3 N) was absorbed into the baseline during its hold and its lift read as a contact that
    // did not end (51 of 162 untouched frames above 0.5 N). The gate's holds
    // (`force_model::FORCE_GATE`) keep that press out of the baseline; measured 38 of 162 with
    // the placed law (session 31's default here), 18 of 162 with the forward model (session 32),
    // the rest being contacts that have not yet returned (steady below 0.3 of their peak)
    // when the 0.6 s rests end. The 2 % is not met; this pins the figure so a change
    // in either direction is seen.
    eprintln!("{over} of {quiet} untouched frames above 0.5 N");
    assert!(over as f64 <= 0.15 * quiet as f64, "{over} of {quiet} untouched frames above 0.5 N");
    // the same sensor's next session at the same places (the held-out places are
    // examples/force_eval.rs's business)
    let mape = 100.0 * errs.iter().sum::<f64>() / errs.len() as f64;
    eprintln!("MAPE {mape:.1} % above 0.5 N");
    // docs/force.md: the calibrated models do not reach the 10 % the issue asks (here 35.7 %
    // with the session-32 default's forward model; 41.2 % with `placed`, session 31's fallback
    // on this member; 108.2 % with session 31's single-start identification unguarded; 31.4 %
    // with `total` and the gate, 72 % with the session-29 drift model); pinned with a small
    // margin
    assert!(mape < 40.0, "MAPE {mape:.1} % on the same sensor's next session");
    let pressed = (0..f.len()).filter(|&k| test.force[k.saturating_sub(4)] > 2.0);
    let (n, with) = pressed.fold((0, 0), |(n, w), k| (n + 1, w + usize::from(f[k].is_some())));
    // the gate holds a press from 2 σ on, so no press above 2 N goes unreported: measured 1640
    // of 1640 (1472 with the session-29 drift model, 632 with the detector before it)
    eprintln!("a force in {with} of {n} frames pressed above 2 N");
    assert!(with as f64 > 0.95 * n as f64, "a force in {with} of {n} frames pressed above 2 N");
}

#[test]
fn a_gauge_file_matched_by_time_and_clear_refusals() {
    let dir = tempfile::tempdir().unwrap();
    // tuning member 221 (4 presses): one on which the guard below fires with round 10's
    // gain-doubt weighted inversion (examples/force_parts/rule_round10.md); member 1 took that
    // path from session 34 until then, member 701 before
    let rec = ForceSession::presses(221, 4).simulate();
    write_csv(&dir.path().join("cal.csv"), &rec);
    // the gauge on its own clock rows (every other frame), in ms
    let mut g = String::from("time_ms,newtons\n");
    for (k, (f, v)) in rec.frames.iter().zip(&rec.gauge).enumerate().filter(|(k, _)| k % 2 == 0) {
        let _ = k;
        g.push_str(&format!("{},{v}\n", f.time.0 as f64 * 1e-6));
    }
    fs::write(dir.path().join("gauge.csv"), g).unwrap();
    let cal = scene(dir.path(), "cal.toml", "cal.csv", "", "source");
    let model = dir.path().join("f.json");
    let run = |extra: &[&str]| {
        gradtac().args(["calibrate", "force"]).arg(&cal).args(extra).arg("--out").arg(&model).output().unwrap()
    };
    let text = ok(run(&[
        "--force-column",
        "newtons",
        "--force-file",
        dir.path().join("gauge.csv").to_str().unwrap(),
        "--force-time-column",
        "time_ms",
        "--force-time-unit",
        "ms",
    ]));
    // member 221 (4 presses): its forward model predicts the presses held aside worse than the
    // placed law (session 32's guard), so the placed law is written and the CLI says why
    assert!(text.contains("calibrated placed force"), "{text}");
    assert!(
        text.contains("note: the identified forward model predicted the calibration's presses, each held aside"),
        "{text}"
    );
    let file = gradtac::scene::read_force_file(&model).unwrap();
    assert_eq!(file.taxels, 24);
    // a missing column, and an output that is the recording, are refused
    let out = run(&["--force-column", "nope"]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("nope"));
    let out = gradtac()
        .args(["calibrate", "force"])
        .arg(&cal)
        .args(["--force-column", "force_n", "--out"])
        .arg(dir.path().join("cal.csv"))
        .output()
        .unwrap();
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("refusing"));
    // a model file that is not valid names itself
    fs::write(&model, "{\"format\":\"gradtac-force\",\"version\":7}").unwrap();
    let bad = scene(dir.path(), "bad.toml", "cal.csv", "[stages.force]\nmodel = \"f.json\"\n", "force");
    let out = gradtac().arg("explain").arg(&bad).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("f.json"), "{err}");
    // refused by its version (read before the model), not by a field this build does not know
    assert!(err.contains("version 7") && err.contains("newer gradtac"), "{err}");
    // the slip-direction form still answers (with what it needs)
    let out = gradtac().arg("calibrate").output().unwrap();
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("force, baseline, dos"));
}

#[test]
fn calibrate_baseline_and_explain_says_whether_it_fits() {
    let dir = tempfile::tempdir().unwrap();
    let rec = ForceSession::presses(702, 2).simulate();
    write_csv(&dir.path().join("r.csv"), &rec);
    let s = scene(dir.path(), "s.toml", "r.csv", "", "source");
    let tare = dir.path().join("tare.json");
    let text = ok(gradtac()
        .args(["calibrate", "baseline"])
        .arg(&s)
        .args(["--to", "0.9", "--out"])
        .arg(&tare)
        .output()
        .unwrap());
    assert!(text.contains("baseline of sensor ff from 91 untouched frames"), "{text}");
    // a stretch with a press in it is refused
    let out = gradtac()
        .args(["calibrate", "baseline"])
        .arg(&s)
        .args(["--out"])
        .arg(dir.path().join("t2.json"))
        .output()
        .unwrap();
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("not untouched"));
    let with = scene(dir.path(), "w.toml", "r.csv", "[stages.locate]\nbaseline = \"tare.json\"\n", "track");
    let explain = ok(gradtac().arg("explain").arg(&with).output().unwrap());
    assert!(explain.contains("stored tare.json") && explain.contains("fits the recording's first frames"), "{explain}");
    // another sensor's recording does not fit it
    let other = ForceSession::presses(703, 1).simulate();
    write_csv(&dir.path().join("o.csv"), &other);
    let o = scene(dir.path(), "o.toml", "o.csv", "[stages.locate]\nbaseline = \"tare.json\"\n", "track");
    let explain = ok(gradtac().arg("explain").arg(&o).output().unwrap());
    assert!(explain.contains("DOES NOT FIT"), "{explain}");
    let out = ok(gradtac().args(["run", "-q"]).arg(&o).env("GRADTAC_LOG", "warn").output().unwrap());
    assert!(out.contains("no longer fits the sensor"), "{out}");
}

#[test]
fn a_stage_table_the_plan_does_not_run_is_named_with_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let rec = ForceSession::presses(704, 1).simulate();
    write_csv(&dir.path().join("r.csv"), &rec);
    let s = scene(dir.path(), "s.toml", "r.csv", "\n[stages.surface]\ngrid = { nx = 16 }\n", "track");
    let out = gradtac().arg("explain").arg(&s).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stdout.contains("settings not used by this plan") && stdout.contains("s.toml:8: [stages.surface]"),
        "{stdout}"
    );
    assert!(
        stderr.contains("s.toml:8: [stages.surface] is set but not used") && stderr.contains("centroid"),
        "{stderr}"
    );
}

#[test]
fn area_and_amplitude_models_run_through_their_location_chain() {
    let dir = tempfile::tempdir().unwrap();
    let rec = ForceSession::presses(705, 4).simulate();
    write_csv(&dir.path().join("r.csv"), &rec);
    for (method, locate) in [("area", ""), ("amplitude", "[stages.locate]\nmethod = \"fit\"\n")] {
        let cal = scene(dir.path(), &format!("cal_{method}.toml"), "r.csv", locate, "source");
        let model = dir.path().join(format!("{method}.json"));
        let text = ok(gradtac()
            .args(["calibrate", "force"])
            .arg(&cal)
            .args(["--force-column", "force_n", "--method", method, "--out"])
            .arg(&model)
            .output()
            .unwrap());
        assert!(text.contains(&format!("calibrated {method} force")), "{text}");
        let extra = format!("{locate}[stages.force]\nmodel = \"{method}.json\"\n");
        let run = scene(dir.path(), &format!("run_{method}.toml"), "r.csv", &extra, "force");
        let explain = ok(gradtac().arg("explain").arg(&run).output().unwrap());
        assert!(explain.contains("contour area → N"), "{explain}");
        ok(gradtac().args(["run", "-q"]).arg(&run).output().unwrap());
        let f = forces(&dir.path().join(format!("run_{method}.toml.parquet")));
        assert!(f.iter().filter(|x| x.is_some()).count() > 200, "{method}: too few forces");
    }
    // an amplitude model without the fit is refused, naming the file
    let bad = scene(dir.path(), "bad.toml", "r.csv", "[stages.force]\nmodel = \"amplitude.json\"\n", "force");
    let out = gradtac().arg("explain").arg(&bad).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("amplitude.json") && err.contains("method = \"fit\""), "{err}");
}

/// The default method end to end on member 702, a sensor whose identification succeeds: a
/// version-5 `forward` file without a note, the bare scene runs it and `explain` names it, no
/// force before the first press, and the next session read more closely than the placed law.
#[test]
fn the_default_writes_forward_where_the_identification_fits() {
    let dir = tempfile::tempdir().unwrap();
    let rec = ForceSession::presses(702, 6).simulate();
    write_csv(&dir.path().join("cal.csv"), &rec);
    let cal = scene(dir.path(), "cal.toml", "cal.csv", "", "source");
    let test = ForceSession { noise_stream: 9, ..ForceSession::presses(702, 6) }.simulate();
    write_csv(&dir.path().join("test.csv"), &test);
    let mut mapes = Vec::new();
    for method in ["forward", "placed"] {
        let model = dir.path().join(format!("{method}.json"));
        let mut cmd = gradtac();
        cmd.args(["calibrate", "force"]).arg(&cal).args(["--force-column", "force_n"]);
        if method == "placed" {
            cmd.args(["--method", "placed"]);
        }
        let text = ok(cmd.arg("--out").arg(&model).output().unwrap());
        assert!(text.contains(&format!("calibrated {method} force on")) && !text.contains("note:"), "{text}");
        let file = gradtac::scene::read_force_file(&model).unwrap();
        assert_eq!(file.version, if method == "forward" { 5 } else { 3 });
        let body = format!("[stages.force]\nmodel = \"{method}.json\"\n");
        let run = scene(dir.path(), &format!("{method}.toml"), "test.csv", &body, "force");
        if method == "forward" {
            let explain = ok(gradtac().arg("explain").arg(&run).output().unwrap());
            assert!(explain.contains("the identified forward model"), "{explain}");
        }
        ok(gradtac().args(["run", "-q"]).arg(&run).output().unwrap());
        let f = forces(&dir.path().join(format!("{method}.toml.parquet")));
        assert_eq!(f.len(), test.frames.len());
        assert!(f[..100].iter().all(Option::is_none), "a force before the first press");
        mapes.push(mape_above_half_newton(&f, &test.force));
    }
    eprintln!("member 702: forward {:.1} %, placed {:.1} % above 0.5 N on the next session", mapes[0], mapes[1]);
    // measured 4.8 % against 19.1 %; pinned with a margin
    assert!(mapes[0] < 8.0 && mapes[0] < mapes[1], "forward {:.1} % against placed {:.1} %", mapes[0], mapes[1]);
}
