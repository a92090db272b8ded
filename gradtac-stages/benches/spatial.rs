//! Benchmarks of the spatial stages (window, interpolate, contour, track).
//!
//! `cargo bench -p gradtac-stages --bench spatial`
//!
//! - `surface/<method>/<n>`: one surface of an n×n grid from 24 BioTac SP taxel values (a
//!   sparse weighted sum over the precomputed weight table), per frame.
//! - `spade_direct/<method>/64`: the same 64×64 surface evaluated point by point with spade
//!   (locate + weights every frame): the baseline the weight table replaces.
//! - `build/<method>/64`: building the weight table once (per layout, grid and method).
//! - `contour64/<mode>`: the maximal contour of a 64×64 natural-neighbour event surface,
//!   marching the peak region only or the whole grid.
//! - `pipeline64/<variant>`: window (sliding, 10 frames, advanced every frame) → natural
//!   neighbour 64×64 → maximal contour → track, per input frame, on a synthetic contact moving
//!   over the sensor (≈ 10 events per frame); `fresh+whole` sums every surface afresh and marches
//!   the whole grid, `incremental+peak` updates the surface from the changed taxels and marches
//!   around the peak only.
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use gradtac_stages::contour::{ContourConfig, MaxContourFinder};
use gradtac_stages::interpolate::{Grid, Interpolate, InterpolateConfig, Interpolator, Method, Outside};
use gradtac_stages::track::{Track, TrackConfig};
use gradtac_stages::window::{Window, WindowConfig};
use gradtac_stages::{contour::Contour, EventBatch, TactileEvent};
use gradtac_stream::{Layout, Stage, StageExt, Timestamp};
use spade::{DelaunayTriangulation, FloatTriangulation, Point2, Triangulation};
use std::hint::black_box;
use std::sync::Arc;

const FRAME_NS: i64 = 10_000_000;

/// Event templates for one lap of a contact moving back and forth over the sensor: per frame,
/// `round(4·exp(−d²/2σ²))` positive events per taxel (σ = 3 mm), times relative to the frame start.
fn templates(l: &Layout, frames: usize) -> Vec<Vec<TactileEvent>> {
    (0..frames)
        .map(|k| {
            let phase = (k as f64 / frames as f64) * std::f64::consts::TAU;
            let c = [8.0 * phase.sin(), 3.0 * (2.0 * phase).sin()];
            let mut ev = Vec::new();
            for (i, p) in l.positions().iter().enumerate() {
                let d2 = (p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2);
                let n = (4.0 * (-d2 / 18.0).exp()).round() as i64;
                for j in 0..n {
                    ev.push(TactileEvent {
                        time: Timestamp((j + 1) * FRAME_NS / (n + 1)),
                        taxel: i as u16,
                        polarity: 1,
                    });
                }
            }
            ev.sort_by_key(|e| (e.time, e.taxel));
            ev
        })
        .collect()
}

fn batch(t: &[Vec<TactileEvent>], k: u64) -> EventBatch {
    let start = k as i64 * FRAME_NS;
    let events = t[k as usize % t.len()]
        .iter()
        .map(|e| TactileEvent { time: Timestamp(start + e.time.as_nanos()), ..*e })
        .collect();
    EventBatch { sensor: "ff".into(), time: Timestamp(start + FRAME_NS), seq: k, taxels: 24, events }
}

fn surfaces(c: &mut Criterion) {
    let l = Layout::biotac_sp();
    let vals: Vec<f64> = (0..24).map(|i| ((i * 7) % 5) as f64).collect();
    let mut g = c.benchmark_group("surface");
    g.throughput(Throughput::Elements(1));
    for n in [16, 32, 64, 128] {
        let grid = Arc::new(Grid::try_new(l.extent(), n, n).unwrap());
        for m in [Method::NaturalNeighbour, Method::Linear, Method::Nearest, Method::InverseDistance] {
            let it = Interpolator::try_new(&l, grid.clone(), m, Outside::Nan, 2.0, 0.0).unwrap();
            let mut out = vec![0.0; n * n];
            g.bench_with_input(BenchmarkId::new(format!("{m:?}"), n), &n, |b, _| {
                b.iter(|| it.surface_into(black_box(&vals), &mut out))
            });
        }
    }
    g.finish();
    // the same surface straight from spade, without the weight table (the baseline it replaces)
    let mut g = c.benchmark_group("spade_direct");
    g.throughput(Throughput::Elements(1));
    let mut tri: DelaunayTriangulation<Point2<f64>> = DelaunayTriangulation::new();
    for p in l.positions() {
        tri.insert(Point2::new(p[0], p[1])).unwrap();
    }
    let grid = Grid::try_new(l.extent(), 64, 64).unwrap();
    let value = |v: spade::handles::VertexHandle<'_, Point2<f64>>| vals[v.fix().index()];
    let nn = tri.natural_neighbor();
    let mut out = vec![0.0; 64 * 64];
    // same values as the weight table (checked once, outside the timing)
    let table = Interpolator::try_new(&l, Arc::new(grid.clone()), Method::NaturalNeighbour, Outside::Nan, 2.0, 0.0)
        .unwrap()
        .surface(&vals);
    for j in 0..64 {
        for i in 0..64 {
            let d = nn.interpolate(value, Point2::new(grid.x(i), grid.y(j))).unwrap_or(f64::NAN);
            let t = table[[j, i]];
            assert!((d.is_nan() && t.is_nan()) || (d - t).abs() < 1e-12, "({i},{j}): {d} vs {t}");
        }
    }
    g.bench_function(BenchmarkId::new("NaturalNeighbour", 64), |b| {
        b.iter(|| {
            for j in 0..64 {
                for i in 0..64 {
                    out[j * 64 + i] = nn.interpolate(value, Point2::new(grid.x(i), grid.y(j))).unwrap_or(f64::NAN);
                }
            }
            black_box(&out);
        })
    });
    let bary = tri.barycentric();
    g.bench_function(BenchmarkId::new("Linear", 64), |b| {
        b.iter(|| {
            for j in 0..64 {
                for i in 0..64 {
                    out[j * 64 + i] = bary.interpolate(value, Point2::new(grid.x(i), grid.y(j))).unwrap_or(f64::NAN);
                }
            }
            black_box(&out);
        })
    });
    g.finish();
    let mut g = c.benchmark_group("build");
    let grid = Arc::new(Grid::try_new(l.extent(), 64, 64).unwrap());
    for m in [Method::NaturalNeighbour, Method::Linear, Method::Nearest, Method::InverseDistance] {
        g.bench_function(BenchmarkId::new(format!("{m:?}"), 64), |b| {
            b.iter(|| Interpolator::try_new(&l, grid.clone(), m, Outside::Nan, 2.0, 0.0).unwrap())
        });
    }
    g.finish();
}

fn contours(c: &mut Criterion) {
    let l = Layout::biotac_sp();
    let t = templates(&l, 200);
    let mut w = Window::try_new(&WindowConfig { frames: Some(10), ..Default::default() }).unwrap();
    let mut aggs = Vec::new();
    for k in 0..60 {
        w.push(batch(&t, k), &mut aggs).unwrap();
    }
    let grid = Arc::new(Grid::try_new(l.extent(), 64, 64).unwrap());
    let it = Interpolator::try_new(&l, grid.clone(), Method::NaturalNeighbour, Outside::Nan, 2.0, 0.0).unwrap();
    let z = it.surface(&aggs.last().unwrap().values);
    let mut g = c.benchmark_group("contour64");
    g.throughput(Throughput::Elements(1));
    for (name, peak_only) in [("peak_only", true), ("whole_grid", false)] {
        let mut f = MaxContourFinder::try_new(&ContourConfig { peak_only, ..Default::default() }).unwrap();
        assert!(f.find(z.view(), &grid).contact().is_some());
        g.bench_function(name, |b| b.iter(|| f.find(black_box(z.view()), &grid)));
    }
    g.finish();
}

fn pipeline(c: &mut Criterion) {
    let l = Layout::biotac_sp();
    let t = templates(&l, 200);
    let mut g = c.benchmark_group("pipeline64");
    g.throughput(Throughput::Elements(1));
    for (name, incremental, peak_only) in [
        ("fresh+whole", false, false),
        ("fresh+peak", false, true),
        ("incremental+whole", true, false),
        ("incremental+peak", true, true),
    ] {
        let w = Window::try_new(&WindowConfig { frames: Some(10), ..Default::default() }).unwrap();
        let icfg = InterpolateConfig { method: Method::NaturalNeighbour, incremental, ..Default::default() };
        let i = Interpolate::try_new(&icfg, &l).unwrap();
        let cc = Contour::try_new(&ContourConfig { peak_only, ..Default::default() }).unwrap();
        let tr = Track::try_new(&TrackConfig::default()).unwrap();
        let mut chain = w.then(i).then(cc).then(tr);
        let mut k = 0u64;
        let mut out = Vec::new();
        g.bench_function(name, |b| {
            b.iter(|| {
                out.clear();
                chain.push(batch(&t, k), &mut out).unwrap();
                k += 1;
                black_box(&out);
            })
        });
    }
    g.finish();
}

criterion_group!(group, surfaces, contours, pipeline);
criterion_main!(group);
