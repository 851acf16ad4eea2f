"""How chaotic a task's outcome is: how far the final position moves when the action moves by a tiny amount, and
when the timestep halves.

Used by ``python -m benchmarks.robot_check --sensitivity`` (the floor under robot-mode mismatches: no release is
exactly the kinematic one) and ``python -m benchmarks.design_checks.bridge --chaos`` (why Bridge-v1 has a block).
On its own it measures the nominal tasks (any registered id but the varied ones, whose check is
``benchmarks.design_checks.hidden_physics --only convergence``)::

    python -m benchmarks.design_checks.chaos --ids PhyPlan/Launch-v0 PhyPlan/Bridge-v0 --actions 200
    python -m benchmarks.design_checks.chaos --actions 200 --seed 7310000 --seed-step 7919 --deltas 1e-6

Action i is the i-th draw of ``numpy.random.default_rng(--seed)`` on the context ``reset(seed=--seed + --seed-step
* i)`` (the defaults: contexts 0 .. actions - 1, as ``robot_check``).
"""
from __future__ import annotations

import argparse
import importlib

import numpy as np

from benchmarks.design_checks import seeds as seeding


def random_actions(env, actions: int, seed: int) -> np.ndarray:
    """``actions`` uniform random actions in ``env``'s action box (``numpy.random.default_rng(seed)``): action i is
    tried on the context of ``reset(seed=i)``, as in ``robot_check`` (or of ``context_seeds[i]``)."""
    lo, hi = env.action_space.low.astype(np.float64), env.action_space.high.astype(np.float64)
    return lo + (hi - lo) * np.random.default_rng(seed).random((actions, len(lo)))


def final_positions(env, acts: np.ndarray, delta: float = 0.0, context_seeds=None) -> np.ndarray:
    """The final object position of each action (moved by ``delta`` in every dimension, capped at the upper bound)
    on the context of ``reset(seed=context_seeds[i])`` (default ``i``): ``(n, 3)``."""
    hi = env.action_space.high.astype(np.float64)
    contexts = range(len(acts)) if context_seeds is None else context_seeds
    if len(contexts) != len(acts):
        raise ValueError(f"{len(acts)} actions but {len(contexts)} context seeds")
    out = []
    for s, a in zip(contexts, acts):
        env.reset(seed=int(s))
        out.append(env.step(np.minimum(a + delta, hi))[4]["final_pos"])
    return np.array(out)


def landing_moves(env, actions: int, seed: int, deltas, context_seeds=None) -> dict[float, np.ndarray]:
    """Per delta, how far (m) each of ``actions`` random actions' final position moves when every action dimension
    moves by delta (rad or m)."""
    acts = random_actions(env, actions, seed)
    base = final_positions(env, acts, context_seeds=context_seeds)
    return {float(d): np.linalg.norm(final_positions(env, acts, float(d), context_seeds) - base, axis=1)
            for d in deltas}


def halved(cls: type, varied: bool = False) -> type:
    """``cls`` (a nominal task class; a varied one with ``varied=True``) at half its timestep, the end rule still
    checked every 5 ms."""
    if hasattr(cls, "base_task") and not varied:
        raise ValueError(f"{cls.__name__} is a varied task: its timestep check is benchmarks.design_checks."
                         f"hidden_physics --only convergence")

    # the timestep is set before the scene is built, so a contact calibrated at it (an impact pair) is calibrated at
    # the halved one
    return type(cls.__name__ + "Halved", (cls,), {"timestep": cls.timestep / 2, "chunk": 2 * cls.chunk})


def chaos(cls: type, actions: int, seed: int, deltas=(), context_seeds=None) -> dict[str, np.ndarray]:
    """How far (m) the final positions of ``actions`` random actions move when the action moves by each delta and
    when the timestep halves (``cls`` without the Panda)."""
    env = cls(with_panda=False)
    out = {f"delta {d:g}": m for d, m in landing_moves(env, actions, seed, deltas, context_seeds).items()}
    acts = random_actions(env, actions, seed)
    fine = final_positions(halved(cls)(with_panda=False), acts, context_seeds=context_seeds)
    out["timestep halved"] = np.linalg.norm(fine - final_positions(env, acts, context_seeds=context_seeds), axis=1)
    env.close()
    return out


def print_table(title: str, moves: dict[str, np.ndarray]) -> None:
    print(title)
    print("| change | median | p90 | max | share > 1 cm |")
    print("|---|---|---|---|---|")
    for name, m in moves.items():
        mm = m * 1000
        print(f"| {name} | {np.median(mm):.2f} | {np.percentile(mm, 90):.2f} | {mm.max():.1f} | "
              f"{np.mean(m > 0.01):.1%} |", flush=True)


def env_class(env_id: str) -> type:
    """The class registered for ``env_id``."""
    import gymnasium as gym

    import phyplan_envs  # noqa: F401  (registers the ids)

    if env_id not in gym.registry:
        raise ValueError(f"unknown id {env_id!r}")
    module, _, attr = str(gym.spec(env_id).entry_point).partition(":")
    return getattr(importlib.import_module(module), attr)


def main(argv=None) -> None:
    import phyplan_envs

    p = argparse.ArgumentParser(prog="python -m benchmarks.design_checks.chaos",
                                description="How far a nominal task's final position moves when the timestep halves "
                                            "(and for tiny action changes).")
    p.add_argument("--ids", nargs="+", default=[phyplan_envs.env_id(t) for t in phyplan_envs.TASKS],
                   help="registered ids (default: the nominal tasks' current ids)")
    p.add_argument("--actions", type=int, default=200, help="random actions per id (default 200)")
    p.add_argument("--deltas", nargs="*", type=float, default=[],
                   help="also move every action dimension by these amounts (rad or m)")
    seeding.add_arguments(p)
    args = p.parse_args(argv)
    seeding.check(p, args, args.actions, "--actions")
    try:
        classes = {i: env_class(i) for i in args.ids}
        for cls in classes.values():
            halved(cls)
    except ValueError as e:
        p.error(f"--ids: {e}")
    first = args.seed or 0
    contexts = seeding.seed_list(first, args.seed_step, args.actions)
    for env_id, cls in classes.items():
        moves = chaos(cls, args.actions, first, args.deltas, contexts)
        print_table(f"\n{env_id}: final-position moves, mm ({args.actions} random actions of default_rng({first}) on "
                    f"the contexts of {seeding.describe(contexts)})", moves)


if __name__ == "__main__":
    main()
