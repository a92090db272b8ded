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
//! - [`io`] — sources (CSV, NumPy, Arrow IPC, CAN, ROS bags) and sinks (Parquet).
//! - [`scene`], [`plan`], [`run`] — scenes, the planner and the runner behind `gradtac run`.
//!
//! ## Embedding: sources and stages compose with `?`
//!
//! A source is an [`Iterator`] (offline) or a [`futures::Stream`](https://docs.rs/futures/0.3/futures/stream/trait.Stream.html) (live) of
//! `Result<TaxelFrame, E>` items; [`stream::IteratorStageExt::stage`] and
//! [`stream::StreamStageExt::stage`] put a stage behind it, the way `TryStreamExt` adapters
//! do. The output keeps the source's error type and every stage's error converts into it
//! (the three crates' errors convert into each other without nesting), so stages chain with
//! no glue, and `?` lifts any of them into [`Error`] (or `Box<dyn Error>`). Plain values (a
//! `Vec` of frames) use [`stage_plain`](stream::IteratorStageExt::stage_plain) instead of
//! `.map(Ok)`. Every stage is built the same way,
//! [`FromConfig::from_config`](stages::FromConfig::from_config)`(&config, &context)`, from its
//! scene table's config and a [`StageContext`](stages::StageContext) (layout, taxel count,
//! rate); the constructor validates, so a bad setting fails before any data moves.
//!
//! ```
//! use gradtac::io::{CsvFrames, CsvSourceConfig};
//! use gradtac::stages::centroid::Centroid;
//! use gradtac::stages::locate::LocateConfig;
//! use gradtac::stages::savgol::{SavGol, SavGolConfig};
//! use gradtac::stages::track::{Track, TrackConfig, TrackPoint};
//! use gradtac::stages::{FromConfig, StageContext};
//! use gradtac::stream::{IteratorStageExt, Layout, SensorId};
//!
//! fn tracks(csv: &std::path::Path) -> Result<Vec<TrackPoint>, gradtac::Error> {
//!     let source = CsvSourceConfig::new(csv, "ff_e{1..24}".parse()?).with_rate_hz(100.0);
//!     let ctx = StageContext::new(Layout::biotac_sp()).with_rate_hz(100.0);
//!     let points = CsvFrames::open(&source, SensorId::new("ff"))?
//!         .stage(SavGol::from_config(&SavGolConfig::default(), &ctx)?)
//!         .stage(Centroid::from_config(&LocateConfig::default(), &ctx)?)
//!         .stage(Track::from_config(&TrackConfig::default(), &ctx)?)
//!         .collect::<Result<Vec<_>, _>>()?;
//!     Ok(points)
//! }
//! # // a recording to read: a simulated fingertip pressed and moved upwards
//! # use gradtac::stages::sim::{Scene, SensorModel, Simulator, Trajectory};
//! # let dir = std::env::temp_dir().join(format!("gradtac-doc-{}", std::process::id()));
//! # std::fs::create_dir_all(&dir).unwrap();
//! # let (csv, truth) = (dir.join("ff.csv"), dir.join("truth.csv"));
//! # let layout = Layout::biotac_sp();
//! # let sim = Simulator::try_new(layout.clone(), SensorModel::default(), 3).unwrap();
//! # sim.run(&Scene::trajectory(Trajectory::Up, 8.0, 2.0, &layout)).unwrap().write_csv(&csv, &truth).unwrap();
//! let points = tracks(&csv)?;
//! assert!(points.iter().any(|p| p.x_mm.is_finite()), "some frames see a contact");
//! # std::fs::remove_dir_all(&dir).unwrap();
//! # Ok::<(), gradtac::Error>(())
//! ```
//!
//! The same stages run live on tokio: [`io::blocking_stream`] moves the reader onto the
//! blocking pool and [`stream::StreamStageExt::stage`] chains them on the stream (see
//! `examples/embed_csv.rs`, which reads a CSV both ways and checks they agree).
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
//!
//! ## Features
//!
//! | feature | default | what it adds |
//! |---|---|---|
//! | `cli` | on | the `gradtac` binary (clap, tracing-subscriber) and the runner's progress bars (indicatif) |
//! | `plot` | on | the `plot` module and `gradtac plot` / `gradtac demo`'s figures (plotters) |
//! | `view` | off | the [rerun](https://rerun.io) view: the `view` module, `gradtac run --view` / `--view-save`, `gradtac view`, `demo --view` (rerun `=0.36`, SDK only; needs Rust 1.95) |
//!
//! A library user who needs neither depends on `gradtac = { version = "…", default-features = false }`:
//! the pipeline, the sources and sinks, scenes, plans and runs stay.
#![warn(missing_docs)]

pub use gradtac_io as io;
pub use gradtac_stages as stages;
pub use gradtac_stream as stream;

pub mod batch;
pub mod calibrate;
pub mod chain;
#[cfg(feature = "plot")]
pub mod demo;
mod error;
mod explain;
pub mod guard;
pub mod memory;
mod parallel;
pub mod plan;
#[cfg(feature = "plot")]
pub mod plot;
mod recorded;
pub mod run;
pub mod scene;
pub mod sinks;
pub mod unused;
#[cfg(feature = "view")]
pub mod view;

pub use error::Error;
pub use plan::{Plan, Tap};
pub use scene::Scene;
