#!/usr/bin/env bash
# The force table of docs/force.md on fewer members (--quick: 3 tuning, 4 held-out): CI checks
# the example runs end to end and that the default method (`total`) keeps its held-out floors
# (worst member ≤ 75 %, mean ≤ 35 %, untouched frames above 0.5 N ≤ 15 %; measured with the
# force gate 64.7 %, 28.1 %, 11.9 % — held-out seed 100 keeps contacts into its rests; the
# session-29 gate measured 79.2 %, 32.5 %, 4.4 %). ≈ 10 s after the release build the other
# checks made.
set -euo pipefail
cd "$(dirname "$0")/.."
echo "== force calibration, held-out places of held-out members (quick)"
cargo run --release --example force_eval -- --quick
