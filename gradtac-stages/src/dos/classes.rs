//! The slip-direction classes (`n`, `e`, `s`, `w`, `cw`, `aw`, `t`) and their geometry.

use super::*;

/// A BioTacSP-DoS class (see the [module docs](crate::dos) for the map to layout directions).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DosClass {
    /// Translational slip north: contact moves toward `+x` (the fingertip).
    N,
    /// Translational slip east: contact moves toward `+y`.
    E,
    /// Translational slip south: contact moves toward `−x`.
    S,
    /// Translational slip west: contact moves toward `−y`.
    W,
    /// Rotational slip clockwise (`+x` toward `+y`).
    Cw,
    /// Rotational slip anticlockwise (`+y` toward `+x`).
    Aw,
    /// Stable touch, no slip.
    T,
}

impl DosClass {
    /// All seven classes in the dataset's order (`n, e, s, w, cw, aw, t`).
    pub const ALL: [DosClass; 7] =
        [DosClass::N, DosClass::E, DosClass::S, DosClass::W, DosClass::Cw, DosClass::Aw, DosClass::T];

    /// The dataset's name (`"n"`, …, `"t"`).
    pub fn as_str(self) -> &'static str {
        match self {
            DosClass::N => "n",
            DosClass::E => "e",
            DosClass::S => "s",
            DosClass::W => "w",
            DosClass::Cw => "cw",
            DosClass::Aw => "aw",
            DosClass::T => "t",
        }
    }

    /// Unit vector of the contact's motion in the layout's axes for a translational class
    /// (`n` → `[1, 0]`, `e` → `[0, 1]`, `s` → `[−1, 0]`, `w` → `[0, −1]`); `None` otherwise.
    pub fn direction(self) -> Option<[f64; 2]> {
        match self {
            DosClass::N => Some([1.0, 0.0]),
            DosClass::E => Some([0.0, 1.0]),
            DosClass::S => Some([-1.0, 0.0]),
            DosClass::W => Some([0.0, -1.0]),
            _ => None,
        }
    }

    /// `+1` for `cw` (rotation from `+x` toward `+y`, growing orientation angle), `−1` for
    /// `aw`, `None` otherwise.
    pub fn rotation_sense(self) -> Option<f64> {
        match self {
            DosClass::Cw => Some(1.0),
            DosClass::Aw => Some(-1.0),
            _ => None,
        }
    }

    /// The class of the same slip seen in a layout mirrored across `y = 0` (the BioTac SP's
    /// electrodes 11–20 mirror 1–10): `e` ↔ `w` (the `y` component of the motion flips) and
    /// `cw` ↔ `aw` (a reflection reverses every rotation); `n`, `s` and `t` stay.
    pub fn mirrored(self) -> DosClass {
        match self {
            DosClass::E => DosClass::W,
            DosClass::W => DosClass::E,
            DosClass::Cw => DosClass::Aw,
            DosClass::Aw => DosClass::Cw,
            other => other,
        }
    }

    /// The translational class whose direction is closest to `v` (layout axes), `None` for a
    /// zero or non-finite vector.
    pub fn from_direction(v: [f64; 2]) -> Option<DosClass> {
        if !(v[0].is_finite() && v[1].is_finite()) || (v[0] == 0.0 && v[1] == 0.0) {
            return None;
        }
        [DosClass::N, DosClass::E, DosClass::S, DosClass::W].into_iter().max_by(|a, b| {
            let (da, db) = (a.direction().unwrap_or([0.0; 2]), b.direction().unwrap_or([0.0; 2]));
            (da[0] * v[0] + da[1] * v[1]).total_cmp(&(db[0] * v[0] + db[1] * v[1]))
        })
    }
}

impl fmt::Display for DosClass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for DosClass {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        DosClass::ALL
            .into_iter()
            .find(|c| c.as_str().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| invalid(format!("unknown class {s:?}; expected one of n, e, s, w, cw, aw, t")))
    }
}
