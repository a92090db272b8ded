//! Inputs that once crashed `gradtac plot` (found by the issue-12 audit or by the
//! `plot_parquet` fuzz target, see `docs/fuzzing.md`), each pinned to a clean error.
//! Crashing files live in `tests/fuzz_regressions/`.

use gradtac::plot::plot_parquet;
use std::path::{Path, PathBuf};

fn crash(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_regressions").join(name)
}

/// Replay a fuzz corpus of the `plot_parquet` target on stable (`GRADTAC_REPLAY_PLOT=<dir>
/// cargo test --test fuzz_regressions -- --ignored --nocapture`): prints where dependency
/// panics were contained (for upstream reports) and fails if a panic escaped.
#[test]
#[ignore = "needs a corpus directory in GRADTAC_REPLAY_PLOT"]
fn replay_plot_corpus() {
    use std::collections::BTreeMap;
    use std::sync::Mutex;
    let Some(dir) = std::env::var_os("GRADTAC_REPLAY_PLOT") else { return };
    static SEEN: Mutex<BTreeMap<String, (usize, String, String)>> = Mutex::new(BTreeMap::new());
    static FILE: Mutex<String> = Mutex::new(String::new());
    // gradtac's quiet hook (installed once, by the first `contain`) would hide contained
    // panics from this one: install it now and replace it
    gradtac_io::contain::install_quiet_hook();
    std::panic::set_hook(Box::new(|info| {
        let at = info.location().map(|l| format!("{}:{}", l.file(), l.line())).unwrap_or_default();
        let at = at.rsplit("/registry/src/").next().unwrap_or(&at).to_string();
        let msg = info.payload_as_str().unwrap_or("").chars().take(100).collect::<String>();
        let file = FILE.lock().unwrap().clone();
        SEEN.lock().unwrap().entry(at).or_insert((0, msg, file)).0 += 1;
    }));
    let out = tempfile::tempdir().unwrap();
    let (mut files, mut errors) = (0, 0);
    for e in std::fs::read_dir(dir).unwrap() {
        let path = e.unwrap().path();
        *FILE.lock().unwrap() = path.display().to_string();
        files += 1;
        match std::panic::catch_unwind(|| plot_parquet(&path, &out.path().join("p.png"))) {
            Ok(Ok(_)) => {}
            Ok(Err(e)) => {
                errors += 1;
                if std::env::var_os("GRADTAC_REPLAY_VERBOSE").is_some() {
                    eprintln!("{}: {e}", path.display());
                }
            }
            Err(_) => panic!("a panic escaped plot_parquet on {}", path.display()),
        }
    }
    let _ = std::panic::take_hook();
    eprintln!("{files} files, {errors} errors; contained panics:");
    for (at, (n, msg, file)) in SEEN.lock().unwrap().iter() {
        eprintln!("  {n:6}  {at}: {msg}\n          first in {file}");
    }
}

/// Fuzz target `plot_parquet`: a footer whose column chunk starts at a negative offset made
/// parquet 60 assert in `ColumnChunkMetaData::byte_range`. The footer's column ranges are
/// now checked first: an error naming the file, row group and column.
#[test]
fn parquet_negative_column_offset_is_a_footer_error() {
    let out = tempfile::tempdir().unwrap();
    let f = crash("parquet_negative_column_offset.parquet");
    let e = plot_parquet(&f, &out.path().join("p.png")).unwrap_err().to_string();
    assert!(e.contains("parquet_negative_column_offset.parquet") && e.contains("row group"), "{e}");
    assert!(e.contains("lies outside the file") && !e.contains("panicked"), "{e}");
}

/// Fuzz target `plot_parquet`: a dictionary-encoded data page without its dictionary page
/// made parquet 60 panic while decoding ("Decoder for dict should have been set"; no
/// metadata tells beforehand), contained at the reader (an upstream bug, see
/// `docs/upstream-arrow-parquet.md`). This file also has a later page header without its
/// required fields, which the page-header check now finds first; the containment itself is
/// tested by `a_contained_dependency_panic_prints_only_the_error`. Either way: an error naming
/// the file and the row group.
#[test]
fn parquet_missing_dictionary_page_is_a_row_group_error() {
    let out = tempfile::tempdir().unwrap();
    let f = crash("parquet_dictionary_page_missing.parquet");
    let e = plot_parquet(&f, &out.path().join("p.png")).unwrap_err().to_string();
    assert!(e.contains("parquet_dictionary_page_missing.parquet") && e.contains("row group"), "{e}");
}

/// Fuzz target `plot_parquet` (crash-1cfc6c5e…): a frame file whose times span more than
/// `i64::MAX` nanoseconds (one near `i64::MIN`, one near `i64::MAX`) overflowed the time
/// axis' `t − t0`. Times are now subtracted in i128: the file plots.
#[test]
fn parquet_time_span_beyond_i64_plots() {
    let out = tempfile::tempdir().unwrap();
    let f = crash("parquet_time_span_overflow.parquet");
    let r = plot_parquet(&f, &out.path().join("p.png"));
    assert!(r.is_ok(), "{r:?}");
}

/// Fuzz target `plot_parquet` (timeout-93ed442c…): a 16 kB file whose page header holds an
/// unknown field with a list of 182 million booleans, which parquet 60's thrift reader skips
/// one no-byte element at a time (`read_page_header_len` → `skip_till_depth`): ~60 s, past
/// libFuzzer's 30 s timeout. The page headers of a row group are now checked first with
/// bounded work (`gradtac_io::parquet_check`): an error naming file, row group, column, page.
#[test]
fn parquet_slow_page_header_is_refused_at_once() {
    let out = tempfile::tempdir().unwrap();
    let f = crash("parquet_slow_page_header.parquet");
    let e = plot_parquet(&f, &out.path().join("p.png")).unwrap_err().to_string();
    assert!(e.contains("parquet_slow_page_header.parquet") && e.contains("row group 3: column 4"), "{e}");
    assert!(e.contains("page 1 at byte 5969") && e.contains("a list of 182047830 elements"), "{e}");
}

/// A contained dependency panic used to print Rust's panic message (and a backtrace under
/// `RUST_BACKTRACE`) to stderr before gradtac's error. The input: a frame file whose
/// dictionary page (row group 0, at byte 61) is relabelled an index page, so parquet 60 skips
/// it and panics decoding the dictionary-encoded data after it ("Decoder for dict should
/// have been set"; the page headers themselves are well formed). stderr holds the one error.
#[test]
fn a_contained_dependency_panic_prints_only_the_error() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = std::fs::read(crash("parquet_time_span_overflow.parquet")).unwrap();
    assert_eq!(&b[61..63], &[0x15, 0x04], "field 1 (type) = 2, a dictionary page");
    b[62] = 0x02; // type = 1, an index page
    let f = dir.path().join("index_page.parquet");
    std::fs::write(&f, &b).unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_gradtac"))
        .args(["plot".as_ref(), f.as_os_str(), "--out".as_ref(), dir.path().join("p.png").as_os_str()])
        .env("RUST_BACKTRACE", "1")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("index_page.parquet: row group 0: malformed data (the parquet reader panicked: Decoder"),
        "{err}"
    );
    assert!(!err.contains("panicked at") && !err.contains("backtrace"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    // the library call (no hook of the CLI involved) is silent too, and gives the same error
    let e = plot_parquet(&f, &dir.path().join("p.png")).unwrap_err().to_string();
    assert!(e.contains("row group 0: malformed data (the parquet reader panicked"), "{e}");
}
