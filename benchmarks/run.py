"""Command line of the benchmark harness (also installed as ``phyplan-bench``).

Examples::

    python -m benchmarks.run --tasks launch slide --agents random oracle --contexts 20 --attempts 5 --seeds 3 \\
        --out results/quick
    python -m benchmarks.run --out results/bench --skip-missing            # the default benchmark (make bench)
    python -m benchmarks.run --agents random mypkg.agents:MyAgent --out results/mine --workers 2
    python -m benchmarks.run --track varied --agents random oracle --out results/varied   # hidden physics, K=10
    python -m benchmarks.run ... --backend ray                              # RAY_ADDRESS=... for a cluster

Rerunning a command with the same ``--out`` resumes it; see :mod:`benchmarks.harness` for the protocol and
:mod:`benchmarks.report` for the summary's definitions. Outputs: ``attempts.jsonl``, ``config.json``,
``summary.md``, ``summary.csv``, ``regret_<task>.png`` and ``runtime.png``.
"""
from __future__ import annotations

import os

# one thread per process before numpy/torch load: faster with several workers, and identical floats everywhere
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import sys  # noqa: E402
from typing import Sequence  # noqa: E402

DEFAULTS = dict(contexts=20, attempts=5, seeds=3, split="test")
"""The defaults: 20 test contexts, 5 attempts (the paper's Table "after 1 -> 5 attempts"), 3 run seeds."""
VARIED_ATTEMPTS = 10
"""Attempts per context on the varied (hidden-physics) track: adaptation needs more than 5."""
VARIED_AGENTS = ("phyplan", "phyplan-position", "phyplan-nogp", "phyplan-sysid", "dqn-simple", "dqn-adapted", "random",
                 "oracle")
"""Default agents when every task is a varied one: the adaptive PhyPlan variants beside the default agents."""


def build_parser() -> argparse.ArgumentParser:
    from . import harness, splits

    p = argparse.ArgumentParser(
        prog="phyplan-bench",
        description="Score agents on phyplan tasks: regret vs attempts on fixed test contexts, with resume, "
                    "parallel workers and Ray.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--tasks", nargs="+", metavar="TASK", default=None,
                   help="task names (default: the --track's tasks); nominal (phyplan_envs.TASKS) or varied "
                        "(phyplan_envs.VARIED_TASKS, e.g. launch-varied)")
    p.add_argument("--track", default="nominal", choices=["nominal", "varied", "depth"],
                   help="default task set: 'nominal' (the five tasks), 'varied' (their hidden-physics versions, "
                        f"{VARIED_ATTEMPTS} attempts by default) or 'depth' (Paddles-N at its default N = 3 and its "
                        "varied version; over N: python -m benchmarks.depth)")
    p.add_argument("--agents", nargs="+", metavar="AGENT", default=None,
                   help=f"agent names, entry points or 'module:Class' (default: {' '.join(harness.DEFAULT_AGENTS)}; "
                        f"on the varied track {' '.join(VARIED_AGENTS)})")
    p.add_argument("--contexts", type=int, default=DEFAULTS["contexts"],
                   help="contexts per task (the first N of the split)")
    p.add_argument("--attempts", type=int, default=None,
                   help=f"attempts per context (K; default {DEFAULTS['attempts']}, or {VARIED_ATTEMPTS} when every "
                        f"task is a varied one)")
    p.add_argument("--seeds", type=int, default=DEFAULTS["seeds"], help="run seeds per task and agent (0..N-1)")
    p.add_argument("--split", default=DEFAULTS["split"], choices=list(splits.SPLITS), help="context split")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (rerun with the same DIR to resume)")
    p.add_argument("--workers", type=int, default=1, help="parallel worker processes (or Ray CPUs)")
    p.add_argument("--backend", default="process", choices=["process", "ray"],
                   help="'process': local processes; 'ray': Ray tasks (RAY_ADDRESS for a cluster)")
    p.add_argument("--skip-missing", action="store_true",
                   help="skip default agents that are not available yet (not registered, not importable, or their "
                        "setup fails, e.g. missing weights) instead of failing")
    p.add_argument("--no-plots", action="store_true", help="do not write the PNG plots")
    p.add_argument("--video", metavar="DIR", default=None,
                   help="also write one MP4 per (task, agent, seed, context) to DIR, its attempts one after another "
                        "(benchmarks/videos.py)")
    p.add_argument("--video-contexts", type=int, default=2, help="with --video: the first N contexts of each task")
    p.add_argument("--video-robot", action="store_true",
                   help="with --video: replay the attempts in robot mode (the Panda executes them)")
    p.add_argument("--attempt-timeout", type=float, default=harness.DEFAULT_ATTEMPT_TIMEOUT, metavar="SECONDS",
                   help="time limit of each agent call of an attempt (begin_context, act, observe): a call past it "
                        "fails its attempt with a timeout, the cell's later attempts are not run and the agent is "
                        "made afresh; 0: no limit")
    p.add_argument("--memory-limit", type=float, default=None, metavar="MB",
                   help="resident memory each worker process may use: past it the worker is killed and its cell "
                        "fails with 'crashed: out of memory' (Linux; checked every 50 ms, so a budget, not a hard "
                        "cap); default: none (the kernel's OOM killer, which then fails the cell)")
    p.add_argument("--in-process", action="store_true",
                   help="run the agents in this process instead of a watched worker process (serial only; for "
                        "debuggers and profilers): an agent that kills its process then ends the run, and its cell "
                        f"is recorded as crashed after {harness.MAX_STRIKES} such deaths")
    p.add_argument("--repair", action="store_true",
                   help=f"move damaged lines of attempts.jsonl (not UTF-8/JSON, wrong-typed fields, out-of-range "
                        f"attempts) to {harness.REJECTED_NAME} and rerun their cells")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark; prints the summary table; returns the exit code (2 for bad arguments)."""
    from . import harness, report

    p = build_parser()
    args = p.parse_args(argv)
    if args.workers < 1:
        p.error(f"--workers must be at least 1, got {args.workers}")
    if args.video_contexts < 1:
        p.error(f"--video-contexts must be at least 1, got {args.video_contexts}")
    if not args.attempt_timeout >= 0:
        p.error(f"--attempt-timeout must be a number of seconds >= 0 (0: no limit), got {args.attempt_timeout}")
    if args.memory_limit is not None and not args.memory_limit > 0:
        p.error(f"--memory-limit must be a positive number of megabytes, got {args.memory_limit}")
    if args.in_process and (args.workers > 1 or args.backend != "process"):
        p.error("--in-process runs the agents in this process: it cannot be combined with --workers > 1 or "
                "--backend ray")
    if args.memory_limit is not None and (args.in_process or args.backend != "process"):
        p.error("--memory-limit needs the agents in the harness's worker processes: not with --in-process or "
                "--backend ray (Ray has its own memory monitor)")

    def log(msg: str) -> None:
        print(msg, file=sys.stderr)

    try:
        import phyplan_envs

        tasks = harness.check_tasks(args.tasks if args.tasks is not None else list(phyplan_envs.TRACKS[args.track]))
        varied = all(t in phyplan_envs.VARIED_TASKS for t in tasks)
        if args.attempts is None:
            args.attempts = VARIED_ATTEMPTS if varied else DEFAULTS["attempts"]
        if args.agents is None and varied:
            args.agents = list(VARIED_AGENTS)
        agents, bounds = harness.resolve_agents(args.agents, skip_missing=args.skip_missing, log=log)
        config = harness.RunConfig(tasks=tasks, agents=agents, contexts=args.contexts, attempts=args.attempts,
                                   seeds=args.seeds, split=args.split, bound_agents=bounds)
    except ValueError as exc:
        p.error(str(exc))
    try:
        result = harness.run(config, args.out, workers=args.workers, backend=args.backend,
                             progress=not args.quiet, log=log, attempt_timeout=args.attempt_timeout or None,
                             repair=args.repair, isolate=not args.in_process, memory_limit=args.memory_limit)
    except (harness.ConfigMismatch, harness.OutDirError) as exc:
        p.error(str(exc))
    except harness.DamagedRecords as exc:
        print(f"phyplan-bench: error: {exc}", file=sys.stderr)
        return 1
    except ValueError as exc:       # an option this platform cannot honour (e.g. --memory-limit without /proc)
        p.error(str(exc))
    except RuntimeError as exc:
        print(f"phyplan-bench: error: {exc}", file=sys.stderr)
        return 1
    _, text = report.write_report(result.records, args.out, config.to_dict(), plots=not args.no_plots)
    print(text)
    log(f"wrote {args.out}/summary.md, summary.csv, attempts.jsonl" + ("" if args.no_plots else ", plots"))
    if args.video:
        from .videos import write_videos
        write_videos(result.records, args.video, args.video_contexts, robot="panda" if args.video_robot else None,
                     log=None if args.quiet else log)
    problems = harness.describe_unavailable(result.unavailable)
    for line in problems:
        log(("skipped: " if args.skip_missing else "error: ") + line)
    return 1 if problems and not args.skip_missing else 0


if __name__ == "__main__":
    sys.exit(main())
