"""Is the DQN action grid fine enough? The best grid action's real reward on *dev* contexts.

For each context: the project's search on the real simulator (:func:`phyplan_agents.sim_search.search`, the
oracle's, ``--budget`` calls) finds the best continuous action; then every grid action within one grid step of it
(the ``3 ** D`` grid points around the nearest one) is simulated. The best of those is a *lower bound* on the best
grid action's reward (an exhaustive search would cost ``grid.n`` simulations per context); the gap to the continuous
best is what the discretisation costs near the optimum.

    python -m benchmarks.dqn_grid --task launch --task slide --task bounce --task bridge --contexts 20
    python -m benchmarks.dqn_grid --task paddles --paddles 1 2 3 --exhaustive     # Paddles-N, one grid per N

prints, per task, the share of contexts whose best grid action found reaches ``--threshold`` (0.9), the median and
minimum of that reward and of the continuous best, and the simulations spent. The contexts are the first
``--contexts`` seeds of the *dev* split (:mod:`benchmarks.splits`): the grid resolution is a tuning choice, so it
is checked on dev contexts, never on the test contexts the benchmark reports. ``--counts`` tries another resolution;
``--sensitivity`` also prints how far the landing point moves per action dimension at the search's best action
(which dimensions need the finer grid).

With four or five action dimensions the optimum found is one point of a set of solutions (two goal coordinates,
more action dimensions), and the grid actions near *that* point can all miss while others hit. ``--exhaustive``
scores the whole grid instead (:func:`exhaustive_best`): every grid action is simulated once, in the first
context, and its landing point ranks the grid for every context by ``1 - |landing - goal| / d0``; the
``--verify`` (20) best of that ranking are then simulated in the context itself, and the best of those real rewards
is reported (again a lower bound on the best grid action). The ranking is exact for tasks whose context is only the
goal, as long as the object does not touch the goal box; the line also gives how many verified simulations landed
within 1 mm of the ranking's landing point. It costs ``grid.n + contexts * verify`` simulations
(``--workers`` processes, :func:`phyplan_envs.simulate_batch`).
"""
from __future__ import annotations

import argparse
import itertools
import os
import sys
import time

import numpy as np

import phyplan_envs
from phyplan_agents.dqn.cache import make_env, scene_name, task_grid
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


def landing_sensitivity(env, context, action, low, high, h: float = 0.005) -> np.ndarray:
    """How far the landing point moves per action dimension near ``action``: ``|d landing / d u_i|`` in metres per
    full range of dimension ``i`` (a one-sided finite difference of ``h`` of the range, towards the box's inside)."""
    low, high = np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)
    action = np.asarray(action, dtype=np.float64)

    def landing(a):
        env.reset(options={"context": context})
        return np.asarray(env.step(a)[4]["final_pos"][:2])

    base = landing(action)
    out = np.zeros(len(action))
    for i in range(len(action)):
        a = action.copy()
        step = h * (high[i] - low[i])
        a[i] = a[i] + step if a[i] + step <= high[i] else a[i] - step
        out[i] = np.linalg.norm(landing(a) - base) / h
    return out


def exhaustive_best(task: str, grid, infos, verify: int = 20, workers: int = 2, progress: bool = False,
                    scene=None) -> dict:
    """The best grid action of each context from a landing map of the whole grid, checked on the real simulator.

    ``infos``: the reset infos of the contexts (``goal``, ``initial_distance``, ``context``). Every grid action is
    simulated once in the first context; per context, the ``verify`` grid actions whose landing point is nearest
    the goal are simulated in that context. Returns ``{"grid_reward"`` (C,) best real reward, ``"proxy_reward"`` (C,)
    the landing map's best, ``"grid_action"`` (C, D), ``"agree"`` share of verified simulations within 1 mm of the
    map, ``"simulations"``}. ``scene``: the task's scene arguments (e.g. ``{"paddles": 3}``).
    """
    import phyplan_envs
    from phyplan_envs import simulate_batch

    env_id = phyplan_envs.env_id(task)
    kwargs = {"obs_mode": "state", "with_panda": False, **dict(scene or {})}
    points = grid.points()
    chunk = 4096
    landing = np.zeros((grid.n, 2))
    for a in range(0, grid.n, chunk):
        landing[a:a + chunk] = simulate_batch(env_id, infos[0]["context"], points[a:a + chunk], workers=workers,
                                              **kwargs).final_pos[:, :2]
        if progress:
            print(f"  landing map {min(a + chunk, grid.n)}/{grid.n}", file=sys.stderr, flush=True)
    out = {"grid_reward": [], "proxy_reward": [], "grid_action": [], "agree": 0, "simulations": grid.n}
    k = min(int(verify), grid.n)
    for info in infos:
        goal, d0 = np.asarray(info["goal"], dtype=np.float64), float(info["initial_distance"])
        proxy = 1.0 - np.linalg.norm(landing - goal, axis=1) / d0
        top = np.argsort(-proxy, kind="stable")[:k]
        res = simulate_batch(env_id, info["context"], points[top], workers=workers, **kwargs)
        out["simulations"] += k
        out["agree"] += int(np.sum(np.linalg.norm(res.final_pos[:, :2] - landing[top], axis=1) <= 1e-3))
        best = int(np.argmax(res.reward))
        out["grid_reward"].append(float(res.reward[best]))
        out["proxy_reward"].append(float(proxy[top[0]]))
        out["grid_action"].append(points[top[best]])
    out["agree"] = out["agree"] / (k * len(infos))
    return {key: np.asarray(v) if isinstance(v, list) else v for key, v in out.items()}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.dqn_grid", description=__doc__.split("\n")[0])
    p.add_argument("--task", action="append", required=True, help="task name (repeatable)")
    p.add_argument("--contexts", type=int, default=20, help="dev contexts per task (the first N dev seeds; 20)")
    p.add_argument("--counts", type=int, nargs="+", default=None, help="grid values per dimension (default: the "
                   "task's default resolution, phyplan_agents.dqn.grid.DEFAULT_COUNTS)")
    p.add_argument("--budget", type=int, default=200, help="search calls per context before the grid step (200)")
    p.add_argument("--threshold", type=float, default=0.9)
    p.add_argument("--exhaustive", action="store_true", help="score every grid action from a landing map, then "
                   "verify the best --verify per context on the real simulator (see the module docstring)")
    p.add_argument("--verify", type=int, default=20, help="--exhaustive: grid actions simulated per context (20)")
    p.add_argument("--workers", type=int, default=2, help="--exhaustive: simulation processes (2)")
    p.add_argument("--paddles", type=int, nargs="+", default=None,
                   help="Paddles-N: check the grid of each N given (the task must have the 'paddles' scene argument)")
    p.add_argument("--sensitivity", action="store_true", help="also print the median over contexts of how far the "
                   "landing point moves per action dimension at the search's best action (m per full range)")
    args = p.parse_args(argv)
    if args.contexts < 1 or args.budget < 4:
        p.error("--contexts must be >= 1 and --budget >= 4")
    if args.verify < 1 or args.workers < 1:
        p.error("--verify and --workers must be >= 1")
    runs = [(t, {}) for t in args.task]
    if args.paddles is not None:
        bad = [t for t in args.task if "paddles" not in getattr(phyplan_envs.task_class(t), "scene_args", ())]
        if bad:
            p.error(f"--paddles: task(s) {bad} have no 'paddles' scene argument")
        runs = [(t, {"paddles": n}) for t in args.task for n in args.paddles]
    for task, scene in runs:
        try:
            grid = task_grid(task, tuple(args.counts) if args.counts else None, scene)
        except (TypeError, ValueError) as exc:
            p.error(f"--counts / --paddles: {exc}")
        env = make_env(task, obs_mode="state", scene=scene)
        label, names = scene_name(task, scene), [d.name for d in env.unwrapped.action_dims]
        t0 = time.perf_counter()
        if args.exhaustive:
            infos = [env.reset(seed=int(seed))[1] for seed in splits.context_seeds("dev", args.contexts)]
            env.close()
            r = exhaustive_best(task, grid, infos, args.verify, args.workers, progress=True, scene=scene)
            g = r["grid_reward"]
            print(f"{label}: grid {'x'.join(map(str, grid.counts))} ({grid.n} actions), exhaustive: best grid action "
                  f">= {args.threshold} on {int(np.sum(g >= args.threshold))}/{len(g)} dev contexts; grid best median "
                  f"{np.median(g):.3f}, min {g.min():.3f}; landing map's best median {np.median(r['proxy_reward']):.3f}"
                  f"; {100 * r['agree']:.0f}% of the verified simulations landed within 1 mm of the map; "
                  f"{r['simulations']} simulations; {time.perf_counter() - t0:.0f} s", flush=True)
            continue
        rows = []
        for seed in splits.context_seeds("dev", args.contexts):
            _, info = env.reset(seed=int(seed))
            rows.append(best_grid_reward(env, info["context"], grid, budget=args.budget))
            if args.sensitivity:
                rows[-1]["sensitivity"] = landing_sensitivity(env, info["context"], rows[-1]["continuous_action"],
                                                              grid.low, grid.high)
        env.close()
        g = np.array([r["grid_reward"] for r in rows])
        c = np.array([r["continuous_reward"] for r in rows])
        sims = [r["simulations"] for r in rows]
        print(f"{label}: grid {'x'.join(map(str, grid.counts))} ({grid.n} actions); best grid action >= "
              f"{args.threshold} on {int(np.sum(g >= args.threshold))}/{len(g)} dev contexts; grid best median "
              f"{np.median(g):.3f}, min {g.min():.3f}; continuous best median {np.median(c):.3f}, min {c.min():.3f}; "
              f"{int(np.median(sims))} simulations per context (median); {time.perf_counter() - t0:.0f} s",
              flush=True)
        if args.sensitivity:
            med = np.median([r["sensitivity"] for r in rows], axis=0)
            print(f"{label}: landing moves per full range of each action dimension at the search's best action "
                  f"(median over contexts): " + ", ".join(f"{n} {m:.2f} m" for n, m in zip(names, med)), flush=True)
    return 0


if __name__ == "__main__":
    os.environ.setdefault("MUJOCO_GL", "egl")
    sys.exit(main())
