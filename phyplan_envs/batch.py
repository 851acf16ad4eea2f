"""Batched simulation: many one-step episodes (context, action) at once, bit-identical to single envs.

:func:`simulate_batch` runs ``N`` episodes and returns what ``N`` single envs would, bit for bit::

    from phyplan_envs import simulate_batch
    res = simulate_batch("PhyPlan/Launch-v0", info["context"], actions)     # actions (N, 2)
    res.reward, res.final_pos, res.info, res.obs

Every episode is ``env.reset(options={"context": c}); env.step(a)`` on an env made by ``gym.make(env_id,
**env_kwargs)``: the batch path adds no physics of its own, so whatever a task's ``reset``/``step`` do (hidden
physics selected by the context, a robot mode) is exactly what the batch does. An episode's outcome depends only
on its (context, action), not on the episodes an env ran before (``reset`` restores the model and the data), so
the split of the batch over envs and processes cannot change a result (``tests/test_batch.py`` checks it).

Design: a pool of persistent worker processes, each holding the compiled envs it has used, gets contiguous chunks
of the batch (speed: ``python -m benchmarks.batch_speed``). ``mujoco.rollout`` (native threads over ``MjData``
copies) was measured and rejected (``python -m benchmarks.batch_speed --rollout``): a task places its tools by
editing the *model* (pendulum rig, bridge, wedge poses), so every episode needs its own ``MjModel`` copy, and a
copy of the model with the Panda's meshes costs tens of milliseconds, more than a whole episode (3-20 ms); a
rollout split into chunks (to check the end rule as it goes) is not bit-identical to the env's stepping, because
rollout returns no ``qacc_warmstart`` to continue from; and it would bypass a task's own ``step``.

Workers are fresh interpreters (subprocesses), never forks: a forked child of a process that has rendered with EGL
hangs at its first render, and multiprocessing pools cannot start inside the harness's (daemonic) pool workers.
``workers=1`` (or a batch of one) runs in the calling thread, on an env cached per thread. Pools persist between
calls (one per worker count) and are shut down at exit or by :func:`close_pools`.

Threads, signals, fork. :func:`simulate_batch` may be called from several threads at once and returns what serial
calls would, bit for bit. A pool runs one call at a time (its lock is held from the first job sent to the last
reply read), so calls with the same worker count take turns and calls with different counts run side by side;
the in-process path uses one env per thread. A call re-entered from the thread that is running one (from a signal
handler) raises ``RuntimeError``; a forked child never uses its parent's pools (it starts its own). Workers ignore
SIGINT and stay in the caller's process group: Ctrl-C, or ``kill -INT`` to the caller alone, raises
``KeyboardInterrupt`` in the caller's main thread, which kills and reaps the pool's workers at once (they may be
mid-job, or blocked writing a reply) before it propagates; any other failure inside a call does the same, and the
next call starts a new pool. Should the caller die without cleaning up, a worker exits at the end of its current
job, when its pipe closes. ``tests/test_batch_threads.py`` checks these.
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
from typing import Any, Mapping, NamedTuple, Sequence

import numpy as np


class BatchResult(NamedTuple):
    """The outcomes of a batch, one row per action, equal to those of single-env episodes.

    Attributes:
        reward: ``(N,)`` float64, the reward of each ``env.step``.
        final_pos: ``(N, 3)`` float64, ``info["final_pos"]`` of each episode.
        info: the ``N`` step ``info`` dicts.
        obs: the ``N`` observations returned by ``env.step``.
    """

    reward: np.ndarray
    final_pos: np.ndarray
    info: tuple
    obs: tuple


def default_workers() -> int:
    """The cores this process may run on (``os.sched_getaffinity``), else ``os.cpu_count()``."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


# ============================================================================================= one thread's envs
_LOCAL = threading.local()      # .envs: this thread's envs (an env is never stepped by two threads at once)


def _env_key(env_id: str, env_kwargs: Mapping[str, Any]) -> bytes:
    return pickle.dumps((env_id, sorted(env_kwargs.items())))


def cached_env(env_id: str, env_kwargs: Mapping[str, Any] | None = None):
    """This thread's env for ``(env_id, env_kwargs)``, made once per thread by ``gym.make`` and reused."""
    import gymnasium as gym

    envs = getattr(_LOCAL, "envs", None)
    if envs is None:
        envs = _LOCAL.envs = {}
    env_kwargs = dict(env_kwargs or {})
    key = _env_key(env_id, env_kwargs)
    env = envs.get(key)
    if env is None:
        env = envs[key] = gym.make(env_id, **env_kwargs)
    return env


def run_episodes(env, contexts: Sequence[Mapping[str, Any]], actions: np.ndarray) -> list[tuple]:
    """``(reward, info, obs)`` of ``env.reset(options={"context": c}); env.step(a)`` for each pair, in order."""
    out = []
    for context, action in zip(contexts, actions):
        env.reset(options={"context": context})
        obs, reward, _, _, info = env.step(action)
        out.append((float(reward), info, obs))
    return out


def _run_chunk(job: tuple) -> list[tuple]:
    env_id, env_kwargs, contexts, actions = job
    return run_episodes(cached_env(env_id, env_kwargs), contexts, actions)


# ==================================================================================================== the pools
# A worker is a fresh interpreter (``python -c``) that reads length-prefixed pickled jobs on stdin and writes the
# results on a private copy of its stdout (stray prints of a task go to stderr). It ignores SIGINT from its start.
_WORKER_CODE = ("import signal; signal.signal(signal.SIGINT, signal.SIG_IGN); "
                "from phyplan_envs.batch import _worker_main; _worker_main()")
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
    """The loop of one worker process: run each job ``(env_id, env_kwargs, contexts, actions)``, reply."""
    out = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)                       # prints of task code go to stderr, not into the protocol stream
    inp = sys.stdin.buffer
    while True:
        try:
            job = _recv(inp)
        except EOFError:
            return
        try:
            reply = ("ok", _run_chunk(job))
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


# ====================================================================================================== the API
def _normalise(env_id: Any, contexts: Any, actions: Any, workers: Any) -> tuple[list, np.ndarray, int]:
    import gymnasium as gym

    if not isinstance(env_id, str):
        raise ValueError(f"env_id must be a registered id string such as 'PhyPlan/Launch-v0', got {env_id!r}")
    if env_id not in gym.registry:
        known = ", ".join(k for k in gym.registry if k.startswith("PhyPlan/"))
        raise ValueError(f"env_id {env_id!r} is not registered (import phyplan_envs first); PhyPlan ids: {known}")
    try:
        acts = np.asarray(actions, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"actions must be a numeric (N, action_dim) array, got {actions!r}") from None
    if acts.ndim != 2:
        raise ValueError(f"actions must be a 2-D (N, action_dim) array, got shape {acts.shape}")
    n = len(acts)
    if isinstance(contexts, Mapping):
        ctx = [contexts] * n
    elif isinstance(contexts, Sequence) and all(isinstance(c, Mapping) for c in contexts):
        ctx = list(contexts)
        if len(ctx) != n:
            raise ValueError(f"contexts must be one context dict or a list of one per action: got {len(ctx)} "
                             f"contexts for {n} actions")
    else:
        raise ValueError("contexts must be one context dict (as info['context']) or a list of such dicts, got "
                         f"{type(contexts).__name__}")
    if workers is None:
        workers = default_workers()
    if not (isinstance(workers, (int, np.integer)) and not isinstance(workers, bool) and workers >= 1):
        raise ValueError(f"workers must be an integer >= 1 or None (the machine's cores), got {workers!r}")
    return ctx, acts, int(workers)


def _chunks(n: int, workers: int) -> list[tuple[int, int]]:
    """Contiguous index ranges: about 4 per worker, so that long episodes do not leave a worker idle."""
    k = min(n, 4 * workers)
    edges = np.linspace(0, n, k + 1).round().astype(int)
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:]) if b > a]


def _collect(rows: list[tuple]) -> BatchResult:
    reward = np.array([r[0] for r in rows], dtype=np.float64)
    final = np.array([np.asarray(r[1]["final_pos"], dtype=np.float64) for r in rows]).reshape(len(rows), 3)
    return BatchResult(reward=reward, final_pos=final, info=tuple(r[1] for r in rows), obs=tuple(r[2] for r in rows))


def simulate_batch(env_id: str, contexts, actions, workers: int | None = None, **env_kwargs: Any) -> BatchResult:
    """Simulate one episode per action; the same outcomes, bit for bit, as ``N`` single envs.

    Args:
        env_id: a registered id, e.g. ``"PhyPlan/Bridge-v1"``.
        contexts: one context dict (``info["context"]`` or ``env.context``) for every action, or a list of one per
            action.
        actions: ``(N, action_dim)`` actions in the env's units (validated by the env, as in ``env.step``).
        workers: processes to spread the batch over (default: the machine's cores, :func:`default_workers`);
            ``1`` runs in the calling thread. Several threads may call at once (see the module docstring).
        **env_kwargs: ``gym.make`` keywords of the env (``obs_mode``, ``clip_actions``, ...). The observations in
            the result follow ``obs_mode``; use the default ``"state"`` when only rewards are needed (an image
            observation renders every final frame).

    Returns:
        :class:`BatchResult` with ``reward`` (N,), ``final_pos`` (N, 3), ``info`` and ``obs`` (N each), in the order
        of ``actions``.
    """
    ctx, acts, workers = _normalise(env_id, contexts, actions, workers)
    n = len(acts)
    if n == 0:
        return BatchResult(np.zeros(0), np.zeros((0, 3)), (), ())
    workers = min(workers, n)
    if workers == 1:
        return _collect(run_episodes(cached_env(env_id, env_kwargs), ctx, acts))
    jobs = [(env_id, env_kwargs, ctx[a:b], acts[a:b]) for a, b in _chunks(n, workers)]
    while True:
        try:
            parts = worker_pool(workers).run(jobs)
            break
        except PoolClosed:              # shut down by another thread while this call waited for it: a new pool
            continue
    return _collect([row for part in parts for row in part])
