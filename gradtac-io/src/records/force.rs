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

use super::columns::{schema_with_id, unit_field, with_lead, LeadBuilder};
use super::{arrow_error, ArrowRecord, RecordBuilder};
use crate::Result;
use arrow_array::builder::Float64Builder;
use arrow_array::RecordBatch;
use arrow_schema::{DataType, SchemaRef};
use gradtac_stages::force::ForceEstimate;
use std::sync::Arc;

impl ArrowRecord for ForceEstimate {
    type Shape = ();
    type Builder = ForceBuilder;
    const SCHEMA_ID: &'static str = "force/1";

    fn schema(_: &()) -> SchemaRef {
        schema_with_id(
            with_lead(
                ["time_ns"],
                vec![
                    unit_field("area_mm2", DataType::Float64, false, "mm2"),
                    unit_field("force_n", DataType::Float64, true, "N"),
                ],
            ),
            Self::SCHEMA_ID,
            vec![],
        )
    }

    fn builder(_: &(), capacity: usize) -> ForceBuilder {
        ForceBuilder {
            schema: Self::schema(&()),
            lead: LeadBuilder::with_capacity(capacity),
            area: Float64Builder::with_capacity(capacity),
            force: Float64Builder::with_capacity(capacity),
        }
    }
}

/// Builds `force/1` batches (see the [module documentation](self)).
pub struct ForceBuilder {
    schema: SchemaRef,
    /// `sensor`, `time_ns`, `seq`.
    lead: LeadBuilder<1>,
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
        self.lead.append(&e.sensor, [e.time], e.seq);
        self.area.append_value(e.area_mm2);
        self.force.append_option(e.force_n);
        Ok(())
    }

    fn len(&self) -> usize {
        self.lead.rows()
    }

    fn finish(&mut self) -> Result<RecordBatch> {
        let columns = self.lead.finish(vec![Arc::new(self.area.finish()), Arc::new(self.force.finish())]);
        RecordBatch::try_new(self.schema.clone(), columns).map_err(|e| arrow_error(ForceEstimate::SCHEMA_ID, e))
    }
}
