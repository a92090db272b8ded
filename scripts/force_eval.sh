#!/usr/bin/env bash
# The force table of docs/force.md on fewer members (--quick: 3 tuning, 4 held-out), so CI
# checks the example runs end to end (≈ 10 s after the release build the other checks made).
set -euo pipefail
cd "$(dirname "$0")/.."
echo "== force calibration, held-out places of held-out members (quick)"
cargo run --release --example force_eval -- --quick
