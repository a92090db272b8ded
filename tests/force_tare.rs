//! A hand that starts in contact, and a stored baseline that stops fitting, on members of the
//! forward-model family no choice was made on (seeds 600..606; `docs/force.md`).
//!
//! Protocol per member: 3 s untouched (the tare's stretch), then — continuing the same
//! sensor's drift — a recording that starts pressed at 2–8 N at a drawn place, holds 1.5 s and
//! lifts. The chain is the bare default (centroid) with `[stages.locate] baseline`, and a
//! ridge force model calibrated on a press session of the same member.

use gradtac::stages::centroid::Centroid;
use gradtac::stages::contour::ContourOutcome;
use gradtac::stages::force::ForceEstimate;
use gradtac::stages::force_model::{calibrate, force_detector, CalibrationMethod, ChangeForce, GaugeSample};
use gradtac::stages::locate::LocateConfig;
use gradtac::stages::sim_force::{ForceSession, Segment};
use gradtac::stages::tare::Tare;
use gradtac::stages::track::{ContactState, Track, TrackConfig};
use gradtac::stream::{Layout, Stage, StageExt, TaxelFrame};

const SEEDS: std::ops::Range<u64> = 600..606;

fn tare_of(frames: &[TaxelFrame]) -> Tare {
    let values: Vec<Vec<f64>> = frames.iter().map(|f| f.values.clone()).collect();
    let times: Vec<i64> = frames.iter().map(|f| f.time.0).collect();
    Tare::measure(&values, &times, "biotac-sp", "ff", &LocateConfig::default()).unwrap()
}

/// The member's untouched stretch, and a recording of the same sensor that starts pressed.
fn member(seed: u64, rest_after_s: f64) -> (Vec<TaxelFrame>, ForceSession, Vec<TaxelFrame>, Vec<f64>) {
    let base = ForceSession::presses(seed, 1);
    let rest = ForceSession { segments: vec![Segment::Rest(3.0)], noise_stream: 1, ..base.clone() };
    let at = base.places()[0];
    let f = 2.0 + (seed % 7) as f64;
    let pressed = ForceSession {
        segments: vec![
            Segment::Press { at, from_n: f, peak_n: f, rise_s: 0.0, hold_s: 1.5, fall_s: 0.3 },
            Segment::Rest(rest_after_s),
        ],
        t0_s: 3.0,
        noise_stream: 2,
        ..base.clone()
    };
    let r = pressed.simulate();
    (rest.simulate().frames, pressed, r.frames, r.force)
}

/// A ridge model of the member's sensor, calibrated on a press session of its own.
fn ridge_of(seed: u64) -> gradtac::stages::force_model::ForceFile {
    let session = ForceSession { noise_stream: 3, ..ForceSession::presses(seed, 4) };
    let rec = session.simulate();
    let mut det = force_detector(24, &LocateConfig::default()).unwrap();
    let samples: Vec<GaugeSample> = rec
        .frames
        .iter()
        .map(|f| {
            let ch = det.push(f, "t").unwrap();
            let k = ((ch.start.0 + ch.end.0) / 2 - rec.frames[0].time.0) as f64 * 1e-7;
            GaugeSample {
                change: det.change().to_vec(),
                contact: ch.contact,
                area_mm2: None,
                amplitude: None,
                force_n: rec.gauge[k.round() as usize],
                time_s: 0.5 * (ch.start.as_secs_f64() + ch.end.as_secs_f64()),
            }
        })
        .collect();
    calibrate(
        &samples,
        CalibrationMethod::Ridge,
        1e-3,
        gradtac::stages::force::ForceMethod::Isotonic,
        &Layout::biotac_sp(),
    )
    .unwrap()
}

#[test]
fn with_a_tare_a_recording_that_starts_in_contact_reports_contact_location_and_force_from_its_first_frame() {
    let layout = Layout::biotac_sp();
    let cfg = LocateConfig::default();
    for seed in SEEDS {
        let (rest, _, frames, truth) = member(seed, 1.0);
        let tare = tare_of(&rest);
        // without the tare the first frames calibrate and the press reads as the baseline
        let plain = Centroid::try_new(&cfg, &layout).unwrap().run_all(frames.clone()).unwrap();
        assert!(!matches!(plain[0].outcome, ContourOutcome::Contact(_)));
        let mut c = Centroid::try_new(&cfg, &layout).unwrap().with_tare(&tare).unwrap();
        let mut track = Track::try_new(&TrackConfig::default()).unwrap();
        let mut force = ChangeForce::try_new(&ridge_of(seed), &cfg).unwrap().with_tare(&tare).unwrap();
        let (mut contours, mut points, mut forces) = (Vec::new(), Vec::new(), Vec::<ForceEstimate>::new());
        for f in &frames {
            c.push(f.clone(), &mut contours).unwrap();
            force.push(f.clone(), &mut forces).unwrap();
        }
        for cf in contours.iter().cloned() {
            track.push(cf, &mut points).unwrap();
        }
        assert!(matches!(contours[0].outcome, ContourOutcome::Contact(_)), "seed {seed}: {:?}", contours[0].outcome);
        assert_eq!(points[0].state, ContactState::Contact, "seed {seed}");
        let f0 = forces[0].force_n.unwrap_or_else(|| panic!("seed {seed}: no force on the first frame"));
        // the first frame's force is the press's, within the method's held-out error band
        assert!(
            (f0 - truth[0]).abs() < 0.35 * truth[0],
            "seed {seed}: first frame {f0:.2} N against {:.2} N",
            truth[0]
        );
        // pressed throughout the hold; released after the lift
        let hold = 150;
        let pressed = contours[..hold].iter().filter(|c| matches!(c.outcome, ContourOutcome::Contact(_))).count();
        assert!(pressed as f64 > 0.98 * hold as f64, "seed {seed}: contact in {pressed} of {hold} frames");
        let end = &contours[contours.len() - 20..];
        assert!(
            end.iter().all(|c| !matches!(c.outcome, ContourOutcome::Contact(_))),
            "seed {seed}: contact after the lift"
        );
        assert!(c.detector().tare_mismatch().is_none(), "seed {seed}: {:?}", c.detector().tare_mismatch());
    }
}

#[test]
fn a_tare_of_another_sensor_or_before_a_temperature_shift_is_called_out() {
    let layout = Layout::biotac_sp();
    let cfg = LocateConfig::default();
    let run = |tare: &Tare, frames: &[TaxelFrame]| {
        let mut c = Centroid::try_new(&cfg, &layout).unwrap().with_tare(tare).unwrap();
        let _ = c.run_all(frames.to_vec()).unwrap();
        c.detector().tare_mismatch().cloned()
    };
    for seed in SEEDS.take(3) {
        let (rest, _, frames, _) = member(seed, 6.0);
        let (other_rest, ..) = member(seed + 50, 1.0);
        assert!(run(&tare_of(&rest), &frames).is_none(), "seed {seed}");
        // another sensor: its baselines differ by hundreds of counts
        let m =
            run(&tare_of(&other_rest), &frames).unwrap_or_else(|| panic!("seed {seed}: another sensor's tare fits"));
        assert!(m.median_sigmas > cfg.contact_sigmas && m.seq < 100, "seed {seed}: {m:?}");
        // a temperature shift of every taxel by 150 counts (called out once it outlasts the press)
        let warm: Vec<TaxelFrame> = frames
            .iter()
            .map(|f| TaxelFrame { values: f.values.iter().map(|v| v + 150.0).collect(), ..f.clone() })
            .collect();
        assert!(run(&tare_of(&rest), &warm).is_some(), "seed {seed}: a shifted sensor fits");
        // explain's check reads the same statistic
        assert!(tare_of(&other_rest).median_sigmas(&frames[0].values).unwrap() > cfg.contact_sigmas);
    }
}
