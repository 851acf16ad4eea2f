"""phyplan_envs.rendering: camera views draw exactly what a plain mujoco.Renderer draws, open lazily, close cleanly,
and every renderer is tracked for the exit hook; envs draw their observations and frames through it."""
from __future__ import annotations

import gc

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import phyplan_envs
from phyplan_envs import rendering

ENV_ID = phyplan_envs.env_id("launch")


@pytest.fixture(scope="module")
def env():
    e = gym.make(ENV_ID, with_panda=False).unwrapped
    e.reset(seed=0)
    yield e
    e.close()


def _plain(model, data, camera, size, groups):
    opt = mujoco.MjvOption()
    for g, shown in groups.items():
        opt.geomgroup[g] = int(shown)
    with mujoco.Renderer(model, size, size) as r:
        r.update_scene(data, camera=camera, scene_option=opt)
        return r.render().copy()


def test_view_draws_what_a_plain_renderer_draws(env):
    cam = mujoco.mj_name2id(env.model, mujoco.mjtObj.mjOBJ_CAMERA, "view")
    for groups in ({}, {1: False}):
        view = rendering.CameraView(env.model, cam, 48, 48, groups)
        try:
            img = view.draw(env.data)
        finally:
            view.close()
        assert img.shape == (48, 48, 3) and img.dtype == np.uint8 and img.max() > 0
        np.testing.assert_array_equal(img, _plain(env.model, env.data, cam, 48, groups))


def test_view_opens_lazily_returns_fresh_arrays_and_reopens_after_close(env):
    view = rendering.CameraView(env.model, 0, 32, 32)
    assert not view.is_open
    a = view.draw(env.data)
    assert view.is_open
    b = view.draw(env.data)
    assert not np.shares_memory(a, b)
    np.testing.assert_array_equal(a, b)
    view.close()
    view.close()                                   # idempotent
    assert not view.is_open
    np.testing.assert_array_equal(view.draw(env.data), a)
    view.close()


def test_bad_view_arguments_are_clear_errors(env):
    with pytest.raises(ValueError, match="camera"):
        rendering.CameraView(env.model, env.model.ncam, 32, 32)
    with pytest.raises(ValueError, match="geomgroups"):
        rendering.CameraView(env.model, 0, 32, 32, {mujoco.mjNGROUP: True})


def test_renderers_are_tracked_until_collected(env):
    gc.collect()
    n0 = rendering.live_renderers()
    r = rendering.new_renderer(env.model, 16, 16)
    assert rendering.live_renderers() == n0 + 1 and rendering._EXIT_HOOK
    r.close()
    del r
    gc.collect()
    assert rendering.live_renderers() == n0


EXIT_SCRIPT = """
import gymnasium as gym, phyplan_envs
from phyplan_envs import rendering
env = gym.make("PhyPlan/Launch-v0", with_panda=False, obs_mode="image", image_size=16).unwrapped
env.reset(seed=0)
r = env.observer.obs_view._renderer
assert rendering.live_renderers() == 1
rendering.close_renderers()
assert r._mjr_context is None and r._gl_context is None
view, data = env.observer.obs_view, env.data
env.close()                       # (closing again is harmless)
view.draw(data)                   # a new renderer, left open at exit: the atexit hook closes it
"""


def test_close_renderers_closes_the_live_ones_and_exit_is_clean():
    """In a fresh process (closing every renderer would break other tests' envs): close_renderers() frees the live
    renderers, and a process that exits with an env's renderer still open (the atexit hook) exits cleanly."""
    import os
    import subprocess
    import sys

    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    done = subprocess.run([sys.executable, "-c", EXIT_SCRIPT], capture_output=True, text=True, env=env, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "Error" not in done.stderr and "Exception" not in done.stderr, done.stderr


def test_state_env_opens_no_renderer_and_image_env_closes_its_own():
    gc.collect()
    n0 = rendering.live_renderers()
    e = gym.make(ENV_ID, with_panda=False).unwrapped
    e.reset(seed=0)
    e.step(e.action_space.sample())
    assert rendering.live_renderers() == n0 and not e.observer.obs_view.is_open
    e.close()
    e = gym.make(ENV_ID, with_panda=False, obs_mode="image", image_size=32, render_mode="rgb_array").unwrapped
    obs, _ = e.reset(seed=0)
    frame = e.render()
    assert obs.shape == (32, 32, 3) and frame.shape == (e.render_size, e.render_size, 3)
    views = e.observer.obs_view, e.observer.frame_view
    assert all(v.is_open for v in views)
    e.close()
    assert not any(v.is_open for v in views)
