//! Contour: iso-contours of a surface and the *maximal contour*, the region of touch
//! (method.md, stage 6).
//!
//! # What it does
//! - [`isolines`]: marching squares at one level with linear interpolation of the crossing
//!   along each cell edge — the same vertices as `skimage.measure.find_contours` (a point is
//!   *above* when `z > level`; squares with a NaN corner are skipped; the crossing on an edge is
//!   `p + (level − z_p)/(z_q − z_p)·(q − p)` with `p` the lower index). Saddle cells (two
//!   diagonal corners above) follow a [`Saddle`] rule, used consistently everywhere.
//! - [`MaxContourFinder`] / the [`Contour`] stage: the **maximal contour** is the highest level
//!   (of the configured [`Levels`]) at which the region above the level that contains the
//!   surface's peak has an area of at least [`ContourConfig::min_area_mm2`]. Reported: its
//!   boundary polygon (mm, counter-clockwise), holes, area (mm²), centroid (mm), orientation of
//!   the principal axis (rad), eccentricity, the level and the peak.
//!
//! **The search** goes down the levels from the highest. At each level the peak's component
//! of `{z > level}` (4-connected, plus the diagonals across saddle cells the saddle rule
//! joins) is found on grids of at most 64 × 64 points as one 64-bit mask per row: a row's
//! mask of points above is computed once per level (only for the rows the component reaches
//! and their neighbours), and a row's members are the runs of that mask holding a member of
//! the row above or below (or the diagonal neighbour of one across a joined saddle cell),
//! grown row against row with bit operations until nothing changes. Larger grids use a
//! scanline fill by horizontal runs. A level whose component covers fewer cells than
//! `min_area_mm2` needs (a rigorous upper bound of its area: the cells with a corner in the
//! component, widened for rounding) is skipped without marching. Otherwise the component is
//! marched over its bounding box — only the cells whose corners lie on both sides of the
//! level, found from the row masks (with row masks, values are read only at those cells'
//! corners) — its segments linked into rings and measured (Green's theorem). The outcome is
//! bit-identical to flooding, marching and measuring every level in turn (the reference the
//! tests compare against on random surfaces, narrow and wider than 64 columns).
//!
//! **Closing along the grid edge.** A region cut by the grid's edge, by NaN (outside the
//! hull under [`Outside::Nan`](crate::interpolate::Outside)) is closed *along* that edge:
//! outside the grid and at NaN the surface counts as −∞, so the boundary runs through the
//! last grid points that are above the level. Such a contour is flagged
//! [`MaxContour::clipped`]; its area and centroid describe the visible part only.
//!
//! **Peak and ties.** The peak is the largest finite value; ties go to the first grid point in
//! raster order (lowest row = lowest y, then lowest column = lowest x). With two equal peaks
//! the maximal contour is therefore the region around the first one — the other peak's region
//! is a separate component at that level and is not merged (a union's centroid would lie
//! between the two contacts, where nothing touches).
//!
//! **No contact** is data ([`ContourOutcome::NoContact`]): no finite value, a peak below
//! [`ContourConfig::min_peak`], a flat surface, or no level with a region of non-trivial area.
//!
//! # Units
//! Coordinates in mm (the grid's), areas in mm², angles in radians measured from +x toward +y
//! in `(−π/2, π/2]`; levels and peak in surface units.
//!
//! # Delay
//! None: one [`ContourFrame`] per surface.
//!
//! # Trade-offs
//! | option | faster | more accurate / robust |
//! |---|---|---|
//! | `levels` | few levels (coarse area steps) | many levels (the maximal contour hugs the peak more tightly) |
//! | `min_area_mm2` | — | small: the region hugs the busiest taxel (a surface of non-negative values peaks *at* a taxel, so the location snaps toward taxels); large: the centroid averages more of the surface. Synthetic contact moving over the BioTac SP (`tests/spatial_pipeline.rs`): mean location error 1.55 mm at 1 mm², 0.90 mm at 15 mm² |
//! | `peak_only` | `true`: march only the peak region's bounding box (64 × 64 event surface: 2.0–2.4 µs) | `false`: march the whole grid (identical result, a cross-check: 36–39 µs) |
//! | `saddle` | — | `centre` (mean of the corners) follows the bilinear surface best |
//! | grid size | small | large (sub-cell interpolation already makes areas second-order accurate) |

use crate::interpolate::{Grid, Surface};
use crate::Error;
use gradtac_stream::{Delay, HasSensor, SensorId, Stage, Timed, Timestamp};
use ndarray::ArrayView2;
use serde::{Deserialize, Serialize};

const STAGE: &str = "contour";

/// How a saddle cell (two diagonal corners above the level, two below) is split.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Saddle {
    /// The corners above are joined when the mean of the four corners is above the level
    /// (the bilinear surface's value at the cell centre); otherwise they are separated.
    #[default]
    Centre,
    /// Corners above are always joined (skimage `fully_connected="high"`).
    High,
    /// Corners above are always separated (skimage's default, `fully_connected="low"`).
    Low,
}

impl Saddle {
    fn joins_above(self, z: [f64; 4], level: f64) -> bool {
        match self {
            Saddle::High => true,
            Saddle::Low => false,
            Saddle::Centre => (z[0] + z[1] + z[2] + z[3]) * 0.25 > level,
        }
    }
}

/// Contour levels.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Levels {
    /// `n` levels evenly spaced strictly between the surface's finite minimum and maximum:
    /// `min + k·(max − min)/(n + 1)` for `k = 1..=n` (recomputed for every surface).
    Count(usize),
    /// Explicit levels in surface units (any order).
    Explicit(Vec<f64>),
}

impl Default for Levels {
    fn default() -> Self {
        Levels::Count(10)
    }
}

/// Configuration of the [`Contour`] stage (`[stages.contour]` in a scene).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ContourConfig {
    /// Levels: a count (`levels = 10`, evenly spaced) or a list (`levels = [1.0, 2.0]`).
    /// Default 10.
    pub levels: Levels,
    /// Smallest area (mm²) a region must have to count as the maximal contour. Default 1.
    pub min_area_mm2: f64,
    /// Smallest peak (surface units) for a contact; below it the frame is "no contact".
    /// Default 1 (one event, for window aggregates).
    pub min_peak: f64,
    /// Saddle rule. Default `centre`.
    pub saddle: Saddle,
    /// March only the bounding box of the peak's region (same result, faster). Default true.
    pub peak_only: bool,
}

impl Default for ContourConfig {
    fn default() -> Self {
        ContourConfig {
            levels: Levels::Count(10),
            min_area_mm2: 1.0,
            min_peak: 1.0,
            saddle: Saddle::Centre,
            peak_only: true,
        }
    }
}

/// One iso-line in fractional index coordinates `[col, row]` (x, y).
#[derive(Clone, Debug, PartialEq)]
pub struct Isoline {
    /// Vertices; a closed line does not repeat its first vertex.
    pub points: Vec<[f64; 2]>,
    /// Whether the line closes on itself.
    pub closed: bool,
}

/// The maximal contour of one surface.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MaxContour {
    /// The level (surface units).
    pub level: f64,
    /// Outer boundary (mm), counter-clockwise, first vertex not repeated.
    pub polygon: Vec<[f64; 2]>,
    /// Boundaries of holes (mm), clockwise.
    pub holes: Vec<Vec<[f64; 2]>>,
    /// Area of the region (mm²), holes excluded.
    pub area_mm2: f64,
    /// Area centroid (mm): the contact location.
    pub centroid_mm: [f64; 2],
    /// Angle of the principal (major) axis of the region's second moments (rad, from +x toward
    /// +y, in `(−π/2, π/2]`); meaningless when `eccentricity` is near 0 (a round region).
    pub orientation_rad: f64,
    /// `√(1 − λ_min/λ_max)` of the second-moment eigenvalues: 0 round, → 1 elongated.
    pub eccentricity: f64,
    /// The surface's peak value.
    pub peak: f64,
    /// Where the peak is (mm, a grid point).
    pub peak_mm: [f64; 2],
    /// True when the region was closed along the grid edge or a NaN (outside-hull) boundary
    /// (for `method = "fit"`: the fitted position hit the layout's extent).
    pub clipped: bool,
    /// What the model fit says about the point (`method = "fit"`); `None` for the other methods.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit: Option<crate::fit::FitSummary>,
}

/// Why a surface has no contact.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoContact {
    /// No finite value on the surface (or a value of ±∞).
    NoData,
    /// The peak is below `min_peak`.
    BelowMinPeak,
    /// The surface is flat (max == min) or no level lies below its peak.
    Flat,
    /// No level's region reaches `min_area_mm2`.
    TooSmall,
}

/// The result for one surface: a contact region or the reason there is none.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum ContourOutcome {
    /// The maximal contour.
    Contact(MaxContour),
    /// No contact, and why.
    NoContact(NoContact),
}

impl ContourOutcome {
    /// The contour, if any.
    pub fn contact(&self) -> Option<&MaxContour> {
        match self {
            ContourOutcome::Contact(c) => Some(c),
            ContourOutcome::NoContact(_) => None,
        }
    }
}

/// The output of the [`Contour`] stage for one surface.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContourFrame {
    /// The sensor.
    pub sensor: SensorId,
    /// Start of the surface's time span.
    pub start: Timestamp,
    /// End of the span.
    pub end: Timestamp,
    /// Index of the newest source frame.
    pub seq: u64,
    /// The maximal contour or why there is none.
    pub outcome: ContourOutcome,
}

impl Timed for ContourFrame {
    fn time(&self) -> Timestamp {
        self.end
    }
}

impl HasSensor for ContourFrame {
    fn sensor(&self) -> &SensorId {
        &self.sensor
    }
}

// ---------------------------------------------------------------------------------------------
// marching squares core

#[derive(Clone, Copy, Debug)]
struct Seg {
    from: u32,
    to: u32,
    a: [f64; 2],
    b: [f64; 2],
}

/// Inclusive window of grid points.
#[derive(Clone, Copy, Debug, Default)]
struct Win {
    c0: usize,
    c1: usize,
    r0: usize,
    r1: usize,
}

impl Win {
    /// The box grown by one point on every side, clipped to an `nx` × `ny` grid.
    fn grown(self, nx: usize, ny: usize) -> Win {
        Win {
            c0: self.c0.saturating_sub(1),
            c1: (self.c1 + 1).min(nx - 1),
            r0: self.r0.saturating_sub(1),
            r1: (self.r1 + 1).min(ny - 1),
        }
    }
}

#[derive(Default, Debug, Clone)]
struct Scratch {
    vals: Vec<f64>,
    segs: Vec<Seg>,
    start_of: Vec<u32>,
    end_of: Vec<u32>,
    used: Vec<bool>,
    stamp: Vec<u32>,
    gen: u32,
    stack: Vec<(usize, usize)>,
    clipped: bool,
    // the last component's bounding box and member count
    bbox: Win,
    members: usize,
    // per local row of `vals`, bit `lc` set when that value is above the level (windows of at
    // most 64 local columns)
    up_rows: Vec<u128>,
    // per grid row (grids of at most 64 columns): bit `c` set when the point is above the
    // level (`a_rows`, valid where `a_known` holds the level's generation) and when it is in
    // the peak's component (`c_rows`)
    a_rows: Vec<u64>,
    a_known: Vec<u32>,
    a_gen: u32,
    c_rows: Vec<u64>,
}

/// A fresh generation of `marks` (a slot is marked when it holds the current generation, so
/// a new generation unmarks every slot at once) for `len` slots: the marks resized (and
/// cleared) when `len` changed, cleared when the generation counter wraps.
fn next_generation(marks: &mut Vec<u32>, gen: &mut u32, len: usize) -> u32 {
    if marks.len() != len {
        marks.clear();
        marks.resize(len, 0);
        *gen = 0;
    }
    *gen = gen.wrapping_add(1);
    if *gen == 0 {
        marks.iter_mut().for_each(|x| *x = 0);
        *gen = 1;
    }
    *gen
}

impl Scratch {
    /// A fresh stamp generation for a grid of `points` points ([`next_generation`]).
    fn next_generation(&mut self, points: usize) -> u32 {
        next_generation(&mut self.stamp, &mut self.gen, points)
    }
}

const NONE: u32 = u32::MAX;

/// Read access to a surface's values by `(row, col)`: an array, or a surface evaluated lazily
/// (only the points the maximal contour looks at, see [`crate::peak`]): `prepare` a rectangle,
/// then read it with `raw`.
pub(crate) trait Field {
    /// `(rows, cols)`.
    fn dim(&self) -> (usize, usize);
    /// Make every point of rows `r0..=r1`, columns `c0..=c1` readable by [`raw`](Self::raw).
    #[inline(always)]
    fn prepare(&mut self, _r0: usize, _r1: usize, _c0: usize, _c1: usize) {}
    /// The value at `(r, c)`, which a [`prepare`](Self::prepare) covered.
    fn raw(&self, r: usize, c: usize) -> f64;
    /// Bit `c` set when point `(r, c)` is above `level` (NaN never is), for a grid of at most
    /// 64 columns; prepares the row first.
    #[inline(always)]
    fn row_above(&mut self, r: usize, level: f64) -> u64 {
        let nx = self.dim().1;
        self.prepare(r, r, 0, nx - 1);
        (0..nx).fold(0u64, |m, c| m | ((self.raw(r, c) > level) as u64) << c)
    }
}

/// A row-major surface in a slice.
struct Dense<'a> {
    z: &'a [f64],
    nx: usize,
    ny: usize,
}

impl Field for Dense<'_> {
    #[inline(always)]
    fn dim(&self) -> (usize, usize) {
        (self.ny, self.nx)
    }
    #[inline(always)]
    fn raw(&self, r: usize, c: usize) -> f64 {
        self.z[r * self.nx + c]
    }
    #[inline(always)]
    fn row_above(&mut self, r: usize, level: f64) -> u64 {
        let row = &self.z[r * self.nx..(r + 1) * self.nx];
        let chunks = row.chunks_exact(8);
        let rest = chunks.remainder();
        let mut m = 0u64;
        for (k, ch) in chunks.enumerate() {
            // one byte 0/1 per value, gathered into 8 bits by a multiplication (exact: every
            // partial product lands on a distinct bit, the wanted ones at bits 56..64)
            let mut bytes = [0u8; 8];
            for (b, &x) in bytes.iter_mut().zip(ch) {
                *b = (x > level) as u8;
            }
            let b = u64::from_le_bytes(bytes).wrapping_mul(0x0102_0408_1020_4080) >> 56;
            m |= b << (8 * k);
        }
        let base = row.len() - rest.len();
        for (j, &x) in rest.iter().enumerate() {
            m |= ((x > level) as u64) << (base + j);
        }
        m
    }
}

impl Field for ArrayView2<'_, f64> {
    #[inline(always)]
    fn dim(&self) -> (usize, usize) {
        ArrayView2::dim(self)
    }
    #[inline(always)]
    fn raw(&self, r: usize, c: usize) -> f64 {
        self[[r, c]]
    }
}

/// March the cells of a window. `pad`: the window is surrounded by −∞ and NaN counts as −∞
/// (closed rings); otherwise squares with a NaN corner are skipped (skimage's rule).
/// `comp`: when given, points above the level that are not members of the component count as −∞.
fn march<F: Field>(
    z: &mut F,
    level: f64,
    saddle: Saddle,
    w: Win,
    pad: bool,
    comp: Option<Member<'_>>,
    s: &mut Scratch,
) {
    let nx = z.dim().1;
    let width = (w.c1 - w.c0 + 3) as i64; // local columns -1 ..= c1-c0+1
    let height = (w.r1 - w.r0 + 3) as i64;
    // the link tables hold NONE except at the previous march's segments: clear just those
    for g in &s.segs {
        s.start_of[g.from as usize] = NONE;
        s.end_of[g.to as usize] = NONE;
    }
    s.segs.clear();
    s.clipped = false;
    // the window's values once, surrounded by a ring of −∞, with NaN and (given `comp`) other
    // components' points above the level replaced by −∞
    s.vals.clear();
    if !matches!(comp, Some(Member::Rows(_)) if pad) {
        s.vals.resize((width * height) as usize, f64::NEG_INFINITY);
    }
    z.prepare(w.r0, w.r1, w.c0, w.c1);
    // with a padded window of ≤ 64 columns, the cells with corners on both sides of the level
    // are found from bit masks of the points above, and only they are visited; with the
    // component as row masks, those masks are the component's and the values are read from
    // `z` only at the visited cells' corners (`vals` stays empty)
    let rows = match comp {
        Some(Member::Rows(rows)) if pad => Some(rows),
        _ => None,
    };
    let masks = pad && (width <= 64 || rows.is_some());
    s.up_rows.clear();
    s.up_rows.resize(if masks { height as usize } else { 0 }, 0);
    if let Some(rows) = rows {
        let keep = (1u128 << (w.c1 - w.c0 + 1)) - 1;
        for (up, &m) in s.up_rows[1..].iter_mut().zip(&rows[w.r0..=w.r1]) {
            *up = ((m >> w.c0) as u128 & keep) << 1;
        }
    } else {
        for r in w.r0..=w.r1 {
            let lr = (r - w.r0 + 1) * width as usize;
            let mut up = 0u64;
            for c in w.c0..=w.c1 {
                let mut v = z.raw(r, c);
                if v.is_nan() {
                    v = if pad { f64::NEG_INFINITY } else { f64::NAN };
                } else if let Some(m) = comp {
                    if v > level && !m.has(r, r * nx + c, c) {
                        v = f64::NEG_INFINITY;
                    }
                }
                s.vals[lr + (c - w.c0 + 1)] = v;
                up |= ((v > level) as u64) << ((c - w.c0 + 1) & 63);
            }
            if masks {
                s.up_rows[r - w.r0 + 1] = up as u128;
            }
        }
    }
    // a point's value as marched (only with `rows`): −∞ outside the window and at NaN and at
    // points above the level that are not members
    let lazy = |z: &F, c: i64, r: i64| -> f64 {
        let rows = rows.expect("lazy values with row masks");
        if c < w.c0 as i64 || c > w.c1 as i64 || r < w.r0 as i64 || r > w.r1 as i64 {
            return f64::NEG_INFINITY;
        }
        let (r, c) = (r as usize, c as usize);
        let v = z.raw(r, c);
        if rows[r] >> c & 1 == 1 {
            v
        } else if v.is_nan() || v > level {
            f64::NEG_INFINITY
        } else {
            v
        }
    };
    let vals = std::mem::take(&mut s.vals);
    let val = |c: i64, r: i64| -> f64 {
        let lc = c - (w.c0 as i64 - 1);
        let lr = r - (w.r0 as i64 - 1);
        vals[(lr * width + lc) as usize]
    };
    // local edge ids: horizontal edge from (c,r) to (c+1,r): 2·idx; vertical (c,r)→(c,r+1): 2·idx+1
    let id = |c: i64, r: i64, vertical: bool| -> u32 {
        let lc = c - (w.c0 as i64 - 1);
        let lr = r - (w.r0 as i64 - 1);
        (2 * (lr * width + lc) + vertical as i64) as u32
    };
    let (cs, ce, rs, re) = if pad {
        (w.c0 as i64 - 1, w.c1 as i64, w.r0 as i64 - 1, w.r1 as i64)
    } else {
        (w.c0 as i64, w.c1 as i64 - 1, w.r0 as i64, w.r1 as i64 - 1)
    };
    let mut clipped = false;
    let mut frac = |a: f64, b: f64| -> f64 {
        if a == f64::NEG_INFINITY {
            clipped = true;
            1.0
        } else if b == f64::NEG_INFINITY {
            clipped = true;
            0.0
        } else if a == b {
            0.0
        } else {
            (level - a) / (b - a)
        }
    };
    for r in rs..=re {
        // the two rows of the cells' corners (local columns from `cs`)
        let at = |c: i64, r: i64| ((r - (w.r0 as i64 - 1)) * width + c - (w.c0 as i64 - 1)) as usize;
        let n = (ce - cs + 2) as usize;
        let (top, bottom) = if rows.is_some() {
            (&[][..], &[][..])
        } else {
            (&vals[at(cs, r)..at(cs, r) + n], &vals[at(cs, r + 1)..at(cs, r + 1) + n])
        };
        // the cells to visit, in increasing column: with masks, those whose corners are not all
        // on one side (bit i: cell i), else every cell
        let cells = n - 1;
        let mut mixed = if masks {
            let lr = (r - (w.r0 as i64 - 1)) as usize;
            let (t, b) = (s.up_rows[lr], s.up_rows[lr + 1]);
            let m = (t ^ (t >> 1)) | (b ^ (b >> 1)) | (t ^ b);
            if cells >= 128 {
                m
            } else {
                m & ((1u128 << cells) - 1)
            }
        } else {
            0
        };
        let mut next = 0usize;
        loop {
            let i = if masks {
                if mixed == 0 {
                    break;
                }
                let i = mixed.trailing_zeros() as usize;
                mixed &= mixed - 1;
                i
            } else {
                if next == cells {
                    break;
                }
                next += 1;
                next - 1
            };
            let c = cs + i as i64;
            // corners counter-clockwise in (x = col, y = row): (c,r) (c+1,r) (c+1,r+1) (c,r+1)
            let v = if rows.is_some() {
                [lazy(z, c, r), lazy(z, c + 1, r), lazy(z, c + 1, r + 1), lazy(z, c, r + 1)]
            } else {
                [top[i], top[i + 1], bottom[i + 1], bottom[i]]
            };
            debug_assert!(
                rows.is_some()
                    || v.map(f64::to_bits)
                        == [val(c, r), val(c + 1, r), val(c + 1, r + 1), val(c, r + 1)].map(f64::to_bits)
            );
            if !pad && v.iter().any(|x| x.is_nan()) {
                continue;
            }
            let up = [v[0] > level, v[1] > level, v[2] > level, v[3] > level];
            let case = up[0] as u8 | (up[1] as u8) << 1 | (up[2] as u8) << 2 | (up[3] as u8) << 3;
            if case == 0 || case == 15 {
                continue;
            }
            // edge k joins corner k to corner k+1; canonical direction = increasing index
            let edge_pt = |k: usize, frac: &mut dyn FnMut(f64, f64) -> f64| -> (u32, [f64; 2]) {
                let (cf, rf) = (c as f64, r as f64);
                match k {
                    0 => (id(c, r, false), [cf + frac(v[0], v[1]), rf]),
                    1 => (id(c + 1, r, true), [cf + 1.0, rf + frac(v[1], v[2])]),
                    2 => (id(c, r + 1, false), [cf + frac(v[3], v[2]), rf + 1.0]),
                    _ => (id(c, r, true), [cf, rf + frac(v[0], v[3])]),
                }
            };
            let exit = |k: usize| up[k] && !up[(k + 1) % 4];
            let entry = |k: usize| !up[k] && up[(k + 1) % 4];
            if case == 5 || case == 10 {
                let joined = saddle.joins_above(v, level);
                for k in (0..4).filter(|&k| exit(k)) {
                    let e = if joined { (k + 1) % 4 } else { (k + 3) % 4 };
                    let (from, a) = edge_pt(k, &mut frac);
                    let (to, b) = edge_pt(e, &mut frac);
                    s.segs.push(Seg { from, to, a, b });
                }
            } else {
                let k = (0..4).find(|&k| exit(k)).expect("a mixed cell has an exit");
                let e = (0..4).find(|&k| entry(k)).expect("a mixed cell has an entry");
                let (from, a) = edge_pt(k, &mut frac);
                let (to, b) = edge_pt(e, &mut frac);
                s.segs.push(Seg { from, to, a, b });
            }
        }
    }
    s.clipped = clipped;
    s.vals = vals;
    let n_ids = (2 * width * height) as usize;
    if s.start_of.len() < n_ids {
        s.start_of.resize(n_ids, NONE);
        s.end_of.resize(n_ids, NONE);
    }
    for (i, g) in s.segs.iter().enumerate() {
        s.start_of[g.from as usize] = i as u32;
        s.end_of[g.to as usize] = i as u32;
    }
}

/// The members of a component: stamped with a generation, or bits of per-row masks.
#[derive(Clone, Copy)]
enum Member<'a> {
    Stamp(&'a [u32], u32),
    Rows(&'a [u64]),
}

impl Member<'_> {
    /// Whether point `(r, c)` (raster index `i`) is a member.
    #[inline(always)]
    fn has(self, r: usize, i: usize, c: usize) -> bool {
        match self {
            Member::Stamp(stamp, gen) => stamp[i] == gen,
            Member::Rows(rows) => rows[r] >> c & 1 == 1,
        }
    }
}

/// The bits of `a` in the runs of consecutive bits of `a` that hold a bit of `s` (an occluded
/// fill both ways, Kogge–Stone).
#[inline(always)]
fn fill_runs(a: u64, s: u64) -> u64 {
    let x = s & a;
    let (mut g, mut up) = (a, x);
    up |= g & (up << 1);
    g &= g << 1;
    up |= g & (up << 2);
    g &= g << 2;
    up |= g & (up << 4);
    g &= g << 4;
    up |= g & (up << 8);
    g &= g << 8;
    up |= g & (up << 16);
    g &= g << 16;
    up |= g & (up << 32);
    let (mut g, mut down) = (a, x);
    down |= g & (down >> 1);
    g &= g >> 1;
    down |= g & (down >> 2);
    g &= g >> 2;
    down |= g & (down >> 4);
    g &= g >> 4;
    down |= g & (down >> 8);
    g &= g >> 8;
    down |= g & (down >> 16);
    g &= g >> 16;
    down |= g & (down >> 32);
    up | down
}

/// Link the segments of the last [`march`] into lines.
fn link(s: &mut Scratch) -> Vec<Isoline> {
    let n = s.segs.len();
    s.used.clear();
    s.used.resize(n, false);
    let mut lines = Vec::new();
    // segments not yet in a line: a line has at most that many points plus one, so its points
    // are allocated once (a maximal contour is usually one ring holding every segment)
    let mut left = n;
    // open lines start where no segment ends
    for i in 0..n {
        if s.end_of[s.segs[i].from as usize] == NONE {
            lines.push(follow(s, i, false, &mut left));
        }
    }
    for i in 0..n {
        if !s.used[i] {
            lines.push(follow(s, i, true, &mut left));
        }
    }
    lines
}

fn follow(s: &mut Scratch, first: usize, closed: bool, left: &mut usize) -> Isoline {
    let mut pts = Vec::with_capacity(*left + 1);
    let mut i = first;
    loop {
        *left -= 1;
        s.used[i] = true;
        let g = s.segs[i];
        pts.push(g.a);
        let next = s.start_of[g.to as usize];
        if next == NONE {
            pts.push(g.b);
            return Isoline { points: pts, closed: false };
        }
        if next as usize == first || s.used[next as usize] {
            return Isoline { points: pts, closed };
        }
        i = next as usize;
    }
}

/// The iso-lines of `z` at `level` in fractional index coordinates `[col, row]`, with
/// scikit-image's conventions (see the [module docs](self)): lines that reach the array's edge
/// or a NaN square stay open.
pub fn isolines(z: ArrayView2<'_, f64>, level: f64, saddle: Saddle) -> Vec<Isoline> {
    let (ny, nx) = z.dim();
    if nx < 2 || ny < 2 {
        return Vec::new();
    }
    let mut s = Scratch::default();
    let mut z = z;
    march(&mut z, level, saddle, Win { c0: 0, c1: nx - 1, r0: 0, r1: ny - 1 }, false, None, &mut s);
    link(&mut s)
}

/// The closed boundaries of `{z > level}` (NaN and outside the array count as −∞, so regions
/// are closed along the edge), in index coordinates; outer boundaries counter-clockwise
/// (positive area), holes clockwise.
pub fn region_boundaries(z: ArrayView2<'_, f64>, level: f64, saddle: Saddle) -> Vec<Vec<[f64; 2]>> {
    let (ny, nx) = z.dim();
    if nx == 0 || ny == 0 {
        return Vec::new();
    }
    let mut s = Scratch::default();
    let mut z = z;
    march(&mut z, level, saddle, Win { c0: 0, c1: nx - 1, r0: 0, r1: ny - 1 }, true, None, &mut s);
    link(&mut s).into_iter().map(|l| l.points).collect()
}

/// Area, first and second moments of a polygon relative to `o` (Green's theorem; signed by
/// orientation): `[A, ∫x, ∫y, ∫x², ∫xy, ∫y²]`.
fn moments(p: &[[f64; 2]], o: [f64; 2]) -> [f64; 6] {
    let mut m = [0.0; 6];
    let n = p.len();
    for i in 0..n {
        let (x0, y0) = (p[i][0] - o[0], p[i][1] - o[1]);
        let (x1, y1) = (p[(i + 1) % n][0] - o[0], p[(i + 1) % n][1] - o[1]);
        let c = x0 * y1 - x1 * y0;
        m[0] += c;
        m[1] += (x0 + x1) * c;
        m[2] += (y0 + y1) * c;
        m[3] += (x0 * x0 + x0 * x1 + x1 * x1) * c;
        m[4] += (x0 * y1 + 2.0 * x0 * y0 + 2.0 * x1 * y1 + x1 * y0) * c;
        m[5] += (y0 * y0 + y0 * y1 + y1 * y1) * c;
    }
    [m[0] / 2.0, m[1] / 6.0, m[2] / 6.0, m[3] / 12.0, m[4] / 24.0, m[5] / 12.0]
}

/// Signed area of a polygon (positive counter-clockwise).
pub fn polygon_area(p: &[[f64; 2]]) -> f64 {
    moments(p, p.first().copied().unwrap_or([0.0; 2]))[0]
}

/// Finds maximal contours; holds scratch buffers so repeated calls do not allocate much.
#[derive(Clone, Debug)]
pub struct MaxContourFinder {
    cfg: ContourConfig,
    s: Scratch,
    levels: Vec<f64>,
    // tests: search levels the way first written (the exactness reference)
    reference: bool,
    // the last component was found as row masks (`Scratch::c_rows`), not stamps
    bits: bool,
}

impl MaxContourFinder {
    /// Validates the configuration: at least one level, finite levels, finite non-negative
    /// `min_area_mm2`, finite `min_peak`.
    pub fn try_new(cfg: &ContourConfig) -> crate::Result<Self> {
        let bad = |reason: String| Err(Error::InvalidConfig { stage: STAGE, reason });
        match &cfg.levels {
            Levels::Count(0) => return bad("`levels` must be ≥ 1".into()),
            Levels::Count(n) if *n > 100_000 => return bad(format!("{n} levels is too many (≤ 100000)")),
            Levels::Explicit(v) if v.is_empty() => return bad("`levels` is an empty list".into()),
            Levels::Explicit(v) if v.iter().any(|x| !x.is_finite()) => {
                return bad(format!("`levels` {v:?} must be finite"))
            }
            _ => {}
        }
        let area = crate::limits::MAX_MM * crate::limits::MAX_MM;
        if !(cfg.min_area_mm2.is_finite() && cfg.min_area_mm2 >= 0.0 && cfg.min_area_mm2 <= area) {
            return bad(format!("`min_area_mm2` = {} must be finite, ≥ 0 and ≤ {area:e}", cfg.min_area_mm2));
        }
        if !cfg.min_peak.is_finite() {
            return bad(format!("`min_peak` = {} must be finite", cfg.min_peak));
        }
        Ok(MaxContourFinder {
            cfg: cfg.clone(),
            s: Scratch::default(),
            levels: Vec::new(),
            reference: false,
            bits: false,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &ContourConfig {
        &self.cfg
    }

    /// The maximal contour of `z` (shape `(ny, nx)` matching `grid`).
    ///
    /// # Panics
    /// If the shape of `z` is not the grid's (the [`Contour`] stage checks this and returns an
    /// error instead).
    pub fn find(&mut self, z: ArrayView2<'_, f64>, grid: &Grid) -> ContourOutcome {
        let (ny, nx) = z.dim();
        assert_eq!((ny, nx), (grid.ny(), grid.nx()), "surface shape must match its grid");
        match z.as_slice() {
            Some(sl) => self.find_slice(sl, grid),
            None => {
                let v: Vec<f64> = z.iter().copied().collect();
                self.find_slice(&v, grid)
            }
        }
    }

    /// The maximal contour of a row-major surface `z` (`grid.len()` values), as
    /// [`find`](Self::find).
    ///
    /// # Panics
    /// If `z.len() != grid.len()`.
    pub fn find_slice(&mut self, z: &[f64], grid: &Grid) -> ContourOutcome {
        self.find_slice_in(z, &whole_chunks(z.len()), grid)
    }

    /// As [`find_slice`](Self::find_slice) for a surface whose values outside the chunk
    /// `ranges` (see [`scan_in`]) are all NaN: the peak and minimum are looked for in the
    /// ranges only. The outcome is identical.
    pub(crate) fn find_slice_in(&mut self, z: &[f64], ranges: &[(u32, u32)], grid: &Grid) -> ContourOutcome {
        let (ny, nx) = (grid.ny(), grid.nx());
        assert_eq!(z.len(), nx * ny, "surface length must match its grid");
        // peak (first in raster order) and finite minimum
        let (mut zmax, mut zmin, mut at) = (f64::NEG_INFINITY, f64::INFINITY, usize::MAX);
        scan_in(z, ranges, &mut zmax, &mut zmin, &mut at);
        self.find_in(&mut Dense { z, nx, ny }, grid, zmax, zmin, at)
    }

    /// The maximal contour given the surface's finite maximum `zmax` (first at raster index
    /// `at`, `usize::MAX` when there is no finite value) and finite minimum `zmin`; reads only
    /// the points it needs from `z`.
    pub(crate) fn find_in<F: Field>(
        &mut self,
        z: &mut F,
        grid: &Grid,
        zmax: f64,
        zmin: f64,
        at: usize,
    ) -> ContourOutcome {
        let nx = z.dim().1;
        if at == usize::MAX || zmax == f64::INFINITY || zmin == f64::NEG_INFINITY {
            // no finite value, or ±∞ (which no level can split)
            return ContourOutcome::NoContact(NoContact::NoData);
        }
        if zmax < self.cfg.min_peak {
            return ContourOutcome::NoContact(NoContact::BelowMinPeak);
        }
        if zmax <= zmin {
            return ContourOutcome::NoContact(NoContact::Flat);
        }
        let (pr, pc) = (at / nx, at % nx);
        self.levels.clear();
        match &self.cfg.levels {
            Levels::Count(n) => {
                let range = zmax - zmin;
                let m = *n as f64 + 1.0;
                if range.is_finite() {
                    self.levels.extend((1..=*n).map(|k| zmin + k as f64 * (range / m)));
                } else {
                    // a range beyond f64 (|z| near 1.8e308): the same levels as convex combinations
                    self.levels.extend((1..=*n).map(|k| zmin * (1.0 - k as f64 / m) + zmax * (k as f64 / m)));
                }
            }
            Levels::Explicit(v) => self.levels.extend(v.iter().copied()),
        }
        self.levels.retain(|&l| l < zmax);
        if self.levels.is_empty() {
            return ContourOutcome::NoContact(NoContact::Flat);
        }
        self.levels.retain(|l| l.is_finite());
        self.levels.sort_by(|a, b| b.total_cmp(a));
        self.levels.dedup();
        let levels = std::mem::take(&mut self.levels);
        let result = if cfg!(test) && self.reference {
            self.levels_reference(z, grid, &levels, zmax, pr, pc)
        } else {
            self.levels_fast(z, grid, &levels, zmax, pr, pc)
        };
        self.levels = levels;
        result
    }

    /// The level search: at each level the peak's component is found by horizontal runs
    /// ([`component_runs`](Self::component_runs)), the level is skipped when a rigorous upper
    /// bound of its region's area is under `min_area_mm2`, and only the other levels are
    /// marched, linked and measured — exactly as [`levels_reference`](Self::levels_reference)
    /// does for every level.
    fn levels_fast<F: Field>(
        &mut self,
        z: &mut F,
        grid: &Grid,
        levels: &[f64],
        zmax: f64,
        pr: usize,
        pc: usize,
    ) -> ContourOutcome {
        let (ny, nx) = z.dim();
        let cell = grid.cell_area();
        self.bits = nx <= 64 && ny <= 64;
        for &level in levels {
            let w =
                if self.bits { self.component_bits(z, level, pr, pc) } else { self.component_runs(z, level, pr, pc) };
            // The region lies in the cells with a corner in the component: at most 4 per point
            // and at most the cells of its bounding box grown by one. The reference's area is
            // a float sum of at most 2 terms per cell, each of magnitude ≤ 2·(nx + ny)² (index
            // units about the peak), so it exceeds the true area by at most `slack`.
            let b = self.s.bbox;
            let cells = (4 * self.s.members).min((b.c1 - b.c0 + 2) * (b.r1 - b.r0 + 2)) as f64;
            let span = (nx + ny + 2) as f64;
            let slack = (2.0 * cells).powi(2) * f64::EPSILON * 2.0 * span * span;
            if (cells + slack) * cell * (1.0 + 4.0 * f64::EPSILON) < self.cfg.min_area_mm2 {
                continue;
            }
            let win = if self.cfg.peak_only { w } else { Win { c0: 0, c1: nx - 1, r0: 0, r1: ny - 1 } };
            if let Some(c) = self.contour_at(z, grid, level, win, zmax, pr, pc) {
                return ContourOutcome::Contact(c);
            }
        }
        ContourOutcome::NoContact(NoContact::TooSmall)
    }

    /// The level search as first written (the exactness reference of the tests): for every
    /// level, flood the peak's component afresh, march, link and measure.
    fn levels_reference<F: Field>(
        &mut self,
        z: &mut F,
        grid: &Grid,
        levels: &[f64],
        zmax: f64,
        pr: usize,
        pc: usize,
    ) -> ContourOutcome {
        let (ny, nx) = z.dim();
        self.bits = false;
        for &level in levels {
            let w = self.component(z, level, pr, pc);
            let win = if self.cfg.peak_only { w } else { Win { c0: 0, c1: nx - 1, r0: 0, r1: ny - 1 } };
            if let Some(c) = self.contour_at(z, grid, level, win, zmax, pr, pc) {
                return ContourOutcome::Contact(c);
            }
        }
        ContourOutcome::NoContact(NoContact::TooSmall)
    }

    /// March the stamped component at `level` over `win`, link its rings and measure them: the
    /// maximal contour when its area reaches `min_area_mm2`.
    #[allow(clippy::too_many_arguments)]
    fn contour_at<F: Field>(
        &mut self,
        z: &mut F,
        grid: &Grid,
        level: f64,
        win: Win,
        zmax: f64,
        pr: usize,
        pc: usize,
    ) -> Option<MaxContour> {
        let cell = grid.cell_area();
        let peak_mm = [grid.x(pc), grid.y(pr)];
        let gen = self.s.gen;
        let stamp = std::mem::take(&mut self.s.stamp);
        let c_rows = std::mem::take(&mut self.s.c_rows);
        let member = if self.bits { Member::Rows(&c_rows) } else { Member::Stamp(&stamp, gen) };
        march(z, level, self.cfg.saddle, win, true, Some(member), &mut self.s);
        self.s.stamp = stamp;
        self.s.c_rows = c_rows;
        let clipped = self.s.clipped;
        let rings = link(&mut self.s);
        // moments in index units about the peak, scaled to mm afterwards
        // (x_mm = x_min + dx·col, y_mm = y_min + dy·row)
        let origin = [pc as f64, pr as f64];
        let mut outer = (0usize, f64::NEG_INFINITY);
        let mut m = [0.0; 6];
        for (i, r) in rings.iter().enumerate() {
            let mi = moments(&r.points, origin);
            if mi[0] > outer.1 {
                outer = (i, mi[0]);
            }
            for k in 0..6 {
                m[k] += mi[k];
            }
        }
        if rings.is_empty() || m[0] * cell < self.cfg.min_area_mm2 {
            return None;
        }
        let to_mm = |p: &[f64; 2]| grid.index_to_mm(p[0], p[1]);
        let (dx, dy) = (grid.dx(), grid.dy());
        let a = m[0] * cell;
        let (ci, cj) = (m[1] / m[0], m[2] / m[0]);
        let (cx, cy) = (dx * ci, dy * cj);
        let mu20 = dx * dx * (m[3] / m[0] - ci * ci);
        let mu11 = dx * dy * (m[4] / m[0] - ci * cj);
        let mu02 = dy * dy * (m[5] / m[0] - cj * cj);
        let mut theta = 0.5 * (2.0 * mu11).atan2(mu20 - mu02);
        if theta <= -std::f64::consts::FRAC_PI_2 {
            theta += std::f64::consts::PI;
        }
        let half_tr = 0.5 * (mu20 + mu02);
        let disc = (0.25 * (mu20 - mu02).powi(2) + mu11 * mu11).sqrt();
        let (l1, l2) = (half_tr + disc, half_tr - disc);
        let ecc = if l1 > 0.0 { (1.0 - (l2 / l1).max(0.0)).max(0.0).sqrt() } else { 0.0 };
        // the rings' own vectors, converted to mm in place
        let in_mm = |mut pts: Vec<[f64; 2]>| {
            pts.iter_mut().for_each(|p| *p = to_mm(p));
            pts
        };
        let mut rings = rings;
        let polygon = in_mm(std::mem::take(&mut rings[outer.0].points));
        let holes =
            rings.into_iter().enumerate().filter(|&(i, _)| i != outer.0).map(|(_, r)| in_mm(r.points)).collect();
        Some(MaxContour {
            level,
            polygon,
            holes,
            area_mm2: a,
            centroid_mm: [peak_mm[0] + cx, peak_mm[1] + cy],
            orientation_rad: theta,
            eccentricity: ecc,
            peak: zmax,
            peak_mm,
            clipped,
            fit: None,
        })
    }

    /// The component of `{z > level}` holding the peak `(pr, pc)` as per-row bit masks
    /// (`Scratch::c_rows`, grids of at most 64 × 64 points): the same set as
    /// [`component`](Self::component), grown row against row — a row's members are the runs of
    /// its points above that hold a member of the row above or below, or the diagonal
    /// neighbour of one across a saddle cell the saddle rule joins — row by row down and up
    /// from the peak's row, a row growing its neighbours again only after it changed. Each row's mask of points above is computed once per
    /// level, for the rows the component reaches and their neighbours. Records the member
    /// count and bounding box; returns the box grown by one point (clipped to the grid).
    fn component_bits<F: Field>(&mut self, z: &mut F, level: f64, pr: usize, pc: usize) -> Win {
        let (ny, nx) = z.dim();
        debug_assert!(nx <= 64 && ny <= 64);
        let saddle = self.cfg.saddle;
        let s = &mut self.s;
        if s.a_rows.len() != ny {
            s.a_rows.clear();
            s.a_rows.resize(ny, 0);
            s.c_rows.clear();
            s.c_rows.resize(ny, 0);
        }
        let gen = next_generation(&mut s.a_known, &mut s.a_gen, ny);
        let (a_rows, a_known, c_rows) = (&mut s.a_rows, &mut s.a_known, &mut s.c_rows);
        let mut above = |z: &mut F, r: usize| -> u64 {
            if a_known[r] != gen {
                let m = z.row_above(r, level);
                a_rows[r] = m;
                a_known[r] = gen;
            }
            a_rows[r]
        };
        // members of rows rlo..=rhi only
        let (mut rlo, mut rhi) = (pr, pr);
        c_rows[pr] = fill_runs(above(z, pr), 1 << pc);
        // row `r` grown from its neighbour row `q`: whether it changed
        let mut grow = |z: &mut F, c_rows: &mut [u64], r: usize, q: usize| -> bool {
            let cq = c_rows[q];
            if cq == 0 {
                return false;
            }
            let (ar, aq) = (above(z, r), above(z, q));
            let mut seeds = cq & ar;
            let right = cq & !(aq >> 1) & !ar & (ar >> 1);
            let left = cq & !(aq << 1) & !ar & (ar << 1);
            let old = c_rows[r];
            if seeds & !old == 0 && right | left == 0 {
                // every seed is a member already: a row's members are whole runs
                return false;
            }
            // diagonals across saddle cells (`right`, `left`): member (q, c) and (r, c ± 1)
            // above, the two side corners (q, c ± 1) and (r, c) below
            for (mut k, dir) in [(right, 1i64), (left, -1i64)] {
                while k != 0 {
                    let c = k.trailing_zeros() as usize;
                    k &= k - 1;
                    let x = (c as i64 + dir) as usize;
                    if seeds >> x & 1 == 1 || c_rows[r] >> x & 1 == 1 {
                        continue;
                    }
                    let (rm, cm) = (r.min(q), x.min(c));
                    let v = [z.raw(rm, cm), z.raw(rm, cm + 1), z.raw(rm + 1, cm + 1), z.raw(rm + 1, cm)];
                    if saddle.joins_above(v, level) {
                        seeds |= 1 << x;
                    }
                }
            }
            let new = fill_runs(ar, seeds | old);
            c_rows[r] = new;
            new != old
        };
        // rows changed since they last grew the row below (`down`) / above (`up`)
        let (mut down, mut up) = (1u64 << pr, 1u64 << pr);
        while down | up != 0 {
            while down != 0 {
                let q = down.trailing_zeros() as usize;
                down &= down - 1;
                let r = q + 1;
                if r >= ny {
                    continue;
                }
                if r > rhi {
                    c_rows[r] = 0;
                }
                if grow(z, c_rows, r, q) {
                    rhi = rhi.max(r);
                    down |= 1 << r;
                    up |= 1 << r;
                }
            }
            while up != 0 {
                let q = 63 - up.leading_zeros() as usize;
                up &= !(1 << q);
                if q == 0 {
                    continue;
                }
                let r = q - 1;
                if r < rlo {
                    c_rows[r] = 0;
                }
                if grow(z, c_rows, r, q) {
                    rlo = rlo.min(r);
                    down |= 1 << r;
                    up |= 1 << r;
                }
            }
        }
        let mut members = 0;
        let mut bb = Win { c0: pc, c1: pc, r0: rlo, r1: rhi };
        for &m in &c_rows[rlo..=rhi] {
            if m != 0 {
                members += m.count_ones() as usize;
                bb.c0 = bb.c0.min(m.trailing_zeros() as usize);
                bb.c1 = bb.c1.max(63 - m.leading_zeros() as usize);
            }
        }
        // rows outside rlo..=rhi hold no members (cleared when first reached)
        c_rows[..rlo].fill(0);
        c_rows[rhi + 1..].fill(0);
        s.members = members;
        s.bbox = bb;
        bb.grown(nx, ny)
    }

    /// The component of `{z > level}` holding the peak `(pr, pc)`, stamped with a new
    /// generation: the same set as [`component`](Self::component) (the connected set of
    /// points above the level under 4-connectivity plus the diagonals across saddle cells the
    /// saddle rule joins — a set, whatever the order it is found in), found by horizontal
    /// runs: a seed is extended left and right over the points above, then the rows above and
    /// below the run are scanned for one new seed per span of points above, and the two
    /// diagonal neighbours beyond the run's ends are linked when the saddle rule joins them.
    /// Records the member count and bounding box; returns the box grown by one point (clipped
    /// to the grid).
    fn component_runs<F: Field>(&mut self, z: &mut F, level: f64, pr: usize, pc: usize) -> Win {
        let (ny, nx) = z.dim();
        let saddle = self.cfg.saddle;
        let s = &mut self.s;
        let gen = s.next_generation(nx * ny);
        s.stamp[pr * nx + pc] = gen;
        s.stack.clear();
        s.stack.push((pr, pc));
        let mut bb = Win { c0: pc, c1: pc, r0: pr, r1: pr };
        let mut members = 0;
        while let Some((r, c)) = s.stack.pop() {
            let row = r * nx;
            let (mut a, mut b) = (c, c);
            while a > 0 && s.stamp[row + a - 1] != gen && {
                z.prepare(r, r, a - 1, a - 1);
                z.raw(r, a - 1) > level
            } {
                a -= 1;
                s.stamp[row + a] = gen;
            }
            while b + 1 < nx && s.stamp[row + b + 1] != gen && {
                z.prepare(r, r, b + 1, b + 1);
                z.raw(r, b + 1) > level
            } {
                b += 1;
                s.stamp[row + b] = gen;
            }
            let (lo, hi) = (a.saturating_sub(1), (b + 1).min(nx - 1));
            z.prepare(r, r, lo, hi);
            members += b - a + 1;
            bb = Win { c0: bb.c0.min(a), c1: bb.c1.max(b), r0: bb.r0.min(r), r1: bb.r1.max(r) };
            for rr in [r.wrapping_sub(1), r + 1] {
                if rr >= ny {
                    continue;
                }
                z.prepare(rr, rr, lo, hi);
                let o = rr * nx;
                let mut in_span = false;
                for x in a..=b {
                    if s.stamp[o + x] != gen && z.raw(rr, x) > level {
                        if !in_span {
                            s.stamp[o + x] = gen;
                            s.stack.push((rr, x));
                            in_span = true;
                        }
                    } else {
                        in_span = false;
                    }
                }
                // the diagonal neighbours beyond the run's ends: linked across a saddle cell
                // (both side corners below) that the rule joins; with a side corner above,
                // that corner is a member and links them through its own rows
                for (x, end) in [(a.wrapping_sub(1), a), (b + 1, b)] {
                    if x >= nx || s.stamp[o + x] == gen {
                        continue;
                    }
                    let above = z.raw(rr, x) > level;
                    if !above || z.raw(r, x) > level || z.raw(rr, end) > level {
                        continue;
                    }
                    let (rm, cm) = (r.min(rr), x.min(end));
                    let v = [z.raw(rm, cm), z.raw(rm, cm + 1), z.raw(rm + 1, cm + 1), z.raw(rm + 1, cm)];
                    if saddle.joins_above(v, level) {
                        s.stamp[o + x] = gen;
                        s.stack.push((rr, x));
                    }
                }
            }
        }
        s.members = members;
        s.bbox = bb;
        bb.grown(nx, ny)
    }

    /// Flood-fill the component of `{z > level}` containing (pr, pc) — 4-connected, plus
    /// diagonals across saddle cells the saddle rule joins — stamping it with a new generation;
    /// returns its bounding box grown by one point (clipped to the grid).
    fn component<F: Field>(&mut self, z: &mut F, level: f64, pr: usize, pc: usize) -> Win {
        let (ny, nx) = z.dim();
        let s = &mut self.s;
        let gen = s.next_generation(nx * ny);
        // NaN is never above
        let (mut r0, mut r1, mut c0, mut c1) = (pr, pr, pc, pc);
        s.stack.clear();
        s.stack.push((pr, pc));
        s.stamp[pr * nx + pc] = gen;
        while let Some((r, c)) = s.stack.pop() {
            r0 = r0.min(r);
            r1 = r1.max(r);
            c0 = c0.min(c);
            c1 = c1.max(c);
            z.prepare(r.saturating_sub(1), (r + 1).min(ny - 1), c.saturating_sub(1), (c + 1).min(nx - 1));
            for (dr, dc) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1), (-1, -1), (-1, 1), (1, -1), (1, 1)] {
                let (rr, cc) = (r as i64 + dr, c as i64 + dc);
                if rr < 0 || cc < 0 || rr >= ny as i64 || cc >= nx as i64 {
                    continue;
                }
                let (rr, cc) = (rr as usize, cc as usize);
                let above = z.raw(rr, cc) > level;
                if s.stamp[rr * nx + cc] == gen || !above {
                    continue;
                }
                if dr != 0 && dc != 0 {
                    // diagonal: only across a saddle cell that the rule joins
                    let (o1, o2) = (z.raw(r, cc) > level, z.raw(rr, c) > level);
                    if !(o1 || o2) {
                        let (rm, cm) = (r.min(rr), c.min(cc));
                        let v = [z.raw(rm, cm), z.raw(rm, cm + 1), z.raw(rm + 1, cm + 1), z.raw(rm + 1, cm)];
                        if !self.cfg.saddle.joins_above(v, level) {
                            continue;
                        }
                    } else {
                        // reachable through an orthogonal neighbour; visited that way
                        continue;
                    }
                }
                s.stamp[rr * nx + cc] = gen;
                s.stack.push((rr, cc));
            }
        }
        Win { c0, c1, r0, r1 }.grown(nx, ny)
    }
}

/// Finite maximum (first index in raster order) and minimum of all of `v` ([`scan_in`] over
/// [`whole_chunks`]; the tests' entry).
#[cfg(test)]
fn scan(v: &[f64], zmax: &mut f64, zmin: &mut f64, at: &mut usize) {
    scan_in(v, &whole_chunks(v.len()), zmax, zmin, at);
}

/// Lanes of [`scan_in`]: eight independent lanes with `x < m ? x : m` selects (NaN never
/// selected), so the compiler vectorises the pass.
pub(crate) const SCAN_LANES: usize = 8;

/// The one range of every whole chunk of a slice of `len` values, for [`scan_in`].
fn whole_chunks(len: usize) -> [(u32, u32); 1] {
    [(0, (len - len % SCAN_LANES) as u32)]
}

/// The lanes' minima and maxima carried over the whole chunks of `v` (a loop of its own, so
/// that the lanes stay in registers and the compiler vectorises it).
#[inline(never)]
fn lanes(v: &[f64], mut mn: [f64; SCAN_LANES], mut mx: [f64; SCAN_LANES]) -> ([f64; SCAN_LANES], [f64; SCAN_LANES]) {
    for c in v.chunks_exact(SCAN_LANES) {
        for l in 0..SCAN_LANES {
            let x = c[l];
            mn[l] = if x < mn[l] { x } else { mn[l] };
            mx[l] = if x > mx[l] { x } else { mx[l] };
        }
    }
    (mn, mx)
}

/// [`scan`] over the chunks of [`SCAN_LANES`] values in `ranges` (each `[a, b)` with `a`, `b`
/// multiples of `SCAN_LANES`, ascending, within the whole chunks of `v`) and the remainder of `v`
/// after its last whole chunk. Bit-identical to [`scan`] when every value outside the ranges
/// (and the remainder) is NaN: each value meets the same lane in the same order, and NaN is
/// never selected.
pub(crate) fn scan_in(v: &[f64], ranges: &[(u32, u32)], zmax: &mut f64, zmin: &mut f64, at: &mut usize) {
    const L: usize = SCAN_LANES;
    let mut mn = [f64::INFINITY; L];
    let mut mx = [f64::NEG_INFINITY; L];
    for &(a, b) in ranges {
        (mn, mx) = lanes(&v[a as usize..b as usize], mn, mx);
    }
    for &x in &v[v.len() - v.len() % L..] {
        mn[0] = if x < mn[0] { x } else { mn[0] };
        mx[0] = if x > mx[0] { x } else { mx[0] };
    }
    let hi = mx.iter().copied().fold(f64::NEG_INFINITY, |a, b| if b > a { b } else { a });
    if hi == f64::NEG_INFINITY {
        return;
    }
    // first index of the maximum: only the lanes whose maximum equals it hold it, and in each
    // such lane the first value equal to it is looked for (a stride of `L` through the ranges,
    // then the remainder for lane 0, which took the remainder's values)
    let rest = v.len() - v.len() % L;
    let mut first = usize::MAX;
    for (l, &m) in mx.iter().enumerate() {
        if m != hi {
            continue;
        }
        let mut found = usize::MAX;
        'lane: for &(a, b) in ranges {
            for i in (a as usize + l..(b as usize).min(first)).step_by(L) {
                if v[i] == hi {
                    found = i;
                    break 'lane;
                }
            }
        }
        if found == usize::MAX && l == 0 {
            found = v[rest..].iter().position(|&x| x == hi).map_or(usize::MAX, |i| rest + i);
        }
        first = first.min(found);
    }
    *at = first;
    *zmax = hi;
    *zmin = mn.iter().copied().fold(f64::INFINITY, |a, b| if b < a { b } else { a });
}

/// The contour stage: one [`ContourFrame`] per [`Surface`] (see the [module docs](self)).
#[derive(Clone, Debug)]
#[must_use = "a stage does nothing until inputs are pushed"]
pub struct Contour {
    finder: MaxContourFinder,
}

impl Contour {
    /// A stage from its configuration (validated).
    pub fn try_new(cfg: &ContourConfig) -> crate::Result<Self> {
        Ok(Contour { finder: MaxContourFinder::try_new(cfg)? })
    }

    /// The maximal contour of one surface, without the stage wrapping.
    pub fn find(&mut self, s: &Surface) -> ContourOutcome {
        self.finder.find(s.values.view(), &s.grid)
    }
}

impl Stage for Contour {
    type In = Surface;
    type Out = ContourFrame;
    type Error = Error;

    fn push(&mut self, s: Surface, out: &mut Vec<ContourFrame>) -> crate::Result<()> {
        if s.values.dim() != (s.grid.ny(), s.grid.nx()) {
            return Err(Error::BadInput {
                stage: STAGE,
                sensor: s.sensor.to_string(),
                seq: s.seq,
                reason: format!("surface of shape {:?} on a {}×{} grid", s.values.dim(), s.grid.ny(), s.grid.nx()),
            });
        }
        let outcome = self.find(&s);
        out.push(ContourFrame { sensor: s.sensor, start: s.start, end: s.end, seq: s.seq, outcome });
        Ok(())
    }

    fn reset(&mut self) {}

    fn delay(&self) -> Delay {
        Delay::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::{array, Array2};

    #[test]
    fn single_square_saddle_rules_match_skimage() {
        let z = array![[1.0, 0.0], [0.0, 1.0]];
        // skimage low: [[0,0.5],[0.5,0]] and [[1,0.5],[0.5,1]] (row, col)
        let low = isolines(z.view(), 0.5, Saddle::Low);
        assert_eq!(low.len(), 2);
        let mut segs: Vec<_> = low.iter().map(|l| l.points.clone()).collect();
        segs.sort_by(|a, b| a[0].partial_cmp(&b[0]).unwrap());
        for s in &segs {
            assert_eq!(s.len(), 2);
            assert!(!low[0].closed);
        }
        let ends: Vec<[f64; 2]> = segs.iter().flat_map(|s| s.iter().copied()).collect();
        for p in [[0.5, 0.0], [0.0, 0.5], [1.0, 0.5], [0.5, 1.0]] {
            assert!(ends.contains(&p), "{p:?} in {ends:?}");
        }
        // low separates (0,0) from (1,1): one segment joins (0.5,0) and (0,0.5)
        assert!(segs.iter().any(|s| s.contains(&[0.5, 0.0]) && s.contains(&[0.0, 0.5])));
        let high = isolines(z.view(), 0.5, Saddle::High);
        assert!(high.iter().any(|l| l.points.contains(&[0.5, 0.0]) && l.points.contains(&[1.0, 0.5])));
    }

    #[test]
    fn closed_ring_area_and_orientation() {
        let mut z = Array2::zeros((5, 5));
        z[[2, 2]] = 1.0;
        let rings = region_boundaries(z.view(), 0.5, Saddle::Centre);
        assert_eq!(rings.len(), 1);
        // a diamond with half-diagonals 0.5: area 0.5, counter-clockwise
        assert!((polygon_area(&rings[0]) - 0.5).abs() < 1e-15);
        // a region touching the edge is closed along it
        let mut z = Array2::zeros((3, 3));
        z[[0, 0]] = 1.0;
        let rings = region_boundaries(z.view(), 0.5, Saddle::Centre);
        assert_eq!(rings.len(), 1);
        assert!((polygon_area(&rings[0]) - 0.125).abs() < 1e-15, "{rings:?}");
    }

    #[test]
    fn scan_finds_the_first_maximum_and_skips_nan() {
        for n in [1usize, 7, 8, 9, 64, 67] {
            for peak in 0..n {
                for dup in [None, Some(n - 1), Some(0)] {
                    let mut v: Vec<f64> = (0..n).map(|i| (i % 5) as f64 - 2.0).collect();
                    v[n / 2] = f64::NAN;
                    v[peak] = 10.0;
                    if let Some(d) = dup {
                        v[d] = 10.0;
                    }
                    let (mut hi, mut lo, mut at) = (f64::NEG_INFINITY, f64::INFINITY, usize::MAX);
                    scan(&v, &mut hi, &mut lo, &mut at);
                    let want = v.iter().position(|&x| x == 10.0).unwrap();
                    assert_eq!((hi, at), (10.0, want), "n {n} peak {peak} dup {dup:?}");
                    let min = v.iter().copied().filter(|x| !x.is_nan()).fold(f64::INFINITY, f64::min);
                    assert_eq!(lo, min);
                }
            }
        }
        let (mut hi, mut lo, mut at) = (f64::NEG_INFINITY, f64::INFINITY, usize::MAX);
        scan(&[f64::NAN; 9], &mut hi, &mut lo, &mut at);
        assert_eq!(at, usize::MAX);
    }

    #[test]
    fn scan_in_ranges_equals_the_whole_scan_when_the_rest_is_nan() {
        // every chunk pattern of a few lengths, values with ±0, ties of the maximum and NaN
        for n in [8usize, 9, 16, 31, 40, 67] {
            let chunks = n / SCAN_LANES;
            for mask in 0u32..(1 << chunks) {
                for seed in 0..4u64 {
                    let mut v: Vec<f64> = (0..n)
                        .map(|i| match (i as u64 * 7 + seed * 3) % 6 {
                            0 => 0.0,
                            1 => -0.0,
                            2 => 3.0,
                            3 => f64::NAN,
                            4 => -2.5,
                            _ => 3.0 - (i as f64) * 1e-3,
                        })
                        .collect();
                    let mut ranges: Vec<(u32, u32)> = Vec::new();
                    for c in 0..chunks {
                        let (a, b) = (c * SCAN_LANES, (c + 1) * SCAN_LANES);
                        if mask >> c & 1 == 0 {
                            v[a..b].iter_mut().for_each(|x| *x = f64::NAN);
                        } else {
                            match ranges.last_mut() {
                                Some((_, e)) if *e == a as u32 => *e = b as u32,
                                _ => ranges.push((a as u32, b as u32)),
                            }
                        }
                    }
                    let mut whole = (f64::NEG_INFINITY, f64::INFINITY, usize::MAX);
                    scan(&v, &mut whole.0, &mut whole.1, &mut whole.2);
                    let mut part = (f64::NEG_INFINITY, f64::INFINITY, usize::MAX);
                    scan_in(&v, &ranges, &mut part.0, &mut part.1, &mut part.2);
                    assert_eq!(
                        (whole.0.to_bits(), whole.1.to_bits(), whole.2),
                        (part.0.to_bits(), part.1.to_bits(), part.2),
                        "n {n} mask {mask:b} seed {seed}"
                    );
                    // and against brute force: the first index equal to the maximum
                    let finite: Vec<f64> = v.iter().copied().filter(|x| !x.is_nan()).collect();
                    if finite.is_empty() {
                        assert_eq!(part.2, usize::MAX);
                    } else {
                        let max = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                        assert_eq!(part.0, max);
                        assert_eq!(part.2, v.iter().position(|&x| x == max).unwrap(), "n {n} mask {mask:b}");
                    }
                }
            }
        }
    }

    mod fast_equals_reference {
        use super::*;
        use crate::interpolate::{InterpolateConfig, Interpolator};
        use gradtac_stream::Extent;
        use proptest::prelude::*;

        fn configs() -> Vec<ContourConfig> {
            vec![
                ContourConfig::default(),
                ContourConfig { min_area_mm2: 0.0, saddle: Saddle::Low, ..Default::default() },
                ContourConfig { min_area_mm2: 15.0, saddle: Saddle::High, peak_only: false, ..Default::default() },
                ContourConfig { levels: Levels::Count(25), min_area_mm2: 3.0, min_peak: -1e9, ..Default::default() },
                ContourConfig {
                    levels: Levels::Explicit(vec![0.5, 1.5, 2.5, 3.5]),
                    min_area_mm2: 2.0,
                    min_peak: -1e9,
                    ..Default::default()
                },
            ]
        }

        /// Both level searches on one surface: identical outcomes (compared through `Debug`,
        /// which prints every float exactly).
        fn check(z: ArrayView2<'_, f64>, grid: &Grid) -> Result<(), TestCaseError> {
            for cfg in configs() {
                let mut fast = MaxContourFinder::try_new(&cfg).unwrap();
                let mut reference = MaxContourFinder::try_new(&cfg).unwrap();
                reference.reference = true;
                let (a, b) = (fast.find(z, grid), reference.find(z, grid));
                prop_assert_eq!(format!("{a:?}"), format!("{b:?}"), "{:?}", cfg);
            }
            Ok(())
        }

        fn interp() -> &'static Interpolator {
            static I: std::sync::OnceLock<Interpolator> = std::sync::OnceLock::new();
            I.get_or_init(|| {
                Interpolator::from_config(&InterpolateConfig::default(), &gradtac_stream::Layout::biotac_sp()).unwrap()
            })
        }

        /// `len` grid values, mostly a few distinct small integers (ties, plateaus, saddles,
        /// several peaks), some NaN, some arbitrary.
        fn few_values(len: usize) -> impl Strategy<Value = Vec<f64>> {
            proptest::collection::vec(
                prop_oneof![4 => (0u8..5).prop_map(f64::from), 1 => Just(f64::NAN), 1 => -3.0f64..7.0],
                len,
            )
        }

        proptest! {
            #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]
            /// Small grids of few distinct values (ties, plateaus, saddles, several peaks) with NaN.
            #[test]
            fn on_random_grids(v in few_values(11 * 9)) {
                let grid = Grid::try_new(Extent { x_min: 0.0, x_max: 4.0, y_min: -1.0, y_max: 2.0 }, 11, 9).unwrap();
                let z = Array2::from_shape_vec((9, 11), v).unwrap();
                check(z.view(), &grid)?;
            }

            /// Grids wider than 64 columns (the component found by runs, not row masks).
            #[test]
            fn on_wide_grids(v in few_values(67 * 5)) {
                let grid = Grid::try_new(Extent { x_min: 0.0, x_max: 20.0, y_min: -1.0, y_max: 2.0 }, 67, 5).unwrap();
                let z = Array2::from_shape_vec((5, 67), v).unwrap();
                check(z.view(), &grid)?;
            }

            /// Natural-neighbour 64 × 64 surfaces of random window aggregates (the default chain).
            #[test]
            fn on_interpolated_surfaces(v in proptest::collection::vec(prop_oneof![
                3 => Just(0.0),
                3 => (-3i8..8).prop_map(f64::from),
                1 => -20.0f64..20.0,
            ], 24)) {
                let it = interp();
                check(it.surface(&v).view(), it.grid())?;
            }
        }
    }

    #[test]
    fn config_validation() {
        assert!(MaxContourFinder::try_new(&ContourConfig { levels: Levels::Count(0), ..Default::default() }).is_err());
        assert!(MaxContourFinder::try_new(&ContourConfig {
            levels: Levels::Explicit(vec![f64::NAN]),
            ..Default::default()
        })
        .is_err());
        assert!(MaxContourFinder::try_new(&ContourConfig { min_area_mm2: -1.0, ..Default::default() }).is_err());
        let toml_like: ContourConfig = serde_json::from_str(r#"{"levels": [1.0, 2.0], "saddle": "low"}"#).unwrap();
        assert_eq!(toml_like.levels, Levels::Explicit(vec![1.0, 2.0]));
        let c: ContourConfig = serde_json::from_str(r#"{"levels": 5}"#).unwrap();
        assert_eq!(c.levels, Levels::Count(5));
    }
}
