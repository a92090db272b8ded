//! Other engines read gradtac archives natively: a sensor-partitioned archive of track points
//! (UTC times, no contact as null) is read by pyarrow and, when installed, DuckDB, Polars and
//! DataFusion (Python packages), each checking that
//! - `sensor` is a hive partition (DuckDB `read_parquet('<dir>/**/*.parquet', hive_partitioning =
//!   true)`, Polars `scan_parquet(..., hive_partitioning=True)`, `pyarrow.dataset(...,
//!   partitioning="hive")`, DataFusion `CREATE EXTERNAL TABLE ... PARTITIONED BY (sensor)`);
//! - `avg(x_mm)` per sensor is a number (no contact is null, not NaN), equal to the mean of
//!   the points with contact;
//! - the time column is a timestamp (ns, UTC); a rate-timed archive's is a duration.
//!
//! The Python interpreter is `$GRADTAC_PYTHON` if set, else `python3`. Without it, or without
//! pyarrow, the test says so and passes; an engine that is not installed is skipped and named.
//! `scripts/interop.sh` installs all four into a virtual environment and runs this test.

use gradtac::io::archive::{ParquetArchive, Partitioning};
use gradtac::io::{FrameShape, TimeBase};
use gradtac::stages::contour::NoContact;
use gradtac::stages::track::{ContactState, TrackPoint};
use gradtac::stream::{SensorId, TaxelFrame, Timestamp};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

const SCRIPT: &str = r#"
import json, math, sys
tracks, frames = sys.argv[1], sys.argv[2]
glob = tracks + "/**/*.parquet"
out = {}

def finite(x):
    return x is not None and isinstance(x, float) and math.isfinite(x)

import pyarrow as pa, pyarrow.dataset as ds, pyarrow.compute as pc
d = ds.dataset(tracks, format="parquet", partitioning="hive")
t = d.to_table()
means = {}
for s in sorted(set(t.column("sensor").to_pylist())):
    rows = d.to_table(filter=ds.field("sensor") == s)
    means[s] = pc.mean(rows.column("x_mm")).as_py()
f = ds.dataset(frames, format="parquet").to_table()
out["pyarrow"] = {
    "version": pa.__version__,
    "rows": t.num_rows,
    "avg_x_mm": means,
    "time_type": str(t.schema.field("time").type),
    "partition": "sensor" in d.partitioning.schema.names,
    "columns_in_files": ds.dataset(tracks, format="parquet").schema.names,
    "relative_time_type": str(f.schema.field("time").type),
    "nan_x": int(pc.sum(pc.is_nan(pc.drop_null(t.column("x_mm")))).as_py() or 0),
    "null_x": t.column("x_mm").null_count,
}

try:
    import duckdb
except ImportError:
    out["duckdb"] = "not installed"
else:
    con = duckdb.connect()
    q = f"SELECT sensor, avg(x_mm), any_value(typeof(time)) FROM read_parquet('{glob}', hive_partitioning = true) GROUP BY sensor ORDER BY sensor"
    rows = con.execute(q).fetchall()
    out["duckdb"] = {
        "version": duckdb.__version__,
        "query": q,
        "avg_x_mm": {r[0]: r[1] for r in rows},
        "time_type": rows[0][2],
        "partition": True,
    }

try:
    import polars as pl
except ImportError:
    out["polars"] = "not installed"
else:
    lf = pl.scan_parquet(glob, hive_partitioning=True)
    g = lf.group_by("sensor").agg(pl.col("x_mm").mean()).sort("sensor").collect()
    out["polars"] = {
        "version": pl.__version__,
        "avg_x_mm": dict(zip(g["sensor"].to_list(), g["x_mm"].to_list())),
        "time_type": str(lf.collect_schema()["time"]),
        "partition": "sensor" in lf.collect_schema().names(),
    }

try:
    import datafusion
except ImportError:
    out["datafusion"] = "not installed"
else:
    ctx = datafusion.SessionContext()
    ddl = f"CREATE EXTERNAL TABLE tracks STORED AS PARQUET PARTITIONED BY (sensor) LOCATION '{tracks}/'"
    ctx.sql(ddl).collect()
    q = "SELECT sensor, avg(x_mm) AS avg_x_mm, arrow_typeof(min(time)) AS time_type FROM tracks GROUP BY sensor ORDER BY sensor"
    r = ctx.sql(q).to_pydict()
    out["datafusion"] = {
        "version": datafusion.__version__,
        "query": ddl + "; " + q,
        "avg_x_mm": dict(zip(r["sensor"], r["avg_x_mm"])),
        "time_type": r["time_type"][0],
        "partition": True,
    }

print(json.dumps(out))
"#;

fn python() -> String {
    std::env::var("GRADTAC_PYTHON").unwrap_or_else(|_| "python3".into())
}

fn has_pyarrow(py: &str) -> bool {
    Command::new(py).args(["-c", "import pyarrow.dataset"]).output().map(|o| o.status.success()).unwrap_or(false)
}

fn point(sensor: &str, k: u64) -> TrackPoint {
    let contact = k % 5 != 3;
    let nan = f64::NAN;
    let t = 1_700_000_000_000_000_000 + k as i64 * 10_000_000; // 2023-11-14, 10 ms apart
    TrackPoint {
        sensor: SensorId::new(sensor),
        time: Timestamp(t),
        start: Timestamp(t - 90_000_000),
        seq: k,
        state: if contact { ContactState::Contact } else { ContactState::NoContact },
        no_contact: (!contact).then_some(NoContact::TooSmall),
        track: contact.then_some(0),
        x_mm: if contact { (k as f64 * 0.37).sin() * 8.0 + if sensor == "ff" { 2.0 } else { -3.0 } } else { nan },
        y_mm: if contact { k as f64 * 0.01 } else { nan },
        area_mm2: if contact { 20.0 } else { nan },
        orientation_rad: if contact { 0.1 } else { nan },
        peak: if contact { 1.5 } else { nan },
        velocity_mm_s: (contact && k % 5 != 4).then_some([1.0, -2.0]),
        gated: false,
        fit: None,
    }
}

/// Writes the two archives; returns the expected mean of `x_mm` per sensor.
fn write_archives(tracks: &Path, frames: &Path) -> BTreeMap<String, f64> {
    let sensors = ["ff", "th"];
    let points: Vec<TrackPoint> = (0..400u64).map(|k| point(sensors[(k % 2) as usize], k)).collect();
    let mut a = ParquetArchive::<TrackPoint>::try_new(tracks, ())
        .unwrap()
        .with_partitioning(Partitioning::Sensor)
        .unwrap()
        .with_time_base(TimeBase::Utc)
        .unwrap()
        .with_roll_rows(64)
        .unwrap();
    for p in &points {
        a.push(p).unwrap();
    }
    a.finish().unwrap();
    let mut f = ParquetArchive::<TaxelFrame>::try_new(frames, FrameShape::unnamed(3).unwrap())
        .unwrap()
        .with_partitioning(Partitioning::Sensor)
        .unwrap();
    for k in 0..50u64 {
        f.push(&TaxelFrame::new(SensorId::new("ff"), Timestamp::at_rate(k, 100.0), k, vec![1.0, 2.0, k as f64]))
            .unwrap();
    }
    f.finish().unwrap();
    sensors
        .iter()
        .map(|s| {
            let xs: Vec<f64> =
                points.iter().filter(|p| p.sensor.as_str() == *s && p.x_mm.is_finite()).map(|p| p.x_mm).collect();
            (s.to_string(), xs.iter().sum::<f64>() / xs.len() as f64)
        })
        .collect()
}

fn check_means(engine: &str, got: &serde_json::Value, want: &BTreeMap<String, f64>) {
    for (s, m) in want {
        let v = got["avg_x_mm"][s]
            .as_f64()
            .unwrap_or_else(|| panic!("{engine}: avg(x_mm) of {s} is {}", got["avg_x_mm"][s]));
        assert!(v.is_finite() && (v - m).abs() < 1e-9, "{engine}: avg(x_mm) of {s} = {v}, want {m}");
    }
    assert_eq!(got["partition"], true, "{engine}: sensor is a partition");
}

#[test]
fn engines_read_an_archive_natively() {
    let py = python();
    if !has_pyarrow(&py) {
        eprintln!("skipped: {py} with pyarrow is not available (scripts/interop.sh installs it in a venv)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (tracks, frames) = (dir.path().join("tracks"), dir.path().join("frames"));
    let want = write_archives(&tracks, &frames);
    let out = Command::new(&py).arg("-c").arg(SCRIPT).arg(&tracks).arg(&frames).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    println!("{}", serde_json::to_string_pretty(&v).unwrap());

    let pa = &v["pyarrow"];
    check_means("pyarrow", pa, &want);
    assert_eq!(pa["rows"], 400);
    assert_eq!(pa["time_type"], "timestamp[ns, tz=UTC]");
    assert_eq!(pa["relative_time_type"], "duration[ns]", "a rate-timed source's times are durations");
    assert_eq!(pa["nan_x"], 0, "no NaN in x_mm");
    assert_eq!(pa["null_x"], 80, "no contact (every 5th point) is null");
    let in_files: Vec<&str> = pa["columns_in_files"].as_array().unwrap().iter().map(|c| c.as_str().unwrap()).collect();
    assert!(!in_files.contains(&"sensor"), "the partition column is not repeated in the files: {in_files:?}");

    for engine in ["duckdb", "polars", "datafusion"] {
        let e = &v[engine];
        if e.is_string() {
            eprintln!("{engine}: {} — skipped", e.as_str().unwrap());
            continue;
        }
        check_means(engine, e, &want);
        let t = e["time_type"].as_str().unwrap().to_lowercase();
        let utc_timestamp = match engine {
            // DuckDB ≥ 1.2 keeps nanoseconds (TIMESTAMPTZ_NS); older versions say TIMESTAMP WITH TIME ZONE
            "duckdb" => t == "timestamptz_ns" || t == "timestamp with time zone",
            "polars" => t.starts_with("datetime") && t.contains("ns") && t.contains("utc"),
            _ => t.starts_with("timestamp(n") && t.contains("utc"),
        };
        assert!(utc_timestamp, "{engine}: time is {t}, not a UTC timestamp");
    }
}
