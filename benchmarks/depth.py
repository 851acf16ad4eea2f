"""Chain depth as a dial: how every agent's regret, the composed chain's landing error and the time per decision grow
with the number of paddles N of ``PhyPlan/Paddles-v2`` (its chain: swing, hit, then a throw and a glide per paddle,
then the last throw).

Sections (per N in ``--depths``, default 1..6):

* ``regret``: every agent of ``--agents`` on the first ``--contexts`` test contexts x ``--seeds`` run seeds, 5
  attempts (:func:`benchmarks.harness.evaluate` with ``env_kwargs={"paddles": N}``): regret after 1 and 5 attempts,
  mean and 95% interval over contexts, each agent's median wall seconds of its first ``act``, and the paddles its
  best attempts use (:func:`paths`: the share whose ball touches every paddle, the chain depth the agent's answers
  really have); ``--task paddles-varied`` runs it on the hidden-physics version (``--attempts`` attempts per
  context);
* ``accuracy``: the composed chain's predicted landing against the simulator's on ``--actions`` chain actions (the
  ball meets every paddle: :func:`benchmarks.design_checks.paddles_actions.chain_actions`) of one dev context: mean
  and p90 error, and the share it has no prediction for; with ``--task paddles-varied``, on each of the first three test
  contexts (its hidden restitution outside the training range; ``--split dev``: dev contexts, inside it) the
  conditioned chain at the context's true restitution and at the nominal one, the prior of the first attempt
  (what the first attempt's plan rests on), and at the true one with the exact-impact faces' edge guard at every
  restitution (``ComposedChain(..., edge_guard_from=0)``), with the touches only the default chain predicts: how
  many, and their largest error;
* ``decision``: ``phyplan``'s first decision on the first 10 test contexts (at most ``--contexts``): median CPU
  seconds of its one thread (:func:`time.process_time`, which other processes on the machine barely change), wall
  seconds, and the candidates it scores (its ``skill_evals``) with the CPU time per candidate;
* ``cost``: CPU seconds per candidate of the chain (batches of 1,024 distinct rows) and of the simulator (one
  episode), each the least of 3 timings, on uniform random actions and on chain actions (the full fall through
  every paddle; 10 of them, their copies moved by up to 1 mm so that no two rows of the batch are the same).

Usage::

    python -m benchmarks.depth                                  # everything, N = 1..6, ~1 h on one core
    python -m benchmarks.depth --section accuracy cost          # the chain alone (minutes)
    python -m benchmarks.depth --agents phyplan random --depths 1 2 3 --contexts 20 --seeds 3
    python -m benchmarks.depth --section regret --task paddles-varied --agents phyplan-sysid phyplan --attempts 10
    python -m benchmarks.depth --section accuracy --task paddles-varied --actions 20 [--split dev]

``--plot FILE`` writes the figure (regret after 5 attempts, landing error and time per decision against N);
``--json FILE`` the figures; ``--redraw --json FILE --plot PNG`` runs nothing and draws the figure from them.
Figures: docs/depth.md; the tables and the figure: :mod:`benchmarks.depth_report`.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

import phyplan_envs
from benchmarks import depth_report
from phyplan_envs import splits

AGENTS = ("random", "oracle", "phyplan", "phyplan-nogp")
SECTIONS = ("regret", "accuracy", "cost", "decision")
TASK = "paddles"
VARIED = "paddles-varied"


def _env(n: int, **kwargs):
    import gymnasium as gym

    return gym.make(phyplan_envs.env_id(TASK), paddles=n, with_panda=False, **kwargs).unwrapped


def regret(n: int, agents, contexts: int, seeds: int, attempts: int = 5, task: str = TASK) -> dict:
    from benchmarks.harness import AgentUnavailable, evaluate
    from benchmarks.stats import half_width, regret_per_context

    out = {}
    ctx = splits.context_seeds("test", contexts)
    for agent in agents:
        t0 = time.perf_counter()
        try:
            records = evaluate(agent, task, ctx, attempts=attempts, seeds=list(range(seeds)),
                               env_kwargs={"paddles": n, "with_panda": False}, split="test")
        except AgentUnavailable as exc:      # e.g. a DQN baseline without a model for this N: no row, say why
            print(f"  N={n} {task} {agent}: skipped ({exc})", flush=True)
            continue
        _, curves = regret_per_context(records)
        mean, hw = curves.mean(axis=0), half_width(curves)
        first = [r.act_time for r in records if r.attempt == 1]
        five = min(5, attempts) - 1
        out[agent] = {"regret1": float(mean[0]), "regret1_hw": float(hw[0]), "regret5": float(mean[five]),
                      "regret5_hw": float(hw[five]), "attempts": attempts, "regret_last": float(mean[-1]),
                      "regret_last_hw": float(hw[-1]), "decision_s": float(np.median(first)),
                      "wall_s": time.perf_counter() - t0, **paths(records, n, task)}
        last = f", regret@{attempts} {mean[-1]:.3f} ± {hw[-1]:.3f}" if attempts > 5 else ""
        print(f"  N={n} {task} {agent}: regret@1 {mean[0]:.3f} ± {hw[0]:.3f}, regret@{five + 1} {mean[five]:.3f} "
              f"± {hw[five]:.3f}{last}, first decision {np.median(first):.2f} s (median); best attempts touching "
              f"every paddle {100 * out[agent]['every_paddle']:.0f}%, paddles touched {out[agent]['touched']:.2f} "
              f"of {n} (mean)", flush=True)
    return out


def paths(records, n: int, task: str = TASK) -> dict:
    """The paddles the best attempt of each (run seed, context) cell uses: its action replayed on its context, the
    paddles whose board the ball touched (face, edge or corner:
    :func:`benchmarks.design_checks.paddles.met_paddles` with ``board``). Returns the share of cells whose best
    attempt touches every paddle (``every_paddle``) and the mean number touched (``touched``)."""
    import gymnasium as gym

    from benchmarks.design_checks.paddles_actions import attempt

    env = gym.make(phyplan_envs.env_id(task), paddles=n, with_panda=False, record_trajectory=True).unwrapped
    best: dict = {}
    for r in records:
        key = (r.seed, r.context)
        if r.reward is not None and (key not in best or r.reward > best[key].reward):
            best[key] = r
    touched = []
    for (_, context), r in sorted(best.items()):
        env.reset(seed=context)
        touched.append(attempt(env, env.context, np.array(r.action), board=True)[2])
    t = np.array(touched, dtype=bool).reshape(len(touched), n)
    return {"every_paddle": float(t.all(axis=1).mean()) if len(t) else float("nan"),
            "touched": float(t.sum(axis=1).mean()) if len(t) else float("nan")}


def _skills():
    from phyplan_agents.phyplan.agent import load_default_skills
    from phyplan_agents.phyplan.fastnet import fast_skills

    return fast_skills(load_default_skills())


def _chain(n: int):
    from phyplan_agents.phyplan.composer import composed

    return composed(TASK, {"paddles": n}), _skills()


def accuracy(n: int, actions: int, seed: int, design=None, aimed: bool = False) -> dict:
    """The composed chain's landing against the simulator's on ``actions`` chain actions of the first dev context
    (the module docstring); ``design``: on that design study of the paddles
    (:class:`benchmarks.design_checks.paddles_actions.Design`, default the task), the chain composed from its scene
    with the same skills; ``aimed``: the chain actions aimed
    (:func:`benchmarks.design_checks.paddles_actions.aimed_action`). Also the simulator's arrival speed at each
    paddle's face (m/s, per action and paddle: ``arrival``,
    :func:`benchmarks.design_checks.paddles_actions.arrival_speeds`)."""
    from benchmarks.design_checks.paddles_actions import arrival_speeds, chain_actions, flight

    study = design is not None and not design.is_task()
    env = design.make(n, record_trajectory=True) if study else _env(n, record_trajectory=True)
    env.reset(seed=splits.context_seeds("dev", 1)[0])
    context = env.context
    acts = np.array(chain_actions(env, context, actions, np.random.default_rng(seed), aimed=aimed))
    acts = acts.reshape(-1, env.paddles)
    sim, arrival = np.empty(len(acts)), np.empty((len(acts), env.paddles))
    for j, a in enumerate(acts):
        info = flight(env, context, a)[1]
        sim[j], arrival[j] = info["final_pos"][0], arrival_speeds(env, a, info["trajectory"])
    if study:
        from phyplan_agents.phyplan.composer import ComposedChain

        chain, skills = ComposedChain(env=env), _skills()
    else:
        chain, skills = _chain(n)
    pred = chain.rollout(None, acts, skills).numpy().astype(np.float64)
    err = np.linalg.norm(pred - np.column_stack([sim, np.zeros(len(sim))]), axis=1)
    ok = np.isfinite(err)
    return {"actions": len(acts), "mean_m": float(err[ok].mean()) if ok.any() else float("nan"),
            "p90_m": float(np.percentile(err[ok], 90)) if ok.any() else float("nan"),
            "no_prediction": float(1 - ok.mean()) if len(ok) else float("nan"), "arrival": arrival}


VARIED_CONTEXTS = 3      # test contexts of the varied accuracy section


def accuracy_varied(n: int, actions: int, seed: int, split: str = "test") -> dict:
    """The conditioned chain on PaddlesVaried's first :data:`VARIED_CONTEXTS` contexts of ``split`` (test: hidden
    physics outside the training range; dev: inside it): landing error at each context's true restitution and at
    the nominal one (the module docstring), over all their chain actions; and at the true one with the edge guard at
    every restitution (``edge_guard_from=0``, under ``guarded``), with the touches only the default chain predicts
    (``below_guard``: how many, and their largest error)."""
    import gymnasium as gym
    import torch

    from benchmarks.design_checks.paddles_actions import attempt, chain_actions
    from phyplan_agents.phyplan.composer import ComposedChain, composed
    from phyplan_agents.phyplan.fastnet import fast_skills
    from phyplan_agents.phyplan.varied import load_conditioned_skills, parameter_space

    env = gym.make(phyplan_envs.env_id(VARIED), paddles=n, with_panda=False, record_trajectory=True).unwrapped
    chain, skills = composed(VARIED, {"paddles": n}), fast_skills(load_conditioned_skills())
    guarded = ComposedChain(VARIED, {"paddles": n}, edge_guard_from=0.0)
    names = phyplan_envs.hidden_physics.parameter_names(VARIED)
    nominal = np.array([p.prior for p in parameter_space(VARIED)])
    errs = {"true": [], "nominal": [], "guarded": []}
    physics = []
    for i, ctx_seed in enumerate(splits.context_seeds(split, VARIED_CONTEXTS)):
        env.reset(seed=ctx_seed)
        context = env.context
        true = np.array([env.hidden_physics[k] for k in names])
        physics.append(true.tolist())
        acts = np.array(chain_actions(env, context, actions, np.random.default_rng(seed + i)))
        if len(acts) == 0:
            continue
        sim = np.column_stack([[attempt(env, context, a)[1] for a in acts], np.zeros(len(acts))])
        for key, theta, c in (("true", true, chain), ("nominal", nominal, chain), ("guarded", true, guarded)):
            rows = torch.as_tensor(np.hstack([acts, np.tile(theta, (len(acts), 1))]), dtype=torch.float32)
            pred = c.rollout(None, rows, skills).numpy().astype(np.float64)
            errs[key].append(np.linalg.norm(pred - sim, axis=1))
    out = {"physics": physics}
    if errs["true"]:
        e, g = np.concatenate(errs["true"]), np.concatenate(errs["guarded"])
        below = np.isfinite(e) & np.isnan(g)
        out["below_guard"] = {"touches": int(below.sum()), "max_m": float(e[below].max()) if below.any() else 0.0}
    for key, e in errs.items():
        e = np.concatenate(e) if e else np.array([np.nan])
        ok = np.isfinite(e)
        out[key] = {"actions": len(e), "mean_m": float(e[ok].mean()) if ok.any() else float("nan"),
                    "p90_m": float(np.percentile(e[ok], 90)) if ok.any() else float("nan"),
                    "no_prediction": float(1 - ok.mean())}
    return out


def _best_cpu_s(fn, repeats: int) -> float:
    """The least CPU seconds (:func:`time.process_time`) of ``repeats`` runs of ``fn()``: the cost with the least
    interference from the rest of the machine (the practice of :mod:`timeit`)."""
    best = float("inf")
    for _ in range(repeats):
        c0 = time.process_time()
        fn()
        best = min(best, time.process_time() - c0)
    return best


JITTER = 1e-3    # m of a paddle's offset (and a tenth of it in rad of the release angle): how far the copies of the
                 # cost section's chain actions move, so that no two rows of its batch are the same


def distinct_copies(acts: np.ndarray, batch: int, rng, lo, hi) -> np.ndarray:
    """``batch`` rows: the actions ``acts`` in turn, every copy after the first moved by up to :data:`JITTER` (clipped
    to the bounds ``lo``, ``hi``). The chain computes a repeated row once, so a batch of repeated rows would time
    only its distinct rows."""
    rows = np.resize(np.asarray(acts, dtype=float), (batch, len(lo)))
    scale = JITTER * np.r_[0.1, np.ones(len(lo) - 1)]
    moved = rng.uniform(-1.0, 1.0, rows.shape) * scale
    moved[:len(acts)] = 0.0
    return np.clip(rows + moved, lo, hi)


def cost(n: int, batch: int = 1024, chain_acts: int = 10, repeats: int = 3) -> dict:
    """CPU seconds per candidate of the chain (batches of ``batch`` distinct rows) and of the simulator (one episode,
    over the first 30 actions of the set), each the least of ``repeats`` timings, on uniform random actions and on
    ``chain_acts`` chain actions (the ball falls through every paddle), whose copies fill the chain's batch
    (:func:`distinct_copies`)."""
    from benchmarks.design_checks.paddles_actions import chain_actions

    env = _env(n, record_trajectory=True)
    obs, info = env.reset(seed=splits.context_seeds("dev", 1)[0])
    rng = np.random.default_rng(0)
    lo, hi = env.action_low, env.action_high
    sets = {"random": lo + (hi - lo) * rng.random((batch, len(lo))),
            "chain": np.array(chain_actions(env, info["context"], chain_acts, rng))}
    chain, skills = _chain(n)
    out = {}
    for name, acts in sets.items():
        rows = distinct_copies(acts, batch, rng, lo, hi)
        chain.rollout(obs, rows[:8], skills)
        chain_s = _best_cpu_s(lambda: chain.rollout(obs, rows, skills), repeats) / batch

        def simulate():
            for a in acts[:30]:
                env.reset(options={"context": info["context"]})
                env.step(a)

        sim_s = _best_cpu_s(simulate, repeats) / min(30, len(acts))
        out[name] = {"chain_s": chain_s, "sim_s": sim_s, "ratio": sim_s / chain_s}
    return out


def decision(n: int, contexts: int, agent_name: str = "phyplan") -> dict:
    """``agent_name``'s first decision on the first ``contexts`` test contexts: its median CPU seconds (the process
    time of one thread, which other processes on the machine barely change), wall seconds, and candidates scored
    (the agent's ``skill_evals``), so that time = candidates x cost per candidate."""
    import phyplan_agents
    from phyplan_agents import TaskInfo

    env = _env(n)
    agent = phyplan_agents.make(agent_name)
    agent.setup(TaskInfo.from_env(env), seed=0)
    cpu, wall, evals = [], [], []
    for seed in splits.context_seeds("test", contexts):
        obs, info = env.reset(seed=seed)
        agent.begin_context(obs, info)
        e0 = agent.stats()["skill_evals"]
        t0, c0 = time.perf_counter(), time.process_time()
        agent.act()
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - t0)
        evals.append(agent.stats()["skill_evals"] - e0)
    per = np.array(cpu) / np.maximum(evals, 1)
    return {"agent": agent_name, "contexts": contexts, "cpu_s": float(np.median(cpu)), "wall_s": float(np.median(wall)),
            "cpu_max_s": float(np.max(cpu)), "evaluations": float(np.median(evals)),
            "cpu_per_evaluation_s": float(np.median(per))}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.depth", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--depths", type=int, nargs="+", default=[1, 2, 3, 4, 5, 6], help="the N (default 1..6)")
    p.add_argument("--section", choices=SECTIONS, nargs="+", default=list(SECTIONS))
    p.add_argument("--agents", nargs="+", default=list(AGENTS), help="agents of the regret section")
    p.add_argument("--contexts", type=int, default=20, help="test contexts per N (default 20)")
    p.add_argument("--seeds", type=int, default=3, help="run seeds (default 3)")
    p.add_argument("--actions", type=int, default=40, help="chain actions of the accuracy section (default 40)")
    p.add_argument("--task", choices=(TASK, VARIED), default=TASK,
                   help=f"the regret and accuracy sections' task: {TASK} or its hidden-physics version {VARIED} "
                        "(its figures go under 'regret-varied' and 'accuracy-varied')")
    p.add_argument("--split", choices=("test", "dev"), default="test",
                   help="the accuracy section's contexts with --task paddles-varied: test (hidden physics outside "
                        "the training range, under 'accuracy-varied') or dev (inside it, under 'accuracy-varied-dev')")
    p.add_argument("--attempts", type=int, default=5, help="attempts per context of the regret section (default 5)")
    p.add_argument("--plot", default=None, help="write the figure to this PNG")
    p.add_argument("--json", default=None, help="write the figures to this JSON file (merged if it exists)")
    p.add_argument("--redraw", action="store_true",
                   help="run no section: print the tables and draw --plot from the figures in --json")
    args = p.parse_args(argv)
    if args.redraw and not (args.json and args.plot):
        p.error("--redraw needs --json (the figures) and --plot (the figure to draw)")
    if any(n < 1 for n in args.depths):
        p.error(f"--depths must be >= 1, got {args.depths}")
    if args.split != "test" and not (args.task == VARIED and "accuracy" in args.section):
        p.error(f"--split {args.split} needs --task {VARIED} and the accuracy section")
    if args.contexts < 1 or args.seeds < 1 or args.actions < 1 or args.attempts < 1:
        p.error("--contexts, --seeds, --actions and --attempts must be at least 1")
    import torch

    torch.set_num_threads(1)
    results: dict = {}
    if args.json:
        try:
            with open(args.json) as f:
                results = json.load(f)
        except FileNotFoundError:
            pass
    for n in [] if args.redraw else args.depths:
        print(f"N={n}", flush=True)
        row = results.setdefault(str(n), {})
        if "accuracy" in args.section and args.task == VARIED:
            row["accuracy-varied" + ("-dev" if args.split == "dev" else "")] = v = \
                accuracy_varied(n, args.actions, seed=n, split=args.split)
            for key in ("true", "nominal", "guarded"):
                a = v[key]
                restitutions = [round(p[0], 3) for p in v["physics"]]
                at = ("true restitution, the edge guard at every restitution" if key == "guarded"
                      else f"{key} restitution")
                print(f"  N={n} {VARIED} chain at the {at}, over {a['actions']} chain actions of "
                      f"{VARIED_CONTEXTS} {args.split} contexts (restitutions {restitutions}): mean "
                      f"{100 * a['mean_m']:.1f} cm, p90 {100 * a['p90_m']:.1f} cm, no prediction "
                      f"{100 * a['no_prediction']:.0f}%", flush=True)
            if "below_guard" in v:
                b = v["below_guard"]
                print(f"  N={n} touches the chain predicts only below the guard's restitution: {b['touches']}, "
                      f"error at most {100 * b['max_m']:.1f} cm", flush=True)
        elif "accuracy" in args.section:
            a = accuracy(n, args.actions, seed=n)
            row["accuracy"] = {k: v for k, v in a.items() if k != "arrival"}    # the per-action speeds: not kept
            print(f"  N={n} chain landing error over {a['actions']} chain actions: mean {100 * a['mean_m']:.1f} cm, "
                  f"p90 {100 * a['p90_m']:.1f} cm, no prediction {100 * a['no_prediction']:.0f}%", flush=True)
        if "cost" in args.section:
            row["cost"] = c = cost(n)
            for kind, k in c.items():
                print(f"  N={n} cost per candidate ({kind} actions): chain {1e6 * k['chain_s']:.1f} us, simulator "
                      f"{1e3 * k['sim_s']:.1f} ms ({k['ratio']:.0f}x)", flush=True)
        if "decision" in args.section:
            row["decision"] = d = decision(n, min(args.contexts, 10))
            print(f"  N={n} {d['agent']} first decision over {d['contexts']} test contexts: median {d['cpu_s']:.2f} s "
                  f"CPU ({d['cpu_s'] / n:.2f} s per paddle), {d['wall_s']:.2f} s wall; median {d['evaluations']:.0f} "
                  f"candidates scored, {1e6 * d['cpu_per_evaluation_s']:.0f} us CPU each", flush=True)
        if "regret" in args.section:
            key = "regret" if args.task == TASK else "regret-varied"
            row.setdefault(key, {}).update(regret(n, args.agents, args.contexts, args.seeds, args.attempts, args.task))
        if args.json:
            with open(args.json, "w") as f:
                json.dump(results, f, indent=1)
    depth_report.print_tables(results, TASK, VARIED, VARIED_CONTEXTS)
    if args.plot:
        depth_report.plot(results, args.plot)
        print(f"wrote {args.plot}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
