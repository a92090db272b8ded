//! Log-change tactile events (method.md, stage 3): the DVS rule per taxel.
//!
//! # What it does
//! Each taxel keeps a reference level `r` on the log scale, starting at `ln y₀` of its first
//! sample. The value used is `y = max(x + offset, floor)` (see *Values ≤ 0* below). Whenever
//! `ln y` has moved from `r` by at least `τ`, the stage emits one [`TactileEvent`] per threshold
//! crossed — polarity +1 up, −1 down — and moves `r` by `±τ` for each. Concretely the levels are
//! `L(j) = e^{r₀ + jτ}` for integer `j` and the reference is one of them, `L(k)`; a sample
//! `y ≥ L(k+1)` crosses every level `k+1..=j` with `L(j) ≤ y < L(j+1)`, a sample `y ≤ L(k−1)`
//! every level `k−1, k−2, …, j` with `L(j−1) < y ≤ L(j)`; then `k := j`. (The paper's inline
//! `ln X' > e^τ ln X` contradicts its own `|ln X' − ln X| > τ`; this is the latter, with `≥`.)
//!
//! Between two samples `(t, y_t)` and `(t+δ, y_{t+δ})` of a taxel the signal is taken as linear
//! in **value**, so level `L` is crossed at `t + δ·(L − y_t)/(y_{t+δ} − y_t)`, rounded to the
//! nearest nanosecond (halves up). Levels are geometric in value, so a rise crosses them densest near `t`
//! (the paper's "frequency of events higher initially").
//!
//! The comparison runs in the linear domain against the two cached bounds `L(k±1)` per taxel,
//! so a sample that crosses nothing costs two comparisons and no logarithm; `ln` and `exp` are
//! evaluated only for crossings. Because the bounds are recomputed from the integer level `k`
//! (not accumulated), a constant signal never fires again after its crossings, and feeding the
//! same frames in any chunking gives bit-identical events.
//!
//! # Output
//! Exactly one [`EventBatch`] per input frame (often empty), stamped with that frame's time and
//! seq; the batch holds the events of the interval `[t, t+δ]` that frame closed (a crossing
//! that rounds to `t` itself is stamped `t`). Inside a batch events are in non-decreasing time;
//! ties are ordered by taxel index, then by crossing order. Across the batches of one stream
//! times are non-decreasing too: a taxel whose previous sample was skipped interpolates from its
//! last finite sample, but its event times are clamped to no earlier than the previous frame.
//! Delay: none (the events of an interval are known when it closes). With a noise-adaptive
//! threshold ([`Threshold::Noise`]) the first `calibrate_frames` frames (and those after a
//! [`reset`](Stage::reset)) give empty batches while the noise is measured; gaps handled by
//! [`EventGapPolicy::Reset`] keep the measured τ.
//!
//! Event schema as written to Parquet/Arrow (`event/1`, specified in the repository's
//! `docs/schemas.md`): one row per event with `sensor` (Utf8), `time_ns` (Int64, the event's
//! interpolated time), `frame_time_ns` (Int64) and `seq` (UInt64) of the batch's frame,
//! `taxel` (UInt16) and `polarity` (Int8, ±1); an empty batch writes no row.
//!
//! # Policies
//! | situation | behaviour |
//! |---|---|
//! | `x + offset ≤ floor` (e.g. 0 after min-max normalisation) | the value is raised to `floor` (`> 0`), counted in [`EventCounters::floored`]; never `ln 0` |
//! | NaN or ±inf | [`NonFinitePolicy::Error`]: [`Error::BadValue`] naming sensor, frame seq and taxel; [`NonFinitePolicy::Skip`]: the sample is ignored for that taxel (its next finite sample interpolates from the last finite one), counted in [`EventCounters::skipped`] |
//! | more than `max_events_per_step` crossings of one taxel in one step | the earliest `max_events_per_step` are emitted, the reference still moves past all of them (it tracks the signal), the rest counted in [`EventCounters::overflow`] (and per taxel, [`Events::overflow_per_taxel`]) |
//! | a crossing within `refractory_s` of the taxel's previous emitted event | not emitted, but the reference moves (the taxel is blind, as a DVS pixel); counted in [`EventCounters::suppressed`] |
//! | dropped frames (`seq` jumps) or an interval longer than `max_gap_s` | [`EventGapPolicy::Interpolate`] (default): one long interval, crossings interpolated across it; [`EventGapPolicy::Reset`]: references restart at the new frame, the change across the gap produces no events |
//! | time going backwards | always a reset (there is no interval to interpolate in) |
//!
//! With no floor clamping, no cap overflow and no refractory suppression, the running sum of
//! `polarity·τ` of a taxel equals `r − ln y₀`, so it reconstructs `ln y − ln y₀` to within `τ`
//! at every sample.
//!
//! # Polarity: which events count toward a contact
//! [`Polarity`] (`[stages.events] polarity`): `both` (the stage's default, the paper's events:
//! +1 up, −1 down; a scene's event chain defaults to `press_release` instead, through
//! `[stages.locate] event_chain`, [`EventChain`](crate::locate::EventChain)), `press` (only crossings that take the taxel further from its **baseline** — its
//! starting level `ln y₀` — emitted as +1; crossings back toward it dropped and counted in
//! [`EventCounters::released`]) or `press_release` (+1 away from the baseline, −1 back toward
//! it; the running sum of polarities is then `|k|`, the taxel's distance from its baseline in
//! thresholds). "Away from the baseline" needs no sign per electrode, so an electrode that
//! reads the other way under pressure presses like the rest. Emission order, times and the
//! reference are those of `both`; only which crossings are emitted and their sign differ.
//!
//! # Speed
//! Per 24-taxel frame (criterion, `benches/signal.rs`, one core, release): ≈ 3 ns per taxel when
//! nothing crosses (66 ns per frame at 0.44 events per frame, 15 M frames/s) plus ≈ 30–50 ns per
//! event (2.1 M frames/s at 9.3 events per frame). One allocation per frame that has events
//! (the batch's exact-size `Vec`), none otherwise. A frame's events are ordered by one integer
//! sort of packed keys under every polarity (`press_release` included: its polarity is a bit
//! of the key); on a machine at load 10, 2026-11-27: `events_touch_press_release` 5.12 ms per
//! 4096 frames (was 5.88 ms with the tuple sort it used before), `events_touch` (`both`)
//! 5.42 ms (6.16 ms in the run before; same code path, so that difference is the load's).
//!
//! # Trade-offs
//! | knob | smaller | larger |
//! |---|---|---|
//! | `threshold` τ | finer resolution, more events (cap!) | fewer events, coarser; τ ≥ the total log change → none |
//! | `threshold = { noise_sigmas, calibrate_frames }` | (as τ, in σ of each taxel's noise) | (as τ); longer calibration: steadier σ, later first event |
//! | `floor` | more events from near-zero values (log blows up) | insensitive near 0 |
//! | `refractory_s` | faithful counts | bounded rate, lost resolution |
//! | `polarity` | `both`: a moving contact's leading (press) and trailing (release) edges both fire | `press`: the pressing edge only; `press_release`: signed by press/release, a long signed window holds the change field |

use crate::{Error, EventBatch, Result, TactileEvent};
use gradtac_stream::{Delay, Stage, TaxelFrame, Timestamp};
use serde::{Deserialize, Serialize};

const STAGE: &str = "events";

/// A finite input whose offset value is below the floor (non-finite input goes to the policy).
#[inline(always)]
fn below_floor(x: f64, y: f64, floor: f64) -> bool {
    x.is_finite() && !y.is_nan() && y < floor
}

/// The smallest accepted threshold: below it neighbouring levels `e^{r₀+jτ}` stop being
/// distinct in `f64` for large `|r₀ + jτ|`.
pub const MIN_THRESHOLD: f64 = 1e-12;

fn invalid(reason: impl Into<String>) -> Error {
    Error::InvalidConfig { stage: STAGE, reason: reason.into() }
}

/// The threshold `τ` on `ln y`: one for all taxels, one per taxel, or measured from each
/// taxel's noise. In TOML `threshold = 0.1`, `threshold = [0.1, 0.2, …]` or
/// `threshold = { noise_sigmas = 4.0, calibrate_frames = 20 }`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Threshold {
    /// The same `τ` for every taxel.
    Uniform(f64),
    /// `τ` per taxel (length = number of taxels).
    PerTaxel(Vec<f64>),
    /// Noise-adaptive: the first `calibrate_frames` frames (2–100 000; no events) measure each
    /// taxel's noise `σᵢ` of `ln y` (the larger of the first-difference estimate and the
    /// scatter about a straight line, as the `locate` change detector does), then
    /// `τᵢ = noise_sigmas · σᵢ` (≥ [`MIN_THRESHOLD`]; a taxel quieter than a quarter of the median
    /// taxel counts as that quarter). A sensor three times noisier gets three times the τ and
    /// so the same rate of noise events: the event-count contact threshold (the contour's
    /// `min_peak`) then means the same number of σ on any sensor.
    Noise {
        /// `τᵢ` in σ of the taxel's `ln y` per frame (> 0, ≤ 1000).
        noise_sigmas: f64,
        /// Frames measuring the noise at start-up and after a [`reset`](Stage::reset).
        calibrate_frames: u32,
    },
}

/// Per-taxel σ of a series of frames (`samples[k][i]`, NaN = skipped): the larger of the
/// white-noise estimate from first differences (`Var(x[k+1] − x[k]) = 2σ²`) and the scatter
/// about a least-squares line (slow, correlated fluctuations, but not a linear trend), with
/// floors of a quarter of the median taxel's σ and `1e-12`.
pub fn noise_sigma(samples: &[Vec<f64>], taxels: usize) -> Vec<f64> {
    let mut sigma: Vec<f64> = (0..taxels)
        .map(|i| {
            let pts: Vec<(f64, f64)> = samples
                .iter()
                .enumerate()
                .filter_map(|(k, f)| f.get(i).copied().filter(|v| v.is_finite()).map(|v| (k as f64, v)))
                .collect();
            let m = pts.len() as f64;
            if pts.len() < 2 {
                return 0.0;
            }
            let d2: f64 = pts.windows(2).map(|w| (w[1].1 - w[0].1).powi(2)).sum();
            let white = (d2 / (2.0 * (m - 1.0))).sqrt();
            let (tm, vm) = (pts.iter().map(|p| p.0).sum::<f64>() / m, pts.iter().map(|p| p.1).sum::<f64>() / m);
            let stt: f64 = pts.iter().map(|p| (p.0 - tm).powi(2)).sum();
            let slope = pts.iter().map(|p| (p.0 - tm) * (p.1 - vm)).sum::<f64>() / stt.max(f64::MIN_POSITIVE);
            let r2: f64 = pts.iter().map(|p| (p.1 - vm - slope * (p.0 - tm)).powi(2)).sum();
            let scatter = if m > 2.0 { (r2 / (m - 2.0)).sqrt() } else { 0.0 };
            white.max(scatter)
        })
        .collect();
    let mut sorted = sigma.clone();
    sorted.sort_by(f64::total_cmp);
    let med = sorted.get(taxels / 2).copied().unwrap_or(0.0);
    for s in &mut sigma {
        *s = s.max(0.25 * med).max(1e-12);
    }
    sigma
}

/// The default: `τᵢ` = 4 σ of each taxel's noise, measured over the first 20 frames — the
/// `events` contact-location method's own default (`[stages.locate] event_tau_sigmas = 4`,
/// `calibrate_frames = 20`, chosen on tuning members of the simulator family; the repository's
/// `docs/tradeoff.md`), so a chain composed in code from stage defaults runs what a bare scene
/// runs. A fixed `τ` is not a safe default: the right value depends on the sensor's noise (on
/// the BioTacSP-DoS recordings `τ = 0.05` after min–max normalisation fires on noise, and almost
/// every 10-frame window then holds a "contact").
impl Default for Threshold {
    fn default() -> Self {
        Threshold::Noise { noise_sigmas: 4.0, calibrate_frames: 20 }
    }
}

/// What to do with a NaN or ±inf input value.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NonFinitePolicy {
    /// Fail with [`Error::BadValue`] naming the sensor, frame and taxel.
    #[default]
    Error,
    /// Ignore that taxel's sample and count it.
    Skip,
}

/// What a gap in the stream (dropped frames, or an interval above `max_gap_s`) does.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EventGapPolicy {
    /// Treat the gap as one long interval; crossings are interpolated across it.
    #[default]
    Interpolate,
    /// Restart every taxel's reference at the frame after the gap.
    Reset,
}

/// Which events count, and what their polarity means (`[stages.events] polarity`).
///
/// **The baseline.** Each taxel's baseline is its reference's starting level `r₀ = ln y₀`: the
/// first sample after start-up (after the noise calibration, when τ is measured), after a
/// [`reset`](Stage::reset), or after a gap under [`EventGapPolicy::Reset`]. The reference sits
/// `k` whole thresholds from it (`r = r₀ + kτ`). A crossing that takes `|k|` up moves the value
/// **away from the baseline** — the taxel is being pressed further, whichever way its value
/// reads under pressure; a crossing that takes `|k|` down moves it **back toward the baseline**
/// — a release. So an electrode whose value *rises* under pressure (a flipped sign, up to 30 %
/// of the electrodes in the simulator family, and on real sensors whose electrodes read either
/// way) presses with +1 crossings, its neighbours with −1 crossings, and both count as
/// presses: no sign is assumed or learned, only the untouched level at the start. The cost:
/// a stream that starts *in contact* takes the pressed level as its baseline (its release
/// then counts as a press), and slow drift away from the baseline counts as pressing (drift
/// back toward it as releasing).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Polarity {
    /// Every crossing is emitted with the direction of `ln y`: +1 up, −1 down (the paper's DVS
    /// events). The stage's default (a scene's event chain defaults to
    /// [`PressRelease`](Polarity::PressRelease): [`EventChain`](crate::locate::EventChain)).
    #[default]
    Both,
    /// Only crossings away from the taxel's baseline are emitted, each with polarity **+1**
    /// (pressing); crossings back toward it are dropped (counted in
    /// [`EventCounters::released`]). A window of counts (or signed sums) then sees only the
    /// pressing edge of a contact.
    Press,
    /// Every crossing is emitted, with polarity **+1 away from the baseline** (press) and
    /// **−1 toward it** (release). The running signed sum of a taxel is then `|k|`, its
    /// distance from the baseline in thresholds: a signed window as long as the contact holds
    /// the contact's current change field, whatever each electrode's sign. The default of a
    /// scene's event chain ([`EventChain`](crate::locate::EventChain)).
    PressRelease,
}

impl Polarity {
    /// The name used in scenes.
    pub fn name(self) -> &'static str {
        match self {
            Polarity::Both => "both",
            Polarity::Press => "press",
            Polarity::PressRelease => "press_release",
        }
    }
}

/// Configuration of [`Events`]; a `[stages.events]` table in a scene.
///
/// ```toml
/// threshold = { noise_sigmas = 4.0, calibrate_frames = 20 }   # the default; or a fixed τ
///                           # on ln(value): 0.05, or one per taxel: [0.05, 0.04, …]
/// refractory_s = 0.0        # seconds; 0 = none
/// max_events_per_step = 64  # per taxel per input frame
/// offset = 0.0              # y = max(x + offset, floor)
/// floor = 1e-3
/// non_finite = "error"      # or "skip"
/// gap = "interpolate"       # or "reset"
/// # max_gap_s = 0.05        # an interval longer than this is a gap (optional)
/// polarity = "both"         # or "press" (only crossings away from each taxel's baseline,
///                           # as +1) or "press_release" (+1 away, −1 back toward it)
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EventsConfig {
    /// `τ`, dimensionless (a change of `ln y`; 0.05 ≈ 5 %). ≥ [`MIN_THRESHOLD`], finite.
    /// Default: measured, 4 σ of each taxel's noise over the first 20 frames (see
    /// [`Threshold::default`]).
    pub threshold: Threshold,
    /// Refractory period in **seconds** (rounded to whole ns): after an emitted event a taxel's
    /// crossings within this time are not emitted. Default 0 (none).
    pub refractory_s: f64,
    /// Most events one taxel may emit for one input frame (≥ 1); the rest are counted as
    /// overflow. Default 64.
    pub max_events_per_step: u32,
    /// Added to every value before the log (same unit as the input). Default 0.
    pub offset: f64,
    /// Values below it (after `offset`) are raised to it before the log (same unit as the
    /// input, > 0). Default 1e-3 (0.1 % of full scale for normalised input).
    pub floor: f64,
    /// NaN / ±inf handling. Default [`NonFinitePolicy::Error`].
    pub non_finite: NonFinitePolicy,
    /// Gap handling. Default [`EventGapPolicy::Interpolate`].
    pub gap: EventGapPolicy,
    /// An interval longer than this many **seconds** is a gap (besides a `seq` jump, which
    /// always is). Default `None`.
    pub max_gap_s: Option<f64>,
    /// Which crossings are emitted and what their polarity means: `both` (direction of
    /// `ln y`, the default), `press` (only away from each taxel's baseline, as +1) or
    /// `press_release` (+1 away, −1 toward); see [`Polarity`].
    pub polarity: Polarity,
}

impl Default for EventsConfig {
    fn default() -> Self {
        EventsConfig {
            threshold: Threshold::default(),
            refractory_s: 0.0,
            max_events_per_step: 64,
            offset: 0.0,
            floor: 1e-3,
            non_finite: NonFinitePolicy::Error,
            gap: EventGapPolicy::Interpolate,
            max_gap_s: None,
            polarity: Polarity::Both,
        }
    }
}

/// What the stage dropped or altered, summed over its life (kept across [`Stage::reset`];
/// see [`Events::clear_counters`]).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct EventCounters {
    /// Crossings not emitted because of `max_events_per_step`.
    pub overflow: u64,
    /// Crossings not emitted because of the refractory period.
    pub suppressed: u64,
    /// Non-finite samples skipped ([`NonFinitePolicy::Skip`]).
    pub skipped: u64,
    /// Samples raised to `floor`.
    pub floored: u64,
    /// Crossings back toward the baseline not emitted under [`Polarity::Press`].
    pub released: u64,
}

/// The log-change event generator over [`TaxelFrame`]s; see the [module docs](self).
///
/// ```
/// use gradtac_stages::events::{Events, EventsConfig, Threshold};
/// use gradtac_stream::{StageExt, TaxelFrame, Timestamp};
///
/// let config = EventsConfig { threshold: Threshold::Uniform(0.5), ..Default::default() };
/// let mut ev = Events::try_new(1, config).unwrap();
/// let frame = |k: u64, x: f64| TaxelFrame::new("ff".into(), Timestamp(k as i64 * 10_000_000), k, vec![x]);
/// let batches = ev.run_all([frame(0, 1.0), frame(1, 3.0)]).unwrap();
/// assert_eq!(batches.len(), 2); // one batch per frame
/// // ln 3 = 1.0986: two crossings of 0.5, at values e^0.5 and e^1.0
/// let ev1 = &batches[1].events;
/// assert_eq!(ev1.len(), 2);
/// assert!(ev1.iter().all(|e| e.polarity == 1));
/// let t = (0.5f64.exp() - 1.0) / 2.0 * 1e7;
/// assert_eq!(ev1[0].time, Timestamp(t.round() as i64));
/// ```
#[derive(Clone, Debug)]
#[must_use = "a stage does nothing until frames are pushed"]
pub struct Events {
    config: EventsConfig,
    taxels: usize,
    tau: Vec<f64>,
    refractory_ns: i64,
    max_gap_ns: Option<i64>,
    // Per-taxel state (structure of arrays).
    /// `L(k−1)`, or +inf for a taxel without a reference yet.
    lo: Vec<f64>,
    /// `L(k+1)`, or −inf for a taxel without a reference yet.
    hi: Vec<f64>,
    /// `L(k)`.
    mid: Vec<f64>,
    /// `ln y₀`.
    r0: Vec<f64>,
    /// `k`: the reference is `r₀ + kτ`.
    level: Vec<i64>,
    /// Last finite value `y` and its time (ns).
    prev: Vec<f64>,
    prev_t: Vec<i64>,
    /// Time of the last emitted event (ns), `i64::MIN` for none.
    last_event: Vec<i64>,
    /// [`Threshold::Noise`] while calibrating: `ln y` of the frames so far (NaN = skipped).
    calib: Option<Vec<Vec<f64>>>,
    overflow_per_taxel: Vec<u64>,
    /// (time, seq) of the previous frame of the segment.
    last_frame: Option<(Timestamp, u64)>,
    counters: EventCounters,
    /// Events of the frame being processed (reused; the batch gets an exact-size copy).
    scratch: Vec<TactileEvent>,
    /// Taxels of the frame being processed that need the slow path (reused).
    slow_taxels: Vec<u32>,
    /// Sort keys of the frame being processed (reused).
    sort_keys: Vec<u64>,
    /// Bits below an event's time in its packed sort key: the taxel index's bits and one for
    /// the polarity ([`Events::sort_batch`]).
    key_shift: u32,
}

impl Events {
    /// An event generator for frames of `taxels` values.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] for zero or more than 65 535 taxels, a threshold that is not
    /// finite and ≥ [`MIN_THRESHOLD`] (or a per-taxel list of the wrong length), a negative or
    /// non-finite refractory period, a zero cap, a `floor` that is not finite and > 0, a
    /// non-finite offset, or a `max_gap_s` that is not finite and > 0.
    pub fn try_new(taxels: usize, config: EventsConfig) -> Result<Events> {
        if taxels == 0 || taxels > u16::MAX as usize {
            return Err(invalid(format!("taxels must be 1..=65535, got {taxels}")));
        }
        let tau = match &config.threshold {
            Threshold::Uniform(t) => vec![*t; taxels],
            Threshold::PerTaxel(v) if v.len() == taxels => v.clone(),
            Threshold::PerTaxel(v) => {
                return Err(invalid(format!("threshold has {} values for {taxels} taxels", v.len())));
            }
            Threshold::Noise { noise_sigmas, calibrate_frames } => {
                if !(noise_sigmas.is_finite() && *noise_sigmas > 0.0 && *noise_sigmas <= 1000.0) {
                    return Err(invalid(format!(
                        "threshold noise_sigmas must be in (0, 1000], got {}",
                        gradtac_stream::num::Short(*noise_sigmas)
                    )));
                }
                if !(2..=100_000).contains(calibrate_frames) {
                    return Err(invalid(format!(
                        "threshold calibrate_frames must be in 2..=100000, got {calibrate_frames}"
                    )));
                }
                // placeholder until the calibration measures the noise
                vec![1.0; taxels]
            }
        };
        if let Some((i, t)) = tau.iter().enumerate().find(|(_, t)| !(t.is_finite() && **t >= MIN_THRESHOLD)) {
            return Err(invalid(format!(
                "threshold of taxel {i} must be finite and >= {MIN_THRESHOLD:e}, got {}",
                gradtac_stream::num::Short(*t)
            )));
        }
        let r = config.refractory_s;
        if !(r.is_finite() && (0.0..=9.0e9).contains(&r)) {
            return Err(invalid(format!(
                "refractory_s must be finite, >= 0 and at most 9e9 s, got {}",
                gradtac_stream::num::Short(r)
            )));
        }
        if config.max_events_per_step == 0 {
            return Err(invalid("max_events_per_step must be at least 1"));
        }
        let most = crate::limits::MAX_EVENTS_PER_STEP;
        if config.max_events_per_step > most {
            return Err(invalid(format!(
                "max_events_per_step = {} exceeds the maximum of {most} (events of one taxel for one frame)",
                config.max_events_per_step
            )));
        }
        if !(config.floor.is_finite() && config.floor > 0.0) {
            return Err(invalid(format!(
                "floor must be finite and > 0 (it keeps ln finite), got {}",
                gradtac_stream::num::Short(config.floor)
            )));
        }
        if !config.offset.is_finite() {
            return Err(invalid(format!("offset must be finite, got {}", gradtac_stream::num::Short(config.offset))));
        }
        let max_gap_ns = match config.max_gap_s {
            None => None,
            Some(g) if g.is_finite() && g > 0.0 && g <= 9.0e9 => Some((g * 1e9).round() as i64),
            Some(g) => {
                return Err(invalid(format!(
                    "max_gap_s must be finite, > 0 and at most 9e9 s, got {}",
                    gradtac_stream::num::Short(g)
                )))
            }
        };
        Ok(Events {
            taxels,
            tau,
            refractory_ns: (r * 1e9).round() as i64,
            max_gap_ns,
            lo: vec![f64::INFINITY; taxels],
            hi: vec![f64::NEG_INFINITY; taxels],
            mid: vec![1.0; taxels],
            scratch: Vec::new(),
            slow_taxels: Vec::with_capacity(taxels),
            sort_keys: Vec::new(),
            key_shift: usize::BITS - (taxels.max(2) - 1).leading_zeros() + 1,
            r0: vec![0.0; taxels],
            level: vec![0; taxels],
            prev: vec![0.0; taxels],
            prev_t: vec![0; taxels],
            last_event: vec![i64::MIN; taxels],
            overflow_per_taxel: vec![0; taxels],
            last_frame: None,
            counters: EventCounters::default(),
            calib: matches!(config.threshold, Threshold::Noise { .. }).then(Vec::new),
            config,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &EventsConfig {
        &self.config
    }

    /// The thresholds `τ` per taxel in effect (for [`Threshold::Noise`]: measured by the
    /// calibration; `None` while it runs).
    pub fn thresholds(&self) -> Option<&[f64]> {
        self.calib.is_none().then_some(&self.tau[..])
    }

    /// [`Threshold::Noise`] calibration: record one frame; after the last, set `τ` and start
    /// the references at the next frame. Emits no events.
    fn calibrate(&mut self, frame: &TaxelFrame) -> Result<bool> {
        let Threshold::Noise { noise_sigmas, calibrate_frames } = self.config.threshold else { return Ok(false) };
        let Some(calib) = self.calib.as_mut() else { return Ok(false) };
        let (offset, floor) = (self.config.offset, self.config.floor);
        let mut row = Vec::with_capacity(self.taxels);
        for (i, &x) in frame.values.iter().enumerate() {
            if !x.is_finite() {
                if self.config.non_finite == NonFinitePolicy::Error {
                    return Err(Error::BadValue {
                        stage: STAGE,
                        sensor: frame.sensor.to_string(),
                        seq: frame.seq,
                        taxel: i,
                        value: x,
                        reason: "non-finite value",
                    });
                }
                self.counters.skipped += 1;
                row.push(f64::NAN);
                continue;
            }
            let y = x + offset;
            let y = if below_floor(x, y, floor) { floor } else { y };
            row.push(y.ln());
        }
        calib.push(row);
        if calib.len() >= calibrate_frames as usize {
            let sigma = noise_sigma(calib, self.taxels);
            self.tau = sigma.iter().map(|s| (noise_sigmas * s).max(MIN_THRESHOLD)).collect();
            self.calib = None;
            self.clear_state();
        }
        Ok(true)
    }

    /// Number of taxels per frame.
    pub fn taxels(&self) -> usize {
        self.taxels
    }

    /// What was dropped or altered so far.
    pub fn counters(&self) -> EventCounters {
        self.counters
    }

    /// Crossings dropped by the cap, so far (= `counters().overflow`).
    pub fn overflow(&self) -> u64 {
        self.counters.overflow
    }

    /// Crossings dropped by the cap, per taxel.
    pub fn overflow_per_taxel(&self) -> &[u64] {
        &self.overflow_per_taxel
    }

    /// Zero all counters.
    pub fn clear_counters(&mut self) {
        self.counters = EventCounters::default();
        self.overflow_per_taxel.iter_mut().for_each(|c| *c = 0);
    }

    /// The current reference level `r = r₀ + kτ` (on the `ln` scale) of a taxel; `None` before
    /// its first finite sample of the segment, or for a taxel index out of range.
    pub fn reference(&self, taxel: usize) -> Option<f64> {
        let lo = *self.lo.get(taxel)?;
        (lo != f64::INFINITY).then(|| self.r0[taxel] + self.level[taxel] as f64 * self.tau[taxel])
    }

    fn clear_state(&mut self) {
        self.lo.iter_mut().for_each(|x| *x = f64::INFINITY);
        self.hi.iter_mut().for_each(|x| *x = f64::NEG_INFINITY);
        self.last_event.iter_mut().for_each(|x| *x = i64::MIN);
        self.last_frame = None;
    }

    #[inline]
    fn bad_value(&mut self, frame: &TaxelFrame, taxel: usize, x: f64) -> Result<()> {
        match self.config.non_finite {
            NonFinitePolicy::Error => Err(Error::BadValue {
                stage: STAGE,
                sensor: frame.sensor.to_string(),
                seq: frame.seq,
                taxel,
                value: x,
                reason: "non-finite value",
            }),
            NonFinitePolicy::Skip => {
                self.counters.skipped += 1;
                Ok(())
            }
        }
    }

    /// Sort a frame's events by (time, taxel, polarity −1 before +1). That is the stable
    /// (time, taxel, crossing) order: one taxel's step crosses its levels in time order, and
    /// when a `press_release` step swings through the baseline its releases (−1) come before
    /// its presses (+1); events equal in all three are identical.
    ///
    /// All times lie in `[previous frame, now]`. Each event packs into one `u64` key
    /// `(time − start) << s | taxel << 1 | (polarity > 0)` with `s` = the taxel index's bits + 1
    /// (6 for 24 taxels), a plain integer sort, whenever the span fits `63 − s` bits of ns:
    /// 4.5 years for 24 taxels, 19.5 hours at the 65 535-taxel maximum. A longer span (a frame
    /// after a gap that long) takes the stable tuple sort, which gives the same order.
    fn sort_batch(&mut self, events: &mut [TactileEvent], now: i64) {
        let start = events.iter().map(|e| e.time.as_nanos()).min().unwrap_or(now);
        let shift = self.key_shift;
        if now.checked_sub(start).is_none_or(|span| span >= 1i64 << (63 - shift)) {
            events.sort_by_key(|e| (e.time, e.taxel, e.polarity));
            return;
        }
        let mut keys = std::mem::take(&mut self.sort_keys);
        keys.clear();
        keys.extend(events.iter().map(|e| {
            ((e.time.as_nanos() - start) as u64) << shift | (e.taxel as u64) << 1 | u64::from(e.polarity > 0)
        }));
        keys.sort_unstable();
        let taxel_mask = (1u64 << (shift - 1)) - 1;
        for (e, k) in events.iter_mut().zip(&keys) {
            *e = TactileEvent {
                time: Timestamp(start + (k >> shift) as i64),
                taxel: ((k >> 1) & taxel_mask) as u16,
                polarity: if k & 1 == 1 { 1 } else { -1 },
            };
        }
        self.sort_keys = keys;
    }

    /// A sample that is outside the taxel's bounds, non-finite, or the taxel's first.
    #[cold]
    fn slow(&mut self, frame: &TaxelFrame, i: usize, x: f64, y: f64, events: &mut Vec<TactileEvent>) -> Result<()> {
        if !(x.is_finite() && y.is_finite()) {
            return self.bad_value(frame, i, x);
        }
        let now = frame.time.as_nanos();
        let tau = self.tau[i];
        if self.lo[i] == f64::INFINITY {
            // First finite sample of this taxel in the segment: it becomes the reference.
            let r0 = y.ln();
            self.r0[i] = r0;
            self.level[i] = 0;
            self.lo[i] = (r0 - tau).exp();
            self.mid[i] = r0.exp(); // L(0), computed like every other level
            self.hi[i] = (r0 + tau).exp();
            self.prev[i] = y;
            self.prev_t[i] = now;
            return Ok(());
        }
        let r0 = self.r0[i];
        let lvl = |j: i64| (r0 + j as f64 * tau).exp();
        let k = self.level[i];
        let (lo, mid, hi) = (self.lo[i], self.mid[i], self.hi[i]);
        // (direction, final level j, new bounds L(j−1), L(j), L(j+1)). One crossing — by far
        // the most common case — costs one exp and no ln: the bounds shift by one level.
        let (dir, j, bounds) = if y >= hi {
            let next = lvl(k + 2);
            if y < next {
                (1i64, k + 1, (mid, hi, next))
            } else {
                let mut j = (((y.ln() - r0) / tau).floor() as i64).max(k + 2);
                while lvl(j + 1) <= y {
                    j += 1;
                }
                while j > k + 2 && lvl(j) > y {
                    j -= 1;
                }
                (1i64, j, (lvl(j - 1), lvl(j), lvl(j + 1)))
            }
        } else if y <= lo {
            let next = lvl(k - 2);
            if y > next {
                (-1i64, k - 1, (next, lo, mid))
            } else {
                let mut j = (((y.ln() - r0) / tau).ceil() as i64).min(k - 2);
                while lvl(j - 1) >= y {
                    j -= 1;
                }
                while j < k - 2 && lvl(j) < y {
                    j += 1;
                }
                (-1i64, j, (lvl(j - 1), lvl(j), lvl(j + 1)))
            }
        } else {
            // Inside the bounds after all (only reachable for a taxel just (re)initialised).
            self.prev[i] = y;
            self.prev_t[i] = now;
            return Ok(());
        };
        // Crossings at levels k+dir, k+2·dir, …, j, in time order.
        let (p, pt) = (self.prev[i], self.prev_t[i]);
        let dy = y - p;
        let dt = (now - pt) as f64;
        // Clamped to the previous frame's time: after a skipped sample the interval reaches
        // further back, but batches must stay in time order.
        let not_before = self.last_frame.map_or(i64::MIN, |(t, _)| t.as_nanos());
        let time_of = |v: f64| {
            let frac = ((v - p) / dy).clamp(0.0, 1.0);
            // frac·dt ≥ 0: adding ½ and truncating rounds half up, without a libm call.
            (pt + (frac * dt + 0.5) as i64).max(not_before)
        };
        let cap = self.config.max_events_per_step;
        let polarity = self.config.polarity;
        let mut emitted = 0u32;
        let mut lv = k + dir;
        let mut remaining = (j - k).unsigned_abs();
        while remaining > 0 {
            // the crossing into level `lv` moves away from the baseline (level 0) iff it takes
            // |level| up: lv·dir > 0
            let away = lv * dir > 0;
            if polarity == Polarity::Press && !away {
                self.counters.released += 1;
                remaining -= 1;
                lv += dir;
                continue;
            }
            if emitted == cap {
                self.counters.overflow += remaining;
                self.overflow_per_taxel[i] += remaining;
                break;
            }
            let level_value = if lv == k + dir {
                if dir > 0 {
                    hi
                } else {
                    lo
                }
            } else {
                lvl(lv)
            };
            let te = time_of(level_value);
            let free_at = self.last_event[i].saturating_add(self.refractory_ns);
            if self.refractory_ns > 0 && te < free_at {
                // Crossing times are monotone in the level: binary-search the first crossing at
                // or after `free_at` (or none), suppressing everything before it.
                let (mut a, mut b) = (1u64, remaining); // crossing `lv + dir·m`, m ∈ [a, b]; b = none
                while a < b {
                    let m = a + (b - a) / 2;
                    if time_of(lvl(lv + dir * m as i64)) >= free_at {
                        b = m;
                    } else {
                        a = m + 1;
                    }
                }
                let skip = a;
                self.counters.suppressed += skip;
                remaining -= skip;
                lv += dir * skip as i64;
                continue;
            }
            let pol = match polarity {
                Polarity::Both => dir as i8,
                Polarity::Press => 1,
                Polarity::PressRelease if away => 1,
                Polarity::PressRelease => -1,
            };
            events.push(TactileEvent { time: Timestamp(te), taxel: i as u16, polarity: pol });
            self.last_event[i] = te;
            emitted += 1;
            remaining -= 1;
            lv += dir;
        }
        self.level[i] = j;
        (self.lo[i], self.mid[i], self.hi[i]) = bounds;
        self.prev[i] = y;
        self.prev_t[i] = now;
        Ok(())
    }
}

impl Stage for Events {
    type In = TaxelFrame;
    type Out = EventBatch;
    type Error = Error;

    fn push(&mut self, frame: TaxelFrame, out: &mut Vec<EventBatch>) -> Result<()> {
        let n = self.taxels;
        crate::error::check_taxel_count(STAGE, &frame.sensor, frame.seq, n, frame.values.len())?;
        if self.calibrate(&frame)? {
            out.push(EventBatch {
                sensor: frame.sensor,
                time: frame.time,
                seq: frame.seq,
                taxels: n as u16,
                events: Vec::new(),
            });
            return Ok(());
        }
        if let Some((t, seq)) = self.last_frame {
            let dt = frame.time - t;
            let gap = frame.seq != seq.wrapping_add(1) || self.max_gap_ns.is_some_and(|g| dt > g);
            if dt < 0 || (gap && self.config.gap == EventGapPolicy::Reset) {
                self.clear_state();
            }
        }
        let now = frame.time.as_nanos();
        let (offset, floor) = (self.config.offset, self.config.floor);
        let mut events = std::mem::take(&mut self.scratch);
        events.clear();
        let mut first_taxel_with_events = usize::MAX;
        let mut several = false;
        // Pass 1, branch-light over all taxels: values inside their bounds only update `prev`;
        // the rest (crossings, non-finite, first samples) are listed for pass 2.
        let mut slow = std::mem::take(&mut self.slow_taxels);
        slow.clear();
        let mut floored = 0;
        let state = self.lo.iter().zip(&self.hi).zip(self.prev.iter_mut().zip(self.prev_t.iter_mut()));
        for (i, (&x, ((&lo, &hi), (prev, prev_t)))) in frame.values.iter().zip(state).enumerate() {
            let mut y = x + offset;
            if below_floor(x, y, floor) {
                y = floor;
                floored += 1;
            }
            if y > lo && y < hi {
                *prev = y;
                *prev_t = now;
            } else {
                slow.push(i as u32);
            }
        }
        self.counters.floored += floored;
        for &i in &slow {
            let i = i as usize;
            let x = frame.values[i];
            let y = x + offset;
            let y = if below_floor(x, y, floor) { floor } else { y };
            let before = events.len();
            let r = self.slow(&frame, i, x, y, &mut events);
            if let Err(e) = r {
                self.scratch = events;
                self.slow_taxels = slow;
                return Err(e);
            }
            if events.len() > before {
                if first_taxel_with_events == usize::MAX {
                    first_taxel_with_events = i;
                } else {
                    several = true;
                }
            }
        }
        if several {
            self.sort_batch(&mut events, now);
        }
        self.last_frame = Some((frame.time, frame.seq));
        let batch_events = events.to_vec(); // exact size; no allocation when empty
        self.scratch = events;
        self.slow_taxels = slow;
        out.push(EventBatch {
            sensor: frame.sensor,
            time: frame.time,
            seq: frame.seq,
            taxels: n as u16,
            events: batch_events,
        });
        Ok(())
    }

    fn reset(&mut self) {
        self.clear_state();
        if matches!(self.config.threshold, Threshold::Noise { .. }) {
            self.calib = Some(Vec::new());
        }
    }

    fn delay(&self) -> Delay {
        Delay::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gradtac_stream::StageExt;

    fn frame(k: u64, v: Vec<f64>) -> TaxelFrame {
        TaxelFrame::new("ff".into(), Timestamp(k as i64 * 10_000_000), k, v)
    }

    fn tau(t: f64) -> EventsConfig {
        EventsConfig { threshold: Threshold::Uniform(t), ..Default::default() }
    }

    #[test]
    fn down_crossings_and_interpolated_times() {
        let mut ev = Events::try_new(1, tau(0.5)).unwrap();
        let b = ev.run_all([frame(0, vec![1.0]), frame(1, vec![0.3])]).unwrap();
        // ln 0.3 = −1.204: levels −0.5, −1.0 crossed
        let e = &b[1].events;
        assert_eq!(e.len(), 2);
        assert!(e.iter().all(|e| e.polarity == -1 && e.taxel == 0));
        for (ev, level) in e.iter().zip([-0.5f64, -1.0]) {
            let t = (1.0 - level.exp()) / 0.7 * 1e7;
            assert_eq!(ev.time, Timestamp(t.round() as i64));
        }
    }

    #[test]
    fn reference_moves_by_whole_thresholds_and_does_not_refire() {
        let mut ev = Events::try_new(1, tau(0.1)).unwrap();
        let mut out = Vec::new();
        ev.push(frame(0, vec![1.0]), &mut out).unwrap();
        ev.push(frame(1, vec![1.35]), &mut out).unwrap(); // ln 1.35 = 0.300: exactly at/near level 3
        let n = out[1].events.len();
        assert!(n == 2 || n == 3, "{n}");
        for k in 2..10 {
            ev.push(frame(k, vec![1.35]), &mut out).unwrap();
            assert!(out.last().unwrap().events.is_empty());
        }
        let r = ev.reference(0).unwrap();
        assert!((1.35f64.ln() - r).abs() < 0.1 && r <= 1.35f64.ln());
    }

    #[test]
    fn ties_are_ordered_by_taxel_then_crossing() {
        let mut ev = Events::try_new(3, tau(0.2)).unwrap();
        let b = ev.run_all([frame(0, vec![1.0, 1.0, 1.0]), frame(1, vec![2.0, 2.0, 0.5])]).unwrap();
        let e = &b[1].events;
        assert!(e.windows(2).all(|w| w[0].time <= w[1].time));
        // taxels 0 and 1 are identical: each of their events comes as a (0, 1) pair
        let same: Vec<_> = e.iter().filter(|e| e.taxel < 2).collect();
        assert!(same.chunks(2).all(|c| c[0].taxel == 0 && c[1].taxel == 1 && c[0].time == c[1].time));
    }

    #[test]
    fn long_intervals_sort_with_and_without_packed_keys() {
        // 3 taxels leave 60 bits of ns to the packed keys: an interval of 2^48 ns (3.3 days)
        // packs, one of 2^61 ns (73 years) takes the tuple sort; both give the same order
        for (at, pol) in [(1i64 << 48, Polarity::Both), (1 << 61, Polarity::Both), (1 << 48, Polarity::PressRelease)] {
            let far = TaxelFrame::new("ff".into(), Timestamp(at), 1, vec![2.0, 3.0, 0.5]);
            let c = EventsConfig { threshold: Threshold::Uniform(0.2), polarity: pol, ..Default::default() };
            let b = Events::try_new(3, c).unwrap().run_all([frame(0, vec![1.0, 1.0, 1.0]), far]).unwrap();
            let e = &b[1].events;
            assert_eq!(e.len(), 3 + 5 + 3);
            assert!(e.windows(2).all(|w| (w[0].time, w[0].taxel) <= (w[1].time, w[1].taxel)));
            for t in 0..3u16 {
                // under press_release every crossing here moves away from the baseline: +1
                let want = if t == 2 && pol == Polarity::Both { -1 } else { 1 };
                assert!(e.iter().filter(|e| e.taxel == t).all(|e| e.polarity == want), "{at} {pol:?}");
            }
        }
        // the widest layout keeps 46 bits (19.5 h): a 20-hour interval takes the tuple sort
        assert_eq!(Events::try_new(65_535, tau(0.1)).unwrap().key_shift, 17);
        assert_eq!(Events::try_new(24, tau(0.1)).unwrap().key_shift, 6);
        assert_eq!(Events::try_new(1, tau(0.1)).unwrap().key_shift, 2);
    }

    #[test]
    fn refractory_suppresses_but_tracks() {
        let mut c = tau(0.01);
        c.refractory_s = 0.004; // 4 ms, frames 10 ms apart
        let mut ev = Events::try_new(1, c).unwrap();
        let b = ev.run_all([frame(0, vec![1.0]), frame(1, vec![2.0]), frame(2, vec![2.0])]).unwrap();
        let e = &b[1].events;
        // ln 2 / 0.01 = 69 crossings in 10 ms: at most one per 4 ms
        assert!(!e.is_empty() && e.len() <= 3, "{}", e.len());
        assert!(e.windows(2).all(|w| w[1].time - w[0].time >= 4_000_000));
        assert_eq!(ev.counters().suppressed + e.len() as u64, 69);
        assert!(b[2].events.is_empty());
    }

    #[test]
    fn bad_configs_are_refused() {
        assert!(Events::try_new(0, EventsConfig::default()).is_err());
        assert!(Events::try_new(70_000, EventsConfig::default()).is_err());
        assert!(Events::try_new(1, tau(0.0)).is_err());
        assert!(Events::try_new(1, tau(f64::NAN)).is_err());
        let c = EventsConfig { threshold: Threshold::PerTaxel(vec![0.1; 3]), ..Default::default() };
        assert!(Events::try_new(24, c).unwrap_err().to_string().contains("3 values for 24"));
        assert!(Events::try_new(1, EventsConfig { floor: 0.0, ..Default::default() }).is_err());
        assert!(Events::try_new(1, EventsConfig { max_events_per_step: 0, ..Default::default() }).is_err());
        assert!(Events::try_new(1, EventsConfig { refractory_s: -1.0, ..Default::default() }).is_err());
        assert!(Events::try_new(1, EventsConfig { max_gap_s: Some(0.0), ..Default::default() }).is_err());
    }

    #[test]
    fn the_default_threshold_is_the_events_methods_default() {
        // a chain composed in code from stage defaults runs what a bare `events` scene runs
        let l = crate::locate::LocateConfig::default();
        let want = Threshold::Noise { noise_sigmas: l.event_tau_sigmas, calibrate_frames: l.calibrate_frames };
        assert_eq!(EventsConfig::default().threshold, want);
        assert_eq!(Threshold::default(), want);
        // and it calibrates: no events during the first frames, then τ per taxel
        let mut ev = Events::try_new(2, EventsConfig::default()).unwrap();
        let mut out = Vec::new();
        for k in 0..l.calibrate_frames as u64 {
            let v = 100.0 + (k % 3) as f64;
            ev.push(
                TaxelFrame::new(
                    gradtac_stream::SensorId::new("s"),
                    Timestamp(k as i64 * 10_000_000),
                    k,
                    vec![v, v + 1.0],
                ),
                &mut out,
            )
            .unwrap();
        }
        assert!(out.iter().all(|b| b.events.is_empty()));
        assert!(ev.thresholds().is_some());
    }

    #[test]
    fn noise_threshold_scales_with_the_noise() {
        // deterministic "noise": ±a alternation on a baseline of 1000; a step of 40 a later
        let run = |a: f64| {
            let c = EventsConfig {
                threshold: Threshold::Noise { noise_sigmas: 4.0, calibrate_frames: 20 },
                ..Default::default()
            };
            let mut ev = Events::try_new(2, c).unwrap();
            let frames = (0..60u64).map(|k| {
                let e = if k % 2 == 0 { a } else { -a };
                let step = if k >= 40 { 40.0 * a } else { 0.0 };
                frame(k, vec![1000.0 + e + step, 2000.0 - e])
            });
            let b = ev.run_all(frames).unwrap();
            assert!(b[..20].iter().all(|b| b.events.is_empty()));
            let counts: Vec<usize> =
                (0..2).map(|t| b.iter().flat_map(|b| &b.events).filter(|e| e.taxel == t).count()).collect();
            (counts, ev)
        };
        let (c1, _) = run(1.0);
        let (c3, _) = run(3.0);
        // noise alone (2 a peak to peak < 4 σ) never fires; the 40 σ step fires the same number
        // of events whatever the noise
        assert_eq!(c1[1], 0);
        assert!(c1[0] > 0 && (c1[0] as i64 - c3[0] as i64).abs() <= 1, "{c1:?} vs {c3:?}");
        assert_eq!(c3[1], 0);
        // σ of ln y from ±1 alternation: |Δ ln y| ≈ 2/1000 → σ ≈ √2/1000
        let c = EventsConfig {
            threshold: Threshold::Noise { noise_sigmas: 1.0, calibrate_frames: 20 },
            ..Default::default()
        };
        let mut ev = Events::try_new(1, c).unwrap();
        assert!(ev.thresholds().is_none());
        ev.run_all((0..20u64).map(|k| frame(k, vec![1000.0 + if k % 2 == 0 { 1.0 } else { -1.0 }]))).unwrap();
        // run_all ends with finish → reset: calibrating again
        assert!(ev.thresholds().is_none());
        let mut ev = Events::try_new(
            1,
            EventsConfig {
                threshold: Threshold::Noise { noise_sigmas: 1.0, calibrate_frames: 20 },
                ..Default::default()
            },
        )
        .unwrap();
        let mut out = Vec::new();
        for k in 0..20u64 {
            ev.push(frame(k, vec![1000.0 + if k % 2 == 0 { 1.0 } else { -1.0 }]), &mut out).unwrap();
        }
        let t = ev.thresholds().unwrap()[0];
        assert!((t - 2f64.sqrt() / 1000.0).abs() < 1e-5, "{t}");
        for bad in [
            Threshold::Noise { noise_sigmas: 0.0, calibrate_frames: 20 },
            Threshold::Noise { noise_sigmas: 3.0, calibrate_frames: 1 },
        ] {
            assert!(Events::try_new(1, EventsConfig { threshold: bad, ..Default::default() }).is_err());
        }
        let c: EventsConfig =
            serde_json::from_str(r#"{"threshold": {"noise_sigmas": 4.0, "calibrate_frames": 20}}"#).unwrap();
        assert_eq!(c.threshold, Threshold::Noise { noise_sigmas: 4.0, calibrate_frames: 20 });
    }

    fn polarity(p: Polarity) -> EventsConfig {
        EventsConfig { polarity: p, ..tau(0.1) }
    }

    /// Three electrodes: 0 and 1 fall under pressure (the family's usual sign), 2 is flipped
    /// (rises); a press (frames 1–3) then a release (frames 5–7).
    fn press_then_release() -> Vec<TaxelFrame> {
        let depth = [0.0, 0.2, 0.5, 0.8, 0.8, 0.5, 0.2, 0.0];
        depth
            .iter()
            .enumerate()
            .map(|(k, d)| frame(k as u64, vec![1.0 - 0.6 * d, 1.0 - 0.3 * d, 1.0 + 0.9 * d]))
            .collect()
    }

    #[test]
    fn press_keeps_pressing_crossings_of_either_sign_and_drops_releases() {
        let all = Events::try_new(3, polarity(Polarity::Both)).unwrap().run_all(press_then_release()).unwrap();
        let mut ev = Events::try_new(3, polarity(Polarity::Press)).unwrap();
        let press = ev.run_all(press_then_release()).unwrap();
        let count = |b: &[EventBatch], range: std::ops::Range<usize>, t: u16| {
            b[range].iter().flat_map(|b| &b.events).filter(|e| e.taxel == t).count()
        };
        for t in 0..3u16 {
            // pressing: the same crossings as `both`, now all +1 (the flipped electrode 2 too)
            assert_eq!(count(&press, 1..5, t), count(&all, 1..5, t), "taxel {t}");
            assert!(count(&press, 1..5, t) > 0);
            // releasing: nothing, though `both` fires
            assert_eq!(count(&press, 5..8, t), 0, "taxel {t}");
            assert!(count(&all, 5..8, t) > 0);
        }
        assert!(press.iter().flat_map(|b| &b.events).all(|e| e.polarity == 1));
        let released: usize = (0..3).map(|t| count(&all, 5..8, t)).sum();
        assert_eq!(ev.counters().released, released as u64);
        // `both` still gives physical directions: electrode 2 rises, 0 and 1 fall, when pressed
        assert!(all[1..5].iter().flat_map(|b| &b.events).all(|e| e.polarity == if e.taxel == 2 { 1 } else { -1 }));
    }

    #[test]
    fn press_release_sums_to_the_distance_from_the_baseline() {
        // a taxel that swings through its baseline in one step: a release, then presses
        let frames = [1.0, 1.5, 0.6, 0.6, 1.0, 2.0].iter().enumerate().map(|(k, &v)| frame(k as u64, vec![v, 3.0 - v]));
        let mut ev = Events::try_new(2, polarity(Polarity::PressRelease)).unwrap();
        let mut sum = [0i64; 2];
        let mut out = Vec::new();
        for f in frames {
            out.clear();
            ev.push(f, &mut out).unwrap();
            let b = &out[0];
            assert!(b.events.windows(2).all(|w| (w[0].time, w[0].taxel) <= (w[1].time, w[1].taxel)));
            for e in &b.events {
                sum[e.taxel as usize] += e.polarity as i64;
            }
            for (t, s) in sum.iter().enumerate() {
                let r = ev.reference(t).unwrap();
                let r0 = if t == 0 { 0.0 } else { 2f64.ln() };
                let k = ((r - r0) / 0.1).round() as i64;
                assert_eq!(*s, k.abs(), "taxel {t} at frame {}", b.seq);
            }
        }
        // the swing 1.5 → 0.6 crosses down through the baseline: releases before presses
        let mut ev = Events::try_new(1, polarity(Polarity::PressRelease)).unwrap();
        let b = ev.run_all([frame(0, vec![1.0]), frame(1, vec![1.5]), frame(2, vec![0.6])]).unwrap();
        let p: Vec<i8> = b[2].events.iter().map(|e| e.polarity).collect();
        let first_press = p.iter().position(|&x| x == 1).unwrap();
        assert!(
            first_press > 0 && p[..first_press].iter().all(|&x| x == -1) && p[first_press..].iter().all(|&x| x == 1)
        );
    }

    #[test]
    fn polarity_parses_and_defaults_to_both() {
        assert_eq!(EventsConfig::default().polarity, Polarity::Both);
        for (text, want) in
            [("both", Polarity::Both), ("press", Polarity::Press), ("press_release", Polarity::PressRelease)]
        {
            let c: EventsConfig = serde_json::from_str(&format!(r#"{{"polarity": "{text}"}}"#)).unwrap();
            assert_eq!(c.polarity, want);
            assert_eq!(want.name(), text);
        }
        assert!(serde_json::from_str::<EventsConfig>(r#"{"polarity": "up"}"#).is_err());
    }

    proptest::proptest! {
        /// Any chunking of the frames (a reset-free push per frame vs. `run_all`) gives the same
        /// events under every polarity; `press` is `both`'s away-from-baseline subset.
        #[test]
        fn polarity_is_chunking_invariant_and_press_is_a_subset(
            values in proptest::collection::vec(proptest::collection::vec(0.05f64..5.0, 3), 2..40),
            cut in 0usize..40,
        ) {
            let frames: Vec<TaxelFrame> = values.iter().enumerate().map(|(k, v)| frame(k as u64, v.clone())).collect();
            for p in [Polarity::Both, Polarity::Press, Polarity::PressRelease] {
                let whole = Events::try_new(3, polarity(p)).unwrap().run_all(frames.clone()).unwrap();
                let mut ev = Events::try_new(3, polarity(p)).unwrap();
                let mut parts = Vec::new();
                let cut = cut.min(frames.len());
                for f in &frames[..cut] { ev.push(f.clone(), &mut parts).unwrap(); }
                for f in &frames[cut..] { ev.push(f.clone(), &mut parts).unwrap(); }
                ev.finish(&mut parts).unwrap();
                proptest::prop_assert_eq!(&whole, &parts);
            }
            let both = Events::try_new(3, polarity(Polarity::Both)).unwrap().run_all(frames.clone()).unwrap();
            let rel = Events::try_new(3, polarity(Polarity::PressRelease)).unwrap().run_all(frames.clone()).unwrap();
            let press = Events::try_new(3, polarity(Polarity::Press)).unwrap().run_all(frames).unwrap();
            for ((b, r), p) in both.iter().zip(&rel).zip(&press) {
                // the same crossings, relabelled; `press` keeps the +1 of press_release
                let key = |e: &TactileEvent| (e.time, e.taxel);
                let mut bk: Vec<_> = b.events.iter().map(key).collect();
                let mut rk: Vec<_> = r.events.iter().map(key).collect();
                bk.sort();
                rk.sort();
                proptest::prop_assert_eq!(bk, rk);
                let pk: Vec<_> = p.events.iter().map(key).collect();
                let rp: Vec<_> = r.events.iter().filter(|e| e.polarity == 1).map(key).collect();
                proptest::prop_assert_eq!(pk, rp);
            }
        }
    }

    proptest::proptest! {
        /// The packed-key sort gives the stable (time, taxel, polarity) order — the crossing
        /// order — for any events in the frame's span, mixed polarities per taxel included, and
        /// so does the tuple sort it falls back to beyond the packed range.
        #[test]
        fn packed_sort_is_the_tuple_sort(
            raw in proptest::collection::vec((0i64..1000, 0u16..24, proptest::bool::ANY), 0..200),
            far in proptest::bool::ANY,
        ) {
            let mut ev = Events::try_new(24, tau(0.1)).unwrap();
            let base = if far { 1i64 << 58 } else { 5_000_000 };
            let now = base + 1000;
            let events: Vec<TactileEvent> = raw
                .iter()
                .map(|&(t, taxel, up)| TactileEvent { time: Timestamp(base + t), taxel, polarity: if up { 1 } else { -1 } })
                .collect();
            let mut want = events.clone();
            want.sort_by_key(|e| (e.time, e.taxel, e.polarity));
            let mut got = events.clone();
            ev.sort_batch(&mut got, now);
            proptest::prop_assert_eq!(&got, &want);
            // a span beyond 57 bits (24 taxels): the fallback, same order
            let mut got = events;
            ev.sort_batch(&mut got, base + (1i64 << 57) + 1000);
            proptest::prop_assert_eq!(got, want);
        }
    }

    #[test]
    fn config_deserialises_scalar_or_per_taxel() {
        let c: EventsConfig = serde_json::from_str(r#"{"threshold": 0.2, "non_finite": "skip"}"#).unwrap();
        assert_eq!(c.threshold, Threshold::Uniform(0.2));
        assert_eq!(c.non_finite, NonFinitePolicy::Skip);
        let c: EventsConfig = serde_json::from_str(r#"{"threshold": [0.1, 0.2], "gap": "reset"}"#).unwrap();
        assert_eq!(c.threshold, Threshold::PerTaxel(vec![0.1, 0.2]));
        assert!(serde_json::from_str::<EventsConfig>(r#"{"tau": 0.1}"#).is_err());
    }
}
