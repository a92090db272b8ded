//! ROS 1 bag source: the input's first byte picks the sensors (finger or none, header or
//! record time), the rest is a bag (record headers, connection records, chunks: none, bz2,
//! lz4 — their `compression` / `size` header fields and data) read through `RosbagFrames`,
//! and again message by message through `BagReader`.
#![no_main]

use gradtac_io::rosbag::{BagReader, RosbagFrames};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, body)) = data.split_first() else { return };
    let path = gradtac_fuzz::file("fuzz.bag", body);
    if let Ok(frames) = RosbagFrames::open(&path, gradtac_fuzz::bag_sensors(mode)) {
        gradtac_fuzz::drain(frames, true);
    }
    if let Ok(mut r) = BagReader::open(&path) {
        for _ in 0..gradtac_fuzz::MAX_ITEMS {
            match r.next_message() {
                Ok(Some(m)) => {
                    let _ = (m.connection.topic.len(), m.data.len(), m.offset);
                }
                _ => break,
            }
        }
    }
});
