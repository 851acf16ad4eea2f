"""The seeds of a design check's samples: the project's default seeds, or fresh ones outside every split.

Sample ``i`` of a check uses the context seed ``seed + seed_step * i`` (``env.reset(seed=...)``: the goal and, for a
varied task, the hidden physics) and the i-th draw of ``numpy.random.default_rng(seed)`` for whatever else is random
(the action). ``--seed 7310000 --seed-step 7919`` (:data:`FRESH_SEED`, :data:`FRESH_STEP`) gives contexts that lie
in no split of :mod:`phyplan_envs.splits`: a figure measured on them was not tuned on them.
"""
from __future__ import annotations

import argparse

from phyplan_envs.splits import split_of

FRESH_SEED = 7_310_000     # the fresh seeds of the docs: FRESH_SEED + FRESH_STEP * i, outside every split
FRESH_STEP = 7_919
SEED_BOUND = 2 ** 32       # numpy's and the envs' seeds must stay below this


def add_arguments(p: argparse.ArgumentParser, default_seed: str = "0") -> None:
    """Add ``--seed`` (the first seed) and ``--seed-step`` to a check's parser."""
    p.add_argument("--seed", type=int, default=None, metavar="S",
                   help=f"first seed: sample i uses the context seed S + STEP * i and the i-th draw of "
                        f"default_rng(S) (default {default_seed}; fresh seeds outside every split: "
                        f"--seed {FRESH_SEED} --seed-step {FRESH_STEP})")
    p.add_argument("--seed-step", type=int, default=1, metavar="STEP",
                   help="step between the samples' context seeds (default 1)")


def check(p: argparse.ArgumentParser, args: argparse.Namespace, count: int, count_flag: str) -> None:
    """Refuse bad seeds and counts with an error naming the argument (``p.error``: exit status 2)."""
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        p.error(f"{count_flag} must be a positive number of samples, got {count!r}")
    if args.seed is not None and not 0 <= args.seed < SEED_BOUND:
        p.error(f"--seed must be in [0, 2**32), got {args.seed}")
    if args.seed_step < 1:
        p.error(f"--seed-step must be at least 1, got {args.seed_step}")
    first = 0 if args.seed is None else args.seed
    if first + args.seed_step * (count - 1) >= SEED_BOUND:
        p.error(f"--seed {first} --seed-step {args.seed_step} with {count_flag} {count}: the last seed passes 2**32")


def seed_list(first: int, step: int, n: int) -> list[int]:
    """The context seeds ``first + step * i`` for ``i < n``."""
    if first < 0 or step < 1 or n < 1:
        raise ValueError(f"seeds need first >= 0, step >= 1 and n >= 1; got first {first}, step {step}, n {n}")
    return [first + step * i for i in range(n)]


def describe(seeds: list[int]) -> str:
    """``"seeds 7310000 + 7919 i, i < 200, outside every split"``: what a table was measured on."""
    if len(seeds) == 1:
        form = f"seed {seeds[0]}"
    else:
        step = seeds[1] - seeds[0]
        form = (f"seeds {seeds[0]}..{seeds[-1]}" if step == 1 else
                f"seeds {seeds[0]} + {step} i, i < {len(seeds)}")
    splits = sorted({split_of(s) or "no split" for s in seeds})
    where = "outside every split" if splits == ["no split"] else "in " + " and ".join(
        s if s == "no split" else f"the {s} split" for s in splits)
    return f"{form}, {where}"
