"""The MuJoCo side of the hidden physics: the contacts that obey the parameters (impact pairs of calibrated
restitution, friction pairs), the bob as its own body of settable mass, the pendulum's closed-form swing, and the
puck's frictionless launch pad (the module docstring of :mod:`phyplan_envs.hidden_physics` says how)."""
from __future__ import annotations

import functools
import math

import mujoco
import numpy as np

from .. import assets

IMPEDANCE = 0.99               # constant solimp of the impact pairs: a linear contact (no impedance ramp)
BOB_STIFFNESS = 1.0e5          # K of the bob-object pair: half-period pi/sqrt(K) ~ 10 ms
INCLINE_STIFFNESS = 2.0e5      # K of the ball-incline pair: ~7 ms, the ball sinks < 1 cm into the incline
PAD_THICK = 0.001              # the frictionless launch pad under the puck (Slide, Bridge)
PAD_RISE = 0.0005              # pad top above the table top
PAD_RADIUS = 0.045             # the puck (r 0.02) leaves the pad ~1.5 cm after the bob lets go of it
PAD_BODY = "launch_pad_body"   # v1: the square pad's body, turned to the swing plane with the block
BOB_BODY = "pendulum_bob_body"
BOB_COLLIDER = "pendulum_bob_collider"


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
    (:data:`PAD_BODY`), turned with the block to the swing plane (:func:`phyplan_envs.block.turn_body`), so that the
    block leaves it ``PAD_RADIUS`` from its start along its path, as from the disc, through box-box contacts only.
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
