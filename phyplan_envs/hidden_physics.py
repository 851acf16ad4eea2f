"""Hidden physics of the varied tasks: the parameters, their train/test spaces, and the contacts that obey them.

A varied task (``PhyPlan/<Task>Varied-vN``) draws, per context, physical parameters that the agent never sees:

==============  =====================  ==========  ================  ===============================  ============
parameter       tasks                  nominal     train space       test space                       sampling
==============  =====================  ==========  ================  ===============================  ============
``bob_mass``    slide, bridge          0.5 kg      [0.3, 1.0]        [0.1, 0.3) U (1.0, 6.0]          log-uniform
``bob_mass``    launch                 0.5 kg      [0.3, 1.0]        [0.05, 0.3) U (1.0, 3.0]         log-uniform
``restitution`` launch, slide, bridge  0.5         [0.35, 0.65]      [0.05, 0.35) U (0.65, 0.95]      uniform
``friction``    slide, bridge          0.35        [0.25, 0.45]      [0.15, 0.25) U (0.45, 0.6]       uniform
``restitution`` bounce                 0.8         [0.7, 0.9]        [0.4, 0.7) U (0.9, 0.99]         uniform
==============  =====================  ==========  ================  ===============================  ============

``bob_mass`` is the pendulum bob's mass; ``restitution`` that of the bob-object contact (pendulum tasks) or of the
ball-incline contact (Bounce); ``friction`` the sliding friction of the puck on the table top and the bridge plank.
The two spaces are disjoint and the test space is wider (CausalWorld's spaces A and B): contexts of the ``test``
split (:mod:`phyplan_envs.splits`) draw from the test space, ``train`` and ``dev`` contexts from the train space.

How the contacts obey the parameters (``docs``: the varied tasks' docstrings; measured by
``python -m benchmarks.design_checks.hidden_physics``):

* restitution: a ``<pair>`` with MuJoCo's negative ``solref`` (-K, -D) and a constant impedance
  (``solimp = (IMPEDANCE, IMPEDANCE, ...)``), so the contact is a linear spring-damper whose bounce does not depend
  on the impact speed or the masses. D is *calibrated*: the damping for which two spheres started exactly touching
  separate with relative speed ratio e at the task's timestep (:func:`calibrated_damping`). The closed form of
  :mod:`phyplan_envs.contact` ignores that a contact never pulls and the time discretisation (set 0.2 gave 0.29).
* friction: a ``<pair>`` with ``friction = (mu, mu, 0.005, 1e-4, 1e-4)`` (condim 3).
* bob mass: the bob is its own body (a welded child of the pendulum arm) whose mass and (isotropic) inertia are set
  in the compiled model (:func:`set_bob_mass`).

A context's values are a function of an integer key and the space's name (:func:`values_of_key`). The context
holds neither: its ``physics_token`` is the pair sealed under the process's secret (:func:`seal_token`,
:data:`phyplan_envs.spaces.SECRET_ENV`), which an env holding the same secret opens (:func:`open_token`), so
``reset(options={"context": ...})`` replays a context exactly while the context, the observation and ``info`` hold
no value and no key. No public function returns the secret; the threat model is in docs/hidden-physics.md.
"""
from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import Any, Mapping

import mujoco
import numpy as np

from . import assets
from .spaces import seal, unseal
from .splits import split_of

SPACES = ("train", "test")
KEY_BOUND = 2 ** 63            # physics keys are integers in [0, KEY_BOUND)
IMPEDANCE = 0.99               # constant solimp of the impact pairs: a linear contact (no impedance ramp)
BOB_STIFFNESS = 1.0e5          # K of the bob-object pair: half-period pi/sqrt(K) ~ 10 ms
INCLINE_STIFFNESS = 2.0e5      # K of the ball-incline pair: ~7 ms, the ball sinks < 1 cm into the incline
PAD_THICK = 0.001              # the frictionless launch pad under the puck (Slide, Bridge)
PAD_RISE = 0.0005              # pad top above the table top
PAD_RADIUS = 0.045             # the puck (r 0.02) leaves the pad ~1.5 cm after the bob lets go of it
PAD_BODY = "launch_pad_body"   # v1: the square pad's body, turned to the swing plane with the block
BOB_BODY = "pendulum_bob_body"
BOB_COLLIDER = "pendulum_bob_collider"


@dataclass(frozen=True)
class HiddenParameter:
    """One hidden physical parameter: its nominal value, train space and (two-part) test space.

    Attributes:
        name, unit, doc: what it is.
        nominal: the value an agent that ignores the hidden physics should assume (inside ``train``).
        train: (low, high) of the training space.
        test: ((low, high), (low, high)): the test space, below and above ``train`` (disjoint from it).
        log: sample log-uniformly (masses) instead of uniformly.
    """

    name: str
    unit: str
    doc: str
    nominal: float
    train: tuple[float, float]
    test: tuple[tuple[float, float], tuple[float, float]]
    log: bool = False

    def intervals(self, space: str) -> tuple[tuple[float, float], ...]:
        check_space(space)
        return (self.train,) if space == "train" else self.test

    def hull(self) -> tuple[float, float]:
        return (self.test[0][0], self.test[1][1])

    def sample(self, rng: np.random.Generator, space: str) -> float:
        """A value from ``space``: uniform (or log-uniform) over the union of its intervals."""
        f = np.log if self.log else (lambda x: x)
        parts = [(float(f(lo)), float(f(hi))) for lo, hi in self.intervals(space)]
        lengths = np.array([hi - lo for lo, hi in parts])
        u = rng.random() * lengths.sum()
        for (lo, hi), n in zip(parts, lengths):
            if u <= n:
                x = lo + u
                return float(math.exp(x) if self.log else x)
            u -= n
        lo, hi = parts[-1]
        return float(math.exp(hi) if self.log else hi)

    def in_space(self, value: float, space: str) -> bool:
        return any(lo <= value <= hi for lo, hi in self.intervals(space))


BOB_MASS = HiddenParameter("bob_mass", "kg", "mass of the pendulum bob", 0.5, (0.3, 1.0),
                           ((0.1, 0.3), (1.0, 6.0)), log=True)
# Launch's test masses reach down to the original code's 0.05 kg: with the ball (0.1 kg) the mass effect saturates
# above ~1 kg, and heavy bobs with low restitution cancel (the nominal-physics planner's regret stayed < 0.10).
LAUNCH_BOB_MASS = dataclasses.replace(BOB_MASS, test=((0.05, 0.3), (1.0, 3.0)))
BOB_RESTITUTION = HiddenParameter("restitution", "", "restitution of the bob-object contact", 0.5, (0.35, 0.65),
                                  ((0.05, 0.35), (0.65, 0.95)))
FRICTION = HiddenParameter("friction", "", "sliding friction of the puck on the table and the plank", 0.35,
                           (0.25, 0.45), ((0.15, 0.25), (0.45, 0.6)))
INCLINE_RESTITUTION = HiddenParameter("restitution", "", "restitution of the ball-incline contact", 0.8, (0.7, 0.9),
                                      ((0.4, 0.7), (0.9, 0.99)))

PARAMETERS: dict[str, tuple[HiddenParameter, ...]] = {
    "launch": (LAUNCH_BOB_MASS, BOB_RESTITUTION),
    "slide": (BOB_MASS, BOB_RESTITUTION, FRICTION),
    "bounce": (INCLINE_RESTITUTION,),
    "bridge": (BOB_MASS, BOB_RESTITUTION, FRICTION),
}
"""Base task name -> its hidden parameters (in the order they are drawn)."""


# ================================================================================================ spaces and keys
def check_space(space: str) -> str:
    if space not in SPACES:
        raise ValueError(f"physics space must be one of {SPACES}, got {space!r}")
    return space


def parameters(task: str) -> tuple[HiddenParameter, ...]:
    """The hidden parameters of a base task name (``"launch"``, ...; a ``"-varied"`` suffix is accepted)."""
    base = task[:-len("-varied")] if task.endswith("-varied") else task
    if base not in PARAMETERS:
        raise ValueError(f"no hidden physics for task {task!r}; tasks: {', '.join(PARAMETERS)}")
    return PARAMETERS[base]


def nominal(task: str) -> dict[str, float]:
    """The nominal values of a task's hidden parameters (what an agent ignoring them should assume)."""
    return {p.name: p.nominal for p in parameters(task)}


def space_of_seed(seed: int) -> str:
    """The physics space that a context seed draws from: ``"test"`` for the test split, else ``"train"``."""
    return "test" if split_of(int(seed)) == "test" else "train"


def draw(task: str, space: str, rng: np.random.Generator) -> dict[str, float]:
    """One context's hidden values for ``task`` drawn from ``space`` with ``rng`` (each parameter independently)."""
    check_space(space)
    return {p.name: p.sample(rng, space) for p in parameters(task)}


def values_of_key(task: str, key: int, space: str) -> dict[str, float]:
    """The hidden values that ``physics_key`` ``key`` stands for in ``space`` (deterministic)."""
    check_key(key)
    return draw(task, space, np.random.default_rng(np.random.SeedSequence(int(key))))


def check_key(key: Any) -> int:
    if isinstance(key, bool) or not isinstance(key, (int, np.integer)) or not 0 <= int(key) < KEY_BOUND:
        raise ValueError(f"a physics key must be an integer in [0, 2**63), got {key!r}")
    return int(key)


TOKEN_ENTRY = "options['context']['physics_token']"


def _label(task: str) -> str:
    """The base task name a token is sealed for (``SlideVaried-v0`` and ``-v1`` share their contexts)."""
    parameters(task)
    return "physics:" + (task[:-len("-varied")] if task.endswith("-varied") else task)


def seal_token(task: str, key: int, space: str, secret: bytes) -> str:
    """A context's ``physics_token``: ``(key, space)`` sealed under ``secret`` for ``task`` (deterministic)."""
    return seal(check_key(key).to_bytes(8, "big") + bytes([SPACES.index(check_space(space))]), _label(task), secret)


def open_token(task: str, token: Any, secret: bytes) -> tuple[int, str]:
    """``(key, space)`` of a :func:`seal_token` token; raises naming ``options['context']['physics_token']`` for a
    token that is not one or that another secret or task sealed."""
    payload = unseal(token, _label(task), secret, 9, TOKEN_ENTRY)   # authenticated: only seal_token made it
    return int.from_bytes(payload[:8], "big"), SPACES[payload[8]]


def check_values(task: str, values: Mapping[str, Any]) -> dict[str, float]:
    """``values`` validated: exactly the task's parameter names, finite, inside the hull of the two spaces."""
    if not isinstance(values, Mapping):
        raise ValueError(f"options['physics'] must be a dict of {[p.name for p in parameters(task)]}, "
                         f"got {values!r}")
    names = [p.name for p in parameters(task)]
    if sorted(values) != sorted(names):
        raise ValueError(f"options['physics'] must have exactly the keys {names}, got {sorted(values)}")
    out = {}
    for p in parameters(task):
        v = values[p.name]
        lo, hi = p.hull()
        if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) or not lo <= v <= hi:
            raise ValueError(f"options['physics'][{p.name!r}] must be a number in [{lo}, {hi}], got {v!r}")
        out[p.name] = float(v)
    return out


# ========================================================================================================= contacts
@functools.lru_cache(maxsize=None)
def _two_spheres(timestep: float) -> tuple[mujoco.MjModel, mujoco.MjData]:
    xml = f"""<mujoco><option timestep="{timestep!r}" gravity="0 0 0" integrator="Euler"/><worldbody>
      <body name="a"><freejoint/><geom name="a" type="sphere" size="0.02" mass="0.1"/></body>
      <body name="b" pos="0.04 0 0"><freejoint/><geom name="b" type="sphere" size="0.02" mass="0.1"/></body>
      </worldbody><contact><pair name="p" geom1="a" geom2="b" condim="1" solref="-1 -1"
      solimp="{IMPEDANCE} {IMPEDANCE} 0.001 0.5 2"/></contact></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    return m, mujoco.MjData(m)


def measured_restitution(stiffness: float, damping: float, timestep: float, speed: float = 1.0) -> float:
    """The restitution MuJoCo produces for an impact pair (-stiffness, -damping) at ``timestep``: two free spheres
    started exactly touching, approaching at ``speed``; the ratio of separation to approach speed."""
    m, d = _two_spheres(float(timestep))
    m.pair_solref[0] = (-stiffness, -damping)
    mujoco.mj_resetData(m, d)
    d.qpos[7] = 0.04 - 1e-9
    d.qvel[0], d.qvel[6] = speed / 2, -speed / 2
    for _ in range(int(1.0 / timestep)):
        mujoco.mj_step(m, d)
        if d.qpos[7] - d.qpos[0] > 0.04:
            return float((d.qvel[6] - d.qvel[0]) / speed)
    raise RuntimeError(f"impact pair (-{stiffness}, -{damping}) at dt {timestep}: the spheres did not separate")


@functools.lru_cache(maxsize=4096)
def calibrated_damping(restitution: float, stiffness: float, timestep: float) -> float:
    """The damping D whose pair (-stiffness, -D) gives ``restitution`` at ``timestep`` (bisection to 1e-6 in e)."""
    e = float(restitution)
    if not 0.0 < e < 1.0:
        raise ValueError(f"restitution must be in (0, 1), got {restitution!r}")
    lo, hi = 0.0, 4.0 * math.sqrt(stiffness)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if measured_restitution(stiffness, mid, timestep) > e:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-9 * math.sqrt(stiffness):
            break
    return 0.5 * (lo + hi)


def impact_solref(restitution: float, stiffness: float, timestep: float) -> tuple[float, float]:
    """The negative ``solref`` (-K, -D) of an impact pair of the given restitution (calibrated at ``timestep``)."""
    return (-float(stiffness), -calibrated_damping(float(restitution), float(stiffness), float(timestep)))


def add_impact_pair(root, geom1: str, geom2: str, name: str, restitution: float, stiffness: float) -> None:
    """An elastic, frictionless ``<pair>`` between two geoms (restitution set per context by
    :func:`set_restitution`). Call after the timestep of ``root`` is set."""
    root.contact.add("pair", name=name, geom1=geom1, geom2=geom2, condim=1, friction=(0, 0, 0, 0, 0),
                     solref=impact_solref(restitution, stiffness, float(root.option.timestep)),
                     solimp=(IMPEDANCE, IMPEDANCE, 0.001, 0.5, 2))


def _pair(model: mujoco.MjModel, name: str) -> int:
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_PAIR, name)
    if i < 0:
        raise KeyError(f"no contact pair named {name!r} in the model")
    return i


def set_restitution(model: mujoco.MjModel, pair: str, restitution: float, stiffness: float) -> None:
    """Set the restitution of an impact pair of a compiled model (calibrated at the model's timestep)."""
    model.pair_solref[_pair(model, pair)] = impact_solref(restitution, stiffness, float(model.opt.timestep))


def set_friction(model: mujoco.MjModel, pair: str, friction: float) -> None:
    """Set the sliding friction of a friction pair of a compiled model."""
    i = _pair(model, pair)
    model.pair_friction[i, 0] = model.pair_friction[i, 1] = float(friction)


# ================================================================================================== the pendulum
def separate_bob(root, name: str = "pendulum", mass: float = assets.BOB_MASS) -> None:
    """Make the pendulum's bob its own body (welded to the arm), colliding through a sphere.

    The cube stays as the visual (massless, colliding with nothing); a child body of the arm at the bob's centre
    carries the bob's mass with the cube's (isotropic) inertia and a sphere collider of the cube's half edge, named
    :data:`BOB_COLLIDER`. Against a ball or the side of a puck a sphere's contact normal is the line between the
    centres, horizontal at the bottom of the arc; the cube's face tilts with the arm during the ~10 ms contact and
    lifts the object.
    """
    cube = root.find("geom", f"{name}_bob")
    cube.mass = 0
    cube.contype = cube.conaffinity = 0
    arm = root.find("body", f"{name}_arm")
    bob = arm.add("body", name=BOB_BODY, pos=(0, 0, -assets.PENDULUM_LENGTH))
    i = _cube_inertia(mass)
    bob.add("inertial", pos=(0, 0, 0), mass=mass, diaginertia=(i, i, i))
    bob.add("geom", name=BOB_COLLIDER, type="sphere", size=(assets.BOB_HALF,), mass=0, rgba=(0, 0, 0, 0),
            priority=2, condim=1, friction=(0, 0, 0), **assets.BOB)


def _cube_inertia(mass: float) -> float:
    return 2.0 / 3.0 * mass * assets.BOB_HALF ** 2


def set_bob_mass(model: mujoco.MjModel, data: mujoco.MjData, mass: float) -> None:
    """Set the bob's mass (and inertia) in a model built with :func:`separate_bob`; recomputes MuJoCo's derived
    constants (``mj_setConst``: the contact softness uses the bodies' inverse weights)."""
    b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, BOB_BODY)
    if b < 0:
        raise KeyError(f"no body {BOB_BODY!r}: build the pendulum with hidden_physics.separate_bob")
    model.body_mass[b] = float(mass)
    model.body_inertia[b] = _cube_inertia(float(mass))
    mujoco.mj_setConst(model, data)


def pendulum_constants(model: mujoco.MjModel, bob_mass: float | None = None,
                       name: str = "pendulum") -> tuple[float, float]:
    """``(m g d, I)`` of the pendulum about its hinge: mass x gravity x hinge-to-centre-of-mass distance, and the
    moment of inertia about the hinge axis (arm and bob bodies; rod along the arm's -z, hinge axis y), with the
    model's bob mass or ``bob_mass``."""
    arm = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"{name}_arm")
    bob = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, BOB_BODY)
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, model.body_iquat[arm])
    rot = rot.reshape(3, 3)
    i_arm = (rot @ np.diag(model.body_inertia[arm]) @ rot.T)[1, 1]
    m_a, z_a = model.body_mass[arm], model.body_ipos[arm]
    m_b = float(model.body_mass[bob] if bob_mass is None else bob_mass)
    z_b = model.body_pos[bob] + model.body_ipos[bob]
    inertia = (i_arm + m_a * (z_a[0] ** 2 + z_a[2] ** 2) + _cube_inertia(m_b)
               + m_b * (z_b[0] ** 2 + z_b[2] ** 2))
    mgd = -(m_a * z_a[2] + m_b * z_b[2]) * -model.opt.gravity[2]
    return float(mgd), float(inertia)


def swing_speed(model: mujoco.MjModel, theta_release: float, theta: float) -> float:
    """The hinge's angular speed at angle ``theta`` after release from rest at ``theta_release`` (energy
    conservation of the frictionless compound pendulum)."""
    mgd, inertia = pendulum_constants(model)
    return math.sqrt(max(0.0, 2.0 * mgd * (math.cos(theta) - math.cos(theta_release)) / inertia))


def add_launch_pad(root, xy, table_top: float, name: str = "launch_pad", square: bool = False) -> float:
    """A thin frictionless disc under the puck's start, ``PAD_RISE`` above the table top; returns its top height.

    The bob's push (~10 ms) happens on the pad; the puck then drops ``PAD_RISE`` onto the table and slides. Pushed
    on the frictional table itself, MuJoCo's soft friction cone lifts the puck (hops of 2-10 mm) and the outcome
    jumps by centimetres between timesteps.

    ``square`` (the v1 varied tasks): a square pad of half edge ``PAD_RADIUS`` in its own static body
    (:data:`PAD_BODY`), turned with the block to the swing plane (:func:`phyplan_envs.block.turn_body`), so that the block leaves it
    ``PAD_RADIUS`` from its start along its path, as from the disc, through box-box contacts only.
    """
    top = table_top + PAD_RISE
    if square:
        body = root.worldbody.add("body", name=PAD_BODY, pos=(xy[0], xy[1], 0.0))
        body.add("geom", name=name, type="box", size=(PAD_RADIUS, PAD_RADIUS, PAD_THICK / 2),
                 pos=(0.0, 0.0, top - PAD_THICK / 2), rgba=(0.55, 0.55, 0.6, 1), priority=1, condim=1,
                 friction=(0, 0, 0), **assets.WORLD)
        return top
    root.worldbody.add("geom", name=name, type="cylinder", size=(PAD_RADIUS, PAD_THICK / 2),
                       pos=(xy[0], xy[1], top - PAD_THICK / 2), rgba=(0.55, 0.55, 0.6, 1), priority=1, condim=1,
                       friction=(0, 0, 0), **assets.WORLD)
    return top
