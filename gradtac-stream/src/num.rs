//! Numbers in messages: short form.
//!
//! Rust prints an `f64` in plain decimal, so `1e308` comes out as 309 digits and `5e-324`
//! as 324 zeros and a 5. Errors quote settings and values through [`Short`], which prints
//! the shortest round-tripping digits in exponent form when the plain form would be long.

use std::fmt;

/// An `f64` displayed in short form: plain decimal for `1e-4 ≤ |x| < 1e15` (and 0, ±inf,
/// NaN), exponent form (`1e308`, `5e-324`, `-1.5e20`) beyond. Both round-trip.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Short(pub f64);

impl fmt::Display for Short {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x = self.0;
        let a = x.abs();
        if x.is_finite() && x != 0.0 && !(1e-4..1e15).contains(&a) {
            write!(f, "{x:e}")
        } else {
            write!(f, "{x}")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Short;

    #[test]
    fn short_forms() {
        for (x, s) in [
            (1e308, "1e308"),
            (5e-324, "5e-324"),
            (-1.5e20, "-1.5e20"),
            (0.5, "0.5"),
            (100.0, "100"),
            (0.0, "0"),
            (1e-9, "1e-9"),
            (f64::INFINITY, "inf"),
            (f64::NAN, "NaN"),
            (123456.25, "123456.25"),
        ] {
            assert_eq!(Short(x).to_string(), s);
            if x.is_finite() {
                assert_eq!(s.parse::<f64>().unwrap(), x);
            }
        }
    }
}
