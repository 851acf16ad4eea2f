"""Physics-informed MCTS over the action dimensions (the paper's Algorithm 1), plus a batched local refinement.

The tree fixes one action dimension per level: the root's children are ``D + 1`` evenly spaced values of dimension
0 (both bounds included, as in the reference code), each of their children adds a value of dimension 1, and so on;
a node at depth A (the number of action dimensions) is a complete action. One iteration (:meth:`MCTS.iterate`):

* at an expanded node, pick the child maximising UCB1 ``v_a + c * sqrt(log(sum n) / n_a)`` and recurse; update the
  child's running mean ``v_a`` and count ``n_a`` with the value returned (Algorithm 1, lines 5-10);
* at an unexpanded node, expand it: create its ``D + 1`` children, score each with one rollout (``n_a = 1``), and
  return one rollout of the node itself (lines 12-18);
* at a complete action, return its score (lines 1-3).

A *rollout* of a partial action fills the dimensions not yet fixed uniformly at random (with the planner's seeded
generator) and scores the complete action with the scorer: the skill chain plus the GP-UCB correction for the
PhyPlan agent, the real simulator for ``phyplan-sim``. All rollouts of one expansion go to the scorer as one batch.
Every complete action scored is remembered; the planner's result is the best of them (Algorithm 2, lines 4-11).

:func:`refine` is our addition beyond the paper: a batched pattern search around the best action (a grid of
``points`` values per dimension in a box that shrinks by ``shrink`` per round), scored by the same scorer.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

Scorer = Callable[[np.ndarray], np.ndarray]


@dataclass
class _Node:
    prefix: tuple[float, ...]
    values: np.ndarray | None = None      # the child values of the next dimension (None: not expanded)
    v: np.ndarray | None = None           # children's mean rollout values
    n: np.ndarray | None = None           # children's visit counts
    children: dict[int, "_Node"] = field(default_factory=dict)


class MCTS:
    """One search tree for one decision (the tree is rebuilt for every attempt).

    Args:
        scorer: maps actions ``(N, A)`` to scores ``(N,)`` (higher is better); called once per expansion.
        low, high: the action bounds ``(A,)``.
        rng: the numpy generator for the random rollout fills.
        n_children: children per expansion (default 21 = D + 1 with D = 20, the paper's discretisation factor and
            the reference code's ``D + 1`` evenly spaced points).
        c: the UCB1 exploration constant (default 1, the reference code's).
    """

    def __init__(self, scorer: Scorer, low, high, rng: np.random.Generator, n_children: int = 21, c: float = 1.0):
        self.scorer = scorer
        self.low = np.asarray(low, dtype=np.float64)
        self.high = np.asarray(high, dtype=np.float64)
        if self.low.shape != self.high.shape or self.low.ndim != 1 or np.any(self.high < self.low):
            raise ValueError("low and high must be 1-d arrays of equal length with high >= low")
        if n_children < 2:
            raise ValueError(f"n_children must be >= 2, got {n_children}")
        self.rng = rng
        self.n_children = int(n_children)
        self.c = float(c)
        self.dim = len(self.low)
        self.root = _Node(prefix=())
        self.actions: list[np.ndarray] = []
        self.scores: list[np.ndarray] = []
        self.evaluations = 0

    # -- scoring ---------------------------------------------------------------------------------------------------
    def _fill(self, prefixes: np.ndarray) -> np.ndarray:
        """Complete actions from prefixes (N, d): the remaining dimensions uniform at random."""
        n, d = prefixes.shape
        out = np.empty((n, self.dim))
        out[:, :d] = prefixes
        if d < self.dim:
            lo, hi = self.low[d:], self.high[d:]
            out[:, d:] = lo + (hi - lo) * self.rng.random((n, self.dim - d))
        return out

    def _score(self, actions: np.ndarray) -> np.ndarray:
        s = np.asarray(self.scorer(actions), dtype=np.float64).reshape(-1)
        if s.shape[0] != actions.shape[0]:
            raise ValueError(f"scorer returned {s.shape[0]} scores for {actions.shape[0]} actions")
        self.actions.append(actions)
        self.scores.append(s)
        self.evaluations += len(actions)
        return s

    # -- Algorithm 1 ---------------------------------------------------------------------------------------------------
    def _expand(self, node: _Node) -> float:
        d = len(node.prefix)
        node.values = np.linspace(self.low[d], self.high[d], self.n_children)
        prefix = np.asarray(node.prefix, dtype=np.float64)
        child_prefixes = np.column_stack([np.tile(prefix, (self.n_children, 1)), node.values]) if d else \
            node.values[:, None]
        batch = np.vstack([self._fill(child_prefixes), self._fill(prefix[None, :] if d else np.zeros((1, 0)))])
        s = self._score(batch)
        node.v = s[:-1].copy()
        node.n = np.ones(self.n_children)
        return float(s[-1])

    def _visit(self, node: _Node) -> float:
        d = len(node.prefix)
        if d == self.dim:                                   # terminal: a complete action
            return float(self._score(np.asarray(node.prefix, dtype=np.float64)[None, :])[0])
        if node.values is None:                             # expansion + simulation
            return self._expand(node)
        total = node.n.sum()                                # selection (UCB1)
        ucb = node.v + self.c * np.sqrt(math.log(total) / node.n)
        i = int(np.argmax(ucb))
        child = node.children.get(i)
        if child is None:
            child = node.children[i] = _Node(prefix=node.prefix + (float(node.values[i]),))
        rv = self._visit(child)
        node.v[i] = (node.v[i] * node.n[i] + rv) / (node.n[i] + 1)
        node.n[i] += 1
        return rv

    def iterate(self) -> float:
        """One MCTS iteration from the root; returns the value it propagated."""
        return self._visit(self.root)

    def run(self, iterations: int) -> tuple[np.ndarray, float]:
        """``iterations`` iterations (K); returns the best complete action scored so far and its score."""
        for _ in range(int(iterations)):
            self.iterate()
        return self.best()

    def best(self) -> tuple[np.ndarray, float]:
        if not self.scores:
            raise RuntimeError("no action scored yet: run at least one iteration")
        acts = np.vstack(self.actions)
        sc = np.concatenate(self.scores)
        i = int(np.argmax(sc))
        return acts[i].copy(), float(sc[i])


MAX_REFINE_POINTS = 1000   # a round's grid beyond this many points (more than 3 dimensions) becomes a random sample


def refine(scorer: Scorer, start: np.ndarray, start_score: float, low, high, width, points: int = 11,
           rounds: int = 4, shrink: float = 0.3, rng: np.random.Generator | None = None,
           max_points: int = MAX_REFINE_POINTS) -> tuple[np.ndarray, float, int]:
    """Batched pattern search around ``start`` (our addition beyond the paper).

    Each round scores a grid of ``points`` values per dimension spanning ``start +- width`` (clipped to the
    bounds) in one scorer call, moves to the best point if it beats the current one, and shrinks the box by
    ``shrink``. A grid of more than ``max_points`` points (``points ** A``: 9^5 = 59,049 in five dimensions) is
    replaced by ``max_points`` uniform draws of ``rng`` in the same box, plus its centre and its ``2 A`` axis
    extremes. Returns ``(best action, its score, number of actions scored)``.
    """
    low = np.asarray(low, dtype=np.float64)
    high = np.asarray(high, dtype=np.float64)
    best = np.asarray(start, dtype=np.float64).copy()
    best_score = float(start_score)
    w = np.broadcast_to(np.asarray(width, dtype=np.float64), best.shape).copy()
    a = len(best)
    if int(points) ** a <= max_points:
        offsets = np.linspace(-1.0, 1.0, int(points))
        mesh = np.stack(np.meshgrid(*([offsets] * a), indexing="ij"), axis=-1).reshape(-1, a)
    else:
        if rng is None:
            raise ValueError(f"a refinement grid of {int(points)}^{a} points needs rng for its random sample")
        mesh = np.vstack([np.zeros((1, a)), np.eye(a), -np.eye(a), rng.uniform(-1.0, 1.0, (int(max_points), a))])
    n_scored = 0
    for _ in range(int(rounds)):
        cand = np.clip(best + mesh * w, low, high)
        s = np.asarray(scorer(cand), dtype=np.float64).reshape(-1)
        n_scored += len(cand)
        i = int(np.argmax(s))
        if s[i] > best_score:
            best, best_score = cand[i].copy(), float(s[i])
        w = w * shrink
    return best, best_score, n_scored
