"""The extension module of impactmc (built by maturin from python/src)."""

from os import PathLike
from typing import Any, Callable, Optional

__version__: str

class InputError(ValueError):
    """Input impactmc refuses, with the command line's message."""

    field: Optional[str]
    """The field at fault (``planes[1].restitution``), if one is."""
    file: Optional[str]
    """The scene's file, ``<string>``, ``<dict>`` or ``<replaced>``."""
    line: Optional[int]
    """The line of the file, when known."""

class OutputExistsError(FileExistsError):
    """The output folder already holds a run (``force=True`` overwrites)."""

class Table:
    """An Arrow table (record batches shared with the run, not copied)."""

    num_rows: int
    column_names: list[str]
    def __arrow_c_stream__(self, requested_schema: Optional[object] = None) -> object: ...
    def __len__(self) -> int: ...
    def to_polars(self) -> Any:
        """The table as a polars DataFrame."""
    def to_pyarrow(self) -> Any:
        """The table as a pyarrow Table."""
    def to_numpy(self, column: str) -> Any:
        """One column as a numpy array."""

class Result:
    text: str
    out: Optional[PathLike[str]]
    table_names: list[str]
    values: Optional[list[tuple[str, float]]]
    def _points(self) -> list[Result]: ...
    def _summary_json(self) -> str: ...
    def _manifest_json(self) -> Optional[str]: ...
    def table(self, name: str) -> Table: ...
    def samples(self) -> Table: ...

class Scene:
    name: str
    effects: str
    kernel: str
    toml: str
    source: str
    @staticmethod
    def from_toml(path: str) -> Scene: ...
    @staticmethod
    def from_str(text: str) -> Scene: ...
    @staticmethod
    def _from_json(json: str) -> Scene: ...
    def _replace(self, json: str) -> Scene: ...
    def _to_json(self) -> str: ...
    def _run(
        self,
        samples: Optional[int] = None,
        seed: Optional[int] = None,
        threads: int = 0,
        per_sample: bool = False,
        columns: Optional[list[str]] = None,
        out: Optional[str] = None,
        force: bool = False,
        shard: Optional[str] = None,
        callback: Optional[Callable[[int, int], Any]] = None,
    ) -> Result: ...

def _solve(name: str, text: str, json: Optional[bool] = None) -> str: ...
def _inspect(folder: str) -> tuple[str, str, str]: ...
def _merge(
    shards: list[str],
    out: str,
    force: bool = False,
    allow_partial: bool = False,
    callback: Optional[Callable[[int, int], Any]] = None,
) -> Result: ...
def _accuracy(
    scene: Scene,
    out: str,
    force: bool = False,
    callback: Optional[Callable[[int, int], Any]] = None,
) -> str: ...
