"""The Franka Panda in every phyplan scene: a visual-only arm, posed by inverse kinematics to hold the tool.

The arm is built from the MJCF fragments and meshes that ``gymnasium-robotics`` ships
(``gymnasium_robotics/envs/assets/kitchen_franka/franka_assets/``: ``assets.xml``, ``chain.xml``, ``meshes/``;
Apache-2.0, originally vikashplus/franka). Two models are made from them:

* the **scene copy**, attached to a task's MJCF root by :func:`attach_panda`: the visual meshes only (collision
  meshes and the finger collision capsules are dropped), every geom ``contype=conaffinity=0`` in geom group
  :data:`PANDA_GEOM_GROUP` (4; the env's observation camera hides that group), and **no joints, no actuators and no
  link bodies**: the geoms sit flat on the one attachment frame at the base. It therefore adds no degree of
  freedom, no contact and no actuator to the task's physics, and one static body. The arm is posed kinematically:
  each geom's ``model.geom_pos``/``geom_quat`` is set to its link's frame (forward kinematics of the IK model below
  at joint angles q) composed with the geom's rest pose in that link. (Keeping the 11 link bodies and writing their
  ``body_quat`` works too, but static bodies cost MuJoCo more per step than static geoms.) Moving geoms inside a
  body leaves MuJoCo's per-body bounding-volume tree (built at compile time) stale, so these geoms must stay
  collision-free and invisible to ``mj_ray``; they are, and nothing in phyplan casts rays.
* the **IK model** (:func:`ik_model`, one per process): the same kinematic chain *with* its 7 arm joints and limits,
  no geoms and no fingers, on which `mink <https://github.com/kevinzakka/mink>`_ solves for the joint angles that put
  the grasp site (between the finger pads) at a world point with a given hand orientation.

The env base calls ``attach_panda(root, base_pos, base_yaw)`` while building the scene, ``handle.bind(physics)`` after
compiling it and ``handle.pose_for(env, action)`` before drawing a frame. ``pose_for`` holds the point
``env.hand_target(action)``; the hand orientation is chosen by :func:`grasp_candidates` (perpendicular to a pendulum
rod, so the fingers close on the bob's side faces; otherwise top-down), and the fingers close to
``env.grip_half_width`` (m, default :data:`DEFAULT_GRIP_HALF_WIDTH`, the pendulum bob) when an action is given and
are wide open before any attempt. A task may override the orientation with a method ``hand_axes(action)`` returning
world ``(approach, closing)`` vectors. IK results are cached per process, keyed by the target (rounded to 0.1 mm)
and orientation in the Panda's base frame, so repeated renders of the same pose cost one dictionary look-up.

Modules (every public name is re-exported here, so ``from phyplan_envs.panda import X`` is the stable import):

* :mod:`~phyplan_envs.panda.model`: locating the Franka assets; the scene copy and the IK chain; the arm's facts.
* :mod:`~phyplan_envs.panda.grasp`: grasp frames and the candidate hand orientations (pure geometry).
* :mod:`~phyplan_envs.panda.ik`: the one IK module (mink): :class:`PandaIK` and the per-process solver
  :func:`shared_ik` for the posed arm, ``ArmIK`` for robot mode's arm, on a shared chain, residuals and mink problem.
* :mod:`~phyplan_envs.panda.posing`: :func:`attach_panda` and :class:`PandaHandle` (bind, pose, ``pose_for``).

An articulated Panda (jointed and actuated, to execute an attempt) belongs in a module of its own beside these
(``robot.py``); the visual copy above stays what the default scenes use. ``python -m benchmarks.panda_speed``
measures the stepping rate of every task with and without the Panda (figures in ``docs/panda.md``).
"""
from __future__ import annotations

from .grasp import grasp_candidates, grasp_rotation
from .ik import (HOME_Q, IK_ACCEPT_ORI, IK_ACCEPT_POS, IK_CACHE_SIZE, IK_MAX_ITERS, IK_ORI_TOL, IK_POS_TOL,
                 IK_SOLVER, IKSolution, PandaIK, shared_ik)
from .model import (ARM_JOINTS, ARM_LINKS, ARM_RGBA, DEFAULT_GRIP_HALF_WIDTH, FINGER_BODIES, FINGER_CLEARANCE,
                    FINGER_OPEN, FRANKA_SUBDIR, GRASP_DEPTH, GRASP_QUAT, GRASP_SITE, HAND_LINK, HAND_RGBA,
                    PANDA_GEOM_GROUP, PANDA_SITE_GROUP, SHOULDER_HEIGHT, franka_assets_dir, ik_model, panda_mjcf)
from .posing import PandaHandle, attach_panda

__all__ = [
    # model
    "FRANKA_SUBDIR", "ARM_LINKS", "ARM_JOINTS", "FINGER_BODIES", "HAND_LINK", "GRASP_SITE", "PANDA_GEOM_GROUP",
    "PANDA_SITE_GROUP", "GRASP_DEPTH", "GRASP_QUAT", "SHOULDER_HEIGHT", "FINGER_OPEN", "FINGER_CLEARANCE",
    "DEFAULT_GRIP_HALF_WIDTH", "ARM_RGBA", "HAND_RGBA", "franka_assets_dir", "ik_model", "panda_mjcf",
    # grasp
    "grasp_rotation", "grasp_candidates",
    # ik
    "HOME_Q", "IK_SOLVER", "IK_MAX_ITERS", "IK_POS_TOL", "IK_ORI_TOL", "IK_ACCEPT_POS", "IK_ACCEPT_ORI",
    "IK_CACHE_SIZE", "IKSolution", "PandaIK", "shared_ik",
    # posing
    "PandaHandle", "attach_panda",
]
