//! Diagnosis of the folded kernel's ring fits (issue #22, round 9): the `accurate` fit with
//! and without `fit_fold_lobe`, both without the learned correction, run side by side on the
//! family's **tuning** members (seeds 0..N × the given kinds, `PhysicsSet::Tuning`); per
//! fitted frame of the movement the raw (uncorrected) positions' errors against the truth at
//! the frame's middle time, and what tells a ring fit from a right one. Never run on the
//! held-out members.
//!
//! Run: `cargo run --release --example fold_diag -- [--seeds N] [--kind circle] ['TOML line' …]`
//! (each line is added on top of `preset = "accurate"` for the *folded* fit, e.g. a guard
//! setting; the unfolded fit is always the preset). Prints per member: frames, the folded
//! and unfolded mean raw errors (mm), and over its "ring frames" (the folded error over the
//! unfolded one by more than 1 mm) against the others: the mean distance between the two
//! fits, the folded fit's `ρ/w` at the strongest electrode (layout plane), its far-lobe
//! weight, spread and relative residual, and the unfolded fit's residual.

use gradtac::stages::fit::Fit;
use gradtac::stages::locate::LocateConfig;
use gradtac::stages::sim_family::{Member, PathKind, PhysicsSet};
use gradtac::stream::{Layout, Stage};

#[derive(Default)]
struct Acc {
    n: f64,
    sep: f64,
    rho: f64,
    lobe: f64,
    w: f64,
    res_f: f64,
    res_u: f64,
    d_cen: f64,
    /// frames whose separation exceeds 1, 1.5, 2, 3 mm; whose folded residual exceeds the
    /// unfolded one; whose far lobe is ≥ 0.5
    sep_over: [f64; 4],
    worse_res: f64,
    high_lobe: f64,
}

impl Acc {
    fn add(&mut self, v: [f64; 7]) {
        self.n += 1.0;
        self.sep += v[0];
        self.rho += v[1];
        self.lobe += v[2];
        self.w += v[3];
        self.res_f += v[4];
        self.res_u += v[5];
        self.d_cen += v[6];
        for (k, r) in [1.0, 1.5, 2.0, 3.0].iter().enumerate() {
            self.sep_over[k] += f64::from(u8::from(v[0] > *r));
        }
        self.worse_res += f64::from(u8::from(v[4] > v[5]));
        self.high_lobe += f64::from(u8::from(v[2] >= 0.5));
    }
    fn show(&self) -> String {
        let n = self.n.max(1.0);
        format!(
            "{:4} fr: sep {:.2} ρ/w {:.2} lobe {:+.2} w {:.2} res {:.3}/{:.3} Δcen {:.2} sep>1/1.5/2/3 {:.0}/{:.0}/{:.0}/{:.0} % res worse {:.0} % lobe≥.5 {:.0} %",
            self.n,
            self.sep / n,
            self.rho / n,
            self.lobe / n,
            self.w / n,
            self.res_f / n,
            self.res_u / n,
            self.d_cen / n,
            100.0 * self.sep_over[0] / n,
            100.0 * self.sep_over[1] / n,
            100.0 * self.sep_over[2] / n,
            100.0 * self.sep_over[3] / n,
            100.0 * self.worse_res / n,
            100.0 * self.high_lobe / n
        )
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut seeds = 8u64;
    let mut kinds: Vec<PathKind> = PathKind::ALL.to_vec();
    let mut extra = String::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--seeds" => seeds = it.next().and_then(|v| v.parse().ok()).expect("--seeds N"),
            "--kind" => {
                let k = it.next().expect("--kind NAME");
                kinds = PathKind::ALL.iter().copied().filter(|p| p.name() == k).collect();
            }
            line => {
                extra.push_str(line);
                extra.push('\n');
            }
        }
    }
    let base = "preset = \"accurate\"\nfit_learned_correction = false\n";
    let cu: LocateConfig = toml::from_str(base).unwrap();
    let cf: LocateConfig = toml::from_str(&format!("{base}fit_fold_lobe = true\n{extra}")).unwrap();
    cf.validate().expect("valid settings");
    let layout = Layout::biotac_sp();
    let pos = layout.positions().to_vec();
    for m in Member::grid(0..seeds).into_iter().filter(|m| kinds.contains(&m.kind)) {
        let p = m.physics_in(PhysicsSet::Tuning);
        let rec = p.simulate(m.seed);
        let (mut fu, mut ff) = (Fit::try_new(&cu, &layout).unwrap(), Fit::try_new(&cf, &layout).unwrap());
        fu.record_inputs(true);
        ff.record_inputs(true);
        let (mut ou, mut of) = (Vec::new(), Vec::new());
        let (mut eu, mut ef, mut n) = (0.0, 0.0, 0.0f64);
        let (mut ring, mut right) = (Acc::default(), Acc::default());
        let (t0, t1) = rec.moving_s;
        for f in rec.frames.iter().cloned() {
            ou.clear();
            of.clear();
            fu.push(f.clone(), &mut ou).unwrap();
            ff.push(f, &mut of).unwrap();
            let (Some((xu, pu)), Some((xf, pf)), Some(c)) = (fu.last_input(), ff.last_input(), of.last()) else {
                continue;
            };
            let mid = 0.5 * (c.start.as_secs_f64() + c.end.as_secs_f64());
            if mid <= t0 || mid >= t1 {
                continue;
            }
            let Some(t) = rec.truth_at(mid) else { continue };
            let (du, df) = ((pu[0] - t[0]).hypot(pu[1] - t[1]), (pf[0] - t[0]).hypot(pf[1] - t[1]));
            eu += du;
            ef += df;
            n += 1.0;
            // the strongest (gain-corrected) electrode and the Δ²-weighted centroid, from the inputs
            let v = &xf[7..31];
            let k = (0..24).max_by(|&a, &b| v[a].abs().total_cmp(&v[b].abs())).unwrap();
            let (mut cx, mut cy, mut cw) = (0.0, 0.0, 0.0);
            for i in 0..24 {
                let w = v[i] * v[i];
                cx += w * pos[i][0];
                cy += w * pos[i][1];
                cw += w;
            }
            let w_f = xf[2].exp();
            let rho = (pos[k][0] - pf[0]).hypot(pos[k][1] - pf[1]) / w_f;
            let d_cen = (cx / cw - pf[0]).hypot(cy / cw - pf[1]) - (cx / cw - pu[0]).hypot(cy / cw - pu[1]);
            let row = [(pf[0] - pu[0]).hypot(pf[1] - pu[1]), rho, xf[3], w_f, xf[4], xu[4], d_cen];
            if df > du + 1.0 {
                ring.add(row);
            } else {
                right.add(row);
            }
        }
        println!(
            "seed {:2} {:10} {:12} | fold {:.2} mm unfold {:.2} mm | ring {} | other {}",
            m.seed,
            m.kind.name(),
            rec.physics.kernel.name(),
            ef / n.max(1.0),
            eu / n.max(1.0),
            ring.show(),
            right.show()
        );
    }
}
