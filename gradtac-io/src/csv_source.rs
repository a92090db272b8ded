//! CSV frame source: one [`TaxelFrame`] per data row of a CSV file.
//!
//! A CSV file with a header line is read as a stream of frames: the taxel values come from
//! the columns a [`ColumnSelector`] picks (by name, or by a pattern such as `ff_e{1..24}`),
//! the time from a timestamp column or from a fixed sample rate (see [`CsvSourceConfig`]).
//!
//! Reading is streaming with constant memory: [`CsvFrames`] holds one reusable
//! [`csv::ByteRecord`] and a 64 KiB read buffer ([`READ_BUFFER`]), never the file. It is a plain
//! [`Iterator`] of `Result<TaxelFrame, Error>`; run it on a tokio runtime through
//! [`blocking_stream`](crate::blocking::blocking_stream).
//!
//! ```
//! use gradtac_io::csv_source::{CsvFrames, CsvSourceConfig};
//! use gradtac_stream::SensorId;
//! use std::path::Path;
//!
//! let text = "t,a1,a2,a3\n0.0,1,2,3\n0.01,4,5,6\n";
//! let config = CsvSourceConfig::new("mem.csv", "a{1..3}".parse().unwrap()).with_time_column("t", Default::default());
//! let frames: Vec<_> = CsvFrames::from_reader(text.as_bytes(), Path::new("mem.csv"), &config, SensorId::new("ff"))
//!     .unwrap()
//!     .collect::<Result<_, _>>()
//!     .unwrap();
//! assert_eq!(frames[1].values, [4.0, 5.0, 6.0]);
//! assert_eq!(frames[1].time.as_nanos(), 10_000_000);
//! assert_eq!(frames[1].seq, 1);
//! ```
//!
//! # Errors
//! Every error about the input names the file and the 1-based *physical* line (the header
//! is line 1) and, for a bad cell, the column's header name: a non-numeric, empty or
//! non-finite cell; a row with another number of fields than the header; a time that goes
//! back. After an error the iterator ends.
//!
//! Physical lines are counted by `\n` (LF and CRLF files; blank lines and newlines inside
//! quoted fields count, a row spanning several lines is named by its first). The `csv`
//! crate's own record line numbers are not used: they skip blank lines and lag on CRLF.
//!
//! Cells are trimmed of surrounding whitespace; blank lines are skipped (they do not count
//! as frames, so `seq` counts data rows only).

use crate::{Error, Result};
use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// Most column names a pattern may expand to (a guard against `{1..1000000000}`).
pub const MAX_EXPANSION: usize = 100_000;

// ---------------------------------------------------------------------------------------------
// Column selection
// ---------------------------------------------------------------------------------------------

/// Which CSV columns hold the taxel values, in taxel order.
///
/// Parsed from one string ([`FromStr`], and serde from a string or a list of strings):
///
/// | text | selector | columns |
/// |---|---|---|
/// | `ff_e{1..24}` | `Pattern` | `ff_e1`, `ff_e2`, …, `ff_e24` (range expanded in order) |
/// | `e{01..03}` | `Pattern` | `e01`, `e02`, `e03` (a leading zero pads to the widest bound) |
/// | `ff_e*` | `Pattern` | every header matching the glob, in header order |
/// | `x{1..2}_*` | `Pattern` | ranges first, then each alternative's glob matches in header order |
/// | `a, b,c` | `Names` | `a`, `b`, `c` (a comma-separated list is literal names) |
/// | `a` | `Names` | `a` |
///
/// In a pattern, `{a..b}` is an inclusive integer range (descending when `a > b`), `*`
/// matches any run of characters and `?` one character. Several ranges expand as a
/// cartesian product, the leftmost varying slowest. A pattern must match a column for every
/// alternative; a selection must not pick one column twice. Globs never pick the source's
/// time column, so `*` means "every column but the time".
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ColumnSelector {
    /// Literal column names, in taxel order.
    Names(Vec<String>),
    /// A pattern with `{a..b}` ranges and `*`/`?` globs (see the type's documentation).
    Pattern(String),
}

/// One piece of a pattern before range expansion.
#[derive(Clone, Debug)]
enum Piece {
    Lit(String),
    Range { start: i64, end: i64, width: usize },
}

fn parse_pattern(p: &str) -> std::result::Result<Vec<Piece>, String> {
    let mut pieces = Vec::new();
    let mut lit = String::new();
    let mut rest = p;
    while let Some(open) = rest.find(['{', '}']) {
        lit.push_str(&rest[..open]);
        if rest[open..].starts_with('}') {
            return Err(format!("pattern {p:?}: '}}' without '{{'"));
        }
        let after = &rest[open + 1..];
        let close = after.find('}').ok_or_else(|| format!("pattern {p:?}: '{{' without '}}'"))?;
        let body = &after[..close];
        let (a, b) = body
            .split_once("..")
            .ok_or_else(|| format!("pattern {p:?}: {{{body}}} is not a range {{a..b}} of integers"))?;
        let parse = |s: &str| -> std::result::Result<i64, String> {
            if s.is_empty() || !s.trim_start_matches('-').bytes().all(|c| c.is_ascii_digit()) {
                return Err(format!("pattern {p:?}: {{{body}}} is not a range {{a..b}} of integers"));
            }
            s.parse::<i64>().map_err(|e| format!("pattern {p:?}: {{{body}}}: {e}"))
        };
        let (start, end) = (parse(a)?, parse(b)?);
        let padded = |s: &str| s.trim_start_matches('-').len() > 1 && s.trim_start_matches('-').starts_with('0');
        let width = if padded(a) || padded(b) { a.len().max(b.len()) } else { 0 };
        if !lit.is_empty() {
            pieces.push(Piece::Lit(std::mem::take(&mut lit)));
        }
        pieces.push(Piece::Range { start, end, width });
        rest = &after[close + 1..];
    }
    lit.push_str(rest);
    if !lit.is_empty() {
        pieces.push(Piece::Lit(lit));
    }
    let mut total: u128 = 1;
    for piece in &pieces {
        if let Piece::Range { start, end, .. } = piece {
            total = total.saturating_mul(u128::from(start.abs_diff(*end)) + 1);
        }
    }
    if total > MAX_EXPANSION as u128 {
        return Err(format!("pattern {p:?} expands to {total} names (at most {MAX_EXPANSION})"));
    }
    Ok(pieces)
}

fn expand(pieces: &[Piece]) -> Vec<String> {
    let mut out = vec![String::new()];
    for piece in pieces {
        match piece {
            Piece::Lit(s) => out.iter_mut().for_each(|o| o.push_str(s)),
            &Piece::Range { start, end, width } => {
                let values: Vec<i64> =
                    if start <= end { (start..=end).collect() } else { (end..=start).rev().collect() };
                out =
                    out.iter().flat_map(|prefix| values.iter().map(move |v| format!("{prefix}{v:0width$}"))).collect();
            }
        }
    }
    out
}

fn is_glob(s: &str) -> bool {
    s.contains(['*', '?'])
}

/// `*` any run, `?` one character (by `char`).
fn glob_match(pattern: &str, text: &str) -> bool {
    let p: Vec<char> = pattern.chars().collect();
    let t: Vec<char> = text.chars().collect();
    let (mut pi, mut ti) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while ti < t.len() {
        if pi < p.len() && (p[pi] == '?' || (p[pi] != '*' && p[pi] == t[ti])) {
            pi += 1;
            ti += 1;
        } else if pi < p.len() && p[pi] == '*' {
            star = Some((pi, ti));
            pi += 1;
        } else if let Some((sp, st)) = star {
            pi = sp + 1;
            ti = st + 1;
            star = Some((sp, st + 1));
        } else {
            return false;
        }
    }
    p[pi..].iter().all(|&c| c == '*')
}

impl ColumnSelector {
    /// The names or patterns this selector looks for, after range expansion (globs are kept
    /// as globs), in order.
    pub fn expanded(&self) -> Vec<String> {
        match self {
            ColumnSelector::Names(n) => n.clone(),
            ColumnSelector::Pattern(p) => match parse_pattern(p) {
                Ok(pieces) => expand(&pieces),
                Err(_) => vec![p.clone()],
            },
        }
    }

    /// Check the selector: a non-empty list of non-empty names, or a well-formed pattern.
    pub fn validate(&self) -> Result<()> {
        match self {
            ColumnSelector::Names(n) if n.is_empty() => Err(Error::InvalidConfig("no columns selected".into())),
            ColumnSelector::Names(n) if n.iter().any(|s| s.trim().is_empty()) => {
                Err(Error::InvalidConfig(format!("an empty column name in {n:?}")))
            }
            ColumnSelector::Names(_) => Ok(()),
            ColumnSelector::Pattern(p) if p.trim().is_empty() => {
                Err(Error::InvalidConfig("empty column pattern".into()))
            }
            ColumnSelector::Pattern(p) => parse_pattern(p).map(|_| ()).map_err(Error::InvalidConfig),
        }
    }

    /// Resolve the selector against a header: the indices of the selected columns, in taxel
    /// order. On failure the error's `reason` lists every missing name (and the ambiguous or
    /// repeated ones), and names `origin` as the file, line 1.
    pub fn resolve(&self, header: &[String], origin: &Path) -> Result<Vec<usize>> {
        self.resolve_excluding(header, origin, None)
    }

    /// [`resolve`](Self::resolve), where globs never match column `skip` (the time column:
    /// `*` means every column but the time). A literal name may still pick it.
    pub fn resolve_excluding(&self, header: &[String], origin: &Path, skip: Option<usize>) -> Result<Vec<usize>> {
        self.validate()?;
        let err = |reason: String| Error::Parse { path: origin.to_path_buf(), line: 1, column: None, reason };
        let mut picked = Vec::new();
        let mut missing = Vec::new();
        let mut ambiguous = Vec::new();
        for want in self.expanded() {
            let want = want.trim().to_string();
            if matches!(self, ColumnSelector::Pattern(_)) && is_glob(&want) {
                let before = picked.len();
                picked.extend(
                    header.iter().enumerate().filter(|&(i, h)| Some(i) != skip && glob_match(&want, h)).map(|(i, _)| i),
                );
                if picked.len() == before {
                    missing.push(want);
                }
            } else {
                let mut hits = header.iter().enumerate().filter(|(_, h)| **h == want).map(|(i, _)| i);
                match (hits.next(), hits.next()) {
                    (None, _) => missing.push(want),
                    (Some(i), None) => picked.push(i),
                    (Some(_), Some(_)) => ambiguous.push(want),
                }
            }
        }
        if !missing.is_empty() {
            const SHOW: usize = 12;
            let shown: Vec<&String> = missing.iter().take(SHOW).collect();
            let more = if missing.len() > SHOW { format!(" and {} more", missing.len() - SHOW) } else { String::new() };
            let head: Vec<&String> = header.iter().take(SHOW).collect();
            let head_more = if header.len() > SHOW { ", …" } else { "" };
            return Err(err(format!(
                "missing column{} {shown:?}{more} (selected by {self}); the header has {} columns: {head:?}{head_more}",
                if missing.len() == 1 { "" } else { "s" },
                header.len()
            )));
        }
        if !ambiguous.is_empty() {
            return Err(err(format!("column name(s) {ambiguous:?} appear more than once in the header")));
        }
        let mut seen = vec![false; header.len()];
        let mut twice = Vec::new();
        for &i in &picked {
            if std::mem::replace(&mut seen[i], true) {
                twice.push(header[i].clone());
            }
        }
        if !twice.is_empty() {
            return Err(err(format!("column(s) {twice:?} selected more than once by {self}")));
        }
        Ok(picked)
    }
}

impl FromStr for ColumnSelector {
    type Err = Error;

    /// A comma-separated list is [`ColumnSelector::Names`]; a string with `{`, `}`, `*` or
    /// `?` is a [`ColumnSelector::Pattern`] (validated here); anything else is one name.
    fn from_str(s: &str) -> Result<Self> {
        let s = s.trim();
        let sel = if s.contains(',') {
            ColumnSelector::Names(s.split(',').map(|n| n.trim().to_string()).collect())
        } else if s.contains(['{', '}', '*', '?']) {
            ColumnSelector::Pattern(s.to_string())
        } else {
            ColumnSelector::Names(vec![s.to_string()])
        };
        sel.validate()?;
        Ok(sel)
    }
}

impl fmt::Display for ColumnSelector {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ColumnSelector::Names(n) => f.write_str(&n.join(",")),
            ColumnSelector::Pattern(p) => f.write_str(p),
        }
    }
}

impl Serialize for ColumnSelector {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        match self {
            ColumnSelector::Names(n) => n.serialize(s),
            ColumnSelector::Pattern(p) => s.serialize_str(p),
        }
    }
}

impl<'de> Deserialize<'de> for ColumnSelector {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            One(String),
            List(Vec<String>),
        }
        let sel = match Raw::deserialize(d).map_err(|_| {
            serde::de::Error::custom("expected a column pattern such as \"ff_e{1..24}\" or a list of column names")
        })? {
            Raw::One(s) => s.parse(),
            Raw::List(l) => {
                let sel = ColumnSelector::Names(l.into_iter().map(|n| n.trim().to_string()).collect());
                sel.validate().map(|_| sel)
            }
        };
        sel.map_err(serde::de::Error::custom)
    }
}

// ---------------------------------------------------------------------------------------------
// Time
// ---------------------------------------------------------------------------------------------

/// The unit of a CSV time column.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum TimeUnit {
    /// Seconds (`"s"`), possibly fractional; rounded to the nearest nanosecond.
    #[default]
    #[serde(rename = "s", alias = "seconds")]
    Seconds,
    /// Milliseconds (`"ms"`).
    #[serde(rename = "ms", alias = "milliseconds")]
    Milliseconds,
    /// Microseconds (`"us"`).
    #[serde(rename = "us", alias = "microseconds")]
    Microseconds,
    /// Nanoseconds (`"ns"`).
    #[serde(rename = "ns", alias = "nanoseconds")]
    Nanoseconds,
}

impl TimeUnit {
    /// Decimal digits from this unit to nanoseconds (9 for seconds).
    fn digits(self) -> u32 {
        match self {
            TimeUnit::Seconds => 9,
            TimeUnit::Milliseconds => 6,
            TimeUnit::Microseconds => 3,
            TimeUnit::Nanoseconds => 0,
        }
    }

    /// The unit's short name (`s`, `ms`, `us`, `ns`).
    pub fn as_str(self) -> &'static str {
        match self {
            TimeUnit::Seconds => "s",
            TimeUnit::Milliseconds => "ms",
            TimeUnit::Microseconds => "us",
            TimeUnit::Nanoseconds => "ns",
        }
    }

    /// Parse a cell in this unit to integer nanoseconds, rounded to the nearest (ties away
    /// from zero). Plain decimals (`-12.345678901234`) are converted exactly, without going
    /// through `f64`, so a Unix time in seconds keeps every nanosecond digit; other forms
    /// (`1.5e9`) go through `f64`. `None` for text that is not a finite number or does not
    /// fit `i64` nanoseconds.
    pub fn parse_nanos(self, text: &str) -> Option<i64> {
        parse_decimal_scaled(text, self.digits()).or_else(|| self.float_to_nanos(text.parse().ok()?))
    }

    /// Nanoseconds in one unit (10⁹ for seconds).
    pub fn nanos_per_unit(self) -> i64 {
        10i64.pow(self.digits())
    }

    /// A whole number of this unit as nanoseconds; `None` when it does not fit `i64`.
    pub fn int_to_nanos(self, v: i128) -> Option<i64> {
        v.checked_mul(i128::from(self.nanos_per_unit())).and_then(|x| i64::try_from(x).ok())
    }

    /// A number of this unit rounded to the nearest nanosecond; `None` when it is not finite or
    /// does not fit `i64`.
    pub fn float_to_nanos(self, x: f64) -> Option<i64> {
        let ns = (x * self.nanos_per_unit() as f64).round();
        (ns.is_finite() && ns >= i64::MIN as f64 && ns < i64::MAX as f64).then_some(ns as i64)
    }
}

impl FromStr for TimeUnit {
    type Err = Error;

    /// `s`, `ms`, `us`, `ns` (or `seconds`, `milliseconds`, `microseconds`, `nanoseconds`).
    fn from_str(s: &str) -> Result<Self> {
        match s.trim() {
            "s" | "seconds" => Ok(TimeUnit::Seconds),
            "ms" | "milliseconds" => Ok(TimeUnit::Milliseconds),
            "us" | "microseconds" => Ok(TimeUnit::Microseconds),
            "ns" | "nanoseconds" => Ok(TimeUnit::Nanoseconds),
            other => Err(Error::InvalidConfig(format!("time unit {other:?}: use s, ms, us or ns"))),
        }
    }
}

/// `[+-]?digits[.digits]` times 10^`digits`, rounded half away from zero; `None` for any
/// other form or on overflow.
fn parse_decimal_scaled(text: &str, digits: u32) -> Option<i64> {
    let (neg, body) = match text.as_bytes().first()? {
        b'-' => (true, &text[1..]),
        b'+' => (false, &text[1..]),
        _ => (false, text),
    };
    let (int, frac) = body.split_once('.').unwrap_or((body, ""));
    if int.is_empty() && frac.is_empty() {
        return None;
    }
    if !int.bytes().chain(frac.bytes()).all(|c| c.is_ascii_digit()) {
        return None;
    }
    let mut v: i128 = 0;
    for c in int.bytes() {
        v = v.checked_mul(10)?.checked_add(i128::from(c - b'0'))?;
        if v > i128::from(i64::MAX) + 1 {
            return None;
        }
    }
    let fb = frac.as_bytes();
    for k in 0..digits as usize {
        v = v * 10 + fb.get(k).map_or(0, |c| i128::from(c - b'0'));
    }
    if fb.get(digits as usize).is_some_and(|&c| c >= b'5') {
        v += 1;
    }
    let v = if neg { -v } else { v };
    i64::try_from(v).ok()
}

// ---------------------------------------------------------------------------------------------
// Config
// ---------------------------------------------------------------------------------------------

/// How to read frames from a CSV file. Embedded in scene files, e.g.
///
/// ```toml
/// source = { csv = "recording.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }
/// # or, with a time column in seconds:
/// source = { csv = "recording.csv", columns = ["p1", "p2", "p3"], time_column = "t", time_unit = "s" }
/// ```
///
/// Exactly one of `time_column` and `rate_hz` must be given.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CsvSourceConfig {
    /// The CSV file (key `csv`, alias `path`). Relative paths are relative to the process's
    /// working directory (a scene loader resolves them against the scene file first).
    #[serde(rename = "csv", alias = "path")]
    pub path: PathBuf,
    /// The taxel columns, in taxel order (see [`ColumnSelector`]). Default `"*"`: every
    /// column except the time column, in header order.
    #[serde(default = "all_columns")]
    pub columns: ColumnSelector,
    /// Name of the column holding each row's time, in `time_unit`. Times must not decrease.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_column: Option<String>,
    /// Unit of `time_column`: `"s"` (default), `"ms"`, `"us"` or `"ns"`.
    #[serde(default)]
    pub time_unit: TimeUnit,
    /// Fixed sample rate (Hz) when there is no time column: frame `k` is at
    /// `round(k·10⁹/rate_hz)` ns (see [`Timestamp::at_rate`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_hz: Option<f64>,
    /// Field delimiter, one ASCII character (default `,`).
    #[serde(default = "default_delimiter")]
    pub delimiter: char,
}

fn all_columns() -> ColumnSelector {
    ColumnSelector::Pattern("*".into())
}

fn default_delimiter() -> char {
    ','
}

impl CsvSourceConfig {
    /// A config for `path` and `columns`; set the time with [`with_rate_hz`](Self::with_rate_hz)
    /// or [`with_time_column`](Self::with_time_column).
    pub fn new(path: impl Into<PathBuf>, columns: ColumnSelector) -> Self {
        CsvSourceConfig {
            path: path.into(),
            columns,
            time_column: None,
            time_unit: TimeUnit::default(),
            rate_hz: None,
            delimiter: default_delimiter(),
        }
    }

    /// Frames at a fixed rate (Hz); clears any time column.
    pub fn with_rate_hz(mut self, rate_hz: f64) -> Self {
        self.rate_hz = Some(rate_hz);
        self.time_column = None;
        self
    }

    /// Frames timed by a column in `unit`; clears any rate.
    pub fn with_time_column(mut self, name: impl Into<String>, unit: TimeUnit) -> Self {
        self.time_column = Some(name.into());
        self.time_unit = unit;
        self.rate_hz = None;
        self
    }

    /// Another field delimiter (`'\t'` for TSV).
    pub fn with_delimiter(mut self, delimiter: char) -> Self {
        self.delimiter = delimiter;
        self
    }

    /// Check the settings that do not need the file: columns well formed, exactly one time
    /// source, a finite positive rate, an ASCII delimiter.
    pub fn validate(&self) -> Result<()> {
        self.columns.validate()?;
        let bad = |s: String| Err(Error::InvalidConfig(format!("CSV source {}: {s}", self.path.display())));
        match (&self.time_column, self.rate_hz) {
            (Some(_), Some(_)) => return bad("give either time_column or rate_hz, not both".into()),
            (None, None) => return bad("give time_column (a column of times) or rate_hz (a fixed rate)".into()),
            (None, Some(r)) if Timestamp::check_rate_hz(r).is_err() => {
                return bad(Timestamp::check_rate_hz(r).unwrap_err())
            }
            (Some(c), None) if c.trim().is_empty() => return bad("time_column is empty".into()),
            _ => {}
        }
        if !self.delimiter.is_ascii() || matches!(self.delimiter, '"' | '\n' | '\r') {
            return bad(format!(
                "delimiter {:?} must be one ASCII character other than a quote or newline",
                self.delimiter
            ));
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Progress
// ---------------------------------------------------------------------------------------------

/// A cheap, clonable view of how far a [`CsvFrames`] has read, shareable with another
/// thread (a progress bar) while the iterator runs elsewhere.
#[derive(Clone, Debug)]
pub struct CsvProgress {
    read: Arc<AtomicU64>,
    total: Option<u64>,
}

impl CsvProgress {
    /// Bytes of the input parsed so far (through the end of the last row returned).
    pub fn bytes_read(&self) -> u64 {
        self.read.load(Ordering::Relaxed)
    }

    /// The input's length in bytes when known (a file opened with [`CsvFrames::open`]).
    pub fn total_bytes(&self) -> Option<u64> {
        self.total
    }

    /// `bytes_read / total_bytes` in `[0, 1]`, when the length is known.
    pub fn fraction(&self) -> Option<f64> {
        self.total.map(|t| if t == 0 { 1.0 } else { (self.bytes_read() as f64 / t as f64).min(1.0) })
    }
}

// ---------------------------------------------------------------------------------------------
// The iterator
// ---------------------------------------------------------------------------------------------

#[derive(Clone, Copy, Debug)]
enum TimeSource {
    Column { index: usize, unit: TimeUnit },
    Rate(f64),
}

/// Iterator of the frames of one CSV file (see the [module documentation](self)).
///
/// Built by [`CsvFrames::open`] (a file) or [`CsvFrames::from_reader`] (any [`Read`]); both
/// read and check the header at once, so a missing column fails at construction.
#[must_use = "iterators are lazy and do nothing unless consumed"]
pub struct CsvFrames<R> {
    reader: csv::Reader<LineCounter<R>>,
    record: csv::ByteRecord,
    origin: PathBuf,
    sensor: SensorId,
    header: Vec<String>,
    indices: Vec<usize>,
    time: TimeSource,
    prev_time: Option<i64>,
    seq: u64,
    done: bool,
    progress: CsvProgress,
}

impl<R> fmt::Debug for CsvFrames<R> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("CsvFrames")
            .field("origin", &self.origin)
            .field("sensor", &self.sensor)
            .field("columns", &self.columns())
            .field("time", &self.time)
            .field("seq", &self.seq)
            .field("done", &self.done)
            .finish_non_exhaustive()
    }
}

impl CsvFrames<File> {
    /// Open `config.path`, read its header and resolve the columns; frames belong to `sensor`.
    pub fn open(config: &CsvSourceConfig, sensor: SensorId) -> Result<Self> {
        config.validate()?;
        let path = &config.path;
        let file = File::open(path).map_err(|source| Error::Io { path: path.clone(), source })?;
        let len = file.metadata().map_err(|source| Error::Io { path: path.clone(), source })?.len();
        let mut frames = Self::from_reader(file, path, config, sensor)?;
        frames.progress.total = Some(len);
        Ok(frames)
    }
}

impl<R: Read> CsvFrames<R> {
    /// Read CSV text from `reader`; `origin` names it in errors (`config.path` is ignored).
    /// The total length is unknown ([`CsvProgress::total_bytes`] is `None`).
    pub fn from_reader(reader: R, origin: &Path, config: &CsvSourceConfig, sensor: SensorId) -> Result<Self> {
        config.validate()?;
        let mut reader = csv::ReaderBuilder::new()
            .buffer_capacity(READ_BUFFER)
            .has_headers(true)
            .flexible(true)
            .delimiter(config.delimiter as u8)
            .from_reader(LineCounter::new(reader));
        let origin = origin.to_path_buf();
        let raw = reader.byte_headers().map_err(|e| csv_error(&origin, e))?.clone();
        if raw.is_empty() || (raw.len() == 1 && raw[0].is_empty()) {
            return Err(Error::Parse { path: origin, line: 1, column: None, reason: "no header line".into() });
        }
        let mut header = Vec::with_capacity(raw.len());
        for (i, cell) in raw.iter().enumerate() {
            let mut name = std::str::from_utf8(cell)
                .map_err(|_| Error::Parse {
                    path: origin.clone(),
                    line: 1,
                    column: None,
                    reason: format!("header field {} is not UTF-8", i + 1),
                })?
                .trim()
                .to_string();
            if i == 0 {
                if let Some(stripped) = name.strip_prefix('\u{feff}') {
                    name = stripped.trim().to_string();
                }
            }
            header.push(name);
        }
        let time = match (&config.time_column, config.rate_hz) {
            (Some(name), None) => {
                let name = name.trim();
                let index = ColumnSelector::Names(vec![name.to_string()]).resolve(&header, &origin).map_err(|_| {
                    Error::Parse {
                        path: origin.clone(),
                        line: 1,
                        column: None,
                        reason: format!("time column {name:?} is not in the header (or appears twice)"),
                    }
                })?[0];
                TimeSource::Column { index, unit: config.time_unit }
            }
            (None, Some(rate)) => TimeSource::Rate(rate),
            _ => return Err(Error::InvalidConfig("give exactly one of time_column and rate_hz".into())),
        };
        let skip = match time {
            TimeSource::Column { index, .. } => Some(index),
            TimeSource::Rate(_) => None,
        };
        let indices = config.columns.resolve_excluding(&header, &origin, skip)?;
        let read = Arc::new(AtomicU64::new(reader.position().byte()));
        Ok(CsvFrames {
            reader,
            record: csv::ByteRecord::new(),
            origin,
            sensor,
            header,
            indices,
            time,
            prev_time: None,
            seq: 0,
            done: false,
            progress: CsvProgress { read, total: None },
        })
    }
}

/// Bytes a CSV source reads at a time: 64 KiB (about 500 rows of 24 taxels), so a fast run
/// makes few `read` calls.
pub const READ_BUFFER: usize = 64 << 10;

/// Longest physical line (bytes) a CSV source accepts, header included: 1 MiB (about 40 000
/// columns of 24-byte cells). A longer line fails with its file, line number and an excerpt,
/// so a stray binary file or an unbounded input (`/dev/zero`) cannot grow memory without
/// bound.
pub const MAX_LINE_BYTES: u64 = 1 << 20;

/// The error [`LineCounter`] raises (inside an `io::Error`) for a line over the cap.
#[derive(Debug)]
struct LineTooLong {
    line: u64,
    start: Vec<u8>,
    max: u64,
}

impl fmt::Display for LineTooLong {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "line {} is longer than {} bytes (the limit of a CSV line); it starts {:?}…",
            self.line,
            self.max,
            String::from_utf8_lossy(&self.start)
        )
    }
}

impl std::error::Error for LineTooLong {}

/// A [`Read`] that remembers where the newlines it passed on are, until asked: physical line
/// numbers for [`CsvFrames`]. Queries must not go backwards; the queue holds only newlines
/// the CSV parser has buffered but not yet consumed (at most its [`READ_BUFFER`]'s worth). It
/// also caps the length of a line ([`MAX_LINE_BYTES`]).
struct LineCounter<R> {
    inner: R,
    offset: u64,
    pending: std::collections::VecDeque<u64>,
    passed: u64,
    /// Newlines seen by `read` (its own count, independent of the queries).
    lines_read: u64,
    /// Bytes since the last newline.
    line_len: u64,
    /// The first bytes of the current line (for the error's excerpt).
    line_start: Vec<u8>,
    max_line: u64,
}

impl<R> LineCounter<R> {
    fn new(inner: R) -> Self {
        LineCounter {
            inner,
            offset: 0,
            pending: Default::default(),
            passed: 0,
            lines_read: 0,
            line_len: 0,
            line_start: Vec::new(),
            max_line: MAX_LINE_BYTES,
        }
    }

    /// The 1-based line holding byte `at` (a `\n` belongs to the line it ends).
    fn line_of(&mut self, at: u64) -> u64 {
        while self.pending.front().is_some_and(|&nl| nl < at) {
            self.pending.pop_front();
            self.passed += 1;
        }
        self.passed + 1
    }
}

impl<R> LineCounter<R> {
    /// Count `piece`, the bytes of the current line in this read (up to its newline, or to
    /// the end of the read when `ends` is false); an error when the line passes the cap.
    fn piece(&mut self, piece: &[u8], ends: bool) -> std::io::Result<()> {
        const KEEP: usize = 80;
        self.line_len += piece.len() as u64;
        // the excerpt is only read for a line over the cap: kept for a line that goes on past
        // this read, or taken from this piece when it crosses the cap now
        let over = self.line_len > self.max_line;
        if (!ends || over) && self.line_start.len() < KEEP {
            let take = piece.len().min(KEEP - self.line_start.len());
            self.line_start.extend_from_slice(&piece[..take]);
        }
        if over {
            let e = LineTooLong { line: self.lines_read + 1, start: self.line_start.clone(), max: self.max_line };
            return Err(std::io::Error::new(std::io::ErrorKind::InvalidData, e));
        }
        Ok(())
    }
}

impl<R: Read> Read for LineCounter<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        let buf = &buf[..n];
        let mut line_from = 0;
        for i in memchr::memchr_iter(b'\n', buf) {
            self.piece(&buf[line_from..i], true)?;
            self.pending.push_back(self.offset + i as u64);
            self.lines_read += 1;
            self.line_len = 0;
            self.line_start.clear();
            line_from = i + 1;
        }
        self.piece(&buf[line_from..], false)?;
        self.offset += n as u64;
        Ok(n)
    }
}

fn newlines_in(bytes: &[u8]) -> u64 {
    bytes.iter().filter(|&&b| b == b'\n').count() as u64
}

impl<R> CsvFrames<R> {
    /// The selected columns' header names, in taxel order (one per value of each frame).
    pub fn columns(&self) -> Vec<String> {
        self.indices.iter().map(|&i| self.header[i].clone()).collect()
    }

    /// Number of taxels per frame.
    pub fn taxel_count(&self) -> usize {
        self.indices.len()
    }

    /// The file's name as used in errors.
    pub fn origin(&self) -> &Path {
        &self.origin
    }

    /// The sensor the frames belong to.
    pub fn sensor(&self) -> &SensorId {
        &self.sensor
    }

    /// Bytes of the input parsed so far.
    pub fn bytes_read(&self) -> u64 {
        self.progress.bytes_read()
    }

    /// The input's length in bytes, when known ([`CsvFrames::open`]).
    pub fn total_bytes(&self) -> Option<u64> {
        self.progress.total
    }

    /// A handle that reports progress from another thread.
    pub fn progress(&self) -> CsvProgress {
        self.progress.clone()
    }

    fn parse_error(&self, line: u64, column: Option<usize>, reason: String) -> Error {
        Error::Parse { path: self.origin.clone(), line, column: column.map(|c| self.header[c].clone()), reason }
    }
}

fn csv_error(origin: &Path, e: csv::Error) -> Error {
    let line = e.position().map_or(0, |p| p.line());
    let reason = e.to_string();
    match e.into_kind() {
        csv::ErrorKind::Io(source) => match source.get_ref().and_then(|r| r.downcast_ref::<LineTooLong>()) {
            Some(long) => {
                Error::Parse { path: origin.to_path_buf(), line: long.line, column: None, reason: long.to_string() }
            }
            None => Error::Io { path: origin.to_path_buf(), source },
        },
        _ => Error::Parse { path: origin.to_path_buf(), line, column: None, reason },
    }
}

/// A cell as text without surrounding whitespace. (Cells are trimmed here rather than by
/// `csv`, whose trimming would also drop newlines that [`newlines_in`] must count.)
fn cell_text(cell: &[u8]) -> std::result::Result<&str, String> {
    let s = std::str::from_utf8(cell).map_err(|_| "the cell is not UTF-8 text".to_string())?.trim();
    if s.is_empty() {
        return Err("empty cell".into());
    }
    Ok(s)
}

/// Exact powers of ten as `f64` (every one up to 10²² is representable).
const POW10: [f64; 16] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15];

/// The fast path of a numeric cell: optional ASCII blanks around an optional sign, digits
/// and at most one `.` with digits on both sides, 15 significant digits at most (no exponent,
/// no `inf`/`nan`). Then the mantissa `m` (< 10¹⁵ < 2⁵³) and `10^k` are exact `f64`s and one
/// IEEE division rounds `m / 10^k` correctly, which is what [`f64::from_str`] returns
/// (Clinger's fast path). Anything else is `None`, and the cell takes the general path (with
/// its error messages).
fn fast_f64(cell: &[u8]) -> Option<f64> {
    let cell = cell.trim_ascii();
    let (negative, text) = match cell.first()? {
        b'-' => (true, &cell[1..]),
        b'+' => (false, &cell[1..]),
        _ => (false, cell),
    };
    // 15 digits and a dot at most (checked again below, without the dot)
    if text.is_empty() || text.len() > 16 {
        return None;
    }
    let mut m: u64 = 0;
    let mut dot = None;
    for (i, &b) in text.iter().enumerate() {
        let d = b.wrapping_sub(b'0');
        if d <= 9 {
            m = m * 10 + u64::from(d);
        } else if b == b'.' && dot.is_none() {
            dot = Some(i);
        } else {
            return None;
        }
    }
    let frac = match dot {
        None if text.len() <= 15 => 0,
        None => return None,
        // digits on both sides of the dot
        Some(i) if i > 0 && i + 1 < text.len() => text.len() - i - 1,
        Some(_) => return None,
    };
    let v = m as f64 / POW10[frac];
    Some(if negative { -v } else { v })
}

impl<R: Read> CsvFrames<R> {
    /// The first physical line of the current row, given the line of its last byte: less the
    /// newlines inside quoted fields (`csv`'s own line numbers skip blank lines and CRLF line
    /// ends). Only computed for an error.
    fn row_line(&self, last_line: u64) -> u64 {
        last_line - newlines_in(self.record.as_slice())
    }

    fn read_frame(&mut self) -> Option<Result<TaxelFrame>> {
        match self.reader.read_byte_record(&mut self.record) {
            Ok(false) => return None,
            Ok(true) => {}
            Err(e) => return Some(Err(csv_error(&self.origin, e))),
        }
        let end = self.reader.position().byte();
        self.progress.read.store(end, Ordering::Relaxed);
        // the line of the row's last byte (advancing the line counter); the row's first line
        // is worked out from it only for an error (row_line)
        let last_line = self.reader.get_mut().line_of(end.saturating_sub(1));
        if self.record.len() != self.header.len() {
            let reason = format!("the row has {} fields, the header has {}", self.record.len(), self.header.len());
            return Some(Err(self.parse_error(self.row_line(last_line), None, reason)));
        }
        let mut values = Vec::with_capacity(self.indices.len());
        for &i in &self.indices {
            let cell = &self.record[i];
            if let Some(v) = fast_f64(cell) {
                values.push(v);
                continue;
            }
            let v = cell_text(cell).and_then(|s| match s.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                Ok(_) => Err(format!("{:?} is not a finite number", crate::error::excerpt(s, 80))),
                Err(_) => Err(format!("{:?} is not a number", crate::error::excerpt(s, 80))),
            });
            match v {
                Ok(v) => values.push(v),
                Err(reason) => return Some(Err(self.parse_error(self.row_line(last_line), Some(i), reason))),
            }
        }
        let time = match self.time {
            TimeSource::Rate(rate) => match Timestamp::checked_at_rate(self.seq, rate) {
                Some(t) => t,
                None => {
                    let reason =
                        format!("frame {}: its time at {rate} Hz is beyond the i64-nanosecond range", self.seq);
                    return Some(Err(self.parse_error(self.row_line(last_line), None, reason)));
                }
            },
            TimeSource::Column { index, unit } => {
                let ns = cell_text(&self.record[index]).and_then(|s| {
                    unit.parse_nanos(s).ok_or_else(|| {
                        format!(
                            "time {:?} is not a finite number of {} within ±292 years",
                            crate::error::excerpt(s, 80),
                            unit.as_str()
                        )
                    })
                });
                let ns = match ns {
                    Ok(ns) => ns,
                    Err(reason) => return Some(Err(self.parse_error(self.row_line(last_line), Some(index), reason))),
                };
                if let Some(prev) = self.prev_time.filter(|&p| ns < p) {
                    let reason = format!(
                        "time goes back: {} is {} ns before the previous row's time (times must not decrease)",
                        crate::error::excerpt(String::from_utf8_lossy(&self.record[index]).trim(), 80),
                        prev - ns
                    );
                    return Some(Err(self.parse_error(self.row_line(last_line), Some(index), reason)));
                }
                self.prev_time = Some(ns);
                Timestamp::from_nanos(ns)
            }
        };
        let frame = TaxelFrame::new(self.sensor.clone(), time, self.seq, values);
        self.seq += 1;
        Some(Ok(frame))
    }
}

impl<R: Read> Iterator for CsvFrames<R> {
    type Item = Result<TaxelFrame>;

    fn next(&mut self) -> Option<Result<TaxelFrame>> {
        if self.done {
            return None;
        }
        let item = self.read_frame();
        if !matches!(item, Some(Ok(_))) {
            self.done = true;
        }
        item
    }
}

impl<R: Read> std::iter::FusedIterator for CsvFrames<R> {}

#[cfg(test)]
mod tests {
    use super::*;

    fn sel(s: &str) -> ColumnSelector {
        s.parse().unwrap()
    }

    fn header(names: &[&str]) -> Vec<String> {
        names.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn parse_selector_kinds() {
        assert_eq!(sel("a, b,c"), ColumnSelector::Names(vec!["a".into(), "b".into(), "c".into()]));
        assert_eq!(sel("a"), ColumnSelector::Names(vec!["a".into()]));
        assert_eq!(sel("ff_e{1..24}"), ColumnSelector::Pattern("ff_e{1..24}".into()));
        assert_eq!(sel("ff_*"), ColumnSelector::Pattern("ff_*".into()));
        for bad in ["", "a,,b", "e{1..}", "e{x..3}", "e{1-3}", "e}1", "e{1..3", "e{0..1000000}"] {
            assert!(bad.parse::<ColumnSelector>().is_err(), "{bad:?} should be rejected");
        }
    }

    #[test]
    fn ranges_expand_in_order() {
        let e = sel("ff_e{1..24}").expanded();
        assert_eq!(e.len(), 24);
        assert_eq!(e[0], "ff_e1");
        assert_eq!(e[23], "ff_e24");
        assert_eq!(sel("e{3..1}").expanded(), ["e3", "e2", "e1"]);
        assert_eq!(sel("e{08..10}").expanded(), ["e08", "e09", "e10"]);
        assert_eq!(sel("{1..2}x{-1..0}").expanded(), ["1x-1", "1x0", "2x-1", "2x0"]);
    }

    #[test]
    fn glob_matching() {
        assert!(glob_match("ff_*", "ff_e1"));
        assert!(glob_match("*", ""));
        assert!(glob_match("a*b*c", "aXXbYYc"));
        assert!(!glob_match("a*b*c", "aXXbYY"));
        assert!(glob_match("e?", "e1"));
        assert!(!glob_match("e?", "e10"));
        assert!(glob_match("*e1*", "ff_e10"));
    }

    #[test]
    fn resolve_globs_in_header_order_and_reports_missing() {
        let h = header(&["t", "ff_e2", "th_e1", "ff_e1"]);
        let p = Path::new("x.csv");
        assert_eq!(sel("ff_*").resolve(&h, p).unwrap(), [1, 3]);
        assert_eq!(sel("ff_e{1..2}").resolve(&h, p).unwrap(), [3, 1]);
        assert_eq!(sel("th_e1,ff_e1").resolve(&h, p).unwrap(), [2, 3]);
        let e = sel("ff_e{1..4}").resolve(&h, p).unwrap_err().to_string();
        assert!(e.contains("x.csv:1") && e.contains("ff_e3") && e.contains("ff_e4"), "{e}");
        let e = sel("ff_*,ff_e1").resolve(&h, p).unwrap_err().to_string();
        assert!(e.contains("ff_*"), "a comma list is literal: {e}");
        let e = sel("ff_{1..2}*").resolve(&h, p).unwrap_err().to_string();
        assert!(e.contains("ff_2*"), "{e}");
        assert!("ff_*,".parse::<ColumnSelector>().is_err());
        let twice = ColumnSelector::Names(vec!["t".into(), "t".into()]).resolve(&h, p).unwrap_err();
        assert!(twice.to_string().contains("more than once"), "{twice}");
    }

    #[test]
    fn decimal_time_is_exact() {
        let s = TimeUnit::Seconds;
        assert_eq!(s.parse_nanos("1700000000.123456789"), Some(1_700_000_000_123_456_789));
        assert_eq!(s.parse_nanos("0.0000000005"), Some(1));
        assert_eq!(s.parse_nanos("0.0000000004999"), Some(0));
        assert_eq!(s.parse_nanos("-0.0000000005"), Some(-1));
        assert_eq!(s.parse_nanos("-1.25"), Some(-1_250_000_000));
        assert_eq!(s.parse_nanos(".5"), Some(500_000_000));
        assert_eq!(s.parse_nanos("2."), Some(2_000_000_000));
        assert_eq!(s.parse_nanos("1.5e-3"), Some(1_500_000));
        assert_eq!(s.parse_nanos("1e300"), None);
        assert_eq!(s.parse_nanos("nan"), None);
        assert_eq!(s.parse_nanos("inf"), None);
        assert_eq!(s.parse_nanos("."), None);
        assert_eq!(s.parse_nanos("-"), None);
        let ns = TimeUnit::Nanoseconds;
        assert_eq!(ns.parse_nanos("9223372036854775807"), Some(i64::MAX));
        assert_eq!(ns.parse_nanos("-9223372036854775808"), Some(i64::MIN));
        assert_eq!(ns.parse_nanos("9223372036854775808"), None);
        assert_eq!(ns.parse_nanos("12.5"), Some(13));
        assert_eq!(TimeUnit::Milliseconds.parse_nanos("1.0000015"), Some(1_000_002));
        assert_eq!(TimeUnit::Microseconds.parse_nanos("3"), Some(3_000));
    }

    #[test]
    fn unit_conversions_shared_by_the_sources() {
        let s = TimeUnit::Seconds;
        assert_eq!(s.nanos_per_unit(), 1_000_000_000);
        assert_eq!(TimeUnit::Nanoseconds.nanos_per_unit(), 1);
        assert_eq!(s.int_to_nanos(9), Some(9_000_000_000));
        assert_eq!(s.int_to_nanos(9_223_372_037), None, "beyond i64 nanoseconds");
        assert_eq!(TimeUnit::Nanoseconds.int_to_nanos(i128::from(i64::MIN)), Some(i64::MIN));
        assert_eq!(TimeUnit::Milliseconds.float_to_nanos(1.0000015), Some(1_000_002));
        assert_eq!(s.float_to_nanos(-2.5e-9), Some(-3), "ties away from zero");
        for bad in [f64::NAN, f64::INFINITY, 1e10] {
            assert_eq!(s.float_to_nanos(bad), None, "{bad}");
        }
    }

    #[test]
    fn config_validation() {
        let c = CsvSourceConfig::new("a.csv", sel("a"));
        assert!(c.validate().is_err(), "no time source");
        assert!(c.clone().with_rate_hz(100.0).validate().is_ok());
        for r in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(c.clone().with_rate_hz(r).validate().is_err(), "{r}");
        }
        let mut both = c.clone().with_rate_hz(1.0);
        both.time_column = Some("t".into());
        assert!(both.validate().is_err());
        assert!(c.clone().with_rate_hz(1.0).with_delimiter('é').validate().is_err());
    }

    #[test]
    fn config_from_toml_like_json() {
        let c: CsvSourceConfig =
            serde_json::from_str(r#"{"csv": "r.csv", "columns": "ff_e{1..24}", "rate_hz": 100.0}"#).unwrap();
        assert_eq!(c.path, PathBuf::from("r.csv"));
        assert_eq!(c.columns, ColumnSelector::Pattern("ff_e{1..24}".into()));
        assert_eq!(c.rate_hz, Some(100.0));
        let c: CsvSourceConfig =
            serde_json::from_str(r#"{"path": "r.csv", "columns": ["a", "b"], "time_column": "t", "time_unit": "ns"}"#)
                .unwrap();
        assert_eq!(c.columns, ColumnSelector::Names(vec!["a".into(), "b".into()]));
        assert_eq!(c.time_unit, TimeUnit::Nanoseconds);
        let back: CsvSourceConfig = serde_json::from_str(&serde_json::to_string(&c).unwrap()).unwrap();
        assert_eq!(back, c);
        let unknown = serde_json::from_str::<CsvSourceConfig>(r#"{"csv": "r.csv", "columns": "a", "rate": 1.0}"#);
        assert!(unknown.unwrap_err().to_string().contains("rate"));
        let bad = serde_json::from_str::<CsvSourceConfig>(r#"{"csv": "r.csv", "columns": "a{1..", "rate_hz": 1.0}"#);
        assert!(bad.is_err());
    }

    fn read(text: &str, config: &CsvSourceConfig) -> Vec<Result<TaxelFrame>> {
        CsvFrames::from_reader(text.as_bytes(), Path::new("t.csv"), config, SensorId::new("s")).unwrap().collect()
    }

    #[test]
    fn rate_times_and_seq() {
        let c = CsvSourceConfig::new("t.csv", sel("a,b")).with_rate_hz(3.0);
        let f: Vec<TaxelFrame> = read("a,b\n1,2\n3,4\n5,6\n7,8\n", &c).into_iter().map(|r| r.unwrap()).collect();
        assert_eq!(
            f.iter().map(|f| f.time.as_nanos()).collect::<Vec<_>>(),
            [0, 333_333_333, 666_666_667, 1_000_000_000]
        );
        assert_eq!(f.iter().map(|f| f.seq).collect::<Vec<_>>(), [0, 1, 2, 3]);
        assert_eq!(f[3].values, [7.0, 8.0]);
    }

    #[test]
    fn blank_lines_are_skipped_but_counted() {
        let c = CsvSourceConfig::new("t.csv", sel("a")).with_rate_hz(1.0);
        let r = read("a\n1\n\n2\n\nx\n", &c);
        assert_eq!(r.len(), 3);
        assert_eq!(r[1].as_ref().unwrap().seq, 1);
        let e = r[2].as_ref().unwrap_err().to_string();
        assert!(e.starts_with("t.csv:6 column \"a\""), "{e}");
    }

    #[test]
    fn lines_are_physical() {
        let c = CsvSourceConfig::new("t.csv", sel("a,b")).with_rate_hz(1.0);
        let err_line = |text: &'static str| match read(text, &c).pop().unwrap() {
            Err(Error::Parse { line, column, .. }) => (line, column),
            other => panic!("{other:?}"),
        };
        // A quoted field spanning lines 2-3: the next row starts on line 4.
        assert_eq!(err_line("a,b\n\"1\n\",2\nx,1\n"), (4, Some("a".into())));
        // The bad cell is itself in a row that spans lines 2-3: the row's first line.
        assert_eq!(err_line("a,b\n\"x\n\",2\n"), (2, Some("a".into())));
        // A byte-order mark, CRLF ends, blank lines before the header and between rows.
        assert_eq!(err_line("\u{feff}a,b\r\n1,2\r\n\r\n1,y\r\n"), (4, Some("b".into())));
        assert_eq!(err_line("\n\na,b\n1,2\n\n\n1,y"), (7, Some("b".into())));
        // Short rows (one character before the line end).
        assert_eq!(err_line("a,b\n1,2\n1,2\n1,2\n1,2\n1,2\n,\n"), (7, Some("a".into())));
    }

    #[test]
    fn bad_cells_name_line_and_column() {
        let c = CsvSourceConfig::new("t.csv", sel("a,b")).with_rate_hz(1.0);
        for (text, needle) in [
            ("a,b\n1,2\n1,\n", "t.csv:3 column \"b\": empty cell"),
            ("a,b\n1,2\n1,nan\n", "t.csv:3 column \"b\": \"nan\" is not a finite number"),
            ("a,b\n1,2\n1,inf\n", "not a finite number"),
            ("a,b\n1,2\nq,1\n", "t.csv:3 column \"a\": \"q\" is not a number"),
            ("a,b\n1,2\n1,2,3\n", "t.csv:3: the row has 3 fields, the header has 2"),
            ("a,b\r\n1,2\r\n1\r\n", "t.csv:3: the row has 1 fields"),
        ] {
            let r = read(text, &c);
            assert_eq!(r.len(), 2, "{text:?}: one frame then the error, then the end");
            let e = r[1].as_ref().unwrap_err().to_string();
            assert!(e.contains(needle), "{e:?} lacks {needle:?}");
        }
    }

    #[test]
    fn time_column_must_not_decrease() {
        let c = CsvSourceConfig::new("t.csv", sel("a")).with_time_column("t", TimeUnit::Nanoseconds);
        let r = read("t,a\n5,1\n5,2\n7,3\n6,4\n8,5\n", &c);
        assert_eq!(r.len(), 4);
        assert_eq!(r[1].as_ref().unwrap().time, Timestamp(5));
        let e = r[3].as_ref().unwrap_err().to_string();
        assert!(e.starts_with("t.csv:5 column \"t\": time goes back"), "{e}");
    }

    #[test]
    fn star_means_every_column_but_the_time() {
        let c: CsvSourceConfig =
            serde_json::from_str(r#"{"csv": "t.csv", "time_column": "t", "time_unit": "ns"}"#).unwrap();
        assert_eq!(c.columns, ColumnSelector::Pattern("*".into()));
        let f =
            CsvFrames::from_reader("x,t,y\n1,5,2\n".as_bytes(), Path::new("t.csv"), &c, SensorId::new("s")).unwrap();
        assert_eq!(f.columns(), ["x", "y"]);
        let frames: Vec<_> = f.map(Result::unwrap).collect();
        assert_eq!((frames[0].time, frames[0].values.clone()), (Timestamp(5), vec![1.0, 2.0]));
        // A literal name may still take the time column as a value.
        let c = c.clone();
        let c = CsvSourceConfig { columns: sel("t,x"), ..c };
        let f =
            CsvFrames::from_reader("x,t,y\n1,5,2\n".as_bytes(), Path::new("t.csv"), &c, SensorId::new("s")).unwrap();
        assert_eq!(f.columns(), ["t", "x"]);
        // Without a time column, `*` is every column.
        let c = CsvSourceConfig::new("t.csv", sel("*")).with_rate_hz(1.0);
        let f =
            CsvFrames::from_reader("x,t,y\n1,5,2\n".as_bytes(), Path::new("t.csv"), &c, SensorId::new("s")).unwrap();
        assert_eq!(f.columns(), ["x", "t", "y"]);
    }

    #[test]
    fn time_unit_from_str() {
        assert_eq!("ns".parse::<TimeUnit>().unwrap(), TimeUnit::Nanoseconds);
        assert_eq!("seconds".parse::<TimeUnit>().unwrap(), TimeUnit::Seconds);
        assert_eq!(" ms ".parse::<TimeUnit>().unwrap(), TimeUnit::Milliseconds);
        assert!("h".parse::<TimeUnit>().is_err());
    }

    #[test]
    fn the_scene_example_deserialises_from_toml() {
        #[derive(Deserialize)]
        struct Sensor {
            source: CsvSourceConfig,
        }
        let s: Sensor =
            toml::from_str(r#"source = { csv = "recording.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }"#).unwrap();
        assert_eq!(s.source, CsvSourceConfig::new("recording.csv", sel("ff_e{1..24}")).with_rate_hz(100.0));
        let s: Sensor = toml::from_str(
            "[source]\ncsv = \"r.tsv\"\ncolumns = [\"a\", \"b\"]\ntime_column = \"t\"\ntime_unit = \"ms\"\ndelimiter = \"\\t\"\n",
        )
        .unwrap();
        assert_eq!(s.source.delimiter, '\t');
        assert_eq!(s.source.time_unit, TimeUnit::Milliseconds);
        let e =
            toml::from_str::<Sensor>(r#"source = { csv = "r.csv", columns = "e{1..", rate_hz = 1.0 }"#).err().unwrap();
        assert!(e.to_string().contains("'{' without '}'"), "{e}");
    }

    #[test]
    fn frames_can_move_to_a_blocking_thread() {
        fn send<T: Send + 'static>() {}
        send::<CsvFrames<File>>();
        send::<CsvProgress>();
    }

    #[test]
    fn header_errors() {
        let c = CsvSourceConfig::new("t.csv", sel("a")).with_rate_hz(1.0);
        let open = |t: &'static str| CsvFrames::from_reader(t.as_bytes(), Path::new("t.csv"), &c, SensorId::new("s"));
        assert!(open("").unwrap_err().to_string().contains("no header"));
        assert!(open("b,c\n1,2\n").unwrap_err().to_string().contains("missing column [\"a\"]"));
        let ct = c.clone().with_time_column("time", TimeUnit::Seconds);
        let e = CsvFrames::from_reader("a\n1\n".as_bytes(), Path::new("t.csv"), &ct, SensorId::new("s")).unwrap_err();
        assert!(e.to_string().contains("time column \"time\""), "{e}");
        // A UTF-8 byte-order mark before the header is not part of the first name.
        let f = open("\u{feff}a\n1\n").unwrap();
        assert_eq!(f.columns(), ["a"]);
        assert_eq!(open("a\n").unwrap().count(), 0, "header only: no frames");
    }

    #[test]
    fn progress_counts_bytes() {
        let c = CsvSourceConfig::new("t.csv", sel("a")).with_rate_hz(1.0);
        let text = "a\n1\n22\n";
        let mut f = CsvFrames::from_reader(text.as_bytes(), Path::new("t.csv"), &c, SensorId::new("s")).unwrap();
        let p = f.progress();
        assert_eq!(p.bytes_read(), 2);
        f.next();
        assert_eq!(p.bytes_read(), 4);
        f.next();
        assert_eq!(f.bytes_read(), text.len() as u64);
        assert_eq!(p.total_bytes(), None);
    }

    /// Issue #12: an unbounded input without newlines (`/dev/zero`) stops at the line cap
    /// with file, line and a short excerpt instead of growing memory.
    #[test]
    fn an_endless_line_stops_at_the_cap_naming_file_and_line() {
        let c = CsvSourceConfig::new("zero", sel("a")).with_rate_hz(1.0);
        let e = CsvFrames::from_reader(std::io::repeat(0), Path::new("/dev/zero"), &c, SensorId::new("ff"))
            .err()
            .unwrap()
            .to_string();
        assert!(e.starts_with("/dev/zero:1: line 1 is longer than 1048576 bytes"), "{e}");
        assert!(e.len() < 700, "{}", e.len());
        // a long data line after a good header and row: its own line number, an excerpt
        let text = format!("a\n1\n2{}\n3\n", "9".repeat(MAX_LINE_BYTES as usize + 10));
        let e = read(&text, &c).pop().unwrap().unwrap_err().to_string();
        assert!(
            e.starts_with("t.csv:3: line 3 is longer than 1048576 bytes (the limit of a CSV line); it starts \"2999"),
            "{e}"
        );
        assert!(e.ends_with("99\"…") && e.len() < 400, "{e}");
    }

    /// Issue #12: a 300 MB header line costs at most the cap; a 1 MB bad cell gives a short
    /// error line that still names file, line and column.
    #[test]
    fn huge_headers_and_cells_give_short_errors() {
        let c = CsvSourceConfig::new("h.csv", sel("a")).with_rate_hz(1.0);
        let text = format!("{}\n1\n", "h".repeat(2 * MAX_LINE_BYTES as usize));
        let e = CsvFrames::from_reader(text.as_bytes(), Path::new("h.csv"), &c, SensorId::new("ff"))
            .err()
            .unwrap()
            .to_string();
        assert!(e.starts_with("h.csv:1: line 1 is longer than"), "{e}");
        let cell = "x".repeat(1 << 19);
        let e = read(&format!("a\n1\n{cell}\n"), &c).pop().unwrap().unwrap_err().to_string();
        assert!(e.starts_with("t.csv:3 column \"a\": \"xxxx"), "{e}");
        assert!(e.contains("… (524288 bytes)\" is not a number") && e.len() < 200, "{e}");
    }

    /// Issue #12: `rate_hz = 1e-9` used to stamp every frame from the 10th on with
    /// `i64::MAX` ns and exit 0; tiny rates are refused, and a time that would overflow at an
    /// accepted rate fails at its frame.
    #[test]
    fn rates_whose_times_overflow_are_refused() {
        let e = CsvSourceConfig::new("r.csv", sel("a")).with_rate_hz(1e-9).validate().unwrap_err().to_string();
        assert!(e.contains("rate_hz must be finite and within [1e-3, 1e9] Hz"), "{e}");
        assert!(CsvSourceConfig::new("r.csv", sel("a")).with_rate_hz(1e-3).validate().is_ok());
    }

    /// The fast path of numeric cells gives exactly what `f64::from_str` gives (bit for bit,
    /// signed zeros included), and declines what it cannot read.
    #[test]
    fn fast_cells_are_parsed_like_from_str() {
        for t in ["0", "-0", "+7", "3530", " 12 ", "0.1", "-0.000", "123456789012345", "1.00000000000001", "00042.50"] {
            let want: f64 = t.trim().parse().unwrap();
            assert_eq!(fast_f64(t.as_bytes()).map(f64::to_bits), Some(want.to_bits()), "{t:?}");
        }
        for t in
            ["", " ", "-", "+", ".", "1.", ".5", "1e3", "inf", "NaN", "1.2.3", "0x10", "1 2", "1234567890123456", "--1"]
        {
            assert_eq!(fast_f64(t.as_bytes()), None, "{t:?}");
        }
    }

    proptest::proptest! {
        /// Any short text of digits, dots, signs and blanks: where the fast path answers, it
        /// answers what `from_str` does.
        #[test]
        fn fast_path_agrees_with_from_str(t in "[ ]?[-+]?[0-9]{0,17}[.]?[0-9]{0,17}[ ]?") {
            if let Some(v) = fast_f64(t.as_bytes()) {
                let want: f64 = t.trim().parse().unwrap();
                proptest::prop_assert_eq!(v.to_bits(), want.to_bits());
            }
        }

        /// Decimals the fast path must take (≤ 15 digits) are taken.
        #[test]
        fn short_decimals_take_the_fast_path(i in 0u64..1_000_000_000, f in 0u64..100_000, neg: bool) {
            let t = format!("{}{i}.{f:05}", if neg { "-" } else { "" });
            let want: f64 = t.parse().unwrap();
            proptest::prop_assert_eq!(fast_f64(t.as_bytes()).map(f64::to_bits), Some(want.to_bits()));
        }
    }
}
