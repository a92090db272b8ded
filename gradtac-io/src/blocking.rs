//! Run a blocking iterator (a file reader) as a tokio-fed [`Stream`].
//!
//! [`blocking_stream`] moves the iterator onto tokio's blocking thread pool
//! ([`tokio::task::spawn_blocking`]); items travel through a bounded
//! [`tokio::sync::mpsc`] channel, so the reader runs at most `capacity` items ahead of the
//! consumer and the async side never blocks on file I/O.

use futures::Stream;
use std::future::Future;
use std::pin::Pin;
use std::task::{Context, Poll};
use tokio::sync::mpsc;
use tokio::task::JoinHandle;
use tokio_stream::wrappers::ReceiverStream;

/// Stream returned by [`blocking_stream`].
#[must_use = "streams do nothing unless polled"]
#[derive(Debug)]
pub struct BlockingStream<T, E> {
    rx: ReceiverStream<Result<T, E>>,
    task: Option<JoinHandle<()>>,
}

/// Run `iter` on tokio's blocking pool and yield its items as a [`Stream`].
///
/// - At most `capacity` items (at least 1) wait in the channel; the reader thread blocks
///   (`blocking_send`) while it is full — backpressure, constant memory.
/// - The first `Err` item is forwarded and then reading stops, so the stream yields it once
///   and ends (the gradtac error rule).
/// - Dropping the stream stops the reader at its next item: the pending `blocking_send`
///   fails and the iterator is dropped on its thread.
/// - A panic in the iterator is resumed in the task that polls the stream when the stream
///   reaches its end, rather than ending the stream silently as if the input were complete.
///
/// # Panics
/// Like [`tokio::task::spawn_blocking`], when called outside a tokio runtime.
///
/// ```
/// use futures::StreamExt;
/// use gradtac_io::blocking::blocking_stream;
///
/// # tokio::runtime::Builder::new_current_thread().build().unwrap().block_on(async {
/// let items: Vec<Result<u32, String>> = blocking_stream((0..5).map(Ok), 2).collect().await;
/// assert_eq!(items, [Ok(0), Ok(1), Ok(2), Ok(3), Ok(4)]);
/// # });
/// ```
pub fn blocking_stream<I, T, E>(iter: I, capacity: usize) -> BlockingStream<T, E>
where
    I: Iterator<Item = Result<T, E>> + Send + 'static,
    T: Send + 'static,
    E: Send + 'static,
{
    let (tx, rx) = mpsc::channel(capacity.max(1));
    let task = tokio::task::spawn_blocking(move || {
        for item in iter {
            let last = item.is_err();
            if tx.blocking_send(item).is_err() || last {
                break;
            }
        }
    });
    BlockingStream { rx: ReceiverStream::new(rx), task: Some(task) }
}

impl<T, E> Stream for BlockingStream<T, E> {
    type Item = Result<T, E>;

    fn poll_next(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Self::Item>> {
        let this = &mut *self;
        match Pin::new(&mut this.rx).poll_next(cx) {
            Poll::Ready(None) => {}
            other => return other,
        }
        // The channel closed: the reader is done. Surface a panic instead of a silent end.
        if let Some(task) = this.task.as_mut() {
            match Pin::new(task).poll(cx) {
                Poll::Pending => return Poll::Pending,
                Poll::Ready(result) => {
                    this.task = None;
                    if let Err(e) = result {
                        if e.is_panic() {
                            std::panic::resume_unwind(e.into_panic());
                        }
                    }
                }
            }
        }
        Poll::Ready(None)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.rx.size_hint().0, None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use futures::StreamExt;
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    use std::time::Duration;

    #[tokio::test]
    async fn yields_all_items_in_order() {
        let got: Vec<Result<usize, ()>> = blocking_stream((0..1000).map(Ok), 3).collect().await;
        assert_eq!(got, (0..1000).map(Ok).collect::<Vec<_>>());
    }

    #[tokio::test]
    async fn stops_after_the_first_error() {
        let src = vec![Ok(1), Err("bad"), Ok(3)].into_iter();
        let got: Vec<Result<i32, &str>> = blocking_stream(src, 1).collect().await;
        assert_eq!(got, [Ok(1), Err("bad")]);
    }

    /// Signals on a std channel when the iterator is dropped (on the reader thread).
    struct Watched {
        produced: Arc<AtomicUsize>,
        dropped: std::sync::mpsc::Sender<()>,
    }
    impl Iterator for Watched {
        type Item = Result<usize, ()>;
        fn next(&mut self) -> Option<Self::Item> {
            Some(Ok(self.produced.fetch_add(1, Ordering::SeqCst)))
        }
    }
    impl Drop for Watched {
        fn drop(&mut self) {
            let _ = self.dropped.send(());
        }
    }

    #[tokio::test]
    async fn stops_reading_when_the_receiver_is_dropped() {
        let produced = Arc::new(AtomicUsize::new(0));
        let (tx, dropped) = std::sync::mpsc::channel();
        let capacity = 4;
        let mut s = blocking_stream(Watched { produced: produced.clone(), dropped: tx }, capacity);
        for want in 0..3 {
            assert_eq!(s.next().await, Some(Ok(want)));
        }
        drop(s);
        // The endless iterator is dropped on its thread once the channel is closed.
        let ended = tokio::task::spawn_blocking(move || dropped.recv_timeout(Duration::from_secs(10))).await.unwrap();
        assert!(ended.is_ok(), "the reader did not stop after the stream was dropped");
        // It read at most: 3 consumed + `capacity` queued + 1 blocked in `blocking_send`.
        assert!(produced.load(Ordering::SeqCst) <= 3 + capacity + 1, "{}", produced.load(Ordering::SeqCst));
    }

    #[tokio::test]
    async fn a_reader_panic_is_not_a_silent_end() {
        let src = (0..3).map(|i| if i == 2 { panic!("reader broke") } else { Ok::<_, ()>(i) });
        let outcome = tokio::spawn(async move { blocking_stream(src, 1).collect::<Vec<_>>().await }).await;
        let e = outcome.unwrap_err();
        assert!(e.is_panic());
        let msg = e.into_panic();
        assert_eq!(msg.downcast_ref::<&str>(), Some(&"reader broke"));
    }
}
