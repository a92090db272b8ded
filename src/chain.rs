//! One sensor's stages, built only where its outputs need them (the tap tree of [`Tap::parent`]).

use crate::plan::{SensorPlan, Tap};
use crate::scene::{ForceModelSpec, ForceSettings, Scene, StageSettings};
use crate::sinks::RecordWriter;
use crate::Error;
use gradtac_stages::centroid::Centroid;
use gradtac_stages::contour::{Contour, ContourConfig, ContourFrame, Levels};
use gradtac_stages::dos::{DosClassifier, DosDecision};
use gradtac_stages::events::{Events, Threshold};
use gradtac_stages::fit::Fit;
use gradtac_stages::force::{Force, ForceConfig, ForceEstimate, ForceModel};
use gradtac_stages::force_model::{CalibratedForce, ChangeForce};
use gradtac_stages::interpolate::{Interpolate, Surface};
use gradtac_stages::locate::{LocateMethod, ReturnAnchors, RiseGuard, ShapeFit, DRIFT_SHAPE_RISE_FRACTION};
use gradtac_stages::normalise::{Bounds, Normalise};
use gradtac_stages::peak::SurfaceContour;
use gradtac_stages::raw_contour::RawChange;
use gradtac_stages::savgol::SavGol;
use gradtac_stages::servo::{Servo, ServoCommand};
use gradtac_stages::track::{Track, TrackPoint};
use gradtac_stages::window::{Window, WindowAggregate};
use gradtac_stages::EventBatch;
use gradtac_stream::{Delay, SensorId, Stage, TaxelFrame};

/// The stages of one sensor, `None` where no output needs them, with a reusable buffer after
/// each stage.
pub struct SensorChain {
    sensor: SensorId,
    /// Output indices tapping each stage (indexed by `Tap as usize`).
    taps: [Vec<usize>; TAPS],
    normalise: Option<Normalise>,
    savgol: Option<SavGol>,
    events: Option<Events>,
    window: Option<Window>,
    surface: Option<Interpolate>,
    contour: Option<Contour>,
    /// Surface and contour fused (no surface allocated per window) when no output taps the
    /// surface: the same contours, bit for bit.
    fused: Option<SurfaceContour>,
    /// `[stages.locate] method = "centroid"`: contours from the raw frames.
    centroid: Option<Centroid>,
    /// `[stages.locate] method = "fit"`: contours (fitted contacts) from the raw frames.
    fit: Option<Fit>,
    /// `[stages.locate] method = "raw_contour"`: windows (relative changes) from the raw frames.
    raw_change: Option<RawChange>,
    track: Option<Track>,
    force: Option<Force>,
    /// A force model on the changes (`[stages.force] model = "….json"` of `ridge`): raw frames
    /// in.
    change_force: Option<ChangeForce>,
    /// Whether the stored baseline's mismatch was reported.
    tare_warned: bool,
    servo: Option<Servo>,
    dos: Option<DosClassifier>,
    raw: Vec<TaxelFrame>,
    normalised: Vec<TaxelFrame>,
    smoothed: Vec<TaxelFrame>,
    batches: Vec<EventBatch>,
    windows: Vec<WindowAggregate>,
    surfaces: Vec<Surface>,
    contours: Vec<ContourFrame>,
    points: Vec<TrackPoint>,
    forces: Vec<ForceEstimate>,
    commands: Vec<ServoCommand>,
    decisions: Vec<DosDecision>,
    frames_in: u64,
    /// The last frame's time, and how many frames had the time of the frame before them.
    last_time: Option<gradtac_stream::Timestamp>,
    same_time: u64,
}

/// Number of taps.
const TAPS: usize = Tap::ALL.len();

fn feed<S>(stage: &mut S, input: &mut Vec<S::In>, out: &mut Vec<S::Out>, finish: bool) -> Result<(), Error>
where
    S: Stage,
    S::Error: Into<Error>,
{
    for x in input.drain(..) {
        stage.push(x, out).map_err(Into::into)?;
    }
    if finish {
        stage.finish(out).map_err(Into::into)?;
    }
    Ok(())
}

/// [`feed`] from an input that stages after this one read too (`shared`): its items are
/// cloned into the stage and stay for them; otherwise they move, as in [`feed`].
fn feed_from<S>(
    stage: &mut S,
    input: &mut Vec<S::In>,
    shared: bool,
    out: &mut Vec<S::Out>,
    finish: bool,
) -> Result<(), Error>
where
    S: Stage,
    S::In: Clone,
    S::Error: Into<Error>,
{
    if !shared {
        return feed(stage, input, out, finish);
    }
    for x in input.iter() {
        stage.push(x.clone(), out).map_err(Into::into)?;
    }
    if finish {
        stage.finish(out).map_err(Into::into)?;
    }
    Ok(())
}

/// The change detector's effective settings, for `explain`.
fn describe_detector(l: &gradtac_stages::locate::LocateConfig) -> String {
    let base = match &l.baseline {
        Some(p) => format!("stored baseline {} (contact from the first frame)", p.display()),
        None => format!("calibrate {} frames", l.calibrate_frames),
    };
    format!(
        "{base}, mean of {} frames, floor {} σ, contact {} σ, baseline follows drift τ = {} s",
        l.window_frames, l.floor_sigmas, l.contact_sigmas, l.follow_s
    )
}

/// The event settings in effect: under `[stages.locate] method = "events"` with
/// `event_tau_sigmas > 0` the threshold is measured from each taxel's noise
/// ([`Threshold::Noise`]) over the locate calibration's frames. `st` is read resolved
/// ([`StageSettings::resolved`]), as every builder reads it.
pub fn effective_events(st: &StageSettings) -> gradtac_stages::events::EventsConfig {
    let st = &st.resolved();
    let l = &st.locate;
    match l.method {
        LocateMethod::Events if l.event_tau_sigmas > 0.0 => gradtac_stages::events::EventsConfig {
            threshold: Threshold::Noise { noise_sigmas: l.event_tau_sigmas, calibrate_frames: l.calibrate_frames },
            ..st.events.clone()
        },
        _ => st.events.clone(),
    }
}

/// The contour settings in effect: `raw_contour` surfaces are relative changes that are 0
/// without a contact (the change detector decides), so their contour takes any peak. `st` is
/// read resolved ([`StageSettings::resolved`]).
pub fn effective_contour(st: &StageSettings) -> ContourConfig {
    let st = &st.resolved();
    match st.locate.method {
        LocateMethod::RawContour => ContourConfig { min_peak: 0.0, ..st.contour.clone() },
        _ => st.contour.clone(),
    }
}

/// The Savitzky–Golay stage a scene builds: rate-aware when the source has a rate.
fn savgol_stage(st: &StageSettings, n: usize, rate_hz: Option<f64>) -> Result<SavGol, gradtac_stages::Error> {
    match rate_hz {
        Some(r) => SavGol::try_with_rate(n, st.savgol.clone(), r),
        None => SavGol::try_new(n, st.savgol.clone()),
    }
}

/// The stages a `[stages.locate] method = "events"` scene runs for one sensor up to its
/// track, composed into one [`Stage`]: [`event_contour_stages`] → track. Every stage is built
/// from `st` exactly as [`SensorChain::build`] builds it (a test checks that the track points
/// equal a scene run's), so code that scores or benchmarks "what a scene runs" calls this
/// rather than composing the stages by hand. `rate_hz` is the source's rate (`None`:
/// Savitzky–Golay settings in frames).
///
/// The event chain's keys are read from [`StageSettings::resolved`]: settings built in code
/// with `locate.method = Events` (and any `event_chain`) get the values a scene with that
/// method and chain parses to. Fails on invalid settings, and when `st.locate.method` is not
/// `events` (the other methods locate contact through other stages; a scene runs those).
pub fn event_track_stages(
    st: &StageSettings,
    layout: &gradtac_stream::Layout,
    rate_hz: Option<f64>,
) -> Result<impl Stage<In = TaxelFrame, Out = TrackPoint, Error = gradtac_stream::Error>, Error> {
    use gradtac_stream::StageExt;
    Ok(event_contour_stages(st, layout, rate_hz)?.then(Track::try_new(&st.track)?))
}

/// [`event_track_stages`] without the track: normalise (bypassed under the default
/// `event_chain`) → Savitzky–Golay → events (threshold from [`effective_events`]) → window →
/// surface and maximal contour (fused, as a scene fuses them when no output taps the surface;
/// contour settings from [`effective_contour`]): raw frames in, contours out. The same
/// settings, resolution and errors as [`event_track_stages`].
pub fn event_contour_stages(
    st: &StageSettings,
    layout: &gradtac_stream::Layout,
    rate_hz: Option<f64>,
) -> Result<impl Stage<In = TaxelFrame, Out = ContourFrame, Error = gradtac_stream::Error>, Error> {
    use gradtac_stream::StageExt;
    if st.locate.method != LocateMethod::Events {
        return Err(Error::Scene {
            path: std::path::PathBuf::from("<event_track_stages>"),
            reason: format!(
                "the event stages locate contact under [stages.locate] method = \"events\", not {:?}",
                st.locate.method.name()
            ),
        });
    }
    let st = &st.resolved();
    let n = layout.len();
    Ok(Normalise::try_new(n, &st.normalise)?
        .then(savgol_stage(st, n, rate_hz)?)
        .then(Events::try_new(n, effective_events(st))?)
        .then(Window::try_new(&st.window)?)
        .then(SurfaceContour::try_new(&st.surface, &effective_contour(st), layout)?))
}

impl SensorChain {
    /// Build the stages `plan` says the sensor runs, validating their settings.
    pub fn build(scene: &Scene, plan: &SensorPlan) -> Result<SensorChain, Error> {
        let st = &scene.stages.resolved();
        let n = plan.layout.len();
        let runs = |t| plan.runs(t);
        let method = st.locate.method;
        let rate = scene.sensors[plan.index].source.rate_hz();
        let mut taps: [Vec<usize>; TAPS] = std::array::from_fn(|_| Vec::new());
        for &i in &plan.outputs {
            if let Some(t) = Tap::parse(&scene.outputs[i].tap) {
                taps[t as usize].push(i);
            }
        }
        let contour = runs(Tap::Contour) && !matches!(method, LocateMethod::Centroid | LocateMethod::Fit);
        let tare = scene.loaded.tare.as_ref();
        let scene_err = |reason: String| Error::Scene { path: scene.origin.clone(), reason };
        if let Some(t) = tare.filter(|t| t.taxels != n) {
            return Err(scene_err(format!(
                "[stages.locate] baseline {}: measured on {} taxels, the sensor's layout {} has {n}",
                st.locate.baseline.as_deref().unwrap_or(std::path::Path::new("")).display(),
                t.taxels,
                plan.layout.name()
            )));
        }
        let (force, change_force) = match (runs(Tap::Force), &st.force) {
            (false, _) => (None, None),
            (true, None) => {
                return Err(scene_err(
                    "the force tap needs a calibrated model: [stages.force] model = \"force.json\" (write one with \
                     gradtac calibrate force SCENE --force-column NAME --out force.json) or an inline area curve \
                     model = { method = …, … }"
                        .into(),
                ))
            }
            (true, Some(ForceSettings { model: ForceModelSpec::Inline(m), min_area_mm2 })) => {
                (Some(Force::try_new(&ForceConfig { model: m.clone(), min_area_mm2: *min_area_mm2 })?), None)
            }
            (true, Some(ForceSettings { model: ForceModelSpec::File(p), min_area_mm2 })) => {
                let file = scene.loaded.force.as_ref().expect("read by Scene::load");
                file.check_layout(&plan.layout)
                    .map_err(|e| scene_err(format!("[stages.force] model {}: {e}", p.display())))?;
                match &file.model {
                    CalibratedForce::Area { curve } => (
                        Some(Force::try_new(&ForceConfig { model: curve.clone(), min_area_mm2: *min_area_mm2 })?),
                        None,
                    ),
                    CalibratedForce::Amplitude { curve } => {
                        if method != LocateMethod::Fit {
                            return Err(scene_err(format!(
                                "[stages.force] model {}: an amplitude model reads the contact fit; set \
                                     [stages.locate] method = \"fit\"",
                                p.display()
                            )));
                        }
                        let cfg = ForceConfig { model: curve.clone(), min_area_mm2: *min_area_mm2 };
                        (Some(Force::try_new(&cfg)?.on_fit_amplitude()), None)
                    }
                    _ => {
                        // the layout's positions: the drift model's shape test (`drift_shape`)
                        let mut f = ChangeForce::try_new(file, &st.locate)?.with_positions(plan.layout.positions())?;
                        if let Some(t) = tare {
                            f = f.with_tare(t)?;
                        }
                        (None, Some(f))
                    }
                }
            }
        };
        let fuse = contour && taps[Tap::Surface as usize].is_empty();
        Ok(SensorChain {
            sensor: SensorId::new(&plan.name),
            taps,
            normalise: runs(Tap::Normalise).then(|| Normalise::try_new(n, &st.normalise)).transpose()?,
            savgol: runs(Tap::Savgol).then(|| savgol_stage(st, n, rate)).transpose()?,
            events: runs(Tap::Events).then(|| Events::try_new(n, effective_events(st))).transpose()?,
            window: (runs(Tap::Window) && method != LocateMethod::RawContour)
                .then(|| Window::try_new(&st.window))
                .transpose()?,
            raw_change: (runs(Tap::Window) && method == LocateMethod::RawContour)
                .then(|| {
                    RawChange::try_new(n, &st.locate).and_then(|r| match tare {
                        Some(t) => r.with_tare(t),
                        None => Ok(r),
                    })
                })
                .transpose()?,
            surface: (runs(Tap::Surface) && !fuse)
                .then(|| Interpolate::try_new(&st.surface, &plan.layout))
                .transpose()?,
            contour: (contour && !fuse).then(|| Contour::try_new(&effective_contour(st))).transpose()?,
            fused: fuse
                .then(|| SurfaceContour::try_new(&st.surface, &effective_contour(st), &plan.layout))
                .transpose()?,
            centroid: (runs(Tap::Contour) && method == LocateMethod::Centroid)
                .then(|| {
                    Centroid::try_new(&st.locate, &plan.layout).and_then(|c| match tare {
                        Some(t) => c.with_tare(t),
                        None => Ok(c),
                    })
                })
                .transpose()?,
            fit: (runs(Tap::Contour) && method == LocateMethod::Fit)
                .then(|| {
                    Fit::try_new(&st.locate, &plan.layout).and_then(|c| match tare {
                        Some(t) => c.with_tare(t),
                        None => Ok(c),
                    })
                })
                .transpose()?,
            track: runs(Tap::Track).then(|| Track::try_new(&st.track)).transpose()?,
            force,
            change_force,
            tare_warned: false,
            servo: runs(Tap::Servo).then(|| Servo::try_new(&st.servo, &plan.layout)).transpose()?,
            dos: match (runs(Tap::Dos), &st.dos) {
                (false, _) => None,
                (true, Some(d)) => {
                    let model = crate::calibrate::read_model(&scene.resolve(&d.model))?;
                    let c = DosClassifier::try_new(model, &plan.layout, d.decision_frames)?;
                    Some(match d.hop_frames {
                        Some(hop) if d.early => c.with_hop(hop)?.with_early_decisions()?,
                        Some(hop) => c.with_hop(hop)?,
                        None if d.early => {
                            return Err(Error::Scene {
                                path: scene.base_dir.clone(),
                                reason: "[stages.dos] early = true needs hop_frames (sliding decisions)".into(),
                            })
                        }
                        None => c,
                    })
                }
                (true, None) => {
                    return Err(Error::Scene {
                        path: scene.origin.clone(),
                        reason: "the dos tap needs [stages.dos] model = \"….json\" (write one with gradtac calibrate)"
                            .into(),
                    })
                }
            },
            raw: Vec::new(),
            normalised: Vec::new(),
            smoothed: Vec::new(),
            batches: Vec::new(),
            windows: Vec::new(),
            surfaces: Vec::new(),
            contours: Vec::new(),
            points: Vec::new(),
            forces: Vec::new(),
            commands: Vec::new(),
            decisions: Vec::new(),
            frames_in: 0,
            last_time: None,
            same_time: 0,
        })
    }

    /// The sensor.
    pub fn sensor(&self) -> &SensorId {
        &self.sensor
    }

    /// Frames pushed so far.
    pub fn frames_in(&self) -> u64 {
        self.frames_in
    }

    /// Steady-state delay of the whole chain: of its slowest path (the event front end, or the
    /// contact-location path of `centroid` / `raw_contour`, which skip it).
    pub fn delay(&self) -> Delay {
        let d = |s: Option<Delay>| s.unwrap_or(Delay::ZERO);
        let spatial = d(self.surface.as_ref().map(Stage::delay))
            + d(self.contour.as_ref().map(Stage::delay))
            + d(self.fused.as_ref().map(Stage::delay))
            + d(self.track.as_ref().map(Stage::delay));
        let events = d(self.normalise.as_ref().map(Stage::delay))
            + d(self.savgol.as_ref().map(Stage::delay))
            + d(self.events.as_ref().map(Stage::delay))
            + d(self.window.as_ref().map(Stage::delay))
            + if self.window.is_some() { spatial } else { Delay::ZERO };
        let located = match (&self.centroid, &self.raw_change) {
            (Some(c), _) => c.delay() + d(self.track.as_ref().map(Stage::delay)),
            (None, _) if self.fit.is_some() => {
                d(self.fit.as_ref().map(Stage::delay)) + d(self.track.as_ref().map(Stage::delay))
            }
            (None, Some(r)) => r.delay() + spatial,
            (None, None) => Delay::ZERO,
        };
        // frames first: the time part only comes from duration windows
        if (located.frames, located.nanos) > (events.frames, events.nanos) {
            located
        } else {
            events
        }
    }

    /// The track points the last [`process`](Self::process) produced (for the cross-sensor
    /// slip stage); empty unless the chain runs to `track`.
    pub fn take_points(&mut self) -> std::vec::Drain<'_, TrackPoint> {
        self.points.drain(..)
    }

    /// Frames held once at start-up (normalisation calibration).
    pub fn startup_frames(&self) -> usize {
        self.normalise.as_ref().map_or(0, Normalise::startup_frames)
    }

    /// One line on what a stage does with its settings (`gradtac explain`); `st` is read
    /// resolved ([`StageSettings::resolved`]), as [`SensorChain::build`] reads it.
    pub fn describe(&self, tap: Tap, st: &StageSettings) -> String {
        let st = &st.resolved();
        match tap {
            Tap::Source => "read frames".into(),
            Tap::Normalise if st.normalise.bypass => "bypassed: raw values pass through".into(),
            Tap::Normalise => match st.normalise.bounds(0) {
                Ok(Bounds::Calibrate { frames }) => format!("min–max, bounds from the first {frames} frames"),
                Ok(Bounds::Given { .. }) => "min–max, given bounds".into(),
                Ok(Bounds::Running) => "min–max, running bounds".into(),
                Err(e) => e.to_string(),
            },
            Tap::Savgol => self.savgol.as_ref().map_or(String::new(), |s| {
                let c = s.config();
                format!(
                    "window {}, order {}, deriv {}, {:?} (delay {} frames)",
                    c.window,
                    c.polyorder,
                    c.deriv,
                    c.mode,
                    s.delay_frames()
                )
                .to_lowercase()
            }),
            Tap::Events => self.events.as_ref().map_or(String::new(), |e| {
                let c = e.config();
                let tau = match &c.threshold {
                    Threshold::Uniform(t) => format!("τ = {t}"),
                    Threshold::PerTaxel(v) => format!("τ per taxel {v:?}"),
                    Threshold::Noise { noise_sigmas, calibrate_frames } => format!(
                        "τ = {noise_sigmas} σ of each taxel's ln-value noise, measured over the first {calibrate_frames} frames (no events during them)"
                    ),
                };
                let polarity = match c.polarity {
                    gradtac_stages::events::Polarity::Both => "polarity both (+1 up, −1 down)",
                    gradtac_stages::events::Polarity::Press => {
                        "polarity press (only crossings away from each taxel's baseline, as +1; releases dropped)"
                    }
                    gradtac_stages::events::Polarity::PressRelease => {
                        "polarity press_release (+1 away from each taxel's baseline, −1 back toward it)"
                    }
                };
                format!(
                    "log-change, {tau}, {polarity}, cap {}/taxel/frame (event chain {}: the defaults of the \
                     polarity, window kind, grid and contour keys the scene leaves unset)",
                    c.max_events_per_step,
                    st.locate.event_chain.name()
                )
            }),
            Tap::Window if self.raw_change.is_some() => {
                format!("raw change |x − x₀|/x₀ ({})", describe_detector(&st.locate))
            }
            Tap::Contour if self.fit.is_some() => {
                let l = &st.locate;
                let speed = if l.max_speed_mm_s > 0.0 {
                    format!("moves at most {} mm/s", l.max_speed_mm_s)
                } else {
                    "no speed bound".to_string()
                };
                let prior = if l.fit_motion_prior > 0.0 && l.max_speed_mm_s > 0.0 {
                    format!(
                        "motion prior {} × the speed bound, innovations gated at {} σ",
                        l.fit_motion_prior, l.fit_innovation_sigmas
                    )
                } else {
                    "no motion prior".to_string()
                };
                let gains = if l.fit_gain_rate <= 0.0 {
                    "unit gains".to_string()
                } else if l.fit_gain_keys > 0 {
                    format!(
                        "gains self-calibrated over up to {} key frames {} mm apart (prior {}, zero mean log-gain and trend)",
                        l.fit_gain_keys, l.fit_gain_spacing_mm, l.fit_gain_prior
                    )
                } else {
                    format!("gains learned at rate {}", l.fit_gain_rate)
                };
                let lag = if l.fit_lag_estimate {
                    format!(
                        "fluid lag estimated online from each press onset (prior {} nats per 10 ms toward none, at most {} s) \
                         and undone on the electrodes before the fit",
                        l.fit_lag_prior, l.fit_lag_max_s
                    )
                } else {
                    format!(
                        "lag lead {} s along the velocity of the last {} positions",
                        l.fit_lead_s, l.fit_velocity_frames
                    )
                };
                let shape = format!(
                    "kernel {}, far lobe 2.5 × the spread{}",
                    if l.fit_shape_rate > 0.0 {
                        format!("shape exponent q (2 Gaussian … 1 exponential) learned per sensor at rate {}", l.fit_shape_rate)
                    } else {
                        "Gaussian lobes (fit_shape_rate 0)".to_string()
                    },
                    match (l.fit_fold_lobe && !l.fit_signed, l.fit_fold_guard_mm > 0.0) {
                        (true, true) => format!(
                            ", folded to |K| (fit_fold_lobe) only as a refinement of the unfolded fit within {} mm \
                             (fit_fold_guard_mm)",
                            l.fit_fold_guard_mm
                        ),
                        (true, false) => ", folded to |K| (fit_fold_lobe)".to_string(),
                        _ => String::new(),
                    }
                );
                let changes = if l.fit_signed {
                    "the signed changes (fit_signed)".to_string()
                } else if l.fit_polarity_votes > 0 {
                    format!(
                        "each electrode's polarity learned from {} net votes under a clean fit's core, the far ring's \
                         sign kept (fit_polarity_votes)",
                        l.fit_polarity_votes
                    )
                } else {
                    "the changes' magnitudes |Δ| (fit_polarity_votes 0)".to_string()
                };
                let learned = if l.fit_learned_correction {
                    format!(
                        "learned bias correction on (fit_learned_correction: ridge on {} random features of the normalised \
                         changes and residual pattern, trained on simulated tuning physics only, ≤ {} mm; BioTac SP layout only)",
                        gradtac_stages::fit_learned::RANDOM,
                        gradtac_stages::fit_learned::MAX_CORRECTION_MM
                    )
                } else {
                    "no learned bias correction (fit_learned_correction false)".to_string()
                };
                format!(
                    "model fit (preset {}): robust Levenberg–Marquardt, ≤ {} iterations, on the 3-D electrode cores when the \
                     layout is the BioTac SP; spread, amplitude, far lobe; fits {changes}; {shape}; {gains}; {learned}; model error {} of the \
                     largest change; electrodes at the rails [{}, {}] left out; reports residual and σ (mm) per point; \
                     {lag}; {prior}; position memory {} frames, {speed} ({})",
                    l.preset.name(),
                    l.fit_iterations,
                    l.fit_model_error,
                    l.fit_rails[0],
                    l.fit_rails[1],
                    l.smooth_frames,
                    describe_detector(l)
                )
            }
            Tap::Contour if self.centroid.is_some() => {
                let l = &st.locate;
                let speed = if l.max_speed_mm_s > 0.0 {
                    format!("moves at most {} mm/s", l.max_speed_mm_s)
                } else {
                    "no speed bound".to_string()
                };
                format!(
                    "taxel centroid (preset {}), weights ({} change)^{}{}, position memory {} frames, {speed} ({})",
                    l.preset.name(),
                    l.weights.name(),
                    l.power,
                    l.top_k.map_or(" of all taxels".to_string(), |k| format!(" of the top {k}")),
                    l.smooth_frames,
                    describe_detector(l)
                )
            }
            Tap::Window => {
                let c = &st.window;
                if c.kind == gradtac_stages::window::WindowKind::Cumulative {
                    return format!(
                        "cumulative (every event since the start: the level now), step {}, {:?}",
                        c.step, c.aggregate
                    )
                    .to_lowercase();
                }
                let size = match (c.frames, c.duration_ms) {
                    (_, Some(ms)) => format!("{ms} ms"),
                    (Some(f), None) => format!("{f} frames"),
                    (None, None) => "10 frames (default)".into(),
                };
                format!("{:?} {size}, step {}, {:?}", c.kind, c.step, c.aggregate).to_lowercase()
            }
            Tap::Surface => {
                let c = &st.surface;
                let (nx, ny) = (c.grid.nx, c.grid.ny.unwrap_or(c.grid.nx));
                format!("{:?} on {nx}×{ny} grid, outside hull: {:?}", c.method, c.outside).to_lowercase()
            }
            Tap::Contour => {
                let c = &effective_contour(st);
                let levels = match &c.levels {
                    Levels::Count(k) => format!("{k} levels"),
                    Levels::Explicit(v) => format!("{} given levels", v.len()),
                };
                format!(
                    "maximal contour ({} method), {levels}, min peak {}, min area {} mm²",
                    st.locate.method.name(),
                    c.min_peak,
                    c.min_area_mm2
                )
            }
            Tap::Track => {
                let t = &st.track;
                let gate = match t.max_jump_mm {
                    Some(j) => {
                        format!("gate jumps > {j} mm ({:?}, restart after {} gated frames)", t.gate, t.max_gated_frames)
                            .to_lowercase()
                    }
                    None => "no jump gating".into(),
                };
                format!("{gate}, release after {} frames, velocity α {}", t.release_frames, t.velocity_alpha)
            }
            Tap::Force if self.change_force.is_some() => {
                let f = self.change_force.as_ref().expect("checked");
                let placed;
                let what = match f.model() {
                    gradtac_stages::force_model::CalibratedForce::Forward {
                        exponent,
                        spread,
                        width_mm,
                        shape,
                        lobe,
                        lag_s,
                        gain_rel_sd,
                        ..
                    } => {
                        let weights = match gain_rel_sd {
                            Some(r) => format!(
                                "each taxel's residual weighted by its gain's calibration doubt (1/√(s₀² + (rᵢΔᵢ)²), \
                                 s₀ = {} counts, rᵢ up to {:.3})",
                                gradtac_stages::force_ident::INVERT_NOISE_COUNTS,
                                r.iter().copied().fold(0.0, f64::max)
                            ),
                            None => "residuals unweighted (a version-4 file: no gain doubts)".into(),
                        };
                        placed = format!(
                            "the identified forward model (force exponent {exponent:.3}, spread exponent {spread:.3}, \
                             width {width_mm:.2} mm, profile q {shape:.2}, lobe {lobe:.2}, per-taxel gains, fluid lag \
                             {lag_s} s inverted; {weights}) solved for place and force per frame from the"
                        );
                        placed.as_str()
                    }
                    gradtac_stages::force_model::CalibratedForce::Placed { width_mm, .. } => {
                        placed = format!(
                            "a power law in the total change ÷ the layout's response at the contact (w = {width_mm} mm) \
                             of the"
                        );
                        placed.as_str()
                    }
                    gradtac_stages::force_model::CalibratedForce::Total { .. } => "a power law in the total change of the",
                    _ => "ridge on the",
                };
                let d = f.detector().drift_model().copied().unwrap_or_default();
                format!(
                    "{what} {} signed changes (model file), no force without contact, every baseline follows \
                     drift while untouched ({}; drift model: settle {} s when steady {} σ over {} s, slope memory {} s \
                     prior {} s³, release below {} of the contact's peak total change{}; hold beyond {} σ: baseline \
                     frozen{}, following {} s outside excursions, a level steady {} s is the new rest)",
                    f.detector().change().len(),
                    describe_detector(&st.locate),
                    d.settle_s,
                    d.steady_sigmas,
                    d.steady_s,
                    d.slope_memory_s,
                    d.slope_prior_s3,
                    d.release_fraction,
                    {
                        let mut more = String::new();
                        if d.release_sigmas > 0.0 {
                            more += &format!(" or, still, below {} Σσ", d.release_sigmas);
                        }
                        if d.release_excess > 0.0 {
                            more += &format!(
                                " or, flat {} s ({} within {} Σσ), at most {} of the peak above the untouched floor",
                                if d.release_flat_s > 0.0 { d.release_flat_s } else { d.steady_s },
                                if d.release_flat_range { "range" } else { "first to last" },
                                d.release_flat_sigmas,
                                d.release_excess
                            );
                        }
                        more += match d.return_anchors {
                            ReturnAnchors::Keep => "; the slope's anchors kept at a return",
                            ReturnAnchors::RestartAtShapeReturn => {
                                "; the slope's anchors restarted at a return by the shape alone"
                            }
                            ReturnAnchors::ShiftAtShapeReturn => {
                                "; the slope's anchors shifted to the new level at a return by the shape alone"
                            }
                            ReturnAnchors::RestartAtAnyReturn => "; the slope's anchors restarted at every return",
                            ReturnAnchors::ShiftAtAnyReturn => {
                                "; the slope's anchors shifted to the new level at every return"
                            }
                        };
                        if d.drift_shape > 0.0 {
                            // the rise test: a clause inside the parentheses (the anchors shifted,
                            // perhaps undone) or, when it blocks, one after them
                            let rose = format!(
                                "its total change {} s before was below {} of its own",
                                d.drift_shape_rise_s, DRIFT_SHAPE_RISE_FRACTION
                            );
                            let rise = match (d.drift_shape_rise_s > 0.0, d.drift_shape_rise) {
                                (false, _) => (String::new(), String::new()),
                                (true, RiseGuard::Block) => (
                                    String::new(),
                                    format!(
                                        "; not while {rose} (a press's rise and hold), nor in the first {} s",
                                        d.drift_shape_rise_s
                                    ),
                                ),
                                (true, guard) => (
                                    format!(
                                        ", or shifted to the new level when {rose} (a press's rise and hold taken for \
                                         drift does not teach the slope the press){}",
                                        if guard == RiseGuard::ShiftAnchorsUndo {
                                            format!(
                                                ", and undone when the sensor comes back to the level before it \
                                                 within {} s",
                                                d.undo_window_s()
                                            )
                                        } else {
                                            String::new()
                                        }
                                    ),
                                    String::new(),
                                ),
                            };
                            more += &format!(
                                "; a steady excursion that one smooth bump explains less than {} of ({} fit{}) returns \
                                 (drift without a press's shape; the slope's anchors kept{}){}",
                                d.drift_shape,
                                match d.drift_shape_fit {
                                    ShapeFit::Signed => "signed",
                                    ShapeFit::Magnitude => "magnitude",
                                },
                                if f.detector().positions().is_some() { "" } else { "; off: no layout positions" },
                                rise.0,
                                rise.1,
                            );
                        }
                        if d.quiet_taxel_s > 0.0 {
                            more += &format!(
                                "; a taxel within {} σ follows at {} s, also during an excursion",
                                d.hold_sigmas, d.quiet_taxel_s
                            );
                        }
                        more
                    },
                    d.hold_sigmas,
                    match (d.hold_contact, d.hold_start_sigmas > 0.0) {
                        (false, _) => String::new(),
                        (true, false) => " and a contact until it returns".to_string(),
                        (true, true) => format!(
                            " and a contact until it returns, started only beyond {} σ",
                            d.hold_start_sigmas
                        ),
                    },
                    d.quiet_s,
                    d.stale_s
                )
            }
            Tap::Force => st.force.as_ref().map_or("no model".into(), |f| {
                let curve = match &f.model {
                    ForceModelSpec::Inline(m) => Some(m),
                    ForceModelSpec::File(_) => None,
                };
                let Some(model) = self.force.as_ref().map(|f| f.model()).or(curve) else { return String::new() };
                let m = match model {
                    ForceModel::Linear { .. } => "linear",
                    ForceModel::PowerLaw { .. } => "power law",
                    ForceModel::Exponential { .. } => "exponential",
                    ForceModel::Isotonic { .. } => "isotonic",
                };
                format!("contour area → N, {m} model")
            }),
            Tap::Servo => format!("offset from centre, gain {}, deadband {} mm", st.servo.gain, st.servo.deadband_mm),
            Tap::Slip => st.slip.describe(),
            Tap::Dos => match (&self.dos, &st.dos) {
                (Some(c), Some(d)) => format!(
                    "slip direction, {} classes, {} parameters, {}, {}",
                    c.model().classes.len(),
                    c.model().parameter_count(),
                    match (&c.model().window, &c.model().trees) {
                        (Some(w), _) => format!(
                            "Student t + window net ({}-frame windows, {} hidden), weight a = {}",
                            w.net.config.frames, w.net.config.hidden, w.weight
                        ),
                        (None, Some(t)) => format!(
                            "Student t + gradient-boosted trees ({}-frame windows, {} inputs{}, {} trees), weight a = {}",
                            t.trees.inputs().window.frames,
                            t.trees.input_count(),
                            {
                                let i = t.trees.inputs();
                                let groups: Vec<&str> = [
                                    (i.turn && !i.dilation, "rotation-sense"),
                                    (i.dilation, "rotation-sense (fitted with a dilation), dilation"),
                                    (i.energy, "change-energy"),
                                ]
                                .into_iter()
                                .filter_map(|(on, name)| on.then_some(name))
                                .collect();
                                match groups.split_last() {
                                    None => String::new(),
                                    Some((last, [])) => format!(" with the {last} ones"),
                                    Some((last, rest)) => format!(" with the {} and {last} ones", rest.join(", ")),
                                }
                            },
                            t.trees.trees().len(),
                            t.weight
                        ),
                        (None, None) => "Student t alone (no window part)".to_string(),
                    },
                    match (d.decision_frames, d.hop_frames) {
                        (None, _) => "one decision per recording".to_string(),
                        (Some(n), None) => format!("a decision per {n} frames"),
                        (Some(n), Some(h)) if d.early => {
                            format!("a decision every {h} frames over the last {n} (early: over all frames until {n})")
                        }
                        (Some(n), Some(h)) => format!("a decision every {h} frames over the last {n}"),
                    } + if d.hop_frames.is_some() && c.model().trees.is_some() {
                        " (the trees' windows counted from the contact, each computed once)"
                    } else {
                        ""
                    }
                ),
                _ => String::new(),
            },
        }
    }

    /// Warn once when a stored baseline stopped fitting the sensor.
    fn warn_tare_mismatch(&mut self) {
        if self.tare_warned {
            return;
        }
        let detectors = [
            self.centroid.as_ref().map(Centroid::detector),
            self.raw_change.as_ref().map(RawChange::detector),
            self.change_force.as_ref().map(ChangeForce::detector),
            self.fit.as_ref().map(Fit::detector),
        ];
        if let Some(m) = detectors.into_iter().flatten().find_map(|d| d.tare_mismatch()) {
            tracing::warn!(
                sensor = %self.sensor,
                frame = m.seq,
                median_sigmas = m.median_sigmas,
                "the stored baseline ([stages.locate] baseline) no longer fits the sensor: most taxels sit {:.0} σ \
                 from it (another sensor, or a temperature shift?); contacts are measured against it all the \
                 same — measure a new one with gradtac calibrate baseline",
                m.median_sigmas
            );
            self.tare_warned = true;
        }
    }

    /// The event front end: normalise → Savitzky–Golay → events → window, from `self.raw`
    /// (consumed) to `self.windows` (appended to).
    fn process_events<W: RecordWriter>(&mut self, finish: bool, sinks: &mut W) -> Result<(), Error> {
        let Some(st) = &mut self.normalise else {
            self.raw.clear();
            return Ok(());
        };
        feed(st, &mut self.raw, &mut self.normalised, finish)?;
        sinks.write_all(&self.taps[Tap::Normalise as usize], &self.normalised)?;
        let Some(st) = &mut self.savgol else {
            self.normalised.clear();
            return Ok(());
        };
        feed(st, &mut self.normalised, &mut self.smoothed, finish)?;
        sinks.write_all(&self.taps[Tap::Savgol as usize], &self.smoothed)?;
        let Some(st) = &mut self.events else {
            self.smoothed.clear();
            return Ok(());
        };
        feed(st, &mut self.smoothed, &mut self.batches, finish)?;
        sinks.write_all(&self.taps[Tap::Events as usize], &self.batches)?;
        match &mut self.window {
            Some(st) => feed(st, &mut self.batches, &mut self.windows, finish),
            None => {
                self.batches.clear();
                Ok(())
            }
        }
    }

    /// Push one frame (or, with `finish`, flush) through every built stage, writing each
    /// stage's outputs to the outputs that tap it.
    pub fn process<W: RecordWriter>(
        &mut self,
        frame: Option<TaxelFrame>,
        finish: bool,
        sinks: &mut W,
    ) -> Result<(), Error> {
        if let Some(f) = &frame {
            self.frames_in += 1;
            self.same_time += u64::from(self.last_time == Some(f.time));
            self.last_time = Some(f.time);
        }
        if finish && self.same_time > 0 {
            // once per sensor, at the end, with the count (see docs/safety.md)
            tracing::warn!(
                sensor = %self.sensor,
                frames = self.same_time,
                "frames share their timestamp with the frame before them (duplicated rows?); each is \
                 processed as a sample of its own, which multiplies events and weighs those instants more"
            );
            self.same_time = 0;
        }
        self.points.clear();
        self.raw.extend(frame);
        sinks.write_all(&self.taps[Tap::Source as usize], &self.raw)?;
        sinks.view_source(&self.taps[Tap::Source as usize], &self.raw);
        // the raw frames move into the last stage that reads them (the contact-location front
        // ends, then the normalisation), and are copied for those before it
        if let Some(d) = &mut self.dos {
            let shared =
                self.centroid.is_some() || self.fit.is_some() || self.raw_change.is_some() || self.normalise.is_some();
            feed_from(d, &mut self.raw, shared, &mut self.decisions, finish)?;
            sinks.write_all(&self.taps[Tap::Dos as usize], &self.decisions)?;
            self.decisions.clear();
        }
        if let Some(f) = &mut self.change_force {
            let shared =
                self.centroid.is_some() || self.fit.is_some() || self.raw_change.is_some() || self.normalise.is_some();
            feed_from(f, &mut self.raw, shared, &mut self.forces, finish)?;
            sinks.write_all(&self.taps[Tap::Force as usize], &self.forces)?;
            self.forces.clear();
        }
        if let Some(c) = &mut self.centroid {
            let shared = self.fit.is_some() || self.raw_change.is_some() || self.normalise.is_some();
            feed_from(c, &mut self.raw, shared, &mut self.contours, finish)?;
        }
        if let Some(c) = &mut self.fit {
            let shared = self.raw_change.is_some() || self.normalise.is_some();
            feed_from(c, &mut self.raw, shared, &mut self.contours, finish)?;
        }
        if let Some(r) = &mut self.raw_change {
            feed_from(r, &mut self.raw, self.normalise.is_some(), &mut self.windows, finish)?;
        }
        self.warn_tare_mismatch();
        self.process_events(finish, sinks)?;
        sinks.write_all(&self.taps[Tap::Window as usize], &self.windows)?;
        if let Some(st) = &mut self.fused {
            feed(st, &mut self.windows, &mut self.contours, finish)?;
        }
        match &mut self.surface {
            Some(st) => {
                feed(st, &mut self.windows, &mut self.surfaces, finish)?;
                sinks.write_all(&self.taps[Tap::Surface as usize], &self.surfaces)?;
            }
            None => self.windows.clear(),
        }
        match &mut self.contour {
            Some(st) => feed(st, &mut self.surfaces, &mut self.contours, finish)?,
            None => self.surfaces.clear(),
        }
        sinks.write_all(&self.taps[Tap::Contour as usize], &self.contours)?;
        if let Some(f) = &mut self.force {
            feed_from(f, &mut self.contours, self.track.is_some(), &mut self.forces, finish)?;
            sinks.write_all(&self.taps[Tap::Force as usize], &self.forces)?;
            self.forces.clear();
        }
        let Some(st) = &mut self.track else {
            self.contours.clear();
            return Ok(());
        };
        feed(st, &mut self.contours, &mut self.points, finish)?;
        sinks.write_all(&self.taps[Tap::Track as usize], &self.points)?;
        if let Some(sv) = &mut self.servo {
            // the points stay for the runner's slip stage
            feed_from(sv, &mut self.points, true, &mut self.commands, finish)?;
            sinks.write_all(&self.taps[Tap::Servo as usize], &self.commands)?;
            self.commands.clear();
        }
        // the points stay for the runner's slip stage (take_points), cleared on the next call
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use arrow_array::{Array, Float64Array, RecordBatch};
    use gradtac_stream::StageExt;

    fn xs(batches: &[RecordBatch]) -> Vec<(f64, f64)> {
        let col = |b: &RecordBatch, name: &str| {
            let a = b.column_by_name(name).unwrap().as_any().downcast_ref::<Float64Array>().unwrap().clone();
            (0..a.len()).map(move |i| if a.is_null(i) { f64::NAN } else { a.value(i) }).collect::<Vec<_>>()
        };
        batches.iter().flat_map(|b| col(b, "x_mm").into_iter().zip(col(b, "y_mm"))).collect()
    }

    /// [`event_track_stages`] is what a `method = "events"` scene runs: the same track points,
    /// to the bit, as the scene's runner (a one-sensor pipeline tapping `track`) on the demo's
    /// first finger, for the default chain and the `paper` chain.
    #[test]
    fn the_event_stages_equal_a_scene_run() {
        use gradtac_stages::locate::EventChain;
        let rec = crate::demo::simulate(crate::demo::DEMO_SEED).unwrap();
        let frames: Vec<TaxelFrame> =
            rec.frames.iter().map(|f| f.frame.clone()).filter(|f| f.sensor.as_str() == "ff").collect();
        let layout = gradtac_stream::Layout::biotac_sp();
        for (chain, text) in [
            (EventChain::PressRelease, "[locate]\nmethod = \"events\"\n"),
            (EventChain::Paper, "[locate]\nmethod = \"events\"\nevent_chain = \"paper\"\n"),
        ] {
            // set on the defaults, nothing else: the stages resolve the chain for the method
            let mut st = StageSettings::default();
            st.locate.method = LocateMethod::Events;
            st.locate.event_chain = chain;
            let ours = event_track_stages(&st, &layout, Some(100.0)).unwrap().run_all(frames.clone()).unwrap();
            let settings: toml::Table = toml::from_str(text).unwrap();
            let mut p = crate::memory::Pipeline::new("biotac-sp", "track", &settings, Some(100.0), "ff").unwrap();
            let mut batches = Vec::new();
            for f in &frames {
                p.push(f.time, f.values.clone()).unwrap();
                batches.push(p.take().unwrap());
            }
            batches.push(p.finish().unwrap());
            let scene = xs(&batches);
            let ours: Vec<(f64, f64)> = ours.iter().map(|q| (q.x_mm, q.y_mm)).collect();
            assert_eq!(ours.len(), scene.len(), "{chain:?}");
            assert!(ours.iter().any(|q| q.0.is_finite()), "{chain:?}: some contact");
            for (k, (a, b)) in ours.iter().zip(&scene).enumerate() {
                assert!(
                    a.0.to_bits() == b.0.to_bits() && a.1.to_bits() == b.1.to_bits()
                        || a.0.is_nan() && b.0.is_nan() && a.1.is_nan() && b.1.is_nan(),
                    "{chain:?} point {k}: {a:?} vs {b:?}"
                );
            }
        }
        let centroid = StageSettings::default();
        assert!(event_track_stages(&centroid, &layout, Some(100.0)).is_err());
    }
}
