"""How chaotic a task's outcome is: how far the final position moves when the action moves by a tiny amount.

Used by ``python -m benchmarks.robot_check --sensitivity`` (the floor under robot-mode mismatches: no release is
exactly the kinematic one) and ``python -m benchmarks.design_checks.bridge --chaos`` (why Bridge-v1 has a block).
"""
from __future__ import annotations

import numpy as np


def random_actions(env, actions: int, seed: int) -> np.ndarray:
    """``actions`` uniform random actions in ``env``'s action box (``numpy.random.default_rng(seed)``): action i is
    tried on the context of ``reset(seed=i)``, as in ``robot_check``."""
    lo, hi = env.action_space.low.astype(np.float64), env.action_space.high.astype(np.float64)
    return lo + (hi - lo) * np.random.default_rng(seed).random((actions, len(lo)))


def final_positions(env, acts: np.ndarray, delta: float = 0.0) -> np.ndarray:
    """The final object position of each action (moved by ``delta`` in every dimension, capped at the upper bound)
    on the context of ``reset(seed=i)``: ``(n, 3)``."""
    hi = env.action_space.high.astype(np.float64)
    out = []
    for i, a in enumerate(acts):
        env.reset(seed=i)
        out.append(env.step(np.minimum(a + delta, hi))[4]["final_pos"])
    return np.array(out)


def landing_moves(env, actions: int, seed: int, deltas) -> dict[float, np.ndarray]:
    """Per delta, how far (m) each of ``actions`` random actions' final position moves when every action dimension
    moves by delta (rad or m)."""
    acts = random_actions(env, actions, seed)
    base = final_positions(env, acts)
    return {float(d): np.linalg.norm(final_positions(env, acts, float(d)) - base, axis=1) for d in deltas}
