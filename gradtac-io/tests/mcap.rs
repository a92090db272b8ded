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
    assert!(e.contains("a.mcap topic /rh/tactile (sr_robot_msgs/msg/BiotacAll)") && e.contains("finger ="), "{e}");
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
