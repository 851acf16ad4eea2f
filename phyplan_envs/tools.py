"""Tools that tasks share: the pendulum rig placed and released around a resting object, and its facts."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import assets


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
    """Named access to a pendulum rig built by :func:`phyplan_envs.assets.add_pendulum`.

    ``aim(object_pos, phi, theta, object_half, bob_dz)`` puts the rig so that, released from angle ``theta``
    (radians from vertical), the bob reaches the bottom of its arc just behind the object and pushes it along the
    horizontal direction ``phi`` (radians from +x).
    """

    def __init__(self, env, name: str = "pendulum"):
        self.env = env
        self.rig = env.body_id(name)
        self.hinge = env.joint_qpos_adr(f"{name}_hinge")

    def aim(self, object_pos, phi: float, theta: float, object_half: float, bob_dz: float = 0.0) -> None:
        u = np.array([math.cos(phi), math.sin(phi)])
        back = assets.BOB_HALF + object_half + assets.HIT_GAP
        pivot = (object_pos[0] - back * u[0], object_pos[1] - back * u[1],
                 object_pos[2] + bob_dz + assets.PENDULUM_LENGTH)
        self.env.set_body_pose(self.rig, pivot, yaw=phi)
        self.env.data.qpos[self.hinge] = theta

    def pivot(self) -> np.ndarray:
        return self.env.model.body_pos[self.rig].copy()

    def bob_world_pos(self, phi: float, theta: float) -> np.ndarray:
        """Where the bob centre is when held at ``theta`` (before release): what the Panda's hand holds."""
        p = self.pivot()
        u = np.array([math.cos(phi), math.sin(phi), 0.0])
        return p + assets.PENDULUM_LENGTH * (-math.sin(theta) * u + np.array([0, 0, -math.cos(theta)]))


class PendulumHitMixin:
    """Shared by the tasks in which the pendulum hits an object at rest (Launch, Slide, Bridge).

    A task declares where the object rests (``object_start``), its half-size along the hit (``object_half``), the
    bob's height offset (``bob_dz``) and the swing plane of the resting pendulum between attempts (``rest_phi``);
    the first two action dimensions are ``(phi, theta)``. Tasks with more tools extend ``reset_scene`` and
    ``apply_action`` and call these.
    """

    object_start: np.ndarray
    object_half: float
    bob_dz: float = 0.0
    rest_phi: float = math.pi / 4
    robot_bodies = ("pendulum_arm",)    # robot mode: the arm grasps the bob (its body holds rod and bob)

    @property
    def pendulum(self) -> Pendulum:
        if getattr(self, "_pendulum", None) is None:
            self._pendulum = Pendulum(self)
        return self._pendulum

    def place_pendulum(self, phi: float, theta: float) -> None:
        """Put the object at rest at its start and the pendulum at release angle ``theta`` in plane ``phi``."""
        self.set_object_pose(self.object_start)
        self.pendulum.aim(self.object_start, phi, theta, self.object_half, self.bob_dz)

    def reset_scene(self, context) -> None:
        self.place_pendulum(self.rest_phi, 0.0)   # hanging at rest behind the object: a fixed pose per context

    def apply_action(self, action) -> None:
        self.place_pendulum(action[0], action[1])

    def robot_plan(self, action) -> list:
        """Robot mode: the rig is set up in the plane ``phi`` with the bob hanging (placed directly, as in the
        kinematic mode); the arm grasps the bob, lifts it along its arc to ``theta`` and lets go
        (:func:`phyplan_envs.panda.plans.pendulum_carry`)."""
        from .panda.plans import pendulum_carry

        phi, theta = float(action[0]), float(action[1])
        self.pendulum.aim(self.object_start, phi, 0.0, self.object_half, self.bob_dz)
        return [pendulum_carry(lambda t: self.pendulum.bob_world_pos(phi, t), phi, theta, assets.PENDULUM_LENGTH,
                               assets.BOB_HALF)]

    def hand_target(self, action) -> np.ndarray:
        """The bob at its release angle; before an attempt, 10 cm above the resting bob."""
        if action is None:
            self.place_pendulum(self.rest_phi, 0.0)
            return self.pendulum.bob_world_pos(self.rest_phi, 0.0) + (0.0, 0.0, 0.1)
        self.pendulum.aim(self.object_start, action[0], action[1], self.object_half, self.bob_dz)
        return self.pendulum.bob_world_pos(action[0], action[1])
