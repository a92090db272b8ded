"""gradtac.Pipeline: chunking invariance, times, reset/finish, and the CLI's records."""

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import gradtac
from conftest import press, run_cli, write_csv
from test_run import canonical


def collect(p: gradtac.Pipeline, times, values, chunk: int) -> pa.Table:
    parts = []
    for i in range(0, len(values), chunk):
        parts.append(p.push(None if times is None else times[i : i + chunk], values[i : i + chunk]))
    parts.append(p.finish())
    assert all(b.schema == p.schema for b in parts)
    return pa.Table.from_batches(parts, schema=p.schema)


@pytest.mark.parametrize("tap", ["savgol", "window", "contour", "track"])
def test_chunks_of_one_and_of_many_equal_one_push(tap):
    values = press(frames=300, seed=1)
    times = np.arange(300, dtype=np.int64) * 10_000_000
    whole = collect(gradtac.Pipeline(tap=tap, rate_hz=100.0, sensor="ff"), times, values, 300)
    assert whole.num_rows > 0
    for chunk in (1, 7, 64):
        got = collect(gradtac.Pipeline(tap=tap, rate_hz=100.0, sensor="ff"), times, values, chunk)
        assert canonical(got) == canonical(whole), (tap, chunk)


def test_times_as_seconds_or_by_rate_give_the_same_records():
    values = press(frames=200, seed=2)
    ns = np.arange(200, dtype=np.int64) * 10_000_000
    a = collect(gradtac.Pipeline(tap="track", rate_hz=100.0), ns, values, 50)
    b = collect(gradtac.Pipeline(tap="track", rate_hz=100.0), ns / 1e9, values, 50)
    c = collect(gradtac.Pipeline(tap="track", rate_hz=100.0), None, values, 50)
    assert canonical(a) == canonical(b) == canonical(c)


def test_values_in_any_dtype_or_order_are_accepted_and_reset_starts_afresh():
    values = press(frames=120, seed=3)
    t = np.arange(120, dtype=np.int64) * 10_000_000
    p = gradtac.Pipeline(tap="savgol", rate_hz=100.0)
    ref = collect(p, t, values, 120)
    assert ref.num_rows == 120
    fortran = np.asfortranarray(values.astype(np.float32))
    p.push(t[:10], values[:10])
    p.reset()
    assert canonical(collect(p, t, fortran.astype(np.float64), 30)) == canonical(ref)
    one = p.push(t[0], values[0])  # a single frame, 1-D
    assert one.num_rows <= 1


def test_pipeline_equals_the_cli_chain(tmp_path: Path, gradtac_bin):
    values = press(frames=300, seed=4)
    write_csv(tmp_path / "rec.csv", values)
    (tmp_path / "scene.toml").write_text(
        '[[sensor]]\nname = "ff"\nsource = { csv = "rec.csv", columns = "ff_e{1..24}", rate_hz = 100.0 }\n'
        '[stages.savgol]\nwindow = 9\n'
        '[[output]]\ntap = "track"\npath = "tracks.parquet"\n'
    )
    run_cli(gradtac_bin, "run", "-q", str(tmp_path / "scene.toml"))
    p = gradtac.Pipeline(tap="track", rate_hz=100.0, sensor="ff", settings={"savgol": {"window": 9}})
    got = collect(p, np.arange(300, dtype=np.int64) * 10_000_000, values.astype(np.float64), 1)
    assert canonical(got) == canonical(pq.read_table(tmp_path / "tracks.parquet"))
    plan = p.explain()
    assert "track" in plan and "centroid" in plan and "<pipeline>" in plan, plan


def test_bad_settings_and_shapes_are_exceptions_with_the_message():
    with pytest.raises(gradtac.GradtacError, match="unknown field `windw`"):
        gradtac.Pipeline(settings={"savgol": {"windw": 3}})
    with pytest.raises(gradtac.GradtacError, match="unknown tap"):
        gradtac.Pipeline(tap="tracks")
    with pytest.raises(gradtac.GradtacError, match="savgol"):
        gradtac.Pipeline(tap="savgol", settings={"savgol": {"window": 4}})  # even window
    p = gradtac.Pipeline(tap="savgol", rate_hz=100.0)
    with pytest.raises(gradtac.GradtacError, match=r"shape \(frames, 24\)"):
        p.push(np.arange(2, dtype=np.int64), np.zeros((2, 23)))
    with pytest.raises(ValueError, match="3 times for 2 frames"):
        p.push(np.arange(3, dtype=np.int64), np.zeros((2, 24)))
