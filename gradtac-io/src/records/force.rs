//! [`ForceEstimate`] as Arrow: schema `force/2`, one row per estimate (one per contour frame).
//!
//! | column | Arrow type | meaning |
//! |---|---|---|
//! | `sensor` | `Utf8`, not null | the sensor's name |
//! | `time` | time ([`TimeBase`]), not null | the time the estimate describes: the contour's span end |
//! | `seq` | `UInt64`, not null | index of the newest source frame |
//! | `area_mm2` | `Float64`, nullable | the maximal contour's area (mm²); **null** without contact; `gradtac.unit = mm2` |
//! | `force_n` | `Float64`, nullable | the estimated normal force (N); **null** without contact or below the stage's `min_area_mm2`; `gradtac.unit = N` |
//!
//! Columns map one to one onto [`ForceEstimate`]'s fields; NaN (no contact) and `None` are
//! null. The shape is `()`; every estimate
//! fits, so [`RecordBuilder::append`] never rejects.

use super::columns::{append_present, schema_with_id, unit_field, with_lead, LeadBuilder};
use super::{arrow_error, ArrowRecord, RecordBuilder, TimeBase};
use crate::Result;
use arrow_array::builder::Float64Builder;
use arrow_array::RecordBatch;
use arrow_schema::{DataType, SchemaRef};
use gradtac_stages::force::ForceEstimate;
use std::sync::Arc;

impl ArrowRecord for ForceEstimate {
    type Shape = ();
    type Builder = ForceBuilder;
    const SCHEMA_ID: &'static str = "force/2";

    fn schema(_: &(), time: TimeBase) -> SchemaRef {
        schema_with_id(
            with_lead(
                ["time"],
                time,
                vec![
                    unit_field("area_mm2", DataType::Float64, true, "mm2"),
                    unit_field("force_n", DataType::Float64, true, "N"),
                ],
            ),
            Self::SCHEMA_ID,
            time,
            vec![],
        )
    }

    fn builder(_: &(), time: TimeBase, capacity: usize) -> ForceBuilder {
        ForceBuilder {
            schema: Self::schema(&(), time),
            lead: LeadBuilder::with_capacity(time, capacity),
            area: Float64Builder::with_capacity(capacity),
            force: Float64Builder::with_capacity(capacity),
        }
    }
}

/// Builds `force/2` batches (see the [module documentation](self)).
pub struct ForceBuilder {
    schema: SchemaRef,
    /// `sensor`, `time`, `seq`.
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

    /// Never rejects: every estimate fits `force/2`.
    fn append(&mut self, e: &ForceEstimate) -> Result<()> {
        self.lead.append(&e.sensor, [e.time], e.seq);
        append_present(&mut self.area, e.area_mm2);
        self.force.append_option(e.force_n.filter(|f| !f.is_nan()));
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
