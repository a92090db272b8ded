#!/usr/bin/env bash
# The force table of docs/force.md on fewer members (--quick: 3 tuning, 4 held-out): CI checks
# the example runs end to end and that the default method (`placed`) keeps its held-out floors
# (worst member ≤ 65 %, mean ≤ 35 %, untouched frames above 0.5 N ≤ 15 %; measured session 30:
# 55.7 %, 34.1 %, 12.6 % — `total` measured 64.7 %, 28.1 %, 11.9 %; held-out seed 100 keeps
# contacts into its rests). ≈ 10 s after the release build the other checks made.
set -euo pipefail
cd "$(dirname "$0")/.."
echo "== force calibration, held-out places of held-out members (quick)"
cargo run --release --example force_eval -- --quick
