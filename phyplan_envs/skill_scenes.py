"""Skill-data scenes: seeded MuJoCo rollouts that record what each of the five PhyPlan skills predicts.

The skill models of :mod:`phyplan_agents.skills` learn from the data made here. Every scene is built from the same
pieces and constants as the tasks (:mod:`phyplan_envs.assets`: ``arena`` with its timestep, gravity and elliptic
friction cones, ``add_pendulum``, ``add_ball``, ``add_puck``, ``add_table``, ``add_pedestal``; the task files' start
positions and landing heights), so that a skill learnt here predicts what happens inside a task.

===========  =====================================  ===========================================================
skill        inputs -> outputs                      recorded from
===========  =====================================  ===========================================================
``swing``    (theta_init, t) -> (theta, omega)      the task pendulum released from rest at ``theta_init``
``slide``    (v_init, t) -> (x, v)                  the task puck launched along +x on the task table (mu 0.2)
``throw``    (v_hor, v_ver, t) -> (x, y, v_ver)     the task ball in free flight
``hit``      (m1, m2, v_init) -> (v,)               the task pendulum hitting the ball on the pedestal or the puck
                                                    on the table, with the bob mass and object mass varied
``bounce``   (e, wedge_angle, v_ver, v_hor)         the task ball hitting a frictionless elastic incline
             -> (v_ver, v_hor)
===========  =====================================  ===========================================================

Units: radians, metres, seconds, kilograms. Sign conventions (shared with the PhyPlan agent):

* all vertical quantities are up-positive; throw's ``y`` is the vertical displacement from the release point;
* swing's ``theta`` is the hinge angle from vertical (positive on the release side), ``omega = d theta / dt``
  (negative while the bob swings down towards the object); the bob's speed is ``|omega| * PENDULUM_LENGTH``;
* slide's ``x`` is the distance slid along the launch direction, ``v`` the velocity along it;
* bounce's ``v_hor`` and output ``v_hor`` are along the incline's downslope horizontal direction; the incoming
  ``v_ver`` is negative (falling).

Measured definitions that matter for chaining skills (see ``docs/skills.md``):

* **hit** outputs the *outcome-equivalent launch speed*: MuJoCo's bob contact is soft and lasts 50-80 ms, during which
  the object travels 5-15 cm with the bob, so the object's speed when it separates from the bob does not predict
  where it goes (measured in the tasks: the Launch ball lands as if launched 6-9 % faster than its separation speed,
  the Slide puck stops as if launched up to ~10 % faster). The
  recorded ``v`` is the speed that an instantaneous hit at the object's resting position would need to give the
  same outcome: for the ball, the landing distance at the Launch task's landing height divided by the ideal fall
  time from the pedestal top; for the puck, ``sqrt(2 mu g D)`` with D the distance from its start to where it
  stops and mu the deceleration measured on the same table (:func:`measured_slide_mu`). ``v_init`` is the bob's
  speed measured at the first bob-object contact. The physical separation speed is kept in ``extras``.
* **slide** records only the sliding phase (speed above ``SLIDE_END_SPEED``): the model continues the motion with
  constant deceleration beyond the stop, and a caller reads the stopping distance where ``v`` crosses 0.
* **bounce** records the ball's velocity just before the first contact with the incline and just after the contact
  ends (it lasts 5-15 ms); ``e`` is the nominal restitution of the incline's ``solref`` (:func:`solref_for_restitution`).
"""
from __future__ import annotations

from . import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

import functools
import math
from dataclasses import dataclass, field
from typing import Callable

import mujoco
import numpy as np

from . import assets
from .tasks.launch import BALL_START, LaunchEnv
from .tasks.slide import BOB_DZ, PUCK_START
from .tools import Pendulum

# --- domains (training ranges) -------------------------------------------------------------------------------------
# The tasks release the pendulum at theta in [pi/4, pi/2]; 0.1 rad of margin either side. The bob reaches the bottom
# after 0.28-0.33 s; t runs on to 0.6 s (past the bottom, up the other side).
SWING_THETA = (math.pi / 4 - 0.1, math.pi / 2 + 0.1)
SWING_T = (0.0, 0.6)
# The puck leaves the bob at an outcome-equivalent 1.35-2.75 m/s in the Slide task; slides last up to 1.63 s.
SLIDE_V = (0.8, 3.2)
SLIDE_T = (0.0, 1.7)
SLIDE_END_SPEED = 0.05    # m/s: the sliding phase ends (the puck's speed jitters by ~0.02 m/s while it slides)
# Launch: horizontal 1.3-2.8 m/s; Bounce: 0 (the free fall onto the wedge) and up to 4.8 m/s after the incline; falls
# last up to ~0.5 s (1.2 m drop). v_hor reaches below 0 so that the free fall (v_hor = 0) is not at the domain's edge,
# where the fit is weakest (measured: y 6-8 mm off at v_hor = 0 with the range starting at 0).
THROW_V_HOR = (-1.0, 6.0)
THROW_V_VER = (-3.0, 3.0)
THROW_T = (0.0, 1.0)
THROW_START_Z = 10.0      # m: high enough that the ball never meets the ground within THROW_T
# Hit: bob masses around the task's 0.5 kg; object masses around the ball (0.1 kg, on the pedestal) and the puck
# (0.05 kg, on the table), in two separate ranges (the two objects differ in shape and support, not only mass).
HIT_M1 = (0.4, 0.6)
HIT_M2_BALL = (0.08, 0.14)
HIT_M2_PUCK = (0.03, 0.065)
HIT_V = (1.0, 2.7)        # bob speed at impact: the tasks' theta range gives 1.31-2.43 m/s
HIT_PHI = (0.0, math.pi / 2)
# Bounce: restitution around the task wedge's ~0.95, incline angles around 45 degrees, drops of 0.2-1.5 m.
BOUNCE_E = (0.8, 1.0)
BOUNCE_ANGLE = (math.radians(30), math.radians(60))
BOUNCE_V_VER = (-5.5, -1.0)
BOUNCE_V_HOR = (-1.0, 1.0)
BOUNCE_MIN_APPROACH = 0.5    # m/s: least speed towards the incline (steep inclines outrun a fast downslope ball)
BOUNCE_STIFFNESS = 200000.0   # the K of assets.ELASTIC_SOLREF (notes/physics.md: the good default at dt 0.001)


@dataclass(frozen=True)
class SkillSpec:
    """What a skill maps from and to, in physical units, and the domain its data cover.

    Attributes:
        name: ``swing``, ``slide``, ``throw``, ``hit`` or ``bounce``.
        inputs, outputs: names, in order (the query time ``t`` is the last input of the time-parameterised skills).
        input_units, output_units: one unit string per name.
        ranges: (low, high) per input: the sampling domain of the data (and the models' normalisation).
        time_input: index of the time input, or ``None`` for the collision skills.
    """

    name: str
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    input_units: tuple[str, ...]
    output_units: tuple[str, ...]
    ranges: tuple[tuple[float, float], ...]
    time_input: int | None
    doc: str


SKILLS: dict[str, SkillSpec] = {
    "swing": SkillSpec("swing", ("theta_init", "t"), ("theta", "omega"), ("rad", "s"), ("rad", "rad/s"),
                       (SWING_THETA, SWING_T), 1, "the task pendulum released from rest"),
    "slide": SkillSpec("slide", ("v_init", "t"), ("x", "v"), ("m/s", "s"), ("m", "m/s"),
                       (SLIDE_V, SLIDE_T), 1, "the puck sliding on the task table (sliding phase only)"),
    "throw": SkillSpec("throw", ("v_hor", "v_ver", "t"), ("x", "y", "v_ver"), ("m/s", "m/s", "s"),
                       ("m", "m", "m/s"), (THROW_V_HOR, THROW_V_VER, THROW_T), 2, "the ball in free flight"),
    "hit": SkillSpec("hit", ("m1", "m2", "v_init"), ("v",), ("kg", "kg", "m/s"), ("m/s",),
                     (HIT_M1, (HIT_M2_PUCK[0], HIT_M2_BALL[1]), HIT_V), None,
                     "the pendulum bob (m1) hitting the ball (m2 in HIT_M2_BALL) or the puck (m2 in HIT_M2_PUCK)"),
    "bounce": SkillSpec("bounce", ("e", "wedge_angle", "v_ver", "v_hor"), ("v_ver", "v_hor"),
                        ("", "rad", "m/s", "m/s"), ("m/s", "m/s"),
                        (BOUNCE_E, BOUNCE_ANGLE, BOUNCE_V_VER, BOUNCE_V_HOR), None,
                        "the ball bouncing off a frictionless elastic incline"),
}

ALIASES = {"swinging": "swing", "sliding": "slide", "throwing": "throw", "hitting": "hit", "bouncing": "bounce"}


def skill_spec(name: str) -> SkillSpec:
    """The :class:`SkillSpec` of a skill name (``"slide"`` or ``"sliding"``, ...); a clear error for others."""
    key = ALIASES.get(str(name).lower(), str(name).lower())
    if key not in SKILLS:
        raise ValueError(f"unknown skill {name!r}; skills: {', '.join(SKILLS)} "
                         f"(or {', '.join(ALIASES)})")
    return SKILLS[key]


@dataclass
class SkillData:
    """A data set of one skill: ``inputs`` (N, n_in) and ``outputs`` (N, n_out), float64, physical units.

    ``extras`` holds further per-sample measurements (e.g. the hit's physical separation speed) that the skill
    models do not use. Row ``i`` is sample ``i`` of the seeded stream, so ``head(n)`` of a larger set is the set
    that ``generate(skill, n, seed)`` makes.
    """

    skill: str
    inputs: np.ndarray
    outputs: np.ndarray
    seed: int
    extras: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def spec(self) -> SkillSpec:
        return SKILLS[self.skill]

    def __len__(self) -> int:
        return int(self.inputs.shape[0])

    def head(self, n: int) -> "SkillData":
        """The first ``n`` samples."""
        if not 0 < n <= len(self):
            raise ValueError(f"head({n}): the {self.skill} set has {len(self)} samples")
        return SkillData(self.skill, self.inputs[:n].copy(), self.outputs[:n].copy(), self.seed,
                         {k: v[:n].copy() for k, v in self.extras.items()})


# ====================================================================================================== physics
def solref_for_restitution(e: float, stiffness: float = BOUNCE_STIFFNESS) -> tuple[float, float]:
    """MuJoCo's negative ``solref`` (-K, -D) for a contact of restitution ``e`` (notes/physics.md).

    ``D = 2 zeta sqrt(K)`` with ``zeta = -ln e / sqrt(pi^2 + ln^2 e)`` (a damped spring's bounce); e in (0, 1].
    ``assets.ELASTIC_SOLREF`` (-200000 -15) is e = 0.95 by this rule.
    """
    e = float(e)
    if not 0.0 < e <= 1.0:
        raise ValueError(f"restitution must be in (0, 1], got {e}")
    le = math.log(e)
    zeta = -le / math.sqrt(math.pi ** 2 + le * le)
    return (-float(stiffness), -2.0 * zeta * math.sqrt(stiffness))


def restitution_of_solref(solref) -> float:
    """The nominal restitution of a negative ``solref`` ("-K -D" string or a pair): the inverse of
    :func:`solref_for_restitution`. ``restitution_of_solref(assets.ELASTIC_SOLREF)`` is ~0.95."""
    if isinstance(solref, str):
        solref = [float(v) for v in solref.split()]
    k, dmp = -float(solref[0]), -float(solref[1])
    if k <= 0 or dmp < 0:
        raise ValueError(f"expected a negative solref (-K, -D) with K > 0, D >= 0; got {solref!r}")
    zeta = dmp / (2.0 * math.sqrt(k))
    if zeta >= 1.0:
        return 0.0
    return math.exp(-math.pi * zeta / math.sqrt(1.0 - zeta * zeta))


class _Scene:
    """A compiled skill scene with the named access that :class:`phyplan_envs.tools.Pendulum` uses."""

    def __init__(self, model: mujoco.MjModel):
        self.model = model
        self.data = mujoco.MjData(model)

    @classmethod
    def from_root(cls, root) -> "_Scene":
        return cls(mujoco.MjModel.from_xml_string(root.to_xml_string(), root.get_assets()))

    def _id(self, kind, name: str) -> int:
        i = mujoco.mj_name2id(self.model, kind, name)
        if i < 0:
            raise KeyError(f"no {kind.name} named {name!r} in the skill scene")
        return i

    def body_id(self, name: str) -> int:
        return self._id(mujoco.mjtObj.mjOBJ_BODY, name)

    def geom_id(self, name: str) -> int:
        return self._id(mujoco.mjtObj.mjOBJ_GEOM, name)

    def joint_qpos_adr(self, name: str) -> int:
        return int(self.model.jnt_qposadr[self._id(mujoco.mjtObj.mjOBJ_JOINT, name)])

    def joint_dof_adr(self, name: str) -> int:
        return int(self.model.jnt_dofadr[self._id(mujoco.mjtObj.mjOBJ_JOINT, name)])

    def set_body_pose(self, body: int, pos, yaw: float | None = None) -> None:
        self.model.body_pos[body] = pos
        if yaw is not None:
            self.model.body_quat[body] = assets.yaw_quat(yaw)

    def touching(self, g1: int, g2: int) -> bool:
        d = self.data
        for i in range(d.ncon):
            c = d.contact[i]
            if (c.geom1 == g1 and c.geom2 == g2) or (c.geom1 == g2 and c.geom2 == g1):
                return True
        return False


def _swing_scene() -> _Scene:
    root = assets.arena("skill_swing")
    assets.add_pendulum(root)
    return _Scene.from_root(root)


@functools.lru_cache(maxsize=None)
def pendulum_equivalent_length() -> float:
    """Length (m) of the simple pendulum that swings like the task's compound pendulum (rod + cube bob).

    ``l_eq = I / (m d)`` with I the arm's moment of inertia about the hinge (from MuJoCo's mass matrix), m its mass
    and d the hinge-to-centre-of-mass distance: 0.29948 m against the nominal 0.3 m (the 10 g rod and the cube's own
    inertia). The swing PINN's equation ``theta'' + (g / l) sin(theta) = 0`` uses this l.
    """
    s = _swing_scene()
    m, d = s.model, s.data
    mujoco.mj_forward(m, d)
    full = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, full)
    arm = s.body_id("pendulum_arm")
    dist = -float(m.body_ipos[arm][2])
    return float(full[0, 0] / (m.body_mass[arm] * dist))


def _slide_scene(friction: float = assets.TABLE_FRICTION) -> tuple[_Scene, np.ndarray]:
    """The puck on a long strip of the task table, settled at rest; returns the scene and its settled state."""
    root = assets.arena("skill_slide")
    assets.add_table(root, -0.3, 3.2, -0.4, 0.4, friction=friction)
    assets.add_puck(root)
    s = _Scene.from_root(root)
    m, d = s.model, s.data
    q = s.joint_qpos_adr("puck_free")
    d.qpos[q:q + 3] = (0.0, 0.0, PUCK_START[2])
    d.qpos[q + 3:q + 7] = (1, 0, 0, 0)
    mujoco.mj_step(m, d, nstep=300)   # settle into the soft contact (0.1 mm) before every launch
    d.qvel[:] = 0
    state = np.zeros(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_INTEGRATION))
    mujoco.mj_getState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)
    return s, state


def _slide_rollout(s: _Scene, state: np.ndarray, v0: float, t_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Launch the settled puck at ``v0`` along +x; record (x, v) every step while its speed is above
    ``SLIDE_END_SPEED`` (and at most ``t_max``). Row k is time k * TIMESTEP."""
    m, d = s.model, s.data
    mujoco.mj_setState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)
    q = s.joint_qpos_adr("puck_free")
    dv = s.joint_dof_adr("puck_free")
    x0 = d.qpos[q]
    d.qvel[dv] = v0
    n = int(round(t_max / m.opt.timestep))
    xs = np.empty(n + 1)
    vs = np.empty(n + 1)
    k = 0
    while True:
        xs[k] = d.qpos[q] - x0
        vs[k] = d.qvel[dv]
        if k == n:
            break
        mujoco.mj_step(m, d)
        vel = d.qvel[dv:dv + 3]
        if vel[0] * vel[0] + vel[1] * vel[1] + vel[2] * vel[2] < SLIDE_END_SPEED ** 2:
            break
        k += 1
    return xs[:k + 1], vs[:k + 1]


@functools.lru_cache(maxsize=None)
def measured_slide_mu() -> float:
    """The puck's effective friction coefficient on the task table: its measured deceleration / g.

    MuJoCo combines the two geoms' friction by maximum (both 0.2), but the soft contact makes the puck rock and
    chatter, so the deceleration is measured: a least-squares fit of ``x = v0 t - a t^2 / 2`` (v0 and a per launch,
    one shared a) to the sliding phase of launches at 1.0, 1.5, ..., 3.0 m/s. This is the "true" mu against which
    the slide PINN's estimate is scored (~0.1998).
    """
    s, state = _slide_scene()
    rows, rhs = [], []
    speeds = np.arange(1.0, 3.01, 0.5)
    for i, v0 in enumerate(speeds):
        x, _ = _slide_rollout(s, state, float(v0), SLIDE_T[1])
        t = np.arange(len(x)) * s.model.opt.timestep
        a = np.zeros((len(x), len(speeds) + 1))
        a[:, i] = t
        a[:, -1] = -0.5 * t * t
        rows.append(a)
        rhs.append(x)
    sol, *_ = np.linalg.lstsq(np.concatenate(rows), np.concatenate(rhs), rcond=None)
    return float(sol[-1] / assets.GRAVITY)


# ==================================================================================================== generators
def _progress(n: int, desc: str, enabled: bool):
    if not enabled:
        return range(n)
    from tqdm.auto import tqdm
    return tqdm(range(n), desc=desc, unit="sample", leave=False)


def _steps(t: float) -> int:
    return int(round(t / assets.TIMESTEP))


def _gen_swing(n: int, rng: np.random.Generator, progress: bool) -> tuple[np.ndarray, np.ndarray, dict]:
    s = _swing_scene()
    m, d = s.model, s.data
    hq = s.joint_qpos_adr("pendulum_hinge")
    hv = s.joint_dof_adr("pendulum_hinge")
    x = np.empty((n, 2))
    y = np.empty((n, 2))
    k_max = _steps(SWING_T[1])
    for i in _progress(n, "swing data", progress):
        th0 = rng.uniform(*SWING_THETA)
        k = int(rng.integers(0, k_max + 1))
        mujoco.mj_resetData(m, d)
        d.qpos[hq] = th0
        if k:
            mujoco.mj_step(m, d, nstep=k)
        x[i] = (th0, k * m.opt.timestep)
        y[i] = (d.qpos[hq], d.qvel[hv])
    return x, y, {}


def _gen_slide(n: int, rng: np.random.Generator, progress: bool) -> tuple[np.ndarray, np.ndarray, dict]:
    s, state = _slide_scene()
    x = np.empty((n, 2))
    y = np.empty((n, 2))
    t_end = np.empty(n)
    dt = s.model.opt.timestep
    for i in _progress(n, "slide data", progress):
        v0 = rng.uniform(*SLIDE_V)
        u = rng.random()
        xs, vs = _slide_rollout(s, state, v0, SLIDE_T[1])
        k = min(int(u * len(xs)), len(xs) - 1)      # a uniform time in the sliding phase
        x[i] = (v0, k * dt)
        y[i] = (xs[k], vs[k])
        t_end[i] = (len(xs) - 1) * dt
    return x, y, {"t_end": t_end}


def _gen_throw(n: int, rng: np.random.Generator, progress: bool) -> tuple[np.ndarray, np.ndarray, dict]:
    root = assets.arena("skill_throw")
    assets.add_ball(root)
    s = _Scene.from_root(root)
    m, d = s.model, s.data
    q = s.joint_qpos_adr("ball_free")
    dv = s.joint_dof_adr("ball_free")
    x = np.empty((n, 3))
    y = np.empty((n, 3))
    k_max = _steps(THROW_T[1])
    for i in _progress(n, "throw data", progress):
        vh = rng.uniform(*THROW_V_HOR)
        vv = rng.uniform(*THROW_V_VER)
        k = int(rng.integers(0, k_max + 1))
        mujoco.mj_resetData(m, d)
        d.qpos[q:q + 7] = (0, 0, THROW_START_Z, 1, 0, 0, 0)
        d.qvel[dv:dv + 3] = (vh, 0.0, vv)
        if k:
            mujoco.mj_step(m, d, nstep=k)
        if d.ncon:
            raise RuntimeError("the throw scene's ball touched something; THROW_START_Z is too low")
        x[i] = (vh, vv, k * m.opt.timestep)
        y[i] = (d.qpos[q], d.qpos[q + 2] - THROW_START_Z, d.qvel[dv + 2])
    return x, y, {}


# --- hit -------------------------------------------------------------------------------------------------------------
class _HitScene:
    """The pendulum rig aimed at the ball on the pedestal (Launch) or at the puck on the table (Slide)."""

    def __init__(self, obj: str):
        root = assets.arena(f"skill_hit_{obj}")
        if obj == "ball":
            assets.add_pedestal(root, BALL_START[:2])
            assets.add_ball(root)
            self.start, self.half, self.bob_dz = BALL_START.copy(), assets.BALL_RADIUS, 0.0
        else:
            assets.add_table(root, -0.3, 2.8, -0.3, 2.8)
            assets.add_puck(root)
            self.start, self.half, self.bob_dz = PUCK_START.copy(), assets.PUCK_RADIUS, BOB_DZ
        assets.add_pendulum(root)
        self.obj = obj
        self.spec = mujoco.MjSpec.from_string(root.to_xml_string(), assets=root.get_assets())

    def run(self, m1: float, m2: float, theta: float, phi: float) -> dict[str, float]:
        self.spec.geom("pendulum_bob").mass = m1
        self.spec.geom(f"{self.obj}_geom").mass = m2
        s = _Scene(self.spec.compile())
        m, d = s.model, s.data
        q = s.joint_qpos_adr(f"{self.obj}_free")
        dv = s.joint_dof_adr(f"{self.obj}_free")
        hv = s.joint_dof_adr("pendulum_hinge")
        bob, obj = s.geom_id("pendulum_bob"), s.geom_id(f"{self.obj}_geom")
        d.qpos[q:q + 3] = self.start
        d.qpos[q + 3:q + 7] = (1, 0, 0, 0)
        Pendulum(s).aim(self.start, phi, theta, self.half, self.bob_dz)
        mujoco.mj_forward(m, d)
        u = np.array([math.cos(phi), math.sin(phi)])
        max_steps = _steps(assets.MAX_SIM_TIME)
        v_bob = None
        contact_end = None
        v_sep = None
        prev = d.qpos[q:q + 3].copy()
        out = None
        for k in range(max_steps):
            w = d.qvel[hv]
            mujoco.mj_step(m, d)
            touching = s.touching(bob, obj)
            if v_bob is None:
                if touching:
                    v_bob = abs(w) * assets.PENDULUM_LENGTH
                    k_first = k
                continue
            if touching:
                contact_end = None
                continue
            if contact_end is None:
                contact_end = k
                v_sep = float(d.qvel[dv:dv + 2] @ u)
            pos = d.qpos[q:q + 3].copy()
            if self.obj == "ball":
                z_land = LaunchEnv.landing_height
                if pos[2] <= z_land < prev[2]:
                    f = (prev[2] - z_land) / (prev[2] - pos[2])
                    land = prev + f * (pos - prev)
                    reach = float((land[:2] - self.start[:2]) @ u)
                    fall = math.sqrt(2.0 * (self.start[2] - z_land) / assets.GRAVITY)
                    out = {"v": reach / fall, "distance": reach}
                    break
            elif k - contact_end > 20:
                vel = d.qvel[dv:dv + 3]
                if vel @ vel < 0.01 ** 2:
                    dist = float((pos[:2] - self.start[:2]) @ u)
                    out = {"v": math.sqrt(2.0 * measured_slide_mu() * assets.GRAVITY * max(dist, 0.0)),
                           "distance": dist}
                    break
            prev = pos
        if v_bob is None or out is None:
            raise RuntimeError(f"hit scene ({self.obj}, m1={m1}, m2={m2}, theta={theta}, phi={phi}): the "
                               f"{'bob never touched the object' if v_bob is None else 'object did not land/stop'}")
        out.update(v_bob=v_bob, v_sep=v_sep, contact_s=(contact_end - k_first) * m.opt.timestep)
        return out


def _gen_hit(n: int, rng: np.random.Generator, progress: bool) -> tuple[np.ndarray, np.ndarray, dict]:
    scenes = {"ball": _HitScene("ball"), "puck": _HitScene("puck")}
    l_eq = pendulum_equivalent_length()
    x = np.empty((n, 3))
    y = np.empty((n, 1))
    ex = {k: np.empty(n) for k in ("is_puck", "v_sep", "distance", "contact_s", "theta", "phi")}
    for i in _progress(n, "hit data", progress):
        obj = "puck" if rng.random() < 0.5 else "ball"
        m1 = rng.uniform(*HIT_M1)
        m2 = rng.uniform(*(HIT_M2_PUCK if obj == "puck" else HIT_M2_BALL))
        v_target = rng.uniform(*HIT_V)
        phi = rng.uniform(*HIT_PHI)
        # release angle whose ideal bottom speed is v_target; the recorded v_init is the measured bob speed
        theta = math.acos(1.0 - v_target ** 2 / (2.0 * assets.GRAVITY * l_eq))
        r = scenes[obj].run(m1, m2, theta, phi)
        x[i] = (m1, m2, r["v_bob"])
        y[i] = (r["v"],)
        for k, val in (("is_puck", float(obj == "puck")), ("v_sep", r["v_sep"]), ("distance", r["distance"]),
                       ("contact_s", r["contact_s"]), ("theta", theta), ("phi", phi)):
            ex[k][i] = val
    return x, y, ex


# --- bounce ----------------------------------------------------------------------------------------------------------
INCLINE_HALF = (0.2, 0.15, 0.05)   # half sizes of the incline box: 0.4 m along the slope, 0.3 m wide
INCLINE_POINT = np.array([0.0, 0.0, 1.0])   # where the ball meets the incline (high: nothing else within reach)


def _bounce_scene() -> tuple[_Scene, int]:
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
    s = _Scene.from_root(root)
    return s, s.geom_id("incline")


def _bounce_one(s: _Scene, incline: int, e: float, angle: float, v_ver: float, v_hor: float) -> dict[str, float]:
    m, d = s.model, s.data
    normal = np.array([math.sin(angle), 0.0, math.cos(angle)])   # the incline falls towards +x
    m.body_quat[m.geom_bodyid[incline]] = (math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0)
    m.geom_solref[incline] = solref_for_restitution(e)
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
    for k in range(_steps(0.5)):
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


def _gen_bounce(n: int, rng: np.random.Generator, progress: bool) -> tuple[np.ndarray, np.ndarray, dict]:
    s, incline = _bounce_scene()
    x = np.empty((n, 4))
    y = np.empty((n, 2))
    ex = {k: np.empty(n) for k in ("contact_s", "slide")}
    for i in _progress(n, "bounce data", progress):
        while True:   # redraw incoming velocities that would not meet the incline head-on enough
            e = rng.uniform(*BOUNCE_E)
            angle = rng.uniform(*BOUNCE_ANGLE)
            v_ver = rng.uniform(*BOUNCE_V_VER)
            v_hor = rng.uniform(*BOUNCE_V_HOR)
            if -(v_hor * math.sin(angle) + v_ver * math.cos(angle)) >= BOUNCE_MIN_APPROACH:
                break
        r = _bounce_one(s, incline, e, angle, v_ver, v_hor)
        x[i] = (e, angle, r["v_in"][2], r["v_in"][0])
        y[i] = (r["v_out"][2], r["v_out"][0])
        ex["contact_s"][i] = r["contact_s"]
        ex["slide"][i] = r["slide"]
    return x, y, ex


_GENERATORS: dict[str, Callable] = {"swing": _gen_swing, "slide": _gen_slide, "throw": _gen_throw,
                                    "hit": _gen_hit, "bounce": _gen_bounce}


def generate(skill: str, n: int, seed: int, progress: bool = False) -> SkillData:
    """``n`` samples of ``skill`` from seeded MuJoCo rollouts (deterministic in ``seed``).

    Each sample is one rollout with initial conditions drawn uniformly from the skill's ranges (see
    :data:`SKILLS`) and, for the time-parameterised skills, one query time drawn uniformly (on the 1 ms timestep
    grid) from the time range (slide: from its sliding phase). Row i depends only on (seed, i), so a smaller set is a
    prefix of a larger one with the same seed.

    Costs on one idle core (measured): swing, throw and bounce ~1 ms a sample, slide ~9 ms, hit ~20 ms.
    """
    spec = skill_spec(skill)
    if int(n) != n or n < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
    rng = np.random.default_rng([int(seed), _SKILL_SALT[spec.name]])
    x, y, extras = _GENERATORS[spec.name](int(n), rng, progress)
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise RuntimeError(f"{spec.name} data has non-finite values (seed {seed})")
    return SkillData(spec.name, x, y, int(seed), extras)


# distinct random streams per skill for the same seed
_SKILL_SALT = {"swing": 11, "slide": 12, "throw": 13, "hit": 14, "bounce": 15}

