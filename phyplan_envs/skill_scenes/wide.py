"""Wide-range variants of the swing, hit and throw skills for the Paddles task (new skills; the shipped ``swing``,
``hit`` and ``throw`` and their data are unchanged).

Paddles pushes a ball off a shelf with the task pendulum released at 0.2-0.5 rad (bob speed at the bottom
0.34-0.85 m/s), below the ranges of the shipped skills (swing 0.685-1.67 rad, hit 1.0-2.7 m/s), and the ball falls
through several metres (speeds beyond throw's -3..3 m/s). Each variant records exactly what its shipped skill
records, from the same scene, over a wider domain:

==============  ===================================  =========================================================
skill           inputs -> outputs                    scene (as the shipped skill), domain
==============  ===================================  =========================================================
``swing_wide``  (theta_init, t) -> (theta, omega)    :func:`.swing.swing_scene` (1 ms), theta_init 0.1-1.67 rad,
                                                     t 0-0.6 s
``hit_wide``    (m1, m2, v_init) -> (v,)             :class:`.hit.HitScene` (ball on the pedestal or puck on the
                                                     table, half each), bob speed 0.2-2.7 m/s
``throw_wide``  (v_hor, v_ver, t) -> (x, y, v_ver)   :func:`.throw.throw_scene` with the ball released at 30 m,
                                                     v_hor -1..8, v_ver -8..3 m/s, t 0-1.2 s
``throw_fast``  (v_hor, v_ver, t) -> (x, y, v_ver)   the same released at 40 m, v_hor -1..10, v_ver -10..6 m/s,
                                                     t 0-1.6 s: balls bouncing off paddles (a study's design)
==============  ===================================  =========================================================

The scenes run at the suite's 1 ms timestep as the shipped skills (the Paddles task runs at 0.5 ms; the pendulum's
and the free flight's trajectories agree between the two to well below the models' errors: semi-implicit Euler's
error is O(dt) on a smooth trajectory, ~1e-4 rad and ~5 mm over 1.2 s of a throw).
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from . import hit, swing
from .common import DataSpec, progress, steps
from .hit import HIT_M1, HIT_M2_BALL, HIT_M2_PUCK
from .throw import throw_scene

SWING_WIDE_THETA = (0.1, math.pi / 2 + 0.1)      # (0.1, 1.67) rad: Paddles' 0.2-0.5 rad and the shipped range
SWING_WIDE_T = (0.0, 0.6)
HIT_WIDE_V = (0.2, 2.7)                          # m/s bob speed: Paddles' 0.34-0.85 and the shipped 1.0-2.7
THROW_WIDE_V_HOR = (-1.0, 8.0)
THROW_WIDE_V_VER = (-8.0, 3.0)
THROW_WIDE_T = (0.0, 1.2)
THROW_WIDE_START_Z = 30.0   # m: at v_ver -8 m/s the ball falls 16.7 m in 1.2 s; it never meets the ground
THROW_FAST_V_HOR = (-1.0, 10.0)   # throw_fast: a ball bouncing off paddles (up to 10 m/s) and its longer flights
THROW_FAST_V_VER = (-10.0, 6.0)
THROW_FAST_T = (0.0, 1.6)
THROW_FAST_START_Z = 40.0   # m: at v_ver -10 m/s the ball falls 28.6 m in 1.6 s


class _Swing:
    DATA = DataSpec("swing_wide", ("theta_init", "t"), ("theta", "omega"), ("rad", "s"), ("rad", "rad/s"),
                    (SWING_WIDE_THETA, SWING_WIDE_T), "the task pendulum released from rest (wide release range)")

    @staticmethod
    def generate_samples(n: int, rng: np.random.Generator, show: bool):
        """:func:`.swing.generate_samples` over :data:`SWING_WIDE_THETA` and :data:`SWING_WIDE_T`."""
        return swing.generate_samples(n, rng, show, SWING_WIDE_THETA, SWING_WIDE_T, "swing_wide")


class _Hit:
    DATA = DataSpec("hit_wide", ("m1", "m2", "v_init"), ("v",), ("kg", "kg", "m/s"), ("m/s",),
                    (HIT_M1, (HIT_M2_PUCK[0], HIT_M2_BALL[1]), HIT_WIDE_V),
                    "the pendulum bob (m1) hitting the ball (m2 in HIT_M2_BALL) or the puck (m2 in HIT_M2_PUCK); "
                    "wide bob-speed range")

    @staticmethod
    def generate_samples(n: int, rng: np.random.Generator, show: bool):
        """:func:`.hit.generate_samples` with the bob speed drawn from :data:`HIT_WIDE_V`. ``v_init`` is the
        measured bob speed at the first contact, so it may fall slightly outside the drawn range."""
        return hit.generate_samples(n, rng, show, HIT_WIDE_V, "hit_wide")


def throw_samples(n: int, rng: np.random.Generator, show: bool, name: str, v_hor, v_ver, t, start_z: float):
    """``n`` free flights of the throw scene (:func:`.throw.throw_scene`) released at ``start_z`` m with v_hor and
    v_ver uniform in ``v_hor`` and ``v_ver`` (m/s), recorded after a whole number of steps uniform in ``t`` (s): as
    :func:`.throw.generate_samples` records them (``name``: the progress label)."""
    s = throw_scene()
    m, d = s.model, s.data
    q, dv = s.joint_qpos_adr("ball_free"), s.joint_dof_adr("ball_free")
    x, y = np.empty((n, 3)), np.empty((n, 3))
    k_max = steps(t[1])
    for i in progress(n, f"{name} data", show):
        vh = rng.uniform(*v_hor)
        vv = rng.uniform(*v_ver)
        k = int(rng.integers(0, k_max + 1))
        mujoco.mj_resetData(m, d)
        d.qpos[q:q + 7] = (0, 0, start_z, 1, 0, 0, 0)
        d.qvel[dv:dv + 3] = (vh, 0.0, vv)
        if k:
            mujoco.mj_step(m, d, nstep=k)
        if d.ncon:
            raise RuntimeError(f"the {name} scene's ball touched something")
        x[i] = (vh, vv, k * m.opt.timestep)
        y[i] = (d.qpos[q], d.qpos[q + 2] - start_z, d.qvel[dv + 2])
    return x, y, {}


class ThrowVariant:
    """A throw skill's entry of :data:`phyplan_envs.skill_scenes.DATA_SPECS` (its data spec and generator, as a skill
    module has them): the free flight of the throw scene over ``v_hor``, ``v_ver`` (m/s) and ``t`` (s), released at
    ``start_z`` m (:func:`throw_samples`)."""

    def __init__(self, name: str, v_hor, v_ver, t, start_z: float, what: str):
        self.DATA = DataSpec(name, ("v_hor", "v_ver", "t"), ("x", "y", "v_ver"), ("m/s", "m/s", "s"),
                             ("m", "m", "m/s"), (v_hor, v_ver, t), what)
        self._args = (name, v_hor, v_ver, t, start_z)

    def generate_samples(self, n: int, rng: np.random.Generator, show: bool):
        """As :func:`.throw.generate_samples` over this variant's ranges."""
        return throw_samples(n, rng, show, *self._args)


THROW_WIDE = ThrowVariant("throw_wide", THROW_WIDE_V_HOR, THROW_WIDE_V_VER, THROW_WIDE_T, THROW_WIDE_START_Z,
                          "the ball in free flight (wide velocity and time ranges)")
THROW_FAST = ThrowVariant("throw_fast", THROW_FAST_V_HOR, THROW_FAST_V_VER, THROW_FAST_T, THROW_FAST_START_Z,
                          "the ball in free flight (the velocity and time ranges of balls bouncing off paddles)")
SWING_WIDE, HIT_WIDE = _Swing, _Hit
