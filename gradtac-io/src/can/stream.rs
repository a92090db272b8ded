//! The async shell around [`CanDecoder`]: [`CanStream`] turns any stream of CAN frames
//! (a live socket, a replayed log, the in-memory transport) into a stream of taxel frames,
//! optionally paced at the frames' original timing.

use crate::can::frame::CanFrame;
use crate::can::reassembly::{CanDecoder, DecodedFrame};
use crate::can::stats::{CanStats, StatsHandle};
use crate::{Error, Result};
use futures::Stream;
use gradtac_stream::{TaxelFrame, Timestamp};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::future::Future;
use std::pin::Pin;
use std::task::{Context, Poll};
use std::time::{Duration, SystemTime};
use tokio::time::{Instant, Sleep};

/// How a recorded stream is paced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Timing {
    /// As fast as the consumer takes frames (`"fast"`).
    #[default]
    #[serde(rename = "fast", alias = "as-fast-as-possible")]
    Fast,
    /// At the recorded spacing (`"original"`), divided by a speed factor: frame `k` leaves
    /// `(t_k − t_0) / speed` after the first one (tokio time, so tests can pause the clock).
    /// A frame stamped earlier than the one before it leaves at once.
    #[serde(rename = "original")]
    Original,
}

/// A stream of [`TaxelFrame`]s decoded from a stream of CAN frames.
///
/// - Items: `Ok(frame)` per completed (or carried) set; an `Err` of the frame stream is
///   yielded once and ends the stream (the decoder's open sets are not flushed then).
/// - At the end of the frame stream, open sets are closed by [`Stage::finish`](gradtac_stream::Stage::finish)
///   (incomplete, by policy).
/// - [`stats_handle`](Self::stats_handle) reads the fault counts while the stream runs.
#[must_use = "streams do nothing unless polled"]
#[derive(Debug)]
pub struct CanStream<S> {
    frames: S,
    decoder: CanDecoder,
    ready: VecDeque<DecodedFrame>,
    pace: Option<Pace>,
    pending: Option<CanFrame>,
    sleep: Option<Pin<Box<Sleep>>>,
    wall_expiry: bool,
    expiry: Option<Pin<Box<Sleep>>>,
    done: bool,
}

#[derive(Debug, Clone, Copy)]
struct Pace {
    speed: f64,
    origin: Option<(Timestamp, Instant)>,
}

/// Slowest replay speed of `timing = "original"`: 1/1000 of real time (a one-second log
/// replays in 17 minutes). `speed = 1e-9` used to be accepted and slept for days.
pub const MIN_REPLAY_SPEED: f64 = 1e-3;
/// Fastest replay speed of `timing = "original"`: 10⁶ × real time (beyond it the pacing is
/// below the timer's resolution; use `timing = "fast"`).
pub const MAX_REPLAY_SPEED: f64 = 1e6;

/// Check a replay `speed`: finite and within [`MIN_REPLAY_SPEED`] … [`MAX_REPLAY_SPEED`]
/// (NaN, infinities, zero, negative and subnormal values are refused); the message says the
/// range and the value in short form.
pub fn check_replay_speed(speed: f64) -> std::result::Result<(), String> {
    if speed.is_finite() && (MIN_REPLAY_SPEED..=MAX_REPLAY_SPEED).contains(&speed) {
        Ok(())
    } else {
        Err(format!(
            "speed = {} is outside {MIN_REPLAY_SPEED:e} … {MAX_REPLAY_SPEED:e} (a factor on the log's own pace: 2 replays \
             twice as fast)",
            gradtac_stream::num::Short(speed)
        ))
    }
}

impl<S> CanStream<S>
where
    S: Stream<Item = Result<CanFrame>> + Unpin,
{
    /// Decode `frames` with `decoder`, as fast as they come.
    pub fn new(frames: S, decoder: CanDecoder) -> Self {
        CanStream {
            frames,
            decoder,
            ready: VecDeque::new(),
            pace: None,
            pending: None,
            sleep: None,
            wall_expiry: false,
            expiry: None,
            done: false,
        }
    }

    /// Pace frames by their timestamps (see [`Timing`]); `speed` within
    /// [`MIN_REPLAY_SPEED`] … [`MAX_REPLAY_SPEED`] ([`check_replay_speed`]).
    pub fn with_timing(mut self, timing: Timing, speed: f64) -> Result<Self> {
        check_replay_speed(speed).map_err(Error::InvalidConfig)?;
        self.pace = match timing {
            Timing::Fast => None,
            Timing::Original => Some(Pace { speed, origin: None }),
        };
        Ok(self)
    }

    /// For live sources whose frames carry wall-clock (Unix epoch) times: while no frame
    /// arrives, close sets that time out by the system clock, instead of waiting for the next
    /// frame to notice.
    pub fn with_wall_clock_expiry(mut self) -> Self {
        self.wall_expiry = true;
        self
    }

    /// A shared handle on the decoder's counts.
    pub fn stats_handle(&self) -> StatsHandle {
        self.decoder.stats_handle()
    }

    /// The decoder's counts so far.
    pub fn stats(&self) -> CanStats {
        self.decoder.stats()
    }

    /// Yield [`DecodedFrame`]s (with carried-value flags) instead of `TaxelFrame`s.
    pub fn flagged(self) -> FlaggedCanStream<S> {
        FlaggedCanStream(self)
    }

    fn poll_decoded(&mut self, cx: &mut Context<'_>) -> Poll<Option<Result<DecodedFrame>>> {
        loop {
            if let Some(x) = self.ready.pop_front() {
                return Poll::Ready(Some(Ok(x)));
            }
            if self.done {
                return Poll::Ready(None);
            }
            if let Some(frame) = self.pending {
                if let Some(s) = self.sleep.as_mut() {
                    if s.as_mut().poll(cx).is_pending() {
                        return Poll::Pending;
                    }
                    self.sleep = None;
                }
                self.pending = None;
                self.push(frame);
                continue;
            }
            match Pin::new(&mut self.frames).poll_next(cx) {
                Poll::Ready(Some(Ok(frame))) => {
                    self.expiry = None;
                    if let Some(p) = self.pace.as_mut() {
                        let (t0, i0) = *p.origin.get_or_insert((frame.time(), Instant::now()));
                        let dt = frame.time().0.saturating_sub(t0.0).max(0) as f64 / p.speed;
                        // a gap beyond what an Instant can hold is shortened to 30 days
                        let gap = Duration::from_nanos(dt.min(u64::MAX as f64) as u64);
                        let due = i0.checked_add(gap).unwrap_or_else(|| i0 + Duration::from_secs(30 * 86_400));
                        if due > Instant::now() {
                            self.sleep = Some(Box::pin(tokio::time::sleep_until(due)));
                            self.pending = Some(frame);
                            continue;
                        }
                    }
                    self.push(frame);
                }
                Poll::Ready(Some(Err(e))) => {
                    self.done = true;
                    return Poll::Ready(Some(Err(e)));
                }
                Poll::Ready(None) => {
                    self.done = true;
                    let mut out = Vec::new();
                    self.decoder.finish_decoded(&mut out);
                    self.ready.extend(out);
                }
                Poll::Pending => {
                    if !self.wall_expiry {
                        return Poll::Pending;
                    }
                    let Some(deadline) = self.decoder.next_deadline() else {
                        self.expiry = None;
                        return Poll::Pending;
                    };
                    let now = wall_now();
                    let wait = (deadline - now).max(0) as u64 + 1;
                    let sl =
                        self.expiry.get_or_insert_with(|| Box::pin(tokio::time::sleep(Duration::from_nanos(wait))));
                    if sl.as_mut().poll(cx).is_pending() {
                        return Poll::Pending;
                    }
                    self.expiry = None;
                    let mut out = Vec::new();
                    self.decoder.advance_to(wall_now(), &mut out);
                    self.ready.extend(out);
                }
            }
        }
    }

    fn push(&mut self, frame: CanFrame) {
        let mut out = Vec::new();
        self.decoder.push_decoded(frame, &mut out);
        self.ready.extend(out);
    }
}

fn wall_now() -> Timestamp {
    let d = SystemTime::now().duration_since(SystemTime::UNIX_EPOCH).unwrap_or_default();
    Timestamp(d.as_nanos().min(i64::MAX as u128) as i64)
}

impl<S> Stream for CanStream<S>
where
    S: Stream<Item = Result<CanFrame>> + Unpin,
{
    type Item = Result<TaxelFrame>;

    fn poll_next(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Self::Item>> {
        self.poll_decoded(cx).map(|o| o.map(|r| r.map(|d| d.frame)))
    }
}

/// [`CanStream`] yielding [`DecodedFrame`]s; see [`CanStream::flagged`].
#[must_use = "streams do nothing unless polled"]
#[derive(Debug)]
pub struct FlaggedCanStream<S>(CanStream<S>);

impl<S> FlaggedCanStream<S> {
    /// A shared handle on the decoder's counts.
    pub fn stats_handle(&self) -> StatsHandle {
        self.0.decoder.stats_handle()
    }
}

impl<S> Stream for FlaggedCanStream<S>
where
    S: Stream<Item = Result<CanFrame>> + Unpin,
{
    type Item = Result<DecodedFrame>;

    fn poll_next(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Self::Item>> {
        self.0.poll_decoded(cx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::can::codec::{CanCodec, CodecConfig, IncompletePolicy, PresetConfig, PresetKind};
    use crate::can::transport::frame_channel;
    use futures::StreamExt;

    fn decoder() -> CanDecoder {
        let mut p = PresetConfig::new(PresetKind::BiotacMux, &["ff"]);
        p.timeout_ms = 20.0;
        p.incomplete = IncompletePolicy::Carry;
        CanDecoder::new(CanCodec::try_new(&CodecConfig::preset(p)).unwrap())
    }

    fn mux_frame(m: u8, t: Timestamp) -> CanFrame {
        CanFrame::standard(0x100, &[m, 0x40, 0x04, 0x00, 0x40, 0x04, 0x00, 0], t).unwrap()
    }

    async fn feed_partial() -> (crate::can::transport::FrameSender, crate::can::transport::FrameReceiver) {
        let (tx, rx) = frame_channel(16);
        let now = wall_now();
        for m in 0..6 {
            tx.send(mux_frame(m, now)).await.unwrap();
        }
        for m in 0..3 {
            tx.send(mux_frame(m, now + 1)).await.unwrap();
        }
        (tx, rx)
    }

    #[tokio::test]
    async fn wall_clock_expiry_closes_sets_while_the_bus_is_quiet() {
        // bounded: a regression must fail, not hang the suite
        tokio::time::timeout(Duration::from_secs(30), async {
            let (tx, rx) = feed_partial().await;
            let mut s = CanStream::new(rx, decoder()).with_wall_clock_expiry().flagged();
            let first = s.next().await.unwrap().unwrap();
            assert!(first.is_complete());
            // the sender stays open and silent: only the system clock can close the second set
            let second = tokio::time::timeout(Duration::from_secs(5), s.next()).await.expect("expired by the clock");
            let second = second.unwrap().unwrap();
            assert_eq!(second.carried, (12..24).collect::<Vec<u32>>());
            assert_eq!(s.stats_handle().snapshot().incomplete.count, 1);
            drop(tx);
            assert!(s.next().await.is_none());
        })
        .await
        .expect("test timed out");
    }

    #[tokio::test]
    async fn without_wall_clock_expiry_a_quiet_bus_waits_for_frames() {
        // bounded: a regression must fail, not hang the suite
        tokio::time::timeout(Duration::from_secs(30), async {
            let (tx, rx) = feed_partial().await;
            let mut s = CanStream::new(rx, decoder());
            assert!(s.next().await.unwrap().is_ok());
            assert!(tokio::time::timeout(Duration::from_millis(60), s.next()).await.is_err());
            drop(tx); // end of stream: finish() carries the open set
            assert_eq!(s.next().await.unwrap().unwrap().values.len(), 24);
            assert_eq!(s.stats().sets_carried, 1);
        })
        .await
        .expect("test timed out");
    }

    #[tokio::test]
    async fn original_timing_spaces_frames_out() {
        // bounded: a regression must fail, not hang the suite
        tokio::time::timeout(Duration::from_secs(30), async {
            let (tx, rx) = frame_channel(32); // holds all 18 frames: no consumer runs yet
            for k in 0..3i64 {
                for m in 0..6 {
                    tx.send(mux_frame(m, Timestamp(k * 40_000_000 + i64::from(m)))).await.unwrap();
                }
            }
            drop(tx);
            let start = tokio::time::Instant::now();
            let s = CanStream::new(rx, decoder()).with_timing(Timing::Original, 2.0).unwrap();
            let got: Vec<TaxelFrame> = s.map(|r| r.unwrap()).collect().await;
            assert_eq!(got.len(), 3);
            // 80 ms of recording at 2× speed: at least 40 ms
            assert!(start.elapsed() >= Duration::from_millis(40), "{:?}", start.elapsed());
        })
        .await
        .expect("test timed out");
    }
}
