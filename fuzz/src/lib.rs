//! Helpers shared by the fuzz targets: a private scratch directory per fuzzing process
//! (readers that take a path get the input written to a file there) and a cap on how many
//! items a target pulls from an iterator.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// At most this many items are pulled from a source per input (a source that yields more
/// is still exercised; the cap keeps one execution short).
pub const MAX_ITEMS: usize = 20_000;

/// This process's scratch directory (under `/dev/shm` when it exists, so writes stay in memory).
pub fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let base = if Path::new("/dev/shm").is_dir() { PathBuf::from("/dev/shm") } else { std::env::temp_dir() };
        let dir = base.join(format!("gradtac-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch directory");
        dir
    })
}

/// Write `bytes` to the scratch file `name` and return its path.
pub fn file(name: &str, bytes: &[u8]) -> PathBuf {
    let p = scratch().join(name);
    std::fs::write(&p, bytes).expect("scratch file");
    p
}

/// Pull at most [`MAX_ITEMS`] items (errors included) from `it`; stop after the first error
/// when `stop_on_error` (as the pipeline does).
pub fn drain<T, E>(it: impl Iterator<Item = Result<T, E>>, stop_on_error: bool) -> usize {
    let mut n = 0;
    for item in it.take(MAX_ITEMS) {
        n += 1;
        if item.is_err() && stop_on_error {
            break;
        }
    }
    n
}

/// Split `data` at the first occurrence of `sep` (the whole input and nothing otherwise).
pub fn split_at<'a>(data: &'a [u8], sep: &[u8]) -> (&'a [u8], Option<&'a [u8]>) {
    match data.windows(sep.len()).position(|w| w == sep) {
        Some(i) => (&data[..i], Some(&data[i + sep.len()..])),
        None => (data, None),
    }
}

/// The sensors a recorded-hand target reads, from a mode byte: topic `/rh/tactile`; bit 0:
/// finger `ff` and `th` (else one sensor without a finger); bit 1: record time.
pub fn bag_sensors(mode: u8) -> Vec<gradtac_io::rosbag::BagSensor> {
    use gradtac_io::rosbag::{BagSensor, Finger, StampSource};
    let time = if mode & 2 != 0 { StampSource::Record } else { StampSource::Header };
    let one = |name: &str, finger| BagSensor {
        sensor: gradtac_stream::SensorId::new(name),
        topic: "/rh/tactile".into(),
        finger,
        time,
    };
    if mode & 1 != 0 {
        vec![one("ff", Some(Finger::Ff)), one("th", Some(Finger::Th))]
    } else {
        vec![one("x", None)]
    }
}

/// Let panics raised inside the Arrow / Parquet crates unwind (instead of aborting at once,
/// as libfuzzer-sys's hook does) so that gradtac's containment at the source boundary
/// ([`gradtac_io::contain`]) can turn them into errors; a panic anywhere else, or one that
/// gradtac does not contain, still aborts and is reported as a crash. Call at the start of
/// every execution of a target whose readers contain dependency panics (idempotent).
pub fn contain_dependency_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let aborting = std::panic::take_hook();
        // gradtac's quiet hook (silent inside `contain`) would hide a panic of gradtac's own
        // code inside `contain` from the fuzzer: install it now (it is installed once per
        // process) and replace it, so this hook decides alone.
        gradtac_io::contain::install_quiet_hook();
        drop(std::panic::take_hook());
        std::panic::set_hook(Box::new(move |info| {
            let file = info.location().map(|l| l.file()).unwrap_or("");
            let dependency =
                ["/arrow-", "/parquet-"].iter().any(|c| file.contains(c)) && file.contains("/.cargo/registry/");
            if !dependency {
                aborting(info);
            }
        }));
    });
}
