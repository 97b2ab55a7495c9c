"""Predefined-time adaptive consensus from Python.

``run`` runs one scenario (the ``host-sim run`` of the command line, same code path) and returns
its summary and trajectory; ``sweep`` runs a campaign (``host-sim sweep``) and returns its results
table; ``Controller`` steps one agent's firmware controller (controller-core, ``f32``).
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Any, Callable, Dict, Iterator, List, Mapping, Optional, Tuple, Union

import numpy as np

from . import _native
from ._native import OutputError, ScenarioError

__all__ = [
    "Controller",
    "OutputError",
    "Results",
    "RunResult",
    "ScenarioError",
    "Trajectory",
    "run",
    "sweep",
]

Scenario = Union[str, "os.PathLike[str]", Mapping[str, Any]]


def _source(scenario: Scenario) -> Tuple[str, str]:
    """(kind, text) of a scenario given as a path, TOML text or a dict."""
    if isinstance(scenario, Mapping):
        return "json", json.dumps(scenario, default=_plain)
    if isinstance(scenario, os.PathLike):
        return "path", os.fspath(scenario)
    if isinstance(scenario, str):
        one_line = "\n" not in scenario and "=" not in scenario
        if one_line and (scenario.endswith(".toml") or os.path.isfile(scenario)):
            return "path", scenario
        return "toml", scenario
    raise TypeError(
        f"scenario: expected a path, TOML text or a dict, got {type(scenario).__name__}"
    )


def _plain(value: Any) -> Any:
    """numpy values as plain Python ones (for JSON)."""
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not a scenario value")


def _sets(set: Optional[Mapping[str, Any]]) -> List[Tuple[str, str]]:
    """``{key: value}`` as (key, JSON value) pairs: host-sim writes each as ``--set key=value``."""
    return [(str(k), json.dumps(v, default=_plain)) for k, v in (set or {}).items()]


class _Columns(Mapping[str, np.ndarray]):
    """Named numpy columns in the order of a CSV file's header."""

    def __init__(self, columns: Dict[str, np.ndarray]):
        self._columns = columns

    def __getitem__(self, name: str) -> np.ndarray:
        return self._columns[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._columns)

    def __len__(self) -> int:
        return len(self._columns)

    @property
    def columns(self) -> List[str]:
        """Column names, as in the CSV header."""
        return list(self._columns)

    @property
    def rows(self) -> int:
        """Number of rows."""
        return len(next(iter(self._columns.values()), ()))

    def to_pandas(self) -> "Any":
        """A ``pandas.DataFrame`` (needs pandas)."""
        import pandas as pd

        return pd.DataFrame(self._columns)

    def to_polars(self) -> "Any":
        """A ``polars.DataFrame`` (needs polars)."""
        import polars as pl

        return pl.DataFrame({k: v.tolist() if v.dtype == object else v for k, v in self._columns.items()})

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.rows} rows, {len(self)} columns)"


class Trajectory(_Columns):
    """The columns of ``trajectory.csv`` as numpy arrays, in the CSV's order.

    ``t``, ``yd``, ``y{i}``, ``x{i}_{j}`` are ``float64`` (the plant side); ``e``, ``u``, ``q``
    and the estimates ``float32`` (the controller's own values).
    """


class RunResult:
    """One finished run: ``summary`` (equal to summary.json), ``trajectory``, ``out``."""

    def __init__(self, summary: Dict[str, Any], trajectory: Optional[Trajectory], out: Optional[Path]):
        self.summary = summary
        self.trajectory = trajectory
        self.out = out

    def __repr__(self) -> str:
        s = self.summary
        return (
            f"RunResult({s.get('scenario')!r}, diverged={s.get('diverged')}, "
            f"max_error_after_predefined_time={s.get('max_error_after_predefined_time')})"
        )


def run(
    scenario: Scenario,
    set: Optional[Mapping[str, Any]] = None,
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
    *,
    format: str = "csv",
    plots: Optional[bool] = None,
    decimate: Optional[int] = None,
    agents: Optional[str] = None,
    trajectory: bool = True,
) -> RunResult:
    """Run one scenario, as ``host-sim run`` does.

    ``scenario``: a path to a TOML file, TOML text, or a dict of the same tables. ``set``:
    overrides ``{"controller.ts": 1.0, "plant.x0[2][1]": 0.5}``, as ``--set``. ``out``: also
    write the files of ``host-sim run --out`` there (``summary.json``, the trajectory in
    ``format`` "csv" or "parquet", and the figures unless ``plots=False``). ``decimate`` and
    ``agents`` as the CLI's options; ``trajectory=False`` keeps no columns in memory.

    Raises ``ScenarioError`` (a ``ValueError`` naming the key) for an invalid scenario or option,
    ``OutputError`` (an ``OSError``) when a file cannot be written.
    """
    kind, source = _source(scenario)
    out_path = Path(out) if out is not None else None
    summary, columns = _native.run(
        kind,
        source,
        _sets(set),
        None if out_path is None else os.fspath(out_path),
        format,
        out_path is not None if plots is None else plots,
        decimate,
        agents,
        trajectory,
    )
    table = Trajectory(columns) if columns is not None else None
    return RunResult(json.loads(summary), table, out_path)


class Results(_Columns):
    """A campaign's ``results.csv`` as columns: ``run``, the axis keys, the metrics, ...

    Numbers are ``int64``/``float64`` arrays (an empty cell is NaN in a float column, and a
    column of empty cells is all NaN, as pandas reads it), flags ``bool``; text, and an integer
    or flag column with empty cells, are ``object`` arrays with ``None`` for empty cells.
    ``out`` is the campaign's directory.
    """

    def __init__(self, columns: Dict[str, List[Any]], out: Path):
        super().__init__({k: _array(v) for k, v in columns.items()})
        self.out = out


def _array(values: List[Any]) -> np.ndarray:
    given = [v for v in values if v is not None]
    if all(isinstance(v, float) for v in given):
        return np.array([np.nan if v is None else v for v in values], dtype=np.float64)
    if len(given) == len(values) and values:
        if all(isinstance(v, bool) for v in values):
            return np.array(values, dtype=bool)
        if all(isinstance(v, int) for v in values):
            return np.array(values, dtype=np.int64)
    return np.array(values, dtype=object)


def _progress(show: Union[bool, Callable[[int, int], None]]) -> Tuple[Optional[Callable[[int, int], None]], Callable[[], None]]:
    """A callback (done, total) and a closer: tqdm if installed, else a line on stderr."""
    if callable(show):
        return show, lambda: None
    if not show:
        return None, lambda: None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        tqdm = None
    if tqdm is not None:
        bar: List[Any] = []

        def update(done: int, total: int) -> None:
            if not bar:
                bar.append(tqdm(total=total, initial=done, unit="run"))
            else:
                bar[0].update(done - bar[0].n)

        return update, lambda: bar and bar[0].close()
    last = [-1]

    def show_line(done: int, total: int) -> None:
        step = max(1, total // 20)
        if done == total or done - last[0] >= step:
            last[0] = done
            print(f"\r{done}/{total} runs", end="\n" if done == total else "", file=sys.stderr, flush=True)

    return show_line, lambda: None


def sweep(
    campaign: Union[str, "os.PathLike[str]"],
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
    *,
    shard: Optional[str] = None,
    format: str = "csv",
    progress: Union[bool, Callable[[int, int], None]] = True,
) -> Results:
    """Run a campaign file, as ``host-sim sweep``; returns its results table.

    ``out``: the campaign's directory (``results.csv``, ``campaign.json``, journal, figures;
    an interrupted sweep resumes from it); without it a temporary directory is used and removed.
    ``shard="k/N"`` runs one shard. ``format="parquet"`` also writes ``results.parquet``.
    ``progress``: a tqdm bar if tqdm is installed, else a line on stderr; ``False`` for none, or a
    callable ``(done, total)``.
    """
    callback, close = _progress(progress)
    if out is None:
        with tempfile.TemporaryDirectory(prefix="ptconsensus-sweep-") as tmp:
            try:
                columns = _native.sweep(os.fspath(campaign), tmp, shard, format, callback)
            finally:
                close()
            return Results(columns, Path(tmp))
    try:
        columns = _native.sweep(os.fspath(campaign), os.fspath(out), shard, format, callback)
    finally:
        close()
    return Results(columns, Path(out))


class Controller:
    """One agent's controller of a scenario: controller-core's law in ``f32``, the code the node
    firmware runs, stepped one sample at a time.

    ``Controller("scenarios/example1.toml", agent=2)``; ``step(x, neighbours, leader)`` takes the
    agent's state (``n`` values), its neighbours' outputs in the order of ``neighbours``
    (``None``: nothing received) and the leader's ``y_d`` (used when ``pinned``), and returns the
    step's ``u``, ``q``, ``e``, ``mu``, ``xi``, ``lambda`` and ``fault``.
    """

    def __init__(self, scenario: Scenario, agent: int = 1, set: Optional[Mapping[str, Any]] = None):
        kind, source = _source(scenario)
        self._inner = _native.Controller(kind, source, _sets(set), agent)
        self.agent = agent

    @property
    def n(self) -> int:
        """States per agent."""
        return self._inner.n

    @property
    def m(self) -> int:
        """Actuators per agent."""
        return self._inner.m

    @property
    def neighbours(self) -> List[int]:
        """The agents (1-based) this one hears, in the order ``step`` takes their values."""
        return self._inner.neighbours

    @property
    def pinned(self) -> bool:
        """Whether this agent hears the leader."""
        return self._inner.pinned

    def step(self, x: Any, neighbours: Any = (), leader: Optional[float] = None) -> Dict[str, Any]:
        """One sample (LAW §6); values are rounded to ``f32`` as a node reads them."""
        xs = [float(v) for v in x]
        nb = [None if v is None else float(v) for v in neighbours]
        return self._inner.step(xs, nb, None if leader is None else float(leader))

    def reset(self) -> None:
        """Back to the initial state (sample 0, initial estimates)."""
        self._inner.reset()

    def __repr__(self) -> str:
        return f"Controller(agent={self.agent}, n={self.n}, m={self.m}, neighbours={self.neighbours}, pinned={self.pinned})"
