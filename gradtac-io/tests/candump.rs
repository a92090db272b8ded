//! A candump log of a three-finger recording (multiplexed `biotac-mux` preset) with injected
//! bad traffic, decoded offline, through the async replay and through the in-memory
//! transport. The log is written here by hand (own bit packing, own line formatting), not with
//! the crate's helpers, so that encoding and decoding are checked against each other.

use futures::StreamExt;
use gradtac_io::can::{
    frame_channel, CanCodec, CanDecoder, CanFrame, CanStream, CandumpConfig, CandumpReader, CandumpSource, CodecConfig,
    IncompletePolicy, PresetConfig, PresetKind, Timing,
};
use gradtac_stream::{StageExt, TaxelFrame, Timestamp};
use proptest::prelude::*;
use std::io::{BufReader, Read};

const FINGERS: [&str; 3] = ["ff", "mf", "th"];
const CYCLES: u64 = 50;
const T0_NS: i64 = 1_700_000_000_000_000_000;
const CYCLE_NS: i64 = 10_000_000; // 100 Hz

/// The electrode value finger `f` reports in cycle `k` for electrode `e` (raw counts).
fn value(f: usize, k: u64, e: usize) -> u16 {
    (1500 + 100 * f as u64 + 10 * e as u64 + 3 * k) as u16
}

/// Four 12-bit values, big-endian MSB first, in 6 bytes.
fn pack12(v: [u16; 4]) -> [u8; 6] {
    [
        (v[0] >> 4) as u8,
        (((v[0] & 0xF) << 4) | (v[1] >> 8)) as u8,
        (v[1] & 0xFF) as u8,
        (v[2] >> 4) as u8,
        (((v[2] & 0xF) << 4) | (v[3] >> 8)) as u8,
        (v[3] & 0xFF) as u8,
    ]
}

fn line(t_ns: i64, id: &str, data: &[u8]) -> String {
    let hex: String = data.iter().map(|b| format!("{b:02X}")).collect();
    format!("({}.{:06}) can0 {id}#{hex}", t_ns / 1_000_000_000, (t_ns % 1_000_000_000) / 1000)
}

/// What the generator injected, to compare with the decoder's counts.
#[derive(Default, Debug)]
struct Truth {
    /// (finger, cycle, time of the set's last frame) of every set that completes.
    complete: Vec<(usize, u64, i64)>,
    /// mux 6–8 frames written.
    ignored: u64,
    frames: u64,
    unknown_id: u64,
    wrong_length: u64,
    unknown_mux: u64,
    out_of_range: u64,
    /// (finger, cycle) of the sets that never complete, with their time of last frame.
    incomplete: Vec<(usize, u64, i64)>,
}

/// The log text and what it holds. Faults:
/// - th cycle 10: electrode 9 reads 0xFFF (ADC rail: out of range) → incomplete;
/// - mf cycle 20: the mux-4 frame is lost → incomplete when cycle 21 begins;
/// - th cycles 40–44: th sends mux 0–2 of cycle 40 and then goes silent until cycle 45 →
///   cycle 40 times out (timeout 15 ms);
/// - 4 unknown ids (3 standard, 1 extended with a fingertip's number), 2 wrong lengths,
///   1 unknown mux value; plus a remote, an error and a CAN FD line the reader skips.
fn recording() -> (String, Truth) {
    let mut lines = Vec::new();
    let mut t = Truth::default();
    let emit = |lines: &mut Vec<String>, t: &mut Truth, ns: i64, id: &str, data: &[u8]| {
        lines.push(line(ns, id, data));
        t.frames += 1;
    };
    for k in 0..CYCLES {
        let base = T0_NS + k as i64 * CYCLE_NS;
        for (f, _) in FINGERS.iter().enumerate() {
            if f == 2 && (41..45).contains(&k) {
                continue; // th silent
            }
            let id = format!("{:03X}", 0x100 + f);
            let mut last = 0;
            let mut ok = true;
            for mux in 0..9u8 {
                let ns = base + f as i64 * 1_000_000 + mux as i64 * 100_000;
                if mux < 6 {
                    if f == 1 && k == 20 && mux == 4 {
                        ok = false;
                        continue;
                    }
                    if f == 2 && k == 40 && mux >= 3 {
                        ok = false;
                        continue;
                    }
                    let mut v = [0u16; 4];
                    for (j, x) in v.iter_mut().enumerate() {
                        *x = value(f, k, 4 * mux as usize + j);
                    }
                    if f == 2 && k == 10 && mux == 2 {
                        v[1] = 0xFFF; // electrode 10 = taxel 9
                        t.out_of_range += 1;
                        ok = false;
                    }
                    let mut data = vec![mux];
                    data.extend(pack12(v));
                    data.push(0);
                    emit(&mut lines, &mut t, ns, &id, &data);
                    last = ns;
                } else {
                    emit(&mut lines, &mut t, ns, &id, &[mux, 0x12, 0x34, 0, 0, 0, 0, 0]);
                    t.ignored += 1;
                }
            }
            if ok {
                t.complete.push((f, k, last));
            } else {
                t.incomplete.push((f, k, last));
            }
        }
        let extra = base + 5_000_000;
        match k {
            3 | 17 | 33 => {
                emit(&mut lines, &mut t, extra, "1F0", &[1, 2, 3]);
                t.unknown_id += 1;
            }
            5 => {
                emit(&mut lines, &mut t, extra, "00000100", &[0; 8]); // extended, not 0x100
                t.unknown_id += 1;
            }
            7 | 27 => {
                emit(&mut lines, &mut t, extra, "101", &[0, 1, 2, 3, 4, 5]);
                t.wrong_length += 1;
            }
            12 => {
                emit(&mut lines, &mut t, extra, "100", &[0x0A, 0, 0, 0, 0, 0, 0, 0]);
                t.unknown_mux += 1;
            }
            13 => {
                lines.push(format!("({}.{:06}) can0 100#R", extra / 1_000_000_000, (extra % 1_000_000_000) / 1000));
                lines.push(format!("({}.{:06}) can0 20000004#0000000000000000", extra / 1_000_000_000, 1));
                lines.push(format!("({}.{:06}) can0 100##1DEADBEEF", extra / 1_000_000_000, 2));
            }
            _ => {}
        }
    }
    let mut text = lines.join("\n");
    text.push('\n');
    (text, t)
}

fn codec(policy: IncompletePolicy) -> CanCodec {
    let mut p = PresetConfig::new(PresetKind::BiotacMux, &FINGERS);
    p.timeout_ms = 15.0;
    p.incomplete = policy;
    CanCodec::try_new(&CodecConfig::preset(p)).unwrap()
}

fn expected_values(f: usize, k: u64) -> Vec<f64> {
    (0..24).map(|e| value(f, k, e) as f64).collect()
}

fn decode_text(text: &str, policy: IncompletePolicy) -> (Vec<TaxelFrame>, gradtac_io::can::CanStats) {
    let reader = CandumpReader::new("three-finger.log", text.as_bytes());
    let mut src = CandumpSource::new(reader, CanDecoder::new(codec(policy)));
    let frames: Vec<TaxelFrame> = src.by_ref().collect::<Result<_, _>>().unwrap();
    (frames, src.stats())
}

#[test]
fn three_finger_recording_decodes_to_the_right_frames_and_fault_counts() {
    let (text, truth) = recording();
    let (frames, st) = decode_text(&text, IncompletePolicy::Drop);

    // every complete set, and nothing else, in order per finger, with the right values
    assert_eq!(frames.len(), truth.complete.len());
    assert_eq!(frames.len(), 3 * 50 - 1 - 1 - 5);
    for (f, name) in FINGERS.iter().enumerate() {
        let got: Vec<&TaxelFrame> = frames.iter().filter(|x| x.sensor.as_str() == *name).collect();
        let want: Vec<&(usize, u64, i64)> = truth.complete.iter().filter(|c| c.0 == f).collect();
        assert_eq!(got.len(), want.len(), "{name}");
        for (g, &&(_, k, last)) in got.iter().zip(&want) {
            assert_eq!(g.values, expected_values(f, k), "{name} cycle {k}");
            assert_eq!(g.time, Timestamp(last / 1000 * 1000), "{name} cycle {k}");
        }
    }
    // seq counts cycles, dropped ones included: th jumps 9 → 11 and 39 → 41 (cycle 45)
    let th_seq: Vec<u64> = frames.iter().filter(|x| x.sensor.as_str() == "th").map(|x| x.seq).collect();
    assert_eq!(&th_seq[9..11], &[9, 11]);
    assert_eq!(&th_seq[38..40], &[39, 41]);

    assert_eq!(st.frames, truth.frames);
    assert_eq!(st.frames_ignored, truth.ignored);
    assert_eq!(st.unknown_id.count, truth.unknown_id);
    assert_eq!(st.unknown_id.count, 4);
    assert_eq!(st.wrong_length.count, 2);
    assert_eq!(st.unknown_mux.count, 1);
    assert_eq!(st.out_of_range.count, truth.out_of_range);
    assert_eq!(st.incomplete.count, truth.incomplete.len() as u64);
    assert_eq!(st.incomplete.count, 3);
    assert_eq!((st.sets_complete, st.sets_dropped, st.sets_carried, st.carried.count), (143, 3, 0, 0));
    assert_eq!(
        st.frames_decoded,
        truth.frames - truth.ignored - truth.unknown_id - truth.wrong_length - truth.unknown_mux
    );

    // first occurrences name the id and time
    let first = st.unknown_id.first.as_ref().unwrap();
    assert_eq!((first.id, first.extended, first.time), (0x1F0, false, Timestamp(T0_NS + 3 * CYCLE_NS + 5_000_000)));
    let first = st.wrong_length.first.as_ref().unwrap();
    assert_eq!((first.id, first.time), (0x101, Timestamp(T0_NS + 7 * CYCLE_NS + 5_000_000)));
    assert!(first.detail.contains("6 data bytes, the message has 8"), "{}", first.detail);
    let first = st.out_of_range.first.as_ref().unwrap();
    assert_eq!(first.sensor.as_ref().unwrap().as_str(), "th");
    assert!(first.detail.contains("taxel 9 raw 4095"), "{}", first.detail);
    let first = st.incomplete.first.as_ref().unwrap();
    assert_eq!((first.id, first.time), (0x102, Timestamp(T0_NS + 10 * CYCLE_NS + 2_000_000)));
    let text_stats = st.to_string();
    assert!(text_stats.contains("4 × unknown_id (first: id 1F0 at "), "{text_stats}");
}

#[test]
fn carry_policy_fills_lost_values_from_the_previous_cycle() {
    let (text, truth) = recording();
    let reader = CandumpReader::new("three-finger.log", text.as_bytes());
    let out: Vec<CanFrame> = reader.collect::<Result<_, _>>().unwrap();
    let mut dec = CanDecoder::new(codec(IncompletePolicy::Carry)).flagged();
    let decoded = dec.run_all(out).unwrap();
    assert_eq!(decoded.len(), truth.complete.len() + truth.incomplete.len());
    let find = |name: &str, seq: u64| {
        decoded.iter().find(|d| d.frame.sensor.as_str() == name && d.frame.seq == seq).unwrap().clone()
    };
    // th cycle 10: taxel 9 out of range → carried from cycle 9
    let d = find("th", 10);
    assert_eq!(d.carried, vec![9]);
    let mut want = expected_values(2, 10);
    want[9] = value(2, 9, 9) as f64;
    assert_eq!(d.frame.values, want);
    // mf cycle 20: mux 4 lost → taxels 16–19 from cycle 19
    let d = find("mf", 20);
    assert_eq!(d.carried, vec![16, 17, 18, 19]);
    assert_eq!(d.frame.values[16], value(1, 19, 16) as f64);
    assert_eq!(d.frame.values[15], value(1, 20, 15) as f64);
    // th cycle 40 timed out after mux 0–2 → taxels 12–23 from cycle 39
    let d = find("th", 40);
    assert_eq!(d.carried, (12..24).collect::<Vec<u32>>());
    assert_eq!(d.frame.values[11], value(2, 40, 11) as f64);
    assert_eq!(d.frame.values[23], value(2, 39, 23) as f64);
    let st = dec.decoder().stats();
    assert_eq!((st.incomplete.count, st.sets_carried, st.sets_dropped), (3, 3, 0));
    assert_eq!(st.carried.count, 1 + 4 + 12);
    assert!(decoded.iter().filter(|d| d.carried.is_empty()).count() == truth.complete.len());
}

#[test]
fn a_corrupt_line_is_an_error_naming_file_and_line() {
    let (text, _) = recording();
    let mut lines: Vec<&str> = text.lines().collect();
    lines[99] = "(1700000000.5) can0 10#00";
    let bad = lines.join("\n");
    let reader = CandumpReader::new("three-finger.log", bad.as_bytes());
    let mut src = CandumpSource::new(reader, CanDecoder::new(codec(IncompletePolicy::Drop)));
    let err = src.find_map(|r| r.err()).unwrap().to_string();
    assert!(err.starts_with("three-finger.log:100: identifier \"10\" has 2 digits"), "{err}");
    assert!(src.next().is_none());
}

/// The frames completed before a corrupt line are all yielded before its error (the decoder
/// is not flushed: the log did not end), the error comes once, then nothing; the reader's
/// counts stay readable.
#[test]
fn frames_before_a_corrupt_line_are_kept_and_the_error_comes_once() {
    let (text, _) = recording();
    let mut lines: Vec<&str> = text.lines().collect();
    lines[99] = "(1700000000.5) can0 10#00";
    let bad = lines.join("\n");
    let before: Vec<CanFrame> =
        CandumpReader::new("x.log", lines[..99].join("\n").as_bytes()).collect::<Result<_, _>>().unwrap();
    let n_before = before.len() as u64;
    let mut dec = CanDecoder::new(codec(IncompletePolicy::Drop));
    let mut want = Vec::new();
    for f in before {
        gradtac_stream::Stage::push(&mut dec, f, &mut want).unwrap();
    }
    assert!(want.len() > 10, "{}", want.len());
    let reader = CandumpReader::new("three-finger.log", bad.as_bytes());
    let mut src = CandumpSource::new(reader, CanDecoder::new(codec(IncompletePolicy::Drop)));
    let got: Vec<TaxelFrame> = src.by_ref().map_while(Result::ok).collect();
    assert_eq!(got, want);
    assert!(src.next().is_none() && src.next().is_none());
    assert_eq!((src.reader_stats().lines, src.reader_stats().frames), (100, n_before));
    assert_eq!(src.stats(), dec.stats());
}

#[tokio::test]
async fn replay_from_a_file_matches_the_iterator_fast_and_original_timing() {
    let (text, _) = recording();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rec.log");
    std::fs::write(&path, &text).unwrap();
    let mut p = PresetConfig::new(PresetKind::BiotacMux, &FINGERS);
    p.timeout_ms = 15.0;
    let mut cfg = CandumpConfig::new(&path, CodecConfig::preset(p));
    let offline: Vec<TaxelFrame> = CandumpSource::open(&cfg).unwrap().collect::<Result<_, _>>().unwrap();
    assert_eq!(offline.len(), 143);
    let fast = gradtac_io::can::candump::replay(&cfg).unwrap();
    let stats = fast.stats_handle();
    let live: Vec<TaxelFrame> = fast.map(|r| r.unwrap()).collect().await;
    assert_eq!(live, offline);
    assert_eq!(stats.snapshot().incomplete.count, 3);

    // original timing at 8× speed: the 0.5 s recording takes at least 0.5/8 s
    cfg.timing = Timing::Original;
    cfg.speed = 8.0;
    let start = std::time::Instant::now();
    let paced: Vec<TaxelFrame> = gradtac_io::can::candump::replay(&cfg).unwrap().map(|r| r.unwrap()).collect().await;
    let span = (offline.last().unwrap().time - offline[0].time) as f64 * 1e-9;
    assert!(start.elapsed().as_secs_f64() >= span / 8.0 * 0.99, "{:?} for {span} s", start.elapsed());
    assert_eq!(paced, offline);
    cfg.speed = 0.0;
    assert!(gradtac_io::can::candump::replay(&cfg).unwrap_err().to_string().contains("speed"));
}

#[test]
fn replay_outside_a_runtime_is_an_error_not_a_panic() {
    let cfg = CandumpConfig::new("nope.log", CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &["ff"])));
    assert!(gradtac_io::can::candump::replay(&cfg).unwrap_err().to_string().contains("tokio runtime"));
}

#[test]
fn config_from_toml() {
    let cfg: CandumpConfig = toml::from_str(
        r#"
        candump = "rec.log"
        interface = "can0"
        timing = "original"
        speed = 2.0
        [codec.preset]
        kind = "biotac-mux"
        sensors = ["ff", "mf", "th"]
        timeout_ms = 15.0
        "#,
    )
    .unwrap();
    assert_eq!(cfg.timing, Timing::Original);
    assert_eq!(cfg.interface.as_deref(), Some("can0"));
    let e = CandumpSource::open(&cfg).unwrap_err().to_string();
    assert!(e.starts_with("rec.log: "), "{e}");
}

/// A reader that returns the bytes in the given chunk sizes (cycling).
struct Chunked {
    data: Vec<u8>,
    pos: usize,
    sizes: Vec<usize>,
    i: usize,
}

impl Read for Chunked {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.sizes[self.i % self.sizes.len()].min(buf.len()).min(self.data.len() - self.pos);
        self.i += 1;
        buf[..n].copy_from_slice(&self.data[self.pos..self.pos + n]);
        self.pos += n;
        Ok(n)
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Bytes arriving in any chunking (and any buffer size) decode to the same frames and
    /// counts as the whole text at once.
    #[test]
    fn byte_chunking_does_not_change_the_result(
        sizes in proptest::collection::vec(1usize..200, 1..8),
        cap in 1usize..300,
    ) {
        let (text, _) = recording();
        let (want, want_stats) = decode_text(&text, IncompletePolicy::Carry);
        let r = Chunked { data: text.into_bytes(), pos: 0, sizes, i: 0 };
        let reader = CandumpReader::new("x.log", BufReader::with_capacity(cap, r));
        let mut src = CandumpSource::new(reader, CanDecoder::new(codec(IncompletePolicy::Carry)));
        let got: Vec<TaxelFrame> = src.by_ref().collect::<Result<_, _>>().unwrap();
        prop_assert_eq!(got, want);
        prop_assert_eq!(src.stats(), want_stats);
    }

    /// Frames sent through the in-memory transport in any batching (the consumer running
    /// between batches) decode to the same frames as the synchronous decoder.
    #[test]
    fn transport_batching_does_not_change_the_result(
        batches in proptest::collection::vec(1usize..64, 1..10),
        cap in 1usize..32,
    ) {
        let (text, _) = recording();
        let frames: Vec<CanFrame> =
            CandumpReader::new("x.log", text.as_bytes()).collect::<Result<_, _>>().unwrap();
        let want = CanDecoder::new(codec(IncompletePolicy::Drop)).run_all(frames.clone()).unwrap();
        let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
        let got: Vec<TaxelFrame> = rt.block_on(async move {
            let (tx, rx) = frame_channel(cap);
            let stream = CanStream::new(rx, CanDecoder::new(codec(IncompletePolicy::Drop)));
            let producer = tokio::spawn(async move {
                let mut it = frames.into_iter();
                let mut b = 0;
                loop {
                    let n = batches[b % batches.len()];
                    b += 1;
                    let batch: Vec<CanFrame> = it.by_ref().take(n).collect();
                    if batch.is_empty() {
                        break;
                    }
                    for f in batch {
                        tx.send(f).await.unwrap();
                    }
                    tokio::task::yield_now().await;
                }
            });
            let got = stream.map(|r| r.unwrap()).collect::<Vec<_>>().await;
            producer.await.unwrap();
            got
        });
        prop_assert_eq!(got, want);
    }
}

/// A real BioTacSP-DoS recording (when the shared data is present), sent through the
/// `biotac-mux` wire format as a candump log at 100 Hz and decoded back: every electrode value
/// must come back exactly, every frame complete, no fault.
#[test]
fn real_biotacsp_recording_survives_the_wire_format_when_present() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/biotacsp-dos/aw/bottle0.csv");
    if !path.exists() {
        eprintln!("skipped: {} is absent", path.display());
        return;
    }
    let text = std::fs::read_to_string(&path).unwrap();
    let rows: Vec<Vec<u16>> = text
        .lines()
        .skip(1)
        .filter(|l| !l.is_empty())
        .map(|l| l.split(',').map(|c| c.trim().parse().unwrap()).collect())
        .collect();
    let mut log = String::new();
    for (k, r) in rows.iter().enumerate() {
        assert_eq!(r.len(), 24);
        for mux in 0..6u8 {
            let m = mux as usize;
            let mut data = vec![mux];
            data.extend(pack12([r[4 * m], r[4 * m + 1], r[4 * m + 2], r[4 * m + 3]]));
            data.push(0);
            log.push_str(&line(T0_NS + k as i64 * CYCLE_NS + i64::from(mux) * 100_000, "100", &data));
            log.push('\n');
        }
    }
    let reader = CandumpReader::new("bottle0.log", log.as_bytes());
    let codec = CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &["ff"]))).unwrap();
    let mut src = CandumpSource::new(reader, CanDecoder::new(codec));
    let frames: Vec<TaxelFrame> = src.by_ref().collect::<Result<_, _>>().unwrap();
    assert_eq!(frames.len(), rows.len());
    for (f, r) in frames.iter().zip(&rows) {
        assert_eq!(f.values, r.iter().map(|&v| f64::from(v)).collect::<Vec<_>>());
    }
    let st = src.stats();
    assert_eq!((st.sets_complete, st.total_faults()), (rows.len() as u64, 0));
}
