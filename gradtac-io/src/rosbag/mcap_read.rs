//! An MCAP container reader: records, chunks (uncompressed, zstd, lz4), schemas, channels and
//! messages, written from the format's public specification. Every length a record claims —
//! the record's own, a string's, a schema's data, a chunk's compressed records and its
//! uncompressed size — is checked against the bytes that hold it (the file, the record, the
//! chunk) before anything is allocated for it, so a tiny file can never reserve gigabytes.
//!
//! The file is `MAGIC`, records, `MAGIC`; a record is `opcode: u8, length: u64, content`;
//! strings are `length: u32, UTF-8`:
//!
//! | opcode | record | read here |
//! |---|---|---|
//! | `0x01` | header (`profile`, `library`) | checked |
//! | `0x03` | schema (`id: u16`, `name`, `encoding`, `data: u32-prefixed bytes`) | kept |
//! | `0x04` | channel (`id: u16`, `schema_id: u16`, `topic`, `message_encoding`, `metadata` map) | kept |
//! | `0x05` | message (`channel_id: u16`, `sequence: u32`, `log_time: u64`, `publish_time: u64`, data) | yielded |
//! | `0x06` | chunk (`start, end: u64`, `uncompressed_size: u64`, `crc: u32`, `compression`, `records: u64-prefixed`) | decompressed (within the [`InflateBudget`]), CRC checked, its records read |
//! | `0x0F`, `0x02` | data end, footer | the end of what is read (the summary section repeats schemas and channels) |
//! | others | indexes, attachments, metadata, statistics | skipped without being read |
//!
//! Why not the `mcap` crate's reader: it reserves a string's claimed length before reading it
//! (a 712-byte file whose channel topic claims `0xC0000000` bytes aborted the process
//! reserving 3 GB), its errors name no offset, and its lz4 support builds C.

use super::inflate::{inflate_into, InflateBudget};
use crate::{Error, Result};
use std::collections::HashMap;
use std::fs::File;
use std::io::{BufReader, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The first (and last) eight bytes of an MCAP file.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";
/// Largest MCAP record (and uncompressed chunk) accepted (256 MiB); a record is also never
/// longer than the bytes left in its file or chunk.
pub const MAX_RECORD_BYTES: u64 = 256 << 20;

mod op {
    pub const HEADER: u8 = 0x01;
    pub const FOOTER: u8 = 0x02;
    pub const SCHEMA: u8 = 0x03;
    pub const CHANNEL: u8 = 0x04;
    pub const MESSAGE: u8 = 0x05;
    pub const CHUNK: u8 = 0x06;
    pub const DATA_END: u8 = 0x0F;
}

/// A schema record.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct McapSchema {
    /// Its id (> 0).
    pub id: u16,
    /// The type's name (`sr_robot_msgs/msg/BiotacAll`).
    pub name: String,
    /// `ros2msg`, …
    pub encoding: String,
    /// The definition.
    pub data: Vec<u8>,
}

/// A channel record, with its schema (`None` for schema id 0).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct McapChannel {
    /// Its id.
    pub id: u16,
    /// The topic.
    pub topic: String,
    /// `cdr`, …
    pub message_encoding: String,
    /// The schema of its messages.
    pub schema: Option<Arc<McapSchema>>,
}

/// One message, borrowing its bytes from the reader.
#[derive(Debug)]
pub struct McapMessage<'a> {
    /// Its channel.
    pub channel: &'a Arc<McapChannel>,
    /// `log_time` (ns).
    pub log_time: u64,
    /// The serialised message.
    pub data: &'a [u8],
    /// Byte offset of its record in the file (of the chunk holding it, when in a chunk).
    pub offset: u64,
}

/// A bounded reader of a record's fields; every failure says which field.
struct Fields<'a> {
    b: &'a [u8],
    i: usize,
    record: &'static str,
}

impl<'a> Fields<'a> {
    fn take(&mut self, n: usize, what: &str) -> std::result::Result<&'a [u8], String> {
        let left = self.b.len() - self.i;
        if n > left {
            return Err(format!(
                "{} record: {what} claims {n} bytes, but only {left} are left in the record",
                self.record
            ));
        }
        let s = &self.b[self.i..self.i + n];
        self.i += n;
        Ok(s)
    }

    fn u16(&mut self, what: &str) -> std::result::Result<u16, String> {
        Ok(u16::from_le_bytes(self.take(2, what)?.try_into().expect("2 bytes")))
    }

    fn u32(&mut self, what: &str) -> std::result::Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4, what)?.try_into().expect("4 bytes")))
    }

    fn u64(&mut self, what: &str) -> std::result::Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8, what)?.try_into().expect("8 bytes")))
    }

    /// `u32` length-prefixed bytes, the length checked against the record first.
    fn bytes(&mut self, what: &str) -> std::result::Result<&'a [u8], String> {
        let n = self.u32(what)?;
        self.take(usize::try_from(n).unwrap_or(usize::MAX), what)
    }

    fn string(&mut self, what: &str) -> std::result::Result<String, String> {
        let b = self.bytes(what)?;
        String::from_utf8(b.to_vec()).map_err(|_| format!("{} record: {what} is not UTF-8", self.record))
    }

    /// A `map<string, string>`: its byte length and every key and value inside it checked.
    fn string_map(&mut self, what: &str) -> std::result::Result<(), String> {
        let b = self.bytes(what)?;
        let mut m = Fields { b, i: 0, record: self.record };
        while m.i < b.len() {
            m.bytes(what)?;
            m.bytes(what)?;
        }
        Ok(())
    }
}

/// Where the last message's bytes are.
#[derive(Clone)]
enum Held {
    Chunk(std::ops::Range<usize>),
    Loose(std::ops::Range<usize>),
}

/// Reads an MCAP file front to back (see the [module docs](self)).
pub struct McapReader {
    path: PathBuf,
    file: BufReader<File>,
    len: u64,
    pos: u64,
    /// The last top-level record read whole.
    record: Vec<u8>,
    /// The current chunk's records (uncompressed), the read position in them and the
    /// chunk's offset in the file.
    chunk: Vec<u8>,
    chunk_pos: usize,
    chunk_offset: u64,
    schemas: HashMap<u16, Arc<McapSchema>>,
    channels: HashMap<u16, Arc<McapChannel>>,
    budget: InflateBudget,
    records: u64,
    done: bool,
    cur: Option<(u16, u64, u64, Held)>,
}

impl McapReader {
    /// Open an MCAP file and check its magic.
    pub fn open(path: impl AsRef<Path>) -> Result<Self> {
        let (path, file, len) = super::container_io::open_regular(path)?;
        let mut r = McapReader {
            path,
            file,
            len,
            pos: 0,
            record: Vec::new(),
            chunk: Vec::new(),
            chunk_pos: 0,
            chunk_offset: 0,
            schemas: HashMap::new(),
            channels: HashMap::new(),
            budget: InflateBudget::for_file(len),
            records: 0,
            done: false,
            cur: None,
        };
        let mut magic = [0u8; 8];
        let got = r.read_up_to(&mut magic)?;
        if got < 8 || magic != *MAGIC {
            let reason = if magic[..got].starts_with(b"#ROSBAG") {
                "this is a ROS 1 bag, not an MCAP file: use `rosbag = \"…\"`"
            } else {
                "not an MCAP file (no MCAP magic)"
            };
            return Err(r.err(0, reason));
        }
        Ok(r)
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Bytes of the file consumed so far and its size.
    pub fn progress(&self) -> (u64, u64) {
        (self.pos, self.len)
    }

    fn err(&self, offset: u64, reason: impl Into<String>) -> Error {
        super::container_io::error_at(&self.path, offset, reason)
    }

    fn io(&self, source: std::io::Error) -> Error {
        Error::Io { path: self.path.clone(), source }
    }

    fn read_up_to(&mut self, buf: &mut [u8]) -> Result<usize> {
        super::container_io::read_up_to(&mut self.file, &self.path, &mut self.pos, buf)
    }

    /// The next message of any channel, or `None` after the data section.
    pub fn next_message(&mut self) -> Result<Option<McapMessage<'_>>> {
        self.cur = None;
        let Some(cur) = self.advance()? else { return Ok(None) };
        self.cur = Some(cur);
        Ok(self.current())
    }

    /// The message the last [`next_message`](Self::next_message) returned, again.
    pub fn current(&self) -> Option<McapMessage<'_>> {
        let (channel, log_time, offset, held) = self.cur.as_ref()?;
        let data = match held {
            Held::Chunk(r) => self.chunk.get(r.clone())?,
            Held::Loose(r) => self.record.get(r.clone())?,
        };
        Some(McapMessage { channel: self.channels.get(channel)?, log_time: *log_time, data, offset: *offset })
    }

    fn advance(&mut self) -> Result<Option<(u16, u64, u64, Held)>> {
        loop {
            if self.chunk_pos < self.chunk.len() {
                if let Some(m) = self.next_in_chunk()? {
                    return Ok(Some(m));
                }
                continue;
            }
            if self.done {
                return Ok(None);
            }
            let at = self.pos;
            let mut head = [0u8; 9];
            let got = self.read_up_to(&mut head)?;
            if got < 9 {
                self.done = true;
                return Err(
                    self.err(at, "the file ends before the MCAP data section does (no data end or footer record)")
                );
            }
            let opcode = head[0];
            let len = u64::from_le_bytes(head[1..].try_into().expect("8 bytes"));
            let left = self.len.saturating_sub(self.pos);
            self.records += 1;
            let what = record_name(opcode);
            if len > left {
                self.done = true;
                return Err(self.err(
                    at,
                    format!("{what} record (opcode {opcode:#04x}) claims {len} bytes, but the file has {left} left"),
                ));
            }
            match opcode {
                op::DATA_END | op::FOOTER => {
                    self.done = true;
                    return Ok(None);
                }
                op::HEADER | op::SCHEMA | op::CHANNEL | op::MESSAGE | op::CHUNK => {
                    if len > MAX_RECORD_BYTES {
                        self.done = true;
                        return Err(self.err(at, format!("{what} record of {len} bytes (limit {MAX_RECORD_BYTES})")));
                    }
                    let mut rec = std::mem::take(&mut self.record);
                    rec.clear();
                    rec.resize(len as usize, 0);
                    let got = self.read_up_to(&mut rec);
                    self.record = rec;
                    if got? < len as usize {
                        self.done = true;
                        return Err(self.err(at, format!("the file ended inside {what} record")));
                    }
                    if at == 8 && opcode != op::HEADER {
                        self.done = true;
                        return Err(self.err(at, format!("the first record is {what} record, not a header")));
                    }
                    let r = self.handle_top(opcode, at);
                    if r.is_err() {
                        self.done = true;
                    }
                    if let Some(m) = r? {
                        return Ok(Some(m));
                    }
                }
                _ => {
                    self.file.seek(SeekFrom::Current(len as i64)).map_err(|e| self.io(e))?;
                    self.pos += len;
                }
            }
        }
    }

    fn handle_top(&mut self, opcode: u8, at: u64) -> Result<Option<(u16, u64, u64, Held)>> {
        let rec = std::mem::take(&mut self.record);
        let r = match opcode {
            op::HEADER => {
                let mut f = Fields { b: &rec, i: 0, record: "header" };
                let r = f.string("the profile").and_then(|_| f.string("the library"));
                r.map(|_| None).map_err(|e| self.err(at, e))
            }
            op::CHUNK => self.open_chunk(&rec, at).map(|()| None),
            op::MESSAGE => self.message(&rec, at).map(|(c, t, d)| Some((c, t, at, Held::Loose(d)))),
            _ => self.definition(opcode, &rec).map(|()| None).map_err(|e| self.err(at, e)),
        };
        self.record = rec;
        r
    }

    /// A record of the current chunk: a message is returned, a schema or channel kept,
    /// anything else skipped (`None`: call again).
    fn next_in_chunk(&mut self) -> Result<Option<(u16, u64, u64, Held)>> {
        let at = self.chunk_offset;
        let inner = self.chunk_pos;
        let fail = |s: &Self, r: String| s.err(at, format!("in the chunk, record at byte {inner} of its data: {r}"));
        let b = &self.chunk[inner..];
        if b.len() < 9 {
            self.chunk_pos = self.chunk.len();
            return Err(fail(self, format!("{} bytes left, too few for a record's opcode and length", b.len())));
        }
        let opcode = b[0];
        let len = u64::from_le_bytes(b[1..9].try_into().expect("8 bytes"));
        let left = (b.len() - 9) as u64;
        if len > left {
            self.chunk_pos = self.chunk.len();
            return Err(fail(
                self,
                format!(
                    "{} record (opcode {opcode:#04x}) claims {len} bytes, but the chunk has {left} left",
                    record_name(opcode)
                ),
            ));
        }
        let data = inner + 9..inner + 9 + len as usize;
        self.chunk_pos = data.end;
        let chunk = std::mem::take(&mut self.chunk);
        let r = match opcode {
            op::MESSAGE => self
                .message(&chunk[data.clone()], at)
                .map(|(c, t, d)| Some((c, t, at, Held::Chunk(data.start + d.start..data.start + d.end)))),
            op::SCHEMA | op::CHANNEL => self.definition(opcode, &chunk[data]).map(|()| None).map_err(|r| fail(self, r)),
            op::CHUNK => Err(fail(self, "a chunk inside a chunk".into())),
            _ => Ok(None),
        };
        self.chunk = chunk;
        if r.is_err() {
            self.chunk_pos = self.chunk.len();
        }
        r
    }

    /// A message record: channel, log time and the range of its data in `b`.
    fn message(&self, b: &[u8], at: u64) -> Result<(u16, u64, std::ops::Range<usize>)> {
        let mut f = Fields { b, i: 0, record: "message" };
        let head = (|| {
            Ok::<_, String>((f.u16("channel id")?, f.u32("sequence")?, f.u64("log time")?, f.u64("publish time")?))
        })();
        let (channel, _seq, log_time, _publish) = head.map_err(|e| self.err(at, e))?;
        if !self.channels.contains_key(&channel) {
            return Err(
                self.err(at, format!("a message of channel {channel}, which no channel record declared before it"))
            );
        }
        let start = f.i;
        Ok((channel, log_time, start..b.len()))
    }

    /// A schema or channel record, kept (the first definition of an id wins; the summary
    /// section repeats them).
    fn definition(&mut self, opcode: u8, b: &[u8]) -> std::result::Result<(), String> {
        if opcode == op::SCHEMA {
            let mut f = Fields { b, i: 0, record: "schema" };
            let id = f.u16("the id")?;
            let name = f.string("the name")?;
            let encoding = f.string("the encoding")?;
            let data = f.bytes("the data")?.to_vec();
            if id == 0 {
                return Err("schema record: id 0 is reserved (no schema)".into());
            }
            self.schemas.entry(id).or_insert_with(|| Arc::new(McapSchema { id, name, encoding, data }));
        } else {
            let mut f = Fields { b, i: 0, record: "channel" };
            let id = f.u16("the id")?;
            let schema_id = f.u16("the schema id")?;
            let topic = f.string("the topic")?;
            let message_encoding = f.string("the message encoding")?;
            f.string_map("the metadata")?;
            let schema = match schema_id {
                0 => None,
                s => Some(self.schemas.get(&s).cloned().ok_or_else(|| {
                    format!("channel {id} ({topic}) names schema {s}, which no schema record declared before it")
                })?),
            };
            self.channels.entry(id).or_insert_with(|| Arc::new(McapChannel { id, topic, message_encoding, schema }));
        }
        Ok(())
    }

    /// Decompress a chunk record into `self.chunk`, within the budget.
    fn open_chunk(&mut self, b: &[u8], at: u64) -> Result<()> {
        let mut f = Fields { b, i: 0, record: "chunk" };
        let head = (|| {
            f.u64("the start time")?;
            f.u64("the end time")?;
            let size = f.u64("the uncompressed size")?;
            let crc = f.u32("the uncompressed CRC")?;
            let compression = f.string("the compression")?;
            let n = f.u64("the records")?;
            let records = f.take(usize::try_from(n).unwrap_or(usize::MAX), "the records")?;
            Ok::<_, String>((size, crc, compression, records))
        })();
        let (size, crc, compression, records) = head.map_err(|e| self.err(at, e))?;
        if size > MAX_RECORD_BYTES {
            return Err(self.err(at, format!("a chunk of {size} bytes uncompressed (limit {MAX_RECORD_BYTES})")));
        }
        let kind = if compression.is_empty() { "uncompressed" } else { compression.as_str() };
        self.budget.admit(kind, records.len() as u64, size).map_err(|r| self.err(at, r))?;
        let mut out = std::mem::take(&mut self.chunk);
        let r = match compression.as_str() {
            "" => {
                out.clear();
                out.extend_from_slice(records);
                Ok(out.len() as u64 == size)
            }
            "zstd" => zstd::stream::read::Decoder::with_buffer(records).and_then(|d| inflate_into(d, size, &mut out)),
            "lz4" => inflate_into(lz4_flex::frame::FrameDecoder::new(records), size, &mut out),
            other => {
                self.chunk = out;
                self.chunk.clear();
                return Err(self.err(at, format!("chunk compression {other:?} is not supported (none, zstd, lz4)")));
            }
        };
        let holds = out.len();
        self.chunk = out;
        self.chunk_pos = 0;
        self.chunk_offset = at;
        let fault = match r {
            Err(e) => Some(format!("a {kind} chunk does not decompress: {e}")),
            Ok(false) => Some(format!("a chunk declares {size} bytes uncompressed but holds {holds}")),
            Ok(true) if crc != 0 && crc32fast::hash(&self.chunk) != crc => Some(format!(
                "the chunk's records fail their CRC (recorded {crc:#010x}, computed {:#010x})",
                crc32fast::hash(&self.chunk)
            )),
            Ok(true) => None,
        };
        if let Some(reason) = fault {
            self.chunk.clear();
            return Err(self.err(at, reason));
        }
        Ok(())
    }
}

fn record_name(opcode: u8) -> &'static str {
    match opcode {
        op::HEADER => "a header",
        op::FOOTER => "a footer",
        op::SCHEMA => "a schema",
        op::CHANNEL => "a channel",
        op::MESSAGE => "a message",
        op::CHUNK => "a chunk",
        0x07 => "a message index",
        0x08 => "a chunk index",
        0x09 => "an attachment",
        0x0A => "an attachment index",
        0x0B => "a statistics",
        0x0C => "a metadata",
        0x0D => "a metadata index",
        0x0E => "a summary offset",
        op::DATA_END => "a data end",
        _ => "an unknown",
    }
}
