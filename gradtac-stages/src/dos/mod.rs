//! Direction of slip on one fingertip: the seven BioTacSP-DoS classes from GradTac features
//! (method.md, stage 7 and "Real data at hand").
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
//! are right about two times in three; the 85 % at 1 s is not reached.
//!
//! *Targets not reached, and why it stops here.* The issue asked for ≥ 90 % cross-set each
//! way, ≥ 90 % nested and ≥ 85 % at 1 s. Measured: 85.7 % / 66.7 %, 80.2 %, ~65 %. The
//! remaining errors are mostly `cw` ↔ `aw` (13 of 33 nested errors) and `n` → `cw`/`aw`: on
//! these recordings rotation is visible only as a weak side asymmetry of the drift
//! (`drift_signed_y`) that half a dozen recordings show reversed. Solids → basic trains on two
//! objects (56 recordings) and the choice inside it rests on a two-fold leave-one-object-out —
//! the weakest link. Every extension tried (log below) left the nested figure at or under
//! 80.2 %; a figure chosen on the test data would be easy to get and is not reported.
//!
//! *Design log* (nested leave-one-object-out unless marked; one recording = 0.6 points):
//!
//! | tried | nested |
//! |---|---|
//! | the design grid above (linear drift map, 120 candidates) — **shipped** | 80.2 % |
//! | log instead of linear drift scale (drift features only, λ 0.5, plain LOOO) | 80.2 % = linear |
//! | + centroid of the rising drift (`w·max(s, 0)`), as a fourth feature set | 79.0 % |
//! | + centroid of the falling drift (`w·max(−s, 0)`) | 80.2 % |
//! | + both | 80.2 % |
//! | + displacement of the drift centroid from the first to the second half of the span | 80.2 % |
//! | + flow of change across neighbouring taxels (pairs < 6.5 mm apart: asymmetry of the 50 ms lagged correlation of their smoothed, standardised first differences, summed along the pair's direction) — flow vector / curl / both | 79.6 / 79.6 / 80.2 % (class means indistinguishable) |
//! | + rotation of the drift pattern (principal-axis orientation of the first third's drift map to the last third's, weighted by anisotropy) | 79.6 % |
//! | sub-span voting: features of overlapping 1.4 s / 1 s / 2 s / 0.7 s sub-spans, summed class distances | 78.4 / 79.6 / 77.8 / 77.8 % |
//! | per-taxel maps `[w, w·s]` (48 values), L2 logistic regression with mirror augmentation (plain LOOO, 3 strengths) | 75.4–76.6 % |
//! | the seven drift moments, logistic regression (plain LOOO) | 71.9–76.6 % |
//! | model fitted on prefixes (1, 2 s and whole) for early answers (plain LOOO at 1 s / whole) | 68.9 / 82.6 % vs 70.1 / 83.2 % |
//!
//! The rows after the first were exploratory re-implementations (numpy) of the same features and
//! rule; none beat the grid, so none was ported. The cross-set figures of the shipped grid were
//! printed once before those explorations; nothing was changed after seeing them.
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
//! # The learned model ([`DosNet`]) — measured, not the default
//! [`DosNet`] (module `net`) classifies a per-taxel, multi-time-scale representation of the span
//! ([`NetExtractor`]: for each taxel the drift weight and signed weight at 0.3 and 0.6 s, the
//! net change since contact against the taxel's noise, plus the seven drift moments: 127 inputs,
//! exactly invariant to a gain and an offset per taxel) with one hidden layer of 16 `tanh` units
//! (2 421 parameters). It streams: the representation is kept as running sums, and a decision
//! every frame costs a median 2.9 µs, p99 3.4 µs (`dos_eval`, 46 165 frames, release build,
//! a loaded 2-core machine). The trainer (`dos::train`, cargo feature `train`, no extra crate)
//! adds every recording's mirror image (taxel permutation of the layout's reflection,
//! `e ↔ w`, `cw ↔ aw`) and random copies with white noise, speed and time warp, taxel dropout,
//! small layout rotations, vibration added or removed and prefix crops, and fits by full-batch
//! Adam: 1.8 s for all 167 recordings.
//!
//! Held out (`dos_eval`, `--learned-only` for just this part; per recording): the candidates
//! are weight decay {0.01, 0.1} × augmentation {mirror only, mirror + 2 random copies}, chosen by
//! leave-one-object-out inside the training objects of every fold, exactly as the Student-t
//! design's (whose row, above, is the baseline):
//!
//! | method | nested leave-one-object-out | basic → solids | solids → basic |
//! |---|---|---|---|
//! | Student-t design (the default, above) | **80.2 %** | **85.7 %** | 66.7 % |
//! | learned, 4 candidates chosen per fold | 76.0 % | 75.0 % | **68.5 %** |
//! | (comparison) both, log posteriors summed with equal (untuned) weights | 80.2 % | 85.7 % | **70.3 %** |
//!
//! Published protocol (basic only, per 5-frame window of solids): with the causal history
//! 64.7 % (the Student-t design 63.3 %); from the window alone the learned model is at chance
//! (14.2 %: the basic-chosen weight decay 0.1 flattens a model of 50 ms windows to one class),
//! the Student-t one 29.1 %; the ConvLSTM 82.56 %. Early answers (streaming, everything since
//! contact), basic → solids: 0.5 s 25.0 %, **1 s 73.2 %**, 2 s 78.6 %, whole 75.0 %;
//! solids → basic: 0.5 s 39.6 %, **1 s 61.3 %**, 2 s 67.6 %, whole 69.4 %.
//!
//! It does not beat the Student-t design on objects it has not seen (it wins only solids →
//! basic, by two recordings, and at 1 s basic → solids), so the defaults stay the Student-t
//! model. The two err differently: the fixed ensemble (no weight chosen) keeps the Student-t
//! figures where it is strong and adds four recordings solids → basic — measured in
//! `dos_eval`, not yet what the `dos` stage runs. Exploratory looks before the grid was fixed (plain leave-one-object-out over all six
//! objects, one configuration each, so in-sample for these choices): 16 hidden with weight
//! decay 0.001 / 0.01 and six copies 70.7 / 76.6 %, 8 hidden with 0.03 77.2 %, mirror only
//! 74–77 %; the grid above was fixed after them and the held-out figures were printed once.
//!
//! # The window model ([`DosWindowNet`]) and its combination — the default of `gradtac calibrate` until stop 33 (`--window-net` since stop 34)
//! (since stop 31 with the mirror-averaged ensemble as its window part: see the end of this
//! section; the tables here are of the single network it replaced)
//! [`DosWindowNet`] (module `window`) answers from **one 5-frame (50 ms) window** of raw frames,
//! as the published ConvLSTM does: the *level pattern* across the taxels (each taxel's window
//! sum against the mean over all taxels, divided by their spread) and its change across the
//! window (48 inputs for the BioTac SP, exactly invariant to a gain and an offset common to all
//! taxels, not per taxel), one hidden layer of 16 `tanh` units, 999 parameters. The drift
//! features above measure motion *since contact*, which a 50 ms window does not hold (29 %);
//! the pattern of how the skin is sheared already holds the direction. Per recording (and on a
//! stream, since contact) [`WindowVote`] sums the log posteriors of the completed
//! non-overlapping windows — causal: at frame `t` only windows ending by `t`. Streaming cost
//! per frame: median 0.11 µs, p99 1.4–1.5 µs (`dos_eval`, 46 165 frames, loaded 2-core machine).
//! The trainer (`train_window`, feature `train`, no crate) adds every recording's mirror image
//! and random copies (noise, speed and time warp, taxel dropout, layout rotation, vibration,
//! and a gain and an offset *per taxel*), and fits by minibatch Adam: 1.3–1.4 s on all 167
//! recordings.
//!
//! Held out (`dos_eval`, `--window-only` for just this part). Candidates: mirror images only,
//! or mirror images and one random copy per recording; chosen per fold by leave-one-object-out
//! accuracy per window inside the training objects. The network's settings (16 hidden, weight
//! decay 1e-4, 20 epochs of batches of 64, learning rate 0.003, gain spread 0.01, offset spread
//! 0.1) were set once, before any figure of this model. The **combination** adds the
//! Student-t design's log posterior and the vote's mean log posterior per window,
//! `a·ln p_t + (1 − a)·mean ln p_w`, with `a ∈ {0, 0.25, 0.5, 0.75, 1}` chosen by
//! leave-one-object-out inside the training objects of every outer fold (both models refitted
//! on each inner training part, each model's candidate the one its own procedure chose for the
//! fold); it chose `a` = 0.75 in seven of eight folds and 0.5 once.
//!
//! | method (per recording unless marked) | nested leave-one-object-out | basic → solids | solids → basic |
//! |---|---|---|---|
//! | Student-t design (the default) | 80.2 % | 85.7 % | 66.7 % |
//! | window model, vote over all windows | 77.2 % | 89.3 % | 66.7 % |
//! | window model, per 5-frame window alone | 75.7 % | **86.2 %** | 65.4 % |
//! | **combination** (weight chosen inside the folds) | **88.0 %** | **89.3 %** | **78.4 %** |
//!
//! The published protocol (trained on basic only, per non-overlapping 5-frame window of
//! solids): the window alone **86.2 %** (2 651 / 3 076; the ConvLSTM 82.56 %, the Student-t
//! design 29.1 %); with the causal history since contact (the vote) 87.3 %. Early answers, the
//! vote at 1 s into contact: basic → solids 87.5 %, solids → basic 64.0 %; the combination at
//! 1 s: 85.7 % and 73.9 % (0.25 s: the vote already 85.7 % and 64.0 %).
//!
//! Not reached: solids → basic ≥ 85 % (78.4 %; two training objects). The window model depends
//! on the sensor's level pattern, so it transfers between objects on one sensor; a second
//! sensor differs in every taxel's rest level, which only the augmentation models. How the
//! representation was found (disclosed; in-sample for that choice): before this design,
//! exploratory numpy fits (softmax regression and 32-unit networks, about twenty
//! configurations) were scored directly on the two cross-set splits — raw levels per window
//! 84–90 % / 60–66 %, drift since contact 28–59 % / 30–47 %, the level pattern across taxels
//! 85–88 % / 66–72 %; the last was ported. The held-out procedure above was then run once, and
//! the combination was added after seeing that run's figures (its weight grid fixed before its
//! first run).
//!
//! **The combination is the default.** It beats the Student-t model on every protocol above, so
//! a model file may carry a window part ([`DosModel::window`], a [`DosWindowPart`]: the net and
//! the weight `a`), `gradtac calibrate` writes one (`--no-window` leaves it out), and the `dos`
//! stage ([`DosClassifier`]) then decides by [`DosModel::combine`]: the Student-t decision of
//! the span and the causal vote of the net over the same frames (the segment, the tumbling span,
//! or the replayed sliding window; before the first complete 5-frame window, the Student-t
//! decision alone). `gradtac calibrate` chooses as the held-out procedure does, on all the
//! recordings it is given: the window candidate by leave-one-object-out accuracy per window, then
//! `a` ∈ {0, 0.25, 0.5, 0.75, 1} by leave-one-object-out per recording (both models refitted
//! without each object), then the net fitted on every recording (about 20 fits of the net; with
//! fewer than two objects, no choice: the augmented candidate and `a` = 0.75). The one
//! difference from the held-out procedure: the Student-t part is `calibrate`'s fixed default
//! design, not re-chosen per fold. Model files without `window` (all written before it existed)
//! read and decide exactly as before, and a model without a window part is written without the
//! key. A window part is validated when read (`window.weight` in `[0, 1]`, `window.net` as
//! [`DosWindowNet::validate`]) and its taxel count against the layout when the stage is built.
//! Checked in `dos_eval --window-only`: the `dos` stage on the model file each held-out fold's
//! procedure writes (one decision per recording) decides as the combination on all 334 held-out
//! recordings (nested 88.0 %, basic → solids 89.3 %, solids → basic 78.4 %), at a cost per frame
//! of median 0.21–0.22 µs, p99 1.7–1.9 µs (feature extraction and the vote; 92 330 frames, shared
//! 2-core machine). `gradtac calibrate` on the 167 development recordings: 7.7 s in all (release), it
//! chose the mirror-only candidate and `a` = 0.75 (leave-one-object-out per recording for
//! a = 0 / 0.25 / 0.5 / 0.75 / 1: 130 / 142 / 151 / 152 / 139 of 167 — in-sample for that choice).
//! (Those figures are the previous default's; with the mirror-averaged ensemble below, the one
//! window candidate, `gradtac calibrate` takes 27–30 s and chooses `a` = 0.75: 132 / 144 / 152 /
//! 154 / 139 of 167, in-sample for that choice.)
//! In the sliding mode each decision replays its `n` frames through the feature extractor, and
//! sums the vote from the log posteriors of its net windows, each computed once and kept across
//! decisions (a net window depends on its own frames only; the sum is bit-identical to a fresh
//! vote, tested): with `n` = 250 and a decision every 10 frames the per-frame p99 (the decision
//! frames) is 39 µs with the window part against 34 µs without (median 0.22 µs both; 92 330
//! frames; 79 µs before the cache).
//!
//! **Measured against the contact's start, and ensembles (a candidate, not the default).** The
//! window model's level pattern carries the object, and solids → basic learns from two objects.
//! Two additions, both in the inference crate without a trainer crate: a causal per-recording
//! normalisation ([`WindowInputs::Both`]: beside the level pattern, each taxel's change since
//! its own mean over the contact's first 0.1 s, as a pattern across taxels — see
//! [`window`](DosWindowNet)), and an ensemble over seeds merged by logit averaging into one
//! network (`train_window::merge_members`; five members of 16 hidden units = one network of 80,
//! 5 913 parameters). Held out exactly as the rows above (every choice inside each outer fold's
//! training objects: `a` by leave-one-object-out per recording; one window candidate, so no
//! window choice), `dos_eval --window-only --window-candidates
//! examples/dos_eval_parts/since_start_ensemble.json` (inputs `both`, reference 10 frames,
//! mirror images only, weight decay 1e-3, five members; 7 min 49 s on the shared machine):
//!
//! | method (per recording unless marked) | nested leave-one-object-out | basic → solids | solids → basic |
//! |---|---|---|---|
//! | since-start ensemble, vote over all windows | 85.6 % (143/167) | 83.9 % (47/56) | 70.3 % (78/111) |
//! | since-start ensemble, per 5-frame window alone | 81.9 % | 82.2 % | 67.8 % |
//! | since-start ensemble + Student t (weight chosen inside the folds) | **89.8 %** (150/167) | **91.1 %** (51/56) | 75.7 % (84/111) |
//! | the default combination (above) | 88.0 % | 89.3 % | **78.4 %** |
//!
//! It gains on nested (+3 recordings) and basic → solids (+1) but loses solids → basic (−3)
//! and falls under the ConvLSTM on its protocol (82.2 % per window, 2 528 / 3 076, against
//! 82.56 %; the default window model 86.2 %), so **it is not the default**: defaults change
//! only for a model that wins held out on every protocol. The `dos` stage decides as the
//! combination on 334 of 334 held-out recordings with it too; one decision per recording costs
//! median 0.26 µs, p99 5.1 µs per frame (the vote alone p99 4.7 µs); at 1 s into contact
//! 83.9 % / 76.6 % (basic → solids / solids → basic). In the sliding mode (250 frames, a
//! decision every 10) its p99 is 230 µs: the reference moves with the replayed window, so no
//! net window's log posterior can be kept across decisions (every net window is recomputed);
//! the levels-only default keeps its cache.
//!
//! *Where solids → basic stops (the default combination, measured; `dos_eval --window-only`
//! prints it).* Per test object: case 60.7 % (17/28), hd 92.9 % (26/28), pen 77.8 % (21/27),
//! sponge 82.1 % (23/28) — case alone holds 11 of the 24 errors; the other three objects
//! together are at 84.3 % (70/83). By class, the errors drift toward rotation: true → decided
//! `s→aw` 5, `cw→aw` 4, `cw→s` 3, `n→aw` 2, `n→cw` 2, `n→t` 2, `t→s` 2, `w→cw` 2, `aw→cw` 1,
//! `w→n` 1 (9 of 24 decided `aw` or `cw` for a translation). Basic → solids errs 6 times,
//! spread over both objects (3 each). With two training objects the weight `a` and every
//! learned pattern come from bottle and cardboard, whose contact is rigid and large; the case
//! is the one basic object whose errors dominate.
//!
//! *How the candidate was chosen* (log; no figure outside a training set's own objects was
//! looked at before the one held-out run): `dos_eval --window-inner` prints each candidate's
//! leave-one-object-out accuracy *inside* basic and *inside* solids only (the inner folds of
//! the two cross-set protocols). Nineteen configurations were scored that way: inputs levels /
//! since-start / both, reference 10 or 25 frames, 16 or 32 hidden, weight decay 1e-4 / 1e-3,
//! 0–2 random copies with per-taxel gain 0.01–0.2 and offset 0.1–1, seeds 1–3, one or five
//! members. Since-start alone was weak (inside basic 44–46 % per window against 61–62 % for
//! levels; inside solids 33–34 % against 65–66 %); `both` was best inside basic (66–71 % per
//! window, 71–75 % per recording); seeds alone moved inside-basic accuracy by 9 points (60.5 to
//! 69.9 % per window), which the five-member ensemble removes; the candidate was the best on
//! both inner views (inside basic 70.9 % per window, 73.9 % per recording; inside solids 69.1 %
//! and 73.2 %). Those inner folds are disjoint from the cross-set test objects but overlap the
//! nested protocol's outer test objects (a basic object held out inside basic is also an outer
//! fold of the nested protocol), so the nested figure of this row is not fully clean. **One
//! candidate was scored held out** (one run). Stronger augmentation (two random copies, gain
//! 0.2, offset 1) was worse inside both sets (63.9 / 63.0 % per window).
//!
//! **The mirror-averaged ensemble — the default window part since stop 31.** Training adds
//! every recording's mirror image, but a single network is still only *nearly* symmetric, and
//! its seed moves its accuracy by several points. `WindowTrainConfig::mirror_average`
//! (`train_window`) merges every fitted network with its own mirror image
//! (`train_window::mirrored_net`: inputs permuted by the layout's mirror permutation, found from
//! the taxel coordinates, outputs by [`DosClass::mirrored`]), so a mirrored recording gets
//! exactly the mirrored posterior — the window model becomes symmetric by construction, as the
//! Student-t model is — and three such pairs (seeds 1–3, mirror images and one random copy per
//! recording, the other settings unchanged) are merged into one network of 96 hidden units
//! (5 479 parameters). Inference and the file format are unchanged (levels inputs, one dense
//! network).
//!
//! *How it was chosen* (no figure outside a training set's own objects looked at before the one
//! held-out run): `dos_eval --window-inner`, leave-one-object-out inside basic and inside solids
//! only, per window (per recording in brackets):
//!
//! | window candidate | inside basic | inside solids |
//! |---|---|---|
//! | mirror images only, one net (the previous default's first candidate) | 60.6 % (59.5 %) | 65.4 % (67.9 %) |
//! | mirror images + one random copy, one net (its second) | 61.7 % (65.8 %) | 66.1 % (71.4 %) |
//! | mirror only, five members | 66.4 % (69.4 %) | 65.7 % (66.1 %) |
//! | two copies, gain 0.05, rotation 20° | 57.8 % (59.5 %) | 65.0 % (67.9 %) |
//! | mirror only, 32 hidden, weight decay 1e-3 | 61.4 % (64.9 %) | 63.3 % (64.3 %) |
//! | mirror only, 10-frame windows (not the published protocol) | 62.5 % (64.9 %) | 60.6 % (64.3 %) |
//! | mirror only, mirror-averaged | 61.9 % (64.0 %) | 63.3 % (64.3 %) |
//! | one copy, mirror-averaged | 64.3 % (69.4 %) | 65.2 % (69.6 %) |
//! | mirror only, five members, mirror-averaged | 65.7 % (69.4 %) | 67.4 % (69.6 %) |
//! | mirror only, three members, mirror-averaged | 64.9 % (67.6 %) | 67.6 % (69.6 %) |
//! | **one copy, three members, mirror-averaged (chosen)** | **66.0 % (69.4 %)** | **68.4 % (71.4 %)** |
//!
//! The chosen one is the best per window on both inner views; it is the only candidate (no
//! choice per fold), so `gradtac calibrate` fits it 7 times (≈ 30 s on the 167 recordings on the
//! loaded 2-core machine). As before, these inner folds are disjoint from the cross-set test
//! objects but overlap the nested protocol's outer test objects, so its nested figure is not
//! fully clean. **Held out, scored once** (`dos_eval --window-only`; the weight `a` chosen inside
//! every fold's training objects exactly as before):
//!
//! | per recording unless marked | nested leave-one-object-out | basic → solids | solids → basic | ConvLSTM protocol (basic → solids, per 5-frame window) |
//! |---|---|---|---|---|
//! | **combination with the mirror-averaged ensemble (default)** | **91.6 %** (153/167) | **92.9 %** (52/56) | **79.3 %** (88/111) | 85.9 % (2 643/3 076) |
//! | previous default combination (one net, choice between two candidates) | 88.0 % (147/167) | 89.3 % (50/56) | 78.4 % (87/111) | **86.2 %** (2 651/3 076) |
//! | mirror-averaged ensemble alone, vote | 79.0 % | 87.5 % | 69.4 % | with history 86.7 % |
//! | previous window model alone, vote | 77.2 % | 89.3 % | 66.7 % | with history 87.3 % |
//! | Student-t design alone | 80.2 % | 85.7 % | 66.7 % | 29.1 % |
//!
//! Weights chosen: 0.75 in six of eight folds, 0.5 for bottle and hd. Early answers of the
//! combination at 1 s into contact: basic → solids 83.9 % (47/56), solids → basic 76.6 %
//! (85/111) (previous default 85.7 % / 73.9 %); the ensemble's vote alone at 1 s 85.7 % / 68.5 %.
//! It gains 6 recordings nested, 2 basic → solids and 1 solids → basic, and loses 8 of 3 076
//! windows on the ConvLSTM protocol (still above the ConvLSTM's 82.56 %). The `dos` stage
//! decides as the combination on 334 of 334 held-out recordings; per frame median 0.23 µs,
//! p99 4.6 µs (one decision per recording); in the sliding mode (250 frames, hop 10) p99 45 µs
//! against 35 µs for the Student-t part alone (the net windows are cached, as before). Since
//! the sliding mode prepares each decision's replay a share per frame ahead of it
//! ([`DosClassifier`]), those are 8.5 µs and 6.6 µs (`examples/dos_sliding_cost`).
//!
//! After that run (so informed by it, and disclosed) six variants of the chosen candidate were
//! looked at on the same inner views only, per window inside basic / inside solids: itself
//! 66.0 / 68.4 %, five members 65.7 / 68.5 %, two random copies 60.9 / 68.5 %, weight decay 1e-3
//! 61.7 / 67.5 %, 24 hidden 64.0 / 64.9 %, 30 epochs 66.5 / 69.4 %. The last is above the chosen
//! one on both views by 0.5 and 1.0 points (34 and 32 windows, inside the seed noise); it was
//! neither scored held out nor adopted.
//!
//! *Not reached: solids → basic ≥ 85 %* (79.3 %). The case object is still 17/28; the other
//! three basic objects are at 85.5 % (71/83). The errors stay rotational: `cw→aw` 5, `s→aw` 5,
//! `cw→s` 2, `n→aw` 2, `n→cw` 2, `t→s` 2, `w→cw` 2 and three single ones (of 23 errors, 11
//! decide a rotation for a translation and 6 the wrong rotation). Symmetry removes the side bias a
//! two-object training set can teach, not the rotation–translation confusion of an object the
//! training set has no counterpart of.
//!
//! **Motion inputs about the contact's own centre (stop 31's `rot`; opt-in then, the default
//! since the rule below).**
//! `WindowNetConfig::motion` adds four causal inputs to the window net (see the `window` module
//! docs): the drift of the contact's weighted centre since the span's first 0.1 s in contact
//! radii (x, y), the turn of the contact's principal axis (`Im(z·z̄_r)/(tr·tr_r)`, a ratio of
//! second moments: size and a common gain/offset cancel) and the rotation's share of the motion.
//! Aimed at the rotation-for-translation errors above. *Rule, written down before any run:*
//! candidates the default (three mirror-averaged members) and the same with `motion`, nothing
//! else; scored by `dos_eval --window-inner --window-candidates
//! examples/dos_eval_parts/motion_candidates.json` (leave-one-object-out inside basic and inside
//! solids only); adopted only if higher per window inside **both** sets and **not lower per
//! recording in either**; otherwise opt-in, no held-out run. Inner folds, per window (per
//! recording in brackets):
//!
//! | window candidate | inside basic | inside solids |
//! |---|---|---|
//! | default (three mirror-averaged members) | 66.0 % (69.4 %, 77/111) | 68.4 % (71.4 %, 40/56) |
//! | default + motion inputs | 66.8 % (68.5 %, 76/111) | **76.7 %** (**78.6 %**, 44/56) |
//! | (first version, defective: weights `|dev_i|` and an undamped share; see below) | 63.7 % (64.9 %) | 68.9 % (71.4 %) |
//!
//! Inside solids (what the solids → basic training chooses on; two folds, bottle ↔ cardboard)
//! the motion inputs gain 8.3 points per window and 4 recordings; inside basic they gain
//! 0.8 points per window but lose one recording (76 against 77 of 111), so by the rule stated
//! beforehand they are **not adopted** and **no held-out figure was scored** — the default
//! `gradtac calibrate` output, the held-out figures above and the `dos_eval` floors are
//! unchanged. The first version weighted every taxel by `|dev_i|` (the taxels below the mean
//! level too, which makes most contacts look round) and divided by the motion with no floor
//! (rounding noise on a still contact gave a share of 0.11); both were found by the unit test
//! on a synthetic turning and shifting blob, not by an inner score, and fixed before the second
//! inner run (the only one of the fixed feature). Overlap: the inner folds are disjoint from the
//! cross-set test objects but overlap the nested protocol's outer test objects. Not measured:
//! the held-out figures. Cost (`cargo run --release --example window_motion_cost`, synthetic
//! frames, a 96-unit net, the loaded 2-core machine): p99 3.78 µs per frame with the motion
//! inputs against 3.28 µs without (median 0.13 / 0.12 µs). The
//! inside-solids gain is the strongest signal any window candidate has shown on that view; a
//! next stop that wants it held out must state its own rule before scoring it.
//!
//! **Stop 32: the motion inputs judged by a rule on the inner views, then held out.**
//! *Selection rule, written and committed before any run of this stop — and after the inner
//! figures of the two candidates above were seen (they are tuning data; the rule was written
//! knowing them, so it is not blind to them).* Inner views only: `dos_eval --window-inner`,
//! leave-one-object-out inside basic (4 folds, 111 recordings) and inside solids (2 folds, 56
//! recordings); no figure on an object outside the training set of a cross-set protocol is
//! looked at for the choice.
//! - Pool: (0) the default (three mirror-averaged members), (1) the default + motion inputs
//!   (reference 10 frames) — both already scored, figures above, not re-run — and two more,
//!   each scored once on the inner views
//!   (`examples/dos_eval_parts/motion_round2_candidates.json`): (2) motion inputs with a
//!   0.25 s reference span (`reference_frames = 25`), (3) motion inputs with two random
//!   copies per recording instead of one (more of the copies' layout rotation ≤ 10°, time
//!   warp, speed, noise, dropout, vibration and per-taxel gain/offset).
//! - Excluded: a candidate with more than **2** recordings fewer than the default in either
//!   inner view.
//! - Winner: the most recordings right summed over both inner views (of 167); ties to the
//!   higher mean of the two per-window accuracies; then to the earlier in the pool. The default
//!   stays if nothing beats it.
//! - The winner, if not the default, is scored held out **once** (`dos_eval --window-only`
//!   with it as the only window candidate: nested leave-one-object-out, basic → solids,
//!   solids → basic, the ConvLSTM protocol) and becomes the default of `gradtac calibrate dos`
//!   — unless that one run puts a target already met under its bound (nested ≥ 85 %,
//!   basic → solids ≥ 85 %, ConvLSTM protocol ≥ 82.6 %): a guard, not a choice; the
//!   solids → basic figure is reported whatever it is and decides nothing.
//! - Disclosed in advance: with motion inputs a window's input also holds a summary of the
//!   contact's first `reference_frames` frames (the reference of the drift and the turn), so its
//!   "per 5-frame window" figure is the window plus that reference, not the window alone.
//!
//! *Inner views* (`dos_eval --window-inner --window-candidates
//! examples/dos_eval_parts/motion_round2_candidates.json`, 18 s on the loaded machine; per
//! window, per recording in brackets):
//!
//! | window candidate | inside basic | inside solids | recordings, both views | mean per window |
//! |---|---|---|---|---|
//! | (0) default (stop 31) | 66.0 % (77/111) | 68.4 % (40/56) | 117 | 67.2 % |
//! | **(1) + motion inputs, reference 10 frames** | **66.8 %** (76/111) | **76.7 %** (44/56) | **120** | **71.8 %** |
//! | (2) + motion inputs, reference 25 frames | 65.5 % (73/111) | 75.0 % (44/56) | 117 (excluded: −4 inside basic) | 70.2 % |
//! | (3) + motion inputs, two random copies | 65.1 % (75/111) | 75.9 % (44/56) | 119 | 70.5 % |
//!
//! By the rule, **(1) wins** (120 recordings; it loses one inside basic, within the 2 allowed).
//! Candidate (1) was then scored held out once (`dos_eval --window-only --window-candidates
//! examples/dos_eval_parts/motion_only.json`, the winner as the only window candidate).
//!
//! **Held out, scored once — the default of `gradtac calibrate dos` in stops 32–33** (the weight
//! `a` chosen inside every fold's training objects exactly as before; one window candidate, so
//! no window choice per fold; 4 min 5 s for the whole `--window-only` run on the loaded
//! machine):
//!
//! | per recording unless marked | nested leave-one-object-out | basic → solids | **solids → basic** | ConvLSTM protocol (basic → solids, per 5-frame window) |
//! |---|---|---|---|---|
//! | **combination with the motion ensemble (default)** | **88.6 %** (148/167) | **94.6 %** (53/56) | **78.4 %** (87/111) | 86.6 % (2 664/3 076) ² |
//! | combination with stop 31's ensemble (no motion inputs) | 91.6 % (153/167) | 92.9 % (52/56) | 79.3 % (88/111) | 85.9 % (2 643/3 076) |
//! | motion ensemble alone, vote | 83.2 % (139/167) | 89.3 % (50/56) | 72.1 % (80/111) | with history 88.3 % (2 716/3 076) |
//! | stop 31's ensemble alone, vote | 79.0 % | 87.5 % | 69.4 % | with history 86.7 % |
//! | motion ensemble, per 5-frame window | 78.5 % (7 201/9 170) | 86.6 % | 70.0 % (4 267/6 094) | — |
//! | Student-t design alone (the baseline of this table) | 80.2 % | 85.7 % | 66.7 % | 29.1 % |
//!
//! ² The window and, as the motion inputs' reference, the contact's first 0.1 s (declared in
//! the rule above): not the window alone. The window-alone figure of the published protocol
//! is stop 31's 85.9 %.
//!
//! Weights chosen: 0.75 in five of the six nested folds, 0.5 for hd and in both cross-set
//! trainings. Early answers of the combination at 1 s into contact: basic → solids 89.3 %
//! (50/56), solids → basic 77.5 % (86/111) (stop 31: 83.9 % / 76.6 %); the vote alone at 1 s
//! 87.5 % / 71.2 %. Solids → basic per test object: case 64.3 % (18/28), hd 85.7 % (24/28),
//! pen 81.5 % (22/27), sponge 82.1 % (23/28); errors true → decided `cw→aw` 6, `aw→cw` 3,
//! `n→cw` 2, `s→aw` 2, `t→s` 2 and nine single ones: 7 of 24 decide a rotation for a
//! translation (11 of 23 before), 9 the wrong rotation sense (6 before). The motion inputs moved
//! errors from rotation-for-translation to rotation-sense, and lost 5 recordings nested and 1
//! solids → basic while gaining 1 basic → solids and 8 windows per window on the ConvLSTM
//! protocol: **held out it is not better than stop 31's default**; it is the default because
//! the rule stated beforehand picked it and its guard (no met target lost) held — no held-out
//! figure was used to choose. `gradtac calibrate --no-window-motion` gives stop 31's net.
//!
//! *Not reached: solids → basic ≥ 85 %* (78.4 %); the other targets still hold (nested 88.6 %,
//! basic → solids 94.6 %, ConvLSTM protocol 86.6 % ≥ 82.6 %). The inner view inside solids
//! (+8.3 points per window, what the solids → basic training sees) did not carry over to the
//! basic test objects: learned on two solid objects, the drift and the turn of a contact do not
//! look the same on the case. Cost: one decision per recording through the `dos` stage p99
//! 5.38 µs per frame (median 0.25 µs; 92 330 frames); the vote alone p99 5.03 µs;
//! `window_motion_cost` (synthetic, 96 hidden) p99 3.88 µs against 3.35 µs without motion.
//! **The sliding mode (250 frames, hop 10)** was p99 136 µs per frame with the motion inputs
//! when each decision frame did its whole window (45 µs with stop 31's net; the Student-t part
//! alone 36 µs, already over 20 µs): the reference moves with the replayed window, so every
//! decision recomputes the motion inputs of all its ~50 net windows. The stage keeps each net
//! window's level-input hidden sums and deviations across decisions and recomputes only the
//! four motion inputs, the `tanh` layer and the outputs (238 µs p99 before that cache, measured
//! in the held-out run above); and it does that work, and the Student-t replay, a share per
//! frame ahead of each decision ([`DosClassifier`]): **p99 20.4–20.8 µs per frame** with the
//! window part, 6.2–6.3 µs Student-t alone (`examples/dos_sliding_cost` on the 167 development
//! recordings, two runs at load ≈ 4; the model from `gradtac calibrate dos`). With early
//! answers every 5 frames the work per frame doubles: p99 36.6 µs (12.2 µs Student-t alone).
//! Decisions bit-identical throughout (tested). Training on all 167 recordings: 3.7–6.1 s (one fit; 5 871
//! parameters); `gradtac calibrate dos` on them 20 s (release, load ≈ 5 on the 2-core machine;
//! chose `a` = 0.5: 139 / 144 / 151 / 149 / 139 of 167 for a = 0 / 0.25 / 0.5 / 0.75 / 1,
//! in-sample for that choice; two runs byte-identical). The whole `dos_eval` (CI's step) passes
//! its floors in 5 min 3 s (the window part's held-out figures 26 s). Back to back on the same
//! loaded machine, `dos_eval --window-only` took 169 s with this default against 164 s with stop
//! 31's (re-run as a timing check, the same figures as before: 91.6 / 92.9 / 79.3 %).
//!
//! # Gradient-boosted trees ([`DosTrees`]) — the rule's winner of stop 33, held out once; the default since stop 34
//! [`DosTrees`] (module `trees`) is a window model like [`DosWindowNet`] — one answer per
//! non-overlapping 5-frame window, per recording (or since contact) the causal vote of the
//! windows' log posteriors ([`TreeVote`]) — whose classifier is a softmax ensemble of regression
//! trees over a **richer per-taxel time representation** ([`TreeExtractor`], causal): the window
//! net's inputs `both` with the motion inputs (76), each taxel's level pattern now minus 6 and 20
//! windows earlier (0.3 s and 1 s; 48) and the mean change across the window over the last 6
//! windows (24): 148 inputs. Inference is a plain walk of arrays in this crate (no dependency),
//! validated on load (indices in range and after their parent, depth ≤ [`MAX_TREE_DEPTH`],
//! finite values; NaN goes right); with the model's mirror permutation it averages each window's
//! logits with its mirror image's, so a mirrored recording gets the mirrored posterior exactly.
//! The trainer (`train_trees`, feature `train`, hand-written: no crate had softmax boosting in a
//! stable, clearly licensed release, see its docs) reuses the window model's augmentation
//! (mirror images + one random copy: noise, speed and warp, dropout, rotation, vibration, per-taxel
//! gain and offset): 80 rounds × 7 trees of depth ≤ 4, learning rate 0.1, λ 1, 32 bins, half the
//! rows per round — set before any figure. Fit on all 167 recordings 3.3–5.0 s (release, load ≈ 9
//! on the 2-core machine).
//!
//! *Rule* (`examples/dos_eval_parts/trees_rule.md`, committed before any figure of a tree model):
//! only the inner views decide (leave-one-object-out inside basic and inside solids, per recording
//! = the window model's vote alone); most recordings right over both wins; a candidate losing more
//! than 2 recordings in either view against the current default is excluded; the winner scored
//! held out once; adopted only if no met target falls under its bound. `examples/dos_trees`
//! (its output in `examples/dos_eval_parts/trees_inner_views.txt`, 40 s):
//!
//! | window candidate (inner views only) | inside basic, per window | per recording | inside solids, per window | per recording | both |
//! |---|---|---|---|---|---|
//! | current default window part (the motion ensemble, re-run) | 66.8 % | 76/111 | 76.7 % | 44/56 | 120 |
//! | **T1: trees, 148 inputs (winner)** | **80.6 %** | **94/111** | 73.9 % | 44/56 | **138** |
//! | T2: trees, the 76 window inputs only | 77.6 % | 93/111 | 73.4 % | 43/56 | 136 |
//!
//! **Held out, scored once** (`dos_trees --held-out examples/dos_eval_parts/trees_t1.json`, output
//! in `examples/dos_eval_parts/trees_held_out.txt`, 417 s; the combination with the Student-t
//! design exactly as the window net's: Student-t candidate chosen per fold by its own procedure,
//! `a` ∈ {0, 0.25, 0.5, 0.75, 1} by leave-one-object-out per recording inside the training
//! objects with both models refitted):
//!
//! | per recording unless marked | nested leave-one-object-out | basic → solids | solids → basic | ConvLSTM protocol (basic → solids, per 5-frame window) |
//! |---|---|---|---|---|
//! | **combination with T1** | **89.2 %** (149/167) | 91.1 % (51/56) | **79.3 %** (88/111) | **90.0 %** (2 769/3 076) ³; with the causal history (the vote) 90.0 % (2 768) |
//! | T1 alone, vote | 88.0 % (147/167) | 91.1 % (51/56) | 83.8 % (93/111) | — |
//! | T1 alone, per 5-frame window | 85.3 % | 90.0 % | 80.1 % | — |
//! | combination with the motion ensemble (the default, stop 32's figures) | 88.6 % (148/167) | **94.6 %** (53/56) | 78.4 % (87/111) | 86.6 % ² |
//! | Student-t design alone (baseline, re-run) | 80.2 % | 85.7 % | 66.7 % | 29.1 % |
//!
//! ³ The window and the causal history its inputs hold (the contact's first 0.1 s, the level
//! pattern 0.3 s and 1 s earlier, the last 0.3 s of changes): not the window alone.
//!
//! Weights chosen: 0.25–0.5 nested, 0.5 basic → solids, 0.75 solids → basic. Early answers at 1 s
//! into contact: combination 89.3 % (50/56) basic → solids, 78.4 % (87/111) solids → basic (the
//! default: 89.3 / 77.5 %); T1's vote alone 89.3 / 81.1 %. Solids → basic per test object: case
//! 75.0 %, hd 89.3 %, pen 70.4 %, sponge 82.1 %; 11 of its 23 errors are the rotation sense
//! (`cw→aw` 8, `aw→cw` 3). **Against the default:** +1 recording nested, −2 basic → solids, +1
//! solids → basic, +105 windows on the ConvLSTM protocol: not clearly better held out; every met
//! target stays met (nested ≥ 85 %, basic → solids ≥ 85 %, ConvLSTM ≥ 82.6 %), so by its rule it
//! qualifies as the default. Solids → basic ≥ 85 % is still not reached (79.3 %; the trees alone
//! reach 83.8 % there, but the rule scores the combination, and that observation chose nothing).
//!
//! **The default since stop 34.** A model file may carry a tree part ([`DosTreesPart`]: the
//! trees and the weight `a`; exclusive with the window net's [`DosWindowPart`]), which
//! `gradtac calibrate dos` writes by default (`--window-net` writes the net instead; the same
//! procedure as the net's: `a` by leave-one-object-out per recording, then the trees fitted on
//! all; 21–42 s on the 167 recordings, release, load 3–7 on 2 cores; it chose `a` = 0.5, as
//! the held-out run's basic → solids fold did) and the `dos` stage runs in every mode. Stop 33
//! left it an option because the stage's sliding mode refused it (a replay of ~50 windows × 1 120
//! tree walks per decision); stop 34 built the sliding mode for it — its tree windows are
//! counted from the contact and each is computed once, not replayed (exact semantics and the
//! measured agreement with a fresh replay: [`DosClassifier`]) — and halved the walk's cost
//! (16-byte nodes, `trees` source file). Cost per frame (`examples/dos_sliding_cost`, 46 165
//! frames, load ≈ 6–7 on 2 cores; the trees' vote alone, one decision per recording: p99 7.0 µs,
//! stop 33 17.5–17.9 µs):
//!
//! | mode | trees: median | p99 | window net (stop 32's default), same run: p99 |
//! |---|---|---|---|
//! | sliding, last 250 frames, hop 10 | 0.57 µs | **9.7 µs** (load ≈ 3.5: 9.0 µs) | 20.9 µs (load ≈ 3.5: 19.7 µs) |
//! | sliding, 250 frames, hop 10, early answers | 3.8 µs | 9.7 µs | — |
//! | sliding, last 100 frames, hop 10 | 2.2 µs | 9.6 µs | — |
//! | one decision per recording (`dos_trees --cost-only`, load ≈ 3) | 0.26 µs | 7.7 µs (stop 33: 17.9 µs) | 5.4 µs (stop 32) |
//!
//! Reproduced with the default (stop 34): `dos_trees --held-out
//! examples/dos_eval_parts/trees_t1.json` printed every figure of the table above unchanged
//! (the walk's new layout is bit-identical); `dos_eval` (CI) runs the default's cross-set splits
//! and the ConvLSTM protocol with floors 87 / 76 / 87 % (measured 91.1 / 79.3 / 90.0 %;
//! `--trees-nested` adds the nested figure, floor 86 %, measured 89.2 % — reproduced by
//! `dos_eval --trees-only --trees-nested`, 367 s at load ≈ 7–8, so ≈ 4–6 min more, not in CI)
//! and the sliding mode's p99 per frame with the default's parts (printed beside the 20 µs bound, not enforced; measured 9.71
//! µs). The tree section adds 16 s (held-out part alone) to 41 s (with the cost check: a fit
//! on all recordings and 46 165 timed frames) to `dos_eval`, whose whole run took 6 min 18 s
//! with the 16 s version (wall, load ≈ 8 on 2 cores; ≈ 6 min 2 s without it). This reproduces
//! the choice already made by the rule; nothing was chosen on it.
//!
//! **Round 2 (stop 34): T4, regularised trees, the default in stop 34 (since stop 35: T9,
//! below).** Rule and candidates in `examples/dos_eval_parts/trees_rule_round2.md` (committed
//! before any figure of them): stop 33's rule with T1 as the baseline re-run; candidates aimed at transfer from few training objects —
//! T3 object-level augmentation (3 copies, per-taxel gain 0.15, offset 0.3), T4 regularisation
//! (60 rounds, depth ≤ 3, λ 5, minimum hessian 5), T5 offset-invariant inputs (`since_start` +
//! motion + slope, 76), T6 T3's augmentation with speed 1.5, warp 0.2, dropout 0.1, rotation 20°.
//! Inner views (`trees_round2_inner_views.txt`, per recording, inside basic + inside solids): T1
//! 94 + 44 = 138 (reproduced), T3 91 + 45 = 136 (excluded), **T4 94 + 46 = 140**, T5 80 + 40 = 120
//! (excluded), T6 96 + 44 = 140 (T4 wins the tie on mean per-window accuracy, 77.9 against 76.1 %).
//! Held out once (`dos_trees --held-out examples/dos_eval_parts/trees_t4.json`,
//! `trees_round2_held_out.txt`), combination with T4: nested **89.2 %** (149/167), basic → solids
//! **92.9 %** (52/56), solids → basic **82.0 %** (91/111; T1 79.3 %, target 85 % still not met),
//! ConvLSTM protocol **89.0 %** (2 738/3 076; with the causal vote 88.3 %); at 1 s 89.3 / 81.1 %;
//! T4's vote alone 88.6 / 91.1 / 87.4 % (observed, nothing chosen on it). Every met target stays
//! met and the sliding mode's p99 is 7.6 µs (`dos_eval --trees-only --trees-nested`, which
//! reproduces every figure), so by the rule T4 is `train_trees::TreeTrainConfig::default()` and
//! `gradtac calibrate dos`'s tree part (420 trees, ≈ 5 000 nodes against T1's 11 556; fit 2.0 s).
//! `dos_eval`'s floors follow: 86 / 89 / 79 / 86 % (nested / basic → solids / solids → basic /
//! ConvLSTM). The T1 figures above are kept as stop 33's record.
//!
//! **Round 3 (stop 35): T9, object-imprint augmentation, the default until round 4.** Rule and candidates in
//! `examples/dos_eval_parts/trees_rule_round3.md` (committed before any figure of them): round
//! 2's rule with T4 as the baseline re-run; every augmentation the issue names (mirror, rotation,
//! vibration added/removed, per-taxel gain/offset, noise, speed/warp, dropout) was already in T4,
//! so the candidates are T7 input subsampling per tree (`train_trees::TreeTrainConfig::colsample`
//! 0.5), T8 richer lags of the level pattern (2, 6, 20, 60 windows: 196 inputs) and T9 an
//! **object imprint** on two random copies per recording (`train_window::imprint`: a static
//! smooth bump over neighbouring taxels, spread 0.5 of the level spread, width 3–8 mm). Inner
//! views (`trees_round3_inner_views.txt`, per recording, inside basic + inside solids): T4 94 +
//! 46 = 140 (reproduced), T7 97 + 46 = 143, T8 97 + 44 = 141, **T9 99 + 45 = 144** (mean per
//! window 79.4 % against 77.9 %). Held out once (`dos_trees --held-out
//! examples/dos_eval_parts/trees_t9.json`, `trees_round3_held_out.txt`), combination with T9
//! (T4 in brackets): nested **89.8 %** (150/167; 89.2), basic → solids **92.9 %** (52/56; 92.9),
//! solids → basic **82.9 %** (92/111; 82.0 — target 85 % still not met), ConvLSTM protocol
//! **89.5 %** (2 753/3 076; 89.0), with the causal vote 88.0 % (88.3); at 1 s 91.1 / 81.1 %
//! (89.3 / 81.1). T9's vote alone 89.8 / 91.1 / 83.8 % (T4's 88.6 / 91.1 / 87.4: observed,
//! nothing chosen on either). Every met target stays met; `gradtac calibrate dos` takes 24 s on
//! the 167 recordings (release, load ≈ 3.5 on 2 cores; 420 trees, 5 252 nodes) and the sliding
//! mode's p99 is 7.5 µs per frame (`dos_sliding_cost`, 250 frames, hop 10), so by the rule T9 is
//! `TreeTrainConfig::default()` (T4 with `augment.copies` 2 and `augment.imprint` 0.5; the
//! window net's `WindowAugment::default()` is unchanged). `dos_eval`'s floors follow: 87 / 89 /
//! 80 / 87 %.
//!
//! **Round 4 (stop 35): T12, rotation-sense inputs and input subsampling, the default.** Rule,
//! candidates and a diagnosis in `examples/dos_eval_parts/trees_rule_round4.md` (committed
//! before any figure of them). Diagnosis on the inner views (`examples/dos_trees_diag.rs`,
//! `trees_round4_diagnosis.txt`): of T9's 23 inner errors 8 are `cw ↔ aw` and 9 a stable touch
//! decided as a slip; the turn of the principal axis (the one rotation input) has the class's
//! sign on 31 of 48 rotation recordings. Candidates, each T9 plus: T10 `colsample` 0.5, T11 the
//! **rotation-sense inputs** ([`TreeInputs::turn`]: the rigid motion `(vx, vy, θ)` of the level
//! pattern fitted to each lag's change and to the slope, 9 inputs), T12 both. Inner views
//! (`trees_round4_inner_views.txt`): T9 99 + 45 = 144 (reproduced; 79.4 % per window), T10 97 +
//! 47 = 144 (79.4 %), T11 99 + 45 = 144 (79.6 %), **T12 98 + 46 = 144 (79.9 %)**: T12 wins on
//! the tie-break. Held out once (`dos_trees --held-out examples/dos_eval_parts/trees_t12.json`,
//! `trees_round4_held_out.txt`), combination with T12 (T9 in brackets): nested **89.2 %**
//! (149/167; 89.8), basic → solids **91.1 %** (51/56; 92.9), solids → basic **81.1 %** (90/111;
//! 82.9 — target 85 % still not met), ConvLSTM protocol **88.7 %** (2 728/3 076; 89.5), with the
//! causal vote 89.7 % (88.0); at 1 s 85.7 / 82.0 % (91.1 / 81.1). T12's vote alone 91.6 / 92.9 /
//! 82.9 % (T9's 89.8 / 91.1 / 83.8: observed, nothing chosen on either). Held out T12 is a little
//! worse than T9 on every combined figure; every met target stays met, `gradtac calibrate dos`
//! takes 19.5 s on the 167 recordings (420 trees, 5 420 nodes) and the sliding mode's p99 is
//! 8.2 µs per frame (`dos_sliding_cost`), so by the rule stated beforehand T12 is
//! `TreeTrainConfig::default()` (T9 with `inputs.turn` and `colsample` 0.5). `dos_eval`'s floors
//! follow: 87 / 87 / 79 / 86 %.
//!
//! **Round 5 (stop 35): T13, change-energy inputs, the default.** Rule, candidate and diagnosis
//! in `examples/dos_eval_parts/trees_rule_round5.md` (committed before any figure of T13).
//! Diagnosis on the inner views (`dos_trees_diag`, `trees_round5_diagnosis.txt`): of T12's 23
//! inner errors 8 are a stable touch decided as a slip (sponge 3, bottle 2, cardboard 3); such a
//! touch is misread in every third of the recording (not while the object settles), and — per
//! taxel only — the trees cannot see that the whole pattern hardly moved, while the root mean
//! square over the taxels of each change block is 2.6–9× lower on touches than on slips on every
//! object. Candidate T13 = T12 + the **change-energy inputs** ([`TreeInputs::energy`]: that RMS
//! of the lag-6 and lag-20 changes, the slope and the since-start pattern; 4 inputs). Inner
//! views (`trees_round5_inner_views.txt`): T12 98 + 46 = 144 (reproduced; 79.9 % per window),
//! **T13 98 + 48 = 146 (81.9 %)**: T13 wins. Held out once (`dos_trees --held-out
//! examples/dos_eval_parts/trees_t13.json`, `trees_round5_held_out.txt`), combination with T13
//! (T12 in brackets): nested **88.6 %** (148/167; 89.2), basic → solids **91.1 %** (51/56;
//! 91.1), solids → basic **82.9 %** (92/111; 81.1 — target 85 % still not met), ConvLSTM
//! protocol **89.7 %** (2 758/3 076; 88.7), with the causal vote 89.9 % (89.7); at 1 s 89.3 /
//! 84.7 % (85.7 / 82.0). T13's vote alone 89.2 / 91.1 / 83.8 % (observed, nothing chosen on
//! it). Every met target stays met; `gradtac calibrate dos` takes 27.1 s on the 167 recordings
//! (420 trees, 5 404 nodes; it chose `a` = 0.25) and the sliding mode's p99 is 8.07 µs per
//! frame (`dos_sliding_cost`), so by the rule T13 is `TreeTrainConfig::default()` (T12 with
//! `inputs.energy`). `dos_eval`'s floors follow: 86 / 87 / 80 / 87 %. Looked at after the
//! choice (inner views, `trees_round5_t13_diagnosis.txt`): T13's two recordings come from the
//! bottle's rotations (`aw → t` 2, `cw → s` 1 fixed), not from the touches — 9 inner touches are
//! still read as slips (T12: 8), the sponge's and the bottle's in every window; that group stays
//! open.
//!
//! **Round 6 (stop 36): T15, the flow fitted with a dilation, the default.** Rule, candidates and
//! diagnosis in `examples/dos_eval_parts/trees_rule_round6.md` (committed before any figure of
//! a candidate). Diagnosis without a model (`dos_trees_diag`, `trees_round6_diagnosis.txt`): T13's
//! fitted turn `θ` over lag 20 and of the slope has the class's sign on exactly 24 of 48 inner
//! rotations — no sense — because a spreading pattern (a press, creep) is not in the rigid
//! flow's model and leaks into it; fitted jointly with an isotropic dilation about the contact's
//! centre, `θ`'s sign agrees on 35/48. *(Corrected in round 7: the 24/48 was read from the wrong
//! columns — the diagnosis assumed the turn block came last, but the change-energy inputs follow
//! it. Read right, T13's `θ` over lag 20 is negative for `cw` and positive for `aw` on 33/48
//! rotations (T15's: 35/48), so the dilation added little sense; T15 was chosen on the inner views, which the bug did not touch.)* And the share of a change's energy that the rigid flow
//! explains is below the slips' median for 24/24 touches (sponge included), without the object's
//! stiffness. Candidates (each one change on T13): T14 + the **flow-share inputs**
//! (`flow_share`, 3; removed in stop 37, code at `e43beac`), T15 + the **dilation** ([`TreeInputs::dilation`]: the fit with
//! a fourth unknown, its `δ` as 3 inputs), T16 both. Inner views (`trees_round6_inner_views.txt`):
//! T13 98 + 48 = 146 (reproduced; 81.9 % per window), T14 97 + 50 = 147 (81.4 %), **T15 99 + 50 =
//! 149 (81.5 %)**, T16 98 + 50 = 148 (81.3 %): T15 wins. Held out once (`dos_trees --held-out
//! examples/dos_eval_parts/trees_t15.json`, `trees_round6_held_out.txt`), combination with T15
//! (T13 in brackets): nested **88.6 %** (148/167; 88.6), basic → solids **92.9 %** (52/56; 91.1),
//! solids → basic **82.9 %** (92/111; 82.9 — target 85 % still not met), ConvLSTM protocol
//! **90.6 %** (2 788/3 076; 89.7), with the causal vote 91.0 % (89.9); at 1 s 89.3 / 86.5 % (89.3 /
//! 84.7). T15's vote alone 89.2 / 92.9 / 83.8 %. Every met target stays met; `gradtac calibrate
//! dos` takes 38.9 s on the 167 recordings (420 trees, 5 376 nodes; it chose `a` = 0.25;
//! 2 cores shared with other runs) and the sliding mode's p99 is 8.84 µs per frame
//! (`dos_sliding_cost`), so by the rule T15 is `TreeTrainConfig::default()` (T13 with
//! `inputs.dilation`). `dos_eval`'s floors follow: 86 / 89 / 80 / 88 %. This stop's held-out
//! splits have now been scored by four rounds' winners; a gain of one or two recordings is within
//! what that can produce.
//!
//! **Round 7 (stop 36): no winner, T15 stays the default.** Rule, candidates and diagnosis in
//! `examples/dos_eval_parts/trees_rule_round7.md` (committed before any figure of a candidate).
//! First the diagnosis's column bug above was fixed (`trees_round7_t15_diagnosis.txt`,
//! `trees_round7_t13_diagnosis.txt`) and the rotation-sign convention checked (no label or axis
//! bug; see the class table below). Candidates (each one change on T15), aimed at transfer from
//! few training objects and at touches that keep settling (the sponge's touch since contact
//! exceeds its slips' smallest change): T17 four random copies per recording instead of two,
//! T18 an object imprint of spread 1.0 instead of 0.5, T19 the window inputs `levels` (no
//! since-start block). Inner views (`trees_round7_inner_views.txt`): T15 99 + 50 = 149
//! (reproduced; 81.5 % per window), T17 96 + 46 = 142 (excluded: −4 inside solids), T18 99 + 50 =
//! 149 (81.2 %: a tie on recordings, lower per window), T19 96 + 45 = 141 (excluded). None
//! strictly beats T15, so nothing was scored held out and the held-out figures stay round 6's.
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
//! With the default tree part: every 5 frames one window's 148 inputs and 2 × 560 tree walks; in
//! the sliding mode the kept windows' log posteriors (≤ `n`/5 × 7 values) and one sum of them per
//! decision — p99 9.7 µs per frame at 250 frames, hop 10 (table in the trees section; the
//! semantics in [`DosClassifier`]). No delay beyond the decision's own: a tree window counts once
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
//! | window part | the net ([`DosWindowPart`], `--window-net`): every decision a fresh replay; sliding p99 20.9 µs (loaded) | trees ([`DosTreesPart`], default): held out +1 nested / −2 basic → solids / +1 solids → basic recordings, +3.4 points on the ConvLSTM protocol; sliding p99 9.7 µs, its windows keep the contact's history |

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
