#!/usr/bin/env bash
# The force table of docs/force.md on fewer members (--quick: 3 tuning, 4 held-out): CI checks
# the example runs end to end and that the default method (`forward` with its guard, session 31)
# keeps its held-out floors (worst member ≤ 65 %, mean ≤ 35 %, untouched frames above 0.5 N ≤ 15 %;
# measured session 31: 55.7 %, 33.8 %, 12.1 % — seeds 100 and 102 fall back to the placed law,
# which measured 55.7 %, 34.1 %, 12.6 %; held-out seed 100 keeps contacts into its rests).
# ≈ 5 s after the release build the other checks made.
set -euo pipefail
cd "$(dirname "$0")/.."
echo "== force calibration, held-out places of held-out members (quick)"
cargo run --release --example force_eval -- --quick
