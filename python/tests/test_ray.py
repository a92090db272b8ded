"""gradtac.ray on a local Ray with 2 workers, every socket on loopback: the archive is the one
`gradtac batch` writes (byte for byte), and DuckDB reads it as one table partitioned by
recording and sensor."""

import ipaddress
import os
import re
import subprocess
from pathlib import Path

import pytest

# read by Ray when it is imported: keep its node address on loopback (see gradtac.ray.init_local)
os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")

ray = pytest.importorskip("ray")
duckdb = pytest.importorskip("duckdb")

import gradtac  # noqa: E402
import gradtac.ray as gray  # noqa: E402
from conftest import press, run_cli, scene_text, write_csv  # noqa: E402


@pytest.fixture(scope="module")
def local_ray():
    ctx = gray.init_local(num_cpus=2, object_store_memory=80 * 1024 * 1024, log_to_driver=False)
    yield ctx
    ray.shutdown()


@pytest.fixture(scope="module")
def recordings(tmp_path_factory) -> list:
    d = tmp_path_factory.mktemp("recs")
    paths = []
    for i, name in enumerate(["bottle1", "bottle2", "can7", "mug 3", "ball%4"]):
        paths.append(write_csv(d / f"{name}.csv", press(frames=300, seed=i, fingers=("ff", "th")), fingers=("ff", "th")))
    return paths


def descendants(pid: int) -> set:
    children = {}
    for p in Path("/proc").iterdir():
        if p.name.isdigit():
            try:
                ppid = int((p / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            children.setdefault(ppid, []).append(int(p.name))
    out, todo = {pid}, [pid]
    while todo:
        for c in children.get(todo.pop(), []):
            if c not in out:
                out.add(c)
                todo.append(c)
    return out


def listening_sockets_of(pids: set) -> list:
    """(local address, process) of every TCP/UDP socket listening in `pids` (ss -ltunp)."""
    out = subprocess.run(["ss", "-ltunpH"], capture_output=True, text=True, check=True).stdout
    found = []
    for line in out.splitlines():
        owners = {int(p) for p in re.findall(r"pid=(\d+)", line)}
        if owners & pids:
            local = line.split()[4]
            found.append((local, line))
    return found


def is_loopback(local: str) -> bool:
    host = local.rsplit(":", 1)[0].strip("[]").split("%")[0]
    if host.startswith("::ffff:"):
        host = host[len("::ffff:") :]
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def test_ray_archive_equals_gradtac_batch_and_reads_in_duckdb(local_ray, recordings, tmp_path: Path, gradtac_bin):
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text(csv="any.csv", two=True))
    out_ray, out_batch, out_cli = tmp_path / "ray", tmp_path / "batch", tmp_path / "cli"
    report = gray.run_recordings(scene, [str(r) for r in recordings], out_ray)
    assert not report.failed, report
    assert len(report.done) == 5 and report.frames == 5 * 600

    # every socket the Ray processes (this driver, GCS, raylet, workers) listen on is loopback
    sockets = listening_sockets_of(descendants(os.getpid()))
    assert sockets, "Ray listens somewhere"
    assert all(is_loopback(a) for a, _ in sockets), [line for a, line in sockets if not is_loopback(a)]

    # the same Rust function in a thread pool, and the CLI: the same files, byte for byte
    gradtac.load_scene(scene).run_batch([str(r) for r in recordings], str(out_batch), jobs=2)
    run_cli(gradtac_bin, "batch", "-q", str(scene), *map(str, recordings), "--out", str(out_cli))
    files = sorted(p.relative_to(out_ray) for p in out_ray.rglob("*") if p.is_file())
    assert len(files) == 3 * 5 * 2  # outputs × recordings × sensors
    assert files[0].parts[1].startswith("recording=") and files[0].parts[2].startswith("sensor=")
    for other in (out_batch, out_cli):
        assert files == sorted(p.relative_to(other) for p in other.rglob("*") if p.is_file())
        for f in files:
            assert (out_ray / f).read_bytes() == (other / f).read_bytes(), f

    # DuckDB: one table per output, recording and sensor as partitions
    con = duckdb.connect()
    rows = con.execute(
        f"SELECT recording, sensor, count(*) FROM read_parquet('{out_ray}/tracks/**/*.parquet', hive_partitioning = true) "
        "GROUP BY ALL ORDER BY ALL"
    ).fetchall()
    assert rows == [(r, s, 300) for r in sorted(["ball%4", "bottle1", "bottle2", "can7", "mug 3"]) for s in ("ff", "th")]
    total = con.execute(f"SELECT count(*) FROM read_parquet('{out_ray}/smoothed/**/*.parquet', hive_partitioning = true)")
    assert total.fetchone()[0] == 3000


def test_ray_reports_a_failing_recording_and_runs_the_others(local_ray, recordings, tmp_path: Path):
    bad = tmp_path / "broken.csv"
    bad.write_text("ff_e1,ff_e2\n1,2\n")
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text(csv="any.csv", two=True))
    report = gray.run_recordings(scene, [str(recordings[0]), str(bad)], tmp_path / "out")
    assert [d["recording"] for d in report.done] == [str(recordings[0])]
    assert len(report.failed) == 1 and "broken.csv" in report.failed[0][1]
    # a recording already in the archive fails, as in gradtac batch
    again = gray.run_recordings(scene, [str(recordings[0])], tmp_path / "out")
    assert not again.done and "already holds" in again.failed[0][1]
    # checks before anything runs: two recordings with one stem
    with pytest.raises(gradtac.GradtacError, match="same stem"):
        gray.run_recordings(scene, [str(recordings[0]), str(recordings[0])], tmp_path / "out2")
    with pytest.raises(gradtac.GradtacError, match="matches no file"):
        gray.run_recordings(scene, [str(tmp_path / "*.nothing")], tmp_path / "out3")
