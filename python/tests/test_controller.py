"""ptconsensus.Controller: the firmware's f32 controller stepped from Python gives the commands
of the built-in plant's run, sample by sample, bit for bit."""

import pickle

import numpy as np
import pytest

import ptconsensus as pc
from conftest import EXAMPLE1

SET = {"simulation.t_end": 3.0}


def test_stepped_controllers_give_the_commands_of_the_run():
    tr = pc.run(EXAMPLE1, set=SET).trajectory
    agents = sum(1 for c in tr.columns if c.startswith("mu"))
    for i in range(1, agents + 1):
        c = pc.Controller(EXAMPLE1, agent=i, set=SET)
        got = {k: [] for k in ("u1", "u2", "q1", "q2", "e1", "e2", "mu", "xi", "lambda")}
        for k in range(tr.rows):
            x = [tr[f"x{i}_1"][k], tr[f"x{i}_2"][k]]
            nb = [tr[f"y{j}"][k] for j in c.neighbours]
            s = c.step(x, nb, tr["yd"][k] if c.pinned else None)
            assert s["fault"] is None
            for l in (1, 2):
                got[f"u{l}"].append(s["u"][l - 1])
                got[f"q{l}"].append(s["q"][l - 1])
                got[f"e{l}"].append(s["e"][l - 1])
            for name in ("mu", "xi", "lambda"):
                got[name].append(s[name])
        for name, values in got.items():
            column = f"{name[0]}{i}_{name[1]}" if name[-1].isdigit() else f"{name}{i}"
            assert np.array_equal(np.array(values, dtype=np.float32), tr[column]), (i, column)


def test_the_graph_is_the_scenarios():
    assert pc.Controller(EXAMPLE1, agent=1).neighbours == []
    assert pc.Controller(EXAMPLE1, agent=1).pinned
    c = pc.Controller(EXAMPLE1, agent=4)
    assert (c.neighbours, c.pinned, c.n, c.m) == ([1, 3], False, 2, 2)


def test_reset_starts_over():
    c = pc.Controller(EXAMPLE1, agent=1)
    first = c.step([0.02, 0.8], [], 0.0)
    c.step([0.03, 0.7], [], 0.01)
    c.reset()
    assert c.step([0.02, 0.8], [], 0.0) == first


@pytest.mark.parametrize(
    "args, message",
    [
        (([0.1], [], 0.0), r"x: expected 2 values \(the agent's state, n\), got shape \(1,\)"),
        (([[0.1, 0.2]], [], 0.0), r"x: expected 2 values"),
        (([0.0, 0.0], [1.0], 0.0), r"neighbours: expected 0 values"),
    ],
)
def test_wrong_shapes_are_value_errors_naming_the_argument(args, message):
    with pytest.raises(ValueError, match=message):
        pc.Controller(EXAMPLE1, agent=1).step(*args)


@pytest.mark.parametrize(
    "args, name",
    [((["a", 0.0], [], 0.0), "x"), (([0.0, 0.0], [], "0.5"), "leader"), (([0.0, 0.0], "1"), "neighbours")],
)
def test_wrong_types_are_type_errors_naming_the_argument(args, name):
    c = pc.Controller(EXAMPLE1, agent=4 if name == "neighbours" else 1)
    with pytest.raises(TypeError, match=f"^{name}"):
        c.step(*args)


@pytest.mark.parametrize("agent", [5, 0, -1, 2**70])
def test_an_agent_out_of_range_is_a_value_error_naming_it(agent):
    with pytest.raises(pc.ScenarioError, match=f"agent: {agent} out of range"):
        pc.Controller(EXAMPLE1, agent=agent)


def test_an_agent_number_of_the_wrong_type_is_a_type_error():
    with pytest.raises(TypeError, match="agent"):
        pc.Controller(EXAMPLE1, agent="1")


def test_a_pinned_agent_without_a_leader_value_is_an_error():
    c = pc.Controller(EXAMPLE1, agent=1)
    with pytest.raises(ValueError, match="leader: agent 1 is pinned.*ptconsensus.MISSING"):
        c.step([0.5, 0.0], [])
    assert c.k == 0
    # With the leader's value the command is far from zero; an agent that is not pinned
    # needs none.
    assert abs(c.step([0.5, 0.0], [], 0.0).u[0]) > 1.0
    assert pc.Controller(EXAMPLE1, agent=2).step([0.5, 0.0], [0.4]).fault is None


def test_a_leader_deliberately_missing_is_passed_as_missing():
    with_value = pc.Controller(EXAMPLE1, agent=1).step([0.5, 0.0], [], 0.0)
    missing = pc.Controller(EXAMPLE1, agent=1).step([0.5, 0.0], [], pc.MISSING)
    assert not np.array_equal(missing.u, with_value.u)
    assert pc.MISSING is pickle.loads(pickle.dumps(pc.MISSING))


def test_step_returns_numpy_arrays_in_a_typed_result_and_counts_samples():
    c = pc.Controller(EXAMPLE1, agent=4)
    assert (c.h, c.k) == (0.001, 0)
    s = c.step(np.array([0.0, 0.7]), np.array([0.02, 0.01]))
    assert isinstance(s, pc.Step) and s.k == 0 and c.k == 1
    for name, size in (("u", c.m), ("q", c.m), ("e", c.n)):
        v = getattr(s, name)
        assert isinstance(v, np.ndarray) and v.dtype == np.float32 and v.shape == (size,), name
    assert s["lambda"] == s.lambda_ and isinstance(s.mu, float)
    c.step([0.0, 0.7], [None, pc.MISSING])
    assert c.k == 2
    c.reset()
    assert c.k == 0
