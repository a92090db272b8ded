//! Reading gradtac Parquet files and archives into one table: footer checks, decimation,
//! typed column accessors that take every schema version (`docs/schemas.md`), and the
//! `--sensor` / `--from` / `--to` row filters.

use super::*;

/// What [`read_table`] read: one file, or the files of an archive directory as one table.
pub(super) struct Table {
    pub(super) schema_id: String,
    /// Key-value metadata: the file's, or for an archive the union over its files (the first
    /// file holding a key gives its value).
    pub(super) kv: HashMap<String, String>,
    pub(super) schema: SchemaRef,
    /// The rows read (all, or every `stride`-th), in file order.
    pub(super) batches: Vec<RecordBatch>,
    /// Rows in the file (in all the archive's files).
    pub(super) total_rows: usize,
    /// Every this many rows were read (`None`: all).
    pub(super) stride: Option<usize>,
    /// For a directory, its Parquet files read, in order (relative to the directory).
    pub(super) files: Option<Vec<PathBuf>>,
}

impl Table {
    pub(super) fn rows(&self) -> usize {
        self.batches.iter().map(RecordBatch::num_rows).sum()
    }

    /// The layout for `sensor`: its own metadata, the file's, or the BioTac SP when `taxels`
    /// (if given) matches its count.
    pub(super) fn layout(&self, sensor: &str, taxels: Option<usize>, notes: &mut Vec<String>) -> Option<Layout> {
        for key in [format!("gradtac.layout.{sensor}"), "gradtac.layout".to_string()] {
            if let Some(csv) = self.kv.get(&key) {
                match Layout::from_csv_reader("layout", csv.as_bytes(), Path::new(&key)) {
                    Ok(l) if taxels.is_none_or(|n| n == l.len()) => return Some(l),
                    Ok(l) => notes.push(format!("{key}: {} taxels, the data has {taxels:?}; ignored", l.len())),
                    Err(e) => notes.push(format!("{key} is not a layout CSV ({e}); ignored")),
                }
            }
        }
        let b = Layout::biotac_sp();
        if taxels.is_none_or(|n| n == b.len()) {
            notes.push(format!("{sensor}: no layout in the file; the built-in BioTac SP layout is drawn"));
            Some(b)
        } else {
            None
        }
    }
}

/// Read a Parquet file, or every finished Parquet file of a directory (an archive) as one
/// table; see [`plot_parquet`].
pub(super) fn read_table(path: &Path) -> R<Table> {
    if path.is_dir() {
        read_archive(path)
    } else {
        read_file(path)
    }
}

/// A Parquet file opened for reading (footer parsed and checked, no rows read yet).
pub(super) struct Opened {
    pub(super) file: std::fs::File,
    pub(super) meta: ArrowReaderMetadata,
    pub(super) kv: HashMap<String, String>,
    pub(super) schema: SchemaRef,
    /// Its `gradtac.schema`, one of [`KNOWN`].
    pub(super) schema_id: String,
    pub(super) rows: usize,
}

/// Open a Parquet file and check that it is a gradtac file of a known schema.
///
/// The footer is parsed by the parquet crate; a panic inside it on a malformed footer (an
/// upstream bug) is contained and reported as this file's error (see
/// [`gradtac_io::contain`]). The row counts of the footer must add up.
pub(super) fn open_parquet(path: &Path) -> R<Opened> {
    let mut file = std::fs::File::open(path).map_err(|e| PlotErr(format!("cannot open: {e}")))?;
    // the footer's lengths and Thrift structure first (bounded work; see parquet_check)
    gradtac_io::parquet_check::check_footer(&mut file).map_err(PlotErr)?;
    let meta = match gradtac_io::contain::contain(|| ArrowReaderMetadata::load(&file, ArrowReaderOptions::new())) {
        Ok(Ok(m)) => m,
        Ok(Err(e)) => return Err(PlotErr(format!("not a readable Parquet file: {e}"))),
        Err(panic) => {
            return Err(PlotErr(format!(
                "not a readable Parquet file (the parquet reader panicked on its footer: {panic})"
            )))
        }
    };
    let fm = meta.metadata().file_metadata();
    let kv: HashMap<String, String> = fm
        .key_value_metadata()
        .map(|v| v.iter().filter_map(|kv| Some((kv.key.clone(), kv.value.clone()?))).collect())
        .unwrap_or_default();
    let schema = meta.schema().clone();
    let schema_id = kv
        .get(gradtac_io::records::SCHEMA_KEY)
        .or_else(|| schema.metadata().get(gradtac_io::records::SCHEMA_KEY))
        .cloned()
        .ok_or_else(|| {
            PlotErr(format!("no `{}` metadata: not a file written by a gradtac sink", gradtac_io::records::SCHEMA_KEY))
        })?;
    if !KNOWN.contains(&schema_id.as_str()) {
        return Err(PlotErr(format!("unknown schema {schema_id:?} (known: {})", KNOWN.join(", "))));
    }
    let rows =
        usize::try_from(fm.num_rows()).map_err(|_| PlotErr(format!("malformed footer: {} rows", fm.num_rows())))?;
    let len = file.metadata().map_err(|e| PlotErr(format!("cannot open: {e}")))?.len();
    let mut in_groups = 0usize;
    for (i, rg) in meta.metadata().row_groups().iter().enumerate() {
        let n = usize::try_from(rg.num_rows())
            .map_err(|_| PlotErr(format!("malformed footer: row group {i} has {} rows", rg.num_rows())))?;
        in_groups = in_groups.saturating_add(n);
        // where the reader will seek: inside the file (the parquet crate asserts non-negative)
        for (j, c) in rg.columns().iter().enumerate() {
            let start = c.dictionary_page_offset().unwrap_or(c.data_page_offset());
            let size = c.compressed_size();
            let end = u64::try_from(start).ok().zip(u64::try_from(size).ok()).and_then(|(a, b)| a.checked_add(b));
            if end.is_none_or(|e| e > len) {
                return Err(PlotErr(format!(
                    "malformed footer: row group {i} column {j} at byte {start} ({size} bytes) lies outside the file \
                     ({len} bytes)"
                )));
            }
        }
    }
    if in_groups != rows {
        return Err(PlotErr(format!("malformed footer: {rows} rows in the file, {in_groups} in its row groups")));
    }
    Ok(Opened { file, meta, kv, schema, schema_id, rows })
}

/// The decimation stride for `total_rows` rows of a table (`None`: read them all). Large
/// tables are decimated while reading (memory stays bounded): every k-th row, k a prime ≥ 11
/// so that rows of up to 10 interleaved sensors are all sampled.
pub(super) fn read_stride(total_rows: usize, schema_id: &str, schema: &SchemaRef) -> Option<usize> {
    let budget = read_budget(schema_id, schema);
    (total_rows > budget).then(|| next_prime(total_rows.div_ceil(budget).max(11)))
}

/// The rows of a file of `rows` rows whose index in the whole table (`first` + the index in
/// the file) is a multiple of `k`.
pub(super) fn every_kth(rows: usize, first: usize, k: usize) -> RowSelection {
    let lead = (k - first % k) % k;
    if lead >= rows {
        return RowSelection::from(vec![RowSelector::skip(rows)]);
    }
    let mut sel = Vec::with_capacity(2 * (rows / k + 2));
    if lead > 0 {
        sel.push(RowSelector::skip(lead));
    }
    let mut i = lead;
    while i < rows {
        sel.push(RowSelector::select(1));
        let skip = (k - 1).min(rows - i - 1);
        if skip > 0 {
            sel.push(RowSelector::skip(skip));
        }
        i += k;
    }
    RowSelection::from(sel)
}

/// Read an opened file's rows: all, or those [`every_kth`] selects; `first` is the index of
/// the file's first row in the whole table.
///
/// Row groups are read one at a time, so an error names its row group; a panic inside the
/// parquet / arrow crates on malformed data (an upstream bug) is contained and reported as
/// that row group's error (see [`gradtac_io::contain`]).
pub(super) fn read_rows(o: Opened, first: usize, stride: Option<usize>) -> R<Vec<RecordBatch>> {
    let mut batches = Vec::new();
    let mut start = 0usize;
    let mut inflated = 0u64;
    for (i, rg) in o.meta.metadata().row_groups().iter().enumerate() {
        let at = |e: String| PlotErr(format!("row group {i}: {e}"));
        let n = rg.num_rows() as usize; // checked non-negative by `open_parquet`
                                        // page headers bounded before the parquet crate reads them (its skip is unbounded)
        let declared = gradtac_io::parquet_check::check_row_group(&mut &o.file, rg).map_err(at)?;
        // a file's pages together decompress to at most 64 × its size (at least 256 MiB)
        inflated = inflated.saturating_add(declared);
        let budget = gradtac_io::parquet_check::file_budget(o.file.metadata().map_or(0, |m| m.len()));
        if inflated > budget {
            return Err(at(format!(
                "its pages and those before declare {inflated} bytes uncompressed, more than the file's budget of \
                 {budget} bytes (64 times its size, at least 256 MiB); refused as a decompression bomb"
            )));
        }
        let file = o.file.try_clone().map_err(|e| at(format!("cannot read: {e}")))?;
        let builder = ParquetRecordBatchReaderBuilder::new_with_metadata(file, o.meta.clone()).with_row_groups(vec![i]);
        let builder = match stride {
            Some(k) => builder.with_row_selection(every_kth(n, first + start, k)),
            None => builder,
        };
        let read = gradtac_io::contain::contain(|| -> std::result::Result<Vec<RecordBatch>, String> {
            let reader = builder.build().map_err(|e| format!("cannot read: {e}"))?;
            reader.collect::<std::result::Result<Vec<_>, _>>().map_err(|e| format!("cannot read rows: {e}"))
        });
        match read {
            Ok(Ok(b)) => batches.extend(b),
            Ok(Err(e)) => return Err(at(e)),
            Err(panic) => return Err(at(format!("malformed data (the parquet reader panicked: {panic})"))),
        }
        start += n;
    }
    Ok(batches)
}

pub(super) fn read_file(path: &Path) -> R<Table> {
    let o = open_parquet(path)?;
    let (schema_id, kv, schema, total_rows) = (o.schema_id.clone(), o.kv.clone(), o.schema.clone(), o.rows);
    let stride = read_stride(total_rows, &schema_id, &schema);
    let batches = read_rows(o, 0, stride)?;
    Ok(Table { schema_id, kv, schema, batches, total_rows, stride, files: None })
}

/// Does a file or directory name mark something dataset readers skip (hidden, or `_`-prefixed
/// like `_SUCCESS`)?
pub(super) fn skipped_name(name: &std::ffi::OsStr) -> bool {
    let b = name.as_encoded_bytes();
    b.first().is_some_and(|c| *c == b'.' || *c == b'_')
}

/// The finished Parquet files under `dir`, recursively, in lexical order of their path
/// components (an archive's write order), relative to `dir`; and how many `.partial` files
/// were skipped. Names starting with `.` or `_` are skipped (files and directories), as are
/// files not ending in `.parquet`; symbolic links to files are followed, to directories not.
pub(super) fn archive_files(dir: &Path) -> R<(Vec<PathBuf>, usize)> {
    fn walk(root: &Path, rel: &Path, files: &mut Vec<PathBuf>, partial: &mut usize) -> R<()> {
        let here = root.join(rel);
        let rd = std::fs::read_dir(&here).map_err(|e| PlotErr(format!("cannot list {}: {e}", here.display())))?;
        let mut entries = rd
            .collect::<std::io::Result<Vec<_>>>()
            .map_err(|e| PlotErr(format!("cannot list {}: {e}", here.display())))?;
        entries.sort_by_key(|e| e.file_name());
        for e in entries {
            let name = e.file_name();
            let path = rel.join(&name);
            let ft = e.file_type().map_err(|err| PlotErr(format!("{}: {err}", path.display())))?;
            if name.as_encoded_bytes().ends_with(gradtac_io::parquet_sink::PARTIAL_SUFFIX.as_bytes()) {
                *partial += 1;
            } else if skipped_name(&name) {
            } else if ft.is_dir() {
                walk(root, &path, files, partial)?;
            } else if (ft.is_file() || (ft.is_symlink() && e.path().is_file()))
                && name.as_encoded_bytes().ends_with(b".parquet")
            {
                files.push(path);
            }
        }
        Ok(())
    }
    let (mut files, mut partial) = (Vec::new(), 0);
    walk(dir, Path::new(""), &mut files, &mut partial)?;
    Ok((files, partial))
}

/// Read every finished Parquet file under `dir` as one table: they must share one
/// `gradtac.schema` and the same columns; decimation counts the rows of all files.
pub(super) fn read_archive(dir: &Path) -> R<Table> {
    let (files, partial) = archive_files(dir)?;
    if files.is_empty() {
        let reason = if partial > 0 {
            let s = if partial == 1 { "" } else { "s" };
            format!(
                "no finished Parquet file to plot, only {partial} unfinished `.partial` file{s} (being written, or \
                 left by a crash)"
            )
        } else if std::fs::read_dir(dir).map(|mut d| d.next().is_none()).unwrap_or(false) {
            "empty directory: no finished Parquet file to plot".to_string()
        } else {
            "no finished Parquet file to plot (`*.parquet`; names starting with `.` or `_` are skipped)".to_string()
        };
        return Err(PlotErr(reason));
    }
    let in_file = |f: &Path, e: PlotErr| PlotErr(format!("{}: {}", f.display(), e.0));
    // Pass 1: footers only — the common schema, the total row count, the merged metadata.
    let mut first: Option<Opened> = None;
    let mut kv = HashMap::new();
    let mut rows = Vec::with_capacity(files.len());
    for f in &files {
        let o = open_parquet(&dir.join(f)).map_err(|e| in_file(f, e))?;
        if let Some(p) = &first {
            let same_columns = p.schema.fields().len() == o.schema.fields().len()
                && p.schema
                    .fields()
                    .iter()
                    .zip(o.schema.fields())
                    .all(|(a, b)| a.name() == b.name() && a.data_type() == b.data_type());
            if o.schema_id != p.schema_id {
                return Err(PlotErr(format!(
                    "{}: schema {} differs from {} of {} (the archive's first file); an archive's files must share one \
                     `gradtac.schema`",
                    f.display(),
                    o.schema_id,
                    p.schema_id,
                    files[0].display()
                )));
            }
            if !same_columns {
                return Err(PlotErr(format!(
                    "{}: schema {} with other columns (or column types) than {} (the archive's first file)",
                    f.display(),
                    o.schema_id,
                    files[0].display()
                )));
            }
        }
        for (k, v) in &o.kv {
            kv.entry(k.clone()).or_insert_with(|| v.clone());
        }
        rows.push(o.rows);
        if first.is_none() {
            first = Some(o);
        }
    }
    let first = first.expect("files is not empty");
    let (schema_id, schema) = (first.schema_id.clone(), first.schema.clone());
    drop(first);
    let total_rows: usize = rows.iter().sum();
    let stride = read_stride(total_rows, &schema_id, &schema);
    // Pass 2: the rows, every k-th of the whole table.
    let mut batches = Vec::new();
    let mut offset = 0;
    for (f, n) in files.iter().zip(&rows) {
        if *n > 0 {
            let o = open_parquet(&dir.join(f)).map_err(|e| in_file(f, e))?;
            if o.rows != *n {
                return Err(in_file(f, PlotErr(format!("changed while read ({n} rows, then {})", o.rows))));
            }
            let read = read_rows(o, offset, stride).map_err(|e| in_file(f, e))?;
            let partition = hive_sensor(f);
            for b in read {
                batches.push(match &partition {
                    Some(sensor) => with_sensor_column(b, sensor).map_err(|e| in_file(f, e))?,
                    None => b,
                });
            }
        }
        offset += n;
    }
    let schema = match (batches.first(), schema.column_with_name(PARTITION)) {
        (Some(b), None) => b.schema(),
        _ => schema,
    };
    Ok(Table { schema_id, kv, schema, batches, total_rows, stride, files: Some(files) })
}

/// The hive partition column of archives.
const PARTITION: &str = gradtac_io::archive::PARTITION_COLUMN;

/// The sensor of a file in a hive partition directory `sensor=<name>` (percent-decoded), the
/// innermost such directory of its path.
pub(super) fn hive_sensor(rel: &Path) -> Option<String> {
    let prefix = format!("{PARTITION}=");
    rel.parent()?.components().rev().find_map(|c| {
        let c = c.as_os_str().to_str()?;
        c.strip_prefix(&prefix).map(percent_decode)
    })
}

/// `%XX` escapes (UTF-8 bytes) decoded; an invalid escape stays as it is.
fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16).map(|d| d as u8);
        match (b[i], b.get(i + 1).copied().and_then(hex), b.get(i + 2).copied().and_then(hex)) {
            (b'%', Some(h), Some(l)) => {
                out.push(h * 16 + l);
                i += 3;
            }
            (c, _, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// `b` with a leading `sensor` column of the partition's value, when the file left it out (the
/// archive default); a file that keeps its own column must agree with its directory.
pub(super) fn with_sensor_column(b: RecordBatch, sensor: &str) -> R<RecordBatch> {
    if let Some(col) = b.column_by_name(PARTITION) {
        let own = strings_of(col).ok_or_else(|| wrong(PARTITION, col))?;
        if let Some(other) = own.iter().find(|s| s.as_str() != sensor) {
            return Err(PlotErr(format!("a row's sensor {other:?} differs from its directory {PARTITION}={sensor}")));
        }
        return Ok(b);
    }
    let schema = b.schema();
    let mut fields: Vec<arrow_schema::FieldRef> =
        vec![std::sync::Arc::new(arrow_schema::Field::new(PARTITION, arrow_schema::DataType::Utf8, false))];
    fields.extend(schema.fields().iter().cloned());
    let mut columns: Vec<ArrayRef> =
        vec![std::sync::Arc::new(arrow_array::StringArray::from(vec![sensor; b.num_rows()]))];
    columns.extend(b.columns().iter().cloned());
    let schema = arrow_schema::Schema::new_with_metadata(fields, schema.metadata().clone());
    RecordBatch::try_new(std::sync::Arc::new(schema), columns).map_err(|e| PlotErr(format!("partition column: {e}")))
}

/// Renames of the columns of older schema versions to the newest names (`docs/schemas.md`).
const RENAMED: [(&str, &str); 8] = [
    ("time_ns", "time"),
    ("start_ns", "start"),
    ("end_ns", "end"),
    ("frame_time_ns", "frame_time"),
    ("onset_ns", "onset"),
    ("first_seen_ns", "first_seen"),
    ("vx_mm_s", "velocity_x_mm_s"),
    ("vy_mm_s", "velocity_y_mm_s"),
];

/// The schema family (`frame`, `event`, …) and version of a schema id.
pub(super) fn family(schema_id: &str) -> (&str, u32) {
    let (name, v) = schema_id.split_once('/').unwrap_or((schema_id, "0"));
    (name, v.parse().unwrap_or(0))
}

/// A table of any known schema version in the newest version's column names, and for
/// `event/1` (0-based taxel indices) taxel numbers counting from 1 as in `event/2`; times stay
/// in whatever Arrow type the file has (`Int64` ns, `Timestamp(ns)`, `Duration(ns)`), read by
/// [`i64s`].
pub(super) fn normalise(mut t: Table) -> R<Table> {
    let (name, version) = family(&t.schema_id);
    let zero_based = name == "event" && version < 2;
    let fix = |b: &RecordBatch| -> R<RecordBatch> {
        let schema = b.schema();
        let mut fields = Vec::with_capacity(b.num_columns());
        let mut columns = Vec::with_capacity(b.num_columns());
        for (f, c) in schema.fields().iter().zip(b.columns()) {
            let new = RENAMED.iter().find(|(old, _)| old == f.name()).map_or(f.name().as_str(), |(_, n)| n);
            let mut c = c.clone();
            if zero_based && f.name() == "taxel" {
                let p = c.as_primitive_opt::<UInt16Type>().ok_or_else(|| wrong("taxel", &c))?;
                let numbers =
                    arrow_array::UInt16Array::from_iter_values(p.values().iter().map(|v| v.saturating_add(1)));
                c = std::sync::Arc::new(numbers);
            }
            fields.push(f.as_ref().clone().with_name(new));
            columns.push(c);
        }
        let schema = arrow_schema::Schema::new_with_metadata(fields, schema.metadata().clone());
        RecordBatch::try_new(std::sync::Arc::new(schema), columns).map_err(|e| PlotErr(format!("{e}")))
    };
    if version < 2 || zero_based {
        t.batches = t.batches.iter().map(fix).collect::<R<_>>()?;
        if let Some(b) = t.batches.first() {
            t.schema = b.schema();
        } else {
            t.schema = fix(&RecordBatch::new_empty(t.schema.clone()))?.schema();
        }
    }
    Ok(t)
}

/// The rows to draw: `options.sensors` (all when empty; a slip file's pair matches by either
/// sensor) and times from `options.from` to `options.to` seconds after the table's first time.
pub(super) fn filter_rows(mut t: Table, options: &PlotOptions, notes: &mut Vec<String>) -> R<Table> {
    if options.sensors.is_empty() && options.from.is_none() && options.to.is_none() {
        return Ok(t);
    }
    let time = ["time", "end"].into_iter().find(|c| t.schema.column_with_name(c).is_some());
    let t0 = match time {
        Some(c) => t.batches.iter().map(|b| i64s(b, c).map(|v| v.into_iter().min())).collect::<R<Vec<_>>>()?,
        None => Vec::new(),
    }
    .into_iter()
    .flatten()
    .min();
    let before = t.rows();
    let mut seen: Vec<String> = Vec::new();
    let mut kept = Vec::with_capacity(t.batches.len());
    for b in &t.batches {
        let mut keep = vec![true; b.num_rows()];
        if !options.sensors.is_empty() {
            let cols: Vec<Vec<String>> = ["sensor", "first", "second"]
                .iter()
                .filter(|c| b.column_by_name(c).is_some())
                .map(|c| strings(b, c))
                .collect::<R<_>>()?;
            for (i, k) in keep.iter_mut().enumerate() {
                let names: Vec<&String> = cols.iter().map(|c| &c[i]).collect();
                for n in &names {
                    if !seen.contains(n) {
                        seen.push((*n).clone());
                    }
                }
                *k &= names.iter().any(|n| options.sensors.contains(n));
            }
        }
        if let (Some(c), Some(t0)) = (time, t0) {
            for (k, v) in keep.iter_mut().zip(i64s(b, c)?) {
                let s = secs(v, t0);
                *k &= options.from.is_none_or(|f| s >= f) && options.to.is_none_or(|e| s <= e);
            }
        }
        let mask = arrow_array::BooleanArray::from(keep);
        kept.push(arrow_select::filter::filter_record_batch(b, &mask).map_err(|e| PlotErr(e.to_string()))?);
    }
    if let Some(missing) = options.sensors.iter().find(|s| !seen.contains(s)) {
        return Err(PlotErr(format!("--sensor {missing}: no such sensor (the file has {})", seen.join(", "))));
    }
    t.batches = kept;
    let after = t.rows();
    let mut what = Vec::new();
    if !options.sensors.is_empty() {
        what.push(format!("sensors {}", options.sensors.join(", ")));
    }
    if options.from.is_some() || options.to.is_some() {
        let f = options.from.map_or("start".into(), |f| format!("{f} s"));
        let e = options.to.map_or("end".into(), |e| format!("{e} s"));
        what.push(format!("times {f} to {e} after the first row"));
    }
    notes.push(format!("{}: {after} of {before} rows read", what.join("; ")));
    if after == 0 {
        return Err(PlotErr(format!("no row left after the filters ({})", what.join("; "))));
    }
    Ok(t)
}

/// At most this many rows of a file (or of all an archive's files) are read: [`MAX_POINTS`] per
/// drawn sensor (ten times that for events, a tenth for windows), and for surfaces about 64 MB
/// of values.
pub(super) fn read_budget(schema_id: &str, schema: &SchemaRef) -> usize {
    let rows = MAX_POINTS * MAX_SENSORS;
    match family(schema_id).0 {
        "event" => 10 * rows,
        "window" => rows / 10,
        "surface" => {
            let n = match schema.field_with_name("values").map(|f| f.data_type().clone()) {
                Ok(arrow_schema::DataType::FixedSizeList(_, n)) => n.max(1) as usize,
                _ => 1,
            };
            (64_000_000 / (8 * n)).clamp(64, 1600)
        }
        _ => rows,
    }
}

/// The smallest prime ≥ `n`.
pub(super) fn next_prime(n: usize) -> usize {
    let is_prime = |m: usize| m >= 2 && (2..).take_while(|d| d * d <= m).all(|d| m % d != 0);
    (n..).find(|&m| is_prime(m)).unwrap_or(n)
}

pub(super) fn column<'a>(b: &'a RecordBatch, name: &str) -> R<&'a ArrayRef> {
    b.column_by_name(name).ok_or_else(|| PlotErr(format!("no column `{name}`")))
}

pub(super) fn wrong(name: &str, a: &ArrayRef) -> PlotErr {
    PlotErr(format!("column `{name}` has type {}, not the schema's", a.data_type()))
}

pub(super) fn strings(b: &RecordBatch, name: &str) -> R<Vec<String>> {
    let a = column(b, name)?;
    strings_of(a).ok_or_else(|| wrong(name, a))
}

/// A string column (`Utf8`, `LargeUtf8`, a dictionary of `Utf8`) as strings.
fn strings_of(a: &ArrayRef) -> Option<Vec<String>> {
    if let Some(s) = a.as_string_opt::<i32>() {
        return Some((0..s.len()).map(|i| s.value(i).to_string()).collect());
    }
    if let Some(s) = a.as_string_opt::<i64>() {
        return Some((0..s.len()).map(|i| s.value(i).to_string()).collect());
    }
    if let Some(d) = a.as_any_dictionary_opt() {
        if let Some(v) = d.values().as_string_opt::<i32>() {
            return Some(d.normalized_keys().into_iter().map(|k| v.value(k).to_string()).collect());
        }
    }
    None
}

/// An integer nanosecond column: `Int64` (schemas of version 1), `Timestamp(ns)` or
/// `Duration(ns)` (the newer versions), the nanoseconds as stored.
pub(super) fn i64s(b: &RecordBatch, name: &str) -> R<Vec<i64>> {
    use arrow_array::types::{DurationNanosecondType, TimestampNanosecondType};
    let a = column(b, name)?;
    if let Some(p) = a.as_primitive_opt::<Int64Type>() {
        return Ok(p.values().to_vec());
    }
    if let Some(p) = a.as_primitive_opt::<TimestampNanosecondType>() {
        return Ok(p.values().to_vec());
    }
    let p = a.as_primitive_opt::<DurationNanosecondType>().ok_or_else(|| wrong(name, a))?;
    Ok(p.values().to_vec())
}

/// A Float64 column, null as NaN.
pub(super) fn f64s(b: &RecordBatch, name: &str) -> R<Vec<f64>> {
    let a = column(b, name)?;
    let p = a.as_primitive_opt::<Float64Type>().ok_or_else(|| wrong(name, a))?;
    Ok((0..p.len()).map(|i| if p.is_null(i) { f64::NAN } else { p.value(i) }).collect())
}

/// A `FixedSizeList<Float64, n>` column: `(n, values of every row, concatenated)`.
pub(super) fn fixed_lists(b: &RecordBatch, name: &str) -> R<(usize, Vec<f64>)> {
    let a = column(b, name)?;
    let l = a.as_fixed_size_list_opt().ok_or_else(|| wrong(name, a))?;
    let n = l.value_length() as usize;
    let mut out = Vec::with_capacity(l.len() * n);
    for i in 0..l.len() {
        let v = l.value(i);
        let p = v.as_primitive_opt::<Float64Type>().ok_or_else(|| wrong(name, a))?;
        out.extend(p.values().iter().copied());
    }
    Ok((n, out))
}

/// A `List<FixedSizeList<Float64, 2>>` column (polygons), null as empty.
pub(super) fn polygons(b: &RecordBatch, name: &str) -> R<Vec<Vec<[f64; 2]>>> {
    let a = column(b, name)?;
    let l = a.as_list_opt::<i32>().ok_or_else(|| wrong(name, a))?;
    let mut out = Vec::with_capacity(l.len());
    for i in 0..l.len() {
        if l.is_null(i) {
            out.push(Vec::new());
            continue;
        }
        let pts = l.value(i);
        let f = pts.as_fixed_size_list_opt().ok_or_else(|| wrong(name, a))?;
        let mut poly = Vec::with_capacity(f.len());
        for j in 0..f.len() {
            let xy = f.value(j);
            let p = xy.as_primitive_opt::<Float64Type>().ok_or_else(|| wrong(name, a))?;
            if p.len() == 2 {
                poly.push([p.value(0), p.value(1)]);
            }
        }
        out.push(poly);
    }
    Ok(out)
}

/// Taxel names from a field's `gradtac.taxels` metadata.
pub(super) fn taxel_names(schema: &SchemaRef, field: &str) -> Option<Vec<String>> {
    let f = schema.field_with_name(field).ok()?;
    let json = f.metadata().get("gradtac.taxels")?;
    serde_json::from_str(json).ok()
}

/// Rows grouped by sensor (first appearance order), each a list of `(batch, row)`.
pub(super) fn by_sensor(t: &Table) -> R<Groups> {
    let mut order: Groups = Vec::new();
    let mut index: HashMap<String, usize> = HashMap::new();
    for (bi, b) in t.batches.iter().enumerate() {
        for (ri, s) in strings(b, "sensor")?.into_iter().enumerate() {
            let k = *index.entry(s.clone()).or_insert_with(|| {
                order.push((s, Vec::new()));
                order.len() - 1
            });
            order[k].1.push((bi, ri));
        }
    }
    Ok(order)
}

/// Every `k`-th index so that at most `max` remain.
pub(super) fn stride(len: usize, max: usize) -> usize {
    len.div_ceil(max.max(1)).max(1)
}

pub(super) fn limit_sensors<T>(mut s: Vec<(String, T)>, notes: &mut Vec<String>) -> Vec<(String, T)> {
    if s.len() > MAX_SENSORS {
        let rest: Vec<String> = s[MAX_SENSORS..].iter().map(|(n, _)| n.clone()).collect();
        notes.push(format!("only the first {MAX_SENSORS} sensors are drawn; left out: {}", rest.join(", ")));
        s.truncate(MAX_SENSORS);
    }
    s
}

pub(super) fn secs(t_ns: i64, t0: i64) -> f64 {
    // i128: times from a file may span more than i64 nanoseconds
    (i128::from(t_ns) - i128::from(t0)) as f64 * 1e-9
}
