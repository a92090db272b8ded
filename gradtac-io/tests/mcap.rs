//! MCAP (ROS 2) source: files written here with the `mcap` crate's writer, messages
//! CDR-serialised by hand (the encoder below is written from the CDR rules, independently of
//! the library's decoder), read back exactly through `McapFrames`.

use gradtac_io::rosbag::{BagSensor, Finger, McapFrames, StampSource};
use gradtac_stream::{SensorId, TaxelFrame};
use std::collections::BTreeMap;
use std::path::Path;

const SCHEMA: &str = "std_msgs/Header header\nBiotac[5] tactiles\n\
================================================================================\n\
MSG: std_msgs/Header\n# Standard metadata\nbuiltin_interfaces/Time stamp\nstring frame_id\n\
================================================================================\n\
MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n\
================================================================================\n\
MSG: sr_robot_msgs/Biotac\nint16 pac0\nint16 pac1\nint16[] pac\nint16 pdc\nint16 tac\nint16 tdc\nint16[] electrodes\n";

/// A little-endian CDR writer: primitives aligned to their size from the end of the 4-byte
/// encapsulation header.
struct Cdr(Vec<u8>);

impl Cdr {
    fn new() -> Self {
        Cdr(vec![0x00, 0x01, 0x00, 0x00])
    }
    fn align(&mut self, n: usize) {
        while (self.0.len() - 4) % n != 0 {
            self.0.push(0);
        }
    }
    fn i16(&mut self, v: i16) {
        self.align(2);
        self.0.extend(v.to_le_bytes());
    }
    fn u32(&mut self, v: u32) {
        self.align(4);
        self.0.extend(v.to_le_bytes());
    }
    fn string(&mut self, s: &str) {
        self.u32(s.len() as u32 + 1);
        self.0.extend(s.as_bytes());
        self.0.push(0);
    }
    fn i16s(&mut self, v: &[i16]) {
        self.u32(v.len() as u32);
        for &x in v {
            self.i16(x);
        }
    }
}

fn message(sec: i32, nsec: u32, electrodes: &[Vec<i16>; 5]) -> Vec<u8> {
    let mut c = Cdr::new();
    c.u32(sec as u32);
    c.u32(nsec);
    c.string("rh_distal"); // 9 + NUL: the next int16 lands unaligned unless padded
    for (s, e) in electrodes.iter().enumerate() {
        c.i16(1);
        c.i16(-2);
        c.i16s(&[5, -5, 7]);
        c.i16(100 * s as i16);
        c.i16(3);
        c.i16(4);
        c.i16s(e);
    }
    c.0
}

fn electrodes(i: usize) -> [Vec<i16>; 5] {
    std::array::from_fn(|s| {
        if s == 3 {
            vec![]
        } else {
            (0..24).map(|e| (2000 + 11 * i + e * 3 + 97 * s) as i16).collect()
        }
    })
}

fn write_mcap(path: &Path, n: usize, compression: Option<mcap::Compression>) {
    let f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut w = mcap::WriteOptions::new().compression(compression).chunk_size(Some(4096)).create(f).unwrap();
    let schema = w.add_schema("sr_robot_msgs/msg/BiotacAll", "ros2msg", SCHEMA.as_bytes()).unwrap();
    let other = w.add_schema("std_msgs/msg/String", "ros2msg", b"string data\n").unwrap();
    let ch = w.add_channel(schema, "/rh/tactile", "cdr", &BTreeMap::new()).unwrap();
    let chatter = w.add_channel(other, "/chatter", "cdr", &BTreeMap::new()).unwrap();
    for i in 0..n {
        let (sec, nsec) = (1_700_000_000 + (i / 100) as i32, (i % 100) as u32 * 10_000_000 + 3);
        let data = message(sec, nsec, &electrodes(i));
        let log_time = sec as u64 * 1_000_000_000 + u64::from(nsec) + 1234;
        let header =
            mcap::records::MessageHeader { channel_id: ch, sequence: i as u32, log_time, publish_time: log_time };
        w.write_to_known_channel(&header, &data).unwrap();
        if i % 10 == 0 {
            let mut c = Cdr::new();
            c.string("hello");
            let h = mcap::records::MessageHeader { channel_id: chatter, sequence: 0, log_time, publish_time: log_time };
            w.write_to_known_channel(&h, &c.0).unwrap();
        }
    }
    w.finish().unwrap();
}

fn sensor(name: &str, finger: Option<Finger>) -> BagSensor {
    BagSensor { sensor: SensorId::new(name), topic: "/rh/tactile".into(), finger, time: StampSource::Header }
}

fn read(path: &Path, sensors: Vec<BagSensor>) -> gradtac_io::Result<Vec<TaxelFrame>> {
    McapFrames::open(path, sensors)?.collect()
}

#[test]
fn ros2_biotac_all_round_trips_through_mcap() {
    let dir = tempfile::tempdir().unwrap();
    for (name, comp) in [("plain", None), ("zstd", Some(mcap::Compression::Zstd))] {
        let p = dir.path().join(format!("{name}.mcap"));
        write_mcap(&p, 300, comp);
        let frames = read(&p, vec![sensor("ff", Some(Finger::Ff)), sensor("th", Some(Finger::Th))]).unwrap();
        assert_eq!(frames.len(), 600, "{name}");
        for i in 0..300 {
            let t = (1_700_000_000 + (i / 100) as i64) * 1_000_000_000 + (i % 100) as i64 * 10_000_000 + 3;
            let e = electrodes(i);
            for (k, slot) in [(0, 0), (1, 4)] {
                let f = &frames[2 * i + k];
                assert_eq!((f.time.0, f.seq), (t, i as u64), "{name} message {i}");
                assert_eq!(f.values, e[slot].iter().map(|&v| f64::from(v)).collect::<Vec<_>>());
            }
        }
        let mut s = sensor("mf", Some(Finger::Mf));
        s.time = StampSource::Record;
        let f = read(&p, vec![s]).unwrap();
        assert_eq!(f[0].time.0, 1_700_000_000_000_000_000 + 3 + 1234);
    }
}

#[test]
fn mcap_errors_name_file_topic_and_type() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.mcap");
    write_mcap(&p, 20, None);
    let e = read(&p, vec![sensor("ff", None)]).unwrap_err().to_string();
    // the message's record (its chunk's) offset, then topic and type
    assert!(e.contains("a.mcap at byte ") && e.contains(", topic /rh/tactile (sr_robot_msgs/msg/BiotacAll)"), "{e}");
    assert!(e.contains("finger ="), "{e}");
    let mut s = sensor("x", None);
    s.topic = "/chatter".into();
    let e = read(&p, vec![s]).unwrap_err().to_string();
    assert!(e.contains("neither `tactiles`"), "{e}");
    let mut s = sensor("x", Some(Finger::Ff));
    s.topic = "/lh/tactile".into();
    let e = read(&p, vec![s]).unwrap_err().to_string();
    assert!(e.contains("/chatter (std_msgs/msg/String), /rh/tactile (sr_robot_msgs/msg/BiotacAll)"), "{e}");
    // truncations and byte flips: errors naming the file, never panics
    let bytes = std::fs::read(&p).unwrap();
    let q = dir.path().join("bad.mcap");
    for cut in (0..bytes.len()).step_by(97) {
        std::fs::write(&q, &bytes[..cut]).unwrap();
        if let Err(e) = read(&q, vec![sensor("ff", Some(Finger::Ff))]) {
            assert!(e.to_string().contains("bad.mcap"), "{e}");
        }
    }
    for at in (0..bytes.len()).step_by(13) {
        let mut b = bytes.clone();
        b[at] ^= 0x5A;
        std::fs::write(&q, &b).unwrap();
        if let Err(e) = read(&q, vec![sensor("ff", Some(Finger::Ff))]) {
            assert!(e.to_string().contains("bad.mcap"), "{e}");
        }
    }
    std::fs::write(&q, b"#ROSBAG V2.0\n").unwrap();
    let e = read(&q, vec![sensor("ff", Some(Finger::Ff))]).unwrap_err().to_string();
    assert!(e.contains("bad.mcap") && e.contains("MCAP"), "{e}");
}

/// MCAP records written by hand (the writer cannot make malformed or lz4 files).
mod by_hand {
    pub const MAGIC: &[u8] = b"\x89MCAP0\r\n";

    pub fn string(s: &[u8]) -> Vec<u8> {
        let mut v = (s.len() as u32).to_le_bytes().to_vec();
        v.extend(s);
        v
    }

    pub fn record(op: u8, content: &[u8]) -> Vec<u8> {
        let mut v = vec![op];
        v.extend((content.len() as u64).to_le_bytes());
        v.extend(content);
        v
    }

    pub fn header() -> Vec<u8> {
        record(0x01, &[string(b"ros2"), string(b"test")].concat())
    }

    pub fn schema(id: u16, name: &str, text: &str) -> Vec<u8> {
        record(
            0x03,
            &[id.to_le_bytes().to_vec(), string(name.as_bytes()), string(b"ros2msg"), string(text.as_bytes())].concat(),
        )
    }

    pub fn channel(id: u16, schema: u16, topic: &str) -> Vec<u8> {
        record(
            0x04,
            &[
                id.to_le_bytes().to_vec(),
                schema.to_le_bytes().to_vec(),
                string(topic.as_bytes()),
                string(b"cdr"),
                0u32.to_le_bytes().to_vec(),
            ]
            .concat(),
        )
    }

    pub fn message(channel: u16, seq: u32, log_time: u64, data: &[u8]) -> Vec<u8> {
        let mut c = channel.to_le_bytes().to_vec();
        c.extend(seq.to_le_bytes());
        c.extend(log_time.to_le_bytes());
        c.extend(log_time.to_le_bytes());
        c.extend(data);
        record(0x05, &c)
    }

    /// A chunk of `records` (uncompressed bytes) stored as `compressed` under `compression`,
    /// declaring `size` bytes uncompressed.
    pub fn chunk(compression: &str, size: u64, crc: u32, compressed: &[u8]) -> Vec<u8> {
        let mut c = 0u64.to_le_bytes().to_vec();
        c.extend(u64::MAX.to_le_bytes());
        c.extend(size.to_le_bytes());
        c.extend(crc.to_le_bytes());
        c.extend(string(compression.as_bytes()));
        c.extend((compressed.len() as u64).to_le_bytes());
        c.extend(compressed);
        record(0x06, &c)
    }

    pub fn file(records: &[Vec<u8>]) -> Vec<u8> {
        let mut v = MAGIC.to_vec();
        for r in records {
            v.extend(r);
        }
        v.extend(record(0x0F, &0u32.to_le_bytes()));
        v.extend(record(0x02, &[0u8; 20]));
        v.extend(MAGIC);
        v
    }
}

/// Issue 24, case 1: a channel's topic (or the header's profile) claiming 0xC0000000 bytes
/// made the `mcap` crate reserve 3 GB and abort; now a one-line error naming the file, the
/// record's offset and the field, before anything is allocated for it (by construction: the
/// claim is compared with the bytes left in the record first).
#[test]
fn mcap_string_lengths_a_record_claims_are_checked_first() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.mcap");
    write_mcap(&p, 3, None);
    let good = std::fs::read(&p).unwrap();
    let q = dir.path().join("claims.mcap");
    // every channel record's topic length (in the chunk and in the summary)
    let mut topic = good.clone();
    unset_chunk_crcs(&mut topic);
    let pat = [&11u32.to_le_bytes()[..], b"/rh/tactile"].concat();
    let mut n = 0;
    for i in 0..topic.len() - pat.len() {
        if topic[i..i + pat.len()] == pat[..] {
            topic[i..i + 4].copy_from_slice(&0xC000_0000u32.to_le_bytes());
            n += 1;
        }
    }
    assert!(n >= 1);
    std::fs::write(&q, &topic).unwrap();
    let t = std::time::Instant::now();
    let e = read(&q, vec![sensor("ff", Some(Finger::Ff))]).unwrap_err().to_string();
    assert!(t.elapsed().as_secs_f64() < 5.0);
    assert!(e.starts_with(&format!("{}", q.display())) && e.contains(" at byte "), "{e}");
    assert!(e.contains("channel record: the topic claims 3221225472 bytes"), "{e}");
    assert!(!e.contains('\n'), "{e}");
    // the header's profile: the first record, at byte 8
    let mut profile = good.clone();
    unset_chunk_crcs(&mut profile);
    assert_eq!(profile[8], 0x01);
    profile[17..21].copy_from_slice(&0xC000_0000u32.to_le_bytes());
    std::fs::write(&q, &profile).unwrap();
    let e = read(&q, vec![sensor("ff", Some(Finger::Ff))]).unwrap_err().to_string();
    assert!(e.contains("claims.mcap at byte 8: header record: the profile claims 3221225472 bytes"), "{e}");
    // a 712-byte file by hand: schema name, encoding, data and channel fields each claiming 3 GB
    let text = "int32 x\n";
    let fields: [(&str, Vec<u8>); 4] = [
        ("schema record: the name", by_hand::schema(1, "a/msg/B", text)),
        ("schema record: the data", by_hand::schema(1, "a/msg/B", text)),
        ("channel record: the message encoding", by_hand::channel(1, 1, "/t")),
        ("channel record: the metadata", by_hand::channel(1, 1, "/t")),
    ];
    for (k, (what, mut rec)) in fields.into_iter().enumerate() {
        // the offset of the length field inside the record (after opcode and length)
        let at = 9 + match k {
            0 => 2,
            1 => 2 + 4 + 7 + 4 + 7,
            2 => 2 + 2 + 4 + 2,
            _ => 2 + 2 + 4 + 2 + 4 + 3,
        };
        rec[at..at + 4].copy_from_slice(&0xC000_0000u32.to_le_bytes());
        let mut recs = vec![by_hand::header()];
        if k >= 2 {
            recs.push(by_hand::schema(1, "a/msg/B", text));
        }
        recs.push(rec);
        let mut f = by_hand::file(&recs);
        f.resize(f.len().max(712), 0);
        std::fs::write(&q, &f).unwrap();
        let e = read(&q, vec![sensor("ff", None)]).unwrap_err().to_string();
        assert!(e.contains(what) && e.contains("claims 3221225472 bytes"), "{what}: {e}");
    }
}

/// A record's own length beyond the file's end is refused before it is read (the `mcap`
/// crate asked for it whole: up to its 256 MiB limit, from a file of a few hundred bytes).
#[test]
fn mcap_record_lengths_are_checked_against_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let q = dir.path().join("r.mcap");
    let mut rec = by_hand::channel(1, 0, "/t");
    rec[1..9].copy_from_slice(&(200u64 << 20).to_le_bytes());
    std::fs::write(&q, by_hand::file(&[by_hand::header(), rec])).unwrap();
    let e = read(&q, vec![sensor("ff", None)]).unwrap_err().to_string();
    assert!(e.contains("r.mcap at byte 33: a channel record (opcode 0x04) claims 209715200 bytes"), "{e}");
    // a message of an undeclared channel, and a record inside a chunk running past it
    let msg = by_hand::message(7, 0, 1, &[0; 8]);
    std::fs::write(&q, by_hand::file(&[by_hand::header(), msg.clone()])).unwrap();
    let e = read(&q, vec![sensor("ff", None)]).unwrap_err().to_string();
    assert!(e.contains("at byte 33: a message of channel 7"), "{e}");
    let mut inner = msg;
    inner[1..9].copy_from_slice(&1000u64.to_le_bytes());
    let c = by_hand::chunk("", inner.len() as u64, 0, &inner);
    std::fs::write(&q, by_hand::file(&[by_hand::header(), c])).unwrap();
    let e = read(&q, vec![sensor("ff", None)]).unwrap_err().to_string();
    assert!(e.contains("at byte 33: in the chunk, record at byte 0 of its data: a message record"), "{e}");
}

/// MCAP chunks: lz4 (read through lz4_flex), and the decompression budget: a small zstd or
/// lz4 chunk declaring 250 MiB is refused before it is decompressed, naming file and chunk.
#[test]
fn mcap_lz4_chunks_read_and_bombs_are_refused() {
    use std::io::Write;
    let dir = tempfile::tempdir().unwrap();
    let q = dir.path().join("c.mcap");
    let text = "int32[] electrodes\n";
    let mut inner = by_hand::schema(1, "a/msg/E", text);
    inner.extend(by_hand::channel(1, 1, "/rh/tactile"));
    for i in 0..3u32 {
        let mut m = vec![0, 1, 0, 0];
        m.extend(2u32.to_le_bytes());
        m.extend((10 * i as i32).to_le_bytes());
        m.extend((10 * i as i32 + 1).to_le_bytes());
        inner.extend(by_hand::message(1, i, 1000 * u64::from(i), &m));
    }
    let mut e = lz4_flex::frame::FrameEncoder::new(Vec::new());
    e.write_all(&inner).unwrap();
    let lz4 = e.finish().unwrap();
    let crc = crc32(&inner);
    let mut s = sensor("ff", None);
    s.time = StampSource::Record;
    for (name, rec) in [
        ("lz4", by_hand::chunk("lz4", inner.len() as u64, crc, &lz4)),
        ("none", by_hand::chunk("", inner.len() as u64, crc, &inner)),
    ] {
        std::fs::write(&q, by_hand::file(&[by_hand::header(), rec])).unwrap();
        let f = read(&q, vec![s.clone()]).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(
            f.iter().map(|f| f.values.clone()).collect::<Vec<_>>(),
            vec![vec![0.0, 1.0], vec![10.0, 11.0], vec![20.0, 21.0]]
        );
        assert_eq!(f[2].time.0, 2000);
    }
    // a wrong CRC
    std::fs::write(&q, by_hand::file(&[by_hand::header(), by_hand::chunk("lz4", inner.len() as u64, crc ^ 1, &lz4)]))
        .unwrap();
    let e = read(&q, vec![s.clone()]).unwrap_err().to_string();
    assert!(e.contains("c.mcap at byte 33: the chunk's records fail their CRC"), "{e}");
    // bombs: 250 MiB of zeros declared by a few hundred bytes
    let z = zstd::bulk::compress(&vec![0u8; 1 << 20], 19).unwrap();
    for (kind, bytes) in [("zstd", z), ("lz4", lz4.clone())] {
        std::fs::write(&q, by_hand::file(&[by_hand::header(), by_hand::chunk(kind, 250 << 20, 0, &bytes)])).unwrap();
        let t = std::time::Instant::now();
        let e = read(&q, vec![s.clone()]).unwrap_err().to_string();
        assert!(t.elapsed().as_secs_f64() < 1.0);
        assert!(
            e.contains(&format!("c.mcap at byte 33: a {kind} chunk of")) && e.contains("decompression bomb"),
            "{e}"
        );
    }
    // a chunk lying about its size (declares less than it holds): stops one byte past its claim
    std::fs::write(&q, by_hand::file(&[by_hand::header(), by_hand::chunk("lz4", 10, 0, &lz4)])).unwrap();
    let e = read(&q, vec![s]).unwrap_err().to_string();
    assert!(e.contains("declares 10 bytes uncompressed but holds 11"), "{e}");
}

/// Set every top-level chunk's CRC to 0 (not checked), so that a mutated record inside it
/// reaches the record's own checks.
fn unset_chunk_crcs(f: &mut [u8]) {
    let mut at = 8;
    while at + 9 <= f.len() {
        let len = u64::from_le_bytes(f[at + 1..at + 9].try_into().unwrap()) as usize;
        if f[at] == 0x06 {
            f[at + 9 + 24..at + 9 + 28].fill(0);
        }
        if f[at] == 0x0F {
            return;
        }
        at += 9 + len;
    }
}

fn crc32(b: &[u8]) -> u32 {
    // the reflected CRC-32 (IEEE), bit by bit: independent of the reader's crc32fast
    let mut c = !0u32;
    for &x in b {
        c ^= u32::from(x);
        for _ in 0..8 {
            c = if c & 1 != 0 { (c >> 1) ^ 0xEDB8_8320 } else { c >> 1 };
        }
    }
    !c
}
