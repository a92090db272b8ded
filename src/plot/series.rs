//! Time series figures: frames (one line per taxel), events (raster), window aggregates (heat
//! strip), and the scalar series of `force` and `servo` outputs.

use super::*;

pub(super) fn frames_plot(t: &Table, notes: &mut Vec<String>) -> R<Prepared> {
    no_rows(t)?;
    let names = taxel_names(&t.schema, "values");
    let groups = limit_sensors(by_sensor(t)?, notes);
    let cols: Vec<(Vec<i64>, ListCol)> =
        t.batches.iter().map(|b| Ok((i64s(b, "time")?, fixed_lists(b, "values")?))).collect::<R<_>>()?;
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
                let mut chart = chart_on(area, format!("{sensor}: {n} taxels"), frame, x0..x1, y0..y1)?;
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

pub(super) fn events_plot(t: &Table, notes: &mut Vec<String>) -> R<Prepared> {
    no_rows(t)?;
    let names = taxel_names(&t.schema, "taxel");
    let groups = limit_sensors(by_sensor(t)?, notes);
    let cols: Vec<(Vec<i64>, Vec<u16>, Vec<i8>)> = t
        .batches
        .iter()
        .map(|b| {
            let ta = column(b, "taxel")?;
            // taxel numbers count from 1 (event/1 files were renumbered by `normalise`); rows
            // are drawn at the 0-based index
            let taxel: Vec<u16> = ta
                .as_primitive_opt::<UInt16Type>()
                .ok_or_else(|| wrong("taxel", ta))?
                .values()
                .iter()
                .map(|k| k.saturating_sub(1))
                .collect();
            let pa = column(b, "polarity")?;
            let pol = pa.as_primitive_opt::<Int8Type>().ok_or_else(|| wrong("polarity", pa))?.values().to_vec();
            Ok((i64s(b, "time")?, taxel, pol))
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
                let caption = format!("{sensor}: {} events, {pos} up, {} down", pts.len(), pts.len() - pos);
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
                legend_entry(&mut chart, "+1: ln x rose one threshold", dot_key(up))?;
                legend_entry(&mut chart, "−1: ln x fell one threshold", dot_key(down))?;
                draw_legend(&mut chart, SeriesLabelPosition::UpperRight, 0.85, 12)?;
            }
            Ok(())
        }),
    })
}

pub(super) fn window_plot(t: &Table, notes: &mut Vec<String>) -> R<Prepared> {
    no_rows(t)?;
    let names = taxel_names(&t.schema, "values");
    let groups = limit_sensors(by_sensor(t)?, notes);
    let cols: Vec<(Vec<i64>, Vec<String>, ListCol)> = t
        .batches
        .iter()
        .map(|b| Ok((i64s(b, "end")?, strings(b, "aggregate")?, fixed_lists(b, "values")?)))
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
                let caption = format!("{sensor}: {} windows", pts.len());
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

/// Stacked time-series panels of Float64 columns (null as a gap), one line per sensor and
/// column; `panels`: (title, y label, columns).
pub(super) fn series_plot(
    t: &Table,
    notes: &mut Vec<String>,
    time: &str,
    panels: &[(&str, &str, &[&str])],
) -> R<Prepared> {
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
