"""How far a last-bit difference moves each registered id's outcome: the evidence behind the cross-machine part of the
reproducibility contract (README, "Reproducibility"; docs/reproducibility.md).

Another CPU (or another SIMD path of MuJoCo, numpy, libm or BLAS) changes results in their last bits. This command
makes such a change on purpose: for each registered id it runs ``--actions`` random actions on contexts of the
``dev`` split, then the same actions moved by one unit in the last place (``np.nextafter`` towards the upper bound,
every dimension), and prints per id the largest and the 99th-percentile change of the reward and of the final
position, and the share of landings moved by more than 1 mm and by more than 1 cm::

    python -m benchmarks.repro_check                 # every registered id, 100 actions each
    python -m benchmarks.repro_check --ids PhyPlan/Bridge-v0 PhyPlan/Bridge-v1 --actions 200

An id whose outcomes move by millimetres here is chaotic: its results agree across machines only statistically.
"""
from __future__ import annotations

import argparse
import sys
import warnings
from typing import Sequence

import numpy as np


def last_bit_moves(env_id: str, n_actions: int, seed: int = 0) -> dict[str, float]:
    """The changes of reward and final position (m) when every action dimension moves by one ulp."""
    import gymnasium as gym

    import phyplan_envs  # noqa: F401  (registers the ids)
    from benchmarks import splits

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", ".*out of date")
        env = gym.make(env_id, obs_mode="state").unwrapped
    rng = np.random.default_rng(seed)
    lo, hi = env.action_space.low.astype(np.float64), env.action_space.high.astype(np.float64)
    contexts = splits.context_seeds("dev", n_actions)
    dr, dp = [], []
    for ctx in contexts:
        a = lo + (hi - lo) * rng.random(len(lo))
        out = []
        for action in (a, np.nextafter(a, hi)):
            env.reset(seed=ctx)
            _, reward, _, _, info = env.step(action)
            out.append((float(reward), np.asarray(info["final_pos"], dtype=np.float64)))
        dr.append(abs(out[0][0] - out[1][0]))
        dp.append(float(np.linalg.norm(out[0][1] - out[1][1])))
    env.close()
    dr, dp = np.array(dr), np.array(dp)
    return {"reward_max": float(dr.max()), "reward_p99": float(np.quantile(dr, 0.99)), "pos_max": float(dp.max()),
            "pos_p99": float(np.quantile(dp, 0.99)), "over_1mm": float(np.mean(dp > 1e-3)),
            "over_1cm": float(np.mean(dp > 1e-2))}


def main(argv: Sequence[str] | None = None) -> int:
    import gymnasium as gym

    import phyplan_envs  # noqa: F401

    p = argparse.ArgumentParser(prog="python -m benchmarks.repro_check", description=__doc__.split("\n\n")[0])
    p.add_argument("--ids", nargs="+", metavar="ID", help="registered ids (default: every PhyPlan id)")
    p.add_argument("--actions", type=int, default=100, help="random actions (one dev context each) per id")
    p.add_argument("--seed", type=int, default=0, help="seed of the random actions")
    args = p.parse_args(argv)
    known = sorted(i for i in gym.registry if i.startswith("PhyPlan/"))
    ids = args.ids or known
    bad = [i for i in ids if i not in known]
    if bad:
        p.error(f"--ids: unknown id(s) {', '.join(bad)}; registered: {', '.join(known)}")
    if not 1 <= args.actions <= 1000:
        p.error(f"--actions must be in 1..1000 (the dev split's size), got {args.actions}")
    print(f"Outcome change when every action dimension moves by one ulp ({args.actions} actions per id, seed "
          f"{args.seed})\n")
    print("| id | reward max | reward p99 | position max (mm) | position p99 (mm) | > 1 mm | > 1 cm |")
    print("|---|---|---|---|---|---|---|")
    for env_id in ids:
        m = last_bit_moves(env_id, args.actions, args.seed)
        print(f"| {env_id} | {m['reward_max']:.1e} | {m['reward_p99']:.1e} | {1e3 * m['pos_max']:.2g} | "
              f"{1e3 * m['pos_p99']:.2g} | {100 * m['over_1mm']:.0f}% | {100 * m['over_1cm']:.0f}% |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
