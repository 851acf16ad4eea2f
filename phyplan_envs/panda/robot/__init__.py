"""Robot execution: the articulated, actuated Panda of robot mode (``robot="panda"``) carries out every attempt.

A task's ``robot_plan(action)`` places the tools the arm does not carry and returns pick-carry-release steps
(:class:`Carry`, built by :mod:`.plans`); :meth:`RobotArm.execute` plans each step's joint path before anything moves
(:class:`PathPlanner` on the warm-started :class:`phyplan_envs.panda.ik.ArmIK`), tracks it with the position
servos, grasps, carries, corrects the release in closed loop and lets go; :class:`RobotReport` says how it went
(failures never raise). The flight after the last release runs without the arm (:mod:`.flight`). docs/robot.md has
the design and its measurements.

Modules:

* :mod:`.model`: the articulated Panda's MJCF (:func:`~.model.add_robot`, the grasp and latch equalities, the
  finger pads' contact bit :data:`~.model.ROBOT_BIT`).
* :mod:`.arm`: the controller (:class:`RobotArm`, :class:`RobotReport`, :func:`attach_robot`), with its servo
  motion (:mod:`.motion`), measurements (:mod:`.sensing`) and scene switches (:mod:`.switches`).
* :mod:`.paths`: plan steps (:class:`Carry`) to joint paths (:class:`PathPlanner`, :class:`RobotFailure`).
* :mod:`.plans`: the tasks' hand paths (the pendulum, the drop, the plank).
* :mod:`.flight`: the flight without the arm in the kinematic twin (:class:`~.flight.ArmFreeFlight`).

The names above are re-exported here (``from phyplan_envs.panda.robot import attach_robot``); the flight is imported
from its module.
"""
from __future__ import annotations

from .arm import RobotArm, RobotReport, attach_robot
from .paths import Carry, PathPlanner, RobotFailure

__all__ = ["Carry", "PathPlanner", "RobotArm", "RobotFailure", "RobotReport", "attach_robot"]
