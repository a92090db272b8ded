//! One scene over many recordings: `gradtac batch`, and the per-recording call that the Python
//! package and the Ray recipe bind.
//!
//! A batch runs a scene once per recording. For each recording, every file-backed source of the
//! scene's sensors (a CSV, NumPy, Arrow IPC, ROS bag or MCAP file, a bus's candump log) is
//! replaced by the recording, so the scene must read exactly one distinct file (several sensors
//! may read it: the columns of a two-finger CSV, the fingers of a bag, the sensors of a CAN
//! log); a scene that reads two files, a NumPy source with a separate `timestamps` file or a
//! live CAN interface is refused, naming the scene key.
//!
//! Every output of the scene becomes one table of a hive-partitioned archive under `out`:
//!
//! ```text
//! <out>/<output-name>/recording=<stem>/sensor=<name>/part-000000.parquet
//! <out>/<output-name>/recording=<stem>/part-000000.parquet        (slip: the pair is in the columns)
//! ```
//!
//! `<output-name>` is the file stem of the output's path in the scene (`tracks` for
//! `out/tracks.parquet`), `<stem>` the recording's file stem (`bottle12` for
//! `…/n/bottle12.csv`); both directory values are percent-encoded as hive readers decode them
//! ([`gradtac_io::archive::hive_segment`]). The files hold neither a `recording` nor a `sensor`
//! column: the directories do (DuckDB `read_parquet('<out>/tracks/**/*.parquet',
//! hive_partitioning = true)`, `pyarrow.dataset(..., partitioning="hive")`). Each file is
//! written under a temporary name (`.part-000000.parquet.partial`, or `part-000000.parquet.partial`
//! for slip) and renamed when the recording's run finishes; an output's `archive` settings
//! (rolling by rows, bytes or time; row groups; zstd level) are kept, its partitioning is
//! always by sensor.
//!
//! A batch never adds to or replaces a recording already in the archive: if
//! `<out>/<output-name>/recording=<stem>` exists the recording fails (remove it or choose
//! another `out`). Two recordings with one stem are refused before anything runs.
//! The output-safety checks of `gradtac run` ([`crate::guard`]) apply to every recording.

use crate::run::{run_blocking, RunOptions};
use crate::scene::{BusSource, OutputSpec, Scene, SourceSpec};
use crate::{Error, Plan, Tap};
use gradtac_io::archive::{hive_segment, ArchiveConfig, Partitioning};
use gradtac_io::parquet_sink::PARTIAL_SUFFIX;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// The hive partition key of the recording.
pub const RECORDING_KEY: &str = "recording";
/// The hive partition key of the sensor.
pub const SENSOR_KEY: &str = "sensor";
/// The first file of a partition (the archive's naming: `part-` and a 6-digit index).
pub const FIRST_FILE: &str = "part-000000.parquet";

/// What one recording's run wrote.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RecordingSummary {
    /// The recording, as given.
    pub recording: PathBuf,
    /// Frames read (every sensor).
    pub frames: u64,
    /// The final paths written (every output, every partition).
    pub files: Vec<PathBuf>,
}

/// `<out>/<output_name>/recording=<recording_stem>/sensor=<sensor>`: the directory of one
/// sensor's files of one output for one recording (the values percent-encoded as hive readers
/// decode them).
pub fn batch_layout_dir(out: &Path, output_name: &str, recording_stem: &str, sensor: &str) -> PathBuf {
    recording_dir(out, output_name, recording_stem).join(hive_segment(SENSOR_KEY, sensor))
}

/// `<out>/<output_name>/recording=<recording_stem>`: one output's directory for one recording.
pub fn recording_dir(out: &Path, output_name: &str, recording_stem: &str) -> PathBuf {
    out.join(output_name).join(hive_segment(RECORDING_KEY, recording_stem))
}

/// The recording's partition value: its file stem (`bottle12` for `n/bottle12.csv`).
pub fn recording_stem(recording: &Path) -> Result<String, Error> {
    match recording.file_stem().and_then(|s| s.to_str()) {
        Some(s) if !s.is_empty() => Ok(s.to_string()),
        _ => Err(Error::Scene {
            path: recording.to_path_buf(),
            reason: "a recording needs a file name with a UTF-8 stem (it names the recording= partition)".into(),
        }),
    }
}

/// Each output's table name in the archive: the file stem of its path in the scene (`tracks`
/// for `out/tracks.parquet`). Two outputs with one name are refused.
pub fn output_names(scene: &Scene) -> Result<Vec<String>, Error> {
    let mut names: Vec<String> = Vec::new();
    for (i, o) in scene.outputs.iter().enumerate() {
        let name = match o.path.file_stem().and_then(|s| s.to_str()) {
            Some(s) if !s.is_empty() && s != "." && s != ".." => s.to_string(),
            _ => {
                return Err(Error::Scene {
                    path: scene.origin.clone(),
                    reason: format!(
                        "output #{} path {:?}: its file stem names the batch table; give it a UTF-8 file name",
                        i + 1,
                        o.path
                    ),
                })
            }
        };
        if let Some(j) = names.iter().position(|n| *n == name) {
            return Err(Error::Scene {
                path: scene.origin.clone(),
                reason: format!(
                    "outputs #{} ({}) and #{} ({}) would both be the batch table {name:?}; give them different file names",
                    j + 1,
                    scene.outputs[j].path.display(),
                    i + 1,
                    o.path.display()
                ),
            });
        }
        names.push(name);
    }
    Ok(names)
}

/// Refuse two recordings with one stem (they would share a `recording=` partition), naming both.
pub fn check_stems(recordings: &[PathBuf]) -> Result<(), Error> {
    let mut seen: Vec<(String, &PathBuf)> = Vec::with_capacity(recordings.len());
    for r in recordings {
        let stem = recording_stem(r)?;
        if let Some((_, first)) = seen.iter().find(|(s, _)| *s == stem) {
            return Err(Error::Scene {
                path: r.clone(),
                reason: format!(
                    "{} and {} have the same stem {stem:?} and would share the partition recording={stem}; \
                     rename one or run them in separate batches",
                    first.display(),
                    r.display()
                ),
            });
        }
        seen.push((stem, r));
    }
    Ok(())
}

/// The scene keys that name a file the scene reads (`sensor "ff" source.csv`, `bus "hand"
/// candump`), with the file resolved; a live CAN interface or a separate timestamps file is an
/// error naming its key.
fn file_sources(scene: &Scene) -> Result<Vec<(String, PathBuf)>, Error> {
    let bad = |reason: String| Error::Scene { path: scene.origin.clone(), reason };
    let mut keys = Vec::new();
    for s in &scene.sensors {
        let key = format!("sensor {:?} source.{}", s.name, s.source.kind());
        match &s.source {
            SourceSpec::Bus { bus } => {
                let spec = scene.buses.iter().find(|b| &b.name == bus).expect("validated by Scene");
                match &spec.source {
                    BusSource::Candump(c) => {
                        keys.push((format!("bus {:?} candump", spec.name), scene.resolve(&c.path)));
                    }
                    #[cfg(target_os = "linux")]
                    BusSource::Live(_) => {
                        return Err(bad(format!(
                            "bus {:?} interface: a live CAN interface cannot be replaced by a recording; \
                             batch runs scenes whose sensors read files",
                            spec.name
                        )))
                    }
                }
            }
            SourceSpec::Npy(c) if c.timestamps.is_some() => {
                return Err(bad(format!(
                    "sensor {:?} source.timestamps: a batch replaces the one file a scene reads by each \
                     recording, and this source reads a second (its timestamps); give rate_hz instead",
                    s.name
                )))
            }
            other => keys.push((key, scene.resolve(other.path()))),
        }
    }
    Ok(keys)
}

/// Check that a batch can run `scene`: its sensors read exactly one distinct file (no live
/// source, no second file) and its outputs have distinct table names ([`output_names`]).
pub fn check_batchable(scene: &Scene) -> Result<(), Error> {
    let keys = file_sources(scene)?;
    let Some((first_key, first)) = keys.first() else {
        return Err(Error::Scene {
            path: scene.origin.clone(),
            reason: "the scene reads no file: a batch replaces the file its sensors read by each recording".into(),
        });
    };
    let same = |a: &Path, b: &Path| crate::guard::resolve(a) == crate::guard::resolve(b);
    if let Some((key, other)) = keys.iter().find(|(_, p)| !same(p, first)) {
        return Err(Error::Scene {
            path: scene.origin.clone(),
            reason: format!(
                "{first_key} reads {} but {key} reads {}: a batch replaces the one file a scene reads by each \
                 recording, so every sensor must read the same file",
                first.display(),
                other.display()
            ),
        });
    }
    output_names(scene).map(drop)
}

/// The scene with every file source replaced by `recording` and every output moved into the
/// batch archive under `out` (see the [module docs](self)).
pub fn batch_scene(scene: &Scene, recording: &Path, out: &Path) -> Result<Scene, Error> {
    check_batchable(scene)?;
    let abs = |p: &Path| std::path::absolute(p).map_err(|source| Error::Io { path: p.to_path_buf(), source });
    let (recording_abs, out) = (abs(recording)?, abs(out)?);
    let stem = recording_stem(recording)?;
    let mut s = scene.clone();
    for sensor in &mut s.sensors {
        match &mut sensor.source {
            SourceSpec::Csv(c) => c.path = recording_abs.clone(),
            SourceSpec::Npy(c) => c.path = recording_abs.clone(),
            SourceSpec::Arrow(c) => c.path = recording_abs.clone(),
            SourceSpec::Rosbag(c) | SourceSpec::Mcap(c) => c.path = recording_abs.clone(),
            SourceSpec::Bus { .. } => {}
        }
    }
    for bus in &mut s.buses {
        if let BusSource::Candump(c) = &mut bus.source {
            c.path = recording_abs.clone();
        }
        if let Some(stats) = &bus.stats {
            let table = stats.file_stem().and_then(|t| t.to_str()).unwrap_or("can-stats");
            bus.stats = Some(recording_dir(&out, table, &stem).join(format!("{}.json", bus.name)));
        }
    }
    let names = output_names(scene)?;
    for (o, name) in s.outputs.iter_mut().zip(&names) {
        let dir = recording_dir(&out, name, &stem);
        if dir.exists() {
            return Err(Error::Scene {
                path: dir,
                reason: "already holds this recording's outputs; a batch never adds to or replaces them \
                         (remove the directory or choose another --out)"
                    .into(),
            });
        }
        *o = if o.tap == Tap::Slip.name() {
            // slip events name no sensor (the pair is in their columns): one file per recording
            OutputSpec { path: dir.join(FIRST_FILE), archive: None, ..o.clone() }
        } else {
            let archive = ArchiveConfig {
                partition: Partitioning::Sensor,
                partition_column: false,
                ..o.archive.clone().unwrap_or_default()
            };
            OutputSpec { path: dir, archive: Some(archive), ..o.clone() }
        };
    }
    Ok(s)
}

/// Run `scene` with every file source replaced by `recording`, writing under `out` in the hive
/// layout of the [module docs](self); single-threaded (a batch runs recordings in parallel).
///
/// Fails before any data moves when the scene reads more than one file or a live source, when
/// an output would resolve to an input ([`crate::guard`]), or when the recording is already in
/// the archive. A run that fails leaves its files under their temporary names; so does one
/// that Ctrl-C cuts short (its finished files are renamed back, and the error is
/// [`Error::Interrupted`]), so a final name in the archive always holds a whole recording.
pub fn run_recording(scene: &Scene, recording: &Path, out: &Path) -> Result<RecordingSummary, Error> {
    let s = batch_scene(scene, recording, out)?;
    for bus in &s.buses {
        if let Some(dir) = bus.stats.as_deref().and_then(Path::parent) {
            std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.to_path_buf(), source })?;
        }
    }
    let plan = Plan::new(&s)?;
    let report = run_blocking(&s, &plan, &RunOptions { threads: 1, ..Default::default() })?;
    if report.interrupted {
        // a recording cut short is a failed one: its files go back to temporary names, so
        // the archive's final names only ever hold whole recordings
        for f in report.outputs.iter().flat_map(|(files, _)| files) {
            let (Some(dir), Some(name)) = (f.parent(), f.file_name().and_then(|n| n.to_str())) else { continue };
            let hidden = if name == FIRST_FILE && s.outputs.iter().any(|o| o.path == *f) {
                format!("{name}{PARTIAL_SUFFIX}")
            } else {
                format!(".{name}{PARTIAL_SUFFIX}")
            };
            let to = dir.join(hidden);
            std::fs::rename(f, &to).map_err(|source| Error::Io { path: f.clone(), source })?;
        }
        return Err(Error::Interrupted);
    }
    Ok(RecordingSummary {
        recording: recording.to_path_buf(),
        frames: report.frames.iter().map(|(_, n)| n).sum(),
        files: report.outputs.into_iter().flat_map(|(files, _)| files).collect(),
    })
}

/// Options of [`run_batch`].
#[derive(Clone, Debug, Default)]
pub struct BatchOptions {
    /// Recordings run at once (0: the available cores).
    pub jobs: usize,
    /// Draw a progress bar over the recordings (on stderr; with the `cli` feature).
    pub progress: bool,
}

/// What a batch did.
#[derive(Debug, Default)]
pub struct BatchReport {
    /// The recordings that ran, in the order given.
    pub done: Vec<RecordingSummary>,
    /// The recordings that failed, in the order given, with the reason.
    pub failed: Vec<(PathBuf, Error)>,
    /// Recordings not started (after Ctrl-C).
    pub skipped: usize,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Threads used.
    pub jobs: usize,
}

impl std::fmt::Display for BatchReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (r, e) in &self.failed {
            writeln!(f, "failed: {}: {}", r.display(), gradtac_io::excerpt(&e.to_string(), 2000).replace('\n', " "))?;
        }
        let frames: u64 = self.done.iter().map(|d| d.frames).sum();
        let files: usize = self.done.iter().map(|d| d.files.len()).sum();
        writeln!(
            f,
            "batch: {} recordings ran, {} failed{}; {frames} frames, {files} files in {:.3} s on {} threads",
            self.done.len(),
            self.failed.len(),
            if self.skipped > 0 { format!(", {} not started (interrupted)", self.skipped) } else { String::new() },
            self.seconds,
            self.jobs
        )
    }
}

/// The batch's progress bar: indicatif's with the `cli` feature, nothing without it.
mod progress_bar {
    #[cfg(feature = "cli")]
    pub(super) struct Bar(indicatif::ProgressBar);

    #[cfg(feature = "cli")]
    impl Bar {
        pub(super) fn new(total: u64) -> Bar {
            let bar = indicatif::ProgressBar::new(total);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} recordings {msg}",
                )
                .expect("valid template"),
            );
            Bar(bar)
        }
        pub(super) fn inc(&self, failed: usize) {
            if failed > 0 {
                self.0.set_message(format!("({failed} failed)"));
            }
            self.0.inc(1);
        }
        pub(super) fn finish(&self) {
            self.0.finish_and_clear();
        }
    }

    /// Without the `cli` feature a bar draws nothing.
    #[cfg(not(feature = "cli"))]
    pub(super) struct Bar;

    #[cfg(not(feature = "cli"))]
    impl Bar {
        pub(super) fn new(_total: u64) -> Bar {
            Bar
        }
        pub(super) fn inc(&self, _failed: usize) {}
        pub(super) fn finish(&self) {}
    }
}

/// The number of threads `0` stands for: the available cores.
pub fn available_threads() -> usize {
    std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
}

/// Run `scene` once per recording ([`run_recording`]) on a pool of `opts.jobs` threads. A
/// recording that fails is reported in [`BatchReport::failed`] and does not stop the others.
///
/// Fails up front (nothing runs) when two recordings share a stem, two outputs share a table
/// name, or the scene cannot be batched (see [`batch_scene`], checked on the first recording).
pub fn run_batch(scene: &Scene, recordings: &[PathBuf], out: &Path, opts: &BatchOptions) -> Result<BatchReport, Error> {
    let start = Instant::now();
    check_stems(recordings)?;
    check_batchable(scene)?;
    let jobs = if opts.jobs == 0 { available_threads() } else { opts.jobs }.clamp(1, recordings.len().max(1));
    let next = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let results: Mutex<Vec<Option<Result<RecordingSummary, Error>>>> =
        Mutex::new((0..recordings.len()).map(|_| None).collect());
    let failures = AtomicUsize::new(0);
    let bar = opts.progress.then(|| progress_bar::Bar::new(recordings.len() as u64));
    let (done_tx, done_rx) = tokio::sync::oneshot::channel::<()>();
    std::thread::scope(|scope| {
        // Ctrl-C: no recording starts after it (those running stop as `gradtac run` does)
        let stop = &stop;
        scope.spawn(move || {
            let Ok(rt) = tokio::runtime::Builder::new_current_thread().enable_all().build() else { return };
            rt.block_on(async {
                tokio::select! {
                    r = tokio::signal::ctrl_c() => if r.is_ok() { stop.store(true, Ordering::Relaxed) },
                    _ = done_rx => {}
                }
            });
        });
        let workers: Vec<_> = (0..jobs)
            .map(|_| {
                scope.spawn(|| loop {
                    if stop.load(Ordering::Relaxed) {
                        return;
                    }
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(rec) = recordings.get(i) else { return };
                    let r = run_recording(scene, rec, out);
                    if r.is_err() {
                        failures.fetch_add(1, Ordering::Relaxed);
                    }
                    if matches!(r, Err(Error::Interrupted)) {
                        stop.store(true, Ordering::Relaxed);
                    }
                    if let Some(b) = &bar {
                        b.inc(failures.load(Ordering::Relaxed));
                    }
                    results.lock().expect("no panic holds the lock")[i] = Some(r);
                })
            })
            .collect();
        let joined: Vec<_> = workers.into_iter().map(|w| w.join()).collect();
        // end the Ctrl-C listener before a worker's panic goes on
        let _ = done_tx.send(());
        for j in joined {
            if let Err(panic) = j {
                std::panic::resume_unwind(panic);
            }
        }
    });
    if let Some(b) = &bar {
        b.finish();
    }
    let mut report = BatchReport { jobs, ..Default::default() };
    for (rec, r) in recordings.iter().zip(results.into_inner().expect("no panic holds the lock")) {
        match r {
            Some(Ok(s)) => report.done.push(s),
            Some(Err(e)) => report.failed.push((rec.clone(), e)),
            None => report.skipped += 1,
        }
    }
    report.seconds = start.elapsed().as_secs_f64();
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(text: &str) -> Scene {
        Scene::from_toml(text, "/base", Path::new("/base/scene.toml")).unwrap()
    }

    const BUS: &str = r#"
[[bus]]
name = "hand"
candump = "hand.log"
codec = { preset = { kind = "biotac-mux", sensors = ["ff", "th"] } }
stats = "out/can-stats.json"
[[sensor]]
name = "ff"
source = { bus = "hand" }
[[sensor]]
name = "th"
source = { bus = "hand" }
[[output]]
tap = "source"
path = "out/raw.parquet"
[[output]]
tap = "slip"
path = "out/slip.parquet"
"#;

    #[test]
    fn a_bus_scene_reads_the_recording_and_writes_into_the_partitions() {
        let s = batch_scene(&scene(BUS), Path::new("/data/g 1.log"), Path::new("/arch")).unwrap();
        let BusSource::Candump(c) = &s.buses[0].source else { panic!("a candump bus") };
        assert_eq!(c.path, Path::new("/data/g 1.log"));
        assert_eq!(s.buses[0].stats.as_deref(), Some(Path::new("/arch/can-stats/recording=g%201/hand.json")));
        assert_eq!(s.outputs[0].path, Path::new("/arch/raw/recording=g%201"));
        let a = s.outputs[0].archive.as_ref().unwrap();
        assert_eq!((a.partition, a.partition_column), (Partitioning::Sensor, false));
        assert_eq!(s.outputs[1].path, Path::new("/arch/slip/recording=g%201/part-000000.parquet"));
        assert!(s.outputs[1].archive.is_none());
        assert_eq!(
            batch_layout_dir(Path::new("/arch"), "raw", "g 1", "ff"),
            Path::new("/arch/raw/recording=g%201/sensor=ff")
        );
    }

    #[test]
    fn an_archive_output_keeps_its_rolling_and_is_partitioned_by_sensor() {
        let text = r#"
[[sensor]]
name = "ff"
source = { csv = "a.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }
[[output]]
tap = "track"
path = "out/tracks"
archive = { roll_rows = 100, zstd_level = 5 }
"#;
        let s = batch_scene(&scene(text), Path::new("/d/r.csv"), Path::new("/arch")).unwrap();
        let a = s.outputs[0].archive.as_ref().unwrap();
        assert_eq!((a.roll_rows, a.zstd_level, a.partition), (Some(100), 5, Partitioning::Sensor));
        assert_eq!(s.outputs[0].path, Path::new("/arch/tracks/recording=r"));
        let SourceSpec::Csv(c) = &s.sensors[0].source else { panic!("csv") };
        assert_eq!(c.path, Path::new("/d/r.csv"));
    }

    #[test]
    fn scenes_that_read_more_than_one_file_are_refused_naming_the_keys() {
        let two = r#"
[[sensor]]
name = "ff"
source = { csv = "a.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }
[[sensor]]
name = "th"
source = { npy = "b.npy", rate_hz = 100.0 }
[[output]]
tap = "source"
path = "out/raw.parquet"
"#;
        let e = check_batchable(&scene(two)).unwrap_err().to_string();
        assert!(e.contains("sensor \"ff\" source.csv") && e.contains("sensor \"th\" source.npy"), "{e}");
        let ts = two.replace("b.npy\", rate_hz = 100.0", "a.csv\", timestamps = \"t.npy\"");
        let e = check_batchable(&scene(&ts)).unwrap_err().to_string();
        assert!(e.contains("sensor \"th\" source.timestamps"), "{e}");
        // the same file read by two sensors is one file
        let same = two.replace(
            "{ npy = \"b.npy\", rate_hz = 100.0 }",
            "{ csv = \"./a.csv\", columns = \"th_e{1..24}\", rate_hz = 100.0 }",
        );
        check_batchable(&scene(&same)).unwrap();
        #[cfg(target_os = "linux")]
        {
            let live = BUS.replace("candump = \"hand.log\"", "interface = \"can0\"");
            let e = check_batchable(&scene(&live)).unwrap_err().to_string();
            assert!(e.contains("bus \"hand\" interface"), "{e}");
        }
    }

    #[test]
    fn stems_and_table_names() {
        assert_eq!(recording_stem(Path::new("a/b/bottle12.csv")).unwrap(), "bottle12");
        assert!(recording_stem(Path::new("/")).is_err());
        let e = check_stems(&[PathBuf::from("a/x.csv"), PathBuf::from("b/y.csv"), PathBuf::from("c/x.npy")])
            .unwrap_err()
            .to_string();
        assert!(e.contains("a/x.csv") && e.contains("c/x.npy"), "{e}");
        assert_eq!(output_names(&scene(BUS)).unwrap(), ["raw", "slip"]);
    }
}
