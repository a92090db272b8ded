//! # gradtac-stream
//!
//! The core of [gradtac](https://docs.rs/gradtac): the data types every stage shares
//! ([`TaxelFrame`], [`Layout`], [`SensorId`], [`Timestamp`]), the synchronous [`Stage`]
//! abstraction, and the adapters that run any stage over an [`Iterator`]
//! ([`IteratorStageExt`]) or a [`futures::Stream`](https://docs.rs/futures/0.3/futures/stream/trait.Stream.html) ([`StreamStageExt`]), per sensor
//! ([`Keyed`]), and that merge several sources by time ([`merge_iter`], [`merge_streams`]).
//!
//! A stage is a plain state machine: push one input, get zero or more outputs; `finish`
//! flushes; `reset` forgets history. It is tested without an executor and runs unchanged
//! offline (iterators) and live (tokio streams):
//!
//! ```
//! use gradtac_stream::{map_stage, IteratorStageExt, StageExt, StreamStageExt};
//! use futures::StreamExt;
//!
//! let double = || map_stage(|x: f64| 2.0 * x);
//! type E = gradtac_stream::Error;
//! let offline: Result<Vec<f64>, E> = [1.0, 2.0].into_iter().map(Ok).stage(double()).collect();
//! let live: Vec<Result<f64, E>> = futures::executor::block_on(
//!     futures::stream::iter([Ok(1.0), Ok(2.0)]).stage(double()).collect(),
//! );
//! assert_eq!(offline.unwrap(), live.into_iter().collect::<Result<Vec<_>, _>>().unwrap());
//! ```
#![warn(missing_docs)]
// Where the crates that link here find these docs when rustdoc has not written them yet
// (`cargo doc --no-deps --workspace` documents the members in parallel): beside their own,
// relative to the doc root. Without it such links render as literal `[text]`.
#![doc(html_root_url = "../")]

pub mod adapters;
mod error;
mod frame;
mod keyed;
pub mod layout;
pub mod merge;
pub mod num;
mod sensor;
mod stage;
mod time;

pub use adapters::iter::{IteratorStageExt, PlainItems, StageIter};
pub use adapters::merge_iter::{merge_iter, MergeIter};
pub use adapters::merge_stream::{merge_streams, MergeStreams};
pub use adapters::stream::{PlainStream, StageStream, StreamStageExt};
pub use error::{Error, Result};
pub use frame::TaxelFrame;
pub use keyed::Keyed;
pub use layout::{Extent, Layout};
pub use merge::MergeCore;
pub use sensor::{HasSensor, SensorId};
pub use stage::{map_stage, Chain, Delay, MapStage, Stage, StageExt};
pub use time::{Timed, Timestamp};
