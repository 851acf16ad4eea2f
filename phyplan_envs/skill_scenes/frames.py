"""Camera frames of the slide and swing skills' rollouts: the input of skill data *with perception* (the paper's
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

What the simulator knows (the true launch velocity, displacement and velocity) is yielded beside the frames as
``truth`` for measuring the reading's error only. Reading the frames is the agents' business
(:mod:`phyplan_agents.perception.skill_data`); this module only films.
"""
from __future__ import annotations

from typing import Iterator

import mujoco
import numpy as np

from ..camera import DepthView, camera_model
from ..rendering import CameraView
from ..tasks.slide import FACTS as SLIDE_FACTS
from .slide import SLIDE_T, SLIDE_V, slide_rollout, slide_scene
from .swing import SWING_T, SWING_THETA, swing_scene

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


def slide_frames(n: int, seed: int, salt: int) -> Iterator[dict]:
    """Per sample ``i < n``: ``{"camera", "times", "frames", "k", "truth"}`` (module docstring).

    ``frames`` maps a physics step (``times``: its time in s) to ``{"rgb", "depth"}``; ``k`` is the query step;
    ``truth`` holds ``v_init``, ``x`` and ``v`` of the simulator at step ``k``. ``salt`` is the slide skill's
    random-stream salt of :func:`phyplan_envs.skill_scenes.generate`, so that rows match its slide data.
    """
    s, state = slide_scene(camera=FRAME_CAMERA)
    m, d = s.model, s.data
    cam_id = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, "frames")
    h, w = FRAME_SIZE
    rgb_view, depth_view = CameraView(m, cam_id, h, w), DepthView(m, cam_id, h, w)
    cam = camera_model(m, d, cam_id, h, w)
    dv = s.joint_dof_adr("puck_free")
    rng = np.random.default_rng([int(seed), int(salt)])
    dt = m.opt.timestep
    try:
        for _ in range(int(n)):
            v0 = rng.uniform(*SLIDE_V)
            u = rng.random()
            xs, vs = slide_rollout(s, state, v0, SLIDE_T[1])
            k = min(int(u * len(xs)), len(xs) - 1)
            last = len(xs) - 1 + FRAME_STEPS     # the puck has (nearly) stopped; frames may run a little past
            wanted = sorted({*(j * FRAME_STEPS for j in range(LAUNCH_FRAMES)),
                             max(k - FRAME_STEPS, 0), k, min(k + FRAME_STEPS, last)})
            mujoco.mj_setState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)
            d.qvel[dv] = v0                      # the launch of slide_rollout, replayed
            frames = _film(s, wanted, (rgb_view, depth_view))
            yield {"camera": cam, "frames": frames, "times": {j: j * dt for j in frames}, "k": k,
                   "truth": {"v_init": v0, "x": float(xs[k]), "v": float(vs[k])}}
    finally:
        rgb_view.close()
        depth_view.close()


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



def swing_frames(n: int, seed: int, salt: int) -> Iterator[dict]:
    """Per swing sample ``i < n``: ``{"camera", "times", "frames", "k", "truth"}`` as :func:`slide_frames`
    (``truth``: ``theta_init``, ``theta`` and ``omega`` at step ``k``); rows match the swing data of
    :func:`phyplan_envs.skill_scenes.generate` for the skill's ``salt``."""
    s = swing_scene(camera=SWING_CAMERA)
    m, d = s.model, s.data
    cam_id = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, "frames")
    h, w = SWING_SIZE
    views = (CameraView(m, cam_id, h, w), DepthView(m, cam_id, h, w))
    hq, hv = s.joint_qpos_adr("pendulum_hinge"), s.joint_dof_adr("pendulum_hinge")
    rng = np.random.default_rng([int(seed), int(salt)])
    dt = m.opt.timestep
    k_max = int(round(SWING_T[1] / dt))
    try:
        for _ in range(int(n)):
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
            cam = camera_model(m, d, cam_id, h, w)
            yield {"camera": cam, "frames": frames, "times": {j: j * dt for j in frames}, "k": k, "truth": truth}
    finally:
        for v in views:
            v.close()
