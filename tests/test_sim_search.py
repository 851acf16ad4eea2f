"""phyplan_agents.sim_search: the one search on the real simulator (the oracle's), on stand-in objectives."""
from __future__ import annotations

import math

import numpy as np
import pytest

from phyplan_agents.sim_search import LocalSearch, periodic_dims, search


def _bowl(target):
    t = np.asarray(target, dtype=np.float64)
    return lambda a: 1.0 - float(np.linalg.norm(np.asarray(a) - t))


def test_finds_an_interior_optimum_within_budget_and_records_history():
    calls = []
    f = _bowl([0.3, 1.1, 0.7])

    def objective(a):
        calls.append(np.array(a))
        return f(a)                                  # a plain float objective (no info)

    res = search(objective, [0, 0.5, 0], [1, 1.5, 1], budget=300, seed=3)
    assert res.best_reward >= 0.995 and res.calls == len(calls) <= 300
    assert res.best_reward >= res.grid_best_reward and res.grid_points == 4 ** 3 and res.starts >= 1
    actions, rewards = res.history
    assert actions.shape == (res.calls, 3) and rewards.shape == (res.calls,)
    np.testing.assert_array_equal(actions, np.asarray(calls))        # in call order, the actions really called
    assert rewards.max() == res.best_reward
    np.testing.assert_array_equal(actions[int(np.argmax(rewards))], res.best_action)


def test_same_seed_same_calls_other_seed_other_samples():
    f = _bowl([0.41, 0.77])
    a = search(f, [0, 0], [1, 1], budget=120, seed=5, stop_reward=1.0)
    b = search(f, [0, 0], [1, 1], budget=120, seed=5, stop_reward=1.0)
    c = search(f, [0, 0], [1, 1], budget=120, seed=6, stop_reward=1.0)
    np.testing.assert_array_equal(a.history[0], b.history[0])
    assert a.best_reward == b.best_reward and a.calls == b.calls == 120     # stop_reward 1.0 spends the budget
    assert not np.array_equal(a.history[0], c.history[0])


def test_periodic_dimension_wraps_around_the_bound():
    assert periodic_dims([-math.pi, 0.5], [math.pi, 1.5]).tolist() == [True, False]
    target = np.array([math.pi - 0.02, 1.2])

    def f(a):
        d = (a[0] - target[0] + math.pi) % (2 * math.pi) - math.pi
        return 1.0 - math.hypot(d, a[1] - target[1])

    res = search(f, [-math.pi, 0.5], [math.pi, 1.5], budget=150, seed=0)
    assert f(res.best_action) >= 0.995
    acts = res.history[0]
    assert np.all(acts >= [-math.pi, 0.5]) and np.all(acts <= [math.pi, 1.5])


def test_model_step_uses_final_position_and_goal():
    # the final xy is a linear map of the action; the reward only says how far it lands from the goal
    goal = np.array([0.37, -0.21])
    m = np.array([[1.0, 0.3], [-0.2, 0.8]])

    def sim(a):
        final = m @ (np.asarray(a) - 0.5)
        return 1.0 - float(np.linalg.norm(final - goal)), {"final_pos": np.r_[final, 0.0], "goal": goal}

    with_model = search(sim, [0, 0], [1, 1], budget=200, seed=0)
    without = search(sim, [0, 0], [1, 1], budget=200, seed=0, model_steps=False)
    assert with_model.best_reward >= 0.995
    assert with_model.calls < without.calls              # Gauss-Newton lands on the goal in a few steps


def test_non_finite_rewards_count_as_minus_infinity():
    res = search(lambda a: math.nan if a[0] < 0.5 else 1.0 - abs(a[0] - 0.8), [0.0], [1.0], budget=40, seed=0)
    assert res.best_action[0] >= 0.5 and res.best_reward >= 0.99
    assert np.isneginf(res.history[1][0])                    # the grid's first point, a = 0


def test_continuation_refine_and_next_distinct():
    s = LocalSearch(_bowl([0.2, 0.9]), [0, 0], [1, 1], budget=40, seed=1)
    with pytest.raises(RuntimeError, match="run"):
        s.refine_best(5)
    s.run()
    with pytest.raises(RuntimeError, match="already"):
        s.run()
    calls = s.calls
    s.refine_best(10)
    assert calls < s.calls <= calls + 10
    other = s.next_distinct([s.best_u])
    assert np.max(s.gap(other, s.best_u)) > 0.01


@pytest.mark.parametrize("kw, name", [({"budget": 3}, "budget"), ({"budget": 10.0}, "budget"),
                                      ({"grid_fraction": 0.0}, "grid_fraction"), ({"n_starts": 0}, "n_starts"),
                                      ({"stop_reward": 1.5}, "stop_reward"), ({"min_step": 1.0}, "min_step")])
def test_bad_options_name_the_argument(kw, name):
    with pytest.raises(ValueError, match=name):
        search(_bowl([0.5]), [0.0], [1.0], **kw)


def test_bad_bounds_and_objective_are_errors():
    with pytest.raises(ValueError, match="high > low"):
        search(_bowl([0.5]), [1.0], [0.0])
    with pytest.raises(ValueError, match="finite"):
        search(_bowl([0.5]), [0.0], [math.inf])
    with pytest.raises(TypeError, match="objective"):
        search(42, [0.0], [1.0])
    with pytest.raises(ValueError, match="periodic"):
        LocalSearch(_bowl([0.5]), [0.0], [1.0], periodic=[True, False])
