"""The persistent worker processes of :func:`phyplan_envs.batch.simulate_batch`: :class:`WorkerPool`, one per worker
count (:func:`worker_pool`), shut down by :func:`close_pools` and at exit.

A job is ``(function, argument)``: a module-level function (pickled by reference) and its picklable argument; a
worker replies ``function(argument)``. The pool knows nothing of envs: the batch sends its episode runner.

Workers are fresh interpreters (subprocesses), never forks: a forked child of a process that has rendered with EGL
hangs at its first render, and multiprocessing pools cannot start inside the harness's (daemonic) pool workers.
A worker reads length-prefixed pickled jobs on stdin and writes the replies on a private copy of its stdout (stray
prints go to stderr). Pools persist between calls (one per worker count).

Threads, signals, fork. A pool runs one call at a time (its lock is held from the first job sent to the last reply
read), so calls with the same worker count take turns and calls with different counts run side by side. A call
re-entered from the thread that is running one (from a signal handler) raises ``RuntimeError``; a forked child
never uses its parent's pools (it starts its own). Workers ignore SIGINT and stay in the caller's process group:
Ctrl-C, or ``kill -INT`` to the caller alone, raises ``KeyboardInterrupt`` in the caller's main thread, which kills
and reaps the pool's workers at once (they may be mid-job, or blocked writing a reply) before it propagates; any
other failure inside a call does the same, and the next call starts a new pool. Should the caller die without
cleaning up, a worker exits at the end of its current job, when its pipe closes. ``tests/test_batch_threads.py``
checks these.
"""
from __future__ import annotations

import atexit
import contextlib
import os
import pickle
import selectors
import struct
import subprocess
import sys
import threading
import time
import traceback
from pathlib import Path


# A worker is a fresh interpreter (``python -c``) that reads length-prefixed pickled jobs on stdin and writes the
# results on a private copy of its stdout (stray prints of a task go to stderr). It ignores SIGINT from its start.
_WORKER_CODE = ("import signal; signal.signal(signal.SIGINT, signal.SIG_IGN); "
                "from phyplan_envs.batch_pool import _worker_main; _worker_main()")
_LEN = struct.Struct("<Q")
_SIGNAL_POLL = 0.1        # s: the longest a pending KeyboardInterrupt waits while a call waits for replies
_CLOSE_TIMEOUT = 5.0      # seconds an idle worker gets to exit after its stdin closes, before it is killed


def _send(fh, obj) -> None:
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    fh.write(_LEN.pack(len(data)))
    fh.write(data)
    fh.flush()


def _recv(fh):
    head = fh.read(_LEN.size)
    if len(head) < _LEN.size:
        raise EOFError("stream closed")
    n = _LEN.unpack(head)[0]
    data = fh.read(n)
    if len(data) < n:
        raise EOFError("stream closed")
    return pickle.loads(data)


def _worker_main() -> None:
    """The loop of one worker process: run each job ``(function, argument)``, reply ``function(argument)``."""
    out = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)                       # prints of task code go to stderr, not into the protocol stream
    inp = sys.stdin.buffer
    while True:
        try:
            job = _recv(inp)
        except EOFError:
            return
        try:
            function, argument = job
            reply = ("ok", function(argument))
        except BaseException as exc:  # noqa: BLE001 - every failure goes back to the caller
            tb = traceback.format_exc()
            try:
                pickle.dumps(exc)
                reply = ("err", exc, tb)
            except Exception:  # noqa: BLE001 - an unpicklable exception
                reply = ("err", RuntimeError(f"{type(exc).__name__}: {exc}"), tb)
        _send(out, reply)


class _Worker:
    def __init__(self):
        env = dict(os.environ)
        root = str(Path(__file__).resolve().parent.parent)
        env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
        env.setdefault("OMP_NUM_THREADS", "1")
        self.proc = subprocess.Popen([sys.executable, "-c", _WORKER_CODE], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, env=env, cwd=root)

    def kill(self) -> None:
        """End the process now (it may be mid-job), reap it and close its pipes."""
        with contextlib.suppress(OSError):
            self.proc.kill()
        self.proc.wait()
        for fh in (self.proc.stdin, self.proc.stdout):
            with contextlib.suppress(OSError):  # a job half-written when the worker was killed
                fh.close()


class PoolClosed(RuntimeError):
    """:meth:`WorkerPool.run` on a pool that was shut down (by :func:`close_pools` or a failed call)."""


def _stop(workers: list[_Worker], graceful: bool) -> None:
    """Kill ``workers`` now, or (``graceful``: idle workers) close their stdin, let them exit, kill stragglers."""
    try:
        if graceful:
            for w in workers:
                with contextlib.suppress(OSError):
                    w.proc.stdin.close()
            deadline = time.monotonic() + _CLOSE_TIMEOUT
            for w in workers:
                with contextlib.suppress(subprocess.TimeoutExpired):
                    w.proc.wait(timeout=max(0.0, deadline - time.monotonic()))
    finally:
        for w in workers:
            w.kill()                            # a no-op on one that has exited, but for closing its pipes


class WorkerPool:
    """``workers`` persistent worker processes; :meth:`run` spreads jobs over them (one job per idle worker).

    One call at a time: :meth:`run` holds the pool's lock for the whole call (jobs out, every reply in), so calls
    from several threads take turns and each gets exactly its own replies. A call from the thread that is already
    inside :meth:`run` (a signal handler or callback during a batch) raises ``RuntimeError``. A call that fails or
    is interrupted kills the workers (they may be mid-job) and the pool is closed: :func:`worker_pool` starts a
    new one.
    """

    def __init__(self, workers: int):
        self._lock = threading.RLock()          # re-entrant, so that a re-entered call can see it is one
        self._owner: int | None = None          # the thread inside _run, if any
        self.workers: list[_Worker] = []
        try:
            for _ in range(int(workers)):
                self.workers.append(_Worker())
        except BaseException:
            _stop(self.workers, graceful=False)
            raise

    def run(self, jobs: list[tuple]) -> list:
        """The replies to ``jobs``, in order; raises :class:`PoolClosed` if the pool is shut down."""
        with self._lock:
            if self._owner is not None:         # only this thread can hold the lock: a call inside its own call
                raise RuntimeError("simulate_batch was called again from the thread that is running a batch on "
                                   "the same worker pool (from a signal handler or a callback inside the batch?); "
                                   "this is not supported: call it after the running batch returns")
            if not self.workers:
                raise PoolClosed("this simulate_batch worker pool is shut down")
            self._owner = threading.get_ident()
            try:
                return self._run(jobs)
            finally:
                self._owner = None

    def _run(self, jobs: list[tuple]) -> list:
        results: list = [None] * len(jobs)
        pending = list(range(len(jobs)))[::-1]
        busy: dict[int, int] = {}               # worker index -> job index
        sel = selectors.DefaultSelector()
        try:
            for w, worker in enumerate(self.workers):
                sel.register(worker.proc.stdout, selectors.EVENT_READ, w)
                if pending:
                    busy[w] = pending.pop()
                    _send(worker.proc.stdin, jobs[busy[w]])
            while busy:
                # A timeout, so that a SIGINT delivered to another thread of this process (which leaves this select
                # blocked) is still handled within _SIGNAL_POLL s, not only when the next reply arrives.
                for key, _ in sel.select(timeout=_SIGNAL_POLL):
                    w = key.data
                    try:
                        reply = _recv(self.workers[w].proc.stdout)
                    except EOFError:
                        raise RuntimeError(f"simulate_batch worker {w} (pid {self.workers[w].proc.pid}) died; see "
                                           f"its stderr above") from None
                    if reply[0] == "err":
                        raise reply[1] from RuntimeError("in a simulate_batch worker:\n" + reply[2])
                    results[busy.pop(w)] = reply[1]
                    if pending:
                        busy[w] = pending.pop()
                        _send(self.workers[w].proc.stdin, jobs[busy[w]])
        except BaseException:                   # an error, a dead worker, KeyboardInterrupt: workers may be mid-job
            workers, self.workers = self.workers, []
            _stop(workers, graceful=False)
            raise
        finally:
            sel.close()
        return results

    @property
    def alive(self) -> bool:
        return bool(self.workers) and all(w.proc.poll() is None for w in self.workers)

    def close(self, wait: bool = True) -> None:
        """Shut the workers down once the call running on the pool (if any) returns; ``wait=False``: if a call is
        running, kill the workers now (that call then fails on a dead worker)."""
        if self._lock.acquire(blocking=wait):
            try:
                workers, self.workers = self.workers, []
            finally:
                self._lock.release()
            _stop(workers, graceful=True)
        else:
            _stop(list(self.workers), graceful=False)


_POOLS: dict[int, WorkerPool] = {}
_POOLS_LOCK = threading.RLock()


def worker_pool(workers: int) -> WorkerPool:
    """The shared pool of ``workers`` processes of this process (started on first use, restarted if broken)."""
    with _POOLS_LOCK:
        pool = _POOLS.get(workers)
        if pool is None or not pool.alive:
            if pool is not None:
                pool.close(wait=False)          # a worker died: end the others too
            pool = _POOLS[workers] = WorkerPool(workers)
        return pool


def close_pools(wait: bool = True) -> None:
    """Shut down the worker processes of :func:`simulate_batch` (they are started again when next needed); a
    batch running in another thread finishes first (``wait=False``, as at exit: it is killed)."""
    with _POOLS_LOCK:
        pools = list(_POOLS.values())
        _POOLS.clear()
    for pool in pools:
        pool.close(wait)


def _forget_pools_after_fork() -> None:
    """In a forked child: the inherited pools talk to the parent's workers, so the child starts its own."""
    global _POOLS_LOCK
    _POOLS.clear()
    _POOLS_LOCK = threading.RLock()


atexit.register(close_pools, False)
if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pools_after_fork)
