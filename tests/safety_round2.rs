//! Issue #24 (hardening, round two), end to end: lengths a file claims, decompression bombs,
//! unbounded speeds, values that are not numbers, degenerate calibrations, and errors that say
//! where (`scene.toml:LINE` of the key; `explain` refuses exactly what `run` refuses).

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn gradtac(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gradtac")).current_dir(dir).args(args).output().unwrap()
}

/// A clean failure: exit status 1, no panic, one error line (besides log lines, e.g. the
/// warning naming outputs left as `.partial`); that line.
fn failed(o: &Output) -> String {
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "stderr: {e}");
    assert!(!e.contains("panicked"), "{e}");
    let lines: Vec<&str> = e.lines().filter(|l| !l.contains(" WARN ") && !l.is_empty()).collect();
    assert_eq!(lines.len(), 1, "not one error line: {e}");
    lines[0].to_string()
}

const LAYOUT: &str = "name,x_mm,y_mm\na,0,0\nb,10,0\nc,0,10\n";

fn setup(dir: &Path) {
    let mut text = String::from("t,a,b,c\n");
    for k in 0..30 {
        text += &format!("{},{},{},{}\n", k as f64 * 0.01, 100 + k, 200 + 2 * k, 300 + (k * k) % 17);
    }
    fs::write(dir.join("rec.csv"), text).unwrap();
    fs::write(dir.join("tri.csv"), LAYOUT).unwrap();
    fs::write(dir.join("hand.log"), "(1.0) can0 100#000102\n(1.1) can0 100#010203\n").unwrap();
}

const SENSOR: &str =
    "[[sensor]]\nname = \"ff\"\nlayout = \"tri.csv\"\nsource = { csv = \"rec.csv\", columns = \"a,b,c\", time_column = \"t\" }\n";

fn bus(extra: &str, message: &str) -> String {
    format!(
        "[[bus]]\nname = \"hand\"\ncandump = \"hand.log\"\n{extra}\
         codec = {{ sensors = [{{ name = \"ff\", taxels = 3, messages = [{{ id = 0x100, start_bit = 0, bits = 8, count = 3{message} }}] }}] }}\n"
    )
}

/// Bad scenes, each with the text its error must hold and the line it must name (the key's).
fn bad_scenes() -> Vec<(&'static str, String, &'static str, usize)> {
    let out = "[[output]]\ntap = \"source\"\npath = \"o.parquet\"\n";
    let can_sensor = "[[sensor]]\nname = \"ff\"\nlayout = \"tri.csv\"\nsource = { bus = \"hand\" }\n";
    let mut v = vec![
        (
            "row_group_size = 0",
            format!("{SENSOR}[[output]]\ntap = \"source\"\npath = \"o.parquet\"\nrow_group_size = 0\n"),
            "output #1 (o.parquet): row_group_size must be at least 1",
            8,
        ),
        (
            "roll_seconds = -7",
            format!("{SENSOR}[[output]]\ntap = \"source\"\npath = \"arch\"\narchive = {{ roll_seconds = -7 }}\n"),
            "output #1 (arch): archive: roll_seconds must be positive and finite, got -7",
            8,
        ),
        (
            "roll_seconds = 1e-300",
            format!("{SENSOR}[[output]]\ntap = \"source\"\npath = \"arch\"\n[output.archive]\nroll_seconds = 1e-300\n"),
            "roll_seconds = 1e-300 must be between 1 ns and 292 years",
            9,
        ),
        (
            "zstd_level = 99",
            format!("{SENSOR}[[output]]\ntap = \"source\"\npath = \"arch\"\narchive = {{ zstd_level = 99 }}\n"),
            "archive: zstd level 99",
            8,
        ),
        (
            "slip first = second",
            format!(
                "{SENSOR}[stages.slip]\nfirst = \"ff\"\nsecond = \"ff\"\n[[output]]\ntap = \"slip\"\npath = \"s.parquet\"\n"
            ),
            "[stages.slip]: ",
            7,
        ),
        (
            "codec scale = 1e308",
            format!("{}{can_sensor}{out}", bus("", ", scale = 1e308")),
            "raw 255 · scale 1e308 + offset 0 = inf is not finite",
            1,
        ),
    ];
    // a CAN sensor whose codec carries another taxel count than its layout: at the codec
    v.push((
        "CAN taxel count",
        format!("{}[[sensor]]\nname = \"ff\"\nsource = {{ bus = \"hand\" }}\n{out}", bus("", "")),
        "bus \"hand\" (hand.log): sensor \"ff\" carries 3 taxels, but its layout biotac-sp has 24",
        4,
    ));
    for (speed, shown) in [
        ("1e-9", "1e-9"),
        ("5e-324", "5e-324"),
        ("inf", "inf"),
        ("nan", "NaN"),
        ("-1.0", "-1"),
        ("0.0", "0"),
        ("1e7", "10000000"),
    ] {
        v.push((
            "replay speed",
            format!("{}{can_sensor}{out}", bus(&format!("timing = \"original\"\nspeed = {speed}\n"), "")),
            Box::leak(format!("bus \"hand\": speed = {shown} is outside 1e-3 … 1e6").into_boxed_str()),
            5,
        ));
    }
    v
}

/// The Done-when: each bad scene ends in a one-line error naming the scene file and
/// the line of the key, and `explain` refuses it with the very same error as `run`, before
/// anything is read or written; numbers in short form (`1e308`, not 309 digits).
#[test]
fn explain_and_run_refuse_the_same_bad_scenes_at_the_line_of_the_key() {
    let dir = tempfile::tempdir().unwrap();
    setup(dir.path());
    for (name, text, want, line) in bad_scenes() {
        fs::write(dir.path().join("scene.toml"), &text).unwrap();
        let e_explain = failed(&gradtac(dir.path(), &["explain", "scene.toml"]));
        let e_run = failed(&gradtac(dir.path(), &["run", "-q", "scene.toml"]));
        assert_eq!(e_explain, e_run, "{name}: explain and run differ");
        assert!(e_run.starts_with(&format!("gradtac: error: scene.toml:{line}: ")), "{name}: {e_run}");
        assert!(e_run.contains(want), "{name}: want {want:?} in {e_run}");
        assert!(e_run.len() < 400, "{name}: {e_run}");
        assert!(!dir.path().join("o.parquet").exists() && !dir.path().join("arch").exists(), "{name}");
    }
    // the good versions of the same settings are accepted by both
    fs::write(
        dir.path().join("scene.toml"),
        format!("{}[[sensor]]\nname = \"ff\"\nlayout = \"tri.csv\"\nsource = {{ bus = \"hand\" }}\n[[output]]\ntap = \"source\"\npath = \"o.parquet\"\nrow_group_size = 1\n", bus("timing = \"original\"\nspeed = 1000.0\n", ", scale = 1e300")),
    )
    .unwrap();
    let o = gradtac(dir.path(), &["run", "-q", "scene.toml"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// Write `<class>/<name>.csv` recordings of 24 columns for `calibrate`.
fn labelled(dir: &Path, class: &str, name: &str, frames: usize, constant: bool) -> PathBuf {
    fs::create_dir_all(dir.join(class)).unwrap();
    let mut text: String = (1..=24).map(|i| format!("ff_e{i}")).collect::<Vec<_>>().join(",");
    text.push('\n');
    for k in 0..frames {
        let row: Vec<String> =
            (0..24).map(|i| if constant { "2000".into() } else { format!("{}", 2000 + (k * (i + 1)) % 97) }).collect();
        text += &row.join(",");
        text.push('\n');
    }
    let p = dir.join(class).join(format!("{name}.csv"));
    fs::write(&p, text).unwrap();
    p
}

/// `calibrate` on one-frame or constant recordings wrote a degenerate model (every mean 0,
/// variances at the 1e-12 floor) without a word; now it refuses, naming the files.
#[test]
fn calibrate_refuses_one_frame_and_constant_recordings_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    labelled(&data, "n", "good", 300, false);
    let one = labelled(&data, "s", "one", 1, false);
    let flat = labelled(&data, "e", "flat", 300, true);
    let out = dir.path().join("model.json");
    let o = Command::new(env!("CARGO_BIN_EXE_gradtac"))
        .arg("calibrate")
        .arg(&data)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let e = failed(&o);
    assert!(e.contains("2 recordings cannot be calibrated on"), "{e}");
    assert!(
        e.contains(&format!("{} has 1 frame, not more than the longest drift lag (60 frames)", one.display())),
        "{e}"
    );
    assert!(e.contains(&format!("{} does not vary", flat.display())), "{e}");
    assert!(!out.exists());
    // the library refuses the same
    let opts = gradtac::calibrate::CalibrateOptions::default();
    let layout = gradtac::stream::Layout::biotac_sp();
    assert!(gradtac::calibrate::labelled_spans(&data, &layout, &opts).is_err());
    fs::remove_file(&one).unwrap();
    fs::remove_file(&flat).unwrap();
    assert!(gradtac::calibrate::labelled_spans(&data, &layout, &opts).is_ok());
}

/// `plot --from -1` was refused as an argument (only `--from=-1` worked).
#[test]
fn plot_takes_negative_times_as_values() {
    let dir = tempfile::tempdir().unwrap();
    setup(dir.path());
    fs::write(dir.path().join("scene.toml"), format!("{SENSOR}[[output]]\ntap = \"source\"\npath = \"o.parquet\"\n"))
        .unwrap();
    let o = gradtac(dir.path(), &["run", "-q", "scene.toml"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = gradtac(dir.path(), &["plot", "o.parquet", "--from", "-1", "--to", "-0.5", "--out", "p.png"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!e.contains("unexpected argument"), "{e}");
    assert!(o.status.success() || e.contains("o.parquet"), "{e}");
    let o = gradtac(dir.path(), &["plot", "o.parquet", "--from", "-1", "--out", "p.png"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// The MCAP and bag cases through the CLI under a 256 MB address-space cap (`ulimit -v`), each
/// within 5 s: a 712-byte MCAP whose channel topic claims 0xC0000000 bytes (exit 134 under a
/// 2 GiB cap before), and a bag of bz2 chunks each declaring 250 MiB.
#[test]
fn mcap_claims_and_bag_bombs_end_in_one_line_under_a_256_mb_cap() {
    let dir = tempfile::tempdir().unwrap();
    setup(dir.path());
    // MCAP: header, schema, a channel whose topic length claims 3 GB, padded to 712 bytes
    let string = |s: &[u8]| [&(s.len() as u32).to_le_bytes()[..], s].concat();
    let rec = |op: u8, c: &[u8]| [&[op][..], &(c.len() as u64).to_le_bytes(), c].concat();
    let mut f = b"\x89MCAP0\r\n".to_vec();
    f.extend(rec(1, &[string(b"ros2"), string(b"x")].concat()));
    f.extend(rec(
        3,
        &[&1u16.to_le_bytes()[..], &string(b"a/msg/B"), &string(b"ros2msg"), &string(b"int16[] electrodes\n")].concat(),
    ));
    let mut ch =
        [&1u16.to_le_bytes()[..], &1u16.to_le_bytes(), &string(b"/rh/tactile"), &string(b"cdr"), &0u32.to_le_bytes()]
            .concat();
    ch[4..8].copy_from_slice(&0xC000_0000u32.to_le_bytes());
    f.extend(rec(4, &ch));
    f.resize(712, 0);
    fs::write(dir.path().join("x.mcap"), &f).unwrap();
    // bag: a connection no sensor reads and 100 bz2 chunks of a few hundred bytes declaring 250 MiB
    let field =
        |n: &str, v: &[u8]| [&((n.len() + 1 + v.len()) as u32).to_le_bytes()[..], n.as_bytes(), b"=", v].concat();
    let brec = |fields: &[(&str, &[u8])], data: &[u8]| {
        let h: Vec<u8> = fields.iter().flat_map(|(n, v)| field(n, v)).collect();
        [&(h.len() as u32).to_le_bytes()[..], &h, &(data.len() as u32).to_le_bytes(), data].concat()
    };
    let zeros = {
        // a bzip2 stream of 1 MiB of zeros, by the pure-Rust encoder of the bag tests' crate
        // would need a dev-dependency here: a stored valid stream is not needed, the claim is
        // refused before a byte is decompressed
        vec![0x42u8; 269]
    };
    let mut b = b"#ROSBAG V2.0\n".to_vec();
    b.extend(brec(&[("op", &[3]), ("index_pos", &0u64.to_le_bytes())], &[b' '; 16]));
    b.extend(brec(
        &[("op", &[7]), ("conn", &1u32.to_le_bytes()), ("topic", b"/camera")],
        &[field("topic", b"/camera"), field("type", b"x/Y"), field("message_definition", b"uint8[] data\n")].concat(),
    ));
    for _ in 0..100 {
        b.extend(brec(&[("op", &[5]), ("compression", b"bz2"), ("size", &(250u32 << 20).to_le_bytes())], &zeros));
    }
    fs::write(dir.path().join("x.bag"), &b).unwrap();
    for (kind, file, want) in [
        ("mcap", "x.mcap", "x.mcap at byte 86: channel record: the topic claims 3221225472 bytes"),
        ("rosbag", "x.bag", "chunk #1: a bz2 chunk of 269 bytes declares 262144000 bytes uncompressed"),
    ] {
        let scene = format!(
            "[[sensor]]\nname = \"ff\"\nsource = {{ {kind} = \"{file}\", topic = \"/rh/tactile\" }}\n\
             [[output]]\ntap = \"source\"\npath = \"o.parquet\"\n"
        );
        fs::write(dir.path().join("scene.toml"), scene).unwrap();
        let t = std::time::Instant::now();
        let o = Command::new("sh")
            .current_dir(dir.path())
            .env("MALLOC_ARENA_MAX", "2")
            .args(["-c", "ulimit -v 262144 && exec \"$0\" run -q scene.toml", env!("CARGO_BIN_EXE_gradtac")])
            .output()
            .unwrap();
        assert!(t.elapsed().as_secs_f64() < 5.0, "{kind}: {:?}", t.elapsed());
        let e = failed(&o);
        assert!(e.contains(want), "{kind}: {e}");
    }
}

/// An Arrow IPC file in the long layout (sensor, time, values as a variable-length list).
fn long_ipc(path: &Path, time_name: &str, time: arrow_array::ArrayRef, values_per_row: usize) {
    use arrow_array::builder::{Float64Builder, ListBuilder};
    use arrow_array::{ArrayRef, RecordBatch, StringArray};
    use std::sync::Arc;
    let rows = 4;
    let mut values = ListBuilder::new(Float64Builder::new());
    for k in 0..rows {
        for j in 0..values_per_row {
            values.values().append_value((k * 10 + j) as f64);
        }
        values.append(true);
    }
    let batch = RecordBatch::try_from_iter([
        ("sensor", Arc::new(StringArray::from(vec!["ff"; rows])) as ArrayRef),
        (time_name, time),
        ("values", Arc::new(values.finish()) as ArrayRef),
    ])
    .unwrap();
    let mut w = arrow_ipc::writer::FileWriter::try_new(fs::File::create(path).unwrap(), &batch.schema()).unwrap();
    w.write(&batch).unwrap();
    w.finish().unwrap();
}

/// A taxel-count mismatch from an Arrow IPC source (list-valued `values`) was caught by the
/// first stage (`centroid: sensor ff frame 0: expected 24 taxels, got 1`); now at the source,
/// naming its file. The time column is named as the file names it (`time` in frame/2, was
/// called `time_ns`), and a damaged IPC file's error is one line.
#[test]
fn arrow_sources_say_where_on_one_line() {
    use arrow_array::{ArrayRef, Int64Array, StringArray};
    use std::sync::Arc;
    let dir = tempfile::tempdir().unwrap();
    setup(dir.path());
    let times = || Arc::new(Int64Array::from(vec![0, 10_000_000, 20_000_000, 30_000_000])) as ArrayRef;
    long_ipc(&dir.path().join("one.arrow"), "time", times(), 1);
    let scene = |file: &str| {
        format!(
            "[[sensor]]\nname = \"ff\"\nlayout = \"tri.csv\"\nsource = {{ arrow = \"{file}\" }}\n\
             [[output]]\ntap = \"normalise\"\npath = \"o.parquet\"\n"
        )
    };
    fs::write(dir.path().join("scene.toml"), scene("one.arrow")).unwrap();
    let e = failed(&gradtac(dir.path(), &["run", "-q", "scene.toml"]));
    assert!(e.contains("one.arrow: sensor ff frame 0: 1 taxel values, but layout tri has 3 taxels"), "{e}");
    // three values per row: read and normalised
    long_ipc(&dir.path().join("three.arrow"), "time", times(), 3);
    fs::write(dir.path().join("scene.toml"), scene("three.arrow")).unwrap();
    let o = gradtac(dir.path(), &["run", "-q", "scene.toml"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // a time column of the wrong type, named `time` as in the file
    let text = Arc::new(StringArray::from(vec!["a", "b", "c", "d"])) as ArrayRef;
    long_ipc(&dir.path().join("t.arrow"), "time", text, 3);
    fs::write(dir.path().join("scene.toml"), scene("t.arrow")).unwrap();
    let e = failed(&gradtac(dir.path(), &["run", "-q", "scene.toml"]));
    assert!(e.contains("column time: type Utf8") && !e.contains("time_ns"), "{e}");
    // damaged files: every error is one line (`failed` checks), whatever arrow's verifier says
    let good = fs::read(dir.path().join("three.arrow")).unwrap();
    for at in (8..good.len().min(600)).step_by(11) {
        let mut b = good.clone();
        b[at] ^= 0xFF;
        fs::write(dir.path().join("bad.arrow"), &b).unwrap();
        fs::write(dir.path().join("scene.toml"), scene("bad.arrow")).unwrap();
        let o = gradtac(dir.path(), &["run", "-q", "scene.toml"]);
        if !o.status.success() {
            let e = failed(&o);
            assert!(e.contains("bad.arrow"), "byte {at}: {e}");
        }
    }
}
