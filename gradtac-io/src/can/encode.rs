//! Encoding taxel frames into CAN frames: the inverse of the codec, for simulated hands on a
//! virtual bus, replay of recorded data onto a bus, and writing candump logs
//! ([`CandumpWriter`](super::CandumpWriter)).
//!
//! ```text
//! TaxelFrame ──CanEncoder (codec, out-of-range policy, counts)──> CanFrame ──> frame_channel / bus / candump log
//! ```
//!
//! - [`CanCodec::encode`]: one sensor's values → its CAN frames; strict (a value that does not
//!   fit is an error naming sensor, taxel and CAN id); stateless.
//! - [`CanEncoder`]: owns a codec; looks sensors up by [`SensorId`]; optional clamping
//!   ([`OutOfRangePolicy::Clamp`], counted in [`EncodeStats`]); a [`Stage`] from
//!   [`TaxelFrame`]s to [`CanFrame`]s.
//!
//! # What decoding gives back
//! Each value is quantised to `raw = round((value − offset) / scale)` (nearest level), so
//! - a value on the codec's grid (`raw · scale + offset` for a valid `raw`, e.g. anything a
//!   [`CanDecoder`](super::CanDecoder) emitted) decodes back bit-equal;
//! - any other value inside the valid range decodes to within half a quantum (`|scale| / 2`);
//! - a value more than half a quantum outside `[raw_min, raw_max]` (after scaling), or not
//!   finite, is an error ([`Error::CanEncode`]) — or, under [`OutOfRangePolicy::Clamp`], a
//!   finite one becomes the nearest valid level and is counted.
//!
//! All frames of one set carry the set's time, so the decoder's output frame (stamped with
//! its last CAN frame) has the input's time; `seq` is the decoder's own count. Restamp frames
//! with [`CanFrame::with_time`] to spread a cycle over time. Bits that no field or multiplexer
//! uses are zero (the `x`/`y` words of `xela-uskin`, byte 7 of `biotac-mux`), and multiplexer
//! values listed in `ignore` are never produced: the encoder writes taxel data only.
//!
//! # Example
//! ```
//! use gradtac_io::can::{CanCodec, CanDecoder, CanEncoder, CodecConfig, PresetConfig, PresetKind};
//! use gradtac_stream::{SensorId, StageExt, TaxelFrame, Timestamp};
//!
//! let codec = CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &["ff", "mf"])))?;
//! let mut enc = CanEncoder::new(codec.clone());
//! // fingertip "mf": 24 electrodes, raw counts 1 … 4094
//! let values: Vec<f64> = (0..24).map(|e| 1000.0 + e as f64).collect();
//! let frame = TaxelFrame::new(SensorId::new("mf"), Timestamp(1_000_000), 0, values.clone());
//! let mut can = Vec::new();
//! enc.encode_frame(&frame, &mut can)?;
//! assert_eq!(can.len(), 6); // mux 0 … 5, id 0x101
//! assert_eq!(can[0].data(), &[0, 0x3E, 0x83, 0xE9, 0x3E, 0xA3, 0xEB, 0]); // 1000, 1001, 1002, 1003
//!
//! let decoded = CanDecoder::new(codec).run_all(can)?;
//! assert_eq!(decoded, vec![frame]);
//!
//! // 5000 does not fit a 12-bit electrode: an error naming sensor, taxel and CAN id
//! let mut bad = values;
//! bad[9] = 5000.0;
//! let e = enc.encode(1, &bad, Timestamp(0), &mut Vec::new()).unwrap_err().to_string();
//! assert!(e.starts_with("CAN encoding of sensor \"mf\" taxel 9: value 5000 is outside"), "{e}");
//! assert!(e.ends_with("(CAN id 101, mux 2)"), "{e}");
//! # Ok::<(), gradtac_io::Error>(())
//! ```

use crate::can::codec::CanCodec;
use crate::can::frame::CanFrame;
use crate::{Error, Result};
use gradtac_stream::{Delay, SensorId, Stage, TaxelFrame, Timestamp};
use serde::{Deserialize, Serialize};

/// What [`CanEncoder`] does with a finite value outside its field's valid range.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum OutOfRangePolicy {
    /// Fail with [`Error::CanEncode`] naming the sensor, taxel and CAN id (`"error"`).
    #[default]
    #[serde(rename = "error")]
    Error,
    /// Encode the nearest valid raw value (`raw_min` or `raw_max`) and count it in
    /// [`EncodeStats::clamped`] (`"clamp"`): a saturating sensor. Non-finite values are errors
    /// even so. Note that presets' valid ranges can be narrower than the field (`biotac-mux`:
    /// 1 … 4094), so a clamped value lands on the last *valid* level, never on a rail.
    #[serde(rename = "clamp")]
    Clamp,
}

/// What a [`CanEncoder`] produced.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct EncodeStats {
    /// Taxel sets (frames of one sensor) encoded.
    pub sets: u64,
    /// CAN frames produced.
    pub frames: u64,
    /// Values clamped to their field's valid range ([`OutOfRangePolicy::Clamp`]).
    pub clamped: u64,
    /// Where the first clamp happened (sensor, time, how many values of that set), if any.
    pub first_clamp: Option<String>,
}

/// Encodes taxel frames into CAN frames with a [`CanCodec`] (see the [module docs](self)).
///
/// As a [`Stage`] it takes [`TaxelFrame`]s and yields each one's CAN frames, stamped with the
/// frame's time; a frame of a sensor the codec does not have, with the wrong number of values,
/// or with a value that does not fit (unless clamping) is an `Err` and produces no CAN frame.
/// It holds no state between frames but its counts: [`delay`](Stage::delay) is zero and
/// [`reset`](Stage::reset) does nothing (counts are kept, as the decoder's are).
#[derive(Clone, Debug)]
#[must_use = "an encoder does nothing until frames are pushed"]
pub struct CanEncoder {
    codec: CanCodec,
    policy: OutOfRangePolicy,
    stats: EncodeStats,
}

impl CanEncoder {
    /// An encoder for a validated codec; out-of-range values are errors.
    pub fn new(codec: CanCodec) -> Self {
        CanEncoder { codec, policy: OutOfRangePolicy::Error, stats: EncodeStats::default() }
    }

    /// The same encoder with another out-of-range policy.
    pub fn with_out_of_range(mut self, policy: OutOfRangePolicy) -> Self {
        self.policy = policy;
        self
    }

    /// The codec.
    pub fn codec(&self) -> &CanCodec {
        &self.codec
    }

    /// Counts so far.
    pub fn stats(&self) -> &EncodeStats {
        &self.stats
    }

    /// Encode one set of sensor index `sensor`'s values, stamped `time`, appending the CAN
    /// frames to `out` (see [`CanCodec::encode`]; clamps under [`OutOfRangePolicy::Clamp`]).
    /// On error `out` is left as it was and nothing is counted.
    pub fn encode(&mut self, sensor: usize, values: &[f64], time: Timestamp, out: &mut Vec<CanFrame>) -> Result<()> {
        let before = out.len();
        let clamped = self.codec.encode_with(sensor, values, time, self.policy == OutOfRangePolicy::Clamp, out)?;
        self.stats.sets += 1;
        self.stats.frames += (out.len() - before) as u64;
        if clamped > 0 {
            self.stats.clamped += clamped;
            if self.stats.first_clamp.is_none() {
                self.stats.first_clamp = Some(format!(
                    "sensor {:?} at {} ns: {clamped} of {} values clamped",
                    self.codec.sensor_id(sensor).as_str(),
                    time.as_nanos(),
                    values.len()
                ));
            }
            tracing::debug!(
                target: "gradtac_io::can",
                sensor = self.codec.sensor_id(sensor).as_str(),
                time_ns = time.as_nanos(),
                count = clamped,
                "encoder clamped values to their valid range"
            );
        }
        Ok(())
    }

    /// Encode a taxel frame: its sensor is looked up by name, its time stamps the CAN frames.
    pub fn encode_frame(&mut self, frame: &TaxelFrame, out: &mut Vec<CanFrame>) -> Result<()> {
        let Some(i) = self.codec.sensor_index(&frame.sensor) else {
            return Err(Error::CanEncode {
                sensor: frame.sensor.as_str().to_string(),
                taxel: None,
                reason: format!("frame {}: the codec has no such sensor", frame.seq),
            });
        };
        self.encode(i, &frame.values, frame.time, out)
    }

    /// The index of a sensor in the codec; see [`CanCodec::sensor_index`].
    pub fn sensor_index(&self, id: &SensorId) -> Option<usize> {
        self.codec.sensor_index(id)
    }
}

impl Stage for CanEncoder {
    type In = TaxelFrame;
    type Out = CanFrame;
    type Error = Error;

    fn push(&mut self, input: TaxelFrame, out: &mut Vec<CanFrame>) -> Result<()> {
        self.encode_frame(&input, out)
    }

    /// Nothing to forget: the encoder keeps no state between frames (counts are kept).
    fn reset(&mut self) {}

    fn delay(&self) -> Delay {
        Delay::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::can::codec::{ByteOrder, CodecConfig, IncompletePolicy, MessageSpec, MuxSpec, SensorSpec};
    use crate::can::{CanDecoder, PresetConfig, PresetKind};
    use gradtac_stream::StageExt;

    fn codec(messages: Vec<MessageSpec>, taxels: u32) -> CanCodec {
        let s = SensorSpec { name: "s".into(), taxels, timeout_ms: 50.0, incomplete: IncompletePolicy::Drop, messages };
        CanCodec::from_sensors(&[s]).unwrap()
    }

    fn encode(c: &CanCodec, values: &[f64]) -> Result<Vec<CanFrame>> {
        let mut out = Vec::new();
        c.encode(0, values, Timestamp(7), &mut out)?;
        Ok(out)
    }

    #[test]
    fn packs_the_documented_layouts() {
        // docs/can.md, biotac-mux: mf (0x101), mux 5 → 05 12 34 56 78 9A BC 00
        let c =
            CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &["ff", "mf"]))).unwrap();
        let mut v = vec![2000.0; 24];
        v[20..].copy_from_slice(&[291.0, 1110.0, 1929.0, 2748.0]);
        let mut out = Vec::new();
        c.encode(1, &v, Timestamp(7), &mut out).unwrap();
        assert_eq!(out.len(), 6);
        assert!(out.iter().all(|f| f.id() == 0x101 && !f.is_extended() && f.time() == Timestamp(7)));
        assert_eq!(out[5].data(), &[5, 0x12, 0x34, 0x56, 0x78, 0x9A, 0xBC, 0]);
        // xela-uskin with 12 taxels: m1 taxel 11 is id 0x72B, z = 0x1234 in bytes 5-6
        let mut p = PresetConfig::new(PresetKind::XelaUskin, &["m0", "m1"]);
        p.taxels = Some(12);
        let c = CanCodec::try_new(&CodecConfig::preset(p)).unwrap();
        let mut v = vec![0.0; 12];
        v[11] = 4660.0;
        out.clear();
        c.encode(1, &v, Timestamp(0), &mut out).unwrap();
        assert_eq!(out.iter().map(|f| f.id()).collect::<Vec<_>>(), (0x720..0x72C).collect::<Vec<_>>());
        assert_eq!(out[11].data(), &[0, 0, 0, 0, 0, 0x12, 0x34, 0]);
    }

    #[test]
    fn packs_little_endian_signed_fields_and_id_bits() {
        // the decoder's own test layouts, run backwards
        let m = MessageSpec { byte_order: ByteOrder::Little, ..MessageSpec::new(0x10, 8, 12, 2) };
        let out = encode(&codec(vec![m], 2), &[0xDAB as f64, 0xEFC as f64]).unwrap();
        assert_eq!(out[0].data(), &[0, 0xAB, 0xCD, 0xEF]);
        let m = MessageSpec {
            signed: true,
            scale: 0.5,
            offset: 10.0,
            raw_min: Some(-100),
            raw_max: Some(100),
            ..MessageSpec::new(0x10, 0, 16, 2)
        };
        let out = encode(&codec(vec![m], 2), &[9.0, 60.0]).unwrap();
        assert_eq!(out[0].data(), &[0xFF, 0xFE, 0x00, 0x64]);
        // ids 0x200..0x203 with 3 mux blocks of 2 taxels; the id's free bits hold the id index,
        // other bits of `id` are kept, a fixed `length` pads with zeros
        let m = MessageSpec {
            mask: Some(0x7F3),
            shift: 2,
            id_groups: Some(2),
            mux: Some(MuxSpec::new(0, 3, vec![9])),
            length: Some(8),
            ..MessageSpec::new(0x201, 8, 8, 2)
        };
        let out = encode(&codec(vec![m], 12), &(0..12).map(f64::from).collect::<Vec<_>>()).unwrap();
        let got: Vec<(u32, Vec<u8>)> = out.iter().map(|f| (f.id(), f.data().to_vec())).collect();
        assert_eq!(
            got,
            vec![
                (0x201, vec![0, 0, 1, 0, 0, 0, 0, 0]),
                (0x201, vec![1, 2, 3, 0, 0, 0, 0, 0]),
                (0x201, vec![2, 4, 5, 0, 0, 0, 0, 0]),
                (0x205, vec![0, 6, 7, 0, 0, 0, 0, 0]),
                (0x205, vec![1, 8, 9, 0, 0, 0, 0, 0]),
                (0x205, vec![2, 10, 11, 0, 0, 0, 0, 0]),
            ]
        );
    }

    #[test]
    fn rounds_to_the_nearest_level() {
        let m = MessageSpec { scale: 0.25, offset: -1.0, ..MessageSpec::new(0x10, 0, 8, 3) };
        let c = codec(vec![m], 3);
        // (v + 1) / 0.25 = 4.4 → 4, 4.6 → 5, -0.4 → 0 (within half a quantum of level 0)
        let out = encode(&c, &[0.1, 0.15, -1.1]).unwrap();
        assert_eq!(out[0].data(), &[4, 5, 0]);
        // 255.5 levels is half a quantum past the last one: out of range
        let e = encode(&c, &[0.0, 0.0, 255.0 * 0.25 - 1.0 + 0.13]).unwrap_err().to_string();
        assert!(e.contains("taxel 2") && e.contains("-1 … 62.75"), "{e}");
    }

    #[test]
    fn errors_name_sensor_taxel_and_id_and_leave_out_untouched() {
        let c = CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &["ff"]))).unwrap();
        let mut out = vec![CanFrame::standard(1, &[], Timestamp(0)).unwrap()];
        let mut v = vec![100.0; 24];
        v[13] = 0.0; // raw 0 sits on the ADC rail: outside the preset's valid range 1 … 4094
        let e = c.encode(0, &v, Timestamp(0), &mut out).unwrap_err();
        assert_eq!(
            e.to_string(),
            "CAN encoding of sensor \"ff\" taxel 13: value 0 is outside the field's valid range 1 … 4094 \
             (raw 1 … 4094, scale 1, offset 0) (CAN id 100, mux 3)"
        );
        assert!(matches!(e, Error::CanEncode { taxel: Some(13), .. }));
        assert_eq!(out.len(), 1);
        v[13] = f64::NAN;
        let e = c.encode(0, &v, Timestamp(0), &mut out).unwrap_err().to_string();
        assert!(e.contains("taxel 13: value NaN is not finite"), "{e}");
        v[13] = f64::INFINITY;
        assert!(c.encode(0, &v, Timestamp(0), &mut out).unwrap_err().to_string().contains("inf is not finite"));
        let e = c.encode(0, &v[..23], Timestamp(0), &mut out).unwrap_err().to_string();
        assert_eq!(e, "CAN encoding of sensor \"ff\": 23 values, but the sensor has 24 taxels");
        let e = c.encode(3, &v, Timestamp(0), &mut out).unwrap_err().to_string();
        assert_eq!(e, "CAN encoding of sensor \"index 3\": the codec has 1 sensors");
        let mut enc = CanEncoder::new(c);
        let f = TaxelFrame::new(SensorId::new("th"), Timestamp(0), 4, vec![100.0; 24]);
        let e = enc.encode_frame(&f, &mut out).unwrap_err().to_string();
        assert_eq!(e, "CAN encoding of sensor \"th\": frame 4: the codec has no such sensor");
        assert_eq!(out.len(), 1);
        assert_eq!(enc.stats(), &EncodeStats::default());
    }

    #[test]
    fn clamping_is_explicit_and_counted() {
        let c = CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &["ff"]))).unwrap();
        let mut enc = CanEncoder::new(c.clone()).with_out_of_range(OutOfRangePolicy::Clamp);
        let mut v = vec![100.0; 24];
        v[0] = -20.0;
        v[23] = 1e12;
        let f = TaxelFrame::new(SensorId::new("ff"), Timestamp(5), 0, v.clone());
        let can = enc.run_all([f.clone()]).unwrap();
        let st = enc.stats();
        assert_eq!((st.sets, st.frames, st.clamped), (1, 6, 2));
        assert_eq!(st.first_clamp.as_deref(), Some("sensor \"ff\" at 5 ns: 2 of 24 values clamped"));
        let out = CanDecoder::new(c).run_all(can).unwrap();
        v[0] = 1.0;
        v[23] = 4094.0;
        assert_eq!(out[0].values, v);
        // non-finite values are not clamped
        let mut bad = f;
        bad.values[3] = f64::NEG_INFINITY;
        assert!(enc.run_all([bad]).is_err());
        assert_eq!(enc.stats().sets, 1);
    }
}
