//! The planner: from a scene to the stages each sensor needs — and nothing more.
//!
//! Stages form one chain per sensor, in the method's order ([`Tap::ALL`]). An output taps
//! one stage; a sensor runs a stage only if some output that covers the sensor taps that
//! stage or a later one. A sensor no output covers is not read at all.

use crate::chain::SensorChain;
use crate::scene::Scene;
/// The taps are the scene's vocabulary (an output names one); defined in [`crate::scene`] so
/// that the scene reads them without importing the planner.
pub use crate::scene::Tap;
use crate::Error;
use gradtac_stream::Layout;
use std::fmt::Write as _;

/// What one sensor runs.
#[derive(Clone, Debug)]
pub struct SensorPlan {
    /// Index of the sensor in the scene.
    pub index: usize,
    /// The sensor's name.
    pub name: String,
    /// Its layout.
    pub layout: Layout,
    /// The stages it runs (empty: not read at all), in [`Tap::ALL`] order.
    pub needed: Vec<Tap>,
    /// Indices (into the scene's outputs) of the outputs that take data from this sensor.
    pub outputs: Vec<usize>,
}

impl SensorPlan {
    /// True when the sensor runs `tap` (the source counts as a stage).
    pub fn runs(&self, tap: Tap) -> bool {
        self.needed.contains(&tap)
    }

    /// True when the sensor is read at all.
    pub fn is_read(&self) -> bool {
        !self.needed.is_empty()
    }

    /// The stages it runs, in order.
    pub fn stages(&self) -> impl Iterator<Item = Tap> + '_ {
        self.needed.iter().copied()
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
        // Before anything is read: no output may replace an input, another output or a non-file.
        crate::guard::check_outputs(scene)?;
        let mut sensors = Vec::new();
        for (index, spec) in scene.sensors.iter().enumerate() {
            // errors name the scene file and the sensor
            let at = |e: Error| match e {
                Error::Scene { .. } => e,
                other => {
                    Error::Scene { path: scene.origin.clone(), reason: format!("sensor {:?}: {other}", spec.name) }
                }
            };
            let layout = scene.layout(spec).map_err(at)?;
            let slip_pair = [&scene.stages.slip.first, &scene.stages.slip.second];
            let outputs: Vec<usize> = scene
                .outputs
                .iter()
                .enumerate()
                .filter(|(_, o)| match Tap::parse(&o.tap) {
                    // a slip output takes the tracks of its two sensors
                    Some(Tap::Slip) => slip_pair.contains(&&spec.name),
                    _ => o.sensors.as_ref().is_none_or(|v| v.contains(&spec.name)),
                })
                .map(|(i, _)| i)
                .collect();
            let mut needed: Vec<Tap> = outputs
                .iter()
                .filter_map(|&i| Tap::parse(&scene.outputs[i].tap))
                .flat_map(|t| t.with_ancestors_in(scene.stages.locate.method))
                .collect();
            needed.sort();
            needed.dedup();
            let plan = SensorPlan { index, name: spec.name.clone(), layout, needed, outputs };
            // Construct each stage once now, so a bad setting is reported before any data moves.
            SensorChain::build(scene, &plan).map_err(at)?;
            sensors.push(plan);
        }
        if scene.outputs.iter().any(|o| o.tap == Tap::Slip.name()) {
            let c = &scene.stages.slip;
            for name in [&c.first, &c.second] {
                if !sensors.iter().any(|p| &p.name == name) {
                    return Err(Error::Scene {
                        path: scene.origin.clone(),
                        reason: format!(
                            "a slip output needs the sensors [stages.slip] first = {:?} and second = {:?}; {name:?} is not declared",
                            c.first, c.second
                        ),
                    });
                }
            }
            let _validated = gradtac_stages::slip::Slip::try_new(c)?;
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
            if !p.is_read() {
                let _ = writeln!(s, "  not read: no output uses this sensor");
                continue;
            }
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
                    let next: Vec<&str> = p
                        .stages()
                        .filter(|t| t.parent_in(scene.stages.locate.method) == Some(tap))
                        .map(Tap::name)
                        .collect();
                    format!("feeds {}", next.join(", "))
                };
                let _ = writeln!(s, "  {:<10} {:<52} {}", tap.name(), chain.describe(tap, &scene.stages), why);
            }
            let delay = chain.delay();
            let later: Vec<&str> = Tap::ALL.into_iter().filter(|t| !p.runs(*t)).map(Tap::name).collect();
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
