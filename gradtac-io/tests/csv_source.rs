//! Integration tests of the CSV frame source.

use futures::StreamExt;
use gradtac_io::{blocking_stream, ColumnSelector, CsvFrames, CsvSourceConfig, Error, TimeUnit};
use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
use proptest::prelude::*;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// A reader that hands out its data in the given chunk sizes (cycled), like a pipe or a
/// socket would.
struct Chunked<'a> {
    data: &'a [u8],
    sizes: Vec<usize>,
    next: usize,
}

impl Read for Chunked<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let want = self.sizes[self.next % self.sizes.len()].max(1);
        self.next += 1;
        let n = want.min(buf.len()).min(self.data.len());
        buf[..n].copy_from_slice(&self.data[..n]);
        self.data = &self.data[n..];
        Ok(n)
    }
}

fn sensor() -> SensorId {
    SensorId::new("ff")
}

/// Frames, or the error's text (errors are compared by what a user sees).
fn collect(frames: impl Iterator<Item = Result<TaxelFrame, Error>>) -> Vec<Result<TaxelFrame, String>> {
    frames.map(|r| r.map_err(|e| e.to_string())).collect()
}

fn write_temp(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::File::create(&path).unwrap().write_all(text.as_bytes()).unwrap();
    path
}

/// A CSV text from generated rows: a time column in seconds, three value columns, with
/// optional quoting, CRLF line ends, blank lines and bad cells. Also returns each row's
/// first physical line.
fn render(rows: &[(u32, [i32; 3], u8)], crlf: bool) -> (String, Vec<u64>) {
    let nl = if crlf { "\r\n" } else { "\n" };
    let mut s = format!("t,e1,junk,e2,e3{nl}");
    let mut t = 0u64;
    let mut lines = Vec::new();
    for (dt, v, style) in rows {
        lines.push(s.matches('\n').count() as u64 + 1);
        t += u64::from(*dt);
        let time = format!("{}.{:06}", t / 1_000_000, t % 1_000_000);
        let cells: Vec<String> = v.iter().map(|x| format!("{}", *x as f64 / 8.0)).collect();
        match style % 8 {
            0 => s.push_str(&format!("\"{time}\",{},\"j,k\",{},{}{nl}", cells[0], cells[1], cells[2])),
            1 => s.push_str(&format!("{time}, {} ,\"multi{nl}line\",{},{}{nl}{nl}", cells[0], cells[1], cells[2])),
            2 if v[0] % 29 == 0 => s.push_str(&format!("{time},{},x,oops,{}{nl}", cells[0], cells[2])),
            _ => s.push_str(&format!("{time},{},x,{},{}{nl}", cells[0], cells[1], cells[2])),
        }
    }
    (s, lines)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Any chunking of the input yields exactly the frames (and the error) of a one-pass read.
    #[test]
    fn any_chunking_gives_the_one_pass_frames(
        rows in prop::collection::vec((0u32..2_000_000, prop::array::uniform3(-100_000i32..100_000), any::<u8>()), 0..120),
        crlf in any::<bool>(),
        sizes in prop::collection::vec(1usize..70, 1..16),
    ) {
        let (text, lines) = render(&rows, crlf);
        let config = CsvSourceConfig::new("gen.csv", "e{1..3}".parse().unwrap()).with_time_column("t", TimeUnit::Seconds);
        let origin = Path::new("gen.csv");
        let once = collect(CsvFrames::from_reader(text.as_bytes(), origin, &config, sensor()).unwrap());
        let chunked = Chunked { data: text.as_bytes(), sizes, next: 0 };
        let pieces = collect(CsvFrames::from_reader(chunked, origin, &config, sensor()).unwrap());
        prop_assert_eq!(&once, &pieces);
        // And the one-pass read itself is right: frame k has the k-th row's values.
        for (k, r) in once.iter().enumerate() {
            match r {
                Ok(f) => {
                    prop_assert_eq!(f.seq, k as u64);
                    let v = rows[k].1;
                    prop_assert_eq!(&f.values, &v.iter().map(|x| *x as f64 / 8.0).collect::<Vec<_>>());
                    let t: u64 = rows[..=k].iter().map(|r| u64::from(r.0)).sum();
                    prop_assert_eq!(f.time, Timestamp::from_nanos(t as i64 * 1000));
                }
                Err(e) => {
                    prop_assert_eq!(k, once.len() - 1, "the error is the last item");
                    let want = format!("gen.csv:{} column \"e2\": \"oops\" is not a number", lines[k]);
                    prop_assert!(e.starts_with(&want), "{} is not {}", e, want);
                }
            }
        }
    }
}

#[test]
fn non_numeric_cell_at_line_57_names_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let header: Vec<String> = (1..=24).map(|i| format!("ff_e{i}")).collect();
    let mut text = header.join(",") + "\n";
    for row in 2..=80 {
        let cells: Vec<String> =
            (1..=24).map(|i| if row == 57 && i == 7 { "12a4".into() } else { format!("{}", 3000 + row + i) }).collect();
        text += &(cells.join(",") + "\n");
    }
    let path = write_temp(dir.path(), "bad.csv", &text);
    let config = CsvSourceConfig::new(&path, "ff_e{1..24}".parse().unwrap()).with_rate_hz(100.0);
    let items: Vec<_> = CsvFrames::open(&config, sensor()).unwrap().collect();
    assert_eq!(items.len(), 56, "55 frames (lines 2..=56), then the error, then the end");
    assert!(items[..55].iter().all(Result::is_ok));
    let err = items[55].as_ref().unwrap_err();
    match err {
        Error::Parse { path: p, line, column, .. } => {
            assert_eq!(p, &path);
            assert_eq!(*line, 57);
            assert_eq!(column.as_deref(), Some("ff_e7"));
        }
        other => panic!("{other:?}"),
    }
    let msg = err.to_string();
    assert!(msg.contains(&path.display().to_string()) && msg.contains(":57") && msg.contains("ff_e7"), "{msg}");
    assert!(msg.contains("12a4"), "{msg}");
}

#[test]
fn pattern_glob_and_list_selection() {
    let text = "id,b2,a1,b1,a2,t\n1,22,11,21,12,0\n";
    let pick = |sel: &str| -> Result<Vec<f64>, String> {
        let config = CsvSourceConfig::new("s.csv", sel.parse().map_err(|e: Error| e.to_string())?).with_rate_hz(1.0);
        let mut f = CsvFrames::from_reader(text.as_bytes(), Path::new("s.csv"), &config, sensor())
            .map_err(|e| e.to_string())?;
        Ok(f.next().unwrap().unwrap().values)
    };
    assert_eq!(pick("a{1..2}").unwrap(), [11.0, 12.0]);
    assert!(pick("{a..b}1").unwrap_err().contains("not a range"));
    assert_eq!(pick("b*").unwrap(), [22.0, 21.0], "globs match in header order");
    assert_eq!(pick("b{1..2}").unwrap(), [21.0, 22.0], "ranges expand in range order");
    assert_eq!(pick("b1, a1 ,id").unwrap(), [21.0, 11.0, 1.0], "lists keep their order");
    assert_eq!(pick("?1").unwrap(), [11.0, 21.0]);
    let e = pick("a{1..4}").unwrap_err();
    assert!(e.starts_with("s.csv:1") && e.contains("\"a3\", \"a4\""), "{e}");
    let e = pick("c*").unwrap_err();
    assert!(e.contains("missing column [\"c*\"]"), "{e}");
    // The columns' names in taxel order, for the sink's taxel names.
    let config = CsvSourceConfig::new("s.csv", "b*".parse().unwrap()).with_rate_hz(1.0);
    let f = CsvFrames::from_reader(text.as_bytes(), Path::new("s.csv"), &config, sensor()).unwrap();
    assert_eq!(f.columns(), ["b2", "b1"]);
    assert_eq!(f.taxel_count(), 2);
    // A list in a scene file is literal names.
    let c: CsvSourceConfig = serde_json::from_value(serde_json::json!({
        "csv": "s.csv", "columns": ["a*", "b1"], "rate_hz": 1.0
    }))
    .unwrap();
    assert_eq!(c.columns, ColumnSelector::Names(vec!["a*".into(), "b1".into()]));
}

#[test]
fn time_columns_in_seconds_and_nanoseconds() {
    let secs = "time,v\n1700000000.000000001,1\n1700000000.0100000005,2\n1700000000.02,3\n";
    let config = CsvSourceConfig::new("t.csv", "v".parse().unwrap()).with_time_column("time", TimeUnit::Seconds);
    let t: Vec<i64> = CsvFrames::from_reader(secs.as_bytes(), Path::new("t.csv"), &config, sensor())
        .unwrap()
        .map(|f| f.unwrap().time.as_nanos())
        .collect();
    // Exact decimal conversion (an f64 would lose the last digits of a Unix time in s).
    assert_eq!(t, [1_700_000_000_000_000_001, 1_700_000_000_010_000_001, 1_700_000_000_020_000_000]);

    let ns = "v,time\n1,-5\n2,-5\n3,1000000000000\n";
    let config = CsvSourceConfig::new("t.csv", "v".parse().unwrap()).with_time_column("time", TimeUnit::Nanoseconds);
    let t: Vec<i64> = CsvFrames::from_reader(ns.as_bytes(), Path::new("t.csv"), &config, sensor())
        .unwrap()
        .map(|f| f.unwrap().time.as_nanos())
        .collect();
    assert_eq!(t, [-5, -5, 1_000_000_000_000]);

    let back = "v,time\n1,10\n2,9\n";
    let r: Vec<_> =
        CsvFrames::from_reader(back.as_bytes(), Path::new("back.csv"), &config, sensor()).unwrap().collect();
    let e = r[1].as_ref().unwrap_err().to_string();
    assert!(e.starts_with("back.csv:3 column \"time\": time goes back"), "{e}");
}

#[test]
fn fixed_rate_starts_at_zero_without_drift() {
    let mut text = String::from("a\n");
    for i in 0..1000 {
        text += &format!("{i}\n");
    }
    let config = CsvSourceConfig::new("r.csv", "a".parse().unwrap()).with_rate_hz(300.0);
    let f: Vec<TaxelFrame> = CsvFrames::from_reader(text.as_bytes(), Path::new("r.csv"), &config, sensor())
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert_eq!(f.len(), 1000);
    assert_eq!(f[0].time, Timestamp::ZERO);
    assert_eq!(f[300].time, Timestamp::from_nanos(1_000_000_000));
    assert_eq!(f[999].time, Timestamp::from_nanos(3_330_000_000));
    assert_eq!(f[1].time, Timestamp::from_nanos(3_333_333));
    assert!(f.iter().all(|x| x.sensor == sensor()));
}

#[test]
fn open_reports_progress_and_missing_files() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_temp(dir.path(), "p.csv", "a,b\n1,2\n3,4\n");
    let config = CsvSourceConfig::new(&path, "a,b".parse().unwrap()).with_rate_hz(10.0);
    let mut frames = CsvFrames::open(&config, sensor()).unwrap();
    let progress = frames.progress();
    assert_eq!(progress.total_bytes(), Some(12));
    assert_eq!(progress.fraction(), Some(4.0 / 12.0));
    assert!(frames.by_ref().all(|f| f.is_ok()));
    assert_eq!(progress.bytes_read(), 12);
    assert_eq!(progress.fraction(), Some(1.0));

    let missing = CsvSourceConfig::new(dir.path().join("nope.csv"), "a".parse().unwrap()).with_rate_hz(1.0);
    let e = CsvFrames::open(&missing, sensor()).unwrap_err();
    assert!(matches!(e, Error::Io { .. }) && e.to_string().contains("nope.csv"), "{e}");
}

#[tokio::test]
async fn runs_as_a_tokio_stream() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("a,b\n");
    for i in 0..500 {
        text += &format!("{i},{}\n", -i);
    }
    text += "1,x\n";
    let path = write_temp(dir.path(), "s.csv", &text);
    let config = CsvSourceConfig::new(&path, "a,b".parse().unwrap()).with_rate_hz(100.0);
    let frames = CsvFrames::open(&config, sensor()).unwrap();
    let items: Vec<_> = blocking_stream(frames, 16).collect().await;
    assert_eq!(items.len(), 501);
    assert_eq!(items[499].as_ref().unwrap().values, [499.0, -499.0]);
    assert!(items[500].as_ref().unwrap_err().to_string().contains(":502 column \"b\""));
}

/// A real BioTacSP-DoS recording, when the shared data is present.
#[test]
fn reads_a_biotacsp_dos_recording_when_present() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/biotacsp-dos/aw/bottle0.csv");
    if !path.exists() {
        eprintln!("skipped: {} is absent", path.display());
        return;
    }
    let config = CsvSourceConfig::new(&path, "ff_e{1..24}".parse().unwrap()).with_rate_hz(100.0);
    let frames: Vec<TaxelFrame> = CsvFrames::open(&config, sensor()).unwrap().map(Result::unwrap).collect();
    // Independent parse of the same file.
    let text = std::fs::read_to_string(&path).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .filter(|l| !l.is_empty())
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    assert_eq!(frames.len(), rows.len());
    for (f, r) in frames.iter().zip(&rows) {
        assert_eq!(&f.values, r);
    }
    assert_eq!(frames.last().unwrap().time, Timestamp::at_rate(rows.len() as u64 - 1, 100.0));
}
