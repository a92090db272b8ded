//! What crosses the view's queue: a compact copy of one record, independent of where it came
//! from (a running pipeline or a Parquet file being replayed).

use gradtac_stream::Layout;

/// The clock of a sensor's times (see `docs/schemas.md`, *Times*).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Clock {
    /// Nanoseconds since the Unix epoch: the `utc` timestamp timeline.
    Utc,
    /// Nanoseconds since the source's own origin: the `time` duration timeline.
    Relative,
}

/// Which frames a frame record holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FrameKind {
    /// As the source delivers them (`source` tap): entity `…/raw`.
    Raw,
    /// Min–max normalised (`normalise` tap): entity `…/normalised`.
    Normalised,
    /// Savitzky–Golay smoothed (`savgol` tap): entity `…/smoothed`.
    Smoothed,
    /// Per-taxel window aggregates (`window` tap): entity `…/window`.
    Window,
}

impl FrameKind {
    /// The kind of the frames a scene tap writes (`source` and the non-frame taps: raw).
    pub fn of_tap(tap: crate::Tap) -> FrameKind {
        match tap {
            crate::Tap::Normalise => FrameKind::Normalised,
            crate::Tap::Savgol => FrameKind::Smoothed,
            crate::Tap::Window => FrameKind::Window,
            _ => FrameKind::Raw,
        }
    }

    /// The last part of its entity paths.
    pub fn name(self) -> &'static str {
        match self {
            FrameKind::Raw => "raw",
            FrameKind::Normalised => "normalised",
            FrameKind::Smoothed => "smoothed",
            FrameKind::Window => "window",
        }
    }
}

/// One record to log. Times are integer nanoseconds on the sensor's [`Clock`].
#[derive(Clone, Debug)]
pub enum Rec {
    /// A sensor's layout and clock (sent once per sensor before its records; again to change).
    Sensor { sensor: String, layout: Option<Layout>, clock: Clock },
    /// One value per taxel.
    Frame { sensor: String, kind: FrameKind, t: i64, values: Vec<f64> },
    /// Event counts of one frame (only frames with at least one event).
    Events { sensor: String, t: i64, positive: u32, negative: u32 },
    /// A surface on a grid (row-major, `ny` rows of `nx`), linspace from `x0` to `x1`, `y0` to `y1` (mm).
    Surface { sensor: String, t: i64, nx: usize, ny: usize, extent: [f64; 4], values: Vec<f32> },
    /// A maximal contour (`None`: no contact), with its area centroid (mm) and area (mm²).
    Contour { sensor: String, t: i64, polygon: Option<Vec<[f64; 2]>>, centroid: Option<[f64; 2]>, area: Option<f64> },
    /// A contact point (mm; `None`: no contact) with its position uncertainty σ (mm) when known.
    Contact { sensor: String, t: i64, xy: Option<[f64; 2]>, sigma_mm: Option<f64> },
    /// A force estimate (N; `None`: none).
    Force { sensor: String, t: i64, force_n: Option<f64> },
    /// A servo command (mm; `None`: no contact, no command).
    Servo { sensor: String, t: i64, motion_mm: Option<[f64; 2]> },
    /// A change of a two-finger grasp's state.
    Slip { pair: String, t: i64, onset: i64, class: String, previous: String },
    /// A one-fingertip slip-direction decision.
    Dos { sensor: String, t: i64, class: String, posterior: Option<f64> },
}

impl Rec {
    /// The entity-path root the record lives under (a sensor's name, or `slip`).
    pub fn root(&self) -> &str {
        match self {
            Rec::Sensor { sensor, .. }
            | Rec::Frame { sensor, .. }
            | Rec::Events { sensor, .. }
            | Rec::Surface { sensor, .. }
            | Rec::Contour { sensor, .. }
            | Rec::Contact { sensor, .. }
            | Rec::Force { sensor, .. }
            | Rec::Servo { sensor, .. }
            | Rec::Dos { sensor, .. } => sensor,
            Rec::Slip { .. } => "slip",
        }
    }

    /// Bytes the record holds beyond its own size (for the queue's memory bound).
    pub fn heap_bytes(&self) -> usize {
        match self {
            Rec::Frame { values, .. } => values.len() * 8,
            Rec::Surface { values, .. } => values.len() * 4,
            Rec::Contour { polygon, .. } => polygon.as_ref().map_or(0, |p| p.len() * 16),
            _ => 0,
        }
    }
}
