"""Online system identification: the hidden physical parameters of a context from the landings seen so far.

After each real attempt the agent knows its actions ``a_1..a_n`` and where the object ended, ``y_1..y_n`` (the env's
``info["final_pos"]``). A parameter-conditioned skill chain predicts the end point ``f(a, theta)`` for any values
``theta`` of the hidden parameters (friction mu, restitution e, bob mass). :class:`ParameterFit` finds the
maximum-a-posteriori values

    theta_hat = argmin_theta  sum_i |f(a_i, theta) - y_i|^2 / sigma^2  +  sum_j ((u_j - u0_j) / s)^2

over a box, where ``u`` are the parameters mapped to the unit box (log scale for masses), ``u0`` the prior (the
training space's centre) and ``s`` the prior's width. ``sigma`` is the chain's own error (about 1 cm); the prior term
only decides among parameter values that explain the landings equally well (one landing cannot separate a heavier
bob from a more elastic contact; both give the same launch speed, and the planner only needs that speed).

Each attempt's squared error ``r^2`` (in units of sigma^2) enters through the Cauchy loss ``c^2 log(1 + r^2 / c^2)``
(``outlier``: c = 5 by default): quadratic for landings the chain explains, only logarithmic beyond c sigma, so it
still ranks every parameter value by how far off it predicts, but a landing the chain cannot explain at any physics
(a contact no skill knows, an edge path centimetres off) no longer drags the estimate towards whatever physics
moves its prediction closest. An attempt the chain makes no prediction for at some ``theta`` counts there as a
miss c sigma beyond the best prediction of it on the global grid (``r = min_grid r + c``: ``c^2 log 2`` where some
physics explains the landing exactly), where the plain sum of squares would rule that ``theta`` out, even the true
one. So having no prediction never costs less than the best explanation the landing gets. Counted as a flat c-sigma
miss, a landing 5 cm past the farthest prediction of any physics (sigma 1 cm) cost more where the chain explained
it than where it predicted nothing, and the fit settled on physics that predicted none of the landings
(PaddlesVaried-v3; docs/depth.md).

The search is coarse to fine and batched: the objective at every point of a regular grid over the unit box (one
chain call for all grid points and attempts), then ``levels`` zoom grids, each centred on the best point so far and
spanning one spacing of the previous grid either side (one chain call each). With three parameters that is 343
points per level and a final resolution of 1/6 / 3^4 ~ 0.002 of each range in five chain calls; a gradient-based
least-squares polish (scipy) needed ~70 small chain calls for the same fit, 15x slower. Deterministic: no random
numbers.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

Predictor = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""``predict(actions (M, A), theta (M, P)) -> end xy (M, 2)``, one row per (action, parameter) pair."""


@dataclass(frozen=True)
class Parameter:
    """One hidden parameter as the identification sees it.

    Attributes:
        name: e.g. ``"mu"``, ``"restitution"``, ``"bob_mass"``.
        low, high: the search box (the training space extended to the test space).
        prior: the value assumed before any attempt (the training space's centre).
        log: search on a log scale (masses spanning orders of magnitude).
    """

    name: str
    low: float
    high: float
    prior: float
    log: bool = False

    def __post_init__(self):
        if not (self.low < self.high) or not (self.low <= self.prior <= self.high):
            raise ValueError(f"parameter {self.name!r}: need low < high and low <= prior <= high, got "
                             f"({self.low}, {self.high}, prior {self.prior})")
        if self.log and self.low <= 0:
            raise ValueError(f"parameter {self.name!r}: a log-scale parameter needs low > 0, got {self.low}")

    def to_unit(self, v):
        v = np.asarray(v, dtype=np.float64)
        if self.log:
            return (np.log(v) - math.log(self.low)) / (math.log(self.high) - math.log(self.low))
        return (v - self.low) / (self.high - self.low)

    def from_unit(self, u):
        u = np.clip(np.asarray(u, dtype=np.float64), 0.0, 1.0)
        if self.log:
            return np.exp(math.log(self.low) + u * (math.log(self.high) - math.log(self.low)))
        return self.low + u * (self.high - self.low)


class ParameterFit:
    """MAP fit of hidden parameters to observed end points (see the module docstring).

    Args:
        params: the parameters, in the predictor's column order.
        predict: the conditioned chain, ``predict(actions, theta) -> xy``.
        noise: sigma, the chain's end-point error (m; default 0.01).
        prior_width: s, the prior's standard deviation in unit-box coordinates (default 0.5: weak).
        grid: grid points per parameter of the global pass (default: 41 for one parameter, 13 for two, 7 for
            three or more).
        zoom: points per parameter of each zoom level (default: 21 for one parameter, 9 for two, 7 for three or
            more).
        levels: zoom levels after the global grid (default: 2 for one parameter, 3 for two, 4 for three or more).
        outlier: c, the Cauchy loss's scale in units of sigma (default 5; None: the plain sum of squares, and an
            attempt without a prediction rules a ``theta`` out).
    """

    def __init__(self, params: Sequence[Parameter], predict: Predictor, noise: float = 0.01,
                 prior_width: float = 0.5, grid: int | None = None, zoom: int | None = None,
                 levels: int | None = None, outlier: float | None = 5.0):
        if not params:
            raise ValueError("params must name at least one parameter")
        if noise <= 0 or prior_width <= 0:
            raise ValueError(f"noise and prior_width must be positive, got {noise}, {prior_width}")
        if outlier is not None and not (np.isfinite(outlier) and outlier > 0):
            raise ValueError(f"outlier must be a positive number of sigmas or None, got {outlier}")
        self.c2 = None if outlier is None else float(outlier) ** 2
        self.params = tuple(params)
        self.predict = predict
        self.noise = float(noise)
        self.prior_width = float(prior_width)
        p = len(self.params)
        self.grid = int(grid) if grid is not None else (41 if p == 1 else 13 if p == 2 else 7)
        if self.grid < 2:
            raise ValueError(f"grid must be >= 2, got {grid}")
        self.zoom = int(zoom) if zoom is not None else (21 if p == 1 else 9 if p == 2 else 7)
        self.levels = int(levels) if levels is not None else (2 if p == 1 else 3 if p == 2 else 4)
        if self.zoom < 3 or self.levels < 0:
            raise ValueError(f"zoom must be >= 3 and levels >= 0, got {zoom}, {levels}")
        self.u0 = np.array([q.to_unit(q.prior) for q in self.params])
        axes = [np.linspace(0.0, 1.0, self.grid)] * p
        self._grid_u = np.array(list(itertools.product(*axes)))
        self._zoom = np.array(list(itertools.product(*[np.linspace(-1.0, 1.0, self.zoom)] * p)))
        self.evaluations = 0

    # -- coordinates ------------------------------------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        return tuple(q.name for q in self.params)

    @property
    def prior(self) -> np.ndarray:
        return np.array([q.prior for q in self.params])

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        u = np.atleast_2d(u)
        return np.column_stack([q.from_unit(u[:, j]) for j, q in enumerate(self.params)])

    # -- objective --------------------------------------------------------------------------------------------------
    def _end_points(self, actions: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Predicted end points (G, n, 2) for G parameter rows (unit coords) and n actions."""
        g, n = len(u), len(actions)
        theta = np.repeat(self.from_unit(u), n, axis=0)
        acts = np.tile(actions, (g, 1))
        xy = np.asarray(self.predict(acts, theta), dtype=np.float64).reshape(g, n, 2)
        self.evaluations += g * n
        return xy

    def _squared_errors(self, actions, finals, u: np.ndarray) -> np.ndarray:
        """Each attempt's squared error (B, n), in units of sigma^2, at B parameter rows ``u`` (unit coordinates), in
        one batched chain call; ``nan`` where the chain has no prediction."""
        xy = self._end_points(actions, u)                                   # (B, n, 2)
        return np.sum(((xy - finals[None]) / self.noise) ** 2, axis=2)

    def _unexplained(self, grid_errors: np.ndarray) -> np.ndarray:
        """Each attempt's squared error (n,) where the chain has no prediction: (c sigma beyond its best prediction
        on the global grid)^2, c^2 where no grid point predicts it (the module docstring)."""
        finite = np.isfinite(grid_errors)
        best = np.sqrt(np.min(np.where(finite, grid_errors, np.inf), axis=0))
        return np.where(finite.any(axis=0), (best + math.sqrt(self.c2)) ** 2, self.c2)

    def _costs(self, per: np.ndarray, u: np.ndarray, unexplained: np.ndarray | None) -> np.ndarray:
        """The objective at B parameter rows ``u`` from their squared errors ``per`` (B, n)."""
        if self.c2 is None:
            data = np.where(np.all(np.isfinite(per), axis=1), per.sum(axis=1), np.inf)
        else:
            data = (self.c2 * np.log1p(np.where(np.isfinite(per), per, unexplained) / self.c2)).sum(axis=1)
        return data + np.sum(((u - self.u0) / self.prior_width) ** 2, axis=1)

    def cost(self, actions, finals, theta) -> float:
        """The objective (the sum above) at parameter values ``theta`` (P,): a chain call on the global grid too,
        where the chain has no prediction for an attempt at ``theta``."""
        actions, finals = np.atleast_2d(actions), np.atleast_2d(finals)
        u = np.array([q.to_unit(v) for q, v in zip(self.params, np.atleast_1d(theta))])[None]
        per = self._squared_errors(actions, finals, u)
        unexplained = None
        if self.c2 is not None:
            unexplained = (np.zeros(per.shape[1]) if np.isfinite(per).all()
                           else self._unexplained(self._squared_errors(actions, finals, self._grid_u)))
        return float(self._costs(per, u, unexplained)[0])

    # -- fit --------------------------------------------------------------------------------------------------------
    def _observed(self, actions, finals) -> tuple[np.ndarray, np.ndarray]:
        """The attempts with an observed end point: actions (n, A) and finals (n, 2), checked."""
        actions = np.atleast_2d(np.asarray(actions, dtype=np.float64))
        finals = np.atleast_2d(np.asarray(finals, dtype=np.float64))
        if finals.size == 0:
            return actions[:0], finals.reshape(0, 2)
        if len(actions) != len(finals) or finals.shape[1] != 2:
            raise ValueError(f"actions ({actions.shape}) and finals ({finals.shape}) must have one row per attempt "
                             f"and finals two columns (x, y)")
        keep = np.all(np.isfinite(finals), axis=1)
        return actions[keep], finals[keep]

    def _grid_costs(self, actions, finals) -> tuple[np.ndarray, np.ndarray | None]:
        """The objective at every point of the global grid, and the attempts' unexplained errors."""
        per = self._squared_errors(actions, finals, self._grid_u)
        unexplained = None if self.c2 is None else self._unexplained(per)
        return self._costs(per, self._grid_u, unexplained), unexplained

    def plausible(self, actions, finals, within: float, limit: int) -> np.ndarray:
        """Parameter values (M, P) on the global grid whose objective is within ``within`` (in sigma^2 units) of
        the grid's best: the physics that explain the landings about as well as the best does. At most ``limit``
        of them, evenly spaced through the grid's order (for one parameter: from its lowest value to its highest);
        before any landing, the whole grid's spread the same way."""
        if not (np.isfinite(within) and within >= 0) or limit < 1:
            raise ValueError(f"within must be a finite number >= 0 and limit >= 1, got {within}, {limit}")
        actions, finals = self._observed(actions, finals)
        if len(finals) == 0:
            idx = np.arange(len(self._grid_u))
        else:
            cost, _ = self._grid_costs(actions, finals)
            idx = np.flatnonzero(np.isfinite(cost) & (cost <= np.nanmin(cost) + within))
        if len(idx) > limit:
            idx = idx[np.unique(np.round(np.linspace(0, len(idx) - 1, limit)).astype(int))]
        return self.from_unit(self._grid_u[idx])

    def fit(self, actions, finals) -> np.ndarray:
        """MAP parameters (P,) given actions (n, A) and their observed end points (n, 2); the prior if n = 0."""
        actions, finals = self._observed(actions, finals)
        if len(finals) == 0:
            return self.prior.copy()
        cost, unexplained = self._grid_costs(actions, finals)
        i = int(np.argmin(cost))
        best_u, best_c = self._grid_u[i], float(cost[i])
        half = 1.0 / (self.grid - 1)                      # the zoom box's half-width: one grid spacing
        for _ in range(self.levels):
            box = np.clip(best_u + half * self._zoom, 0.0, 1.0)
            cost = self._costs(self._squared_errors(actions, finals, box), box, unexplained)
            i = int(np.argmin(cost))
            if cost[i] < best_c:
                best_u, best_c = box[i], float(cost[i])
            half *= 2.0 / (self.zoom - 1)                 # the new box spans two of the last level's spacings
        return self.from_unit(best_u)[0]
