//! Column helpers shared by the record schemas (fields with units, taxel lists, points, and
//! the leading `sensor` / time / `seq` columns of per-sensor records).

use super::frame::{FrameShape, TAXELS_KEY, UNIT_KEY};
use super::SCHEMA_KEY;
use crate::Error;
use arrow_array::builder::{ArrayBuilder, Int64Builder, StringBuilder, UInt64Builder};
use arrow_array::ArrayRef;
use arrow_schema::{DataType, Field, FieldRef, Schema, SchemaRef};
use gradtac_stream::{SensorId, Timestamp};
use std::collections::HashMap;
use std::sync::Arc;

/// A field with `gradtac.unit = unit` in its metadata.
pub(crate) fn unit_field(name: &str, data_type: DataType, nullable: bool, unit: &str) -> Field {
    Field::new(name, data_type, nullable).with_metadata(HashMap::from([(UNIT_KEY.to_string(), unit.to_string())]))
}

/// A not-null `Int64` time column in ns.
pub(crate) fn ns_field(name: &str) -> Field {
    unit_field(name, DataType::Int64, false, "ns")
}

/// The not-null `Float64` item of a list column.
pub(crate) fn item_field() -> FieldRef {
    Arc::new(Field::new("item", DataType::Float64, false))
}

/// `FixedSizeList<Float64 not null>[n]`.
pub(crate) fn f64_list(n: usize) -> DataType {
    DataType::FixedSizeList(item_field(), n as i32)
}

/// The not-null `[x, y]` item of a point list (`FixedSizeList<Float64 not null>[2]`).
pub(crate) fn point_item_field() -> FieldRef {
    Arc::new(Field::new("item", f64_list(2), false))
}

/// The JSON array of a shape's taxel names (the value of `gradtac.taxels`).
pub(crate) fn taxel_names_json(shape: &FrameShape) -> String {
    serde_json::to_string(shape.names()).expect("a list of strings serialises")
}

/// A field whose metadata holds the taxel names of `shape` under `gradtac.taxels`.
pub(crate) fn with_taxels(field: Field, shape: &FrameShape) -> Field {
    let mut md = field.metadata().clone();
    md.insert(TAXELS_KEY.to_string(), taxel_names_json(shape));
    field.with_metadata(md)
}

/// A schema with `gradtac.schema = id` and the `extra` pairs in its metadata.
pub(crate) fn schema_with_id(fields: Vec<Field>, id: &str, extra: Vec<(String, String)>) -> SchemaRef {
    let mut md = HashMap::from([(SCHEMA_KEY.to_string(), id.to_string())]);
    md.extend(extra);
    Arc::new(Schema::new_with_metadata(fields, md))
}

/// [`Error::Record`] for schema `id`.
pub(crate) fn record_error(id: &str, reason: String) -> Error {
    Error::Record { schema: id.to_string(), reason }
}

/// The leading columns of a per-sensor record — `sensor` (`Utf8`, not null), one not-null
/// `Int64` ns column per name in `times` (with `gradtac.unit = ns`), `seq` (`UInt64`, not
/// null), in that order — followed by `rest`.
pub(crate) fn with_lead<const N: usize>(times: [&str; N], rest: Vec<Field>) -> Vec<Field> {
    let mut fields = Vec::with_capacity(N + 2 + rest.len());
    fields.push(Field::new("sensor", DataType::Utf8, false));
    fields.extend(times.map(ns_field));
    fields.push(Field::new("seq", DataType::UInt64, false));
    fields.extend(rest);
    fields
}

/// Builds the leading columns of [`with_lead`]: the sensor, `N` times and the sequence number
/// of each row.
pub(crate) struct LeadBuilder<const N: usize> {
    sensor: StringBuilder,
    times: [Int64Builder; N],
    seq: UInt64Builder,
}

impl<const N: usize> LeadBuilder<N> {
    /// Room for `capacity` rows (and sensor names of about 4 bytes).
    pub(crate) fn with_capacity(capacity: usize) -> Self {
        LeadBuilder {
            sensor: StringBuilder::with_capacity(capacity, capacity * 4),
            times: std::array::from_fn(|_| Int64Builder::with_capacity(capacity)),
            seq: UInt64Builder::with_capacity(capacity),
        }
    }

    /// Appends one row's leading values (the times in the order of the names given to
    /// [`with_lead`]).
    pub(crate) fn append(&mut self, sensor: &SensorId, times: [Timestamp; N], seq: u64) {
        self.sensor.append_value(sensor.as_str());
        for (builder, t) in self.times.iter_mut().zip(times) {
            builder.append_value(t.as_nanos());
        }
        self.seq.append_value(seq);
    }

    /// Pending rows.
    pub(crate) fn rows(&self) -> usize {
        self.seq.len()
    }

    /// The finished leading columns, in schema order, followed by `rest`.
    pub(crate) fn finish(&mut self, rest: Vec<ArrayRef>) -> Vec<ArrayRef> {
        let mut columns: Vec<ArrayRef> = Vec::with_capacity(N + 2 + rest.len());
        columns.push(Arc::new(self.sensor.finish()));
        columns.extend(self.times.iter_mut().map(|b| Arc::new(b.finish()) as ArrayRef));
        columns.push(Arc::new(self.seq.finish()));
        columns.extend(rest);
        columns
    }
}
