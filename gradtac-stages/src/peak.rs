//! The surface and the maximal contour fused: the maximal contour of an interpolated surface
//! without a surface array per frame (method.md, stages 5–6 fused).
//!
//! # What it does
//! [`SurfaceContour`] takes per-taxel values (a window aggregate) and returns the same
//! [`ContourFrame`] as [`Interpolate`](crate::interpolate::Interpolate) →
//! [`Contour`](crate::contour::Contour), **bit for bit** (tested), without allocating a
//! [`Surface`](crate::interpolate::Surface) per frame. The scene chain runs it whenever no
//! output taps the surface. Two evaluations, identical outcomes:
//!
//! - **Dense** (default): the whole surface into a buffer kept between frames, by the weight
//!   table's column runs with zero taxels skipped
//!   ([`WeightTable::apply_again`](crate::interpolate::WeightTable::apply_again)), then
//!   [`MaxContourFinder::find_slice`]'s search (its scan for peak and minimum reads only the
//!   8-point chunks that hold a point with weights when the fill is NaN). First, a rigorous
//!   upper bound of the whole surface (the largest taxel value widened by the rounding slack
//!   below, and the fill value) settles a window whose bound is under `min_peak` as "below min
//!   peak" without summing the grid — a window without events costs `O(taxels)`.
//! - **Peak-local** ([`SurfaceContour::with_peak_local`]): the maximal contour needs the
//!   surface's peak (first in raster order), its finite minimum (for counted levels) and the
//!   values in and around the peak's region — not all `nx·ny` points. Grid points are
//!   evaluated only on demand:
//!
//!   1. The grid is cut into blocks (8 × 8 points on a 64 × 64 grid; a power of two a side).
//!      For each block the [`PeakIndex`] (built once per interpolator) holds the union of the
//!      taxels its points' weights use. Interpolation weights are convex (non-negative,
//!      summing to 1 for natural neighbour, linear, nearest, inverse distance and the hull
//!      extension), so every value in a block lies within `[min, max]` of those taxels'
//!      values, widened by a rigorous rounding slack (`ε·max|v|` with `ε` from the table's
//!      worst weight-sum error and row length; exact 0 when all taxels are ≥ 0 or ≤ 0 on that
//!      side).
//!   2. The peak: evaluate the block with the highest upper bound, then only blocks whose
//!      upper bound reaches the best value found (`≥`, so ties in raster order are resolved
//!      exactly). The minimum likewise from below. A peak bound under `min_peak` ends the
//!      frame without evaluating anything.
//!   3. The region search and marching squares read values through a cache that evaluates a
//!      block the first time one of its points is read (at most once per frame) — with the
//!      same summation order as the full grid, so every value is bit-identical.
//!
//!   Inputs with `max|v| > 1e300`, or tables with negative weights beyond rounding, fall back
//!   to evaluating every point (identical results, full cost).
//!
//! `incremental` (an [`InterpolateConfig`] setting of the tapped surface) does not apply: the
//! fused stage always sums afresh, so its contours are those of `incremental = false`
//! (incremental surfaces differ from fresh sums by ≤ 1e-12 relative).
//!
//! # Delay
//! None: one [`ContourFrame`] per input.
//!
//! # Trade-offs
//! Per window of the dense stress chain (fixed event τ = 0.05, the events' default before it
//! became the measured 4 σ; signed 10-frame windows, natural neighbour 64 × 64, 10 levels, min
//! area 1 mm²) on a real BioTacSP-DoS recording tiled 10 times (2,790 windows, 2,759 with
//! contact): instructions per raw frame of the whole chain (raw frame → track
//! point) from `valgrind --tool=callgrind` on
//! `cargo run --release -p gradtac-stages --example chain_cost -- <variant>_dense <1|2>` (the
//! difference of 2 and 1 repeats, so set-up cancels; repeatable to the instruction), and
//! criterion medians of `cargo bench -p gradtac-stages --bench chain` (2-core machine shared
//! with other builds: wall times are noisy, the instruction counts are not).
//!
//! | variant | real: instructions / frame | real: criterion median (2,790 frames) | simulated grasp: instructions / frame |
//! |---|---|---|---|
//! | fused, dense (default, what a scene runs) | **127 k** | 25.2 ms (111 k frames/s) | **114 k** |
//! | the same before the peak scan skipped NaN chunks and found the peak's index by lanes, and rings were allocated once | 136 k | 29.1 / 29.0 ms (96 k frames/s) | 122 k |
//! | fused, peak-local (≈ 2,100 of 4,096 points evaluated: the row masks read whole rows) | 257 k | — | — |
//! | `Interpolate` → `Contour` (a surface array per window, what a scene runs when the surface is tapped) | 166 k | — | 152 k |
//! | before the row masks (component by runs, window copied for marching): fused, dense | 166 k | 35.5 / 36.4 ms (79 k / 77 k frames/s) | 125 k |
//! | before the row masks: peak-local (≈ 1,600 points evaluated) | 271 k | — | — |
//! | before the row masks: `Interpolate` → `Contour` | 196 k | — | 155 k |
//! | before any of these speed-ups (row sums, a flood, march and link per level): `Interpolate` → `Contour` | 465 k | 83.0 / 125.1 ms (34 k / 22 k frames/s) | 301 k |
//!
//! The front end (normalise → Savitzky–Golay → events → window) and the track are ≈ 19 k of
//! these instructions per frame on the real recording; the dense surface (column runs, zero
//! taxels skipped) ≈ 42 k; the scan for peak and minimum ≈ 14 k (only the 8-point chunks
//! inside the hull, the peak's index looked for in its lane alone);
//! the region search, marching, linking and measuring ≈ 51 k (≈ 900 points at the accepted
//! level, 1.35 levels tried per window on average; 104 k for the whole maximal contour before
//! the row masks). Criterion medians of the fused dense chain: two runs each, old and new
//! binaries alternating, load average ≈ 3–4.5 (simulated grasp, 200 frames: 2.18 / 1.97 ms
//! before, 2.01 / 1.76 ms after). Earlier medians of the other rows (before the row masks,
//! alternating runs at load 2.5–4): peak-local 89.0 / 98.1 ms, `Interpolate` → `Contour`
//! 57.2 / 54.8 ms. The `digest` variant of `chain_cost` fingerprints every track point and
//! contour outcome: identical before and after the row masks, real and simulated.
//!
//! On contact data the dense evaluation wins: the block bounds cost more than the points they
//! skip, because the maximal contour's region covers a large part of the grid (≈ 900 points
//! at the accepted level). Peak-local pays off only where most frames have no contact (a
//! peak bound under `min_peak` settles the frame with no point evaluated) or tiny regions.

use crate::contour::{ContourConfig, ContourFrame, ContourOutcome, Field, MaxContourFinder, NoContact};
use crate::interpolate::{Grid, InterpolateConfig, Interpolator, TaxelValues, WeightTable};
use crate::{Error, Result};
use gradtac_stream::{Delay, Layout, Stage};

const STAGE: &str = "interpolate";

/// Values beyond this magnitude take the full-grid path (no overflow reasoning needed).
const MAX_LAZY: f64 = 1e300;

/// Per-block taxel supports of a weight table on its grid (see the [module docs](self)).
#[derive(Clone, Debug)]
pub struct PeakIndex {
    nx: usize,
    ny: usize,
    bs: usize,
    shift: u32,
    nbx: usize,
    starts: Vec<u32>,
    support: Vec<u16>,
    // block holds a point with an empty row (fill value / NaN)
    has_empty: Vec<bool>,
    // block holds a point with a non-empty row
    has_row: Vec<bool>,
    // rigorous relative slack of Σ w·v against [min v, max v] of a row's taxels
    eps: f64,
    // all weights ≥ 0: a row over taxels ≥ 0 sums to ≥ 0 exactly
    nonneg: bool,
    fill: f64,
    // dense [block × taxel] largest weight of the taxel at any point of the block (0: not in
    // the support); empty when too large or when weights can be negative
    wmax: Vec<f64>,
    n_taxels: usize,
    // some block holds a point with a non-empty row / with an empty row
    any_row: bool,
    any_empty: bool,
}

/// Largest dense `blocks × taxels` table of per-block weight maxima kept.
const MAX_WMAX: usize = 1 << 20;

impl PeakIndex {
    /// Index `table` laid out on `grid` (row-major, `grid.len()` points).
    pub fn new(table: &WeightTable, grid: &Grid) -> Self {
        let (nx, ny) = (grid.nx(), grid.ny());
        debug_assert_eq!(table.points(), nx * ny);
        // about 8 × 8 blocks whatever the grid (at least 4 points a side)
        let bs = (nx.max(ny) / 8).clamp(4, 64).next_power_of_two();
        let shift = bs.trailing_zeros();
        let (nbx, nby) = (nx.div_ceil(bs), ny.div_ceil(bs));
        let mut starts = vec![0u32];
        let mut support = Vec::new();
        let mut has_empty = Vec::with_capacity(nbx * nby);
        let mut has_row = Vec::with_capacity(nbx * nby);
        let n_taxels = table.taxels();
        let mut seen = vec![false; n_taxels];
        let dense = nbx * nby * n_taxels <= MAX_WMAX;
        let mut wmax: Vec<f64> = if dense { vec![0.0; nbx * nby * n_taxels] } else { Vec::new() };
        let (mut delta, mut max_len, mut nonneg) = (0.0f64, 0usize, true);
        for by in 0..nby {
            for bx in 0..nbx {
                let (mut empty, mut row) = (false, false);
                let first = support.len();
                for r in by * bs..((by + 1) * bs).min(ny) {
                    for c in bx * bs..((bx + 1) * bs).min(nx) {
                        let (ks, ws) = table.row_parts(r * nx + c);
                        if ks.is_empty() {
                            empty = true;
                            continue;
                        }
                        row = true;
                        max_len = max_len.max(ks.len());
                        let (mut sum, mut neg) = (0.0, 0.0);
                        for (&k, &w) in ks.iter().zip(ws) {
                            if !seen[k as usize] {
                                seen[k as usize] = true;
                                support.push(k);
                            }
                            if w < 0.0 {
                                neg -= w;
                                nonneg = false;
                            }
                            if dense {
                                let b = by * nbx + bx;
                                let m = &mut wmax[b * n_taxels + k as usize];
                                *m = m.max(w);
                            }
                            sum += w;
                        }
                        // |Σw − 1| (plus twice the negative mass: Σ w·v ≤ max v + M·that)
                        delta = delta.max((sum - 1.0).abs() + 2.0 * neg);
                    }
                }
                for &k in &support[first..] {
                    seen[k as usize] = false;
                }
                starts.push(support.len() as u32);
                has_empty.push(empty);
                has_row.push(row);
            }
        }
        // Σ w·v rounded (n terms): |fl − exact| ≤ γ_n Σ|w v| ≤ γ_n (1 + δ) M, γ_n ≈ n·2⁻⁵³;
        // the sum of weights itself was computed with a similar error. A factor 4 of margin.
        let max_support = starts.windows(2).map(|w| (w[1] - w[0]) as usize).max().unwrap_or(0);
        let gamma = (max_len.max(max_support) as f64 + 2.0) * f64::EPSILON;
        let eps = 4.0 * (delta + gamma * (1.0 + delta) + gamma);
        if !nonneg {
            wmax = Vec::new();
        }
        let (any_row, any_empty) = (has_row.iter().any(|&r| r), has_empty.iter().any(|&e| e));
        PeakIndex {
            nx,
            ny,
            bs,
            shift,
            nbx,
            starts,
            support,
            has_empty,
            has_row,
            eps,
            nonneg,
            fill: table.fill(),
            wmax,
            n_taxels,
            any_row,
            any_empty,
        }
    }

    /// Number of blocks.
    pub fn blocks(&self) -> usize {
        self.has_row.len()
    }

    /// The relative rounding slack `ε` of the block bounds.
    pub fn slack(&self) -> f64 {
        self.eps
    }

    /// One side of block `b`'s weighted (fractional-knapsack) bound: every value `Σ w_k v_k`
    /// (`0 ≤ w_k ≤ ŵ_k`, `Σ w_k = 1`) is at most (`upper`) / at least the optimum of filling
    /// weight into the largest (smallest) values first, widened by `slack` (`ε·max|v|`).
    /// Without weight maxima, `±∞` (no information beyond the plain bound).
    fn side(&self, b: usize, v: &[f64], order: &[u16], upper: bool, slack: f64) -> f64 {
        if self.wmax.is_empty() || !self.has_row[b] {
            return if upper { f64::INFINITY } else { f64::NEG_INFINITY };
        }
        let w = &self.wmax[b * self.n_taxels..(b + 1) * self.n_taxels];
        let mut x = if upper {
            let (first, k) = knapsack(w, v, order.iter().rev());
            let mut x = k.min(first) + slack;
            if first <= 0.0 {
                x = x.min(0.0); // nonneg weights (wmax exists only then): all terms ≤ 0
            }
            x
        } else {
            let (first, k) = knapsack(w, v, order.iter());
            let mut x = k.max(first) - slack;
            if first >= 0.0 {
                x = x.max(0.0);
            }
            x
        };
        if self.has_empty[b] && !self.fill.is_nan() {
            x = if upper { x.max(self.fill) } else { x.min(self.fill) };
        }
        x
    }

    /// Bounds `[lo, hi]` of every value in block `b` for taxel values `v` (`order`: the taxels
    /// by ascending value; `None`: the plain `[min, max]` bound), or `None` when the block has no
    /// finite value at all (only NaN fill).
    ///
    /// With the per-block weight maxima `ŵ_k`, every point's value `Σ w_k v_k` (`0 ≤ w_k ≤ ŵ_k`,
    /// `Σ w_k = 1`) is at most the fractional-knapsack optimum: fill weight into the largest
    /// values first. Without them, `[min, max]` of the support's values.
    fn bounds(&self, b: usize, v: &[f64], order: Option<&[u16]>) -> Option<(f64, f64)> {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        if self.has_row[b] {
            let (a, m, klo, khi) = if let (false, Some(order)) = (self.wmax.is_empty(), order) {
                let w = &self.wmax[b * self.n_taxels..(b + 1) * self.n_taxels];
                let (m, hi_k) = knapsack(w, v, order.iter().rev());
                let (a, lo_k) = knapsack(w, v, order.iter());
                (a, m, lo_k, hi_k)
            } else {
                let (mut a, mut m) = (f64::INFINITY, f64::NEG_INFINITY);
                for &k in &self.support[self.starts[b] as usize..self.starts[b + 1] as usize] {
                    let x = v[k as usize];
                    a = if x < a { x } else { a };
                    m = if x > m { x } else { m };
                }
                (a, m, a, m)
            };
            let slack = self.eps * a.abs().max(m.abs());
            lo = klo.max(a) - slack;
            hi = khi.min(m) + slack;
            if self.nonneg {
                if a >= 0.0 {
                    lo = lo.max(0.0);
                }
                if m <= 0.0 {
                    hi = hi.min(0.0);
                }
            }
        }
        if self.has_empty[b] && !self.fill.is_nan() {
            lo = lo.min(self.fill);
            hi = hi.max(self.fill);
        }
        (lo <= hi).then_some((lo, hi))
    }
}

/// The fractional-knapsack bound: weight (at most `w[k]` each, `Σ = 1`) filled into the taxels
/// in the order given; returns `(first value met = the support's extreme, bound)`.
#[inline]
fn knapsack<'a>(w: &[f64], v: &[f64], order: impl Iterator<Item = &'a u16>) -> (f64, f64) {
    let (mut acc, mut sum, mut first) = (0.0f64, 0.0f64, f64::NAN);
    for &k in order {
        let wk = w[k as usize];
        if wk == 0.0 {
            continue;
        }
        let x = v[k as usize];
        if first.is_nan() {
            first = x;
        }
        let t = wk.min(1.0 - acc);
        sum += t * x;
        acc += t;
        if acc >= 1.0 {
            return (first, sum);
        }
    }
    // weight left over by rounding: put it on the extreme value (conservative)
    (first, sum + (1.0 - acc) * first)
}

/// One frame's surface evaluated on demand: a cache of the points computed so far.
#[derive(Clone, Debug, Default)]
struct LazyCache {
    z: Vec<f64>,
    block_done: Vec<u32>,
    gen: u32,
    evaluated: u64,
}

impl LazyCache {
    fn start(&mut self, points: usize, blocks: usize) {
        if self.z.len() != points || self.block_done.len() != blocks {
            self.z = vec![0.0; points];
            self.block_done = vec![0; blocks];
            self.gen = 0;
        }
        self.gen = self.gen.wrapping_add(1);
        if self.gen == 0 {
            self.block_done.iter_mut().for_each(|s| *s = 0);
            self.gen = 1;
        }
    }
}

/// A [`Field`] over a weight table and one set of taxel values, evaluating points on demand.
struct Lazy<'a> {
    table: &'a WeightTable,
    index: &'a PeakIndex,
    v: &'a [f64],
    cache: &'a mut LazyCache,
}

impl Lazy<'_> {
    /// Evaluate every point of block `b` (rows of contiguous points, the same sums as the
    /// full grid).
    #[cold]
    fn eval_block(&mut self, b: usize) {
        let ix = self.index;
        self.cache.block_done[b] = self.cache.gen;
        let (by, bx) = (b / ix.nbx, b % ix.nbx);
        let (c0, c1) = (bx * ix.bs, ((bx + 1) * ix.bs).min(ix.nx));
        for r in by * ix.bs..((by + 1) * ix.bs).min(ix.ny) {
            for p in r * ix.nx + c0..r * ix.nx + c1 {
                self.cache.z[p] = self.table.value_at(p, self.v);
            }
            self.cache.evaluated += (c1 - c0) as u64;
        }
    }

    /// Evaluate block `b` (once per frame) and fold its values into the running peak / min.
    fn block(&mut self, b: usize, best: &mut (f64, usize), min: &mut f64) {
        if self.cache.block_done[b] == self.cache.gen {
            return;
        }
        self.eval_block(b);
        let ix = self.index;
        let (by, bx) = (b / ix.nbx, b % ix.nbx);
        let (c0, c1) = (bx * ix.bs, ((bx + 1) * ix.bs).min(ix.nx));
        for r in by * ix.bs..((by + 1) * ix.bs).min(ix.ny) {
            for p in r * ix.nx + c0..r * ix.nx + c1 {
                let x = self.cache.z[p];
                if x > best.0 || (x == best.0 && p < best.1) {
                    *best = (x, p);
                }
                *min = if x < *min { x } else { *min };
            }
        }
    }

    /// The finite maximum (first in raster order; index `usize::MAX` if none) and minimum,
    /// given every block's bounds (`lo > hi`: no finite value).
    fn extremes(&mut self, bounds: &[(f64, f64)], order: &[u16]) -> (f64, usize, f64) {
        let mut best = (f64::NEG_INFINITY, usize::MAX);
        let mut min = f64::INFINITY;
        let (mut top, mut bottom) = ((f64::NEG_INFINITY, usize::MAX), ((f64::INFINITY, f64::INFINITY), usize::MAX));
        for (b, &bd) in bounds.iter().enumerate() {
            if bd.0 > bd.1 {
                continue;
            }
            if bd.1 > top.0 {
                top = (bd.1, b);
            }
            // the lowest lower bound, then the lowest upper bound (an all-zero block first)
            if bd.0 < bottom.0 .0 || (bd.0 == bottom.0 .0 && bd.1 < bottom.0 .1) {
                bottom = (bd, b);
            }
        }
        if top.1 == usize::MAX {
            return (best.0, best.1, min); // no block has a finite value
        }
        self.block(top.1, &mut best, &mut min);
        self.block(bottom.1, &mut best, &mut min);
        let m = self.v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let slack = self.index.eps * m;
        for (b, &(lo, hi)) in bounds.iter().enumerate() {
            if lo > hi {
                continue;
            }
            // the plain bound first, the weighted (knapsack) one only where the plain one
            // does not settle it; each side only where it matters
            let need_hi = hi >= best.0 && self.index.side(b, self.v, order, true, slack) >= best.0;
            if need_hi || (lo < min && self.index.side(b, self.v, order, false, slack) < min) {
                // the block can hold a better (or an equal, earlier) peak, or a lower minimum
                self.block(b, &mut best, &mut min);
            }
        }
        (best.0, best.1, min)
    }
}

impl Field for Lazy<'_> {
    #[inline(always)]
    fn dim(&self) -> (usize, usize) {
        (self.index.ny, self.index.nx)
    }
    #[inline(always)]
    fn prepare(&mut self, r0: usize, r1: usize, c0: usize, c1: usize) {
        let ix = self.index;
        for br in r0 >> ix.shift..=r1 >> ix.shift {
            for bc in c0 >> ix.shift..=c1 >> ix.shift {
                let b = br * ix.nbx + bc;
                if self.cache.block_done[b] != self.cache.gen {
                    self.eval_block(b);
                }
            }
        }
    }
    #[inline(always)]
    fn raw(&self, r: usize, c: usize) -> f64 {
        self.cache.z[r * self.index.nx + c]
    }
}

/// The maximal contour of an interpolated surface, evaluating only the grid points it needs
/// (see the [module docs](self)). Holds its caches; reuse one per sensor.
#[derive(Clone, Debug)]
pub struct PeakContourFinder {
    interp: Interpolator,
    finder: MaxContourFinder,
    cache: LazyCache,
    bounds: Vec<(f64, f64)>,
    order: Vec<u16>,
    full: u64,
    // the whole surface, reused (the dense evaluation)
    dense: Vec<f64>,
    peak_local: bool,
}

impl PeakContourFinder {
    /// A finder for surfaces of `interp` with the contour settings of `finder`.
    pub fn new(interp: Interpolator, finder: MaxContourFinder) -> Self {
        PeakContourFinder {
            interp,
            finder,
            cache: LazyCache::default(),
            bounds: Vec::new(),
            order: Vec::new(),
            full: 0,
            dense: Vec::new(),
            peak_local: false,
        }
    }

    /// Evaluate only the blocks of grid points the maximal contour reads (`true`), or the
    /// whole surface into a reused buffer (`false`, the default: faster on contact data, see
    /// the [module docs](self)). Both give identical outcomes.
    pub fn with_peak_local(mut self, peak_local: bool) -> Self {
        self.peak_local = peak_local;
        self
    }

    /// The interpolator.
    pub fn interpolator(&self) -> &Interpolator {
        &self.interp
    }

    /// Grid points evaluated so far (a measure of the work saved against `frames·nx·ny`).
    pub fn points_evaluated(&self) -> u64 {
        self.full + self.cache.evaluated
    }

    /// The maximal contour of the surface of taxel values `v` (one per taxel, finite) — the
    /// same outcome as [`MaxContourFinder::find`] on
    /// [`Interpolator::surface`]`(v)`.
    ///
    /// # Panics
    /// If `v.len()` is not the layout's taxel count ([`SurfaceContour`] checks and errs).
    pub fn find(&mut self, v: &[f64]) -> ContourOutcome {
        let table = self.interp.table().clone();
        assert_eq!(v.len(), table.taxels(), "one value per taxel");
        let grid = self.interp.grid().clone();
        if !self.peak_local {
            if let Some(outcome) = self.below_min_peak(v) {
                return outcome;
            }
            if self.dense.len() == grid.len() {
                table.apply_again(v, &mut self.dense);
            } else {
                self.dense.resize(grid.len(), 0.0);
                table.apply(v, &mut self.dense);
            }
            self.full += grid.len() as u64;
            // points without weights hold the fill: with NaN there, the peak scan skips them
            return self.finder.find_slice_in(&self.dense, table.finite_chunks(), &grid);
        }
        let index = self.interp.peak_index();
        let big = v.iter().any(|x| x.is_nan() || x.abs() > MAX_LAZY);
        let outcome = if big || index.eps.is_nan() || index.eps >= 1e-6 {
            // full grid: bit-identical by construction
            let mut z = vec![0.0; grid.len()];
            table.apply(v, &mut z);
            self.full += z.len() as u64;
            let view = ndarray::ArrayView2::from_shape((grid.ny(), grid.nx()), &z).expect("grid shape");
            self.finder.find(view, &grid)
        } else {
            self.cache.start(grid.len(), index.blocks());
            let (any, hi) = all_bounds(index, v, &mut self.order, &mut self.bounds);
            if !any {
                ContourOutcome::NoContact(NoContact::NoData)
            } else if hi < self.finder.config().min_peak {
                ContourOutcome::NoContact(NoContact::BelowMinPeak)
            } else {
                let mut lazy = Lazy { table: &table, index, v, cache: &mut self.cache };
                let (zmax, at, zmin) = lazy.extremes(&self.bounds, &self.order);
                self.finder.find_in(&mut lazy, &grid, zmax, zmin, at)
            }
        };
        outcome
    }

    /// `Some(BelowMinPeak)` when a rigorous upper bound of every surface value is under
    /// `min_peak`: the full grid's outcome, settled without evaluating it. The bound is the
    /// largest taxel value widened by the table's rounding slack (`ε·max|v|`, clamped to 0 when
    /// every value is ≤ 0 and the weights are non-negative), and the fill value where points
    /// have no weights — the union of the block bounds of the peak-local evaluation, so just as
    /// rigorous. `O(taxels)`; a window without events (all zeros) costs no grid sum. `None`
    /// (evaluate) for values beyond `±1e300`, a table without any weighted point, or one whose
    /// weights are not convex within rounding.
    fn below_min_peak(&self, v: &[f64]) -> Option<ContourOutcome> {
        let index = self.interp.peak_index();
        if !index.any_row || index.eps.is_nan() || index.eps >= 1e-6 {
            return None;
        }
        let (mut a, mut m) = (f64::INFINITY, f64::NEG_INFINITY);
        for &x in v {
            if x.is_nan() || x.abs() > MAX_LAZY {
                return None;
            }
            a = if x < a { x } else { a };
            m = if x > m { x } else { m };
        }
        let mut hi = m + index.eps * a.abs().max(m.abs());
        if index.nonneg && m <= 0.0 {
            hi = hi.min(0.0);
        }
        if index.any_empty && !index.fill.is_nan() {
            if !index.fill.is_finite() {
                return None;
            }
            hi = hi.max(index.fill);
        }
        (hi < self.finder.config().min_peak).then_some(ContourOutcome::NoContact(NoContact::BelowMinPeak))
    }

    /// Forget the previous frame (a discontinuity): nothing is carried between frames.
    pub fn reset(&mut self) {}
}

/// Every block's bounds into `bounds` (`(+∞, −∞)` for a block without finite values); returns
/// whether any block has a finite value and the largest upper bound.
fn all_bounds(index: &PeakIndex, v: &[f64], order: &mut Vec<u16>, bounds: &mut Vec<(f64, f64)>) -> (bool, f64) {
    order.clear();
    order.extend(0..v.len() as u16);
    order.sort_unstable_by(|&a, &b| v[a as usize].total_cmp(&v[b as usize]));
    bounds.clear();
    let (mut any, mut hi) = (false, f64::NEG_INFINITY);
    for b in 0..index.blocks() {
        match index.bounds(b, v, None) {
            Some(bd) => {
                any = true;
                hi = hi.max(bd.1);
                bounds.push(bd);
            }
            None => bounds.push((f64::INFINITY, f64::NEG_INFINITY)),
        }
    }
    (any, hi)
}

/// The interpolate → contour stages fused, evaluating only what the maximal contour needs: one
/// [`ContourFrame`] per input, identical to `Interpolate` → `Contour` (see the
/// [module docs](self)).
#[derive(Clone, Debug)]
#[must_use = "a stage does nothing until inputs are pushed"]
pub struct SurfaceContour<I = crate::window::WindowAggregate> {
    finder: PeakContourFinder,
    _in: std::marker::PhantomData<fn(I)>,
}

impl<I> SurfaceContour<I> {
    /// The fused stage for a layout; fails where `Interpolate::try_new` or `Contour::try_new`
    /// would.
    pub fn try_new(surface: &InterpolateConfig, contour: &ContourConfig, layout: &Layout) -> Result<Self> {
        if surface.refresh_every == 0 {
            return Err(Error::InvalidConfig { stage: STAGE, reason: "refresh_every must be ≥ 1".into() });
        }
        let interp = Interpolator::from_config(surface, layout)?;
        Ok(Self::from_parts(interp, MaxContourFinder::try_new(contour)?))
    }

    /// The fused stage from a (shared) interpolator and a contour finder.
    pub fn from_parts(interp: Interpolator, finder: MaxContourFinder) -> Self {
        SurfaceContour { finder: PeakContourFinder::new(interp, finder), _in: std::marker::PhantomData }
    }

    /// Evaluate only the blocks of grid points the maximal contour reads (see
    /// [`PeakContourFinder::with_peak_local`]).
    pub fn with_peak_local(mut self, peak_local: bool) -> Self {
        self.finder = self.finder.with_peak_local(peak_local);
        self
    }

    /// The finder.
    pub fn finder(&self) -> &PeakContourFinder {
        &self.finder
    }
}

impl<I: TaxelValues> Stage for SurfaceContour<I> {
    type In = I;
    type Out = ContourFrame;
    type Error = Error;

    fn push(&mut self, input: I, out: &mut Vec<ContourFrame>) -> Result<()> {
        crate::interpolate::check_input(&input, self.finder.interp.table().taxels())?;
        let v = input.taxel_values();
        let outcome = self.finder.find(v);
        let (start, end) = input.span();
        out.push(ContourFrame { sensor: input.sensor().clone(), start, end, seq: input.seq(), outcome });
        Ok(())
    }

    fn reset(&mut self) {
        self.finder.reset();
    }

    fn delay(&self) -> Delay {
        Delay::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contour::{Levels, Saddle};
    use crate::interpolate::{GridConfig, Method, Outside};
    use proptest::prelude::*;
    use std::sync::OnceLock;

    /// The reference: the full grid (every point a fresh sum), then the contour finder.
    fn full(interp: &Interpolator, finder: &mut MaxContourFinder, v: &[f64]) -> ContourOutcome {
        let s = interp.surface(v);
        finder.find(s.view(), interp.grid())
    }

    fn interps() -> &'static [Interpolator] {
        static ALL: OnceLock<Vec<Interpolator>> = OnceLock::new();
        ALL.get_or_init(build_interps)
    }

    fn build_interps() -> Vec<Interpolator> {
        let l = Layout::biotac_sp();
        let mut out = Vec::new();
        for (method, outside) in [
            (Method::NaturalNeighbour, Outside::Nan),
            (Method::NaturalNeighbour, Outside::Fill),
            (Method::Linear, Outside::Extend),
            (Method::Nearest, Outside::Nan),
            (Method::InverseDistance, Outside::Fill),
        ] {
            for nx in [64, 17] {
                let cfg = InterpolateConfig {
                    method,
                    outside,
                    fill_value: 0.5,
                    grid: GridConfig { nx, ..Default::default() },
                    ..Default::default()
                };
                out.push(Interpolator::from_config(&cfg, &l).unwrap());
            }
        }
        out
    }

    fn finders() -> Vec<ContourConfig> {
        vec![
            ContourConfig::default(),
            ContourConfig { levels: Levels::Count(3), min_area_mm2: 0.0, min_peak: -1e9, ..Default::default() },
            ContourConfig { levels: Levels::Explicit(vec![0.5, 2.0, 3.0]), saddle: Saddle::Low, ..Default::default() },
            ContourConfig { peak_only: false, min_area_mm2: 15.0, saddle: Saddle::High, ..Default::default() },
        ]
    }

    /// Random window aggregates: small integer counts (ties), all equal (flat), zeros, two equal
    /// peaks, negatives (net polarity), a single hot taxel at the edge, and wide magnitudes.
    fn aggregate() -> impl Strategy<Value = Vec<f64>> {
        prop_oneof![
            proptest::collection::vec(0u8..6, 24).prop_map(|v| v.into_iter().map(f64::from).collect()),
            (0u8..5).prop_map(|x| vec![f64::from(x); 24]),
            (0usize..24, 0usize..24, 1u8..9).prop_map(|(a, b, h)| {
                let mut v = vec![0.0; 24];
                v[a] = f64::from(h);
                v[b] = f64::from(h);
                v
            }),
            proptest::collection::vec(-4i8..5, 24).prop_map(|v| v.into_iter().map(f64::from).collect()),
            proptest::collection::vec(-1e6f64..1e6, 24),
            proptest::collection::vec(prop_oneof![Just(0.0), 1e-300f64..1e-290, 1e290f64..1e300], 24),
            // at and just under the default min_peak (1): the dense path's early exit
            proptest::collection::vec(prop_oneof![Just(1.0), Just(1.0 - f64::EPSILON / 2.0), 0.999f64..1.0], 24),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]
        #[test]
        fn peak_local_equals_the_full_grid(frames in proptest::collection::vec(aggregate(), 1..4)) {
            for interp in interps() {
                for cfg in finders() {
                    let mut reference = MaxContourFinder::try_new(&cfg).unwrap();
                    let new = |lazy| {
                        PeakContourFinder::new(interp.clone(), MaxContourFinder::try_new(&cfg).unwrap())
                            .with_peak_local(lazy)
                    };
                    let (mut lazy, mut dense) = (new(true), new(false));
                    for v in &frames {
                        let want = full(interp, &mut reference, v);
                        // bit for bit (NaN-free outcomes, so == is exact equality)
                        let got = lazy.find(v);
                        prop_assert_eq!(&got, &want, "{:?} {:?} {:?}", interp.method(), cfg, v);
                        let got = dense.find(v);
                        prop_assert_eq!(&got, &want, "dense {:?} {:?} {:?}", interp.method(), cfg, v);
                    }
                }
            }
        }
    }

    #[test]
    fn evaluates_a_fraction_of_the_grid_on_a_local_contact() {
        let l = Layout::biotac_sp();
        let interp = Interpolator::from_config(&InterpolateConfig::default(), &l).unwrap();
        let mut f =
            PeakContourFinder::new(interp.clone(), MaxContourFinder::try_new(&ContourConfig::default()).unwrap())
                .with_peak_local(true);
        let mut reference = MaxContourFinder::try_new(&ContourConfig::default()).unwrap();
        let mut v = vec![0.0; 24];
        (v[3], v[4], v[7]) = (6.0, 3.0, 2.0);
        let want = full(&interp, &mut reference, &v);
        assert!(want.contact().is_some());
        assert_eq!(f.find(&v), want);
        let n = f.points_evaluated();
        assert!(n < 4096 / 2, "{n} points evaluated");
        // no contact at all: settled by the bounds
        assert_eq!(f.find(&[0.0; 24]), ContourOutcome::NoContact(NoContact::BelowMinPeak));
        assert_eq!(f.points_evaluated(), n);
    }

    #[test]
    fn stage_errors_match_interpolate() {
        use crate::interpolate::Interpolate;
        use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
        let l = Layout::biotac_sp();
        let cfg = InterpolateConfig::default();
        let mut fused = SurfaceContour::<TaxelFrame>::try_new(&cfg, &ContourConfig::default(), &l).unwrap();
        let mut plain = Interpolate::<TaxelFrame>::try_new(&cfg, &l).unwrap();
        let frame = |v: Vec<f64>| TaxelFrame { sensor: SensorId::new("s"), time: Timestamp(5), seq: 9, values: v };
        for bad in [vec![0.0; 23], {
            let mut v = vec![1.0; 24];
            v[4] = f64::NAN;
            v
        }] {
            let (mut a, mut b) = (Vec::new(), Vec::new());
            let ea = fused.push(frame(bad.clone()), &mut a).unwrap_err().to_string();
            let eb = plain.push(frame(bad), &mut b).unwrap_err().to_string();
            assert_eq!(ea, eb);
        }
        let (mut out, mut surf, mut want) = (Vec::new(), Vec::new(), Vec::new());
        let mut v = vec![0.0; 24];
        v[20] = 3.0;
        fused.push(frame(v.clone()), &mut out).unwrap();
        plain.push(frame(v), &mut surf).unwrap();
        crate::contour::Contour::try_new(&ContourConfig::default()).unwrap().push(surf.remove(0), &mut want).unwrap();
        assert_eq!(out, want);
        assert_eq!((out[0].start, out[0].end, out[0].seq), (Timestamp(5), Timestamp(5), 9));
    }
}
