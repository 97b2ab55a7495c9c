"""The package's exceptions survive pickle and a process pool with their type and message, and
speak of Python's arguments."""

import pickle
from concurrent.futures import ProcessPoolExecutor

import pytest

import ptconsensus as pc
from conftest import EXAMPLE1


def run_with(overrides):
    """A pool worker's task: one short run with `overrides`."""
    return pc.run(EXAMPLE1, set={"simulation.t_end": 0.5, **overrides}, trajectory=False).summary


@pytest.mark.parametrize("error", [pc.ScenarioError, pc.OutputError])
def test_exceptions_are_defined_in_the_package(error):
    assert error.__module__ == "ptconsensus"
    assert pc.ScenarioError.__mro__[1] is ValueError and pc.OutputError.__mro__[1] is OSError


def test_a_raised_error_pickles_with_its_type_and_message(tmp_path):
    with pytest.raises(pc.ScenarioError) as bad_key:
        pc.run(EXAMPLE1, set={"controller.ts": -1.0})
    blocked = tmp_path / "file"
    blocked.write_text("")
    with pytest.raises(pc.OutputError) as bad_out:
        pc.run(EXAMPLE1, set={"simulation.t_end": 0.1}, out=blocked / "sub")
    for e in (bad_key.value, bad_out.value):
        back = pickle.loads(pickle.dumps(e))
        assert type(back) is type(e) and str(back) == str(e) and str(e)
    assert "controller.ts: `ts` must be > 0" in str(bad_key.value)


def test_an_error_in_a_pool_worker_arrives_with_its_type_and_message():
    with ProcessPoolExecutor(max_workers=2) as pool:
        good = pool.submit(run_with, {"controller.ts": 1.0})
        bad = pool.submit(run_with, {"controller.ts": -1.0})
        assert good.result()["predefined_time"] == 2.0
        with pytest.raises(pc.ScenarioError, match=r"invalid scenario: controller\.ts: `ts` must be > 0") as e:
            bad.result()
    assert isinstance(e.value, ValueError)


def test_option_messages_name_the_python_arguments():
    assert pc._python_terms("invalid option: --decimate: use --decimate 9 (about 1 GB), or --force to write it") == (
        "invalid argument: decimate: use decimate=9 (about 1 GB), or force=True to write it"
    )
    assert pc._python_terms("invalid option: --set controller.ts: bad") == 'invalid argument: set["controller.ts"]: bad'
