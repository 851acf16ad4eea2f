"""The random baseline: a uniform action per attempt, from the agent's own seeded generator."""
from __future__ import annotations

import numpy as np

from .base import Agent


class RandomAgent(Agent):
    """Draws each attempt's action uniformly inside the task's action bounds (the paper's Random policy)."""

    name = "random"

    def act(self) -> np.ndarray:
        return self.uniform_actions(1)[0]
