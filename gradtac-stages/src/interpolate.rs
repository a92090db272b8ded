//! Interpolate: from per-taxel values at the layout's positions to a surface on a regular grid
//! (method.md, stage 5).
//!
//! # What it does
//! The layout is fixed, so every grid point's interpolation weights are computed **once** per
//! (layout, grid, method) into a sparse [`WeightTable`] (compressed rows: for each grid point the
//! taxels it depends on and their weights). A frame is then a sparse weighted sum
//! `z[p] = Σ_k w[p,k] · v[k]`, summed taxel by taxel over each taxel's runs of consecutive
//! grid points (a loop the compiler vectorises), skipping taxels whose value is 0 (most of a
//! window aggregate's) — bit-identical to summing each point's row in taxel order (tested).
//! The [`Interpolate`] stage can also update the previous surface
//! incrementally from the taxels whose value changed (`z += w[·,k] · Δv[k]`, see
//! [`InterpolateConfig::incremental`]).
//!
//! # Methods ([`Method`])
//! - **Natural neighbour** (Sibson, "area stealing"; the paper's method): weights from
//!   [`spade`]'s `natural_neighbor().get_weights`. C¹ except at the taxels, reproduces linear
//!   fields exactly inside the convex hull.
//! - **Linear** (barycentric on the Delaunay triangulation, spade's `barycentric()`): C⁰, kinks
//!   along triangle edges, reproduces linear fields exactly.
//! - **Nearest** taxel (Voronoi cells; ties go to the lower taxel index): piecewise constant.
//! - **Inverse distance** (Shepard) with power `p`: `w_k ∝ d_k^{−p}` over all taxels; a grid point
//!   on a taxel takes that taxel's value. Flat spots at the taxels for `p > 1`, does not reproduce
//!   linear fields.
//!
//! # Outside the taxels' convex hull ([`Outside`])
//! - `nan` (default): the surface is NaN there (no data). Contours treat NaN as lower than
//!   every level, so a region is cut along the hull.
//! - `fill`: a constant ([`InterpolateConfig::fill_value`], default 0 — "no events").
//! - `extend`: natural neighbour and linear take the value at the closest point of the hull
//!   boundary (linear along that hull edge), a continuous extension; nearest and inverse
//!   distance use their own formulas, which are defined everywhere.
//!
//! Points exactly on the hull boundary, on Delaunay edges or on taxels are inside and work for
//! every method (MetPy's `natural_neighbor_to_grid` divides by zero on some of them).
//!
//! # Units
//! Grid coordinates in mm (the layout's); surface values in the input's units (events for a
//! window aggregate). The array is indexed `[row, col]` = `[y index, x index]`: row `j` is at
//! `y_j`, column `i` at `x_i`, both increasing (image convention of scikit-image / MetPy).
//!
//! # Delay
//! None: one surface per input, stamped with the input's time span.
//!
//! # Trade-offs (24 BioTac SP taxels, 64 × 64 grid, `outside = "nan"`)
//! Per-surface times: criterion medians of `cargo bench -p gradtac-stages --bench spatial --
//! '^surface/'` (release, one core of a shared 2-core machine at load ≈ 3–4, one run on
//! 2026-11-26 with the column-run sums; 5 of the bench's 24 taxel values are 0 and skipped —
//! a window aggregate usually has more zeros, so sums there are cheaper still). Before the
//! column-run sums (row by row): natural neighbour 5.5–7.6, linear 4.6–6.8, nearest 2.4–4.3,
//! inverse distance 17.8–21.4 µs. Build times: medians of two earlier runs.
//!
//! | method | smoothness | linear field exact | weights / inside point | µs / surface | build (once) |
//! |---|---|---|---|---|---|
//! | natural neighbour | C¹ off the taxels | yes | 4.9 | 3.9 (spade point by point: 468–507) | 0.75–0.87 ms |
//! | linear | C⁰ (kinks on edges) | yes | 3 | 2.8 (spade point by point: 181) | 0.29–0.45 ms |
//! | nearest | discontinuous | no | 1 | 1.7 | 0.29–0.44 ms |
//! | inverse distance | C^∞ off taxels, flat spots at taxels | no | 24 (all) | 16.9 | 1.6–1.7 ms |
//!
//! Grid size, natural neighbour: 0.37 / 1.0 / 3.9 / 16.5 µs per surface at 16² / 32² / 64² /
//! 128² (before: 0.34–0.40 / 1.2–2.1 / 5.5–7.6 / 21.6–23.7).
//!
//! | option | faster | more accurate |
//! |---|---|---|
//! | `incremental` | `true`: cost ∝ changed taxels | `false`: every surface a fresh sum (bit-reproducible) |
//! | grid `nx`,`ny` | small | large (cost ∝ nx·ny) |

use crate::{Error, Result};
use gradtac_stream::{Delay, Extent, HasSensor, Layout, SensorId, Stage, TaxelFrame, Timestamp};
use ndarray::Array2;
use serde::{Deserialize, Serialize};
use spade::{DelaunayTriangulation, FloatTriangulation, HasPosition, Point2, Triangulation};
use std::sync::Arc;

const STAGE: &str = "interpolate";

/// How a grid's extent is chosen.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GridConfig {
    /// Number of grid columns (points along x), ≥ 2. Default 64.
    pub nx: usize,
    /// Number of grid rows (points along y), ≥ 2; `None` = `nx`. Default `None`.
    pub ny: Option<usize>,
    /// Margin (mm) around the taxels' bounding box; `None` uses the layout's own
    /// [`extent`](Layout::extent) (which has a 2 mm margin). Ignored when `extent` is given.
    pub margin_mm: Option<f64>,
    /// An explicit extent (mm); overrides `margin_mm`.
    pub extent: Option<Extent>,
}

impl Default for GridConfig {
    fn default() -> Self {
        GridConfig { nx: 64, ny: None, margin_mm: None, extent: None }
    }
}

/// A regular grid in mm: `nx` columns from `x_min` to `x_max` and `ny` rows from `y_min` to
/// `y_max`, both ends included (like `numpy.linspace`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Grid {
    extent: Extent,
    nx: usize,
    ny: usize,
}

impl Grid {
    /// A grid over `extent` with `nx × ny` points. Refuses fewer than 2 points per axis, more
    /// than [`MAX_GRID_POINTS`](crate::limits::MAX_GRID_POINTS) (2²⁰) points, an empty or
    /// non-finite extent, or one reaching beyond ±2·[`MAX_MM`](crate::limits::MAX_MM).
    pub fn try_new(extent: Extent, nx: usize, ny: usize) -> Result<Self> {
        let bad = |reason: String| Error::InvalidConfig { stage: STAGE, reason };
        if nx < 2 || ny < 2 {
            return Err(bad(format!("grid {nx}×{ny}: at least 2 points per axis are needed")));
        }
        if nx.saturating_mul(ny) > crate::limits::MAX_GRID_POINTS {
            return Err(bad(format!(
                "grid {nx}×{ny} has more than {} points (1024 × 1024)",
                crate::limits::MAX_GRID_POINTS
            )));
        }
        let e = extent;
        let lim = 2.0 * crate::limits::MAX_MM;
        if [e.x_min, e.x_max, e.y_min, e.y_max].iter().any(|v| v.abs() > lim) {
            return Err(bad(format!("grid extent {e:?} reaches beyond ±{lim} mm")));
        }
        let finite = [e.x_min, e.x_max, e.y_min, e.y_max].iter().all(|v| v.is_finite());
        if !(finite && e.x_max > e.x_min && e.y_max > e.y_min) {
            return Err(bad(format!("grid extent {e:?} is empty or not finite")));
        }
        Ok(Grid { extent, nx, ny })
    }

    /// The grid a [`GridConfig`] asks for over a layout.
    pub fn from_config(cfg: &GridConfig, layout: &Layout) -> Result<Self> {
        let extent = match (cfg.extent, cfg.margin_mm) {
            (Some(e), _) => e,
            (None, None) => layout.extent(),
            (None, Some(m)) => {
                crate::limits::check_mm(STAGE, "margin_mm", m, false)?;
                let p = layout.positions();
                let f = |k: usize, min: bool| {
                    p.iter().map(|q| q[k]).fold(if min { f64::INFINITY } else { f64::NEG_INFINITY }, |a, b| {
                        if min {
                            a.min(b)
                        } else {
                            a.max(b)
                        }
                    })
                };
                Extent { x_min: f(0, true), x_max: f(0, false), y_min: f(1, true), y_max: f(1, false) }.grown(m)
            }
        };
        Grid::try_new(extent, cfg.nx, cfg.ny.unwrap_or(cfg.nx))
    }

    /// The extent (mm).
    pub fn extent(&self) -> Extent {
        self.extent
    }
    /// Number of columns (x).
    pub fn nx(&self) -> usize {
        self.nx
    }
    /// Number of rows (y).
    pub fn ny(&self) -> usize {
        self.ny
    }
    /// Number of grid points.
    pub fn len(&self) -> usize {
        self.nx * self.ny
    }
    /// Always false (a grid has at least 4 points).
    pub fn is_empty(&self) -> bool {
        false
    }
    /// Spacing along x (mm).
    pub fn dx(&self) -> f64 {
        self.extent.width() / (self.nx - 1) as f64
    }
    /// Spacing along y (mm).
    pub fn dy(&self) -> f64 {
        self.extent.height() / (self.ny - 1) as f64
    }
    /// x of column `i` (mm); the last column is exactly `x_max`.
    pub fn x(&self, i: usize) -> f64 {
        lin(self.extent.x_min, self.extent.x_max, i, self.nx)
    }
    /// y of row `j` (mm); the last row is exactly `y_max`.
    pub fn y(&self, j: usize) -> f64 {
        lin(self.extent.y_min, self.extent.y_max, j, self.ny)
    }
    /// The x of every column (mm), for writing the grid next to a surface.
    pub fn xs(&self) -> Vec<f64> {
        (0..self.nx).map(|i| self.x(i)).collect()
    }
    /// The y of every row (mm).
    pub fn ys(&self) -> Vec<f64> {
        (0..self.ny).map(|j| self.y(j)).collect()
    }
    /// Map fractional (column, row) index coordinates to mm.
    pub fn index_to_mm(&self, col: f64, row: f64) -> [f64; 2] {
        [self.extent.x_min + col * self.dx(), self.extent.y_min + row * self.dy()]
    }
    /// Area of one grid cell (mm²).
    pub fn cell_area(&self) -> f64 {
        self.dx() * self.dy()
    }
}

fn lin(a: f64, b: f64, i: usize, n: usize) -> f64 {
    if i + 1 == n {
        b
    } else {
        a + (b - a) * (i as f64 / (n - 1) as f64)
    }
}

/// An interpolation method (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Sibson natural neighbour (the paper's method). Also accepted as `natural_neighbor`.
    #[default]
    #[serde(alias = "natural_neighbor")]
    NaturalNeighbour,
    /// Barycentric on the Delaunay triangulation.
    Linear,
    /// Nearest taxel.
    Nearest,
    /// Inverse distance weighting with power [`InterpolateConfig::power`].
    InverseDistance,
}

/// What the surface holds outside the taxels' convex hull (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Outside {
    /// NaN.
    #[default]
    Nan,
    /// [`InterpolateConfig::fill_value`].
    Fill,
    /// Closest-hull-point extension (natural neighbour, linear); the method's own formula
    /// (nearest, inverse distance).
    Extend,
}

/// Configuration of the [`Interpolate`] stage (`[stages.surface]` in a scene).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InterpolateConfig {
    /// The method. Default `natural_neighbour`.
    pub method: Method,
    /// Inverse-distance power `p` (dimensionless, > 0). Default 2.
    pub power: f64,
    /// Policy outside the convex hull. Default `nan`.
    pub outside: Outside,
    /// Value for `outside = "fill"` (input units). Default 0.
    pub fill_value: f64,
    /// The grid.
    pub grid: GridConfig,
    /// Update the previous surface from the taxels whose value changed instead of summing
    /// afresh. Faster when few taxels change per frame (a sliding window advanced every frame);
    /// results differ from a fresh sum by rounding only (≲ 1e-12 relative), bounded by a full
    /// recomputation every `refresh_every` surfaces. A frame whose changed taxels' weights make
    /// up half the table or more is summed afresh instead (cheaper, and exact). Default `false`.
    pub incremental: bool,
    /// With `incremental`: recompute in full every this many surfaces (≥ 1). Default 64.
    pub refresh_every: u32,
}

impl Default for InterpolateConfig {
    fn default() -> Self {
        InterpolateConfig {
            method: Method::NaturalNeighbour,
            power: 2.0,
            outside: Outside::Nan,
            fill_value: 0.0,
            grid: GridConfig::default(),
            incremental: false,
            refresh_every: 64,
        }
    }
}

/// Per-grid-point interpolation weights in compressed-row form, plus the transpose (per taxel)
/// for incremental updates.
///
/// Row `p` (grid point `p = row·nx + col`) holds `(taxel, weight)` pairs in
/// `taxels[starts[p]..starts[p+1]]`, `weights[..]`. A point with an empty row takes the
/// table's [`fill`](WeightTable::fill) value (NaN or the fill value) — it lies outside the hull.
#[derive(Clone, Debug)]
pub struct WeightTable {
    starts: Vec<u32>,
    taxels: Vec<u16>,
    weights: Vec<f64>,
    // transpose as runs of consecutive grid points: taxel k owns runs
    // run_starts[k]..run_starts[k+1]; run r covers points run_point[r].. with weights
    // col_weights[run_weight[r]..run_weight[r+1]]
    run_starts: Vec<u32>,
    run_point: Vec<u32>,
    run_weight: Vec<u32>,
    col_weights: Vec<f64>,
    // the surface before any taxel is added: 0 at points with weights, `fill` elsewhere
    base: Vec<f64>,
    // runs `[a, b)` of consecutive points with weights (where `base` is 0)
    weighted_runs: Vec<(u32, u32)>,
    inside: Vec<bool>,
    n_taxels: usize,
    fill: f64,
    // the whole chunks of `contour::SCAN_LANES` points that can hold a finite value (a point
    // with weights, or any point when the fill is not NaN), merged into ranges `[a, b)`
    finite_chunks: Vec<(u32, u32)>,
}

impl WeightTable {
    /// Ranges of whole [`SCAN_LANES`](crate::contour::SCAN_LANES)-point chunks outside which
    /// (up to the remainder after the last whole chunk) every surface value is NaN.
    pub(crate) fn finite_chunks(&self) -> &[(u32, u32)] {
        &self.finite_chunks
    }

    /// Number of grid points (rows).
    pub fn points(&self) -> usize {
        self.starts.len() - 1
    }
    /// Number of taxels (columns).
    pub fn taxels(&self) -> usize {
        self.n_taxels
    }
    /// Total number of stored weights.
    pub fn nnz(&self) -> usize {
        self.weights.len()
    }
    /// Value of points with an empty row.
    pub fn fill(&self) -> f64 {
        self.fill
    }
    /// The `(taxel, weight)` pairs of grid point `p`.
    pub fn row(&self, p: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let (a, b) = (self.starts[p] as usize, self.starts[p + 1] as usize);
        self.taxels[a..b].iter().zip(&self.weights[a..b]).map(|(&k, &w)| (k as usize, w))
    }
    /// Whether grid point `p` lies inside (or on) the taxels' convex hull.
    pub fn inside(&self, p: usize) -> bool {
        self.inside[p]
    }

    /// `out[p] = Σ w·values` for every grid point (`out.len() == points()`).
    ///
    /// Summed taxel by taxel over the table's column runs (contiguous grid points, a loop the
    /// compiler vectorises), skipping taxels whose value is 0. Every point sees the same
    /// operations in the same order as its row sum `((0 + w₀v₀) + w₁v₁) + …` (ascending
    /// taxel), and adding `w·0 = ±0` to a sum that starts at `+0` never changes it, so the
    /// result is bit-identical to [`value_at`](Self::value_at) at every point (tested).
    pub fn apply(&self, values: &[f64], out: &mut [f64]) {
        debug_assert_eq!(values.len(), self.n_taxels);
        debug_assert_eq!(out.len(), self.points());
        out.copy_from_slice(&self.base);
        self.accumulate(values, out);
    }

    /// A new row-major vector of `Σ w·values` for every grid point (as [`apply`](Self::apply)).
    pub fn apply_to_vec(&self, values: &[f64]) -> Vec<f64> {
        debug_assert_eq!(values.len(), self.n_taxels);
        let mut out = self.base.clone();
        self.accumulate(values, &mut out);
        out
    }

    /// As [`apply`](Self::apply), for an `out` that already holds a surface of this table (its
    /// points without weights hold the fill value, which no sum touches): only the points with
    /// weights are reset, to 0, before the sums. Bit-identical to `apply`.
    pub fn apply_again(&self, values: &[f64], out: &mut [f64]) {
        debug_assert_eq!(values.len(), self.n_taxels);
        debug_assert_eq!(out.len(), self.points());
        for &(a, b) in &self.weighted_runs {
            out[a as usize..b as usize].fill(0.0);
        }
        self.accumulate(values, out);
    }

    /// `out += Σ_k w[·,k]·values[k]` over the taxels with a non-zero value, in ascending taxel
    /// order, run by run.
    fn accumulate(&self, values: &[f64], out: &mut [f64]) {
        for (k, &v) in values.iter().enumerate() {
            if v == 0.0 {
                continue;
            }
            self.add_taxel(k, v, out);
        }
    }

    /// `Σ w·values` at grid point `p` alone — bit-identical to that point of [`apply`](Self::apply).
    #[inline(always)]
    pub fn value_at(&self, p: usize, values: &[f64]) -> f64 {
        self.row_value(self.starts[p] as usize, self.starts[p + 1] as usize, values)
    }

    /// The taxels and weights of grid point `p` (crate-internal: the peak-local index).
    pub(crate) fn row_parts(&self, p: usize) -> (&[u16], &[f64]) {
        let (a, b) = (self.starts[p] as usize, self.starts[p + 1] as usize);
        (&self.taxels[a..b], &self.weights[a..b])
    }

    /// Number of stored weights of taxel `k`'s column (the cost of [`add_taxel`](Self::add_taxel)).
    pub(crate) fn column_nnz(&self, k: usize) -> usize {
        let (a, b) = (self.run_starts[k] as usize, self.run_starts[k + 1] as usize);
        if a == b {
            0
        } else {
            (self.run_weight[b] - self.run_weight[a]) as usize
        }
    }

    #[inline(always)]
    fn row_value(&self, a: usize, b: usize, values: &[f64]) -> f64 {
        if a == b {
            return self.fill;
        }
        let mut s = 0.0;
        for (&k, &w) in self.taxels[a..b].iter().zip(&self.weights[a..b]) {
            s += w * values[k as usize];
        }
        s
    }

    /// `out += w[·, taxel] · delta`: the change of the surface when one taxel's value changes
    /// by `delta`.
    pub fn add_taxel(&self, taxel: usize, delta: f64, out: &mut [f64]) {
        let (a, b) = (self.run_starts[taxel] as usize, self.run_starts[taxel + 1] as usize);
        let bounds = self.run_weight[a..=b].windows(2);
        for (&p, w) in self.run_point[a..b].iter().zip(bounds) {
            let (w0, w1, p) = (w[0] as usize, w[1] as usize, p as usize);
            let ws = &self.col_weights[w0..w1];
            for (o, &w) in out[p..p + ws.len()].iter_mut().zip(ws) {
                *o += w * delta;
            }
        }
    }

    fn from_rows(rows: Vec<Vec<(usize, f64)>>, n_taxels: usize, fill: f64, inside: Vec<bool>) -> Self {
        let mut starts = Vec::with_capacity(rows.len() + 1);
        let (mut taxels, mut weights) = (Vec::new(), Vec::new());
        let mut counts = vec![0u32; n_taxels + 1];
        starts.push(0u32);
        for r in &rows {
            for &(k, w) in r {
                taxels.push(k as u16);
                weights.push(w);
                counts[k + 1] += 1;
            }
            starts.push(taxels.len() as u32);
        }
        for k in 0..n_taxels {
            counts[k + 1] += counts[k];
        }
        let mut next = counts.clone();
        let mut col_points = vec![0u32; taxels.len()];
        let mut cw = vec![0.0; taxels.len()];
        for (p, r) in rows.iter().enumerate() {
            for &(k, w) in r {
                let at = next[k] as usize;
                col_points[at] = p as u32;
                cw[at] = w;
                next[k] += 1;
            }
        }
        // split each taxel's (ascending) points into runs of consecutive points
        let (mut run_starts, mut run_point, mut run_weight) = (vec![0u32], Vec::new(), Vec::new());
        let mut col_weights = Vec::with_capacity(cw.len());
        for k in 0..n_taxels {
            let (a, b) = (counts[k] as usize, counts[k + 1] as usize);
            for i in a..b {
                if i == a || col_points[i] != col_points[i - 1] + 1 {
                    run_point.push(col_points[i]);
                    run_weight.push(col_weights.len() as u32);
                }
                col_weights.push(cw[i]);
            }
            run_starts.push(run_point.len() as u32);
        }
        run_weight.push(col_weights.len() as u32);
        let base: Vec<f64> = starts.windows(2).map(|se| if se[0] == se[1] { fill } else { 0.0 }).collect();
        let mut weighted_runs = Vec::new();
        for (p, se) in starts.windows(2).enumerate() {
            if se[0] == se[1] {
                continue;
            }
            match weighted_runs.last_mut() {
                Some((_, b)) if *b == p as u32 => *b += 1,
                _ => weighted_runs.push((p as u32, p as u32 + 1)),
            }
        }
        let lanes = crate::contour::SCAN_LANES;
        let whole = (rows.len() / lanes) * lanes;
        let mut finite_chunks: Vec<(u32, u32)> = Vec::new();
        for a in (0..whole).step_by(lanes) {
            let finite = !fill.is_nan() || (a..a + lanes).any(|p| starts[p] != starts[p + 1]);
            if !finite {
                continue;
            }
            match finite_chunks.last_mut() {
                Some((_, b)) if *b == a as u32 => *b += lanes as u32,
                _ => finite_chunks.push((a as u32, (a + lanes) as u32)),
            }
        }
        WeightTable {
            finite_chunks,
            starts,
            taxels,
            weights,
            run_starts,
            run_point,
            run_weight,
            col_weights,
            base,
            weighted_runs,
            inside,
            n_taxels,
            fill,
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Taxel {
    pos: Point2<f64>,
    index: usize,
}

impl HasPosition for Taxel {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.pos
    }
}

/// spade refuses coordinates of magnitude below ~1.8e-43 (other than 0); at mm scale they are 0.
fn snap(v: f64) -> f64 {
    if v.abs() < spade::MIN_ALLOWED_VALUE {
        0.0
    } else {
        v
    }
}

/// How many weight tables [`Interpolator::from_config`] keeps for sharing.
pub const SHARED_TABLES: usize = 16;
/// Grids of more points than this are not kept for sharing (bounded memory).
pub const SHARED_MAX_POINTS: usize = 1 << 18;

#[derive(PartialEq)]
struct TableKey {
    positions: Vec<[u64; 2]>,
    extent: [u64; 4],
    n: [usize; 2],
    method: Method,
    outside: Outside,
    power: u64,
    fill: u64,
}

static TABLES: std::sync::Mutex<Vec<(TableKey, Interpolator)>> = std::sync::Mutex::new(Vec::new());

/// The interpolation of one layout onto one grid by one method: a [`WeightTable`] built once.
#[derive(Clone, Debug)]
pub struct Interpolator {
    grid: Arc<Grid>,
    table: Arc<WeightTable>,
    method: Method,
    outside: Outside,
    // the block bounds for peak-local evaluation, built on first use and shared by clones
    peak: Arc<std::sync::OnceLock<crate::peak::PeakIndex>>,
}

impl Interpolator {
    /// Build the weights of every grid point. `power` is used by inverse distance only,
    /// `fill_value` by [`Outside::Fill`] only.
    ///
    /// Refuses (with [`Error::InvalidConfig`]) a layout spade cannot triangulate (all taxels
    /// on one line, coordinates beyond ±3e60), more than 65 535 taxels, and a non-positive
    /// or non-finite `power`.
    pub fn try_new(
        layout: &Layout,
        grid: Arc<Grid>,
        method: Method,
        outside: Outside,
        power: f64,
        fill_value: f64,
    ) -> Result<Self> {
        let bad = |reason: String| Error::InvalidConfig { stage: STAGE, reason };
        let pos: Vec<[f64; 2]> = layout.positions().iter().map(|p| [snap(p[0]), snap(p[1])]).collect();
        let n = pos.len();
        if n > u16::MAX as usize {
            return Err(bad(format!("{n} taxels; at most 65535 are supported")));
        }
        if method == Method::InverseDistance && !(power.is_finite() && power > 0.0) {
            return Err(bad(format!("inverse-distance power {power} must be finite and > 0")));
        }
        let mut tri: DelaunayTriangulation<Taxel> = DelaunayTriangulation::new();
        for (index, p) in pos.iter().enumerate() {
            tri.insert(Taxel { pos: Point2::new(p[0], p[1]), index }).map_err(|e| {
                bad(format!("layout {:?}: taxel {} at {p:?} cannot be triangulated: {e:?}", layout.name(), index))
            })?;
        }
        if tri.num_vertices() != n {
            return Err(bad(format!("layout {:?}: two taxels share a position", layout.name())));
        }
        if tri.all_vertices_on_line() {
            return Err(bad(format!(
                "layout {:?}: all taxels lie on one line; no surface can be spanned",
                layout.name()
            )));
        }
        let hull: Vec<(usize, usize)> = tri
            .convex_hull()
            .map(|e| {
                let [a, b] = e.vertices();
                (a.data().index, b.data().index)
            })
            .collect();
        let fill = match outside {
            Outside::Nan => f64::NAN,
            _ => fill_value,
        };
        let nn = tri.natural_neighbor();
        let bary = tri.barycentric();
        let mut buf = Vec::new();
        let mut rows = Vec::with_capacity(grid.len());
        let mut inside = Vec::with_capacity(grid.len());
        for j in 0..grid.ny() {
            for i in 0..grid.nx() {
                let q = [snap(grid.x(i)), snap(grid.y(j))];
                let qp = Point2::new(q[0], q[1]);
                // inside test: barycentric locate is exact (spade's robust predicates)
                bary.get_weights(qp, &mut buf);
                let is_in = !buf.is_empty();
                inside.push(is_in);
                let mut row: Vec<(usize, f64)> = Vec::new();
                if is_in || outside == Outside::Extend {
                    match method {
                        Method::NaturalNeighbour | Method::Linear if is_in => {
                            if method == Method::NaturalNeighbour {
                                nn.get_weights(qp, &mut buf);
                            }
                            row.extend(buf.iter().map(|&(v, w)| (tri.vertex(v).data().index, w)));
                        }
                        Method::NaturalNeighbour | Method::Linear => row = hull_projection(&pos, &hull, q),
                        Method::Nearest => row.push((nearest(&pos, q), 1.0)),
                        Method::InverseDistance => row = idw(&pos, q, power),
                    }
                }
                row.retain(|&(_, w)| w != 0.0);
                row.sort_by_key(|&(k, _)| k);
                if (is_in || outside == Outside::Extend) && row.is_empty() {
                    // cannot happen for valid weights (they sum to 1); keep the surface honest
                    return Err(bad(format!("no weights at grid point ({i}, {j}) = {q:?}")));
                }
                rows.push(row);
            }
        }
        let table = WeightTable::from_rows(rows, n, fill, inside);
        Ok(Interpolator { grid, table: Arc::new(table), method, outside, peak: Default::default() })
    }

    /// The interpolator a config asks for over a layout.
    ///
    /// Built once per (taxel positions, grid, method, outside policy, power, fill value) in a
    /// process: later calls with the same key — the planner's validation, the runner, every
    /// sensor with the same layout — share the same weight table (and peak index) through an
    /// `Arc`. The memo keeps the [`SHARED_TABLES`] most recent tables of at most
    /// [`SHARED_MAX_POINTS`] grid points each; larger grids are built per call.
    pub fn from_config(cfg: &InterpolateConfig, layout: &Layout) -> Result<Self> {
        let grid = Grid::from_config(&cfg.grid, layout)?;
        let key = TableKey {
            positions: layout.positions().iter().map(|p| [p[0].to_bits(), p[1].to_bits()]).collect(),
            extent: [grid.extent.x_min, grid.extent.x_max, grid.extent.y_min, grid.extent.y_max].map(f64::to_bits),
            n: [grid.nx, grid.ny],
            method: cfg.method,
            outside: cfg.outside,
            power: if cfg.method == Method::InverseDistance { cfg.power.to_bits() } else { 0 },
            fill: if cfg.outside == Outside::Fill { cfg.fill_value.to_bits() } else { 0 },
        };
        let memo = grid.len() <= SHARED_MAX_POINTS;
        if memo {
            let shared = TABLES.lock().unwrap_or_else(|e| e.into_inner());
            if let Some((_, it)) = shared.iter().find(|(k, _)| *k == key) {
                return Ok(it.clone());
            }
        }
        let it = Self::try_new(layout, Arc::new(grid), cfg.method, cfg.outside, cfg.power, cfg.fill_value)?;
        if memo {
            let mut shared = TABLES.lock().unwrap_or_else(|e| e.into_inner());
            if !shared.iter().any(|(k, _)| *k == key) {
                if shared.len() >= SHARED_TABLES {
                    shared.remove(0);
                }
                shared.push((key, it.clone()));
            }
        }
        Ok(it)
    }

    /// True when `self` and `other` share one weight table (built once).
    pub fn shares_table(&self, other: &Interpolator) -> bool {
        Arc::ptr_eq(&self.table, &other.table)
    }

    /// The grid.
    pub fn grid(&self) -> &Arc<Grid> {
        &self.grid
    }
    /// The weight table.
    pub fn table(&self) -> &Arc<WeightTable> {
        &self.table
    }
    /// The block bounds used to evaluate only the points the maximal contour needs (built once
    /// per interpolator, on first use, and shared by its clones).
    pub fn peak_index(&self) -> &crate::peak::PeakIndex {
        self.peak.get_or_init(|| crate::peak::PeakIndex::new(&self.table, &self.grid))
    }

    /// The method.
    pub fn method(&self) -> Method {
        self.method
    }
    /// The outside-hull policy.
    pub fn outside(&self) -> Outside {
        self.outside
    }

    /// Interpolate one set of taxel values (one per taxel, in layout order) to a new array of
    /// shape `(ny, nx)`.
    pub fn surface(&self, values: &[f64]) -> Array2<f64> {
        let mut out = Array2::zeros((self.grid.ny(), self.grid.nx()));
        self.surface_into(values, out.as_slice_mut().expect("a fresh array is contiguous"));
        out
    }

    /// Interpolate into a row-major buffer of `nx·ny` values. Panics if lengths differ
    /// (use [`Interpolate`] for checked input).
    pub fn surface_into(&self, values: &[f64], out: &mut [f64]) {
        assert_eq!(values.len(), self.table.taxels(), "one value per taxel");
        assert_eq!(out.len(), self.grid.len(), "one output per grid point");
        self.table.apply(values, out);
    }
}

/// Weights at the closest point of the convex hull boundary: linear along the closest hull edge.
fn hull_projection(pos: &[[f64; 2]], hull: &[(usize, usize)], q: [f64; 2]) -> Vec<(usize, f64)> {
    let mut best = (f64::INFINITY, 0usize, 0usize, 0.0f64);
    for &(a, b) in hull {
        let (pa, pb) = (pos[a], pos[b]);
        let (ex, ey) = (pb[0] - pa[0], pb[1] - pa[1]);
        let len2 = ex * ex + ey * ey;
        let t = (((q[0] - pa[0]) * ex + (q[1] - pa[1]) * ey) / len2).clamp(0.0, 1.0);
        let (cx, cy) = (pa[0] + t * ex - q[0], pa[1] + t * ey - q[1]);
        let d2 = cx * cx + cy * cy;
        if d2 < best.0 {
            best = (d2, a, b, t);
        }
    }
    let (_, a, b, t) = best;
    vec![(a, 1.0 - t), (b, t)]
}

fn nearest(pos: &[[f64; 2]], q: [f64; 2]) -> usize {
    let mut best = (f64::INFINITY, 0);
    for (k, p) in pos.iter().enumerate() {
        let d2 = (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
        if d2 < best.0 {
            best = (d2, k);
        }
    }
    best.1
}

fn idw(pos: &[[f64; 2]], q: [f64; 2], power: f64) -> Vec<(usize, f64)> {
    let d: Vec<f64> = pos.iter().map(|p| (p[0] - q[0]).hypot(p[1] - q[1])).collect();
    if let Some(k) = d.iter().position(|&x| x == 0.0) {
        return vec![(k, 1.0)];
    }
    // scale by the smallest distance first so d^-p neither overflows nor underflows
    let dmin = d.iter().copied().fold(f64::INFINITY, f64::min);
    let raw: Vec<f64> = d.iter().map(|&x| (dmin / x).powf(power)).collect();
    let sum: f64 = raw.iter().sum();
    raw.iter().enumerate().map(|(k, &r)| (k, r / sum)).collect()
}

/// A surface on a grid: values in input units at the grid points, with the grid attached.
#[derive(Clone, Debug, PartialEq)]
pub struct Surface {
    /// The sensor.
    pub sensor: SensorId,
    /// Start of the time span the values describe (inclusive; a window's start).
    pub start: Timestamp,
    /// End of the span (the time of the newest frame that contributed).
    pub end: Timestamp,
    /// Index of the newest source frame that contributed.
    pub seq: u64,
    /// The grid (shared by every surface of one interpolator).
    pub grid: Arc<Grid>,
    /// Values, shape `(ny, nx)`, indexed `[row (y), col (x)]`.
    pub values: Array2<f64>,
}

impl HasSensor for Surface {
    fn sensor(&self) -> &SensorId {
        &self.sensor
    }
}

impl gradtac_stream::Timed for Surface {
    fn time(&self) -> Timestamp {
        self.end
    }
}

/// What the [`Interpolate`] stage accepts: anything with per-taxel values, a sensor, a time
/// span and a frame index (window aggregates, or raw / normalised frames for raw-data contours).
pub trait TaxelValues: HasSensor {
    /// One value per taxel, in layout order.
    fn taxel_values(&self) -> &[f64];
    /// `(start, end)` of the time span.
    fn span(&self) -> (Timestamp, Timestamp);
    /// Index of the newest source frame.
    fn seq(&self) -> u64;
}

impl TaxelValues for TaxelFrame {
    fn taxel_values(&self) -> &[f64] {
        &self.values
    }
    fn span(&self) -> (Timestamp, Timestamp) {
        (self.time, self.time)
    }
    fn seq(&self) -> u64 {
        self.seq
    }
}

impl TaxelValues for crate::window::WindowAggregate {
    fn taxel_values(&self) -> &[f64] {
        &self.values
    }
    fn span(&self) -> (Timestamp, Timestamp) {
        (self.start, self.end)
    }
    fn seq(&self) -> u64 {
        self.seq
    }
}

/// The interpolation stage: one [`Surface`] per input (see the [module docs](self)).
#[derive(Clone, Debug)]
#[must_use = "a stage does nothing until inputs are pushed"]
pub struct Interpolate<I = crate::window::WindowAggregate> {
    interp: Interpolator,
    incremental: bool,
    refresh_every: u32,
    // incremental state
    prev_values: Vec<f64>,
    current: Vec<f64>,
    since_refresh: u32,
    have_prev: bool,
    _in: std::marker::PhantomData<fn(I)>,
}

/// The [`Interpolate`] stage under its scene name: the `surface` tap (`[stages.surface]`)
/// makes [`Surface`]s with it.
pub type SurfaceStage<I = crate::window::WindowAggregate> = Interpolate<I>;

impl<I> Interpolate<I> {
    /// A stage for a layout. Fails on an invalid grid, method parameter or degenerate layout.
    pub fn try_new(cfg: &InterpolateConfig, layout: &Layout) -> Result<Self> {
        if cfg.refresh_every == 0 {
            return Err(Error::InvalidConfig { stage: STAGE, reason: "refresh_every must be ≥ 1".into() });
        }
        Ok(Self::from_interpolator(Interpolator::from_config(cfg, layout)?, cfg.incremental, cfg.refresh_every.max(1)))
    }

    /// A stage from a prebuilt interpolator (share one weight table between sensors with the
    /// same layout: [`Interpolator`] is cheap to clone).
    pub fn from_interpolator(interp: Interpolator, incremental: bool, refresh_every: u32) -> Self {
        let n = interp.table.taxels();
        let g = interp.grid.len();
        Interpolate {
            interp,
            incremental,
            refresh_every: refresh_every.max(1),
            prev_values: vec![0.0; n],
            current: vec![0.0; if incremental { g } else { 0 }],
            since_refresh: 0,
            have_prev: false,
            _in: std::marker::PhantomData,
        }
    }

    /// The interpolator.
    pub fn interpolator(&self) -> &Interpolator {
        &self.interp
    }
}

/// The checks every surface stage makes on its input (`Interpolate`, and the fused
/// [`SurfaceContour`](crate::peak::SurfaceContour)): `taxels` values, all finite. Errors name
/// the `interpolate` stage, sensor, frame and taxel.
pub(crate) fn check_input<I: TaxelValues>(input: &I, taxels: usize) -> Result<()> {
    let v = input.taxel_values();
    crate::error::check_taxel_count(STAGE, input.sensor(), input.seq(), taxels, v.len())?;
    match v.iter().position(|x| !x.is_finite()) {
        Some(k) => Err(Error::BadValue {
            stage: STAGE,
            sensor: input.sensor().to_string(),
            seq: input.seq(),
            taxel: k,
            value: v[k],
            reason: "not finite",
        }),
        None => Ok(()),
    }
}

impl<I: TaxelValues> Stage for Interpolate<I> {
    type In = I;
    type Out = Surface;
    type Error = Error;

    fn push(&mut self, input: I, out: &mut Vec<Surface>) -> Result<()> {
        check_input(&input, self.interp.table.taxels())?;
        let v = input.taxel_values();
        let (ny, nx) = (self.interp.grid.ny(), self.interp.grid.nx());
        let values = if self.incremental {
            let table = &self.interp.table;
            // the incremental update costs the changed taxels' column lengths; past half the
            // table a fresh sum is cheaper (and exact), so take it
            let changed: usize = v
                .iter()
                .zip(&self.prev_values)
                .enumerate()
                .filter(|(_, (a, b))| a != b)
                .map(|(k, _)| table.column_nnz(k))
                .sum();
            if !self.have_prev || self.since_refresh >= self.refresh_every || 2 * changed >= table.nnz() {
                table.apply(v, &mut self.current);
                self.since_refresh = 0;
                self.have_prev = true;
            } else {
                for (k, (&new, &old)) in v.iter().zip(&self.prev_values).enumerate() {
                    if new != old {
                        table.add_taxel(k, new - old, &mut self.current);
                    }
                }
                self.since_refresh += 1;
            }
            self.prev_values.copy_from_slice(v);
            Array2::from_shape_vec((ny, nx), self.current.clone()).expect("shape matches the grid")
        } else {
            Array2::from_shape_vec((ny, nx), self.interp.table.apply_to_vec(v)).expect("shape matches the grid")
        };
        let (start, end) = input.span();
        out.push(Surface {
            sensor: input.sensor().clone(),
            start,
            end,
            seq: input.seq(),
            grid: self.interp.grid.clone(),
            values,
        });
        Ok(())
    }

    fn reset(&mut self) {
        self.have_prev = false;
        self.since_refresh = 0;
    }

    fn delay(&self) -> Delay {
        Delay::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout(p: Vec<[f64; 2]>) -> Layout {
        let names = (0..p.len()).map(|i| format!("t{i}")).collect();
        Layout::try_new("test", names, p, None).unwrap()
    }

    #[test]
    fn grid_points_span_the_extent_exactly() {
        let e = Extent { x_min: -1.0, x_max: 2.0, y_min: 0.5, y_max: 1.5 };
        let g = Grid::try_new(e, 7, 3).unwrap();
        assert_eq!(g.x(0), -1.0);
        assert_eq!(g.x(6), 2.0);
        assert_eq!(g.y(2), 1.5);
        assert!((g.x(2) - 0.0).abs() < 1e-15);
        assert!(Grid::try_new(e, 1, 3).is_err());
        assert!(Grid::try_new(Extent { x_max: -1.0, ..e }, 3, 3).is_err());
    }

    #[test]
    fn square_layout_centre_and_corners() {
        let l = layout(vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]);
        let e = Extent { x_min: 0.0, x_max: 1.0, y_min: 0.0, y_max: 1.0 };
        let g = Arc::new(Grid::try_new(e, 3, 3).unwrap());
        for m in [Method::NaturalNeighbour, Method::Linear, Method::Nearest, Method::InverseDistance] {
            let it = Interpolator::try_new(&l, g.clone(), m, Outside::Nan, 2.0, 0.0).unwrap();
            let s = it.surface(&[1.0, 2.0, 3.0, 4.0]);
            // corners are taxels
            assert_eq!(s[[0, 0]], 1.0, "{m:?}");
            assert_eq!(s[[0, 2]], 2.0, "{m:?}");
            assert_eq!(s[[2, 0]], 3.0, "{m:?}");
            assert_eq!(s[[2, 2]], 4.0, "{m:?}");
            if m != Method::Nearest {
                // centre of a symmetric square: the mean for every symmetric method
                assert!((s[[1, 1]] - 2.5).abs() < 1e-12, "{m:?}: {}", s[[1, 1]]);
            }
            // every row's weights sum to 1
            for p in 0..g.len() {
                let sum: f64 = it.table().row(p).map(|(_, w)| w).sum();
                assert!((sum - 1.0).abs() < 1e-12, "{m:?} point {p}: {sum}");
            }
        }
    }

    #[test]
    fn outside_policies() {
        let l = layout(vec![[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]]);
        let e = Extent { x_min: 0.0, x_max: 2.0, y_min: 0.0, y_max: 2.0 };
        let g = Arc::new(Grid::try_new(e, 3, 3).unwrap());
        let v = [0.0, 2.0, 4.0]; // f = x + 2y
        let nan = Interpolator::try_new(&l, g.clone(), Method::NaturalNeighbour, Outside::Nan, 2.0, 0.0).unwrap();
        let s = nan.surface(&v);
        assert!(s[[2, 2]].is_nan()); // (2,2) outside the triangle
        assert_eq!(s[[1, 1]], 3.0); // (1,1) on the hull edge
        let fill = Interpolator::try_new(&l, g.clone(), Method::Linear, Outside::Fill, 2.0, -7.0).unwrap();
        assert_eq!(fill.surface(&v)[[2, 2]], -7.0);
        let ext = Interpolator::try_new(&l, g.clone(), Method::NaturalNeighbour, Outside::Extend, 2.0, 0.0).unwrap();
        // closest hull point of (2,2) is (1,1): value 3
        assert!((ext.surface(&v)[[2, 2]] - 3.0).abs() < 1e-12);
        // (2,1): closest hull point on edge (2,0)-(0,2) is (1.5, 0.5): 1.5 + 1 = 2.5
        assert!((ext.surface(&v)[[1, 2]] - 2.5).abs() < 1e-12);
    }

    #[test]
    fn weight_tables_are_built_once_per_layout_and_grid() {
        let l = Layout::biotac_sp();
        let cfg = InterpolateConfig { grid: GridConfig { nx: 19, ..Default::default() }, ..Default::default() };
        let a = Interpolator::from_config(&cfg, &l).unwrap();
        let b = Interpolator::from_config(&cfg, &l).unwrap();
        assert!(a.shares_table(&b));
        // every stage built from the config shares it too
        let st = Interpolate::<TaxelFrame>::try_new(&cfg, &l).unwrap();
        assert!(st.interpolator().shares_table(&a));
        // another grid, method or fill value is another table
        for other in [
            InterpolateConfig { grid: GridConfig { nx: 20, ..Default::default() }, ..cfg.clone() },
            InterpolateConfig { method: Method::Linear, ..cfg.clone() },
            InterpolateConfig { outside: Outside::Fill, fill_value: 1.0, ..cfg.clone() },
        ] {
            assert!(!Interpolator::from_config(&other, &l).unwrap().shares_table(&a), "{other:?}");
        }
    }

    #[test]
    fn incremental_surfaces_match_fresh_sums() {
        // many and few changed taxels per frame (the former take a fresh sum automatically)
        let l = Layout::biotac_sp();
        let cfg = InterpolateConfig { grid: GridConfig { nx: 24, ..Default::default() }, ..Default::default() };
        let mut inc =
            Interpolate::<TaxelFrame>::try_new(&InterpolateConfig { incremental: true, ..cfg.clone() }, &l).unwrap();
        let fresh = Interpolator::from_config(&cfg, &l).unwrap();
        let mut v = vec![0.0; 24];
        for k in 0..200u64 {
            if k % 7 == 0 {
                v.iter_mut().enumerate().for_each(|(i, x)| *x = ((i as u64 * 31 + k * 17) % 11) as f64 - 3.0);
            } else {
                v[(k * 5 % 24) as usize] += 1.5;
            }
            let f = TaxelFrame { sensor: SensorId::new("s"), time: Timestamp(k as i64), seq: k, values: v.clone() };
            let mut out = Vec::new();
            inc.push(f, &mut out).unwrap();
            let want = fresh.surface(&v);
            for (a, b) in out[0].values.iter().zip(want.iter()) {
                assert!(a.is_nan() && b.is_nan() || (a - b).abs() <= 1e-12 * (1.0 + b.abs()), "{a} vs {b}");
            }
        }
    }

    mod column_sums {
        use super::*;
        use proptest::prelude::*;

        proptest! {
            #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
            /// The column-run sum (`apply`, zero taxels skipped) is bit-identical to every
            /// point's row sum, for every method and outside policy.
            #[test]
            fn equal_row_sums_bit_for_bit(v in proptest::collection::vec(prop_oneof![
                Just(0.0),
                Just(-0.0),
                (-8i8..9).prop_map(f64::from),
                -1e6f64..1e6,
                -1e300f64..1e300,
            ], 24)) {
                for it in tables() {
                    let dense = it.surface(&v);
                    let mut via_vec = it.table().apply_to_vec(&v.iter().map(|x| x * 3.0 - 1.0).collect::<Vec<_>>());
                    it.table().apply_again(&v, &mut via_vec);
                    for (p, (&got, &alt)) in dense.as_slice().unwrap().iter().zip(&via_vec).enumerate() {
                        let want = it.table().value_at(p, &v);
                        prop_assert!(got.to_bits() == want.to_bits(), "point {}: {:e} vs {:e}", p, got, want);
                        prop_assert!(alt.to_bits() == want.to_bits());
                    }
                }
            }
        }
    }

    fn tables() -> &'static [Interpolator] {
        static ALL: std::sync::OnceLock<Vec<Interpolator>> = std::sync::OnceLock::new();
        ALL.get_or_init(|| {
            let l = Layout::biotac_sp();
            let mut out = Vec::new();
            for (method, outside) in [
                (Method::NaturalNeighbour, Outside::Nan),
                (Method::NaturalNeighbour, Outside::Extend),
                (Method::Linear, Outside::Fill),
                (Method::Nearest, Outside::Nan),
                (Method::InverseDistance, Outside::Fill),
            ] {
                let cfg = InterpolateConfig {
                    method,
                    outside,
                    fill_value: 0.25,
                    grid: GridConfig { nx: 64, ..Default::default() },
                    ..Default::default()
                };
                out.push(Interpolator::from_config(&cfg, &l).unwrap());
            }
            out
        })
    }

    #[test]
    fn degenerate_and_bad_config_refused() {
        let l = layout(vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
        let g = Arc::new(Grid::try_new(l.extent(), 4, 4).unwrap());
        let e = Interpolator::try_new(&l, g.clone(), Method::InverseDistance, Outside::Nan, 0.0, 0.0).unwrap_err();
        assert!(e.to_string().contains("power"), "{e}");
        let cfg = InterpolateConfig { refresh_every: 0, ..Default::default() };
        assert!(Interpolate::<TaxelFrame>::try_new(&cfg, &l).is_err());
    }
}
