//! [`RosbagFrames`]: one pass over a ROS 1 bag, yielding the taxel frames of every sensor
//! that reads it.

use super::bag::BagReader;
use super::decode::Wire;
use super::extract::{BagSensor, Demux, Fault, QueuedFrames};
use super::msgdef::Dialect;
use crate::error::BagSite;
use crate::{Error, Result};
use gradtac_stream::TaxelFrame;
use std::collections::VecDeque;
use std::path::Path;

/// The frames of several sensors read from one ROS 1 bag in one pass, in the order the bag
/// recorded their messages (an `Iterator<Item = Result<TaxelFrame>>`).
///
/// Each sensor names a topic and, for `BiotacAll`-style messages, a finger; a message on a
/// topic read by `k` sensors yields `k` frames (one per sensor, in sensor order). A frame's
/// `seq` counts that sensor's messages from 0, its time is the message's header stamp (or
/// the record time, per [`StampSource`](super::StampSource)). The first error ends the
/// iteration: it names the file, the byte offset and, for a message, topic, type and index.
pub struct RosbagFrames {
    reader: BagReader,
    demux: Demux,
    pending: VecDeque<TaxelFrame>,
    buf: Vec<TaxelFrame>,
    done: bool,
}

impl RosbagFrames {
    /// Open `path` for `sensors` (at least one).
    pub fn open(path: impl AsRef<Path>, sensors: Vec<BagSensor>) -> Result<Self> {
        if sensors.is_empty() {
            return Err(Error::InvalidConfig("a ROS bag source needs at least one sensor".into()));
        }
        // chunks of topics no sensor reads are seeked over when the bag has an index
        let topics: Vec<String> = sensors.iter().map(|s| s.topic.clone()).collect();
        Ok(RosbagFrames {
            reader: BagReader::open(path)?.with_topics(topics)?,
            demux: Demux::new(sensors, Wire::Ros1, Dialect::Ros1),
            pending: VecDeque::new(),
            buf: Vec::new(),
            done: false,
        })
    }

    /// File bytes consumed so far and the file's size (for progress).
    pub fn progress(&self) -> (u64, u64) {
        (self.reader.bytes_read(), self.reader.len())
    }

    fn fault(&self, offset: u64, f: Fault) -> Error {
        Error::Bag {
            path: self.reader.path().to_path_buf(),
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
            let (id, offset, index) = (m.connection.id, m.offset, m.index);
            if !self.demux.knows(id) {
                let c = m.connection.clone();
                self.demux.connect(id, &c.topic, &c.msg_type, &c.definition).map_err(|f| self.fault(offset, f))?;
            }
            // borrow again: `connect` needed `&mut self`
            let Some(m) = self.reader.current() else { return Ok(false) };
            let r = self.demux.message(id, index, m.record_time.nanos(), m.data, &mut self.buf);
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

impl QueuedFrames for RosbagFrames {
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
        self.reader.path()
    }
}

impl Iterator for RosbagFrames {
    type Item = Result<TaxelFrame>;

    fn next(&mut self) -> Option<Self::Item> {
        self.next_frame()
    }
}
