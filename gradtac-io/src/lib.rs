//! # gradtac-io
//!
//! Sources and sinks for gradtac pipelines: sources yield `Result<TaxelFrame>` items as
//! iterators (offline) and, through [`blocking`], as tokio-fed streams; sinks write any
//! stage's output to Parquet through one Arrow schema per output type.
#![warn(missing_docs)]
// Where the crates that link here find these docs when rustdoc has not written them yet
// (`cargo doc --no-deps --workspace` documents the members in parallel): beside their own,
// relative to the doc root. Without it such links render as literal `[text]`.
#![doc(html_root_url = "../")]

pub mod archive;
pub mod arrow_ipc;
pub mod batches;
pub mod blocking;
pub mod can;
pub mod contain;
pub mod csv_source;
mod error;
mod ipc_check;
pub mod npy;
pub mod parquet_check;
pub mod parquet_sink;
pub mod records;
pub mod rosbag;

pub use archive::{ArchiveConfig, ParquetArchive, Partitioning, RecordSink};
pub use blocking::{
    blocking_archive, blocking_sink, blocking_stream, blocking_stream_chunked, BlockingArchive, BlockingSink,
    BlockingStream, ChunkedBlockingStream,
};
pub use csv_source::{ColumnSelector, CsvFrames, CsvProgress, CsvSourceConfig, TimeUnit};
pub use error::{excerpt, BagSite, Error, Result};
pub use parquet_sink::ParquetSink;
pub use records::{ArrowRecord, FrameShape, RecordBuilder, TimeBase};
