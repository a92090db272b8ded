//! Slip between two opposing fingertips (method.md, stage 7): onset time and class.
//!
//! # What it does
//! Reads two named sensors — `first` (default `ff`, the first finger) and `second` (default
//! `th`, the thumb) — and emits a [`SlipEvent`] whenever the grasp's state ([`SlipClass`])
//! changes: stable → slipping (the slip onset) and back. Its inputs ([`SlipInput`], interleaved
//! in time order per source; other sensors are ignored) come by two paths:
//! - **pattern points** ([`crate::slip_pattern`], the default evidence): per frame, where the
//!   noise-calibrated, baseline-relative change pattern of the raw frames lies, with a summed
//!   energy contact test far more sensitive than the contact locator's per-taxel threshold —
//!   a light grip on a weak finger, or a contact between electrodes, still gives a position;
//! - **track points** ([`TrackPoint`], the `track` tap; [`Stage::push`] takes them): the contact
//!   locator's track (with the default centroid locator also the change pattern's centroid,
//!   but gated by its 10 σ contact test and smoothed). The baseline rule reads only these.
//!
//! `evidence` picks the path of the `displacement` rule: `pattern` (default), `track`, or
//! `both` (per finger the track where it has evidence, else the pattern). A scene with a `slip`
//! output builds what that needs: with `pattern`, the pattern stage on the two sensors' raw
//! frames and no locator or track (unless another output taps them). Track ids and restarts
//! are ignored, short dropouts keep the history: the rule needs no contour and no unbroken track.
//!
//! Default rule, `method = "displacement"`:
//! 1. **World frame.** Each contact point is projected on its finger's `up` vector (a unit
//!    vector in that sensor's layout plane pointing to world up; `first_up = [0, 1]`,
//!    `second_up = [0, −1]`: the pads face each other, the convention of [`crate::sim`],
//!    "Two-finger convention"), at the middle of its averaging span (`(start + time)/2`).
//! 2. **Displacement per finger.** Once a finger has been in contact `settle_s` (closing the
//!    grasp moves the centroid while the pattern settles), its displacement along up over the
//!    last `window_s`, `2·window_s`, `4·window_s`, … — the window doubled while it is at most
//!    `history_s` (by default 0.3, 0.6, 1.2 and 2.4 s: the longest covers the slowest slips,
//!    which reach the distance only over their whole length); least-squares slope × span, so
//!    one noisy point does not count — the largest, in units of `distance_mm`, clamped to ±1:
//!    `d₁`, `d₂`. A finger without contact for longer than
//!    `max_gap_s` starts afresh; shorter dropouts keep its history and last value.
//! 3. **Common and differential mode.** `L = (d₁ + d₂)/2` (both move the same way in the
//!    world: longitudinal slip) and `R = (d₁ − d₂)/2` (opposite ways: rotational slip). The
//!    candidate is a slip when `max(|L|, |R|) ≥ 0.75` (both fingers moved, the weaker at least
//!    half of `distance_mm`) and `max ≥ dominance · min`: longitudinal **up** (`L > 0`) /
//!    **down** if `|L| ≥ |R|`, else rotational: `R < 0` (the object's surface moves down at the
//!    first finger, up at the second) is **clockwise**, `R > 0` counter-clockwise — as seen
//!    looking along the rotation axis with the first finger on the right, the second on the
//!    left, up pointing up. Below 0.25 in both modes the candidate is stable; in between the
//!    state is kept (hysteresis).
//! 4. **Persistence.** A candidate different from the current state must persist for
//!    `min_duration_s` before the state changes. The event carries `time` (the decision),
//!    `first_seen` and `onset`: for a slip, the **change point** of the moving fingers'
//!    position histories (`onset_position`: by default `fit`, the contact point of a per-frame
//!    model fit of each finger's change pattern, [`crate::slip_pattern`] step 6; `energy`, the
//!    decision's own energy-weighted point; `linear`, a linear-weight point) — drifting at a constant rate until `t₀` (a grip still ramping;
//!    `onset_model = "hinge"`: still), then moving with a speed that rises over `r`
//!    (`u = a + g·t + b·z(t − t₀)`, `z` the distance of a unit-speed start; `onset_starts`: by
//!    default `linear_cubic`, a sudden start, linear rises over 0.1, 0.2, 0.3 s and
//!    accelerating (`x²`, the distance growing as the cube of the time) rises over 0.2, 0.3,
//!    0.4 s; `linear_smooth` has smooth `3x² − 2x³` rises instead of the cubic ones, `linear`
//!    only the first four), `(t₀, start)` with the least squared error over the last
//!    `history_s`. The fingers that moved at least half of `distance_mm` give one `t₀` each,
//!    combined by `onset_fingers` (default `clear_earliest`: the earliest `t₀` among the
//!    fingers whose fit is clear, weight `(C − E)/E` — `C` its history's spread, `E` the fit's
//!    squared error — at least `onset_finger_gate` (0.35) × the clearest finger's, since a
//!    slip's onset is its first finger's start; `weighted`: each `t₀` weighted by `(C − E)/E`;
//!    `mean`; `earliest`), minus `onset_lead_s`
//!    (the fit's bias measured on tuning members: upstream delay against the fit's lateness on
//!    soft starts), never later than `first_seen`; for a return to stable `first_seen`. So
//!    `onset` estimates the first frame of motion, not the decision; it is computed at the
//!    decision from the history up to it (the event is not delayed by it). A time step is
//!    decided once every input of it is in, so the order of same-time inputs (the two
//!    fingers' points of one frame) changes nothing ([`Slip::push_input`], "Same-time
//!    inputs").
//!
//! The previous rule, `method = "velocity"` (the cheap baseline of the tables below): a
//! least-squares velocity over `velocity_window_s` of the current track (≥ `min_points`
//! points), `L`, `R` in mm/s against `speed_threshold_mm_s`, onset = the oldest point of the
//! regression windows.
//!
//! The state starts stable, so a grasp that never slips yields no event at all.
//!
//! # Measured: both fingers in one likelihood, model averaging, and what the onset target needs (stop 32)
//! **Question.** Can the onset fit reach the issue's target (per start shape median |error|
//! ≤ 30 ms, mean signed within ±10 ms) from the position histories it already has, by (a)
//! pooling the two fingers' evidence in one likelihood with a shared change point and a test
//! for "one finger first", (b) averaging over starts and change points instead of taking the
//! best, or (c) correcting the bias by the fitted start? **No; and the measured reason is the
//! start shape, not the noise.** The defaults are unchanged.
//!
//! **How it was measured.** `slip_eval -- onsetdump` with `DUMP_POSITION=fit` dumps the stage's
//! own onset-position histories (the default model-fit point) at each tuning slip's first
//! decision, `DUMP_SEEDS=400` over seeds 0..400 (tuning side: the held-out seeds are
//! 1000..1100); `scripts/onset_probe.rs joint` evaluates the estimators on them. Per finger `k`
//! and start `s` of the default set, the ramp-null fit's profile log-likelihood
//! `ℓₖ(c, s) = −nₖ/2 · ln SSEₖ(c, s)` on a common 10 ms grid of change points `c`. The probe's
//! argmax with `clear_earliest` 0.35 reproduces the stage's default figures (seeds 0..120, 218
//! slips: 40 / −21, 39 / +4, 36 / +15 ms after the same +8 ms lead, exactly; 0..400: worst
//! shape 47 / 31 against the stage's 46 / 31; 400..800: 54 / 34 against 54 / 27 — the probe's
//! grid is 10 ms steps over the span both fingers share, and it does not clamp the onset to the
//! decision's `first_seen`). Every row has its own lead (its mean signed error over all
//! slips). **Protocol, said plainly:** these were
//! exploratory runs on tuning-side seeds; no ranking rule was written before them. The rule
//! applied afterwards — a candidate would go into the stage (and to one held-out run) only if
//! its worst shape's median were ≥ 3 ms lower with no larger worst |mean| on both seed sets —
//! passes none (the best worst-shape median on 0..400 is 44 ms, against the target's 30).
//!
//! **Confirmatory run, rule committed first.** A rule — a candidate wins only if it ranks
//! first (worst shape median, then worst |mean|) and its worst median is ≥ 3 ms below the
//! default's with no larger worst |mean| — with eight declared estimators
//! (the rows marked ✓ below and the default), was committed in `scripts/onset_probe.rs`
//! (`CONFIRM=1`) before its one run on fresh tuning-side seeds 400..800 (`DUMP_FROM=400
//! DUMP_SEEDS=800`, 673 slips; never looked at before). Worst shape median / |mean| (ms), ranked:
//! (b) per finger T = 1 51 / 37, **default 54 / 34**, merge within 0.1 s 55 / 34, (a)+(b)
//! P = 20 T = 4 56 / 41, (a) shared 58 / 34, (a) P = 20 58 / 34, (a)+(b) P = 20 T = 2 58 / 39,
//! (a) P = 5 65 / 30. The first ranked is 3 ms better on the median but 3 ms worse on the
//! mean: **no candidate wins**; nothing was built into the stage and **no held-out seed was
//! scored** (there is no final candidate).
//!
//! Worst shape median / |mean|, then per shape and slice median |error| / mean signed (ms);
//! seeds 0..400 (723 slips decided right; in brackets the worst on 0..120, 218 slips):
//!
//! | estimator | worst | step | linear | smooth | one finger first | together |
//! |---|---|---|---|---|---|---|
//! | **default** (per finger argmax, `clear_earliest` 0.35) | **47 / 31** (40 / 21) | 47 / −31 | 41 / +7 | 43 / +25 | 53 / +18 | 37 / −18 |
//! | (a) shared change point ✓ | 50 / 28 (47 / 27) | 50 / −28 | 45 / +2 | 45 / +27 | 60 / +22 | 39 / −21 |
//! | (a) shared, split when Σ max ℓₖ − max ℓ_shared > 5 ✓ | 53 / 23 (54 / 15) | 34 / −23 | 46 / +1 | 53 / +23 | 52 / +14 | 38 / −13 |
//! | (a) shared, split test P = 20 ✓ | 47 / 27 (44 / 33) | 35 / −26 | 40 / −1 | 47 / +27 | 49 / +10 | 36 / −10 |
//! | (a)+(b) shared, P = 20, posterior mean T = 2 ✓ | 45 / 33 (48 / 41) | 36 / −31 | 30 / −0 | 45 / +33 | 39 / +7 | 33 / −7 |
//! | (a)+(b) shared, P = 20, T = 4 ✓ | 44 / 35 (47 / 44) | 38 / −35 | 26 / +1 | 44 / +35 | 40 / +7 | 31 / −6 |
//! | (b) per finger posterior mean T = 1, `clear_earliest` 0.35 ✓ | 46 / 33 (39 / 27) | 46 / −33 | 38 / +5 | 41 / +28 | 51 / +17 | 35 / −16 |
//! | (b) per finger T = 4 | 51 / 38 (53 / 34) | 51 / −38 | 28 / +7 | 39 / +32 | 46 / +16 | 34 / −15 |
//! | the start kind pooled over the fingers, separate change points, P = 5 | 66 / 24 (64 / 12) | 36 / −19 | 49 / −5 | 66 / +24 | 59 / +8 | 40 / −8 |
//! | (c) lead per fitted start kind (5-fold CV over seeds) | 52 / 43 (54 / 36) | 52 / −43 | 29 / +11 | 40 / +33 | 49 / +17 | 38 / −16 |
//! | fingers within 0.1 s → the shared fit, else default ✓ | 44 / 29 (48 / 15) | 43 / −29 | 44 / +5 | 41 / +25 | 56 / +17 | 37 / −16 |
//!
//! (Also tried, none better: the shared fit with T = 1–32 and P = 0–20; `earliest` and `mean`
//! over posterior means; merging within 0.02–0.15 s; the starts of `linear_smooth`, a fine grid
//! of the family's own linear 0.05–0.3 s and smooth 0.1–0.4 s starts, a 0.05 s linear start
//! added — `START_SET=smooth|fine|lc05|lc05n`: worst 45–60 ms, step −30 to −44 ms.) What every
//! estimator keeps is the step–smooth split of the mean: step −19 to −43 ms, smooth +23 to
//! +38 ms. Averaging (b) *widens* it: where the shapes nearly tie, the posterior spreads over
//! change points that move the other way for each shape.
//!
//! **Two-finger oracles** (told what no estimator has; same histories and grid; seeds 0..400,
//! in brackets 0..120):
//!
//! | told | worst | step | linear | smooth | one finger first | together |
//! |---|---|---|---|---|---|---|
//! | the true start (shape and length) and each finger's true start time offset, shared change point | **23 / 3** (26 / 4) | 22 / +0 | 22 / +3 | 23 / −3 | 23 / +0 | 23 / −0 |
//! | the true start, one change point or two by the split test P = 10 | **31 / 9** (33 / 19) | 25 / +9 | 31 / −3 | 30 / −6 | 38 / +11 | 23 / −11 |
//! | the true start, shared change point | 45 / 2 (40 / 5) | 45 / +0 | 43 / +2 | 39 / −2 | 48 / +30 | 39 / −29 |
//! | the true start, per finger, earliest | 36 / 11 (37 / 23) | 28 / +11 | 36 / −4 | 33 / −7 | 39 / +12 | 25 / −11 |
//! | each finger's offset, not the start (starts of the default set) | 41 / 29 (35 / 23) | 32 / −29 | 36 / +2 | 41 / +27 | 38 / −1 | 36 / +1 |
//! | the start of the default set nearest the truth (smooth → cubic), split P = 5 | 42 / 42 (44 / 47) | 37 / +32 | 42 / +9 | 39 / −42 | 44 / +12 | 35 / −12 |
//!
//! On the confirmatory seeds 400..800 the same oracles give 28 / 1 (start and offsets told),
//! 37 / 10 (start told, split P = 10: step 24 / +10, linear 31 / −4, smooth 37 / −7), 51 / 2
//! (start told, shared), 51 / 33 (offsets told, not the start).
//!
//! **What this shows.** With both fingers in one likelihood the evidence is nearly enough: told
//! the start, a penalised one-or-two change-point fit reaches 31 / 9 ms (0..400; 37 / 10 on
//! 400..800), and told also the fingers' offsets 23–28 ms with no bias — the per-finger
//! floor of stop 31 (36–41 ms) was the single finger's, not the data's. What is missing is the **start shape**:
//! told the offsets but not the start, the step–smooth split stays (−29 / +27 ms), and told the
//! start but not the offsets the means are right (±2 ms) and only the medians need the split
//! test. The shape is not identifiable from the positions: for 244 step-start slips the
//! two-finger likelihood picks a sudden start 59 times (linear 138, cubic 47), the sudden
//! start's log-likelihood a median 8.3 units below the best — seen through the sensor's fluid
//! lag and the 3-frame average a step is a soft start; for linear and smooth starts the true
//! kind is a median 0.2–0.3 units from the best (a coin toss). And the nearest start *of the
//! set* is not good enough either (last row): the length matters as much as the kind. The
//! reason is physical: the position's noise is 0.045 mm (median pre-onset residual about a
//! line; quartiles 0.025–0.093), and a contact with a smooth start of 0.25–0.4 s at the
//! family's median 7.6 mm/s has moved 0.05 mm only 78–105 ms after its onset (a linear one of
//! 0.15–0.3 s: 44–62 ms; a step: 7 ms; at 3 mm/s: 111–149, 71–100, 17 ms). The first 50–150 ms
//! of a soft start are below the noise, so the onset is an extrapolation of the assumed start
//! back to zero speed, and the assumption is the shape.
//!
//! **Less noise or no fluid lag does not make the shape identifiable** (diagnostic physics,
//! never for a choice: `DIAG_NOISE_SCALE` / `DIAG_LAG_SCALE` in `slip_eval`, seeds 0..400;
//! worst shape median / |mean|, ms). The stage's default: ¼ of the white noise and drift walk
//! 44 / 29, no fluid lag 42 / 27, both 40 / 24 (normal physics 46 / 31). Told each finger's
//! offset but not the start: 37 / 31, 39 / 21, 35 / 23 — the step–smooth split of the mean
//! stays (both: step −21, smooth +23 ms). With both changes and the family's own start shapes
//! in the fit's set (`START_SET=fine`), a step still scores its sudden start a median 10.4
//! log-likelihood units below the best (the 3-frame average and the fitted position round it),
//! and linear and smooth starts stay a coin toss (true kind 0.0–0.4 units from the best);
//! the best estimator, (a) with P = 20, is 37 / 34. Told the start, the same histories give
//! 24 / 4 (split P = 10). A smooth start and a linear one with a later change point explain
//! nearly the same positions: without noise, the least-squares linear start for a smooth one
//! of 0.1 / 0.2 / 0.3 / 0.4 s is 0.08 / 0.16 / 0.22 / 0.30 s long and starts 10 / 20 / 40 /
//! 50 ms later. The first frame of non-zero speed of a soft start is not what the positions
//! pin down.
//!
//! **The tuning set is small.** The stage's default, worst shape median / |mean|: seeds 0..120
//! 40 / 21 ms, 0..400 46 / 31, 400..800 54 / 27, held out (1000..1100) 48 / 33. Sets of this
//! size differ by 7–14 ms: stop 31b's 3 ms tuning gain was noise, and so would be any gain
//! this size; a next search should rank on several hundred seeds (`DIAG_SEEDS` /
//! `DUMP_SEEDS` / `DUMP_FROM`).
//!
//! **What could meet the target** (not done here): an observable that differs between start
//! shapes — skin stretch before sliding, a break-away vibration — which the simulator does not
//! model and which was not added; or a truth onset that is observable, such as the first frame
//! at which the contact has moved a small distance (0.05 mm), which is a change of the issue's
//! definition, not of the estimator.
//!
//! # Measured: how the fingers' change points combine (stop 31b)
//! **Why.** The simulator's truth onset is the first finger's start ([`crate::sim_grasp`]:
//! in half the grasps the other finger starts 0.03–0.2 s later), while `weighted` (stop 31's
//! default) dates between the two fingers; held out, the "one finger first" slice was the
//! widened property with the largest bias, 54 ms median / +27 ms mean signed. New:
//! `onset_fingers = "clear_earliest"` — the earliest `t₀` among the fingers whose fit weight
//! is at least `onset_finger_gate` × the clearest finger's (gate 0 is `earliest`, 1 the
//! clearest finger alone), so a finger whose fit barely stands out of its residual cannot
//! pull the onset early. Same delay and cost as `weighted` (the weights are computed anyway).
//!
//! **Tuning** (`slip_eval -- tune fingers`, seeds 0..120 × 5, 280 grasps, 218 slips right;
//! rule stated in the code before the run, round 3's: worst start shape's median |error|,
//! then its |mean signed|; each setting its own lead = its tuning mean signed error to 5 ms;
//! another rule adopted only if it ranks first). The other onset settings at the defaults
//! (fit position, `ramp_hinge`, `linear_cubic`), plus `weighted` / `clear_earliest` 0.5 under
//! `hinge` and under `linear_smooth` / `linear` starts (the joint check; all ranked below,
//! 51–63 ms worst median). Per setting: worst median / worst |mean|, then step, linear,
//! smooth, one finger first, both together (median / mean signed, ms), demo onset (s,
//! printed, not ranked):
//!
//! | `onset_fingers` | lead (s) | worst | step | linear | smooth | one finger first | together | demo |
//! |---|---|---|---|---|---|---|---|---|
//! | **`clear_earliest`, gate 0.35 (chosen)** | 0.010 | 41 / 23 | 40 / −23 | 41 / +2 | 35 / +13 | 47 / +24 | 36 / −25 | −0.080 |
//! | `clear_earliest`, gate 0.2 | 0.000 | 42 / 25 | 35 / −25 | 42 / +4 | 40 / +17 | 47 / +25 | 35 / −22 | −0.070 |
//! | `weighted` (stop 31's default) | 0.025 | 44 / 25 | 44 / −22 | 38 / −0 | 40 / +25 | 47 / +32 | 37 / −24 | −0.051 |
//! | `clear_earliest`, gate 0.5 | 0.015 | 44 / 21 | 44 / −21 | 43 / +1 | 36 / +17 | 46 / +26 | 38 / −23 | −0.085 |
//! | `clear_earliest`, gate 0.1 | −0.015 | 47 / 21 | 29 / −18 | 45 / +2 | 47 / +21 | 51 / +25 | 36 / −17 | −0.055 |
//! | `clear_earliest`, gate 0.75 | 0.020 | 49 / 22 | 49 / −22 | 46 / +1 | 45 / +21 | 54 / +30 | 40 / −24 | −0.090 |
//! | `clear_earliest`, gate 1 | 0.025 | 51 / 25 | 51 / −22 | 49 / −0 | 42 / +25 | 53 / +32 | 39 / −24 | −0.015 |
//! | `mean` | 0.040 | 52 / 26 | 52 / −24 | 37 / −4 | 50 / +26 | 37 / +29 | 53 / −25 | −0.070 |
//! | `earliest` | −0.030 | 59 / 13 | 28 / −13 | 47 / +2 | 59 / +13 | 54 / +25 | 37 / −19 | −0.040 |
//!
//! **Held out, scored once** for the chosen setting (seeds 1000..1100 × 5, 500 grasps;
//! stop 31's default in the same run for comparison; median |error| / mean signed, ms):
//!
//! | | step | linear | smooth | one finger first | all | exponential kernel | held-out variant | class | false alarms / min | demo (s) |
//! |---|---|---|---|---|---|---|---|---|---|---|
//! | **`clear_earliest` 0.35, lead 0.010 (default)** | 44 / −33 | 44 / +3 | 48 / +22 | 55 / +16 | 45 / −5 | 47 / −10 | 51 / −1 | 491/500 | 0.27 | −0.080 |
//! | `weighted`, lead 0.025 (stop 31) | 42 / −32 | 44 / +11 | 45 / +28 | 54 / +27 | 43 / −1 | 48 / −5 | 44 / +5 | 491/500 | 0.27 | −0.051 |
//!
//! (Other properties, default against stop 31: grip still ramping 46 / −6 against 46 / −5,
//! load rising 46 / +2 against 44 / +4, none of the three 37 / −16 against 29 / −14, slower
//! than 4 mm/s 60 / −19 against 58 / −13.) Class accuracy and false alarms cannot move (the
//! onset settings do not touch the decision). **What held out shows:** the linear and smooth
//! means move toward zero (+11 → +3, +28 → +22 ms) and the one-finger-first slice's mean
//! falls from +27 to +16 ms, but the medians do not improve (worst shape 45 → 48 ms, all
//! 43 → 45 ms), the held-out variant's median rises (44 → 51 ms) and the demo's onset moves
//! from −0.051 to −0.080 s. The tuning gain on the rule's criterion (44 → 41 ms) did not
//! hold out (45 → 48 ms): a 3 ms difference on ≈ 70 slips per shape is within the sampling
//! spread, and the gate's tuning curve is not smooth (0.2 / 0.35 / 0.5: 42 / 41 / 44 ms).
//! The setting is the default because the rule stated before the run chose it.
//!
//! **The one-finger-first bias is mostly not the combination.** On the tuning members even
//! `earliest` leaves that slice at +25 ms mean against −19 ms for grasps whose fingers start
//! together, and every rule above keeps a 40–60 ms gap between the two slices: most of that
//! slice's lateness comes from somewhere other than how the fingers combine (the first
//! finger's own change point, or which fingers pass the half-distance test at the decision —
//! not measured here). The issue's target (per shape ≤ 30 ms median, mean within ±10 ms): **not met.**
//!
//! # Measured: decisions independent of the same-time input order (stop 31), and what the onset target needs
//! **The change.** The stage used to decide at the first input that completed its condition,
//! so the two fingers' order at one timestamp decided whether the onset fit saw one point
//! more of one finger: 24 ms of onset on the demo's grasp (`gradtac::demo`). A time step is now
//! decided once all of its inputs are in ([`Slip::push_input`]); a proptest checks that any
//! order of same-time inputs gives the same events under every evidence path and both rules,
//! and it fails on the old per-input decision. With the default (pattern evidence) the step's
//! last pattern point completes it: no added delay. Class accuracy and false alarms did not
//! move (held out 491/500, 0.27 / min).
//!
//! **Re-chosen on the tuning members** (`slip_eval -- tune onset`, round 3's 54 settings and its
//! rule, stated before the run: worst start shape's median |error|, then its
//! |mean signed|; lead = the tuning mean to 5 ms): the same setting wins, with the same lead
//! 0.025 s — worst shape 44 / 25 ms (step 44 / −22, linear 38 / −0, smooth 40 / +25 ms; round 3:
//! 44 / 28). The defaults are unchanged.
//!
//! The same search with the fit's **fluid-lag estimate** (`onset_fit_lag`, new, [`crate::lag`]:
//! each sensor's lag from its press onset, undone on the electrodes before the fit; 18 more
//! settings, 72 in all). Why try it: given the true start, the fit's per-finger error grows
//! with the sensor's lag on the tuning members, +16 ms mean below 20 ms of lag to +67 ms at
//! 60–100 ms. Rule stated before the run: adopt it only if a setting with it ranks first. It
//! ranks below: its best, `earliest` fingers with lead −0.015 s, is 45 / 40 ms worst shape
//! (step 40 / −40, linear 33 / +10, smooth 45 / +30), the chosen setting with it 49 / 32. Off
//! by default.
//!
//! **Held out, scored once** (seeds 1000..1100 × 5, 500 grasps; median |error| / mean signed,
//! ms): all 43 / −1 (round 3: 42 / −1), **step 42 / −32, linear 44 / +11, smooth 45 / +28**
//! (round 3: 42 / −33, 43 / +9, 40 / +27); exponential kernel 48 / −5; held-out variant
//! (exponential starts) 44 / +5. `gradtac demo` now prints **−0.051 s** (was −0.074 s), and
//! `slip_eval` the same in either order. **Target (per shape ≤ 30 ms median, mean within ±10
//! ms): not met.**
//!
//! **A longer look-ahead does not help** (`slip_eval -- tune horizon`, tuning members only;
//! each slip the default decides right, re-dated by the same fit `h` after its decision, lead
//! re-centred per `h`; rule stated before the run: offer `h` as a setting only if every shape
//! reaches ≤ 30 ms median and ±10 ms mean):
//!
//! | `h` after the decision (s) | lead (s) | step | linear | smooth | worst median / \|mean\| (ms) |
//! |---|---|---|---|---|---|
//! | 0 (the stage) | 0.026 | 45 / −24 | 38 / −2 | 40 / +23 | 45 / 24 |
//! | 0.1 | 0.034 | 56 / −35 | 35 / +5 | 42 / +28 | 56 / 35 |
//! | 0.2 | 0.037 | 67 / −39 | 37 / +4 | 40 / +33 | 67 / 39 |
//! | 0.3 | 0.035 | 65 / −46 | 48 / −0 | 49 / +42 | 65 / 46 |
//! | 0.5 | 0.038 | 106 / −33 | 71 / −6 | 66 / +35 | 106 / 35 |
//! | 1.0 | 0.155 | 365 / −64 | 293 / −7 | 278 / +66 | 365 / 66 |
//!
//! The step–smooth gap *grows* with the horizon: what tells a step from a soft start is the
//! curvature over the start itself (≤ 0.4 s), which the decision (median 0.47 s after the
//! onset) already has in its history; later points add the motion's end and the load rise,
//! which the hinge model does not describe. No horizon is offered.
//!
//! **No other observable in the simulator differs with the start shape.** In
//! [`crate::sim_grasp`] the start shape enters only through the contact's progress along its
//! path; the grip force (its ramp, its squeeze modulation) and every electrode term are the
//! same for a step and a smooth start. The one onset-related signal beyond position, the end
//! of a still-ramping grip at `t₀ + o` (`o` ∈ [0, 0.3] s, half the grasps), is a timeline choice
//! of the simulator, not physics of a slip, and is independent of the start shape: not used.
//!
//! **Even knowing the shape, the median target is out of reach for this fit.** On the stage's
//! own onset position (the model fit's point, contact 4 σ; `-- onsetdump` with `DUMP_FIT=1
//! DUMP_FIT_CONTACT=4 DUMP_FIT_PEAK=1`, then `scripts/onset_probe.rs oracle`; tuning members),
//! the change-point fit given each slip's **true** start shape and length (an oracle, not a
//! method) reaches step 36 / +2, linear 34 / −1, smooth **41** / −0 ms: identifying the shape
//! would meet the ±10 ms mean target but not the 30 ms median one, and the shape is not
//! identified (`onset_probe conf` on the same histories: the fit picks a sudden start for 53
//! of 142 step fingers and 22 of 154 smooth ones; the true start's log-likelihood gap to the
//! best, median 1.9 / 4.0 / 2.1 units for step / linear / smooth). Choosing among its seven
//! starts, the fit is +52 ms late per finger (against its own onset, no lead) on smooth
//! starts, −21 / +6 ms on step / linear ones: a soft start's first part is below the
//! position's noise. Averaging the fit's frames more does not move the oracle (windows of 1 /
//! 3 / 5 / 9 frames: worst shape 41 / 41 / 39 / 39 ms). Reaching the target needs an
//! observable the simulator does not model (shear stretch before sliding, a break-away
//! vibration, incipient slip). (Stop 32, above, on the stage's own positions: this floor is a
//! single finger's. Both fingers in one likelihood, told the true start, reach 31 / 9 ms worst
//! shape; the start shape is still what no estimator identifies.)
//!
//! # Measured: the onset position (round 3: the model-fit position, the default)
//! Same protocol, members and columns as the next section. The previous round found that the
//! energy-weighted point sticks to the strongest taxel (the oracle's error grows as the slip
//! slows), so this round searched **which position the change-point fit reads**
//! (`onset_position`), the decisions unchanged (they read the energy-weighted point whatever
//! this is: class accuracy and false alarms are identical by construction).
//!
//! **Tuning** (seeds 0..120 × 5, 280 grasps, 218 slips right; `slip_eval -- tune onset`):
//! `onset_position` ∈ {energy, linear, fit} × the previous round's 18 fit settings, each with
//! its own lead (54 settings); then, for `fit` only, the fit's contact test ∈ {10 (the locator's
//! default), 6, 4} σ, 6 instead of 3 iterations and signed instead of magnitudes (18 settings
//! each; 126 settings in all; that second step ran on a scratch build reading the fit's settings
//! from the environment — the example's search runs the first step with the chosen 4 σ). Ranked
//! by the worst start shape's median |error|, then its |mean signed|. Chosen: `fit` (contact 4 σ, 3 iterations, magnitudes), `ramp_hinge`,
//! `linear_cubic`, `weighted`, lead 0.025 s — worst shape 44 ms median, 28 ms |mean| (step
//! 44 / −22, linear 40 / +0, smooth 39 / +28 ms). Next: contact 6 σ 48 / 26, contact 10 σ
//! 48 / 27, the previous default (`energy`) 49 / 31, 6 iterations 51 / 27, the best `linear`
//! row (`hinge`, `linear`, `weighted`, lead 0.025) 51 / 53; signed fits ranked below.
//!
//! **Held out** (seeds 1000..1100 × 5, 500 grasps, **scored once** for the chosen setting; the
//! best `linear` row was scored once too, as a record; no choice was made after either run):
//!
//! | | all right | false alarms / min | median \|err\| (ms) | mean signed (ms) | step | linear | smooth | held-out variant, exponential starts |
//! |---|---|---|---|---|---|---|---|---|
//! | **fit position (default)** | 491/500 | 0.27 | 42 | −1 | 42 / −33 | 43 / +9 | 40 / +27 | 193/200, 44 / +3 |
//! | energy position (previous default) | 491/500 | 0.27 | 49 | −3 | 52 / −32 | 46 / +0 | 47 / +31 | 193/200, 44 / +1 |
//! | linear-weight position (not chosen) | 491/500 | 0.27 | 53 | −1 | 48 / −44 | 44 / +12 | 63 / +40 | 193/200, 37 / −8 |
//! | track velocity (baseline) | 350/500 | 0.63 | 160 | +209 | 100 / +164 | 187 / +222 | 211 / +253 | — |
//!
//! (per shape: median |error| / mean signed, ms.) Exponential kernel (held-out physics): 48 /
//! −6 ms against 50 / −6. By property (default): grip still ramping 44 / −7, load rising
//! 42 / +3, one finger first 53 / +27, none of the three 32 / −14, slower than 4 mm/s
//! 55 / −14 ms. The demo's recording: `gradtac demo` printed **−0.074 s** (−0.051 s since
//! stop 31's same-time decision, above), and so did
//! `slip_eval`'s in-process replay (previous default −0.020 s). The replay used to give
//! −0.050 s because it fed the two fingers' same-time frames in the simulator's order (thumb
//! first) while the scene's runner breaks ties by the scene's sensor order (first finger
//! first): this stage decided at the first input that completed its condition, and the onset
//! fit then read one finger's history one point longer in one order than in the other
//! (`gradtac::demo` has the measurement). The demo is the old simulator, neither tuning nor
//! held out, and was not a criterion this round.
//!
//! Against the targets (per start shape median |error| ≤ 30 ms and mean signed within ±10 ms):
//! **not met.** Every shape's median falls (step 52 → 42, linear 46 → 43, smooth 47 → 40 ms),
//! the means do not move (step −33, smooth +27 ms). Why, measured on the tuning members
//! (`-- onsetdump`, `DUMP_FIT=1` for the fit's points, `scripts/onset_probe.rs`):
//! - **The position was half the problem.** Given each slip's true start shape (an oracle,
//!   not a method), the fit's point reaches 29–31 / 32–34 / 35–38 ms per shape (means within
//!   ±9 ms; the range over the fit's variants: raw point, filtered point, 6 iterations) —
//!   near the target — against 45 / 50 / 41 with the energy point and 34 / 33 / 41 with the
//!   linear one.
//! - **The start is still not identified.** With any of the three positions the start the
//!   fit chooses has nearly the same distribution whatever the true shape (the fit's raw
//!   point, per finger, among sudden / linear 0.1, 0.2, 0.3 / smooth 0.2, 0.3, 0.4: true steps
//!   47 / 30, 10, 19 / 10, 7, 14; true smooth 18 / 31, 15, 12 / 21, 8, 43), and the true start
//!   fits only 2–4 log-likelihood units worse than the best. The fit dates the intercept of the visible
//!   motion well, so a step and a smooth start of the same intercept get the same onset, and
//!   the two shapes' means stay about `r̄/2` apart (≈ 60 ms: smooth starts last 0.1–0.4 s).
//!   Tried on the tuning histories, none of which narrows that gap below 50 ms: a penalty per
//!   start length in the choice (κ from −4 to 10 log-likelihood units per 0.1 s, energy and
//!   fit points: step means stay −22 … −43 ms, smooth +21 … +37 ms), one start shared by both
//!   fingers (the same), a linear stack of the starts' change points (with the fits'
//!   likelihood gaps and 1/speed, weighted to count each shape alike; 5-fold CV over seeds,
//!   its best: step 60 / −51, smooth 57 / +14 ms), and (last round) Bayesian averaging,
//!   shorter fit spans and a speed-dependent lead.
//! - **What is left** is an observable that sees the first 0.1–0.2 s of a soft start, where
//!   the contact has moved less than the point's noise (a smooth start of 0.3 s at 10 mm/s
//!   has moved 0.03 mm after 0.1 s) — the simulator moves only the contact (no shear stretch,
//!   no stick-slip, no vibration at the break-away, `sim_grasp`'s "Not modelled"), so on this
//!   family the start of a soft slip is not visible in the taxels at all until it has moved;
//!   a per-shape mean within ±10 ms then needs the start's length from the later motion,
//!   which the fits above cannot tell apart.
//!
//! # Measured: the widened grasp family — onset by start shape (round 2, the energy position)
//! Protocol (`cargo run --release --example slip_eval`; `-- tune onset` for the search, `--
//! onsetdiag` for every tuning member's signed error and properties, `-- onsetdump` for every
//! tuning slip's position histories at its decision with the truth): two-finger grasps from
//! [`crate::sim_grasp`]'s **widened** family — every member draws a step, linear (0.05–0.3 s)
//! or smooth (`3x² − 2x³`, 0.1–0.4 s) start, and with probability ½ each a grip still ramping
//! at the onset (0.4–1.6 × `F` at the end of the press to `F`, 0–0.3 s after the onset), a
//! load rising while slipping (speed × `1 + α τ`, `α` 0.5–3 /s), and one finger starting
//! 0.03–0.2 s before the other. Bare default scene (raw frames → pattern → slip).
//!
//! **Tuning** (seeds 0..120 × 5 classes, Gaussian / difference-of-Gaussians kernels on both
//! fingers: 280 grasps, 218 slips right). Searched: `onset_model` ∈ {hinge, ramp_hinge} ×
//! `onset_fingers` ∈ {mean, earliest, weighted} × `onset_starts` ∈ {linear, linear_smooth,
//! linear_cubic}, each with `onset_lead_s` = its mean signed error on the tuning members
//! without a lead (to 5 ms); ranked by the worst start shape's median |error|, then the worst
//! |mean signed error|. The decisions (class, false alarms) do not depend on these settings.
//! Chosen (first row): `ramp_hinge`, `linear_cubic`, `weighted`, lead 0.03 s — worst shape
//! 49 ms median, 31 ms |mean| (step 47 / −31, linear 42 / +9, smooth 49 / +25 ms). The next
//! rows (worst median / worst |mean|, ms): hinge linear_cubic weighted (lead 0.02) 52 / 35;
//! hinge linear_smooth mean (lead 0.045, the previous default) 57 / 47; ramp_hinge
//! linear_cubic mean 58 / 38; ramp_hinge linear_smooth weighted 59 / 43; hinge linear_smooth
//! weighted 59 / 43; hinge linear_cubic mean 60 / 44; hinge linear weighted 61 / 53; the
//! other ten 65–76 / 35–61 (every `earliest` row among them).
//!
//! What the tuning members show (`-- onsetdump`, fits refitted offline on those histories):
//! - **The start is not identified from a finger's pattern point.** The start the fit
//!   chooses has nearly the same distribution whatever the true shape (per finger, of
//!   sudden / linear 0.1, 0.2, 0.3 / smooth 0.2, 0.3, 0.4: true steps 45 / 25, 11, 21 /
//!   11, 9, 20; true linear 25 / 21, 15, 15 / 7, 12, 45; true smooth 21 / 15, 9, 19 / 24, 15,
//!   51), and the true start fits only ≈ 3–4 log-likelihood units worse than the best
//!   (white-noise units; the residual is not white). Since the fit dates the *intercept* of
//!   the visible motion well (`t₀ + r/2`), a wrong `r` is a bias of `Δr/2`: 80–90 ms between
//!   steps and smooth starts for every estimator tried (single fixed starts: ≈ 120 ms;
//!   Bayesian averaging over starts, fits on the last 0.25–0.9 s before the intercept, a
//!   joint start for both fingers, a speed-dependent lead: 80–90 ms).
//! - **Even knowing the start does not reach 30 ms.** Fitting each finger with its true
//!   start and length (an oracle, not a method) gives per shape 45 / 50 / 41 ms median with
//!   means within ±14 ms. The pattern point lags the contact by a distance, not a time: that
//!   oracle's error grows as the slip slows (+76 ms mean below 4 mm/s, +23 ms above 15 mm/s)
//!   — the energy-weighted centroid (`wᵢ ∝ zᵢ²`) sticks to the strongest taxel. A scratch
//!   build with a linear-weight centroid (`wᵢ = max(0, |zᵢ| − f)`) removed the speed
//!   dependence and brought the oracle to 34 / 33 / 41 ms, but the shape confusion stayed
//!   (no estimator with it ranked better than the chosen one), so it was not kept.
//!
//! **Held out**: seeds 1000..1100 × 5 classes of the widened family, every kernel (500
//! grasps; 275 with an exponential kernel — physics not tuned on — on some finger), scored
//! once with the chosen defaults, and a **held-out variant** never used for a choice (seeds
//! 2000..2040 × 5, [`crate::sim_grasp::GraspFamily::held_out_variant`]: exponential starts,
//! grips 0.3–2 × `F`, load rises to 4 /s, finger lags to 0.3 s). "Previous onset estimate":
//! `hinge`, `linear_smooth`, `mean`, lead 0.045 s (the defaults before this search). Columns
//! as in the tables further below, plus the **mean signed** onset error of the slips right.
//!
//! | | stable | long. up | long. down | rot. cw | rot. ccw | all right | onset \|err\| median (ms) | mean signed (ms) | \|err\| p90 (ms) | decided after onset, median (ms) | false alarms / min still |
//! |---|---|---|---|---|---|---|---|---|---|---|---|
//! | displacement (default), all | 100/100 | 97/100 | 100/100 | 95/100 | 99/100 | 491/500 (98.2 %) | 49 | -3 | 130 | 470 | 0.27 |
//! | displacement (default), exponential kernel (held-out physics) | 55/55 | 52/55 | 55/55 | 53/55 | 55/55 | 270/275 (98.2 %) | 50 | -6 | 134 | 469 | 0.49 |
//! | displacement (default), tuning members (in-sample) | 56/56 | 54/56 | 55/56 | 55/56 | 54/56 | 274/280 (97.9 %) | 47 | +1 | 136 | 455 | 0.00 |
//! | displacement, previous onset estimate, all | 100/100 | 97/100 | 100/100 | 95/100 | 99/100 | 491/500 (98.2 %) | 52 | -9 | 133 | 470 | 0.27 |
//! | displacement, previous onset estimate, exponential kernel (held-out physics) | 55/55 | 52/55 | 55/55 | 53/55 | 55/55 | 270/275 (98.2 %) | 59 | -15 | 124 | 469 | 0.49 |
//! | track velocity (baseline), all | 98/100 | 62/100 | 64/100 | 52/100 | 57/100 | 333/500 (66.6 %) | 151 | +194 | 414 | 389 | 0.72 |
//!
//! By start shape (held out; each row: the slips of that shape and all stable grasps):
//!
//! | | stable | long. up | long. down | rot. cw | rot. ccw | all right | onset \|err\| median (ms) | mean signed (ms) | \|err\| p90 (ms) | decided after onset, median (ms) | false alarms / min still |
//! |---|---|---|---|---|---|---|---|---|---|---|---|
//! | displacement (default), step start | 100/100 | 31/31 | 45/45 | 37/38 | 35/35 | 248/249 (99.6 %) | 52 | -32 | 124 | 428 | 0.00 |
//! | displacement (default), linear start | 100/100 | 39/41 | 27/27 | 29/31 | 31/32 | 226/231 (97.8 %) | 46 | +0 | 128 | 471 | 0.31 |
//! | displacement (default), smooth start | 100/100 | 27/28 | 28/28 | 29/31 | 33/33 | 217/220 (98.6 %) | 47 | +31 | 148 | 505 | 0.16 |
//! | displacement, previous onset estimate, step start | 100/100 | 31/31 | 45/45 | 37/38 | 35/35 | 248/249 (99.6 %) | 61 | -52 | 124 | 428 | 0.00 |
//! | displacement, previous onset estimate, linear start | 100/100 | 39/41 | 27/27 | 29/31 | 31/32 | 226/231 (97.8 %) | 45 | +3 | 125 | 471 | 0.31 |
//! | displacement, previous onset estimate, smooth start | 100/100 | 27/28 | 28/28 | 29/31 | 33/33 | 217/220 (98.6 %) | 47 | +32 | 148 | 505 | 0.16 |
//! | track velocity (baseline), step start | 98/100 | 18/31 | 23/45 | 19/38 | 23/35 | 181/249 (72.7 %) | 88 | +139 | 380 | 322 | 0.91 |
//! | track velocity (baseline), linear start | 98/100 | 28/41 | 22/27 | 14/31 | 15/32 | 177/231 (76.6 %) | 160 | +196 | 390 | 394 | 0.31 |
//! | track velocity (baseline), smooth start | 98/100 | 16/28 | 19/28 | 19/31 | 19/33 | 171/220 (77.7 %) | 207 | +253 | 472 | 438 | 0.65 |
//! | held-out variant: default, exponential start | 39/40 | 39/40 | 40/40 | 37/40 | 38/40 | 193/200 (96.5 %) | 44 | +1 | 140 | 451 | 0.68 |
//! | held-out variant: previous onset estimate, exponential start | 39/40 | 39/40 | 40/40 | 37/40 | 38/40 | 193/200 (96.5 %) | 52 | -13 | 129 | 451 | 0.68 |
//!
//! By widened property (held out, default / previous; median / mean signed, ms): grip still
//! ramping 48 / −8 against 56 / −12; load rising 50 / +7 against 52 / +1; one finger first
//! 61 / +26 against 61 / +19; none of the three 39 / −24 against 48 / −35; slower than 4 mm/s
//! 56 / −12 against 63 / −2.
//!
//! Against the targets (per start shape median |error| ≤ 30 ms and mean signed error within
//! ±10 ms, no drop in class accuracy or false alarms): **not met**. Class accuracy and false
//! alarms are unchanged (491/500, 0.27 / min: the onset settings do not touch the decision).
//! The steps' bias falls from −52 to −32 ms and their median from 61 to 52 ms, the overall
//! median from 52 to 49 ms, the held-out variant's from 52 to 44 ms; linear starts are
//! centred (+0 ms), smooth starts still +31 ms, and every shape's median stays 46–52 ms. Why
//! (above): the start is not identified from the pattern points, and even a known start
//! leaves ≈ 40–50 ms from the centroid's stickiness. What is left: a position that follows
//! the contact evenly (the linear-weight centroid removes the oracle's speed dependence), and
//! an observable that sees the start itself (the pattern's change, not its centroid).
//!
//! # Measured: grasps from the model family, bare default scene (first family, previous onset estimate)
//! (The figures of this section are the first family's — a linear start of 0–0.3 s, nothing
//! else widened, [`crate::sim_grasp::GraspFamily::narrow`] — with the onset estimate of then:
//! linear starts, lead 0.03 s; kept as the record of how the decision settings were chosen.)
//! Protocol (`cargo run --release --example slip_eval`, `-- tune` for the search; the tables
//! below were its output then): two-finger grasps from [`crate::sim_grasp`] — each finger its own
//! forward-model draw (kernel shape, width, gains and signs, lag, drift, noise, knee,
//! baselines), one grip force 0.5–10 N with squeeze changes, onsets 1–2.5 s, speeds 2–30 mm/s
//! with slow starts of 0–0.3 s. The chain is what a scene without `[stages.*]` tables runs:
//! raw frames → [`crate::slip_pattern`] → slip, all defaults (the `track` path and the baseline
//! read taxel centroid → track, defaults).
//!
//! **Tuning**: seeds 0..120 × 5 classes with a Gaussian or difference-of-Gaussians kernel on
//! both fingers (280 grasps; the previous session's 0..40 gave 95, too few to separate the
//! settings: dozens tied at 95/95). Searched: `evidence` ∈ {track, pattern, both},
//! `distance_mm` ∈ {0.8, 1, 1.5, 2, 2.5}, `pattern_contact_sigmas` ∈ {3, 4, 6, 12},
//! `pattern_floor_sigmas` ∈ {0, 1, 2}, `pattern_window_frames` ∈ {3, 5} (the other settings at
//! the previous search's choice, re-checked below), each with `onset_lead_s` = its median signed onset error on
//! the tuning members with no lead (to 0.01 s). Ranked by: the demo's recording (`gradtac
//! demo`, the old simulator: neither a tuning nor a held-out member) classified right with
//! |onset error| ≤ 0.040 s (the issue's "as good or better" for the demo), then false alarms,
//! then grasps right, then median onset error. Chosen (the first row): `pattern`, 1.5 mm,
//! 3 σ, floor 1 σ, 3 frames, lead 0.03 s — 274/280 right, no false alarm, 30 ms on the tuning
//! members. The demo filter decided between near ties only: without it the first row is the
//! same with 5 frames (274/280, 28 ms; demo −0.045 s). The best setting of each evidence
//! (`slip_eval -- tune`; rank in the ranking above, the demo filter included):
//!
//! - best track: rank 158 — FA 0 right 257/280 med 37 ms, dist 1.5, demo -0.080 s
//! - best pattern: rank 1 — FA 0 right 274/280 med 30 ms, dist 1.5, demo -0.020 s
//! - best both: rank 31 — FA 0 right 261/280 med 42 ms, dist 2.5, demo -0.035 s
//!
//! A second stage (`slip_eval -- tune rule`), on the chosen evidence: `window_s` ∈ {0.2, 0.3,
//! 0.4} × `min_duration_s` ∈ {0.05, 0.1, 0.2} × `dominance` ∈ {1.25, 1.5, 2}, same ranking,
//! kept `window_s` 0.3 s and `min_duration_s` 0.1 s (274/280, 30 ms); `dominance` made no
//! difference on the tuning members (kept at 1.5).
//!
//! A third stage (`slip_eval -- diag`, which lists the tuning members' misses with each
//! finger's displacement trace and physics; `DIAG_SEEDS=400` for seeds 0..400, 930 grasps with
//! Gaussian / difference-of-Gaussians kernels — every seed below the held-out 1000). The 27
//! misses of the defaults there (903/930; rot. cw the worst class, 176/186 = 94.6 %): 17
//! slips without a decision, nearly all because **one finger's pattern point moves much less
//! than its contact** (the weaker finger at 0–0.6 of `distance_mm` while the other is at 1; 22
//! of the 27 misses have a difference-of-Gaussians kernel on some finger — its negative
//! surround and the saturated centre pull the energy centroid), several of them slow slips
//! (2–4 mm/s) whose weaker finger reaches the distance only over more than the 1.2 s window;
//! 5 with the wrong class first, where a finger's point moves the **wrong way** (not the fluid
//! lag: the candidate persisted 0.1 s with the same class, and the lagging finger's evidence
//! is clamped, so a lag alone gives an ambiguous `|L| = |R|` that keeps the state); 5 with a
//! slip event in a still stretch (3 of them on stable grasps: squeeze changes moving one
//! finger's point by a full `distance_mm`). Tried on those 930 (default otherwise):
//!
//! | change | right | rot. cw | stable | false alarms / min | onset median |
//! |---|---|---|---|---|---|
//! | none (`history_s` 1.5: windows 0.3–1.2 s) | 903/930 | 176/186 | 183/186 | 0.29 | 31 ms |
//! | **window ladder to `history_s` = 2.4 s (adopted)** | 907/930 | 178/186 | 183/186 | 0.34 | 31 ms |
//! | ladder to 3.6 s | 907/930 | 178/186 | 183/186 | 0.34 | 31 ms |
//! | ladder to 4.8 s | 909/930 | 179/186 | 182/186 | 0.38 | 31 ms |
//! | slip level 0.7 (of 0.75) | 905/930 | 176/186 | 183/186 | 0.29 | 29 ms |
//! | slip level 0.65 | 907/930 | 178/186 | 183/186 | 0.43 | 29 ms |
//! | slip level 0.6 | 902/930 | 175/186 | 182/186 | 0.62 | 29 ms |
//! | position from taxels above 5 % of the peak energy only | 897/930 | 175/186 | 184/186 | 0.24 | 34 ms |
//! | … above 10 % | 892/930 | 174/186 | 185/186 | 0.24 | 37 ms |
//! | … above 20 % | 876/930 | 167/186 | 186/186 | 0.19 | 53 ms |
//! | `pattern_follow_s` 0 / 1 / 5 / 20 (of 2) | 902 / 903 / 903 / 902 | 176 / 175 / 176 / 176 | 183–184 | 0.24–0.29 | 30–31 ms |
//!
//! Adopted: the window ladder doubles up to `history_s` (was fixed at ×1, ×2, ×4) and
//! `history_s` = 2.4 s — the shortest ladder covering the family's slowest slips (≤ 1.5 s of
//! motion plus ≤ 0.3 s of slow start); on seeds 0..120 it changes nothing (274/280, 30 ms),
//! 3.6 s gains nothing more, 4.8 s two grasps for a false alarm on a stable grasp. The
//! held-out members were scored once with it (the tables below; before it: 292/300, rot. cw
//! 56/60, onset median 25 ms). Not adopted: a lower slip level (0.65: the same gain with more
//! false alarms — a threshold tweak, not a fix), a peak-relative position floor (fewer slips
//! right: the point jumps between taxels), the baseline follow (no effect).
//!
//! **Held out**: seeds 1000..1060 × 5 classes, every kernel (300 grasps; 165 with an
//! exponential kernel — the physics not tuned on — on some finger). "Right": a stable grasp
//! without any slip event; a slipping grasp whose first slip event decided after the onset has
//! the true class, with no slip event before the onset. Onset error: `|onset − true onset|` of
//! the slipping grasps right. False alarms: slip events before the onset (stable grasps: any)
//! per minute of still grasp (stable grasps and the still part of slipping ones).
//!
//! | | stable | long. up | long. down | rot. cw | rot. ccw | all right | onset err median (ms) | p90 (ms) | decided after onset, median (ms) | false alarms / min still |
//! |---|---|---|---|---|---|---|---|---|---|---|
//! | displacement (default), all | 60/60 | 58/60 | 59/60 | 57/60 | 59/60 | 293/300 (97.7 %) | 28 | 106 | 468 | 0.30 |
//! | displacement (default), exponential kernel (held-out physics) | 33/33 | 31/33 | 33/33 | 32/33 | 33/33 | 162/165 (98.2 %) | 26 | 81 | 478 | 0.55 |
//! | displacement (default), tuning members (in-sample) | 56/56 | 54/56 | 55/56 | 55/56 | 54/56 | 274/280 (97.9 %) | 30 | 132 | 437 | 0.00 |
//! | track velocity (previous rule, baseline), all | 58/60 | 30/60 | 35/60 | 27/60 | 29/60 | 179/300 (59.7 %) | 126 | 402 | 363 | 0.76 |
//! | track velocity (previous rule, baseline), exponential kernel (held-out physics) | 32/33 | 18/33 | 18/33 | 15/33 | 12/33 | 95/165 (57.6 %) | 126 | 321 | 363 | 1.10 |
//! | track velocity (previous rule, baseline), tuning members (in-sample) | 54/56 | 28/56 | 28/56 | 35/56 | 27/56 | 172/280 (61.4 %) | 125 | 475 | 355 | 0.96 |
//!
//! Against the targets (every class ≥ 95 %, median onset error ≤ 30 ms, no false alarm on
//! stable grasps): met, with no margin on rotational cw — 57/60 (95.0 %; the other classes
//! ≥ 96.7 %, 97.7 % overall), median onset error 28 ms, the stable grasps 60/60 without any
//! event. One grasp more than before the window ladder (a rotational cw slip at 3.2 mm/s with
//! a slow start); one more miss on that class would put it under the target. The false alarms
//! left (0.30 per minute) are slip events before the onset of slipping grasps. The seven
//! misses (`slip_eval` lists them): two without a decision (3.2 mm/s with a slow start,
//! 23 mm/s), three with the wrong class first (two fast slips at 20–24 mm/s, one at 9.7 mm/s
//! decided 0.25 s after its onset), two with a slip event in the still part before the onset
//! (both with an exponential kernel on some finger). What the tuning members' misses show
//! (above): a finger's pattern point moving much less than its contact, or the wrong way —
//! the position estimate, not the decision rule, is what is left to improve.
//!
//! By slip speed (held out, default; each row with all 60 stable grasps):
//!
//! | | stable | long. up | long. down | rot. cw | rot. ccw | all right | onset err median (ms) | p90 (ms) | decided after onset, median (ms) | false alarms / min still |
//! |---|---|---|---|---|---|---|---|---|---|---|
//! | 2–4 mm/s (+ all stable) | 60/60 | 20/21 | 15/15 | 15/15 | 13/14 | 123/125 (98.4 %) | 44 | 172 | 726 | 0.28 |
//! | 4–8 mm/s (+ all stable) | 60/60 | 17/18 | 10/10 | 14/14 | 21/21 | 122/123 (99.2 %) | 27 | 116 | 559 | 0.28 |
//! | 8–15 mm/s (+ all stable) | 60/60 | 10/10 | 20/20 | 13/14 | 20/20 | 123/124 (99.2 %) | 23 | 73 | 403 | 0.00 |
//! | 15–30 mm/s (+ all stable) | 60/60 | 11/11 | 14/15 | 15/17 | 5/5 | 105/108 (97.2 %) | 17 | 66 | 301 | 0.00 |
//!
//! The demo's recording through the same inputs: demo recording (`gradtac demo`), default: Some("longitudinal_down") onset error -0.020 s.
//!
//! # Delay
//! An event is emitted `min_duration_s` after the candidate is first seen ([`Stage::delay`]
//! reports that); the candidate is first seen once a finger's displacement over a window
//! reaches ¾ of `distance_mm` (and the other's half) — a time that grows as the slip slows —
//! after the pattern's averaging (`(pattern_window_frames − 1)/2` frames, 1 by default). A
//! return to stable is seen once no window of the ladder shows motion: up to `history_s`
//! (2.4 s) after the motion stops. The decision latency trade on the held-out members (other
//! settings default; `window_s` 0.3 and `min_duration_s` 0.1 are the default, chosen by the
//! previous search on the tuning members):
//!
//! | | stable | long. up | long. down | rot. cw | rot. ccw | all right | onset err median (ms) | p90 (ms) | decided after onset, median (ms) | false alarms / min still |
//! |---|---|---|---|---|---|---|---|---|---|---|
//! | window 0.2 s, persist 0 s | 59/60 | 56/60 | 58/60 | 55/60 | 57/60 | 285/300 (95.0 %) | 27 | 111 | 377 | 4.99 |
//! | window 0.2 s, persist 0.05 s | 60/60 | 57/60 | 59/60 | 56/60 | 58/60 | 290/300 (96.7 %) | 26 | 114 | 420 | 1.82 |
//! | window 0.2 s, persist 0.1 s | 60/60 | 57/60 | 60/60 | 57/60 | 59/60 | 293/300 (97.7 %) | 28 | 99 | 469 | 0.91 |
//! | window 0.2 s, persist 0.2 s | 60/60 | 59/60 | 60/60 | 56/60 | 59/60 | 294/300 (98.0 %) | 33 | 103 | 570 | 0.15 |
//! | window 0.3 s, persist 0 s | 60/60 | 56/60 | 58/60 | 56/60 | 57/60 | 287/300 (95.7 %) | 27 | 116 | 377 | 2.42 |
//! | window 0.3 s, persist 0.05 s | 60/60 | 57/60 | 59/60 | 57/60 | 58/60 | 291/300 (97.0 %) | 26 | 106 | 419 | 1.06 |
//! | window 0.3 s, persist 0.1 s | 60/60 | 58/60 | 59/60 | 57/60 | 59/60 | 293/300 (97.7 %) | 28 | 106 | 468 | 0.30 |
//! | window 0.3 s, persist 0.2 s | 60/60 | 58/60 | 60/60 | 57/60 | 59/60 | 294/300 (98.0 %) | 33 | 105 | 569 | 0.30 |
//! | window 0.4 s, persist 0 s | 59/60 | 56/60 | 59/60 | 56/60 | 58/60 | 288/300 (96.0 %) | 26 | 104 | 370 | 1.97 |
//! | window 0.4 s, persist 0.05 s | 60/60 | 57/60 | 59/60 | 57/60 | 58/60 | 291/300 (97.0 %) | 27 | 109 | 419 | 1.06 |
//! | window 0.4 s, persist 0.1 s | 60/60 | 57/60 | 60/60 | 57/60 | 59/60 | 293/300 (97.7 %) | 28 | 99 | 469 | 0.61 |
//! | window 0.4 s, persist 0.2 s | 60/60 | 59/60 | 60/60 | 56/60 | 59/60 | 294/300 (98.0 %) | 33 | 104 | 569 | 0.15 |
//! | window 0.6 s, persist 0 s | 60/60 | 56/60 | 59/60 | 57/60 | 58/60 | 290/300 (96.7 %) | 26 | 116 | 398 | 1.06 |
//! | window 0.6 s, persist 0.05 s | 60/60 | 58/60 | 60/60 | 57/60 | 58/60 | 293/300 (97.7 %) | 28 | 106 | 438 | 0.45 |
//! | window 0.6 s, persist 0.1 s | 60/60 | 58/60 | 60/60 | 57/60 | 59/60 | 294/300 (98.0 %) | 28 | 99 | 488 | 0.30 |
//! | window 0.6 s, persist 0.2 s | 60/60 | 59/60 | 60/60 | 57/60 | 59/60 | 295/300 (98.3 %) | 31 | 105 | 586 | 0.15 |
//!
//! # Units
//! Positions mm, displacements in units of `distance_mm` (`common_mm_s` / `differential_mm_s`
//! of the `displacement` rule are `L`, `R` in those units; mm/s for `velocity`), times ns
//! ([`Timestamp`]); configuration in seconds and mm.
//!
//! # Cost
//! Per point O(history) for the slopes of the window ladder: one pass for every window's
//! means and one for their centred sums side by side (2 × `history_s` × rate point visits,
//! 480 at 100 Hz; `history_s` ≤ [`MAX_HISTORY_S`]; bit-identical to a separate fit per
//! window). Once per slip decision the change point: O(history) suffix sums, then
//! O(256 · longest start's points) for the candidates (one pass serves every start; ≤ 40
//! points at 100 Hz with `linear_smooth`, ≤ 30 with `linear`) and O(history) for each of the
//! few candidates re-scored exactly — the same onset as the direct O(starts · 256 · 2 ·
//! history) fit, to the candidate. Live (`examples/latency.rs`, two fingertips on a CAN bus,
//! 100 Hz, three runs on a loaded 2-core machine, medians of the runs; measured with the
//! previous default): a frame that decides a slip 67–68 µs p50 with `onset_starts =
//! "linear_smooth"` against 47 µs with `linear` (the fit before the widened family); every
//! frame 0.9 µs p50, 1.2 µs p99 with either (1.2–1.4 µs with `linear`: noise); decision
//! frames' p99 3–8 ms under that load for both. The current default (`linear_cubic`, the
//! ramp null, `weighted`: seven starts as before, plus one O(history) pass per finger for the
//! weight), in-process (`slip_eval`: every push that decided a slip on the 500 held-out
//! members, 402 decisions, one thread on a loaded 2-core machine): p50 51 µs against 49 µs
//! for the previous default in the same run; p99 8.1 ms for both (the machine's load). The
//! pattern path adds
//! O(taxels) per frame ([`crate::slip_pattern`]); with `evidence = "pattern"` a slip output
//! needs no locator or track. The default `onset_position = "fit"` adds a model fit per
//! frame and finger in [`crate::slip_pattern`] (its Cost section) and nothing here (the
//! onset history is one more position per point).
//!
//! # Trade-offs
//! | knob | lower | higher |
//! |---|---|---|
//! | `distance_mm` | detects slips sooner and slower ones; false alarms from centroid wander (squeeze, drift) | misses short slips; later decisions |
//! | `window_s` | quick decisions on fast slips, noisier slope | smoother, later; slow slips need the 2× and 4× windows anyway |
//! | `min_duration_s` | quick decisions | fewer false alarms, later events |
//! | `settle_s` | slips soon after the grasp closes are seen | fewer false alarms from the grasp settling |
//! | `onset_lead_s` | onsets late on laggy sensors / slow starts | onsets early on quick sensors / sudden slips |
//! | `onset_starts` | `linear`: ≈ ⅔ of the fit's work per decision; soft starts dated later | `linear_cubic` (default) or `linear_smooth`: seven starts; with `ramp_hinge` and `weighted` the tuning members' worst start shape 49 ms median \|error\| (`linear_smooth` 59, `linear` 70) |
//! | `onset_model` | `hinge`: a grip still ramping before the slip pulls the onset early | `ramp_hinge` (default): the ramp is absorbed; a drift-like slow start is taken for drift |
//! | `onset_position` | `energy`: the decision's own point, O(taxels) per frame; it sticks to the strongest taxel (held out: median 49 ms, per shape 52 / 46 / 47 ms) | `fit` (default): a model fit per frame and finger; the point follows the contact evenly (held out: 42 ms, per shape 42 / 43 / 40 ms); `linear` in between in cost, not better in error |
//! | `onset_fingers` | `mean`: a finger whose point barely moves or wanders counts as much as a clean one; `earliest`: the first finger's onset, but the earlier of two noisy fits (steps early) | `weighted`: each finger by its fit's clarity; a slip that starts on one finger is dated between the two, nearer the clearer; `clear_earliest` (default): the earliest clear finger — the first finger's start, a noisy fit kept out by the gate (held out: one-finger-first mean +16 against +27 ms, medians 0–3 ms worse) |
//! | `onset_finger_gate` (`clear_earliest`) | toward `earliest`: unclear fits compete, onsets early | toward the clearest finger alone: a slip that starts on the less clear finger is dated late |
//! | `history_s` | cheaper; slow slips reach `distance_mm` in no window, their onsets fall outside it | slow slips decided and dated; long still stretches with drift or squeeze count as motion (4.8 s: a false alarm more on the tuning members); the return to stable comes later (the longest window sees the motion until it leaves it: up to `history_s` after it stops); more work per point |
//! | `max_gap_s` | a dropout forgets the history | a long dropout may join two contacts |
//! | `evidence` | `track`: the locator's gated, smoothed track — a weak finger gives none, so no decision | `pattern`: a position from every frame with any change; `both`: the track where it has evidence |
//! | `pattern_*` | see [`crate::slip_pattern`] (trade-offs there) | |
//!
//! # Example: a grasp from the model family, end to end
//! ```
//! use gradtac_stages::sim_grasp::{detect, GraspMember};
//! use gradtac_stages::slip::{SlipClass, SlipConfig};
//!
//! let rec = GraspMember { seed: 1003, class: SlipClass::RotationalCcw }.simulate();
//! // taxel centroid → track → slip, every stage at its defaults
//! let events = detect(&rec, &SlipConfig::default())?;
//! assert_eq!(events[0].class, SlipClass::RotationalCcw);
//! let err = events[0].onset.as_secs_f64() - rec.truth.onset_s;
//! assert!(err.abs() < 0.1, "{err}");
//! # Ok::<(), gradtac_stages::Error>(())
//! ```

use crate::slip_pattern::PatternPoint;
use crate::track::{ContactState, TrackPoint};
use crate::{Error, Result};
use gradtac_stream::{Delay, SensorId, Stage, Timed, Timestamp};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

const STAGE: &str = "slip";

/// The state of a two-finger grasp.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SlipClass {
    /// No slip.
    #[default]
    Stable,
    /// The object moves up between the fingers.
    LongitudinalUp,
    /// The object moves down between the fingers.
    LongitudinalDown,
    /// The object rotates clockwise (surface down at the first finger, up at the second).
    RotationalCw,
    /// The object rotates counter-clockwise (surface up at the first finger, down at the second).
    RotationalCcw,
}

impl SlipClass {
    /// All five classes.
    pub const ALL: [SlipClass; 5] = [
        SlipClass::Stable,
        SlipClass::LongitudinalUp,
        SlipClass::LongitudinalDown,
        SlipClass::RotationalCw,
        SlipClass::RotationalCcw,
    ];

    /// The snake_case name (as serialised).
    pub fn name(self) -> &'static str {
        match self {
            SlipClass::Stable => "stable",
            SlipClass::LongitudinalUp => "longitudinal_up",
            SlipClass::LongitudinalDown => "longitudinal_down",
            SlipClass::RotationalCw => "rotational_cw",
            SlipClass::RotationalCcw => "rotational_ccw",
        }
    }

    /// True for every class but [`SlipClass::Stable`].
    pub fn is_slip(self) -> bool {
        self != SlipClass::Stable
    }
}

/// How a finger's motion is measured (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SlipMethod {
    /// Displacement of the contact (the change pattern's centroid with the default locator)
    /// over `window_s`, each finger against `distance_mm`; onset from a change-point fit.
    #[default]
    Displacement,
    /// The previous rule (the cheap baseline): track velocity over `velocity_window_s` against
    /// `speed_threshold_mm_s`; onset is the oldest point of the regression windows.
    Velocity,
}

impl SlipMethod {
    /// The name in scenes.
    pub fn name(self) -> &'static str {
        match self {
            SlipMethod::Displacement => "displacement",
            SlipMethod::Velocity => "velocity",
        }
    }
}

/// Where the `displacement` rule reads each finger's position (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SlipEvidence {
    /// The contact track only ([`SlipInput::Track`]).
    Track,
    /// The raw-frame change pattern only ([`SlipInput::Pattern`], [`crate::slip_pattern`]).
    #[default]
    Pattern,
    /// The track where it has evidence, else the pattern.
    Both,
}

impl SlipEvidence {
    /// The name in scenes.
    pub fn name(self) -> &'static str {
        match self {
            SlipEvidence::Track => "track",
            SlipEvidence::Pattern => "pattern",
            SlipEvidence::Both => "both",
        }
    }

    /// Whether the slip stage needs the raw frames' pattern points.
    pub fn needs_frames(self) -> bool {
        self != SlipEvidence::Track
    }

    /// Whether the slip stage needs the track points.
    pub fn needs_tracks(self) -> bool {
        self != SlipEvidence::Pattern
    }
}

/// What the change-point fit that dates a slip's onset takes the stretch before the onset to
/// be (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum OnsetModel {
    /// Still, then moving: `u = a + b·z(t − t₀)`.
    Hinge,
    /// Drifting at a constant rate, then moving: `u = a + g·t + b·z(t − t₀)` — a grip force
    /// still ramping (or drift) moves the pattern point slowly before the slip; a still model
    /// puts the onset early to absorb that ramp.
    #[default]
    RampHinge,
}

impl OnsetModel {
    /// The name in scenes.
    pub fn name(self) -> &'static str {
        match self {
            OnsetModel::Hinge => "hinge",
            OnsetModel::RampHinge => "ramp_hinge",
        }
    }
}

/// Which starts of the motion the change-point fit tries (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum OnsetStarts {
    /// Sudden, or a speed rising linearly over 0.1, 0.2 or 0.3 s (4 starts).
    Linear,
    /// Those and a speed rising smoothly (`3x² − 2x³`) over 0.2, 0.3 or 0.4 s (7 starts;
    /// more of the fit's work per decision).
    LinearSmooth,
    /// The linear ones and a speed rising as `x²` (an accelerating start: the distance grows
    /// as the cube of the time) over 0.2, 0.3 or 0.4 s (7 starts; the same work as
    /// `linear_smooth`).
    #[default]
    LinearCubic,
}

impl OnsetStarts {
    /// The name in scenes.
    pub fn name(self) -> &'static str {
        match self {
            OnsetStarts::Linear => "linear",
            OnsetStarts::LinearSmooth => "linear_smooth",
            OnsetStarts::LinearCubic => "linear_cubic",
        }
    }
}

/// Which pattern position the change-point fit that dates a slip's onset reads
/// ([`crate::slip_pattern`]; the decision always reads the energy-weighted one).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum OnsetPosition {
    /// The decision's position: the mean weighted by the change's energy above the floor,
    /// `max(0, zᵢ² − f²)` — it sticks to the strongest taxel while the contact crosses it.
    Energy,
    /// The mean weighted by the change above the floor, `max(0, |zᵢ| − f)`: follows the
    /// contact more evenly across the taxels (one more weighted sum per frame).
    Linear,
    /// The contact position of a per-frame model fit of the change pattern
    /// ([`crate::fit::Fit`]'s fitted point, before its position memory and motion prior: one
    /// Levenberg–Marquardt fit per frame and finger), which does not stick to a taxel.
    #[default]
    Fit,
}

impl OnsetPosition {
    /// The name in scenes.
    pub fn name(self) -> &'static str {
        match self {
            OnsetPosition::Energy => "energy",
            OnsetPosition::Linear => "linear",
            OnsetPosition::Fit => "fit",
        }
    }
}

/// How the fingers' fitted change points make one onset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum OnsetFingers {
    /// Their mean.
    Mean,
    /// The earliest: a slip that starts on one finger starts there.
    Earliest,
    /// Their mean weighted by how clearly each finger's fit stands out of its residual:
    /// `(C − E)/E`, `C` the history's spread about its mean, `E` the fit's squared error — a
    /// finger whose point barely moves, or wanders, counts less than one that moves cleanly.
    Weighted,
    /// The earliest change point among the fingers whose fit is clear enough: weight
    /// (`(C − E)/E`, as `weighted`) at least `onset_finger_gate` × the clearest finger's. The
    /// simulator's truth (and a slip that starts on one finger) is the first finger's start,
    /// which a mean dates between the two; the gate keeps a finger whose fit barely stands out
    /// of its residual from pulling the onset early. Gate 0 is `earliest`, gate 1 the clearest
    /// finger alone. The default (stop 31b).
    #[default]
    ClearEarliest,
}

impl OnsetFingers {
    /// The name in scenes.
    pub fn name(self) -> &'static str {
        match self {
            OnsetFingers::Mean => "mean",
            OnsetFingers::Earliest => "earliest",
            OnsetFingers::Weighted => "weighted",
            OnsetFingers::ClearEarliest => "clear_earliest",
        }
    }
}

/// One input of the [`Slip`] stage: a track point or a pattern point, of either finger.
#[derive(Clone, Debug, PartialEq)]
pub enum SlipInput {
    /// A contact track point (`track` tap).
    Track(TrackPoint),
    /// A raw-frame pattern point ([`crate::slip_pattern::SlipPattern`]).
    Pattern(PatternPoint),
}

impl From<TrackPoint> for SlipInput {
    fn from(p: TrackPoint) -> Self {
        SlipInput::Track(p)
    }
}

impl From<PatternPoint> for SlipInput {
    fn from(p: PatternPoint) -> Self {
        SlipInput::Pattern(p)
    }
}

impl Timed for SlipInput {
    fn time(&self) -> Timestamp {
        match self {
            SlipInput::Track(p) => p.time,
            SlipInput::Pattern(p) => p.time,
        }
    }
}

/// Configuration of the [`Slip`] stage (`[stages.slip]` in a scene).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SlipConfig {
    /// The first sensor (the first finger). Default `"ff"`.
    pub first: String,
    /// The second sensor, facing the first (the thumb). Default `"th"`.
    pub second: String,
    /// World up in the first sensor's layout plane (any non-zero vector; normalised).
    /// Default `[0, 1]`.
    pub first_up: [f64; 2],
    /// World up in the second sensor's layout plane. Default `[0, −1]` (mirrored).
    pub second_up: [f64; 2],
    /// How motion is measured. Default `displacement`.
    pub method: SlipMethod,
    /// `displacement`: the window (s, > 0) over which each finger's displacement along world
    /// up is measured (least-squares slope × window). Default 0.3.
    pub window_s: f64,
    /// `displacement`: a finger moves when its displacement over the window reaches this
    /// (mm, > 0). Default 1.5.
    pub distance_mm: f64,
    /// `displacement`: how far back (s, ≥ `window_s`, ≤ [`MAX_HISTORY_S`]) each finger's
    /// position history reaches: the longest window of the displacement ladder (`window_s`
    /// doubled while ≤ this) and the span of the change-point fit that dates the onset.
    /// Default 2.4 (the ladder 0.3, 0.6, 1.2, 2.4 s covers the slowest slips of the family,
    /// ≤ 1.8 s long).
    pub history_s: f64,
    /// `displacement`: subtracted from the fitted change point (s; negative moves it later): the
    /// fit's bias — the upstream delay (the averaging, the sensor's fluid lag) against the
    /// fit's own lateness on soft starts — measured on tuning members. Default 0.010 (the
    /// mean signed error of the default fit without a lead on the tuning members, to 5 ms;
    /// 0.025 with `onset_fingers = "weighted"`).
    pub onset_lead_s: f64,
    /// `displacement`: the model of the change-point fit ([`OnsetModel`]). Default
    /// `ramp_hinge`.
    pub onset_model: OnsetModel,
    /// `displacement`: how the fingers' change points combine ([`OnsetFingers`]). Default
    /// `clear_earliest`.
    pub onset_fingers: OnsetFingers,
    /// `onset_fingers = "clear_earliest"`: a finger's change point competes for the earliest
    /// only when its fit weight is at least this fraction (0–1) of the clearest finger's.
    /// Default 0.35 (`slip_eval -- tune fingers`).
    pub onset_finger_gate: f64,
    /// `displacement`: the starts the change-point fit tries ([`OnsetStarts`]). Default
    /// `linear_cubic`.
    pub onset_starts: OnsetStarts,
    /// `displacement` with pattern evidence: the pattern position the change-point fit reads
    /// ([`OnsetPosition`]; the decision reads the energy-weighted one whatever this is). Default
    /// `fit`.
    pub onset_position: OnsetPosition,
    /// `onset_position = "fit"`: estimate each sensor's fluid lag online from its press
    /// onsets and undo it on the electrodes before the fit ([`crate::lag`], the locator's
    /// `fit_lag_estimate`), so the fitted point is not `v·τ` behind a moving contact. Default
    /// `false`.
    pub onset_fit_lag: bool,
    /// A finger without a usable contact point for longer than this (s, > 0; a contact
    /// dropout or missing input) starts afresh: history cleared, `settle_s` again. Shorter
    /// dropouts keep the history (the contact may have moved meanwhile) and the last evidence.
    /// (`velocity`: any point without contact clears the finger.) Default 0.5.
    pub max_gap_s: f64,
    /// `displacement`: a finger's evidence starts this long (s, ≥ 0) after its contact starts
    /// (closing the grasp moves the contact's centroid while the pattern settles). Default 0.3.
    pub settle_s: f64,
    /// `velocity`: length of the velocity regression (s, > 0). Default 0.15.
    pub velocity_window_s: f64,
    /// `velocity`: fewest contact points in the regression (≥ 2). Default 5.
    pub min_points: usize,
    /// `velocity`: slip speed threshold on `max(|L|, |R|)` (mm/s, > 0). Default 5.
    pub speed_threshold_mm_s: f64,
    /// How clearly one mode must dominate (≥ 1): a slip class is a candidate only when
    /// `max(|L|, |R|) ≥ dominance · min(|L|, |R|)`; a more ambiguous motion keeps the current
    /// state. Default 1.5.
    pub dominance: f64,
    /// How long a new candidate class must persist before it becomes the state (s, ≥ 0).
    /// Default 0.1.
    pub min_duration_s: f64,
    /// `displacement`: where each finger's position comes from (see the [module docs](self)).
    /// Default `pattern`.
    pub evidence: SlipEvidence,
    /// Pattern evidence ([`crate::slip_pattern`]): start-up frames measuring each taxel's
    /// baseline and noise (2–100 000). Default 20.
    pub pattern_calibrate_frames: u32,
    /// Pattern evidence: frames averaged (1–1000). Default 3.
    pub pattern_window_frames: u32,
    /// Pattern evidence: the noise floor removed from each taxel's energy (σ of one frame,
    /// ≥ 0). Default 1.
    pub pattern_floor_sigmas: f64,
    /// Pattern evidence: a finger is in contact when its energy above the floor reaches the
    /// square of this (σ of one frame, > 0). Default 3.
    pub pattern_contact_sigmas: f64,
    /// Pattern evidence: time constant (s, ≥ 0; 0 = never) with which taxels below the floor
    /// follow drift. Default 2.
    pub pattern_follow_s: f64,
}

impl Default for SlipConfig {
    fn default() -> Self {
        SlipConfig {
            first: "ff".into(),
            second: "th".into(),
            first_up: [0.0, 1.0],
            second_up: [0.0, -1.0],
            method: SlipMethod::Displacement,
            window_s: 0.3,
            distance_mm: 1.5,
            history_s: 2.4,
            onset_lead_s: 0.010,
            onset_model: OnsetModel::RampHinge,
            onset_fingers: OnsetFingers::ClearEarliest,
            onset_finger_gate: 0.35,
            onset_starts: OnsetStarts::LinearCubic,
            onset_position: OnsetPosition::Fit,
            onset_fit_lag: false,
            max_gap_s: 0.5,
            settle_s: 0.3,
            velocity_window_s: 0.15,
            min_points: 5,
            speed_threshold_mm_s: 5.0,
            dominance: 1.5,
            min_duration_s: 0.1,
            evidence: SlipEvidence::Pattern,
            pattern_calibrate_frames: 20,
            pattern_window_frames: 3,
            pattern_floor_sigmas: 1.0,
            pattern_contact_sigmas: 3.0,
            pattern_follow_s: 2.0,
        }
    }
}

impl SlipConfig {
    /// Whether the stage decides from raw-frame pattern points (the displacement rule with
    /// `pattern` or `both` evidence): a scene then feeds it [`crate::slip_pattern`]'s points.
    pub fn reads_frames(&self) -> bool {
        self.method == SlipMethod::Displacement && self.evidence.needs_frames()
    }

    /// Whether the stage decides from track points (the velocity rule, or the displacement
    /// rule with `track` or `both` evidence): a scene then builds the locator and the track.
    pub fn reads_tracks(&self) -> bool {
        self.method == SlipMethod::Velocity || self.evidence.needs_tracks()
    }

    /// One line with every effective value (for `explain`).
    pub fn describe(&self) -> String {
        let common = format!(
            "{} (up {:?}) and {} (up {:?}), dominance {}, persist {} s",
            self.first, self.first_up, self.second, self.second_up, self.dominance, self.min_duration_s
        );
        match self.method {
            SlipMethod::Displacement => format!(
                "two-finger slip by displacement: {} mm over {} s per finger after {} s of contact, onset by \
                 change-point fit ({}, {} starts, {} finger, {} position) over {} s minus {} s, dropouts > {} s start afresh; evidence {}{}; {common}",
                self.distance_mm,
                self.window_s,
                self.settle_s,
                self.onset_model.name(),
                self.onset_starts.name(),
                match self.onset_fingers {
                    OnsetFingers::ClearEarliest => format!("clear_earliest (gate {})", self.onset_finger_gate),
                    f => f.name().to_string(),
                },
                match self.onset_position {
                    OnsetPosition::Fit => {
                        let lc = crate::slip_pattern::onset_fit_config(self);
                        format!(
                            "fit (per-frame model fit: contact {} σ, {} iterations, {}{})",
                            lc.contact_sigmas,
                            lc.fit_iterations,
                            if lc.fit_signed { "signed" } else { "magnitudes" },
                            if lc.fit_lag_estimate { ", fluid lag estimated" } else { "" }
                        )
                    }
                    p => p.name().to_string(),
                },
                self.history_s,
                self.onset_lead_s,
                self.max_gap_s,
                self.evidence.name(),
                if self.evidence.needs_frames() {
                    format!(
                        " (raw-frame pattern: calibrate {} frames, average {}, floor {} σ, contact energy ≥ ({} σ)², \
                         follow {} s)",
                        self.pattern_calibrate_frames,
                        self.pattern_window_frames,
                        self.pattern_floor_sigmas,
                        self.pattern_contact_sigmas,
                        self.pattern_follow_s
                    )
                } else {
                    String::new()
                }
            ),
            SlipMethod::Velocity => format!(
                "two-finger slip by track velocity: {} mm/s over {} s (≥ {} points); {common}",
                self.speed_threshold_mm_s, self.velocity_window_s, self.min_points
            ),
        }
    }
}

/// A finger's world-up position history: (time ns, position mm), oldest first
/// ([`Slip::position_histories`]).
pub type PositionHistory = Vec<(i64, f64)>;

/// A change of the grasp's state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SlipEvent {
    /// When the change was decided (the time of the track point that decided it).
    pub time: Timestamp,
    /// Estimated start of the new state. For a slip (`displacement`): the change point of the
    /// fingers' positions fitted over `history_s`, minus `onset_lead_s` (never after
    /// `first_seen`); (`velocity`): the oldest contact point in the regression windows when the
    /// slip was first seen. For a return to stable: `first_seen`.
    pub onset: Timestamp,
    /// When the new state was first seen (the first point of the persisting candidate).
    pub first_seen: Timestamp,
    /// The new state.
    pub class: SlipClass,
    /// The state before.
    pub previous: SlipClass,
    /// Common-mode motion `L` along world up at `time` (`velocity`: mm/s; `displacement`:
    /// the fingers' displacements in units of `distance_mm`, each clamped to ±1; NaN when a
    /// finger has no evidence).
    pub common_mm_s: f64,
    /// Differential motion `R` at `time` (same units as `common_mm_s`).
    pub differential_mm_s: f64,
}

impl Timed for SlipEvent {
    fn time(&self) -> Timestamp {
        self.time
    }
}

/// One source's position history along world up (the `displacement` rule).
#[derive(Clone, Debug, Default)]
struct Path {
    /// (time ns, world-up position mm).
    history: VecDeque<(i64, f64)>,
    /// (time ns, world-up position mm) of the onset fit's position (`onset_position`; for a
    /// track the same as `history`): the same times as `history`.
    onset_history: VecDeque<(i64, f64)>,
    last_time: Option<Timestamp>,
    /// Start of the current contact (ns).
    contact_since: Option<i64>,
    /// The last usable point (ns).
    last_usable: Option<i64>,
    /// Displacement over the window in units of `distance_mm`, clamped to ±1.
    moved: Option<f64>,
}

impl Path {
    fn clear(&mut self) {
        self.history.clear();
        self.onset_history.clear();
        self.contact_since = None;
        self.last_usable = None;
        self.moved = None;
    }
}

#[derive(Clone, Debug, Default)]
struct Finger {
    track: Option<u64>,
    /// (time ns, x mm, y mm): the velocity rule's regression window.
    points: VecDeque<(i64, f64, f64)>,
    velocity: Option<[f64; 2]>,
    /// `[track, pattern]` position histories.
    paths: [Path; 2],
}

impl Finger {
    /// Forget the track's evidence (not the pattern's).
    fn clear_track(&mut self) {
        self.track = None;
        self.points.clear();
        self.velocity = None;
        self.paths[0].clear();
    }

    /// The displacement evidence the rule uses and the history it comes from.
    fn evidence(&self, mode: SlipEvidence) -> Option<(f64, &Path)> {
        let of = |k: usize| self.paths[k].moved.map(|m| (m, &self.paths[k]));
        match mode {
            SlipEvidence::Track => of(0),
            SlipEvidence::Pattern => of(1),
            SlipEvidence::Both => of(0).or_else(|| of(1)),
        }
    }
}

/// The two-finger slip detector (see the [module docs](self)).
#[derive(Clone, Debug)]
#[must_use = "a stage does nothing until inputs are pushed"]
pub struct Slip {
    cfg: SlipConfig,
    first: SensorId,
    second: SensorId,
    up: [[f64; 2]; 2],
    window_ns: i64,
    velocity_window_ns: i64,
    history_ns: i64,
    gap_ns: i64,
    settle_ns: i64,
    min_duration_ns: i64,
    fingers: [Finger; 2],
    state: SlipClass,
    candidate: Option<(SlipClass, Timestamp, Timestamp)>,
    /// Whether a pattern point of `first` or `second` has come since construction / reset.
    pattern_seen: bool,
    /// The time step whose inputs have come in part: the decision for it runs once it is
    /// complete ([`Slip::push_input`], "Same-time inputs").
    pending: Option<Timestamp>,
}

fn unit(v: [f64; 2], what: &str) -> Result<[f64; 2]> {
    let n = v[0].hypot(v[1]);
    if n.is_finite() && n > 0.0 {
        Ok([v[0] / n, v[1] / n])
    } else {
        Err(Error::InvalidConfig { stage: STAGE, reason: format!("`{what}` = {v:?} must be a finite non-zero vector") })
    }
}

/// Longest `history_s` (s): the history is scanned per point.
pub const MAX_HISTORY_S: f64 = 60.0;

/// Fraction of `distance_mm` (each finger, clamped) the stronger mode needs for a slip.
const SLIP_LEVEL: f64 = 0.75;
/// Below this fraction in both modes the grasp is still again.
const STILL_LEVEL: f64 = 0.25;

impl Slip {
    /// A detector from its configuration (validated).
    pub fn try_new(cfg: &SlipConfig) -> Result<Self> {
        let bad = |reason: String| Err(Error::InvalidConfig { stage: STAGE, reason });
        if cfg.first == cfg.second {
            return bad(format!("`first` and `second` are both {:?}", cfg.first));
        }
        let span = crate::limits::MAX_SPAN_S;
        for (name, v, zero_ok) in [
            ("velocity_window_s", cfg.velocity_window_s, false),
            ("window_s", cfg.window_s, false),
            ("history_s", cfg.history_s, false),
            ("max_gap_s", cfg.max_gap_s, false),
            ("settle_s", cfg.settle_s, true),
            ("min_duration_s", cfg.min_duration_s, true),
        ] {
            if !(v.is_finite() && (v > 0.0 || (zero_ok && v == 0.0)) && v <= span) {
                let low = if zero_ok { "≥ 0" } else { "> 0" };
                return bad(format!("`{name}` = {v} must be finite, {low} and at most {span} s"));
            }
        }
        if !(cfg.onset_lead_s.is_finite() && cfg.onset_lead_s.abs() <= span) {
            return bad(format!("`onset_lead_s` = {} must be finite and within ±{span} s", cfg.onset_lead_s));
        }
        if !(0.0..=1.0).contains(&cfg.onset_finger_gate) {
            return bad(format!("`onset_finger_gate` = {} must be within 0 and 1", cfg.onset_finger_gate));
        }
        if cfg.history_s > MAX_HISTORY_S {
            return bad(format!("`history_s` = {} must be at most {MAX_HISTORY_S} s", cfg.history_s));
        }
        if cfg.history_s < cfg.window_s {
            return bad(format!("`history_s` = {} must be ≥ `window_s` = {}", cfg.history_s, cfg.window_s));
        }
        if cfg.min_points < 2 {
            return bad(format!("`min_points` = {} must be ≥ 2", cfg.min_points));
        }
        if !(cfg.speed_threshold_mm_s.is_finite() && cfg.speed_threshold_mm_s > 0.0) {
            return bad(format!("`speed_threshold_mm_s` = {} must be finite and > 0", cfg.speed_threshold_mm_s));
        }
        if !(cfg.distance_mm.is_finite() && cfg.distance_mm > 0.0 && cfg.distance_mm <= crate::limits::MAX_SPAN_S) {
            return bad(format!("`distance_mm` = {} must be finite and > 0", cfg.distance_mm));
        }
        if !(cfg.dominance.is_finite() && cfg.dominance >= 1.0) {
            return bad(format!("`dominance` = {} must be finite and ≥ 1", cfg.dominance));
        }
        crate::limits::check_count(STAGE, "min_points", cfg.min_points as u64, crate::limits::MAX_POINTS as u64)?;
        let ns = |s: f64| (s * 1e9).round() as i64;
        Ok(Slip {
            first: SensorId::new(&cfg.first),
            second: SensorId::new(&cfg.second),
            up: [unit(cfg.first_up, "first_up")?, unit(cfg.second_up, "second_up")?],
            window_ns: ns(cfg.window_s),
            velocity_window_ns: ns(cfg.velocity_window_s),
            history_ns: ns(cfg.history_s),
            gap_ns: ns(cfg.max_gap_s),
            settle_ns: ns(cfg.settle_s),
            min_duration_ns: ns(cfg.min_duration_s),
            cfg: cfg.clone(),
            fingers: Default::default(),
            state: SlipClass::Stable,
            candidate: None,
            pattern_seen: false,
            pending: None,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &SlipConfig {
        &self.cfg
    }

    /// The current state.
    pub fn state(&self) -> SlipClass {
        self.state
    }

    /// The current world-up speeds `(v_first, v_second)` (mm/s) of the `velocity` rule, when
    /// both are known.
    pub fn speeds(&self) -> Option<(f64, f64)> {
        let v = |i: usize| self.fingers[i].velocity.map(|v| v[0] * self.up[i][0] + v[1] * self.up[i][1]);
        Some((v(0)?, v(1)?))
    }

    /// The current displacements `(first, second)` along world up over the window, in units of
    /// `distance_mm` clamped to ±1 (`displacement` rule), when both are known.
    pub fn displacements(&self) -> Option<(f64, f64)> {
        Some((self.moved(0)?, self.moved(1)?))
    }

    /// Each finger's world-up position history the onset fit reads (time ns, mm; the last
    /// `history_s`; the `onset_position` of pattern points) with the displacement the rule
    /// measured, when known: what the onset fit dates a slip from (diagnostics: `slip_eval --
    /// onsetdump`).
    pub fn position_histories(&self) -> [Option<(f64, PositionHistory)>; 2] {
        let of = |i: usize| {
            self.fingers[i].evidence(self.cfg.evidence).map(|(m, p)| (m, p.onset_history.iter().copied().collect()))
        };
        [of(0), of(1)]
    }

    /// Finger `i`'s displacement from the evidence the rule uses, when known.
    fn moved(&self, i: usize) -> Option<f64> {
        self.fingers[i].evidence(self.cfg.evidence).map(|e| e.0)
    }

    fn classify(&self, l: f64, r: f64, slip_level: f64, still_level: f64) -> SlipClass {
        let (hi, lo) = (l.abs().max(r.abs()), l.abs().min(r.abs()));
        if hi < still_level {
            SlipClass::Stable
        } else if hi < slip_level || hi < self.cfg.dominance * lo {
            self.state
        } else if l.abs() >= r.abs() {
            if l > 0.0 {
                SlipClass::LongitudinalUp
            } else {
                SlipClass::LongitudinalDown
            }
        } else if r < 0.0 {
            SlipClass::RotationalCw
        } else {
            SlipClass::RotationalCcw
        }
    }

    fn candidate_now(&self) -> (SlipClass, f64, f64) {
        match self.cfg.method {
            SlipMethod::Velocity => {
                let Some((v1, v2)) = self.speeds() else {
                    return (SlipClass::Stable, f64::NAN, f64::NAN);
                };
                let (l, r) = ((v1 + v2) / 2.0, (v1 - v2) / 2.0);
                let th = self.cfg.speed_threshold_mm_s;
                (self.classify(l, r, th, th), l, r)
            }
            SlipMethod::Displacement => {
                let (a, b) = (self.moved(0), self.moved(1));
                if a.is_none() && b.is_none() {
                    return (SlipClass::Stable, f64::NAN, f64::NAN);
                }
                let (a, b) = (a.unwrap_or(0.0), b.unwrap_or(0.0));
                let (l, r) = ((a + b) / 2.0, (a - b) / 2.0);
                let show = |v: f64, ok: bool| if ok { v } else { f64::NAN };
                let both = self.displacements().is_some();
                (self.classify(l, r, SLIP_LEVEL, STILL_LEVEL), show(l, both), show(r, both))
            }
        }
    }

    /// The onset the change-point fit gives from the histories as they are now (`displacement`;
    /// `fallback` when no finger moved at least half `distance_mm` or no fit exists): what a
    /// slip decided now would carry. A diagnostic for re-dating a slip later than its decision
    /// (`slip_eval -- tune horizon` measures that trade on the tuning members).
    pub fn onset_fit_now(&self, fallback: Timestamp) -> Timestamp {
        self.fitted_onset(fallback)
    }

    /// The onset of a slip decided now (`displacement`): the fingers' fitted change points
    /// (of those that moved at least half `distance_mm`) combined by `onset_fingers`, minus
    /// `onset_lead_s`.
    fn fitted_onset(&self, fallback: Timestamp) -> Timestamp {
        let drift = self.cfg.onset_model == OnsetModel::RampHinge;
        // (change point, fit weight) per moving finger
        let mut fits = [(0i64, 0.0f64); 2];
        let mut n = 0;
        for f in &self.fingers {
            if let Some((_, path)) = f.evidence(self.cfg.evidence).filter(|e| e.0.abs() >= 0.5) {
                if let Some((t, _, sse)) = change_point(&path.onset_history, drift, self.cfg.onset_starts) {
                    fits[n] = (t, fit_weight(&path.onset_history, sse));
                    n += 1;
                }
            }
        }
        let fits = &fits[..n];
        if fits.is_empty() {
            return fallback;
        }
        let mean = || (fits.iter().fold(0.0, |s, f| s + f.0 as f64) / n as f64).round() as i64;
        let t = match self.cfg.onset_fingers {
            OnsetFingers::Weighted => {
                let wsum = fits.iter().fold(0.0, |s, f| s + f.1 * f.0 as f64);
                let wn = fits.iter().fold(0.0, |s, f| s + f.1);
                if wn > 0.0 && (wsum / wn).is_finite() {
                    (wsum / wn).round() as i64
                } else {
                    mean()
                }
            }
            OnsetFingers::Mean => mean(),
            OnsetFingers::Earliest => fits.iter().map(|f| f.0).min().unwrap_or(i64::MAX),
            OnsetFingers::ClearEarliest => clear_earliest(fits, self.cfg.onset_finger_gate),
        };
        let t = t - (self.cfg.onset_lead_s * 1e9).round() as i64;
        Timestamp(t.min(fallback.0))
    }
}

/// Most windows of the ladder: `window_ns` doubles each step and stays within `i64`.
const MAX_LADDER: usize = 64;

/// A history's displacement along up over the window ladder `window_ns`, `2·window_ns`,
/// `4·window_ns`, … (each ≤ `history_ns` but the first; least-squares slope × span), the
/// largest in units of `distance_mm`, clamped to ±1; `None` before the history spans half a
/// window.
///
/// Runs on every pattern or track point, so it is written for speed without changing a bit:
/// the windows are nested (each holds the newest points of the next), so one pass from the
/// newest point gives every window's sums of `t` and `u` (the running sums where the window
/// ends), and a second pass accumulates every window's centred moments side by side —
/// independent sums, each over the same points in the same order as a separate two-pass
/// fit per window ([`displacement_reference`] in the tests, compared bit for bit).
fn displacement_of(history: &VecDeque<(i64, f64)>, window_ns: i64, history_ns: i64, distance_mm: f64) -> Option<f64> {
    let mid = history.back()?.0;
    let span = mid - history.front().map_or(mid, |q| q.0);
    // the ladder: (window, oldest time it holds)
    let mut ws = [0i64; MAX_LADDER];
    let mut nw = 0;
    let mut w = window_ns;
    while nw < MAX_LADDER {
        if nw > 0 {
            match w.checked_mul(2) {
                Some(x) => w = x,
                None => break,
            }
        }
        if (nw > 0 && w > history_ns) || 2 * span < w {
            break;
        }
        ws[nw] = w;
        nw += 1;
    }
    if nw == 0 {
        return None;
    }
    let t_of = |p: &(i64, f64)| (p.0 - mid) as f64 * 1e-9;
    // pass 1: per window, the count and the sums of t and u over its points, newest first
    let mut n = [0usize; MAX_LADDER];
    let mut st = [0.0f64; MAX_LADDER];
    let mut su = [0.0f64; MAX_LADDER];
    let (mut cn, mut cst, mut csu) = (0usize, 0.0f64, 0.0f64);
    let mut open = 0; // windows before `open` are closed
    for p in history.iter().rev() {
        while open < nw && p.0 < mid - ws[open] {
            (n[open], st[open], su[open]) = (cn, cst, csu);
            open += 1;
        }
        if open == nw {
            break;
        }
        cn += 1;
        cst += t_of(p);
        csu += p.1;
    }
    for k in open..nw {
        (n[k], st[k], su[k]) = (cn, cst, csu);
    }
    // windows of fewer than 3 points have no slope; the others hold at least their points
    let first = (0..nw).find(|&k| n[k] >= 3).unwrap_or(nw);
    let mut mt = [0.0f64; MAX_LADDER];
    let mut mu = [0.0f64; MAX_LADDER];
    for k in first..nw {
        mt[k] = st[k] / n[k] as f64;
        mu[k] = su[k] / n[k] as f64;
    }
    // pass 2: the centred moments of every window, in groups of up to 4 windows side by side
    // (independent sums in registers); within a group, the points newest first in segments
    // held by the same windows
    let mut stt = [0.0f64; MAX_LADDER];
    let mut stu = [0.0f64; MAX_LADDER];
    let len = history.len();
    let mut g = first;
    while g < nw {
        let end = (g + 4).min(nw);
        let mut from = 0;
        for (a, &to) in n.iter().enumerate().take(end).skip(g) {
            // points from..to (newest first) lie in windows a..end
            let pts = history.range(len - to..len - from).rev().map(|p| (t_of(p), p.1));
            let b = end;
            match b - a {
                4 => centred::<4>(pts, &mt[a..b], &mu[a..b], &mut stt[a..b], &mut stu[a..b]),
                3 => centred::<3>(pts, &mt[a..b], &mu[a..b], &mut stt[a..b], &mut stu[a..b]),
                2 => centred::<2>(pts, &mt[a..b], &mu[a..b], &mut stt[a..b], &mut stu[a..b]),
                _ => centred::<1>(pts, &mt[a..b], &mu[a..b], &mut stt[a..b], &mut stu[a..b]),
            }
            from = to;
        }
        g = end;
    }
    let mut moved: Option<f64> = None;
    for k in first..nw {
        if stt[k] > 0.0 {
            let d = stu[k] / stt[k] * ws[k] as f64 * 1e-9 / distance_mm;
            if moved.is_none_or(|m| d.abs() > m.abs()) {
                moved = Some(d);
            }
        }
    }
    moved.map(|d| d.clamp(-1.0, 1.0))
}

/// `stt[k] += (t − mt[k])²`, `stu[k] += (t − mt[k])·(u − mu[k])` over the points, for `N`
/// windows at once (each sum in the points' order; `N` fixed so the sums stay in registers).
#[inline(always)]
fn centred<const N: usize>(
    pts: impl Iterator<Item = (f64, f64)>,
    mt: &[f64],
    mu: &[f64],
    stt: &mut [f64],
    stu: &mut [f64],
) {
    let (mt, mu): ([f64; N], [f64; N]) = (mt.try_into().expect("N means"), mu.try_into().expect("N means"));
    let mut a: [f64; N] = stt.try_into().expect("N sums");
    let mut b: [f64; N] = stu.try_into().expect("N sums");
    for (t, u) in pts {
        for k in 0..N {
            let dt = t - mt[k];
            a[k] += dt * dt;
            b[k] += dt * (u - mu[k]);
        }
    }
    stt.copy_from_slice(&a);
    stu.copy_from_slice(&b);
}

/// [`displacement_of`] as first written: a separate two-pass fit per window (the tests'
/// bit-for-bit reference).
#[cfg(test)]
fn displacement_reference(
    history: &VecDeque<(i64, f64)>,
    window_ns: i64,
    history_ns: i64,
    distance_mm: f64,
) -> Option<f64> {
    let mid = history.back()?.0;
    let span = mid - history.front().map_or(mid, |q| q.0);
    let mut moved: Option<f64> = None;
    let mut w = window_ns;
    for k in 0.. {
        if k > 0 {
            w *= 2;
        }
        if (k > 0 && w > history_ns) || 2 * span < w {
            break;
        }
        if let Some(v) = slope_since(history, mid - w) {
            let d = v * w as f64 * 1e-9 / distance_mm;
            if moved.is_none_or(|m| d.abs() > m.abs()) {
                moved = Some(d);
            }
        }
    }
    moved.map(|d| d.clamp(-1.0, 1.0))
}

/// Least-squares slope of x and y against t (s) over the points; `None` when degenerate.
fn regression(points: &VecDeque<(i64, f64, f64)>) -> Option<[f64; 2]> {
    let t0 = points.front()?.0;
    let ts = move |p: &(i64, f64, f64)| (p.0 - t0) as f64 * 1e-9;
    Some([ls_slope(points.iter().map(|p| (ts(p), p.1)), 1)?, ls_slope(points.iter().map(|p| (ts(p), p.2)), 1)?])
}

/// Least-squares slope (mm/s) of the history points newer than `since` (ns); `None` with fewer
/// than 3 points or no time spread.
#[cfg(test)]
fn slope_since(history: &VecDeque<(i64, f64)>, since: i64) -> Option<f64> {
    let t0 = history.back()?.0;
    ls_slope(history.iter().rev().take_while(|p| p.0 >= since).map(|p| ((p.0 - t0) as f64 * 1e-9, p.1)), 3)
}

/// Least-squares slope of `u` against `t` over `(t, u)` pairs: two passes (means, then
/// moments); `None` with fewer than `min_points` pairs or no spread in `t`.
fn ls_slope(pts: impl Iterator<Item = (f64, f64)> + Clone, min_points: usize) -> Option<f64> {
    let (mut n, mut st, mut su) = (0usize, 0.0, 0.0);
    for (t, u) in pts.clone() {
        n += 1;
        st += t;
        su += u;
    }
    if n < min_points.max(1) {
        return None;
    }
    let (mt, mu) = (st / n as f64, su / n as f64);
    let (mut stt, mut stu) = (0.0, 0.0);
    for (t, u) in pts {
        let dt = t - mt;
        stt += dt * dt;
        stu += dt * (u - mu);
    }
    (stt > 0.0).then(|| stu / stt)
}

/// How clearly a change-point fit with squared error `sse` stands out of the history's
/// residual: `(C − E)/E` (`C`: the positions' squared spread about their mean, `E` = `sse`,
/// kept ≥ `1e-12·C`), 0 when the fit explains nothing; the weight of [`OnsetFingers::Weighted`].
fn fit_weight(h: &VecDeque<(i64, f64)>, sse: f64) -> f64 {
    let n = h.len() as f64;
    if n == 0.0 {
        return 0.0;
    }
    let mean = h.iter().map(|p| p.1).sum::<f64>() / n;
    let c: f64 = h.iter().map(|p| (p.1 - mean) * (p.1 - mean)).sum();
    let e = sse.max(1e-12 * c);
    if !(c.is_finite() && e.is_finite()) || e <= 0.0 {
        return 0.0;
    }
    ((c - e) / e).max(0.0)
}

/// [`OnsetFingers::ClearEarliest`]: the earliest change point among `fits` (change point,
/// fit weight) whose weight is at least `gate` × the largest (every one when no weight is
/// positive or finite). `fits` is not empty.
fn clear_earliest(fits: &[(i64, f64)], gate: f64) -> i64 {
    let top = fits.iter().map(|f| f.1).filter(|w| w.is_finite()).fold(0.0, f64::max);
    let floor = if top > 0.0 { gate * top } else { f64::NEG_INFINITY };
    fits.iter().filter(|f| f.1.is_nan() || f.1 >= floor).map(|f| f.0).min().unwrap_or(i64::MAX)
}

/// Tails of at most this many points are summed directly in [`change_point`].
const DIRECT_TAIL: usize = 32;

/// The change point of a still-then-moving position history: the start `t₀` of the soft-start
/// hinge `u = a + b·z(t − t₀)` (with `drift`, `+ g·t`: the ramp null; `z`: distance of a
/// unit-speed motion with a start of [`STARTS`] — all of them with `smooth`, else the linear
/// ones) with the least squared error, and that start; `t₀` over the history's sample
/// times (leaving 3 points on either side; at most 256 of them, evenly spaced). Run once per
/// slip decision, so it bounds that frame's latency.
///
/// Cost: each candidate's regression moments come from suffix sums for the points past the
/// soft start (O(1); a tail of at most [`DIRECT_TAIL`] points is summed directly) plus the
/// points inside it — one pass over the longest start's ≤ 0.4 s·rate points serves all of
/// them, its power sums recorded where each shorter one ends — and its squared error in closed
/// form (`Cuu − Czu²/Czz`, with the drift projected out first); the candidates within a
/// rounding margin of the least closed-form error are then re-scored with the direct two-pass
/// sums of [`change_point_direct`] and chosen by its rule, so the answer is the direct fit's
/// (tested to the candidate on random and simulated histories, both nulls, both start sets) at
/// O(256 · 0.4 s·rate) instead of O(256 · 7 · 2n). Both fingers' fits at 240 history points
/// (2.4 s at 100 Hz): ≈ 67 µs of a decision frame with every start, 47 µs with the linear
/// ones (`examples/latency.rs`).
fn change_point(h: &VecDeque<(i64, f64)>, drift: bool, set: OnsetStarts) -> Option<(i64, Start, f64)> {
    let (starts, ends) = start_set(set);
    let n = h.len();
    if n < 8 {
        return None;
    }
    let t0 = h[0].0;
    let ts: Vec<f64> = h.iter().map(|p| (p.0 - t0) as f64 * 1e-9).collect();
    // the screen's own axes: times (s) back from the newest point, so a short tail near the end
    // sums small numbers, and positions about their mean, so no offset cancels
    let t_end = h[n - 1].0;
    let te: Vec<f64> = h.iter().map(|p| (p.0 - t_end) as f64 * 1e-9).collect();
    let mean = h.iter().map(|p| p.1).sum::<f64>() / n as f64;
    let us: Vec<f64> = h.iter().map(|p| p.1 - mean).collect();
    let raw_scale: f64 = h.iter().map(|p| p.1 * p.1).sum();
    // suffix sums over points j.. of 1, t, t², u, t·u (index n: none)
    let mut suf = vec![[0.0f64; 5]; n + 1];
    for j in (0..n).rev() {
        let (t, u) = (te[j], us[j]);
        let s = suf[j + 1];
        suf[j] = [s[0] + 1.0, s[1] + t, s[2] + t * t, s[3] + u, s[4] + t * u];
    }
    let m = n as f64;
    let su = suf[0][3];
    let cuu = us.iter().map(|u| u * u).sum::<f64>() - su * su / m;
    // rounding margin: far above the closed form's error and the direct sums' own noise
    let margin = 1e-9 * cuu.abs() + 1e-13 * raw_scale;
    if cuu.is_nan() || cuu <= 1e3 * margin.max(f64::MIN_POSITIVE) {
        // flat to rounding: the candidates differ by noise alone; the direct rule decides
        return change_point_direct(&ts, h, drift, starts);
    }
    // the drift regressor t (ramp null): its centred moments
    let (st, stt, stu) = (suf[0][1], suf[0][2], suf[0][4]);
    let ctt = stt - st * st / m;
    let ctu = stu - st * su / m;
    // closed-form error of every candidate, in the direct rule's order
    let mut approx: Vec<(f64, usize, Start)> = Vec::with_capacity(starts.len() * candidates(n).len());
    for k in candidates(n) {
        let c = te[k];
        let mut j = k;
        while j < n && te[j] - c <= 0.0 {
            j += 1;
        }
        // inside the starts (0 < d < r): the power sums of d the start shapes' z-sums are made
        // of — Σdᵖ (p = 2, 3, 4, 6, 7, 8), Σdᵖ·u and Σdᵖ·t (p = 2, 3, 4) — over the points of
        // the longest start, recorded where each shorter one ends (one pass for every start)
        let mut soft = [(0usize, [0.0f64; 12]); START_ENDS_S.len()];
        let mut acc = [0.0f64; 12];
        for (slot, &r) in soft.iter_mut().zip(ends) {
            while j < n && te[j] - c < r {
                let d = te[j] - c;
                let d2 = d * d;
                let d3 = d2 * d;
                let d4 = d2 * d2;
                let (u, t) = (us[j], te[j]);
                for (a, v) in acc.iter_mut().zip([
                    d2,
                    d3,
                    d4,
                    d4 * d2,
                    d4 * d3,
                    d4 * d4,
                    d2 * u,
                    d3 * u,
                    d4 * u,
                    d2 * t,
                    d3 * t,
                    d4 * t,
                ]) {
                    *a += v;
                }
                j += 1;
            }
            *slot = (j, acc);
        }
        for &start in starts {
            let r = start.length_s();
            let (j, [p2, p3, p4, p6, p7, p8, pu2, pu3, pu4, pt2, pt3, pt4]) =
                soft[ends.iter().position(|&e| e == r).expect("a start ends at a listed length")];
            let (mut sz, mut szz, mut szu, mut szt) = match start {
                _ if r == 0.0 => (0.0, 0.0, 0.0, 0.0),
                // z = d²/2r
                Start::Linear(_) => (p2 / (2.0 * r), p4 / (4.0 * r * r), pu2 / (2.0 * r), pt2 / (2.0 * r)),
                // z = d³/r² − d⁴/2r³
                Start::Smooth(_) => {
                    let (a, b) = (1.0 / (r * r), 1.0 / (2.0 * r * r * r));
                    (a * p3 - b * p4, a * a * p6 - 2.0 * a * b * p7 + b * b * p8, a * pu3 - b * pu4, a * pt3 - b * pt4)
                }
                // z = d³/3r²
                Start::Cubic(_) => {
                    let a = 1.0 / (3.0 * r * r);
                    (a * p3, a * a * p6, a * pu3, a * pt3)
                }
            };
            // past the start z = t − e (e = c + the start's lag: r/2 linear and smooth, 2r/3
            // cubic): a short tail directly, a long one (whose z has the spread to absorb the
            // cancellation) from the suffix sums
            let e = c + start.lag_s();
            if n - j <= DIRECT_TAIL {
                for q in j..n {
                    let z = te[q] - e;
                    sz += z;
                    szz += z * z;
                    szu += z * us[q];
                    szt += z * te[q];
                }
            } else {
                let [c0, c1, c2, cu0, cu1] = suf[j];
                sz += c1 - e * c0;
                szz += c2 - 2.0 * e * c1 + e * e * c0;
                szu += cu1 - e * cu0;
                szt += c2 - e * c1;
            }
            let mut var = szz - sz * sz / m;
            let mut czu = szu - sz * su / m;
            let mut res = cuu;
            if drift {
                // ramp null: project t out of z and u first
                if ctt <= 0.0 {
                    approx.push((f64::INFINITY, k, start));
                    continue;
                }
                let czt = szt - sz * st / m;
                var -= czt * czt / ctt;
                czu -= czt * ctu / ctt;
                res -= ctu * ctu / ctt;
            }
            let sse = if var > DRIFT_VAR_FLOOR * szz.abs().max(f64::MIN_POSITIVE) || (!drift && var > 0.0) {
                res - czu * czu / var
            } else {
                f64::INFINITY
            };
            approx.push((sse, k, start));
        }
    }
    let least = approx.iter().map(|a| a.0).fold(f64::INFINITY, f64::min);
    if !least.is_finite() {
        return change_point_direct(&ts, h, drift, starts);
    }
    let mut best: Option<(f64, usize, Start)> = None;
    for &(a, k, start) in &approx {
        if a > least + margin {
            continue;
        }
        if let Some(sse) = direct_sse(&ts, h, ts[k], start, drift) {
            if best.is_none_or(|(e, _, _)| sse < e) {
                best = Some((sse, k, start));
            }
        }
    }
    best.map(|(sse, k, start)| (h[k].0, start, sse))
}

/// With the ramp null, a candidate whose soft-start regressor is (to this fraction of its
/// spread) a straight line in `t` has no change point: it is the drift itself.
const DRIFT_VAR_FLOOR: f64 = 1e-9;

/// The change-point candidates of a history of `n` ≥ 8 points: indices leaving 3 points on
/// either side, at most 256 of them, evenly spaced.
fn candidates(n: usize) -> std::iter::StepBy<std::ops::Range<usize>> {
    (3..n - 3).step_by((n - 6).div_ceil(256).max(1))
}

/// The squared error of the hinge `u = a + b·z(t − c)` (with `drift`: `u = a + g·t +
/// b·z(t − c)`, the ramp null) fitted by direct two-pass sums over every point (`ts`: the
/// history's times in s); `None` when `z` has no spread (with `drift`: none beside `t`'s).
fn direct_sse(ts: &[f64], h: &VecDeque<(i64, f64)>, c: f64, start: Start, drift: bool) -> Option<f64> {
    let m = h.len() as f64;
    let (mut sz, mut su, mut st) = (0.0, 0.0, 0.0);
    for (&t, p) in ts.iter().zip(h) {
        sz += start.z(t, c);
        su += p.1;
        st += t;
    }
    let (mz, mu, mt) = (sz / m, su / m, st / m);
    let (mut szz, mut szu, mut stt, mut stu, mut szt, mut raw_zz) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (&t, p) in ts.iter().zip(h) {
        let z0 = start.z(t, c);
        let (z, u, tt) = (z0 - mz, p.1 - mu, t - mt);
        szz += z * z;
        szu += z * u;
        stt += tt * tt;
        stu += tt * u;
        szt += z * tt;
        raw_zz += z0 * z0;
    }
    let (b, g) = if drift {
        if stt <= 0.0 {
            return None;
        }
        let var = szz - szt * szt / stt;
        if var.is_nan() || var <= DRIFT_VAR_FLOOR * raw_zz.max(f64::MIN_POSITIVE) {
            return None;
        }
        let b = (szu - szt * stu / stt) / var;
        (b, (stu - b * szt) / stt)
    } else {
        if szz <= 0.0 {
            return None;
        }
        (szu / szz, 0.0)
    };
    Some(ts.iter().zip(h).map(|(&t, p)| (p.1 - mu - b * (start.z(t, c) - mz) - g * (t - mt)).powi(2)).sum())
}

/// [`change_point`] by direct sums for every candidate: O(256 · 4 · 2n). The reference the
/// screened search reproduces, and its fallback when the history is flat to rounding.
fn change_point_direct(
    ts: &[f64],
    h: &VecDeque<(i64, f64)>,
    drift: bool,
    starts: &[Start],
) -> Option<(i64, Start, f64)> {
    let mut best: Option<(f64, usize, Start)> = None;
    for k in candidates(h.len()) {
        for &start in starts {
            if let Some(sse) = direct_sse(ts, h, ts[k], start, drift) {
                if best.is_none_or(|(e, _, _)| sse < e) {
                    best = Some((sse, k, start));
                }
            }
        }
    }
    best.map(|(sse, k, start)| (h[k].0, start, sse))
}

/// A start of the motion the change-point fit tries: its speed rises from 0 to full over `r`
/// seconds linearly, smoothly (`3x² − 2x³`) or as `x²` (cubic distance); `r = 0` is a sudden
/// start.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Start {
    /// `z = d²/2r` for `0 < d < r`.
    Linear(f64),
    /// `z = d³/r² − d⁴/2r³` for `0 < d < r`.
    Smooth(f64),
    /// `z = d³/3r²` for `0 < d < r`.
    Cubic(f64),
}

impl Start {
    const fn length_s(self) -> f64 {
        match self {
            Start::Linear(r) | Start::Smooth(r) | Start::Cubic(r) => r,
        }
    }

    /// How far behind a sudden start at `c` the motion is past the start (s): `z = d − lag`
    /// for `d ≥ r` (`r/2` linear and smooth, `2r/3` cubic).
    fn lag_s(self) -> f64 {
        match self {
            Start::Linear(r) | Start::Smooth(r) => r / 2.0,
            Start::Cubic(r) => 2.0 * r / 3.0,
        }
    }

    /// The progress `z(t − c)` of a unit-speed motion with this start: `d − lag` past it.
    fn z(self, t: f64, c: f64) -> f64 {
        let d = t - c;
        let r = self.length_s();
        if d <= 0.0 {
            0.0
        } else if d < r {
            match self {
                Start::Linear(_) => d * d / (2.0 * r),
                Start::Smooth(_) => d * d * d / (r * r) - d * d * d * d / (2.0 * r * r * r),
                Start::Cubic(_) => d * d * d / (3.0 * r * r),
            }
        } else {
            d - self.lag_s()
        }
    }
}

/// The starts the change-point fit tries (in the direct rule's order): sudden, linear over
/// 0.1–0.3 s, smooth over 0.2–0.4 s, cubic over 0.2–0.4 s. The sets of [`OnsetStarts`] are
/// the linear ones and either the smooth or the cubic ones ([`start_set`]).
const STARTS: [Start; 10] = [
    Start::Linear(0.0),
    Start::Linear(0.1),
    Start::Linear(0.2),
    Start::Linear(0.3),
    Start::Smooth(0.2),
    Start::Smooth(0.3),
    Start::Smooth(0.4),
    Start::Cubic(0.2),
    Start::Cubic(0.3),
    Start::Cubic(0.4),
];

/// [`OnsetStarts::LinearCubic`]'s starts, in the direct rule's order.
const LINEAR_CUBIC: [Start; 7] = [STARTS[0], STARTS[1], STARTS[2], STARTS[3], STARTS[7], STARTS[8], STARTS[9]];

/// The starts of a set and the lengths the screen records its sums at (ascending).
fn start_set(set: OnsetStarts) -> (&'static [Start], &'static [f64]) {
    match set {
        OnsetStarts::Linear => (&STARTS[..4], &START_ENDS_S[..4]),
        OnsetStarts::LinearSmooth => (&STARTS[..7], &START_ENDS_S[..]),
        OnsetStarts::LinearCubic => (&LINEAR_CUBIC[..], &START_ENDS_S[..]),
    }
}

/// Every start's length, ascending (the screen records its sums where each one ends).
const START_ENDS_S: [f64; 5] = [0.0, 0.1, 0.2, 0.3, 0.4];
const _: () = {
    let mut i = 1;
    while i < START_ENDS_S.len() {
        assert!(START_ENDS_S[i - 1] < START_ENDS_S[i], "START_ENDS_S must ascend");
        i += 1;
    }
    let mut k = 0;
    while k < STARTS.len() {
        let r = STARTS[k].length_s();
        let mut found = false;
        let mut i = 0;
        while i < START_ENDS_S.len() {
            found |= START_ENDS_S[i] == r;
            i += 1;
        }
        assert!(found, "every start's length is in START_ENDS_S");
        k += 1;
    }
};

/// The linear start's progress (the tests' histories).
#[cfg(test)]
fn soft_z(t: f64, c: f64, r: f64) -> f64 {
    Start::Linear(r).z(t, c)
}

#[cfg(test)]
const SOFT_STARTS_S: [f64; 4] = [0.0, 0.1, 0.2, 0.3];

impl Stage for Slip {
    type In = TrackPoint;
    type Out = SlipEvent;
    type Error = Error;

    /// A track point.
    ///
    /// With `evidence = "pattern"` (the default) the `displacement` rule reads pattern points
    /// only ([`Slip::push_input`] with [`SlipInput::Pattern`], from
    /// [`crate::slip_pattern::SlipPattern`]). Track points of `first` / `second` that arrive
    /// **before any pattern point** of those sensors (since construction or the last reset) are
    /// an error ([`Error::BadInput`] naming the setting): a pipeline that feeds only tracks
    /// (`tracks.then(slip)`) would otherwise never decide anything. Such a pipeline sets
    /// `evidence = "track"` (or `"both"`); a runner that feeds both paths hands each frame's
    /// pattern point over before the track points it makes (as [`crate::sim_grasp::slip_inputs`]
    /// does), and then the track points are ignored.
    fn push(&mut self, p: TrackPoint, out: &mut Vec<SlipEvent>) -> Result<()> {
        self.push_input(SlipInput::Track(p), out)
    }

    /// Runs the decision of the last time step (when its inputs were not yet known to be
    /// complete), then [`Stage::reset`].
    fn finish(&mut self, out: &mut Vec<SlipEvent>) -> Result<()> {
        if let Some(p) = self.pending.take() {
            self.decide(p, out);
        }
        self.reset();
        Ok(())
    }

    fn reset(&mut self) {
        self.fingers = Default::default();
        self.state = SlipClass::Stable;
        self.candidate = None;
        self.pattern_seen = false;
        self.pending = None;
    }

    /// `min_duration_s` (a candidate must persist that long); reading track points, one more
    /// input frame (a step's decision waits for the next time: "Same-time inputs" in
    /// [`Slip::push_input`]).
    fn delay(&self) -> Delay {
        let extra = if self.cfg.reads_tracks() { Delay::frames(1) } else { Delay::ZERO };
        Delay::nanos(self.min_duration_ns) + extra
    }
}

impl Slip {
    /// Push one input of either path (a track point — what [`Stage::push`] takes — or a
    /// raw-frame pattern point); events as [`Stage::push`].
    ///
    /// # Same-time inputs
    /// The decision for a time step runs once **every input of that step is in**, so the order
    /// of the inputs that share a timestamp (the two fingers' points of one frame, and a
    /// frame's pattern point and track points) does not change any event: a step is complete
    /// when an input of a later time comes, when both fingers' pattern points of it are in and
    /// the configuration reads no track points (the default: `slip_pattern` gives exactly one
    /// point per sensor and frame, so the default scene decides on the step's last input, with
    /// no added delay), or at [`Stage::finish`]. With track evidence (several track points of
    /// one sensor may share a time) the decision waits for the next input's time: one input
    /// step later, [`Stage::delay`]'s one frame.
    pub fn push_input(&mut self, input: SlipInput, out: &mut Vec<SlipEvent>) -> Result<()> {
        let time = input.time();
        if let Some(p) = self.pending.filter(|&p| time > p) {
            self.pending = None;
            self.decide(p, out);
        }
        if self.take(input)? {
            let p = self.pending.map_or(time, |p| p.max(time));
            self.pending = Some(p);
            let have = |i: usize| self.fingers[i].paths[1].last_time == Some(p);
            if !self.cfg.reads_tracks() && have(0) && have(1) {
                self.pending = None;
                self.decide(p, out);
            }
        }
        Ok(())
    }

    /// The decision step for time `time`, every input of it in.
    fn decide(&mut self, time: Timestamp, out: &mut Vec<SlipEvent>) {
        let (class, l, r) = self.candidate_now();
        if class == self.state {
            self.candidate = None;
            return;
        }
        let (since, evidence) = match self.candidate {
            Some((c, since, evidence)) if c == class => (since, evidence),
            _ => {
                // the regression windows that show the new motion start here
                let evidence = self
                    .fingers
                    .iter()
                    .filter_map(|f| f.points.front().map(|q| Timestamp(q.0)))
                    .min()
                    .map_or(time, |e| e.min(time));
                let evidence = if class.is_slip() { evidence } else { time };
                self.candidate = Some((class, time, evidence));
                (time, evidence)
            }
        };
        if time - since >= self.min_duration_ns {
            let onset = match (class.is_slip(), self.cfg.method) {
                (true, SlipMethod::Displacement) => self.fitted_onset(since),
                _ => evidence,
            };
            out.push(SlipEvent {
                time,
                onset,
                first_seen: since,
                class,
                previous: self.state,
                common_mm_s: l,
                differential_mm_s: r,
            });
            self.state = class;
            self.candidate = None;
        }
    }

    /// Take one input into the fingers' histories; whether it was one the rule reads.
    fn take(&mut self, input: SlipInput) -> Result<bool> {
        // (source 0 = track, 1 = pattern)
        let (sensor, time, start, seq, usable, xy, onset_xy, gated, track, src) = match &input {
            SlipInput::Track(p) => (
                &p.sensor,
                p.time,
                p.start,
                p.seq,
                p.state == ContactState::Contact,
                [p.x_mm, p.y_mm],
                [p.x_mm, p.y_mm],
                p.gated,
                p.track,
                0,
            ),
            SlipInput::Pattern(p) => (
                &p.sensor,
                p.time,
                p.start,
                p.seq,
                p.contact,
                [p.x_mm, p.y_mm],
                [p.onset_x_mm, p.onset_y_mm],
                false,
                None,
                1,
            ),
        };
        let i = if *sensor == self.first {
            0
        } else if *sensor == self.second {
            1
        } else {
            return Ok(false);
        };
        let displacement = self.cfg.method == SlipMethod::Displacement;
        if src == 1 {
            self.pattern_seen = true;
        } else if !self.cfg.reads_tracks() && !self.pattern_seen {
            return Err(Error::BadInput {
                stage: STAGE,
                sensor: sensor.to_string(),
                seq,
                reason: format!(
                    "a track point, but `evidence = \"{}\"` reads only raw-frame pattern points \
                     (`SlipInput::Pattern` from `slip_pattern`) and none has come: set `evidence = \"track\"` \
                     (or \"both\") to decide from tracks, or push the pattern points first",
                    self.cfg.evidence.name()
                ),
            });
        }
        let wanted = if src == 0 { self.cfg.reads_tracks() } else { self.cfg.reads_frames() };
        if !wanted {
            return Ok(false);
        }
        let up = self.up[i];
        let f = &mut self.fingers[i];
        if let Some(t) = f.paths[src].last_time {
            if time < t {
                return Err(Error::BadInput {
                    stage: STAGE,
                    sensor: sensor.to_string(),
                    seq,
                    reason: format!("time {time:?} is before the previous point's {t:?}"),
                });
            }
        }
        f.paths[src].last_time = Some(time);
        let usable = usable && xy[0].is_finite() && xy[1].is_finite();
        let dropout = f.paths[src].last_usable.is_some_and(|t| time.as_nanos() - t > self.gap_ns);
        if dropout || (!usable && !displacement) {
            if src == 0 {
                f.clear_track();
            } else {
                f.paths[1].clear();
            }
        }
        if usable && !gated {
            let now = time.as_nanos();
            if displacement {
                let path = &mut f.paths[src];
                path.last_usable = Some(now);
                if now - *path.contact_since.get_or_insert(now) >= self.settle_ns {
                    // the point describes the middle of the averaging span
                    let mid = start.as_nanos().min(now) / 2 + now / 2;
                    let mid = mid.max(path.history.back().map_or(i64::MIN, |q| q.0));
                    let u = xy[0] * up[0] + xy[1] * up[1];
                    path.history.push_back((mid, u));
                    // the onset fit's position: a frame without one (`fit`: the model fit found no
                    // contact there) leaves a gap in its history only
                    let v = onset_xy[0] * up[0] + onset_xy[1] * up[1];
                    if v.is_finite() {
                        path.onset_history.push_back((mid, v));
                    }
                    while path.history.front().is_some_and(|q| mid - q.0 > self.history_ns) {
                        path.history.pop_front();
                    }
                    while path.onset_history.front().is_some_and(|q| mid - q.0 > self.history_ns) {
                        path.onset_history.pop_front();
                    }
                    path.moved = displacement_of(&path.history, self.window_ns, self.history_ns, self.cfg.distance_mm);
                }
            } else {
                f.paths[0].last_usable = Some(now);
                if f.track != track {
                    f.clear_track();
                    f.track = track;
                    f.paths[0].last_usable = Some(now);
                }
                f.points.push_back((now, xy[0], xy[1]));
                while f.points.front().is_some_and(|q| now - q.0 > self.velocity_window_ns) {
                    f.points.pop_front();
                }
                let span = now - f.points.front().map_or(now, |q| q.0);
                f.velocity = if f.points.len() >= self.cfg.min_points && 2 * span >= self.velocity_window_ns {
                    regression(&f.points)
                } else {
                    None
                };
            }
        }
        Ok(true)
    }

    /// Push every input in order, then [`Stage::finish`]: the events.
    pub fn run_inputs(&mut self, inputs: impl IntoIterator<Item = SlipInput>) -> Result<Vec<SlipEvent>> {
        let mut out = Vec::new();
        for i in inputs {
            self.push_input(i, &mut out)?;
        }
        self.finish(&mut out)?;
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A still-then-moving history: `n` points from `t0_ns` every `dt_ns` (± `jitter` of it),
    /// position `offset` + noise, then moving at `speed` after `onset` (s) with a soft start `r`.
    #[allow(clippy::too_many_arguments)]
    fn hinge_history(
        n: usize,
        t0_ns: i64,
        dt_ns: i64,
        jitter: &[f64],
        offset: f64,
        noise: &[f64],
        onset: f64,
        speed: f64,
        r: f64,
    ) -> VecDeque<(i64, f64)> {
        let mut t = t0_ns;
        (0..n)
            .map(|i| {
                t += dt_ns + (dt_ns as f64 * 0.3 * jitter[i % jitter.len()]) as i64;
                let s = (t - t0_ns) as f64 * 1e-9;
                (t, offset + noise[i % noise.len()] + speed * soft_z(s, onset, r))
            })
            .collect()
    }

    const SETS: [OnsetStarts; 3] = [OnsetStarts::Linear, OnsetStarts::LinearSmooth, OnsetStarts::LinearCubic];

    fn direct(h: &VecDeque<(i64, f64)>, drift: bool, set: OnsetStarts) -> Option<(i64, Start, f64)> {
        if h.len() < 8 {
            return None;
        }
        let ts: Vec<f64> = h.iter().map(|p| (p.0 - h[0].0) as f64 * 1e-9).collect();
        change_point_direct(&ts, h, drift, start_set(set).0)
    }

    /// `h` with a drift of `rate` per second added (a ramp before and after the onset).
    fn drifting(h: &VecDeque<(i64, f64)>, rate: f64) -> VecDeque<(i64, f64)> {
        h.iter().map(|&(t, u)| (t, u + rate * (t - h[0].0) as f64 * 1e-9)).collect()
    }

    #[test]
    fn change_point_dates_a_clean_hinge() {
        // 1.5 s at 100 Hz, still then 10 mm/s from 0.8 s, sudden and soft starts
        for r in SOFT_STARTS_S {
            let h = hinge_history(150, 0, 10_000_000, &[0.0], 3.0, &[0.0], 0.8, 10.0, r);
            for (drift, set) in SETS.into_iter().flat_map(|s| [(false, s), (true, s)]) {
                let t = change_point(&h, drift, set).expect("a hinge").0;
                assert!((t as f64 * 1e-9 - 0.8).abs() <= 0.0101, "r = {r}, drift {drift}, {set:?}: {t}");
                assert_eq!(Some(t), direct(&h, drift, set).map(|x| x.0));
            }
        }
        // a smooth start: the smooth set dates it and names it
        let h: VecDeque<(i64, f64)> =
            (0..150).map(|i| (i * 10_000_000, 3.0 + 10.0 * Start::Smooth(0.3).z(i as f64 * 0.01, 0.8))).collect();
        for drift in [false, true] {
            let (t, start, _) = change_point(&h, drift, OnsetStarts::LinearSmooth).expect("a hinge");
            assert!((t as f64 * 1e-9 - 0.8).abs() <= 0.0101 && start == Start::Smooth(0.3), "{t} {start:?}");
            assert_eq!(
                change_point(&h, drift, OnsetStarts::LinearSmooth),
                direct(&h, drift, OnsetStarts::LinearSmooth)
            );
        }
    }

    /// Without noise, the default set (sudden, linear, cubic starts) dates a sudden, a linear
    /// and a cubic start (distance growing as the cube of the time) at their known `t₀`: on a
    /// sample, to the sample with the start named and no residual; between samples (the
    /// candidates are the samples), within 40 ms — a start between samples is fitted by a
    /// neighbouring `(t₀, r)` with about the same intercept `t₀ + lag`. A constant history
    /// has no onset (its fit's weight is 0).
    #[test]
    fn the_default_starts_date_step_linear_and_cubic_starts() {
        for (start, name) in [
            (Start::Linear(0.0), "step"),
            (Start::Linear(0.2), "linear"),
            (Start::Cubic(0.3), "cubic"),
            (Start::Cubic(0.4), "cubic"),
        ] {
            for onset in [0.8, 1.234] {
                let h: VecDeque<(i64, f64)> =
                    (0..240).map(|i| (i * 10_000_000, -2.0 + 7.0 * start.z(i as f64 * 0.01, onset))).collect();
                let (t, got, sse) = change_point(&h, false, OnsetStarts::LinearCubic).expect("a hinge");
                let tol = if onset == 0.8 { 0.0101 } else { 0.04 };
                assert!((t as f64 * 1e-9 - onset).abs() <= tol, "{name}: {t} for {onset}");
                if onset == 0.8 {
                    // on a sample: the exact start, no residual
                    assert_eq!(got, start, "{name}");
                    assert!(sse < 1e-12, "{name}: {sse}");
                }
                assert_eq!(
                    change_point(&h, false, OnsetStarts::LinearCubic),
                    direct(&h, false, OnsetStarts::LinearCubic)
                );
            }
        }
        // constant: no onset decided from it (every candidate fits it exactly, and its weight is 0)
        let flat: VecDeque<(i64, f64)> = (0..240).map(|i| (i * 10_000_000, 1.5)).collect();
        if let Some((_, _, sse)) = change_point(&flat, false, OnsetStarts::LinearCubic) {
            assert_eq!(fit_weight(&flat, sse), 0.0);
        }
        // the finger weight: a clean fit outweighs a noisy one
        let noise: Vec<f64> = (0..97).map(|i| ((i * 37 % 97) as f64 / 97.0 - 0.5) * 0.5).collect();
        let clean = hinge_history(240, 0, 10_000_000, &[0.0], 0.0, &noise[..1], 1.0, 5.0, 0.1);
        let noisy = hinge_history(240, 0, 10_000_000, &[0.0], 0.0, &noise, 1.0, 5.0, 0.1);
        let w = |h: &VecDeque<(i64, f64)>| fit_weight(h, change_point(h, false, OnsetStarts::LinearCubic).unwrap().2);
        assert!(w(&clean) > 100.0 * w(&noisy) && w(&noisy) > 0.0, "{} {}", w(&clean), w(&noisy));
    }

    /// A ramp before the onset (a grip force still changing moves the point slowly): the
    /// still model puts the onset early to absorb it, the ramp null dates it.
    #[test]
    fn the_ramp_null_dates_a_hinge_on_a_ramp() {
        let noise: Vec<f64> = (0..97).map(|i| ((i * 37 % 97) as f64 / 97.0 - 0.5) * 0.02).collect();
        for r in SOFT_STARTS_S {
            let h = drifting(&hinge_history(200, 0, 10_000_000, &[0.0], 3.0, &noise, 1.5, 4.0, r), 0.6);
            let ramp = change_point(&h, true, OnsetStarts::Linear).expect("a hinge").0 as f64 * 1e-9;
            let still = change_point(&h, false, OnsetStarts::Linear).expect("a hinge").0 as f64 * 1e-9;
            assert!((ramp - 1.5).abs() <= 0.0201, "r = {r}: ramp null {ramp}");
            assert!(still < 1.5 - 0.05, "r = {r}: still model {still}");
            assert_eq!(change_point(&h, true, OnsetStarts::Linear), direct(&h, true, OnsetStarts::Linear));
        }
    }

    #[test]
    fn change_point_of_flat_and_long_histories_is_the_direct_fit() {
        for (drift, smooth) in SETS.into_iter().flat_map(|s| [(false, s), (true, s)]) {
            // exactly flat: the candidates differ by rounding alone; the direct rule decides
            let flat: VecDeque<(i64, f64)> = (0..40).map(|i| (i * 10_000_000, 0.1)).collect();
            assert_eq!(change_point(&flat, drift, smooth), direct(&flat, drift, smooth));
            // 60 s at 1 kHz (the longest history) with a late onset: same candidate
            let noise: Vec<f64> = (0..97).map(|i| ((i * 37 % 97) as f64 / 97.0 - 0.5) * 0.01).collect();
            let h = hinge_history(60_000, 5_000_000_000, 1_000_000, &[0.0], 12.0, &noise, 59.2, 5.0, 0.1);
            assert_eq!(change_point(&h, drift, smooth), direct(&h, drift, smooth));
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]
        /// The screened search picks exactly the candidate the direct two-pass fit picks, with
        /// either null.
        #[test]
        fn change_point_is_the_direct_fit(
            n in 8usize..400,
            dt_ns in proptest::sample::select(vec![1_000_000i64, 3_000_000, 10_000_000, 33_333_333]),
            jitter in proptest::collection::vec(-1.0f64..1.0, 1..8),
            offset in proptest::sample::select(vec![0.0, -4.2, 13.0, 1e4]),
            noise_scale in proptest::sample::select(vec![0.0, 1e-6, 0.01, 0.3]),
            noise in proptest::collection::vec(-1.0f64..1.0, 1..50),
            onset_frac in 0.0f64..1.2,
            speed in -30.0f64..30.0,
            r in 0.0f64..0.4,
            drift in proptest::prelude::any::<bool>(),
            smooth in proptest::sample::select(SETS.to_vec()),
            ramp in proptest::sample::select(vec![0.0, 0.5, -2.0]),
        ) {
            let noise: Vec<f64> = noise.iter().map(|x| x * noise_scale).collect();
            let span = n as f64 * dt_ns as f64 * 1e-9;
            let h = hinge_history(n, 1_700_000_000_000_000_000, dt_ns, &jitter, offset, &noise, onset_frac * span, speed, r);
            let h = drifting(&h, ramp);
            proptest::prop_assert_eq!(change_point(&h, drift, smooth), direct(&h, drift, smooth));
        }
    }
    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(300))]
        /// The one-pass ladder gives the separate per-window fits' displacement bit for bit:
        /// any history (repeated times, gaps, offsets far from the motion), any ladder.
        #[test]
        fn displacement_is_the_per_window_fit(
            n in 0usize..300,
            steps in proptest::collection::vec(0i64..40_000_000, 1..20),
            values in proptest::collection::vec(-1.0f64..1.0, 1..40),
            offset in proptest::sample::select(vec![0.0, -3.7, 250.0, 1e6]),
            slope in -40.0f64..40.0,
            window_ns in proptest::sample::select(vec![1_000_000i64, 30_000_000, 300_000_000, 1_000_000_000]),
            ladder in 0u32..6,
            distance_mm in 0.05f64..5.0,
            regular in proptest::prelude::any::<bool>(),
        ) {
            // regular: 100 Hz, so points fall exactly on the windows' ends
            let mut t = 1_700_000_000_000_000_000i64;
            let h: VecDeque<(i64, f64)> = (0..n)
                .map(|i| {
                    t += if regular { 10_000_000 } else { steps[i % steps.len()] };
                    (t, offset + slope * (i as f64) * 0.01 + values[i % values.len()])
                })
                .collect();
            let history_ns = window_ns << ladder;
            let got = displacement_of(&h, window_ns, history_ns, distance_mm);
            let want = displacement_reference(&h, window_ns, history_ns, distance_mm);
            proptest::prop_assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits));
        }
    }

    /// The ladder's fits on a history that moves only lately: the longest window does not
    /// win, a middle one does (the reference and the one-pass version agree on which).
    #[test]
    fn displacement_takes_the_largest_window_displacement() {
        // 2.4 s at 100 Hz: still for 2.1 s, then 0.3 s at 10 mm/s
        let h: VecDeque<(i64, f64)> =
            (0..240).map(|i| (i as i64 * 10_000_000, if i < 210 { 0.0 } else { (i - 210) as f64 * 0.1 })).collect();
        let got = displacement_of(&h, 300_000_000, 2_400_000_000, 5.0).unwrap();
        assert_eq!(got.to_bits(), displacement_reference(&h, 300_000_000, 2_400_000_000, 5.0).unwrap().to_bits());
        // the 0.3 s window sees the motion alone (3.0 mm of 5), the longer ones dilute it (2.9, 1.8, 1.0 mm)
        assert!(got > 0.5 && got < 0.7, "{got}");
        // a history shorter than half the first window has no displacement
        let short: VecDeque<(i64, f64)> = (0..10).map(|i| (i as i64 * 10_000_000, i as f64)).collect();
        assert_eq!(displacement_of(&short, 300_000_000, 2_400_000_000, 1.0), None);
    }

    use gradtac_stream::StageExt;

    /// Track points of `ff` and `th` at 100 Hz; each finger's position from a function of t (s).
    fn points(n: usize, ff: impl Fn(f64) -> [f64; 2], th: impl Fn(f64) -> [f64; 2]) -> Vec<TrackPoint> {
        let mut out = Vec::new();
        for k in 0..n {
            let t = Timestamp::at_rate(k as u64, 100.0);
            for (name, p) in [("th", th(t.as_secs_f64())), ("ff", ff(t.as_secs_f64()))] {
                out.push(TrackPoint {
                    sensor: name.into(),
                    time: t,
                    start: t,
                    seq: k as u64,
                    state: ContactState::Contact,
                    no_contact: None,
                    track: Some(0),
                    x_mm: p[0],
                    y_mm: p[1],
                    area_mm2: 10.0,
                    orientation_rad: 0.0,
                    peak: 5.0,
                    velocity_mm_s: None,
                    gated: false,
                    fit: None,
                });
            }
        }
        out
    }

    /// Moves by `v` mm/s along y after 0.5 s.
    fn ramp(v: f64) -> impl Fn(f64) -> [f64; 2] + Copy {
        move |t| [0.0, v * (t - 0.5).max(0.0)]
    }

    /// The displacement rule on the track path.
    fn track() -> SlipConfig {
        SlipConfig { evidence: SlipEvidence::Track, ..Default::default() }
    }

    /// The previous rule (the baseline) with its previous persistence.
    fn velocity() -> SlipConfig {
        SlipConfig { method: SlipMethod::Velocity, min_duration_s: 0.08, ..Default::default() }
    }

    const CASES: [(f64, f64, SlipClass); 4] = [
        (10.0, -10.0, SlipClass::LongitudinalUp),
        (-10.0, 10.0, SlipClass::LongitudinalDown),
        (-10.0, -10.0, SlipClass::RotationalCw),
        (10.0, 10.0, SlipClass::RotationalCcw),
    ];

    #[test]
    fn displacement_classes_and_onset_from_synthetic_tracks() {
        for (ff_v, th_v, want) in CASES {
            // onset_lead 0: the change point itself
            let cfg = SlipConfig { onset_lead_s: 0.0, ..track() };
            let ev = Slip::try_new(&cfg).unwrap().run_all(points(150, ramp(ff_v), ramp(th_v))).unwrap();
            assert_eq!(ev.len(), 1, "{want:?}: {ev:?}");
            assert_eq!((ev[0].class, ev[0].previous), (want, SlipClass::Stable));
            let onset = ev[0].onset.as_secs_f64();
            assert!((onset - 0.5).abs() <= 0.011, "{want:?}: onset {onset}");
            assert!(ev[0].time - ev[0].first_seen >= 100_000_000);
            // the default lead moves the onset by itself (earlier when positive)
            let ev2 = Slip::try_new(&track()).unwrap().run_all(points(150, ramp(ff_v), ramp(th_v))).unwrap();
            let lead = (SlipConfig::default().onset_lead_s * 1e9).round() as i64;
            assert_eq!(ev2[0].onset.0, (ev[0].onset.0 - lead).min(ev2[0].first_seen.0));
            // every onset setting dates this sudden start to the frame, and none changes the decision
            for (onset_model, onset_fingers, onset_starts) in [
                (OnsetModel::RampHinge, OnsetFingers::Mean, OnsetStarts::LinearSmooth),
                (OnsetModel::Hinge, OnsetFingers::Mean, OnsetStarts::LinearSmooth),
                (OnsetModel::RampHinge, OnsetFingers::Weighted, OnsetStarts::LinearCubic),
                (OnsetModel::Hinge, OnsetFingers::Earliest, OnsetStarts::Linear),
                (OnsetModel::RampHinge, OnsetFingers::Earliest, OnsetStarts::Linear),
                (OnsetModel::RampHinge, OnsetFingers::ClearEarliest, OnsetStarts::LinearCubic),
                (OnsetModel::Hinge, OnsetFingers::ClearEarliest, OnsetStarts::Linear),
            ] {
                let c = SlipConfig { onset_model, onset_fingers, onset_starts, ..cfg.clone() };
                let e = Slip::try_new(&c).unwrap().run_all(points(150, ramp(ff_v), ramp(th_v))).unwrap();
                assert_eq!((e.len(), e[0].class, e[0].time), (1, want, ev[0].time), "{c:?}");
                assert!((e[0].onset.as_secs_f64() - 0.5).abs() <= 0.011, "{c:?}: {:?}", e[0].onset);
            }
        }
    }

    #[test]
    fn a_slip_that_starts_on_one_finger_is_dated_at_that_finger_by_clear_earliest() {
        // ff starts at 0.5 s, th 0.1 s later: the truth is the first finger's start
        let late = |v: f64| move |t: f64| [0.0, v * (t - 0.6).max(0.0)];
        let onset = |onset_fingers, onset_finger_gate| {
            let cfg = SlipConfig { onset_fingers, onset_finger_gate, onset_lead_s: 0.0, ..track() };
            let ev = Slip::try_new(&cfg).unwrap().run_all(points(170, ramp(10.0), late(-10.0))).unwrap();
            assert_eq!(ev[0].class, SlipClass::LongitudinalUp, "{cfg:?}");
            ev[0].onset.as_secs_f64()
        };
        let first = onset(OnsetFingers::ClearEarliest, 0.35);
        assert!((first - 0.5).abs() <= 0.011, "clear_earliest {first}");
        assert!((onset(OnsetFingers::Earliest, 0.35) - first).abs() < 1e-9);
        // gate 1: the clearer finger alone (either start); the mean dates between the two
        let clearest = onset(OnsetFingers::ClearEarliest, 1.0);
        assert!((clearest - 0.5).abs() <= 0.011 || (clearest - 0.6).abs() <= 0.011, "gate 1 {clearest}");
        let mean = onset(OnsetFingers::Mean, 0.35);
        assert!((mean - 0.55).abs() <= 0.011, "mean {mean}");
    }

    #[test]
    fn clear_earliest_gates_unclear_fits() {
        // (change point ns, fit weight)
        let fits = [(100, 1.0), (200, 10.0)];
        assert_eq!(clear_earliest(&fits, 0.0), 100);
        assert_eq!(clear_earliest(&fits, 0.1), 100);
        assert_eq!(clear_earliest(&fits, 0.35), 200);
        assert_eq!(clear_earliest(&fits, 1.0), 200);
        // no clear finger at all: the earliest
        assert_eq!(clear_earliest(&[(300, 0.0), (200, 0.0)], 0.5), 200);
        assert_eq!(clear_earliest(&[(300, f64::NAN), (200, 0.0)], 0.5), 200);
        assert_eq!(clear_earliest(&[(300, f64::INFINITY), (200, 1.0)], 0.5), 200);
        assert_eq!(clear_earliest(&[(300, 2.0)], 1.0), 300);
        // the gate is validated
        for gate in [-0.1, 1.5, f64::NAN] {
            let cfg = SlipConfig { onset_finger_gate: gate, ..Default::default() };
            assert!(Slip::try_new(&cfg).is_err(), "{gate}");
        }
    }

    #[test]
    fn velocity_rule_classes_from_synthetic_tracks() {
        for (ff_v, th_v, want) in CASES {
            let mut s = Slip::try_new(&velocity()).unwrap();
            let ev = s.run_all(points(100, ramp(ff_v), ramp(th_v))).unwrap();
            assert_eq!(ev.len(), 1, "{want:?}: {ev:?}");
            assert_eq!(ev[0].class, want);
            assert_eq!(ev[0].previous, SlipClass::Stable);
            // tracks in contact from t = 0: the evidence reaches back one regression window
            let onset = ev[0].onset.as_secs_f64();
            let seen = ev[0].first_seen.as_secs_f64();
            assert!((0.5..0.6).contains(&seen), "{want:?}: first seen {seen}");
            assert!(onset >= seen - 0.16 - 1e-9 && onset <= seen - 0.15 + 1e-9, "{want:?}: onset {onset}");
            assert!(ev[0].time - ev[0].first_seen >= 80_000_000);
        }
    }

    #[test]
    fn ambiguous_motion_keeps_the_state_unless_dominance_is_one() {
        // one finger still, the other moving: |L| = |R|
        for base in [track(), velocity()] {
            let mut s = Slip::try_new(&base).unwrap();
            assert!(s.run_all(points(150, ramp(0.0), ramp(20.0))).unwrap().is_empty());
        }
        let mut s = Slip::try_new(&SlipConfig { dominance: 1.0, ..velocity() }).unwrap();
        let ev = s.run_all(points(150, ramp(0.0), ramp(20.0))).unwrap();
        assert_eq!(ev.len(), 1);
        assert_eq!(ev[0].class, SlipClass::LongitudinalDown); // ties go to longitudinal
                                                              // displacement: each finger's evidence is clamped to ±1, so one moving finger reaches
                                                              // |L| = |R| = 0.5 < 0.75 whatever the dominance — both fingers must move
        let mut s = Slip::try_new(&SlipConfig { dominance: 1.0, ..track() }).unwrap();
        assert!(s.run_all(points(150, ramp(0.0), ramp(20.0))).unwrap().is_empty());
    }

    fn chunked(cfg: &SlipConfig, input: &[TrackPoint], cut: usize) -> Vec<SlipEvent> {
        let mut s = Slip::try_new(cfg).unwrap();
        let mut out = crate::test_util::push_in_chunks(input, cut, |p, part| s.push(p.clone(), part));
        s.finish(&mut out).unwrap();
        out
    }

    #[test]
    fn chunking_does_not_change_the_events() {
        let stop = |v: f64| move |t: f64| [0.0, v * (t - 0.5).clamp(0.0, 0.4)];
        let input = points(450, stop(-10.0), stop(-10.0));
        for cfg in [track(), velocity()] {
            let all = Slip::try_new(&cfg).unwrap().run_all(input.clone()).unwrap();
            assert_eq!(all.len(), 2, "{all:?}");
            for cut in [1, 3, 7, 64] {
                assert_eq!(chunked(&cfg, &input, cut), all, "chunks of {cut}");
            }
        }
    }

    proptest::proptest! {
        #[test]
        fn chunking_invariance(seed in 0u64..1000, cut in 1usize..50, vf in -20.0f64..20.0, vt in -20.0f64..20.0) {
            // a wobbling track with a random slip, cut into random chunks
            let wob = move |k: f64| (seed as f64 + k * 37.0).sin() * 0.05;
            let input = points(150, move |t| [wob(t), vf * (t - 0.6).max(0.0) + wob(t + 1.0)],
                                    move |t| [wob(t + 2.0), vt * (t - 0.6).max(0.0)]);
            let all = Slip::try_new(&track()).unwrap().run_all(input.clone()).unwrap();
            proptest::prop_assert_eq!(chunked(&track(), &input, cut), all);
        }
    }

    #[test]
    fn slow_motion_no_contact_and_other_sensors_give_no_slip() {
        for cfg in [track(), velocity()] {
            let mut s = Slip::try_new(&cfg).unwrap();
            assert!(s.run_all(points(150, ramp(0.5), ramp(-0.5))).unwrap().is_empty());
            // one finger without contact: no evidence
            let mut pts = points(150, ramp(10.0), ramp(-10.0));
            for p in pts.iter_mut().filter(|p| p.sensor.as_str() == "th") {
                p.state = ContactState::NoContact;
                p.x_mm = f64::NAN;
                p.y_mm = f64::NAN;
                p.track = None;
            }
            assert!(s.run_all(pts).unwrap().is_empty());
            // sensors other than first/second are ignored
            let cfg = SlipConfig { first: "mf".into(), second: "rf".into(), ..cfg };
            let mut s = Slip::try_new(&cfg).unwrap();
            assert!(s.run_all(points(150, ramp(10.0), ramp(-10.0))).unwrap().is_empty());
        }
    }

    #[test]
    fn a_long_dropout_starts_afresh_and_a_short_one_does_not() {
        // both fingers lose contact from 0.45 s to 0.45 s + gap; the slip starts at 0.5 s
        for (gap, slips) in [(0.2, true), (0.7, false)] {
            let mut pts = points(150, ramp(-10.0), ramp(10.0));
            for p in pts.iter_mut() {
                let t = p.time.as_secs_f64();
                if (0.45..0.45 + gap).contains(&t) {
                    p.state = ContactState::NoContact;
                    p.x_mm = f64::NAN;
                    p.y_mm = f64::NAN;
                }
            }
            let ev = Slip::try_new(&track()).unwrap().run_all(pts).unwrap();
            // after a long dropout the fingers settle again (0.3 s) and the motion ends at 1.5 s
            // before enough history: no slip
            assert_eq!(!ev.is_empty(), slips, "gap {gap}: {ev:?}");
        }
    }

    #[test]
    fn slip_then_rest_returns_to_stable() {
        let stop = |v: f64| move |t: f64| [0.0, v * (t - 0.5).clamp(0.0, 0.4)];
        for cfg in [track(), velocity()] {
            let mut s = Slip::try_new(&cfg).unwrap();
            let ev = s.run_all(points(450, stop(-10.0), stop(10.0))).unwrap();
            let classes: Vec<_> = ev.iter().map(|e| e.class).collect();
            assert_eq!(classes, [SlipClass::LongitudinalDown, SlipClass::Stable]);
            assert!(ev[1].onset.as_secs_f64() > 0.9);
            assert_eq!(ev[1].onset, ev[1].first_seen);
            // the longest window of the ladder (history_s) sees the motion until it leaves it
            assert!(ev[1].first_seen.as_secs_f64() <= 0.9 + cfg.history_s + 0.05, "{ev:?}");
        }
    }

    /// Pattern points of one sensor at 100 Hz from a position function (contact throughout).
    fn pattern(n: usize, name: &str, at: impl Fn(f64) -> [f64; 2]) -> Vec<PatternPoint> {
        (0..n)
            .map(|k| {
                let t = Timestamp::at_rate(k as u64, 100.0);
                let p = at(t.as_secs_f64());
                PatternPoint {
                    sensor: name.into(),
                    time: t,
                    start: t,
                    seq: k as u64,
                    contact: true,
                    energy: 100.0,
                    x_mm: p[0],
                    y_mm: p[1],
                    onset_x_mm: p[0],
                    onset_y_mm: p[1],
                }
            })
            .collect()
    }

    /// The track points of `ff` only, and pattern points of both fingers, merged in time order
    /// (pattern first at a tie, as the runner hands them over).
    fn mixed(ff: impl Fn(f64) -> [f64; 2] + Copy, th: impl Fn(f64) -> [f64; 2] + Copy) -> Vec<SlipInput> {
        let tracks: Vec<TrackPoint> = points(150, ff, th).into_iter().filter(|p| p.sensor.as_str() == "ff").collect();
        let mut pats = pattern(150, "th", th);
        pats.extend(pattern(150, "ff", ff));
        pats.sort_by_key(|p| p.time);
        let mut out: Vec<SlipInput> = Vec::new();
        let mut tr = tracks.into_iter().peekable();
        for p in pats {
            while tr.peek().is_some_and(|q| q.time < p.time) {
                out.push(tr.next().unwrap().into());
            }
            out.push(p.into());
        }
        out.extend(tr.map(SlipInput::from));
        out
    }

    #[test]
    fn the_pattern_path_stands_in_for_a_missing_track() {
        for (ff_v, th_v, want) in CASES {
            let input = mixed(ramp(ff_v), ramp(th_v));
            // the track alone has one finger: no decision
            let track_only = SlipConfig { evidence: SlipEvidence::Track, ..Default::default() };
            assert!(Slip::try_new(&track_only).unwrap().run_inputs(input.clone()).unwrap().is_empty());
            for evidence in [SlipEvidence::Both, SlipEvidence::Pattern] {
                let cfg = SlipConfig { evidence, onset_lead_s: 0.0, ..Default::default() };
                let ev = Slip::try_new(&cfg).unwrap().run_inputs(input.clone()).unwrap();
                assert_eq!(ev.len(), 1, "{evidence:?} {want:?}: {ev:?}");
                assert_eq!(ev[0].class, want);
                let onset = ev[0].onset.as_secs_f64();
                assert!((onset - 0.5).abs() <= 0.011, "{want:?}: onset {onset}");
            }
        }
        // the velocity rule reads tracks only
        let ev = Slip::try_new(&velocity()).unwrap().run_inputs(mixed(ramp(10.0), ramp(-10.0))).unwrap();
        assert!(ev.is_empty());
    }

    #[test]
    fn explain_names_the_onset_position_and_its_fit() {
        let d = SlipConfig::default().describe();
        assert!(d.contains("fit (per-frame model fit: contact 4 σ, 3 iterations, magnitudes)"), "{d}");
        let e = SlipConfig { onset_position: OnsetPosition::Energy, ..Default::default() }.describe();
        assert!(e.contains("clear_earliest (gate 0.35) finger, energy position"), "{e}");
        let w: SlipConfig = toml::from_str("onset_fingers = \"weighted\"\nonset_finger_gate = 0.2").unwrap();
        assert!(w.describe().contains("weighted finger"), "{}", w.describe());
        let g: SlipConfig = toml::from_str("onset_finger_gate = 0.2").unwrap();
        assert!(g.describe().contains("clear_earliest (gate 0.2) finger"), "{}", g.describe());
        assert!(toml::from_str::<SlipConfig>("onset_fingers = \"latest\"").is_err());
        let toml: SlipConfig = toml::from_str("onset_position = \"linear\"").unwrap();
        assert_eq!(toml.onset_position, OnsetPosition::Linear);
        assert!(toml::from_str::<SlipConfig>("onset_position = \"centroid\"").is_err());
        // the fit's fluid-lag estimate: off by default, named when on, passed to the fit
        assert!(!d.contains("fluid lag"), "{d}");
        let lag: SlipConfig = toml::from_str("onset_fit_lag = true").unwrap();
        assert!(lag.describe().contains("magnitudes, fluid lag estimated)"), "{}", lag.describe());
        assert!(crate::slip_pattern::onset_fit_config(&lag).fit_lag_estimate);
        assert!(!crate::slip_pattern::onset_fit_config(&SlipConfig::default()).fit_lag_estimate);
    }

    #[test]
    fn onset_points_missing_on_some_frames_leave_gaps_in_the_onset_history_only() {
        // the model fit finds no contact on every third frame (NaN onset position): the
        // decision (from x_mm, y_mm) is unchanged and the onset is dated from the rest
        let (ff, th) = (ramp(-10.0), ramp(10.0));
        let input = |gaps: bool| -> Vec<SlipInput> {
            let mut a = pattern(150, "ff", ff);
            let mut b = pattern(150, "th", th);
            if gaps {
                for p in a.iter_mut().chain(b.iter_mut()).filter(|p| p.seq % 3 == 0) {
                    p.onset_x_mm = f64::NAN;
                    p.onset_y_mm = f64::NAN;
                }
            }
            a.into_iter().zip(b).flat_map(|(a, b)| [SlipInput::from(a), SlipInput::from(b)]).collect()
        };
        let cfg = SlipConfig { onset_lead_s: 0.0, ..Default::default() };
        let full = Slip::try_new(&cfg).unwrap().run_inputs(input(false)).unwrap();
        let gaps = Slip::try_new(&cfg).unwrap().run_inputs(input(true)).unwrap();
        assert_eq!(full.len(), gaps.len());
        assert!(!full.is_empty() && full[0].class.is_slip());
        for (a, b) in full.iter().zip(&gaps) {
            assert_eq!((a.time, a.class, a.first_seen), (b.time, b.class, b.first_seen));
            let d = (a.onset.as_secs_f64() - b.onset.as_secs_f64()).abs();
            assert!(d <= 0.03, "onset moved {d} s: {a:?} {b:?}");
        }
    }

    #[test]
    fn a_pattern_dropout_keeps_or_forgets_like_a_track_dropout() {
        for (gap, slips) in [(0.2, true), (0.7, false)] {
            let mut input = mixed(ramp(-10.0), ramp(10.0));
            for i in input.iter_mut() {
                if let SlipInput::Pattern(p) = i {
                    let t = p.time.as_secs_f64();
                    if p.sensor.as_str() == "th" && (0.45..0.45 + gap).contains(&t) {
                        p.contact = false;
                        p.x_mm = f64::NAN;
                        p.y_mm = f64::NAN;
                    }
                }
            }
            let ev = Slip::try_new(&SlipConfig::default()).unwrap().run_inputs(input).unwrap();
            assert_eq!(!ev.is_empty(), slips, "gap {gap}: {ev:?}");
        }
    }

    proptest::proptest! {
        #[test]
        fn mixed_inputs_chunking_invariance(cut in 1usize..60, vf in -20.0f64..20.0, vt in -20.0f64..20.0) {
            let input = mixed(move |t| [0.0, vf * (t - 0.6).max(0.0)], move |t| [0.0, vt * (t - 0.6).max(0.0)]);
            let all = Slip::try_new(&track()).unwrap().run_inputs(input.clone()).unwrap();
            let mut s = Slip::try_new(&track()).unwrap();
            let mut out = crate::test_util::push_in_chunks(&input, cut, |i, part| s.push_input(i.clone(), part));
            s.finish(&mut out).unwrap();
            proptest::prop_assert_eq!(&out, &all);
            // and a reset starts afresh
            s.reset();
            proptest::prop_assert_eq!(s.run_inputs(input).unwrap(), all);
        }
    }

    /// Both fingers' pattern and track points of a noisy soft-start slip (speeds `vf`, `vt`
    /// mm/s after 0.6 s, a linear start of `r` s, noise from `seed`), in time order with the
    /// inputs of each time step in the order `perm` picks (a seeded shuffle per step).
    fn same_time_mix(vf: f64, vt: f64, r: f64, seed: u64, perm: u64) -> Vec<SlipInput> {
        let noise = |k: u64, j: u64| {
            let x = (k.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ j.wrapping_mul(0xC2B2_AE3D_27D4_EB4F) ^ seed)
                .wrapping_mul(0x2545_F491_4F6C_DD1D);
            ((x >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.1
        };
        let at = |v: f64, t: f64| {
            let d = (t - 0.6).max(0.0);
            v * if d < r { d * d / (2.0 * r) } else { d - r / 2.0 }
        };
        let mut out = Vec::new();
        for k in 0..200u64 {
            let t = Timestamp::at_rate(k, 100.0);
            let s = t.as_secs_f64();
            let mut step: Vec<SlipInput> = Vec::new();
            for (j, (name, v)) in [("ff", vf), ("th", vt)].into_iter().enumerate() {
                let y = at(v, s) + noise(k, j as u64);
                let yo = at(v, s) + noise(k, j as u64 + 7);
                step.push(SlipInput::Pattern(PatternPoint {
                    sensor: name.into(),
                    time: t,
                    start: Timestamp::at_rate(k.saturating_sub(2), 100.0),
                    seq: k,
                    contact: true,
                    energy: 100.0,
                    x_mm: 0.0,
                    y_mm: y,
                    onset_x_mm: 0.0,
                    onset_y_mm: yo,
                }));
                let mut tp = points(1, |_| [0.0, y], |_| [0.0, y]).remove(0);
                tp.sensor = name.into();
                tp.time = t;
                tp.start = t;
                tp.seq = k;
                step.push(SlipInput::Track(tp));
            }
            // the pattern point of a sensor comes before its track points (the runner's
            // contract); otherwise any order within the step
            let mut key = perm ^ k.wrapping_mul(0x9E37_79B9_7F4A_7C15);
            for i in (1..step.len()).rev() {
                key = key.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                step.swap(i, (key >> 33) as usize % (i + 1));
            }
            let (pats, tracks): (Vec<_>, Vec<_>) = step.into_iter().partition(|i| matches!(i, SlipInput::Pattern(_)));
            if perm % 2 == 0 {
                out.extend(pats);
                out.extend(tracks);
            } else {
                // interleaved: each sensor's pattern point right before its own track point
                for p in pats {
                    let name = match &p {
                        SlipInput::Pattern(q) => q.sensor.clone(),
                        _ => unreachable!(),
                    };
                    out.push(p);
                    out.extend(tracks.iter().filter(|i| matches!(i, SlipInput::Track(q) if q.sensor == name)).cloned());
                }
            }
        }
        out
    }

    proptest::proptest! {
        /// Any order of the inputs that share a timestamp gives the same events, for every
        /// evidence path and both rules (the decision waits until a step is complete).
        #[test]
        fn same_time_inputs_in_any_order_give_the_same_events(
            vf in -20.0f64..20.0, vt in -20.0f64..20.0, r in 0.0f64..0.4, seed in 0u64..1000, perm in 1u64..1_000_000,
        ) {
            for cfg in [
                SlipConfig::default(),
                SlipConfig { evidence: SlipEvidence::Both, ..Default::default() },
                track(),
                velocity(),
            ] {
                let a = Slip::try_new(&cfg).unwrap().run_inputs(same_time_mix(vf, vt, r, seed, 0)).unwrap();
                let b = Slip::try_new(&cfg).unwrap().run_inputs(same_time_mix(vf, vt, r, seed, perm)).unwrap();
                proptest::prop_assert_eq!(&a, &b, "{:?}", cfg.evidence);
            }
        }
    }

    #[test]
    fn the_default_decides_on_a_steps_last_pattern_point() {
        // the default reads pattern points only: a step's decision runs once both fingers'
        // points of it are in, with no wait for the next step
        let input = same_time_mix(10.0, 10.0, 0.1, 3, 0);
        let all = Slip::try_new(&SlipConfig::default()).unwrap().run_inputs(input.clone()).unwrap();
        assert!(!all.is_empty() && all[0].class.is_slip(), "{all:?}");
        let mut s = Slip::try_new(&SlipConfig::default()).unwrap();
        let mut out = Vec::new();
        for i in input {
            let t = i.time();
            s.push_input(i, &mut out).unwrap();
            if let Some(e) = out.first() {
                assert_eq!(e.time, t, "emitted at a later step than its own");
                break;
            }
        }
        assert_eq!(out.first(), all.first());
        // the stated delay: the persistence alone; a track-reading rule adds one frame
        assert_eq!(Slip::try_new(&SlipConfig::default()).unwrap().delay(), Delay::nanos(100_000_000));
        assert_eq!(Slip::try_new(&track()).unwrap().delay(), Delay { frames: 1, nanos: 100_000_000 });
    }

    #[test]
    fn track_points_without_pattern_points_are_an_error_under_pattern_evidence() {
        let pts = points(150, ramp(10.0), ramp(-10.0));
        // the default (pattern evidence): the first track point of first/second is an error
        let mut s = Slip::try_new(&SlipConfig::default()).unwrap();
        let e = s.run_all(pts.clone()).unwrap_err();
        assert!(matches!(&e, Error::BadInput { stage: "slip", sensor, seq: 0, .. } if sensor == "th"), "{e}");
        assert!(e.to_string().contains("evidence = \"track\""), "{e}");
        // track points of other sensors are ignored as before
        let other = points(5, ramp(0.0), ramp(0.0))
            .into_iter()
            .map(|p| TrackPoint { sensor: SensorId::new("mf"), ..p })
            .collect::<Vec<_>>();
        assert!(Slip::try_new(&SlipConfig::default()).unwrap().run_all(other).unwrap().is_empty());
        // track and both evidence, and the velocity rule, read them
        for cfg in [track(), SlipConfig { evidence: SlipEvidence::Both, ..Default::default() }, velocity()] {
            assert_eq!(Slip::try_new(&cfg).unwrap().run_all(pts.clone()).unwrap().len(), 1, "{cfg:?}");
        }
        // after a pattern point, track points are accepted (and ignored); a reset forgets it
        let mut s = Slip::try_new(&SlipConfig::default()).unwrap();
        let mut out = Vec::new();
        s.push_input(pattern(1, "ff", ramp(0.0)).remove(0).into(), &mut out).unwrap();
        for p in pts.iter().take(10).cloned() {
            s.push(p, &mut out).unwrap();
        }
        assert!(out.is_empty());
        s.reset();
        assert!(s.push(pts[0].clone(), &mut out).is_err());
    }

    #[test]
    fn bad_config_and_time_going_back() {
        for cfg in [
            SlipConfig { second: "ff".into(), ..Default::default() },
            SlipConfig { first_up: [0.0, 0.0], ..Default::default() },
            SlipConfig { velocity_window_s: 0.0, ..Default::default() },
            SlipConfig { min_points: 1, ..Default::default() },
            SlipConfig { speed_threshold_mm_s: -1.0, ..Default::default() },
            SlipConfig { window_s: 2.0, history_s: 1.0, ..Default::default() },
            SlipConfig { distance_mm: f64::NAN, ..Default::default() },
            SlipConfig { settle_s: -0.1, ..Default::default() },
            SlipConfig { max_gap_s: 0.0, ..Default::default() },
        ] {
            assert!(Slip::try_new(&cfg).is_err(), "{cfg:?}");
        }
        let mut s = Slip::try_new(&track()).unwrap();
        let mut pts = points(3, ramp(0.0), ramp(0.0));
        pts.swap(0, 4);
        let e = s.run_all(pts).unwrap_err();
        assert!(matches!(e, Error::BadInput { stage: "slip", .. }), "{e}");
        let toml_cfg: SlipConfig = serde_json::from_str(r#"{"speed_threshold_mm_s": 5.0}"#).unwrap();
        assert_eq!(toml_cfg.speed_threshold_mm_s, 5.0);
        assert!(serde_json::from_str::<SlipConfig>(r#"{"speed": 5.0}"#).is_err());
    }
}
