//! A stage over an [`Iterator`].

use crate::Stage;
use std::collections::VecDeque;

/// Iterator adapter for [`IteratorStageExt::stage`]: pulls `Result` items from the inner
/// iterator, pushes the `Ok` ones through the stage and yields its outputs; at the end it
/// yields what [`Stage::finish`] flushes. The first error is yielded once, then the iterator
/// ends.
#[must_use = "iterators are lazy and do nothing unless consumed"]
pub struct StageIter<I, S: Stage> {
    inner: I,
    stage: S,
    buf: Vec<S::Out>,
    ready: VecDeque<S::Out>,
    done: bool,
}

impl<I, S: Stage> StageIter<I, S> {
    /// The stage being driven.
    pub fn stage(&self) -> &S {
        &self.stage
    }
}

impl<I, S, E> Iterator for StageIter<I, S>
where
    I: Iterator<Item = Result<S::In, E>>,
    S: Stage,
    S::Error: Into<E>,
{
    type Item = Result<S::Out, E>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(x) = self.ready.pop_front() {
                return Some(Ok(x));
            }
            if self.done {
                return None;
            }
            let r = match self.inner.next() {
                Some(Ok(x)) => self.stage.push(x, &mut self.buf),
                Some(Err(e)) => {
                    self.done = true;
                    return Some(Err(e));
                }
                None => {
                    self.done = true;
                    self.stage.finish(&mut self.buf)
                }
            };
            self.ready.extend(self.buf.drain(..));
            if let Err(e) = r {
                self.done = true;
                self.ready.clear();
                return Some(Err(e.into()));
            }
        }
    }
}

/// Runs stages over iterators of `Result` items; implemented for every such iterator.
///
/// ```
/// use gradtac_stream::{map_stage, IteratorStageExt};
/// let out: Result<Vec<i32>, gradtac_stream::Error> =
///     [1, 2, 3].into_iter().map(Ok).stage(map_stage(|x: i32| x + 1)).collect();
/// assert_eq!(out.unwrap(), vec![2, 3, 4]);
/// ```
pub trait IteratorStageExt: Iterator + Sized {
    /// Drive `stage` with this iterator's items (see [`StageIter`]).
    fn stage<S, E>(self, stage: S) -> StageIter<Self, S>
    where
        Self: Iterator<Item = Result<S::In, E>>,
        S: Stage,
        S::Error: Into<E>,
    {
        StageIter { inner: self, stage, buf: Vec::new(), ready: VecDeque::new(), done: false }
    }
}

impl<I: Iterator> IteratorStageExt for I {}
