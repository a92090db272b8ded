//! Round trips of the task-stage schemas (`slip/1`, `force/1`, `servo/1`, `dos/2`) through
//! `ParquetSink` and the Parquet reader, bit-exact (NaN payloads included), with records made
//! by hand and by the stages themselves; proptests for every schema; rejection of `dos/2`
//! decisions that do not fit the sink's classes; forces, servo commands and dos decisions
//! through sensor-partitioned rolled archives; and (when installed) pyarrow reading one file
//! of each kind, plus two slip files of different pairs read as one dataset.

use gradtac_io::archive::{ParquetArchive, Partitioning};
use gradtac_io::records::dos::DOS_CLASSES_KEY;
use gradtac_io::records::servo::servo_action_name;
use gradtac_io::records::slip::{SLIP_FIRST_KEY, SLIP_SECOND_KEY};
use gradtac_io::records::{ArrowRecord, DosShape, SlipShape};
use gradtac_io::{Error, ParquetSink};
use gradtac_stages::contour::{ContourFrame, ContourOutcome, MaxContour, NoContact};
use gradtac_stages::dos::{
    Decision, DosClass, DosClassifier, DosDecision, DosFeatureConfig, DosModel, Feature, FeatureVector,
};
use gradtac_stages::force::{Force, ForceConfig, ForceEstimate, ForceModel};
use gradtac_stages::servo::{Motion, Servo, ServoAction, ServoCommand, ServoConfig};
use gradtac_stages::slip::{Slip, SlipClass, SlipConfig, SlipEvent, SlipEvidence};
use gradtac_stages::track::{ContactState, TrackPoint};
use gradtac_stream::{HasSensor, Layout, SensorId, Stage, TaxelFrame, Timed, Timestamp};
use proptest::prelude::*;

mod common;
use common::*;

// ---------------------------------------------------------------------------------------------
// slip/1

/// The bits of a scalar as a file gives it back: an absent value (NaN) is stored as null and
/// reads back as the one canonical NaN.
fn sbit(x: f64) -> u64 {
    if x.is_nan() {
        f64::NAN.to_bits()
    } else {
        x.to_bits()
    }
}

fn sbits(v: &[f64]) -> Vec<u64> {
    v.iter().copied().map(sbit).collect()
}

fn slip_class(s: &str) -> SlipClass {
    SlipClass::ALL.into_iter().find(|c| c.name() == s).unwrap_or_else(|| panic!("slip class {s}"))
}

/// The events of a file, and the (first, second) pair of every row.
fn slips_of(r: &ReadBack) -> (Vec<(String, String)>, Vec<SlipEvent>) {
    let (mut pairs, mut out) = (Vec::new(), Vec::new());
    for b in &r.batches {
        let (first, second) = (strs(b, "first"), strs(b, "second"));
        let [time, onset, first_seen] = ["time", "onset", "first_seen"].map(|n| i64s(b, n));
        let (class, previous) = (strs(b, "class"), strs(b, "previous"));
        let (common, differential) = (f64s(b, "common_mm_s"), f64s(b, "differential_mm_s"));
        for i in 0..b.num_rows() {
            pairs.push((first[i].clone().unwrap(), second[i].clone().unwrap()));
            out.push(SlipEvent {
                time: Timestamp(time[i]),
                onset: Timestamp(onset[i]),
                first_seen: Timestamp(first_seen[i]),
                class: slip_class(class[i].as_deref().unwrap()),
                previous: slip_class(previous[i].as_deref().unwrap()),
                common_mm_s: common[i].unwrap_or(f64::NAN),
                differential_mm_s: differential[i].unwrap_or(f64::NAN),
            });
        }
    }
    (pairs, out)
}

type SlipKey = (i64, i64, i64, SlipClass, SlipClass, [u64; 2]);

fn slip_keys(e: &[SlipEvent]) -> Vec<SlipKey> {
    e.iter()
        .map(|e| {
            (
                e.time.as_nanos(),
                e.onset.as_nanos(),
                e.first_seen.as_nanos(),
                e.class,
                e.previous,
                [sbit(e.common_mm_s), sbit(e.differential_mm_s)],
            )
        })
        .collect()
}

fn some_slips() -> Vec<SlipEvent> {
    (0..30usize)
        .map(|k| {
            let t = k as i64 * 50_000_000;
            SlipEvent {
                time: Timestamp(t),
                onset: Timestamp(t - 90_000_000),
                first_seen: Timestamp(t - 80_000_000),
                class: SlipClass::ALL[k % 5],
                previous: SlipClass::ALL[(k + 2) % 5],
                common_mm_s: special(k),
                differential_mm_s: if k % 4 == 0 { f64::NAN } else { special(k + 4) },
            }
        })
        .collect()
}

#[test]
fn slips_round_trip_bit_exact_with_the_pair_in_metadata_and_columns() {
    let dir = tempfile::tempdir().unwrap();
    let input = some_slips();
    let r = read(&write(&dir.path().join("slip.parquet"), SlipShape::new("ff", "th"), &input, 7));
    assert_eq!(schema_id(&r), "slip/2");
    assert_eq!(r.schema.metadata()[SLIP_FIRST_KEY], "ff");
    assert_eq!(r.schema.metadata()[SLIP_SECOND_KEY], "th");
    let (pairs, back) = slips_of(&r);
    assert_eq!(slip_keys(&back), slip_keys(&input));
    assert!(pairs.iter().all(|p| p == &("ff".to_string(), "th".to_string())));
    assert_eq!(pairs.len(), input.len());
    for c in ["time", "onset", "first_seen"] {
        let t = r.schema.field_with_name(c).unwrap().data_type().clone();
        assert_eq!(t, arrow_schema::DataType::Duration(arrow_schema::TimeUnit::Nanosecond), "{c}");
    }
    assert_eq!(unit(&r, "common_mm_s").as_deref(), Some("mm/s"));
    assert!(nullable(&r, "common_mm_s") && nullable(&r, "differential_mm_s"), "a missing speed is null");
}

/// Track points of `ff` and `th` at 100 Hz, both in contact on track 0; positions from `f(t)`.
fn grasp(n: usize, ff: impl Fn(f64) -> [f64; 2], th: impl Fn(f64) -> [f64; 2]) -> Vec<TrackPoint> {
    let mut out = Vec::new();
    for k in 0..n {
        let t = Timestamp::at_rate(k as u64, 100.0);
        for (name, p) in [("th", th(t.as_secs_f64())), ("ff", ff(t.as_secs_f64()))] {
            out.push(TrackPoint {
                sensor: SensorId::new(name),
                time: t,
                start: t,
                seq: k as u64,
                state: ContactState::Contact,
                no_contact: None,
                track: Some(0),
                x_mm: p[0],
                y_mm: p[1],
                area_mm2: 10.0,
                orientation_rad: 0.0,
                peak: 5.0,
                velocity_mm_s: None,
                gated: false,
                fit: None,
            });
        }
    }
    out
}

#[test]
fn the_slip_stages_events_come_back() {
    // Both fingers see the object move up by 20 mm/s (mirrored in the thumb's layout) from
    // 0.5 s to 1.5 s: stable → longitudinal up → stable.
    let ramp = |v: f64| move |t: f64| [0.0, v * (t - 0.5).clamp(0.0, 1.0)];
    // track points only: the displacement rule on its track path
    let cfg = SlipConfig { evidence: SlipEvidence::Track, ..SlipConfig::default() };
    let mut slip = Slip::try_new(&cfg).unwrap();
    let mut events = Vec::new();
    // 4.5 s: the default rule returns to stable once its longest window (the ladder 0.3 s,
    // doubling up to `history_s` = 2.4 s) has been still
    for p in grasp(450, ramp(20.0), ramp(-20.0)) {
        slip.push(p, &mut events).unwrap();
    }
    slip.finish(&mut events).unwrap();
    assert!(events.len() >= 2, "{events:?}");
    assert_eq!((events[0].previous, events[0].class), (SlipClass::Stable, SlipClass::LongitudinalUp));
    let dir = tempfile::tempdir().unwrap();
    let r = read(&write(&dir.path().join("slip.parquet"), SlipShape::from_config(&cfg), &events, 1));
    let (pairs, back) = slips_of(&r);
    assert_eq!(back, events);
    assert_eq!(pairs[0], ("ff".to_string(), "th".to_string()));
}

// ---------------------------------------------------------------------------------------------
// force/1

fn forces_of(r: &ReadBack) -> Vec<ForceEstimate> {
    let mut out = Vec::new();
    for b in &r.batches {
        let sensor = strs(b, "sensor");
        let (time, seq) = (i64s(b, "time"), u64s(b, "seq"));
        let (area, force) = (f64s(b, "area_mm2"), f64s(b, "force_n"));
        for i in 0..b.num_rows() {
            out.push(ForceEstimate {
                sensor: SensorId::new(sensor[i].as_deref().unwrap()),
                time: Timestamp(time[i]),
                seq: seq[i],
                area_mm2: area[i].unwrap_or(f64::NAN),
                force_n: force[i],
            });
        }
    }
    out
}

type ForceKey = (String, i64, u64, u64, Option<u64>);

fn force_keys(f: &[ForceEstimate]) -> Vec<ForceKey> {
    f.iter()
        .map(|f| {
            (
                f.sensor.to_string(),
                f.time.as_nanos(),
                f.seq,
                sbit(f.area_mm2),
                f.force_n.filter(|x| !x.is_nan()).map(f64::to_bits),
            )
        })
        .collect()
}

fn some_forces() -> Vec<ForceEstimate> {
    (0..40usize)
        .map(|k| {
            let contact = k % 6 != 5;
            ForceEstimate {
                sensor: SensorId::new(["ff", "th", "mf"][k % 3]),
                time: Timestamp(k as i64 * 10_000_000 - 3),
                seq: k as u64,
                area_mm2: if contact {
                    special(k)
                } else if k % 12 == 5 {
                    odd_nan()
                } else {
                    f64::NAN
                },
                force_n: (contact && k % 7 != 0).then(|| special(k + 2)),
            }
        })
        .collect()
}

#[test]
fn forces_round_trip_bit_exact() {
    let dir = tempfile::tempdir().unwrap();
    let input = some_forces();
    let r = read(&write(&dir.path().join("force.parquet"), (), &input, 9));
    assert_eq!(schema_id(&r), "force/2");
    assert_eq!(rows(&r), input.len());
    assert_eq!(force_keys(&forces_of(&r)), force_keys(&input));
    assert_eq!(unit(&r, "area_mm2").as_deref(), Some("mm2"));
    assert_eq!(unit(&r, "force_n").as_deref(), Some("N"));
    assert!(nullable(&r, "area_mm2") && nullable(&r, "force_n"), "no contact: null area and force");
}

fn contour(seq: u64, area: Option<f64>) -> ContourFrame {
    let t = seq as i64 * 10_000_000;
    ContourFrame {
        sensor: SensorId::new("ff"),
        start: Timestamp(t - 90_000_000),
        end: Timestamp(t),
        seq,
        outcome: match area {
            Some(area_mm2) => ContourOutcome::Contact(MaxContour {
                level: 1.0,
                polygon: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
                holes: vec![],
                area_mm2,
                centroid_mm: [0.3, 0.3],
                orientation_rad: 0.1,
                eccentricity: 0.5,
                peak: 3.0,
                peak_mm: [0.0, 0.0],
                clipped: false,
                fit: None,
            }),
            None => ContourOutcome::NoContact(NoContact::BelowMinPeak),
        },
    }
}

#[test]
fn the_force_stages_estimates_come_back() {
    let cfg = ForceConfig { model: ForceModel::PowerLaw { scale: 0.05, exponent: 1.4 }, min_area_mm2: 5.0 };
    let mut force = Force::try_new(&cfg).unwrap();
    let mut out = Vec::new();
    for k in 0..20u64 {
        let area = match k % 4 {
            0 => None,
            1 => Some(2.0), // below min_area_mm2: an area, no force
            _ => Some(7.5 + k as f64 / 3.0),
        };
        force.push(contour(k, area), &mut out).unwrap();
    }
    assert!(out.iter().any(|e| e.area_mm2.is_nan()) && out.iter().any(|e| e.force_n.is_none() && e.area_mm2 == 2.0));
    let dir = tempfile::tempdir().unwrap();
    let r = read(&write(&dir.path().join("force.parquet"), (), &out, 4));
    assert_eq!(force_keys(&forces_of(&r)), force_keys(&out));
}

// ---------------------------------------------------------------------------------------------
// servo/1

const MOTION_COLUMNS: [&str; 7] =
    ["offset_x_mm", "offset_y_mm", "distance_mm", "direction_x", "direction_y", "motion_x_mm", "motion_y_mm"];

fn servos_of(r: &ReadBack) -> Vec<ServoCommand> {
    let mut out = Vec::new();
    for b in &r.batches {
        let sensor = strs(b, "sensor");
        let (time, seq) = (i64s(b, "time"), u64s(b, "seq"));
        let action = strs(b, "action");
        let m = MOTION_COLUMNS.map(|n| f64s(b, n));
        for i in 0..b.num_rows() {
            let action = match action[i].as_deref().unwrap() {
                "no_contact" => {
                    assert!(m.iter().all(|c| c[i].is_none()), "row {i}: motion columns are null without a command");
                    ServoAction::NoContact
                }
                "move" => {
                    // a NaN (which no motion has) would be stored as null
                    let v = m.each_ref().map(|c| c[i].unwrap_or(f64::NAN));
                    ServoAction::Move(Motion {
                        offset_mm: [v[0], v[1]],
                        distance_mm: v[2],
                        direction: [v[3], v[4]],
                        motion_mm: [v[5], v[6]],
                    })
                }
                other => panic!("action {other}"),
            };
            out.push(ServoCommand {
                sensor: SensorId::new(sensor[i].as_deref().unwrap()),
                time: Timestamp(time[i]),
                seq: seq[i],
                action,
            });
        }
    }
    out
}

type ServoKey = (String, i64, u64, Option<Vec<u64>>);

fn servo_keys(c: &[ServoCommand]) -> Vec<ServoKey> {
    c.iter()
        .map(|c| {
            let m = c.motion().map(|m| {
                sbits(&[
                    m.offset_mm[0],
                    m.offset_mm[1],
                    m.distance_mm,
                    m.direction[0],
                    m.direction[1],
                    m.motion_mm[0],
                    m.motion_mm[1],
                ])
            });
            (c.sensor.to_string(), c.time.as_nanos(), c.seq, m)
        })
        .collect()
}

fn some_servos() -> Vec<ServoCommand> {
    (0..40usize)
        .map(|k| ServoCommand {
            sensor: SensorId::new(if k % 2 == 0 { "ff" } else { "th" }),
            time: Timestamp(k as i64 * 10_000_000),
            seq: k as u64,
            action: if k % 5 == 4 {
                ServoAction::NoContact
            } else {
                ServoAction::Move(Motion {
                    offset_mm: [special(k), -1.5],
                    distance_mm: special(k + 1),
                    direction: [if k % 3 == 0 { odd_nan() } else { 0.6 }, -0.8],
                    motion_mm: [special(k + 2), 0.0],
                })
            },
        })
        .collect()
}

#[test]
fn servo_commands_round_trip_bit_exact() {
    let dir = tempfile::tempdir().unwrap();
    let input = some_servos();
    let r = read(&write(&dir.path().join("servo.parquet"), (), &input, 6));
    assert_eq!(schema_id(&r), "servo/2");
    assert_eq!(rows(&r), input.len());
    assert_eq!(servo_keys(&servos_of(&r)), servo_keys(&input));
    for c in MOTION_COLUMNS {
        assert!(nullable(&r, c), "{c}");
        let expected = if c.starts_with("direction") { None } else { Some("mm") };
        assert_eq!(unit(&r, c).as_deref(), expected, "{c}");
    }
}

#[test]
fn the_servo_stages_commands_come_back() {
    let layout = Layout::biotac_sp();
    let mut servo = Servo::try_new(&ServoConfig { deadband_mm: 0.5, ..ServoConfig::default() }, &layout).unwrap();
    let centre = servo.centre();
    let mut out = Vec::new();
    for (k, p) in grasp(30, |t| [3.0 * t, 1.0 - t], |_| [0.0; 2]).into_iter().enumerate() {
        let p = match k % 7 {
            3 => TrackPoint { state: ContactState::NoContact, x_mm: f64::NAN, y_mm: f64::NAN, track: None, ..p },
            5 => TrackPoint { x_mm: centre[0], y_mm: centre[1], ..p }, // zero offset: zero direction
            _ => p,
        };
        servo.push(p, &mut out).unwrap();
    }
    assert!(out.iter().any(|c| c.action == ServoAction::NoContact));
    assert!(out.iter().filter_map(ServoCommand::motion).any(|m| m.motion_mm != [0.0, 0.0]));
    let dir = tempfile::tempdir().unwrap();
    let r = read(&write(&dir.path().join("servo.parquet"), (), &out, 8));
    assert_eq!(servos_of(&r), out);
}

// ---------------------------------------------------------------------------------------------
// dos/2

fn dos_class(s: &str) -> DosClass {
    s.parse().unwrap_or_else(|e| panic!("{e}"))
}

fn dos_of(r: &ReadBack) -> Vec<DosDecision> {
    let classes: Vec<String> = serde_json::from_str(&r.schema.metadata()[DOS_CLASSES_KEY]).unwrap();
    let mut out = Vec::new();
    for b in &r.batches {
        let sensor = strs(b, "sensor");
        let [start, end] = ["start", "end"].map(|n| i64s(b, n));
        let [seq, frames, events] = ["seq", "frames", "events"].map(|n| u64s(b, n));
        let class = strs(b, "class");
        let (distances, posterior) = (f64_lists(b, "distances"), f64_lists(b, "posterior"));
        let features = Feature::ALL.map(|f| f64s(b, f.name()));
        for i in 0..b.num_rows() {
            assert_eq!(distances[i].len(), classes.len());
            out.push(DosDecision {
                sensor: SensorId::new(sensor[i].as_deref().unwrap()),
                start: Timestamp(start[i]),
                end: Timestamp(end[i]),
                seq: seq[i],
                frames: frames[i],
                decision: Decision {
                    class: dos_class(class[i].as_deref().unwrap()),
                    distances: distances[i].clone(),
                    posterior: posterior[i].clone(),
                },
                features: FeatureVector {
                    all: features.each_ref().map(|c| c[i].unwrap_or(f64::NAN)),
                    frames: frames[i],
                    events: events[i],
                },
            });
        }
    }
    out
}

type DosKey = (String, i64, i64, u64, u64, u64, DosClass, Vec<u64>, Vec<u64>, Vec<u64>);

fn dos_keys(d: &[DosDecision]) -> Vec<DosKey> {
    d.iter()
        .map(|d| {
            (
                d.sensor.to_string(),
                d.start.as_nanos(),
                d.end.as_nanos(),
                d.seq,
                d.frames,
                d.features.events,
                d.decision.class,
                bits(&d.decision.distances),
                bits(&d.decision.posterior),
                sbits(&d.features.all),
            )
        })
        .collect()
}

fn some_dos(classes: &[DosClass]) -> Vec<DosDecision> {
    let k = classes.len();
    (0..12usize)
        .map(|j| {
            let frames = 50 + j as u64;
            DosDecision {
                sensor: SensorId::new(if j % 3 == 0 { "th" } else { "ff" }),
                start: Timestamp(j as i64 * 1_000_000_000),
                end: Timestamp(j as i64 * 1_000_000_000 + 490_000_000),
                seq: 50 * j as u64 + 49,
                frames,
                decision: Decision {
                    class: classes[j % k],
                    distances: (0..k).map(|c| special(j + c)).collect(),
                    posterior: (0..k).map(|c| if c == 0 { odd_nan() } else { 1.0 / (c + j) as f64 }).collect(),
                },
                features: FeatureVector {
                    all: std::array::from_fn(|f| special(3 * j + f)),
                    frames,
                    events: (j * 17) as u64,
                },
            }
        })
        .collect()
}

#[test]
fn dos_decisions_round_trip_bit_exact_with_the_classes_in_metadata() {
    let dir = tempfile::tempdir().unwrap();
    let classes = vec![DosClass::T, DosClass::Cw, DosClass::N, DosClass::W];
    let input = some_dos(&classes);
    let r = read(&write(&dir.path().join("dos.parquet"), DosShape::new(classes).unwrap(), &input, 5));
    assert_eq!(schema_id(&r), "dos/3");
    assert_eq!(rows(&r), input.len());
    assert_eq!(r.schema.metadata()[DOS_CLASSES_KEY], r#"["t","cw","n","w"]"#);
    assert_eq!(dos_keys(&dos_of(&r)), dos_keys(&input));
    assert_eq!(unit(&r, "positive_x").as_deref(), Some("mm"));
    assert_eq!(unit(&r, "rotation").as_deref(), Some("rad"));
    assert_eq!(unit(&r, "rate"), None);
    let end = r.schema.field_with_name("end").unwrap().data_type().clone();
    assert_eq!(end, arrow_schema::DataType::Duration(arrow_schema::TimeUnit::Nanosecond));
}

#[test]
fn dos_decisions_that_do_not_fit_are_rejected_and_the_sink_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    let classes = vec![DosClass::N, DosClass::S, DosClass::T];
    let shape = DosShape::new(classes.clone()).unwrap();
    let good = some_dos(&classes);
    let mut sink = ParquetSink::<DosDecision>::try_new(dir.path().join("dos.parquet"), shape)
        .unwrap()
        .with_row_group_size(2)
        .unwrap();
    sink.push(&good[0]).unwrap();
    let mut bad = good[1].clone();
    bad.decision.distances.pop();
    let e = sink.push(&bad).unwrap_err();
    assert!(matches!(e, Error::Record { .. }) && e.to_string().contains("2 distances"), "{e}");
    assert!(e.to_string().contains(&format!("frame {}", bad.seq)) && e.to_string().contains(r#"["n","s","t"]"#), "{e}");
    let mut bad = good[1].clone();
    bad.decision.posterior.push(0.0);
    let e = sink.push(&bad).unwrap_err();
    assert!(matches!(e, Error::Record { .. }) && e.to_string().contains("4 posteriors"), "{e}");
    let mut bad = good[1].clone();
    bad.decision.class = DosClass::Aw;
    let e = sink.push(&bad).unwrap_err();
    assert!(matches!(e, Error::Record { .. }) && e.to_string().contains("class aw"), "{e}");
    let mut bad = good[1].clone();
    bad.features.frames += 1;
    let e = sink.push(&bad).unwrap_err();
    assert!(matches!(e, Error::Record { .. }) && e.to_string().contains("frames"), "{e}");
    sink.push(&good[2]).unwrap();
    let r = read(&sink.finish().unwrap());
    assert_eq!(dos_keys(&dos_of(&r)), dos_keys(&[good[0].clone(), good[2].clone()]));
}

#[test]
fn dos_shapes_refuse_no_class_and_a_class_twice() {
    assert!(matches!(DosShape::new(vec![]), Err(Error::InvalidConfig(_))));
    assert!(matches!(DosShape::new(vec![DosClass::E, DosClass::E]), Err(Error::InvalidConfig(_))));
}

/// Raw counts of one sensor: rest ≈ 3 600, a press moving along the layout's x.
fn raw_frames(layout: &Layout, n: usize) -> Vec<TaxelFrame> {
    let positions = layout.positions();
    (0..n)
        .map(|k| {
            let cx = -8.0 + 16.0 * k as f64 / n as f64;
            let values = positions
                .iter()
                .map(|p| {
                    let d2 = (p[0] - cx).powi(2) + p[1].powi(2);
                    3600.0 - 400.0 * (-d2 / 20.0).exp() + (k % 3) as f64
                })
                .collect();
            TaxelFrame::new(SensorId::new("ff"), Timestamp::at_rate(k as u64, 100.0), k as u64, values)
        })
        .collect()
}

#[test]
fn the_dos_classifiers_decisions_come_back() {
    let cfg = DosFeatureConfig::default();
    let d = cfg.features.len();
    let samples: Vec<(DosClass, Vec<f64>)> = (0..9)
        .map(|i| {
            let class = [DosClass::N, DosClass::S, DosClass::T][i % 3];
            (class, (0..d).map(|j| (i % 3) as f64 + 0.1 * ((i + j) % 4) as f64).collect())
        })
        .collect();
    let model = DosModel::calibrate(cfg, &samples).unwrap();
    let shape = DosShape::from_model(&model).unwrap();
    assert_eq!(shape.classes(), model.classes.as_slice());
    let layout = Layout::biotac_sp();
    let mut stage = DosClassifier::try_new(model, &layout, Some(40)).unwrap();
    let mut out = Vec::new();
    for f in raw_frames(&layout, 100) {
        stage.push(f, &mut out).unwrap();
    }
    stage.finish(&mut out).unwrap();
    assert_eq!(out.iter().map(|d| d.frames).collect::<Vec<_>>(), [40, 40, 20]);
    let dir = tempfile::tempdir().unwrap();
    let r = read(&write(&dir.path().join("dos.parquet"), shape, &out, 2));
    assert_eq!(dos_of(&r), out);
}

// ---------------------------------------------------------------------------------------------
// archives: the types with a sensor and a time go to sensor-partitioned, rolled archives

/// `input` through a sensor-partitioned archive rolling every 5 rows; then, per sensor, the
/// files read back in name order and decoded with `of`, compared (by `key`) with that sensor's
/// records in input order.
fn archive_round_trip<T, K: PartialEq + std::fmt::Debug>(
    shape: T::Shape,
    input: &[T],
    of: impl Fn(&ReadBack) -> Vec<T>,
    key: impl Fn(&[T]) -> Vec<K>,
) where
    T: ArrowRecord + HasSensor + Timed + Clone + Send + 'static,
{
    let dir = tempfile::tempdir().unwrap();
    let mut archive = ParquetArchive::<T>::try_new(dir.path(), shape)
        .unwrap()
        .with_partitioning(Partitioning::Sensor)
        .unwrap()
        // the files keep their sensor column here, so each is read back on its own
        .with_partition_column(true)
        .unwrap()
        .with_roll_rows(5)
        .unwrap();
    for r in input {
        archive.push(r).unwrap();
    }
    let mut files = archive.finish().unwrap();
    files.sort();
    let mut sensors: Vec<String> = input.iter().map(|r| r.sensor().to_string()).collect();
    sensors.sort();
    sensors.dedup();
    for s in sensors {
        let part = dir.path().join(format!("sensor={s}"));
        let back: Vec<T> =
            files.iter().filter(|f| f.parent() == Some(part.as_path())).flat_map(|f| of(&read(f))).collect();
        let expected: Vec<T> = input.iter().filter(|r| r.sensor().as_str() == s).cloned().collect();
        assert_eq!(key(&back), key(&expected), "sensor {s}");
    }
}

#[test]
fn forces_servo_commands_and_dos_decisions_go_to_sensor_partitioned_archives() {
    archive_round_trip((), &some_forces(), forces_of, force_keys);
    archive_round_trip((), &some_servos(), servos_of, servo_keys);
    let classes = vec![DosClass::S, DosClass::T];
    archive_round_trip(DosShape::new(classes.clone()).unwrap(), &some_dos(&classes), dos_of, dos_keys);
}

// ---------------------------------------------------------------------------------------------
// proptests: any records → the same records back

fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![any::<u64>().prop_map(f64::from_bits), any::<f64>(), Just(f64::NAN), Just(-0.0)]
}

fn any_name() -> impl Strategy<Value = String> {
    prop_oneof![Just("ff".to_string()), Just("th".to_string()), "\\PC{0,12}"]
}

fn any_ts() -> impl Strategy<Value = Timestamp> {
    any::<i64>().prop_map(Timestamp)
}

fn any_slip_class() -> impl Strategy<Value = SlipClass> {
    proptest::sample::select(SlipClass::ALL.to_vec())
}

fn any_slip() -> impl Strategy<Value = SlipEvent> {
    (any_ts(), any_ts(), any_ts(), any_slip_class(), any_slip_class(), any_f64(), any_f64()).prop_map(
        |(time, onset, first_seen, class, previous, common_mm_s, differential_mm_s)| SlipEvent {
            time,
            onset,
            first_seen,
            class,
            previous,
            common_mm_s,
            differential_mm_s,
        },
    )
}

fn any_force() -> impl Strategy<Value = ForceEstimate> {
    (any_name(), any_ts(), any::<u64>(), any_f64(), proptest::option::of(any_f64())).prop_map(
        |(sensor, time, seq, area_mm2, force_n)| ForceEstimate {
            sensor: SensorId::new(sensor),
            time,
            seq,
            area_mm2,
            force_n,
        },
    )
}

fn any_servo() -> impl Strategy<Value = ServoCommand> {
    let motion = proptest::collection::vec(any_f64(), 7).prop_map(|v| {
        ServoAction::Move(Motion {
            offset_mm: [v[0], v[1]],
            distance_mm: v[2],
            direction: [v[3], v[4]],
            motion_mm: [v[5], v[6]],
        })
    });
    (any_name(), any_ts(), any::<u64>(), prop_oneof![Just(ServoAction::NoContact), motion])
        .prop_map(|(sensor, time, seq, action)| ServoCommand { sensor: SensorId::new(sensor), time, seq, action })
}

/// Distinct classes in any order, and decisions over them.
fn any_dos() -> impl Strategy<Value = (Vec<DosClass>, Vec<DosDecision>)> {
    Just(DosClass::ALL.to_vec()).prop_shuffle().prop_flat_map(|all| {
        (1usize..=7).prop_flat_map(move |k| {
            let classes = all[..k].to_vec();
            let decision = (
                (any_name(), any_ts(), any_ts(), any::<u64>(), any::<u64>(), any::<u64>()),
                proptest::sample::select(classes.clone()),
                proptest::collection::vec(any_f64(), k),
                proptest::collection::vec(any_f64(), k),
                proptest::collection::vec(any_f64(), Feature::ALL.len()),
            )
                .prop_map(|((sensor, start, end, seq, frames, events), class, distances, posterior, f)| DosDecision {
                    sensor: SensorId::new(sensor),
                    start,
                    end,
                    seq,
                    frames,
                    decision: Decision { class, distances, posterior },
                    features: FeatureVector { all: std::array::from_fn(|i| f[i]), frames, events },
                });
            (Just(classes), proptest::collection::vec(decision, 0..12))
        })
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn any_slip_events_come_back(
        input in proptest::collection::vec(any_slip(), 0..40),
        (first, second) in (any_name(), any_name()),
        row_group in 1usize..40,
    ) {
        let dir = tempfile::tempdir().unwrap();
        let shape = SlipShape::new(first.clone(), second.clone());
        let r = read(&write(&dir.path().join("s.parquet"), shape, &input, row_group));
        prop_assert_eq!(&r.schema.metadata()[SLIP_FIRST_KEY], &first);
        prop_assert_eq!(&r.schema.metadata()[SLIP_SECOND_KEY], &second);
        let (pairs, back) = slips_of(&r);
        prop_assert_eq!(slip_keys(&back), slip_keys(&input));
        prop_assert!(pairs.iter().all(|(a, b)| a == &first && b == &second));
    }

    #[test]
    fn any_force_estimates_come_back(input in proptest::collection::vec(any_force(), 0..40), row_group in 1usize..40) {
        let dir = tempfile::tempdir().unwrap();
        let r = read(&write(&dir.path().join("f.parquet"), (), &input, row_group));
        prop_assert_eq!(force_keys(&forces_of(&r)), force_keys(&input));
    }

    #[test]
    fn any_servo_commands_come_back(input in proptest::collection::vec(any_servo(), 0..40), row_group in 1usize..40) {
        let dir = tempfile::tempdir().unwrap();
        let r = read(&write(&dir.path().join("v.parquet"), (), &input, row_group));
        prop_assert_eq!(servo_keys(&servos_of(&r)), servo_keys(&input));
    }

    #[test]
    fn any_dos_decisions_come_back((classes, input) in any_dos(), row_group in 1usize..20) {
        let dir = tempfile::tempdir().unwrap();
        let shape = DosShape::new(classes).unwrap();
        let r = read(&write(&dir.path().join("d.parquet"), shape, &input, row_group));
        prop_assert_eq!(dos_keys(&dos_of(&r)), dos_keys(&input));
    }
}

// ---------------------------------------------------------------------------------------------
// pyarrow

/// pyarrow reads a file of each schema (every row, as Python sees it, equals what was
/// written), and two slip files of different pairs as one dataset.
#[test]
fn pyarrow_reads_every_task_schema() {
    use serde_json::{json, Value};
    // a scalar's absent value (NaN in Rust) is null in the files
    fn hn(x: f64) -> Value {
        if x.is_nan() {
            Value::Null
        } else {
            h(x)
        }
    }
    if !pyarrow_available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let slips = some_slips();
    let forces = some_forces();
    let servos = some_servos();
    let classes = vec![DosClass::N, DosClass::E, DosClass::T];
    let dos = some_dos(&classes);
    let paths = [
        write(&dir.path().join("slip.parquet"), SlipShape::new("ff", "th"), &slips, 16),
        write(&dir.path().join("force.parquet"), (), &forces, 16),
        write(&dir.path().join("servo.parquet"), (), &servos, 16),
        write(&dir.path().join("dos.parquet"), DosShape::new(classes.clone()).unwrap(), &dos, 16),
    ];
    let pairs = dir.path().join("pairs");
    std::fs::create_dir(&pairs).unwrap();
    write(&pairs.join("ff-th.parquet"), SlipShape::new("ff", "th"), &slips[..3], 16);
    write(&pairs.join("mf-th.parquet"), SlipShape::new("mf", "th"), &slips[3..5], 16);
    let script = format!(
        "{PY_DESCRIBE}{}",
        r#"
import pyarrow.dataset as ds
out = [describe(p) for p in sys.argv[2:]]
pairs = ds.dataset(sys.argv[1], format="parquet").to_table(columns=["first", "second", "time"])
pairs = pairs.set_column(2, "time", pairs.column("time").cast("int64")).to_pylist()
print(json.dumps({"files": out, "pairs": sorted((r["first"], r["second"], r["time"]) for r in pairs)}))
"#
    );
    let v = run_python(&script, std::iter::once(pairs.as_os_str()).chain(paths.iter().map(|p| p.as_os_str())));
    let files = &v["files"];

    // slip/1
    let s = &files[0];
    assert_eq!(s["schema"], "slip/2");
    assert_eq!(s["arrow_md"][SLIP_FIRST_KEY], "ff");
    assert_eq!(s["arrow_md"][SLIP_SECOND_KEY], "th");
    assert_eq!(s["types"]["class"], "string");
    let rows: Vec<Value> = slips
        .iter()
        .map(|e| {
            json!({"first": "ff", "second": "th", "time": e.time.as_nanos(), "onset": e.onset.as_nanos(),
                   "first_seen": e.first_seen.as_nanos(), "class": e.class.name(),
                   "previous": e.previous.name(), "common_mm_s": hn(e.common_mm_s),
                   "differential_mm_s": hn(e.differential_mm_s)})
        })
        .collect();
    assert_eq!(s["rows"], Value::Array(rows));

    // force/1
    let f = &files[1];
    assert_eq!(f["schema"], "force/2");
    let rows: Vec<Value> = forces
        .iter()
        .map(|e| {
            json!({"sensor": e.sensor.as_str(), "time": e.time.as_nanos(), "seq": e.seq,
                   "area_mm2": hn(e.area_mm2), "force_n": e.force_n.map(hn)})
        })
        .collect();
    assert_eq!(f["rows"], Value::Array(rows));

    // servo/1
    let c = &files[2];
    assert_eq!(c["schema"], "servo/2");
    let rows: Vec<Value> = servos
        .iter()
        .map(|c| {
            let m = c.motion();
            json!({"sensor": c.sensor.as_str(), "time": c.time.as_nanos(), "seq": c.seq,
                   "action": servo_action_name(&c.action),
                   "offset_x_mm": m.map(|m| hn(m.offset_mm[0])), "offset_y_mm": m.map(|m| hn(m.offset_mm[1])),
                   "distance_mm": m.map(|m| hn(m.distance_mm)),
                   "direction_x": m.map(|m| hn(m.direction[0])), "direction_y": m.map(|m| hn(m.direction[1])),
                   "motion_x_mm": m.map(|m| hn(m.motion_mm[0])), "motion_y_mm": m.map(|m| hn(m.motion_mm[1]))})
        })
        .collect();
    assert_eq!(c["rows"], Value::Array(rows));

    // dos/2
    let d = &files[3];
    assert_eq!(d["schema"], "dos/3");
    assert_eq!(d["arrow_md"][DOS_CLASSES_KEY], r#"["n","e","t"]"#);
    assert_eq!(d["types"]["posterior"], "fixed_size_list<item: double not null>[3]");
    let rows: Vec<Value> = dos
        .iter()
        .map(|d| {
            let mut o = json!({"sensor": d.sensor.as_str(), "start": d.start.as_nanos(),
                               "end": d.end.as_nanos(), "seq": d.seq, "frames": d.frames,
                               "events": d.features.events, "class": d.decision.class.as_str(),
                               "distances": hs(&d.decision.distances), "posterior": hs(&d.decision.posterior)});
            for f in Feature::ALL {
                o[f.name()] = hn(d.features.get(f));
            }
            o
        })
        .collect();
    assert_eq!(d["rows"], Value::Array(rows));

    // two pairs as one table: every row says which pair it is about
    let mut expected: Vec<Value> = slips[..3]
        .iter()
        .map(|e| json!(["ff", "th", e.time.as_nanos()]))
        .chain(slips[3..5].iter().map(|e| json!(["mf", "th", e.time.as_nanos()])))
        .collect();
    expected.sort_by_key(|v| v.to_string());
    let mut got = v["pairs"].as_array().unwrap().clone();
    got.sort_by_key(|v| v.to_string());
    assert_eq!(got, expected);
}
