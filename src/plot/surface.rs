//! Surface figures: the stored surface at a few instants, its iso-lines and maximal contour
//! drawn with the contour settings the run used (the file's scene metadata), taxels as circles.

use super::*;

/// The grid of a `surface/1` file from its `gradtac.grid` schema metadata.
pub(super) fn grid_of(t: &Table) -> R<Grid> {
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

/// The contour stage's settings of the run that wrote `t`: `[stages.contour]` of the scene in
/// its `gradtac.scene` metadata, and whether they came from there (else the stage's defaults
/// with any peak, for files written without a scene).
pub(super) fn contour_settings(t: &Table) -> (ContourConfig, bool) {
    let stored = t.kv.get("gradtac.scene").and_then(|text| {
        let scene: toml::Value = toml::from_str(text).ok()?;
        let c = scene.get("stages").and_then(|s| s.get("contour")).cloned();
        match c {
            Some(v) => v.try_into::<ContourConfig>().ok(),
            None => Some(ContourConfig::default()), // the scene left the contour stage at its defaults
        }
    });
    match stored {
        Some(c) => (c, true),
        None => (ContourConfig { min_peak: -f64::MAX, ..Default::default() }, false),
    }
}

/// The maximal contour of a surface with the contour settings `cfg`.
pub(super) fn max_contour(grid: &Grid, values: &[f64], cfg: &ContourConfig) -> Option<Vec<[f64; 2]>> {
    let z = ArrayView2::from_shape((grid.ny(), grid.nx()), values).ok()?;
    let mut f = MaxContourFinder::try_new(cfg).ok()?;
    match f.find(z, grid) {
        ContourOutcome::Contact(c) => Some(c.polygon),
        ContourOutcome::NoContact(_) => None,
    }
}

pub(super) fn surface_plot(t: &Table, notes: &mut Vec<String>) -> R<Prepared> {
    no_rows(t)?;
    let grid = grid_of(t)?;
    let groups = limit_sensors(by_sensor(t)?, notes);
    let cols: Vec<(Vec<i64>, ListCol)> =
        t.batches.iter().map(|b| Ok((i64s(b, "end")?, fixed_lists(b, "values")?))).collect::<R<_>>()?;
    let t0 = cols.iter().flat_map(|c| c.0.iter().copied()).min().unwrap_or(0);
    let m = grid.len();
    if cols.iter().any(|c| c.1 .0 != m) {
        return Err(PlotErr(format!("surface rows do not hold nx·ny = {m} values")));
    }
    let (cfg, stored) = contour_settings(t);
    notes.push(if stored {
        "iso-lines and maximal contours drawn with the run's [stages.contour] settings (the file's gradtac.scene)"
            .into()
    } else {
        format!(
            "no scene in the file: iso-lines and maximal contours drawn with the contour stage's defaults \
             ({ISO_LEVELS} levels, min area 1 mm²) and any peak"
        )
    });
    let mut rows_out = Vec::new();
    for (sensor, rows) in &groups {
        let contour_of = |&(bi, ri): &(usize, usize)| max_contour(&grid, &cols[bi].1 .1[ri * m..(ri + 1) * m], &cfg);
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
                contour: contour_of(&(bi, ri)),
                truth: None,
            })
            .collect();
        rows_out.push((panels, layout));
    }
    let drawn = rows_out.iter().map(|r| r.0.len() as u64).sum();
    let size = (4 * SURF_PANEL + BAR_W, TITLE_H + SURF_ROW_H * rows_out.len() as u32);
    let sensors = groups.iter().map(|g| g.0.clone()).collect();
    let title = format!("interpolated surfaces on a {}×{} grid", grid.nx(), grid.ny());
    Ok(Prepared {
        size,
        sensors,
        drawn,
        draw: Box::new(move |root| {
            let rows: Vec<(&[SurfacePanel], Option<&Layout>)> =
                rows_out.iter().map(|(p, l)| (p.as_slice(), l.as_ref())).collect();
            draw_surfaces(root, &grid, &rows, &title, &cfg)
        }),
    })
}

/// Rows of surface panels (a common colour scale) with a colour bar and a title.
pub(super) fn draw_surfaces(
    root: &Area<'_>,
    grid: &Grid,
    rows: &[(&[SurfacePanel], Option<&Layout>)],
    title: &str,
    cfg: &ContourConfig,
) -> R<()> {
    let (top, body) = root.split_vertically(TITLE_H);
    top.draw(&Text::new(title.to_string(), (12, 10), ("sans-serif", 20).into_font()))?;
    // the legend: one key per mark, in the title strip
    let truth = rows.iter().any(|r| r.0.iter().any(|p| p.truth.is_some()));
    let taxels = rows.iter().any(|r| r.1.is_some());
    let font = ("sans-serif", 13).into_font();
    let mut x = 470;
    let y = 20;
    let mut key = |label: &str, draw: &dyn Fn(i32) -> R<()>| -> R<()> {
        draw(x)?;
        top.draw(&Text::new(label.to_string(), (x + 26, y - 8), font.clone()))?;
        x += 34 + 7 * label.chars().count() as i32;
        Ok(())
    };
    let iso = match &cfg.levels {
        Levels::Count(n) => format!("iso-lines ({n} levels)"),
        Levels::Explicit(v) => format!("iso-lines ({} levels)", v.len()),
    };
    key(&iso, &|x| {
        Ok(top.draw(&PathElement::new(vec![(x, y), (x + 20, y)], RGBColor(150, 150, 150).stroke_width(2)))?)
    })?;
    key("maximal contour", &|x| Ok(top.draw(&PathElement::new(vec![(x, y), (x + 20, y)], RED.stroke_width(3)))?))?;
    key("its centroid", &|x| Ok(top.draw(&Cross::new((x + 10, y), 6, RED.stroke_width(2)))?))?;
    if taxels {
        key("taxel", &|x| Ok(top.draw(&Circle::new((x + 10, y), 5, RGBColor(90, 90, 90).stroke_width(1)))?))?;
    }
    if truth {
        key("true contact", &|x| Ok(top.draw(&TriangleMarker::new((x + 10, y), 7, BLACK.filled()))?))?;
    }
    key("outside the taxels' hull", &|x| {
        Ok(top.draw(&Rectangle::new([(x + 2, y - 7), (x + 18, y + 7)], NAN_GREY.filled()))?)
    })?;
    let (main, bar) = body.split_horizontally(4 * SURF_PANEL);
    let (lo, hi) = range_of(rows.iter().flat_map(|r| r.0.iter().flat_map(|p| p.values.iter().copied())));
    colour_bar(&bar, lo, hi, viridis, "surface value")?;
    for (row_area, (panels, layout)) in main.split_evenly((rows.len().max(1), 1)).iter().zip(rows) {
        for (area, p) in row_area.split_evenly((1, 4)).iter().zip(panels.iter()) {
            draw_surface_panel(area, grid, p, *layout, (lo, hi), cfg)?;
        }
    }
    Ok(())
}

pub(super) fn draw_surface_panel(
    area: &Area<'_>,
    grid: &Grid,
    p: &SurfacePanel,
    layout: Option<&Layout>,
    (lo, hi): (f64, f64),
    cfg: &ContourConfig,
) -> R<()> {
    let (nx, ny) = (grid.nx(), grid.ny());
    if p.values.len() != nx * ny {
        return Err(PlotErr(format!("panel {:?}: {} values for a {nx}×{ny} grid", p.label, p.values.len())));
    }
    let (w, h) = area.dim_in_pixel();
    let (xr, yr) = equal_aspect(grid.extent(), w as f64 - 60.0, h as f64 - 70.0);
    let (bx, by) = ((xr.start, xr.end), (yr.start, yr.end));
    let mut chart = chart_on(area, &p.label, Frame { caption: 15, margin: 8, x_area: 30, y_area: 40 }, xr, yr)?;
    let (xd, yd) = match layout {
        Some(l) if plane_axes(l).0.contains("finger") => ("x (mm) → fingertip", "y (mm) across the pad"),
        _ => ("x (mm)", "y (mm)"),
    };
    chart.configure_mesh().disable_mesh().x_desc(xd).y_desc(yd).label_style(("sans-serif", 11)).draw()?;
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
    let levels: Vec<f64> = match &cfg.levels {
        Levels::Count(n) => (1..=*n).map(|k| zmin + (zmax - zmin) * k as f64 / (*n + 1) as f64).collect(),
        Levels::Explicit(v) => v.clone(),
    };
    for level in levels {
        for iso in isolines(z, level, cfg.saddle) {
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
    let contour = p.contour.clone().or_else(|| max_contour(grid, &p.values, cfg));
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

pub(super) fn centroid(poly: &[[f64; 2]]) -> (f64, f64) {
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
    let cfg = ContourConfig { min_peak: -f64::MAX, ..Default::default() };
    render(out, size, |root| draw_surfaces(root, grid, &[(panels, layout)], title, &cfg))?;
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
