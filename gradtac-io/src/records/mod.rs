//! Arrow records: one documented Arrow schema per pipeline output type.
//!
//! Every type a sink can write implements [`ArrowRecord`] in its own file under
//! `src/records/`: frames ([`frame`], `frame/2`), events ([`events`], `event/2`), window
//! aggregates ([`window`], `window/2`), surfaces ([`surface`], `surface/2`), contours
//! ([`contour`], `contour/2`), tracks ([`track`], `track/3`), slip events ([`slip`],
//! `slip/2`), forces ([`force`], `force/2`), servo commands ([`servo`], `servo/2`) and
//! slip-direction decisions ([`dos`], `dos/3`). The trait gives
//! - a schema id stored in files under the key `gradtac.schema` (`frame/2`: name and
//!   version; bump the version on any incompatible change),
//! - the Arrow [`Schema`](arrow_schema::Schema), which may depend on a per-sink **shape**
//!   ([`ArrowRecord::Shape`]: the taxel names for frames, a grid size for surfaces) and on
//!   the [`TimeBase`] of the records' times,
//! - a [`RecordBuilder`] that appends records one at a time and cuts them into
//!   [`RecordBatch`]es.
//!
//! Schemas are documented column by column in `docs/schemas.md` at the repository root.
//!
//! # Conventions (every schema)
//! - **Names**: a column is named after the Rust field it stores, unit suffix included
//!   (`TrackPoint::x_mm` → `x_mm`, `TrackPoint::time` → `time`); a two-vector field
//!   `<stem>_<unit>: [f64; 2]` is the two columns `<stem>_x_<unit>`, `<stem>_y_<unit>`
//!   (`velocity_mm_s` → `velocity_x_mm_s`, `velocity_y_mm_s`; `centroid_mm` → `centroid_x_mm`,
//!   …), so SQL aggregates see scalars; a field of a nested value keeps its own name, and the
//!   enclosing record's field that would clash is prefixed (an event's `time`, its batch's
//!   `frame_time`). Polygons are lists of `[x, y]` points.
//! - **Times**: every time is a [`Timestamp`](gradtac_stream::Timestamp) column of the sink's
//!   [`TimeBase`]: `Timestamp(Nanosecond, "UTC")` when the source's clock is the Unix epoch
//!   (live CAN, candump logs, ROS bags), `Duration(Nanosecond)` since the source's own start
//!   otherwise (rate-timed files, files whose time column has its own origin). The schema
//!   metadata says which under `gradtac.time` (`utc` or `relative`).
//! - **Absent values are null, never NaN**: a scalar that does not exist (no contact, a
//!   feature the model did not need, a missing velocity) is null; NaN is never written to a
//!   scalar column. (Surface grid points outside the taxels' hull are list items, see
//!   [`surface`].)
//! - **Taxel numbers count from 1**, like the built-in names `e1` … `e24`: taxel number `k`
//!   is the layout's `k`-th taxel, `names[k − 1]` of the `gradtac.taxels` list.
//!
//! # Adding a type
//! 1. Create `src/records/<type>.rs` with a shape type (or `()`), a builder holding one Arrow
//!    array builder per column, and `impl ArrowRecord for <Type>`.
//! 2. `append` must check the record against the shape *before* touching any column
//!    builder, so a rejected record leaves the builder consistent, and reject with
//!    [`Error::Record`] (never panic).
//! 3. Add `mod <type>;` and its `pub use` here, a section in `docs/schemas.md`, and a round
//!    trip test.
//!
//! ```
//! use gradtac_io::records::{to_batch, ArrowRecord, FrameShape};
//! use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
//!
//! let shape = FrameShape::unnamed(2).unwrap();
//! let frames = [TaxelFrame::new(SensorId::new("ff"), Timestamp(0), 0, vec![1.0, 2.0])];
//! let batch = to_batch(&shape, &frames).unwrap();
//! assert_eq!(batch.num_rows(), 1);
//! assert_eq!(TaxelFrame::SCHEMA_ID, "frame/2");
//! ```

mod columns;
pub mod contour;
pub mod dos;
pub mod events;
pub mod force;
pub mod frame;
pub mod servo;
pub mod slip;
pub mod surface;
pub mod track;
pub mod window;

pub use contour::ContourBuilder;
pub use dos::{DosBuilder, DosShape};
pub use events::{EventBuilder, EventShape};
pub use force::ForceBuilder;
pub use frame::{FrameBuilder, FrameShape};
pub use servo::ServoBuilder;
pub use slip::{SlipBuilder, SlipShape};
pub use surface::{SurfaceBuilder, SurfaceShape};
pub use track::TrackBuilder;
pub use window::{WindowBuilder, WindowShape};

use crate::{Error, Result};
use arrow_array::RecordBatch;
use arrow_schema::{DataType, SchemaRef, TimeUnit};

/// Key of the schema id (`frame/2`, …) in Arrow schema metadata and Parquet key-value
/// metadata.
pub const SCHEMA_KEY: &str = "gradtac.schema";

/// Key of the [`TimeBase`] (`utc` or `relative`) in Arrow schema metadata.
pub const TIME_KEY: &str = "gradtac.time";

/// What the records' [`Timestamp`](gradtac_stream::Timestamp)s count from, which fixes the
/// Arrow type of every time column.
///
/// | source | clock | base |
/// |---|---|---|
/// | live SocketCAN, candump logs | Unix epoch | [`Utc`](TimeBase::Utc) |
/// | ROS 1 bags, MCAP | Unix epoch (the recording's header stamps) | [`Utc`](TimeBase::Utc) |
/// | CSV / NumPy / Arrow IPC at a fixed `rate_hz` | 0 at the first frame | [`Relative`](TimeBase::Relative) |
/// | CSV / NumPy / Arrow IPC with a time column | the column's own origin | [`Relative`](TimeBase::Relative) |
///
/// The default is `Relative`: it claims nothing about the origin.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum TimeBase {
    /// Nanoseconds since the Unix epoch: `Timestamp(Nanosecond, "UTC")` columns.
    Utc,
    /// Nanoseconds since the source's own origin: `Duration(Nanosecond)` columns.
    #[default]
    Relative,
}

impl TimeBase {
    /// The Arrow type of a time column.
    pub fn data_type(self) -> DataType {
        match self {
            TimeBase::Utc => DataType::Timestamp(TimeUnit::Nanosecond, Some("UTC".into())),
            TimeBase::Relative => DataType::Duration(TimeUnit::Nanosecond),
        }
    }

    /// `utc` or `relative` (the value of [`TIME_KEY`]).
    pub fn name(self) -> &'static str {
        match self {
            TimeBase::Utc => "utc",
            TimeBase::Relative => "relative",
        }
    }
}

/// A type with one Arrow schema, that sinks can write (see the [module documentation](self)).
pub trait ArrowRecord: Sized {
    /// What fixes the schema for one sink (taxel names for frames; `()` when nothing does).
    type Shape: Clone + std::fmt::Debug + Send + Sync + 'static;
    /// Accumulates records of this type into Arrow arrays.
    type Builder: RecordBuilder<Self>;
    /// Schema name and version, `<name>/<version>`, stored under [`SCHEMA_KEY`].
    const SCHEMA_ID: &'static str;

    /// The Arrow schema for `shape`, times of `time` (its metadata holds [`SCHEMA_KEY`] and
    /// [`TIME_KEY`]).
    fn schema(shape: &Self::Shape, time: TimeBase) -> SchemaRef;

    /// An empty builder for `shape`, times of `time`, with room for `capacity` records.
    fn builder(shape: &Self::Shape, time: TimeBase, capacity: usize) -> Self::Builder;
}

/// Appends records to Arrow array builders and cuts them into record batches.
pub trait RecordBuilder<T>: Send {
    /// The schema of the batches [`finish`](Self::finish) returns.
    fn schema(&self) -> SchemaRef;

    /// Append one record. A record that does not fit the shape (e.g. another taxel count)
    /// is rejected with [`Error::Record`] and leaves the builder unchanged.
    fn append(&mut self, record: &T) -> Result<()>;

    /// Records appended since the last [`finish`](Self::finish).
    fn len(&self) -> usize;

    /// True when no record is pending.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The pending records as one batch; the builder is empty afterwards.
    fn finish(&mut self) -> Result<RecordBatch>;
}

/// All of `records` as one batch of `T`'s schema for `shape`, with relative times
/// ([`TimeBase::Relative`]; [`to_batch_in`] chooses).
pub fn to_batch<T: ArrowRecord>(shape: &T::Shape, records: &[T]) -> Result<RecordBatch> {
    to_batch_in(shape, TimeBase::Relative, records)
}

/// All of `records` as one batch of `T`'s schema for `shape`, times of `time`.
pub fn to_batch_in<T: ArrowRecord>(shape: &T::Shape, time: TimeBase, records: &[T]) -> Result<RecordBatch> {
    let mut b = T::builder(shape, time, records.len());
    for r in records {
        b.append(r)?;
    }
    b.finish()
}

/// An Arrow error as [`Error::Arrow`] with what was being done.
pub(crate) fn arrow_error(context: impl Into<String>, e: impl std::fmt::Display) -> Error {
    Error::Arrow { context: context.into(), reason: e.to_string() }
}
