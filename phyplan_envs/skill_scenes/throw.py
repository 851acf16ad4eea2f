"""The throw skill's scene: the task ball in free flight, ``(v_hor, v_ver, t) -> (x, y, v_ver)``."""
from __future__ import annotations

import mujoco
import numpy as np

from .. import assets
from .common import DataSpec, Scene, progress, steps

# Launch: horizontal 1.3-2.8 m/s; Bounce: 0 (the free fall onto the wedge) and up to 4.8 m/s after the incline; falls
# last up to ~0.5 s (1.2 m drop). v_hor reaches below 0 so that the free fall (v_hor = 0) is not at the domain's edge,
# where the fit is weakest (measured: y 6-8 mm off at v_hor = 0 with the range starting at 0).
THROW_V_HOR = (-1.0, 6.0)
THROW_V_VER = (-3.0, 3.0)
THROW_T = (0.0, 1.0)
THROW_START_Z = 10.0      # m: high enough that the ball never meets the ground within THROW_T

DATA = DataSpec("throw", ("v_hor", "v_ver", "t"), ("x", "y", "v_ver"), ("m/s", "m/s", "s"), ("m", "m", "m/s"),
                (THROW_V_HOR, THROW_V_VER, THROW_T), "the ball in free flight")


def throw_scene(camera: dict | None = None) -> Scene:
    """The task ball alone. ``camera``: keywords of :func:`phyplan_envs.assets.add_camera` for a camera ``"frames"``
    filming the flight (the perception data of :mod:`.frames`; a camera changes nothing in the physics)."""
    root = assets.arena("skill_throw")
    assets.add_ball(root)
    if camera is not None:
        assets.add_camera(root, "frames", **camera)
    return Scene.from_root(root)


def throw_release(s: Scene, v_hor: float, v_ver: float) -> None:
    """Reset ``s`` to the release: the ball at rest orientation at (0, 0, THROW_START_Z), velocity (v_hor, 0, v_ver)."""
    m, d = s.model, s.data
    q, dv = s.joint_qpos_adr("ball_free"), s.joint_dof_adr("ball_free")
    mujoco.mj_resetData(m, d)
    d.qpos[q:q + 7] = (0, 0, THROW_START_Z, 1, 0, 0, 0)
    d.qvel[dv:dv + 3] = (v_hor, 0.0, v_ver)


def throw_draw(rng: np.random.Generator) -> tuple[float, float, int]:
    """One sample's launch velocity and query step, drawn from ``rng`` (the order of :func:`generate_samples`)."""
    vh = rng.uniform(*THROW_V_HOR)
    vv = rng.uniform(*THROW_V_VER)
    return vh, vv, int(rng.integers(0, steps(THROW_T[1]) + 1))


def generate_samples(n: int, rng: np.random.Generator, show: bool) -> tuple[np.ndarray, np.ndarray, dict]:
    """``n`` rows: a launch velocity and a query time drawn uniformly, the displacement and v_ver at that time."""
    s = throw_scene()
    m, d = s.model, s.data
    q = s.joint_qpos_adr("ball_free")
    dv = s.joint_dof_adr("ball_free")
    x = np.empty((n, 3))
    y = np.empty((n, 3))
    for i in progress(n, "throw data", show):
        vh, vv, k = throw_draw(rng)
        throw_release(s, vh, vv)
        if k:
            mujoco.mj_step(m, d, nstep=k)
        if d.ncon:
            raise RuntimeError("the throw scene's ball touched something; THROW_START_Z is too low")
        x[i] = (vh, vv, k * m.opt.timestep)
        y[i] = (d.qpos[q], d.qpos[q + 2] - THROW_START_Z, d.qvel[dv + 2])
    return x, y, {}
