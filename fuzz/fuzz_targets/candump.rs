//! candump log: any bytes as a `candump -l` log, decoded with the preset the first byte
//! selects (biotac-mux or xela-uskin, strict or lenient on CAN FD lines).
#![no_main]

use gradtac_io::can::candump::{CandumpReader, CandumpSource, FdPolicy};
use gradtac_io::can::{CanCodec, CanDecoder, CodecConfig, PresetConfig, PresetKind};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, body)) = data.split_first() else { return };
    let kind = if mode & 1 == 0 { PresetKind::BiotacMux } else { PresetKind::XelaUskin };
    let codec = CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(kind, &["ff", "mf"]))).expect("preset");
    let mut reader = CandumpReader::new("fuzz.log", body);
    if mode & 2 != 0 {
        reader = reader.with_fd_policy(FdPolicy::Error);
    }
    if mode & 4 != 0 {
        reader = reader.with_interface("can0");
    }
    let source = CandumpSource::new(reader, CanDecoder::new(codec));
    gradtac_fuzz::drain(source, false);
});
