"""One parametrised suite over every registered task: API, determinism, errors, reward, images."""
from __future__ import annotations

import importlib
import json
import math
import re
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import phyplan_envs
from phyplan_envs import assets

TASKS = list(phyplan_envs.ALL_TASKS)   # the nominal and the varied (hidden-physics) tasks
IDS = [phyplan_envs.env_id(t) for t in TASKS] + list(phyplan_envs.LEGACY_IDS)   # every registered id
MODES = ["state", "image", "state_image", "rgbd"]


def _mid_action(env):
    return ((env.action_space.low.astype(np.float64) + env.action_space.high) / 2)


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("mode", MODES)
def test_check_env(env_id, mode):
    env = gym.make(env_id, obs_mode=mode, image_size=32)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_registered_and_spec(env_id):
    env = gym.make(env_id)
    base = env.unwrapped
    assert env.spec.id == env_id
    assert len(base.action_names) == env.action_space.shape[0]
    assert env.observation_space.shape == (len(base.state_names),)
    # The docstring is the user's spec: its action table gives every dimension's name and both bounds.
    table = _docstring_action_table(type(base).__doc__)
    assert list(table) == list(base.action_names), f"{env_id}: docstring actions {list(table)}"
    for dim, low, high in zip(base.action_dims, env.action_space.low, env.action_space.high):
        doc_low, doc_high = table[dim.name]
        assert doc_low == pytest.approx(low, abs=1e-6), f"{env_id} {dim.name}: docstring low {doc_low} != {low}"
        assert doc_high == pytest.approx(high, abs=1e-6), f"{env_id} {dim.name}: docstring high {doc_high} != {high}"
    # and the documented state entries
    doc = type(base).__doc__
    for name in base.state_names:
        assert f"``{name}``" in doc or re.search(rf"\b{re.escape(name)}\b", doc), f"{env_id} docstring lacks {name}"
    env.close()


_ROW = re.compile(r"^\s*``(\w+)``\s+\[([^,\]]+),\s*([^\]]+)\]")


def _bound(text: str) -> float:
    """A bound as the docstring writes it: a number or an expression in pi (``pi/2``, ``-pi``, ``3*pi/4``)."""
    expr = text.strip().replace("π", "pi")
    if not re.fullmatch(r"[-+*/().\d\s]*(pi[-+*/().\d\s]*)*", expr):
        raise AssertionError(f"unreadable bound {text!r} in a docstring action table")
    return float(eval(expr, {"__builtins__": {}}, {"pi": math.pi}))


def _docstring_action_table(doc: str) -> dict[str, tuple[float, float]]:
    rows = {}
    for line in (doc or "").splitlines():
        m = _ROW.match(line)
        if m:
            rows[m.group(1)] = (_bound(m.group(2)), _bound(m.group(3)))
    return rows


def _registered_class(env_id: str) -> type:
    module, _, attr = gym.registry[env_id].entry_point.partition(":")
    return getattr(importlib.import_module(module), attr)


@pytest.mark.parametrize("env_id", IDS)
def test_one_house_of_parts(env_id):
    """A registered class resolves its methods through at most four of our classes (the task, a family's shared
    declarations, the base; a varied task adds a hidden-physics component, not a mixin), its spec docstring is its
    own (not another class's appended at import), and no superseded id's class is a base of another id's."""
    cls = _registered_class(env_id)
    ours = [c for c in cls.__mro__ if c.__module__.split(".")[0] == "phyplan_envs"]
    assert len(ours) <= 4, (env_id, [c.__name__ for c in ours])
    assert "__doc__" in cls.__dict__ and cls.__doc__, env_id
    others = [_registered_class(i) for i in IDS if i != env_id]
    assert not any((o.__doc__ or "").strip() in cls.__doc__ for o in others), env_id
    legacy = [_registered_class(i) for i in phyplan_envs.LEGACY_IDS]
    assert not any(old in cls.__mro__[1:] for old in legacy) or env_id in phyplan_envs.LEGACY_IDS, \
        (env_id, [c.__name__ for c in cls.__mro__])


def test_docstring_table_parser_catches_a_wrong_bound():
    """The check above can fail: a table row whose bound differs from the space is read as different."""
    table = _docstring_action_table("    ``theta``   [pi/4, pi/3]    rad   release angle\n")
    assert table == {"theta": (pytest.approx(math.pi / 4), pytest.approx(math.pi / 3))}
    assert table["theta"][1] != pytest.approx(math.pi / 2)


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("mode", MODES)
def test_observations_finite_inside_space_and_not_shared(env_id, mode):
    """Over random actions every observation is finite and inside its space, and no two share memory."""
    env = gym.make(env_id, obs_mode=mode, image_size=32)
    space = env.observation_space
    rng = np.random.default_rng(5)
    seen = []

    def arrays(obs):
        return list(obs.values()) if isinstance(obs, dict) else [obs]

    for seed in range(3):
        obs, _ = env.reset(seed=seed)
        a = env.action_space.low + (env.action_space.high - env.action_space.low) * rng.random(env.action_space.shape)
        obs2, reward, *_ = env.step(a)
        for o in (obs, obs2):
            assert space.contains(o), f"{env_id} {mode}: observation outside its space"
            for arr in arrays(o):
                assert np.all(np.isfinite(arr))
            seen.append(o)
        assert np.isfinite(reward)
    flat = [arr for o in seen for arr in arrays(o)]
    for i, x in enumerate(flat):
        for y in flat[i + 1:]:
            assert not np.shares_memory(x, y), f"{env_id} {mode}: two observations share memory"
    env.close()


def _run(env_id, seed, action, mode="state"):
    env = gym.make(env_id, obs_mode=mode, image_size=32)
    obs0, _ = env.reset(seed=seed)
    obs1, reward, term, trunc, info = env.step(np.asarray(action))
    env.close()
    return obs0, obs1, reward, info


@pytest.mark.parametrize("env_id", IDS)
def test_same_seed_same_outcome_in_two_instances(env_id):
    env = gym.make(env_id)
    a = _mid_action(env)
    env.close()
    o0a, o1a, ra, ia = _run(env_id, 7, a, "state_image")
    o0b, o1b, rb, ib = _run(env_id, 7, a, "state_image")
    np.testing.assert_array_equal(o0a["state"], o0b["state"])
    np.testing.assert_array_equal(o0a["image"], o0b["image"])
    np.testing.assert_array_equal(o1a["state"], o1b["state"])
    assert ra == rb
    np.testing.assert_array_equal(ia["final_pos"], ib["final_pos"])
    # a different seed gives a different context
    o0c, *_ = _run(env_id, 8, a)
    assert not np.array_equal(o0a["state"], o0c)


@pytest.mark.parametrize("env_id", IDS)
def test_same_seed_same_outcome_in_fresh_process(env_id):
    env = gym.make(env_id)
    a = _mid_action(env)
    env.close()
    _, obs, reward, info = _run(env_id, 3, a)
    code = (
        "import json, numpy as np, gymnasium as gym, phyplan_envs\n"
        f"env = gym.make({env_id!r}, image_size=32)\n"
        "env.reset(seed=3)\n"
        f"o, r, *_ , info = env.step(np.array({a.tolist()!r}))\n"
        "print(json.dumps({'obs': o.tolist(), 'reward': r, 'final': info['final_pos'].tolist()}))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert got["reward"] == reward
    assert got["final"] == info["final_pos"].tolist()
    assert got["obs"] == obs.tolist()


@pytest.mark.parametrize("env_id", IDS)
def test_reward_matches_info_distances(env_id):
    env = gym.make(env_id)
    rng = np.random.default_rng(0)
    for seed in range(3):
        _, info0 = env.reset(seed=seed)
        a = env.action_space.low + (env.action_space.high - env.action_space.low) * rng.random(env.action_space.shape)
        _, r, term, trunc, info = env.step(a)
        assert term and not trunc
        d = np.linalg.norm(info["final_pos"][:2] - info["goal"])
        assert info["distance"] == pytest.approx(d)
        assert info["initial_distance"] == pytest.approx(info0["initial_distance"])
        assert r == pytest.approx(1 - d / info["initial_distance"])
        assert info["is_success"] == bool(np.all(np.abs(info["final_pos"][:2] - info["goal"]) <= assets.GOAL_HALF))
        assert info["n_steps"] > 0 and 0 < info["sim_time"] <= assets.MAX_SIM_TIME + 1e-9
        assert np.isfinite(r)
    env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_bad_actions(env_id):
    env = gym.make(env_id)
    env.reset(seed=0)
    n = env.action_space.shape[0]
    a = _mid_action(env)
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(n + 1))
    with pytest.raises(ValueError, match="non-finite"):
        env.step(np.full(n, np.nan))
    bad = a.copy()
    bad[0] = np.inf
    with pytest.raises(ValueError, match="non-finite"):
        env.step(bad)
    with pytest.raises(TypeError, match="numeric"):
        env.step(["a"] * n)
    high = env.action_space.high.astype(np.float64) + 0.5
    with pytest.raises(ValueError, match="out of bounds"):
        env.step(high)
    # after the errors the episode is still usable
    env.step(a)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(a)
    env.close()
    # clipping is an explicit option
    env = gym.make(env_id, clip_actions=True)
    env.reset(seed=0)
    _, _, _, _, info = env.step(high)
    assert info["clipped"]
    np.testing.assert_allclose(info["action"], env.action_space.high, rtol=1e-6)
    env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_context_round_trip(env_id):
    env = gym.make(env_id)
    a = _mid_action(env)
    _, info = env.reset(seed=11)
    _, r1, *_ = env.step(a)
    env.reset(seed=999)
    obs, info2 = env.reset(options={"context": info["context"]})
    np.testing.assert_array_equal(info2["goal"], info["goal"])
    _, r2, *_ = env.step(a)
    assert r1 == r2
    with pytest.raises(ValueError, match="goal"):
        env.reset(options={"context": {"nogoal": 1}})
    with pytest.raises(ValueError, match="unknown reset options"):
        env.reset(options={"gaol": (1, 1)})
    env.close()


def test_bad_constructor_arguments():
    with pytest.raises(ValueError, match="obs_mode"):
        gym.make("PhyPlan/Launch-v0", obs_mode="pixels")
    with pytest.raises(ValueError, match="render_mode"):
        phyplan_envs.task_class("launch")(render_mode="human")
    with pytest.raises(ValueError, match="image_size"):
        gym.make("PhyPlan/Launch-v0", image_size=3)
    with pytest.raises(ValueError, match="unknown task"):
        phyplan_envs.env_id("juggle")


@pytest.mark.parametrize("env_id", IDS)
def test_trajectory_on_request(env_id):
    env = gym.make(env_id)
    env.reset(seed=0)
    _, _, _, _, info = env.step(_mid_action(env))
    assert "trajectory" not in info
    env.reset(seed=0, options={"record_trajectory": True})
    _, _, _, _, info2 = env.step(_mid_action(env))
    traj = info2["trajectory"]
    assert traj.shape[1] == 4 and np.all(np.diff(traj[:, 0]) > 0)
    assert traj[-1, 0] == pytest.approx(info2["sim_time"])
    env.close()


# ------------------------------------------------------------------------------------------- images
def _goal_pixels(img):
    r, g, b = img[..., 0].astype(int), img[..., 1].astype(int), img[..., 2].astype(int)
    return (r > 150) & (g < 80) & (b < 80)


@pytest.mark.parametrize("env_id", IDS)
def test_image_shows_goal_and_follows_it(env_id):
    env = gym.make(env_id, obs_mode="image")
    img1, info1 = env.reset(seed=0)
    assert img1.shape == (128, 128, 3) and img1.dtype == np.uint8
    mask1 = _goal_pixels(img1)
    assert mask1.sum() >= 4, "the goal box is not visible in the image observation"
    goal2 = info1["goal"] + np.array([0.12, -0.12]) if info1["goal"][1] > 0.3 else info1["goal"] + np.array([-0.12, 0.12])
    img2, _ = env.reset(seed=0, options={"goal": goal2})
    mask2 = _goal_pixels(img2)
    assert mask2.sum() >= 4
    c1 = np.argwhere(mask1).mean(axis=0)
    c2 = np.argwhere(mask2).mean(axis=0)
    assert np.linalg.norm(c1 - c2) > 2, "the goal moved but its image did not"
    env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_render_rgb_array(env_id):
    env = gym.make(env_id, render_mode="rgb_array")
    env.reset(seed=0)
    env.step(_mid_action(env))
    frame = env.render()
    assert frame.shape == (480, 480, 3) and frame.dtype == np.uint8 and frame.std() > 5
    env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_reset_restores_neutral_tools_after_another_attempt(env_id):
    """An attempt that moved the tools (yaw, plank, pendulum) leaks nothing into the next reset's observation."""
    fresh = gym.make(env_id, obs_mode="state_image", image_size=32)
    used = gym.make(env_id, obs_mode="state_image", image_size=32)
    first, _ = fresh.reset(seed=5)
    used.reset(seed=9)
    used.step(used.action_space.high.astype(np.float64))
    again, _ = used.reset(seed=5)
    np.testing.assert_array_equal(again["state"], first["state"])
    np.testing.assert_array_equal(again["image"], first["image"])
    a = _mid_action(fresh)
    ra, rb = fresh.step(a), used.step(a)
    assert ra[1] == rb[1]
    np.testing.assert_array_equal(ra[4]["final_pos"], rb[4]["final_pos"])
    np.testing.assert_array_equal(ra[0]["image"], rb[0]["image"])
    fresh.close()
    used.close()
