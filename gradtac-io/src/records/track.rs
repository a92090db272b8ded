//! [`TrackPoint`] as Arrow: schema `track/3`, one row per track point.
//!
//! | column | Arrow type | meaning |
//! |---|---|---|
//! | `sensor` | `Utf8`, not null | the sensor's name |
//! | `time` | time ([`TimeBase`]), not null | the time the point describes: the end of the surface's span |
//! | `start` | time ([`TimeBase`]), not null | start of the surface's span (the window's start) |
//! | `seq` | `UInt64`, not null | index of the newest source frame |
//! | `state` | `Utf8`, not null | `contact` or `no_contact` |
//! | `no_contact` | `Utf8`, nullable | why there is no contact (`no_data`, `below_min_peak`, `flat`, `too_small`); null when the point has no reason |
//! | `track` | `UInt64`, nullable | the track the point belongs to; null without contact |
//! | `x_mm`, `y_mm` | `Float64`, nullable | contact location (mm); null without contact |
//! | `area_mm2` | `Float64`, nullable | maximal-contour area (mm²); null without contact |
//! | `orientation_rad` | `Float64`, nullable | principal-axis orientation (rad); null without contact |
//! | `peak` | `Float64`, nullable | surface peak (surface units); null without contact |
//! | `velocity_x_mm_s`, `velocity_y_mm_s` | `Float64`, nullable | [`TrackPoint::velocity_mm_s`] `[x, y]` (mm/s); null on a track's first point and without contact |
//! | `gated` | `Boolean`, not null | the point repeats the last accepted one because the contour jumped |
//! | `fit_amplitude` | `Float64`, nullable | [`TrackPoint::fit`]: the model fit's amplitude `\|A\|` (input units); null unless `[stages.locate] method = "fit"` and in contact |
//! | `fit_spread_mm` | `Float64`, nullable | the fit's spread `w` (mm) |
//! | `fit_residual` | `Float64`, nullable | the fit's relative residual `‖Δ − model‖/‖Δ‖` |
//! | `fit_sigma_mm` | `Float64`, nullable | the fit's position uncertainty: 1-σ ellipse's major semi-axis (mm) |
//!
//! Columns map one to one onto [`TrackPoint`]'s fields, named after them (a two-vector
//! field `velocity_mm_s` as `velocity_x_mm_s`, `velocity_y_mm_s`); an absent value (`None`,
//! or NaN in a float field) is null, never NaN; the `fit_*` columns are [`TrackPoint::fit`]'s
//! fields. `track/2` had no `fit_*` columns (readers by name read both). `track/1` (0.1) had `Int64` `time_ns` /
//! `start_ns`, NaN for absent floats and `vx_mm_s` / `vy_mm_s`. The shape is `()`.

use super::columns::{append_present, schema_with_id, unit_field, with_lead, LeadBuilder};
use super::contour::no_contact_name;
use super::{arrow_error, ArrowRecord, RecordBuilder, TimeBase};
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
    const SCHEMA_ID: &'static str = "track/3";

    fn schema(_: &(), time: TimeBase) -> SchemaRef {
        let f = |name: &str, unit: &str| unit_field(name, DataType::Float64, true, unit);
        schema_with_id(
            with_lead(
                ["time", "start"],
                time,
                vec![
                    Field::new("state", DataType::Utf8, false),
                    Field::new("no_contact", DataType::Utf8, true),
                    Field::new("track", DataType::UInt64, true),
                    f("x_mm", "mm"),
                    f("y_mm", "mm"),
                    f("area_mm2", "mm2"),
                    f("orientation_rad", "rad"),
                    Field::new("peak", DataType::Float64, true),
                    unit_field("velocity_x_mm_s", DataType::Float64, true, "mm/s"),
                    unit_field("velocity_y_mm_s", DataType::Float64, true, "mm/s"),
                    Field::new("gated", DataType::Boolean, false),
                    Field::new("fit_amplitude", DataType::Float64, true),
                    f("fit_spread_mm", "mm"),
                    Field::new("fit_residual", DataType::Float64, true),
                    f("fit_sigma_mm", "mm"),
                ],
            ),
            Self::SCHEMA_ID,
            time,
            vec![],
        )
    }

    fn builder(_: &(), time: TimeBase, capacity: usize) -> TrackBuilder {
        let floats = || Float64Builder::with_capacity(capacity);
        TrackBuilder {
            schema: Self::schema(&(), time),
            lead: LeadBuilder::with_capacity(time, capacity),
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
            fit_amplitude: floats(),
            fit_spread: floats(),
            fit_residual: floats(),
            fit_sigma: floats(),
        }
    }
}

/// Builds `track/3` batches (see the [module documentation](self)).
pub struct TrackBuilder {
    schema: SchemaRef,
    /// `sensor`, `time`, `start`, `seq`.
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
    fit_amplitude: Float64Builder,
    fit_spread: Float64Builder,
    fit_residual: Float64Builder,
    fit_sigma: Float64Builder,
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

    /// Never rejects: every track point fits `track/3`.
    fn append(&mut self, p: &TrackPoint) -> Result<()> {
        self.lead.append(&p.sensor, [p.time, p.start], p.seq);
        self.state.append_value(contact_state_name(p.state));
        self.no_contact.append_option(p.no_contact.map(no_contact_name));
        self.track.append_option(p.track);
        append_present(&mut self.x, p.x_mm);
        append_present(&mut self.y, p.y_mm);
        append_present(&mut self.area, p.area_mm2);
        append_present(&mut self.orientation, p.orientation_rad);
        append_present(&mut self.peak, p.peak);
        self.vx.append_option(p.velocity_mm_s.map(|v| v[0]).filter(|v| !v.is_nan()));
        self.vy.append_option(p.velocity_mm_s.map(|v| v[1]).filter(|v| !v.is_nan()));
        self.gated.append_value(p.gated);
        let fit = |f: fn(&gradtac_stages::fit::FitSummary) -> f64| p.fit.as_ref().map(f).filter(|v| !v.is_nan());
        self.fit_amplitude.append_option(fit(|s| s.amplitude));
        self.fit_spread.append_option(fit(|s| s.spread_mm));
        self.fit_residual.append_option(fit(|s| s.residual));
        self.fit_sigma.append_option(fit(|s| s.sigma_mm));
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
            Arc::new(self.fit_amplitude.finish()),
            Arc::new(self.fit_spread.finish()),
            Arc::new(self.fit_residual.finish()),
            Arc::new(self.fit_sigma.finish()),
        ]);
        RecordBatch::try_new(self.schema.clone(), columns).map_err(|e| arrow_error(TrackPoint::SCHEMA_ID, e))
    }
}
