"""Exact impacts of a ball on the top faces of static boards: Newton's restitution law, resolved inside the timestep.

MuJoCo's soft contact turns an impact into a spring-damper over a few milliseconds, and with a 0.5 ms step the ball
first touches anywhere within a step: how much normal speed comes back then depends on that arrival phase (the
spread is measured by ``python -m benchmarks.design_checks.hidden_physics --only rebound-phase``). A ball that hops
along a paddle carries that spread from hop to hop, and PaddlesVaried-v2's landings moved by centimetres when the
timestep halved. :class:`FaceImpacts` resolves the approach to each face instead:

* after every physics step, a ball whose centre has crossed a face's contact plane (the top face, offset by the
  ball's radius) from above, at a point inside the face, is put back at the crossing (interpolated along the step's
  straight path, which is exactly the integrator's) with its velocity ``v - (1 + e) (v . n) n`` (``n`` the face's
  normal, ``e`` the restitution; frictionless: the speed along the face is kept, and the spin), and is moved on
  for the rest of the step at that velocity;
* where the rebound ``e |v . n|`` would be slower than :data:`GLIDE_SPEED`, the law ends its series of hops: the
  ball is left to the board's own contact (Paddles' overdamped one), on which it glides down the face;
* a touch of the board anywhere else (its edges, corners or underside) is the board's own contact too.

The step is ``mujoco.mj_step`` plus that test, so an episode is deterministic and the same in every executor (the
flight's end rule calls :meth:`FaceImpacts.step` in place of ``mujoco.mj_step``); it runs step by step only while the
ball can reach a face within the call's steps, and in one ``mj_step(..., nstep)`` otherwise.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

GLIDE_SPEED = 0.05       # m/s: a rebound slower than this ends the hops; the ball glides on the board's contact
STEP_MARGIN = 0.01       # m: a face this much farther than the ball can travel in a call's steps is left alone
GRAVITY_REACH = 0.5 * 9.81


class FaceImpacts:
    """Newton's restitution law for a ball (free joint) on the top faces of static square boards (one restitution
    for all), in place of MuJoCo's soft contact for the approach; the module docstring is the spec.

    Args:
        restitution: ``e`` in [0, 1] (0: every arrival is left to the boards' own contact).
        glide_speed: rebounds slower than this (m/s) are left to the boards' own contact.
    """

    def __init__(self, restitution: float = 0.0, glide_speed: float = GLIDE_SPEED):
        self.restitution = check_restitution(restitution)
        self.glide_speed = float(glide_speed)
        self.bound = None

    def bind(self, model, qpos_adr: int, qvel_adr: int, radius: float, bodies, half: float) -> None:
        """The ball (its free joint's ``qpos`` and ``qvel`` addresses and radius, m) and the boards: the bodies whose
        origin is their top face's centre and whose local z is its normal, square faces of half edge ``half``."""
        if not radius > 0 or not half > 0:
            raise ValueError(f"radius and half must be positive, got {radius} and {half}")
        self.bound = (model, int(qpos_adr), int(qvel_adr), float(radius), np.asarray(bodies, dtype=np.int64),
                      float(half))

    def faces(self, d):
        """The faces' centres (K, 3), normals, in-face axes, and each contact plane's offset ``n . c + radius``."""
        _, _, _, r, bodies, _ = self.bound
        c = d.xpos[bodies].copy()
        rot = d.xmat[bodies].reshape(-1, 3, 3)
        n, u, w = rot[:, :, 2].copy(), rot[:, :, 0].copy(), rot[:, :, 1].copy()
        return c, n, u, w, np.einsum("ij,ij->i", n, c) + r

    def step(self, m, d, nstep: int = 1) -> None:
        """``mujoco.mj_step(m, d, nstep)`` with the faces' impacts resolved after every step."""
        if self.bound is None:
            raise RuntimeError("FaceImpacts.step before bind()")
        if self.restitution == 0.0:
            mujoco.mj_step(m, d, nstep=nstep)
            return
        _, qa, qv, _, _, half = self.bound
        c, n, u, w, off = self.faces(d)
        p0 = d.qpos[qa:qa + 3].copy()
        s0 = n @ p0 - off
        span = nstep * m.opt.timestep
        reach = float(np.linalg.norm(d.qvel[qv:qv + 3])) * span + GRAVITY_REACH * span * span + STEP_MARGIN
        if not np.any((s0 >= 0) & (s0 <= reach)):
            mujoco.mj_step(m, d, nstep=nstep)     # no face is within reach of the ball during these steps
            return
        dt = m.opt.timestep
        for _ in range(nstep):
            mujoco.mj_step(m, d)
            p = d.qpos[qa:qa + 3].copy()
            s1 = n @ p - off
            crossed = np.flatnonzero((s0 >= 0) & (s1 < 0))
            for i in crossed:
                f = s0[i] / (s0[i] - s1[i])
                at = p0 + f * (p - p0)
                rel = at - c[i]
                if abs(rel @ u[i]) > half or abs(rel @ w[i]) > half:
                    continue                       # beside the face: the board's edge, its own contact
                v = d.qvel[qv:qv + 3].copy()
                vn = float(v @ n[i])
                if vn >= 0 or -self.restitution * vn < self.glide_speed:
                    continue                       # the board's own contact: the ball glides
                v = v - (1.0 + self.restitution) * vn * n[i]
                p = at + (1.0 - f) * dt * v
                d.qpos[qa:qa + 3] = p
                d.qvel[qv:qv + 3] = v
                s1 = n @ p - off
                break
            p0, s0 = p, s1


def check_restitution(e: float) -> float:
    """``e`` as a float in [0, 1], or a ValueError naming it."""
    e = float(e)
    if not (math.isfinite(e) and 0.0 <= e <= 1.0):
        raise ValueError(f"restitution must be in [0, 1], got {e}")
    return e
