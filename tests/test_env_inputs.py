"""Envs: every input is checked where it enters (goals, contexts, options, seeds, actions, constructor
arguments) with an error naming it; a closed env refuses to be used; make/close cycles do not accumulate memory."""
from __future__ import annotations

import copy
import json
import math
import subprocess
import sys

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import phyplan_envs
from phyplan_envs import assets, compiled
from phyplan_envs.spaces import GOAL_BOUND, MIN_GOAL_DISTANCE, STATE_BOUND

TASKS = list(phyplan_envs.ALL_TASKS)
IDS = [phyplan_envs.env_id(t) for t in TASKS]


@pytest.fixture(scope="module")
def envs():
    made = {i: gym.make(i, with_panda=False).unwrapped for i in IDS}
    yield made
    for e in made.values():
        e.close()


def _mid(env):
    return (env.action_space.low.astype(np.float64) + env.action_space.high) / 2


# ============================================================================================================= goals
@pytest.mark.parametrize("env_id", IDS)
def test_goal_at_the_object_start_is_refused(envs, env_id):
    """Before: a goal at the start made d0 = 0 and step() divided by zero (reward NaN/inf)."""
    env = envs[env_id]
    _, info = env.reset(seed=0)
    start = info["object_pos"][:2]
    for goal in (start, start + 1e-160, start + [MIN_GOAL_DISTANCE / 2, 0.0]):
        with pytest.raises(ValueError, match=r"options\['goal'\] = .* m from the .*'s start .* at least 0.1 m"):
            env.reset(options={"goal": goal})
        with pytest.raises(RuntimeError, match="reset"):        # the failed reset left no episode to step
            env.step(_mid(env))
    ctx = dict(info["context"], goal=start.copy())
    with pytest.raises(ValueError, match=r"options\['context'\]\['goal'\]"):
        env.reset(options={"context": ctx})
    _, info2 = env.reset(options={"goal": start + [MIN_GOAL_DISTANCE * 1.01, 0.0]})   # just far enough
    _, r, *_ = env.step(_mid(env))
    assert math.isfinite(r) and info2["initial_distance"] >= MIN_GOAL_DISTANCE


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("goal", [(GOAL_BOUND + 0.01, 0.5), (0.5, -STATE_BOUND - 1), (1e39, 0.0), (0.0, 1e155),
                                  (-1e308, 1e308)])
def test_goal_outside_the_arena_is_refused(envs, env_id, goal):
    """Before: 10.5 m put the observation outside its space, 1e39 made it inf, 1e155 made the reward NaN."""
    env = envs[env_id]
    with pytest.raises(ValueError, match=r"options\['goal'\] = .* outside the .* goal region: x in \[-6.0, 6.0\]"):
        env.reset(seed=0, options={"goal": goal})


@pytest.mark.parametrize("goal, error, match", [
    ((np.inf, 0.0), ValueError, "two finite numbers"), ((0.5, np.nan), ValueError, "two finite numbers"),
    ((0.5, 0.5, 0.0), ValueError, "two finite numbers"), (0.5, ValueError, "two finite numbers"),
    ({"x": 1}, TypeError, r"options\['goal'\] must be two finite numbers .*dict"),
    ("0.5 0.5", TypeError, r"options\['goal'\].*str"), ((0.5 + 1j, 0.5), TypeError, "real numbers"),
    ((True, False), TypeError, "real numbers"), ([[0.5], [0.5, 1.0]], TypeError, "real numbers"),
])
def test_goal_values_of_the_wrong_kind(envs, goal, error, match):
    env = envs[IDS[0]]
    with pytest.raises(error, match=match):
        env.reset(seed=0, options={"goal": goal})


def test_edge_of_the_goal_region_is_accepted_and_stays_in_the_space(envs):
    env = envs[phyplan_envs.env_id("launch")]
    for goal in ((GOAL_BOUND, GOAL_BOUND), (-GOAL_BOUND, -GOAL_BOUND)):
        obs, _ = env.reset(seed=0, options={"goal": goal})
        assert env.observation_space.contains(obs)
        obs, r, *_ = env.step(_mid(env))
        assert env.observation_space.contains(obs) and math.isfinite(r)


def test_the_goal_region_is_the_arena_floor():
    """GOAL_BOUND is the half-size of the ground plane that assets.arena builds, and inside the state space."""
    root = assets.arena()
    ground = root.find("geom", "ground")
    assert tuple(ground.size[:2]) == (GOAL_BOUND, GOAL_BOUND) and GOAL_BOUND < STATE_BOUND


# ========================================================================================================== contexts
@pytest.mark.parametrize("env_id", IDS)
def test_context_entries_are_checked_and_round_trip(envs, env_id):
    env = envs[env_id]
    _, info = env.reset(seed=3)
    ctx = info["context"]
    assert set(ctx) <= set(env.context_keys)
    _, r1, *_ = env.step(_mid(env))
    env.reset(options={"context": ctx})
    _, r2, *_ = env.step(_mid(env))
    assert r1 == r2
    with pytest.raises(ValueError, match=r"unknown entries \['angle'\]; a context of this task holds: goal"):
        env.reset(options={"context": {**ctx, "angle": 1.0}})
    with pytest.raises(TypeError, match=r"options\['context'\] must be a dict"):
        env.reset(options={"context": [0.5, 0.5]})
    with pytest.raises(ValueError, match="'goal' entry"):
        env.reset(options={"context": {k: v for k, v in ctx.items() if k != "goal"}})


def test_varied_context_entries_go_through_the_task_hook(envs):
    env = envs[phyplan_envs.env_id("launch-varied")]
    _, info = env.reset(seed=3)
    ctx = info["context"]
    assert set(ctx) == {"goal", "physics_token"}
    token = ctx["physics_token"]
    flipped = token[:-1] + ("0" if token[-1] != "0" else "1")
    for bad, error, match in ((dict(physics_token=7), TypeError, r"\['physics_token'\] must be the sealed token"),
                              (dict(physics_token=[token]), TypeError, "physics_token"),
                              (dict(physics_token="pt1-zz"), ValueError, "physics_token.* must be a sealed token"),
                              (dict(physics_token=token[4:]), ValueError, "physics_token.* must be a sealed token"),
                              (dict(physics_token=flipped), ValueError, "physics_token.* was not sealed for"),
                              (dict(physics_key=3, physics_space="train"), ValueError, "physics was sealed")):
        with pytest.raises(error, match=match):
            env.reset(options={"context": {**ctx, **bad}})
    with pytest.raises(TypeError, match="reset options must be a dict"):
        env.reset(options=5)


# ====================================================================================================== options, seed
@pytest.mark.parametrize("options, error, match", [
    (5, TypeError, "reset options must be a dict .*int 5"), ("abc", TypeError, "reset options must be a dict .*str"),
    ([("goal", (1, 1))], TypeError, "reset options must be a dict"),
    ({"gaol": (1, 1)}, ValueError, r"unknown reset options \['gaol'\]"),
    ({"record_trajectory": "no"}, TypeError, r"options\['record_trajectory'\] must be True or False, got str"),
    ({"record_trajectory": 1}, TypeError, "record_trajectory"),
])
def test_bad_reset_options_name_the_input(envs, options, error, match):
    env = envs[IDS[0]]
    with pytest.raises(error, match=match):
        env.reset(seed=0, options=options)


@pytest.mark.parametrize("seed, error", [("1", TypeError), (1.5, TypeError), (True, TypeError), ([1], TypeError),
                                         (-1, ValueError)])
def test_bad_seeds_name_the_seed(envs, seed, error):
    with pytest.raises(error, match="seed must be a non-negative integer or None"):
        envs[IDS[0]].reset(seed=seed)
    envs[IDS[0]].reset(seed=2 ** 70)           # any non-negative integer is a seed


def test_numpy_integer_seeds_equal_python_ones(envs):
    env = envs[IDS[0]]
    _, a = env.reset(seed=np.int64(5))
    _, b = env.reset(seed=5)
    np.testing.assert_array_equal(a["goal"], b["goal"])


def test_record_trajectory_option_is_a_real_flag(envs):
    env = envs[IDS[0]]
    env.reset(seed=0, options={"record_trajectory": False})
    assert "trajectory" not in env.step(_mid(env))[4]
    env.reset(seed=0, options={"record_trajectory": np.bool_(True)})
    assert env.step(_mid(env))[4]["trajectory"].shape[1] == 4


# ============================================================================================================ actions
@pytest.mark.parametrize("make_action", [
    lambda a: a.astype(np.complex128), lambda a: [str(v) for v in a], lambda a: "0.5",
    lambda a: np.ones(a.shape, dtype=bool), lambda a: [None] * len(a), lambda a: {"phi": 0.5},
])
def test_non_real_actions_are_a_type_error(envs, make_action):
    """Before: complex actions lost their imaginary part and strings like "0.5" were parsed, silently."""
    env = envs[IDS[0]]
    env.reset(seed=0)
    with pytest.raises(TypeError, match="action must be numeric"):
        env.step(make_action(_mid(env)))
    env.step(_mid(env))          # the episode was still usable


# ============================================================================================= constructor arguments
@pytest.mark.parametrize("kw, error, match", [
    ({"obs_mode": 1}, TypeError, "obs_mode"), ({"obs_mode": "pixels"}, ValueError, "obs_mode"),
    ({"image_size": 64.0}, TypeError, "image_size"), ({"image_size": "64"}, TypeError, "image_size"),
    ({"image_size": 8}, ValueError, "image_size"), ({"render_mode": "human"}, ValueError, "render_mode"),
    ({"render_mode": True}, TypeError, "render_mode"),
    ({"clip_actions": "yes"}, TypeError, "clip_actions must be True or False"),
    ({"record_trajectory": "no"}, TypeError, "record_trajectory must be True or False"),
    ({"with_panda": 0}, TypeError, "with_panda must be True or False"),
])
def test_constructor_arguments_are_type_checked(kw, error, match):
    with pytest.raises(error, match=match):
        phyplan_envs.task_class("launch")(**kw)


def test_task_specific_constructor_arguments_are_type_checked():
    with pytest.raises(TypeError, match="robot must be None"):
        phyplan_envs.task_class("launch")(robot=1)
    with pytest.raises(TypeError, match="physics_space must be 'auto', 'train' or 'test', got list"):
        phyplan_envs.task_class("launch-varied")(physics_space=["train"])


# ============================================================================================================= close
def test_a_closed_env_refuses_render_reset_and_step():
    """Before: render() after close() silently opened a new renderer."""
    env = gym.make(phyplan_envs.env_id("launch"), with_panda=False, render_mode="rgb_array").unwrapped
    env.reset(seed=0)
    assert env.render().shape == (env.render_size, env.render_size, 3)
    env.close()
    env.close()                                             # closing again is harmless
    for call in (env.render, lambda: env.reset(seed=0), lambda: env.step(_mid(env))):
        with pytest.raises(RuntimeError, match=r"after close\(\): the env is closed"):
            call()
    assert env.model is None and env.physics is None        # the compiled model is released


def test_compiled_scene_copies_equal_a_fresh_compile():
    """The env's model is a copy of the cached compiled scene: the same bytes as compiling its MJCF afresh."""
    env = gym.make(phyplan_envs.env_id("bounce")).unwrapped
    fresh = mujoco.MjModel.from_xml_string(env.mjcf_model.to_xml_string(), env.mjcf_model.get_assets())

    def saved(m):
        buf = np.zeros(mujoco.mj_sizeModel(m), dtype=np.uint8)
        mujoco.mj_saveModel(m, None, buf)
        return buf

    other = gym.make(phyplan_envs.env_id("bounce")).unwrapped
    assert other.model is not env.model and compiled.cached_scenes() >= 1
    env.model.body_pos[1] += 1.0                            # envs never share a model
    assert not np.array_equal(other.model.body_pos[1], env.model.body_pos[1])
    copied = compiled.compile_scene(env.mjcf_model).model.ptr     # what an env gets before it binds the Panda
    assert np.array_equal(saved(copied), saved(fresh))
    env.close()
    other.close()




@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/statm")
def test_make_close_cycles_do_not_accumulate_memory():
    """Before: 50 make/close cycles retained ~670 MiB (each env's ~23 MB Panda model waited for the cyclic garbage
    collector, and every make compiled it again). Now: 20 cycles (with the Panda) after a warm-up grow the RSS by
    a few MiB (measured +1 to +16 MiB; before: +100 MiB and more, peaks of +300 MiB)."""
    done = subprocess.run([sys.executable, "-m", "benchmarks.memory_cycles", "--warmup", "8", "--cycles", "20", "--json"],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout.strip().splitlines()[-1])
    assert out["growth"] < 40 and out["peak"] < 60, out
