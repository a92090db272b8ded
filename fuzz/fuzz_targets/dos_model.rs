//! DoS model JSON: any bytes as a model file, read as `gradtac` reads `model = "..."`, then a
//! classifier built on the BioTac SP layout and run over a short synthetic press, once deciding
//! at the end and once in the sliding mode with early answers (its replay prepared ahead).
#![no_main]

use gradtac::calibrate::read_model;
use gradtac_stages::dos::DosClassifier;
use gradtac_stream::{Layout, SensorId, Stage, TaxelFrame, Timestamp};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = gradtac_fuzz::file("model.json", data);
    let Ok(model) = read_model(&path) else { return };
    let layout = Layout::biotac_sp();
    let Ok(once) = DosClassifier::try_new(model.clone(), &layout, None) else { return };
    let sliding = DosClassifier::try_new(model, &layout, Some(20)).and_then(|d| d.with_hop(3)?.with_early_decisions());
    for mut dos in [Ok(once), sliding].into_iter().flatten() {
        let mut out = Vec::new();
        for k in 0..60u64 {
            let values = (0..layout.len()).map(|j| 2000.0 + ((k * 7 + j as u64 * 13) % 50) as f64).collect();
            let frame = TaxelFrame::new(SensorId::new("ff"), Timestamp::at_rate(k, 100.0), k, values);
            if dos.push(frame, &mut out).is_err() {
                break;
            }
        }
        let _ = dos.finish(&mut out);
    }
});
