//! Arrow records: one documented Arrow schema per pipeline output type.
//!
//! Every type a sink can write implements [`ArrowRecord`] in its own file under
//! `src/records/`: frames ([`frame`], `frame/1`), events ([`events`], `event/1`), window
//! aggregates ([`window`], `window/1`), surfaces ([`surface`], `surface/1`), contours
//! ([`contour`], `contour/1`), tracks ([`track`], `track/1`), slip events ([`slip`],
//! `slip/1`), forces ([`force`], `force/1`), servo commands ([`servo`], `servo/1`) and
//! slip-direction decisions ([`dos`], `dos/2`). The trait gives
//! - a schema id stored in files under the key `gradtac.schema` (`frame/1`: name and
//!   version; bump the version on any incompatible change),
//! - the Arrow [`Schema`](arrow_schema::Schema), which may depend on a per-sink **shape**
//!   ([`ArrowRecord::Shape`]: the taxel names for frames, a grid size for surfaces),
//! - a [`RecordBuilder`] that appends records one at a time and cuts them into
//!   [`RecordBatch`]es.
//!
//! Schemas are documented column by column in `docs/schemas.md` at the repository root.
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
//! assert_eq!(TaxelFrame::SCHEMA_ID, "frame/1");
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
use arrow_schema::SchemaRef;

/// Key of the schema id (`frame/1`, …) in Arrow schema metadata and Parquet key-value
/// metadata.
pub const SCHEMA_KEY: &str = "gradtac.schema";

/// A type with one Arrow schema, that sinks can write (see the [module documentation](self)).
pub trait ArrowRecord: Sized {
    /// What fixes the schema for one sink (taxel names for frames; `()` when nothing does).
    type Shape: Clone + std::fmt::Debug + Send + Sync + 'static;
    /// Accumulates records of this type into Arrow arrays.
    type Builder: RecordBuilder<Self>;
    /// Schema name and version, `<name>/<version>`, stored under [`SCHEMA_KEY`].
    const SCHEMA_ID: &'static str;

    /// The Arrow schema for `shape` (its metadata holds [`SCHEMA_KEY`]).
    fn schema(shape: &Self::Shape) -> SchemaRef;

    /// An empty builder for `shape`, with room for `capacity` records.
    fn builder(shape: &Self::Shape, capacity: usize) -> Self::Builder;
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

/// All of `records` as one batch of `T`'s schema for `shape`.
pub fn to_batch<T: ArrowRecord>(shape: &T::Shape, records: &[T]) -> Result<RecordBatch> {
    let mut b = T::builder(shape, records.len());
    for r in records {
        b.append(r)?;
    }
    b.finish()
}

/// An Arrow error as [`Error::Arrow`] with what was being done.
pub(crate) fn arrow_error(context: impl Into<String>, e: impl std::fmt::Display) -> Error {
    Error::Arrow { context: context.into(), reason: e.to_string() }
}
