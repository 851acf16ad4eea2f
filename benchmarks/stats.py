"""The one confidence interval of the benchmarks: a Student-t interval over contexts.

Every table with an interval (the ``make bench`` summary, ``phyplan_eval``'s regret table, the DQN evaluation) uses
:func:`mean_ci`. The unit is the context, not the cell: the run seeds of one context share its difficulty, so a
context's cells are first averaged over the seeds (:func:`per_context`), and the interval is
``mean ± t(0.5 + level/2, n-1) · sd / sqrt(n)`` over the n context means (sd with ``ddof=1``). With one context there
is no interval (NaN).
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np


def mean_ci(per_context: np.ndarray, level: float = 0.95) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean and a Student-t confidence interval over the first axis (one row per context).

    Returns ``(mean, low, high)``; low and high are NaN with fewer than two rows.
    """
    if not 0.0 < float(level) < 1.0:
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    x = np.asarray(per_context, dtype=np.float64)
    n = x.shape[0]
    if n == 0:
        raise ValueError("no contexts to summarise")
    mean = x.mean(axis=0)
    if n < 2:
        nan = np.full_like(mean, np.nan)
        return mean, nan, nan
    from scipy import stats

    half = stats.t.ppf(0.5 + level / 2, n - 1) * x.std(axis=0, ddof=1) / math.sqrt(n)
    return mean, mean - half, mean + half


def half_width(per_context: np.ndarray, level: float = 0.95) -> np.ndarray:
    """The half-width of :func:`mean_ci` (for ``mean ± half`` tables); NaN with fewer than two rows."""
    mean, low, _ = mean_ci(per_context, level)
    return mean - low


def per_context(values: Sequence, contexts: Sequence[int]) -> tuple[list[int], np.ndarray]:
    """Average the rows (cells) of each context over its run seeds: ``(sorted context ids, one mean row each)``.

    ``values`` has one row (a number or a vector, e.g. a regret curve) per cell and ``contexts`` the cell's context;
    a context's rows are averaged in the order they come.
    """
    x = np.asarray(values, dtype=np.float64)
    ctx = np.asarray(contexts)
    if len(x) != len(ctx):
        raise ValueError(f"values has {len(x)} rows but contexts has {len(ctx)} entries")
    if len(x) == 0:
        raise ValueError("no cells to summarise")
    ids = sorted(set(ctx.tolist()))
    return ids, np.array([x[ctx == c].mean(axis=0) for c in ids])


def regret_per_context(records: Sequence) -> tuple[list[int], np.ndarray]:
    """Regret curves of attempt records (``seed``, ``context``, ``attempt``, ``regret``), averaged per context.

    Returns ``(sorted context ids, array (contexts, K))``, ready for :func:`mean_ci`. Every cell must have the same
    attempts ``1..K``.
    """
    cells: dict[tuple[int, int], dict[int, float]] = {}
    for r in records:
        cells.setdefault((r.seed, r.context), {})[r.attempt] = r.regret
    if not cells:
        raise ValueError("no records to summarise")
    k = max(max(c) for c in cells.values())
    short = [key for key, c in cells.items() if set(c) != set(range(1, k + 1))]
    if short:
        raise ValueError(f"cells (seed, context) {short[:3]} lack some of the attempts 1..{k}")
    keys = sorted(cells)
    return per_context([[cells[key][a] for a in range(1, k + 1)] for key in keys], [c for _, c in keys])
