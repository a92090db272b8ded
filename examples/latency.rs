//! # Live latency: CAN frame → decode → two fingertip chains → slip decision
//!
//! Per-frame processing latency of the live path, measured over ≥ 100,000 taxel frames:
//!
//! ```text
//!  CAN frames (biotac-mux, encoded with gradtac-io's CanEncoder, 7 per fingertip per 10 ms)
//!    └─ CanDecoder::push ─> TaxelFrame ─> Runner::push ─> the fingertip's SensorChain
//!                                           (the stages a scene runs) ─> Slip ─> slip output
//! ```
//!
//! The chains are the ones `gradtac run` builds for a scene of two fingertips on a CAN bus
//! with the two-finger `slip` output and no stage settings but the contact-location method:
//! [`Runner`] over [`Plan::new`] of that scene, so whatever a scene runs by default is what is
//! timed (routing between stages and the outputs' sinks included). Four scenes:
//! - `slip`: the slip output alone, all defaults. The slip's default evidence is the raw
//!   frames' change pattern (`slip_pattern`), so the plan builds source → slip and nothing
//!   else: the fastest path from a CAN frame to a slip decision. Its default onset position
//!   (`[stages.slip] onset_position = "fit"`) fits the contact model to each finger's change
//!   pattern on every frame in contact: the price of the onset's accuracy.
//! - `slip (energy)`: the same with `onset_position = "energy"` (the change pattern's own
//!   energy-weighted point, O(taxels) per frame): the difference against `slip` is what the
//!   default's per-frame fit costs on the live path.
//! - `centroid+track`: also a `track` output, default locator (`method = "centroid"`): taxel
//!   centroid → track runs beside the slip.
//! - `events+track`: also a `track` output with `[stages.locate] method = "events"`, the
//!   natural-neighbour event chain of the default `event_chain = "press_release"` — (normalise
//!   bypassed) → Savitzky–Golay → press/release events → cumulative window → surface (32 × 32)
//!   and maximal contour (fused) → track — beside the slip. A cumulative window never
//!   empties, so the surface and contour run on every frame.
//!
//! The hand is the simulator's two-finger grasp that slips (thumb `th`, first finger `ff`),
//! tiled in time to the requested length. The CAN frames are encoded up front (that is the
//! hand's work); the timed part is, per CAN frame that completes a fingertip's set, decoding
//! it and pushing the taxel frame through the runner (that finger's chain and the slip
//! stage): the time from the CAN frame's arrival to the slip decision it allows. The four
//! scenes run alternately in blocks of 1,000 taxel frames, so all meet the same machine
//! load.
//!
//! Output: p50 / p99 / p99.9 / max per variant over the taxel frames (the first 2,000 are
//! warm-up and not counted), then over the frames whose push wrote a slip decision
//! (`decision`) and the others (`other`), the slip events written, and the load average.
//! (The tiled grasp slips every 2 s, so about 2 % of its frames decide: more than a real
//! hand's, and a decision costs more than a frame.) Machines are noisy: run it several times
//! and take medians. `GRADTAC_LATENCY_DUMP=<prefix>` writes each variant's latencies (ns, in
//! frame order) to `<prefix>-<method>.txt`.
//!
//! Measured (median of 3 runs under `nice -n 10`, load average ≈ 9 on 2 cores, 2026-11-27;
//! the table and the earlier figures in the repository's `docs/tradeoff.md`), p50 / p99 of all
//! frames: `slip` 6.0 / 33.1 µs, `slip (energy)` 1.0 / 1.3 µs, `centroid+track` 6.5 / 33.5 µs,
//! `events+track` 11.1 / 43.5 µs; a deciding frame about 80 µs p50 in every scene (88 µs
//! with the events chain). So the default onset position's per-frame fit costs 5 µs at p50
//! and about 32 µs at p99 on every frame. At that load the p99.9 and max columns (milliseconds)
//! are the scheduler, not the pipeline.
//!
//! Run: `cargo run --release --example latency [taxel_frames]` (default 100,000).

use gradtac::io::can::{CanCodec, CanDecoder, CanEncoder, CanFrame, CodecConfig, PresetConfig, PresetKind};
use gradtac::run::Runner;
use gradtac::stages::sim::{GraspConfig, Scene as SimScene, SensorModel, Simulator};
use gradtac::stages::slip::SlipClass;
use gradtac::stream::{Layout, SensorId, Stage, TaxelFrame, Timestamp};
use gradtac::{Plan, Scene};
use std::path::Path;
use std::time::Instant;

type BoxError = Box<dyn std::error::Error + Send + Sync>;

const PERIOD_NS: i64 = 10_000_000;
const WARMUP: usize = 2_000;
const BLOCK: usize = 1_000;

/// The slip output with the onset dated from the change pattern's own point rather than a
/// per-frame model fit: the `slip (energy)` scene, for the cost of the default's fit.
const ENERGY: &str = "[stages.slip]\nonset_position = \"energy\"\n";

/// The scene `gradtac run` would read: two fingertips on a CAN bus, the slip output (first),
/// with `track` also the track output, and the contact-location method.
fn scene_text(method: &str, track: bool, slip: &str) -> String {
    let track_output = if track {
        format!("[[output]]\ntap = \"track\"\npath = \"out/track-{method}.parquet\"\n")
    } else {
        String::new()
    };
    let variant = if slip.is_empty() { "" } else { "-energy" };
    format!(
        r#"
[[bus]]
name = "hand"
candump = "hand.log"
codec = {{ preset = {{ kind = "biotac-mux", sensors = ["th", "ff"] }} }}

[[sensor]]
name = "th"
source = {{ bus = "hand" }}
[[sensor]]
name = "ff"
source = {{ bus = "hand" }}

[stages.locate]
method = "{method}"
{slip}
[[output]]
tap = "slip"
path = "out/slip-{method}-{track}{variant}.parquet"
{track_output}"#
    )
}

/// One variant's live loop state: decoder and runner, and the latencies measured so far.
struct Loop {
    name: &'static str,
    decoder: CanDecoder,
    runner: Option<Runner>,
    taxels: Vec<TaxelFrame>,
    latencies_ns: Vec<u64>,
    /// Per latency: whether that push wrote a slip decision.
    decided: Vec<bool>,
    slip_rows: u64,
    frames: usize,
    cursor: usize,
}

impl Loop {
    fn new(
        name: &'static str,
        method: &str,
        track: bool,
        slip: &str,
        dir: &Path,
        codec: &CanCodec,
        capacity: usize,
    ) -> Result<Loop, BoxError> {
        let file = dir.join(format!("{name}.toml").replace(['+', ' ', '(', ')'], "_"));
        let scene = Scene::from_toml(&scene_text(method, track, slip), dir, &file)?;
        let plan = Plan::new(&scene)?;
        Ok(Loop {
            name,
            decoder: CanDecoder::new(codec.clone()),
            runner: Some(Runner::new(&scene, &plan)?),
            taxels: Vec::with_capacity(4),
            latencies_ns: Vec::with_capacity(capacity),
            decided: Vec::with_capacity(capacity),
            slip_rows: 0,
            frames: 0,
            cursor: 0,
        })
    }

    /// Feed CAN frames until `n` more taxel frames came out; time each taxel frame's path.
    fn run(&mut self, can: &[CanFrame], n: usize) -> Result<(), BoxError> {
        let runner = self.runner.as_mut().expect("running");
        let target = self.frames + n;
        while self.frames < target && self.cursor < can.len() {
            let t0 = Instant::now();
            self.decoder.push(can[self.cursor], &mut self.taxels)?;
            self.cursor += 1;
            if self.taxels.is_empty() {
                continue;
            }
            for f in self.taxels.drain(..) {
                runner.push(f)?;
            }
            let dt = t0.elapsed().as_nanos() as u64;
            let rows = runner.rows()[0];
            if self.frames >= WARMUP {
                self.latencies_ns.push(dt);
                self.decided.push(rows > self.slip_rows);
            }
            self.slip_rows = rows;
            self.frames += 1;
        }
        Ok(())
    }

    /// Finish the outputs and print the variant's lines: every frame, then the frames whose
    /// push wrote a slip decision and the others.
    fn report(&mut self) -> Result<(), BoxError> {
        let outputs = self.runner.take().expect("running").finish()?;
        let events: u64 = outputs.iter().map(|(_, rows)| rows).sum();
        if let Ok(d) = std::env::var("GRADTAC_LATENCY_DUMP") {
            let text: Vec<String> = self.latencies_ns.iter().map(u64::to_string).collect();
            std::fs::write(format!("{d}-{}.txt", self.name), text.join("\n"))?;
        }
        let pick = |decided: Option<bool>| -> Vec<u64> {
            let mut v: Vec<u64> = self
                .latencies_ns
                .iter()
                .zip(&self.decided)
                .filter(|&(_, &d)| decided.is_none_or(|want| d == want))
                .map(|(&x, _)| x)
                .collect();
            v.sort_unstable();
            v
        };
        for (what, decided) in [("all", None), ("decision", Some(true)), ("other", Some(false))] {
            let s = pick(decided);
            println!(
                "{:<15} {:<9} {:>9} {:>9.1} {:>9.1} {:>9.1} {:>9.1} {:>12}",
                self.name,
                what,
                s.len(),
                percentile(&s, 0.5),
                percentile(&s, 0.99),
                percentile(&s, 0.999),
                s.last().map_or(f64::NAN, |&x| x as f64 / 1e3),
                if decided.is_none() { events.to_string() } else { String::new() }
            );
        }
        Ok(())
    }
}

fn percentile(sorted: &[u64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted[i] as f64 / 1e3
}

fn load() -> String {
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    load.split_whitespace().take(3).collect::<Vec<_>>().join(" ")
}

fn main() -> Result<(), BoxError> {
    let wanted: usize = std::env::args().nth(1).map_or(Ok(100_000), |s| s.parse())?;
    let layout = Layout::biotac_sp();
    let grasp = SimScene::grasp(SlipClass::LongitudinalDown, &GraspConfig::default(), &layout);
    let recording = Simulator::try_new(layout.clone(), SensorModel::default(), 1)?.run(&grasp)?;
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

    let dir = std::env::temp_dir().join(format!("gradtac-latency-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    std::fs::write(dir.join("hand.log"), "")?;
    let mut loops = [
        Loop::new("slip", "centroid", false, "", &dir, &codec, wanted)?,
        Loop::new("slip (energy)", "centroid", false, ENERGY, &dir, &codec, wanted)?,
        Loop::new("centroid+track", "centroid", true, "", &dir, &codec, wanted)?,
        Loop::new("events+track", "events", true, "", &dir, &codec, wanted)?,
    ];
    let load_before = load();
    while loops.iter().any(|l| l.frames < wanted + WARMUP && l.cursor < can.len()) {
        for l in &mut loops {
            l.run(&can, BLOCK)?;
        }
    }
    println!(
        "live latency, CAN frame → decode → 2 fingertips (the stages each scene runs) → slip decision\n\
         {} CAN frames for {} taxel frames per scene ({} warm-up not counted); load average before {}, after {}",
        can.len(),
        wanted,
        WARMUP,
        load_before,
        load()
    );
    println!(
        "{:<15} {:<9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>12}",
        "scene", "frames", "count", "p50 µs", "p99 µs", "p99.9 µs", "max µs", "rows written"
    );
    for l in &mut loops {
        l.report()?;
    }
    std::fs::remove_dir_all(&dir)?;
    Ok(())
}
