//! A ROS 1 bag (format 2.0) container reader, written from the format's public specification.
//!
//! A bag is the magic line `#ROSBAG V2.0\n` followed by records. Each record is
//! `header_len: u32, header, data_len: u32, data` (little-endian), the header a run of fields
//! `len: u32, "name=value"`, with `op` (one byte) saying what the record is:
//!
//! | op | record | read here |
//! |---|---|---|
//! | `0x03` | bag header (`index_pos`, `conn_count`, `chunk_count`) | checked, skipped |
//! | `0x05` | chunk (`compression` = `none` / `bz2` / `lz4`, `size` uncompressed); data = records | decompressed, its records read |
//! | `0x07` | connection (`conn`, `topic`); data = a header with `type`, `md5sum`, `message_definition` | kept |
//! | `0x02` | message data (`conn`, `time` = sec `u32` + nsec `u32`); data = the serialised message | yielded |
//! | `0x04`, `0x06` | index data, chunk info | skipped (chunk infos read by [`BagReader::with_topics`]) |
//!
//! The reader walks the file front to back (it does not need the index, so a bag whose
//! recording was cut off before the index was written still reads), yielding messages in
//! the order they were recorded. With [`BagReader::with_topics`] it first reads the index
//! (when the bag has one) and seeks over the chunks whose connections are all on other
//! topics, without reading or decompressing them. `lz4` chunks are LZ4 frames (`roslz4`), `bz2` chunks bzip2
//! streams; both are decoded by pure-Rust crates.
//!
//! **Bounds.** A record's header and data may not run past the end of the file (or of the
//! chunk), a header is at most [`MAX_HEADER_BYTES`], a chunk at most [`MAX_CHUNK_BYTES`]
//! uncompressed and within the file's [`InflateBudget`] (a ratio bound per chunk and a total
//! per file, checked before a chunk is decompressed), and decompressed bytes are allocated as
//! they arrive, never from a declared size alone: a malformed bag is an [`Error::Bag`] naming
//! the byte offset, never a panic or a huge allocation.
//!
//! Why not the `rosbag` crate: it memory-maps the whole file (a bag truncated or rewritten
//! while read is a SIGBUS, not an error), builds C code for bzip2 and lz4, and gives no byte
//! offsets in its errors; the container itself is small enough to read from the spec.

use super::inflate::{inflate_into, InflateBudget};
use crate::{Error, Result};
use std::collections::HashMap;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The first line of every ROS bag 2.0 file.
pub const MAGIC: &[u8] = b"#ROSBAG V2.0\n";
/// Largest record header accepted (a connection's header holds the full message definition).
pub const MAX_HEADER_BYTES: u32 = 16 << 20;
/// Largest chunk accepted, uncompressed (`rosbag record` writes ~768 KiB chunks).
pub const MAX_CHUNK_BYTES: u32 = 256 << 20;

/// Record ops.
mod op {
    pub const MSG_DATA: u8 = 0x02;
    pub const BAG_HEADER: u8 = 0x03;
    pub const CHUNK: u8 = 0x05;
    pub const CHUNK_INFO: u8 = 0x06;
    pub const CONNECTION: u8 = 0x07;
}

/// A connection: one topic as published with one message type.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Connection {
    /// The bag's id of the connection.
    pub id: u32,
    /// The topic (`/rh/tactile`).
    pub topic: String,
    /// The message type (`sr_robot_msgs/BiotacAll`).
    pub msg_type: String,
    /// The type's MD5 sum as recorded.
    pub md5sum: String,
    /// The full message definition text embedded by the recorder (the type's own fields,
    /// then every type it uses after `MSG: pkg/Type` lines).
    pub definition: String,
}

/// A ROS time: seconds and nanoseconds since the Unix epoch.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
pub struct RosTime {
    /// Seconds.
    pub sec: u32,
    /// Nanoseconds (< 10⁹ in a well-formed time).
    pub nsec: u32,
}

impl RosTime {
    /// Nanoseconds since the epoch.
    pub fn nanos(self) -> i64 {
        i64::from(self.sec) * 1_000_000_000 + i64::from(self.nsec)
    }
}

/// One message read from a bag, borrowing its bytes from the reader.
#[derive(Debug)]
pub struct BagMessage<'a> {
    /// Its connection.
    pub connection: &'a Arc<Connection>,
    /// The time the recorder received it.
    pub record_time: RosTime,
    /// 0-based index of the message on its connection.
    pub index: u64,
    /// The serialised message (ROS 1 wire format).
    pub data: &'a [u8],
    /// Byte offset of its record in the file (of the chunk holding it, when compressed).
    pub offset: u64,
}

/// A record's header fields.
struct Header<'a> {
    fields: Vec<(&'a [u8], &'a [u8])>,
}

impl<'a> Header<'a> {
    fn parse(b: &'a [u8]) -> std::result::Result<Self, String> {
        let mut fields = Vec::new();
        let mut i = 0usize;
        while i < b.len() {
            let len = read_u32(b, i).ok_or("a header field length runs past the header")? as usize;
            i += 4;
            let f = b.get(i..i.saturating_add(len)).ok_or("a header field runs past the header")?;
            i += len;
            let eq = f.iter().position(|&c| c == b'=').ok_or("a header field has no '='")?;
            fields.push((&f[..eq], &f[eq + 1..]));
        }
        Ok(Header { fields })
    }

    fn get(&self, name: &str) -> Option<&'a [u8]> {
        self.fields.iter().find(|(k, _)| *k == name.as_bytes()).map(|(_, v)| *v)
    }

    fn need(&self, name: &str) -> std::result::Result<&'a [u8], String> {
        self.get(name).ok_or_else(|| format!("the record header has no {name:?} field"))
    }

    fn u32(&self, name: &str) -> std::result::Result<u32, String> {
        let v = self.need(name)?;
        read_u32(v, 0).filter(|_| v.len() == 4).ok_or_else(|| format!("header field {name:?} is not 4 bytes"))
    }

    fn op(&self) -> std::result::Result<u8, String> {
        match self.need("op")? {
            [o] => Ok(*o),
            _ => Err("header field \"op\" is not 1 byte".into()),
        }
    }

    fn string(&self, name: &str) -> std::result::Result<String, String> {
        String::from_utf8(self.need(name)?.to_vec()).map_err(|_| format!("header field {name:?} is not UTF-8"))
    }
}

fn read_u32(b: &[u8], at: usize) -> Option<u32> {
    let s = b.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}

/// Reads a ROS 1 bag front to back (see the [module docs](self)).
pub struct BagReader {
    path: PathBuf,
    file: BufReader<File>,
    len: u64,
    pos: u64,
    /// The current chunk's records (uncompressed), the read position in them and the chunk's
    /// offset in the file.
    chunk: Vec<u8>,
    chunk_pos: usize,
    chunk_offset: u64,
    /// A message record outside chunks (rare), kept until handed out.
    loose: Vec<u8>,
    connections: HashMap<u32, Arc<Connection>>,
    counts: HashMap<u32, u64>,
    chunks: u64,
    budget: InflateBudget,
    /// From the bag's index (when [`with_topics`](BagReader::with_topics) read one): the
    /// connections of each chunk, by the chunk's offset, and the topics wanted.
    chunk_conns: HashMap<u64, Vec<u32>>,
    topics: Option<std::collections::HashSet<String>>,
    skipped: u64,
    /// The last message returned: connection, time, offset, bytes, index.
    cur: Option<(u32, RosTime, u64, Held, u64)>,
}

/// Where the last message's bytes are.
enum Held {
    Chunk(std::ops::Range<usize>),
    Loose,
}

impl BagReader {
    /// Open a bag and check its magic line.
    pub fn open(path: impl AsRef<Path>) -> Result<Self> {
        let (path, file, len) = super::container_io::open_regular(path)?;
        let mut r = BagReader {
            path,
            file,
            len,
            pos: 0,
            chunk: Vec::new(),
            chunk_pos: 0,
            chunk_offset: 0,
            loose: Vec::new(),
            connections: HashMap::new(),
            counts: HashMap::new(),
            chunks: 0,
            budget: InflateBudget::for_file(len),
            chunk_conns: HashMap::new(),
            topics: None,
            skipped: 0,
            cur: None,
        };
        let mut magic = [0u8; MAGIC.len()];
        let got = r.read_up_to(&mut magic)?;
        if got < MAGIC.len() || magic[..] != *MAGIC {
            let reason = if magic.starts_with(b"#ROSBAG V") {
                format!("bag format {:?} is not supported (only 2.0)", String::from_utf8_lossy(&magic[9..]).trim())
            } else if magic[..got].starts_with(b"\x89MCAP") {
                "this is an MCAP file (ROS 2): use `mcap = \"…\"`".into()
            } else {
                "not a ROS bag (no \"#ROSBAG V2.0\" line)".into()
            };
            return Err(r.err(0, reason));
        }
        Ok(r)
    }

    /// Read only what `topics` need: when the bag has an index (the connection and chunk-info
    /// records `rosbag record` writes at its end), chunks whose connections are all on other
    /// topics are seeked over without being read or decompressed (a camera topic, or a
    /// decompression bomb on a topic no sensor reads, costs nothing). Without a readable index
    /// every chunk is read as before; a malformed index is ignored (the data section is what
    /// counts). Call right after [`open`](Self::open).
    pub fn with_topics(mut self, topics: impl IntoIterator<Item = String>) -> Result<Self> {
        let start = self.pos;
        if let Ok(Some(map)) = self.read_index() {
            self.chunk_conns = map;
        } else {
            self.chunk_conns.clear();
        }
        self.file.seek(SeekFrom::Start(start)).map_err(|e| self.io(e))?;
        self.pos = start;
        self.topics = Some(topics.into_iter().collect());
        Ok(self)
    }

    /// The index: the chunk-info records' connections per chunk offset, and the connection
    /// records (kept); `None` when the bag header names no index.
    fn read_index(&mut self) -> Result<Option<HashMap<u64, Vec<u32>>>> {
        let at = self.pos;
        let Some(hlen) = self.read_len(at, "record header")? else { return Ok(None) };
        if hlen > MAX_HEADER_BYTES {
            return Ok(None);
        }
        let hbytes = self.read_vec(u64::from(hlen), at, "header")?;
        let header = Header::parse(&hbytes).map_err(|r| self.err(at, r))?;
        if header.op().ok() != Some(op::BAG_HEADER) {
            return Ok(None);
        }
        let index_pos = match header.get("index_pos") {
            Some(v) if v.len() == 8 => u64::from_le_bytes(v.try_into().expect("8 bytes")),
            _ => return Ok(None),
        };
        if index_pos <= at || index_pos >= self.len {
            return Ok(None);
        }
        self.file.seek(SeekFrom::Start(index_pos)).map_err(|e| self.io(e))?;
        self.pos = index_pos;
        let mut map = HashMap::new();
        loop {
            let at = self.pos;
            let Some(hlen) = self.read_len(at, "record header")? else { break };
            if hlen > MAX_HEADER_BYTES {
                return Ok(None);
            }
            let hbytes = self.read_vec(u64::from(hlen), at, "header")?;
            let header = Header::parse(&hbytes).map_err(|r| self.err(at, r))?;
            let dlen = self.read_len(at, "record data")?.ok_or_else(|| self.err(at, "no data length"))?;
            match header.op().map_err(|r| self.err(at, r))? {
                op::CONNECTION => {
                    let data = self.read_vec(u64::from(dlen), at, "connection data")?;
                    self.add_connection(&header, &data, at)?;
                }
                op::CHUNK_INFO => {
                    let pos = match header.get("chunk_pos") {
                        Some(v) if v.len() == 8 => u64::from_le_bytes(v.try_into().expect("8 bytes")),
                        _ => return Ok(None),
                    };
                    let data = self.read_vec(u64::from(dlen), at, "chunk info data")?;
                    let conns = data.chunks_exact(8).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
                    map.insert(pos, conns);
                }
                _ => self.skip(u64::from(dlen), at)?,
            }
        }
        Ok(Some(map))
    }

    /// Chunks seeked over unread (their connections are all on topics not wanted).
    pub fn chunks_skipped(&self) -> u64 {
        self.skipped
    }

    /// True when the index says the chunk at `at` holds only connections of unwanted topics.
    fn unwanted_chunk(&self, at: u64) -> bool {
        let (Some(topics), Some(conns)) = (&self.topics, self.chunk_conns.get(&at)) else { return false };
        conns.iter().all(|c| self.connections.get(c).is_some_and(|c| !topics.contains(&c.topic)))
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// File size in bytes.
    pub fn len(&self) -> u64 {
        self.len
    }

    /// True for an empty file (never a valid bag).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Bytes of the file consumed so far.
    pub fn bytes_read(&self) -> u64 {
        self.pos
    }

    /// The connections seen so far.
    pub fn connections(&self) -> impl Iterator<Item = &Arc<Connection>> {
        self.connections.values()
    }

    /// Chunks read so far.
    pub fn chunks_read(&self) -> u64 {
        self.chunks
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

    /// Read exactly `n` bytes (already checked against the file's length).
    fn read_vec(&mut self, n: u64, at: u64, what: &str) -> Result<Vec<u8>> {
        if n > self.len.saturating_sub(self.pos) {
            return Err(self.err(at, format!("the record's {what} ({n} bytes) runs past the end of the file")));
        }
        let mut v = vec![0u8; n as usize];
        let got = self.read_up_to(&mut v)?;
        if (got as u64) < n {
            return Err(self.err(at, format!("the file ended inside the record's {what}")));
        }
        Ok(v)
    }

    fn read_len(&mut self, at: u64, what: &str) -> Result<Option<u32>> {
        let mut b = [0u8; 4];
        match self.read_up_to(&mut b)? {
            0 => Ok(None),
            4 => Ok(Some(u32::from_le_bytes(b))),
            _ => Err(self.err(at, format!("the file ended inside a {what} length"))),
        }
    }

    fn skip(&mut self, n: u64, at: u64) -> Result<()> {
        if n > self.len.saturating_sub(self.pos) {
            return Err(self.err(at, format!("the record's data ({n} bytes) runs past the end of the file")));
        }
        self.file.seek(SeekFrom::Current(n as i64)).map_err(|e| self.io(e))?;
        self.pos += n;
        Ok(())
    }

    /// The next message of any connection, or `None` at the end of the bag.
    pub fn next_message(&mut self) -> Result<Option<BagMessage<'_>>> {
        self.cur = None;
        let Some((conn, time, offset, held)) = self.advance()? else { return Ok(None) };
        let count = self.counts.entry(conn).or_insert(0);
        let index = *count;
        *count += 1;
        self.cur = Some((conn, time, offset, held, index));
        Ok(self.current())
    }

    /// The message the last [`next_message`](Self::next_message) returned, again.
    pub fn current(&self) -> Option<BagMessage<'_>> {
        let (conn, time, offset, held, index) = self.cur.as_ref()?;
        let data = match held {
            Held::Chunk(r) => self.chunk.get(r.clone())?,
            Held::Loose => &self.loose[..],
        };
        Some(BagMessage {
            connection: self.connections.get(conn)?,
            record_time: *time,
            index: *index,
            data,
            offset: *offset,
        })
    }

    /// Move to the next message record; returns its connection, time, offset and bytes.
    fn advance(&mut self) -> Result<Option<(u32, RosTime, u64, Held)>> {
        loop {
            if self.chunk_pos < self.chunk.len() {
                if let Some(m) = self.next_in_chunk()? {
                    return Ok(Some(m));
                }
                continue;
            }
            let at = self.pos;
            let Some(hlen) = self.read_len(at, "record header")? else { return Ok(None) };
            if hlen > MAX_HEADER_BYTES {
                return Err(self.err(at, format!("a record header of {hlen} bytes (limit {MAX_HEADER_BYTES})")));
            }
            let hbytes = self.read_vec(u64::from(hlen), at, "header")?;
            let header = Header::parse(&hbytes).map_err(|r| self.err(at, r))?;
            let op = header.op().map_err(|r| self.err(at, r))?;
            let dlen = self
                .read_len(at, "record data")?
                .ok_or_else(|| self.err(at, "the file ended before the record's data length"))?;
            match op {
                op::CHUNK if self.unwanted_chunk(at) => {
                    self.skip(u64::from(dlen), at)?;
                    self.chunks += 1;
                    self.skipped += 1;
                }
                op::CHUNK => {
                    let data = self.read_vec(u64::from(dlen), at, "chunk data")?;
                    self.chunk = self.decompress(&header, data, at)?;
                    self.chunk_pos = 0;
                    self.chunk_offset = at;
                    self.chunks += 1;
                }
                op::CONNECTION => {
                    let data = self.read_vec(u64::from(dlen), at, "connection data")?;
                    self.add_connection(&header, &data, at)?;
                }
                op::MSG_DATA => {
                    let (conn, time) = self.message_header(&header, at)?;
                    self.loose = self.read_vec(u64::from(dlen), at, "message data")?;
                    return Ok(Some((conn, time, at, Held::Loose)));
                }
                op::BAG_HEADER if at != MAGIC.len() as u64 => {
                    return Err(self.err(at, "a second bag header record"));
                }
                _ => self.skip(u64::from(dlen), at)?,
            }
        }
    }

    /// Read the next record of the current chunk; a message is returned, anything else is
    /// handled and `None` returned (call again).
    fn next_in_chunk(&mut self) -> Result<Option<(u32, RosTime, u64, Held)>> {
        let at = self.chunk_offset;
        let b = &self.chunk;
        let mut i = self.chunk_pos;
        let inner = i;
        let fail = |s: &Self, r: String| s.err(at, format!("in the chunk, record at byte {inner} of its data: {r}"));
        let hlen = read_u32(b, i).ok_or_else(|| fail(self, "a header length runs past the chunk".into()))? as usize;
        i += 4;
        let hb = b.get(i..i.saturating_add(hlen)).ok_or_else(|| fail(self, "the header runs past the chunk".into()))?;
        i += hlen;
        let dlen = read_u32(b, i).ok_or_else(|| fail(self, "a data length runs past the chunk".into()))? as usize;
        i += 4;
        let data = i..i.saturating_add(dlen);
        if data.end > b.len() {
            return Err(fail(self, format!("the data ({dlen} bytes) runs past the chunk")));
        }
        self.chunk_pos = data.end;
        let header = Header::parse(hb).map_err(|r| fail(self, r))?;
        match header.op().map_err(|r| fail(self, r))? {
            op::MSG_DATA => {
                let (conn, time) = self.message_header(&header, at)?;
                Ok(Some((conn, time, at, Held::Chunk(data))))
            }
            op::CONNECTION => {
                let d = self.chunk[data].to_vec();
                let hb = hb.to_vec();
                let header = Header::parse(&hb).map_err(|r| fail(self, r))?;
                self.add_connection(&header, &d, at)?;
                Ok(None)
            }
            _ => Ok(None),
        }
    }

    fn message_header(&self, h: &Header<'_>, at: u64) -> Result<(u32, RosTime)> {
        let conn = h.u32("conn").map_err(|r| self.err(at, r))?;
        let t = h.need("time").map_err(|r| self.err(at, r))?;
        let (Some(sec), Some(nsec), 8) = (read_u32(t, 0), read_u32(t, 4), t.len()) else {
            return Err(self.err(at, "header field \"time\" is not 8 bytes"));
        };
        if !self.connections.contains_key(&conn) {
            return Err(
                self.err(at, format!("a message of connection {conn}, which no connection record declared before it"))
            );
        }
        Ok((conn, RosTime { sec, nsec }))
    }

    fn add_connection(&mut self, h: &Header<'_>, data: &[u8], at: u64) -> Result<()> {
        let id = h.u32("conn").map_err(|r| self.err(at, r))?;
        if self.connections.contains_key(&id) {
            return Ok(()); // the index section repeats every connection
        }
        let topic = h.string("topic").map_err(|r| self.err(at, r))?;
        let d = Header::parse(data).map_err(|r| self.err(at, format!("connection {topic}: {r}")))?;
        let field = |n: &str| d.string(n).map_err(|r| self.err(at, format!("connection {topic}: {r}")));
        let c = Connection {
            id,
            msg_type: field("type")?,
            md5sum: d.get("md5sum").map(|v| String::from_utf8_lossy(v).into_owned()).unwrap_or_default(),
            definition: field("message_definition")?,
            topic,
        };
        self.connections.insert(id, Arc::new(c));
        Ok(())
    }

    fn decompress(&mut self, h: &Header<'_>, data: Vec<u8>, at: u64) -> Result<Vec<u8>> {
        let size = h.u32("size").map_err(|r| self.err(at, r))?;
        if size > MAX_CHUNK_BYTES {
            return Err(self.err(at, format!("a chunk of {size} bytes uncompressed (limit {MAX_CHUNK_BYTES})")));
        }
        let kind = h.string("compression").map_err(|r| self.err(at, r))?;
        if kind != "none" {
            let n = data.len() as u64;
            self.budget
                .admit(&kind, n, u64::from(size))
                .map_err(|r| self.err(at, format!("chunk #{}: {r}", self.chunks + 1)))?;
        }
        let out = match kind.as_str() {
            "none" => data,
            "bz2" => self.inflate(bzip2::read::BzDecoder::new(&data[..]), size, at, "bz2")?,
            "lz4" => self.inflate(lz4_flex::frame::FrameDecoder::new(&data[..]), size, at, "lz4")?,
            other => return Err(self.err(at, format!("chunk compression {other:?} is not supported (none, bz2, lz4)"))),
        };
        if out.len() != size as usize {
            return Err(self.err(at, format!("a chunk declares {size} bytes uncompressed but holds {}", out.len())));
        }
        Ok(out)
    }

    /// Decompress at most `size + 1` bytes, growing the buffer as bytes arrive.
    fn inflate(&self, r: impl Read, size: u32, at: u64, kind: &str) -> Result<Vec<u8>> {
        let mut out = Vec::new();
        inflate_into(r, u64::from(size), &mut out).map_err(|e| {
            self.err(at, format!("chunk #{}: a {kind} chunk does not decompress: {e}", self.chunks + 1))
        })?;
        Ok(out)
    }
}
