//! Round trips of every stage output schema (`event/1`, `window/1`, `surface/1`, `contour/1`,
//! `track/1`) through `ParquetSink` and the Parquet reader, bit-exact; proptests for events,
//! windows, contours and tracks; rejection of records that do not fit the sink's shape; and
//! (when installed) pyarrow reading one file of each kind.

use arrow_array::cast::AsArray;
use arrow_array::types::{Float64Type, Int8Type, UInt16Type};
use arrow_array::{Array, RecordBatch};
use gradtac_io::records::frame::TAXELS_KEY;
use gradtac_io::records::surface::GRID_KEY;
use gradtac_io::records::{EventShape, SurfaceShape, WindowShape};
use gradtac_io::{Error, ParquetSink};
use gradtac_stages::contour::{ContourFrame, ContourOutcome, MaxContour, NoContact};
use gradtac_stages::interpolate::{Grid, Surface};
use gradtac_stages::track::{ContactState, TrackPoint};
use gradtac_stages::window::{Aggregate, Split, WindowAggregate};
use gradtac_stages::{EventBatch, TactileEvent};
use gradtac_stream::{Extent, Layout, SensorId, Timestamp};
use ndarray::{Array2, ShapeBuilder};
use proptest::prelude::*;
use std::sync::Arc;

mod common;
use common::*;

// ---------------------------------------------------------------------------------------------
// reading (the shared helpers are in `common`)

fn bools(b: &RecordBatch, name: &str) -> Vec<Option<bool>> {
    col(b, name).as_boolean().iter().collect()
}

/// A `List<FixedSizeList<Float64>[2]>` value as points.
fn ring(a: &dyn Array) -> Vec<[f64; 2]> {
    let points = a.as_fixed_size_list();
    assert_eq!(points.value_length(), 2);
    let flat = points.values().as_primitive::<Float64Type>();
    assert_eq!(points.null_count(), 0);
    let off = points.offset() * 2;
    (0..points.len()).map(|i| [flat.value(off + 2 * i), flat.value(off + 2 * i + 1)]).collect()
}

fn pbits(v: &[[f64; 2]]) -> Vec<[u64; 2]> {
    v.iter().map(|p| [p[0].to_bits(), p[1].to_bits()]).collect()
}

// ---------------------------------------------------------------------------------------------
// event/1

fn batch(sensor: &str, time: i64, seq: u64, taxels: u16, events: &[(i64, u16, i8)]) -> EventBatch {
    EventBatch {
        sensor: SensorId::new(sensor),
        time: Timestamp(time),
        seq,
        taxels,
        events: events
            .iter()
            .map(|&(t, taxel, polarity)| TactileEvent { time: Timestamp(t), taxel, polarity })
            .collect(),
    }
}

type EventRow = (String, i64, i64, u64, u16, i8);

fn event_rows(r: &ReadBack) -> Vec<EventRow> {
    let mut out = Vec::new();
    for b in &r.batches {
        let sensor = strs(b, "sensor");
        let (t, ft) = (i64s(b, "time"), i64s(b, "frame_time"));
        let seq = opt_u64s(b, "seq");
        let taxel = col(b, "taxel").as_primitive::<UInt16Type>().values().to_vec();
        let pol = col(b, "polarity").as_primitive::<Int8Type>().values().to_vec();
        for i in 0..b.num_rows() {
            // the column numbers taxels from 1; the rows here hold the 0-based index
            assert!(taxel[i] >= 1, "taxel numbers count from 1");
            out.push((sensor[i].clone().unwrap(), t[i], ft[i], seq[i].unwrap(), taxel[i] - 1, pol[i]));
        }
    }
    out
}

fn rows_of(batches: &[EventBatch]) -> Vec<EventRow> {
    batches
        .iter()
        .flat_map(|b| {
            b.events
                .iter()
                .map(|e| (b.sensor.to_string(), e.time.as_nanos(), b.time.as_nanos(), b.seq, e.taxel, e.polarity))
        })
        .collect()
}

/// Rows back into batches: consecutive rows of one (sensor, frame time, seq) form one batch;
/// the taxel count is the length of the `gradtac.taxels` metadata.
fn events_of(r: &ReadBack) -> Vec<EventBatch> {
    let names: Vec<String> =
        serde_json::from_str(&r.schema().field_with_name("taxel").unwrap().metadata()[TAXELS_KEY]).unwrap();
    let mut out: Vec<EventBatch> = Vec::new();
    for (s, t, ft, seq, taxel, polarity) in event_rows(r) {
        let e = TactileEvent { time: Timestamp(t), taxel, polarity };
        match out.last_mut() {
            Some(b) if b.sensor.as_str() == s && b.time.as_nanos() == ft && b.seq == seq => b.events.push(e),
            _ => out.push(batch(&s, ft, seq, names.len() as u16, &[]).with(e)),
        }
    }
    out
}

trait With {
    fn with(self, e: TactileEvent) -> Self;
}
impl With for EventBatch {
    fn with(mut self, e: TactileEvent) -> Self {
        self.events.push(e);
        self
    }
}

/// What `events_of` should give for `input`: empty batches dropped, consecutive batches of one
/// (sensor, time, seq) merged.
fn expected_events(input: &[EventBatch]) -> Vec<EventBatch> {
    let mut out: Vec<EventBatch> = Vec::new();
    for b in input.iter().filter(|b| !b.events.is_empty()) {
        match out.last_mut() {
            Some(o) if o.sensor == b.sensor && o.time == b.time && o.seq == b.seq => o.events.extend(&b.events),
            _ => out.push(b.clone()),
        }
    }
    out
}

fn some_events() -> Vec<EventBatch> {
    (0..40u64)
        .map(|k| {
            let t = k as i64 * 10_000_000 - 5;
            let events: Vec<(i64, u16, i8)> = (0..(k % 4))
                .map(|j| {
                    (t - 3_000_000 + j as i64 * 1000, ((k + j) % 24) as u16, if (k + j) % 3 == 0 { -1 } else { 1 })
                })
                .collect();
            batch(if k % 5 == 0 { "th" } else { "ff" }, t, k, 24, &events)
        })
        .collect()
}

#[test]
fn events_round_trip_one_row_per_event() {
    let dir = tempfile::tempdir().unwrap();
    let layout = Layout::biotac_sp();
    let input = some_events();
    let path = write(&dir.path().join("events.parquet"), EventShape::from_layout(&layout), &input, 7);
    let r = read(&path);
    assert_eq!(schema_id(&r), "event/2");
    assert_eq!(r.kv["gradtac.version"], env!("CARGO_PKG_VERSION"));
    let n_events: usize = input.iter().map(|b| b.events.len()).sum();
    assert_eq!(r.batches.iter().map(RecordBatch::num_rows).sum::<usize>(), n_events);
    assert_eq!(event_rows(&r), rows_of(&input));
    assert_eq!(events_of(&r), expected_events(&input));
    let names: Vec<String> =
        serde_json::from_str(&r.schema().field_with_name("taxel").unwrap().metadata()[TAXELS_KEY]).unwrap();
    assert_eq!(names, layout.names());
    for t in ["time", "frame_time"] {
        assert_eq!(
            r.schema().field_with_name(t).unwrap().data_type(),
            &arrow_schema::DataType::Duration(arrow_schema::TimeUnit::Nanosecond),
            "{t}"
        );
    }
}

#[test]
fn events_with_a_bad_taxel_are_rejected_and_the_sink_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    let mut sink = ParquetSink::<EventBatch>::try_new(dir.path().join("e.parquet"), EventShape::unnamed(3).unwrap())
        .unwrap()
        .with_row_group_size(2)
        .unwrap();
    sink.push(&batch("ff", 10, 1, 3, &[(5, 0, 1), (6, 2, -1)])).unwrap();
    // taxel index beyond the count, in an otherwise good batch: nothing of it is written
    let e = sink.push(&batch("ff", 20, 2, 3, &[(15, 1, 1), (16, 3, 1)])).unwrap_err();
    assert!(matches!(e, Error::Record { .. }), "{e}");
    assert!(e.to_string().contains("taxel 3") && e.to_string().contains("frame 2"), "{e}");
    // another taxel count
    let e = sink.push(&batch("ff", 30, 3, 24, &[(25, 1, 1)])).unwrap_err();
    assert!(matches!(e, Error::Record { .. }) && e.to_string().contains("24 taxels"), "{e}");
    sink.push(&batch("ff", 40, 4, 3, &[(35, 1, -1)])).unwrap();
    let r = read(&sink.finish().unwrap());
    assert_eq!(
        event_rows(&r),
        vec![("ff".into(), 5, 10, 1, 0, 1), ("ff".into(), 6, 10, 1, 2, -1), ("ff".into(), 35, 40, 4, 1, -1)]
    );
}

#[test]
fn an_event_file_of_empty_batches_has_no_rows() {
    let dir = tempfile::tempdir().unwrap();
    let input: Vec<EventBatch> = (0..5).map(|k| batch("ff", k, k as u64, 3, &[])).collect();
    let path = write(&dir.path().join("e.parquet"), EventShape::unnamed(3).unwrap(), &input, 10);
    let r = read(&path);
    assert_eq!(schema_id(&r), "event/2");
    assert_eq!(r.batches.iter().map(RecordBatch::num_rows).sum::<usize>(), 0);
}

// ---------------------------------------------------------------------------------------------
// window/1

fn windows_of(r: &ReadBack) -> Vec<WindowAggregate> {
    let mut out = Vec::new();
    for b in &r.batches {
        let sensor = strs(b, "sensor");
        let (start, end) = (i64s(b, "start"), i64s(b, "end"));
        let (seq, frames) = (opt_u64s(b, "seq"), opt_u64s(b, "frames"));
        let aggregate = strs(b, "aggregate");
        let (values, pos, neg) =
            (opt_f64_lists(b, "values"), opt_f64_lists(b, "positive"), opt_f64_lists(b, "negative"));
        for i in 0..b.num_rows() {
            assert_eq!(pos[i].is_some(), neg[i].is_some(), "positive and negative are null together");
            out.push(WindowAggregate {
                sensor: SensorId::new(sensor[i].as_deref().unwrap()),
                start: Timestamp(start[i]),
                end: Timestamp(end[i]),
                seq: seq[i].unwrap(),
                frames: frames[i].unwrap(),
                aggregate: match aggregate[i].as_deref().unwrap() {
                    "signed" => Aggregate::Signed,
                    "count" => Aggregate::Count,
                    "split" => Aggregate::Split,
                    other => panic!("aggregate {other}"),
                },
                values: values[i].clone().unwrap(),
                split: pos[i].clone().map(|positive| Split { positive, negative: neg[i].clone().unwrap() }),
            });
        }
    }
    out
}

type WindowKey = (String, i64, i64, u64, u64, Aggregate, Vec<u64>, Option<(Vec<u64>, Vec<u64>)>);

fn window_keys(w: &[WindowAggregate]) -> Vec<WindowKey> {
    w.iter()
        .map(|w| {
            (
                w.sensor.to_string(),
                w.start.as_nanos(),
                w.end.as_nanos(),
                w.seq,
                w.frames,
                w.aggregate,
                bits(&w.values),
                w.split.as_ref().map(|s| (bits(&s.positive), bits(&s.negative))),
            )
        })
        .collect()
}

fn some_windows(n: usize) -> Vec<WindowAggregate> {
    (0..30usize)
        .map(|k| {
            let values: Vec<f64> =
                (0..n).map(|i| if (k + i) % 4 == 0 { special(k + i) } else { (k * i) as f64 - 7.5 }).collect();
            let aggregate = [Aggregate::Signed, Aggregate::Count, Aggregate::Split][k % 3];
            let split = (aggregate == Aggregate::Split).then(|| Split {
                positive: (0..n).map(|i| (i + k) as f64).collect(),
                negative: (0..n).map(|i| if i == 1 { odd_nan() } else { (i * k) as f64 * 0.25 }).collect(),
            });
            WindowAggregate {
                sensor: SensorId::new(if k % 2 == 0 { "ff" } else { "mf" }),
                start: Timestamp(k as i64 * 1_000 - 9_000),
                end: Timestamp(k as i64 * 1_000),
                seq: k as u64 * 3 + 2,
                frames: if k == 4 { 0 } else { 10 },
                aggregate,
                values,
                split,
            }
        })
        .collect()
}

#[test]
fn windows_round_trip_bit_exact() {
    let dir = tempfile::tempdir().unwrap();
    let shape = WindowShape::new(vec!["a".into(), "b".into(), "c".into(), "d".into(), "e".into()]).unwrap();
    let input = some_windows(5);
    let r = read(&write(&dir.path().join("w.parquet"), shape, &input, 8));
    assert_eq!(schema_id(&r), "window/2");
    assert_eq!(window_keys(&windows_of(&r)), window_keys(&input));
    for c in ["values", "positive", "negative"] {
        let md = r.schema().field_with_name(c).unwrap().metadata()[TAXELS_KEY].clone();
        assert_eq!(md, r#"["a","b","c","d","e"]"#);
    }
    assert!(r.schema().field_with_name("positive").unwrap().is_nullable());
    assert!(!r.schema().field_with_name("values").unwrap().is_nullable());
}

#[test]
fn windows_of_another_size_are_rejected_and_the_sink_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    let mut sink =
        ParquetSink::<WindowAggregate>::try_new(dir.path().join("w.parquet"), WindowShape::unnamed(5).unwrap())
            .unwrap();
    let good = some_windows(5);
    sink.push(&good[0]).unwrap();
    let e = sink.push(&some_windows(4)[1]).unwrap_err();
    assert!(matches!(e, Error::Record { .. }) && e.to_string().contains("4 values"), "{e}");
    let mut bad_split = good[2].clone();
    bad_split.split.as_mut().unwrap().positive.pop();
    let e = sink.push(&bad_split).unwrap_err();
    assert!(matches!(e, Error::Record { .. }) && e.to_string().contains("4 positive counts"), "{e}");
    sink.push(&good[3]).unwrap();
    let r = read(&sink.finish().unwrap());
    assert_eq!(window_keys(&windows_of(&r)), window_keys(&[good[0].clone(), good[3].clone()]));
}

// ---------------------------------------------------------------------------------------------
// surface/1

fn grid(nx: usize, ny: usize) -> Arc<Grid> {
    Arc::new(
        Grid::try_new(Extent { x_min: -7.3, x_max: 11.9, y_min: 0.1 + 0.2, y_max: 24.000000000000004 }, nx, ny)
            .unwrap(),
    )
}

fn surface(g: &Arc<Grid>, k: usize) -> Surface {
    let (nx, ny) = (g.nx(), g.ny());
    let f = |(r, c): (usize, usize)| {
        if (r + c + k) % 11 == 0 {
            special(r * nx + c + k)
        } else {
            (g.x(c) * 0.3 + g.y(r)).sin() * (k as f64 + 1.0)
        }
    };
    // odd surfaces in column-major memory order, to check the logical row-major order is written
    let values = if k % 2 == 1 { Array2::from_shape_fn((ny, nx).f(), f) } else { Array2::from_shape_fn((ny, nx), f) };
    Surface {
        sensor: SensorId::new("ff"),
        start: Timestamp(k as i64 * 10 - 90),
        end: Timestamp(k as i64 * 10),
        seq: k as u64,
        grid: g.clone(),
        values,
    }
}

fn surfaces_of(r: &ReadBack, g: &Arc<Grid>) -> Vec<Surface> {
    let mut out = Vec::new();
    for b in &r.batches {
        let sensor = strs(b, "sensor");
        let (start, end) = (i64s(b, "start"), i64s(b, "end"));
        let seq = opt_u64s(b, "seq");
        let values = opt_f64_lists(b, "values");
        for i in 0..b.num_rows() {
            out.push(Surface {
                sensor: SensorId::new(sensor[i].as_deref().unwrap()),
                start: Timestamp(start[i]),
                end: Timestamp(end[i]),
                seq: seq[i].unwrap(),
                grid: g.clone(),
                values: Array2::from_shape_vec((g.ny(), g.nx()), values[i].clone().unwrap()).unwrap(),
            });
        }
    }
    out
}

type SurfaceKey = (String, i64, i64, u64, Grid, Vec<u64>);

fn surface_keys(s: &[Surface]) -> Vec<SurfaceKey> {
    s.iter()
        .map(|s| {
            let v: Vec<u64> = s.values.iter().map(|x| x.to_bits()).collect(); // logical row-major order
            (s.sensor.to_string(), s.start.as_nanos(), s.end.as_nanos(), s.seq, (*s.grid).clone(), v)
        })
        .collect()
}

#[test]
fn surfaces_round_trip_row_major_with_the_grid_in_metadata() {
    let dir = tempfile::tempdir().unwrap();
    let g = grid(7, 5);
    let input: Vec<Surface> = (0..9).map(|k| surface(&g, k)).collect();
    assert!(input[1].values.as_slice().is_none(), "a column-major surface is among the inputs");
    let r = read(&write(&dir.path().join("s.parquet"), SurfaceShape::new(g.clone()), &input, 4));
    assert_eq!(schema_id(&r), "surface/2");
    assert_eq!(surface_keys(&surfaces_of(&r, &g)), surface_keys(&input));
    // element row·nx + col is values[[row, col]]
    let flat = opt_f64_lists(&r.batches[0], "values")[1].clone().unwrap();
    assert_eq!(flat[2 * 7 + 3].to_bits(), input[1].values[[2, 3]].to_bits());
    // the grid, from the metadata alone
    let md: serde_json::Value = serde_json::from_str(&r.schema().metadata()[GRID_KEY]).unwrap();
    let e = g.extent();
    assert_eq!(md["nx"], 7);
    assert_eq!(md["ny"], 5);
    for (k, v) in [("x_min", e.x_min), ("x_max", e.x_max), ("y_min", e.y_min), ("y_max", e.y_max)] {
        assert_eq!(md[k].as_f64().unwrap().to_bits(), v.to_bits(), "{k}");
    }
    let back = Grid::try_new(
        Extent {
            x_min: md["x_min"].as_f64().unwrap(),
            x_max: md["x_max"].as_f64().unwrap(),
            y_min: md["y_min"].as_f64().unwrap(),
            y_max: md["y_max"].as_f64().unwrap(),
        },
        7,
        5,
    )
    .unwrap();
    assert_eq!(back, *g);
}

#[test]
fn a_surface_on_another_grid_is_rejected_and_the_sink_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    let g = grid(6, 4);
    let mut sink = ParquetSink::<Surface>::try_new(dir.path().join("s.parquet"), SurfaceShape::new(g.clone())).unwrap();
    sink.push(&surface(&g, 0)).unwrap();
    // another size
    let e = sink.push(&surface(&grid(4, 6), 1)).unwrap_err();
    assert!(matches!(e, Error::Record { .. }) && e.to_string().contains("4×6"), "{e}");
    // same size, another extent (an equal grid in another Arc is accepted below)
    let shifted = Arc::new(Grid::try_new(Extent { x_min: -7.3, x_max: 12.0, ..g.extent() }, 6, 4).unwrap());
    let e = sink.push(&surface(&shifted, 2)).unwrap_err();
    assert!(matches!(e, Error::Record { .. }) && e.to_string().contains("surface/2"), "{e}");
    // values that do not match the surface's own grid
    let mut bad = surface(&g, 3);
    bad.values = Array2::zeros((6, 4));
    let e = sink.push(&bad).unwrap_err();
    assert!(matches!(e, Error::Record { .. }) && e.to_string().contains("6×4 values"), "{e}");
    let equal = grid(6, 4);
    assert!(!Arc::ptr_eq(&equal, &g));
    sink.push(&surface(&equal, 4)).unwrap();
    let r = read(&sink.finish().unwrap());
    assert_eq!(surface_keys(&surfaces_of(&r, &g)), surface_keys(&[surface(&g, 0), surface(&g, 4)]));
}

// ---------------------------------------------------------------------------------------------
// contour/1

fn contours_of(r: &ReadBack) -> Vec<ContourFrame> {
    let mut out = Vec::new();
    for b in &r.batches {
        let sensor = strs(b, "sensor");
        let (start, end) = (i64s(b, "start"), i64s(b, "end"));
        let seq = opt_u64s(b, "seq");
        let contact = bools(b, "contact");
        let no_contact = strs(b, "no_contact");
        let names = [
            "level",
            "area_mm2",
            "centroid_x_mm",
            "centroid_y_mm",
            "orientation_rad",
            "eccentricity",
            "peak",
            "peak_x_mm",
            "peak_y_mm",
        ];
        let floats: Vec<Vec<Option<f64>>> = names.iter().map(|n| f64s(b, n)).collect();
        let clipped = bools(b, "clipped");
        let polygon = col(b, "polygon").as_list::<i32>();
        let holes = col(b, "holes").as_list::<i32>();
        for i in 0..b.num_rows() {
            let outcome = if contact[i].unwrap() {
                assert!(no_contact[i].is_none());
                let v: Vec<f64> = floats.iter().map(|c| c[i].unwrap_or(f64::NAN)).collect();
                let hs = holes.value(i);
                let hs = hs.as_list::<i32>();
                ContourOutcome::Contact(MaxContour {
                    level: v[0],
                    polygon: ring(polygon.value(i).as_ref()),
                    holes: (0..hs.len()).map(|h| ring(hs.value(h).as_ref())).collect(),
                    area_mm2: v[1],
                    centroid_mm: [v[2], v[3]],
                    orientation_rad: v[4],
                    eccentricity: v[5],
                    peak: v[6],
                    peak_mm: [v[7], v[8]],
                    clipped: clipped[i].unwrap(),
                    fit: None,
                })
            } else {
                assert!(floats.iter().all(|c| c[i].is_none()) && clipped[i].is_none());
                assert!(polygon.is_null(i) && holes.is_null(i));
                ContourOutcome::NoContact(match no_contact[i].as_deref().unwrap() {
                    "no_data" => NoContact::NoData,
                    "below_min_peak" => NoContact::BelowMinPeak,
                    "flat" => NoContact::Flat,
                    "too_small" => NoContact::TooSmall,
                    other => panic!("no_contact {other}"),
                })
            };
            out.push(ContourFrame {
                sensor: SensorId::new(sensor[i].as_deref().unwrap()),
                start: Timestamp(start[i]),
                end: Timestamp(end[i]),
                seq: seq[i].unwrap(),
                outcome,
            });
        }
    }
    out
}

#[derive(Debug, PartialEq)]
enum OutcomeKey {
    Contact(Vec<u64>, Vec<[u64; 2]>, Vec<Vec<[u64; 2]>>, bool),
    NoContact(NoContact),
}

fn contour_keys(c: &[ContourFrame]) -> Vec<(String, i64, i64, u64, OutcomeKey)> {
    c.iter()
        .map(|c| {
            let o = match &c.outcome {
                ContourOutcome::Contact(m) => OutcomeKey::Contact(
                    bits(
                        &[
                            m.level,
                            m.area_mm2,
                            m.centroid_mm[0],
                            m.centroid_mm[1],
                            m.orientation_rad,
                            m.eccentricity,
                            m.peak,
                            m.peak_mm[0],
                            m.peak_mm[1],
                        ]
                        .map(canonical),
                    ),
                    pbits(&m.polygon),
                    m.holes.iter().map(|h| pbits(h)).collect(),
                    m.clipped,
                ),
                ContourOutcome::NoContact(r) => OutcomeKey::NoContact(*r),
            };
            (c.sensor.to_string(), c.start.as_nanos(), c.end.as_nanos(), c.seq, o)
        })
        .collect()
}

fn some_contours() -> Vec<ContourFrame> {
    let reasons = [NoContact::NoData, NoContact::BelowMinPeak, NoContact::Flat, NoContact::TooSmall];
    (0..24usize)
        .map(|k| {
            let outcome = if k % 3 == 2 {
                ContourOutcome::NoContact(reasons[k % 4])
            } else {
                let square = |c: f64, h: f64| vec![[c - h, c - h], [c + h, c - h], [c + h, c + h], [c - h, c + h]];
                ContourOutcome::Contact(MaxContour {
                    level: 0.1 * k as f64,
                    polygon: square(k as f64, 3.0 + special(k).abs().min(1.0)),
                    holes: (0..k % 3)
                        .map(|h| square(k as f64 + 0.5 * h as f64, 0.25).into_iter().rev().collect())
                        .collect(),
                    area_mm2: 36.0 - k as f64 * 0.01,
                    centroid_mm: [k as f64 + 1e-17, -(k as f64)],
                    orientation_rad: special(k + 1),
                    eccentricity: if k == 4 { odd_nan() } else { 0.5 },
                    peak: special(k + 2),
                    peak_mm: [-0.0, f64::MIN_POSITIVE],
                    clipped: k % 2 == 0,
                    fit: None,
                })
            };
            ContourFrame {
                sensor: SensorId::new(["ff", "mf", "th"][k % 3]),
                start: Timestamp(k as i64 * 1000 - 500),
                end: Timestamp(k as i64 * 1000),
                seq: k as u64,
                outcome,
            }
        })
        .collect()
}

#[test]
fn contours_round_trip_with_polygons_and_holes() {
    let dir = tempfile::tempdir().unwrap();
    let input = some_contours();
    let r = read(&write(&dir.path().join("c.parquet"), (), &input, 5));
    assert_eq!(schema_id(&r), "contour/2");
    assert_eq!(contour_keys(&contours_of(&r)), contour_keys(&input));
    assert_eq!(unit(&r, "polygon").as_deref(), Some("mm"));
    assert_eq!(unit(&r, "area_mm2").as_deref(), Some("mm2"));
}

// ---------------------------------------------------------------------------------------------
// track/1

fn tracks_of(r: &ReadBack) -> Vec<TrackPoint> {
    let mut out = Vec::new();
    for b in &r.batches {
        let sensor = strs(b, "sensor");
        let (time, start) = (i64s(b, "time"), i64s(b, "start"));
        let seq = opt_u64s(b, "seq");
        let (state, no_contact) = (strs(b, "state"), strs(b, "no_contact"));
        let track = opt_u64s(b, "track");
        let [x, y, area, orientation, peak, vx, vy] =
            ["x_mm", "y_mm", "area_mm2", "orientation_rad", "peak", "velocity_x_mm_s", "velocity_y_mm_s"]
                .map(|n| f64s(b, n));
        let gated = bools(b, "gated");
        for i in 0..b.num_rows() {
            out.push(TrackPoint {
                sensor: SensorId::new(sensor[i].as_deref().unwrap()),
                time: Timestamp(time[i]),
                start: Timestamp(start[i]),
                seq: seq[i].unwrap(),
                state: match state[i].as_deref().unwrap() {
                    "contact" => ContactState::Contact,
                    "no_contact" => ContactState::NoContact,
                    other => panic!("state {other}"),
                },
                no_contact: no_contact[i].as_deref().map(|s| match s {
                    "no_data" => NoContact::NoData,
                    "below_min_peak" => NoContact::BelowMinPeak,
                    "flat" => NoContact::Flat,
                    "too_small" => NoContact::TooSmall,
                    other => panic!("no_contact {other}"),
                }),
                track: track[i],
                // absent values are null; the Rust fields hold NaN for them
                x_mm: x[i].unwrap_or(f64::NAN),
                y_mm: y[i].unwrap_or(f64::NAN),
                area_mm2: area[i].unwrap_or(f64::NAN),
                orientation_rad: orientation[i].unwrap_or(f64::NAN),
                peak: peak[i].unwrap_or(f64::NAN),
                velocity_mm_s: (vx[i].is_some() || vy[i].is_some())
                    .then(|| [vx[i].unwrap_or(f64::NAN), vy[i].unwrap_or(f64::NAN)]),
                gated: gated[i].unwrap(),
                fit: None,
            });
        }
    }
    out
}

type TrackKey = (String, i64, i64, u64, ContactState, Option<NoContact>, Option<u64>, Vec<u64>, Option<[u64; 2]>, bool);

/// NaN as the one NaN a null reads back as (the files store no NaN payload in scalars).
fn canonical(x: f64) -> f64 {
    if x.is_nan() {
        f64::NAN
    } else {
        x
    }
}

fn track_keys(t: &[TrackPoint]) -> Vec<TrackKey> {
    t.iter()
        .map(|p| {
            (
                p.sensor.to_string(),
                p.time.as_nanos(),
                p.start.as_nanos(),
                p.seq,
                p.state,
                p.no_contact,
                p.track,
                bits(&[p.x_mm, p.y_mm, p.area_mm2, p.orientation_rad, p.peak].map(canonical)),
                // a velocity of two NaNs is stored as two nulls: no velocity
                p.velocity_mm_s
                    .filter(|v| !(v[0].is_nan() && v[1].is_nan()))
                    .map(|v| [canonical(v[0]).to_bits(), canonical(v[1]).to_bits()]),
                p.gated,
            )
        })
        .collect()
}

fn some_tracks() -> Vec<TrackPoint> {
    (0..50usize)
        .map(|k| {
            let contact = k % 5 != 3;
            let nan = f64::NAN;
            TrackPoint {
                sensor: SensorId::new(if k % 2 == 0 { "ff" } else { "th" }),
                time: Timestamp(k as i64 * 10_000_000),
                start: Timestamp(k as i64 * 10_000_000 - 90_000_000),
                seq: k as u64,
                state: if contact { ContactState::Contact } else { ContactState::NoContact },
                no_contact: (!contact).then_some([NoContact::TooSmall, NoContact::NoData][k % 2]),
                track: contact.then_some(k as u64 / 10),
                x_mm: if contact { special(k) } else { nan },
                y_mm: if contact { k as f64 * 0.1 } else { nan },
                area_mm2: if contact { 12.5 } else { odd_nan() },
                orientation_rad: if contact { -std::f64::consts::FRAC_PI_2 + 1e-16 } else { nan },
                peak: if contact { special(k + 3) } else { nan },
                velocity_mm_s: (contact && k % 10 != 0).then_some([special(k + 5), -3.25]),
                gated: k % 7 == 0,
                fit: None,
            }
        })
        .collect()
}

#[test]
fn tracks_round_trip_bit_exact() {
    let dir = tempfile::tempdir().unwrap();
    let input = some_tracks();
    let r = read(&write(&dir.path().join("t.parquet"), (), &input, 16));
    assert_eq!(schema_id(&r), "track/3");
    assert_eq!(track_keys(&tracks_of(&r)), track_keys(&input));
    assert_eq!(unit(&r, "velocity_x_mm_s").as_deref(), Some("mm/s"));
    // no contact: null, never NaN, in every float column (avg() in an SQL engine is a number)
    type Get = fn(&TrackPoint) -> f64;
    let fields: [(&str, Get); 5] = [
        ("x_mm", |p| p.x_mm),
        ("y_mm", |p| p.y_mm),
        ("area_mm2", |p| p.area_mm2),
        ("orientation_rad", |p| p.orientation_rad),
        ("peak", |p| p.peak),
    ];
    for (c, get) in fields {
        let values = f64s(&r.batches[0], c);
        assert!(values.iter().flatten().all(|v| !v.is_nan()), "{c} holds no NaN");
        for (v, p) in values.iter().zip(&input) {
            assert_eq!(v.is_none(), get(p).is_nan(), "{c}: null exactly where the point has no value");
            if p.state == ContactState::NoContact {
                assert!(v.is_none(), "{c}: null without contact");
            }
        }
    }
    assert_eq!(
        r.schema().field_with_name("time").unwrap().data_type(),
        &arrow_schema::DataType::Duration(arrow_schema::TimeUnit::Nanosecond)
    );
}

// ---------------------------------------------------------------------------------------------
// proptests: any records → the same records back

fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![any::<u64>().prop_map(f64::from_bits), any::<f64>(), Just(f64::NAN), Just(-0.0)]
}

fn any_sensor() -> impl Strategy<Value = SensorId> {
    prop_oneof![Just("ff".to_string()), Just("th".to_string()), "\\PC{0,12}"].prop_map(SensorId::new)
}

fn any_ts() -> impl Strategy<Value = Timestamp> {
    any::<i64>().prop_map(Timestamp)
}

fn any_no_contact() -> impl Strategy<Value = NoContact> {
    prop_oneof![
        Just(NoContact::NoData),
        Just(NoContact::BelowMinPeak),
        Just(NoContact::Flat),
        Just(NoContact::TooSmall)
    ]
}

fn any_event_batch(taxels: u16) -> impl Strategy<Value = EventBatch> {
    (
        any_sensor(),
        any_ts(),
        prop_oneof![0..4u64, any::<u64>()],
        proptest::collection::vec((any_ts(), 0..taxels, any::<i8>()), 0..6),
    )
        .prop_map(move |(sensor, time, seq, ev)| EventBatch {
            sensor,
            time,
            seq,
            taxels,
            events: ev.into_iter().map(|(time, taxel, polarity)| TactileEvent { time, taxel, polarity }).collect(),
        })
}

fn any_events() -> impl Strategy<Value = (u16, Vec<EventBatch>)> {
    (1u16..40).prop_flat_map(|n| (Just(n), proptest::collection::vec(any_event_batch(n), 0..30)))
}

fn any_track_point() -> impl Strategy<Value = TrackPoint> {
    (
        (any_sensor(), any_ts(), any_ts(), any::<u64>()),
        (any::<bool>(), proptest::option::of(any_no_contact()), proptest::option::of(any::<u64>())),
        proptest::collection::vec(any_f64(), 5),
        (proptest::option::of((any_f64(), any_f64())), any::<bool>()),
    )
        .prop_map(|((sensor, time, start, seq), (contact, no_contact, track), f, (v, gated))| TrackPoint {
            sensor,
            time,
            start,
            seq,
            state: if contact { ContactState::Contact } else { ContactState::NoContact },
            no_contact,
            track,
            x_mm: f[0],
            y_mm: f[1],
            area_mm2: f[2],
            orientation_rad: f[3],
            peak: f[4],
            velocity_mm_s: v.map(|(a, b)| [a, b]),
            gated,
            fit: None,
        })
}

fn any_ring(max: usize) -> impl Strategy<Value = Vec<[f64; 2]>> {
    proptest::collection::vec((any_f64(), any_f64()).prop_map(|(x, y)| [x, y]), 0..max)
}

fn any_contour() -> impl Strategy<Value = ContourFrame> {
    let contact = (
        proptest::collection::vec(any_f64(), 9),
        any_ring(12),
        proptest::collection::vec(any_ring(5), 0..3),
        any::<bool>(),
    )
        .prop_map(|(f, polygon, holes, clipped)| {
            ContourOutcome::Contact(MaxContour {
                level: f[0],
                polygon,
                holes,
                area_mm2: f[1],
                centroid_mm: [f[2], f[3]],
                orientation_rad: f[4],
                eccentricity: f[5],
                peak: f[6],
                peak_mm: [f[7], f[8]],
                clipped,
                fit: None,
            })
        });
    let outcome = prop_oneof![contact, any_no_contact().prop_map(ContourOutcome::NoContact)];
    (any_sensor(), any_ts(), any_ts(), any::<u64>(), outcome)
        .prop_map(|(sensor, start, end, seq, outcome)| ContourFrame { sensor, start, end, seq, outcome })
}

fn any_windows() -> impl Strategy<Value = (usize, Vec<WindowAggregate>)> {
    (1usize..12).prop_flat_map(|n| {
        let w = (
            (any_sensor(), any_ts(), any_ts(), any::<u64>(), any::<u64>()),
            proptest::collection::vec(any_f64(), n),
            proptest::option::of((proptest::collection::vec(any_f64(), n), proptest::collection::vec(any_f64(), n))),
            prop_oneof![Just(Aggregate::Signed), Just(Aggregate::Count), Just(Aggregate::Split)],
        )
            .prop_map(|((sensor, start, end, seq, frames), values, split, aggregate)| WindowAggregate {
                sensor,
                start,
                end,
                seq,
                frames,
                aggregate,
                values,
                split: split.map(|(positive, negative)| Split { positive, negative }),
            });
        (Just(n), proptest::collection::vec(w, 0..20))
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn any_events_come_back((n, input) in any_events(), row_group in 1usize..40) {
        let dir = tempfile::tempdir().unwrap();
        let r = read(&write(&dir.path().join("e.parquet"), EventShape::unnamed(n as usize).unwrap(), &input, row_group));
        prop_assert_eq!(event_rows(&r), rows_of(&input));
        prop_assert_eq!(events_of(&r), expected_events(&input));
    }

    #[test]
    fn any_track_points_come_back(input in proptest::collection::vec(any_track_point(), 0..40), row_group in 1usize..40) {
        let dir = tempfile::tempdir().unwrap();
        let r = read(&write(&dir.path().join("t.parquet"), (), &input, row_group));
        prop_assert_eq!(track_keys(&tracks_of(&r)), track_keys(&input));
    }

    #[test]
    fn any_contours_come_back(input in proptest::collection::vec(any_contour(), 0..20), row_group in 1usize..20) {
        let dir = tempfile::tempdir().unwrap();
        let r = read(&write(&dir.path().join("c.parquet"), (), &input, row_group));
        prop_assert_eq!(contour_keys(&contours_of(&r)), contour_keys(&input));
    }

    #[test]
    fn any_windows_come_back((n, input) in any_windows(), row_group in 1usize..20) {
        let dir = tempfile::tempdir().unwrap();
        let r = read(&write(&dir.path().join("w.parquet"), WindowShape::unnamed(n).unwrap(), &input, row_group));
        prop_assert_eq!(window_keys(&windows_of(&r)), window_keys(&input));
    }
}

// ---------------------------------------------------------------------------------------------
// pyarrow

/// pyarrow reads a file of each schema; every row, as Python sees it, equals what was written.
#[test]
fn pyarrow_reads_every_schema() {
    // a scalar's absent value (NaN in Rust) is null in the files
    fn hn(x: f64) -> serde_json::Value {
        if x.is_nan() {
            serde_json::Value::Null
        } else {
            serde_json::json!(h(x))
        }
    }
    use serde_json::{json, Value};
    if !pyarrow_available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let events = some_events();
    let windows = some_windows(3);
    let g = grid(4, 3);
    let surfaces: Vec<Surface> = (0..4).map(|k| surface(&g, k)).collect();
    let contours = some_contours();
    let tracks = some_tracks();
    let paths = [
        write(&dir.path().join("event.parquet"), EventShape::unnamed(24).unwrap(), &events, 16),
        write(&dir.path().join("window.parquet"), WindowShape::unnamed(3).unwrap(), &windows, 16),
        write(&dir.path().join("surface.parquet"), SurfaceShape::new(g.clone()), &surfaces, 16),
        write(&dir.path().join("contour.parquet"), (), &contours, 16),
        write(&dir.path().join("track.parquet"), (), &tracks, 16),
    ];
    let script = format!("{PY_DESCRIBE}\nprint(json.dumps([describe(p) for p in sys.argv[1:]]))\n");
    let v = run_python(&script, &paths);

    // event/1
    let e = &v[0];
    assert_eq!(e["schema"], "event/2");
    assert_eq!(e["types"]["taxel"], "uint16");
    assert_eq!(e["types"]["polarity"], "int8");
    let rows: Vec<Value> = rows_of(&events)
        .into_iter()
        .map(|(s, t, ft, seq, taxel, p)| {
            json!({"sensor": s, "time": t, "frame_time": ft, "seq": seq, "taxel": taxel + 1, "polarity": p})
        })
        .collect();
    assert_eq!(e["rows"], Value::Array(rows));

    // window/1
    let w = &v[1];
    assert_eq!(w["schema"], "window/2");
    assert_eq!(w["types"]["positive"], "fixed_size_list<item: double not null>[3]");
    let rows: Vec<Value> = windows
        .iter()
        .map(|w| {
            json!({"sensor": w.sensor.as_str(), "start": w.start.as_nanos(), "end": w.end.as_nanos(),
                   "seq": w.seq, "frames": w.frames,
                   "aggregate": gradtac_io::records::window::aggregate_name(w.aggregate),
                   "values": hs(&w.values),
                   "positive": w.split.as_ref().map(|s| hs(&s.positive)),
                   "negative": w.split.as_ref().map(|s| hs(&s.negative))})
        })
        .collect();
    assert_eq!(w["rows"], Value::Array(rows));

    // surface/1: rows and the grid
    let s = &v[2];
    assert_eq!(s["schema"], "surface/2");
    assert_eq!(s["types"]["values"], "fixed_size_list<item: double not null>[12]");
    let grid_md: Value = serde_json::from_str(s["arrow_md"][GRID_KEY].as_str().unwrap()).unwrap();
    assert_eq!(grid_md["nx"], 4);
    assert_eq!(grid_md["ny"], 3);
    let rows: Vec<Value> = surfaces
        .iter()
        .map(|s| {
            let v: Vec<f64> = s.values.iter().copied().collect();
            json!({"sensor": s.sensor.as_str(), "start": s.start.as_nanos(), "end": s.end.as_nanos(),
                   "seq": s.seq, "values": hs(&v)})
        })
        .collect();
    assert_eq!(s["rows"], Value::Array(rows));

    // contour/1
    let c = &v[3];
    assert_eq!(c["schema"], "contour/2");
    assert_eq!(c["types"]["polygon"], "list<item: fixed_size_list<item: double not null>[2] not null>");
    let rows: Vec<Value> = contours
        .iter()
        .map(|c| {
            let base = json!({"sensor": c.sensor.as_str(), "start": c.start.as_nanos(),
                              "end": c.end.as_nanos(), "seq": c.seq});
            let rest = match &c.outcome {
                ContourOutcome::Contact(m) => json!({
                    "contact": true, "no_contact": null, "level": hn(m.level), "area_mm2": hn(m.area_mm2),
                    "centroid_x_mm": hn(m.centroid_mm[0]), "centroid_y_mm": hn(m.centroid_mm[1]),
                    "orientation_rad": hn(m.orientation_rad), "eccentricity": hn(m.eccentricity), "peak": hn(m.peak),
                    "peak_x_mm": hn(m.peak_mm[0]), "peak_y_mm": hn(m.peak_mm[1]), "clipped": m.clipped,
                    "polygon": hp(&m.polygon), "holes": m.holes.iter().map(|x| hp(x)).collect::<Value>()}),
                ContourOutcome::NoContact(r) => json!({
                    "contact": false, "no_contact": gradtac_io::records::contour::no_contact_name(*r),
                    "level": null, "area_mm2": null, "centroid_x_mm": null, "centroid_y_mm": null,
                    "orientation_rad": null, "eccentricity": null, "peak": null, "peak_x_mm": null,
                    "peak_y_mm": null, "clipped": null, "polygon": null, "holes": null}),
            };
            let mut o = base.as_object().unwrap().clone();
            o.extend(rest.as_object().unwrap().clone());
            Value::Object(o)
        })
        .collect();
    assert_eq!(c["rows"], Value::Array(rows));

    // track/1
    let t = &v[4];
    assert_eq!(t["schema"], "track/3");
    let rows: Vec<Value> = tracks
        .iter()
        .map(|p| {
            json!({"sensor": p.sensor.as_str(), "time": p.time.as_nanos(), "start": p.start.as_nanos(),
                   "seq": p.seq, "state": gradtac_io::records::track::contact_state_name(p.state),
                   "no_contact": p.no_contact.map(gradtac_io::records::contour::no_contact_name),
                   "track": p.track, "x_mm": hn(p.x_mm), "y_mm": hn(p.y_mm), "area_mm2": hn(p.area_mm2),
                   "orientation_rad": hn(p.orientation_rad), "peak": hn(p.peak),
                   "velocity_x_mm_s": p.velocity_mm_s.map(|v| hn(v[0])), "velocity_y_mm_s": p.velocity_mm_s.map(|v| hn(v[1])),
                   "gated": p.gated, "fit_amplitude": null, "fit_spread_mm": null, "fit_residual": null,
                   "fit_sigma_mm": null})
        })
        .collect();
    assert_eq!(t["rows"], Value::Array(rows));
}
