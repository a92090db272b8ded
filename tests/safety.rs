//! Issue #12, end to end: the `gradtac` binary never writes over what it should not, never
//! panics or blows up on a small input, and says where an error is, once.
//!
//! Every case of the issue is reproduced here as a named test on a tiny scene in a temporary
//! directory.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn gradtac(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gradtac")).args(args).output().unwrap()
}

fn run(scene: &Path) -> Output {
    gradtac(&["run".as_ref(), "-q".as_ref(), scene.as_os_str()])
}

fn explain(scene: &Path) -> Output {
    gradtac(&["explain".as_ref(), scene.as_os_str()])
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A clean failure: exit status 1 (not a panic's 101), no panic message, one error line.
fn failed(o: &Output) -> String {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(1), "stderr: {e}");
    assert!(!e.contains("panicked"), "{e}");
    e
}

/// A 3-taxel CSV with a time column in seconds (100 Hz) and `rows` rows.
fn csv(dir: &Path, name: &str, rows: usize) -> PathBuf {
    let mut text = String::from("t,a,b,c\n");
    for k in 0..rows {
        text += &format!("{},{},{},{}\n", k as f64 * 0.01, 100 + k, 200 + 2 * k, 300 + (k * k) % 17);
    }
    let p = dir.join(name);
    fs::write(&p, text).unwrap();
    p
}

const LAYOUT: &str = "name,x_mm,y_mm\na,0,0\nb,10,0\nc,0,10\n";

/// A scene over `rec.csv` with a 3-taxel layout file, the given outputs and extra tables.
fn scene(dir: &Path, source: &str, rest: &str) -> PathBuf {
    fs::write(dir.join("tri.csv"), LAYOUT).unwrap();
    let text = format!(
        "[[sensor]]\nname = \"ff\"\nlayout = \"tri.csv\"\nsource = {{ {source} }}\n\n{rest}\n",
        source = if source.is_empty() { "csv = \"rec.csv\", columns = \"a,b,c\", time_column = \"t\"" } else { source }
    );
    let p = dir.join("scene.toml");
    fs::write(&p, text).unwrap();
    p
}

fn output(path: &str) -> String {
    format!("[[output]]\ntap = \"source\"\npath = \"{path}\"\n")
}

/// Names of the files in `dir` (sorted).
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into()).collect();
    v.sort();
    v
}

// ---- 1. outputs never replace anything they should not -----------------------------------

/// The data-loss case (and the Done-when): an output `path` equal to the scene's own
/// source exits non-zero before writing anything, and the recording is byte-for-byte unchanged.
#[test]
fn an_output_naming_its_own_source_is_refused_and_the_source_is_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let src = csv(dir.path(), "rec.csv", 50);
    let before = fs::read(&src).unwrap();
    let sc = scene(dir.path(), "", &output("rec.csv"));
    let files = listing(dir.path());
    let e = failed(&run(&sc));
    assert!(e.contains("scene.toml: output #1 (rec.csv)"), "{e}");
    assert!(e.contains("same file as the source of sensor \"ff\""), "{e}");
    assert_eq!(fs::read(&src).unwrap(), before, "the recording was changed");
    assert_eq!(listing(dir.path()), files, "something was written");
    // the same through another spelling of the path, a symbolic link and a hard link
    fs::create_dir(dir.path().join("sub")).unwrap();
    for (path, how) in [("sub/../rec.csv", "dot-dot"), ("./rec.csv", "dot")] {
        let sc = scene(dir.path(), "", &output(path));
        assert!(failed(&run(&sc)).contains("same file as the source"), "{how}");
    }
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&src, dir.path().join("link.parquet")).unwrap();
        fs::hard_link(&src, dir.path().join("hard.parquet")).unwrap();
        for path in ["link.parquet", "hard.parquet"] {
            let sc = scene(dir.path(), "", &output(path));
            assert!(failed(&run(&sc)).contains("same file as the source"), "{path}");
        }
    }
    assert_eq!(fs::read(&src).unwrap(), before);
    // explain refuses it too, before reading anything
    let sc = scene(dir.path(), "", &output("rec.csv"));
    assert!(failed(&explain(&sc)).contains("refusing to replace an input"));
}

/// The scene file, a layout CSV, a dos model and a bus's candump log are inputs too; a bus's
/// stats file is an output.
#[test]
fn outputs_over_the_scene_a_layout_a_model_or_a_bus_log_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    csv(dir.path(), "rec.csv", 30);
    let cases = [
        (output("scene.toml"), "the scene file"),
        (output("tri.csv"), "the layout of sensor \"ff\""),
        (format!("{}[stages.dos]\nmodel = \"m.json\"\n", output("m.json")), "the dos model"),
    ];
    for (rest, what) in cases {
        fs::write(dir.path().join("m.json"), "{}").unwrap();
        let sc = scene(dir.path(), "", &rest);
        let before = fs::read(&sc).unwrap();
        let e = failed(&run(&sc));
        assert!(e.contains(what) && e.contains("refusing to replace an input"), "{what}: {e}");
        assert_eq!(fs::read(&sc).unwrap(), before);
        assert_eq!(fs::read_to_string(dir.path().join("tri.csv")).unwrap(), LAYOUT);
        assert_eq!(fs::read_to_string(dir.path().join("m.json")).unwrap(), "{}");
    }
    let bus = |stats: &str, out: &str| {
        format!(
            "[[bus]]\nname = \"hand\"\ncandump = \"hand.log\"\n{stats}codec = {{ preset = {{ kind = \"biotac-mux\", sensors = [\"ff\"] }} }}\n\n\
             [[sensor]]\nname = \"ff\"\nsource = {{ bus = \"hand\" }}\n\n{}",
            output(out)
        )
    };
    fs::write(dir.path().join("hand.log"), "(1.0) can0 100#00\n").unwrap();
    for (text, what) in [
        (bus("", "hand.log"), "the candump log of bus \"hand\""),
        (bus("stats = \"hand.log\"\n", "o.parquet"), "the stats file of bus \"hand\""),
    ] {
        let sc = dir.path().join("bus.toml");
        fs::write(&sc, text).unwrap();
        let e = failed(&run(&sc));
        assert!(e.contains(what), "{what}: {e}");
    }
    assert_eq!(fs::read_to_string(dir.path().join("hand.log")).unwrap(), "(1.0) can0 100#00\n");
}

/// Two outputs may not write one file: the same path spelled twice, one output on another's
/// temporary `.partial` file, or a file inside another output's archive directory.
#[test]
fn outputs_colliding_with_each_other_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    csv(dir.path(), "rec.csv", 30);
    let archive = "[[output]]\ntap = \"source\"\npath = \"arch\"\narchive = { roll_rows = 10 }\n";
    for (rest, want) in [
        (format!("{}{}", output("o.parquet"), output("./o.parquet")), "both write"),
        (format!("{}{}", output("o.parquet"), output("o.parquet.partial")), "both write"),
        (format!("{archive}{}", output("arch/x.parquet")), "archive directory"),
    ] {
        let sc = scene(dir.path(), "", &rest);
        let e = failed(&run(&sc));
        assert!(e.contains(want), "{e}");
    }
    // an input inside an archive directory
    fs::create_dir(dir.path().join("arch")).unwrap();
    csv(&dir.path().join("arch"), "rec.csv", 30);
    let src = "csv = \"arch/rec.csv\", columns = \"a,b,c\", time_column = \"t\"";
    let e = failed(&run(&scene(dir.path(), src, archive)));
    assert!(e.contains("is a directory holding the source of sensor"), "{e}");
}

/// Anything that exists and is not a regular file is refused: a FIFO, a directory where a
/// file is expected, a symbolic link to a device (`/dev/null`, which a root run used to turn
/// into a regular file), a regular file where an archive directory is expected.
#[cfg(unix)]
#[test]
fn outputs_over_devices_fifos_and_directories_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    csv(dir.path(), "rec.csv", 30);
    fs::create_dir(dir.path().join("adir")).unwrap();
    std::os::unix::fs::symlink("/dev/null", dir.path().join("null.parquet")).unwrap();
    let mut cases = vec![("adir", "a directory"), ("null.parquet", "a character device")];
    let fifo = Command::new("mkfifo").arg(dir.path().join("fifo.parquet")).status().is_ok_and(|s| s.success());
    if fifo {
        cases.push(("fifo.parquet", "a FIFO"));
        // a FIFO where the temporary file would go (opening it would block)
        Command::new("mkfifo").arg(dir.path().join("t.parquet.partial")).status().unwrap();
        cases.push(("t.parquet", "its temporary file"));
    }
    for (path, want) in cases {
        let e = failed(&run(&scene(dir.path(), "", &output(path))));
        assert!(e.contains(want) && e.contains("never replaces anything else"), "{path}: {e}");
    }
    assert!(fs::symlink_metadata(dir.path().join("null.parquet")).unwrap().file_type().is_symlink());
    fs::write(dir.path().join("file"), "x").unwrap();
    let archive = "[[output]]\ntap = \"source\"\npath = \"file\"\narchive = { roll_rows = 10 }\n";
    let e = failed(&run(&scene(dir.path(), "", archive)));
    assert!(e.contains("exists and is a regular file, not a directory"), "{e}");
    assert_eq!(fs::read_to_string(dir.path().join("file")).unwrap(), "x");
    // an ordinary earlier output is still replaced, as before
    let sc = scene(dir.path(), "", &output("o.parquet"));
    fs::write(dir.path().join("o.parquet"), "old").unwrap();
    assert!(run(&sc).status.success());
    assert_ne!(fs::read(dir.path().join("o.parquet")).unwrap(), b"old");
}

/// `gradtac plot --out` and `gradtac calibrate --out` write one file each: not over what they read.
#[test]
fn plot_and_calibrate_do_not_write_over_their_inputs() {
    let dir = tempfile::tempdir().unwrap();
    csv(dir.path(), "rec.csv", 30);
    assert!(run(&scene(dir.path(), "", &output("o.parquet"))).status.success());
    let o = dir.path().join("o.parquet");
    let before = fs::read(&o).unwrap();
    let e = failed(&gradtac(&["plot".as_ref(), o.as_os_str(), "--out".as_ref(), o.as_os_str()]));
    assert!(e.contains("would replace the plotted input"), "{e}");
    assert_eq!(fs::read(&o).unwrap(), before);
    let data = dir.path().join("data");
    fs::create_dir_all(data.join("n")).unwrap();
    let m = data.join("n/rec.csv");
    fs::copy(dir.path().join("rec.csv"), &m).unwrap();
    let e = failed(&gradtac(&["calibrate".as_ref(), data.as_os_str(), "--out".as_ref(), m.as_os_str()]));
    assert!(e.contains("inside the data directory"), "{e}");
    assert_eq!(fs::read(&m).unwrap(), fs::read(dir.path().join("rec.csv")).unwrap());
}

/// `gradtac demo --dir DIR` writes `recording.csv`, `truth.csv` and `scene.toml`: not over a
/// user's files of those names.
#[test]
fn the_demo_does_not_write_over_a_users_files() {
    let dir = tempfile::tempdir().unwrap();
    let mine = csv(dir.path(), "recording.csv", 10);
    let before = fs::read(&mine).unwrap();
    let e = failed(&gradtac(&["demo".as_ref(), "-q".as_ref(), "--dir".as_ref(), dir.path().as_os_str()]));
    assert!(e.contains("recording.csv") && e.contains("not from an earlier demo"), "{e}");
    assert_eq!(fs::read(&mine).unwrap(), before);
    assert_eq!(listing(dir.path()), ["recording.csv"]);
}

// ---- 2, 3. geometry and sizes are bounded -------------------------------------------------

/// A grid extent or `margin_mm` around 1e160 panicked inside spade, even in `explain`.
#[test]
fn a_1e160_grid_margin_or_extent_is_a_clean_error_in_explain_and_run() {
    let dir = tempfile::tempdir().unwrap();
    csv(dir.path(), "rec.csv", 30);
    let tap = "[[output]]\ntap = \"surface\"\npath = \"s.parquet\"\n";
    for grid in ["margin_mm = 1e160", "extent = { x_min = -1e160, x_max = 1e160, y_min = -1e160, y_max = 1e160 }"] {
        let sc = scene(dir.path(), "", &format!("[stages.surface.grid]\n{grid}\n\n{tap}"));
        for o in [explain(&sc), run(&sc)] {
            let e = failed(&o);
            assert!(e.contains("scene.toml") || e.contains("surface") || e.contains("interpolate"), "{e}");
            assert!(e.contains("1000000 mm") || e.contains("beyond"), "{e}");
        }
    }
    // and a layout with such coordinates
    fs::write(dir.path().join("far.csv"), "name,x_mm,y_mm\na,0,0\nb,1e160,0\nc,0,1\n").unwrap();
    let text = fs::read_to_string(scene(dir.path(), "", tap)).unwrap().replace("tri.csv", "far.csv");
    fs::write(dir.path().join("far.toml"), text).unwrap();
    assert!(failed(&explain(&dir.path().join("far.toml"))).contains("beyond"));
}

/// The resource blow-ups from tiny inputs end in a clean error at construction.
#[test]
fn size_like_settings_beyond_their_bounds_are_refused_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    csv(dir.path(), "rec.csv", 3);
    let events = "[[output]]\ntap = \"events\"\npath = \"e.parquet\"\n";
    let cases = [
        (
            format!("[stages.events]\nthreshold = 1e-9\nmax_events_per_step = 4294967295\n{events}"),
            "max_events_per_step",
        ),
        (
            "[stages.surface.grid]\nnx = 4096\n[[output]]\ntap = \"surface\"\npath = \"s.parquet\"\n".into(),
            "1048576 points",
        ),
        ("[stages.window]\nframes = 2000000\n[[output]]\ntap = \"window\"\npath = \"w.parquet\"\n".into(), "frames"),
        (format!("[stages.savgol]\nwindow = 100003\n{events}"), "window"),
        (
            format!("[stages.normalise]\nmin = [-1e308, -1e308, -1e308]\nmax = [1e308, 1e308, 1e308]\n{events}"),
            "overflows f64",
        ),
    ];
    for (rest, want) in cases {
        let sc = scene(dir.path(), "", &rest);
        let o = explain(&sc);
        assert!(!o.status.success(), "{want}: accepted");
        let e = failed(&o);
        assert!(e.contains("scene.toml"), "{e}");
        assert!(e.contains(want), "{want}: {e}");
        assert!(failed(&run(&sc)).contains(want));
    }
    assert!(!dir.path().join("e.parquet.partial").exists());
    // the tiny threshold with the largest cap runs, small and quick
    let sc = scene(dir.path(), "", &format!("[stages.events]\nthreshold = 1e-9\nmax_events_per_step = 4096\n{events}"));
    let o = run(&sc);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(fs::metadata(dir.path().join("e.parquet")).unwrap().len() < 20 << 20);
}

/// A custom CAN codec with `taxels = 4294967295` aborted allocating 4 GB.
#[test]
fn a_can_codec_of_four_billion_taxels_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("hand.log"), "(1.0) can0 100#00\n").unwrap();
    let text = "[[bus]]\nname = \"hand\"\ncandump = \"hand.log\"\n\
        codec = { sensors = [{ name = \"ff\", taxels = 4294967295, messages = [{ id = 0x100, start_bit = 0, bits = 8, count = 1 }] }] }\n\
        [[sensor]]\nname = \"ff\"\nsource = { bus = \"hand\" }\n[[output]]\ntap = \"source\"\npath = \"o.parquet\"\n";
    let sc = dir.path().join("scene.toml");
    fs::write(&sc, text).unwrap();
    let e = failed(&run(&sc));
    assert!(e.contains("scene.toml") && e.contains("bus \"hand\"") && e.contains("at most 65535"), "{e}");
}

/// `csv = "/dev/zero"` grew memory at 200 MB/s; a line over the cap (1 MiB) now stops it, and
/// one 300 MB header line (here 3 MB) is neither held whole nor echoed whole.
#[test]
fn an_endless_or_huge_line_stops_at_the_cap_with_a_short_error() {
    let dir = tempfile::tempdir().unwrap();
    if Path::new("/dev/zero").exists() {
        let sc = scene(dir.path(), "csv = \"/dev/zero\", columns = \"a\", rate_hz = 100.0", &output("o.parquet"));
        let e = failed(&run(&sc));
        assert!(e.contains("/dev/zero:1: line 1 is longer than 1048576 bytes"), "{e}");
        assert!(e.len() < 1000, "{} bytes of error", e.len());
    }
    fs::write(dir.path().join("rec.csv"), format!("t,{}\n0,1\n", "h".repeat(3 << 20))).unwrap();
    let e = failed(&run(&scene(dir.path(), "", &output("o.parquet"))));
    assert!(e.contains("rec.csv:1: line 1 is longer than") && e.len() < 1000, "{e}");
}

/// A scene (or model) file is read whole: `gradtac run /dev/zero` stops at 16 MiB.
#[test]
fn an_endless_scene_file_is_refused() {
    if Path::new("/dev/zero").exists() {
        let e = failed(&gradtac(&["explain".as_ref(), "/dev/zero".as_ref()]));
        assert!(e.contains("/dev/zero: larger than 16777216 bytes"), "{e}");
    }
}

/// `rate_hz = 1e-9` stamped every frame from the 10th on with `i64::MAX` ns and exited 0.
#[test]
fn a_rate_whose_times_overflow_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    csv(dir.path(), "rec.csv", 30);
    let sc = scene(dir.path(), "csv = \"rec.csv\", columns = \"a,b,c\", rate_hz = 1e-9", &output("o.parquet"));
    let e = failed(&run(&sc));
    assert!(e.contains("scene.toml: sensor \"ff\": source:") && e.contains("rate_hz must be finite and within"), "{e}");
    assert!(!dir.path().join("o.parquet").exists());
}

// ---- 4, 5. silent nonsense and errors that say where, once --------------------------------

/// Duplicated timestamps used to multiply events without a word: a warning per sensor, once,
/// with the count — and, stderr being a pipe here, without ANSI colour codes.
#[test]
fn duplicated_timestamps_warn_once_with_the_count_and_no_colour() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("t,a,b,c\n");
    for k in 0..40 {
        let t = if (10..14).contains(&k) { 0.10 } else { k as f64 * 0.01 };
        text += &format!("{t},{},{},{}\n", 100 + k, 200 + k, 300 + k % 7);
    }
    fs::write(dir.path().join("rec.csv"), text).unwrap();
    let o = run(&scene(dir.path(), "", &output("o.parquet")));
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert_eq!(e.matches("share their timestamp").count(), 1, "{e}");
    assert!(e.contains("frames=3") && e.contains("sensor=ff"), "{e}");
    assert!(!e.contains('\u{1b}'), "ANSI escape in {e:?}");
}

/// Planner errors printed an empty path (`gradtac: error: : a slip output needs…`).
#[test]
fn planner_errors_name_the_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    csv(dir.path(), "rec.csv", 30);
    let sc = scene(dir.path(), "", "[[output]]\ntap = \"slip\"\npath = \"slip.parquet\"\n");
    let e = failed(&run(&sc));
    assert!(e.starts_with(&format!("gradtac: error: {}: a slip output needs", sc.display())), "{e}");
    // from the scene's own directory the path is still there
    let o = Command::new(env!("CARGO_BIN_EXE_gradtac"))
        .current_dir(dir.path())
        .args(["run", "scene.toml"])
        .output()
        .unwrap();
    assert!(failed(&o).starts_with("gradtac: error: scene.toml: a slip output needs"));
}

/// `[[bus]]` errors named neither the scene file nor the bus; and an I/O error printed its
/// cause twice.
#[test]
fn bus_errors_name_the_scene_and_the_bus_once() {
    let dir = tempfile::tempdir().unwrap();
    let text = "[[bus]]\nname = \"hand\"\ncandump = \"missing.log\"\n\
        codec = { preset = { kind = \"biotac-mux\", sensors = [\"ff\"] } }\n\
        [[sensor]]\nname = \"ff\"\nsource = { bus = \"hand\" }\n[[output]]\ntap = \"source\"\npath = \"o.parquet\"\n";
    let sc = dir.path().join("scene.toml");
    fs::write(&sc, text).unwrap();
    let e = failed(&run(&sc));
    assert!(e.contains("scene.toml: bus \"hand\": ") && e.contains("missing.log"), "{e}");
    assert_eq!(e.matches("No such file").count(), 1, "said twice: {e}");
    // a malformed line of the log: file, line and bus
    fs::write(dir.path().join("missing.log"), "(1.0) can0 10X#00\n").unwrap();
    let e = failed(&run(&sc));
    assert!(e.contains("missing.log:1: bus \"hand\": "), "{e}");
    fs::write(&sc, text.replace("codec = {", "bogus = 1\ncodec = {")).unwrap();
    let e = failed(&run(&sc));
    assert!(e.contains("scene.toml") && e.contains("bus \"hand\"") && e.contains("bogus"), "{e}");
}

/// A 1 MB bad cell yielded a 1 MB error line; now an excerpt with the full size.
#[test]
fn a_megabyte_bad_cell_gives_a_short_error_naming_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let cell = "x".repeat(1 << 19) + "\u{e9}";
    fs::write(dir.path().join("rec.csv"), format!("t,a,b,c\n0,1,2,3\n0.01,1,{cell},3\n")).unwrap();
    let e = failed(&run(&scene(dir.path(), "", &output("o.parquet"))));
    assert!(e.contains("rec.csv:3 column \"b\"") && e.contains("… (524290 bytes)"), "{e}");
    assert!(e.len() < 1000, "{} bytes", e.len());
}

/// A NaN at input frame 48 was reported as "frame 43" (the Savitzky–Golay delay) when the
/// events stage met it. Sources refuse non-finite cells at their line; the smoothing stage
/// refuses them at their input frame (see `gradtac-stages` savgol tests for the stage alone).
#[test]
fn a_non_finite_value_is_reported_at_its_input_row() {
    let dir = tempfile::tempdir().unwrap();
    let src = csv(dir.path(), "rec.csv", 80);
    let mut lines: Vec<String> = fs::read_to_string(&src).unwrap().lines().map(String::from).collect();
    lines[49] = "0.48,1,NaN,3".into(); // frame 48 is line 50
    fs::write(&src, lines.join("\n") + "\n").unwrap();
    let e = failed(&run(&scene(dir.path(), "", "[[output]]\ntap = \"events\"\npath = \"e.parquet\"\n")));
    assert!(e.contains("rec.csv:50 column \"b\""), "{e}");
    assert!(!e.contains("frame 43"), "{e}");
}
