"""The block puck: the puck as a square block that faces the swing plane, and the contacts it slides on.

Used by the puck tasks' later versions (``PhyPlan/Bridge-v1``, ``SlideVaried-v1``, ``BridgeVaried-v1``) and by the
conditioned skills' data scenes. MuJoCo collides a cylinder (the v0 disc) with a box or a cylinder through its
general convex collider, whose contact points jitter as the disc slides: outcomes moved by centimetres when the
timestep halved, and a few per cent of Bridge-v0 landings move by more than 1 cm when the action moves by 1e-8 rad.
A box on a box (and a sphere or box on a box) has an exact collider: the block is turned to slide along a face
normal (:func:`turn_free_body`), and the static supports whose edges it crosses (a launch pad, a round table's
top) collide as boxes turned with it (:func:`turn_body`, :func:`add_square_top`).
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from . import assets

BLOCK_HALF = assets.PUCK_RADIUS * math.sqrt(math.pi) / 2   # the square block of the disc's footprint (17.7 mm)
FRICTION_REFERENCE = (0.05, 1.0)   # solreffriction of the block's friction pairs (see add_friction_pair)


def make_block(root, geom: str = "puck_geom") -> None:
    """Turn the disc puck into the block: a box of half edge :data:`BLOCK_HALF` (the disc's footprint area, the
    same thickness and mass).

    MuJoCo collides a cylinder with a box through its general convex collider, whose contact points jitter as the
    disc slides: its stops moved up to 15 mm when the timestep halved. A box on a box (and a sphere on a box) has an
    exact collider; the block, turned to slide along a face normal, stops within 0.5 mm of the same point at both
    timesteps and of the Coulomb stop ``v^2 / (2 mu g)``.
    """
    g = root.find("geom", geom)
    g.type = "box"
    g.size = (BLOCK_HALF, BLOCK_HALF, assets.PUCK_HALF_HEIGHT)


def add_friction_pair(root, geom1: str, geom2: str, name: str, friction: float, soft_reference: bool = False) -> None:
    """A frictional ``<pair>`` (condim 3) of sliding friction ``friction`` (a varied task sets it per context,
    :func:`phyplan_envs.hidden_physics.set_friction`); its solref (0.005, 1) is stiffer than MuJoCo's default, so a
    pushed puck hops less.

    ``soft_reference`` (the block): the friction dimensions get their own, slower reference (``solreffriction``
    :data:`FRICTION_REFERENCE`). With the normal's fast reference, a sliding contact's friction residual is large
    and MuJoCo's elliptic cone turns part of it into normal force: the sliding block hops (up to ~3 mm at 4 m/s) and
    the hops depend on the timestep. With the slow one the hops are sub-millimetre and converge in the timestep, and
    over a long slide the deceleration is ``friction * g``; over a table only a hop or two long it is not (figures:
    ``python -m benchmarks.design_checks.hidden_physics --only friction``, docs/hidden-physics.md)."""
    extra = {"solreffriction": FRICTION_REFERENCE} if soft_reference else {}
    root.contact.add("pair", name=name, geom1=geom1, geom2=geom2, condim=3,
                     friction=(friction, friction, 0.005, 0.0001, 0.0001), solref=(0.005, 1), **extra)


def add_square_top(root, geom: str, half: float, **contact) -> None:
    """Let a round table top ``geom`` collide as a square of half edge ``half`` (its body turned with the block,
    :func:`turn_body`): along the block's path from the table centre the square's rim is the disc's rim. The
    cylinder stays as the (non-colliding) visual, renamed ``<geom>_visual``; the invisible box takes its name and
    position; ``contact`` holds its collision bits (and friction)."""
    visual = root.find("geom", geom)
    visual.name = f"{geom}_visual"
    visual.contype = visual.conaffinity = 0
    body = visual.parent
    body.add("geom", name=geom, type="box", size=(half, half, visual.size[1]), pos=visual.pos, rgba=(0, 0, 0, 0),
             **contact)


def turn_body(model: mujoco.MjModel, body: int, yaw: float) -> None:
    """Set a static body's yaw in the compiled model (takes effect at the next ``mj_forward``/``mj_step``)."""
    model.body_quat[body] = assets.yaw_quat(yaw)


def turn_free_body(qpos: np.ndarray, adr: int, yaw: float) -> None:
    """Turn a free joint's orientation (at qpos[adr + 3 : adr + 7]) by ``yaw`` about the world z axis."""
    turned = np.empty(4)
    mujoco.mju_mulQuat(turned, assets.yaw_quat(yaw), qpos[adr + 3:adr + 7])
    qpos[adr + 3:adr + 7] = turned
