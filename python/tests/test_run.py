"""ptconsensus.run against host-sim run: the same summary, trajectory and files."""

import csv
import re
import json
import os
import signal
from pathlib import Path

import numpy as np
import pytest

import ptconsensus as pc
from conftest import EXAMPLE1

SHORT = {"simulation.t_end": 2.0}


def read_csv(path: Path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def test_summary_equals_the_cli_summary_json(host_sim, tmp_path):
    host_sim("run", EXAMPLE1, "--out", tmp_path / "cli", "--no-plots", "-q", "--set", "simulation.t_end=2.0")
    r = pc.run(EXAMPLE1, set=SHORT)
    assert r.summary == json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert r.out is None


def test_trajectory_columns_equal_the_cli_csv(host_sim, tmp_path):
    host_sim("run", EXAMPLE1, "--out", tmp_path, "--no-plots", "-q", "--set", "simulation.t_end=2.0")
    header, rows = read_csv(tmp_path / "trajectory.csv")
    tr = pc.run(EXAMPLE1, set=SHORT).trajectory
    assert tr.columns == header
    assert tr.rows == len(rows) == 2000
    for c, name in enumerate(header):
        col = tr[name]
        parsed = np.array([float(r[c]) for r in rows])
        want = parsed.astype(col.dtype)
        assert np.array_equal(col, want, equal_nan=True), name
    assert tr["t"].dtype == np.float64 and tr["q1_1"].dtype == np.float32
    assert tr["t"][1234] == 1.234


def test_out_writes_the_files_of_host_sim_run(host_sim, tmp_path):
    host_sim("run", EXAMPLE1, "--out", tmp_path / "cli", "-q", "--set", "simulation.t_end=2.0")
    r = pc.run(EXAMPLE1, set=SHORT, out=tmp_path / "py")
    cli = sorted(p.name for p in (tmp_path / "cli").iterdir())
    assert sorted(p.name for p in (tmp_path / "py").iterdir()) == cli
    for name in ("summary.json", "trajectory.csv"):
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name
    assert r.out == tmp_path / "py"


def test_a_dict_and_toml_text_run_like_the_file():
    tomllib = pytest.importorskip("tomllib")

    text = EXAMPLE1.read_text()
    by_path = pc.run(EXAMPLE1, set=SHORT, trajectory=False).summary
    assert pc.run(text, set=SHORT, trajectory=False).summary == by_path
    assert pc.run(tomllib.loads(text), set=SHORT, trajectory=False).summary == by_path
    assert pc.run(str(EXAMPLE1), set=SHORT, trajectory=False).summary == by_path


def test_set_takes_python_values_as_toml_values():
    x0 = [[0.0, 0.0], [1.0, 1.0], [0.5, 0.0], [0.0, 0.0]]
    s = pc.run(
        EXAMPLE1,
        set={"simulation.t_end": 1, "controller.ts": 1.5, "quantizer.enabled": False, "plant.x0": np.array(x0)},
        trajectory=False,
    ).summary
    assert (s["predefined_time"], s["quantizer"], s["t_end"]) == (3.0, False, 1.0)


@pytest.mark.parametrize(
    "kwargs, key",
    [
        ({"set": {"controller.ts": -1.0}}, "controller.ts"),
        ({"set": {"controller.tss": 1.0}}, "controller"),
        ({"set": {"simulation.h": "fast"}}, "simulation.h"),
        ({"decimate": 0}, "decimate: must be >= 1"),
        ({"format": "xlsx"}, "format: 'xlsx'"),
        ({"agents": "9"}, "invalid argument: agents: "),
        ({"agents": [2, 9]}, "invalid argument: agents: "),
        ({"set": {"controller.ts": float("nan")}}, "controller.ts: "),
        ({"set": {"controller.ts": float("inf")}}, "controller.ts: "),
    ],
)
def test_bad_input_raises_scenario_error_naming_the_key(kwargs, key):
    with pytest.raises(pc.ScenarioError, match=re.escape(key)) as e:
        pc.run(EXAMPLE1, **kwargs)
    assert isinstance(e.value, ValueError)
    assert "--" not in str(e.value) and "line 1 column" not in str(e.value)


@pytest.mark.parametrize("name", ["no-such.toml", "scenarios/example1", "no such file"])
def test_a_missing_scenario_file_names_it(name):
    with pytest.raises(pc.ScenarioError, match=f"{name}: not found"):
        pc.run(name)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"set": [("controller.ts", 1)]}, None),
        ({"set": "controller.ts=1"}, "set"),
        ({"set": {"controller.ts": object()}}, 'set["controller.ts"]'),
        ({"set": {1: 1.0}}, "set"),
        ({"decimate": "3"}, "decimate"),
        ({"decimate": 2.5}, "decimate"),
        ({"trajectory": "no"}, "trajectory"),
        ({"out": 3}, "out"),
        ({"format": 1}, "format"),
    ],
)
def test_arguments_of_the_wrong_type_are_type_errors_naming_them(kwargs, name):
    run = lambda: pc.run(EXAMPLE1, **{"set": SHORT, "trajectory": False, **kwargs})
    if name is None:  # (key, value) pairs are overrides too
        assert run().summary["predefined_time"] == 2.0
        return
    with pytest.raises(TypeError, match="^" + re.escape(name)):
        run()


def test_a_size_limit_message_speaks_of_the_arguments(tmp_path):
    long = {"simulation.t_end": 3000.0}
    with pytest.raises(pc.ScenarioError) as e:
        pc.run(EXAMPLE1, set=long, out=tmp_path / "o", plots=False)
    message = str(e.value)
    assert message.startswith("invalid argument: decimate: trajectory.csv would take about 2.51 GB")
    assert "use decimate=2 " in message and "or force=True" in message
    assert not (tmp_path / "o").exists()
    with pytest.raises(pc.ScenarioError, match="decimate: the trajectory kept in memory would take about 2.24 GB"):
        pc.run(EXAMPLE1, set={"simulation.t_end": 7000.0})


def test_a_long_run_without_files_or_trajectory_is_not_refused():
    """7,000 s of Example 1 (its trajectory.csv would take 5.85 GB): nothing is written or kept,
    so the size limit does not apply; the run starts (a progress call) and is then stopped."""
    calls = []

    def progress(done, total):
        calls.append((done, total))
        if len(calls) == 2:  # the signal handler runs here, or at the next check
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(KeyboardInterrupt):
        pc.run(EXAMPLE1, set={"simulation.t_end": 7000.0}, trajectory=False, progress=progress)
    assert calls[0][1] == 7_000_000 and calls[-1][0] < 7_000_000


def test_an_exception_of_the_progress_callback_stops_the_run():
    def progress(done, total):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        pc.run(EXAMPLE1, set={"simulation.t_end": 7000.0}, trajectory=False, progress=progress)


def test_progress_reports_the_samples_of_a_run():
    calls = []
    pc.run(EXAMPLE1, set=SHORT, trajectory=False, progress=lambda d, t: calls.append((d, t)))
    assert calls[-1] == (2000, 2000) and all(t == 2000 for _, t in calls)


def test_to_pandas_has_the_columns_and_rows():
    pd = pytest.importorskip("pandas")
    tr = pc.run(EXAMPLE1, set={"simulation.t_end": 0.5}).trajectory
    df = tr.to_pandas()
    assert isinstance(df, pd.DataFrame)
    assert list(df.columns) == tr.columns and len(df) == 500
    assert np.shares_memory(df["u1_1"].to_numpy(), tr["u1_1"]), "to_pandas copied"
