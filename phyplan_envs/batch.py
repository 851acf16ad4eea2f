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

Design: a pool of persistent worker processes (:mod:`phyplan_envs.batch_pool`), each holding the compiled envs it has
used, gets contiguous chunks of the batch (speed: ``python -m benchmarks.batch_speed``). ``mujoco.rollout`` (native
threads over ``MjData`` copies) was measured and rejected (``python -m benchmarks.batch_speed --rollout``): a task
places its tools by editing the *model* (pendulum rig, bridge, wedge poses), so every episode needs its own ``MjModel``
copy, and a copy of the model with the Panda's meshes costs tens of milliseconds, more than a whole episode (3-20 ms); a
rollout split into chunks (to check the end rule as it goes) is not bit-identical to the env's stepping, because rollout
returns no ``qacc_warmstart`` to continue from; and it would bypass a task's own ``step``.

Workers are fresh interpreters, never forks (:mod:`phyplan_envs.batch_pool`). ``workers=1`` (or a batch of one) runs
in the calling thread, on an env cached per thread (:func:`cached_env`). Pools persist between calls (one per worker
count) and are shut down at exit or by :func:`close_pools`.

Threads, signals, fork. :func:`simulate_batch` may be called from several threads at once and returns what serial
calls would, bit for bit: a pool runs one call at a time and the in-process path uses one env per thread. A call
re-entered from the thread that is running one (from a signal handler) raises ``RuntimeError``; Ctrl-C during a call
kills its pool's workers before ``KeyboardInterrupt`` propagates (the details: :mod:`phyplan_envs.batch_pool`).

Public names: :func:`simulate_batch`, :class:`BatchResult`, :func:`default_workers`, :func:`cached_env`,
:func:`run_episodes`; the pool's :func:`worker_pool`, :func:`close_pools`, :class:`WorkerPool` and
:class:`PoolClosed` are re-exported from :mod:`phyplan_envs.batch_pool`.
"""
from __future__ import annotations

import os
import pickle
import threading
from typing import Any, Mapping, NamedTuple, Sequence

import numpy as np

from .batch_pool import PoolClosed, WorkerPool, close_pools, worker_pool  # noqa: F401  (WorkerPool re-exported)


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
    jobs = [(_run_chunk, (env_id, env_kwargs, ctx[a:b], acts[a:b])) for a, b in _chunks(n, workers)]
    while True:
        try:
            parts = worker_pool(workers).run(jobs)
            break
        except PoolClosed:              # shut down by another thread while this call waited for it: a new pool
            continue
    return _collect([row for part in parts for row in part])
