"""Fixed context splits: which ``env.reset(seed=s)`` seeds are for training, for tuning and for testing.

The splits live with the envs because they define the benchmark's contexts (as PHYRE keeps its folds in its
library); :mod:`benchmarks.splits` re-exports them.

A *context* of a task (goal and scene) is fully determined by the seed it is reset with: the context with id ``s``
is ``env.reset(seed=s)[1]["context"]``. Every task uses the same three disjoint seed ranges:

=========  ======================  =========  ==================================================================
split      seeds                   count      used by
=========  ======================  =========  ==================================================================
``train``  0 .. 99 999             100 000    anything that learns from contexts (DQN data, skill fitting)
``dev``    100 000 .. 100 999      1 000      tuning hyperparameters, quick checks
``test``   200 000 .. 200 999      1 000      the benchmark (``python -m benchmarks.run``, default split)
=========  ======================  =========  ==================================================================

The gap between ``dev`` and ``test`` is deliberate: a training loop that runs past the end of ``train`` by mistake
still does not reach a test context. A benchmark with ``--contexts n`` uses the *first* ``n`` seeds of its split, so
every run, on every machine, sees the same contexts.

Training code gets its seeds from :func:`train_seeds` (or :func:`sample_seeds` for a random subset) and can guard
itself with :func:`assert_train_seeds`::

    from phyplan_envs.splits import train_seeds
    for s in train_seeds(100):
        obs, info = env.reset(seed=s)
"""
from __future__ import annotations

from typing import Iterable

import numpy as np

SPLITS: dict[str, range] = {
    "train": range(0, 100_000),
    "dev": range(100_000, 101_000),
    "test": range(200_000, 201_000),
}
"""Split name -> the seeds of its contexts (``range``, stop excluded). Disjoint; the same for every task."""


def split_range(split: str) -> range:
    """The seeds of ``split`` (``"train"``, ``"dev"`` or ``"test"``)."""
    try:
        return SPLITS[split]
    except KeyError:
        raise ValueError(f"unknown split {split!r}; available splits: {', '.join(SPLITS)}") from None


def context_seeds(split: str, n: int | None = None) -> list[int]:
    """The first ``n`` context seeds of ``split`` (all of them if ``n`` is None).

    Raises ``ValueError`` if ``n`` is not a positive integer or exceeds the size of the split.
    """
    seeds = split_range(split)
    if n is None:
        return list(seeds)
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"the number of contexts must be a positive integer, got {n!r}")
    if n > len(seeds):
        raise ValueError(f"split {split!r} has only {len(seeds)} contexts, asked for {n}")
    return list(seeds[: int(n)])


def train_seeds(n: int | None = None) -> list[int]:
    """The first ``n`` training-context seeds (``0 .. n-1``); never a dev or test context."""
    return context_seeds("train", n)


def sample_seeds(split: str, n: int, rng: np.random.Generator) -> list[int]:
    """``n`` distinct seeds of ``split`` drawn with ``rng`` (without replacement), e.g. random training contexts."""
    seeds = split_range(split)
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= len(seeds):
        raise ValueError(f"n must be an integer in [1, {len(seeds)}] for split {split!r}, got {n!r}")
    picks = rng.choice(len(seeds), size=int(n), replace=False)
    return [int(seeds[i]) for i in picks]


def split_of(seed: int) -> str | None:
    """The split a context seed belongs to, or None if it is in no split (e.g. 150 000)."""
    for name, seeds in SPLITS.items():
        if seed in seeds:
            return name
    return None


def assert_train_seeds(seeds: Iterable[int]) -> None:
    """Raise ``ValueError`` if any seed is not a training seed (guard for code that learns from contexts)."""
    bad = [int(s) for s in seeds if split_of(int(s)) != "train"]
    if bad:
        shown = ", ".join(str(s) for s in bad[:5]) + (" ..." if len(bad) > 5 else "")
        raise ValueError(f"{len(bad)} seed(s) outside the train split {SPLITS['train']}: {shown}; "
                         f"use phyplan_envs.splits.train_seeds()")


def make_context(task: str, seed: int) -> dict:
    """The context of ``task`` with id ``seed`` (what ``env.reset(seed=seed)`` samples), as a dict."""
    import gymnasium as gym

    from .registry import env_id

    env = gym.make(env_id(task))
    try:
        _, info = env.reset(seed=int(seed))
        return info["context"]
    finally:
        env.close()
