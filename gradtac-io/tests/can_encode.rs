//! CAN encoding round trips: taxel values → `CanCodec::encode` → `CanDecoder` (decode +
//! reassembly) → the same values, for both presets and for random hand-built layouts (byte
//! orders, widths 1–32 bits, signed/unsigned, scales, offsets, valid sub-ranges, id-indexed and
//! multiplexed blocks, interleaved messages); and frames → `CandumpWriter` → `CandumpReader`
//! → the same frames.

use gradtac_io::can::{
    write_candump, ByteOrder, CanCodec, CanDecoder, CanEncoder, CanFrame, CandumpReader, CandumpWriter, CodecConfig,
    IncompletePolicy, MessageSpec, MuxSpec, PresetConfig, PresetKind, SensorSpec,
};
use gradtac_io::Error;
use gradtac_stream::{SensorId, StageExt, TaxelFrame, Timestamp};
use proptest::prelude::*;

/// The layout of one message's fields, drawn at random.
#[derive(Clone, Debug)]
struct Fields {
    bits: u32,
    count: u32,
    start_bit: u32,
    order: ByteOrder,
    signed: bool,
    scale: f64,
    offset: f64,
    raw_min: i64,
    raw_max: i64,
    restricted: bool,
    /// The multiplexer byte, when the message is multiplexed.
    mux_byte: Option<u8>,
}

fn field_range(bits: u32, signed: bool) -> (i64, i64) {
    if signed {
        (-(1i64 << (bits - 1)), (1i64 << (bits - 1)) - 1)
    } else {
        (0, (1i64 << bits) - 1)
    }
}

/// A value of `lo ..= hi` from a random seed.
fn pick(seed: u64, lo: i64, hi: i64) -> i64 {
    lo + (seed % ((hi - lo) as u64 + 1)) as i64
}

prop_compose! {
    /// Fields that fit a frame next to an optional multiplexer byte.
    fn fields(mux: bool)(
        bits in 1u32..=32, count in 1u32..=6, little in any::<bool>(), signed in any::<bool>(),
        mux_byte in 0u8..8, after in any::<bool>(), start_seed in any::<u32>(),
        scale in (1.0f64..10.0, -3i32..=3, any::<bool>()),
        offset in -1000.0f64..1000.0, restricted in any::<bool>(), range_seed in any::<(u64, u64)>(),
    ) -> Fields {
        // fields live below or above the mux byte, in whichever region can hold one field
        let (mut lo, mut hi) = if !mux { (0, 64) } else if after { (8 * u32::from(mux_byte) + 8, 64) } else { (0, 8 * u32::from(mux_byte)) };
        if hi - lo < bits {
            (lo, hi) = if after { (0, 8 * u32::from(mux_byte)) } else { (8 * u32::from(mux_byte) + 8, 64) };
        }
        let count = count.min((hi - lo) / bits);
        let start_bit = lo + start_seed % (hi - lo - count * bits + 1);
        let (fmin, fmax) = field_range(bits, signed);
        let (raw_min, raw_max) = if restricted {
            let a = pick(range_seed.0, fmin, fmax);
            (a, pick(range_seed.1, a, fmax))
        } else {
            (fmin, fmax)
        };
        let (mantissa, exp, negative) = scale;
        let scale = if negative { -1.0 } else { 1.0 } * mantissa * 10f64.powi(exp);
        Fields {
            bits, count, start_bit,
            order: if little { ByteOrder::Little } else { ByteOrder::Big },
            signed, scale, offset, raw_min, raw_max, restricted,
            mux_byte: mux.then_some(mux_byte),
        }
    }
}

/// A random codec: sensor "pad" (index 0, the other frame format, so its ids never clash) and
/// sensor "s" (index 1) carried by one message or two interleaved ones (A and B share the
/// block structure; blocks alternate A's `count` taxels, then B's).
#[derive(Clone, Debug)]
struct Layout {
    codec: CanCodec,
    /// For each taxel of "s": (raw_min, raw_max, scale, offset) of the field carrying it.
    taxels: Vec<(i64, i64, f64, f64)>,
}

prop_compose! {
    fn layout()(mux_groups in proptest::option::of(1u32..=4))(
        a in fields(mux_groups.is_some()), b in proptest::option::of(fields(mux_groups.is_some())),
        mux_groups in Just(mux_groups), free_bits in 0u32..=3, shift in 0u32..=2, id_groups_seed in any::<u32>(),
        extended in any::<bool>(), id_seed in any::<u32>(), length_extra in 0u8..=8, ignore in any::<bool>(),
    ) -> Layout {
        let width = if extended { 0x1FFF_FFFFu32 } else { 0x7FF };
        let top = if extended { 1 << 28 } else { 1 << 10 };
        let index_bits = ((1u32 << free_bits) - 1) << shift;
        let mask = width & !index_bits;
        let id_groups = 1 + id_groups_seed % (1 << free_bits);
        let base = id_seed & width & !top;
        let groups = id_groups * mux_groups.unwrap_or(1);
        let stride = a.count + b.as_ref().map_or(0, |b| b.count);
        let message = |f: &Fields, id: u32, first_taxel: u32| {
            let end = (f.start_bit + f.count * f.bits).div_ceil(8) as u8;
            let needed = end.max(f.mux_byte.map_or(0, |m| m + 1));
            MessageSpec {
                id,
                extended,
                mask: Some(mask),
                shift,
                id_groups: Some(id_groups),
                length: Some((needed + length_extra).min(8)),
                mux: mux_groups.map(|g| {
                    MuxSpec::new(f.mux_byte.unwrap_or(0), g, if ignore && g < 4 { vec![200] } else { vec![] })
                }),
                start_bit: f.start_bit,
                bits: f.bits,
                count: f.count,
                byte_order: f.order,
                signed: f.signed,
                scale: f.scale,
                offset: f.offset,
                raw_min: f.restricted.then_some(f.raw_min),
                raw_max: f.restricted.then_some(f.raw_max),
                first_taxel,
                stride: Some(stride),
                ..MessageSpec::new(id, 0, 1, 1)
            }
        };
        let mut messages = vec![message(&a, base, 0)];
        if let Some(b) = &b {
            messages.push(message(b, base | top, a.count));
        }
        let taxels = groups * stride;
        let mut per_taxel = Vec::with_capacity(taxels as usize);
        for t in 0..taxels {
            let f = if t % stride < a.count { &a } else { b.as_ref().unwrap() };
            per_taxel.push((f.raw_min, f.raw_max, f.scale, f.offset));
        }
        let pad = SensorSpec {
            name: "pad".into(),
            taxels: 1,
            timeout_ms: 50.0,
            incomplete: IncompletePolicy::Drop,
            messages: vec![MessageSpec { extended: !extended, ..MessageSpec::new(0x7FF, 0, 8, 1) }],
        };
        let s = SensorSpec { name: "s".into(), taxels, timeout_ms: 50.0, incomplete: IncompletePolicy::Drop, messages };
        let codec = CanCodec::from_sensors(&[pad, s]).expect("generated layouts are valid");
        Layout { codec, taxels: per_taxel }
    }
}

const T: Timestamp = Timestamp(1_700_000_000_000_000_000);

/// Encode `values` for sensor `sensor`, decode through the decoder, return the one frame.
fn round_trip(codec: &CanCodec, sensor: usize, values: &[f64]) -> Result<TaxelFrame, TestCaseError> {
    let mut can = Vec::new();
    codec.encode(sensor, values, T, &mut can).map_err(|e| TestCaseError::fail(e.to_string()))?;
    let mut dec = CanDecoder::new(codec.clone());
    let out = dec.run_all(can).map_err(|e| TestCaseError::fail(e.to_string()))?;
    let st = dec.stats();
    prop_assert_eq!(st.total_faults(), 0, "{}", st);
    prop_assert_eq!(out.len(), 1);
    prop_assert_eq!(&out[0].sensor, codec.sensor_id(sensor));
    prop_assert_eq!(out[0].time, T);
    Ok(out[0].clone())
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    /// Values on the grid (`raw · scale + offset`, as the decoder computes them) come back
    /// bit-equal.
    #[test]
    fn grid_values_round_trip_bit_equal(l in layout(), seeds in proptest::collection::vec(any::<u64>(), 512)) {
        let values: Vec<f64> = l.taxels.iter().enumerate()
            .map(|(t, &(lo, hi, scale, offset))| pick(seeds[t % seeds.len()] ^ t as u64, lo, hi) as f64 * scale + offset)
            .collect();
        let got = round_trip(&l.codec, 1, &values)?;
        prop_assert_eq!(bits(&got.values), bits(&values));
    }

    /// Any finite value inside the valid range decodes to within half a quantum; values more
    /// than a quantum outside it are errors naming the sensor and taxel.
    #[test]
    fn finite_values_round_trip_within_half_a_quantum(
        l in layout(), u in proptest::collection::vec(0.0f64..=1.0, 512), bad in any::<proptest::sample::Index>(),
        beyond in 1.01f64..1e6,
    ) {
        let values: Vec<f64> = l.taxels.iter().enumerate().map(|(t, &(lo, hi, scale, offset))| {
            let (a, b) = (lo as f64 * scale + offset, hi as f64 * scale + offset);
            let (a, b) = (a.min(b), a.max(b));
            a + u[t % u.len()] * (b - a)
        }).collect();
        let got = round_trip(&l.codec, 1, &values)?;
        for (t, (&want, &have)) in values.iter().zip(&got.values).enumerate() {
            let q = l.taxels[t].2.abs();
            prop_assert!((want - have).abs() <= 0.5 * q * (1.0 + 1e-9) + 1e-9 * want.abs().max(1.0),
                "taxel {}: {} decoded as {} (quantum {})", t, want, have, q);
        }
        let t = bad.index(values.len());
        let (lo, hi, scale, offset) = l.taxels[t];
        let mut wrong = values.clone();
        wrong[t] = if scale > 0.0 { hi as f64 * scale + offset + beyond * scale } else { lo as f64 * scale + offset - beyond * scale };
        let mut out = Vec::new();
        match l.codec.encode(1, &wrong, T, &mut out) {
            Err(Error::CanEncode { sensor, taxel, .. }) => {
                prop_assert_eq!(sensor.as_str(), "s");
                prop_assert_eq!(taxel, Some(t as u32));
            }
            other => prop_assert!(false, "expected an encoding error for taxel {}: {:?}", t, other),
        }
        prop_assert!(out.is_empty());
    }

    /// `biotac-mux`: every valid electrode reading of every fingertip, interleaved on one bus.
    #[test]
    fn biotac_mux_round_trips(
        raws in proptest::collection::vec(1u16..=4094, 3 * 24), base in 0u32..0x700, extended in any::<bool>(),
    ) {
        let mut p = PresetConfig::new(PresetKind::BiotacMux, &["ff", "mf", "th"]);
        p.base_id = Some(base);
        p.extended = extended;
        let codec = CanCodec::try_new(&CodecConfig::preset(p)).unwrap();
        let frames: Vec<TaxelFrame> = ["ff", "mf", "th"].iter().enumerate().map(|(i, n)| {
            let v = raws[24 * i..24 * (i + 1)].iter().map(|&r| f64::from(r)).collect();
            TaxelFrame::new(SensorId::new(n), T + i as i64, 0, v)
        }).collect();
        let can = CanEncoder::new(codec.clone()).run_all(frames.clone()).unwrap();
        prop_assert_eq!(can.len(), 18);
        prop_assert_eq!(CanDecoder::new(codec).run_all(can).unwrap(), frames);
    }

    /// `xela-uskin`: any 16-bit z value, any module size up to the public 16, standard or
    /// extended ids.
    #[test]
    fn xela_uskin_round_trips(taxels in 1u32..=16, z in proptest::collection::vec(any::<u16>(), 64), extended in any::<bool>()) {
        let mut p = PresetConfig::new(PresetKind::XelaUskin, &["m0", "m1"]);
        p.taxels = Some(taxels);
        p.extended = extended;
        let codec = CanCodec::try_new(&CodecConfig::preset(p)).unwrap();
        for sensor in 0..2 {
            let values: Vec<f64> = z[..taxels as usize].iter().map(|&r| f64::from(r)).collect();
            let got = round_trip(&codec, sensor, &values)?;
            prop_assert_eq!(bits(&got.values), bits(&values));
        }
    }

    /// Frames → candump log → frames, identical (times on whole µs, as candump logs them).
    #[test]
    fn candump_writer_round_trips(
        frames in proptest::collection::vec(
            (any::<bool>(), any::<u32>(), proptest::collection::vec(any::<u8>(), 0..=8), 0i64..4_000_000_000_000_000),
            0..40),
        iface in "[a-z][a-z0-9_.-]{0,14}",
    ) {
        let frames: Vec<CanFrame> = frames.into_iter().map(|(ext, id, data, us)| {
            let id = if ext { id & 0x1FFF_FFFF } else { id & 0x7FF };
            CanFrame::try_new(id, ext, &data, Timestamp(us * 1000)).unwrap()
        }).collect();
        let mut text = Vec::new();
        prop_assert_eq!(write_candump(frames.clone(), &iface, &mut text).unwrap(), frames.len() as u64);
        let mut r = CandumpReader::new("mem.log", &text[..]).with_interface(iface.clone());
        let back: Vec<CanFrame> = r.by_ref().collect::<Result<_, _>>().unwrap();
        prop_assert_eq!(back, frames);
        prop_assert_eq!(r.stats().other_interface, 0);
    }
}

/// The writer's lines are candump's: 3/8-digit ids, upper-case hex, µs (truncated); its
/// output replays through the decoder like the logged original.
#[test]
fn candump_writer_format_and_errors() {
    let frames = [
        CanFrame::standard(0x1F, &[0xAB, 0x0C], Timestamp(1_500_000_999)).unwrap(),
        CanFrame::extended(0x1ABC, &[], Timestamp(0)).unwrap(),
    ];
    let mut w = CandumpWriter::new("x.log", Vec::new(), "can0").unwrap();
    for f in &frames {
        w.write(f).unwrap();
    }
    assert_eq!(w.frames(), 2);
    let text = String::from_utf8(w.finish().unwrap()).unwrap();
    assert_eq!(text, "(1.500000) can0 01F#AB0C\n(0.000000) can0 00001ABC#\n");
    // sub-µs parts are truncated, as candump does
    let back: Vec<CanFrame> = CandumpReader::new("x.log", text.as_bytes()).map(Result::unwrap).collect();
    assert_eq!(back[0], frames[0].with_time(Timestamp(1_500_000_000)));

    let e = CandumpWriter::new("x.log", Vec::new(), "can 0").unwrap_err().to_string();
    assert!(e.contains("\"can 0\" must be one non-empty word"), "{e}");
    assert!(CandumpWriter::new("x.log", Vec::new(), "").is_err());
    let before = CanFrame::standard(0x123, &[1], Timestamp(-1)).unwrap();
    let e = write_candump([frames[0], before], "can0", Vec::new()).unwrap_err().to_string();
    assert_eq!(
        e,
        "candump record does not fit the sink: frame 1 (id 123) at -1 ns is before the Unix epoch; \
         a candump log cannot hold it"
    );

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("enc.log");
    let mut w = CandumpWriter::create(&path, "vcan0").unwrap();
    w.write(&frames[0]).unwrap();
    w.finish().unwrap();
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "(1.500000) vcan0 01F#AB0C\n");
}

/// A simulated hand on a virtual bus: encoder → candump log → `CandumpSource` gives back the
/// frames that went in (the scene path a recorded or simulated session takes).
#[test]
fn encoded_session_replays_from_a_candump_log() {
    let codec =
        CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &["ff", "th"]))).unwrap();
    let mut frames = Vec::new();
    for k in 0..20u64 {
        for (i, name) in ["ff", "th"].iter().enumerate() {
            let v = (0..24).map(|e| (100 + 37 * k + 11 * e + 500 * i as u64) as f64).collect();
            frames.push(TaxelFrame::new(SensorId::new(name), T + (k as i64) * 10_000_000 + i as i64 * 1000, k, v));
        }
    }
    let can = CanEncoder::new(codec.clone()).run_all(frames.clone()).unwrap();
    let mut log = Vec::new();
    write_candump(can, "vcan0", &mut log).unwrap();
    let reader = CandumpReader::new("sim.log", &log[..]);
    let source = gradtac_io::can::CandumpSource::new(reader, CanDecoder::new(codec));
    let back: Vec<TaxelFrame> = source.map(Result::unwrap).collect();
    assert_eq!(back, frames);
}
