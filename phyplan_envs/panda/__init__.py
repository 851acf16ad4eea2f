"""The Franka Panda in every phyplan scene, in two ideas: the posed visual arm and robot mode's articulated arm.

Both are built from the MJCF fragments and meshes that ``gymnasium-robotics`` ships
(``gymnasium_robotics/envs/assets/kitchen_franka/franka_assets/``: ``assets.xml``, ``chain.xml``, ``meshes/``;
Apache-2.0, originally vikashplus/franka).

* :mod:`phyplan_envs.panda.posed`: the **posed visual arm** of the kinematic mode (``robot=None``, the default):
  a visual-only copy of the Panda in the task scene (no joints, no actuators, no contacts) that inverse kinematics
  poses to hold the tool. Modules ``scene_copy`` (the copy's MJCF), ``candidates`` (the hand orientations it tries)
  and ``posing`` (:func:`attach_panda`, :class:`PandaHandle`).
* :mod:`phyplan_envs.panda.robot`: **robot execution** (``robot="panda"``): the articulated, actuated Panda that
  carries out every attempt's plan. Modules ``model`` (its MJCF), ``arm`` (the controller), ``motion``, ``sensing``
  and ``switches`` (its parts), ``paths`` (plan steps to joint paths), ``plans`` (the tasks' hand paths) and
  ``flight`` (the flight without the arm).

Shared by the two (modules of this package):

* :mod:`~phyplan_envs.panda.model`: locating the Franka assets; the IK chain (:func:`ik_model`); the arm's facts.
* :mod:`~phyplan_envs.panda.grasp`: grasp frames (pure geometry).
* :mod:`~phyplan_envs.panda.ik`: the one IK module (mink): the chain, residuals, tolerances, home posture and mink
  problem written once; :class:`PandaIK` and the per-process solver :func:`shared_ik` for the posed arm (fresh
  solves), ``ArmIK`` for robot mode (warm-started solves); :mod:`~phyplan_envs.panda.ik_step` its iteration.

Every public name of the posed arm and of the shared modules is re-exported here, so ``from phyplan_envs.panda
import X`` is the stable import; robot mode's names are imported from :mod:`phyplan_envs.panda.robot`.
``python -m benchmarks.panda_speed`` measures the stepping rate of every task with and without the Panda (figures in
``docs/panda.md``).
"""
from __future__ import annotations

from .grasp import grasp_rotation
from .ik import (HOME_Q, IK_ACCEPT_ORI, IK_ACCEPT_POS, IK_CACHE_SIZE, IK_MAX_ITERS, IK_ORI_TOL, IK_POS_TOL,
                 IK_SOLVER, IKSolution, PandaIK, shared_ik)
from .model import (ARM_JOINTS, ARM_LINKS, ARM_RGBA, DEFAULT_GRIP_HALF_WIDTH, FINGER_BODIES, FINGER_CLEARANCE,
                    FINGER_OPEN, FRANKA_SUBDIR, GRASP_DEPTH, GRASP_QUAT, GRASP_SITE, HAND_LINK, HAND_RGBA,
                    PANDA_GEOM_GROUP, PANDA_SITE_GROUP, SHOULDER_HEIGHT, franka_assets_dir, ik_model)
from .posed.candidates import grasp_candidates
from .posed.posing import PandaHandle, attach_panda
from .posed.scene_copy import panda_mjcf

__all__ = [
    # model
    "FRANKA_SUBDIR", "ARM_LINKS", "ARM_JOINTS", "FINGER_BODIES", "HAND_LINK", "GRASP_SITE", "PANDA_GEOM_GROUP",
    "PANDA_SITE_GROUP", "GRASP_DEPTH", "GRASP_QUAT", "SHOULDER_HEIGHT", "FINGER_OPEN", "FINGER_CLEARANCE",
    "DEFAULT_GRIP_HALF_WIDTH", "ARM_RGBA", "HAND_RGBA", "franka_assets_dir", "ik_model",
    # grasp
    "grasp_rotation",
    # ik
    "HOME_Q", "IK_SOLVER", "IK_MAX_ITERS", "IK_POS_TOL", "IK_ORI_TOL", "IK_ACCEPT_POS", "IK_ACCEPT_ORI",
    "IK_CACHE_SIZE", "IKSolution", "PandaIK", "shared_ik",
    # posed: scene_copy, candidates, posing
    "panda_mjcf", "grasp_candidates", "PandaHandle", "attach_panda",
]
