//! Per-frame cost of the `dos` stage, shared by `dos_eval` (its window part's cost lines) and
//! `dos_sliding_cost`.

use gradtac::stages::dos::{DosClassifier, DosDecision, DosModel};
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
            cost.push(push_timed(&mut stage, seq, v, &mut out)?);
            out.clear();
        }
    }
    Ok(cost)
}

/// Push frame `seq` (raw values `v`, 100 Hz, sensor `ff`) into `stage`, its decisions onto
/// `out`; the push's time in µs (the frame's construction outside it).
pub fn push_timed(
    stage: &mut DosClassifier,
    seq: usize,
    v: &[f64],
    out: &mut Vec<DosDecision>,
) -> Result<f64, Box<dyn Error>> {
    let f = frame(seq, v);
    let t = Instant::now();
    stage.push(f, out)?;
    Ok(t.elapsed().as_secs_f64() * 1e6)
}

/// Frame `seq` of a recording (raw values `v`) as the `dos` stage is given it: sensor `ff`,
/// 100 Hz from time 0.
pub fn frame(seq: usize, v: &[f64]) -> TaxelFrame {
    TaxelFrame::new(SensorId::new("ff"), Timestamp::from_nanos(seq as i64 * 10_000_000), seq as u64, v.to_vec())
}
