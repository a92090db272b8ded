//! Built-in codec layouts (see `docs/can.md` for the wire formats with worked examples).
//!
//! # `xela-uskin`: one frame per taxel, big-endian 16-bit fields
//! A uSkin-style module sends one frame per taxel and cycle. Sensor `i` of the preset owns the
//! id block `base_id + i·B … base_id + i·B + taxels − 1`, where `B` is `taxels` rounded up to
//! a power of two (16 for the default 16-taxel 4×4 module); the id's low bits are the taxel
//! index. The data is 6 bytes: `x` (bytes 0–1), `y` (bytes 2–3) and `z` (bytes 4–5), each an
//! unsigned big-endian 16-bit count. The preset maps `z`, the normal component GradTac works
//! on, to the taxel's value (counts, scale 1); `x`/`y` are not decoded (a custom codec with
//! `start_bit = 0, count = 3` maps all three to 3 channels per taxel). Every 16-bit value is
//! valid unless `raw_min`/`raw_max` say otherwise. Default `base_id` = `0x200`.
//!
//! # `biotac-mux`: multiplexed per-fingertip frames, 24 electrodes in 12-bit fields
//! Fingertip `i` uses the single id `base_id + i` (default `base_id` = `0x100`). Each frame is
//! 8 bytes; byte 0 is the multiplexer:
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

use crate::can::codec::{MessageSpec, MuxSpec, PresetConfig, PresetKind, SensorSpec};
use crate::can::frame::{MAX_EXTENDED_ID, MAX_STANDARD_ID};
use crate::{Error, Result};

/// Default first id of `biotac-mux`.
pub const BIOTAC_MUX_BASE_ID: u32 = 0x100;
/// Default first id of `xela-uskin`.
pub const XELA_USKIN_BASE_ID: u32 = 0x200;
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
                        mux: Some(MuxSpec { byte: 0, groups: 6, ignore: BIOTAC_MUX_OTHER.to_vec() }),
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
                        length: Some(6),
                        raw_min: p.raw_min,
                        raw_max: p.raw_max,
                        ..MessageSpec::new(base + i as u32 * block, 32, 16, 1)
                    }],
                })
                .collect())
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::can::codec::{CanCodec, CodecConfig, Decoded, PresetConfig, PresetKind};
    use crate::can::frame::CanFrame;
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
        let mut p = PresetConfig::new(PresetKind::XelaUskin, &["m0", "m1"]);
        p.taxels = Some(12);
        let c = CanCodec::try_new(&CodecConfig::preset(p.clone())).unwrap();
        // m1 owns 0x210..0x21B; taxel 11 → z = bytes 4-5
        let f = CanFrame::standard(0x21B, &[0, 1, 0, 2, 0x12, 0x34], Timestamp(0)).unwrap();
        let mut out = Vec::new();
        assert_eq!(c.decode(&f, &mut out), Decoded::Values { sensor: 1, group: 11 });
        assert_eq!((out[0].taxel, out[0].value), (11, Some(4660.0)));
        let f = CanFrame::standard(0x21C, &[0; 6], Timestamp(0)).unwrap();
        assert_eq!(c.decode(&f, &mut out), Decoded::UnknownId);
        p.base_id = Some(0x208);
        let e = CanCodec::try_new(&CodecConfig::preset(p)).unwrap_err().to_string();
        assert!(e.contains("CAN preset \"xela-uskin\": base_id 0x208 must be a multiple of 0x10"), "{e}");
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
