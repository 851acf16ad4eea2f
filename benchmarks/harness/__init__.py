"""The benchmark harness: runs the agent protocol on fixed contexts and records every attempt.

Protocol (the paper's evaluation, PHYRE-style). For each task, agent, run seed and test context:

1. ``agent.setup(TaskInfo.from_env(env), seed)`` — once per (task, agent, run seed) in each process; the env is
   made with the agent's ``env_kwargs`` attribute (a dict of ``gym.make`` keywords, e.g. ``{"obs_mode": "image",
   "image_size": 64}``) or its ``obs_mode`` attribute, default ``obs_mode="state"``;
2. the context's observation ``obs, info = env.reset(seed=context)`` goes to
   ``agent.begin_context(obs, info, simulator)``, where ``simulator`` is a counted
   :class:`phyplan_agents.Simulator` on a separate env fixed to this context if ``agent.needs_simulator``, else None;
3. for attempts ``k = 1 .. K``: ``action = agent.act()``; the env is reset to the same context and stepped with the
   action; ``agent.observe(action, reward, info)``.

One *cell* is (task, agent, run seed, context) with all its K attempts. Cells are independent: before each cell the
harness reseeds the agent from (run seed, context) only (:func:`cell_seed`), so a cell's outcome does not depend on
which cells ran before it, in which process, or in which order. That is what makes ``--workers N`` and ``--backend
ray`` give the same records as a serial run and makes resuming exact. An agent that keeps learning across contexts
breaks this on purpose; it should keep such state out of ``begin_context`` onwards or accept order-dependence.

Reseeding an agent: the harness calls ``agent.reseed(seed)`` if the agent has that method, otherwise it replaces
``agent.rng`` with ``numpy.random.default_rng(seed)``; it also seeds Python's ``random``, NumPy's global generator and
(if imported) torch's, for agents that draw from global generators.

Every attempt becomes one :class:`AttemptRecord`, appended to ``DIR/attempts.jsonl`` and flushed as it happens.
Failures are data, not crashes: an exception in ``begin_context``, ``act`` or ``observe``, or an action that is not a
finite vector of the right shape inside the bounds, is recorded with ``error`` set to the reason (reward None, best
and regret unchanged) and the run goes on. An agent that cannot be made or set up at all (``setup`` raises, e.g.
missing weights) is *unavailable*: its cells are reported, not recorded, so a rerun after the fix fills them in.
``BaseException``s of an agent (``SystemExit``, its own ``KeyboardInterrupt``) are recorded too; a user's Ctrl-C stops
the run. Each agent call may take ``attempt_timeout`` seconds (``--attempt-timeout``, default 300): a call past it
fails its attempt, the cell's later attempts are recorded as not run and the agent is made afresh
(:mod:`~benchmarks.harness.guard`).

Agents run in worker processes (one for a serial run) watched by the main process, which runs no agent code
(:mod:`~benchmarks.harness.supervise`): an agent whose process dies (``os._exit``, a signal such as SIGSEGV, the OOM
killer, ``memory_limit``) fails its cell like a timeout does (``crashed: exit code 7 during act()``, the later
attempts not run) and the run goes on with a fresh worker. If the run's own process dies while a cell runs
(``isolate=False``, or it was killed), the in-flight marker (:mod:`~benchmarks.harness.inflight`) makes the reruns
run that cell alone, and record it as crashed after a second death, so no rerun dies on the same cell forever.

One writer: a run holds an exclusive lock on ``DIR`` (:mod:`~benchmarks.harness.lock`); a second run on it is
refused while the first lives. Damaged lines of ``attempts.jsonl`` raise :class:`DamagedRecords` naming them;
``repair=True`` (``--repair``) moves them to ``attempts.rejected.jsonl`` and reruns their cells.

Resume: ``DIR/config.json`` stores the run's configuration; a rerun with the same ``DIR`` and the same configuration
skips the finished cells (all K attempts recorded) and reruns the rest. A truncated last line (a run killed with
``kill -9`` mid-write) and the records of unfinished cells are dropped first. A different configuration in the same
``DIR`` is refused.

For a study that needs figures rather than a results directory, :func:`evaluate` runs the same cells (same runner,
same seeding, same records) for one agent on given contexts in this process and returns the records.

The package, one idea per module: :mod:`~benchmarks.harness.records` (the record, cell and configuration types),
:mod:`~benchmarks.harness.runner` (the cell runner, seeding, action checks), :mod:`~benchmarks.harness.store`
(``attempts.jsonl`` and ``config.json``: write, load, resume, repair), :mod:`~benchmarks.harness.supervise` (the
watched worker processes), :mod:`~benchmarks.harness.inflight` (the in-flight marker),
:mod:`~benchmarks.harness.backends` (which of them runs the cells, and Ray); this module holds the drivers.
"""
from __future__ import annotations

from collections import OrderedDict
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from .. import splits
from ..platform_info import record_platform
from .backends import run_isolated, run_ray, run_serial
from .records import (ACTION_TOL, BOUND_AGENTS, CONFIG_NAME, DEFAULT_AGENTS, HARNESS_VERSION, RECORDS_NAME,
                      TIMING_FIELDS, TIMING_SUFFIXES, AttemptRecord, Cell, CellOutcome, ConfigMismatch, RunConfig,
                      RunResult, jsonable, shorten)
from .guard import DEFAULT_ATTEMPT_TIMEOUT, AttemptTimeout, interrupts_marked
from .inflight import INFLIGHT_NAME, MAX_STRIKES, InFlight
from .lock import DirLock, DirLocked
from .runner import Runner, cell_seed, make_agent, reseed_agent, validate_action
from .store import (REJECTED_NAME, DamagedRecords, OutDirError, Writer, check_out_dir, load_records, prepare_dir,
                    read_config)

__all__ = [
    "AgentUnavailable",
    "ACTION_TOL", "BOUND_AGENTS", "CONFIG_NAME", "DEFAULT_AGENTS", "DEFAULT_ATTEMPT_TIMEOUT", "AttemptTimeout",
    "DamagedRecords", "DirLock", "DirLocked", "INFLIGHT_NAME", "MAX_STRIKES", "OutDirError", "REJECTED_NAME",
    "check_out_dir", "HARNESS_VERSION",
    "RECORDS_NAME", "TIMING_FIELDS",
    "TIMING_SUFFIXES", "AttemptRecord", "Cell", "CellOutcome", "ConfigMismatch", "RunConfig", "RunResult", "Runner",
    "Writer", "cell_seed", "check_tasks", "describe_unavailable", "evaluate", "jsonable", "load_records",
    "make_agent", "prepare_dir", "read_config", "reseed_agent", "resolve_agents", "run", "validate_action",
]


def resolve_agents(names: Sequence[str] | None, skip_missing: bool = False,
                   log: Callable[[str], None] = print) -> tuple[list[str], list[str]]:
    """Check agent names: returns ``(runnable names, bound names)``.

    Unknown names raise ``ValueError`` listing the available agents. A name of :data:`DEFAULT_AGENTS` that cannot be
    loaded yet (not registered, or its module not written yet) is skipped with a message if ``skip_missing``, and
    raises otherwise.
    """
    import phyplan_agents

    names = list(DEFAULT_AGENTS if names is None else names)
    ok, bounds, missing = [], [], []
    for name in names:
        try:
            cls = phyplan_agents.resolve(name)
        except Exception as exc:
            if name in DEFAULT_AGENTS:
                missing.append((name, str(exc)))
                continue
            raise ValueError(f"{exc}") from None
        ok.append(name)
        if name in BOUND_AGENTS or getattr(cls, "is_bound", False):
            bounds.append(name)
    if missing:
        text = "; ".join(f"{n} ({shorten(reason, 160)})" for n, reason in missing)
        if not skip_missing:
            raise ValueError(f"agents not available yet: {text}. Pass --skip-missing to run the others "
                             f"(available agents: {', '.join(phyplan_agents.available())})")
        log(f"skipping agents not available yet: {', '.join(n for n, _ in missing)}")
    if not ok:
        raise ValueError("no agent left to run (all requested agents are missing)")
    return ok, bounds


def check_tasks(names: Sequence[str] | None) -> list[str]:
    """Check task names (default: the nominal track, ``phyplan_envs.TRACKS["nominal"]``; every registered task name
    is accepted, the varied ones and Paddles' included); unknown ones raise ``ValueError`` listing the tasks."""
    import phyplan_envs

    if names is None:
        return list(phyplan_envs.TRACKS["nominal"])
    bad = [n for n in names if n not in phyplan_envs.ALL_TASKS]
    if bad:
        raise ValueError(f"unknown task(s) {', '.join(map(repr, bad))}; available tasks: "
                         f"{', '.join(phyplan_envs.ALL_TASKS)}")
    return list(names)


def run(config: RunConfig, out_dir: str | Path, workers: int = 1, backend: str = "process",
        progress: bool = True, agent_specs: Mapping[str, Any] | None = None,
        log: Callable[[str], None] = print, attempt_timeout: float | None = DEFAULT_ATTEMPT_TIMEOUT,
        repair: bool = False, isolate: bool = True, memory_limit: float | None = None) -> RunResult:
    """Run (or resume) a benchmark into ``out_dir``; the result holds all its records (finished cells only).

    Args:
        config: what to run (see :class:`RunConfig`).
        out_dir: output directory (created); ``attempts.jsonl`` and ``config.json`` live here.
        workers: processes for the cells (1 = in this process).
        backend: ``"process"`` (a local process pool when ``workers > 1``) or ``"ray"`` (Ray tasks; connects to
            ``RAY_ADDRESS`` if set, else starts a local Ray with ``workers`` CPUs).
        progress: show a tqdm progress bar (attempts done, rate, ETA).
        agent_specs: optional agent name -> ``"module:Class"`` or class, for names the registry does not know in
            a fresh process (worker processes resolve agents by name again).
        attempt_timeout: seconds each agent call (``begin_context``, ``act``, ``observe``) may take before its
            attempt fails with a timeout (:mod:`benchmarks.harness.guard`); ``None`` or 0: no limit.
        repair: move damaged lines of ``attempts.jsonl`` to ``attempts.rejected.jsonl`` and rerun their cells
            (without it a damaged file raises :class:`DamagedRecords` naming the lines).
        isolate: run the agents in watched worker processes (the default; ``workers`` of them, one for a serial
            run), so that an agent that kills its process fails its cell (:mod:`~benchmarks.harness.supervise`).
            ``False`` (only with ``workers=1``): in this process, as a debugger or profiler wants it; an agent that
            kills it ends the run, and the in-flight marker keeps reruns from dying on that cell forever.
        memory_limit: megabytes of resident memory a worker process may use; past it the worker is killed and its
            cell fails with ``crashed: out of memory: ...`` (needs ``isolate``, the process backend and Linux).

    Guarantees: one writer per ``out_dir`` (:class:`DirLock`; a second run on it raises :class:`DirLocked`);
    every record is flushed as it is made, so an interrupted run (Ctrl-C, a kill) keeps every finished record.
    """
    if backend not in ("process", "ray"):
        raise ValueError(f"backend must be 'process' or 'ray', got {backend!r}")
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    _check_isolation(workers, backend, isolate, memory_limit)
    out = check_out_dir(out_dir)
    with interrupts_marked(), DirLock(out):
        return _run_locked(config, out, workers, backend, progress, agent_specs, log, attempt_timeout, repair,
                           isolate, memory_limit)


def _check_isolation(workers: int, backend: str, isolate: bool, memory_limit: float | None) -> None:
    if not isinstance(isolate, bool):
        raise ValueError(f"isolate must be True or False, got {isolate!r}")
    if not isolate and (workers > 1 or backend != "process"):
        raise ValueError("isolate=False (--in-process) runs the agents in this process: it needs workers=1 and the "
                         "process backend")
    if memory_limit is None:
        return
    if isinstance(memory_limit, bool) or not isinstance(memory_limit, (int, float)) or not memory_limit > 0:
        raise ValueError(f"memory limit must be a positive number of megabytes, got {memory_limit!r}")
    if not isolate or backend != "process":
        raise ValueError("a memory limit (--memory-limit) needs the agents in the harness's worker processes: the "
                         "process backend, without --in-process (Ray has its own memory monitor)")
    if not Path("/proc/self/statm").exists():
        raise ValueError("a memory limit (--memory-limit) reads the workers' memory from /proc: Linux only")


def _run_locked(config: RunConfig, out: Path, workers: int, backend: str, progress: bool,
                agent_specs: Mapping[str, Any] | None, log: Callable[[str], None], attempt_timeout: float | None,
                repair: bool, isolate: bool, memory_limit: float | None) -> RunResult:
    prepare_dir(out, config)
    record_platform(out)        # where these records are made (platform.json; README, "Reproducibility")
    path = out / RECORDS_NAME
    done, dropped = load_records(path, config.attempts, repair=True, quarantine=repair)
    finished = {r.cell for r in done}
    todo = [c for c in config.cells() if c.key not in finished]
    total = len(config.cells())
    if finished:
        log(f"resuming {out}: {len(finished)}/{total} cells done" +
            (f" ({dropped} records of interrupted cells dropped)" if dropped else ""))
    unavailable: dict[tuple[str, str, int], str] = {}
    inflight = InFlight(out, finished, log) if backend == "process" else None
    if todo:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(todo) * config.attempts, unit="attempt", desc="bench", disable=not progress,
                   dynamic_ncols=True, smoothing=0.05)
        writer = Writer(path, bar)
        if inflight is not None:
            todo = inflight.settle(todo, config, writer, log)

        def done(cell: Cell, outcome: CellOutcome) -> None:
            if outcome.unavailable is not None:
                unavailable.setdefault((cell.task, cell.agent, cell.seed), outcome.unavailable)
                bar.update(config.attempts)  # nothing will come for this cell

        try:
            if backend == "ray":
                run_ray(todo, config, writer, workers, agent_specs or {}, done, attempt_timeout)
            elif isolate:
                run_isolated(todo, config, writer, workers, agent_specs or {}, done, attempt_timeout, memory_limit,
                             inflight)
            else:
                run_serial(todo, config, writer, agent_specs or {}, done, attempt_timeout, inflight)
        finally:
            if inflight is not None:
                inflight.close()
            writer.close()
            bar.close()
    records, _ = load_records(path, config.attempts, repair=True)
    return RunResult(records=records, unavailable=unavailable, ran=len(todo))


def describe_unavailable(unavailable: Mapping[tuple[str, str, int], str]) -> list[str]:
    """One line per agent and reason: which tasks and seeds could not be run and why."""
    groups: "OrderedDict[tuple[str, str], list[tuple[str, int]]]" = OrderedDict()
    for (task, agent, seed), reason in unavailable.items():
        groups.setdefault((agent, reason), []).append((task, seed))
    lines = []
    for (agent, reason), where in groups.items():
        tasks = list(OrderedDict.fromkeys(t for t, _ in where))
        seeds = sorted({s for _, s in where})
        lines.append(f"agent {agent!r} could not be set up on {', '.join(tasks)} (seeds {seeds}): {reason}; "
                     f"its cells were not run (rerun the same command after fixing it)")
    return lines

def evaluate(agent: Any, task: str, contexts: Sequence[int], attempts: int = 5, seeds: int | Sequence[int] = 0,
             split: str | None = None, name: str | None = None, env_kwargs: Mapping[str, Any] | None = None,
             errors: str = "raise", progress: bool = False) -> list[AttemptRecord]:
    """Score one agent on given contexts: the records of every (run seed, context) cell, in that order.

    The same cell runner, seeding and records as :func:`run` (a cell's records here equal the run's for the same
    agent, task, seed and context), in this process and without a results directory: what a study uses to get
    figures.

    Args:
        agent: a registered name or ``"module:Class"``, a class or zero-argument factory (called once per run seed),
            or an agent object (set up once per run seed; inspect it afterwards).
        task: task name.
        contexts: context ids (``env.reset`` seeds, e.g. ``splits.context_seeds("dev", 5)``).
        attempts: attempts per context.
        seeds: the run seeds (an int is one seed).
        split: the split written into the records (default: the split each context belongs to).
        name: the agent name in the records (default: ``agent`` if it is a string, else its ``name`` attribute or
            ``__name__``).
        env_kwargs: extra ``gym.make`` keywords for the envs (see :class:`~benchmarks.harness.runner.Runner`).
        errors: ``"raise"`` (default): a failed attempt (an exception in the agent, a bad action) raises
            ``RuntimeError`` naming the cell; ``"record"``: it stays in the records as in :func:`run`.
        progress: a tqdm bar over the cells on stderr.
    """
    (task,) = check_tasks([task])
    if isinstance(attempts, bool) or not isinstance(attempts, (int, np.integer)) or attempts < 1:
        raise ValueError(f"attempts must be a positive integer, got {attempts!r}")
    if errors not in ("raise", "record"):
        raise ValueError(f"errors must be 'raise' or 'record', got {errors!r}")
    seed_list = [seeds] if isinstance(seeds, (int, np.integer)) else list(seeds)
    ctx_list = list(contexts)
    for what, values in (("seeds", seed_list), ("contexts", ctx_list)):
        if not values:
            raise ValueError(f"{what} is empty")
        bad = [v for v in values if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0]
        if bad:
            raise ValueError(f"{what} must be non-negative integers, got {bad[:3]}")
    if name is None:
        name = agent if isinstance(agent, str) else getattr(agent, "name", None) or getattr(agent, "__name__", None)
        if not isinstance(name, str) or not name:
            raise ValueError(f"name: cannot tell the agent's name from {agent!r}; pass name=...")
    runner = Runner({name: agent}, env_kwargs)
    out: list[AttemptRecord] = []
    bar = None
    if progress:
        import sys

        from tqdm.auto import tqdm

        bar = tqdm(total=len(seed_list) * len(ctx_list), desc=f"{task} {name}", leave=False, file=sys.stderr)
    try:
        with interrupts_marked():
            _evaluate_cells(runner, task, name, seed_list, ctx_list, attempts, split, errors, out, bar)
    finally:
        runner.close()
        if bar is not None:
            bar.close()
    return out


class AgentUnavailable(RuntimeError):
    """:func:`evaluate`: the agent could not be set up on the task (its ``setup`` failed, e.g. a missing model)."""


def _evaluate_cells(runner: Runner, task: str, name: str, seed_list: list, ctx_list: list, attempts: int,
                    split: str | None, errors: str, out: list, bar: Any) -> None:
    for seed in seed_list:
        for ctx in ctx_list:
            cell = Cell(task, name, int(seed), int(ctx))
            cell_split = split or splits.split_of(int(ctx)) or "none"
            outcome = runner.run_cell(cell, attempts, cell_split, out.append)
            if outcome.unavailable is not None:
                raise AgentUnavailable(f"agent {name!r} could not be set up on {task} (seed {seed}): "
                                   f"{outcome.unavailable}")
            failed = [r for r in out[-attempts:] if r.error is not None]
            if failed and errors == "raise":
                raise RuntimeError(f"agent {name!r} on {task}, seed {seed}, context {ctx}, attempt "
                                   f"{failed[0].attempt}: {failed[0].error}")
            if bar is not None:
                bar.update(1)
