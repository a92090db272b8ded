#!/usr/bin/env bash
# Benchmarks of issue #26 part 2 (a table on stdout; medians of RUNS runs, wall clock):
# 1. `gradtac run` of a 5-sensor scene over BioTacSP-DoS data (each sensor: all 167 recordings
#    concatenated, rotated per sensor; 46,165 frames per sensor) with --threads 1 vs all cores,
#    for the default chain (centroid → track) and the events chain (surface, contour → track);
# 2. `gradtac batch` of a one-sensor tracks scene over the 167 recordings vs a shell loop of
#    `gradtac run`, one per recording (the same outputs, one file per recording).
# Needs ../shared/data/biotacsp-dos. Builds the release binary.
#
#   scripts/bench_batch.sh            # RUNS=3 by default
set -euo pipefail
cd "$(dirname "$0")/.."
runs="${RUNS:-3}"
dos="$(pwd)/../shared/data/biotacsp-dos"
[ -d "$dos" ] || { echo "needs $dos"; exit 1; }
bin="${GRADTAC_BIN:-}"
if [ -z "$bin" ]; then
    cargo build --release --quiet
    bin="$(pwd)/${CARGO_TARGET_DIR:-target}/release/gradtac"
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cores=$(nproc)

# median wall-clock seconds of `runs` runs of "$@" (each after `prep`, not timed)
median() {
    local prep="$1"; shift
    local times=()
    for _ in $(seq "$runs"); do
        eval "$prep"
        local t0 t1
        t0=$(date +%s.%N)
        "$@" > /dev/null
        t1=$(date +%s.%N)
        times+=("$(echo "$t1 - $t0" | bc -l)")
    done
    printf '%s\n' "${times[@]}" | sort -g | awk '{a[NR]=$1} END {m = (NR % 2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2; printf "%.3f", m}'
}

python3 scripts/multi_sensor_csv.py "$dos" "$tmp/five.csv" 5 > /dev/null
frames=$(( ($(wc -l < "$tmp/five.csv") - 1) * 5 ))
for chain in centroid events; do
    {
        for s in 1 2 3 4 5; do
            printf '[[sensor]]\nname = "s%d"\nsource = { csv = "five.csv", columns = "s%d_e{1..24}", rate_hz = 100.0 }\n' $s $s
        done
        [ $chain = events ] && printf '[stages.locate]\nmethod = "events"\n'
        printf '[[output]]\ntap = "track"\npath = "out/tracks.parquet"\n'
    } > "$tmp/$chain.toml"
done

echo "machine: $cores cores (shared: load average $(cut -d' ' -f1-3 /proc/loadavg)); medians of $runs runs, wall clock"
echo
echo "| gradtac run, 5 sensors × $((frames / 5)) frames | --threads 1 (s) | --threads $cores (s) | speed-up |"
echo "|---|---|---|---|"
for chain in centroid events; do
    one=$(median "rm -rf $tmp/out" "$bin" run --quiet --threads 1 "$tmp/$chain.toml")
    cmp_dir="$tmp/out-1"; rm -rf "$cmp_dir"; mv "$tmp/out" "$cmp_dir"
    all=$(median "rm -rf $tmp/out" "$bin" run --quiet --threads "$cores" "$tmp/$chain.toml")
    cmp "$cmp_dir/tracks.parquet" "$tmp/out/tracks.parquet"
    echo "| $chain chain → tracks | $one | $all | $(echo "$one / $all" | bc -l | xargs printf '%.2f') |"
done

# batch vs a shell loop of run
cat > "$tmp/one.toml" <<'TOML'
[[sensor]]
name = "ff"
source = { csv = "RECORDING", columns = "ff_e{1..24}", rate_hz = 100.0 }
[[output]]
tap = "track"
path = "OUT"
TOML
mkdir -p "$tmp/loop-scenes"
n=0
for f in "$dos"/*/*.csv; do
    stem=$(basename "$f" .csv)
    sed -e "s|RECORDING|$f|" -e "s|OUT|$tmp/loop/$stem.parquet|" "$tmp/one.toml" > "$tmp/loop-scenes/$stem.toml"
    n=$((n + 1))
done
loop() { for sc in "$tmp"/loop-scenes/*.toml; do "$bin" run --quiet --threads 1 "$sc"; done; }
batch_scene="$tmp/batch.toml"
sed -e "s|RECORDING|any.csv|" -e "s|OUT|out/tracks.parquet|" "$tmp/one.toml" > "$batch_scene"
t_loop=$(median "rm -rf $tmp/loop" loop)
t_b1=$(median "rm -rf $tmp/arch" "$bin" batch --quiet "$batch_scene" "$dos/*/*.csv" --out "$tmp/arch" --jobs 1)
t_bn=$(median "rm -rf $tmp/arch" "$bin" batch --quiet "$batch_scene" "$dos/*/*.csv" --out "$tmp/arch" --jobs "$cores")
echo
echo "| $n recordings → tracks | wall (s) | vs the loop |"
echo "|---|---|---|"
echo "| shell loop of gradtac run | $t_loop | 1.00 |"
echo "| gradtac batch --jobs 1 | $t_b1 | $(echo "$t_loop / $t_b1" | bc -l | xargs printf '%.2f')× |"
echo "| gradtac batch --jobs $cores | $t_bn | $(echo "$t_loop / $t_bn" | bc -l | xargs printf '%.2f')× |"
