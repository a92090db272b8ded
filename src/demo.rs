//! The embedded default: a synthetic recording and a scene over it, run by `gradtac demo`.
//!
//! The recording is a small forward model of one BioTac SP fingertip (until the full
//! simulator lands): a round indenter presses, circles once around the pad centre and lifts,
//! and each electrode reads `baseline − gain · F(t) · exp(−d² / 2σ²) + noise`, quantised to
//! 12-bit counts. `d` is the electrode's distance (mm, layout plane) from the indenter, `F`
//! a smooth force envelope, σ = 4 mm. Deterministic for a seed.

use crate::Error;
use gradtac_stream::Layout;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use std::path::{Path, PathBuf};

/// Sample rate of the synthetic recording (Hz).
pub const RATE_HZ: f64 = 100.0;

/// Write a synthetic one-fingertip recording as CSV (`ff_e1..ff_e24`, no time column, 100 Hz)
/// and return the number of frames.
pub fn write_recording(path: &Path, seconds: f64, seed: u64) -> Result<usize, Error> {
    let layout = Layout::biotac_sp();
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let mut w = csv::Writer::from_path(path).map_err(|e| io(std::io::Error::other(e)))?;
    let header: Vec<String> = (1..=layout.len()).map(|i| format!("ff_e{i}")).collect();
    w.write_record(&header).map_err(|e| io(std::io::Error::other(e)))?;
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 2.0).expect("valid sigma");
    let baseline: Vec<f64> = (0..layout.len()).map(|i| 2800.0 + 37.0 * ((i * 7) % 13) as f64).collect();
    let gain: Vec<f64> = (0..layout.len()).map(|i| 260.0 + 11.0 * ((i * 5) % 7) as f64).collect();
    let n = (seconds * RATE_HZ).round() as usize;
    let [cx, cy] = layout.extent().centre();
    for k in 0..n {
        let t = k as f64 / n as f64; // 0..1 over the recording
        let force = (std::f64::consts::PI * t).sin().powi(2); // press, hold, lift
        let angle = 2.0 * std::f64::consts::PI * t;
        let (ix, iy) = (cx + 5.0 * angle.cos(), cy + 5.0 * angle.sin());
        let row: Vec<String> = layout
            .positions()
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let d2 = (p[0] - ix).powi(2) + (p[1] - iy).powi(2);
                let v = baseline[i] - gain[i] * force * (-d2 / (2.0 * 16.0)).exp() + noise.sample(&mut rng);
                format!("{}", v.round().clamp(0.0, 4095.0))
            })
            .collect();
        w.write_record(&row).map_err(|e| io(std::io::Error::other(e)))?;
    }
    w.flush().map_err(io)?;
    Ok(n)
}

/// The demo's scene, over `recording.csv` in the same directory.
pub const DEMO_SCENE: &str = r#"# gradtac demo scene: one synthetic BioTac SP fingertip.
[[sensor]]
name = "ff"
layout = "biotac-sp"
source = { csv = "recording.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }

[stages.normalise]
calibrate_frames = 20

[[output]]
tap = "source"
path = "out/raw.parquet"

[[output]]
tap = "normalise"
path = "out/normalised.parquet"
"#;

/// A fresh directory for a demo run under the system's temporary directory.
pub fn fresh_dir() -> Result<PathBuf, Error> {
    let stamp = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let base = std::env::temp_dir();
    for k in 0..1000u32 {
        let dir = base.join(format!("gradtac-demo-{stamp}-{}-{k}", std::process::id()));
        match std::fs::create_dir(&dir) {
            Ok(()) => return Ok(dir),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(source) => return Err(Error::Io { path: dir, source }),
        }
    }
    Err(Error::Io { path: base, source: std::io::Error::other("no fresh directory name left") })
}
