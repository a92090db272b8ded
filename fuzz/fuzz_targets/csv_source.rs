//! CSV source: any bytes as a CSV file, read with the column and time settings the first
//! byte selects (all columns / a pattern / names; a time column in s or ns, or a rate;
//! `,` or `;`).
#![no_main]

use gradtac_io::{ColumnSelector, CsvFrames, CsvSourceConfig, TimeUnit};
use gradtac_stream::SensorId;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, body)) = data.split_first() else { return };
    let columns = match mode & 3 {
        0 => ColumnSelector::Pattern("*".into()),
        1 => ColumnSelector::Pattern("e{1..24}".into()),
        2 => ColumnSelector::Names(vec!["a".into(), "b".into()]),
        _ => ColumnSelector::Pattern("ff_e{01..3}".into()),
    };
    let mut cfg = CsvSourceConfig::new("fuzz.csv", columns);
    cfg = match (mode >> 2) & 3 {
        0 => cfg.with_rate_hz(100.0),
        1 => cfg.with_time_column("t", TimeUnit::Seconds),
        2 => cfg.with_time_column("time_ns", TimeUnit::Nanoseconds),
        _ => cfg.with_rate_hz(1e-3),
    };
    if mode & 16 != 0 {
        cfg = cfg.with_delimiter(';');
    }
    if cfg.validate().is_err() {
        return;
    }
    if let Ok(frames) = CsvFrames::from_reader(body, Path::new("fuzz.csv"), &cfg, SensorId::new("ff")) {
        gradtac_fuzz::drain(frames, false);
    }
});
