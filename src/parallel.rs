//! The sensors' chains on threads of their own, with outputs byte-identical to one thread.
//!
//! The runner's thread keeps everything whose order matters: the merge by time, the sinks and
//! the cross-sensor slip stage. It hands the frames to chain threads in batches (each chain
//! lives on one thread; a thread holds one or more chains, assigned round-robin) and each
//! chain records what it would have written ([`Collected`], one buffer per batch with a mark
//! per frame), with the track points it made. The runner's thread then replays the batch frame by frame, in the merged order: the
//! slip stage's raw-frame evidence of the frame, the chain's writes, the chain's track points
//! into the slip stage, the slip events — exactly the sequence of calls [`Runner`] makes on
//! one thread, so every sink receives the same records in the same order and writes the same
//! bytes. At the end the chains are flushed on their threads and replayed in chain order, as
//! [`Runner::finish`] does.
//!
//! Up to [`IN_FLIGHT`] batches are out at once, so the chain threads work on one batch while
//! the runner's thread replays the one before.
//!
//! [`Runner`]: crate::run::Runner
//! [`Runner::finish`]: crate::run::Runner::finish

use crate::chain::SensorChain;
use crate::plan::Plan;
use crate::run::SlipNode;
use crate::scene::Scene;
use crate::sinks::{Collected, Sinks};
use crate::Error;
use gradtac_stages::track::TrackPoint;
use gradtac_stream::{SensorId, TaxelFrame};
use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::mpsc::{channel, Receiver, Sender};
use std::thread::JoinHandle;

/// Batches handed out and not yet replayed, at most.
pub(crate) const IN_FLIGHT: usize = 2;

/// What a chain thread's chains did with a batch of frames (or their flushes), frame by frame:
/// the writes and track points of frame `k` are those between the marks `k - 1` and `k`.
#[derive(Default)]
struct BatchOut {
    writes: Collected,
    /// Per frame: `writes.len()` after it.
    ends: Vec<usize>,
    points: Vec<TrackPoint>,
    /// Per frame: `points.len()` after it.
    point_ends: Vec<usize>,
    /// The first error: the frame's index in the batch and the error.
    error: Option<(usize, Error)>,
}

impl BatchOut {
    /// Frame `k`'s writes and points.
    fn ranges(&self, k: usize) -> (std::ops::Range<usize>, std::ops::Range<usize>) {
        let from = |v: &[usize]| if k == 0 { 0 } else { v[k - 1] };
        (from(&self.ends)..self.ends[k], from(&self.point_ends)..self.point_ends[k])
    }
}

enum Job {
    /// Frames, each with the index of its chain (among the thread's chains: `local`).
    Frames(Vec<(usize, TaxelFrame)>),
    /// Flush every chain, in order.
    Finish,
}

enum Reply {
    Frames(BatchOut),
    Finished(BatchOut),
}

struct Worker {
    jobs: Sender<Job>,
    replies: Receiver<Reply>,
    handle: Option<JoinHandle<()>>,
}

/// One chain thread's loop: process what comes, reply in order; after an error the chains
/// are left alone (the runner stops at the first error it replays).
fn work(mut chains: Vec<SensorChain>, jobs: Receiver<Job>, replies: Sender<Reply>) {
    let mut failed = false;
    let step = |out: &mut BatchOut, chain: &mut SensorChain, frame: Option<TaxelFrame>, failed: &mut bool| {
        if !*failed {
            let finish = frame.is_none();
            if let Err(e) = chain.process(frame, finish, &mut out.writes) {
                out.error = Some((out.ends.len(), e));
                *failed = true;
            }
            out.points.extend(chain.take_points());
        }
        out.ends.push(out.writes.len());
        out.point_ends.push(out.points.len());
    };
    while let Ok(job) = jobs.recv() {
        let mut out = BatchOut::default();
        let reply = match job {
            Job::Frames(frames) => {
                for (i, f) in frames {
                    step(&mut out, &mut chains[i], Some(f), &mut failed);
                }
                Reply::Frames(out)
            }
            Job::Finish => {
                for c in &mut chains {
                    step(&mut out, c, None, &mut failed);
                }
                Reply::Finished(out)
            }
        };
        if replies.send(reply).is_err() {
            return;
        }
    }
}

/// A batch handed out: per frame, its chain; the workers that got frames of it; the frames
/// the slip stage reads (kept on this thread).
struct Pending {
    chains: Vec<usize>,
    workers: Vec<usize>,
    slip_frames: Vec<Option<TaxelFrame>>,
}

/// The threaded counterpart of [`crate::run::Runner`] (see the [module docs](self)).
pub(crate) struct Parallel {
    workers: Vec<Worker>,
    /// Per chain: (worker, index among the worker's chains).
    owner: Vec<(usize, usize)>,
    sensors: Vec<SensorId>,
    frames: Vec<u64>,
    last: usize,
    slip: Option<SlipNode>,
    sinks: Option<Sinks>,
    pending: VecDeque<Pending>,
}

fn thread_gone() -> Error {
    Error::Io {
        path: PathBuf::from("<chain thread>"),
        source: std::io::Error::other("a sensor's chain thread ended unexpectedly (panicked)"),
    }
}

impl Parallel {
    /// Build every planned stage, open every output and start `threads` chain threads (at
    /// most one per chain).
    pub(crate) fn new(
        scene: &Scene,
        plan: &Plan,
        threads: usize,
        memory: Option<&crate::memory::MemoryOutputs>,
    ) -> Result<Parallel, Error> {
        let (chains, slip, sinks) = crate::run::build_parts(scene, plan, memory)?;
        let n = threads.clamp(1, chains.len().max(1));
        let sensors: Vec<SensorId> = chains.iter().map(|c| c.sensor().clone()).collect();
        let mut groups: Vec<Vec<SensorChain>> = (0..n).map(|_| Vec::new()).collect();
        let mut owner = Vec::with_capacity(chains.len());
        for (i, c) in chains.into_iter().enumerate() {
            owner.push((i % n, groups[i % n].len()));
            groups[i % n].push(c);
        }
        let mut workers = Vec::with_capacity(n);
        for (k, group) in groups.into_iter().enumerate() {
            let (jobs, job_rx) = channel();
            let (reply_tx, replies) = channel();
            let handle = std::thread::Builder::new()
                .name(format!("gradtac-chain-{k}"))
                .spawn(move || work(group, job_rx, reply_tx))
                .map_err(|source| Error::Io { path: PathBuf::from("<chain thread>"), source });
            match handle {
                Ok(h) => workers.push(Worker { jobs, replies, handle: Some(h) }),
                Err(e) => {
                    sinks.abort();
                    return Err(e);
                }
            }
        }
        let frames = vec![0; sensors.len()];
        Ok(Parallel { workers, owner, sensors, frames, last: 0, slip, sinks: Some(sinks), pending: VecDeque::new() })
    }

    fn chain_index(&mut self, s: &SensorId) -> Option<usize> {
        let c = self.sensors.get(self.last)?;
        if c.ptr_eq(s) || c == s {
            return Some(self.last);
        }
        let i = self.sensors.iter().position(|c| c == s)?;
        self.last = i;
        Some(i)
    }

    /// Hand a batch of frames (in time order) to the chain threads; replays the oldest batch
    /// out when [`IN_FLIGHT`] are out. Frames of sensors the plan does not run are ignored.
    pub(crate) fn push_batch(&mut self, frames: Vec<TaxelFrame>) -> Result<(), Error> {
        let mut jobs: Vec<Vec<(usize, TaxelFrame)>> = (0..self.workers.len()).map(|_| Vec::new()).collect();
        let mut pending =
            Pending { chains: Vec::with_capacity(frames.len()), workers: Vec::new(), slip_frames: Vec::new() };
        for f in frames {
            let Some(i) = self.chain_index(&f.sensor) else { continue };
            self.frames[i] += 1;
            if let Some(node) = &self.slip {
                pending.slip_frames.push(node.reads_frames_of(&f.sensor).then(|| f.clone()));
            }
            pending.chains.push(i);
            let (w, local) = self.owner[i];
            jobs[w].push((local, f));
        }
        for (w, job) in jobs.into_iter().enumerate().filter(|(_, j)| !j.is_empty()) {
            self.workers[w].jobs.send(Job::Frames(job)).map_err(|_| thread_gone())?;
            pending.workers.push(w);
        }
        if pending.chains.is_empty() {
            return Ok(());
        }
        self.pending.push_back(pending);
        while self.pending.len() > IN_FLIGHT {
            self.replay_oldest()?;
        }
        Ok(())
    }

    /// Replay every batch handed out (before waiting for more input, so that a live source's
    /// frames are written without waiting for the next batch).
    pub(crate) fn drain(&mut self) -> Result<(), Error> {
        while !self.pending.is_empty() {
            self.replay_oldest()?;
        }
        Ok(())
    }

    fn replay_oldest(&mut self) -> Result<(), Error> {
        let Some(p) = self.pending.pop_front() else { return Ok(()) };
        let mut outs: Vec<(BatchOut, usize)> = (0..self.workers.len()).map(|_| (BatchOut::default(), 0)).collect();
        for &w in &p.workers {
            match self.workers[w].replies.recv() {
                Ok(Reply::Frames(v)) => outs[w].0 = v,
                _ => return Err(thread_gone()),
            }
        }
        let sinks = self.sinks.as_mut().expect("open until finish or abort");
        for (j, &i) in p.chains.iter().enumerate() {
            let (w, _) = self.owner[i];
            let (out, k) = &mut outs[w];
            if *k >= out.ends.len() {
                return Err(thread_gone());
            }
            if let (Some(node), Some(Some(frame))) = (&mut self.slip, p.slip_frames.get(j)) {
                node.push_frame(frame)?;
            }
            let (writes, points) = out.ranges(*k);
            out.writes.replay_range(writes, sinks)?;
            if out.error.as_ref().is_some_and(|(at, _)| at == k) {
                return Err(out.error.take().expect("checked").1);
            }
            if let Some(node) = &mut self.slip {
                node.push_points(&self.sensors[i], out.points[points].iter().cloned(), false)?;
                node.write_events(sinks)?;
            }
            *k += 1;
        }
        Ok(())
    }

    /// Frames pushed so far, per sensor.
    pub(crate) fn frames_in(&self) -> Vec<(String, u64)> {
        self.sensors.iter().zip(&self.frames).map(|(s, n)| (s.to_string(), *n)).collect()
    }

    /// End of input: replay what is out, flush every chain (on its thread) and replay the
    /// flushes in chain order, finish every output. On an error the outputs are left as
    /// `.partial` files.
    pub(crate) fn finish(mut self) -> Result<Vec<(Vec<PathBuf>, u64)>, Error> {
        match self.flush() {
            Ok(()) => {
                self.stop();
                self.sinks.take().expect("open until finish or abort").finish()
            }
            Err(e) => {
                self.abort();
                Err(e)
            }
        }
    }

    fn flush(&mut self) -> Result<(), Error> {
        self.drain()?;
        for w in &self.workers {
            w.jobs.send(Job::Finish).map_err(|_| thread_gone())?;
        }
        let mut flushed: Vec<(BatchOut, usize)> = Vec::with_capacity(self.workers.len());
        for w in &self.workers {
            match w.replies.recv() {
                Ok(Reply::Finished(v)) => flushed.push((v, 0)),
                _ => return Err(thread_gone()),
            }
        }
        let sinks = self.sinks.as_mut().expect("open until finish or abort");
        let n = self.owner.len();
        for i in 0..n {
            let (w, _) = self.owner[i];
            let (out, k) = &mut flushed[w];
            if *k >= out.ends.len() {
                return Err(thread_gone());
            }
            let (writes, points) = out.ranges(*k);
            out.writes.replay_range(writes, sinks)?;
            if out.error.as_ref().is_some_and(|(at, _)| at == k) {
                return Err(out.error.take().expect("checked").1);
            }
            if let Some(node) = &mut self.slip {
                node.push_points(&self.sensors[i], out.points[points].iter().cloned(), i + 1 == n)?;
                node.write_events(sinks)?;
            }
            *k += 1;
        }
        Ok(())
    }

    /// Close the job channels and join the threads.
    fn stop(&mut self) {
        for w in &mut self.workers {
            let (closed, _) = channel();
            drop(std::mem::replace(&mut w.jobs, closed));
            if let Some(h) = w.handle.take() {
                let _ = h.join();
            }
        }
    }

    /// After an error: stop the threads, close every output as a valid `.partial` file; returns
    /// their paths.
    pub(crate) fn abort(mut self) -> Vec<PathBuf> {
        self.stop();
        self.sinks.take().map(Sinks::abort).unwrap_or_default()
    }
}

impl Drop for Parallel {
    fn drop(&mut self) {
        self.stop();
    }
}
