#!/usr/bin/env python3
"""Tile a recording's rows (blank lines dropped, header kept once) into a longer CSV:
`tile_csv.py SRC OUT FRAMES` writes FRAMES rows (the last copy cut short), and
`tile_csv.py SRC OUT xK` writes K whole copies."""
import sys

src, out, n = sys.argv[1], sys.argv[2], sys.argv[3]
lines = [l for l in open(src).read().splitlines() if l.strip()]
header, rows = lines[0], lines[1:]
frames = len(rows) * int(n[1:]) if n.startswith("x") else int(n)
with open(out, "w") as f:
    f.write(header + "\n")
    full, rest = divmod(frames, len(rows))
    block = "\n".join(rows) + "\n"
    for _ in range(full):
        f.write(block)
    if rest:
        f.write("\n".join(rows[:rest]) + "\n")
