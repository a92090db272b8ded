//! Issue #12: every size-like and geometric setting has a documented bound, checked when the
//! stage is built (before any data moves), with an error naming the setting.

use gradtac_stages::events::{Events, EventsConfig, Threshold};
use gradtac_stages::interpolate::{Grid, GridConfig, Interpolate, InterpolateConfig};
use gradtac_stages::limits::*;
use gradtac_stages::window::{Window, WindowConfig};
use gradtac_stream::{Extent, Layout, Stage, TaxelFrame, Timestamp};

fn err<T, E: std::fmt::Display>(r: Result<T, E>) -> String {
    match r {
        Ok(_) => panic!("accepted"),
        Err(e) => e.to_string(),
    }
}

/// A grid extent or margin around 1e160 mm used to reach spade, which panicked ("This is a
/// bug in spade"), even in `gradtac explain`. Both are refused by the stage's constructor.
#[test]
fn grid_extent_or_margin_of_1e160_is_refused_before_spade() {
    let bt = Layout::biotac_sp();
    let margin =
        InterpolateConfig { grid: GridConfig { margin_mm: Some(1e160), ..Default::default() }, ..Default::default() };
    let e = err(Interpolate::<TaxelFrame>::try_new(&margin, &bt));
    assert!(e.contains("margin_mm") && e.contains("1000000 mm"), "{e}");
    let extent = Extent { x_min: -1e160, x_max: 1e160, y_min: -1e160, y_max: 1e160 };
    let cfg =
        InterpolateConfig { grid: GridConfig { extent: Some(extent), ..Default::default() }, ..Default::default() };
    let e = err(Interpolate::<TaxelFrame>::try_new(&cfg, &bt));
    assert!(e.contains("reaches beyond"), "{e}");
    // the largest accepted margin builds (and interpolates) fine
    let ok = InterpolateConfig {
        grid: GridConfig { margin_mm: Some(MAX_MM), nx: 8, ..Default::default() },
        ..Default::default()
    };
    assert!(Interpolate::<TaxelFrame>::try_new(&ok, &bt).is_ok());
    // layout coordinates are bounded too
    let names = (0..3).map(|i| format!("t{i}")).collect();
    let e = err(Layout::try_new("far", names, vec![[0.0, 0.0], [1e160, 0.0], [0.0, 1.0]], None));
    assert!(e.contains("beyond"), "{e}");
}

/// `nx = 4096` used to reach 5.2 GB on 30 frames; grids are capped at 2²⁰ points.
#[test]
fn grid_points_are_capped() {
    let e = Extent { x_min: 0.0, x_max: 1.0, y_min: 0.0, y_max: 1.0 };
    assert!(err(Grid::try_new(e, 4096, 4096)).contains("1048576 points"));
    assert!(Grid::try_new(e, 1024, 1024).is_ok());
    assert_eq!(MAX_GRID_POINTS, 1 << 20);
}

/// A 3-row recording with `threshold = 1e-9, max_events_per_step = 4294967295` took 1.9 GB
/// and 47 s. The cap is bounded; the tiny threshold with the largest cap stays small.
#[test]
fn events_per_step_are_bounded_and_a_tiny_threshold_stays_small() {
    let cfg = EventsConfig { threshold: Threshold::Uniform(1e-9), max_events_per_step: u32::MAX, ..Default::default() };
    let e = err(Events::try_new(24, cfg));
    assert!(e.contains("max_events_per_step") && e.contains("4096"), "{e}");
    let cfg = EventsConfig {
        threshold: Threshold::Uniform(1e-9),
        max_events_per_step: MAX_EVENTS_PER_STEP,
        ..Default::default()
    };
    let mut ev = Events::try_new(24, cfg).unwrap();
    let mut out = Vec::new();
    for (k, v) in [1e-3, 1.0, 1e-3].into_iter().enumerate() {
        let f = TaxelFrame::new("ff".into(), Timestamp(k as i64 * 10_000_000), k as u64, vec![v; 24]);
        ev.push(f, &mut out).unwrap();
    }
    ev.finish(&mut out).unwrap();
    let n: usize = out.iter().map(|b| b.events.len()).sum();
    assert!(n <= 3 * 24 * MAX_EVENTS_PER_STEP as usize, "{n}");
    assert!(ev.counters().overflow > 1_000_000_000, "the rest are counted, not stored");
}

#[test]
fn window_sizes_are_bounded() {
    let w =
        |frames, duration_ms, step| Window::try_new(&WindowConfig { frames, duration_ms, step, ..Default::default() });
    assert!(err(w(Some(u64::MAX), None, 1)).contains("frames"));
    assert!(err(w(None, Some(1e300), 1)).contains("duration_ms"));
    assert!(err(w(Some(10), None, u64::MAX)).contains("step"));
    assert!(w(Some(MAX_WINDOW_FRAMES), None, 1).is_ok());
}
