"""The oracle: searches the action space with the real simulator. The upper bound in every table.

It knows nothing about any task beyond :class:`~phyplan_agents.base.TaskInfo` (action names and bounds), so it works
for every task in :data:`phyplan_envs.TASKS`. Its search, with at most ``budget`` simulator calls per context, is
:mod:`phyplan_agents.sim_search` (a coarse grid, then a local model step + evolution-strategy refinement from the
distinct best grid points; periodic yaw dimensions wrap around), the project's one search on the real simulator.

Attempts: the first :meth:`act` of a context runs the search and returns the best action found. Each later
:meth:`act` spends up to ``attempt_budget`` more calls refining around the best; if that finds a better action it
is returned, otherwise the next-best evaluated action that differs from every action already submitted (by more
than 1% of the range in some dimension).

Determinism: the search's random draws come from a generator seeded by ``(seed, the context's goal)``, so a
context's result depends only on the agent's seed, its options and the context, not on the contexts before it.

Cost: one simulator call is one episode, so a context costs at most ``budget`` episodes; the search usually stops at
``stop_reward`` well before. ``python -m benchmarks.solvability --contexts 50 --budget 200`` prints the calls and
seconds per context (figures: docs/agents.md, *Oracle*).
"""
from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from .base import Agent, Simulator, TaskInfo
from .sim_search import LocalSearch, SearchResult, periodic_dims, search_options

__all__ = ["OracleAgent", "SearchResult"]


class OracleAgent(Agent):
    """Coarse grid then local evolution-strategy refinement on the real simulator (see :mod:`.sim_search`).

    Args:
        budget: most simulator calls for the search of one context (first attempt). Default 200: with
            ``grid_fraction=0.4`` this is an 8 x 8 grid for two action dimensions (4 x 4 x 4 for three) plus
            refinement (its cost: the module docstring).
        attempt_budget: most further simulator calls per later attempt of the same context (default 40).
        grid_fraction: share of ``budget`` for the coarse grid (default 0.4), in (0, 1].
        n_starts: how many distinct grid optima are refined (default 3).
        stop_reward: the search stops once the best reward reaches this (default 0.995, i.e. the object ends within
            0.5% of its initial distance from the goal; well above the 0.95 solvability threshold). Use 1.0 to
            always spend the whole budget.
        min_step: a local refinement has converged when its step size (normalised to the action range) falls below
            this (default 1e-4, i.e. 7.9e-5 rad for an angle in [pi/4, pi/2]).
        model_steps: try a Gauss-Newton step on the final xy before each round of samples (default true; see
            :mod:`.sim_search`). Without ``final_pos``/``goal`` in the simulator's info it is skipped automatically.
    """

    name = "oracle"
    needs_simulator = True

    def __init__(self, budget: int = 200, attempt_budget: int = 40, grid_fraction: float = 0.4,
                 n_starts: int = 3, stop_reward: float = 0.995, min_step: float = 1e-4, model_steps: bool = True,
                 **kwargs: Any):
        super().__init__(**kwargs)
        self.options = search_options(budget, grid_fraction, n_starts, stop_reward, min_step, model_steps)
        if not (isinstance(attempt_budget, (int, np.integer)) and attempt_budget >= 0):
            raise ValueError(f"attempt_budget must be an integer >= 0, got {attempt_budget!r}")
        self.budget = self.options["budget"]
        self.attempt_budget = int(attempt_budget)
        self.seed = 0
        self.result: SearchResult | None = None
        self._search: LocalSearch | None = None

    # -- protocol -----------------------------------------------------------------------------------------------------
    def setup(self, task: TaskInfo, seed: int = 0) -> None:
        super().setup(task, seed)
        self.seed = int(seed)
        lo = np.asarray(task.action_low, dtype=np.float64)
        hi = np.asarray(task.action_high, dtype=np.float64)
        if lo.shape != hi.shape or lo.ndim != 1 or not np.all(np.isfinite(lo)) or not np.all(hi > lo):
            raise ValueError(f"the oracle needs finite action bounds with high > low, got {lo} .. {hi}")
        self._periodic = periodic_dims(lo, hi)

    def reseed(self, seed: int) -> None:
        """Set the seed of the search's random draws (the harness calls this before each context)."""
        self.seed = int(seed)
        self.rng = np.random.default_rng(seed)

    def begin_context(self, obs: Any, info: Mapping[str, Any], simulator: Simulator | None = None) -> None:
        if self.task is None:
            raise RuntimeError("call setup(task, seed) before begin_context()")
        if simulator is None:
            raise ValueError("the oracle needs the real simulator: pass a phyplan_agents.Simulator for this context "
                             "to begin_context (the harness does so for agents with needs_simulator = True)")
        super().begin_context(obs, info, simulator)
        goal = np.asarray(info.get("goal", info.get("context", {}).get("goal", (0.0, 0.0))), dtype=np.float64)
        self._search = LocalSearch(simulator, self.task.action_low, self.task.action_high, **self.options,
                                   seed=[self.seed, *goal.view(np.uint64).tolist()], periodic=self._periodic)
        self._submitted: list[np.ndarray] = []
        self.result = None

    def act(self) -> np.ndarray:
        if self.task is None or self._search is None:
            raise RuntimeError("call setup() and begin_context() before act()")
        s = self._search
        if self.result is None:
            self.result = s.run()
            u = s.best_u
        elif s.refine_best(self.attempt_budget):
            u = s.best_u
        else:
            u = s.next_distinct(self._submitted)
        self._submitted.append(u.copy())
        return s.to_action(u)

    # -- accounting ---------------------------------------------------------------------------------------------------
    @property
    def best_reward(self) -> float:
        """The best simulator reward found so far in this context (``-inf`` before the first act)."""
        return -math.inf if self._search is None else float(self._search.best_reward)

    @property
    def best_action(self) -> np.ndarray | None:
        return None if self._search is None else self._search.best_action
