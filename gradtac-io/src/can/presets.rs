//! Built-in codec layouts (see `docs/can.md` for the wire formats, their sources and worked
//! examples).
//!
//! # `syntouch-biotac`: SynTouch BioTac words as relayed by Clearpath's `numatac_can_driver`
//! Source: the public ROS package `clearpathrobotics/numatac_can_driver`
//! (`src/numatac_can_driver.cpp`, `include/numatac_can_driver/bt_can.h`). Every frame carries
//! one sampled channel of up to three BioTacs: byte 0 holds the channel id
//! (`(data[0] & 0x7E) >> 1`: PAC 0, PDC 1, TAC 2, TDC 3, electrodes E1… at 17…), then sensor `j`'s
//! 12-bit sample in bytes `2j+1`, `2j+2` as `value = (b0 >> 1) · 32 + (b1 >> 3)`; each of the
//! two bytes carries an odd parity bit in bit 0 (the driver's `parity_values` table). Electrode
//! channels 17–40 (E1–E24 of a BioTac SP; 17–35 for the 19-electrode BioTac with
//! `taxels = 19`) become taxels 0–23; PAC/PDC/TAC/TDC frames are counted as ignored; a word
//! failing parity is counted (`parity`) and its sample dropped. The driver reads every CAN id
//! on its interface: without `base_id` the preset matches any standard id too. Values are raw
//! counts (0–4095).
//!
//! # `xela-uskin`: Xela uSkin as read by the public driver
//! Source: `o2as_xela_sensor` in the public repository `Automation-Research-Team/aist_robotiq`
//! (`src/o2as_xela_sensor/xela_sensor.py`). The host starts acquisition with a frame of id
//! `0x200 | board` (board from 1) and data `[7, 0]`; the board then sends one frame per taxel
//! at id `0x710 + taxel` (16 taxels, a 4×4 module) with `X = d[1] << 8 | d[2]`,
//! `Y = d[3] << 8 | d[4]`, `Z = d[5] << 8 | d[6]`; `d[1] ≥ 250` marks an invalid sample
//! (counted `invalid_sample`, the taxel's value unused). The preset maps Z, the normal
//! component, to the taxel's value (raw counts). Frames are 8 bytes (the driver reads `d[1]`–`d[6]`;
//! the length is our assumption). Sensor `i` of the preset owns ids
//! `base_id + i·B …` with `B` = `taxels` rounded up to a power of two — the public driver
//! handles one board only, so ids for a second board are our extrapolation.
//!
//! # `biotac-mux`: our own framing (no device uses it)
//! A compact multiplexed layout of our own for hands that have no CAN framing (simulated hands,
//! bridges we write): fingertip `i` uses the single id `base_id + i` (default `0x100`). Each
//! frame is 8 bytes; byte 0 is the multiplexer:
//!
//! | mux (byte 0) | bytes 1–6 | byte 7 |
//! |---|---|---|
//! | 0–5 | electrodes `4·mux + 1 … 4·mux + 4` (taxels `4·mux … 4·mux + 3`) as four unsigned 12-bit fields, big-endian, MSB first: `b1 b2 b3 b4 b5 b6` = `E0 E0 E0 E1 E1 E1 E2 E2 E2 E3 E3 E3` in nibbles | reserved |
//! | 6, 7, 8 | PDC, TAC, TDC words (pressure and temperatures) that a hand rotates through the same id | reserved |
//!
//! so a complete fingertip frame takes the six frames with mux 0–5. Mux 6–8 are counted as
//! ignored; any other mux value is a fault. A 12-bit electrode reading of `0x000` or `0xFFF`
//! sits on an ADC rail (an open or shorted electrode), so the valid raw range is
//! `1 … 4094` unless `raw_min`/`raw_max` widen it. Values are raw counts (scale 1).

use crate::can::codec::{InvalidIf, MessageSpec, MuxSpec, PresetConfig, PresetKind, SensorSpec, WordFormat};
use crate::can::frame::{MAX_EXTENDED_ID, MAX_STANDARD_ID};
use crate::{Error, Result};

/// Default first id of `biotac-mux`.
pub const BIOTAC_MUX_BASE_ID: u32 = 0x100;
/// Default first id of `xela-uskin` (the public driver's 1808 = `0x710`).
pub const XELA_USKIN_BASE_ID: u32 = 0x710;
/// `xela-uskin`: start-acquisition command id is `XELA_USKIN_START_ID | board` (board from 1).
pub const XELA_USKIN_START_ID: u32 = 0x200;
/// `xela-uskin`: data of the start-acquisition command.
pub const XELA_USKIN_START_DATA: [u8; 2] = [7, 0];
/// `xela-uskin`: `data[1]` at or above this marks an invalid sample.
pub const XELA_USKIN_INVALID_MIN: u8 = 250;
/// `syntouch-biotac`: channel id of electrode E1 (E1–E24 are 17–40).
pub const SYNTOUCH_FIRST_ELECTRODE: u8 = 17;
/// `syntouch-biotac`: channel ids of PAC, PDC, TAC and TDC (counted as ignored).
pub const SYNTOUCH_OTHER_CHANNELS: [u8; 4] = [0, 1, 2, 3];
/// `syntouch-biotac`: at most this many sensors' words fit one 8-byte frame.
pub const SYNTOUCH_MAX_SENSORS: usize = 3;
/// Electrodes of a BioTac-style fingertip.
pub const BIOTAC_ELECTRODES: u32 = 24;
/// Multiplexer values of `biotac-mux` that carry PDC / TAC / TDC words (ignored).
pub const BIOTAC_MUX_OTHER: [u8; 3] = [6, 7, 8];
/// Default taxels of an `xela-uskin` module (4×4).
pub const XELA_USKIN_TAXELS: u32 = 16;

pub(crate) fn expand(p: &PresetConfig) -> Result<Vec<SensorSpec>> {
    let bad = |s: String| Error::InvalidConfig(format!("CAN preset {:?}: {s}", p.kind.as_str()));
    if p.sensors.is_empty() {
        return Err(bad("no sensors".into()));
    }
    let width = if p.extended { MAX_EXTENDED_ID } else { MAX_STANDARD_ID };
    let n = p.sensors.len() as u64;
    match p.kind {
        PresetKind::BiotacMux => {
            if p.taxels.is_some_and(|t| t != BIOTAC_ELECTRODES) {
                return Err(bad(format!("has {BIOTAC_ELECTRODES} taxels per fingertip; `taxels` cannot change that")));
            }
            let base = p.base_id.unwrap_or(BIOTAC_MUX_BASE_ID);
            if u64::from(base) + n - 1 > u64::from(width) {
                return Err(bad(format!("ids {base:#x}+{n} do not fit the identifier")));
            }
            Ok(p.sensors
                .iter()
                .enumerate()
                .map(|(i, name)| SensorSpec {
                    name: name.clone(),
                    taxels: BIOTAC_ELECTRODES,
                    timeout_ms: p.timeout_ms,
                    incomplete: p.incomplete,
                    messages: vec![MessageSpec {
                        extended: p.extended,
                        length: Some(8),
                        mux: Some(MuxSpec::new(0, 6, BIOTAC_MUX_OTHER.to_vec())),
                        raw_min: Some(p.raw_min.unwrap_or(1)),
                        raw_max: Some(p.raw_max.unwrap_or(4094)),
                        ..MessageSpec::new(base + i as u32, 8, 12, 4)
                    }],
                })
                .collect())
        }
        PresetKind::XelaUskin => {
            let taxels = p.taxels.unwrap_or(XELA_USKIN_TAXELS);
            if taxels == 0 || taxels > 1024 {
                return Err(bad(format!("taxels = {taxels}; must be 1–1024")));
            }
            let block = taxels.next_power_of_two();
            let base = p.base_id.unwrap_or(XELA_USKIN_BASE_ID);
            if base % block != 0 {
                return Err(bad(format!(
                    "base_id {base:#x} must be a multiple of {block:#x} (taxels rounded up to a power of two)"
                )));
            }
            if u64::from(base) + n * u64::from(block) - 1 > u64::from(width) {
                return Err(bad(format!("{n} blocks of {block} ids from {base:#x} do not fit the identifier")));
            }
            Ok(p.sensors
                .iter()
                .enumerate()
                .map(|(i, name)| SensorSpec {
                    name: name.clone(),
                    taxels,
                    timeout_ms: p.timeout_ms,
                    incomplete: p.incomplete,
                    messages: vec![MessageSpec {
                        extended: p.extended,
                        mask: Some(width & !(block - 1)),
                        id_groups: Some(taxels),
                        length: Some(8),
                        raw_min: p.raw_min,
                        raw_max: p.raw_max,
                        invalid_if: Some(InvalidIf { byte: 1, min: XELA_USKIN_INVALID_MIN }),
                        ..MessageSpec::new(base + i as u32 * block, 40, 16, 1)
                    }],
                })
                .collect())
        }
        PresetKind::SyntouchBiotac => {
            if p.sensors.len() > SYNTOUCH_MAX_SENSORS {
                return Err(bad(format!(
                    "{} sensors, but one 8-byte frame holds the words of at most {SYNTOUCH_MAX_SENSORS}",
                    p.sensors.len()
                )));
            }
            let taxels = p.taxels.unwrap_or(BIOTAC_ELECTRODES);
            if !(1..=BIOTAC_ELECTRODES).contains(&taxels) {
                return Err(bad(format!("taxels = {taxels}; electrode channels 17–40 give 1–24")));
            }
            // Without base_id, any standard id (as the driver reads every frame).
            let (id, mask, shift) = match p.base_id {
                Some(b) => (b, width, 0),
                None if p.extended => return Err(bad("give base_id for extended ids".into())),
                None => (0, 0, 11),
            };
            let n = p.sensors.len() as u8;
            Ok(p.sensors
                .iter()
                .enumerate()
                .map(|(j, name)| SensorSpec {
                    name: name.clone(),
                    taxels,
                    timeout_ms: p.timeout_ms,
                    incomplete: p.incomplete,
                    messages: vec![MessageSpec {
                        extended: p.extended,
                        mask: Some(mask),
                        shift,
                        id_groups: Some(1),
                        length: Some(1 + 2 * n),
                        mux: Some(MuxSpec {
                            mask: 0x7E,
                            shift: 1,
                            first: SYNTOUCH_FIRST_ELECTRODE,
                            ..MuxSpec::new(0, taxels, SYNTOUCH_OTHER_CHANNELS.to_vec())
                        }),
                        word: WordFormat::Biotac,
                        shared: true,
                        raw_min: p.raw_min,
                        raw_max: p.raw_max,
                        ..MessageSpec::new(id, 8 + 16 * j as u32, 16, 1)
                    }],
                })
                .collect())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::can::codec::{biotac_word, CanCodec, CodecConfig, Decoded, PresetConfig, PresetKind};
    use crate::can::frame::CanFrame;
    use crate::can::{CanDecoder, FaultKind};
    use gradtac_stream::StageExt;
    use gradtac_stream::Timestamp;

    #[test]
    fn biotac_mux_layout() {
        let c =
            CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &["ff", "mf"]))).unwrap();
        assert_eq!(c.num_sensors(), 2);
        assert_eq!(c.taxels(1), 24);
        // mf (0x101), mux 5: electrodes 20..23 = 0x123, 0x456, 0x789, 0xABC
        let f = CanFrame::standard(0x101, &[5, 0x12, 0x34, 0x56, 0x78, 0x9A, 0xBC, 0], Timestamp(0)).unwrap();
        let mut out = Vec::new();
        assert_eq!(c.decode(&f, &mut out), Decoded::Values { sensor: 1, group: 5 });
        let got: Vec<(u32, Option<f64>)> = out.iter().map(|v| (v.taxel, v.value)).collect();
        assert_eq!(got, vec![(20, Some(291.0)), (21, Some(1110.0)), (22, Some(1929.0)), (23, Some(2748.0))]);
        let rail = CanFrame::standard(0x100, &[0, 0xFF, 0xF0, 0x00, 0, 0x01, 0x00, 0], Timestamp(0)).unwrap();
        c.decode(&rail, &mut out);
        assert_eq!(out.iter().map(|v| v.value).collect::<Vec<_>>(), vec![None, None, None, Some(256.0)]);
        let pdc = CanFrame::standard(0x100, &[7, 0, 0, 0, 0, 0, 0, 0], Timestamp(0)).unwrap();
        assert_eq!(c.decode(&pdc, &mut out), Decoded::Ignored { sensor: 0, value: 7 });
    }

    #[test]
    fn xela_uskin_layout() {
        // the public driver's one board: taxel t at 0x710 + t, z = d[5] << 8 | d[6]
        let c = CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::XelaUskin, &["board1"]))).unwrap();
        assert_eq!(c.taxels(0), 16);
        let f = CanFrame::standard(0x715, &[0, 0x01, 0x02, 0x03, 0x04, 0x12, 0x34, 0], Timestamp(0)).unwrap();
        let mut out = Vec::new();
        assert_eq!(c.decode(&f, &mut out), Decoded::Values { sensor: 0, group: 5 });
        assert_eq!((out[0].taxel, out[0].value, out[0].fault), (5, Some(4660.0), None));
        // d[1] = 249 is still a sample; 250 and above mark it invalid
        let f = CanFrame::standard(0x71F, &[0, 249, 0xFF, 0, 0, 0xFF, 0xFF, 0], Timestamp(0)).unwrap();
        c.decode(&f, &mut out);
        assert_eq!((out[0].taxel, out[0].value), (15, Some(65535.0)));
        let f = CanFrame::standard(0x71F, &[0, 250, 0, 0, 0, 0x12, 0x34, 0], Timestamp(0)).unwrap();
        c.decode(&f, &mut out);
        assert_eq!((out[0].value, out[0].fault), (None, Some(FaultKind::InvalidSample)));
        // the start command and ids past the module are not taxel frames
        let start = CanFrame::standard(XELA_USKIN_START_ID | 1, &XELA_USKIN_START_DATA, Timestamp(0)).unwrap();
        assert_eq!(c.decode(&start, &mut out), Decoded::UnknownId);
        let f = CanFrame::standard(0x720, &[0; 8], Timestamp(0)).unwrap();
        assert_eq!(c.decode(&f, &mut out), Decoded::UnknownId);
        let mut p = PresetConfig::new(PresetKind::XelaUskin, &["m0"]);
        p.base_id = Some(0x708);
        let e = CanCodec::try_new(&CodecConfig::preset(p)).unwrap_err().to_string();
        assert!(e.contains("CAN preset \"xela-uskin\": base_id 0x708 must be a multiple of 0x10"), "{e}");
    }

    #[test]
    fn xela_uskin_invalid_samples_are_counted_and_unused() {
        let c = CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::XelaUskin, &["b"]))).unwrap();
        let frame = |t: u32, d1: u8, z: u16, ms: i64| {
            let [hi, lo] = z.to_be_bytes();
            CanFrame::standard(0x710 + t, &[0, d1, 0, 0, 0, hi, lo, 0], Timestamp(ms * 1_000_000)).unwrap()
        };
        let mut frames: Vec<CanFrame> = (0..16).map(|t| frame(t, 0, 100 + t as u16, 0)).collect();
        frames.extend((0..16).map(|t| frame(t, if t == 7 { 251 } else { 1 }, 200 + t as u16, 10)));
        frames.extend((0..16).map(|t| frame(t, 2, 300 + t as u16, 20)));
        let mut dec = CanDecoder::new(c);
        let got = dec.run_all(frames).unwrap();
        assert_eq!(got.len(), 2, "the cycle with an invalid sample is dropped");
        assert_eq!(got[0].values, (100..116).map(f64::from).collect::<Vec<_>>());
        assert_eq!(got[1].values, (300..316).map(f64::from).collect::<Vec<_>>());
        let st = dec.stats();
        assert_eq!((st.invalid_sample.count, st.sets_dropped, st.out_of_range.count), (1, 1, 0));
    }

    /// A BioTac word by hand: 7 high bits in b0[7:1], 5 low bits in b1[7:3], odd parity in bit 0.
    #[test]
    fn biotac_words_by_hand() {
        // 1234 = 38·32 + 18: b0 = 38 << 1 = 0x4C (3 ones: parity 0), b1 = 18 << 3 = 0x90 (2 ones: parity 1)
        assert_eq!(biotac_word(1234), 0x4C91);
        assert_eq!(biotac_word(0), 0x0101);
        assert_eq!(biotac_word(4095), 0xFEF8);
    }

    #[test]
    fn syntouch_biotac_layout() {
        let c =
            CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::SyntouchBiotac, &["ff", "mf", "th"])))
                .unwrap();
        // channel E5 = 21: (0xAB & 0x7E) >> 1 = 21 (bit 7 and the parity bit are not the id);
        // ff = 1234, mf = 0, th = 4095
        let f = CanFrame::standard(0x123, &[0xAB, 0x4C, 0x91, 0x01, 0x01, 0xFE, 0xF8], Timestamp(0)).unwrap();
        let mut out = Vec::new();
        let mut got = Vec::new();
        let mut from = 0;
        loop {
            let (d, next) = c.decode_from(from, &f, &mut out);
            got.push((d, out.iter().map(|v| (v.taxel, v.value)).collect::<Vec<_>>()));
            match next {
                Some(n) if n < 3 => from = n,
                _ => break,
            }
        }
        assert_eq!(
            got,
            vec![
                (Decoded::Values { sensor: 0, group: 4 }, vec![(4, Some(1234.0))]),
                (Decoded::Values { sensor: 1, group: 4 }, vec![(4, Some(0.0))]),
                (Decoded::Values { sensor: 2, group: 4 }, vec![(4, Some(4095.0))]),
            ]
        );
        // th's high byte with even parity (0x4D: 4 ones): counted, never decoded
        let f = CanFrame::standard(0x123, &[0xAB, 0x4C, 0x91, 0x01, 0x01, 0x4D, 0x91], Timestamp(0)).unwrap();
        c.decode_from(2, &f, &mut out);
        assert_eq!((out[0].raw, out[0].value, out[0].fault), (1234, None, Some(FaultKind::Parity)));
        // PAC (channel 0) is ignored; channel 41 is not an electrode
        let pac = CanFrame::standard(0x123, &[0x80, 1, 1, 1, 1, 1, 1], Timestamp(0)).unwrap();
        assert_eq!(c.decode(&pac, &mut out), Decoded::Ignored { sensor: 0, value: 0 });
        let e41 = CanFrame::standard(0x123, &[41 << 1, 1, 1, 1, 1, 1, 1], Timestamp(0)).unwrap();
        assert_eq!(c.decode(&e41, &mut out), Decoded::UnknownMux { sensor: 0, value: 41 });
        let short = CanFrame::standard(0x123, &[0xAB, 0x4C, 0x91], Timestamp(0)).unwrap();
        assert!(matches!(c.decode(&short, &mut out), Decoded::WrongLength { expected: 7, got: 3, .. }));
        let four = PresetConfig::new(PresetKind::SyntouchBiotac, &["a", "b", "c", "d"]);
        assert!(CanCodec::try_new(&CodecConfig::preset(four)).unwrap_err().to_string().contains("at most 3"));
    }

    /// Full cycles of a three-BioTac relay with PAC interleaved (as the SynTouch frame
    /// structure samples it), one parity failure: that sensor's cycle is dropped and counted.
    #[test]
    fn syntouch_biotac_cycles_and_parity_failures() {
        let mut p = PresetConfig::new(PresetKind::SyntouchBiotac, &["ff", "mf", "th"]);
        p.base_id = Some(0x3A0);
        let c = CanCodec::try_new(&CodecConfig::preset(p)).unwrap();
        let value = |cycle: u16, s: u16, e: u16| 100 * cycle + 1000 * s + e;
        let mut frames = Vec::new();
        let mut t = 0;
        for cycle in 0..3u16 {
            for e in 0..24u16 {
                let mut d = vec![(17 + e as u8) << 1];
                for s in 0..3 {
                    let mut w = biotac_word(value(cycle, s, e)).to_be_bytes();
                    if cycle == 1 && s == 2 && e == 9 {
                        w[1] ^= 0x08; // one flipped data bit: b1 now has even parity
                    }
                    d.extend(w);
                }
                frames.push(CanFrame::standard(0x3A0, &d, Timestamp(t)).unwrap());
                frames.push(CanFrame::standard(0x3A0, &[0x81, 1, 1, 1, 1, 1, 1], Timestamp(t + 1)).unwrap());
                t += 10_000;
            }
        }
        frames.push(CanFrame::standard(0x3A1, &[0; 7], Timestamp(t)).unwrap());
        let mut dec = CanDecoder::new(c);
        let got = dec.run_all(frames).unwrap();
        let names: Vec<&str> = got.iter().map(|f| f.sensor.as_str()).collect();
        assert_eq!(names, ["ff", "mf", "th", "ff", "mf", "ff", "mf", "th"]);
        for f in &got {
            let s = ["ff", "mf", "th"].iter().position(|n| *n == f.sensor.as_str()).unwrap() as u16;
            let cycle = f.seq as u16;
            assert_eq!(f.values, (0..24).map(|e| f64::from(value(cycle, s, e))).collect::<Vec<_>>());
        }
        let st = dec.stats();
        assert_eq!((st.parity.count, st.sets_dropped, st.frames_ignored, st.unknown_id.count), (1, 1, 72, 1));
        assert_eq!(st.frames_decoded, 72);
    }

    #[test]
    fn syntouch_biotac_encodes_shared_frames_that_decode_back() {
        let c = CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::SyntouchBiotac, &["ff", "th"])))
            .unwrap();
        let ff: Vec<f64> = (0..24).map(|e| f64::from(e * 170)).collect();
        let th: Vec<f64> = (0..24).map(|e| 4095.0 - f64::from(e)).collect();
        let mut can = Vec::new();
        c.encode_shared(&[(0, &ff), (1, &th)], Timestamp(5), &mut can).unwrap();
        assert_eq!(can.len(), 24);
        // E5: ff = 680 = 21·32 + 8 → 0x2A (3 ones), 8 << 3 = 0x40 (1 one);
        // th = 4091 = 127·32 + 27 → 0xFE (7 ones), 27 << 3 = 0xD8 (4 ones) → parity bit: 0xD9
        assert_eq!(can[4].data(), &[21 << 1, 0x2A, 0x40, 0xFE, 0xD9]);
        let e = c.encode(0, &ff, Timestamp(5), &mut can).unwrap_err().to_string();
        assert!(e.contains("encode_shared"), "{e}");
        let e = c.encode_shared(&[(0, &ff)], Timestamp(5), &mut can).unwrap_err().to_string();
        assert!(e.contains("\"th\"") && e.contains("give its values too"), "{e}");
        let got = CanDecoder::new(c).run_all(can).unwrap();
        assert_eq!((got[0].values.clone(), got[1].values.clone()), (ff, th));
    }

    #[test]
    fn preset_from_toml() {
        let cfg: CodecConfig = toml::from_str(
            "[preset]\nkind = \"biotac-mux\"\nsensors = [\"ff\", \"mf\", \"th\"]\nbase_id = 0x400\nincomplete = \"carry\"\ntimeout_ms = 25.0\n",
        )
        .unwrap();
        let c = CanCodec::try_new(&cfg).unwrap();
        assert_eq!(c.sensor_id(2).as_str(), "th");
        let mut out = Vec::new();
        let f = CanFrame::standard(0x402, &[0; 8], Timestamp(0)).unwrap();
        assert!(matches!(c.decode(&f, &mut out), Decoded::Values { sensor: 2, .. }));
    }
}
