//! Two-finger slip on grasps drawn from the widened family of forward models
//! (`gradtac_stages::sim_grasp`, `GraspFamily::widened`): the default chain of a bare scene
//! (raw frames → slip_pattern → slip) scored on held-out members — whole, by start shape
//! (step / linear / smooth) and by widened property — against the previous default onset
//! estimate (the energy-weighted pattern position; `ramp_hinge`, `linear_cubic`, `weighted`, lead
//! 0.03 s), the linear-weight position (searched, not chosen) and the track-velocity baseline
//! (taxel centroid → track → slip), with the
//! demo's recording (`gradtac demo`) through the same inputs and a held-out variant of the
//! family never used for a choice. It also times every push that decided a slip (the
//! change-point fits run there): p50 / p99 over the held-out members, default and previous.
//!
//! ```text
//! cargo run --release --example slip_eval                # the tables of the slip docs (≈ 30 s)
//! cargo run --release --example slip_eval -- check       # and the CI floors (scripts/slip_eval.sh)
//! cargo run --release --example slip_eval -- trade       # also the decision latency trade
//! cargo run --release --example slip_eval -- tune onset  # the onset search on the tuning seeds
//! cargo run --release --example slip_eval -- tune fingers  # how the fingers' change points combine (stop 31b)
//! cargo run --release --example slip_eval -- tune horizon  # each tuning slip re-dated 0–1 s after its decision
//! cargo run --release --example slip_eval -- onsetdiag   # each tuning slip's signed error and properties
//! cargo run --release --example slip_eval -- onsetdump   # each tuning slip's position histories at its decision
//!                                                        # (input of scripts/onset_probe.rs; DUMP_POSITION=linear:
//!                                                        # the linear-weight position, =fit: the default's
//!                                                        # per-frame model-fit position; DUMP_FIT=1: the model-fit
//!                                                        # locator's positions over the same span instead;
//!                                                        # DUMP_SEEDS=400: seeds 0..400, below the held-out ones;
//!                                                        # DUMP_FROM=400 DUMP_SEEDS=800: seeds 400..800;
//!                                                        # DIAG_NOISE_SCALE / DIAG_LAG_SCALE: diagnostic
//!                                                        # physics, never for a choice)
//! cargo run --release --example slip_eval -- tune        # the (earlier) evidence search
//! cargo run --release --example slip_eval -- tune rule   # then window_s × min_duration_s × dominance
//! DIAG_SEEDS=400 cargo run --release --example slip_eval -- diag  # the tuning members' misses
//! ```
//!
//! `-- diag` lists the defaults' misses on tuning members (seeds `0..DIAG_SEEDS`, default 120;
//! Gaussian / difference-of-Gaussians kernels only, never a held-out seed) with each finger's
//! physics and displacement trace (units of `distance_mm`, every 40 ms around the motion), then
//! their table row; `DIAG_HISTORY`, `DIAG_PERSIST`, `DIAG_SETTLE`, `DIAG_GAP`, `DIAG_FOLLOW`
//! override `history_s`, `min_duration_s`, `settle_s`, `max_gap_s`, `pattern_follow_s` there.
//!
//! Protocol: tuning members are seeds 0..120 × 5 classes of the widened family whose two
//! fingers both draw a Gaussian or difference-of-Gaussians kernel (the exponential kernel is
//! held-out physics); settings are chosen on them only (`onset_lead_s` is the chosen fit's
//! mean signed onset error there). Held-out members are seeds 1000..1100 × 5 classes of the
//! same family (every kernel), reported whole, by start shape, by property and restricted to
//! grasps with an exponential kernel on some finger; the held-out variant
//! (`GraspFamily::held_out_variant`, seeds 2000..2040) is scored only. The demo's recording is
//! from the old simulator: neither a tuning nor a held-out member.

use gradtac::stages::sim_family::KernelShape;
use gradtac::stages::sim_grasp::{
    score, slip_inputs, track_points_per_frame, GraspFamily, GraspMember, GraspRecording, GraspScore, StartShape,
};
use gradtac::stages::slip::{
    OnsetFingers, OnsetModel, OnsetPosition, OnsetStarts, Slip, SlipClass, SlipConfig, SlipEvidence, SlipMethod,
};
use gradtac::stages::track::TrackPoint;

struct Case {
    member: GraspMember,
    exponential: bool,
    truth: gradtac::stages::sim_grasp::GraspTruth,
    rec: GraspRecording,
    /// The track points each frame produced (then the finish's); empty unless asked for (the
    /// default chain reads the raw frames only).
    tracks: Vec<Vec<TrackPoint>>,
}

/// Diagnostics only (stop 32, "what the onset target needs"): `DIAG_NOISE_SCALE` scales every
/// finger's white noise and drift walk, `DIAG_LAG_SCALE` its fluid lag, before simulating. Unset
/// (always, for every figure that chooses or checks anything) they change nothing.
fn diag_physics(g: &mut gradtac::stages::sim_grasp::Grasp) {
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    for f in &mut g.fingers {
        if let Some(x) = env("DIAG_NOISE_SCALE") {
            f.physics.noise_counts *= x;
            f.physics.drift_walk *= x;
        }
        if let Some(x) = env("DIAG_LAG_SCALE") {
            f.physics.lag_s *= x;
        }
    }
}

fn cases(
    seeds: std::ops::Range<u64>,
    family: &GraspFamily,
    with_tracks: bool,
    keep: impl Fn(bool) -> bool + Sync,
) -> Vec<Case> {
    let members = GraspMember::grid(seeds);
    let work = |ms: &[GraspMember]| -> Vec<Case> {
        ms.iter()
            .filter_map(|m| {
                let mut g = m.draw_in(family);
                diag_physics(&mut g);
                let exponential = g.fingers.iter().any(|f| matches!(f.physics.kernel, KernelShape::Exponential));
                if !keep(exponential) {
                    return None;
                }
                let rec = g.simulate();
                let tracks = if with_tracks {
                    track_points_per_frame(&rec.frames).expect("simulated frames are valid")
                } else {
                    vec![]
                };
                Some(Case { member: *m, exponential, truth: rec.truth, rec, tracks })
            })
            .collect()
    };
    let half = members.len() / 2;
    std::thread::scope(|s| {
        let a = s.spawn(|| work(&members[..half]));
        let mut out = work(&members[half..]);
        let mut first = a.join().expect("worker");
        first.append(&mut out);
        first
    })
}

fn events(c: &Case, cfg: &SlipConfig) -> Vec<gradtac::stages::slip::SlipEvent> {
    let input = slip_inputs(&c.rec.frames, &c.tracks, cfg).expect("valid frames");
    Slip::try_new(cfg).expect("valid").run_inputs(input).expect("valid points")
}

fn run(c: &Case, cfg: &SlipConfig) -> GraspScore {
    score(&c.truth, &events(c, cfg))
}

fn pct(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// Per class (right, of), onset errors of the slips right, decisions, false alarms, still time.
struct Summary {
    right: [(usize, usize); 5],
    onset: Vec<f64>,
    signed: Vec<f64>,
    decided: Vec<f64>,
    false_alarms: usize,
    stable_min: f64,
}

fn summarise(scores: &[GraspScore]) -> Summary {
    let mut s = Summary {
        right: [(0, 0); 5],
        onset: vec![],
        signed: vec![],
        decided: vec![],
        false_alarms: 0,
        stable_min: 0.0,
    };
    for r in scores {
        let k = SlipClass::ALL.iter().position(|c| *c == r.truth.class).unwrap();
        s.right[k].1 += 1;
        s.right[k].0 += usize::from(r.right());
        if r.right() && r.truth.class.is_slip() {
            s.onset.push(r.onset_error_s.abs());
            s.signed.push(r.onset_error_s);
            s.decided.push(r.decided_s);
        }
        s.false_alarms += r.false_alarms;
        s.stable_min += r.still_s / 60.0;
    }
    s
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

impl Summary {
    fn all(&self) -> (usize, usize) {
        self.right.iter().fold((0, 0), |a, r| (a.0 + r.0, a.1 + r.1))
    }
    fn worst_class(&self) -> f64 {
        self.right.iter().map(|r| r.0 as f64 / r.1.max(1) as f64).fold(1.0, f64::min)
    }
    fn row(&mut self, label: &str) -> String {
        let cls: Vec<String> = self.right.iter().map(|r| format!("{}/{}", r.0, r.1)).collect();
        let (a, n) = self.all();
        format!(
            "| {label} | {} | {a}/{n} ({:.1} %) | {:.0} | {:+.0} | {:.0} | {:.0} | {:.2} |",
            cls.join(" | "),
            100.0 * a as f64 / n.max(1) as f64,
            1e3 * pct(&mut self.onset, 0.5),
            1e3 * mean(&self.signed),
            1e3 * pct(&mut self.onset, 0.9),
            1e3 * pct(&mut self.decided, 0.5),
            self.false_alarms as f64 / self.stable_min.max(1e-9),
        )
    }
}

const HEADER: &str = "| | stable | long. up | long. down | rot. cw | rot. ccw | all right | onset \\|err\\| median (ms) | mean signed (ms) | \\|err\\| p90 (ms) | decided after onset, median (ms) | false alarms / min still |\n|---|---|---|---|---|---|---|---|---|---|---|---|";

/// The demo's recording (`gradtac demo`: another simulator, neither a tuning nor a held-out
/// member) as frames in the order the demo's scene runs them (ties by the scene's sensor
/// order, `gradtac::demo::frames_in_scene_order`: the slip onset depends on it), with the
/// track points each frame makes.
fn demo_frames() -> (Vec<gradtac::stream::TaxelFrame>, Vec<Vec<TrackPoint>>) {
    let rec = gradtac::demo::simulate(gradtac::demo::DEMO_SEED).expect("demo simulates");
    let frames = gradtac::demo::frames_in_scene_order(&rec);
    let tracks = track_points_per_frame(&frames).expect("valid");
    (frames, tracks)
}

/// The first slip event's class and onset error (s) on the demo's recording under `cfg`.
fn demo_onset(
    demo: &(Vec<gradtac::stream::TaxelFrame>, Vec<Vec<TrackPoint>>),
    cfg: &SlipConfig,
) -> (Option<&'static str>, f64) {
    let input = slip_inputs(&demo.0, &demo.1, cfg).expect("valid");
    let ev = Slip::try_new(cfg).expect("valid").run_inputs(input).expect("ok");
    match ev.iter().find(|e| e.class.is_slip()) {
        Some(e) => (Some(e.class.name()), e.onset.as_secs_f64() - gradtac::stages::sim::GraspConfig::default().onset_s),
        None => (None, f64::NAN),
    }
}

/// The bound #15 put on the demo's printed onset error (s). Reported, no longer a gate (stop
/// 31): the demo is one grasp of another simulator, and ±40 ms on one grasp is well inside the
/// per-grasp spread of the onset error (held-out p90 ≈ 120 ms), so as a filter it chose on
/// noise; and the onset default chosen on the tuning members by the issue's own criteria
/// (per start shape) prints −0.051 s (stop 31) and −0.080 s (stop 31b), outside it. The searches keep the demo's **class** as a
/// gate (a setting that gets the demo's slip wrong is not chosen) and print its onset error
/// with `within ±0.040 s: yes/no`.
const DEMO_ONSET_BOUND_S: f64 = 0.040;

/// `yes` when the demo's onset error is within [`DEMO_ONSET_BOUND_S`].
fn demo_close(d: (Option<&'static str>, f64)) -> &'static str {
    if d.1.abs() <= DEMO_ONSET_BOUND_S + 1e-9 {
        "yes"
    } else {
        "no"
    }
}

/// Tuning seeds `0..TUNING_SEEDS` (Gaussian / difference-of-Gaussians kernels on both fingers).
const TUNING_SEEDS: u64 = 120;

fn main() {
    let demo = demo_frames();
    let tune = std::env::args().any(|a| a == "tune");
    let t = std::time::Instant::now();
    let tuning = cases(0..TUNING_SEEDS, &GraspFamily::widened(), false, |exp| !exp);
    eprintln!("{} tuning grasps simulated in {:.1?}", tuning.len(), t.elapsed());
    if std::env::args().any(|a| a == "diag") {
        // the tuning members' failures under the defaults, with each finger's displacement
        // (units of distance_mm) around the decision
        let n: u64 = std::env::var("DIAG_SEEDS").ok().and_then(|s| s.parse().ok()).unwrap_or(TUNING_SEEDS);
        let tuning = if n == TUNING_SEEDS { tuning } else { cases(0..n, &GraspFamily::widened(), false, |exp| !exp) };
        let env = |k: &str, d: f64| std::env::var(k).ok().and_then(|v| v.parse().ok()).unwrap_or(d);
        let d0 = SlipConfig::default();
        let def = SlipConfig {
            pattern_follow_s: env("DIAG_FOLLOW", d0.pattern_follow_s),
            max_gap_s: env("DIAG_GAP", d0.max_gap_s),
            settle_s: env("DIAG_SETTLE", d0.settle_s),
            min_duration_s: env("DIAG_PERSIST", d0.min_duration_s),
            history_s: env("DIAG_HISTORY", d0.history_s),
            ..d0
        };
        let mut sc = Vec::new();
        for c in &tuning {
            let r = run(c, &def);
            sc.push(r);
            if r.right() {
                continue;
            }
            let ev = events(c, &def);
            println!(
                "seed {} {:>17} onset {:.2} end {:.2} speed {:.1} ramp {:.2} lag {:.3}/{:.3}: got {:?} FA {} {:?}",
                c.member.seed,
                c.truth.class.name(),
                c.truth.onset_s,
                c.truth.end_s,
                c.truth.speed_mm_s,
                c.truth.ramp_s,
                c.rec.grasp.fingers[0].physics.lag_s,
                c.rec.grasp.fingers[1].physics.lag_s,
                r.detected.map(|d| d.name()),
                r.false_alarms,
                ev.iter().map(|e| (e.class.name(), (e.time.as_secs_f64() * 100.0).round() / 100.0)).collect::<Vec<_>>()
            );
            for f in &c.rec.grasp.fingers {
                let ph = &f.physics;
                println!(
                    "   {} move {:+.2},{:+.2} mm from {:.1},{:.1} kernel {:?} width {:.2} amp·F {:.1} knee {:.0} noise {:.1}",
                    f.sensor, f.to[0] - f.from[0], f.to[1] - f.from[1], f.from[0], f.from[1],
                    ph.kernel, ph.width_mm, ph.amplitude * ph.force_n, ph.knee_counts, ph.noise_counts
                );
            }
            let input = slip_inputs(&c.rec.frames, &c.tracks, &def).expect("valid");
            let mut s = Slip::try_new(&def).expect("valid");
            let mut out = Vec::new();
            let mut line = String::new();
            let mut last_k = -1;
            for i in input {
                let t = gradtac::stream::Timed::time(&i).as_secs_f64();
                s.push_input(i, &mut out).expect("ok");
                let k = (t * 100.0).round() as i64;
                if k % 4 == 0 && k != last_k && t > c.truth.onset_s - 0.3 && t < c.truth.end_s + 0.3 {
                    last_k = k;
                    if let Some((a, b)) = s.displacements() {
                        line.push_str(&format!(" {:.2}:{:+.2}/{:+.2}", t, a, b));
                    }
                }
            }
            println!("   {line}");
        }
        println!("{}", HEADER);
        println!("{}", summarise(&sc).row("default, tuning"));
        return;
    }
    if std::env::args().any(|a| a == "onsetdiag") {
        for (model, fingers) in
            [(OnsetModel::Hinge, OnsetFingers::Mean), (OnsetModel::RampHinge, OnsetFingers::Earliest)]
        {
            let cfg =
                SlipConfig { onset_model: model, onset_fingers: fingers, onset_lead_s: 0.0, ..Default::default() };
            for c in &tuning {
                let r = run(c, &cfg);
                if r.right() && c.truth.class.is_slip() {
                    let t = &c.truth;
                    println!(
                        "{} {} {:>6} r {:.2} grip {:.2} load {:.1} lag {:.2} v {:5.1} err {:+.3} decided {:.3} flag {:.3}/{:.3}",
                        model.name(),
                        c.member.seed,
                        t.start.name(),
                        t.ramp_s,
                        t.grip_start,
                        t.load_rise,
                        t.finger_lag_s,
                        t.speed_mm_s,
                        r.onset_error_s,
                        r.decided_s,
                        c.rec.grasp.fingers[0].physics.lag_s,
                        c.rec.grasp.fingers[1].physics.lag_s,
                    );
                }
            }
        }
        return;
    }
    if std::env::args().any(|a| a == "onsetdump") {
        // every tuning slip's position histories at its first slip decision (default settings,
        // no lead), with the truth: the data the onset estimator is designed on
        // (tuning members only: the held-out ones are never looked at for a choice)
        // DUMP_SEEDS: more tuning-side seeds (0..n; never the held-out 1000..1100), as `diag`
        let n: u64 = std::env::var("DUMP_SEEDS").ok().and_then(|s| s.parse().ok()).unwrap_or(TUNING_SEEDS);
        // DUMP_FROM: the first seed (default 0)
        let from: u64 = std::env::var("DUMP_FROM").ok().and_then(|s| s.parse().ok()).unwrap_or(0);
        let set = if n == TUNING_SEEDS && from == 0 {
            tuning
        } else {
            cases(from.min(n)..n.min(1000), &GraspFamily::widened(), false, |exp| !exp)
        };
        let onset_position = match std::env::var("DUMP_POSITION").as_deref() {
            Ok("linear") => OnsetPosition::Linear,
            Ok("fit") => OnsetPosition::Fit,
            _ => OnsetPosition::Energy,
        };
        let cfg = SlipConfig { onset_lead_s: 0.0, onset_position, ..Default::default() };
        for c in set.iter().filter(|c| c.truth.class.is_slip()) {
            let r = run(c, &cfg);
            let input = slip_inputs(&c.rec.frames, &c.tracks, &cfg).expect("valid");
            let mut s = Slip::try_new(&cfg).expect("valid");
            let mut out = Vec::new();
            for i in input {
                s.push_input(i, &mut out).expect("ok");
                if let Some(e) = out.iter().find(|e| e.class.is_slip() && e.time.as_secs_f64() >= c.truth.onset_s) {
                    let t = &c.truth;
                    let g = &c.rec.grasp;
                    println!(
                        "G {} {} {} {} {:.4} {:.3} {:.3} {:.4} {:.3} {:.5} {:.5} {:.5} {:.5} {:.5} {:.4} {:.4} {}",
                        c.member.seed,
                        t.class.name(),
                        u8::from(r.right()),
                        t.start.name(),
                        t.ramp_s,
                        t.grip_start,
                        t.load_rise,
                        t.finger_lag_s,
                        t.speed_mm_s,
                        t.onset_s,
                        g.fingers[0].onset_s,
                        g.fingers[1].onset_s,
                        e.time.as_secs_f64(),
                        e.onset.as_secs_f64(),
                        g.fingers[0].physics.lag_s,
                        g.fingers[1].physics.lag_s,
                        e.class.name(),
                    );
                    for (k, h) in s.position_histories().iter().enumerate() {
                        if let Some((m, h)) = h {
                            let pts: Vec<String> = match std::env::var("DUMP_FIT").is_ok() {
                                true => fit_history(c, k, h.first().map_or(0, |p| p.0), h.last().map_or(0, |p| p.0)),
                                false => h.iter().map(|p| format!("{:.4}:{:.4}", p.0 as f64 * 1e-9, p.1)).collect(),
                            };
                            println!("H {k} {m:.3} {}", pts.join(" "));
                        }
                    }
                    break;
                }
            }
        }
        return;
    }
    if tune && std::env::args().any(|a| a == "horizon") {
        tune_horizon(&tuning);
        return;
    }
    if tune && std::env::args().any(|a| a == "fingers") {
        tune_fingers(&tuning, &demo);
        return;
    }
    if tune && std::env::args().any(|a| a == "onset") {
        tune_onset(&tuning, &demo);
        return;
    }
    if tune {
        // the search: where each finger's position comes from and the pattern's contact test,
        // with the displacement threshold; the other settings at the defaults chosen before
        let mut grid = Vec::new();
        if std::env::args().any(|a| a == "rule") {
            // second stage: the rule's own settings on the chosen evidence
            for window_s in [0.2, 0.3, 0.4] {
                for min_duration_s in [0.05, 0.1, 0.2] {
                    for dominance in [1.25, 1.5, 2.0] {
                        grid.push(SlipConfig { window_s, min_duration_s, dominance, ..Default::default() });
                    }
                }
            }
        }
        for distance_mm in [0.8, 1.0, 1.5, 2.0, 2.5].into_iter().filter(|_| !std::env::args().any(|a| a == "rule")) {
            grid.push(SlipConfig { evidence: SlipEvidence::Track, distance_mm, ..Default::default() });
            for evidence in [SlipEvidence::Pattern, SlipEvidence::Both] {
                for pattern_contact_sigmas in [3.0, 4.0, 6.0, 12.0] {
                    for pattern_floor_sigmas in [0.0, 1.0, 2.0] {
                        for pattern_window_frames in [3, 5] {
                            grid.push(SlipConfig {
                                evidence,
                                distance_mm,
                                pattern_contact_sigmas,
                                pattern_floor_sigmas,
                                pattern_window_frames,
                                ..Default::default()
                            });
                        }
                    }
                }
            }
        }
        let mut rows = Vec::new();
        for cfg in grid {
            let cfg = SlipConfig { onset_lead_s: 0.0, ..cfg };
            let scores: Vec<GraspScore> = tuning.iter().map(|c| run(c, &cfg)).collect();
            let mut signed: Vec<f64> =
                scores.iter().filter(|r| r.right() && r.truth.class.is_slip()).map(|r| r.onset_error_s).collect();
            let bias = pct(&mut signed, 0.5);
            let cfg = SlipConfig { onset_lead_s: (bias.max(0.0) * 100.0).round() / 100.0, ..cfg };
            let scores: Vec<GraspScore> = tuning.iter().map(|c| run(c, &cfg)).collect();
            let mut s = summarise(&scores);
            let (a, n) = s.all();
            let med = pct(&mut s.onset, 0.5);
            let d = demo_onset(&demo, &cfg);
            let demo_ok = d.0 == Some(gradtac::demo::DEMO_SLIP.name());
            rows.push((s.false_alarms, a, n, med, s.worst_class(), cfg, d, demo_ok));
        }
        rows.sort_by(|x, y| y.7.cmp(&x.7).then(x.0.cmp(&y.0)).then(y.1.cmp(&x.1)).then(x.3.total_cmp(&y.3)));
        println!(
            "tuning ({} grasps), ranked by: the demo's class right (its onset error is printed, not a gate), \
             then false alarms, then grasps right, then median onset error",
            tuning.len()
        );
        let first_of = |e: SlipEvidence| rows.iter().position(|r| r.5.evidence == e);
        for e in [SlipEvidence::Track, SlipEvidence::Pattern, SlipEvidence::Both] {
            if let Some(i) = first_of(e) {
                let r = &rows[i];
                println!(
                    "best {}: rank {} — FA {} right {}/{} med {:.0} ms, dist {}, demo {:+.3} s (within ±{DEMO_ONSET_BOUND_S} s: {})",
                    e.name(),
                    i + 1,
                    r.0,
                    r.1,
                    r.2,
                    r.3 * 1e3,
                    r.5.distance_mm,
                    r.6 .1,
                    demo_close(r.6)
                );
            }
        }
        for r in rows.iter().take(40) {
            let c = &r.5;
            let demo = r.6;
            println!(
                "FA {} right {}/{} worst {:.3} med {:.0} ms | {} dist {} contact {} floor {} frames {} window {} persist {} dominance {} lead {:.2} | demo {:?} {:+.3} s",
                r.0,
                r.1,
                r.2,
                r.4,
                r.3 * 1e3,
                c.evidence.name(),
                c.distance_mm,
                c.pattern_contact_sigmas,
                c.pattern_floor_sigmas,
                c.pattern_window_frames,
                c.window_s,
                c.min_duration_s,
                c.dominance,
                c.onset_lead_s,
                demo.0,
                demo.1
            );
        }
        return;
    }
    let held = cases(HELD_OUT, &GraspFamily::widened(), true, |_| true);
    let variant = cases(VARIANT, &GraspFamily::held_out_variant(), false, |_| true);
    eprintln!("{} held-out grasps, {} variant grasps simulated in {:.1?}", held.len(), variant.len(), t.elapsed());
    let def = SlipConfig::default();
    let before = previous_onset();
    let d = demo_onset(&demo, &def);
    println!(
        "demo recording (`gradtac demo`), default: {:?} onset error {:+.3} s (within ±{DEMO_ONSET_BOUND_S} s: {})",
        d.0,
        d.1,
        demo_close(d)
    );
    let d = demo_onset(&demo, &before);
    println!(
        "demo recording, previous default (energy position, ramp_hinge, linear_cubic, weighted, lead 0.03 s): {:?} onset error {:+.3} s\n",
        d.0, d.1
    );
    for (label, cfg) in [("default", &def), ("previous default", &before)] {
        let (p50, p99, n) = decide_cost(&held, cfg);
        println!("slip-deciding pushes, {label}: p50 {p50:.1} µs, p99 {p99:.1} µs ({n} decisions, held-out members)");
        let (p50, p99, n) = pattern_cost(&held, cfg);
        println!(
            "slip_pattern pushes, {label}: p50 {p50:.2} µs, p99 {p99:.2} µs per frame ({n} frames, held-out members)"
        );
    }
    println!();
    let base = SlipConfig { method: SlipMethod::Velocity, min_duration_s: 0.08, ..Default::default() };
    // the onset fit on the linear-weight pattern position (the search's best row with it on the
    // tuning members; not chosen: scored here as a record, the decisions are the default's)
    let linear = SlipConfig {
        onset_position: OnsetPosition::Linear,
        onset_model: OnsetModel::Hinge,
        onset_starts: OnsetStarts::Linear,
        onset_fingers: OnsetFingers::Weighted,
        onset_lead_s: 0.025,
        ..Default::default()
    };
    // stop 31's default: the fingers' change points weighted by fit clarity, lead 0.025 s
    let weighted = SlipConfig { onset_fingers: OnsetFingers::Weighted, onset_lead_s: 0.025, ..def.clone() };
    let configs = [
        ("displacement (default)", &def),
        ("displacement, stop 31 default (weighted fingers)", &weighted),
        ("displacement, previous default (energy position)", &before),
        ("displacement, linear-weight onset position (not chosen)", &linear),
        ("track velocity (baseline)", &base),
    ];
    let runs: Vec<Vec<GraspScore>> =
        configs.iter().map(|(_, cfg)| held.iter().map(|c| run(c, cfg)).collect()).collect();
    let sel = |k: usize, f: &dyn Fn(&Case) -> bool| -> Vec<GraspScore> {
        held.iter().zip(&runs[k]).filter(|(c, _)| f(c)).map(|(_, r)| *r).collect()
    };
    println!(
        "## Held-out members (seeds {}..{} × 5 classes, widened family, every kernel), bare default scene\n",
        HELD_OUT.start, HELD_OUT.end
    );
    println!("{HEADER}");
    for (k, (label, cfg)) in configs.iter().enumerate() {
        println!("{}", summarise(&runs[k]).row(&format!("{label}, all")));
        println!(
            "{}",
            summarise(&sel(k, &|c| c.exponential)).row(&format!("{label}, exponential kernel (held-out physics)"))
        );
        if k < 4 {
            let tun: Vec<GraspScore> = tuning.iter().map(|c| run(c, cfg)).collect();
            println!("{}", summarise(&tun).row(&format!("{label}, tuning members (in-sample)")));
        }
    }
    println!("\n## By start shape (held-out; each row: the slips of that shape and all stable grasps)\n");
    println!("{HEADER}");
    for (k, (label, _)) in configs.iter().enumerate() {
        for shape in StartShape::FAMILY {
            let sc = sel(k, &|c| !c.truth.class.is_slip() || c.truth.start == shape);
            println!("{}", summarise(&sc).row(&format!("{label}, {} start", shape.name())));
        }
    }
    println!("\n## By widened property (held-out, default, stop 31 default, previous default, linear-weight onset position; slips with the property + all stable)\n");
    println!("{HEADER}");
    type Prop = (&'static str, fn(&Case) -> bool);
    let props: [Prop; 5] = [
        ("grip still ramping at the onset", |c| c.truth.grip_start != 1.0),
        ("load rising while slipping", |c| c.truth.load_rise > 0.0),
        ("one finger first", |c| c.truth.finger_lag_s > 0.0),
        ("none of the three", |c| c.truth.grip_start == 1.0 && c.truth.load_rise == 0.0 && c.truth.finger_lag_s == 0.0),
        ("slower than 4 mm/s", |c| c.truth.speed_mm_s < 4.0),
    ];
    for (k, (label, _)) in configs.iter().enumerate().take(4) {
        for (name, f) in &props {
            let sc = sel(k, &|c| !c.truth.class.is_slip() || f(c));
            println!("{}", summarise(&sc).row(&format!("{label}, {name}")));
        }
    }
    println!(
        "\n## Held-out variant (seeds {}..{} × 5 classes, `GraspFamily::held_out_variant`: exponential starts, wider ramps and lags; never used for a choice)\n",
        VARIANT.start, VARIANT.end
    );
    println!("{HEADER}");
    for (label, cfg) in &configs[..4] {
        let sc: Vec<GraspScore> = variant.iter().map(|c| run(c, cfg)).collect();
        println!("{}", summarise(&sc).row(&format!("{label}, exponential start")));
    }
    if std::env::args().any(|a| a == "trade") {
        println!("\n## Decision latency trade (held-out; window_s × min_duration_s, other settings default)\n");
        println!("{HEADER}");
        for window_s in [0.2, 0.3, 0.4, 0.6] {
            for min_duration_s in [0.0, 0.05, 0.1, 0.2] {
                let cfg = SlipConfig { window_s, min_duration_s, ..def.clone() };
                let sc: Vec<GraspScore> = held.iter().map(|c| run(c, &cfg)).collect();
                println!("{}", summarise(&sc).row(&format!("window {window_s} s, persist {min_duration_s} s")));
            }
        }
    }
    if std::env::args().any(|a| a == "check") {
        check_floors(&held, &runs[0], &demo, &def);
    }
    println!("\nfailures (held-out, default):");
    for (c, r) in held.iter().zip(&runs[0]) {
        if !r.right() {
            println!(
                "  seed {} {:>17} onset {:.2}: got {:?}, FA {} {:?}, speed {:.1} mm/s, {} start {:.2} s, exp {}",
                c.member.seed,
                c.truth.class.name(),
                c.truth.onset_s,
                r.detected.map(|d| d.name()),
                r.false_alarms,
                events(c, &def)
                    .iter()
                    .map(|e| (e.class.name(), (e.time.as_secs_f64() * 100.0).round() / 100.0))
                    .collect::<Vec<_>>(),
                c.truth.speed_mm_s,
                c.truth.start.name(),
                c.truth.ramp_s,
                c.exponential
            );
        }
    }
}

/// `-- check` (CI, `scripts/slip_eval.sh`): the default's held-out figures against floors a
/// little below the measured ones (the simulator is deterministic; measured at stop 31b:
/// 491/500 right, 0.27 false alarms / min, median 45 ms, per shape 44–48 ms and −33 … +22 ms
/// mean; demo −0.080 s), and
/// the demo's slip class right, its onset error, and the same events in the simulator's and
/// the scene's frame order. Exits 1 naming every floor missed.
fn check_floors(
    held: &[Case],
    scores: &[GraspScore],
    demo: &(Vec<gradtac::stream::TaxelFrame>, Vec<Vec<TrackPoint>>),
    def: &SlipConfig,
) {
    let mut bad = Vec::new();
    let mut all = summarise(scores);
    let (a, n) = all.all();
    let fa = all.false_alarms as f64 / all.stable_min.max(1e-9);
    let med = pct(&mut all.onset, 0.5);
    println!("\ncheck: {a}/{n} right, {fa:.2} false alarms / min, median |onset error| {:.0} ms", med * 1e3);
    if a < 489 || n != 500 {
        bad.push(format!("{a}/{n} right (floor 489/500)"));
    }
    if fa > 0.35 {
        bad.push(format!("{fa:.2} false alarms / min (floor 0.35)"));
    }
    if med > 0.048 {
        bad.push(format!("median |onset error| {:.0} ms (floor 48)", med * 1e3));
    }
    for shape in StartShape::FAMILY {
        let sc: Vec<GraspScore> = held
            .iter()
            .zip(scores)
            .filter(|(c, _)| c.truth.class.is_slip() && c.truth.start == shape)
            .map(|(_, r)| *r)
            .collect();
        let mut s = summarise(&sc);
        let (m, mn) = (pct(&mut s.onset, 0.5), mean(&s.signed));
        println!("check: {} start median {:.0} ms, mean signed {:+.0} ms", shape.name(), m * 1e3, mn * 1e3);
        if m > 0.050 || mn.abs() > 0.035 {
            bad.push(format!("{} start {:.0} / {:+.0} ms (floors 50 ms, ±35 ms)", shape.name(), m * 1e3, mn * 1e3));
        }
    }
    let d = demo_onset(demo, def);
    println!("check: demo {:?} onset error {:+.3} s", d.0, d.1);
    if d.0 != Some(gradtac::demo::DEMO_SLIP.name()) || d.1.is_nan() || d.1.abs() > 0.090 {
        bad.push(format!(
            "demo {:?} {:+.3} s (class {}, |onset error| ≤ 0.090 s)",
            d.0,
            d.1,
            gradtac::demo::DEMO_SLIP.name()
        ));
    }
    // the simulator's own order (thumb first at each time step): the same events
    let rec = gradtac::demo::simulate(gradtac::demo::DEMO_SEED).expect("demo simulates");
    let sim_order: Vec<gradtac::stream::TaxelFrame> = rec.frames.iter().map(|f| f.frame.clone()).collect();
    let tracks = track_points_per_frame(&sim_order).expect("valid");
    let events_in = |frames: &[gradtac::stream::TaxelFrame], tracks: &[Vec<TrackPoint>]| {
        Slip::try_new(def).expect("valid").run_inputs(slip_inputs(frames, tracks, def).expect("valid")).expect("ok")
    };
    if events_in(&sim_order, &tracks) != events_in(&demo.0, &demo.1) {
        bad.push("the demo's slip events depend on the order of same-time frames".into());
    }
    if bad.is_empty() {
        println!("check: every floor holds");
    } else {
        for b in &bad {
            eprintln!("slip_eval check FAILED: {b}");
        }
        std::process::exit(1);
    }
}

/// Held-out members of the widened family (every kernel).
const HELD_OUT: std::ops::Range<u64> = 1000..1100;
/// Held-out variant members ([`GraspFamily::held_out_variant`]).
const VARIANT: std::ops::Range<u64> = 2000..2040;

/// The previous default onset estimate (the last session's, chosen on the same tuning members):
/// the energy-weighted pattern position, a drifting-then-moving hinge with linear and cubic
/// starts, the fingers weighted by fit clarity, lead 0.03 s (everything else default).
fn previous_onset() -> SlipConfig {
    SlipConfig {
        onset_position: OnsetPosition::Energy,
        onset_model: OnsetModel::RampHinge,
        onset_fingers: OnsetFingers::Weighted,
        onset_starts: OnsetStarts::LinearCubic,
        onset_lead_s: 0.03,
        ..Default::default()
    }
}

/// The wall time (µs) of every push that decided a slip (the change-point fits run there), over
/// `cases`: `(p50, p99, count)`. One thread; on a loaded machine the tail is the machine's.
fn decide_cost(cases: &[Case], cfg: &SlipConfig) -> (f64, f64, usize) {
    let mut us = Vec::new();
    for c in cases {
        let input = slip_inputs(&c.rec.frames, &c.tracks, cfg).expect("valid");
        let mut s = Slip::try_new(cfg).expect("valid");
        let mut out = Vec::new();
        for i in input {
            let n = out.len();
            let t = std::time::Instant::now();
            s.push_input(i, &mut out).expect("ok");
            let dt = t.elapsed();
            if out.len() > n && out[n].class.is_slip() {
                us.push(dt.as_secs_f64() * 1e6);
            }
        }
    }
    let n = us.len();
    (pct(&mut us, 0.5), pct(&mut us, 0.99), n)
}

/// The wall time (µs) of every raw frame pushed through the pattern stage (the onset position's
/// model fits run there with `onset_position = "fit"`), over `cases`: `(p50, p99, count)`.
fn pattern_cost(cases: &[Case], cfg: &SlipConfig) -> (f64, f64, usize) {
    use gradtac::stages::slip_pattern::SlipPattern;
    let layout = gradtac::stream::Layout::biotac_sp();
    let mut us = Vec::new();
    let mut out = Vec::new();
    for c in cases {
        let mut s = SlipPattern::try_new(cfg, [&layout, &layout]).expect("valid");
        for f in &c.rec.frames {
            out.clear();
            let t = std::time::Instant::now();
            s.push_frame(f, &mut out).expect("ok");
            us.push(t.elapsed().as_secs_f64() * 1e6);
        }
    }
    let n = us.len();
    (pct(&mut us, 0.5), pct(&mut us, 0.99), n)
}

/// The onset estimate's search on the tuning members only: model × finger combination, each
/// with `onset_lead_s` = its mean signed onset error on the tuning members without a lead
/// (to 0.005 s); ranked by the worst start shape's median |error| after the correction, then
/// the worst start shape's |mean signed error|. The decisions (class, false alarms) do not
/// depend on these settings: only the onset's dating does.
fn tune_onset(tuning: &[Case], demo: &(Vec<gradtac::stream::TaxelFrame>, Vec<Vec<TrackPoint>>)) {
    let mut rows = Vec::new();
    // the fit position with and without its fluid-lag estimate (stop 31)
    let positions = [
        (OnsetPosition::Energy, false),
        (OnsetPosition::Linear, false),
        (OnsetPosition::Fit, false),
        (OnsetPosition::Fit, true),
    ];
    for ((onset_position, onset_fit_lag), (onset_model, onset_fingers, onset_starts)) in
        positions.into_iter().flat_map(|p| {
            [OnsetModel::Hinge, OnsetModel::RampHinge]
                .into_iter()
                .flat_map(|m| [OnsetFingers::Mean, OnsetFingers::Earliest, OnsetFingers::Weighted].map(|f| (m, f)))
                .flat_map(|(m, f)| {
                    [OnsetStarts::Linear, OnsetStarts::LinearSmooth, OnsetStarts::LinearCubic].map(|s| (m, f, s))
                })
                .map(move |x| (p, x))
        })
    {
        {
            let cfg = SlipConfig {
                onset_model,
                onset_fingers,
                onset_starts,
                onset_position,
                onset_fit_lag,
                onset_lead_s: 0.0,
                ..Default::default()
            };
            let scores: Vec<GraspScore> = tuning.iter().map(|c| run(c, &cfg)).collect();
            let signed: Vec<f64> =
                scores.iter().filter(|r| r.right() && r.truth.class.is_slip()).map(|r| r.onset_error_s).collect();
            let lead = (mean(&signed) * 200.0).round() / 200.0;
            let cfg = SlipConfig { onset_lead_s: lead, ..cfg };
            let mut worst_med: f64 = 0.0;
            let mut worst_mean: f64 = 0.0;
            let mut per = String::new();
            for shape in StartShape::FAMILY {
                let sc: Vec<GraspScore> = tuning
                    .iter()
                    .zip(&scores)
                    .filter(|(c, _)| c.truth.class.is_slip() && c.truth.start == shape)
                    .map(|(_, r)| GraspScore { onset_error_s: r.onset_error_s - lead, ..*r })
                    .collect();
                let mut s = summarise(&sc);
                let (med, mn) = (pct(&mut s.onset, 0.5), mean(&s.signed));
                worst_med = worst_med.max(med);
                worst_mean = worst_mean.max(mn.abs());
                per.push_str(&format!(" {} {:.0}/{:+.0}", shape.name(), med * 1e3, mn * 1e3));
            }
            let d = demo_onset(demo, &cfg);
            rows.push((worst_med, worst_mean, cfg, per, d));
        }
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    println!(
        "onset search on {} tuning grasps (ranked by the worst start shape's median |error|, then |mean signed|)",
        tuning.len()
    );
    for (med, mn, cfg, per, d) in rows {
        println!(
            "worst median {:.0} ms, worst |mean| {:.0} ms | {}{} {} {} {} lead {:+.3} | per shape median/mean (ms):{} | demo {:?} {:+.3} s",
            med * 1e3,
            mn * 1e3,
            cfg.onset_position.name(),
            if cfg.onset_fit_lag { "+lag" } else { "" },
            cfg.onset_model.name(),
            cfg.onset_starts.name(),
            cfg.onset_fingers.name(),
            cfg.onset_lead_s,
            per,
            d.0,
            d.1
        );
    }
}

/// How the fingers' change points combine (`onset_fingers`, stop 31b), on the tuning members
/// only, the other onset settings at the defaults: `mean`, `earliest`, `weighted` and
/// `clear_earliest` with gates 0.1–1, each with its own lead (its tuning mean signed error
/// without one, to 5 ms); and `clear_earliest` gate 0.5 under the other starts and models
/// (the joint check). Rule stated before the run (round 3's): ranked by the worst start
/// shape's median |error|, then its |mean signed|; a rule other than the default is adopted
/// only if it ranks first. The one-finger-first slice (`finger_lag_s > 0`) and the demo are
/// printed, not ranked on.
fn tune_fingers(tuning: &[Case], demo: &(Vec<gradtac::stream::TaxelFrame>, Vec<Vec<TrackPoint>>)) {
    let d = SlipConfig::default();
    let mut grid: Vec<SlipConfig> = [OnsetFingers::Mean, OnsetFingers::Earliest, OnsetFingers::Weighted]
        .into_iter()
        .map(|onset_fingers| SlipConfig { onset_fingers, ..d.clone() })
        .collect();
    for onset_finger_gate in [0.1, 0.2, 0.35, 0.5, 0.75, 1.0] {
        grid.push(SlipConfig { onset_fingers: OnsetFingers::ClearEarliest, onset_finger_gate, ..d.clone() });
    }
    for (onset_model, onset_starts) in [
        (OnsetModel::Hinge, OnsetStarts::LinearCubic),
        (OnsetModel::RampHinge, OnsetStarts::LinearSmooth),
        (OnsetModel::RampHinge, OnsetStarts::Linear),
    ] {
        for onset_fingers in [OnsetFingers::Weighted, OnsetFingers::ClearEarliest] {
            // gate 0.5: the default when the rule was run (the run is reproduced as it was)
            grid.push(SlipConfig { onset_fingers, onset_model, onset_starts, onset_finger_gate: 0.5, ..d.clone() });
        }
    }
    let mut rows = Vec::new();
    for cfg in grid {
        let cfg = SlipConfig { onset_lead_s: 0.0, ..cfg };
        let scores: Vec<GraspScore> = tuning.iter().map(|c| run(c, &cfg)).collect();
        let signed: Vec<f64> =
            scores.iter().filter(|r| r.right() && r.truth.class.is_slip()).map(|r| r.onset_error_s).collect();
        let lead = (mean(&signed) * 200.0).round() / 200.0;
        let cfg = SlipConfig { onset_lead_s: lead, ..cfg };
        let slice = |keep: &dyn Fn(&Case) -> bool| {
            let sc: Vec<GraspScore> = tuning
                .iter()
                .zip(&scores)
                .filter(|(c, _)| c.truth.class.is_slip() && keep(c))
                .map(|(_, r)| GraspScore { onset_error_s: r.onset_error_s - lead, ..*r })
                .collect();
            let mut s = summarise(&sc);
            (pct(&mut s.onset, 0.5), mean(&s.signed))
        };
        let (mut worst_med, mut worst_mean) = (0.0f64, 0.0f64);
        let mut per = String::new();
        for shape in StartShape::FAMILY {
            let (med, mn) = slice(&|c: &Case| c.truth.start == shape);
            worst_med = worst_med.max(med);
            worst_mean = worst_mean.max(mn.abs());
            per.push_str(&format!(" {} {:.0}/{:+.0}", shape.name(), med * 1e3, mn * 1e3));
        }
        let (fm, fs) = slice(&|c: &Case| c.truth.finger_lag_s > 0.0);
        let (nm, ns) = slice(&|c: &Case| c.truth.finger_lag_s == 0.0);
        let (am, as_) = slice(&|_: &Case| true);
        per.push_str(&format!(
            " | one finger first {:.0}/{:+.0}, together {:.0}/{:+.0}, all {:.0}/{:+.0}",
            fm * 1e3,
            fs * 1e3,
            nm * 1e3,
            ns * 1e3,
            am * 1e3,
            as_ * 1e3
        ));
        let dm = demo_onset(demo, &cfg);
        rows.push((worst_med, worst_mean, cfg, per, dm));
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    println!(
        "finger-combination search on {} tuning grasps (ranked by the worst start shape's median |error|, then |mean signed|)",
        tuning.len()
    );
    for (med, mn, cfg, per, dm) in rows {
        println!(
            "worst median {:.0} ms, worst |mean| {:.0} ms | {} {} {}{} lead {:+.3} | median/mean (ms):{} | demo {:?} {:+.3} s",
            med * 1e3,
            mn * 1e3,
            cfg.onset_model.name(),
            cfg.onset_starts.name(),
            cfg.onset_fingers.name(),
            if cfg.onset_fingers == OnsetFingers::ClearEarliest {
                format!(" gate {}", cfg.onset_finger_gate)
            } else {
                String::new()
            },
            cfg.onset_lead_s,
            per,
            dm.0,
            dm.1
        );
    }
}

/// Look-ahead after the decision (s) that `-- tune horizon` re-dates each slip at.
const HORIZONS: [f64; 7] = [0.0, 0.1, 0.2, 0.3, 0.5, 0.75, 1.0];

/// Idea "trade delay for accuracy", on the tuning members only: each slip the defaults decide
/// right (no lead) is re-dated by the same change-point fit `h` seconds after its decision
/// (the histories then hold `h` more of the motion); per horizon, the lead that centres all
/// shapes (their mean signed error) and per start shape the median |error| / mean signed after
/// it. Rule stated before the run: a horizon is offered only if every shape's mean is within
/// ±10 ms and median ≤ 30 ms on these members.
fn tune_horizon(tuning: &[Case]) {
    use gradtac::stream::{Timed, Timestamp};
    let cfg = SlipConfig { onset_lead_s: 0.0, ..Default::default() };
    // per horizon: (shape, signed error) of every slip decided right
    let mut errs: Vec<Vec<(StartShape, f64)>> = vec![Vec::new(); HORIZONS.len()];
    for c in tuning.iter().filter(|c| c.truth.class.is_slip()) {
        if !run(c, &cfg).right() {
            continue;
        }
        let t0 = c.truth.onset_s;
        let input = slip_inputs(&c.rec.frames, &c.tracks, &cfg).expect("valid");
        let mut s = Slip::try_new(&cfg).expect("valid");
        let mut out = Vec::new();
        let mut decided: Option<f64> = None;
        let mut next = 0;
        for i in input {
            let t = i.time().as_secs_f64();
            while let Some(d) = decided {
                if next < HORIZONS.len() && t > d + HORIZONS[next] + 1e-9 {
                    let on = s.onset_fit_now(Timestamp(i64::MAX)).as_secs_f64();
                    errs[next].push((c.truth.start, on - t0));
                    next += 1;
                } else {
                    break;
                }
            }
            s.push_input(i, &mut out).expect("ok");
            if decided.is_none() {
                if let Some(e) = out.iter().find(|e| e.class.is_slip() && e.time.as_secs_f64() >= t0) {
                    decided = Some(e.time.as_secs_f64());
                    errs[0].push((c.truth.start, e.onset.as_secs_f64() - t0));
                    next = 1;
                }
            }
        }
        // horizons past the recording's end: the fit at the end
        while decided.is_some() && next < HORIZONS.len() {
            let on = s.onset_fit_now(Timestamp(i64::MAX)).as_secs_f64();
            errs[next].push((c.truth.start, on - t0));
            next += 1;
        }
    }
    println!("onset re-dated h after the decision, tuning members (slips decided right; lead = mean signed of all)");
    for (h, e) in HORIZONS.iter().zip(&errs) {
        let lead = mean(&e.iter().map(|x| x.1).collect::<Vec<_>>());
        let mut line = format!("h {h:.2} s: n {} lead {:+.3} s |", e.len(), lead);
        let mut worst = (0.0f64, 0.0f64);
        for shape in StartShape::FAMILY {
            let mut v: Vec<f64> = e.iter().filter(|x| x.0 == shape).map(|x| x.1 - lead).collect();
            let mn = mean(&v);
            let mut a: Vec<f64> = v.iter().map(|x| x.abs()).collect();
            let md = pct(&mut a, 0.5);
            v.clear();
            worst = (worst.0.max(md), worst.1.max(mn.abs()));
            line.push_str(&format!(" {} {:.0}/{:+.0}", shape.name(), md * 1e3, mn * 1e3));
        }
        line.push_str(&format!(" | worst {:.0}/{:.0} ms", worst.0 * 1e3, worst.1 * 1e3));
        println!("{line}");
    }
}

/// Scratch: finger `k`'s world-up positions from the model-fit locator over `[from, to]` ns.
fn fit_history(c: &Case, k: usize, from: i64, to: i64) -> Vec<String> {
    use gradtac::stages::fit::Fit;
    use gradtac::stages::locate::LocateConfig;
    use gradtac::stream::{Layout, Stage};
    let name = ["ff", "th"][k];
    let up = if k == 0 { 1.0 } else { -1.0 };
    let layout = Layout::biotac_sp();
    let wf = std::env::var("DUMP_FIT_WINDOW").ok().and_then(|v| v.parse().ok()).unwrap_or(3);
    let env = |k: &str, d: f64| std::env::var(k).ok().and_then(|v| v.parse().ok()).unwrap_or(d);
    let cfg = LocateConfig {
        window_frames: wf,
        fit_motion_prior: env("DUMP_FIT_PRIOR", 0.8),
        smooth_frames: env("DUMP_FIT_SMOOTH", 3.0) as u32,
        fit_iterations: env("DUMP_FIT_ITER", 3.0) as u32,
        contact_sigmas: env("DUMP_FIT_CONTACT", 10.0),
        ..Default::default()
    };
    let peak = std::env::var("DUMP_FIT_PEAK").is_ok();
    let mut f = Fit::try_new(&cfg, &layout).expect("valid");
    let mut out = Vec::new();
    for fr in c.rec.frames.iter().filter(|fr| fr.sensor.as_str() == name) {
        f.push(fr.clone(), &mut out).expect("ok");
    }
    out.iter()
        .filter_map(|cf| {
            let mid = cf.start.as_nanos() / 2 + cf.end.as_nanos() / 2;
            let m = cf.outcome.contact()?;
            let y = if peak { m.peak_mm[1] } else { m.centroid_mm[1] };
            (mid >= from && mid <= to).then(|| format!("{:.4}:{:.4}", mid as f64 * 1e-9, up * y))
        })
        .collect()
}
