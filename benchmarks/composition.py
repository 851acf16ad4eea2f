"""The composed skill chains against the simulator: landing error, cost per candidate and time per decision.

Every task's chain is composed from the scene it describes (:mod:`phyplan_agents.phyplan.composer`); LaunchBounce's
has no code of its own anywhere in the agents. This command measures, per task (default: all the nominal tasks and
LaunchBounceVaried at its contexts' true physics):

* ``accuracy``: the composed chain's predicted final xy against the simulator's on ``--contexts`` dev contexts
  (``--split test``: test contexts) x ``--actions`` actions (uniform random; on LaunchBounce *bouncing* actions,
  whose ball meets the wedge: :func:`benchmarks.design_checks.launch_bounce.bouncing_actions`): mean and p90
  error, the share of actions the chain has no prediction for (NaN: a contact outside every skill's domain), and
  the share of predicted paths with a contact at an edge or corner, with their mean error and the others';
* ``cost``: seconds per candidate of the chain in batches of 1,024 (the median of :data:`REPEATS` timings) and of
  the simulator (the mean of 50 episodes), one core;
* ``decision``: ``phyplan``'s seconds per decision (MCTS + refinement) on ``--contexts`` test contexts, one core;
* ``solutions`` (with ``--solutions FILE``, a ``contexts.csv`` of :mod:`benchmarks.solvability`): on each context
  the oracle solved (reward >= 0.95), whether the chain predicts the oracle's action at all, and how far from the
  simulated landing; a solution the chain has no prediction for (outside every skill's domain) is one no
  skill-based planner can find. With ``--records FILE`` (a benchmark run's ``attempts.jsonl`` of one agent), a
  table per context puts the agent's regret after its last attempt next to the context's hidden physics and what
  the chain says of the oracle's solution.

Usage::

    python -m benchmarks.composition                       # all sections, all tasks (~10 min on one core)
    python -m benchmarks.composition --tasks launch-bounce --section accuracy
    python -m benchmarks.composition --tasks launch-bounce-varied --section accuracy --split test --contexts 20
    python -m benchmarks.solvability --tasks launch-bounce-varied --contexts 20 --first-seed 200000 --budget 1500 \
        --out results/solv-lbv
    python -m benchmarks.composition --tasks launch-bounce-varied --section solutions \
        --solutions results/solv-lbv/contexts.csv
    python -m benchmarks.run --tasks launch-bounce-varied --agents phyplan-sysid --seeds 3 --out results/lbv-sysid
    python -m benchmarks.composition --tasks launch-bounce-varied --section solutions \
        --solutions results/solv-lbv/contexts.csv --records results/lbv-sysid/attempts.jsonl

Figures: docs/composition.md.
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np

import phyplan_envs
from phyplan_envs import splits

DEFAULT_TASKS = tuple(phyplan_envs.TASKS) + ("launch-bounce-varied",)
SECTIONS = ("accuracy", "cost", "decision", "solutions")
REPEATS = 7            # timings of the chain's batch in the cost section (their median)


def _env(task):
    import gymnasium as gym

    return gym.make(phyplan_envs.env_id(task), with_panda=False).unwrapped


def _skills(task):
    from phyplan_agents.phyplan.agent import load_default_skills
    from phyplan_agents.phyplan.fastnet import fast_skills
    from phyplan_agents.phyplan.varied import load_conditioned_skills
    from phyplan_envs.hidden_physics import is_varied

    return fast_skills(load_conditioned_skills() if is_varied(task) else load_default_skills())


def _actions(env, task, n, rng, seed):
    if phyplan_envs.hidden_physics.base_task(task) == "launch-bounce":
        from benchmarks.design_checks.launch_bounce import bouncing_actions

        return bouncing_actions(env, n, int(rng.integers(2 ** 31)), [seed] * n)
    lo, hi = env.action_low, env.action_high
    return lo + (hi - lo) * rng.random((n, len(lo)))


def _rows(env, task, actions):
    import torch

    if phyplan_envs.hidden_physics.is_varied(task):
        phys = np.array([env.hidden_physics[p] for p in phyplan_envs.hidden_physics.parameter_names(task)])
        actions = np.hstack([actions, np.tile(phys, (len(actions), 1))])
    return torch.as_tensor(actions, dtype=torch.float32)


def accuracy(task: str, contexts: int, actions: int, split: str = "dev") -> dict:
    from phyplan_agents.phyplan.composer import ComposedChain

    env, chain, sk = _env(task), ComposedChain(task), _skills(task)
    rng = np.random.default_rng(0)
    err, nan, edge = [], [], []
    for seed in splits.context_seeds(split, contexts):
        obs, info = env.reset(seed=seed)
        acts = _actions(env, task, actions, rng, seed)
        env.reset(options={"context": info["context"]})
        trace = chain.trace(_rows(env, task, acts), sk)
        for a, p, n_edges in zip(acts, trace.final.numpy(), trace.edges.numpy()):
            env.reset(options={"context": info["context"]})
            final = env.step(a)[4]["final_pos"][:2]
            nan.append(not np.all(np.isfinite(p)))
            if not nan[-1]:
                err.append(np.linalg.norm(p - final))
                edge.append(n_edges > 0)
    err, edge = np.array(err), np.array(edge, dtype=bool)
    return {"task": task, "n": len(nan), "mean_m": float(err.mean()), "p90_m": float(np.percentile(err, 90)),
            "no_prediction": float(np.mean(nan)), "edge_share": float(edge.mean()),
            "edge_mean_m": float(err[edge].mean()) if edge.any() else float("nan"),
            "face_mean_m": float(err[~edge].mean()) if (~edge).any() else float("nan")}


def solutions(task: str, path: str) -> dict:
    """The composed chain on the oracle's solving actions of a solvability run's ``contexts.csv`` (rows of ``task``
    with reward >= 0.95): the share it predicts, its landing error on those, and per context (``contexts``: seed,
    hidden physics, the oracle's best reward, the chain's error on its action, NaN where it has no prediction)."""
    import csv

    from phyplan_agents.phyplan.composer import ComposedChain

    env, chain, sk = _env(task), ComposedChain(task), _skills(task)
    names = [f"action_{n}" for n in env.action_names]
    params = phyplan_envs.hidden_physics.parameter_names(task) if phyplan_envs.hidden_physics.is_varied(task) else ()
    err, none, contexts = [], 0, []
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["task"] == task]
    for r in rows:
        obs, info = env.reset(seed=int(r["seed"]))
        physics = {k: float(env.hidden_physics[k]) for k in params}
        e = float("nan")
        if float(r["best_reward"]) >= 0.95:
            a = np.array([[float(r[n]) for n in names]])
            pred = chain.rollout(obs, _rows(env, task, a), sk).numpy()[0]
            env.reset(options={"context": info["context"]})
            final = env.step(a[0])[4]["final_pos"][:2]
            if np.all(np.isfinite(pred)):
                e = float(np.linalg.norm(pred - final))
                err.append(e)
            else:
                none += 1
        contexts.append({"seed": int(r["seed"]), "physics": physics, "best": float(r["best_reward"]), "error_m": e})
    return {"task": task, "solved": len(err) + none, "no_prediction": none,
            "median_m": float(np.median(err)) if err else float("nan"), "contexts": contexts}


def regret_by_context(path: str, task: str) -> dict[int, tuple[str, float]]:
    """Per context of a benchmark run's ``attempts.jsonl``: (agent, its regret after its last attempt, averaged over
    run seeds). One agent per task in the file."""
    from benchmarks.harness.store import load_records

    recs = [r for r in load_records(path)[0] if r.task == task]
    agents = sorted({r.agent for r in recs})
    if len(agents) != 1:
        raise ValueError(f"--records: {path} holds {len(agents)} agents on {task} ({agents}); run one agent per file")
    last: dict[tuple[int, int], tuple[int, float]] = {}
    for r in recs:
        if r.attempt >= last.get((r.seed, r.context), (0, 0.0))[0]:
            last[(r.seed, r.context)] = (r.attempt, r.regret)
    out: dict[int, list[float]] = {}
    for (_, ctx), (_, reg) in last.items():
        out.setdefault(ctx, []).append(reg)
    return {ctx: (agents[0], float(np.mean(v))) for ctx, v in out.items()}


def cost(task: str, batch: int = 1024) -> dict:
    from phyplan_agents.phyplan.composer import ComposedChain

    env, chain, sk = _env(task), ComposedChain(task), _skills(task)
    rng = np.random.default_rng(1)
    obs, info = env.reset(seed=splits.context_seeds("dev", 1)[0])
    lo, hi = env.action_low, env.action_high
    acts = lo + (hi - lo) * rng.random((batch, len(lo)))
    rows = _rows(env, task, acts)
    chain.rollout(obs, rows[:8], sk)
    times = []
    for _ in range(REPEATS):                  # the median of several timings: one batch takes ~0.1 s
        t0 = time.perf_counter()
        chain.rollout(obs, rows, sk)
        times.append(time.perf_counter() - t0)
    chain_s = float(np.median(times)) / batch
    t0 = time.perf_counter()
    for a in acts[:50]:
        env.reset(options={"context": info["context"]})
        env.step(a)
    sim_s = (time.perf_counter() - t0) / 50
    return {"task": task, "chain_s": chain_s, "sim_s": sim_s, "ratio": sim_s / chain_s}


def decision(task: str, contexts: int) -> dict:
    import phyplan_agents
    from phyplan_agents import TaskInfo

    env = _env(task)
    agent = phyplan_agents.make("phyplan-sysid" if phyplan_envs.hidden_physics.is_varied(task) else "phyplan")
    agent.setup(TaskInfo.from_env(env), seed=0)
    times = []
    for seed in splits.context_seeds("test", contexts):
        obs, info = env.reset(seed=seed)
        agent.begin_context(obs, info)
        t0 = time.perf_counter()
        agent.act()
        times.append(time.perf_counter() - t0)
    return {"task": task, "decision_s": float(np.median(times)), "max_s": float(np.max(times))}


def main(argv=None) -> None:
    p = argparse.ArgumentParser(prog="python -m benchmarks.composition", description=__doc__.split("\n\n")[0])
    p.add_argument("--tasks", nargs="+", default=list(DEFAULT_TASKS), help="task names (default: %(default)s)")
    p.add_argument("--section", choices=SECTIONS, nargs="+", default=list(SECTIONS[:3]),
                   help="sections (default accuracy cost decision)")
    p.add_argument("--contexts", type=int, default=5, help="contexts per task (default 5)")
    p.add_argument("--actions", type=int, default=40, help="actions per context for accuracy (default 40)")
    p.add_argument("--solutions", default=None, metavar="FILE",
                   help="a solvability run's contexts.csv, for the solutions section")
    p.add_argument("--records", default=None, metavar="FILE",
                   help="with --section solutions: a benchmark run's attempts.jsonl of one agent; prints, per context, "
                        "its regret after the last attempt next to whether the chain predicts the oracle's solution")
    p.add_argument("--split", choices=("dev", "test"), default="dev",
                   help="the contexts of the accuracy section (default dev; test: a varied task's test-space physics)")
    args = p.parse_args(argv)
    unknown = [t for t in args.tasks if t not in phyplan_envs.ALL_TASKS]
    if unknown:
        p.error(f"--tasks: unknown {unknown}; tasks: {', '.join(phyplan_envs.ALL_TASKS)}")
    if args.contexts < 1 or args.actions < 1:
        p.error("--contexts and --actions must be at least 1")
    if "solutions" in args.section and args.solutions is None:
        p.error("--section solutions needs --solutions FILE (a benchmarks.solvability contexts.csv)")
    if args.solutions is not None and not os.path.isfile(args.solutions):
        p.error(f"--solutions: no file {args.solutions!r}")
    if args.records is not None and not os.path.isfile(args.records):
        p.error(f"--records: no file {args.records!r}")
    if args.records is not None and "solutions" not in args.section:
        p.error("--records goes with --section solutions")
    import torch

    torch.set_num_threads(1)
    if "accuracy" in args.section:
        print(f"\nComposed chain vs simulator ({args.contexts} {args.split} contexts x {args.actions} actions; "
              f"LaunchBounce: bouncing actions; edge: the predicted paths with a contact at an edge or corner)\n\n"
              f"| task | actions | mean error (m) | p90 (m) | no prediction | edge | edge mean (m) | others' mean (m) |\n"
              f"|---|---|---|---|---|---|---|---|")
        for t in args.tasks:
            r = accuracy(t, args.contexts, args.actions, args.split)
            edge_mean, others = (f"{r[k]:.4f}" if np.isfinite(r[k]) else "-" for k in ("edge_mean_m", "face_mean_m"))
            print(f"| {t} | {r['n']} | {r['mean_m']:.4f} | {r['p90_m']:.4f} | {r['no_prediction']:.0%} | "
                  f"{r['edge_share']:.0%} | {edge_mean} | {others} |", flush=True)
    if "cost" in args.section:
        print("\nCost per candidate, one core (chain: a batch of 1,024; simulator: one episode)\n\n"
              "| task | chain (ms) | simulator (ms) | simulator / chain |\n|---|---|---|---|")
        for t in args.tasks:
            r = cost(t)
            print(f"| {t} | {1e3 * r['chain_s']:.3f} | {1e3 * r['sim_s']:.2f} | {r['ratio']:.0f}x |", flush=True)
    if "decision" in args.section:
        print(f"\nTime per decision (phyplan; phyplan-sysid on a varied task), one core, {args.contexts} test "
              f"contexts\n\n| task | median (s) | max (s) |\n|---|---|---|")
        for t in args.tasks:
            r = decision(t, args.contexts)
            print(f"| {t} | {r['decision_s']:.2f} | {r['max_s']:.2f} |", flush=True)

    if "solutions" in args.section:
        print(f"\nThe chain on the oracle's solutions ({args.solutions})\n\n"
              "| task | contexts solved | no prediction | chain's median error where it predicts (m) |\n"
              "|---|---|---|---|")
        per_task = []
        for t in args.tasks:
            r = solutions(t, args.solutions)
            per_task.append(r)
            print(f"| {t} | {r['solved']} | {r['no_prediction']} | {r['median_m']:.4f} |", flush=True)
        if args.records is not None:
            for r in per_task:
                try:
                    regrets = regret_by_context(args.records, r["task"])
                except ValueError as exc:           # several agents in the file, or damaged records
                    p.error(f"--records: {exc}")
                print_contexts(r, regrets)


def print_contexts(r: dict, regrets: dict[int, tuple[str, float]]) -> None:
    """Per context: its hidden physics, the oracle's best reward, whether the chain predicts the oracle's action
    (its error), and the agent's regret after its last attempt (``regrets`` from :func:`regret_by_context`)."""
    agent = next(iter(regrets.values()))[0] if regrets else "agent"
    names = list(r["contexts"][0]["physics"]) if r["contexts"] else []
    print(f"\n{r['task']}: per context\n\n| context | {' | '.join(names) + ' | ' if names else ''}oracle best | "
          f"chain on the oracle's action | {agent} regret (last attempt) |\n|---|{'---|' * len(names)}---|---|---|")
    for c in sorted(r["contexts"], key=lambda c: -regrets.get(c["seed"], ("", float("nan")))[1]):
        chain = ("not solved" if c["best"] < 0.95 else "no prediction" if not np.isfinite(c["error_m"])
                 else f"{100 * c['error_m']:.1f} cm")
        reg = regrets.get(c["seed"], ("", float("nan")))[1]
        phys = "".join(f"{v:.3f} | " for v in c["physics"].values())
        print(f"| {c['seed']} | {phys}{c['best']:.3f} | {chain} | {reg:.3f} |", flush=True)


if __name__ == "__main__":
    main()
