//! # Live latency: CAN frame → decode → two fingertip chains → slip decision
//!
//! Per-frame processing latency of the live path, measured over ≥ 100,000 taxel frames:
//!
//! ```text
//!  CAN frames (biotac-mux, encoded with gradtac-io's CanEncoder, 7 per fingertip per 10 ms)
//!    └─ CanDecoder::push ─> TaxelFrame ─> Keyed[ normalise → Savitzky–Golay → events → window
//!                                               → surface + maximal contour → track ] ─> Slip
//! ```
//!
//! The hand is the simulator's two-finger grasp that slips (thumb `th`, first finger `ff`),
//! tiled in time to the requested length. Every stage runs at its default settings (a bare
//! scene's: natural neighbour 64 × 64), with the sensor rate 100 Hz. The CAN frames are encoded
//! up front (that is the hand's work); the timed part is, per CAN frame, decoding it and — when
//! it completes a fingertip's set — pushing the taxel frame through that finger's chain and the
//! slip stage: the time from a CAN frame's arrival to the slip decision it allows.
//!
//! Two variants of the surface + contour step, measured alternately in blocks of 1,000 frames
//! (so both meet the same machine load):
//! - `peak`: [`SurfaceContour`](gradtac::stages::peak::SurfaceContour), evaluating only the grid
//!   points the maximal contour needs;
//! - `full`: `Interpolate` → `Contour`, the whole 64 × 64 surface every frame (what a scene runs).
//!
//! Output: p50 / p99 / p99.9 / max per variant over the taxel frames (the first 2,000 are
//! warm-up and not counted), and the number of slip events (the same in both variants: their
//! outputs are identical).
//!
//! Run: `cargo run --release --example latency [taxel_frames]` (default 100,000).

use gradtac::io::can::{CanCodec, CanDecoder, CanEncoder, CanFrame, CodecConfig, PresetConfig, PresetKind};
use gradtac::stages::contour::{Contour, ContourConfig};
use gradtac::stages::events::{Events, EventsConfig};
use gradtac::stages::interpolate::{Interpolate, InterpolateConfig};
use gradtac::stages::normalise::{Normalise, NormaliseConfig};
use gradtac::stages::peak::SurfaceContour;
use gradtac::stages::savgol::{SavGol, SavGolConfig};
use gradtac::stages::sim::{GraspConfig, Scene, SensorModel, Simulator};
use gradtac::stages::slip::{Slip, SlipClass, SlipConfig, SlipEvent, SlipEvidence};
use gradtac::stages::track::{Track, TrackConfig, TrackPoint};
use gradtac::stages::window::{Window, WindowAggregate, WindowConfig};
use gradtac::stream::{Keyed, Layout, SensorId, Stage, StageExt, TaxelFrame, Timestamp};
use std::time::Instant;

type BoxError = Box<dyn std::error::Error + Send + Sync>;

const RATE_HZ: f64 = 100.0;
const PERIOD_NS: i64 = 10_000_000;
const WARMUP: usize = 2_000;
const BLOCK: usize = 1_000;

fn front(
    n: usize,
) -> Result<impl Stage<In = TaxelFrame, Out = WindowAggregate, Error = gradtac::stream::Error> + Clone, BoxError> {
    Ok(Normalise::try_new(n, &NormaliseConfig::default())?
        .then(SavGol::try_with_rate(n, SavGolConfig::default(), RATE_HZ)?)
        .then(Events::try_new(n, EventsConfig::default())?)
        .then(Window::try_new(&WindowConfig::default())?))
}

/// One variant's live loop state: decoder and pipeline, and the latencies measured so far.
struct Loop<P> {
    decoder: CanDecoder,
    pipeline: P,
    taxels: Vec<TaxelFrame>,
    slips: Vec<SlipEvent>,
    latencies_ns: Vec<u64>,
    frames: usize,
    events: usize,
}

impl<P: Stage<In = TaxelFrame, Out = SlipEvent>> Loop<P>
where
    P::Error: std::fmt::Debug,
{
    /// Feed CAN frames until `n` more taxel frames came out; time each taxel frame's path.
    fn run(&mut self, can: &[CanFrame], cursor: &mut usize, n: usize) {
        let target = self.frames + n;
        while self.frames < target && *cursor < can.len() {
            let t0 = Instant::now();
            self.decoder.push(can[*cursor], &mut self.taxels).expect("valid CAN frames decode");
            *cursor += 1;
            if self.taxels.is_empty() {
                continue;
            }
            for f in self.taxels.drain(..) {
                self.pipeline.push(f, &mut self.slips).expect("the pipeline accepts decoded frames");
            }
            let dt = t0.elapsed().as_nanos() as u64;
            self.events += self.slips.len();
            self.slips.clear();
            if self.frames >= WARMUP {
                self.latencies_ns.push(dt);
            }
            self.frames += 1;
        }
    }
}

fn report(name: &str, latencies_ns: &mut [u64], events: usize) {
    latencies_ns.sort_unstable();
    let s = &*latencies_ns;
    println!(
        "{:<6} {:>9} {:>9.1} {:>9.1} {:>9.1} {:>9.1} {:>12}",
        name,
        s.len(),
        percentile(s, 0.5),
        percentile(s, 0.99),
        percentile(s, 0.999),
        *s.last().unwrap_or(&0) as f64 / 1e3,
        events
    );
}

fn percentile(sorted: &[u64], p: f64) -> f64 {
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted[i] as f64 / 1e3
}

fn main() -> Result<(), BoxError> {
    let wanted: usize = std::env::args().nth(1).map_or(Ok(100_000), |s| s.parse())?;
    let layout = Layout::biotac_sp();
    let scene = Scene::grasp(SlipClass::LongitudinalDown, &GraspConfig::default(), &layout);
    let recording = Simulator::try_new(layout.clone(), SensorModel::default(), 1)?.run(&scene)?;
    let sensors: Vec<&str> = recording.sensors.iter().map(SensorId::as_str).collect();
    let cycles: Vec<Vec<TaxelFrame>> =
        recording.taxel_frames().chunks(sensors.len()).map(<[TaxelFrame]>::to_vec).collect();

    // the hand: every cycle of both fingertips encoded, tiled in time to the wanted length
    let codec = CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(PresetKind::BiotacMux, &sensors)))?;
    let mut encoder = CanEncoder::new(codec.clone());
    let total_cycles = (wanted + WARMUP).div_ceil(sensors.len()) + 1;
    let mut can = Vec::new();
    for k in 0..total_cycles {
        for f in &cycles[k % cycles.len()] {
            let time = Timestamp(k as i64 * PERIOD_NS);
            encoder.encode_frame(&TaxelFrame { time, seq: k as u64, ..f.clone() }, &mut can)?;
        }
    }

    let n = layout.len();
    let icfg = InterpolateConfig::default();
    let ccfg = ContourConfig::default();
    let peak_chain = front(n)?
        .then(SurfaceContour::<WindowAggregate>::try_new(&icfg, &ccfg, &layout)?)
        .then(Track::try_new(&TrackConfig::default())?);
    let full_chain = front(n)?
        .then(Interpolate::try_new(&icfg, &layout)?)
        .then(Contour::try_new(&ccfg)?)
        .then(Track::try_new(&TrackConfig::default())?);
    // these pipelines end in tracks: the displacement rule on its track path
    let slip = Slip::try_new(&SlipConfig { evidence: SlipEvidence::Track, ..SlipConfig::default() })?;
    fn pipeline<S>(chain: S, slip: Slip) -> impl Stage<In = TaxelFrame, Out = SlipEvent, Error = gradtac::stream::Error>
    where
        S: Stage<In = TaxelFrame, Out = TrackPoint, Error = gradtac::stream::Error> + Clone,
    {
        Keyed::new(move |_: &SensorId| chain.clone()).then(slip)
    }
    let mut peak = Loop {
        decoder: CanDecoder::new(codec.clone()),
        pipeline: pipeline(peak_chain, slip.clone()),
        taxels: Vec::new(),
        slips: Vec::new(),
        latencies_ns: Vec::with_capacity(wanted),
        frames: 0,
        events: 0,
    };
    let mut full = Loop {
        decoder: CanDecoder::new(codec),
        pipeline: pipeline(full_chain, slip),
        taxels: Vec::new(),
        slips: Vec::new(),
        latencies_ns: Vec::with_capacity(wanted),
        frames: 0,
        events: 0,
    };
    let (mut cp, mut cf) = (0usize, 0usize);
    while peak.frames < wanted + WARMUP || full.frames < wanted + WARMUP {
        peak.run(&can, &mut cp, BLOCK);
        full.run(&can, &mut cf, BLOCK);
        if cp >= can.len() && cf >= can.len() {
            break;
        }
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "live latency, CAN frame → decode → 2 fingertip chains (default settings, NN 64×64) → slip decision\n\
         {} CAN frames for {} taxel frames per variant ({} warm-up not counted); load average: {}",
        can.len(),
        wanted,
        WARMUP,
        load.split_whitespace().take(3).collect::<Vec<_>>().join(" ")
    );
    println!(
        "{:<6} {:>9} {:>9} {:>9} {:>9} {:>9} {:>12}",
        "path", "frames", "p50 µs", "p99 µs", "p99.9 µs", "max µs", "slip events"
    );
    report("peak", &mut peak.latencies_ns, peak.events);
    report("full", &mut full.latencies_ns, full.events);
    if peak.events != full.events {
        return Err(format!("slip events differ: peak {} vs full {}", peak.events, full.events).into());
    }
    Ok(())
}
