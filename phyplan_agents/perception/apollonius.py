"""The goal from rewards: where must the goal be for the attempts so far to have scored what they did?

An attempt that ends at ``p`` scores ``r = 1 - |g - p| / |g - s|`` (``s`` the object's start, ``g`` the goal), so
the goal lies on the *Apollonius circle* of that attempt,

    |g - p| = rho |g - s|,      rho = 1 - r,

the points whose distances from ``p`` and ``s`` have the ratio ``rho`` (for ``rho != 1`` a circle with centre
``(p - rho^2 s) / (1 - rho^2)`` and radius ``rho |p - s| / |1 - rho^2|``; for ``rho = 1`` the perpendicular bisector
of ``p s``). Two attempts leave at most two points, three in general one. :func:`solve_goal` finds the goal by least
squares on the residuals ``|g - p_k| - rho_k |g - s|`` (metres: the landing's error, which is what the
chain-predicted or picture-read landings get wrong), Levenberg-Marquardt from the guess and from the pairwise
intersections of the first circles.

Degenerate input never gives NaN: with one attempt the answer is the point of its circle nearest the guess and
``determined`` is false; when the start and every landing lie on one line, the goal's mirror image in that line fits
as well, so both are returned (the one nearer the guess first) and ``determined`` is false; rows with non-finite
landings or rewards are left out.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

_EPS = 1e-12


@dataclass
class GoalFit:
    """The least-squares goal.

    Attributes:
        goal: the estimate (2,), always finite.
        rms: root mean square of the residuals ``|g - p_k| - rho_k |g - s|`` at it (m).
        determined: false when the attempts leave a whole curve (one attempt) or a mirror pair (collinear
            landings), or the fit is singular; then ``goal`` is the candidate nearest the guess.
        alternatives: other points that fit as well (e.g. the mirror image), nearest the guess first.
        attempts: the attempts used (finite rows).
    """

    goal: np.ndarray
    rms: float
    determined: bool
    alternatives: list[np.ndarray] = field(default_factory=list)
    attempts: int = 0


def residuals(goal, start, landings, rewards) -> np.ndarray:
    """``|g - p_k| - (1 - r_k) |g - s|`` (n,) for one goal (2,)."""
    g = np.asarray(goal, dtype=np.float64)
    p = np.atleast_2d(np.asarray(landings, dtype=np.float64))
    rho = 1.0 - np.asarray(rewards, dtype=np.float64).reshape(-1)
    return np.linalg.norm(g - p, axis=1) - rho * np.linalg.norm(g - np.asarray(start, dtype=np.float64))


def circle(start, landing, reward) -> tuple[np.ndarray, float] | None:
    """Centre and radius of the Apollonius circle of one attempt (``None`` for ``rho = 1``: a line)."""
    s, p = np.asarray(start, dtype=np.float64), np.asarray(landing, dtype=np.float64)
    rho = 1.0 - float(reward)
    k = 1.0 - rho * rho
    if abs(k) < 1e-9:
        return None
    return (p - rho * rho * s) / k, abs(rho * np.linalg.norm(p - s) / k)


def intersect(c1: np.ndarray, r1: float, c2: np.ndarray, r2: float) -> list[np.ndarray]:
    """Intersections of two circles; if they miss each other, the point of closest approach on the centre line."""
    d_vec = c2 - c1
    d = float(np.linalg.norm(d_vec))
    if d < _EPS:
        return []
    e = d_vec / d
    a = (r1 * r1 - r2 * r2 + d * d) / (2 * d)
    h2 = r1 * r1 - a * a
    if h2 <= 0:                                       # tangent or apart: the nearest points' middle
        a = float(np.clip(a, -r1, r1))
        return [c1 + a * e]
    h = np.sqrt(h2)
    n = np.array([-e[1], e[0]])
    return [c1 + a * e + h * n, c1 + a * e - h * n]


def _jacobian(g, s, p, rho) -> np.ndarray:
    dp = g - p
    ds = g - s
    np_ = np.maximum(np.linalg.norm(dp, axis=1), _EPS)[:, None]
    ns = max(float(np.linalg.norm(ds)), _EPS)
    return dp / np_ - rho[:, None] * ds[None] / ns


def _levenberg_marquardt(g0, s, p, rho, iterations: int = 60) -> np.ndarray:
    g = np.asarray(g0, dtype=np.float64).copy()
    lam = 1e-3
    f = np.linalg.norm(g - p, axis=1) - rho * np.linalg.norm(g - s)
    cost = float(f @ f)
    for _ in range(iterations):
        j = _jacobian(g, s, p, rho)
        a = j.T @ j
        b = -j.T @ f
        try:
            step = np.linalg.solve(a + lam * (np.trace(a) / 2 + 1e-9) * np.eye(2), b)
        except np.linalg.LinAlgError:
            break
        if not np.all(np.isfinite(step)):
            break
        g_new = g + step
        f_new = np.linalg.norm(g_new - p, axis=1) - rho * np.linalg.norm(g_new - s)
        c_new = float(f_new @ f_new)
        if c_new < cost:
            g, f, cost = g_new, f_new, c_new
            lam = max(lam / 3, 1e-9)
            if np.linalg.norm(step) < 1e-9:
                break
        else:
            lam *= 4
            if lam > 1e8:
                break
    return g


def solve_goal(start, landings, rewards, guess, tolerance: float = 1e-4) -> GoalFit:
    """The goal that best explains the attempts (module docstring).

    Args:
        start: the object's start xy (2,).
        landings: where the attempts ended (n, 2): read from the picture after the attempt, or predicted.
        rewards: their rewards (n,).
        guess: a point near the goal (2,), e.g. the prior's centre; breaks the ties degenerate input leaves.
        tolerance: minima whose rms residual is within ``1.5 x`` the best one's plus this (m) fit equally well.
    """
    s = np.asarray(start, dtype=np.float64).reshape(2)
    g0 = np.asarray(guess, dtype=np.float64).reshape(2)
    if not (np.all(np.isfinite(s)) and np.all(np.isfinite(g0))):
        raise ValueError(f"start and guess must be finite, got {s} and {g0}")
    p = np.asarray(landings, dtype=np.float64).reshape(-1, 2)
    r = np.asarray(rewards, dtype=np.float64).reshape(-1)
    if len(p) != len(r):
        raise ValueError(f"one reward per landing: got {len(p)} landings and {len(r)} rewards")
    keep = np.all(np.isfinite(p), axis=1) & np.isfinite(r)
    p, r = p[keep], r[keep]
    if len(p) == 0:
        return GoalFit(g0.copy(), 0.0, False, [], 0)
    rho = np.maximum(1.0 - r, 0.0)

    seeds = [g0] + [g0 + d for d in 0.03 * np.array([[1, 0], [-1, 0], [0, 1], [0, -1]])]   # off any symmetry line
    circles = [c for c in (circle(s, p[k], r[k]) for k in range(min(len(p), 4))) if c is not None]
    for i in range(len(circles)):
        for j in range(i + 1, len(circles)):
            seeds += intersect(*circles[i], *circles[j])
    found: list[tuple[float, np.ndarray]] = []
    for seed in seeds:
        g = _levenberg_marquardt(seed, s, p, rho)
        if not np.all(np.isfinite(g)):
            continue
        f = np.linalg.norm(g - p, axis=1) - rho * np.linalg.norm(g - s)
        found.append((float(np.sqrt(np.mean(f * f))), g))
    if not found:
        return GoalFit(g0.copy(), float("inf"), False, [], len(p))
    best_rms = min(c for c, _ in found)
    good = [(c, g) for c, g in found if c <= 1.5 * best_rms + tolerance]
    distinct: list[tuple[float, np.ndarray]] = []           # one per minimum, nearest the guess first
    for c, g in sorted(good, key=lambda cg: float(np.linalg.norm(cg[1] - g0))):
        if all(np.linalg.norm(g - q) > 5e-3 for _, q in distinct):
            distinct.append((c, g))
    rms, goal = distinct[0]
    sv = np.linalg.svd(_jacobian(goal, s, p, rho), compute_uv=False)
    determined = len(p) >= 2 and len(distinct) == 1 and sv[-1] > 1e-3 * max(sv[0], _EPS)
    return GoalFit(goal.copy(), float(rms), bool(determined), [q.copy() for _, q in distinct[1:]], len(p))
