"""Run one scene over many recordings on a Ray cluster.

Each recording is one Ray task that calls the Rust ``gradtac::batch::run_recording`` — the
function behind ``gradtac batch`` — so the archive is the one ``gradtac batch`` writes, file
for file and byte for byte::

    <out>/<output-name>/recording=<stem>/sensor=<name>/part-000000.parquet
    <out>/<output-name>/recording=<stem>/part-000000.parquet          (slip outputs)

``<output-name>`` is the file stem of the output's path in the scene, ``<stem>`` the
recording's file stem. DuckDB, pyarrow and Polars read each output as one table with
``recording`` and ``sensor`` as hive partitions. ``out`` must be a directory every worker
can write (a shared file system on a multi-node cluster).

A recording that fails (unreadable, a bad cell, already in the archive) is reported in the
result and does not stop the others, as in ``gradtac batch``. Tasks are not retried: a
retried recording would find its own partial files (``max_retries=0``).

Example (a local Ray on this machine, every socket on loopback)::

    import gradtac.ray as gr
    gr.init_local(num_cpus=2)
    report = gr.run_recordings("scene.toml", ["data/*/*.csv"], "archive")
    print(report)               # 167 recordings ran, 0 failed ...

On a cluster, ``ray.init(address="auto")`` (or any ``ray.init``) instead of ``init_local``.
See ``docs/python.md`` for the recipe.
"""

from __future__ import annotations

import glob
import os
import sys
import time
from dataclasses import dataclass, field
from typing import Any, Dict, Iterable, List, Optional, Sequence, Tuple, Union

from . import GradtacError, Scene, load_scene

__all__ = ["BatchReport", "expand_recordings", "init_local", "run_recordings"]

#: Ray's environment switch that makes its node-address detection return the loopback address
#: (what it does on macOS and Windows). With it, ``_node_ip_address="127.0.0.1"`` is kept
#: instead of being replaced by the machine's address, and Ray's gRPC servers (GCS, raylet,
#: object manager, workers) and the runtime-env agent listen on 127.0.0.1 only.
LOOPBACK_ENV = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"


@dataclass
class BatchReport:
    """What :func:`run_recordings` did."""

    #: One dict per recording that ran: ``recording``, ``frames``, ``files``.
    done: List[Dict[str, Any]] = field(default_factory=list)
    #: ``(recording, message)`` per recording that failed.
    failed: List[Tuple[str, str]] = field(default_factory=list)
    #: Wall-clock seconds.
    seconds: float = 0.0

    @property
    def frames(self) -> int:
        """Frames read over every recording that ran."""
        return sum(d["frames"] for d in self.done)

    def __str__(self) -> str:
        files = sum(len(d["files"]) for d in self.done)
        lines = [
            f"ray batch: {len(self.done)} recordings ran, {len(self.failed)} failed; "
            f"{self.frames} frames, {files} files in {self.seconds:.3f} s"
        ]
        lines += [f"failed: {r}: {m}" for r, m in self.failed]
        return "\n".join(lines)


def expand_recordings(recordings: Union[str, "os.PathLike[str]", Iterable[Union[str, "os.PathLike[str]"]]]) -> List[str]:
    """Paths or glob patterns to absolute paths, as ``gradtac batch`` takes them: a pattern
    (holding ``*``, ``?`` or ``[`` and naming no existing file) expands in sorted order, and
    one that matches nothing is an error."""
    if isinstance(recordings, (str, os.PathLike)):
        recordings = [recordings]
    out: List[str] = []
    for r in recordings:
        r = os.fspath(r)
        if not os.path.exists(r) and any(c in r for c in "*?["):
            matches = sorted(p for p in glob.glob(r, recursive=True) if os.path.isfile(p))
            if not matches:
                raise GradtacError(f"{r}: the pattern matches no file")
            out += [os.path.abspath(p) for p in matches]
        else:
            out.append(os.path.abspath(r))
    return out


def init_local(num_cpus: int = 2, **kwargs: Any) -> Any:
    """Start a local Ray whose every socket listens on loopback only.

    ``ray.init(num_cpus=…, include_dashboard=False, _node_ip_address="127.0.0.1")`` with
    :data:`LOOPBACK_ENV` set to ``0`` (without it Ray replaces ``127.0.0.1`` by the machine's
    own address and its servers listen on every interface). The variable is read when Ray is
    imported, so call this before anything imports ``ray``; otherwise set the variable in
    the environment yourself. Extra keyword arguments go to ``ray.init``.
    """
    if "ray" in sys.modules and os.environ.get(LOOPBACK_ENV) != "0":
        from ray._private import ray_constants  # the switch is read at import

        if getattr(ray_constants, "ENABLE_RAY_CLUSTER", False):
            raise RuntimeError(
                f"ray was imported before gradtac.ray.init_local: set {LOOPBACK_ENV}=0 in the environment "
                "(or call init_local first) so that Ray listens on loopback only"
            )
    os.environ[LOOPBACK_ENV] = "0"
    import ray

    kwargs.setdefault("include_dashboard", False)
    kwargs.setdefault("_node_ip_address", "127.0.0.1")
    return ray.init(num_cpus=num_cpus, **kwargs)


def _run_one(scene: Scene, recording: str, out: str) -> Tuple[str, Any]:
    """One recording (a Ray task): its summary, or its error message."""
    try:
        return ("done", scene.run_recording(recording, out))
    except Exception as e:  # reported per recording, as gradtac batch does
        return ("failed", str(e) if isinstance(e, (GradtacError, OSError)) else f"{type(e).__name__}: {e}")


def run_recordings(
    scene: Any,
    recordings: Union[str, "os.PathLike[str]", Sequence[Union[str, "os.PathLike[str]"]]],
    out: Union[str, "os.PathLike[str]"],
    *,
    num_cpus: float = 1,
    base_dir: Union[str, "os.PathLike[str]", None] = None,
    progress: bool = False,
) -> BatchReport:
    """Run ``scene`` once per recording as Ray tasks (``num_cpus`` each) into the batch
    archive under ``out``; Ray must be initialised (``ray.init`` or :func:`init_local`).

    ``scene`` is a path, TOML text, a dict or a :class:`gradtac.Scene`; ``recordings`` paths
    or glob patterns (:func:`expand_recordings`). Before any task starts, the checks of
    ``gradtac batch`` run here (one file read by the scene, distinct output names, distinct
    recording stems) and raise :class:`gradtac.GradtacError`. Then each recording's failure
    is in :attr:`BatchReport.failed`. ``progress`` prints one line per finished recording.
    """
    import ray

    start = time.perf_counter()
    s = load_scene(scene, base_dir)
    # workers may run elsewhere: every path absolute
    origin = os.fspath(s.origin)
    s = Scene.from_toml(
        s.text,
        os.path.abspath(os.fspath(s.base_dir) or "."),
        os.path.abspath(origin) if os.path.exists(origin) else origin,
    )
    recs = expand_recordings(recordings)
    s.check_batch(recs)
    out = os.path.abspath(os.fspath(out))
    os.makedirs(out, exist_ok=True)
    task = ray.remote(num_cpus=num_cpus, max_retries=0)(_run_one)
    scene_ref = ray.put(s)
    pending = {task.remote(scene_ref, r, out): r for r in recs}
    results: Dict[str, Tuple[str, Any]] = {}
    while pending:
        ready, _ = ray.wait(list(pending), num_returns=1)
        for ref in ready:
            rec = pending.pop(ref)
            try:
                results[rec] = ray.get(ref)
            except Exception as e:  # the worker died
                results[rec] = ("failed", f"{type(e).__name__}: {e}")
            if progress:
                kind, what = results[rec]
                print(f"gradtac.ray: {kind}: {rec}" + (f": {what}" if kind == "failed" else ""), flush=True)
    report = BatchReport()
    for rec in recs:
        kind, what = results[rec]
        if kind == "done":
            report.done.append(what)
        else:
            report.failed.append((rec, what))
    report.seconds = time.perf_counter() - start
    return report
