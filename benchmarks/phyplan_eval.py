"""PhyPlan agent figures: chain accuracy, regret targets, decision time, chain vs simulator cost.

    python -m benchmarks.phyplan_eval                          # everything, all tasks with a skill chain
    python -m benchmarks.phyplan_eval --section regret --tasks launch --contexts 20 --seeds 0 1 2
    python -m benchmarks.phyplan_eval --section accuracy speed

Sections:

* ``accuracy``: the skill chain's predicted final xy against the simulator's, over random actions on several
  contexts per task: mean and 90th percentile of the distance (m), and the same relative to the distance travelled.
* ``regret``: mean regret after 1 and after ``--attempts`` attempts over ``--contexts`` held-out contexts (the first
  seeds of the ``test`` split, :mod:`benchmarks.splits`) x ``--seeds`` run seeds, per agent, with the issue's
  targets (<= 0.10 after 1 attempt, <= 0.03 after 5), ± the 95% Student-t half-width over contexts
  (:mod:`benchmarks.stats`). The cells are run by the harness's cell runner (:func:`benchmarks.harness.evaluate`),
  so the figures are those of a harness run.
* ``speed``: one decision (K = 10, D = 20, with and without the refinement) on one core; the cost of scoring one
  candidate with the chain (one batch of 4096 random actions) against simulating it (``Simulator.evaluate``: reset
  to the context and step); ``phyplan`` against ``phyplan-sim`` per attempt.

Medians over several runs; one torch/BLAS thread. The default skills are the shipped pretrained ones
(``SkillSet.load()``); ``--skill-kinds '{"swing": "nn"}'`` swaps in other shipped kinds, ``--skills module:attr``
another skill set object. ``--hit-scale 1.05`` multiplies the hit model's output by 1.05: a chain with a known
systematic error, to measure how the adaptation copes with one (the shipped chain is too accurate to show it).
``--json PATH`` also writes every figure to a JSON file.
"""
from __future__ import annotations

import argparse
import importlib
import json
import os
import statistics
import sys
import time
from typing import Any, Sequence

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import phyplan_envs  # noqa: E402  (sets MUJOCO_GL before mujoco is imported)
import gymnasium as gym  # noqa: E402

TARGET_REGRET_1 = 0.10     # target: mean regret after 1 attempt
TARGET_REGRET_5 = 0.03     # target: mean regret after 5 attempts
TARGET_DECISION_S = 0.5    # target: one decision (K = 10, D = 20) on one core
TARGET_SPEEDUP = 100.0     # target: chain scoring >= 100x cheaper than simulating


def _single_thread() -> None:
    import torch

    torch.set_num_threads(1)


def chain_tasks() -> list[str]:
    """Tasks with a skill chain: every nominal task (each chain is composed from its scene description)."""
    return list(phyplan_envs.TRACKS["nominal"])


class ScaledSkill:
    """A skill model whose outputs are multiplied by ``factor`` (a deliberate systematic error)."""

    def __init__(self, model: Any, factor: float):
        self.model, self.factor = model, float(factor)
        self.spec = getattr(model, "spec", None)

    def predict(self, x):
        return self.model.predict(x) * self.factor


class PerturbedSkills:
    """A skill set with the hit model's output scaled by ``hit_scale``."""

    def __init__(self, skills: Any, hit_scale: float):
        for name in ("swing", "slide", "throw", "hit", "bounce"):
            setattr(self, name, getattr(skills, name))
        self.hit = ScaledSkill(skills.hit, hit_scale)


def load_skills(spec: str | None, kinds: dict[str, str] | None = None, hit_scale: float = 1.0):
    if spec:
        module, _, attr = spec.partition(":")
        obj = getattr(importlib.import_module(module), attr)
        skills = obj() if isinstance(obj, type) or callable(obj) and not hasattr(obj, "swing") else obj
    elif kinds:
        from phyplan_agents.skills import SkillSet

        skills = SkillSet.load(kinds=kinds)
    else:
        from phyplan_agents.phyplan.agent import load_default_skills

        skills = load_default_skills()
    return PerturbedSkills(skills, hit_scale) if hit_scale != 1.0 else skills


def test_seeds(n: int) -> list[int]:
    from benchmarks.splits import context_seeds

    return context_seeds("test", n)


def _random_actions(env, n: int, rng: np.random.Generator) -> np.ndarray:
    lo = env.action_space.low.astype(np.float64)
    hi = env.action_space.high.astype(np.float64)
    return lo + (hi - lo) * rng.random((n, len(lo)))


# ================================================================================================= accuracy
def chain_accuracy(task: str, skills: Any, contexts: int = 5, actions: int = 40, seed: int = 0) -> dict[str, float]:
    """Predicted vs simulated final xy over random actions on ``contexts`` dev contexts."""
    from benchmarks.splits import context_seeds
    from phyplan_agents.phyplan import ChainPredictor

    env = gym.make(phyplan_envs.env_id(task))
    chain = ChainPredictor.for_task(task, skills)
    rng = np.random.default_rng(seed)
    err, rel = [], []
    for ctx in context_seeds("dev", contexts):
        obs, info = env.reset(seed=ctx)
        chain.set_context(obs)
        acts = _random_actions(env, actions, rng)
        pred = chain.final_xy(acts)
        for a, p in zip(acts, pred):
            env.reset(options={"context": info["context"]})
            final = env.step(a)[4]["final_pos"][:2]
            e = float(np.linalg.norm(p - final))
            err.append(e)
            rel.append(e / max(float(np.linalg.norm(final - obs[2:4])), 1e-6))
    env.close()
    err, rel = np.array(err), np.array(rel)
    return {"n": len(err), "mean_m": float(err.mean()), "p90_m": float(np.percentile(err, 90)),
            "max_m": float(err.max()), "mean_rel": float(rel.mean()), "p90_rel": float(np.percentile(rel, 90))}


def bridge_exits(skills: Any, contexts: int = 4, actions: int = 60, seed: int = 1) -> dict[str, dict[str, float]]:
    """Bridge chain error by where the puck leaves its support (rim, plank end, plank side, or stops first).

    ``along`` is the signed error along the hit direction (predicted - simulated; negative: predicted short).
    """
    import math

    from benchmarks.splits import context_seeds
    from phyplan_agents.phyplan import ChainPredictor

    env = gym.make(phyplan_envs.env_id("bridge"))
    chain = ChainPredictor.for_task("bridge", skills)
    rng = np.random.default_rng(seed)
    groups: dict[str, list[tuple[float, float]]] = {}
    for ctx in context_seeds("dev", contexts):
        obs, info = env.reset(seed=ctx)
        chain.set_context(obs)
        radius, length, half_w = float(obs[5]), float(obs[7]), float(obs[8]) / 2
        acts = _random_actions(env, actions, rng)
        for a, p in zip(acts, chain.final_xy(acts)):
            env.reset(options={"context": info["context"]})
            step_info = env.step(a)[4]
            final = step_info["final_pos"][:2]
            d = a[0] - a[2]
            onto = radius * abs(math.sin(d)) <= half_w
            side = onto and half_w / max(abs(math.sin(d)), 1e-9) < (radius + length) / max(math.cos(d), 1e-9)
            kind = ("stops" if step_info["end_reason"] == "rest" else
                    "rim" if not onto else "plank side" if side else "plank end")
            u = np.array([math.cos(a[0]), math.sin(a[0])])
            groups.setdefault(kind, []).append((float(np.linalg.norm(p - final)), float(np.dot(p - final, u))))
    env.close()
    out = {}
    for kind, rows in sorted(groups.items()):
        e = np.array(rows)
        out[kind] = {"n": len(e), "mean_m": float(e[:, 0].mean()), "p90_m": float(np.percentile(e[:, 0], 90)),
                     "mean_along_m": float(e[:, 1].mean())}
    return out


# =================================================================================================== regret
def run_regret(task: str, agent_name: str, contexts: Sequence[int], seeds: Sequence[int], attempts: int,
               agent_kwargs: dict[str, Any] | None = None, progress: bool = True) -> dict[str, Any]:
    """Regret after each attempt for every (run seed, context) cell, run by the harness's cell runner.

    ``ci95_regret`` is the 95% half-width over contexts (:mod:`benchmarks.stats`, seeds averaged per context first).
    """
    import functools

    import phyplan_agents
    from benchmarks.harness import evaluate
    from benchmarks.stats import half_width, regret_per_context

    kw = dict(agent_kwargs or {})
    records = evaluate(functools.partial(phyplan_agents.make, agent_name, **kw), task, list(contexts), attempts,
                       [int(s) for s in seeds], name=agent_name, progress=progress)
    cells: dict[tuple[int, int], list[Any]] = {}
    for r in records:                                   # evaluate returns the cells seed by seed, context by context
        cells.setdefault((r.seed, r.context), []).append(r)
    reg = np.array([[r.regret for r in recs] for recs in cells.values()])
    half = half_width(regret_per_context(records)[1])
    per_seed = reg.reshape(len(seeds), len(contexts), attempts).mean(axis=1)
    return {
        "task": task, "agent": agent_name, "kwargs": kw, "contexts": len(contexts),
        "seeds": list(seeds), "attempts": attempts,
        "mean_regret": reg.mean(axis=0).tolist(),
        "ci95_regret": [float(h) if np.isfinite(h) else None for h in half],
        "per_seed_regret": per_seed.tolist(),
        "solved_share": float(np.mean(reg[:, -1] <= TARGET_REGRET_5)),
        "median_plan_s": float(np.median([r.act_time for r in records])),
        "mean_skill_evals_per_context": float(np.mean([sum(r.skill_evals for r in c) for c in cells.values()])),
        "mean_sim_calls_per_context": float(np.mean([sum(r.sim_calls for r in c) for c in cells.values()])),
        "regrets": reg.tolist(),
    }


# ==================================================================================================== speed
def _median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def speed(task: str, skills: Any, repeats: int = 7, batch: int = 4096, sim_attempts: int = 3) -> dict[str, float]:
    import functools

    import phyplan_agents
    from benchmarks.harness import evaluate
    from benchmarks.splits import context_seeds
    from phyplan_agents import Simulator
    from phyplan_agents.phyplan import ChainPredictor

    env = gym.make(phyplan_envs.env_id(task))
    ctxs = context_seeds("dev", repeats)
    out: dict[str, float] = {}

    # one decision, K = 10, D = 20: with the refinement (the agent's default) and the paper's MCTS alone; two
    # attempts per context through the harness's cell runner: the first decision, and the second with the GP in the
    # loop (its time includes the observe() that updates the GP)
    for label, kw in (("decision_s", {}), ("decision_mcts_only_s", {"refine_rounds": 0})):
        recs = evaluate(functools.partial(phyplan_agents.make, "phyplan", skills=skills, iterations=10,
                                          discretisation=20, **kw), task, ctxs, attempts=2, name="phyplan")
        times = [r.act_time + (recs[i - 1].observe_time if r.attempt == 2 else 0.0) for i, r in enumerate(recs)]
        out[label] = statistics.median(times)
        out[label.replace("_s", "_evals")] = sum(r.skill_evals for r in recs) / len(recs)

    # scoring one candidate: batched chain vs one simulation, interleaved round by round so that both see the same
    # machine load (the speed-up is the median of the per-round ratios)
    chain = ChainPredictor.for_task(task, skills)
    obs, info = env.reset(seed=ctxs[0])
    chain.set_context(obs)
    rng = np.random.default_rng(0)
    sim_env = gym.make(phyplan_envs.env_id(task))
    sim = Simulator(sim_env, info["context"])
    chain_t, sim_t = [], []
    for _ in range(repeats):
        acts = _random_actions(env, batch, rng)
        t0 = time.perf_counter()
        chain.final_xy(acts)
        chain_t.append((time.perf_counter() - t0) / batch)
        per = []
        for a in _random_actions(env, 5, rng):
            t0 = time.perf_counter()
            sim.evaluate(a)
            per.append(time.perf_counter() - t0)
        sim_t.append(statistics.median(per))
    out["chain_per_candidate_s"] = statistics.median(chain_t)
    out["sim_per_candidate_s"] = statistics.median(sim_t)
    out["speedup"] = statistics.median([s_ / c_ for s_, c_ in zip(sim_t, chain_t)])

    # phyplan vs phyplan-sim, wall time per attempt (the same planner; the simulator scores the candidates)
    for name in ("phyplan", "phyplan-sim"):
        kw = {"skills": skills} if name == "phyplan" else {}
        recs = evaluate(functools.partial(phyplan_agents.make, name, **kw), task, ctxs[:sim_attempts], attempts=1,
                        name=name)
        out[f"{name}_attempt_s"] = statistics.median([r.act_time for r in recs])
        out[f"{name}_evaluations_per_attempt"] = sum(r.skill_evals + r.sim_calls for r in recs) / len(recs)
    env.close()
    sim_env.close()
    return out


# ===================================================================================================== main
def _fmt(x: float) -> str:
    return f"{x:.4f}"


def _pm(mean: float, half: float | None) -> str:
    """``mean ± half`` (the 95% half-width over contexts, :mod:`benchmarks.stats`); the mean alone without one."""
    return _fmt(mean) if half is None else f"{_fmt(mean)} ± {_fmt(half)}"


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    p = argparse.ArgumentParser(prog="python -m benchmarks.phyplan_eval", description=__doc__.split("\n\n")[0])
    p.add_argument("--section", nargs="+", default=["accuracy", "regret", "speed"],
                   choices=["accuracy", "regret", "speed"])
    p.add_argument("--tasks", nargs="+", default=None, help="default: every task with a skill chain")
    p.add_argument("--agents", nargs="+", default=["phyplan", "phyplan-nogp"])
    p.add_argument("--agent-kwargs", default="{}", help="JSON keyword arguments for every agent, e.g. "
                                                        "'{\"residual\": \"position\"}'")
    p.add_argument("--contexts", type=int, default=20, help="held-out (test split) contexts per task (default 20)")
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="run seeds (default 0 1 2)")
    p.add_argument("--attempts", type=int, default=5)
    p.add_argument("--accuracy-contexts", type=int, default=5)
    p.add_argument("--accuracy-actions", type=int, default=40)
    p.add_argument("--skills", default=None, help="module:attr of a skill set (default: the shipped skills)")
    p.add_argument("--skill-kinds", default=None,
                   help="JSON {skill: kind} of shipped models, e.g. '{\"swing\": \"nn\"}'")
    p.add_argument("--hit-scale", type=float, default=1.0, help="multiply the hit model's output (default 1)")
    p.add_argument("--json", default=None, help="also write all figures to this JSON file")
    p.add_argument("--no-progress", action="store_true")
    args = p.parse_args(argv)
    _single_thread()
    tasks = args.tasks or chain_tasks()
    unknown = [t for t in tasks if t not in chain_tasks()]
    if unknown:
        p.error(f"tasks without a skill chain: {unknown}; available: {chain_tasks()}")
    skills = load_skills(args.skills, json.loads(args.skill_kinds) if args.skill_kinds else None, args.hit_scale)
    extra = json.loads(args.agent_kwargs)
    results: dict[str, Any] = {"command": "python -m benchmarks.phyplan_eval " + " ".join(sys.argv[1:] if argv is None
                                                                                          else list(argv))}

    if "accuracy" in args.section:
        print("\n## Skill chain vs simulator: final xy over random actions "
              f"({args.accuracy_contexts} dev contexts x {args.accuracy_actions} actions)")
        print("| task | mean (m) | p90 (m) | max (m) | mean / distance travelled | p90 / distance |")
        print("|---|---|---|---|---|---|")
        results["accuracy"] = {}
        for task in tasks:
            acc = chain_accuracy(task, skills, args.accuracy_contexts, args.accuracy_actions)
            results["accuracy"][task] = acc
            print(f"| {task} | {_fmt(acc['mean_m'])} | {_fmt(acc['p90_m'])} | {_fmt(acc['max_m'])} | "
                  f"{acc['mean_rel']:.2%} | {acc['p90_rel']:.2%} |", flush=True)

    if "accuracy" in args.section and "bridge" in tasks:
        print("\n## Bridge: chain error by where the puck leaves its support (4 dev contexts x 60 actions)")
        print("| exit | n | mean (m) | p90 (m) | mean signed error along phi (m) |")
        print("|---|---|---|---|---|")
        results["bridge_exits"] = bridge_exits(skills)
        for kind, r in results["bridge_exits"].items():
            print(f"| {kind} | {r['n']} | {_fmt(r['mean_m'])} | {_fmt(r['p90_m'])} | {r['mean_along_m']:+.4f} |",
                  flush=True)

    if "regret" in args.section:
        ctxs = test_seeds(args.contexts)
        k = args.attempts
        print(f"\n## Mean regret ({args.contexts} test contexts x seeds {args.seeds}; ± 95% Student-t half-width over "
              f"contexts; targets: <= {TARGET_REGRET_1} after 1, <= {TARGET_REGRET_5} after {k})")
        print(f"| task | agent | after 1 | after {k} | per-seed after {k} | share <= {TARGET_REGRET_5} | "
              f"plan s (median) | skill evals / context | sim calls / context | target |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        results["regret"] = []
        for task in tasks:
            for name in args.agents:
                kw = dict(extra)
                if name != "phyplan-sim":
                    kw.setdefault("skills", skills)
                res = run_regret(task, name, ctxs, args.seeds, k, kw, progress=not args.no_progress)
                res["kwargs"] = {key: v for key, v in kw.items() if key != "skills"}
                results["regret"].append(res)
                m = res["mean_regret"]
                ok = m[0] <= TARGET_REGRET_1 and m[-1] <= TARGET_REGRET_5
                per_seed = " / ".join(_fmt(s[-1]) for s in res["per_seed_regret"])
                label = name + ("" if not extra else " " + json.dumps(extra))
                ci = res["ci95_regret"]
                print(f"| {task} | {label} | {_pm(m[0], ci[0])} | {_pm(m[-1], ci[-1])} | {per_seed} | "
                      f"{res['solved_share']:.0%} | "
                      f"{res['median_plan_s']:.3f} | {res['mean_skill_evals_per_context']:.0f} | "
                      f"{res['mean_sim_calls_per_context']:.0f} | {'met' if ok else 'NOT met'} |", flush=True)

    if "speed" in args.section:
        print("\n## Speed (one core; medians)")
        print("| task | decision K=10 D=20 (s) | MCTS only (s) | chain / candidate (us, batch 4096) | simulation / candidate "
              "(ms) | chain speed-up | phyplan / attempt (s) | phyplan-sim / attempt (s) | candidates / attempt |")
        print("|---|---|---|---|---|---|---|---|---|")
        results["speed"] = {}
        for task in tasks:
            sp = speed(task, skills)
            results["speed"][task] = sp
            print(f"| {task} | {sp['decision_s']:.3f} | {sp['decision_mcts_only_s']:.3f} | "
                  f"{sp['chain_per_candidate_s'] * 1e6:.1f} | {sp['sim_per_candidate_s'] * 1e3:.2f} | "
                  f"{sp['speedup']:.0f}x | {sp['phyplan_attempt_s']:.3f} | {sp['phyplan-sim_attempt_s']:.2f} | "
                  f"{sp['phyplan_evaluations_per_attempt']:.0f} |", flush=True)
        print(f"targets: decision <= {TARGET_DECISION_S} s; chain speed-up >= {TARGET_SPEEDUP:.0f}x")

    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)
    return results


if __name__ == "__main__":
    main()
