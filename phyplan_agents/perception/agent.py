"""``phyplan-perception``: the PhyPlan agent planning from the RGB-D observation alone.

It asks for ``obs_mode="rgbd"`` (:attr:`PhyPlanPerceptionAgent.env_kwargs`), reads the state vector the skill chain
needs from the context's picture (:func:`phyplan_agents.perception.perceive`) and then plans exactly as ``phyplan``
(MCTS over the skill chain, GP-UCB on the reward error). It reads nothing from ``info``: neither at
``begin_context`` (the harness's ``info["context"]`` holds the goal) nor after an attempt (the reward residual needs
only the reward).

What it knows besides the pictures: the camera's calibration (a fixed property of the env, read once in
:meth:`~PhyPlanPerceptionAgent.setup` from its own copy of the env, made without the Panda and never stepped) and
the task's declared facts, as ``phyplan`` does. A scene it cannot read (goal out of view or hidden, a failed fit) is
a :class:`~phyplan_agents.perception.PerceptionError` in ``begin_context``, never a guessed position.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..base import TaskInfo
from ..phyplan.agent import PhyPlanAgent
from .scene import Percept, perceive

IMAGE_SIZE = 256     # pixels: at 128 the goal's centre errs ~2x more (1 pixel is ~8 mm on the ground at 256)


def camera_calibration(task: TaskInfo, name: str = "obs"):
    """The calibration of camera ``name`` of the env ``task`` describes, and the env's facts and state names.

    Read from a private copy of the env (no Panda; it is never reset or stepped, so it knows no context)."""
    import phyplan_envs

    size = int(dict(task.env_kwargs).get("image_size", 128))
    env = phyplan_envs.task_class(task.task)(image_size=size, with_panda=False)
    try:
        return env.camera_model(name), env.facts, tuple(env.state_names)
    finally:
        env.close()


class PhyPlanPerceptionAgent(PhyPlanAgent):
    """PhyPlan from RGB-D pictures: :func:`~phyplan_agents.perception.perceive`, then the ``phyplan`` planner.

    Takes every option of :class:`~phyplan_agents.phyplan.agent.PhyPlanAgent`. After ``begin_context``,
    :attr:`percept` holds what was read (state, per-object measurements).
    """

    name = "phyplan-perception"
    env_kwargs = {"obs_mode": "rgbd", "image_size": IMAGE_SIZE}

    def __init__(self, **kwargs: Any):
        if kwargs.get("residual", "reward") != "reward":
            raise ValueError("phyplan-perception models the reward error only: residual='position' reads the final "
                             "position from the step's info, which this agent does not use")
        if kwargs.get("scorer", "chain") != "chain":
            raise ValueError("phyplan-perception plans with the skill chain (scorer='chain'); the simulator scorer "
                             "would need the state")
        super().__init__(**kwargs)
        self.percept: Percept | None = None
        self._camera = None

    def setup(self, task: TaskInfo, seed: int = 0) -> None:
        if task.obs_mode != "rgbd":
            raise ValueError(f"{self.name} plans from RGB-D pictures; make the env with obs_mode='rgbd' "
                             f"(got obs_mode={task.obs_mode!r})")
        super().setup(task, seed)
        self._camera, self._facts, self._state_names = camera_calibration(task)

    def read_state(self, obs: Any) -> np.ndarray:
        """The state vector read from the picture (:class:`~phyplan_agents.perception.PerceptionError` if the
        scene cannot be read)."""
        if self._camera is None:
            raise RuntimeError("setup(task, seed) must be called before begin_context()")
        self.percept = perceive(self.task.task, obs, self._camera, self._facts, self._state_names)
        return self.percept.require()
