#!/usr/bin/env bash
# CLI throughput on real data: one BioTacSP-DoS recording tiled to N frames (default 1,000,000),
# run to track points, written to Parquet, timed with /usr/bin/time; prints frames/s (wall
# and per CPU-second).
#
#   scripts/bench_cli_tiling.sh [GRADTAC_BINARY ...]
#
# Each contact-location method in METHODS (default "events centroid") is timed: `events` is
# the natural-neighbour event chain of a bare `method = "events"` (its default event_chain:
# Savitzky–Golay → press/release events → cumulative window → surface 32×32 → contour → track), `centroid` the default scene's chain, whose kernel is cheap, so its
# figure is mostly CSV reading, routing and Parquet writing. Every binary given is timed back
# to back on the same tiling (e.g. an old build and a new one), repeated REPEATS times
# (default 3) in turn; the median is printed per binary and method. Defaults:
# target/release/gradtac. Data: ../shared/data/biotacsp-dos/<RECORDING> beside the repository
# (RECORDING defaults to aw/bottle0.csv; GRADTAC_SHARED_DATA names another data directory);
# skipped when absent. FRAMES=… overrides the tiling length. With KEEP=1 the outputs stay in
# out/<method>-<k>/ of the temporary directory printed, for comparing binaries' outputs.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
data="${GRADTAC_SHARED_DATA:-$root/../shared/data}"
rec="$data/biotacsp-dos/${RECORDING:-aw/bottle0.csv}"
frames="${FRAMES:-1000000}"
repeats="${REPEATS:-3}"
methods="${METHODS:-events centroid}"
if [ ! -f "$rec" ]; then
    echo "bench_cli_tiling: $rec not found; skipped"
    exit 0
fi
bins=("$@")
[ ${#bins[@]} -eq 0 ] && bins=("$root/target/release/gradtac")
tmp=$(mktemp -d)
if [ "${KEEP:-0}" = 1 ]; then echo "outputs kept in $tmp"; else trap 'rm -rf "$tmp"' EXIT; fi
python3 "$root/scripts/tile_csv.py" "$rec" "$tmp/tiled.csv" "$frames"
for m in $methods; do
    cat > "$tmp/scene-$m.toml" <<TOML
[[sensor]]
name = "ff"
layout = "biotac-sp"
source = { csv = "tiled.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }
[stages.locate]
method = "$m"
[[output]]
tap = "track"
path = "out/$m/track.parquet"
TOML
done
echo "tiling: $rec × → $frames frames; load: $(cut -d' ' -f1-3 /proc/loadavg) on $(nproc) cores"
declare -A results
for r in $(seq 1 "$repeats"); do
    for m in $methods; do
        k=0
        for b in "${bins[@]}"; do
            k=$((k + 1))
            rm -rf "$tmp/out/$m"
            /usr/bin/time -f "%e %U %S" -o "$tmp/time.txt" "$b" run --quiet "$tmp/scene-$m.toml"
            if [ "${KEEP:-0}" = 1 ]; then rm -rf "$tmp/out/$m-$k"; mv "$tmp/out/$m" "$tmp/out/$m-$k"; fi
            read -r wall user sys < "$tmp/time.txt"
            line=$(python3 -c "import sys; w,u,s,n=map(float,sys.argv[1:]); print(f'{n/w:.0f} {n/(u+s):.0f} {w:.2f} {u+s:.2f}')" "$wall" "$user" "$sys" "$frames")
            echo "run $r $m $b: frames/s wall, frames/s per CPU-s, wall s, CPU s = $line (load $(cut -d' ' -f1 /proc/loadavg))"
            results["$m $b"]+="$line;"
        done
    done
done
for m in $methods; do
    for b in "${bins[@]}"; do
        python3 - "$m $b" "${results["$m $b"]}" <<'PY'
import sys, statistics
b, rows = sys.argv[1], [r.split() for r in sys.argv[2].split(";") if r]
wall = statistics.median(float(r[0]) for r in rows)
cpu = statistics.median(float(r[1]) for r in rows)
print(f"median {b}: {wall:.0f} frames/s wall, {cpu:.0f} frames/s per CPU-second ({len(rows)} runs)")
PY
    done
done
