//! Savitzky–Golay against scipy and against exact rational coefficients.
//!
//! The vectors in `tests/reference/` come from `tests/reference/gen_savgol.py` (scipy and numpy
//! versions are recorded in each JSON file's `versions`). scipy's `savgol_coeffs` is only
//! trustworthy where its raw-Vandermonde `lstsq` is well-conditioned; every case carries scipy's
//! own error against exact rational arithmetic (`scipy_err`), and we compare with scipy where
//! that error is ≤ 1e-12 and with the exact values everywhere.

use gradtac_stages::savgol::{savgol_coeffs, savgol_weights, SavGol, SavGolConfig, SavGolMode};
use gradtac_stream::{StageExt, TaxelFrame, Timestamp};
use serde::Deserialize;

const COEFF_TOL: f64 = 1e-10;
const FILTER_TOL: f64 = 1e-9;

#[derive(Deserialize)]
struct Versions {
    scipy: String,
    numpy: String,
}

#[derive(Deserialize)]
struct CoeffFile {
    versions: Versions,
    scipy_ok: f64,
    sweep: Vec<SweepCase>,
    full: Vec<FullCase>,
    high: Vec<HighCase>,
}

#[derive(Deserialize)]
struct HighCase {
    window: usize,
    polyorder: usize,
    deriv: usize,
    coeffs: Vec<f64>,
}

#[derive(Deserialize)]
struct SweepCase {
    window: usize,
    polyorder: usize,
    deriv: usize,
    max_abs: f64,
    exact_fp: f64,
    scipy_fp: f64,
    scipy_err: f64,
}

#[derive(Deserialize)]
struct FullCase {
    window: usize,
    polyorder: usize,
    deriv: usize,
    delta: f64,
    #[serde(rename = "use")]
    use_: String,
    pos: Option<usize>,
    source: String,
    coeffs: Vec<f64>,
}

#[derive(Deserialize)]
struct FilterFile {
    versions: Versions,
    cases: Vec<FilterCase>,
}

#[derive(Deserialize)]
struct FilterCase {
    window: usize,
    polyorder: usize,
    deriv: usize,
    delta: f64,
    scipy_err: f64,
    input: Vec<Vec<f64>>,
    output: Vec<Vec<f64>>,
}

fn load<T: for<'de> Deserialize<'de>>(name: &str) -> T {
    let path = format!("{}/tests/reference/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn fingerprint(c: &[f64]) -> f64 {
    c.iter().enumerate().map(|(j, x)| x * (((37 * j + 11) % 23) as f64 / 23.0 - 0.5)).sum()
}

fn rel_err(got: &[f64], want: &[f64]) -> f64 {
    let scale = want.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let err = got.iter().zip(want).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    if scale == 0.0 {
        err
    } else {
        err / scale
    }
}

#[test]
fn sweep_windows_5_to_201_orders_0_to_12() {
    let file: CoeffFile = load("savgol_coeffs.json");
    assert!(file.versions.scipy.starts_with('1') && !file.versions.numpy.is_empty());
    assert_eq!(file.sweep.len(), 3801, "every odd window 5..201 × order 0..12 (< window) × deriv 0..2");
    let (mut worst_exact, mut worst_scipy, mut n_scipy) = (0.0f64, 0.0f64, 0);
    for c in &file.sweep {
        let mine = savgol_coeffs(c.window, c.polyorder, c.deriv, 1.0).unwrap();
        assert_eq!(mine.len(), c.window);
        let max_abs = mine.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let fp = fingerprint(&mine);
        let id = format!("w {} p {} d {}", c.window, c.polyorder, c.deriv);
        // deriv > polyorder: all-zero coefficients, compared absolutely
        let scale = if c.max_abs > 0.0 { c.max_abs } else { 1.0 };
        let e = (fp - c.exact_fp).abs() / scale;
        assert!(e <= COEFF_TOL, "{id}: fingerprint vs exact {e:e}");
        assert!((max_abs - c.max_abs).abs() <= COEFF_TOL * scale, "{id}: max |c| {max_abs} vs {}", c.max_abs);
        worst_exact = worst_exact.max(e);
        if c.scipy_err <= file.scipy_ok {
            let e = (fp - c.scipy_fp).abs() / scale;
            assert!(e <= COEFF_TOL, "{id}: fingerprint vs scipy {e:e}");
            worst_scipy = worst_scipy.max(e);
            n_scipy += 1;
        }
    }
    assert!(n_scipy > 1000, "scipy is well-conditioned in only {n_scipy} cases");
    eprintln!(
        "sweep: worst fingerprint error vs exact {worst_exact:.1e}, vs scipy ({n_scipy} cases) {worst_scipy:.1e}"
    );
}

#[test]
fn full_vectors_match_scipy_or_exact() {
    let file: CoeffFile = load("savgol_coeffs.json");
    let (mut worst, mut worst_exact, mut n_scipy) = (0.0f64, 0.0f64, 0);
    for c in &file.full {
        let mine = match (c.use_.as_str(), c.pos) {
            ("conv", None) => savgol_coeffs(c.window, c.polyorder, c.deriv, c.delta).unwrap(),
            ("dot", Some(pos)) => savgol_weights(c.window, c.polyorder, c.deriv, c.delta, pos).unwrap(),
            other => panic!("unexpected case {other:?}"),
        };
        let e = rel_err(&mine, &c.coeffs);
        assert!(
            e <= COEFF_TOL,
            "w {} p {} d {} delta {} {} pos {:?} ({}): {e:e}",
            c.window,
            c.polyorder,
            c.deriv,
            c.delta,
            c.use_,
            c.pos,
            c.source
        );
        worst = worst.max(e);
        if c.source == "exact" {
            worst_exact = worst_exact.max(e);
        }
        n_scipy += usize::from(c.source == "scipy");
    }
    assert!(n_scipy > 500);
    eprintln!(
        "full vectors: {} cases ({n_scipy} from scipy), worst relative error {worst:.1e} ({worst_exact:.1e} where the reference is exact)",
        file.full.len()
    );
}

/// Beyond order 12: every accepted (window, order) matches the exact weights; the refused ones
/// are the near-interpolating fits, refused with the condition number in the message.
#[test]
fn high_orders_are_exact_or_refused() {
    let file: CoeffFile = load("savgol_coeffs.json");
    let (mut accepted, mut refused, mut worst) = (Vec::new(), Vec::new(), 0.0f64);
    for c in &file.high {
        match savgol_coeffs(c.window, c.polyorder, c.deriv, 1.0) {
            Ok(mine) => {
                let e = rel_err(&mine, &c.coeffs);
                assert!(e <= COEFF_TOL, "w {} p {} d {}: {e:e}", c.window, c.polyorder, c.deriv);
                worst = worst.max(e);
                accepted.push((c.window, c.polyorder));
            }
            Err(e) => {
                assert!(e.to_string().contains("condition number"), "{e}");
                refused.push((c.window, c.polyorder));
            }
        }
    }
    accepted.dedup();
    refused.dedup();
    eprintln!("high orders: accepted {accepted:?} (worst error {worst:.1e}), refused {refused:?}");
    for must in [(21, 20), (41, 25), (101, 40), (201, 40)] {
        assert!(accepted.contains(&must), "{must:?} should be accepted");
    }
    for must in [(31, 30), (41, 40)] {
        assert!(refused.contains(&must), "{must:?} should be refused");
    }
}

fn frames_of(input: &[Vec<f64>]) -> Vec<TaxelFrame> {
    let n = input[0].len();
    (0..n)
        .map(|k| {
            TaxelFrame::new(
                "ff".into(),
                Timestamp::at_rate(k as u64, 100.0),
                k as u64,
                input.iter().map(|s| s[k]).collect(),
            )
        })
        .collect()
}

#[test]
fn centred_stream_reproduces_savgol_filter_interp_edges_included() {
    let file: FilterFile = load("savgol_filter.json");
    assert!(!file.versions.scipy.is_empty());
    assert!(file.cases.len() >= 20);
    for c in &file.cases {
        let n = c.input[0].len();
        let id = format!("w {} p {} d {} delta {} n {n}", c.window, c.polyorder, c.deriv, c.delta);
        assert!(c.scipy_err < FILTER_TOL, "{id}: reference itself off by {}", c.scipy_err);
        let config = SavGolConfig {
            window: c.window,
            polyorder: c.polyorder,
            deriv: c.deriv,
            delta: Some(c.delta),
            ..Default::default()
        };
        let fs = frames_of(&c.input);
        let mut sg = SavGol::try_new(c.input.len(), config.clone()).unwrap();
        let out = sg.run_all(fs.clone()).unwrap();
        assert_eq!(out.len(), n, "{id}");
        for (k, o) in out.iter().enumerate() {
            assert_eq!((o.seq, o.time), (fs[k].seq, fs[k].time), "{id}: stamps");
        }
        for (taxel, want) in c.output.iter().enumerate() {
            let got: Vec<f64> = out.iter().map(|f| f.values[taxel]).collect();
            let e = rel_err(&got, want);
            assert!(e <= FILTER_TOL, "{id} taxel {taxel}: {e:e}");
        }
        // Causal: the fit at the newest sample of the last window is scipy's last end-edge value.
        let mut causal = SavGol::try_new(c.input.len(), SavGolConfig { mode: SavGolMode::Causal, ..config }).unwrap();
        let out = causal.run_all(fs).unwrap();
        assert_eq!(out.len(), n);
        let last = out.last().unwrap();
        for (taxel, want) in c.output.iter().enumerate() {
            let scale = want.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let e = (last.values[taxel] - want[n - 1]).abs() / scale;
            assert!(e <= FILTER_TOL, "{id} causal taxel {taxel}: {e:e}");
        }
    }
}
