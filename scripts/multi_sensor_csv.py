#!/usr/bin/env python3
"""Build a K-sensor CSV from BioTacSP-DoS recordings, for `gradtac run --threads` benchmarks:
`multi_sensor_csv.py DATA_DIR OUT K [ROWS]` writes columns s1_e1..s1_e24, ..., sK_e1..sK_e24;
sensor k reads every recording of DATA_DIR (sorted, blank lines dropped) concatenated, starting
at recording k (a rotation, so the sensors differ), cut to ROWS rows (default: all)."""
import glob
import os
import sys

data, out, k = sys.argv[1], sys.argv[2], int(sys.argv[3])
files = sorted(glob.glob(os.path.join(data, "*", "*.csv")))
if not files:
    sys.exit(f"no recordings under {data}")
recs = []
for p in files:
    lines = [l for l in open(p).read().splitlines() if l.strip()]
    recs.append(lines[1:])
limit = int(sys.argv[4]) if len(sys.argv) > 4 else None
streams = []
for s in range(k):
    rows = [r for rec in recs[s:] + recs[:s] for r in rec]
    streams.append(rows)
n = min(len(r) for r in streams)
if limit is not None:
    n = min(n, limit)
with open(out, "w") as f:
    f.write(",".join(f"s{s + 1}_e{e}" for s in range(k) for e in range(1, 25)) + "\n")
    for i in range(n):
        f.write(",".join(streams[s][i] for s in range(k)) + "\n")
print(f"{out}: {n} rows, {k} sensors")
