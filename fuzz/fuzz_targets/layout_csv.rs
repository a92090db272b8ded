//! Electrode layout CSV: any bytes as a layout file.
#![no_main]

use gradtac_stream::Layout;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(layout) = Layout::from_csv_reader("fuzz", data, Path::new("fuzz-layout.csv")) {
        // what the stages ask of a layout
        let _ = layout.len();
    }
});
