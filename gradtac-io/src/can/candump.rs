//! can-utils `candump -l` log files: a streaming parser ([`CandumpReader`]), an offline
//! source of taxel frames ([`CandumpSource`]), a replay stream with original timing
//! ([`replay`]) and a writer ([`CandumpWriter`], [`write_candump`]).
//!
//! # Format
//! One frame per line, as written by `candump -l` (and read by `canplayer`):
//!
//! ```text
//! (1700000000.123456) can0 123#DEADBEEF          standard id: 3 hex digits
//! (1700000000.123789) can0 1ABCDEF0#0102         extended id: 8 hex digits
//! (1700000000.124000) can0 123#                  no data bytes
//! (1700000000.124100) can0 123#R                 remote request (optionally #R<dlc>)
//! (1700000000.124200) can0 123#1122334455667788_C   8 bytes with a raw DLC of 12 (len8_dlc)
//! (1700000000.124300) can0 20000004#0004000000000000 error frame (CAN_ERR_FLAG 0x20000000 in the id)
//! (1700000000.124400) can0 123##1DEADBEEF        CAN FD: `##`, a flags nibble, up to 64 bytes
//! (1700000000.124500) can0 123###…               CAN XL
//! ```
//!
//! The time in parentheses is seconds since the Unix epoch with up to 9 fraction digits
//! (candump writes 6); it becomes a [`Timestamp`] exactly (no floating point). An optional
//! trailing `R`/`T` (receive/transmit marker of `candump -x`) is accepted. Blank lines are
//! skipped.
//!
//! # What becomes a [`CanFrame`]
//! Classic data frames only. Remote frames and error frames carry no taxel data: they are
//! counted ([`CandumpStats`]) and skipped. CAN FD and CAN XL frames cannot go through a
//! classic 8-byte codec: by default ([`FdPolicy::Skip`]) their lines are checked for syntax,
//! counted and skipped; with [`FdPolicy::Error`] the first one is an error. Frames of other
//! interfaces are skipped when an interface is chosen ([`CandumpReader::with_interface`]).
//!
//! Any other malformed line is an [`Error::Parse`] naming `file:line` and what is wrong; the
//! reader then stops (a corrupt log is not guessed at).
//!
//! # Writing
//! [`CandumpWriter`] writes classic data frames as `candump -l` does (3- or 8-digit id,
//! upper-case hex, time with 6 fraction digits, truncated to the µs), so `canplayer` and
//! [`CandumpReader`] read them back; frames whose times are whole µs read back identical.
//! Times before the Unix epoch cannot be written (an error naming the frame).

use crate::blocking::{blocking_stream, BlockingStream};
use crate::can::codec::{CanCodec, CodecConfig};
use crate::can::frame::{CanFrame, MAX_EXTENDED_ID, MAX_STANDARD_ID};
use crate::can::reassembly::CanDecoder;
use crate::can::stats::{CanStats, StatsHandle};
use crate::can::stream::{CanStream, Timing};
use crate::{Error, Result};
use gradtac_stream::{IteratorStageExt, StageIter, TaxelFrame, Timestamp};
use serde::{Deserialize, Serialize};
use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

/// CAN error frame flag in a logged identifier.
const CAN_ERR_FLAG: u32 = 0x2000_0000;

/// What to do with CAN FD (`##`) and CAN XL (`###`) lines.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum FdPolicy {
    /// Check their syntax, count them and skip them (`"skip"`).
    #[default]
    #[serde(rename = "skip")]
    Skip,
    /// Fail at the first one (`"error"`).
    #[serde(rename = "error")]
    Error,
}

/// What a [`CandumpReader`] read and skipped.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct CandumpStats {
    /// Lines read (blank ones included).
    pub lines: u64,
    /// Classic data frames yielded.
    pub frames: u64,
    /// Remote (RTR) frames skipped.
    pub remote_skipped: u64,
    /// Error frames skipped.
    pub error_frames_skipped: u64,
    /// CAN FD / XL frames skipped.
    pub fd_skipped: u64,
    /// Frames of other interfaces skipped.
    pub other_interface: u64,
}

/// One parsed log line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LogEntry<'a> {
    /// A classic data frame.
    Data {
        /// Interface name.
        interface: &'a str,
        /// The frame.
        frame: CanFrame,
    },
    /// A remote request.
    Remote {
        /// Interface name.
        interface: &'a str,
    },
    /// An error frame.
    ErrorFrame {
        /// Interface name.
        interface: &'a str,
    },
    /// A CAN FD or XL frame.
    Fd {
        /// Interface name.
        interface: &'a str,
        /// Its identifier.
        id: u32,
        /// Its length in bytes.
        len: usize,
    },
}

/// Parse one log line (without its newline). `Ok(None)` for a blank line; `Err` says what is
/// wrong (the caller adds file and line).
pub fn parse_line(line: &str) -> std::result::Result<Option<LogEntry<'_>>, String> {
    let line = line.trim_end_matches(['\r', '\n']);
    if line.trim().is_empty() {
        return Ok(None);
    }
    let mut tokens = line.split_ascii_whitespace();
    let stamp = tokens.next().unwrap_or("");
    let time = parse_time(stamp)?;
    let interface = tokens.next().ok_or("missing interface and frame after the time")?;
    let frame = tokens.next().ok_or("missing frame after the interface (expected e.g. 123#DEADBEEF)")?;
    match tokens.next() {
        None | Some("R") | Some("T") => {}
        Some(t) => return Err(format!("unexpected {t:?} after the frame")),
    }
    if let Some(t) = tokens.next() {
        return Err(format!("unexpected {t:?} after the frame"));
    }
    let hash = frame.find('#').ok_or_else(|| format!("frame {frame:?} has no '#' between id and data"))?;
    let (id_s, rest) = (&frame[..hash], &frame[hash + 1..]);
    let id = u32::from_str_radix(id_s, 16)
        .ok()
        .filter(|_| id_s.bytes().all(|b| b.is_ascii_hexdigit()))
        .ok_or_else(|| format!("identifier {id_s:?} is not hexadecimal"))?;
    let extended = match id_s.len() {
        3 => false,
        8 => true,
        n => return Err(format!("identifier {id_s:?} has {n} digits; candump writes 3 (standard) or 8 (extended)")),
    };
    if !extended && id > MAX_STANDARD_ID {
        return Err(format!("standard identifier {id_s} is larger than 7FF"));
    }
    if extended && id > MAX_EXTENDED_ID {
        if id & !(CAN_ERR_FLAG | MAX_EXTENDED_ID) == 0 && id & CAN_ERR_FLAG != 0 {
            hex_bytes(rest, 8).map_err(|e| format!("error frame: {e}"))?;
            return Ok(Some(LogEntry::ErrorFrame { interface }));
        }
        return Err(format!("identifier {id_s} does not fit 29 bits"));
    }
    if let Some(fd) = rest.strip_prefix('#') {
        if let Some(xl) = fd.strip_prefix('#') {
            // CAN XL: checked loosely (its header fields vary between can-utils versions).
            if xl.is_empty() {
                return Err("CAN XL frame without content".into());
            }
            return Ok(Some(LogEntry::Fd { interface, id, len: xl.len() / 2 }));
        }
        let mut chars = fd.chars();
        match chars.next() {
            Some(c) if c.is_ascii_hexdigit() => {}
            _ => return Err(format!("CAN FD frame {frame:?}: expected a flags nibble after '##'")),
        }
        let data = hex_bytes(chars.as_str(), 64).map_err(|e| format!("CAN FD frame: {e}"))?;
        if !matches!(data.len(), 0..=8 | 12 | 16 | 20 | 24 | 32 | 48 | 64) {
            return Err(format!("CAN FD frame with {} bytes (not a valid FD length)", data.len()));
        }
        return Ok(Some(LogEntry::Fd { interface, id, len: data.len() }));
    }
    if let Some(r) = rest.strip_prefix('R') {
        if !(r.is_empty() || (r.len() == 1 && r.as_bytes()[0].is_ascii_digit() && r.as_bytes()[0] <= b'8')) {
            return Err(format!("remote frame {frame:?}: expected #R or #R<dlc 0-8>"));
        }
        return Ok(Some(LogEntry::Remote { interface }));
    }
    let (data_s, dlc) = match rest.split_once('_') {
        None => (rest, None),
        Some((d, x)) => (d, Some(x)),
    };
    let data = hex_bytes(data_s, 8)?;
    if let Some(x) = dlc {
        let ok = x.len() == 1 && u8::from_str_radix(x, 16).is_ok_and(|v| v > 8) && data.len() == 8;
        if !ok {
            return Err(format!("raw DLC suffix _{x} is allowed only after 8 data bytes, as one hex digit 9-F"));
        }
    }
    let frame = CanFrame::try_new(id, extended, data.as_slice(), time).map_err(|e| e.to_string())?;
    Ok(Some(LogEntry::Data { interface, frame }))
}

/// `(1700000000.123456)` → ns since the epoch, exactly.
fn parse_time(s: &str) -> std::result::Result<Timestamp, String> {
    let inner = s
        .strip_prefix('(')
        .and_then(|x| x.strip_suffix(')'))
        .ok_or_else(|| format!("expected a time like (1700000000.123456) at the start, found {s:?}"))?;
    let (secs, frac) = inner.split_once('.').ok_or_else(|| format!("time {s} has no '.'"))?;
    let digits = |x: &str| !x.is_empty() && x.bytes().all(|b| b.is_ascii_digit());
    if !digits(secs) || !digits(frac) || frac.len() > 9 {
        return Err(format!("time {s} is not seconds.fraction (digits, at most 9 after the point)"));
    }
    let secs: i64 = secs.parse().map_err(|_| format!("time {s} is out of range"))?;
    let frac: i64 = frac.parse::<i64>().unwrap_or(0) * 10i64.pow(9 - frac.len() as u32);
    secs.checked_mul(1_000_000_000)
        .and_then(|n| n.checked_add(frac))
        .map(Timestamp)
        .ok_or_else(|| format!("time {s} is out of range"))
}

/// Up to 64 bytes decoded from hex pairs, without allocating.
struct Bytes {
    buf: [u8; 64],
    len: usize,
}

impl Bytes {
    fn as_slice(&self) -> &[u8] {
        &self.buf[..self.len]
    }
    fn len(&self) -> usize {
        self.len
    }
}

fn hex_bytes(s: &str, max: usize) -> std::result::Result<Bytes, String> {
    if s.len() % 2 != 0 {
        return Err(format!("data {s:?} has an odd number of hex digits"));
    }
    if s.len() / 2 > max.min(64) {
        return Err(format!("{} data bytes; at most {max}", s.len() / 2));
    }
    fn nibble(c: u8) -> Option<u8> {
        match c {
            b'0'..=b'9' => Some(c - b'0'),
            b'a'..=b'f' => Some(c - b'a' + 10),
            b'A'..=b'F' => Some(c - b'A' + 10),
            _ => None,
        }
    }
    let mut out = Bytes { buf: [0; 64], len: s.len() / 2 };
    for (i, p) in s.as_bytes().chunks_exact(2).enumerate() {
        match (nibble(p[0]), nibble(p[1])) {
            (Some(h), Some(l)) => out.buf[i] = h << 4 | l,
            _ => return Err(format!("data {s:?} is not hexadecimal")),
        }
    }
    Ok(out)
}

/// Streams [`CanFrame`]s from a candump log, one line at a time (constant memory).
///
/// Yields `Err` ([`Error::Parse`] with file:line, or [`Error::Io`]) at the first malformed
/// line, then ends.
#[derive(Debug)]
#[must_use = "iterators are lazy and do nothing unless consumed"]
pub struct CandumpReader<R> {
    reader: R,
    path: PathBuf,
    line_no: u64,
    buf: Vec<u8>,
    interface: Option<String>,
    fd: FdPolicy,
    stats: CandumpStats,
    done: bool,
}

impl CandumpReader<BufReader<File>> {
    /// Open a log file.
    pub fn open(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let f = File::open(path).map_err(|source| Error::Io { path: path.to_owned(), source })?;
        Ok(Self::new(path, BufReader::with_capacity(64 * 1024, f)))
    }
}

impl<R: BufRead> CandumpReader<R> {
    /// A reader over any buffered input; `name` names it in errors.
    pub fn new(name: impl Into<PathBuf>, reader: R) -> Self {
        CandumpReader {
            reader,
            path: name.into(),
            line_no: 0,
            buf: Vec::with_capacity(128),
            interface: None,
            fd: FdPolicy::Skip,
            stats: CandumpStats::default(),
            done: false,
        }
    }

    /// Keep only frames of this interface (others are counted and skipped).
    pub fn with_interface(mut self, interface: impl Into<String>) -> Self {
        self.interface = Some(interface.into());
        self
    }

    /// What to do with CAN FD / XL lines (default [`FdPolicy::Skip`]).
    pub fn with_fd_policy(mut self, fd: FdPolicy) -> Self {
        self.fd = fd;
        self
    }

    /// Counts so far.
    pub fn stats(&self) -> &CandumpStats {
        &self.stats
    }

    /// The 1-based number of the last line read.
    pub fn line(&self) -> u64 {
        self.line_no
    }

    fn err(&mut self, reason: String) -> Option<Result<CanFrame>> {
        self.done = true;
        Some(Err(Error::Parse { path: self.path.clone(), line: self.line_no, column: None, reason }))
    }
}

/// Longest line (bytes) of a candump log: 4 KiB (a CAN FD line is under 200 bytes). A longer
/// line fails with its file and line number, so an unbounded input cannot grow memory.
pub const MAX_LINE_BYTES: u64 = 4096;

impl<R: BufRead> Iterator for CandumpReader<R> {
    type Item = Result<CanFrame>;

    fn next(&mut self) -> Option<Result<CanFrame>> {
        while !self.done {
            self.buf.clear();
            // at most one byte over the cap is read: an endless line (`/dev/zero`) stops here
            match std::io::Read::take(&mut self.reader, MAX_LINE_BYTES + 1).read_until(b'\n', &mut self.buf) {
                Ok(0) => {
                    self.done = true;
                    return None;
                }
                Ok(_) => {}
                Err(source) => {
                    self.done = true;
                    return Some(Err(Error::Io { path: self.path.clone(), source }));
                }
            }
            self.line_no += 1;
            self.stats.lines += 1;
            if self.buf.len() as u64 > MAX_LINE_BYTES {
                let start = String::from_utf8_lossy(&self.buf[..80]).into_owned();
                return self.err(format!("line longer than {MAX_LINE_BYTES} bytes; it starts {start:?}…"));
            }
            let Ok(text) = std::str::from_utf8(&self.buf) else {
                return self.err("not UTF-8 text".into());
            };
            let entry = match parse_line(text) {
                Ok(Some(e)) => e,
                Ok(None) => continue,
                Err(reason) => return self.err(reason),
            };
            let iface = match &entry {
                LogEntry::Data { interface, .. }
                | LogEntry::Remote { interface }
                | LogEntry::ErrorFrame { interface }
                | LogEntry::Fd { interface, .. } => *interface,
            };
            if self.interface.as_deref().is_some_and(|want| want != iface) {
                self.stats.other_interface += 1;
                continue;
            }
            match entry {
                LogEntry::Data { frame, .. } => {
                    self.stats.frames += 1;
                    return Some(Ok(frame));
                }
                LogEntry::Remote { .. } => self.stats.remote_skipped += 1,
                LogEntry::ErrorFrame { .. } => self.stats.error_frames_skipped += 1,
                LogEntry::Fd { id, len, .. } => match self.fd {
                    FdPolicy::Skip => self.stats.fd_skipped += 1,
                    FdPolicy::Error => {
                        return self.err(format!(
                            "CAN FD/XL frame (id {id:X}, {len} bytes): the decoder reads classic CAN frames only \
                             (set fd = \"skip\" to skip such frames)"
                        ))
                    }
                },
            }
        }
        None
    }
}

/// Writes [`CanFrame`]s as a `candump -l` log, one line per frame (see [Writing](self#writing)).
///
/// ```
/// use gradtac_io::can::{CanFrame, CandumpReader, CandumpWriter};
/// use gradtac_stream::Timestamp;
///
/// let f = CanFrame::standard(0x101, &[5, 0x12, 0x34], Timestamp(1_700_000_000_123_456_000))?;
/// let mut w = CandumpWriter::new("out.log", Vec::new(), "vcan0")?;
/// w.write(&f)?;
/// let text = w.finish()?;
/// assert_eq!(text, b"(1700000000.123456) vcan0 101#051234\n");
/// let back: Vec<CanFrame> = CandumpReader::new("out.log", &text[..]).collect::<Result<_, _>>()?;
/// assert_eq!(back, vec![f]);
/// # Ok::<(), gradtac_io::Error>(())
/// ```
#[derive(Debug)]
pub struct CandumpWriter<W: Write> {
    writer: W,
    name: PathBuf,
    interface: String,
    frames: u64,
    line: String,
}

impl CandumpWriter<BufWriter<File>> {
    /// Create (or truncate) a log file.
    pub fn create(path: impl AsRef<Path>, interface: &str) -> Result<Self> {
        let path = path.as_ref();
        let f = File::create(path).map_err(|source| Error::Io { path: path.to_owned(), source })?;
        Self::new(path, BufWriter::with_capacity(64 * 1024, f), interface)
    }
}

impl<W: Write> CandumpWriter<W> {
    /// A writer into any output; `name` names it in errors. The interface name must be one
    /// non-empty token without whitespace (as it is one field of the line).
    pub fn new(name: impl Into<PathBuf>, writer: W, interface: &str) -> Result<Self> {
        if interface.is_empty() || interface.chars().any(char::is_whitespace) {
            return Err(Error::InvalidConfig(format!(
                "candump interface name {interface:?} must be one non-empty word without whitespace"
            )));
        }
        Ok(CandumpWriter { writer, name: name.into(), interface: interface.into(), frames: 0, line: String::new() })
    }

    /// Write one frame as one line. A time before the Unix epoch is an [`Error::Record`]
    /// naming the frame (nothing is written).
    pub fn write(&mut self, frame: &CanFrame) -> Result<()> {
        use std::fmt::Write as _;
        let ns = frame.time().as_nanos();
        if ns < 0 {
            return Err(Error::Record {
                schema: "candump".into(),
                reason: format!(
                    "frame {} (id {}) at {ns} ns is before the Unix epoch; a candump log cannot hold it",
                    self.frames,
                    frame.id_string()
                ),
            });
        }
        self.line.clear();
        let _ = write!(
            self.line,
            "({}.{:06}) {} {}#",
            ns / 1_000_000_000,
            (ns % 1_000_000_000) / 1000,
            self.interface,
            frame.id_string()
        );
        for b in frame.data() {
            let _ = write!(self.line, "{b:02X}");
        }
        self.line.push('\n');
        self.writer.write_all(self.line.as_bytes()).map_err(|source| Error::Io { path: self.name.clone(), source })?;
        self.frames += 1;
        Ok(())
    }

    /// Frames written so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Flush and return the output.
    pub fn finish(mut self) -> Result<W> {
        self.writer.flush().map_err(|source| Error::Io { path: self.name.clone(), source })?;
        Ok(self.writer)
    }
}

/// Write `frames` (each with its own time) to `writer` as a `candump -l` log of interface
/// `interface`; returns the number of lines written. See [`CandumpWriter`].
pub fn write_candump<W: Write>(frames: impl IntoIterator<Item = CanFrame>, interface: &str, writer: W) -> Result<u64> {
    let mut w = CandumpWriter::new("candump output", writer, interface)?;
    for f in frames {
        w.write(&f)?;
    }
    let n = w.frames();
    w.finish()?;
    Ok(n)
}

fn one() -> f64 {
    1.0
}

/// A scene's candump source.
///
/// ```toml
/// [sources.hand]
/// candump = "recordings/grasp.log"   # the log (alias `path`)
/// interface = "can0"                 # optional: keep only this interface
/// timing = "fast"                    # "fast" (as fast as possible) | "original"
/// speed = 1.0                        # with "original": 2.0 replays twice as fast
/// fd = "skip"                        # CAN FD lines: "skip" | "error"
/// [sources.hand.codec.preset]
/// kind = "biotac-mux"
/// sensors = ["ff", "mf", "th"]
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CandumpConfig {
    /// The log file. Relative paths are relative to the working directory (a scene loader
    /// resolves them against the scene file first).
    #[serde(rename = "candump", alias = "path")]
    pub path: PathBuf,
    /// Keep only frames of this interface.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub interface: Option<String>,
    /// Replay pacing of the async source ([`replay`]); the iterator ignores it.
    #[serde(default)]
    pub timing: Timing,
    /// Speed factor for `timing = "original"` (> 0).
    #[serde(default = "one")]
    pub speed: f64,
    /// CAN FD / XL lines.
    #[serde(default)]
    pub fd: FdPolicy,
    /// The frame codec.
    pub codec: CodecConfig,
}

impl CandumpConfig {
    /// A config with defaults: fast timing, all interfaces, FD lines skipped.
    pub fn new(path: impl Into<PathBuf>, codec: CodecConfig) -> Self {
        CandumpConfig {
            path: path.into(),
            interface: None,
            timing: Timing::Fast,
            speed: 1.0,
            fd: FdPolicy::Skip,
            codec,
        }
    }

    fn reader(&self) -> Result<CandumpReader<BufReader<File>>> {
        let mut r = CandumpReader::open(&self.path)?.with_fd_policy(self.fd);
        if let Some(i) = &self.interface {
            r = r.with_interface(i.clone());
        }
        Ok(r)
    }
}

/// Taxel frames from a candump log, offline (an [`Iterator`]): [`CandumpReader`] →
/// [`CanDecoder`]. Bad traffic is counted in [`stats`](Self::stats); a malformed line ends
/// the iteration with an error naming file:line (the frames decoded before it are yielded
/// first).
#[must_use = "iterators are lazy and do nothing unless consumed"]
#[derive(Debug)]
pub struct CandumpSource<R = BufReader<File>> {
    /// The reader driving the decoder ([`StageIter`] flushes the decoder at the end of the log).
    frames: StageIter<CandumpReader<R>, CanDecoder>,
}

impl CandumpSource {
    /// Open the source a scene describes (its `timing` does not apply to an iterator).
    pub fn open(config: &CandumpConfig) -> Result<Self> {
        let codec = CanCodec::try_new(&config.codec)?;
        Ok(CandumpSource::new(config.reader()?, CanDecoder::new(codec)))
    }
}

impl<R: BufRead> CandumpSource<R> {
    /// A source from a reader and a decoder.
    pub fn new(reader: CandumpReader<R>, decoder: CanDecoder) -> Self {
        CandumpSource { frames: reader.stage(decoder) }
    }

    /// The decoder's counts so far.
    pub fn stats(&self) -> CanStats {
        self.frames.stage_ref().stats()
    }

    /// A shared handle on the decoder's counts.
    pub fn stats_handle(&self) -> StatsHandle {
        self.frames.stage_ref().stats_handle()
    }

    /// The reader's counts (lines, skipped remote/error/FD frames).
    pub fn reader_stats(&self) -> &CandumpStats {
        self.frames.inner().stats()
    }
}

impl<R: BufRead> Iterator for CandumpSource<R> {
    type Item = Result<TaxelFrame>;

    /// The next frame; a reader error is yielded once, then the iteration ends. (The decoder
    /// itself never fails on traffic: bad traffic is counted, not an error.)
    fn next(&mut self) -> Option<Result<TaxelFrame>> {
        self.frames.next()
    }
}

/// Replay a candump log as a tokio stream of taxel frames, with the config's timing:
/// `"original"` sleeps (tokio time) so that frames leave at their logged spacing divided by
/// `speed`; `"fast"` yields them as fast as the consumer takes them. The file is read on
/// tokio's blocking pool ([`blocking_stream`]), so the async side never blocks on I/O.
///
/// Must be called inside a tokio runtime (an error otherwise, not a panic).
pub fn replay(config: &CandumpConfig) -> Result<CanStream<BlockingStream<CanFrame, Error>>> {
    if tokio::runtime::Handle::try_current().is_err() {
        return Err(Error::InvalidConfig(format!(
            "candump replay of {}: must be started inside a tokio runtime",
            config.path.display()
        )));
    }
    let codec = CanCodec::try_new(&config.codec)?;
    let reader = config.reader()?;
    CanStream::new(blocking_stream(reader, 256), CanDecoder::new(codec)).with_timing(config.timing, config.speed)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(line: &str) -> CanFrame {
        match parse_line(line).unwrap().unwrap() {
            LogEntry::Data { frame, .. } => frame,
            e => panic!("not data: {e:?}"),
        }
    }

    #[test]
    fn parses_standard_extended_and_empty_frames() {
        let f = data("(1700000000.123456) can0 123#DEADBEEF");
        assert_eq!((f.id(), f.is_extended(), f.data()), (0x123, false, &[0xDE, 0xAD, 0xBE, 0xEF][..]));
        assert_eq!(f.time(), Timestamp(1_700_000_000_123_456_000));
        let f = data("(1.5) vcan0 1ABCDEF0#0102 R");
        assert_eq!((f.id(), f.is_extended(), f.data()), (0x1ABC_DEF0, true, &[1, 2][..]));
        assert_eq!(f.time(), Timestamp(1_500_000_000));
        let f = data("(0.000000001) can0 000#\r\n");
        assert!(f.is_empty());
        assert_eq!(f.time(), Timestamp(1));
        assert_eq!(data("(1.0) can0 00000123#11").id(), 0x123); // extended with a small id
        assert_eq!(data("(1.0) can0 123#1122334455667788_C").len(), 8);
        assert_eq!(parse_line("   ").unwrap(), None);
    }

    #[test]
    fn classifies_remote_error_and_fd_lines() {
        assert!(matches!(parse_line("(1.0) can0 123#R").unwrap(), Some(LogEntry::Remote { .. })));
        assert!(matches!(parse_line("(1.0) can0 123#R4").unwrap(), Some(LogEntry::Remote { .. })));
        assert!(matches!(
            parse_line("(1.0) can0 20000004#0004000000000000").unwrap(),
            Some(LogEntry::ErrorFrame { .. })
        ));
        assert_eq!(
            parse_line("(1.0) can1 123##1DEADBEEF").unwrap(),
            Some(LogEntry::Fd { interface: "can1", id: 0x123, len: 4 })
        );
        let twelve = format!("(1.0) can1 123##0{}", "AB".repeat(12));
        assert!(matches!(parse_line(&twelve).unwrap(), Some(LogEntry::Fd { len: 12, .. })));
    }

    #[test]
    fn rejects_malformed_lines_with_reasons() {
        for (line, want) in [
            ("1.0 can0 123#00", "expected a time"),
            ("(1,0) can0 123#00", "no '.'"),
            ("(1.0123456789) can0 123#00", "at most 9"),
            ("(1.0) can0", "missing frame"),
            ("(1.0)", "missing interface"),
            ("(1.0) can0 12300", "no '#'"),
            ("(1.0) can0 12G#00", "not hexadecimal"),
            ("(1.0) can0 1234#00", "4 digits"),
            ("(1.0) can0 800#00", "larger than 7FF"),
            ("(1.0) can0 40000000#00", "29 bits"),
            ("(1.0) can0 123#0", "odd number"),
            ("(1.0) can0 123#0G", "not hexadecimal"),
            ("(1.0) can0 123#112233445566778899", "at most 8"),
            ("(1.0) can0 123#11_9", "only after 8 data bytes"),
            ("(1.0) can0 123##G00", "flags nibble"),
            (&format!("(1.0) can0 123##0{}", "00".repeat(9)), "not a valid FD length"),
            ("(1.0) can0 123#R9", "#R<dlc"),
            ("(1.0) can0 123#00 extra", "unexpected"),
        ] {
            let e = parse_line(line).unwrap_err();
            assert!(e.contains(want), "{line}: {e}");
        }
    }

    /// Issue #12: an unbounded input (`candump = "/dev/zero"`) stops at the line cap.
    #[test]
    fn an_endless_line_stops_at_the_cap() {
        let mut r = CandumpReader::new("/dev/zero", std::io::BufReader::new(std::io::repeat(b'1')));
        let e = r.next().unwrap().unwrap_err().to_string();
        assert!(e.starts_with("/dev/zero:1: line longer than 4096 bytes; it starts \"111"), "{e}");
        assert!(e.len() < 200 && r.next().is_none(), "{e}");
    }

    #[test]
    fn reader_names_file_and_line_and_counts_skips() {
        let log = "(1.0) can0 123#01\n\n(1.1) can1 123#02\n(1.2) can0 123#R\n(1.3) can0 123##1AA\n\
                   (1.4) can0 20000004#0000000000000000\n(1.5) can0 124#03\n(1.6) can0 xyz\n(1.7) can0 125#04\n";
        let mut r = CandumpReader::new("grasp.log", log.as_bytes()).with_interface("can0");
        let ids: Vec<u32> = r.by_ref().take(2).map(|f| f.unwrap().id()).collect();
        assert_eq!(ids, vec![0x123, 0x124]);
        let e = r.next().unwrap().unwrap_err().to_string();
        assert_eq!(e, "grasp.log:8: frame \"xyz\" has no '#' between id and data");
        assert!(r.next().is_none());
        let s = r.stats();
        assert_eq!(
            (s.lines, s.frames, s.other_interface, s.remote_skipped, s.fd_skipped, s.error_frames_skipped),
            (8, 2, 1, 1, 1, 1)
        );
        let mut r = CandumpReader::new("x.log", "(1.0) can0 123##1AA\n".as_bytes()).with_fd_policy(FdPolicy::Error);
        let e = r.next().unwrap().unwrap_err().to_string();
        assert!(e.starts_with("x.log:1: CAN FD/XL frame (id 123, 1 bytes)"), "{e}");
        let mut r = CandumpReader::new("bin.log", &b"(1.0) can0 123#\xFF\n"[..]);
        assert_eq!(r.next().unwrap().unwrap_err().to_string(), "bin.log:1: not UTF-8 text");
    }

    #[test]
    fn candump_lines_round_trip() {
        let f = CanFrame::extended(0x1234567, &[9, 8, 7], Timestamp(1_700_000_001_000_002_000)).unwrap();
        assert_eq!(data(&f.to_candump_line("can0")), f);
    }

    proptest::proptest! {
        /// Arbitrary text, and mutations of valid lines, never panic the parser.
        #[test]
        fn parse_line_never_panics(s in "\\PC{0,60}", valid in 0usize..4, cut in 0usize..40, junk in "[#R_.()0-9A-Fa-z ]{0,6}") {
            let _ = parse_line(&s);
            let lines = ["(1700000000.123456) can0 123#DEADBEEF", "(1.5) vcan0 1ABCDEF0#0102 R",
                         "(1.0) can1 123##1DEADBEEF", "(1.0) can0 20000004#0004000000000000"];
            let l = lines[valid];
            let cut = cut.min(l.len());
            let _ = parse_line(&format!("{}{junk}{}", &l[..cut], &l[cut..]));
        }
    }
}
