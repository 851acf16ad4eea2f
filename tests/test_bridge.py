"""PhyPlan/Bridge-v0: API checks, determinism, and the physics the task design rests on.

tests/test_envs.py runs the checks shared by every task on Bridge too (determinism in a fresh process, bad actions,
context round trip, trajectories, images that follow the goal).
"""
from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import phyplan_envs
from phyplan_envs import assets
from phyplan_envs.tasks import bridge

ENV_ID = "PhyPlan/Bridge-v0"


def make(**kw):
    kw.setdefault("with_panda", False)   # the Panda is visual only; test_envs.py builds the default scene
    return gym.make(ENV_ID, **kw).unwrapped


def landing(env, action, goal=(1.2, 0.5)):
    env.reset(seed=0, options={"goal": goal})
    _, reward, _, _, info = env.step(np.asarray(action, dtype=np.float64))
    return float(np.hypot(*info["final_pos"][:2])), reward, info


@pytest.mark.parametrize("obs_mode", ["state", "image", "state_image"])
def test_check_env(obs_mode):
    env = gym.make(ENV_ID, obs_mode=obs_mode)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_registered_and_spec_matches_docstring():
    assert phyplan_envs.env_id("bridge") == ENV_ID
    env = make()
    assert env.action_names == ("phi", "theta", "bridge_yaw")
    np.testing.assert_allclose(env.action_space.low, [0, math.pi / 4, 0], atol=1e-6)
    np.testing.assert_allclose(env.action_space.high, [math.pi / 2, math.pi / 2, math.pi / 2], atol=1e-6)
    doc = type(env).__doc__
    for name in env.action_names + env.state_names:
        assert f"``{name}``" in doc or name in doc, name
    obs, _ = env.reset(seed=1)
    assert obs.shape == (len(env.state_names),)
    np.testing.assert_allclose(obs[5:], [bridge.TABLE_RADIUS, bridge.TABLE_HEIGHT, assets.BRIDGE_LENGTH,
                                         assets.BRIDGE_WIDTH], atol=1e-6)


def test_goal_sampling_within_documented_range():
    env = make()
    for seed in range(30):
        _, info = env.reset(seed=seed)
        g = info["goal"]
        assert bridge.GOAL_DISTANCE[0] <= np.hypot(*g) <= bridge.GOAL_DISTANCE[1]
        assert -1e-9 <= math.atan2(g[1], g[0]) <= math.pi / 2 + 1e-9


def test_same_seed_same_outcome_and_neutral_reset():
    a, b = make(obs_mode="state_image"), make(obs_mode="state_image")
    action = np.array([0.5, 1.4, 0.5])
    oa, _ = a.reset(seed=7)
    # b first plays a different attempt with the bridge elsewhere: reset must restore the neutral tool poses
    b.reset(seed=3)
    b.step([1.2, 1.0, 0.1])
    ob, _ = b.reset(seed=7)
    assert b.bridge_yaw() == pytest.approx(bridge.NEUTRAL_YAW)
    np.testing.assert_array_equal(oa["state"], ob["state"])
    np.testing.assert_array_equal(oa["image"], ob["image"])
    ra = a.step(action)
    rb = b.step(action)
    assert ra[1] == rb[1]
    np.testing.assert_array_equal(ra[4]["final_pos"], rb[4]["final_pos"])
    np.testing.assert_array_equal(ra[0]["image"], rb[0]["image"])
    assert a.bridge_yaw() == pytest.approx(0.5)


def test_reward_matches_info_distances():
    env = make()
    for seed, action in [(0, [0.3, 1.5, 0.3]), (1, [1.0, 1.0, 0.2]), (2, [0.7, 0.9, 0.7])]:
        _, info0 = env.reset(seed=seed)
        _, reward, terminated, truncated, info = env.step(action)
        assert terminated and not truncated
        goal = info0["goal"]
        d0 = np.linalg.norm(goal - bridge.PUCK_START[:2])
        d = np.linalg.norm(info["final_pos"][:2] - goal)
        assert info["initial_distance"] == pytest.approx(d0)
        assert info["distance"] == pytest.approx(d)
        assert reward == pytest.approx(1 - d / d0)
        assert info["is_success"] == bool(np.all(np.abs(info["final_pos"][:2] - goal) <= assets.GOAL_HALF))


def test_aligned_bridge_carries_puck_farther():
    for phi in (0.3, 1.2):
        aligned, _, info_a = landing(make(), [phi, math.pi / 2, phi])
        away, _, info_b = landing(make(), [phi, math.pi / 2, 0.0 if phi > math.pi / 4 else math.pi / 2])
        assert info_a["end_reason"] == info_b["end_reason"] == "landed"
        # the plank ends 1.0 m out; without it the puck leaves the table rim at 0.25 m
        assert aligned > 1.3 and away < 0.9, (phi, aligned, away)
        # the puck flies along phi either way
        for info in (info_a, info_b):
            assert math.atan2(info["final_pos"][1], info["final_pos"][0]) == pytest.approx(phi, abs=0.02)


def test_far_goal_needs_the_bridge():
    """A goal 1.3 m out: some release angle lands near it over the bridge; none does without it."""
    env = make()
    goal = bridge.polar(1.3, 0.5)
    thetas = np.radians(np.arange(70, 90.1, 2.5))
    rewards = {}
    for name, yaw in (("with", 0.5), ("without", math.pi / 2)):
        best = -np.inf
        for th in thetas:
            env.reset(seed=0, options={"goal": goal})
            best = max(best, env.step([0.5, th, yaw])[1])
        rewards[name] = best
    assert rewards["with"] > 0.9
    assert rewards["without"] < 0.7
    assert rewards["with"] - rewards["without"] > 0.2


def test_landing_is_smooth_in_release_angle():
    """Over the bridge the landing distance grows smoothly with theta (a flush plank made it jump by up to 0.14 m)."""
    env = make()
    thetas = np.radians(np.arange(70, 90.01, 1.0))
    dist = np.array([landing(env, [0.6, th, 0.6])[0] for th in thetas])
    assert np.all(np.diff(dist) > -0.01), np.round(dist, 3)
    resid = dist - np.polyval(np.polyfit(thetas, dist, 3), thetas)
    assert np.max(np.abs(resid)) < 0.02, np.round(resid, 3)


def test_puck_can_stop_on_the_plank():
    """A slow puck stops on the plank: the episode ends by the rest rule and its xy there counts."""
    _, _, info = landing(make(), [0.6, math.radians(55), 0.6])
    assert info["end_reason"] == "rest"
    r = np.hypot(*info["final_pos"][:2])
    assert bridge.TABLE_RADIUS < r < bridge.TABLE_RADIUS + assets.BRIDGE_LENGTH
    assert info["final_pos"][2] > bridge.TABLE_HEIGHT - assets.BRIDGE_DROP
