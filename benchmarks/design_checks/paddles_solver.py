"""Paddles-N's certificate solver (:func:`solve`) and its "every paddle matters" check (:func:`paddle_matters`),
on many contexts (:func:`solvable`): ``python -m benchmarks.design_checks.paddles --solvable C`` (that module's
docstring gives the commands; figures in docs/depth.md)."""
from __future__ import annotations

import math

import numpy as np

from benchmarks.design_checks.paddles_actions import TASK, Design, attempt, chain_actions

SOLVED = 0.95
MATTERS = 0.9
SHIFT = 0.2              # m: the paddle shift of the "every paddle matters" check


def solve(env, context, rng, starts: int = 3, sweeps: int = 6,
          chain_only: bool = False, aimed: bool = False) -> tuple[float, np.ndarray, int]:
    """The certificate solver: a chain action, then a coordinate search from it (each dimension in turn over 9
    points in a window that halves every sweep); again from a new chain action, up to ``starts`` times, until the
    reward reaches 0.995. With ``chain_only`` the search keeps only chain actions (whose ball meets every paddle).
    ``aimed``: the chain actions aimed (:func:`~benchmarks.design_checks.paddles_actions.aimed_action`). Returns
    (best reward, its action, attempts)."""
    lo, hi = env.action_low, env.action_high
    calls = 0
    best_r, best_a = -math.inf, lo.copy()
    for _ in range(starts):
        found = chain_actions(env, context, 1, rng, aimed=aimed)
        calls += 1
        if not found:
            continue
        a = found[0]
        r = attempt(env, context, a)[0]
        calls += 1
        width = np.array([0.04] + [0.1] * (len(lo) - 1))
        for _ in range(sweeps):
            for d in range(len(lo)):
                for x in np.linspace(a[d] - width[d], a[d] + width[d], 9):
                    b = a.copy()
                    b[d] = np.clip(x, lo[d], hi[d])
                    rb, _, met = attempt(env, context, b)
                    calls += 1
                    if rb > r and (all(met) or not chain_only):
                        r, a = rb, b
            if r >= 0.995:
                break
            width = width / 2
        if r > best_r:
            best_r, best_a = r, a
        if best_r >= 0.995:
            break
    return best_r, best_a, calls


def alone_move(env, d: int, s: float) -> np.ndarray:
    """The change of action values d and d + 1 (placed paddle d's offset and the next one's) that moves paddle d alone
    on v1/v2: paddle i sits at ``x[i - 1] + falls[i - 1] * offset[i]`` (``env.facts.paddle_falls``), so offset d += s
    moves paddle d's x by ``falls[d - 1] * s`` and the paddles below with it, and offset d + 1 -= ``falls[d - 1] *
    falls[d] * s`` puts paddle d + 1 and the ones below it back (the faces fall alternately, so both offsets move by
    +s: each is measured along the way the face of the paddle above it falls)."""
    falls = env.facts.paddle_falls
    return np.array([s, -falls[d - 1] * falls[d] * s if d + 1 < len(falls) else 0.0])


def paddle_matters(env, context, action, relative: bool = False, shift: float = SHIFT,
                   alone: bool = False) -> list[float]:
    """Per placed paddle, the best reward after moving its action value by -``shift`` or +``shift`` (default
    :data:`SHIFT`) from ``action``: only
    moves the action bounds leave whole count (a move the bound cuts short is not a SHIFT move; the ranges are at
    least 0.6 m, so one side always fits). On v1 the value is the paddle's offset from the one above, so the paddles
    below move with it; on v0 it is the paddle's x. With ``relative`` (a study on v0 of placing each paddle relative
    to the one above), it and every paddle below it move together; NaN where neither side fits. With ``alone`` (v1/v2)
    the paddle moves alone: its x by +-``shift`` while every other paddle stays, i.e. its offset by s and the next
    paddle's offset (if any) by what keeps that paddle's x (:func:`alone_move`); both must stay in their bounds."""
    if relative and alone:
        raise ValueError("paddle_matters: relative and alone are different moves; give one")
    lo, hi = env.action_low, env.action_high
    out = []
    for d in range(1, len(action)):
        rs = []
        moved = slice(d, None) if relative else slice(d, d + 2) if alone else slice(d, d + 1)
        for s in (-shift, shift):
            b = action.copy()
            if alone:
                b[moved] = action[moved] + alone_move(env, d, s)[:len(action) - d]
            else:
                b[moved] = action[moved] + s
            if np.all(lo[moved] <= b[moved]) and np.all(b[moved] <= hi[moved]):
                rs.append(attempt(env, context, b)[0])
        out.append(max(rs) if rs else math.nan)
    return out


def solvable(n: int, contexts: int, seed: int, step: int, starts: int = 3,
             goal_range: tuple[float, float] | None = None, design: Design = TASK,
             chain_only: bool = False, relative: bool = False, aimed: bool = False, shift: float = SHIFT,
             alone: bool = False) -> dict:
    """The certificate solver and the "every paddle matters" check on ``contexts`` contexts (module docstring).
    With ``goal_range`` ``(lo, hi)``, context i's goal is put at x = U(lo, hi) (``default_rng(seed + step * i)``'s
    first draw), y = 0, through ``reset(options={"goal": ...})``: a study of other goal samplers. ``design``: the
    task's, or a study's (other paddles, restitution, timestep). ``chain_only``: :func:`solve`'s; ``relative``,
    ``shift`` and ``alone``: :func:`paddle_matters`'s; ``aimed``: :func:`solve`'s. Also returns,
    per solved context, whether the solution's ball touches every paddle (``chained``; face, edge or corner), and per
    placed paddle whether no move fitted the bounds (``unfit``: its check gave NaN, so it does not matter) and the
    check's value (``moved``: the best reward after the move)."""
    env = design.make(n, record_trajectory=True)
    rewards, calls, matters, per_paddle, chained, moved = [], [], [], [], [], []
    for i in range(contexts):
        goal = None
        if goal_range is not None:
            goal = [float(np.random.default_rng(seed + step * i).uniform(*goal_range)), 0.0]
        env.reset(seed=seed + step * i, options=None if goal is None else {"goal": goal})
        context = env.context
        rng = np.random.default_rng(seed + step * i)
        r, a, c = solve(env, context, rng, starts=starts, chain_only=chain_only, aimed=aimed)
        rewards.append(r)
        calls.append(c)
        if n > 1 and r >= SOLVED:
            shifted = paddle_matters(env, context, a, relative, shift, alone=alone)
            per_paddle.append(np.array(shifted) < MATTERS)
            moved.append(shifted)
            matters.append(bool(np.all(np.array(shifted) < MATTERS)))   # a NaN (no move fits) never matters
            chained.append(all(attempt(env, context, a, board=True)[2]))
    return {"rewards": np.array(rewards), "calls": np.array(calls), "matters": np.array(matters, dtype=bool),
            "chained": np.array(chained, dtype=bool),
            "per_paddle": np.array(per_paddle, dtype=bool).reshape(len(per_paddle), max(n - 1, 0)),
            "moved": np.array(moved, dtype=float).reshape(len(moved), max(n - 1, 0)),
            "unfit": np.isnan(np.array(moved, dtype=float).reshape(len(moved), max(n - 1, 0)))}
