//! Per-frame cost of the `dos` window net's causal vote with and without the motion inputs
//! (`WindowNetConfig::motion`, the default of `gradtac calibrate` since stop 32), at the default net's size (96 hidden units: three
//! mirror-averaged members of 16). The cost does not depend on the weights, so the nets here
//! have fixed made-up weights and the frames are synthetic (no data needed): 200 spans of 300
//! frames each, one `push` and one `decision` per frame. Prints the median and p99 per frame.
//!
//! `cargo run --release --example window_motion_cost`

use gradtac::stages::dos::{DosClass, DosWindowNet, WindowNetConfig};
use gradtac::stream::Layout;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let layout = Layout::biotac_sp();
    println!("| window net (96 hidden) | median per frame | p99 per frame |");
    println!("|---|---|---|");
    for motion in [false, true] {
        let config = WindowNetConfig { hidden: 96, motion, ..Default::default() };
        let d = config.inputs(24);
        let net = DosWindowNet {
            config,
            taxels: 24,
            classes: DosClass::ALL.to_vec(),
            input_mean: vec![0.0; d],
            input_scale: vec![1.0; d],
            w1: (0..96).map(|h| (0..d).map(|j| ((h * 7 + j * 3) % 11) as f64 * 0.01).collect()).collect(),
            b1: vec![0.0; 96],
            w2: (0..7).map(|k| (0..96).map(|h| ((k + h) % 5) as f64 * 0.1).collect()).collect(),
            b2: vec![0.0; 7],
            recordings: 1,
        };
        net.validate()?;
        let mut v = net.vote(&layout)?;
        let mut cost = Vec::with_capacity(60_000);
        for r in 0..200u64 {
            v.reset();
            for t in 0..300u64 {
                let f: Vec<f64> = (0..24u64).map(|i| (2000 + (i * 37 + t * (r + 3)) % 97) as f64).collect();
                let s = Instant::now();
                std::hint::black_box(v.push(&f)?);
                std::hint::black_box(v.decision());
                cost.push(s.elapsed().as_secs_f64() * 1e6);
            }
        }
        cost.sort_by(f64::total_cmp);
        let q = |p: f64| cost[((cost.len() - 1) as f64 * p).round() as usize];
        let name = if motion { "with the motion inputs (the default)" } else { "levels only (stop 31's)" };
        println!("| {name} | {:.2} µs | {:.2} µs |", q(0.5), q(0.99));
    }
    Ok(())
}
