//! CAN frame decoding: the input is a sequence of frames (4 bytes id LE, 1 byte flags —
//! bit 7 extended, bit 6 "time is absolute", low 4 bits the length —, the data bytes, 8
//! bytes time LE: a delta in ns, or the absolute time), each decoded field by field by the
//! codec and pushed through reassembly, for both presets (biotac-mux and xela-uskin), with
//! clock advances between frames when bit 5 is set.
#![no_main]

use gradtac_io::can::{CanCodec, CanDecoder, CanFrame, CodecConfig, PresetConfig, PresetKind};
use gradtac_stream::Timestamp;
use libfuzzer_sys::fuzz_target;

fn frames(mut data: &[u8]) -> Vec<(CanFrame, bool)> {
    let mut out = Vec::new();
    let mut t: i64 = 0;
    while data.len() >= 5 && out.len() < 10_000 {
        let id = u32::from_le_bytes(data[..4].try_into().unwrap());
        let flags = data[4];
        let len = usize::from(flags & 0x0f);
        data = &data[5..];
        let payload = &data[..len.min(data.len())];
        data = &data[payload.len()..];
        let mut tb = [0u8; 8];
        let n = data.len().min(8);
        tb[..n].copy_from_slice(&data[..n]);
        data = &data[n..];
        let tv = i64::from_le_bytes(tb);
        t = if flags & 0x40 != 0 { tv } else { t.saturating_add(tv & 0xffff_ffff) };
        if let Ok(f) = CanFrame::try_new(id, flags & 0x80 != 0, payload, Timestamp(t)) {
            out.push((f, flags & 0x20 != 0));
        }
    }
    out
}

fuzz_target!(|data: &[u8]| {
    let frames = frames(data);
    for kind in [PresetKind::BiotacMux, PresetKind::XelaUskin] {
        let codec =
            CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(kind, &["ff", "mf", "th"]))).expect("preset");
        let mut fields = Vec::new();
        for (f, _) in &frames {
            let _ = codec.decode(f, &mut fields);
        }
        let mut dec = CanDecoder::new(codec);
        let mut out = Vec::new();
        for &(f, tick) in &frames {
            if tick {
                dec.advance_to(f.time(), &mut out);
            }
            dec.push_decoded(f, &mut out);
            out.clear();
        }
        dec.finish_decoded(&mut out);
    }
});
