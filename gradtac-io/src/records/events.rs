//! [`EventBatch`] as Arrow: schema `event/2`, one row per event.
//!
//! | column | Arrow type | meaning |
//! |---|---|---|
//! | `sensor` | `Utf8`, not null | the sensor's name |
//! | `time` | time ([`TimeBase`]), not null | the event's (interpolated) time, [`TactileEvent::time`] |
//! | `frame_time` | time ([`TimeBase`]), not null | the time of the frame whose interval the event fell in ([`EventBatch::time`]) |
//! | `seq` | `UInt64`, not null | that frame's index ([`EventBatch::seq`]) |
//! | `taxel` | `UInt16`, not null | the taxel's **number, counting from 1** in layout order (like the names `e1` … `e24`): [`TactileEvent::taxel`] (a 0-based index) + 1; field metadata `gradtac.taxels` = JSON array of the taxel names, so `names[taxel − 1]` names it |
//! | `polarity` | `Int8`, not null | +1 for a rise of `ln x`, −1 for a fall; under `[stages.events] polarity = "press"` / `"press_release"`: +1 away from the taxel's baseline, −1 back toward it |
//!
//! Batches are flattened: a batch of `k` events writes `k` rows in its own (time) order, and a
//! batch with no events writes **no row** (an event archive holds events, not frame ticks;
//! the frame stream is in the `frame/1` archive). The taxel count
//! ([`EventBatch::taxels`]) is not a column: it is the sink's [`EventShape`], and a batch
//! with another count, or an event with a taxel index ≥ the count, is rejected with
//! [`Error::Record`](crate::Error::Record).
//!
//! [`RecordBuilder::len`] counts pending **rows** (events), so a sink cuts row groups by
//! events, not by batches.

use super::columns::{record_error, schema_with_id, with_lead, with_taxels, LeadBuilder};
use super::{arrow_error, ArrowRecord, FrameShape, RecordBuilder, TimeBase};
use crate::Result;
use arrow_array::builder::{Int8Builder, UInt16Builder};
use arrow_array::RecordBatch;
use arrow_schema::{DataType, Field, SchemaRef};
use gradtac_stages::{EventBatch, TactileEvent};
use std::sync::Arc;

/// The taxels of the events one sink writes (names, in layout order) — the same shape as
/// frames: build it with [`FrameShape::from_layout`], [`FrameShape::new`] or
/// [`FrameShape::unnamed`].
pub type EventShape = FrameShape;

/// The `taxel` column's number of a taxel index: `index + 1` (taxel numbers count from 1,
/// like the layout names `e1` … `e24`). An appended event's index is below its batch's taxel
/// count, itself a `u16`, so the number always fits.
pub fn taxel_number(index: u16) -> u16 {
    index.saturating_add(1)
}

impl ArrowRecord for EventBatch {
    type Shape = EventShape;
    type Builder = EventBuilder;
    const SCHEMA_ID: &'static str = "event/2";

    fn schema(shape: &EventShape, time: TimeBase) -> SchemaRef {
        schema_with_id(
            with_lead(
                ["time", "frame_time"],
                time,
                vec![
                    with_taxels(Field::new("taxel", DataType::UInt16, false), shape),
                    Field::new("polarity", DataType::Int8, false),
                ],
            ),
            Self::SCHEMA_ID,
            time,
            vec![],
        )
    }

    fn builder(shape: &EventShape, time: TimeBase, capacity: usize) -> EventBuilder {
        EventBuilder {
            schema: Self::schema(shape, time),
            n: shape.len(),
            lead: LeadBuilder::with_capacity(time, capacity),
            taxel: UInt16Builder::with_capacity(capacity),
            polarity: Int8Builder::with_capacity(capacity),
        }
    }
}

/// Builds `event/2` batches (see the [module documentation](self)).
pub struct EventBuilder {
    schema: SchemaRef,
    n: usize,
    /// `sensor`, `time`, `frame_time`, `seq`.
    lead: LeadBuilder<2>,
    taxel: UInt16Builder,
    polarity: Int8Builder,
}

impl std::fmt::Debug for EventBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EventBuilder").field("taxels", &self.n).field("pending", &self.len()).finish()
    }
}

impl EventBuilder {
    fn check(&self, b: &EventBatch) -> Result<()> {
        let id = EventBatch::SCHEMA_ID;
        if b.taxels as usize != self.n {
            return Err(record_error(
                id,
                format!(
                    "sensor {} frame {} has {} taxels; this sink was built for {} taxels",
                    b.sensor, b.seq, b.taxels, self.n
                ),
            ));
        }
        if let Some((k, e)) = b.events.iter().enumerate().find(|(_, e)| e.taxel as usize >= self.n) {
            return Err(record_error(
                id,
                format!(
                    "sensor {} frame {} event {k}: taxel {} is beyond the {} taxels of this sink",
                    b.sensor, b.seq, e.taxel, self.n
                ),
            ));
        }
        Ok(())
    }

    fn push_event(&mut self, b: &EventBatch, e: &TactileEvent) {
        self.lead.append(&b.sensor, [e.time, b.time], b.seq);
        self.taxel.append_value(taxel_number(e.taxel));
        self.polarity.append_value(e.polarity);
    }
}

impl RecordBuilder<EventBatch> for EventBuilder {
    fn schema(&self) -> SchemaRef {
        self.schema.clone()
    }

    fn append(&mut self, batch: &EventBatch) -> Result<()> {
        self.check(batch)?;
        for e in &batch.events {
            self.push_event(batch, e);
        }
        Ok(())
    }

    /// Pending rows (events), not batches.
    fn len(&self) -> usize {
        self.lead.rows()
    }

    fn finish(&mut self) -> Result<RecordBatch> {
        let columns = self.lead.finish(vec![Arc::new(self.taxel.finish()), Arc::new(self.polarity.finish())]);
        RecordBatch::try_new(self.schema.clone(), columns).map_err(|e| arrow_error(EventBatch::SCHEMA_ID, e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::records::frame::TAXELS_KEY;
    use crate::records::{to_batch, SCHEMA_KEY};
    use arrow_array::{Array, DurationNanosecondArray, Int8Array, StringArray, UInt16Array, UInt64Array};
    use gradtac_stream::{SensorId, Timestamp};

    fn batch(seq: u64, taxels: u16, events: &[(i64, u16, i8)]) -> EventBatch {
        EventBatch {
            sensor: SensorId::new("ff"),
            time: Timestamp(seq as i64 * 10),
            seq,
            taxels,
            events: events
                .iter()
                .map(|&(t, taxel, polarity)| TactileEvent { time: Timestamp(t), taxel, polarity })
                .collect(),
        }
    }

    #[test]
    fn one_row_per_event_and_none_for_an_empty_batch() {
        let shape = EventShape::unnamed(3).unwrap();
        let b =
            to_batch(&shape, &[batch(0, 3, &[]), batch(1, 3, &[(3, 2, -1), (7, 0, 1)]), batch(2, 3, &[(15, 1, 1)])])
                .unwrap();
        assert_eq!(b.num_rows(), 3);
        let col = |i: usize| b.column(i).clone();
        let sensor = col(0);
        let sensor = sensor.as_any().downcast_ref::<StringArray>().unwrap();
        let t = col(1);
        let t = t.as_any().downcast_ref::<DurationNanosecondArray>().unwrap();
        let ft = col(2);
        let ft = ft.as_any().downcast_ref::<DurationNanosecondArray>().unwrap();
        let seq = col(3);
        let seq = seq.as_any().downcast_ref::<UInt64Array>().unwrap();
        let taxel = col(4);
        let taxel = taxel.as_any().downcast_ref::<UInt16Array>().unwrap();
        let pol = col(5);
        let pol = pol.as_any().downcast_ref::<Int8Array>().unwrap();
        assert_eq!(sensor.value(2), "ff");
        assert_eq!(t.values().to_vec(), vec![3, 7, 15]);
        assert_eq!(ft.values().to_vec(), vec![10, 10, 20]);
        assert_eq!(seq.values().to_vec(), vec![1, 1, 2]);
        assert_eq!(taxel.values().to_vec(), vec![3, 1, 2], "taxel numbers count from 1");
        assert_eq!(pol.values().to_vec(), vec![-1, 1, 1]);
        assert_eq!(b.schema().metadata().get(SCHEMA_KEY).map(String::as_str), Some("event/2"));
        assert_eq!(b.schema().field(4).metadata().get(TAXELS_KEY).map(String::as_str), Some(r#"["0","1","2"]"#));
    }

    #[test]
    fn bad_taxels_are_rejected_and_leave_the_builder_intact() {
        let shape = EventShape::unnamed(3).unwrap();
        let mut b = EventBatch::builder(&shape, crate::records::TimeBase::Relative, 4);
        b.append(&batch(0, 3, &[(0, 1, 1)])).unwrap();
        let e = b.append(&batch(1, 3, &[(1, 0, 1), (2, 3, 1)])).unwrap_err().to_string();
        assert!(e.contains("event/2") && e.contains("frame 1") && e.contains("taxel 3"), "{e}");
        let e = b.append(&batch(2, 4, &[(1, 0, 1)])).unwrap_err().to_string();
        assert!(e.contains("4 taxels") && e.contains("built for 3"), "{e}");
        assert_eq!(b.len(), 1);
        b.append(&batch(3, 3, &[(5, 2, -1)])).unwrap();
        assert_eq!(b.finish().unwrap().num_rows(), 2);
        assert!(b.is_empty());
    }
}
