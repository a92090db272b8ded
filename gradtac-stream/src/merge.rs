//! Merging several time-ordered sources into one time-ordered stream.
//!
//! [`MergeCore`] is the synchronous heart; [`merge_iter`](crate::adapters::merge_iter::merge_iter)
//! and [`merge_streams`](crate::adapters::merge_stream::merge_streams) drive it from iterators and
//! from streams.
//!
//! **Order.** An item is released only when every source that has not ended has at least one
//! item queued, and the released item is the earliest of the queue heads (ties go to the
//! lower source index, so the merge is deterministic). If each source is in non-decreasing
//! time, the output is too. A source that goes back in time is not reordered: its items keep
//! their own order.
//!
//! **Bounded buffering.** Each source queues at most `capacity` items; a source is not
//! read while its queue is full. Memory is `sources × capacity` items whatever the lengths.
//! A source that stays silent holds the merge back (it is waiting for that source's next
//! time): for live buses that may fall silent, merge per bus or use one source per sensor.

use crate::Timed;
use std::collections::VecDeque;

/// The synchronous merge state (see the [module docs](self)).
#[derive(Debug)]
pub struct MergeCore<T> {
    queues: Vec<VecDeque<T>>,
    ended: Vec<bool>,
    capacity: usize,
}

impl<T: Timed> MergeCore<T> {
    /// A merge of `sources` inputs, each queueing at most `capacity` (≥ 1) items.
    pub fn new(sources: usize, capacity: usize) -> Self {
        let capacity = capacity.max(1);
        MergeCore {
            queues: (0..sources).map(|_| VecDeque::with_capacity(capacity)).collect(),
            ended: vec![false; sources],
            capacity,
        }
    }

    /// Number of sources.
    pub fn sources(&self) -> usize {
        self.queues.len()
    }

    /// True when source `i` has not ended and its queue has room.
    pub fn wants(&self, i: usize) -> bool {
        !self.ended[i] && self.queues[i].len() < self.capacity
    }

    /// True when source `i` has not ended and nothing is queued from it: the merge cannot
    /// release anything until it delivers.
    pub fn starved(&self, i: usize) -> bool {
        !self.ended[i] && self.queues[i].is_empty()
    }

    /// Queue an item of source `i`.
    pub fn push(&mut self, i: usize, item: T) {
        debug_assert!(!self.ended[i], "push after end");
        self.queues[i].push_back(item);
    }

    /// Source `i` has ended.
    pub fn end(&mut self, i: usize) {
        self.ended[i] = true;
    }

    /// True when every source has ended and every queue is empty.
    pub fn is_done(&self) -> bool {
        self.ended.iter().all(|&e| e) && self.queues.iter().all(VecDeque::is_empty)
    }

    /// The next item in time order, if it can be known now.
    pub fn pop_ready(&mut self) -> Option<T> {
        if (0..self.queues.len()).any(|i| self.starved(i)) {
            return None;
        }
        let mut best: Option<(usize, crate::Timestamp)> = None;
        for (i, q) in self.queues.iter().enumerate() {
            if let Some(h) = q.front() {
                let t = h.time();
                if best.is_none_or(|(_, bt)| t < bt) {
                    best = Some((i, t));
                }
            }
        }
        best.and_then(|(i, _)| self.queues[i].pop_front())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Timestamp;

    #[derive(Debug, PartialEq)]
    struct It(i64, u8);
    impl Timed for It {
        fn time(&self) -> Timestamp {
            Timestamp(self.0)
        }
    }

    #[test]
    fn waits_for_every_live_source_and_breaks_ties_by_index() {
        let mut m = MergeCore::new(2, 2);
        m.push(1, It(5, 1));
        assert_eq!(m.pop_ready(), None, "source 0 may still deliver something earlier");
        m.push(0, It(5, 0));
        assert_eq!(m.pop_ready(), Some(It(5, 0)));
        assert_eq!(m.pop_ready(), None);
        m.end(0);
        assert_eq!(m.pop_ready(), Some(It(5, 1)));
        assert!(!m.is_done());
        m.end(1);
        assert!(m.is_done());
    }

    #[test]
    fn capacity_bounds_each_queue() {
        let mut m: MergeCore<It> = MergeCore::new(1, 2);
        m.push(0, It(1, 0));
        assert!(m.wants(0));
        m.push(0, It(2, 0));
        assert!(!m.wants(0));
    }
}
