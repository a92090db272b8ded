//! Every row of a gradtac Parquet output (any schema, any version; a file or an archive
//! directory) as view records, for `gradtac view` (features `view` and `plot`).
//!
//! Unlike the figures, nothing is decimated: the files are read one row group at a time and
//! each row group's records are handed on before the next is read, so memory stays at one
//! row group's.

use super::surface::grid_of;
use super::*;
use crate::view::rec::{Clock, FrameKind, Rec};
use std::collections::{HashMap, HashSet};

/// What [`replay_records`] read.
#[derive(Clone, Debug, Default)]
pub(crate) struct ReadCounts {
    /// Files read.
    pub(crate) files: usize,
    /// Rows read.
    pub(crate) rows: u64,
    /// Schema ids of the files read (first appearance order).
    pub(crate) schemas: Vec<String>,
    /// `.partial` files skipped (archives).
    pub(crate) partial: usize,
}

/// Read `input` (a Parquet file, or a directory of them read recursively as `gradtac plot`
/// does: hive partitions included, `.partial` and hidden files skipped) and hand each row
/// group's records to `sink`.
pub(crate) fn replay_records(input: &Path, sink: &mut dyn FnMut(Vec<Rec>)) -> Result<ReadCounts, Error> {
    let err = |e: PlotErr| Error::View(format!("{}: {}", input.display(), e.0));
    let (files, partial): (Vec<PathBuf>, usize) = if input.is_dir() {
        let (files, partial) = archive_files(input).map_err(err)?;
        if files.is_empty() {
            return Err(err(PlotErr(format!(
                "no finished Parquet file to replay ({partial} unfinished `.partial` files skipped)"
            ))));
        }
        (files.into_iter().map(|f| input.join(f)).collect(), partial)
    } else {
        (vec![input.to_path_buf()], 0)
    };
    let mut counts = ReadCounts { partial, ..ReadCounts::default() };
    // per sensor declared: whether with a layout
    let mut declared: HashMap<String, bool> = HashMap::new();
    for f in &files {
        let in_file = |e: PlotErr| Error::View(format!("{}: {}", f.display(), e.0));
        let o = open_parquet(f).map_err(in_file)?;
        if !counts.schemas.contains(&o.schema_id) {
            counts.schemas.push(o.schema_id.clone());
        }
        let partition = f.strip_prefix(input).ok().and_then(hive_sensor);
        let header = Table {
            schema_id: o.schema_id.clone(),
            kv: o.kv.clone(),
            schema: o.schema.clone(),
            batches: Vec::new(),
            total_rows: o.rows,
            stride: None,
            files: None,
        };
        for (i, rg) in o.meta.metadata().row_groups().iter().enumerate() {
            let at = |e: String| in_file(PlotErr(format!("row group {i}: {e}")));
            gradtac_io::parquet_check::check_row_group(&mut &o.file, rg).map_err(at)?;
            let file = o.file.try_clone().map_err(|e| at(format!("cannot read: {e}")))?;
            let builder =
                ParquetRecordBatchReaderBuilder::new_with_metadata(file, o.meta.clone()).with_row_groups(vec![i]);
            let read = gradtac_io::contain::contain(|| -> std::result::Result<Vec<RecordBatch>, String> {
                let reader = builder.build().map_err(|e| format!("cannot read: {e}"))?;
                reader.collect::<std::result::Result<Vec<_>, _>>().map_err(|e| format!("cannot read rows: {e}"))
            });
            let batches = match read {
                Ok(Ok(b)) => b,
                Ok(Err(e)) => return Err(at(e)),
                Err(panic) => return Err(at(format!("malformed data (the parquet reader panicked: {panic})"))),
            };
            for b in batches {
                let b = match &partition {
                    Some(s) => with_sensor_column(b, s).map_err(in_file)?,
                    None => b,
                };
                let t = normalise(Table { batches: vec![b], schema: o.schema.clone(), ..header.clone_empty() })
                    .map_err(in_file)?;
                let Some(b) = t.batches.first() else { continue };
                counts.rows += b.num_rows() as u64;
                let mut recs = Vec::with_capacity(b.num_rows() + 1);
                batch_records(&header, b, &mut declared, &mut recs).map_err(in_file)?;
                sink(recs);
            }
        }
        counts.files += 1;
    }
    Ok(counts)
}

impl Table {
    /// The same file's header without rows.
    fn clone_empty(&self) -> Table {
        Table {
            schema_id: self.schema_id.clone(),
            kv: self.kv.clone(),
            schema: self.schema.clone(),
            batches: Vec::new(),
            total_rows: self.total_rows,
            stride: self.stride,
            files: None,
        }
    }
}

/// The clock of a time column: `Timestamp` (Unix epoch, UTC) or anything else (`Duration`,
/// the `Int64` nanoseconds of version 1: relative).
fn clock_of(b: &RecordBatch, column: &str) -> Clock {
    match b.column_by_name(column).map(|c| c.data_type()) {
        Some(arrow_schema::DataType::Timestamp(..)) => Clock::Utc,
        _ => Clock::Relative,
    }
}

/// `Some(v)` for a finite value (nulls read as NaN).
fn some(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// The first nullable `Float64` column whose name says it is a position uncertainty (σ, mm),
/// as a `track` schema newer than `track/2` may carry.
fn sigma_column(b: &RecordBatch) -> Option<String> {
    b.schema()
        .fields()
        .iter()
        .find(|f| {
            let n = f.name().to_ascii_lowercase();
            (n.contains("sigma") || n.contains("uncertainty")) && f.data_type() == &arrow_schema::DataType::Float64
        })
        .map(|f| f.name().clone())
}

fn batch_records(header: &Table, b: &RecordBatch, declared: &mut HashMap<String, bool>, out: &mut Vec<Rec>) -> R<()> {
    let (family, _) = family(&header.schema_id);
    let time_col = if b.column_by_name("time").is_some() { "time" } else { "end" };
    let clock = clock_of(b, time_col);
    let taxels = match family {
        "frame" | "window" => Some(fixed_lists(&b.slice(0, b.num_rows().min(1)), "values")?.0),
        _ => None,
    };
    // declare each sensor before its first record; again with its layout from the first file
    // of frames (the files of contours or tracks hold no taxel count)
    let mut declare = |sensor: &str, out: &mut Vec<Rec>| {
        let had_layout = declared.get(sensor).copied();
        if had_layout == Some(true) || (had_layout == Some(false) && taxels.is_none()) {
            return;
        }
        let mut notes = Vec::new();
        let layout = if taxels.is_some() { header.layout(sensor, taxels, &mut notes) } else { None };
        declared.insert(sensor.to_string(), layout.is_some());
        out.push(Rec::Sensor { sensor: sensor.to_string(), layout, clock });
    };
    if family == "slip" {
        let (first, second) = (strings(b, "first")?, strings(b, "second")?);
        for s in first.iter().chain(&second) {
            declare(s, out);
        }
        let (t, onset) = (i64s(b, "time")?, i64s(b, "onset")?);
        let (class, previous) = (strings(b, "class")?, strings(b, "previous")?);
        for i in 0..b.num_rows() {
            out.push(Rec::Slip {
                pair: format!("{}–{}", first[i], second[i]),
                t: t[i],
                onset: onset[i],
                class: class[i].clone(),
                previous: previous[i].clone(),
            });
        }
        return Ok(());
    }
    let sensors = strings(b, "sensor")?;
    let t = i64s(b, time_col)?;
    for s in dedup(&sensors) {
        declare(s, out);
    }
    let n = b.num_rows();
    match family {
        "frame" | "window" => {
            let kind = if family == "window" {
                FrameKind::Window
            } else {
                match header.kv.get("gradtac.tap").map(String::as_str) {
                    Some("normalise") => FrameKind::Normalised,
                    Some("savgol") => FrameKind::Smoothed,
                    _ => FrameKind::Raw,
                }
            };
            let (k, values) = fixed_lists(b, "values")?;
            for i in 0..n {
                let v = values[i * k..(i + 1) * k].to_vec();
                out.push(Rec::Frame { sensor: sensors[i].clone(), kind, t: t[i], values: v });
            }
        }
        "event" => {
            // one row per event: counts per (sensor, frame) in row order
            let frame_time = i64s(b, "frame_time")?;
            let pol = column(b, "polarity")?;
            let pol = pol.as_primitive_opt::<Int8Type>().ok_or_else(|| wrong("polarity", pol))?;
            let mut i = 0;
            while i < n {
                let (mut pos, mut neg, mut j) = (0u32, 0u32, i);
                while j < n && sensors[j] == sensors[i] && frame_time[j] == frame_time[i] {
                    if pol.value(j) > 0 {
                        pos += 1;
                    } else {
                        neg += 1;
                    }
                    j += 1;
                }
                out.push(Rec::Events { sensor: sensors[i].clone(), t: frame_time[i], positive: pos, negative: neg });
                i = j;
            }
        }
        "surface" => {
            let grid = grid_of(header)?;
            let (k, values) = fixed_lists(b, "values")?;
            if k != grid.len() {
                return Err(PlotErr(format!("surface rows hold {k} values, the grid nx·ny = {}", grid.len())));
            }
            let e = grid.extent();
            for i in 0..n {
                out.push(Rec::Surface {
                    sensor: sensors[i].clone(),
                    t: t[i],
                    nx: grid.nx(),
                    ny: grid.ny(),
                    extent: [e.x_min, e.x_max, e.y_min, e.y_max],
                    values: values[i * k..(i + 1) * k].iter().map(|&v| v as f32).collect(),
                });
            }
        }
        "contour" => {
            let polys = polygons(b, "polygon")?;
            let (cx, cy, area) = (f64s(b, "centroid_x_mm")?, f64s(b, "centroid_y_mm")?, f64s(b, "area_mm2")?);
            let contact = column(b, "contact")?;
            let contact = contact.as_boolean_opt().ok_or_else(|| wrong("contact", contact))?;
            for i in 0..n {
                let c = contact.value(i);
                out.push(Rec::Contour {
                    sensor: sensors[i].clone(),
                    t: t[i],
                    polygon: (c && !polys[i].is_empty()).then(|| polys[i].clone()),
                    centroid: some(cx[i]).zip(some(cy[i])).map(|(x, y)| [x, y]),
                    area: if c { some(area[i]) } else { None },
                });
            }
        }
        "track" => {
            let (x, y) = (f64s(b, "x_mm")?, f64s(b, "y_mm")?);
            // `track/1` has no `state`: a contact is a finite position
            let state = match b.column_by_name("state") {
                Some(_) => strings(b, "state")?,
                None => vec!["contact".to_string(); n],
            };
            let sigma = match sigma_column(b) {
                Some(c) => f64s(b, &c)?,
                None => vec![f64::NAN; n],
            };
            for i in 0..n {
                let xy = (state[i] == "contact").then(|| some(x[i]).zip(some(y[i])).map(|(x, y)| [x, y])).flatten();
                out.push(Rec::Contact { sensor: sensors[i].clone(), t: t[i], xy, sigma_mm: some(sigma[i]) });
            }
        }
        "force" => {
            let f = f64s(b, "force_n")?;
            for i in 0..n {
                out.push(Rec::Force { sensor: sensors[i].clone(), t: t[i], force_n: some(f[i]) });
            }
        }
        "servo" => {
            let (x, y) = (f64s(b, "motion_x_mm")?, f64s(b, "motion_y_mm")?);
            let action = strings(b, "action")?;
            for i in 0..n {
                let m = (action[i] == "move").then(|| some(x[i]).zip(some(y[i])).map(|(x, y)| [x, y])).flatten();
                out.push(Rec::Servo { sensor: sensors[i].clone(), t: t[i], motion_mm: m });
            }
        }
        "dos" => {
            let class = strings(b, "class")?;
            let posterior = fixed_lists(b, "posterior").ok();
            for i in 0..n {
                let q = posterior.as_ref().and_then(|(k, v)| {
                    v.get(i * k..(i + 1) * k)
                        .and_then(|r| r.iter().copied().fold(None, |m: Option<f64>, p| Some(m.map_or(p, |m| m.max(p)))))
                });
                out.push(Rec::Dos { sensor: sensors[i].clone(), t: t[i], class: class[i].clone(), posterior: q });
            }
        }
        other => return Err(PlotErr(format!("unknown schema family {other:?}"))),
    }
    Ok(())
}

/// The distinct values in first-appearance order.
fn dedup(v: &[String]) -> Vec<&String> {
    let mut seen = HashSet::new();
    v.iter().filter(|s| seen.insert(s.as_str())).collect()
}
