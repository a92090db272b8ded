//! The error type of `gradtac-io`.

use std::path::PathBuf;

/// Errors of sources and sinks. Every variant about input names where: file and line (and
/// column) for text files, byte offset for binary files, CAN id and time for bus traffic.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An I/O error on a path.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A source or sink was configured with values it cannot work with.
    #[error("invalid configuration: {0}")]
    InvalidConfig(String),
    /// A malformed text input (CSV, candump): file, 1-based line and, where known, column.
    #[error("{path}:{line}{}: {}", column.as_ref().map(|c| format!(" column {:?}", excerpt(c, 80))).unwrap_or_default(), excerpt(reason, MAX_REASON_CHARS))]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// The column's name (CSV header) where the error is in one cell.
        column: Option<String>,
        /// What is wrong.
        reason: String,
    },
    /// Arrow or Parquet failed.
    #[error("{context}: {reason}")]
    Arrow {
        /// What was being done (a path, a schema).
        context: String,
        /// The library's message.
        reason: String,
    },
    /// A record that does not fit a sink's schema (a frame with another taxel count, …).
    #[error("{schema} record does not fit the sink: {reason}")]
    Record {
        /// The schema id (`frame/1`, …).
        schema: String,
        /// What does not fit, naming the record (sensor, frame index).
        reason: String,
    },
    /// A CAN interface could not be opened or read: names the interface, what was being done
    /// and the OS reason.
    #[error("CAN interface {interface:?}: {action}: {source}")]
    CanInterface {
        /// The interface (`can0`).
        interface: String,
        /// What failed (`cannot open`, `read failed`, …), with any diagnosis.
        action: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// Taxel values that cannot be encoded into CAN frames (not finite, outside the valid
    /// range of their field, a value count that is not the sensor's taxel count): names the
    /// sensor and, where one value is at fault, the taxel and the CAN id it would go to.
    #[error("CAN encoding of sensor {sensor:?}{}: {reason}", taxel.map(|t| format!(" taxel {t}")).unwrap_or_default())]
    CanEncode {
        /// The sensor's name (or `index N` for an index the codec does not have).
        sensor: String,
        /// The taxel whose value does not fit, if the fault is one value's.
        taxel: Option<u32>,
        /// What is wrong.
        reason: String,
    },
    /// A malformed binary file (NumPy `.npy`, Arrow IPC): the file and the byte offset.
    #[error("{path} at byte {offset}: {reason}")]
    Binary {
        /// The file.
        path: PathBuf,
        /// Byte offset in the file where the problem is.
        offset: u64,
        /// What is wrong.
        reason: String,
    },
    /// A malformed or unusable recorded-hand file (ROS bag, MCAP), or a topic whose messages
    /// do not fit: names the file, the byte offset and, where known, topic, type and message.
    #[error("{path}{site}: {reason}")]
    Bag {
        /// The file.
        path: PathBuf,
        /// Where in it (boxed: keeps the error small).
        site: Box<BagSite>,
        /// What is wrong.
        reason: String,
    },
    /// A stage's error in a pipeline fed by a gradtac-io source (`source.stage(Normalise…)`):
    /// the stage's own error, naming the stage, sensor and frame.
    #[error(transparent)]
    Stage(gradtac_stages::Error),
    /// A core-crate error in a pipeline fed by a gradtac-io source (a layout, a composed
    /// [`Chain`](gradtac_stream::Chain)'s error).
    #[error(transparent)]
    Stream(gradtac_stream::Error),
}

/// Where in a recorded-hand file (ROS bag, MCAP) a problem is: the byte offset of the record
/// and, once known, the topic, its message type and the message's 0-based index on the topic.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BagSite {
    /// Byte offset of the record (for messages inside a compressed chunk: of the chunk), when
    /// the reader knows it.
    pub offset: Option<u64>,
    /// The topic.
    pub topic: Option<String>,
    /// The message type (`sr_robot_msgs/BiotacAll`).
    pub msg_type: Option<String>,
    /// 0-based index of the message on its topic.
    pub index: Option<u64>,
}

impl std::fmt::Display for BagSite {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut sep = " ";
        if let Some(o) = self.offset {
            write!(f, " at byte {o}")?;
            sep = ", ";
        }
        if let Some(t) = &self.topic {
            write!(f, "{sep}topic {t}")?;
        }
        if let Some(t) = &self.msg_type {
            write!(f, " ({t})")?;
        }
        if let Some(i) = self.index {
            write!(f, ", message {i}")?;
        }
        Ok(())
    }
}

/// Into the common pipeline error. The [`Error::Stage`] and [`Error::Stream`] wrappers are
/// taken off (a stage error becomes `Other(stage error)`, a core error itself), so converting
/// back and forth never nests.
impl From<Error> for gradtac_stream::Error {
    fn from(e: Error) -> Self {
        match e {
            Error::Stream(e) => e,
            Error::Stage(e) => gradtac_stream::Error::other(e),
            e => gradtac_stream::Error::other(e),
        }
    }
}

/// A stage error where a source's items carry this crate's error: `?` and
/// [`IteratorStageExt::stage`](gradtac_stream::IteratorStageExt::stage) need no glue.
impl From<gradtac_stages::Error> for Error {
    fn from(e: gradtac_stages::Error) -> Self {
        Error::Stage(e)
    }
}

/// A core-crate error where a source's items carry this crate's error (a composed chain of
/// stages has the core error). An error that came from this crate or from a stage is unwrapped
/// to its own variant, never nested.
impl From<gradtac_stream::Error> for Error {
    fn from(e: gradtac_stream::Error) -> Self {
        if e.downcast_ref::<Error>().is_some() || e.downcast_ref::<gradtac_stages::Error>().is_some() {
            if let gradtac_stream::Error::Other(inner) = e {
                return match inner.downcast::<Error>() {
                    Ok(io) => *io,
                    Err(inner) => match inner.downcast::<gradtac_stages::Error>() {
                        Ok(stage) => Error::Stage(*stage),
                        Err(inner) => Error::Stream(gradtac_stream::Error::Other(inner)),
                    },
                };
            }
        }
        Error::Stream(e)
    }
}

/// Longest error reason printed whole (characters); longer ones are cut by [`excerpt`].
pub const MAX_REASON_CHARS: usize = 400;

/// `text` cut to at most `max` characters for an error message: a longer text keeps its first
/// `max` characters and ends with `… (N bytes)`, N being its full length. Anything an error
/// echoes from an input (a cell, a line, a header name) goes through here, so a 1 MB bad cell
/// gives a short error line.
pub fn excerpt(text: &str, max: usize) -> String {
    match text.char_indices().nth(max) {
        None => text.to_string(),
        Some((cut, _)) => format!("{}… ({} bytes)", &text[..cut], text.len()),
    }
}

/// `Result` with [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

#[cfg(test)]
mod tests {
    use super::*;

    /// io → stream → io and stage → io → stream → io give back the same error, not a nest.
    #[test]
    fn conversions_between_the_crates_errors_do_not_nest() {
        let io = Error::InvalidConfig("x".into());
        let back: Error = gradtac_stream::Error::from(io).into();
        assert!(matches!(back, Error::InvalidConfig(ref r) if r == "x"), "{back:?}");
        let stage = gradtac_stages::Error::InvalidConfig { stage: "savgol", reason: "even window".into() };
        let as_io: Error = stage.clone().into();
        let as_stream: gradtac_stream::Error = as_io.into();
        assert_eq!(as_stream.downcast_ref::<gradtac_stages::Error>(), Some(&stage));
        let again: Error = as_stream.into();
        assert!(matches!(again, Error::Stage(ref s) if *s == stage), "{again:?}");
        let core: Error = gradtac_stream::Error::UnknownLayout("nope".into()).into();
        assert!(matches!(core, Error::Stream(gradtac_stream::Error::UnknownLayout(_))), "{core:?}");
        assert_eq!(core.to_string(), gradtac_stream::Error::UnknownLayout("nope".into()).to_string());
    }

    #[test]
    fn a_megabyte_cell_gives_a_short_error_line() {
        assert_eq!(excerpt("short", 80), "short");
        let cell = "x".repeat(1 << 20);
        let cut = excerpt(&cell, 80);
        assert!(cut.ends_with("… (1048576 bytes)") && cut.len() < 120, "{cut}");
        assert_eq!(excerpt("ééé", 2), "éé… (6 bytes)");
        let e = Error::Parse { path: "a.csv".into(), line: 3, column: Some(cell.clone()), reason: cell };
        assert!(e.to_string().len() < 600, "{}", e.to_string().len());
    }
}
