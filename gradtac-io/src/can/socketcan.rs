//! The live SocketCAN source (Linux): frames from a CAN interface through the `socketcan`
//! crate's tokio socket, decoded by [`CanStream`].
//!
//! Frames are stamped with the kernel's receive time (`SO_TIMESTAMPNS`, ns since the Unix
//! epoch, the [`Timestamp`] rule for live sources). Remote and error frames are skipped
//! (counted at `DEBUG` in the log). Sets that time out while the bus is quiet are closed on the
//! system clock ([`CanStream::with_wall_clock_expiry`]).
//!
//! Opening fails with [`Error::CanInterface`] naming the interface and the OS reason. On a
//! kernel without CAN support (no `CONFIG_CAN`, as on the machines this crate is built on)
//! every CAN socket fails with `EAFNOSUPPORT`, "Address family not supported by protocol";
//! the error then says so even when the interface does not exist either.

use crate::can::codec::{CanCodec, CodecConfig};
use crate::can::frame::CanFrame;
use crate::can::reassembly::CanDecoder;
use crate::can::stream::CanStream;
use crate::{Error, Result};
use futures::stream::BoxStream;
use futures::{Stream, StreamExt};
use gradtac_stream::Timestamp;
use serde::{Deserialize, Serialize};
use socketcan::{EmbeddedFrame, Frame, Socket, SocketOptions};
use std::pin::Pin;
use std::task::{Context, Poll};
use std::time::SystemTime;

/// `EAFNOSUPPORT` on Linux.
const EAFNOSUPPORT: i32 = 97;

/// A scene's live CAN source.
///
/// ```toml
/// [sources.hand]
/// interface = "can0"
/// [sources.hand.codec.preset]
/// kind = "biotac-mux"
/// sensors = ["ff", "mf", "th"]
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SocketCanConfig {
    /// The interface name (`can0`, `vcan0`).
    pub interface: String,
    /// The frame codec.
    pub codec: CodecConfig,
}

/// Raw CAN frames from an interface (a [`Stream`] of [`CanFrame`]s); see the module docs.
#[must_use = "streams do nothing unless polled"]
pub struct SocketCanFrames {
    interface: String,
    inner: BoxStream<'static, Result<CanFrame>>,
}

impl std::fmt::Debug for SocketCanFrames {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SocketCanFrames").field("interface", &self.interface).finish_non_exhaustive()
    }
}

fn open_error(interface: &str, e: std::io::Error) -> Error {
    let mut action = String::from("cannot open a CAN socket");
    if e.raw_os_error() == Some(EAFNOSUPPORT) {
        action.push_str(
            " (this kernel has no SocketCAN support: CONFIG_CAN is not set or the can/can_raw modules are not loaded)",
        );
    } else if e.raw_os_error() == Some(19) {
        action.push_str(" (no such network interface; `ip link show` lists them)");
    }
    Error::CanInterface { interface: interface.to_owned(), action, source: e }
}

impl SocketCanFrames {
    /// Open `interface`. Must be called inside a tokio runtime with I/O enabled (an error
    /// otherwise, not a panic).
    pub fn open(interface: &str) -> Result<Self> {
        if tokio::runtime::Handle::try_current().is_err() {
            return Err(Error::CanInterface {
                interface: interface.to_owned(),
                action: "cannot open outside a tokio runtime".into(),
                source: std::io::Error::other("no tokio runtime"),
            });
        }
        let socket = match socketcan::tokio::CanSocket::open(interface) {
            Ok(s) => s,
            Err(e) => {
                // A missing interface hides a kernel without CAN: probe the address family
                // (interface index 0, bound to no interface in particular).
                if e.raw_os_error() != Some(EAFNOSUPPORT) {
                    if let Err(probe) = socketcan::CanSocket::open_iface(0) {
                        if probe.raw_os_error() == Some(EAFNOSUPPORT) {
                            return Err(open_error(interface, probe));
                        }
                    }
                }
                return Err(open_error(interface, e));
            }
        };
        socket.set_recv_timestamp(true).map_err(|e| Error::CanInterface {
            interface: interface.to_owned(),
            action: "cannot enable receive timestamps (SO_TIMESTAMPNS)".into(),
            source: e,
        })?;
        let name = interface.to_owned();
        let inner = futures::stream::unfold(Some(socket), move |state| {
            let name = name.clone();
            async move {
                let socket = state?;
                loop {
                    match socket.read_frame_with_timestamp().await {
                        Ok((frame, at)) => {
                            let socketcan::CanFrame::Data(d) = frame else {
                                tracing::debug!(target: "gradtac_io::can", interface = %name, "skipped a remote or error frame");
                                continue;
                            };
                            let time = at.duration_since(SystemTime::UNIX_EPOCH).map_or(0, |x| x.as_nanos() as i64);
                            let r = CanFrame::try_new(d.raw_id(), d.is_extended(), d.data(), Timestamp(time));
                            return Some((r, Some(socket)));
                        }
                        Err(e) => {
                            let err =
                                Error::CanInterface { interface: name.clone(), action: "read failed".into(), source: e };
                            return Some((Err(err), None));
                        }
                    }
                }
            }
        })
        .boxed();
        Ok(SocketCanFrames { interface: interface.to_owned(), inner })
    }

    /// The interface name.
    pub fn interface(&self) -> &str {
        &self.interface
    }
}

impl Stream for SocketCanFrames {
    type Item = Result<CanFrame>;

    fn poll_next(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Self::Item>> {
        self.inner.poll_next_unpin(cx)
    }
}

/// Open the live source a scene describes: taxel frames decoded from `interface`, with sets
/// expiring on the system clock while the bus is quiet.
pub fn open(config: &SocketCanConfig) -> Result<CanStream<SocketCanFrames>> {
    let codec = CanCodec::try_new(&config.codec)?;
    let frames = SocketCanFrames::open(&config.interface)?;
    Ok(CanStream::new(frames, CanDecoder::new(codec)).with_wall_clock_expiry())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::can::codec::{PresetConfig, PresetKind};

    /// True when this kernel has SocketCAN (`/proc/net/can` exists with CONFIG_CAN).
    fn kernel_has_can() -> bool {
        std::path::Path::new("/proc/net/can").exists()
    }

    #[tokio::test]
    async fn opening_fails_with_interface_and_os_reason() {
        for iface in ["can0", "lo", "gtnosuchif0"] {
            let e = SocketCanFrames::open(iface).unwrap_err();
            let text = e.to_string();
            eprintln!("{text}");
            assert!(text.starts_with(&format!("CAN interface {iface:?}: cannot open a CAN socket")), "{text}");
            let Error::CanInterface { source, .. } = &e else { panic!("{e:?}") };
            assert!(source.raw_os_error().is_some(), "{text}");
            if !kernel_has_can() {
                // this machine: no CONFIG_CAN
                assert_eq!(source.raw_os_error(), Some(EAFNOSUPPORT), "{text}");
                assert!(text.contains("Address family not supported"), "{text}");
                assert!(text.contains("no SocketCAN support"), "{text}");
            }
        }
        let cfg = SocketCanConfig {
            interface: "can0".into(),
            codec: CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &["ff"])),
        };
        assert!(open(&cfg).unwrap_err().to_string().contains("\"can0\""));
    }

    #[test]
    fn opening_outside_a_runtime_is_an_error() {
        let e = SocketCanFrames::open("can0").unwrap_err().to_string();
        assert!(e.contains("outside a tokio runtime"), "{e}");
    }
}
