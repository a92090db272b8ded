//! Parquet archives: a directory of Parquet files of one record type, rolled by size, row
//! count or time and optionally partitioned hive-style by sensor, so Spark, DataFusion, DuckDB
//! or `pyarrow.dataset` read the whole directory as one table.
//!
//! [`ParquetArchive`] is a synchronous core (arrow-rs style: [`try_new`](ParquetArchive::try_new)
//! validates, `with_*` set options) over one [`ParquetSink`] per open file. An async pipeline
//! feeds it through [`blocking_archive`](crate::blocking::blocking_archive).
//!
//! # Layout
//! ```text
//! <dir>/part-000000.parquet                      partition: none
//! <dir>/part-000001.parquet
//! <dir>/.part-000002.parquet.partial             the file being written (hidden)
//!
//! <dir>/sensor=ff/part-000000.parquet            partition: sensor
//! <dir>/sensor=ff/.part-000001.parquet.partial
//! <dir>/sensor=th/part-000000.parquet
//! ```
//! - File names are `<prefix>-<index>.parquet` (prefix `part` unless
//!   [`with_prefix`](ParquetArchive::with_prefix) says otherwise), the index counting from 0 per
//!   directory, zero-padded to 6 digits (so the names sort lexically in write order up to a
//!   million files per directory; beyond, the index grows wider). An archive opened on a
//!   directory that already holds files of the same prefix continues after the highest index
//!   found, final or temporary, so it never overwrites anything.
//! - With [`Partitioning::Sensor`] each sensor gets a directory `sensor=<name>`; characters
//!   other than ASCII letters, digits, `-`, `_`, `.` and `~` are percent-encoded (UTF-8
//!   bytes), as hive readers (`pyarrow` `segment_encoding="uri"`, Spark, DuckDB) decode them.
//!   The files do **not** repeat the `sensor` column: the directory name holds it, and a
//!   column of the same name inside the files makes DataFusion's `PARTITIONED BY (sensor)` fail
//!   ("duplicate qualified field name") and leaves the other engines to pick one of two.
//!   [`with_partition_column`](ParquetArchive::with_partition_column)`(true)` keeps it (every
//!   file then complete on its own, for readers that ignore directory names).
//! - Time columns are `Duration(ns)` unless [`with_time_base`](ParquetArchive::with_time_base)
//!   says `Timestamp(ns, "UTC")` ([`TimeBase`]).
//! - Every file's key-value metadata holds `gradtac.version`, `gradtac.schema` and every pair
//!   given with [`with_metadata`](ParquetArchive::with_metadata) /
//!   [`set_metadata`](ParquetArchive::set_metadata) (the scene, the layout).
//!
//! # Rolling
//! Each partition has at most one open file; a file is finished and the next one started when
//! - **rows**: it holds [`roll_rows`](ParquetArchive::with_roll_rows) records (checked after
//!   every record; a file holds exactly that many, the last one fewer);
//! - **bytes**: its [estimated size](ParquetSink::estimated_size) reaches
//!   [`roll_bytes`](ParquetArchive::with_roll_bytes). The estimate is the bytes written to the
//!   file (flushed row groups, compressed, exact) plus the Parquet writer's estimate of the row
//!   group in progress; it grows each time a batch of `min(row_group_size, 8192)` records is
//!   handed to the writer, so a file overshoots `roll_bytes` by at most about one such batch
//!   plus the footer. Lower `row_group_size` for tighter sizes;
//! - **time**: a record's time falls in a later span than the file's first (accepted) record, spans
//!   being aligned to the epoch: record time `t` (ns) is in span `t.div_euclid(span)`
//!   ([`with_roll_span`](ParquetArchive::with_roll_span)). With a span of one hour, files
//!   start on the hour whatever time the stream started. A late record (an earlier span than
//!   the open file's) goes to the open file: files never reopen, so a file may hold a few late
//!   rows from the previous span; rows are never reordered or dropped.
//!
//! Conditions combine: whichever comes first rolls. With none, each partition is one file.
//!
//! # No data loss
//! Only the file being written is under a temporary name, `.<name>.partial` beside its final
//! name: hidden, so dataset readers (which skip names starting with `.` or `_`) ignore it while
//! the archive is written and after a crash. A file is finished by writing its footer,
//! `fsync`ing it, renaming it to its final name and `fsync`ing the directory; a final name
//! therefore always holds a complete, valid file.
//! - **End of stream**: [`finish`](ParquetArchive::finish) finishes every open file.
//! - **Error upstream** (a source or stage fails) and **cancel** (Ctrl-C): call
//!   [`finish`](ParquetArchive::finish) too — every record pushed is valid data, so the open
//!   files are finished **under their final names**. [`abort`](ParquetArchive::abort) is for
//!   the rare caller that wants the sink's behaviour instead: open files closed valid (with a
//!   footer) but left under their temporary names.
//! - **Error in the archive**: a record that does not fit the schema is rejected with
//!   [`Error::Record`] and the archive stays usable. An I/O or Parquet error leaves that file
//!   under its temporary name (closed valid when possible) and the archive failed: later
//!   pushes fail, and [`finish`](ParquetArchive::finish) still finishes the other open files
//!   and then returns the error.
//! - **Drop without `finish`**, panic or kill: open files stay under their temporary names,
//!   possibly without a footer; every file already finished is intact. (Drop does no I/O:
//!   closing a file can fail, and drop cannot report it. The async handle
//!   [`BlockingArchive`](crate::blocking::BlockingArchive) does finish on drop, on its own
//!   thread, because it can log the outcome there.)
//!
//! An empty file is never written: a partition that received no record has no file, and an
//! empty open file (possible only after a rejected record) is deleted when finished.
//!
//! ```
//! use gradtac_io::archive::{ParquetArchive, Partitioning};
//! use gradtac_io::FrameShape;
//! use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
//!
//! let dir = tempfile::tempdir().unwrap();
//! let mut archive = ParquetArchive::<TaxelFrame>::try_new(dir.path(), FrameShape::unnamed(2).unwrap())
//!     .unwrap()
//!     .with_partitioning(Partitioning::Sensor)
//!     .unwrap()
//!     .with_roll_rows(10)
//!     .unwrap()
//!     .with_metadata("gradtac.scene", "demo");
//! for k in 0..25u64 {
//!     let sensor = if k % 2 == 0 { "ff" } else { "th" };
//!     archive.push(&TaxelFrame::new(SensorId::new(sensor), Timestamp(k as i64), k, vec![1.0, 2.0])).unwrap();
//! }
//! let files = archive.finish().unwrap();
//! // ff got 13 frames (10 + 3), th 12 (10 + 2)
//! assert_eq!(files.len(), 4);
//! assert!(dir.path().join("sensor=ff/part-000001.parquet").exists());
//! ```

use crate::parquet_sink::{
    check_row_group_size, check_zstd_level, set_pair, ParquetSink, DEFAULT_ROW_GROUP_SIZE, DEFAULT_ZSTD_LEVEL,
    PARTIAL_SUFFIX,
};
use crate::records::{ArrowRecord, TimeBase};
use crate::{Error, Result};
use arrow_schema::SchemaRef;
use gradtac_stream::{HasSensor, Timed};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt;
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

/// Name of the hive partition column (and of the records' sensor column).
pub const PARTITION_COLUMN: &str = "sensor";
/// File name prefix unless [`ParquetArchive::with_prefix`] says otherwise.
pub const DEFAULT_PREFIX: &str = "part";
/// Digits of the zero-padded file index.
const INDEX_WIDTH: usize = 6;

/// How an archive splits its files into directories.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Partitioning {
    /// All files directly in the archive's directory.
    #[default]
    None,
    /// One directory per sensor, `sensor=<name>` (hive style).
    Sensor,
}

/// An archive's options as a scene embeds them (e.g. in an `[[output]]` table); see
/// [`ParquetArchive::from_config`]. Every field is optional.
///
/// ```
/// let cfg: gradtac_io::archive::ArchiveConfig =
///     toml::from_str("roll_bytes = 134217728\nroll_seconds = 3600\npartition = \"sensor\"").unwrap();
/// assert_eq!(cfg.partition, gradtac_io::archive::Partitioning::Sensor);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ArchiveConfig {
    /// Roll when a file's estimated size reaches this many **bytes** (≥ 1; see the module's
    /// rolling rules). Default: no size limit.
    pub roll_bytes: Option<u64>,
    /// Roll when a record's time enters a new span of this many **seconds** (> 0, at least
    /// 1 ns, aligned to the epoch). Default: no time limit.
    pub roll_seconds: Option<f64>,
    /// Roll when a file holds this many **records** (rows of the schema; ≥ 1). Default: no
    /// row limit.
    pub roll_rows: Option<u64>,
    /// `"none"` (default) or `"sensor"` (one `sensor=<name>` directory per sensor).
    pub partition: Partitioning,
    /// Rows per Parquet row group (≥ 1; default 65 536).
    pub row_group_size: usize,
    /// zstd level, 1 fastest … 22 smallest (default 3; 0 is zstd's own default).
    pub zstd_level: i32,
    /// File name prefix: ASCII letters, digits, `-`, `_`, not starting with `_` (default
    /// `part`).
    pub prefix: String,
    /// With `partition = "sensor"`: keep the `sensor` column inside the files too (default
    /// false: the directory name holds it, as hive readers expect).
    pub partition_column: bool,
}

impl Default for ArchiveConfig {
    fn default() -> Self {
        ArchiveConfig {
            roll_bytes: None,
            roll_seconds: None,
            roll_rows: None,
            partition: Partitioning::None,
            row_group_size: DEFAULT_ROW_GROUP_SIZE,
            zstd_level: DEFAULT_ZSTD_LEVEL,
            prefix: DEFAULT_PREFIX.to_string(),
            partition_column: false,
        }
    }
}

impl ArchiveConfig {
    /// Check every option without touching the file system (what
    /// [`ParquetArchive::from_config`] would refuse): on failure, the offending key and why.
    /// A planner calls this before anything is read, so `explain` refuses what `run` would.
    pub fn check(&self) -> std::result::Result<(), (&'static str, String)> {
        if self.roll_bytes == Some(0) {
            return Err(("roll_bytes", "roll_bytes must be at least 1".into()));
        }
        if self.roll_rows == Some(0) {
            return Err(("roll_rows", "roll_rows must be at least 1".into()));
        }
        if let Some(s) = self.roll_seconds {
            roll_span(s).map_err(|e| ("roll_seconds", plain(e)))?;
        }
        check_row_group_size(self.row_group_size).map_err(|e| ("row_group_size", plain(e)))?;
        check_zstd_level(self.zstd_level).map_err(|e| ("zstd_level", plain(e)))?;
        check_prefix(&self.prefix).map_err(|e| ("prefix", plain(e)))?;
        Ok(())
    }
}

/// An `InvalidConfig` message without its prefix (the caller adds where).
fn plain(e: Error) -> String {
    match e {
        Error::InvalidConfig(r) => r,
        e => e.to_string(),
    }
}

/// `roll_seconds` as a span: positive, finite, at least 1 ns and at most 292 years.
fn roll_span(s: f64) -> Result<Duration> {
    let short = gradtac_stream::num::Short(s);
    if !(s.is_finite() && s > 0.0) {
        return Err(Error::InvalidConfig(format!("roll_seconds must be positive and finite, got {short}")));
    }
    let span = Duration::try_from_secs_f64(s)
        .ok()
        .filter(|d| d.as_nanos() >= 1 && d.as_nanos() <= i64::MAX as u128)
        .ok_or_else(|| Error::InvalidConfig(format!("roll_seconds = {short} must be between 1 ns and 292 years")))?;
    Ok(span)
}

fn check_prefix(prefix: &str) -> Result<()> {
    let ok = !prefix.is_empty()
        && prefix.len() <= 64
        && !prefix.starts_with('_')
        && prefix.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_');
    if !ok {
        return Err(Error::InvalidConfig(format!(
            "archive prefix {prefix:?} must be 1-64 ASCII letters, digits, '-' or '_', not starting with '_'"
        )));
    }
    Ok(())
}

/// One open file.
struct OpenFile<T: ArrowRecord> {
    sink: ParquetSink<T>,
    /// The time span of the file's first accepted record (time rolling only; `None` until
    /// then, so a rejected record's time never sets it).
    span: Option<i64>,
}

/// Writes records of type `T` to a directory of Parquet files (see the
/// [module documentation](self)).
#[must_use = "an archive leaves its open files unfinished until `finish` is called"]
pub struct ParquetArchive<T: ArrowRecord> {
    dir: PathBuf,
    shape: T::Shape,
    schema: SchemaRef,
    time: TimeBase,
    partitioning: Partitioning,
    partition_column: bool,
    prefix: String,
    roll_bytes: Option<u64>,
    roll_rows: Option<u64>,
    roll_span_ns: Option<i64>,
    row_group_size: usize,
    zstd_level: i32,
    writer_thread: bool,
    metadata: Vec<(String, String)>,
    /// Open files by partition directory name (`""` when not partitioned).
    open: BTreeMap<String, OpenFile<T>>,
    /// The next file index per partition directory that has been opened once.
    next_index: BTreeMap<String, u64>,
    finished: Vec<PathBuf>,
    rows: u64,
    failure: Option<String>,
}

impl<T: ArrowRecord> fmt::Debug for ParquetArchive<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ParquetArchive")
            .field("dir", &self.dir)
            .field("schema", &T::SCHEMA_ID)
            .field("partitioning", &self.partitioning)
            .field("prefix", &self.prefix)
            .field("roll_bytes", &self.roll_bytes)
            .field("roll_rows", &self.roll_rows)
            .field("roll_span_ns", &self.roll_span_ns)
            .field("row_group_size", &self.row_group_size)
            .field("zstd_level", &self.zstd_level)
            .field("writer_thread", &self.writer_thread)
            .field("open", &self.open.keys().collect::<Vec<_>>())
            .field("finished", &self.finished.len())
            .field("rows", &self.rows)
            .field("failure", &self.failure)
            .finish_non_exhaustive()
    }
}

impl<T: ArrowRecord + HasSensor + Timed> ParquetArchive<T> {
    /// An archive in `dir`, created (with its parents) if missing. Fails if `dir` is not a
    /// writable directory (a probe file is created and removed). `shape` fixes the schema of
    /// every file. No file is created before the first record.
    pub fn try_new(dir: impl AsRef<Path>, shape: T::Shape) -> Result<Self> {
        let dir = dir.as_ref().to_path_buf();
        if dir.exists() && !dir.is_dir() {
            return Err(Error::InvalidConfig(format!("archive directory {} is not a directory", dir.display())));
        }
        fs::create_dir_all(&dir).map_err(|source| Error::Io { path: dir.clone(), source })?;
        let probe = dir.join(format!(".gradtac-probe-{}", std::process::id()));
        fs::File::create(&probe)
            .and_then(|_| fs::remove_file(&probe))
            .map_err(|source| Error::Io { path: probe.clone(), source })?;
        Ok(ParquetArchive {
            dir,
            schema: T::schema(&shape, TimeBase::default()),
            shape,
            time: TimeBase::default(),
            partitioning: Partitioning::None,
            partition_column: false,
            prefix: DEFAULT_PREFIX.to_string(),
            roll_bytes: None,
            roll_rows: None,
            roll_span_ns: None,
            row_group_size: DEFAULT_ROW_GROUP_SIZE,
            zstd_level: DEFAULT_ZSTD_LEVEL,
            writer_thread: false,
            metadata: Vec::new(),
            open: BTreeMap::new(),
            next_index: BTreeMap::new(),
            finished: Vec::new(),
            rows: 0,
            failure: None,
        })
    }

    /// [`try_new`](Self::try_new) with every option of `config`.
    pub fn from_config(dir: impl AsRef<Path>, shape: T::Shape, config: &ArchiveConfig) -> Result<Self> {
        let mut a = Self::try_new(dir, shape)?
            .with_partitioning(config.partition)?
            .with_partition_column(config.partition_column)?
            .with_prefix(&config.prefix)?
            .with_row_group_size(config.row_group_size)?
            .with_zstd_level(config.zstd_level)?;
        if let Some(b) = config.roll_bytes {
            a = a.with_roll_bytes(b)?;
        }
        if let Some(r) = config.roll_rows {
            a = a.with_roll_rows(r)?;
        }
        if let Some(s) = config.roll_seconds {
            a = a.with_roll_span(roll_span(s)?)?;
        }
        Ok(a)
    }
}

impl<T: ArrowRecord + HasSensor + Timed> ParquetArchive<T> {
    fn check_not_started(&self, what: &str) -> Result<()> {
        if self.next_index.is_empty() {
            Ok(())
        } else {
            Err(Error::InvalidConfig(format!("{what} must be set before the archive's first record")))
        }
    }

    /// Partition the files ([`Partitioning::None`] by default). Before the first record.
    pub fn with_partitioning(mut self, partitioning: Partitioning) -> Result<Self> {
        self.check_not_started("partitioning")?;
        self.partitioning = partitioning;
        self.update_schema();
        Ok(self)
    }

    /// With [`Partitioning::Sensor`], keep the `sensor` column inside the files too (default
    /// false: the `sensor=<name>` directory holds it, as hive readers expect; see the
    /// [module documentation](self)). Before the first record.
    pub fn with_partition_column(mut self, keep: bool) -> Result<Self> {
        self.check_not_started("partition_column")?;
        self.partition_column = keep;
        self.update_schema();
        Ok(self)
    }

    /// The [`TimeBase`] of the time columns (default [`TimeBase::Relative`]). Before the first
    /// record.
    pub fn with_time_base(mut self, time: TimeBase) -> Result<Self> {
        self.check_not_started("the time base")?;
        self.time = time;
        self.update_schema();
        Ok(self)
    }

    /// True when the files leave out the partition column.
    fn drops_partition_column(&self) -> bool {
        self.partitioning == Partitioning::Sensor && !self.partition_column
    }

    fn update_schema(&mut self) {
        let full = T::schema(&self.shape, self.time);
        self.schema = match full.index_of(PARTITION_COLUMN) {
            Ok(i) if self.drops_partition_column() => {
                let keep: Vec<usize> = (0..full.fields().len()).filter(|&k| k != i).collect();
                Arc::new(full.project(&keep).expect("indices of the schema's own fields"))
            }
            _ => full,
        };
    }

    /// Roll when a file's estimated size reaches `bytes` (≥ 1; see the module's rolling
    /// rules). Before the first record.
    pub fn with_roll_bytes(mut self, bytes: u64) -> Result<Self> {
        self.check_not_started("roll_bytes")?;
        if bytes == 0 {
            return Err(Error::InvalidConfig("roll_bytes must be at least 1".into()));
        }
        self.roll_bytes = Some(bytes);
        Ok(self)
    }

    /// Roll when a file holds `rows` records (≥ 1). Before the first record.
    pub fn with_roll_rows(mut self, rows: u64) -> Result<Self> {
        self.check_not_started("roll_rows")?;
        if rows == 0 {
            return Err(Error::InvalidConfig("roll_rows must be at least 1".into()));
        }
        self.roll_rows = Some(rows);
        Ok(self)
    }

    /// Roll when a record's time (ns, the records' own epoch) enters a later span of length
    /// `span`, spans aligned to the epoch (`t.div_euclid(span)`). `span` must be at least
    /// 1 ns and at most `i64::MAX` ns (292 years). Before the first record.
    pub fn with_roll_span(mut self, span: Duration) -> Result<Self> {
        self.check_not_started("roll span")?;
        let ns = i64::try_from(span.as_nanos())
            .ok()
            .filter(|&ns| ns > 0)
            .ok_or_else(|| Error::InvalidConfig(format!("roll span {span:?} must be between 1 ns and 292 years")))?;
        self.roll_span_ns = Some(ns);
        Ok(self)
    }

    /// File name prefix (default `part`): 1 to 64 ASCII letters, digits, `-` or `_`, not
    /// starting with `_` (dataset readers skip names starting with `_` or `.`). Before the
    /// first record.
    pub fn with_prefix(mut self, prefix: &str) -> Result<Self> {
        self.check_not_started("prefix")?;
        check_prefix(prefix)?;
        self.prefix = prefix.to_string();
        Ok(self)
    }

    /// Rows per row group of every file (≥ 1; default 65 536). Before the first record.
    pub fn with_row_group_size(mut self, rows: usize) -> Result<Self> {
        self.check_not_started("row_group_size")?;
        check_row_group_size(rows)?;
        self.row_group_size = rows;
        Ok(self)
    }

    /// zstd level of every file (see [`ParquetSink::with_zstd_level`]). Before the first
    /// record.
    pub fn with_zstd_level(mut self, level: i32) -> Result<Self> {
        self.check_not_started("zstd level")?;
        check_zstd_level(level)?;
        self.zstd_level = level;
        Ok(self)
    }

    /// Each open file encodes and writes on a thread of its own (see
    /// [`ParquetSink::with_writer_thread`]; default `false`). Before the first record. With
    /// [`roll_bytes`](Self::with_roll_bytes) the size estimate then counts only the batches a
    /// file's thread has written, so a file may overshoot `roll_bytes` by up to two more
    /// batches of `min(row_group_size, 8192)` records.
    pub fn with_writer_thread(mut self, on: bool) -> Result<Self> {
        self.check_not_started("writer thread")?;
        self.writer_thread = on;
        Ok(self)
    }

    /// Add a key-value pair to the metadata of every file finished from now on (including
    /// the open ones: metadata is written with the footer). A key given twice keeps the
    /// last value.
    pub fn with_metadata(mut self, key: impl Into<String>, value: impl Into<String>) -> Self {
        self.set_metadata(key, value);
        self
    }

    /// [`with_metadata`](Self::with_metadata) through `&mut`.
    pub fn set_metadata(&mut self, key: impl Into<String>, value: impl Into<String>) {
        set_pair(&mut self.metadata, key.into(), value.into());
    }

    /// The archive's directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The Arrow schema of every file (without `sensor` when partitioned by it, unless
    /// [`with_partition_column`](Self::with_partition_column)).
    pub fn schema(&self) -> &SchemaRef {
        &self.schema
    }

    /// Rows accepted so far, over all files (an event batch counts one row per event).
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Every file finished so far, in the order they were finished.
    pub fn finished(&self) -> &[PathBuf] {
        &self.finished
    }

    /// The temporary paths of the files being written, sorted by partition.
    pub fn open_files(&self) -> Vec<&Path> {
        self.open.values().map(|f| f.sink.partial_path()).collect()
    }

    /// Append one record to its partition's open file, opening a file or rolling first when
    /// needed (see the module's rules). A record that does not fit the schema is rejected
    /// with [`Error::Record`] and the archive stays usable; so is a record with an empty
    /// sensor name when partitioning by sensor. Any other error leaves the archive failed.
    pub fn push(&mut self, record: &T) -> Result<()> {
        if let Some(reason) = &self.failure {
            return Err(self.failed_error(reason));
        }
        let key = match self.partitioning {
            Partitioning::None => String::new(),
            Partitioning::Sensor => {
                let sensor = record.sensor().as_str();
                if sensor.is_empty() {
                    return Err(Error::Record {
                        schema: T::SCHEMA_ID.into(),
                        reason: "an empty sensor name cannot name a partition directory".into(),
                    });
                }
                hive_segment(PARTITION_COLUMN, sensor)
            }
        };
        let span = self.roll_span_ns.map(|s| record.time().as_nanos().div_euclid(s));
        if let (Some(open), Some(span)) = (self.open.get(&key), span) {
            if open.span.is_some_and(|s| span > s) {
                self.finish_file(&key)?;
            }
        }
        if !self.open.contains_key(&key) {
            self.open_file(&key)?;
        }
        let file = self.open.get_mut(&key).expect("opened above");
        let rows_before = file.sink.rows();
        match file.sink.push(record) {
            Ok(()) => {}
            Err(e @ Error::Record { .. }) => return Err(e),
            Err(e) => {
                self.fail(&key, &e);
                return Err(e);
            }
        }
        self.rows += file.sink.rows() - rows_before;
        if file.span.is_none() {
            file.span = span;
        }
        let full = self.roll_rows.is_some_and(|n| file.sink.rows() >= n)
            || self.roll_bytes.is_some_and(|b| file.sink.estimated_size() >= b);
        if full {
            self.finish_file(&key)?;
        }
        Ok(())
    }

    /// Finish every open file now (under its final name); the next record of each
    /// partition starts a new file. For a checkpoint, or before a long pause.
    pub fn roll(&mut self) -> Result<()> {
        if let Some(reason) = &self.failure {
            return Err(self.failed_error(reason));
        }
        let keys: Vec<String> = self.open.keys().cloned().collect();
        for key in keys {
            self.finish_file(&key)?;
        }
        Ok(())
    }

    /// Finish every open file under its final name (end of stream, an upstream error, a
    /// cancel) and return every file the archive finished, in order. If a file cannot be
    /// finished (or the archive had already failed), the other open files are still finished
    /// and the first error is returned; files finished are valid either way.
    pub fn finish(mut self) -> Result<Vec<PathBuf>> {
        let mut first = self.failure.as_ref().map(|r| self.failed_error(r));
        let keys: Vec<String> = self.open.keys().cloned().collect();
        for key in keys {
            if let Err(e) = self.finish_file(&key) {
                first.get_or_insert(e);
            }
        }
        match first {
            None => Ok(std::mem::take(&mut self.finished)),
            Some(e) => Err(e),
        }
    }

    /// Close every open file as a valid Parquet file but leave it under its temporary name
    /// ([`ParquetSink::abort`]); returns those paths. Files finished earlier stay finished.
    pub fn abort(mut self) -> Result<Vec<PathBuf>> {
        let mut first = None;
        let mut kept = Vec::new();
        for (_, mut file) in std::mem::take(&mut self.open) {
            self.apply_metadata(&mut file.sink);
            match file.sink.abort() {
                Ok(p) => kept.push(p),
                Err(e) => {
                    first.get_or_insert(e);
                }
            }
        }
        first.map_or(Ok(kept), Err)
    }

    fn failed_error(&self, reason: &str) -> Error {
        Error::Arrow { context: format!("archive {}", self.dir.display()), reason: format!("failed earlier: {reason}") }
    }

    fn fail(&mut self, key: &str, e: &Error) {
        self.failure.get_or_insert_with(|| e.to_string());
        if let Some(mut file) = self.open.remove(key) {
            self.apply_metadata(&mut file.sink);
            // Keep what can be kept readable under the temporary name.
            let _ = file.sink.abort();
        }
    }

    fn apply_metadata(&self, sink: &mut ParquetSink<T>) {
        for (k, v) in &self.metadata {
            sink.set_metadata(k.clone(), v.clone());
        }
    }

    fn open_file(&mut self, key: &str) -> Result<()> {
        let dir = if key.is_empty() { self.dir.clone() } else { self.dir.join(key) };
        let index = match self.next_index.get(key) {
            Some(&i) => i,
            None => {
                fs::create_dir_all(&dir).map_err(|source| Error::Io { path: dir.clone(), source })?;
                next_free_index(&dir, &self.prefix)?
            }
        };
        let name = format!("{}-{index:0INDEX_WIDTH$}.parquet", self.prefix);
        let path = dir.join(&name);
        let temp = dir.join(format!(".{name}{PARTIAL_SUFFIX}"));
        // Dropped only when the records have the column (update_schema left it out).
        let drop = self.drops_partition_column() && self.schema.index_of(PARTITION_COLUMN).is_err();
        let sink = ParquetSink::try_new_with_temp(path, temp, self.shape.clone())
            .and_then(|s| s.with_time_base(self.time))
            .and_then(|s| if drop { s.without_column(PARTITION_COLUMN) } else { Ok(s) })
            .and_then(|s| s.with_row_group_size(self.row_group_size))
            .and_then(|s| s.with_zstd_level(self.zstd_level))
            .and_then(|s| s.with_writer_thread(self.writer_thread));
        let sink = match sink {
            Ok(s) => s,
            Err(e) => {
                self.failure.get_or_insert_with(|| e.to_string());
                return Err(e);
            }
        };
        self.next_index.insert(key.to_string(), index + 1);
        self.open.insert(key.to_string(), OpenFile { sink, span: None });
        Ok(())
    }

    /// Finish the open file of partition `key` (an empty one is deleted instead).
    fn finish_file(&mut self, key: &str) -> Result<()> {
        let Some(mut file) = self.open.remove(key) else { return Ok(()) };
        if file.sink.rows() == 0 {
            let temp = file.sink.partial_path().to_path_buf();
            drop(file);
            return fs::remove_file(&temp).map_err(|source| Error::Io { path: temp, source });
        }
        self.apply_metadata(&mut file.sink);
        match file.sink.finish() {
            Ok(path) => {
                tracing::debug!(path = %path.display(), "archive file finished");
                self.finished.push(path);
                Ok(())
            }
            Err(e) => {
                self.failure.get_or_insert_with(|| e.to_string());
                Err(e)
            }
        }
    }
}

/// A writer of records of type `T` — one Parquet file ([`ParquetSink`]) or an archive
/// ([`ParquetArchive`]) — behind one object-safe interface, so a host (the CLI's outputs)
/// can hold `Box<dyn RecordSink<T>>` whichever the configuration chose.
pub trait RecordSink<T>: Send {
    /// Append one record ([`ParquetSink::push`], [`ParquetArchive::push`]).
    fn push(&mut self, record: &T) -> Result<()>;
    /// Records accepted so far.
    fn rows(&self) -> u64;
    /// Add or replace a key-value pair in the metadata of the file(s) not yet finished.
    fn set_metadata(&mut self, key: String, value: String);
    /// Finish: every file under its final name; returns the files finished (one for a sink).
    fn finish(self: Box<Self>) -> Result<Vec<PathBuf>>;
    /// Close valid files but leave the open ones under their temporary names; returns those.
    fn abort(self: Box<Self>) -> Result<Vec<PathBuf>>;
}

impl<T: ArrowRecord> RecordSink<T> for ParquetSink<T> {
    fn push(&mut self, record: &T) -> Result<()> {
        ParquetSink::push(self, record)
    }
    fn rows(&self) -> u64 {
        ParquetSink::rows(self)
    }
    fn set_metadata(&mut self, key: String, value: String) {
        ParquetSink::set_metadata(self, key, value)
    }
    fn finish(self: Box<Self>) -> Result<Vec<PathBuf>> {
        ParquetSink::finish(*self).map(|p| vec![p])
    }
    fn abort(self: Box<Self>) -> Result<Vec<PathBuf>> {
        ParquetSink::abort(*self).map(|p| vec![p])
    }
}

impl<T: ArrowRecord + HasSensor + Timed> RecordSink<T> for ParquetArchive<T> {
    fn push(&mut self, record: &T) -> Result<()> {
        ParquetArchive::push(self, record)
    }
    fn rows(&self) -> u64 {
        ParquetArchive::rows(self)
    }
    fn set_metadata(&mut self, key: String, value: String) {
        ParquetArchive::set_metadata(self, key, value)
    }
    fn finish(self: Box<Self>) -> Result<Vec<PathBuf>> {
        ParquetArchive::finish(*self)
    }
    fn abort(self: Box<Self>) -> Result<Vec<PathBuf>> {
        ParquetArchive::abort(*self)
    }
}

/// The first index after every `<prefix>-<digits>.parquet` and `.<prefix>-<digits>.parquet.partial`
/// in `dir` (0 when there is none).
fn next_free_index(dir: &Path, prefix: &str) -> Result<u64> {
    let entries = fs::read_dir(dir).map_err(|source| Error::Io { path: dir.to_path_buf(), source })?;
    let mut next = 0;
    for entry in entries {
        let entry = entry.map_err(|source| Error::Io { path: dir.to_path_buf(), source })?;
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        let name = name.strip_prefix('.').and_then(|n| n.strip_suffix(PARTIAL_SUFFIX)).unwrap_or(name);
        let index = name
            .strip_prefix(prefix)
            .and_then(|n| n.strip_prefix('-'))
            .and_then(|n| n.strip_suffix(".parquet"))
            .filter(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
            .and_then(|d| d.parse::<u64>().ok());
        if let Some(i) = index {
            next = next.max(i + 1);
        }
    }
    Ok(next)
}

/// `key=value` with `value` percent-encoded except ASCII letters, digits, `-`, `_`, `.`, `~`
/// (URI unreserved characters), as hive-style readers decode it.
pub fn hive_segment(key: &str, value: &str) -> String {
    let mut s = String::with_capacity(key.len() + 1 + value.len());
    s.push_str(key);
    s.push('=');
    for b in value.bytes() {
        if b.is_ascii_alphanumeric() || matches!(b, b'-' | b'_' | b'.' | b'~') {
            s.push(b as char);
        } else {
            s.push_str(&format!("%{b:02X}"));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::FrameShape;
    use gradtac_stream::{SensorId, TaxelFrame, Timestamp};

    fn frame(sensor: &str, t: i64, seq: u64) -> TaxelFrame {
        TaxelFrame::new(SensorId::new(sensor), Timestamp(t), seq, vec![seq as f64, -(seq as f64)])
    }

    fn archive(dir: &Path) -> ParquetArchive<TaxelFrame> {
        ParquetArchive::try_new(dir, FrameShape::unnamed(2).unwrap()).unwrap()
    }

    #[test]
    fn hive_segments_escape_what_paths_and_hive_cannot_hold() {
        assert_eq!(hive_segment("sensor", "ff"), "sensor=ff");
        assert_eq!(hive_segment("sensor", "left/ff 1"), "sensor=left%2Fff%201");
        assert_eq!(hive_segment("sensor", "a=b%"), "sensor=a%3Db%25");
        assert_eq!(hive_segment("sensor", "é"), "sensor=%C3%A9");
        assert_eq!(hive_segment("sensor", ".."), "sensor=..");
    }

    #[test]
    fn options_are_validated() {
        let dir = tempfile::tempdir().unwrap();
        assert!(archive(dir.path()).with_roll_rows(0).is_err());
        assert!(archive(dir.path()).with_roll_bytes(0).is_err());
        assert!(archive(dir.path()).with_roll_span(Duration::ZERO).is_err());
        assert!(archive(dir.path()).with_roll_span(Duration::from_secs(u64::MAX)).is_err());
        assert!(archive(dir.path()).with_roll_span(Duration::from_nanos(1)).is_ok());
        assert!(archive(dir.path()).with_row_group_size(0).is_err());
        assert!(archive(dir.path()).with_zstd_level(23).is_err());
        for bad in ["", "_hidden", "a.b", "a/b", "é"] {
            assert!(archive(dir.path()).with_prefix(bad).is_err(), "{bad:?}");
        }
        assert!(archive(dir.path()).with_prefix("frames-ff_2").is_ok());
        let file = dir.path().join("f");
        fs::write(&file, b"x").unwrap();
        let e = ParquetArchive::<TaxelFrame>::try_new(&file, FrameShape::unnamed(2).unwrap()).unwrap_err();
        assert!(e.to_string().contains("not a directory"), "{e}");
        let cfg = ArchiveConfig { roll_seconds: Some(f64::NAN), ..ArchiveConfig::default() };
        assert!(ParquetArchive::<TaxelFrame>::from_config(dir.path(), FrameShape::unnamed(2).unwrap(), &cfg).is_err());
        let cfg = ArchiveConfig { roll_seconds: Some(-1.0), ..ArchiveConfig::default() };
        assert!(ParquetArchive::<TaxelFrame>::from_config(dir.path(), FrameShape::unnamed(2).unwrap(), &cfg).is_err());
    }

    #[test]
    fn options_are_fixed_once_writing_starts() {
        let dir = tempfile::tempdir().unwrap();
        let mut a = archive(dir.path());
        a.push(&frame("ff", 0, 0)).unwrap();
        assert!(a.with_roll_rows(5).is_err());
    }

    #[test]
    fn config_parses_with_defaults_and_rejects_unknown_fields() {
        let cfg: ArchiveConfig = toml::from_str("roll_rows = 5").unwrap();
        assert_eq!(cfg, ArchiveConfig { roll_rows: Some(5), ..ArchiveConfig::default() });
        assert!(toml::from_str::<ArchiveConfig>("roll_row = 5").is_err());
        assert!(toml::from_str::<ArchiveConfig>("partition = \"taxel\"").is_err());
    }

    #[test]
    fn rows_roll_exactly_and_names_sort() {
        let dir = tempfile::tempdir().unwrap();
        let mut a = archive(dir.path()).with_roll_rows(3).unwrap();
        for k in 0..10 {
            a.push(&frame("ff", k, k as u64)).unwrap();
            // only the file being written is temporary
            assert!(a.open_files().len() <= 1);
        }
        assert_eq!(a.finished().len(), 3);
        assert_eq!(a.open_files(), [dir.path().join(".part-000003.parquet.partial")]);
        let files = a.finish().unwrap();
        let names: Vec<_> = files.iter().map(|p| p.file_name().unwrap().to_str().unwrap().to_string()).collect();
        assert_eq!(names, ["part-000000.parquet", "part-000001.parquet", "part-000002.parquet", "part-000003.parquet"]);
    }

    #[test]
    fn time_spans_align_to_the_epoch_and_late_rows_stay() {
        let dir = tempfile::tempdir().unwrap();
        let mut a = archive(dir.path()).with_roll_span(Duration::from_nanos(10)).unwrap();
        // spans: [-10,0) [0,10) [10,20) ...; 12 is late after 25 and stays in the open file
        for (seq, t) in [-3i64, 0, 9, 10, 25, 12, 30].into_iter().enumerate() {
            a.push(&frame("ff", t, seq as u64)).unwrap();
        }
        assert_eq!(a.finished().len(), 4, "{:?}", a.finished());
        assert_eq!(a.finish().unwrap().len(), 5);
    }

    #[test]
    fn a_rejected_record_does_not_set_the_time_span() {
        let dir = tempfile::tempdir().unwrap();
        let mut a = archive(dir.path()).with_roll_span(Duration::from_nanos(10)).unwrap();
        a.push(&frame("ff", 0, 0)).unwrap();
        // a bad record far in the future: rolls (its span is later) but is rejected …
        let bad = TaxelFrame::new(SensorId::new("ff"), Timestamp(1_000_000), 1, vec![1.0]);
        assert!(matches!(a.push(&bad), Err(Error::Record { .. })));
        // … and the next file's span comes from its first accepted record, so time rolling goes on
        for (seq, t) in [(2, 12), (3, 15), (4, 21)] {
            a.push(&frame("ff", t, seq)).unwrap();
        }
        let files = a.finish().unwrap();
        assert_eq!(files.len(), 3, "[0] [12, 15] [21]: {files:?}");
    }

    #[test]
    fn existing_files_are_never_overwritten() {
        let dir = tempfile::tempdir().unwrap();
        fs::write(dir.path().join("part-000004.parquet"), b"old").unwrap();
        fs::write(dir.path().join(".part-000007.parquet.partial"), b"crashed").unwrap();
        fs::write(dir.path().join("other-000009.parquet"), b"other prefix").unwrap();
        let mut a = archive(dir.path());
        a.push(&frame("ff", 0, 0)).unwrap();
        assert_eq!(a.finish().unwrap(), [dir.path().join("part-000008.parquet")]);
        assert_eq!(fs::read(dir.path().join("part-000004.parquet")).unwrap(), b"old");
    }

    #[test]
    fn a_rejected_record_keeps_the_archive_usable_and_leaves_no_empty_file() {
        let dir = tempfile::tempdir().unwrap();
        let mut a = archive(dir.path()).with_partitioning(Partitioning::Sensor).unwrap();
        let bad = TaxelFrame::new(SensorId::new("th"), Timestamp(0), 0, vec![1.0]);
        assert!(matches!(a.push(&bad), Err(Error::Record { .. })));
        let unnamed = TaxelFrame::new(SensorId::new(""), Timestamp(0), 0, vec![1.0, 2.0]);
        assert!(matches!(a.push(&unnamed), Err(Error::Record { .. })));
        a.push(&frame("ff", 0, 0)).unwrap();
        assert_eq!(a.rows(), 1);
        assert_eq!(a.finish().unwrap(), [dir.path().join("sensor=ff/part-000000.parquet")]);
        assert_eq!(fs::read_dir(dir.path().join("sensor=th")).unwrap().count(), 0, "no file for th");
    }

    #[test]
    fn an_empty_archive_writes_no_file() {
        let dir = tempfile::tempdir().unwrap();
        assert!(archive(dir.path()).finish().unwrap().is_empty());
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0, "the probe file is gone");
    }

    #[test]
    fn sinks_and_archives_are_interchangeable_record_sinks() {
        let dir = tempfile::tempdir().unwrap();
        let shape = FrameShape::unnamed(2).unwrap();
        let sinks: Vec<Box<dyn RecordSink<TaxelFrame>>> = vec![
            Box::new(ParquetSink::try_new(dir.path().join("one.parquet"), shape.clone()).unwrap()),
            Box::new(archive(&dir.path().join("many")).with_roll_rows(2).unwrap()),
        ];
        let mut done = Vec::new();
        for mut s in sinks {
            for k in 0..3 {
                s.push(&frame("ff", k, k as u64)).unwrap();
            }
            s.set_metadata("k".into(), "v".into());
            assert_eq!(s.rows(), 3);
            done.push(s.finish().unwrap().len());
        }
        assert_eq!(done, [1, 2]);
    }

    #[test]
    fn every_output_type_can_be_archived() {
        fn archivable<T: ArrowRecord + HasSensor + Timed + Send + 'static>() {
            let _ = blocking_archive_is_available::<T>;
        }
        fn blocking_archive_is_available<T: ArrowRecord + HasSensor + Timed + Send + 'static>(
            a: ParquetArchive<T>,
        ) -> crate::BlockingArchive<T> {
            crate::blocking_archive(a, 1)
        }
        archivable::<TaxelFrame>();
        archivable::<gradtac_stages::EventBatch>();
        archivable::<gradtac_stages::window::WindowAggregate>();
        archivable::<gradtac_stages::interpolate::Surface>();
        archivable::<gradtac_stages::contour::ContourFrame>();
        archivable::<gradtac_stages::track::TrackPoint>();
    }

    #[test]
    fn archive_can_move_to_a_blocking_thread() {
        fn send<T: Send + 'static>() {}
        send::<ParquetArchive<TaxelFrame>>();
    }
}
