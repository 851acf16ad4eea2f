"""The free-hit skill's scene: the task pendulum hitting the ball off the pedestal, recorded in free flight,
``(m1, m2, v_init, edge) -> (dz, v_hor, v_ver)`` at :data:`D_REF` along the swing direction.

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

``v_init`` is the bob's speed measured at the first touch, as for :mod:`.hit`; ``edge`` is the distance from the
ball's resting position to the pedestal top's edge along the swing direction (the top is square, so it grows from
``PEDESTAL_HALF`` along an axis to sqrt(2) times that on a diagonal, and where the ball drops off it changes its
vertical speed by up to 0.05 m/s). From this state the ball is in free flight, which the throw skill models.
``extras`` hold the time from the first touch to the free state, the distance ``d_free`` at which the ball came
free, its offset across the swing plane (below 0.02 mm), and the release and plane angles.

``hit_free_slow`` (:data:`SLOW`) is the same hand-over for slow hits: bob speeds of :data:`HIT_SLOW_V` (Paddles'
gentle pushes: 0.34-0.85 m/s) and tops whose edge lies :data:`EDGE_SLOW` ahead of the ball (Paddles' shelf: 2 cm).
The scene is the same pendulum, ball and frictionless top, the top's half size set per sample so that its edge along
the swing lies at the drawn ``edge``. A slow ball is free within 7 cm, and the state is taken at :data:`D_SLOW`
(0.075 m) instead: at 0.115 m a ball pushed at 0.34 m/s off Paddles' shelf has already met the first paddle when
that paddle's face rises towards the shelf (odd N).

``hit_free_cond`` (:data:`COND`) is the same hand-over under the varied tasks' physics (the scene of
:mod:`.hit_cond`: the bob's sphere collider, the bob-ball impact pair, 0.5 ms, the attempt from the first touch),
``(bob_mass, restitution, v_init, edge) -> (gain, dz_excess, vz_excess)``, with the parameters drawn from the training
space. Its outputs are relative to an ideal hit, so that they stay small and smooth where the test spaces
extrapolate: ``gain`` is ``v_hor`` over :func:`~.hit_cond.ideal_hit_speed`, and ``dz_excess`` and ``vz_excess`` are
the height and vertical velocity at :data:`D_REF` minus those of a ball that left its resting position
horizontally at ``v_hor`` (``-g t^2 / 2`` and ``-g t``, ``t = D_REF / v_hor``).
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from .. import assets
from .. import hidden_physics as hp
from .common import DataSpec, progress, steps
from .hit import HIT_M1, HIT_M2_BALL, HIT_PHI, HIT_V, HitScene
from .hit_cond import (BALL_MASS, DOMAIN_BOB_MASS, DOMAIN_RESTITUTION, HIT_COND_PHI, HIT_COND_V, HitCondScene,
                       draw_train, ideal_hit_speed)
from .swing import pendulum_equivalent_length

D_REF = 0.115         # m: the hand-over plane, beyond where every ball of the domain is free (at most ~11 cm)
D_SLOW = 0.075        # m: ``hit_free_slow``'s, beyond where every ball of its domain is free (at most ~7 cm)
HIT_SLOW_V = (0.2, 1.05)     # m/s bob speed: Paddles' 0.34-0.85, up to the lower end of hit_free's HIT_V
EDGE_SLOW = (0.015, 0.035)   # m: the tops' edge ahead of the ball, from 1.5 cm (Paddles' shelf: 2 cm) to 3.5 cm
FREE_WITHIN = 1.0     # s: a ball not free this long after the first touch is an error of the scene

EDGE = (assets.PEDESTAL_HALF, assets.PEDESTAL_HALF * math.sqrt(2.0))   # m: the pedestal top's edge along the swing

DATA = DataSpec("hit_free", ("m1", "m2", "v_init", "edge"), ("dz", "v_hor", "v_ver"), ("kg", "kg", "m/s", "m"),
                ("m", "m/s", "m/s"), (HIT_M1, HIT_M2_BALL, HIT_V, EDGE),
                "the pendulum bob (m1) hitting the ball (m2) off the pedestal: the ball's free flight at D_REF")


def edge_distance(phi: float, half: float = assets.PEDESTAL_HALF) -> float:
    """The distance from the centre of a square top of half size ``half`` to its edge along the direction ``phi``."""
    return half / max(abs(math.cos(phi)), abs(math.sin(phi)))


def _free(d, geom: int) -> bool:
    return not any(geom in (d.contact[i].geom1, d.contact[i].geom2) for i in range(d.ncon))


def _at_ref(rel: np.ndarray, vel: np.ndarray, u: np.ndarray, d_ref: float = D_REF) -> dict[str, float]:
    """A free ball's offset ``rel`` from its start and velocity ``vel``, carried in free flight to ``d_ref``."""
    d_free, v_hor = float(rel[:2] @ u), float(vel[:2] @ u)
    dt = (d_ref - d_free) / v_hor
    return {"dz": float(rel[2] + vel[2] * dt - 0.5 * assets.GRAVITY * dt * dt), "v_hor": v_hor,
            "v_ver": float(vel[2] - assets.GRAVITY * dt), "d_free": d_free,
            "across": float(rel[:2] @ np.array([-u[1], u[0]]))}


def free_state(scene: HitScene, m1: float, m2: float, theta: float, phi: float,
               d_ref: float = D_REF) -> dict[str, float]:
    """One hit of the ball: its state at the first step after the first bob touch at which it touches nothing,
    carried in free flight to the plane ``d_ref`` out along the swing."""
    s, q, dv, hv, bob, obj = scene.prepared(m1, m2, theta, phi)
    m, d = s.model, s.data
    u = np.array([math.cos(phi), math.sin(phi)])
    v_bob = None
    for k in range(steps(assets.MAX_SIM_TIME)):
        w = d.qvel[hv]
        mujoco.mj_step(m, d)
        if v_bob is None:
            if s.touching(bob, obj):
                v_bob, k_first = abs(w) * assets.PENDULUM_LENGTH, k
            continue
        if _free(d, obj):
            return {"v_bob": v_bob, "t": (k - k_first) * m.opt.timestep,
                    **_at_ref(d.qpos[q:q + 3] - scene.start, d.qvel[dv:dv + 3], u, d_ref)}
        if (k - k_first) * m.opt.timestep > FREE_WITHIN:
            break
    raise RuntimeError(f"hit_free scene (m1={m1}, m2={m2}, theta={theta}, phi={phi}): the "
                       f"{'bob never touched the ball' if v_bob is None else 'ball was not free'} "
                       f"within {FREE_WITHIN} s")


def free_state_cond(scene: HitCondScene, bob_mass: float, restitution: float, v_init: float,
                    phi: float) -> dict[str, float]:
    """One hit of the ball under the varied physics, from the first touch: its free state at :data:`D_REF`."""
    start = scene.prepare(bob_mass, restitution, 0.0, v_init, phi)
    s = scene.scene
    m, d = s.model, s.data
    u = np.array([math.cos(phi), math.sin(phi)])
    for k in range(int(round(FREE_WITHIN / m.opt.timestep))):
        mujoco.mj_step(m, d)
        if k > 0 and _free(d, scene.geom):
            return {"t": (k + 1) * m.opt.timestep,
                    **_at_ref(d.qpos[scene.q:scene.q + 3] - start, d.qvel[scene.dv:scene.dv + 3], u)}
    raise RuntimeError(f"hit_free_cond scene (bob_mass={bob_mass}, restitution={restitution}, v_init={v_init}, "
                       f"phi={phi}): the ball was not free within {FREE_WITHIN} s")


def excess(v_hor, dz, v_ver, d_ref: float = D_REF):
    """``(dz_excess, vz_excess)``: the height and vertical velocity at ``d_ref`` above those of a ball that left its
    start horizontally at ``v_hor`` (floats, arrays or tensors)."""
    t = d_ref / v_hor
    return dz + 0.5 * assets.GRAVITY * t * t, v_ver + assets.GRAVITY * t


def from_excess(v_hor, dz_excess, vz_excess, d_ref: float = D_REF):
    """``(dz, v_ver)`` at ``d_ref`` back from :func:`excess` (floats, arrays or tensors)."""
    t = d_ref / v_hor
    return dz_excess - 0.5 * assets.GRAVITY * t * t, vz_excess - assets.GRAVITY * t


def generate_samples(n: int, rng: np.random.Generator, show: bool, v_range=HIT_V, edge_range=None,
                     d_ref: float = D_REF, label: str = "hit_free") -> tuple[np.ndarray, np.ndarray, dict]:
    """``n`` hits of the ball: masses, bob speed (in ``v_range``) and hit direction drawn uniformly (as :mod:`.hit`'s
    ball hits); with ``edge_range``, the top's edge along the swing drawn uniformly in it too (the top resized); the
    state taken at ``d_ref``."""
    scene = HitScene("ball")
    l_eq = pendulum_equivalent_length()
    x = np.empty((n, 4))
    y = np.empty((n, 3))
    ex = {k: np.empty(n) for k in ("t", "d_free", "across", "theta", "phi")}
    for i in progress(n, f"{label} data", show):
        m1, m2 = rng.uniform(*HIT_M1), rng.uniform(*HIT_M2_BALL)
        v_target = rng.uniform(*v_range)
        phi = rng.uniform(*HIT_PHI)
        if edge_range is not None:
            edge = rng.uniform(*edge_range)
            half = edge * max(abs(math.cos(phi)), abs(math.sin(phi)))
            scene.spec.geom("pedestal").size = (half, half, assets.PEDESTAL_HEIGHT / 2)
        # release angle whose ideal bottom speed is v_target; the recorded v_init is the measured bob speed
        theta = math.acos(1.0 - v_target ** 2 / (2.0 * assets.GRAVITY * l_eq))
        r = free_state(scene, m1, m2, theta, phi, d_ref)
        x[i] = (m1, m2, r["v_bob"], edge_distance(phi, float(scene.spec.geom("pedestal").size[0])))
        y[i] = (r["dz"], r["v_hor"], r["v_ver"])
        for k in ex:
            ex[k][i] = {"theta": theta, "phi": phi}.get(k, r.get(k))
    return x, y, ex


DATA_SLOW = DataSpec("hit_free_slow", ("m1", "m2", "v_init", "edge"), ("v_hor", "dz_excess", "vz_excess"),
                     ("kg", "kg", "m/s", "m"), ("m/s", "m", "m/s"), (HIT_M1, HIT_M2_BALL, HIT_SLOW_V, EDGE_SLOW),
                     "the pendulum bob (m1) pushing the ball (m2) off a top whose edge is `edge` ahead: the ball's "
                     "free flight at D_SLOW, relative to a ball that left its start horizontally at v_hor")


class _Slow:
    """``hit_free_slow``'s data spec and generator (:func:`generate_samples` over the slow hits, at :data:`D_SLOW`).
    Its outputs are ``v_hor`` and the height and vertical velocity relative to a ball that left its start
    horizontally at ``v_hor`` (:func:`excess`): a slow ball drops tens of centimetres on its way to the plane, which
    the excess leaves out (fitted directly, ``dz`` and ``v_ver`` had 3 mm and 19 mm/s RMS errors)."""

    DATA = DATA_SLOW

    @staticmethod
    def generate_samples(n: int, rng: np.random.Generator, show: bool):
        x, y, ex = generate_samples(n, rng, show, HIT_SLOW_V, EDGE_SLOW, D_SLOW, "hit_free_slow")
        dz, vz = excess(y[:, 1], y[:, 0], y[:, 2], D_SLOW)
        return x, np.column_stack([y[:, 1], dz, vz]), ex


SLOW = _Slow
REFERENCE = {"hit_free": D_REF, "hit_free_cond": D_REF, "hit_free_slow": D_SLOW}   # each hand-over skill's plane (m)


DATA_COND = DataSpec("hit_free_cond", ("bob_mass", "restitution", "v_init", "edge"),
                     ("gain", "dz_excess", "vz_excess"), ("kg", "", "m/s", "m"), ("", "m", "m/s"),
                     (DOMAIN_BOB_MASS, DOMAIN_RESTITUTION, HIT_COND_V, EDGE),
                     "the bob hitting the ball off the pedestal under the varied physics: its free flight at D_REF "
                     "relative to an ideal hit; parameter data from the training space")


def generate_samples_cond(n: int, rng: np.random.Generator, show: bool) -> tuple[np.ndarray, np.ndarray, dict]:
    """``n`` hits of the ball: bob mass and restitution (training space), bob speed and direction drawn."""
    scene = HitCondScene("ball")
    x = np.empty((n, 4))
    y = np.empty((n, 3))
    ex = {k: np.empty(n) for k in ("t", "d_free", "across", "dz", "v_hor", "v_ver", "phi")}
    for i in progress(n, "hit_free_cond data", show):
        m1, e = draw_train(hp.BOB_MASS, rng), draw_train(hp.BOB_RESTITUTION, rng)
        v, phi = float(rng.uniform(*HIT_COND_V)), float(rng.uniform(*HIT_COND_PHI))
        r = free_state_cond(scene, m1, e, v, phi)
        x[i] = (m1, e, v, edge_distance(phi))
        y[i] = (r["v_hor"] / ideal_hit_speed(m1, BALL_MASS, e, v),) + tuple(excess(r["v_hor"], r["dz"], r["v_ver"]))
        for k in ex:
            ex[k][i] = phi if k == "phi" else r[k]
    return x, y, ex


class _Cond:
    """``hit_free_cond``'s data spec and generator (the varied physics)."""

    DATA = DATA_COND
    generate_samples = staticmethod(generate_samples_cond)


COND = _Cond
