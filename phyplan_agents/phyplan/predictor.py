"""The chain predictor (the paper's Algorithm 3, batched): predicted final position and reward of many actions.

Each task's skill chain lives with the planner, composed from the scene the task describes
(:mod:`phyplan_agents.phyplan.composer`: e.g. Launch's swing -> hit -> throw). This module turns a chain into a
reward predictor for one context::

    predictor = ChainPredictor.for_task("launch", load_default_skills())
    predictor.set_context(state)          # the state observation of env.reset
    r = predictor.reward(actions)         # (N,) predicted 1 - |xy - goal| / d0 for (N, A) actions

The reward is the env's: ``1 - d / d0`` with d the xy distance of the predicted final position from the goal and d0
the distance of the object's start from the goal (both read from the state vector: goal_x, goal_y, object_x,
object_y are its first four entries).
"""
from __future__ import annotations

from typing import Any

import numpy as np
import torch

from .composer import Chain, chain_for, composed
from .fastnet import fast_skills


NO_PREDICTION = -1.0   # the score of an action without a prediction: as bad as ending twice as far from the goal as
                       # the start (finite, so that a tree search's running means stay comparable)


class ChainPredictor:
    """One task's skill chain as a batched reward predictor.

    Args:
        chain: the task's :class:`~phyplan_agents.phyplan.composer.Chain` (skills in order and its ``rollout``).
        skills: an object with the skill models the chain uses as attributes (``swing``, ``hit``, ...).
        facts: the task's physical facts (``phyplan_envs.task_class(task).facts``), passed to the rollout.
        chunk: at most this many actions go through the skill models in one call (bounds memory; default 4096).
        fast: evaluate the skill networks through :func:`~phyplan_agents.phyplan.fastnet.fast_skills` (same
            outputs to float32 rounding, ~3x faster; default true).

    Attributes:
        evaluations: the number of actions scored so far (each action is one chain rollout).
    """

    def __init__(self, chain: Chain, skills: Any, facts: Any, chunk: int = 4096, fast: bool = True):
        if not isinstance(chain, Chain):
            raise TypeError(f"chain must be a phyplan_agents.phyplan.composer.Chain, got {type(chain).__name__}")
        missing = sorted({s for s in chain.skills if not hasattr(skills, s)})
        if missing:
            raise ValueError(f"the {chain.task} chain needs skill models {', '.join(missing)}; skills has none "
                             f"(give an object with attributes {', '.join(dict.fromkeys(chain.skills))})")
        if facts is None:
            raise ValueError(f"the {chain.task} chain needs the task's facts (phyplan_envs.task_class(task).facts)")
        self.chain = chain
        self.facts = facts
        self.skills = fast_skills(skills) if fast else skills
        self.chunk = int(chunk)
        self.evaluations = 0
        self._state: torch.Tensor | None = None
        self._goal: torch.Tensor | None = None
        self._d0 = 1.0

    @classmethod
    def for_task(cls, task: str, skills: Any, facts: Any = None, scene=None, **kwargs) -> "ChainPredictor":
        """The predictor of task ``task``'s chain (``"launch"``, ``"slide"``, ...) with scene arguments ``scene``
        (e.g. ``{"paddles": 4}``); ``facts`` default to that scene's."""
        chain = chain_for(task, scene)
        if facts is None:
            facts = composed(task, scene).facts
        return cls(chain, skills, facts, **kwargs)

    def set_context(self, state) -> None:
        """Fix the context: the task's state vector (goal_x, goal_y, object_x, object_y, object_z, ...)."""
        s = torch.as_tensor(np.asarray(state, dtype=np.float32))
        if s.ndim != 1 or s.shape[0] < 5 or not torch.all(torch.isfinite(s)):
            raise ValueError(f"state must be a finite vector (goal_x, goal_y, object_x, object_y, object_z, ...), "
                             f"got {np.asarray(state)!r}")
        self._state = s
        self._goal = s[0:2].clone()
        self._d0 = float(torch.linalg.norm(s[2:4] - s[0:2]))
        if self._d0 <= 0:
            raise ValueError("the object starts on the goal (initial distance 0): the reward 1 - d/d0 is undefined")

    @property
    def goal(self) -> np.ndarray:
        return self._goal.numpy().astype(np.float64)

    @property
    def initial_distance(self) -> float:
        return self._d0

    def final_xy(self, actions) -> np.ndarray:
        """Predicted final xy (N, 2) of the moving object for actions (N, A), in metres."""
        if self._state is None:
            raise RuntimeError("call set_context(state) before scoring actions")
        a = torch.as_tensor(np.asarray(actions, dtype=np.float32))
        if a.ndim == 1:
            a = a[None]
        out = []
        with torch.no_grad():
            for i in range(0, a.shape[0], self.chunk):
                xy = self.chain.rollout(self._state, a[i:i + self.chunk], self.skills, self.facts)
                out.append(torch.as_tensor(xy, dtype=torch.float32).reshape(-1, 2))
        self.evaluations += int(a.shape[0])
        return torch.cat(out).numpy().astype(np.float64) if out else np.zeros((0, 2))

    def reward_of_xy(self, xy: np.ndarray) -> np.ndarray:
        """The env's reward ``1 - |xy - goal| / d0`` of final positions ``xy`` (N, 2); a position the chain has no
        prediction for (NaN: an event outside every skill's domain) scores :data:`NO_PREDICTION`."""
        d = np.linalg.norm(np.asarray(xy, dtype=np.float64) - self.goal, axis=-1)
        r = 1.0 - d / self._d0
        return np.where(np.isfinite(r), r, NO_PREDICTION)

    def reward(self, actions) -> np.ndarray:
        """Predicted reward (N,) of actions (N, A)."""
        return self.reward_of_xy(self.final_xy(actions))
