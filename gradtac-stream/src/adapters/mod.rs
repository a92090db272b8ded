//! Adapters that drive a [`Stage`](crate::Stage) from an iterator or a stream, one per file.

pub mod iter;
pub mod merge_iter;
pub mod merge_stream;
pub mod stream;
