//! The error type of `gradtac-stream`, and the common error of a pipeline.

use std::path::PathBuf;

/// Errors of the core crate, and the error every pipeline carries in its `Result` items.
///
/// Other gradtac crates convert their own errors into it (`From`), so a pipeline built from
/// stages of several crates has one error type; the original error stays reachable through
/// [`std::error::Error::source`] / downcasting.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A layout is unusable (too few taxels, duplicates, non-finite positions, …).
    #[error("invalid layout {name:?}: {reason}")]
    InvalidLayout {
        /// The layout's name.
        name: String,
        /// What is wrong.
        reason: String,
    },
    /// A layout CSV could not be read.
    #[error("{path}:{line}: {reason}")]
    LayoutFile {
        /// The file.
        path: PathBuf,
        /// 1-based line number (0 when the error is not tied to one line).
        line: u64,
        /// What is wrong.
        reason: String,
    },
    /// A layout name that is not built in.
    #[error("unknown built-in layout {0:?} (built in: {list})", list = crate::layout::BUILTIN_LAYOUTS.join(", "))]
    UnknownLayout(String),
    /// An I/O error with the path it concerns.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A frame with the wrong number of taxels for its stage.
    #[error("sensor {sensor} frame {seq}: expected {expected} taxels, got {got}")]
    TaxelCount {
        /// The sensor.
        sensor: String,
        /// The frame's index.
        seq: u64,
        /// What the stage was built for.
        expected: usize,
        /// What arrived.
        got: usize,
    },
    /// An error from another gradtac crate (stages, io), kept as its source.
    #[error(transparent)]
    Other(Box<dyn std::error::Error + Send + Sync + 'static>),
}

impl Error {
    /// Wrap any error as [`Error::Other`].
    pub fn other(e: impl std::error::Error + Send + Sync + 'static) -> Self {
        Error::Other(Box::new(e))
    }

    /// The wrapped error of [`Error::Other`] if it is an `E`.
    pub fn downcast_ref<E: std::error::Error + 'static>(&self) -> Option<&E> {
        match self {
            Error::Other(e) => e.downcast_ref::<E>(),
            _ => None,
        }
    }
}

/// `Result` with [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl From<std::convert::Infallible> for Error {
    fn from(e: std::convert::Infallible) -> Self {
        match e {}
    }
}
