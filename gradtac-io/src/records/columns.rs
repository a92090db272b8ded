//! Column helpers shared by the record schemas (fields with units, taxel lists, points).

use super::frame::{FrameShape, TAXELS_KEY, UNIT_KEY};
use super::SCHEMA_KEY;
use crate::Error;
use arrow_schema::{DataType, Field, FieldRef, Schema, SchemaRef};
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
