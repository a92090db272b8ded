"""GradTac tactile processing from Python.

Raw tactile-sensor streams to contact locations, forces and slip, computed by the gradtac
Rust library. Everything that works runs in Rust with the GIL released; data comes back as
pyarrow record batches and tables over the Arrow C data interface (no per-row Python
objects).

- :func:`run` runs a scene (a path, TOML text or a dict) and yields ``(output, RecordBatch)``
  pairs, writing nothing; ``run(scene, write=True)`` writes the scene's Parquet outputs
  exactly as ``gradtac run`` does.
- :func:`explain` prints what a scene runs, with every effective setting.
- :class:`Pipeline` is a streaming single-sensor chain: push NumPy frames, get Arrow batches.
- :func:`read_rosbag`, :func:`read_mcap`, :func:`read_candump` read recordings into tables.
- :mod:`gradtac.ray` runs a scene over many recordings on a Ray cluster.

Errors are :class:`GradtacError` (``FileNotFoundError`` / ``PermissionError`` for files that
cannot be opened) with the Rust message, which names the file, line and key.
"""

from __future__ import annotations

import os
from typing import Any, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import pyarrow as pa

from . import _gradtac
from ._gradtac import GradtacError
from ._gradtac import Scene as _Scene

__all__ = [
    "GradtacError",
    "Pipeline",
    "Scene",
    "explain",
    "load_scene",
    "read_candump",
    "read_mcap",
    "read_rosbag",
    "run",
    "run_tables",
]

__version__: str = _gradtac.__version__

#: A parsed scene (``gradtac.Scene.load(path)``, ``Scene.from_toml(text)``, ``Scene.from_dict(d)``).
Scene = _Scene

SceneLike = Union[str, "os.PathLike[str]", Mapping[str, Any], _Scene]


def load_scene(scene: SceneLike, base_dir: Union[str, "os.PathLike[str]", None] = None) -> _Scene:
    """Parse a scene given as a path, TOML text, a dict, or an already parsed :class:`Scene`.

    A ``str`` holding a newline, ``=`` or ``[`` is TOML text; any other ``str`` (and any
    ``os.PathLike``) is a path to a scene file, whose relative paths resolve against the
    file's directory. Relative paths of text and dict scenes resolve against ``base_dir``
    (default: the working directory).
    """
    if isinstance(scene, _Scene):
        return scene
    base = os.fspath(base_dir) if base_dir is not None else None
    if isinstance(scene, Mapping):
        return _Scene.from_dict(dict(scene), base)
    if isinstance(scene, str) and any(c in scene for c in "\n=["):
        return _Scene.from_toml(scene, base)
    if isinstance(scene, (str, os.PathLike)):
        return _Scene.load(os.fspath(scene))
    raise TypeError(f"a scene is a path, TOML text or a dict, not {type(scene).__name__}")


def explain(scene: SceneLike, base_dir: Union[str, "os.PathLike[str]", None] = None) -> str:
    """The scene's plan as ``gradtac explain`` prints it: which stages run for which sensor,
    why, and every effective setting."""
    return load_scene(scene, base_dir).explain()


def run(
    scene: SceneLike,
    write: bool = False,
    base_dir: Union[str, "os.PathLike[str]", None] = None,
) -> Any:
    """Run a scene.

    With ``write=False`` (the default) nothing is written: returns an iterator of
    ``(output, batch)`` pairs, ``output`` being the output's path as the scene writes it and
    ``batch`` a :class:`pyarrow.RecordBatch` of that output's records (the schema and values
    the Parquet file would hold, its key-value metadata included). The run goes on in a
    Rust thread a few batches ahead of the iterator, so memory stays bounded; leaving the
    loop early stops it.

    With ``write=True`` the outputs are written exactly as ``gradtac run`` writes them
    (byte for byte), and a report dict is returned (``frames``, ``outputs``, ``seconds``).
    """
    s = load_scene(scene, base_dir)
    if write:
        return s.run_write()
    return _named(s)


def _named(s: _Scene) -> Iterator[Tuple[str, pa.RecordBatch]]:
    names = [path for _, path in s.outputs]
    for index, batch in s.run_batches():
        yield names[index], batch


def run_tables(
    scene: SceneLike, base_dir: Union[str, "os.PathLike[str]", None] = None
) -> Dict[str, pa.Table]:
    """Run a scene in memory and gather each output into one :class:`pyarrow.Table`
    (keyed by the output's path as the scene writes it; an output without rows is an empty
    table of its schema)."""
    s = load_scene(scene, base_dir)
    names = [path for _, path in s.outputs]
    batches: Dict[int, List[pa.RecordBatch]] = {i: [] for i in range(len(names))}
    it = s.run_batches()
    for index, batch in it:
        batches[index].append(batch)
    tables = {}
    for i, name in enumerate(names):
        schema = batches[i][0].schema if batches[i] else it.schema(i)
        tables[name] = pa.Table.from_batches(batches[i], schema=schema)
    return tables


class Pipeline:
    """A streaming single-sensor chain: NumPy frames in, Arrow batches out.

    ``Pipeline(layout="biotac-sp", tap="track", settings={"savgol": {"window": 9}})`` builds
    the stages the ``tap`` needs (any stage of a scene's output vocabulary: ``source``,
    ``normalise``, ``savgol``, ``events``, ``window``, ``surface``, ``contour``, ``track``,
    ``force``, ``servo``, ``dos``) with ``settings`` keyed as a scene's ``[stages.*]`` tables,
    so code and ``gradtac run`` agree. It is the scene runner itself, on a one-sensor scene
    (see :attr:`scene`). ``rate_hz`` is the frame rate the stages assume (settings in
    seconds need it); ``sensor`` fills the ``sensor`` column.

    :meth:`push` returns the records the pushed frames completed, one
    :class:`pyarrow.RecordBatch` per call (possibly empty: a stage's delay holds records back
    until later frames or :meth:`finish`). Pushing in chunks of any size gives the same
    records as one push. Invalid settings raise :class:`GradtacError` naming the key.
    """

    def __init__(
        self,
        layout: str = "biotac-sp",
        tap: str = "track",
        settings: Optional[Mapping[str, Any]] = None,
        rate_hz: Optional[float] = None,
        sensor: str = "sensor",
    ) -> None:
        self._inner = _gradtac.Pipeline(
            layout, tap, dict(settings) if settings is not None else None, rate_hz, sensor
        )

    @property
    def taxels(self) -> int:
        """Taxels per frame (the layout's)."""
        return self._inner.taxels

    @property
    def schema(self) -> pa.Schema:
        """The schema of every batch :meth:`push` and :meth:`finish` return."""
        return self._inner.schema

    @property
    def scene(self) -> str:
        """The one-sensor scene the pipeline runs, as TOML."""
        return self._inner.scene

    def explain(self) -> str:
        """Each stage's effective settings, as ``gradtac explain`` prints them."""
        return self._inner.explain()

    def push(self, times: Any, values: Any) -> pa.RecordBatch:
        """Push ``n`` frames and return the records they completed.

        ``times``: ``n`` times, int64 nanoseconds or float64 seconds (rounded to the
        nanosecond), or ``None`` to time the frames by ``rate_hz`` (frame k of the stream
        at k / rate). ``values``: an ``n × taxels`` array (a single frame may be 1-D);
        a C-contiguous float64 array is read in place, anything else is converted first.
        """
        v = np.asarray(values)
        if v.ndim == 1:
            v = v.reshape(1, -1)
        if v.dtype != np.float64 or not v.flags.c_contiguous:
            v = np.ascontiguousarray(v, dtype=np.float64)
        if times is None:
            return self._inner.push_at_rate(v)
        t = np.asarray(times)
        if t.ndim == 0:
            t = t.reshape(1)
        if t.shape[0] != v.shape[0]:
            raise ValueError(f"{t.shape[0]} times for {v.shape[0]} frames")
        if np.issubdtype(t.dtype, np.integer):
            return self._inner.push_ns(np.ascontiguousarray(t, dtype=np.int64), v)
        if np.issubdtype(t.dtype, np.floating):
            return self._inner.push_s(np.ascontiguousarray(t, dtype=np.float64), v)
        if np.issubdtype(t.dtype, np.timedelta64) or np.issubdtype(t.dtype, np.datetime64):
            return self._inner.push_ns(np.ascontiguousarray(t.astype("int64")), v)
        raise TypeError(f"times must be int64 ns or float64 s, not {t.dtype}")

    def finish(self) -> pa.RecordBatch:
        """End of stream: flush every stage and return the last records. The pipeline then
        starts afresh (the next push begins a new stream)."""
        return self._inner.finish()

    def reset(self) -> None:
        """Drop every stage's state and pending record (a gap in the stream, or after an
        error): the next push begins a new stream."""
        self._inner.reset()

    def __repr__(self) -> str:
        return f"Pipeline(taxels={self.taxels}, schema={self.schema.metadata.get(b'gradtac.schema', b'').decode()})"


def _source_table(scene: Dict[str, Any]) -> pa.Table:
    (table,) = run_tables(scene).values()
    return table


def _bag_scene(kind: str, path: Any, topic: str, finger: Union[str, Sequence[str]], time: str, layout: str) -> Dict[str, Any]:
    fingers = [finger] if isinstance(finger, str) else list(finger)
    if not fingers:
        raise ValueError("give at least one finger")
    return {
        "sensor": [
            {
                "name": f,
                "layout": layout,
                "source": {kind: os.fspath(os.path.abspath(path)), "topic": topic, "finger": f, "time": time},
            }
            for f in fingers
        ],
        "output": [{"tap": "source", "path": "frames.parquet"}],
    }


def read_rosbag(
    path: Union[str, "os.PathLike[str]"],
    topic: str,
    finger: Union[str, Sequence[str]] = "ff",
    time: str = "header",
    layout: str = "biotac-sp",
) -> pa.Table:
    """Read fingertip frames from a ROS 1 bag into a table (schema ``frame/2``: ``sensor``,
    ``time`` as UTC timestamps, ``seq``, one column per taxel). ``finger`` is one of ``ff``,
    ``mf``, ``rf``, ``lf``, ``th`` (or a list: one pass over the file, frames merged by time);
    ``time`` is ``"header"`` (the message stamp) or ``"record"`` (when it was recorded)."""
    return _source_table(_bag_scene("rosbag", path, topic, finger, time, layout))


def read_mcap(
    path: Union[str, "os.PathLike[str]"],
    topic: str,
    finger: Union[str, Sequence[str]] = "ff",
    time: str = "header",
    layout: str = "biotac-sp",
) -> pa.Table:
    """Read fingertip frames from an MCAP file (ROS 2, CDR) into a table; as :func:`read_rosbag`."""
    return _source_table(_bag_scene("mcap", path, topic, finger, time, layout))


def read_candump(
    path: Union[str, "os.PathLike[str]"],
    codec: Mapping[str, Any],
    sensors: Sequence[str],
    layout: str = "biotac-sp",
    interface: Optional[str] = None,
) -> pa.Table:
    """Read the frames of ``sensors`` from a can-utils ``candump -l`` log into one table
    (merged by time; ``time`` in UTC). ``codec`` is the bus's codec table as in a scene,
    e.g. ``{"preset": {"kind": "biotac-mux", "sensors": ["ff", "th"]}}`` (see ``docs/can.md``)."""
    if not sensors:
        raise ValueError("give at least one sensor")
    bus: Dict[str, Any] = {"name": "bus", "candump": os.fspath(os.path.abspath(path)), "codec": dict(codec)}
    if interface is not None:
        bus["interface"] = interface
    scene = {
        "bus": [bus],
        "sensor": [{"name": s, "layout": layout, "source": {"bus": "bus"}} for s in sensors],
        "output": [{"tap": "source", "path": "frames.parquet"}],
    }
    return _source_table(scene)
