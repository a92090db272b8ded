//! [`TrackPoint`] as Arrow: schema `track/1`, one row per track point.
//!
//! | column | Arrow type | meaning |
//! |---|---|---|
//! | `sensor` | `Utf8`, not null | the sensor's name |
//! | `time_ns` | `Int64`, not null | the time the point describes: the end of the surface's span; `gradtac.unit = ns` |
//! | `start_ns` | `Int64`, not null | start of the surface's span (the window's start); `gradtac.unit = ns` |
//! | `seq` | `UInt64`, not null | index of the newest source frame |
//! | `state` | `Utf8`, not null | `contact` or `no_contact` |
//! | `no_contact` | `Utf8`, nullable | why there is no contact (`no_data`, `below_min_peak`, `flat`, `too_small`); null when the point has no reason |
//! | `track` | `UInt64`, nullable | the track the point belongs to; null without contact |
//! | `x_mm`, `y_mm` | `Float64`, not null | contact location (mm); NaN without contact |
//! | `area_mm2` | `Float64`, not null | maximal-contour area (mm²); NaN without contact |
//! | `orientation_rad` | `Float64`, not null | principal-axis orientation (rad); NaN without contact |
//! | `peak` | `Float64`, not null | surface peak (surface units); NaN without contact |
//! | `vx_mm_s`, `vy_mm_s` | `Float64`, nullable | velocity (mm/s); null on a track's first point and without contact |
//! | `gated` | `Boolean`, not null | the point repeats the last accepted one because the contour jumped |
//!
//! Columns map one to one onto [`TrackPoint`]'s fields (NaN stays NaN, `None` is null), so a
//! file reads back into the same points bit-exactly. The shape is `()`.

use super::columns::{schema_with_id, unit_field, with_lead, LeadBuilder};
use super::contour::no_contact_name;
use super::{arrow_error, ArrowRecord, RecordBuilder};
use crate::Result;
use arrow_array::builder::{BooleanBuilder, Float64Builder, StringBuilder, UInt64Builder};
use arrow_array::RecordBatch;
use arrow_schema::{DataType, Field, SchemaRef};
use gradtac_stages::track::{ContactState, TrackPoint};
use std::sync::Arc;

/// The `state` column's text for a [`ContactState`] (as in serde).
pub fn contact_state_name(s: ContactState) -> &'static str {
    match s {
        ContactState::Contact => "contact",
        ContactState::NoContact => "no_contact",
    }
}

impl ArrowRecord for TrackPoint {
    type Shape = ();
    type Builder = TrackBuilder;
    const SCHEMA_ID: &'static str = "track/1";

    fn schema(_: &()) -> SchemaRef {
        let f = |name: &str, unit: &str| unit_field(name, DataType::Float64, false, unit);
        schema_with_id(
            with_lead(
                ["time_ns", "start_ns"],
                vec![
                    Field::new("state", DataType::Utf8, false),
                    Field::new("no_contact", DataType::Utf8, true),
                    Field::new("track", DataType::UInt64, true),
                    f("x_mm", "mm"),
                    f("y_mm", "mm"),
                    f("area_mm2", "mm2"),
                    f("orientation_rad", "rad"),
                    Field::new("peak", DataType::Float64, false),
                    unit_field("vx_mm_s", DataType::Float64, true, "mm/s"),
                    unit_field("vy_mm_s", DataType::Float64, true, "mm/s"),
                    Field::new("gated", DataType::Boolean, false),
                ],
            ),
            Self::SCHEMA_ID,
            vec![],
        )
    }

    fn builder(_: &(), capacity: usize) -> TrackBuilder {
        let floats = || Float64Builder::with_capacity(capacity);
        TrackBuilder {
            schema: Self::schema(&()),
            lead: LeadBuilder::with_capacity(capacity),
            state: StringBuilder::with_capacity(capacity, capacity * 10),
            no_contact: StringBuilder::new(),
            track: UInt64Builder::with_capacity(capacity),
            x: floats(),
            y: floats(),
            area: floats(),
            orientation: floats(),
            peak: floats(),
            vx: floats(),
            vy: floats(),
            gated: BooleanBuilder::with_capacity(capacity),
        }
    }
}

/// Builds `track/1` batches (see the [module documentation](self)).
pub struct TrackBuilder {
    schema: SchemaRef,
    /// `sensor`, `time_ns`, `start_ns`, `seq`.
    lead: LeadBuilder<2>,
    state: StringBuilder,
    no_contact: StringBuilder,
    track: UInt64Builder,
    x: Float64Builder,
    y: Float64Builder,
    area: Float64Builder,
    orientation: Float64Builder,
    peak: Float64Builder,
    vx: Float64Builder,
    vy: Float64Builder,
    gated: BooleanBuilder,
}

impl std::fmt::Debug for TrackBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TrackBuilder").field("pending", &self.len()).finish()
    }
}

impl RecordBuilder<TrackPoint> for TrackBuilder {
    fn schema(&self) -> SchemaRef {
        self.schema.clone()
    }

    /// Never rejects: every track point fits `track/1`.
    fn append(&mut self, p: &TrackPoint) -> Result<()> {
        self.lead.append(&p.sensor, [p.time, p.start], p.seq);
        self.state.append_value(contact_state_name(p.state));
        self.no_contact.append_option(p.no_contact.map(no_contact_name));
        self.track.append_option(p.track);
        self.x.append_value(p.x_mm);
        self.y.append_value(p.y_mm);
        self.area.append_value(p.area_mm2);
        self.orientation.append_value(p.orientation_rad);
        self.peak.append_value(p.peak);
        self.vx.append_option(p.velocity_mm_s.map(|v| v[0]));
        self.vy.append_option(p.velocity_mm_s.map(|v| v[1]));
        self.gated.append_value(p.gated);
        Ok(())
    }

    fn len(&self) -> usize {
        self.lead.rows()
    }

    fn finish(&mut self) -> Result<RecordBatch> {
        let columns = self.lead.finish(vec![
            Arc::new(self.state.finish()),
            Arc::new(self.no_contact.finish()),
            Arc::new(self.track.finish()),
            Arc::new(self.x.finish()),
            Arc::new(self.y.finish()),
            Arc::new(self.area.finish()),
            Arc::new(self.orientation.finish()),
            Arc::new(self.peak.finish()),
            Arc::new(self.vx.finish()),
            Arc::new(self.vy.finish()),
            Arc::new(self.gated.finish()),
        ]);
        RecordBatch::try_new(self.schema.clone(), columns).map_err(|e| arrow_error(TrackPoint::SCHEMA_ID, e))
    }
}
