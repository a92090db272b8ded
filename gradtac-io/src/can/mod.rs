//! CAN bus sources: a declarative frame codec, reassembly of taxel frames from several CAN
//! frames, fault statistics, and the sources that feed them — candump logs, an in-memory
//! transport and (on Linux) a live SocketCAN interface.
//!
//! ```text
//! candump log ──CandumpReader──┐
//! frame_channel ──FrameReceiver─┼──> CanFrame ──CanDecoder (codec + reassembly + stats)──> TaxelFrame
//! SocketCAN ──SocketCanFrames───┘        (sync Stage; CanStream is its async shell)
//! ```
//!
//! - [`CanFrame`]: a classic CAN frame (id, standard/extended, ≤ 8 bytes, time) with no
//!   driver types in it.
//! - [`CodecConfig`] / [`CanCodec`]: which ids carry which taxels and how values are packed;
//!   presets `syntouch-biotac` and `xela-uskin` (the public framings, with their sources) and
//!   `biotac-mux` (our own) ([`presets`]); serde shape in `docs/can.md`.
//! - [`CanDecoder`]: the synchronous [`Stage`](gradtac_stream::Stage) from CAN frames to
//!   taxel frames, with per-sensor timeout and [`IncompletePolicy`]; never fails on traffic,
//!   counts faults in [`CanStats`].
//! - [`CandumpSource`] (iterator), [`candump::replay`] (tokio stream with original or fast
//!   timing), [`frame_channel`] + [`CanStream`] (in-memory), `socketcan::open` (live).
//! - The way back ([`encode`]): [`CanEncoder`] / [`CanCodec::encode`] turn taxel values into
//!   the CAN frames the codec decodes back to them (simulated hands, replay onto a bus), and
//!   [`CandumpWriter`] / [`write_candump`] write frames as a `candump -l` log.

pub mod candump;
pub mod codec;
pub mod encode;
pub mod frame;
pub mod presets;
pub mod reassembly;
#[cfg(target_os = "linux")]
pub mod socketcan;
pub mod stats;
pub mod stream;
pub mod transport;

pub use candump::{write_candump, CandumpConfig, CandumpReader, CandumpSource, CandumpStats, CandumpWriter, FdPolicy};
pub use codec::{
    ByteOrder, CanCodec, CodecConfig, IncompletePolicy, MessageSpec, MuxSpec, PresetConfig, PresetKind, SensorSpec,
};
pub use encode::{CanEncoder, EncodeStats, OutOfRangePolicy};
pub use frame::CanFrame;
pub use reassembly::{CanDecoder, DecodedFrame, FlaggedDecoder};
pub use stats::{CanStats, Fault, FaultKind, FaultSite, StatsHandle};
pub use stream::{CanStream, FlaggedCanStream, Timing};
pub use transport::{frame_channel, FrameReceiver, FrameSender};
