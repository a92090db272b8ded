#!/usr/bin/env bash
# The learned bias correction's committed weights (gradtac-stages/src/fit_learned_weights.rs)
# are what examples/train_fit_correction.rs produces from simulated tuning physics (issue #22,
# round 6): re-trained and compared, every number within 1e-6 of the largest weight.
# ≈ 100 s on one core after the build (the release build is shared with the other examples).
set -euo pipefail
cd "$(dirname "$0")/.."
echo "== learned fit correction: weights reproduced from the training example"
cargo run --release --example train_fit_correction -- --check
