"""The f32 firmware controller in host-sim against a float64 pure-Python reference of the law
(reference.py) on Example 1: the same gains and, after the predefined time, the same tracking
error within f32 rounding (LAW §8's anchor: about 0.17 at Ts = 2, h = 1 ms)."""

import pytest

import ptconsensus as pc
import reference
from conftest import EXAMPLE1

tomllib = pytest.importorskip("tomllib")


def test_the_f32_run_matches_the_float64_reference():
    with open(EXAMPLE1, "rb") as f:
        scenario = tomllib.load(f)
    ref = reference.run(scenario)
    s = pc.run(EXAMPLE1, trajectory=False).summary
    assert s["c1"] == pytest.approx(ref["c1"], rel=1e-6)
    assert s["c2"] == pytest.approx(ref["c2"], rel=1e-6)
    assert s["max_error_after_predefined_time"] == pytest.approx(ref["max_error_after_predefined_time"], rel=1e-3)
    assert 0.16 < ref["max_error_after_predefined_time"] < 0.18
    for a, mu, lam in zip(s["agents"], ref["final_mu"], ref["final_lambda"]):
        assert a["final_lambda"] == pytest.approx(lam, rel=1e-2)
        assert a["final_mu"] == pytest.approx(mu, rel=1e-2)
