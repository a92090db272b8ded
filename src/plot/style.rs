//! Colours and the chart scaffolding shared by every figure (frames, axes, legends, colour bars).

use super::*;

// colours

pub(super) fn lerp_table(table: &[(u8, u8, u8)], t: f64) -> RGBColor {
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    let x = t * (table.len() - 1) as f64;
    let i = (x.floor() as usize).min(table.len() - 2);
    let f = x - i as f64;
    let (a, b) = (table[i], table[i + 1]);
    let m = |p: u8, q: u8| (p as f64 + (q as f64 - p as f64) * f).round() as u8;
    RGBColor(m(a.0, b.0), m(a.1, b.1), m(a.2, b.2))
}

/// Viridis (matplotlib's), 9 anchors, `t` in [0, 1].
pub(super) fn viridis(t: f64) -> RGBColor {
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
pub(super) fn diverging(t: f64) -> RGBColor {
    const D: [(u8, u8, u8); 5] = [(33, 102, 172), (146, 197, 222), (247, 247, 247), (244, 165, 130), (178, 24, 43)];
    lerp_table(&D, t)
}

pub(super) const NAN_GREY: RGBColor = RGBColor(225, 225, 225);

pub(super) fn series_colour(i: usize) -> RGBColor {
    let c = Palette99::pick(i).to_rgba();
    RGBColor(c.0, c.1, c.2)
}

// ---------------------------------------------------------------------------------------------
// chart scaffolding shared by the panels

/// A point on a backend (px), as plotters' `BackendCoord`: where legend keys are drawn.
pub(super) type BackendCoord = (i32, i32);

/// A chart's box along one axis, `(from, to)`, as [`clamp_pt`] and [`segments`] take it.
pub(super) type Bounds = (f64, f64);

/// A chart with f64 axes on the backend `DB`.
pub(super) type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The sizes (px) around a chart: its caption's font, the margin on every side, and the label
/// areas below the plot (x axis) and left of it (y axis).
#[derive(Clone, Copy)]
pub(super) struct Frame {
    pub(super) caption: i32,
    pub(super) margin: i32,
    pub(super) x_area: i32,
    pub(super) y_area: i32,
}

/// The frame of most panels: an 18 px caption, 12 px margins, 36 px of x labels, 60 px of y
/// labels (others are this with a field changed).
pub(super) const PANEL: Frame = Frame { caption: 18, margin: 12, x_area: 36, y_area: 60 };

/// A chart of `xr × yr` on `area`, `caption` above it in sans-serif, sized by `frame`.
pub(super) fn chart_on<'a, DB: DrawingBackend>(
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
pub(super) fn draw_axes<DB: DrawingBackend>(
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
pub(super) fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
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
pub(super) fn legend_entry<'a, DB, E, F>(chart: &mut Chart<'a, DB>, label: impl Into<String>, key: F) -> R<()>
where
    DB: DrawingBackend + 'a,
    E: IntoDynElement<'a, DB, BackendCoord>,
    F: Fn(BackendCoord) -> E + 'a,
{
    chart.draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?.label(label).legend(key);
    Ok(())
}

/// A legend key: a 14 px line drawn with `style`.
pub(super) fn line_key(style: impl Into<ShapeStyle>) -> impl Fn(BackendCoord) -> PathElement<BackendCoord> {
    let style = style.into();
    move |(x, y)| PathElement::new(vec![(x, y), (x + 14, y)], style)
}

/// A legend key: a dot of `colour`.
pub(super) fn dot_key(colour: RGBColor) -> impl Fn(BackendCoord) -> Circle<BackendCoord, i32> {
    move |(x, y)| Circle::new((x + 7, y), 4, colour.filled())
}

/// The row index an axis value `v` labels: `v` itself when it is whole and not negative, else
/// `None` (a tick between rows, left blank).
pub(super) fn row_index(v: f64) -> Option<f64> {
    let i = v.round();
    if (v - i).abs() > 1e-9 || i < 0.0 {
        None
    } else {
        Some(i)
    }
}

/// A taxel axis label: the name of the taxel row `v` (its index when `names` has none), blank
/// between rows.
pub(super) fn taxel_label(names: Option<&[String]>, v: f64) -> String {
    match row_index(v) {
        None => String::new(),
        Some(i) => names.and_then(|nm| nm.get(i as usize).cloned()).unwrap_or_else(|| format!("{i}")),
    }
}

/// An equal-aspect chart of `layout`'s plane (axes in mm) on `area`, `title` above, with the
/// taxels as labelled circles; and the chart's box `(x, y)` for [`clamp_pt`] and [`segments`].
pub(super) fn plane_chart<'a, DB: DrawingBackend>(
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
    let (x, y) = plane_axes(layout);
    draw_axes(&mut chart, Some(x), y, 12)?;
    draw_taxels(&mut chart, layout, true)?;
    legend_entry(&mut chart, "taxel (name)", |c| Circle::new(c, 5, RGBColor(90, 90, 90).stroke_width(1)))?;
    Ok((chart, bx, by))
}

/// Vertical dashed lines (4 px dashes, 4 px gaps) in `style` at each of `xs`, from `y0` to `y1`.
pub(super) fn draw_onsets<DB: DrawingBackend>(
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
pub(super) fn class_spans(steps: &[(f64, SlipClass)], end: f64) -> Vec<(f64, f64, SlipClass)> {
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
pub(super) fn slip_legend<'a, DB: DrawingBackend + 'a>(strip: &mut Chart<'a, DB>) -> R<()> {
    for c in SlipClass::ALL {
        let col = slip_colour(c);
        legend_entry(strip, c.name(), move |(x, y)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], col.filled()))?;
    }
    draw_legend(strip, SeriesLabelPosition::UpperRight, 0.9, 11)
}

/// Each sensor's rows of `groups`, every [`draw_stride`]-th (at most `max`; `what` names them in
/// the note), as the points `point(batch, row)` gives; and how many points there are in all.
pub(super) fn thin_rows<T>(
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
pub(super) fn list_row((m, v): &ListCol, ri: usize) -> &[f64] {
    &v[ri * m..(ri + 1) * m]
}

/// The stride that draws at most `max` of a sensor's `rows` rows; above 1, a note says so
/// (`what`: the rows' noun, plural).
pub(super) fn draw_stride(sensor: &str, rows: usize, max: usize, what: &str, notes: &mut Vec<String>) -> usize {
    let k = stride(rows, max);
    if k > 1 {
        notes.push(format!("{sensor}: every {k}th of {rows} {what} drawn"));
    }
    k
}

pub(super) fn slip_colour(c: SlipClass) -> RGBColor {
    match c {
        SlipClass::Stable => RGBColor(200, 200, 200),
        SlipClass::LongitudinalUp => RGBColor(31, 119, 180),
        SlipClass::LongitudinalDown => RGBColor(255, 127, 14),
        SlipClass::RotationalCw => RGBColor(44, 160, 44),
        SlipClass::RotationalCcw => RGBColor(214, 39, 40),
    }
}

/// A value range `[lo, hi]` with `hi > lo` from finite values (a flat or empty set is widened).
pub(super) fn range_of(values: impl IntoIterator<Item = f64>) -> (f64, f64) {
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
pub(super) const BIG: f64 = 1e300;

/// `v` clamped into `r` widened by twice its span on each side (a point far outside a chart
/// would overflow plotters' pixel arithmetic; the widened band keeps lines' directions), NaN
/// kept (callers skip it).
pub(super) fn clampr(v: f64, r: (f64, f64)) -> f64 {
    let s = 2.0 * (r.1 - r.0);
    if v.is_nan() {
        v
    } else {
        v.clamp(r.0 - s, r.1 + s)
    }
}

/// A point clamped into a chart's widened box (see [`clampr`]).
pub(super) fn clamp_pt((x, y): (f64, f64), xr: (f64, f64), yr: (f64, f64)) -> (f64, f64) {
    (clampr(x, xr), clampr(y, yr))
}

pub(super) fn padded((lo, hi): (f64, f64), f: f64) -> (f64, f64) {
    let d = (hi - lo) * f;
    (lo - d, hi + d)
}

/// A vertical colour bar for `[lo, hi]` with its label.
pub(super) fn colour_bar(area: &Area<'_>, lo: f64, hi: f64, cmap: fn(f64) -> RGBColor, label: &str) -> R<()> {
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
pub(super) fn equal_aspect(e: Extent, w: f64, h: f64) -> (std::ops::Range<f64>, std::ops::Range<f64>) {
    let (ew, eh) = (e.width(), e.height());
    let s = (ew / w.max(1.0)).max(eh / h.max(1.0));
    let (cx, cy) = (0.5 * (e.x_min + e.x_max), 0.5 * (e.y_min + e.y_max));
    let (hw, hh) = (0.5 * s * w, 0.5 * s * h);
    (cx - hw..cx + hw, cy - hh..cy + hh)
}

/// Taxels as grey circles, labelled when `names`.
/// The layout plane's axis labels: the BioTac SP's unwrapped frame (x along the finger, +
/// toward the tip; y the arc length across the pad from its midline), or the layout's own
/// frame for other layouts.
pub(super) fn plane_axes(layout: &Layout) -> (&'static str, &'static str) {
    if layout.names() == Layout::biotac_sp().names() && layout.positions() == Layout::biotac_sp().positions() {
        ("x (mm) along the finger, + toward the tip", "y (mm) across the pad, from its midline")
    } else {
        ("x (mm, layout frame)", "y (mm, layout frame)")
    }
}

pub(super) fn draw_taxels<DB: DrawingBackend>(chart: &mut Chart<'_, DB>, layout: &Layout, names: bool) -> R<()>
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
