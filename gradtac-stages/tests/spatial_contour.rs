//! Contours: agreement with scikit-image, the maximal contour on analytic surfaces, and
//! peak-only marching equal to whole-grid marching.

use gradtac_stages::contour::{
    isolines, polygon_area, region_boundaries, ContourConfig, ContourOutcome, Levels, MaxContourFinder, NoContact,
    Saddle,
};
use gradtac_stages::interpolate::Grid;
use gradtac_stream::Extent;
use ndarray::Array2;
use proptest::prelude::*;
use std::collections::HashMap;

#[derive(serde::Deserialize)]
struct File {
    generator: serde_json::Value,
    surfaces: HashMap<String, Surf>,
    cases: Vec<Case>,
}
#[derive(serde::Deserialize)]
struct Surf {
    shape: [usize; 2],
    values: Vec<Option<f64>>,
}
#[derive(serde::Deserialize)]
struct Case {
    surface: String,
    level: f64,
    fully_connected: String,
    contours: Vec<Vec<[f64; 2]>>,
}

/// A polyline in a canonical form: closed lines without the repeated point, rotated to start
/// at the smallest vertex, in the direction whose second vertex is smaller; open lines in the
/// direction whose first vertex is smaller. Points are `[col, row]`.
fn canonical(mut p: Vec<[f64; 2]>, closed: bool) -> Vec<[f64; 2]> {
    // order on points rounded to 1e-9, so that last-ulp differences do not change the form
    let q = |a: &[f64; 2]| ((a[0] * 1e9).round() as i64, (a[1] * 1e9).round() as i64);
    let lt = |a: &[f64; 2], b: &[f64; 2]| q(a).cmp(&q(b));
    if closed {
        let n = p.len();
        let k = (0..n).min_by(|&a, &b| lt(&p[a], &p[b])).unwrap();
        p.rotate_left(k);
        if n > 2 && lt(&p[n - 1], &p[1]).is_lt() {
            p[1..].reverse();
        }
    } else if lt(p.last().unwrap(), &p[0]).is_lt() {
        p.reverse();
    }
    p
}

#[test]
fn isolines_match_skimage_find_contours() {
    let file: File = serde_json::from_str(include_str!("reference/contours.json")).unwrap();
    assert!(file.generator["scikit-image"].is_string());
    let mut lines_checked = 0;
    for c in &file.cases {
        let s = &file.surfaces[&c.surface];
        let z =
            Array2::from_shape_vec((s.shape[0], s.shape[1]), s.values.iter().map(|v| v.unwrap_or(f64::NAN)).collect())
                .unwrap();
        let saddle = if c.fully_connected == "low" { Saddle::Low } else { Saddle::High };
        let ours = isolines(z.view(), c.level, saddle);
        let mut ours: Vec<Vec<[f64; 2]>> = ours.into_iter().map(|l| canonical(l.points, l.closed)).collect();
        let mut theirs: Vec<Vec<[f64; 2]>> = c
            .contours
            .iter()
            .map(|l| {
                let closed = l.len() > 2 && l[0] == l[l.len() - 1];
                let mut pts: Vec<[f64; 2]> = l.iter().map(|&[r, col]| [col, r]).collect();
                if closed {
                    pts.pop();
                }
                canonical(pts, closed)
            })
            .collect();
        let key = |l: &Vec<[f64; 2]>| ((l[0][0] * 1e9).round() as i64, (l[0][1] * 1e9).round() as i64, l.len());
        ours.sort_by_key(key);
        theirs.sort_by_key(key);
        assert_eq!(ours.len(), theirs.len(), "{} level {} {}", c.surface, c.level, c.fully_connected);
        for (a, b) in ours.iter().zip(&theirs) {
            assert_eq!(a.len(), b.len(), "{} level {}", c.surface, c.level);
            for (p, q) in a.iter().zip(b) {
                assert!(
                    (p[0] - q[0]).abs() < 1e-12 && (p[1] - q[1]).abs() < 1e-12,
                    "{} level {} {}: {p:?} vs {q:?}",
                    c.surface,
                    c.level,
                    c.fully_connected
                );
            }
            lines_checked += 1;
        }
    }
    assert!(lines_checked > 100, "{lines_checked}");
}

fn grid(nx: usize, ny: usize) -> Grid {
    Grid::try_new(Extent { x_min: 0.0, x_max: (nx - 1) as f64 * 0.5, y_min: 0.0, y_max: (ny - 1) as f64 * 0.5 }, nx, ny)
        .unwrap()
}

fn gaussian(g: &Grid, cx: f64, cy: f64, sx: f64, sy: f64, angle: f64) -> Array2<f64> {
    let (c, s) = (angle.cos(), angle.sin());
    Array2::from_shape_fn((g.ny(), g.nx()), |(j, i)| {
        let (dx, dy) = (g.x(i) - cx, g.y(j) - cy);
        let (u, v) = (c * dx + s * dy, -s * dx + c * dy);
        10.0 * (-(u * u) / (2.0 * sx * sx) - (v * v) / (2.0 * sy * sy)).exp()
    })
}

fn find(z: &Array2<f64>, g: &Grid, cfg: &ContourConfig) -> ContourOutcome {
    MaxContourFinder::try_new(cfg).unwrap().find(z.view(), g)
}

#[test]
fn flat_surface_has_no_contact() {
    let g = grid(20, 20);
    let z = Array2::from_elem((20, 20), 5.0);
    assert_eq!(find(&z, &g, &ContourConfig::default()), ContourOutcome::NoContact(NoContact::Flat));
    let z = Array2::from_elem((20, 20), 0.0);
    assert_eq!(find(&z, &g, &ContourConfig::default()), ContourOutcome::NoContact(NoContact::BelowMinPeak));
    let z = Array2::from_elem((20, 20), f64::NAN);
    assert_eq!(find(&z, &g, &ContourConfig::default()), ContourOutcome::NoContact(NoContact::NoData));
    // explicit levels all above the peak: flat as far as the levels can tell
    let cfg = ContourConfig { levels: Levels::Explicit(vec![100.0]), ..Default::default() };
    let z = gaussian(&g, 5.0, 5.0, 1.0, 1.0, 0.0);
    assert_eq!(find(&z, &g, &cfg), ContourOutcome::NoContact(NoContact::Flat));
    // a minimum area nothing reaches
    let cfg = ContourConfig { min_area_mm2: 1e6, ..Default::default() };
    assert_eq!(find(&z, &g, &cfg), ContourOutcome::NoContact(NoContact::TooSmall));
}

#[test]
fn single_peak_centroid_area_and_orientation() {
    let g = grid(81, 81); // 0..40 mm, 0.5 mm spacing
    let (cx, cy) = (20.0, 20.0);
    // round peak on a grid point: symmetric polygon, centroid exact to rounding
    let z = gaussian(&g, cx, cy, 3.0, 3.0, 0.0);
    let cfg = ContourConfig { levels: Levels::Explicit(vec![5.0]), ..Default::default() };
    let c = find(&z, &g, &cfg).contact().cloned().expect("a contact");
    assert!((c.centroid_mm[0] - cx).abs() < 1e-9 && (c.centroid_mm[1] - cy).abs() < 1e-9, "{:?}", c.centroid_mm);
    // {z > 5} is a disc of radius σ√(2 ln 2); marching squares is second-order accurate
    let r = 3.0 * (2.0 * 2f64.ln()).sqrt();
    let want = std::f64::consts::PI * r * r;
    assert!((c.area_mm2 - want).abs() / want < 5e-3, "{} vs {want}", c.area_mm2);
    assert!(c.eccentricity < 0.05, "{}", c.eccentricity);
    assert_eq!(c.peak, 10.0);
    assert_eq!(c.peak_mm, [cx, cy]);
    assert!(!c.clipped);
    assert!(polygon_area(&c.polygon) > 0.0, "counter-clockwise");
    // an elongated peak at 30°, off the grid points: orientation and centroid follow it
    let angle = 30f64.to_radians();
    let z = gaussian(&g, 17.3, 22.1, 5.0, 2.0, angle);
    let c = find(&z, &g, &ContourConfig::default()).contact().cloned().unwrap();
    assert!((c.orientation_rad - angle).abs() < 0.01, "{}", c.orientation_rad.to_degrees());
    assert!((c.centroid_mm[0] - 17.3).abs() < 0.02 && (c.centroid_mm[1] - 22.1).abs() < 0.02, "{:?}", c.centroid_mm);
    assert!(c.eccentricity > 0.8);
    // default levels: 10 levels between min and max; the highest (≈ 0.909·peak) wins when its area ≥ 1 mm²
    assert!(
        (c.level
            - (z.iter().cloned().fold(f64::INFINITY, f64::min)
                + 10.0 * (c.peak - z.iter().cloned().fold(f64::INFINITY, f64::min)) / 11.0))
            .abs()
            < 1e-12
    );
}

#[test]
fn two_equal_peaks_take_the_first_in_raster_order() {
    let g = grid(81, 61);
    let a = gaussian(&g, 10.0, 15.0, 2.0, 2.0, 0.0);
    let b = gaussian(&g, 30.0, 15.0, 2.0, 2.0, 0.0);
    let z = &a + &b;
    for peak_only in [true, false] {
        let cfg = ContourConfig { peak_only, ..Default::default() };
        let c = find(&z, &g, &cfg).contact().cloned().unwrap();
        // ties go to the first grid point in raster order: same row, lower x
        assert_eq!(c.peak_mm, [10.0, 15.0]);
        // the other component (masked while marching) does not make the region look cut
        assert!(!c.clipped);
        assert!((c.centroid_mm[0] - 10.0).abs() < 1e-6, "{:?}", c.centroid_mm);
        // the other peak's region is not merged: the area equals a lone peak's at that level
        let single = find(&a, &g, &ContourConfig { levels: Levels::Explicit(vec![c.level]), ..cfg.clone() });
        let s = single.contact().unwrap();
        assert!((c.area_mm2 - s.area_mm2).abs() < 1e-6 * s.area_mm2, "{} vs {}", c.area_mm2, s.area_mm2);
    }
}

#[test]
fn region_cut_by_the_grid_edge_is_closed_along_it() {
    let g = grid(41, 41);
    // peak centred on the left edge: half a disc is visible
    let z = gaussian(&g, 0.0, 10.0, 3.0, 3.0, 0.0);
    let cfg = ContourConfig { levels: Levels::Explicit(vec![5.0]), ..Default::default() };
    let c = find(&z, &g, &cfg).contact().cloned().unwrap();
    assert!(c.clipped);
    let r = 3.0 * (2.0 * 2f64.ln()).sqrt();
    let half = std::f64::consts::PI * r * r / 2.0;
    assert!((c.area_mm2 - half).abs() / half < 1e-2, "{} vs {half}", c.area_mm2);
    // the polygon runs along x = 0 between the crossings
    assert!(c.polygon.iter().filter(|p| p[0] == 0.0).count() >= 2);
    // centroid of a half disc: 4r/(3π) from the edge
    assert!((c.centroid_mm[0] - 4.0 * r / (3.0 * std::f64::consts::PI)).abs() < 0.02, "{:?}", c.centroid_mm);
    // NaN (outside the hull) closes a region the same way
    let mut zn = gaussian(&g, 10.0, 10.0, 3.0, 3.0, 0.0);
    for j in 0..41 {
        for i in 0..20 {
            zn[[j, i]] = f64::NAN;
        }
    }
    let c = find(&zn, &g, &cfg).contact().cloned().unwrap();
    assert!(c.clipped);
    assert!(c.polygon.iter().all(|p| p[0] >= 9.5));
}

#[test]
fn ring_with_a_hole() {
    let g = grid(61, 61);
    // an annulus: high on a ring of radius 8 around (15,15)
    let z = Array2::from_shape_fn((61, 61), |(j, i)| {
        let r = (g.x(i) - 15.0).hypot(g.y(j) - 15.0);
        10.0 * (-(r - 8.0).powi(2) / 2.0).exp()
    });
    let cfg = ContourConfig { levels: Levels::Explicit(vec![5.0]), ..Default::default() };
    let c = find(&z, &g, &cfg).contact().cloned().unwrap();
    assert_eq!(c.holes.len(), 1);
    // annulus of radii 8 ± √(2 ln 2)
    let w = (2.0 * 2f64.ln()).sqrt();
    let want = std::f64::consts::PI * ((8.0 + w).powi(2) - (8.0 - w).powi(2));
    assert!((c.area_mm2 - want).abs() / want < 1e-2, "{} vs {want}", c.area_mm2);
    assert!((c.centroid_mm[0] - 15.0).abs() < 1e-2 && (c.centroid_mm[1] - 15.0).abs() < 1e-2);
}

#[test]
fn region_boundaries_close_everything() {
    let g = grid(30, 30);
    let z = gaussian(&g, 0.0, 0.0, 4.0, 4.0, 0.0) + gaussian(&g, 14.5, 14.5, 1.0, 1.0, 0.0);
    let rings = region_boundaries(z.view(), 5.0, Saddle::Centre);
    assert_eq!(rings.len(), 2);
    assert!(rings.iter().all(|r| polygon_area(r) > 0.0));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Marching only the peak region's bounding box gives exactly the whole-grid result, for any
    /// surface (random bumps, plateaus, NaN holes) and any saddle rule.
    #[test]
    fn peak_only_equals_whole_grid(
        vals in prop::collection::vec(prop::option::weighted(0.95, -3i32..6), 12 * 14),
        saddle in prop::sample::select(vec![Saddle::Centre, Saddle::High, Saddle::Low]),
        levels in 1usize..12,
        min_area in 0.0f64..3.0,
    ) {
        let g = grid(14, 12);
        let z = Array2::from_shape_vec((12, 14), vals.iter().map(|v| v.map_or(f64::NAN, |x| x as f64)).collect()).unwrap();
        let base = ContourConfig { levels: Levels::Count(levels), saddle, min_area_mm2: min_area, ..Default::default() };
        let a = find(&z, &g, &ContourConfig { peak_only: true, ..base.clone() });
        let b = find(&z, &g, &ContourConfig { peak_only: false, ..base });
        prop_assert_eq!(&a, &b);
        if let Some(c) = a.contact() {
            prop_assert!(c.area_mm2 >= min_area);
            prop_assert!(polygon_area(&c.polygon) > 0.0);
            prop_assert!(c.centroid_mm[0].is_finite() && c.centroid_mm[1].is_finite());
        }
    }
}

/// Surfaces at the extremes of f64: huge values whose range overflows, tiny values near the
/// subnormal range, and a huge constant offset; the contour is the same shape in each.
#[test]
fn extreme_values_keep_the_shape() {
    let g = grid(41, 41);
    let base = gaussian(&g, 10.0, 10.0, 3.0, 3.0, 0.0).mapv(|v| v / 10.0 * 2.0 - 1.0); // −1..1
    let cfg = ContourConfig { min_peak: f64::MIN, ..Default::default() };
    let want = find(&base, &g, &cfg).contact().cloned().unwrap();
    for scale in [1e-300, 1e300, 1.7e308] {
        let z = base.mapv(|v| v * scale);
        let c = find(&z, &g, &cfg).contact().cloned().unwrap_or_else(|| panic!("scale {scale:e}"));
        assert!((c.area_mm2 - want.area_mm2).abs() < 1e-9 * want.area_mm2, "scale {scale:e}: {}", c.area_mm2);
        assert!((c.centroid_mm[0] - want.centroid_mm[0]).abs() < 1e-9, "scale {scale:e}");
    }
    // an offset of 1e12 leaves ~4 significant digits of the bump: the shape survives roughly
    let z = base.mapv(|v| v + 1e12);
    let c = find(&z, &g, &cfg).contact().cloned().unwrap();
    assert!((c.area_mm2 - want.area_mm2).abs() < 1e-3 * want.area_mm2, "{} vs {}", c.area_mm2, want.area_mm2);
    // ±∞ on the surface is refused as no data, not a panic
    let mut z = base.clone();
    z[[3, 3]] = f64::INFINITY;
    assert_eq!(find(&z, &g, &cfg), ContourOutcome::NoContact(NoContact::NoData));
}
