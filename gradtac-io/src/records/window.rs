//! [`WindowAggregate`] as Arrow: schema `window/2`, one row per aggregate.
//!
//! | column | Arrow type | meaning |
//! |---|---|---|
//! | `sensor` | `Utf8`, not null | the sensor's name |
//! | `start` | time ([`TimeBase`]), not null | start of the window's span ([`WindowAggregate::start`]) |
//! | `end` | time ([`TimeBase`]), not null | end of the span, the newest frame's time ([`WindowAggregate::end`]) |
//! | `seq` | `UInt64`, not null | index of the newest frame in the window |
//! | `frames` | `UInt64`, not null | number of input frames the window covers (0 for a duration window holding events only) |
//! | `aggregate` | `Utf8`, not null | what `values` holds: `signed` (Σ polarity), `count` (number of events) or `split` (signed sum, with `positive`/`negative`) |
//! | `values` | `FixedSizeList<Float64 not null>[n]`, not null | one aggregate per taxel, in layout order; `gradtac.taxels` = JSON array of the taxel names |
//! | `positive` | `FixedSizeList<Float64 not null>[n]`, **nullable** | events of polarity +1 per taxel; null when the aggregate has no split |
//! | `negative` | `FixedSizeList<Float64 not null>[n]`, **nullable** | events of polarity −1 per taxel (non-negative counts); null when the aggregate has no split |
//!
//! `n` is fixed per sink by its [`WindowShape`]; an aggregate with another number of values
//! (or a split of another length) is rejected with [`Error::Record`](crate::Error::Record).

use super::columns::{f64_list, item_field, record_error, schema_with_id, with_lead, with_taxels, LeadBuilder};
use super::{arrow_error, ArrowRecord, FrameShape, RecordBuilder, TimeBase};
use crate::Result;
use arrow_array::builder::{FixedSizeListBuilder, Float64Builder, StringBuilder, UInt64Builder};
use arrow_array::RecordBatch;
use arrow_schema::{DataType, Field, SchemaRef};
use gradtac_stages::window::{Aggregate, WindowAggregate};
use std::sync::Arc;

/// The taxels of the aggregates one sink writes (names, in layout order) — the same shape as
/// frames: build it with [`FrameShape::from_layout`], [`FrameShape::new`] or
/// [`FrameShape::unnamed`].
pub type WindowShape = FrameShape;

/// The `aggregate` column's text for an [`Aggregate`] (as in scene files).
pub fn aggregate_name(a: Aggregate) -> &'static str {
    match a {
        Aggregate::Signed => "signed",
        Aggregate::Count => "count",
        Aggregate::Split => "split",
    }
}

fn list_builder(n: usize, capacity: usize) -> FixedSizeListBuilder<Float64Builder> {
    FixedSizeListBuilder::with_capacity(Float64Builder::with_capacity(capacity * n), n as i32, capacity)
        .with_field(item_field())
}

impl ArrowRecord for WindowAggregate {
    type Shape = WindowShape;
    type Builder = WindowBuilder;
    const SCHEMA_ID: &'static str = "window/2";

    fn schema(shape: &WindowShape, time: TimeBase) -> SchemaRef {
        let n = shape.len();
        schema_with_id(
            with_lead(
                ["start", "end"],
                time,
                vec![
                    Field::new("frames", DataType::UInt64, false),
                    Field::new("aggregate", DataType::Utf8, false),
                    with_taxels(Field::new("values", f64_list(n), false), shape),
                    with_taxels(Field::new("positive", f64_list(n), true), shape),
                    with_taxels(Field::new("negative", f64_list(n), true), shape),
                ],
            ),
            Self::SCHEMA_ID,
            time,
            vec![],
        )
    }

    fn builder(shape: &WindowShape, time: TimeBase, capacity: usize) -> WindowBuilder {
        let n = shape.len();
        WindowBuilder {
            schema: Self::schema(shape, time),
            n,
            lead: LeadBuilder::with_capacity(time, capacity),
            frames: UInt64Builder::with_capacity(capacity),
            aggregate: StringBuilder::with_capacity(capacity, capacity * 6),
            values: list_builder(n, capacity),
            positive: list_builder(n, 0),
            negative: list_builder(n, 0),
        }
    }
}

/// Builds `window/2` batches (see the [module documentation](self)).
pub struct WindowBuilder {
    schema: SchemaRef,
    n: usize,
    /// `sensor`, `start`, `end`, `seq`.
    lead: LeadBuilder<2>,
    frames: UInt64Builder,
    aggregate: StringBuilder,
    values: FixedSizeListBuilder<Float64Builder>,
    positive: FixedSizeListBuilder<Float64Builder>,
    negative: FixedSizeListBuilder<Float64Builder>,
}

impl std::fmt::Debug for WindowBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WindowBuilder").field("taxels", &self.n).field("pending", &self.len()).finish()
    }
}

fn append_list(b: &mut FixedSizeListBuilder<Float64Builder>, values: Option<&[f64]>, n: usize) {
    match values {
        Some(v) => {
            b.values().append_slice(v);
            b.append(true);
        }
        None => {
            // A null list still takes `n` child slots; they hold 0.0 and are never read.
            b.values().append_slice(&vec![0.0; n]);
            b.append(false);
        }
    }
}

impl RecordBuilder<WindowAggregate> for WindowBuilder {
    fn schema(&self) -> SchemaRef {
        self.schema.clone()
    }

    fn append(&mut self, w: &WindowAggregate) -> Result<()> {
        let n = self.n;
        let misfit = |what: &str, len: usize| {
            record_error(
                WindowAggregate::SCHEMA_ID,
                format!(
                    "sensor {} window ending at frame {} has {len} {what}; this sink was built for {n} taxels",
                    w.sensor, w.seq
                ),
            )
        };
        if w.values.len() != n {
            return Err(misfit("values", w.values.len()));
        }
        if let Some(s) = &w.split {
            if s.positive.len() != n {
                return Err(misfit("positive counts", s.positive.len()));
            }
            if s.negative.len() != n {
                return Err(misfit("negative counts", s.negative.len()));
            }
        }
        self.lead.append(&w.sensor, [w.start, w.end], w.seq);
        self.frames.append_value(w.frames);
        self.aggregate.append_value(aggregate_name(w.aggregate));
        append_list(&mut self.values, Some(&w.values), n);
        append_list(&mut self.positive, w.split.as_ref().map(|s| s.positive.as_slice()), n);
        append_list(&mut self.negative, w.split.as_ref().map(|s| s.negative.as_slice()), n);
        Ok(())
    }

    fn len(&self) -> usize {
        self.lead.rows()
    }

    fn finish(&mut self) -> Result<RecordBatch> {
        let columns = self.lead.finish(vec![
            Arc::new(self.frames.finish()),
            Arc::new(self.aggregate.finish()),
            Arc::new(self.values.finish()),
            Arc::new(self.positive.finish()),
            Arc::new(self.negative.finish()),
        ]);
        RecordBatch::try_new(self.schema.clone(), columns).map_err(|e| arrow_error(WindowAggregate::SCHEMA_ID, e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::records::to_batch;
    use arrow_array::{Array, FixedSizeListArray};
    use gradtac_stages::window::Split;
    use gradtac_stream::{SensorId, Timestamp};

    fn agg(values: Vec<f64>, split: Option<Split>) -> WindowAggregate {
        WindowAggregate {
            sensor: SensorId::new("ff"),
            start: Timestamp(0),
            end: Timestamp(90),
            seq: 9,
            frames: 10,
            aggregate: if split.is_some() { Aggregate::Split } else { Aggregate::Signed },
            values,
            split,
        }
    }

    #[test]
    fn split_columns_are_null_without_a_split() {
        let shape = WindowShape::unnamed(2).unwrap();
        let split = Split { positive: vec![1.0, 0.0], negative: vec![0.0, 2.0] };
        let b = to_batch(&shape, &[agg(vec![1.0, -1.0], None), agg(vec![1.0, -2.0], Some(split))]).unwrap();
        let pos = b.column_by_name("positive").unwrap().as_any().downcast_ref::<FixedSizeListArray>().unwrap();
        assert!(pos.is_null(0) && pos.is_valid(1));
        assert_eq!(b.column_by_name("aggregate").unwrap().len(), 2);
    }

    #[test]
    fn wrong_lengths_are_rejected_and_leave_the_builder_intact() {
        let shape = WindowShape::unnamed(2).unwrap();
        let mut b = WindowAggregate::builder(&shape, crate::records::TimeBase::Relative, 2);
        b.append(&agg(vec![1.0, 2.0], None)).unwrap();
        let e = b.append(&agg(vec![1.0], None)).unwrap_err().to_string();
        assert!(e.contains("window/2") && e.contains("1 values") && e.contains("2 taxels"), "{e}");
        let bad = Split { positive: vec![1.0, 0.0], negative: vec![0.0] };
        let e = b.append(&agg(vec![1.0, 2.0], Some(bad))).unwrap_err().to_string();
        assert!(e.contains("1 negative counts"), "{e}");
        assert_eq!(b.len(), 1);
        assert_eq!(b.finish().unwrap().num_rows(), 1);
    }
}
