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
