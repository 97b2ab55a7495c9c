"""ptconsensus.sweep against host-sim sweep: the same results table and files."""

import csv

import numpy as np
import pytest

import ptconsensus as pc
from conftest import EXAMPLE1, GRID


def test_results_equal_the_cli_results_csv(host_sim, tmp_path):
    host_sim("sweep", GRID, "--out", tmp_path / "cli", "-q")
    calls = []
    r = pc.sweep(GRID, tmp_path / "py", progress=lambda done, total: calls.append((done, total)))
    cli = (tmp_path / "cli" / "results.csv").read_bytes()
    assert (tmp_path / "py" / "results.csv").read_bytes() == cli
    with open(tmp_path / "cli" / "results.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert r.columns == list(rows[0].keys())
    assert r["run"].tolist() == [int(x["run"]) for x in rows]
    for name in ("max_abs_u", "settling_time", "divergence_time"):
        want = np.array([float(x[name]) if x[name] else np.nan for x in rows])
        assert np.array_equal(r[name], want, equal_nan=True), name
    assert [s for s in r["status"]] == [x["status"] for x in rows]
    assert calls[0] == (0, 6) and calls[-1] == (6, 6) and len(calls) == 7


def test_without_out_a_temporary_directory_is_used(capsys):
    r = pc.sweep(GRID, progress=False)
    assert len(r["run"]) == 6 and r.out is None
    assert isinstance(r, dict)


def test_a_scenario_with_axes_as_python_values_sweeps_like_the_campaign_file(tmp_path):
    from_file = pc.sweep(GRID, progress=False)
    axes = {"controller.ts": [0.5, 1.0], "simulation.h": np.array([0.0, 0.002, 0.012])}
    scenario = GRID.parent / "../../../scenarios/example1.toml"
    text = scenario.read_text()
    tomllib = __import__("tomllib")
    for given in (scenario, str(scenario), text, tomllib.loads(text)):
        r = pc.sweep(given, axes=axes, set={"simulation.t_end": 3}, progress=False)
        assert r.columns == from_file.columns
        for name in r.columns:
            if name == "scenario":
                continue
            a, b = r[name], from_file[name]
            assert np.array_equal(a, b, equal_nan=a.dtype == np.float64), name


def test_monte_carlo_draws_given_as_python_values(tmp_path):
    r = pc.sweep(
        EXAMPLE1,
        tmp_path,
        samples={"plant.x0[1][1]": {"dist": "uniform", "low": -0.3, "high": 0.3}},
        draws=3,
        seed=7,
        set={"simulation.t_end": 0.5},
        progress=False,
    )
    assert r.out == tmp_path and (tmp_path / "results.csv").exists()
    assert r["draw"].tolist() == [0, 1, 2]
    x = r["plant.x0[1][1]"]
    assert x.dtype == np.float64 and np.all((-0.3 <= x) & (x < 0.3)) and len(set(x)) == 3


def test_a_campaign_file_with_axes_given_too_is_a_type_error():
    with pytest.raises(TypeError, match="axes: a campaign file defines its own"):
        pc.sweep(GRID, axes={"controller.ts": [1.0]}, progress=False)
