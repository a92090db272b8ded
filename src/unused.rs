//! Settings a scene gives that its plan will not use: a `[stages.<name>]` table of a stage no
//! sensor runs (e.g. `[stages.surface]` while `[stages.locate] method = "centroid"`), or a
//! `[stages.locate]` key the chosen method ignores. [`Plan::new`](crate::Plan::new) warns about
//! each (naming the scene file and line) and `gradtac explain` lists them, so a setting that
//! silently does nothing is told so.

use crate::plan::{Plan, Tap};
use crate::scene::Scene;
use gradtac_stages::locate::LocateMethod;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt;

/// One unused setting.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unused {
    /// The key, e.g. `[stages.surface]` or `[stages.locate] power`.
    pub key: String,
    /// The scene file's line (1-based) where it is set; 0 when unknown.
    pub line: usize,
    /// Why the plan does not use it.
    pub why: String,
}

impl fmt::Display for Unused {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {} is set but not used: {}", self.line, self.key, self.why)
    }
}

type Spanned<T> = toml::Spanned<T>;

/// A `[stages.<name>]` table: its keys with their spans.
type StageTable = Spanned<BTreeMap<String, Spanned<toml::Value>>>;

#[derive(Deserialize)]
struct Top {
    #[serde(default)]
    stages: Option<BTreeMap<String, StageTable>>,
}

fn line_of(text: &str, at: usize) -> usize {
    text.get(..at).map_or(0, |s| s.matches('\n').count()) + 1
}

/// Locate keys read by each method (`centroid` / `raw_contour` share the change detector).
fn locate_key_used(key: &str, method: LocateMethod, detector_elsewhere: bool) -> bool {
    let detector = ["calibrate_frames", "window_frames", "floor_sigmas", "contact_sigmas", "follow_s", "baseline"];
    let centroid_only = ["power", "weights", "top_k", "smooth_frames", "max_speed_mm_s"];
    match key {
        "method" => true,
        "event_tau_sigmas" => method == LocateMethod::Events,
        "calibrate_frames" if method == LocateMethod::Events => true,
        k if detector.contains(&k) => method != LocateMethod::Events || detector_elsewhere,
        k if centroid_only.contains(&k) => matches!(method, LocateMethod::Centroid | LocateMethod::Fit),
        k if k.starts_with("fit_") => method == LocateMethod::Fit,
        _ => true,
    }
}

/// The settings of `scene` that `plan` will not use (see the [module docs](self)).
pub fn unused_settings(scene: &Scene, plan: &Plan) -> Vec<Unused> {
    let Ok(top) = toml::from_str::<Top>(&scene.text) else { return Vec::new() };
    let Some(stages) = top.stages else { return Vec::new() };
    let method = scene.stages.locate.method;
    let runs = |t: Tap| plan.sensors.iter().any(|p| p.runs(t));
    let force_frames = scene.force_reads_frames() && runs(Tap::Force);
    let located = runs(Tap::Contour) || (method == LocateMethod::RawContour && runs(Tap::Window));
    let m = format!("[stages.locate] method = \"{}\"", method.name());
    let mut out = Vec::new();
    for (name, table) in &stages {
        let line = line_of(&scene.text, table.span().start);
        let key = format!("[stages.{name}]");
        let no_output = |stage: &str| format!("no output needs the {stage} stage (nor a stage after it)");
        let why: Option<String> = match name.as_str() {
            // (the event stages also run for an `events`, `window` or `surface` tap of any method)
            "normalise" | "savgol" | "events" | "window" if method != LocateMethod::Events && !runs(Tap::Events) => {
                Some(if runs(Tap::Contour) {
                    format!("{m} does not run the event chain (normalise → savgol → events → window)")
                } else {
                    no_output(name)
                })
            }
            "surface" | "contour"
                if matches!(method, LocateMethod::Centroid | LocateMethod::Fit)
                    && !(name == "surface" && runs(Tap::Surface)) =>
            {
                Some(if runs(Tap::Contour) {
                    format!("{m} locates contact from the taxels directly: no surface or contour is computed")
                } else {
                    no_output(name)
                })
            }
            "locate"
                if !(located || force_frames || runs(Tap::Events) && table.get_ref().contains_key("event_chain")) =>
            {
                Some("no output needs contact location (contour, track, force, servo or slip by tracks)".into())
            }
            "locate" => {
                for (k, v) in table.get_ref() {
                    // the event chain's defaults apply wherever the event stages run
                    let (used, why) = if k == "event_chain" {
                        (runs(Tap::Events), "no output runs the event chain (events, window, surface)".to_string())
                    } else {
                        (locate_key_used(k, method, force_frames), format!("{m} does not read it"))
                    };
                    if !used {
                        out.push(Unused {
                            key: format!("[stages.locate] {k}"),
                            line: line_of(&scene.text, v.span().start),
                            why,
                        });
                    }
                }
                None
            }
            other => match Tap::parse(other) {
                Some(t) if t != Tap::Source && !runs(t) => Some(no_output(other)),
                _ => None,
            },
        };
        if let Some(why) = why {
            out.push(Unused { key, line, why });
        }
    }
    out.sort_by_key(|u| u.line);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn scene(extra: &str, tap: &str) -> (Scene, Plan) {
        let text = format!(
            "[[sensor]]\nname = \"ff\"\nsource = {{ csv = \"r.csv\", columns = \"ff_e{{1..24}}\", rate_hz = 100.0 }}\n\
             [[output]]\ntap = \"{tap}\"\npath = \"o.parquet\"\n{extra}"
        );
        let s = Scene::from_toml(&text, "/nonexistent", Path::new("s.toml")).unwrap();
        let p = Plan::decide(&s).unwrap();
        (s, p)
    }

    #[test]
    fn a_surface_table_under_the_centroid_is_named_with_its_line() {
        let (s, p) = scene("\n[stages.surface]\ngrid = { nx = 16 }\n", "track");
        let u = unused_settings(&s, &p);
        assert_eq!(u.len(), 1, "{u:?}");
        assert_eq!((u[0].key.as_str(), u[0].line), ("[stages.surface]", 8));
        assert!(u[0].why.contains("method = \"centroid\""), "{}", u[0]);
        // under raw_contour the surface is computed: nothing to say
        let (s, p) =
            scene("\n[stages.locate]\nmethod = \"raw_contour\"\n[stages.surface]\ngrid = { nx = 16 }\n", "track");
        assert_eq!(unused_settings(&s, &p), vec![]);
    }

    #[test]
    fn tables_no_output_needs_and_locate_keys_the_method_ignores() {
        let (s, p) = scene("\n[stages.track]\nrelease_frames = 3\n[stages.locate]\npower = 3.0\n", "source");
        let u = unused_settings(&s, &p);
        let keys: Vec<&str> = u.iter().map(|u| u.key.as_str()).collect();
        assert_eq!(keys, ["[stages.track]", "[stages.locate]"], "{u:?}");
        assert!(u[0].why.contains("no output needs the track stage"));
        let (s, p) = scene("\n[stages.locate]\nmethod = \"events\"\npower = 3.0\nevent_tau_sigmas = 5.0\n", "contour");
        let u = unused_settings(&s, &p);
        assert_eq!(u.len(), 1, "{u:?}");
        assert_eq!((u[0].key.as_str(), u[0].line), ("[stages.locate] power", 10));
        // the defaults' scene: nothing
        let (s, p) = scene("", "track");
        assert!(unused_settings(&s, &p).is_empty());
    }

    #[test]
    fn the_event_chain_keys_count_wherever_the_event_stages_run() {
        // a surface tap runs the event chain under the centroid too: its tables and the chain
        // are used, while the track still locates by the centroid
        let chain = "\n[stages.locate]\nevent_chain = \"paper\"\n[stages.events]\npolarity = \"both\"\n\
                     [stages.surface]\ngrid = { nx = 16 }\n";
        let (s, p) = scene(chain, "surface");
        assert_eq!(unused_settings(&s, &p), vec![]);
        // with only a track output nothing runs them: each is named
        let (s, p) = scene(chain, "track");
        let keys: Vec<String> = unused_settings(&s, &p).into_iter().map(|u| u.key).collect();
        assert_eq!(keys, ["[stages.locate] event_chain", "[stages.events]", "[stages.surface]"], "{keys:?}");
    }
}
