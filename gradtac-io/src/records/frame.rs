//! [`TaxelFrame`] as Arrow: schema `frame/2`.
//!
//! | column | Arrow type | meaning |
//! |---|---|---|
//! | `sensor` | `Utf8`, not null | the sensor's name ([`SensorId`](gradtac_stream::SensorId)) |
//! | `time` | `Timestamp(ns, "UTC")` or `Duration(ns)` ([`TimeBase`]), not null | [`TaxelFrame::time`] |
//! | `seq` | `UInt64`, not null | index of the source frame, from 0 per sensor |
//! | `values` | `FixedSizeList<Float64 not null>[n]`, not null | one value per taxel, in layout order; field metadata `gradtac.taxels` = JSON array of the `n` taxel names |
//!
//! The schema's metadata holds `gradtac.schema = frame/2` and `gradtac.time`. `frame/1` (until
//! 0.1) had `time_ns` as `Int64` nanoseconds. `n` is fixed per sink by its
//! [`FrameShape`]; a frame with another count is rejected with [`Error::Record`].

use super::columns::{schema_with_id, with_lead, LeadBuilder};
use super::{arrow_error, ArrowRecord, RecordBuilder, TimeBase};
use crate::{Error, Result};
use arrow_array::builder::{FixedSizeListBuilder, Float64Builder};
use arrow_array::RecordBatch;
use arrow_schema::{DataType, Field, FieldRef, SchemaRef};
use gradtac_stream::{Layout, TaxelFrame};
use std::collections::HashMap;
use std::sync::Arc;

/// Field-metadata key of the taxel names on the `values` column (a JSON array of strings).
pub const TAXELS_KEY: &str = "gradtac.taxels";
/// Field-metadata key of a column's unit.
pub const UNIT_KEY: &str = "gradtac.unit";

/// The taxels of the frames one sink writes: their number and names, in value order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FrameShape {
    names: Arc<[String]>,
}

impl FrameShape {
    /// A shape from taxel names (at least one; no name twice).
    pub fn new(names: Vec<String>) -> Result<Self> {
        if names.is_empty() {
            return Err(Error::InvalidConfig("a frame shape needs at least one taxel".into()));
        }
        if i32::try_from(names.len()).is_err() {
            return Err(Error::InvalidConfig(format!("{} taxels is more than Arrow's i32 list size", names.len())));
        }
        let mut sorted: Vec<&String> = names.iter().collect();
        sorted.sort();
        if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
            return Err(Error::InvalidConfig(format!("taxel name {:?} appears twice", w[0])));
        }
        Ok(FrameShape { names: names.into() })
    }

    /// `count` taxels named by their index: `"0"`, `"1"`, ….
    pub fn unnamed(count: usize) -> Result<Self> {
        Self::new((0..count).map(|i| i.to_string()).collect())
    }

    /// The taxels of a layout, in its order.
    pub fn from_layout(layout: &Layout) -> Self {
        // A validated layout has ≥ 3 unique names.
        FrameShape { names: layout.names().to_vec().into() }
    }

    /// The taxel names, in value order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Number of taxels (values per frame).
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// Always false: a shape has at least one taxel.
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }
}

fn item_field() -> FieldRef {
    Arc::new(Field::new("item", DataType::Float64, false))
}

impl ArrowRecord for TaxelFrame {
    type Shape = FrameShape;
    type Builder = FrameBuilder;
    const SCHEMA_ID: &'static str = "frame/2";

    fn schema(shape: &FrameShape, time: TimeBase) -> SchemaRef {
        let taxels = serde_json::to_string(shape.names()).expect("a list of strings serialises");
        let n = shape.len() as i32;
        schema_with_id(
            with_lead(
                ["time"],
                time,
                vec![Field::new("values", DataType::FixedSizeList(item_field(), n), false)
                    .with_metadata(HashMap::from([(TAXELS_KEY.to_string(), taxels)]))],
            ),
            Self::SCHEMA_ID,
            time,
            vec![],
        )
    }

    fn builder(shape: &FrameShape, time: TimeBase, capacity: usize) -> FrameBuilder {
        let n = shape.len();
        FrameBuilder {
            schema: Self::schema(shape, time),
            n,
            lead: LeadBuilder::with_capacity(time, capacity),
            values: FixedSizeListBuilder::with_capacity(
                Float64Builder::with_capacity(capacity * n),
                n as i32,
                capacity,
            )
            .with_field(item_field()),
        }
    }
}

/// Builds `frame/2` batches (see the [module documentation](self)).
pub struct FrameBuilder {
    schema: SchemaRef,
    n: usize,
    /// `sensor`, `time`, `seq`.
    lead: LeadBuilder<1>,
    values: FixedSizeListBuilder<Float64Builder>,
}

impl std::fmt::Debug for FrameBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FrameBuilder").field("taxels", &self.n).field("pending", &self.len()).finish()
    }
}

impl RecordBuilder<TaxelFrame> for FrameBuilder {
    fn schema(&self) -> SchemaRef {
        self.schema.clone()
    }

    fn append(&mut self, frame: &TaxelFrame) -> Result<()> {
        if frame.values.len() != self.n {
            return Err(Error::Record {
                schema: TaxelFrame::SCHEMA_ID.into(),
                reason: format!(
                    "sensor {} frame {} has {} values; this sink was built for {} taxels",
                    frame.sensor,
                    frame.seq,
                    frame.values.len(),
                    self.n
                ),
            });
        }
        self.lead.append(&frame.sensor, [frame.time], frame.seq);
        self.values.values().append_slice(&frame.values);
        self.values.append(true);
        Ok(())
    }

    fn len(&self) -> usize {
        self.lead.rows()
    }

    fn finish(&mut self) -> Result<RecordBatch> {
        let columns = self.lead.finish(vec![Arc::new(self.values.finish())]);
        RecordBatch::try_new(self.schema.clone(), columns).map_err(|e| arrow_error(TaxelFrame::SCHEMA_ID, e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::records::{to_batch, to_batch_in, SCHEMA_KEY, TIME_KEY};
    use arrow_array::{
        Array, DurationNanosecondArray, FixedSizeListArray, Float64Array, StringArray, TimestampNanosecondArray,
        UInt64Array,
    };
    use arrow_schema::TimeUnit;
    use gradtac_stream::{SensorId, Timestamp};

    fn frame(s: &str, t: i64, seq: u64, v: Vec<f64>) -> TaxelFrame {
        TaxelFrame::new(SensorId::new(s), Timestamp(t), seq, v)
    }

    #[test]
    fn batch_holds_every_field_bit_exact() {
        let shape = FrameShape::new(vec!["a".into(), "b".into()]).unwrap();
        let odd = [f64::MIN_POSITIVE / 4.0, -0.0, f64::MAX, f64::NAN, 1e-300, 0.1 + 0.2];
        let frames: Vec<TaxelFrame> = odd
            .chunks(2)
            .enumerate()
            .map(|(i, v)| frame(if i == 1 { "th" } else { "ff" }, i as i64 * -7, i as u64, v.to_vec()))
            .collect();
        let b = to_batch(&shape, &frames).unwrap();
        assert_eq!(b.num_rows(), 3);
        let sensor = b.column(0).as_any().downcast_ref::<StringArray>().unwrap();
        let time = b.column(1).as_any().downcast_ref::<DurationNanosecondArray>().unwrap();
        let seq = b.column(2).as_any().downcast_ref::<UInt64Array>().unwrap();
        let values = b.column(3).as_any().downcast_ref::<FixedSizeListArray>().unwrap();
        let flat = values.values().as_any().downcast_ref::<Float64Array>().unwrap();
        assert_eq!(sensor.value(1), "th");
        assert_eq!(time.value(2), -14);
        assert_eq!(seq.value(2), 2);
        assert_eq!(values.value_length(), 2);
        let bits: Vec<u64> = flat.values().iter().map(|x| x.to_bits()).collect();
        assert_eq!(bits, odd.iter().map(|x| x.to_bits()).collect::<Vec<_>>());
        let md = b.schema().field(3).metadata().get(TAXELS_KEY).cloned();
        assert_eq!(md.as_deref(), Some(r#"["a","b"]"#));
        assert_eq!(b.schema().metadata().get(SCHEMA_KEY).map(String::as_str), Some("frame/2"));
        assert_eq!(b.schema().metadata().get(TIME_KEY).map(String::as_str), Some("relative"));
    }

    #[test]
    fn time_columns_take_the_type_of_the_time_base() {
        let shape = FrameShape::unnamed(1).unwrap();
        let f = [frame("ff", 1_700_000_000_123_456_789, 0, vec![1.0])];
        let utc = to_batch_in(&shape, TimeBase::Utc, &f).unwrap();
        assert_eq!(utc.schema().field(1).data_type(), &DataType::Timestamp(TimeUnit::Nanosecond, Some("UTC".into())));
        let t = utc.column(1).as_any().downcast_ref::<TimestampNanosecondArray>().unwrap();
        assert_eq!(t.value(0), 1_700_000_000_123_456_789);
        assert_eq!(t.timezone(), Some("UTC"));
        assert_eq!(utc.schema().metadata().get(TIME_KEY).map(String::as_str), Some("utc"));
        let rel = to_batch_in(&shape, TimeBase::Relative, &f).unwrap();
        assert_eq!(rel.schema().field(1).data_type(), &DataType::Duration(TimeUnit::Nanosecond));
        assert_eq!(rel.schema().field(1).name(), "time");
    }

    #[test]
    fn wrong_taxel_count_is_an_error_and_leaves_the_builder_intact() {
        let shape = FrameShape::unnamed(3).unwrap();
        let mut b = TaxelFrame::builder(&shape, TimeBase::default(), 4);
        b.append(&frame("ff", 0, 0, vec![1.0, 2.0, 3.0])).unwrap();
        let e = b.append(&frame("ff", 1, 41, vec![1.0, 2.0])).unwrap_err().to_string();
        assert!(
            e.contains("frame/2") && e.contains("frame 41") && e.contains("2 values") && e.contains("3 taxels"),
            "{e}"
        );
        assert_eq!(b.len(), 1);
        b.append(&frame("ff", 2, 2, vec![4.0, 5.0, 6.0])).unwrap();
        let batch = b.finish().unwrap();
        assert_eq!(batch.num_rows(), 2);
        assert!(b.is_empty());
        assert_eq!(b.finish().unwrap().num_rows(), 0);
    }

    #[test]
    fn shape_validation() {
        assert!(FrameShape::new(vec![]).is_err());
        assert!(FrameShape::new(vec!["a".into(), "a".into()]).is_err());
        let l = Layout::biotac_sp();
        let s = FrameShape::from_layout(&l);
        assert_eq!(s.len(), 24);
        assert_eq!(s.names()[0], l.names()[0]);
    }
}
