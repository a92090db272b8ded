//! Interpolation: analytic cases, MetPy reference vectors, degenerate geometry, incremental updates.

use gradtac_stages::interpolate::{Grid, Interpolate, InterpolateConfig, Interpolator, Method, Outside};
use gradtac_stream::{Extent, Layout, Stage, TaxelFrame, Timestamp};
use proptest::prelude::*;
use std::sync::Arc;

const ALL: [Method; 4] = [Method::NaturalNeighbour, Method::Linear, Method::Nearest, Method::InverseDistance];

fn layout(p: Vec<[f64; 2]>) -> Layout {
    let names = (0..p.len()).map(|i| format!("t{i}")).collect();
    Layout::try_new("test", names, p, None).unwrap()
}

fn interp(l: &Layout, g: &Arc<Grid>, m: Method, o: Outside) -> Interpolator {
    Interpolator::try_new(l, g.clone(), m, o, 2.0, 0.0).unwrap()
}

#[test]
fn constant_in_constant_out_every_method_and_policy() {
    let l = Layout::biotac_sp();
    let g = Arc::new(Grid::try_new(l.extent(), 64, 64).unwrap());
    for m in ALL {
        for o in [Outside::Nan, Outside::Fill, Outside::Extend] {
            let it = interp(&l, &g, m, o);
            let s = it.surface(&[3.25; 24]);
            let mut inside = 0;
            for (p, &v) in s.iter().enumerate() {
                if it.table().inside(p) || o == Outside::Extend {
                    assert!((v - 3.25).abs() <= 32.0 * f64::EPSILON * 3.25, "{m:?} {o:?} point {p}: {v}");
                    inside += 1;
                } else if o == Outside::Nan {
                    assert!(v.is_nan());
                } else {
                    assert_eq!(v, 0.0);
                }
            }
            assert!(inside > 64 * 64 / 3, "{m:?} {o:?}: only {inside} points inside");
        }
    }
}

#[test]
fn linear_field_is_reproduced_by_natural_neighbour_and_linear() {
    let l = Layout::biotac_sp();
    let f = |p: [f64; 2]| 1.5 - 0.75 * p[0] + 2.25 * p[1];
    let vals: Vec<f64> = l.positions().iter().map(|&p| f(p)).collect();
    for n in [16, 64, 128] {
        let g = Arc::new(Grid::try_new(l.extent(), n, n).unwrap());
        for m in [Method::NaturalNeighbour, Method::Linear] {
            // Extend: outside the hull the closest hull point's value, which is also linear
            // along the hull edge, so inside-only points are checked
            let it = interp(&l, &g, m, Outside::Nan);
            let s = it.surface(&vals);
            let mut worst: f64 = 0.0;
            for j in 0..n {
                for i in 0..n {
                    let v = s[[j, i]];
                    if !v.is_nan() {
                        worst = worst.max((v - f([g.x(i), g.y(j)])).abs());
                    }
                }
            }
            assert!(worst <= 1e-9, "{m:?} {n}: {worst:e}");
        }
    }
}

/// A square lattice of taxels with a grid of half the spacing: grid points fall on taxels, on
/// Delaunay edges (lattice sides and diagonals) and at the centres of cocircular squares, where
/// the Delaunay triangulation is ambiguous (MetPy divides by zero on several of these).
#[test]
fn grid_points_on_taxels_edges_and_cocircular_centres() {
    let mut p = Vec::new();
    for j in 0..4 {
        for i in 0..5 {
            p.push([i as f64, j as f64]);
        }
    }
    let l = layout(p.clone());
    let e = Extent { x_min: 0.0, x_max: 4.0, y_min: 0.0, y_max: 3.0 };
    let g = Arc::new(Grid::try_new(e, 9, 7).unwrap());
    let f = |q: [f64; 2]| 0.5 + 2.0 * q[0] - 3.0 * q[1];
    let vals: Vec<f64> = p.iter().map(|&q| f(q)).collect();
    for m in ALL {
        let it = interp(&l, &g, m, Outside::Nan);
        let s = it.surface(&vals);
        for j in 0..7 {
            for i in 0..9 {
                let v = s[[j, i]];
                assert!(v.is_finite(), "{m:?} ({i},{j}) is on or inside the hull");
                let exact = f([g.x(i), g.y(j)]);
                if i % 2 == 0 && j % 2 == 0 {
                    // on a taxel: every method returns the taxel's value
                    assert!((v - exact).abs() < 1e-12, "{m:?} ({i},{j}): {v} vs {exact}");
                }
                if matches!(m, Method::NaturalNeighbour | Method::Linear) {
                    assert!((v - exact).abs() < 1e-12, "{m:?} ({i},{j}): {v} vs {exact}");
                }
            }
        }
    }
}

#[derive(serde::Deserialize)]
struct NnFile {
    generator: serde_json::Value,
    cases: Vec<NnCase>,
}

#[derive(serde::Deserialize)]
struct NnCase {
    name: String,
    positions: Vec<[f64; 2]>,
    values: Vec<f64>,
    extent: Extent,
    nx: usize,
    ny: usize,
    expected: Vec<Option<f64>>,
}

/// Natural-neighbour values agree with MetPy's `natural_neighbor_to_grid` wherever MetPy
/// returns a finite value (reference vectors from `reference/gen_spatial.py`).
#[test]
fn natural_neighbour_matches_metpy() {
    let text = include_str!("reference/natural_neighbour.json");
    let file: NnFile = serde_json::from_str(text).unwrap();
    assert!(file.generator["metpy"].is_string());
    // the script's BioTac positions are the built-in layout's
    let bt = Layout::biotac_sp();
    for (a, b) in bt.positions().iter().zip(&file.cases[0].positions) {
        assert!((a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12);
    }
    let mut compared = 0;
    for c in &file.cases {
        let l = layout(c.positions.clone());
        let g = Arc::new(Grid::try_new(c.extent, c.nx, c.ny).unwrap());
        let it = interp(&l, &g, Method::NaturalNeighbour, Outside::Nan);
        let s = it.surface(&c.values);
        let mut worst: f64 = 0.0;
        for (k, (v, want)) in s.iter().zip(&c.expected).enumerate() {
            // where MetPy gives NaN (outside its hull, or a failure on a Delaunay edge) ours is
            // checked by the analytic tests instead
            if let Some(w) = want {
                assert!(v.is_finite(), "{}: point {k}: MetPy {w}, we NaN", c.name);
                worst = worst.max((v - w).abs());
                compared += 1;
            }
        }
        assert!(worst <= 1e-6, "{}: max |Δ| = {worst:e}", c.name);
        eprintln!("{}: max |Δ| vs MetPy = {worst:e}", c.name);
    }
    assert!(compared > 4000);
}

#[test]
fn degenerate_layouts_are_refused_with_clear_errors() {
    let n = |k: usize| (0..k).map(|i| format!("t{i}")).collect::<Vec<_>>();
    assert!(Layout::try_new("two", n(2), vec![[0.0, 0.0], [1.0, 0.0]], None).is_err());
    assert!(Layout::try_new("dup", n(3), vec![[0.0, 0.0], [1.0, 1.0], [0.0, 0.0]], None).is_err());
    assert!(Layout::try_new("line", n(4), vec![[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.0]], None).is_err());
    // spade cannot triangulate coordinates beyond ±3.2e60; layouts stop far earlier (1e6 mm)
    let e = Layout::try_new("huge", n(3), vec![[0.0, 0.0], [1e61, 0.0], [0.0, 1e61]], None).unwrap_err();
    assert!(e.to_string().contains("beyond ±1000000 mm"), "{e}");
    // nearly collinear but accepted by the layout: either refused clearly or valid weights
    let thin = Layout::try_new("thin", n(3), vec![[0.0, 0.0], [1.0, 0.0], [0.5, 1e-9]], None).unwrap();
    let g = Arc::new(Grid::try_new(thin.extent(), 8, 8).unwrap());
    if let Ok(it) = Interpolator::try_new(&thin, g.clone(), Method::NaturalNeighbour, Outside::Nan, 2.0, 0.0) {
        for p in 0..g.len() {
            let s: f64 = it.table().row(p).map(|(_, w)| w).sum();
            assert!(it.table().row(p).count() == 0 || (s - 1.0).abs() < 1e-9);
        }
    }
}

#[test]
fn stage_checks_input_and_stamps_span() {
    let l = Layout::biotac_sp();
    let cfg = InterpolateConfig::default();
    let mut st = Interpolate::<TaxelFrame>::try_new(&cfg, &l).unwrap();
    let mut out = Vec::new();
    st.push(TaxelFrame::new("ff".into(), Timestamp(5), 7, vec![1.0; 24]), &mut out).unwrap();
    assert_eq!(out[0].values.dim(), (64, 64));
    assert_eq!((out[0].start, out[0].end, out[0].seq), (Timestamp(5), Timestamp(5), 7));
    let e = st.push(TaxelFrame::new("ff".into(), Timestamp(6), 8, vec![1.0; 23]), &mut out).unwrap_err();
    assert!(e.to_string().contains("frame 8: expected 24 taxels, got 23"), "{e}");
    let mut v = vec![0.0; 24];
    v[4] = f64::NAN;
    let e = st.push(TaxelFrame::new("ff".into(), Timestamp(6), 9, v), &mut out).unwrap_err();
    assert!(e.to_string().contains("frame 9 taxel 4"), "{e}");
    let toml_like: InterpolateConfig =
        serde_json::from_str(r#"{"method": "natural_neighbor", "outside": "extend", "grid": {"nx": 32}}"#).unwrap();
    assert_eq!(toml_like.method, Method::NaturalNeighbour);
    assert!(serde_json::from_str::<InterpolateConfig>(r#"{"methd": "linear"}"#).is_err());
}

fn arb_layout() -> impl Strategy<Value = Vec<[f64; 2]>> {
    prop::collection::vec((0.0f64..20.0, 0.0f64..20.0), 3..30).prop_filter_map("valid layout", |v| {
        let p: Vec<[f64; 2]> = v.into_iter().map(|(x, y)| [x, y]).collect();
        let names = (0..p.len()).map(|i| format!("t{i}")).collect();
        Layout::try_new("p", names, p.clone(), None).ok().map(|_| p)
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Inside the hull the weights of every method sum to 1 and are non-negative (natural
    /// neighbour, linear, nearest, inverse distance are all convex combinations); a linear field
    /// is reproduced by natural neighbour and linear.
    #[test]
    fn weights_are_a_partition_of_unity(p in arb_layout(), n in 5usize..24) {
        let l = layout(p.clone());
        let g = Arc::new(Grid::try_new(l.extent(), n, n + 1).unwrap());
        for m in ALL {
            let it = interp(&l, &g, m, Outside::Extend);
            for q in 0..g.len() {
                let mut s = 0.0;
                for (_, w) in it.table().row(q) {
                    prop_assert!(w >= -1e-12, "{:?}: negative weight {}", m, w);
                    s += w;
                }
                prop_assert!((s - 1.0).abs() < 1e-9, "{:?} point {}: Σw = {}", m, q, s);
            }
        }
        let f = |q: [f64; 2]| 2.0 - q[0] + 0.5 * q[1];
        let vals: Vec<f64> = p.iter().map(|&q| f(q)).collect();
        for m in [Method::NaturalNeighbour, Method::Linear] {
            let s = interp(&l, &g, m, Outside::Nan).surface(&vals);
            for j in 0..g.ny() {
                for i in 0..g.nx() {
                    let v = s[[j, i]];
                    if !v.is_nan() {
                        prop_assert!((v - f([g.x(i), g.y(j)])).abs() < 1e-9, "{:?}: {} at ({},{})", m, v, i, j);
                    }
                }
            }
        }
    }

    /// Incremental updates equal fresh sums up to rounding, and refresh bounds the drift.
    #[test]
    fn incremental_matches_full(frames in prop::collection::vec(prop::collection::vec(-3i32..4, 24), 1..40),
                                refresh in 1u32..10) {
        let l = Layout::biotac_sp();
        let base = InterpolateConfig { grid: gradtac_stages::interpolate::GridConfig { nx: 24, ..Default::default() },
                                       ..Default::default() };
        let inc = InterpolateConfig { incremental: true, refresh_every: refresh, ..base.clone() };
        let mut a = Interpolate::<TaxelFrame>::try_new(&base, &l).unwrap();
        let mut b = Interpolate::<TaxelFrame>::try_new(&inc, &l).unwrap();
        for (k, f) in frames.iter().enumerate() {
            let v: Vec<f64> = f.iter().map(|&x| x as f64).collect();
            let fr = TaxelFrame::new("ff".into(), Timestamp(k as i64), k as u64, v);
            let (mut oa, mut ob) = (Vec::new(), Vec::new());
            a.push(fr.clone(), &mut oa).unwrap();
            b.push(fr, &mut ob).unwrap();
            for (x, y) in oa[0].values.iter().zip(ob[0].values.iter()) {
                prop_assert!((x.is_nan() && y.is_nan()) || (x - y).abs() < 1e-12, "{} vs {}", x, y);
            }
        }
    }
}

/// Layouts at extreme scales and far from the origin: weights still sum to 1 and a linear field
/// is reproduced to rounding relative to the coordinates' magnitude.
#[test]
fn extreme_layout_scales_and_offsets() {
    let bt = Layout::biotac_sp();
    // (the largest scale and offset stay within the layout's bound of ±1e6 mm, MAX_COORD_MM)
    for (scale, offset) in [(1e-6, 0.0), (5e4, 0.0), (1.0, 9.9e5), (1e-3, 1e3), (1e-30, 0.0)] {
        let p: Vec<[f64; 2]> = bt.positions().iter().map(|q| [q[0] * scale + offset, q[1] * scale - offset]).collect();
        let l = layout(p.clone());
        // the layout's default extent adds 2 mm, which dwarfs a nanometre layout: grid over
        // the bounding box
        let (xs, ys): (Vec<f64>, Vec<f64>) = p.iter().map(|q| (q[0], q[1])).unzip();
        let mm = |v: &[f64]| v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
        let ((x0, x1), (y0, y1)) = (mm(&xs), mm(&ys));
        let g = Arc::new(Grid::try_new(Extent { x_min: x0, x_max: x1, y_min: y0, y_max: y1 }, 32, 32).unwrap());
        let f = |q: [f64; 2]| 3.0 + (q[0] - offset) / scale - 2.0 * (q[1] + offset) / scale;
        let vals: Vec<f64> = p.iter().map(|&q| f(q)).collect();
        for m in [Method::NaturalNeighbour, Method::Linear] {
            let it = interp(&l, &g, m, Outside::Nan);
            let s = it.surface(&vals);
            // rounding of the coordinates (|offset| + extent·scale)·ε, amplified by the field's
            // gradient 1/scale
            let tol = 1e-9 * (1.0 + offset.abs() / scale);
            let mut inside = 0;
            for j in 0..32 {
                for i in 0..32 {
                    let v = s[[j, i]];
                    if !v.is_nan() {
                        inside += 1;
                        let e = (v - f([g.x(i), g.y(j)])).abs();
                        assert!(e <= tol, "{m:?} scale {scale:e} offset {offset:e}: error {e:e} > {tol:e}");
                    }
                }
            }
            assert!(inside > 300, "{m:?} scale {scale:e}: {inside} points inside");
        }
    }
}
