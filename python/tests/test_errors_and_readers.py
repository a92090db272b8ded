"""Rust errors as Python exceptions with the message (file, line, key); the readers."""

import re
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

import gradtac
from conftest import SHARED, scene_text


def test_a_misspelt_scene_key_names_the_line_and_key(tmp_path: Path):
    (tmp_path / "scene.toml").write_text(scene_text() + "\n[stages.savgol]\nwindw = 3\n")
    with pytest.raises(gradtac.GradtacError) as e:
        gradtac.load_scene(tmp_path / "scene.toml")
    msg = str(e.value)
    # one error shape everywhere: `file:line: …` naming the key
    assert re.search(r"scene\.toml:\d+: ", msg) and "windw" in msg, msg


def test_a_missing_recording_is_file_not_found_naming_it(tmp_path: Path):
    (tmp_path / "scene.toml").write_text(scene_text(csv="nope.csv"))
    with pytest.raises(FileNotFoundError, match="nope.csv"):
        list(gradtac.run(tmp_path / "scene.toml"))
    with pytest.raises(FileNotFoundError, match="nope.csv"):
        gradtac.run(tmp_path / "scene.toml", write=True)


def test_a_bad_cell_names_file_and_line(tmp_path: Path):
    rows = ["," .join(f"ff_e{i}" for i in range(1, 25))] + [",".join(["2800"] * 24)] * 5
    rows[4] = ",".join(["2800"] * 10 + ["oops"] + ["2800"] * 13)
    (tmp_path / "rec.csv").write_text("\n".join(rows) + "\n")
    (tmp_path / "scene.toml").write_text(scene_text())
    with pytest.raises(gradtac.GradtacError, match=r"rec\.csv:5"):
        list(gradtac.run(tmp_path / "scene.toml"))
    # a failed write leaves no final output (only .partial files, as the CLI)
    with pytest.raises(gradtac.GradtacError):
        gradtac.run(tmp_path / "scene.toml", write=True)
    assert not (tmp_path / "out" / "tracks.parquet").exists()


def test_a_scene_of_the_wrong_type_is_a_type_error():
    with pytest.raises(TypeError):
        gradtac.load_scene(42)


BAG = SHARED / "data" / "rosbag" / "shadow-rh-tactile-untouched.bag"


@pytest.mark.skipif(not BAG.is_file(), reason="shared ROS bag absent")
def test_read_rosbag_gives_a_frame_table_per_finger():
    t = gradtac.read_rosbag(BAG, "/rh/tactile", finger=["ff", "th"])
    assert isinstance(t, pa.Table) and t.num_rows > 0
    assert set(t.column("sensor").to_pylist()) == {"ff", "th"}
    assert str(t.schema.field("time").type) == "timestamp[ns, tz=UTC]"
    one = gradtac.read_rosbag(BAG, "/rh/tactile", finger="ff")
    assert one.num_rows * 2 == t.num_rows
    with pytest.raises(gradtac.GradtacError):
        gradtac.read_rosbag(BAG, "/no/such/topic", finger="ff")


def test_read_candump_decodes_a_log(tmp_path: Path):
    # one biotac-mux frame per taxel group would need the codec; a log of unrelated ids
    # decodes to no frames, and a malformed line names file:line
    (tmp_path / "ok.log").write_text("(1700000000.000000) can0 7FF#0102\n")
    t = gradtac.read_candump(tmp_path / "ok.log", {"preset": {"kind": "biotac-mux", "sensors": ["ff"]}}, ["ff"])
    assert t.num_rows == 0 and "sensor" in t.schema.names
    (tmp_path / "bad.log").write_text("(1700000000.000000) can0 7FF#0102\nnot a candump line\n")
    with pytest.raises(gradtac.GradtacError, match=r"bad\.log:2"):
        gradtac.read_candump(tmp_path / "bad.log", {"preset": {"kind": "biotac-mux", "sensors": ["ff"]}}, ["ff"])
