"""Fixtures: synthetic BioTac SP recordings (a press that moves over the fingertip), scenes,
and the gradtac CLI binary (``GRADTAC_BIN``, set by ``scripts/python-check``)."""

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

TAXELS = 24
RATE_HZ = 100.0


def press(frames: int = 400, seed: int = 0, fingers=("ff",)) -> "np.ndarray":
    """Raw electrode values (frames × 24 per finger): a quiet baseline with noise, then a
    contact that grows, moves across the taxels and lifts."""
    rng = np.random.default_rng(seed)
    cols = []
    for k, _ in enumerate(fingers):
        base = 2800.0 + 40.0 * rng.standard_normal(TAXELS)
        x = base + 3.0 * rng.standard_normal((frames, TAXELS))
        t = np.arange(frames)
        on = (t > frames // 4) & (t < 3 * frames // 4)
        centre = 4.0 + 12.0 * (t - frames // 4) / (frames // 2) + 2 * k
        depth = np.where(on, 250.0 * np.sin(np.pi * np.clip((t - frames // 4) / (frames // 2), 0, 1)), 0.0)
        idx = np.arange(TAXELS)
        bump = depth[:, None] * np.exp(-0.5 * ((idx[None, :] - centre[:, None]) / 2.5) ** 2)
        cols.append(np.round(x + bump))
    return np.hstack(cols)


def write_csv(path: Path, values: "np.ndarray", fingers=("ff",)) -> Path:
    header = ",".join(f"{f}_e{i}" for f in fingers for i in range(1, TAXELS + 1))
    np.savetxt(path, values, fmt="%d", delimiter=",", header=header, comments="")
    return path


SCENE = """
[[sensor]]
name = "ff"
source = {{ csv = "{csv}", columns = "ff_e{{1..24}}", rate_hz = 100.0 }}
{extra_sensor}
[[output]]
tap = "track"
path = "out/tracks.parquet"

[[output]]
tap = "savgol"
path = "out/smoothed.parquet"

[[output]]
tap = "contour"
path = "out/contours.parquet"
"""

TH = """
[[sensor]]
name = "th"
source = {{ csv = "{csv}", columns = "th_e{{1..24}}", rate_hz = 100.0 }}
"""


def scene_text(csv: str = "rec.csv", two: bool = False) -> str:
    return SCENE.format(csv=csv, extra_sensor=TH.format(csv=csv) if two else "")


@pytest.fixture
def recording_dir(tmp_path: Path) -> Path:
    """A directory with rec.csv (two fingers, ff and th) and scene.toml (both sensors)."""
    write_csv(tmp_path / "rec.csv", press(fingers=("ff", "th")), fingers=("ff", "th"))
    (tmp_path / "scene.toml").write_text(scene_text(two=True))
    return tmp_path


@pytest.fixture(scope="session")
def gradtac_bin() -> str:
    """The gradtac CLI (GRADTAC_BIN, or `gradtac` on PATH); skips when absent."""
    b = os.environ.get("GRADTAC_BIN") or shutil.which("gradtac")
    if not b or not os.path.exists(b):
        pytest.skip("no gradtac CLI binary (set GRADTAC_BIN)")
    return b


def run_cli(gradtac_bin: str, *args: str, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([gradtac_bin, *args], cwd=cwd, capture_output=True, text=True, check=True)


SHARED = Path(os.environ.get("GRADTAC_SHARED", Path(__file__).resolve().parents[2] / ".." / "shared"))
DOS = SHARED / "data" / "biotacsp-dos"
