"""The oracle: searches the action space with the real simulator. The upper bound in every table.

It knows nothing about any task beyond :class:`~phyplan_agents.base.TaskInfo` (action names and bounds), so it works
for every task in :data:`phyplan_envs.TASKS`. Its search, with at most ``budget`` simulator calls per context:

1. **Coarse grid.** ``n`` values per action dimension with ``n ** D <= grid_fraction * budget`` (``n >= 2``):
   bounded dimensions include both bounds (goals near the ends of the reachable range need the extreme actions);
   a dimension whose bounds span exactly 2 pi (e.g. Bounce's wedge yaw in [-pi, pi]) is treated as *periodic*: its
   grid is ``n`` equally spaced angles and the local search wraps around instead of stopping at the bound.
2. **Local refinement** from the best ``n_starts`` grid points that are not grid neighbours of each other (distinct
   basins), best first: a (1 + lambda) evolution strategy in the box normalised to [0, 1]^D, with ``lambda = 2 D``
   Gaussian samples drawn as D antithetic pairs around the incumbent, step size starting at half a grid cell,
   multiplied by 1.5 after an improvement (capped at one cell) and by 0.5 otherwise. Before each round of samples,
   if the simulator's ``info`` carries ``final_pos`` and ``goal`` (every phyplan task's does), one *model step*
   is tried: a least-squares linear fit of the object's final xy against the action on the evaluated points near
   the incumbent, then the Gauss-Newton step that moves the final xy onto the goal (minimum norm when there are
   more action dimensions than two), no longer than twice the fitted points' spread. When it improves, the round's
   samples are skipped. On 20 contexts this cut the mean calls after the grid from 44 to 3 (Launch) and from 65
   to 33 (Slide); the Gaussian samples keep the search going across kinks and jumps of the landing map. A start ends when its step falls below
   ``min_step`` (converged) and the search ends when the best reward reaches ``stop_reward`` or the budget is
   spent.

Rewards of evaluated actions are cached, so a repeated point never costs a second call.

Attempts: the first :meth:`act` of a context runs the search and returns the best action found. Each later
:meth:`act` spends up to ``attempt_budget`` more calls refining around the best; if that finds a better action it
is returned, otherwise the next-best evaluated action that differs from every action already submitted (by more
than 1% of the range in some dimension).

Determinism: the search's random draws come from a generator seeded by ``(seed, the context's goal)``, so a
context's result depends only on the agent's seed, its options and the context, not on the contexts before it.

Cost: one simulator call is one episode, median 3.7 ms (Launch), 21 ms (Slide), 3.5 ms (Bounce) and 8.5 ms
(Bridge) on one core of the 2-core dev machine, so the default budget of 200 calls costs at most ~0.7, 4.2, 0.7 and
1.7 s per context. The search usually stops at ``stop_reward`` well before: on seeds 0..49 it used median 66, 69,
67 and 109 calls (``python -m benchmarks.solvability --contexts 50 --budget 200``, which prints calls and seconds
per context).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from .base import Agent, Simulator, TaskInfo


@dataclass(frozen=True)
class SearchResult:
    """The outcome of the oracle's search on one context.

    Attributes:
        best_action: the best action found (physical units).
        best_reward: its reward in the simulator.
        grid_best_reward: the best reward on the coarse grid alone.
        calls: simulator calls spent by the search (grid + refinement).
        grid_points: the number of grid points (``n ** D``).
        starts: how many local refinements were run.
    """

    best_action: np.ndarray
    best_reward: float
    grid_best_reward: float
    calls: int
    grid_points: int
    starts: int


class OracleAgent(Agent):
    """Coarse grid then local evolution-strategy refinement on the real simulator (see the module docstring).

    Args:
        budget: most simulator calls for the search of one context (first attempt). Default 200: with
            ``grid_fraction=0.4`` this is an 8 x 8 grid for two action dimensions (4 x 4 x 4 for three) plus
            refinement, and costs a few seconds at most per context on the current tasks (see the module docstring).
        attempt_budget: most further simulator calls per later attempt of the same context (default 40).
        grid_fraction: share of ``budget`` for the coarse grid (default 0.4), in (0, 1].
        n_starts: how many distinct grid optima are refined (default 3).
        stop_reward: the search stops once the best reward reaches this (default 0.995, i.e. the object ends within
            0.5% of its initial distance from the goal; well above the 0.95 solvability threshold). Use 1.0 to
            always spend the whole budget.
        min_step: a local refinement has converged when its step size (normalised to the action range) falls below
            this (default 1e-4, i.e. 7.9e-5 rad for an angle in [pi/4, pi/2]).
        model_steps: try a Gauss-Newton step on the final xy before each round of samples (default true; see the
            module docstring). Without ``final_pos``/``goal`` in the simulator's info it is skipped automatically.
    """

    name = "oracle"
    needs_simulator = True

    def __init__(self, budget: int = 200, attempt_budget: int = 40, grid_fraction: float = 0.4,
                 n_starts: int = 3, stop_reward: float = 0.995, min_step: float = 1e-4, model_steps: bool = True,
                 **kwargs: Any):
        super().__init__(**kwargs)
        if not (isinstance(budget, (int, np.integer)) and budget >= 4):
            raise ValueError(f"budget must be an integer >= 4 simulator calls, got {budget!r}")
        if not (isinstance(attempt_budget, (int, np.integer)) and attempt_budget >= 0):
            raise ValueError(f"attempt_budget must be an integer >= 0, got {attempt_budget!r}")
        if not (0.0 < float(grid_fraction) <= 1.0):
            raise ValueError(f"grid_fraction must be in (0, 1], got {grid_fraction!r}")
        if not (isinstance(n_starts, (int, np.integer)) and n_starts >= 1):
            raise ValueError(f"n_starts must be an integer >= 1, got {n_starts!r}")
        if not (math.isfinite(stop_reward) and stop_reward <= 1.0):
            raise ValueError(f"stop_reward must be a finite number <= 1, got {stop_reward!r}")
        if not (0.0 < float(min_step) < 1.0):
            raise ValueError(f"min_step must be in (0, 1), got {min_step!r}")
        self.budget = int(budget)
        self.attempt_budget = int(attempt_budget)
        self.grid_fraction = float(grid_fraction)
        self.n_starts = int(n_starts)
        self.stop_reward = float(stop_reward)
        self.min_step = float(min_step)
        self.model_steps = bool(model_steps)
        self.seed = 0
        self.result: SearchResult | None = None

    # -- protocol -----------------------------------------------------------------------------------------------------
    def setup(self, task: TaskInfo, seed: int = 0) -> None:
        super().setup(task, seed)
        self.seed = int(seed)
        lo = np.asarray(task.action_low, dtype=np.float64)
        hi = np.asarray(task.action_high, dtype=np.float64)
        if lo.shape != hi.shape or lo.ndim != 1 or not np.all(np.isfinite(lo)) or not np.all(hi > lo):
            raise ValueError(f"the oracle needs finite action bounds with high > low, got {lo} .. {hi}")
        self._lo, self._span = lo, hi - lo
        self._periodic = np.abs(self._span - 2.0 * math.pi) < 1e-4

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
        self._ctx_rng = np.random.default_rng([self.seed, *goal.view(np.uint64).tolist()])
        self._cache: dict[bytes, float] = {}
        self._points: list[np.ndarray] = []      # evaluated points, normalised to [0, 1]^D
        self._rewards: list[float] = []
        self._finals: list[np.ndarray] = []      # the object's final xy of each evaluated point (NaN if not given)
        self._goal: np.ndarray | None = None
        self._calls = 0
        self._submitted: list[np.ndarray] = []
        self._best_u: np.ndarray | None = None
        self._best_r = -math.inf
        self._sigma = 0.0
        self.result = None

    def act(self) -> np.ndarray:
        if self.task is None or not hasattr(self, "_cache"):
            raise RuntimeError("call setup() and begin_context() before act()")
        if self.result is None:
            self._search()
            u = self._best_u
        else:
            before = self._best_r
            self._refine(self._best_u, self._calls + self.attempt_budget, max(self._sigma, 4 * self.min_step))
            if self._best_r > before:
                u = self._best_u
            else:
                u = self._next_distinct()
        self._submitted.append(u.copy())
        return self._to_action(u)

    # -- search -------------------------------------------------------------------------------------------------------
    def _to_action(self, u: np.ndarray) -> np.ndarray:
        a = self._lo + u * self._span
        return np.clip(a, self.task.action_low, self.task.action_high)

    def _wrap(self, u: np.ndarray) -> np.ndarray:
        u = u.copy()
        u[self._periodic] = np.mod(u[self._periodic], 1.0)
        u[~self._periodic] = np.clip(u[~self._periodic], 0.0, 1.0)
        return u

    def _evaluate(self, u: np.ndarray) -> float:
        key = np.round(u, 12).tobytes()
        if key in self._cache:
            return self._cache[key]
        reward, info = self.simulator.evaluate(self._to_action(u))
        if not math.isfinite(reward):
            reward = -math.inf
        self._calls += 1
        self._cache[key] = reward
        self._points.append(u.copy())
        self._rewards.append(reward)
        final = info.get("final_pos") if isinstance(info, Mapping) else None
        if final is not None and self._goal is None and isinstance(info, Mapping) and "goal" in info:
            self._goal = np.asarray(info["goal"], dtype=np.float64)[:2].copy()
        self._finals.append(np.asarray(final, dtype=np.float64)[:2].copy() if final is not None
                            else np.full(2, np.nan))
        if reward > self._best_r:
            self._best_r, self._best_u = reward, u.copy()
        return reward

    def _done(self, limit: int) -> bool:
        return self._calls >= limit or self._best_r >= self.stop_reward

    def _grid(self) -> tuple[np.ndarray, np.ndarray]:
        d = len(self._lo)
        n = max(2, int(math.floor((self.grid_fraction * self.budget) ** (1.0 / d) + 1e-9)))
        while n > 2 and n ** d > self.budget:
            n -= 1
        axes, cell = [], np.empty(d)
        for i in range(d):
            if self._periodic[i]:
                axes.append(np.arange(n) / n)
                cell[i] = 1.0 / n
            else:
                axes.append(np.linspace(0.0, 1.0, n))
                cell[i] = 1.0 / (n - 1)
        mesh = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, d)
        return mesh, cell

    def _search(self) -> None:
        grid, cell = self._grid()
        for u in grid:
            if self._calls >= self.budget:
                break
            self._evaluate(u)
        grid_best = self._best_r
        # distinct starts: best grid points that are not neighbours of an already chosen start
        order = np.argsort(-np.asarray(self._rewards), kind="stable")
        starts: list[np.ndarray] = []
        for i in order:
            u = self._points[i]
            if all(np.any(self._gap(u, s) > 1.5 * cell) for s in starts):
                starts.append(u)
            if len(starts) >= self.n_starts:
                break
        n_run = 0
        for s in starts:
            if self._done(self.budget):
                break
            self._refine(s, self.budget, 0.5 * float(cell.min()), cap=float(cell.min()))
            n_run += 1
        self.result = SearchResult(best_action=self._to_action(self._best_u), best_reward=float(self._best_r),
                                   grid_best_reward=float(grid_best), calls=self._calls,
                                   grid_points=len(grid), starts=n_run)

    def _gap(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        g = np.abs(u - v)
        g[self._periodic] = np.minimum(g[self._periodic], 1.0 - g[self._periodic])
        return g

    def _refine(self, start: np.ndarray, limit: int, sigma: float, cap: float | None = None) -> None:
        """(1 + 2D)-ES with antithetic Gaussian samples around ``start`` until converged, stopped or over budget."""
        cap = cap if cap is not None else max(sigma, 4 * self.min_step)
        x = start.copy()
        fx = self._cache.get(np.round(x, 12).tobytes())
        if fx is None:
            if self._done(limit):
                return
            fx = self._evaluate(x)
        d = len(x)
        while not self._done(limit) and sigma >= self.min_step:
            if self.model_steps:
                step = self._model_step(x, sigma)
                if step is not None:
                    c = self._wrap(x + step)
                    f = self._evaluate(c)
                    if f > fx:
                        x, fx = c, f
                        sigma = min(cap, max(sigma * 0.5, float(np.max(np.abs(step))), 2 * self.min_step))
                        self._sigma = sigma
                        continue
                    if self._done(limit):
                        break
            z = self._ctx_rng.standard_normal((d, d))
            cands = np.concatenate([x + sigma * z, x - sigma * z])
            best_c, best_f = None, fx
            for c in cands:
                if self._done(limit):
                    break
                c = self._wrap(c)
                f = self._evaluate(c)
                if f > best_f:
                    best_c, best_f = c, f
            if best_c is not None:
                x, fx = best_c, best_f
                sigma = min(1.5 * sigma, cap)
            else:
                sigma *= 0.5
            self._sigma = sigma

    def _model_step(self, x: np.ndarray, sigma: float) -> np.ndarray | None:
        """A Gauss-Newton step towards the goal from a local linear fit of the final xy, or None.

        Fits ``final_xy ~ f(x) + J (u - x)`` by least squares on the (up to) ``3 D`` evaluated points nearest to
        ``x`` within ``4 sigma`` and returns the minimum-norm ``delta`` with ``J delta = goal - final_xy(x)``,
        shortened to at most twice the spread of the fitted points.
        """
        if self._goal is None or len(self._points) < 3:
            return None
        d = len(x)
        pts = np.asarray(self._points)
        fin = np.asarray(self._finals)
        diff = pts - x
        diff[:, self._periodic] = (diff[:, self._periodic] + 0.5) % 1.0 - 0.5
        dist = np.max(np.abs(diff), axis=1)
        ok = np.isfinite(fin).all(axis=1) & (dist <= 4 * sigma)
        idx = np.flatnonzero(ok)
        if len(idx) < d + 2:
            return None
        idx = idx[np.argsort(dist[idx], kind="stable")[:3 * d]]
        here = idx[dist[idx] < 1e-12]
        if len(here) == 0:
            return None
        a = np.hstack([np.ones((len(idx), 1)), diff[idx]])
        coef, _, rank, _ = np.linalg.lstsq(a, fin[idx], rcond=None)
        if rank < d + 1:
            return None
        jac = coef[1:].T                                   # (2, D)
        step = np.linalg.lstsq(jac, self._goal - fin[here[0]], rcond=None)[0]
        reach = 2.0 * float(dist[idx].max())
        size = float(np.max(np.abs(step)))
        if not np.isfinite(size) or size < 1e-12:
            return None
        return step * min(1.0, reach / size)

    def _next_distinct(self) -> np.ndarray:
        """The best evaluated point that differs from every submitted action by > 1% of the range in some dim."""
        for i in np.argsort(-np.asarray(self._rewards), kind="stable"):
            u = self._points[i]
            if all(np.any(self._gap(u, s) > 0.01) for s in self._submitted):
                return u
        return self._best_u

    # -- accounting ---------------------------------------------------------------------------------------------------
    @property
    def best_reward(self) -> float:
        """The best simulator reward found so far in this context (``-inf`` before the first act)."""
        return float(getattr(self, "_best_r", -math.inf))

    @property
    def best_action(self) -> np.ndarray | None:
        u = getattr(self, "_best_u", None)
        return None if u is None else self._to_action(u)
