//! Direction of slip on one fingertip: the seven BioTacSP-DoS classes from GradTac features
//! (`docs/method.md`, stage 7).
//!
//! # Current state (stop 37)
//! **The default** (what `gradtac calibrate dos` writes and the `dos` stage runs): the
//! **Student-t design** over the seven drift features (sections below) **combined with a tree
//! part**, T15 ([`DosTreesPart`]: gradient-boosted trees, [`DosTrees`], over 5-frame windows, 164
//! inputs per window — the level pattern, its change since contact and across the window, the
//! motion inputs, each taxel's change over 0.3 s and 1 s and its recent slope, the rotation-sense
//! flow fitted with a dilation, the change energies; see the `trees` source file).
//! A decision is `a·ln p(Student t) + (1 − a)·(mean ln p per window of the trees' causal vote)`,
//! `a` chosen by leave-one-object-out inside `calibrate`. T15 = `TreeTrainConfig::default()` =
//! `examples/dos_eval_parts/trees_t15.json` (60 rounds × 7 trees of depth ≤ 3, λ 5, half the
//! inputs per tree; trained with mirror images and two augmented copies per recording including
//! an object imprint).
//!
//! **Held out** (the BioTacSP-DoS development subset: 167 recordings, object sets *basic* = case,
//! hd, pen, sponge and *solids* = bottle, cardboard; per recording unless marked; chance 14.3 %).
//! T15 was chosen on inner views only (leave-one-object-out inside basic and inside solids, never
//! across; `examples/dos_eval_parts/trees_rule_round6.md`) and scored held out once; the weight
//! `a` and the Student-t design's choices are made inside each outer fold's training objects:
//!
//! | per recording unless marked | nested leave-one-object-out | basic → solids | solids → basic | ConvLSTM protocol: trained on basic, per 5-frame window of solids | at 1 s into contact (b → s / s → b) |
//! |---|---|---|---|---|---|
//! | **default: Student t + T15** | **88.6 %** (148/167) | **92.9 %** (52/56) | **82.9 %** (92/111) | **90.6 %** (2 788/3 076; the vote so far 91.0 %) ¹ | 89.3 % / 86.5 % |
//! | T15's vote alone | 89.2 % | 92.9 % | 83.8 % | — | 89.3 % / 84.7 % |
//! | Student t alone (the baseline) | 80.2 % | 85.7 % | 66.7 % | 29.1 % (the window alone); 63.3 % (history) | 66.1 % / 64.9 % |
//! | nearest class mean of the unit mean-change vector (the cheapest baseline) | 28.7 % | 19.6 % | 26.1 % | — | — |
//! | the published ConvLSTM (Zapata-Impata et al. 2019) | — | — | — | 82.56 % | — |
//!
//! ¹ The trees' answer per window: the window and the causal history its inputs hold (the
//! contact's first 0.1 s, the pattern 0.3 s and 1 s earlier, the last 0.3 s of changes).
//!
//! Reproduce: `cargo run --release --example dos_eval -- DATA_DIR --trees-only` (basic → solids,
//! solids → basic, the ConvLSTM protocol, 1 s, the sliding cost; fails under its floors 89 / 80 /
//! 88 %; `--trees-nested` adds the nested figure, floor 86 %); the full held-out run is
//! `cargo run --release --example dos_trees -- --held-out examples/dos_eval_parts/trees_t15.json`
//! (output `trees_round6_held_out.txt`). Cost: sliding mode (last 250 frames, a decision every
//! 10) p99 8.3–9.1 µs per frame (bound 20 µs; `dos_eval`, `examples/dos_sliding_cost`, shared
//! 2-core machine); `gradtac calibrate dos` 38.9 s on the 167 recordings (bound 2 min).
//!
//! **Targets (issue #23)** — per recording basic → solids, solids → basic and nested ≥ 85 %, the
//! ConvLSTM protocol ≥ 82.6 %, early answers at 1 s reported. Met: nested, basic → solids, the
//! ConvLSTM protocol. **Not met: solids → basic, 82.9 %** (3 recordings short; trained on two
//! objects; 12 of its 19 errors are `cw ↔ aw`). The issue's own figure on the BioTacSP-DoS object
//! sets that are not in this repository's data (64.0 %, measured by its author when the
//! Student-t design alone was the default) cannot be re-measured here; those sets are never
//! looked up or used.
//!
//! **Caveats.** The same held-out splits have been scored by the winners of every round (the
//! trees' rounds 1–6, the window nets before them); each choice was made on inner views only,
//! but a gain of one or two recordings is within what repeated scoring can produce. Which sense
//! of rotation the label `cw` means on the data is not settled (the class table below); no model
//! depends on it. How the default was reached: the table under "How the default was reached"
//! below.
//!
//! # What it does
//! A recording (or a span of a stream) of one sensor's raw frames is turned into a short
//! feature vector and classified by the most likely class under a heavy-tailed (Student t)
//! density per class, fitted by [`DosModel::calibrate`] from labelled recordings. The features
//! come from two views of the same frames:
//! - the **drift map** ([`crate::drift`]): for every taxel, how far its log signal moves over
//!   0.3, 0.6 and 1.2 s measured in units of its own frame-to-frame noise, and in which
//!   direction — *where* on the layout the pressure is slowly changing, independent of each
//!   taxel's gain and of the object's stiffness;
//! - the GradTac chain: log-change [events](crate::events) on the raw counts → per-taxel event
//!   counts split by polarity (and, for the track features, tumbling [window](crate::window)
//!   aggregates) → where the counts lie on the layout, optionally through
//!   [natural-neighbour surfaces](crate::interpolate) and [maximal contours](crate::contour)
//!   ([`CentroidMethod`]).
//!
//! The classes ([`DosClass`]) are those of the BioTacSP-DoS dataset (Zapata-Impata, Gil and
//! Torres, "Learning Spatio Temporal Tactile Features with a ConvLSTM for the Direction Of Slip
//! Detection", Sensors 19(3):523, 2019): translational slip `n`, `e`, `s`, `w`, rotational slip
//! `cw`, `aw`, and stable touch `t`. [`DosFeatureExtractor`] is the plain state machine,
//! [`DosClassifier`] the [`Stage`], [`DosModel`] the fitted, serialisable parameters.
//!
//! # Features ([`Feature`])
//! Over the span, with `τ` = [`DosFeatureConfig::threshold`] on `ln(counts)`; "location" is
//! the configured [`CentroidMethod`] (default: the count-weighted mean of the taxel positions);
//! `w_i`, `s_i` are the drift map's weight and sign of taxel `i` at position `(x_i, y_i)` (lags
//! [`DosFeatureConfig::drift_lags`]), `W = Σ w_i` and `(x̄, ȳ) = Σ w_i (x_i, y_i) / W`. The
//! **default** set ([`Feature::DEFAULT`]) is the seven drift features, on the linear drift
//! scale ([`DriftScale::Linear`]): all of them exactly invariant to a gain and an offset per
//! recording, and odd or even under the layout's mirror ([`Feature::mirror_sign`]).
//!
//! | feature | unit | definition |
//! |---|---|---|
//! | `drift_level` | — | `ln(1 + W)`: how much slow change there is (touch is lowest) |
//! | `drift_x`, `drift_y` | mm | `(x̄, ȳ)`: where the slow change is (on the side the contact leaves, like the events) |
//! | `drift_spread` | — | `ln(1 + Σ w_i ((x_i − x̄)² + (y_i − ȳ)²) / W)` |
//! | `drift_anisotropy` | mm² | `Σ w_i ((x_i − x̄)² − (y_i − ȳ)²) / W`: translations spread their drift along the pad, rotations do not |
//! | `drift_cross` | mm² | `Σ w_i (x_i − x̄)(y_i − ȳ) / W` |
//! | `drift_signed_y` | mm | `Σ w_i s_i y_i / W`: which side of the pad rises and which falls |
//! | `rate` | — | `ln(1 + events per second)`, all taxels, both polarities: how much is happening (touch is quiet) |
//! | `positive_fraction` | — | positive events / all events (0.5 without events) |
//! | `positive_x`, `positive_y` | mm | location of the **positive**-event counts (counts rising: pressure leaving) |
//! | `negative_x`, `negative_y` | mm | location of the **negative**-event counts (pressure arriving) |
//! | `activity_x`, `activity_y` | mm | location of all events |
//! | `track_dx`, `track_dy` | mm | displacement of the contact track: the location of all events in tumbling windows of [`DosFeatureConfig::track_window_frames`], mean of the last third of the windows minus mean of the first third |
//! | `rotation` | rad | rotation of the event distribution: sum over consecutive track windows of the change of its principal-axis orientation (wrapped to `(−π/2, π/2]`, weighted by the smaller of the two eccentricities — a round distribution has no orientation) |
//!
//! A distribution without weight (no events; no contour reaching `min_peak`; no drift) is
//! located at the centre of the layout's extent (with zero drift moments); a span with fewer
//! than two track windows has zero displacement and rotation; a span shorter than a drift lag
//! averages the lags it has. Every computed feature is finite for any finite input (tested at
//! 0, negative, 1e±300 and saturating counts); the extractor computes only the parts its
//! configured features need (see [`DosFeatureExtractor`]) and leaves the others NaN. The
//! drift features agree with an independent numpy implementation to 1e-12
//! (`tests/dos_drift_reference.rs`, vectors and script in `tests/reference/`).
//!
//! **Measured — held out** (BioTacSP-DoS development subset: 167 recordings of ~2.8 s, object
//! sets *basic* = case, hd, pen, sponge and *solids* = bottle, cardboard; per-recording
//! accuracy, chance 14.3 %; `cargo run --release --example dos_eval`, which prints these tables
//! and fails when a held-out figure drops under its floor; `gradtac calibrate --cross-validate`
//! prints this design's three held-out figures for any labelled data):
//!
//! | method | parameters | nested leave-one-object-out | basic → solids | solids → basic |
//! |---|---|---|---|---|
//! | nearest class mean of the unit mean-change vector (24 taxels; the cheapest baseline) | 168 | 28.7 % | 19.6 % | 26.1 % |
//! | the classifier before this design (9 features: log drift map + positive-event centroid, λ 0.5, fixed) | 126 | 83.2 % ¹ | 82.1 % ¹ | 74.8 % ¹ |
//! | **this design**: 120 candidates chosen inside every fold (below) | 98 | **80.2 %** | **85.7 %** | **66.7 %** |
//! | (comparison) the same choice with the earlier nine features added as candidates | ≤ 126 | 82.0 % | 82.1 % | 66.7 % |
//!
//! ¹ Not held out for its choices: its features and lags were picked by looking at the
//! leave-one-object-out accuracy over all six objects, so its first column is that plain
//! figure, and its cross-set figures come from choices that saw the test objects.
//!
//! *Protocols.* **Nested leave-one-object-out**: for each of the six objects, every choice —
//! drift lags (`[30, 60, 120]`, `[60]`, `[30, 60]`, `[60, 120]`), drift-feature set
//! (`drift_level, drift_x, drift_y` / + `drift_spread, drift_anisotropy` / all seven),
//! shrinkage `λ` (1, 0.75, 0.5, 0.25, 0) and mirror augmentation (off / on) — is made by
//! leave-one-object-out over the *other five* objects only ([`crate::dos_select`]); the chosen
//! candidate is fitted on those five and decides the held-out object. **Cross-set**: the same
//! choice by leave-one-object-out inside the training set (four basic objects, or the two
//! solids), fitted on the whole set, decides every recording of the other set. Student-t `ν` = 3
//! was never tuned. The per-fold choices were almost always all seven drift features with
//! `λ` 0.25–0.5; lags and mirror varied (`dos_eval` lists them). **The shipped defaults** are
//! what the same procedure picks on all 167 recordings: the seven drift features, lags
//! `[30, 60]`, linear scale, `λ` = 0, mirror augmentation on (inner leave-one-object-out
//! 83.2 % — in-sample for that choice; not a held-out figure).
//!
//! *The published protocol* (ConvLSTM of Zapata-Impata et al.: trained on basic only, accuracy
//! per non-overlapping 5-frame = 50 ms window of unseen objects, 82.56 % on solids): the
//! basic-trained choice decides each 5-frame window of the solids recordings — from **the window
//! alone** (a model of the same features with lags 1, 2, 4 frames, fitted on the basic
//! recordings' 5-frame windows): **29.1 %**; from **the causal history since contact** (the
//! basic-trained model on all frames up to the window's end — what a streaming robot has):
//! **63.3 %**. A 50 ms window holds no slow drift: these features need time, the ConvLSTM's
//! per-window figure is out of their reach.
//!
//! *Early answers* — the streaming [`DosClassifier`] with sliding decisions every 5 frames and
//! early answers ([`with_early_decisions`](DosClassifier::with_early_decisions): each over all
//! frames since contact), the cross-set choice fitted on whole training recordings:
//!
//! | split | 0.25 s | 0.5 s | 1 s | 2 s | whole (2.7–2.8 s) |
//! |---|---|---|---|---|---|
//! | basic → solids (56 recordings) | 14.3 % | 14.3 % | 66.1 % | 78.6 % | 85.7 % |
//! | solids → basic (111 recordings) | 14.4 % | 59.5 % | 64.9 % | 68.5 % | 66.7 % |
//!
//! Before 0.3 s (0.6 s for a choice of lags `[60]`) no drift lag has a difference, every
//! feature is at its no-drift value and every recording gets the same class. At 1 s the answers
//! are right about two times in three; an earlier issue's 85 % at 1 s is not reached by this
//! model alone.
//!
//! *What changed, and what it buys.* The drift map now differences raw values
//! ([`DriftScale::Linear`]), which makes every default feature exactly invariant to a gain and
//! an offset per recording (tested, `tests/dos_invariance.rs`: ×0.5, ×2 and added offsets
//! change no decision, on synthetic and on all 167 real recordings); the log scale gave the same
//! accuracy. Calibration adds every recording's mirror image across `y = 0`
//! ([`mirror_augmented`]), so the model is symmetric: a recording mirrored on the layout gets the
//! mirrored class (`e` ↔ `w`, `cw` ↔ `aw`; all 167 real recordings). The event-centroid
//! features of the previous default are not offset-invariant and are no longer in it; with them
//! as candidates the nested choice gives the comparison row above — three recordings more in
//! the nested figure, two fewer basic → solids, the same solids → basic: no consistent gain
//! for losing the invariance.
//!
//! **Why it works, and what does not.** Slip on the BioTac shows as slow (< 3 Hz) drifts of the
//! electrode impedances, strongest where the contact is leaving; their signs differ between
//! objects (so signed net changes classify poorly, ≈ 40 %), their *amplitudes* relative to each
//! electrode's own noise do not. Events count the same drifts but in absolute log units, so a
//! noisy electrode looks busy. Vibration above 5 Hz, the event track's displacement and
//! rotation, and the maximal contour add little: rotational slip of a real object barely moves
//! or turns the activity on the 24 electrodes; `cw`/`aw` are told apart mainly by
//! `drift_signed_y` and `drift_anisotropy`, and 7 of the 48 rotation recordings have the side
//! asymmetry reversed — the main remaining error.
//!
//! The targets this design was first measured against (an earlier issue's: ≥ 90 % each way and
//! nested, ≥ 85 % at 1 s; not reached alone), why it stopped there, and the log of every
//! extension tried (none beat the grid) are kept in `examples/dos_eval_parts/history.md`.
//!
//! # The window part: gradient-boosted trees ([`DosTrees`], the default since stop 34)
//! A model file may carry a window part that answers from 5-frame (50 ms) windows of raw frames,
//! as the published ConvLSTM does, voted causally over the span: the tree part
//! ([`DosModel::trees`], a [`DosTreesPart`]: the trees and the weight `a`; written by
//! `gradtac calibrate dos`) or the window net ([`DosModel::window`], a [`DosWindowPart`],
//! `--window-net`); at most one. Without one (`--no-window`, and every file written before they
//! existed) the Student-t design decides alone, exactly as before. The weight `a` ∈ {0, 0.25,
//! 0.5, 0.75, 1} is chosen by leave-one-object-out per recording on the recordings `calibrate`
//! is given (both models refitted without each object), then the part is fitted on all of them.
//! Both parts are validated when read and against the layout when the stage is built.
//!
//! [`DosTrees`] (module `trees`; representation, decision, validation and cost in its source
//! file's docs) is a softmax ensemble of regression trees over the [`TreeExtractor`]'s causal
//! per-taxel time representation ([`TreeInputs`]), walked as plain arrays in this crate (no
//! dependency), averaged with its mirror image so a mirrored recording gets the mirrored
//! posterior exactly. The trainer (`train_trees`, feature `train`, hand-written, never linked by
//! a robot) reuses the window model's augmentation (mirror images; random copies with noise,
//! speed and time warp, taxel dropout, layout rotation, vibration, per-taxel gain and offset, and
//! an object imprint). In the sliding mode its windows are counted from the contact and each is
//! computed once ([`DosClassifier`] gives the exact semantics and the measured agreement with a
//! fresh replay).
//!
//! **Other window models, measured, not the default** (same held-out protocols; each row the
//! figures of its own stop; the record in `examples/dos_eval_parts/history.md`):
//!
//! | model | nested | basic → solids | solids → basic | ConvLSTM protocol |
//! |---|---|---|---|---|
//! | [`DosWindowNet`] with motion inputs, three mirror-averaged members (stop 32's default; `--window-net`) + Student t | 88.6 % | 94.6 % | 78.4 % | 86.6 % |
//! | the same without motion inputs (stop 31's default; `--no-window-motion`) + Student t | 91.6 % | 92.9 % | 79.3 % | 85.9 % (the window alone) |
//! | since-start five-member ensemble + Student t (`since_start_ensemble.json`) | 89.8 % | 91.1 % | 75.7 % | 82.2 % |
//! | [`DosNet`], the learned whole-span model, 4 candidates chosen per fold (alone) | 76.0 % | 75.0 % | 68.5 % | chance (14.2 %) |
//!
//! # How the default was reached (rounds)
//! Every tree round followed one protocol: a rule file with the candidates spelled out (the
//! current default first, re-run as the baseline) committed before any figure; ranked on the
//! inner views only (recordings right inside basic + inside solids; ties → mean per-window
//! accuracy); excluded if it loses more than 2 recordings in a view; the winner must strictly
//! beat the baseline, is scored held out once, and becomes the default only if every target
//! already met stays met. The rule files keep each round's settings, commands, diagnoses,
//! held-out tables and costs; the `trees_round*` text files keep the tools' outputs.
//!
//! | stop (round) | candidates | inner views (basic + solids, recordings right) | verdict; held out, combination (nested / b → s / s → b / ConvLSTM) | record |
//! |---|---|---|---|---|
//! | ≤ 31 | window net + combination; since-start ensemble; mirror-averaged ensemble; motion inputs (opt-in) | per-window inner views (no rule file) | mirror-averaged ensemble the default: 91.6 / 92.9 / 79.3 / 85.9 | `history.md` |
//! | 32 | (1) motion inputs, (2) with a 25-frame reference, (3) with two copies | 117 → **120**, 117 (excl.), 119 | motion ensemble the default: 88.6 / 94.6 / 78.4 / 86.6 | `history.md`, `motion_round2_candidates.json` |
//! | 33 (1) | T1 trees, 148 inputs; T2 window inputs only | 120 → T1 138, T2 136 | T1: 89.2 / 91.1 / 79.3 / 90.0; the default in stop 34 | `trees_rule.md` |
//! | 34 (2) | T3 object augmentation, T4 regularised, T5 offset-invariant, T6 T3 + geometry/time | 138 → 136 (excl.), **140**, 120 (excl.), 140 (tie lost) | T4: 89.2 / 92.9 / 82.0 / 89.0 | `trees_rule_round2.md` |
//! | 35 (3) | T7 half the inputs per tree, T8 more lags, T9 object imprint | 140 → 143, 141, **144** | T9: 89.8 / 92.9 / 82.9 / 89.5 | `trees_rule_round3.md` |
//! | 35 (4) | T10 half the inputs per tree, T11 rotation-sense inputs, T12 both | 144 → 144, 144, **144** (tie-break) | T12: 89.2 / 91.1 / 81.1 / 88.7 | `trees_rule_round4.md` |
//! | 35 (5) | T13 change-energy inputs | 144 → **146** | T13: 88.6 / 91.1 / 82.9 / 89.7 | `trees_rule_round5.md` |
//! | 36 (6) | T14 flow share (removed in stop 37, code at `e43beac`), T15 dilation, T16 both | 146 → 147, **149**, 148 | **T15: 88.6 / 92.9 / 82.9 / 90.6** (the default) | `trees_rule_round6.md` |
//! | 36 (7) | T17 four copies, T18 imprint 1.0, T19 window inputs `levels` | 149 → 142 (excl.), 149 (tie lost), 141 (excl.) | no winner; nothing scored held out | `trees_rule_round7.md` |
//!
//! All record files are in `examples/dos_eval_parts/`; the candidates of round `k` are
//! `trees_round{k}_candidates.json` (round 1: `trees_candidates.json`), each adopted default's
//! settings `trees_t1.json`, `trees_t4.json`, `trees_t9.json`, `trees_t12.json`,
//! `trees_t13.json`, `trees_t15.json`. The inner views run with `examples/dos_trees` (its docs
//! give each round's command), the held-out runs with `dos_trees --held-out FILE`. This page's
//! longer per-round entries up to stop 36 are in `history.md`, unchanged.
//!
//! # Decision rule
//! [`DosModel::calibrate`] fits class means `μ_c`, pooled within-class variances `σ²_j` and
//! per-class variances shrunk toward them, `σ²_{c,j} = λ·σ²_j + (1 − λ)·s²_{c,j}` with
//! `s²_{c,j}` the class's own variance and `λ` = [`DosModel::DEFAULT_SHRINKAGE`] = 0 (chosen by
//! the nested procedure above, not fitted; [`DosModel::calibrate_with_shrinkage`] takes
//! another; 0.5 before). With
//! `m_c = Σ_j (f_j − μ_{c,j})² / σ²_{c,j}` a feature vector `f` of `d` features gets the class
//! minimising `D_c = Σ_j ln σ²_{c,j} + (ν + d)·ln(1 + m_c/ν)` (ties: the first class in the
//! model's order): the maximum-likelihood class of a multivariate Student t per class with
//! diagonal scales, `ν` = [`DosModel::DEFAULT_STUDENT_T_DOF`] = 3 degrees of freedom and equal
//! priors. One feature far off its class mean costs logarithmically, not quadratically, so a
//! recording that is unusual in one feature (an object-specific offset) is not thrown out of
//! its class by it. [`DosModel::with_student_t_dof`]`(None)` (and model files without
//! `student_t_dof`) use the Gaussian `D_c = Σ_j ln σ²_{c,j} + m_c`. Where `m_c` overflows
//! (features near ±`f64::MAX`) it is evaluated as `ln m_c` by log-sum-exp, so the decision
//! and the posterior stay defined. With `λ = 1` (or a model
//! file without `class_variances`) every class shares `σ²_j`, the log terms drop and the rule is
//! the nearest class mean in `m_c`. [`Decision::posterior`] gives `softmax(−D_c/2)`.
//!
//! **Parameter count:** `2 × classes × features` numbers — a mean and a variance per class and
//! feature (the stored pooled variances only feed the shrinkage). With the 7 classes and the 7
//! default features: **98** (56 = `(7 + 1) × 7` for the pooled model). Configuration
//! (threshold, drift lags and scale, window, grid, contour settings, centroid method, the
//! feature list, `λ`, `ν`, mirror augmentation) is fixed, not fitted. Calibration with the
//! mirror images doubles the samples, not the parameters.
//!
//! # Class names → directions (layout axes of [`Layout::biotac_sp`](gradtac_stream::Layout::biotac_sp): x along the finger toward the tip, y across)
//! | class | contact motion | [`DosClass::direction`] / [`DosClass::rotation_sense`] |
//! |---|---|---|
//! | `n` | toward the tip | `+x` |
//! | `s` | toward the palm | `−x` |
//! | `e` | across | `+y` |
//! | `w` | across | `−y` |
//! | `cw` | rotation from `+x` toward `+y` | `+1` |
//! | `aw` | rotation from `+y` toward `+x` | `−1` |
//! | `t` | none | — |
//!
//! *How the translations were determined* (BioTacSP-DoS development subset, 167 recordings):
//! pressing the skin lowers a BioTac electrode's count — across recordings each electrode's
//! counts lie far below its largest value (≈ its rest value, 3 600–3 700) and never much above.
//! The class-mean change of counts (last 20 frames minus first 20) then shows where pressure
//! goes: for `n` the counts rise (pressure leaves) at the proximal electrodes (x ≈ −6…−11 mm:
//! e8–e10, e18–e20) and fall (pressure arrives) at the pad's middle and tip (e15, e23, e24,
//! x ≈ 0…5 mm): the contact moves toward `+x`. `s` is the mirror image (rise at e21–e24, fall at
//! e8/e18: `−x`); `e` rises on the `−y` side (e3–e7), so the contact moves toward `+y`; `w`
//! rises on the `+y` side (e11–e17): `−y`. The event features agree: the events concentrate
//! on the side the contact leaves (class-mean event centroids `n` x ≈ −4 mm, `s` x ≈ +2,
//! `e` y ≈ −5.5, `w` y ≈ +4.7), and so does the drift map (`drift_x` `n` −1.9 mm, `s` +1.4;
//! `drift_y` `e` −3.1, `w` +2.7). Viewed from outside the pad with the tip up, `+y` is to the
//! right, so this is the compass: north up, east right.
//! *Rotation sense* is the compass convention (clockwise = north toward east = `+x` toward
//! `+y`, the direction in which [`MaxContour::orientation_rad`](crate::contour::MaxContour)
//! and the `rotation` feature grow). It is **not** confirmed by the data: on the development
//! subset the `rotation` feature of `cw` and `aw` recordings does not differ (class means
//! −0.38 and +0.20 rad with spreads above 1 rad; see `dos_eval`'s printout). What does differ
//! is `drift_signed_y` (class means `cw` −1.2 mm, `aw` +2.3 mm, spreads ≈ 2.3 mm: in `cw` the
//! `−y` side's counts tend to rise and the `+y` side's to fall, in `aw` the reverse) — a
//! signature the classifier learns, not a geometric derivation of the sense. Two turn measures
//! that agree on synthetic turns (both tested) disagree on the real rotations (stop 36,
//! `examples/dos_trees_diag.rs`, mean per recording of the 48 `cw`/`aw` recordings): the turn of
//! the pattern's principal axis has the sign above on 31/48, the rigid turn fitted beside a
//! dilation ([`TreeInputs::dilation`]) over 1 s on 13/48 (the opposite sign on 35/48); per
//! object the fitted turn never has a majority of the sign above (4/8 at most), in basic and
//! solids alike, so no object or set is labelled the other way round. No trainer, model or stage uses the sign of a rotation
//! class (the mirror augmentation maps `cw ↔ aw`, right whatever the sense), so the models do not
//! depend on this convention; only [`DosClass::rotation_sense`]'s meaning does.
//!
//! # Units, delay, cost
//! Input in raw sensor counts (> 0; a value ≤ 0 is raised to the events stage's floor,
//! 1e-3). The extractor has no delay of its own: a decision covers the span pushed so far
//! ([`DosClassifier`]: every `decision_frames` frames, or at `finish`), and needs more than
//! the shortest drift lag (0.3 s) of it to weigh anything — see the latency trade above.
//! Extracting the default features costs 0.26–0.28 µs per frame (`dos_eval`; criterion
//! `--bench tasks`: 0.28 µs, of which the drift map 0.14 µs), every feature with surface
//! locations of the track windows 0.65 µs (32 × 32 natural neighbour); the drift map keeps the last
//! `max(drift_lags)` frames (60 × 24 values with the default lags). A decision is `classes × features`
//! multiply-adds and `classes` logarithms (plus `classes × features` with per-class variances).
//! With the default tree part (T15): every 5 frames one window's 164 inputs (with a 4 × 4
//! least-squares solve per lag and slope) and 2 × 420 tree walks (the input and its mirror
//! image); in the sliding mode the kept windows' log posteriors (≤ `n`/5 × 7 values) and one sum
//! of them per decision — p99 8.3–9.1 µs per frame at 250 frames, hop 10 (current state above;
//! the semantics in [`DosClassifier`]). No delay beyond the decision's own: a tree window counts once
//! its fifth frame is in.
//!
//! # Trade-offs
//! | knob | lower | higher |
//! |---|---|---|
//! | `drift_lags` | sees fast, short slips; noise weighs more | sees slow drifts; needs longer spans |
//! | `threshold` τ (event features) | more noise events (quiet touch looks busy) | loses slow, small slips |
//! | `track_window_frames` | noisy track, more rotation samples | smeared track, few samples |
//! | `min_area_mm2` (max contour) | centroid snaps to the busiest taxel | centroid averages a larger region |
//! | [`CentroidMethod`] | `taxels`: cheapest, most accurate here | `surface` / `max_contour`: the paper's geometry, 2× the cost, less accurate here |
//! | features | fewer: fewer parameters, more robust on unseen objects | more: fits the seen objects better |
//! | shrinkage `λ` | 0: each class's own spread (e.g. quiet `t`), noisy with few recordings per class | 1: one pooled spread, fewest parameters |
//! | Student-t `ν` | heavier tails: one odd feature matters less | `∞`: the Gaussian, every deviation counts quadratically |
//! | `decision_frames` (stage) | faster answers from little evidence (1 s: ≈ 65 % cross-set) | later, surer answers (whole recordings: 67–86 % cross-set) |
//! | mirror augmentation | off: the model may learn a side preference of the training data | on (default): symmetric model, twice the samples, same parameter count |
//! | drift scale | `log`: the previous default, gain-invariant only | `linear` (default): gain- and offset-invariant, same accuracy |
//! | hop ([`DosClassifier::with_hop`]) | an answer every few frames; one `decision_frames` extraction each | fewer answers, less CPU |
//! | window part | the net ([`DosWindowPart`], `--window-net`, stop 32's): every decision a fresh replay; sliding p99 20.9 µs (loaded); held out 88.6 / 94.6 / 78.4 / 86.6 % | trees ([`DosTreesPart`], default, T15): its windows keep the contact's history; sliding p99 8.3–9.1 µs; held out 88.6 / 92.9 / 82.9 / 90.6 % (nested / basic → solids / solids → basic / ConvLSTM protocol) |

use crate::contour::{ContourConfig, Levels, MaxContour, MaxContourFinder, Saddle};
use crate::drift::{DriftMap, DriftScale};
use crate::events::{Events, EventsConfig, Threshold};
use crate::interpolate::{GridConfig, Interpolator, Method, Outside};
use crate::window::{Aggregate, Window, WindowAggregate, WindowConfig, WindowKind};
use crate::{Error, EventBatch, Result};
use gradtac_stream::{Delay, HasSensor, Layout, SensorId, Stage, TaxelFrame, Timed, Timestamp};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;
use std::sync::Arc;

mod classes;
mod cross_validation;
mod dense;
mod extractor;
mod features;
mod model;
mod net;
mod stage;
#[cfg(feature = "train")]
pub mod train;
#[cfg(feature = "train")]
pub mod train_trees;
#[cfg(feature = "train")]
pub mod train_window;
mod trees;
mod window;

pub use classes::*;
pub use cross_validation::*;
pub use extractor::*;
pub use features::*;
pub use model::*;
pub use net::*;
pub use stage::*;
pub use trees::*;
pub use window::*;

const STAGE: &str = "dos";

fn invalid(reason: impl Into<String>) -> Error {
    Error::InvalidConfig { stage: STAGE, reason: reason.into() }
}

#[cfg(test)]
mod tests;
#[cfg(test)]
use tests::support as tests_support;
#[cfg(test)]
mod net_tests;
#[cfg(test)]
mod trees_tests;
#[cfg(test)]
mod window_tests;
