//! Reassembly of taxel frames from CAN frames: [`CanDecoder`], the synchronous core every CAN
//! source feeds.
//!
//! # What it does
//! Each CAN frame is decoded by the [`CanCodec`]; its values go into the *open set* of its
//! sensor (one slot per taxel). A set is closed
//! - **complete**, when every taxel's slot has been filled by a valid value: a [`TaxelFrame`]
//!   is emitted at once;
//! - **incomplete**, when
//!   - a frame arrives for a slot the open set has already seen (the next cycle began before
//!     this one completed: lost frames),
//!   - the decoder's clock (the latest frame time seen, or [`CanDecoder::advance_to`]) passes
//!     the set's first frame time by more than the sensor's `timeout_ms`,
//!   - every slot was seen but some values were out of range, or
//!   - the stream ends ([`Stage::finish`]) with the set open.
//!
//!   An incomplete set is counted ([`CanStats::incomplete`]) and then, by the sensor's
//!   [`IncompletePolicy`], dropped, or emitted with each missing taxel holding the last valid
//!   value received for it and flagged ([`DecodedFrame::carried`]). A set with a taxel that
//!   never had a value is dropped even under `carry`.
//!
//! Bad frames (unknown id, wrong length, unknown multiplexer value) and out-of-range values
//! are counted in [`CanStats`] and logged; they never stop the decoder nor panic it.
//!
//! # Output
//! - `sensor`: from the codec; `values`: the decoded values in the sensor's unit;
//! - `time`: the time of the last CAN frame that contributed to the set (the moment the
//!   sample was known); times of one sensor never decrease when input times do not;
//! - `seq`: the index of the set (bus cycle) per sensor from 0, counting dropped sets too, so
//!   a gap in `seq` shows dropped cycles.
//!
//! # Delay and trade-offs
//! A complete set leaves with its last CAN frame: [`Stage::delay`] is zero. An incomplete set
//! leaves when its fault is detected: at the latest `timeout_ms` after its first frame (plus
//! the wait for the next frame when driven only by frames; [`CanDecoder::advance_to`] lets a
//! live source expire sets on a timer).
//!
//! | policy | output rate | values | use when |
//! |---|---|---|---|
//! | `drop` | a frame is missing per lost set | every value from its own cycle | offline analysis, accuracy first |
//! | `carry` | steady | carried taxels are up to one or more cycles stale (flagged) | live control that needs a steady rate |
//!
//! A short `timeout_ms` detects lost frames sooner but splits sets whose frames are spread
//! over a long cycle; set it above the sensor's cycle time (e.g. 2–5 cycles).

use crate::can::codec::{CanCodec, Decoded, FieldValue, IncompletePolicy};
use crate::can::frame::CanFrame;
use crate::can::stats::{CanStats, FaultKind, FaultSite, StatsHandle};
use crate::{Error, Result};
use gradtac_stream::{Delay, SensorId, Stage, TaxelFrame, Timestamp};

/// A taxel frame and which of its values were carried from earlier sets.
#[derive(Clone, Debug, PartialEq)]
pub struct DecodedFrame {
    /// The frame.
    pub frame: TaxelFrame,
    /// Taxel indices whose value was carried from an earlier set (policy `carry`); empty for a
    /// complete set.
    pub carried: Vec<u32>,
}

impl DecodedFrame {
    /// True when no value was carried.
    pub fn is_complete(&self) -> bool {
        self.carried.is_empty()
    }
}

impl From<DecodedFrame> for TaxelFrame {
    fn from(d: DecodedFrame) -> TaxelFrame {
        d.frame
    }
}

/// Why a set closed incomplete.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Why {
    Timeout,
    Restarted,
    OutOfRange,
    EndOfStream,
}

impl Why {
    fn as_str(self) -> &'static str {
        match self {
            Why::Timeout => "timed out",
            Why::Restarted => "a new cycle began before it completed",
            Why::OutOfRange => "values out of range",
            Why::EndOfStream => "the stream ended",
        }
    }
}

/// The open set of one sensor, and what carries over between sets.
#[derive(Clone, Debug)]
struct SetState {
    open: bool,
    first_id: u32,
    first_extended: bool,
    first_time: Timestamp,
    last_time: Timestamp,
    seen: Vec<bool>,
    n_seen: usize,
    values: Vec<Option<f64>>,
    last: Vec<Option<f64>>,
    seq: u64,
}

impl SetState {
    fn new(taxels: usize) -> Self {
        SetState {
            open: false,
            first_id: 0,
            first_extended: false,
            first_time: Timestamp::ZERO,
            last_time: Timestamp::ZERO,
            seen: vec![false; taxels],
            n_seen: 0,
            values: vec![None; taxels],
            last: vec![None; taxels],
            seq: 0,
        }
    }

    fn clear_set(&mut self) {
        self.open = false;
        self.seen.fill(false);
        self.n_seen = 0;
        self.values.fill(None);
    }
}

/// Decodes CAN frames into [`TaxelFrame`]s: codec + per-sensor reassembly + fault counts (see
/// the [module docs](self)).
///
/// As a [`Stage`] it takes [`CanFrame`]s and yields `TaxelFrame`s; [`flagged`](Self::flagged)
/// gives a stage yielding [`DecodedFrame`]s that keep the carried-value flags. Bad traffic is
/// never an `Err`: it is counted in [`stats`](Self::stats).
///
/// ```
/// use gradtac_io::can::{CanCodec, CanDecoder, CanFrame, CodecConfig, PresetConfig, PresetKind};
/// use gradtac_stream::{StageExt, Timestamp};
///
/// let codec = CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &["ff"])))?;
/// let mut dec = CanDecoder::new(codec);
/// // six multiplexed frames (mux 0..5) make one 24-electrode frame
/// let frames: Vec<CanFrame> = (0..6u8)
///     .map(|m| CanFrame::standard(0x100, &[m, 0x40, 0x04, 0x00, 0x40, 0x04, 0x00, 0], Timestamp(1_000 * m as i64)))
///     .collect::<Result<_, _>>()?;
/// let out = dec.run_all(frames)?;
/// assert_eq!(out.len(), 1);
/// assert_eq!(&out[0].values[..4], &[1024.0, 1024.0, 1024.0, 1024.0]);
/// assert_eq!(dec.stats().sets_complete, 1);
/// # Ok::<(), gradtac_io::Error>(())
/// ```
#[derive(Debug)]
#[must_use = "a decoder does nothing until frames are pushed"]
pub struct CanDecoder {
    codec: CanCodec,
    sets: Vec<SetState>,
    clock: Option<Timestamp>,
    fields: Vec<FieldValue>,
    scratch: Vec<DecodedFrame>,
    stats: StatsHandle,
}

impl CanDecoder {
    /// A decoder for a validated codec.
    pub fn new(codec: CanCodec) -> Self {
        let sets = (0..codec.num_sensors()).map(|i| SetState::new(codec.taxels(i))).collect();
        CanDecoder { codec, sets, clock: None, fields: Vec::new(), scratch: Vec::new(), stats: StatsHandle::default() }
    }

    /// The codec.
    pub fn codec(&self) -> &CanCodec {
        &self.codec
    }

    /// A copy of the counts so far.
    pub fn stats(&self) -> CanStats {
        self.stats.snapshot()
    }

    /// A shared handle on the counts, to read them while the decoder runs inside a stream.
    pub fn stats_handle(&self) -> StatsHandle {
        self.stats.clone()
    }

    /// A stage yielding [`DecodedFrame`]s (with carried-value flags) instead of `TaxelFrame`s.
    pub fn flagged(self) -> FlaggedDecoder {
        FlaggedDecoder(self)
    }

    /// The earliest time at which an open set times out, if any set is open.
    pub fn next_deadline(&self) -> Option<Timestamp> {
        self.sets
            .iter()
            .enumerate()
            .filter(|(_, s)| s.open)
            // saturating: frame times come from the bus or a log and may lie anywhere in i64
            .map(|(i, s)| Timestamp(s.first_time.0.saturating_add(self.codec.sensor(i).timeout_ns)))
            .min()
    }

    /// Advance the clock to `now` without a frame (a live source's timer): sets that time out
    /// by then are closed as incomplete.
    pub fn advance_to(&mut self, now: Timestamp, out: &mut Vec<DecodedFrame>) {
        let stats = self.stats.clone();
        let mut st = stats.lock();
        self.tick(now, &mut st, out);
    }

    fn tick(&mut self, now: Timestamp, st: &mut CanStats, out: &mut Vec<DecodedFrame>) {
        let clock = self.clock.map_or(now, |c| c.max(now));
        self.clock = Some(clock);
        for i in 0..self.sets.len() {
            let s = &self.sets[i];
            if s.open && clock.0.saturating_sub(s.first_time.0) > self.codec.sensor(i).timeout_ns {
                self.close(i, Some(Why::Timeout), st, out);
            }
        }
    }

    /// Push one CAN frame, appending the frames it completes (with flags) to `out`.
    pub fn push_decoded(&mut self, frame: CanFrame, out: &mut Vec<DecodedFrame>) {
        let stats = self.stats.clone();
        let mut st = stats.lock();
        st.frames += 1;
        self.tick(frame.time(), &mut st, out);
        let mut fields = std::mem::take(&mut self.fields);
        let mut from = 0;
        let mut decoded_any = false;
        loop {
            let (decoded, next) = self.codec.decode_from(from, &frame, &mut fields);
            if from > 0 && decoded == Decoded::UnknownId {
                break; // no further sensor's part of a shared frame
            }
            self.apply(&frame, decoded, &fields, &mut decoded_any, &mut st, out);
            if !matches!(decoded, Decoded::Values { .. }) {
                break; // the other parts of a shared frame share its length and multiplexer
            }
            match next {
                Some(n) => from = n,
                None => break,
            }
        }
        if decoded_any {
            st.frames_decoded += 1;
        }
        self.fields = fields;
    }

    /// Handle one message's part of a frame.
    fn apply(
        &mut self,
        frame: &CanFrame,
        decoded: Decoded,
        fields: &[FieldValue],
        decoded_any: &mut bool,
        st: &mut CanStats,
        out: &mut Vec<DecodedFrame>,
    ) {
        let site = |codec: &CanCodec, sensor: Option<usize>, detail: String| FaultSite {
            id: frame.id(),
            extended: frame.is_extended(),
            time: frame.time(),
            sensor: sensor.map(|i| codec.sensor_id(i).clone()),
            detail,
        };
        match decoded {
            Decoded::UnknownId => st.record(FaultKind::UnknownId, 1, || {
                site(&self.codec, None, format!("no message matches ({} bytes)", frame.len()))
            }),
            Decoded::WrongLength { sensor, expected, got } => st.record(FaultKind::WrongLength, 1, || {
                site(&self.codec, Some(sensor), format!("{got} data bytes, the message has {expected}"))
            }),
            Decoded::UnknownMux { sensor, value } => st.record(FaultKind::UnknownMux, 1, || {
                site(&self.codec, Some(sensor), format!("multiplexer value {value} selects no taxel block"))
            }),
            Decoded::Ignored { .. } => st.frames_ignored += 1,
            Decoded::Values { sensor, .. } => {
                *decoded_any = true;
                let repeat = {
                    let s = &self.sets[sensor];
                    s.open && fields.iter().any(|f| s.seen[f.taxel as usize])
                };
                if repeat {
                    self.close(sensor, Some(Why::Restarted), st, out);
                }
                let s = &mut self.sets[sensor];
                if !s.open {
                    s.open = true;
                    s.first_id = frame.id();
                    s.first_extended = frame.is_extended();
                    s.first_time = frame.time();
                }
                s.last_time = s.last_time.max(frame.time());
                let mut bad = Vec::new();
                for f in fields {
                    let t = f.taxel as usize;
                    s.seen[t] = true;
                    s.n_seen += 1;
                    match f.value {
                        Some(v) => s.values[t] = Some(v),
                        None => bad.push(*f),
                    }
                }
                let complete = s.n_seen == s.seen.len();
                let invalid = bad.iter().filter(|f| f.fault == Some(FaultKind::InvalidSample)).count();
                if invalid > 0 {
                    st.record(FaultKind::InvalidSample, 1, || {
                        site(
                            &self.codec,
                            Some(sensor),
                            format!("the device marks the sample invalid ({invalid} values unused)"),
                        )
                    });
                }
                for kind in [FaultKind::Parity, FaultKind::OutOfRange] {
                    let detail: Vec<String> = bad
                        .iter()
                        .filter(|f| f.fault.unwrap_or(FaultKind::OutOfRange) == kind)
                        .map(|f| format!("taxel {} raw {}", f.taxel, f.raw))
                        .collect();
                    let what =
                        if kind == FaultKind::Parity { "failing the parity check" } else { "outside the valid range" };
                    st.record(kind, detail.len() as u64, || {
                        site(&self.codec, Some(sensor), format!("{} {what}", detail.join(", ")))
                    });
                }
                if complete {
                    self.close(sensor, None, st, out);
                }
            }
        }
    }

    /// Close sensor `i`'s open set: emit it (complete or per policy) or drop it.
    fn close(&mut self, i: usize, why: Option<Why>, st: &mut CanStats, out: &mut Vec<DecodedFrame>) {
        let sensor: &SensorId = self.codec.sensor_id(i);
        let policy = self.codec.sensor(i).policy;
        let s = &mut self.sets[i];
        if !s.open {
            return;
        }
        let seq = s.seq;
        s.seq += 1;
        let missing: Vec<u32> = (0..s.values.len()).filter(|&t| s.values[t].is_none()).map(|t| t as u32).collect();
        for (t, v) in s.values.iter().enumerate() {
            if v.is_some() {
                s.last[t] = *v;
            }
        }
        if missing.is_empty() {
            let values = s.values.iter().map(|v| v.unwrap_or(f64::NAN)).collect();
            out.push(DecodedFrame {
                frame: TaxelFrame::new(sensor.clone(), s.last_time, seq, values),
                carried: Vec::new(),
            });
            st.sets_complete += 1;
            s.clear_set();
            return;
        }
        let why = why.unwrap_or(Why::OutOfRange);
        let can_carry = policy == IncompletePolicy::Carry && missing.iter().all(|&t| s.last[t as usize].is_some());
        let site = FaultSite {
            id: s.first_id,
            extended: s.first_extended,
            time: s.first_time,
            sensor: Some(sensor.clone()),
            detail: format!(
                "set {seq}: {}; {} of {} taxels missing ({}){}",
                why.as_str(),
                missing.len(),
                s.values.len(),
                short_list(&missing),
                match (policy, can_carry) {
                    (IncompletePolicy::Drop, _) => "; dropped",
                    (IncompletePolicy::Carry, true) => "; last values carried",
                    (IncompletePolicy::Carry, false) => "; dropped: a missing taxel has no earlier value to carry",
                }
            ),
        };
        let (carry_site_id, carry_ext, carry_time) = (s.first_id, s.first_extended, s.first_time);
        st.record(FaultKind::Incomplete, 1, || site);
        if can_carry {
            let values = (0..s.values.len()).map(|t| s.values[t].or(s.last[t]).unwrap_or(f64::NAN)).collect();
            let n = missing.len() as u64;
            let detail = format!("set {seq}: taxels {} carried", short_list(&missing));
            out.push(DecodedFrame {
                frame: TaxelFrame::new(sensor.clone(), s.last_time, seq, values),
                carried: missing,
            });
            st.sets_carried += 1;
            st.record(FaultKind::Carried, n, || FaultSite {
                id: carry_site_id,
                extended: carry_ext,
                time: carry_time,
                sensor: Some(sensor.clone()),
                detail,
            });
        } else {
            st.sets_dropped += 1;
        }
        s.clear_set();
    }

    /// End of stream: close every open set as incomplete (by policy), then reset.
    pub fn finish_decoded(&mut self, out: &mut Vec<DecodedFrame>) {
        let stats = self.stats.clone();
        let mut st = stats.lock();
        for i in 0..self.sets.len() {
            self.close(i, Some(Why::EndOfStream), &mut st, out);
        }
        drop(st);
        Stage::reset(self);
    }
}

fn short_list(v: &[u32]) -> String {
    let mut s: Vec<String> = v.iter().take(8).map(|x| x.to_string()).collect();
    if v.len() > 8 {
        s.push("…".into());
    }
    s.join(", ")
}

impl Stage for CanDecoder {
    type In = CanFrame;
    type Out = TaxelFrame;
    type Error = Error;

    fn push(&mut self, input: CanFrame, out: &mut Vec<TaxelFrame>) -> Result<()> {
        let mut buf = std::mem::take(&mut self.scratch);
        self.push_decoded(input, &mut buf);
        out.extend(buf.drain(..).map(|d| d.frame));
        self.scratch = buf;
        Ok(())
    }

    fn finish(&mut self, out: &mut Vec<TaxelFrame>) -> Result<()> {
        let mut buf = std::mem::take(&mut self.scratch);
        self.finish_decoded(&mut buf);
        out.extend(buf.drain(..).map(|d| d.frame));
        self.scratch = buf;
        Ok(())
    }

    /// Forget open sets, last values (nothing is carried across a reset), `seq` counters and
    /// the clock; counts in [`stats`](CanDecoder::stats) are kept.
    fn reset(&mut self) {
        for (i, s) in self.sets.iter_mut().enumerate() {
            *s = SetState::new(self.codec.taxels(i));
        }
        self.clock = None;
    }

    fn delay(&self) -> Delay {
        Delay::ZERO
    }
}

/// [`CanDecoder`] as a stage yielding [`DecodedFrame`]s; see [`CanDecoder::flagged`].
#[derive(Debug)]
#[must_use = "a decoder does nothing until frames are pushed"]
pub struct FlaggedDecoder(CanDecoder);

impl FlaggedDecoder {
    /// The decoder.
    pub fn decoder(&self) -> &CanDecoder {
        &self.0
    }

    /// The decoder, back.
    pub fn into_inner(self) -> CanDecoder {
        self.0
    }
}

impl Stage for FlaggedDecoder {
    type In = CanFrame;
    type Out = DecodedFrame;
    type Error = Error;

    fn push(&mut self, input: CanFrame, out: &mut Vec<DecodedFrame>) -> Result<()> {
        self.0.push_decoded(input, out);
        Ok(())
    }

    fn finish(&mut self, out: &mut Vec<DecodedFrame>) -> Result<()> {
        self.0.finish_decoded(out);
        Ok(())
    }

    fn reset(&mut self) {
        Stage::reset(&mut self.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::can::codec::{CodecConfig, MessageSpec, SensorSpec};
    use gradtac_stream::StageExt;

    /// A 4-taxel sensor at id 0x10 carried by 2 frames (mux 0/1), two 8-bit fields each,
    /// valid range 1..=250.
    fn decoder(policy: IncompletePolicy) -> CanDecoder {
        let m = MessageSpec {
            mux: Some(crate::can::codec::MuxSpec::new(0, 2, vec![9])),
            raw_min: Some(1),
            raw_max: Some(250),
            ..MessageSpec::new(0x10, 8, 8, 2)
        };
        let s = SensorSpec { name: "s".into(), taxels: 4, timeout_ms: 10.0, incomplete: policy, messages: vec![m] };
        CanDecoder::new(CanCodec::try_new(&CodecConfig::sensors(vec![s])).unwrap())
    }

    fn f(mux: u8, a: u8, b: u8, ms: i64) -> CanFrame {
        CanFrame::standard(0x10, &[mux, a, b], Timestamp(ms * 1_000_000)).unwrap()
    }

    #[test]
    fn complete_sets_emit_at_their_last_frame() {
        let mut d = decoder(IncompletePolicy::Drop);
        let out = d.clone_run(&[f(0, 1, 2, 0), f(1, 3, 4, 1), f(0, 5, 6, 2), f(1, 7, 8, 3)]);
        assert_eq!(out.len(), 2);
        assert_eq!(out[0].frame.values, vec![1.0, 2.0, 3.0, 4.0]);
        assert_eq!((out[1].frame.seq, out[1].frame.time), (1, Timestamp(3_000_000)));
        assert_eq!(d.stats().sets_complete, 2);
        assert_eq!(d.stats().total_faults(), 0);
    }

    impl CanDecoder {
        fn clone_run(&mut self, frames: &[CanFrame]) -> Vec<DecodedFrame> {
            let mut out = Vec::new();
            for x in frames {
                self.push_decoded(*x, &mut out);
            }
            self.finish_decoded(&mut out);
            out
        }
    }

    #[test]
    fn lost_frame_drops_the_set_under_drop() {
        let mut d = decoder(IncompletePolicy::Drop);
        // set 0 complete; set 1 loses mux 1; set 2 complete
        let out = d.clone_run(&[f(0, 1, 2, 0), f(1, 3, 4, 1), f(0, 5, 6, 2), f(0, 9, 9, 4), f(1, 8, 8, 5)]);
        assert_eq!(out.iter().map(|x| x.frame.seq).collect::<Vec<_>>(), vec![0, 2]);
        assert_eq!(out[1].frame.values, vec![9.0, 9.0, 8.0, 8.0]);
        let st = d.stats();
        assert_eq!((st.incomplete.count, st.sets_dropped, st.carried.count), (1, 1, 0));
        let first = st.incomplete.first.unwrap();
        assert_eq!((first.id, first.time), (0x10, Timestamp(2_000_000)));
        assert!(first.detail.contains("new cycle"), "{}", first.detail);
    }

    #[test]
    fn carry_fills_from_last_values_and_flags_them() {
        let mut d = decoder(IncompletePolicy::Carry);
        // set 1: mux 1 lost; out-of-range 0 in set 2's taxel 0 → carried from set 1
        let out = d.clone_run(&[f(0, 1, 2, 0), f(1, 3, 4, 1), f(0, 5, 6, 2), f(0, 0, 7, 4), f(1, 8, 9, 5)]);
        assert_eq!(out.len(), 3);
        assert_eq!(out[1].frame.values, vec![5.0, 6.0, 3.0, 4.0]);
        assert_eq!(out[1].carried, vec![2, 3]);
        assert_eq!(out[2].frame.values, vec![5.0, 7.0, 8.0, 9.0]);
        assert_eq!(out[2].carried, vec![0]);
        let st = d.stats();
        assert_eq!((st.incomplete.count, st.sets_carried, st.carried.count, st.out_of_range.count), (2, 2, 3, 1));
    }

    #[test]
    fn carry_never_invents_a_first_value() {
        let mut d = decoder(IncompletePolicy::Carry);
        let out = d.clone_run(&[f(0, 1, 2, 0), f(0, 3, 4, 1)]);
        assert!(out.is_empty());
        assert_eq!(d.stats().sets_dropped, 2); // restart + end of stream
    }

    #[test]
    fn timeout_closes_a_set_and_faults_are_counted() {
        let mut d = decoder(IncompletePolicy::Drop);
        let bad_len = CanFrame::standard(0x10, &[0, 1], Timestamp(0)).unwrap();
        let unknown = CanFrame::standard(0x11, &[0, 1, 2], Timestamp(0)).unwrap();
        let out = d.clone_run(&[f(0, 1, 2, 0), bad_len, unknown, f(7, 0, 0, 1), f(9, 0, 0, 1), f(1, 3, 4, 20)]);
        // mux 1 arrives 20 ms after the set began (timeout 10 ms): the set times out first,
        // then mux 1 opens a new set that the end of the stream leaves incomplete
        assert!(out.is_empty());
        let st = d.stats();
        assert_eq!(st.frames, 6);
        assert_eq!((st.wrong_length.count, st.unknown_id.count, st.unknown_mux.count, st.frames_ignored), (1, 1, 1, 1));
        assert_eq!(st.incomplete.count, 2);
        assert!(st.incomplete.first.unwrap().detail.contains("timed out"));
        assert_eq!(d.next_deadline(), None);
    }

    #[test]
    fn advance_to_expires_open_sets() {
        let mut d = decoder(IncompletePolicy::Drop);
        let mut out = Vec::new();
        d.push_decoded(f(0, 1, 2, 0), &mut out);
        assert_eq!(d.next_deadline(), Some(Timestamp(10_000_000)));
        d.advance_to(Timestamp(10_000_000), &mut out);
        assert_eq!(d.stats().incomplete.count, 0);
        d.advance_to(Timestamp(10_000_001), &mut out);
        assert_eq!(d.stats().incomplete.count, 1);
    }

    #[test]
    fn stage_runs_and_reset_forgets() {
        let mut d = decoder(IncompletePolicy::Drop);
        let out = d.run_all([f(0, 1, 2, 0), f(1, 3, 4, 1)]).unwrap();
        assert_eq!(out[0].values, vec![1.0, 2.0, 3.0, 4.0]);
        // finish reset seq
        let out = d.run_all([f(0, 1, 2, 0), f(1, 3, 4, 1)]).unwrap();
        assert_eq!(out[0].seq, 0);
        let mut fl = decoder(IncompletePolicy::Drop).flagged();
        assert!(fl.run_all([f(0, 1, 2, 0), f(1, 3, 4, 1)]).unwrap()[0].is_complete());
    }
}
