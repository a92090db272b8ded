//! An in-memory CAN transport: a bounded channel pair that carries [`CanFrame`]s from a
//! producer (a test, a simulator, a host application's own bus driver) to a [`CanStream`].
//!
//! ```
//! use futures::StreamExt;
//! use gradtac_io::can::{frame_channel, CanCodec, CanDecoder, CanFrame, CanStream, CodecConfig, PresetConfig, PresetKind};
//! use gradtac_stream::Timestamp;
//!
//! # tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap().block_on(async {
//! let codec = CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &["ff"])))?;
//! let (tx, rx) = frame_channel(64);
//! let mut taxels = CanStream::new(rx, CanDecoder::new(codec));
//! tokio::spawn(async move {
//!     for m in 0..6u8 {
//!         let f = CanFrame::standard(0x100, &[m, 0x10, 0x01, 0x00, 0x10, 0x01, 0x00, 0], Timestamp(m as i64)).unwrap();
//!         tx.send(f).await.unwrap();
//!     }
//! }); // dropping the sender ends the stream
//! let frame = taxels.next().await.unwrap()?;
//! assert_eq!(frame.values, vec![256.0; 24]);
//! assert!(taxels.next().await.is_none());
//! # Ok::<(), gradtac_io::Error>(())
//! # }).unwrap();
//! ```
//!
//! [`CanStream`]: super::CanStream

use crate::can::frame::CanFrame;
use crate::{Error, Result};
use futures::Stream;
use std::pin::Pin;
use std::task::{Context, Poll};
use tokio::sync::mpsc;

/// A bounded channel for CAN frames (`capacity` ≥ 1 frames wait at most; senders then wait:
/// backpressure).
pub fn frame_channel(capacity: usize) -> (FrameSender, FrameReceiver) {
    let (tx, rx) = mpsc::channel(capacity.max(1));
    (FrameSender(tx), FrameReceiver(rx))
}

/// The sending half of [`frame_channel`]; clone it for several producers. Dropping every
/// sender ends the receiver's stream.
#[derive(Clone, Debug)]
pub struct FrameSender(mpsc::Sender<Result<CanFrame>>);

/// The error of a send when the receiver is gone; gives the frame back.
#[derive(Debug, thiserror::Error)]
#[error("the CAN frame receiver was dropped")]
pub struct Closed(pub CanFrame);

impl FrameSender {
    /// Send a frame, waiting while the channel is full.
    pub async fn send(&self, frame: CanFrame) -> std::result::Result<(), Closed> {
        self.0.send(Ok(frame)).await.map_err(|e| Closed(unwrap_frame(e.0)))
    }

    /// Send from synchronous code (a driver thread), blocking while the channel is full.
    /// Must not be called from inside an async task.
    pub fn blocking_send(&self, frame: CanFrame) -> std::result::Result<(), Closed> {
        self.0.blocking_send(Ok(frame)).map_err(|e| Closed(unwrap_frame(e.0)))
    }

    /// Send without waiting; `Ok(false)` when the channel is full (the frame is not sent).
    pub fn try_send(&self, frame: CanFrame) -> std::result::Result<bool, Closed> {
        match self.0.try_send(Ok(frame)) {
            Ok(()) => Ok(true),
            Err(mpsc::error::TrySendError::Full(_)) => Ok(false),
            Err(mpsc::error::TrySendError::Closed(e)) => Err(Closed(unwrap_frame(e))),
        }
    }

    /// Report a transport failure: the receiver yields it and ends.
    pub async fn send_error(&self, error: Error) -> std::result::Result<(), Error> {
        self.0.send(Err(error)).await.map_err(|e| match e.0 {
            Err(e) => e,
            Ok(_) => unreachable!("an error was sent"),
        })
    }
}

fn unwrap_frame(r: Result<CanFrame>) -> CanFrame {
    match r {
        Ok(f) => f,
        Err(_) => unreachable!("a frame was sent"),
    }
}

/// The receiving half of [`frame_channel`]: a [`Stream`] of frames that ends when every
/// sender is dropped, or after yielding an error sent with [`FrameSender::send_error`].
#[derive(Debug)]
#[must_use = "streams do nothing unless polled"]
pub struct FrameReceiver(mpsc::Receiver<Result<CanFrame>>);

impl Stream for FrameReceiver {
    type Item = Result<CanFrame>;

    fn poll_next(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Self::Item>> {
        let r = self.0.poll_recv(cx);
        if let Poll::Ready(Some(Err(_))) = &r {
            self.0.close();
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use futures::StreamExt;
    use gradtac_stream::Timestamp;

    fn fr(i: u32) -> CanFrame {
        CanFrame::standard(i, &[i as u8], Timestamp(i as i64)).unwrap()
    }

    #[tokio::test]
    async fn carries_frames_in_order_and_ends_with_the_senders() {
        let (tx, rx) = frame_channel(2);
        let tx2 = tx.clone();
        let h = tokio::spawn(async move {
            for i in 0..10 {
                tx.send(fr(i)).await.unwrap();
            }
        });
        drop(tx2);
        let got: Vec<u32> = rx.map(|f| f.unwrap().id()).collect().await;
        h.await.unwrap();
        assert_eq!(got, (0..10).collect::<Vec<_>>());
    }

    #[tokio::test]
    async fn try_send_reports_full_and_closed() {
        let (tx, mut rx) = frame_channel(1);
        assert!(tx.try_send(fr(1)).unwrap());
        assert!(!tx.try_send(fr(2)).unwrap());
        assert_eq!(rx.next().await.unwrap().unwrap().id(), 1);
        drop(rx);
        assert_eq!(tx.try_send(fr(3)).unwrap_err().0.id(), 3);
        assert!(tx.send(fr(4)).await.is_err());
    }

    #[tokio::test]
    async fn an_error_ends_the_stream() {
        let (tx, rx) = frame_channel(4);
        tx.send(fr(1)).await.unwrap();
        tx.send_error(Error::InvalidConfig("bus off".into())).await.unwrap();
        let got: Vec<Result<CanFrame>> = rx.collect().await;
        assert_eq!(got.len(), 2);
        assert!(got[1].as_ref().unwrap_err().to_string().contains("bus off"));
    }
}
