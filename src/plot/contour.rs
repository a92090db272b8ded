//! Contour figures: centroid paths and outlines on the layout plane, area over time.

use super::*;

pub(super) fn contour_plot(t: &Table, notes: &mut Vec<String>) -> R<Prepared> {
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
                end: i64s(b, "end")?,
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
            let (mut plane, bx, by) = plane_chart(&left, "contact centroids and contours", &layout)?;
            for (i, (sensor, pts, outlines)) in series.iter().enumerate() {
                let c = series_colour(i);
                if !outlines.is_empty() {
                    legend_entry(&mut plane, format!("{sensor} contour"), line_key(c.mix(0.5).stroke_width(1)))?;
                }
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
pub(super) fn segments(pts: impl Iterator<Item = (f64, f64)>, xr: (f64, f64), yr: (f64, f64)) -> Vec<Vec<(f64, f64)>> {
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
