"""The restitution-conditioned bounce skill's scene: the ball bouncing off the incline under the varied tasks'
physics, ``(restitution, wedge_angle, v_ver, v_hor) -> (dv_ver, dv_hor)``.

The hidden-physics track (:mod:`phyplan_envs.hidden_physics`) sets the ball-incline restitution per context through
an impact pair. This scene is the ball and a frictionless incline with that pair at the varied timestep; each
sample draws a restitution from the **training space** (the data spec's range is the hull of the training and test
spaces: the models' normalisation domain), an incline angle and an incoming velocity.

The outputs are the deviation of the outgoing velocity from the ideal reflection off a frictionless plane,
``(v_ver, v_hor) - ideal_bounce(restitution, wedge_angle, v_ver_in, v_hor_in)`` (:func:`ideal_bounce`: the normal
component reversed and scaled by the restitution, the tangential one kept), which the conditioned chains add back.
The deviation is a few centimetres per second and smooth, so a network learns it closely and extrapolates it far
more gracefully than the raw velocity. Sign conventions as in :mod:`.bounce` (``v_hor`` along the incline's
downslope horizontal direction, vertical up-positive).
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from .. import assets
from .. import hidden_physics as hp
from ..hidden_physics import TIMESTEP, TOUCH_OVERLAP
from .bounce import BOUNCE_ANGLE, BOUNCE_MIN_APPROACH, BOUNCE_V_HOR, BOUNCE_V_VER, INCLINE_HALF, INCLINE_POINT
from .common import DataSpec, Scene, progress
from .hit_cond import draw_train

PARAM = hp.INCLINE_RESTITUTION
# the models' domain: the hull of the training and test spaces when the shipped model was trained (the test space
# has been widened to 0.4-0.99 since; values beyond are extrapolated). Fixed so that a rebuild has the same domain.
DOMAIN_RESTITUTION = (0.5, 0.98)

DATA = DataSpec("bounce_cond", ("restitution", "wedge_angle", "v_ver", "v_hor"), ("dv_ver", "dv_hor"),
                ("", "rad", "m/s", "m/s"), ("m/s", "m/s"),
                (DOMAIN_RESTITUTION, BOUNCE_ANGLE, BOUNCE_V_VER, BOUNCE_V_HOR),
                "the ball bouncing off a frictionless incline (impact pair) under the varied physics; deviation "
                "from the ideal reflection; restitution data from the training space")


def ideal_bounce(restitution, wedge_angle, v_ver, v_hor):
    """Outgoing (v_ver, v_hor) of an ideal bounce off a frictionless incline at ``wedge_angle`` (its normal
    ``(sin a, cos a)`` in (downslope, up)): the normal component reversed and scaled by the restitution.
    Works on floats, numpy arrays and torch tensors."""
    if hasattr(wedge_angle, "sin"):
        nx, nz = wedge_angle.sin(), wedge_angle.cos()
    else:
        nx, nz = np.sin(wedge_angle), np.cos(wedge_angle)
    vn = v_hor * nx + v_ver * nz
    return v_ver - (1 + restitution) * vn * nz, v_hor - (1 + restitution) * vn * nx


def bounce_cond_scene() -> Scene:
    """The ball and a frictionless incline box joined by the varied impact pair ``ball_incline``."""
    root = assets.arena("skill_bounce_cond")
    root.option.timestep = TIMESTEP
    body = root.worldbody.add("body", name="incline", pos=INCLINE_POINT)
    body.add("geom", name="incline", type="box", size=INCLINE_HALF, pos=(0, 0, -INCLINE_HALF[2]),
             rgba=assets.TOOL_RGBA, priority=1, condim=1, friction=(0, 0, 0),
             solref=[float(v) for v in assets.ELASTIC_SOLREF.split()], **assets.WORLD)
    assets.add_ball(root)
    hp.add_impact_pair(root, "ball_geom", "incline", "ball_incline", PARAM.nominal, hp.INCLINE_STIFFNESS)
    return Scene.from_root(root)


def bounce_cond_one(s: Scene, restitution: float, angle: float, v_ver: float, v_hor: float) -> dict:
    """One bounce from the first touch (as the task: the ball starts exactly touching the incline, moving at
    ``(v_hor, v_ver)``): the incoming velocity and the velocity just after the contact ends."""
    m, d = s.model, s.data
    incline = s.geom_id("incline")
    normal = np.array([math.sin(angle), 0.0, math.cos(angle)])   # the incline falls towards +x
    m.body_quat[m.geom_bodyid[incline]] = (math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0)
    hp.set_restitution(m, "ball_incline", restitution, hp.INCLINE_STIFFNESS)
    q = s.joint_qpos_adr("ball_free")
    dv = s.joint_dof_adr("ball_free")
    mujoco.mj_resetData(m, d)
    vel = np.array([v_hor, 0.0, v_ver])
    touch = INCLINE_POINT + assets.BALL_RADIUS * normal
    d.qpos[q:q + 7] = (*(touch - TOUCH_OVERLAP * normal), 1, 0, 0, 0)
    d.qvel[dv:dv + 3] = vel
    mujoco.mj_forward(m, d)
    v_in, v_out = vel, None
    for _ in range(int(round(0.2 / m.opt.timestep))):
        mujoco.mj_step(m, d)
        if not d.ncon:
            v_out = d.qvel[dv:dv + 3].copy()
            break
    if v_out is None or v_out @ normal <= 0:
        raise RuntimeError(f"bounce_cond scene (restitution={restitution}, angle={angle}, v=({v_ver}, {v_hor})): "
                           f"no clean bounce")
    return {"v_in": v_in, "v_out": v_out}


def generate_samples(n: int, rng: np.random.Generator, show: bool) -> tuple[np.ndarray, np.ndarray, dict]:
    """``n`` bounces: restitution (training space), incline angle and incoming velocity (head-on enough)."""
    s = bounce_cond_scene()
    x = np.empty((n, 4))
    y = np.empty((n, 2))
    for i in progress(n, "bounce_cond data", show):
        while True:
            e = draw_train(PARAM, rng)
            angle = rng.uniform(*BOUNCE_ANGLE)
            v_ver = rng.uniform(*BOUNCE_V_VER)
            v_hor = rng.uniform(*BOUNCE_V_HOR)
            if -(v_hor * math.sin(angle) + v_ver * math.cos(angle)) >= BOUNCE_MIN_APPROACH:
                break
        r = bounce_cond_one(s, e, angle, v_ver, v_hor)
        vi, vo = r["v_in"], r["v_out"]
        iv, ih = ideal_bounce(e, angle, vi[2], vi[0])
        x[i] = (e, angle, vi[2], vi[0])
        y[i] = (vo[2] - iv, vo[0] - ih)
    return x, y, {}
