//! The view's thread: [`Rec`]s to rerun archetypes (entity layout in the module docs).

use super::rec::{Clock, FrameKind, Rec};
use gradtac_stream::Layout;
use rerun::blueprint::{
    Blueprint, BlueprintActivation, ContainerLike, Horizontal, Spatial2DView, Tabs, TextLogView, TimeSeriesView,
    Vertical,
};
use rerun::{EntityPath, EntityPathPart, RecordingStream, TimeCell};
use std::collections::{BTreeMap, BTreeSet, HashMap};

/// The duration timeline (sources with their own origin).
pub const TIME: &str = "time";
/// The timestamp timeline (Unix-epoch sources).
pub const UTC: &str = "utc";

/// Taxel marker radius on the layout plane (mm).
const TAXEL_RADIUS_MM: f32 = 1.0;
/// Contact marker radius when the point has no uncertainty (mm).
const CONTACT_RADIUS_MM: f32 = 0.5;

/// What the logger knows of a sensor.
#[derive(Default)]
struct SensorState {
    clock: Option<Clock>,
    layout: Option<Layout>,
    /// Per frame kind: the first frame (raw: the baseline colours are relative to) and the
    /// largest change seen so far (the colour scale).
    colour: HashMap<FrameKind, (Vec<f64>, f64)>,
    /// Entities whose static parts (series names, taxel positions) were logged.
    statics: BTreeSet<String>,
    /// Series entities (`s/series/<name>`) seen: one blueprint tab each.
    series: BTreeSet<String>,
    has_log: bool,
    /// The surface grid whose placement was logged.
    grid: Option<(usize, usize, [u64; 4])>,
}

pub struct Logger {
    rec: RecordingStream,
    blueprint: bool,
    sensors: BTreeMap<String, SensorState>,
    slip: bool,
    /// The layout of the last blueprint sent (sensors, their series, log, slip).
    sent: Option<String>,
}

fn path(root: &str, parts: &[&str]) -> EntityPath {
    let mut v = vec![EntityPathPart::new(root)];
    v.extend(parts.iter().map(|p| EntityPathPart::new(*p)));
    EntityPath::from(v)
}

/// Blue (−1) – white (0) – red (+1).
fn diverging(x: f64) -> rerun::Color {
    let x = if x.is_finite() { x.clamp(-1.0, 1.0) } else { 0.0 };
    let f = |v: f64| (255.0 * v).round() as u8;
    if x >= 0.0 {
        rerun::Color::from_rgb(255, f(1.0 - x), f(1.0 - x))
    } else {
        rerun::Color::from_rgb(f(1.0 + x), f(1.0 + x), 255)
    }
}

impl Logger {
    pub fn new(rec: RecordingStream, blueprint: bool) -> Logger {
        Logger { rec, blueprint, sensors: BTreeMap::new(), slip: false, sent: None }
    }

    fn set_time(&self, clock: Clock, t: i64) {
        self.rec.reset_time();
        // i64::MIN is rerun's "static"; a time there is one nanosecond later
        let t = t.max(i64::MIN + 1);
        match clock {
            Clock::Relative => self.rec.set_time(TIME, TimeCell::from_duration_nanos(t)),
            Clock::Utc => self.rec.set_time(UTC, TimeCell::from_timestamp_nanos_since_epoch(t)),
        }
    }

    fn state(&mut self, sensor: &str) -> &mut SensorState {
        self.sensors.entry(sensor.to_string()).or_default()
    }

    /// Set the record's time on its sensor's clock.
    fn at(&mut self, sensor: &str, t: i64) {
        let clock = self.state(sensor).clock.unwrap_or(Clock::Relative);
        self.set_time(clock, t);
    }

    fn series(&mut self, sensor: &str, name: &str) -> EntityPath {
        self.state(sensor).series.insert(name.to_string());
        path(sensor, &["series", name])
    }

    /// Log through rerun; an error (a closed viewer) is reported once by rerun itself.
    fn put<A: rerun::AsComponents + ?Sized>(&self, path: &EntityPath, a: &A) {
        if let Err(e) = self.rec.log(path.clone(), a) {
            tracing::debug!(%e, %path, "rerun log failed");
        }
    }

    fn put_static<A: rerun::AsComponents + ?Sized>(&self, path: &EntityPath, a: &A) {
        if let Err(e) = self.rec.log_static(path.clone(), a) {
            tracing::debug!(%e, %path, "rerun log failed");
        }
    }

    pub fn log(&mut self, r: Rec) {
        match r {
            Rec::Sensor { sensor, layout, clock } => {
                let s = self.state(&sensor);
                s.clock = Some(clock);
                if layout.is_some() {
                    s.layout = layout;
                    s.statics.clear();
                }
            }
            Rec::Frame { sensor, kind, t, values } => self.frame(&sensor, kind, t, &values),
            Rec::Events { sensor, t, positive, negative } => {
                let p = self.series(&sensor, "events");
                if self.state(&sensor).statics.insert("events".into()) {
                    self.put_static(
                        &p,
                        &rerun::SeriesLines::new()
                            .with_names(["+1 events", "−1 events"])
                            .with_colors([rerun::Color::from_rgb(220, 50, 40), rerun::Color::from_rgb(40, 90, 220)]),
                    );
                }
                self.at(&sensor, t);
                self.put(&p, &rerun::Scalars::new([f64::from(positive), f64::from(negative)]));
            }
            Rec::Surface { sensor, t, nx, ny, extent, values } => {
                let p = path(&sensor, &["plane", "surface"]);
                let key = (nx, ny, extent.map(f64::to_bits));
                if self.state(&sensor).grid != Some(key) {
                    // pixel (col, row) covers [col, col+1): its centre lands on the grid point
                    let [x0, x1, y0, y1] = extent;
                    let dx = (x1 - x0) / (nx.max(2) - 1) as f64;
                    let dy = (y1 - y0) / (ny.max(2) - 1) as f64;
                    self.put_static(
                        &p,
                        &rerun::Transform3D::from_translation_scale(
                            [(x0 - dx / 2.0) as f32, (y0 - dy / 2.0) as f32, 0.0],
                            rerun::Scale3D::from([dx as f32, dy as f32, 1.0]),
                        ),
                    );
                    self.state(&sensor).grid = Some(key);
                }
                self.at(&sensor, t);
                let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
                let image = rerun::DepthImage::from_data_type_and_bytes(
                    bytes,
                    [nx as u32, ny as u32],
                    rerun::ChannelDatatype::F32,
                )
                .with_colormap(rerun::components::Colormap::Viridis);
                self.put(&p, &image);
            }
            Rec::Contour { sensor, t, polygon, centroid: _, area } => {
                let p = path(&sensor, &["plane", "contour"]);
                let a = self.series(&sensor, "contact_area");
                self.at(&sensor, t);
                if let Some(area) = area.filter(|a| a.is_finite()) {
                    self.put(&a, &rerun::Scalars::new([area]));
                }
                // the taxel-centroid locator finds a contact without an outline
                match polygon {
                    Some(mut poly) if !poly.is_empty() => {
                        poly.push(poly[0]);
                        let strip: Vec<[f32; 2]> = poly.iter().map(|q| [q[0] as f32, q[1] as f32]).collect();
                        self.put(
                            &p,
                            &rerun::LineStrips2D::new([strip])
                                .with_colors([rerun::Color::from_rgb(255, 255, 255)])
                                .with_radii([0.15]),
                        );
                    }
                    _ => self.put(&p, &rerun::Clear::flat()),
                }
            }
            Rec::Contact { sensor, t, xy, sigma_mm } => {
                let p = path(&sensor, &["plane", "contact"]);
                let sp = self.series(&sensor, "contact");
                if self.state(&sensor).statics.insert("contact".into()) {
                    self.put_static(&sp, &rerun::SeriesLines::new().with_names(["x (mm)", "y (mm)"]));
                }
                self.at(&sensor, t);
                match xy {
                    Some([x, y]) => {
                        let r = sigma_mm.map_or(CONTACT_RADIUS_MM, |s| s as f32);
                        self.put(
                            &p,
                            &rerun::Points2D::new([[x as f32, y as f32]])
                                .with_radii([r])
                                .with_colors([rerun::Color::from_rgb(255, 200, 0)]),
                        );
                        self.put(&sp, &rerun::Scalars::new([x, y]));
                    }
                    None => self.put(&p, &rerun::Clear::flat()),
                }
            }
            Rec::Force { sensor, t, force_n } => {
                let p = self.series(&sensor, "force");
                if let Some(f) = force_n.filter(|f| f.is_finite()) {
                    self.at(&sensor, t);
                    self.put(&p, &rerun::Scalars::new([f]));
                }
            }
            Rec::Servo { sensor, t, motion_mm } => {
                let p = self.series(&sensor, "servo");
                if self.state(&sensor).statics.insert("servo".into()) {
                    self.put_static(&p, &rerun::SeriesLines::new().with_names(["motion x (mm)", "motion y (mm)"]));
                }
                if let Some([x, y]) = motion_mm {
                    self.at(&sensor, t);
                    self.put(&p, &rerun::Scalars::new([x, y]));
                }
            }
            Rec::Dos { sensor, t, class, posterior } => {
                let p = path(&sensor, &["log"]);
                self.state(&sensor).has_log = true;
                self.at(&sensor, t);
                let text = match posterior {
                    Some(q) => format!("slip direction {class} (posterior {q:.2})"),
                    None => format!("slip direction {class}"),
                };
                self.put(&p, &rerun::TextLog::new(text).with_level(rerun::TextLogLevel::INFO));
            }
            Rec::Slip { pair, t, onset, class, previous } => {
                self.slip = true;
                // the pair's clock: that of its sensors (the first one declared)
                let clock = self.sensors.values().find_map(|s| s.clock).unwrap_or(Clock::Relative);
                self.set_time(clock, t);
                let who = if pair.is_empty() { String::new() } else { format!("{pair}: ") };
                let lead = (t - onset) as f64 * 1e-9;
                let level = if class == "stable" { rerun::TextLogLevel::INFO } else { rerun::TextLogLevel::WARN };
                self.put(
                    &path("slip", &["log"]),
                    &rerun::TextLog::new(format!("{who}{previous} → {class} (onset {lead:.3} s earlier)"))
                        .with_level(level),
                );
                let index = ["stable", "longitudinal_up", "longitudinal_down", "rotational_cw", "rotational_ccw"]
                    .iter()
                    .position(|c| *c == class)
                    .map_or(-1.0, |i| i as f64);
                self.put(&path("slip", &["class"]), &rerun::Scalars::new([index]));
            }
        }
        self.send_blueprint();
    }

    fn frame(&mut self, sensor: &str, kind: FrameKind, t: i64, values: &[f64]) {
        let name = kind.name();
        let series = self.series(sensor, name);
        let plane = path(sensor, &["plane", name]);
        let s = self.state(sensor);
        let layout = s.layout.clone().filter(|l| l.len() == values.len());
        if s.statics.insert(name.to_string()) {
            let names: Vec<String> = match &layout {
                Some(l) => l.names().to_vec(),
                None => (1..=values.len()).map(|i| format!("e{i}")).collect(),
            };
            self.put_static(&series, &rerun::SeriesLines::new().with_names(names.clone()));
            if let Some(l) = &layout {
                let pos: Vec<[f32; 2]> = l.positions().iter().map(|p| [p[0] as f32, p[1] as f32]).collect();
                self.put_static(
                    &plane,
                    &rerun::Points2D::new(pos).with_radii([TAXEL_RADIUS_MM]).with_labels(names).with_show_labels(false),
                );
            }
        }
        // colours: the change from the first frame (raw) or from 0, over the largest change so far
        let s = self.state(sensor);
        let (base, scale) = s.colour.entry(kind).or_insert_with(|| {
            let base = if kind == FrameKind::Raw { values.to_vec() } else { vec![0.0; values.len()] };
            (base, 0.0)
        });
        if base.len() != values.len() {
            *base = vec![0.0; values.len()];
        }
        let change: Vec<f64> = values.iter().zip(base.iter()).map(|(v, b)| v - b).collect();
        let largest = change.iter().filter(|c| c.is_finite()).fold(0.0f64, |m, c| m.max(c.abs()));
        *scale = scale.max(largest);
        let scale = if *scale > 0.0 { *scale } else { 1.0 };
        let colours: Vec<rerun::Color> = change.iter().map(|c| diverging(c / scale)).collect();
        self.at(sensor, t);
        self.put(&series, &rerun::Scalars::new(values.iter().copied()));
        if layout.is_some() {
            self.put(&plane, &rerun::Points2D::update_fields().with_colors(colours));
        }
    }

    /// One panel per sensor: its layout plane above a tab per series, and its log; a slip panel.
    fn send_blueprint(&mut self) {
        if !self.blueprint {
            return;
        }
        let key = format!(
            "{:?}{}",
            self.sensors.iter().map(|(k, s)| (k, &s.series, s.has_log)).collect::<Vec<_>>(),
            self.slip
        );
        if self.sent.as_ref() == Some(&key) {
            return;
        }
        let mut columns: Vec<ContainerLike> = Vec::new();
        for (name, s) in &self.sensors {
            let mut rows: Vec<ContainerLike> = vec![Spatial2DView::new(format!("{name}: layout plane (mm)"))
                .with_origin(path(name, &["plane"]))
                .into()];
            if !s.series.is_empty() {
                let tabs: Vec<ContainerLike> = s
                    .series
                    .iter()
                    .map(|k| TimeSeriesView::new(format!("{name}: {k}")).with_origin(path(name, &["series", k])).into())
                    .collect();
                rows.push(Tabs::new(tabs).into());
            }
            if s.has_log {
                rows.push(TextLogView::new(format!("{name}: log")).with_origin(path(name, &["log"])).into());
            }
            columns.push(Vertical::new(rows).with_name(name.clone()).into());
        }
        if self.slip {
            columns.push(
                Vertical::new([
                    TextLogView::new("slip events").with_origin(path("slip", &["log"])).into(),
                    TimeSeriesView::new("slip class").with_origin(path("slip", &["class"])).into(),
                ])
                .with_name("slip")
                .into(),
            );
        }
        if columns.is_empty() {
            return;
        }
        match Blueprint::new(Horizontal::new(columns)).send(&self.rec, BlueprintActivation::default()) {
            Ok(()) => self.sent = Some(key),
            Err(e) => {
                tracing::warn!(%e, "cannot send the rerun blueprint; the viewer lays the entities out itself");
                self.blueprint = false;
            }
        }
    }

    /// Flush (waiting at most `timeout`; `None`: until done) and close the stream.
    pub fn finish(self, timeout: Option<std::time::Duration>) {
        let flushed = match timeout {
            None => self.rec.flush_blocking(),
            Some(t) => self.rec.flush_with_timeout(t),
        };
        match flushed {
            Ok(()) => drop(self.rec),
            Err(e) => {
                tracing::warn!(%e, "the rerun recording could not be flushed (is the viewer still there?)");
                // rerun's gRPC client waits forever on drop for a viewer that never takes
                // the data: leave the stream (its thread and buffer) rather than hang the run
                std::mem::forget(self.rec);
            }
        }
    }
}
