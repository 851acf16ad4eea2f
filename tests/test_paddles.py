"""Paddles-N: the scene for any N, its arguments, its description against the model, the hidden restitution."""
from __future__ import annotations

import math

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import phyplan_envs  # noqa: F401
from phyplan_envs.tasks.paddles import MAX_PADDLES, OFFSET_SPAN, THETA, goal_range
from phyplan_envs.tasks.paddles_v0 import GOAL_RANGE_V0, PADDLE_SPAN


def make(n=3, version=1, **kw):
    return gym.make(f"PhyPlan/Paddles-v{version}", paddles=n, with_panda=False, **kw)


@pytest.mark.parametrize("version, name, span", [(1, "offset", OFFSET_SPAN), (0, "x", PADDLE_SPAN)])
@pytest.mark.parametrize("n", [1, 2, 3, 6])
def test_action_space_and_facts_grow_with_n(n, version, name, span):
    env = make(n, version)
    base = env.unwrapped
    assert base.action_names == ("theta",) + tuple(f"paddle{i}_{name}" for i in range(1, n))
    assert base.action_low[0] == THETA[0] and base.action_high[0] == THETA[1]
    assert np.all(base.action_low[1:] == span[0]) and np.all(base.action_high[1:] == span[1])
    f = base.facts
    assert f.shelf_top == n + 1.5
    assert f.paddle_z == tuple(n + 1.0 - i for i in range(n))
    assert f.paddle_falls[-1] == 1 and all(a == -b for a, b in zip(f.paddle_falls, f.paddle_falls[1:]))
    obs, info = env.reset(seed=1)
    assert obs[5] == pytest.approx(f.shelf_top) and obs[6] == pytest.approx(f.first_paddle_x)
    lo, hi = goal_range(n, None if version else GOAL_RANGE_V0)
    assert lo <= info["goal"][0] <= hi and info["goal"][1] == 0.0
    env.close()


@pytest.mark.parametrize("bad, err", [(0, ValueError), (MAX_PADDLES + 1, ValueError), (2.0, TypeError),
                                      (True, TypeError), ("3", TypeError)])
def test_bad_paddles_argument_names_it(bad, err):
    with pytest.raises(err, match="paddles"):
        make(bad)


@pytest.mark.parametrize("version, action", [(1, [0.3, 0.5, 0.85, 0.6]), (0, [0.3, 0.9, 0.1, 0.8])])
def test_description_matches_the_model(version, action):
    """Each paddle's described face is its board's top face in the compiled model after the set-up."""
    env = make(4, version).unwrapped
    env.reset(seed=0)
    a = np.array(action)
    env.release(a)
    d = env.describe(a)
    assert len(d.faces) == 4 and d.striker is not None and d.striker.plane[0] == 0.0
    for i, face in enumerate(d.faces):
        gid = mujoco.mj_name2id(env.model, mujoco.mjtObj.mjOBJ_GEOM, f"paddle{i}_board")
        rot = env.data.geom_xmat[gid].reshape(3, 3)
        top = env.data.geom_xpos[gid] + rot[:, 2] * env.model.geom_size[gid][2]
        assert np.allclose(face.vertices[0].mean(axis=0), top, atol=1e-9)
        assert np.allclose(face.normal[0], rot[:, 2], atol=1e-9)
        assert face.vertices[0].mean(axis=0)[0] == pytest.approx(env.paddle_x(a)[0, i])
        assert face.restitution == 0.0
    assert d.supports[0].top == pytest.approx(env.facts.shelf_top)


def test_ball_meets_paddle_zero_for_every_release():
    """Every release angle's ball lands on the fixed first paddle and glides off its lower edge."""
    env = make(1, record_trajectory=True).unwrapped
    env.reset(seed=0)
    for theta in np.linspace(*THETA, 4):
        _, _, _, _, info = env.step(np.array([theta]))
        p = info["trajectory"][:, 1:]
        c = np.array([env.facts.first_paddle_x, 0.0, env.facts.paddle_z[0]])
        n = np.array([math.sin(math.pi / 4), 0.0, math.cos(math.pi / 4)])
        assert np.min(np.abs((p - c) @ n - env.facts.ball_radius)) < 0.004
        assert info["final_pos"][0] > c[0] + 0.5       # thrown ahead off the lower edge
        env.reset(seed=0)


def test_varied_v3_hides_the_restitution_of_exact_impacts():
    env = gym.make("PhyPlan/PaddlesVaried-v3", paddles=2, with_panda=False).unwrapped
    obs, info = env.reset(seed=3)
    e = env.hidden_physics["paddle_restitution"]
    assert 0.02 <= e <= 0.4 and "paddle_restitution" not in info and env.hidden.impacts.restitution == e
    d = env.describe((env.action_low + env.action_high) / 2)
    assert [f.restitution for f in d.faces] == ["paddle_restitution"] * 2
    assert all(f.contact == "exact_impact" for f in d.faces)
    for i in range(2):     # no impact pair: the boards keep Paddles' own contact
        assert mujoco.mj_name2id(env.model, mujoco.mjtObj.mjOBJ_PAIR, f"ball_paddle{i}") == -1


def test_varied_v2_hides_the_paddle_restitution():
    with pytest.warns(DeprecationWarning, match="out of date"):
        env = gym.make("PhyPlan/PaddlesVaried-v2", paddles=2, with_panda=False).unwrapped
    obs, info = env.reset(seed=3)
    e = env.hidden_physics["paddle_restitution"]
    assert 0.02 <= e <= 0.4 and "paddle_restitution" not in info
    d = env.describe((env.action_low + env.action_high) / 2)
    assert [f.restitution for f in d.faces] == ["paddle_restitution"] * 2
    assert all(f.contact == "impact_pair" for f in d.faces)
    for i in range(2):
        assert mujoco.mj_name2id(env.model, mujoco.mjtObj.mjOBJ_PAIR, f"ball_paddle{i}") >= 0


def test_v0_paddles_change_the_landing_and_runs_repeat():
    env = make(2, version=0).unwrapped
    env.reset(seed=0)
    ctx = env.context
    out = []
    for x in (-0.6, -0.6, -0.4, -0.9):     # paddle 1 under paddle 0's throw (twice), moved along it, out of it
        env.reset(options={"context": ctx})
        out.append(env.step(np.array([0.3, x]))[4]["final_pos"][0])
    assert out[0] == out[1]                 # the same machine, the same action: bit-identical
    assert abs(out[2] - out[0]) > 0.05      # the paddle meets the ball higher up: it leaves faster
    assert out[3] < 0 < out[0]              # missed: the ball falls back behind the shelf


@pytest.mark.parametrize("kwargs, named", [({"half": 0.0}, "half"), ({"tilt": 0.0}, "tilt"),
                                           ({"tilt": math.pi / 2}, "tilt"), ({"tilt": float("nan")}, "tilt")])
def test_a_paddle_refuses_a_bad_shape_by_name(kwargs, named):
    from phyplan_envs.tools.paddles import Paddle

    with pytest.raises(ValueError, match=named):
        Paddle(1, 2.0, 1, span=PADDLE_SPAN, **kwargs)


def test_a_paddle_chain_refuses_paddles_with_an_action_span():
    from phyplan_envs.tools.paddles import Paddle, PaddleChain

    with pytest.raises(ValueError, match="fixed x"):
        PaddleChain([Paddle(0, 2.0, 1, x=0.25), Paddle(1, 1.0, -1, span=PADDLE_SPAN)], OFFSET_SPAN)


def test_an_offset_moves_its_paddle_and_every_paddle_below():
    """v1 places paddle i at paddle i-1's x plus its offset along the way paddle i-1's face falls: at N = 4 (faces
    falling -x, +x, -x, +x) moving paddle 2's offset moves paddles 2 and 3 by as much, in the model too."""
    env = make(4).unwrapped
    env.reset(seed=0)
    a = np.array([0.3, 0.5, 0.6, 0.7])
    x = env.paddle_x(a)[0]
    assert np.allclose(x, [0.25, 0.25 - 0.5, 0.25 - 0.5 + 0.6, 0.25 - 0.5 + 0.6 - 0.7])
    b = a.copy()
    b[2] += 0.2
    assert np.allclose(env.paddle_x(b)[0] - x, [0.0, 0.0, 0.2, 0.2])
    env.release(b)
    assert np.allclose([env.model.body(f"paddle{i}").pos[0] for i in range(4)], env.paddle_x(b)[0])


@pytest.mark.parametrize("n", [2, 3])
def test_v1_lands_where_v0_lands_with_the_same_paddle_places(n):
    """The versions differ in how an action places the paddles, not in the physics: v0 given the x that v1's
    offsets put the paddles at lands the ball at the same point (on one machine, bit for bit; with one goal for both,
    as the goal box's place changes the last bits of the simulation)."""
    v1, v0 = make(n).unwrapped, make(n, version=0).unwrapped
    rng = np.random.default_rng(n)
    for _ in range(2):
        a = rng.uniform(v1.action_low, v1.action_high)
        b = np.concatenate([a[:1], v1.paddle_x(a)[0, 1:]])
        v1.reset(seed=5, options={"goal": [0.8, 0.0]})
        v0.reset(seed=5, options={"goal": [0.8, 0.0]})
        assert v1.step(a)[4]["final_pos"].tolist() == v0.step(b)[4]["final_pos"].tolist()


def test_v2s_episode_cap_grows_with_n_and_v1_keeps_4_s():
    """v1's 4 s cap ends a fall through 12 paddles in the air (and v1 warns from N = 8 on); v2's grows by 0.75 s per
    paddle beyond N = 6, and the same action lands. Up to N = 6 the two give the same outcome, bit for bit."""
    import warnings

    assert gym.make("PhyPlan/Paddles-v2", paddles=6, with_panda=False).unwrapped.max_sim_time == 4.0
    assert gym.make("PhyPlan/Paddles-v2", paddles=12, with_panda=False).unwrapped.max_sim_time == 8.5
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gym.make("PhyPlan/Paddles-v2", paddles=12, with_panda=False).close()
    with pytest.warns(UserWarning, match="paddles=8.*4 s episode cap.*timeout"):
        gym.make("PhyPlan/Paddles-v1", paddles=8, with_panda=False).close()
    with pytest.warns(UserWarning, match="paddles=12"):
        old12 = gym.make("PhyPlan/Paddles-v1", paddles=12, with_panda=False).unwrapped
    new12 = gym.make("PhyPlan/Paddles-v2", paddles=12, with_panda=False).unwrapped
    a = np.full(12, 0.675)
    a[0] = 0.3
    ends = []
    for env in (old12, new12):
        env.reset(seed=0)
        ends.append(env.step(a)[4]["end_reason"])
    assert ends == ["timeout", "landed"]
    for n in (3, 6):
        out = []
        for version in (1, 2):
            env = gym.make(f"PhyPlan/Paddles-v{version}", paddles=n, with_panda=False).unwrapped
            env.reset(seed=5)
            act = np.random.default_rng(n).uniform(env.action_low, env.action_high)
            _, r, _, _, info = env.step(act)
            out.append((r, info["final_pos"].tolist(), info["end_reason"]))
        assert out[0] == out[1]


@pytest.mark.parametrize("n", [1, 3, 5, 8])
def test_varied_v3_goals_lie_where_chains_land_under_the_contexts_restitution(n):
    """PaddlesVaried-v3 draws each goal inside its context's band (where chain actions land at its restitution);
    a restitution with no band (the ball hops off and misses the next paddle) is redrawn."""
    from phyplan_envs.hidden_physics.tasks import paddles_reach

    env = gym.make("PhyPlan/PaddlesVaried-v3", paddles=n, with_panda=False).unwrapped
    for seed in (0, 1, 200000, 200001, 200002, 200003):
        env.reset(seed=seed)
        band = paddles_reach(n, env.hidden_physics["paddle_restitution"])
        assert band is not None and band[0] <= env.context["goal"][0] <= band[1] and env.context["goal"][1] == 0.0
    assert paddles_reach(5, 0.35) is None and paddles_reach(7, 0.35) is None and paddles_reach(2, 0.4) is not None
