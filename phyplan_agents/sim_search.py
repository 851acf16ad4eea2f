"""Find the best action on the real simulator: a coarse grid, then local refinement (a model step plus an ES).

This is the one search routine of the project for "maximise the reward of one context by calling the simulator":
the oracle agent (:mod:`phyplan_agents.oracle`), the solvability certificate (``benchmarks.solvability``), the
Bounce/Bridge design checks and the DQN grid check all use it. It knows nothing about any task: it sees an
*objective* (a callable ``action -> reward`` or ``action -> (reward, info)``, or a :class:`~phyplan_agents.Simulator`)
and a box of action bounds.

The search, with at most ``budget`` objective calls:

1. **Coarse grid.** ``n`` values per action dimension with ``n ** D <= grid_fraction * budget`` (``n >= 2``):
   bounded dimensions include both bounds (goals near the ends of the reachable range need the extreme actions);
   a dimension whose bounds span exactly 2 pi (e.g. Bounce's wedge yaw in [-pi, pi]) is treated as *periodic*: its
   grid is ``n`` equally spaced angles and the local search wraps around instead of stopping at the bound.
2. **Local refinement** from the best ``n_starts`` grid points that are not grid neighbours of each other (distinct
   basins), best first: a (1 + lambda) evolution strategy in the box normalised to [0, 1]^D, with ``lambda = 2 D``
   Gaussian samples drawn as D antithetic pairs around the incumbent, step size starting at half a grid cell,
   multiplied by 1.5 after an improvement (capped at one cell) and by 0.5 otherwise. Before each round of samples,
   if the objective's ``info`` carries ``final_pos`` and ``goal`` (every phyplan task's does), one *model step*
   is tried: a least-squares linear fit of the object's final xy against the action on the evaluated points near
   the incumbent, then the Gauss-Newton step that moves the final xy onto the goal (minimum norm when there are
   more action dimensions than two), no longer than twice the fitted points' spread. When it improves, the round's
   samples are skipped: the model step is what keeps the calls after the grid few (docs/agents.md, *Oracle*); the
   Gaussian samples keep the search going across kinks and jumps of the landing map. A start
   ends when its step falls below ``min_step`` (converged) and the search ends when the best reward reaches
   ``stop_reward`` or the budget is spent.

Rewards of evaluated actions are cached, so a repeated point never costs a second call. A non-finite reward counts
as ``-inf``.

Usage::

    from phyplan_agents.sim_search import search
    result = search(simulator, low, high, budget=200, seed=0)
    result.best_action, result.best_reward, result.calls
    actions, rewards = result.history                   # every evaluated action, in call order

:class:`LocalSearch` is the same search as an object, for callers that continue it (the oracle refines further
around the best point on later attempts: :meth:`LocalSearch.refine_best`, :meth:`LocalSearch.next_distinct`).

Determinism: the only random draws are the ES samples, from ``np.random.default_rng(seed)``; the same objective,
bounds, options and seed give the same calls in the same order, bit for bit.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence, Union

import numpy as np

Objective = Callable[[np.ndarray], Union[float, "tuple[float, Mapping[str, Any]]"]]


@dataclass(frozen=True)
class SearchResult:
    """The outcome of one search.

    Attributes:
        best_action: the best action found (physical units).
        best_reward: its reward.
        grid_best_reward: the best reward on the coarse grid alone.
        calls: objective calls spent (grid + refinement).
        grid_points: the number of grid points (``n ** D``).
        starts: how many local refinements were run.
        history: ``(actions (N, D), rewards (N,))`` of every call, in call order.
    """

    best_action: np.ndarray
    best_reward: float
    grid_best_reward: float
    calls: int
    grid_points: int
    starts: int
    history: tuple[np.ndarray, np.ndarray] = (np.zeros((0, 0)), np.zeros(0))


def periodic_dims(low: Sequence[float], high: Sequence[float]) -> np.ndarray:
    """Which dimensions are angles over a full turn (bounds spanning 2 pi within 1e-4): the search wraps them."""
    span = np.asarray(high, dtype=np.float64) - np.asarray(low, dtype=np.float64)
    return np.abs(span - 2.0 * math.pi) < 1e-4


class LocalSearch:
    """Grid + local refinement on an objective over the box ``[low, high]`` (see the module docstring).

    Args:
        objective: ``action -> reward`` or ``action -> (reward, info)`` (``info`` may carry ``final_pos`` and
            ``goal`` for the model step), or an object with such an ``evaluate`` method (a
            :class:`~phyplan_agents.Simulator`).
        low, high: finite action bounds (D,), ``high > low``.
        budget: most objective calls of :meth:`run` (>= 4).
        grid_fraction: share of ``budget`` for the coarse grid, in (0, 1].
        n_starts: how many distinct grid optima are refined (>= 1).
        stop_reward: the search stops once the best reward reaches this (<= 1; 1.0 spends the whole budget).
        min_step: a refinement has converged when its step (normalised to the action range) falls below this.
        model_steps: try the Gauss-Newton step on the final xy (skipped automatically without ``final_pos``/``goal``).
        seed: seed of the ES samples: anything ``np.random.default_rng`` takes (an int, a list of ints).
        periodic: (D,) bools, the dimensions that wrap around; default :func:`periodic_dims`.
    """

    def __init__(self, objective: Objective | Any, low: Sequence[float], high: Sequence[float], *,
                 budget: int = 200, grid_fraction: float = 0.4, n_starts: int = 3, stop_reward: float = 0.995,
                 min_step: float = 1e-4, model_steps: bool = True, seed: Any = 0,
                 periodic: Sequence[bool] | None = None):
        options = search_options(budget, grid_fraction, n_starts, stop_reward, min_step, model_steps)
        lo = np.asarray(low, dtype=np.float64)
        hi = np.asarray(high, dtype=np.float64)
        if lo.shape != hi.shape or lo.ndim != 1 or not np.all(np.isfinite(lo)) or not np.all(np.isfinite(hi)) \
                or not np.all(hi > lo):
            raise ValueError(f"low and high must be finite 1-D action bounds with high > low, got {lo} .. {hi}")
        self._call = objective.evaluate if hasattr(objective, "evaluate") else objective
        self._call_batch = getattr(objective, "evaluate_batch", None)     # a Simulator: many calls in one batch
        if not callable(self._call):
            raise TypeError(f"objective must be callable or have an evaluate method, got {type(objective).__name__}")
        self.low, self.high = lo, hi
        self._lo, self._span = lo, hi - lo
        self._periodic = periodic_dims(lo, hi) if periodic is None else np.asarray(periodic, dtype=bool)
        if self._periodic.shape != lo.shape:
            raise ValueError(f"periodic must have one entry per action dimension ({len(lo)}), got {periodic!r}")
        for name, value in options.items():     # budget, grid_fraction, n_starts, stop_reward, min_step, model_steps
            setattr(self, name, value)
        self._rng = np.random.default_rng(seed)
        self._cache: dict[bytes, float] = {}
        self.points: list[np.ndarray] = []       # evaluated points, normalised to [0, 1]^D
        self.rewards: list[float] = []
        self._finals: list[np.ndarray] = []      # the object's final xy of each evaluated point (NaN if not given)
        self._goal: np.ndarray | None = None
        self.calls = 0
        self.best_u: np.ndarray | None = None
        self.best_reward = -math.inf
        self.sigma = 0.0                         # the last refinement's step size
        self.result: SearchResult | None = None

    # -- coordinates ----------------------------------------------------------------------------------------------
    def to_action(self, u: np.ndarray) -> np.ndarray:
        """A point of the unit box as an action (physical units, clipped to the bounds)."""
        return np.clip(self._lo + u * self._span, self.low, self.high)

    @property
    def best_action(self) -> np.ndarray | None:
        return None if self.best_u is None else self.to_action(self.best_u)

    @property
    def history(self) -> tuple[np.ndarray, np.ndarray]:
        """``(actions (N, D), rewards (N,))`` of every call so far, in call order."""
        if not self.points:
            return np.zeros((0, len(self._lo))), np.zeros(0)
        return self.to_action(np.asarray(self.points)), np.asarray(self.rewards, dtype=np.float64)

    def _wrap(self, u: np.ndarray) -> np.ndarray:
        u = u.copy()
        u[self._periodic] = np.mod(u[self._periodic], 1.0)
        u[~self._periodic] = np.clip(u[~self._periodic], 0.0, 1.0)
        return u

    def gap(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Per-dimension distance of two unit-box points (the short way round on periodic dimensions)."""
        g = np.abs(u - v)
        g[self._periodic] = np.minimum(g[self._periodic], 1.0 - g[self._periodic])
        return g

    # -- calls ----------------------------------------------------------------------------------------------------
    def evaluate(self, u: np.ndarray) -> float:
        """The reward at unit-box point ``u`` (cached: a repeated point costs no call)."""
        key = np.round(u, 12).tobytes()
        if key in self._cache:
            return self._cache[key]
        out = self._call(self.to_action(u))
        reward, info = out if isinstance(out, tuple) else (out, None)
        return self._record(u, key, reward, info)

    def evaluate_many(self, us: np.ndarray, limit: int) -> None:
        """:meth:`evaluate` each point of ``us`` in order while fewer than ``limit`` calls are spent: the same calls
        and bookkeeping, but the uncached points go to the objective's ``evaluate_batch`` as one batch if it has
        one (a :class:`~phyplan_agents.Simulator`, whose batch outcomes equal single calls bit for bit)."""
        todo, keys = [], set()
        for u in us:
            if self.calls + len(todo) >= limit:
                break
            key = np.round(u, 12).tobytes()
            if key not in self._cache and key not in keys:
                todo.append(u)
                keys.add(key)
        if self._call_batch is None or len(todo) < 2:
            for u in todo:
                self.evaluate(u)
            return
        rewards, infos = self._call_batch(self.to_action(np.asarray(todo)))
        for u, reward, info in zip(todo, rewards, infos):
            self._record(u, np.round(u, 12).tobytes(), reward, info)

    def _record(self, u: np.ndarray, key: bytes, reward: float, info: Mapping[str, Any] | None) -> float:
        reward = float(reward)
        if not math.isfinite(reward):
            reward = -math.inf
        self.calls += 1
        self._cache[key] = reward
        self.points.append(u.copy())
        self.rewards.append(reward)
        final = info.get("final_pos") if isinstance(info, Mapping) else None
        if final is not None and self._goal is None and isinstance(info, Mapping) and "goal" in info:
            self._goal = np.asarray(info["goal"], dtype=np.float64)[:2].copy()
        self._finals.append(np.asarray(final, dtype=np.float64)[:2].copy() if final is not None
                            else np.full(2, np.nan))
        if reward > self.best_reward:
            self.best_reward, self.best_u = reward, u.copy()
        return reward

    def _done(self, limit: int) -> bool:
        return self.calls >= limit or self.best_reward >= self.stop_reward

    # -- the search -----------------------------------------------------------------------------------------------
    def grid(self) -> tuple[np.ndarray, np.ndarray]:
        """The coarse grid (unit box, C order) and its cell size per dimension."""
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

    def run(self) -> SearchResult:
        """The grid, then refinement from the distinct best grid points, within ``budget`` calls."""
        if self.result is not None:
            raise RuntimeError("run() was already called; continue with refine_best()")
        grid, cell = self.grid()
        self.evaluate_many(grid, self.budget)
        grid_best = self.best_reward
        # distinct starts: best grid points that are not neighbours of an already chosen start
        order = np.argsort(-np.asarray(self.rewards), kind="stable")
        starts: list[np.ndarray] = []
        for i in order:
            u = self.points[i]
            if all(np.any(self.gap(u, s) > 1.5 * cell) for s in starts):
                starts.append(u)
            if len(starts) >= self.n_starts:
                break
        n_run = 0
        for s in starts:
            if self._done(self.budget):
                break
            self.refine(s, self.budget, 0.5 * float(cell.min()), cap=float(cell.min()))
            n_run += 1
        self.result = SearchResult(best_action=self.to_action(self.best_u), best_reward=float(self.best_reward),
                                   grid_best_reward=float(grid_best), calls=self.calls,
                                   grid_points=len(grid), starts=n_run, history=self.history)
        return self.result

    def refine_best(self, calls: int) -> bool:
        """Spend up to ``calls`` more calls refining around the best point (step: the last refinement's, at least
        ``4 min_step``). Returns whether the best reward improved."""
        if self.best_u is None:
            raise RuntimeError("nothing evaluated yet: call run() first")
        before = self.best_reward
        self.refine(self.best_u, self.calls + int(calls), max(self.sigma, 4 * self.min_step))
        return self.best_reward > before

    def refine(self, start: np.ndarray, limit: int, sigma: float, cap: float | None = None) -> None:
        """(1 + 2D)-ES with antithetic Gaussian samples around unit-box point ``start`` until converged, stopped or
        ``calls`` reaches ``limit``."""
        cap = cap if cap is not None else max(sigma, 4 * self.min_step)
        x = start.copy()
        fx = self._cache.get(np.round(x, 12).tobytes())
        if fx is None:
            if self._done(limit):
                return
            fx = self.evaluate(x)
        d = len(x)
        while not self._done(limit) and sigma >= self.min_step:
            if self.model_steps:
                step = self._model_step(x, sigma)
                if step is not None:
                    c = self._wrap(x + step)
                    f = self.evaluate(c)
                    if f > fx:
                        x, fx = c, f
                        sigma = min(cap, max(sigma * 0.5, float(np.max(np.abs(step))), 2 * self.min_step))
                        self.sigma = sigma
                        continue
                    if self._done(limit):
                        break
            z = self._rng.standard_normal((d, d))
            cands = np.concatenate([x + sigma * z, x - sigma * z])
            best_c, best_f = None, fx
            for c in cands:
                if self._done(limit):
                    break
                c = self._wrap(c)
                f = self.evaluate(c)
                if f > best_f:
                    best_c, best_f = c, f
            if best_c is not None:
                x, fx = best_c, best_f
                sigma = min(1.5 * sigma, cap)
            else:
                sigma *= 0.5
            self.sigma = sigma

    def _model_step(self, x: np.ndarray, sigma: float) -> np.ndarray | None:
        """A Gauss-Newton step towards the goal from a local linear fit of the final xy, or None.

        Fits ``final_xy ~ f(x) + J (u - x)`` by least squares on the (up to) ``3 D`` evaluated points nearest to
        ``x`` within ``4 sigma`` and returns the minimum-norm ``delta`` with ``J delta = goal - final_xy(x)``,
        shortened to at most twice the spread of the fitted points.
        """
        if self._goal is None or len(self.points) < 3:
            return None
        d = len(x)
        pts = np.asarray(self.points)
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

    def next_distinct(self, exclude: Sequence[np.ndarray], tol: float = 0.01) -> np.ndarray:
        """The best evaluated unit-box point that differs from every point of ``exclude`` by more than ``tol`` (of
        the range) in some dimension; the best point if there is none."""
        for i in np.argsort(-np.asarray(self.rewards), kind="stable"):
            u = self.points[i]
            if all(np.any(self.gap(u, s) > tol) for s in exclude):
                return u
        return self.best_u


def search_options(budget: Any = 200, grid_fraction: Any = 0.4, n_starts: Any = 3, stop_reward: Any = 0.995,
                   min_step: Any = 1e-4, model_steps: Any = True) -> dict[str, Any]:
    """The search options (of :class:`LocalSearch` and the oracle) checked by :func:`check_options` and in the types
    the search uses, by name."""
    check_options(budget=budget, grid_fraction=grid_fraction, n_starts=n_starts, stop_reward=stop_reward,
                  min_step=min_step)
    return {"budget": int(budget), "grid_fraction": float(grid_fraction), "n_starts": int(n_starts),
            "stop_reward": float(stop_reward), "min_step": float(min_step), "model_steps": bool(model_steps)}


def check_options(budget: Any = 200, grid_fraction: Any = 0.4, n_starts: Any = 3, stop_reward: Any = 0.995,
                  min_step: Any = 1e-4) -> None:
    """Raise ``ValueError`` naming the first search option out of range."""
    if not (isinstance(budget, (int, np.integer)) and not isinstance(budget, bool) and budget >= 4):
        raise ValueError(f"budget must be an integer >= 4 simulator calls, got {budget!r}")
    if not (0.0 < float(grid_fraction) <= 1.0):
        raise ValueError(f"grid_fraction must be in (0, 1], got {grid_fraction!r}")
    if not (isinstance(n_starts, (int, np.integer)) and n_starts >= 1):
        raise ValueError(f"n_starts must be an integer >= 1, got {n_starts!r}")
    if not (math.isfinite(stop_reward) and stop_reward <= 1.0):
        raise ValueError(f"stop_reward must be a finite number <= 1, got {stop_reward!r}")
    if not (0.0 < float(min_step) < 1.0):
        raise ValueError(f"min_step must be in (0, 1), got {min_step!r}")


def search(objective: Objective | Any, low: Sequence[float], high: Sequence[float], *, budget: int = 200,
           seed: Any = 0, **options: Any) -> SearchResult:
    """Maximise ``objective`` over the box ``[low, high]`` with at most ``budget`` calls; see :class:`LocalSearch`
    for ``objective`` and the ``options`` (``grid_fraction``, ``n_starts``, ``stop_reward``, ``min_step``,
    ``model_steps``, ``periodic``)."""
    return LocalSearch(objective, low, high, budget=budget, seed=seed, **options).run()
