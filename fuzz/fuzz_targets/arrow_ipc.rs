//! Arrow IPC source: the first byte selects the layout (long; long keeping sensor "ff";
//! wide `e{1..3}` at a rate; wide `*` with a time column `t` in s) and the framing (auto /
//! file / stream); the rest is the IPC data, read as `gradtac run` reads an `arrow` source.
#![no_main]

use gradtac_io::arrow_ipc::{open_reader, BatchLayout, IpcFormat, WideTime};
use gradtac_io::{ColumnSelector, TimeUnit};
use gradtac_stream::SensorId;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    gradtac_fuzz::contain_dependency_panics();
    let Some((&mode, body)) = data.split_first() else { return };
    let sensor = SensorId::new("ff");
    let layout = match mode & 3 {
        0 => BatchLayout::Long { sensors: None },
        1 => BatchLayout::Long { sensors: Some(vec!["ff".into()]) },
        2 => BatchLayout::Wide {
            sensor,
            columns: ColumnSelector::Pattern("e{1..3}".into()),
            time: WideTime::Rate(100.0),
        },
        _ => BatchLayout::Wide {
            sensor,
            columns: ColumnSelector::Pattern("*".into()),
            time: WideTime::Column { name: "t".into(), unit: TimeUnit::Seconds },
        },
    };
    let format = match (mode >> 2) & 3 {
        1 => IpcFormat::File,
        2 => IpcFormat::Stream,
        _ => IpcFormat::Auto,
    };
    let reader = std::io::Cursor::new(body.to_vec());
    if let Ok(frames) = open_reader(reader, "fuzz.arrow", format, layout) {
        gradtac_fuzz::drain(frames, false);
    }
});
