//! The error type of the `gradtac` package (scenes, planning, running).

use std::path::PathBuf;

/// Errors of scenes, plans and runs; the errors of the member crates pass through.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A scene file is malformed or inconsistent.
    #[error("{path}: {reason}")]
    Scene {
        /// The scene file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A scene setting that is refused, at the line of its key (`scene.toml:12: …`).
    #[error("{path}:{line}: {reason}")]
    SceneAt {
        /// The scene file.
        path: PathBuf,
        /// 1-based line of the key (or of its table).
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// An I/O error with its path.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// From the core crate (layouts, pipeline errors).
    #[error(transparent)]
    Stream(gradtac_stream::Error),
    /// From a stage (configuration, bad input).
    #[error(transparent)]
    Stage(#[from] gradtac_stages::Error),
    /// From a source or sink.
    #[error(transparent)]
    Io2(gradtac_io::Error),
    /// The run was interrupted (Ctrl-C); finished outputs were kept.
    #[error("interrupted")]
    Interrupted,
    /// A plot could not be made: an unreadable or unknown input file, or a drawing failure.
    #[error("plot {path}: {reason}")]
    Plot {
        /// The input (or output) file.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// The rerun view (feature `view`) could not be opened or written.
    #[error("view: {0}")]
    View(String),
}

impl Error {
    /// Unwrap a pipeline error into the most specific variant (stage or io error inside).
    /// The same as `Error::from(e)`, which `?` uses.
    pub fn from_pipeline(e: gradtac_stream::Error) -> Self {
        match e {
            gradtac_stream::Error::Other(inner) => match inner.downcast::<gradtac_stages::Error>() {
                Ok(s) => Error::Stage(*s),
                Err(inner) => match inner.downcast::<gradtac_io::Error>() {
                    Ok(s) => Error::from(*s),
                    Err(inner) => Error::Stream(gradtac_stream::Error::Other(inner)),
                },
            },
            other => Error::Stream(other),
        }
    }
}

/// `?` on a pipeline's items: the most specific variant (see [`Error::from_pipeline`]).
impl From<gradtac_stream::Error> for Error {
    fn from(e: gradtac_stream::Error) -> Self {
        Error::from_pipeline(e)
    }
}

/// `?` on a source's items: a stage or core error that travelled in a source's error type
/// comes out as [`Error::Stage`] / [`Error::Stream`], the rest as [`Error::Io2`].
impl From<gradtac_io::Error> for Error {
    fn from(e: gradtac_io::Error) -> Self {
        match e {
            gradtac_io::Error::Stage(s) => Error::Stage(s),
            gradtac_io::Error::Stream(s) => Error::from_pipeline(s),
            e => Error::Io2(e),
        }
    }
}
