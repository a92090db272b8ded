//! The declarative CAN frame codec: which CAN ids carry which taxels of which sensor, and how
//! their values are packed.
//!
//! A codec is configured by a [`CodecConfig`] (a scene's `codec` table) made of
//! [`SensorSpec`]s, each with one or more [`MessageSpec`]s, and/or a built-in preset
//! ([`PresetConfig`], see [`presets`](super::presets)). [`CanCodec::try_new`] validates the
//! whole configuration — every taxel carried by exactly one message slot, no two messages
//! claiming the same CAN id, fields inside 8 bytes — so that decoding never meets an
//! impossible case at run time.
//!
//! # Message model
//! A CAN frame matches a message when `frame.id & mask == id & mask` and the frame format
//! (standard/extended) agrees. The matched frame carries `count` consecutive fields of `bits`
//! bits each, starting at bit `start_bit`, for taxels
//!
//! ```text
//! taxel(k) = first_taxel + group · stride + k        k = 0 … count−1
//! group    = id_index · mux.groups + mux_value        (terms absent when unused)
//! id_index = (frame.id & !mask) >> shift              (0 when mask covers every id bit)
//! ```
//!
//! so a message can stand for one frame (`mask` = all bits, no mux), for a run of ids (one
//! frame per taxel or per taxel block: free low id bits index the block) or for a multiplexed
//! frame whose first byte (`mux.byte`) says which block it carries this time.
//!
//! # Bit numbering
//! - `byte_order = "big"` (Motorola): the payload is read as one big-endian bit string; bit 0
//!   is the most significant bit of byte 0, bit 8 the MSB of byte 1, and each field is read
//!   most significant bit first. A 16-bit field at `start_bit = 8` is bytes 1–2 read as a
//!   big-endian `u16`; two 12-bit fields at bit 8 are `b1b2b3` = `AAA BBB` (nibbles).
//! - `byte_order = "little"` (Intel): the payload is read as one little-endian integer; bit 0 is
//!   the least significant bit of byte 0 and a field's value is `(payload >> start) & mask`.
//!   A 16-bit field at `start_bit = 8` is bytes 1–2 read as a little-endian `u16`.
//!
//! In both orders byte `i` holds bits `8i … 8i+7`, so byte-aligned fields are what one expects.
//!
//! # Values
//! `raw` is the unsigned field, or its two's-complement value when `signed`. A raw value
//! outside `[raw_min, raw_max]` is *out of range*: it is counted and its taxel gets no value
//! from this frame (the set is then incomplete, see [`IncompletePolicy`]). A valid value
//! becomes `raw · scale + offset` in the sensor's unit.
//!
//! # Encoding
//! [`CanCodec::encode`] is the inverse: one sensor's values (in the sensor's unit) become the
//! CAN frames that decode back to them — `raw = round((value − offset) / scale)`, checked
//! against `[raw_min, raw_max]`, packed in the message's bit numbering, with the id index in
//! the free id bits and the block in the multiplexer byte. Bits no field uses are zero;
//! multiplexer values in `ignore` are never produced. [`CanEncoder`](super::CanEncoder) adds
//! lookup by [`SensorId`], an optional clamping mode with counts, and the
//! [`Stage`](gradtac_stream::Stage) from taxel frames to CAN frames; see
//! [`encode`](super::encode).

use crate::can::frame::{fmt_id, CanFrame, MAX_EXTENDED_ID, MAX_STANDARD_ID};
use crate::{Error, Result};
use gradtac_stream::{SensorId, Timestamp};
use serde::{Deserialize, Serialize};

/// Byte (and bit) order of a message's fields; see the [module docs](self) for the numbering.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum ByteOrder {
    /// Big-endian / Motorola (`"big"`, alias `"motorola"`).
    #[default]
    #[serde(rename = "big", alias = "motorola")]
    Big,
    /// Little-endian / Intel (`"little"`, alias `"intel"`).
    #[serde(rename = "little", alias = "intel")]
    Little,
}

/// What to do with a taxel set that does not complete (a timeout, a new cycle starting first,
/// out-of-range values, the end of the stream).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum IncompletePolicy {
    /// Drop the set and count it (`"drop"`): no frame is emitted for that cycle.
    #[default]
    #[serde(rename = "drop")]
    Drop,
    /// Emit the set with each missing taxel holding the last valid value received for it, and
    /// flag those taxels ([`DecodedFrame::carried`](super::DecodedFrame::carried)); counted.
    /// A set with a taxel that never had a value is dropped instead: values are never made up.
    #[serde(rename = "carry")]
    Carry,
}

/// The multiplexer of a message: a byte whose value says which taxel block the frame carries.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MuxSpec {
    /// Index (0–7) of the multiplexer byte in the payload.
    pub byte: u8,
    /// Number of taxel blocks: values `0 … groups−1` select a block.
    pub groups: u32,
    /// Multiplexer values that carry other data (a hand rotating pressure or temperature words
    /// through the same id): such frames are counted as ignored, not as faults. Any other value
    /// outside `0 … groups−1` is an *unknown multiplexer value* fault.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ignore: Vec<u8>,
    /// Bits of the byte that hold the multiplexer value (default `0xFF`): the value is
    /// `(byte & mask) >> shift`.
    #[serde(default = "full_byte")]
    pub mask: u8,
    /// Right shift applied after `mask` (0–7).
    #[serde(default)]
    pub shift: u8,
    /// The value that selects block 0 (values `first … first + groups − 1` select blocks;
    /// `ignore` lists raw values).
    #[serde(default)]
    pub first: u8,
}

impl MuxSpec {
    /// The whole byte `byte` selects `groups` blocks from value 0, `ignore` listing values that
    /// carry other data.
    pub fn new(byte: u8, groups: u32, ignore: Vec<u8>) -> Self {
        MuxSpec { byte, groups, ignore, mask: 0xFF, shift: 0, first: 0 }
    }
}

fn full_byte() -> u8 {
    0xFF
}

/// How a field's bits become its raw value.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum WordFormat {
    /// The field's bits are the raw value (`"plain"`, default).
    #[default]
    #[serde(rename = "plain")]
    Plain,
    /// A SynTouch BioTac word (`"biotac"`): 16 bits = two bytes `b0 b1`, each with an odd
    /// parity bit in bit 0; `raw = (b0 >> 1) · 32 + (b1 >> 3)` (12 bits). A byte with even
    /// parity makes the field a *parity* fault: its value is dropped, never decoded. Needs
    /// `bits = 16`, a byte-aligned `start_bit`, big-endian, unsigned.
    #[serde(rename = "biotac")]
    Biotac,
}

impl WordFormat {
    fn is_plain(&self) -> bool {
        *self == WordFormat::Plain
    }
}

/// A byte whose value marks the whole frame as an invalid sample (Xela uSkin:
/// `{ byte = 1, min = 250 }`, i.e. `data[1] ≥ 250`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InvalidIf {
    /// The byte (0–7).
    pub byte: u8,
    /// Values `≥ min` mark the sample invalid.
    pub min: u8,
}

/// A BioTac byte: the 7-bit `v` in bits 7–1 and an odd parity bit in bit 0.
pub fn biotac_byte(v: u8) -> u8 {
    let b = (v & 0x7F) << 1;
    b | u8::from(b.count_ones() % 2 == 0)
}

/// The 16 bits of a BioTac word holding the 12-bit `raw` (see [`WordFormat::Biotac`]).
pub fn biotac_word(raw: u16) -> u16 {
    let hi = biotac_byte((raw >> 5) as u8 & 0x7F);
    let lo = biotac_byte(((raw & 0x1F) as u8) << 2);
    u16::from(hi) << 8 | u16::from(lo)
}

/// One CAN message layout: the ids it matches and the run of taxel fields it carries.
///
/// Serde shape (a `[[…messages]]` TOML table); every field but `id`, `bits` and `start_bit` has
/// a default:
///
/// ```toml
/// id = 0x100            # base identifier
/// extended = false      # 29-bit identifier
/// mask = 0x7FF          # id bits that must equal `id` (default: all)
/// shift = 0             # id_index = (frame.id & !mask) >> shift
/// id_groups = 16        # number of valid id_index values (default: all the mask leaves free)
/// length = 8            # exact data length required (default: the bytes the fields and mux need)
/// mux = { byte = 0, groups = 6, ignore = [6, 7, 8] }
/// start_bit = 8         # first bit of field 0 (see bit numbering)
/// bits = 12             # width of each field, 1–32
/// count = 4             # fields per frame (default 1)
/// byte_order = "big"    # "big" | "little"
/// signed = false
/// scale = 1.0           # value = raw · scale + offset
/// offset = 0.0
/// raw_min = 1           # valid raw range, inclusive (default: everything the field can hold)
/// raw_max = 4094
/// first_taxel = 0       # taxel of field 0 of group 0
/// stride = 4            # taxels between groups (default: count)
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MessageSpec {
    /// Base identifier.
    pub id: u32,
    /// True for 29-bit extended identifiers.
    #[serde(default)]
    pub extended: bool,
    /// Identifier bits that must equal those of `id`; default: all bits (an exact match).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mask: Option<u32>,
    /// Right shift applied to the free (unmasked) id bits to get the id index.
    #[serde(default)]
    pub shift: u32,
    /// Number of valid id indices (ids whose index is ≥ this are unknown ids); default: every
    /// index the mask leaves free.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id_groups: Option<u32>,
    /// Exact data length (bytes) a frame must have; other lengths are a *wrong length* fault.
    /// Default: the smallest length holding the fields and the multiplexer.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub length: Option<u8>,
    /// Optional multiplexer byte.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mux: Option<MuxSpec>,
    /// First bit of field 0 (see the bit numbering in the module docs).
    pub start_bit: u32,
    /// Width of each field in bits (1–32).
    pub bits: u32,
    /// Number of consecutive fields (taxels) per frame.
    #[serde(default = "one")]
    pub count: u32,
    /// Byte order of the fields.
    #[serde(default)]
    pub byte_order: ByteOrder,
    /// Fields are two's-complement signed.
    #[serde(default)]
    pub signed: bool,
    /// Multiplier from raw value to the sensor's unit.
    #[serde(default = "one_f64")]
    pub scale: f64,
    /// Added after scaling (sensor unit).
    #[serde(default)]
    pub offset: f64,
    /// Smallest valid raw value (inclusive).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub raw_min: Option<i64>,
    /// Largest valid raw value (inclusive).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub raw_max: Option<i64>,
    /// Taxel index of field 0 of group 0.
    #[serde(default)]
    pub first_taxel: u32,
    /// Taxels between consecutive groups; default `count`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stride: Option<u32>,
    /// How the fields' bits become raw values ([`WordFormat`]; default `"plain"`).
    #[serde(default, skip_serializing_if = "WordFormat::is_plain")]
    pub word: WordFormat,
    /// A byte marking the whole frame as an invalid sample ([`InvalidIf`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub invalid_if: Option<InvalidIf>,
    /// The frame carries other sensors' fields too: messages of different sensors with the
    /// same `id`, `mask`, `shift`, `extended`, `length` and `mux`, all `shared`, each decode their
    /// own fields of every matching frame (SynTouch words of several BioTacs in one frame).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub shared: bool,
}

fn one() -> u32 {
    1
}
fn one_f64() -> f64 {
    1.0
}
fn default_timeout_ms() -> f64 {
    50.0
}

impl MessageSpec {
    /// A message matching exactly `id` (standard), carrying `count` unsigned big-endian
    /// fields of `bits` bits from `start_bit`; refine with struct update syntax.
    pub fn new(id: u32, start_bit: u32, bits: u32, count: u32) -> Self {
        MessageSpec {
            id,
            extended: false,
            mask: None,
            shift: 0,
            id_groups: None,
            length: None,
            mux: None,
            start_bit,
            bits,
            count,
            byte_order: ByteOrder::Big,
            signed: false,
            scale: 1.0,
            offset: 0.0,
            raw_min: None,
            raw_max: None,
            first_taxel: 0,
            stride: None,
            word: WordFormat::Plain,
            invalid_if: None,
            shared: false,
        }
    }
}

/// One sensor on the bus: its name, taxel count, reassembly timeout and policy, and the
/// messages that carry its taxels.
///
/// ```toml
/// [[codec.sensors]]
/// name = "ff"
/// taxels = 24
/// timeout_ms = 50.0      # a set not complete this long after its first frame is incomplete
/// incomplete = "drop"    # "drop" | "carry"
/// [[codec.sensors.messages]]
/// id = 0x100
/// # … see MessageSpec
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorSpec {
    /// The sensor's name (its [`SensorId`]).
    pub name: String,
    /// Number of taxels in a frame.
    pub taxels: u32,
    /// Milliseconds after a set's first CAN frame within which the set must be complete;
    /// measured on frame timestamps. Default 50 ms.
    #[serde(default = "default_timeout_ms")]
    pub timeout_ms: f64,
    /// What to do with incomplete sets.
    #[serde(default)]
    pub incomplete: IncompletePolicy,
    /// The messages carrying the taxels.
    pub messages: Vec<MessageSpec>,
}

/// The built-in layouts; see [`presets`](super::presets) for their wire formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum PresetKind {
    /// Xela uSkin as its public drivers read it: one frame per taxel at id `0x710 + taxel`,
    /// x/y/z big-endian in bytes 1–6, `data[1] ≥ 250` an invalid sample (`"xela-uskin"`).
    #[serde(rename = "xela-uskin")]
    XelaUskin,
    /// SynTouch BioTac words relayed on CAN as Clearpath's `numatac_can_driver` reads them:
    /// byte 0 the channel (`(b & 0x7E) >> 1`, electrodes 17–40), then one parity-checked
    /// 2-byte word per sensor (`"syntouch-biotac"`).
    #[serde(rename = "syntouch-biotac")]
    SyntouchBiotac,
    /// Our own multiplexed per-fingertip frames, 24 electrodes in 12-bit fields (`"biotac-mux"`;
    /// no device uses it).
    #[serde(rename = "biotac-mux")]
    BiotacMux,
}

impl PresetKind {
    /// The name used in scene files (`"xela-uskin"`, `"biotac-mux"`).
    pub fn as_str(self) -> &'static str {
        match self {
            PresetKind::XelaUskin => "xela-uskin",
            PresetKind::BiotacMux => "biotac-mux",
            PresetKind::SyntouchBiotac => "syntouch-biotac",
        }
    }
}

/// A preset instantiated for a list of sensors.
///
/// ```toml
/// [codec.preset]
/// kind = "syntouch-biotac"     # or "xela-uskin", "biotac-mux"
/// sensors = ["ff", "mf", "th"] # sensor i: the preset's i-th word slot / id block
/// base_id = 0x100              # default: any id (syntouch-biotac), 0x710 (xela-uskin), 0x100 (biotac-mux)
/// extended = false
/// taxels = 16                  # xela-uskin (default 16), syntouch-biotac (default 24)
/// timeout_ms = 50.0
/// incomplete = "drop"
/// raw_min = 1                  # default: the preset's valid range
/// raw_max = 4094
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PresetConfig {
    /// Which layout.
    pub kind: PresetKind,
    /// Sensor names, in id order.
    pub sensors: Vec<String>,
    /// First CAN id (default per preset).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_id: Option<u32>,
    /// Use 29-bit identifiers.
    #[serde(default)]
    pub extended: bool,
    /// Taxels per sensor (`xela-uskin`, `syntouch-biotac`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub taxels: Option<u32>,
    /// Reassembly timeout (ms) per sensor.
    #[serde(default = "default_timeout_ms")]
    pub timeout_ms: f64,
    /// Policy for incomplete sets.
    #[serde(default)]
    pub incomplete: IncompletePolicy,
    /// Override of the preset's smallest valid raw value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub raw_min: Option<i64>,
    /// Override of the preset's largest valid raw value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub raw_max: Option<i64>,
}

impl PresetConfig {
    /// A preset for `sensors` with all defaults.
    pub fn new(kind: PresetKind, sensors: &[&str]) -> Self {
        PresetConfig {
            kind,
            sensors: sensors.iter().map(|s| s.to_string()).collect(),
            base_id: None,
            extended: false,
            taxels: None,
            timeout_ms: default_timeout_ms(),
            incomplete: IncompletePolicy::Drop,
            raw_min: None,
            raw_max: None,
        }
    }

    /// The sensors this preset stands for.
    pub fn expand(&self) -> Result<Vec<SensorSpec>> {
        super::presets::expand(self)
    }
}

/// The codec of a scene's CAN source: a preset, explicit sensors, or both (their ids must not
/// overlap).
///
/// ```toml
/// [sources.hand.codec.preset]
/// kind = "biotac-mux"
/// sensors = ["ff", "mf", "th"]
/// # and/or
/// [[sources.hand.codec.sensors]]
/// name = "palm"
/// # …
/// ```
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CodecConfig {
    /// A built-in layout.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preset: Option<PresetConfig>,
    /// Explicitly described sensors.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sensors: Vec<SensorSpec>,
}

impl CodecConfig {
    /// A config made of one preset.
    pub fn preset(p: PresetConfig) -> Self {
        CodecConfig { preset: Some(p), sensors: Vec::new() }
    }

    /// A config of explicit sensors.
    pub fn sensors(sensors: Vec<SensorSpec>) -> Self {
        CodecConfig { preset: None, sensors }
    }
}

/// A validated message, ready to decode.
#[derive(Clone, Debug)]
struct Message {
    sensor: usize,
    id: u32,
    extended: bool,
    mask: u32,
    shift: u32,
    id_groups: u32,
    length: u8,
    mux: Option<(u8, u32, [bool; 256])>,
    /// Multiplexer mask, shift and first value.
    mux_bits: (u8, u8, u8),
    word: WordFormat,
    invalid_if: Option<InvalidIf>,
    shared: bool,
    start_bit: u32,
    bits: u32,
    count: u32,
    order: ByteOrder,
    signed: bool,
    scale: f64,
    offset: f64,
    raw_min: i64,
    raw_max: i64,
    first_taxel: u32,
    stride: u32,
}

impl Message {
    /// Field `k` holding `raw`, placed in the 64-bit payload word (the inverse of decoding).
    fn pack(&self, raw: i64, k: u32) -> u64 {
        let u = match self.word {
            WordFormat::Plain => raw as u64 & ((1u64 << self.bits) - 1),
            WordFormat::Biotac => u64::from(biotac_word(raw as u16)),
        };
        let p = self.start_bit + k * self.bits;
        match self.order {
            ByteOrder::Big => u << (64 - p - self.bits),
            ByteOrder::Little => u << p,
        }
    }

    /// The frame of block `mux` with payload `word` at `id`.
    fn frame(&self, id: u32, word: u64, mux: u32, time: Timestamp) -> Result<CanFrame> {
        let mut bytes = match self.order {
            ByteOrder::Big => word.to_be_bytes(),
            ByteOrder::Little => word.to_le_bytes(),
        };
        if let Some((byte, _, _)) = &self.mux {
            let (mask, shift, first) = self.mux_bits;
            bytes[*byte as usize] = (((mux + u32::from(first)) << shift) as u8) & mask;
        }
        CanFrame::try_new(id, self.extended, &bytes[..self.length as usize], time)
    }

    /// The decoded value of a raw value (exactly as [`CanCodec::decode`] computes it).
    fn value(&self, raw: i64) -> f64 {
        raw as f64 * self.scale + self.offset
    }

    /// The raw value encoding `v`, and whether it was clamped; `Err` says why `v` does not fit.
    fn quantise(&self, v: f64, clamp: bool) -> std::result::Result<(i64, bool), String> {
        if !v.is_finite() {
            return Err(format!("value {v} is not finite"));
        }
        let x = ((v - self.offset) / self.scale).round();
        let (lo, hi) = (self.raw_min as f64, self.raw_max as f64);
        // Within one level of the range the neighbours decide; beyond it `v` is out of range
        // (this also keeps `x as i64` exact: the range lies inside ±2^32).
        let raw = if x >= lo - 1.0 && x <= hi + 1.0 {
            let r0 = x as i64;
            let mut best = (r0, (self.value(r0) - v).abs());
            for c in [r0 - 1, r0 + 1] {
                let e = (self.value(c) - v).abs();
                if e < best.1 {
                    best = (c, e);
                }
            }
            best.0
        } else if x < lo {
            self.raw_min - 1
        } else {
            self.raw_max + 1
        };
        if (self.raw_min..=self.raw_max).contains(&raw) {
            return Ok((raw, false));
        }
        if clamp {
            return Ok((raw.clamp(self.raw_min, self.raw_max), true));
        }
        let (a, b) = (self.value(self.raw_min), self.value(self.raw_max));
        Err(format!(
            "value {v} is outside the field's valid range {} … {} (raw {} … {}, scale {}, offset {})",
            a.min(b),
            a.max(b),
            self.raw_min,
            self.raw_max,
            self.scale,
            self.offset
        ))
    }
}

/// A validated sensor.
#[derive(Clone, Debug)]
pub(crate) struct Sensor {
    pub(crate) id: SensorId,
    pub(crate) taxels: u32,
    pub(crate) timeout_ns: i64,
    pub(crate) policy: IncompletePolicy,
}

/// One field decoded from a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldValue {
    /// The taxel it belongs to.
    pub taxel: u32,
    /// The raw field value (sign-extended when signed).
    pub raw: i64,
    /// `raw · scale + offset`, or `None` when `raw` is out of the valid range, fails its
    /// parity check or belongs to an invalid sample.
    pub value: Option<f64>,
    /// Why `value` is `None` ([`FaultKind::OutOfRange`](super::FaultKind::OutOfRange),
    /// `Parity` or `InvalidSample`).
    pub fault: Option<super::FaultKind>,
}

/// What a frame is to the codec.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Decoded {
    /// Its fields were appended to the output (some may be out of range).
    Values {
        /// Index of the sensor ([`CanCodec::sensor_id`]).
        sensor: usize,
        /// The message's block index (`id_index · mux.groups + mux_value`).
        group: u32,
    },
    /// No message matches the id (or the id index is past `id_groups`).
    UnknownId,
    /// The message matched but the data length is not the one required.
    WrongLength {
        /// Index of the sensor.
        sensor: usize,
        /// Required length.
        expected: u8,
        /// The frame's length.
        got: u8,
    },
    /// The multiplexer value selects no block and is not ignored.
    UnknownMux {
        /// Index of the sensor.
        sensor: usize,
        /// The value.
        value: u8,
    },
    /// The multiplexer value is listed as carrying other data.
    Ignored {
        /// Index of the sensor.
        sensor: usize,
        /// The value.
        value: u8,
    },
}

/// A validated codec: maps CAN frames to taxel values. Stateless; reassembly into frames is
/// [`CanDecoder`](super::CanDecoder)'s job.
#[derive(Clone, Debug)]
pub struct CanCodec {
    sensors: Vec<Sensor>,
    messages: Vec<Message>,
}

fn width_mask(extended: bool) -> u32 {
    if extended {
        MAX_EXTENDED_ID
    } else {
        MAX_STANDARD_ID
    }
}

/// Most taxels of one sensor a codec accepts (the stages' limit too): a custom codec with
/// `taxels = 4294967295` used to abort allocating 4 GB.
pub const MAX_TAXELS: u32 = 65_535;

impl CanCodec {
    /// Validate a configuration. Errors ([`Error::InvalidConfig`]) name the sensor and message
    /// (`sensor "ff" message 0 (id 0x100)`) and say what is wrong.
    pub fn try_new(config: &CodecConfig) -> Result<Self> {
        let mut specs = Vec::new();
        if let Some(p) = &config.preset {
            specs.extend(p.expand()?);
        }
        specs.extend(config.sensors.iter().cloned());
        Self::from_sensors(&specs)
    }

    /// Validate a list of sensors (see [`try_new`](Self::try_new)).
    pub fn from_sensors(specs: &[SensorSpec]) -> Result<Self> {
        let bad = |s: String| Error::InvalidConfig(format!("CAN codec: {s}"));
        if specs.is_empty() {
            return Err(bad("no sensors".into()));
        }
        let mut sensors = Vec::with_capacity(specs.len());
        let mut messages = Vec::new();
        for (si, s) in specs.iter().enumerate() {
            if s.name.trim().is_empty() {
                return Err(bad(format!("sensor {si} has an empty name")));
            }
            if specs[..si].iter().any(|o| o.name == s.name) {
                return Err(bad(format!("sensor {:?} is described twice", s.name)));
            }
            let who = format!("sensor {:?}", s.name);
            if s.taxels == 0 {
                return Err(bad(format!("{who}: taxels must be at least 1")));
            }
            if s.taxels > MAX_TAXELS {
                return Err(bad(format!("{who}: taxels = {}; at most {MAX_TAXELS} are supported", s.taxels)));
            }
            if !(s.timeout_ms.is_finite() && s.timeout_ms > 0.0 && s.timeout_ms < 1e9) {
                return Err(bad(format!(
                    "{who}: timeout_ms must be positive and finite, got {}",
                    gradtac_stream::num::Short(s.timeout_ms)
                )));
            }
            if s.messages.is_empty() {
                return Err(bad(format!("{who}: no messages")));
            }
            let mut covered = vec![false; s.taxels as usize];
            for (mi, m) in s.messages.iter().enumerate() {
                let who = format!("{who} message {mi} (id {:#x})", m.id);
                let msg = compile_message(si, m, s.taxels, &mut covered).map_err(|r| bad(format!("{who}: {r}")))?;
                messages.push((msg, who));
            }
            let missing: Vec<usize> = covered.iter().enumerate().filter(|(_, c)| !**c).map(|(i, _)| i).collect();
            if !missing.is_empty() {
                return Err(bad(format!(
                    "{who}: taxels {} are carried by no message, so a set could never complete",
                    list(&missing)
                )));
            }
            sensors.push(Sensor {
                id: SensorId::new(&s.name),
                taxels: s.taxels,
                timeout_ns: (s.timeout_ms * 1e6).round() as i64,
                policy: s.incomplete,
            });
        }
        // No frame may match two messages. Conservative: the masks' common bits must differ.
        for (i, (a, wa)) in messages.iter().enumerate() {
            for (b, wb) in &messages[..i] {
                let same_frame = a.shared
                    && b.shared
                    && a.sensor != b.sensor
                    && (a.id, a.mask, a.shift, a.id_groups, a.length, a.mux_bits)
                        == (b.id, b.mask, b.shift, b.id_groups, b.length, b.mux_bits)
                    && a.mux.as_ref().map(|x| (x.0, x.1, x.2)) == b.mux.as_ref().map(|x| (x.0, x.1, x.2));
                if a.extended == b.extended && (a.id ^ b.id) & a.mask & b.mask == 0 && !same_frame {
                    return Err(bad(format!("{wa} and {wb} both match some CAN ids; give them disjoint ids or masks")));
                }
            }
        }
        Ok(CanCodec { sensors, messages: messages.into_iter().map(|(m, _)| m).collect() })
    }

    /// Number of sensors.
    pub fn num_sensors(&self) -> usize {
        self.sensors.len()
    }

    /// The id of sensor `i` (in configuration order).
    pub fn sensor_id(&self, i: usize) -> &SensorId {
        &self.sensors[i].id
    }

    /// Number of taxels of sensor `i`.
    pub fn taxels(&self, i: usize) -> usize {
        self.sensors[i].taxels as usize
    }

    pub(crate) fn sensor(&self, i: usize) -> &Sensor {
        &self.sensors[i]
    }

    /// The index of the sensor named `id`, if the codec has it.
    pub fn sensor_index(&self, id: &SensorId) -> Option<usize> {
        self.sensors.iter().position(|s| s.id == *id)
    }

    /// Encode one set of sensor `sensor`'s taxel values (in the sensor's unit, i.e. after
    /// `scale` and `offset`) into the CAN frames that [`decode`](Self::decode) reads back as
    /// those values, appending them to `out`, all stamped `time`.
    ///
    /// Each value becomes `raw = round((value − offset) / scale)` (to the nearest level; of
    /// the levels next to it, the one whose decoded value is closest, so a value the decoder
    /// produced encodes back to its own raw value even where `(value − offset) / scale` is a
    /// few ulps off). Frames come in message order and, per message, in block order
    /// (`id_index`, then multiplexer value); bits no field or multiplexer uses are zero.
    ///
    /// Errors ([`Error::CanEncode`], naming the sensor, taxel and CAN id): `sensor` is not an
    /// index of the codec, `values` does not hold exactly one value per taxel, or a value is
    /// not finite or lies outside the valid range (a raw value outside `[raw_min, raw_max]`
    /// after rounding, i.e. more than half a quantum past the outermost level). Nothing is
    /// clamped; [`CanEncoder`](super::CanEncoder) offers an explicit clamping mode. On error
    /// `out` is left as it was.
    pub fn encode(&self, sensor: usize, values: &[f64], time: Timestamp, out: &mut Vec<CanFrame>) -> Result<()> {
        self.encode_with(sensor, values, time, false, out).map(|_| ())
    }

    /// [`encode`](Self::encode), optionally clamping out-of-range (finite) values to the
    /// nearest valid raw value; returns the number of clamped values.
    pub(crate) fn encode_with(
        &self,
        sensor: usize,
        values: &[f64],
        time: Timestamp,
        clamp: bool,
        out: &mut Vec<CanFrame>,
    ) -> Result<u64> {
        let Some(s) = self.sensors.get(sensor) else {
            return Err(Error::CanEncode {
                sensor: format!("index {sensor}"),
                taxel: None,
                reason: format!("the codec has {} sensors", self.sensors.len()),
            });
        };
        let fail =
            |taxel: Option<u32>, reason: String| Error::CanEncode { sensor: s.id.as_str().to_string(), taxel, reason };
        if values.len() != s.taxels as usize {
            return Err(fail(None, format!("{} values, but the sensor has {} taxels", values.len(), s.taxels)));
        }
        let start = out.len();
        let mut clamped = 0;
        for m in self.messages.iter().filter(|m| m.sensor == sensor) {
            if m.shared {
                out.truncate(start);
                return Err(fail(
                    None,
                    format!(
                        "its frames (CAN id {}) carry other sensors' fields too (shared): encode them together with CanCodec::encode_shared",
                        fmt_id(m.id, m.extended)
                    ),
                ));
            }
            let mux_groups = m.mux.as_ref().map_or(1, |x| x.1);
            // The id bits that hold the id index (the free bits from `shift` up).
            let index_bits = ((!m.mask & width_mask(m.extended)) >> m.shift) << m.shift;
            for id_index in 0..m.id_groups {
                let id = (m.id & !index_bits) | (id_index << m.shift);
                for mux in 0..mux_groups {
                    let base = m.first_taxel + (id_index * mux_groups + mux) * m.stride;
                    let mut word = 0u64;
                    for k in 0..m.count {
                        let t = base + k;
                        let raw = match m.quantise(values[t as usize], clamp) {
                            Ok((raw, c)) => {
                                clamped += u64::from(c);
                                raw
                            }
                            Err(reason) => {
                                out.truncate(start);
                                let mux = if m.mux.is_some() { format!(", mux {mux}") } else { String::new() };
                                return Err(fail(
                                    Some(t),
                                    format!("{reason} (CAN id {}{mux})", fmt_id(id, m.extended)),
                                ));
                            }
                        };
                        word |= m.pack(raw, k);
                    }
                    match m.frame(id, word, mux, time) {
                        Ok(f) => out.push(f),
                        Err(e) => {
                            out.truncate(start);
                            return Err(e);
                        }
                    }
                }
            }
        }
        Ok(clamped)
    }

    /// Encode one set of values of every sensor whose messages share frames (`shared`, as in
    /// `syntouch-biotac`): `sets` lists `(sensor index, values)`; each shared frame is built
    /// once, carrying the fields of all its sensors, in block order, all stamped `time`.
    /// Messages of the listed sensors that are not shared are encoded as by
    /// [`encode`](Self::encode). Errors as there, and when a sensor sharing a frame with a
    /// listed one is not listed. On error `out` is left as it was.
    pub fn encode_shared(&self, sets: &[(usize, &[f64])], time: Timestamp, out: &mut Vec<CanFrame>) -> Result<()> {
        let start = out.len();
        let values_of = |sensor: usize| sets.iter().find(|(s, _)| *s == sensor).map(|(_, v)| *v);
        let fail = |out: &mut Vec<CanFrame>, sensor: usize, taxel: Option<u32>, reason: String| {
            out.truncate(start);
            Error::CanEncode {
                sensor: self.sensors.get(sensor).map_or(format!("index {sensor}"), |s| s.id.as_str().to_string()),
                taxel,
                reason,
            }
        };
        for &(sensor, values) in sets {
            let Some(s) = self.sensors.get(sensor) else {
                return Err(fail(out, sensor, None, format!("the codec has {} sensors", self.sensors.len())));
            };
            if values.len() != s.taxels as usize {
                return Err(fail(
                    out,
                    sensor,
                    None,
                    format!("{} values, but the sensor has {} taxels", values.len(), s.taxels),
                ));
            }
            if self.messages.iter().any(|m| m.sensor == sensor && !m.shared) {
                // its own frames: the plain path (all-or-nothing via `start`)
                let mut own = CanCodec { sensors: self.sensors.clone(), messages: Vec::new() };
                own.messages = self.messages.iter().filter(|m| m.sensor == sensor && !m.shared).cloned().collect();
                if let Err(e) = own.encode(sensor, values, time, out) {
                    out.truncate(start);
                    return Err(e);
                }
            }
        }
        let same_frame = |a: &Message, b: &Message| {
            (a.id, a.extended, a.mask, a.shift, a.id_groups, a.length, a.mux_bits)
                == (b.id, b.extended, b.mask, b.shift, b.id_groups, b.length, b.mux_bits)
        };
        for (i, lead) in self.messages.iter().enumerate() {
            let listed = sets.iter().any(|(s, _)| *s == lead.sensor);
            if !lead.shared || !listed || self.messages[..i].iter().any(|m| m.shared && same_frame(m, lead)) {
                continue;
            }
            let group: Vec<&Message> = self.messages[i..].iter().filter(|m| m.shared && same_frame(m, lead)).collect();
            let mux_groups = lead.mux.as_ref().map_or(1, |x| x.1);
            let index_bits = ((!lead.mask & width_mask(lead.extended)) >> lead.shift) << lead.shift;
            for id_index in 0..lead.id_groups {
                let id = (lead.id & !index_bits) | (id_index << lead.shift);
                for mux in 0..mux_groups {
                    let mut word = 0u64;
                    for m in &group {
                        let Some(values) = values_of(m.sensor) else {
                            return Err(fail(
                                out,
                                m.sensor,
                                None,
                                format!(
                                    "it shares frames (CAN id {}) with listed sensors: give its values too",
                                    fmt_id(id, m.extended)
                                ),
                            ));
                        };
                        let base = m.first_taxel + (id_index * mux_groups + mux) * m.stride;
                        for k in 0..m.count {
                            let t = base + k;
                            let raw = match m.quantise(values[t as usize], false) {
                                Ok((raw, _)) => raw,
                                Err(reason) => {
                                    return Err(fail(
                                        out,
                                        m.sensor,
                                        Some(t),
                                        format!("{reason} (CAN id {})", fmt_id(id, m.extended)),
                                    ))
                                }
                            };
                            word |= m.pack(raw, k);
                        }
                    }
                    match lead.frame(id, word, mux, time) {
                        Ok(f) => out.push(f),
                        Err(e) => {
                            out.truncate(start);
                            return Err(e);
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// Decode one frame: append its fields to `out` (cleared first) and say what it was.
    /// For a frame that `shared` messages of several sensors match, this is the first one's
    /// part; [`decode_from`](Self::decode_from) visits the others.
    pub fn decode(&self, frame: &CanFrame, out: &mut Vec<FieldValue>) -> Decoded {
        self.decode_from(0, frame, out).0
    }

    /// [`decode`](Self::decode) starting the search at message `from`; also returns where to
    /// search next when the matched message is `shared` (another sensor's part of the same
    /// frame may follow), `None` otherwise.
    pub fn decode_from(&self, from: usize, frame: &CanFrame, out: &mut Vec<FieldValue>) -> (Decoded, Option<usize>) {
        out.clear();
        let id = frame.id();
        let ext = frame.is_extended();
        let Some((at, m)) = self
            .messages
            .iter()
            .enumerate()
            .skip(from)
            .find(|(_, m)| m.extended == ext && (id & m.mask) == (m.id & m.mask))
        else {
            return (Decoded::UnknownId, None);
        };
        let next = m.shared.then_some(at + 1);
        let id_index = (id & !m.mask & width_mask(ext)) >> m.shift;
        if id_index >= m.id_groups {
            return (Decoded::UnknownId, None);
        }
        if frame.len() != m.length as usize {
            return (Decoded::WrongLength { sensor: m.sensor, expected: m.length, got: frame.len() as u8 }, next);
        }
        let data = frame.data();
        let mut group = id_index;
        if let Some((byte, groups, ignore)) = &m.mux {
            let (mask, shift, first) = m.mux_bits;
            let raw = (data[*byte as usize] & mask) >> shift;
            let v = u32::from(raw).wrapping_sub(u32::from(first));
            if u32::from(raw) < u32::from(first) || v >= *groups {
                return if ignore[raw as usize] {
                    (Decoded::Ignored { sensor: m.sensor, value: raw }, next)
                } else {
                    (Decoded::UnknownMux { sensor: m.sensor, value: raw }, next)
                };
            }
            group = id_index * groups + v;
        }
        let invalid = m.invalid_if.is_some_and(|x| data[x.byte as usize] >= x.min);
        let mut padded = [0u8; 8];
        padded[..data.len()].copy_from_slice(data);
        let word = match m.order {
            ByteOrder::Big => u64::from_be_bytes(padded),
            ByteOrder::Little => u64::from_le_bytes(padded),
        };
        let fmask = (1u64 << m.bits) - 1;
        let base = m.first_taxel + group * m.stride;
        for k in 0..m.count {
            let p = m.start_bit + k * m.bits;
            let u = match m.order {
                ByteOrder::Big => (word >> (64 - p - m.bits)) & fmask,
                ByteOrder::Little => (word >> p) & fmask,
            };
            let (raw, parity_ok) = match m.word {
                WordFormat::Plain => {
                    let raw =
                        if m.signed && u >> (m.bits - 1) & 1 == 1 { u as i64 - (1i64 << m.bits) } else { u as i64 };
                    (raw, true)
                }
                WordFormat::Biotac => {
                    let (b0, b1) = ((u >> 8) as u8, u as u8);
                    (i64::from(b0 >> 1) * 32 + i64::from(b1 >> 3), b0.count_ones() % 2 == 1 && b1.count_ones() % 2 == 1)
                }
            };
            let fault = if invalid {
                Some(super::FaultKind::InvalidSample)
            } else if !parity_ok {
                Some(super::FaultKind::Parity)
            } else if raw < m.raw_min || raw > m.raw_max {
                Some(super::FaultKind::OutOfRange)
            } else {
                None
            };
            let value = fault.is_none().then_some(raw as f64 * m.scale + m.offset);
            out.push(FieldValue { taxel: base + k, raw, value, fault });
        }
        (Decoded::Values { sensor: m.sensor, group }, next)
    }
}

/// `[0, 1, 2]` → `"0, 1, 2"`, shortened after 12 entries.
fn list(v: &[usize]) -> String {
    let mut s: Vec<String> = v.iter().take(12).map(|x| x.to_string()).collect();
    if v.len() > 12 {
        s.push(format!("… ({} in all)", v.len()));
    }
    s.join(", ")
}

fn compile_message(
    sensor: usize,
    m: &MessageSpec,
    taxels: u32,
    covered: &mut [bool],
) -> std::result::Result<Message, String> {
    let width = width_mask(m.extended);
    if m.id > width {
        return Err(format!("id does not fit a {} identifier", if m.extended { "29-bit" } else { "11-bit" }));
    }
    let mask = m.mask.unwrap_or(width);
    if mask & !width != 0 {
        return Err(format!("mask {mask:#x} has bits outside the {}-bit identifier", if m.extended { 29 } else { 11 }));
    }
    if m.shift > 28 {
        return Err(format!("shift {} is larger than an identifier", m.shift));
    }
    let free = (!mask & width) >> m.shift;
    if free & free.wrapping_add(1) != 0 {
        return Err(format!(
            "the id bits the mask leaves free above `shift` must be contiguous from `shift` (free bits {:#x})",
            !mask & width
        ));
    }
    let reachable = u64::from(free) + 1;
    let id_groups = match m.id_groups {
        None => reachable,
        Some(0) => return Err("id_groups must be at least 1".into()),
        Some(g) if u64::from(g) > reachable => {
            return Err(format!("id_groups = {g} but the mask leaves room for only {reachable} id indices"))
        }
        Some(g) => u64::from(g),
    };
    if !(1..=32).contains(&m.bits) {
        return Err(format!("bits = {}; a field is 1 to 32 bits wide", m.bits));
    }
    if m.count == 0 {
        return Err("count must be at least 1".into());
    }
    let end_bit = u64::from(m.start_bit) + u64::from(m.count) * u64::from(m.bits);
    if end_bit > 64 {
        return Err(format!(
            "fields end at bit {end_bit} (start_bit {} + {} × {} bits) but a frame holds 64 bits",
            m.start_bit, m.count, m.bits
        ));
    }
    let mut needed = end_bit.div_ceil(8) as u8;
    let mux = match &m.mux {
        None => None,
        Some(x) => {
            if x.byte > 7 {
                return Err(format!("mux.byte = {}; a frame has bytes 0–7", x.byte));
            }
            let (lo, hi) = (u64::from(x.byte) * 8, u64::from(x.byte) * 8 + 8);
            if lo < end_bit && u64::from(m.start_bit) < hi {
                return Err(format!("mux byte {} overlaps the fields (bits {}–{})", x.byte, m.start_bit, end_bit - 1));
            }
            if x.groups == 0 || x.groups > 256 {
                return Err(format!("mux.groups = {}; must be 1–256", x.groups));
            }
            if x.shift > 7 || x.mask == 0 {
                return Err(format!(
                    "mux.mask = {:#x}, mux.shift = {}: the mask must keep a bit and shift be 0–7",
                    x.mask, x.shift
                ));
            }
            let top = u32::from(x.mask >> x.shift);
            if u32::from(x.first) + x.groups - 1 > top {
                return Err(format!(
                    "mux values {} … {} do not fit (byte & {:#x}) >> {}",
                    x.first,
                    u32::from(x.first) + x.groups - 1,
                    x.mask,
                    x.shift
                ));
            }
            let mut ignore = [false; 256];
            for &v in &x.ignore {
                if u32::from(v) >= u32::from(x.first) && u32::from(v) < u32::from(x.first) + x.groups {
                    return Err(format!("mux value {v} is both a taxel block (< groups = {}) and ignored", x.groups));
                }
                ignore[v as usize] = true;
            }
            needed = needed.max(x.byte + 1);
            Some((x.byte, x.groups, ignore))
        }
    };
    if let Some(x) = &m.invalid_if {
        if x.byte > 7 {
            return Err(format!("invalid_if.byte = {}; a frame has bytes 0–7", x.byte));
        }
        needed = needed.max(x.byte + 1);
    }
    let length = match m.length {
        None => needed,
        Some(l) if l > 8 => return Err(format!("length = {l}; a classic CAN frame has at most 8 bytes")),
        Some(l) if l < needed => return Err(format!("length = {l} but the fields and mux need {needed} bytes")),
        Some(l) => l,
    };
    if m.word == WordFormat::Biotac
        && (m.bits != 16 || m.start_bit % 8 != 0 || m.byte_order != ByteOrder::Big || m.signed)
    {
        return Err("word = \"biotac\" needs bits = 16, a byte-aligned start_bit, big-endian, unsigned".into());
    }
    let field_min = if m.signed { -(1i64 << (m.bits - 1)) } else { 0 };
    let field_max = match m.word {
        WordFormat::Biotac => 4095,
        WordFormat::Plain if m.signed => (1i64 << (m.bits - 1)) - 1,
        WordFormat::Plain => (1i64 << m.bits) - 1,
    };
    let raw_min = m.raw_min.unwrap_or(field_min);
    let raw_max = m.raw_max.unwrap_or(field_max);
    if raw_min > raw_max {
        return Err(format!("raw_min {raw_min} > raw_max {raw_max}"));
    }
    if raw_max < field_min || raw_min > field_max {
        return Err(format!(
            "valid range {raw_min}…{raw_max} excludes every value a {}{}-bit field holds",
            if m.signed { "signed " } else { "" },
            m.bits
        ));
    }
    let short = gradtac_stream::num::Short;
    if !m.scale.is_finite() || m.scale == 0.0 || !m.offset.is_finite() {
        return Err(format!(
            "scale ({}) must be finite and non-zero, offset ({}) finite",
            short(m.scale),
            short(m.offset)
        ));
    }
    // every raw value of the valid range must decode to a finite number
    for raw in [raw_min, raw_max] {
        let v = raw as f64 * m.scale + m.offset;
        if !v.is_finite() {
            return Err(format!(
                "raw {raw} · scale {} + offset {} = {} is not finite: values up to raw_max {raw_max} (from raw_min \
                 {raw_min}) must decode to finite numbers",
                short(m.scale),
                short(m.offset),
                short(v)
            ));
        }
    }
    let groups = id_groups * mux.as_ref().map_or(1, |x| u64::from(x.1));
    let stride = m.stride.unwrap_or(m.count);
    if groups > 1 && stride < m.count {
        return Err(format!("stride {stride} < count {}: blocks would overlap", m.count));
    }
    let last = u64::from(m.first_taxel) + (groups - 1) * u64::from(stride) + u64::from(m.count) - 1;
    if last >= u64::from(taxels) {
        return Err(format!(
            "carries taxels up to {last} ({groups} blocks × stride {stride} from taxel {}), but the sensor has {taxels}",
            m.first_taxel
        ));
    }
    // `last < taxels` bounds this loop by the taxel count.
    for g in 0..groups {
        for k in 0..u64::from(m.count) {
            let t = (u64::from(m.first_taxel) + g * u64::from(stride) + k) as usize;
            if covered[t] {
                return Err(format!("taxel {t} is already carried by another message slot"));
            }
            covered[t] = true;
        }
    }
    Ok(Message {
        sensor,
        id: m.id,
        extended: m.extended,
        mask,
        shift: m.shift,
        id_groups: id_groups as u32,
        length,
        mux_bits: m.mux.as_ref().map_or((0xFF, 0, 0), |x| (x.mask, x.shift, x.first)),
        mux,
        word: m.word,
        invalid_if: m.invalid_if,
        shared: m.shared,
        start_bit: m.start_bit,
        bits: m.bits,
        count: m.count,
        order: m.byte_order,
        signed: m.signed,
        scale: m.scale,
        offset: m.offset,
        raw_min,
        raw_max,
        first_taxel: m.first_taxel,
        stride,
    })
}

/// A CAN id for messages: `123` or `1ABCDEF0`, as candump prints it.
pub fn id_string(id: u32, extended: bool) -> String {
    fmt_id(id, extended)
}

#[cfg(test)]
mod tests {
    use super::*;
    use gradtac_stream::Timestamp;

    fn sensor(messages: Vec<MessageSpec>, taxels: u32) -> SensorSpec {
        SensorSpec { name: "s".into(), taxels, timeout_ms: 50.0, incomplete: IncompletePolicy::Drop, messages }
    }

    fn frame(id: u32, data: &[u8]) -> CanFrame {
        CanFrame::standard(id, data, Timestamp(0)).unwrap()
    }

    fn decode(c: &CanCodec, f: &CanFrame) -> (Decoded, Vec<FieldValue>) {
        let mut out = Vec::new();
        let d = c.decode(f, &mut out);
        (d, out)
    }

    #[test]
    fn big_endian_12_bit_fields_read_msb_first() {
        // bytes 1..4 = AB CD EF → fields 0xABC, 0xDEF
        let c = CanCodec::from_sensors(&[sensor(vec![MessageSpec::new(0x10, 8, 12, 2)], 2)]).unwrap();
        let (d, v) = decode(&c, &frame(0x10, &[0, 0xAB, 0xCD, 0xEF]));
        assert_eq!(d, Decoded::Values { sensor: 0, group: 0 });
        assert_eq!(v.iter().map(|f| f.raw).collect::<Vec<_>>(), vec![0xABC, 0xDEF]);
        assert_eq!(v[1].value, Some(0xDEF as f64));
    }

    #[test]
    fn little_endian_fields_read_lsb_first() {
        // LE payload 0xEFCDAB00 ; bits 8.. = 0xEFCDAB ; 12-bit fields: 0xDAB, 0xEFC
        let m = MessageSpec { byte_order: ByteOrder::Little, ..MessageSpec::new(0x10, 8, 12, 2) };
        let c = CanCodec::from_sensors(&[sensor(vec![m], 2)]).unwrap();
        let (_, v) = decode(&c, &frame(0x10, &[0, 0xAB, 0xCD, 0xEF]));
        assert_eq!(v.iter().map(|f| f.raw).collect::<Vec<_>>(), vec![0xDAB, 0xEFC]);
        // 16-bit LE at byte 1 = bytes 1-2 little-endian
        let m = MessageSpec { byte_order: ByteOrder::Little, ..MessageSpec::new(0x10, 8, 16, 1) };
        let c = CanCodec::from_sensors(&[sensor(vec![m], 1)]).unwrap();
        let (_, v) = decode(&c, &frame(0x10, &[0, 0x34, 0x12]));
        assert_eq!(v[0].raw, 0x1234);
    }

    #[test]
    fn signed_scale_offset_and_range() {
        let m = MessageSpec {
            signed: true,
            scale: 0.5,
            offset: 10.0,
            raw_min: Some(-100),
            raw_max: Some(100),
            ..MessageSpec::new(0x10, 0, 16, 3)
        };
        let c = CanCodec::from_sensors(&[sensor(vec![m], 3)]).unwrap();
        let (_, v) = decode(&c, &frame(0x10, &[0xFF, 0xFE, 0x00, 0x64, 0x80, 0x00]));
        assert_eq!(v[0].raw, -2);
        assert_eq!(v[0].value, Some(9.0));
        assert_eq!(v[1].value, Some(60.0));
        assert_eq!(v[2].raw, -32768);
        assert_eq!(v[2].value, None);
    }

    #[test]
    fn a_sensor_of_four_billion_taxels_is_refused_without_allocating() {
        let m = MessageSpec::new(0x10, 0, 8, 1);
        let e = CanCodec::from_sensors(&[sensor(vec![m], u32::MAX)]).unwrap_err().to_string();
        assert!(e.contains("taxels = 4294967295; at most 65535"), "{e}");
    }

    #[test]
    fn id_index_and_mux_select_taxels() {
        // ids 0x200..0x203 → blocks of 2 taxels; mux byte 0 selects 0..2 within each
        let m = MessageSpec {
            mask: Some(0x7FC),
            mux: Some(MuxSpec::new(0, 3, vec![9])),
            length: Some(8),
            ..MessageSpec::new(0x200, 8, 16, 2)
        };
        let c = CanCodec::from_sensors(&[sensor(vec![m], 24)]).unwrap();
        let (d, v) = decode(&c, &frame(0x202, &[1, 0, 7, 0, 8, 0, 0, 0]));
        assert_eq!(d, Decoded::Values { sensor: 0, group: 7 });
        assert_eq!(v.iter().map(|f| (f.taxel, f.raw)).collect::<Vec<_>>(), vec![(14, 7), (15, 8)]);
        assert_eq!(decode(&c, &frame(0x202, &[9, 0, 0, 0, 0, 0, 0, 0])).0, Decoded::Ignored { sensor: 0, value: 9 });
        assert_eq!(decode(&c, &frame(0x202, &[3, 0, 0, 0, 0, 0, 0, 0])).0, Decoded::UnknownMux { sensor: 0, value: 3 });
        assert_eq!(decode(&c, &frame(0x202, &[0, 0, 0])).0, Decoded::WrongLength { sensor: 0, expected: 8, got: 3 });
        assert_eq!(decode(&c, &frame(0x204, &[0; 8])).0, Decoded::UnknownId);
        // extended frames with the same number do not match a standard message
        let mut out = Vec::new();
        assert_eq!(c.decode(&CanFrame::extended(0x200, &[0; 8], Timestamp(0)).unwrap(), &mut out), Decoded::UnknownId);
    }

    #[test]
    fn id_groups_limits_the_ids() {
        let m = MessageSpec { mask: Some(0x7F0), id_groups: Some(12), ..MessageSpec::new(0x200, 0, 16, 1) };
        let c = CanCodec::from_sensors(&[sensor(vec![m], 12)]).unwrap();
        assert!(matches!(decode(&c, &frame(0x20B, &[0, 1])).0, Decoded::Values { group: 11, .. }));
        assert_eq!(decode(&c, &frame(0x20C, &[0, 1])).0, Decoded::UnknownId);
    }

    fn err(specs: &[SensorSpec]) -> String {
        CanCodec::from_sensors(specs).unwrap_err().to_string()
    }

    #[test]
    fn validation_names_the_problem() {
        let e = err(&[sensor(vec![MessageSpec::new(0x10, 0, 16, 2)], 3)]);
        assert!(e.contains("taxels 2 are carried by no message"), "{e}");
        let e = err(&[sensor(vec![MessageSpec::new(0x10, 0, 16, 4)], 3)]);
        assert!(e.contains("sensor \"s\" message 0 (id 0x10)") && e.contains("up to 3"), "{e}");
        let e = err(&[sensor(vec![MessageSpec::new(0x10, 60, 8, 1)], 1)]);
        assert!(e.contains("end at bit 68"), "{e}");
        let e = err(&[sensor(vec![MessageSpec::new(0x10, 0, 33, 1)], 1)]);
        assert!(e.contains("1 to 32"), "{e}");
        let e = err(&[sensor(
            vec![MessageSpec::new(0x10, 0, 8, 1), MessageSpec { first_taxel: 1, ..MessageSpec::new(0x10, 8, 8, 1) }],
            2,
        )]);
        assert!(e.contains("both match"), "{e}");
        let e = err(&[sensor(
            vec![MessageSpec::new(0x10, 0, 8, 2), MessageSpec { first_taxel: 1, ..MessageSpec::new(0x11, 0, 8, 1) }],
            2,
        )]);
        assert!(e.contains("taxel 1 is already carried"), "{e}");
        let m = MessageSpec { mux: Some(MuxSpec::new(0, 1, vec![])), ..MessageSpec::new(0x10, 0, 8, 1) };
        assert!(err(&[sensor(vec![m], 1)]).contains("overlaps"));
        let m = MessageSpec { length: Some(1), ..MessageSpec::new(0x10, 0, 16, 1) };
        assert!(err(&[sensor(vec![m], 1)]).contains("need 2 bytes"));
        let m = MessageSpec { mask: Some(0x7F5), ..MessageSpec::new(0x10, 0, 16, 1) };
        assert!(err(&[sensor(vec![m], 16)]).contains("contiguous"));
        let m = MessageSpec::new(0x800, 0, 16, 1);
        assert!(err(&[sensor(vec![m], 1)]).contains("11-bit"));
        let mut s = sensor(vec![MessageSpec::new(0x10, 0, 8, 1)], 1);
        s.timeout_ms = 0.0;
        assert!(err(&[s.clone()]).contains("timeout_ms"));
        s.timeout_ms = 1.0;
        assert!(err(&[s.clone(), s]).contains("described twice"));
        assert!(err(&[]).contains("no sensors"));
    }

    #[test]
    fn deserializes_from_toml() {
        let cfg: CodecConfig = toml::from_str(
            r#"
            [[sensors]]
            name = "palm"
            taxels = 4
            incomplete = "carry"
            [[sensors.messages]]
            id = 0x300
            start_bit = 0
            bits = 16
            count = 4
            byte_order = "intel"
            raw_max = 60000
            "#,
        )
        .unwrap();
        assert_eq!(cfg.sensors[0].messages[0].byte_order, ByteOrder::Little);
        assert_eq!(cfg.sensors[0].incomplete, IncompletePolicy::Carry);
        assert_eq!(cfg.sensors[0].timeout_ms, 50.0);
        let c = CanCodec::try_new(&cfg).unwrap();
        assert_eq!(c.taxels(0), 4);
        let e = toml::from_str::<CodecConfig>("[[sensors]]\nname='a'\ntaxels=1\nmessages=[]\nbogus=1").unwrap_err();
        assert!(e.to_string().contains("bogus"), "{e}");
    }

    proptest::proptest! {
        /// Any frame, against any valid message layout, decodes without panicking and yields
        /// taxels inside the sensor.
        #[test]
        fn decode_never_panics(
            start in 0u32..64, bits in 1u32..=32, count in 1u32..8, little in proptest::bool::ANY,
            signed in proptest::bool::ANY, mux in proptest::option::of(0u8..8),
            id in 0u32..0x800, data in proptest::collection::vec(proptest::num::u8::ANY, 0..=8),
        ) {
            let m = MessageSpec {
                byte_order: if little { ByteOrder::Little } else { ByteOrder::Big },
                signed,
                mask: Some(0x7F0),
                id_groups: Some(2),
                mux: mux.map(|b| MuxSpec::new(b, 3, vec![200])),
                ..MessageSpec::new(0x100, start, bits, count)
            };
            let taxels = 2 * 3 * count;
            if let Ok(c) = CanCodec::from_sensors(&[sensor(vec![m], taxels)]) {
                let f = CanFrame::standard(id, &data, Timestamp(0)).unwrap();
                let mut out = Vec::new();
                let _ = c.decode(&f, &mut out);
                for v in &out {
                    proptest::prop_assert!(v.taxel < taxels);
                }
            }
        }
    }
}
