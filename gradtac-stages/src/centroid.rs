//! Taxel centroid: contact location as the weighted mean of the taxel positions, weighted by a
//! power of each taxel's change from its baseline (the cheap reference method; see
//! [`locate`](crate::locate) for the calibrated change detector it uses).
//!
//! # What it does
//! Raw frames in, one [`ContourFrame`] out per frame (so `track`, `force`, `servo` and `slip`
//! consume it like a maximal contour):
//! - weights `wᵢ = cᵢ^p`, with `cᵢ = |x̄ᵢ − x₀ᵢ| − floor` the change above the taxel's noise
//!   floor in input units (`weights = "counts"`, the default) or `rᵢ = cᵢ/|x₀ᵢ|` relative to its
//!   resting level (`weights = "relative"`) ([`ChangeDetector`]), `p` = `power`; with `top_k`
//!   only the `k` largest weights count;
//! - location `Σ wᵢ pᵢ / Σ wᵢ` (mm), optionally smoothed with a memory of `smooth_frames` in
//!   which each frame counts with its total weight `Σ wᵢ`; a frame without a contact (or with every weight 0) is
//!   `NoContact(BelowMinPeak)`; the calibration frames are `NoContact(NoData)`;
//! - a **physical speed bound**: within one contact the reported point moves at most
//!   `max_speed_mm_s · Δt` per frame (default 30 mm/s, the top slip speed of the forward-model
//!   family: 0.3 mm per frame at 100 Hz); a new contact (after a frame without one) starts where
//!   it is found. Why: on real BioTacSP-DoS recordings the unbounded centroid jumps up to 1.4 mm
//!   per frame, and the frames that do are not noise — they are changes of 10–20 σ in two or
//!   more regions of the pad at once, often of opposite sign (the baseline is the first contact,
//!   so pressure leaving one region shows as a change as strong as pressure arriving in
//!   another), whose balance shifts faster than any contact moves; the weighted mean then slides
//!   across the pad between them. Taxels entering or leaving the sum are not the cause (their
//!   weight starts from 0 at the noise floor, so the mean moves continuously). The bound turns
//!   such a slide into motion at the physical limit; on the simulated family it costs nothing
//!   measurable (`docs/tradeoff.md`);
//! - the reported "region": `area_mm2 = 4π·√det C` (the 2-σ ellipse of the weights' second
//!   moments `C`; 0 for a single taxel), its orientation and eccentricity, `peak` = the
//!   largest `rᵢ`, `peak_mm` its taxel, `level` = 0, no polygon.
//!
//! # Units
//! Positions mm (the layout's plane), changes in input units (counts) or dimensionless
//! (relative), times ns.
//!
//! # Delay
//! `(window_frames − 1)/2` frames (the span `start..end` of each output covers the averaged
//! frames), plus the position memory's lag (≈ `smooth_frames − 1` frames at constant strength);
//! while the speed bound holds the point back it trails the estimate by (distance − bound)/speed.
//! Start-up: `calibrate_frames` frames without contact.
//!
//! # Cost
//! O(taxels) per frame, no allocation in steady state beyond the output: ≈ 0.1–0.3 µs per
//! BioTac SP frame in a release build (`benches/locate.rs`).
//!
//! # Trade-offs
//! | option | lower | higher |
//! |---|---|---|
//! | `weights` | `relative`: a taxel with a low resting level weighs more for the same change | `counts`: the change as the ADC sees it (the default; 0.053 vs 0.060 of the width, worst kind, on the family's tuning members, `docs/tradeoff.md`) |
//! | `power` | spreads toward the taxels' mean (pulled to the pad centre) | snaps to the strongest taxel (quantised to taxel positions) |
//! | `top_k` | robust to far, sign-flipped lobes; quantised | uses every taxel that moved |
//! | `window_frames` | immediate, noisier | smoother, more delay |
//! | `smooth_frames` | immediate, weak frames jitter | weak frames barely move the point; more lag |
//! | `floor_sigmas` / `contact_sigmas` | sensitive, noise may count | misses light touches |
//! | `max_speed_mm_s` | quiet track, lags a fast real move (0 = no bound) | follows any slide of the weights, jumps |

use crate::contour::{ContourFrame, ContourOutcome, MaxContour, NoContact};
use crate::locate::{CentroidWeights, ChangeDetector, LocateConfig, PositionMemory};
use crate::{Error, Result};
use gradtac_stream::{Delay, Layout, Stage, TaxelFrame};

const STAGE: &str = "centroid";

/// The taxel-centroid stage (see the [module docs](self)).
#[derive(Clone, Debug)]
pub struct Centroid {
    det: ChangeDetector,
    positions: Vec<[f64; 2]>,
    order: Vec<usize>,
    /// The reported position's memory (`smooth_frames`, `max_speed_mm_s`).
    memory: PositionMemory,
}

impl Centroid {
    /// A centroid stage for `layout` (the config is validated).
    pub fn try_new(cfg: &LocateConfig, layout: &Layout) -> Result<Self> {
        Ok(Centroid {
            det: ChangeDetector::try_new(layout.len(), cfg)?,
            positions: layout.positions().to_vec(),
            order: Vec::with_capacity(layout.len()),
            memory: PositionMemory::default(),
        })
    }

    /// The change detector (calibrated noise and baselines).
    pub fn detector(&self) -> &ChangeDetector {
        &self.det
    }

    /// Measure against a stored untouched baseline ([`ChangeDetector::with_tare`]): contact
    /// from the first frame.
    pub fn with_tare(mut self, tare: &crate::tare::Tare) -> Result<Self> {
        self.det = self.det.with_tare(tare)?;
        Ok(self)
    }

    /// The centroid of weights `w` over `positions` (`None` when every weight is 0).
    pub fn weighted(positions: &[[f64; 2]], w: &[f64]) -> Option<MaxContour> {
        let sw: f64 = w.iter().sum();
        if sw <= 0.0 || !sw.is_finite() {
            return None;
        }
        let (mut mx, mut my) = (0.0, 0.0);
        for (p, &wi) in positions.iter().zip(w) {
            mx += wi * p[0];
            my += wi * p[1];
        }
        let c = [mx / sw, my / sw];
        let (mut cxx, mut cyy, mut cxy) = (0.0, 0.0, 0.0);
        let (mut peak, mut at) = (f64::NEG_INFINITY, c);
        for (p, &wi) in positions.iter().zip(w) {
            let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
            cxx += wi * dx * dx;
            cyy += wi * dy * dy;
            cxy += wi * dx * dy;
            if wi > peak {
                peak = wi;
                at = *p;
            }
        }
        let (cxx, cyy, cxy) = (cxx / sw, cyy / sw, cxy / sw);
        let det = (cxx * cyy - cxy * cxy).max(0.0);
        let tr = cxx + cyy;
        let disc = ((cxx - cyy).powi(2) / 4.0 + cxy * cxy).sqrt();
        let (l1, l2) = (tr / 2.0 + disc, (tr / 2.0 - disc).max(0.0));
        Some(MaxContour {
            level: 0.0,
            polygon: Vec::new(),
            holes: Vec::new(),
            area_mm2: 4.0 * std::f64::consts::PI * det.sqrt(),
            centroid_mm: c,
            orientation_rad: 0.5 * (2.0 * cxy).atan2(cxx - cyy),
            eccentricity: if l1 > 0.0 { (1.0 - l2 / l1).max(0.0).sqrt() } else { 0.0 },
            peak,
            peak_mm: at,
            clipped: false,
            fit: None,
        })
    }
}

impl Stage for Centroid {
    type In = TaxelFrame;
    type Out = ContourFrame;
    type Error = Error;

    fn push(&mut self, f: TaxelFrame, out: &mut Vec<ContourFrame>) -> Result<()> {
        let ch = self.det.push(&f, STAGE)?;
        let outcome = if ch.calibrating {
            ContourOutcome::NoContact(NoContact::NoData)
        } else if !ch.contact {
            ContourOutcome::NoContact(NoContact::BelowMinPeak)
        } else {
            let cfg = self.det.config();
            let rel = self.det.relative();
            let p = cfg.power;
            let base = match cfg.weights {
                CentroidWeights::Relative => rel,
                CentroidWeights::Counts => self.det.excess(),
            };
            let mut w: Vec<f64> = base.iter().map(|&r| if p == 2.0 { r * r } else { r.powf(p) }).collect();
            if let Some(k) = cfg.top_k.filter(|&k| k < w.len()) {
                self.order.clear();
                self.order.extend(0..w.len());
                self.order.sort_by(|&a, &b| w[b].total_cmp(&w[a]));
                for &i in &self.order[k..] {
                    w[i] = 0.0;
                }
            }
            match Centroid::weighted(&self.positions, &w) {
                Some(mut c) => {
                    let s: f64 = w.iter().sum();
                    c.centroid_mm = self.memory.update(cfg, c.centroid_mm, s, ch.end);
                    // report the peak as a relative change, not a weight
                    c.peak = rel.iter().copied().fold(0.0, f64::max);
                    ContourOutcome::Contact(c)
                }
                None => ContourOutcome::NoContact(NoContact::BelowMinPeak),
            }
        };
        if outcome.contact().is_none() {
            self.memory.clear();
        }
        out.push(ContourFrame { sensor: f.sensor, start: ch.start, end: ch.end, seq: ch.seq, outcome });
        Ok(())
    }

    fn reset(&mut self) {
        self.det.reset();
        self.memory.clear();
    }

    fn delay(&self) -> Delay {
        Delay::frames((self.det.config().window_frames as u64 - 1) / 2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gradtac_stream::{StageExt, Timestamp};

    fn frames(n: u64, f: impl Fn(u64) -> Vec<f64>) -> Vec<TaxelFrame> {
        (0..n).map(|k| TaxelFrame::new("ff".into(), Timestamp::at_rate(k, 100.0), k, f(k))).collect()
    }

    fn noise(k: u64, i: usize) -> f64 {
        // deterministic ±1 pattern, different per taxel
        if (k + i as u64) % 2 == 0 {
            1.0
        } else {
            -1.0
        }
    }

    #[test]
    fn single_taxel_lands_on_it() {
        let layout = Layout::biotac_sp();
        let mut c = Centroid::try_new(&LocateConfig::default(), &layout).unwrap();
        let out = c
            .run_all(frames(60, |k| {
                (0..24).map(|i| 2000.0 + noise(k, i) + if k >= 30 && i == 23 { 150.0 } else { 0.0 }).collect()
            }))
            .unwrap();
        assert_eq!(out.len(), 60);
        assert!(out[..20].iter().all(|o| o.outcome == ContourOutcome::NoContact(NoContact::NoData)));
        assert!(out[20..30].iter().all(|o| o.outcome.contact().is_none()));
        let p = out[59].outcome.contact().expect("contact");
        let e24 = layout.positions()[23];
        assert!((p.centroid_mm[0] - e24[0]).abs() < 1e-9 && (p.centroid_mm[1] - e24[1]).abs() < 1e-9);
        assert!(p.area_mm2.abs() < 1e-9);
    }

    #[test]
    fn symmetric_pair_lands_in_the_middle_whatever_the_signs() {
        let layout = Layout::biotac_sp();
        // electrodes 22 and 23 mirror each other across y = 0; one falls, one rises (relative to
        // their different baselines by the same fraction)
        // (a 2-frame window averages the ±1 test noise to exactly 0)
        let cfg = LocateConfig { top_k: Some(2), window_frames: 2, ..Default::default() };
        let mut c = Centroid::try_new(&cfg, &layout).unwrap();
        let base = |i: usize| if i == 21 || i == 22 { 2500.0 } else { 1500.0 + 100.0 * i as f64 };
        let out = c
            .run_all(frames(50, |k| {
                (0..24)
                    .map(|i| {
                        let b = base(i);
                        let d = match (k >= 25, i) {
                            (true, 21) => -0.05 * b,
                            (true, 22) => 0.05 * b,
                            (true, 5) => 0.01 * b, // a weaker third taxel that top-2 drops
                            _ => 0.0,
                        };
                        b + noise(k, i) + d
                    })
                    .collect()
            }))
            .unwrap();
        let p = out[49].outcome.contact().expect("contact");
        let (a, b) = (layout.positions()[21], layout.positions()[22]);
        assert!((p.centroid_mm[0] - (a[0] + b[0]) / 2.0).abs() < 1e-6, "{:?}", p.centroid_mm);
        assert!((p.centroid_mm[1] - (a[1] + b[1]) / 2.0).abs() < 1e-6, "{:?}", p.centroid_mm);
        // the 2-σ ellipse of two points is degenerate (a line): zero area, fully eccentric
        assert!(p.area_mm2 < 1e-6 && (p.eccentricity - 1.0).abs() < 1e-9);
    }

    #[test]
    fn counts_weigh_the_change_as_the_adc_sees_it_relative_weighs_it_against_the_level() {
        let layout = Layout::biotac_sp();
        // electrodes 22 and 23 rest at 1000 and 3000 counts; both rise by the same 100 counts
        let base = |i: usize| match i {
            21 => 1000.0,
            22 => 3000.0,
            _ => 2000.0,
        };
        let input = || {
            frames(50, |k| {
                (0..24)
                    .map(|i| base(i) + noise(k, i) + if k >= 25 && (i == 21 || i == 22) { 100.0 } else { 0.0 })
                    .collect()
            })
        };
        let (a, b) = (layout.positions()[21], layout.positions()[22]);
        let at = |weights: CentroidWeights| {
            let cfg =
                LocateConfig { weights, window_frames: 2, smooth_frames: 1, max_speed_mm_s: 0.0, ..Default::default() };
            let out = Centroid::try_new(&cfg, &layout).unwrap().run_all(input()).unwrap();
            out[49].outcome.contact().expect("contact").centroid_mm
        };
        // counts: equal weights, the midpoint (the floor, 2 σ of the ±1 noise, is the same for both)
        let p = at(CentroidWeights::Counts);
        assert!((p[0] - (a[0] + b[0]) / 2.0).abs() < 1e-6 && (p[1] - (a[1] + b[1]) / 2.0).abs() < 1e-6, "{p:?}");
        // relative: weights (c/1000)² : (c/3000)² = 9 : 1, nine tenths of the way to electrode 22
        let p = at(CentroidWeights::Relative);
        let want = [(9.0 * a[0] + b[0]) / 10.0, (9.0 * a[1] + b[1]) / 10.0];
        assert!((p[0] - want[0]).abs() < 1e-6 && (p[1] - want[1]).abs() < 1e-6, "{p:?} vs {want:?}");
    }

    #[test]
    fn the_speed_bound_limits_each_step_and_a_new_contact_starts_free() {
        let layout = Layout::biotac_sp();
        // a press on electrode 24 hands over to electrode 1 (far away) at frame 40
        let input = |k: u64| -> Vec<f64> {
            (0..24)
                .map(|i| {
                    let on = (30..40).contains(&k) && i == 23 || k >= 40 && i == 0;
                    2000.0 + noise(k, i) + if on { 150.0 } else { 0.0 }
                })
                .collect()
        };
        let track = |speed: f64| {
            let cfg = LocateConfig { max_speed_mm_s: speed, window_frames: 1, smooth_frames: 1, ..Default::default() };
            Centroid::try_new(&cfg, &layout).unwrap().run_all(frames(80, input)).unwrap()
        };
        let steps = |out: &[ContourFrame]| -> Vec<f64> {
            out.windows(2)
                .filter_map(|w| {
                    let (a, b) = (w[0].outcome.contact()?, w[1].outcome.contact()?);
                    Some((a.centroid_mm[0] - b.centroid_mm[0]).hypot(a.centroid_mm[1] - b.centroid_mm[1]))
                })
                .collect()
        };
        let free = steps(&track(0.0));
        let bounded = steps(&track(30.0));
        let (e1, e24) = (layout.positions()[0], layout.positions()[23]);
        let far = (e1[0] - e24[0]).hypot(e1[1] - e24[1]);
        assert!(free.iter().copied().fold(0.0, f64::max) > 0.5 * far, "{free:?}");
        // 30 mm/s at 100 Hz: 0.3 mm per frame
        assert!(bounded.iter().all(|&d| d <= 0.3 + 1e-9), "{bounded:?}");
        let out = track(30.0);
        let end = out[79].outcome.contact().unwrap().centroid_mm;
        // 40 frames × 0.3 mm = 12 mm of travel toward electrode 1
        assert!((end[0] - e1[0]).hypot(end[1] - e1[1]) < (far - 11.9).max(1e-6), "{end:?}");
    }

    #[test]
    fn constant_input_is_never_a_contact_and_reset_recalibrates() {
        let layout = Layout::biotac_sp();
        let mut c = Centroid::try_new(&LocateConfig::default(), &layout).unwrap();
        let out = c.run_all(frames(100, |_| vec![3000.0; 24])).unwrap();
        assert!(out.iter().all(|o| o.outcome.contact().is_none()));
        // after run_all (finish → reset) the stage calibrates again
        let out = c.run_all(frames(21, |_| vec![1.0; 24])).unwrap();
        assert_eq!(out[19].outcome, ContourOutcome::NoContact(NoContact::NoData));
        assert_eq!(c.delay(), Delay::frames(4)); // (9 − 1)/2 frames of the default window
    }
}
