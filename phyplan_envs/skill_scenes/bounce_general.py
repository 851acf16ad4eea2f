"""The general-incidence bounce skill's scenes: the task ball arriving at an incline from any direction that hits
its face, ``(e, incline_angle, v_down, v_across, v_normal) -> (v_down, v_across, v_normal)``.

Velocities are in the **incline frame** (:func:`incline_basis`): ``down`` along the steepest descent in the face,
``across`` along the face's level line (``normal x down``, so (down, across, normal) is right-handed) and ``normal``
the outward normal; the incoming ``v_normal`` is negative (towards the face). ``incline_angle`` is the face's tilt
from horizontal (the normal's angle from vertical).

Two physics, each its own skill (the contact exactly as the tasks set it):

* ``bounce_general``: the Bounce-v0 wedge's contact (:func:`.bounce.bounce_scene`: ``priority=1``, ``condim=1``,
  zero friction, MuJoCo's default ``solimp``, timestep 1 ms) with the restitution ``e`` set as the existing bounce
  skill sets it, ``solref = solref_for_restitution(e, 2e5)`` (:mod:`phyplan_envs.contact`); ``e`` is that solref's
  nominal restitution, 0.9487 for the task wedge (``assets.ELASTIC_SOLREF``).
* ``bounce_general_cond``: the hidden-physics track's ball-incline impact pair (:func:`.bounce_cond.
  bounce_cond_scene`: calibrated damping, constant impedance, timestep 0.5 ms) with the restitution set by
  :func:`phyplan_envs.hidden_physics.set_restitution`. As the other conditioned skills, the data draw the
  restitution from the track's **training space** (0.7-0.9); the model domain is the hull of both spaces (0.4-0.99).

Each sample is one arrival: the ball is started one timestep before it first touches the face, with the velocity
that MuJoCo's Euler step turns into the sampled incoming velocity at the touch, and with a sampled **arrival phase**
``u``: in the step it first touches, the ball sinks ``u |v_normal| dt`` into the face (a ball arriving from a flight
meets the face at a uniformly random point of a timestep; the phase changes the outcome, the "sawtooth" of
docs/physics.md, so the data carry it as scatter). Recorded: the velocity at the first state in contact (``v_in``:
the sampled one to rounding) and at the first state out of contact (``v_out``: right after the contact ends).

Sampled domain: speed uniform in :data:`SPEED`, direction uniform over the directions within :data:`MAX_INCIDENCE`
of the inward normal, redrawn below :data:`MIN_NORMAL_SPEED` towards the face; incline angle uniform in
:data:`ANGLE`; ``e`` uniform in :data:`E_NOMINAL_RANGE` (nominal physics) or the training space (varied).

What the data show (``python -m benchmarks.skills_bounce_general``, docs/skills.md): ``v_across`` comes out
unchanged exactly (no friction), ``v_down`` gains ``g sin(incline_angle)`` times the contact's duration (~7 ms), and
``v_normal`` is reversed and scaled by ``e + beta (1 - e)`` with beta ~0.03, scattered by the arrival phase by
~0.01 in the effective restitution (~20 mm/s RMS).
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from .. import assets
from .. import hidden_physics as hp
from ..contact import solref_for_restitution
from .bounce import BOUNCE_STIFFNESS, bounce_scene
from .bounce_cond import bounce_cond_scene
from .common import DataSpec, progress

SPEED = (0.5, 6.0)                        # m/s: LaunchBounce's 1-3 m/s, and the vertical drops of today's bounce
SPEED_FAST = (0.5, 10.0)                  # m/s: bounce_general_fast's (balls falling through bouncing paddles)
MAX_INCIDENCE = math.radians(85.0)        # largest angle between the incoming velocity and the inward normal
MIN_NORMAL_SPEED = 0.1                    # m/s towards the face (slower, gravity rivals the contact)
ANGLE = (math.radians(10.0), math.radians(80.0))
WALL_ANGLE = (math.radians(80.0), math.radians(90.0))   # the wall skills': steep faces up to vertical walls
E_NOMINAL_RANGE = (0.8, 1.0)              # the existing bounce skill's range around the task wedge's 0.9487
E_NOMINAL = 0.9487                        # restitution_of_solref(assets.ELASTIC_SOLREF), rounded as in the docs
COND_PARAM = hp.INCLINE_RESTITUTION       # train [0.7, 0.9], test [0.4, 0.7) U (0.9, 0.99], nominal 0.8
COND_DOMAIN = COND_PARAM.hull()           # (0.4, 0.99): the conditioned model's domain
PHYSICS = ("nominal", "varied")
SKILL_OF_PHYSICS = {"nominal": "bounce_general", "varied": "bounce_general_cond"}
_V_RANGE = (-SPEED[1], SPEED[1])
_VN_RANGE = (-SPEED[1], -MIN_NORMAL_SPEED)
COLUMNS = ("v_down", "v_across", "v_normal")

DATA = DataSpec("bounce_general", ("e", "incline_angle") + COLUMNS, COLUMNS,
                ("", "rad", "m/s", "m/s", "m/s"), ("m/s", "m/s", "m/s"),
                (E_NOMINAL_RANGE, ANGLE, _V_RANGE, _V_RANGE, _VN_RANGE),
                "the ball arriving at a frictionless elastic incline from any direction into its face (the Bounce-v0 "
                "wedge contact, timestep 1 ms); velocities in the incline frame")
DATA_COND = DataSpec("bounce_general_cond", ("restitution", "incline_angle") + COLUMNS, COLUMNS,
                     ("", "rad", "m/s", "m/s", "m/s"), ("m/s", "m/s", "m/s"),
                     (COND_DOMAIN, ANGLE, _V_RANGE, _V_RANGE, _VN_RANGE),
                     "the ball arriving at a frictionless incline (the varied tasks' impact pair, timestep 0.5 ms) "
                     "from any direction into its face; restitution data from the training space; velocities in "
                     "the incline frame")


# The wall skills (``bounce_wall``, ``bounce_wall_cond``): the same scenes, contact and arrivals on faces tilted 80-90
# degrees (LaunchBounce's wedge has vertical back and side walls, which the general bounce's 10-80 degrees leave out).
DATA_WALL = DataSpec("bounce_wall", DATA.inputs, COLUMNS, DATA.input_units, DATA.output_units,
                     (E_NOMINAL_RANGE, WALL_ANGLE, _V_RANGE, _V_RANGE, _VN_RANGE),
                     "the ball arriving at a frictionless elastic face tilted 80-90 degrees (a wall; the Bounce-v0 "
                     "wedge contact, timestep 1 ms); velocities in the incline frame")
DATA_WALL_COND = DataSpec("bounce_wall_cond", DATA_COND.inputs, COLUMNS, DATA_COND.input_units,
                          DATA_COND.output_units, (COND_DOMAIN, WALL_ANGLE, _V_RANGE, _V_RANGE, _VN_RANGE),
                          "the ball arriving at a frictionless face tilted 80-90 degrees (a wall; the varied tasks' "
                          "impact pair, timestep 0.5 ms); restitution data from the training space")


def incline_basis(angle: float) -> np.ndarray:
    """Rows (down, across, normal) of the incline frame of a face tilted by ``angle`` that falls towards +x (the
    scenes' incline): ``normal = (sin a, 0, cos a)``, ``down = (cos a, 0, -sin a)``, ``across = (0, 1, 0)``."""
    s, c = math.sin(angle), math.cos(angle)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def check_physics(physics: str) -> str:
    if physics not in PHYSICS:
        raise ValueError(f"physics must be one of {PHYSICS}, got {physics!r}")
    return physics


class GeneralBounceScene:
    """The ball and a pitched incline box under one of the two physics (compiled once; angle and restitution are
    set per bounce)."""

    def __init__(self, physics: str = "nominal"):
        self.physics = check_physics(physics)
        if physics == "nominal":
            self.scene, self.incline = bounce_scene()
        else:
            self.scene = bounce_cond_scene()
            self.incline = self.scene.geom_id("incline")
        s = self.scene
        self.qpos = s.joint_qpos_adr("ball_free")
        self.dof = s.joint_dof_adr("ball_free")
        self.point = s.model.body_pos[s.model.geom_bodyid[self.incline]].copy()   # the impact point

    @property
    def timestep(self) -> float:
        return float(self.scene.model.opt.timestep)

    def set_incline(self, e: float, angle: float) -> None:
        m = self.scene.model
        m.body_quat[m.geom_bodyid[self.incline]] = (math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0)
        if self.physics == "nominal":
            m.geom_solref[self.incline] = solref_for_restitution(e, BOUNCE_STIFFNESS)
        else:
            hp.set_restitution(m, "ball_incline", e, hp.INCLINE_STIFFNESS)

    def bounce(self, e: float, angle: float, v_local, phase: float, gravity: bool = True) -> dict:
        """One arrival at the incline (module docstring). ``v_local``: the incoming velocity in the incline frame
        (``v_local[2] < 0``); ``phase`` in (0, 1): the arrival phase ``u``; ``gravity=False`` switches gravity off
        (for measuring what it does during the contact).

        Returns ``v_in``, ``v_out`` (incline frame), ``contact_s`` (duration) and ``slide`` (m the ball's centre
        moved along the face during the contact)."""
        v_local = np.asarray(v_local, dtype=float)
        if v_local.shape != (3,) or not np.all(np.isfinite(v_local)) or v_local[2] >= 0:
            raise ValueError(f"v_local must be 3 finite numbers with v_local[2] < 0 (into the face), got {v_local!r}")
        if not 0.0 < phase < 1.0:
            raise ValueError(f"phase must be in (0, 1), got {phase!r}")
        s = self.scene
        m, d = s.model, s.data
        self.set_incline(e, angle)
        m.opt.gravity[:] = (0.0, 0.0, -assets.GRAVITY if gravity else 0.0)
        basis = incline_basis(angle)
        normal = basis[2]
        dt = self.timestep
        v1 = basis.T @ v_local                                   # world velocity at the first touch
        v0 = v1 - m.opt.gravity * dt                             # one Euler step of free flight turns v0 into v1
        q1 = self.point + (assets.BALL_RADIUS - phase * abs(v_local[2]) * dt) * normal
        q0 = q1 - v1 * dt
        mujoco.mj_resetData(m, d)
        d.qpos[self.qpos:self.qpos + 7] = (*q0, 1.0, 0.0, 0.0, 0.0)
        d.qvel[self.dof:self.dof + 3] = v0
        mujoco.mj_forward(m, d)
        if d.ncon:
            raise RuntimeError("general bounce scene: the ball starts in contact")
        v_in = v_out = None
        k_in = 0
        for k in range(int(round(0.2 / dt))):
            before = d.qvel[self.dof:self.dof + 3].copy()
            p_before = d.qpos[self.qpos:self.qpos + 3].copy()
            mujoco.mj_step(m, d)
            # after mj_step, d.ncon holds the contacts of the state the step started from
            if v_in is None:
                if d.ncon:
                    v_in, k_in, p_in = before, k, p_before
                elif k > 0:
                    break
                continue
            if not d.ncon:
                v_out, p_out = before, p_before
                break
        if v_in is None or v_out is None or v_out @ normal <= 0:
            raise RuntimeError(f"general bounce scene ({self.physics}, e={e}, angle={angle}, v={v_local.tolist()}, "
                               f"phase={phase}): no clean bounce")
        m.opt.gravity[:] = (0.0, 0.0, -assets.GRAVITY)
        moved = p_out - p_in
        return {"v_in": basis @ v_in, "v_out": basis @ v_out, "contact_s": (k - k_in) * dt,
                "slide": float(np.linalg.norm(moved - (moved @ normal) * normal))}


def draw_velocity(rng: np.random.Generator, speed=SPEED) -> np.ndarray:
    """An incoming velocity in the incline frame: speed uniform in ``speed``, direction uniform within
    :data:`MAX_INCIDENCE` of the inward normal, redrawn while its normal speed is below :data:`MIN_NORMAL_SPEED`."""
    cmin = math.cos(MAX_INCIDENCE)
    while True:
        s = rng.uniform(*speed)
        c = rng.uniform(cmin, 1.0)
        psi = rng.uniform(0.0, 2.0 * math.pi)
        if s * c >= MIN_NORMAL_SPEED:
            r = s * math.sqrt(max(0.0, 1.0 - c * c))
            return np.array([r * math.cos(psi), r * math.sin(psi), -s * c])


def sample(n: int, rng: np.random.Generator, physics: str, restitution=None, angle=None, show: bool = False,
           velocity=None) -> tuple[np.ndarray, np.ndarray, dict]:
    """``n`` seeded arrivals under ``physics`` (``"nominal"`` or ``"varied"``).

    Per sample, in this order from ``rng``: the restitution (uniform in ``restitution`` (low, high), a fixed value
    if a number, ``restitution(rng)`` if callable; default the physics' data range), the incline angle (likewise,
    default :data:`ANGLE`), the incoming
    velocity (:func:`draw_velocity`, or ``velocity(rng)`` if given) and the arrival phase. Returns the inputs (N, 5),
    the outputs (N, 3) and extras ``contact_s``, ``slide``, ``phase``."""
    scene = GeneralBounceScene(physics)
    if restitution is None:
        restitution = E_NOMINAL_RANGE if physics == "nominal" else COND_PARAM.train
    angle = ANGLE if angle is None else angle
    x, y = np.empty((n, 5)), np.empty((n, 3))
    ex = {k: np.empty(n) for k in ("contact_s", "slide", "phase")}

    def draw(spec) -> float:
        if callable(spec):
            return float(spec(rng))
        return float(spec) if np.isscalar(spec) else float(rng.uniform(*spec))

    for i in progress(n, f"{SKILL_OF_PHYSICS[physics]} data", show):
        e, a = draw(restitution), draw(angle)
        v = draw_velocity(rng) if velocity is None else np.asarray(velocity(rng), dtype=float)
        u = min(max(rng.random(), 1e-3), 1.0 - 1e-3)
        r = scene.bounce(e, a, v, u)
        x[i] = (e, a, *r["v_in"])
        y[i] = r["v_out"]
        ex["contact_s"][i], ex["slide"][i], ex["phase"][i] = r["contact_s"], r["slide"], u
    return x, y, ex


def generate_samples(n: int, rng: np.random.Generator, show: bool) -> tuple[np.ndarray, np.ndarray, dict]:
    """``bounce_general`` data (nominal physics) for :func:`phyplan_envs.skill_scenes.generate`."""
    return sample(n, rng, "nominal", show=show)


def generate_samples_cond(n: int, rng: np.random.Generator, show: bool) -> tuple[np.ndarray, np.ndarray, dict]:
    """``bounce_general_cond`` data (varied physics, training-space restitution) for
    :func:`phyplan_envs.skill_scenes.generate`."""
    return sample(n, rng, "varied", show=show)


class _Cond:
    """The ``bounce_general_cond`` entry of :data:`phyplan_envs.skill_scenes.DATA_SPECS` (its data spec and
    generator, as a skill module has them)."""

    DATA = DATA_COND
    generate_samples = staticmethod(generate_samples_cond)


COND = _Cond


class _Wall:
    """``bounce_wall``: the nominal physics on faces of :data:`WALL_ANGLE`."""

    DATA = DATA_WALL

    @staticmethod
    def generate_samples(n: int, rng: np.random.Generator, show: bool):
        return sample(n, rng, "nominal", angle=WALL_ANGLE, show=show)


class _WallCond:
    """``bounce_wall_cond``: the varied physics (training-space restitution) on faces of :data:`WALL_ANGLE`."""

    DATA = DATA_WALL_COND

    @staticmethod
    def generate_samples(n: int, rng: np.random.Generator, show: bool):
        return sample(n, rng, "varied", angle=WALL_ANGLE, show=show)


WALL, WALL_COND = _Wall, _WallCond


# The fast general bounce (``bounce_general_fast``): the same scene, contact, angles and restitutions as
# ``bounce_general``, arrivals up to 10 m/s (a ball falling through bouncing paddles gains speed at every paddle).
DATA_FAST = DataSpec("bounce_general_fast", DATA.inputs, COLUMNS, DATA.input_units, DATA.output_units,
                     (E_NOMINAL_RANGE, ANGLE, (-SPEED_FAST[1], SPEED_FAST[1]), (-SPEED_FAST[1], SPEED_FAST[1]),
                      (-SPEED_FAST[1], -MIN_NORMAL_SPEED)),
                     "the ball arriving at a frictionless elastic incline from any direction into its face at up "
                     "to 10 m/s (the Bounce-v0 wedge contact, timestep 1 ms); velocities in the incline frame")


class _Fast:
    """``bounce_general_fast``: the nominal physics with speeds of :data:`SPEED_FAST`."""

    DATA = DATA_FAST

    @staticmethod
    def generate_samples(n: int, rng: np.random.Generator, show: bool):
        return sample(n, rng, "nominal", velocity=lambda r: draw_velocity(r, SPEED_FAST), show=show)


FAST = _Fast
