"""The general bounce off a face with exact impacts, ``bounce_general_exact_cond``: PaddlesVaried-v3's paddles
(:mod:`phyplan_envs.hidden_physics.impacts`), ``(restitution, incline_angle, v_down, v_across, v_normal) ->
(v_down, v_across, v_normal)`` in the incline frame of :mod:`.bounce_general` (same inputs, outputs, frame and
arrival procedure as ``bounce_general_low_cond``, :mod:`.bounce_general_low`).

The scene: the ball and a 2 m square board with Paddles' overdamped contact (``assets.PADDLE_SOLREF``) at the
Paddles timestep (0.5 ms), stepped by :class:`phyplan_envs.hidden_physics.FaceImpacts` with the arrival's
restitution. ``v_in`` is the velocity at the start of the step in which the ball reaches the face, ``v_out`` the
velocity at the end of it, after the impact. Only arrivals that bounce are data: the restitution times the normal
arrival speed is at least ``GLIDE_SPEED`` (slower rebounds glide, the ``glide`` skill's part; the sampler redraws
the others). Restitution data from ``PADDLE_RESTITUTION``'s training space (0.05-0.25), model domain its hull
(0.02-0.4); speeds 0.5-9 m/s, directions within 85 degrees of the inward normal and at least 0.1 m/s into the face,
incline angle 10-80 degrees (as ``bounce_general_low_cond``).
"""
from __future__ import annotations

import math

import numpy as np

from .. import assets
from .. import hidden_physics as hp
from .bounce_general import ANGLE, COLUMNS, draw_velocity
from .bounce_general_low import (BOARD_HALF, COND_DOMAIN, COND_PARAM, POINT, SPEED_LOW, TIMESTEP, _VN_RANGE,
                                 _V_RANGE, start_arrival)
from .common import DataSpec, Scene, progress

DATA = DataSpec("bounce_general_exact_cond", ("restitution", "incline_angle") + COLUMNS, COLUMNS,
                ("", "rad", "m/s", "m/s", "m/s"), ("m/s", "m/s", "m/s"),
                (COND_DOMAIN, ANGLE, _V_RANGE, _V_RANGE, _VN_RANGE),
                "the ball arriving at a frictionless incline with exact impacts (PaddlesVaried-v3's paddles, "
                "timestep 0.5 ms) from any direction into its face, fast enough to bounce; restitution data from "
                "PADDLE_RESTITUTION's training space; velocities in the incline frame; v_out after the impact")
MAX_STEPS = 200          # steps before the touch the ball is started within (it starts one step away)


def exact_bounce_scene() -> Scene:
    """The ball and a 2 m square board with Paddles' overdamped contact at 0.5 ms."""
    root = assets.arena("skill_bounce_exact")
    root.option.timestep = TIMESTEP
    body = root.worldbody.add("body", name="incline", pos=POINT)
    body.add("geom", name="incline", type="box", size=BOARD_HALF, pos=(0, 0, -BOARD_HALF[2]),
             rgba=assets.TOOL_RGBA, priority=1, condim=1, friction=(0, 0, 0),
             solref=[float(v) for v in assets.PADDLE_SOLREF], **assets.WORLD)
    assets.add_ball(root)
    return Scene.from_root(root)


class ExactBounceScene:
    """The exact-impact bounce scene (compiled once; angle and restitution set per bounce)."""

    def __init__(self):
        self.scene = exact_bounce_scene()
        s = self.scene
        m = s.model
        self.incline = s.geom_id("incline")
        self.body = int(m.geom_bodyid[self.incline])
        self.qpos = s.joint_qpos_adr("ball_free")
        self.dof = s.joint_dof_adr("ball_free")
        self.impacts = hp.FaceImpacts()
        self.impacts.bind(m, self.qpos, self.dof, assets.BALL_RADIUS, [self.body], BOARD_HALF[0])

    def bounce(self, e: float, angle: float, v_local, phase: float) -> dict:
        """One arrival, started one step before the touch with arrival phase ``phase`` (the procedure of
        :meth:`.bounce_general_low.LowBounceScene.bounce`). Returns ``v_in`` and ``v_out`` (incline frame)."""
        s = self.scene
        m, d = s.model, s.data
        m.body_quat[self.body] = (math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0)
        self.impacts.restitution = float(e)
        basis = start_arrival(m, d, self.qpos, self.dof, angle, v_local, phase)
        normal = basis[2]
        for _ in range(MAX_STEPS):
            before = d.qvel[self.dof:self.dof + 3].copy()
            self.impacts.step(m, d, 1)
            after = d.qvel[self.dof:self.dof + 3].copy()
            if after @ normal > 0:
                return {"v_in": basis @ before, "v_out": basis @ after}
        raise RuntimeError(f"exact bounce scene (e={e}, angle={angle}, v={v_local.tolist()}, phase={phase}): no "
                           f"bounce within {MAX_STEPS} steps")


def sample(n: int, rng: np.random.Generator, restitution=None, show: bool = False):
    """``n`` seeded arrivals that bounce (per sample from ``rng``: restitution, angle, velocity redrawn until
    ``restitution * |v_normal| >= GLIDE_SPEED``, phase). Returns inputs (N, 5), outputs (N, 3) and extras
    ``phase``."""
    scene = ExactBounceScene()
    restitution = COND_PARAM.train if restitution is None else restitution
    x, y = np.empty((n, 5)), np.empty((n, 3))
    ex = {"phase": np.empty(n)}
    for i in progress(n, "bounce_general_exact_cond data", show):
        e = float(restitution) if np.isscalar(restitution) else float(rng.uniform(*restitution))
        a = float(rng.uniform(*ANGLE))
        v = draw_velocity(rng, SPEED_LOW)
        while e * abs(v[2]) < hp.GLIDE_SPEED:
            v = draw_velocity(rng, SPEED_LOW)
        u = min(max(rng.random(), 1e-3), 1.0 - 1e-3)
        r = scene.bounce(e, a, v, u)
        x[i] = (e, a, *r["v_in"])
        y[i] = r["v_out"]
        ex["phase"][i] = u
    return x, y, ex


class _ExactCond:
    DATA = DATA

    @staticmethod
    def generate_samples(n: int, rng: np.random.Generator, show: bool):
        return sample(n, rng, show=show)


EXACT_COND = _ExactCond
__all__ = ["DATA", "EXACT_COND", "ExactBounceScene", "exact_bounce_scene", "sample"]
