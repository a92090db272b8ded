//! One sensor's stages, built only where its outputs need them (the tap tree of [`Tap::parent`]).

use crate::plan::{SensorPlan, Tap};
use crate::scene::{Scene, StageSettings};
use crate::sinks::Sinks;
use crate::Error;
use gradtac_stages::contour::{Contour, ContourFrame, Levels};
use gradtac_stages::dos::{DosClassifier, DosDecision};
use gradtac_stages::events::{Events, Threshold};
use gradtac_stages::force::{Force, ForceEstimate, ForceModel};
use gradtac_stages::interpolate::{Interpolate, Surface};
use gradtac_stages::normalise::{Bounds, Normalise};
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
    track: Option<Track>,
    force: Option<Force>,
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

impl SensorChain {
    /// Build the stages `plan` says the sensor runs, validating their settings.
    pub fn build(scene: &Scene, plan: &SensorPlan) -> Result<SensorChain, Error> {
        let st = &scene.stages;
        let n = plan.layout.len();
        let runs = |t| plan.runs(t);
        let rate = scene.sensors[plan.index].source.rate_hz();
        let mut taps: [Vec<usize>; TAPS] = std::array::from_fn(|_| Vec::new());
        for &i in &plan.outputs {
            if let Some(t) = Tap::parse(&scene.outputs[i].tap) {
                taps[t as usize].push(i);
            }
        }
        Ok(SensorChain {
            sensor: SensorId::new(&plan.name),
            taps,
            normalise: runs(Tap::Normalise).then(|| Normalise::try_new(n, &st.normalise)).transpose()?,
            savgol: runs(Tap::Savgol)
                .then(|| match rate {
                    Some(r) => SavGol::try_with_rate(n, st.savgol.clone(), r),
                    None => SavGol::try_new(n, st.savgol.clone()),
                })
                .transpose()?,
            events: runs(Tap::Events).then(|| Events::try_new(n, st.events.clone())).transpose()?,
            window: runs(Tap::Window).then(|| Window::try_new(&st.window)).transpose()?,
            surface: runs(Tap::Surface).then(|| Interpolate::try_new(&st.surface, &plan.layout)).transpose()?,
            contour: runs(Tap::Contour).then(|| Contour::try_new(&st.contour)).transpose()?,
            track: runs(Tap::Track).then(|| Track::try_new(&st.track)).transpose()?,
            force: match (runs(Tap::Force), &st.force) {
                (false, _) => None,
                (true, Some(cfg)) => Some(Force::try_new(cfg)?),
                (true, None) => {
                    return Err(Error::Scene {
                        path: scene.base_dir.clone(),
                        reason: "the force tap needs a calibrated model: [stages.force] model = { method = …, … } \
                                 (fit one from labelled data with ForceModel::fit, see the force stage docs)"
                            .into(),
                    })
                }
            },
            servo: runs(Tap::Servo).then(|| Servo::try_new(&st.servo, &plan.layout)).transpose()?,
            dos: match (runs(Tap::Dos), &st.dos) {
                (false, _) => None,
                (true, Some(d)) => {
                    let model = crate::calibrate::read_model(&scene.resolve(&d.model))?;
                    let c = DosClassifier::try_new(model, &plan.layout, d.decision_frames)?;
                    Some(match d.hop_frames {
                        Some(hop) => c.with_hop(hop)?,
                        None => c,
                    })
                }
                (true, None) => {
                    return Err(Error::Scene {
                        path: scene.base_dir.clone(),
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

    /// Steady-state delay of the whole chain.
    pub fn delay(&self) -> Delay {
        let d = |s: Option<Delay>| s.unwrap_or(Delay::ZERO);
        d(self.normalise.as_ref().map(Stage::delay))
            + d(self.savgol.as_ref().map(Stage::delay))
            + d(self.events.as_ref().map(Stage::delay))
            + d(self.window.as_ref().map(Stage::delay))
            + d(self.surface.as_ref().map(Stage::delay))
            + d(self.contour.as_ref().map(Stage::delay))
            + d(self.track.as_ref().map(Stage::delay))
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

    /// One line on what a stage does with its settings (`gradtac explain`).
    pub fn describe(&self, tap: Tap, st: &StageSettings) -> String {
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
                    Threshold::PerTaxel(_) => "τ per taxel".into(),
                };
                format!("log-change, {tau}, cap {}/taxel/frame", c.max_events_per_step)
            }),
            Tap::Window => {
                let c = &st.window;
                let size = match (c.frames, c.duration_ms) {
                    (_, Some(ms)) => format!("{ms} ms"),
                    (Some(f), None) => format!("{f} frames"),
                    (None, None) => "default size".into(),
                };
                format!("{:?} {size}, step {}, {:?}", c.kind, c.step, c.aggregate).to_lowercase()
            }
            Tap::Surface => {
                let c = &st.surface;
                let (nx, ny) = (c.grid.nx, c.grid.ny.unwrap_or(c.grid.nx));
                format!("{:?} on {nx}×{ny} grid, outside hull: {:?}", c.method, c.outside).to_lowercase()
            }
            Tap::Contour => {
                let c = &st.contour;
                let levels = match &c.levels {
                    Levels::Count(k) => format!("{k} levels"),
                    Levels::Explicit(v) => format!("{} given levels", v.len()),
                };
                format!("maximal contour, {levels}, min area {} mm²", c.min_area_mm2)
            }
            Tap::Track => match st.track.max_jump_mm {
                Some(j) => format!("gate jumps > {j} mm ({:?})", st.track.gate).to_lowercase(),
                None => "no jump gating".into(),
            },
            Tap::Force => st.force.as_ref().map_or("no model".into(), |f| {
                let m = match &f.model {
                    ForceModel::Linear { .. } => "linear",
                    ForceModel::PowerLaw { .. } => "power law",
                    ForceModel::Exponential { .. } => "exponential",
                    ForceModel::Isotonic { .. } => "isotonic",
                };
                format!("contour area → N, {m} model")
            }),
            Tap::Servo => format!("offset from centre, gain {}, deadband {} mm", st.servo.gain, st.servo.deadband_mm),
            Tap::Slip => format!("two-finger slip of {} and {}", st.slip.first, st.slip.second),
            Tap::Dos => match (&self.dos, &st.dos) {
                (Some(c), Some(d)) => format!(
                    "slip direction, {} classes, {} parameters, {}",
                    c.model().classes.len(),
                    c.model().parameter_count(),
                    match (d.decision_frames, d.hop_frames) {
                        (None, _) => "one decision per recording".to_string(),
                        (Some(n), None) => format!("a decision per {n} frames"),
                        (Some(n), Some(h)) => format!("a decision every {h} frames over the last {n}"),
                    }
                ),
                _ => String::new(),
            },
        }
    }

    /// Push one frame (or, with `finish`, flush) through every built stage, writing each
    /// stage's outputs to the outputs that tap it.
    pub fn process(&mut self, frame: Option<TaxelFrame>, finish: bool, sinks: &mut Sinks) -> Result<(), Error> {
        if frame.is_some() {
            self.frames_in += 1;
        }
        self.points.clear();
        self.raw.extend(frame);
        sinks.write_all(&self.taps[Tap::Source as usize], &self.raw)?;
        if let Some(d) = &mut self.dos {
            feed(d, &mut self.raw.clone(), &mut self.decisions, finish)?;
            sinks.write_all(&self.taps[Tap::Dos as usize], &self.decisions)?;
            self.decisions.clear();
        }
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
        let Some(st) = &mut self.window else {
            self.batches.clear();
            return Ok(());
        };
        feed(st, &mut self.batches, &mut self.windows, finish)?;
        sinks.write_all(&self.taps[Tap::Window as usize], &self.windows)?;
        let Some(st) = &mut self.surface else {
            self.windows.clear();
            return Ok(());
        };
        feed(st, &mut self.windows, &mut self.surfaces, finish)?;
        sinks.write_all(&self.taps[Tap::Surface as usize], &self.surfaces)?;
        let Some(st) = &mut self.contour else {
            self.surfaces.clear();
            return Ok(());
        };
        feed(st, &mut self.surfaces, &mut self.contours, finish)?;
        sinks.write_all(&self.taps[Tap::Contour as usize], &self.contours)?;
        if let Some(f) = &mut self.force {
            feed(f, &mut self.contours.clone(), &mut self.forces, finish)?;
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
            feed(sv, &mut self.points.clone(), &mut self.commands, finish)?;
            sinks.write_all(&self.taps[Tap::Servo as usize], &self.commands)?;
            self.commands.clear();
        }
        // the points stay for the runner's slip stage (take_points), cleared on the next call
        Ok(())
    }
}
