"""Where the hidden-physics agents lose regret: skill accuracy off the training physics, identification, search.

For each varied task and context (test split: test-space physics; ``--split dev``: training space) this measures,
with privileged access to the context's hidden values (``env.unwrapped.hidden_physics``):

* **skill accuracy**: the varied chain (:class:`~phyplan_agents.phyplan.varied.PhysicsPredictor`) at the *true*
  physics against the env's landing, over random actions (mean error per context over the actions it predicts;
  the share it makes no prediction for, an arrival outside every skill's domain, is printed). The conditioned skills saw
  training-space data only, so test-space contexts show how far they carry;
* **search**: the regret of one attempt planned by PhyPlan's MCTS + refinement with the chain at the true physics
  (no identification needed): the floor that skill accuracy and search leave;
* **identification**: the regret of that one attempt with the chain at the nominal physics instead (what
  ``phyplan-nogp`` does, attempt after attempt).

Prints a table per task and writes a figure: chain error against each hidden parameter, training and test
contexts coloured apart. Example::

    python -m benchmarks.sysid_diagnostics --contexts 10 --out docs/img/sysid_diagnostics.png
    python -m benchmarks.sysid_diagnostics --tasks launch-bounce-varied --splits test --contexts 20 --iterations 40
    python -m benchmarks.sysid_diagnostics --tasks paddles-varied --paddles 1 2 3 4 5 6 --splits test dev --contexts 10
"""
from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Sequence  # noqa: E402

import numpy as np  # noqa: E402


def diagnose(task: str, split: str, n: int, actions_per_context: int = 8, seed: int = 0,
             iterations: int | None = None, scene: dict | None = None) -> list[dict]:
    """Per context: its hidden values, the chain's mean landing error at the true physics, and the one-attempt
    regret of PhyPlan's planner with the chain at the true and at the nominal physics (``iterations``: its MCTS
    iterations K, default the agent's; ``scene``: the task's scene arguments, e.g. ``{"paddles": 4}``)."""
    import gymnasium as gym

    import phyplan_envs
    from phyplan_agents import TaskInfo
    from phyplan_agents.phyplan.agent import PhyPlanNoGPAgent
    from phyplan_envs import splits

    env = gym.make(phyplan_envs.env_id(task), obs_mode="state", with_panda=False, **(scene or {}))
    info0 = TaskInfo.from_env(env)
    agent = PhyPlanNoGPAgent() if iterations is None else PhyPlanNoGPAgent(iterations=iterations)
    agent.setup(info0, seed)
    pred = agent.predictor
    nominal = pred.theta
    rng = np.random.default_rng(seed)
    out = []
    for ctx in splits.context_seeds(split, n):
        obs, info = env.reset(seed=ctx)
        hidden = env.unwrapped.hidden_physics
        truth = np.array([hidden[p.name] for p in pred.space])

        def attempt(action):
            env.reset(options={"context": info["context"]})
            _, reward, _, _, step = env.step(action)
            return float(reward), np.asarray(step["final_pos"][:2], dtype=np.float64)

        agent.reseed(ctx)
        agent.begin_context(obs, info)
        pred.theta = truth
        errs = []
        for a in rng.uniform(info0.action_low, info0.action_high, (actions_per_context, info0.action_dim)):
            errs.append(float(np.linalg.norm(pred.final_xy(a[None])[0] - attempt(a)[1])))
        errs = np.array(errs)
        finite = errs[np.isfinite(errs)]       # NaN: the chain makes no prediction (outside every skill's domain)
        r_true = attempt(agent.act())[0]
        pred.theta = nominal
        r_nominal = attempt(agent.act())[0]
        out.append({"context": ctx, "hidden": hidden, "chain_error": float(finite.mean()) if len(finite) else math.nan,
                    "no_prediction": float(np.mean(~np.isfinite(errs))),
                    "regret_true_physics": max(0.0, 1 - r_true), "regret_nominal_physics": max(0.0, 1 - r_nominal)})
    env.close()
    return out


def plot(results: dict[tuple[str, str], list[dict]], out: str | Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks = sorted({t for t, _ in results})
    names = {t: list(next(iter(results[(t, s)] for s in ("test", "dev") if (t, s) in results))[0]["hidden"])
             for t in tasks}
    cols = max(len(v) for v in names.values())
    fig, axes = plt.subplots(len(tasks), cols, figsize=(3.4 * cols, 2.6 * len(tasks)), squeeze=False)
    for i, t in enumerate(tasks):
        for j in range(cols):
            ax = axes[i, j]
            if j >= len(names[t]):
                ax.axis("off")
                continue
            p = names[t][j]
            for split, colour in (("dev", "tab:blue"), ("test", "tab:orange")):
                rows = results.get((t, split), [])
                if rows:
                    ax.scatter([r["hidden"][p] for r in rows], [1000 * r["chain_error"] for r in rows], s=14,
                               color=colour, label="train space" if split == "dev" else "test space")
            ax.set_xlabel(p, fontsize=8)
            ax.set_ylabel(f"{t}\nchain error (mm)" if j == 0 else "", fontsize=8)
            if p == "bob_mass":
                from matplotlib.ticker import NullFormatter, ScalarFormatter

                ax.set_xscale("log")
                ax.xaxis.set_major_formatter(ScalarFormatter())
                ax.xaxis.set_minor_formatter(NullFormatter())
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3)
            if i == 0 and j == 0:
                ax.legend(fontsize=7)
    fig.suptitle("varied chain at the true physics vs the env: mean landing error per context", fontsize=10)
    fig.tight_layout()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    import phyplan_envs

    p = argparse.ArgumentParser(prog="python -m benchmarks.sysid_diagnostics", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--tasks", nargs="+", default=list(phyplan_envs.VARIED_TASKS))
    p.add_argument("--splits", nargs="+", default=["dev", "test"], choices=["dev", "test"])
    p.add_argument("--contexts", type=int, default=10, help="contexts per task and split (default 10)")
    p.add_argument("--actions", type=int, default=8, help="random actions per context for the chain error")
    p.add_argument("--iterations", type=int, default=None, metavar="K",
                   help="the planner's MCTS iterations (default the agent's, 10): how much a larger search helps")
    p.add_argument("--paddles", type=int, nargs="+", default=None, metavar="N",
                   help="paddles-varied only: its paddle counts, one row each (default the task's, 3)")
    p.add_argument("--out", default=None, help="figure PNG (default: none)")
    args = p.parse_args(argv)
    if args.paddles is not None and (args.tasks != ["paddles-varied"] or min(args.paddles) < 1):
        p.error("--paddles takes paddle counts >= 1 and only with --tasks paddles-varied")
    if args.iterations is not None and args.iterations < 1:
        p.error(f"--iterations must be at least 1, got {args.iterations}")
    results = {}
    scenes = [(t, None) for t in args.tasks] if args.paddles is None else \
        [(f"paddles-varied N={n}", {"paddles": n}) for n in args.paddles]
    width = max(14, *(len(name) for name, _ in scenes))
    print(f"{'task':{width}s} split  contexts  chain error mm (mean / max)  no prediction  regret@1 true physics  "
          "regret@1 nominal")
    for name, scene in scenes:
        t = args.tasks[0] if scene else name
        for s in args.splits:
            rows = diagnose(t, s, args.contexts, args.actions, iterations=args.iterations, scene=scene)
            results[(name, s)] = rows
            ce = np.array([r["chain_error"] for r in rows])
            ce = ce[np.isfinite(ce)] if np.isfinite(ce).any() else np.array([math.nan])
            none = np.mean([r["no_prediction"] for r in rows])
            rt = np.array([r["regret_true_physics"] for r in rows])
            rn = np.array([r["regret_nominal_physics"] for r in rows])
            print(f"{name:{width}s} {s:5s} {len(rows):9d}  {1000 * ce.mean():12.1f} / {1000 * ce.max():5.1f}"
                  f"        {none:6.0%}        {rt.mean():8.3f} (max {rt.max():.3f})      {rn.mean():8.3f}",
                  flush=True)
    if args.out:
        print(f"wrote {plot(results, args.out)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
