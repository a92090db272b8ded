//! Scene files: which sensors, which sources, which stage settings, which outputs.
//!
//! A scene is TOML. Relative paths (sources, layouts, outputs) are resolved against the
//! directory of the scene file.
//!
//! ```toml
//! [[sensor]]
//! name = "ff"
//! layout = "biotac-sp"                 # a built-in layout, or a path to a CSV (name,x_mm,y_mm)
//! source = { csv = "recording.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }
//!
//! [stages.normalise]
//! calibrate_frames = 20
//!
//! [[output]]
//! tap = "normalise"                    # any stage by name, or "source" for the raw frames
//! path = "out/normalised.parquet"
//! # sensors = ["ff"]                   # default: every sensor
//! ```
//!
//! Every table rejects unknown keys, so a misspelt setting is an error, not a silent default.

use crate::Error;
use gradtac_io::archive::ArchiveConfig;
use gradtac_io::arrow_ipc::ArrowIpcConfig;
#[cfg(target_os = "linux")]
use gradtac_io::can::socketcan::SocketCanConfig;
use gradtac_io::can::{CanCodec, CandumpConfig};
use gradtac_io::npy::NpySourceConfig;
use gradtac_io::rosbag::BagSourceConfig;
use gradtac_io::CsvSourceConfig;
use gradtac_stages::contour::ContourConfig;
use gradtac_stages::events::EventsConfig;
use gradtac_stages::force::ForceModel;
use gradtac_stages::force_model::ForceFile;
use gradtac_stages::interpolate::InterpolateConfig;
use gradtac_stages::locate::{EventChain, LocateConfig, LocateMethod};
use gradtac_stages::normalise::NormaliseConfig;
use gradtac_stages::savgol::SavGolConfig;
use gradtac_stages::servo::ServoConfig;
use gradtac_stages::slip::SlipConfig;
use gradtac_stages::tare::Tare;
use gradtac_stages::track::TrackConfig;
use gradtac_stages::window::WindowConfig;
use gradtac_stream::Layout;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A parsed scene (see the [module docs](self)).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// The sensors, each with its own source.
    #[serde(rename = "sensor", default)]
    pub sensors: Vec<SensorSpec>,
    /// CAN buses (candump logs or live SocketCAN interfaces) that sensors read with
    /// `source = { bus = "<name>" }`.
    #[serde(rename = "bus", default)]
    pub buses: Vec<BusSpec>,
    /// Stage settings shared by every sensor.
    #[serde(default)]
    pub stages: StageSettings,
    /// What to write.
    #[serde(rename = "output", default)]
    pub outputs: Vec<OutputSpec>,
    /// Directory relative paths are resolved against (the scene file's; not part of the TOML).
    #[serde(skip)]
    pub base_dir: PathBuf,
    /// The TOML text the scene was parsed from (stored in output metadata).
    #[serde(skip)]
    pub text: String,
    /// The scene file the scene was read from (empty when parsed from text without one);
    /// named by planner errors and protected from being written over (see [`crate::guard`]).
    #[serde(skip)]
    pub origin: PathBuf,
    /// Model files the scene names, read and validated when it is loaded
    /// (`[stages.force] model = "force.json"`, `[stages.locate] baseline = "tare.json"`).
    #[serde(skip)]
    pub loaded: LoadedFiles,
}

/// The files a scene's settings name, read and validated with the scene.
#[derive(Clone, Debug, Default)]
pub struct LoadedFiles {
    /// `[stages.force] model = "….json"` (`gradtac calibrate force`).
    pub force: Option<ForceFile>,
    /// `[stages.locate] baseline = "….json"` (`gradtac calibrate baseline`).
    pub tare: Option<Tare>,
}

/// `[stages.force]`: the calibrated force model.
///
/// ```toml
/// [stages.force]
/// model = "force.json"      # written by `gradtac calibrate force`
/// # or a curve over the contour area given inline:
/// # model = { method = "power_law", scale = 0.05, exponent = 1.4 }
/// min_area_mm2 = 0.0        # inline curves: smaller contours give no force
/// ```
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForceSettings {
    /// The model: a file (relative to the scene) or an inline area curve.
    pub model: ForceModelSpec,
    /// Contours smaller than this (mm²) give no force (area models). Default 0.
    #[serde(default)]
    pub min_area_mm2: f64,
}

/// Where a force model comes from.
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
pub enum ForceModelSpec {
    /// A model file written by `gradtac calibrate force`.
    File(PathBuf),
    /// An area curve given inline ([`ForceModel`]).
    Inline(ForceModel),
}

impl<'de> Deserialize<'de> for ForceModelSpec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error as _;
        match toml::Value::deserialize(d)? {
            toml::Value::String(p) => Ok(ForceModelSpec::File(PathBuf::from(p))),
            v @ toml::Value::Table(_) => {
                ForceModel::deserialize(v).map(ForceModelSpec::Inline).map_err(D::Error::custom)
            }
            _ => Err(D::Error::custom(
                "model is a file (model = \"force.json\", from gradtac calibrate force) or an inline curve \
                 (model = { method = \"power_law\", … })",
            )),
        }
    }
}

/// Read a force model file (bounded size), validated; errors name the file.
pub fn read_force_file(path: &Path) -> Result<ForceFile, Error> {
    let text = crate::guard::read_text_capped(path, crate::guard::MAX_MODEL_BYTES)?;
    let bad = |reason: String| Error::Scene { path: path.to_path_buf(), reason };
    // the format and version first: a newer file is refused by its version, not by a field
    #[derive(serde::Deserialize)]
    struct Header {
        format: String,
        version: u32,
    }
    let head: Header = serde_json::from_str(&text).map_err(|e| bad(format!("not a gradtac force model: {e}")))?;
    gradtac_stages::force_model::check_header(&head.format, head.version).map_err(|e| bad(e.to_string()))?;
    let file: ForceFile = serde_json::from_str(&text).map_err(|e| bad(format!("not a gradtac force model: {e}")))?;
    file.validate().map_err(|e| bad(e.to_string()))?;
    Ok(file)
}

/// Read a tare (stored baseline) file (bounded size), validated; errors name the file.
pub fn read_tare_file(path: &Path) -> Result<Tare, Error> {
    let text = crate::guard::read_text_capped(path, crate::guard::MAX_MODEL_BYTES)?;
    let bad = |reason: String| Error::Scene { path: path.to_path_buf(), reason };
    let tare: Tare = serde_json::from_str(&text).map_err(|e| bad(format!("not a gradtac baseline (tare): {e}")))?;
    tare.validate().map_err(|e| bad(e.to_string()))?;
    Ok(tare)
}

/// One sensor of a scene.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorSpec {
    /// The sensor's name (`ff`, `th`, …): the key of its stream and the `sensor` column of outputs.
    pub name: String,
    /// A built-in layout name (`biotac-sp`) or a path to a layout CSV. Default `biotac-sp`.
    #[serde(default = "default_layout")]
    pub layout: String,
    /// Where its frames come from.
    pub source: SourceSpec,
}

fn default_layout() -> String {
    "biotac-sp".into()
}

/// A sensor's source: a table whose kind key (`csv = "…"`, `npy = "…"`, `arrow = "…"`) names
/// the file; the other keys are that kind's settings ([`CsvSourceConfig`],
/// [`NpySourceConfig`], [`ArrowIpcConfig`]).
///
/// An Arrow IPC file in the long layout (`sensor`/`time_ns`/`seq`/`values`) may hold several
/// sensors; without an explicit `sensors = [...]` filter the scene keeps the rows whose
/// `sensor` equals the scene sensor's name.
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
#[non_exhaustive]
pub enum SourceSpec {
    /// A CSV file.
    Csv(CsvSourceConfig),
    /// A NumPy `.npy` file (frames × taxels).
    Npy(NpySourceConfig),
    /// An Arrow IPC file or stream.
    Arrow(ArrowIpcConfig),
    /// One fingertip of a recorded hand in a ROS 1 bag
    /// (`source = { rosbag = "grasp.bag", topic = "/rh/tactile", finger = "ff" }`); sensors
    /// naming the same file share one pass over it.
    Rosbag(BagSourceConfig),
    /// One fingertip of a recorded hand in an MCAP file (ROS 2, CDR;
    /// `source = { mcap = "grasp.mcap", topic = "/rh/tactile", finger = "ff" }`).
    Mcap(BagSourceConfig),
    /// A sensor decoded from a CAN bus of the scene (`source = { bus = "hand" }`).
    Bus {
        /// The bus's name.
        bus: String,
    },
}

/// Source kinds, by their key.
pub const SOURCE_KINDS: &[&str] = &["csv", "npy", "arrow", "bus", "rosbag", "mcap"];

/// A CAN bus shared by several sensors: a candump log (`candump = "log.txt"`, replayed as fast
/// as possible or with `timing = "original"`) or a live SocketCAN interface
/// (`interface = "can0"`), with its frame codec (see `docs/can.md`).
///
/// ```toml
/// [[bus]]
/// name = "hand"
/// candump = "grasp.log"
/// codec = { preset = { kind = "biotac-mux", sensors = ["ff", "th"] } }
/// stats = "out/can-stats.json"      # optional: fault counts written at the end of the run
/// ```
///
/// Frames of sensors that no output uses are decoded (they share the bus) but not processed.
#[derive(Clone, Debug, Serialize)]
pub struct BusSpec {
    /// The bus's name, referenced by sensors.
    pub name: String,
    /// Where to write the bus's fault counts (JSON) at the end of a run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stats: Option<PathBuf>,
    /// The traffic.
    pub source: BusSource,
}

/// Where a bus's CAN frames come from.
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
#[non_exhaustive]
pub enum BusSource {
    /// A can-utils `candump -l` log.
    Candump(CandumpConfig),
    /// A live SocketCAN interface.
    #[cfg(target_os = "linux")]
    Live(SocketCanConfig),
}

impl<'de> Deserialize<'de> for BusSpec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error as _;
        let mut table = toml::Table::deserialize(d)?;
        let name = match table.remove("name") {
            Some(toml::Value::String(n)) => n,
            _ => return Err(D::Error::custom("a [[bus]] needs name = \"…\"")),
        };
        let stats = match table.remove("stats") {
            Some(toml::Value::String(p)) => Some(PathBuf::from(p)),
            None => None,
            Some(_) => return Err(D::Error::custom(format!("bus {name:?}: stats must be a path"))),
        };
        let v = toml::Value::Table(table.clone());
        let source = if table.contains_key("candump") {
            BusSource::Candump(
                CandumpConfig::deserialize(v).map_err(|e| D::Error::custom(format!("bus {name:?}: {e}")))?,
            )
        } else if table.contains_key("interface") {
            #[cfg(target_os = "linux")]
            {
                BusSource::Live(
                    SocketCanConfig::deserialize(v).map_err(|e| D::Error::custom(format!("bus {name:?}: {e}")))?,
                )
            }
            #[cfg(not(target_os = "linux"))]
            {
                drop(v);
                return Err(D::Error::custom(format!("bus {name:?}: live SocketCAN interfaces need Linux")));
            }
        } else {
            return Err(D::Error::custom(format!(
                "bus {name:?} names no traffic: give candump = \"log\" or interface = \"can0\""
            )));
        };
        Ok(BusSpec { name, stats, source })
    }
}

/// Each `[[bus]]` table of a scene's text with the line (1-based) where it starts (toml's
/// span; empty if the text has no array of bus tables).
fn bus_tables(text: &str) -> Vec<(toml::Table, usize)> {
    #[derive(Deserialize)]
    struct Buses {
        #[serde(rename = "bus", default)]
        bus: Vec<toml::Spanned<toml::Table>>,
    }
    let Ok(b) = toml::from_str::<Buses>(text) else { return Vec::new() };
    b.bus
        .into_iter()
        .map(|t| {
            let line = text.get(..t.span().start).map_or(0, |s| s.matches('\n').count()) + 1;
            (t.into_inner(), line)
        })
        .collect()
}

/// A step on the path to a key of a scene's text: a table key or an index into an array of
/// tables (`[[output]]` #2 is `Key("output"), Index(1)`).
#[derive(Clone, Copy, Debug)]
pub(crate) enum Step<'a> {
    /// A key.
    Key(&'a str),
    /// An element of an array.
    Index(usize),
}

/// The 1-based line where the key at `path` is written in `text` (of the deepest step found:
/// a key left at its default names the line of its table), `None` when not even the first
/// step is there.
pub(crate) fn key_line(text: &str, path: &[Step<'_>]) -> Option<usize> {
    use toml::de::{DeTable, DeValue};
    let root = DeTable::parse(text).ok()?;
    let mut value: Option<&DeValue<'_>> = None;
    let mut at = None;
    for step in path {
        let next = match (step, value) {
            (Step::Key(k), None) => {
                root.get_ref().iter().find(|(key, _)| key.get_ref() == k).map(|(k, v)| (k.span(), v))
            }
            (Step::Key(k), Some(DeValue::Table(t))) => {
                t.iter().find(|(key, _)| key.get_ref() == k).map(|(k, v)| (k.span(), v))
            }
            (Step::Index(i), Some(DeValue::Array(a))) => a.get(*i).map(|v| (v.span(), v)),
            _ => None,
        };
        let Some((span, v)) = next else { break };
        at = Some(span.start);
        value = Some(v.get_ref());
    }
    at.map(|start| text.get(..start).map_or(0, |s| s.matches('\n').count()) + 1)
}

/// A parse error raised inside a `[[bus]]` table, at the line of that bus (toml points such
/// errors at the first `[[bus]]` of the file, the array's span): the first bus table that
/// does not deserialize.
fn bus_error_at_its_line(text: &str, message: &str) -> Option<(usize, String)> {
    let message = message.trim_end();
    if !(message.starts_with("bus ") || message.starts_with("a [[bus]]")) {
        return None;
    }
    let (_, line) =
        bus_tables(text).into_iter().find(|(t, _)| BusSpec::deserialize(toml::Value::Table(t.clone())).is_err())?;
    Some((line, message.replace('\n', " ")))
}

/// A TOML or scene-structure error as one line at the line it points to
/// (`scene.toml:7: unknown field `x`, expected …`).
fn parse_error(text: &str, origin: &Path, e: &toml::de::Error) -> Error {
    if let Some((line, reason)) = bus_error_at_its_line(text, e.message()) {
        return Error::SceneAt { path: origin.to_path_buf(), line, reason };
    }
    let reason = e.message().trim_end().replace('\n', " ");
    match e.span() {
        Some(span) => Error::SceneAt {
            path: origin.to_path_buf(),
            line: text.get(..span.start).map_or(0, |s| s.matches('\n').count()) + 1,
            reason,
        },
        None => Error::Scene { path: origin.to_path_buf(), reason },
    }
}

impl<'de> Deserialize<'de> for SourceSpec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error as _;
        let table = toml::Table::deserialize(d)?;
        let kinds: Vec<&str> = SOURCE_KINDS.iter().copied().filter(|k| table.contains_key(*k)).collect();
        if kinds.len() > 1 {
            return Err(D::Error::custom(format!("a source has one kind; this one names {}", kinds.join(" and "))));
        }
        let v = toml::Value::Table(table);
        match kinds.first().copied() {
            Some("csv") => return CsvSourceConfig::deserialize(v).map(SourceSpec::Csv).map_err(D::Error::custom),
            Some("npy") => return NpySourceConfig::deserialize(v).map(SourceSpec::Npy).map_err(D::Error::custom),
            Some("arrow") => return ArrowIpcConfig::deserialize(v).map(SourceSpec::Arrow).map_err(D::Error::custom),
            Some("rosbag") => return BagSourceConfig::deserialize(v).map(SourceSpec::Rosbag).map_err(D::Error::custom),
            Some("mcap") => return BagSourceConfig::deserialize(v).map(SourceSpec::Mcap).map_err(D::Error::custom),
            Some("bus") => {
                return match v.as_table().map(|t| (t.len(), t.get("bus"))) {
                    Some((1, Some(toml::Value::String(b)))) => Ok(SourceSpec::Bus { bus: b.clone() }),
                    _ => Err(D::Error::custom("a bus source is just { bus = \"<name of a [[bus]]>\" }")),
                }
            }
            _ => {}
        }
        Err(D::Error::custom(format!(
            "a source names its kind with one of the keys {}: e.g. source = {{ csv = \"recording.csv\", ... }}",
            SOURCE_KINDS.join(", ")
        )))
    }
}

impl SourceSpec {
    /// The source's fixed sample rate (Hz), when it has one.
    pub fn rate_hz(&self) -> Option<f64> {
        match self {
            SourceSpec::Csv(c) => c.rate_hz,
            SourceSpec::Npy(c) => c.rate_hz,
            SourceSpec::Arrow(c) => c.rate_hz,
            SourceSpec::Bus { .. } | SourceSpec::Rosbag(_) | SourceSpec::Mcap(_) => None,
        }
    }

    /// The file the source reads.
    pub fn path(&self) -> &Path {
        match self {
            SourceSpec::Csv(c) => &c.path,
            SourceSpec::Npy(c) => &c.path,
            SourceSpec::Arrow(c) => &c.path,
            SourceSpec::Rosbag(c) | SourceSpec::Mcap(c) => &c.path,
            SourceSpec::Bus { bus } => Path::new(bus),
        }
    }

    /// The kind's key (`csv`, `npy`, `arrow`).
    pub fn kind(&self) -> &'static str {
        match self {
            SourceSpec::Csv(_) => "csv",
            SourceSpec::Npy(_) => "npy",
            SourceSpec::Arrow(_) => "arrow",
            SourceSpec::Bus { .. } => "bus",
            SourceSpec::Rosbag(_) => "rosbag",
            SourceSpec::Mcap(_) => "mcap",
        }
    }

    fn validate(&self) -> Result<(), String> {
        match self {
            SourceSpec::Csv(c) => c.validate().map_err(|e| e.to_string()),
            SourceSpec::Npy(c) => match (c.rate_hz, &c.timestamps) {
                (Some(_), Some(_)) => Err("give rate_hz or timestamps, not both".into()),
                (Some(r), None) => gradtac_stream::Timestamp::check_rate_hz(r),
                (None, None) => Err("give rate_hz (Hz) or timestamps (a 1-D .npy)".into()),
                _ => Ok(()),
            },
            SourceSpec::Arrow(c) => c.layout(gradtac_stream::SensorId::new("_")).map(|_| ()).map_err(|e| e.to_string()),
            SourceSpec::Bus { .. } => Ok(()),
            SourceSpec::Rosbag(c) | SourceSpec::Mcap(c) if c.topic.is_empty() => {
                Err("topic = \"\" names no topic".into())
            }
            SourceSpec::Rosbag(_) | SourceSpec::Mcap(_) => Ok(()),
        }
    }
}

/// Stage settings, one table per stage (`[stages.<tap>]`); a missing table means the stage's
/// defaults, except for the event chain's six keys, which take the values of
/// `[stages.locate] event_chain` ([`EventChain`]; `press_release` by default) when the scene
/// leaves them unset. Each table is the stage's own configuration struct, documented with the
/// stage.
///
/// The event chain's values follow `locate.method` and `locate.event_chain` wherever the
/// settings are used: every builder ([`crate::chain::SensorChain::build`],
/// [`crate::chain::event_track_stages`], `explain`, the calibrations) reads
/// [`StageSettings::resolved`]. So code may change the method or the chain at any time, e.g.
/// `StageSettings { locate, ..Default::default() }`, and builds the stages a scene with that
/// method and chain parses to (see [`EventChainKeys`] for which keys follow).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageSettings {
    /// Min–max normalisation ([`NormaliseConfig`]).
    #[serde(default)]
    pub normalise: NormaliseConfig,
    /// Savitzky–Golay smoothing / derivatives ([`SavGolConfig`]).
    #[serde(default)]
    pub savgol: SavGolConfig,
    /// Log-change events ([`EventsConfig`]).
    #[serde(default)]
    pub events: EventsConfig,
    /// Event windows ([`WindowConfig`]).
    #[serde(default)]
    pub window: WindowConfig,
    /// Interpolated surfaces ([`InterpolateConfig`]).
    #[serde(default)]
    pub surface: InterpolateConfig,
    /// Maximal contours ([`ContourConfig`]).
    #[serde(default)]
    pub contour: ContourConfig,
    /// How contact is located — `centroid`, `raw_contour` or `events` — and the calibrated
    /// change detector of the first two ([`LocateConfig`]).
    #[serde(default)]
    pub locate: LocateConfig,
    /// Contact tracks ([`TrackConfig`]).
    #[serde(default)]
    pub track: TrackConfig,
    /// A calibrated force model ([`ForceSettings`]; required by the force tap).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force: Option<ForceSettings>,
    /// Edge-following servo commands ([`ServoConfig`]).
    #[serde(default)]
    pub servo: ServoConfig,
    /// Two-finger slip ([`SlipConfig`]: which two sensors, thresholds).
    #[serde(default)]
    pub slip: SlipConfig,
    /// One-fingertip slip direction ([`DosSettings`]; required by the dos tap).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dos: Option<DosSettings>,
    /// Bookkeeping, not a setting: which of the event chain's keys the scene set itself, and
    /// which method and chain the others hold the values of ([`EventChainKeys`]). Leave it to
    /// `..Default::default()` or the scene's parse.
    #[serde(skip)]
    pub chain_keys: EventChainKeys,
}

/// The settings of a scene with no `[stages.*]` table: every stage's defaults, with the event
/// chain's keys from the default [`EventChain`] (`press_release`) for the default method.
impl Default for StageSettings {
    fn default() -> Self {
        let mut st = StageSettings {
            normalise: Default::default(),
            savgol: Default::default(),
            events: Default::default(),
            window: Default::default(),
            surface: Default::default(),
            contour: Default::default(),
            locate: Default::default(),
            track: Default::default(),
            force: None,
            servo: Default::default(),
            slip: Default::default(),
            dos: None,
            chain_keys: EventChainKeys::default(),
        };
        st.resolve();
        st
    }
}

/// The event-chain keys a scene may set (`[stages.<table>] <key>`; an empty key: the table
/// itself, or for `normalise` also an output tapping it), in [`EventChainKeys`]' order.
pub const EVENT_CHAIN_KEYS: [(&str, &str); 8] = [
    ("normalise", ""),
    ("events", "polarity"),
    ("window", "kind"),
    ("window", "frames"),
    ("window", "duration_ms"),
    ("surface", "grid.nx"),
    ("contour", "min_peak"),
    ("contour", "min_area_mm2"),
];

/// Which of the event chain's keys follow `[stages.locate] event_chain` ([`EventChain`]) and
/// `method` (the [`StageSettings::chain_keys`] bookkeeping).
///
/// The keys: `[stages.normalise] bypass` (set when the scene has a `[stages.normalise]` table
/// or a `normalise` output), `[stages.events] polarity`, `[stages.window] kind` (set also by a
/// window `frames` / `duration_ms`: a size alone asks for the stages' sized `sliding` window),
/// `[stages.surface] grid.nx`, `[stages.contour] min_peak` and `min_area_mm2` — the last four
/// under `method = "raw_contour"` the stages' own defaults (the `paper` chain's values), since
/// that method's window, surface and contour are the raw change's.
///
/// A key follows the chain unless the scene set it, or code changed it from the value the
/// chain gave it: [`StageSettings::resolved`] gives every key that still holds the chain's
/// value for the method and chain last resolved the value for the current ones. (So a key
/// that code sets to exactly the value the chain had given it still follows the chain.)
/// `Default` is the state of freshly deserialised tables (the stages' own defaults, nothing
/// set); [`StageSettings::default`] and [`Scene::from_toml`] resolve from there. Its `Debug`
/// prints no state: settings with the same values print the same.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct EventChainKeys {
    /// The chain the unset keys hold the values of, and whether for `raw_contour`.
    holds: (EventChain, bool),
    /// Per [`EVENT_CHAIN_KEYS`] entry: the scene sets it.
    set: [bool; 8],
}

impl Default for EventChainKeys {
    fn default() -> Self {
        EventChainKeys { holds: (EventChain::Paper, false), set: [false; 8] }
    }
}

impl std::fmt::Debug for EventChainKeys {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("EventChainKeys { .. }")
    }
}

impl StageSettings {
    /// The settings of a scene whose only `[stages.*]` keys are `[stages.locate] method` and
    /// `event_chain`: every stage's defaults, with the event chain's values resolved for that
    /// method and chain (the same as setting both on [`StageSettings::default`], resolved).
    pub fn for_method(method: LocateMethod, chain: EventChain) -> StageSettings {
        let mut st = StageSettings::default();
        st.locate.method = method;
        st.locate.event_chain = chain;
        st.resolve();
        st
    }

    /// The settings in effect: the event chain's keys that follow the chain
    /// ([`EventChainKeys`]) given its values for the current `locate.method` and
    /// `locate.event_chain`; every other value as it is. What every builder and `explain`
    /// read; the fields of a parsed scene or of [`StageSettings::default`] are already
    /// resolved until code changes the method or the chain.
    pub fn resolved(&self) -> StageSettings {
        let mut st = self.clone();
        st.resolve();
        st
    }

    /// [`StageSettings::resolved`] in place.
    fn resolve(&mut self) {
        let now = (self.locate.event_chain, self.locate.method == LocateMethod::RawContour);
        let was = self.chain_keys.holds;
        if was == now {
            return;
        }
        let [normalise, polarity, kind, frames, duration, nx, peak, area] = self.chain_keys.set;
        // raw_contour's window, surface and contour are the raw change's, not the event chain's:
        // they keep the stages' own defaults (the `paper` chain's values)
        let spatial = |(chain, raw): (EventChain, bool)| if raw { EventChain::Paper } else { chain };
        let (old, new, old_s, new_s) = (was.0, now.0, spatial(was), spatial(now));
        fn follow<T: PartialEq>(set: bool, key: &mut T, old: T, new: T) {
            if !set && *key == old {
                *key = new;
            }
        }
        follow(normalise, &mut self.normalise.bypass, old.normalise_bypass(), new.normalise_bypass());
        follow(polarity, &mut self.events.polarity, old.polarity(), new.polarity());
        follow(kind || frames || duration, &mut self.window.kind, old_s.window_kind(), new_s.window_kind());
        follow(nx, &mut self.surface.grid.nx, old_s.grid_nx(), new_s.grid_nx());
        follow(peak, &mut self.contour.min_peak, old_s.min_peak(), new_s.min_peak());
        follow(area, &mut self.contour.min_area_mm2, old_s.min_area_mm2(), new_s.min_area_mm2());
        self.chain_keys.holds = now;
    }
}

/// Whether a scene's parsed TOML sets `[stages.<table>] <key>` (`key` may be dotted, `grid.nx`).
fn sets_stage_key(top: Option<&toml::Table>, (table, key): &(&str, &str)) -> bool {
    let mut at = top.and_then(|v| v.get("stages")).and_then(|s| s.get(table));
    for part in key.split('.').filter(|p| !p.is_empty()) {
        at = at.and_then(|t| t.get(part));
    }
    at.is_some()
}

/// `[stages.dos]`: the one-fingertip slip-direction classifier.
///
/// ```toml
/// [stages.dos]
/// model = "dos-model.json"     # written by `gradtac calibrate`
/// decision_frames = 250        # one decision per 250 frames; omit for one per recording
/// hop_frames = 10              # optional: a decision every 10 frames over the last 250 (sliding)
/// early = true                 # optional, with hop_frames: answers before 250 frames have arrived
/// ```
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DosSettings {
    /// The model file (JSON), relative to the scene.
    pub model: PathBuf,
    /// Frames per decision (≥ 1); `None`: one decision at the end of each recording.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub decision_frames: Option<u64>,
    /// Sliding decisions: one every `hop_frames` frames (≥ 1) over the last `decision_frames`
    /// frames, each extracted as a fresh recording (needs `decision_frames`; see
    /// `gradtac_stages::dos::DosClassifier`). `None`: tumbling spans.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hop_frames: Option<u64>,
    /// With `hop_frames`: answer from the first hop after contact, each decision over all
    /// frames so far until `decision_frames` have arrived (`DosClassifier::with_early_decisions`;
    /// accuracy by time since contact in `gradtac_stages::dos`). Default false.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub early: bool,
}

/// One output: a tap on a stage, written to a file.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// The stage whose output is written (see [`Tap`]).
    pub tap: String,
    /// The Parquet file to write.
    pub path: PathBuf,
    /// Only these sensors (default: all).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensors: Option<Vec<String>>,
    /// Rows per Parquet row group (default 65 536).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub row_group_size: Option<usize>,
    /// Write an archive directory at `path` instead of one file: rolling files
    /// (`roll_bytes`, `roll_seconds`, `roll_rows`) and optional hive partitioning
    /// (`partition = "sensor"` → `path/sensor=ff/part-000000.parquet`); see
    /// [`ArchiveConfig`] and `docs/schemas.md`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub archive: Option<ArchiveConfig>,
}

impl Scene {
    /// Parse a scene from TOML text; relative paths will resolve against `base_dir`.
    pub fn from_toml(text: &str, base_dir: impl Into<PathBuf>, origin: &Path) -> Result<Self, Error> {
        let mut scene: Scene = toml::from_str(text).map_err(|e| parse_error(text, origin, &e))?;
        let top = toml::from_str::<toml::Table>(text).ok();
        let taps_normalise = scene.outputs.iter().any(|o| o.tap == "normalise");
        scene.stages.chain_keys.set =
            EVENT_CHAIN_KEYS.map(|k| sets_stage_key(top.as_ref(), &k) || (k == ("normalise", "") && taps_normalise));
        scene.stages.resolve();
        scene.base_dir = base_dir.into();
        scene.text = text.to_string();
        scene.origin = origin.to_path_buf();
        scene.validate(origin)?;
        scene.load_files()?;
        Ok(scene)
    }

    /// Read and parse a scene file.
    pub fn load(path: &Path) -> Result<Self, Error> {
        let text = crate::guard::read_text_capped(path, crate::guard::MAX_SCENE_BYTES)?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Self::from_toml(&text, base, path)
    }

    /// Read the model files the settings name ([`LoadedFiles`]).
    fn load_files(&mut self) -> Result<(), Error> {
        if let Some(ForceSettings { model: ForceModelSpec::File(p), .. }) = &self.stages.force {
            self.loaded.force = Some(read_force_file(&self.resolve(p))?);
        }
        if let Some(p) = &self.stages.locate.baseline {
            self.loaded.tare = Some(read_tare_file(&self.resolve(p))?);
        }
        Ok(())
    }

    /// Whether the force tap reads raw frames (a changes-based model file) rather than
    /// contours.
    pub fn force_reads_frames(&self) -> bool {
        self.loaded.force.as_ref().is_some_and(|f| f.model.reads_changes())
    }

    /// A path from the scene, resolved against its directory.
    pub fn resolve(&self, p: &Path) -> PathBuf {
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.base_dir.join(p)
        }
    }

    /// An error about the setting at `path`, naming the scene file and the line of its key
    /// (`scene.toml:12: …`; without a line when the scene has no text, e.g. built in code).
    pub(crate) fn at(&self, path: &[Step<'_>], reason: impl Into<String>) -> Error {
        let reason = reason.into();
        match key_line(&self.text, path) {
            Some(line) => Error::SceneAt { path: self.origin.clone(), line, reason },
            None => Error::Scene { path: self.origin.clone(), reason },
        }
    }

    /// The layout of a sensor (built in, or loaded from its CSV).
    pub fn layout(&self, sensor: &SensorSpec) -> Result<Layout, Error> {
        if gradtac_stream::layout::BUILTIN_LAYOUTS.contains(&sensor.layout.as_str()) {
            return Ok(Layout::builtin(&sensor.layout)?);
        }
        Ok(Layout::from_csv_path(&self.resolve(Path::new(&sensor.layout)))?)
    }

    fn validate(&self, origin: &Path) -> Result<(), Error> {
        let bad = |reason: String| Error::Scene { path: origin.to_path_buf(), reason };
        if self.sensors.is_empty() {
            return Err(bad("no [[sensor]]".into()));
        }
        for (i, s) in self.sensors.iter().enumerate() {
            if s.name.is_empty() {
                return Err(bad(format!("sensor #{} has an empty name", i + 1)));
            }
            if self.sensors[..i].iter().any(|o| o.name == s.name) {
                return Err(bad(format!("sensor {:?} is declared twice", s.name)));
            }
            s.source.validate().map_err(|r| bad(format!("sensor {:?}: source: {r}", s.name)))?;
            if let SourceSpec::Bus { bus } = &s.source {
                if !self.buses.iter().any(|b| &b.name == bus) {
                    return Err(bad(format!("sensor {:?} reads bus {bus:?}, which is not declared", s.name)));
                }
            }
        }
        let lines = bus_tables(&self.text);
        for (i, b) in self.buses.iter().enumerate() {
            // the line of this [[bus]] (toml's span of its table)
            let bad = |r: String| match lines.get(i) {
                Some(&(_, line)) => Error::SceneAt { path: origin.to_path_buf(), line, reason: r },
                None => bad(r),
            };
            if self.buses[..i].iter().any(|o| o.name == b.name) {
                return Err(bad(format!("bus {:?} is declared twice", b.name)));
            }
            let codec = match &b.source {
                BusSource::Candump(c) => {
                    // the replay speed, at the line of its key
                    if let Err(r) = gradtac_io::can::stream::check_replay_speed(c.speed) {
                        let key = [Step::Key("bus"), Step::Index(i), Step::Key("speed")];
                        return Err(match key_line(&self.text, &key) {
                            Some(line) => Error::SceneAt {
                                path: origin.to_path_buf(),
                                line,
                                reason: format!("bus {:?}: {r}", b.name),
                            },
                            None => bad(format!("bus {:?}: {r}", b.name)),
                        });
                    }
                    &c.codec
                }
                #[cfg(target_os = "linux")]
                BusSource::Live(c) => &c.codec,
            };
            CanCodec::try_new(codec).map_err(|e| bad(format!("bus {:?}: {e}", b.name)))?;
        }
        if self.outputs.is_empty() {
            return Err(bad("no [[output]]: nothing would be computed".into()));
        }
        let l = &self.stages.locate;
        if l.method == gradtac_stages::locate::LocateMethod::Events
            && l.event_tau_sigmas > 0.0
            && self.stages.events.threshold != gradtac_stages::events::Threshold::default()
        {
            return Err(bad(format!(
                "[stages.events] threshold is set, but under [stages.locate] method = \"events\" the threshold is \
                 measured from each taxel's noise (event_tau_sigmas = {}); set [stages.locate] event_tau_sigmas = 0 \
                 to use the given threshold",
                l.event_tau_sigmas
            )));
        }
        for (i, o) in self.outputs.iter().enumerate() {
            if Tap::parse(&o.tap).is_none() {
                return Err(bad(format!(
                    "output #{} taps {:?}; known taps: {}",
                    i + 1,
                    o.tap,
                    Tap::names().join(", ")
                )));
            }
            for name in o.sensors.iter().flatten() {
                if !self.sensors.iter().any(|s| &s.name == name) {
                    return Err(bad(format!("output #{} names sensor {name:?}, which is not declared", i + 1)));
                }
            }
            if self.outputs[..i].iter().any(|p| p.path == o.path) {
                return Err(bad(format!("two outputs write {}", o.path.display())));
            }
            // sink settings, checked here so that `explain` refuses what `run` would
            let out = |key: &str, r: String| {
                let at = [Step::Key("output"), Step::Index(i), Step::Key(key)];
                self.at(&at, format!("output #{} ({}): {r}", i + 1, o.path.display()))
            };
            if let Some(n) = o.row_group_size {
                gradtac_io::parquet_sink::check_row_group_size(n)
                    .map_err(|e| out("row_group_size", e.to_string().replace("invalid configuration: ", "")))?;
            }
            if let Some(a) = &o.archive {
                a.check().map_err(|(key, r)| {
                    let at = [Step::Key("output"), Step::Index(i), Step::Key("archive"), Step::Key(key)];
                    self.at(&at, format!("output #{} ({}): archive: {r}", i + 1, o.path.display()))
                })?;
            }
        }
        Ok(())
    }
}

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
    /// Force estimates from the maximal contour's area (needs a calibrated model).
    Force,
    /// Edge-following motion commands from the contact's offset.
    Servo,
    /// Two-finger slip events (a pair of sensors: `[stages.slip] first`, `second`).
    Slip,
    /// One-fingertip slip direction (BioTacSP-DoS classes) from a calibrated model
    /// (`[stages.dos] model = "…json"`, written by `gradtac calibrate`); on raw frames.
    Dos,
}

impl Tap {
    /// Every tap, in chain order.
    pub const ALL: [Tap; 12] = [
        Tap::Source,
        Tap::Normalise,
        Tap::Savgol,
        Tap::Events,
        Tap::Window,
        Tap::Surface,
        Tap::Contour,
        Tap::Track,
        Tap::Force,
        Tap::Servo,
        Tap::Slip,
        Tap::Dos,
    ];

    /// The stage whose output this one consumes (`None` for the source). Stages form a tree:
    /// the chain source → … → contour → track, with `force` on contours, `servo` and `slip` on
    /// tracks.
    pub fn parent(self) -> Option<Tap> {
        Some(match self {
            Tap::Source => return None,
            Tap::Normalise | Tap::Dos => Tap::Source,
            Tap::Savgol => Tap::Normalise,
            Tap::Events => Tap::Savgol,
            Tap::Window => Tap::Events,
            Tap::Surface => Tap::Window,
            Tap::Contour => Tap::Surface,
            Tap::Track | Tap::Force => Tap::Contour,
            Tap::Servo | Tap::Slip => Tap::Track,
        })
    }

    /// This stage and every stage it depends on.
    pub fn with_ancestors(self) -> impl Iterator<Item = Tap> {
        std::iter::successors(Some(self), |t| t.parent())
    }

    /// The parent under a contact-location method (`[stages.locate] method`): `centroid` and
    /// `fit` make contours straight from the source frames, `raw_contour` makes the window (the
    /// per-taxel relative changes) from them; `events` is [`Tap::parent`].
    pub fn parent_in(self, method: LocateMethod) -> Option<Tap> {
        match (method, self) {
            (LocateMethod::Centroid | LocateMethod::Fit, Tap::Contour) | (LocateMethod::RawContour, Tap::Window) => {
                Some(Tap::Source)
            }
            _ => self.parent(),
        }
    }

    /// This stage and every stage it depends on under `method` (see [`Tap::parent_in`]).
    pub fn with_ancestors_in(self, method: LocateMethod) -> impl Iterator<Item = Tap> {
        std::iter::successors(Some(self), move |t| t.parent_in(method))
    }

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
            Tap::Force => "force",
            Tap::Servo => "servo",
            Tap::Slip => "slip",
            Tap::Dos => "dos",
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

#[cfg(test)]
mod tests {
    use super::*;

    const ISSUE_EXAMPLE: &str = r#"
[[sensor]]
name = "ff"
layout = "biotac-sp"
source = { csv = "recording.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }

[stages.normalise]
calibrate_frames = 20

[[output]]
tap = "normalise"
path = "out/normalised.parquet"
"#;

    /// A scene of one fingertip tapping `events`, `surface` and `track` (every event-chain key
    /// in use under every method), with the given `[stages.*]` text.
    fn chain_scene(stages: &str) -> Scene {
        let text = format!(
            "[[sensor]]\nname = \"ff\"\nsource = {{ csv = \"x.csv\", columns = \"ff_e{{1..24}}\", rate_hz = 100.0 }}\n\
             {stages}[[output]]\ntap = \"events\"\npath = \"e.parquet\"\n[[output]]\ntap = \"surface\"\n\
             path = \"s.parquet\"\n[[output]]\ntap = \"track\"\npath = \"t.parquet\"\n"
        );
        Scene::from_toml(&text, ".", Path::new("s.toml")).unwrap()
    }

    /// No trap: `locate.method` and `locate.event_chain` set on [`StageSettings::default`]
    /// (nothing else, no call after) build what a scene with that method and chain parses to —
    /// the same resolved settings and the same `explain` text of the built plan (every
    /// effective value, the chain named) — for every method × chain, and back again; and
    /// [`StageSettings::for_method`] is those settings.
    #[test]
    fn a_method_set_on_the_defaults_builds_what_the_scene_parses_to() {
        use gradtac_stages::locate::{EventChain, LocateMethod};
        let methods = [LocateMethod::Centroid, LocateMethod::Events, LocateMethod::RawContour, LocateMethod::Fit];
        let explain = |scene: &Scene| crate::Plan::new(scene).unwrap().explain(scene);
        for method in methods {
            for chain in [EventChain::PressRelease, EventChain::Paper] {
                let what = format!("{method:?} {chain:?}");
                let parsed = chain_scene(&format!(
                    "[stages.locate]\nmethod = \"{}\"\nevent_chain = \"{}\"\n",
                    method.name(),
                    chain.name()
                ));
                let mut code = StageSettings::default();
                code.locate.method = method;
                code.locate.event_chain = chain;
                assert_eq!(format!("{:?}", code.resolved()), format!("{:?}", parsed.stages), "{what}");
                let one = StageSettings::for_method(method, chain);
                assert_eq!(format!("{:?}", one), format!("{:?}", parsed.stages), "{what}");
                let mut scene = chain_scene("");
                scene.stages = code.clone();
                let text = explain(&scene);
                assert_eq!(text, explain(&parsed), "{what}");
                assert!(text.contains(&format!("event chain {}", chain.name())), "{what}: {text}");
                // the struct-update form, and a detour through every other method and chain
                let locate = LocateConfig { method, event_chain: chain, ..Default::default() };
                let update = StageSettings { locate, ..Default::default() };
                assert_eq!(format!("{:?}", update.resolved()), format!("{:?}", parsed.stages), "{what}");
                for other in methods {
                    let mut detour = code.clone();
                    detour.locate.method = other;
                    detour.locate.event_chain = EventChain::Paper;
                    detour = detour.resolved();
                    detour.locate.method = method;
                    detour.locate.event_chain = chain;
                    assert_eq!(format!("{:?}", detour.resolved()), format!("{:?}", parsed.stages), "{what} {other:?}");
                }
            }
        }
        // raw_contour keeps the stages' own window, surface and contour under either chain
        let raw = StageSettings::for_method(LocateMethod::RawContour, EventChain::PressRelease);
        assert_eq!((raw.surface.grid.nx, raw.contour.min_area_mm2), (64, 1.0));
    }

    /// A key set in code, or by the scene, stays whatever the method and chain become; the
    /// keys nobody set follow.
    #[test]
    fn keys_set_in_code_or_by_the_scene_do_not_follow_the_chain() {
        use gradtac_stages::locate::{EventChain, LocateMethod};
        let mut code = StageSettings::default();
        code.contour.min_peak = 3.0;
        code.locate.method = LocateMethod::Events;
        code.locate.event_chain = EventChain::Paper;
        let r = code.resolved();
        assert_eq!((r.contour.min_peak, r.contour.min_area_mm2, r.surface.grid.nx), (3.0, 1.0, 64));
        // the scene sets min_peak to the default chain's own value: it stays under `paper`
        let mut scene = chain_scene("[stages.locate]\nmethod = \"events\"\n[stages.contour]\nmin_peak = 6\n");
        scene.stages.locate.event_chain = EventChain::Paper;
        let r = scene.stages.resolved();
        assert_eq!((r.contour.min_peak, r.contour.min_area_mm2, r.surface.grid.nx), (6.0, 1.0, 64));
        assert!(crate::Plan::new(&scene).unwrap().explain(&scene).contains("min peak 6, min area 1 mm²"));
        // a window given a size by the scene keeps the stages' sized sliding window
        let mut scene = chain_scene(
            "[stages.locate]\nmethod = \"events\"\nevent_chain = \"paper\"\n[stages.window]\nframes = 20\n",
        );
        scene.stages.locate.event_chain = EventChain::PressRelease;
        assert_eq!(scene.stages.resolved().window.kind, gradtac_stages::window::WindowKind::Sliding);
    }

    /// Deserialised tables hold the stages' own defaults, which must be the `paper` chain's
    /// values: the state [`EventChainKeys::default`] says they hold.
    #[test]
    fn the_stages_defaults_are_the_paper_chain() {
        use gradtac_stages::locate::EventChain;
        let p = EventChain::Paper;
        assert_eq!(NormaliseConfig::default().bypass, p.normalise_bypass());
        assert_eq!(EventsConfig::default().polarity, p.polarity());
        assert_eq!(WindowConfig::default().kind, p.window_kind());
        assert_eq!(InterpolateConfig::default().grid.nx, p.grid_nx());
        assert_eq!(ContourConfig::default().min_peak, p.min_peak());
        assert_eq!(ContourConfig::default().min_area_mm2, p.min_area_mm2());
    }

    #[test]
    fn the_issue_example_parses() {
        let s = Scene::from_toml(ISSUE_EXAMPLE, "/data", Path::new("scene.toml")).unwrap();
        assert_eq!(s.sensors[0].name, "ff");
        assert_eq!(s.stages.normalise.calibrate_frames, Some(20));
        assert_eq!(s.resolve(&s.outputs[0].path), PathBuf::from("/data/out/normalised.parquet"));
        assert_eq!(s.layout(&s.sensors[0]).unwrap().len(), 24);
    }

    #[test]
    fn mistakes_are_named() {
        let err = |t: &str| Scene::from_toml(t, ".", Path::new("s.toml")).unwrap_err().to_string();
        assert!(err(&ISSUE_EXAMPLE.replace("calibrate_frames", "calibrate_frame")).contains("unknown field"));
        assert!(err(&ISSUE_EXAMPLE.replace("tap = \"normalise\"", "tap = \"normalize\"")).contains("known taps"));
        assert!(err(&ISSUE_EXAMPLE.replace(", rate_hz = 100.0", "")).contains("rate_hz"));
        assert!(err(&ISSUE_EXAMPLE.replace("csv = ", "cvs = ")).contains("kind"));
        assert!(err(
            &ISSUE_EXAMPLE.replace("path = \"out/normalised.parquet\"", "path = \"o.parquet\"\nsensors = [\"th\"]")
        )
        .contains("\"th\""));
        assert!(err("").contains("no [[sensor]]"));
    }
}

#[cfg(test)]
mod bus_line_tests {
    use super::*;

    fn err(text: &str) -> String {
        Scene::from_toml(text, ".", Path::new("s.toml")).unwrap_err().to_string()
    }

    /// `[[bus]]` errors name the line of their own bus (toml pointed parse errors inside any
    /// bus at the first `[[bus]]`, and validation errors had no line).
    #[test]
    fn bus_errors_name_the_line_of_their_bus() {
        let head =
            "[[sensor]]\nname = \"ff\"\nsource = { bus = \"b\" }\n[[output]]\ntap = \"source\"\npath = \"o.parquet\"\n";
        let bus = |name: &str, extra: &str| {
            format!(
                "\n[[bus]]\nname = \"{name}\"\ncandump = \"l.log\"\n{extra}codec = {{ preset = {{ kind = \"biotac-mux\", sensors = [\"ff\"] }} }}\n"
            )
        };
        let two = |second: &str| format!("{head}{}{}", bus("a", ""), second);
        // lines: the first [[bus]] at 8, the second at 13
        let e = err(&two(&bus("b", "bogus = 1\n")));
        assert!(e.starts_with("s.toml:13: bus \"b\": unknown field `bogus`"), "{e}");
        let e = err(&format!("{head}{}{}", bus("b", ""), bus("b", "")));
        assert_eq!(e, "s.toml:13: bus \"b\" is declared twice");
        let e = err(&two("\n[[bus]]\ncandump = \"l.log\"\n"));
        assert_eq!(e, "s.toml:13: a [[bus]] needs name = \"…\"");
        let custom = "codec = { sensors = [{ name = \"ff\", taxels = 4294967295, messages = [] }] }\n";
        let e = err(&format!("{head}{}\n[[bus]]\nname = \"b\"\ncandump = \"l.log\"\n{custom}", bus("a", "")));
        assert!(e.starts_with("s.toml:13: bus \"b\": invalid configuration") && e.contains("4294967295"), "{e}");
        // other parse errors: one line, at toml's position
        let e = err(&format!("{head}{}x = [", bus("a", "")));
        assert!(e.starts_with("s.toml:12: ") && !e.contains('\n'), "{e}");
    }
}
