//! [`McapFrames`]: one pass over an MCAP file (the ROS 2 default bag format) with
//! CDR-encoded messages and `ros2msg` schemas, yielding the taxel frames of every sensor that
//! reads it.
//!
//! The container is read by [`McapReader`] (every length a
//! record claims checked before anything is allocated for it; chunks uncompressed, zstd or
//! lz4, within the decompression budget); the messages are decoded by the schema text each
//! channel's schema carries (`ros2msg`, parsed with ROS 2 rules) and the CDR decoder. Times:
//! `header.stamp` (`builtin_interfaces/Time`) or, with `time = "record"`, the message's
//! `log_time`.

use super::decode::Wire;
use super::extract::{BagSensor, Demux, Fault, QueuedFrames};
use super::msgdef::Dialect;
use crate::error::BagSite;
use crate::{Error, Result};
use gradtac_stream::TaxelFrame;
use std::collections::{HashMap, VecDeque};
use std::path::{Path, PathBuf};

use super::mcap_read::McapReader;
pub use super::mcap_read::MAX_RECORD_BYTES;

/// The frames of several sensors read from one MCAP file in one pass, in file order (an
/// `Iterator<Item = Result<TaxelFrame>>`); see [`RosbagFrames`](super::RosbagFrames) for the
/// per-sensor rules, which are the same.
pub struct McapFrames {
    path: PathBuf,
    reader: McapReader,
    demux: Demux,
    counts: HashMap<u16, u64>,
    pending: VecDeque<TaxelFrame>,
    buf: Vec<TaxelFrame>,
    done: bool,
}

impl McapFrames {
    /// Open `path` for `sensors` (at least one).
    pub fn open(path: impl AsRef<Path>, sensors: Vec<BagSensor>) -> Result<Self> {
        let path = path.as_ref().to_path_buf();
        if sensors.is_empty() {
            return Err(Error::InvalidConfig("an MCAP source needs at least one sensor".into()));
        }
        let reader = McapReader::open(&path)?;
        Ok(McapFrames {
            path,
            reader,
            demux: Demux::new(sensors, Wire::Cdr, Dialect::Ros2),
            counts: HashMap::new(),
            pending: VecDeque::new(),
            buf: Vec::new(),
            done: false,
        })
    }

    /// File bytes consumed so far and the file's size (for progress).
    pub fn progress(&self) -> (u64, u64) {
        self.reader.progress()
    }

    fn fault(&self, offset: u64, f: Fault) -> Error {
        Error::Bag {
            path: self.path.clone(),
            site: Box::new(BagSite {
                offset: Some(offset),
                topic: Some(f.topic),
                msg_type: Some(f.msg_type),
                index: f.index,
            }),
            reason: f.reason,
        }
    }

    fn fill(&mut self) -> Result<bool> {
        loop {
            let Some(m) = self.reader.next_message()? else { return Ok(false) };
            let ch = m.channel.clone();
            let offset = m.offset;
            let id = u32::from(ch.id);
            if !self.demux.knows(id) {
                let (ty, encoding, text) = match &ch.schema {
                    Some(s) => (s.name.clone(), s.encoding.clone(), String::from_utf8_lossy(&s.data).into_owned()),
                    None => (String::new(), "(no schema)".to_string(), String::new()),
                };
                let wrong =
                    |reason: String| Fault { topic: ch.topic.clone(), msg_type: ty.clone(), index: None, reason };
                let readers = self.demux.reads(&ch.topic);
                if readers && ch.message_encoding != "cdr" {
                    return Err(self.fault(
                        offset,
                        wrong(format!("message encoding {:?}; only \"cdr\" (ROS 2) is read", ch.message_encoding)),
                    ));
                }
                if readers && encoding != "ros2msg" {
                    return Err(self.fault(
                        offset,
                        wrong(format!("schema encoding {encoding:?}; only \"ros2msg\" definitions are read")),
                    ));
                }
                self.demux.connect(id, &ch.topic, &ty, &text).map_err(|f| self.fault(offset, f))?;
            }
            let count = self.counts.entry(ch.id).or_insert(0);
            let index = *count;
            *count += 1;
            // borrow again: `connect` needed `&mut self`
            let Some(m) = self.reader.current() else { return Ok(false) };
            let t = i64::try_from(m.log_time).unwrap_or(i64::MAX);
            let r = self.demux.message(id, index, t, m.data, &mut self.buf);
            if let Err(f) = r {
                return Err(self.fault(offset, f));
            }
            if !self.buf.is_empty() {
                self.pending.extend(self.buf.drain(..));
                return Ok(true);
            }
        }
    }
}

impl QueuedFrames for McapFrames {
    fn decode_more(&mut self) -> Result<bool> {
        self.fill()
    }

    fn queue(&mut self) -> (&mut VecDeque<TaxelFrame>, &mut bool) {
        (&mut self.pending, &mut self.done)
    }

    fn demux(&self) -> &Demux {
        &self.demux
    }

    fn path(&self) -> &Path {
        &self.path
    }
}

impl Iterator for McapFrames {
    type Item = Result<TaxelFrame>;

    fn next(&mut self) -> Option<Self::Item> {
        self.next_frame()
    }
}
