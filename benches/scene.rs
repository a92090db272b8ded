//! What a scene runs, end to end per raw frame: [`Runner`] over [`Plan::new`] of a scene with
//! one fingertip and one `track` output (Parquet, zstd, in a temporary directory), no stage
//! settings but the contact-location method — the chains `gradtac run` builds, with routing
//! and the output's sink included (the CSV reading is not: frames are pushed from memory).
//!
//! `cargo bench -p gradtac --bench scene`
//!
//! - `scene/<input>/events`: `[stages.locate] method = "events"` with its default event chain
//!   (`event_chain = "press_release"`) — Savitzky–Golay on raw counts → press/release events
//!   (noise-adaptive τ) → cumulative window → natural neighbour 32 × 32 and maximal contour
//!   (fused, as a scene runs them when no output taps the surface) → track → Parquet.
//! - `scene/<input>/events_paper`: the same with `event_chain = "paper"` — normalise →
//!   Savitzky–Golay → events of both polarities → 10-frame sliding window → 64 × 64.
//! - `scene/<input>/centroid`: the default scene — taxel centroid → track → Parquet.
//!
//! Inputs: `real` — the BioTacSP-DoS recording `aw/bottle0.csv` (`shared/data` beside the
//! workspace, or `$GRADTAC_SHARED_DATA`; skipped when absent) tiled 100 times (27,900 frames at
//! 100 Hz); `sim` — a simulated grasp's first finger (`gradtac::stages::sim`, seed 1), tiled
//! 100 times (20,000 frames). `scene/<input>/setup` times the fixed part alone (building the
//! runner, writing an empty file): with `setup` subtracted, a variant's time per frame is
//! what a long run pays. Throughput is frames per second; each iteration builds the runner (the weight
//! table is shared, so that is cheap), pushes every frame and finishes the file.
use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use gradtac::run::Runner;
use gradtac::stages::sim::{GraspConfig, Scene as SimScene, SensorModel, Simulator};
use gradtac::stages::slip::SlipClass;
use gradtac::stream::{Layout, SensorId, TaxelFrame, Timestamp};
use gradtac::{Plan, Scene};
use std::path::{Path, PathBuf};

/// How many times each recording is repeated: enough frames that the runner's set-up and the
/// file's close (measured on their own as `setup`) are a small part of an iteration.
const TILES: usize = 100;

fn data_dir() -> PathBuf {
    std::env::var_os("GRADTAC_SHARED_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data"))
}

fn read_csv(path: &Path) -> Option<Vec<Vec<f64>>> {
    let text = std::fs::read_to_string(path).ok()?;
    Some(
        text.lines()
            .skip(1)
            .filter(|l| !l.trim().is_empty())
            .map(|l| l.split(',').map(|x| x.trim().parse().expect("a number")).collect())
            .collect(),
    )
}

fn inputs(layout: &Layout) -> Vec<(&'static str, Vec<TaxelFrame>)> {
    let mut v = Vec::new();
    match read_csv(&data_dir().join("biotacsp-dos/aw/bottle0.csv")) {
        Some(rows) => {
            let sensor = SensorId::new("ff");
            let frames = (0..rows.len() * TILES)
                .map(|k| {
                    TaxelFrame::new(
                        sensor.clone(),
                        Timestamp(k as i64 * 10_000_000),
                        k as u64,
                        rows[k % rows.len()].clone(),
                    )
                })
                .collect();
            v.push(("real", frames));
        }
        None => eprintln!("scene bench: shared/data/biotacsp-dos/aw/bottle0.csv not found; real input skipped"),
    }
    let sim = Simulator::try_new(layout.clone(), SensorModel::default(), 1).expect("simulator");
    let scene = SimScene::grasp(SlipClass::LongitudinalDown, &GraspConfig::default(), layout);
    let mut frames = sim.run(&scene).expect("simulated").taxel_frames();
    let first = frames[0].sensor.clone();
    frames.retain(|f| f.sensor == first);
    let ff = SensorId::new("ff");
    let n = frames.len();
    let frames = (0..n * TILES)
        .map(|k| TaxelFrame::new(ff.clone(), Timestamp(k as i64 * 10_000_000), k as u64, frames[k % n].values.clone()))
        .collect();
    v.push(("sim", frames));
    v
}

fn scene(dir: &Path, name: &str, method: &str, extra: &str) -> (Scene, Plan) {
    let text = format!(
        r#"
[[sensor]]
name = "ff"
source = {{ csv = "unused.csv", columns = "ff_e{{1..24}}", rate_hz = 100.0 }}

[stages.locate]
method = "{method}"
{extra}
[[output]]
tap = "track"
path = "out/track-{name}.parquet"
"#
    );
    let scene = Scene::from_toml(&text, dir, &dir.join(format!("{name}.toml"))).expect("a valid scene");
    let plan = Plan::new(&scene).expect("a valid plan");
    (scene, plan)
}

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let layout = Layout::biotac_sp();
    for (name, frames) in inputs(&layout) {
        let mut g = c.benchmark_group(format!("scene/{name}"));
        g.throughput(Throughput::Elements(frames.len() as u64));
        for (name, method, extra) in [
            ("events", "events", ""),
            ("events_paper", "events", "event_chain = \"paper\""),
            ("centroid", "centroid", ""),
        ] {
            let (scene, plan) = scene(dir.path(), name, method, extra);
            if name == "events" {
                // the fixed part of an iteration: build the runner, write an empty file
                g.bench_function("setup", |b| {
                    b.iter(|| Runner::new(&scene, &plan).expect("runner").finish().expect("written"))
                });
            }
            g.bench_function(name, |b| {
                b.iter_batched(
                    || frames.clone(),
                    |frames| {
                        let mut runner = Runner::new(&scene, &plan).expect("runner");
                        for f in frames {
                            runner.push(f).expect("valid frames");
                        }
                        runner.finish().expect("written")
                    },
                    BatchSize::LargeInput,
                )
            });
        }
        g.finish();
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(4));
    targets = bench
}
criterion_main!(benches);
