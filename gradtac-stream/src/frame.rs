//! Taxel frames: one reading of every taxel of one sensor.

use crate::{HasSensor, SensorId, Timed, Timestamp};
use serde::{Deserialize, Serialize};

/// One sample of a sensor: a value per taxel, at one time.
///
/// `values[i]` belongs to taxel `i` of the sensor's [`Layout`](crate::Layout). Units depend on
/// where the frame is in a pipeline: raw counts from a source, dimensionless after
/// normalisation, counts/s after a Savitzky–Golay derivative.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TaxelFrame {
    /// The sensor the frame comes from.
    pub sensor: SensorId,
    /// When it was sampled (see [`Timestamp`] for the epoch rule). Stages that delay
    /// (centred Savitzky–Golay) stamp their output with the time of the sample it describes.
    pub time: Timestamp,
    /// Index of the source frame this frame describes, counted from 0 per sensor: errors and
    /// outputs name frames by it.
    pub seq: u64,
    /// One value per taxel.
    pub values: Vec<f64>,
}

impl TaxelFrame {
    /// A frame from its parts.
    pub fn new(sensor: SensorId, time: Timestamp, seq: u64, values: Vec<f64>) -> Self {
        TaxelFrame { sensor, time, seq, values }
    }

    /// Number of taxels.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// True for a frame with no taxels.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }
}

impl Timed for TaxelFrame {
    fn time(&self) -> Timestamp {
        self.time
    }
}

impl HasSensor for TaxelFrame {
    fn sensor(&self) -> &SensorId {
        &self.sensor
    }
}
