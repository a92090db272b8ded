//! # The rerun view's cost per frame
//!
//! `gradtac run` of a scene in process ([`run::run_blocking`]), with the view off and on,
//! over the demo's simulated two-finger grasp (`ff`, `th`, 100 Hz) tiled in time to
//! `repeats` copies (default 20: ≈ 24,000 taxel frames). Two scenes:
//! - `track`: a `track` output (the default centroid locator → tracker);
//! - `all`: the outputs `scripts/view-check` uses: source (archive), normalise, events,
//!   surface (64 × 64), contour, track, servo, slip.
//!
//! Variants, each `reps` times (default 5), interleaved so all meet the same machine load:
//! - `off`: no view;
//! - `rrd`: the view on, saving an `.rrd`, lossless (the run waits for the view: the full
//!   cost of logging every record, flush included — what `gradtac run --view-save` costs for
//!   files);
//! - `rrd-drop`: the same with the live policy (`--view-drop`, always for live buses): the
//!   pipeline never waits; the table shows the time and the share of records dropped.
//!
//! Output: a table of the median wall time (run and the view's finish: flush and close; the
//! part of it after the run in its own column), µs per taxel frame, the ratio to `off`, the
//! `.rrd` size and the records logged / dropped. Run:
//! `cargo run --release --features view --example view_cost [repeats] [reps]`.

use gradtac::run::{self, RunOptions};
use gradtac::view::{View, ViewOptions};
use gradtac::{Plan, Scene};
use std::path::Path;
use std::time::Instant;

const SENSORS: &str = r#"
[[sensor]]
name = "ff"
layout = "biotac-sp"
source = { csv = "recording.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }

[[sensor]]
name = "th"
layout = "biotac-sp"
source = { csv = "recording.csv", columns = "th_e{1..24}", rate_hz = 100.0 }
"#;

const TRACK: &str = r#"
[[output]]
tap = "track"
path = "out/tracks.parquet"
"#;

const ALL: &str = r#"
[[output]]
tap = "source"
path = "out/raw"
archive = { partition = "sensor", roll_rows = 4000 }

[[output]]
tap = "normalise"
path = "out/normalised.parquet"

[[output]]
tap = "events"
path = "out/events.parquet"

[[output]]
tap = "surface"
path = "out/surfaces.parquet"

[[output]]
tap = "contour"
path = "out/contours.parquet"

[[output]]
tap = "track"
path = "out/tracks.parquet"

[[output]]
tap = "servo"
path = "out/servo.parquet"

[[output]]
tap = "slip"
path = "out/slip.parquet"
"#;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

struct Row {
    seconds: Vec<f64>,
    /// The part after the run: the view's finish (flush, close).
    finish: Vec<f64>,
    rrd_bytes: u64,
    logged: u64,
    dropped: u64,
    offered: u64,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let repeats: usize = args.get(1).map_or(Ok(20), |s| s.parse())?;
    let reps: usize = args.get(2).map_or(Ok(5), |s| s.parse())?;
    let dir = tempfile_dir()?;
    // the demo's grasp, tiled in time
    let rec = gradtac::demo::simulate(gradtac::demo::DEMO_SEED)?;
    rec.write_csv(&dir.join("one.csv"), &dir.join("truth.csv"))?;
    let text = std::fs::read_to_string(dir.join("one.csv"))?;
    let mut lines = text.lines();
    let header = lines.next().ok_or("empty recording")?;
    let body: Vec<&str> = lines.collect();
    let mut csv = String::with_capacity(text.len() * repeats);
    csv.push_str(header);
    csv.push('\n');
    for _ in 0..repeats {
        for l in &body {
            csv.push_str(l);
            csv.push('\n');
        }
    }
    std::fs::write(dir.join("recording.csv"), csv)?;
    let frames = (body.len() * repeats * 2) as f64;
    println!(
        "view cost per frame: {} taxel frames (2 sensors × {} rows), {reps} runs each\n",
        frames,
        body.len() * repeats
    );
    println!(
        "| scene | view | median (ms) | of it: finish (ms) | µs / frame | ratio to off | .rrd (MB) | records logged | dropped |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for (name, outputs) in [("track", TRACK), ("all", ALL)] {
        let scene_path = dir.join(format!("{name}.toml"));
        std::fs::write(&scene_path, format!("{SENSORS}{outputs}"))?;
        let scene = Scene::load(&scene_path)?;
        let plan = Plan::new(&scene)?;
        let variants = ["off", "rrd", "rrd-drop"];
        let mut rows: Vec<Row> = variants
            .iter()
            .map(|_| Row { seconds: Vec::new(), finish: Vec::new(), rrd_bytes: 0, logged: 0, dropped: 0, offered: 0 })
            .collect();
        for _ in 0..reps {
            for (i, v) in variants.iter().enumerate() {
                let _ = std::fs::remove_dir_all(dir.join("out"));
                let rrd = dir.join("run.rrd");
                let _ = std::fs::remove_file(&rrd);
                let start = Instant::now();
                let view = match *v {
                    "off" => None,
                    _ => Some(View::save(&rrd, &ViewOptions { lossless: *v == "rrd", ..ViewOptions::default() })?),
                };
                let options =
                    RunOptions { progress: false, view: view.as_ref().map(View::handle), ..Default::default() };
                run::run_blocking(&scene, &plan, &options)?;
                drop(options);
                let ran = start.elapsed().as_secs_f64();
                if let Some(view) = view {
                    let r = view.finish()?;
                    rows[i].logged = r.logged;
                    rows[i].dropped = r.dropped;
                    rows[i].offered = r.offered;
                    rows[i].rrd_bytes = std::fs::metadata(&rrd).map(|m| m.len()).unwrap_or(0);
                }
                let total = start.elapsed().as_secs_f64();
                rows[i].seconds.push(total);
                rows[i].finish.push(total - ran);
            }
        }
        let off = median(&mut rows[0].seconds.clone());
        for (v, r) in variants.iter().zip(&mut rows) {
            let m = median(&mut r.seconds);
            let fin = median(&mut r.finish);
            let (mb, logged, dropped) = if *v == "off" {
                ("—".to_string(), "—".to_string(), "—".to_string())
            } else {
                (
                    format!("{:.1}", r.rrd_bytes as f64 / 1e6),
                    r.logged.to_string(),
                    format!("{} ({:.0} %)", r.dropped, 100.0 * r.dropped as f64 / r.offered.max(1) as f64),
                )
            };
            println!(
                "| {name} | {v} | {:.1} | {:.1} | {:.2} | {:.2} | {mb} | {logged} | {dropped} |",
                m * 1e3,
                fin * 1e3,
                m * 1e6 / frames,
                m / off
            );
        }
    }
    std::fs::remove_dir_all(&dir)?;
    Ok(())
}

fn tempfile_dir() -> std::io::Result<std::path::PathBuf> {
    let dir = std::env::temp_dir().join(format!("gradtac-view-cost-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let _ = Path::new(&dir);
    Ok(dir)
}
