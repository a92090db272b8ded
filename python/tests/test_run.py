"""gradtac.run / run_tables / explain against the gradtac CLI, bit for bit."""

import io
import shutil
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import gradtac
from conftest import DOS, run_cli, scene_text, write_csv, press


def canonical(t: pa.Table) -> bytes:
    """The table's data as bytes: one uncompressed Parquet row group with no schema metadata,
    so equal bytes mean equal values bit for bit (NaN payloads and nulls included), whatever
    the chunking."""
    buf = io.BytesIO()
    t = t.replace_schema_metadata(None).combine_chunks()
    pq.write_table(t, buf, row_group_size=max(t.num_rows, 1), compression="none", write_statistics=False)
    return buf.getvalue()


def file_metadata(path: Path) -> dict:
    md = dict(pq.read_metadata(path).metadata)
    md.pop(b"ARROW:schema", None)
    return md


def outputs(d: Path):
    return sorted(p.relative_to(d) for p in (d / "out").rglob("*") if p.is_file())


def test_write_true_is_byte_identical_to_the_cli(recording_dir: Path, tmp_path_factory, gradtac_bin):
    py_dir = tmp_path_factory.mktemp("py")
    shutil.copy(recording_dir / "rec.csv", py_dir / "rec.csv")
    shutil.copy(recording_dir / "scene.toml", py_dir / "scene.toml")
    run_cli(gradtac_bin, "run", "-q", str(recording_dir / "scene.toml"))
    report = gradtac.run(py_dir / "scene.toml", write=True)
    assert [n for _, n in report["outputs"]] == [800, 800, 800]
    assert outputs(recording_dir) == outputs(py_dir) and len(outputs(py_dir)) == 3
    for rel in outputs(py_dir):
        assert (recording_dir / rel).read_bytes() == (py_dir / rel).read_bytes(), rel


def test_in_memory_batches_equal_the_cli_parquet(recording_dir: Path, gradtac_bin):
    run_cli(gradtac_bin, "run", "-q", str(recording_dir / "scene.toml"))
    before = sorted(recording_dir.rglob("*"))
    pairs = list(gradtac.run(recording_dir / "scene.toml"))
    assert sorted(recording_dir.rglob("*")) == before, "run() without write=True writes nothing"
    assert {name for name, _ in pairs} == {"out/tracks.parquet", "out/smoothed.parquet", "out/contours.parquet"}
    assert all(isinstance(b, pa.RecordBatch) for _, b in pairs)
    tables = gradtac.run_tables(recording_dir / "scene.toml")
    for name, table in tables.items():
        path = recording_dir / name
        from_file = pq.read_table(path)
        streamed = pa.Table.from_batches([b for n, b in pairs if n == name])
        assert table.schema.remove_metadata() == from_file.schema.remove_metadata()
        assert canonical(table) == canonical(from_file), name
        assert canonical(streamed) == canonical(from_file), name
        # the batches carry the file's key-value metadata (scene, tap, layouts, schema, version)
        md = table.schema.metadata
        for k, v in file_metadata(path).items():
            assert md.get(k) == v, k
        assert md[b"gradtac.schema"] == from_file.schema.metadata[b"gradtac.schema"]


def test_scene_as_text_and_dict_and_explain(recording_dir: Path):
    text = scene_text()
    by_text = gradtac.run_tables(text, base_dir=recording_dir)
    scene = {
        "sensor": [
            {"name": "ff", "source": {"csv": str(recording_dir / "rec.csv"), "columns": "ff_e{1..24}", "rate_hz": 100.0}}
        ],
        "stages": {"savgol": {"window": 11}},
        "output": [{"tap": "track", "path": "out/tracks.parquet"}, {"tap": "savgol", "path": "out/smoothed.parquet"}],
    }
    by_dict = gradtac.run_tables(scene, base_dir=recording_dir)
    for name in ("out/tracks.parquet", "out/smoothed.parquet"):
        assert canonical(by_dict[name]) == canonical(by_text[name]), name
    assert by_text["out/tracks.parquet"].num_rows == 400
    plan = gradtac.explain(scene)
    assert "savgol" in plan and "window 11" in plan and "track" in plan
    assert not (recording_dir / "out").exists()


def test_leaving_the_loop_early_stops_the_run(recording_dir: Path):
    it = gradtac.run(recording_dir / "scene.toml")
    name, batch = next(it)
    assert batch.num_rows > 0
    del it  # the run's thread sees the reader gone and stops; nothing is left behind
    assert not (recording_dir / "out").exists()


@pytest.mark.skipif(not DOS.is_dir(), reason="dev recordings (shared/data/biotacsp-dos) absent")
def test_a_dev_recording_matches_the_cli(tmp_path: Path, gradtac_bin):
    rec = sorted(DOS.glob("*/*.csv"))[0]
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text(csv=str(rec)))
    run_cli(gradtac_bin, "run", "-q", str(scene))
    tables = gradtac.run_tables(scene)
    for name, table in tables.items():
        assert canonical(table) == canonical(pq.read_table(tmp_path / name)), name


def test_ctrl_c_still_raises_keyboard_interrupt_after_a_run(recording_dir: Path):
    # a run installs tokio's SIGINT handler (it finishes the outputs on Ctrl-C); Python's own
    # handler must still see later Ctrl-Cs
    import subprocess
    import sys

    code = (
        "import os, signal, time, gradtac\n"
        f"gradtac.run_tables({str(recording_dir / 'scene.toml')!r})\n"
        f"gradtac.run({str(recording_dir / 'scene.toml')!r}, write=True)\n"
        "try:\n"
        "    os.kill(os.getpid(), signal.SIGINT)\n"
        "    time.sleep(5)\n"
        "    print('no interrupt')\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "interrupted", (out.stdout, out.stderr)
