"""ptconsensus.sweep against host-sim sweep: the same results table and files."""

import csv

import numpy as np

import ptconsensus as pc
from conftest import GRID


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
    assert len(r["run"]) == 6 and not r.out.exists()
