//! Counts of CAN traffic and its faults, with the first occurrence of each fault.
//!
//! Every fault is counted, remembered by its first occurrence (CAN id and time) and logged
//! through `tracing` (target `gradtac_io::can`) with the id and time: at `WARN` when the
//! fault's count reaches 1, 2, 4, 8, … (so a flood of bad frames logs a few lines, not one per
//! frame) and at `DEBUG` otherwise.

use crate::can::frame::fmt_id;
use gradtac_stream::{SensorId, Timestamp};
use serde::Serialize;
use std::fmt;
use std::sync::{Arc, Mutex, MutexGuard};

/// The kinds of bad traffic.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// A frame whose id no message of the codec matches.
    UnknownId,
    /// A frame of a known message with another data length than the message's.
    WrongLength,
    /// A multiplexer value that selects no taxel block and is not listed as ignored.
    UnknownMux,
    /// A field whose raw value is outside the valid range (counted per value).
    OutOfRange,
    /// A taxel set that did not complete (timeout, a new cycle starting first, out-of-range
    /// values, end of stream); counted per set, whether dropped or carried.
    Incomplete,
    /// A taxel value carried from an earlier set into an incomplete one (counted per value).
    Carried,
    /// A field whose bytes fail their parity check (SynTouch BioTac words: odd parity per
    /// byte); the value is dropped, never decoded (counted per value).
    Parity,
    /// A frame its device marks as an invalid sample (Xela uSkin: `data[1] ≥ 250`); none of
    /// its values are used (counted per frame).
    InvalidSample,
}

impl FaultKind {
    /// The snake_case name used in logs and serialised stats.
    pub fn as_str(self) -> &'static str {
        match self {
            FaultKind::UnknownId => "unknown_id",
            FaultKind::WrongLength => "wrong_length",
            FaultKind::UnknownMux => "unknown_mux",
            FaultKind::OutOfRange => "out_of_range",
            FaultKind::Incomplete => "incomplete",
            FaultKind::Carried => "carried",
            FaultKind::Parity => "parity",
            FaultKind::InvalidSample => "invalid_sample",
        }
    }
}

/// Where a fault happened: the CAN frame (id, format, time) and, when known, the sensor.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct FaultSite {
    /// CAN identifier of the frame (for an incomplete set: its first frame).
    pub id: u32,
    /// True for an extended identifier.
    pub extended: bool,
    /// The frame's time.
    pub time: Timestamp,
    /// The sensor, when the id belongs to one.
    pub sensor: Option<SensorId>,
    /// What exactly (the length found, the value, the missing taxels, …).
    pub detail: String,
}

impl fmt::Display for FaultSite {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "id {} at {}", fmt_id(self.id, self.extended), self.time)?;
        if let Some(s) = &self.sensor {
            write!(f, " (sensor {s})")?;
        }
        write!(f, ": {}", self.detail)
    }
}

/// A fault's count and first occurrence.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Fault {
    /// How many times it happened.
    pub count: u64,
    /// The first time it happened.
    pub first: Option<FaultSite>,
}

/// Counts of what a [`CanDecoder`](super::CanDecoder) saw.
///
/// Serialises (serde) to a flat object, e.g. for a `stats` JSON output:
/// `{"frames": 1200, "frames_decoded": 1180, …, "unknown_id": {"count": 3, "first": {…}}, …}`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct CanStats {
    /// CAN frames pushed into the decoder.
    pub frames: u64,
    /// Frames whose fields were decoded into a taxel set.
    pub frames_decoded: u64,
    /// Frames with a multiplexer value listed as carrying other data.
    pub frames_ignored: u64,
    /// Taxel frames emitted with every value from the current cycle.
    pub sets_complete: u64,
    /// Taxel frames emitted with carried values (policy `carry`).
    pub sets_carried: u64,
    /// Incomplete sets dropped (policy `drop`, or `carry` without an earlier value).
    pub sets_dropped: u64,
    /// Frames with an id no message matches.
    pub unknown_id: Fault,
    /// Frames with the wrong data length.
    pub wrong_length: Fault,
    /// Frames with an unknown multiplexer value.
    pub unknown_mux: Fault,
    /// Field values outside the valid raw range.
    pub out_of_range: Fault,
    /// Sets that did not complete.
    pub incomplete: Fault,
    /// Taxel values carried from earlier sets.
    pub carried: Fault,
    /// Field values failing their parity check (dropped).
    pub parity: Fault,
    /// Frames marked by their device as invalid samples.
    pub invalid_sample: Fault,
}

impl CanStats {
    /// The fault record of a kind.
    pub fn fault(&self, kind: FaultKind) -> &Fault {
        match kind {
            FaultKind::UnknownId => &self.unknown_id,
            FaultKind::WrongLength => &self.wrong_length,
            FaultKind::UnknownMux => &self.unknown_mux,
            FaultKind::OutOfRange => &self.out_of_range,
            FaultKind::Incomplete => &self.incomplete,
            FaultKind::Carried => &self.carried,
            FaultKind::Parity => &self.parity,
            FaultKind::InvalidSample => &self.invalid_sample,
        }
    }

    fn fault_mut(&mut self, kind: FaultKind) -> &mut Fault {
        match kind {
            FaultKind::UnknownId => &mut self.unknown_id,
            FaultKind::WrongLength => &mut self.wrong_length,
            FaultKind::UnknownMux => &mut self.unknown_mux,
            FaultKind::OutOfRange => &mut self.out_of_range,
            FaultKind::Incomplete => &mut self.incomplete,
            FaultKind::Carried => &mut self.carried,
            FaultKind::Parity => &mut self.parity,
            FaultKind::InvalidSample => &mut self.invalid_sample,
        }
    }

    /// Total faults of every kind except `carried` (which is a consequence of `incomplete`).
    pub fn total_faults(&self) -> u64 {
        self.unknown_id.count
            + self.wrong_length.count
            + self.unknown_mux.count
            + self.out_of_range.count
            + self.incomplete.count
            + self.parity.count
            + self.invalid_sample.count
    }

    /// Count `n` faults of `kind` at `site` and log them.
    pub(crate) fn record(&mut self, kind: FaultKind, n: u64, site: impl FnOnce() -> FaultSite) {
        if n == 0 {
            return;
        }
        let f = self.fault_mut(kind);
        let before = f.count;
        f.count += n;
        // log when the count crosses a power of two (1, 2, 4, …)
        let loud = before == 0 || (before + 1..=f.count).any(u64::is_power_of_two);
        let lazy = f.first.is_none() || loud || tracing::enabled!(target: "gradtac_io::can", tracing::Level::DEBUG);
        if !lazy {
            return;
        }
        let s = site();
        let count = f.count;
        if loud {
            tracing::warn!(target: "gradtac_io::can", fault = kind.as_str(), id = %fmt_id(s.id, s.extended),
                time_ns = s.time.as_nanos(), sensor = s.sensor.as_ref().map(|x| x.as_str()), count,
                "CAN {}: {s}", kind.as_str());
        } else {
            tracing::debug!(target: "gradtac_io::can", fault = kind.as_str(), id = %fmt_id(s.id, s.extended),
                time_ns = s.time.as_nanos(), sensor = s.sensor.as_ref().map(|x| x.as_str()), count,
                "CAN {}: {s}", kind.as_str());
        }
        if f.first.is_none() {
            f.first = Some(s);
        }
    }
}

impl fmt::Display for CanStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} CAN frames ({} decoded, {} ignored); taxel sets: {} complete, {} carried, {} dropped",
            self.frames,
            self.frames_decoded,
            self.frames_ignored,
            self.sets_complete,
            self.sets_carried,
            self.sets_dropped
        )?;
        for k in [
            FaultKind::UnknownId,
            FaultKind::WrongLength,
            FaultKind::UnknownMux,
            FaultKind::OutOfRange,
            FaultKind::Incomplete,
            FaultKind::Carried,
            FaultKind::Parity,
            FaultKind::InvalidSample,
        ] {
            let x = self.fault(k);
            if let Some(site) = &x.first {
                write!(f, "; {} × {} (first: {site})", x.count, k.as_str())?;
            }
        }
        Ok(())
    }
}

/// A shared view of a decoder's [`CanStats`], readable while the decoder runs inside a stream
/// (another task, another thread). Cloning shares the same counts.
#[derive(Clone, Debug, Default)]
pub struct StatsHandle(Arc<Mutex<CanStats>>);

impl StatsHandle {
    /// A copy of the counts now.
    pub fn snapshot(&self) -> CanStats {
        self.lock().clone()
    }

    pub(crate) fn lock(&self) -> MutexGuard<'_, CanStats> {
        // A panic while holding the lock cannot leave counts inconsistent in a harmful way.
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_first_site_and_counts() {
        let mut s = CanStats::default();
        let site = |id| move || FaultSite { id, extended: false, time: Timestamp(5), sensor: None, detail: "x".into() };
        s.record(FaultKind::UnknownId, 1, site(1));
        s.record(FaultKind::UnknownId, 1, site(2));
        s.record(FaultKind::OutOfRange, 3, site(3));
        s.record(FaultKind::OutOfRange, 0, site(4));
        assert_eq!(s.unknown_id.count, 2);
        assert_eq!(s.unknown_id.first.as_ref().unwrap().id, 1);
        assert_eq!(s.out_of_range.count, 3);
        assert_eq!(s.total_faults(), 5);
        let text = s.to_string();
        assert!(text.contains("2 × unknown_id (first: id 001 at 0.000000005s: x)"), "{text}");
        let json = serde_json::to_string(&s).unwrap();
        assert!(json.contains("\"unknown_id\":{\"count\":2"), "{json}");
    }
}
