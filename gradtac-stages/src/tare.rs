//! A stored untouched baseline ("tare"): each taxel's resting value and noise, measured once
//! from an untouched stretch of a sensor's recording (`gradtac calibrate baseline`), so that a
//! recording which starts in contact is measured against the sensor's real rest instead of its
//! first frames ([`ChangeDetector::with_tare`](crate::locate::ChangeDetector::with_tare)).
//!
//! [`Tare::measure`] takes the stretch's frames: the baseline is each taxel's straight-line
//! fit at the stretch's **end** (drift continues from there), the noise σ the change
//! detector's own estimate (the larger of the first-difference and the about-a-line scatter).
//! It refuses a stretch that is not untouched: the change detector with the scene's settings,
//! calibrated on the stretch's first frames, must see no contact in it.
//!
//! The file is JSON, versioned and validated on read ([`Tare::validate`]: format, version,
//! taxel count within bounds and matching every array, finite values, positive noise).

use crate::{Error, Result};
use serde::{Deserialize, Serialize};

const STAGE: &str = "tare";

/// The `format` tag of a tare file.
pub const TARE_FORMAT: &str = "gradtac-tare";
/// The version this build writes and reads.
pub const TARE_VERSION: u32 = 1;

/// A stored untouched baseline (see the [module docs](self)).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tare {
    /// Always [`TARE_FORMAT`].
    pub format: String,
    /// [`TARE_VERSION`].
    pub version: u32,
    /// The layout's name it was measured on.
    pub layout: String,
    /// The sensor's name in the scene it was measured from.
    pub sensor: String,
    /// Number of taxels.
    pub taxels: usize,
    /// Frames of the untouched stretch.
    pub frames: u64,
    /// Time of the stretch's first and last frame (ns).
    pub span_ns: [i64; 2],
    /// Resting value per taxel at the end of the stretch (input units).
    pub baseline: Vec<f64>,
    /// Noise σ of one frame per taxel (input units).
    pub noise: Vec<f64>,
}

/// The tare no longer fits the sensor ([`ChangeDetector::tare_mismatch`](crate::locate::ChangeDetector::tare_mismatch)).
#[derive(Clone, Debug, PartialEq)]
pub struct TareMismatch {
    /// The frame at which it was decided.
    pub seq: u64,
    /// The median taxel's change from the tare, in its σ.
    pub median_sigmas: f64,
}

impl TareMismatch {
    /// Seconds that more than three quarters of the taxels sit beyond the contact threshold
    /// before the tare is called a mismatch (a shift that never goes away).
    pub const SHIFT_S: f64 = 5.0;
    /// Seconds that nine in ten taxels sit beyond it with mixed signs (no more than four in
    /// five one way) before the tare is called a mismatch (another sensor).
    pub const MIXED_S: f64 = 0.5;
}

/// Most taxels a tare may hold.
pub const MAX_TAXELS: usize = 65_536;

fn invalid(reason: String) -> Error {
    Error::InvalidConfig { stage: STAGE, reason }
}

impl Tare {
    /// Measure a tare from an untouched stretch (`frames`: values per frame, `times_ns` the
    /// frames' times), refusing a stretch with a contact in it: the change detector with the
    /// scene's settings `cfg`, calibrated on the stretch's first `calibrate_frames` frames as
    /// it would be without a tare, must see no contact in the rest.
    pub fn measure(
        frames: &[Vec<f64>],
        times_ns: &[i64],
        layout: &str,
        sensor: &str,
        cfg: &crate::locate::LocateConfig,
    ) -> Result<Tare> {
        let m = frames.len();
        let need = (cfg.calibrate_frames as usize).max(20) + 1;
        if m < need || times_ns.len() != m {
            return Err(invalid(format!(
                "an untouched stretch needs at least {need} frames (calibrate_frames + 1), got {m}"
            )));
        }
        let n = frames[0].len();
        if n == 0 || n > MAX_TAXELS || frames.iter().any(|f| f.len() != n) {
            return Err(invalid(format!("frames of {n} taxels (1..={MAX_TAXELS}, all alike) expected")));
        }
        let cfg = crate::locate::LocateConfig { baseline: None, ..cfg.clone() };
        let mut det = crate::locate::ChangeDetector::try_new(n, &cfg)?;
        let id = gradtac_stream::SensorId::new(sensor);
        for (k, (v, &t)) in frames.iter().zip(times_ns).enumerate() {
            let f = gradtac_stream::TaxelFrame::new(id.clone(), gradtac_stream::Timestamp(t), k as u64, v.clone());
            let ch = det.push(&f, STAGE)?;
            if ch.contact {
                let (i, z) = det
                    .change()
                    .iter()
                    .zip(det.noise())
                    .map(|(d, s)| (d / s).abs())
                    .enumerate()
                    .max_by(|a, b| a.1.total_cmp(&b.1))
                    .unwrap_or((0, 0.0));
                return Err(invalid(format!(
                    "the stretch is not untouched: at frame {k} taxel {} is {z:.0} σ from its baseline (a contact \
                     by the detector's settings; pick a stretch without one)",
                    i + 1
                )));
            }
        }
        let (_, noise) = crate::locate::baseline_and_noise(frames, n);
        let tm = (m - 1) as f64 / 2.0;
        let stt: f64 = (0..m).map(|k| (k as f64 - tm).powi(2)).sum();
        let baseline = (0..n)
            .map(|i| {
                let mean = frames.iter().map(|f| f[i]).sum::<f64>() / m as f64;
                let slope = frames.iter().enumerate().map(|(k, f)| (k as f64 - tm) * (f[i] - mean)).sum::<f64>() / stt;
                mean + slope * (m - 1) as f64 / 2.0
            })
            .collect();
        let tare = Tare {
            format: TARE_FORMAT.into(),
            version: TARE_VERSION,
            layout: layout.into(),
            sensor: sensor.into(),
            taxels: n,
            frames: m as u64,
            span_ns: [times_ns[0], times_ns[m - 1]],
            baseline,
            noise,
        };
        tare.validate()?;
        Ok(tare)
    }

    /// Check a (read) tare: format and version, taxel count in bounds and matching every
    /// array, finite baselines, finite positive noise.
    pub fn validate(&self) -> Result<()> {
        if self.format != TARE_FORMAT {
            return Err(invalid(format!("format {:?} is not {TARE_FORMAT:?}", self.format)));
        }
        if self.version != TARE_VERSION {
            return Err(invalid(format!(
                "version {} (this build reads version {TARE_VERSION}; measure it again with gradtac calibrate baseline)",
                self.version
            )));
        }
        if self.taxels == 0 || self.taxels > MAX_TAXELS {
            return Err(invalid(format!("{} taxels (want 1..={MAX_TAXELS})", self.taxels)));
        }
        if self.baseline.len() != self.taxels || self.noise.len() != self.taxels {
            return Err(invalid(format!(
                "{} taxels but {} baselines and {} noise values",
                self.taxels,
                self.baseline.len(),
                self.noise.len()
            )));
        }
        if let Some(i) = self.baseline.iter().position(|v| !v.is_finite()) {
            return Err(invalid(format!("baseline of taxel {} is not finite", i + 1)));
        }
        if let Some(i) = self.noise.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(invalid(format!("noise of taxel {} is not a finite positive number", i + 1)));
        }
        if self.frames < 2 {
            return Err(invalid(format!("measured on {} frames", self.frames)));
        }
        Ok(())
    }

    /// Whether this tare's mean noise and baseline, against `values` (e.g. the first frames of
    /// a recording), look like the same sensor at rest: the median taxel's distance from its
    /// baseline in σ.
    pub fn median_sigmas(&self, values: &[f64]) -> Option<f64> {
        if values.len() != self.taxels {
            return None;
        }
        let mut z: Vec<f64> =
            values.iter().zip(&self.baseline).zip(&self.noise).map(|((v, b), s)| ((v - b) / s).abs()).collect();
        z.sort_by(f64::total_cmp);
        z.get(z.len() / 2).copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> crate::locate::LocateConfig {
        crate::locate::LocateConfig::default()
    }

    fn stretch(n: usize, m: usize, step_at: Option<usize>) -> Vec<Vec<f64>> {
        (0..m)
            .map(|k| {
                (0..n)
                    .map(|i| {
                        let noise = if (k + i) % 2 == 0 { 1.0 } else { -1.0 };
                        let step = if step_at.is_some_and(|s| k >= s) && i == 0 { 100.0 } else { 0.0 };
                        1000.0 + 10.0 * i as f64 + 0.05 * k as f64 + noise + step
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn measures_the_resting_line_at_the_end_and_refuses_a_touch() {
        let f = stretch(3, 200, None);
        let times: Vec<i64> = (0..200).map(|k| k * 10_000_000).collect();
        let t = Tare::measure(&f, &times, "l", "ff", &cfg()).unwrap();
        assert_eq!((t.taxels, t.frames, t.span_ns), (3, 200, [0, 1_990_000_000]));
        // the line at the last frame: 1000 + 10 i + 0.05·199 (± the alternation's tilt)
        assert!((t.baseline[1] - (1010.0 + 0.05 * 199.0)).abs() < 0.1, "{:?}", t.baseline);
        let json = serde_json::to_string(&t).unwrap();
        let back: Tare = serde_json::from_str(&json).unwrap();
        assert_eq!(back, t);
        let e = Tare::measure(&stretch(3, 200, Some(120)), &times, "l", "ff", &cfg()).unwrap_err().to_string();
        assert!(e.contains("not untouched") && e.contains("taxel 1"), "{e}");
        assert!(Tare::measure(&f[..5], &times[..5], "l", "ff", &cfg()).is_err());
    }

    #[test]
    fn bad_files_are_refused() {
        let f = stretch(2, 50, None);
        let times: Vec<i64> = (0..50).collect();
        let good = Tare::measure(&f, &times, "l", "ff", &cfg()).unwrap();
        for bad in [
            Tare { version: 2, ..good.clone() },
            Tare { format: "x".into(), ..good.clone() },
            Tare { taxels: 3, ..good.clone() },
            Tare { taxels: 0, baseline: vec![], noise: vec![], ..good.clone() },
            Tare { noise: vec![1.0, 0.0], ..good.clone() },
            Tare { baseline: vec![1.0, f64::NAN], ..good.clone() },
        ] {
            assert!(bad.validate().is_err(), "{bad:?}");
        }
        assert!(serde_json::from_str::<Tare>("{\"format\":\"gradtac-tare\"}").is_err());
    }
}
