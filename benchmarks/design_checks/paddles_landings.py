"""Where Paddles-N's chain actions land and how stably: the measurements behind the design checks' ``--reach`` and
``--chaos`` (the command and its figures: :mod:`benchmarks.design_checks.paddles`).

:func:`reach` lands K chain actions of one context (the goal ranges are their p5-p95); :func:`chaos` moves each by
tiny deltas and halves the timestep, to tell whether a landing converges and is not chaotic; :func:`finer` builds
the task with a finer timestep; :func:`share_interval` is a share's 95% Clopper-Pearson interval.
"""
from __future__ import annotations

import math

import numpy as np

from benchmarks.design_checks.chaos import halved
from benchmarks.design_checks.paddles_actions import TASK, Design, FixedPhysics, attempt, chain_actions, flight

def reach(n: int, k: int, seed: int, design: Design = TASK, aimed: bool = False,
          restitution: float | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """``k`` chain actions on the context of ``reset(seed=seed)``: (their landing x, their offsets: each placed
    paddle's x less the x of the paddle above it (paddle 0's for paddle 1), along the direction the ball leaves that
    paddle in, rows per action (how far below and ahead the chain catches the ball), and how many of their episodes
    ended before the ball landed (their x is where it was then)); on ``design``'s task; ``aimed``: the chain actions
    aimed; ``restitution``: on PaddlesVaried with that hidden restitution."""
    if restitution is None:
        env = design.make(n, record_trajectory=True)
    else:
        env = FixedPhysics(design.make(n, record_trajectory=True, physics_space="train"),
                           {"paddle_restitution": float(restitution)})
    env.reset(seed=seed)
    context = env.context
    rng = np.random.default_rng(seed)
    acts = np.array(chain_actions(env, context, k, rng, aimed=aimed)).reshape(-1, n)
    x = env.paddle_x(acts)
    offsets = np.diff(x, axis=1) * np.array(env.facts.paddle_falls[:-1])
    infos = [flight(env, context, a)[1] for a in acts]
    return (np.array([i["final_pos"][0] for i in infos]), offsets,
            sum(i["end_reason"] != "landed" for i in infos))


def finer(n: int, halvings: int, design: Design = TASK, space: str | None = None):
    """Paddles-``n`` of ``design`` (no Panda, recording its flight) with its timestep halved ``halvings`` times (0:
    the design's own); with ``space``, PaddlesVaried-``n`` with its restitution from that physics space."""
    kwargs = {"physics_space": space} if space else {}
    cls = type(design.make(n, **kwargs))
    for _ in range(halvings):
        cls = halved(cls, varied=bool(space))
    return cls(paddles=n, with_panda=False, record_trajectory=True, **kwargs)


def share_interval(hits: int, total: int) -> tuple[float, float]:
    """The 95% Clopper-Pearson interval of a share of ``hits`` in ``total`` (how far a share over this many landings
    can be from the rate of the population they are drawn from)."""
    from scipy.stats import binomtest

    ci = binomtest(hits, total).proportion_ci(0.95)
    return float(ci.low), float(ci.high)


def chaos(n: int, k: int, seed: int, deltas, halvings: int = 0, design: Design = TASK, space: str | None = None,
          seed_step: int | None = None, aimed: bool = False) -> dict:
    """Chaos and convergence over ``k`` chain actions on the context of ``reset(seed=seed)`` (with ``seed_step``:
    one chain action on each of the contexts ``seed + seed_step * i``, i < k, as LaunchBounce's check), on
    ``design``'s task with its timestep halved ``halvings`` times (0: its own): each action moved by each of
    ``deltas`` (a random sign per dimension), and the timestep halved once more; ``space``: on PaddlesVaried, each
    context's restitution from that physics space (``restitution`` in the result: the one context's, or the
    median); ``aimed``: the chain actions aimed."""
    env = finer(n, halvings, design, space)
    rng = np.random.default_rng(seed)
    runs = []                                  # (context, action, its restitution)
    for i in range(1 if seed_step is None else k):
        env.reset(seed=seed + (seed_step or 0) * i)
        context = env.context
        e = env.hidden_physics["paddle_restitution"] if space else math.nan
        found = chain_actions(env, context, k if seed_step is None else 1, rng, aimed=aimed)
        runs += [(context, a, e) for a in found]
    lo, hi = env.action_low, env.action_high
    first = [attempt(env, c, a) for c, a, _ in runs]
    base = np.array([r[1] for r in first])
    moves, other = {}, {}
    for dlt in deltas:
        sign = rng.choice([-1.0, 1.0], size=(len(runs), len(lo)))
        moved = [attempt(env, c, np.clip(a + dlt * sg, lo, hi)) for (c, a, _), sg in zip(runs, sign)]
        moves[dlt] = np.abs(np.array([m[1] for m in moved]) - base)
        other[dlt] = np.array([m[2] != r[2] for m, r in zip(moved, first)], dtype=bool)   # met other paddles
    fine = finer(n, halvings + 1, design, space)
    conv = np.abs(np.array([attempt(fine, c, a)[1] for c, a, _ in runs]) - base)
    out = {"actions": len(runs), "contexts": len({id(c) for c, _, _ in runs}), "moves": moves,
           "other_paddles": other, "halved": conv}
    if space and runs:
        out["restitution"] = float(np.median([e for _, _, e in runs]))
    return out
