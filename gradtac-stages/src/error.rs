//! The error type of `gradtac-stages`.

/// Errors of the signal-processing stages: invalid configuration (at construction) and bad
/// input (naming the sensor, frame index and taxel).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A stage was configured with values it cannot work with; raised by its constructor.
    #[error("{stage}: invalid configuration: {reason}")]
    InvalidConfig {
        /// The stage (`"normalise"`, `"savgol"`, …).
        stage: &'static str,
        /// What is wrong and, where it helps, what would work.
        reason: String,
    },
    /// A frame whose taxel count differs from the stage's.
    #[error("{stage}: sensor {sensor} frame {seq}: expected {expected} taxels, got {got}")]
    TaxelCount {
        /// The stage.
        stage: &'static str,
        /// The sensor.
        sensor: String,
        /// The frame's index in its source.
        seq: u64,
        /// What the stage was built for.
        expected: usize,
        /// What arrived.
        got: usize,
    },
    /// A value the stage's policy refuses (NaN, ±inf, ≤ 0 before a log, …).
    #[error("{stage}: sensor {sensor} frame {seq} taxel {taxel}: {reason} (value {value})")]
    BadValue {
        /// The stage.
        stage: &'static str,
        /// The sensor.
        sensor: String,
        /// The frame's index in its source.
        seq: u64,
        /// The taxel's index (0-based).
        taxel: usize,
        /// The offending value.
        value: f64,
        /// Why it is refused.
        reason: &'static str,
    },
    /// An input item the stage refuses as a whole (time going backwards, events out of order,
    /// a batch of another sensor).
    #[error("{stage}: sensor {sensor} frame {seq}: {reason}")]
    BadInput {
        /// The stage.
        stage: &'static str,
        /// The sensor.
        sensor: String,
        /// The frame's index in its source.
        seq: u64,
        /// What is wrong.
        reason: String,
    },
}

impl From<Error> for gradtac_stream::Error {
    fn from(e: Error) -> Self {
        gradtac_stream::Error::other(e)
    }
}

/// `Result` with [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The finiteness check of stages that refuse NaN / ±inf input: the first non-finite value
/// of `frame` is an [`Error::BadValue`] naming the stage, sensor, frame and taxel.
pub(crate) fn check_finite(stage: &'static str, frame: &gradtac_stream::TaxelFrame) -> Result<()> {
    match frame.values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(taxel) => Err(Error::BadValue {
            stage,
            sensor: frame.sensor.to_string(),
            seq: frame.seq,
            taxel,
            value: frame.values[taxel],
            reason: "not a finite number",
        }),
    }
}

/// The input check every stage makes: `got` taxels where the stage was built for `expected`
/// is an [`Error::TaxelCount`] naming the stage, sensor and frame.
pub(crate) fn check_taxel_count(
    stage: &'static str,
    sensor: &dyn std::fmt::Display,
    seq: u64,
    expected: usize,
    got: usize,
) -> Result<()> {
    if got == expected {
        Ok(())
    } else {
        Err(Error::TaxelCount { stage, sensor: sensor.to_string(), seq, expected, got })
    }
}
