"""The glide skill's scene: the task ball gliding on a frictionless incline board (the Paddles paddle contact),
``(incline_angle, v_down0, v_across0, t) -> (s_down, s_across, v_down)``.

The board is a long box (:data:`GLIDE_HALF`: 10 m along the slope, 4 m across) with exactly the paddle's contact
(:func:`phyplan_envs.assets.add_paddle`: ``priority=1``, ``condim=1``, zero friction, the overdamped ``solref =
assets.PADDLE_SOLREF``) at the Paddles timestep (0.5 ms), pitched by
``incline_angle`` so that its face falls towards +x (the incline frame of :mod:`.bounce_general`: ``down`` the
steepest descent, ``across`` the level line, ``normal`` the outward normal).

Each sample: the ball is put on the face 1.5 m below its upper edge and **settled** in resting contact (gravity's
normal component only, 0.1 s, then the velocity zeroed: it sits at the contact's equilibrium depth), then given the
in-plane velocity ``v_down0 * down + v_across0 * across`` under full gravity and stepped to the query time ``t`` (on
the 0.5 ms grid). Recorded: the displacement of the ball's centre along ``down`` (``s_down``) and ``across``
(``s_across``) from its settled start, and the downslope velocity ``v_down``.

``v_across`` is not an output: the face is frictionless (condim 1: only a normal force), so it stays at
``v_across0`` (the data check it: ``extras["v_across_err"]``, below 1e-9 m/s) and ``s_across = v_across0 t``. The
ball stays on the board: the start leaves 1.5 m above (v_down0 >= -1 m/s rises < 0.6 m in 0.6 s) and 8.5 m below
(at most 6.5 m travelled), 2 m either side (at most 1.2 m); ``extras["normal_drift"]`` (the change of the centre's
height above the face, m) and ``extras["in_contact"]`` record that it stays in resting contact. The law of the data
is ``s_down = v_down0 t + g sin(a) t^2 / 2``, ``v_down = v_down0 + g sin(a) t`` (the PINN's residual); the data
are MuJoCo's, not that formula.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from .. import assets
from .bounce_general import incline_basis
from .common import DataSpec, Scene, progress

GLIDE_TIMESTEP = 0.0005                       # s: the Paddles task's
GLIDE_ANGLE = (math.radians(20.0), math.radians(70.0))
GLIDE_V_DOWN = (-1.0, 8.0)
GLIDE_V_ACROSS = (-2.0, 2.0)
GLIDE_T = (0.0, 0.6)
GLIDE_SOLREF = assets.PADDLE_SOLREF          # the paddle's nominal contact
GLIDE_HALF = (5.0, 2.0, assets.PADDLE_THICK / 2)   # half sizes of the board: 10 m along the slope, 4 m across
GLIDE_POINT = np.array([0.0, 0.0, 10.0])      # the centre of the board's face (its low end stays above 5 m)
GLIDE_START = -3.5                            # m along ``down`` from the face's centre: 1.5 m below the upper edge
SETTLE_S = 0.1                                # s of settling under gravity's normal component

DATA = DataSpec("glide", ("incline_angle", "v_down0", "v_across0", "t"), ("s_down", "s_across", "v_down"),
                ("rad", "m/s", "m/s", "s"), ("m", "m", "m/s"), (GLIDE_ANGLE, GLIDE_V_DOWN, GLIDE_V_ACROSS, GLIDE_T),
                "the ball gliding on a frictionless incline board (the paddle contact, timestep 0.5 ms), started in "
                "resting contact with an in-plane velocity; displacement and downslope speed in the incline frame")


def glide_scene() -> Scene:
    """The ball and the long board (the paddle's contact settings), at the Paddles timestep."""
    root = assets.arena("skill_glide")
    root.option.timestep = GLIDE_TIMESTEP
    body = root.worldbody.add("body", name="board", pos=GLIDE_POINT)
    body.add("geom", name="board", type="box", size=GLIDE_HALF, pos=(0, 0, -GLIDE_HALF[2]),
             rgba=assets.TOOL_RGBA, priority=1, condim=1, friction=(0, 0, 0),
             solref=[float(v) for v in GLIDE_SOLREF],
             **assets.WORLD)
    assets.add_ball(root)
    return Scene.from_root(root)


class GlideScene:
    """The compiled glide scene; :meth:`glide` runs one sample."""

    def __init__(self):
        self.scene = glide_scene()
        s = self.scene
        self.board = s.geom_id("board")
        self.qpos = s.joint_qpos_adr("ball_free")
        self.dof = s.joint_dof_adr("ball_free")

    def settle(self, angle: float) -> np.ndarray:
        """Pitch the board to ``angle``, put the ball on the face at :data:`GLIDE_START` and let it settle; returns
        the incline basis (rows down, across, normal)."""
        s = self.scene
        m, d = s.model, s.data
        m.body_quat[m.geom_bodyid[self.board]] = (math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0)
        basis = incline_basis(angle)
        down, normal = basis[0], basis[2]
        mujoco.mj_resetData(m, d)
        start = GLIDE_POINT + GLIDE_START * down + (assets.BALL_RADIUS - 1e-6) * normal
        d.qpos[self.qpos:self.qpos + 7] = (*start, 1.0, 0.0, 0.0, 0.0)
        m.opt.gravity[:] = -assets.GRAVITY * math.cos(angle) * normal     # the normal component of gravity only
        mujoco.mj_step(m, d, nstep=int(round(SETTLE_S / m.opt.timestep)))
        m.opt.gravity[:] = (0.0, 0.0, -assets.GRAVITY)
        d.qvel[:] = 0.0
        mujoco.mj_forward(m, d)
        if not d.ncon:
            raise RuntimeError(f"glide scene (angle {angle}): the settled ball is not in contact")
        return basis

    def glide(self, angle: float, v_down0: float, v_across0: float, k: int) -> dict:
        """One sample: settle at ``angle``, launch in the plane, step ``k`` steps. Returns ``s_down``,
        ``s_across``, ``v_down``, ``v_across``, ``normal_drift``, ``in_contact``."""
        s = self.scene
        m, d = s.model, s.data
        basis = self.settle(angle)
        p0 = d.qpos[self.qpos:self.qpos + 3].copy()
        d.qvel[self.dof:self.dof + 3] = v_down0 * basis[0] + v_across0 * basis[1]
        if k:
            mujoco.mj_step(m, d, nstep=int(k))
        mujoco.mj_forward(m, d)
        disp = basis @ (d.qpos[self.qpos:self.qpos + 3] - p0)
        vel = basis @ d.qvel[self.dof:self.dof + 3]
        return {"s_down": float(disp[0]), "s_across": float(disp[1]), "v_down": float(vel[0]),
                "v_across": float(vel[1]), "normal_drift": float(disp[2]), "in_contact": float(d.ncon > 0)}


def generate_samples(n: int, rng: np.random.Generator, show: bool) -> tuple[np.ndarray, np.ndarray, dict]:
    """``n`` glides: angle, v_down0, v_across0 and a query step (0.5 ms grid) drawn uniformly, in this order."""
    g = GlideScene()
    x, y = np.empty((n, 4)), np.empty((n, 3))
    ex = {k: np.empty(n) for k in ("v_across_err", "normal_drift", "in_contact")}
    k_max = int(round(GLIDE_T[1] / GLIDE_TIMESTEP))
    for i in progress(n, "glide data", show):
        a = rng.uniform(*GLIDE_ANGLE)
        vd = rng.uniform(*GLIDE_V_DOWN)
        va = rng.uniform(*GLIDE_V_ACROSS)
        k = int(rng.integers(0, k_max + 1))
        r = g.glide(a, vd, va, k)
        x[i] = (a, vd, va, k * GLIDE_TIMESTEP)
        y[i] = (r["s_down"], r["s_across"], r["v_down"])
        ex["v_across_err"][i] = r["v_across"] - va
        ex["normal_drift"][i] = r["normal_drift"]
        ex["in_contact"][i] = r["in_contact"]
    return x, y, ex
