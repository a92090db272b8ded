"""The README's Python example runs as written (on a synthetic recording and scene)."""

import re
from pathlib import Path

import pytest

from conftest import SHARED, press, scene_text, write_csv

README = Path(__file__).resolve().parents[2] / "README.md"


def test_readme_example_runs(tmp_path: Path, monkeypatch):
    if not README.is_file():
        pytest.skip("README.md not beside the tests")
    block = re.search(r"## From Python.*?```python\n(.*?)```", README.read_text(), re.S).group(1)
    assert 15 <= len(block.strip().splitlines()) <= 25
    write_csv(tmp_path / "recording.csv", press(frames=300))
    (tmp_path / "scene.toml").write_text(scene_text(csv="recording.csv"))
    bag = SHARED / "data" / "rosbag" / "shadow-rh-tactile-untouched.bag"
    if bag.is_file():
        block = block.replace('"grasp.bag"', repr(str(bag)))
    else:
        block = "\n".join(l for l in block.splitlines() if "grasp.bag" not in l)
    monkeypatch.chdir(tmp_path)
    env: dict = {}
    exec(compile(block, str(README), "exec"), env)
    assert (tmp_path / "out" / "tracks.parquet").is_file()
    assert sum(b.num_rows for b in env["batches"]) == 300
