//! # gradtac-io
//!
//! Sources and sinks for gradtac pipelines: sources yield `Result<TaxelFrame>` items as
//! iterators (offline) and, through [`blocking`], as tokio-fed streams; sinks write any
//! stage's output to Parquet through one Arrow schema per output type.
#![warn(missing_docs)]

pub mod blocking;
pub mod csv_source;
mod error;
pub mod parquet_sink;
pub mod records;

pub use blocking::{blocking_stream, BlockingStream};
pub use csv_source::{ColumnSelector, CsvFrames, CsvProgress, CsvSourceConfig, TimeUnit};
pub use error::{Error, Result};
pub use parquet_sink::ParquetSink;
pub use records::{ArrowRecord, FrameShape, RecordBuilder};
