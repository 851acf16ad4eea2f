"""Agents in worker processes, watched by the main process: an agent that ends its process fails its cell, not the run.

:func:`run_isolated` runs the cells in ``workers`` spawned processes (one for a serial run). Each worker runs cells
with its own :class:`~benchmarks.harness.runner.Runner` and sends every record through a pipe as it is made. The main
process runs no agent code: it hands out the cells, writes the records, and watches the workers.

* A worker that dies during a cell (``os._exit``, a signal such as SIGSEGV, the kernel's OOM killer) fails that cell:
  the attempt in flight is recorded as ``crashed: exit code 7 during act()`` or ``crashed: signal 11 (SIGSEGV) during
  act()``, the cell's later attempts as not run (as after a timeout), and a fresh worker takes the next cell. A death
  in ``make``/``setup`` makes the set-up unavailable for this run, as a ``setup`` that raises does. A death before
  the cell began (closing an evicted set-up, or between cells) reruns the cell once on a fresh worker.
* ``memory_limit`` (MB): a worker whose resident memory exceeds it is killed (SIGKILL) and its cell fails with
  ``crashed: out of memory: ...``. The check runs every :data:`MEMORY_POLL` s, so it is a budget, not a hard cap: a
  fast allocation can overshoot it by what it allocates in that time.
* A call past ``attempt_timeout`` that neither the worker's alarm nor its watchdog stops (C code that holds the
  interpreter) is killed from here ``2 * grace`` s after the limit; its attempt fails with the timeout.

Workers ignore SIGINT (a Ctrl-C stops the main process, which then ends them), end themselves when the main process
dies, and raise their ``oom_score_adj`` so that the kernel's OOM killer picks a worker before the main process.
"""
from __future__ import annotations

import os
import pickle
import signal
import threading
import time
import traceback
from collections import deque
from typing import Any, Callable, Mapping, Sequence

from .guard import DEFAULT_ATTEMPT_TIMEOUT, Guard
from .inflight import InFlight
from .records import AttemptRecord, Cell, CellOutcome, RunConfig, missing_attempts
from .runner import PHASES, SETUP_PHASES, Runner

MEMORY_POLL = 0.05
"""Seconds between two checks of the workers' resident memory (with a memory limit)."""
_PHASE_INDEX = {name: i for i, name in enumerate(PHASES)}
_AGENT_CALLS = frozenset({"begin_context", "act", "observe"})
_BEFORE_CELL = frozenset({"idle", "close"})
_WHERE = {"env": "the env's reset/step", "close": "the closing of an earlier set-up", "make": "making the agent",
          "make env": "making the env", "idle": "the harness's code between cells"}


# ================================================================================================= the worker
def _worker_main(conn: Any, shared: Any, agent_specs: Mapping[str, Any], attempt_timeout: float | None) -> None:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    os.environ.setdefault("MKL_NUM_THREADS", "1")
    signal.signal(signal.SIGINT, signal.SIG_IGN)     # a Ctrl-C is the main process's; it ends the workers
    try:
        with open("/proc/self/oom_score_adj", "w") as f:
            f.write("500")                              # the OOM killer takes a worker, not the main process
    except OSError:
        pass
    exit_with_parent()

    def on_phase(name: str) -> None:
        shared[1] = time.monotonic()
        shared[0] = _PHASE_INDEX[name]

    runner = Runner(agent_specs, attempt_timeout=attempt_timeout, on_phase=on_phase)
    runner.stuck_note = "so its worker process was ended (the run went on)"

    def emit(rec: AttemptRecord) -> None:
        conn.send(("record", rec))

    try:
        conn.send(("ready", os.getpid()))
        while True:
            job = conn.recv()
            if job is None:
                break
            try:
                outcome = runner.run_cell(*job, emit)
            except Exception as exc:  # a bug of the harness, not an agent's failure: the run stops
                conn.send(("error", f"{type(exc).__name__}: {exc}", traceback.format_exc(limit=6)))
                break
            on_phase("idle")
            conn.send(("done", outcome))
    except (EOFError, OSError):      # the main process is gone
        pass
    finally:
        runner.close()


def exit_with_parent(poll: float = 0.5) -> None:
    """End this worker when the main process dies (e.g. ``kill -9``), instead of lingering as an orphan."""
    parent = os.getppid()

    def watch() -> None:
        while True:
            time.sleep(poll)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


# ================================================================================================ the watcher
def describe_exit(code: int) -> str:
    """``exit code 7``, ``signal 11 (SIGSEGV)``, ``signal 9 (SIGKILL: ...)`` from a ``Process.exitcode``."""
    if code >= 0:
        return f"exit code {code}"
    try:
        name = signal.Signals(-code).name
    except ValueError:
        name = "unknown signal"
    if -code == signal.SIGKILL:
        name += ": killed from outside, e.g. by the kernel's OOM killer"
    return f"signal {-code} ({name})"


def _rss(pid: int) -> int | None:
    """Resident memory of a process in bytes (Linux ``/proc``), None if it cannot be read."""
    try:
        with open(f"/proc/{pid}/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return None


class _Worker:
    """One worker process, its pipe, and the cell it runs."""

    def __init__(self, ctx: Any, args: tuple):
        self.conn, child = ctx.Pipe()
        self.shared = ctx.RawArray("d", 2)             # [phase index, time.monotonic() when it began]
        self.proc = ctx.Process(target=_worker_main, args=(child, self.shared, *args), name="phyplan-bench-worker")
        self.proc.start()
        child.close()
        self.ready = False
        self.cell: Cell | None = None
        self.received: list[AttemptRecord] = []
        self.killed: str | None = None                  # why the watcher killed it
        self.killed_by_timeout = False

    def start(self, cell: Cell, attempts: int, split: str) -> None:
        self.cell, self.received = cell, []
        try:
            self.conn.send((cell, attempts, split))
        except OSError:                  # it just died: the watcher sees it
            pass

    def phase(self) -> tuple[str, float]:
        return PHASES[int(self.shared[0])], float(self.shared[1])

    def kill(self, reason: str, timeout: bool = False) -> None:
        if self.killed is None:
            self.killed, self.killed_by_timeout = reason, timeout
            try:
                self.proc.kill()
            except OSError:
                pass


class _Pool:
    def __init__(self, config: RunConfig, emit: Callable, workers: int, agent_specs: Mapping[str, Any],
                 done_cb: Callable[[Cell, CellOutcome], None], attempt_timeout: float | None,
                 memory_limit: float | None, inflight: InFlight | None):
        import multiprocessing as mp

        self.ctx = mp.get_context("spawn")  # fresh interpreters: MuJoCo/EGL and torch state do not survive fork well
        self.config, self.emit, self.size, self.done_cb, self.inflight = config, emit, workers, done_cb, inflight
        self.args = (dict(agent_specs), attempt_timeout)
        self.timeout = attempt_timeout or None
        self.grace = Guard(attempt_timeout).grace
        self.memory_limit = memory_limit
        self.workers: list[_Worker] = []
        self.queue: deque[Cell] = deque()
        self.setup_crashed: dict[tuple[str, str, int], str] = {}
        self.retried: set[Cell] = set()

    def run(self, cells: Sequence[Cell]) -> None:
        from multiprocessing.connection import wait

        self.queue.extend(cells)
        poll = MEMORY_POLL if self.memory_limit else (1.0 if self.timeout else None)
        while self.queue or any(w.cell is not None for w in self.workers):
            self._dispatch()
            if not self.workers:          # every queued cell was settled without a worker
                continue
            wait([w.conn for w in self.workers] + [w.proc.sentinel for w in self.workers], timeout=poll)
            for w in list(self.workers):
                self._drain(w)
                if w.proc.exitcode is not None:
                    self._drain(w)
                    self.workers.remove(w)
                    w.conn.close()
                    self._died(w, w.proc.exitcode)
            self._watch()

    def _dispatch(self) -> None:
        config, inflight = self.config, self.inflight
        while self.queue:
            busy = [w.cell for w in self.workers if w.cell is not None]
            cell = self.queue[0]
            if inflight is not None and busy and (inflight.is_suspect(cell) or any(map(inflight.is_suspect, busy))):
                return                    # a suspect runs alone (inflight.py)
            reason = self.setup_crashed.get((cell.task, cell.agent, cell.seed))
            if reason is not None:
                self.queue.popleft()
                self.done_cb(cell, CellOutcome(0, reason))
                continue
            free = next((w for w in self.workers if w.cell is None and w.killed is None), None)
            if free is None:
                if len(self.workers) >= self.size:
                    return
                free = _Worker(self.ctx, self.args)
                self.workers.append(free)
            self.queue.popleft()
            if inflight is not None:
                inflight.start(cell)
            free.start(cell, config.attempts, config.split)

    def _drain(self, w: _Worker) -> None:
        while True:
            try:
                if not w.conn.poll():
                    return
                msg = w.conn.recv()
            except (EOFError, OSError):
                return
            if msg[0] == "record":
                w.received.append(msg[1])
                self.emit(msg[1])
            elif msg[0] == "done":
                cell, w.cell, w.received = w.cell, None, []
                self._finish(cell, msg[1])
            elif msg[0] == "ready":
                w.ready = True
            else:
                raise RuntimeError(f"a worker process failed ({msg[1]}); the cells finished so far are saved: "
                                   f"rerun the same command to resume\n{msg[2]}")

    def _finish(self, cell: Cell, outcome: CellOutcome) -> None:
        if self.inflight is not None:
            self.inflight.finish(cell)
        self.done_cb(cell, outcome)

    def _died(self, w: _Worker, code: int) -> None:
        if not w.ready:
            raise RuntimeError(f"a worker process ended before it could start ({w.killed or describe_exit(code)}; "
                               f"its error, if any, is above). A spawned worker imports the main script again: a "
                               f"script read from stdin cannot be, pass isolate=False there. The cells finished so "
                               f"far are saved")
        cell = w.cell
        if cell is None:                  # between cells: nothing to blame
            return
        attempts = self.config.attempts
        phase, _ = w.phase()
        status = w.killed or describe_exit(code)
        if len(w.received) >= attempts:   # every attempt is recorded (the watchdog's backstop, or a late death)
            self._finish(cell, CellOutcome(len(w.received)))
        elif phase in _BEFORE_CELL and not w.received and cell not in self.retried:
            self.retried.add(cell)        # the cell had not begun: run it again, once, on a fresh worker
            self.queue.appendleft(cell)
        elif phase in SETUP_PHASES:
            reason = f"{phase}: crashed: {status}"
            self.setup_crashed[(cell.task, cell.agent, cell.seed)] = reason
            self._finish(cell, CellOutcome(0, reason))
        else:
            reason = status if w.killed_by_timeout else f"crashed: {status} during {_WHERE.get(phase, phase + '()')}"
            for rec in missing_attempts(cell, self.config.split, attempts, w.received, reason):
                self.emit(rec)
            self._finish(cell, CellOutcome(attempts))

    def _watch(self) -> None:
        now = time.monotonic()
        for w in self.workers:
            if w.killed is not None or w.proc.exitcode is not None:
                continue
            if self.memory_limit:
                rss = _rss(w.proc.pid)
                if rss is not None and rss > self.memory_limit * 2**20:
                    w.kill(f"out of memory: resident memory above --memory-limit {self.memory_limit:g} MB, "
                           f"killed (SIGKILL)")
                    continue
            phase, since = w.phase()
            if self.timeout and w.cell is not None and phase in _AGENT_CALLS \
                    and now - since > self.timeout + 2 * self.grace:
                w.kill(Guard(self.timeout).describe_timeout(phase) + "; the agent did not stop (stuck outside "
                       "Python, holding the interpreter), so its worker process was killed", timeout=True)

    def close(self, interrupted: bool) -> None:
        for w in self.workers:
            if interrupted:
                try:
                    self._drain(w)        # keep whatever already arrived
                except RuntimeError:
                    pass
            if w.cell is not None:
                w.proc.kill()
            else:
                try:
                    w.conn.send(None)
                except OSError:
                    pass
        deadline = time.monotonic() + 10
        for w in self.workers:
            w.proc.join(max(0.1, deadline - time.monotonic()))
            if w.proc.exitcode is None:
                w.proc.kill()
                w.proc.join(5)
            w.conn.close()
        self.workers.clear()


def run_isolated(cells: Sequence[Cell], config: RunConfig, emit: Callable, workers: int,
                 agent_specs: Mapping[str, Any], done_cb: Callable[[Cell, CellOutcome], None],
                 attempt_timeout: float | None = DEFAULT_ATTEMPT_TIMEOUT, memory_limit: float | None = None,
                 inflight: InFlight | None = None) -> None:
    """Run ``cells`` in ``workers`` watched worker processes (see the module docstring); records go to ``emit``, each
    cell's outcome to ``done_cb``."""
    try:
        pickle.dumps(dict(agent_specs))
    except Exception as exc:
        raise ValueError(f"agent_specs must be picklable to run the agents in worker processes ({exc}); pass "
                         f"isolate=False to run them in this process") from None
    if not cells:
        return
    pool = _Pool(config, emit, workers, agent_specs, done_cb, attempt_timeout, memory_limit, inflight)
    interrupted = True
    try:
        pool.run(cells)
        interrupted = False
    finally:
        pool.close(interrupted)
