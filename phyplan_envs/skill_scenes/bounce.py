"""The bounce skill's scene: the task ball hitting a frictionless elastic incline,
``(e, wedge_angle, v_ver, v_hor) -> (v_ver, v_hor)``.

The ball's velocity is recorded just before the first contact with the incline and just after the contact ends (it
lasts 5-15 ms); ``e`` is the nominal restitution of the incline's ``solref``
(:func:`phyplan_envs.contact.solref_for_restitution`). ``v_hor`` (input and output) is along the incline's
downslope horizontal direction; the incoming ``v_ver`` is negative (falling).
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from .. import assets
from ..contact import DEFAULT_STIFFNESS, solref_for_restitution
from .common import DataSpec, Scene, progress, steps

# Bounce: restitution around the task wedge's ~0.95, incline angles around 45 degrees, drops of 0.2-1.5 m.
BOUNCE_E = (0.8, 1.0)
BOUNCE_ANGLE = (math.radians(30), math.radians(60))
BOUNCE_V_VER = (-5.5, -1.0)
BOUNCE_V_HOR = (-1.0, 1.0)
BOUNCE_MIN_APPROACH = 0.5    # m/s: least speed towards the incline (steep inclines outrun a fast downslope ball)
BOUNCE_STIFFNESS = DEFAULT_STIFFNESS   # the K of assets.ELASTIC_SOLREF
INCLINE_HALF = (0.2, 0.15, 0.05)   # half sizes of the incline box: 0.4 m along the slope, 0.3 m wide
INCLINE_POINT = np.array([0.0, 0.0, 1.0])   # where the ball meets the incline (high: nothing else within reach)

DATA = DataSpec("bounce", ("e", "wedge_angle", "v_ver", "v_hor"), ("v_ver", "v_hor"), ("", "rad", "m/s", "m/s"),
                ("m/s", "m/s"), (BOUNCE_E, BOUNCE_ANGLE, BOUNCE_V_VER, BOUNCE_V_HOR),
                "the ball bouncing off a frictionless elastic incline")


def bounce_scene() -> tuple[Scene, int]:
    """The ball and an incline: a box whose top face is the incline, with the task wedge's contact settings
    (``priority=1``, ``condim=1``, zero friction, negative ``solref``); its angle and solref are set per sample."""
    root = assets.arena("skill_bounce")
    # A static body whose origin is the impact point; yawing/pitching the body (not the geom: MuJoCo's midphase
    # keeps per-body bounding volumes from compile time) sets the incline angle.
    body = root.worldbody.add("body", name="incline", pos=INCLINE_POINT)
    body.add("geom", name="incline", type="box", size=INCLINE_HALF, pos=(0, 0, -INCLINE_HALF[2]),
             rgba=assets.TOOL_RGBA, priority=1, condim=1, friction=(0, 0, 0),
             solref=[float(v) for v in assets.ELASTIC_SOLREF.split()], **assets.WORLD)
    assets.add_ball(root)
    s = Scene.from_root(root)
    return s, s.geom_id("incline")


def bounce_one(s: Scene, incline: int, e: float, angle: float, v_ver: float, v_hor: float) -> dict[str, float]:
    """One bounce off the incline at ``angle`` with restitution ``e``: velocities before and after, contact time."""
    m, d = s.model, s.data
    normal = np.array([math.sin(angle), 0.0, math.cos(angle)])   # the incline falls towards +x
    m.body_quat[m.geom_bodyid[incline]] = (math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0)
    m.geom_solref[incline] = solref_for_restitution(e, BOUNCE_STIFFNESS)
    q = s.joint_qpos_adr("ball_free")
    dv = s.joint_dof_adr("ball_free")
    mujoco.mj_resetData(m, d)
    # start 1 cm (along the path) before touching the incline at INCLINE_POINT
    vel = np.array([v_hor, 0.0, v_ver])
    touch = INCLINE_POINT + assets.BALL_RADIUS * normal
    d.qpos[q:q + 7] = (*(touch - 0.01 * vel / np.linalg.norm(vel)), 1, 0, 0, 0)
    d.qvel[dv:dv + 3] = vel
    mujoco.mj_forward(m, d)
    if d.ncon:
        raise RuntimeError("bounce scene: the ball starts in contact")
    v_in = v_out = None
    k_in = 0
    for k in range(steps(0.5)):
        before = d.qvel[dv:dv + 3].copy()
        mujoco.mj_step(m, d)
        if v_in is None:
            if d.ncon:
                v_in, k_in, p_in = before, k, d.qpos[q:q + 3].copy()
            continue
        if not d.ncon:
            v_out = d.qvel[dv:dv + 3].copy()
            p_out = d.qpos[q:q + 3].copy()
            break
    if v_in is None or v_out is None:
        raise RuntimeError(f"bounce scene (e={e}, angle={angle}, v=({v_ver}, {v_hor})): no clean bounce")
    # no second touch: the ball must move away from the incline
    if v_out @ normal <= 0:
        raise RuntimeError(f"bounce scene (e={e}, angle={angle}, v=({v_ver}, {v_hor})): the ball did not leave")
    return {"v_in": v_in, "v_out": v_out, "contact_s": (k - k_in) * m.opt.timestep,
            "slide": float(np.linalg.norm(p_out - p_in))}


def generate_samples(n: int, rng: np.random.Generator, show: bool) -> tuple[np.ndarray, np.ndarray, dict]:
    """``n`` bounces: restitution, incline angle and incoming velocity drawn uniformly (head-on enough)."""
    s, incline = bounce_scene()
    x = np.empty((n, 4))
    y = np.empty((n, 2))
    ex = {k: np.empty(n) for k in ("contact_s", "slide")}
    for i in progress(n, "bounce data", show):
        while True:   # redraw incoming velocities that would not meet the incline head-on enough
            e = rng.uniform(*BOUNCE_E)
            angle = rng.uniform(*BOUNCE_ANGLE)
            v_ver = rng.uniform(*BOUNCE_V_VER)
            v_hor = rng.uniform(*BOUNCE_V_HOR)
            if -(v_hor * math.sin(angle) + v_ver * math.cos(angle)) >= BOUNCE_MIN_APPROACH:
                break
        r = bounce_one(s, incline, e, angle, v_ver, v_hor)
        x[i] = (e, angle, r["v_in"][2], r["v_in"][0])
        y[i] = (r["v_out"][2], r["v_out"][0])
        ex["contact_s"][i] = r["contact_s"]
        ex["slide"][i] = r["slide"]
    return x, y, ex
