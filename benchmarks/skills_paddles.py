"""Validation of the Paddles task's skills (swing_wide, hit_wide, throw_wide, glide, bounce_general_low(_cond)).

    python -m benchmarks.skills_paddles                  # the shipped weights on the fixed validation sets
    python -m benchmarks.skills_paddles --seed 7310000 --n 500 --skills glide,throw_wide

Per shipped model: ``n`` MuJoCo samples of its skill (:func:`phyplan_envs.skill_scenes.generate`, seed ``--seed``;
default the validation seed ``training.VAL_SEED`` with 2000 samples: the figures the training command prints),
RMSE and max |error| per output in physical units. For ``bounce_general_low_cond`` also the hidden-physics test
space of ``PADDLE_RESTITUTION`` ((0.02, 0.05) U (0.25, 0.4): restitutions the data never cover), and for the low
bounces the fraction of arrivals that separate from the face (the others end at the rebound's peak).
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from phyplan_envs import skill_scenes as ss
from phyplan_envs.skill_scenes import bounce_general_low as bgl
from phyplan_agents.skills import load_skill, training
from phyplan_agents.skills.models import PINN_SKILLS

SKILLS = ("swing_wide", "hit_wide", "throw_wide", "glide", "bounce_general_low", "bounce_general_low_cond")
TRAIN_SEEDS = (training.SHIPPED_SEED,)


def _row(name: str, model, x, y) -> str:
    err = model.predict(x).double().numpy() - y
    rmse = np.sqrt((err ** 2).mean(axis=0))
    mx = np.abs(err).max(axis=0)
    cells = ", ".join(f"{o} {r:.4g} (max {m:.3g})" for o, r, m in zip(model.outputs, rmse, mx))
    return f"  {name:<34} {cells}"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.skills_paddles", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seed", type=int, default=training.VAL_SEED, help="data seed (default: the validation seed)")
    p.add_argument("--n", type=int, default=training.VAL_SIZE, help="samples per skill (default 2000)")
    p.add_argument("--skills", default=",".join(SKILLS), help="comma-separated subset")
    p.add_argument("--directory", default=None, help="weights folder (default: the shipped one)")
    args = p.parse_args(argv)
    if args.seed in TRAIN_SEEDS:
        p.error(f"seed {args.seed} is the training data's seed")
    if args.n < 1:
        p.error("--n must be positive")
    skills = [s.strip() for s in args.skills.split(",") if s.strip()]
    bad = set(skills) - set(SKILLS)
    if bad:
        p.error(f"unknown skills {sorted(bad)}; choose from {', '.join(SKILLS)}")
    import torch
    torch.set_num_threads(1)
    for skill in skills:
        t0 = time.perf_counter()
        d = ss.generate(skill, args.n, args.seed)
        kinds = ("pinn", "nn") if skill in PINN_SKILLS else ("nn",)
        print(f"{skill}: n {len(d)}, seed {args.seed} ({time.perf_counter() - t0:.0f} s data)")
        if "separated" in d.extras:
            print(f"  separated from the face: {d.extras['separated'].mean():.3f} of the arrivals")
        for kind in kinds:
            m = load_skill(skill, kind, args.directory)
            print(_row(f"{kind}" + "".join(f" {k}={v:.4g}" for k, v in m.params.items()), m, d.inputs,
                       d.outputs))
        if skill == "bounce_general_low_cond":
            rng = np.random.default_rng([args.seed, 99])
            parts = [bgl.sample(max(1, args.n // 4), rng, "varied", restitution=iv)
                     for iv in bgl.COND_PARAM.test]
            x = np.concatenate([q[0] for q in parts])
            y = np.concatenate([q[1] for q in parts])
            for kind in kinds:
                m = load_skill(skill, kind, args.directory)
                print(_row(f"{kind}, test space {bgl.COND_PARAM.test}", m, x, y))
    return 0


if __name__ == "__main__":
    sys.exit(main())
