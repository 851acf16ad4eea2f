"""The free-hit skill's scene: the task pendulum hitting the ball off the pedestal, recorded in free flight,
``(m1, m2, v_init) -> (dz, v_hor, v_ver)`` at :data:`D_REF` along the swing direction.

The hit skill (:mod:`.hit`) hands over an *outcome-equivalent* speed: exact where the ball lands at the Launch task's
landing height, but not on the way there (MuJoCo's soft bob contact carries the ball 7-11 cm, and it leaves the
pedestal already falling at 0.26-0.40 m/s; a path from the resting position at the equivalent speed runs up to 12 mm
off the real one). A flight that meets something before the ground needs the ball's physical state. This scene
takes it at the first time step after the first bob-ball touch at which the ball touches nothing (neither the bob
nor the pedestal), and carries that free flight in closed form (gravity only, as in the scene) to the vertical
plane :data:`D_REF` from the resting position along the swing direction, so that the record does not jump with the
time step on which the ball came free:

* ``dz``: the ball's height there above its resting position (m; negative: it has dropped off the pedestal's top);
* ``v_hor``, ``v_ver``: its velocity there along the swing direction and upwards (m/s).

``v_init`` is the bob's speed measured at the first touch, as for :mod:`.hit`. From this state the ball is in free
flight, which the throw skill models. ``extras`` hold the time from the first touch to the free state, the distance
``d_free`` at which the ball came free, its offset across the swing plane (below 0.02 mm), and the release and plane
angles.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from .. import assets
from .common import DataSpec, progress, steps
from .hit import HIT_M1, HIT_M2_BALL, HIT_PHI, HIT_V, HitScene
from .swing import pendulum_equivalent_length

D_REF = 0.115         # m: the hand-over plane, beyond where every ball of the domain is free (at most ~11 cm)
FREE_WITHIN = 1.0     # s: a ball not free this long after the first touch is an error of the scene

DATA = DataSpec("hit_free", ("m1", "m2", "v_init"), ("dz", "v_hor", "v_ver"), ("kg", "kg", "m/s"),
                ("m", "m/s", "m/s"), (HIT_M1, HIT_M2_BALL, HIT_V),
                "the pendulum bob (m1) hitting the ball (m2) off the pedestal: the ball's free flight at D_REF")


def free_state(scene: HitScene, m1: float, m2: float, theta: float, phi: float) -> dict[str, float]:
    """One hit of the ball: its state at the first step after the first bob touch at which it touches nothing,
    carried in free flight to the plane :data:`D_REF`."""
    s, q, dv, hv, bob, obj = scene.prepared(m1, m2, theta, phi)
    m, d = s.model, s.data
    u = np.array([math.cos(phi), math.sin(phi)])
    across = np.array([-u[1], u[0]])
    v_bob = None
    for k in range(steps(assets.MAX_SIM_TIME)):
        w = d.qvel[hv]
        mujoco.mj_step(m, d)
        if v_bob is None:
            if s.touching(bob, obj):
                v_bob, k_first = abs(w) * assets.PENDULUM_LENGTH, k
            continue
        if any(obj in (d.contact[i].geom1, d.contact[i].geom2) for i in range(d.ncon)):
            if (k - k_first) * m.opt.timestep > FREE_WITHIN:
                break
            continue
        rel = d.qpos[q:q + 3] - scene.start
        vel = d.qvel[dv:dv + 3]
        d_free, v_hor = float(rel[:2] @ u), float(vel[:2] @ u)
        dt = (D_REF - d_free) / v_hor
        return {"v_bob": v_bob, "dz": float(rel[2] + vel[2] * dt - 0.5 * assets.GRAVITY * dt * dt), "v_hor": v_hor,
                "v_ver": float(vel[2] - assets.GRAVITY * dt), "t": (k - k_first) * m.opt.timestep,
                "d_free": d_free, "across": float(rel[:2] @ across)}
    raise RuntimeError(f"hit_free scene (m1={m1}, m2={m2}, theta={theta}, phi={phi}): the "
                       f"{'bob never touched the ball' if v_bob is None else 'ball was not free'} "
                       f"within {FREE_WITHIN} s")


def generate_samples(n: int, rng: np.random.Generator, show: bool) -> tuple[np.ndarray, np.ndarray, dict]:
    """``n`` hits of the ball: masses, bob speed and hit direction drawn uniformly (as :mod:`.hit`'s ball hits)."""
    scene = HitScene("ball")
    l_eq = pendulum_equivalent_length()
    x = np.empty((n, 3))
    y = np.empty((n, 3))
    ex = {k: np.empty(n) for k in ("t", "d_free", "across", "theta", "phi")}
    for i in progress(n, "hit_free data", show):
        m1, m2 = rng.uniform(*HIT_M1), rng.uniform(*HIT_M2_BALL)
        v_target = rng.uniform(*HIT_V)
        phi = rng.uniform(*HIT_PHI)
        # release angle whose ideal bottom speed is v_target; the recorded v_init is the measured bob speed
        theta = math.acos(1.0 - v_target ** 2 / (2.0 * assets.GRAVITY * l_eq))
        r = free_state(scene, m1, m2, theta, phi)
        x[i] = (m1, m2, r["v_bob"])
        y[i] = (r["dz"], r["v_hor"], r["v_ver"])
        for k in ex:
            ex[k][i] = {"theta": theta, "phi": phi}.get(k, r.get(k))
    return x, y, ex
