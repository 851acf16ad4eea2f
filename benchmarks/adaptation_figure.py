"""A figure like the paper's Fig. 10: where each agent's attempts land relative to the goal, attempt by attempt.

One varied context (default: the first test context of ``bounce-varied``, whose hidden physics come from the test
space), every agent run for ``--attempts`` attempts through the harness's cell runner (:func:`benchmarks.harness.
evaluate`: the same seeding and records as the benchmark), then each recorded action replayed in the env to read
its landing point (the env is deterministic, so the replay is the attempt). One panel per agent: the landing points
relative to the goal centre, coloured by attempt number, with the goal box drawn; the printed table gives each
attempt's distance from the goal.

Example::

    python -m benchmarks.adaptation_figure --out docs/img/adaptation_bounce.png
    python -m benchmarks.adaptation_figure --task slide-varied --context 200003 --agents phyplan phyplan-sysid
"""
from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Sequence  # noqa: E402

import numpy as np  # noqa: E402

AGENTS = ("random", "dqn-simple", "dqn-adapted", "phyplan-nogp", "phyplan", "phyplan-position", "phyplan-sysid",
          "oracle")


def landings(task: str, context: int, actions: Sequence[Sequence[float]]) -> tuple[np.ndarray, np.ndarray]:
    """The goal (2,) and the landing points (n, 2) of ``actions`` replayed at context ``context``."""
    import gymnasium as gym

    import phyplan_envs

    env = gym.make(phyplan_envs.env_id(task), obs_mode="state", with_panda=False)
    try:
        _, info = env.reset(seed=int(context))
        ctx = info["context"]
        out = []
        for a in actions:
            env.reset(options={"context": ctx})
            _, _, _, _, step_info = env.step(np.asarray(a, dtype=np.float64))
            out.append(np.asarray(step_info["final_pos"], dtype=np.float64)[:2])
        return np.asarray(info["goal"], dtype=np.float64), np.asarray(out).reshape(-1, 2)
    finally:
        env.close()


def run(task: str, context: int, agents: Sequence[str], attempts: int, seed: int) -> dict[str, dict]:
    """Per agent: its actions, rewards, landing points and the goal at ``context`` (one run seed)."""
    from . import harness

    out = {}
    for name in agents:
        records = harness.evaluate(name, task, [context], attempts=attempts, seeds=seed)
        actions = [r.action for r in records if r.action is not None]
        goal, xy = landings(task, context, actions)
        out[name] = {"actions": actions, "rewards": [r.reward for r in records], "xy": xy, "goal": goal,
                     "distance": np.linalg.norm(xy - goal, axis=1)}
    return out


def plot(results: dict[str, dict], task: str, context: int, out: str | Path, hidden: dict | None = None,
         span: float = 0.3) -> Path:
    """One panel per agent: landing points minus the goal within +-``span`` m (farther ones on the border)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    names = list(results)
    cols = min(4, len(names))
    rows = int(np.ceil(len(names) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 3.2 * rows + 0.5), squeeze=False)
    cmap = plt.get_cmap("viridis")
    for ax, name in zip(axes.ravel(), names):
        r = results[name]
        rel = r["xy"] - r["goal"]
        n = len(rel)
        # points beyond the panel are drawn on its border as triangles (the same scale in every panel)
        far = np.max(np.abs(rel), axis=1) > span if n else np.zeros(0, bool)
        shown = np.clip(rel, -0.97 * span, 0.97 * span)
        ax.add_patch(Rectangle((-0.05, -0.05), 0.1, 0.1, fill=False, color="red", lw=1.2))
        ax.plot(shown[:, 0], shown[:, 1], "-", color="0.8", lw=0.8, zorder=1)
        for mask, marker in ((~far, "o"), (far, "^")):
            sc = ax.scatter(shown[mask, 0], shown[mask, 1], c=np.arange(1, n + 1)[mask], cmap=cmap, vmin=1,
                            vmax=max(n, 2), s=28, marker=marker, zorder=2, edgecolors="k", linewidths=0.4)
        for k, (x, y) in enumerate(shown, start=1):
            if k <= 3 or k == n:
                ax.annotate(str(k), (x, y), textcoords="offset points", xytext=(3, 3), fontsize=7)
        ax.plot([0], [0], "r+", ms=9)
        ax.set_xlim(-span, span)
        ax.set_ylim(-span, span)
        ax.set_aspect("equal")
        ax.set_title(f"{name}\nbest d = {100 * float(np.min(r['distance'])):.1f} cm", fontsize=9)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    for ax in axes.ravel()[len(names):]:
        ax.axis("off")
    fig.colorbar(sc, ax=axes.ravel().tolist(), shrink=0.6, label="attempt")
    hid = "" if not hidden else " (" + ", ".join(f"{k} {v:.3g}" for k, v in hidden.items()) + ")"
    fig.suptitle(f"{task}, context {context}{hid}: landing point - goal (m; triangles: beyond +-{span:g} m), "
                 f"goal box in red", fontsize=10)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def hidden_physics(task: str, context: int) -> dict:
    """The context's hidden values (privileged, for the figure's title only)."""
    import gymnasium as gym

    import phyplan_envs

    env = gym.make(phyplan_envs.env_id(task), obs_mode="state", with_panda=False)
    try:
        env.reset(seed=int(context))
        return dict(getattr(env.unwrapped, "hidden_physics", {}) or {})
    finally:
        env.close()


def main(argv: Sequence[str] | None = None) -> int:
    from phyplan_envs import splits

    p = argparse.ArgumentParser(prog="python -m benchmarks.adaptation_figure", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--task", default="bounce-varied", help="a task name (default bounce-varied)")
    p.add_argument("--context", type=int, default=None, help="context id (default: the first test context)")
    p.add_argument("--agents", nargs="+", default=list(AGENTS), help="agents, one panel each")
    p.add_argument("--attempts", type=int, default=10, help="attempts per agent (default 10)")
    p.add_argument("--seed", type=int, default=0, help="run seed (default 0)")
    p.add_argument("--out", default="docs/img/adaptation_bounce.png", help="output PNG")
    p.add_argument("--span", type=float, default=0.3, help="half-width of every panel (m; default 0.3)")
    args = p.parse_args(argv)
    if args.attempts < 1:
        p.error(f"--attempts must be >= 1, got {args.attempts}")
    context = args.context if args.context is not None else splits.context_seeds("test", 1)[0]
    results = run(args.task, context, args.agents, args.attempts, args.seed)
    hidden = hidden_physics(args.task, context)
    data = Path(args.out).with_suffix(".json")
    data.parent.mkdir(parents=True, exist_ok=True)
    data.write_text(json.dumps({"task": args.task, "context": context, "seed": args.seed, "agents": {
        k: {"actions": v["actions"], "rewards": v["rewards"], "xy": v["xy"].tolist(), "goal": v["goal"].tolist()}
        for k, v in results.items()}}, indent=1) + "\n")
    path = plot(results, args.task, context, args.out, hidden, args.span)
    width = max(len(n) for n in results)
    print(f"{args.task} context {context}: distance from the goal (cm) per attempt")
    print(" " * width + " " + " ".join(f"{k:>6d}" for k in range(1, args.attempts + 1)))
    for name, r in results.items():
        print(f"{name:<{width}} " + " ".join(f"{100 * d:6.1f}" for d in r["distance"]))
    print(f"wrote {path} and {data.name} (the landing points)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
