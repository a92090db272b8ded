//! NumPy source: the input is a `.npy` file of frames, optionally followed by the marker
//! `TIMESTAMPS` and a second `.npy` file of timestamps (then read with those, else at a rate).
#![no_main]

use gradtac_io::npy::{NpyFrames, NpySourceConfig};
use gradtac_io::TimeUnit;
use gradtac_stream::SensorId;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let (values, times) = gradtac_fuzz::split_at(data, b"TIMESTAMPS");
    let vpath = gradtac_fuzz::file("values.npy", values);
    let cfg = match times {
        Some(t) => NpySourceConfig::with_timestamps(&vpath, gradtac_fuzz::file("times.npy", t), TimeUnit::Seconds),
        None => NpySourceConfig::with_rate(&vpath, 100.0),
    };
    if let Ok(frames) = NpyFrames::open(&cfg, SensorId::new("ff")) {
        gradtac_fuzz::drain(frames, false);
    }
});
