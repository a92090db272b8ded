//! `.npy` source: files written byte by byte here (the format of numpy.lib.format), every
//! supported dtype in both byte orders, timestamps, and corrupt files.

use futures::StreamExt;
use gradtac_io::npy::{NpyFrames, NpySourceConfig};
use gradtac_io::{Error, TimeUnit};
use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
use std::path::{Path, PathBuf};

/// A `.npy` file as numpy writes it: magic, version, header length, the dict padded with
/// spaces to a multiple of 64 bytes (ending in '\n'), then the data.
fn npy(version: u8, descr: &str, fortran: bool, shape: &[u64], data: &[u8]) -> Vec<u8> {
    let shape_s = match shape.len() {
        1 => format!("({},)", shape[0]),
        _ => format!("({})", shape.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(", ")),
    };
    let fortran_s = if fortran { "True" } else { "False" };
    let mut dict = format!("{{'descr': '{descr}', 'fortran_order': {fortran_s}, 'shape': {shape_s}, }}");
    let pre = if version == 1 { 10 } else { 12 };
    while (pre + dict.len() + 1) % 64 != 0 {
        dict.push(' ');
    }
    dict.push('\n');
    let mut out = b"\x93NUMPY".to_vec();
    out.extend([version, 0]);
    if version == 1 {
        out.extend((dict.len() as u16).to_le_bytes());
    } else {
        out.extend((dict.len() as u32).to_le_bytes());
    }
    out.extend(dict.as_bytes());
    out.extend(data);
    out
}

/// Values of frame k, taxel j: small integers every dtype holds, some negative.
fn val(k: usize, j: usize) -> i32 {
    (k as i32 * 7 + j as i32 * 3) % 50 - (if j % 2 == 0 { 0 } else { 20 })
}

fn encode(code: &str, big: bool, values: &[f64]) -> Vec<u8> {
    let mut out = Vec::new();
    for &v in values {
        let b: Vec<u8> = match (code, big) {
            ("f8", false) => v.to_le_bytes().to_vec(),
            ("f8", true) => v.to_be_bytes().to_vec(),
            ("f4", false) => (v as f32).to_le_bytes().to_vec(),
            ("f4", true) => (v as f32).to_be_bytes().to_vec(),
            ("i2", false) => (v as i16).to_le_bytes().to_vec(),
            ("i2", true) => (v as i16).to_be_bytes().to_vec(),
            ("u2", false) => (v as u16).to_le_bytes().to_vec(),
            ("u2", true) => (v as u16).to_be_bytes().to_vec(),
            ("i4", false) => (v as i32).to_le_bytes().to_vec(),
            ("i4", true) => (v as i32).to_be_bytes().to_vec(),
            ("i8", false) => (v as i64).to_le_bytes().to_vec(),
            ("i8", true) => (v as i64).to_be_bytes().to_vec(),
            _ => unreachable!(),
        };
        out.extend(b);
    }
    out
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn read_all(cfg: &NpySourceConfig) -> Result<Vec<TaxelFrame>, Error> {
    NpyFrames::open(cfg, SensorId::new("ff"))?.collect()
}

const K: usize = 5;
const T: usize = 24;

#[test]
fn every_dtype_in_both_byte_orders() {
    let dir = tempfile::tempdir().unwrap();
    for code in ["f8", "f4", "i2", "u2", "i4"] {
        for big in [false, true] {
            let mut want = Vec::new();
            for k in 0..K {
                let row: Vec<f64> = (0..T)
                    .map(|j| {
                        let v = val(k, j) as f64;
                        match code {
                            "u2" => v.abs() * 100.0 + 60000.0, // near the top of u16
                            "f8" | "f4" => v + 0.25,
                            "i4" => v * 100_000.0,
                            _ => v,
                        }
                    })
                    .collect();
                want.push(row);
            }
            let flat: Vec<f64> = want.concat();
            let descr = format!("{}{code}", if big { '>' } else { '<' });
            for version in [1, 2] {
                let p = write(
                    dir.path(),
                    &format!("{code}{big}{version}.npy"),
                    &npy(version, &descr, false, &[K as u64, T as u64], &encode(code, big, &flat)),
                );
                let frames = read_all(&NpySourceConfig::with_rate(&p, 100.0)).unwrap();
                assert_eq!(frames.len(), K, "{descr}");
                for (k, f) in frames.iter().enumerate() {
                    assert_eq!(f.values, want[k], "{descr} v{version} frame {k}");
                    assert_eq!(f.seq, k as u64);
                    assert_eq!(f.time, Timestamp(k as i64 * 10_000_000));
                    assert_eq!(f.sensor.as_str(), "ff");
                }
            }
        }
    }
}

#[test]
fn timestamps_in_seconds_or_integer_nanoseconds() {
    let dir = tempfile::tempdir().unwrap();
    let data = npy(1, "<f8", false, &[3, 2], &encode("f8", false, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]));
    let p = write(dir.path(), "d.npy", &data);
    let ts = write(dir.path(), "t.npy", &npy(1, "<f8", false, &[3], &encode("f8", false, &[10.0, 10.25, 10.5])));
    let frames = read_all(&NpySourceConfig::with_timestamps(&p, &ts, TimeUnit::Seconds)).unwrap();
    assert_eq!(
        frames.iter().map(|f| f.time.as_nanos()).collect::<Vec<_>>(),
        [10_000_000_000, 10_250_000_000, 10_500_000_000]
    );
    assert_eq!(frames[2].values, vec![5.0, 6.0]);
    let ns: [i64; 3] = [1_700_000_000_123_456_789, 1_700_000_000_133_456_789, 1_700_000_000_143_456_789];
    let bytes: Vec<u8> = ns.iter().flat_map(|v| v.to_be_bytes()).collect();
    let tn = write(dir.path(), "tn.npy", &npy(1, ">i8", false, &[3], &bytes));
    let frames = read_all(&NpySourceConfig::with_timestamps(&p, &tn, TimeUnit::Nanoseconds)).unwrap();
    // exact integer ns, no float rounding
    assert_eq!(frames.iter().map(|f| f.time.as_nanos()).collect::<Vec<_>>(), ns);
    // wrong count, decreasing, both / neither time options
    let t2 = write(dir.path(), "t2.npy", &npy(1, "<f8", false, &[2], &encode("f8", false, &[1.0, 2.0])));
    let e = read_all(&NpySourceConfig::with_timestamps(&p, &t2, TimeUnit::Seconds)).unwrap_err().to_string();
    assert!(e.contains("holds 2 timestamps") && e.contains("holds 3 frames"), "{e}");
    let td = write(dir.path(), "td.npy", &npy(1, "<f8", false, &[3], &encode("f8", false, &[1.0, 3.0, 2.0])));
    let e = read_all(&NpySourceConfig::with_timestamps(&p, &td, TimeUnit::Seconds)).unwrap_err().to_string();
    assert!(e.contains("td.npy at byte 144: timestamp 2 (2000000000 ns) is earlier"), "{e}");
    let mut both = NpySourceConfig::with_timestamps(&p, &ts, TimeUnit::Seconds);
    both.rate_hz = Some(1.0);
    assert!(read_all(&both).unwrap_err().to_string().contains("not both"));
    both.rate_hz = None;
    both.timestamps = None;
    assert!(read_all(&both).unwrap_err().to_string().contains("timestamps (a .npy file) or a rate_hz"));
    let e = read_all(&NpySourceConfig::with_rate(&p, 0.0)).unwrap_err().to_string();
    assert!(e.contains("rate_hz must be finite and within"), "{e}");
    let tf = write(dir.path(), "tf.npy", &npy(1, "<f4", false, &[3], &[0; 12]));
    let e = read_all(&NpySourceConfig::with_timestamps(&p, &tf, TimeUnit::Seconds)).unwrap_err().to_string();
    assert!(e.contains("tf.npy at byte 128: timestamps of dtype <f4 are not supported"), "{e}");
}

fn open_err(dir: &Path, name: &str, bytes: &[u8]) -> String {
    let p = write(dir, name, bytes);
    match NpyFrames::open(&NpySourceConfig::with_rate(&p, 100.0), SensorId::new("ff")) {
        Ok(mut it) => it.find_map(|r| r.err()).expect("an error").to_string(),
        Err(e) => e.to_string(),
    }
}

#[test]
fn corrupt_files_name_the_file_and_the_byte_offset() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let good = npy(1, "<f8", false, &[2, 3], &encode("f8", false, &[1.0; 6]));
    assert_eq!(read_all(&NpySourceConfig::with_rate(write(d, "good.npy", &good), 1.0)).unwrap().len(), 2);

    let mut bad_magic = good.clone();
    bad_magic[1] = b'X';
    let e = open_err(d, "magic.npy", &bad_magic);
    assert!(e.contains("magic.npy at byte 0: not a NumPy .npy file"), "{e}");

    let mut bad_version = good.clone();
    bad_version[6] = 9;
    assert!(open_err(d, "v.npy", &bad_version).contains("v.npy at byte 6: unsupported .npy format version 9.0"));

    let e = open_err(d, "short.npy", &good[..40]);
    assert!(e.contains("short.npy at byte 10: file ends inside the header"), "{e}");
    let e = open_err(d, "tiny.npy", &good[..5]);
    assert!(e.contains("tiny.npy at byte 0: file ends inside the .npy preamble"), "{e}");

    let e = open_err(d, "trunc.npy", &good[..good.len() - 3]);
    assert!(e.contains("trunc.npy at byte 173: file ends at byte 173 but shape [2, 3] of <f8 needs 176 bytes"), "{e}");
    let mut long = good.clone();
    long.extend([0, 0]);
    let e = open_err(d, "long.npy", &long);
    assert!(e.contains("long.npy at byte 176: 2 bytes after the data"), "{e}");

    let mut garbled = good.clone();
    garbled[44] = b'#'; // inside the dict
    let e = open_err(d, "garbled.npy", &garbled);
    assert!(e.contains("garbled.npy at byte 44: unexpected character '#'"), "{e}");
    let mut nonascii = good.clone();
    nonascii[20] = 0xE9;
    assert!(open_err(d, "latin.npy", &nonascii).contains("latin.npy at byte 20: header is not ASCII"));
    let mut no_newline = good.clone();
    no_newline[127] = b' ';
    assert!(open_err(d, "nl.npy", &no_newline).contains("nl.npy at byte 127: header does not end with a newline"));

    let e = open_err(d, "fortran.npy", &npy(1, "<f8", true, &[2, 3], &encode("f8", false, &[1.0; 6])));
    assert!(e.contains("fortran.npy at byte 0: Fortran-order") && e.contains("C order"), "{e}");
    let e = open_err(d, "oned.npy", &npy(1, "<f8", false, &[6], &encode("f8", false, &[1.0; 6])));
    assert!(e.contains("oned.npy at byte 0: shape [6] is not 2-D; expected (frames, taxels)"), "{e}");
    let e = open_err(d, "threed.npy", &npy(1, "<f8", false, &[1, 2, 3], &encode("f8", false, &[1.0; 6])));
    assert!(e.contains("shape [1, 2, 3] is not 2-D"), "{e}");
    let e = open_err(d, "c16.npy", &npy(1, "<c16", false, &[1, 1], &[0; 16]));
    assert!(e.contains("c16.npy at byte 20: dtype \"<c16\" is not supported"), "{e}");
    let e = open_err(d, "i8.npy", &npy(1, "<i8", false, &[1, 1], &[0; 8]));
    assert!(e.contains("dtype <i8 is not supported for taxel values"), "{e}");

    let mut nan = encode("f8", false, &[1.0; 6]);
    nan[32..40].copy_from_slice(&f64::NAN.to_le_bytes());
    let e = open_err(d, "nan.npy", &npy(1, "<f8", false, &[2, 3], &nan));
    assert!(e.contains("nan.npy at byte 160: frame 1 taxel 1: value NaN is not finite"), "{e}");

    let e = NpyFrames::open(&NpySourceConfig::with_rate(d.join("nope.npy"), 1.0), SensorId::new("x")).unwrap_err();
    assert!(matches!(e, Error::Io { .. }) && e.to_string().contains("nope.npy"), "{e}");
}

#[test]
fn empty_recording_and_metadata() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "e.npy", &npy(3, "<u2", false, &[0, 24], &[]));
    let it = NpyFrames::open(&NpySourceConfig::with_rate(&p, 1.0), SensorId::new("ff")).unwrap();
    assert_eq!((it.frame_count(), it.taxel_count(), it.header().version), (0, 24, (3, 0)));
    assert_eq!(it.count(), 0);
}

#[test]
fn config_from_toml() {
    let cfg: NpySourceConfig =
        toml::from_str("npy = \"ff.npy\"\ntimestamps = \"ff_t.npy\"\ntime_unit = \"ns\"\n").unwrap();
    assert_eq!(cfg.time_unit, TimeUnit::Nanoseconds);
    assert_eq!(cfg.timestamps.as_deref(), Some(Path::new("ff_t.npy")));
    assert!(toml::from_str::<NpySourceConfig>("npy = \"a\"\nrate = 1.0").is_err());
}

#[tokio::test]
async fn streams_through_the_blocking_pool() {
    let dir = tempfile::tempdir().unwrap();
    let flat: Vec<f64> = (0..K * T).map(|i| i as f64).collect();
    let p = write(dir.path(), "s.npy", &npy(1, "<f4", false, &[K as u64, T as u64], &encode("f4", false, &flat)));
    let it = NpyFrames::open(&NpySourceConfig::with_rate(&p, 50.0), SensorId::new("th")).unwrap();
    let got: Vec<TaxelFrame> = gradtac_io::blocking_stream(it, 2).map(|r| r.unwrap()).collect().await;
    assert_eq!(got.len(), K);
    assert_eq!(got[4].values[23], (4 * T + 23) as f64);
    assert_eq!(got[1].time, Timestamp(20_000_000));
}

/// Files written by numpy itself (when `python3` with numpy is installed; skipped otherwise):
/// every dtype, both byte orders, format 1.0 and 2.0, compared value by value.
#[test]
fn reads_files_written_by_numpy_when_available() {
    let dir = tempfile::tempdir().unwrap();
    let script = r#"
import sys, numpy as np
d = sys.argv[1]
base = (np.arange(5 * 24).reshape(5, 24) % 97) - 40
for code in ["f8", "f4", "i2", "u2", "i4"]:
    for order in "<>":
        a = base.astype(order + code) if code != "u2" else (base + 40).astype(order + code) * 600
        np.save(f"{d}/{code}{order == '>'}.npy", a)
np.lib.format.write_array(open(f"{d}/v2.npy", "wb"), base.astype("<f8"), version=(2, 0))
np.save(f"{d}/t.npy", np.array([0.5, 0.75, 1.0, 1.25, 1.5]))
"#;
    let ok = std::process::Command::new("python3").arg("-c").arg(script).arg(dir.path()).status();
    if !matches!(ok, Ok(s) if s.success()) {
        eprintln!("python3 with numpy not available: skipping");
        return;
    }
    let base: Vec<f64> = (0..5 * 24).map(|i| ((i % 97) - 40) as f64).collect();
    for code in ["f8", "f4", "i2", "u2", "i4"] {
        for big in [false, true] {
            let p = dir.path().join(format!("{code}{}.npy", if big { "True" } else { "False" }));
            let frames = read_all(&NpySourceConfig::with_rate(&p, 1.0)).unwrap();
            assert_eq!(frames.len(), 5);
            let got: Vec<f64> = frames.iter().flat_map(|f| f.values.clone()).collect();
            let want: Vec<f64> = base.iter().map(|&v| if code == "u2" { (v + 40.0) * 600.0 } else { v }).collect();
            assert_eq!(got, want, "{code} big={big}");
        }
    }
    let t = dir.path().join("t.npy");
    let frames = read_all(&NpySourceConfig::with_timestamps(dir.path().join("v2.npy"), &t, TimeUnit::Seconds)).unwrap();
    assert_eq!(frames[4].time, Timestamp(1_500_000_000));
    assert_eq!(frames[4].values[23], base[4 * 24 + 23]);
}

/// A real BioTacSP-DoS recording (when the shared data is present) stored as big-endian
/// `u2` and as little-endian `f8` `.npy` files reads back exactly as its CSV values.
#[test]
fn real_biotacsp_recording_as_npy_when_present() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/biotacsp-dos/cw/bottle4.csv");
    if !path.exists() {
        eprintln!("skipped: {} is absent", path.display());
        return;
    }
    let text = std::fs::read_to_string(&path).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .filter(|l| !l.is_empty())
        .map(|l| l.split(',').map(|c| c.trim().parse().unwrap()).collect())
        .collect();
    let flat: Vec<f64> = rows.concat();
    let dir = tempfile::tempdir().unwrap();
    for (descr, code, big) in [(">u2", "u2", true), ("<f8", "f8", false)] {
        let p = write(
            dir.path(),
            &format!("{code}.npy"),
            &npy(1, descr, false, &[rows.len() as u64, 24], &encode(code, big, &flat)),
        );
        let frames = read_all(&NpySourceConfig::with_rate(&p, 100.0)).unwrap();
        assert_eq!(frames.len(), rows.len());
        for (f, r) in frames.iter().zip(&rows) {
            assert_eq!(&f.values, r, "{descr}");
        }
    }
}
