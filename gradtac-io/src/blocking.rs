//! Run blocking file I/O beside an async pipeline: the thin async shell around gradtac-io's
//! synchronous sources and sinks.
//!
//! - [`blocking_stream`] moves an iterator (a file reader) onto tokio's blocking thread pool
//!   ([`tokio::task::spawn_blocking`]); items travel through a bounded
//!   [`tokio::sync::mpsc`] channel, so the reader runs at most `capacity` items ahead of the
//!   consumer and the async side never blocks on file I/O.
//! - [`blocking_sink`] does the converse for a [`ParquetSink`]: records sent from async code
//!   are written on the blocking pool.
//! - [`blocking_archive`] does the same for a [`ParquetArchive`]; dropping its handle
//!   finishes the archive's open files.

use crate::archive::ParquetArchive;
use crate::{ArrowRecord, Error, ParquetSink, Result as IoResult};
use futures::Stream;
use gradtac_stream::{HasSensor, Timed};
use std::future::Future;
use std::path::PathBuf;
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
/// Once a reader's channel has closed: wait for its task to end and re-raise its panic, if
/// it panicked (a panicking reader must not look like a short source).
fn reader_end(task: &mut Option<JoinHandle<()>>, cx: &mut Context<'_>) -> Poll<()> {
    if let Some(t) = task.as_mut() {
        let result = std::task::ready!(Pin::new(t).poll(cx));
        *task = None;
        if let Err(e) = result {
            if e.is_panic() {
                std::panic::resume_unwind(e.into_panic());
            }
        }
    }
    Poll::Ready(())
}

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
        reader_end(&mut this.task, cx).map(|()| None)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.rx.size_hint().0, None)
    }
}

/// Stream returned by [`blocking_stream_chunked`].
#[must_use = "streams do nothing unless polled"]
#[derive(Debug)]
pub struct ChunkedBlockingStream<T, E> {
    rx: mpsc::Receiver<Vec<Result<T, E>>>,
    chunk: std::vec::IntoIter<Result<T, E>>,
    task: Option<JoinHandle<()>>,
}

/// [`blocking_stream_chunked`] sends an item at once when the chunk before it went this long
/// ago: a source slower than this per item hands over every item as it comes.
pub const CHUNK_WAIT: std::time::Duration = std::time::Duration::from_millis(1);

/// [`blocking_stream`] for a reader that is usually ahead of its consumer (a file read as fast
/// as it goes): items cross the channel in chunks of up to `chunk` (at least 1), so the two
/// threads hand over (and wake each other) once per chunk instead of once per item — on a
/// fast source, that hand-over costs more than reading the item.
///
/// - A chunk is sent when it is full, when an item arrives [`CHUNK_WAIT`] or more after the
///   last send (so a slow source's items go one by one, as they come; the clock is read at
///   chunk lengths 1, 2, 4, …, so an item of a middling source waits at most about twice
///   `CHUNK_WAIT`), at the first `Err` item (then reading stops) and at the end. A reader that blocks inside `next` holds the
///   items it read within `CHUNK_WAIT` of the last send until its next item.
/// - At most `capacity` items (rounded up to whole chunks, at least one chunk) wait in the
///   channel, plus the chunk being filled: constant memory.
/// - Dropping the stream stops the reader when it next sends; a panic in the iterator is
///   resumed in the polling task, as in [`blocking_stream`].
///
/// # Panics
/// Like [`tokio::task::spawn_blocking`], when called outside a tokio runtime.
///
/// ```
/// use futures::StreamExt;
/// use gradtac_io::blocking::blocking_stream_chunked;
///
/// # tokio::runtime::Builder::new_current_thread().build().unwrap().block_on(async {
/// let items: Vec<Result<u32, String>> = blocking_stream_chunked((0..5).map(Ok), 4, 2).collect().await;
/// assert_eq!(items, [Ok(0), Ok(1), Ok(2), Ok(3), Ok(4)]);
/// # });
/// ```
pub fn blocking_stream_chunked<I, T, E>(iter: I, capacity: usize, chunk: usize) -> ChunkedBlockingStream<T, E>
where
    I: Iterator<Item = Result<T, E>> + Send + 'static,
    T: Send + 'static,
    E: Send + 'static,
{
    let chunk = chunk.max(1);
    let (tx, rx) = mpsc::channel(capacity.div_ceil(chunk).max(1));
    let task = tokio::task::spawn_blocking(move || {
        let mut buf = Vec::with_capacity(chunk);
        let mut sent = std::time::Instant::now();
        for item in iter {
            let last = item.is_err();
            buf.push(item);
            // the clock is read at chunk lengths 1, 2, 4, …: an item that comes CHUNK_WAIT after
            // the last send goes at once, later ones within twice their wait
            if last || buf.len() >= chunk || (buf.len().is_power_of_two() && sent.elapsed() >= CHUNK_WAIT) {
                let full = std::mem::replace(&mut buf, Vec::with_capacity(chunk));
                if tx.blocking_send(full).is_err() || last {
                    return;
                }
                sent = std::time::Instant::now();
            }
        }
        if !buf.is_empty() {
            let _ = tx.blocking_send(buf);
        }
    });
    ChunkedBlockingStream { rx, chunk: Vec::new().into_iter(), task: Some(task) }
}

// Nothing of the stream is pinned structurally: the receiver, the chunk and the task handle
// are all polled through `&mut`.
impl<T, E> Unpin for ChunkedBlockingStream<T, E> {}

impl<T, E> Stream for ChunkedBlockingStream<T, E> {
    type Item = Result<T, E>;

    fn poll_next(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Self::Item>> {
        let this = &mut *self;
        loop {
            if let Some(item) = this.chunk.next() {
                return Poll::Ready(Some(item));
            }
            match this.rx.poll_recv(cx) {
                Poll::Ready(Some(chunk)) => this.chunk = chunk.into_iter(),
                Poll::Ready(None) => break,
                Poll::Pending => return Poll::Pending,
            }
        }
        // The channel closed: the reader is done. Surface a panic instead of a silent end.
        reader_end(&mut this.task, cx).map(|()| None)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.chunk.len(), None)
    }
}

enum SinkMsg<T> {
    Record(T),
    Finish,
    Abort,
}

/// Handle returned by [`blocking_sink`]: send records, then [`finish`](Self::finish) or
/// [`abort`](Self::abort).
#[must_use = "a sink writes nothing final until `finish` is awaited"]
pub struct BlockingSink<T> {
    tx: mpsc::Sender<SinkMsg<T>>,
    task: JoinHandle<IoResult<PathBuf>>,
}

impl<T> std::fmt::Debug for BlockingSink<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BlockingSink").field("closed", &self.tx.is_closed()).finish_non_exhaustive()
    }
}

/// Run `sink` on tokio's blocking pool; feed it from async code through a bounded channel
/// of `capacity` records (at least 1).
///
/// The writer stops at its first error (a record that does not fit, an I/O error), aborting
/// the sink (the `.partial` file keeps the records written before): later
/// [`send`](BlockingSink::send)s fail, and [`finish`](BlockingSink::finish) returns that
/// error. Dropping the handle without `finish` or `abort` drops the sink, which leaves the
/// `.partial` file and never the final name.
///
/// # Panics
/// Like [`tokio::task::spawn_blocking`], when called outside a tokio runtime.
///
/// ```
/// use gradtac_io::blocking::blocking_sink;
/// use gradtac_io::{FrameShape, ParquetSink};
/// use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
///
/// # tokio::runtime::Builder::new_current_thread().build().unwrap().block_on(async {
/// let dir = tempfile::tempdir().unwrap();
/// let sink = ParquetSink::<TaxelFrame>::try_new(dir.path().join("f.parquet"), FrameShape::unnamed(1).unwrap()).unwrap();
/// let writer = blocking_sink(sink, 64);
/// for k in 0..10 {
///     writer.send(TaxelFrame::new(SensorId::new("ff"), Timestamp(k), k as u64, vec![k as f64])).await.unwrap();
/// }
/// let path = writer.finish().await.unwrap();
/// assert!(path.exists());
/// # });
/// ```
pub fn blocking_sink<T>(mut sink: ParquetSink<T>, capacity: usize) -> BlockingSink<T>
where
    T: ArrowRecord + Send + 'static,
{
    let (tx, mut rx) = mpsc::channel::<SinkMsg<T>>(capacity.max(1));
    let task = tokio::task::spawn_blocking(move || {
        while let Some(msg) = rx.blocking_recv() {
            match msg {
                SinkMsg::Record(r) => {
                    if let Err(e) = sink.push(&r) {
                        // Keep what was written readable under the `.partial` name.
                        let _ = sink.abort();
                        return Err(e);
                    }
                }
                SinkMsg::Finish => return sink.finish(),
                SinkMsg::Abort => return sink.abort(),
            }
        }
        // Every handle dropped without finish/abort: leave the `.partial` file.
        Err(Error::InvalidConfig(format!("{}: dropped before finish", sink.path().display())))
    });
    BlockingSink { tx, task }
}

impl<T: Send + 'static> BlockingSink<T> {
    /// Send one record, waiting while the channel is full. Fails when the writer has
    /// stopped (after an error; [`finish`](Self::finish) returns it).
    pub async fn send(&self, record: T) -> IoResult<()> {
        self.tx.send(SinkMsg::Record(record)).await.map_err(|_| stopped())
    }

    /// Write everything sent so far and complete the file ([`ParquetSink::finish`]);
    /// returns the final path, or the writer's first error.
    pub async fn finish(self) -> IoResult<PathBuf> {
        self.close(SinkMsg::Finish).await
    }

    /// Stop and keep what was sent in a valid `.partial` file ([`ParquetSink::abort`]);
    /// returns its path.
    pub async fn abort(self) -> IoResult<PathBuf> {
        self.close(SinkMsg::Abort).await
    }

    async fn close(self, msg: SinkMsg<T>) -> IoResult<PathBuf> {
        let _ = self.tx.send(msg).await; // if the writer stopped, its error is in the task
        match self.task.await {
            Ok(result) => result,
            Err(e) if e.is_panic() => std::panic::resume_unwind(e.into_panic()),
            Err(e) => Err(Error::InvalidConfig(format!("sink task cancelled: {e}"))),
        }
    }
}

enum ArchiveMsg<T> {
    Record(T),
    Roll,
    Finish,
    Abort,
}

/// Handle returned by [`blocking_archive`]: send records, then [`finish`](Self::finish).
#[must_use = "an archive's open files are finished when `finish` is awaited (or, unreported, on drop)"]
pub struct BlockingArchive<T> {
    tx: mpsc::Sender<ArchiveMsg<T>>,
    task: JoinHandle<IoResult<Vec<PathBuf>>>,
}

impl<T> std::fmt::Debug for BlockingArchive<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BlockingArchive").field("closed", &self.tx.is_closed()).finish_non_exhaustive()
    }
}

/// Run `archive` on tokio's blocking pool; feed it from async code through a bounded channel
/// of `capacity` records (at least 1).
///
/// - [`finish`](BlockingArchive::finish) writes everything sent and finishes every open
///   file under its final name; call it at the end of the stream, **and** when the stream
///   fails or is cancelled (e.g. the branch of a `tokio::select!` on Ctrl-C): the records
///   sent are valid data. It returns every file the archive finished, or the first error.
/// - The writer stops at its first error (a record that does not fit, an I/O error); it then
///   finishes the open files it can (see [`ParquetArchive::finish`]); later
///   [`send`](BlockingArchive::send)s fail and `finish` returns the error.
/// - **Drop** of the handle without `finish`/`abort` (a cancelled task, a panic in the
///   producer) is seen by the writer thread as a closed channel: it writes what was sent
///   and finishes the open files there, logging the outcome with `tracing` (an `error!`
///   when it fails, since no caller can receive it). A tokio runtime waits for its
///   blocking threads when it shuts down, so this completes before the runtime is gone —
///   but not if the process exits first (`std::process::exit`, a kill): then the open
///   files stay under their temporary names. Prefer awaiting `finish`.
///
/// # Panics
/// Like [`tokio::task::spawn_blocking`], when called outside a tokio runtime.
///
/// ```
/// use gradtac_io::archive::ParquetArchive;
/// use gradtac_io::blocking::blocking_archive;
/// use gradtac_io::FrameShape;
/// use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
///
/// # tokio::runtime::Builder::new_current_thread().build().unwrap().block_on(async {
/// let dir = tempfile::tempdir().unwrap();
/// let archive = ParquetArchive::<TaxelFrame>::try_new(dir.path(), FrameShape::unnamed(1).unwrap())
///     .unwrap()
///     .with_roll_rows(4)
///     .unwrap();
/// let writer = blocking_archive(archive, 64);
/// for k in 0..10 {
///     writer.send(TaxelFrame::new(SensorId::new("ff"), Timestamp(k), k as u64, vec![k as f64])).await.unwrap();
/// }
/// let files = writer.finish().await.unwrap();
/// assert_eq!(files.len(), 3); // 4 + 4 + 2 rows
/// # });
/// ```
pub fn blocking_archive<T>(mut archive: ParquetArchive<T>, capacity: usize) -> BlockingArchive<T>
where
    T: ArrowRecord + HasSensor + Timed + Send + 'static,
{
    let (tx, mut rx) = mpsc::channel::<ArchiveMsg<T>>(capacity.max(1));
    let task = tokio::task::spawn_blocking(move || {
        while let Some(msg) = rx.blocking_recv() {
            match msg {
                ArchiveMsg::Record(r) => {
                    if let Err(e) = archive.push(&r) {
                        if let Err(also) = archive.finish() {
                            tracing::error!(error = %also, "archive: finishing after an error failed too");
                        }
                        return Err(e);
                    }
                }
                ArchiveMsg::Roll => {
                    if let Err(e) = archive.roll() {
                        let _ = archive.finish();
                        return Err(e);
                    }
                }
                ArchiveMsg::Finish => return archive.finish(),
                ArchiveMsg::Abort => return archive.abort(),
            }
        }
        // Every handle dropped without finish/abort: a cancelled task or a panic upstream.
        let dir = archive.dir().display().to_string();
        match archive.finish() {
            Ok(files) => {
                tracing::warn!(archive = %dir, files = files.len(), "archive handle dropped: open files finished");
                Ok(files)
            }
            Err(e) => {
                tracing::error!(archive = %dir, error = %e, "archive handle dropped: finishing failed");
                Err(e)
            }
        }
    });
    BlockingArchive { tx, task }
}

impl<T: Send + 'static> BlockingArchive<T> {
    /// Send one record, waiting while the channel is full. Fails when the writer has
    /// stopped (after an error; [`finish`](Self::finish) returns it).
    pub async fn send(&self, record: T) -> IoResult<()> {
        self.tx.send(ArchiveMsg::Record(record)).await.map_err(|_| stopped())
    }

    /// Ask the writer to finish every open file now ([`ParquetArchive::roll`]), after the
    /// records sent before. Fails when the writer has stopped.
    pub async fn roll(&self) -> IoResult<()> {
        self.tx.send(ArchiveMsg::Roll).await.map_err(|_| stopped())
    }

    /// Write everything sent so far and finish every open file under its final name
    /// ([`ParquetArchive::finish`]); returns every file finished, or the writer's first error.
    pub async fn finish(self) -> IoResult<Vec<PathBuf>> {
        self.close(ArchiveMsg::Finish).await
    }

    /// Write everything sent so far and leave the open files closed but under their
    /// temporary names ([`ParquetArchive::abort`]); returns those paths.
    pub async fn abort(self) -> IoResult<Vec<PathBuf>> {
        self.close(ArchiveMsg::Abort).await
    }

    async fn close(self, msg: ArchiveMsg<T>) -> IoResult<Vec<PathBuf>> {
        let _ = self.tx.send(msg).await; // if the writer stopped, its error is in the task
        match self.task.await {
            Ok(result) => result,
            Err(e) if e.is_panic() => std::panic::resume_unwind(e.into_panic()),
            Err(e) => Err(Error::InvalidConfig(format!("archive task cancelled: {e}"))),
        }
    }
}

fn stopped() -> Error {
    Error::InvalidConfig("the sink's writer has stopped; `finish` returns its error".into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use futures::StreamExt;
    use std::fs::File;
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

    #[tokio::test]
    async fn chunked_yields_all_items_in_order_and_stops_after_the_first_error() {
        for (capacity, chunk) in [(1, 1), (3, 2), (1024, 64), (5, 1000)] {
            let got: Vec<Result<usize, ()>> =
                blocking_stream_chunked((0..1000).map(Ok), capacity, chunk).collect().await;
            assert_eq!(got, (0..1000).map(Ok).collect::<Vec<_>>(), "capacity {capacity}, chunk {chunk}");
        }
        let src = vec![Ok(1), Err("bad"), Ok(3)].into_iter();
        let got: Vec<Result<i32, &str>> = blocking_stream_chunked(src, 8, 4).collect().await;
        assert_eq!(got, [Ok(1), Err("bad")]);
    }

    #[tokio::test]
    async fn chunked_stops_reading_when_the_receiver_is_dropped() {
        let produced = Arc::new(AtomicUsize::new(0));
        let (tx, dropped) = std::sync::mpsc::channel();
        let (capacity, chunk) = (8, 4);
        let mut s = blocking_stream_chunked(Watched { produced: produced.clone(), dropped: tx }, capacity, chunk);
        for want in 0..3 {
            assert_eq!(s.next().await, Some(Ok(want)));
        }
        drop(s);
        let ended = tokio::task::spawn_blocking(move || dropped.recv_timeout(Duration::from_secs(10))).await.unwrap();
        assert!(ended.is_ok(), "the reader did not stop after the stream was dropped");
        // at most: the chunk consumed from, `capacity` queued, and one chunk blocked in the send
        assert!(produced.load(Ordering::SeqCst) <= chunk + capacity + chunk, "{}", produced.load(Ordering::SeqCst));
    }

    /// A source slower than CHUNK_WAIT per item hands over each item as it comes, not after a
    /// full chunk (the reader then stalls for 3 s).
    #[tokio::test]
    async fn chunked_hands_over_a_slow_sources_items() {
        let src = (0..3).map(|i| {
            std::thread::sleep(CHUNK_WAIT * 3);
            Ok::<_, ()>(i)
        });
        let stall = std::iter::once_with(|| {
            std::thread::sleep(Duration::from_secs(3));
            Ok(99)
        });
        let mut s = blocking_stream_chunked(src.chain(stall), 1024, 1000);
        for want in 0..3 {
            let got = tokio::time::timeout(Duration::from_secs(2), s.next()).await;
            assert_eq!(got.ok().flatten(), Some(Ok(want)), "item {want} came only with the stalled one");
        }
    }

    #[tokio::test]
    async fn chunked_reader_panic_is_not_a_silent_end() {
        let src = (0..3).map(|i| if i == 2 { panic!("reader broke") } else { Ok::<_, ()>(i) });
        let outcome = tokio::spawn(async move { blocking_stream_chunked(src, 4, 2).collect::<Vec<_>>().await }).await;
        let e = outcome.unwrap_err();
        assert!(e.is_panic());
        assert_eq!(e.into_panic().downcast_ref::<&str>(), Some(&"reader broke"));
    }

    #[tokio::test]
    async fn blocking_sink_finishes_aborts_and_reports_errors() {
        use crate::FrameShape;
        use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
        let dir = tempfile::tempdir().unwrap();
        let frame = |k: u64, n: usize| TaxelFrame::new(SensorId::new("ff"), Timestamp(k as i64), k, vec![k as f64; n]);
        let new = |name: &str| {
            ParquetSink::<TaxelFrame>::try_new(dir.path().join(name), FrameShape::unnamed(2).unwrap()).unwrap()
        };

        let w = blocking_sink(new("ok.parquet"), 2);
        for k in 0..100 {
            w.send(frame(k, 2)).await.unwrap();
        }
        assert_eq!(w.finish().await.unwrap(), dir.path().join("ok.parquet"));

        let w = blocking_sink(new("ab.parquet"), 2);
        w.send(frame(0, 2)).await.unwrap();
        assert_eq!(w.abort().await.unwrap(), dir.path().join("ab.parquet.partial"));
        assert!(!dir.path().join("ab.parquet").exists());

        let w = blocking_sink(new("bad.parquet"), 1);
        w.send(frame(0, 2)).await.unwrap();
        let _ = w.send(frame(1, 3)).await; // accepted by the channel or refused: either way
        let mut refused = false;
        for k in 2..10 {
            refused |= w.send(frame(k, 2)).await.is_err();
        }
        assert!(refused, "sends fail once the writer stopped");
        let e = w.finish().await.unwrap_err();
        assert!(matches!(e, Error::Record { .. }), "{e}");
        assert!(!dir.path().join("bad.parquet").exists());
        let partial = File::open(dir.path().join("bad.parquet.partial")).unwrap();
        let rows = parquet::file::reader::FileReader::metadata(
            &parquet::file::reader::SerializedFileReader::new(partial).unwrap(),
        )
        .file_metadata()
        .num_rows();
        assert_eq!(rows, 1, "the frame before the bad one, in a readable file");

        let w = blocking_sink(new("drop.parquet"), 4);
        w.send(frame(0, 2)).await.unwrap();
        drop(w);
        assert!(!dir.path().join("drop.parquet").exists());
        assert!(dir.path().join("drop.parquet.partial").exists());
    }
}
