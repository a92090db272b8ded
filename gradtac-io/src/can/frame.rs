//! Classic CAN frames, independent of any bus driver.

use crate::{Error, Result};
use gradtac_stream::{Timed, Timestamp};
use std::fmt;

/// Largest standard (11-bit) identifier.
pub const MAX_STANDARD_ID: u32 = 0x7FF;
/// Largest extended (29-bit) identifier.
pub const MAX_EXTENDED_ID: u32 = 0x1FFF_FFFF;

/// One classic CAN data frame as the decoder sees it: identifier, frame format, up to 8 data
/// bytes and the time it was received.
///
/// The type is independent of the bus driver: the candump parser, the in-memory transport and
/// the SocketCAN source all produce it. Remote (RTR) frames, error frames and CAN FD frames are
/// not data for a taxel codec; the readers count and skip them before they become a
/// `CanFrame`.
///
/// `time` follows the [`Timestamp`] epoch rule for live sources: nanoseconds since the Unix
/// epoch (candump logs store exactly that, in seconds with µs resolution).
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct CanFrame {
    id: u32,
    extended: bool,
    len: u8,
    data: [u8; 8],
    time: Timestamp,
}

impl CanFrame {
    /// A validated frame: `id` must fit 11 bits (standard) or 29 bits (`extended`), `data` must
    /// hold at most 8 bytes.
    pub fn try_new(id: u32, extended: bool, data: &[u8], time: Timestamp) -> Result<Self> {
        let max = if extended { MAX_EXTENDED_ID } else { MAX_STANDARD_ID };
        if id > max {
            return Err(Error::InvalidConfig(format!(
                "CAN id {id:#x} does not fit a {} identifier (max {max:#x})",
                if extended { "29-bit extended" } else { "11-bit standard" }
            )));
        }
        if data.len() > 8 {
            return Err(Error::InvalidConfig(format!(
                "CAN id {id:#x}: {} data bytes; a classic CAN frame carries at most 8",
                data.len()
            )));
        }
        let mut d = [0u8; 8];
        d[..data.len()].copy_from_slice(data);
        Ok(CanFrame { id, extended, len: data.len() as u8, data: d, time })
    }

    /// A standard-id frame; see [`try_new`](Self::try_new).
    pub fn standard(id: u32, data: &[u8], time: Timestamp) -> Result<Self> {
        Self::try_new(id, false, data, time)
    }

    /// An extended-id frame; see [`try_new`](Self::try_new).
    pub fn extended(id: u32, data: &[u8], time: Timestamp) -> Result<Self> {
        Self::try_new(id, true, data, time)
    }

    /// The identifier (without format flags).
    pub fn id(&self) -> u32 {
        self.id
    }

    /// True for a 29-bit extended identifier.
    pub fn is_extended(&self) -> bool {
        self.extended
    }

    /// The data bytes (0–8).
    pub fn data(&self) -> &[u8] {
        &self.data[..self.len as usize]
    }

    /// Number of data bytes.
    pub fn len(&self) -> usize {
        self.len as usize
    }

    /// True for a frame without data bytes.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// When the frame was received.
    pub fn time(&self) -> Timestamp {
        self.time
    }

    /// The same frame stamped with another time.
    pub fn with_time(mut self, time: Timestamp) -> Self {
        self.time = time;
        self
    }

    /// The identifier as candump prints it: 3 hex digits (standard) or 8 (extended).
    pub fn id_string(&self) -> String {
        fmt_id(self.id, self.extended)
    }

    /// The frame as one `candump -l` log line (without newline), e.g.
    /// `(1700000000.123456) can0 123#DEADBEEF`. The time is printed with µs resolution
    /// (truncated, as candump does). Logs cannot hold times before the Unix epoch; for them
    /// the line is not meaningful.
    pub fn to_candump_line(&self, interface: &str) -> String {
        let ns = self.time.as_nanos();
        let secs = ns.div_euclid(1_000_000_000);
        let us = ns.rem_euclid(1_000_000_000) / 1000;
        let mut s = format!("({secs}.{us:06}) {interface} {}#", self.id_string());
        for b in self.data() {
            s.push_str(&format!("{b:02X}"));
        }
        s
    }
}

/// An identifier formatted like candump: `123` or `1ABCDEF0`.
pub(crate) fn fmt_id(id: u32, extended: bool) -> String {
    if extended {
        format!("{id:08X}")
    } else {
        format!("{id:03X}")
    }
}

impl fmt::Debug for CanFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "CanFrame({}#", self.id_string())?;
        for b in self.data() {
            write!(f, "{b:02X}")?;
        }
        write!(f, " @ {:?})", self.time)
    }
}

impl Timed for CanFrame {
    fn time(&self) -> Timestamp {
        self.time
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validates_id_and_length() {
        assert!(CanFrame::standard(0x7FF, &[], Timestamp(0)).is_ok());
        let e = CanFrame::standard(0x800, &[], Timestamp(0)).unwrap_err().to_string();
        assert!(e.contains("0x800") && e.contains("11-bit"), "{e}");
        assert!(CanFrame::extended(0x1FFF_FFFF, &[1; 8], Timestamp(0)).is_ok());
        assert!(CanFrame::extended(0x2000_0000, &[], Timestamp(0)).is_err());
        let e = CanFrame::standard(1, &[0; 9], Timestamp(0)).unwrap_err().to_string();
        assert!(e.contains("9 data bytes"), "{e}");
    }

    #[test]
    fn candump_line_formats_like_candump() {
        let f = CanFrame::standard(0x123, &[0xDE, 0xAD, 0xBE, 0xEF], Timestamp(1_700_000_000_123_456_789)).unwrap();
        assert_eq!(f.to_candump_line("can0"), "(1700000000.123456) can0 123#DEADBEEF");
        let f = CanFrame::extended(0x1ABC, &[], Timestamp(5_000_999)).unwrap();
        assert_eq!(f.to_candump_line("vcan1"), "(0.005000) vcan1 00001ABC#");
        assert_eq!(f.len(), 0);
        assert!(f.is_empty());
    }
}
