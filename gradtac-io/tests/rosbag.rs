//! ROS 1 bag source: synthetic bags written here (both Shadow `Biotac` definitions, every
//! chunk compression), malformed bags, and the real Shadow Hand bag when the `shared` directory beside the repository is present.

use gradtac_io::rosbag::{BagReader, BagSensor, Finger, RosbagFrames, StampSource};
use gradtac_stream::{SensorId, TaxelFrame};
use std::io::Write;
use std::path::{Path, PathBuf};

const HEADER_DEF: &str = "================================================================================\n\
MSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id\n";

/// `sr_robot_msgs/Biotac` as in the recorded bag (no `pac`), and the newer one with it.
fn biotac_all_def(with_pac: bool) -> String {
    format!(
        "Header header\nBiotac[5] tactiles\n{HEADER_DEF}================================================================================\n\
MSG: sr_robot_msgs/Biotac\nint16 pac0\nint16 pac1\n{}int16 pdc\n\nint16 tac\nint16 tdc\n\nint16[] electrodes\n",
        if with_pac { "int16[] pac\n" } else { "" }
    )
}

fn field(name: &str, value: &[u8]) -> Vec<u8> {
    let mut f = ((name.len() + 1 + value.len()) as u32).to_le_bytes().to_vec();
    f.extend(name.as_bytes());
    f.push(b'=');
    f.extend(value);
    f
}

fn record(fields: &[(&str, &[u8])], data: &[u8]) -> Vec<u8> {
    let h: Vec<u8> = fields.iter().flat_map(|(n, v)| field(n, v)).collect();
    let mut r = (h.len() as u32).to_le_bytes().to_vec();
    r.extend(h);
    r.extend((data.len() as u32).to_le_bytes());
    r.extend(data);
    r
}

/// One synthetic message: stamp, and per slot (pdc, electrodes).
struct Msg {
    sec: u32,
    nsec: u32,
    tactiles: Vec<(i16, Vec<i16>)>,
}

fn serialise(m: &Msg, seq: u32, with_pac: bool) -> Vec<u8> {
    let mut b = seq.to_le_bytes().to_vec();
    b.extend(m.sec.to_le_bytes());
    b.extend(m.nsec.to_le_bytes());
    b.extend(3u32.to_le_bytes());
    b.extend(b"rh_");
    for (pdc, e) in &m.tactiles {
        b.extend(1i16.to_le_bytes());
        b.extend(2i16.to_le_bytes());
        if with_pac {
            b.extend(22u32.to_le_bytes());
            for k in 0..22i16 {
                b.extend((k - 11).to_le_bytes());
            }
        }
        b.extend(pdc.to_le_bytes());
        b.extend(3i16.to_le_bytes());
        b.extend(4i16.to_le_bytes());
        b.extend((e.len() as u32).to_le_bytes());
        for v in e {
            b.extend(v.to_le_bytes());
        }
    }
    b
}

fn messages(n: usize) -> Vec<Msg> {
    (0..n)
        .map(|i| Msg {
            sec: 1_542_630_000 + (i / 100) as u32,
            nsec: (i % 100) as u32 * 10_000_000 + 7,
            tactiles: (0..5)
                .map(|s| {
                    if s == 3 {
                        (0, vec![])
                    } else {
                        (s as i16 * 100, (0..24).map(|e| (1000 + 37 * i as i32 + 5 * e - 300 * s) as i16).collect())
                    }
                })
                .collect(),
        })
        .collect()
}

/// Write a bag: bag header, chunks of `per_chunk` messages (connection record in the first),
/// then the connection again in the index section, like `rosbag record`.
fn write_bag(path: &Path, msgs: &[Msg], with_pac: bool, compression: &str, per_chunk: usize) {
    let def = biotac_all_def(with_pac);
    let conn_data: Vec<u8> = [
        field("topic", b"/rh/tactile"),
        field("type", b"sr_robot_msgs/BiotacAll"),
        field("md5sum", b"0123"),
        field("message_definition", def.as_bytes()),
    ]
    .concat();
    let conn = record(&[("op", &[7]), ("conn", &0u32.to_le_bytes()), ("topic", b"/rh/tactile")], &conn_data);
    let mut out = b"#ROSBAG V2.0\n".to_vec();
    let hdr = record(&[("op", &[3]), ("index_pos", &0u64.to_le_bytes())], &[b' '; 16]);
    out.extend(hdr);
    for (c, group) in msgs.chunks(per_chunk).enumerate() {
        let mut inner = Vec::new();
        if c == 0 {
            inner.extend(&conn);
        }
        for (k, m) in group.iter().enumerate() {
            let t = [m.sec.to_le_bytes(), m.nsec.to_le_bytes()].concat();
            let seq = (c * per_chunk + k) as u32;
            inner.extend(record(
                &[("op", &[2]), ("conn", &0u32.to_le_bytes()), ("time", &t)],
                &serialise(m, seq, with_pac),
            ));
        }
        let data = match compression {
            "none" => inner.clone(),
            "bz2" => {
                let mut e = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::best());
                e.write_all(&inner).unwrap();
                e.finish().unwrap()
            }
            "lz4" => {
                let mut e = lz4_flex::frame::FrameEncoder::new(Vec::new());
                e.write_all(&inner).unwrap();
                e.finish().unwrap()
            }
            _ => unreachable!(),
        };
        out.extend(record(
            &[("op", &[5]), ("compression", compression.as_bytes()), ("size", &(inner.len() as u32).to_le_bytes())],
            &data,
        ));
        out.extend(record(&[("op", &[4]), ("ver", &1u32.to_le_bytes()), ("conn", &0u32.to_le_bytes())], &[0; 12]));
    }
    out.extend(&conn);
    std::fs::write(path, out).unwrap();
}

fn sensor(name: &str, finger: Option<Finger>) -> BagSensor {
    BagSensor { sensor: SensorId::new(name), topic: "/rh/tactile".into(), finger, time: StampSource::Header }
}

fn read_all(path: &Path, sensors: Vec<BagSensor>) -> gradtac_io::Result<Vec<TaxelFrame>> {
    RosbagFrames::open(path, sensors)?.collect()
}

#[test]
fn both_biotac_definitions_and_every_compression_decode_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let msgs = messages(250);
    for with_pac in [false, true] {
        for comp in ["none", "bz2", "lz4"] {
            let p = dir.path().join(format!("{comp}-{with_pac}.bag"));
            write_bag(&p, &msgs, with_pac, comp, 64);
            let frames = read_all(&p, vec![sensor("ff", Some(Finger::Ff)), sensor("th", Some(Finger::Th))]).unwrap();
            assert_eq!(frames.len(), 500, "{comp} pac={with_pac}");
            for (i, m) in msgs.iter().enumerate() {
                let (ff, th) = (&frames[2 * i], &frames[2 * i + 1]);
                assert_eq!((ff.sensor.as_str(), th.sensor.as_str()), ("ff", "th"));
                let t = i64::from(m.sec) * 1_000_000_000 + i64::from(m.nsec);
                assert_eq!((ff.time.0, ff.seq, th.time.0, th.seq), (t, i as u64, t, i as u64));
                let want = |s: usize| m.tactiles[s].1.iter().map(|&v| f64::from(v)).collect::<Vec<_>>();
                assert_eq!(ff.values, want(0));
                assert_eq!(th.values, want(4));
            }
        }
    }
}

#[test]
fn record_time_and_the_reader_api() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.bag");
    write_bag(&p, &messages(3), false, "lz4", 2);
    let mut r = BagReader::open(&p).unwrap();
    let mut n = 0;
    while let Some(m) = r.next_message().unwrap() {
        assert_eq!(
            (m.connection.topic.as_str(), m.connection.msg_type.as_str()),
            ("/rh/tactile", "sr_robot_msgs/BiotacAll")
        );
        assert_eq!(m.index, n);
        n += 1;
    }
    assert_eq!((n, r.chunks_read()), (3, 2));
    let mut s = sensor("mf", Some(Finger::Mf));
    s.time = StampSource::Record;
    let f = read_all(&p, vec![s]).unwrap();
    assert_eq!(f[2].time.0, 1_542_630_000 * 1_000_000_000 + 20_000_007);
}

#[test]
fn unfit_topics_and_types_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.bag");
    write_bag(&p, &messages(3), true, "none", 10);
    let err = |s: Vec<BagSensor>| read_all(&p, s).unwrap_err().to_string();
    let e = err(vec![sensor("ff", None)]);
    assert!(e.contains("topic /rh/tactile (sr_robot_msgs/BiotacAll)") && e.contains("finger = \"ff\""), "{e}");
    assert!(e.starts_with(&p.display().to_string()), "{e}");
    let mut s = sensor("ff", Some(Finger::Ff));
    s.topic = "/lh/tactile".into();
    let e = err(vec![s]);
    assert!(
        e.contains("topic /lh/tactile is not in the file; its topics: /rh/tactile (sr_robot_msgs/BiotacAll)"),
        "{e}"
    );
    // slot lf is empty in these messages
    let e = err(vec![sensor("lf", Some(Finger::Lf))]);
    assert!(e.contains("message 0") && e.contains("no electrodes"), "{e}");
}

#[test]
fn malformed_bags_are_errors_naming_the_file_never_panics() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.bag");
    write_bag(&good, &messages(5), false, "bz2", 2);
    let bytes = std::fs::read(&good).unwrap();
    let p = dir.path().join("bad.bag");
    // every truncation
    for cut in (0..bytes.len()).step_by(7) {
        std::fs::write(&p, &bytes[..cut]).unwrap();
        match read_all(&p, vec![sensor("ff", Some(Finger::Ff))]) {
            Ok(f) => assert!(f.len() <= 5),
            Err(e) => assert!(e.to_string().contains("bad.bag"), "{e}"),
        }
    }
    // byte flips everywhere (lengths, ops, compressed data)
    for at in (13..bytes.len()).step_by(5) {
        let mut b = bytes.clone();
        b[at] ^= 0xA5;
        std::fs::write(&p, &b).unwrap();
        if let Err(e) = read_all(&p, vec![sensor("ff", Some(Finger::Ff))]) {
            assert!(e.to_string().contains("bad.bag"), "{e}");
        }
    }
    // a huge declared chunk size is refused before allocating
    let mut huge = b"#ROSBAG V2.0\n".to_vec();
    huge.extend(record(&[("op", &[5]), ("compression", b"bz2"), ("size", &u32::MAX.to_le_bytes())], &[0; 4]));
    std::fs::write(&p, &huge).unwrap();
    let e = read_all(&p, vec![sensor("ff", Some(Finger::Ff))]).unwrap_err().to_string();
    assert!(e.contains("at byte 13") && e.contains("limit"), "{e}");
    std::fs::write(&p, b"#ROSBAG V1.2\n").unwrap();
    let e = read_all(&p, vec![sensor("ff", Some(Finger::Ff))]).unwrap_err().to_string();
    assert!(e.contains("1.2") && e.contains("not supported"), "{e}");
}

/// The real bag from a Shadow Hand (`shared/data/rosbag` beside the repository, or under
/// the directory `GRADTAC_SHARED` names), when present.
fn shared_bag() -> Option<PathBuf> {
    let shared = std::env::var_os("GRADTAC_SHARED")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared"));
    let p = shared.join("data/rosbag/shadow-rh-tactile-untouched.bag");
    p.is_file().then_some(p)
}

#[test]
fn the_shadow_bag_reads_all_fingers() {
    let Some(bag) = shared_bag() else {
        eprintln!("skipped: ../shared/data/rosbag is absent");
        return;
    };
    let sensors = Finger::ALL.iter().map(|&f| sensor(f.as_str(), Some(f))).collect::<Vec<_>>();
    // the rf and lf slots hold 24 zeros in this recording
    let frames = read_all(&bag, sensors).unwrap();
    assert_eq!(frames.len(), 5 * 977);
    let dt: Vec<i64> =
        frames.chunks(5).map(|c| c[0].time.0).collect::<Vec<_>>().windows(2).map(|w| w[1] - w[0]).collect();
    assert!(dt.iter().all(|&d| (9_000_000..=11_000_000).contains(&d)), "stamps ~10 ms apart");
    assert!(frames.iter().all(|f| f.values.len() == 24));
}

/// Issue 24, case 2: 100 bz2 chunks of a few hundred bytes, each declaring 250 MiB of zeros,
/// on a connection no sensor reads, took ≈ 65 s and 529 MB for a 38 kB bag. Now the first is
/// refused before it is decompressed (ratio above 1024 : 1 beyond 1 MiB), naming the file,
/// the chunk and its offset: memory bounded by construction (nothing of the declared size is
/// allocated), time in milliseconds.
#[test]
fn bz2_bomb_chunks_are_refused_before_decompressing() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bomb.bag");
    let mut e = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::best());
    e.write_all(&vec![0u8; 1 << 20]).unwrap();
    let zeros = e.finish().unwrap();
    assert!(zeros.len() < 300, "{}", zeros.len());
    let cam = record(
        &[("op", &[7]), ("conn", &1u32.to_le_bytes()), ("topic", b"/camera")],
        &[field("topic", b"/camera"), field("type", b"x/Y"), field("message_definition", b"uint8[] data\n")].concat(),
    );
    let mut out = b"#ROSBAG V2.0\n".to_vec();
    out.extend(record(&[("op", &[3]), ("index_pos", &0u64.to_le_bytes())], &[b' '; 16]));
    out.extend(cam);
    let first = out.len();
    for _ in 0..100 {
        out.extend(record(&[("op", &[5]), ("compression", b"bz2"), ("size", &(250u32 << 20).to_le_bytes())], &zeros));
    }
    std::fs::write(&p, &out).unwrap();
    let t = std::time::Instant::now();
    let e = read_all(&p, vec![sensor("ff", Some(Finger::Ff))]).unwrap_err().to_string();
    assert!(t.elapsed().as_secs_f64() < 5.0, "{:?}", t.elapsed());
    assert!(
        e.starts_with(&format!(
            "{} at byte {first}: chunk #1: a bz2 chunk of {} bytes declares 262144000 bytes",
            p.display(),
            zeros.len()
        )),
        "{e}"
    );
    assert!(e.contains("decompression bomb") && !e.contains('\n'), "{e}");
    // lz4 likewise
    let mut enc = lz4_flex::frame::FrameEncoder::new(Vec::new());
    enc.write_all(&vec![0u8; 1 << 20]).unwrap();
    let lz = enc.finish().unwrap();
    out.truncate(first);
    out.extend(record(&[("op", &[5]), ("compression", b"lz4"), ("size", &(250u32 << 20).to_le_bytes())], &lz));
    std::fs::write(&p, &out).unwrap();
    let e = read_all(&p, vec![sensor("ff", Some(Finger::Ff))]).unwrap_err().to_string();
    assert!(e.contains("chunk #1: a lz4 chunk of") && e.contains("decompression bomb"), "{e}");
    // within the floor (1 MiB) the chunk is decompressed: its honest zeros are no records
    out.truncate(first);
    out.extend(record(&[("op", &[5]), ("compression", b"bz2"), ("size", &(1u32 << 20).to_le_bytes())], &zeros));
    std::fs::write(&p, &out).unwrap();
    let e = read_all(&p, vec![sensor("ff", Some(Finger::Ff))]).unwrap_err().to_string();
    assert!(e.contains("chunk") && !e.contains("decompression bomb"), "{e}");
}

/// With the bag's index (connection and chunk-info records after the data, as `rosbag
/// record` writes), chunks whose connections are all on topics no sensor reads are seeked over
/// unread: the bomb (100 bz2 chunks declaring 250 MiB each on `/camera`) between
/// the chunks of `/rh/tactile` costs nothing, and the frames read are exact.
#[test]
fn chunks_of_unread_topics_are_skipped_through_the_index() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("indexed.bag");
    let def = biotac_all_def(false);
    let conn_data = |topic: &[u8], ty: &[u8], d: &[u8]| {
        [field("topic", topic), field("type", ty), field("md5sum", b"0"), field("message_definition", d)].concat()
    };
    let tactile = record(
        &[("op", &[7]), ("conn", &0u32.to_le_bytes()), ("topic", b"/rh/tactile")],
        &conn_data(b"/rh/tactile", b"sr_robot_msgs/BiotacAll", def.as_bytes()),
    );
    let camera = record(
        &[("op", &[7]), ("conn", &1u32.to_le_bytes()), ("topic", b"/camera")],
        &conn_data(b"/camera", b"x/Y", b"uint8[] data\n"),
    );
    let mut e = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::best());
    e.write_all(&vec![0u8; 1 << 20]).unwrap();
    let zeros = e.finish().unwrap();
    let msgs = messages(4);
    let mut out = b"#ROSBAG V2.0\n".to_vec();
    let header_at = out.len();
    out.extend(record(&[("op", &[3]), ("index_pos", &0u64.to_le_bytes())], &[b' '; 16]));
    let mut infos = Vec::new();
    for (k, m) in msgs.iter().enumerate() {
        // one tactile chunk (its connection inside, as rosbag writes), then 25 bombs
        let mut inner = if k == 0 { tactile.clone() } else { Vec::new() };
        let t = [m.sec.to_le_bytes(), m.nsec.to_le_bytes()].concat();
        inner.extend(record(
            &[("op", &[2]), ("conn", &0u32.to_le_bytes()), ("time", &t)],
            &serialise(m, k as u32, false),
        ));
        infos.push((out.len() as u64, 0u32));
        out.extend(record(
            &[("op", &[5]), ("compression", b"none"), ("size", &(inner.len() as u32).to_le_bytes())],
            &inner,
        ));
        for _ in 0..25 {
            infos.push((out.len() as u64, 1u32));
            out.extend(record(
                &[("op", &[5]), ("compression", b"bz2"), ("size", &(250u32 << 20).to_le_bytes())],
                &zeros,
            ));
        }
    }
    let index_pos = out.len() as u64;
    out.extend(&tactile);
    out.extend(&camera);
    for (pos, conn) in &infos {
        let data = [conn.to_le_bytes(), 1u32.to_le_bytes()].concat();
        out.extend(record(
            &[
                ("op", &[6]),
                ("ver", &1u32.to_le_bytes()),
                ("chunk_pos", &pos.to_le_bytes()),
                ("count", &1u32.to_le_bytes()),
            ],
            &data,
        ));
    }
    // the bag header's index_pos (its field value is the last 8 bytes of its header)
    let hlen = u32::from_le_bytes(out[header_at..header_at + 4].try_into().unwrap()) as usize;
    let v = header_at + 4 + hlen - 8;
    out[v..v + 8].copy_from_slice(&index_pos.to_le_bytes());
    std::fs::write(&p, &out).unwrap();
    let t = std::time::Instant::now();
    let frames = read_all(&p, vec![sensor("ff", Some(Finger::Ff))]).unwrap();
    assert!(t.elapsed().as_secs_f64() < 5.0);
    assert_eq!(frames.len(), 4);
    for (f, m) in frames.iter().zip(&msgs) {
        assert_eq!(f.values, m.tactiles[0].1.iter().map(|&v| f64::from(v)).collect::<Vec<_>>());
    }
    let mut r = BagReader::open(&p).unwrap().with_topics(["/rh/tactile".to_string()]).unwrap();
    while r.next_message().unwrap().is_some() {}
    assert_eq!((r.chunks_read(), r.chunks_skipped()), (104, 100));
    // the same bag without its index: the first bomb is refused (bounded, one line)
    out[v..v + 8].copy_from_slice(&0u64.to_le_bytes());
    std::fs::write(&p, &out).unwrap();
    let e = read_all(&p, vec![sensor("ff", Some(Finger::Ff))]).unwrap_err().to_string();
    assert!(e.contains("chunk #2: a bz2 chunk of") && e.contains("decompression bomb"), "{e}");
}
