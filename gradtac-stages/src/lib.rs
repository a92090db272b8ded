//! # gradtac-stages
//!
//! The signal-processing stages of GradTac, each a synchronous [`Stage`](gradtac_stream::Stage)
//! in its own module: [`normalise`] → [`savgol`] → [`events`] → [`window`] →
//! [`interpolate`] → [`contour`] → [`track`], and the tasks built on them ([`slip`], [`force`],
//! [`servo`], [`dos`] with its [`drift`] map). No async runtime and no Arrow here: stages are
//! plain state machines, driven by the adapters of `gradtac-stream`.
//!
//! The method each stage implements is specified in the repository's `docs/method.md`
//! (a restatement of the GradTac paper); every stage's docs state its delay, units and
//! trade-offs.
#![warn(missing_docs)]
// Where the crates that link here find these docs when rustdoc has not written them yet
// (`cargo doc --no-deps --workspace` documents the members in parallel): beside their own,
// relative to the doc root. Without it such links render as literal `[text]`.
#![doc(html_root_url = "../")]

mod error;
pub mod event;

pub mod centroid;
pub mod context;
pub mod contour;
pub mod dos;
pub mod dos_select;
pub mod drift;
pub mod events;
pub mod fit;
pub mod fit_learned;
pub mod force;
pub mod force_ident;
pub mod force_model;
pub mod interpolate;
pub mod lag;
pub mod limits;
pub mod locate;
pub mod normalise;
pub mod peak;
pub mod raw_contour;
pub mod savgol;
pub mod servo;
pub mod sim;
pub mod sim_family;
pub mod sim_force;
pub mod sim_grasp;
pub mod slip;
pub mod slip_pattern;
pub mod splitmix;
pub mod tare;
pub mod track;
pub mod window;

pub use context::{FromConfig, StageContext};
pub use error::{Error, Result};
pub use event::{EventBatch, TactileEvent};

/// Helpers of the crate's own tests.
#[cfg(test)]
pub(crate) mod test_util {
    /// Push `input` in chunks of `cut` items, each chunk's outputs collected in a vector of
    /// its own and appended, as a caller feeding a stage piecewise does; the caller then
    /// `finish`es. The chunking tests compare this with one run over the whole input.
    pub(crate) fn push_in_chunks<T, O, E: std::fmt::Debug>(
        input: &[T],
        cut: usize,
        mut push: impl FnMut(&T, &mut Vec<O>) -> Result<(), E>,
    ) -> Vec<O> {
        let mut out = Vec::new();
        for chunk in input.chunks(cut) {
            let mut part = Vec::new();
            for x in chunk {
                push(x, &mut part).unwrap();
            }
            out.extend(part);
        }
        out
    }
}
