"""Predefined-time adaptive consensus from Python.

``run`` runs one scenario (the ``host-sim run`` of the command line, same code path) and returns
its summary and trajectory; ``sweep`` runs a campaign (``host-sim sweep``) over a scenario's
keys and returns its results table; ``Controller`` steps one agent's firmware controller
(controller-core, ``f32``).

Errors are ``ScenarioError`` (a ``ValueError``) for an invalid scenario, key or argument value
and ``OutputError`` (an ``OSError``) for a file that cannot be read or written; both are
defined here, so they survive ``pickle`` (a worker of a process pool raises them unchanged).
Arguments of the wrong type raise ``TypeError``. Ctrl-C (``KeyboardInterrupt``) stops a run or
sweep within a few tens of milliseconds and leaves no partial file.
"""

from __future__ import annotations

import functools
import json
import math
import numbers
import operator
import os
import re
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

__all__ = [
    "MISSING",
    "Controller",
    "OutputError",
    "Results",
    "RunResult",
    "ScenarioError",
    "Step",
    "Trajectory",
    "run",
    "sweep",
]


class ScenarioError(ValueError):
    """An invalid scenario, campaign, key or argument value; the message names the key (a
    scenario key such as ``controller.ts``) or the argument (``decimate``, ``set["..."]``)."""


class OutputError(OSError):
    """A file could not be read or written; the message names it."""


# The extension raises the exceptions above (it imports them from this module), so it is
# imported after they are defined.
from . import _native  # noqa: E402


class _Missing:
    """A value that was not received (``Controller.step``'s ``leader`` or a neighbour)."""

    _instance: Optional["_Missing"] = None

    def __new__(cls) -> "_Missing":
        if cls._instance is None:
            cls._instance = super().__new__(cls)
        return cls._instance

    def __reduce__(self) -> str:
        return "MISSING"

    def __repr__(self) -> str:
        return "ptconsensus.MISSING"


MISSING = _Missing()
"""Passed as ``leader=`` (or as a neighbour's value) to ``Controller.step`` for a sample in which
that value was not received: the controller treats the link as missing, as a node does."""

Scenario = Union[str, "os.PathLike[str]", Mapping[str, Any]]
Progress = Union[bool, Callable[[int, int], None]]

_OPTION = re.compile(r"--([a-z][a-z0-9-]*)(?:(:)| (\d+))?")
_SET_KEY = re.compile(r"--set ([^\s:]+)")


def _python_terms(message: str) -> str:
    """A host-sim message in the words of this package's arguments: ``--decimate 9`` →
    ``decimate=9``, ``--force`` → ``force=True``, ``--set k`` → ``set["k"]``."""
    message = message.replace("invalid option: ", "invalid argument: ", 1)
    message = _SET_KEY.sub(lambda m: f"set[{json.dumps(m.group(1))}]", message)

    def option(m: "re.Match[str]") -> str:
        name = m.group(1).replace("-", "_")
        if name == "force":
            return "force=True" + (m.group(2) or "")
        if m.group(2):
            return f"{name}:"
        return f"{name}={m.group(3) or ''}"

    return _OPTION.sub(option, message)


def _call(function: Callable[..., Any], *args: Any) -> Any:
    """``function(*args)`` with the message of a ScenarioError or OutputError in Python's terms."""
    try:
        return function(*args)
    except (ScenarioError, OutputError) as e:
        raise type(e)(_python_terms(str(e))) from None


# --- Python values as TOML ---------------------------------------------------------------

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def _toml_key(key: Any, where: str) -> str:
    if not isinstance(key, str):
        raise TypeError(f"{where}: keys are strings, got {type(key).__name__} {key!r}")
    return key if _BARE_KEY.fullmatch(key) else json.dumps(key, ensure_ascii=False)


def _toml(value: Any, where: str) -> str:
    """``value`` as an inline TOML value; ``where`` names it in a TypeError."""
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        f = float(value)
        if math.isnan(f):
            return "nan"
        if math.isinf(f):
            return "inf" if f > 0 else "-inf"
        return repr(f)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, os.PathLike):
        return json.dumps(os.fspath(value), ensure_ascii=False)
    if isinstance(value, Mapping):
        items = (f"{_toml_key(k, where)} = {_toml(v, f'{where}.{k}')}" for k, v in value.items())
        return "{" + ", ".join(items) + "}"
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v, f"{where}[{i + 1}]") for i, v in enumerate(value)) + "]"
    raise TypeError(
        f"{where}: {type(value).__name__} is not a scenario value "
        "(numbers, booleans, strings, lists, arrays and dicts are)"
    )


def _toml_document(table: Mapping[str, Any], where: str) -> str:
    """A dict of tables as a TOML document (each top-level key on one line, inline)."""
    return "".join(f"{_toml_key(k, where)} = {_toml(v, f'{where}[{k!r}]')}\n" for k, v in table.items())


def _source(scenario: Scenario) -> Tuple[str, str]:
    """(kind, text) of a scenario given as a path, TOML text or a dict.

    A string is a path when it is one line without ``=`` (TOML text of a scenario has both).
    """
    if isinstance(scenario, Mapping):
        return "toml", _toml_document(scenario, "scenario")
    if isinstance(scenario, os.PathLike):
        return "path", os.fspath(scenario)
    if isinstance(scenario, str):
        if "\n" not in scenario and "=" not in scenario:
            return "path", scenario
        return "toml", scenario
    raise TypeError(f"scenario: expected a path, TOML text or a dict, got {type(scenario).__name__}")


def _pairs(set: Any) -> List[Tuple[str, Any]]:
    if set is None:
        return []
    if isinstance(set, Mapping):
        return list(set.items())
    if isinstance(set, (str, bytes)) or not isinstance(set, Iterable):
        raise TypeError(f"set: expected a dict {{key: value}} or (key, value) pairs, got {type(set).__name__}")
    pairs = []
    for item in set:
        if not (isinstance(item, (tuple, list)) and len(item) == 2):
            raise TypeError(f"set: expected (key, value) pairs, got {item!r}")
        pairs.append((item[0], item[1]))
    return pairs


def _sets(set: Any) -> List[str]:
    """Overrides ``{key: value}`` (or pairs) as the ``key=value`` lines of ``--set``."""
    lines = []
    for key, value in _pairs(set):
        if not isinstance(key, str):
            raise TypeError(f"set: keys are scenario keys as strings, got {type(key).__name__} {key!r}")
        lines.append(f"{key}={_toml(value, f'set[{json.dumps(key)}]')}")
    return lines


def _count(name: str, value: Any) -> Optional[int]:
    """An optional integer argument >= 1."""
    if value is None:
        return None
    if isinstance(value, bool):
        raise TypeError(f"{name}: expected an integer, got bool")
    try:
        k = operator.index(value)
    except TypeError:
        raise TypeError(f"{name}: expected an integer, got {type(value).__name__}") from None
    if k < 1:
        raise ScenarioError(f"invalid argument: {name}: must be >= 1, got {k}")
    return k


def _agents(value: Any) -> Optional[str]:
    """``agents=``: ``"1,3-4"`` or a list of 1-based agent numbers."""
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return str(int(value))
    if isinstance(value, Iterable):
        items = list(value)
        if all(isinstance(a, numbers.Integral) and not isinstance(a, bool) for a in items):
            return ",".join(str(int(a)) for a in items)
    raise TypeError(f"agents: expected \"1,3-4\" or a list of agent numbers, got {value!r}")


def _path(name: str, value: Any) -> Optional[Path]:
    if value is None:
        return None
    if not isinstance(value, (str, os.PathLike)):
        raise TypeError(f"{name}: expected a path, got {type(value).__name__}")
    return Path(value)


def _choice(name: str, value: Any, choices: Sequence[str]) -> str:
    if not isinstance(value, str):
        raise TypeError(f"{name}: expected one of {', '.join(map(repr, choices))}, got {type(value).__name__}")
    if value not in choices:
        raise ScenarioError(f"invalid argument: {name}: {value!r}, expected one of {', '.join(map(repr, choices))}")
    return value


def _flag(name: str, value: Any) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name}: expected True or False, got {type(value).__name__}")
    return bool(value)


# --- tables ------------------------------------------------------------------------------


class _Columns(Dict[str, np.ndarray]):
    """Named numpy columns in the order of a CSV file's header: a ``dict``, so that
    ``pandas.DataFrame(table)`` and ``polars.DataFrame(table)`` read it as columns."""

    @property
    def columns(self) -> List[str]:
        """Column names, as in the CSV header."""
        return list(self)

    @property
    def rows(self) -> int:
        """Number of rows."""
        return len(next(iter(self.values()), ()))

    def to_pandas(self) -> Any:
        """A ``pandas.DataFrame`` of the columns, without copying them where pandas allows it
        (it keeps numeric numpy columns as they are when ``copy=False``)."""
        import pandas as pd

        return pd.DataFrame(self, copy=False)

    def to_polars(self) -> Any:
        """A ``polars.DataFrame`` of the columns (polars takes numeric numpy arrays without a
        copy where it can; text columns are converted)."""
        import polars as pl

        return pl.DataFrame({k: v.tolist() if v.dtype == object else v for k, v in self.items()})

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.rows} rows, {len(self)} columns)"


_AGENT_COLUMN = re.compile(r"([a-z]+?)(\d+)(?:_(\d+))?")


class Trajectory(_Columns):
    """The columns of ``trajectory.csv`` as numpy arrays, in the CSV's order (a ``dict``).

    ``t``, ``yd``, ``y{i}``, ``x{i}_{j}`` and ``qf{i}_{l}`` are ``float64`` (the plant side);
    ``e``, ``u``, ``q`` and the estimates ``float32`` (the controller's own values).

    Stacked as python-control's ``TimeResponseData`` (agents first, time last): ``states``
    ``(agents, n, samples)``, ``errors`` ``(agents, n, samples)``, ``inputs``, ``quantized``,
    ``applied`` (``q^f``, after the faults) ``(agents, m, samples)``, ``outputs``
    ``(agents, samples)``, ``estimates`` ``(agents, 3, samples)`` (``mu``, ``xi``,
    ``lambda``); ``time`` and ``reference`` (``y_d``). A stacked array is built from the
    columns on first use (one copy) and kept; ``agents`` lists the agents it holds (1-based).
    """

    def _group(self, prefix: str) -> np.ndarray:
        by_agent: Dict[int, List[np.ndarray]] = {}
        for name, col in self.items():
            m = _AGENT_COLUMN.fullmatch(name)
            if m and m.group(1) == prefix:
                by_agent.setdefault(int(m.group(2)), []).append(col)
        if not by_agent:
            raise KeyError(f"no {prefix} columns in this trajectory")
        return np.stack([np.stack(cols) for _, cols in sorted(by_agent.items())])

    @property
    def agents(self) -> List[int]:
        """The agents (1-based) whose columns the trajectory holds."""
        return sorted(int(n[1:]) for n in self if re.fullmatch(r"y\d+", n))

    @property
    def time(self) -> np.ndarray:
        """Sample times ``t`` [s]."""
        return self["t"]

    @property
    def reference(self) -> np.ndarray:
        """The leader's ``y_d``."""
        return self["yd"]

    @functools.cached_property
    def states(self) -> np.ndarray:
        """``x`` as ``(agents, n, samples)``, ``float64``."""
        return self._group("x")

    @functools.cached_property
    def errors(self) -> np.ndarray:
        """The backstepping errors ``e`` as ``(agents, n, samples)``, ``float32``."""
        return self._group("e")

    @functools.cached_property
    def inputs(self) -> np.ndarray:
        """The commands ``u`` as ``(agents, m, samples)``, ``float32``."""
        return self._group("u")

    @functools.cached_property
    def quantized(self) -> np.ndarray:
        """The quantized commands ``q`` as ``(agents, m, samples)``, ``float32``."""
        return self._group("q")

    @functools.cached_property
    def applied(self) -> np.ndarray:
        """What the actuators apply after the faults, ``q^f`` (eq. 3), ``(agents, m, samples)``."""
        return self._group("qf")

    @functools.cached_property
    def outputs(self) -> np.ndarray:
        """``y`` as ``(agents, samples)``, ``float64``."""
        return self._group("y")[:, 0, :]

    @functools.cached_property
    def estimates(self) -> np.ndarray:
        """``(mu, xi, lambda)`` as ``(agents, 3, samples)``, ``float32``."""
        return np.stack([self._group(p)[:, 0, :] for p in ("mu", "xi", "lambda")], axis=1)


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


def _progress(show: Progress, unit: str) -> Tuple[Optional[Callable[[int, int], None]], Callable[[], None]]:
    """A callback (done, total) and a closer: tqdm if installed, else a line on stderr."""
    if callable(show):
        return show, lambda: None
    if not _flag("progress", show):
        return None, lambda: None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        tqdm = None
    if tqdm is not None:
        bar: List[Any] = []

        def update(done: int, total: int) -> None:
            if not bar:
                bar.append(tqdm(total=total, initial=done, unit=unit))
            else:
                bar[0].update(done - bar[0].n)

        return update, lambda: bar and bar[0].close()
    last = [-1]

    def show_line(done: int, total: int) -> None:
        step = max(1, total // 20)
        if done == total or done - last[0] >= step:
            last[0] = done
            print(f"\r{done}/{total} {unit}s", end="\n" if done == total else "", file=sys.stderr, flush=True)

    return show_line, lambda: None


def _remove_if_empty(directory: Optional[Path], existed: bool) -> None:
    """A directory this call created, removed again when nothing was put in it."""
    if directory is not None and not existed:
        try:
            directory.rmdir()
        except OSError:
            pass


def run(
    scenario: Scenario,
    set: Optional[Mapping[str, Any]] = None,
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
    *,
    format: str = "csv",
    plots: Optional[bool] = None,
    decimate: Optional[int] = None,
    agents: Optional[Union[str, Sequence[int]]] = None,
    trajectory: bool = True,
    force: bool = False,
    progress: Progress = False,
) -> RunResult:
    """Run one scenario, as ``host-sim run`` does.

    ``scenario``: a path to a TOML file, TOML text, or a dict of the same tables. ``set``:
    overrides ``{"controller.ts": 1.0, "plant.x0[2][1]": 0.5}`` (or ``(key, value)`` pairs), as
    ``--set``. ``out``: also write the files of ``host-sim run --out`` there (``summary.json``,
    the trajectory in ``format`` "csv" or "parquet", and the figures unless ``plots=False``).
    ``decimate`` and ``agents`` as the CLI's options; ``trajectory=False`` keeps no columns in
    memory. The trajectory's size is checked where it goes (the file in ``out``, else memory;
    2 GiB): ``force=True`` runs anyway. ``progress``: ``True`` shows the samples done (tqdm if
    installed), or a callable ``(done, total)``.

    Raises ``ScenarioError`` (a ``ValueError`` naming the key) for an invalid scenario or
    argument value, ``TypeError`` for an argument of the wrong type, ``OutputError`` (an
    ``OSError``) when a file cannot be written, ``KeyboardInterrupt`` on Ctrl-C (no partial
    file is left).
    """
    kind, source = _source(scenario)
    sets = _sets(set)
    out_path = _path("out", out)
    format = _choice("format", format, ("csv", "parquet"))
    draw = out_path is not None if plots is None else _flag("plots", plots)
    callback, close = _progress(progress, "sample")
    existed = out_path is not None and out_path.exists()
    try:
        summary, columns = _call(
            _native.run,
            kind,
            source,
            sets,
            None if out_path is None else os.fspath(out_path),
            format,
            draw,
            _count("decimate", decimate),
            _agents(agents),
            _flag("trajectory", trajectory),
            _flag("force", force),
            callback,
        )
    except BaseException:
        _remove_if_empty(out_path, existed)
        raise
    finally:
        close()
    table = Trajectory(columns) if columns is not None else None
    return RunResult(json.loads(summary), table, out_path)


class Results(_Columns):
    """A campaign's ``results.csv`` as columns (a ``dict``): ``run``, the axis keys, ``draw``
    and the sampled keys, the metrics, ``status``, ...

    Numbers are ``int64``/``float64`` arrays (an empty cell is NaN in a float column, and a
    column of empty cells is all NaN, as pandas reads it), flags ``bool``; text, and an integer
    or flag column with empty cells, are ``object`` arrays with ``None`` for empty cells.
    ``out`` is the campaign's directory (``None`` when it ran in a temporary one).
    """

    def __init__(self, columns: Mapping[str, List[Any]], out: Optional[Path]):
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


_CAMPAIGN_KEY = re.compile(r"^\s*scenario\s*=", re.M)


def _is_campaign_file(scenario: Any) -> bool:
    """A path to a campaign file (it names its base scenario with a top-level ``scenario``)."""
    if isinstance(scenario, Mapping) or (isinstance(scenario, str) and ("\n" in scenario or "=" in scenario)):
        return False
    try:
        return bool(_CAMPAIGN_KEY.search(Path(scenario).read_text()))
    except (OSError, UnicodeDecodeError, TypeError):
        return False


def _campaign(
    scenario: Scenario,
    directory: Path,
    set: Any,
    axes: Any,
    samples: Any,
    draws: Optional[int],
    seed: Optional[int],
    output_runs: Optional[Sequence[int]],
    metric: Optional[str],
) -> Path:
    """A campaign file over ``scenario`` written into ``directory`` (with the scenario's text
    beside it when it is given as text or a dict); returns its path."""
    kind, source = _source(scenario)
    if kind == "path":
        base = os.path.abspath(source)
    else:
        (directory / "scenario.toml").write_text(source)
        base = "scenario.toml"
    table: Dict[str, Any] = {"scenario": base}
    if set is not None:
        table["set"] = _sets(set)
    if axes is not None:
        table["axis"] = [{"key": k, "values": list(np.asarray(v).tolist() if isinstance(v, np.ndarray) else v)} for k, v in _pairs(axes)]
    if samples is not None:
        table["sample"] = [{"key": k, **dict(spec)} for k, spec in _pairs(samples)]
    if draws is not None:
        table["draws"] = _count("draws", draws)
    if seed is not None:
        table["seed"] = operator.index(seed)
    if output_runs is not None:
        table["output"] = {"runs": [operator.index(r) for r in output_runs]}
    if metric is not None:
        table["plot"] = {"metric": metric}
    path = directory / "campaign.toml"
    path.write_text(_toml_document(table, "campaign"))
    return path


def sweep(
    scenario: Scenario,
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
    *,
    axes: Optional[Mapping[str, Sequence[Any]]] = None,
    samples: Optional[Mapping[str, Mapping[str, Any]]] = None,
    draws: Optional[int] = None,
    seed: Optional[int] = None,
    set: Optional[Mapping[str, Any]] = None,
    output_runs: Optional[Sequence[int]] = None,
    metric: Optional[str] = None,
    shard: Optional[str] = None,
    format: str = "csv",
    progress: Progress = True,
) -> Results:
    """Run a campaign, as ``host-sim sweep``; returns its results table.

    ``scenario``: a campaign file (docs/CAMPAIGNS.md), or a scenario (a path, TOML text or a
    dict, as ``run`` takes) with the campaign given here: ``axes={"controller.ts": [0.5, 1.0],
    "simulation.h": [0.001, 0.002]}`` (a grid, every combination, first key slowest),
    ``samples={"plant.x0[1][1]": {"dist": "uniform", "low": -0.3, "high": 0.3}}`` (Monte Carlo
    draws, ``draws`` per grid point, ``seed``), ``set`` (overrides of every run),
    ``output_runs`` (runs that also write ``runs/<run>/``) and ``metric`` (the figures').

    ``out``: the campaign's directory (``results.csv``, ``campaign.json``, journal, figures; an
    interrupted sweep resumes from it); without it a temporary directory is used and removed
    (``Results.out`` is then ``None``). ``shard="k/N"`` runs one shard. ``format="parquet"``
    also writes ``results.parquet``. ``progress``: a tqdm bar if tqdm is installed, else a line
    on stderr; ``False`` for none, or a callable ``(done, total)``.

    Ctrl-C raises ``KeyboardInterrupt`` within a few tens of milliseconds; the runs finished
    before are in ``out``'s journal, and the same call resumes from them.
    """
    given = {"axes": axes, "samples": samples, "draws": draws, "seed": seed, "set": set, "output_runs": output_runs, "metric": metric}
    out_path = _path("out", out)
    format = _choice("format", format, ("csv", "parquet"))
    if shard is not None and not isinstance(shard, str):
        raise TypeError(f"shard: expected \"k/N\", got {type(shard).__name__}")
    callback, close = _progress(progress, "run")
    with tempfile.TemporaryDirectory(prefix="ptconsensus-sweep-") as tmp:
        if _is_campaign_file(scenario):
            extra = [k for k, v in given.items() if v is not None]
            if extra:
                raise TypeError(f"{extra[0]}: a campaign file defines its own; give a scenario instead of {os.fspath(scenario)}")
            campaign = Path(os.fspath(scenario))
        else:
            campaign = _campaign(scenario, Path(tmp), **given)
        directory = out_path if out_path is not None else Path(tmp) / "out"
        existed = directory.exists()
        try:
            columns = _call(_native.sweep, os.fspath(campaign), os.fspath(directory), shard, format, callback)
        except BaseException:
            _remove_if_empty(out_path, existed)
            raise
        finally:
            close()
    return Results(columns, out_path)


# --- one agent's controller --------------------------------------------------------------


@dataclass(frozen=True)
class Step:
    """One sample of ``Controller.step`` (LAW §6): the commands ``u`` before quantization (28),
    the quantized ``q`` (2) (``m`` values each, ``float32``), the backstepping errors ``e``
    (``n`` values), the adaptive estimates ``mu``, ``xi``, ``lambda_`` after the update, the
    sample index ``k`` it was (0-based), and ``fault``: ``None``, or why the step held its last
    command."""

    u: np.ndarray
    q: np.ndarray
    e: np.ndarray
    mu: float
    xi: float
    lambda_: float
    fault: Optional[str]
    k: int

    def __getitem__(self, name: str) -> Any:
        """``step["u"]``, ``step["lambda"]``: the fields by their names in ``trajectory.csv``."""
        return getattr(self, "lambda_" if name == "lambda" else name)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Step):
            return NotImplemented
        return (
            all(np.array_equal(getattr(self, f), getattr(other, f)) for f in ("u", "q", "e"))
            and (self.mu, self.xi, self.lambda_, self.fault, self.k) == (other.mu, other.xi, other.lambda_, other.fault, other.k)
        )


def _vector(name: str, values: Any, length: int, what: str) -> List[float]:
    try:
        a = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name}: expected {length} numbers ({what}), got {values!r}") from None
    if a.ndim != 1 or a.shape[0] != length:
        raise ValueError(f"{name}: expected {length} values ({what}), got shape {a.shape}")
    return a.tolist()


def _link(name: str, value: Any) -> Optional[float]:
    if value is None or value is MISSING:
        return None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name}: expected a number, None or ptconsensus.MISSING, got {type(value).__name__}")
    return float(value)


class Controller:
    """One agent's controller of a scenario: controller-core's law in ``f32``, the code the node
    firmware runs, stepped one sample at a time.

    ``Controller("scenarios/example1.toml", agent=2)``; ``step(x, neighbours, leader)`` takes the
    agent's state (``n`` values), its neighbours' outputs in the order of ``neighbours``
    (``None`` or ``MISSING``: nothing received) and the leader's ``y_d`` (required when
    ``pinned``; ``MISSING`` when it was not received), and returns a ``Step``. ``h`` is the
    scenario's sample period, ``k`` the number of samples stepped since the start or ``reset``.
    """

    def __init__(self, scenario: Scenario, agent: int = 1, set: Optional[Mapping[str, Any]] = None):
        kind, source = _source(scenario)
        if isinstance(agent, bool) or not isinstance(agent, numbers.Integral):
            raise TypeError(f"agent: expected a 1-based agent number, got {type(agent).__name__}")
        if not -(2**63) < agent < 2**63:
            raise ScenarioError(f"invalid scenario: agent: {agent} out of range (agents are 1-based)")
        self._inner = _call(_native.Controller, kind, source, _sets(set), int(agent))
        self.agent = int(agent)

    @property
    def n(self) -> int:
        """States per agent."""
        return self._inner.n

    @property
    def m(self) -> int:
        """Actuators per agent."""
        return self._inner.m

    @property
    def h(self) -> float:
        """The scenario's sample period ``h`` [s]."""
        return self._inner.h

    @property
    def k(self) -> int:
        """Samples stepped since the start or the last ``reset`` (the next step's index)."""
        return self._inner.k

    @property
    def neighbours(self) -> List[int]:
        """The agents (1-based) this one hears, in the order ``step`` takes their values."""
        return self._inner.neighbours

    @property
    def pinned(self) -> bool:
        """Whether this agent hears the leader."""
        return self._inner.pinned

    def step(self, x: Any, neighbours: Any = (), leader: Any = None) -> Step:
        """One sample (LAW §6); values are rounded to ``f32`` as a node reads them.

        A pinned agent needs ``leader``: ``leader=None`` raises ``ValueError`` (a forgotten
        value would otherwise read as ``y_d = 0`` being unknown), ``leader=MISSING`` says the
        leader's value was not received in this sample. An agent that is not pinned ignores it.
        """
        xs = _vector("x", x, self.n, "the agent's state, n")
        if isinstance(neighbours, (str, bytes)) or not isinstance(neighbours, Iterable):
            raise TypeError(f"neighbours: expected {len(self.neighbours)} values, got {type(neighbours).__name__}")
        nb = [_link(f"neighbours[{i}]", v) for i, v in enumerate(neighbours)]
        if len(nb) != len(self.neighbours):
            raise ValueError(
                f"neighbours: expected {len(self.neighbours)} values (the outputs of agents "
                f"{self.neighbours}), got {len(nb)}"
            )
        if self.pinned and leader is None:
            raise ValueError(
                f"leader: agent {self.agent} is pinned (it hears the leader): give the leader's "
                "y_d, or leader=ptconsensus.MISSING for a sample in which it was not received"
            )
        k = self.k
        u, q, e, mu, xi, lam, fault = _call(self._inner.step, xs, nb, _link("leader", leader))
        return Step(u, q, e, mu, xi, lam, fault, k)

    def reset(self) -> None:
        """Back to the initial state (sample 0, initial estimates)."""
        self._inner.reset()

    def __repr__(self) -> str:
        return (
            f"Controller(agent={self.agent}, n={self.n}, m={self.m}, h={self.h}, "
            f"neighbours={self.neighbours}, pinned={self.pinned}, k={self.k})"
        )
