//! The planner: from a scene to the stages each sensor needs — and nothing more.
//!
//! Stages form one chain per sensor, in the method's order ([`Tap::ALL`]). An output taps
//! one stage; a sensor runs a stage only if some output that covers the sensor taps that
//! stage or a later one. A sensor no output covers is not read at all.

use crate::chain::SensorChain;
use crate::scene::Scene;
use crate::Error;
use gradtac_stream::Layout;
use std::fmt::Write as _;

/// A point of the per-sensor chain that an output can tap, in chain order. Its name is also
/// the name of the stage's settings table (`[stages.<name>]`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Tap {
    /// Raw frames as the source delivers them.
    Source,
    /// Min–max normalised frames.
    Normalise,
    /// Savitzky–Golay smoothed (or differentiated) frames.
    Savgol,
    /// Log-change event batches (one per frame).
    Events,
    /// Per-taxel event aggregates over a window.
    Window,
    /// Interpolated surfaces on a grid.
    Surface,
    /// Maximal contours.
    Contour,
    /// Contact track points.
    Track,
}

impl Tap {
    /// Every tap, in chain order.
    pub const ALL: [Tap; 8] =
        [Tap::Source, Tap::Normalise, Tap::Savgol, Tap::Events, Tap::Window, Tap::Surface, Tap::Contour, Tap::Track];

    /// The tap's name in scenes.
    pub fn name(self) -> &'static str {
        match self {
            Tap::Source => "source",
            Tap::Normalise => "normalise",
            Tap::Savgol => "savgol",
            Tap::Events => "events",
            Tap::Window => "window",
            Tap::Surface => "surface",
            Tap::Contour => "contour",
            Tap::Track => "track",
        }
    }

    /// The tap of a scene name.
    pub fn parse(s: &str) -> Option<Tap> {
        Tap::ALL.into_iter().find(|t| t.name() == s)
    }

    /// All tap names, in chain order.
    pub fn names() -> Vec<&'static str> {
        Tap::ALL.iter().map(|t| t.name()).collect()
    }
}

/// What one sensor runs.
#[derive(Clone, Debug)]
pub struct SensorPlan {
    /// Index of the sensor in the scene.
    pub index: usize,
    /// The sensor's name.
    pub name: String,
    /// Its layout.
    pub layout: Layout,
    /// The last stage it runs (`None`: not read at all).
    pub deepest: Option<Tap>,
    /// Indices (into the scene's outputs) of the outputs that take data from this sensor.
    pub outputs: Vec<usize>,
}

impl SensorPlan {
    /// True when the sensor runs `tap` (the source counts as a stage).
    pub fn runs(&self, tap: Tap) -> bool {
        self.deepest.is_some_and(|d| tap <= d)
    }

    /// The stages it runs, in order.
    pub fn stages(&self) -> impl Iterator<Item = Tap> + '_ {
        Tap::ALL.into_iter().filter(|t| self.runs(*t))
    }
}

/// The plan of a whole scene.
#[derive(Clone, Debug)]
pub struct Plan {
    /// Per sensor, in scene order.
    pub sensors: Vec<SensorPlan>,
}

impl Plan {
    /// Plan a scene: validate every stage setting that will be used (invalid configuration
    /// fails here, before anything is read) and decide what each sensor runs.
    pub fn new(scene: &Scene) -> Result<Plan, Error> {
        let mut sensors = Vec::new();
        for (index, spec) in scene.sensors.iter().enumerate() {
            let layout = scene.layout(spec)?;
            let outputs: Vec<usize> = scene
                .outputs
                .iter()
                .enumerate()
                .filter(|(_, o)| o.sensors.as_ref().is_none_or(|v| v.contains(&spec.name)))
                .map(|(i, _)| i)
                .collect();
            let deepest = outputs.iter().filter_map(|&i| Tap::parse(&scene.outputs[i].tap)).max();
            let plan = SensorPlan { index, name: spec.name.clone(), layout, deepest, outputs };
            // Construct each stage once now, so a bad setting is reported before any data moves.
            SensorChain::build(scene, &plan)?;
            sensors.push(plan);
        }
        Ok(Plan { sensors })
    }

    /// The plan as text: which stages run for which sensor and why (`gradtac explain`).
    pub fn explain(&self, scene: &Scene) -> String {
        let mut s = String::new();
        for p in &self.sensors {
            let spec = &scene.sensors[p.index];
            let _ = writeln!(
                s,
                "sensor {} — layout {} ({} taxels), source {} {}",
                p.name,
                p.layout.name(),
                p.layout.len(),
                spec.source.kind(),
                scene.resolve(spec.source.path()).display()
            );
            let Some(deepest) = p.deepest else {
                let _ = writeln!(s, "  not read: no output uses this sensor");
                continue;
            };
            let chain = SensorChain::build(scene, p).expect("validated by Plan::new");
            for tap in p.stages() {
                let tapped_by: Vec<String> = p
                    .outputs
                    .iter()
                    .filter(|&&i| scene.outputs[i].tap == tap.name())
                    .map(|&i| format!("output #{} {}", i + 1, scene.outputs[i].path.display()))
                    .collect();
                let why = if !tapped_by.is_empty() {
                    format!("written to {}", tapped_by.join(", "))
                } else {
                    let next = Tap::ALL.into_iter().find(|t| *t > tap).map_or("", Tap::name);
                    format!("feeds {next}")
                };
                let _ = writeln!(s, "  {:<10} {:<52} {}", tap.name(), chain.describe(tap, &scene.stages), why);
            }
            let delay = chain.delay();
            let later: Vec<&str> = Tap::ALL.into_iter().filter(|t| *t > deepest).map(Tap::name).collect();
            if !later.is_empty() {
                let _ = writeln!(s, "  not built: {} (no output needs them)", later.join(", "));
            }
            let rate = spec.source.rate_hz();
            let _ = writeln!(
                s,
                "  latency: {} frames + {:.3} ms in steady state{}; start-up holds {} frames",
                delay.frames,
                delay.nanos as f64 * 1e-6,
                rate.map_or(String::new(), |r| format!(" (= {:.1} ms at {r} Hz)", delay.seconds_at(r) * 1e3)),
                chain.startup_frames()
            );
        }
        let _ = writeln!(s, "outputs:");
        for (i, o) in scene.outputs.iter().enumerate() {
            let who = o.sensors.as_ref().map_or("all sensors".to_string(), |v| v.join(", "));
            let _ = writeln!(s, "  #{} {} → {} ({who})", i + 1, o.tap, scene.resolve(&o.path).display());
        }
        s
    }
}
