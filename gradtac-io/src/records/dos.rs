//! [`DosDecision`] as Arrow: schema `dos/3`, one row per slip-direction decision of the
//! one-fingertip classifier ([`gradtac_stages::dos`]: one per span of `decision_frames`
//! frames, or one per recording).
//!
//! | column | Arrow type | meaning |
//! |---|---|---|
//! | `sensor` | `Utf8`, not null | the sensor's name |
//! | `start` | time ([`TimeBase`]), not null | time of the span's first frame |
//! | `end` | time ([`TimeBase`]), not null | time of its last frame (the decision's time) |
//! | `seq` | `UInt64`, not null | index of the last frame |
//! | `frames` | `UInt64`, not null | frames in the span ([`DosDecision::frames`], = [`FeatureVector::frames`]) |
//! | `events` | `UInt64`, not null | events in the span ([`FeatureVector::events`]) |
//! | `class` | `Utf8`, not null | the decided class: `n`, `e`, `s`, `w`, `cw`, `aw`, `t` ([`DosClass::as_str`]) |
//! | `distances` | `FixedSizeList<Float64 not null>[k]`, not null | `D_c` per model class ([`Decision::distances`]), in the order of the shape's classes |
//! | `posterior` | `FixedSizeList<Float64 not null>[k]`, not null | `softmax(−D_c/2)` per model class ([`Decision::posterior`]), same order |
//! | `rate`, `positive_fraction` | `Float64`, not null | features (dimensionless) |
//! | `positive_x`, `positive_y`, `negative_x`, `negative_y`, `activity_x`, `activity_y`, `track_dx`, `track_dy` | `Float64`, not null | features (mm); `gradtac.unit = mm` |
//! | `rotation` | `Float64`, not null | feature (rad); `gradtac.unit = rad` |
//! | `drift_level`, `drift_spread` | `Float64`, not null | features (dimensionless: `ln(1 + …)`) |
//! | `drift_x`, `drift_y`, `drift_signed_y` | `Float64`, not null | features (mm); `gradtac.unit = mm` |
//! | `drift_anisotropy`, `drift_cross` | `Float64`, not null | features (mm²); `gradtac.unit = mm2` |
//!
//! `dos/3` differs from `dos/1` only by the seven `drift_*` columns (added with the drift
//! features of [`gradtac_stages::drift`]). The eighteen feature columns are [`FeatureVector::all`] in [`Feature::ALL`] order, named by
//! [`Feature::name`] (the names of model files), whichever features the model uses.
//!
//! The shape ([`DosShape`]) is the model's classes, in decision order; it is stored in the
//! schema metadata under `gradtac.dos.classes` as a JSON array of class names, so element `i`
//! of `distances` and `posterior` belongs to class `classes[i]`. A decision with another
//! number of distances or posteriors, a class not among the shape's, or features of another
//! frame count than `frames` is rejected with [`Error::Record`].
//! Floats are stored bit-exactly, so a file reads back into the same decisions.
//!
//! ```
//! use gradtac_io::records::{to_batch, DosShape};
//! use gradtac_stages::dos::{Decision, DosClass, DosDecision, FeatureVector};
//! use gradtac_stream::{SensorId, Timestamp};
//!
//! let shape = DosShape::new(vec![DosClass::N, DosClass::T]).unwrap();
//! let d = DosDecision {
//!     sensor: SensorId::new("ff"),
//!     start: Timestamp(0),
//!     end: Timestamp(2_790_000_000),
//!     seq: 279,
//!     frames: 280,
//!     decision: Decision { class: DosClass::T, distances: vec![9.0, 1.0], posterior: vec![0.018, 0.982] },
//!     features: FeatureVector { all: [0.5; 18], frames: 280, events: 12 },
//! };
//! let batch = to_batch(&shape, &[d]).unwrap();
//! assert_eq!(batch.schema().metadata()["gradtac.dos.classes"], r#"["n","t"]"#);
//! ```

use super::columns::{
    append_present, f64_list, item_field, record_error, schema_with_id, time_field, unit_field, TimeBuilder,
};
use super::{arrow_error, ArrowRecord, RecordBuilder, TimeBase};
use crate::{Error, Result};
use arrow_array::builder::{ArrayBuilder, FixedSizeListBuilder, Float64Builder, StringBuilder, UInt64Builder};
use arrow_array::{ArrayRef, RecordBatch};
use arrow_schema::{DataType, Field, SchemaRef};
use gradtac_stages::dos::{Decision, DosClass, DosDecision, DosModel, Feature, FeatureVector};
use std::sync::Arc;

/// Schema-metadata key of the classes of a `dos/3` file (JSON array of class names).
pub const DOS_CLASSES_KEY: &str = "gradtac.dos.classes";

/// The classes of the model whose decisions one sink writes, in the model's decision order
/// (the order of [`Decision::distances`] and [`Decision::posterior`]).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct DosShape {
    classes: Arc<[DosClass]>,
}

impl DosShape {
    /// A shape from the classes in decision order (at least one; none twice).
    pub fn new(classes: Vec<DosClass>) -> Result<Self> {
        if classes.is_empty() {
            return Err(Error::InvalidConfig("a dos shape needs at least one class".into()));
        }
        for (i, c) in classes.iter().enumerate() {
            if classes[..i].contains(c) {
                return Err(Error::InvalidConfig(format!("dos class {c} appears twice")));
            }
        }
        Ok(DosShape { classes: classes.into() })
    }

    /// The classes of `model` (e.g. `classifier.model()`), in its order.
    pub fn from_model(model: &DosModel) -> Result<Self> {
        Self::new(model.classes.clone())
    }

    /// The classes, in decision order.
    pub fn classes(&self) -> &[DosClass] {
        &self.classes
    }

    /// Number of classes (`k`, the length of `distances` and `posterior`).
    pub fn len(&self) -> usize {
        self.classes.len()
    }

    /// Always false: a shape has at least one class.
    pub fn is_empty(&self) -> bool {
        self.classes.is_empty()
    }

    /// The value of [`DOS_CLASSES_KEY`]: the class names as a JSON array.
    pub fn classes_json(&self) -> String {
        serde_json::to_string(&self.classes.iter().map(|c| c.as_str()).collect::<Vec<_>>())
            .expect("a list of strings serialises")
    }
}

/// The unit of a feature column (`None`: dimensionless).
fn feature_unit(f: Feature) -> Option<&'static str> {
    match f {
        Feature::Rate | Feature::PositiveFraction | Feature::DriftLevel | Feature::DriftSpread => None,
        Feature::Rotation => Some("rad"),
        Feature::DriftAnisotropy | Feature::DriftCross => Some("mm2"),
        _ => Some("mm"),
    }
}

impl ArrowRecord for DosDecision {
    type Shape = DosShape;
    type Builder = DosBuilder;
    const SCHEMA_ID: &'static str = "dos/3";

    fn schema(shape: &DosShape, time: TimeBase) -> SchemaRef {
        let mut fields = vec![
            Field::new("sensor", DataType::Utf8, false),
            time_field("start", time),
            time_field("end", time),
            Field::new("seq", DataType::UInt64, false),
            Field::new("frames", DataType::UInt64, false),
            Field::new("events", DataType::UInt64, false),
            Field::new("class", DataType::Utf8, false),
            Field::new("distances", f64_list(shape.len()), false),
            Field::new("posterior", f64_list(shape.len()), false),
        ];
        fields.extend(Feature::ALL.iter().map(|&f| match feature_unit(f) {
            Some(u) => unit_field(f.name(), DataType::Float64, true, u),
            None => Field::new(f.name(), DataType::Float64, true),
        }));
        schema_with_id(fields, Self::SCHEMA_ID, time, vec![(DOS_CLASSES_KEY.to_string(), shape.classes_json())])
    }

    fn builder(shape: &DosShape, time: TimeBase, capacity: usize) -> DosBuilder {
        let k = shape.len();
        // A shape holds at most the 7 distinct classes, so `k` fits an i32 list size.
        let list = || {
            FixedSizeListBuilder::with_capacity(Float64Builder::with_capacity(capacity * k), k as i32, capacity)
                .with_field(item_field())
        };
        DosBuilder {
            schema: Self::schema(shape, time),
            shape: shape.clone(),
            sensor: StringBuilder::with_capacity(capacity, capacity * 4),
            start: TimeBuilder::with_capacity(time, capacity),
            end: TimeBuilder::with_capacity(time, capacity),
            seq: UInt64Builder::with_capacity(capacity),
            frames: UInt64Builder::with_capacity(capacity),
            events: UInt64Builder::with_capacity(capacity),
            class: StringBuilder::with_capacity(capacity, capacity * 2),
            distances: list(),
            posterior: list(),
            features: (0..Feature::ALL.len()).map(|_| Float64Builder::with_capacity(capacity)).collect(),
        }
    }
}

/// Builds `dos/3` batches (see the [module documentation](self)).
pub struct DosBuilder {
    schema: SchemaRef,
    shape: DosShape,
    sensor: StringBuilder,
    start: TimeBuilder,
    end: TimeBuilder,
    seq: UInt64Builder,
    frames: UInt64Builder,
    events: UInt64Builder,
    class: StringBuilder,
    distances: FixedSizeListBuilder<Float64Builder>,
    posterior: FixedSizeListBuilder<Float64Builder>,
    /// One builder per feature, [`Feature::ALL`] order.
    features: Vec<Float64Builder>,
}

impl std::fmt::Debug for DosBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DosBuilder").field("classes", &self.shape.classes()).field("pending", &self.len()).finish()
    }
}

impl DosBuilder {
    fn check(&self, d: &DosDecision) -> Result<()> {
        let k = self.shape.len();
        let bad = |reason: String| {
            Err(record_error(DosDecision::SCHEMA_ID, format!("sensor {} frame {}: {reason}", d.sensor, d.seq)))
        };
        let Decision { class, distances, posterior } = &d.decision;
        if distances.len() != k {
            return bad(format!(
                "{} distances; this sink was built for {k} classes {}",
                distances.len(),
                self.shape.classes_json()
            ));
        }
        if posterior.len() != k {
            return bad(format!(
                "{} posteriors; this sink was built for {k} classes {}",
                posterior.len(),
                self.shape.classes_json()
            ));
        }
        if !self.shape.classes().contains(class) {
            return bad(format!("class {class} is not among this sink's classes {}", self.shape.classes_json()));
        }
        let FeatureVector { frames, .. } = d.features;
        if frames != d.frames {
            return bad(format!("the decision covers {} frames but its features {frames}", d.frames));
        }
        Ok(())
    }
}

impl RecordBuilder<DosDecision> for DosBuilder {
    fn schema(&self) -> SchemaRef {
        self.schema.clone()
    }

    fn append(&mut self, d: &DosDecision) -> Result<()> {
        self.check(d)?;
        self.sensor.append_value(d.sensor.as_str());
        self.start.append(d.start);
        self.end.append(d.end);
        self.seq.append_value(d.seq);
        self.frames.append_value(d.frames);
        self.events.append_value(d.features.events);
        self.class.append_value(d.decision.class.as_str());
        self.distances.values().append_slice(&d.decision.distances);
        self.distances.append(true);
        self.posterior.values().append_slice(&d.decision.posterior);
        self.posterior.append(true);
        for (b, &v) in self.features.iter_mut().zip(&d.features.all) {
            append_present(b, v);
        }
        Ok(())
    }

    fn len(&self) -> usize {
        self.seq.len()
    }

    fn finish(&mut self) -> Result<RecordBatch> {
        let mut columns: Vec<ArrayRef> = vec![
            Arc::new(self.sensor.finish()),
            self.start.finish(),
            self.end.finish(),
            Arc::new(self.seq.finish()),
            Arc::new(self.frames.finish()),
            Arc::new(self.events.finish()),
            Arc::new(self.class.finish()),
            Arc::new(self.distances.finish()),
            Arc::new(self.posterior.finish()),
        ];
        columns.extend(self.features.iter_mut().map(|b| Arc::new(b.finish()) as ArrayRef));
        RecordBatch::try_new(self.schema.clone(), columns).map_err(|e| arrow_error(DosDecision::SCHEMA_ID, e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gradtac_stream::{SensorId, Timestamp};

    fn decision(class: DosClass, k: usize, frames: u64) -> DosDecision {
        DosDecision {
            sensor: SensorId::new("ff"),
            start: Timestamp(0),
            end: Timestamp(10),
            seq: 7,
            frames,
            decision: Decision { class, distances: vec![1.0; k], posterior: vec![0.5; k] },
            features: FeatureVector { all: [0.0; 18], frames: 8, events: 3 },
        }
    }

    #[test]
    fn shapes_need_distinct_classes() {
        assert!(DosShape::new(vec![]).is_err());
        let e = DosShape::new(vec![DosClass::N, DosClass::T, DosClass::N]).unwrap_err().to_string();
        assert!(e.contains("class n appears twice"), "{e}");
        assert_eq!(DosShape::new(DosClass::ALL.to_vec()).unwrap().classes_json(), r#"["n","e","s","w","cw","aw","t"]"#);
    }

    #[test]
    fn bad_decisions_are_rejected_and_leave_the_builder_intact() {
        let shape = DosShape::new(vec![DosClass::N, DosClass::S, DosClass::T]).unwrap();
        let mut b = DosDecision::builder(&shape, crate::records::TimeBase::Relative, 2);
        b.append(&decision(DosClass::S, 3, 8)).unwrap();
        let e = b.append(&decision(DosClass::S, 2, 8)).unwrap_err().to_string();
        assert!(e.contains("dos/3") && e.contains("frame 7") && e.contains("2 distances"), "{e}");
        let mut d = decision(DosClass::S, 3, 8);
        d.decision.posterior.push(0.0);
        let e = b.append(&d).unwrap_err().to_string();
        assert!(e.contains("4 posteriors"), "{e}");
        let e = b.append(&decision(DosClass::Cw, 3, 8)).unwrap_err().to_string();
        assert!(e.contains("class cw is not among"), "{e}");
        let e = b.append(&decision(DosClass::T, 3, 9)).unwrap_err().to_string();
        assert!(e.contains("9 frames but its features 8"), "{e}");
        assert_eq!(b.len(), 1);
        b.append(&decision(DosClass::T, 3, 8)).unwrap();
        let batch = b.finish().unwrap();
        assert_eq!(batch.num_rows(), 2);
        assert_eq!(batch.num_columns(), 9 + 18);
        assert!(b.is_empty());
    }
}
