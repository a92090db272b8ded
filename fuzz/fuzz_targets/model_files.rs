//! Force model and tare files: any bytes as `force.json` (`[stages.force] model = …`) or
//! `tare.json` (`[stages.locate] baseline = …`), read as `gradtac` reads a scene that names
//! them, then the sensor's chain built from the scene and run over a short synthetic press
//! (untouched, pressed, released; with a non-finite frame when the mode asks).
//!
//! First byte: bit 0 picks the file (0 force model, 1 tare), bit 1 puts a NaN in one frame,
//! bit 2 (tare only) taps `force` with the built-in curve rather than `track`; rest: the file.
#![no_main]

use gradtac::chain::SensorChain;
use gradtac::sinks::Collected;
use gradtac::{Plan, Scene};
use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, file)) = data.split_first() else { return };
    let dir = gradtac_fuzz::scratch().join("models");
    std::fs::create_dir_all(&dir).expect("scratch directory");
    let (name, table, tap) = if mode & 1 == 0 {
        ("force.json", "[stages.force]\nmodel = \"force.json\"\n", "force")
    } else {
        ("tare.json", "[stages.locate]\nbaseline = \"tare.json\"\n", if mode & 4 == 0 { "track" } else { "force" })
    };
    std::fs::write(dir.join(name), file).expect("scratch file");
    let text = format!(
        "[[sensor]]\nname = \"ff\"\nsource = {{ csv = \"r.csv\", columns = \"ff_e{{1..24}}\", rate_hz = 100.0 }}\n\
         [[output]]\ntap = \"{tap}\"\npath = \"out.parquet\"\n{table}"
    );
    let Ok(scene) = Scene::from_toml(&text, &dir, Path::new("fuzz-scene.toml")) else { return };
    let Ok(plan) = Plan::new(&scene) else { return };
    let _ = plan.explain(&scene);
    let Some(sensor) = plan.sensors.first() else { return };
    let Ok(mut chain) = SensorChain::build(&scene, sensor) else { return };
    let mut sink = Collected::default();
    let id = SensorId::new("ff");
    for k in 0..90u64 {
        // 30 frames untouched, 40 pressed near taxels 3–8, 20 released
        let press = if (30..70).contains(&k) { 120.0 } else { 0.0 };
        let mut values: Vec<f64> = (0..24u64)
            .map(|j| 2000.0 + ((k * 7 + j * 13) % 5) as f64 + if (3..9).contains(&j) { press } else { 0.0 })
            .collect();
        if mode & 2 != 0 && k == 45 {
            values[4] = f64::NAN;
        }
        let frame = TaxelFrame::new(id.clone(), Timestamp::at_rate(k, 100.0), k, values);
        if chain.process(Some(frame), false, &mut sink).is_err() {
            return;
        }
    }
    let _ = chain.process(None, true, &mut sink);
});
