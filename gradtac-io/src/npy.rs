//! NumPy `.npy` source: a `frames × taxels` array, read row by row.
//!
//! # Format
//! A `.npy` file (format versions 1.0, 2.0 and 3.0) is the magic `\x93NUMPY`, a version, a
//! little-endian header length (2 bytes in 1.0, 4 bytes after), a header that is a Python dict
//! literal — `{'descr': '<f8', 'fortran_order': False, 'shape': (1000, 24), }` — and the raw
//! data. This source accepts
//! - `descr`: `f8`, `f4`, `i2`, `u2`, `i4` (and `i1`, `u1`, `u4`, which f64 also holds
//!   exactly), with byte order `<` (little), `>` (big), `|` (one byte) or `=` (this machine's);
//! - `fortran_order: False` (C order): frame `k` is row `k`;
//! - `shape`: two dimensions, `(frames, taxels)`, `taxels ≥ 1` (`frames` may be 0).
//!
//! The header is parsed here (a tiny grammar) rather than with a crate, so that every error
//! names the file and the byte offset of the offending token: a wrong magic (offset 0), an
//! unsupported version (6), a bad key or value (its offset in the header), a file shorter or
//! longer than the shape says (the offset where data ends / should end), a non-finite value
//! (the offset of the element).
//!
//! # Time
//! Either a separate 1-D `.npy` of timestamps, one per frame (`f8` in `time_unit`, default
//! seconds, rounded to the nearest ns; or integer `i8`, `u8`, `i4`, `u4` in `time_unit`,
//! exact), which must not decrease; or a fixed `rate_hz` (frame `k` at
//! `round(k·10⁹/rate_hz)` ns from 0, see [`Timestamp::at_rate`]). Exactly one is required.
//!
//! # Memory
//! Constant: one row of bytes and one timestamp are read at a time through `BufReader`s.

use crate::{Error, Result, TimeUnit};
use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
use serde::{Deserialize, Serialize};
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

/// Element type of a `.npy` array.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NpyDtype {
    /// `f8`: IEEE 754 binary64.
    F64,
    /// `f4`: IEEE 754 binary32.
    F32,
    /// `i1`.
    I8,
    /// `u1`.
    U8,
    /// `i2`.
    I16,
    /// `u2`.
    U16,
    /// `i4`.
    I32,
    /// `u4`.
    U32,
    /// `i8` (timestamps only).
    I64,
    /// `u8` (timestamps only).
    U64,
}

impl NpyDtype {
    /// Bytes per element.
    pub fn size(self) -> usize {
        match self {
            NpyDtype::I8 | NpyDtype::U8 => 1,
            NpyDtype::I16 | NpyDtype::U16 => 2,
            NpyDtype::F32 | NpyDtype::I32 | NpyDtype::U32 => 4,
            NpyDtype::F64 | NpyDtype::I64 | NpyDtype::U64 => 8,
        }
    }

    /// The NumPy type code without byte order (`f8`, `i2`, …).
    pub fn code(self) -> &'static str {
        match self {
            NpyDtype::F64 => "f8",
            NpyDtype::F32 => "f4",
            NpyDtype::I8 => "i1",
            NpyDtype::U8 => "u1",
            NpyDtype::I16 => "i2",
            NpyDtype::U16 => "u2",
            NpyDtype::I32 => "i4",
            NpyDtype::U32 => "u4",
            NpyDtype::I64 => "i8",
            NpyDtype::U64 => "u8",
        }
    }

    fn from_code(code: &str) -> Option<Self> {
        Some(match code {
            "f8" => NpyDtype::F64,
            "f4" => NpyDtype::F32,
            "i1" => NpyDtype::I8,
            "u1" => NpyDtype::U8,
            "i2" => NpyDtype::I16,
            "u2" => NpyDtype::U16,
            "i4" => NpyDtype::I32,
            "u4" => NpyDtype::U32,
            "i8" => NpyDtype::I64,
            "u8" => NpyDtype::U64,
            _ => return None,
        })
    }
}

/// A parsed `.npy` header.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NpyHeader {
    /// Format version (major, minor).
    pub version: (u8, u8),
    /// Element type.
    pub dtype: NpyDtype,
    /// True when elements are big-endian.
    pub big_endian: bool,
    /// True for Fortran (column-major) order.
    pub fortran_order: bool,
    /// The array's shape.
    pub shape: Vec<u64>,
    /// Byte offset of the first element.
    pub data_offset: u64,
}

impl NpyHeader {
    /// Number of elements (`None` on overflow).
    pub fn elements(&self) -> Option<u64> {
        self.shape.iter().try_fold(1u64, |a, &d| a.checked_mul(d))
    }

    /// The descr string (`<f8`).
    pub fn descr(&self) -> String {
        let order = if self.dtype.size() == 1 {
            '|'
        } else if self.big_endian {
            '>'
        } else {
            '<'
        };
        format!("{order}{}", self.dtype.code())
    }
}

fn bin_err(path: &Path, offset: u64, reason: impl Into<String>) -> Error {
    Error::Binary { path: path.to_owned(), offset, reason: reason.into() }
}

fn io_err(path: &Path, source: std::io::Error) -> Error {
    Error::Io { path: path.to_owned(), source }
}

/// Read and check the header of a `.npy` stream positioned at its start (the data follows).
pub fn read_header<R: Read>(reader: &mut R, path: &Path) -> Result<NpyHeader> {
    let mut pre = [0u8; 10];
    read_full(reader, &mut pre, path, 0, "the .npy preamble")?;
    if &pre[..6] != b"\x93NUMPY" {
        return Err(bin_err(
            path,
            0,
            format!("not a NumPy .npy file (magic {:02X?}, expected 93 4E 55 4D 50 59)", &pre[..6]),
        ));
    }
    let version = (pre[6], pre[7]);
    let (len, start) = match version.0 {
        1 => (u64::from(u16::from_le_bytes([pre[8], pre[9]])), 10u64),
        2 | 3 => {
            let mut more = [0u8; 2];
            read_full(reader, &mut more, path, 10, "the header length")?;
            (u64::from(u32::from_le_bytes([pre[8], pre[9], more[0], more[1]])), 12u64)
        }
        _ => return Err(bin_err(path, 6, format!("unsupported .npy format version {}.{}", version.0, version.1))),
    };
    if len > 1 << 20 {
        return Err(bin_err(path, 8, format!("header length {len} is implausibly large (corrupt header)")));
    }
    let mut text = vec![0u8; len as usize];
    read_full(reader, &mut text, path, start, "the header")?;
    let text = match version.0 {
        3 => String::from_utf8(text)
            .map_err(|e| bin_err(path, start + e.utf8_error().valid_up_to() as u64, "header is not UTF-8"))?,
        _ => {
            if let Some(i) = text.iter().position(|b| !b.is_ascii()) {
                return Err(bin_err(path, start + i as u64, "header is not ASCII (corrupt header)"));
            }
            text.iter().map(|&b| b as char).collect()
        }
    };
    let (dtype, big_endian, fortran_order, shape) =
        parse_dict(&text).map_err(|(at, r)| bin_err(path, start + at as u64, r))?;
    Ok(NpyHeader { version, dtype, big_endian, fortran_order, shape, data_offset: start + len })
}

fn read_full<R: Read>(r: &mut R, buf: &mut [u8], path: &Path, offset: u64, what: &str) -> Result<()> {
    r.read_exact(buf).map_err(|e| match e.kind() {
        std::io::ErrorKind::UnexpectedEof => bin_err(path, offset, format!("file ends inside {what}")),
        _ => io_err(path, e),
    })
}

/// A token of the header dict, with its byte position.
#[derive(Debug, PartialEq)]
enum Tok {
    Punct(char),
    Str(String),
    Int(u64),
    Bool(bool),
}

fn tokenize(s: &str) -> std::result::Result<Vec<(usize, Tok)>, (usize, String)> {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        match c {
            b' ' | b'\t' | b'\n' | b'\r' => i += 1,
            b'{' | b'}' | b'(' | b')' | b'[' | b']' | b':' | b',' => {
                out.push((i, Tok::Punct(c as char)));
                i += 1;
            }
            b'\'' | b'"' => {
                let end = s[i + 1..].find(c as char).ok_or((i, "unterminated string".to_string()))?;
                out.push((i, Tok::Str(s[i + 1..i + 1 + end].to_string())));
                i += end + 2;
            }
            b'0'..=b'9' => {
                let start = i;
                while i < b.len() && b[i].is_ascii_digit() {
                    i += 1;
                }
                // Python 2 longs: 100L
                let v =
                    s[start..i].parse::<u64>().map_err(|_| (start, format!("number {} too large", &s[start..i])))?;
                if i < b.len() && b[i] == b'L' {
                    i += 1;
                }
                out.push((start, Tok::Int(v)));
            }
            _ if s[i..].starts_with("True") => {
                out.push((i, Tok::Bool(true)));
                i += 4;
            }
            _ if s[i..].starts_with("False") => {
                out.push((i, Tok::Bool(false)));
                i += 5;
            }
            _ => {
                let ch = s[i..].chars().next().unwrap_or('?');
                return Err((i, format!("unexpected character {ch:?} in the header")));
            }
        }
    }
    Ok(out)
}

type Dict = (NpyDtype, bool, bool, Vec<u64>);

fn parse_dict(s: &str) -> std::result::Result<Dict, (usize, String)> {
    if !s.ends_with('\n') {
        return Err((s.len().saturating_sub(1), "header does not end with a newline (corrupt header)".into()));
    }
    let toks = tokenize(s)?;
    let mut it = toks.into_iter().peekable();
    let end = s.len();
    let expect = |it: &mut std::iter::Peekable<std::vec::IntoIter<(usize, Tok)>>, p: char| match it.next() {
        Some((_, Tok::Punct(c))) if c == p => Ok(()),
        Some((at, t)) => Err((at, format!("expected {p:?}, found {t:?}"))),
        None => Err((end, format!("header ends before {p:?}"))),
    };
    expect(&mut it, '{')?;
    let (mut descr, mut fortran, mut shape) = (None, None, None);
    loop {
        match it.next() {
            Some((_, Tok::Punct('}'))) => break,
            Some((at, Tok::Str(key))) => {
                expect(&mut it, ':')?;
                match key.as_str() {
                    "descr" => match it.next() {
                        Some((vat, Tok::Str(d))) => descr = Some((vat, d)),
                        Some((vat, Tok::Punct('['))) | Some((vat, Tok::Punct('('))) => {
                            return Err((vat, "structured dtypes are not supported".into()))
                        }
                        Some((vat, t)) => return Err((vat, format!("descr must be a string like '<f8', found {t:?}"))),
                        None => return Err((end, "header ends inside descr".into())),
                    },
                    "fortran_order" => match it.next() {
                        Some((vat, Tok::Bool(b))) => fortran = Some((vat, b)),
                        Some((vat, t)) => {
                            return Err((vat, format!("fortran_order must be True or False, found {t:?}")))
                        }
                        None => return Err((end, "header ends inside fortran_order".into())),
                    },
                    "shape" => {
                        let sat = match it.next() {
                            Some((sat, Tok::Punct('('))) => sat,
                            Some((sat, t)) => return Err((sat, format!("shape must be a tuple, found {t:?}"))),
                            None => return Err((end, "header ends inside shape".into())),
                        };
                        let mut dims = Vec::new();
                        loop {
                            match it.next() {
                                Some((_, Tok::Punct(')'))) => break,
                                Some((_, Tok::Int(v))) => {
                                    dims.push(v);
                                    match it.next() {
                                        Some((_, Tok::Punct(','))) => {}
                                        Some((_, Tok::Punct(')'))) => break,
                                        Some((a, t)) => {
                                            return Err((a, format!("expected ',' or ')' in shape, found {t:?}")))
                                        }
                                        None => return Err((end, "header ends inside shape".into())),
                                    }
                                }
                                Some((a, t)) => {
                                    return Err((a, format!("shape dimensions must be integers, found {t:?}")))
                                }
                                None => return Err((end, "header ends inside shape".into())),
                            }
                        }
                        shape = Some((sat, dims));
                    }
                    other => {
                        return Err((
                            at,
                            format!("unexpected key {other:?} (a .npy header has descr, fortran_order, shape)"),
                        ))
                    }
                }
                match it.next() {
                    Some((_, Tok::Punct(','))) => {}
                    Some((_, Tok::Punct('}'))) => break,
                    Some((a, t)) => return Err((a, format!("expected ',' or '}}', found {t:?}"))),
                    None => return Err((end, "header ends before '}'".into())),
                }
            }
            Some((at, t)) => return Err((at, format!("expected a key, found {t:?}"))),
            None => return Err((end, "header ends before '}'".into())),
        }
    }
    if let Some((at, t)) = it.next() {
        return Err((at, format!("unexpected {t:?} after the header dict")));
    }
    let (dat, d) = descr.ok_or((0, "header has no 'descr'".to_string()))?;
    let (_, fortran) = fortran.ok_or((0, "header has no 'fortran_order'".to_string()))?;
    let (_, shape) = shape.ok_or((0, "header has no 'shape'".to_string()))?;
    let (order, code) = d.split_at(d.chars().next().map_or(0, |c| if "<>|=".contains(c) { 1 } else { 0 }));
    let dtype = NpyDtype::from_code(code).ok_or_else(|| {
        (dat, format!("dtype {d:?} is not supported (use f8, f4, i2, u2, i4, i1, u1, u4; i8/u8 for timestamps)"))
    })?;
    let big = match order {
        ">" => true,
        "<" | "|" => false,
        "=" | "" => cfg!(target_endian = "big"),
        _ => false,
    };
    if order == "|" && dtype.size() != 1 {
        return Err((dat, format!("dtype {d:?}: '|' (no byte order) is only valid for 1-byte types")));
    }
    Ok((dtype, big, fortran, shape))
}

/// The first `$n` bytes of `$b` as a `$t`, big-endian when `$big`.
macro_rules! read_bytes {
    ($t:ty, $n:expr, $b:expr, $big:expr) => {{
        let mut a = [0u8; $n];
        a.copy_from_slice(&$b[..$n]);
        if $big {
            <$t>::from_be_bytes(a)
        } else {
            <$t>::from_le_bytes(a)
        }
    }};
}

fn element(dtype: NpyDtype, big: bool, b: &[u8]) -> f64 {
    match dtype {
        NpyDtype::F64 => read_bytes!(f64, 8, b, big),
        NpyDtype::F32 => f64::from(read_bytes!(f32, 4, b, big)),
        NpyDtype::I8 => f64::from(b[0] as i8),
        NpyDtype::U8 => f64::from(b[0]),
        NpyDtype::I16 => f64::from(read_bytes!(i16, 2, b, big)),
        NpyDtype::U16 => f64::from(read_bytes!(u16, 2, b, big)),
        NpyDtype::I32 => f64::from(read_bytes!(i32, 4, b, big)),
        NpyDtype::U32 => f64::from(read_bytes!(u32, 4, b, big)),
        NpyDtype::I64 => read_bytes!(i64, 8, b, big) as f64,
        NpyDtype::U64 => read_bytes!(u64, 8, b, big) as f64,
    }
}

/// A timestamp element in `unit` as integer ns; `Err` says why not.
fn timestamp(dtype: NpyDtype, big: bool, b: &[u8], unit: TimeUnit) -> std::result::Result<i64, String> {
    let int = |v: i128| {
        unit.int_to_nanos(v).ok_or_else(|| format!("timestamp {v} {} does not fit i64 nanoseconds", unit.as_str()))
    };
    match dtype {
        NpyDtype::F64 => {
            let x = read_bytes!(f64, 8, b, big);
            unit.float_to_nanos(x)
                .ok_or_else(|| format!("timestamp {x} {} is not finite or does not fit i64 nanoseconds", unit.as_str()))
        }
        NpyDtype::I64 => int(i128::from(read_bytes!(i64, 8, b, big))),
        NpyDtype::U64 => int(i128::from(read_bytes!(u64, 8, b, big))),
        NpyDtype::I32 => int(i128::from(read_bytes!(i32, 4, b, big))),
        NpyDtype::U32 => int(i128::from(read_bytes!(u32, 4, b, big))),
        other => Err(format!("timestamps of dtype {} are not supported (use f8, i8, u8, i4 or u4)", other.code())),
    }
}

/// A scene's `.npy` source.
///
/// ```toml
/// [sources.ff]
/// npy = "data/ff.npy"              # frames × taxels (alias `path`)
/// timestamps = "data/ff_t.npy"     # optional 1-D, one per frame …
/// time_unit = "s"                  # … in "s" (default), "ms", "us" or "ns"
/// # rate_hz = 100.0                # … or a fixed rate instead
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NpySourceConfig {
    /// The data file. Relative paths are relative to the working directory (a scene loader
    /// resolves them against the scene file first).
    #[serde(rename = "npy", alias = "path")]
    pub path: PathBuf,
    /// A 1-D `.npy` of one timestamp per frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timestamps: Option<PathBuf>,
    /// Unit of `timestamps`.
    #[serde(default)]
    pub time_unit: TimeUnit,
    /// Fixed sample rate (Hz) when there are no timestamps.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_hz: Option<f64>,
}

impl NpySourceConfig {
    /// Frames of `path` at a fixed rate (Hz).
    pub fn with_rate(path: impl Into<PathBuf>, rate_hz: f64) -> Self {
        NpySourceConfig { path: path.into(), timestamps: None, time_unit: TimeUnit::Seconds, rate_hz: Some(rate_hz) }
    }

    /// Frames of `path` stamped by the 1-D array in `timestamps`, in `unit`.
    pub fn with_timestamps(path: impl Into<PathBuf>, timestamps: impl Into<PathBuf>, unit: TimeUnit) -> Self {
        NpySourceConfig { path: path.into(), timestamps: Some(timestamps.into()), time_unit: unit, rate_hz: None }
    }
}

/// The timestamps file being read alongside.
#[derive(Debug)]
struct Times {
    path: PathBuf,
    reader: BufReader<File>,
    header: NpyHeader,
    unit: TimeUnit,
    last: Option<i64>,
}

/// Taxel frames from a `.npy` file (see the [module docs](self)): an [`Iterator`] of
/// `Result<TaxelFrame>` that stops after the first error.
#[derive(Debug)]
#[must_use = "iterators are lazy and do nothing unless consumed"]
pub struct NpyFrames {
    path: PathBuf,
    reader: BufReader<File>,
    header: NpyHeader,
    sensor: SensorId,
    frames: u64,
    taxels: usize,
    k: u64,
    row: Vec<u8>,
    times: Option<Times>,
    rate_hz: f64,
    done: bool,
}

fn open_checked(path: &Path) -> Result<(BufReader<File>, NpyHeader, u64)> {
    let f = File::open(path).map_err(|e| io_err(path, e))?;
    let len = f.metadata().map_err(|e| io_err(path, e))?.len();
    let mut r = BufReader::with_capacity(64 * 1024, f);
    let h = read_header(&mut r, path)?;
    Ok((r, h, len))
}

fn check_size(path: &Path, h: &NpyHeader, len: u64) -> Result<()> {
    let need = h
        .elements()
        .and_then(|n| n.checked_mul(h.dtype.size() as u64))
        .and_then(|n| n.checked_add(h.data_offset))
        .ok_or_else(|| bin_err(path, 0, format!("shape {:?} is too large", h.shape)))?;
    if len < need {
        return Err(bin_err(
            path,
            len,
            format!("file ends at byte {len} but shape {:?} of {} needs {need} bytes (truncated)", h.shape, h.descr()),
        ));
    }
    if len > need {
        return Err(bin_err(
            path,
            need,
            format!("{} bytes after the data that shape {:?} of {} describes", len - need, h.shape, h.descr()),
        ));
    }
    Ok(())
}

impl NpyFrames {
    /// Open `config.path` (and its timestamps), check headers, shapes and file sizes; frames
    /// belong to `sensor`.
    pub fn open(config: &NpySourceConfig, sensor: SensorId) -> Result<Self> {
        let path = config.path.clone();
        let (reader, header, len) = open_checked(&path)?;
        if !matches!(
            header.dtype,
            NpyDtype::F64
                | NpyDtype::F32
                | NpyDtype::I16
                | NpyDtype::U16
                | NpyDtype::I32
                | NpyDtype::I8
                | NpyDtype::U8
                | NpyDtype::U32
        ) {
            return Err(bin_err(
                &path,
                header.data_offset,
                format!("dtype {} is not supported for taxel values (f64 cannot hold every value)", header.descr()),
            ));
        }
        if header.fortran_order {
            return Err(bin_err(
                &path,
                0,
                "Fortran-order (column-major) arrays are not supported; save the array in C order \
                 (numpy.ascontiguousarray) so frames can be streamed row by row",
            ));
        }
        let [frames, taxels] = header.shape[..] else {
            return Err(bin_err(&path, 0, format!("shape {:?} is not 2-D; expected (frames, taxels)", header.shape)));
        };
        if taxels == 0 {
            return Err(bin_err(&path, 0, format!("shape {:?} has no taxels", header.shape)));
        }
        check_size(&path, &header, len)?;
        let taxels = usize::try_from(taxels).map_err(|_| bin_err(&path, 0, "too many taxels"))?;
        let times = match (&config.timestamps, config.rate_hz) {
            (Some(_), Some(_)) => {
                return Err(Error::InvalidConfig(format!(
                    "{}: give either timestamps or rate_hz, not both",
                    path.display()
                )))
            }
            (None, None) => {
                return Err(Error::InvalidConfig(format!(
                    "{}: the frames need timestamps (a .npy file) or a rate_hz",
                    path.display()
                )))
            }
            (None, Some(r)) => {
                Timestamp::check_rate_hz(r).map_err(Error::InvalidConfig)?;
                None
            }
            (Some(tp), None) => {
                let (r, h, len) = open_checked(tp)?;
                let n = match h.shape[..] {
                    [n] => n,
                    [n, 1] if !h.fortran_order || n <= 1 => n,
                    _ => return Err(bin_err(tp, 0, format!("timestamps must be a 1-D array, shape is {:?}", h.shape))),
                };
                if !matches!(h.dtype, NpyDtype::F64 | NpyDtype::I64 | NpyDtype::U64 | NpyDtype::I32 | NpyDtype::U32) {
                    return Err(bin_err(
                        tp,
                        h.data_offset,
                        format!("timestamps of dtype {} are not supported (use f8, i8, u8, i4 or u4)", h.descr()),
                    ));
                }
                if n != frames {
                    return Err(Error::InvalidConfig(format!(
                        "{} holds {n} timestamps but {} holds {frames} frames",
                        tp.display(),
                        path.display()
                    )));
                }
                check_size(tp, &h, len)?;
                Some(Times { path: tp.clone(), reader: r, header: h, unit: config.time_unit, last: None })
            }
        };
        Ok(NpyFrames {
            row: vec![0; taxels * header.dtype.size()],
            path,
            reader,
            header,
            sensor,
            frames,
            taxels,
            k: 0,
            times,
            rate_hz: config.rate_hz.unwrap_or(1.0),
            done: false,
        })
    }

    /// The data file's header.
    pub fn header(&self) -> &NpyHeader {
        &self.header
    }

    /// Number of frames in the file.
    pub fn frame_count(&self) -> u64 {
        self.frames
    }

    /// Taxels per frame.
    pub fn taxel_count(&self) -> usize {
        self.taxels
    }

    /// Frames yielded so far.
    pub fn position(&self) -> u64 {
        self.k
    }

    /// The sensor the frames belong to.
    pub fn sensor(&self) -> &SensorId {
        &self.sensor
    }

    fn read_frame(&mut self) -> Result<TaxelFrame> {
        let size = self.header.dtype.size();
        let row_off = self.header.data_offset + self.k * (self.taxels * size) as u64;
        self.reader.read_exact(&mut self.row).map_err(|e| match e.kind() {
            std::io::ErrorKind::UnexpectedEof => {
                bin_err(&self.path, row_off, format!("file ends inside frame {}", self.k))
            }
            _ => io_err(&self.path, e),
        })?;
        let mut values = Vec::with_capacity(self.taxels);
        for (j, b) in self.row.chunks_exact(size).enumerate() {
            let v = element(self.header.dtype, self.header.big_endian, b);
            if !v.is_finite() {
                return Err(bin_err(
                    &self.path,
                    row_off + (j * size) as u64,
                    format!("frame {} taxel {j}: value {v} is not finite", self.k),
                ));
            }
            values.push(v);
        }
        let time = match &mut self.times {
            None => Timestamp::checked_at_rate(self.k, self.rate_hz).ok_or_else(|| {
                bin_err(
                    &self.path,
                    row_off,
                    format!("frame {}: its time at {} Hz is beyond the i64-nanosecond range", self.k, self.rate_hz),
                )
            })?,
            Some(t) => {
                let ts = t.header.dtype.size();
                let off = t.header.data_offset + self.k * ts as u64;
                let mut b = [0u8; 8];
                t.reader.read_exact(&mut b[..ts]).map_err(|e| match e.kind() {
                    std::io::ErrorKind::UnexpectedEof => {
                        bin_err(&t.path, off, format!("file ends inside timestamp {}", self.k))
                    }
                    _ => io_err(&t.path, e),
                })?;
                let ns = timestamp(t.header.dtype, t.header.big_endian, &b[..ts], t.unit)
                    .map_err(|r| bin_err(&t.path, off, format!("timestamp {}: {r}", self.k)))?;
                if let Some(prev) = t.last {
                    if ns < prev {
                        return Err(bin_err(
                            &t.path,
                            off,
                            format!("timestamp {} ({ns} ns) is earlier than the one before ({prev} ns)", self.k),
                        ));
                    }
                }
                t.last = Some(ns);
                Timestamp(ns)
            }
        };
        Ok(TaxelFrame::new(self.sensor.clone(), time, self.k, values))
    }
}

impl Iterator for NpyFrames {
    type Item = Result<TaxelFrame>;

    fn next(&mut self) -> Option<Result<TaxelFrame>> {
        if self.done || self.k >= self.frames {
            return None;
        }
        let r = self.read_frame();
        match &r {
            Ok(_) => self.k += 1,
            Err(_) => self.done = true,
        }
        Some(r)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        if self.done {
            return (0, Some(0));
        }
        let left = usize::try_from(self.frames - self.k).unwrap_or(usize::MAX);
        (0, Some(left))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hdr(dict: &str) -> std::result::Result<Dict, (usize, String)> {
        parse_dict(dict)
    }

    #[test]
    fn parses_numpy_headers() {
        let (d, big, f, s) = hdr("{'descr': '<f8', 'fortran_order': False, 'shape': (3, 24), }        \n").unwrap();
        assert_eq!((d, big, f, s), (NpyDtype::F64, false, false, vec![3, 24]));
        let (d, big, _, s) = hdr("{\"descr\":\">i2\",\"shape\":(5,),\"fortran_order\":True}\n").unwrap();
        assert_eq!((d, big, s), (NpyDtype::I16, true, vec![5]));
        let (d, _, _, s) = hdr("{'descr': '|u1', 'fortran_order': False, 'shape': (), }\n").unwrap();
        assert_eq!((d, s), (NpyDtype::U8, vec![]));
        let (_, _, _, s) = hdr("{'descr': '<u2', 'fortran_order': False, 'shape': (2L, 3L), }\n").unwrap();
        assert_eq!(s, vec![2, 3]);
    }

    #[test]
    fn header_errors_point_at_the_token() {
        for (h, at, want) in [
            ("{'descr': '<c16', 'fortran_order': False, 'shape': (3,), }\n", 10, "not supported"),
            ("{'descr': [('a', '<f8')], 'fortran_order': False, 'shape': (3,), }\n", 10, "structured"),
            ("{'descr': '<f8', 'fortran_order': 0, 'shape': (3,), }\n", 34, "True or False"),
            ("{'descr': '<f8', 'fortran_order': False, 'shape': [3], }\n", 50, "tuple"),
            ("{'descr': '<f8', 'fortran_order': False, 'shape': (3, x), }\n", 54, "unexpected character"),
            ("{'descr': '<f8', 'fortran_order': False, 'shape': (3,), 'x': 1}\n", 56, "unexpected key"),
            ("{'descr': '<f8', 'fortran_order': False}\n", 0, "no 'shape'"),
            ("{'descr': '<f8', 'fortran_order': False, 'shape': (3,)\n", 55, "before '}'"),
            ("{'descr': '<f8', 'fortran_order': False, 'shape': (3,), 'x}\n", 56, "unterminated"),
            ("{'descr': '<f8', 'fortran_order': False, 'shape': (3,)}", 54, "newline"),
            ("{'descr': '|f8', 'fortran_order': False, 'shape': (3,)}\n", 10, "only valid for 1-byte"),
        ] {
            let (pos, r) = hdr(h).unwrap_err();
            assert!(r.contains(want), "{h}: {r}");
            assert_eq!(pos, at, "{h}: {r}");
        }
    }

    #[test]
    fn elements_and_timestamps_convert() {
        assert_eq!(element(NpyDtype::I16, true, &[0xFF, 0xFE]), -2.0);
        assert_eq!(element(NpyDtype::U16, false, &[0xFE, 0xFF]), 65534.0);
        assert_eq!(element(NpyDtype::F32, false, &1.5f32.to_le_bytes()), 1.5);
        assert_eq!(timestamp(NpyDtype::F64, false, &1.25f64.to_le_bytes(), TimeUnit::Seconds), Ok(1_250_000_000));
        assert_eq!(timestamp(NpyDtype::I64, true, &7i64.to_be_bytes(), TimeUnit::Milliseconds), Ok(7_000_000));
        assert!(timestamp(NpyDtype::I64, false, &i64::MAX.to_le_bytes(), TimeUnit::Seconds).is_err());
        assert!(timestamp(NpyDtype::F64, false, &f64::NAN.to_le_bytes(), TimeUnit::Seconds).is_err());
    }

    proptest::proptest! {
        /// Random bytes, and valid headers with one byte changed, never panic the header
        /// reader; errors carry an offset inside the input.
        #[test]
        fn header_reader_never_panics(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..200),
                                      at in 0usize..128, b in proptest::num::u8::ANY) {
            let _ = read_header(&mut &bytes[..], Path::new("x.npy"));
            let mut h = b"\x93NUMPY\x01\x00\x76\x00{'descr': '<f8', 'fortran_order': False, 'shape': (3, 24), }".to_vec();
            while h.len() < 127 {
                h.push(b' ');
            }
            h.push(b'\n');
            proptest::prop_assert!(read_header(&mut &h[..], Path::new("x.npy")).is_ok());
            h[at] = b;
            if let Err(Error::Binary { offset, .. }) = read_header(&mut &h[..], Path::new("x.npy")) {
                proptest::prop_assert!(offset <= 128);
            }
        }
    }
}
