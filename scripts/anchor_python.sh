#!/usr/bin/env bash
# The Python anchor of the surface → maximal-contour step (scipy's LinearNDInterpolator or
# precomputed weights, then scikit-image's find_contours) on the window aggregates of a real
# recording, beside gradtac's own time for the same step.
#
#   scripts/anchor_python.sh [WINDOWS]      # default 300 windows timed in Python
#
# Makes a venv in $CARGO_TARGET_DIR/anchor-venv (or target/anchor-venv) with numpy, scipy,
# scikit-image and pyarrow; tiles ../shared/data/biotacsp-dos/aw/bottle0.csv 10 times; runs
# `gradtac run` with a fixed event threshold τ = 0.05 (the dense stress case of
# benches/chain.rs: nearly every window in contact) writing the window, surface and contour taps; then scripts/anchor_python.py times
# the Python step per window and checks that it finds the same contacts. gradtac's time for
# the same step is `cargo bench -p gradtac-stages --bench chain -- contour_of_window/real_dense/peak`.
# Skipped when the data is absent.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
data="${GRADTAC_SHARED_DATA:-$root/../shared/data}"
rec="$data/biotacsp-dos/aw/bottle0.csv"
if [ ! -f "$rec" ]; then
    echo "anchor_python: $rec not found; skipped"
    exit 0
fi
venv="${ANCHOR_VENV:-${CARGO_TARGET_DIR:-$root/target}/anchor-venv}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet numpy scipy scikit-image pyarrow
(cd "$root" && cargo build --release --quiet --bin gradtac)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python3 "$root/scripts/tile_csv.py" "$rec" "$tmp/tiled.csv" x10
cat > "$tmp/scene.toml" <<'TOML'
[[sensor]]
name = "ff"
layout = "biotac-sp"
source = { csv = "tiled.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }
[stages.locate]
method = "events"
event_tau_sigmas = 0.0
[stages.events]
threshold = 0.05
[[output]]
tap = "window"
path = "out/window.parquet"
[[output]]
tap = "surface"
path = "out/surface.parquet"
[[output]]
tap = "contour"
path = "out/contour.parquet"
TOML
"${CARGO_TARGET_DIR:-$root/target}/release/gradtac" run --quiet "$tmp/scene.toml"
"$venv/bin/python" -c 'import numpy, scipy, skimage; print(f"numpy {numpy.__version__}, scipy {scipy.__version__}, scikit-image {skimage.__version__}")'
"$venv/bin/python" "$root/scripts/anchor_python.py" "$tmp/out" "${1:-300}"
