//! MCAP source: the input's first byte picks the sensors (finger or none, header or record
//! time), the rest is an MCAP file (records, strings, chunks: uncompressed, zstd, lz4) read
//! through `McapFrames`, and again record by record through `McapReader`.
#![no_main]

use gradtac_io::rosbag::mcap_read::McapReader;
use gradtac_io::rosbag::McapFrames;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, body)) = data.split_first() else { return };
    let path = gradtac_fuzz::file("fuzz.mcap", body);
    let sensors = gradtac_fuzz::bag_sensors(mode);
    if let Ok(frames) = McapFrames::open(&path, sensors) {
        gradtac_fuzz::drain(frames, true);
    }
    if let Ok(mut r) = McapReader::open(&path) {
        for _ in 0..gradtac_fuzz::MAX_ITEMS {
            match r.next_message() {
                Ok(Some(m)) => {
                    let _ = (m.channel.topic.len(), m.data.len(), m.offset);
                }
                _ => break,
            }
        }
    }
});
