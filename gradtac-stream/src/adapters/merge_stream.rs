//! Time-ordered merge of streams.

use crate::merge::MergeCore;
use crate::Timed;
use futures::Stream;
use std::pin::Pin;
use std::task::{Context, Poll};

/// Stream returned by [`merge_streams`].
#[must_use = "streams do nothing unless polled"]
pub struct MergeStreams<S, T, E> {
    sources: Vec<S>,
    core: MergeCore<T>,
    /// A source's error, held until the items that source delivered before it are out.
    error: Option<(usize, E)>,
    failed: bool,
}

/// Merge streams of time-ordered `Result` items into one time-ordered stream, queueing at
/// most `capacity` items per source (see [`crate::merge`] for the order rule). Sources are
/// polled concurrently: while the merge waits for a slow source, the others fill their
/// queues up to `capacity` and then are not polled (back-pressure). The first error of any
/// source is yielded once, then the merge ends; the items that source delivered before its
/// error (and whatever the order rule releases before them) come out first.
///
/// Sources must be `Unpin`; box others with `Box::pin`.
pub fn merge_streams<S, T, E>(sources: Vec<S>, capacity: usize) -> MergeStreams<S, T, E>
where
    S: Stream<Item = Result<T, E>> + Unpin,
    T: Timed,
{
    let core = MergeCore::new(sources.len(), capacity);
    MergeStreams { sources, core, error: None, failed: false }
}

impl<S, T, E> Stream for MergeStreams<S, T, E>
where
    S: Stream<Item = Result<T, E>> + Unpin,
    T: Timed + Unpin,
    E: Unpin,
{
    type Item = Result<T, E>;

    fn poll_next(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Result<T, E>>> {
        let this = self.get_mut();
        if this.failed {
            return Poll::Ready(None);
        }
        loop {
            if let Some(x) = this.core.pop_ready() {
                return Poll::Ready(Some(Ok(x)));
            }
            if this.core.is_done() {
                return Poll::Ready(None);
            }
            if this.error.as_ref().is_some_and(|(i, _)| this.core.starved(*i)) {
                this.failed = true;
                return Poll::Ready(this.error.take().map(|(_, e)| Err(e)));
            }
            let mut progressed = false;
            for i in 0..this.sources.len() {
                while this.core.wants(i) && this.error.as_ref().is_none_or(|(j, _)| *j != i) {
                    match Pin::new(&mut this.sources[i]).poll_next(cx) {
                        Poll::Ready(Some(Ok(x))) => {
                            this.core.push(i, x);
                            progressed = true;
                        }
                        Poll::Ready(Some(Err(e))) => {
                            if this.error.is_none() {
                                this.error = Some((i, e));
                            } else {
                                // only the first error is reported; a second failing source just ends
                                this.core.end(i);
                            }
                            progressed = true;
                            break;
                        }
                        Poll::Ready(None) => {
                            this.core.end(i);
                            progressed = true;
                        }
                        Poll::Pending => break,
                    }
                }
            }
            if !progressed {
                // Every starved source returned Pending and registered our waker.
                return Poll::Pending;
            }
        }
    }
}
