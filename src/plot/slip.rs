//! Slip figures: the two-finger grasp's state over time (`slip`), one-fingertip slip-direction
//! decisions (`dos`), and the demo's slip timeline.

use super::*;

pub(super) fn slip_class(name: &str) -> Option<SlipClass> {
    SlipClass::ALL.into_iter().find(|c| c.name() == name)
}

/// `slip/1`: the state strip and the speeds at the events.
pub(super) fn slip_plot(t: &Table) -> R<Prepared> {
    no_rows(t)?;
    let mut ev: Vec<(f64, f64, SlipClass, SlipClass, f64, f64)> = Vec::new();
    let mut pair = None;
    let mut raw: Vec<(i64, i64, String, String, f64, f64)> = Vec::new();
    for b in &t.batches {
        let (time, onset) = (i64s(b, "time")?, i64s(b, "onset")?);
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
        let bad = |n: &str| PlotErr(format!("slip file: unknown class {n:?}"));
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
            let caption = format!("grasp state of the pair {first} / {second}");
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
pub(super) fn dos_plot(t: &Table, notes: &mut Vec<String>) -> R<Prepared> {
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
        .map(|b| Ok((i64s(b, "end")?, strings(b, "class")?, fixed_lists(b, "posterior")?)))
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
    Ok(Prepared {
        size: (PANEL_W, STRIP_H * series.len() as u32),
        sensors: groups.iter().map(|g| g.0.clone()).collect(),
        drawn,
        draw: Box::new(move |root| {
            let label = |v: &f64| row_index(*v).and_then(|i| classes.get(i as usize).cloned()).unwrap_or_default();
            for (area, (sensor, pts)) in root.split_evenly((series.len(), 1)).iter().zip(&series) {
                let (x0, x1) = padded(range_of(pts.iter().map(|p| p.0)), 0.02);
                let caption =
                    format!("{sensor}: {} slip-direction decisions; shade: posterior of the decided class", pts.len());
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
