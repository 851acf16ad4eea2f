"""The declarative description of a task's scene for a batch of actions: what is where after the set-up.

``env.describe(actions)`` (:meth:`phyplan_envs.base.PhyPlanEnv.describe`) returns a :class:`SceneDescription` for
``actions`` of shape ``(N, A)``: the moving object, what sets it moving (a :class:`Striker` that hits it, or a
:class:`Release` that lets it go at rest), the :class:`Support` tops it can rest or slide on, the :class:`Face` s it
can bounce off, the :class:`Obstacle` s it can run into, the landing height and the end rule. Every tool of the
task describes its own part (``Tool.describe``); arrays with a leading ``N`` axis are per action, the rest are
constants. It is a statement of facts (geometry, masses, contact properties), computed in closed form without
stepping the simulation: it says nothing about how objects move, which is what a planner's models are for.

A physical property the task hides (a varied task's hidden physics, :mod:`phyplan_envs.hidden_physics`) is given by
the *name* of its hidden parameter (a ``str``) instead of a value: e.g. ``striker.bob_mass == "bob_mass"``.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Union

import numpy as np

Value = Union[float, str]          # a fact's value, or the name of the hidden parameter that holds it


@dataclass
class MovingObject:
    """The object whose end position is scored. ``shape``: ``"ball"`` or ``"puck"``; ``start``: its centre at rest
    (3,); ``radius``: the ball's radius or the puck's half-size in the plane; ``half_height``: the centre's height
    above what it rests on; ``mass`` (kg)."""

    name: str
    shape: str
    start: np.ndarray
    radius: float
    half_height: float
    mass: float


@dataclass
class Striker:
    """A pendulum that swings from rest at ``release`` (N,) rad from vertical in the vertical plane ``plane`` (N,)
    rad from +x, and hits ``target`` at the bottom of its arc along ``plane``. ``length`` (m) from pivot to bob
    centre; ``bob_mass`` (kg); ``restitution`` of the bob-object contact (``None``: the task's fixed contact)."""

    target: str
    plane: np.ndarray
    release: np.ndarray
    length: float
    bob_mass: Value
    restitution: Value | None = None


@dataclass
class Release:
    """The object is let go at rest with its centre at ``pos`` (N, 3)."""

    target: str
    pos: np.ndarray


@dataclass
class Support:
    """A horizontal top at height ``top`` (m) that an object can rest or slide on: ``shape`` ``"disc"`` (``centre``,
    ``radius``) or ``"rect"`` (``centre``, ``half`` (2,) half extents along its own x and y, turned by ``yaw``).
    ``centre`` is (2,) or (N, 2), ``yaw`` a float or (N,). ``friction``: sliding friction (0: frictionless)."""

    name: str
    shape: str
    centre: np.ndarray
    top: float
    friction: Value
    radius: float = 0.0
    half: np.ndarray = field(default_factory=lambda: np.zeros(2))
    yaw: float | np.ndarray = 0.0


@dataclass
class Face:
    """A planar face an object bounces off: the convex polygon ``vertices`` (N, k, 3) (or (k, 3)) with outward unit
    ``normal`` (N, 3) (or (3,)); ``restitution`` of the contact, ``friction`` (0: frictionless) and the ``tool`` it
    belongs to. ``contact``: the contact's model, ``"solref"`` (the geom's own soft contact, ``ELASTIC_SOLREF`` at
    a 1 ms timestep: Bounce-v0's wedge) or ``"impact_pair"`` (a pair whose damping is calibrated to
    ``restitution`` at the task's timestep: :mod:`phyplan_envs.hidden_physics`) or ``"exact_impact"`` (Newton's law
    resolved inside the timestep, hops ending in a glide: :mod:`phyplan_envs.hidden_physics.impacts`), where a rebound
    slower than ``glide_speed`` (m/s) is no bounce: the object stays on the face and glides."""

    name: str
    tool: str
    vertices: np.ndarray
    normal: np.ndarray
    restitution: Value
    friction: float = 0.0
    contact: str = "solref"
    glide_speed: float = 0.0


@dataclass
class Obstacle:
    """A solid upright block the moving object can run into: a box from height ``bottom`` to ``top`` (m) over the
    rectangle ``centre`` (2,), ``half`` (2,) half extents along its own x and y, turned by ``yaw`` (rad). The
    contact is ``restitution`` (0: it keeps none of the normal speed) and frictionless; ``tool`` is the tool it
    belongs to (e.g. the pedestal's column under its top)."""

    name: str
    tool: str
    centre: np.ndarray
    half: np.ndarray
    bottom: float
    top: float
    restitution: float = 0.0
    yaw: float = 0.0


@dataclass
class SceneDescription:
    """A task's scene for ``n`` actions (module docstring). ``end_rule``: ``"landed"`` (the object's centre falls
    below ``landing_height``) or ``"rest"`` (it stops); either way the attempt also ends when it lands."""

    n: int
    object: MovingObject
    striker: Striker | None = None
    release: Release | None = None
    supports: list[Support] = field(default_factory=list)
    faces: list[Face] = field(default_factory=list)
    obstacles: list[Obstacle] = field(default_factory=list)
    landing_height: float = 0.0
    end_rule: str = "landed"

    def add(self, part) -> None:
        """Add a tool's part (one of the classes above, or a list of them)."""
        if isinstance(part, (list, tuple)):
            for p in part:
                self.add(p)
        elif isinstance(part, MovingObject):
            self.object = part
        elif isinstance(part, Striker):
            self.striker = part
        elif isinstance(part, Release):
            self.release = part
        elif isinstance(part, Support):
            self.supports.append(part)
        elif isinstance(part, Face):
            self.faces.append(part)
        elif isinstance(part, Obstacle):
            self.obstacles.append(part)
        elif part is not None:
            raise TypeError(f"not a scene part: {type(part).__name__}")

    def hidden_parameters(self) -> tuple[str, ...]:
        """The names of the hidden parameters the description refers to (empty for a nominal task)."""
        names = []
        for v in self._values():
            if isinstance(v, str) and v not in names:
                names.append(v)
        return tuple(names)

    def _values(self):
        if self.striker is not None:
            yield self.striker.bob_mass
            yield self.striker.restitution
        for s in self.supports:
            yield s.friction
        for f in self.faces:
            yield f.restitution


def yaw_rotation(yaw) -> np.ndarray:
    """Rotation matrices (N, 3, 3) (or (3, 3)) about +z by ``yaw``."""
    yaw = np.asarray(yaw, dtype=np.float64)
    c, s = np.cos(yaw), np.sin(yaw)
    z, o = np.zeros_like(yaw), np.ones_like(yaw)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def prism_faces(name: str, pos: np.ndarray, yaw: np.ndarray, half: float, angle: float, base_z: float,
                restitution: Value, contact: str = "solref") -> list[Face]:
    """The faces of a wedge (a triangular prism on a square base of half edge ``half``, incline ``angle`` falling
    towards local +x, ridge at local x = -half) whose axis stands at ``pos`` (N, 3) turned by ``yaw`` (N,), base at
    height ``base_z`` above ``pos``: the incline, the back wall and the two sides (the bottom stands on its
    support)."""
    h, top = half, 2 * half * np.tan(angle)
    local = {
        "incline": ([(-h, -h, top), (h, -h, 0), (h, h, 0), (-h, h, top)], (np.sin(angle), 0.0, np.cos(angle))),
        "back": ([(-h, -h, 0), (-h, -h, top), (-h, h, top), (-h, h, 0)], (-1.0, 0.0, 0.0)),
        "side_a": ([(-h, -h, 0), (h, -h, 0), (-h, -h, top)], (0.0, -1.0, 0.0)),
        "side_b": ([(-h, h, 0), (-h, h, top), (h, h, 0)], (0.0, 1.0, 0.0)),
    }
    rot = yaw_rotation(yaw)                                     # (N, 3, 3)
    offset = np.asarray(pos, dtype=np.float64) + np.array([0.0, 0.0, base_z])
    faces = []
    for face, (verts, normal) in local.items():
        v = np.einsum("nij,kj->nki", rot, np.asarray(verts, dtype=np.float64)) + offset[:, None, :]
        nrm = np.einsum("nij,j->ni", rot, np.asarray(normal, dtype=np.float64))
        faces.append(Face(f"{name}_{face}", name, v, nrm, restitution, contact=contact))
    return faces
