"""Batched simulation and vector envs: bit-identical to single-env episodes, in every mode."""
from __future__ import annotations

import numpy as np
import pytest

import gymnasium as gym

import phyplan_envs
from phyplan_envs.batch import BatchResult, simulate_batch

TASKS = list(phyplan_envs.TASKS)


def _actions(env, n: int, seed: int) -> np.ndarray:
    u = env.unwrapped
    lo, hi = u._low64, u._high64
    a = lo + (hi - lo) * np.random.default_rng(seed).random((n, len(lo)))
    a[0] = lo            # the bounds themselves are valid actions
    a[1] = hi
    return a


def _same_info(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for k in a:
        if isinstance(a[k], dict):
            _same_info(a[k], b[k])
        elif isinstance(a[k], np.ndarray):
            assert a[k].dtype == b[k].dtype and np.array_equal(a[k], b[k]), k
        else:
            assert a[k] == b[k], k


def _single(env_id: str, contexts, actions, **kwargs):
    """The reference: one fresh env per episode."""
    out = []
    for c, a in zip(contexts, actions):
        env = gym.make(env_id, **kwargs)
        env.reset(options={"context": c})
        obs, r, term, trunc, info = env.step(a)
        assert term and not trunc
        out.append((r, info, obs))
        env.close()
    return out


def _check(res: BatchResult, ref) -> None:
    assert res.reward.shape == (len(ref),) and res.final_pos.shape == (len(ref), 3)
    for k, (r, info, obs) in enumerate(ref):
        assert res.reward[k] == r
        assert np.array_equal(res.final_pos[k], info["final_pos"])
        _same_info(res.info[k], info)
        assert np.array_equal(res.obs[k], obs)


@pytest.mark.parametrize("task", TASKS)
def test_batch_bit_identical_to_single_envs(task):
    env_id = phyplan_envs.env_id(task)
    env = gym.make(env_id)
    contexts = [env.reset(seed=s)[1]["context"] for s in (11, 12, 13)]
    actions = _actions(env, 6, seed=5)
    per_action = [contexts[k % 3] for k in range(len(actions))]
    ref = _single(env_id, per_action, actions)
    _check(simulate_batch(env_id, per_action, actions, workers=1), ref)
    _check(simulate_batch(env_id, per_action, actions, workers=2), ref)
    # one context for every action
    ref0 = _single(env_id, [contexts[0]] * 3, actions[:3])
    _check(simulate_batch(env_id, contexts[0], actions[:3], workers=2), ref0)


def test_batch_independent_of_split_and_history():
    """Chunks run on reused envs in any order: the same numbers whatever the worker count."""
    env_id = phyplan_envs.env_id("bridge")
    env = gym.make(env_id)
    ctx = env.reset(seed=2)[1]["context"]
    actions = _actions(env, 9, seed=8)
    a = simulate_batch(env_id, ctx, actions, workers=1)
    b = simulate_batch(env_id, ctx, actions[::-1], workers=2)
    assert np.array_equal(a.reward, b.reward[::-1]) and np.array_equal(a.final_pos, b.final_pos[::-1])
    assert len(simulate_batch(env_id, ctx, np.zeros((0, 3))).reward) == 0


def test_batch_env_kwargs_and_errors():
    env_id = phyplan_envs.env_id("launch")
    env = gym.make(env_id)
    ctx = env.reset(seed=0)[1]["context"]
    res = simulate_batch(env_id, ctx, [[0.3, 3.0]], workers=1, clip_actions=True)
    assert res.info[0]["clipped"] and res.info[0]["action"][1] == pytest.approx(np.pi / 2)
    with pytest.raises(ValueError, match="out of bounds"):
        simulate_batch(env_id, ctx, [[0.3, 1.0], [0.3, 3.0]], workers=2)      # raised in a worker, re-raised here
    assert simulate_batch(env_id, ctx, [[0.3, 1.0], [0.4, 1.0]], workers=2).reward.shape == (2,)  # pool usable
    with pytest.raises(ValueError, match="actions"):
        simulate_batch(env_id, ctx, [0.3, 1.0])
    with pytest.raises(ValueError, match="contexts"):
        simulate_batch(env_id, [ctx, ctx], [[0.3, 1.0]])
    with pytest.raises(ValueError, match="contexts"):
        simulate_batch(env_id, "goal", [[0.3, 1.0]])
    with pytest.raises(ValueError, match="workers"):
        simulate_batch(env_id, ctx, [[0.3, 1.0]], workers=0)
    with pytest.raises(ValueError, match="env_id"):
        simulate_batch("PhyPlan/Nothing-v0", ctx, [[0.3, 1.0]])
