//! The speed–accuracy trade of the contact-location methods, tuned on some members of the
//! forward-model family ([`gradtac::stages::sim_family`]) and scored on others.
//!
//! Methods (`[stages.locate] method`): the taxel **centroid** (the cheap reference), the
//! paper's **raw contours** (maximal contour of the baseline-relative change) and the paper's
//! **event contours** (Savitzky–Golay → log-change events → window of counts → surface →
//! maximal contour). Each method's settings grid (window, τ, grid, min area, power, top-k)
//! runs on every member; every track point with a contact during the movement is compared
//! with the true contact at the middle of the point's span (`start..time`).
//!
//! - **Members.** A member is `(seed, kind)`; each draws its own physics (kernel shape and
//!   width, gains and signs, lag, drift, noise, knee, baselines, force, speed, path; see the
//!   family's docs). **Tuning**: seeds `TUNE` × 4 kinds; **test (held out)**: seeds `TEST` ×
//!   4 kinds. Every choice (each method's settings and the default method) is made on the
//!   tuning members only, by the worst kind's mean error among settings that report a contact
//!   in ≥ 90 % of the movement frames.
//! - **Error** as a fraction of the **sensor width** = the BioTac SP layout's x extent (taxels'
//!   bounding box + 2 mm margin each side, 26.6 mm). *mean*: over the kinds' per-recording mean
//!   errors; *worst kind*: the largest per-kind mean; *contact*: share of movement frames with a
//!   contact.
//! - **Paper protocol.** Per recording the track point nearest in time to each of its 5
//!   way-points (within 50 ms); one similarity transform (scale, rotation, translation) fitted
//!   over all way-points of all test recordings maps the track onto the truth; mean and worst
//!   kind of the remaining error (a way-point without a contact counts as the distance from the
//!   pad centre).
//! - **µs/frame**: the method's whole chain from raw counts to track points per frame, median
//!   over the test recordings (one run each; release build).
//!
//! Run: `cargo run --release --example tradeoff [-- --quick]` (`--quick`: fewer members and a
//! smaller grid).

use gradtac::stages::centroid::Centroid;
use gradtac::stages::contour::{Contour, ContourConfig};
use gradtac::stages::events::{Events, EventsConfig, Threshold};
use gradtac::stages::interpolate::{GridConfig, Interpolate, InterpolateConfig};
use gradtac::stages::locate::LocateConfig;
use gradtac::stages::raw_contour::RawChange;
use gradtac::stages::savgol::{SavGol, SavGolConfig};
use gradtac::stages::sim_family::{FamilyRecording, Member, PathKind, Similarity};
use gradtac::stages::track::{ContactState, Track, TrackConfig, TrackPoint};
use gradtac::stages::window::{Aggregate, Window, WindowConfig};
use gradtac::stages::EventBatch;
use gradtac::stream::{Layout, StageExt};
use std::collections::HashMap;
use std::time::Instant;

/// One setting of one method.
#[derive(Clone, Debug)]
enum Setting {
    Centroid { window: u32, power: f64, top_k: Option<usize>, floor: f64, contact: f64, smooth: u32, speed: f64 },
    Raw { grid: usize, window: u32, min_area: f64 },
    Events { grid: usize, window: u64, tau: f64, min_area: f64 },
}

impl Setting {
    fn cells(&self) -> [String; 5] {
        match self {
            Setting::Centroid { window, power, top_k, floor, contact, smooth, speed } => [
                "centroid".into(),
                "—".into(),
                window.to_string(),
                "—".into(),
                format!(
                    "p = {power}{}, floor {floor} σ, contact {contact} σ, smooth {smooth}, {}",
                    top_k.map_or(String::new(), |k| format!(", top {k}")),
                    if *speed > 0.0 { format!("≤ {speed} mm/s") } else { "no speed bound".into() }
                ),
            ],
            Setting::Raw { grid, window, min_area } => [
                "raw contour".into(),
                format!("{grid}×{grid}"),
                window.to_string(),
                "—".into(),
                format!("min area {min_area} mm²"),
            ],
            // τ < 0: noise-adaptive, τᵢ = |τ| σᵢ
            Setting::Events { grid, window, tau, min_area } => [
                if *tau < 0.0 { "event contour, τ from noise".into() } else { "event contour".into() },
                format!("{grid}×{grid}"),
                window.to_string(),
                if *tau < 0.0 { format!("{} σ", -tau) } else { tau.to_string() },
                format!("min area {min_area} mm²"),
            ],
        }
    }
}

/// Run one setting on one recording: track points and µs/frame.
fn run(
    s: &Setting,
    layout: &Layout,
    rec: &FamilyRecording,
    batches: Option<&Vec<EventBatch>>,
) -> (Vec<TrackPoint>, f64) {
    let track = || Track::try_new(&TrackConfig::default()).unwrap();
    let surface = |grid: usize| {
        Interpolate::try_new(
            &InterpolateConfig {
                grid: GridConfig { nx: grid, ..Default::default() },
                incremental: true,
                ..Default::default()
            },
            layout,
        )
        .unwrap()
    };
    let frames = rec.frames.clone();
    let n = frames.len() as f64;
    let t0 = Instant::now();
    let pts = match s {
        Setting::Centroid { window, power, top_k, floor, contact, smooth, speed } => {
            let cfg = LocateConfig {
                max_speed_mm_s: *speed,
                window_frames: *window,
                power: *power,
                top_k: *top_k,
                floor_sigmas: *floor,
                contact_sigmas: *contact,
                smooth_frames: *smooth,
                ..Default::default()
            };
            Centroid::try_new(&cfg, layout).unwrap().then(track()).run_all(frames).unwrap()
        }
        Setting::Raw { grid, window, min_area } => {
            let cfg = LocateConfig { window_frames: *window, ..Default::default() };
            let cc = ContourConfig { min_peak: 0.0, min_area_mm2: *min_area, ..Default::default() };
            RawChange::try_new(layout.len(), &cfg)
                .unwrap()
                .then(surface(*grid))
                .then(Contour::try_new(&cc).unwrap())
                .then(track())
                .run_all(frames)
                .unwrap()
        }
        Setting::Events { grid, window, tau, min_area } => {
            // the front end (Savitzky–Golay + events) depends on τ only: cached, timed once
            let b = batches.expect("events need their batches").clone();
            let wc = WindowConfig { frames: Some(*window), aggregate: Aggregate::Count, ..Default::default() };
            let cc = ContourConfig { min_peak: 2.0, min_area_mm2: *min_area, ..Default::default() };
            let _ = tau;
            Window::try_new(&wc)
                .unwrap()
                .then(surface(*grid))
                .then(Contour::try_new(&cc).unwrap())
                .then(track())
                .run_all(b)
                .unwrap()
        }
    };
    (pts, t0.elapsed().as_secs_f64() * 1e6 / n)
}

fn front_end(layout: &Layout, rec: &FamilyRecording, tau: f64) -> (Vec<EventBatch>, f64) {
    let sg = SavGol::try_with_rate(layout.len(), SavGolConfig::default(), 100.0).unwrap();
    let threshold = if tau < 0.0 {
        // the noise-adaptive τ calibrates over the same frames as the change detector
        Threshold::Noise { noise_sigmas: -tau, calibrate_frames: LocateConfig::default().calibrate_frames }
    } else {
        Threshold::Uniform(tau)
    };
    let ev = Events::try_new(layout.len(), EventsConfig { threshold, ..Default::default() }).unwrap();
    let frames = rec.frames.clone();
    let n = frames.len() as f64;
    let t0 = Instant::now();
    let b = sg.then(ev).run_all(frames).unwrap();
    (b, t0.elapsed().as_secs_f64() * 1e6 / n)
}

/// Per recording: mean error (mm) over contact points during the movement, contact share, and
/// the track point (x, y) nearest each way-point (None: no contact within 50 ms).
struct Score {
    mean_mm: f64,
    contact: f64,
    way: Vec<Option<[f64; 2]>>,
}

fn score(rec: &FamilyRecording, pts: &[TrackPoint]) -> Score {
    let (t0, t1) = rec.moving_s;
    let moving = |t: f64| t > t0 && t < t1;
    let mid = |p: &TrackPoint| 0.5 * (p.start.as_secs_f64() + p.time.as_secs_f64());
    let total = pts.iter().filter(|p| moving(mid(p))).count().max(1);
    let errs: Vec<f64> = pts
        .iter()
        .filter(|p| p.state == ContactState::Contact && moving(mid(p)))
        .filter_map(|p| {
            let c = rec.physics.path.at((mid(p) - t0) / (t1 - t0));
            Some((p.x_mm - c[0]).hypot(p.y_mm - c[1])).filter(|e| e.is_finite())
        })
        .collect();
    let way = rec
        .waypoints
        .iter()
        .map(|&(tw, _)| {
            pts.iter()
                .filter(|p| p.state == ContactState::Contact && (mid(p) - tw).abs() <= 0.05)
                .min_by(|a, b| (mid(a) - tw).abs().total_cmp(&(mid(b) - tw).abs()))
                .map(|p| [p.x_mm, p.y_mm])
        })
        .collect();
    // a recording without any contact during the movement scores the mean distance of the truth
    // from the pad centre (what "no idea" costs), not infinity
    let mean_mm = if errs.is_empty() {
        let c = Layout::biotac_sp().extent().centre();
        let d: Vec<f64> = (1..20)
            .map(|i| {
                let p = rec.physics.path.at(i as f64 / 20.0);
                (p[0] - c[0]).hypot(p[1] - c[1])
            })
            .collect();
        d.iter().sum::<f64>() / d.len() as f64
    } else {
        errs.iter().sum::<f64>() / errs.len() as f64
    };
    Score { mean_mm, contact: errs.len() as f64 / total as f64, way }
}

/// Mean and worst-kind of per-recording means (fractions of `width`), and the mean contact share.
fn summary(members: &[Member], scores: &[Score], width: f64) -> (f64, f64, &'static str, f64) {
    let mut by_kind: HashMap<PathKind, Vec<f64>> = HashMap::new();
    for (m, s) in members.iter().zip(scores) {
        by_kind.entry(m.kind).or_default().push(s.mean_mm / width);
    }
    let mean = scores.iter().map(|s| s.mean_mm / width).sum::<f64>() / scores.len() as f64;
    let (mut worst, mut wk) = (0.0, "");
    for k in PathKind::ALL {
        if let Some(v) = by_kind.get(&k) {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            if m > worst || m.is_nan() {
                worst = m;
                wk = k.name();
            }
        }
    }
    let contact = scores.iter().map(|s| s.contact).sum::<f64>() / scores.len() as f64;
    (mean, worst, wk, contact)
}

/// The paper's protocol: one similarity over every way-point of every recording.
fn paper(members: &[Member], recs: &[FamilyRecording], scores: &[Score], width: f64) -> (f64, f64) {
    let centre = Layout::biotac_sp().extent().centre();
    let (mut from, mut to) = (Vec::new(), Vec::new());
    for (r, s) in recs.iter().zip(scores) {
        for (w, p) in r.waypoints.iter().zip(&s.way) {
            if let Some(p) = p {
                from.push(*p);
                to.push(w.1);
            }
        }
    }
    let sim = Similarity::fit(&from, &to);
    let mut by_kind: HashMap<PathKind, Vec<f64>> = HashMap::new();
    let mut all = Vec::new();
    for ((m, r), s) in members.iter().zip(recs).zip(scores) {
        for (w, p) in r.waypoints.iter().zip(&s.way) {
            let q = p.map_or(centre, |p| sim.apply(p));
            let e = (q[0] - w.1[0]).hypot(q[1] - w.1[1]) / width;
            by_kind.entry(m.kind).or_default().push(e);
            all.push(e);
        }
    }
    let worst = by_kind.values().map(|v| v.iter().sum::<f64>() / v.len() as f64).fold(0.0, f64::max);
    (all.iter().sum::<f64>() / all.len().max(1) as f64, worst)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let tune_seeds: Vec<u64> = if quick { (0..3).collect() } else { (0..8).collect() };
    let test_seeds: Vec<u64> = if quick { (100..104).collect() } else { (100..116).collect() };
    let layout = Layout::biotac_sp();
    let width = layout.extent().width();
    let grids: &[usize] = if quick { &[16] } else { &[16, 32] };
    // τ < 0: noise-adaptive, τᵢ = |τ| σᵢ of each taxel's measured noise
    let taus: &[f64] = if quick { &[0.001, 0.002, -4.0] } else { &[0.0005, 0.001, 0.002, 0.004, -2.0, -4.0, -8.0] };

    let mut settings = Vec::new();
    for window in [1u32, 3, 5, 9] {
        for power in [1.0, 2.0, 4.0] {
            for top_k in [None, Some(4)] {
                for floor in [2.0, 3.0, 4.0] {
                    for contact in [6.0, 10.0] {
                        for smooth in [1, 3] {
                            for speed in [0.0, 30.0] {
                                settings.push(Setting::Centroid {
                                    window,
                                    power,
                                    top_k,
                                    floor,
                                    contact,
                                    smooth,
                                    speed,
                                });
                            }
                        }
                    }
                }
            }
        }
    }
    for &grid in grids {
        for window in [3u32, 5, 9] {
            for min_area in [10.0, 30.0, 60.0, 100.0] {
                settings.push(Setting::Raw { grid, window, min_area });
            }
        }
    }
    for &grid in grids {
        for window in [5u64, 10, 20] {
            for &tau in taus {
                for min_area in [30.0, 60.0, 120.0] {
                    settings.push(Setting::Events { grid, window, tau, min_area });
                }
            }
        }
    }

    let tune = Member::grid(tune_seeds.iter().copied());
    let test = Member::grid(test_seeds.iter().copied());
    let sim = |ms: &[Member]| ms.iter().map(Member::simulate).collect::<Vec<_>>();
    let (tune_recs, test_recs) = (sim(&tune), sim(&test));
    let frames: usize = test_recs.iter().map(|r| r.frames.len()).sum();
    eprintln!(
        "{} tuning and {} test recordings ({frames} test frames), {} settings",
        tune.len(),
        test.len(),
        settings.len()
    );

    // events front end per (recording, τ)
    let mut front: HashMap<(bool, usize, u64), Vec<EventBatch>> = HashMap::new();
    let mut front_us: HashMap<u64, Vec<f64>> = HashMap::new();
    for &tau in taus {
        for (is_test, recs) in [(false, &tune_recs), (true, &test_recs)] {
            for (i, r) in recs.iter().enumerate() {
                let (b, us) = front_end(&layout, r, tau);
                front.insert((is_test, i, tau.to_bits()), b);
                if is_test {
                    front_us.entry(tau.to_bits()).or_default().push(us);
                }
            }
        }
    }

    struct Row {
        s: Setting,
        tune: (f64, f64, &'static str, f64),
        test: (f64, f64, &'static str, f64),
        paper: (f64, f64),
        us: f64,
    }
    let mut rows = Vec::new();
    for s in &settings {
        let tau = match s {
            Setting::Events { tau, .. } => Some(tau.to_bits()),
            _ => None,
        };
        let eval = |recs: &[FamilyRecording], is_test: bool| {
            let mut us = Vec::new();
            let scores: Vec<Score> = recs
                .iter()
                .enumerate()
                .map(|(i, r)| {
                    let b = tau.map(|t| &front[&(is_test, i, t)]);
                    let (pts, u) = run(s, &layout, r, b);
                    us.push(u + tau.map_or(0.0, |t| median(front_us[&t].clone())));
                    score(r, &pts)
                })
                .collect();
            (scores, median(us))
        };
        let (ts, _) = eval(&tune_recs, false);
        let (hs, us) = eval(&test_recs, true);
        rows.push(Row {
            s: s.clone(),
            tune: summary(&tune, &ts, width),
            test: summary(&test, &hs, width),
            paper: paper(&test, &test_recs, &hs, width),
            us,
        });
    }

    println!("| method | grid | window (frames) | τ | other | **held-out worst kind** | held-out mean | paper protocol mean | paper protocol worst kind | contact | tuning worst kind | µs/frame |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut chosen: Vec<&Row> = Vec::new();
    let eligible = |r: &&Row| r.tune.3 >= 0.9;
    let by_tuning = |a: &&Row, b: &&Row| a.tune.1.total_cmp(&b.tune.1).then(a.tune.0.total_cmp(&b.tune.0));
    for label in ["centroid", "raw contour", "event contour", "event contour, τ from noise"] {
        let of = |r: &&Row| r.s.cells()[0] == label;
        let best = rows.iter().filter(of).filter(eligible).min_by(by_tuning);
        // one row per (grid, window, τ): its other settings chosen on the tuning members
        let mut keys: Vec<(String, String, String)> = Vec::new();
        for r in rows.iter().filter(of) {
            let c = r.s.cells();
            let k = (c[1].clone(), c[2].clone(), c[3].clone());
            if !keys.contains(&k) {
                keys.push(k);
            }
        }
        for k in keys {
            let group = rows.iter().filter(|r| {
                let c = r.s.cells();
                c[0] == label && (c[1].clone(), c[2].clone(), c[3].clone()) == k
            });
            let Some(r) = group.clone().filter(eligible).min_by(by_tuning).or_else(|| group.min_by(by_tuning)) else {
                continue;
            };
            let c = r.s.cells();
            let mark = if best.is_some_and(|b| std::ptr::eq(b, r)) { " ← chosen on tuning" } else { "" };
            println!(
                "| {}{mark} | {} | {} | {} | {} | {:.3} ({}) | {:.3} | {:.3} | {:.3} | {:.0} % | {:.3} | {:.2} |",
                c[0],
                c[1],
                c[2],
                c[3],
                c[4],
                r.test.1,
                r.test.2,
                r.test.0,
                r.paper.0,
                r.paper.1,
                100.0 * r.test.3,
                r.tune.1,
                r.us
            );
        }
        chosen.extend(best);
    }
    println!();
    println!("Chosen per method on the tuning members (seeds {tune_seeds:?} × 4 kinds), scored on the held-out members (seeds {test_seeds:?} × 4 kinds):");
    println!();
    println!("| method | setting | held-out worst kind | held-out mean | paper protocol mean / worst kind | contact | µs/frame |");
    println!("|---|---|---|---|---|---|---|");
    for r in &chosen {
        let c = r.s.cells();
        println!(
            "| {} | grid {}, window {}, τ {}, {} | {:.3} ({}) | {:.3} | {:.3} / {:.3} | {:.0} % | {:.2} |",
            c[0],
            c[1],
            c[2],
            c[3],
            c[4],
            r.test.1,
            r.test.2,
            r.test.0,
            r.paper.0,
            r.paper.1,
            100.0 * r.test.3,
            r.us
        );
    }
    let ld = LocateConfig::default();
    let lib_default = rows.iter().find(|r| {
        matches!(r.s, Setting::Centroid { window, power, top_k, floor, contact, smooth, speed }
            if window == ld.window_frames && power == ld.power && top_k == ld.top_k && floor == ld.floor_sigmas
                && contact == ld.contact_sigmas && smooth == ld.smooth_frames && speed == ld.max_speed_mm_s)
    });
    if let Some(r) = lib_default {
        let c = r.s.cells();
        println!(
            "| **centroid, the library's default** | window {}, {} | {:.3} ({}) | {:.3} | {:.3} / {:.3} | {:.0} % | {:.2} |",
            c[2], c[4], r.test.1, r.test.2, r.test.0, r.paper.0, r.paper.1, 100.0 * r.test.3, r.us
        );
        println!();
        println!("The library's default centroid setting scores {:.3} (worst kind) on the tuning members.", r.tune.1);
    }
    // The default method: the lowest worst-kind error on the tuning members among the methods
    // that meet the project's speed target (≥ 200,000 frames/s per core: ≤ 5 µs/frame)
    let fast = |r: &&&Row| r.us <= 5.0;
    if let Some(d) = chosen.iter().filter(fast).min_by(|a, b| a.tune.1.total_cmp(&b.tune.1)) {
        println!();
        println!(
            "Default method (lowest worst-kind error on the tuning members among methods at ≤ 5 µs/frame): {}.",
            d.s.cells()[0]
        );
    }
    if let Some(r) = chosen.iter().find(|r| r.s.cells()[0] == "event contour, τ from noise") {
        println!(
            "Noise-adaptive event threshold chosen on the tuning members: τ = {} (`[stages.locate] event_tau_sigmas`; library default {}).",
            r.s.cells()[3],
            LocateConfig::default().event_tau_sigmas
        );
    }
    if let Some(d) = chosen.iter().min_by(|a, b| a.tune.1.total_cmp(&b.tune.1)) {
        println!(
            "Lowest worst-kind error on the tuning members at any cost: {} ({:.3} on tuning, {:.3} held out).",
            d.s.cells()[0],
            d.tune.1,
            d.test.1
        );
    }
    println!();
    println!("Sensor width {width:.1} mm (BioTac SP layout x extent). Front end of the event contours (Savitzky–Golay + events, included in their µs/frame): {}.",
        taus.iter()
            .map(|t| {
                let label = if *t < 0.0 { format!("{} σ", -t) } else { t.to_string() };
                format!("τ {label}: {:.2} µs", median(front_us[&t.to_bits()].clone()))
            })
            .collect::<Vec<_>>()
            .join(", "));
}
