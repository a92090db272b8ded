//! Column helpers shared by the record schemas (fields with units, taxel lists, points, and
//! the leading `sensor` / time / `seq` columns of per-sensor records, time columns).

use super::frame::{FrameShape, TAXELS_KEY, UNIT_KEY};
use super::{TimeBase, SCHEMA_KEY, TIME_KEY};
use crate::Error;
use arrow_array::builder::{ArrayBuilder, Float64Builder, Int64Builder, StringBuilder, UInt64Builder};
use arrow_array::types::{DurationNanosecondType, TimestampNanosecondType};
use arrow_array::ArrayRef;
use arrow_schema::{DataType, Field, FieldRef, Schema, SchemaRef};
use gradtac_stream::{SensorId, Timestamp};
use std::collections::HashMap;
use std::sync::Arc;

/// A field with `gradtac.unit = unit` in its metadata.
pub(crate) fn unit_field(name: &str, data_type: DataType, nullable: bool, unit: &str) -> Field {
    Field::new(name, data_type, nullable).with_metadata(HashMap::from([(UNIT_KEY.to_string(), unit.to_string())]))
}

/// A not-null time column of `base`'s Arrow type (`Timestamp(ns, "UTC")` or `Duration(ns)`).
pub(crate) fn time_field(name: &str, base: TimeBase) -> Field {
    Field::new(name, base.data_type(), false)
}

/// Builds one time column of a [`TimeBase`]: `Timestamp(ns, "UTC")` or `Duration(ns)`, both
/// holding the [`Timestamp`]'s nanoseconds unchanged.
pub(crate) struct TimeBuilder {
    base: TimeBase,
    ns: Int64Builder,
}

impl TimeBuilder {
    /// Room for `capacity` rows.
    pub(crate) fn with_capacity(base: TimeBase, capacity: usize) -> Self {
        TimeBuilder { base, ns: Int64Builder::with_capacity(capacity) }
    }

    /// Appends one time.
    pub(crate) fn append(&mut self, t: Timestamp) {
        self.ns.append_value(t.as_nanos());
    }

    /// Pending rows.
    pub(crate) fn len(&self) -> usize {
        self.ns.len()
    }

    /// The column, typed by the base (a reinterpretation of the same `i64` buffer, no copy).
    pub(crate) fn finish(&mut self) -> ArrayRef {
        let ns = self.ns.finish();
        match self.base {
            TimeBase::Utc => Arc::new(ns.reinterpret_cast::<TimestampNanosecondType>().with_timezone("UTC")),
            TimeBase::Relative => Arc::new(ns.reinterpret_cast::<DurationNanosecondType>()),
        }
    }
}

/// Appends `v`, or null when it is NaN (an absent value: the records never store NaN in a
/// scalar column).
pub(crate) fn append_present(b: &mut Float64Builder, v: f64) {
    if v.is_nan() {
        b.append_null();
    } else {
        b.append_value(v);
    }
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

/// A schema with `gradtac.schema = id`, `gradtac.time = <base>` and the `extra` pairs in its
/// metadata.
pub(crate) fn schema_with_id(fields: Vec<Field>, id: &str, base: TimeBase, extra: Vec<(String, String)>) -> SchemaRef {
    let mut md =
        HashMap::from([(SCHEMA_KEY.to_string(), id.to_string()), (TIME_KEY.to_string(), base.name().to_string())]);
    md.extend(extra);
    Arc::new(Schema::new_with_metadata(fields, md))
}

/// [`Error::Record`] for schema `id`.
pub(crate) fn record_error(id: &str, reason: String) -> Error {
    Error::Record { schema: id.to_string(), reason }
}

/// The leading columns of a per-sensor record — `sensor` (`Utf8`, not null), one not-null
/// time column of `base`'s type per name in `times`, `seq` (`UInt64`, not null), in that
/// order — followed by `rest`.
pub(crate) fn with_lead<const N: usize>(times: [&str; N], base: TimeBase, rest: Vec<Field>) -> Vec<Field> {
    let mut fields = Vec::with_capacity(N + 2 + rest.len());
    fields.push(Field::new("sensor", DataType::Utf8, false));
    fields.extend(times.map(|t| time_field(t, base)));
    fields.push(Field::new("seq", DataType::UInt64, false));
    fields.extend(rest);
    fields
}

/// Builds the leading columns of [`with_lead`]: the sensor, `N` times and the sequence number
/// of each row.
pub(crate) struct LeadBuilder<const N: usize> {
    sensor: StringBuilder,
    times: [TimeBuilder; N],
    seq: UInt64Builder,
}

impl<const N: usize> LeadBuilder<N> {
    /// Room for `capacity` rows (and sensor names of about 4 bytes).
    pub(crate) fn with_capacity(base: TimeBase, capacity: usize) -> Self {
        LeadBuilder {
            sensor: StringBuilder::with_capacity(capacity, capacity * 4),
            times: std::array::from_fn(|_| TimeBuilder::with_capacity(base, capacity)),
            seq: UInt64Builder::with_capacity(capacity),
        }
    }

    /// Appends one row's leading values (the times in the order of the names given to
    /// [`with_lead`]).
    pub(crate) fn append(&mut self, sensor: &SensorId, times: [Timestamp; N], seq: u64) {
        self.sensor.append_value(sensor.as_str());
        for (builder, t) in self.times.iter_mut().zip(times) {
            builder.append(t);
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
        columns.extend(self.times.iter_mut().map(TimeBuilder::finish));
        columns.push(Arc::new(self.seq.finish()));
        columns.extend(rest);
        columns
    }
}
