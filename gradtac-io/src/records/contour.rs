//! [`ContourFrame`] as Arrow: schema `contour/2`, one row per surface's contour outcome.
//!
//! | column | Arrow type | meaning |
//! |---|---|---|
//! | `sensor` | `Utf8`, not null | the sensor's name |
//! | `start` | time ([`TimeBase`]), not null | start of the surface's span |
//! | `end` | time ([`TimeBase`]), not null | end of the span |
//! | `seq` | `UInt64`, not null | index of the newest source frame |
//! | `contact` | `Boolean`, not null | a maximal contour was found |
//! | `no_contact` | `Utf8`, nullable | why there is none: `no_data`, `below_min_peak`, `flat`, `too_small`; null on contact |
//! | `level` | `Float64`, nullable | the contour's level (surface units) |
//! | `area_mm2` | `Float64`, nullable | region area, holes excluded (mm²) |
//! | `centroid_x_mm`, `centroid_y_mm` | `Float64`, nullable | area centroid: the contact location (mm) |
//! | `orientation_rad` | `Float64`, nullable | principal-axis angle from +x toward +y, in `(−π/2, π/2]` (rad) |
//! | `eccentricity` | `Float64`, nullable | `√(1 − λ_min/λ_max)`: 0 round, → 1 elongated |
//! | `peak` | `Float64`, nullable | the surface's peak value (surface units) |
//! | `peak_x_mm`, `peak_y_mm` | `Float64`, nullable | where the peak is (a grid point, mm) |
//! | `clipped` | `Boolean`, nullable | the region was closed along the grid edge or a NaN boundary |
//! | `polygon` | `List<FixedSizeList<Float64 not null>[2] not null>`, nullable | outer boundary `[x, y]` (mm), counter-clockwise, first vertex not repeated |
//! | `holes` | `List<List<FixedSizeList<Float64 not null>[2] not null> not null>`, nullable | boundaries of holes (mm), clockwise; an empty list when the region has none |
//!
//! Every column from `level` on is null exactly when `contact` is false. Floating-point
//! values are stored bit-exactly. The shape is `()`: nothing fixes the schema.
//!
//! One Arrow batch holds at most `i32::MAX` polygon vertices (the offsets of a `List`); a
//! contour that would overflow a pending batch is rejected with
//! [`Error::Record`](crate::Error::Record) — write fewer records per batch (a smaller row
//! group) in that case.

use super::columns::{
    append_present, item_field, point_item_field, record_error, schema_with_id, time_field, unit_field, TimeBuilder,
};
use super::{arrow_error, ArrowRecord, RecordBuilder, TimeBase};
use crate::Result;
use arrow_array::builder::{
    ArrayBuilder, BooleanBuilder, FixedSizeListBuilder, Float64Builder, ListBuilder, StringBuilder, UInt64Builder,
};
use arrow_array::{ArrayRef, RecordBatch};
use arrow_schema::{DataType, Field, FieldRef, SchemaRef};
use gradtac_stages::contour::{ContourFrame, ContourOutcome, NoContact};
use std::sync::Arc;

/// The `no_contact` column's text for a [`NoContact`] reason (as in serde).
pub fn no_contact_name(r: NoContact) -> &'static str {
    match r {
        NoContact::NoData => "no_data",
        NoContact::BelowMinPeak => "below_min_peak",
        NoContact::Flat => "flat",
        NoContact::TooSmall => "too_small",
    }
}

/// `List<FixedSizeList<Float64>[2]>`: a ring of `[x, y]` points.
fn ring_type() -> DataType {
    DataType::List(point_item_field())
}

fn ring_item_field() -> FieldRef {
    Arc::new(Field::new("item", ring_type(), false))
}

type PointBuilder = FixedSizeListBuilder<Float64Builder>;
type RingBuilder = ListBuilder<PointBuilder>;

fn ring_builder() -> RingBuilder {
    ListBuilder::new(FixedSizeListBuilder::new(Float64Builder::new(), 2).with_field(item_field()))
        .with_field(point_item_field())
}

fn append_ring(b: &mut RingBuilder, ring: &[[f64; 2]]) {
    let points = b.values();
    for p in ring {
        points.values().append_slice(p);
        points.append(true);
    }
    b.append(true);
}

impl ArrowRecord for ContourFrame {
    type Shape = ();
    type Builder = ContourBuilder;
    const SCHEMA_ID: &'static str = "contour/2";

    fn schema(_: &(), time: TimeBase) -> SchemaRef {
        let f = |name: &str, unit: &str| unit_field(name, DataType::Float64, true, unit);
        schema_with_id(
            vec![
                Field::new("sensor", DataType::Utf8, false),
                time_field("start", time),
                time_field("end", time),
                Field::new("seq", DataType::UInt64, false),
                Field::new("contact", DataType::Boolean, false),
                Field::new("no_contact", DataType::Utf8, true),
                Field::new("level", DataType::Float64, true),
                f("area_mm2", "mm2"),
                f("centroid_x_mm", "mm"),
                f("centroid_y_mm", "mm"),
                f("orientation_rad", "rad"),
                Field::new("eccentricity", DataType::Float64, true),
                Field::new("peak", DataType::Float64, true),
                f("peak_x_mm", "mm"),
                f("peak_y_mm", "mm"),
                Field::new("clipped", DataType::Boolean, true),
                unit_field("polygon", ring_type(), true, "mm"),
                unit_field("holes", DataType::List(ring_item_field()), true, "mm"),
            ],
            Self::SCHEMA_ID,
            time,
            vec![],
        )
    }

    fn builder(_: &(), time: TimeBase, capacity: usize) -> ContourBuilder {
        let floats = || Float64Builder::with_capacity(capacity);
        ContourBuilder {
            schema: Self::schema(&(), time),
            points: 0,
            sensor: StringBuilder::with_capacity(capacity, capacity * 4),
            start: TimeBuilder::with_capacity(time, capacity),
            end: TimeBuilder::with_capacity(time, capacity),
            seq: UInt64Builder::with_capacity(capacity),
            contact: BooleanBuilder::with_capacity(capacity),
            no_contact: StringBuilder::new(),
            floats: std::array::from_fn(|_| floats()),
            clipped: BooleanBuilder::with_capacity(capacity),
            polygon: ring_builder(),
            holes: ListBuilder::new(ring_builder()).with_field(ring_item_field()),
        }
    }
}

/// Number of `Float64` scalar columns (`level` … `peak_y_mm`).
const FLOATS: usize = 9;

/// Builds `contour/2` batches (see the [module documentation](self)).
pub struct ContourBuilder {
    schema: SchemaRef,
    /// Polygon vertices (outer and holes) pending.
    points: usize,
    sensor: StringBuilder,
    start: TimeBuilder,
    end: TimeBuilder,
    seq: UInt64Builder,
    contact: BooleanBuilder,
    no_contact: StringBuilder,
    /// level, area, centroid x, centroid y, orientation, eccentricity, peak, peak x, peak y.
    floats: [Float64Builder; FLOATS],
    clipped: BooleanBuilder,
    polygon: RingBuilder,
    holes: ListBuilder<RingBuilder>,
}

impl std::fmt::Debug for ContourBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ContourBuilder").field("pending", &self.len()).finish()
    }
}

impl RecordBuilder<ContourFrame> for ContourBuilder {
    fn schema(&self) -> SchemaRef {
        self.schema.clone()
    }

    fn append(&mut self, c: &ContourFrame) -> Result<()> {
        let points = match &c.outcome {
            ContourOutcome::Contact(m) => m.polygon.len() + m.holes.iter().map(Vec::len).sum::<usize>(),
            ContourOutcome::NoContact(_) => 0,
        };
        // The outer and the hole lists have separate offsets; bounding their sum bounds both.
        if self.points.saturating_add(points) > i32::MAX as usize {
            return Err(record_error(
                ContourFrame::SCHEMA_ID,
                format!(
                    "sensor {} contour of frame {} has {points} vertices, more than one Arrow batch holds after \
                     the {} pending; write smaller row groups",
                    c.sensor, c.seq, self.points
                ),
            ));
        }
        self.points += points;
        self.sensor.append_value(c.sensor.as_str());
        self.start.append(c.start);
        self.end.append(c.end);
        self.seq.append_value(c.seq);
        match &c.outcome {
            ContourOutcome::Contact(m) => {
                self.contact.append_value(true);
                self.no_contact.append_null();
                let v = [
                    m.level,
                    m.area_mm2,
                    m.centroid_mm[0],
                    m.centroid_mm[1],
                    m.orientation_rad,
                    m.eccentricity,
                    m.peak,
                    m.peak_mm[0],
                    m.peak_mm[1],
                ];
                for (b, x) in self.floats.iter_mut().zip(v) {
                    append_present(b, x);
                }
                self.clipped.append_value(m.clipped);
                append_ring(&mut self.polygon, &m.polygon);
                for h in &m.holes {
                    append_ring(self.holes.values(), h);
                }
                self.holes.append(true);
            }
            ContourOutcome::NoContact(r) => {
                self.contact.append_value(false);
                self.no_contact.append_value(no_contact_name(*r));
                for b in &mut self.floats {
                    b.append_null();
                }
                self.clipped.append_null();
                self.polygon.append(false);
                self.holes.append(false);
            }
        }
        Ok(())
    }

    fn len(&self) -> usize {
        self.seq.len()
    }

    fn finish(&mut self) -> Result<RecordBatch> {
        self.points = 0;
        let mut columns: Vec<ArrayRef> = vec![
            Arc::new(self.sensor.finish()),
            self.start.finish(),
            self.end.finish(),
            Arc::new(self.seq.finish()),
            Arc::new(self.contact.finish()),
            Arc::new(self.no_contact.finish()),
        ];
        columns.extend(self.floats.iter_mut().map(|b| Arc::new(b.finish()) as ArrayRef));
        columns.push(Arc::new(self.clipped.finish()));
        columns.push(Arc::new(self.polygon.finish()));
        columns.push(Arc::new(self.holes.finish()));
        RecordBatch::try_new(self.schema.clone(), columns).map_err(|e| arrow_error(ContourFrame::SCHEMA_ID, e))
    }
}
