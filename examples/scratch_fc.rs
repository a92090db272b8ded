use gradtac::stages::centroid::Centroid;
use gradtac::stages::contour::{Contour, ContourConfig, ContourOutcome};
use gradtac::stages::events::{Events, EventsConfig, Polarity, Threshold};
use gradtac::stages::interpolate::{GridConfig, Interpolate, InterpolateConfig};
use gradtac::stages::locate::{LocateConfig, Preset};
use gradtac::stages::savgol::{SavGol, SavGolConfig};
use gradtac::stages::sim_family::{Member, PhysicsSet};
use gradtac::stages::window::{Aggregate, Window, WindowConfig, WindowKind};
use gradtac::stream::{Layout, StageExt};
fn main() {
    let layout = Layout::biotac_sp();
    let minpk: f64 = std::env::args().nth(1).map_or(2.0, |s| s.parse().unwrap());
    let (mut fe, mut fc, mut n) = (0usize, 0usize, 0usize);
    for m in Member::grid(0..8) {
        let rec = m.simulate_in(PhysicsSet::Tuning);
        let sg = SavGol::try_with_rate(24, SavGolConfig::default(), 100.0).unwrap();
        let ev = Events::try_new(
            24,
            EventsConfig {
                threshold: Threshold::Noise { noise_sigmas: 4.0, calibrate_frames: 20 },
                polarity: Polarity::PressRelease,
                ..Default::default()
            },
        )
        .unwrap();
        let w = Window::try_new(&WindowConfig {
            kind: WindowKind::Cumulative,
            aggregate: Aggregate::Signed,
            ..Default::default()
        })
        .unwrap();
        let s = Interpolate::try_new(
            &InterpolateConfig {
                grid: GridConfig { nx: 32, ..Default::default() },
                incremental: true,
                ..Default::default()
            },
            &layout,
        )
        .unwrap();
        let c = Contour::try_new(&ContourConfig { min_peak: minpk, min_area_mm2: 60.0, ..Default::default() }).unwrap();
        let out = sg.then(ev).then(w).then(s).then(c).run_all(rec.frames.clone()).unwrap();
        let cen = Centroid::try_new(&LocateConfig::preset(Preset::Fast), &layout)
            .unwrap()
            .run_all(rec.frames.clone())
            .unwrap();
        let idx = |t: gradtac::stream::Timestamp| (t.as_secs_f64() * 100.0).round() as usize;
        for f in &out {
            let k = idx(f.end);
            if k > 30
                && k < rec.force.len()
                && rec.force[k] == 0.0
                && rec.force[k.saturating_sub(8)..(k + 8).min(rec.force.len())].iter().all(|&x| x == 0.0)
            {
                n += 1;
                if matches!(f.outcome, ContourOutcome::Contact(_)) {
                    fe += 1;
                    if std::env::var("V").is_ok() {
                        let first = rec.force.iter().position(|&x| x > 0.0).unwrap();
                        println!("seed {} {:?} k {k} first force {first} len {}", m.seed, m.kind, rec.force.len());
                    }
                }
            }
        }
        for f in &cen {
            let k = idx(f.end);
            if k > 30
                && k < rec.force.len()
                && rec.force[k.saturating_sub(8)..(k + 8).min(rec.force.len())].iter().all(|&x| x == 0.0)
            {
                if matches!(f.outcome, ContourOutcome::Contact(_)) {
                    fc += 1;
                }
            }
        }
    }
    println!(
        "untouched frames {n}: events PR cumulative contact {:.1} %, centroid {:.1} %",
        100.0 * fe as f64 / n as f64,
        100.0 * fc as f64 / n as f64
    );
}
