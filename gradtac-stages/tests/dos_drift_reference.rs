//! The drift map and the slip classifier's drift features against an independent numpy
//! implementation (`tests/reference/gen_dos_drift.py` → `dos_drift.json`): synthetic integer
//! counts of a BioTac SP with a pressure bump sliding north, west, turning, at rest, and a
//! 45-frame span (only the 30-frame lag has differences); a constant taxel and values ≤ 0 (the
//! floor) included.

use gradtac_stages::dos::{DosFeatureConfig, DosFeatureExtractor, Feature};
use gradtac_stages::drift::{DriftMap, DriftScale};
use gradtac_stream::{Layout, TaxelFrame, Timestamp};
use serde_json::Value;

fn reference() -> Value {
    let text = include_str!("reference/dos_drift.json");
    serde_json::from_str(text).expect("dos_drift.json parses")
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

fn close(got: f64, want: f64, what: &str) {
    let tol = 1e-12 * want.abs().max(1.0);
    assert!((got - want).abs() <= tol, "{what}: got {got:e}, numpy {want:e} (diff {:e})", (got - want).abs());
}

#[test]
fn drift_map_and_features_match_numpy() {
    let r = reference();
    let lags: Vec<u64> = r["lags"].as_array().unwrap().iter().map(|v| v.as_u64().unwrap()).collect();
    let floor = r["floor"].as_f64().unwrap();
    let names: Vec<&str> = r["features"].as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect();
    assert_eq!(names, Feature::DRIFT.map(|f| f.name()));
    // the numpy reference is the log-scale map
    let cfg = DosFeatureConfig { drift_lags: lags.clone(), drift_scale: DriftScale::Log, ..Default::default() };
    let layout = Layout::biotac_sp();
    let cases = r["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 5);
    for case in cases {
        let name = case["name"].as_str().unwrap();
        let counts: Vec<Vec<f64>> = case["counts"].as_array().unwrap().iter().map(floats).collect();
        let mut map = DriftMap::try_new(24, &lags, floor).unwrap();
        let mut x = DosFeatureExtractor::try_new(&cfg, &layout).unwrap();
        for (k, frame) in counts.iter().enumerate() {
            map.push(frame).unwrap();
            x.push(TaxelFrame::new("ff".into(), Timestamp::at_rate(k as u64, 100.0), k as u64, frame.clone())).unwrap();
        }
        let snap = map.snapshot();
        for (i, (g, w)) in snap.weights.iter().zip(floats(&case["weights"])).enumerate() {
            close(*g, w, &format!("{name}: weight of taxel {i}"));
        }
        for (i, (g, w)) in snap.signs.iter().zip(floats(&case["signs"])).enumerate() {
            close(*g, w, &format!("{name}: sign of taxel {i}"));
        }
        let fv = x.features();
        for (f, want) in Feature::DRIFT.iter().zip(floats(&case["features"])) {
            close(fv.get(*f), want, &format!("{name}: {}", f.name()));
        }
    }
}

#[test]
fn the_reference_cases_are_what_they_claim() {
    let r = reference();
    let case = |n: &str| r["cases"].as_array().unwrap().iter().find(|c| c["name"] == n).unwrap().clone();
    let north = case("north");
    let w = floats(&north["weights"]);
    assert_eq!(w[5], 0.0, "the constant taxel e6 weighs nothing");
    let counts = north["counts"].as_array().unwrap();
    assert!(counts.iter().any(|f| f[7].as_f64().unwrap() <= 0.0), "a value at or below zero is included");
    assert_eq!(case("short")["counts"].as_array().unwrap().len(), 45);
    // touch drifts least
    let level = |n: &str| floats(&case(n)["features"])[0];
    for n in ["north", "west", "rotate", "short"] {
        assert!(level(n) > level("touch") + 1.0, "{n}");
    }
}
