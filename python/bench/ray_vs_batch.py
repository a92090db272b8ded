"""Ray on 2 local workers against `gradtac batch --jobs 2` over the dev recordings.

Both run one scene per recording into the same archive layout (Ray's tasks call the Rust
function behind `gradtac batch`). Prints medians of REPEATS runs (seconds, wall clock) and the
ratio; Ray's start-up (`init_local`) is timed separately and not counted in its runs.

    python python/bench/ray_vs_batch.py [--data ../shared/data/biotacsp-dos] [--repeats 3]
"""

import argparse
import os
import shutil
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")

import gradtac.ray as gr  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
SCENE = """
[[sensor]]
name = "ff"
source = { csv = "any.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }

[[output]]
tap = "track"
path = "tracks.parquet"

[[output]]
tap = "savgol"
path = "smoothed.parquet"
"""


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", default=str(ROOT / ".." / "shared" / "data" / "biotacsp-dos"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "gradtac"))
    args = ap.parse_args()
    recs = gr.expand_recordings(os.path.join(args.data, "*", "*.csv"))
    work = Path(tempfile.mkdtemp())
    scene = work / "scene.toml"
    scene.write_text(SCENE)
    batch_s, ray_s = [], []
    try:
        for i in range(args.repeats):
            out = work / f"batch{i}"
            t = time.perf_counter()
            subprocess.run([args.bin, "batch", "-q", str(scene), *recs, "--out", str(out), "--jobs", "2"], check=True)
            batch_s.append(time.perf_counter() - t)
            shutil.rmtree(out)
        t = time.perf_counter()
        gr.init_local(num_cpus=2, object_store_memory=80 * 1024 * 1024, log_to_driver=False)
        startup = time.perf_counter() - t
        for i in range(args.repeats):
            out = work / f"ray{i}"
            report = gr.run_recordings(scene, recs, out)
            assert not report.failed, report
            ray_s.append(report.seconds)
            shutil.rmtree(out)
        frames = report.frames
    finally:
        shutil.rmtree(work, ignore_errors=True)
    b, r = statistics.median(batch_s), statistics.median(ray_s)
    print(f"{len(recs)} recordings, {frames} frames, outputs track + savgol; medians of {args.repeats}")
    print(f"gradtac batch --jobs 2 : {b:.3f} s  ({batch_s})")
    print(f"gradtac.ray, 2 workers : {r:.3f} s  ({ray_s}); Ray start-up {startup:.1f} s not counted")
    print(f"ray / batch            : {r / b:.2f}")


if __name__ == "__main__":
    main()
