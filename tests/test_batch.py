"""Batched simulation and vector envs: bit-identical to single-env episodes, in every mode."""
from __future__ import annotations

import numpy as np
import pytest

import gymnasium as gym

import phyplan_envs
from phyplan_envs import BatchResult, simulate_batch

TASKS = list(phyplan_envs.ALL_TASKS)      # the nominal tasks and the hidden-physics (varied) ones


def _actions(env, n: int, seed: int) -> np.ndarray:
    u = env.unwrapped
    lo, hi = u.action_low, u.action_high
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


def test_batch_env_modes_robot():
    """Env modes go through the env's own reset/step: the robot mode (robot="panda") too."""
    env_id = phyplan_envs.env_id("launch")
    env = gym.make(env_id, robot="panda")
    ctx = env.reset(seed=3)[1]["context"]
    actions = _actions(env, 3, seed=1)
    _check(simulate_batch(env_id, ctx, actions, workers=2, robot="panda"), _single(env_id, [ctx] * 3, actions,
                                                                                    robot="panda"))


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


# ============================================================================================== vector envs
def _single_env_rewards(env_id: str, seed: int, rounds: list[np.ndarray], **kwargs) -> np.ndarray:
    """Rewards of sub-env i as a single env: reset(seed=seed + i), then one attempt per round, reset() between."""
    out = np.zeros((len(rounds), len(rounds[0])))
    for i in range(len(rounds[0])):
        env = gym.make(env_id, **kwargs)
        env.reset(seed=seed + i)
        for k, actions in enumerate(rounds):
            if k:
                env.reset()
            out[k, i] = env.step(actions[i])[1]
        env.close()
    return out


@pytest.mark.parametrize("mode", ["vector_entry_point", "sync", "async"])
def test_make_vec_modes_match_single_envs(mode):
    env_id = phyplan_envs.env_id("launch")
    rounds = [np.array([[0.2, 0.9], [0.8, 1.2], [1.4, 1.5]]), np.array([[0.5, 1.0], [0.1, 0.8], [1.0, 1.3]])]
    ref = _single_env_rewards(env_id, 7, rounds)
    vec = gym.make_vec(env_id, num_envs=3, vectorization_mode=mode)
    if mode == "vector_entry_point":
        from phyplan_envs.vector import PhyPlanVectorEnv
        assert isinstance(vec.unwrapped, PhyPlanVectorEnv)
    try:
        obs, _ = vec.reset(seed=7)
        assert obs.shape == (3, 6)
        _, r, term, trunc, info = vec.step(rounds[0])
        assert np.array_equal(r, ref[0]) and term.all() and not trunc.any()
        assert info["end_reason"][0] in ("landed", "rest", "timeout")
        obs, r, term, _, info = vec.step(rounds[0])                 # NEXT_STEP: the reset step
        assert not r.any() and not term.any() and "context" in info
        _, r, term, _, _ = vec.step(rounds[1])
        assert np.array_equal(r, ref[1]) and term.all()
    finally:
        vec.close()


def test_vector_env_same_step_and_disabled_autoreset():
    from gymnasium.vector import AutoresetMode

    from phyplan_envs.vector import PhyPlanVectorEnv

    env_id = phyplan_envs.env_id("launch")
    rounds = [np.array([[0.2, 0.9], [0.8, 1.2]]), np.array([[0.5, 1.0], [0.1, 0.8]])]
    ref = _single_env_rewards(env_id, 3, rounds)
    vec = PhyPlanVectorEnv(env_id, num_envs=2, workers=2, autoreset_mode="same_step")
    vec.reset(seed=3)
    for k in range(2):                              # every step is an attempt; the final outcome is in the info
        obs, r, term, _, info = vec.step(rounds[k])
        assert np.array_equal(r, ref[k]) and term.all()
        assert info["final_info"]["initial_distance"][0] > 0 and obs[0][0] == np.float32(info["context"]["goal"][0][0])
    vec = PhyPlanVectorEnv(env_id, num_envs=2, workers=1, autoreset_mode=AutoresetMode.DISABLED)
    vec.reset(seed=3)
    assert np.array_equal(vec.step(rounds[0])[1], ref[0])
    with pytest.raises(RuntimeError, match="reset"):
        vec.step(rounds[1])
    vec.reset(options={"reset_mask": np.array([True, True])})
    assert np.array_equal(vec.step(rounds[1])[1], ref[1])
    with pytest.raises(ValueError, match="render_mode"):
        PhyPlanVectorEnv(env_id, num_envs=2, render_mode="rgb_array")
    with pytest.raises(ValueError, match="autoreset_mode"):
        PhyPlanVectorEnv(env_id, num_envs=2, autoreset_mode="sometimes")


_ASYNC_AFTER_RENDER = """
import gymnasium as gym, numpy as np, warnings
import phyplan_envs
if __name__ == "__main__":
    import multiprocessing
    multiprocessing.RLock()          # fixes the default start method ('fork') implicitly, as tqdm's lock does
    env = gym.make("PhyPlan/Launch-v0", render_mode="rgb_array", obs_mode="image", image_size=32)
    env.reset(seed=0)
    assert env.render().shape == (480, 480, 3)
    vec = gym.make_vec("PhyPlan/Launch-v0", num_envs=2, vectorization_mode="async", obs_mode="image", image_size=32)
    obs, _ = vec.reset(seed=0)
    _, r, _, _, _ = vec.step(np.array([[0.5, 1.0], [0.6, 1.2]]))
    vec.close()
    single = []
    for i, a in enumerate([[0.5, 1.0], [0.6, 1.2]]):
        env.reset(seed=i)
        single.append(env.step(np.array(a))[1])
    assert obs.shape == (2, 32, 32, 3) and np.array_equal(r, single), (r, single)
    print("ok")
"""


def test_async_vector_env_after_render_does_not_hang(tmp_path):
    """Fork after EGL used to hang at the children's first render; now the start method switches to forkserver."""
    import os
    import signal
    import subprocess
    import sys

    script = tmp_path / "async_after_render.py"
    script.write_text(_ASYNC_AFTER_RENDER)
    # its own process group, so that a hang kills the vector env's workers too (they would outlive the test)
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        out, err = proc.communicate(timeout=150)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail("async vector env after a render hung for 150 s")
    proc = subprocess.CompletedProcess(proc.args, proc.returncode, out, err)
    assert proc.returncode == 0 and proc.stdout.strip().endswith("ok"), proc.stderr[-3000:]
    assert "forkserver" in proc.stderr          # the switch is announced


def test_forked_child_of_a_rendering_process_raises_instead_of_hanging(monkeypatch):
    import os

    from phyplan_envs import gl_fork

    monkeypatch.setattr(gl_fork, "_OPENED", True)      # as after a render in this process (without one)
    pid = os.fork()
    if pid == 0:                                       # the child: a render must raise, not hang
        code = 3
        try:
            gl_fork.before_renderer()
        except RuntimeError as exc:
            code = 0 if "forked" in str(exc) else 4
        os._exit(code)
    assert os.waitpid(pid, 0)[1] == 0
    gl_fork.before_renderer()                          # the parent itself still renders


# ============================================================================================ pickle / copy
@pytest.mark.parametrize("task", TASKS)
def test_pickle_and_deepcopy_round_trips(task):
    import copy
    import pickle

    env_id = phyplan_envs.env_id(task)
    env = gym.make(env_id, clip_actions=True)
    env.reset(seed=21)
    copies = [pickle.loads(pickle.dumps(env)), copy.deepcopy(env)]
    action = _actions(env, 3, seed=2)[2]
    outs = [e.step(action) for e in [env] + copies]
    for o in outs[1:]:
        assert o[1] == outs[0][1] and np.array_equal(o[0], outs[0][0])
        _same_info(o[4], outs[0][4])
    # the generator is copied too: the next sampled contexts agree
    goals = [e.reset()[1]["goal"] for e in [env] + copies]
    assert all(np.array_equal(g, goals[0]) for g in goals)
    assert copies[0].unwrapped.spec.id == env_id and copies[0].unwrapped.clip_actions
    fresh = copy.deepcopy(gym.make(env_id))                   # never reset: still needs a reset
    with pytest.raises(Exception):
        fresh.step(action)


def test_check_env_passes_on_a_copy():
    import copy

    from gymnasium.utils.env_checker import check_env

    env = gym.make(phyplan_envs.env_id("bounce"))
    env.reset(seed=1)
    check_env(copy.deepcopy(env).unwrapped, skip_render_check=True)


# ============================================================================================== the Simulator
def test_simulator_batch_equals_single_calls():
    from phyplan_agents import Simulator

    env_id = phyplan_envs.env_id("slide")
    env = gym.make(env_id)
    ctx = env.reset(seed=9)[1]["context"]
    actions = _actions(env, 4, seed=4)
    one = Simulator(gym.make(env_id), ctx)
    ref = [one.evaluate(a) for a in actions]
    for workers in (1, 2):
        sim = Simulator(gym.make(env_id), ctx, workers=workers)
        rewards, infos = sim.evaluate_batch(actions)
        assert sim.calls == 4 and np.array_equal(rewards, [r for r, _ in ref])
        for info, (_, ref_info) in zip(infos, ref):
            _same_info(info, ref_info)
        assert np.array_equal(sim.evaluate_many(actions[:2]), rewards[:2]) and sim.calls == 6
    with pytest.raises(ValueError, match="workers"):
        Simulator(env, ctx, workers=0)
