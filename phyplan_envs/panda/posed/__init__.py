"""The posed visual arm: the Panda of the kinematic mode, a visual-only copy posed by inverse kinematics.

The arm is built from the MJCF fragments and meshes that ``gymnasium-robotics`` ships
(``gymnasium_robotics/envs/assets/kitchen_franka/franka_assets/``: ``assets.xml``, ``chain.xml``, ``meshes/``;
Apache-2.0, originally vikashplus/franka). The posed arm uses two models made from them:

* the **scene copy**, attached to a task's MJCF root by :func:`attach_panda`: the visual meshes only (collision meshes
  and the finger collision capsules are dropped), every geom ``contype=conaffinity=0`` in geom group
  :data:`~phyplan_envs.panda.model.PANDA_GEOM_GROUP` (4; the env's observation camera hides that group), and **no
  joints, no actuators and no link bodies**: the geoms sit flat on the one attachment frame at the base. It therefore
  adds no degree of freedom, no contact and no actuator to the task's physics, and one static body. The arm is posed
  kinematically: each geom's ``model.geom_pos``/``geom_quat`` is set to its link's frame (forward kinematics of the IK
  model below at joint angles q) composed with the geom's rest pose in that link. (Keeping the 11 link bodies and
  writing their ``body_quat`` works too, but static bodies cost MuJoCo more per step than static geoms.) Moving geoms
  inside a body leaves MuJoCo's per-body bounding-volume tree (built at compile time) stale, so these geoms must stay
  collision-free and invisible to ``mj_ray``; they are, and nothing in phyplan casts rays.
* the **IK model** (:func:`phyplan_envs.panda.model.ik_model`, one per process, shared with robot mode's IK): the
  same kinematic chain *with* its 7 arm joints and limits, no geoms and no fingers, on which
  `mink <https://github.com/kevinzakka/mink>`_ solves for the joint angles that put the grasp site (between the
  finger pads) at a world point with a given hand orientation (:class:`phyplan_envs.panda.ik.PandaIK`).

The env base calls ``attach_panda(root, base_pos, base_yaw)`` while building the scene, ``handle.bind(physics)`` after
compiling it and ``handle.pose_for(env, action)`` before drawing a frame. ``pose_for`` holds the point
``env.hand_target(action)``; the hand orientation is chosen by :func:`grasp_candidates` (perpendicular to a pendulum
rod, so the fingers close on the bob's side faces; otherwise top-down), and the fingers close to ``env.grip_half_width``
(m, default :data:`~phyplan_envs.panda.model.DEFAULT_GRIP_HALF_WIDTH`, the pendulum bob) when an action is given and are
wide open before any attempt. A task may override the orientation with a method ``hand_axes(action)`` returning world
``(approach, closing)`` vectors. IK results are cached per process, keyed by the target (rounded to 0.1 mm) and
orientation in the Panda's base frame, so repeated renders of the same pose cost one dictionary look-up.

Modules (their public names are re-exported by :mod:`phyplan_envs.panda`, the stable import):

* :mod:`~phyplan_envs.panda.posed.scene_copy`: the scene copy's MJCF (:func:`panda_mjcf`).
* :mod:`~phyplan_envs.panda.posed.candidates`: the candidate hand orientations (:func:`grasp_candidates`).
* :mod:`~phyplan_envs.panda.posed.posing`: :func:`attach_panda` and :class:`PandaHandle` (bind, pose, ``pose_for``).
"""
from __future__ import annotations

from .candidates import grasp_candidates
from .posing import PandaHandle, attach_panda
from .scene_copy import panda_mjcf

__all__ = ["PandaHandle", "attach_panda", "grasp_candidates", "panda_mjcf"]
