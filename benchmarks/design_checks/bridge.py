"""Bridge design check: how many contexts are solvable and how many need the bridge plank.

``python -m benchmarks.design_checks.bridge --contexts 50 --seed 0 [--smooth]`` measures, with a grid search plus
local refinement over the real simulator, the best reward with and without the bridge per sampled context (and,
with ``--smooth``, how smooth the end distance is near each optimum). The figures are quoted in
:mod:`phyplan_envs.tasks.bridge`'s docstring. (The general oracle agent lives in :mod:`phyplan_agents.oracle`.)
"""
from __future__ import annotations

import numpy as np

from phyplan_envs.tasks.bridge import BridgeEnv


def evaluate(env, context, action) -> tuple[float, dict]:
    env.reset(options={"context": context})
    _, reward, _, _, info = env.step(np.asarray(action, dtype=np.float64))
    return reward, info


def pattern_search(f, x0, lo, hi, step, min_step, max_evals):
    """Maximise ``f`` from ``x0`` by compass moves (+-step per coordinate), halving the steps when none improves."""
    x, fx = np.array(x0, dtype=np.float64), f(x0)
    step = np.array(step, dtype=np.float64)
    evals = 1
    while evals < max_evals and np.any(step >= min_step):
        best = (fx, None)
        for i in range(len(x)):
            for s in (1.0, -1.0):
                y = x.copy()
                y[i] = np.clip(y[i] + s * step[i], lo[i], hi[i])
                if y[i] == x[i]:
                    continue
                fy = f(y)
                evals += 1
                if fy > best[0]:
                    best = (fy, y)
        if best[1] is None:
            step /= 2
        else:
            fx, x = best[0], best[1]
    return fx, x, evals


def best_reward(env, context, with_bridge: bool, grid=(9, 7, 9), starts: int = 3, max_evals: int = 60,
                good_enough: float = 0.99) -> tuple[float, np.ndarray, int]:
    """Best reward found for ``context`` by a grid over the action space, then pattern search from the best points.

    ``with_bridge=False`` keeps the bridge out of the puck's path: its yaw is the bound farther from ``phi``
    (at least pi/4 away; the plank blocks a straight path only within ~0.34 rad of its yaw), and only ``phi`` and
    ``theta`` are searched. Returns ``(reward, action, simulator calls)``.
    """
    lo, hi = env.unwrapped._low64, env.unwrapped._high64
    calls = 0

    def full(a):
        a = np.asarray(a, dtype=np.float64)
        if with_bridge:
            return a
        return np.array([a[0], a[1], hi[2] if a[0] < (lo[2] + hi[2]) / 2 else lo[2]])

    def f(a):
        nonlocal calls
        calls += 1
        return evaluate(env, context, full(a))[0]

    dims = 3 if with_bridge else 2
    axes = [np.linspace(lo[i], hi[i], grid[i]) for i in range(dims)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, dims)
    scores = np.array([f(p) for p in points])
    order = np.argsort(-scores)
    best_r, best_a = float(scores[order[0]]), points[order[0]]
    spacing = np.array([(hi[i] - lo[i]) / (grid[i] - 1) for i in range(dims)])
    for k in order[:starts]:
        if best_r >= good_enough:
            break
        r, a, _ = pattern_search(f, points[k], lo[:dims], hi[:dims], spacing / 2, spacing / 64, max_evals)
        if r > best_r:
            best_r, best_a = r, a
    return best_r, full(best_a), calls


def smoothness(env, context, action, half_width_deg=2.0, n=17) -> float:
    """Largest deviation (m) of the end distance from a quadratic fit over theta +- ``half_width_deg`` at ``action``."""
    lo, hi = env.unwrapped._low64, env.unwrapped._high64
    th = np.clip(action[1] + np.radians(np.linspace(-half_width_deg, half_width_deg, n)), lo[1], hi[1])
    dist = []
    for t in th:
        _, info = evaluate(env, context, [action[0], t, action[2]])
        dist.append(float(np.hypot(*info["final_pos"][:2])))
    dist = np.array(dist)
    fit = np.polyval(np.polyfit(th, dist, 2), th)
    return float(np.max(np.abs(dist - fit)))


def main(argv=None) -> None:
    import argparse
    import time

    p = argparse.ArgumentParser(description="Bridge design check: solvable and needs-the-bridge shares.")
    p.add_argument("--contexts", type=int, default=50)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--margin", type=float, default=0.2, help="'needs the bridge': best with - best without > this")
    p.add_argument("--smooth", action="store_true", help="also measure smoothness near each optimum")
    args = p.parse_args(argv)

    env = BridgeEnv()
    rng = np.random.default_rng(args.seed)
    rows = []
    t0 = time.perf_counter()
    for i in range(args.contexts):
        _, info = env.reset(seed=int(rng.integers(2 ** 31)))
        ctx = info["context"]
        r_with, a_with, c1 = best_reward(env, ctx, True)
        r_without, a_without, c2 = best_reward(env, ctx, False, good_enough=2.0)
        smooth = smoothness(env, ctx, a_with) if args.smooth else float("nan")
        d = float(np.hypot(*ctx["goal"]))
        rows.append((d, r_with, r_without, smooth))
        print(f"context {i:3d}: goal distance {d:.3f} m  best with bridge {r_with:.3f} "
              f"{np.round(a_with, 3).tolist()}  without {r_without:.3f}  calls {c1 + c2}"
              + (f"  smoothness {smooth * 1000:.1f} mm" if args.smooth else ""), flush=True)
    rows = np.array(rows)
    solvable = np.mean(rows[:, 1] >= 0.95)
    needs = np.mean(rows[:, 1] - rows[:, 2] > args.margin)
    print(f"\n{args.contexts} contexts, seed {args.seed}, {time.perf_counter() - t0:.0f} s")
    print(f"solvable (best reward >= 0.95): {solvable:.0%}; mean best reward {rows[:, 1].mean():.3f}")
    print(f"needs the bridge (best with - best without > {args.margin}): {needs:.0%}; "
          f"mean best without {rows[:, 2].mean():.3f}")
    if args.smooth:
        print(f"smoothness near the optimum (theta +-2 deg, max |landing - quadratic fit|): "
              f"median {np.median(rows[:, 3]) * 1000:.1f} mm, max {rows[:, 3].max() * 1000:.1f} mm")


if __name__ == "__main__":
    main()
