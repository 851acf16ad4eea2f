"""Is the DQN action grid fine enough? The best grid action's real reward on *dev* contexts.

For each context: the project's search on the real simulator (:func:`phyplan_agents.sim_search.search`, the
oracle's, ``--budget`` calls) finds the best continuous action; then every grid action within one grid step of it
(the ``3 ** D`` grid points around the nearest one) is simulated. The best of those is a *lower bound* on the best
grid action's reward (an exhaustive search would cost ``grid.n`` simulations per context); the gap to the continuous
best is what the discretisation costs near the optimum.

    python -m benchmarks.dqn_grid --task launch --task slide --task bounce --task bridge --contexts 20

prints, per task, the share of contexts whose best grid action found reaches ``--threshold`` (0.9), the median and
minimum of that reward and of the continuous best, and the simulations spent. The contexts are the first
``--contexts`` seeds of the *dev* split (:mod:`benchmarks.splits`): the grid resolution is a tuning choice, so it
is checked on dev contexts, never on the test contexts the benchmark reports. ``--counts`` tries another resolution.
"""
from __future__ import annotations

import argparse
import itertools
import os
import sys
import time

import numpy as np

from phyplan_agents.dqn.cache import make_env, task_grid
from phyplan_agents.sim_search import search

from . import splits


def best_grid_reward(env, context, grid, budget: int = 200, seed: int = 0) -> dict:
    """The search's best continuous action for ``context``, then the best grid action within one step of it.

    Returns ``{"grid_reward", "grid_action", "continuous_reward", "continuous_action", "simulations"}``.
    """
    calls = 0

    def simulate(a):
        nonlocal calls
        calls += 1
        env.reset(options={"context": context})
        _, reward, _, _, info = env.step(np.asarray(a, dtype=np.float64))
        return float(reward), info

    low, high = np.asarray(grid.low), np.asarray(grid.high)
    res = search(simulate, low, high, budget=budget, seed=seed)
    centre = np.rint((res.best_action - low) / grid.steps).astype(np.int64)
    best_r, best_a = -np.inf, None
    for move in itertools.product((-1, 0, 1), repeat=grid.dim):
        sub = centre + np.asarray(move)
        if np.any(sub < 0) or np.any(sub >= np.asarray(grid.counts)):
            continue
        a = low + sub * grid.steps
        r = simulate(a)[0]
        if r > best_r:
            best_r, best_a = r, a
    return {"grid_reward": float(best_r), "grid_action": best_a, "continuous_reward": float(res.best_reward),
            "continuous_action": res.best_action, "simulations": calls}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.dqn_grid", description=__doc__.split("\n")[0])
    p.add_argument("--task", action="append", required=True, help="task name (repeatable)")
    p.add_argument("--contexts", type=int, default=20, help="dev contexts per task (the first N dev seeds; 20)")
    p.add_argument("--counts", type=int, nargs="+", default=None, help="grid values per dimension (default: the "
                   "task's default resolution, phyplan_agents.dqn.grid.DEFAULT_COUNTS)")
    p.add_argument("--budget", type=int, default=200, help="search calls per context before the grid step (200)")
    p.add_argument("--threshold", type=float, default=0.9)
    args = p.parse_args(argv)
    if args.contexts < 1 or args.budget < 4:
        p.error("--contexts must be >= 1 and --budget >= 4")
    for task in args.task:
        env = make_env(task, obs_mode="state")
        try:
            grid = task_grid(task, tuple(args.counts) if args.counts else None)
        except ValueError as exc:
            p.error(f"--counts: {exc}")
        t0 = time.perf_counter()
        rows = []
        for seed in splits.context_seeds("dev", args.contexts):
            _, info = env.reset(seed=int(seed))
            rows.append(best_grid_reward(env, info["context"], grid, budget=args.budget))
        env.close()
        g = np.array([r["grid_reward"] for r in rows])
        c = np.array([r["continuous_reward"] for r in rows])
        sims = [r["simulations"] for r in rows]
        print(f"{task}: grid {'x'.join(map(str, grid.counts))} ({grid.n} actions); best grid action >= "
              f"{args.threshold} on {int(np.sum(g >= args.threshold))}/{len(g)} dev contexts; grid best median "
              f"{np.median(g):.3f}, min {g.min():.3f}; continuous best median {np.median(c):.3f}, min {c.min():.3f}; "
              f"{int(np.median(sims))} simulations per context (median); {time.perf_counter() - t0:.0f} s",
              flush=True)
    return 0


if __name__ == "__main__":
    os.environ.setdefault("MUJOCO_GL", "egl")
    sys.exit(main())
