#!/usr/bin/env bash
# `gradtac batch` archives read by DuckDB as one table per output, with `recording` and `sensor`
# as hive partitions (and no such columns inside the files):
# - simulated two-finger grasps (the demo's recording under three names), tracks + slip;
# - with ../shared/data/biotacsp-dos present: all its recordings (one fingertip each), tracks;
#   DuckDB's row count per recording must equal the recording's data rows.
# Installs pyarrow and DuckDB into a virtual environment (shared with scripts/interop.sh).
#
#   scripts/batch_duckdb.sh            # venv in $INTEROP_VENV or target/interop-venv
#   GRADTAC_BIN=target/debug/gradtac INTEROP_VENV=/tmp/v scripts/batch_duckdb.sh
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${INTEROP_VENV:-${CARGO_TARGET_DIR:-target}/interop-venv}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --upgrade pyarrow duckdb
# GRADTAC_BIN: a gradtac binary to use instead of building the release one
bin="${GRADTAC_BIN:-}"
if [ -z "$bin" ]; then
    cargo build --release --quiet
    bin="${CARGO_TARGET_DIR:-target}/release/gradtac"
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

"$bin" demo --dir "$tmp/demo" --quiet > /dev/null
mkdir -p "$tmp/rec"
for name in grasp-a grasp-b "grasp c"; do cp "$tmp/demo/recording.csv" "$tmp/rec/$name.csv"; done
cat > "$tmp/grasp.toml" <<'TOML'
[[sensor]]
name = "ff"
source = { csv = "recording.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }
[[sensor]]
name = "th"
source = { csv = "recording.csv", columns = "th_e{1..24}", rate_hz = 100.0 }
[[output]]
tap = "track"
path = "out/tracks.parquet"
[[output]]
tap = "slip"
path = "out/slip.parquet"
TOML
"$bin" batch "$tmp/grasp.toml" "$tmp/rec/*.csv" --out "$tmp/grasp-archive" --jobs 2

cat > "$tmp/check.py" <<'PY'
import glob, os, sys
import duckdb, pyarrow.parquet as pq

def check(archive, table, recordings, sensors, rows_per_recording=None):
    root = os.path.join(archive, table)
    con = duckdb.connect()
    src = f"read_parquet('{root}/**/*.parquet', hive_partitioning = true)"
    cols = [r[0] for r in con.execute(f"DESCRIBE SELECT * FROM {src}").fetchall()]
    assert cols.count("recording") == 1, cols
    assert (cols.count("sensor") == 1) == bool(sensors), cols
    group = "recording, sensor" if sensors else "recording"
    got = con.execute(f"SELECT {group}, count(*) FROM {src} GROUP BY ALL ORDER BY ALL").fetchall()
    # per partition, DuckDB's rows = the rows pyarrow reads from that partition's files; the files
    # themselves hold neither column
    files = sorted(glob.glob(f"{root}/**/*.parquet", recursive=True))
    assert files, root
    per = {}
    for f in files:
        names = pq.read_schema(f).names
        assert "recording" not in names and "sensor" not in names, (f, names)
        parts = dict(p.split("=", 1) for p in os.path.relpath(f, root).split(os.sep)[:-1])
        from urllib.parse import unquote
        key = tuple(unquote(parts[k]) for k in (["recording", "sensor"] if sensors else ["recording"]))
        per[key] = per.get(key, 0) + pq.read_metadata(f).num_rows
    assert {r[:-1]: r[-1] for r in got} == per, (got, per)
    assert sorted({r[0] for r in got}) == sorted(recordings), (sorted({r[0] for r in got}), sorted(recordings))
    if sensors:
        assert sorted({r[1] for r in got}) == sorted(sensors), got
    if rows_per_recording:
        mine = {r[0]: r[-1] for r in got}
        assert mine == rows_per_recording, [(k, mine.get(k), v) for k, v in rows_per_recording.items() if mine.get(k) != v][:5]
    print(f"duckdb {duckdb.__version__}: {table}: {len(files)} files, {len(got)} partitions, "
          f"{sum(r[-1] for r in got)} rows; partitions {cols[-2:] if sensors else cols[-1:]}")

archive = sys.argv[1]
check(archive, "tracks", ["grasp-a", "grasp-b", "grasp c"], ["ff", "th"])
check(archive, "slip", ["grasp-a", "grasp-b", "grasp c"], [])
if len(sys.argv) > 2:
    data, dos_archive = sys.argv[2], sys.argv[3]
    rows = {}
    for p in glob.glob(f"{data}/*/*.csv"):
        with open(p) as f:
            rows[os.path.splitext(os.path.basename(p))[0]] = sum(1 for l in f if l.strip()) - 1
    check(dos_archive, "tracks", list(rows), ["ff"], rows)
PY

dos=../shared/data/biotacsp-dos
if [ -d "$dos" ]; then
    cat > "$tmp/dos.toml" <<'TOML'
[[sensor]]
name = "ff"
source = { csv = "any.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }
[[output]]
tap = "track"
path = "out/tracks.parquet"
TOML
    "$bin" batch "$tmp/dos.toml" "$dos/*/*.csv" --out "$tmp/dos-archive"
    "$venv/bin/python" "$tmp/check.py" "$tmp/grasp-archive" "$dos" "$tmp/dos-archive"
else
    echo "($dos absent: the DoS batch is skipped)"
    "$venv/bin/python" "$tmp/check.py" "$tmp/grasp-archive"
fi
echo "batch archives read by DuckDB: ok"
