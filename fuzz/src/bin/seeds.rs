//! Write a small seed corpus per fuzz target (valid inputs of every kind, so mutations start
//! deep inside the readers): `seeds <corpus-dir>` writes `<corpus-dir>/<target>/seed-*`.
//! The corpus is generated, not committed (see `docs/fuzzing.md`).

// Built with the targets' coverage instrumentation, which libFuzzer's runtime resolves.
extern crate libfuzzer_sys;

use arrow_array::builder::{FixedSizeListBuilder, Float64Builder, StringDictionaryBuilder};
use arrow_array::types::Int32Type;
use arrow_array::{ArrayRef, Float64Array, Int64Array, RecordBatch, StringArray};
use gradtac_io::can::{write_candump, CanCodec, CanEncoder, CodecConfig, OutOfRangePolicy, PresetConfig, PresetKind};
use gradtac_io::records::FrameShape;
use gradtac_io::records::SurfaceShape;
use gradtac_io::{ArrowRecord, ParquetSink};
use gradtac_stages::contour::{Contour, ContourConfig};
use gradtac_stages::dos::{DosClass, DosFeatureConfig, DosModel, Feature};
use gradtac_stages::events::{Events, EventsConfig, Threshold};
use gradtac_stages::force::ForceMethod;
use gradtac_stages::force_model::{calibrate_unguarded, CalibrationMethod, GaugeSample};
use gradtac_stages::interpolate::{GridConfig, Interpolate, InterpolateConfig};
use gradtac_stages::locate::LocateConfig;
use gradtac_stages::sim::{Scene as SimScene, SensorModel, Simulator, Trajectory};
use gradtac_stages::sim_force::{ForceSession, Segment};
use gradtac_stages::tare::Tare;
use gradtac_stages::track::{Track, TrackConfig};
use gradtac_stages::window::{Aggregate, Window, WindowConfig};
use gradtac_stream::{Layout, StageExt, TaxelFrame};
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn put(dir: &Path, target: &str, name: &str, bytes: &[u8]) {
    let d = dir.join(target);
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(d.join(format!("seed-{name}")), bytes).unwrap();
}

fn with_mode(mode: u8, body: &[u8]) -> Vec<u8> {
    let mut v = vec![mode];
    v.extend_from_slice(body);
    v
}

fn npy(descr: &str, shape: &[usize], data: &[u8]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let shape = if dims.len() == 1 { format!("({},)", dims[0]) } else { format!("({})", dims.join(", ")) };
    let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut v = b"\x93NUMPY\x01\x00".to_vec();
    v.extend_from_slice(&(header.len() as u16).to_le_bytes());
    v.extend_from_slice(header.as_bytes());
    v.extend_from_slice(data);
    v
}

fn ipc(batch: &RecordBatch, file: bool) -> Vec<u8> {
    let mut buf = Vec::new();
    if file {
        let mut w = arrow_ipc::writer::FileWriter::try_new(&mut buf, &batch.schema()).unwrap();
        w.write(batch).unwrap();
        w.write(batch).unwrap();
        w.finish().unwrap();
    } else {
        let mut w = arrow_ipc::writer::StreamWriter::try_new(&mut buf, &batch.schema()).unwrap();
        w.write(batch).unwrap();
        w.finish().unwrap();
    }
    buf
}

fn parquet<T: ArrowRecord>(dir: &Path, name: &str, shape: T::Shape, records: &[T], layout: &Layout) {
    let tmp = std::env::temp_dir().join(format!("gradtac-seed-{}-{name}.parquet", std::process::id()));
    let mut sink = ParquetSink::<T>::try_new(&tmp, shape).unwrap().with_row_group_size(8).unwrap();
    sink.set_metadata("gradtac.layout", layout.to_csv());
    for r in records {
        sink.push(r).unwrap();
    }
    sink.finish().unwrap();
    put(dir, "plot_parquet", name, &std::fs::read(&tmp).unwrap());
    std::fs::remove_file(&tmp).unwrap();
}

fn main() {
    let dir = PathBuf::from(std::env::args().nth(1).expect("usage: seeds <corpus-dir>"));
    let layout = Layout::biotac_sp();
    let sim = Simulator::try_new(layout.clone(), SensorModel::default(), 3).unwrap();
    let rec = sim.run(&SimScene::trajectory(Trajectory::CircleCcw, 2.0, 4.0, &layout)).unwrap();
    let frames: Vec<TaxelFrame> = rec.taxel_frames().into_iter().take(40).collect();

    // CSV: header + a few rows, at a rate, with a time column in s and in ns, `;`-separated.
    let mut csv = String::from("t,e1,e2,e3\n");
    for (k, f) in frames.iter().take(6).enumerate() {
        csv += &format!("{},{},{},{}\n", k as f64 * 0.01, f.values[0], f.values[1], f.values[2]);
    }
    put(&dir, "csv_source", "rate", &with_mode(1, csv.as_bytes()));
    put(&dir, "csv_source", "time-s", &with_mode(5, csv.as_bytes()));
    put(&dir, "csv_source", "semicolon", &with_mode(16 | 5, csv.replace(',', ";").as_bytes()));
    put(&dir, "csv_source", "time-ns", &with_mode(8, b"time_ns,a,b\n0,1.5,2\n10000000,1e3,-4\n"));
    put(&dir, "csv_source", "quoted", &with_mode(2, b"\"a\",\"b\"\n\"1\",2\n3,\"4\"\n"));

    // NumPy: f64 / i16 values at a rate, and with f64 / i64 timestamps.
    let vals: Vec<u8> =
        frames.iter().take(5).flat_map(|f| f.values[..4].iter().flat_map(|v| v.to_le_bytes())).collect();
    let f64s = npy("<f8", &[5, 4], &vals);
    put(&dir, "npy", "f8", &f64s);
    put(&dir, "npy", "i2", &npy("<i2", &[3, 2], &[1, 0, 2, 0, 3, 0, 4, 0, 5, 0, 6, 0]));
    let ts: Vec<u8> = (0..5).flat_map(|k| (k as f64 * 0.01).to_le_bytes()).collect();
    let mut with_ts = f64s.clone();
    with_ts.extend_from_slice(b"TIMESTAMPS");
    with_ts.extend_from_slice(&npy("<f8", &[5], &ts));
    put(&dir, "npy", "f8-times", &with_ts);
    let mut with_its = f64s;
    with_its.extend_from_slice(b"TIMESTAMPS");
    let its: Vec<u8> = (0..5i64).flat_map(|k| k.to_le_bytes()).collect();
    with_its.extend_from_slice(&npy("<i8", &[5], &its));
    put(&dir, "npy", "f8-itimes", &with_its);

    // Arrow IPC: long (utf8 and dictionary sensor, fixed-size-list values), wide, zero rows.
    let long = |dict: bool, rows: usize| {
        let sensor: ArrayRef = if dict {
            let mut b = StringDictionaryBuilder::<Int32Type>::new();
            for k in 0..rows {
                b.append_value(if k % 2 == 0 { "ff" } else { "th" });
            }
            Arc::new(b.finish())
        } else {
            Arc::new(StringArray::from_iter_values((0..rows).map(|k| if k % 2 == 0 { "ff" } else { "th" })))
        };
        let time: ArrayRef = Arc::new(Int64Array::from_iter_values((0..rows as i64).map(|k| k * 10_000_000)));
        let mut vb = FixedSizeListBuilder::new(Float64Builder::new(), 3);
        for k in 0..rows {
            vb.values().append_slice(&[k as f64, 2.0, 3.5]);
            vb.append(true);
        }
        let values: ArrayRef = Arc::new(vb.finish());
        RecordBatch::try_from_iter([("sensor", sensor), ("time_ns", time), ("values", values)]).unwrap()
    };
    let wide = {
        let col = |j: usize| -> ArrayRef { Arc::new(Float64Array::from_iter_values((0..4).map(|k| (k * j) as f64))) };
        let t: ArrayRef = Arc::new(Float64Array::from_iter_values((0..4).map(|k| k as f64 * 0.01)));
        RecordBatch::try_from_iter([("t", t), ("e1", col(1)), ("e2", col(2)), ("e3", col(3))]).unwrap()
    };
    for (name, batch, mode) in [
        ("long", long(false, 4), 0u8),
        ("dict", long(true, 4), 1),
        ("empty-dict", long(true, 0), 0),
        ("wide", wide.clone(), 2),
    ] {
        put(&dir, "arrow_ipc", &format!("{name}-file"), &with_mode(mode, &ipc(&batch, true)));
        put(&dir, "arrow_ipc", &format!("{name}-stream"), &with_mode(mode | 8, &ipc(&batch, false)));
    }
    put(&dir, "arrow_ipc", "wide-time", &with_mode(3, &ipc(&wide, true)));

    // CAN: the frames of a few sets for both presets, as candump logs and as binary frames.
    for (k, kind) in [PresetKind::BiotacMux, PresetKind::XelaUskin].into_iter().enumerate() {
        let codec = CanCodec::try_new(&CodecConfig::preset(PresetConfig::new(kind, &["ff", "mf"]))).unwrap();
        let taxels = codec.taxels(0);
        let mut enc = CanEncoder::new(codec).with_out_of_range(OutOfRangePolicy::Clamp);
        let mut can = Vec::new();
        for f in frames.iter().take(3) {
            let values: Vec<f64> = (0..taxels).map(|j| f.values[j % f.values.len()]).collect();
            for s in 0..2 {
                let _ = enc.encode(s, &values, f.time, &mut can);
            }
        }
        let mut log = Vec::new();
        write_candump(can.iter().copied(), "can0", &mut log).unwrap();
        put(&dir, "candump", kind.as_str(), &with_mode(k as u8, &log));
        let mut bin = Vec::new();
        let mut last = 0i64;
        for f in &can {
            bin.extend_from_slice(&f.id().to_le_bytes());
            bin.push((u8::from(f.is_extended()) << 7) | f.len() as u8);
            bin.extend_from_slice(f.data());
            bin.extend_from_slice(&(f.time().0 - last).to_le_bytes());
            last = f.time().0;
        }
        put(&dir, "can_frames", kind.as_str(), &bin);
    }

    // Scenes: the demo's, and one per source kind with every output.
    put(&dir, "scene", "demo", gradtac::demo::DEMO_SCENE.as_bytes());
    let outputs = ["normalise", "events", "window", "surface", "contour", "track", "force", "dos", "slip"]
        .iter()
        .map(|t| format!("[[output]]\ntap = \"{t}\"\npath = \"out/{t}.parquet\"\n"))
        .collect::<String>();
    for (name, source) in [
        ("npy", "{ npy = \"v.npy\", rate_hz = 100.0 }"),
        ("arrow", "{ arrow = \"v.arrow\", sensors = [\"ff\"] }"),
        ("csv", "{ csv = \"r.csv\", columns = \"e{1..24}\", time_column = \"t\", time_unit = \"ms\" }"),
    ] {
        let scene = format!(
            "[[sensor]]\nname = \"ff\"\nlayout = \"biotac-sp\"\nsource = {source}\n\n[stages.events]\nthreshold = 0.01\n\n{outputs}"
        );
        put(&dir, "scene", name, scene.as_bytes());
    }

    // Layout CSV.
    put(&dir, "layout_csv", "biotac-sp", layout.to_csv().as_bytes());

    // DoS model JSON.
    let cfg = DosFeatureConfig { features: vec![Feature::TrackDx], ..Default::default() };
    let samples: Vec<(DosClass, Vec<f64>)> = DosClass::ALL
        .into_iter()
        .enumerate()
        .flat_map(|(k, c)| [(c, vec![k as f64]), (c, vec![k as f64 + 0.5])])
        .collect();
    let model = DosModel::calibrate(cfg, &samples).unwrap();
    put(&dir, "dos_model", "one-feature", serde_json::to_string_pretty(&model).unwrap().as_bytes());

    // Force model and tare files (a mode byte first: see fuzz_targets/model_files.rs): a model
    // of each calibration method that reads the changes, from a gauge session of a simulated
    // member (unguarded: the guard would replace `forward` by `placed` on these plain changes, and
    // the seed is to hold a forward model), and a tare of the same member's untouched stretch.
    let session = ForceSession { noise_stream: 3, ..ForceSession::presses(7, 4) };
    let rec = session.simulate();
    // each frame's change from the first (untouched) one, in contact while the gauge reads
    let base = &rec.frames[0].values;
    let samples: Vec<GaugeSample> = rec
        .frames
        .iter()
        .zip(&rec.gauge)
        .map(|(f, &g)| GaugeSample {
            change: f.values.iter().zip(base).map(|(v, b)| v - b).collect(),
            contact: g > 0.0,
            area_mm2: None,
            amplitude: None,
            force_n: g,
            time_s: f.time.as_secs_f64(),
        })
        .collect();
    for method in [CalibrationMethod::Forward, CalibrationMethod::Ridge, CalibrationMethod::Total, CalibrationMethod::Placed]
    {
        let file = calibrate_unguarded(&samples, method, 1e-3, ForceMethod::Isotonic, &layout).unwrap();
        let json = serde_json::to_string_pretty(&file).unwrap();
        put(&dir, "model_files", method.name(), &with_mode(0, json.as_bytes()));
    }
    let rest = ForceSession { segments: vec![Segment::Rest(3.0)], noise_stream: 1, ..session }.simulate();
    let values: Vec<Vec<f64>> = rest.frames.iter().map(|f| f.values.clone()).collect();
    let times: Vec<i64> = rest.frames.iter().map(|f| f.time.0).collect();
    let tare = Tare::measure(&values, &times, "biotac-sp", "ff", &LocateConfig::default()).unwrap();
    let json = serde_json::to_string_pretty(&tare).unwrap();
    put(&dir, "model_files", "tare-track", &with_mode(1, json.as_bytes()));
    put(&dir, "model_files", "tare-force-nan", &with_mode(7, json.as_bytes()));

    // Parquet files of the stages' outputs (what `gradtac plot` reads).
    parquet(&dir, "frames", FrameShape::from_layout(&layout), &frames, &layout);
    let mut ev =
        Events::try_new(24, EventsConfig { threshold: Threshold::Uniform(0.002), ..Default::default() }).unwrap();
    let batches = ev.run_all(frames.clone()).unwrap();
    parquet(&dir, "events", FrameShape::from_layout(&layout), &batches, &layout);
    let mut w =
        Window::try_new(&WindowConfig { frames: Some(5), aggregate: Aggregate::Count, ..Default::default() }).unwrap();
    let windows = w.run_all(batches).unwrap();
    parquet(&dir, "window", FrameShape::from_layout(&layout), &windows, &layout);
    let icfg = InterpolateConfig { grid: GridConfig { nx: 8, ..Default::default() }, ..Default::default() };
    let surfaces = Interpolate::try_new(&icfg, &layout).unwrap().run_all(windows).unwrap();
    let grid = surfaces[0].grid.clone();
    parquet(&dir, "surface", SurfaceShape::new(grid), &surfaces, &layout);
    let contours = Contour::try_new(&ContourConfig { min_peak: 1.0, min_area_mm2: 5.0, ..Default::default() })
        .unwrap()
        .run_all(surfaces)
        .unwrap();
    parquet(&dir, "contour", (), &contours, &layout);
    let points = Track::try_new(&TrackConfig::default()).unwrap().run_all(contours).unwrap();
    parquet(&dir, "track", (), &points, &layout);
    recorded_hands(&dir);
    println!("seeds written to {}", dir.display());
}

/// Seeds of the `mcap` and `bag_chunks` targets: files written by hand (header, schema or
/// connection, messages with a header stamp and an `int16[] electrodes` array; loose and in
/// chunks of every compression), each prefixed with the mode byte (0: one sensor, header
/// time; 2: record time).
fn recorded_hands(dir: &Path) {
    use std::io::Write;
    fn lz4(b: &[u8]) -> Vec<u8> {
        let mut e = lz4_flex::frame::FrameEncoder::new(Vec::new());
        e.write_all(b).unwrap();
        e.finish().unwrap()
    }
    fn bz2(b: &[u8]) -> Vec<u8> {
        let mut e = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::best());
        e.write_all(b).unwrap();
        e.finish().unwrap()
    }
    fn string(s: &[u8]) -> Vec<u8> {
        [&(s.len() as u32).to_le_bytes()[..], s].concat()
    }
    // MCAP
    let rec = |op: u8, c: &[u8]| [&[op][..], &(c.len() as u64).to_le_bytes(), c].concat();
    let def = "std_msgs/Header header\nint16[] electrodes\n\
================================================================================\nMSG: std_msgs/Header\n\
builtin_interfaces/Time stamp\nstring frame_id\n\
================================================================================\nMSG: builtin_interfaces/Time\n\
int32 sec\nuint32 nanosec\n";
    let schema = rec(3, &[&1u16.to_le_bytes()[..], &string(b"x/msg/E"), &string(b"ros2msg"), &string(def.as_bytes())].concat());
    let meta = [string(b"k"), string(b"v")].concat();
    let channel = rec(
        4,
        &[&1u16.to_le_bytes()[..], &1u16.to_le_bytes(), &string(b"/rh/tactile"), &string(b"cdr"), &string(&meta)].concat(),
    );
    let mut msgs = Vec::new();
    for i in 0..4u32 {
        let mut cdr = vec![0u8, 1, 0, 0];
        cdr.extend(7i32.to_le_bytes());
        cdr.extend((i * 1000).to_le_bytes());
        cdr.extend(string(b"tip\0"));
        cdr.extend(3u32.to_le_bytes());
        for e in 0..3i16 {
            cdr.extend((100 * i as i16 + e).to_le_bytes());
        }
        let head = [&1u16.to_le_bytes()[..], &i.to_le_bytes(), &u64::from(i).to_le_bytes(), &u64::from(i).to_le_bytes()].concat();
        msgs.push(rec(5, &[head, cdr].concat()));
    }
    let header = rec(1, &[string(b"ros2"), string(b"seed")].concat());
    let inner: Vec<u8> = [schema.clone(), channel.clone()].into_iter().chain(msgs.iter().cloned()).flatten().collect();
    let chunk = |kind: &str, data: &[u8]| {
        let c = [
            &0u64.to_le_bytes()[..],
            &9u64.to_le_bytes(),
            &(inner.len() as u64).to_le_bytes(),
            &0u32.to_le_bytes(),
            &string(kind.as_bytes()),
            &(data.len() as u64).to_le_bytes(),
            data,
        ]
        .concat();
        rec(6, &c)
    };
    let tail = [rec(0x0F, &0u32.to_le_bytes()), rec(2, &[0u8; 20]), b"\x89MCAP0\r\n".to_vec()].concat();
    let magic = b"\x89MCAP0\r\n".to_vec();
    let loose = [magic.clone(), header.clone(), inner.clone(), tail.clone()].concat();
    put(dir, "mcap", "loose", &with_mode(0, &loose));
    put(dir, "mcap", "loose-record-time", &with_mode(2, &loose));
    for (kind, data) in [("", inner.clone()), ("lz4", lz4(&inner)), ("zstd", zstd::bulk::compress(&inner, 3).unwrap())] {
        let f = [magic.clone(), header.clone(), chunk(kind, &data), tail.clone()].concat();
        put(dir, "mcap", &format!("chunk-{}", if kind.is_empty() { "none" } else { kind }), &with_mode(0, &f));
    }

    // an MCAP file as the `mcap` crate's writer makes it (zstd chunks, message indexes,
    // the summary section)
    {
        let mut w = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            .chunk_size(Some(256))
            .create(std::io::Cursor::new(Vec::new()))
            .unwrap();
        let schema = w.add_schema("x/msg/E", "ros2msg", def.as_bytes()).unwrap();
        let ch = w.add_channel(schema, "/rh/tactile", "cdr", &std::collections::BTreeMap::new()).unwrap();
        for (i, m) in msgs.iter().enumerate() {
            let data = &m[9 + 22..];
            let h = mcap::records::MessageHeader { channel_id: ch, sequence: i as u32, log_time: i as u64, publish_time: 0 };
            w.write_to_known_channel(&h, data).unwrap();
        }
        w.finish().unwrap();
        put(dir, "mcap", "writer-zstd", &with_mode(0, &w.into_inner().into_inner()));
    }

    // ROS 1 bag
    let field = |name: &str, value: &[u8]| [&((name.len() + 1 + value.len()) as u32).to_le_bytes()[..], name.as_bytes(), b"=", value].concat();
    let brec = |fields: &[(&str, &[u8])], data: &[u8]| {
        let h: Vec<u8> = fields.iter().flat_map(|(n, v)| field(n, v)).collect();
        [&(h.len() as u32).to_le_bytes()[..], &h, &(data.len() as u32).to_le_bytes(), data].concat()
    };
    let def = "Header header\nint16[] electrodes\n\
================================================================================\nMSG: std_msgs/Header\n\
uint32 seq\ntime stamp\nstring frame_id\n";
    let conn_data = [field("topic", b"/rh/tactile"), field("type", b"x/E"), field("md5sum", b"0"), field("message_definition", def.as_bytes())].concat();
    let conn = brec(&[("op", &[7]), ("conn", &0u32.to_le_bytes()), ("topic", b"/rh/tactile")], &conn_data);
    let mut inner = conn.clone();
    for i in 0..4u32 {
        let mut m = i.to_le_bytes().to_vec();
        m.extend(7u32.to_le_bytes());
        m.extend((i * 1000).to_le_bytes());
        m.extend(string(b"tip"));
        m.extend(3u32.to_le_bytes());
        for e in 0..3i16 {
            m.extend((100 * i as i16 + e).to_le_bytes());
        }
        let t = [7u32.to_le_bytes(), (i * 1000).to_le_bytes()].concat();
        inner.extend(brec(&[("op", &[2]), ("conn", &0u32.to_le_bytes()), ("time", &t)], &m));
    }
    let bag_header = brec(&[("op", &[3]), ("index_pos", &0u64.to_le_bytes())], &[b' '; 16]);
    for (kind, data) in [("none", inner.clone()), ("bz2", bz2(&inner)), ("lz4", lz4(&inner))] {
        let c = brec(&[("op", &[5]), ("compression", kind.as_bytes()), ("size", &(inner.len() as u32).to_le_bytes())], &data);
        let idx = brec(&[("op", &[4]), ("ver", &1u32.to_le_bytes()), ("conn", &0u32.to_le_bytes())], &[0; 12]);
        let f = [b"#ROSBAG V2.0\n".to_vec(), bag_header.clone(), c, idx, conn.clone()].concat();
        put(dir, "bag_chunks", kind, &with_mode(0, &f));
    }
    let f = [b"#ROSBAG V2.0\n".to_vec(), bag_header, inner].concat();
    put(dir, "bag_chunks", "loose", &with_mode(2, &f));
}
