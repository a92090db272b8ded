//! # gradtac
//!
//! Tactile-sensor streams to contact locations, forces and slip: the GradTac method as
//! typed stream operators. This package re-exports the member crates and adds scenes
//! (TOML descriptions of sensors, stage settings and outputs), the planner that builds only
//! what a scene's outputs need, and the `gradtac` command-line tool.
//!
//! - [`stream`] — core types ([`stream::TaxelFrame`], [`stream::Layout`]), the
//!   [`stream::Stage`] trait and its iterator / stream adapters, merging by time.
//! - [`stages`] — the signal-processing stages.
//! - [`io`] — sources (CSV, …) and sinks (Parquet).
//!
//! Stages compose only in the method's order; a wrong order is a type error:
//!
//! ```compile_fail
//! use gradtac::stream::{StageExt, TaxelFrame};
//! use gradtac::stages::normalise::{Normalise, NormaliseConfig};
//! // `map_stage` turns frames into a number; normalise wants frames back: does not compile.
//! let wrong = gradtac::stream::map_stage(|f: TaxelFrame| f.values[0])
//!     .then(Normalise::try_new(24, &NormaliseConfig::default()).unwrap());
//! ```
#![warn(missing_docs)]

pub use gradtac_io as io;
pub use gradtac_stages as stages;
pub use gradtac_stream as stream;

pub mod calibrate;
pub mod chain;
pub mod demo;
mod error;
pub mod guard;
pub mod plan;
pub mod plot;
mod recorded;
pub mod run;
pub mod scene;
pub mod sinks;

pub use error::Error;
pub use plan::{Plan, Tap};
pub use scene::Scene;
