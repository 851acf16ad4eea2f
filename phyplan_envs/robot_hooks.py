"""The task hooks of the Panda (where it stands, what its hand holds) and of robot mode (the arm's plan and scene
changes): defaults of :class:`phyplan_envs.base.PhyPlanEnv`, which a task overrides."""
from __future__ import annotations

from typing import Any

import numpy as np
from dm_control import mjcf


class RobotHooks:
    """Panda and robot-mode hooks of a task (mixed into :class:`phyplan_envs.base.PhyPlanEnv`)."""

    def robot_plan(self, action: np.ndarray) -> list:
        """Robot mode: place the tools the arm does not carry and return the arm's steps for ``action``
        (:class:`phyplan_envs.panda.robot.Carry`, usually from :mod:`phyplan_envs.panda.plans`)."""
        raise NotImplementedError(f"{type(self).__name__} has no robot plan: it cannot run with robot='panda'")

    def robot_scene(self, root: mjcf.RootElement) -> None:
        """Robot mode: changes to the scene the arm needs (e.g. a pivot for a tool it turns); default none."""

    def robot_placement(self) -> dict[str, Any]:
        """Robot mode: where the articulated Panda stands (default: where the visual one does)."""
        return self.panda_placement()

    def panda_placement(self) -> dict[str, Any]:
        """Where the Panda stands: ``base_pos`` (world xyz of its base) and ``base_yaw`` (rad)."""
        return {"base_pos": (-0.55, -0.35, 0.0), "base_yaw": 0.6}

    def hand_target(self, action: np.ndarray | None) -> np.ndarray:
        """The world point the Panda's hand holds at release for ``action`` (``None``: before any attempt).

        Pendulum tasks hold the bob at its release angle; others override. Default: the object's start position.
        """
        return self._start_pos.copy()
