"""The pendulum rig: swung from a release angle, its bob hits an object at rest (Launch, Slide, Bridge).

:class:`Pendulum` is named access to a rig built by :func:`phyplan_envs.assets.add_pendulum` in any scene with
``body_id``/``joint_qpos_adr``/``set_body_pose`` (a task's :class:`~phyplan_envs.scene.Scene`, a skill scene);
:class:`PendulumRig` is the task tool: it builds the rig, applies the action dimensions :data:`PENDULUM_DIMS`
(``phi``, ``theta``) and, in robot mode, has the arm lift the bob along its arc.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import assets
from ..description import Striker
from ..spaces import ActionDim
from .tool import Tool

PENDULUM_DIMS = (
    ActionDim("phi", 0.0, math.pi / 2, "rad", "pendulum plane angle (direction of the hit)"),
    ActionDim("theta", math.pi / 4, math.pi / 2, "rad", "release angle of the pendulum from vertical"),
)
"""The action dimensions of the pendulum: the swing plane (direction of the hit) and the release angle."""
REST_PHI = math.pi / 4          # the swing plane of the resting pendulum between attempts


@dataclass(frozen=True)
class PendulumFacts:
    """The pendulum rig's physical facts (m, kg), part of the facts of every task that swings it.

    Attributes:
        pendulum_length: pivot to bob centre (the nominal length; the compound rod + cube swings like a simple
            pendulum 0.2995 m long, see :func:`phyplan_envs.skill_scenes.pendulum_equivalent_length`).
        bob_mass: mass of the cube bob.
        bob_dz: height of the bob's centre at the bottom of its arc relative to the object's centre.
    """

    pendulum_length: float = assets.PENDULUM_LENGTH
    bob_mass: float = assets.BOB_MASS
    bob_dz: float = 0.0


class Pendulum:
    """Named access to a pendulum rig built by :func:`phyplan_envs.assets.add_pendulum` in ``scene``.

    ``aim(object_pos, phi, theta, object_half, bob_dz)`` puts the rig so that, released from angle ``theta``
    (radians from vertical), the bob reaches the bottom of its arc just behind the object and pushes it along the
    horizontal direction ``phi`` (radians from +x).
    """

    def __init__(self, scene, name: str = "pendulum"):
        self.scene = scene
        self.rig = scene.body_id(name)
        self.hinge = scene.joint_qpos_adr(f"{name}_hinge")

    def aim(self, object_pos, phi: float, theta: float, object_half: float, bob_dz: float = 0.0) -> None:
        u = np.array([math.cos(phi), math.sin(phi)])
        back = assets.BOB_HALF + object_half + assets.HIT_GAP
        pivot = (object_pos[0] - back * u[0], object_pos[1] - back * u[1],
                 object_pos[2] + bob_dz + assets.PENDULUM_LENGTH)
        self.scene.set_body_pose(self.rig, pivot, yaw=phi)
        self.scene.data.qpos[self.hinge] = theta

    def pivot(self) -> np.ndarray:
        return self.scene.model.body_pos[self.rig].copy()

    def bob_world_pos(self, phi: float, theta: float) -> np.ndarray:
        """Where the bob centre is when held at ``theta`` (before release): what the Panda's hand holds."""
        p = self.pivot()
        u = np.array([math.cos(phi), math.sin(phi), 0.0])
        return p + assets.PENDULUM_LENGTH * (-math.sin(theta) * u + np.array([0, 0, -math.cos(theta)]))


class PendulumRig(Pendulum, Tool):
    """The pendulum that hits ``target`` (a :class:`~phyplan_envs.tools.Ball` or :class:`~phyplan_envs.tools.Puck`
    at rest at its ``start``; its ``half`` is its half-size along the hit) with the bob's centre ``bob_dz`` above
    the target's at the bottom of the arc. Between attempts it hangs at rest in the plane ``rest_phi``. After
    ``bind`` it has :class:`Pendulum`'s named access (``rig``, ``hinge``, ``aim``, ``pivot``, ...) and
    ``hinge_dof``.

    ``plane``: a fixed swing plane (rad from +x): the rig's only action dimension is then ``theta``, in
    ``theta_range`` (default :data:`PENDULUM_DIMS`' range), and it rests in that plane; by default it applies
    ``phi`` and ``theta``."""

    dims = PENDULUM_DIMS
    robot_bodies = ("pendulum_arm",)    # robot mode: the arm grasps the bob (its body holds rod and bob)

    def __init__(self, target, bob_dz: float = 0.0, bob_mass: float = assets.BOB_MASS, rest_phi: float = REST_PHI,
                 name: str = "pendulum", plane: float | None = None, theta_range: tuple[float, float] | None = None):
        self.target, self.bob_dz, self.bob_mass, self.rest_phi, self.name = target, bob_dz, bob_mass, rest_phi, name
        self.plane = None if plane is None else float(plane)
        if plane is not None or theta_range is not None:
            phi, theta = PENDULUM_DIMS
            lo, hi = theta_range if theta_range is not None else (theta.low, theta.high)
            theta = ActionDim(theta.name, float(lo), float(hi), theta.unit, theta.doc)
            self.dims = (theta,) if plane is not None else (phi, theta)
        if plane is not None:
            self.rest_phi = self.plane

    def _phi_theta(self, values) -> tuple[float, float]:
        """The swing plane and release angle of the rig's action values."""
        if self.plane is not None:
            return self.plane, float(values[0])
        return float(values[0]), float(values[1])

    def build(self, root) -> None:
        assets.add_pendulum(root, name=self.name, bob_mass=self.bob_mass)

    def bind(self, scene) -> None:
        Tool.bind(self, scene)
        Pendulum.__init__(self, scene, self.name)
        self.hinge_dof = scene.joint_dof_adr(f"{self.name}_hinge")

    # --- state -------------------------------------------------------------------------------------------------------
    def aim_at_target(self, phi: float, theta: float, half: float | None = None) -> None:
        """The rig aimed at the target's start (clearing ``half``, default the target's) in plane ``phi``, at
        ``theta``."""
        t = self.target
        self.aim(t.start, phi, theta, t.half if half is None else half, self.bob_dz)

    def hinge_angle(self) -> float:
        """The hinge's angle now (rad from vertical; the release angle before the swing)."""
        return float(self.scene.data.qpos[self.hinge])

    def hinge_speed(self) -> float:
        """The hinge's angular speed now (rad/s; negative while the bob swings down towards the target)."""
        return float(self.scene.data.qvel[self.hinge_dof])

    def place(self, phi: float, theta: float) -> None:
        """Put the target at rest at its start and the pendulum at release angle ``theta`` in plane ``phi``."""
        self.target.rest(phi)
        self.aim_at_target(phi, theta)

    # --- the tool ----------------------------------------------------------------------------------------------------
    def reset(self) -> None:
        self.place(self.rest_phi, 0.0)   # hanging at rest behind the object: a fixed pose per context

    def apply(self, values) -> None:
        self.place(*self._phi_theta(values))

    def robot_steps(self, values) -> list:
        """Robot mode: the target at rest and the rig set up in the plane ``phi`` with the bob hanging (placed
        directly, as in the kinematic mode); the arm grasps the bob, lifts it along its arc to ``theta`` and lets go
        (:func:`phyplan_envs.panda.robot.plans.pendulum_carry`)."""
        from ..panda.robot.plans import pendulum_carry

        phi, theta = self._phi_theta(values)
        self.target.rest(phi)
        self.aim_at_target(phi, 0.0)
        return [pendulum_carry(lambda t: self.bob_world_pos(phi, t), phi, theta, assets.PENDULUM_LENGTH,
                               assets.BOB_HALF)]

    def describe(self, values):
        if self.plane is not None:
            plane, theta = np.full(len(values), self.plane), values[:, 0].copy()
        else:
            plane, theta = values[:, 0].copy(), values[:, 1].copy()
        return Striker(self.target.name, plane, theta, assets.PENDULUM_LENGTH, self.bob_mass)

    # --- the visual Panda ------------------------------------------------------------------------------------------
    def hand_target(self, values) -> np.ndarray:
        """The bob at its release angle; before an attempt (``values`` None), 10 cm above the resting bob."""
        if values is None:
            self.place(self.rest_phi, 0.0)
            return self.bob_world_pos(self.rest_phi, 0.0) + (0.0, 0.0, 0.1)
        phi, theta = self._phi_theta(values)
        self.aim_at_target(phi, theta)
        return self.bob_world_pos(phi, theta)
