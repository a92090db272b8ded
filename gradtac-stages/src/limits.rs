//! Bounds of every size-like and geometric setting, checked by the stages' constructors.
//!
//! A setting outside its bound is refused with [`Error::InvalidConfig`](crate::Error) when the
//! stage is built — before any data moves, so `gradtac explain` reports it too — instead of
//! allocating gigabytes or handing an absurd number to a geometry library. Every bound is
//! generous for a tactile sensor (a BioTac is about 30 mm across, samples at 100 Hz) and
//! documented with its reason in the repository's `docs/safety.md`.

use crate::{Error, Result};

/// Largest absolute coordinate (mm) of a taxel, a grid extent or a geometric setting
/// (distances, margins, centres): 10⁶ mm (1 km), far beyond any tactile skin, far below where
/// floating-point geometry (spade's triangulation) loses its precision guarantees.
pub const MAX_MM: f64 = gradtac_stream::layout::MAX_COORD_MM;
/// Most grid points of a surface (`nx · ny`): 2²⁰ (1024 × 1024), 8 MiB per surface.
pub const MAX_GRID_POINTS: usize = 1 << 20;
/// Most events one taxel may emit for one input frame (`max_events_per_step`).
pub const MAX_EVENTS_PER_STEP: u32 = 4096;
/// Longest event window, in frames (`frames`, `step`): 2²⁰ (≈ 2.9 h at 100 Hz).
pub const MAX_WINDOW_FRAMES: u64 = 1 << 20;
/// Longest event window or decay constant, in milliseconds (`duration_ms`): 10⁷ ms (≈ 2.8 h).
pub const MAX_WINDOW_MS: f64 = 1e7;
/// Most frames per one-fingertip slip decision (`decision_frames`, `hop_frames`,
/// `track_window_frames`): 2²⁰ frames.
pub const MAX_DOS_FRAMES: u64 = 1 << 20;
/// Longest time span (s) of a setting in seconds that makes a stage hold data
/// (`velocity_window_s`, `min_duration_s`): one hour.
pub const MAX_SPAN_S: f64 = 3600.0;
/// Most points a velocity fit may ask for (`min_points`).
pub const MAX_POINTS: usize = 1 << 16;
/// Most frames a tracker may coast or wait (`max_gated_frames`, `release_frames`).
pub const MAX_TRACK_FRAMES: u32 = 1 << 20;

/// A length in mm: finite, within `[min, MAX_MM]` (`min` is 0 for distances that may be 0).
pub(crate) fn check_mm(stage: &'static str, name: &str, v: f64, positive: bool) -> Result<()> {
    let ok = v.is_finite() && v <= MAX_MM && if positive { v > 0.0 } else { v >= 0.0 };
    if ok {
        return Ok(());
    }
    let low = if positive { "> 0" } else { "≥ 0" };
    Err(Error::InvalidConfig { stage, reason: format!("`{name}` = {v} mm must be finite, {low} and ≤ {MAX_MM} mm") })
}

/// A coordinate in mm: finite and within ±[`MAX_MM`].
pub(crate) fn check_coord(stage: &'static str, name: &str, v: [f64; 2]) -> Result<()> {
    if v.iter().all(|c| c.is_finite() && c.abs() <= MAX_MM) {
        return Ok(());
    }
    Err(Error::InvalidConfig { stage, reason: format!("`{name}` = {v:?} mm must be finite and within ±{MAX_MM} mm") })
}

/// A count at most `max`.
pub(crate) fn check_count(stage: &'static str, name: &str, v: u64, max: u64) -> Result<()> {
    if v <= max {
        return Ok(());
    }
    Err(Error::InvalidConfig { stage, reason: format!("`{name}` = {v} exceeds the maximum of {max}") })
}
