"""Property-based fuzz of every registered env: whatever is passed to ``reset`` and ``step`` (seeds,
options valid and garbage, actions finite, NaN, inf, huge, on the bounds, of the wrong shape or dtype), the env
either raises a clear ``ValueError``/``TypeError`` or returns a finite reward and an observation inside its space.

The default run draws 100 cases (derandomised: the same cases every run); ``pytest -m slow`` adds a run of 2,000.
"""
from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import phyplan_envs
from phyplan_envs.spaces import GOAL_BOUND

IDS = [phyplan_envs.env_id(t) for t in phyplan_envs.ALL_TASKS]
_ENVS: dict[str, gym.Env] = {}


def _env(env_id: str) -> gym.Env:
    if env_id not in _ENVS:
        _ENVS[env_id] = gym.make(env_id)
    return _ENVS[env_id]


@pytest.fixture(scope="module", autouse=True)
def _close_envs():
    yield
    for env in _ENVS.values():
        env.close()
    _ENVS.clear()


# ============================================================================================== the strategies
FLOATS = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([0.0, -0.0, 1e-300, 1e155, 1e39,
                                                                                     -1e308, 10.0, 6.0, 6.000001]))
SCALARS = st.one_of(FLOATS, st.integers(-2 ** 70, 2 ** 70), st.booleans(), st.none(), st.text(max_size=5),
                    st.complex_numbers(max_magnitude=10), st.binary(max_size=4))
GARBAGE = st.recursive(SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                        st.dictionaries(st.text(max_size=4), inner, max_size=3),
                                                        st.tuples(inner, inner)), max_leaves=8)
GOALS = st.one_of(
    st.tuples(st.floats(-GOAL_BOUND, GOAL_BOUND), st.floats(-GOAL_BOUND, GOAL_BOUND)),  # inside the region
    st.tuples(FLOATS, FLOATS), st.lists(FLOATS, max_size=3), GARBAGE)
SEEDS = st.one_of(st.none(), st.integers(0, 2 ** 64 - 1), st.integers(-5, -1), st.integers(2 ** 64, 2 ** 66),
                  GARBAGE)


@st.composite
def options(draw, env_id: str):
    kind = draw(st.sampled_from(["none", "goal", "context", "record", "mixed", "garbage"]))
    if kind == "none":
        return None
    if kind == "goal":
        return {"goal": draw(GOALS)}
    if kind == "context":
        env = _env(env_id)
        _, info = env.reset(seed=draw(st.integers(0, 1000)))
        ctx = dict(info["context"])
        tweak = draw(st.sampled_from(["same", "goal", "entry", "extra", "drop"]))
        if tweak == "goal":
            ctx["goal"] = draw(GOALS)
        elif tweak == "entry":
            ctx[draw(st.sampled_from(sorted(ctx)))] = draw(GARBAGE)
        elif tweak == "extra":
            ctx[draw(st.text(max_size=6))] = draw(GARBAGE)
        elif tweak == "drop":
            ctx.pop(draw(st.sampled_from(sorted(ctx))))
        return {"context": ctx}
    if kind == "record":
        return {"record_trajectory": draw(st.one_of(st.booleans(), GARBAGE))}
    if kind == "mixed":
        return draw(st.dictionaries(st.sampled_from(["goal", "context", "record_trajectory", "physics", "seed"]),
                                    GARBAGE, max_size=3))
    return draw(GARBAGE)


@st.composite
def actions(draw, env_id: str):
    env = _env(env_id)
    low = env.action_space.low.astype(np.float64)
    high = env.action_space.high.astype(np.float64)
    n = low.size
    kind = draw(st.sampled_from(["inside", "inside", "bounds", "special", "shape", "dtype", "garbage"]))
    if kind == "inside":
        return np.array([draw(st.floats(lo, hi)) for lo, hi in zip(low, high)])
    if kind == "bounds":        # exactly on the float32 bounds of the Box, or the float64 ones of the task
        exact = np.array([[d.low, d.high] for d in env.unwrapped.action_dims])
        pick = draw(st.lists(st.integers(0, 1), min_size=n, max_size=n))
        src = draw(st.sampled_from(["box", "dims"]))
        return np.array([(low, high)[p][i] if src == "box" else exact[i][p] for i, p in enumerate(pick)])
    if kind == "special":
        return np.array([draw(st.one_of(FLOATS, st.floats(lo, hi))) for lo, hi in zip(low, high)])
    if kind == "shape":
        shape = draw(st.sampled_from([(), (n + 1,), (n - 1,), (1, n), (n, 1), (2, n), (0,)]))
        return np.full(shape, draw(st.floats(0.5, 1.0)))
    if kind == "dtype":
        mid = (low + high) / 2
        dtype = draw(st.sampled_from([np.float32, np.float16, np.int64, np.complex128, np.bool_, str, object]))
        return mid.astype(dtype)
    return draw(GARBAGE)


# ============================================================================================== the property
def _in_space(space, obs) -> bool:
    if isinstance(obs, dict):
        return all(_in_space(space[k], v) for k, v in obs.items())
    return space.contains(obs) and bool(np.all(np.isfinite(obs)))


def _case(data) -> None:
    env_id = data.draw(st.sampled_from(IDS), label="env_id")
    env = _env(env_id)
    seed = data.draw(SEEDS, label="seed")
    opts = data.draw(options(env_id), label="options")
    try:
        obs, info = env.reset(seed=seed, options=opts)
    except (ValueError, TypeError) as exc:
        assert str(exc), "an error without a message"
        env.reset(seed=0)       # a failed reset leaves an env that a good reset restores
        obs, info = None, None
    if obs is not None:
        assert _in_space(env.observation_space, obs), (env_id, seed, opts, obs)
    action = data.draw(actions(env_id), label="action")
    try:
        obs, reward, terminated, truncated, info = env.step(action)
    except (ValueError, TypeError) as exc:
        assert str(exc), "an error without a message"
        return
    assert math.isfinite(reward) and reward <= 1.0, (env_id, seed, opts, action, reward)
    assert terminated and not truncated
    assert _in_space(env.observation_space, obs), (env_id, seed, opts, action, obs)


COMMON = dict(deadline=None, database=None, derandomize=True, print_blob=True,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much])


@settings(max_examples=100, **COMMON)
@given(st.data())
def test_fuzz_reset_and_step(data):
    _case(data)


@pytest.mark.slow
@settings(max_examples=2000, **COMMON)
@given(st.data())
def test_fuzz_reset_and_step_long(data):
    _case(data)
