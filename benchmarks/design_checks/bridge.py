"""Bridge design check: how many contexts are solvable and how many need the bridge plank; how chaotic the landing is.

``python -m benchmarks.design_checks.bridge --contexts 50 --seed 0 [--smooth]`` measures, with the project's search
on the real simulator (:mod:`phyplan_agents.sim_search`: grid, model step, ES; the oracle's), the best reward with
and without the bridge per sampled context (and, with ``--smooth``, how smooth the end distance is near each
optimum). ``--chaos`` instead measures how far the landing moves when every action dimension moves by 1e-8, 1e-6
and 1e-4 rad, and when the timestep halves, over random actions (:mod:`benchmarks.design_checks.chaos`).
``--version 0`` checks the superseded Bridge-v0 (the disc puck) instead of the current version. The figures are
quoted in :mod:`phyplan_envs.tasks.bridge`'s docstrings.
"""
from __future__ import annotations

import numpy as np

from benchmarks.design_checks.chaos import final_positions, landing_moves, random_actions
from phyplan_agents.sim_search import search
from phyplan_envs.tasks.bridge import BridgeEnv, BridgeEnvV0

CLASSES = {0: BridgeEnvV0, 1: BridgeEnv}     # version -> class


def make(version: int, halved: bool = False):
    """Bridge-v``version`` without the Panda; ``halved``: at half its timestep (end-rule checks still every 5 ms)."""
    base = CLASSES[version]
    if not halved:
        return base(with_panda=False)

    def build_scene(self, root):
        base.build_scene(self, root)
        root.option.timestep = root.option.timestep / 2

    return type(base.__name__ + "Halved", (base,), {"build_scene": build_scene, "chunk": 2 * base.chunk})(
        with_panda=False)


def chaos(version: int, actions: int = 200, seed: int = 0, deltas=(1e-8, 1e-6, 1e-4)) -> dict:
    """How far (m) the landings of ``actions`` random actions move when the action moves by each delta and when the
    timestep halves."""
    env = make(version)
    out = {f"delta {d:g}": m for d, m in landing_moves(env, actions, seed, deltas).items()}
    acts = random_actions(env, actions, seed)
    out["timestep halved"] = np.linalg.norm(final_positions(make(version, halved=True), acts)
                                            - final_positions(env, acts), axis=1)
    return out


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
    lo, hi = env.unwrapped._low64, env.unwrapped._high64

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

    if args.chaos:
        print(f"Bridge-v{args.version}: landing moves over {args.actions} random actions (seed {args.seed}), mm")
        print("| change | median | p90 | max | share > 1 cm |")
        print("|---|---|---|---|---|")
        for name, m in chaos(args.version, args.actions, args.seed).items():
            mm = m * 1000
            print(f"| {name} | {np.median(mm):.2f} | {np.percentile(mm, 90):.2f} | {mm.max():.1f} | "
                  f"{np.mean(m > 0.01):.1%} |", flush=True)
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
