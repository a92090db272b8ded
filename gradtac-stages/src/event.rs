//! Tactile events: the output type of the [`events`](crate::events) stage.

use gradtac_stream::{HasSensor, SensorId, Timed, Timestamp};
use serde::{Deserialize, Serialize};

/// One log-change event of one taxel: `ln x` crossed the taxel's reference level by one
/// threshold `τ` in the direction of `polarity`.
#[derive(Copy, Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TactileEvent {
    /// When the crossing happened, interpolated inside the sample interval (see method.md, stage 3).
    pub time: Timestamp,
    /// The taxel's index in the sensor's layout (0-based).
    pub taxel: u16,
    /// +1 for a rise of `ln x`, −1 for a fall.
    pub polarity: i8,
}

/// The events one input frame produced (possibly none), with that frame's identity.
///
/// The events stage emits exactly one batch per input frame, so downstream windows can count
/// frames and advance on time even when nothing happens. Events inside a batch are in
/// non-decreasing `time`; ties are ordered by taxel index, then by crossing order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EventBatch {
    /// The sensor.
    pub sensor: SensorId,
    /// The time of the frame that closed the interval the events fell in.
    pub time: Timestamp,
    /// That frame's index in its source.
    pub seq: u64,
    /// Number of taxels of the sensor (so an aggregate knows its size without a layout).
    pub taxels: u16,
    /// The events, in time order.
    pub events: Vec<TactileEvent>,
}

impl Timed for EventBatch {
    fn time(&self) -> Timestamp {
        self.time
    }
}

impl HasSensor for EventBatch {
    fn sensor(&self) -> &SensorId {
        &self.sensor
    }
}
