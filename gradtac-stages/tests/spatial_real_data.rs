//! The spatial chain on real BioTacSP-DoS recordings (Zapata-Impata, Gil and Torres, Sensors
//! 19(3):523, 2019), read from `shared/data` when present; the test passes without it.
//!
//! raw counts → events (τ = 0.005 on ln counts) → sliding window (10 frames) → natural
//! neighbour 32×32 → maximal contour → track. Checks that real data runs without errors and
//! yields finite geometry, and prints each slip class's mean track displacement (an
//! observation, not an assertion: the paper's method is evaluated elsewhere).

use gradtac_stages::contour::{Contour, ContourConfig};
use gradtac_stages::events::{Events, EventsConfig, Threshold};
use gradtac_stages::interpolate::{GridConfig, Interpolate, InterpolateConfig};
use gradtac_stages::track::{ContactState, Track, TrackConfig};
use gradtac_stages::window::{Window, WindowConfig};
use gradtac_stream::{Layout, StageExt, TaxelFrame, Timestamp};

mod common;
use common::{data_dir, read};

#[test]
fn real_recordings_run_through_the_spatial_chain() {
    let Some(root) = data_dir() else { return };
    let l = Layout::biotac_sp();
    let mut frames_total = 0usize;
    let mut contact_total = 0usize;
    for class in ["n", "e", "s", "w", "cw", "aw", "t"] {
        let mut files: Vec<_> = std::fs::read_dir(root.join(class)).unwrap().map(|e| e.unwrap().path()).collect();
        files.sort();
        let (mut dx, mut dy, mut n) = (0.0, 0.0, 0);
        for f in files.iter().take(4) {
            let rows = read(f);
            let ev = Events::try_new(24, EventsConfig { threshold: Threshold::Uniform(0.005), ..Default::default() })
                .unwrap();
            let w = Window::try_new(&WindowConfig { frames: Some(10), ..Default::default() }).unwrap();
            let icfg = InterpolateConfig {
                grid: GridConfig { nx: 32, ..Default::default() },
                incremental: true,
                ..Default::default()
            };
            let i = Interpolate::try_new(&icfg, &l).unwrap();
            let c = Contour::try_new(&ContourConfig::default()).unwrap();
            let t = Track::try_new(&TrackConfig::default()).unwrap();
            let mut chain = ev.then(w).then(i).then(c).then(t);
            let input: Vec<TaxelFrame> = rows
                .into_iter()
                .enumerate()
                .map(|(k, v)| TaxelFrame::new("ff".into(), Timestamp::at_rate(k as u64, 100.0), k as u64, v))
                .collect();
            let len = input.len();
            let pts = chain.run_all(input).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
            assert_eq!(pts.len(), len, "{}", f.display());
            let contacts: Vec<_> = pts.iter().filter(|p| p.state == ContactState::Contact).collect();
            for p in &contacts {
                assert!(p.x_mm.is_finite() && p.y_mm.is_finite() && p.area_mm2 > 0.0, "{}: {p:?}", f.display());
            }
            frames_total += len;
            contact_total += contacts.len();
            if let (Some(a), Some(b)) = (contacts.first(), contacts.last()) {
                dx += b.x_mm - a.x_mm;
                dy += b.y_mm - a.y_mm;
                n += 1;
            }
        }
        if n > 0 {
            eprintln!(
                "class {class:>2}: mean track displacement ({:+.2}, {:+.2}) mm over {n} files",
                dx / n as f64,
                dy / n as f64
            );
        }
    }
    eprintln!("{contact_total} of {frames_total} frames with contact");
    assert!(contact_total > 0);
}
