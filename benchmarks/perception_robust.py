"""Perception that never gives up: ``phyplan-perception`` against ``phyplan`` on contexts outside every split.

The contexts are ``7_310_000 + 7_919 i`` (``i < --contexts``), which no split holds (checked against
:mod:`phyplan_envs.splits`), so nothing in the project was tuned on them. For each task the command

1. reads every context's picture at reset with :func:`phyplan_agents.perception.perceive` and lists the contexts
   whose goal it cannot read (hidden under the Bridge plank, cut by the picture's border, a failed fit);
2. scores the agents on all contexts through the harness's cell runner (:func:`benchmarks.harness.evaluate`: the
   same seeding and records as ``python -m benchmarks.run``), ``--workers`` processes over chunks of contexts; a
   context is *lost* when an attempt of it failed (e.g. ``PerceptionError`` in ``begin_context``);
3. replays the flagged contexts with ``phyplan-perception`` twice in this process: as the harness does (no picture
   after an attempt) and *looking again* (the picture after each attempt passed to ``observe(..., obs=...)``),
   reporting the goal estimate's error after each attempt (the truth read from the env's ``info`` by this command
   only) and the regret after the last attempt.

``--blind`` adds ``phyplan-perception-blind`` (``goal_from_picture=False``): the goal from the task's goal
distribution and the rewards alone, in every context.

    python -m benchmarks.perception_robust --contexts 200 --workers 2 --out results/perception_robust
    python -m benchmarks.perception_robust --contexts 10 --out /tmp/pr10          # cost check

Every (task, agent, chunk) is written to ``DIR/cells/*.jsonl`` when done, and a rerun with the same ``DIR``
reuses them (resume); the summary goes to stdout and ``DIR/summary.md``.
"""
from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

import numpy as np

FIRST, STRIDE = 7_310_000, 7_919
AGENTS = {"phyplan-perception": ("phyplan-perception", {}), "phyplan": ("phyplan", {}),
          "phyplan-perception-blind": ("phyplan-perception", {"goal_from_picture": False})}
CHUNK = 25


def hidden_seeds(n: int) -> list[int]:
    """The first ``n`` hidden-style context seeds; ``ValueError`` if one falls in a split."""
    from phyplan_envs.splits import split_of

    seeds = [FIRST + STRIDE * i for i in range(n)]
    inside = [s for s in seeds if split_of(s) is not None]
    if inside:
        raise ValueError(f"hidden-style seeds inside a split: {inside[:3]}")
    return seeds


def unreadable_goals(task: str, seeds) -> dict[int, str]:
    """Contexts whose goal the pipeline cannot read from the picture at reset, with the reported problems."""
    import gymnasium as gym

    import phyplan_envs
    from phyplan_agents.perception import perceive
    from phyplan_agents.perception.agent import IMAGE_SIZE

    env = gym.make(phyplan_envs.env_id(task), obs_mode="rgbd", image_size=IMAGE_SIZE, with_panda=False).unwrapped
    cam, out = env.camera_model("obs"), {}
    try:
        for s in seeds:
            obs, _ = env.reset(seed=int(s))
            p = perceive(task, obs, cam, env.facts, env.state_names)
            if not np.all(np.isfinite(p.state[:2])):
                out[int(s)] = "; ".join(p.problems)
    finally:
        env.close()
    return out


def _run_chunk(job: tuple) -> list[dict]:
    """One (task, agent, contexts) job in a worker: the harness's records as dicts."""
    import os

    os.environ.setdefault("MUJOCO_GL", "egl")
    import phyplan_agents
    from benchmarks.harness import evaluate

    task, label, contexts, attempts, env_kwargs = job
    name, kwargs = AGENTS[label]
    recs = evaluate(lambda: phyplan_agents.make(name, **kwargs), task, contexts, attempts=attempts, seeds=0,
                    split="none", name=label, errors="record", env_kwargs=env_kwargs)
    keep = ("context", "attempt", "reward", "regret", "success", "error", "agent_stats", "act_time", "begin_time")
    return [{k: getattr(r, k) for k in keep} for r in recs]


def score(out: Path, tasks, labels, seeds, attempts: int, workers: int, env_kwargs=None, tag: str = "") -> dict:
    """Records per (task, agent), from ``out/cells`` where done, else computed (in ``workers`` processes).
    ``env_kwargs``: extra ``gym.make`` keywords of the envs (e.g. ``camera_noise``); ``tag`` ends the cell files'
    names so that runs with other keywords keep their own cells."""
    cells = out / "cells"
    cells.mkdir(parents=True, exist_ok=True)
    jobs, done = [], {}
    for task in tasks:
        for label in labels:
            for k in range(0, len(seeds), CHUNK):
                chunk = seeds[k:k + CHUNK]
                path = cells / f"{task}__{label}__{chunk[0]}_{len(chunk)}_{attempts}{tag}.jsonl"
                if path.exists():
                    done[path] = [json.loads(line) for line in path.read_text().splitlines() if line]
                else:
                    jobs.append((path, (task, label, chunk, attempts, env_kwargs)))
    total = len(done) + len(jobs)
    if jobs:
        def save(path, rows):
            tmp = path.with_suffix(".tmp")
            tmp.write_text("".join(json.dumps(r) + "\n" for r in rows))
            tmp.replace(path)
            done[path] = rows
            print(f"  done {path.name} ({len(done)}/{total} chunks)", flush=True)

        if workers > 1:
            with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as pool:
                futures = {pool.submit(_run_chunk, job): path for path, job in jobs}
                for fut, path in futures.items():
                    save(path, fut.result())
        else:
            for path, job in jobs:
                save(path, _run_chunk(job))
    result: dict = {}
    for path, rows in done.items():
        task, label = path.name.split("__")[:2]
        result.setdefault((task, label), []).extend(rows)
    return result


def look_again(task: str, contexts, attempts: int) -> list[dict]:
    """Replay ``contexts`` with ``phyplan-perception``, without and with the picture after each attempt."""
    import gymnasium as gym

    import phyplan_agents
    import phyplan_envs
    from benchmarks.harness import cell_seed, reseed_agent
    from phyplan_agents import TaskInfo

    rows = []
    for look in (False, True):
        agent = phyplan_agents.make("phyplan-perception")
        env = gym.make(phyplan_envs.env_id(task), **agent.env_kwargs)
        agent.setup(TaskInfo.from_env(env), seed=0)
        for ctx in contexts:
            reseed_agent(agent, cell_seed(0, int(ctx)))
            obs, info = env.reset(seed=int(ctx))
            truth = np.asarray(info["goal"], dtype=np.float64)
            agent.begin_context(obs, {})
            errs, best = [float(np.linalg.norm(agent.goal_estimate - truth))], -np.inf
            for _ in range(attempts):
                a = agent.act()
                env.reset(options={"context": info["context"]})
                after, r, *_ = env.step(a)
                agent.observe(a, float(r), {}, obs=after if look else None)
                best = max(best, float(r))
                errs.append(float(np.linalg.norm(agent.goal_estimate - truth)))
            rows.append({"context": int(ctx), "look_again": look, "goal_error": errs, "regret": max(0.0, 1 - best),
                         "found_after": agent.fallback.get("found_after"), "stats": agent.stats()})
        env.close()
    return rows


def _ci(x) -> str:
    x = np.asarray(x, dtype=np.float64)
    half = 1.96 * x.std(ddof=1) / np.sqrt(len(x)) if len(x) > 1 else 0.0
    return f"{x.mean():.3f} ± {half:.3f}"


def summarise(results: dict, flagged: dict, replays: dict, tasks, labels, seeds, attempts: int) -> str:
    lines = [f"Hidden-style contexts {FIRST} + {STRIDE} i, i < {len(seeds)} (outside every split), {attempts} "
             f"attempts, run seed 0. Lost: a context with a failed attempt. Regret: max(0, 1 - best reward so far), "
             f"mean ± 95% CI.", "",
             f"| task | agent | contexts | goal unreadable at reset | lost | regret@1 | regret@{attempts} | "
             f"regret@{attempts} on the unreadable ones | fallbacks |", "|---|---|---|---|---|---|---|---|---|"]
    for task in tasks:
        for label in labels:
            rows = results.get((task, label), [])
            by_ctx: dict[int, list] = {}
            for r in rows:
                by_ctx.setdefault(r["context"], []).append(r)
            lost = sorted(c for c, rr in by_ctx.items() if any(r["error"] for r in rr))
            reg = {c: {r["attempt"]: r["regret"] for r in rr} for c, rr in by_ctx.items()}
            r1 = [v[1] for v in reg.values()]
            rk = [v[attempts] for v in reg.values()]
            fl = [reg[c][attempts] for c in flagged[task] if c in reg]
            fb = int(sum(r["agent_stats"].get("perception_fallback", 0) for r in rows))
            lines.append(f"| {task} | {label} | {len(by_ctx)} | {len(flagged[task])} | {len(lost)} | {_ci(r1)} | "
                         f"{_ci(rk)} | {', '.join(f'{v:.3f}' for v in fl) or '-'} | {fb} |")
    if any(replays.values()):
        lines += ["", "Unreadable goals replayed with `phyplan-perception` (goal error in mm after 0, 1, ... "
                  "attempts; *look again*: the picture after each attempt passed to `observe`):", "",
                  "| task | context | look again | goal error (mm) | found after | regret@%d |" % attempts,
                  "|---|---|---|---|---|---|"]
        for task, rows in replays.items():
            for r in rows:
                errs = " / ".join(f"{1000 * e:.0f}" for e in r["goal_error"])
                lines.append(f"| {task} | {r['context']} | {'yes' if r['look_again'] else 'no'} | {errs} | "
                             f"{r['found_after']} | {r['regret']:.3f} |")
    return "\n".join(lines)


def add_run_arguments(p: argparse.ArgumentParser) -> None:
    """The arguments every perception study shares: contexts, tasks, attempts, workers."""
    from phyplan_envs import TRACKS

    tasks = TRACKS["nominal"]        # Paddles has no scene reader (docs/depth.md)
    p.add_argument("--contexts", type=int, default=200, help="hidden-style contexts per task")
    p.add_argument("--tasks", nargs="+", default=list(tasks), choices=list(tasks))
    p.add_argument("--attempts", type=int, default=5)
    p.add_argument("--workers", type=int, default=1)


def checked_run(p: argparse.ArgumentParser, a: argparse.Namespace) -> tuple[Path, list[int]]:
    """The results directory (made) and the context seeds of a parsed run; ``p.error`` on bad counts."""
    if a.contexts < 1 or a.attempts < 1 or a.workers < 1:
        p.error("--contexts, --attempts and --workers must be >= 1")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    return out, hidden_seeds(a.contexts)


def tasks_flag(tasks) -> str:
    """`` --tasks ...`` for a command line, empty for the default (every nominal task)."""
    from phyplan_envs import TRACKS

    return "" if list(tasks) == list(TRACKS["nominal"]) else " --tasks " + " ".join(tasks)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_run_arguments(p)
    p.add_argument("--blind", action="store_true", help="also score phyplan-perception-blind (goal_from_picture="
                                                         "False: the goal from the rewards alone)")
    p.add_argument("--out", required=True, help="results directory (resumed if it exists)")
    a = p.parse_args(argv)
    out, seeds = checked_run(p, a)
    labels = ["phyplan-perception", "phyplan"] + (["phyplan-perception-blind"] if a.blind else [])
    t0 = time.perf_counter()
    flagged = {t: unreadable_goals(t, seeds) for t in a.tasks}
    for t, f in flagged.items():
        print(f"{t}: goal unreadable at reset in {len(f)}/{len(seeds)} contexts: "
              + ", ".join(f"{c} ({why})" for c, why in f.items()), flush=True)
    results = score(out, a.tasks, labels, seeds, a.attempts, a.workers)
    replays = {t: look_again(t, list(f), a.attempts) for t, f in flagged.items()}
    text = summarise(results, flagged, replays, a.tasks, labels, seeds, a.attempts)
    text += (f"\n\nCommand: `python -m benchmarks.perception_robust --contexts {a.contexts} --workers {a.workers}"
             f"{' --blind' if a.blind else ''}{'' if a.attempts == 5 else f' --attempts {a.attempts}'}"
             f"{tasks_flag(a.tasks)} --out {a.out}` ({time.perf_counter() - t0:.0f} s wall, resumed cells included at no cost)")
    print(text)
    (out / "summary.md").write_text(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
