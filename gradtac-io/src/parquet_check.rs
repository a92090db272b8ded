//! Parquet page headers checked before the parquet crate reads a column chunk.
//!
//! A column chunk is a run of pages, each a Thrift compact-protocol `PageHeader` followed by
//! `compressed_page_size` bytes of data. The parquet crate (60) reads every header with a
//! Thrift reader that skips the fields it does not know — and its skip of a list (or map)
//! of booleans reads no bytes per element, so a header claiming a list of 2³¹ booleans takes
//! 2³¹ iterations from one 6-byte field, and a few such fields in a 16 kB file took a minute
//! (found by the `plot_parquet` fuzz target; see `docs/upstream-arrow-parquet.md`).
//!
//! [`check_column_chunk`] walks a chunk's page headers first, with a reader of its own that
//! consumes exactly the bytes the parquet crate's does (the same typed fields of
//! `PageHeader`, `DataPageHeader`, `DictionaryPageHeader`, `DataPageHeaderV2`, and its skip
//! for everything else, statistics included) but with every amount bounded:
//!
//! | what | bound |
//! |---|---|
//! | one page header | inside the column chunk, ≤ [`MAX_PAGE_HEADER_BYTES`] (as Arrow C++'s default) |
//! | a string / binary | ≤ the bytes left for the header |
//! | nesting of skipped fields | ≤ [`MAX_DEPTH`] (the parquet crate's own skip depth) |
//! | fields, list elements, map entries of all headers of a chunk | ≤ the chunk's length + [`WORK_SLACK`] (each takes ≥ 1 byte in a well-formed file) |
//! | a varint | ≤ 10 bytes |
//! | a page's data | `0 ≤ compressed_page_size ≤` the bytes left in the chunk, `uncompressed_page_size ≥ 0` |
//!
//! so the check, and the parquet crate's reading after it, take time linear in the chunk's
//! size. A chunk that breaks a bound is refused with the page and byte offset; the caller
//! adds the file, row group and column. Well-formed files (every writer's) pass: the bounds
//! are what the format implies. Cost: the headers are read twice (a few bytes per page;
//! the page data is seeked over).

use std::io::{Read, Seek, SeekFrom};

/// The most bytes one page header may take (Arrow C++'s default `max_page_header_size`).
pub const MAX_PAGE_HEADER_BYTES: u64 = 16 << 20;

/// The deepest nesting of skipped fields (the parquet crate's `DEFAULT_SKIP_DEPTH`).
pub const MAX_DEPTH: u32 = 64;

/// Work units (fields, list elements, map entries) allowed beyond one per byte of a chunk.
pub const WORK_SLACK: u64 = 64;

/// The longest varint (a u64 in 7-bit groups).
const MAX_VARINT_BYTES: usize = 10;

/// The first read of a page header (grown, doubling, up to the header bound).
const FIRST_READ: u64 = 64 << 10;

/// `PageType::INDEX_PAGE` (its data is skipped by the parquet crate).
pub const INDEX_PAGE: i32 = 1;

/// What a checked page header says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PageHeaderInfo {
    /// Bytes the header takes.
    pub header_len: usize,
    /// `PageHeader.type` (0 data, 1 index, 2 dictionary, 3 data v2).
    pub page_type: i32,
    /// `PageHeader.uncompressed_page_size`.
    pub uncompressed_page_size: i32,
    /// `PageHeader.compressed_page_size`: the bytes of data after the header.
    pub compressed_page_size: i32,
}

/// Why [`scan_page_header`] stopped.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ScanError {
    /// The header goes on past the bytes given, which are fewer than it may span: read more.
    NeedMore,
    /// The header goes on past the bytes it may span.
    PastEnd,
    /// Malformed.
    Bad(String),
    /// Beyond a bound: more work than the bytes allow, a string past its span, nesting.
    Bound(String),
}

/// The pages of a checked column chunk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChunkPages {
    /// Pages (dictionary and index pages included).
    pub pages: usize,
    /// Bytes of all page headers.
    pub header_bytes: u64,
    /// Bytes the pages declare uncompressed.
    pub uncompressed_bytes: u64,
}

/// Largest accepted ratio of a page's declared uncompressed size to its compressed size
/// (beyond [`PAGE_RATIO_FLOOR_BYTES`]): the parquet crate sizes its decompression buffer by
/// the declared size.
pub const MAX_PAGE_RATIO: u64 = 1024;
/// A page may declare up to this many bytes uncompressed whatever its compressed size (16 MiB;
/// writers cut pages at about 1 MiB).
pub const PAGE_RATIO_FLOOR_BYTES: u64 = 16 << 20;
/// The pages of a file may declare this many times the file's size uncompressed in all ...
pub const MAX_FILE_RATIO: u64 = 64;
/// ... or this many bytes (256 MiB), whichever is more.
pub const FILE_FLOOR_BYTES: u64 = 256 << 20;

/// The uncompressed bytes the pages of a file of `file_len` bytes may declare in all.
pub fn file_budget(file_len: u64) -> u64 {
    file_len.saturating_mul(MAX_FILE_RATIO).max(FILE_FLOOR_BYTES)
}

type Scan<T> = Result<T, ScanError>;

fn bad<T>(s: impl Into<String>) -> Scan<T> {
    Err(ScanError::Bad(s.into()))
}

fn beyond<T>(s: impl Into<String>) -> Scan<T> {
    Err(ScanError::Bound(s.into()))
}

/// A field of a struct the parquet crate reads typed (by field id, whatever type the field
/// header declares), as opposed to skipping it.
#[derive(Clone, Copy)]
enum Typed {
    /// An i32 or enum: one zigzag varint.
    I32,
    /// A bool: in the field header (an error if it declares another type).
    Bool,
    /// A struct, its typed fields; all others skipped.
    Struct(&'static [(i16, Typed)]),
}

/// `DataPageHeader` as read without statistics (field 5, statistics, is skipped).
const DATA_PAGE_HEADER: &[(i16, Typed)] = &[(1, Typed::I32), (2, Typed::I32), (3, Typed::I32), (4, Typed::I32)];
/// `IndexPageHeader`: no fields.
const INDEX_PAGE_HEADER: &[(i16, Typed)] = &[];
/// `DictionaryPageHeader`.
const DICTIONARY_PAGE_HEADER: &[(i16, Typed)] = &[(1, Typed::I32), (2, Typed::I32), (3, Typed::Bool)];
/// `DataPageHeaderV2` as read without statistics (field 8 skipped).
const DATA_PAGE_HEADER_V2: &[(i16, Typed)] = &[
    (1, Typed::I32),
    (2, Typed::I32),
    (3, Typed::I32),
    (4, Typed::I32),
    (5, Typed::I32),
    (6, Typed::I32),
    (7, Typed::Bool),
];
/// `PageHeader`.
const PAGE_HEADER: &[(i16, Typed)] = &[
    (1, Typed::I32),
    (2, Typed::I32),
    (3, Typed::I32),
    (4, Typed::I32),
    (5, Typed::Struct(DATA_PAGE_HEADER)),
    (6, Typed::Struct(INDEX_PAGE_HEADER)),
    (7, Typed::Struct(DICTIONARY_PAGE_HEADER)),
    (8, Typed::Struct(DATA_PAGE_HEADER_V2)),
];

// Thrift compact-protocol field types.
const T_BOOL_TRUE: u8 = 1;
const T_BOOL_FALSE: u8 = 2;
const T_BYTE: u8 = 3;
const T_I16: u8 = 4;
const T_I32: u8 = 5;
const T_I64: u8 = 6;
const T_DOUBLE: u8 = 7;
const T_BINARY: u8 = 8;
const T_LIST: u8 = 9;
const T_SET: u8 = 10;
const T_MAP: u8 = 11;
const T_STRUCT: u8 = 12;
const T_UUID: u8 = 13;

struct Cursor<'a> {
    buf: &'a [u8],
    pos: usize,
    /// The bytes the header may span (`buf` holds a prefix of them).
    span: u64,
    /// Work units left.
    budget: u64,
}

impl Cursor<'_> {
    fn end(&self) -> ScanError {
        if (self.buf.len() as u64) < self.span {
            ScanError::NeedMore
        } else {
            ScanError::PastEnd
        }
    }

    fn byte(&mut self) -> Scan<u8> {
        let b = *self.buf.get(self.pos).ok_or_else(|| self.end())?;
        self.pos += 1;
        Ok(b)
    }

    /// Skip `n` bytes, which must lie inside the span.
    fn skip_bytes(&mut self, n: u64, what: &str) -> Scan<()> {
        let left = self.span - self.pos as u64;
        if n > left {
            return beyond(format!("{what} of {n} bytes, {left} left for the page header"));
        }
        let to = self.pos as u64 + n;
        if to > self.buf.len() as u64 {
            return Err(ScanError::NeedMore);
        }
        self.pos = to as usize;
        Ok(())
    }

    fn charge(&mut self, units: u64, what: impl FnOnce() -> String) -> Scan<()> {
        match self.budget.checked_sub(units) {
            Some(b) => {
                self.budget = b;
                Ok(())
            }
            None => beyond(format!("{} (more than the column chunk's bytes allow)", what())),
        }
    }

    fn varint(&mut self) -> Scan<u64> {
        let mut v = 0u64;
        for i in 0..MAX_VARINT_BYTES {
            let b = self.byte()?;
            v |= u64::from(b & 0x7f).wrapping_shl(7 * i as u32);
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        bad(format!("a varint longer than {MAX_VARINT_BYTES} bytes"))
    }

    fn zigzag(&mut self) -> Scan<i64> {
        let v = self.varint()?;
        Ok((v >> 1) as i64 ^ -((v & 1) as i64))
    }

    /// A field header (`read_field_begin`): `None` at the stop field, else (type, id).
    fn field(&mut self, last_id: i16) -> Scan<Option<(u8, i16)>> {
        self.charge(1, || "too many fields".into())?;
        let b = self.byte()?;
        let ty = b & 0x0f;
        if ty == 0 {
            return Ok(None);
        }
        if ty > T_UUID {
            return bad(format!("field type {ty}"));
        }
        let delta = b >> 4;
        let id = if delta != 0 {
            last_id.checked_add(i16::from(delta)).map_or_else(|| bad(format!("field id {last_id} + {delta}")), Ok)?
        } else {
            self.zigzag()? as i16
        };
        Ok(Some((ty, id)))
    }

    /// An element type of a list, set or map (1 and 2 both mean bool).
    fn element_type(nibble: u8) -> Scan<u8> {
        match nibble {
            1 | 2 => Ok(T_BOOL_TRUE),
            3..=13 => Ok(nibble),
            _ => bad(format!("element type {nibble}")),
        }
    }

    /// Skip a value of type `ty`, as the parquet crate's `skip_till_depth` does (a bool,
    /// in a field header or as a list element, takes no bytes there).
    fn skip(&mut self, ty: u8, depth: u32) -> Scan<()> {
        if depth == 0 {
            return beyond(format!("fields nested deeper than {MAX_DEPTH}"));
        }
        match ty {
            T_BOOL_TRUE | T_BOOL_FALSE => Ok(()),
            T_BYTE => self.byte().map(drop),
            T_I16 | T_I32 | T_I64 => self.varint().map(drop),
            T_DOUBLE => self.skip_bytes(8, "a double"),
            T_UUID => self.skip_bytes(16, "a uuid"),
            T_BINARY => {
                let n = self.varint()?;
                self.skip_bytes(n, "a string")
            }
            T_STRUCT => {
                while let Some((ty, _)) = self.field(0)? {
                    self.skip(ty, depth - 1)?;
                }
                Ok(())
            }
            T_LIST | T_SET => {
                let h = self.byte()?;
                if h == 0 {
                    return Ok(()); // some writers' empty list
                }
                let elem = Self::element_type(h & 0x0f)?;
                let n = match h >> 4 {
                    15 => {
                        let n = self.varint()?;
                        i32::try_from(n).map_or_else(|_| bad(format!("a list of {n} elements")), Ok)?
                    }
                    n => i32::from(n),
                };
                self.charge(n as u64, || format!("a list of {n} elements"))?;
                for _ in 0..n {
                    self.skip(elem, depth - 1)?;
                }
                Ok(())
            }
            T_MAP => {
                let n = self.varint()?;
                let n = i32::try_from(n).map_or_else(|_| bad(format!("a map of {n} entries")), Ok)?;
                if n > 0 {
                    let kv = self.byte()?;
                    let (k, v) = (Self::element_type(kv >> 4)?, Self::element_type(kv & 0x0f)?);
                    self.charge(2 * n as u64, || format!("a map of {n} entries"))?;
                    for _ in 0..n {
                        self.skip(k, depth - 1)?;
                        self.skip(v, depth - 1)?;
                    }
                }
                Ok(())
            }
            _ => bad(format!("cannot skip field type {ty}")),
        }
    }

    /// Read a struct the parquet crate reads typed; the i32 values of fields 1–3 of this
    /// struct land in `top` (used for `PageHeader` itself).
    fn typed_struct(&mut self, fields: &[(i16, Typed)], mut top: Option<&mut [Option<i32>; 3]>) -> Scan<()> {
        let mut last = 0i16;
        while let Some((ty, id)) = self.field(last)? {
            match fields.iter().find(|(f, _)| *f == id).map(|(_, t)| *t) {
                Some(Typed::I32) => {
                    let v = self.zigzag()? as i32;
                    if let Some(top) = top.as_deref_mut() {
                        if (1..=3).contains(&id) {
                            top[id as usize - 1] = Some(v);
                        }
                    }
                }
                Some(Typed::Bool) => {
                    if ty != T_BOOL_TRUE && ty != T_BOOL_FALSE {
                        return bad(format!("field {id} should be a bool, is of type {ty}"));
                    }
                }
                Some(Typed::Struct(inner)) => self.typed_struct(inner, None)?,
                None => self.skip(ty, MAX_DEPTH)?,
            }
            last = id;
        }
        Ok(())
    }
}

/// Check the page header at the start of `buf`, which holds the first bytes (all, or a
/// prefix) of the `span` bytes the header may take; `budget` is the work left for the chunk
/// (fields, list elements, map entries), reduced by this header's on success.
pub fn scan_page_header(buf: &[u8], span: u64, budget: &mut u64) -> Result<PageHeaderInfo, ScanError> {
    let buf = &buf[..buf.len().min(usize::try_from(span).unwrap_or(usize::MAX))];
    let mut c = Cursor { buf, pos: 0, span, budget: *budget };
    let mut top = [None; 3];
    c.typed_struct(PAGE_HEADER, Some(&mut top))?;
    let [Some(page_type), Some(uncompressed_page_size), Some(compressed_page_size)] = top else {
        let missing = ["type", "uncompressed_page_size", "compressed_page_size"]
            .iter()
            .zip(top)
            .filter(|(_, v)| v.is_none())
            .map(|(n, _)| *n)
            .collect::<Vec<_>>();
        return bad(format!("no {}", missing.join(", ")));
    };
    *budget = c.budget;
    Ok(PageHeaderInfo { header_len: c.pos, page_type, uncompressed_page_size, compressed_page_size })
}

/// Bytes of the file read around the current page header.
struct Window {
    start: u64,
    buf: Vec<u8>,
}

impl Window {
    /// `want` bytes at `at` (which, with `want`, lies in the chunk ending at `end`).
    fn get<R: Read + Seek>(&mut self, r: &mut R, at: u64, want: u64, end: u64) -> std::io::Result<&[u8]> {
        let have = at >= self.start && at + want <= self.start + self.buf.len() as u64;
        if !have {
            let n = want.max(FIRST_READ).min(end - at);
            self.buf.clear();
            r.seek(SeekFrom::Start(at))?;
            r.by_ref().take(n).read_to_end(&mut self.buf)?;
            if (self.buf.len() as u64) < n {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::UnexpectedEof,
                    format!("the file ends at byte {}", at + self.buf.len() as u64),
                ));
            }
            self.start = at;
        }
        let from = (at - self.start) as usize;
        Ok(&self.buf[from..from + want as usize])
    }
}

/// Walk the page headers of the column chunk of `len` bytes at byte `start` of `r` (which
/// the caller has checked lie inside the file) and check them against the bounds in the
/// module doc. Reads only the headers (the page data is seeked over). The error names the
/// page (0-based) and its byte offset in the file.
pub fn check_column_chunk<R: Read + Seek>(r: &mut R, start: u64, len: u64) -> Result<ChunkPages, String> {
    let end = start.checked_add(len).ok_or_else(|| format!("a column chunk of {len} bytes at byte {start}"))?;
    let mut budget = len.saturating_add(WORK_SLACK);
    let mut window = Window { start: 0, buf: Vec::new() };
    let (mut at, mut pages, mut header_bytes, mut uncompressed_bytes) = (start, 0usize, 0u64, 0u64);
    while at < end {
        let left = end - at;
        let span = left.min(MAX_PAGE_HEADER_BYTES);
        let mut want = span.min(FIRST_READ);
        let page = |e: String| format!("page {pages} at byte {at}: {e}");
        let h = loop {
            let buf = window.get(r, at, want, end).map_err(|e| page(format!("cannot read: {e}")))?;
            let mut b = budget;
            match scan_page_header(buf, span, &mut b) {
                Ok(h) => {
                    budget = b;
                    break h;
                }
                Err(ScanError::NeedMore) => want = (want * 2).min(span),
                Err(ScanError::PastEnd) if span < left => {
                    return Err(page(format!("a page header longer than {MAX_PAGE_HEADER_BYTES} bytes")))
                }
                Err(ScanError::PastEnd) => {
                    return Err(page(format!(
                        "the page header runs past the end of the column chunk ({left} bytes left)"
                    )))
                }
                Err(ScanError::Bad(e) | ScanError::Bound(e)) => {
                    return Err(page(format!("malformed page header: {e}")))
                }
            }
        };
        let after = left - h.header_len as u64;
        if h.compressed_page_size < 0 || h.compressed_page_size as u64 > after || h.uncompressed_page_size < 0 {
            return Err(page(format!(
                "a page of {} bytes ({} uncompressed) where {after} bytes are left in the column chunk",
                h.compressed_page_size, h.uncompressed_page_size
            )));
        }
        let (c, u) = (h.compressed_page_size as u64, h.uncompressed_page_size as u64);
        if u > c.saturating_mul(MAX_PAGE_RATIO).max(PAGE_RATIO_FLOOR_BYTES) {
            return Err(page(format!(
                "a page of {c} bytes declares {u} bytes uncompressed: more than {MAX_PAGE_RATIO} times its size (and \
                 above {PAGE_RATIO_FLOOR_BYTES} bytes); refused as a decompression bomb"
            )));
        }
        at += h.header_len as u64 + c;
        header_bytes += h.header_len as u64;
        uncompressed_bytes += u;
        pages += 1;
    }
    Ok(ChunkPages { pages, header_bytes, uncompressed_bytes })
}

/// The most bytes a Parquet footer's metadata may take (64 MiB; gradtac's files hold a few
/// kB, and the parquet crate reads the whole footer into memory).
pub const MAX_FOOTER_BYTES: u64 = 64 << 20;

/// Check a Parquet file's footer (the Thrift `FileMetaData` before the closing
/// `len: u32, "PAR1"`) before the parquet crate parses it: its length inside the file and
/// ≤ [`MAX_FOOTER_BYTES`], and its Thrift structure walked as the parquet crate's skip would
/// with the bounds of a page header (strings inside the footer, nesting ≤ [`MAX_DEPTH`],
/// fields, list elements and map entries ≤ its bytes + [`WORK_SLACK`]). The parquet crate's
/// skip of an unknown list of booleans reads no byte per element, so a footer field claiming
/// 2³¹ booleans kept it busy for minutes, as page headers did. A file without the plain
/// `PAR1` trailer (too short, encrypted `PARE`) is left to the parquet crate to refuse.
pub fn check_footer<R: Read + Seek>(r: &mut R) -> Result<(), String> {
    let io = |e: std::io::Error| format!("cannot read the footer: {e}");
    let len = r.seek(SeekFrom::End(0)).map_err(io)?;
    if len < 12 {
        return Ok(());
    }
    let mut tail = [0u8; 8];
    r.seek(SeekFrom::Start(len - 8)).map_err(io)?;
    r.read_exact(&mut tail).map_err(io)?;
    if &tail[4..] != b"PAR1" {
        return Ok(());
    }
    let n = u64::from(u32::from_le_bytes([tail[0], tail[1], tail[2], tail[3]]));
    if n > len - 12 {
        return Err(format!("the footer claims {n} bytes of metadata, but the file holds {} before it", len - 12));
    }
    if n > MAX_FOOTER_BYTES {
        return Err(format!("a footer of {n} bytes (limit {MAX_FOOTER_BYTES})"));
    }
    let at = len - 8 - n;
    let mut buf = vec![0u8; n as usize];
    r.seek(SeekFrom::Start(at)).map_err(io)?;
    r.read_exact(&mut buf).map_err(io)?;
    let mut c = Cursor { buf: &buf, pos: 0, span: n, budget: n.saturating_add(WORK_SLACK) };
    // Walked as one skipped struct; the parquet crate reads its known fields typed (whatever
    // type a field header declares), so where the two readings part (a malformed type, a
    // premature end) the walk stops and the parquet crate decides; a bound broken before
    // that is refused.
    match c.skip(T_STRUCT, MAX_DEPTH) {
        Err(ScanError::Bound(e)) => {
            Err(format!("malformed footer at byte {}: {}", at + c.pos as u64, e.replace("column chunk", "footer")))
        }
        Ok(()) | Err(ScanError::Bad(_) | ScanError::NeedMore | ScanError::PastEnd) => Ok(()),
    }
}

/// [`check_column_chunk`] for every column chunk of a row group (before the parquet crate
/// reads it); the error names the column (index and path). Returns the bytes its pages
/// declare uncompressed (the caller bounds a file's total by [`file_budget`]).
pub fn check_row_group<R: Read + Seek>(
    r: &mut R,
    rg: &parquet::file::metadata::RowGroupMetaData,
) -> Result<u64, String> {
    let mut total = 0u64;
    for (j, c) in rg.columns().iter().enumerate() {
        let col = || format!("column {j} ({})", c.column_path());
        let start = c.dictionary_page_offset().unwrap_or(c.data_page_offset());
        let (start, len) = u64::try_from(start)
            .ok()
            .zip(u64::try_from(c.compressed_size()).ok())
            .ok_or_else(|| format!("{}: at byte {start}, {} bytes", col(), c.compressed_size()))?;
        let pages = check_column_chunk(r, start, len).map_err(|e| format!("{}: {e}", col()))?;
        total = total.saturating_add(pages.uncompressed_bytes);
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor as Io;

    /// A compact-protocol writer for hand-built headers.
    #[derive(Default)]
    struct W(Vec<u8>);

    impl W {
        fn varint(&mut self, mut v: u64) -> &mut Self {
            while v >= 0x80 {
                self.0.push((v as u8) | 0x80);
                v >>= 7;
            }
            self.0.push(v as u8);
            self
        }
        fn zz(&mut self, v: i64) -> &mut Self {
            self.varint(((v << 1) ^ (v >> 63)) as u64)
        }
        /// A field header with a delta from the last id.
        fn field(&mut self, delta: u8, ty: u8) -> &mut Self {
            self.0.push(delta << 4 | ty);
            self
        }
        fn i32_field(&mut self, delta: u8, v: i32) -> &mut Self {
            self.field(delta, T_I32).zz(v.into())
        }
        fn stop(&mut self) -> &mut Self {
            self.0.push(0);
            self
        }
        fn raw(&mut self, b: &[u8]) -> &mut Self {
            self.0.extend_from_slice(b);
            self
        }
        /// type, uncompressed, compressed, then a data page header (v1) and its stop.
        fn data_page(&mut self, size: i32) -> &mut Self {
            self.i32_field(1, 0).i32_field(1, size).i32_field(1, size);
            self.field(2, T_STRUCT).i32_field(1, 10).i32_field(1, 0).i32_field(1, 3).i32_field(1, 3)
        }
    }

    fn scan(b: &[u8]) -> Result<PageHeaderInfo, ScanError> {
        let mut budget = b.len() as u64 + WORK_SLACK;
        scan_page_header(b, b.len() as u64, &mut budget)
    }

    fn chunk(b: &[u8]) -> Result<ChunkPages, String> {
        check_column_chunk(&mut Io::new(b), 0, b.len() as u64)
    }

    #[test]
    fn a_plain_data_page_header() {
        let mut w = W::default();
        w.data_page(5).stop().stop();
        let h = scan(&w.0).unwrap();
        assert_eq!(
            h,
            PageHeaderInfo { header_len: w.0.len(), page_type: 0, uncompressed_page_size: 5, compressed_page_size: 5 }
        );
        w.raw(b"hello");
        assert_eq!(
            chunk(&w.0).unwrap(),
            ChunkPages { pages: 1, header_bytes: w.0.len() as u64 - 5, uncompressed_bytes: 5 }
        );
    }

    /// A page declaring 2 GB uncompressed from 5 bytes (the parquet crate sizes its
    /// decompression buffer by the claim) is refused; up to the 16 MiB floor any page passes.
    #[test]
    fn page_decompression_bombs_are_refused() {
        let page = |uncompressed: i32| {
            let mut w = W::default();
            w.i32_field(1, 0).i32_field(1, uncompressed).i32_field(1, 5);
            w.field(2, T_STRUCT).i32_field(1, 10).i32_field(1, 0).i32_field(1, 3).i32_field(1, 3);
            w.stop().stop().raw(b"hello");
            chunk(&w.0)
        };
        assert_eq!(page(16 << 20).unwrap().uncompressed_bytes, 16 << 20);
        let e = page(i32::MAX).unwrap_err();
        assert!(
            e.contains("page 0 at byte 0: a page of 5 bytes declares 2147483647 bytes") && e.contains("bomb"),
            "{e}"
        );
        assert_eq!(file_budget(1000), FILE_FLOOR_BYTES);
        assert_eq!(file_budget(1 << 30), 64 << 30);
    }

    #[test]
    fn pages_are_walked_by_their_compressed_size() {
        let mut w = W::default();
        // a dictionary page (type 2, field 7), a data page v2 (type 3, field 8), an index page
        w.i32_field(1, 2).i32_field(1, 3).i32_field(1, 3).field(4, T_STRUCT);
        w.i32_field(1, 2).i32_field(1, 0).field(1, T_BOOL_TRUE).stop().stop().raw(b"abc");
        w.i32_field(1, 3).i32_field(1, 4).i32_field(1, 2).i32_field(1, -7); // crc
        w.field(4, T_STRUCT);
        for v in [4, 0, 4, 0, 1, 0] {
            w.i32_field(1, v);
        }
        w.field(1, T_BOOL_FALSE).stop().stop().raw(b"de");
        w.i32_field(1, 1).i32_field(1, 0).i32_field(1, 0).field(3, T_STRUCT).stop().stop();
        assert_eq!(chunk(&w.0).unwrap().pages, 3);
    }

    #[test]
    fn unknown_fields_and_statistics_are_skipped_like_parquet_does() {
        let mut w = W::default();
        w.i32_field(1, 0).i32_field(1, 1).i32_field(1, 1);
        w.field(2, T_STRUCT).i32_field(1, 1).i32_field(1, 0).i32_field(1, 3).i32_field(1, 3);
        // statistics (field 5, skipped): max, min as binaries, null_count, is_max_value_exact
        w.field(1, T_STRUCT).field(1, T_BINARY).varint(3).raw(b"zzz").field(1, T_BINARY).varint(1).raw(b"a");
        w.field(1, T_I64).zz(-4).field(4, T_BOOL_TRUE).stop();
        w.stop();
        // unknown fields of PageHeader: a double, a uuid, a list of i32, a map string→bool, a
        // list of bools (no bytes per element in parquet's skip), a set of structs, a byte
        w.field(7, T_DOUBLE).raw(&[0; 8]).field(1, T_UUID).raw(&[0; 16]);
        w.field(1, T_LIST).raw(&[0x35]).zz(1).zz(2).zz(-3);
        w.field(1, T_MAP).varint(2).raw(&[0x81]).varint(1).raw(b"x").varint(0);
        w.field(1, T_LIST).raw(&[0x21]); // two bools
        w.field(1, T_SET).raw(&[0x1c]).field(1, T_BYTE).raw(&[9]).stop();
        w.field(0, T_BYTE).zz(300).raw(&[1]); // full field id 300
        w.field(1, T_LIST).raw(&[0]); // a writer's empty list
        w.stop().raw(b"x");
        assert_eq!(chunk(&w.0).unwrap().pages, 1);
    }

    #[test]
    fn a_huge_list_of_bools_is_refused_before_it_is_iterated() {
        // the fuzzer's slow header: an unknown field holding a list of 2³¹ − 1 booleans
        let mut w = W::default();
        w.data_page(0).stop().field(4, T_LIST).raw(&[0xf1]).varint(i32::MAX as u64).stop();
        let e = chunk(&w.0).unwrap_err();
        assert!(e.contains("page 0 at byte 0") && e.contains("a list of 2147483647 elements"), "{e}");
        // a map of bools likewise
        let mut w = W::default();
        w.data_page(0).stop().field(4, T_MAP).varint(1 << 30).raw(&[0x11]).stop();
        assert!(chunk(&w.0).unwrap_err().contains("a map of 1073741824 entries"));
        // nested lists: each small, together beyond the chunk's budget
        let mut w = W::default();
        w.data_page(0).stop().field(4, T_LIST).raw(&[0xf9]).varint(40);
        for _ in 0..40 {
            w.raw(&[0xf1]).varint(40);
        }
        w.stop();
        let e = chunk(&w.0).unwrap_err();
        assert!(e.contains("a list of 40 elements"), "{e}");
    }

    #[test]
    fn the_work_budget_is_shared_by_the_pages_of_a_chunk() {
        // each page alone passes; 100 of them with 20 bools each exceed the chunk's bytes
        let mut one = W::default();
        one.data_page(0).stop().field(4, T_LIST).raw(&[0xf1]).varint(20).stop();
        assert!(chunk(&one.0).is_ok());
        let all: Vec<u8> = std::iter::repeat_n(one.0.clone(), 100).flatten().collect();
        assert!(chunk(&all).unwrap_err().contains("a list of 20 elements"));
    }

    #[test]
    fn lengths_depths_and_sizes_are_bounded() {
        // a data page header; the next field (delta 4) is PageHeader's unknown field 9
        let head = || {
            let mut w = W::default();
            w.data_page(0).stop();
            w
        };
        // a string longer than what is left
        let mut w = head();
        w.field(4, T_BINARY).varint(1 << 40).stop();
        assert!(chunk(&w.0).unwrap_err().contains("a string of 1099511627776 bytes"));
        // nesting deeper than 64
        let mut w = head();
        w.field(4, T_STRUCT);
        for _ in 0..70 {
            w.field(1, T_STRUCT);
        }
        w.raw(&[0; 72]);
        assert!(chunk(&w.0).unwrap_err().contains("nested deeper than 64"));
        // an over-long varint
        let mut w = head();
        w.field(4, T_I64).raw(&[0xff; 11]).raw(&[0]).stop();
        assert!(chunk(&w.0).unwrap_err().contains("varint longer"));
        // a page larger than the rest of the chunk, a negative one
        for size in [10, -1] {
            let mut w = W::default();
            w.data_page(size).stop().stop().raw(b"abc");
            let e = chunk(&w.0).unwrap_err();
            assert!(e.contains(&format!("a page of {size} bytes")) && e.contains("3 bytes are left"), "{e}");
        }
        // a header cut by the end of the chunk, one with a field missing, a bad type
        let mut w = head();
        assert!(chunk(&w.0).unwrap_err().contains("runs past the end of the column chunk"));
        w.stop();
        assert!(chunk(&w.0[3..]).unwrap_err().contains("no type"), "{:?}", chunk(&w.0[3..]));
        assert!(chunk(&[0x0e]).unwrap_err().contains("field type 14"));
        // a bool field where the typed reader wants a bool
        let mut w = W::default();
        w.i32_field(1, 2).i32_field(1, 0).i32_field(1, 0).field(4, T_STRUCT);
        w.i32_field(1, 0).i32_field(1, 0).i32_field(1, 1).stop().stop();
        assert!(chunk(&w.0).unwrap_err().contains("field 3 should be a bool"));
    }

    #[test]
    fn a_header_longer_than_the_first_read_is_read_whole() {
        // statistics of 200 kB (more than the first 64 kB read)
        let mut w = W::default();
        w.data_page(2).field(1, T_STRUCT).field(1, T_BINARY).varint(200_000).raw(&vec![7; 200_000]).stop();
        w.stop().stop().raw(b"ab");
        let mut again = w.0.clone();
        again.extend_from_slice(&w.0);
        let mut file = vec![0u8; 100];
        file.extend_from_slice(&again);
        let c = check_column_chunk(&mut Io::new(&file), 100, again.len() as u64).unwrap();
        assert_eq!(c.pages, 2);
        assert_eq!(c.header_bytes, again.len() as u64 - 4);
    }

    #[test]
    fn a_prefix_asks_for_more_the_span_decides_past_end() {
        let mut w = W::default();
        w.data_page(0).stop().stop();
        let n = w.0.len();
        let mut b = 1000;
        assert_eq!(scan_page_header(&w.0[..n - 1], n as u64, &mut b), Err(ScanError::NeedMore));
        assert_eq!(scan_page_header(&w.0[..n - 1], n as u64 - 1, &mut b), Err(ScanError::PastEnd));
        assert_eq!(b, 1000, "a failed scan spends nothing");
        assert!(scan_page_header(&w.0, n as u64, &mut b).is_ok());
        assert!(b < 1000);
    }

    /// Files written by the parquet crate's own writer (as gradtac's `ParquetSink` does):
    /// every chunk passes, with as many pages as the parquet crate's page reader finds.
    #[test]
    fn parquet_written_files_pass_with_the_pages_parquet_reads() {
        use arrow_array::{ArrayRef, Float64Array, Int64Array, RecordBatch, StringArray};
        use parquet::arrow::ArrowWriter;
        use parquet::basic::{Compression, ZstdLevel};
        use parquet::file::properties::{EnabledStatistics, WriterProperties, WriterVersion};
        use parquet::file::reader::{FileReader, SerializedFileReader};
        use std::sync::Arc;

        let n = 5000;
        let t: ArrayRef = Arc::new(Int64Array::from_iter_values((0..n).map(|i| i * 1_000_000)));
        let v: ArrayRef = Arc::new(Float64Array::from_iter_values((0..n).map(|i| (i as f64).sin())));
        let s: ArrayRef = Arc::new(StringArray::from_iter_values((0..n).map(|i| format!("sensor-{}", i % 7))));
        let batch = RecordBatch::try_from_iter([("time_ns", t), ("value", v), ("sensor", s)]).unwrap();
        let dir = tempfile::tempdir().unwrap();
        for (version, stats, compression) in [
            (WriterVersion::PARQUET_1_0, EnabledStatistics::Page, Compression::UNCOMPRESSED),
            (WriterVersion::PARQUET_2_0, EnabledStatistics::Page, Compression::ZSTD(ZstdLevel::default())),
            (WriterVersion::PARQUET_2_0, EnabledStatistics::Chunk, Compression::UNCOMPRESSED),
        ] {
            let props = WriterProperties::builder()
                .set_writer_version(version)
                .set_statistics_enabled(stats)
                .set_write_page_header_statistics(stats == EnabledStatistics::Page)
                .set_compression(compression)
                .set_data_page_row_count_limit(300)
                .set_write_batch_size(100)
                .set_max_row_group_row_count(Some(2000))
                .build();
            let mut bytes = Vec::new();
            let mut w = ArrowWriter::try_new(&mut bytes, batch.schema(), Some(props)).unwrap();
            w.write(&batch).unwrap();
            w.close().unwrap();
            let path = dir.path().join("f.parquet");
            std::fs::write(&path, &bytes).unwrap();
            let reader = SerializedFileReader::new(std::fs::File::open(&path).unwrap()).unwrap();
            let mut checked = 0;
            for (i, rg) in reader.metadata().row_groups().iter().enumerate() {
                for (j, c) in rg.columns().iter().enumerate() {
                    let (start, len) = c.byte_range();
                    let got = check_column_chunk(&mut Io::new(&bytes), start, len).unwrap();
                    let expected = reader.get_row_group(i).unwrap().get_column_page_reader(j).unwrap().count();
                    assert_eq!(got.pages, expected, "{version:?} row group {i} column {j}");
                    assert!(expected > 1, "several pages per chunk ({expected})");
                    checked += 1;
                }
            }
            assert_eq!(checked, 9);
        }
    }

    /// The footer: a well-formed one passes; one whose unknown field claims a list of 2³¹
    /// booleans (the footer twin of the slow page header) is refused at once.
    #[test]
    fn footers_are_checked_like_page_headers() {
        let file = |meta: &[u8]| {
            let mut f = b"PAR1".to_vec();
            f.extend(meta);
            f.extend((meta.len() as u32).to_le_bytes());
            f.extend(b"PAR1");
            std::io::Cursor::new(f)
        };
        // FileMetaData { 1: version = 1 (i32), 3: num_rows = 0 (i64), stop }
        let mut w = W(Vec::new());
        w.field(1, T_I32).raw(&[0x02]).field(2, T_I64).raw(&[0x00]).raw(&[0x00]);
        assert!(check_footer(&mut file(&w.0)).is_ok());
        // an unknown field 9: a list of i32::MAX booleans, in 7 bytes
        let mut w = W(Vec::new());
        w.field(9, T_LIST).raw(&[0xF1, 0xFF, 0xFF, 0xFF, 0xFF, 0x07]).raw(&[0x00]);
        let t = std::time::Instant::now();
        let e = check_footer(&mut file(&w.0)).unwrap_err();
        assert!(e.contains("a list of 2147483647 elements"), "{e}");
        assert!(t.elapsed().as_secs_f64() < 0.1);
        // a length beyond the file, and a string beyond the footer
        let mut f = file(&[0x00]).into_inner();
        let k = f.len() - 8;
        f[k..k + 4].copy_from_slice(&1000u32.to_le_bytes());
        let e = check_footer(&mut std::io::Cursor::new(f)).unwrap_err();
        assert!(e.contains("claims 1000 bytes"), "{e}");
        let mut w = W(Vec::new());
        w.field(4, T_BINARY).raw(&[0xFF, 0x7F]).raw(&[0x00]);
        assert!(check_footer(&mut file(&w.0)).unwrap_err().contains("a string of 16383 bytes"));
        // a malformed type is left to the parquet crate (it reads known fields typed)
        assert!(check_footer(&mut file(&[0x1F, 0x00])).is_ok());
        // not Parquet or encrypted: left to the parquet crate
        assert!(check_footer(&mut std::io::Cursor::new(b"PAR1xxxxPARE".to_vec())).is_ok());
    }
}
