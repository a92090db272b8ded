#!/usr/bin/env python3
"""Write a long synthetic BioTac-style CSV (header ff_e1..ff_e24, integer counts) for
memory and throughput checks: `make_long_csv.py OUT.csv FRAMES`."""
import sys

out, frames = sys.argv[1], int(sys.argv[2])
with open(out, "w") as f:
    f.write(",".join(f"ff_e{i}" for i in range(1, 25)) + "\n")
    base = [2000 + 37 * j for j in range(24)]
    chunk = []
    for k in range(frames):
        chunk.append(",".join(str(b + (k * 7 + j * 13) % 251) for j, b in enumerate(base)))
        if len(chunk) == 10000:
            f.write("\n".join(chunk) + "\n")
            chunk = []
    if chunk:
        f.write("\n".join(chunk) + "\n")
