"""Is the action grid fine enough? The best grid action's real reward on held-out contexts.

For each context, a search over the grid with the real simulator: every ``stride``-th grid value along each dimension
(a coarse sub-grid), then greedy hill climbing over grid neighbours (one step along up to all dimensions) from the
``starts`` best coarse points until no neighbour improves. The reward found is a *lower bound* on the best grid
action's reward (an exhaustive search would cost ``grid.n`` simulations per context).

    python -m phyplan_agents.dqn.check_grid --task launch --contexts 20

prints, per task, the fraction of contexts whose best grid action found reaches reward >= 0.9, and the median
reward and simulations spent.
"""
from __future__ import annotations

import argparse
import itertools
import time

import numpy as np

from .cache import make_env, task_grid, test_seeds


def best_grid_reward(env, context, grid, stride: int = 4, starts: int = 3) -> tuple[float, np.ndarray, int]:
    """A lower bound on the best grid action's reward for ``context``: ``(reward, action, simulations)``."""
    cache: dict[tuple[int, ...], float] = {}

    def reward(sub: tuple[int, ...]) -> float:
        if sub not in cache:
            env.reset(options={"context": context})
            a = np.asarray(grid.low) + np.asarray(sub) * grid.steps
            cache[sub] = float(env.step(a)[1])
        return cache[sub]

    coarse_axes = [sorted(set(range(0, c, stride)) | {c - 1}) for c in grid.counts]
    coarse = sorted(itertools.product(*coarse_axes), key=lambda s: -reward(s))
    moves = [m for m in itertools.product((-1, 0, 1), repeat=grid.dim) if any(m)]
    for start in coarse[:starts]:
        cur = start
        while True:
            nbrs = [tuple(int(x) for x in np.add(cur, m)) for m in moves]
            nbrs = [s for s in nbrs if all(0 <= s[i] < grid.counts[i] for i in range(grid.dim))]
            best = max(nbrs, key=reward)
            if reward(best) <= reward(cur):
                break
            cur = best
    sub = max(cache, key=cache.get)
    return cache[sub], np.asarray(grid.low) + np.asarray(sub) * grid.steps, len(cache)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--task", action="append", required=True, help="task name (repeatable)")
    p.add_argument("--contexts", type=int, default=20, help="held-out contexts per task (test seeds)")
    p.add_argument("--counts", type=int, nargs="+", default=None, help="grid values per dimension (default: the "
                   "task's default resolution)")
    p.add_argument("--stride", type=int, default=4)
    p.add_argument("--threshold", type=float, default=0.9)
    args = p.parse_args(argv)
    for task in args.task:
        env = make_env(task, obs_mode="state")
        grid = task_grid(task, tuple(args.counts) if args.counts else None)
        t0 = time.perf_counter()
        rewards, sims = [], []
        for seed in test_seeds(task, args.contexts):
            _, info = env.reset(seed=int(seed))
            r, _, n = best_grid_reward(env, info["context"], grid, stride=args.stride)
            rewards.append(r)
            sims.append(n)
        env.close()
        rewards = np.asarray(rewards)
        print(f"{task}: grid {'x'.join(map(str, grid.counts))} ({grid.n} actions); best grid reward >= "
              f"{args.threshold} on {np.mean(rewards >= args.threshold):.0%} of {len(rewards)} contexts; "
              f"median {np.median(rewards):.3f}, min {rewards.min():.3f}; {int(np.median(sims))} simulations per "
              f"context (median); {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
