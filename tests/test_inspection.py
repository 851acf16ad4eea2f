"""The inspection API of the envs (phyplan_envs.base): what design checks, benchmarks and tests read instead of the
envs' private state. Each item is checked against what the env does in ``step``."""
from __future__ import annotations

import collections
import math

import gymnasium as gym
import numpy as np
import pytest

import phyplan_envs
from phyplan_envs import assets

IDS = ["PhyPlan/Launch-v0", "PhyPlan/Bounce-v0", "PhyPlan/Bridge-v1", "PhyPlan/SlideVaried-v1",
       "PhyPlan/BounceVaried-v0"]


def _make(env_id, **kw):
    return gym.make(env_id, with_panda=kw.pop("with_panda", False), **kw).unwrapped


def _action(env, seed=0):
    rng = np.random.default_rng(seed)
    return env.action_low + (env.action_high - env.action_low) * rng.random(len(env.action_dims))


@pytest.mark.parametrize("env_id", IDS)
def test_action_bounds_are_the_declared_float64_bounds(env_id):
    env = _make(env_id)
    low, high = env.action_low, env.action_high
    assert low.dtype == high.dtype == np.float64
    assert low.tolist() == [d.low for d in env.action_dims] and high.tolist() == [d.high for d in env.action_dims]
    np.testing.assert_array_equal(env.action_space.low, low.astype(np.float32))
    low[:] = 99.0                                  # a copy: the env's bounds are not changed through it
    assert env.action_low.tolist() == [d.low for d in env.action_dims]
    env.close()


@pytest.mark.parametrize("robot", [None, "panda"])
@pytest.mark.parametrize("env_id", IDS)
def test_release_is_the_state_step_flies_from(env_id, robot):
    """``release(action)`` sets up and releases as ``step`` does: the object's state is where the recorded flight
    starts; the episode is then used up."""
    a, b = _make(env_id, robot=robot, with_panda=robot is not None), _make(env_id, robot=robot,
                                                                            with_panda=robot is not None)
    a.reset(seed=4)
    b.reset(seed=4, options={"record_trajectory": True})
    action = _action(a, seed=4)
    state = a.release(action)
    info = b.step(action)[4]
    np.testing.assert_array_equal(state.pos, info["trajectory"][0, 1:])
    assert state.pos.shape == state.vel.shape == state.angvel.shape == (3,) and state.quat.shape == (4,)
    now = a.object_state()
    np.testing.assert_array_equal(now.pos, a.object_pos())
    np.testing.assert_array_equal(now.vel, a.object_vel())
    with pytest.raises(RuntimeError, match="one attempt"):
        a.step(action)
    with pytest.raises(RuntimeError, match="one attempt"):
        a.release(action)
    a.close()
    b.close()


def test_release_checks_the_action_as_step_does():
    env = _make("PhyPlan/Launch-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="out of bounds"):
        env.release(np.array([0.3, 3.0]))
    with pytest.raises(ValueError, match="shape"):
        env.release(np.array([0.3]))
    env.release(np.array([0.3, 1.0]))               # the refused ones used nothing up
    env.close()


@pytest.mark.parametrize("env_id", ["PhyPlan/Launch-v0", "PhyPlan/Bridge-v0", "PhyPlan/LaunchVaried-v0"])
def test_the_pendulum_state(env_id):
    """The pendulum tool's hinge: at the release angle before a nominal swing; a varied task starts at the first
    touch, the bob already swinging towards the object."""
    env = _make(env_id)
    env.reset(seed=1)
    action = _action(env, seed=1)
    env.release(action)
    p = env.pendulum
    assert env.data.qpos[p.hinge] == p.hinge_angle() and env.data.qvel[p.hinge_dof] == p.hinge_speed()
    if env_id.startswith("PhyPlan/LaunchVaried"):
        assert p.hinge_speed() < 0 and abs(p.hinge_angle()) < 0.2
    else:
        assert p.hinge_angle() == pytest.approx(action[1], abs=1e-12) and p.hinge_speed() == 0.0
    env.close()
    assert _make("PhyPlan/Bounce-v0").pendulum is None


def test_timestep_is_the_models():
    for env_id, dt in (("PhyPlan/Slide-v0", assets.TIMESTEP), ("PhyPlan/SlideVaried-v1", 0.0005)):
        env = _make(env_id)
        assert env.timestep == dt == env.model.opt.timestep
        env.close()


def test_contact_pairs_and_touching():
    import mujoco

    env = _make("PhyPlan/Launch-v0")
    env.reset(seed=0)
    mujoco.mj_step(env.model, env.data, nstep=20)        # the ball settles onto the pedestal
    pairs = {frozenset(p) for p in env.contact_pairs()}
    assert frozenset(("ball_geom", "pedestal")) in pairs           # the ball rests on the pedestal
    assert env.touching("ball_geom", "pedestal") and env.touching("pedestal", "ball_geom")
    assert not env.touching("ball_geom", "ground")
    with pytest.raises(KeyError, match="no geom named 'nothing'"):
        env.touching("ball_geom", "nothing")
    env.close()


@pytest.mark.parametrize("robot, stages", [(None, {"setup", "flight"}),
                                           ("panda", {"plan", "setup", "ik", "setup_physics", "flight"})])
def test_stage_timer_times_every_stage_and_changes_nothing(robot, stages):
    seconds, steps = collections.Counter(), collections.Counter()

    def timer(stage, s, n=0):
        seconds[stage] += s
        steps[stage] += n

    outs = []
    for timed in (False, True):
        env = gym.make("PhyPlan/Launch-v0", robot=robot).unwrapped
        if timed:
            env.stage_timer = timer
        env.reset(seed=2)
        outs.append(env.step(np.array([0.6, 1.1]))[1:])
        env.close()
    assert set(seconds) == stages and all(v >= 0 for v in seconds.values())
    assert (steps["setup_physics"] > 0) == (robot is not None) and steps["flight"] == 0
    assert outs[0][0] == outs[1][0] and np.array_equal(outs[0][3]["final_pos"], outs[1][3]["final_pos"])


def test_named_access_names_the_scene():
    env = _make("PhyPlan/Bounce-v0")
    assert env.body_id("wedge") == env.scene.body_id("wedge")
    with pytest.raises(KeyError, match="no body named 'plank' in the bounce scene"):
        env.body_id("plank")
    assert math.isfinite(env.scene.joint_dof_adr("ball_free"))
    env.close()


def test_every_registered_class_has_the_inspection_api():
    names = ("action_low", "action_high", "release", "object_state", "object_pos", "object_vel", "timestep",
             "contact_pairs", "touching", "stage_timer", "pendulum")
    for env_id in [phyplan_envs.env_id(t) for t in phyplan_envs.ALL_TASKS] + list(phyplan_envs.LEGACY_IDS):
        cls = gym.registry[env_id].entry_point
        module, _, attr = cls.partition(":")
        import importlib

        klass = getattr(importlib.import_module(module), attr)
        assert all(hasattr(klass, n) for n in names), env_id
