//! Figures of gradtac outputs (`gradtac plot`) and of the demo's results, drawn with
//! [plotters](https://docs.rs/plotters) as SVG (the output ends in `.svg`: vector lines, text as text) or PNG (any
//! other extension: a pixel buffer encoded with [png](https://docs.rs/png)); see [`ImageFormat`].
//!
//! The code is split by figure kind: `read` (files, archives, schema versions, filters),
//! `style` (colours, axes, legends), `series` (frames, events, windows, force, servo),
//! `surface`, `contour`, `track`, `slip` (slip and dos), and `backend` (SVG or PNG).
//!
//! [`plot_parquet`] reads any Parquet file a gradtac sink wrote, or a directory of them (an
//! archive: rolled files, optionally hive-partitioned `sensor=<name>/`, read as one table),
//! detects its schema from the `gradtac.schema` key-value metadata (`docs/schemas.md`; every
//! version: `frame/1` and `frame/2` alike, older column names and `Int64` times are read as
//! the newest) and draws (`--sensor`, `--from`, `--to`: [`PlotOptions`]):
//!
//! | schema | plot | size (px, `s` = sensors drawn, at most [`MAX_SENSORS`]) |
//! |---|---|---|
//! | `frame` | one line per taxel over time, one panel per sensor | 1200 × 340·s |
//! | `event` | raster: time × taxel, red = +1, blue = −1, one panel per sensor | 1200 × 340·s |
//! | `window` | heat strip: time × taxel, colour = aggregate (diverging for `signed`), one panel per sensor | 1320 × 340·s |
//! | `surface` | the surface at 4 instants (evenly spaced over the rows with a contact, else over all rows) with its iso-lines and maximal contour (bold) found with the run's `[stages.contour]` settings from the file's `gradtac.scene` (the stage's defaults and any peak without a scene), taxels as circles, a legend of every mark; one row per sensor | 1640 × (40 + 400·s) |
//! | `contour` | left: centroid paths on the layout plane with the outlines of 4 contours; right: area (mm²) over time; sensors in colours | 1400 × 620 |
//! | `track` | trajectory on the layout plane coloured by time, taxels as labelled circles; one panel per sensor | 640·s + 120 × 680 |
//! | `slip` | the grasp's state over time (a class strip from each event's decision time) and the common / differential speeds at the events | 1200 × 560 |
//! | `force` | force (N) and contour area (mm²) over time, sensors in colours | 1200 × 680 |
//! | `servo` | commanded motion (x, y) and contact offset (x, y, distance) over time, sensors in colours | 1200 × 680 |
//! | `dos` | decided class over time per sensor (one row per class of `gradtac.dos.classes`), marker shade = posterior of the decided class | 1200 × 340·s |
//!
//! Times are drawn in seconds from the first row of the file (its epoch may be Unix time).
//! An archive's finished `*.parquet` files are found recursively in lexical path order
//! (hidden and `_` names, such as the `.partial` files being written, are skipped) and must
//! share one schema; their rows count together for decimation.
//! The layout comes from the file's `gradtac.layout.<sensor>` or `gradtac.layout` metadata (CSV,
//! as the CLI writes it) and falls back to the built-in BioTac SP layout when the file has none
//! and the taxel count matches (or for `contour` and `track` files, which carry no taxel count).
//! Large files (and archives) are decimated while reading (every k-th row, k a prime ≥ 11 so interleaved sensors
//! are all sampled; at most `MAX_POINTS · MAX_SENSORS` rows, ten times that for events, a tenth
//! for windows, ≈ 64 MB of values for surfaces), so memory stays bounded for long archives, and
//! again for drawing (at most [`MAX_POINTS`] points per series); [`PlotSummary::notes`] says when.
//!
//! The demo's plots take plain data, not files: [`plot_surface_with_contours`],
//! [`plot_trajectory_vs_truth`] and [`plot_slip_timeline`].
//!
//! Text uses DejaVu Sans from the [`dejavu`] crate, registered with plotters' `ab_glyph`
//! renderer: no system font library is needed.
//!
//! Every mark has a legend entry; layout-plane axes are in mm with the finger's orientation
//! (BioTac SP: x along the finger toward the tip, y across the pad); titles name the sensor
//! and what is drawn, not the schema id.
//!
//! Output files are written to `<name>.partial` and renamed, so an image under its final name
//! is complete.

use crate::Error;
use arrow_array::cast::AsArray;
use arrow_array::types::{Float64Type, Int64Type, Int8Type, UInt16Type};
use arrow_array::{Array, ArrayRef, RecordBatch};
use arrow_schema::SchemaRef;
use gradtac_stages::contour::{isolines, ContourConfig, ContourOutcome, Levels, MaxContourFinder};
use gradtac_stages::interpolate::Grid;
use gradtac_stages::slip::{SlipClass, SlipEvent};
use gradtac_stream::{Extent, Layout};
use ndarray::ArrayView2;
use parquet::arrow::arrow_reader::{
    ArrowReaderMetadata, ArrowReaderOptions, ParquetRecordBatchReaderBuilder, RowSelection, RowSelector,
};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::collections::HashMap;
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// The schemas [`plot_parquet`] knows.
pub const KNOWN: [&str; 22] = [
    "frame/1",
    "frame/2",
    "event/1",
    "event/2",
    "window/1",
    "window/2",
    "surface/1",
    "surface/2",
    "contour/1",
    "contour/2",
    "track/1",
    "track/2",
    "track/3",
    "slip/1",
    "slip/2",
    "force/1",
    "force/2",
    "servo/1",
    "servo/2",
    "dos/1",
    "dos/2",
    "dos/3",
];

/// At most this many sensors of one file are drawn (the rest are named in the notes).
pub const MAX_SENSORS: usize = 4;
/// At most this many points per drawn series (events: per panel); more rows are decimated.
pub const MAX_POINTS: usize = 20_000;
/// Number of iso-lines drawn on a surface (evenly spaced strictly between its minimum and
/// maximum, as the contour stage's default `levels = 10`).
pub const ISO_LEVELS: usize = 10;

const PANEL_W: u32 = 1200;
const STRIP_H: u32 = 340;
const BAR_W: u32 = 120;
const SURF_PANEL: u32 = 380;
const SURF_ROW_H: u32 = 400;
const TITLE_H: u32 = 40;
const TRACK_PANEL: u32 = 640;
const TRACK_H: u32 = 680;

/// What a plot drew.
#[derive(Clone, Debug, PartialEq)]
pub struct PlotSummary {
    /// The schema id of the input (`frame/2`, …), or the plot's kind for the direct
    /// functions (`surface`, `trajectory`, `slip timeline`).
    pub kind: String,
    /// Rows (or points) read.
    pub rows: u64,
    /// Rows (or points) drawn, after decimation.
    pub drawn: u64,
    /// Sensors drawn, in order of first appearance.
    pub sensors: Vec<String>,
    /// Image width (px).
    pub width: u32,
    /// Image height (px).
    pub height: u32,
    /// Remarks: decimation, sensors left out, the layout used, contours recomputed.
    pub notes: Vec<String>,
}

impl fmt::Display for PlotSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{}: {} rows, {} drawn, sensors [{}], {}×{} px",
            self.kind,
            self.rows,
            self.drawn,
            self.sensors.join(", "),
            self.width,
            self.height
        )?;
        for n in &self.notes {
            writeln!(f, "  {n}")?;
        }
        Ok(())
    }
}

/// One instant of [`plot_surface_with_contours`].
#[derive(Clone, Debug, PartialEq)]
pub struct SurfacePanel {
    /// Panel title, e.g. `"t = 1.20 s"`.
    pub label: String,
    /// The surface on the grid, row-major (`row·nx + col` is the value at `(x(col), y(row))`),
    /// as in `surface/2`; NaN is drawn grey (outside the taxels' hull).
    pub values: Vec<f64>,
    /// The maximal contour's outline (mm) if known; `None`: found with the contour stage's
    /// defaults (10 levels, min area 1 mm², any peak).
    pub contour: Option<Vec<[f64; 2]>>,
    /// A true contact position to mark (mm), e.g. the simulator's.
    pub truth: Option<[f64; 2]>,
}

/// A sensor's track for [`plot_slip_timeline`]: `(t s, x mm, y mm)`, NaN without contact.
#[derive(Clone, Copy, Debug)]
pub struct TimelineTrack<'a> {
    /// Sensor name (legend).
    pub sensor: &'a str,
    /// Its points.
    pub points: &'a [(f64, f64, f64)],
}

/// Drawing errors without a path; [`Error::Plot`] adds it.
#[derive(Debug)]
struct PlotErr(String);

impl<E: std::error::Error + Send + Sync> From<DrawingAreaErrorKind<E>> for PlotErr {
    fn from(e: DrawingAreaErrorKind<E>) -> Self {
        PlotErr(format!("drawing failed: {e}"))
    }
}

impl From<String> for PlotErr {
    fn from(s: String) -> Self {
        PlotErr(s)
    }
}

type R<T> = std::result::Result<T, PlotErr>;
type Area<'a> = DrawingArea<AnyBackend<'a>, Shift>;
/// Rows of each sensor, `(batch, row)`, in order of first appearance.
type Groups = Vec<(String, Vec<(usize, usize)>)>;
/// A `FixedSizeList<Float64, n>` column: `n` and the concatenated values.
type ListCol = (usize, Vec<f64>);
/// A polygon (mm).
type Outline = Vec<[f64; 2]>;
type DrawFn = Box<dyn FnOnce(&Area<'_>) -> R<()>>;

fn plot_error(path: &Path, e: PlotErr) -> Error {
    Error::Plot { path: path.to_path_buf(), reason: e.0 }
}

fn register_fonts() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // DejaVu Sans ships inside the `dejavu` crate; registering valid TTF bytes cannot fail.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular());
        let _ = plotters::style::register_font("sans-serif", FontStyle::Bold, dejavu::sans::bold());
    });
}

/// Draw with `draw` and write the image to `out` in the format of its extension
/// ([`ImageFormat::of`]: SVG for `.svg`, PNG otherwise), via `<out>.partial` + rename, so a
/// file under its final name is complete.
fn render(out: &Path, (w, h): (u32, u32), draw: impl FnOnce(&Area<'_>) -> R<()>) -> Result<(), Error> {
    register_fonts();
    let mut tmp = out.as_os_str().to_owned();
    tmp.push(".partial");
    let tmp = PathBuf::from(tmp);
    let io = |source: std::io::Error| Error::Io { path: tmp.clone(), source };
    match ImageFormat::of(out) {
        ImageFormat::Svg => {
            let mut svg = String::new();
            {
                let root = AnyBackend::Svg(SVGBackend::with_string(&mut svg, (w, h))).into_drawing_area();
                root.fill(&WHITE).map_err(|e| plot_error(out, e.into()))?;
                draw(&root).map_err(|e| plot_error(out, e))?;
                root.present().map_err(|e| plot_error(out, e.into()))?;
            }
            std::fs::write(&tmp, svg).map_err(io)?;
        }
        ImageFormat::Png => {
            let mut buf = vec![0u8; w as usize * h as usize * 3];
            {
                let root = AnyBackend::Bitmap(BitMapBackend::with_buffer(&mut buf, (w, h))).into_drawing_area();
                root.fill(&WHITE).map_err(|e| plot_error(out, e.into()))?;
                draw(&root).map_err(|e| plot_error(out, e))?;
                root.present().map_err(|e| plot_error(out, e.into()))?;
            }
            let file = std::fs::File::create(&tmp).map_err(io)?;
            let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let png_err = |e: png::EncodingError| plot_error(out, PlotErr(format!("PNG encoding failed: {e}")));
            let mut writer = enc.write_header().map_err(png_err)?;
            writer.write_image_data(&buf).map_err(png_err)?;
            writer.finish().map_err(png_err)?;
        }
    }
    std::fs::rename(&tmp, out).map_err(|source| Error::Io { path: out.to_path_buf(), source })?;
    Ok(())
}

mod backend;
mod contour;
mod read;
mod series;
mod slip;
mod style;
mod surface;
mod track;
use backend::AnyBackend;
pub use backend::ImageFormat;
use contour::*;
use read::*;
use series::*;
pub use slip::plot_slip_timeline;
use slip::*;
use style::*;
pub use surface::plot_surface_with_contours;
use surface::*;
pub use track::plot_trajectory_vs_truth;
use track::*;

/// Plot a Parquet file written by a gradtac sink, or a directory of them (an archive written
/// by [`ParquetArchive`](gradtac_io::ParquetArchive)), as a PNG at `output_png`; see the
/// [module docs](self) for what each schema gives.
///
/// A directory is read as one table: its finished `*.parquet` files, found recursively (so
/// hive partitions `sensor=<name>/` are included; a file without a `sensor` column — the
/// archive default — takes it from its `sensor=<name>` directory) in
/// lexical order of their paths, which is an archive's write order; names starting with `.`
/// or `_` (the archive's `.<name>.partial` files being written, `_SUCCESS`) are skipped. The
/// files must share one `gradtac.schema` and the same columns. Their key-value metadata is
/// merged (the first file holding a key gives its value). Decimation counts the rows of all
/// files, so memory stays bounded however many files there are. [`PlotSummary::rows`] is the
/// sum over the files; the notes say how many files were read.
///
/// # Errors
/// [`Error::Plot`] (naming `input`, and for a directory the file at fault relative to it) when
/// a file cannot be read, has no `gradtac.schema` metadata, an unknown schema, or columns that
/// do not match it; when a directory holds no finished Parquet file, or files of different
/// schemas; or when drawing fails. [`Error::Io`] when the image cannot be written.
pub fn plot_parquet(input: &Path, output: &Path) -> Result<PlotSummary, Error> {
    plot_parquet_with(input, output, &PlotOptions::default())
}

/// What [`plot_parquet_with`] draws of a file: some sensors, a time span.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlotOptions {
    /// Only these sensors (all when empty; a slip file's pair matches by either of its two
    /// sensors). A name the file does not hold is an error.
    pub sensors: Vec<String>,
    /// Only rows from this many seconds after the file's (archive's) first time.
    pub from: Option<f64>,
    /// Only rows up to this many seconds after the file's first time.
    pub to: Option<f64>,
}

impl PlotOptions {
    fn check(&self) -> R<()> {
        for (name, v) in [("--from", self.from), ("--to", self.to)] {
            if v.is_some_and(|v| !v.is_finite()) {
                return Err(PlotErr(format!("{name} must be a finite number of seconds")));
            }
        }
        if let (Some(f), Some(t)) = (self.from, self.to) {
            if f > t {
                return Err(PlotErr(format!("--from {f} s is after --to {t} s")));
            }
        }
        Ok(())
    }
}

/// [`plot_parquet`] with [`PlotOptions`]: only some sensors, only a span of time. The filters
/// apply to the rows read (after the decimation of large files). The format is the output's
/// extension's: SVG for `.svg`, PNG otherwise.
pub fn plot_parquet_with(input: &Path, output: &Path, options: &PlotOptions) -> Result<PlotSummary, Error> {
    let output_png = output;
    options.check().map_err(|e| plot_error(input, e))?;
    let mut notes = Vec::new();
    let table = read_table(input)
        .and_then(normalise)
        .and_then(|t| filter_rows(t, options, &mut notes))
        .map_err(|e| plot_error(input, e))?;
    if let Some(files) = &table.files {
        let n = files.len();
        let s = if n == 1 { "" } else { "s" };
        notes.push(format!("archive: {n} Parquet file{s} read as one table"));
    }
    if let Some(k) = table.stride {
        let what = if table.files.is_some() { "archive" } else { "file" };
        notes.push(format!("large {what}: every {k}th of its {} rows read", table.total_rows));
    }
    let plan = match family(&table.schema_id).0 {
        "frame" => frames_plot(&table, &mut notes),
        "event" => events_plot(&table, &mut notes),
        "window" => window_plot(&table, &mut notes),
        "surface" => surface_plot(&table, &mut notes),
        "contour" => contour_plot(&table, &mut notes),
        "track" => track_plot(&table, &mut notes),
        "slip" => slip_plot(&table),
        "force" => series_plot(
            &table,
            &mut notes,
            "time",
            &[("estimated normal force", "force (N)", &["force_n"]), ("contact area", "area (mm²)", &["area_mm2"])],
        ),
        "servo" => series_plot(
            &table,
            &mut notes,
            "time",
            &[
                ("commanded sensor motion (layout frame)", "motion (mm)", &["motion_x_mm", "motion_y_mm"]),
                (
                    "contact offset from the servo centre (layout frame)",
                    "offset (mm)",
                    &["offset_x_mm", "offset_y_mm", "distance_mm"],
                ),
            ],
        ),
        "dos" => dos_plot(&table, &mut notes),
        other => Err(PlotErr(format!("unknown schema {other:?}"))),
    }
    .map_err(|e| plot_error(input, e))?;
    let Prepared { size, sensors, drawn, draw } = plan;
    render(output_png, size, |root| draw(root))?;
    Ok(PlotSummary {
        kind: table.schema_id.clone(),
        rows: table.total_rows as u64,
        drawn,
        sensors,
        width: size.0,
        height: size.1,
        notes,
    })
}

/// A plot read and laid out, ready to draw.
struct Prepared {
    size: (u32, u32),
    sensors: Vec<String>,
    drawn: u64,
    draw: DrawFn,
}

fn no_rows(t: &Table) -> R<()> {
    if t.rows() == 0 {
        return Err(PlotErr(format!("{} file without rows: nothing to plot", t.schema_id)));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Selecting file by file with the running offset picks exactly every k-th row of the
    /// concatenated table, whatever the file sizes (empty files, files shorter than k).
    #[test]
    fn every_kth_spans_file_boundaries() {
        for (sizes, k) in [
            (vec![100], 11),
            (vec![25, 25, 25, 10], 11),
            (vec![3, 0, 5, 1, 40, 7], 11),
            (vec![10, 11, 12, 13], 13),
            (vec![1, 1, 1, 1, 1], 2),
        ] {
            let mut picked = Vec::new();
            let mut first = 0;
            for n in sizes.iter().copied() {
                let sel = every_kth(n, first, k);
                assert_eq!(sel.iter().map(|s| s.row_count).sum::<usize>(), n, "{sizes:?}");
                let mut i = first;
                for s in sel.iter() {
                    if !s.skip {
                        picked.extend(i..i + s.row_count);
                    }
                    i += s.row_count;
                }
                first += n;
            }
            let want: Vec<usize> = (0..first).step_by(k).collect();
            assert_eq!(picked, want, "{sizes:?} k={k}");
        }
    }
}
