//! [`Surface`] as Arrow: schema `surface/2`, one row per surface.
//!
//! | column | Arrow type | meaning |
//! |---|---|---|
//! | `sensor` | `Utf8`, not null | the sensor's name |
//! | `start` | time ([`TimeBase`]), not null | start of the span the surface describes ([`Surface::start`]) |
//! | `end` | time ([`TimeBase`]), not null | end of the span, the newest contributing frame's time ([`Surface::end`]) |
//! | `seq` | `UInt64`, not null | index of the newest contributing source frame |
//! | `values` | `FixedSizeList<Float64 not null>[nx·ny]`, not null | the values at the grid points, **row-major**: element `row·nx + col` is the point `(x(col), y(row))`; NaN (outside the taxels' hull) preserved bit-exactly |
//!
//! The grid is the sink's [`SurfaceShape`] and is stored in the schema metadata under
//! `gradtac.grid` as JSON `{"nx", "ny", "x_min", "x_max", "y_min", "y_max"}` (mm). Column
//! `col` lies at `x(col) = x_min + (x_max − x_min)·col/(nx − 1)` and row `row` at
//! `y(row) = y_min + (y_max − y_min)·row/(ny − 1)` (both ends included, like
//! `numpy.linspace`), so `values.reshape(ny, nx)` in NumPy gives `[row (y), col (x)]` like
//! [`Surface::values`]. A surface on another grid (another size or extent) is rejected with
//! [`Error::Record`](crate::Error::Record).
//!
//! ```
//! use gradtac_io::records::{to_batch, SurfaceShape};
//! use gradtac_stages::interpolate::{Grid, Surface};
//! use gradtac_stream::{Extent, SensorId, Timestamp};
//! use std::sync::Arc;
//!
//! let grid = Arc::new(Grid::try_new(Extent { x_min: 0.0, x_max: 2.0, y_min: 0.0, y_max: 1.0 }, 3, 2).unwrap());
//! let shape = SurfaceShape::new(grid.clone());
//! // values[[row, col]] = 10·row + col
//! let values = ndarray::Array2::from_shape_fn((2, 3), |(r, c)| (10 * r + c) as f64);
//! let s = Surface { sensor: SensorId::new("ff"), start: Timestamp(0), end: Timestamp(9), seq: 9, grid, values };
//! let batch = to_batch(&shape, &[s]).unwrap();
//! let flat = arrow_array::cast::AsArray::as_fixed_size_list(batch.column(4)).value(0);
//! let flat = arrow_array::cast::AsArray::as_primitive::<arrow_array::types::Float64Type>(&flat).values().to_vec();
//! assert_eq!(flat, [0.0, 1.0, 2.0, 10.0, 11.0, 12.0]); // row-major: row·nx + col
//! assert!(batch.schema().metadata()["gradtac.grid"].contains("\"nx\":3"));
//! ```

use super::columns::{f64_list, item_field, record_error, schema_with_id, with_lead, LeadBuilder};
use super::{arrow_error, ArrowRecord, RecordBuilder, TimeBase};
use crate::Result;
use arrow_array::builder::{FixedSizeListBuilder, Float64Builder};
use arrow_array::RecordBatch;
use arrow_schema::{Field, SchemaRef};
use gradtac_stages::interpolate::{Grid, Surface};
use std::sync::Arc;

/// Schema-metadata key of the grid of a `surface/2` file (JSON object).
pub const GRID_KEY: &str = "gradtac.grid";

/// The grid of the surfaces one sink writes.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceShape {
    grid: Arc<Grid>,
}

impl SurfaceShape {
    /// The shape of surfaces on `grid` (e.g. `Interpolate::interpolator().grid().clone()`,
    /// or `surface.grid.clone()` of the first surface).
    pub fn new(grid: impl Into<Arc<Grid>>) -> Self {
        SurfaceShape { grid: grid.into() }
    }

    /// The grid.
    pub fn grid(&self) -> &Arc<Grid> {
        &self.grid
    }

    /// The value of [`GRID_KEY`]: the grid as JSON.
    pub fn grid_json(&self) -> String {
        let e = self.grid.extent();
        serde_json::json!({
            "nx": self.grid.nx(),
            "ny": self.grid.ny(),
            "x_min": e.x_min,
            "x_max": e.x_max,
            "y_min": e.y_min,
            "y_max": e.y_max,
        })
        .to_string()
    }
}

impl ArrowRecord for Surface {
    type Shape = SurfaceShape;
    type Builder = SurfaceBuilder;
    const SCHEMA_ID: &'static str = "surface/2";

    fn schema(shape: &SurfaceShape, time: TimeBase) -> SchemaRef {
        schema_with_id(
            with_lead(["start", "end"], time, vec![Field::new("values", f64_list(shape.grid.len()), false)]),
            Self::SCHEMA_ID,
            time,
            vec![(GRID_KEY.to_string(), shape.grid_json())],
        )
    }

    fn builder(shape: &SurfaceShape, time: TimeBase, capacity: usize) -> SurfaceBuilder {
        let len = shape.grid.len();
        // Reserve at most 8 MiB of values up front: a surface is large (64×64 = 4096 values).
        let reserve = capacity.saturating_mul(len).min(1 << 20);
        SurfaceBuilder {
            schema: Self::schema(shape, time),
            grid: shape.grid.clone(),
            lead: LeadBuilder::with_capacity(time, capacity),
            values: FixedSizeListBuilder::with_capacity(
                Float64Builder::with_capacity(reserve),
                // A grid holds at most 2^24 points, so this fits an i32 list size.
                len as i32,
                capacity,
            )
            .with_field(item_field()),
        }
    }
}

/// Builds `surface/2` batches (see the [module documentation](self)).
pub struct SurfaceBuilder {
    schema: SchemaRef,
    grid: Arc<Grid>,
    /// `sensor`, `start`, `end`, `seq`.
    lead: LeadBuilder<2>,
    values: FixedSizeListBuilder<Float64Builder>,
}

impl std::fmt::Debug for SurfaceBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SurfaceBuilder")
            .field("nx", &self.grid.nx())
            .field("ny", &self.grid.ny())
            .field("pending", &self.len())
            .finish()
    }
}

impl RecordBuilder<Surface> for SurfaceBuilder {
    fn schema(&self) -> SchemaRef {
        self.schema.clone()
    }

    fn append(&mut self, s: &Surface) -> Result<()> {
        let (nx, ny) = (self.grid.nx(), self.grid.ny());
        if !(Arc::ptr_eq(&s.grid, &self.grid) || *s.grid == *self.grid) {
            let (e, f) = (s.grid.extent(), self.grid.extent());
            return Err(record_error(
                Surface::SCHEMA_ID,
                format!(
                    "sensor {} surface of frame {} is on a {}×{} grid over x {}..{}, y {}..{} mm; this sink was \
                     built for {nx}×{ny} over x {}..{}, y {}..{} mm",
                    s.sensor,
                    s.seq,
                    s.grid.nx(),
                    s.grid.ny(),
                    e.x_min,
                    e.x_max,
                    e.y_min,
                    e.y_max,
                    f.x_min,
                    f.x_max,
                    f.y_min,
                    f.y_max
                ),
            ));
        }
        if s.values.dim() != (ny, nx) {
            let (r, c) = s.values.dim();
            return Err(record_error(
                Surface::SCHEMA_ID,
                format!(
                    "sensor {} surface of frame {} holds {r}×{c} values (rows×cols); its grid has {ny}×{nx}",
                    s.sensor, s.seq
                ),
            ));
        }
        self.lead.append(&s.sensor, [s.start, s.end], s.seq);
        match s.values.as_slice() {
            Some(flat) => self.values.values().append_slice(flat),
            // Not in standard layout (a transposed view): logical row-major order.
            None => s.values.iter().for_each(|&v| self.values.values().append_value(v)),
        }
        self.values.append(true);
        Ok(())
    }

    fn len(&self) -> usize {
        self.lead.rows()
    }

    fn finish(&mut self) -> Result<RecordBatch> {
        let columns = self.lead.finish(vec![Arc::new(self.values.finish())]);
        RecordBatch::try_new(self.schema.clone(), columns).map_err(|e| arrow_error(Surface::SCHEMA_ID, e))
    }
}
