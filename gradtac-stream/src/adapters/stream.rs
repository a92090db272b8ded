//! A stage over a [`futures::Stream`].

use crate::Stage;
use futures::Stream;
use pin_project_lite::pin_project;
use std::collections::VecDeque;
use std::pin::Pin;
use std::task::{Context, Poll};

pin_project! {
    /// Stream adapter for [`StreamStageExt::stage`]: pushes each `Ok` item of the inner stream
    /// through the stage and yields its outputs; at the end of the inner stream it yields what
    /// [`Stage::finish`] flushes. The first error is yielded once, then the stream ends.
    ///
    /// The stage runs inline in `poll_next`: stages are microseconds of CPU per input, so no
    /// blocking thread is needed.
    #[must_use = "streams do nothing unless polled"]
    pub struct StageStream<St, S: Stage> {
        #[pin]
        inner: St,
        stage: S,
        buf: Vec<S::Out>,
        ready: VecDeque<S::Out>,
        done: bool,
    }
}

impl<St, S: Stage> StageStream<St, S> {
    /// The stage being driven (named `stage_ref` so that it never shadows
    /// [`StreamStageExt::stage`]).
    pub fn stage_ref(&self) -> &S {
        &self.stage
    }

    /// The inner stream.
    pub fn inner(&self) -> &St {
        &self.inner
    }
}

impl<St, S, E> Stream for StageStream<St, S>
where
    St: Stream<Item = Result<S::In, E>>,
    S: Stage,
    S::Error: Into<E>,
{
    type Item = Result<S::Out, E>;

    fn poll_next(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Self::Item>> {
        let mut this = self.project();
        loop {
            if let Some(x) = this.ready.pop_front() {
                return Poll::Ready(Some(Ok(x)));
            }
            if *this.done {
                return Poll::Ready(None);
            }
            let r = match futures::ready!(this.inner.as_mut().poll_next(cx)) {
                Some(Ok(x)) => this.stage.push(x, this.buf),
                Some(Err(e)) => {
                    *this.done = true;
                    return Poll::Ready(Some(Err(e)));
                }
                None => {
                    *this.done = true;
                    this.stage.finish(this.buf)
                }
            };
            this.ready.extend(this.buf.drain(..));
            if let Err(e) = r {
                *this.done = true;
                this.ready.clear();
                return Poll::Ready(Some(Err(e.into())));
            }
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.ready.len(), None)
    }
}

/// A stream of plain items as `Ok` items of the common [`Error`](crate::Error): the input of
/// [`StreamStageExt::stage_plain`].
pub type PlainStream<St> =
    futures::stream::Map<St, fn(<St as Stream>::Item) -> Result<<St as Stream>::Item, crate::Error>>;

/// Runs stages over streams; implemented for every stream. The stream form of
/// [`IteratorStageExt`](crate::IteratorStageExt), with the same two entry points: `stage` for
/// `Result` items (a `TryStream`: the output keeps the input's error type, the stage's error
/// converts into it) and `stage_plain` for plain items.
///
/// ```
/// use futures::{stream, StreamExt};
/// use gradtac_stream::{map_stage, StreamStageExt};
/// let out: Vec<Result<i32, gradtac_stream::Error>> = futures::executor::block_on(
///     stream::iter([1, 2]).stage_plain(map_stage(|x: i32| x * 10)).stage(map_stage(|x: i32| x + 1)).collect(),
/// );
/// assert_eq!(out.into_iter().map(Result::unwrap).collect::<Vec<_>>(), vec![11, 21]);
/// ```
pub trait StreamStageExt: Stream + Sized {
    /// Drive `stage` with this stream's `Result` items (see [`StageStream`]).
    fn stage<S, E>(self, stage: S) -> StageStream<Self, S>
    where
        Self: Stream<Item = Result<S::In, E>>,
        S: Stage,
        S::Error: Into<E>,
    {
        StageStream { inner: self, stage, buf: Vec::new(), ready: VecDeque::new(), done: false }
    }

    /// Drive `stage` with this stream's plain (not `Result`) items; the outputs are
    /// `Result<S::Out, gradtac_stream::Error>`.
    fn stage_plain<S>(self, stage: S) -> StageStream<PlainStream<Self>, S>
    where
        S: Stage<In = Self::Item>,
        S::Error: Into<crate::Error>,
    {
        let ok: fn(Self::Item) -> Result<Self::Item, crate::Error> = Ok;
        futures::StreamExt::map(self, ok).stage(stage)
    }
}

impl<St: Stream> StreamStageExt for St {}
