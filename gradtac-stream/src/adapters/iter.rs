//! A stage over an [`Iterator`].

use crate::Stage;
use std::collections::VecDeque;
use std::fmt;

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
    ///
    /// With [`IteratorStageExt`] in scope, `it.stage()` resolves to that trait's `stage`
    /// (a `StageIter` is an iterator too); call this one as `StageIter::stage(&it)`.
    pub fn stage(&self) -> &S {
        &self.stage
    }

    /// The input iterator (e.g. a reader's line count or statistics). Items it has yielded may
    /// still be queued as the stage's outputs.
    pub fn inner(&self) -> &I {
        &self.inner
    }
}

impl<I: fmt::Debug, S: Stage + fmt::Debug> fmt::Debug for StageIter<I, S> {
    /// The input iterator, the stage, how many outputs are queued and whether the input ended
    /// (or failed).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("StageIter")
            .field("inner", &self.inner)
            .field("stage", &self.stage)
            .field("queued", &self.ready.len())
            .field("done", &self.done)
            .finish()
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

#[cfg(test)]
mod tests {
    use super::*;

    /// `inner` sees the input iterator's progress, `stage` the stage's; `Debug` shows both and
    /// the queue.
    #[test]
    fn accessors_see_the_inner_iterator_and_the_stage() {
        let mut it = [1u8, 2, 3].into_iter().map(Ok::<u8, crate::Error>).stage(Counting(0));
        assert!(format!("{it:?}").contains("stage: Counting(0), queued: 0, done: false"), "{it:?}");
        assert_eq!(it.next().unwrap().unwrap(), 1);
        assert_eq!((it.inner().len(), StageIter::stage(&it).0), (2, 1));
        assert_eq!(it.by_ref().map(Result::unwrap).collect::<Vec<_>>(), vec![2, 3]);
        assert_eq!((it.inner().len(), StageIter::stage(&it).0), (0, 3));
        let d = format!("{it:?}");
        assert!(d.starts_with("StageIter { inner: ") && d.contains("stage: Counting(3), queued: 0, done: true"), "{d}");
    }

    #[derive(Debug)]
    struct Counting(u64);

    impl Stage for Counting {
        type In = u8;
        type Out = u8;
        type Error = crate::Error;
        fn push(&mut self, x: u8, out: &mut Vec<u8>) -> Result<(), crate::Error> {
            self.0 += 1;
            out.push(x);
            Ok(())
        }
        fn reset(&mut self) {}
    }
}
