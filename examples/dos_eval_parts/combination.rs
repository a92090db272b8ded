//! The pieces of the held-out combination of the Student-t design and a window model (the
//! window net in `dos_eval`'s window part, the trees in `dos_trees --held-out`): both models'
//! log posteriors over [`DosClass::ALL`], the class a weight decides and the weight chosen.

use gradtac::calibrate::WINDOW_WEIGHTS;
use gradtac::stages::dos::DosClass;

/// Per test recording, the two models' log posteriors over [`DosClass::ALL`]: (Student t, the
/// window model's vote, mean per window).
pub type Pair = ([f64; 7], [f64; 7]);

/// Log posteriors over [`DosClass::ALL`] (−1e3 for a class the model does not know).
pub fn log_over_all(classes: &[DosClass], log_p: &[f64]) -> [f64; 7] {
    let mut out = [-1e3; 7];
    for (c, p) in classes.iter().zip(log_p) {
        out[DosClass::ALL.iter().position(|x| x == c).unwrap_or(0)] = p.max(-1e3);
    }
    out
}

/// The class the combination `a·ln p(Student t) + (1 − a)·(window model)` decides.
pub fn combined_class(pair: &Pair, a: f64) -> DosClass {
    let s: Vec<f64> = pair.0.iter().zip(&pair.1).map(|(t, w)| a * t + (1.0 - a) * w).collect();
    DosClass::ALL[(0..7).fold(0, |m, k| if s[k] > s[m] { k } else { m })]
}

/// The weight of [`WINDOW_WEIGHTS`] deciding most of `inner` (recordings of the training
/// objects, each decided without its object) right; the first on a tie.
pub fn best_weight(inner: &[(Pair, DosClass)]) -> f64 {
    let mut best = (WINDOW_WEIGHTS[0], 0usize);
    for a in WINDOW_WEIGHTS {
        let ok = inner.iter().filter(|(p, c)| combined_class(p, a) == *c).count();
        if ok > best.1 {
            best = (a, ok);
        }
    }
    best.0
}
