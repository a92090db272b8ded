//! [`ForceEstimate`] as Arrow: schema `force/1`, one row per estimate (one per contour frame).
//!
//! | column | Arrow type | meaning |
//! |---|---|---|
//! | `sensor` | `Utf8`, not null | the sensor's name |
//! | `time_ns` | `Int64`, not null | the time the estimate describes: the contour's span end; `gradtac.unit = ns` |
//! | `seq` | `UInt64`, not null | index of the newest source frame |
//! | `area_mm2` | `Float64`, not null | the maximal contour's area (mm²); **NaN** without contact; `gradtac.unit = mm2` |
//! | `force_n` | `Float64`, nullable | the estimated normal force (N); **null** without contact or below the stage's `min_area_mm2`; `gradtac.unit = N` |
//!
//! Columns map one to one onto [`ForceEstimate`]'s fields (NaN stays NaN bit-exactly, `None`
//! is null), so a file reads back into the same estimates. The shape is `()`; every estimate
//! fits, so [`RecordBuilder::append`] never rejects.

use super::columns::{ns_field, schema_with_id, unit_field};
use super::{arrow_error, ArrowRecord, RecordBuilder};
use crate::Result;
use arrow_array::builder::{ArrayBuilder, Float64Builder, Int64Builder, StringBuilder, UInt64Builder};
use arrow_array::{ArrayRef, RecordBatch};
use arrow_schema::{DataType, Field, SchemaRef};
use gradtac_stages::force::ForceEstimate;
use std::sync::Arc;

impl ArrowRecord for ForceEstimate {
    type Shape = ();
    type Builder = ForceBuilder;
    const SCHEMA_ID: &'static str = "force/1";

    fn schema(_: &()) -> SchemaRef {
        schema_with_id(
            vec![
                Field::new("sensor", DataType::Utf8, false),
                ns_field("time_ns"),
                Field::new("seq", DataType::UInt64, false),
                unit_field("area_mm2", DataType::Float64, false, "mm2"),
                unit_field("force_n", DataType::Float64, true, "N"),
            ],
            Self::SCHEMA_ID,
            vec![],
        )
    }

    fn builder(_: &(), capacity: usize) -> ForceBuilder {
        ForceBuilder {
            schema: Self::schema(&()),
            sensor: StringBuilder::with_capacity(capacity, capacity * 4),
            time: Int64Builder::with_capacity(capacity),
            seq: UInt64Builder::with_capacity(capacity),
            area: Float64Builder::with_capacity(capacity),
            force: Float64Builder::with_capacity(capacity),
        }
    }
}

/// Builds `force/1` batches (see the [module documentation](self)).
pub struct ForceBuilder {
    schema: SchemaRef,
    sensor: StringBuilder,
    time: Int64Builder,
    seq: UInt64Builder,
    area: Float64Builder,
    force: Float64Builder,
}

impl std::fmt::Debug for ForceBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ForceBuilder").field("pending", &self.len()).finish()
    }
}

impl RecordBuilder<ForceEstimate> for ForceBuilder {
    fn schema(&self) -> SchemaRef {
        self.schema.clone()
    }

    /// Never rejects: every estimate fits `force/1`.
    fn append(&mut self, e: &ForceEstimate) -> Result<()> {
        self.sensor.append_value(e.sensor.as_str());
        self.time.append_value(e.time.as_nanos());
        self.seq.append_value(e.seq);
        self.area.append_value(e.area_mm2);
        self.force.append_option(e.force_n);
        Ok(())
    }

    fn len(&self) -> usize {
        self.seq.len()
    }

    fn finish(&mut self) -> Result<RecordBatch> {
        let columns: Vec<ArrayRef> = vec![
            Arc::new(self.sensor.finish()),
            Arc::new(self.time.finish()),
            Arc::new(self.seq.finish()),
            Arc::new(self.area.finish()),
            Arc::new(self.force.finish()),
        ];
        RecordBatch::try_new(self.schema.clone(), columns).map_err(|e| arrow_error(ForceEstimate::SCHEMA_ID, e))
    }
}
