"""The fixed train / dev / test context splits, re-exported from :mod:`phyplan_envs.splits` (where they live).

``benchmarks.splits`` stays importable for scripts written against it; new code can import either.
"""
from phyplan_envs.splits import (SPLITS, assert_train_seeds, context_seeds, make_context, sample_seeds, split_of,
                                 split_range, train_seeds)

__all__ = ["SPLITS", "assert_train_seeds", "context_seeds", "make_context", "sample_seeds", "split_of",
           "split_range", "train_seeds"]
