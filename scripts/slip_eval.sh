#!/usr/bin/env bash
# Two-finger slip on the widened grasp family (examples/slip_eval.rs, the tables of the slip
# module docs): CI checks the default's held-out floors (seeds 1000..1100 × 5 classes, 500
# grasps; the simulator is deterministic) — at least 489/500 classes right, at most 0.35 false
# alarms per minute still, median |onset error| ≤ 48 ms, per start shape median ≤ 50 ms and
# mean signed within ±35 ms, the demo's slip class right with |onset error| ≤ 0.090 s, and the
# demo's slip events the same in either order of same-time frames. Measured stop 31b
# (`onset_fingers = "clear_earliest"`): 491/500, 0.27, 45 ms; step 44 / −33, linear 44 / +3,
# smooth 48 / +22 ms; demo −0.080 s (stop 31's `weighted`: 43 ms; 42 / −32, 44 / +11,
# 45 / +28 ms; −0.051 s). The issue's per-shape target, ≤ 30 ms and ±10 ms, is not met.
# ≈ 45–70 s after the release build the other checks made.
set -euo pipefail
cd "$(dirname "$0")/.."
echo "== two-finger slip on held-out grasps of the widened family (floors)"
cargo run --release --example slip_eval -- check
