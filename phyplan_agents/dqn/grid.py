"""The discretisation of a task's continuous action box: a regular grid, and the action encoding the Q-network reads.

SB3's ``DQN`` needs a ``Discrete`` action space, so every task's action box is replaced by a regular grid with
``counts[i]`` evenly spaced values (bounds included) along dimension ``i``. Discrete action ``k`` is the ``k``-th grid
point in C order (the last dimension varies fastest).

Default resolution (:data:`DEFAULT_COUNTS`): 32 x 32 for the two-dimensional pendulum tasks (steps of 0.049 rad in phi
and 0.025 rad in theta), 64 x 16 for Bounce (yaw spans 2 pi: a 0.1 rad step; drop height 0.067 m), 16 x 16 x 8 for
Bridge (phi 0.10 rad, theta 0.052 rad, bridge yaw 0.22 rad), and 9 x 3 x 5 x 5 x 33 = 22,275 actions for
LaunchBounce (phi 0.20 rad, theta 0.39 rad, wedge distance 0.2 m, wedge angle 0.39 rad, wedge yaw 0.20 rad: the yaw,
to which the landing point is by far the most sensitive, gets the most values and the step of phi; theta, the
least sensitive, three; the default 16 values per dimension would be 1,048,576 actions, and SB3's training step
scores every grid action). Paddles-N (any N, :data:`PADDLES_COUNTS`): 32 release angles when theta is the only
action (N = 1), else 5 release angles (0.075 rad) and 21 values per placed paddle over its bounds (Paddles-v1's and v2's
offsets in [0.45, 0.9] m: 0.0225 m steps; chosen on v0's positions in [-1, 1] m, 0.1 m steps, a 0.5 m paddle tilted
45 degrees spanning 0.35 m in x), 41 at N = 2, where one paddle alone moves the landing: 205, 2,205 and 46,305
actions for N = 2, 3, 4 (``python -m benchmarks.dqn_grid --task paddles --paddles 1 2 3 --exhaustive``;
docs/dqn.md). ``python -m benchmarks.dqn_grid`` measures on dev contexts that the best grid action
reaches reward >= 0.9 with these resolutions (20/20 dev contexts per task; for LaunchBounce with ``--exhaustive``;
docs/dqn.md has the table); a task not listed gets 32 values per dimension for up to two dimensions and 16 beyond.

The Q-network never sees action indices: it reads an *encoding* of the action's physical value (see
:meth:`ActionGrid.encode`), so it can also score continuous actions between grid points (DQN-Adapted does).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

DEFAULT_COUNTS: dict[str, tuple[int, ...]] = {
    "launch": (32, 32),
    "slide": (32, 32),
    "bounce": (64, 16),
    "bridge": (16, 16, 8),
    "launch-bounce": (9, 3, 5, 5, 33),
}

PADDLES_COUNTS = {"theta": 5, "paddle": 21, "one_paddle": 41, "theta_alone": 32}
"""Paddles-N's grid values: of the release angle (with paddles to place, and alone at N = 1) and per placed paddle
(when it is the only one placed, N = 2, and otherwise)."""

FOURIER_FREQS = (1, 2, 4)
"""Frequencies (in half-periods over the box) of the sin/cos features of each normalised action coordinate."""


def default_counts(task: str, action_dim: int) -> tuple[int, ...]:
    """The grid resolution used for ``task`` (see the module docstring for where the numbers come from)."""
    if task in DEFAULT_COUNTS and len(DEFAULT_COUNTS[task]) == action_dim:
        return DEFAULT_COUNTS[task]
    if task == "paddles":
        c = PADDLES_COUNTS
        if action_dim == 1:
            return (c["theta_alone"],)
        return (c["theta"],) + (c["one_paddle"] if action_dim == 2 else c["paddle"],) * (action_dim - 1)
    return (32,) * action_dim if action_dim <= 2 else (16,) * action_dim


@dataclass(frozen=True)
class ActionGrid:
    """A regular grid over the box ``[low, high]`` with ``counts[i]`` values along dimension ``i`` (bounds included).

    Attributes:
        low, high: the box bounds in physical units (radians, metres), one per action dimension.
        counts: the number of grid values per dimension (each >= 2).
    """

    low: tuple[float, ...]
    high: tuple[float, ...]
    counts: tuple[int, ...]

    def __post_init__(self) -> None:
        if not (len(self.low) == len(self.high) == len(self.counts) >= 1):
            raise ValueError(f"low, high and counts must have the same non-zero length, got "
                             f"{len(self.low)}, {len(self.high)}, {len(self.counts)}")
        for i, (lo, hi, n) in enumerate(zip(self.low, self.high, self.counts)):
            if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
                raise ValueError(f"action dimension {i}: bounds must be finite with high > low, got [{lo}, {hi}]")
            if int(n) != n or n < 2:
                raise ValueError(f"action dimension {i}: the grid needs at least 2 values, got {n!r}")

    @classmethod
    def for_task(cls, task: str, low: Sequence[float], high: Sequence[float],
                 counts: Sequence[int] | None = None) -> "ActionGrid":
        """The grid for a task's bounds, with ``counts`` or the task's default resolution."""
        counts = tuple(int(c) for c in counts) if counts is not None else default_counts(task, len(low))
        return cls(tuple(float(x) for x in low), tuple(float(x) for x in high), counts)

    # ----------------------------------------------------------------------------------------------------- sizes
    @property
    def dim(self) -> int:
        return len(self.counts)

    @property
    def n(self) -> int:
        """The number of discrete actions."""
        return int(np.prod(self.counts))

    @property
    def steps(self) -> np.ndarray:
        """The spacing of the grid along each dimension (physical units)."""
        return (np.asarray(self.high) - np.asarray(self.low)) / (np.asarray(self.counts) - 1)

    # ------------------------------------------------------------------------------------------------ conversions
    def points(self) -> np.ndarray:
        """All grid actions, shape ``(n, dim)`` float64, in discrete-action order."""
        axes = [np.linspace(lo, hi, c) for lo, hi, c in zip(self.low, self.high, self.counts)]
        mesh = np.meshgrid(*axes, indexing="ij")
        return np.stack([m.reshape(-1) for m in mesh], axis=1)

    def action(self, index: int | np.ndarray) -> np.ndarray:
        """The physical action(s) of discrete index (or indices)."""
        idx = np.asarray(index)
        if np.any(idx < 0) or np.any(idx >= self.n):
            raise ValueError(f"discrete action index out of range [0, {self.n}): {index!r}")
        sub = np.stack(np.unravel_index(idx, self.counts), axis=-1).astype(np.float64)
        return np.asarray(self.low) + sub * self.steps

    def nearest(self, actions: np.ndarray) -> np.ndarray:
        """The discrete index of the grid point nearest to each action (actions outside the box are clipped)."""
        a = np.atleast_2d(np.asarray(actions, dtype=np.float64))
        sub = np.rint((np.clip(a, self.low, self.high) - np.asarray(self.low)) / self.steps).astype(np.int64)
        sub = np.clip(sub, 0, np.asarray(self.counts) - 1)
        return np.ravel_multi_index(tuple(sub.T), self.counts)

    def normalise(self, actions: np.ndarray) -> np.ndarray:
        """Actions mapped affinely from the box to ``[-1, 1]`` per dimension."""
        a = np.asarray(actions, dtype=np.float64)
        lo, hi = np.asarray(self.low), np.asarray(self.high)
        return 2.0 * (a - lo) / (hi - lo) - 1.0

    @property
    def encoding_dim(self) -> int:
        return self.dim * (1 + 2 * len(FOURIER_FREQS))

    def encode(self, actions: np.ndarray) -> np.ndarray:
        """The Q-network's action encoding: the normalised coordinates and their sin/cos Fourier features.

        For each normalised coordinate ``u`` in [-1, 1]: ``u, sin(f pi u / 2), cos(f pi u / 2)`` for ``f`` in
        :data:`FOURIER_FREQS`. Shape ``(..., encoding_dim)`` float32.
        """
        u = self.normalise(actions)
        parts = [u[..., None]]
        for f in FOURIER_FREQS:
            parts += [np.sin(f * np.pi * u / 2)[..., None], np.cos(f * np.pi * u / 2)[..., None]]
        return np.concatenate(parts, axis=-1).reshape(*u.shape[:-1], -1).astype(np.float32)

    def to_dict(self) -> dict:
        return {"low": list(self.low), "high": list(self.high), "counts": list(self.counts)}

    @classmethod
    def from_dict(cls, d: dict) -> "ActionGrid":
        return cls(tuple(float(x) for x in d["low"]), tuple(float(x) for x in d["high"]),
                   tuple(int(c) for c in d["counts"]))
