//! Track figures: contact trajectories on the layout plane, and the demo's trajectory against
//! the simulator's truth.

use super::*;

pub(super) fn track_plot(t: &Table, notes: &mut Vec<String>) -> R<Prepared> {
    no_rows(t)?;
    let groups = limit_sensors(by_sensor(t)?, notes);
    let cols: Vec<(Vec<i64>, Vec<f64>, Vec<f64>)> =
        t.batches.iter().map(|b| Ok((i64s(b, "time")?, f64s(b, "x_mm")?, f64s(b, "y_mm")?))).collect::<R<_>>()?;
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
                draw_trajectory(area, &format!("{sensor}: contact track"), pts, &[], layout, (tl, th))?;
            }
            Ok(())
        }),
    })
}

/// One layout-plane panel: taxels, the truth (dashed black), the track coloured by time.
pub(super) fn draw_trajectory(
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
    s.label("contact (colour: time)").legend(dot_key(viridis(0.5)));
    legend_entry(&mut chart, "contact path", line_key(grey.stroke_width(1)))?;
    draw_legend(&mut chart, SeriesLabelPosition::UpperRight, 0.85, 12)?;
    Ok(())
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
