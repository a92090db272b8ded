//! PNG plots of gradtac outputs (`gradtac plot`) and of the demo's results, drawn with
//! [`plotters`] into a pixel buffer and encoded with [`png`].
//!
//! [`plot_parquet`] reads any Parquet file a gradtac sink wrote, or a directory of them (an
//! archive: rolled files, optionally hive-partitioned `sensor=<name>/`, read as one table),
//! detects its schema from the `gradtac.schema` key-value metadata (`docs/schemas.md`) and
//! draws:
//!
//! | schema | plot | size (px, `s` = sensors drawn, at most [`MAX_SENSORS`]) |
//! |---|---|---|
//! | `frame/1` | one line per taxel over time, one panel per sensor | 1200 × 340·s |
//! | `event/1` | raster: time × taxel, red = +1, blue = −1, one panel per sensor | 1200 × 340·s |
//! | `window/1` | heat strip: time × taxel, colour = aggregate (diverging for `signed`), one panel per sensor | 1320 × 340·s |
//! | `surface/1` | the surface at 4 instants (evenly spaced over the rows with a contact, else over all rows) with 10 iso-lines and the maximal contour (bold) recomputed from the surface, taxels as circles; one row per sensor | 1640 × (40 + 400·s) |
//! | `contour/1` | left: centroid paths on the layout plane with the outlines of 4 contours; right: area (mm²) over time; sensors in colours | 1400 × 620 |
//! | `track/1` | trajectory on the layout plane coloured by time, taxels as labelled circles; one panel per sensor | 640·s + 120 × 680 |
//! | `slip/1` | the grasp's state over time (a class strip from each event's decision time) and the common / differential speeds at the events | 1200 × 560 |
//! | `force/1` | force (N) and contour area (mm²) over time, sensors in colours | 1200 × 680 |
//! | `servo/1` | commanded motion (x, y) and contact offset (x, y, distance) over time, sensors in colours | 1200 × 680 |
//! | `dos/2` (and `dos/1`) | decided class over time per sensor (one row per class of `gradtac.dos.classes`), marker shade = posterior of the decided class | 1200 × 340·s |
//!
//! Times are drawn in seconds from the first row of the file (its epoch may be Unix time).
//! An archive's finished `*.parquet` files are found recursively in lexical path order
//! (hidden and `_` names, such as the `.partial` files being written, are skipped) and must
//! share one schema; their rows count together for decimation.
//! The layout comes from the file's `gradtac.layout.<sensor>` or `gradtac.layout` metadata (CSV,
//! as the CLI writes it) and falls back to the built-in BioTac SP layout when the file has none
//! and the taxel count matches (or for `contour/1` and `track/1`, which carry no taxel count).
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
//! Output files are written to `<name>.partial` and renamed, so a PNG under its final name is
//! complete. The PNG format is used whatever the file's extension.

use crate::Error;
use arrow_array::cast::AsArray;
use arrow_array::types::{Float64Type, Int64Type, Int8Type, UInt16Type};
use arrow_array::{Array, ArrayRef, RecordBatch};
use arrow_schema::SchemaRef;
use gradtac_stages::contour::{isolines, ContourConfig, ContourOutcome, MaxContourFinder, Saddle};
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
pub const KNOWN: [&str; 11] = [
    "frame/1",
    "event/1",
    "window/1",
    "surface/1",
    "contour/1",
    "track/1",
    "slip/1",
    "force/1",
    "servo/1",
    "dos/1",
    "dos/2",
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
    /// The schema id of the input (`frame/1`, …), or the plot's kind for the direct
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
    /// as in `surface/1`; NaN is drawn grey (outside the taxels' hull).
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
type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;
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

/// Render into an RGB buffer with `draw`, then write it as PNG via `<out>.partial` + rename.
fn render(out: &Path, (w, h): (u32, u32), draw: impl FnOnce(&Area<'_>) -> R<()>) -> Result<(), Error> {
    register_fonts();
    let mut buf = vec![0u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_error(out, e.into()))?;
        draw(&root).map_err(|e| plot_error(out, e))?;
        root.present().map_err(|e| plot_error(out, e.into()))?;
    }
    let mut tmp = out.as_os_str().to_owned();
    tmp.push(".partial");
    let tmp = PathBuf::from(tmp);
    let io = |source: std::io::Error| Error::Io { path: tmp.clone(), source };
    let file = std::fs::File::create(&tmp).map_err(io)?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let png_err = |e: png::EncodingError| plot_error(out, PlotErr(format!("PNG encoding failed: {e}")));
    let mut writer = enc.write_header().map_err(png_err)?;
    writer.write_image_data(&buf).map_err(png_err)?;
    writer.finish().map_err(png_err)?;
    std::fs::rename(&tmp, out).map_err(|source| Error::Io { path: out.to_path_buf(), source })?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// colours

fn lerp_table(table: &[(u8, u8, u8)], t: f64) -> RGBColor {
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    let x = t * (table.len() - 1) as f64;
    let i = (x.floor() as usize).min(table.len() - 2);
    let f = x - i as f64;
    let (a, b) = (table[i], table[i + 1]);
    let m = |p: u8, q: u8| (p as f64 + (q as f64 - p as f64) * f).round() as u8;
    RGBColor(m(a.0, b.0), m(a.1, b.1), m(a.2, b.2))
}

/// Viridis (matplotlib's), 9 anchors, `t` in [0, 1].
fn viridis(t: f64) -> RGBColor {
    const V: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (71, 44, 122),
        (59, 81, 139),
        (44, 113, 142),
        (33, 144, 141),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ];
    lerp_table(&V, t)
}

/// Blue – white – red, `t` in [0, 1] (0.5 white).
fn diverging(t: f64) -> RGBColor {
    const D: [(u8, u8, u8); 5] = [(33, 102, 172), (146, 197, 222), (247, 247, 247), (244, 165, 130), (178, 24, 43)];
    lerp_table(&D, t)
}

const NAN_GREY: RGBColor = RGBColor(225, 225, 225);

fn series_colour(i: usize) -> RGBColor {
    let c = Palette99::pick(i).to_rgba();
    RGBColor(c.0, c.1, c.2)
}

// ---------------------------------------------------------------------------------------------
// chart scaffolding shared by the panels

/// A point on a backend (px), as plotters' `BackendCoord`: where legend keys are drawn.
type BackendCoord = (i32, i32);

/// A chart's box along one axis, `(from, to)`, as [`clamp_pt`] and [`segments`] take it.
type Bounds = (f64, f64);

/// A chart with f64 axes on the backend `DB`.
type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The sizes (px) around a chart: its caption's font, the margin on every side, and the label
/// areas below the plot (x axis) and left of it (y axis).
#[derive(Clone, Copy)]
struct Frame {
    caption: i32,
    margin: i32,
    x_area: i32,
    y_area: i32,
}

/// The frame of most panels: an 18 px caption, 12 px margins, 36 px of x labels, 60 px of y
/// labels (others are this with a field changed).
const PANEL: Frame = Frame { caption: 18, margin: 12, x_area: 36, y_area: 60 };

/// A chart of `xr × yr` on `area`, `caption` above it in sans-serif, sized by `frame`.
fn chart_on<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    caption: impl AsRef<str>,
    frame: Frame,
    xr: Range<f64>,
    yr: Range<f64>,
) -> R<Chart<'a, DB>> {
    Ok(ChartBuilder::on(area)
        .caption(caption, ("sans-serif", frame.caption))
        .margin(frame.margin)
        .x_label_area_size(frame.x_area)
        .y_label_area_size(frame.y_area)
        .build_cartesian_2d(xr, yr)?)
}

/// The mesh (grid lines and both axes) of `chart`, with the axis descriptions `x_desc` (none:
/// `None`) and `y_desc`, labels in `label_px` sans-serif.
fn draw_axes<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    x_desc: Option<&str>,
    y_desc: &str,
    label_px: i32,
) -> R<()> {
    let mut mesh = chart.configure_mesh();
    if let Some(d) = x_desc {
        mesh.x_desc(d);
    }
    mesh.y_desc(y_desc).label_style(("sans-serif", label_px)).draw()?;
    Ok(())
}

/// The legend of `chart`'s labelled series at `position`: a white box of opacity `background`
/// with a thin grey border, labels in `font_px` sans-serif.
fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
    background: f64,
    font_px: i32,
) -> R<()> {
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(background))
        .border_style(BLACK.mix(0.3))
        .label_font(("sans-serif", font_px))
        .draw()?;
    Ok(())
}

/// A legend entry without data: `label` with the key `key` (e.g. [`line_key`]).
fn legend_entry<'a, DB, E, F>(chart: &mut Chart<'a, DB>, label: impl Into<String>, key: F) -> R<()>
where
    DB: DrawingBackend + 'a,
    E: IntoDynElement<'a, DB, BackendCoord>,
    F: Fn(BackendCoord) -> E + 'a,
{
    chart.draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?.label(label).legend(key);
    Ok(())
}

/// A legend key: a 14 px line drawn with `style`.
fn line_key(style: impl Into<ShapeStyle>) -> impl Fn(BackendCoord) -> PathElement<BackendCoord> {
    let style = style.into();
    move |(x, y)| PathElement::new(vec![(x, y), (x + 14, y)], style)
}

/// A legend key: a dot of `colour`.
fn dot_key(colour: RGBColor) -> impl Fn(BackendCoord) -> Circle<BackendCoord, i32> {
    move |(x, y)| Circle::new((x + 7, y), 4, colour.filled())
}

/// The row index an axis value `v` labels: `v` itself when it is whole and not negative, else
/// `None` (a tick between rows, left blank).
fn row_index(v: f64) -> Option<f64> {
    let i = v.round();
    if (v - i).abs() > 1e-9 || i < 0.0 {
        None
    } else {
        Some(i)
    }
}

/// A taxel axis label: the name of the taxel row `v` (its index when `names` has none), blank
/// between rows.
fn taxel_label(names: Option<&[String]>, v: f64) -> String {
    match row_index(v) {
        None => String::new(),
        Some(i) => names.and_then(|nm| nm.get(i as usize).cloned()).unwrap_or_else(|| format!("{i}")),
    }
}

/// An equal-aspect chart of `layout`'s plane (axes in mm) on `area`, `title` above, with the
/// taxels as labelled circles; and the chart's box `(x, y)` for [`clamp_pt`] and [`segments`].
fn plane_chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    title: &str,
    layout: &Layout,
) -> R<(Chart<'a, DB>, Bounds, Bounds)>
where
    DB::ErrorType: 'static,
{
    let (w, h) = area.dim_in_pixel();
    let (xr, yr) = equal_aspect(layout.extent(), w as f64 - 80.0, h as f64 - 90.0);
    let (bx, by) = ((xr.start, xr.end), (yr.start, yr.end));
    let mut chart = chart_on(area, title, Frame { y_area: 44, ..PANEL }, xr, yr)?;
    draw_axes(&mut chart, Some("x (mm)"), "y (mm)", 12)?;
    draw_taxels(&mut chart, layout, true)?;
    Ok((chart, bx, by))
}

/// Vertical dashed lines (4 px dashes, 4 px gaps) in `style` at each of `xs`, from `y0` to `y1`.
fn draw_onsets<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    xs: impl IntoIterator<Item = f64>,
    (y0, y1): (f64, f64),
    style: ShapeStyle,
) -> R<()> {
    for x in xs {
        chart.draw_series(DashedLineSeries::new(vec![(x, y0), (x, y1)], 4, 4, style))?;
    }
    Ok(())
}

/// The spans `(from, to, class)` of a class held from each `(time, class)` of `steps` (in time
/// order) to the next one's time, the last to `end`; empty spans are left out.
fn class_spans(steps: &[(f64, SlipClass)], end: f64) -> Vec<(f64, f64, SlipClass)> {
    let mut out = Vec::new();
    for (i, &(t, c)) in steps.iter().enumerate() {
        let to = steps.get(i + 1).map_or(end, |p| p.0);
        if to > t {
            out.push((t, to, c));
        }
    }
    out
}

/// The legend of the slip-class colours ([`slip_colour`]) on a class strip.
fn slip_legend<'a, DB: DrawingBackend + 'a>(strip: &mut Chart<'a, DB>) -> R<()> {
    for c in SlipClass::ALL {
        let col = slip_colour(c);
        legend_entry(strip, c.name(), move |(x, y)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], col.filled()))?;
    }
    draw_legend(strip, SeriesLabelPosition::UpperRight, 0.9, 11)
}

/// Each sensor's rows of `groups`, every [`draw_stride`]-th (at most `max`; `what` names them in
/// the note), as the points `point(batch, row)` gives; and how many points there are in all.
fn thin_rows<T>(
    groups: &Groups,
    max: usize,
    what: &str,
    notes: &mut Vec<String>,
    mut point: impl FnMut(usize, usize) -> T,
) -> (Vec<(String, Vec<T>)>, u64) {
    let mut series = Vec::new();
    let mut drawn = 0u64;
    for (sensor, rows) in groups {
        let k = draw_stride(sensor, rows.len(), max, what, notes);
        let pts: Vec<T> = rows.iter().step_by(k).map(|&(bi, ri)| point(bi, ri)).collect();
        drawn += pts.len() as u64;
        series.push((sensor.clone(), pts));
    }
    (series, drawn)
}

/// The values of row `ri` of a [`ListCol`].
fn list_row((m, v): &ListCol, ri: usize) -> &[f64] {
    &v[ri * m..(ri + 1) * m]
}

/// The stride that draws at most `max` of a sensor's `rows` rows; above 1, a note says so
/// (`what`: the rows' noun, plural).
fn draw_stride(sensor: &str, rows: usize, max: usize, what: &str, notes: &mut Vec<String>) -> usize {
    let k = stride(rows, max);
    if k > 1 {
        notes.push(format!("{sensor}: every {k}th of {rows} {what} drawn"));
    }
    k
}

fn slip_colour(c: SlipClass) -> RGBColor {
    match c {
        SlipClass::Stable => RGBColor(200, 200, 200),
        SlipClass::LongitudinalUp => RGBColor(31, 119, 180),
        SlipClass::LongitudinalDown => RGBColor(255, 127, 14),
        SlipClass::RotationalCw => RGBColor(44, 160, 44),
        SlipClass::RotationalCcw => RGBColor(214, 39, 40),
    }
}

/// A value range `[lo, hi]` with `hi > lo` from finite values (a flat or empty set is widened).
fn range_of(values: impl IntoIterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.into_iter().filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return (0.0, 1.0);
    }
    // beyond ±1e300 the chart's arithmetic overflows: such values are drawn at the edge
    let (lo, hi) = (lo.clamp(-BIG, BIG), hi.clamp(-BIG, BIG));
    if hi - lo < 1e-12 * (1.0 + lo.abs().max(hi.abs())) {
        let d = if lo == 0.0 { 1.0 } else { lo.abs() * 0.05 };
        return (lo - d, hi + d);
    }
    (lo, hi)
}

/// Largest magnitude a plotted value keeps; larger ones are clamped to it.
const BIG: f64 = 1e300;

/// `v` clamped into `r` widened by twice its span on each side (a point far outside a chart
/// would overflow plotters' pixel arithmetic; the widened band keeps lines' directions), NaN
/// kept (callers skip it).
fn clampr(v: f64, r: (f64, f64)) -> f64 {
    let s = 2.0 * (r.1 - r.0);
    if v.is_nan() {
        v
    } else {
        v.clamp(r.0 - s, r.1 + s)
    }
}

/// A point clamped into a chart's widened box (see [`clampr`]).
fn clamp_pt((x, y): (f64, f64), xr: (f64, f64), yr: (f64, f64)) -> (f64, f64) {
    (clampr(x, xr), clampr(y, yr))
}

fn padded((lo, hi): (f64, f64), f: f64) -> (f64, f64) {
    let d = (hi - lo) * f;
    (lo - d, hi + d)
}

/// A vertical colour bar for `[lo, hi]` with its label.
fn colour_bar(area: &Area<'_>, lo: f64, hi: f64, cmap: fn(f64) -> RGBColor, label: &str) -> R<()> {
    let mut chart = ChartBuilder::on(area)
        .margin_top(30)
        .margin_bottom(50)
        .margin_right(30)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..1.0, lo..hi)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(6)
        .y_desc(label)
        .label_style(("sans-serif", 13))
        .draw()?;
    let n = 100;
    chart.draw_series((0..n).map(|i| {
        let a = lo + (hi - lo) * i as f64 / n as f64;
        let b = lo + (hi - lo) * (i + 1) as f64 / n as f64;
        Rectangle::new([(0.0, a), (1.0, b)], cmap((i as f64 + 0.5) / n as f64).filled())
    }))?;
    Ok(())
}

/// Ranges for an equal-aspect chart of `extent` in a plot area of `w × h` px.
fn equal_aspect(e: Extent, w: f64, h: f64) -> (std::ops::Range<f64>, std::ops::Range<f64>) {
    let (ew, eh) = (e.width(), e.height());
    let s = (ew / w.max(1.0)).max(eh / h.max(1.0));
    let (cx, cy) = (0.5 * (e.x_min + e.x_max), 0.5 * (e.y_min + e.y_max));
    let (hw, hh) = (0.5 * s * w, 0.5 * s * h);
    (cx - hw..cx + hw, cy - hh..cy + hh)
}

/// Taxels as grey circles, labelled when `names`.
fn draw_taxels<DB: DrawingBackend>(chart: &mut Chart<'_, DB>, layout: &Layout, names: bool) -> R<()>
where
    DB::ErrorType: 'static,
{
    let grey = RGBColor(90, 90, 90);
    chart
        .draw_series(layout.positions().iter().map(|p| Circle::new((p[0], p[1]), 5, grey.stroke_width(1))))
        .map_err(|e| PlotErr(format!("drawing failed: {e}")))?;
    if names {
        let style = ("sans-serif", 11).into_font().color(&grey);
        chart
            .draw_series(layout.positions().iter().zip(layout.names()).map(|(p, n)| {
                Text::new(n.clone(), (p[0], p[1]), style.clone().pos(Pos::new(HPos::Left, VPos::Bottom)))
            }))
            .map_err(|e| PlotErr(format!("drawing failed: {e}")))?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// reading Parquet

/// What [`read_table`] read: one file, or the files of an archive directory as one table.
struct Table {
    schema_id: String,
    /// Key-value metadata: the file's, or for an archive the union over its files (the first
    /// file holding a key gives its value).
    kv: HashMap<String, String>,
    schema: SchemaRef,
    /// The rows read (all, or every `stride`-th), in file order.
    batches: Vec<RecordBatch>,
    /// Rows in the file (in all the archive's files).
    total_rows: usize,
    /// Every this many rows were read (`None`: all).
    stride: Option<usize>,
    /// For a directory, its Parquet files read, in order (relative to the directory).
    files: Option<Vec<PathBuf>>,
}

impl Table {
    fn rows(&self) -> usize {
        self.batches.iter().map(RecordBatch::num_rows).sum()
    }

    /// The layout for `sensor`: its own metadata, the file's, or the BioTac SP when `taxels`
    /// (if given) matches its count.
    fn layout(&self, sensor: &str, taxels: Option<usize>, notes: &mut Vec<String>) -> Option<Layout> {
        for key in [format!("gradtac.layout.{sensor}"), "gradtac.layout".to_string()] {
            if let Some(csv) = self.kv.get(&key) {
                match Layout::from_csv_reader("layout", csv.as_bytes(), Path::new(&key)) {
                    Ok(l) if taxels.is_none_or(|n| n == l.len()) => return Some(l),
                    Ok(l) => notes.push(format!("{key}: {} taxels, the data has {taxels:?}; ignored", l.len())),
                    Err(e) => notes.push(format!("{key} is not a layout CSV ({e}); ignored")),
                }
            }
        }
        let b = Layout::biotac_sp();
        if taxels.is_none_or(|n| n == b.len()) {
            notes.push(format!("{sensor}: no layout in the file; the built-in BioTac SP layout is drawn"));
            Some(b)
        } else {
            None
        }
    }
}

/// Read a Parquet file, or every finished Parquet file of a directory (an archive) as one
/// table; see [`plot_parquet`].
fn read_table(path: &Path) -> R<Table> {
    if path.is_dir() {
        read_archive(path)
    } else {
        read_file(path)
    }
}

/// A Parquet file opened for reading (footer parsed and checked, no rows read yet).
struct Opened {
    file: std::fs::File,
    meta: ArrowReaderMetadata,
    kv: HashMap<String, String>,
    schema: SchemaRef,
    /// Its `gradtac.schema`, one of [`KNOWN`].
    schema_id: String,
    rows: usize,
}

/// Open a Parquet file and check that it is a gradtac file of a known schema.
///
/// The footer is parsed by the parquet crate; a panic inside it on a malformed footer (an
/// upstream bug) is contained and reported as this file's error (see
/// [`gradtac_io::contain`]). The row counts of the footer must add up.
fn open_parquet(path: &Path) -> R<Opened> {
    let file = std::fs::File::open(path).map_err(|e| PlotErr(format!("cannot open: {e}")))?;
    let meta = match gradtac_io::contain::contain(|| ArrowReaderMetadata::load(&file, ArrowReaderOptions::new())) {
        Ok(Ok(m)) => m,
        Ok(Err(e)) => return Err(PlotErr(format!("not a readable Parquet file: {e}"))),
        Err(panic) => {
            return Err(PlotErr(format!(
                "not a readable Parquet file (the parquet reader panicked on its footer: {panic})"
            )))
        }
    };
    let fm = meta.metadata().file_metadata();
    let kv: HashMap<String, String> = fm
        .key_value_metadata()
        .map(|v| v.iter().filter_map(|kv| Some((kv.key.clone(), kv.value.clone()?))).collect())
        .unwrap_or_default();
    let schema = meta.schema().clone();
    let schema_id = kv
        .get(gradtac_io::records::SCHEMA_KEY)
        .or_else(|| schema.metadata().get(gradtac_io::records::SCHEMA_KEY))
        .cloned()
        .ok_or_else(|| {
            PlotErr(format!("no `{}` metadata: not a file written by a gradtac sink", gradtac_io::records::SCHEMA_KEY))
        })?;
    if !KNOWN.contains(&schema_id.as_str()) {
        return Err(PlotErr(format!("unknown schema {schema_id:?} (known: {})", KNOWN.join(", "))));
    }
    let rows =
        usize::try_from(fm.num_rows()).map_err(|_| PlotErr(format!("malformed footer: {} rows", fm.num_rows())))?;
    let len = file.metadata().map_err(|e| PlotErr(format!("cannot open: {e}")))?.len();
    let mut in_groups = 0usize;
    for (i, rg) in meta.metadata().row_groups().iter().enumerate() {
        let n = usize::try_from(rg.num_rows())
            .map_err(|_| PlotErr(format!("malformed footer: row group {i} has {} rows", rg.num_rows())))?;
        in_groups = in_groups.saturating_add(n);
        // where the reader will seek: inside the file (the parquet crate asserts non-negative)
        for (j, c) in rg.columns().iter().enumerate() {
            let start = c.dictionary_page_offset().unwrap_or(c.data_page_offset());
            let size = c.compressed_size();
            let end = u64::try_from(start).ok().zip(u64::try_from(size).ok()).and_then(|(a, b)| a.checked_add(b));
            if end.is_none_or(|e| e > len) {
                return Err(PlotErr(format!(
                    "malformed footer: row group {i} column {j} at byte {start} ({size} bytes) lies outside the file \
                     ({len} bytes)"
                )));
            }
        }
    }
    if in_groups != rows {
        return Err(PlotErr(format!("malformed footer: {rows} rows in the file, {in_groups} in its row groups")));
    }
    Ok(Opened { file, meta, kv, schema, schema_id, rows })
}

/// The decimation stride for `total_rows` rows of a table (`None`: read them all). Large
/// tables are decimated while reading (memory stays bounded): every k-th row, k a prime ≥ 11
/// so that rows of up to 10 interleaved sensors are all sampled.
fn read_stride(total_rows: usize, schema_id: &str, schema: &SchemaRef) -> Option<usize> {
    let budget = read_budget(schema_id, schema);
    (total_rows > budget).then(|| next_prime(total_rows.div_ceil(budget).max(11)))
}

/// The rows of a file of `rows` rows whose index in the whole table (`first` + the index in
/// the file) is a multiple of `k`.
fn every_kth(rows: usize, first: usize, k: usize) -> RowSelection {
    let lead = (k - first % k) % k;
    if lead >= rows {
        return RowSelection::from(vec![RowSelector::skip(rows)]);
    }
    let mut sel = Vec::with_capacity(2 * (rows / k + 2));
    if lead > 0 {
        sel.push(RowSelector::skip(lead));
    }
    let mut i = lead;
    while i < rows {
        sel.push(RowSelector::select(1));
        let skip = (k - 1).min(rows - i - 1);
        if skip > 0 {
            sel.push(RowSelector::skip(skip));
        }
        i += k;
    }
    RowSelection::from(sel)
}

/// Read an opened file's rows: all, or those [`every_kth`] selects; `first` is the index of
/// the file's first row in the whole table.
///
/// Row groups are read one at a time, so an error names its row group; a panic inside the
/// parquet / arrow crates on malformed data (an upstream bug) is contained and reported as
/// that row group's error (see [`gradtac_io::contain`]).
fn read_rows(o: Opened, first: usize, stride: Option<usize>) -> R<Vec<RecordBatch>> {
    let mut batches = Vec::new();
    let mut start = 0usize;
    for (i, rg) in o.meta.metadata().row_groups().iter().enumerate() {
        let at = |e: String| PlotErr(format!("row group {i}: {e}"));
        let n = rg.num_rows() as usize; // checked non-negative by `open_parquet`
                                        // page headers bounded before the parquet crate reads them (its skip is unbounded)
        gradtac_io::parquet_check::check_row_group(&mut &o.file, rg).map_err(at)?;
        let file = o.file.try_clone().map_err(|e| at(format!("cannot read: {e}")))?;
        let builder = ParquetRecordBatchReaderBuilder::new_with_metadata(file, o.meta.clone()).with_row_groups(vec![i]);
        let builder = match stride {
            Some(k) => builder.with_row_selection(every_kth(n, first + start, k)),
            None => builder,
        };
        let read = gradtac_io::contain::contain(|| -> std::result::Result<Vec<RecordBatch>, String> {
            let reader = builder.build().map_err(|e| format!("cannot read: {e}"))?;
            reader.collect::<std::result::Result<Vec<_>, _>>().map_err(|e| format!("cannot read rows: {e}"))
        });
        match read {
            Ok(Ok(b)) => batches.extend(b),
            Ok(Err(e)) => return Err(at(e)),
            Err(panic) => return Err(at(format!("malformed data (the parquet reader panicked: {panic})"))),
        }
        start += n;
    }
    Ok(batches)
}

fn read_file(path: &Path) -> R<Table> {
    let o = open_parquet(path)?;
    let (schema_id, kv, schema, total_rows) = (o.schema_id.clone(), o.kv.clone(), o.schema.clone(), o.rows);
    let stride = read_stride(total_rows, &schema_id, &schema);
    let batches = read_rows(o, 0, stride)?;
    Ok(Table { schema_id, kv, schema, batches, total_rows, stride, files: None })
}

/// Does a file or directory name mark something dataset readers skip (hidden, or `_`-prefixed
/// like `_SUCCESS`)?
fn skipped_name(name: &std::ffi::OsStr) -> bool {
    let b = name.as_encoded_bytes();
    b.first().is_some_and(|c| *c == b'.' || *c == b'_')
}

/// The finished Parquet files under `dir`, recursively, in lexical order of their path
/// components (an archive's write order), relative to `dir`; and how many `.partial` files
/// were skipped. Names starting with `.` or `_` are skipped (files and directories), as are
/// files not ending in `.parquet`; symbolic links to files are followed, to directories not.
fn archive_files(dir: &Path) -> R<(Vec<PathBuf>, usize)> {
    fn walk(root: &Path, rel: &Path, files: &mut Vec<PathBuf>, partial: &mut usize) -> R<()> {
        let here = root.join(rel);
        let rd = std::fs::read_dir(&here).map_err(|e| PlotErr(format!("cannot list {}: {e}", here.display())))?;
        let mut entries = rd
            .collect::<std::io::Result<Vec<_>>>()
            .map_err(|e| PlotErr(format!("cannot list {}: {e}", here.display())))?;
        entries.sort_by_key(|e| e.file_name());
        for e in entries {
            let name = e.file_name();
            let path = rel.join(&name);
            let ft = e.file_type().map_err(|err| PlotErr(format!("{}: {err}", path.display())))?;
            if name.as_encoded_bytes().ends_with(gradtac_io::parquet_sink::PARTIAL_SUFFIX.as_bytes()) {
                *partial += 1;
            } else if skipped_name(&name) {
            } else if ft.is_dir() {
                walk(root, &path, files, partial)?;
            } else if (ft.is_file() || (ft.is_symlink() && e.path().is_file()))
                && name.as_encoded_bytes().ends_with(b".parquet")
            {
                files.push(path);
            }
        }
        Ok(())
    }
    let (mut files, mut partial) = (Vec::new(), 0);
    walk(dir, Path::new(""), &mut files, &mut partial)?;
    Ok((files, partial))
}

/// Read every finished Parquet file under `dir` as one table: they must share one
/// `gradtac.schema` and the same columns; decimation counts the rows of all files.
fn read_archive(dir: &Path) -> R<Table> {
    let (files, partial) = archive_files(dir)?;
    if files.is_empty() {
        let reason = if partial > 0 {
            let s = if partial == 1 { "" } else { "s" };
            format!(
                "no finished Parquet file to plot, only {partial} unfinished `.partial` file{s} (being written, or \
                 left by a crash)"
            )
        } else if std::fs::read_dir(dir).map(|mut d| d.next().is_none()).unwrap_or(false) {
            "empty directory: no finished Parquet file to plot".to_string()
        } else {
            "no finished Parquet file to plot (`*.parquet`; names starting with `.` or `_` are skipped)".to_string()
        };
        return Err(PlotErr(reason));
    }
    let in_file = |f: &Path, e: PlotErr| PlotErr(format!("{}: {}", f.display(), e.0));
    // Pass 1: footers only — the common schema, the total row count, the merged metadata.
    let mut first: Option<Opened> = None;
    let mut kv = HashMap::new();
    let mut rows = Vec::with_capacity(files.len());
    for f in &files {
        let o = open_parquet(&dir.join(f)).map_err(|e| in_file(f, e))?;
        if let Some(p) = &first {
            let same_columns = p.schema.fields().len() == o.schema.fields().len()
                && p.schema
                    .fields()
                    .iter()
                    .zip(o.schema.fields())
                    .all(|(a, b)| a.name() == b.name() && a.data_type() == b.data_type());
            if o.schema_id != p.schema_id {
                return Err(PlotErr(format!(
                    "{}: schema {} differs from {} of {} (the archive's first file); an archive's files must share one \
                     `gradtac.schema`",
                    f.display(),
                    o.schema_id,
                    p.schema_id,
                    files[0].display()
                )));
            }
            if !same_columns {
                return Err(PlotErr(format!(
                    "{}: schema {} with other columns (or column types) than {} (the archive's first file)",
                    f.display(),
                    o.schema_id,
                    files[0].display()
                )));
            }
        }
        for (k, v) in &o.kv {
            kv.entry(k.clone()).or_insert_with(|| v.clone());
        }
        rows.push(o.rows);
        if first.is_none() {
            first = Some(o);
        }
    }
    let first = first.expect("files is not empty");
    let (schema_id, schema) = (first.schema_id.clone(), first.schema.clone());
    drop(first);
    let total_rows: usize = rows.iter().sum();
    let stride = read_stride(total_rows, &schema_id, &schema);
    // Pass 2: the rows, every k-th of the whole table.
    let mut batches = Vec::new();
    let mut offset = 0;
    for (f, n) in files.iter().zip(&rows) {
        if *n > 0 {
            let o = open_parquet(&dir.join(f)).map_err(|e| in_file(f, e))?;
            if o.rows != *n {
                return Err(in_file(f, PlotErr(format!("changed while read ({n} rows, then {})", o.rows))));
            }
            batches.extend(read_rows(o, offset, stride).map_err(|e| in_file(f, e))?);
        }
        offset += n;
    }
    Ok(Table { schema_id, kv, schema, batches, total_rows, stride, files: Some(files) })
}

/// At most this many rows of a file (or of all an archive's files) are read: [`MAX_POINTS`] per
/// drawn sensor (ten times that for events, a tenth for windows), and for surfaces about 64 MB
/// of values.
fn read_budget(schema_id: &str, schema: &SchemaRef) -> usize {
    let rows = MAX_POINTS * MAX_SENSORS;
    match schema_id {
        "event/1" => 10 * rows,
        "window/1" => rows / 10,
        "surface/1" => {
            let n = match schema.field_with_name("values").map(|f| f.data_type().clone()) {
                Ok(arrow_schema::DataType::FixedSizeList(_, n)) => n.max(1) as usize,
                _ => 1,
            };
            (64_000_000 / (8 * n)).clamp(64, 1600)
        }
        _ => rows,
    }
}

/// The smallest prime ≥ `n`.
fn next_prime(n: usize) -> usize {
    let is_prime = |m: usize| m >= 2 && (2..).take_while(|d| d * d <= m).all(|d| m % d != 0);
    (n..).find(|&m| is_prime(m)).unwrap_or(n)
}

fn column<'a>(b: &'a RecordBatch, name: &str) -> R<&'a ArrayRef> {
    b.column_by_name(name).ok_or_else(|| PlotErr(format!("no column `{name}`")))
}

fn wrong(name: &str, a: &ArrayRef) -> PlotErr {
    PlotErr(format!("column `{name}` has type {}, not the schema's", a.data_type()))
}

fn strings(b: &RecordBatch, name: &str) -> R<Vec<String>> {
    let a = column(b, name)?;
    if let Some(s) = a.as_string_opt::<i32>() {
        return Ok((0..s.len()).map(|i| s.value(i).to_string()).collect());
    }
    if let Some(s) = a.as_string_opt::<i64>() {
        return Ok((0..s.len()).map(|i| s.value(i).to_string()).collect());
    }
    if let Some(d) = a.as_any_dictionary_opt() {
        if let Some(v) = d.values().as_string_opt::<i32>() {
            return Ok(d.normalized_keys().into_iter().map(|k| v.value(k).to_string()).collect());
        }
    }
    Err(wrong(name, a))
}

fn i64s(b: &RecordBatch, name: &str) -> R<Vec<i64>> {
    let a = column(b, name)?;
    let p = a.as_primitive_opt::<Int64Type>().ok_or_else(|| wrong(name, a))?;
    Ok(p.values().to_vec())
}

/// A Float64 column, null as NaN.
fn f64s(b: &RecordBatch, name: &str) -> R<Vec<f64>> {
    let a = column(b, name)?;
    let p = a.as_primitive_opt::<Float64Type>().ok_or_else(|| wrong(name, a))?;
    Ok((0..p.len()).map(|i| if p.is_null(i) { f64::NAN } else { p.value(i) }).collect())
}

/// A `FixedSizeList<Float64, n>` column: `(n, values of every row, concatenated)`.
fn fixed_lists(b: &RecordBatch, name: &str) -> R<(usize, Vec<f64>)> {
    let a = column(b, name)?;
    let l = a.as_fixed_size_list_opt().ok_or_else(|| wrong(name, a))?;
    let n = l.value_length() as usize;
    let mut out = Vec::with_capacity(l.len() * n);
    for i in 0..l.len() {
        let v = l.value(i);
        let p = v.as_primitive_opt::<Float64Type>().ok_or_else(|| wrong(name, a))?;
        out.extend(p.values().iter().copied());
    }
    Ok((n, out))
}

/// A `List<FixedSizeList<Float64, 2>>` column (polygons), null as empty.
fn polygons(b: &RecordBatch, name: &str) -> R<Vec<Vec<[f64; 2]>>> {
    let a = column(b, name)?;
    let l = a.as_list_opt::<i32>().ok_or_else(|| wrong(name, a))?;
    let mut out = Vec::with_capacity(l.len());
    for i in 0..l.len() {
        if l.is_null(i) {
            out.push(Vec::new());
            continue;
        }
        let pts = l.value(i);
        let f = pts.as_fixed_size_list_opt().ok_or_else(|| wrong(name, a))?;
        let mut poly = Vec::with_capacity(f.len());
        for j in 0..f.len() {
            let xy = f.value(j);
            let p = xy.as_primitive_opt::<Float64Type>().ok_or_else(|| wrong(name, a))?;
            if p.len() == 2 {
                poly.push([p.value(0), p.value(1)]);
            }
        }
        out.push(poly);
    }
    Ok(out)
}

/// Taxel names from a field's `gradtac.taxels` metadata.
fn taxel_names(schema: &SchemaRef, field: &str) -> Option<Vec<String>> {
    let f = schema.field_with_name(field).ok()?;
    let json = f.metadata().get("gradtac.taxels")?;
    serde_json::from_str(json).ok()
}

/// Rows grouped by sensor (first appearance order), each a list of `(batch, row)`.
fn by_sensor(t: &Table) -> R<Groups> {
    let mut order: Groups = Vec::new();
    let mut index: HashMap<String, usize> = HashMap::new();
    for (bi, b) in t.batches.iter().enumerate() {
        for (ri, s) in strings(b, "sensor")?.into_iter().enumerate() {
            let k = *index.entry(s.clone()).or_insert_with(|| {
                order.push((s, Vec::new()));
                order.len() - 1
            });
            order[k].1.push((bi, ri));
        }
    }
    Ok(order)
}

/// Every `k`-th index so that at most `max` remain.
fn stride(len: usize, max: usize) -> usize {
    len.div_ceil(max.max(1)).max(1)
}

fn limit_sensors<T>(mut s: Vec<(String, T)>, notes: &mut Vec<String>) -> Vec<(String, T)> {
    if s.len() > MAX_SENSORS {
        let rest: Vec<String> = s[MAX_SENSORS..].iter().map(|(n, _)| n.clone()).collect();
        notes.push(format!("only the first {MAX_SENSORS} sensors are drawn; left out: {}", rest.join(", ")));
        s.truncate(MAX_SENSORS);
    }
    s
}

fn secs(t_ns: i64, t0: i64) -> f64 {
    // i128: times from a file may span more than i64 nanoseconds
    (i128::from(t_ns) - i128::from(t0)) as f64 * 1e-9
}

// ---------------------------------------------------------------------------------------------
// plot_parquet

/// Plot a Parquet file written by a gradtac sink, or a directory of them (an archive written
/// by [`ParquetArchive`](gradtac_io::ParquetArchive)), as a PNG at `output_png`; see the
/// [module docs](self) for what each schema gives.
///
/// A directory is read as one table: its finished `*.parquet` files, found recursively (so
/// hive partitions `sensor=<name>/` are included; each file keeps its `sensor` column) in
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
/// schemas; or when drawing fails. [`Error::Io`] when the PNG cannot be written.
pub fn plot_parquet(input: &Path, output_png: &Path) -> Result<PlotSummary, Error> {
    let table = read_table(input).map_err(|e| plot_error(input, e))?;
    let mut notes = Vec::new();
    if let Some(files) = &table.files {
        let n = files.len();
        let s = if n == 1 { "" } else { "s" };
        notes.push(format!("archive: {n} Parquet file{s} read as one table"));
    }
    if let Some(k) = table.stride {
        let what = if table.files.is_some() { "archive" } else { "file" };
        notes.push(format!("large {what}: every {k}th of its {} rows read", table.total_rows));
    }
    let plan = match table.schema_id.as_str() {
        "frame/1" => frames_plot(&table, &mut notes),
        "event/1" => events_plot(&table, &mut notes),
        "window/1" => window_plot(&table, &mut notes),
        "surface/1" => surface_plot(&table, &mut notes),
        "contour/1" => contour_plot(&table, &mut notes),
        "track/1" => track_plot(&table, &mut notes),
        "slip/1" => slip_plot(&table),
        "force/1" => series_plot(
            &table,
            &mut notes,
            "time_ns",
            &[("estimated force (force/1)", "force (N)", &["force_n"]), ("contour area", "area (mm²)", &["area_mm2"])],
        ),
        "servo/1" => series_plot(
            &table,
            &mut notes,
            "time_ns",
            &[
                ("commanded motion (servo/1)", "motion (mm)", &["motion_x_mm", "motion_y_mm"]),
                ("contact offset from the servo centre", "offset (mm)", &["offset_x_mm", "offset_y_mm", "distance_mm"]),
            ],
        ),
        "dos/1" | "dos/2" => dos_plot(&table, &mut notes),
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

fn frames_plot(t: &Table, notes: &mut Vec<String>) -> R<Prepared> {
    no_rows(t)?;
    let names = taxel_names(&t.schema, "values");
    let groups = limit_sensors(by_sensor(t)?, notes);
    let cols: Vec<(Vec<i64>, ListCol)> =
        t.batches.iter().map(|b| Ok((i64s(b, "time_ns")?, fixed_lists(b, "values")?))).collect::<R<_>>()?;
    let t0 = cols.iter().flat_map(|c| c.0.iter().copied()).min().unwrap_or(0);
    let n = cols.iter().map(|c| c.1 .0).max().unwrap_or(0);
    let (series, drawn) = thin_rows(&groups, MAX_POINTS, "frames", notes, |bi, ri| {
        let (times, values) = &cols[bi];
        (secs(times[ri], t0), list_row(values, ri).to_vec())
    });
    let size = (PANEL_W, STRIP_H * series.len() as u32);
    let sensors = groups.iter().map(|g| g.0.clone()).collect();
    Ok(Prepared {
        size,
        sensors,
        drawn,
        draw: Box::new(move |root| {
            for (area, (sensor, pts)) in root.split_evenly((series.len(), 1)).iter().zip(&series) {
                let (x0, x1) = range_of(pts.iter().map(|p| p.0));
                let (y0, y1) = padded(range_of(pts.iter().flat_map(|p| p.1.iter().copied())), 0.05);
                let frame = Frame { y_area: 70, ..PANEL };
                let mut chart = chart_on(area, format!("{sensor}: {n} taxels (frame/1)"), frame, x0..x1, y0..y1)?;
                draw_axes(&mut chart, Some("time (s from the first row)"), "value", 13)?;
                for i in 0..n {
                    let c = series_colour(i);
                    let label = names.as_ref().and_then(|v| v.get(i).cloned()).unwrap_or(format!("{i}"));
                    let segs = segments(pts.iter().map(|p| (p.0, p.1[i])), (x0, x1), (y0, y1));
                    let s = chart.draw_series(segs.into_iter().map(|seg| PathElement::new(seg, c.stroke_width(1))))?;
                    if n <= 24 {
                        s.label(label).legend(line_key(c));
                    }
                }
                if n <= 24 {
                    draw_legend(&mut chart, SeriesLabelPosition::UpperRight, 0.8, 10)?;
                }
            }
            Ok(())
        }),
    })
}

fn events_plot(t: &Table, notes: &mut Vec<String>) -> R<Prepared> {
    no_rows(t)?;
    let names = taxel_names(&t.schema, "taxel");
    let groups = limit_sensors(by_sensor(t)?, notes);
    let cols: Vec<(Vec<i64>, Vec<u16>, Vec<i8>)> = t
        .batches
        .iter()
        .map(|b| {
            let ta = column(b, "taxel")?;
            let taxel = ta.as_primitive_opt::<UInt16Type>().ok_or_else(|| wrong("taxel", ta))?.values().to_vec();
            let pa = column(b, "polarity")?;
            let pol = pa.as_primitive_opt::<Int8Type>().ok_or_else(|| wrong("polarity", pa))?.values().to_vec();
            Ok((i64s(b, "time_ns")?, taxel, pol))
        })
        .collect::<R<_>>()?;
    let t0 = cols.iter().flat_map(|c| c.0.iter().copied()).min().unwrap_or(0);
    let n = names
        .as_ref()
        .map(Vec::len)
        .unwrap_or_else(|| cols.iter().flat_map(|c| c.1.iter()).max().map_or(1, |&m| m as usize + 1));
    let (series, drawn) = thin_rows(&groups, MAX_POINTS * 10, "events", notes, |bi, ri| {
        (secs(cols[bi].0[ri], t0), cols[bi].1[ri], cols[bi].2[ri])
    });
    let size = (PANEL_W, STRIP_H * series.len() as u32);
    let sensors = groups.iter().map(|g| g.0.clone()).collect();
    Ok(Prepared {
        size,
        sensors,
        drawn,
        draw: Box::new(move |root| {
            let label = |v: &f64| taxel_label(names.as_deref(), *v);
            for (area, (sensor, pts)) in root.split_evenly((series.len(), 1)).iter().zip(&series) {
                let (x0, x1) = range_of(pts.iter().map(|p| p.0));
                let pos = pts.iter().filter(|p| p.2 > 0).count();
                let caption = format!(
                    "{sensor}: {} events, {pos} up (red), {} down (blue) (event/1)",
                    pts.len(),
                    pts.len() - pos
                );
                let mut chart = chart_on(area, caption, PANEL, x0..x1, -0.5..(n as f64 - 0.5))?;
                chart
                    .configure_mesh()
                    .x_desc("time (s from the first event)")
                    .y_desc("taxel")
                    .y_labels(n.min(24))
                    .y_label_formatter(&label)
                    .label_style(("sans-serif", 11))
                    .light_line_style(WHITE)
                    .draw()?;
                let up = RGBColor(200, 30, 30);
                let down = RGBColor(30, 60, 200);
                chart.draw_series(pts.iter().map(|&(x, taxel, p)| {
                    let c = if p > 0 { up } else { down };
                    let y = taxel as f64 + if p > 0 { 0.15 } else { -0.15 };
                    Circle::new((x, y), 1, c.filled())
                }))?;
            }
            Ok(())
        }),
    })
}

fn window_plot(t: &Table, notes: &mut Vec<String>) -> R<Prepared> {
    no_rows(t)?;
    let names = taxel_names(&t.schema, "values");
    let groups = limit_sensors(by_sensor(t)?, notes);
    let cols: Vec<(Vec<i64>, Vec<String>, ListCol)> = t
        .batches
        .iter()
        .map(|b| Ok((i64s(b, "end_ns")?, strings(b, "aggregate")?, fixed_lists(b, "values")?)))
        .collect::<R<_>>()?;
    let t0 = cols.iter().flat_map(|c| c.0.iter().copied()).min().unwrap_or(0);
    let n = cols.iter().map(|c| c.2 .0).max().unwrap_or(0).max(1);
    let mut signed = false;
    let (series, drawn) = thin_rows(&groups, 2000, "windows", notes, |bi, ri| {
        let (times, agg, values) = &cols[bi];
        signed |= agg[ri] == "signed" || agg[ri] == "split";
        (secs(times[ri], t0), list_row(values, ri).to_vec())
    });
    let all = series.iter().flat_map(|s| s.1.iter().flat_map(|p| p.1.iter().copied()));
    let (mut lo, mut hi) = range_of(all);
    let cmap: fn(f64) -> RGBColor = if signed {
        let m = lo.abs().max(hi.abs());
        (lo, hi) = (-m, m);
        diverging
    } else {
        lo = lo.min(0.0);
        viridis
    };
    let size = (PANEL_W + BAR_W, STRIP_H * series.len() as u32);
    let sensors = groups.iter().map(|g| g.0.clone()).collect();
    Ok(Prepared {
        size,
        sensors,
        drawn,
        draw: Box::new(move |root| {
            let (main, bar) = root.split_horizontally(PANEL_W);
            colour_bar(&bar, lo, hi, cmap, "events")?;
            let label = |v: &f64| taxel_label(names.as_deref(), *v);
            for (area, (sensor, pts)) in main.split_evenly((series.len(), 1)).iter().zip(&series) {
                let dt = if pts.len() > 1 { (pts[pts.len() - 1].0 - pts[0].0) / (pts.len() - 1) as f64 } else { 1.0 };
                let x0 = pts.first().map_or(0.0, |p| p.0 - dt);
                let x1 = pts.last().map_or(1.0, |p| p.0).max(x0 + 1e-9);
                let caption = format!("{sensor}: {} windows (window/1)", pts.len());
                let mut chart = chart_on(area, caption, PANEL, x0..x1, -0.5..(n as f64 - 0.5))?;
                chart
                    .configure_mesh()
                    .disable_mesh()
                    .x_desc("window end (s from the first row)")
                    .y_desc("taxel")
                    .y_labels(n.min(24))
                    .y_label_formatter(&label)
                    .label_style(("sans-serif", 11))
                    .draw()?;
                let mut prev = x0;
                let mut rects = Vec::with_capacity(pts.len() * n);
                for (x, v) in pts {
                    for (i, &val) in v.iter().enumerate() {
                        let c = if val.is_finite() { cmap((val - lo) / (hi - lo)) } else { NAN_GREY };
                        rects.push(Rectangle::new([(prev, i as f64 - 0.5), (*x, i as f64 + 0.5)], c.filled()));
                    }
                    prev = *x;
                }
                chart.draw_series(rects)?;
            }
            Ok(())
        }),
    })
}

/// The grid of a `surface/1` file from its `gradtac.grid` schema metadata.
fn grid_of(t: &Table) -> R<Grid> {
    let json = t
        .schema
        .metadata()
        .get(gradtac_io::records::surface::GRID_KEY)
        .or_else(|| t.kv.get(gradtac_io::records::surface::GRID_KEY))
        .ok_or_else(|| PlotErr("surface file without `gradtac.grid` metadata".into()))?;
    let v: serde_json::Value = serde_json::from_str(json).map_err(|e| PlotErr(format!("`gradtac.grid`: {e}")))?;
    let num = |k: &str| {
        v.get(k).and_then(serde_json::Value::as_f64).ok_or_else(|| PlotErr(format!("`gradtac.grid` has no `{k}`")))
    };
    let extent = Extent { x_min: num("x_min")?, x_max: num("x_max")?, y_min: num("y_min")?, y_max: num("y_max")? };
    Grid::try_new(extent, num("nx")? as usize, num("ny")? as usize).map_err(|e| PlotErr(format!("`gradtac.grid`: {e}")))
}

/// The maximal contour of a surface with the contour stage's defaults but any peak.
fn max_contour(grid: &Grid, values: &[f64]) -> Option<Vec<[f64; 2]>> {
    let z = ArrayView2::from_shape((grid.ny(), grid.nx()), values).ok()?;
    let cfg = ContourConfig { min_peak: -f64::MAX, ..Default::default() };
    let mut f = MaxContourFinder::try_new(&cfg).ok()?;
    match f.find(z, grid) {
        ContourOutcome::Contact(c) => Some(c.polygon),
        ContourOutcome::NoContact(_) => None,
    }
}

fn surface_plot(t: &Table, notes: &mut Vec<String>) -> R<Prepared> {
    no_rows(t)?;
    let grid = grid_of(t)?;
    let groups = limit_sensors(by_sensor(t)?, notes);
    let cols: Vec<(Vec<i64>, ListCol)> =
        t.batches.iter().map(|b| Ok((i64s(b, "end_ns")?, fixed_lists(b, "values")?))).collect::<R<_>>()?;
    let t0 = cols.iter().flat_map(|c| c.0.iter().copied()).min().unwrap_or(0);
    let m = grid.len();
    if cols.iter().any(|c| c.1 .0 != m) {
        return Err(PlotErr(format!("surface rows do not hold nx·ny = {m} values")));
    }
    notes.push(format!(
        "maximal contours recomputed from the surfaces ({ISO_LEVELS} levels, min area 1 mm², any peak): the file does not store the contour settings"
    ));
    let mut rows_out = Vec::new();
    for (sensor, rows) in &groups {
        let contour_of = |&(bi, ri): &(usize, usize)| max_contour(&grid, &cols[bi].1 .1[ri * m..(ri + 1) * m]);
        // instants: evenly spaced over the rows with a contact (else over all rows)
        let peak_of = |&(bi, ri): &(usize, usize)| range_of(cols[bi].1 .1[ri * m..(ri + 1) * m].iter().copied()).1;
        let candidates: Vec<(usize, usize)> = {
            let k = stride(rows.len(), 400);
            let sampled: Vec<(usize, usize)> = rows.iter().step_by(k).copied().collect();
            // a contact: a maximal contour on a surface whose peak is at least a quarter of the
            // highest peak (so near-empty windows between contacts are not picked)
            let top = sampled.iter().map(peak_of).fold(f64::NEG_INFINITY, f64::max);
            let with: Vec<(usize, usize)> = sampled
                .iter()
                .copied()
                .filter(|r| (top <= 0.0 || peak_of(r) >= 0.25 * top) && contour_of(r).is_some())
                .collect();
            if with.is_empty() {
                sampled
            } else {
                with
            }
        };
        let picks: Vec<(usize, usize)> = if candidates.len() <= 4 {
            candidates
        } else {
            (0..4).map(|i| candidates[(i * (candidates.len() - 1)) / 3]).collect()
        };
        let layout = t.layout(sensor, None, notes);
        let panels: Vec<SurfacePanel> = picks
            .iter()
            .map(|&(bi, ri)| SurfacePanel {
                label: format!("{sensor}, t = {:.2} s", secs(cols[bi].0[ri], t0)),
                values: cols[bi].1 .1[ri * m..(ri + 1) * m].to_vec(),
                contour: None,
                truth: None,
            })
            .collect();
        rows_out.push((panels, layout));
    }
    let drawn = rows_out.iter().map(|r| r.0.len() as u64).sum();
    let size = (4 * SURF_PANEL + BAR_W, TITLE_H + SURF_ROW_H * rows_out.len() as u32);
    let sensors = groups.iter().map(|g| g.0.clone()).collect();
    let title = format!("surfaces on a {}×{} grid (surface/1)", grid.nx(), grid.ny());
    Ok(Prepared {
        size,
        sensors,
        drawn,
        draw: Box::new(move |root| {
            let rows: Vec<(&[SurfacePanel], Option<&Layout>)> =
                rows_out.iter().map(|(p, l)| (p.as_slice(), l.as_ref())).collect();
            draw_surfaces(root, &grid, &rows, &title)
        }),
    })
}

/// Rows of surface panels (a common colour scale) with a colour bar and a title.
fn draw_surfaces(root: &Area<'_>, grid: &Grid, rows: &[(&[SurfacePanel], Option<&Layout>)], title: &str) -> R<()> {
    let (top, body) = root.split_vertically(TITLE_H);
    top.draw(&Text::new(title.to_string(), (12, 10), ("sans-serif", 20).into_font()))?;
    let (main, bar) = body.split_horizontally(4 * SURF_PANEL);
    let (lo, hi) = range_of(rows.iter().flat_map(|r| r.0.iter().flat_map(|p| p.values.iter().copied())));
    colour_bar(&bar, lo, hi, viridis, "surface value")?;
    for (row_area, (panels, layout)) in main.split_evenly((rows.len().max(1), 1)).iter().zip(rows) {
        for (area, p) in row_area.split_evenly((1, 4)).iter().zip(panels.iter()) {
            draw_surface_panel(area, grid, p, *layout, (lo, hi))?;
        }
    }
    Ok(())
}

fn draw_surface_panel(
    area: &Area<'_>,
    grid: &Grid,
    p: &SurfacePanel,
    layout: Option<&Layout>,
    (lo, hi): (f64, f64),
) -> R<()> {
    let (nx, ny) = (grid.nx(), grid.ny());
    if p.values.len() != nx * ny {
        return Err(PlotErr(format!("panel {:?}: {} values for a {nx}×{ny} grid", p.label, p.values.len())));
    }
    let (w, h) = area.dim_in_pixel();
    let (xr, yr) = equal_aspect(grid.extent(), w as f64 - 60.0, h as f64 - 70.0);
    let (bx, by) = ((xr.start, xr.end), (yr.start, yr.end));
    let mut chart = chart_on(area, &p.label, Frame { caption: 15, margin: 8, x_area: 30, y_area: 40 }, xr, yr)?;
    chart.configure_mesh().disable_mesh().x_desc("x (mm)").y_desc("y (mm)").label_style(("sans-serif", 11)).draw()?;
    let (dx, dy) = (grid.dx(), grid.dy());
    let mut cells = Vec::with_capacity(nx * ny);
    for r in 0..ny {
        for c in 0..nx {
            let v = p.values[r * nx + c];
            let col = if v.is_finite() { viridis((v - lo) / (hi - lo)) } else { NAN_GREY };
            let (x, y) = (grid.x(c), grid.y(r));
            cells.push(Rectangle::new([(x - dx / 2.0, y - dy / 2.0), (x + dx / 2.0, y + dy / 2.0)], col.filled()));
        }
    }
    chart.draw_series(cells)?;
    // iso-lines at ISO_LEVELS levels between this surface's finite min and max
    let z = ArrayView2::from_shape((ny, nx), &p.values[..]).map_err(|e| PlotErr(e.to_string()))?;
    let (zmin, zmax) = range_of(p.values.iter().copied());
    let line = RGBColor(255, 255, 255).mix(0.7);
    for k in 1..=ISO_LEVELS {
        let level = zmin + (zmax - zmin) * k as f64 / (ISO_LEVELS + 1) as f64;
        for iso in isolines(z, level, Saddle::Centre) {
            let mut pts: Vec<(f64, f64)> = iso
                .points
                .iter()
                .map(|q| {
                    let m = grid.index_to_mm(q[0], q[1]);
                    (m[0], m[1])
                })
                .collect();
            if iso.closed {
                if let Some(&f) = pts.first() {
                    pts.push(f);
                }
            }
            chart.draw_series(std::iter::once(PathElement::new(pts, line.stroke_width(1))))?;
        }
    }
    let contour = p.contour.clone().or_else(|| max_contour(grid, &p.values));
    if let Some(poly) = contour.filter(|c| c.len() > 2) {
        let closed = poly.iter().chain(poly.first()).map(|q| (q[0], q[1]));
        for seg in segments(closed, bx, by) {
            chart.draw_series(std::iter::once(PathElement::new(seg, RED.stroke_width(3))))?;
        }
        let a = gradtac_stages::contour::polygon_area(&poly).abs();
        let (cx, cy) = centroid(&poly);
        if a > 0.0 && cx.is_finite() && cy.is_finite() {
            chart.draw_series(std::iter::once(Cross::new(clamp_pt((cx, cy), bx, by), 6, RED.stroke_width(2))))?;
        }
    }
    if let Some(l) = layout {
        draw_taxels(&mut chart, l, false)?;
    }
    if let Some(tr) = p.truth.filter(|t| t[0].is_finite() && t[1].is_finite()) {
        chart.draw_series(std::iter::once(TriangleMarker::new(clamp_pt((tr[0], tr[1]), bx, by), 7, BLACK.filled())))?;
    }
    Ok(())
}

fn centroid(poly: &[[f64; 2]]) -> (f64, f64) {
    let (mut a, mut cx, mut cy) = (0.0, 0.0, 0.0);
    let o = poly[0];
    for i in 0..poly.len() {
        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
        let (x0, y0, x1, y1) = (p[0] - o[0], p[1] - o[1], q[0] - o[0], q[1] - o[1]);
        let c = x0 * y1 - x1 * y0;
        a += c;
        cx += (x0 + x1) * c;
        cy += (y0 + y1) * c;
    }
    if a == 0.0 {
        return (o[0], o[1]);
    }
    (o[0] + cx / (3.0 * a), o[1] + cy / (3.0 * a))
}

fn contour_plot(t: &Table, notes: &mut Vec<String>) -> R<Prepared> {
    no_rows(t)?;
    let groups = limit_sensors(by_sensor(t)?, notes);
    struct Col {
        end: Vec<i64>,
        cx: Vec<f64>,
        cy: Vec<f64>,
        area: Vec<f64>,
        poly: Vec<Vec<[f64; 2]>>,
    }
    let cols: Vec<Col> = t
        .batches
        .iter()
        .map(|b| {
            Ok(Col {
                end: i64s(b, "end_ns")?,
                cx: f64s(b, "centroid_x_mm")?,
                cy: f64s(b, "centroid_y_mm")?,
                area: f64s(b, "area_mm2")?,
                poly: polygons(b, "polygon")?,
            })
        })
        .collect::<R<_>>()?;
    let t0 = cols.iter().flat_map(|c| c.end.iter().copied()).min().unwrap_or(0);
    type Pt = (f64, f64, f64, f64);
    let mut series: Vec<(String, Vec<Pt>, Vec<Outline>)> = Vec::new();
    let mut drawn = 0u64;
    let mut layout = None;
    for (sensor, rows) in &groups {
        if layout.is_none() {
            layout = t.layout(sensor, None, notes);
        }
        let k = draw_stride(sensor, rows.len(), MAX_POINTS, "contours", notes);
        let pts: Vec<Pt> = rows
            .iter()
            .step_by(k)
            .map(|&(bi, ri)| {
                let c = &cols[bi];
                (secs(c.end[ri], t0), c.cx[ri], c.cy[ri], c.area[ri])
            })
            .collect();
        let with: Vec<&(usize, usize)> = rows.iter().filter(|&&(bi, ri)| !cols[bi].poly[ri].is_empty()).collect();
        let outlines: Vec<Vec<[f64; 2]>> = if with.is_empty() {
            Vec::new()
        } else {
            let mut idx: Vec<usize> = (0..4).map(|i| i * (with.len() - 1) / 3).collect();
            idx.dedup();
            idx.into_iter().map(|i| cols[with[i].0].poly[with[i].1].clone()).collect()
        };
        drawn += pts.len() as u64;
        series.push((sensor.clone(), pts, outlines));
    }
    let layout = layout.unwrap_or_else(Layout::biotac_sp);
    let size = (1400, 620);
    let sensors = groups.iter().map(|g| g.0.clone()).collect();
    Ok(Prepared {
        size,
        sensors,
        drawn,
        draw: Box::new(move |root| {
            let (left, right) = root.split_horizontally(600);
            let (mut plane, bx, by) = plane_chart(&left, "contact centroids (contour/1)", &layout)?;
            for (i, (sensor, pts, outlines)) in series.iter().enumerate() {
                let c = series_colour(i);
                for o in outlines {
                    let closed = o.iter().chain(o.first()).map(|q| (q[0], q[1]));
                    for v in segments(closed, bx, by) {
                        plane.draw_series(std::iter::once(PathElement::new(v, c.mix(0.5).stroke_width(1))))?;
                    }
                }
                for seg in segments(pts.iter().map(|p| (p.1, p.2)), bx, by) {
                    plane.draw_series(std::iter::once(PathElement::new(seg, c.stroke_width(2))))?;
                }
                plane
                    .draw_series(
                        pts.iter()
                            .filter(|p| p.1.is_finite() && p.2.is_finite())
                            .map(|p| Circle::new(clamp_pt((p.1, p.2), bx, by), 2, c.filled())),
                    )?
                    .label(sensor.clone())
                    .legend(dot_key(c));
            }
            draw_legend(&mut plane, SeriesLabelPosition::UpperRight, 0.8, 12)?;
            let (x0, x1) = range_of(series.iter().flat_map(|s| s.1.iter().map(|p| p.0)));
            let (a0, a1) = range_of(series.iter().flat_map(|s| s.1.iter().map(|p| p.3)).chain([0.0]));
            let mut chart = chart_on(&right, "contour area", PANEL, x0..x1, a0..a1 * 1.05)?;
            draw_axes(&mut chart, Some("time (s from the first row)"), "area (mm²)", 12)?;
            for (i, (sensor, pts, _)) in series.iter().enumerate() {
                let c = series_colour(i);
                for seg in segments(pts.iter().map(|p| (p.0, p.3)), (x0, x1), (a0, a1)) {
                    chart.draw_series(std::iter::once(PathElement::new(seg, c.stroke_width(2))))?;
                }
                legend_entry(&mut chart, sensor.clone(), line_key(c.stroke_width(2)))?;
            }
            draw_legend(&mut chart, SeriesLabelPosition::UpperRight, 0.8, 12)
        }),
    })
}

/// Runs of finite points (a NaN or ±∞ breaks the line), clamped into the chart's box `xr × yr`.
fn segments(pts: impl Iterator<Item = (f64, f64)>, xr: (f64, f64), yr: (f64, f64)) -> Vec<Vec<(f64, f64)>> {
    let mut out = vec![Vec::new()];
    for p in pts {
        if p.0.is_finite() && p.1.is_finite() {
            out.last_mut().expect("non-empty").push(clamp_pt(p, xr, yr));
        } else if !out.last().expect("non-empty").is_empty() {
            out.push(Vec::new());
        }
    }
    out.retain(|s| s.len() > 1);
    out
}

fn track_plot(t: &Table, notes: &mut Vec<String>) -> R<Prepared> {
    no_rows(t)?;
    let groups = limit_sensors(by_sensor(t)?, notes);
    let cols: Vec<(Vec<i64>, Vec<f64>, Vec<f64>)> =
        t.batches.iter().map(|b| Ok((i64s(b, "time_ns")?, f64s(b, "x_mm")?, f64s(b, "y_mm")?))).collect::<R<_>>()?;
    let t0 = cols.iter().flat_map(|c| c.0.iter().copied()).min().unwrap_or(0);
    let mut panels = Vec::new();
    let mut drawn = 0u64;
    for (sensor, rows) in &groups {
        let layout = t.layout(sensor, None, notes).unwrap_or_else(Layout::biotac_sp);
        let k = draw_stride(sensor, rows.len(), MAX_POINTS, "points", notes);
        let pts: Vec<(f64, f64, f64)> = rows
            .iter()
            .step_by(k)
            .map(|&(bi, ri)| (secs(cols[bi].0[ri], t0), cols[bi].1[ri], cols[bi].2[ri]))
            .collect();
        drawn += pts.iter().filter(|p| p.1.is_finite()).count() as u64;
        panels.push((sensor.clone(), pts, layout));
    }
    let (tl, th) = range_of(panels.iter().flat_map(|p| p.1.iter().filter(|q| q.1.is_finite()).map(|q| q.0)));
    let size = (TRACK_PANEL * panels.len() as u32 + BAR_W, TRACK_H);
    let sensors = groups.iter().map(|g| g.0.clone()).collect();
    Ok(Prepared {
        size,
        sensors,
        drawn,
        draw: Box::new(move |root| {
            let (main, bar) = root.split_horizontally(TRACK_PANEL * panels.len() as u32);
            colour_bar(&bar, tl, th, viridis, "time (s)")?;
            for (area, (sensor, pts, layout)) in main.split_evenly((1, panels.len())).iter().zip(&panels) {
                draw_trajectory(area, &format!("{sensor}: contact track (track/1)"), pts, &[], layout, (tl, th))?;
            }
            Ok(())
        }),
    })
}

/// Stacked time-series panels of Float64 columns (null as a gap), one line per sensor and
/// column; `panels`: (title, y label, columns).
fn series_plot(t: &Table, notes: &mut Vec<String>, time: &str, panels: &[(&str, &str, &[&str])]) -> R<Prepared> {
    no_rows(t)?;
    let groups = limit_sensors(by_sensor(t)?, notes);
    let names: Vec<&str> = panels.iter().flat_map(|p| p.2.iter().copied()).collect();
    let cols: Vec<(Vec<i64>, Vec<Vec<f64>>)> = t
        .batches
        .iter()
        .map(|b| Ok((i64s(b, time)?, names.iter().map(|c| f64s(b, c)).collect::<R<Vec<_>>>()?)))
        .collect::<R<_>>()?;
    let t0 = cols.iter().flat_map(|c| c.0.iter().copied()).min().unwrap_or(0);
    // per sensor: times and each column
    let mut data: Vec<(String, Vec<f64>, Vec<Vec<f64>>)> = Vec::new();
    let mut drawn = 0u64;
    for (sensor, rows) in &groups {
        let k = draw_stride(sensor, rows.len(), MAX_POINTS, "rows", notes);
        let picked: Vec<(usize, usize)> = rows.iter().step_by(k).copied().collect();
        let ts = picked.iter().map(|&(bi, ri)| secs(cols[bi].0[ri], t0)).collect();
        let vs = (0..names.len()).map(|j| picked.iter().map(|&(bi, ri)| cols[bi].1[j][ri]).collect()).collect();
        drawn += picked.len() as u64;
        data.push((sensor.clone(), ts, vs));
    }
    let panels: Vec<(String, String, Vec<usize>)> = {
        let mut j = 0;
        panels
            .iter()
            .map(|(title, y, cs)| {
                let idx = (j..j + cs.len()).collect();
                j += cs.len();
                (title.to_string(), y.to_string(), idx)
            })
            .collect()
    };
    let names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
    let size = (PANEL_W, STRIP_H * panels.len() as u32);
    Ok(Prepared {
        size,
        sensors: groups.iter().map(|g| g.0.clone()).collect(),
        drawn,
        draw: Box::new(move |root| {
            let (x0, x1) = range_of(data.iter().flat_map(|d| d.1.iter().copied()));
            for (area, (title, ydesc, idx)) in root.split_evenly((panels.len(), 1)).iter().zip(&panels) {
                let (y0, y1) =
                    padded(range_of(data.iter().flat_map(|d| idx.iter().flat_map(|&j| d.2[j].iter().copied()))), 0.05);
                let mut chart = chart_on(area, title, Frame { y_area: 70, ..PANEL }, x0..x1, y0..y1)?;
                draw_axes(&mut chart, Some("time (s from the first row)"), ydesc, 12)?;
                let mut k = 0;
                for (sensor, ts, vs) in &data {
                    for &j in idx {
                        let c = series_colour(k);
                        k += 1;
                        let segs = segments(ts.iter().copied().zip(vs[j].iter().copied()), (x0, x1), (y0, y1));
                        chart
                            .draw_series(segs.into_iter().map(|seg| PathElement::new(seg, c.stroke_width(2))))?
                            .label(format!("{sensor} {}", names[j]))
                            .legend(line_key(c.stroke_width(2)));
                    }
                }
                draw_legend(&mut chart, SeriesLabelPosition::UpperRight, 0.85, 12)?;
            }
            Ok(())
        }),
    })
}

fn slip_class(name: &str) -> Option<SlipClass> {
    SlipClass::ALL.into_iter().find(|c| c.name() == name)
}

/// `slip/1`: the state strip and the speeds at the events.
fn slip_plot(t: &Table) -> R<Prepared> {
    no_rows(t)?;
    let mut ev: Vec<(f64, f64, SlipClass, SlipClass, f64, f64)> = Vec::new();
    let mut pair = None;
    let mut raw: Vec<(i64, i64, String, String, f64, f64)> = Vec::new();
    for b in &t.batches {
        let (time, onset) = (i64s(b, "time_ns")?, i64s(b, "onset_ns")?);
        let (class, prev) = (strings(b, "class")?, strings(b, "previous")?);
        let (l, r) = (f64s(b, "common_mm_s")?, f64s(b, "differential_mm_s")?);
        if pair.is_none() {
            let (f, s) = (strings(b, "first")?, strings(b, "second")?);
            pair = f.first().cloned().zip(s.first().cloned());
        }
        for i in 0..time.len() {
            raw.push((time[i], onset[i], class[i].clone(), prev[i].clone(), l[i], r[i]));
        }
    }
    let t0 = raw.iter().map(|r| r.0.min(r.1)).min().unwrap_or(0);
    for (time, onset, c, p, l, r) in &raw {
        let bad = |n: &str| PlotErr(format!("slip/1: unknown class {n:?}"));
        ev.push((
            secs(*time, t0),
            secs(*onset, t0),
            slip_class(c).ok_or_else(|| bad(c))?,
            slip_class(p).ok_or_else(|| bad(p))?,
            *l,
            *r,
        ));
    }
    let (first, second) = pair.unwrap_or_default();
    let drawn = ev.len() as u64;
    Ok(Prepared {
        size: (PANEL_W, 560),
        sensors: vec![first.clone(), second.clone()],
        drawn,
        draw: Box::new(move |root| {
            let (top, bottom) = root.split_vertically(300);
            let (x0, x1) = padded(range_of(ev.iter().flat_map(|e| [e.0, e.1])), 0.05);
            let (y0, y1) = padded(range_of(ev.iter().flat_map(|e| [e.4, e.5]).chain([0.0])), 0.1);
            let caption = format!("slip events of the pair {first}/{second} (slip/1)");
            let mut chart = chart_on(&top, caption, Frame { x_area: 30, y_area: 70, ..PANEL }, x0..x1, y0..y1)?;
            draw_axes(&mut chart, None, "speed (mm/s)", 12)?;
            for (k, (name, f)) in [("common L", 4usize), ("differential R", 5)].into_iter().enumerate() {
                let c = series_colour(k);
                chart
                    .draw_series(ev.iter().filter(|e| if f == 4 { e.4.is_finite() } else { e.5.is_finite() }).map(
                        |e| {
                            let v = if f == 4 { e.4 } else { e.5 };
                            Circle::new(clamp_pt((e.0, v), (x0, x1), (y0, y1)), 5, c.filled())
                        },
                    ))?
                    .label(name)
                    .legend(dot_key(c));
            }
            draw_legend(&mut chart, SeriesLabelPosition::UpperRight, 0.85, 12)?;
            let frame = Frame { caption: 16, y_area: 70, ..PANEL };
            let mut strip = chart_on(&bottom, "state from each decision on; dashed: onsets", frame, x0..x1, 0.0..1.0)?;
            strip
                .configure_mesh()
                .disable_mesh()
                .disable_y_axis()
                .x_desc("time (s from the first event)")
                .label_style(("sans-serif", 12))
                .draw()?;
            let mut steps = vec![(x0, ev.first().map_or(SlipClass::Stable, |e| e.3))];
            steps.extend(ev.iter().map(|e| (e.0, e.2)));
            for (a, b, c) in class_spans(&steps, x1) {
                strip.draw_series(std::iter::once(Rectangle::new([(a, 0.15), (b, 0.85)], slip_colour(c).filled())))?;
            }
            draw_onsets(
                &mut strip,
                ev.iter().filter(|e| e.2.is_slip()).map(|e| e.1),
                (0.0, 1.0),
                BLACK.stroke_width(1),
            )?;
            slip_legend(&mut strip)
        }),
    })
}

/// `dos/2` (and the older `dos/1`): decided class over time per sensor, shade = posterior of the decided class.
fn dos_plot(t: &Table, notes: &mut Vec<String>) -> R<Prepared> {
    no_rows(t)?;
    let classes: Vec<String> = t
        .schema
        .metadata()
        .get(gradtac_io::records::dos::DOS_CLASSES_KEY)
        .and_then(|j| serde_json::from_str(j).ok())
        .ok_or_else(|| PlotErr(format!("dos file without `{}` metadata", gradtac_io::records::dos::DOS_CLASSES_KEY)))?;
    let groups = limit_sensors(by_sensor(t)?, notes);
    let cols: Vec<(Vec<i64>, Vec<String>, ListCol)> = t
        .batches
        .iter()
        .map(|b| Ok((i64s(b, "end_ns")?, strings(b, "class")?, fixed_lists(b, "posterior")?)))
        .collect::<R<_>>()?;
    let t0 = cols.iter().flat_map(|c| c.0.iter().copied()).min().unwrap_or(0);
    let mut series = Vec::new();
    let mut drawn = 0u64;
    for (sensor, rows) in &groups {
        let k = stride(rows.len(), MAX_POINTS);
        let pts: Vec<(f64, usize, f64)> = rows
            .iter()
            .step_by(k)
            .filter_map(|&(bi, ri)| {
                let (ts, cl, (m, post)) = &cols[bi];
                let c = classes.iter().position(|x| x == &cl[ri])?;
                let p = post.get(ri * m + c).copied().unwrap_or(f64::NAN);
                Some((secs(ts[ri], t0), c, p))
            })
            .collect();
        drawn += pts.len() as u64;
        series.push((sensor.clone(), pts));
    }
    let n = classes.len().max(1);
    let schema_id = t.schema_id.clone();
    Ok(Prepared {
        size: (PANEL_W, STRIP_H * series.len() as u32),
        sensors: groups.iter().map(|g| g.0.clone()).collect(),
        drawn,
        draw: Box::new(move |root| {
            let label = |v: &f64| row_index(*v).and_then(|i| classes.get(i as usize).cloned()).unwrap_or_default();
            for (area, (sensor, pts)) in root.split_evenly((series.len(), 1)).iter().zip(&series) {
                let (x0, x1) = padded(range_of(pts.iter().map(|p| p.0)), 0.02);
                let caption = format!("{sensor}: {} decisions ({schema_id}); shade: posterior", pts.len());
                let frame = Frame { y_area: 50, ..PANEL };
                let mut chart = chart_on(area, caption, frame, x0..x1, -0.5..(n as f64 - 0.5))?;
                chart
                    .configure_mesh()
                    .x_desc("decision time (s from the first row)")
                    .y_labels(n)
                    .y_label_formatter(&label)
                    .label_style(("sans-serif", 12))
                    .draw()?;
                chart.draw_series(pts.iter().map(|&(x, c, p)| {
                    let shade = if p.is_finite() { 0.25 + 0.75 * p.clamp(0.0, 1.0) } else { 0.25 };
                    Circle::new((x, c as f64), 5, series_colour(c).mix(shade).filled())
                }))?;
            }
            Ok(())
        }),
    })
}

/// One layout-plane panel: taxels, the truth (dashed black), the track coloured by time.
fn draw_trajectory(
    area: &Area<'_>,
    title: &str,
    track: &[(f64, f64, f64)],
    truth: &[(f64, f64, f64)],
    layout: &Layout,
    (t0, t1): (f64, f64),
) -> R<()> {
    let (mut chart, bx, by) = plane_chart(area, title, layout)?;
    let mut labelled = false;
    for seg in segments(truth.iter().map(|p| (p.1, p.2)), bx, by) {
        let s = chart.draw_series(DashedLineSeries::new(seg, 6, 4, BLACK.stroke_width(2)))?;
        if !labelled {
            s.label("truth").legend(line_key(BLACK.stroke_width(2)));
            labelled = true;
        }
    }
    let grey = RGBColor(150, 150, 150);
    for seg in segments(track.iter().map(|p| (p.1, p.2)), bx, by) {
        chart.draw_series(std::iter::once(PathElement::new(seg, grey.stroke_width(1))))?;
    }
    let span = (t1 - t0).max(1e-12);
    let s = chart.draw_series(
        track
            .iter()
            .filter(|p| p.1.is_finite() && p.2.is_finite())
            .map(|p| Circle::new(clamp_pt((p.1, p.2), bx, by), 3, viridis((p.0 - t0) / span).filled())),
    )?;
    if !truth.is_empty() {
        s.label("track (colour: time)").legend(dot_key(viridis(0.5)));
        draw_legend(&mut chart, SeriesLabelPosition::UpperRight, 0.85, 12)?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// plots from plain data (the demo)

/// Surfaces at a few instants on `grid` (one row of up to 4 panels, a common colour scale):
/// each with [`ISO_LEVELS`] iso-lines (white), the maximal contour (red, bold; the panel's own
/// or recomputed) and its centroid (red cross), the taxels of `layout` (grey circles) and the
/// true contact (black triangle) when given — the paper's contour-pipeline figure.
///
/// Size: `(4·380 + 120) × (40 + 400)` px. Panels after the 4th are not drawn.
///
/// # Errors
/// [`Error::Plot`] when a panel does not hold `nx·ny` values or drawing fails, [`Error::Io`]
/// when the file cannot be written.
pub fn plot_surface_with_contours(
    grid: &Grid,
    panels: &[SurfacePanel],
    layout: Option<&Layout>,
    title: &str,
    out: &Path,
) -> Result<PlotSummary, Error> {
    let panels = &panels[..panels.len().min(4)];
    let size = (4 * SURF_PANEL + BAR_W, TITLE_H + SURF_ROW_H);
    render(out, size, |root| draw_surfaces(root, grid, &[(panels, layout)], title))?;
    Ok(PlotSummary {
        kind: "surface".into(),
        rows: panels.len() as u64,
        drawn: panels.len() as u64,
        sensors: Vec::new(),
        width: size.0,
        height: size.1,
        notes: Vec::new(),
    })
}

/// A contact track against the ground truth on the layout plane: `track` and `truth` are
/// `(t s, x mm, y mm)` (NaN x or y: no contact, the line breaks); the track's points are
/// coloured by time (colour bar), the truth is a dashed black line, the taxels labelled circles.
///
/// Size: 760 × 680 px.
///
/// # Errors
/// [`Error::Plot`] when drawing fails, [`Error::Io`] when the file cannot be written.
pub fn plot_trajectory_vs_truth(
    track: &[(f64, f64, f64)],
    truth: &[(f64, f64, f64)],
    layout: &Layout,
    out: &Path,
) -> Result<PlotSummary, Error> {
    let size = (TRACK_PANEL + BAR_W, TRACK_H);
    let (t0, t1) = range_of(track.iter().filter(|p| p.1.is_finite()).map(|p| p.0));
    render(out, size, |root| {
        let (main, bar) = root.split_horizontally(TRACK_PANEL);
        colour_bar(&bar, t0, t1, viridis, "time (s)")?;
        draw_trajectory(&main, "contact track vs truth", track, truth, layout, (t0, t1))
    })?;
    Ok(PlotSummary {
        kind: "trajectory".into(),
        rows: track.len() as u64,
        drawn: track.iter().filter(|p| p.1.is_finite() && p.2.is_finite()).count() as u64,
        sensors: Vec::new(),
        width: size.0,
        height: size.1,
        notes: Vec::new(),
    })
}

/// A two-finger slip timeline: top, each sensor's contact `y` (solid) and `x` (dashed) over
/// time; bottom, two class strips — the ground truth (`truth`: `(t s, class)` samples, each
/// class holding until the next sample) and the detector's state (from each event's decision
/// `time` on) — with the detected onsets as vertical dashed lines in both panels. Times in
/// seconds, on the tracks' time base (`Timestamp::as_secs_f64` of the same source).
///
/// Size: 1200 × 700 px.
///
/// # Errors
/// [`Error::Plot`] when drawing fails, [`Error::Io`] when the file cannot be written.
pub fn plot_slip_timeline(
    tracks: &[TimelineTrack<'_>],
    events: &[SlipEvent],
    truth: &[(f64, SlipClass)],
    out: &Path,
) -> Result<PlotSummary, Error> {
    let size = (1200, 700);
    let times = tracks
        .iter()
        .flat_map(|t| t.points.iter().map(|p| p.0))
        .chain(truth.iter().map(|p| p.0))
        .chain(events.iter().flat_map(|e| [e.time.as_secs_f64(), e.onset.as_secs_f64()]));
    let (t0, t1) = range_of(times);
    render(out, size, |root| {
        let (top, bottom) = root.split_vertically(440);
        let (y0, y1) = padded(range_of(tracks.iter().flat_map(|t| t.points.iter().flat_map(|p| [p.1, p.2]))), 0.05);
        let mut chart = chart_on(&top, "contact position per finger", Frame { x_area: 30, ..PANEL }, t0..t1, y0..y1)?;
        draw_axes(&mut chart, None, "position (mm)", 12)?;
        for (i, tr) in tracks.iter().enumerate() {
            let c = series_colour(i);
            let mut first = true;
            for seg in segments(tr.points.iter().map(|p| (p.0, p.2)), (t0, t1), (y0, y1)) {
                let s = chart.draw_series(std::iter::once(PathElement::new(seg, c.stroke_width(2))))?;
                if first {
                    s.label(format!("{} y", tr.sensor)).legend(line_key(c.stroke_width(2)));
                    first = false;
                }
            }
            let mut first = true;
            for seg in segments(tr.points.iter().map(|p| (p.0, p.1)), (t0, t1), (y0, y1)) {
                let s = chart.draw_series(DashedLineSeries::new(seg, 5, 4, c.mix(0.6).stroke_width(1)))?;
                if first {
                    s.label(format!("{} x", tr.sensor)).legend(line_key(c.mix(0.6).stroke_width(1)));
                    first = false;
                }
            }
        }
        let onsets = || events.iter().filter(|e| e.class.is_slip()).map(|e| e.onset.as_secs_f64());
        draw_onsets(&mut chart, onsets(), (y0, y1), BLACK.mix(0.6).stroke_width(1))?;
        draw_legend(&mut chart, SeriesLabelPosition::UpperLeft, 0.85, 12)?;

        let caption = "slip class: truth (top) and detected (bottom); dashed: detected onsets";
        let mut strip = chart_on(&bottom, caption, Frame { caption: 16, ..PANEL }, t0..t1, 0.0..2.0)?;
        strip
            .configure_mesh()
            .disable_mesh()
            .x_desc("time (s)")
            .y_labels(5)
            .y_label_formatter(&|v: &f64| {
                if (v - 1.5).abs() < 0.26 {
                    "truth".into()
                } else if (v - 0.5).abs() < 0.26 {
                    "detected".into()
                } else {
                    String::new()
                }
            })
            .label_style(("sans-serif", 12))
            .draw()?;
        let mut truth_sorted = truth.to_vec();
        truth_sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut det = vec![(t0, events.first().map_or(SlipClass::Stable, |e| e.previous))];
        det.extend(events.iter().map(|e| (e.time.as_secs_f64(), e.class)));
        for (band, pts) in [(1.0, class_spans(&truth_sorted, t1)), (0.0, class_spans(&det, t1))] {
            strip.draw_series(
                pts.iter()
                    .map(|&(a, b, c)| Rectangle::new([(a, band + 0.1), (b, band + 0.9)], slip_colour(c).filled())),
            )?;
        }
        draw_onsets(&mut strip, onsets(), (0.0, 2.0), BLACK.stroke_width(1))?;
        slip_legend(&mut strip)
    })?;
    Ok(PlotSummary {
        kind: "slip timeline".into(),
        rows: tracks.iter().map(|t| t.points.len() as u64).sum(),
        drawn: tracks.iter().map(|t| t.points.len() as u64).sum(),
        sensors: tracks.iter().map(|t| t.sensor.to_string()).collect(),
        width: size.0,
        height: size.1,
        notes: Vec::new(),
    })
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
