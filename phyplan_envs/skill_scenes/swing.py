"""The swing skill's scene: the task pendulum released from rest, ``(theta_init, t) -> (theta, omega)``."""
from __future__ import annotations

import functools
import math

import mujoco
import numpy as np

from .. import assets
from .common import DataSpec, Scene, progress, steps

# The tasks release the pendulum at theta in [pi/4, pi/2]; 0.1 rad of margin either side. The bob reaches the bottom
# after 0.28-0.33 s; t runs on to 0.6 s (past the bottom, up the other side).
SWING_THETA = (math.pi / 4 - 0.1, math.pi / 2 + 0.1)
SWING_T = (0.0, 0.6)

DATA = DataSpec("swing", ("theta_init", "t"), ("theta", "omega"), ("rad", "s"), ("rad", "rad/s"),
                (SWING_THETA, SWING_T), "the task pendulum released from rest")


def swing_scene(camera: dict | None = None) -> Scene:
    """The task pendulum alone. ``camera``: keywords of :func:`phyplan_envs.assets.add_camera` for a camera
    ``"frames"`` filming the swing (the perception data of :mod:`.frames`; a camera changes nothing in the physics)."""
    root = assets.arena("skill_swing")
    assets.add_pendulum(root)
    if camera is not None:
        assets.add_camera(root, "frames", **camera)
    return Scene.from_root(root)


@functools.lru_cache(maxsize=None)
def pendulum_equivalent_length() -> float:
    """Length (m) of the simple pendulum that swings like the task's compound pendulum (rod + cube bob).

    ``l_eq = I / (m d)`` with I the arm's moment of inertia about the hinge (from MuJoCo's mass matrix), m its mass
    and d the hinge-to-centre-of-mass distance: 0.29948 m against the nominal 0.3 m (the 10 g rod and the cube's own
    inertia). The swing PINN's equation ``theta'' + (g / l) sin(theta) = 0`` uses this l.
    """
    s = swing_scene()
    m, d = s.model, s.data
    mujoco.mj_forward(m, d)
    full = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, full)
    arm = s.body_id("pendulum_arm")
    dist = -float(m.body_ipos[arm][2])
    return float(full[0, 0] / (m.body_mass[arm] * dist))


def generate_samples(n: int, rng: np.random.Generator, show: bool, theta_range=SWING_THETA, t_range=SWING_T,
                     label: str = "swing") -> tuple[np.ndarray, np.ndarray, dict]:
    """``n`` rows: a release angle (in ``theta_range``) and a query time (in ``t_range``) drawn uniformly, (theta,
    omega) at that time."""
    s = swing_scene()
    m, d = s.model, s.data
    hq = s.joint_qpos_adr("pendulum_hinge")
    hv = s.joint_dof_adr("pendulum_hinge")
    x = np.empty((n, 2))
    y = np.empty((n, 2))
    k_max = steps(t_range[1])
    for i in progress(n, f"{label} data", show):
        th0 = rng.uniform(*theta_range)
        k = int(rng.integers(0, k_max + 1))
        mujoco.mj_resetData(m, d)
        d.qpos[hq] = th0
        if k:
            mujoco.mj_step(m, d, nstep=k)
        x[i] = (th0, k * m.opt.timestep)
        y[i] = (d.qpos[hq], d.qvel[hv])
    return x, y, {}
