//! The one-hidden-layer network both learned direction models share ([`DosNet`](super::DosNet)
//! and [`DosWindowNet`](super::DosWindowNet)): inputs standardised by a mean and a spread,
//! `tanh` hidden units (pre-activations clamped to ±[`MAX_ACT`]), linear outputs. The models
//! own their numbers (their file formats are their own); this module checks and evaluates them.

use super::{invalid, DosClass};
use crate::Result;

/// Largest magnitude of a hidden unit's pre-activation (`tanh` is ±1 to f64 precision beyond).
pub(super) const MAX_ACT: f64 = 40.0;

/// A borrowed view of a model's network.
pub(super) struct Dense<'a> {
    pub input_mean: &'a [f64],
    pub input_scale: &'a [f64],
    pub w1: &'a [Vec<f64>],
    pub b1: &'a [f64],
    pub w2: &'a [Vec<f64>],
    pub b2: &'a [f64],
}

pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Fitted numbers of a network of `d` inputs, `h` hidden units and `c` outputs.
pub(super) fn parameter_count(d: usize, h: usize, c: usize) -> usize {
    2 * d + h * d + h + c * h + c
}

impl Dense<'_> {
    /// Checks the classes (at least two, none twice) and every shape and value for `d` inputs
    /// and `h` hidden units; the error names the field.
    pub fn validate(&self, classes: &[DosClass], d: usize, h: usize) -> Result<()> {
        if classes.len() < 2 {
            return Err(invalid("a model needs at least two classes"));
        }
        for (i, c) in classes.iter().enumerate() {
            if classes[..i].contains(c) {
                return Err(invalid(format!("class {c} appears twice")));
            }
        }
        let c = classes.len();
        let check = |name: &str, v: &[f64], len: usize| -> Result<()> {
            if v.len() != len || !v.iter().all(|x| x.is_finite()) {
                return Err(invalid(format!("{name} must be {len} finite values, got {}", v.len())));
            }
            Ok(())
        };
        check("input_mean", self.input_mean, d)?;
        check("input_scale", self.input_scale, d)?;
        if self.input_scale.iter().any(|&s| s <= 0.0) {
            return Err(invalid("input_scale values must be > 0"));
        }
        if self.w1.len() != h {
            return Err(invalid(format!("w1 has {} rows for {h} hidden units", self.w1.len())));
        }
        for row in self.w1 {
            check("a row of w1", row, d)?;
        }
        check("b1", self.b1, h)?;
        if self.w2.len() != c {
            return Err(invalid(format!("w2 has {} rows for {c} classes", self.w2.len())));
        }
        for row in self.w2 {
            check("a row of w2", row, h)?;
        }
        check("b2", self.b2, c)
    }

    /// The hidden units' sums `Σ_j w1[h][j]·x_j` over the standardised first `prefix.len()`
    /// inputs (at most as many as `input_mean`, all finite, or an error), for
    /// [`logits_from_prefix`](Self::logits_from_prefix).
    pub fn prefix_sums(&self, prefix: &[f64]) -> Result<Vec<f64>> {
        if prefix.len() > self.input_mean.len() {
            return Err(invalid(format!("{} inputs for a model of {}", prefix.len(), self.input_mean.len())));
        }
        if let Some(j) = prefix.iter().position(|v| !v.is_finite()) {
            return Err(invalid(format!("input {j} is {}", prefix[j])));
        }
        let x: Vec<f64> =
            prefix.iter().zip(self.input_mean).zip(self.input_scale).map(|((v, m), s)| (v - m) / s).collect();
        Ok(self.w1.iter().map(|row| dot(row, &x)).collect())
    }

    /// The output logits of the input `prefix ++ tail` from `sums`, the
    /// [`prefix_sums`](Self::prefix_sums) of `prefix`, and the remaining inputs `tail`:
    /// bit-identical to [`logits`](Self::logits) of the whole input (the sums go on in the same
    /// order).
    pub fn logits_from_prefix(&self, sums: &[f64], tail: &[f64]) -> Result<Vec<f64>> {
        let d = self.input_mean.len();
        if sums.len() != self.w1.len() || tail.len() > d {
            return Err(invalid(format!(
                "{} sums and {} inputs for a model of {} hidden units",
                sums.len(),
                tail.len(),
                self.w1.len()
            )));
        }
        if let Some(j) = tail.iter().position(|v| !v.is_finite()) {
            return Err(invalid(format!("input {} is {}", d - tail.len() + j, tail[j])));
        }
        let at = d - tail.len();
        let x: Vec<f64> = tail
            .iter()
            .zip(&self.input_mean[at..])
            .zip(&self.input_scale[at..])
            .map(|((v, m), s)| (v - m) / s)
            .collect();
        let h: Vec<f64> = self
            .w1
            .iter()
            .zip(self.b1)
            .zip(sums)
            .map(|((row, b), &sum)| {
                let sum = row[at..].iter().zip(&x).fold(sum, |a, (w, v)| a + w * v);
                (b + sum).clamp(-MAX_ACT, MAX_ACT).tanh()
            })
            .collect();
        Ok(self.w2.iter().zip(self.b2).map(|(row, b)| b + dot(row, &h)).collect())
    }

    /// The output logits for `input` (as many values as `input_mean`, all finite, or an error).
    pub fn logits(&self, input: &[f64]) -> Result<Vec<f64>> {
        if input.len() != self.input_mean.len() {
            return Err(invalid(format!("{} inputs for a model of {}", input.len(), self.input_mean.len())));
        }
        if let Some(j) = input.iter().position(|v| !v.is_finite()) {
            return Err(invalid(format!("input {j} is {}", input[j])));
        }
        let x: Vec<f64> =
            input.iter().zip(self.input_mean).zip(self.input_scale).map(|((v, m), s)| (v - m) / s).collect();
        let h: Vec<f64> =
            self.w1.iter().zip(self.b1).map(|(row, b)| (b + dot(row, &x)).clamp(-MAX_ACT, MAX_ACT).tanh()).collect();
        Ok(self.w2.iter().zip(self.b2).map(|(row, b)| b + dot(row, &h)).collect())
    }
}
