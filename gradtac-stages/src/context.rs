//! One constructor shape for every stage: [`FromConfig::from_config`]`(&config, &context)`.
//!
//! Stages need different parts of their surroundings: `normalise`, `savgol` and `events` the
//! taxel count, `interpolate`, `centroid` and `servo` the layout, `savgol` the sample rate
//! (derivatives per second). A [`StageContext`] carries all three (the taxel count is the
//! layout's), so every stage is built the same way, from its scene table's config struct:
//!
//! ```
//! use gradtac_stages::context::{FromConfig, StageContext};
//! use gradtac_stages::savgol::{SavGol, SavGolConfig};
//! use gradtac_stages::centroid::Centroid;
//! use gradtac_stages::track::{Track, TrackConfig};
//! use gradtac_stream::{Layout, Stage, StageExt};
//!
//! let ctx = StageContext::new(Layout::biotac_sp()).with_rate_hz(100.0);
//! let pipeline = SavGol::from_config(&SavGolConfig::default(), &ctx)?
//!     .then(Centroid::from_config(&Default::default(), &ctx)?)
//!     .then(Track::from_config(&TrackConfig::default(), &ctx)?);
//! assert_eq!(pipeline.delay().frames, 5 + 4); // savgol's half window + centroid's
//! # Ok::<(), gradtac_stages::Error>(())
//! ```
//!
//! The stage-specific constructors (`SavGol::try_new(taxels, config)`, …) stay: they take
//! exactly what the stage reads and are what `from_config` calls.
//!
//! # From scene key to type
//!
//! | scene table / tap | stage type | config | output type | record schema |
//! |---|---|---|---|---|
//! | `normalise` | [`Normalise`] | [`NormaliseConfig`] | `TaxelFrame` | `frame` |
//! | `savgol` | [`SavGol`] | [`SavGolConfig`] | `TaxelFrame` | `frame` |
//! | `events` | [`Events`] | [`EventsConfig`] | [`EventBatch`](crate::EventBatch) | `event` |
//! | `window` | [`Window`] | [`WindowConfig`] | [`WindowAggregate`](crate::window::WindowAggregate) | `window` |
//! | `surface` | [`Interpolate`] (alias [`SurfaceStage`](crate::interpolate::SurfaceStage)) | [`InterpolateConfig`] | [`Surface`](crate::interpolate::Surface) | `surface` |
//! | `contour` | [`Contour`] | [`ContourConfig`] | [`ContourFrame`](crate::contour::ContourFrame) | `contour` |
//! | `contour` with `[stages.locate] method = "centroid"` | [`Centroid`] | [`LocateConfig`] | [`ContourFrame`](crate::contour::ContourFrame) | `contour` |
//! | `contour` with `method = "fit"` | [`Fit`](crate::fit::Fit) | [`LocateConfig`] | [`ContourFrame`](crate::contour::ContourFrame) | `contour` |
//! | `window` with `method = "raw_contour"` | [`RawChange`] | [`LocateConfig`] | [`WindowAggregate`](crate::window::WindowAggregate) | `window` |
//! | `track` | [`Track`] | [`TrackConfig`] | [`TrackPoint`](crate::track::TrackPoint) | `track` |
//! | `force` | [`Force`] | [`ForceConfig`] | [`ForceEstimate`](crate::force::ForceEstimate) | `force` |
//! | `servo` | [`Servo`] | [`ServoConfig`] | [`ServoCommand`](crate::servo::ServoCommand) | `servo` |
//! | `slip` | [`Slip`] | [`SlipConfig`] | [`SlipEvent`](crate::slip::SlipEvent) | `slip` |
//!
//! The one name that differs is the surface's: the tap and the output are named for what comes
//! out (a [`Surface`](crate::interpolate::Surface)), the stage for what it does
//! (natural-neighbour interpolation); [`SurfaceStage`](crate::interpolate::SurfaceStage) names
//! it by the tap.

use crate::centroid::Centroid;
use crate::contour::{Contour, ContourConfig};
use crate::events::{Events, EventsConfig};
use crate::force::{Force, ForceConfig};
use crate::interpolate::{Interpolate, InterpolateConfig};
use crate::locate::LocateConfig;
use crate::normalise::{Normalise, NormaliseConfig};
use crate::raw_contour::RawChange;
use crate::savgol::{SavGol, SavGolConfig};
use crate::servo::{Servo, ServoConfig};
use crate::slip::{Slip, SlipConfig};
use crate::track::{Track, TrackConfig};
use crate::window::{Window, WindowConfig};
use crate::Result;
use gradtac_stream::Layout;
use std::sync::Arc;

/// What a stage may need to know about where it runs: the sensor's layout (and so its taxel
/// count) and, when the source has a fixed rate, the sample rate.
#[derive(Clone, Debug)]
pub struct StageContext {
    layout: Arc<Layout>,
    rate_hz: Option<f64>,
}

impl StageContext {
    /// A context for a sensor of `layout`, rate unknown (timestamped source).
    pub fn new(layout: impl Into<Arc<Layout>>) -> Self {
        StageContext { layout: layout.into(), rate_hz: None }
    }

    /// With a known sample rate (Hz, finite and > 0; checked by the stages that use it).
    pub fn with_rate_hz(mut self, rate_hz: f64) -> Self {
        self.rate_hz = Some(rate_hz);
        self
    }

    /// The sensor's layout.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// The sensor's taxel count (the layout's).
    pub fn taxels(&self) -> usize {
        self.layout.len()
    }

    /// The sample rate, if the source has a fixed one.
    pub fn rate_hz(&self) -> Option<f64> {
        self.rate_hz
    }
}

/// Build a stage from its config and a [`StageContext`]: the one constructor shape every
/// stage has (see the [module docs](self)). Fails on invalid settings, as the stage's
/// `try_new` does.
pub trait FromConfig: Sized {
    /// The stage's config (its `[stages.<tap>]` table in a scene).
    type Config;

    /// Validate `config` and build the stage for `ctx`.
    fn from_config(config: &Self::Config, ctx: &StageContext) -> Result<Self>;
}

impl FromConfig for Normalise {
    type Config = NormaliseConfig;
    fn from_config(config: &NormaliseConfig, ctx: &StageContext) -> Result<Self> {
        Normalise::try_new(ctx.taxels(), config)
    }
}

/// With a rate in the context, derivatives are per second (`delta = 1/rate`).
impl FromConfig for SavGol {
    type Config = SavGolConfig;
    fn from_config(config: &SavGolConfig, ctx: &StageContext) -> Result<Self> {
        match ctx.rate_hz() {
            Some(r) => SavGol::try_with_rate(ctx.taxels(), config.clone(), r),
            None => SavGol::try_new(ctx.taxels(), config.clone()),
        }
    }
}

impl FromConfig for Events {
    type Config = EventsConfig;
    fn from_config(config: &EventsConfig, ctx: &StageContext) -> Result<Self> {
        Events::try_new(ctx.taxels(), config.clone())
    }
}

impl FromConfig for Window {
    type Config = WindowConfig;
    fn from_config(config: &WindowConfig, _ctx: &StageContext) -> Result<Self> {
        Window::try_new(config)
    }
}

impl<I> FromConfig for Interpolate<I> {
    type Config = InterpolateConfig;
    fn from_config(config: &InterpolateConfig, ctx: &StageContext) -> Result<Self> {
        Interpolate::try_new(config, ctx.layout())
    }
}

impl FromConfig for Contour {
    type Config = ContourConfig;
    fn from_config(config: &ContourConfig, _ctx: &StageContext) -> Result<Self> {
        Contour::try_new(config)
    }
}

impl FromConfig for Centroid {
    type Config = LocateConfig;
    fn from_config(config: &LocateConfig, ctx: &StageContext) -> Result<Self> {
        Centroid::try_new(config, ctx.layout())
    }
}

impl FromConfig for crate::fit::Fit {
    type Config = LocateConfig;
    fn from_config(config: &LocateConfig, ctx: &StageContext) -> Result<Self> {
        crate::fit::Fit::try_new(config, ctx.layout())
    }
}

impl FromConfig for RawChange {
    type Config = LocateConfig;
    fn from_config(config: &LocateConfig, ctx: &StageContext) -> Result<Self> {
        RawChange::try_new(ctx.taxels(), config)
    }
}

impl FromConfig for Track {
    type Config = TrackConfig;
    fn from_config(config: &TrackConfig, _ctx: &StageContext) -> Result<Self> {
        Track::try_new(config)
    }
}

impl FromConfig for Force {
    type Config = ForceConfig;
    fn from_config(config: &ForceConfig, _ctx: &StageContext) -> Result<Self> {
        Force::try_new(config)
    }
}

impl FromConfig for Servo {
    type Config = ServoConfig;
    fn from_config(config: &ServoConfig, ctx: &StageContext) -> Result<Self> {
        Servo::try_new(config, ctx.layout())
    }
}

/// Slip reads two sensors' tracks; the context is not used.
impl FromConfig for Slip {
    type Config = SlipConfig;
    fn from_config(config: &SlipConfig, _ctx: &StageContext) -> Result<Self> {
        Slip::try_new(config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gradtac_stream::{SensorId, Stage, StageExt, TaxelFrame, Timestamp};

    /// Each stage built through `from_config` behaves as the one built by its own `try_new`:
    /// same delay, same outputs on the same input.
    #[test]
    fn from_config_builds_the_same_stages_as_try_new() {
        let layout = Layout::biotac_sp();
        let ctx = StageContext::new(layout.clone()).with_rate_hz(100.0);
        let frames: Vec<TaxelFrame> = (0..60)
            .map(|k| {
                let values = (0..layout.len()).map(|i| 3000.0 + ((k * 7 + i * 13) % 17) as f64).collect();
                TaxelFrame::new(SensorId::new("ff"), Timestamp(k as i64 * 10_000_000), k as u64, values)
            })
            .collect();
        let mut a = SavGol::from_config(&SavGolConfig::default(), &ctx).unwrap();
        let mut b = SavGol::try_with_rate(layout.len(), SavGolConfig::default(), 100.0).unwrap();
        assert_eq!(a.delay(), b.delay());
        assert_eq!(a.run_all(frames.clone()).unwrap(), b.run_all(frames.clone()).unwrap());

        let cfg = LocateConfig::default();
        let mut a =
            Centroid::from_config(&cfg, &ctx).unwrap().then(Track::from_config(&TrackConfig::default(), &ctx).unwrap());
        let mut b = Centroid::try_new(&cfg, &layout).unwrap().then(Track::try_new(&TrackConfig::default()).unwrap());
        let (pa, pb) = (a.run_all(frames.clone()).unwrap(), b.run_all(frames).unwrap());
        assert_eq!(format!("{pa:?}"), format!("{pb:?}"));
        assert_eq!(pa.len(), 60);
    }

    /// Invalid settings fail in `from_config` as in `try_new`.
    #[test]
    fn from_config_refuses_what_try_new_refuses() {
        let ctx = StageContext::new(Layout::biotac_sp());
        let even = SavGolConfig { window: 10, ..Default::default() };
        assert_eq!(SavGol::from_config(&even, &ctx).unwrap_err(), SavGol::try_new(24, even.clone()).unwrap_err());
        assert!(ctx.rate_hz().is_none());
        assert_eq!(ctx.taxels(), 24);
    }
}
