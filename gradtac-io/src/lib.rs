//! # gradtac-io
//!
//! Sources and sinks for gradtac pipelines: sources yield `Result<TaxelFrame>` items as
//! iterators (offline) and, through [`blocking`], as tokio-fed streams; sinks write any
//! stage's output to Parquet through one Arrow schema per output type.
#![warn(missing_docs)]

mod error;

pub use error::{Error, Result};
