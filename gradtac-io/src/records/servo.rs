//! [`ServoCommand`] as Arrow: schema `servo/2`, one row per command (one per track point).
//!
//! | column | Arrow type | meaning |
//! |---|---|---|
//! | `sensor` | `Utf8`, not null | the sensor's name |
//! | `time` | time ([`TimeBase`]), not null | the track point's time |
//! | `seq` | `UInt64`, not null | index of the newest source frame |
//! | `action` | `Utf8`, not null | `move` ([`ServoAction::Move`]) or `no_contact` ([`ServoAction::NoContact`]: no contact, or a gated point; no command) |
//! | `offset_x_mm`, `offset_y_mm` | `Float64`, nullable | contact minus centre ([`Motion::offset_mm`], mm, layout plane); `gradtac.unit = mm` |
//! | `distance_mm` | `Float64`, nullable | length of the offset ([`Motion::distance_mm`], mm); `gradtac.unit = mm` |
//! | `direction_x`, `direction_y` | `Float64`, nullable | unit vector along the offset ([`Motion::direction`]; `[0, 0]` for a zero offset; dimensionless, no unit) |
//! | `motion_x_mm`, `motion_y_mm` | `Float64`, nullable | the commanded sensor motion ([`Motion::motion_mm`], mm; zero inside the deadband); `gradtac.unit = mm` |
//!
//! The seven motion columns are null exactly when `action` is `no_contact`; with `move` they
//! hold the [`Motion`]'s values bit-exactly (a NaN, which no motion has, would be null), so a file reads back into the same
//! commands. The shape is `()`; every command fits, so [`RecordBuilder::append`] never
//! rejects.

use super::columns::{schema_with_id, unit_field, with_lead, LeadBuilder};
use super::{arrow_error, ArrowRecord, RecordBuilder, TimeBase};
use crate::Result;
use arrow_array::builder::{Float64Builder, StringBuilder};
use arrow_array::RecordBatch;
use arrow_schema::{DataType, Field, SchemaRef};
use gradtac_stages::servo::{Motion, ServoAction, ServoCommand};
use std::sync::Arc;

/// The `action` column's text for a [`ServoAction`] (as in serde: `no_contact`, `move`).
pub fn servo_action_name(a: &ServoAction) -> &'static str {
    match a {
        ServoAction::NoContact => "no_contact",
        ServoAction::Move(_) => "move",
    }
}

impl ArrowRecord for ServoCommand {
    type Shape = ();
    type Builder = ServoBuilder;
    const SCHEMA_ID: &'static str = "servo/2";

    fn schema(_: &(), time: TimeBase) -> SchemaRef {
        let mm = |name: &str| unit_field(name, DataType::Float64, true, "mm");
        schema_with_id(
            with_lead(
                ["time"],
                time,
                vec![
                    Field::new("action", DataType::Utf8, false),
                    mm("offset_x_mm"),
                    mm("offset_y_mm"),
                    mm("distance_mm"),
                    Field::new("direction_x", DataType::Float64, true),
                    Field::new("direction_y", DataType::Float64, true),
                    mm("motion_x_mm"),
                    mm("motion_y_mm"),
                ],
            ),
            Self::SCHEMA_ID,
            time,
            vec![],
        )
    }

    fn builder(_: &(), time: TimeBase, capacity: usize) -> ServoBuilder {
        let floats = || Float64Builder::with_capacity(capacity);
        ServoBuilder {
            schema: Self::schema(&(), time),
            lead: LeadBuilder::with_capacity(time, capacity),
            action: StringBuilder::with_capacity(capacity, capacity * 6),
            offset_x: floats(),
            offset_y: floats(),
            distance: floats(),
            direction_x: floats(),
            direction_y: floats(),
            motion_x: floats(),
            motion_y: floats(),
        }
    }
}

/// Builds `servo/2` batches (see the [module documentation](self)).
pub struct ServoBuilder {
    schema: SchemaRef,
    /// `sensor`, `time`, `seq`.
    lead: LeadBuilder<1>,
    action: StringBuilder,
    offset_x: Float64Builder,
    offset_y: Float64Builder,
    distance: Float64Builder,
    direction_x: Float64Builder,
    direction_y: Float64Builder,
    motion_x: Float64Builder,
    motion_y: Float64Builder,
}

impl std::fmt::Debug for ServoBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ServoBuilder").field("pending", &self.len()).finish()
    }
}

impl RecordBuilder<ServoCommand> for ServoBuilder {
    fn schema(&self) -> SchemaRef {
        self.schema.clone()
    }

    /// Never rejects: every command fits `servo/2`.
    fn append(&mut self, c: &ServoCommand) -> Result<()> {
        self.lead.append(&c.sensor, [c.time], c.seq);
        self.action.append_value(servo_action_name(&c.action));
        let m: Option<&Motion> = c.motion();
        self.offset_x.append_option(m.map(|m| m.offset_mm[0]).filter(|v| !v.is_nan()));
        self.offset_y.append_option(m.map(|m| m.offset_mm[1]).filter(|v| !v.is_nan()));
        self.distance.append_option(m.map(|m| m.distance_mm).filter(|v| !v.is_nan()));
        self.direction_x.append_option(m.map(|m| m.direction[0]).filter(|v| !v.is_nan()));
        self.direction_y.append_option(m.map(|m| m.direction[1]).filter(|v| !v.is_nan()));
        self.motion_x.append_option(m.map(|m| m.motion_mm[0]).filter(|v| !v.is_nan()));
        self.motion_y.append_option(m.map(|m| m.motion_mm[1]).filter(|v| !v.is_nan()));
        Ok(())
    }

    fn len(&self) -> usize {
        self.lead.rows()
    }

    fn finish(&mut self) -> Result<RecordBatch> {
        let columns = self.lead.finish(vec![
            Arc::new(self.action.finish()),
            Arc::new(self.offset_x.finish()),
            Arc::new(self.offset_y.finish()),
            Arc::new(self.distance.finish()),
            Arc::new(self.direction_x.finish()),
            Arc::new(self.direction_y.finish()),
            Arc::new(self.motion_x.finish()),
            Arc::new(self.motion_y.finish()),
        ]);
        RecordBatch::try_new(self.schema.clone(), columns).map_err(|e| arrow_error(ServoCommand::SCHEMA_ID, e))
    }
}
