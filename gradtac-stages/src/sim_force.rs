//! Force sessions on the forward-model family: presses at several places of the pad with a
//! gauge's force truth, the skin's response **not linear in force** and its **spread growing
//! with force** — what calibrating and scoring a force model needs ([`sim_family`](crate::sim_family) moves one
//! contact at one constant force; its members and figures are unchanged by this module).
//!
//! A session is one member's sensor ([`Physics::draw`] of the seed: kernel shape and width,
//! amplitude, signed gains, fluid lag, saturation knee, baselines, drift, noise, 12-bit ADC —
//! every term of [`sim_family`](crate::sim_family)'s table) plus a [`ForceResponse`] drawn from the same seed:
//!
//! | term | formula | range drawn per member |
//! |---|---|---|
//! | response to force | `uᵢ = σᵢ gᵢ A F_ref (F/F_ref)^γ K(ρᵢ; w(F))` (sublinear: a stiffening skin) | `γ ∈ [0.55, 0.9]`, `F_ref` = 2 N |
//! | spread | `w(F) = clamp(w · (F/F_ref)^s, 0.75 w, 1.6 w)`: the contact patch grows with force (Hertz: `s` = 1/3) | `s ∈ [0.1, 0.33]` |
//! | gauge | the measured force: `F + N(0, ε²)`, 0 when `F` = 0 | `ε ∈ [0.005, 0.03]` N |
//!
//! A session is a list of [`Segment`]s — rest, or a press at a place rising linearly to its
//! peak, holding and falling — simulated frame by frame at [`RATE_HZ`]
//! ([`ForceSession::simulate`]); [`ForceSession::presses`] draws the calibration protocol
//! (`n` presses at `n` places drawn inside the pad region of [`pad_region`], peaks
//! 1.5–10 N, rising 2 s, holding 0.5 s, falling 1.5 s, 0.6 s apart). Time can start later than 0
//! (`t0_s`), so a second recording continues the first one's drift.
//!
//! ```
//! use gradtac_stages::sim_force::ForceSession;
//! let s = ForceSession::presses(3, 4).simulate();
//! assert_eq!(s.frames.len(), s.force.len());
//! assert!(s.force.iter().cloned().fold(0.0, f64::max) >= 1.5);
//! ```

use crate::sim_family::{
    inside_convex, pad_region, skin_point, sub_seed, PathKind, Physics, CORE_MM, RATE_HZ, SKIN_MM,
};
use gradtac_stream::{SensorId, TaxelFrame, Timestamp};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// Force at which the response equals the linear model's (N).
pub const F_REF_N: f64 = 2.0;

/// The force evaluations' **held-out** members (`examples/force_eval.rs`): scored once per
/// round's winner, after the choice; never explored, probed or tuned on.
pub const HELD_OUT_SEEDS: std::ops::Range<u64> = 100..116;

/// The **fresh** held-out members (stop 39, `examples/fresh_check.md`): as many as
/// [`HELD_OUT_SEEDS`], scored only for the adopted default, after adoption; never for a choice.
pub const FRESH_SEEDS: std::ops::Range<u64> = 9000..9016;

/// Whether `seed` is one of [`HELD_OUT_SEEDS`] or [`FRESH_SEEDS`]: the members every
/// exploration, probe and diagnosis refuses.
pub fn is_held_out(seed: u64) -> bool {
    HELD_OUT_SEEDS.contains(&seed) || FRESH_SEEDS.contains(&seed)
}

// as many fresh seeds as held-out ones (a comparable worst member), none of them held out
const _: () = assert!(
    FRESH_SEEDS.end - FRESH_SEEDS.start == HELD_OUT_SEEDS.end - HELD_OUT_SEEDS.start
        && FRESH_SEEDS.start >= HELD_OUT_SEEDS.end
);

/// How a member's skin responds to force (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ForceResponse {
    /// Exponent `γ` of the response to force (< 1: sublinear).
    pub exponent: f64,
    /// Exponent `s` of the kernel width's growth with force.
    pub spread: f64,
    /// Gauge noise σ (N).
    pub gauge_noise_n: f64,
}

impl ForceResponse {
    /// Draw from the ranges of the [module docs](self) (a stream of the seed of its own).
    pub fn draw(seed: u64) -> ForceResponse {
        let mut rng = StdRng::seed_from_u64(sub_seed(seed, 0xf0_4ce));
        ForceResponse {
            exponent: rng.random_range(0.55..0.9),
            spread: rng.random_range(0.1..0.33),
            gauge_noise_n: rng.random_range(0.005..0.03),
        }
    }

    /// The amplitude factor `F_ref (F/F_ref)^γ` (0 at F ≤ 0).
    pub fn gain(&self, f: f64) -> f64 {
        if f > 0.0 {
            F_REF_N * (f / F_REF_N).powf(self.exponent)
        } else {
            0.0
        }
    }

    /// The kernel width at force `f` for the member's width `w` (mm).
    pub fn width(&self, w: f64, f: f64) -> f64 {
        if f > 0.0 {
            (w * (f / F_REF_N).powf(self.spread)).clamp(0.75 * w, 1.6 * w)
        } else {
            w
        }
    }
}

/// One part of a session.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Segment {
    /// No contact for this long (s).
    Rest(f64),
    /// A press at `at` (layout plane, mm): force rising linearly from `from_n` to `peak_n`
    /// over `rise_s`, holding `hold_s`, falling to 0 over `fall_s`.
    Press {
        /// Place (mm).
        at: [f64; 2],
        /// Force at the segment's start (N; > 0 for a recording that starts in contact).
        from_n: f64,
        /// Peak force (N).
        peak_n: f64,
        /// Rise (s).
        rise_s: f64,
        /// Hold (s).
        hold_s: f64,
        /// Fall (s).
        fall_s: f64,
    },
}

impl Segment {
    fn duration(&self) -> f64 {
        match *self {
            Segment::Rest(s) => s,
            Segment::Press { rise_s, hold_s, fall_s, .. } => rise_s + hold_s + fall_s,
        }
    }

    /// Force and place `t` s into the segment.
    fn at(&self, t: f64) -> (f64, [f64; 2]) {
        match *self {
            Segment::Rest(_) => (0.0, [0.0, 0.0]),
            Segment::Press { at, from_n, peak_n, rise_s, hold_s, fall_s } => {
                let f = if t < rise_s {
                    from_n + (peak_n - from_n) * t / rise_s.max(1e-9)
                } else if t < rise_s + hold_s {
                    peak_n
                } else {
                    peak_n * (1.0 - (t - rise_s - hold_s) / fall_s.max(1e-9)).max(0.0)
                };
                (f, at)
            }
        }
    }
}

/// A force session: a member's sensor, its force response, and what happens (see the
/// [module docs](self)).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ForceSession {
    /// The member's seed (noise is drawn from it too).
    pub seed: u64,
    /// The sensor.
    pub physics: Physics,
    /// Its response to force.
    pub response: ForceResponse,
    /// What happens, in order.
    pub segments: Vec<Segment>,
    /// Time of the first frame (s): a later recording of the same sensor continues its drift.
    pub t0_s: f64,
    /// Noise stream (a second recording of the same sensor uses another).
    pub noise_stream: u64,
}

/// A simulated session: frames (sensor `ff`, 24 taxels) and the truth per frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ForceRecording {
    /// Raw counts.
    pub frames: Vec<TaxelFrame>,
    /// True force (N).
    pub force: Vec<f64>,
    /// The gauge's reading (N): true force plus gauge noise while pressing, 0 otherwise.
    pub gauge: Vec<f64>,
    /// Index of the segment of each frame.
    pub segment: Vec<usize>,
    /// True contact place per frame (`None` without force).
    pub contact: Vec<Option<[f64; 2]>>,
}

impl ForceRecording {
    /// The true force (N) at time `t` (s): linear between frames, the first or last frame's
    /// value outside the recording.
    pub fn force_at(&self, t: f64) -> f64 {
        sampled_at(&self.force, t)
    }

    /// The gauge's reading (N) at time `t` (s), as [`force_at`](Self::force_at).
    pub fn gauge_at(&self, t: f64) -> f64 {
        sampled_at(&self.gauge, t)
    }

    /// Whether no force was applied in the 0.5 s up to `t` (s), read at every frame time back
    /// from `t`: the evaluations' *untouched* frames.
    pub fn untouched_at(&self, t: f64) -> bool {
        let dt = 1.0 / RATE_HZ;
        (0..=50).all(|k| self.force_at(t - k as f64 * dt) == 0.0)
    }
}

/// A per-frame series (one value per frame at [`RATE_HZ`]) at time `t` (s), linear between
/// frames. `t · RATE_HZ`, not `t / dt`: the rounding decides which frames read exactly 0 N.
fn sampled_at(series: &[f64], t: f64) -> f64 {
    let x = t * RATE_HZ;
    let Some(&last) = series.last() else { return 0.0 };
    if x <= 0.0 {
        return series[0];
    }
    let k = x.floor() as usize;
    if k + 1 >= series.len() {
        return last;
    }
    let u = x - k as f64;
    series[k] * (1.0 - u) + series[k + 1] * u
}

impl ForceSession {
    /// Member `seed`'s sensor with the calibration protocol: `n` presses at `n` places (see
    /// the [module docs](self)), after 1 s at rest.
    pub fn presses(seed: u64, n: usize) -> ForceSession {
        let kind = PathKind::ALL[(seed % 4) as usize];
        let physics = Physics::draw(seed, kind);
        let mut rng = StdRng::seed_from_u64(sub_seed(seed, 0x9_1ace));
        let region = pad_region();
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in &region {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let mut segments = vec![Segment::Rest(1.0)];
        for _ in 0..n {
            let mut at = [0.0, 0.0];
            for _ in 0..1000 {
                let c = [rng.random_range(lo[0]..hi[0]), rng.random_range(lo[1]..hi[1])];
                if inside_convex(&region, c) {
                    at = c;
                    break;
                }
            }
            let peak_n = rng.random_range(1.5..10.0);
            segments.push(Segment::Press { at, from_n: 0.0, peak_n, rise_s: 2.0, hold_s: 0.5, fall_s: 1.5 });
            segments.push(Segment::Rest(0.6));
        }
        ForceSession { seed, physics, response: ForceResponse::draw(seed), segments, t0_s: 0.0, noise_stream: 0 }
    }

    /// The place of press `k` of [`presses`](Self::presses).
    pub fn places(&self) -> Vec<[f64; 2]> {
        self.segments
            .iter()
            .filter_map(|s| match s {
                Segment::Press { at, .. } => Some(*at),
                Segment::Rest(_) => None,
            })
            .collect()
    }

    /// Total duration (s).
    pub fn duration_s(&self) -> f64 {
        self.segments.iter().map(Segment::duration).sum()
    }

    /// End (s) of the rest that follows the `n`-th press (the session's end if there is none):
    /// where a calibration on the first `n` presses stops (`force_eval`'s split at `n` = 5 of 10).
    pub fn after_press_s(&self, n: usize) -> f64 {
        let mut t = 0.0;
        let mut presses = 0;
        for seg in &self.segments {
            t += seg.duration();
            if matches!(seg, Segment::Press { .. }) {
                presses += 1;
            }
            if presses == n && matches!(seg, Segment::Rest(_)) {
                return t;
            }
        }
        t
    }

    /// Simulate the session.
    pub fn simulate(&self) -> ForceRecording {
        let p = &self.physics;
        let mut rng = StdRng::seed_from_u64(sub_seed(self.seed, 0x5e55 + self.noise_stream));
        let noise = Normal::new(0.0, p.noise_counts.max(0.0)).expect("finite σ");
        let gauge_noise = Normal::new(0.0, self.response.gauge_noise_n).expect("finite σ");
        let dt = 1.0 / RATE_HZ;
        let walk = Normal::new(0.0, p.drift_walk.max(0.0) * dt.sqrt()).expect("finite q");
        let n = (self.duration_s() * RATE_HZ).round() as usize;
        let alpha = 1.0 - (-dt / p.lag_s).exp();
        let depth: Vec<f64> = (0..24)
            .map(|i| {
                let (e, s) = (CORE_MM[i], SKIN_MM[i]);
                ((e[0] - s[0]).powi(2) + (e[1] - s[1]).powi(2) + (e[2] - s[2]).powi(2)).sqrt()
            })
            .collect();
        // the segment of each frame
        let mut bounds = Vec::with_capacity(self.segments.len());
        let mut acc = 0.0;
        for s in &self.segments {
            acc += s.duration();
            bounds.push(acc);
        }
        let mut lag = [0.0f64; 24];
        let mut rw = [0.0f64; 24];
        // a recording that starts in contact has been pressed long enough for the fluid to settle
        let settled = matches!(self.segments.first(), Some(Segment::Press { from_n, .. }) if *from_n > 0.0);
        let sensor = SensorId::new("ff");
        let mut rec = ForceRecording {
            frames: Vec::with_capacity(n),
            force: Vec::with_capacity(n),
            gauge: Vec::with_capacity(n),
            segment: Vec::with_capacity(n),
            contact: Vec::with_capacity(n),
        };
        let mut seg = 0;
        for k in 0..n {
            let tl = k as f64 * dt;
            while seg + 1 < bounds.len() && tl >= bounds[seg] {
                seg += 1;
            }
            let start = if seg == 0 { 0.0 } else { bounds[seg - 1] };
            let (f, c) = self.segments[seg].at(tl - start);
            let t = self.t0_s + tl;
            let amp = self.response.gain(f) * p.amplitude;
            let w = self.response.width(p.width_mm, f);
            let sp = skin_point(c);
            let values = (0..24)
                .map(|i| {
                    let u = if amp > 0.0 {
                        let e = CORE_MM[i];
                        let d2 = (e[0] - sp[0]).powi(2) + (e[1] - sp[1]).powi(2) + (e[2] - sp[2]).powi(2);
                        let rho = (d2 - depth[i] * depth[i]).max(0.0).sqrt();
                        p.gain[i] * amp * p.kernel.eval(rho, w)
                    } else {
                        0.0
                    };
                    if k == 0 && settled {
                        lag[i] = u;
                    }
                    lag[i] += alpha * (u - lag[i]);
                    rw[i] += walk.sample(&mut rng);
                    let delta = p.knee_counts * (lag[i] / p.knee_counts).tanh();
                    let v = p.baseline[i] + delta + p.drift_slope[i] * t + rw[i] + noise.sample(&mut rng);
                    v.clamp(0.0, 4095.0).round()
                })
                .collect();
            let ts = Timestamp((t * 1e9).round() as i64);
            rec.frames.push(TaxelFrame::new(sensor.clone(), ts, k as u64, values));
            rec.force.push(f);
            let g = if f > 0.0 { f + gauge_noise.sample(&mut rng) } else { 0.0 };
            rec.gauge.push(g);
            rec.segment.push(seg);
            rec.contact.push((f > 0.0).then_some(c));
        }
        rec
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_recording_is_read_between_frames_and_untouched_after_half_a_second_at_rest() {
        // 1 s at rest, then 1 N from frame 100 on
        let force: Vec<f64> = (0..200).map(|k| if k < 100 { 0.0 } else { 1.0 }).collect();
        let rec = ForceRecording {
            frames: Vec::new(),
            gauge: force.iter().map(|f| 2.0 * f).collect(),
            force,
            segment: Vec::new(),
            contact: Vec::new(),
        };
        assert_eq!(rec.force_at(-1.0), 0.0);
        assert_eq!(rec.force_at(0.995), 0.5);
        assert_eq!(rec.gauge_at(0.995), 1.0);
        assert_eq!(rec.force_at(5.0), 1.0);
        // the frame times back from t: 0.5 s of 0 N up to frame 99, not from 99.5 on
        assert!(rec.untouched_at(0.99) && rec.untouched_at(0.5) && rec.untouched_at(0.0));
        assert!(!rec.untouched_at(0.995) && !rec.untouched_at(1.4) && !rec.untouched_at(1.5));
        assert_eq!(ForceRecording { force: Vec::new(), ..rec }.force_at(1.0), 0.0);
    }

    #[test]
    fn response_is_sublinear_and_spreads_with_force() {
        for seed in 0..30 {
            let r = ForceResponse::draw(seed);
            assert!((0.55..0.9).contains(&r.exponent) && (0.1..0.33).contains(&r.spread));
            // doubling the force less than doubles the response, and widens the kernel
            assert!(r.gain(8.0) < 2.0 * r.gain(4.0) && r.gain(8.0) > r.gain(4.0));
            assert!(r.width(3.0, 8.0) > r.width(3.0, 4.0));
            assert_eq!(r.gain(0.0), 0.0);
        }
    }

    #[test]
    fn sessions_are_deterministic_and_the_gauge_follows_the_force() {
        let s = ForceSession::presses(5, 3);
        let a = s.simulate();
        assert_eq!(a, s.simulate());
        assert_eq!(s.places().len(), 3);
        let n = a.frames.len();
        assert_eq!((a.force.len(), a.gauge.len(), a.segment.len()), (n, n, n));
        // the first second is at rest; every press reaches its peak
        assert!(a.force[..100].iter().all(|&f| f == 0.0));
        for (g, f) in a.gauge.iter().zip(&a.force) {
            assert!((g - f).abs() < 0.2, "{g} vs {f}");
        }
        // a pressed frame moves some electrode well beyond the noise
        let k = a.force.iter().enumerate().max_by(|x, y| x.1.total_cmp(y.1)).unwrap().0;
        let moved = (0..24).map(|i| (a.frames[k].values[i] - a.frames[0].values[i]).abs()).fold(0.0, f64::max);
        assert!(moved > 50.0, "{moved}");
    }

    #[test]
    fn the_split_after_a_press_ends_its_rest() {
        let s = ForceSession::presses(5, 4);
        // 1 s at rest, then per press 2 + 0.5 + 1.5 s and 0.6 s at rest
        assert!((s.after_press_s(2) - (1.0 + 2.0 * 4.6)).abs() < 1e-12);
        assert_eq!(s.after_press_s(0), 1.0);
        assert_eq!(s.after_press_s(9), s.duration_s());
        let r = s.simulate();
        let k = (s.after_press_s(2) * RATE_HZ).round() as usize;
        assert_eq!(r.force[k - 1], 0.0);
        assert!(r.force[k + 10] > 0.0);
    }

    #[test]
    fn a_session_can_start_in_contact_and_continue_a_sensor() {
        let mut s = ForceSession::presses(7, 1);
        s.segments =
            vec![Segment::Press { at: [0.0, 0.0], from_n: 4.0, peak_n: 4.0, rise_s: 0.0, hold_s: 1.0, fall_s: 0.5 }];
        s.t0_s = 30.0;
        let r = s.simulate();
        assert_eq!(r.force[0], 4.0);
        assert!(r.frames[0].time.as_secs_f64() >= 30.0);
    }
}
