//! The planner: from a scene to the stages each sensor needs — and nothing more.
//!
//! Stages form one chain per sensor, in the method's order ([`Tap::ALL`]). An output taps
//! one stage; a sensor runs a stage only if some output that covers the sensor taps that
//! stage or a later one. A sensor no output covers is not read at all.

use crate::scene::Scene;
/// The taps are the scene's vocabulary (an output names one); defined in [`crate::scene`] so
/// that the scene reads them without importing the planner.
pub use crate::scene::Tap;
use crate::Error;
use gradtac_stream::Layout;

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
    /// Decide what each sensor runs (without building any stage). [`Plan::new`] is this plus
    /// the construction of every stage, which lives downstream in `explain.rs` (it builds the
    /// chains), so that this module never imports `chain`.
    pub(crate) fn decide(scene: &Scene) -> Result<Plan, Error> {
        // Before anything is read: no output may replace an input, another output or a non-file.
        crate::guard::check_outputs(scene)?;
        let mut sensors = Vec::new();
        for (index, spec) in scene.sensors.iter().enumerate() {
            // errors name the scene file and the sensor
            let at = |e: Error| match e {
                Error::Scene { .. } | Error::SceneAt { .. } => e,
                other => {
                    Error::Scene { path: scene.origin.clone(), reason: format!("sensor {:?}: {other}", spec.name) }
                }
            };
            let layout = scene.layout(spec).map_err(at)?;
            // a CAN sensor's taxel count is the codec's: checked against the layout now, not
            // by the first stage on the first frame
            if let crate::scene::SourceSpec::Bus { bus } = &spec.source {
                if let Some((i, b)) = scene.buses.iter().enumerate().find(|(_, b)| &b.name == bus) {
                    let (codec, log) = match &b.source {
                        crate::scene::BusSource::Candump(c) => (&c.codec, format!(" ({})", c.path.display())),
                        #[cfg(target_os = "linux")]
                        crate::scene::BusSource::Live(c) => (&c.codec, String::new()),
                    };
                    let codec = gradtac_io::can::CanCodec::try_new(codec)?;
                    let id = gradtac_stream::SensorId::new(&spec.name);
                    use crate::scene::Step;
                    let line = [Step::Key("bus"), Step::Index(i), Step::Key("codec")];
                    match codec.sensor_index(&id) {
                        None => {
                            return Err(scene
                                .at(&line, format!("bus {bus:?}{log}: its codec carries no sensor {:?}", spec.name)))
                        }
                        Some(k) if codec.taxels(k) != layout.len() => {
                            return Err(scene.at(
                                &line,
                                format!(
                                    "bus {bus:?}{log}: sensor {:?} carries {} taxels, but its layout {} has {}",
                                    spec.name,
                                    codec.taxels(k),
                                    layout.name(),
                                    layout.len()
                                ),
                            ))
                        }
                        Some(_) => {}
                    }
                }
            }
            let slip_pair = [&scene.stages.slip.first, &scene.stages.slip.second];
            let outputs: Vec<usize> = scene
                .outputs
                .iter()
                .enumerate()
                .filter(|(_, o)| match Tap::parse(&o.tap) {
                    // a slip output takes the tracks (and the frames) of its two sensors
                    Some(Tap::Slip) => slip_pair.contains(&&spec.name),
                    _ => o.sensors.as_ref().is_none_or(|v| v.contains(&spec.name)),
                })
                .map(|(i, _)| i)
                .collect();
            // a slip output whose evidence is the raw-frame pattern alone needs no track
            let slip = &scene.stages.slip;
            let slip_tracks = slip.reads_tracks();
            let mut needed: Vec<Tap> = outputs
                .iter()
                .filter_map(|&i| Tap::parse(&scene.outputs[i].tap))
                .flat_map(|t| match t {
                    Tap::Slip if !slip_tracks => vec![Tap::Source, Tap::Slip],
                    // a force model on the changes reads the raw frames, not contours
                    Tap::Force if scene.force_reads_frames() => vec![Tap::Source, Tap::Force],
                    t => t.with_ancestors_in(scene.stages.locate.method).collect(),
                })
                .collect();
            needed.sort();
            needed.dedup();
            sensors.push(SensorPlan { index, name: spec.name.clone(), layout, needed, outputs });
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
            // a bad slip setting names the scene file and the line of `[stages.slip]` (of
            // `second` when the two sensors are one)
            let _validated = gradtac_stages::slip::Slip::try_new(c).map_err(|e| {
                use crate::scene::Step;
                let key = if c.first == c.second { "second" } else { "first" };
                scene.at(&[Step::Key("stages"), Step::Key("slip"), Step::Key(key)], format!("[stages.slip]: {e}"))
            })?;
        }
        Ok(Plan { sensors })
    }
}
