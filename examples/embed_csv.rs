//! # Embed gradtac: a CSV recording to contact tracks, offline and on tokio
//!
//! What a new application writes to use gradtac as a library: open a CSV source, put three
//! stages behind it with `.stage(…)`, and use `?` everywhere — no error glue, no
//! `.map(Ok)`. The source's items are `Result<TaxelFrame, gradtac::io::Error>`; each stage's
//! error (`gradtac::stages::Error`) converts into the source's error, and that one into
//! `gradtac::Error` at `?`.
//!
//! The pipeline is the default contact-location method of a scene (`[stages.locate] method =
//! "centroid"`, `docs/method.md`) behind a Savitzky–Golay smoother:
//!
//! ```text
//!  CsvFrames ─► SavGol (11 frames, centred) ─► Centroid (taxel centroid) ─► Track ─► TrackPoint
//! ```
//!
//! It runs the same stages twice:
//! 1. **offline**: the reader is an [`Iterator`]; `IteratorStageExt::stage` chains the stages;
//! 2. **tokio**: `gradtac::io::blocking_stream` moves the same reader onto tokio's blocking
//!    pool (a bounded channel, 64 frames ahead) and `StreamStageExt::stage` chains the stages
//!    on the stream — the `TryStream` form.
//!
//! and checks that both give the same points.
//!
//! Run on your own recording (a header line, one row per frame, 24 taxel columns):
//!
//! ```text
//! cargo run --example embed_csv -- recording.csv 'ff_e{1..24}' 100
//! ```
//!
//! (arguments: file, column pattern, sample rate in Hz; the BioTacSP-DoS recordings have this
//! header and rate). Without arguments it writes a simulated recording of a fingertip stroked
//! upwards into a scratch directory and reads that. Exits non-zero if a check fails.

use futures::StreamExt;
use gradtac::io::{blocking_stream, CsvFrames, CsvSourceConfig};
use gradtac::stages::centroid::Centroid;
use gradtac::stages::locate::LocateConfig;
use gradtac::stages::savgol::{SavGol, SavGolConfig};
use gradtac::stages::sim::{Scene, SensorModel, Simulator, Trajectory};
use gradtac::stages::track::{ContactState, Track, TrackConfig, TrackPoint};
use gradtac::stages::{FromConfig, StageContext};
use gradtac::stream::{IteratorStageExt, Layout, SensorId, StreamStageExt};
use std::path::PathBuf;

/// The three stages, each validated by its constructor (a bad setting fails here, before
/// any data moves).
/// Every stage has the one constructor shape `from_config(&config, &context)`; the configs
/// are the structs a scene's `[stages.<tap>]` tables deserialise into.
fn stages(ctx: &StageContext) -> Result<(SavGol, Centroid, Track), gradtac::Error> {
    Ok((
        SavGol::from_config(&SavGolConfig::default(), ctx)?,
        Centroid::from_config(&LocateConfig::default(), ctx)?,
        Track::from_config(&TrackConfig::default(), ctx)?,
    ))
}

/// Offline: an iterator of frames, three stages, `?`.
fn offline(source: &CsvSourceConfig, ctx: &StageContext) -> Result<Vec<TrackPoint>, gradtac::Error> {
    let (savgol, centroid, track) = stages(ctx)?;
    let points = CsvFrames::open(source, SensorId::new("ff"))?
        .stage(savgol)
        .stage(centroid)
        .stage(track)
        .collect::<Result<Vec<_>, _>>()?;
    Ok(points)
}

/// Live: the same reader on tokio's blocking pool, the same stages on the stream.
async fn on_tokio(source: &CsvSourceConfig, ctx: &StageContext) -> Result<Vec<TrackPoint>, gradtac::Error> {
    let (savgol, centroid, track) = stages(ctx)?;
    let frames = blocking_stream(CsvFrames::open(source, SensorId::new("ff"))?, 64);
    let mut points = std::pin::pin!(frames.stage(savgol).stage(centroid).stage(track));
    let mut out = Vec::new();
    while let Some(point) = points.next().await {
        out.push(point?);
    }
    Ok(out)
}

/// A simulated recording (fingertip `ff` stroked upwards) in a scratch directory.
fn simulated_csv() -> Result<PathBuf, Box<dyn std::error::Error>> {
    let dir = std::env::temp_dir().join(format!("gradtac-embed-csv-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let layout = Layout::biotac_sp();
    let recording = Simulator::try_new(layout.clone(), SensorModel::default(), 11)?.run(&Scene::trajectory(
        Trajectory::Up,
        8.0,
        2.0,
        &layout,
    ))?;
    let csv = dir.join("ff.csv");
    recording.write_csv(&csv, &dir.join("truth.csv"))?;
    Ok(csv)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (csv, scratch) = match args.first() {
        Some(path) => (PathBuf::from(path), false),
        None => (simulated_csv()?, true),
    };
    let columns = args.get(1).map_or("ff_e{1..24}", String::as_str);
    let rate_hz: f64 = args.get(2).map_or(Ok(100.0), |r| r.parse())?;
    let source = CsvSourceConfig::new(&csv, columns.parse()?).with_rate_hz(rate_hz);
    let ctx = StageContext::new(Layout::biotac_sp()).with_rate_hz(rate_hz);

    let offline_points = offline(&source, &ctx)?;
    let runtime = tokio::runtime::Builder::new_multi_thread().worker_threads(2).build()?;
    let live_points = runtime.block_on(on_tokio(&source, &ctx))?;

    let contact: Vec<&TrackPoint> = offline_points.iter().filter(|p| p.state == ContactState::Contact).collect();
    println!("{}: {} track points (one per frame)", csv.display(), offline_points.len());
    println!("  in contact: {} points", contact.len());
    if let (Some(first), Some(last)) = (contact.first(), contact.last()) {
        println!(
            "  first contact at {:.2} s ({:.1}, {:.1}) mm, last at {:.2} s ({:.1}, {:.1}) mm",
            first.time.as_secs_f64(),
            first.x_mm,
            first.y_mm,
            last.time.as_secs_f64(),
            last.x_mm,
            last.y_mm
        );
    }
    if scratch {
        if let Some(dir) = csv.parent().filter(|d| d.starts_with(std::env::temp_dir())) {
            std::fs::remove_dir_all(dir)?;
        }
    }

    let mut failures = Vec::new();
    // points without a contact hold NaN positions, so compare their printed form (NaN == NaN)
    if format!("{offline_points:?}") != format!("{live_points:?}") {
        failures.push(format!(
            "offline ({} points) and tokio ({} points) disagree",
            offline_points.len(),
            live_points.len()
        ));
    } else {
        println!("  offline iterator and tokio stream gave the same {} points", live_points.len());
    }
    if contact.is_empty() {
        failures.push("no contact found".to_string());
    }
    if failures.is_empty() {
        Ok(())
    } else {
        Err(failures.join("; ").into())
    }
}
