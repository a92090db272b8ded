//! A stage that turns records of any output type into Arrow [`RecordBatch`](https://docs.rs/arrow-array/60/arrow_array/struct.RecordBatch.html)es: the in-memory
//! sink a host application takes Arrow data from.
//!
//! Records are appended to Arrow builders as they arrive ([`ArrowRecord`]) and cut into
//! batches of `rows` rows; [`Stage::finish`] emits the last, shorter batch. A batch is built
//! once and never copied afterwards (its columns are reference-counted buffers), so handing
//! it to the host is free. The reverse direction — batches a host hands in, decoded to
//! frames — is [`crate::arrow_ipc::BatchDecoder`].
//!
//! ```
//! use gradtac_io::batches::ToBatches;
//! use gradtac_io::records::FrameShape;
//! use gradtac_stream::{SensorId, StageExt, TaxelFrame, Timestamp};
//!
//! let frames = (0..5u64).map(|k| TaxelFrame::new(SensorId::new("ff"), Timestamp(k as i64), k, vec![k as f64; 3]));
//! let mut to_batches = ToBatches::<TaxelFrame>::try_new(FrameShape::unnamed(3)?, 2)?;
//! let batches = to_batches.run_all(frames)?;
//! assert_eq!(batches.iter().map(|b| b.num_rows()).collect::<Vec<_>>(), [2, 2, 1]);
//! # Ok::<(), gradtac_io::Error>(())
//! ```

use crate::records::{ArrowRecord, RecordBuilder, TimeBase};
use crate::{Error, Result};
use arrow_array::RecordBatch;
use gradtac_stream::Stage;

/// Records in, [`RecordBatch`]es of `rows` rows out (see the [module docs](self)).
///
/// Delay: up to `rows − 1` records (a batch leaves when it is full).
#[must_use = "a stage does nothing until records are pushed"]
pub struct ToBatches<T: ArrowRecord> {
    shape: T::Shape,
    builder: T::Builder,
    rows: usize,
}

impl<T: ArrowRecord> ToBatches<T> {
    /// Batches of `rows` (≥ 1) rows of `T`'s schema for `shape`.
    pub fn try_new(shape: T::Shape, rows: usize) -> Result<Self> {
        if rows == 0 {
            return Err(Error::InvalidConfig("ToBatches: rows per batch must be ≥ 1".into()));
        }
        let builder = T::builder(&shape, TimeBase::default(), rows.min(8192));
        Ok(ToBatches { shape, builder, rows })
    }

    /// The schema of every batch.
    pub fn schema(&self) -> arrow_schema::SchemaRef {
        T::schema(&self.shape, TimeBase::default())
    }
}

impl<T: ArrowRecord> Stage for ToBatches<T> {
    type In = T;
    type Out = RecordBatch;
    type Error = Error;

    fn push(&mut self, record: T, out: &mut Vec<RecordBatch>) -> Result<()> {
        self.builder.append(&record)?;
        if self.builder.len() >= self.rows {
            out.push(self.builder.finish()?);
        }
        Ok(())
    }

    fn finish(&mut self, out: &mut Vec<RecordBatch>) -> Result<()> {
        if !self.builder.is_empty() {
            out.push(self.builder.finish()?);
        }
        Ok(())
    }

    /// Drops the records not yet in a batch.
    fn reset(&mut self) {
        self.builder = T::builder(&self.shape, TimeBase::default(), self.rows.min(8192));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arrow_ipc::{BatchDecoder, BatchLayout};
    use crate::records::FrameShape;
    use gradtac_stream::{SensorId, StageExt, TaxelFrame, Timestamp};
    use proptest::prelude::*;

    fn frames(n: u64, sensors: &[&str]) -> Vec<TaxelFrame> {
        (0..n)
            .map(|k| {
                let s = sensors[(k as usize) % sensors.len()];
                TaxelFrame::new(
                    SensorId::new(s),
                    Timestamp(k as i64 * 10),
                    k / sensors.len() as u64,
                    vec![k as f64, -0.5, 1e300],
                )
            })
            .collect()
    }

    proptest! {
        /// Frames → batches (any size) → the long-layout decoder gives the same frames back.
        #[test]
        fn frames_round_trip_through_record_batches(n in 0u64..60, rows in 1usize..17) {
            let input = frames(n, &["ff", "th"]);
            let batches = ToBatches::<TaxelFrame>::try_new(FrameShape::unnamed(3).unwrap(), rows).unwrap()
                .run_all(input.clone()).unwrap();
            prop_assert!(batches.iter().all(|b| b.num_rows() <= rows));
            prop_assert_eq!(batches.iter().map(|b| b.num_rows() as u64).sum::<u64>(), n);
            let mut dec = BatchDecoder::new("memory", BatchLayout::Long { sensors: None });
            let back = dec.run_all(batches).unwrap();
            prop_assert_eq!(back, input);
        }
    }

    #[test]
    fn zero_rows_is_refused_and_a_bad_record_is_an_error() {
        assert!(ToBatches::<TaxelFrame>::try_new(FrameShape::unnamed(3).unwrap(), 0).is_err());
        let mut b = ToBatches::<TaxelFrame>::try_new(FrameShape::unnamed(2).unwrap(), 4).unwrap();
        let mut out = Vec::new();
        let e = b.push(frames(1, &["ff"]).remove(0), &mut out).unwrap_err();
        assert!(matches!(e, Error::Record { .. }), "{e}");
    }
}
