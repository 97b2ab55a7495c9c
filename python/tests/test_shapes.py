"""Results shaped for the tools researchers use: the trajectory is a dict of numpy arrays that
pandas and polars read as columns, with stacked (agents, ..., samples) arrays like
python-control's TimeResponseData."""

import csv

import numpy as np
import pytest

import ptconsensus as pc
from conftest import EXAMPLE1

SHORT = {"simulation.t_end": 1.0}


@pytest.fixture(scope="module")
def tr():
    return pc.run(EXAMPLE1, set=SHORT).trajectory


def test_the_trajectory_is_a_dict_that_pandas_reads_as_the_csv(tr, host_sim, tmp_path):
    pd = pytest.importorskip("pandas")
    host_sim("run", EXAMPLE1, "--out", tmp_path, "--no-plots", "-q", "--set", "simulation.t_end=1")
    with open(tmp_path / "trajectory.csv", newline="") as f:
        rows = list(csv.reader(f))
    assert isinstance(tr, dict)
    df = pd.DataFrame(tr)
    assert df.shape == (len(rows) - 1, len(rows[0])) == (1000, 58)
    assert list(df.columns) == rows[0]
    assert df["u4_2"].dtype == np.float32 and df["t"].dtype == np.float64


def test_polars_reads_the_trajectory_as_columns(tr):
    pl = pytest.importorskip("polars")
    df = pl.DataFrame(tr)
    assert df.shape == (1000, 58) and df.columns == tr.columns
    assert df["q1_1"].dtype == pl.Float32
    assert tr.to_polars().equals(df)
    assert np.shares_memory(df["q1_1"].to_numpy(), tr["q1_1"]), "polars copied"


def test_stacked_arrays_are_agents_by_quantity_by_samples(tr):
    assert tr.agents == [1, 2, 3, 4]
    assert tr.states.shape == (4, 2, 1000) and tr.states.dtype == np.float64
    assert np.array_equal(tr.states[2, 1], tr["x3_2"])
    assert tr.errors.shape == (4, 2, 1000) and np.array_equal(tr.errors[0, 0], tr["e1_1"])
    for name, prefix in (("inputs", "u"), ("quantized", "q"), ("applied", "qf")):
        a = getattr(tr, name)
        assert a.shape == (4, 2, 1000), name
        assert np.array_equal(a[3, 1], tr[f"{prefix}4_2"]), name
    assert tr.outputs.shape == (4, 1000) and np.array_equal(tr.outputs[1], tr["y2"])
    assert tr.estimates.shape == (4, 3, 1000)
    assert np.array_equal(tr.estimates[3, 2], tr["lambda4"]) and np.array_equal(tr.estimates[0, 0], tr["mu1"])
    assert tr.time is tr["t"] and tr.reference is tr["yd"]
    assert tr.inputs is tr.inputs  # built once


def test_a_subset_of_agents_stacks_those_agents():
    tr = pc.run(EXAMPLE1, set=SHORT, agents=[2, 4], decimate=10).trajectory
    assert tr.agents == [2, 4] and tr.states.shape == (2, 2, 100)
    assert np.array_equal(tr.inputs[1, 0], tr["u4_1"])
