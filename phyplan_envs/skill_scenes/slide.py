"""The slide skill's scene: the task puck launched along +x on the task table, ``(v_init, t) -> (x, v)``.

Only the sliding phase is recorded (speed above ``SLIDE_END_SPEED``): the model continues the motion with constant
deceleration beyond the stop, and a caller reads the stopping distance where ``v`` crosses 0.
"""
from __future__ import annotations

import functools

import mujoco
import numpy as np

from .. import assets
from ..tasks.slide import FACTS as SLIDE_FACTS
from .common import DataSpec, Scene, progress

# The puck leaves the bob at an outcome-equivalent 1.35-2.75 m/s in the Slide task; slides last up to 1.63 s.
SLIDE_V = (0.8, 3.2)
SLIDE_T = (0.0, 1.7)
SLIDE_END_SPEED = 0.05    # m/s: the sliding phase ends (the puck's speed jitters by ~0.02 m/s while it slides)

DATA = DataSpec("slide", ("v_init", "t"), ("x", "v"), ("m/s", "s"), ("m", "m/s"),
                (SLIDE_V, SLIDE_T), "the puck sliding on the task table (sliding phase only)")


def slide_scene(friction: float = SLIDE_FACTS.table_friction, camera: dict | None = None) -> tuple[Scene, np.ndarray]:
    """The puck on a long strip of the task table, settled at rest; returns the scene and its settled state.

    ``camera``: keywords of :func:`phyplan_envs.assets.add_camera` for a camera ``"frames"`` filming the strip
    (the perception data of :mod:`.frames`; a camera changes nothing in the physics)."""
    root = assets.arena("skill_slide")
    assets.add_table(root, -0.3, 3.2, -0.4, 0.4, height=SLIDE_FACTS.table_height, friction=friction)
    assets.add_puck(root, mass=SLIDE_FACTS.puck_mass)
    if camera is not None:
        assets.add_camera(root, "frames", **camera)
    s = Scene.from_root(root)
    m, d = s.model, s.data
    q = s.joint_qpos_adr("puck_free")
    d.qpos[q:q + 3] = (0.0, 0.0, SLIDE_FACTS.puck_start[2])
    d.qpos[q + 3:q + 7] = (1, 0, 0, 0)
    mujoco.mj_step(m, d, nstep=300)   # settle into the soft contact (0.1 mm) before every launch
    d.qvel[:] = 0
    state = np.zeros(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_INTEGRATION))
    mujoco.mj_getState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)
    return s, state


def slide_rollout(s: Scene, state: np.ndarray, v0: float, t_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Launch the settled puck at ``v0`` along +x; record (x, v) every step while its speed is above
    ``SLIDE_END_SPEED`` (and at most ``t_max``). Row k is time k * TIMESTEP."""
    m, d = s.model, s.data
    mujoco.mj_setState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)
    q = s.joint_qpos_adr("puck_free")
    dv = s.joint_dof_adr("puck_free")
    x0 = d.qpos[q]
    d.qvel[dv] = v0
    n = int(round(t_max / m.opt.timestep))
    xs = np.empty(n + 1)
    vs = np.empty(n + 1)
    k = 0
    while True:
        xs[k] = d.qpos[q] - x0
        vs[k] = d.qvel[dv]
        if k == n:
            break
        mujoco.mj_step(m, d)
        vel = d.qvel[dv:dv + 3]
        if vel[0] * vel[0] + vel[1] * vel[1] + vel[2] * vel[2] < SLIDE_END_SPEED ** 2:
            break
        k += 1
    return xs[:k + 1], vs[:k + 1]


@functools.lru_cache(maxsize=None)
def measured_slide_mu() -> float:
    """The puck's effective friction coefficient on the task table: its measured deceleration / g.

    MuJoCo combines the two geoms' friction by maximum (both 0.2), but the soft contact makes the puck rock and
    chatter, so the deceleration is measured: a least-squares fit of ``x = v0 t - a t^2 / 2`` (v0 and a per launch,
    one shared a) to the sliding phase of launches at 1.0, 1.5, ..., 3.0 m/s. This is the "true" mu against which
    the slide PINN's estimate is scored (~0.1998).
    """
    s, state = slide_scene()
    rows, rhs = [], []
    speeds = np.arange(1.0, 3.01, 0.5)
    for i, v0 in enumerate(speeds):
        x, _ = slide_rollout(s, state, float(v0), SLIDE_T[1])
        t = np.arange(len(x)) * s.model.opt.timestep
        a = np.zeros((len(x), len(speeds) + 1))
        a[:, i] = t
        a[:, -1] = -0.5 * t * t
        rows.append(a)
        rhs.append(x)
    sol, *_ = np.linalg.lstsq(np.concatenate(rows), np.concatenate(rhs), rcond=None)
    return float(sol[-1] / assets.GRAVITY)


def generate_samples(n: int, rng: np.random.Generator, show: bool) -> tuple[np.ndarray, np.ndarray, dict]:
    """``n`` rows: a launch speed and a uniform time in the sliding phase, (x, v) at that time."""
    s, state = slide_scene()
    x = np.empty((n, 2))
    y = np.empty((n, 2))
    t_end = np.empty(n)
    dt = s.model.opt.timestep
    for i in progress(n, "slide data", show):
        v0 = rng.uniform(*SLIDE_V)
        u = rng.random()
        xs, vs = slide_rollout(s, state, v0, SLIDE_T[1])
        k = min(int(u * len(xs)), len(xs) - 1)      # a uniform time in the sliding phase
        x[i] = (v0, k * dt)
        y[i] = (xs[k], vs[k])
        t_end[i] = (len(xs) - 1) * dt
    return x, y, {"t_end": t_end}
