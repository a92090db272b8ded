//! Window: aggregate events per taxel over time (method.md, stage 4).
//!
//! # What it does
//! Consumes one [`EventBatch`] per input frame (possibly empty) and sums the events of each
//! taxel over a window of time, emitting [`WindowAggregate`]s:
//!
//! - **tumbling** — consecutive, non-overlapping windows. By frame count: every `frames` input
//!   frames one aggregate of those frames' events. By duration: windows `[k·D, (k+1)·D)` of
//!   event time, aligned to the epoch (so sensors sharing an epoch share windows); window `k` is
//!   emitted when the first frame or event at or after `(k+1)·D` arrives (a frame's batch may
//!   still hold events of window `k`). Windows holding neither a frame nor an event are
//!   skipped; a window holding events but no frame (a duration shorter than the frame
//!   interval) is emitted with `frames = 0`. An event older than the open window (not produced
//!   by the events stage, which stamps events inside their frame interval) is counted in the
//!   open window.
//! - **sliding** — after every `step`-th frame, the events of the last `frames` frames, or of
//!   event time `(t − D, t]` where `t` is the newest frame's time.
//! - **decaying** — an exponentially weighted sum emitted after every `step`-th frame: an event
//!   of age `a` weighs `exp(−a/τ)`. By frames, age counts frames (the newest frame's events
//!   weigh 1, the previous frame's `exp(−1/τ)`, …); by duration, age is `t − t_event` in time.
//!
//! - **cumulative** — the sum of every event since the stream began (or the last
//!   [`reset`](Stage::reset)), emitted after every `step`-th frame: a window as long as the
//!   contact, whatever its time scale. With the events stage's
//!   [`Polarity::PressRelease`](crate::events::Polarity::PressRelease) the signed sum of a taxel
//!   is its distance from its baseline in thresholds (`|ln y − ln y₀|/τ`, to within one), so
//!   the aggregate is the contact's change field *now*, flipped electrodes included; with
//!   [`Polarity::Both`](crate::events::Polarity::Both) it is the signed level `(ln y − ln y₀)/τ`.
//!   Being a level rather than a sum over a span, it is stamped as a state of the newest
//!   frame: `start = end` = that frame's time (`frames` still counts the frames since the
//!   start). Only `signed` and `split` aggregates (a cumulative count only grows); no size.
//!   The stage's default kind is `sliding` (the paper's); a scene's event chain defaults to
//!   `cumulative` with press/release events unless its window is given a size or a kind
//!   ([`EventChain`](crate::locate::EventChain)).
//!
//! Per-taxel aggregate ([`Aggregate`]): `signed` (Σ polarity), `count` (number of events), or
//! `split` (positive and negative counts separately, [`WindowAggregate::split`]; `values` then
//! holds the signed sum).
//!
//! # Units
//! Aggregates in events (weighted events for `decaying`); spans in ns ([`Timestamp`]).
//! Sizes: `frames` in input frames, `duration_ms` in milliseconds.
//!
//! # Delay
//! - tumbling by `frames = N`: `N − 1` frames (the first frame of a window waits for the last);
//! - tumbling by duration `D`: `D` (plus up to one frame interval until the closing frame);
//! - sliding and decaying: 0 — every output includes the newest frame; the window's *centre*
//!   lags by half its length (the responsiveness cost of noise robustness);
//! - cumulative: 0 — the level after the newest frame.
//!
//! # Trade-offs
//! | choice | responsiveness | noise robustness | output rate |
//! |---|---|---|---|
//! | short window | high | low | — |
//! | long window | low (smears a moving contact) | high | — |
//! | tumbling | one output per window | — | input rate / N |
//! | sliding | newest frame always in | — | input rate / `step` |
//! | decaying | smooth, no edge effect when events leave | — | input rate / `step`; floating-point sums |
//! | cumulative | the level now (with press/release events: the change field) | no forgetting: drift and a wrong baseline stay | input rate / `step` |
//!
//! Sliding and tumbling sums are kept as exact integer counts (no drift over long streams);
//! decaying sums are `f64`.

use crate::{Error, EventBatch, Result, TactileEvent};
use gradtac_stream::{Delay, HasSensor, SensorId, Stage, Timed, Timestamp};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

const STAGE: &str = "window";

/// The kind of window.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum WindowKind {
    /// Non-overlapping consecutive windows.
    Tumbling,
    /// The last `frames` frames / the last `duration_ms`, advanced every `step` frames.
    #[default]
    Sliding,
    /// Exponentially decaying sum with time constant `frames` / `duration_ms`.
    Decaying,
    /// The sum since the stream began or the last reset (no size), advanced every `step`
    /// frames: with press/release events, each taxel's distance from its baseline.
    Cumulative,
}

/// The per-taxel aggregate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Aggregate {
    /// Σ polarity (events up minus events down).
    #[default]
    Signed,
    /// Number of events regardless of polarity.
    Count,
    /// Positive and negative counts separately; `values` holds the signed sum.
    Split,
}

/// Configuration of the [`Window`] stage (`[stages.window]` in a scene). Give exactly one of
/// `frames` and `duration_ms`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WindowConfig {
    /// Tumbling, sliding, decaying or cumulative. Default `sliding`.
    pub kind: WindowKind,
    /// Window length (tumbling, sliding) or decay time constant τ (decaying) in input frames.
    /// Default 10 (100 ms at the BioTac's 100 Hz) when `duration_ms` is not given.
    pub frames: Option<u64>,
    /// Window length or decay time constant in milliseconds (> 0).
    pub duration_ms: Option<f64>,
    /// Sliding and decaying: emit after every `step`-th frame (≥ 1). Default 1.
    pub step: u64,
    /// The per-taxel aggregate. Default `signed`.
    pub aggregate: Aggregate,
}

impl Default for WindowConfig {
    fn default() -> Self {
        WindowConfig {
            kind: WindowKind::Sliding,
            frames: None,
            duration_ms: None,
            step: 1,
            aggregate: Aggregate::Signed,
        }
    }
}

/// Positive and negative event counts per taxel (for [`Aggregate::Split`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Split {
    /// Events of polarity +1 per taxel.
    pub positive: Vec<f64>,
    /// Events of polarity −1 per taxel (as a non-negative count).
    pub negative: Vec<f64>,
}

/// The aggregate of one window of one sensor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WindowAggregate {
    /// The sensor.
    pub sensor: SensorId,
    /// Start of the span. By frames: the time of the oldest frame in the window; by duration:
    /// the window's start (`k·D` tumbling, `t − D` sliding, exclusive). Decaying: the time of
    /// the first frame since the last reset.
    pub start: Timestamp,
    /// End of the span: the newest frame's time (tumbling by duration: `(k+1)·D`, exclusive).
    pub end: Timestamp,
    /// Index of the newest frame in the window.
    pub seq: u64,
    /// Number of input frames the window covers.
    pub frames: u64,
    /// Which aggregate `values` holds.
    pub aggregate: Aggregate,
    /// One value per taxel (events; weighted events when decaying).
    pub values: Vec<f64>,
    /// Positive / negative counts, for [`Aggregate::Split`] only.
    pub split: Option<Split>,
}

impl Timed for WindowAggregate {
    fn time(&self) -> Timestamp {
        self.end
    }
}

impl HasSensor for WindowAggregate {
    fn sensor(&self) -> &SensorId {
        &self.sensor
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Size {
    Frames(u64),
    Nanos(i64),
}

#[derive(Clone, Debug)]
struct FrameRec {
    time: Timestamp,
    seq: u64,
    events: Vec<TactileEvent>,
}

/// The window stage (see the [module docs](self)). One instance per sensor; wrap it in
/// [`Keyed`](gradtac_stream::Keyed) for several.
#[derive(Clone, Debug)]
#[must_use = "a stage does nothing until inputs are pushed"]
pub struct Window {
    kind: WindowKind,
    size: Size,
    step: u64,
    aggregate: Aggregate,
    // state
    sensor: Option<SensorId>,
    taxels: usize,
    last: Option<(Timestamp, u64)>,
    pos: Vec<i64>,
    neg: Vec<i64>,
    dpos: Vec<f64>,
    dneg: Vec<f64>,
    frames: VecDeque<FrameRec>,
    events: VecDeque<TactileEvent>,
    n_frames: u64,
    since_emit: u64,
    first_time: Option<Timestamp>,
    tumble_k: Option<i64>,
}

impl Window {
    /// A window from its configuration; refuses a zero or non-finite size, both or neither of
    /// `frames`/`duration_ms` given explicitly with conflicting values, and `step = 0`.
    pub fn try_new(cfg: &WindowConfig) -> Result<Self> {
        let bad = |reason: String| Err(Error::InvalidConfig { stage: STAGE, reason });
        let size = match (cfg.frames, cfg.duration_ms) {
            (Some(_), Some(_)) => return bad("give either `frames` or `duration_ms`, not both".into()),
            (None, None) => Size::Frames(10),
            (Some(0), None) => return bad("`frames` must be ≥ 1".into()),
            (Some(n), None) if n > crate::limits::MAX_WINDOW_FRAMES => {
                return bad(format!("`frames` = {n} exceeds the maximum of {}", crate::limits::MAX_WINDOW_FRAMES))
            }
            (Some(n), None) => Size::Frames(n),
            (None, Some(ms)) if ms > crate::limits::MAX_WINDOW_MS => {
                return bad(format!(
                    "`duration_ms` = {ms} exceeds the maximum of {:e} ms",
                    crate::limits::MAX_WINDOW_MS
                ))
            }
            (None, Some(ms)) => {
                let ns = (ms * 1e6).round();
                if !(ms.is_finite() && (1.0..9.2e18).contains(&ns)) {
                    return bad(format!("`duration_ms` = {ms} must be a positive duration of at least 1 ns"));
                }
                Size::Nanos(ns as i64)
            }
        };
        if cfg.step == 0 {
            return bad("`step` must be ≥ 1".into());
        }
        crate::limits::check_count(STAGE, "step", cfg.step, crate::limits::MAX_WINDOW_FRAMES)?;
        if cfg.kind == WindowKind::Tumbling && cfg.step != 1 {
            return bad("`step` applies to sliding, decaying and cumulative windows only".into());
        }
        if cfg.kind == WindowKind::Cumulative {
            if cfg.frames.is_some() || cfg.duration_ms.is_some() {
                return bad(
                    "a cumulative window sums everything since the start: give no `frames` or `duration_ms`".into()
                );
            }
            if cfg.aggregate == Aggregate::Count {
                return bad(
                    "a cumulative window takes `aggregate = \"signed\"` or `\"split\"` (a cumulative count only grows)"
                        .into(),
                );
            }
        }
        Ok(Window {
            kind: cfg.kind,
            size,
            step: cfg.step,
            aggregate: cfg.aggregate,
            sensor: None,
            taxels: 0,
            last: None,
            pos: Vec::new(),
            neg: Vec::new(),
            dpos: Vec::new(),
            dneg: Vec::new(),
            frames: VecDeque::new(),
            events: VecDeque::new(),
            n_frames: 0,
            since_emit: 0,
            first_time: None,
            tumble_k: None,
        })
    }

    fn check(&mut self, b: &EventBatch) -> Result<()> {
        let bad = |reason: String| Error::BadInput { stage: STAGE, sensor: b.sensor.to_string(), seq: b.seq, reason };
        match &self.sensor {
            None => {
                self.sensor = Some(b.sensor.clone());
                self.taxels = b.taxels as usize;
                self.pos = vec![0; self.taxels];
                self.neg = vec![0; self.taxels];
                self.dpos = vec![0.0; self.taxels];
                self.dneg = vec![0.0; self.taxels];
            }
            Some(s) if *s != b.sensor => {
                return Err(bad(format!("batch of sensor {} in the window of sensor {s} (use Keyed)", b.sensor)))
            }
            Some(_) if b.taxels as usize != self.taxels => {
                return Err(Error::TaxelCount {
                    stage: STAGE,
                    sensor: b.sensor.to_string(),
                    seq: b.seq,
                    expected: self.taxels,
                    got: b.taxels as usize,
                })
            }
            Some(_) => {}
        }
        if let Some((t, seq)) = self.last {
            if b.time < t {
                return Err(bad(format!("frame time {:?} is before the previous frame's {t:?} (frame {seq})", b.time)));
            }
        }
        let mut prev = Timestamp(i64::MIN);
        for e in &b.events {
            if e.taxel as usize >= self.taxels {
                return Err(Error::BadValue {
                    stage: STAGE,
                    sensor: b.sensor.to_string(),
                    seq: b.seq,
                    taxel: e.taxel as usize,
                    value: e.taxel as f64,
                    reason: "taxel index beyond the batch's taxel count",
                });
            }
            if e.polarity != 1 && e.polarity != -1 {
                return Err(Error::BadValue {
                    stage: STAGE,
                    sensor: b.sensor.to_string(),
                    seq: b.seq,
                    taxel: e.taxel as usize,
                    value: e.polarity as f64,
                    reason: "polarity must be +1 or -1",
                });
            }
            if e.time < prev {
                return Err(bad("events of the batch are not in time order".into()));
            }
            if e.time > b.time {
                return Err(bad(format!("event at {:?} is after its frame's time {:?}", e.time, b.time)));
            }
            prev = e.time;
        }
        Ok(())
    }

    fn add(&mut self, e: &TactileEvent, sign: i64) {
        let k = e.taxel as usize;
        if e.polarity > 0 {
            self.pos[k] += sign;
        } else {
            self.neg[k] += sign;
        }
    }

    fn emit_counts(&self, start: Timestamp, end: Timestamp, seq: u64, frames: u64, out: &mut Vec<WindowAggregate>) {
        let p: Vec<f64> = self.pos.iter().map(|&x| x as f64).collect();
        let n: Vec<f64> = self.neg.iter().map(|&x| x as f64).collect();
        out.push(self.aggregate_of(start, end, seq, frames, p, n));
    }

    fn aggregate_of(
        &self,
        start: Timestamp,
        end: Timestamp,
        seq: u64,
        frames: u64,
        p: Vec<f64>,
        n: Vec<f64>,
    ) -> WindowAggregate {
        let (values, split) = match self.aggregate {
            Aggregate::Signed => (p.iter().zip(&n).map(|(a, b)| a - b).collect(), None),
            Aggregate::Count => (p.iter().zip(&n).map(|(a, b)| a + b).collect(), None),
            Aggregate::Split => {
                (p.iter().zip(&n).map(|(a, b)| a - b).collect(), Some(Split { positive: p, negative: n }))
            }
        };
        WindowAggregate {
            sensor: self.sensor.clone().expect("set by the first batch"),
            start,
            end,
            seq,
            frames,
            aggregate: self.aggregate,
            values,
            split,
        }
    }

    /// Emit the open duration window (it holds frames, events or both) and clear it.
    fn close_tumbling(&mut self, d: i64, seq_now: u64, out: &mut Vec<WindowAggregate>) {
        let k = self.tumble_k.expect("a window is open");
        let seq = self.frames.back().map_or(seq_now, |f| f.seq);
        self.emit_counts(Timestamp(k.saturating_mul(d)), Timestamp((k + 1).saturating_mul(d)), seq, self.n_frames, out);
        self.clear_counts();
        self.frames.clear();
        self.n_frames = 0;
    }

    fn clear_counts(&mut self) {
        self.pos.iter_mut().for_each(|x| *x = 0);
        self.neg.iter_mut().for_each(|x| *x = 0);
    }
}

impl Stage for Window {
    type In = EventBatch;
    type Out = WindowAggregate;
    type Error = Error;

    fn push(&mut self, b: EventBatch, out: &mut Vec<WindowAggregate>) -> Result<()> {
        self.check(&b)?;
        let first_time = *self.first_time.get_or_insert(b.time);
        self.last = Some((b.time, b.seq));
        match (self.kind, self.size) {
            (WindowKind::Tumbling, Size::Frames(n)) => {
                for e in &b.events {
                    self.add(e, 1);
                }
                if self.frames.is_empty() {
                    self.frames.push_back(FrameRec { time: b.time, seq: b.seq, events: Vec::new() });
                }
                self.n_frames += 1;
                if self.n_frames == n {
                    let start = self.frames[0].time;
                    self.emit_counts(start, b.time, b.seq, n, out);
                    self.clear_counts();
                    self.frames.clear();
                    self.n_frames = 0;
                }
            }
            (WindowKind::Tumbling, Size::Nanos(d)) => {
                let k_of = |t: Timestamp| t.as_nanos().div_euclid(d);
                let kb = k_of(b.time);
                for e in &b.events {
                    let ke = k_of(e.time);
                    let cur = *self.tumble_k.get_or_insert(ke);
                    if ke > cur {
                        self.close_tumbling(d, b.seq, out);
                        self.tumble_k = Some(ke);
                    }
                    // an event older than the open window (late) is counted in it
                    self.add(e, 1);
                }
                let cur = *self.tumble_k.get_or_insert(kb);
                if kb > cur {
                    self.close_tumbling(d, b.seq, out);
                    self.tumble_k = Some(kb);
                }
                self.frames.clear();
                self.frames.push_back(FrameRec { time: b.time, seq: b.seq, events: Vec::new() });
                self.n_frames += 1;
            }
            (WindowKind::Sliding, Size::Frames(n)) => {
                for e in &b.events {
                    self.add(e, 1);
                }
                self.frames.push_back(FrameRec { time: b.time, seq: b.seq, events: b.events });
                if self.frames.len() as u64 > n {
                    let old = self.frames.pop_front().expect("non-empty");
                    for e in &old.events {
                        self.add(e, -1);
                    }
                }
                self.since_emit += 1;
                if self.since_emit >= self.step {
                    self.since_emit = 0;
                    let start = self.frames[0].time;
                    self.emit_counts(start, b.time, b.seq, self.frames.len() as u64, out);
                }
            }
            (WindowKind::Sliding, Size::Nanos(d)) => {
                for e in &b.events {
                    self.add(e, 1);
                    self.events.push_back(*e);
                }
                let cut = Timestamp(b.time.as_nanos().saturating_sub(d));
                while self.events.front().is_some_and(|e| e.time <= cut) {
                    let e = self.events.pop_front().expect("non-empty");
                    self.add(&e, -1);
                }
                self.frames.push_back(FrameRec { time: b.time, seq: b.seq, events: Vec::new() });
                while self.frames.front().is_some_and(|f| f.time <= cut) {
                    self.frames.pop_front();
                }
                self.since_emit += 1;
                if self.since_emit >= self.step {
                    self.since_emit = 0;
                    self.emit_counts(cut, b.time, b.seq, self.frames.len() as u64, out);
                }
            }
            (WindowKind::Cumulative, _) => {
                for e in &b.events {
                    self.add(e, 1);
                }
                self.n_frames += 1;
                self.since_emit += 1;
                if self.since_emit >= self.step {
                    self.since_emit = 0;
                    // a level, stamped as the state of the newest frame
                    self.emit_counts(b.time, b.time, b.seq, self.n_frames, out);
                }
            }
            (WindowKind::Decaying, size) => {
                // decay of what was held since the previous frame; `tau_ns` = None: by frames
                let (decay, tau_ns) = match size {
                    Size::Frames(tau) => (if self.n_frames == 0 { 0.0 } else { (-1.0 / tau as f64).exp() }, None),
                    Size::Nanos(tau) => {
                        let dt = self.frames.back().map_or(0, |f| b.time - f.time) as f64;
                        (if self.n_frames == 0 { 0.0 } else { (-dt / tau as f64).exp() }, Some(tau as f64))
                    }
                };
                for (p, n) in self.dpos.iter_mut().zip(self.dneg.iter_mut()) {
                    *p *= decay;
                    *n *= decay;
                }
                for e in &b.events {
                    let w = tau_ns.map_or(1.0, |tau| (-((b.time - e.time) as f64) / tau).exp());
                    if e.polarity > 0 {
                        self.dpos[e.taxel as usize] += w;
                    } else {
                        self.dneg[e.taxel as usize] += w;
                    }
                }
                self.frames.clear();
                self.frames.push_back(FrameRec { time: b.time, seq: b.seq, events: Vec::new() });
                self.n_frames += 1;
                self.since_emit += 1;
                if self.since_emit >= self.step {
                    self.since_emit = 0;
                    let agg = self.aggregate_of(
                        first_time,
                        b.time,
                        b.seq,
                        self.n_frames,
                        self.dpos.clone(),
                        self.dneg.clone(),
                    );
                    out.push(agg);
                }
            }
        }
        Ok(())
    }

    /// Tumbling windows emit their last, partial window (its `frames` tells how full it is);
    /// sliding and decaying windows have already emitted everything.
    fn finish(&mut self, out: &mut Vec<WindowAggregate>) -> Result<()> {
        if self.kind == WindowKind::Tumbling && self.n_frames > 0 {
            if let (Some(f), Some((t, seq))) = (self.frames.front(), self.last) {
                match self.size {
                    Size::Frames(_) => self.emit_counts(f.time, t, seq, self.n_frames, out),
                    Size::Nanos(d) => {
                        let k = self.tumble_k.expect("set with the first frame");
                        self.emit_counts(
                            Timestamp(k.saturating_mul(d)),
                            Timestamp((k + 1).saturating_mul(d)),
                            seq,
                            self.n_frames,
                            out,
                        )
                    }
                }
            }
        }
        self.reset();
        Ok(())
    }

    fn reset(&mut self) {
        self.sensor = None;
        self.taxels = 0;
        self.last = None;
        self.pos.clear();
        self.neg.clear();
        self.dpos.clear();
        self.dneg.clear();
        self.frames.clear();
        self.events.clear();
        self.n_frames = 0;
        self.since_emit = 0;
        self.first_time = None;
        self.tumble_k = None;
    }

    fn delay(&self) -> Delay {
        match (self.kind, self.size) {
            (WindowKind::Tumbling, Size::Frames(n)) => Delay::frames(n - 1),
            (WindowKind::Tumbling, Size::Nanos(d)) => Delay::nanos(d),
            _ => Delay::ZERO,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gradtac_stream::StageExt;

    fn ev(t: i64, taxel: u16, polarity: i8) -> TactileEvent {
        TactileEvent { time: Timestamp(t), taxel, polarity }
    }
    fn batch(seq: u64, t: i64, events: Vec<TactileEvent>) -> EventBatch {
        EventBatch { sensor: "ff".into(), time: Timestamp(t), seq, taxels: 3, events }
    }

    #[test]
    fn cumulative_sums_since_the_start_as_a_state_of_the_newest_frame() {
        let cfg = WindowConfig { kind: WindowKind::Cumulative, ..Default::default() };
        let mut w = Window::try_new(&cfg).unwrap();
        let out = w
            .run_all([
                batch(0, 10, vec![ev(5, 0, 1), ev(6, 1, -1)]),
                batch(1, 20, vec![ev(15, 0, 1)]),
                batch(2, 30, vec![]),
                batch(3, 40, vec![ev(35, 0, -1), ev(36, 2, 1)]),
            ])
            .unwrap();
        let values: Vec<Vec<f64>> = out.iter().map(|a| a.values.clone()).collect();
        assert_eq!(
            values,
            vec![vec![1.0, -1.0, 0.0], vec![2.0, -1.0, 0.0], vec![2.0, -1.0, 0.0], vec![1.0, -1.0, 1.0]]
        );
        assert_eq!((out[3].start, out[3].end, out[3].seq, out[3].frames), (Timestamp(40), Timestamp(40), 3, 4));
        assert_eq!(w.delay(), Delay::ZERO);
        // step 2: every other frame; a reset starts the sum again
        let cfg =
            WindowConfig { kind: WindowKind::Cumulative, step: 2, aggregate: Aggregate::Split, ..Default::default() };
        let mut w = Window::try_new(&cfg).unwrap();
        let out = w.run_all([batch(0, 10, vec![ev(5, 0, 1)]), batch(1, 20, vec![ev(15, 0, -1)])]).unwrap();
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].split.as_ref().unwrap().positive, vec![1.0, 0.0, 0.0]);
        let out = w.run_all([batch(0, 10, vec![]), batch(1, 20, vec![])]).unwrap();
        assert_eq!(out[0].values, vec![0.0; 3]);
        // no size, no count
        for bad in [
            WindowConfig { kind: WindowKind::Cumulative, frames: Some(5), ..Default::default() },
            WindowConfig { kind: WindowKind::Cumulative, duration_ms: Some(50.0), ..Default::default() },
            WindowConfig { kind: WindowKind::Cumulative, aggregate: Aggregate::Count, ..Default::default() },
        ] {
            assert!(Window::try_new(&bad).is_err(), "{bad:?}");
        }
    }

    /// The case: a press on the BioTac SP layout with flipped electrodes (every third
    /// electrode reads the other way, its value rising under pressure), then the release.
    /// Under `press_release` events a cumulative signed window's maximal contour lies at the
    /// press while pressed and there is no contact after the release; `both` events' signed
    /// levels put the peak on a flipped electrode instead.
    #[test]
    fn press_release_cumulative_finds_the_press_through_flipped_electrodes() {
        use crate::contour::{Contour, ContourConfig, ContourOutcome};
        use crate::events::{Events, EventsConfig, Polarity, Threshold};
        use crate::interpolate::{Interpolate, InterpolateConfig};
        use gradtac_stream::{Layout, TaxelFrame};
        let layout = Layout::biotac_sp();
        let press = [1.0, -2.0];
        let depth = [0.0, 0.0, 0.3, 0.7, 1.0, 1.0, 1.0, 0.6, 0.2, 0.0, 0.0, 0.0];
        let frames: Vec<TaxelFrame> = depth
            .iter()
            .enumerate()
            .map(|(k, d)| {
                let values = layout
                    .positions()
                    .iter()
                    .enumerate()
                    .map(|(i, p)| {
                        let r2 = (p[0] - press[0]).powi(2) + (p[1] - press[1]).powi(2);
                        let sign = if i % 3 == 0 { 1.0 } else { -1.0 };
                        2500.0 + sign * 400.0 * d * (-r2 / (2.0 * 4.0 * 4.0)).exp()
                    })
                    .collect();
                TaxelFrame::new("ff".into(), Timestamp(k as i64 * 10_000_000), k as u64, values)
            })
            .collect();
        let contours = |p: Polarity| {
            let c = EventsConfig { threshold: Threshold::Uniform(0.004), polarity: p, ..Default::default() };
            let b = Events::try_new(layout.len(), c).unwrap().run_all(frames.clone()).unwrap();
            let cfg = WindowConfig { kind: WindowKind::Cumulative, ..Default::default() };
            let cc = ContourConfig { min_peak: 2.0, min_area_mm2: 60.0, ..Default::default() };
            Window::try_new(&cfg)
                .unwrap()
                .then(Interpolate::try_new(&InterpolateConfig::default(), &layout).unwrap())
                .then(Contour::try_new(&cc).unwrap())
                .run_all(b)
                .unwrap()
        };
        let at = |o: &ContourOutcome| match o {
            ContourOutcome::Contact(c) => Some(c.centroid_mm),
            _ => None,
        };
        let pr = contours(Polarity::PressRelease);
        for f in &pr[4..7] {
            let c = at(&f.outcome).expect("a contact while pressed");
            let e = (c[0] - press[0]).hypot(c[1] - press[1]);
            assert!(e < 1.5, "press_release contour at {c:?}, {e:.2} mm from the press");
        }
        // released: every taxel back at its baseline, no contact
        assert!(at(&pr[11].outcome).is_none(), "{:?}", pr[11].outcome);
        let both = contours(Polarity::Both);
        let c = at(&both[5].outcome).expect("both: the flipped electrodes' rise is a peak");
        let e = (c[0] - press[0]).hypot(c[1] - press[1]);
        let e_pr = at(&pr[5].outcome).map(|c| (c[0] - press[0]).hypot(c[1] - press[1])).unwrap();
        assert!(e > 2.0 * e_pr, "both: {e:.2} mm, press_release {e_pr:.2} mm");
    }

    #[test]
    fn sliding_by_frames_drops_old_frames() {
        let cfg = WindowConfig { frames: Some(2), ..Default::default() };
        let mut w = Window::try_new(&cfg).unwrap();
        let out = w
            .run_all([
                batch(0, 10, vec![ev(5, 0, 1), ev(6, 1, -1)]),
                batch(1, 20, vec![ev(15, 0, 1)]),
                batch(2, 30, vec![]),
            ])
            .unwrap();
        assert_eq!(out.len(), 3);
        assert_eq!(out[0].values, vec![1.0, -1.0, 0.0]);
        assert_eq!(out[1].values, vec![2.0, -1.0, 0.0]);
        assert_eq!(out[2].values, vec![1.0, 0.0, 0.0]);
        assert_eq!((out[2].start, out[2].end, out[2].seq, out[2].frames), (Timestamp(20), Timestamp(30), 2, 2));
    }

    #[test]
    fn tumbling_by_duration_assigns_events_by_their_time() {
        let cfg = WindowConfig { kind: WindowKind::Tumbling, duration_ms: Some(1e-5), ..Default::default() }; // 10 ns
        let mut w = Window::try_new(&cfg).unwrap();
        assert_eq!(w.delay(), Delay::nanos(10));
        let out = w
            .run_all([
                batch(0, 4, vec![ev(3, 0, 1)]),
                batch(1, 8, vec![ev(7, 1, 1)]),
                // frame at 12 closes [0,10): its event at 9 belongs to it, the one at 11 to [10,20)
                batch(2, 12, vec![ev(9, 2, -1), ev(11, 2, 1)]),
                batch(3, 35, vec![ev(30, 1, -1)]),
            ])
            .unwrap();
        assert_eq!(out.len(), 3, "{out:?}");
        assert_eq!(out[0].values, vec![1.0, 1.0, -1.0]);
        assert_eq!((out[0].start, out[0].end, out[0].frames, out[0].seq), (Timestamp(0), Timestamp(10), 2, 1));
        assert_eq!(out[1].values, vec![0.0, 0.0, 1.0]);
        assert_eq!(out[2].values, vec![0.0, -1.0, 0.0]); // partial window flushed by finish
        assert_eq!((out[2].start, out[2].end), (Timestamp(30), Timestamp(40)));
    }

    #[test]
    fn split_and_count() {
        for (agg, want) in [(Aggregate::Count, vec![3.0, 0.0, 0.0]), (Aggregate::Split, vec![1.0, 0.0, 0.0])] {
            let cfg = WindowConfig { frames: Some(5), aggregate: agg, ..Default::default() };
            let mut w = Window::try_new(&cfg).unwrap();
            let out = w.run_all([batch(0, 10, vec![ev(1, 0, 1), ev(2, 0, 1), ev(3, 0, -1)])]).unwrap();
            assert_eq!(out[0].values, want);
            if agg == Aggregate::Split {
                let s = out[0].split.as_ref().unwrap();
                assert_eq!((s.positive[0], s.negative[0]), (2.0, 1.0));
            }
        }
    }

    #[test]
    fn decaying_by_frames_weighs_age() {
        let cfg = WindowConfig { kind: WindowKind::Decaying, frames: Some(2), ..Default::default() };
        let mut w = Window::try_new(&cfg).unwrap();
        let out = w.run_all([batch(0, 10, vec![ev(5, 0, 1)]), batch(1, 20, vec![]), batch(2, 30, vec![])]).unwrap();
        assert_eq!(out[0].values[0], 1.0);
        assert!((out[2].values[0] - (-1.0f64).exp()).abs() < 1e-15);
    }

    #[test]
    fn bad_input_is_an_error_naming_the_frame() {
        let mut w = Window::try_new(&WindowConfig::default()).unwrap();
        let mut out = Vec::new();
        w.push(batch(0, 10, vec![]), &mut out).unwrap();
        let e = w.push(batch(1, 20, vec![ev(15, 3, 1)]), &mut out).unwrap_err();
        assert!(e.to_string().contains("frame 1 taxel 3"), "{e}");
        let e = w.push(batch(2, 5, vec![]), &mut out).unwrap_err();
        assert!(e.to_string().contains("before the previous"), "{e}");
        assert!(Window::try_new(&WindowConfig { frames: Some(0), ..Default::default() }).is_err());
        assert!(
            Window::try_new(&WindowConfig { frames: Some(3), duration_ms: Some(1.0), ..Default::default() }).is_err()
        );
        assert!(Window::try_new(&WindowConfig { duration_ms: Some(f64::NAN), ..Default::default() }).is_err());
    }
}
