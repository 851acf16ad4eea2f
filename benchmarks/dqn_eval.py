"""A quick check of the DQN baselines on their own: mean regret after attempt 1 and after the last attempt.

    python -m benchmarks.dqn_eval --task launch --task slide --contexts 20 --attempts 5

runs each agent on the first ``--contexts`` seeds of ``--split`` (default ``test``, :mod:`benchmarks.splits`),
``--attempts`` attempts per context, for ``--seeds`` run seeds, through the harness's cell runner
(:func:`benchmarks.harness.evaluate`: the same protocol, seeding and rewards as ``python -m benchmarks.run``), and
prints a Markdown table of mean regret ``max(0, 1 - best reward so far)`` with the 95% Student-t half-width over
contexts (:mod:`benchmarks.stats`; each context's regret averaged over the seeds first), and the wall time per
context. The full benchmark (plots, resume, parallel runs) is ``python -m benchmarks.run``.
"""
from __future__ import annotations

import argparse
import ast
import functools
import inspect
import time
from typing import Any, Sequence

import numpy as np


def regret_table_row(records: Sequence[Any], attempts: int) -> tuple[np.ndarray, np.ndarray]:
    """Mean regret after each attempt and its 95% half-width over contexts, from one agent's records on one task."""
    from .stats import half_width, regret_per_context

    _, reg = regret_per_context(records)
    if reg.shape[1] != attempts:
        raise ValueError(f"the records have {reg.shape[1]} attempts per cell, expected {attempts}")
    return reg.mean(axis=0), half_width(reg)


def parse_agent_kw(items: Sequence[str]) -> dict[str, Any]:
    """``KEY=VALUE`` strings to a dict (values parsed as Python literals, else kept as strings)."""
    extra: dict[str, Any] = {}
    for kv in items:
        key, sep, value = kv.partition("=")
        if not sep or not key:
            raise ValueError(f"--agent-kw needs KEY=VALUE, got {kv!r}")
        try:
            extra[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            extra[key] = value
    return extra


def main(argv: Sequence[str] | None = None) -> None:
    p = argparse.ArgumentParser(prog="python -m benchmarks.dqn_eval", description=__doc__.split("\n")[0])
    p.add_argument("--task", action="append", required=True, help="task name (repeatable)")
    p.add_argument("--agent", action="append", default=None,
                   help="agent name (repeatable; default dqn-adapted, dqn-simple, random)")
    p.add_argument("--contexts", type=int, default=20)
    p.add_argument("--attempts", type=int, default=5)
    p.add_argument("--seeds", type=int, default=1, help="run seeds 0 .. seeds-1")
    p.add_argument("--split", default="test", choices=["test", "dev"])
    p.add_argument("--model-dir", default=None, help="DQN model folder (default: the shipped models)")
    p.add_argument("--agent-kw", action="append", default=[], metavar="KEY=VALUE",
                   help="extra keyword for the agents whose constructor takes it (repeatable; values parsed as "
                        "Python literals), e.g. optimize=True for dqn-adapted")
    args = p.parse_args(argv)
    for name in ("contexts", "attempts", "seeds"):
        if getattr(args, name) < 1:
            p.error(f"--{name} must be at least 1, got {getattr(args, name)}")

    import torch as th

    import phyplan_agents

    from . import harness, splits

    th.set_num_threads(1)
    agents = args.agent or ["dqn-adapted", "dqn-simple", "random"]
    try:
        extra = parse_agent_kw(args.agent_kw)
        tasks = harness.check_tasks(args.task)
        classes = {n: phyplan_agents.resolve(n) for n in agents}
    except ValueError as exc:
        p.error(str(exc))
    for key in extra:
        if not any(key in inspect.signature(cls).parameters for cls in classes.values()):
            p.error(f"--agent-kw {key}: none of the agents {agents} takes that option")
    contexts = splits.context_seeds(args.split, args.contexts)
    k = args.attempts
    print(f"| task | agent | regret @1 | regret @{k} | s/context |")
    print("|---|---|---|---|---|")
    for task in tasks:
        for name in agents:
            accepted = inspect.signature(classes[name]).parameters
            kwargs = {key: v for key, v in extra.items() if key in accepted}
            if args.model_dir and "model_dir" in accepted:
                kwargs["model_dir"] = args.model_dir
            t0 = time.perf_counter()
            records = harness.evaluate(functools.partial(phyplan_agents.make, name, **kwargs), task, contexts,
                                       attempts=k, seeds=range(args.seeds), split=args.split, name=name)
            per_ctx = (time.perf_counter() - t0) / (len(contexts) * args.seeds)
            mean, half = regret_table_row(records, k)
            print(f"| {task} | {name} | {_pm(mean[0], half[0])} | {_pm(mean[-1], half[-1])} | {per_ctx:.2f} |",
                  flush=True)


def _pm(mean: float, half: float) -> str:
    return f"{mean:.3f}" if not np.isfinite(half) else f"{mean:.3f} ± {half:.3f}"


if __name__ == "__main__":
    main()
