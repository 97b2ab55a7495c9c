"""ptconsensus.run against host-sim run: the same summary, trajectory and files."""

import csv
import json
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
        ({"decimate": 0}, "--decimate"),
        ({"format": "xlsx"}, "--format"),
        ({"agents": "9"}, "--agents"),
    ],
)
def test_bad_input_raises_scenario_error_naming_the_key(kwargs, key):
    with pytest.raises(pc.ScenarioError, match=key.replace(".", r"\.")) as e:
        pc.run(EXAMPLE1, **kwargs)
    assert isinstance(e.value, ValueError)


def test_a_missing_scenario_file_names_it():
    with pytest.raises(pc.ScenarioError, match="no-such.toml: not found"):
        pc.run("no-such.toml")


def test_to_pandas_has_the_columns_and_rows():
    pd = pytest.importorskip("pandas")
    tr = pc.run(EXAMPLE1, set={"simulation.t_end": 0.5}).trajectory
    df = tr.to_pandas()
    assert isinstance(df, pd.DataFrame)
    assert list(df.columns) == tr.columns and len(df) == 500
