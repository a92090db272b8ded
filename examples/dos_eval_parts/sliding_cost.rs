//! Per-frame cost of the `dos` stage in the sliding mode, shared by `dos_eval` (its window
//! part's cost line) and `dos_sliding_cost`.

use gradtac::stages::dos::{DosClassifier, DosModel};
use gradtac::stream::{Layout, SensorId, Stage, TaxelFrame, Timestamp};
use std::error::Error;
use std::time::Instant;

/// Each frame's `push` time (µs) of `model`'s `dos` stage in the sliding mode (the last `n`
/// frames, a decision every `hop`, with early answers if `early`) over every recording (raw
/// values, one row per frame, 100 Hz), one fresh stage per recording.
pub fn push_costs<'a>(
    model: &DosModel,
    recordings: impl IntoIterator<Item = &'a [Vec<f64>]>,
    layout: &Layout,
    (n, hop, early): (u64, u64, bool),
) -> Result<Vec<f64>, Box<dyn Error>> {
    let mut cost = Vec::new();
    let mut out = Vec::new();
    for frames in recordings {
        let mut stage = DosClassifier::try_new(model.clone(), layout, Some(n))?.with_hop(hop)?;
        if early {
            stage = stage.with_early_decisions()?;
        }
        for (seq, v) in frames.iter().enumerate() {
            let f = TaxelFrame::new(
                SensorId::new("ff"),
                Timestamp::from_nanos(seq as i64 * 10_000_000),
                seq as u64,
                v.clone(),
            );
            let t = Instant::now();
            stage.push(f, &mut out)?;
            cost.push(t.elapsed().as_secs_f64() * 1e6);
            out.clear();
        }
    }
    Ok(cost)
}
