"""Bridge design check: how many contexts are solvable and how many need the bridge plank; how chaotic the landing is.

``python -m benchmarks.design_checks.bridge --contexts 50 --seed 0 [--smooth]`` measures, with the project's search
on the real simulator (:mod:`phyplan_agents.sim_search`: grid, model step, ES; the oracle's), the best reward with
and without the bridge per sampled context (and, with ``--smooth``, how smooth the end distance is near each
optimum). ``--chaos`` instead measures how far the landing moves when every action dimension moves by 1e-8, 1e-6
and 1e-4 rad, and when the timestep halves, over random actions (:mod:`benchmarks.design_checks.chaos`).
``--version 0`` checks the superseded Bridge-v0 (the disc puck) instead of the current version. With ``--chaos``,
action i (of ``numpy.random.default_rng(--seed)``) runs on the context ``reset(seed=--seed + --seed-step * i)``
(:mod:`benchmarks.design_checks.seeds`). The figures are quoted in :mod:`phyplan_envs.tasks.bridge`'s docstrings.
"""
from __future__ import annotations

import numpy as np

from benchmarks.design_checks import chaos as chaos_check
from benchmarks.design_checks import seeds as seeding
from phyplan_agents.sim_search import search
from phyplan_envs.tasks.bridge import BridgeEnv
from phyplan_envs.tasks.bridge_v0 import BridgeEnvV0

CLASSES = {0: BridgeEnvV0, 1: BridgeEnv}     # version -> class


def make(version: int, halved: bool = False):
    """Bridge-v``version`` without the Panda; ``halved``: at half its timestep (end-rule checks still every 5 ms)."""
    cls = CLASSES[version]
    return (chaos_check.halved(cls) if halved else cls)(with_panda=False)


def chaos(version: int, actions: int = 200, seed: int = 0, deltas=(1e-8, 1e-6, 1e-4), seed_step: int = 1) -> dict:
    """How far (m) the landings of ``actions`` random actions (``default_rng(seed)``, action i on the context
    ``reset(seed=seed + seed_step * i)``) move when the action moves by each delta and when the timestep halves."""
    contexts = seeding.seed_list(seed, seed_step, actions)
    return chaos_check.chaos(CLASSES[version], actions, seed, deltas, contexts)


def evaluate(env, context, action) -> tuple[float, dict]:
    env.reset(options={"context": context})
    _, reward, _, _, info = env.step(np.asarray(action, dtype=np.float64))
    return reward, info


def best_reward(env, context, with_bridge: bool, budget: int = 300, target: float = 0.99,
                seed: int = 0) -> tuple[float, np.ndarray, int]:
    """Best reward found for ``context`` by the project's search on the real simulator
    (:func:`phyplan_agents.sim_search.search`: grid, model step, ES) with at most ``budget`` calls, stopping once
    the reward reaches ``target`` (``1.0``: spend the whole budget).

    ``with_bridge=False`` keeps the bridge out of the puck's path: its yaw is the bound farther from ``phi``
    (at least pi/4 away; the plank blocks a straight path only within ~0.34 rad of its yaw), and only ``phi`` and
    ``theta`` are searched. Returns ``(reward, action, simulator calls)``.
    """
    lo, hi = env.unwrapped.action_low, env.unwrapped.action_high

    def full(a):
        a = np.asarray(a, dtype=np.float64)
        if with_bridge:
            return a
        return np.array([a[0], a[1], hi[2] if a[0] < (lo[2] + hi[2]) / 2 else lo[2]])

    def simulate(a):
        return evaluate(env, context, full(a))

    dims = 3 if with_bridge else 2
    res = search(simulate, lo[:dims], hi[:dims], budget=budget, stop_reward=target, seed=seed)
    return float(res.best_reward), full(res.best_action), res.calls


def smoothness(env, context, action, half_width_deg=2.0, n=17) -> float:
    """Largest deviation (m) of the end distance from a quadratic fit over theta +- ``half_width_deg`` at ``action``."""
    lo, hi = env.unwrapped.action_low, env.unwrapped.action_high
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
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the context draws (solvability) or of the random actions (--chaos; action i on the "
                        "context reset(seed=SEED + SEED_STEP * i)); default 0")
    p.add_argument("--seed-step", type=int, default=1,
                   help="with --chaos: step between the contexts' seeds (default 1; fresh contexts outside every "
                        f"split: --seed {seeding.FRESH_SEED} --seed-step {seeding.FRESH_STEP})")
    p.add_argument("--margin", type=float, default=0.2, help="'needs the bridge': best with - best without > this")
    p.add_argument("--smooth", action="store_true", help="also measure smoothness near each optimum")
    p.add_argument("--budget", type=int, default=300, help="simulator calls per search with the bridge (300)")
    p.add_argument("--budget-without", type=int, default=200,
                   help="simulator calls per search without the bridge (200; always spent in full)")
    p.add_argument("--version", type=int, choices=sorted(CLASSES), default=max(CLASSES),
                   help="Bridge-vN to check (default: the current version)")
    p.add_argument("--chaos", action="store_true",
                   help="instead: how far the landing moves for tiny action changes and a halved timestep")
    p.add_argument("--actions", type=int, default=200, help="with --chaos: random actions (seed --seed)")
    args = p.parse_args(argv)
    if args.actions < 1 or args.contexts < 1:
        p.error("--actions and --contexts must be at least 1")
    seeding.check(p, args, args.actions if args.chaos else args.contexts, "--actions" if args.chaos else "--contexts")

    if args.chaos:
        contexts = seeding.seed_list(args.seed, args.seed_step, args.actions)
        chaos_check.print_table(f"Bridge-v{args.version}: landing moves over {args.actions} random actions (seed "
                                f"{args.seed}) on the contexts of {seeding.describe(contexts)}, mm",
                                chaos(args.version, args.actions, args.seed, seed_step=args.seed_step))
        return
    env = CLASSES[args.version]()
    rng = np.random.default_rng(args.seed)
    rows = []
    t0 = time.perf_counter()
    for i in range(args.contexts):
        _, info = env.reset(seed=int(rng.integers(2 ** 31)))
        ctx = info["context"]
        r_with, a_with, c1 = best_reward(env, ctx, True, budget=args.budget)
        r_without, a_without, c2 = best_reward(env, ctx, False, budget=args.budget_without, target=1.0)
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
