"""Camera frames of the slide, swing and throw skills' rollouts: the input of skill data *with perception* (the paper's
Fig. 5, left).

The slide scene (:func:`.slide.slide_scene`) gets a camera ``"frames"`` straight above the table strip, filming at
:data:`FRAME_RATE` frames per second in a 512 x 128 RGB-D picture (about 6 mm per pixel on the table). For sample
``i`` of a seed, :func:`slide_frames` draws the launch speed and the query time exactly as
``skill_scenes.generate("slide", n, seed)`` does (the same random stream, so row ``i`` of both is the same launch
and time), replays that rollout and yields the frames a camera would have taken around it:

* the first :data:`LAUNCH_FRAMES` frames after the launch (t = 0, 1/50, 2/50, ... s), from which a reader
  estimates the launch speed,
* the frames one frame period before, at and after the query time (``k`` steps), from which it reads the distance
  slid and the velocity (a central difference).

:func:`swing_frames` does the same for the swing skill (``skill_scenes.generate("swing", n, seed)``): a camera
:data:`SWING_CAMERA` looking along the hinge axis films the bob at release (t = 0) and one frame period before, at
and after the query time.

:func:`throw_frames` does the same for the throw skill (``skill_scenes.generate("throw", n, seed)``): a camera
:data:`THROW_CAMERA` 10.7 m in front of the flight plane, looking along +y, films every flight of the data set
(t up to 1.02 s: x from -1 to 6.1 m, heights 1.8-10.5 m) in a 1280 x 1536 RGB-D picture (about 5.8 mm per pixel in
the plane of flight, so the 40 mm ball spans about 7 pixels, ~40 pixels in all, wherever it is): the first
:data:`LAUNCH_FRAMES` frames after the release and one frame period before, at and after the query time.

What the simulator knows (the true launch velocity, displacement and velocity) is yielded beside the frames as
``truth`` for measuring the reading's error only. Reading the frames is the agents' business
(:mod:`phyplan_agents.perception.skill_data`); this module only films.
"""
from __future__ import annotations

import functools
from contextlib import contextmanager
from typing import Iterator

import mujoco
import numpy as np

from ..camera import DepthView, camera_model
from ..rendering import CameraView
from ..tasks.slide import FACTS as SLIDE_FACTS
from .slide import SLIDE_T, SLIDE_V, slide_rollout, slide_scene
from .swing import SWING_T, SWING_THETA, swing_scene
from .throw import THROW_START_Z, throw_draw, throw_release, throw_scene

FRAME_RATE = 50                      # frames per second (a 20 ms frame period: 20 physics steps)
FRAME_STEPS = 20
LAUNCH_FRAMES = 4                    # frames 0, 20, 40, 60 ms after the launch
FRAME_SIZE = (128, 512)              # height, width (pixels)
# 2.49 m above the table top, looking straight down; the 512-pixel rows run along the strip (+x), covering
# x = -0.15-2.65 m (the puck starts at 0; launches up to 3.2 m/s slide at most ~2.6 m); the columns y within +-0.35 m
FRAME_CAMERA = {"pos": (1.25, 0.0, SLIDE_FACTS.table_height + 2.49), "lookat": (1.25, 0.0, SLIDE_FACTS.table_height),
                "fovy": 16.0}
SWING_SIZE = (256, 256)
# 1.2 m in front of the swing plane (looking along the hinge axis), covering x, z within +-0.37 m of (0, 0.86): the
# bob's whole arc for release angles up to pi/2 + 0.1 (the pivot is at (0, 0, 1)); about 2.9 mm per pixel
SWING_CAMERA = {"pos": (0.0, -1.2, 0.86), "lookat": (0.0, 0.0, 0.86), "fovy": 34.0}
THROW_SIZE = (1536, 1280)
# 10.74 m in front of the flight plane (y = 0), looking along +y at (2.55, 0, 6.15) with a 45 degree vertical field:
# the plane of flight within x = 2.55 +- 3.71 m, z = 6.15 +- 4.45 m, about 0.1 m beyond every ball position of the
# data set's frames (x in [-1.02, 6.12] m, z in [1.84, 10.46] m for launches in THROW_V_HOR x THROW_V_VER and times
# up to THROW_T[1] + one frame period); about 5.8 mm per pixel there
THROW_CAMERA = {"pos": (2.55, -10.743, 6.15), "lookat": (2.55, 0.0, 6.15), "fovy": 45.0}


def _whole(value, what: str, least: int) -> int:
    """``value`` as an int, or a ValueError if it is not an integer >= ``least``."""
    try:
        ok = not isinstance(value, bool) and int(value) == value and value >= least
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ValueError(f"{what} must be an integer >= {least}, got {value!r}")
    return int(value)


def _checked(films):
    """``films(n, seed, salt)`` with its arguments checked when called (not at the first frame, as a generator
    would): ``n`` a positive integer, ``seed`` and ``salt`` non-negative integers."""
    @functools.wraps(films)
    def checked(n: int, seed: int, salt: int) -> Iterator[dict]:
        return films(_whole(n, "n", 1), _whole(seed, "seed", 0), _whole(salt, "salt", 0))
    return checked


@contextmanager
def _camera(scene, size: tuple[int, int]):
    """The scene's ``"frames"`` camera: ``(camera id, (RGB view, depth view))`` of ``size`` (height, width) pictures,
    closed on exit. The offscreen buffer is enlarged to the picture if needed (drawing only; no physics changes)."""
    m = scene.model
    cam_id = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, "frames")
    h, w = size
    m.vis.global_.offwidth = max(int(m.vis.global_.offwidth), w)
    m.vis.global_.offheight = max(int(m.vis.global_.offheight), h)
    views = (CameraView(m, cam_id, h, w), DepthView(m, cam_id, h, w))
    try:
        yield cam_id, views
    finally:
        for v in views:
            v.close()


@_checked
def slide_frames(n: int, seed: int, salt: int) -> Iterator[dict]:
    """Per sample ``i < n``: ``{"camera", "times", "frames", "k", "truth"}`` (module docstring).

    ``frames`` maps a physics step (``times``: its time in s) to ``{"rgb", "depth"}``; ``k`` is the query step;
    ``truth`` holds ``v_init``, ``x`` and ``v`` of the simulator at step ``k``. ``salt`` is the slide skill's
    random-stream salt of :func:`phyplan_envs.skill_scenes.generate`, so that rows match its slide data.
    """
    s, state = slide_scene(camera=FRAME_CAMERA)
    m, d = s.model, s.data
    dv = s.joint_dof_adr("puck_free")
    rng = np.random.default_rng([int(seed), int(salt)])
    dt = m.opt.timestep
    with _camera(s, FRAME_SIZE) as (cam_id, views):
        cam = camera_model(m, d, cam_id, *FRAME_SIZE)
        for _ in range(n):
            v0 = rng.uniform(*SLIDE_V)
            u = rng.random()
            xs, vs = slide_rollout(s, state, v0, SLIDE_T[1])
            k = min(int(u * len(xs)), len(xs) - 1)
            last = len(xs) - 1 + FRAME_STEPS     # the puck has (nearly) stopped; frames may run a little past
            wanted = sorted({*(j * FRAME_STEPS for j in range(LAUNCH_FRAMES)),
                             max(k - FRAME_STEPS, 0), k, min(k + FRAME_STEPS, last)})
            mujoco.mj_setState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)
            d.qvel[dv] = v0                      # the launch of slide_rollout, replayed
            frames = _film(s, wanted, views)
            yield {"camera": cam, "frames": frames, "times": {j: j * dt for j in frames}, "k": k,
                   "truth": {"v_init": v0, "x": float(xs[k]), "v": float(vs[k])}}


def _film(scene, wanted, views) -> dict:
    """Step ``scene`` (already at its start state) to each step in ``wanted`` (sorted) and draw ``views`` there."""
    m, d = scene.model, scene.data
    frames, at = {}, 0
    for step in wanted:
        if step > at:
            mujoco.mj_step(m, d, nstep=step - at)
            at = step
        mujoco.mj_kinematics(m, d)               # positions only: the replay stays bit-identical to the rollout
        mujoco.mj_camlight(m, d)
        frames[step] = {"rgb": views[0].draw(d), "depth": views[1].draw(d)}
    return frames


@_checked
def swing_frames(n: int, seed: int, salt: int) -> Iterator[dict]:
    """Per swing sample ``i < n``: ``{"camera", "times", "frames", "k", "truth"}`` as :func:`slide_frames`
    (``truth``: ``theta_init``, ``theta`` and ``omega`` at step ``k``); rows match the swing data of
    :func:`phyplan_envs.skill_scenes.generate` for the skill's ``salt``."""
    s = swing_scene(camera=SWING_CAMERA)
    m, d = s.model, s.data
    hq, hv = s.joint_qpos_adr("pendulum_hinge"), s.joint_dof_adr("pendulum_hinge")
    rng = np.random.default_rng([int(seed), int(salt)])
    dt = m.opt.timestep
    k_max = int(round(SWING_T[1] / dt))
    with _camera(s, SWING_SIZE) as (cam_id, views):
        for _ in range(n):
            th0 = rng.uniform(*SWING_THETA)
            k = int(rng.integers(0, k_max + 1))
            mujoco.mj_resetData(m, d)            # as the swing data: released from rest at th0, k steps
            d.qpos[hq] = th0
            if k:
                mujoco.mj_step(m, d, nstep=k)
            truth = {"theta_init": th0, "theta": float(d.qpos[hq]), "omega": float(d.qvel[hv])}
            mujoco.mj_resetData(m, d)
            d.qpos[hq] = th0
            frames = _film(s, sorted({0, max(k - FRAME_STEPS, 0), k, k + FRAME_STEPS}), views)
            cam = camera_model(m, d, cam_id, *SWING_SIZE)
            yield {"camera": cam, "frames": frames, "times": {j: j * dt for j in frames}, "k": k, "truth": truth}


@_checked
def throw_frames(n: int, seed: int, salt: int) -> Iterator[dict]:
    """Per throw sample ``i < n``: ``{"camera", "times", "frames", "k", "truth"}`` as :func:`slide_frames`
    (``truth``: ``v_hor``, ``v_ver`` of the release, ``x``, ``y`` and ``v_ver_t`` at step ``k``); rows match the
    throw data of :func:`phyplan_envs.skill_scenes.generate` for the skill's ``salt``."""
    s = throw_scene(camera=THROW_CAMERA)
    m, d = s.model, s.data
    q, dv = s.joint_qpos_adr("ball_free"), s.joint_dof_adr("ball_free")
    rng = np.random.default_rng([int(seed), int(salt)])
    dt = m.opt.timestep
    launch = [j * FRAME_STEPS for j in range(LAUNCH_FRAMES)]
    with _camera(s, THROW_SIZE) as (cam_id, views):
        cam = camera_model(m, d, cam_id, *THROW_SIZE)
        for _ in range(n):
            vh, vv, k = throw_draw(rng)          # as the throw data: released at (0, 0, THROW_START_Z), k steps
            throw_release(s, vh, vv)
            if k:
                mujoco.mj_step(m, d, nstep=k)
            truth = {"v_hor": vh, "v_ver": vv, "x": float(d.qpos[q]), "y": float(d.qpos[q + 2] - THROW_START_Z),
                     "v_ver_t": float(d.qvel[dv + 2])}
            throw_release(s, vh, vv)
            frames = _film(s, sorted({*launch, max(k - FRAME_STEPS, 0), k, k + FRAME_STEPS}), views)
            yield {"camera": cam, "frames": frames, "times": {j: j * dt for j in frames}, "k": k, "truth": truth}
