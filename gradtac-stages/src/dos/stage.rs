//! [`DosClassifier`]: the `dos` stage, raw frames in, [`DosDecision`]s out.

use super::window::LogVote;
use super::*;

/// One slip-direction decision of the [`DosClassifier`] stage.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DosDecision {
    /// The sensor.
    pub sensor: SensorId,
    /// Time of the span's first frame.
    pub start: Timestamp,
    /// Time of its last frame.
    pub end: Timestamp,
    /// Index of the last frame.
    pub seq: u64,
    /// Frames in the span.
    pub frames: u64,
    /// The decision.
    pub decision: Decision,
    /// The span's features (all of them, [`Feature::ALL`] order).
    pub features: FeatureVector,
}

impl Timed for DosDecision {
    fn time(&self) -> Timestamp {
        self.end
    }
}

impl HasSensor for DosDecision {
    fn sensor(&self) -> &SensorId {
        &self.sensor
    }
}

/// The classifier as a [`Stage`]: raw frames of one sensor in, [`DosDecision`]s out.
///
/// | mode | decisions | each covers |
/// |---|---|---|
/// | `decision_frames = None` | one per segment, at [`finish`](Stage::finish) | the whole recording |
/// | `decision_frames = Some(n)` | one per `n` frames (tumbling) | the last `n` frames, event references carried over |
/// | `Some(n)` + [`with_hop`](Self::with_hop)`(h)` | one every `h` frames once `n` have arrived (sliding) | the last `n` frames, **as a fresh recording** (a tree part's windows: with the contact's history, below) |
///
/// The sliding mode is the one for a robot: an answer every `h` frames (e.g. 10 = 0.1 s) about
/// the last `n` (e.g. 250 = 2.5 s; see the latency trade in the [module docs](crate::dos)), each
/// computed exactly as [`DosModel::calibrate`]'s labelled recordings were — from the window's
/// first frame, nothing carried over — so a model calibrated on recordings of `n` frames meets
/// the same features live. It costs one extraction of `n` frames per decision on top of
/// checking every frame as it arrives; that extraction is done a share per frame ahead of the
/// decision (the window the next decision covers is known `n − h` frames early), so no frame
/// carries a whole window: with 250 frames and hop 10, per-frame p99 8.5 µs against 43 µs when
/// the decision frame replayed the window (`examples/dos_sliding_cost`, the 167 development
/// recordings; median 0.4 µs against 0.2). The decisions are bit-identical either way (tested).
/// At `finish`, frames pushed since the last decision get one more decision over the last (up
/// to) `n` frames.
///
/// With the model's window part ([`DosModel::window`]) each decision is the combined score
/// ([`DosModel::combine`]) of the Student-t decision and the causal vote of the window net over
/// the same frames the decision covers: the span since the last decision (or the segment) in
/// the first two modes, the replayed window in the sliding mode (each completed non-overlapping
/// window of the net counted from the span's first frame; none yet: the Student-t decision).
/// Extra cost: a frame copy and, every 5 frames, one window of the net (p99 per frame 1.9 µs
/// in all, `dos_eval`); in the sliding mode the vote summed per decision from the net windows'
/// log posteriors, each computed once and kept until it leaves the window (250 frames, hop 10:
/// per-frame p99 8.5 µs instead of 6.6 µs for the Student-t model alone, with stop 31's net of
/// levels). A net with the motion inputs (the default since stop 32) measures them against the
/// replayed window's own first frames, which move with it: each net window keeps its level
/// inputs' hidden sums and deviations, and each decision's window recomputes its motion
/// inputs, `tanh` layer and outputs — ahead of the decision, a share per frame, as the replay
/// is (bit-identical to a fresh vote, tested). With the pattern since the start
/// (`WindowInputs::SinceStart`, `Both`) nothing is kept and every net window is recomputed
/// ahead.
///
/// With the model's **tree part** instead ([`DosModel::trees`], a [`DosTrees`] vote; stop 33,
/// `gradtac calibrate dos --window-trees`) the decision combines the same way with the trees'
/// causal vote over 5-frame windows (inputs: the window, the contact's first 0.1 s, the level
/// pattern 0.3 s and 1 s earlier, the last 0.3 s of changes; units as the window net's,
/// dimensionless). One decision per segment and tumbling spans: the vote over the span's
/// windows. **The sliding mode** (stop 34) does not replay the trees: their windows are counted
/// from the reset (the contact) and each window's inputs are what a vote since the reset gives
/// it — its log posterior computed once, on the frame that completes it, and kept while it lies
/// inside the last `n` frames. A decision's tree vote is the mean log posterior of the kept
/// windows that lie wholly inside its frames; the Student-t part is still the fresh replay.
/// So, exactly (bit for bit, tested):
/// - while the decision's frames start at the reset — every early answer, every decision of a
///   contact shorter than `n` frames — the decision is a fresh recording's of those frames;
/// - after the window has slid past the reset, the tree windows keep the contact's history:
///   their reference (the pattern since the start, the motion inputs) is the contact's first
///   0.1 s, their lags and slope may reach back before the window's first frame (at most 20
///   windows = 100 frames), and they lie on the contact's 5-frame grid (a fresh recording's
///   starts at the window's first frame). That is what the held-out ConvLSTM-protocol figure
///   scores per window (each window with the causal history since contact); a fresh replay
///   would walk every tree for all ~50 windows per decision (≈ 56 000 walks), far over 20 µs
///   per frame. Measured on the 167 development recordings (`examples/dos_sliding_cost
///   --compare-fresh`, a model calibrated on them): with 250 frames and hop 10, 504 of 505 slid
///   decisions have a fresh recording's class; with 100 frames, 2 921 of 3 010 (97.0 %).
///
/// Extra cost: a frame copy, and every 5 frames one window's 148 inputs and 2 × 560 tree walks
/// (on that frame the replay's share of the Student-t work waits for the next frames); a
/// decision sums ≤ `n`/5 kept log posteriors. Sliding, 250 frames, hop 10, per frame: p99
/// 9.7 µs, median 0.57 µs (Student-t alone p99 6.4 µs; the same run's window net p99 20.9 µs;
/// `examples/dos_sliding_cost`, 46 165 frames, load ≈ 6 on 2 cores; at load ≈ 3.5 trees 9.0 µs,
/// net 19.7 µs); early answers p99 9.7 µs;
/// 100 frames p99 9.6 µs; one decision per recording p99 7.7 µs (median 0.26 µs, `examples/dos_trees
/// --cost-only`, load ≈ 3). No extra delay: a window counts once its fifth frame is in.
///
/// [`reset`](Stage::reset) drops the open span (and the sliding window). Delay: `n − 1` frames;
/// with `None` the decision comes at `finish` and [`Stage::delay`] reports zero (no frame
/// count describes it).
#[derive(Clone, Debug)]
#[must_use = "a stage does nothing until frames are pushed"]
pub struct DosClassifier {
    model: DosModel,
    extractor: DosFeatureExtractor,
    decision_frames: Option<u64>,
    span: Option<(SensorId, Timestamp, Timestamp, u64)>,
    /// Sliding mode: the hop, the window of the last `decision_frames` frames, frames since the
    /// last decision, and the extractor the window is replayed through.
    sliding: Option<Sliding>,
    /// With the model's window part: the causal vote over the span's windows (tumbling spans
    /// and one decision per segment; the sliding mode replays its window through `Sliding::vote`).
    vote: Option<WindowVoteState>,
    /// With the model's tree part: the causal vote of its trees over the span's windows
    /// (tumbling spans and one decision per segment; the sliding mode keeps its own windows,
    /// `Sliding::trees`).
    tree_vote: Option<TreeVoteState>,
}

/// What the sliding mode keeps of one of the net's windows across decisions.
#[derive(Clone, Debug)]
enum NetWindow {
    /// Its log posterior (a net of levels: it depends on the window's own frames only).
    LogPosterior(Vec<f64>),
    /// A net of levels and motion inputs: the hidden sums of its level inputs and its level
    /// deviations (`None`: a flat window), for the motion inputs against each decision's
    /// reference.
    Levels { sums: Vec<f64>, dev: Option<Vec<f64>> },
}

#[derive(Clone, Debug)]
struct Sliding {
    hop: u64,
    /// Decide every `hop` frames from the first, before the window is full.
    early: bool,
    recent: std::collections::VecDeque<TaxelFrame>,
    since: u64,
    replay: DosFeatureExtractor,
    /// The window vote the window is replayed through (with the model's window part).
    vote: Option<WindowVoteState>,
    /// Frames pushed since the last reset (the index of the next frame).
    total: u64,
    /// The net's window starting at each frame index, kept across decisions while it is in
    /// the window ([`NetWindow`]).
    cache: std::collections::HashMap<u64, NetWindow>,
    /// Extractor of one window at a time, for the cache.
    single: Option<WindowExtractor>,
    /// The next decision's window, prepared ahead (see [`Ahead`]).
    ahead: Ahead,
    /// With the model's tree part: its windows since the reset (see [`SlidingTrees`]).
    trees: Option<SlidingTrees>,
}

/// The sliding mode's tree part: the tree model's non-overlapping windows counted from the
/// reset (the contact), each window's inputs as the stream since the reset gives them (the
/// vote of the other modes), its log posterior computed once, when its last frame arrives, and
/// kept while the window lies inside the last `decision_frames` frames. A decision's tree vote
/// is the mean of the kept windows' log posteriors that lie inside its frames (see
/// [`DosClassifier`]).
#[derive(Clone, Debug)]
struct SlidingTrees {
    extractor: TreeExtractor,
    /// `(index of the window's first frame, its log posterior)`, oldest first.
    windows: std::collections::VecDeque<(u64, Vec<f64>)>,
}

impl Sliding {
    /// Forget the stream (a reset or `finish`): the frames, the decisions' counts, the cached
    /// and prepared work, and the tree part's windows; the settings stay.
    fn restart(&mut self) {
        self.recent.clear();
        self.since = 0;
        self.total = 0;
        self.cache.clear();
        self.ahead = Ahead::default();
        if let Some(t) = &mut self.trees {
            t.extractor.reset();
            t.windows.clear();
        }
    }
}

/// The next decision's work, done a share per frame between decisions, so that no one frame
/// carries a whole window's replay (the sliding mode's p99). `replay` holds the frames
/// `first..pushed` of the window that the next decision is predicted to cover; with a net
/// measured against the window's start, `windows` holds the log posteriors of that window's
/// first net windows. A decision whose window starts elsewhere (a `finish`, a prediction
/// missed) replays from scratch; either way the replay receives exactly the frames a fresh one
/// would, in the same order, so the decisions are bit-identical (tested).
#[derive(Clone, Debug, Default)]
struct Ahead {
    /// Index of the predicted window's first frame (`None`: nothing prepared).
    first: Option<u64>,
    /// Index of the next frame to push into the replay.
    pushed: u64,
    /// Log posteriors of the predicted window's net windows `0..windows.len()` (a net
    /// measured against the window's start only).
    windows: Vec<Vec<f64>>,
}

impl DosClassifier {
    /// A classifier for `layout`'s sensor; `decision_frames` (≥ 1) or `None` for one decision
    /// per segment.
    pub fn try_new(model: DosModel, layout: &Layout, decision_frames: Option<u64>) -> Result<Self> {
        model.validate()?;
        if decision_frames == Some(0) {
            return Err(invalid("decision_frames must be ≥ 1"));
        }
        if let Some(n) = decision_frames.filter(|&n| n > crate::limits::MAX_DOS_FRAMES) {
            return Err(invalid(format!(
                "decision_frames = {n} exceeds the maximum of {}",
                crate::limits::MAX_DOS_FRAMES
            )));
        }
        let extractor = DosFeatureExtractor::try_new(&model.config, layout)?;
        let vote = match &model.window {
            Some(w) => Some(
                WindowVoteState::try_new(&w.net, layout).map_err(super::model::in_field("window.net of the model"))?,
            ),
            None => None,
        };
        let tree_vote = match &model.trees {
            Some(t) => Some(
                TreeVoteState::try_new(&t.trees, layout).map_err(super::model::in_field("trees.trees of the model"))?,
            ),
            None => None,
        };
        Ok(DosClassifier { model, extractor, decision_frames, span: None, sliding: None, vote, tree_vote })
    }

    /// Sliding decisions: one every `hop` frames (≥ 1) over the last `decision_frames` frames,
    /// each extracted as a fresh recording (a tree part: its windows keep the contact's history;
    /// see the type's docs). Needs `decision_frames`.
    pub fn with_hop(mut self, hop: u64) -> Result<Self> {
        let Some(n) = self.decision_frames else {
            return Err(invalid("a hop needs decision_frames (the window the sliding decisions cover)"));
        };
        if hop == 0 {
            return Err(invalid("hop must be ≥ 1 frame"));
        }
        if hop > crate::limits::MAX_DOS_FRAMES {
            return Err(invalid(format!(
                "hop_frames = {hop} exceeds the maximum of {}",
                crate::limits::MAX_DOS_FRAMES
            )));
        }
        let replay = self.extractor.clone();
        let vote = self.vote.clone();
        let single = match &self.model.window {
            Some(_) => vote.as_ref().map(|v| v.fresh_extractor()),
            None => None,
        };
        let trees = self.tree_vote.as_ref().map(|v| SlidingTrees {
            extractor: v.fresh_extractor(),
            windows: std::collections::VecDeque::with_capacity(usize::try_from(n).unwrap_or(0).min(1 << 20) / 2 + 1),
        });
        self.sliding = Some(Sliding {
            hop,
            early: false,
            recent: std::collections::VecDeque::with_capacity(usize::try_from(n).unwrap_or(0).min(1 << 20)),
            since: 0,
            replay,
            vote,
            total: 0,
            cache: std::collections::HashMap::new(),
            single,
            ahead: Ahead::default(),
            trees,
        });
        Ok(self)
    }

    /// Sliding mode with early answers: a decision every `hop` frames from the first hop after
    /// contact (a [`reset`](Stage::reset) or the start), each over all frames since then until
    /// `decision_frames` have arrived, over the last `decision_frames` after that — what a robot
    /// that must act before the window fills sees (the accuracy by time since contact is in the
    /// [module docs](crate::dos)). Needs [`with_hop`](Self::with_hop) first.
    pub fn with_early_decisions(mut self) -> Result<Self> {
        match &mut self.sliding {
            Some(sl) => sl.early = true,
            None => return Err(invalid("early decisions need the sliding mode (with_hop)")),
        }
        Ok(self)
    }

    /// The hop of the sliding mode (`None`: tumbling spans or one decision per segment).
    pub fn hop(&self) -> Option<u64> {
        self.sliding.as_ref().map(|s| s.hop)
    }

    /// The model.
    pub fn model(&self) -> &DosModel {
        &self.model
    }

    fn emit(&mut self, out: &mut Vec<DosDecision>) -> Result<()> {
        if let Some((sensor, start, end, seq)) = self.span.take() {
            let features = self.extractor.features();
            let mut decision = self.model.classify_vector(&features)?;
            if let Some(v) = &mut self.vote {
                decision = self.model.combine(decision, v.mean_log_posterior().as_deref());
                v.reset();
            }
            if let Some(v) = &mut self.tree_vote {
                decision = self.model.combine(decision, v.mean_log_posterior().as_deref());
                v.reset();
            }
            out.push(DosDecision { sensor, start, end, seq, frames: features.frames, decision, features });
            self.extractor.clear_span();
        }
        Ok(())
    }
}

impl DosClassifier {
    /// Sliding mode: one decision over the frames in the window, replayed as a fresh recording.
    fn decide_window(&mut self, out: &mut Vec<DosDecision>) -> Result<()> {
        let Some(sl) = &mut self.sliding else { return Ok(()) };
        let (Some(first), Some(last)) = (sl.recent.front(), sl.recent.back()) else { return Ok(()) };
        let (sensor, start, end, seq) = (last.sensor.clone(), first.time, last.time, last.seq);
        let first = sl.total - sl.recent.len() as u64;
        let ahead = std::mem::take(&mut sl.ahead);
        let prepared = ahead.first == Some(first);
        if !prepared {
            sl.replay.reset();
        }
        let from = if prepared { (ahead.pushed - first) as usize } else { 0 };
        for f in sl.recent.iter().skip(from) {
            sl.replay.push(f.clone())?;
        }
        let features = sl.replay.features();
        let mut decision = self.model.classify_vector(&features)?;
        if let (Some(v), Some(w), Some(single)) = (&mut sl.vote, &self.model.window, &mut sl.single) {
            // the vote over the window's non-overlapping net windows from its first frame, as
            // a fresh recording ([`net_window`]); those prepared ahead for this window first
            let f = w.net.config.frames;
            let kind = WindowKind::of(&w.net);
            if kind == WindowKind::OwnReference {
                sl.cache.clear();
            } else {
                sl.cache.retain(|&start, _| start >= first);
            }
            let ready = if prepared { ahead.windows } else { Vec::new() };
            v.reset();
            for k in 0..sl.recent.len() / f {
                match ready.get(k) {
                    Some(lp) => v.add_log_posterior(lp),
                    None => {
                        v.add_log_posterior(&net_window(&w.net, kind, single, &mut sl.cache, &sl.recent, first, 0, k)?)
                    }
                }
            }
            decision = self.model.combine(decision, v.mean_log_posterior().as_deref());
        }
        if let (Some(t), Some(part)) = (&sl.trees, &self.model.trees) {
            // the kept tree windows inside this decision's frames, oldest first (as a vote adds them)
            let mut vote = LogVote::new(part.trees.classes().len());
            for (_, lp) in t.windows.iter().filter(|(at, _)| *at >= first) {
                vote.add(lp);
            }
            decision = self.model.combine(decision, vote.mean_log_posterior().as_deref());
        }
        out.push(DosDecision { sensor, start, end, seq, frames: features.frames, decision, features });
        sl.since = 0;
        Ok(())
    }

    fn push_sliding(&mut self, frame: TaxelFrame, out: &mut Vec<DosDecision>) -> Result<()> {
        let n = self.decision_frames.unwrap_or(1);
        // every frame is checked as it arrives (the same errors as the other modes)
        self.extractor.push(frame.clone())?;
        self.extractor.clear_span();
        let Some(sl) = &mut self.sliding else { return Ok(()) };
        // the tree part's window that this frame completes, if any (its walks are this frame's
        // work: the replay's share of it moves to the next frames)
        let mut walked = false;
        if let (Some(t), Some(part)) = (&mut sl.trees, &self.model.trees) {
            if let Some(x) = t.extractor.push(&frame.values)? {
                let f = part.trees.inputs().window.frames as u64;
                t.windows.push_back((sl.total + 1 - f, part.trees.log_posterior(&x)?));
                walked = true;
            }
        }
        if sl.recent.len() as u64 >= n {
            sl.recent.pop_front();
        }
        sl.recent.push_back(frame);
        sl.since += 1;
        sl.total += 1;
        if let Some(t) = &mut sl.trees {
            // no later decision starts before the window's first frame now
            let first = sl.total - sl.recent.len() as u64;
            while t.windows.front().is_some_and(|(at, _)| *at < first) {
                t.windows.pop_front();
            }
        }
        if (sl.early || sl.recent.len() as u64 >= n) && sl.since >= sl.hop {
            self.decide_window(out)?;
        }
        self.work_ahead(n, walked)
    }

    /// A share of the next decision's replay (and, with a net measured against the window's
    /// own first frames, of its net windows): what is known of the predicted window, spread
    /// over the frames still to come before it.
    ///
    /// On a frame that `walked` a tree window, the replay's share waits for the next frames
    /// (unless the next frame decides): the two costs do not add up on one frame.
    fn work_ahead(&mut self, n: u64, walked: bool) -> Result<()> {
        let Some(sl) = &mut self.sliding else { return Ok(()) };
        let len = sl.recent.len() as u64;
        // frames until the next decision, and the window it will cover
        let mut m = sl.hop.saturating_sub(sl.since).max(1);
        if !sl.early {
            m = m.max(n.saturating_sub(len));
        }
        if walked && m > 1 {
            return Ok(());
        }
        let first = sl.total + m - (len + m).min(n);
        if sl.ahead.first != Some(first) {
            sl.replay.reset();
            sl.ahead = Ahead { first: Some(first), pushed: first, windows: Vec::new() };
        }
        let offset = sl.total - len;
        // (none when the window starts after the frames in: a hop longer than the window)
        let known = sl.total.saturating_sub(sl.ahead.pushed);
        for _ in 0..known.div_ceil(m) {
            let frame = &sl.recent[(sl.ahead.pushed - offset) as usize];
            sl.replay.push(frame.clone())?;
            sl.ahead.pushed += 1;
        }
        if let (Some(w), Some(single)) = (&self.model.window, &mut sl.single) {
            let kind = WindowKind::of(&w.net);
            if kind != WindowKind::Levels {
                let f = w.net.config.frames as u64;
                // net windows of the predicted window whose frames are all in, and the number
                // the decision will use
                let complete = sl.total.saturating_sub(first) / f;
                let used = (len + m).min(n) / f;
                let known = complete.min(used).saturating_sub(sl.ahead.windows.len() as u64);
                for _ in 0..known.div_ceil(m) {
                    let k = sl.ahead.windows.len();
                    let at = (first - offset) as usize;
                    let lp = net_window(&w.net, kind, single, &mut sl.cache, &sl.recent, first, at, k)?;
                    sl.ahead.windows.push(lp);
                }
            }
        }
        Ok(())
    }
}

/// How the sliding mode computes a net window's log posterior.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum WindowKind {
    /// A net of levels: the log posterior depends on the net window's own frames only, and is
    /// kept across decisions.
    Levels,
    /// Levels and the motion inputs: those measure against the replayed window's own first
    /// frames, which move with it; the level inputs' hidden sums and the deviations are kept
    /// across decisions, the motion inputs, `tanh` layer and outputs recomputed per window.
    Motion,
    /// The pattern since the start (`WindowInputs::SinceStart`, `Both`): nothing is kept.
    OwnReference,
}

impl WindowKind {
    fn of(net: &DosWindowNet) -> Self {
        match (net.config.inputs == WindowInputs::Levels, net.config.motion) {
            (true, false) => WindowKind::Levels,
            (true, true) => WindowKind::Motion,
            (false, _) => WindowKind::OwnReference,
        }
    }
}

/// The log posterior of net window `k` (frames `k·f..(k+1)·f`) of the window `frames[at..]`
/// (whose first frame has index `first`) replayed as a fresh recording: a net measured against
/// the replay's first frames sees them as a replay from the window's first frame has them at
/// this net window's end. What does not depend on the window's start is kept in `cache`, by
/// the net window's first frame index.
#[allow(clippy::too_many_arguments)]
fn net_window(
    net: &DosWindowNet,
    kind: WindowKind,
    single: &mut WindowExtractor,
    cache: &mut std::collections::HashMap<u64, NetWindow>,
    frames: &std::collections::VecDeque<TaxelFrame>,
    first: u64,
    at: usize,
    k: usize,
) -> Result<Vec<f64>> {
    let f = net.config.frames;
    let key = first + (k * f) as u64;
    let window = || frames.range(at + k * f..at + (k + 1) * f).map(|fr| fr.values.as_slice());
    let reference = |seen: usize| frames.range(at..).take(seen).map(|fr| fr.values.as_slice());
    match kind {
        WindowKind::OwnReference => {
            single.reset_with_reference(reference((k + 1) * f))?;
            for v in window() {
                single.push(v)?;
            }
            let x = single.input().ok_or_else(|| invalid("a full window gave no input"))?;
            net.log_posterior(&x)
        }
        WindowKind::Levels | WindowKind::Motion if !cache.contains_key(&key) => {
            single.reset();
            for v in window() {
                single.push(v)?;
            }
            let cached = if kind == WindowKind::Motion {
                let (x, dev) = single.input_and_deviations().ok_or_else(|| invalid("a full window gave no input"))?;
                NetWindow::Levels { sums: net.prefix_sums(&x[..x.len() - MOTION_INPUTS])?, dev }
            } else {
                let x = single.input().ok_or_else(|| invalid("a full window gave no input"))?;
                NetWindow::LogPosterior(net.log_posterior(&x)?)
            };
            cache.insert(key, cached);
            net_window(net, kind, single, cache, frames, first, at, k)
        }
        WindowKind::Levels | WindowKind::Motion => match &cache[&key] {
            NetWindow::LogPosterior(lp) => Ok(lp.clone()),
            NetWindow::Levels { sums, dev } => {
                // the reference a fresh vote has at this net window's end
                single.reset_with_reference(reference(((k + 1) * f).min(net.config.reference_frames)))?;
                let m = dev.as_deref().map_or([0.0; MOTION_INPUTS], |d| single.motion_inputs(d));
                net.log_posterior_from_prefix(sums, &m)
            }
        },
    }
}

impl Stage for DosClassifier {
    type In = TaxelFrame;
    type Out = DosDecision;
    type Error = Error;

    fn push(&mut self, frame: TaxelFrame, out: &mut Vec<DosDecision>) -> Result<()> {
        if self.sliding.is_some() {
            return self.push_sliding(frame, out);
        }
        let (sensor, time, seq) = (frame.sensor.clone(), frame.time, frame.seq);
        match (&mut self.vote, &self.model.window) {
            (Some(v), Some(w)) => {
                let values = frame.values.clone();
                // the extractor first: a bad frame gets the same error as without a window part
                self.extractor.push(frame)?;
                v.push(&w.net, &values)?;
            }
            _ => match (&mut self.tree_vote, &self.model.trees) {
                (Some(v), Some(t)) => {
                    let values = frame.values.clone();
                    self.extractor.push(frame)?;
                    v.push(&t.trees, &values)?;
                }
                _ => self.extractor.push(frame)?,
            },
        }
        match &mut self.span {
            Some(s) => {
                s.2 = time;
                s.3 = seq;
            }
            None => self.span = Some((sensor, time, time, seq)),
        }
        if self.decision_frames.is_some_and(|n| self.extractor.frames() >= n) {
            self.emit(out)?;
        }
        Ok(())
    }

    fn finish(&mut self, out: &mut Vec<DosDecision>) -> Result<()> {
        if self.sliding.as_ref().is_some_and(|s| s.since > 0) {
            self.decide_window(out)?;
        }
        if let Some(sl) = &mut self.sliding {
            sl.restart();
        }
        self.emit(out)
    }

    fn reset(&mut self) {
        self.extractor.reset();
        self.span = None;
        if let Some(v) = &mut self.vote {
            v.reset();
        }
        if let Some(v) = &mut self.tree_vote {
            v.reset();
        }
        if let Some(sl) = &mut self.sliding {
            sl.restart();
        }
    }

    fn delay(&self) -> Delay {
        match self.decision_frames {
            Some(n) => Delay::frames(n - 1),
            // the decision comes at `finish`, which no frame count describes
            None => Delay::ZERO,
        }
    }
}
