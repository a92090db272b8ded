//! [`DosFeatureExtractor`]: raw frames of one sensor to a [`FeatureVector`] (events, surfaces, contours, the drift map).

use super::*;

/// One track window's activity contour.
#[derive(Clone, Copy, Debug)]
struct TrackSample {
    centroid: [f64; 2],
    orientation: f64,
    eccentricity: f64,
}

/// Extracts a [`FeatureVector`] from raw frames of one sensor: events → split counts → surfaces
/// → maximal contours, and the drift map. A plain state machine: [`push`](Self::push) frames,
/// read [`features`](Self::features) for the span so far, [`clear_span`](Self::clear_span) to
/// start a new span without losing the event references, [`reset`](Self::reset) on a
/// discontinuity.
///
/// It builds and runs only what its configured features need: the events always (they check
/// the input and give the event features), the track window and its per-window locations only
/// for `track_dx`, `track_dy` or `rotation`, the drift map only for a `drift_*` feature, and
/// surfaces and contours only for the `surface` and `max_contour` [`CentroidMethod`]s. The
/// features of a part that was not built are NaN in the [`FeatureVector`]; to compute every
/// feature (e.g. to compare feature sets), configure [`Feature::ALL`].
#[derive(Clone, Debug)]
pub struct DosFeatureExtractor {
    cfg: DosFeatureConfig,
    taxels: usize,
    events: Events,
    /// Track window (`None`: no track feature configured).
    pub(super) window: Option<Window>,
    /// Surfaces and contours (`None` with [`CentroidMethod::Taxels`]).
    pub(super) spatial: Option<(Interpolator, MaxContourFinder)>,
    centre: [f64; 2],
    positions: Vec<[f64; 2]>,
    seconds: (Option<Timestamp>, Option<Timestamp>),
    pos: Vec<f64>,
    neg: Vec<f64>,
    frames: u64,
    track: Vec<TrackSample>,
    batches: Vec<EventBatch>,
    windows: Vec<WindowAggregate>,
    /// Drift map (`None`: no drift feature configured).
    pub(super) drift: Option<DriftMap>,
    /// The pushed frame's values (the frame itself moves into the events stage).
    values: Vec<f64>,
}

/// Whether `features` use any of `part`.
fn uses(features: &[Feature], part: &[Feature]) -> bool {
    features.iter().any(|f| part.contains(f))
}

/// The features computed from the track windows.
const TRACK: [Feature; 3] = [Feature::TrackDx, Feature::TrackDy, Feature::Rotation];

impl DosFeatureExtractor {
    /// An extractor for `layout`'s sensor (validating the configuration).
    pub fn try_new(cfg: &DosFeatureConfig, layout: &Layout) -> Result<Self> {
        cfg.validate()?;
        let taxels = layout.len();
        let events = Events::try_new(
            taxels,
            EventsConfig { threshold: Threshold::Uniform(cfg.threshold), ..Default::default() },
        )?;
        let window = if uses(&cfg.features, &TRACK) {
            Some(Window::try_new(&WindowConfig {
                kind: WindowKind::Tumbling,
                frames: Some(cfg.track_window_frames),
                duration_ms: None,
                step: 1,
                aggregate: Aggregate::Split,
            })?)
        } else {
            None
        };
        let spatial = if cfg.centroid == CentroidMethod::Taxels {
            None
        } else {
            let grid =
                crate::interpolate::Grid::from_config(&GridConfig { nx: cfg.grid_nx, ..Default::default() }, layout)?;
            let interp =
                Interpolator::try_new(layout, Arc::new(grid), Method::NaturalNeighbour, Outside::Nan, 2.0, 0.0)?;
            let finder = MaxContourFinder::try_new(&ContourConfig {
                levels: Levels::Count(10),
                min_area_mm2: cfg.min_area_mm2,
                min_peak: cfg.min_peak,
                saddle: Saddle::Centre,
                peak_only: true,
            })?;
            Some((interp, finder))
        };
        let drift = if uses(&cfg.features, &Feature::DRIFT) {
            Some(DriftMap::try_new(taxels, &cfg.drift_lags, EventsConfig::default().floor)?.with_scale(cfg.drift_scale))
        } else {
            None
        };
        Ok(DosFeatureExtractor {
            cfg: cfg.clone(),
            taxels,
            events,
            window,
            spatial,
            centre: layout.extent().centre(),
            positions: layout.positions().to_vec(),
            seconds: (None, None),
            pos: vec![0.0; taxels],
            neg: vec![0.0; taxels],
            frames: 0,
            track: Vec::new(),
            batches: Vec::new(),
            windows: Vec::new(),
            drift,
            values: vec![0.0; taxels],
        })
    }

    /// The configuration.
    pub fn config(&self) -> &DosFeatureConfig {
        &self.cfg
    }

    /// Frames in the current span.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Push one raw frame (counts). Errors name the sensor, frame and taxel (wrong taxel count,
    /// non-finite value, time going backwards).
    pub fn push(&mut self, frame: TaxelFrame) -> Result<()> {
        crate::error::check_taxel_count(STAGE, &frame.sensor, frame.seq, self.taxels, frame.values.len())?;
        self.batches.clear();
        let time = frame.time;
        if self.drift.is_some() {
            self.values.copy_from_slice(&frame.values);
        }
        self.events.push(frame, &mut self.batches)?;
        if let Some(drift) = &mut self.drift {
            // The events stage refuses non-finite values (its default policy), so this cannot fail.
            drift.push(&self.values)?;
        }
        self.seconds = (self.seconds.0.or(Some(time)), Some(time));
        self.frames += 1;
        for b in self.batches.drain(..) {
            for e in &b.events {
                let t = e.taxel as usize;
                if e.polarity > 0 {
                    self.pos[t] += 1.0;
                } else {
                    self.neg[t] += 1.0;
                }
            }
            if let Some(window) = &mut self.window {
                window.push(b, &mut self.windows)?;
            }
        }
        let mut windows = std::mem::take(&mut self.windows);
        for w in &windows {
            let Some(split) = &w.split else { continue };
            let counts: Vec<f64> = split.positive.iter().zip(&split.negative).map(|(p, n)| p + n).collect();
            if let Some(sample) = self.locate(&counts) {
                self.track.push(sample);
            }
        }
        windows.clear();
        self.windows = windows;
        Ok(())
    }

    /// The features of the span so far (see the [module docs](crate::dos)).
    pub fn features(&mut self) -> FeatureVector {
        let p: f64 = self.pos.iter().sum();
        let n: f64 = self.neg.iter().sum();
        let total = p + n;
        let mut all = [0.0; 18];
        all[Feature::Rate.index()] = (1.0 + total / self.span_seconds()).ln();
        all[Feature::PositiveFraction.index()] = if total > 0.0 { p / total } else { 0.5 };
        let pc = self.centroid(&self.pos.clone());
        let nc = self.centroid(&self.neg.clone());
        let activity: Vec<f64> = self.pos.iter().zip(&self.neg).map(|(a, b)| a + b).collect();
        let ac = self.centroid(&activity);
        all[Feature::PositiveX.index()] = pc[0];
        all[Feature::PositiveY.index()] = pc[1];
        all[Feature::NegativeX.index()] = nc[0];
        all[Feature::NegativeY.index()] = nc[1];
        all[Feature::ActivityX.index()] = ac[0];
        all[Feature::ActivityY.index()] = ac[1];
        let (d, rot) = if self.window.is_some() { track_motion(&self.track) } else { ([f64::NAN; 2], f64::NAN) };
        all[Feature::TrackDx.index()] = d[0];
        all[Feature::TrackDy.index()] = d[1];
        all[Feature::Rotation.index()] = rot;
        let drift = self.drift_features();
        for (f, v) in Feature::DRIFT.iter().zip(drift) {
            all[f.index()] = v;
        }
        FeatureVector { all, frames: self.frames, events: total as u64 }
    }

    /// Start a new span: counts, track and frame count restart, the event references (and the
    /// partly filled track window) are kept.
    pub fn clear_span(&mut self) {
        self.pos.iter_mut().for_each(|v| *v = 0.0);
        self.neg.iter_mut().for_each(|v| *v = 0.0);
        self.frames = 0;
        self.seconds = (None, None);
        self.track.clear();
        if let Some(d) = &mut self.drift {
            d.clear_span();
        }
    }

    /// Forget everything (a discontinuity in the stream).
    pub fn reset(&mut self) {
        self.clear_span();
        self.events.reset();
        if let Some(w) = &mut self.window {
            w.reset();
        }
        if let Some(d) = &mut self.drift {
            d.reset();
        }
    }

    /// The seven drift features ([`Feature::DRIFT`] order) of the span so far: the
    /// [drift map](crate::drift)'s weights `w_i` and signs `s_i` located on the layout. Without
    /// weight the centroid is the layout's centre and the moments are zero; NaN without a drift
    /// map.
    fn drift_features(&self) -> [f64; 7] {
        let Some(drift) = &self.drift else { return [f64::NAN; 7] };
        let snap = drift.snapshot();
        let total: f64 = snap.weights.iter().sum();
        let level = total.ln_1p();
        if !(total > 0.0 && total.is_finite()) {
            return [level, self.centre[0], self.centre[1], 0.0, 0.0, 0.0, 0.0];
        }
        let (mut cx, mut cy) = (0.0, 0.0);
        for (w, p) in snap.weights.iter().zip(&self.positions) {
            cx += w * p[0];
            cy += w * p[1];
        }
        let (cx, cy) = (cx / total, cy / total);
        let (mut r2, mut aniso, mut cross, mut signed_y) = (0.0, 0.0, 0.0, 0.0);
        for ((w, s), p) in snap.weights.iter().zip(&snap.signs).zip(&self.positions) {
            let (dx, dy) = (p[0] - cx, p[1] - cy);
            r2 += w * (dx * dx + dy * dy);
            aniso += w * (dx * dx - dy * dy);
            cross += w * dx * dy;
            signed_y += w * s * p[1];
        }
        [level, cx, cy, (r2 / total).ln_1p(), aniso / total, cross / total, signed_y / total]
    }

    /// The span's duration: `(t_last − t_first)·n/(n − 1)` for `n` frames (one mean frame
    /// interval per frame); 10 ms per frame when the times do not tell (fewer than two frames,
    /// equal times).
    pub fn span_seconds(&self) -> f64 {
        let n = self.frames as f64;
        match self.seconds {
            (Some(a), Some(b)) if self.frames >= 2 && b > a => (b - a) as f64 * 1e-9 * n / (n - 1.0),
            _ => 0.01 * n.max(1.0),
        }
    }

    fn centroid(&mut self, values: &[f64]) -> [f64; 2] {
        self.locate(values).map_or(self.centre, |s| s.centroid)
    }

    /// Location, orientation and eccentricity of a count distribution by the configured method.
    fn locate(&mut self, values: &[f64]) -> Option<TrackSample> {
        match (&mut self.spatial, self.cfg.centroid) {
            (Some((interp, finder)), CentroidMethod::MaxContour) => contour(interp, finder, values).map(|c| {
                TrackSample { centroid: c.centroid_mm, orientation: c.orientation_rad, eccentricity: c.eccentricity }
            }),
            (Some((interp, _)), CentroidMethod::Surface) => {
                let z = interp.surface(values);
                let g = interp.grid();
                weighted_moments(z.indexed_iter().map(|((j, i), &v)| (g.x(i), g.y(j), v)))
            }
            // Taxels (try_new builds the surfaces for every other method)
            _ => weighted_moments(values.iter().zip(&self.positions).map(|(&v, p)| (p[0], p[1], v))),
        }
    }
}

/// Centroid, principal-axis orientation (rad, `(−π/2, π/2]`) and eccentricity
/// `√(1 − λ_min/λ_max)` of positive finite weights at points; `None` without weight.
fn weighted_moments(points: impl Iterator<Item = (f64, f64, f64)> + Clone) -> Option<TrackSample> {
    let (mut w, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for (x, y, v) in points.clone() {
        if v.is_finite() && v > 0.0 {
            w += v;
            sx += v * x;
            sy += v * y;
        }
    }
    if !(w > 0.0 && w.is_finite()) {
        return None;
    }
    let c = [sx / w, sy / w];
    let (mut xx, mut yy, mut xy) = (0.0, 0.0, 0.0);
    for (x, y, v) in points {
        if v.is_finite() && v > 0.0 {
            let (dx, dy) = (x - c[0], y - c[1]);
            xx += v * dx * dx;
            yy += v * dy * dy;
            xy += v * dx * dy;
        }
    }
    let (xx, yy, xy) = (xx / w, yy / w, xy / w);
    let mut orientation = 0.5 * (2.0 * xy).atan2(xx - yy);
    if orientation <= -std::f64::consts::FRAC_PI_2 {
        orientation += std::f64::consts::PI;
    }
    let half = ((xx - yy).powi(2) / 4.0 + xy * xy).sqrt();
    let (hi, lo) = ((xx + yy) / 2.0 + half, ((xx + yy) / 2.0 - half).max(0.0));
    let eccentricity = if hi > 0.0 { (1.0 - lo / hi).clamp(0.0, 1.0).sqrt() } else { 0.0 };
    let finite = c[0].is_finite() && c[1].is_finite() && orientation.is_finite();
    finite.then_some(TrackSample { centroid: c, orientation, eccentricity })
}

fn contour(interp: &Interpolator, finder: &mut MaxContourFinder, values: &[f64]) -> Option<MaxContour> {
    let z = interp.surface(values);
    finder.find(z.view(), interp.grid()).contact().cloned()
}

/// `ln Σ_j (f_j − μ_j)² / v_j` without overflow for any finite `f`, `μ` and `v > 0`
/// (`−∞` when `f = μ`): each term's log from halved operands, summed by log-sum-exp.
pub(super) fn ln_mahalanobis(means: &[f64], features: &[f64], vars: &[f64]) -> f64 {
    let terms: Vec<f64> = means
        .iter()
        .zip(features)
        .zip(vars)
        .map(|((mu, f), v)| 2.0 * ((f / 2.0 - mu / 2.0).abs().ln() + std::f64::consts::LN_2) - v.ln())
        .collect();
    let top = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if top == f64::NEG_INFINITY {
        return top;
    }
    top + terms.iter().map(|t| (t - top).exp()).sum::<f64>().ln()
}

/// Track displacement (last third minus first third of the samples) and eccentricity-weighted
/// rotation (sum of wrapped orientation changes).
fn track_motion(track: &[TrackSample]) -> ([f64; 2], f64) {
    let k = track.len();
    if k < 2 {
        return ([0.0; 2], 0.0);
    }
    let third = (k / 3).max(1);
    let mean = |s: &[TrackSample]| {
        let n = s.len() as f64;
        [s.iter().map(|t| t.centroid[0]).sum::<f64>() / n, s.iter().map(|t| t.centroid[1]).sum::<f64>() / n]
    };
    let (a, b) = (mean(&track[..third]), mean(&track[k - third..]));
    let mut rot = 0.0;
    for w in track.windows(2) {
        let d = wrap_half_pi(w[1].orientation - w[0].orientation);
        let weight = w[0].eccentricity.min(w[1].eccentricity);
        if d.is_finite() && weight.is_finite() {
            rot += weight * d;
        }
    }
    ([b[0] - a[0], b[1] - a[1]], rot)
}

/// An angle difference of axes (period π) wrapped to `(−π/2, π/2]`.
pub(super) fn wrap_half_pi(d: f64) -> f64 {
    let pi = std::f64::consts::PI;
    let mut r = d.rem_euclid(pi);
    if r > pi / 2.0 {
        r -= pi;
    }
    r
}
