//! The Parquet encoder on a thread of its own: [`ParquetSink::with_writer_thread`]
//! (see there for when to use it).
//!
//! The pushing thread builds Arrow batches of records as before and hands each finished
//! batch over a channel of one slot; this thread encodes, compresses and writes it
//! ([`ArrowWriter::write`], closing row groups as they fill), then, on close, writes the
//! footer and `fsync`s. At most one batch waits in the channel and one is being written, so
//! memory stays bounded and a writer slower than the stream slows the pusher down (it waits
//! for the slot) instead of queueing without end.
//!
//! [`ParquetSink::with_writer_thread`]: super::ParquetSink::with_writer_thread

use super::{bound_row_group, finish_writer};
use crate::records::arrow_error;
use crate::{Error, Result};
use arrow_array::RecordBatch;
use parquet::arrow::ArrowWriter;
use parquet::file::metadata::KeyValue;
use std::fs::File;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{sync_channel, SyncSender};
use std::sync::Arc;
use std::thread::JoinHandle;

enum Msg {
    Batch(RecordBatch),
    Close(Vec<KeyValue>),
}

/// An [`ArrowWriter`] running on its own thread.
pub(super) struct WriterThread {
    tx: Option<SyncSender<Msg>>,
    thread: Option<JoinHandle<Result<()>>>,
    /// Bytes written plus the open row group's estimate, after the last batch written.
    size: Arc<AtomicU64>,
    context: String,
}

impl WriterThread {
    /// Start the thread that owns `writer`; `context` (the file) names it in errors.
    pub(super) fn spawn(writer: ArrowWriter<File>, context: String) -> Result<Self> {
        let (tx, rx) = sync_channel::<Msg>(1);
        let size = Arc::new(AtomicU64::new(0));
        let (seen, ctx) = (size.clone(), context.clone());
        let thread = std::thread::Builder::new()
            .name("gradtac-parquet".into())
            .spawn(move || -> Result<()> {
                let mut w = writer;
                // a closed channel without `Close` (the sink was dropped): leave the file as
                // it is, like a sink dropped on the pushing thread
                while let Ok(msg) = rx.recv() {
                    match msg {
                        Msg::Batch(b) => {
                            w.write(&b).map_err(|e| arrow_error(ctx.as_str(), e))?;
                            bound_row_group(&mut w, &ctx)?;
                            seen.store((w.bytes_written() + w.in_progress_size()) as u64, Ordering::Relaxed);
                        }
                        Msg::Close(metadata) => {
                            finish_writer(&mut w, metadata, &ctx)?;
                            seen.store(w.bytes_written() as u64, Ordering::Relaxed);
                            return Ok(());
                        }
                    }
                }
                Ok(())
            })
            .map_err(|source| Error::Io { path: PathBuf::from(context.as_str()), source })?;
        Ok(WriterThread { tx: Some(tx), thread: Some(thread), size, context })
    }

    /// Hand one batch to the thread, waiting while the previous one still fills the slot.
    /// When the thread has stopped on an error, returns that error.
    pub(super) fn write(&mut self, batch: RecordBatch) -> Result<()> {
        let sent = self.tx.as_ref().map(|tx| tx.send(Msg::Batch(batch)));
        match sent {
            Some(Ok(())) => Ok(()),
            _ => Err(self.join()),
        }
    }

    /// Write the footer with `metadata`, `fsync`, and end the thread: its first error, if any.
    pub(super) fn close(&mut self, metadata: Vec<KeyValue>) -> Result<()> {
        let sent = self.tx.take().map(|tx| tx.send(Msg::Close(metadata)));
        match sent {
            Some(Ok(())) => match self.thread.take().map(|t| t.join()) {
                Some(Ok(result)) => result,
                Some(Err(panic)) => std::panic::resume_unwind(panic),
                None => Err(self.stopped()),
            },
            _ => Err(self.join()),
        }
    }

    /// The size estimate as of the last batch the thread wrote (batches still in the channel
    /// or being written are not counted).
    pub(super) fn estimated_size(&self) -> u64 {
        self.size.load(Ordering::Relaxed)
    }

    /// The thread's error after it stopped early (the channel is closed).
    fn join(&mut self) -> Error {
        self.tx = None;
        match self.thread.take().map(|t| t.join()) {
            Some(Ok(Err(e))) => e,
            Some(Err(panic)) => std::panic::resume_unwind(panic),
            Some(Ok(Ok(()))) | None => self.stopped(),
        }
    }

    fn stopped(&self) -> Error {
        arrow_error(self.context.as_str(), "the writer thread has stopped")
    }
}

impl Drop for WriterThread {
    /// Close the channel and wait for the thread, so that when a dropped sink is gone its
    /// thread no longer touches the file (the file is left as it is, without a footer).
    fn drop(&mut self) {
        self.tx = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use arrow_array::{Float64Array, Int64Array};
    use arrow_schema::{DataType, Field, Schema};

    fn batch(name: &str, dt: DataType, n: i64) -> RecordBatch {
        let schema = Arc::new(Schema::new(vec![Field::new(name, dt.clone(), false)]));
        let col: arrow_array::ArrayRef = match dt {
            DataType::Int64 => Arc::new(Int64Array::from_iter_values(0..n)),
            _ => Arc::new(Float64Array::from_iter_values((0..n).map(|x| x as f64))),
        };
        RecordBatch::try_new(schema, vec![col]).unwrap()
    }

    fn writer(dir: &std::path::Path) -> ArrowWriter<File> {
        let file = File::create(dir.join("w.parquet")).unwrap();
        ArrowWriter::try_new(file, batch("x", DataType::Int64, 1).schema(), None).unwrap()
    }

    /// A batch the writer rejects stops the thread; the error (naming the file) comes back at
    /// the next hand-over and at close, never a panic or a hang.
    #[test]
    fn the_threads_error_surfaces_at_the_next_write_and_at_close() {
        let dir = tempfile::tempdir().unwrap();
        let mut t = WriterThread::spawn(writer(dir.path()), "w.parquet".into()).unwrap();
        t.write(batch("x", DataType::Int64, 10)).unwrap();
        // another schema: ArrowWriter::write fails on the thread
        let _ = t.write(batch("y", DataType::Float64, 10));
        let mut failed = None;
        for _ in 0..3 {
            if let Err(e) = t.write(batch("x", DataType::Int64, 10)) {
                failed = Some(e);
                break;
            }
        }
        let e = failed.expect("a write after the thread stopped fails");
        assert!(e.to_string().contains("w.parquet"), "{e}");
        assert!(t.close(Vec::new()).is_err(), "close after the failure fails");
    }

    /// Close writes the footer and the file reads back; the size estimate is that of the file.
    #[test]
    fn close_finishes_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let mut t = WriterThread::spawn(writer(dir.path()), "w.parquet".into()).unwrap();
        for _ in 0..3 {
            t.write(batch("x", DataType::Int64, 1000)).unwrap();
        }
        t.close(vec![KeyValue::new("k".to_string(), "v".to_string())]).unwrap();
        let size = std::fs::metadata(dir.path().join("w.parquet")).unwrap().len();
        assert_eq!(t.estimated_size(), size);
        let reader = parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(
            File::open(dir.path().join("w.parquet")).unwrap(),
        )
        .unwrap();
        assert_eq!(reader.metadata().file_metadata().num_rows(), 3000);
    }
}
