"""The cell runner: the one loop that runs an agent over a context's attempts (see :mod:`benchmarks.harness`).

A :class:`Runner` keeps a few (task, agent, run seed) set-ups alive in one process and runs cells on them; every
backend, :func:`benchmarks.harness.run` and :func:`benchmarks.harness.evaluate` go through :meth:`Runner.run_cell`.
"""
from __future__ import annotations

import math
import random
import sys
import time
import traceback
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from .guard import DEFAULT_ATTEMPT_TIMEOUT, AttemptTimeout, Guard
from .records import ACTION_TOL, AttemptRecord, Cell, CellOutcome, jsonable, shorten

SLOT_CACHE = 4
"""(task, agent, seed) set-ups kept alive per process."""
PHASES: tuple[str, ...] = ("idle", "close", "make", "make env", "setup", "reseed", "env", "training_stats", "stats",
                           "begin_context", "act", "observe")
"""What a runner reports to ``on_phase``: the agent calls by name, ``env`` (the env's reset/step), ``close`` (an
evicted set-up being closed), ``idle`` (between cells)."""
SETUP_PHASES = frozenset({"make", "make env", "setup"})


# ================================================================================================ seeding
def cell_seed(seed: int, context: int) -> int:
    """The seed of a cell's randomness, derived from (run seed, context id) only (a 32-bit integer)."""
    return int(np.random.SeedSequence([int(seed), int(context)]).generate_state(1)[0])


def reseed_agent(agent: Any, seed: int) -> None:
    """Reseed an agent and the global generators before a cell (see the module docstring)."""
    random.seed(seed)
    np.random.seed(seed % 2**32)
    if "torch" in sys.modules:
        sys.modules["torch"].manual_seed(seed)
    reseed = getattr(agent, "reseed", None)
    if callable(reseed):
        reseed(seed)
    else:
        agent.rng = np.random.default_rng(seed)


# ============================================================================================= validation
def validate_action(action: Any, low: np.ndarray, high: np.ndarray,
                    names: Sequence[str]) -> tuple[np.ndarray | None, str | None]:
    """Check an agent's action: ``(float64 vector clipped within ACTION_TOL, None)`` or ``(None, reason)``."""
    from phyplan_envs.spaces import as_real

    a = as_real(action)        # strings, bools and complex numbers are refused, not cast
    if a is None:
        return None, f"action is not numeric: {shorten(repr(action))}"
    n = len(low)
    if a.shape == (1, n):
        a = a[0]
    if a.shape != (n,):
        return None, f"action has shape {a.shape}, expected ({n},) for {tuple(names)}: {shorten(repr(action))}"
    if not np.all(np.isfinite(a)):
        bad = [names[i] for i in np.flatnonzero(~np.isfinite(a))]
        return None, f"action has non-finite values in {bad}: {a.tolist()}"
    out = (a < low - ACTION_TOL) | (a > high + ACTION_TOL)
    if np.any(out):
        parts = [f"{names[i]}={a[i]:.6g} not in [{low[i]:.6g}, {high[i]:.6g}]" for i in np.flatnonzero(out)]
        return None, "action out of bounds: " + "; ".join(parts)
    return np.clip(a, low, high), None


def _describe(phase: str, exc: BaseException) -> str:
    where = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ else None
    loc = f" (at {Path(where.filename).name}:{where.lineno})" if where else ""
    return shorten(f"{phase}: {type(exc).__name__}: {exc}{loc}")


def _stats(agent: Any) -> dict[str, float]:
    fn = getattr(agent, "stats", None)
    if not callable(fn):
        return {}
    try:
        raw = fn() or {}
    except BaseException as exc:  # noqa: BLE001 - an agent whose stats() fails still gets benchmarked
        Guard.keep(exc)
        return {}
    out = {}
    for k, v in dict(raw).items():
        if isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) and math.isfinite(float(v)):
            out[str(k)] = float(v)
    return out


def _diff(after: Mapping[str, float], before: Mapping[str, float]) -> dict[str, float]:
    keys = set(after) | set(before)
    return {k: after.get(k, 0.0) - before.get(k, 0.0) for k in sorted(keys)}


# ================================================================================================ the runner
def is_agent_object(spec: Any) -> bool:
    """``spec`` is an agent itself (not a name, class or factory): it has the protocol's ``act`` method."""
    return not isinstance(spec, (str, type)) and callable(getattr(spec, "act", None))


def make_agent(spec: Any) -> Any:
    """An agent from a spec of :class:`Runner` (name or ``"module:Class"``, class or factory, or the agent)."""
    import phyplan_agents

    if isinstance(spec, str):
        return phyplan_agents.make(spec)
    if is_agent_object(spec):
        return spec
    if not callable(spec):
        raise TypeError(f"agent spec must be a name, 'module:Class', a class, a factory or an agent, got {spec!r}")
    return spec()


@dataclass
class _Slot:
    """One (task, agent, run seed) set-up: the agent after ``setup`` and its envs."""

    agent: Any
    env: Any
    sim_env: Any
    task_info: Any
    error: str | None
    owned: bool = True


class Runner:
    """Runs cells in one process, keeping the last few (task, agent, seed) set-ups alive between cells.

    Args:
        agent_specs: agent name -> how to make it: a registered name or ``"module:Class"`` string, a class or
            zero-argument factory (called once per set-up), or an agent object (set up again for every run seed).
            Names without an entry are made with ``phyplan_agents.make(name)``.
        env_kwargs: extra ``gym.make`` keywords for both the agent's env and the simulator's env (e.g.
            ``{"with_panda": False}`` in tests); the agent's own ``env_kwargs`` win on a clash.
        attempt_timeout: seconds each agent call of a cell (``begin_context``, ``act``, ``observe``) may take
            (:mod:`benchmarks.harness.guard`); ``None`` or 0: no limit. A call past it fails its attempt with the
            reason, the cell's later attempts are recorded as not run, and the agent's set-up is made afresh for
            the next cell.
        on_phase: called with the name of what the runner is about to do (:data:`PHASES`), so that a supervising
            process can say where a worker died (:mod:`benchmarks.harness.supervise`); None: not reported.
    """

    stuck_note = "so the run ended here: rerun the same command to resume"
    """How the records of a call that ignored the time limit end (a worker process says what happens to it)."""

    def __init__(self, agent_specs: Mapping[str, Any] | None = None, env_kwargs: Mapping[str, Any] | None = None,
                 attempt_timeout: float | None = DEFAULT_ATTEMPT_TIMEOUT,
                 on_phase: Callable[[str], None] | None = None):
        self._slots: OrderedDict[tuple[str, str, int], _Slot] = OrderedDict()
        self._agent_specs = dict(agent_specs or {})
        self._env_kwargs = dict(env_kwargs or {})
        self.attempt_timeout = attempt_timeout
        self.on_phase = on_phase
        Guard(attempt_timeout)      # checks the value

    def _phase(self, name: str) -> None:
        if self.on_phase is not None:
            self.on_phase(name)

    def _stats(self, agent: Any) -> dict[str, float]:
        self._phase("stats")
        return _stats(agent)

    def close(self) -> None:
        for slot in self._slots.values():
            _close_slot(slot)
        self._slots.clear()

    def _slot(self, task: str, agent_name: str, seed: int) -> _Slot:
        key = (task, agent_name, seed)
        if key in self._slots:
            self._slots.move_to_end(key)
            return self._slots[key]
        while len(self._slots) >= SLOT_CACHE:
            self._phase("close")
            _close_slot(self._slots.popitem(last=False)[1])
        self._slots[key] = slot = self._make_slot(task, agent_name, seed)
        return slot

    def _make_slot(self, task: str, agent_name: str, seed: int) -> _Slot:
        import gymnasium as gym

        import phyplan_agents
        import phyplan_envs

        spec = self._agent_specs.get(agent_name, agent_name)
        self._phase("make")
        try:
            agent = make_agent(spec)
        except BaseException as exc:  # noqa: BLE001 - agents' failures are data, a user's Ctrl-C is not
            Guard.keep(exc)
            return _Slot(None, None, None, None, _describe("make", exc))
        owned = agent is not spec
        self._phase("make env")
        try:
            env_kwargs = {**self._env_kwargs, **dict(getattr(agent, "env_kwargs", None) or {})}
            env_kwargs.setdefault("obs_mode", getattr(agent, "obs_mode", "state"))
            env = gym.make(phyplan_envs.env_id(task), **env_kwargs)
            sim_env = None
            if getattr(agent, "needs_simulator", False):
                sim_env = gym.make(phyplan_envs.env_id(task), **{**self._env_kwargs, "obs_mode": "state"})
            info = phyplan_agents.TaskInfo.from_env(env)
        except BaseException as exc:  # noqa: BLE001 - agents' failures are data, a user's Ctrl-C is not
            Guard.keep(exc)
            return _Slot(agent, None, None, None, _describe("make env", exc), owned)
        _single_thread()
        self._phase("setup")
        try:
            agent.setup(info, seed)
        except BaseException as exc:  # noqa: BLE001 - agents' failures are data, a user's Ctrl-C is not
            Guard.keep(exc)
            return _Slot(agent, env, sim_env, info, _describe("setup", exc), owned)
        _single_thread()
        return _Slot(agent, env, sim_env, info, None, owned)

    def run_cell(self, cell: Cell, attempts: int, split: str, emit: Callable[[AttemptRecord], None]) -> CellOutcome:
        """Run one cell: ``attempts`` attempts of ``cell.agent`` at context ``cell.context``; ``emit`` each record.

        Returns ``CellOutcome(attempts)``, or ``CellOutcome(0, reason)`` without emitting anything if the agent could
        not be made or set up.
        """
        from phyplan_agents import Simulator

        slot = self._slot(cell.task, cell.agent, cell.seed)
        base = dict(task=cell.task, agent=cell.agent, seed=cell.seed, context=cell.context, split=split)
        best: float | None = None
        solved = False
        emitted: set[int] = set()

        def record(k: int, **kw: Any) -> AttemptRecord:
            rec = AttemptRecord(**base, attempt=k, best=best,
                                regret=1.0 if best is None else max(0.0, 1.0 - best), solved=solved, **kw)
            emitted.add(k)
            emit(rec)
            return rec

        def not_run(k: int, reason: str) -> None:
            record(k, action=None, reward=None, success=False, distance=None, begin_time=0.0, act_time=0.0,
                   step_time=0.0, observe_time=0.0, sim_calls=0, skill_evals=0.0, agent_stats={}, training={},
                   error=reason)

        def on_stuck(phase: str) -> None:
            """The backstop (guard.py): the agent ignored the time limit; record the cell before the process ends."""
            for k in range(1, attempts + 1):
                if k not in emitted:
                    not_run(k, guard.describe_timeout(phase) + "; the agent did not stop (stuck outside Python), "
                            + self.stuck_note)

        guard = Guard(self.attempt_timeout, on_stuck=on_stuck)
        timed_out: str | None = None

        def failed_all(reason: str, training: dict | None = None) -> CellOutcome:
            for k in range(1, attempts + 1):
                record(k, action=None, reward=None, success=False, distance=None, begin_time=0.0, act_time=0.0,
                       step_time=0.0, observe_time=0.0, sim_calls=0, skill_evals=0.0, agent_stats={},
                       training=training or {}, error=reason)
            return CellOutcome(attempts)

        if slot.error is not None:  # the agent could not be made or set up: nothing to record
            return CellOutcome(0, slot.error)
        agent, env, info_t = slot.agent, slot.env, slot.task_info
        low, high, names = info_t.action_low, info_t.action_high, info_t.action_names

        self._phase("reseed")
        try:
            reseed_agent(agent, cell_seed(cell.seed, cell.context))
        except BaseException as exc:  # noqa: BLE001 - agents' failures are data, a user's Ctrl-C is not
            Guard.keep(exc)
            return failed_all(_describe("reseed", exc))
        self._phase("env")
        obs, info = env.reset(seed=int(cell.context))
        ctx = info["context"]
        simulator = Simulator(slot.sim_env, ctx) if slot.sim_env is not None else None
        self._phase("training_stats")
        try:
            training = jsonable(agent.training_stats()) if callable(getattr(agent, "training_stats", None)) else {}
        except BaseException as exc:  # noqa: BLE001 - agents' failures are data, a user's Ctrl-C is not
            Guard.keep(exc)
            training = {"error": _describe("training_stats", exc)}

        s_before = self._stats(agent)
        t0 = time.perf_counter()
        begin_error = None
        _, begin_error, timeout = self._call(guard, "begin_context", agent.begin_context, obs, info, simulator)
        timed_out = timeout or timed_out
        begin_time = time.perf_counter() - t0
        s_prev = self._stats(agent)
        carry = _diff(s_prev, s_before)       # what begin_context spent, charged to attempt 1
        carry.pop("sim_calls", None)
        sim_prev = simulator.calls if simulator is not None else 0
        carry_sim = sim_prev

        for k in range(1, attempts + 1):
            if timed_out is not None and k > 1:
                not_run(k, f"not run: an earlier call timed out ({shorten(timed_out, 120)})")
                continue
            act_time = step_time = observe_time = 0.0
            action = reward = distance = None
            success = False
            error = begin_error
            if error is None:
                t0 = time.perf_counter()
                raw, error, timeout = self._call(guard, "act", agent.act)
                timed_out = timeout or timed_out
                act_time = time.perf_counter() - t0
            if error is None:
                action, reason = validate_action(raw, low, high, names)
                if reason is not None:
                    error = "bad_action: " + reason
            if error is None:
                self._phase("env")
                t0 = time.perf_counter()
                try:
                    env.reset(options={"context": ctx})
                    _, r, _, _, step_info = env.step(action)
                    reward = float(r)
                except BaseException as exc:  # noqa: BLE001 - agents' failures are data, a user's Ctrl-C is not
                    Guard.keep(exc)
                    error = _describe("env", exc)
                step_time = time.perf_counter() - t0
            if reward is not None:
                success = bool(step_info.get("is_success", False))
                distance = float(step_info["distance"]) if "distance" in step_info else None
                best = reward if best is None else max(best, reward)
                solved = solved or success
                t0 = time.perf_counter()
                _, error, timeout = self._call(guard, "observe", agent.observe, action.copy(), reward, step_info)
                timed_out = timeout or timed_out
                observe_time = time.perf_counter() - t0
            s_now = self._stats(agent)
            spent = _diff(s_now, s_prev)
            spent.pop("sim_calls", None)
            sim_now = simulator.calls if simulator is not None else 0
            sim_calls = sim_now - sim_prev
            if k == 1:
                for key, v in carry.items():
                    spent[key] = spent.get(key, 0.0) + v
                sim_calls += carry_sim
            spent["sim_calls"] = float(sim_calls)
            s_prev, sim_prev = s_now, sim_now
            record(k, action=None if action is None else [float(v) for v in action], reward=reward, success=success,
                   distance=distance, begin_time=begin_time if k == 1 else 0.0, act_time=act_time,
                   step_time=step_time, observe_time=observe_time, sim_calls=int(sim_calls),
                   skill_evals=float(spent.get("skill_evals", 0.0)), agent_stats=spent, training=training,
                   error=error)
        if timed_out is not None:      # the agent may be mid-computation: make it afresh for the next cell
            self._slots.pop((cell.task, cell.agent, cell.seed), None)
            self._phase("close")
            _close_slot(slot, close_agent=False)
        return CellOutcome(attempts)

    @staticmethod
    def _failure(phase: str, exc: BaseException, guard: Guard) -> str:
        if isinstance(exc, AttemptTimeout):
            return guard.describe_timeout(phase)
        return _describe(phase, exc)

    def _call(self, guard: Guard, phase: str, fn, *args):
        """One agent call under the time limit: (its value, the failure or None, the failure again if a timeout)."""
        self._phase(phase)
        value, exc = guard.call(phase, fn, *args)
        if exc is None:
            return value, None, None
        error = self._failure(phase, exc, guard)
        return value, error, (error if isinstance(exc, AttemptTimeout) else None)


def _close_slot(slot: _Slot, close_agent: bool = True) -> None:
    """Close the slot's envs, and its agent if the runner made it (an agent object passed in stays the caller's)."""
    closers = [getattr(env, "close", None) for env in (slot.env, slot.sim_env) if env is not None]
    if close_agent and slot.owned and slot.agent is not None:
        closers.append(getattr(slot.agent, "close", None))
    for close in closers:
        if callable(close):
            try:
                close()
            except Exception:
                pass


def _single_thread() -> None:
    """One intra-op thread for torch, so that serial and parallel runs compute the same floats."""
    torch = sys.modules.get("torch")
    if torch is not None and torch.get_num_threads() != 1:
        torch.set_num_threads(1)
