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
    /// The stage being driven (its statistics, its [`delay`](Stage::delay)).
    ///
    /// Named `stage_ref`, not `stage`, so that it never shadows
    /// [`IteratorStageExt::stage`]: `it.stage(next)` on a `StageIter` always adds a stage.
    pub fn stage_ref(&self) -> &S {
        &self.stage
    }

    /// The stage being driven, mutably.
    pub fn stage_mut(&mut self) -> &mut S {
        &mut self.stage
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

/// An iterator of plain items as `Ok` items of the common [`Error`](crate::Error): the input
/// of [`IteratorStageExt::stage_plain`].
pub type PlainItems<I> = std::iter::Map<I, fn(<I as Iterator>::Item) -> Result<<I as Iterator>::Item, crate::Error>>;

/// Runs stages over iterators; implemented for every iterator.
///
/// Two entry points, as `futures` has `TryStreamExt` beside `StreamExt`:
///
/// - [`stage`](IteratorStageExt::stage) for iterators of `Result` items (every gradtac
///   source): the output keeps the input's error type `E`, and the stage's error must convert
///   into it (`S::Error: Into<E>`). The error types of gradtac's crates all convert into
///   [`gradtac_stream::Error`](crate::Error) and into `gradtac_io::Error`, so any gradtac
///   stage follows any gradtac source or stage, and `?` lifts the result into
///   `gradtac::Error` or `Box<dyn Error>`.
/// - [`stage_plain`](IteratorStageExt::stage_plain) for iterators of plain items (frames held
///   in a `Vec`): items become `Ok` items of [`gradtac_stream::Error`](crate::Error).
///
/// ```
/// use gradtac_stream::{map_stage, IteratorStageExt};
/// // plain items
/// let out: Result<Vec<i32>, gradtac_stream::Error> =
///     [1, 2, 3].into_iter().stage_plain(map_stage(|x: i32| x + 1)).collect();
/// assert_eq!(out.unwrap(), vec![2, 3, 4]);
/// // `Result` items: the error type is the input's; the first error ends the iterator
/// use gradtac_stream::Error;
/// let out: Result<Vec<i32>, Error> =
///     [Ok(1), Err(Error::UnknownLayout("bad".into()))].into_iter().stage(map_stage(|x: i32| x + 1)).collect();
/// assert!(matches!(out, Err(Error::UnknownLayout(_))));
/// ```
pub trait IteratorStageExt: Iterator + Sized {
    /// Drive `stage` with this iterator's `Result` items (see [`StageIter`]).
    fn stage<S, E>(self, stage: S) -> StageIter<Self, S>
    where
        Self: Iterator<Item = Result<S::In, E>>,
        S: Stage,
        S::Error: Into<E>,
    {
        StageIter { inner: self, stage, buf: Vec::new(), ready: VecDeque::new(), done: false }
    }

    /// Drive `stage` with this iterator's plain (not `Result`) items; the outputs are
    /// `Result<S::Out, gradtac_stream::Error>`, so further [`stage`](IteratorStageExt::stage)
    /// calls need no glue. Saves `.map(Ok::<_, gradtac_stream::Error>)`.
    fn stage_plain<S>(self, stage: S) -> StageIter<PlainItems<Self>, S>
    where
        S: Stage<In = Self::Item>,
        S::Error: Into<crate::Error>,
    {
        let ok: fn(Self::Item) -> Result<Self::Item, crate::Error> = Ok;
        self.map(ok).stage(stage)
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
        assert_eq!((it.inner().len(), it.stage_ref().0), (2, 1));
        assert_eq!(it.by_ref().map(Result::unwrap).collect::<Vec<_>>(), vec![2, 3]);
        assert_eq!((it.inner().len(), it.stage_ref().0), (0, 3));
        let d = format!("{it:?}");
        assert!(d.starts_with("StageIter { inner: ") && d.contains("stage: Counting(3), queued: 0, done: true"), "{d}");
    }

    /// `stage` on a `StageIter` adds a stage (no inherent method shadows it), and plain items
    /// need no `Ok` wrapping.
    #[test]
    fn stage_on_a_stage_iter_chains_and_plain_items_compose() {
        let it = [1u8, 2].into_iter().stage_plain(Counting(0)).stage(Counting(0)).stage(Counting(10));
        assert_eq!(it.stage_ref().0, 10);
        assert_eq!(it.inner().stage_ref().0, 0);
        let out: Vec<u8> = it.collect::<Result<_, _>>().unwrap();
        assert_eq!(out, [1, 2]);
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
