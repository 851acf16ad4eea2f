"""Solvability certificate: the oracle searches the real simulator on N contexts per task.

A context counts as *solvable* when the oracle finds an action whose reward is >= 0.95 (the object ends within 5%
of its initial distance from the goal centre). The contexts are those of ``env.reset(seed=s)`` for
``s = first_seed + seed_step * i``, ``i < contexts`` (default seeds 0..49; ``--first-seed 7310000 --seed-step 7919``
are contexts outside every split). A varied task draws its hidden physics from the space of the seed's split (test
split: test space, any other seed: train space) unless ``--physics-space`` names one. Every best action is replayed
once in a fresh env reset to the same context, and that replayed reward is the one reported. The oracle's search is
:mod:`phyplan_agents.sim_search` with its defaults (see :mod:`phyplan_agents.oracle`) except ``--budget`` and
``--stop-reward``. With ``--restarts R`` a context that a search leaves below the threshold is searched again with
the next oracle seed, up to R searches; the table says how many contexts the first search solved.

Usage::

    python -m benchmarks.solvability --tasks launch slide --contexts 50 --budget 200 --workers 2

Prints per task the share of solvable contexts, the mean and minimum best reward, the mean oracle regret
``max(0, 1 - best)``, the simulator calls and seconds per context, then every unsolved context (seed, goal, best
reward, best action) so that goal samplers can be fixed. Writes ``solvability.md``, ``summary.csv`` and
``contexts.csv`` (one row per context) to ``--out`` (default ``results/solvability``). The exit status is 1 if any
task's solvable share is below ``--require`` (default 0.98, the suite's target), else 0.

Results are deterministic: a context's search depends only on (task, seed, oracle seed, budget), not on the worker
that ran it or on the other contexts.
"""
from __future__ import annotations

import argparse
import csv
import math
import multiprocessing as mp
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.design_checks.seeds import SEED_BOUND, describe

THRESHOLD = 0.95
_ENVS: dict[tuple[str, str], tuple[Any, Any]] = {}


def _envs(task: str, physics_space: str = "auto"):
    """One env for the replay and one private env for the oracle's simulator, per task, physics space and process."""
    if (task, physics_space) not in _ENVS:
        import gymnasium as gym
        import phyplan_envs

        kwargs = {"physics_space": physics_space} if task in phyplan_envs.VARIED_TASKS else {}
        _ENVS[task, physics_space] = (gym.make(phyplan_envs.env_id(task), **kwargs),
                                      gym.make(phyplan_envs.env_id(task), **kwargs))
    return _ENVS[task, physics_space]


def certify_context(job: tuple) -> dict[str, Any]:
    """Search the context of ``env.reset(seed=seed)`` up to ``restarts`` times; return one result row.

    Search ``r`` (from 0) uses oracle seed ``oracle_seed + r``; a search runs only while no earlier one reached the
    threshold. The row reports the best replayed reward over the searches, the search that found it, and the
    simulator calls and seconds of all of them.
    """
    task, seed, budget, oracle_seed, stop_reward, sim_workers, physics_space, restarts = job
    from phyplan_agents import Simulator, TaskInfo
    from phyplan_agents.oracle import OracleAgent

    env, sim_env = _envs(task, physics_space)
    obs, info = env.reset(seed=seed)
    start = np.asarray(info["object_pos"], dtype=np.float64)
    goal = np.asarray(info["goal"], dtype=np.float64)
    best: dict[str, Any] | None = None
    calls, seconds = 0, 0.0
    for search in range(restarts):
        agent = OracleAgent(budget=budget, stop_reward=stop_reward)
        agent.setup(TaskInfo.from_env(env), seed=oracle_seed + search)
        simulator = Simulator(sim_env.unwrapped, info["context"], workers=sim_workers)
        t0 = time.perf_counter()
        agent.begin_context(obs, info, simulator)
        action = agent.act()
        seconds += time.perf_counter() - t0
        calls += int(simulator.calls)
        # replay the best action in the evaluation env (the reward an agent would get)
        env.reset(options={"context": info["context"]})
        _, reward, _, _, step_info = env.step(action)
        if best is None or reward > best["reward"]:
            best = {"reward": float(reward), "search": search, "action": np.asarray(action, dtype=np.float64),
                    "step_info": step_info, "result": agent.result, "names": agent.task.action_names}
        if best["reward"] >= THRESHOLD:
            break
    res, step_info = best["result"], best["step_info"]
    rel = goal - start[:2]
    row = {
        "task": task, "seed": seed,
        "goal_x": float(goal[0]), "goal_y": float(goal[1]),
        "goal_distance": float(np.hypot(*rel)), "goal_angle": float(math.atan2(rel[1], rel[0])),
        "best_reward": best["reward"], "search_reward": float(res.best_reward),
        "grid_best_reward": float(res.grid_best_reward),
        "regret": max(0.0, 1.0 - best["reward"]), "solved": bool(best["reward"] >= THRESHOLD),
        "is_success": bool(step_info["is_success"]), "final_distance": float(step_info["distance"]),
        "end_reason": step_info["end_reason"], "searches": search + 1, "best_search": best["search"],
        "sim_calls": calls, "seconds": float(seconds),
    }
    for name, value in zip(best["names"], best["action"]):
        row[f"action_{name}"] = float(value)
    return row


def summarise(rows: list[dict[str, Any]]) -> dict[str, Any]:
    best = np.array([r["best_reward"] for r in rows])
    return {
        "task": rows[0]["task"], "contexts": len(rows),
        "solvable_share": float(np.mean(best >= THRESHOLD)),
        "mean_best_reward": float(best.mean()), "min_best_reward": float(best.min()),
        "mean_regret": float(np.mean([r["regret"] for r in rows])),
        "in_goal_box_share": float(np.mean([r["is_success"] for r in rows])),
        "median_sim_calls": float(np.median([r["sim_calls"] for r in rows])),
        "mean_seconds": float(np.mean([r["seconds"] for r in rows])),
        "seeds": describe(sorted(r["seed"] for r in rows)),
        "solved_by_first_search": int(sum(r["solved"] and r["best_search"] == 0 for r in rows)),
        "max_searches": int(max(r["searches"] for r in rows)),
    }


def markdown(summaries: list[dict[str, Any]], rows: list[dict[str, Any]], command: str) -> str:
    lines = [f"Command: `{command}`", "",
             "| task | contexts (seeds) | solvable (best >= 0.95) | by the first search | searches (max) | mean best | "
             "min best | mean oracle regret | in goal box | median sim calls | s / context |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in summaries:
        lines.append(f"| {s['task']} | {s['contexts']} ({s['seeds']}) | {100 * s['solvable_share']:.0f}% | "
                     f"{s['solved_by_first_search']}/{s['contexts']} | {s['max_searches']} | "
                     f"{s['mean_best_reward']:.4f} | {s['min_best_reward']:.4f} | {s['mean_regret']:.4f} | "
                     f"{100 * s['in_goal_box_share']:.0f}% | {s['median_sim_calls']:.0f} | {s['mean_seconds']:.2f} |")
    unsolved = [r for r in rows if not r["solved"]]
    lines += ["", f"Unsolved contexts: {len(unsolved)}"]
    if unsolved:
        lines += ["", "| task | seed | goal (x, y) | goal distance | goal angle (rad) | best reward | searches | "
                      "best action |",
                  "|---|---|---|---|---|---|---|---|"]
        for r in unsolved:
            act = ", ".join(f"{k[7:]}={v:.4f}" for k, v in r.items() if k.startswith("action_"))
            lines.append(f"| {r['task']} | {r['seed']} | ({r['goal_x']:.3f}, {r['goal_y']:.3f}) | "
                         f"{r['goal_distance']:.3f} | {r['goal_angle']:.3f} | {r['best_reward']:.4f} | "
                         f"{r['searches']} | {act} |")
    return "\n".join(lines) + "\n"


def _write_csv(path: Path, rows: list[dict[str, Any]]) -> None:
    fields: list[str] = []
    for r in rows:
        fields += [k for k in r if k not in fields]
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)


def main(argv: list[str] | None = None) -> int:
    import phyplan_envs

    p = argparse.ArgumentParser(prog="python -m benchmarks.solvability", description=__doc__.split("\n\n")[0])
    p.add_argument("--tasks", nargs="+", default=list(phyplan_envs.TRACKS["nominal"]), metavar="TASK",
                   help=f"tasks to certify (default: the nominal track {' '.join(phyplan_envs.TRACKS['nominal'])}; the "
                        f"varied ones, e.g. launch-varied, by name)")
    p.add_argument("--contexts", type=int, default=50, help="contexts per task (default 50)")
    p.add_argument("--first-seed", type=int, default=0,
                   help="contexts are env.reset(seed=FIRST_SEED + SEED_STEP * i) (default 0)")
    p.add_argument("--seed-step", type=int, default=1, help="step between the contexts' seeds (default 1)")
    p.add_argument("--physics-space", choices=("auto", "train", "test"), default="auto",
                   help="the varied tasks' physics space (default auto: test for test-split seeds, else train)")
    p.add_argument("--budget", type=int, default=200, help="oracle simulator calls per context (default 200)")
    p.add_argument("--stop-reward", type=float, default=0.995,
                   help="the oracle stops searching at this reward (default 0.995, its default)")
    p.add_argument("--oracle-seed", type=int, default=0, help="seed of the oracle's random draws (default 0)")
    p.add_argument("--restarts", type=int, default=1,
                   help="searches per context at most: a context not solved by search r (oracle seed ORACLE_SEED + "
                        "r) is searched again, each time with the full budget (default 1: one search)")
    p.add_argument("--workers", type=int, default=1, help="processes over contexts (default 1)")
    p.add_argument("--sim-workers", type=int, default=1,
                   help="processes for the oracle's batched simulator calls within a context (its grid; default 1; "
                        "the results do not depend on it)")
    p.add_argument("--require", type=float, default=0.98,
                   help="exit with status 1 if a task's solvable share is below this (default 0.98)")
    p.add_argument("--out", default="results/solvability", help="output directory (default results/solvability)")
    args = p.parse_args(argv)

    unknown = [t for t in args.tasks if t not in phyplan_envs.ALL_TASKS]
    if unknown:
        p.error(f"unknown task(s) {unknown}; available: {', '.join(phyplan_envs.ALL_TASKS)}")
    if args.contexts < 1 or args.budget < 4 or args.workers < 1 or args.sim_workers < 1 or args.restarts < 1:
        p.error("--contexts, --restarts, --workers and --sim-workers must be >= 1 and --budget >= 4")
    if args.first_seed < 0:
        p.error(f"--first-seed must be >= 0, got {args.first_seed}")
    if args.seed_step < 1:
        p.error(f"--seed-step must be at least 1, got {args.seed_step}")
    if args.first_seed + args.seed_step * (args.contexts - 1) >= SEED_BOUND:
        p.error("--first-seed + --seed-step * (--contexts - 1) must stay below 2**32")

    seeds = [args.first_seed + args.seed_step * i for i in range(args.contexts)]
    jobs = [(t, s, args.budget, args.oracle_seed, args.stop_reward, args.sim_workers, args.physics_space,
             args.restarts) for t in args.tasks for s in seeds]
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        tqdm = None
    bar = tqdm(total=len(jobs), desc="oracle contexts", file=sys.stderr, disable=not sys.stderr.isatty()) \
        if tqdm else None
    rows: list[dict[str, Any]] = []
    if args.workers == 1:
        for job in jobs:
            rows.append(certify_context(job))
            if bar:
                bar.update()
    else:
        # spawn: no forked MuJoCo/EGL state; each worker makes its own envs
        with mp.get_context("spawn").Pool(args.workers) as pool:
            for row in pool.imap(certify_context, jobs, chunksize=1):
                rows.append(row)
                if bar:
                    bar.update()
    if bar:
        bar.close()

    summaries = [summarise([r for r in rows if r["task"] == t]) for t in args.tasks]
    command = "python -m benchmarks.solvability " + " ".join(argv if argv is not None else sys.argv[1:])
    text = markdown(summaries, rows, command.strip())
    print(text, end="")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "solvability.md").write_text(text)
    _write_csv(out / "summary.csv", summaries)
    _write_csv(out / "contexts.csv", rows)
    print(f"wrote {out / 'solvability.md'}, {out / 'summary.csv'}, {out / 'contexts.csv'}")
    failing = [s["task"] for s in summaries if s["solvable_share"] < args.require]
    if failing:
        print(f"below the required solvable share {args.require:.0%}: {', '.join(failing)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    os.environ.setdefault("MUJOCO_GL", "egl")
    sys.exit(main())
