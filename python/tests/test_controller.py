"""ptconsensus.Controller: the firmware's f32 controller stepped from Python gives the commands
of the built-in plant's run, sample by sample, bit for bit."""

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
    "args, key",
    [(([0.0], [], 0.0), "x"), (([0.0, 0.0], [1.0], 0.0), "neighbours")],
)
def test_wrong_lengths_name_the_argument(args, key):
    with pytest.raises(pc.ScenarioError, match=f"{key}:"):
        pc.Controller(EXAMPLE1, agent=1).step(*args)


def test_an_agent_out_of_range_is_an_error():
    with pytest.raises(pc.ScenarioError, match="agent: 5 out of range"):
        pc.Controller(EXAMPLE1, agent=5)
