//! Parquet sink: any [`ArrowRecord`] type to one zstd-compressed Parquet file, written under
//! a temporary name and renamed only when finished.
//!
//! The synchronous core (arrow-rs style): [`ParquetSink::try_new`] validates and creates the
//! temporary file, `with_*` set options, [`push`](ParquetSink::push) appends one record,
//! [`finish`](ParquetSink::finish) completes the file. An async pipeline feeds it from its
//! consumer loop (or from `spawn_blocking`); the sink does no I/O except when a batch is full.
//!
//! # Crash safety
//! Rows go to `<name>.partial` beside the target (`out/frames.parquet` →
//! `out/frames.parquet.partial`). Only [`finish`](ParquetSink::finish) writes the footer,
//! `fsync`s the file, renames it to the final name (atomic on one file system, replacing an
//! older file) and `fsync`s the directory. So the final name either does not exist or holds
//! a complete file:
//! - [`abort`](ParquetSink::abort) (on a pipeline error) flushes what was pushed, writes the
//!   footer and leaves a valid, readable file under the `.partial` name;
//! - dropping the sink without `finish` (a panic, a crash) leaves the `.partial` file,
//!   possibly without a footer, and never the final name.
//!
//! # Memory
//! Records are buffered in Arrow builders and handed to [`ArrowWriter`] every
//! `min(row_group_size, 8192)` rows; the writer keeps the current row group encoded and
//! compressed in memory until it holds `row_group_size` rows. Memory is bounded by one row
//! group, whatever the length of the stream — and for wide records (surfaces) by
//! [`MAX_BATCH_BYTES`] of buffered records and [`MAX_ROW_GROUP_BYTES`] of row group, whatever
//! `row_group_size` says (a row group is closed early when it reaches that size).
//!
//! # Writer thread
//! By default the pushing thread also encodes and compresses: every
//! `min(row_group_size, 8192)` records a [`push`](ParquetSink::push) hands a batch to the
//! Parquet writer, and one that fills a row group compresses it there (milliseconds). With
//! [`with_writer_thread`](ParquetSink::with_writer_thread) a thread of the sink's own does
//! that work and `push` only appends and hands over (the files are the same, byte for byte);
//! `gradtac run` uses it for its outputs.
//!
//! # Metadata
//! The file's key-value metadata holds `gradtac.version` (this crate's version),
//! `gradtac.schema` ([`ArrowRecord::SCHEMA_ID`], e.g. `frame/2`), the Arrow schema (key
//! `ARROW:schema`, written by `parquet`), and every pair given with
//! [`with_metadata`](ParquetSink::with_metadata) (the CLI adds `gradtac.scene` and
//! `gradtac.layout`). Schemas are documented in `docs/schemas.md`.
//!
//! # Times
//! Time columns are `Duration(ns)` by default (times relative to the source's own origin);
//! [`with_time_base`](ParquetSink::with_time_base)`(TimeBase::Utc)` makes them
//! `Timestamp(ns, "UTC")` for sources on the Unix epoch (see [`TimeBase`]).
//!
//! A directory of files rolled by size or time and partitioned by sensor is written by
//! [`ParquetArchive`](crate::archive::ParquetArchive), one `ParquetSink` per open file.
//!
//! ```
//! use gradtac_io::{FrameShape, ParquetSink};
//! use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
//!
//! let dir = tempfile::tempdir().unwrap();
//! let mut sink = ParquetSink::<TaxelFrame>::try_new(dir.path().join("f.parquet"), FrameShape::unnamed(2).unwrap())
//!     .unwrap()
//!     .with_row_group_size(1000)
//!     .unwrap()
//!     .with_metadata("gradtac.scene", "demo");
//! sink.push(&TaxelFrame::new(SensorId::new("ff"), Timestamp(0), 0, vec![1.0, 2.0])).unwrap();
//! let path = sink.finish().unwrap();
//! assert!(path.ends_with("f.parquet") && path.exists());
//! ```

use crate::records::{arrow_error, ArrowRecord, RecordBuilder, TimeBase, SCHEMA_KEY};
use crate::{Error, Result};
use arrow_schema::SchemaRef;
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use parquet::schema::types::ColumnPath;
use std::fmt;
use std::fs::{self, File};
use std::path::{Path, PathBuf};
use std::sync::Arc;

mod writer_thread;
use writer_thread::WriterThread;

/// Key of the writing crate's version in the file's key-value metadata.
pub const VERSION_KEY: &str = "gradtac.version";
/// Rows per row group unless [`ParquetSink::with_row_group_size`] says otherwise.
pub const DEFAULT_ROW_GROUP_SIZE: usize = 65_536;
/// The zstd level unless [`ParquetSink::with_zstd_level`] says otherwise.
pub const DEFAULT_ZSTD_LEVEL: i32 = 3;
/// The suffix of the temporary file.
pub const PARTIAL_SUFFIX: &str = ".partial";
/// Largest batch handed to the Parquet writer at once.
const MAX_BATCH_ROWS: usize = 8192;
/// Most bytes of records buffered in the Arrow builder (estimated from the schema's fixed
/// widths): wide records (surfaces of 1024² points are 8 MiB each) go to the writer in
/// smaller batches, so the buffer never holds 8192 of them.
pub const MAX_BATCH_BYTES: usize = 32 << 20;
/// Most bytes of a row group the Parquet writer may hold in memory before it is closed,
/// whatever `row_group_size` says: memory stays bounded for wide records.
pub const MAX_ROW_GROUP_BYTES: usize = 128 << 20;

/// Bytes one row of `schema` takes at least (fixed-width columns; 16 per string or list).
fn row_bytes(schema: &arrow_schema::Schema) -> usize {
    use arrow_schema::DataType;
    fn width(dt: &DataType) -> usize {
        match dt {
            DataType::FixedSizeList(f, n) => (*n).max(0) as usize * width(f.data_type()),
            DataType::Struct(fs) => fs.iter().map(|f| width(f.data_type())).sum(),
            other => other.primitive_width().unwrap_or(16),
        }
    }
    schema.fields().iter().map(|f| width(f.data_type())).sum::<usize>().max(1)
}

/// The Parquet encoder: on the pushing thread, or on a thread of its own.
enum Writer {
    Inline(Box<ArrowWriter<File>>),
    Thread(WriterThread),
}

/// Writes records of type `T` to a Parquet file (see the [module documentation](self)).
#[must_use = "a sink writes nothing final until `finish` is called"]
pub struct ParquetSink<T: ArrowRecord> {
    path: PathBuf,
    partial: PathBuf,
    file: Option<File>,
    writer: Option<Writer>,
    /// Encode and write on a thread of its own ([`with_writer_thread`](Self::with_writer_thread)).
    writer_thread: bool,
    builder: T::Builder,
    shape: T::Shape,
    time: TimeBase,
    /// The columns of the records' schema that the file keeps (all unless
    /// [`without_column`](ParquetSink::without_column) dropped one).
    projection: Option<Vec<usize>>,
    /// The file's schema (the records' schema, projected).
    schema: SchemaRef,
    row_group_size: usize,
    /// Rows per batch handed to the writer: `MAX_BATCH_ROWS`, fewer for wide records.
    batch_rows: usize,
    zstd_level: i32,
    metadata: Vec<(String, String)>,
    rows: u64,
    failed: bool,
}

impl<T: ArrowRecord> fmt::Debug for ParquetSink<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ParquetSink")
            .field("path", &self.path)
            .field("schema", &T::SCHEMA_ID)
            .field("row_group_size", &self.row_group_size)
            .field("zstd_level", &self.zstd_level)
            .field("metadata", &self.metadata)
            .field("rows", &self.rows)
            .field("failed", &self.failed)
            .finish_non_exhaustive()
    }
}

/// `<dir>/<name>.partial` for `<dir>/<name>`.
pub fn partial_path(path: &Path) -> Option<PathBuf> {
    let name = path.file_name()?;
    let mut partial = name.to_os_string();
    partial.push(PARTIAL_SUFFIX);
    Some(path.with_file_name(partial))
}

impl<T: ArrowRecord> ParquetSink<T> {
    /// A sink that will write `path`; creates (or truncates) `<path>.partial` now, so an
    /// unwritable directory fails here. The parent directory must exist. `shape` fixes the
    /// schema (e.g. the taxel names of frames).
    pub fn try_new(path: impl AsRef<Path>, shape: T::Shape) -> Result<Self> {
        let path = path.as_ref().to_path_buf();
        let partial = partial_path(&path)
            .ok_or_else(|| Error::InvalidConfig(format!("output path {} has no file name", path.display())))?;
        Self::try_new_with_temp(path, partial, shape)
    }

    /// Like [`try_new`](Self::try_new), with rows written to `temp` (instead of
    /// `<path>.partial`) until [`finish`](Self::finish) renames it to `path`. `temp` must be
    /// on the same file system as `path` (the rename is atomic only there) and differ from
    /// it. [`ParquetArchive`](crate::archive::ParquetArchive) uses a hidden temporary name
    /// (`.part-000003.parquet.partial`) that dataset readers skip.
    pub fn try_new_with_temp(path: impl AsRef<Path>, temp: impl AsRef<Path>, shape: T::Shape) -> Result<Self> {
        let (path, partial) = (path.as_ref().to_path_buf(), temp.as_ref().to_path_buf());
        if path == partial || path.file_name().is_none() || partial.file_name().is_none() {
            return Err(Error::InvalidConfig(format!(
                "output path {} and temporary path {} must be two different file names",
                path.display(),
                partial.display()
            )));
        }
        if path.is_dir() {
            return Err(Error::InvalidConfig(format!("output path {} is a directory", path.display())));
        }
        check_replaceable(&partial)?;
        let file = File::create(&partial).map_err(|source| Error::Io { path: partial.clone(), source })?;
        let time = TimeBase::default();
        let schema = T::schema(&shape, time);
        let batch_rows = (MAX_BATCH_BYTES / row_bytes(&schema)).clamp(1, MAX_BATCH_ROWS);
        Ok(ParquetSink {
            batch_rows,
            builder: T::builder(&shape, time, MAX_BATCH_ROWS.min(DEFAULT_ROW_GROUP_SIZE).min(batch_rows)),
            shape,
            time,
            projection: None,
            path,
            partial,
            file: Some(file),
            writer: None,
            writer_thread: false,
            schema,
            row_group_size: DEFAULT_ROW_GROUP_SIZE,
            zstd_level: DEFAULT_ZSTD_LEVEL,
            metadata: vec![
                (VERSION_KEY.to_string(), env!("CARGO_PKG_VERSION").to_string()),
                (SCHEMA_KEY.to_string(), T::SCHEMA_ID.to_string()),
            ],
            rows: 0,
            failed: false,
        })
    }

    /// Rows per row group (≥ 1; default [`DEFAULT_ROW_GROUP_SIZE`]). Every row group but
    /// the last holds exactly this many rows. Takes effect only before the first batch
    /// reaches the writer (the first `min(rows, 8192)` pushes); set it right after
    /// [`try_new`](Self::try_new).
    pub fn with_row_group_size(mut self, rows: usize) -> Result<Self> {
        check_row_group_size(rows)?;
        if self.writer.is_some() {
            return Err(Error::InvalidConfig("row_group_size must be set before writing starts".into()));
        }
        self.row_group_size = rows;
        Ok(self)
    }

    /// The [`TimeBase`] of the time columns (default [`TimeBase::Relative`]: `Duration(ns)`;
    /// [`TimeBase::Utc`]: `Timestamp(ns, "UTC")`). Before the first record.
    pub fn with_time_base(mut self, time: TimeBase) -> Result<Self> {
        if self.rows > 0 || self.writer.is_some() {
            return Err(Error::InvalidConfig("the time base must be set before the first record".into()));
        }
        let keep: Option<Vec<String>> =
            self.projection.as_ref().map(|_| self.schema.fields().iter().map(|f| f.name().clone()).collect());
        self.time = time;
        let full = T::schema(&self.shape, time);
        self.builder = T::builder(&self.shape, time, MAX_BATCH_ROWS.min(self.row_group_size).min(self.batch_rows));
        self.schema = full.clone();
        if let Some(keep) = keep {
            let indices: Vec<usize> = keep.iter().filter_map(|n| full.index_of(n).ok()).collect();
            self.schema = Arc::new(full.project(&indices).map_err(|e| arrow_error(T::SCHEMA_ID, e))?);
            self.projection = Some(indices);
        }
        Ok(self)
    }

    /// The time base of the time columns.
    pub fn time_base(&self) -> TimeBase {
        self.time
    }

    /// Leave column `name` out of the file (an archive's partition column, whose value is in
    /// the directory name). Before the first record; the column must exist and not be the
    /// only one.
    pub fn without_column(mut self, name: &str) -> Result<Self> {
        if self.rows > 0 || self.writer.is_some() {
            return Err(Error::InvalidConfig("columns must be chosen before the first record".into()));
        }
        let Ok(drop) = self.schema.index_of(name) else {
            return Err(Error::InvalidConfig(format!("schema {} has no column {name:?}", T::SCHEMA_ID)));
        };
        if self.schema.fields().len() == 1 {
            return Err(Error::InvalidConfig(format!("column {name:?} is the only column of {}", T::SCHEMA_ID)));
        }
        let full = T::schema(&self.shape, self.time);
        let indices: Vec<usize> = self
            .schema
            .fields()
            .iter()
            .enumerate()
            .filter(|&(i, _)| i != drop)
            .filter_map(|(_, f)| full.index_of(f.name()).ok())
            .collect();
        self.schema = Arc::new(full.project(&indices).map_err(|e| arrow_error(T::SCHEMA_ID, e))?);
        self.projection = Some(indices);
        Ok(self)
    }

    /// The zstd compression level: any level zstd accepts, 1 fastest … 22 smallest (default
    /// [`DEFAULT_ZSTD_LEVEL`]; 0 means zstd's own default).
    /// Set it before writing starts, like [`with_row_group_size`](Self::with_row_group_size).
    pub fn with_zstd_level(mut self, level: i32) -> Result<Self> {
        check_zstd_level(level)?;
        if self.writer.is_some() {
            return Err(Error::InvalidConfig("zstd level must be set before writing starts".into()));
        }
        self.zstd_level = level;
        Ok(self)
    }

    /// Encode, compress and write on a thread of its own (default `false`: on the thread that
    /// pushes). Set it before writing starts, like
    /// [`with_row_group_size`](Self::with_row_group_size).
    ///
    /// [`push`](Self::push) then only appends to the Arrow builders and, every
    /// `min(row_group_size, 8192)` records, finishes a batch and hands it over (a channel of
    /// one slot: it waits only while the thread is still busy with the batch before the
    /// previous one). The thread encodes the batch, closes row groups as they fill, and on
    /// [`finish`](Self::finish) / [`abort`](Self::abort) writes the footer and `fsync`s. Use it
    /// where the pusher must not stall — a live pipeline, whose pushing thread would
    /// otherwise spend milliseconds compressing each full row group between two frames — or
    /// to overlap encoding with computing on a machine with a spare core. Memory grows by at
    /// most two batches. Files are the same as without it, byte for byte.
    ///
    /// Errors of the thread (a full disk) surface at the next [`push`](Self::push) that hands
    /// it a batch, or at `finish` / `abort`; the sink is then failed as after an inline write
    /// error. [`estimated_size`](Self::estimated_size) counts the batches the thread has
    /// written, not those still in the channel or being written (up to two more batches).
    /// Dropping the sink waits for the thread to stop and leaves the `.partial` file as it
    /// is, as without it.
    pub fn with_writer_thread(mut self, on: bool) -> Result<Self> {
        if self.writer.is_some() {
            return Err(Error::InvalidConfig("the writer thread must be chosen before writing starts".into()));
        }
        self.writer_thread = on;
        Ok(self)
    }

    /// Add a key-value pair to the file's metadata (written with the footer, so it may be
    /// called any time before [`finish`](Self::finish)). A key given twice keeps the last
    /// value; this can also replace `gradtac.version` / `gradtac.schema`.
    pub fn with_metadata(mut self, key: impl Into<String>, value: impl Into<String>) -> Self {
        self.set_metadata(key, value);
        self
    }

    /// [`with_metadata`](Self::with_metadata) through `&mut`.
    pub fn set_metadata(&mut self, key: impl Into<String>, value: impl Into<String>) {
        set_pair(&mut self.metadata, key.into(), value.into());
    }

    /// The final path ([`finish`](Self::finish) renames to it).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The temporary path rows are written to.
    pub fn partial_path(&self) -> &Path {
        &self.partial
    }

    /// The Arrow schema of the file.
    pub fn schema(&self) -> &SchemaRef {
        &self.schema
    }

    /// Rows accepted so far: what the file holds once finished. A record may be several rows
    /// (an [`EventBatch`](gradtac_stages::EventBatch) is one row per event, none when empty),
    /// so this is not the number of [`push`](Self::push) calls.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// The file's size so far, estimated in bytes: the bytes already written to the file
    /// (the magic and every flushed row group, compressed — exact) plus the Parquet writer's
    /// estimate of the row group it is encoding (compressed pages plus the open page
    /// uncompressed). Records still in the Arrow builder — up to `min(row_group_size, 8192)`
    /// of them, handed to the writer when that many have been pushed — are not counted, nor
    /// is the footer (a few hundred bytes to a few kB). 0 before the first batch.
    ///
    /// With [`with_writer_thread`](Self::with_writer_thread), the estimate is the writer
    /// thread's as of the last batch it wrote.
    pub fn estimated_size(&self) -> u64 {
        match &self.writer {
            None => 0,
            Some(Writer::Inline(w)) => (w.bytes_written() + w.in_progress_size()) as u64,
            Some(Writer::Thread(t)) => t.estimated_size(),
        }
    }

    /// Append one record. A record that does not fit the schema (e.g. a frame with another
    /// taxel count) is rejected with [`Error::Record`] and the sink stays usable; an I/O or
    /// Parquet error leaves the sink failed (later calls fail; [`abort`](Self::abort) to
    /// keep what can be kept).
    pub fn push(&mut self, record: &T) -> Result<()> {
        self.check_usable()?;
        let pending = self.builder.len();
        self.builder.append(record)?;
        self.rows += (self.builder.len() - pending) as u64;
        if self.builder.len() >= self.row_group_size.min(self.batch_rows) {
            self.flush_batch()?;
            // (a writer thread checks this itself after each batch)
            if let Some(Writer::Inline(w)) = self.writer.as_mut() {
                let bounded = bound_row_group(w, &self.partial.display().to_string());
                self.failed |= bounded.is_err();
                bounded?;
            }
        }
        Ok(())
    }

    /// Complete the file: write pending rows and the footer, `fsync`, rename
    /// `<path>.partial` to `<path>` and `fsync` the directory. Returns the final path.
    pub fn finish(mut self) -> Result<PathBuf> {
        self.close()?;
        check_replaceable(&self.path)?;
        fs::rename(&self.partial, &self.path).map_err(|source| Error::Io { path: self.path.clone(), source })?;
        sync_parent(&self.path)?;
        Ok(self.path.clone())
    }

    /// Stop writing: pending rows and the footer are written so the `.partial` file is a
    /// valid Parquet file of every record pushed, and it is left under the temporary name.
    /// Returns that path. Fails (leaving the `.partial` file as it is) if the sink had
    /// already failed or closing fails.
    pub fn abort(mut self) -> Result<PathBuf> {
        self.close()?;
        Ok(self.partial.clone())
    }

    fn check_usable(&self) -> Result<()> {
        if self.failed {
            return Err(arrow_error(self.partial.display().to_string(), "an earlier write to this file failed"));
        }
        Ok(())
    }

    fn writer(&mut self) -> Result<&mut Writer> {
        if self.writer.is_none() {
            let context = self.partial.display().to_string();
            let file = self.file.take().ok_or_else(|| arrow_error(context.as_str(), "no file"))?;
            let level = ZstdLevel::try_new(self.zstd_level).map_err(|e| Error::InvalidConfig(e.to_string()))?;
            let props = writer_properties(&self.schema, level, self.row_group_size);
            let writer = ArrowWriter::try_new(file, self.schema.clone(), Some(props))
                .map_err(|e| arrow_error(context.as_str(), e))?;
            self.writer = Some(if self.writer_thread {
                Writer::Thread(WriterThread::spawn(writer, context)?)
            } else {
                Writer::Inline(Box::new(writer))
            });
        }
        Ok(self.writer.as_mut().expect("set above"))
    }

    fn flush_batch(&mut self) -> Result<()> {
        if self.builder.is_empty() {
            return Ok(());
        }
        let projection = self.projection.clone();
        let result = self.builder.finish().and_then(|batch| {
            let context = self.partial.display().to_string();
            let batch = match &projection {
                Some(p) => batch.project(p).map_err(|e| arrow_error(&context, e))?,
                None => batch,
            };
            match self.writer()? {
                Writer::Inline(w) => w.write(&batch).map_err(|e| arrow_error(context, e)),
                Writer::Thread(t) => t.write(batch),
            }
        });
        self.failed |= result.is_err();
        result
    }

    fn close(&mut self) -> Result<()> {
        self.check_usable()?;
        let result = self.flush_batch().and_then(|()| {
            let context = self.partial.display().to_string();
            let metadata = self.metadata.clone();
            let metadata: Vec<KeyValue> = metadata.into_iter().map(|(k, v)| KeyValue::new(k, v)).collect();
            match self.writer()? {
                Writer::Inline(writer) => finish_writer(writer, metadata, &context),
                Writer::Thread(t) => t.close(metadata),
            }
        });
        self.failed = true; // closed: nothing more may be written
        result
    }
}

/// Close the open row group early when it holds more than [`MAX_ROW_GROUP_BYTES`] (after a
/// batch was written; the pushing thread's writer or the writer thread's).
fn bound_row_group(w: &mut ArrowWriter<File>, context: &str) -> Result<()> {
    if w.in_progress_size() > MAX_ROW_GROUP_BYTES {
        w.flush().map_err(|e| arrow_error(context, e))?;
    }
    Ok(())
}

/// Write the footer with `metadata` and `fsync` the file (`context` names it in errors).
fn finish_writer(w: &mut ArrowWriter<File>, metadata: Vec<KeyValue>, context: &str) -> Result<()> {
    for kv in metadata {
        w.append_key_value_metadata(kv);
    }
    w.finish().map_err(|e| arrow_error(context, e))?;
    w.inner().sync_all().map_err(|source| Error::Io { path: PathBuf::from(context), source })
}

/// The writer's settings: zstd at `level`, row groups of `row_group_size` rows, and
/// dictionary encoding only for the string columns (`sensor`, `state`, `class`, …: a few
/// distinct values each). Numeric and time columns are written plain: their values are
/// mostly distinct (times, sequence numbers, positions, surface values), where a dictionary
/// costs a hash per value and saves nothing. Encodings do not change what a reader gets.
fn writer_properties(schema: &arrow_schema::Schema, level: ZstdLevel, row_group_size: usize) -> WriterProperties {
    use arrow_schema::DataType;
    let mut props = WriterProperties::builder()
        .set_compression(Compression::ZSTD(level))
        .set_max_row_group_row_count(Some(row_group_size))
        .set_dictionary_enabled(false);
    for f in schema.fields() {
        if matches!(f.data_type(), DataType::Utf8 | DataType::LargeUtf8 | DataType::Utf8View | DataType::Dictionary(..))
        {
            props = props.set_column_dictionary_enabled(ColumnPath::from(f.name().as_str()), true);
        }
    }
    props.build()
}

/// Checks a row-group size (at least 1 row); shared with
/// [`ParquetArchive`](crate::archive::ParquetArchive).
pub fn check_row_group_size(rows: usize) -> Result<()> {
    if rows == 0 {
        return Err(Error::InvalidConfig("row_group_size must be at least 1".into()));
    }
    Ok(())
}

/// Checks a zstd level (any level zstd accepts); shared with
/// [`ParquetArchive`](crate::archive::ParquetArchive).
pub fn check_zstd_level(level: i32) -> Result<()> {
    ZstdLevel::try_new(level).map_err(|e| Error::InvalidConfig(format!("zstd level {level}: {e}")))?;
    Ok(())
}

/// Sets `key` to `value` in key-value `metadata`, in place when the key is there already (a key
/// given twice keeps the last value), appended otherwise.
pub(crate) fn set_pair(metadata: &mut Vec<(String, String)>, key: String, value: String) {
    match metadata.iter_mut().find(|(k, _)| *k == key) {
        Some(kv) => kv.1 = value,
        None => metadata.push((key, value)),
    }
}

/// Refuse to replace (by rename or truncation) anything at `path` but a regular file or a
/// symbolic link to one: a device (`/dev/null`), a FIFO, a socket or a directory is never
/// replaced, whoever runs the program.
pub fn check_replaceable(path: &Path) -> Result<()> {
    let refuse = |what: &str| {
        Err(Error::InvalidConfig(format!(
            "{} exists and is {what}; refusing to replace it with an output file",
            path.display()
        )))
    };
    match fs::symlink_metadata(path) {
        Err(_) => Ok(()),
        Ok(m) if m.is_file() => Ok(()),
        Ok(m) if m.file_type().is_symlink() => match fs::metadata(path) {
            Ok(t) if t.is_file() => Ok(()),
            Ok(_) => refuse("a symbolic link to something other than a regular file"),
            Err(_) => refuse("a dangling symbolic link"),
        },
        Ok(m) if m.is_dir() => refuse("a directory"),
        Ok(_) => refuse("not a regular file (a device, FIFO or socket)"),
    }
}

/// `fsync` the directory holding `path`, so a rename in it is durable (Unix only).
fn sync_parent(path: &Path) -> Result<()> {
    #[cfg(unix)]
    {
        let parent = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        File::open(parent)
            .and_then(|d| d.sync_all())
            .map_err(|source| Error::Io { path: parent.to_path_buf(), source })?;
    }
    #[cfg(not(unix))]
    let _ = path;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::FrameShape;
    use gradtac_stream::{SensorId, TaxelFrame, Timestamp};

    #[test]
    fn partial_name_is_beside_the_target() {
        assert_eq!(partial_path(Path::new("out/a.parquet")).unwrap(), Path::new("out/a.parquet.partial"));
        assert_eq!(partial_path(Path::new("a")).unwrap(), Path::new("a.partial"));
        assert!(partial_path(Path::new("/")).is_none());
    }

    #[test]
    fn options_are_validated() {
        let dir = tempfile::tempdir().unwrap();
        let shape = FrameShape::unnamed(1).unwrap();
        let new = || ParquetSink::<TaxelFrame>::try_new(dir.path().join("x.parquet"), shape.clone()).unwrap();
        assert!(new().with_row_group_size(0).is_err());
        assert!(new().with_zstd_level(23).is_err());
        assert!(new().with_zstd_level(19).is_ok());
        let e = ParquetSink::<TaxelFrame>::try_new(dir.path(), shape.clone()).unwrap_err();
        assert!(e.to_string().contains("is a directory"), "{e}");
        let e = ParquetSink::<TaxelFrame>::try_new(dir.path().join("no/such/dir/x.parquet"), shape).unwrap_err();
        assert!(matches!(e, Error::Io { .. }), "{e}");
    }

    /// `rows()` counts rows written, not records pushed: an event batch is one row per event
    /// (the run summary prints it), and the finished file holds exactly that many.
    #[test]
    fn rows_counts_rows_not_records() {
        use gradtac_stages::{EventBatch, TactileEvent};
        let dir = tempfile::tempdir().unwrap();
        let shape = crate::records::EventShape::unnamed(3).unwrap();
        let mut sink = ParquetSink::<EventBatch>::try_new(dir.path().join("e.parquet"), shape).unwrap();
        let batch = |seq: u64, taxels: &[u16]| EventBatch {
            sensor: SensorId::new("ff"),
            time: Timestamp(seq as i64),
            seq,
            taxels: 3,
            events: taxels
                .iter()
                .map(|&taxel| TactileEvent { time: Timestamp(seq as i64), taxel, polarity: 1 })
                .collect(),
        };
        for (seq, taxels) in [(0, &[0u16, 1, 2][..]), (1, &[][..]), (2, &[2, 0][..])] {
            sink.push(&batch(seq, taxels)).unwrap();
        }
        assert_eq!(sink.rows(), 5);
        let path = sink.finish().unwrap();
        let file = std::fs::File::open(path).unwrap();
        let meta = parquet::file::reader::SerializedFileReader::new(file).unwrap();
        use parquet::file::reader::FileReader;
        assert_eq!(meta.metadata().file_metadata().num_rows(), 5);
    }

    #[test]
    fn rejected_record_keeps_sink_usable() {
        let dir = tempfile::tempdir().unwrap();
        let mut sink =
            ParquetSink::<TaxelFrame>::try_new(dir.path().join("x.parquet"), FrameShape::unnamed(2).unwrap()).unwrap();
        let f = |n| TaxelFrame::new(SensorId::new("ff"), Timestamp(0), 0, vec![0.0; n]);
        sink.push(&f(2)).unwrap();
        assert!(matches!(sink.push(&f(3)), Err(Error::Record { .. })));
        sink.push(&f(2)).unwrap();
        assert_eq!(sink.rows(), 2);
        let path = sink.finish().unwrap();
        assert!(path.exists());
        assert!(!dir.path().join("x.parquet.partial").exists());
    }

    #[test]
    fn a_chosen_temporary_name_is_used_and_validated() {
        let dir = tempfile::tempdir().unwrap();
        let shape = FrameShape::unnamed(1).unwrap();
        let (path, temp) = (dir.path().join("a.parquet"), dir.path().join(".a.tmp"));
        let e = ParquetSink::<TaxelFrame>::try_new_with_temp(&path, &path, shape.clone()).unwrap_err();
        assert!(e.to_string().contains("two different file names"), "{e}");
        let mut sink = ParquetSink::<TaxelFrame>::try_new_with_temp(&path, &temp, shape).unwrap();
        assert_eq!(sink.partial_path(), temp);
        sink.push(&TaxelFrame::new(SensorId::new("ff"), Timestamp(0), 0, vec![1.0])).unwrap();
        assert!(temp.exists() && !path.exists());
        assert_eq!(sink.finish().unwrap(), path);
        assert!(path.exists() && !temp.exists());
    }

    /// A FIFO made with `mkfifo` (None where the tool is missing).
    fn fifo(path: &Path) -> Option<()> {
        let ok = std::process::Command::new("mkfifo").arg(path).status().ok()?.success();
        ok.then_some(())
    }

    #[test]
    fn finish_never_renames_over_a_fifo_a_directory_or_a_link_to_a_device() {
        let dir = tempfile::tempdir().unwrap();
        let shape = FrameShape::unnamed(1).unwrap();
        let frame = TaxelFrame::new(SensorId::new("ff"), Timestamp(0), 0, vec![1.0]);
        // the target turns into something else while the run writes its .partial
        let mut targets: Vec<(PathBuf, &str)> = Vec::new();
        let d = dir.path().join("is-a-dir.parquet");
        targets.push((d, "a directory"));
        let f = dir.path().join("fifo.parquet");
        if fifo(&f).is_some() {
            targets.push((f, "not a regular file"));
        }
        #[cfg(unix)]
        {
            let l = dir.path().join("null.parquet");
            std::os::unix::fs::symlink("/dev/null", &l).unwrap();
            targets.push((l, "symbolic link to something other than a regular file"));
        }
        for (path, expect) in targets {
            let mut sink = ParquetSink::<TaxelFrame>::try_new(&path, shape.clone()).unwrap();
            sink.push(&frame).unwrap();
            if expect == "a directory" {
                fs::create_dir(&path).unwrap();
            }
            let e = sink.finish().unwrap_err().to_string();
            assert!(e.contains(expect) && e.contains("refusing to replace"), "{e}");
            let m = fs::symlink_metadata(&path).unwrap();
            assert!(!m.is_file(), "{} was replaced", path.display());
        }
        // a FIFO where the temporary file goes is not opened (that would block) nor replaced
        let p = dir.path().join("t.parquet");
        if fifo(&partial_path(&p).unwrap()).is_some() {
            let e = ParquetSink::<TaxelFrame>::try_new(&p, shape).unwrap_err().to_string();
            assert!(e.contains("refusing to replace"), "{e}");
        }
    }

    #[test]
    fn wide_records_are_batched_by_bytes() {
        use arrow_schema::{DataType, Field, Schema};
        let wide = Schema::new(vec![
            Field::new("t", DataType::Int64, false),
            Field::new(
                "v",
                DataType::FixedSizeList(Field::new("item", DataType::Float64, false).into(), 1 << 20),
                false,
            ),
        ]);
        assert_eq!(row_bytes(&wide), 8 + 8 * (1 << 20));
        assert_eq!((MAX_BATCH_BYTES / row_bytes(&wide)).clamp(1, MAX_BATCH_ROWS), 3);
        let narrow = Schema::new(vec![Field::new("t", DataType::Int64, false)]);
        assert_eq!((MAX_BATCH_BYTES / row_bytes(&narrow)).clamp(1, MAX_BATCH_ROWS), MAX_BATCH_ROWS);
    }

    #[test]
    fn estimated_size_grows_with_each_batch_and_bounds_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.parquet");
        let mut sink = ParquetSink::<TaxelFrame>::try_new(&path, FrameShape::unnamed(8).unwrap())
            .unwrap()
            .with_row_group_size(100)
            .unwrap();
        assert_eq!(sink.estimated_size(), 0);
        let mut last = 0;
        for k in 0..1000u64 {
            let values = (0..8).map(|i| ((k * 8 + i) as f64).sqrt()).collect();
            sink.push(&TaxelFrame::new(SensorId::new("ff"), Timestamp(k as i64), k, values)).unwrap();
            let now = sink.estimated_size();
            assert!(now >= last, "never shrinks");
            if (k + 1) % 100 == 0 {
                assert!(now > last, "a batch reached the writer at row {k}");
            }
            last = now;
        }
        let path = sink.finish().unwrap();
        let size = fs::metadata(&path).unwrap().len();
        // Every row group is flushed (1000 rows / 100): the estimate is the bytes written,
        // the file adds only the footer.
        assert!(size >= last && size < last + 16 * 1024, "file {size} bytes, estimate {last}");
    }

    /// A file written through the writer thread is the inline file, byte for byte (several
    /// row groups and batches, a partial last one); `abort` leaves a valid `.partial`; a
    /// dropped sink's thread is gone when the drop returns and the final name never exists.
    #[test]
    fn writer_thread_writes_the_same_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let frames: Vec<TaxelFrame> = (0..20_000u64)
            .map(|k| {
                let values = (0..6).map(|i| ((k * 6 + i) as f64).sqrt().sin()).collect();
                TaxelFrame::new(SensorId::new(if k % 3 == 0 { "th" } else { "ff" }), Timestamp(k as i64), k, values)
            })
            .collect();
        let write = |name: &str, thread: bool, end: &str| {
            let mut sink = ParquetSink::<TaxelFrame>::try_new(dir.path().join(name), FrameShape::unnamed(6).unwrap())
                .unwrap()
                .with_row_group_size(7_000)
                .unwrap()
                .with_writer_thread(thread)
                .unwrap()
                .with_metadata("k", "v");
            for f in &frames {
                sink.push(f).unwrap();
            }
            assert_eq!(sink.rows(), frames.len() as u64);
            let p = match end {
                "finish" => sink.finish().unwrap(),
                "abort" => sink.abort().unwrap(),
                _ => {
                    drop(sink);
                    partial_path(&dir.path().join(name)).unwrap()
                }
            };
            fs::read(p).unwrap()
        };
        let inline = write("inline.parquet", false, "finish");
        let threaded = write("thread.parquet", true, "finish");
        assert!(inline.len() > 1000);
        assert!(inline == threaded, "the writer thread changed the file");
        assert!(
            !dir.path().join("inline.parquet.partial").exists() && !dir.path().join("thread.parquet.partial").exists()
        );
        // abort: the same valid file, under the temporary name
        assert!(write("aborted.parquet", true, "abort") == write("aborted_inline.parquet", false, "abort"));
        assert!(!dir.path().join("aborted.parquet").exists());
        // drop: whatever was written stays under the temporary name, no footer promised
        let dropped = write("dropped.parquet", true, "drop");
        assert!(dropped.starts_with(b"PAR1") && !dir.path().join("dropped.parquet").exists());
        // chosen after writing started: refused
        let mut sink =
            ParquetSink::<TaxelFrame>::try_new(dir.path().join("late.parquet"), FrameShape::unnamed(6).unwrap())
                .unwrap()
                .with_row_group_size(1)
                .unwrap();
        sink.push(&frames[0]).unwrap();
        assert!(sink.with_writer_thread(true).is_err());
    }

    #[test]
    fn sink_can_move_to_a_blocking_thread() {
        fn send<T: Send + 'static>() {}
        send::<ParquetSink<TaxelFrame>>();
    }

    #[test]
    fn metadata_keys_replace() {
        let dir = tempfile::tempdir().unwrap();
        let sink = ParquetSink::<TaxelFrame>::try_new(dir.path().join("x.parquet"), FrameShape::unnamed(2).unwrap())
            .unwrap()
            .with_metadata("k", "1")
            .with_metadata("k", "2");
        assert_eq!(sink.metadata.iter().filter(|(k, _)| k == "k").count(), 1);
        assert_eq!(sink.metadata.last().unwrap().1, "2");
    }
}
