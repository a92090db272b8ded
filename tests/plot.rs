//! `gradtac::plot`: every output schema renders to a PNG of the documented size with real
//! content, from Parquet files written by `ParquetSink` with the records of a simulated
//! trajectory run through the whole chain; an unknown schema, a file without gradtac metadata
//! and a non-Parquet file are refused with a clear error; archive directories (rolled,
//! partitioned) plot as one table, bad ones are refused; the demo's plain-data plots render.

use gradtac::io::archive::{ParquetArchive, Partitioning};
use gradtac::io::records::{FrameShape, SurfaceShape};
use gradtac::io::{ArrowRecord, ParquetSink};
use gradtac::plot::{
    plot_parquet, plot_slip_timeline, plot_surface_with_contours, plot_trajectory_vs_truth, PlotSummary, SurfacePanel,
    TimelineTrack,
};
use gradtac::stages::contour::{Contour, ContourConfig, ContourFrame};
use gradtac::stages::events::{Events, EventsConfig, Threshold};
use gradtac::stages::interpolate::{GridConfig, Interpolate, InterpolateConfig, Surface};
use gradtac::stages::savgol::{SavGol, SavGolConfig};
use gradtac::stages::sim::{GraspConfig, Scene, SensorModel, Simulator, Trajectory};
use gradtac::stages::slip::{Slip, SlipClass, SlipConfig};
use gradtac::stages::track::{Track, TrackConfig, TrackPoint};
use gradtac::stages::window::{Aggregate, Window, WindowAggregate, WindowConfig};
use gradtac::stages::EventBatch;
use gradtac::stream::{Keyed, Layout, SensorId, StageExt, TaxelFrame};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Everything one simulated circle produces, stage by stage.
struct Outputs {
    frames: Vec<TaxelFrame>,
    batches: Vec<EventBatch>,
    windows: Vec<WindowAggregate>,
    surfaces: Vec<Surface>,
    contours: Vec<ContourFrame>,
    points: Vec<TrackPoint>,
    truth: Vec<(f64, f64, f64)>,
}

fn simulate(layout: &Layout) -> Outputs {
    let sim = Simulator::try_new(layout.clone(), SensorModel::default(), 3).unwrap();
    let scene = Scene::trajectory(Trajectory::CircleCcw, 2.0, 4.0, layout);
    let rec = sim.run(&scene).unwrap();
    let frames = rec.taxel_frames();
    let truth = rec
        .frames
        .iter()
        .map(|f| {
            let c = f.truth.contact_mm.unwrap_or([f64::NAN; 2]);
            (f.frame.time.as_secs_f64(), c[0], c[1])
        })
        .collect();
    let mut sg = SavGol::try_with_rate(24, SavGolConfig::default(), 100.0).unwrap();
    let smoothed = sg.run_all(frames.clone()).unwrap();
    let mut ev =
        Events::try_new(24, EventsConfig { threshold: Threshold::Uniform(0.002), ..Default::default() }).unwrap();
    let batches = ev.run_all(smoothed).unwrap();
    let mut w =
        Window::try_new(&WindowConfig { frames: Some(10), aggregate: Aggregate::Count, ..Default::default() }).unwrap();
    let windows = w.run_all(batches.clone()).unwrap();
    let icfg = InterpolateConfig { grid: GridConfig { nx: 32, ..Default::default() }, ..Default::default() };
    let mut i = Interpolate::try_new(&icfg, layout).unwrap();
    let surfaces = i.run_all(windows.clone()).unwrap();
    let mut c = Contour::try_new(&ContourConfig { min_peak: 2.0, min_area_mm2: 30.0, ..Default::default() }).unwrap();
    let contours = c.run_all(surfaces.clone()).unwrap();
    let mut t = Track::try_new(&TrackConfig::default()).unwrap();
    let points = t.run_all(contours.clone()).unwrap();
    Outputs { frames, batches, windows, surfaces, contours, points, truth }
}

/// A fresh scratch directory, removed when the test ends (pass or fail).
struct Scratch(tempfile::TempDir);

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        self.0.path()
    }
}

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        self.0.path()
    }
}

impl Scratch {
    /// With `GRADTAC_KEEP_PLOTS` set, keep the directory (and say where) instead of removing it.
    fn keep_if_asked(self) {
        if std::env::var_os("GRADTAC_KEEP_PLOTS").is_some() {
            eprintln!("plots kept in {}", self.0.keep().display());
        }
    }
}

fn dir(name: &str) -> Scratch {
    Scratch(tempfile::Builder::new().prefix(&format!("gradtac-plot-{name}-")).tempdir().unwrap())
}

fn write<T: ArrowRecord>(path: &Path, shape: T::Shape, records: &[T], layout: Option<&Layout>) {
    let mut sink = ParquetSink::<T>::try_new(path, shape).unwrap().with_row_group_size(64).unwrap();
    if let Some(l) = layout {
        sink.set_metadata("gradtac.layout", l.to_csv());
    }
    for r in records {
        sink.push(r).unwrap();
    }
    sink.finish().unwrap();
}

/// Decode a PNG: (width, height, RGB bytes).
fn decode(path: &Path) -> (u32, u32, Vec<u8>) {
    let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = dec.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

/// The PNG has the summary's size, which is `want`, and real content: many colours and a
/// good share of non-white pixels (a blank or text-only image fails).
fn check_png(path: &Path, s: &PlotSummary, want: (u32, u32), min_ink: f64) {
    let (w, h, rgb) = decode(path);
    assert_eq!((w, h), (s.width, s.height), "{}", s.kind);
    assert_eq!((w, h), want, "{}", s.kind);
    let px: Vec<[u8; 3]> = rgb.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
    let ink = px.iter().filter(|p| **p != [255, 255, 255]).count() as f64 / px.len() as f64;
    let mut colours: Vec<[u8; 3]> = px.clone();
    colours.sort_unstable();
    colours.dedup();
    eprintln!("{}: {w}×{h}, {:.1} % ink, {} colours; {s}", s.kind, 100.0 * ink, colours.len());
    assert!(ink > min_ink, "{}: only {:.2} % of the pixels are drawn", s.kind, 100.0 * ink);
    assert!(colours.len() > 20, "{}: {} colours", s.kind, colours.len());
    assert!(!path.with_extension("png.partial").exists());
}

#[test]
fn every_schema_renders_a_png_of_the_documented_size() {
    let layout = Layout::biotac_sp();
    let o = simulate(&layout);
    assert!(o.points.iter().filter(|p| p.x_mm.is_finite()).count() > 100, "the chain found contacts");
    let d = dir("schemas");
    let shape = FrameShape::from_layout(&layout);
    let grid = o.surfaces[0].grid.clone();

    write(&d.join("frames.parquet"), shape.clone(), &o.frames, Some(&layout));
    write(&d.join("events.parquet"), shape.clone(), &o.batches, None);
    write(&d.join("window.parquet"), shape, &o.windows, None);
    write(&d.join("surface.parquet"), SurfaceShape::new(grid.clone()), &o.surfaces, Some(&layout));
    write(&d.join("contour.parquet"), (), &o.contours, None);
    write(&d.join("track.parquet"), (), &o.points, Some(&layout));

    let cases: [(&str, &str, (u32, u32), f64); 6] = [
        ("frames", "frame/2", (1200, 340), 0.05),
        ("events", "event/2", (1200, 340), 0.02),
        ("window", "window/2", (1320, 340), 0.3),
        ("surface", "surface/2", (4 * 380 + 120, 40 + 400), 0.3),
        ("contour", "contour/2", (1400, 620), 0.03),
        ("track", "track/3", (640 + 120, 680), 0.03),
    ];
    for (name, schema, size, ink) in cases {
        let png = d.join(format!("{name}.png"));
        let s = plot_parquet(&d.join(format!("{name}.parquet")), &png).unwrap();
        assert_eq!(s.kind, schema);
        assert_eq!(s.sensors, vec!["ff".to_string()]);
        assert!(s.rows > 0 && s.drawn > 0 && s.drawn <= s.rows.max(4), "{s}");
        check_png(&png, &s, size, ink);
    }
    // the surface plot drew 4 instants; the window plot one row per window
    let s = plot_parquet(&d.join("surface.parquet"), &d.join("surface.png")).unwrap();
    assert_eq!(s.drawn, 4);
    assert!(s.notes.iter().any(|n| n.contains("no scene in the file")), "{s}");
    // without layout metadata the built-in layout is used, and said so
    let s = plot_parquet(&d.join("contour.parquet"), &d.join("contour.png")).unwrap();
    assert!(s.notes.iter().any(|n| n.contains("BioTac SP")), "{s}");
    d.keep_if_asked();
}

/// Two sensors in one file: one panel each (the height doubles), both named.
#[test]
fn two_sensors_give_two_panels() {
    let layout = Layout::biotac_sp();
    let sim = Simulator::try_new(layout.clone(), SensorModel::default(), 5).unwrap();
    let rec = sim.run(&Scene::grasp(SlipClass::RotationalCw, &GraspConfig::default(), &layout)).unwrap();
    let d = dir("two");
    write(&d.join("frames.parquet"), FrameShape::from_layout(&layout), &rec.taxel_frames(), None);
    let s = plot_parquet(&d.join("frames.parquet"), &d.join("frames.png")).unwrap();
    assert_eq!(s.sensors, vec!["th".to_string(), "ff".to_string()]);
    check_png(&d.join("frames.png"), &s, (1200, 680), 0.05);
}

#[test]
fn unknown_or_foreign_files_are_refused_clearly() {
    use arrow_array::{Int64Array, RecordBatch};
    use arrow_schema::{DataType, Field, Schema};
    use parquet::arrow::ArrowWriter;
    use parquet::file::metadata::KeyValue;
    use parquet::file::properties::WriterProperties;

    let d = dir("unknown");
    let schema = Arc::new(Schema::new(vec![Field::new("x", DataType::Int64, false)]));
    let batch = RecordBatch::try_new(schema.clone(), vec![Arc::new(Int64Array::from(vec![1, 2, 3]))]).unwrap();
    for (name, kv) in [("bogus.parquet", Some("bogus/9")), ("plain.parquet", None)] {
        let props = WriterProperties::builder()
            .set_key_value_metadata(kv.map(|v| vec![KeyValue::new("gradtac.schema".into(), v.to_string())]))
            .build();
        let mut w =
            ArrowWriter::try_new(std::fs::File::create(d.join(name)).unwrap(), schema.clone(), Some(props)).unwrap();
        w.write(&batch).unwrap();
        w.close().unwrap();
    }
    let e = plot_parquet(&d.join("bogus.parquet"), &d.join("bogus.png")).unwrap_err().to_string();
    assert!(e.contains("unknown schema \"bogus/9\"") && e.contains("bogus.parquet"), "{e}");
    let e = plot_parquet(&d.join("plain.parquet"), &d.join("plain.png")).unwrap_err().to_string();
    assert!(e.contains("no `gradtac.schema` metadata"), "{e}");
    std::fs::write(d.join("text.parquet"), "not parquet").unwrap();
    let e = plot_parquet(&d.join("text.parquet"), &d.join("text.png")).unwrap_err().to_string();
    assert!(e.contains("not a readable Parquet file"), "{e}");
    let e = plot_parquet(&d.join("missing.parquet"), &d.join("m.png")).unwrap_err().to_string();
    assert!(e.contains("cannot open"), "{e}");
    assert!(!d.join("bogus.png").exists() && !d.join("plain.png").exists());
    // a file of a known schema with no rows: nothing to plot, said so
    let layout = Layout::biotac_sp();
    write::<TaxelFrame>(&d.join("empty.parquet"), FrameShape::from_layout(&layout), &[], None);
    let e = plot_parquet(&d.join("empty.parquet"), &d.join("empty.png")).unwrap_err().to_string();
    assert!(e.contains("without rows"), "{e}");
}

#[test]
fn demo_plots_from_plain_data() {
    let layout = Layout::biotac_sp();
    let o = simulate(&layout);
    let d = dir("demo");
    // surfaces at 4 instants with contact, with the stage's own maximal contours and the truth
    let with: Vec<usize> = (0..o.contours.len()).filter(|&k| o.contours[k].outcome.contact().is_some()).collect();
    let panels: Vec<SurfacePanel> = (0..4)
        .map(|i| {
            let k = with[i * (with.len() - 1) / 3];
            let s = &o.surfaces[k];
            let t = s.end.as_secs_f64();
            let truth = o.truth.iter().find(|p| (p.0 - t).abs() < 1e-9).map(|p| [p.1, p.2]);
            SurfacePanel {
                label: format!("t = {t:.2} s"),
                values: s.values.iter().copied().collect(),
                contour: o.contours[k].outcome.contact().map(|c| c.polygon.clone()),
                truth,
            }
        })
        .collect();
    let grid = o.surfaces[0].grid.clone();
    let s = plot_surface_with_contours(&grid, &panels, Some(&layout), "circle CCW", &d.join("surface.png")).unwrap();
    check_png(&d.join("surface.png"), &s, (1640, 440), 0.3);
    // a panel of the wrong size is an error, not a panic
    let bad = [SurfacePanel { label: "bad".into(), values: vec![0.0; 3], contour: None, truth: None }];
    assert!(plot_surface_with_contours(&grid, &bad, None, "x", &d.join("bad.png")).is_err());

    let track: Vec<(f64, f64, f64)> = o.points.iter().map(|p| (p.time.as_secs_f64(), p.x_mm, p.y_mm)).collect();
    let s = plot_trajectory_vs_truth(&track, &o.truth, &layout, &d.join("trajectory.png")).unwrap();
    check_png(&d.join("trajectory.png"), &s, (760, 680), 0.03);
    assert!(s.drawn > 100);

    // a slipping grasp through two keyed chains and the slip stage
    let sim = Simulator::try_new(layout.clone(), SensorModel { flip_fraction: 0.0, ..Default::default() }, 1).unwrap();
    let rec = sim.run(&Scene::grasp(SlipClass::LongitudinalUp, &GraspConfig::default(), &layout)).unwrap();
    let l2 = layout.clone();
    let mut keyed = Keyed::new(move |_: &SensorId| {
        let sg = SavGol::try_with_rate(24, SavGolConfig::default(), 100.0).unwrap();
        let ev =
            Events::try_new(24, EventsConfig { threshold: Threshold::Uniform(0.002), ..Default::default() }).unwrap();
        let w = Window::try_new(&WindowConfig { frames: Some(10), ..Default::default() }).unwrap();
        let icfg = InterpolateConfig {
            grid: GridConfig { nx: 32, ..Default::default() },
            incremental: true,
            ..Default::default()
        };
        let i = Interpolate::try_new(&icfg, &l2).unwrap();
        let c = Contour::try_new(&ContourConfig { min_peak: 2.0, min_area_mm2: 60.0, ..Default::default() }).unwrap();
        let t = Track::try_new(&TrackConfig::default()).unwrap();
        sg.then(ev).then(w).then(i).then(c).then(t)
    });
    let pts = keyed.run_all(rec.taxel_frames()).unwrap();
    let mut slip = Slip::try_new(&velocity_rule()).unwrap();
    let events = slip.run_all(pts.clone()).unwrap();
    assert!(events.iter().any(|e| e.class == SlipClass::LongitudinalUp), "{events:?}");
    let of = |s: &str| -> Vec<(f64, f64, f64)> {
        pts.iter().filter(|p| p.sensor.as_str() == s).map(|p| (p.time.as_secs_f64(), p.x_mm, p.y_mm)).collect()
    };
    let (th, ff) = (of("th"), of("ff"));
    let truth: Vec<(f64, SlipClass)> =
        rec.of_sensor("ff").map(|f| (f.frame.time.as_secs_f64(), f.truth.slip)).collect();
    let tracks = [TimelineTrack { sensor: "th", points: &th }, TimelineTrack { sensor: "ff", points: &ff }];
    let s = plot_slip_timeline(&tracks, &events, &truth, &d.join("slip.png")).unwrap();
    check_png(&d.join("slip.png"), &s, (1200, 700), 0.05);
    d.keep_if_asked();
}

/// Numerical extremes: NaN, ±∞, ±f64::MAX, a constant signal, a single row, an all-NaN
/// surface and a track without any contact all render (an image of the documented size),
/// never panic.
#[test]
fn extremes_render_without_panicking() {
    use gradtac::stages::interpolate::Grid;
    use gradtac::stream::{Extent, Timestamp};
    let layout = Layout::biotac_sp();
    let d = dir("extremes");
    let ff = SensorId::new("ff");
    let weird = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, f64::MAX, -f64::MAX, 0.0, -0.0, 5e-324];
    let frames: Vec<TaxelFrame> = (0..3u64)
        .map(|k| {
            let v = (0..24).map(|i| if i < 8 { weird[i] } else { 7.0 }).collect();
            TaxelFrame::new(ff.clone(), Timestamp(k as i64), k, v)
        })
        .collect();
    write(&d.join("frames.parquet"), FrameShape::from_layout(&layout), &frames, None);
    let s = plot_parquet(&d.join("frames.parquet"), &d.join("frames.png")).unwrap();
    assert_eq!((s.width, s.height), (1200, 340));
    // one row, constant
    write(&d.join("one.parquet"), FrameShape::from_layout(&layout), &frames[..1], None);
    assert_eq!(plot_parquet(&d.join("one.parquet"), &d.join("one.png")).unwrap().rows, 1);

    let grid = Arc::new(Grid::try_new(Extent { x_min: 0.0, x_max: 1.0, y_min: 0.0, y_max: 1.0 }, 4, 3).unwrap());
    let surfaces: Vec<Surface> = [f64::NAN, f64::INFINITY, 1.0]
        .iter()
        .enumerate()
        .map(|(k, &v)| Surface {
            sensor: ff.clone(),
            start: Timestamp(0),
            end: Timestamp(k as i64),
            seq: k as u64,
            grid: grid.clone(),
            values: ndarray::Array2::from_elem((3, 4), v),
        })
        .collect();
    write(&d.join("surface.parquet"), SurfaceShape::new(grid.clone()), &surfaces, None);
    let s = plot_parquet(&d.join("surface.parquet"), &d.join("surface.png")).unwrap();
    assert_eq!((s.width, s.height), (1640, 440));

    let o = simulate(&layout);
    let lost: Vec<TrackPoint> = o.points.iter().filter(|p| p.x_mm.is_nan()).take(20).cloned().collect();
    assert_eq!(lost.len(), 20);
    write(&d.join("track.parquet"), (), &lost, None);
    let s = plot_parquet(&d.join("track.parquet"), &d.join("track.png")).unwrap();
    assert_eq!((s.drawn, s.width, s.height), (0, 760, 680));
    let s = plot_trajectory_vs_truth(&[], &[], &layout, &d.join("empty.png")).unwrap();
    assert_eq!((s.width, s.height), (760, 680));
    let s = plot_slip_timeline(&[], &[], &[], &d.join("slip.png")).unwrap();
    assert_eq!((s.width, s.height), (1200, 700));
}

/// The task schemas: slip/1 (from a simulated slipping grasp through the chain and the slip
/// stage), force/1 and servo/1 (from the simulated circle's track), dos/2 (hand-made
/// decisions): each renders at its documented size with content.
#[test]
fn task_schemas_render() {
    use gradtac::io::records::{DosShape, SlipShape};
    use gradtac::stages::dos::{Decision, DosClass, DosDecision, FeatureVector};
    use gradtac::stages::force::ForceEstimate;
    use gradtac::stages::servo::{Motion, ServoAction, ServoCommand};
    use gradtac::stream::Timestamp;

    let layout = Layout::biotac_sp();
    let d = dir("tasks");
    let o = simulate(&layout);

    // slip/1
    let sim = Simulator::try_new(layout.clone(), SensorModel { flip_fraction: 0.0, ..Default::default() }, 2).unwrap();
    let rec = sim.run(&Scene::grasp(SlipClass::RotationalCcw, &GraspConfig::default(), &layout)).unwrap();
    let l2 = layout.clone();
    let mut keyed = Keyed::new(move |_: &SensorId| {
        let sg = SavGol::try_with_rate(24, SavGolConfig::default(), 100.0).unwrap();
        let ev =
            Events::try_new(24, EventsConfig { threshold: Threshold::Uniform(0.002), ..Default::default() }).unwrap();
        let w = Window::try_new(&WindowConfig { frames: Some(10), ..Default::default() }).unwrap();
        let icfg = InterpolateConfig { grid: GridConfig { nx: 32, ..Default::default() }, ..Default::default() };
        let i = Interpolate::try_new(&icfg, &l2).unwrap();
        let c = Contour::try_new(&ContourConfig { min_peak: 2.0, min_area_mm2: 60.0, ..Default::default() }).unwrap();
        sg.then(ev).then(w).then(i).then(c).then(Track::try_new(&TrackConfig::default()).unwrap())
    });
    let pts = keyed.run_all(rec.taxel_frames()).unwrap();
    let slips = Slip::try_new(&velocity_rule()).unwrap().run_all(pts).unwrap();
    assert!(!slips.is_empty());
    write(&d.join("slip.parquet"), SlipShape::new("ff", "th"), &slips, None);

    // force/1 and servo/1 from the circle's track
    let forces: Vec<ForceEstimate> = o
        .points
        .iter()
        .map(|p| ForceEstimate {
            sensor: p.sensor.clone(),
            time: p.time,
            seq: p.seq,
            area_mm2: p.area_mm2,
            force_n: p.area_mm2.is_finite().then_some(0.05 * p.area_mm2),
        })
        .collect();
    write(&d.join("force.parquet"), (), &forces, None);
    let [cx, cy] = layout.extent().centre();
    let servos: Vec<ServoCommand> = o
        .points
        .iter()
        .map(|p| {
            let action = if p.x_mm.is_finite() {
                let off = [p.x_mm - cx, p.y_mm - cy];
                let dist = off[0].hypot(off[1]);
                ServoAction::Move(Motion {
                    offset_mm: off,
                    distance_mm: dist,
                    direction: if dist > 0.0 { [off[0] / dist, off[1] / dist] } else { [0.0, 0.0] },
                    motion_mm: [0.5 * off[0], 0.5 * off[1]],
                })
            } else {
                ServoAction::NoContact
            };
            ServoCommand { sensor: p.sensor.clone(), time: p.time, seq: p.seq, action }
        })
        .collect();
    write(&d.join("servo.parquet"), (), &servos, None);

    // dos/2
    let classes = DosClass::ALL.to_vec();
    let decisions: Vec<DosDecision> = (0..40u64)
        .map(|j| {
            let c = (j as usize / 6) % classes.len();
            let mut posterior = vec![0.02; classes.len()];
            posterior[c] = 0.5 + 0.01 * j as f64;
            DosDecision {
                sensor: SensorId::new("ff"),
                start: Timestamp(j as i64 * 500_000_000),
                end: Timestamp(j as i64 * 500_000_000 + 490_000_000),
                seq: 50 * j + 49,
                frames: 50,
                decision: Decision { class: classes[c], distances: vec![1.0; classes.len()], posterior },
                features: FeatureVector { all: std::array::from_fn(|f| f as f64), frames: 50, events: 3 * j },
            }
        })
        .collect();
    write(&d.join("dos.parquet"), DosShape::new(classes).unwrap(), &decisions, None);

    for (name, schema, size, ink) in [
        ("slip", "slip/2", (1200, 560), 0.05),
        ("force", "force/2", (1200, 680), 0.03),
        ("servo", "servo/2", (1200, 680), 0.03),
        ("dos", "dos/3", (1200, 340), 0.02),
    ] {
        let png = d.join(format!("{name}.png"));
        let s = plot_parquet(&d.join(format!("{name}.parquet")), &png).unwrap();
        assert_eq!(s.kind, schema);
        assert!(s.drawn > 0, "{s}");
        check_png(&png, &s, size, ink);
    }
    d.keep_if_asked();
}

/// A long file of two interleaved sensors is decimated while reading (every 11th row, a prime,
/// so both sensors are sampled) and again for drawing; the summary counts every row.
#[test]
fn long_files_are_decimated_and_keep_every_sensor() {
    use gradtac::stream::Timestamp;
    let d = dir("long");
    let rows = 200_000u64;
    let shape = FrameShape::unnamed(4).unwrap();
    let mut sink = ParquetSink::<TaxelFrame>::try_new(d.join("long.parquet"), shape).unwrap();
    let (th, ff) = (SensorId::new("th"), SensorId::new("ff"));
    for k in 0..rows {
        let s = if k % 2 == 0 { &th } else { &ff };
        let t = (k / 2) as f64 * 0.01;
        let v = (0..4).map(|i| (t + i as f64).sin()).collect();
        sink.push(&TaxelFrame::new(s.clone(), Timestamp((k / 2) as i64 * 10_000_000), k / 2, v)).unwrap();
    }
    sink.finish().unwrap();
    let s = plot_parquet(&d.join("long.parquet"), &d.join("long.png")).unwrap();
    assert_eq!(s.rows, rows);
    assert_eq!(s.sensors, vec!["th".to_string(), "ff".to_string()]);
    assert!(s.notes.iter().any(|n| n.contains("every 11th of its 200000 rows")), "{s}");
    assert!(s.drawn <= 2 * gradtac::plot::MAX_POINTS as u64 && s.drawn > 10_000, "{s}");
    check_png(&d.join("long.png"), &s, (1200, 680), 0.05);
}

/// Rows of a Parquet file, from its footer.
fn parquet_rows(path: &Path) -> u64 {
    let b = parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(path).unwrap())
        .unwrap();
    b.metadata().file_metadata().num_rows() as u64
}

/// Write `frames` to an archive in `dir`, rolled every `roll_rows` records; the finished files.
fn archive(dir: &Path, frames: &[TaxelFrame], roll_rows: u64, partitioning: Partitioning) -> Vec<PathBuf> {
    let shape = FrameShape::from_layout(&Layout::biotac_sp());
    let mut a = ParquetArchive::<TaxelFrame>::try_new(dir, shape)
        .unwrap()
        .with_partitioning(partitioning)
        .unwrap()
        .with_roll_rows(roll_rows)
        .unwrap();
    for f in frames {
        a.push(f).unwrap();
    }
    a.finish().unwrap()
}

/// An archive directory plots as one table: rolled files and hive partitions (two sensors)
/// are all read, in order, the rows summed over the files; `.partial` and `_` files are
/// skipped (the garbage ones here would fail to parse).
#[test]
fn an_archive_directory_plots_as_one_table() {
    let layout = Layout::biotac_sp();
    let sim = Simulator::try_new(layout.clone(), SensorModel::default(), 5).unwrap();
    let frames =
        sim.run(&Scene::grasp(SlipClass::RotationalCw, &GraspConfig::default(), &layout)).unwrap().taxel_frames();
    assert!(frames.len() > 300, "{}", frames.len());
    let d = dir("archive");
    for (name, partitioning, sensors) in
        [("rolled", Partitioning::None, ["th", "ff"]), ("by-sensor", Partitioning::Sensor, ["ff", "th"])]
    {
        let a = d.join(name);
        let files = archive(&a, &frames, 100, partitioning);
        assert!(files.len() >= 4, "{name}: {files:?}");
        if partitioning == Partitioning::Sensor {
            assert!(
                a.join("sensor=ff/part-000000.parquet").exists() && a.join("sensor=th/part-000000.parquet").exists()
            );
        }
        let sum: u64 = files.iter().map(|f| parquet_rows(f)).sum();
        assert_eq!(sum, frames.len() as u64);
        std::fs::write(a.join(".part-000999.parquet.partial"), "half written").unwrap();
        std::fs::write(a.join("_SUCCESS"), "").unwrap();
        std::fs::write(a.join("_metadata.parquet"), "not parquet").unwrap();
        let png = d.join(format!("{name}.png"));
        let s = plot_parquet(&a, &png).unwrap();
        assert_eq!(s.kind, "frame/2", "{s}");
        assert_eq!(s.rows, sum, "{s}");
        assert_eq!(s.sensors, sensors.map(String::from).to_vec(), "{s}");
        let note = format!("archive: {} Parquet files read as one table", files.len());
        assert!(s.notes.contains(&note), "{s}");
        check_png(&png, &s, (1200, 680), 0.05);
    }
}

/// Decimation counts the rows of all the archive's files: every 11th row of the whole table,
/// across file boundaries (per-file restarts would read 10 002 rows here, not 10 000).
#[test]
fn a_long_archive_is_decimated_over_all_its_files() {
    use gradtac::stream::Timestamp;
    let d = dir("long-archive");
    let rows = 110_000u64;
    let mut a = ParquetArchive::<TaxelFrame>::try_new(&d, FrameShape::unnamed(4).unwrap())
        .unwrap()
        .with_roll_rows(25_000)
        .unwrap();
    let (th, ff) = (SensorId::new("th"), SensorId::new("ff"));
    for k in 0..rows {
        let s = if k % 2 == 0 { &th } else { &ff };
        let t = (k / 2) as f64 * 0.01;
        let v = (0..4).map(|i| (t + i as f64).sin()).collect();
        a.push(&TaxelFrame::new(s.clone(), Timestamp((k / 2) as i64 * 10_000_000), k / 2, v)).unwrap();
    }
    assert_eq!(a.finish().unwrap().len(), 5);
    let s = plot_parquet(&d, &d.with_extension("png")).unwrap();
    assert_eq!(s.rows, rows);
    assert_eq!(s.sensors, vec!["th".to_string(), "ff".to_string()]);
    assert!(s.notes.iter().any(|n| n.contains("every 11th of its 110000 rows")), "{s}");
    assert!(s.notes.iter().any(|n| n.contains("archive: 5 Parquet files")), "{s}");
    assert_eq!(s.drawn, rows.div_ceil(11), "{s}");
    check_png(&d.with_extension("png"), &s, (1200, 680), 0.05);
    std::fs::remove_file(d.with_extension("png")).unwrap();
}

/// An empty directory, one with only unfinished files, and one whose files differ in schema
/// or columns are refused, naming the directory and the file at fault.
#[test]
fn bad_archive_directories_are_refused_clearly() {
    let d = dir("bad-archive");
    let shape = FrameShape::from_layout(&Layout::biotac_sp());

    let empty = d.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let e = plot_parquet(&empty, &d.join("empty.png")).unwrap_err().to_string();
    assert!(e.contains("empty directory") && e.contains(&*empty.to_string_lossy()), "{e}");

    let partial = d.join("partial");
    std::fs::create_dir_all(&partial).unwrap();
    std::fs::write(partial.join(".part-000000.parquet.partial"), "half").unwrap();
    let e = plot_parquet(&partial, &d.join("partial.png")).unwrap_err().to_string();
    assert!(e.contains("unfinished") && e.contains("no finished Parquet file"), "{e}");
    assert!(e.contains(&*partial.to_string_lossy()), "{e}");

    let mixed = d.join("mixed");
    std::fs::create_dir_all(&mixed).unwrap();
    let sim = Simulator::try_new(Layout::biotac_sp(), SensorModel::default(), 3).unwrap();
    let frames =
        sim.run(&Scene::trajectory(Trajectory::CircleCcw, 2.0, 4.0, &Layout::biotac_sp())).unwrap().taxel_frames();
    write(&mixed.join("a-frames.parquet"), shape.clone(), &frames, None);
    write::<EventBatch>(&mixed.join("b-events.parquet"), shape.clone(), &[], None);
    let e = plot_parquet(&mixed, &d.join("mixed.png")).unwrap_err().to_string();
    assert!(e.contains(&*mixed.to_string_lossy()), "{e}");
    assert!(e.contains("b-events.parquet: schema event/2 differs from frame/2 of a-frames.parquet"), "{e}");

    let columns = d.join("columns");
    std::fs::create_dir_all(columns.join("sensor=th")).unwrap();
    write(&columns.join("part-000000.parquet"), shape, &frames, None);
    let narrow: Vec<TaxelFrame> =
        frames.iter().map(|f| TaxelFrame { values: f.values[..3].to_vec(), ..f.clone() }).collect();
    write(&columns.join("sensor=th/part-000000.parquet"), FrameShape::unnamed(3).unwrap(), &narrow, None);
    let e = plot_parquet(&columns, &d.join("columns.png")).unwrap_err().to_string();
    assert!(e.contains("other columns") && e.contains("part-000000.parquet"), "{e}");
    assert!(e.contains(&*std::path::Path::new("sensor=th").join("part-000000.parquet").to_string_lossy()), "{e}");
    assert!(!d.join("mixed.png").exists() && !d.join("columns.png").exists());
}

/// `gradtac plot <dir>` plots an archive and writes `<dir>.png` beside it by default (also for
/// a path ending in `/.`).
#[test]
fn the_cli_plots_an_archive_directory_beside_it() {
    let layout = Layout::biotac_sp();
    let sim = Simulator::try_new(layout.clone(), SensorModel::default(), 3).unwrap();
    let frames = sim.run(&Scene::trajectory(Trajectory::CircleCcw, 2.0, 4.0, &layout)).unwrap().taxel_frames();
    let d = dir("cli-archive");
    let a = d.join("run.archive");
    let files = archive(&a, &frames, 50, Partitioning::Sensor);
    for input in [a.clone(), a.join(".")] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_gradtac")).arg("plot").arg(&input).output().unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
        assert!(stdout.contains(&format!("frame/2: {} rows", frames.len())), "{stdout}");
        assert!(stdout.contains(&format!("archive: {} Parquet files read as one table", files.len())), "{stdout}");
        let png = d.join("run.archive.png");
        assert!(stdout.contains(&*png.to_string_lossy()), "{stdout}");
        assert_eq!(decode(&png).0, 1200);
        std::fs::remove_file(&png).unwrap();
    }
}

// ---------------------------------------------------------------------------------------------
// formats, options, old schema versions, codecs, partitioned archives

/// Frames of two sensors, 100 Hz, with a contact pressing `e3`, as a frame/2 file.
fn two_sensor_frames(d: &Path) -> PathBuf {
    let layout = Layout::biotac_sp();
    let frames: Vec<TaxelFrame> = (0..400u64)
        .map(|k| {
            let sensor = if k % 2 == 0 { "ff" } else { "th" };
            let mut v: Vec<f64> = (0..24).map(|i| 1000.0 + i as f64).collect();
            v[2] += 50.0 * ((k as f64) * 0.05).sin();
            TaxelFrame::new(SensorId::new(sensor), gradtac::stream::Timestamp::at_rate(k / 2, 100.0), k / 2, v)
        })
        .collect();
    let p = d.join("frames.parquet");
    write(&p, FrameShape::from_layout(&layout), &frames, Some(&layout));
    p
}

#[test]
fn svg_or_png_by_the_output_extension() {
    let d = dir("formats");
    let input = two_sensor_frames(&d);
    for name in ["frames.svg", "frames.SVG"] {
        let s = plot_parquet(&input, &d.join(name)).unwrap();
        let text = std::fs::read_to_string(d.join(name)).unwrap();
        assert!(text.starts_with("<svg") || text.starts_with("<?xml"), "{name}: {}", &text[..40.min(text.len())]);
        assert!(text.trim_end().ends_with("</svg>"), "{name}: a complete SVG");
        assert!(text.contains(&format!("width=\"{}\"", s.width)), "{name}: its size");
        // text stays text, titles carry no schema id
        assert!(text.contains("<text") && text.contains("ff: 24 taxels"), "{name}");
        assert!(!text.contains("frame/2") && !text.contains("frame/1"), "{name}: no schema id in the figure");
    }
    for name in ["frames.png", "frames.image"] {
        plot_parquet(&input, &d.join(name)).unwrap();
        let bytes = std::fs::read(d.join(name)).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{name}: PNG magic");
    }
    assert!(!d.join("frames.svg.partial").exists());
}

#[test]
fn sensor_and_time_options_choose_the_rows() {
    use gradtac::plot::{plot_parquet_with, PlotOptions};
    let d = dir("options");
    let input = two_sensor_frames(&d);
    let all = plot_parquet(&input, &d.join("all.png")).unwrap();
    assert_eq!(all.sensors, vec!["ff".to_string(), "th".to_string()]);
    let opts = PlotOptions { sensors: vec!["th".into()], from: Some(0.5), to: Some(1.0) };
    let s = plot_parquet_with(&input, &d.join("th.svg"), &opts).unwrap();
    assert_eq!(s.sensors, vec!["th".to_string()]);
    // th's frames at 0.50, 0.51, …, 1.00 s: 51 rows
    assert_eq!(s.drawn, 51, "{s}");
    assert!(s.notes.iter().any(|n| n.contains("51 of 400 rows")), "{s}");
    assert_eq!(s.height, 340, "one panel");
    let e =
        plot_parquet_with(&input, &d.join("x.png"), &PlotOptions { sensors: vec!["mf".into()], ..Default::default() })
            .unwrap_err()
            .to_string();
    assert!(e.contains("--sensor mf") && e.contains("ff, th"), "{e}");
    let e = plot_parquet_with(
        &input,
        &d.join("x.png"),
        &PlotOptions { from: Some(9.0), to: Some(1.0), ..Default::default() },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("--from 9 s is after --to 1 s"), "{e}");
    let e = plot_parquet_with(&input, &d.join("x.png"), &PlotOptions { from: Some(100.0), ..Default::default() })
        .unwrap_err()
        .to_string();
    assert!(e.contains("no row left"), "{e}");
    // the CLI passes them on
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_gradtac"))
        .args(["plot", input.to_str().unwrap(), "-o", d.join("cli.svg").to_str().unwrap(), "--sensor", "ff"])
        .args(["--from", "0", "--to", "0.2"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::read_to_string(d.join("cli.svg")).unwrap().starts_with("<svg"));
    assert!(String::from_utf8_lossy(&out.stdout).contains("sensors [ff]"));
}

/// A file as version-1 writers wrote it: `Int64` ns times named `*_ns`, NaN for no contact,
/// `vx_mm_s` / `vy_mm_s`, 0-based event taxels.
fn write_v1(path: &Path, schema_id: &str, columns: Vec<(&str, arrow_array::ArrayRef)>, taxels: Option<usize>) {
    use arrow_schema::{Field, Schema};
    use parquet::arrow::ArrowWriter;
    use parquet::file::metadata::KeyValue;
    use parquet::file::properties::WriterProperties;
    let fields: Vec<Field> = columns
        .iter()
        .map(|(n, c)| {
            let f = Field::new(*n, c.data_type().clone(), true);
            match taxels.filter(|_| *n == "taxel") {
                Some(k) => f.with_metadata(std::collections::HashMap::from([(
                    "gradtac.taxels".to_string(),
                    serde_json::to_string(&Layout::biotac_sp().names()[..k]).unwrap(),
                )])),
                None => f,
            }
        })
        .collect();
    let schema = Arc::new(Schema::new(fields));
    let batch = arrow_array::RecordBatch::try_new(schema.clone(), columns.into_iter().map(|c| c.1).collect()).unwrap();
    let props = WriterProperties::builder()
        .set_key_value_metadata(Some(vec![KeyValue::new("gradtac.schema".into(), schema_id.to_string())]))
        .build();
    let mut w = ArrowWriter::try_new(std::fs::File::create(path).unwrap(), schema, Some(props)).unwrap();
    w.write(&batch).unwrap();
    w.close().unwrap();
}

#[test]
fn version_1_files_still_plot() {
    use arrow_array::{
        ArrayRef, BooleanArray, Float64Array, Int64Array, Int8Array, StringArray, UInt16Array, UInt64Array,
    };
    let d = dir("v1");
    let n = 200;
    let t: ArrayRef = Arc::new(Int64Array::from_iter_values((0..n).map(|k| k * 10_000_000)));
    let sensor: ArrayRef = Arc::new(StringArray::from(vec!["ff"; n as usize]));
    let seq: ArrayRef = Arc::new(UInt64Array::from_iter_values(0..n as u64));
    let x: ArrayRef = Arc::new(Float64Array::from_iter_values((0..n).map(|k| {
        if k % 7 == 0 {
            f64::NAN
        } else {
            (k as f64 * 0.1).sin() * 5.0
        }
    })));
    let y: ArrayRef = Arc::new(Float64Array::from_iter_values((0..n).map(|k| (k as f64 * 0.1).cos() * 3.0)));
    let v: ArrayRef = Arc::new(Float64Array::from_iter((0..n).map(|k| (k > 0).then_some(1.0))));
    write_v1(
        &d.join("track.parquet"),
        "track/1",
        vec![
            ("sensor", sensor.clone()),
            ("time_ns", t.clone()),
            ("start_ns", t.clone()),
            ("seq", seq.clone()),
            ("x_mm", x.clone()),
            ("y_mm", y),
            ("vx_mm_s", v.clone()),
            ("vy_mm_s", v),
            ("gated", Arc::new(BooleanArray::from(vec![false; n as usize]))),
        ],
        None,
    );
    let s = plot_parquet(&d.join("track.parquet"), &d.join("track.svg")).unwrap();
    assert_eq!((s.kind.as_str(), s.rows), ("track/1", n as u64), "{s}");
    // event/1: taxel 0-based; the raster puts taxel index 23 (e24) in range
    write_v1(
        &d.join("events.parquet"),
        "event/1",
        vec![
            ("sensor", sensor),
            ("time_ns", t.clone()),
            ("frame_time_ns", t),
            ("seq", seq),
            ("taxel", Arc::new(UInt16Array::from_iter_values((0..n).map(|k| (k % 24) as u16)))),
            ("polarity", Arc::new(Int8Array::from_iter_values((0..n).map(|k| if k % 2 == 0 { 1 } else { -1 })))),
        ],
        Some(24),
    );
    let s = plot_parquet(&d.join("events.parquet"), &d.join("events.png")).unwrap();
    assert_eq!((s.kind.as_str(), s.drawn), ("event/1", n as u64), "{s}");
}

#[test]
fn snappy_gzip_and_lz4_files_are_read() {
    use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
    use parquet::arrow::ArrowWriter;
    use parquet::basic::{Compression, GzipLevel};
    use parquet::file::properties::WriterProperties;
    let d = dir("codecs");
    let input = two_sensor_frames(&d);
    // the sink's file, rewritten with each codec (metadata kept), as pyarrow or Spark would
    let reader = ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(&input).unwrap()).unwrap();
    let kv = reader.metadata().file_metadata().key_value_metadata().cloned();
    let schema = reader.schema().clone();
    let batches: Vec<_> = reader.build().unwrap().collect::<Result<_, _>>().unwrap();
    for (name, c) in [
        ("snappy", Compression::SNAPPY),
        ("gzip", Compression::GZIP(GzipLevel::default())),
        ("lz4", Compression::LZ4_RAW),
        ("lz4-hadoop", Compression::LZ4),
    ] {
        let p = d.join(format!("{name}.parquet"));
        let props = WriterProperties::builder().set_compression(c).set_key_value_metadata(kv.clone()).build();
        let mut w = ArrowWriter::try_new(std::fs::File::create(&p).unwrap(), schema.clone(), Some(props)).unwrap();
        for b in &batches {
            w.write(b).unwrap();
        }
        w.close().unwrap();
        let s = plot_parquet(&p, &d.join(format!("{name}.png"))).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(s.rows, 400, "{name}");
    }
}

#[test]
fn partitioned_archives_take_the_sensor_from_the_directory() {
    let layout = Layout::biotac_sp();
    let d = dir("partitioned");
    let frames: Vec<TaxelFrame> = (0..300u64)
        .map(|k| {
            let s = ["ff", "th", "left hand/mf"][(k % 3) as usize];
            TaxelFrame::new(SensorId::new(s), gradtac::stream::Timestamp::at_rate(k, 100.0), k, vec![k as f64; 24])
        })
        .collect();
    let mut a = ParquetArchive::<TaxelFrame>::try_new(d.join("arch"), FrameShape::from_layout(&layout))
        .unwrap()
        .with_partitioning(Partitioning::Sensor)
        .unwrap()
        .with_roll_rows(40)
        .unwrap();
    for f in &frames {
        a.push(f).unwrap();
    }
    let files = a.finish().unwrap();
    assert!(files.len() >= 6);
    let s = plot_parquet(&d.join("arch"), &d.join("arch.svg")).unwrap();
    assert_eq!(s.rows, 300);
    let mut sensors = s.sensors.clone();
    sensors.sort();
    assert_eq!(sensors, vec!["ff".to_string(), "left hand/mf".to_string(), "th".to_string()], "{s}");
    let opts = gradtac::plot::PlotOptions { sensors: vec!["left hand/mf".into()], ..Default::default() };
    let s = gradtac::plot::plot_parquet_with(&d.join("arch"), &d.join("mf.png"), &opts).unwrap();
    assert_eq!(s.drawn, 100, "{s}");
}

/// The track-velocity slip rule these plots were drawn with (event-contour tracks of the old
/// simulator; the displacement default is measured in `tests/slip_family.rs`).
fn velocity_rule() -> SlipConfig {
    SlipConfig { method: gradtac::stages::slip::SlipMethod::Velocity, min_duration_s: 0.08, ..SlipConfig::default() }
}
