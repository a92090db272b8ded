//! A plan checked and explained by building its chains: [`Plan::new`] (what runs, with every
//! stage constructed once so a bad setting fails before anything is read) and
//! [`Plan::explain`] (each stage's effective settings and the latency, read off the built
//! chains).
//!
//! These two methods of [`Plan`] live here, downstream of `plan` and `chain`, so that the
//! modules import one way: `scene` ← `plan` ← `chain` ← `sinks` / `explain` / `run`.

use crate::chain::SensorChain;
use crate::plan::{Plan, Tap};
use crate::scene::Scene;
use crate::Error;
use gradtac_stream::Stage as _;
use std::fmt::Write as _;

impl Plan {
    /// Plan a scene: validate every stage setting that will be used (invalid configuration
    /// fails here, before anything is read) and decide what each sensor runs.
    pub fn new(scene: &Scene) -> Result<Plan, Error> {
        let plan = Plan::decide(scene)?;
        for p in &plan.sensors {
            // Construct each stage once now, so a bad setting is reported before any data
            // moves; errors name the scene file and the sensor.
            SensorChain::build(scene, p).map_err(|e| match e {
                Error::Scene { .. } | Error::SceneAt { .. } => e,
                other => Error::Scene { path: scene.origin.clone(), reason: format!("sensor {:?}: {other}", p.name) },
            })?;
        }
        for u in crate::unused::unused_settings(scene, &plan) {
            tracing::warn!("{}:{}: {} is set but not used: {}", scene.origin.display(), u.line, u.key, u.why);
        }
        Ok(plan)
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
            let slip = &scene.stages.slip;
            let slip_reads_frames = slip.reads_frames();
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
                        .filter(|t| {
                            (t.parent_in(scene.stages.locate.method) == Some(tap)
                                && !(*t == Tap::Force && scene.force_reads_frames()))
                                // the slip stage's pattern evidence reads the raw frames
                                || (*t, tap) == (Tap::Slip, Tap::Source) && slip_reads_frames
                                || (*t, tap) == (Tap::Force, Tap::Source) && scene.force_reads_frames()
                        })
                        .map(Tap::name)
                        .collect();
                    format!("feeds {}", next.join(", "))
                };
                let _ = writeln!(s, "  {:<10} {:<52} {}", tap.name(), chain.describe(tap, &scene.stages), why);
            }
            if let (Some(t), Some(path)) = (&scene.loaded.tare, &scene.stages.locate.baseline) {
                let _ = writeln!(s, "  {:<10} {}", "baseline", describe_tare(scene, p, t, path));
            }
            let mut delay = chain.delay();
            let mut what = "";
            if p.runs(Tap::Slip) {
                // the slip decision is the latest output: its evidence's delay, then persistence
                let built = gradtac_stages::slip::Slip::try_new(slip).expect("validated by Plan::new");
                if slip_reads_frames {
                    let pattern = gradtac_stages::slip_pattern::SlipPattern::try_new(slip, [&p.layout, &p.layout])
                        .expect("validated by Plan::new");
                    delay = pattern.delay() + built.delay();
                } else {
                    delay = delay + built.delay();
                }
                what = " to the slip decision";
            }
            let later: Vec<&str> = Tap::ALL.into_iter().filter(|t| !p.runs(*t)).map(Tap::name).collect();
            if !later.is_empty() {
                let _ = writeln!(s, "  not built: {} (no output needs them)", later.join(", "));
            }
            let rate = spec.source.rate_hz();
            let _ = writeln!(
                s,
                "  latency{what}: {} frames + {:.3} ms in steady state{}; start-up holds {} frames",
                delay.frames,
                delay.nanos as f64 * 1e-6,
                rate.map_or(String::new(), |r| format!(" (= {:.1} ms at {r} Hz)", delay.seconds_at(r) * 1e3)),
                chain.startup_frames()
            );
        }
        let unused = crate::unused::unused_settings(scene, self);
        if !unused.is_empty() {
            let _ = writeln!(s, "settings not used by this plan:");
            for u in unused {
                let _ = writeln!(s, "  {}:{}: {} — {}", scene.origin.display(), u.line, u.key, u.why);
            }
        }
        let _ = writeln!(s, "outputs:");
        for (i, o) in scene.outputs.iter().enumerate() {
            let who = o.sensors.as_ref().map_or("all sensors".to_string(), |v| v.join(", "));
            let _ = writeln!(s, "  #{} {} → {} ({who})", i + 1, o.tap, scene.resolve(&o.path).display());
        }
        s
    }
}

/// The stored baseline, and whether it fits the start of the sensor's recording (file sources
/// only: a live bus is not read by `explain`).
fn describe_tare(
    scene: &Scene,
    p: &crate::plan::SensorPlan,
    t: &gradtac_stages::tare::Tare,
    path: &std::path::Path,
) -> String {
    let mean_noise = t.noise.iter().sum::<f64>() / t.noise.len().max(1) as f64;
    let mut line = format!(
        "stored {} (sensor {}, layout {}, {} untouched frames, mean noise {:.2})",
        path.display(),
        t.sensor,
        t.layout,
        t.frames,
        mean_noise
    );
    if t.taxels != p.layout.len() {
        let _ = write!(line, "; DOES NOT FIT: {} taxels, the sensor has {}", t.taxels, p.layout.len());
        return line;
    }
    if matches!(scene.sensors[p.index].source, crate::scene::SourceSpec::Bus { .. }) {
        return line;
    }
    let mut sum = vec![0.0; t.taxels];
    let mut k = 0usize;
    let read = crate::run::for_each_frame(scene, &p.name, 10, |f| {
        if f.values.len() == sum.len() {
            sum.iter_mut().zip(&f.values).for_each(|(s, v)| *s += v);
            k += 1;
        }
        Ok(true)
    });
    match read {
        Ok(_) if k > 0 => {
            let mean: Vec<f64> = sum.iter().map(|s| s / k as f64).collect();
            let z = t.median_sigmas(&mean).unwrap_or(f64::NAN);
            let contact = scene.stages.locate.contact_sigmas;
            if z > contact {
                let _ = write!(
                    line,
                    "; DOES NOT FIT the recording's first frames: the median taxel is {z:.0} σ from it (> {contact} σ: \
                     another sensor, or a temperature shift?)"
                );
            } else {
                let _ = write!(line, "; fits the recording's first frames (median taxel {z:.1} σ from it)");
            }
        }
        Ok(_) => {}
        Err(e) => {
            let _ = write!(line, "; the recording could not be read to check it: {e}");
        }
    }
    line
}
