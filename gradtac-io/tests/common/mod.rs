//! Helpers shared by the Parquet round-trip tests (`records.rs`, `records_tasks.rs`,
//! `parquet_sink.rs`): writing records through `ParquetSink`, reading a file back with its
//! metadata, typed column accessors, bit patterns of floats, and running pyarrow.
//!
//! Each test crate uses a subset of these, hence `dead_code` is allowed.

#![allow(dead_code)]

use arrow_array::cast::AsArray;
use arrow_array::types::{Float64Type, Int64Type, UInt64Type};
use arrow_array::{Array, RecordBatch};
use gradtac_io::records::frame::UNIT_KEY;
use gradtac_io::records::{ArrowRecord, SCHEMA_KEY};
use gradtac_io::ParquetSink;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::collections::HashMap;
use std::ffi::OsStr;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;

// ---------------------------------------------------------------------------------------------
// special values

pub const SPECIALS: [f64; 9] =
    [f64::MIN_POSITIVE / 3.0, -0.0, f64::MAX, f64::MIN, f64::INFINITY, f64::NEG_INFINITY, 0.1 + 0.2, -1e-300, f64::NAN];

/// A NaN with a payload, to check NaNs are stored bit-exactly.
pub fn odd_nan() -> f64 {
    f64::from_bits(0x7ff8_0000_dead_beef)
}

/// The `k`-th special value: every tenth is [`odd_nan`], the others cycle through [`SPECIALS`].
pub fn special(k: usize) -> f64 {
    if k % 10 == 9 {
        odd_nan()
    } else {
        SPECIALS[k % SPECIALS.len()]
    }
}

// ---------------------------------------------------------------------------------------------
// writing and reading

/// Writes `records` to `path` through a `ParquetSink` with row groups of `row_group` rows.
pub fn write<T: ArrowRecord>(path: &Path, shape: T::Shape, records: &[T], row_group: usize) -> PathBuf {
    let mut sink = ParquetSink::<T>::try_new(path, shape).unwrap().with_row_group_size(row_group).unwrap();
    for r in records {
        sink.push(r).unwrap();
    }
    sink.finish().unwrap()
}

/// A Parquet file read back: its batches, its key-value metadata and the reader's schema.
pub struct ReadBack {
    /// The batches; one empty batch (with the file's schema) when the file has no rows.
    pub batches: Vec<RecordBatch>,
    pub kv: HashMap<String, String>,
    /// The reader's schema (restored from `ARROW:schema`, with schema and field metadata).
    pub schema: arrow_schema::SchemaRef,
}

impl ReadBack {
    pub fn schema(&self) -> arrow_schema::SchemaRef {
        self.schema.clone()
    }
}

/// Reads the whole file at `path`. A file without rows gives one empty batch, so that column
/// accessors can still be called on `batches[0]`.
pub fn read(path: &Path) -> ReadBack {
    let builder = ParquetRecordBatchReaderBuilder::try_new(File::open(path).unwrap()).unwrap();
    let kv = builder
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .map(|kv| kv.iter().map(|kv| (kv.key.clone(), kv.value.clone().unwrap_or_default())).collect())
        .unwrap_or_default();
    let schema = builder.schema().clone();
    let mut batches = builder.build().unwrap().collect::<Result<Vec<_>, _>>().unwrap();
    if batches.is_empty() {
        batches.push(RecordBatch::new_empty(schema.clone()));
    }
    ReadBack { batches, kv, schema }
}

/// The schema id, checked to be the same in the Arrow schema and the Parquet key-value
/// metadata, and checked to come with this crate's version.
pub fn schema_id(r: &ReadBack) -> String {
    assert_eq!(r.schema.metadata().get(SCHEMA_KEY), r.kv.get(SCHEMA_KEY), "schema id in Arrow and Parquet metadata");
    assert_eq!(r.kv["gradtac.version"], env!("CARGO_PKG_VERSION"));
    r.kv[SCHEMA_KEY].clone()
}

/// The unit in the metadata of field `name`.
pub fn unit(r: &ReadBack, name: &str) -> Option<String> {
    r.schema.field_with_name(name).unwrap().metadata().get(UNIT_KEY).cloned()
}

/// Whether field `name` is nullable.
pub fn nullable(r: &ReadBack, name: &str) -> bool {
    r.schema.field_with_name(name).unwrap().is_nullable()
}

/// The number of rows in the file.
pub fn rows(r: &ReadBack) -> usize {
    r.batches.iter().map(RecordBatch::num_rows).sum()
}

// ---------------------------------------------------------------------------------------------
// columns

pub fn col<'a>(b: &'a RecordBatch, name: &str) -> &'a Arc<dyn Array> {
    b.column_by_name(name).unwrap_or_else(|| panic!("no column {name}"))
}

pub fn strs(b: &RecordBatch, name: &str) -> Vec<Option<String>> {
    col(b, name).as_string::<i32>().iter().map(|s| s.map(str::to_string)).collect()
}

/// A not-null `Int64` column.
pub fn i64s(b: &RecordBatch, name: &str) -> Vec<i64> {
    let c = col(b, name);
    let (nulls, values) = if let Some(a) = c.as_primitive_opt::<Int64Type>() {
        (a.null_count(), a.values().to_vec())
    } else if let Some(a) = c.as_primitive_opt::<arrow_array::types::TimestampNanosecondType>() {
        (a.null_count(), a.values().to_vec())
    } else {
        let a = c.as_primitive::<arrow_array::types::DurationNanosecondType>();
        (a.null_count(), a.values().to_vec())
    };
    assert_eq!(nulls, 0, "{name}");
    values
}

/// A not-null `UInt64` column.
pub fn u64s(b: &RecordBatch, name: &str) -> Vec<u64> {
    let a = col(b, name).as_primitive::<UInt64Type>();
    assert_eq!(a.null_count(), 0, "{name}");
    a.values().to_vec()
}

/// A `UInt64` column that may hold nulls.
pub fn opt_u64s(b: &RecordBatch, name: &str) -> Vec<Option<u64>> {
    col(b, name).as_primitive::<UInt64Type>().iter().collect()
}

pub fn f64s(b: &RecordBatch, name: &str) -> Vec<Option<f64>> {
    col(b, name).as_primitive::<Float64Type>().iter().collect()
}

/// A not-null `FixedSizeList<Float64>` column as one `Vec<f64>` per row.
pub fn f64_lists(b: &RecordBatch, name: &str) -> Vec<Vec<f64>> {
    let a = col(b, name).as_fixed_size_list();
    assert_eq!(a.null_count(), 0, "{name}");
    (0..a.len()).map(|r| a.value(r).as_primitive::<Float64Type>().values().to_vec()).collect()
}

/// A `FixedSizeList<Float64>` column as one `Option<Vec<f64>>` per row.
pub fn opt_f64_lists(b: &RecordBatch, name: &str) -> Vec<Option<Vec<f64>>> {
    let a = col(b, name).as_fixed_size_list();
    (0..a.len()).map(|r| a.is_valid(r).then(|| a.value(r).as_primitive::<Float64Type>().values().to_vec())).collect()
}

pub fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

// ---------------------------------------------------------------------------------------------
// pyarrow

/// Python's `float.hex` of `x` (`nan`, `inf`, `-inf` for the non-finite; zero as `-0x0.0p+0`,
/// subnormals as `0x0.…p-1022`, otherwise always 13 hex digits).
pub fn python_float_hex(x: f64) -> String {
    if x.is_nan() {
        return "nan".into();
    }
    if x.is_infinite() {
        return if x > 0.0 { "inf" } else { "-inf" }.into();
    }
    let sign = if x.is_sign_negative() { "-" } else { "" };
    let bits = x.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i64;
    let mant = bits & ((1u64 << 52) - 1);
    if exp == 0 && mant == 0 {
        return format!("{sign}0x0.0p+0");
    }
    let (lead, e) = if exp == 0 { (0, -1022) } else { (1, exp - 1023) };
    format!("{sign}0x{lead}.{mant:013x}p{}{}", if e >= 0 { "+" } else { "-" }, e.abs())
}

#[test]
fn python_float_hex_matches_known_values() {
    assert_eq!(python_float_hex(3.0), "0x1.8000000000000p+1");
    assert_eq!(python_float_hex(1.0), "0x1.0000000000000p+0");
    assert_eq!(python_float_hex(-0.0), "-0x0.0p+0");
    assert_eq!(python_float_hex(0.1), "0x1.999999999999ap-4");
    assert_eq!(python_float_hex(5e-324), "0x0.0000000000001p-1022");
    assert_eq!(python_float_hex(f64::NEG_INFINITY), "-inf");
    assert_eq!(python_float_hex(f64::INFINITY), "inf");
    assert_eq!(python_float_hex(odd_nan()), "nan");
}

/// `x` as Python's `float.hex`, a JSON string.
pub fn h(x: f64) -> serde_json::Value {
    serde_json::Value::String(python_float_hex(x))
}

pub fn hs(v: &[f64]) -> serde_json::Value {
    v.iter().copied().map(h).collect()
}

pub fn hp(v: &[[f64; 2]]) -> serde_json::Value {
    v.iter().map(|p| hs(p)).collect()
}

/// Whether `python3` can import pyarrow; when it cannot, says on stderr that the test is skipped.
pub fn pyarrow_available() -> bool {
    let ok =
        Command::new("python3").args(["-c", "import pyarrow"]).output().map(|o| o.status.success()).unwrap_or(false);
    if !ok {
        eprintln!("skipped: python3 with pyarrow is not available");
    }
    ok
}

/// Runs `python3 -c script args…`, asserts that it succeeded (showing its stderr if not) and
/// parses what it printed as JSON.
pub fn run_python<I, S>(script: &str, args: I) -> serde_json::Value
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    let out = Command::new("python3").arg("-c").arg(script).args(args).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

/// Python that defines `describe(path)`: a Parquet file's `gradtac.schema`, its Arrow schema
/// metadata (without `ARROW:schema`), its column types, and its rows with every float as
/// `float.hex`. Scripts append their own use of it.
pub const PY_DESCRIBE: &str = r#"
import json, sys
import pyarrow.parquet as pq

def conv(v):
    if isinstance(v, float):
        return float.hex(v)
    if isinstance(v, list):
        return [conv(x) for x in v]
    if isinstance(v, dict):
        return {k: conv(x) for k, x in v.items()}
    return v

def describe(path):
    import pyarrow as pa
    t = pq.read_table(path)
    md = pq.read_metadata(path).metadata
    # times (Timestamp / Duration) as their integer nanoseconds
    ints = pa.table(
        [c.cast(pa.int64()) if pa.types.is_timestamp(c.type) or pa.types.is_duration(c.type) else c for c in t.columns],
        names=t.column_names,
    )
    return {
        "schema": md[b"gradtac.schema"].decode(),
        "arrow_md": {k.decode(): v.decode() for k, v in (t.schema.metadata or {}).items() if k != b"ARROW:schema"},
        "types": {f.name: str(f.type) for f in t.schema},
        "rows": conv(ints.to_pylist()),
    }
"#;
