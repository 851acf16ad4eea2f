"""Skill-learning study (the paper's Figs. 5, 6, 13): PINN vs NN against training-set size, and mu estimation.

For the swing, slide and throw skills, trains a PINN and an NN (same network, data loss only) on the first n samples
of a seeded MuJoCo data set, for every n in ``--sizes`` and every seed in ``--seeds``, and scores each on a fixed
validation set (``phyplan_agents.skills.training.VAL_SEED``). Writes to ``--out``:

* ``runs.jsonl`` (appended as trainings finish) and ``runs.csv``: one row per (skill, kind, size, seed): normalised validation MSE (mean over outputs of MSE / output
  variance), per-output RMSE in physical units, the learnt mu (slide PINN), training seconds;
* ``summary.md``: mean (and min-max over seeds) validation nMSE per skill, size and kind; whether the PINN beats the NN
  at every size <= 200 (all seeds' means); the mu estimation error against the simulator's measured mu;
* ``nmse_<skill>.png`` and ``mu_error.png``.

Usage::

    nice -n 10 python -m benchmarks.skills --out results/skills            # full study (~30-40 min on 2 cores)
    python -m benchmarks.skills --quick --out /tmp/skills_quick              # smoke run (~1-2 min)
    python -m benchmarks.skills --perception --out results/skills_perception  # data read from camera frames

``--perception`` (the paper's Fig. 5, left): the swing, slide and throw skills trained on data read from rendered
frames of their scenes by the perception pipeline (:mod:`phyplan_agents.perception.skill_data`: the same initial
conditions and query times as the simulator's data, row for row), default sizes 25, 50, 100, 200. The data are made once per skill
and seed in the main process (``perception_<skill>_seed<s>.npz`` in ``--out``, reused when big enough); the summary
adds their reading error against the simulator's values of the same rows. Validation is on the simulator's data.
Of the three PINNs only the slide's has an unknown physical parameter (mu); the throw and swing PINNs take g (and
the rig's pendulum length) as known constants, so there is nothing of theirs to estimate.
"""
from __future__ import annotations

import argparse
import csv
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

SIZES = (25, 50, 100, 200, 500, 1000)
SEEDS = (0, 1, 2)
SKILLS = ("swing", "slide", "throw")
KINDS = ("pinn", "nn")
# Study training settings: fewer steps than the shipped models (108 trainings must fit in ~40 min on 2 cores).
STUDY_STEPS = 1200
STUDY_LBFGS = 120
MU_GOAL = 0.005          # target: mu within 0.5 % from <= 1000 points

from .skills_chain import chain_accuracy  # noqa: E402  (--chain)
from .skills_perception import PERCEPTION_SIZES, PERCEPTION_SKILLS, perception_data, reading_error  # noqa: E402


def _job(args):
    """Train one model (in a worker process) and return its record."""
    skill, kind, n, seed, steps, lbfgs, n_val, *given = args
    import torch

    torch.set_num_threads(1)
    from phyplan_agents.skills import training
    from phyplan_envs import skill_scenes

    if given:       # --perception: the data read from camera frames, (inputs, outputs)
        data = skill_scenes.SkillData(skill, given[0][0][:n].copy(), given[0][1][:n].copy(), seed)
    else:
        data = _pool(skill, seed, n)
    val = _val(skill, n_val)
    cfg = training.TrainConfig(steps=steps, lbfgs_steps=lbfgs)
    model = training.fit(skill, kind, data, seed=seed, config=cfg, val=val)
    v = model.meta["validation"]
    rec = {"skill": skill, "kind": kind, "n": n, "seed": seed, "nmse": v["nmse"],
           "train_seconds": model.meta["train_seconds"]}
    if given:
        rec["data"] = "perception"
    for k, val_ in v["rmse"].items():
        rec[f"rmse_{k}"] = val_
    if "mu" in model.params:
        rec["mu"] = model.params["mu"]
        rec["true_mu"] = skill_scenes.measured_slide_mu()
        rec["mu_rel_err"] = abs(rec["mu"] / rec["true_mu"] - 1.0)
    return rec


_POOLS: dict = {}
_VALS: dict = {}


def _pool(skill: str, seed: int, n: int):
    """The first n samples of the seed's data stream (cached per worker process; a prefix of the largest set)."""
    from phyplan_envs import skill_scenes

    key = (skill, seed)
    have = _POOLS.get(key)
    if have is None or len(have) < n:
        need = max(n, _POOL_SIZE.get(skill, n))
        _POOLS[key] = have = skill_scenes.generate(skill, need, seed)
    return have.head(n)


_POOL_SIZE: dict = {}


def _val(skill: str, n_val: int):
    from phyplan_agents.skills import training

    if skill not in _VALS:
        _VALS[skill] = training.validation_set(skill, n_val)
    return _VALS[skill]


def _init_worker(pool_sizes):
    _POOL_SIZE.update(pool_sizes)
    os.environ.setdefault("OMP_NUM_THREADS", "1")


def summarise(rows: list[dict], sizes, out: Path) -> str:
    """The markdown summary of the runs (also written to ``out/summary.md``)."""
    skills = sorted({r["skill"] for r in rows}, key=lambda s: SKILLS.index(s) if s in SKILLS else 9)
    lines = ["# Skill learning: PINN vs NN (validation nMSE)", "",
             "nMSE = mean over outputs of (MSE / variance of that output on the validation set); mean over seeds, "
             "min-max in brackets.", ""]
    verdicts = []
    for skill in skills:
        lines += [f"## {skill}", "", "| n | PINN | NN | PINN < NN (means) | seeds with PINN < NN |",
                  "|---|---|---|---|---|"]
        for n in sizes:
            cell = {}
            for kind in KINDS:
                v = [r["nmse"] for r in rows if r["skill"] == skill and r["kind"] == kind and r["n"] == n]
                cell[kind] = (float(np.mean(v)), min(v), max(v)) if v else None
            if cell["pinn"] is None or cell["nn"] is None:
                continue
            better = cell["pinn"][0] < cell["nn"][0]
            if n <= 200:
                verdicts.append((skill, n, better))
            fmt = lambda c: f"{c[0]:.3g} [{c[1]:.2g}-{c[2]:.2g}]"  # noqa: E731
            by_seed = {(r["seed"], r["kind"]): r["nmse"] for r in rows if r["skill"] == skill and r["n"] == n}
            seeds = sorted({sd for sd, _ in by_seed if (sd, "pinn") in by_seed and (sd, "nn") in by_seed})
            wins = sum(by_seed[(sd, "pinn")] < by_seed[(sd, "nn")] for sd in seeds)
            lines.append(f"| {n} | {fmt(cell['pinn'])} | {fmt(cell['nn'])} | {'yes' if better else 'NO'} | "
                         f"{wins}/{len(seeds)} |")
        lines.append("")
    ok = all(b for _, _, b in verdicts)
    lines.append(f"**Goal: PINN below NN at every size <= 200: {'met' if ok else 'NOT met'}** "
                 f"({sum(b for *_, b in verdicts)}/{len(verdicts)} skill-size cells).")
    lines.append("")
    mu_rows = [r for r in rows if "mu" in r]
    if mu_rows:
        true_mu = mu_rows[0]["true_mu"]
        lines += ["## Friction coefficient learnt by the slide PINN", "",
                  f"Simulator's mu: {true_mu:.5f} (measured deceleration / g of the puck on the task table; MuJoCo's "
                  f"nominal friction is 0.2). Relative error |mu / mu_sim - 1|:", "",
                  "| n | mu (per seed) | mean error | max error |", "|---|---|---|---|"]
        first_ok = None
        for n in sizes:
            rs = [r for r in mu_rows if r["n"] == n]
            if not rs:
                continue
            errs = [r["mu_rel_err"] for r in rs]
            if max(errs) <= MU_GOAL and first_ok is None:
                first_ok = n
            mus = ", ".join(f"{r['mu']:.5f}" for r in sorted(rs, key=lambda r: r["seed"]))
            lines.append(f"| {n} | {mus} | {100 * np.mean(errs):.2f} % | {100 * max(errs):.2f} % |")
        lines += ["", f"**Goal: mu within 0.5 % (every seed) from <= 1000 points: "
                      f"{'met from n = ' + str(first_ok) if first_ok and first_ok <= 1000 else 'NOT met'}**", ""]
    from phyplan_agents.skills.models import LEARNT_PARAMS

    fixed = [sk for sk in skills
             if sk not in LEARNT_PARAMS and any(r["skill"] == sk and r["kind"] == "pinn" for r in rows)]
    if fixed:
        lines += [f"PINNs with no unknown physical parameter to estimate: {', '.join(fixed)} (g, and for the swing "
                  "the rig's pendulum length, are given constants of their equations).", ""]
    text = "\n".join(lines)
    (out / "summary.md").write_text(text + "\n")
    return text


def plot(rows: list[dict], sizes, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    for skill in sorted({r["skill"] for r in rows}):
        fig, ax = plt.subplots(figsize=(5, 3.6))
        for kind, style in (("pinn", "o-"), ("nn", "s--")):
            ns, mean, lo, hi = [], [], [], []
            for n in sizes:
                v = [r["nmse"] for r in rows if r["skill"] == skill and r["kind"] == kind and r["n"] == n]
                if v:
                    ns.append(n)
                    mean.append(np.mean(v))
                    lo.append(min(v))
                    hi.append(max(v))
            if ns:
                mean, lo, hi = map(np.array, (mean, lo, hi))
                ax.errorbar(ns, mean, yerr=[mean - lo, hi - mean], fmt=style, capsize=3, label=kind.upper())
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("training points")
        ax.set_ylabel("validation nMSE")
        ax.set_title(f"{skill}: PINN vs NN")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / f"nmse_{skill}.png", dpi=120)
        plt.close(fig)
    mu_rows = [r for r in rows if "mu" in r]
    if mu_rows:
        fig, ax = plt.subplots(figsize=(5, 3.6))
        ns = sorted({r["n"] for r in mu_rows})
        for seed in sorted({r["seed"] for r in mu_rows}):
            e = [100 * next((r["mu_rel_err"] for r in mu_rows if r["n"] == n and r["seed"] == seed), np.nan)
                 for n in ns]
            ax.plot(ns, e, "o-", alpha=0.7, label=f"seed {seed}")
        ax.axhline(100 * MU_GOAL, color="k", ls=":", label="0.5 % goal")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("training points")
        ax.set_ylabel("|mu / mu_sim - 1| (%)")
        ax.set_title("slide PINN: friction estimate")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / "mu_error.png", dpi=120)
        plt.close(fig)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.skills", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default="results/skills", help="output folder (default results/skills)")
    p.add_argument("--sizes", default=",".join(map(str, SIZES)), help="training-set sizes")
    p.add_argument("--seeds", default=",".join(map(str, SEEDS)), help="seeds")
    p.add_argument("--skills", default=",".join(SKILLS), help="skills (of swing, slide, throw)")
    p.add_argument("--steps", type=int, default=STUDY_STEPS, help=f"Adam steps per model (default {STUDY_STEPS})")
    p.add_argument("--lbfgs-steps", type=int, default=STUDY_LBFGS, help=f"L-BFGS iterations (default {STUDY_LBFGS})")
    p.add_argument("--n-val", type=int, default=2000, help="validation samples per skill (default 2000)")
    p.add_argument("--workers", type=int, default=2, help="parallel worker processes (default 2)")
    p.add_argument("--resume", action="store_true",
                   help="keep the trainings already in <out>/runs.jsonl (same step settings) and run the rest")
    p.add_argument("--chain", action="store_true",
                   help="only measure the shipped models' Launch/Slide chain predictions against the tasks")
    p.add_argument("--perception", action="store_true",
                   help="the skills trained on data read from camera frames (module docstring)")
    p.add_argument("--quick", action="store_true",
                   help="smoke run: sizes 25,200, one seed, 150 steps, 10 L-BFGS, 300 validation samples")
    args = p.parse_args(argv)
    if args.perception:
        if args.skills == ",".join(SKILLS):
            args.skills = ",".join(PERCEPTION_SKILLS)
        if any(s.strip() not in PERCEPTION_SKILLS for s in args.skills.split(",")):
            p.error(f"--perception trains {' and '.join(PERCEPTION_SKILLS)} only")
        if args.sizes == ",".join(map(str, SIZES)):
            args.sizes = ",".join(map(str, PERCEPTION_SIZES))
    if args.quick:
        args.sizes, args.seeds, args.steps, args.lbfgs_steps, args.n_val = "25,200", "0", 150, 10, 300
    try:
        sizes = sorted({int(s) for s in args.sizes.split(",")})
        seeds = [int(s) for s in args.seeds.split(",")]
        skills = [s.strip() for s in args.skills.split(",")]
    except ValueError:
        p.error("--sizes and --seeds take comma-separated integers")
    if any(s not in SKILLS for s in skills):
        p.error(f"--skills must be among {SKILLS}")
    if min(sizes) < 2 or args.workers < 1 or args.n_val < 10:
        p.error("sizes must be >= 2, workers >= 1, n-val >= 10")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.chain:
        rows = chain_accuracy()
        lines = ["Launch/Slide: action = release angle theta (rad, phi = 0.3), speed in = predicted bob speed, speed "
                 "out = hit model's object speed. Bounce: action = drop height (m, yaw 0.7), speed in = predicted "
                 "impact speed, speed out = bounce model's outgoing speed. Distances from the object's start (the "
                 "wedge axis for Bounce) to where the episode ends.", "",
                 "| task | action | speed in (m/s) | speed out (m/s) | predicted (m) | simulated (m) | error (cm) |",
                 "|---|---|---|---|---|---|---|"]
        lines += [f"| {r['task']} | {r['action']:.3f} | {r['v_in']:.4f} | {r['v_object']:.4f} | "
                  f"{r['predicted']:.4f} | {r['simulated']:.4f} | {100 * r['error']:+.2f} |" for r in rows]
        for task in ("launch", "slide", "bounce"):
            e = [abs(r["error"]) for r in rows if r["task"] == task]
            lines.append(f"\n{task}: mean |error| {100 * np.mean(e):.2f} cm, max {100 * max(e):.2f} cm")
        text = "\n".join(lines)
        (out / "chain.md").write_text(text + "\n")
        print(text)
        return 0

    jobs = [(s, k, n, seed, args.steps, args.lbfgs_steps, args.n_val)
            for s in skills for n in sorted(sizes, reverse=True) for seed in seeds for k in KINDS]
    reading = ""
    if args.perception:
        given = {(skill, seed): perception_data(out, skill, seed, max(sizes)) for skill in skills for seed in seeds}
        jobs = [j + ((given[j[0], j[3]].inputs, given[j[0], j[3]].outputs),) for j in jobs]
        reading = reading_error(given, max(sizes))
    # PINN jobs first (longest), so the two workers finish together
    jobs.sort(key=lambda j: (j[1] != "pinn", -j[2]))
    print(f"{len(jobs)} trainings ({len(skills)} skills x {len(sizes)} sizes x {len(seeds)} seeds x 2 kinds), "
          f"{args.workers} workers, {args.steps} Adam + {args.lbfgs_steps} L-BFGS steps each", flush=True)
    from tqdm.auto import tqdm

    # every finished training is appended to runs.jsonl at once (nothing is lost if the run is stopped); --resume
    # skips the (skill, kind, n, seed) already there with the same step settings
    log = out / "runs.jsonl"
    rows = []
    if args.resume and log.is_file():
        for line in log.read_text().splitlines():
            rec = json.loads(line)
            if rec.get("steps") == args.steps and rec.get("lbfgs_steps") == args.lbfgs_steps:
                rows.append(rec)
        done = {(r["skill"], r["kind"], r["n"], r["seed"]) for r in rows}
        jobs = [j for j in jobs if (j[0], j[1], j[2], j[3]) not in done]
        print(f"resuming: {len(rows)} trainings done, {len(jobs)} to go", flush=True)
    elif log.exists():
        log.unlink()
    t0 = time.perf_counter()
    pool_sizes = {s: max(sizes) for s in skills}
    with ProcessPoolExecutor(max_workers=args.workers, initializer=_init_worker, initargs=(pool_sizes,)) as ex:
        futures = [ex.submit(_job, j) for j in jobs]
        for fut in tqdm(as_completed(futures), total=len(futures), desc="trainings"):
            rec = fut.result()
            rec.update(steps=args.steps, lbfgs_steps=args.lbfgs_steps)
            rows.append(rec)
            with open(log, "a") as f:
                f.write(json.dumps(rec) + "\n")
    wall = time.perf_counter() - t0
    rows = [r for r in rows if r["skill"] in skills and r["n"] in sizes and r["seed"] in seeds]
    rows.sort(key=lambda r: (SKILLS.index(r["skill"]), r["n"], r["seed"], r["kind"]))
    fields = sorted({k for r in rows for k in r}, key=lambda k: (k not in ("skill", "kind", "n", "seed"), k))
    with open(out / "runs.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    text = summarise(rows, sizes, out)
    if reading:
        text = reading + "\n\n" + text
        (out / "summary.md").write_text(text + "\n")
    plot(rows, sizes, out)
    cmd = "python -m benchmarks.skills " + " ".join(sys.argv[1:] if argv is None else argv)
    if args.resume and (out / "meta.json").is_file():      # add the earlier invocations' wall time
        wall += json.loads((out / "meta.json").read_text()).get("wall_seconds", 0.0)
    (out / "meta.json").write_text(json.dumps({"command": cmd, "wall_seconds": round(wall, 1),
                                               "sizes": sizes, "seeds": seeds, "skills": skills,
                                               "steps": args.steps, "lbfgs_steps": args.lbfgs_steps,
                                               "n_val": args.n_val, "workers": args.workers}, indent=1) + "\n")
    print(text)
    print(f"\nwall time {wall / 60:.1f} min; wrote {out}/runs.csv, summary.md, *.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
