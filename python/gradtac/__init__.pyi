"""Type stubs of `gradtac` (the docstrings are in `__init__.py`)."""

import os
from typing import Any, Dict, Iterator, Literal, Mapping, Optional, Sequence, Tuple, Union, overload

import numpy.typing as npt
import pyarrow as pa

from ._gradtac import GradtacError as GradtacError
from ._gradtac import Scene as Scene

__version__: str

_Path = Union[str, "os.PathLike[str]"]
SceneLike = Union[str, "os.PathLike[str]", Mapping[str, Any], Scene]

def load_scene(scene: SceneLike, base_dir: Optional[_Path] = None) -> Scene: ...
def explain(scene: SceneLike, base_dir: Optional[_Path] = None) -> str: ...
@overload
def run(
    scene: SceneLike, write: Literal[False] = False, base_dir: Optional[_Path] = None
) -> Iterator[Tuple[str, pa.RecordBatch]]: ...
@overload
def run(scene: SceneLike, write: Literal[True], base_dir: Optional[_Path] = None) -> Dict[str, Any]: ...
def run_tables(scene: SceneLike, base_dir: Optional[_Path] = None) -> Dict[str, pa.Table]: ...

class Pipeline:
    def __init__(
        self,
        layout: str = "biotac-sp",
        tap: str = "track",
        settings: Optional[Mapping[str, Any]] = None,
        rate_hz: Optional[float] = None,
        sensor: str = "sensor",
    ) -> None: ...
    @property
    def taxels(self) -> int: ...
    @property
    def schema(self) -> pa.Schema: ...
    @property
    def scene(self) -> str: ...
    def explain(self) -> str: ...
    def push(self, times: Optional[npt.ArrayLike], values: npt.ArrayLike) -> pa.RecordBatch: ...
    def finish(self) -> pa.RecordBatch: ...
    def reset(self) -> None: ...

def read_rosbag(
    path: _Path, topic: str, finger: Union[str, Sequence[str]] = "ff", time: str = "header", layout: str = "biotac-sp"
) -> pa.Table: ...
def read_mcap(
    path: _Path, topic: str, finger: Union[str, Sequence[str]] = "ff", time: str = "header", layout: str = "biotac-sp"
) -> pa.Table: ...
def read_candump(
    path: _Path,
    codec: Mapping[str, Any],
    sensors: Sequence[str],
    layout: str = "biotac-sp",
    interface: Optional[str] = None,
) -> pa.Table: ...
