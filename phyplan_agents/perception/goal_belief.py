"""Where the goal can be when the picture does not show it: a belief on a grid of goal centres.

Three sources, multiplied cell by cell (5 mm cells):

1. **the task's goal distribution** (:func:`sampler_prior`): goals drawn with the env's own ``sample_context`` (a
   private copy that is never reset, a fixed seed: the task's declared sampler, not this context), as a smoothed
   histogram. It says where goals of this task lie at all (e.g. Bridge: 0.9-1.4 m from the table centre, in the
   first quadrant).
2. **what the picture shows** (:func:`carve`): every ground point the camera sees that is not red is not under the
   goal box. Each cell's point at the goal floor's height is projected into the picture; if the pixel shows that
   point (or something behind it) and is not red, no goal box covers the cell. A goal centre is possible only if no
   such cell lies inside its box (a maximum filter of the box's inner size), and if the box holds every red pixel
   (a partly seen goal: the red points' bounds). Cells hidden by something in front (the Bridge plank) or out of
   the picture stay possible.
3. **the rewards** (:meth:`GoalBelief.update`): an attempt that ended at ``p`` with reward ``r`` puts the goal on
   its Apollonius circle ``|g - p| = (1 - r) |g - s|`` (:mod:`.apollonius`); each cell is weighted by a Gaussian of
   its residual (``sigma``: the landing's error), truncated at 4 sigma so that one bad landing cannot rule the
   true cell out.

:meth:`GoalBelief.aim` picks the point to aim at: among the plausible cells (smoothed weight at least 30% of the
largest) the one with the highest expected reward under the belief, leaving out the cells an attempt's reward put
nearer its landing than half the distance it measured. Aiming at a plausible goal either hits it or draws a new
circle that rules it out, where the expected-reward optimum alone can sit in the middle of a ring (or between two
arcs) and learn nothing, attempt after attempt.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
from scipy import ndimage

from phyplan_envs import assets

CELL = 0.005          # m: grid spacing of goal centres
DEPTH_TOL = 0.01      # m: a pixel "shows" a point if its depth is at most this much nearer than the point
BOX_MARGIN = 0.012    # m: the box's outer 12 mm (1.5 pixels on the ground) are left out of the carving
RED_MARGIN = 0.008    # m: slack of the red points' bounds
PLAUSIBLE = 0.3       # aim only at cells whose smoothed weight is at least this share of the largest
CONFIDENT = 0.02      # m: the goal counts as found when this radius around the aim holds MASS of the belief
MASS = 0.9


@dataclass
class GoalGrid:
    """A grid of goal centres: ``origin`` (the first cell's centre), ``shape`` (rows along y, columns along x)."""

    origin: np.ndarray
    shape: tuple[int, int]
    cell: float = CELL

    def centres(self) -> np.ndarray:
        """Cell centres (H, W, 2)."""
        ys = self.origin[1] + self.cell * np.arange(self.shape[0])
        xs = self.origin[0] + self.cell * np.arange(self.shape[1])
        gx, gy = np.meshgrid(xs, ys)
        return np.stack([gx, gy], axis=-1)


def sampler_prior(env: Any, samples: int = 20000, seed: int = 0, blur: float = 0.015,
                  cell: float = CELL) -> tuple[GoalGrid, np.ndarray]:
    """The task's goal distribution on a grid: ``samples`` goals of ``env.sample_context`` (generator ``seed``),
    histogrammed and smoothed by a Gaussian of ``blur`` m; returns the grid and the density (H, W), zero where it
    is below 0.1% of its peak."""
    rng = np.random.default_rng(seed)
    goals = np.array([np.asarray(env.sample_context(rng)["goal"], dtype=np.float64)[:2] for _ in range(samples)])
    pad = assets.GOAL_HALF + 3 * blur
    lo, hi = goals.min(axis=0) - pad, goals.max(axis=0) + pad
    shape = (int(np.ceil((hi[1] - lo[1]) / cell)) + 1, int(np.ceil((hi[0] - lo[0]) / cell)) + 1)
    grid = GoalGrid(lo, shape, cell)
    ij = np.rint((goals - lo) / cell).astype(int)
    hist = np.zeros(shape)
    np.add.at(hist, (ij[:, 1], ij[:, 0]), 1.0)
    dens = ndimage.gaussian_filter(hist, blur / cell, mode="constant")
    dens[dens < 1e-3 * dens.max()] = 0.0
    return grid, dens / dens.sum()


def carve(view, grid: GoalGrid, support: np.ndarray) -> tuple[np.ndarray, dict[str, Any]]:
    """Goal centres the picture allows (module docstring, 2): a boolean (H, W) within ``support``.

    ``view`` is a :class:`~phyplan_agents.perception.reads.RGBDView`. The goal stands on the most common height of
    the uncoloured surfaces seen over ``support`` (the ground, or Slide's table top; a few red pixels of a hidden
    box may be its wall tops, 2 cm higher, so they do not set it)."""
    cam, depth, red = view.cam, view.depth, view.masks["red"]
    pts = view.points
    centres = grid.centres()
    notes: dict[str, Any] = {"red_pixels": int(red.sum())}
    base = _support_height(view, grid, support)
    notes["floor_z"] = base
    h, w = depth.shape
    cells = np.concatenate([centres, np.full(centres.shape[:2] + (1,), base + assets.GOAL_FLOOR_THICK)], axis=-1)
    u, v, zc = cam.project(cells)
    inside = (zc > 0) & (u >= 0) & (u < w) & (v >= 0) & (v < h)
    i = np.clip(np.floor(v).astype(int), 0, h - 1)
    j = np.clip(np.floor(u).astype(int), 0, w - 1)
    seen_empty = inside & (depth[i, j] >= zc - DEPTH_TOL) & ~red[i, j]
    notes["seen_cells"] = int(seen_empty.sum())
    k = 2 * int((assets.GOAL_HALF - BOX_MARGIN) / grid.cell) + 1
    possible = ~ndimage.maximum_filter(seen_empty, size=k, mode="constant", cval=False) & (support > 0)
    if red.any():
        rp = pts[red]
        rp = rp[rp[:, 2] <= base + assets.GOAL_WALL_HEIGHT + 0.01, :2]
        if len(rp):
            lo = rp.max(axis=0) - assets.GOAL_HALF - RED_MARGIN
            hi = rp.min(axis=0) + assets.GOAL_HALF + RED_MARGIN
            if np.all(lo <= hi):
                possible &= np.all((centres >= lo) & (centres <= hi), axis=-1)
            else:
                notes["red_inconsistent"] = True       # more red than one box: the bounds are not used
    notes["possible_cells"] = int(possible.sum())
    return possible, notes


def _support_height(view, grid: GoalGrid, support: np.ndarray) -> float:
    """The most common height (2 mm bins) of uncoloured surfaces seen over the support; 0 (the ground) if none."""
    pts = view.points.reshape(-1, 3)
    plain = ~(view.masks["red"] | view.masks["green"] | view.masks["blue"]).reshape(-1)
    ij = np.rint((pts[:, :2] - grid.origin) / grid.cell).astype(int)
    ok = plain & (ij[:, 0] >= 0) & (ij[:, 0] < grid.shape[1]) & (ij[:, 1] >= 0) & (ij[:, 1] < grid.shape[0])
    ok[ok] = support[ij[ok, 1], ij[ok, 0]] > 0
    z = pts[ok, 2]
    if len(z) < 20:
        return 0.0
    hist, edges = np.histogram(z, bins=np.arange(z.min(), z.max() + 0.004, 0.002))
    return float(edges[np.argmax(hist)] + 0.001)


class GoalBelief:
    """Weights over goal centres (module docstring).

    Args:
        grid: the cells.
        prior: prior weights (H, W), zero where no goal can be.
        start: the object's start xy (the reward's reference point).
        sigma: the landing's error (m) in :meth:`update`.
    """

    def __init__(self, grid: GoalGrid, prior: np.ndarray, start, sigma: float = 0.02):
        if sigma <= 0:
            raise ValueError(f"sigma must be positive, got {sigma}")
        self.grid = grid
        self.start = np.asarray(start, dtype=np.float64).reshape(2)
        self.sigma = float(sigma)
        self._index = np.nonzero(prior > 0)
        if len(self._index[0]) == 0:
            raise ValueError("the prior has no cell with positive weight")
        self.cells = grid.centres()[self._index]                 # (K, 2)
        self.log_w = np.log(prior[self._index])
        self._to_start = np.linalg.norm(self.cells - self.start, axis=1)
        self._tried = np.zeros(len(self.cells), dtype=bool)     # cells an attempt's reward rules out as aims
        self.updates = 0

    @classmethod
    def from_view(cls, view, grid: GoalGrid, density: np.ndarray, start, sigma: float = 0.02):
        """Prior times what the picture allows (:func:`carve`); the prior alone if the picture allows no cell.
        Returns the belief and the carving's notes."""
        possible, notes = carve(view, grid, density)
        if not possible.any():
            notes["carving_dropped"] = True
            possible = density > 0
        return cls(grid, np.where(possible, density, 0.0), start, sigma), notes

    # -- evidence ---------------------------------------------------------------------------------------------------
    def update(self, landing, reward: float, sigma: float | None = None) -> None:
        """One attempt that ended at ``landing`` (2,) with ``reward`` (ignored if either is not finite); ``sigma``:
        the landing's error (default the belief's)."""
        p = np.asarray(landing, dtype=np.float64).reshape(2)
        if not (np.all(np.isfinite(p)) and np.isfinite(reward)):
            return
        to_p = np.linalg.norm(self.cells - p, axis=1)
        res = to_p - (1.0 - float(reward)) * self._to_start
        self.log_w = self.log_w - 0.5 * np.minimum((res / (sigma or self.sigma)) ** 2, 16.0)
        # the middle of the circle: the goal lies (1 - r) d0 from p, so cells nearer p than half that are no aims
        # (their weight may stay plausible within sigma, and aiming there again would learn nothing)
        self._tried |= to_p < 0.5 * (1.0 - float(reward)) * self._to_start
        self.updates += 1

    def seen(self, goal, sd: float = 0.004) -> None:
        """A picture showed the goal at ``goal`` (2,): a Gaussian of ``sd`` m around it."""
        g = np.asarray(goal, dtype=np.float64).reshape(2)
        if np.all(np.isfinite(g)):
            self.log_w = self.log_w - 0.5 * np.sum((self.cells - g) ** 2, axis=1) / sd ** 2

    # -- summaries --------------------------------------------------------------------------------------------------
    @property
    def weights(self) -> np.ndarray:
        w = np.exp(self.log_w - self.log_w.max())
        return w / w.sum()

    @property
    def mean(self) -> np.ndarray:
        return self.weights @ self.cells

    @property
    def spread(self) -> float:
        """Root mean square distance of the belief from its mean (m)."""
        w = self.weights
        return float(np.sqrt(w @ np.sum((self.cells - w @ self.cells) ** 2, axis=1)))

    def mass_within(self, point, radius: float) -> float:
        return float(self.weights[np.linalg.norm(self.cells - np.asarray(point), axis=1) <= radius].sum())

    def aim(self, radius: float = CONFIDENT, max_candidates: int = 1200,
            max_support: int = 2000) -> tuple[np.ndarray, float]:
        """The point to aim at and the belief's mass within ``radius`` of it (module docstring)."""
        w = self.weights
        img = np.zeros(self.grid.shape)
        img[self._index] = w
        smooth = ndimage.gaussian_filter(img, 0.01 / self.grid.cell, mode="constant")[self._index]
        cand = np.nonzero((smooth >= PLAUSIBLE * smooth.max()) & ~self._tried)[0]
        if len(cand) == 0:
            cand = np.nonzero(smooth >= PLAUSIBLE * smooth.max())[0]
        cand = cand[np.argsort(-smooth[cand], kind="stable")[:max_candidates]]
        sup = np.argsort(-w, kind="stable")[:max_support]
        ws = w[sup] / w[sup].sum()
        d = np.linalg.norm(self.cells[cand][:, None] - self.cells[sup][None], axis=2)     # (C, S)
        expected = 1.0 - (d / np.maximum(self._to_start[sup], 1e-6)) @ ws
        target = self.cells[cand[int(np.argmax(expected))]]
        return target.copy(), self.mass_within(target, radius)


def landing_of(obs: Mapping[str, Any] | None, camera, facts, task: str) -> np.ndarray | None:
    """Where the object ended, read from the picture after an attempt (``None`` if not readable)."""
    from .reads import PerceptionError, locate_object

    if obs is None:
        return None
    kind = "ball" if task.startswith(("launch", "bounce")) else "puck"
    radius = facts.ball_radius if kind == "ball" else facts.puck_radius
    try:
        return locate_object(obs, camera, kind, radius, getattr(facts, "puck_half_height", 0.0))[:2]
    except (PerceptionError, ValueError):
        return None
