//! Recorded hands: ROS 1 bags and ROS 2 MCAP files of tactile topics
//! (`sr_robot_msgs/BiotacAll` from a Shadow Hand, or any message with an integer
//! `electrodes` array), decoded by the message definition the file embeds.
//!
//! ```text
//! ROS 1 bag ── BagReader (container: records, none/bz2/lz4 chunks) ──┐
//!                                                                    ├─ Schema (msgdef) ─ decode (ROS 1 / CDR) ─ ElectrodePlan ─> TaxelFrame
//! MCAP ─────── McapReader (container: chunks, channels, schemas) ───┘
//! ```
//!
//! - [`bag::BagReader`]: the ROS bag 2.0 container, written from the public format spec.
//! - [`mcap_read::McapReader`]: the MCAP container, written from the public spec; every
//!   length a record claims is checked before anything is allocated for it.
//! - [`inflate::InflateBudget`]: what a file's chunks may decompress (ratio and total).
//! - [`msgdef::Schema`]: the `.msg` definition text (ROS 1 and ROS 2 rules) parsed and resolved.
//! - [`decode::decode`]: a generic decoder driven by a schema, for the ROS 1 wire format and
//!   CDR; bounded by the message's own length.
//! - [`extract::ElectrodePlan`]: where one fingertip's electrodes and the header stamp are.
//! - [`RosbagFrames`] / [`McapFrames`]: one pass over a bag / MCAP file yielding the frames of
//!   every sensor that reads it (several sensors — fingers — of one file share the pass).
//!
//! Scene syntax (see `docs/recorded-hands.md`):
//!
//! ```toml
//! [[sensor]]
//! name = "ff"
//! source = { rosbag = "grasp.bag", topic = "/rh/tactile", finger = "ff" }
//! ```

pub mod bag;
mod container_io;
pub mod decode;
pub mod extract;
pub mod inflate;
pub mod mcap_read;
pub mod mcap_source;
pub mod msgdef;
mod source;

pub use bag::{BagMessage, BagReader, Connection, RosTime};
pub use extract::{BagSensor, ElectrodePlan};
pub use mcap_source::McapFrames;
pub use source::RosbagFrames;

use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// A Shadow Hand fingertip: the slot of `BiotacAll.tactiles` (ff, mf, rf, lf, th = 0 … 4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Finger {
    /// First finger (slot 0).
    Ff,
    /// Middle finger (slot 1).
    Mf,
    /// Ring finger (slot 2).
    Rf,
    /// Little finger (slot 3).
    Lf,
    /// Thumb (slot 4).
    Th,
}

impl Finger {
    /// Every finger in slot order.
    pub const ALL: [Finger; 5] = [Finger::Ff, Finger::Mf, Finger::Rf, Finger::Lf, Finger::Th];

    /// The slot in `tactiles`.
    pub fn slot(self) -> usize {
        self as usize
    }

    /// Its name (`ff`).
    pub fn as_str(self) -> &'static str {
        ["ff", "mf", "rf", "lf", "th"][self.slot()]
    }
}

/// Where a frame's time comes from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StampSource {
    /// The message's `header.stamp` (when the hand sampled it; default).
    #[default]
    Header,
    /// The time the recorder received the message (bag record time / MCAP `log_time`).
    Record,
}

/// A recorded-hand source of a scene: `{ rosbag = "FILE", topic = "/rh/tactile", finger = "ff" }`
/// or `{ mcap = "FILE", … }`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BagSourceConfig {
    /// The file (key `rosbag` or `mcap` in a scene).
    #[serde(alias = "rosbag", alias = "mcap")]
    pub path: PathBuf,
    /// The topic (`/rh/tactile`).
    pub topic: String,
    /// The fingertip, for messages holding several (`BiotacAll`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub finger: Option<Finger>,
    /// `"header"` (default) or `"record"`.
    #[serde(default)]
    pub time: StampSource,
}

impl BagSourceConfig {
    /// The sensor this configuration describes, named `sensor`.
    pub fn sensor(&self, sensor: gradtac_stream::SensorId) -> BagSensor {
        BagSensor { sensor, topic: self.topic.clone(), finger: self.finger, time: self.time }
    }
}
