//! The model fit's recorded inputs over a simulated recording: the learned correction's
//! samples, as `train_fit_correction` and `fit_lopo` take them.

use gradtac::stages::fit::Fit;
use gradtac::stages::locate::LocateConfig;
use gradtac::stages::sim_family::FamilyRecording;
use gradtac::stream::{Layout, Stage};

/// Runs the fit of `cfg`, its learned correction off (the samples never depend on the
/// weights), over `rec`'s frames with its inputs recorded, and calls `each(inputs, raw
/// position, middle time s)` for every frame that gives both inputs and a contour.
pub fn each_fitted_frame(
    rec: &FamilyRecording,
    cfg: &LocateConfig,
    layout: &Layout,
    mut each: impl FnMut(&[f64], [f64; 2], f64),
) {
    let cfg = LocateConfig { fit_learned_correction: false, ..cfg.clone() };
    let mut fit = Fit::try_new(&cfg, layout).expect("valid fit settings");
    fit.record_inputs(true);
    let mut out = Vec::new();
    for f in rec.frames.iter().cloned() {
        out.clear();
        fit.push(f, &mut out).expect("simulated frames are finite");
        let (Some((x, p)), Some(c)) = (fit.last_input(), out.last()) else { continue };
        each(x, p, 0.5 * (c.start.as_secs_f64() + c.end.as_secs_f64()));
    }
}
