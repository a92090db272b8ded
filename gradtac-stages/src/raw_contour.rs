//! Raw change: the per-taxel surface values of the paper's *raw contours* — the
//! baseline-relative change `|x − x₀|/x₀` of the raw values (noise floor removed, drift
//! followed; see [`locate`](crate::locate)) — as [`WindowAggregate`]s, so the ordinary
//! [`Interpolate`](crate::interpolate::Interpolate) → [`Contour`](crate::contour::Contour) →
//! [`Track`](crate::track::Track) stages turn them into a maximal contour and a track.
//!
//! # What it does
//! One [`WindowAggregate`] per raw frame with `aggregate = Count` (non-negative magnitudes: here relative changes, not event counts), `frames` = the frames
//! averaged, `values[i] = rᵢ` (≥ 0; all 0 while calibrating or without a contact, so the
//! contour stage — run with `min_peak = 0` — reports a flat surface, i.e. no contact).
//!
//! # Units
//! Values are dimensionless relative changes; times ns.
//!
//! # Delay
//! `(window_frames − 1)/2` frames; start-up: `calibrate_frames` frames.
//!
//! # Cost
//! O(taxels) per frame (≈ 0.1 µs for a BioTac SP); the surface and contour that follow cost
//! what they cost for events (µs, growing with the grid).
//!
//! # Trade-offs
//! As [`Centroid`](crate::centroid::Centroid)'s detector settings; the contour's `min_area_mm2`
//! decides how much of the surface the region spans (larger: steadier, pulled to the pad
//! centre).

use crate::locate::{ChangeDetector, LocateConfig};
use crate::window::{Aggregate, WindowAggregate};
use crate::{Error, Result};
use gradtac_stream::{Delay, Stage, TaxelFrame};

const STAGE: &str = "raw_contour";

/// The raw-change stage (see the [module docs](self)).
#[derive(Clone, Debug)]
pub struct RawChange {
    det: ChangeDetector,
}

impl RawChange {
    /// A stage for `taxels` taxels (the config is validated).
    pub fn try_new(taxels: usize, cfg: &LocateConfig) -> Result<Self> {
        Ok(RawChange { det: ChangeDetector::try_new(taxels, cfg)? })
    }

    /// The change detector (calibrated noise and baselines).
    pub fn detector(&self) -> &ChangeDetector {
        &self.det
    }

    /// Measure against a stored untouched baseline ([`ChangeDetector::with_tare`]).
    pub fn with_tare(mut self, tare: &crate::tare::Tare) -> Result<Self> {
        self.det = self.det.with_tare(tare)?;
        Ok(self)
    }
}

impl Stage for RawChange {
    type In = TaxelFrame;
    type Out = WindowAggregate;
    type Error = Error;

    fn push(&mut self, f: TaxelFrame, out: &mut Vec<WindowAggregate>) -> Result<()> {
        let ch = self.det.push(&f, STAGE)?;
        let frames = (self.det.config().window_frames as u64).min(f.seq + 1);
        out.push(WindowAggregate {
            sensor: f.sensor,
            start: ch.start,
            end: ch.end,
            seq: ch.seq,
            frames,
            aggregate: Aggregate::Count,
            values: self.det.relative().to_vec(),
            split: None,
        });
        Ok(())
    }

    fn reset(&mut self) {
        self.det.reset();
    }

    fn delay(&self) -> Delay {
        Delay::frames((self.det.config().window_frames as u64 - 1) / 2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contour::{Contour, ContourConfig};
    use crate::interpolate::{Interpolate, InterpolateConfig};
    use gradtac_stream::{Layout, StageExt, Timestamp};

    #[test]
    fn a_press_on_one_taxel_gives_a_contour_around_it() {
        let layout = Layout::biotac_sp();
        let cfg = LocateConfig::default();
        let mut chain = RawChange::try_new(24, &cfg)
            .unwrap()
            .then(Interpolate::try_new(&InterpolateConfig::default(), &layout).unwrap())
            .then(Contour::try_new(&ContourConfig { min_peak: 0.0, ..Default::default() }).unwrap());
        let frames = (0..60u64).map(|k| {
            let v = (0..24)
                .map(|i| 2500.0 + if k % 2 == 0 { 1.0 } else { -1.0 } + if k >= 30 && i == 23 { -200.0 } else { 0.0 })
                .collect();
            TaxelFrame::new("ff".into(), Timestamp::at_rate(k, 100.0), k, v)
        });
        let out = chain.run_all(frames).unwrap();
        assert_eq!(out.len(), 60);
        assert!(out[..30].iter().all(|o| o.outcome.contact().is_none()));
        let c = out[59].outcome.contact().expect("contact");
        let e24 = layout.positions()[23];
        assert!((c.centroid_mm[0] - e24[0]).hypot(c.centroid_mm[1] - e24[1]) < 1.5, "{:?}", c.centroid_mm);
    }
}
