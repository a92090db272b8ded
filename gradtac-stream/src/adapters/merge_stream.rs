//! Time-ordered merge of streams.

use crate::merge::MergeCore;
use crate::Timed;
use futures::Stream;
use std::pin::Pin;
use std::task::{Context, Poll};

/// Stream returned by [`merge_streams`].
#[must_use = "streams do nothing unless polled"]
pub struct MergeStreams<S, T> {
    sources: Vec<S>,
    core: MergeCore<T>,
    failed: bool,
}

/// Merge streams of time-ordered `Result` items into one time-ordered stream, queueing at
/// most `capacity` items per source (see [`crate::merge`] for the order rule). Sources are
/// polled concurrently: while the merge waits for a slow source, the others fill their
/// queues up to `capacity` and then are not polled (back-pressure). The first error of any
/// source is yielded once, then the merge ends.
///
/// Sources must be `Unpin`; box others with `Box::pin`.
pub fn merge_streams<S, T, E>(sources: Vec<S>, capacity: usize) -> MergeStreams<S, T>
where
    S: Stream<Item = Result<T, E>> + Unpin,
    T: Timed,
{
    let core = MergeCore::new(sources.len(), capacity);
    MergeStreams { sources, core, failed: false }
}

impl<S, T, E> Stream for MergeStreams<S, T>
where
    S: Stream<Item = Result<T, E>> + Unpin,
    T: Timed + Unpin,
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
            let mut progressed = false;
            for i in 0..this.sources.len() {
                while this.core.wants(i) {
                    match Pin::new(&mut this.sources[i]).poll_next(cx) {
                        Poll::Ready(Some(Ok(x))) => {
                            this.core.push(i, x);
                            progressed = true;
                        }
                        Poll::Ready(Some(Err(e))) => {
                            this.failed = true;
                            return Poll::Ready(Some(Err(e)));
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
