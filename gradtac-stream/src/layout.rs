//! Taxel layouts: where each taxel sits on the sensor, in millimetres.

use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Names of the layouts built into the crate, for [`Layout::builtin`].
pub const BUILTIN_LAYOUTS: &[&str] = &["biotac-sp"];

/// An axis-aligned rectangle in mm: the region of the sensor surfaces are drawn on.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Extent {
    /// Smallest x (mm).
    pub x_min: f64,
    /// Largest x (mm).
    pub x_max: f64,
    /// Smallest y (mm).
    pub y_min: f64,
    /// Largest y (mm).
    pub y_max: f64,
}

impl Extent {
    /// Width along x (mm).
    pub fn width(&self) -> f64 {
        self.x_max - self.x_min
    }
    /// Height along y (mm).
    pub fn height(&self) -> f64 {
        self.y_max - self.y_min
    }
    /// The centre point (mm).
    pub fn centre(&self) -> [f64; 2] {
        [(self.x_min + self.x_max) / 2.0, (self.y_min + self.y_max) / 2.0]
    }
    /// The same rectangle grown by `m` mm on every side.
    pub fn grown(&self, m: f64) -> Extent {
        Extent { x_min: self.x_min - m, x_max: self.x_max + m, y_min: self.y_min - m, y_max: self.y_max + m }
    }
}

/// Where each taxel of a sensor sits on a plane, in mm, and the sensor's extent.
///
/// Positions are 2-D: 3-D sensors are projected by whoever builds the layout (the built-in
/// BioTac SP layout documents its projection in [`Layout::biotac_sp`]). A layout is checked
/// at construction ([`Layout::try_new`]): at least 3 taxels, finite positions, no two taxels
/// at the same place, not all on one line — the conditions interpolation over the layout
/// needs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Layout {
    name: String,
    names: Vec<String>,
    positions: Vec<[f64; 2]>,
    extent: Extent,
}

/// Largest absolute taxel coordinate (mm) a layout accepts: 1 km (10⁶ mm) — a skin over a
/// whole robot fits many times over, and interpolation stays accurate to ~1e-9 relative (the
/// extreme-scale tests). Grid extents may reach twice this (a margin of at most this much
/// around the taxels). Far beyond, floating-point geometry loses its guarantees (a 1e160
/// extent made spade panic; spade refuses coordinates beyond ±3.2e60).
pub const MAX_COORD_MM: f64 = 1e6;

/// Largest layout CSV file (bytes) read: 16 MiB.
pub const MAX_LAYOUT_FILE_BYTES: u64 = 16 << 20;

/// Margin (mm) added around the taxels' bounding box when a layout gives no extent.
pub const DEFAULT_MARGIN_MM: f64 = 2.0;

/// Skin-surface positions (mm) of the BioTac SP's sensing electrodes 1..=24 (x along the finger
/// toward the tip, z out of the pad), from the COMSOL model cited in [`Layout::biotac_sp`], which
/// unwraps them onto the plane.
pub const BIOTAC_SP_SKIN_MM: [[f64; 3]; 24] = [
    [11.14857, -5.25733, -3.65186],
    [9.28813, -4.13207, -7.01911],
    [2.46644, -9.07826, -4.139],
    [2.40223, -6.68511, -7.82462],
    [-0.53737, -3.19441, -10.10018],
    [-2.59071, -9.15067, -3.86751],
    [-3.9217, -6.23412, -7.91412],
    [-6.51216, -2.45585, -9.2922],
    [-9.36007, -4.39204, -6.8576],
    [-11.48363, -5.10487, -3.36957],
    [11.15987, 5.26812, -3.65935],
    [9.30141, 4.144, -7.03937],
    [2.46665, 9.07986, -4.13973],
    [2.40237, 6.68595, -7.8256],
    [-0.53735, 3.19416, -10.09939],
    [-2.59194, 9.15986, -3.8714],
    [-3.9194, 6.22657, -7.90454],
    [-6.5019, 2.44801, -9.26256],
    [-9.33708, 4.37031, -6.82367],
    [-11.46739, 5.09033, -3.35997],
    [7.3143, 0.0, -9.38526],
    [5.04212, -1.8519, -9.85908],
    [5.04983, 1.8519, -9.88999],
    [2.64671, 0.0, -10.51272],
];

impl Layout {
    /// A validated layout. `extent` defaults to the taxels' bounding box grown by
    /// [`DEFAULT_MARGIN_MM`]; a given extent must contain every taxel.
    pub fn try_new(
        name: impl Into<String>,
        names: Vec<String>,
        positions: Vec<[f64; 2]>,
        extent: Option<Extent>,
    ) -> Result<Self> {
        let name = name.into();
        let bad = |reason: String| Error::InvalidLayout { name: name.clone(), reason };
        if names.len() != positions.len() {
            return Err(bad(format!("{} names for {} positions", names.len(), positions.len())));
        }
        if positions.len() > u16::MAX as usize {
            return Err(bad(format!("{} taxels; at most 65535 are supported", positions.len())));
        }
        if positions.len() < 3 {
            return Err(bad(format!("{} taxels; at least 3 are needed", positions.len())));
        }
        for (n, p) in names.iter().zip(&positions) {
            if !p[0].is_finite() || !p[1].is_finite() {
                return Err(bad(format!("taxel {n:?} has a non-finite position {p:?}")));
            }
            if p[0].abs() > MAX_COORD_MM || p[1].abs() > MAX_COORD_MM {
                return Err(bad(format!("taxel {n:?} at {p:?} mm is beyond ±{MAX_COORD_MM} mm")));
            }
        }
        for i in 0..names.len() {
            for j in 0..i {
                if names[i] == names[j] {
                    return Err(bad(format!("taxel name {:?} appears twice", names[i])));
                }
                if positions[i] == positions[j] {
                    return Err(bad(format!(
                        "taxels {:?} and {:?} share the position {:?}",
                        names[j], names[i], positions[i]
                    )));
                }
            }
        }
        if collinear(&positions) {
            return Err(bad("all taxels lie on one line".into()));
        }
        let bbox = bounding_box(&positions);
        let extent = match extent {
            None => bbox.grown(DEFAULT_MARGIN_MM),
            Some(e) => {
                let lim = 2.0 * MAX_COORD_MM;
                if ![e.x_min, e.x_max, e.y_min, e.y_max].iter().all(|v| v.is_finite() && v.abs() <= lim) {
                    return Err(bad(format!("extent {e:?} must be finite and within ±{lim} mm")));
                }
                if !(e.x_min <= bbox.x_min && e.x_max >= bbox.x_max && e.y_min <= bbox.y_min && e.y_max >= bbox.y_max) {
                    return Err(bad(format!("extent {e:?} does not contain every taxel (bounding box {bbox:?})")));
                }
                e
            }
        };
        Ok(Layout { name, names, positions, extent })
    }

    /// A built-in layout by name (see [`BUILTIN_LAYOUTS`]).
    pub fn builtin(name: &str) -> Result<Self> {
        match name {
            "biotac-sp" => Ok(Self::biotac_sp()),
            other => Err(Error::UnknownLayout(other.to_string())),
        }
    }

    /// The BioTac SP's 24 sensing electrodes (`e1`..`e24`).
    ///
    /// **Source.** Skin-surface electrode positions (mm) of the COMSOL BioTac SP model by
    /// B. Sadrfaridpour (public repository `bsadr/biotac`, `comsol/matlab/3dmodels/locations.csv`),
    /// as collected in gradtac's shared `layouts/biotac-sp-electrodes.csv`. Axes: x along the
    /// finger, positive toward the tip; y across; z out of the pad (negative on the sensing face).
    ///
    /// **Projection.** A cylindrical arc-length unwrap about the finger's long axis:
    /// `x_mm = x`, `y_mm = ρ·atan2(y, −z)` with `ρ = √(y² + z²)`. Distances along the finger are
    /// kept; across the finger a position becomes the arc length from the pad's midline, so
    /// electrodes on the curved sides are not squeezed together as an orthographic projection
    /// onto the x–y plane would squeeze them. Electrodes 11–20 mirror 1–10 across y = 0.
    /// The extent is the bounding box grown by [`DEFAULT_MARGIN_MM`].
    pub fn biotac_sp() -> Self {
        let positions = BIOTAC_SP_SKIN_MM.iter().map(|&[x, y, z]| [x, y.hypot(z) * y.atan2(-z)]).collect();
        let names = (1..=24).map(|i| format!("e{i}")).collect();
        Layout::try_new("biotac-sp", names, positions, None).expect("the built-in layout is valid")
    }

    /// Load a layout from CSV text with a header and columns `name,x_mm,y_mm` (any order;
    /// other columns are ignored). `origin` names the source in errors.
    pub fn from_csv_reader(name: impl Into<String>, reader: impl std::io::Read, origin: &Path) -> Result<Self> {
        let name = name.into();
        let err = |line: u64, reason: String| Error::LayoutFile { path: origin.to_path_buf(), line, reason };
        let mut rdr = csv::ReaderBuilder::new().trim(csv::Trim::All).from_reader(reader);
        let headers = rdr.headers().map_err(|e| err(1, e.to_string()))?.clone();
        let col = |want: &str| {
            headers
                .iter()
                .position(|h| h == want)
                .ok_or_else(|| err(1, format!("no column {want:?} (header: {:?})", headers.iter().collect::<Vec<_>>())))
        };
        let (cn, cx, cy) = (col("name")?, col("x_mm")?, col("y_mm")?);
        let mut names = Vec::new();
        let mut positions = Vec::new();
        for rec in rdr.records() {
            let rec = rec.map_err(|e| err(e.position().map_or(0, |p| p.line()), e.to_string()))?;
            let line = rec.position().map_or(0, |p| p.line());
            let num = |c: usize, what: &str| -> Result<f64> {
                let s = rec.get(c).unwrap_or("");
                let short: String = s.chars().take(80).collect();
                let more = if short.len() < s.len() { format!("… ({} bytes)", s.len()) } else { String::new() };
                s.parse::<f64>().map_err(|_| err(line, format!("column {what}: {short:?}{more} is not a number")))
            };
            positions.push([num(cx, "x_mm")?, num(cy, "y_mm")?]);
            names.push(rec.get(cn).unwrap_or("").to_string());
        }
        Layout::try_new(name, names, positions, None)
    }

    /// Load a layout CSV file (see [`Layout::from_csv_reader`]); the layout is named after the file stem.
    pub fn from_csv_path(path: &Path) -> Result<Self> {
        let f = std::fs::File::open(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
        let meta = f.metadata().map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
        if !meta.is_file() || meta.len() > MAX_LAYOUT_FILE_BYTES {
            let reason = if meta.is_file() {
                format!("{} bytes; a layout file may hold at most {MAX_LAYOUT_FILE_BYTES}", meta.len())
            } else {
                "not a regular file".to_string()
            };
            return Err(Error::LayoutFile { path: path.to_path_buf(), line: 0, reason });
        }
        let name = path.file_stem().map_or_else(|| "layout".into(), |s| s.to_string_lossy().into_owned());
        Self::from_csv_reader(name, std::io::BufReader::new(f), path)
    }

    /// The layout's name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Taxel names, in taxel order.
    pub fn names(&self) -> &[String] {
        &self.names
    }
    /// Taxel positions (mm), in taxel order.
    pub fn positions(&self) -> &[[f64; 2]] {
        &self.positions
    }
    /// Number of taxels.
    pub fn len(&self) -> usize {
        self.positions.len()
    }
    /// Always false: a valid layout has at least 3 taxels.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }
    /// The sensor's extent (mm).
    pub fn extent(&self) -> Extent {
        self.extent
    }
    /// The layout as CSV (`name,x_mm,y_mm`), the format [`Layout::from_csv_reader`] reads;
    /// sinks store it in file metadata.
    pub fn to_csv(&self) -> String {
        let mut s = String::from("name,x_mm,y_mm\n");
        for (n, p) in self.names.iter().zip(&self.positions) {
            s.push_str(&format!("{n},{},{}\n", p[0], p[1]));
        }
        s
    }
}

fn bounding_box(p: &[[f64; 2]]) -> Extent {
    let mut e =
        Extent { x_min: f64::INFINITY, x_max: f64::NEG_INFINITY, y_min: f64::INFINITY, y_max: f64::NEG_INFINITY };
    for q in p {
        e.x_min = e.x_min.min(q[0]);
        e.x_max = e.x_max.max(q[0]);
        e.y_min = e.y_min.min(q[1]);
        e.y_max = e.y_max.max(q[1]);
    }
    e
}

/// True when every point lies on the line through the two points farthest apart, within a
/// relative tolerance of 1e-12 of that distance squared.
fn collinear(p: &[[f64; 2]]) -> bool {
    let (mut a, mut b, mut best) = (0, 0, -1.0);
    for i in 0..p.len() {
        for j in 0..i {
            let d = (p[i][0] - p[j][0]).powi(2) + (p[i][1] - p[j][1]).powi(2);
            if d > best {
                (a, b, best) = (i, j, d);
            }
        }
    }
    let (ax, ay, bx, by) = (p[a][0], p[a][1], p[b][0], p[b][1]);
    p.iter().all(|q| ((bx - ax) * (q[1] - ay) - (by - ay) * (q[0] - ax)).abs() <= 1e-12 * best)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn biotac_sp_is_symmetric_and_sized() {
        let l = Layout::biotac_sp();
        assert_eq!(l.len(), 24);
        assert_eq!(l.names()[0], "e1");
        // electrodes 11..20 mirror 1..10 across y = 0 (to the model's 0.03 mm asymmetry)
        for i in 0..10 {
            let (a, b) = (l.positions()[i], l.positions()[i + 10]);
            assert!((a[0] - b[0]).abs() < 0.03 && (a[1] + b[1]).abs() < 0.03, "{i}: {a:?} {b:?}");
        }
        // the midline electrodes sit at y = 0
        assert_eq!(l.positions()[20][1], 0.0);
        assert_eq!(l.positions()[23][1], 0.0);
        let e = l.extent();
        assert!(e.width() > 22.0 && e.width() < 28.0, "{e:?}");
        assert!(e.height() > 22.0 && e.height() < 28.0, "{e:?}");
    }

    #[test]
    fn degenerate_layouts_are_refused() {
        let n = |k: usize| (0..k).map(|i| format!("t{i}")).collect::<Vec<_>>();
        assert!(Layout::try_new("two", n(2), vec![[0.0, 0.0], [1.0, 0.0]], None).is_err());
        let e = Layout::try_new("line", n(3), vec![[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]], None).unwrap_err();
        assert!(e.to_string().contains("one line"), "{e}");
        let e = Layout::try_new("dup", n(3), vec![[0.0, 0.0], [1.0, 0.0], [0.0, 0.0]], None).unwrap_err();
        assert!(e.to_string().contains("share the position"), "{e}");
        let e = Layout::try_new("nan", n(3), vec![[0.0, 0.0], [1.0, f64::NAN], [0.0, 1.0]], None).unwrap_err();
        assert!(e.to_string().contains("non-finite"), "{e}");
        assert!(Layout::try_new("ok", n(3), vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], None).is_ok());
    }

    #[test]
    fn csv_round_trip_and_errors_name_the_line() {
        let l = Layout::biotac_sp();
        let back = Layout::from_csv_reader("biotac-sp", l.to_csv().as_bytes(), Path::new("mem.csv")).unwrap();
        assert_eq!(back.positions(), l.positions());
        assert_eq!(back.names(), l.names());
        let bad = "name,x_mm,y_mm\na,0,0\nb,1,0\nc,zero,1\n";
        let e = Layout::from_csv_reader("x", bad.as_bytes(), Path::new("my.csv")).unwrap_err();
        assert_eq!(e.to_string(), "my.csv:4: column x_mm: \"zero\" is not a number");
        let e = Layout::from_csv_reader("x", "a,b\n1,2\n".as_bytes(), Path::new("h.csv")).unwrap_err();
        assert!(e.to_string().starts_with("h.csv:1: no column \"name\""), "{e}");
    }
}
