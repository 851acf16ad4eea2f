"""Where the cells run: in this process, in a local process pool, or as Ray tasks.

Every backend runs each cell with :meth:`Runner.run_cell <benchmarks.harness.runner.Runner.run_cell>` and hands each
record to ``emit`` (the single writer in the main process) and each cell's :class:`CellOutcome` to ``done``. Cells
are independent (see :func:`benchmarks.harness.runner.cell_seed`), so all backends give the same records.
"""
from __future__ import annotations

import os
import sys
import time
from typing import Any, Callable, Mapping, Sequence

from .guard import DEFAULT_ATTEMPT_TIMEOUT, install_interrupt_handler
from .records import AttemptRecord, Cell, CellOutcome, RunConfig
from .runner import Runner


def run_serial(cells: Sequence[Cell], config: RunConfig, emit: Callable, agent_specs: Mapping[str, Any],
                done: Callable[[Cell, CellOutcome], None],
                attempt_timeout: float | None = DEFAULT_ATTEMPT_TIMEOUT) -> None:
    runner = Runner(agent_specs, attempt_timeout=attempt_timeout)
    try:
        for cell in cells:
            done(cell, runner.run_cell(cell, config.attempts, config.split, emit))
    finally:
        runner.close()


# process pool: each worker keeps its own Runner and streams records through a queue to the single writer
_WORKER: dict[str, Any] = {}


def _init_worker(queue: Any, agent_specs: Mapping[str, Any], attempt_timeout: float | None) -> None:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    os.environ.setdefault("MKL_NUM_THREADS", "1")
    install_interrupt_handler()     # a Ctrl-C reaches the workers too: it stops them, it is not an agent's error
    _WORKER["queue"] = queue
    _WORKER["runner"] = Runner(agent_specs, attempt_timeout=attempt_timeout)
    _exit_with_parent()


def _exit_with_parent(poll: float = 0.5) -> None:
    """End this worker when the main process dies (e.g. ``kill -9``), instead of lingering as an orphan."""
    import threading

    parent = os.getppid()

    def watch() -> None:
        while True:
            time.sleep(poll)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


def _worker_cell(cell: Cell, attempts: int, split: str) -> CellOutcome:
    return _WORKER["runner"].run_cell(cell, attempts, split, _WORKER["queue"].put)


def run_processes(cells: Sequence[Cell], config: RunConfig, emit: Callable, workers: int,
                   agent_specs: Mapping[str, Any], done_cb: Callable[[Cell, CellOutcome], None],
                   attempt_timeout: float | None = DEFAULT_ATTEMPT_TIMEOUT) -> None:
    import multiprocessing as mp
    import queue as queue_mod
    from concurrent.futures import ProcessPoolExecutor

    ctx = mp.get_context("spawn")  # fresh interpreters: MuJoCo/EGL and torch state do not survive fork well
    q = ctx.Queue()
    expected = 0
    received = 0
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_init_worker,
                             initargs=(q, dict(agent_specs), attempt_timeout)) as pool:
        futures = {pool.submit(_worker_cell, c, config.attempts, config.split): c for c in cells}
        pending = set(futures)
        try:
            while pending or received < expected:
                try:
                    rec = q.get(timeout=0.1)
                except queue_mod.Empty:
                    pass
                else:
                    emit(rec)
                    received += 1
                    continue
                done = [f for f in pending if f.done()]
                for f in done:
                    pending.discard(f)
                    exc = f.exception()
                    if exc is not None:
                        raise RuntimeError(f"a worker process failed ({type(exc).__name__}: {exc}); the cells "
                                           f"finished so far are saved: rerun the same command to resume") from exc
                    outcome = f.result()
                    expected += outcome.records
                    done_cb(futures[f], outcome)
        except BaseException:
            for f in pending:
                f.cancel()
            # keep whatever already arrived
            while True:
                try:
                    emit(q.get_nowait())
                except (queue_mod.Empty, OSError, EOFError):
                    break
            raise


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
    try:
        remote = ray.remote(num_cpus=1)(_ray_cell)
        specs = ray.put(dict(agent_specs))
        futures = [remote.remote(c, config.attempts, config.split, specs, attempt_timeout) for c in cells]
        while futures:
            ready, futures = ray.wait(futures, num_returns=1)
            cell, recs, outcome = ray.get(ready[0])
            for rec in recs:
                emit(rec)
            done_cb(cell, outcome)
    finally:
        if started:
            ray.shutdown()
