"""Where the cells run: in watched worker processes (the default, serial or parallel), in this process, or as Ray tasks.

Every backend runs each cell with :meth:`Runner.run_cell <benchmarks.harness.runner.Runner.run_cell>` and hands each
record to ``emit`` (the single writer in the main process) and each cell's :class:`CellOutcome` to ``done``. Cells
are independent (see :func:`benchmarks.harness.runner.cell_seed`), so all backends give the same records. The
worker processes are :mod:`~benchmarks.harness.supervise`'s (an agent that kills its process fails its cell);
:func:`run_serial` runs the agents in this process (an agent that kills it ends the run, and the in-flight marker of
:mod:`~benchmarks.harness.inflight` keeps reruns from dying on that cell forever).
"""
from __future__ import annotations

import os
import sys
from typing import Any, Callable, Mapping, Sequence

from .guard import DEFAULT_ATTEMPT_TIMEOUT
from .inflight import InFlight
from .records import AttemptRecord, Cell, CellOutcome, RunConfig, missing_attempts, shorten
from .runner import Runner
from .supervise import run_isolated

__all__ = ["RAY_MAX_RETRIES", "run_isolated", "run_ray", "run_serial"]

RAY_MAX_RETRIES = 1
"""Ray reruns a task whose worker process died this many times (a lost node) before its cell is recorded as crashed."""


def run_serial(cells: Sequence[Cell], config: RunConfig, emit: Callable, agent_specs: Mapping[str, Any],
                done: Callable[[Cell, CellOutcome], None],
                attempt_timeout: float | None = DEFAULT_ATTEMPT_TIMEOUT, inflight: InFlight | None = None) -> None:
    """Run ``cells`` one after another in this process (``isolate=False``, ``--in-process``)."""
    runner = Runner(agent_specs, attempt_timeout=attempt_timeout)
    try:
        for cell in cells:
            if inflight is not None:
                inflight.start(cell)
            outcome = runner.run_cell(cell, config.attempts, config.split, emit)
            if inflight is not None:
                inflight.finish(cell)
            done(cell, outcome)
    finally:
        runner.close()


_WORKER: dict[str, Any] = {}          # a Ray worker's runner, kept between its tasks


def _ray_cell(cell: Cell, attempts: int, split: str, agent_specs: Mapping[str, Any],
              attempt_timeout: float | None = DEFAULT_ATTEMPT_TIMEOUT) -> tuple[Cell, list[AttemptRecord], CellOutcome]:
    runner = _WORKER.get("ray_runner")
    if runner is None:
        runner = _WORKER["ray_runner"] = Runner(agent_specs, attempt_timeout=attempt_timeout)
    out: list[AttemptRecord] = []
    outcome = runner.run_cell(cell, attempts, split, out.append)
    return cell, out, outcome


def run_ray(cells: Sequence[Cell], config: RunConfig, emit: Callable, workers: int,
             agent_specs: Mapping[str, Any], done_cb: Callable[[Cell, CellOutcome], None],
             attempt_timeout: float | None = DEFAULT_ATTEMPT_TIMEOUT) -> None:
    try:
        import ray
    except ImportError:
        raise RuntimeError("--backend ray needs Ray: pip install 'phyplan[ray]' (or pip install ray)") from None
    started = False
    if not ray.is_initialized():
        address = os.environ.get("RAY_ADDRESS")
        # workers see the driver's import path, so "module:Class" agents load there as they do here
        env_vars = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),
                    "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
        kwargs: dict[str, Any] = dict(include_dashboard=False, log_to_driver=False,
                                      runtime_env={"env_vars": env_vars})
        if address:
            ray.init(address=address, **kwargs)
        else:
            ray.init(num_cpus=workers, **kwargs)
        started = True
    # a task whose worker process died (the agent ended it, Ray's memory monitor killed it) fails its cell
    died = tuple(getattr(ray.exceptions, name) for name in ("WorkerCrashedError", "OutOfMemoryError", "NodeDiedError")
                 if hasattr(ray.exceptions, name))
    try:
        remote = ray.remote(num_cpus=1, max_retries=RAY_MAX_RETRIES)(_ray_cell)
        specs = ray.put(dict(agent_specs))
        cell_of = {remote.remote(c, config.attempts, config.split, specs, attempt_timeout): c for c in cells}
        futures = list(cell_of)
        while futures:
            ready, futures = ray.wait(futures, num_returns=1)
            try:
                cell, recs, outcome = ray.get(ready[0])
            except died as exc:
                cell = cell_of[ready[0]]
                first = (str(exc).strip().splitlines() or [""])[0]
                recs = missing_attempts(cell, config.split, config.attempts, [], shorten(
                    f"crashed: the Ray worker running the cell died ({type(exc).__name__}: {first})", 300))
                outcome = CellOutcome(config.attempts)
            for rec in recs:
                emit(rec)
            done_cb(cell, outcome)
    finally:
        if started:
            ray.shutdown()
