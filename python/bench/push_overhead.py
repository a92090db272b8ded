"""Python `Pipeline.push` overhead per frame against the Rust engine it calls.

Times `gradtac.Pipeline(tap=...).push(times, values)` over N synthetic frames (a press that
moves across a BioTac SP) pushed in batches of 1 and of 1,000 frames, and the same frames
through `gradtac::memory::Pipeline::push_frames` in a loop in Rust alone (`_bench_rust_push` in
the same compiled module, so both sides are the same build). Prints a table of medians over REPEATS runs (ns per frame) and the Python overhead.

    python python/bench/push_overhead.py [--frames 20000] [--repeats 7] [--tap track]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import gradtac
from gradtac import _gradtac

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from conftest import press  # noqa: E402



def python_ns_per_frame(values, tap, batch, repeats):
    times = np.arange(len(values), dtype=np.int64) * 10_000_000
    out = []
    rows = 0
    for _ in range(repeats):
        p = gradtac.Pipeline(tap=tap, rate_hz=100.0, sensor="ff")
        rows = 0
        start = time.perf_counter_ns()
        for i in range(0, len(values), batch):
            rows += p.push(times[i : i + batch], values[i : i + batch]).num_rows
        rows += p.finish().num_rows
        out.append((time.perf_counter_ns() - start) / len(values))
    return float(np.median(out)), rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=20000)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--tap", default="track")
    args = ap.parse_args()
    values = np.ascontiguousarray(
        np.vstack([press(frames=1000, seed=s) for s in range(args.frames // 1000)]), dtype=np.float64
    )
    rust_ns = {b: _gradtac._bench_rust_push(values, args.tap, b, args.repeats) for b in (1, 1000)}
    print(f"Pipeline(tap={args.tap!r}) over {len(values)} frames, medians of {args.repeats} runs, ns per frame")
    print(f"{'batch':>6} {'python':>10} {'rust':>10} {'overhead':>10} {'ratio':>6}")
    for batch in (1, 1000):
        py, py_rows = python_ns_per_frame(values, args.tap, batch, args.repeats)
        rs, rs_rows = rust_ns[batch]
        assert py_rows == rs_rows, (py_rows, rs_rows)
        print(f"{batch:>6} {py:>10.0f} {rs:>10.0f} {py - rs:>10.0f} {py / rs:>6.2f}")


if __name__ == "__main__":
    main()
