"""impactmc in Python: Monte Carlo statistics of rigid-ellipsoid impacts.

The same engine and the same answers as the ``impactmc`` command line::

    import impactmc
    scene = impactmc.Scene.from_toml("configs/corner3.toml")
    result = scene.run(samples=10**6)
    print(result.text)                  # the CLI's summary
    result.summary["laws"]["newton"]    # summary.json as a dict
    rows = scene.run(samples=10**5, per_sample=True).samples()
    df = rows.to_polars()               # Arrow, without a copy

A run releases the GIL and works on its own threads; Ctrl-C stops it within
about a second. With ``multiprocessing``, use the ``spawn`` or
``forkserver`` start method: the engine's thread pool does not survive
``fork``.
"""

from __future__ import annotations

import json
import os
from typing import Any, Callable, Iterable, Mapping, Optional, Sequence, Union

from . import _impactmc
from ._impactmc import InputError, OutputExistsError, Table

__all__ = [
    "InputError",
    "accuracy",
    "inspect",
    "merge",
    "OutputExistsError",
    "Result",
    "Scene",
    "Table",
    "solve",
    "__version__",
]

__version__: str = _impactmc.__version__

PathLike = Union[str, "os.PathLike[str]"]
Progress = Union[bool, Callable[[int, int], Any], None]


def solve(case: Union[Mapping[str, Any], PathLike, str]) -> dict:
    """Solves one impact case: the dict ``impactmc solve`` prints.

    ``case`` is a dict, a path to a ``.json`` or ``.toml`` case file, or the
    case's JSON (or TOML) text. Bad input raises :class:`InputError` with
    the command line's message.
    """
    if isinstance(case, Mapping):
        out = _impactmc._solve("<dict>", json.dumps(dict(case)), True)
    elif isinstance(case, os.PathLike) or (
        # One line that is neither JSON nor a TOML key = value: a path (a
        # missing file raises FileNotFoundError, not a parse error).
        isinstance(case, str) and "\n" not in case and not case.lstrip().startswith("{")
        and ("=" not in case or os.path.exists(case))
    ):
        path = os.fspath(case)
        with open(path, encoding="utf-8") as f:
            text = f.read()
        kind = {".json": True, ".toml": False}.get(os.path.splitext(path)[1])
        out = _impactmc._solve(path, text, kind)
    elif isinstance(case, str):
        out = _impactmc._solve("<string>", case, None)
    else:
        raise TypeError(f"a case is a dict, a path or text, not {type(case).__name__}")
    return json.loads(out)


def inspect(folder: PathLike) -> dict:
    """A finished run folder read back, as ``impactmc inspect`` reads it:
    ``{"manifest": ..., "summary": ..., "text": ...}``."""
    manifest, summary, text = _impactmc._inspect(os.fspath(folder))
    return {"manifest": json.loads(manifest), "summary": json.loads(summary), "text": text}


def merge(shards: Iterable[PathLike], out: PathLike, force: bool = False,
          allow_partial: bool = False, progress: Progress = True) -> "Result":
    """Shard folders (runs with ``shard=``) merged into the run folder
    ``out``, as ``impactmc merge``: the statistics of the whole run.
    ``progress`` counts the shards read, as :meth:`Scene.run` counts
    samples; Ctrl-C stops the merge before its next shard, and nothing is
    written."""
    callback, close = _progress(progress, "shards")
    try:
        inner = _impactmc._merge([os.fspath(s) for s in shards], os.fspath(out), force,
                                 allow_partial, callback)
    finally:
        close()
    return Result(inner)


def accuracy(scene: "Scene", out: Optional[PathLike] = None, force: bool = False,
             progress: Progress = True) -> str:
    """The scene's accuracy ladder (its ``[accuracy]`` and ``[material]``
    knobs), as ``impactmc accuracy``: writes ``accuracy.parquet``,
    ``accuracy.md`` and ``accuracy.svg`` into ``out`` (default
    ``results/<name>-accuracy``) and returns the markdown. It runs for
    minutes; ``progress`` counts its steps (one per rung, each up to a few
    seconds), as :meth:`Scene.run` counts samples, and Ctrl-C stops it
    before its next step, with nothing written."""
    if out is None:
        out = os.path.join("results", f"{scene.name}-accuracy")
    callback, close = _progress(progress, "steps")
    try:
        return _impactmc._accuracy(scene._inner, os.fspath(out), force, callback)
    finally:
        close()


def _json(value: Any) -> str:
    """JSON text of a scene's values; non-finite floats, which JSON cannot
    hold, as ``{"$float": "nan"}`` (the extension decodes them)."""

    def enc(v):
        if isinstance(v, float) and v != v:
            return {"$float": "nan"}
        if isinstance(v, float) and v in (float("inf"), float("-inf")):
            return {"$float": "inf" if v > 0 else "-inf"}
        if isinstance(v, Mapping):
            return {str(k): enc(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [enc(x) for x in v]
        return v

    return json.dumps(enc(value), allow_nan=False)


def _table_to_polars(self: Table):
    """The table as a polars DataFrame (no copy of the columns)."""
    import polars as pl

    return pl.DataFrame(self)


def _table_to_pyarrow(self: Table):
    """The table as a pyarrow Table (no copy of the columns)."""
    import pyarrow as pa

    return pa.table(self)


def _table_to_numpy(self: Table, column: str):
    """One column as a numpy array (through pyarrow, or polars if pyarrow
    is missing)."""
    if column not in self.column_names:
        raise KeyError(f"no column {column!r}; the table has {', '.join(self.column_names)}")
    try:
        import pyarrow as pa
    except ImportError:
        return _table_to_polars(self)[column].to_numpy()
    return pa.table(self).column(column).to_numpy()


Table.to_polars = _table_to_polars  # type: ignore[attr-defined]
Table.to_pyarrow = _table_to_pyarrow  # type: ignore[attr-defined]
Table.to_numpy = _table_to_numpy  # type: ignore[attr-defined]


class Result:
    """A finished run: ``summary`` (summary.json as a dict), ``text`` (the
    terminal summary), ``table(name)``, ``samples()`` and ``manifest``."""

    def __init__(self, inner: "_impactmc.Result"):
        self._inner = inner
        self._summary: Optional[dict] = None

    @property
    def summary(self) -> dict:
        """The dict of ``summary.json`` (what ``run --format json`` prints)."""
        if self._summary is None:
            self._summary = json.loads(self._inner._summary_json())
        return self._summary

    @property
    def text(self) -> str:
        """The summary the command line prints."""
        return self._inner.text

    @property
    def out(self) -> Optional[str]:
        """The run folder, or None for a run kept in memory."""
        out = self._inner.out
        return None if out is None else os.fspath(out)

    @property
    def manifest(self) -> Optional[dict]:
        """The run folder's ``manifest.json``, or None for a run kept in
        memory."""
        text = self._inner._manifest_json()
        return None if text is None else json.loads(text)

    @property
    def values(self) -> Optional[dict]:
        """A grid point's swept values, field path to value (``{}`` for a
        run without a sweep; None for the whole of a sweep)."""
        values = self._inner.values
        return None if values is None else dict(values)

    @property
    def points(self) -> list:
        """One :class:`Result` per grid point of a sweep, in grid order,
        each with its ``values``, ``summary``, ``text``, tables and
        per-sample rows (slices of the run's, not copies). A run without
        a sweep has one point."""
        return [Result(p) for p in self._inner._points()]

    @property
    def table_names(self) -> list:
        """The tables :meth:`table` gives: ``summary``, ``histograms`` and,
        for a drop scene, its bounce tables."""
        return self._inner.table_names

    def table(self, name: str) -> Table:
        """A table by name, with the columns of its Parquet file in a run
        folder (a grid point's rows of it, for a point)."""
        return self._inner.table(name)

    def samples(self) -> Table:
        """The per-sample rows of a run with ``per_sample=True``, with the
        columns of ``samples.parquet`` (a grid point's rows, for a
        point)."""
        return self._inner.samples()

    def __str__(self) -> str:
        """The summary the command line prints."""
        return self.text

    def __repr__(self) -> str:
        """What the result is (scene, points, samples, where), then its
        summary, as the command line prints it."""
        return f"{self._inner!r}\n{self.text.rstrip()}"

    def _repr_html_(self) -> str:
        import html

        return f"<pre>{html.escape(self.text)}</pre>"


class Scene:
    """A validated scene, as in ``configs/*.toml``.

    Make one with :meth:`from_toml`, :meth:`from_str` or :meth:`from_dict`;
    :meth:`replace` gives a copy with fields changed. Every input the
    command line refuses raises :class:`InputError` here, with its message.
    """

    def __init__(self, inner: "_impactmc.Scene"):
        self._inner = inner

    @classmethod
    def from_toml(cls, path: PathLike) -> "Scene":
        """A scene file."""
        return cls(_impactmc.Scene.from_toml(os.fspath(path)))

    @classmethod
    def from_str(cls, text: str) -> "Scene":
        """Scene TOML text."""
        return cls(_impactmc.Scene.from_str(text))

    @classmethod
    def from_dict(cls, scene: Mapping[str, Any]) -> "Scene":
        """A scene as the dict of its TOML tables (``tomllib.load`` gives
        one)."""
        return cls(_impactmc.Scene._from_json(_json(dict(scene))))

    def replace(self, **fields: Any) -> "Scene":
        """A copy with fields replaced, e.g. ``replace(samples=10**6,
        laws=["newton"], precision="f64")``. A dict given for a table
        (``body={"mass": 2.0}``) is merged into it; a dotted path
        (``**{"body.mass": 2.0}``) names one field."""
        return Scene(self._inner._replace(_json(fields)))

    @property
    def name(self) -> str:
        return self._inner.name

    @property
    def effects(self) -> str:
        """What the command line prints first: the effects computed."""
        return self._inner.effects

    @property
    def kernel(self) -> str:
        """What the command line prints second: the kernel it runs."""
        return self._inner.kernel

    @property
    def toml(self) -> str:
        """The scene's TOML text."""
        return self._inner.toml

    def to_dict(self) -> dict:
        """The scene as the dict of its TOML tables (what
        :meth:`from_dict` takes)."""
        return json.loads(self._inner._to_json())

    def run(
        self,
        samples: Optional[int] = None,
        seed: Optional[int] = None,
        threads: Optional[int] = None,
        per_sample: bool = False,
        out: Optional[PathLike] = None,
        force: bool = False,
        shard: Optional[Union[str, Sequence[int]]] = None,
        progress: Progress = True,
        columns: Optional[Iterable[str]] = None,
    ) -> Result:
        """Runs the scene (every sweep point), as ``impactmc run`` does.

        ``samples`` and ``seed`` override the scene's; ``threads`` defaults
        to every core (results do not depend on it). With ``per_sample``
        the rows are kept (``Result.samples()``); ``columns`` chooses them.
        Without ``out`` nothing is written to disk; with it the run folder
        is written as the command line writes it (an existing run there
        raises :class:`OutputExistsError` unless ``force``). ``shard`` is
        ``"I/N"`` or ``(I, N)``. ``progress``: True shows a ``tqdm`` bar
        when tqdm is installed, a callable gets ``(done, total)`` samples
        about every 100 ms, False or None shows nothing.
        """
        if isinstance(shard, (tuple, list)):
            shard = f"{shard[0]}/{shard[1]}"
        callback, close = _progress(progress, "samples")
        try:
            inner = self._inner._run(
                samples=samples,
                seed=seed,
                threads=threads or 0,
                per_sample=per_sample,
                columns=None if columns is None else list(columns),
                out=None if out is None else os.fspath(out),
                force=force,
                shard=shard,
                callback=callback,
            )
        finally:
            close()
        return Result(inner)

    def __repr__(self) -> str:
        return repr(self._inner)


def _progress(progress: Progress, unit: str):
    """The callback for the progress of a run (in samples), a merge (in
    shards) or a ladder (in steps), and what closes it."""
    if callable(progress):
        return progress, lambda: None
    if not progress:
        return None, lambda: None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return None, lambda: None
    bar = None

    def update(done: int, total: int) -> None:
        nonlocal bar
        if bar is None:
            bar = tqdm(total=total, unit=unit, unit_scale=unit == "samples", leave=False)
        bar.update(done - bar.n)

    def close() -> None:
        if bar is not None:
            bar.close()

    return update, close
