//! [`SlipEvent`] as Arrow: schema `slip/2`, one row per change of a two-finger grasp's state.
//!
//! | column | Arrow type | meaning |
//! |---|---|---|
//! | `first` | `Utf8`, not null | the first sensor of the pair (the same in every row of a file: [`SlipShape::first`]) |
//! | `second` | `Utf8`, not null | the second sensor, facing the first ([`SlipShape::second`]) |
//! | `time` | time ([`TimeBase`]), not null | when the change was decided ([`SlipEvent::time`]) |
//! | `onset` | time ([`TimeBase`]), not null | estimated start of the new state ([`SlipEvent::onset`]) |
//! | `first_seen` | time ([`TimeBase`]), not null | when the new state was first seen ([`SlipEvent::first_seen`]) |
//! | `class` | `Utf8`, not null | the new state: `stable`, `longitudinal_up`, `longitudinal_down`, `rotational_cw`, `rotational_ccw` ([`SlipClass::name`](gradtac_stages::slip::SlipClass::name)) |
//! | `previous` | `Utf8`, not null | the state before (same names) |
//! | `common_mm_s` | `Float64`, nullable | common-mode speed `L` along world up (mm/s); **null** when a finger's velocity is missing (NaN in Rust); `gradtac.unit = mm/s` |
//! | `differential_mm_s` | `Float64`, nullable | differential speed `R` (mm/s); null when a velocity is missing; `gradtac.unit = mm/s` |
//!
//! A [`SlipEvent`] names no sensor: the pair is the sink's [`SlipShape`], stored in the schema
//! metadata (`gradtac.slip.first`, `gradtac.slip.second`) **and** as the two constant columns
//! `first` and `second`, so files of several pairs read as one table still say which pair each
//! row is about. Floats are stored bit-exactly, NaN (a missing speed) as null. Every event fits `slip/2`: [`RecordBuilder::append`] never rejects.
//!
//! ```
//! use gradtac_io::records::{to_batch, SlipShape};
//! use gradtac_stages::slip::{SlipClass, SlipEvent};
//! use gradtac_stream::Timestamp;
//!
//! let shape = SlipShape::new("ff", "th");
//! let e = SlipEvent {
//!     time: Timestamp(300),
//!     onset: Timestamp(100),
//!     first_seen: Timestamp(200),
//!     class: SlipClass::LongitudinalDown,
//!     previous: SlipClass::Stable,
//!     common_mm_s: -20.0,
//!     differential_mm_s: 0.5,
//! };
//! let batch = to_batch(&shape, &[e]).unwrap();
//! assert_eq!(batch.num_rows(), 1);
//! assert_eq!(batch.schema().metadata()["gradtac.slip.second"], "th");
//! ```

use super::columns::{append_present, schema_with_id, time_field, unit_field, TimeBuilder};
use super::{arrow_error, ArrowRecord, RecordBuilder, TimeBase};
use crate::Result;
use arrow_array::builder::{Float64Builder, StringBuilder};
use arrow_array::{ArrayRef, RecordBatch};
use arrow_schema::{DataType, Field, SchemaRef};
use gradtac_stages::slip::{SlipConfig, SlipEvent};
use std::sync::Arc;

/// Schema-metadata key of the first sensor of a `slip/2` file.
pub const SLIP_FIRST_KEY: &str = "gradtac.slip.first";
/// Schema-metadata key of the second sensor of a `slip/2` file.
pub const SLIP_SECOND_KEY: &str = "gradtac.slip.second";

/// The two sensors whose grasp the slip events of one sink describe.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct SlipShape {
    /// The first sensor (the first finger; [`SlipConfig::first`]).
    pub first: String,
    /// The second sensor, facing the first (the thumb; [`SlipConfig::second`]).
    pub second: String,
}

impl SlipShape {
    /// The pair `first`, `second`.
    pub fn new(first: impl Into<String>, second: impl Into<String>) -> Self {
        SlipShape { first: first.into(), second: second.into() }
    }

    /// The pair a slip stage was configured with.
    pub fn from_config(cfg: &SlipConfig) -> Self {
        Self::new(cfg.first.clone(), cfg.second.clone())
    }
}

impl ArrowRecord for SlipEvent {
    type Shape = SlipShape;
    type Builder = SlipBuilder;
    const SCHEMA_ID: &'static str = "slip/2";

    fn schema(shape: &SlipShape, time: TimeBase) -> SchemaRef {
        schema_with_id(
            vec![
                Field::new("first", DataType::Utf8, false),
                Field::new("second", DataType::Utf8, false),
                time_field("time", time),
                time_field("onset", time),
                time_field("first_seen", time),
                Field::new("class", DataType::Utf8, false),
                Field::new("previous", DataType::Utf8, false),
                unit_field("common_mm_s", DataType::Float64, true, "mm/s"),
                unit_field("differential_mm_s", DataType::Float64, true, "mm/s"),
            ],
            Self::SCHEMA_ID,
            time,
            vec![
                (SLIP_FIRST_KEY.to_string(), shape.first.clone()),
                (SLIP_SECOND_KEY.to_string(), shape.second.clone()),
            ],
        )
    }

    fn builder(shape: &SlipShape, time: TimeBase, capacity: usize) -> SlipBuilder {
        let names = |s: &str| StringBuilder::with_capacity(capacity, capacity * s.len());
        SlipBuilder {
            schema: Self::schema(shape, time),
            shape: shape.clone(),
            first: names(&shape.first),
            second: names(&shape.second),
            time: TimeBuilder::with_capacity(time, capacity),
            onset: TimeBuilder::with_capacity(time, capacity),
            first_seen: TimeBuilder::with_capacity(time, capacity),
            class: StringBuilder::with_capacity(capacity, capacity * 16),
            previous: StringBuilder::with_capacity(capacity, capacity * 16),
            common: Float64Builder::with_capacity(capacity),
            differential: Float64Builder::with_capacity(capacity),
        }
    }
}

/// Builds `slip/2` batches (see the [module documentation](self)).
pub struct SlipBuilder {
    schema: SchemaRef,
    shape: SlipShape,
    first: StringBuilder,
    second: StringBuilder,
    time: TimeBuilder,
    onset: TimeBuilder,
    first_seen: TimeBuilder,
    class: StringBuilder,
    previous: StringBuilder,
    common: Float64Builder,
    differential: Float64Builder,
}

impl std::fmt::Debug for SlipBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SlipBuilder")
            .field("first", &self.shape.first)
            .field("second", &self.shape.second)
            .field("pending", &self.len())
            .finish()
    }
}

impl RecordBuilder<SlipEvent> for SlipBuilder {
    fn schema(&self) -> SchemaRef {
        self.schema.clone()
    }

    /// Never rejects: every slip event fits `slip/2`.
    fn append(&mut self, e: &SlipEvent) -> Result<()> {
        self.first.append_value(&self.shape.first);
        self.second.append_value(&self.shape.second);
        self.time.append(e.time);
        self.onset.append(e.onset);
        self.first_seen.append(e.first_seen);
        self.class.append_value(e.class.name());
        self.previous.append_value(e.previous.name());
        append_present(&mut self.common, e.common_mm_s);
        append_present(&mut self.differential, e.differential_mm_s);
        Ok(())
    }

    fn len(&self) -> usize {
        self.time.len()
    }

    fn finish(&mut self) -> Result<RecordBatch> {
        let columns: Vec<ArrayRef> = vec![
            Arc::new(self.first.finish()),
            Arc::new(self.second.finish()),
            self.time.finish(),
            self.onset.finish(),
            self.first_seen.finish(),
            Arc::new(self.class.finish()),
            Arc::new(self.previous.finish()),
            Arc::new(self.common.finish()),
            Arc::new(self.differential.finish()),
        ];
        RecordBatch::try_new(self.schema.clone(), columns).map_err(|e| arrow_error(SlipEvent::SCHEMA_ID, e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::records::{to_batch, SCHEMA_KEY};
    use arrow_array::cast::AsArray;
    use arrow_array::Array;
    use gradtac_stages::slip::SlipClass;
    use gradtac_stream::Timestamp;

    #[test]
    fn the_pair_is_in_the_metadata_and_in_every_row() {
        let shape = SlipShape::from_config(&SlipConfig::default());
        assert_eq!(shape, SlipShape::new("ff", "th"));
        let ev = |k: i64, class, previous| SlipEvent {
            time: Timestamp(k),
            onset: Timestamp(k - 2),
            first_seen: Timestamp(k - 1),
            class,
            previous,
            common_mm_s: f64::NAN,
            differential_mm_s: -0.0,
        };
        let b = to_batch(
            &shape,
            &[ev(10, SlipClass::RotationalCw, SlipClass::Stable), ev(20, SlipClass::Stable, SlipClass::RotationalCw)],
        )
        .unwrap();
        let md = b.schema().metadata().clone();
        assert_eq!(
            (md[SCHEMA_KEY].as_str(), md[SLIP_FIRST_KEY].as_str(), md[SLIP_SECOND_KEY].as_str()),
            ("slip/2", "ff", "th")
        );
        let s = |name: &str| {
            b.column_by_name(name).unwrap().as_string::<i32>().iter().flatten().collect::<Vec<_>>().join(",")
        };
        assert_eq!(s("first"), "ff,ff");
        assert_eq!(s("second"), "th,th");
        assert_eq!(s("class"), "rotational_cw,stable");
        assert_eq!(s("previous"), "stable,rotational_cw");
        let common = b.column_by_name("common_mm_s").unwrap().as_primitive::<arrow_array::types::Float64Type>();
        assert!(common.is_null(0) && common.null_count() == 2, "a missing speed (NaN) is null, never NaN");
    }
}
