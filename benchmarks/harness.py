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

Resume: ``DIR/config.json`` stores the run's configuration; a rerun with the same ``DIR`` and the same configuration
skips the finished cells (all K attempts recorded) and reruns the rest. A truncated last line (a run killed with
``kill -9`` mid-write) and the records of unfinished cells are dropped first. A different configuration in the same
``DIR`` is refused.
"""
from __future__ import annotations

import dataclasses
import json
import math
import os
import random
import sys
import time
import traceback
from collections import Counter, OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from . import splits

HARNESS_VERSION = 1
"""Bumped whenever the protocol or the record format changes (stored in ``config.json``)."""

DEFAULT_AGENTS: tuple[str, ...] = ("phyplan", "dqn-adapted", "dqn-simple", "random", "oracle")
"""The agents of ``make bench`` (issue 7): ours, the two DQN baselines, random, and the oracle bound."""

BOUND_AGENTS: frozenset[str] = frozenset({"oracle"})
"""Agents shown as the upper bound in tables (besides agents whose class sets ``is_bound = True``)."""

TIMING_FIELDS: tuple[str, ...] = ("begin_time", "act_time", "step_time", "observe_time")
"""Wall-clock fields of a record: the only fields that differ between two runs of the same configuration."""

ACTION_TOL = 1e-6
"""Actions within this of a bound are accepted and clipped (float32 rounding of the Box bounds, as the env does)."""

CONFIG_NAME = "config.json"
RECORDS_NAME = "attempts.jsonl"
_MAX_ERROR_CHARS = 600
_SLOT_CACHE = 4  # (task, agent, seed) set-ups kept alive per process


# ==================================================================================================== records
@dataclass
class AttemptRecord:
    """One attempt of one agent at one context (a line of ``attempts.jsonl``).

    Attributes:
        task, agent, seed: the task name, agent name and run seed.
        context: the context id, i.e. the ``env.reset`` seed (see :mod:`benchmarks.splits`).
        split: the split the context belongs to.
        attempt: 1-based attempt number.
        action: the action stepped (list of floats in physical units), None if the attempt failed before stepping.
        reward: the env's reward ``1 - d/d0``, None if the attempt failed.
        best: best reward over attempts ``1..attempt``, None while no attempt has succeeded in running.
        regret: ``max(0, 1 - best)``; 1.0 while ``best`` is None (the reward of leaving the object where it is is 0).
        success: the object ended inside the goal box in this attempt (the env's ``is_success``).
        solved: ``success`` in any attempt so far.
        distance: final xy distance from the goal centre (m), None if the attempt failed.
        begin_time: seconds in ``begin_context`` (attempt 1 only, else 0).
        act_time, observe_time: seconds in ``act()`` and ``observe()``.
        step_time: seconds for the env's reset to the context and ``step`` (the real attempt).
        sim_calls: real-simulator calls the agent made through the harness's :class:`~phyplan_agents.Simulator`
            during this attempt (``begin_context`` counts towards attempt 1).
        skill_evals: skill-model evaluations the agent reported for this attempt (``agent.stats()`` difference).
        agent_stats: the full difference of ``agent.stats()`` over this attempt (``sim_calls`` as counted above).
        training: ``agent.training_stats()`` — what the agent spent on training before the benchmark.
        error: why the attempt failed (``"bad_action: ..."``, ``"act: ValueError: ..."``, ...), None if it ran.
    """

    task: str
    agent: str
    seed: int
    context: int
    split: str
    attempt: int
    action: list[float] | None
    reward: float | None
    best: float | None
    regret: float
    success: bool
    solved: bool
    distance: float | None
    begin_time: float
    act_time: float
    step_time: float
    observe_time: float
    sim_calls: int
    skill_evals: float
    agent_stats: dict[str, float] = field(default_factory=dict)
    training: dict[str, Any] = field(default_factory=dict)
    error: str | None = None

    @property
    def cell(self) -> tuple[str, str, int, int]:
        return (self.task, self.agent, self.seed, self.context)

    @property
    def failed(self) -> bool:
        """The attempt had an error. (If only ``observe`` raised, the attempt ran and its reward still counts.)"""
        return self.error is not None

    def to_json(self) -> str:
        return json.dumps(dataclasses.asdict(self), allow_nan=False, separators=(",", ":"))

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "AttemptRecord":
        names = {f.name for f in dataclasses.fields(cls)}
        missing = names - set(d) - {"agent_stats", "training", "error"}
        if missing:
            raise ValueError(f"attempt record lacks fields {sorted(missing)}")
        return cls(**{k: v for k, v in d.items() if k in names})

    def without_timing(self) -> dict[str, Any]:
        """The record as a dict without its wall-clock fields (what must agree between equivalent runs)."""
        d = dataclasses.asdict(self)
        for k in TIMING_FIELDS:
            d.pop(k)
        d["agent_stats"] = {k: v for k, v in d["agent_stats"].items() if not k.endswith("_time")}
        d["training"] = {k: v for k, v in d["training"].items() if not k.endswith("_time")}
        return d


@dataclass(frozen=True, order=True)
class Cell:
    """One (task, agent, run seed, context) unit of work: all K attempts at one context."""

    task: str
    agent: str
    seed: int
    context: int

    @property
    def key(self) -> tuple[str, str, int, int]:
        return (self.task, self.agent, self.seed, self.context)


@dataclass
class RunConfig:
    """Everything that determines a run's records (stored as ``DIR/config.json``).

    ``workers`` and ``backend`` are not part of it: they change how fast the cells run, not what they give.
    """

    tasks: list[str]
    agents: list[str]
    contexts: int = 20
    attempts: int = 5
    seeds: int = 3
    split: str = "test"
    bound_agents: list[str] = field(default_factory=list)
    version: int = HARNESS_VERSION

    def __post_init__(self) -> None:
        for name in ("contexts", "attempts", "seeds"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"{name} must be a positive integer, got {v!r}")
        if not self.tasks:
            raise ValueError("no tasks to run")
        if not self.agents:
            raise ValueError("no agents to run")
        for what, names in (("task", self.tasks), ("agent", self.agents)):
            dup = [n for n, c in Counter(names).items() if c > 1]
            if dup:
                raise ValueError(f"{what} names given twice: {dup}")
        splits.context_seeds(self.split, self.contexts)  # validates split and size

    @property
    def context_ids(self) -> list[int]:
        return splits.context_seeds(self.split, self.contexts)

    @property
    def run_seeds(self) -> list[int]:
        return list(range(self.seeds))

    def cells(self) -> list[Cell]:
        """All cells, grouped by (task, agent, seed) so that a process reuses one set-up for consecutive cells."""
        return [Cell(t, a, s, c) for t in self.tasks for a in self.agents for s in self.run_seeds
                for c in self.context_ids]

    def to_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["context_ids"] = [self.context_ids[0], self.context_ids[-1]]
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "RunConfig":
        names = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in d.items() if k in names})

    def comparable(self) -> dict[str, Any]:
        """The fields that must match to share a directory (order of tasks and agents does not matter)."""
        d = self.to_dict()
        d["tasks"] = sorted(d["tasks"])
        d["agents"] = sorted(d["agents"])
        d["bound_agents"] = sorted(d["bound_agents"])
        return d


class ConfigMismatch(ValueError):
    """The output directory holds records of a run with another configuration."""


@dataclass(frozen=True)
class CellOutcome:
    """What running one cell gave: the number of records emitted, or why the agent was unavailable.

    ``unavailable`` is set when the agent could not be made or set up (e.g. its weights are missing); the cell then
    emits no records, so that a rerun after the fix runs it.
    """

    records: int
    unavailable: str | None = None


@dataclass
class RunResult:
    """The outcome of :func:`run`.

    Attributes:
        records: all records of finished cells in the directory (this run's and earlier runs').
        unavailable: ``(task, agent, seed) -> reason`` for set-ups that failed in this run; their cells were not
            run and are not recorded (rerun the same command after fixing the agent to fill them in).
        ran: number of cells run by this call.
    """

    records: list[AttemptRecord]
    unavailable: dict[tuple[str, str, int], str] = field(default_factory=dict)
    ran: int = 0


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
    try:
        a = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        return None, f"action is not numeric: {_short(repr(action))}"
    n = len(low)
    if a.shape == (1, n):
        a = a[0]
    if a.shape != (n,):
        return None, f"action has shape {a.shape}, expected ({n},) for {tuple(names)}: {_short(repr(action))}"
    if not np.all(np.isfinite(a)):
        bad = [names[i] for i in np.flatnonzero(~np.isfinite(a))]
        return None, f"action has non-finite values in {bad}: {a.tolist()}"
    out = (a < low - ACTION_TOL) | (a > high + ACTION_TOL)
    if np.any(out):
        parts = [f"{names[i]}={a[i]:.6g} not in [{low[i]:.6g}, {high[i]:.6g}]" for i in np.flatnonzero(out)]
        return None, "action out of bounds: " + "; ".join(parts)
    return np.clip(a, low, high), None


def _short(text: str, n: int = _MAX_ERROR_CHARS) -> str:
    return text if len(text) <= n else text[: n - 3] + "..."


def _describe(phase: str, exc: BaseException) -> str:
    where = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ else None
    loc = f" (at {Path(where.filename).name}:{where.lineno})" if where else ""
    return _short(f"{phase}: {type(exc).__name__}: {exc}{loc}")


def _jsonable(x: Any) -> Any:
    """Numbers, strings, lists and dicts only (NumPy scalars and arrays converted; non-finite floats to None)."""
    if isinstance(x, Mapping):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(float(x)) else None
    if x is None or isinstance(x, str):
        return x
    return _short(repr(x), 200)


def _stats(agent: Any) -> dict[str, float]:
    fn = getattr(agent, "stats", None)
    if not callable(fn):
        return {}
    try:
        raw = fn() or {}
    except Exception:  # an agent whose stats() fails still gets benchmarked; it just reports nothing
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
@dataclass
class _Slot:
    """One (task, agent, run seed) set-up: the agent after ``setup`` and its envs."""

    agent: Any
    env: Any
    sim_env: Any
    task_info: Any
    error: str | None


class Runner:
    """Runs cells in one process, keeping the last few (task, agent, seed) set-ups alive between cells."""

    def __init__(self, agent_specs: Mapping[str, Any] | None = None):
        self._slots: OrderedDict[tuple[str, str, int], _Slot] = OrderedDict()
        self._agent_specs = dict(agent_specs or {})

    def close(self) -> None:
        for slot in self._slots.values():
            _close_slot(slot)
        self._slots.clear()

    def _slot(self, task: str, agent_name: str, seed: int) -> _Slot:
        key = (task, agent_name, seed)
        if key in self._slots:
            self._slots.move_to_end(key)
            return self._slots[key]
        while len(self._slots) >= _SLOT_CACHE:
            _close_slot(self._slots.popitem(last=False)[1])
        self._slots[key] = slot = self._make_slot(task, agent_name, seed)
        return slot

    def _make_slot(self, task: str, agent_name: str, seed: int) -> _Slot:
        import gymnasium as gym

        import phyplan_agents
        import phyplan_envs

        spec = self._agent_specs.get(agent_name, agent_name)
        try:
            agent = phyplan_agents.make(spec) if isinstance(spec, str) else spec()
        except Exception as exc:
            return _Slot(None, None, None, None, _describe("make", exc))
        try:
            env_kwargs = dict(getattr(agent, "env_kwargs", None) or {})
            env_kwargs.setdefault("obs_mode", getattr(agent, "obs_mode", "state"))
            env = gym.make(phyplan_envs.env_id(task), **env_kwargs)
            sim_env = None
            if getattr(agent, "needs_simulator", False):
                sim_env = gym.make(phyplan_envs.env_id(task), obs_mode="state")
            info = phyplan_agents.TaskInfo.from_env(env)
        except Exception as exc:
            return _Slot(agent, None, None, None, _describe("make env", exc))
        _single_thread()
        try:
            agent.setup(info, seed)
        except Exception as exc:
            return _Slot(agent, env, sim_env, info, _describe("setup", exc))
        _single_thread()
        return _Slot(agent, env, sim_env, info, None)

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

        def record(k: int, **kw: Any) -> AttemptRecord:
            rec = AttemptRecord(**base, attempt=k, best=best,
                                regret=1.0 if best is None else max(0.0, 1.0 - best), solved=solved, **kw)
            emit(rec)
            return rec

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

        try:
            reseed_agent(agent, cell_seed(cell.seed, cell.context))
        except Exception as exc:
            return failed_all(_describe("reseed", exc))
        obs, info = env.reset(seed=int(cell.context))
        ctx = info["context"]
        simulator = Simulator(slot.sim_env, ctx) if slot.sim_env is not None else None
        try:
            training = _jsonable(agent.training_stats()) if callable(getattr(agent, "training_stats", None)) else {}
        except Exception as exc:
            training = {"error": _describe("training_stats", exc)}

        s_before = _stats(agent)
        t0 = time.perf_counter()
        begin_error = None
        try:
            agent.begin_context(obs, info, simulator)
        except Exception as exc:
            begin_error = _describe("begin_context", exc)
        begin_time = time.perf_counter() - t0
        s_prev = _stats(agent)
        carry = _diff(s_prev, s_before)       # what begin_context spent, charged to attempt 1
        carry.pop("sim_calls", None)
        sim_prev = simulator.calls if simulator is not None else 0
        carry_sim = sim_prev

        for k in range(1, attempts + 1):
            act_time = step_time = observe_time = 0.0
            action = reward = distance = None
            success = False
            error = begin_error
            if error is None:
                t0 = time.perf_counter()
                try:
                    raw = agent.act()
                except Exception as exc:
                    error = _describe("act", exc)
                act_time = time.perf_counter() - t0
            if error is None:
                action, reason = validate_action(raw, low, high, names)
                if reason is not None:
                    error = "bad_action: " + reason
            if error is None:
                t0 = time.perf_counter()
                try:
                    env.reset(options={"context": ctx})
                    _, r, _, _, step_info = env.step(action)
                    reward = float(r)
                except Exception as exc:
                    error = _describe("env", exc)
                step_time = time.perf_counter() - t0
            if reward is not None:
                success = bool(step_info.get("is_success", False))
                distance = float(step_info["distance"]) if "distance" in step_info else None
                best = reward if best is None else max(best, reward)
                solved = solved or success
                t0 = time.perf_counter()
                try:
                    agent.observe(action.copy(), reward, step_info)
                except Exception as exc:
                    error = _describe("observe", exc)
                observe_time = time.perf_counter() - t0
            s_now = _stats(agent)
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
        return CellOutcome(attempts)


def _close_slot(slot: _Slot) -> None:
    for env in (slot.env, slot.sim_env):
        if env is not None:
            try:
                env.close()
            except Exception:
                pass


def _single_thread() -> None:
    """One intra-op thread for torch, so that serial and parallel runs compute the same floats."""
    torch = sys.modules.get("torch")
    if torch is not None and torch.get_num_threads() != 1:
        torch.set_num_threads(1)


# ============================================================================================== persistence
def load_records(path: str | Path, attempts: int | None = None,
                 repair: bool = False) -> tuple[list[AttemptRecord], int]:
    """Read ``attempts.jsonl``: the records of finished cells and the number of lines dropped.

    A cell is finished when it has a record for every attempt ``1..attempts`` (``attempts`` None: keep everything).
    Dropped: a truncated or unreadable last line, and the records of unfinished cells. A duplicate of an attempt
    (a cell that ran again after an interruption) replaces the earlier one. With ``repair=True`` the file is
    rewritten (atomically) to hold exactly the returned records if anything was dropped or duplicated.
    Unreadable lines other than the last raise ``ValueError`` (the file was edited or is not ours).
    """
    path = Path(path)
    if not path.exists():
        return [], 0
    raw = path.read_bytes()
    lines = raw.split(b"\n")
    parsed: "OrderedDict[tuple, AttemptRecord]" = OrderedDict()
    dropped = 0
    n_lines = 0
    last_i = max((i for i, line in enumerate(lines) if line.strip()), default=-1)
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        n_lines += 1
        last = i == last_i
        try:
            rec = AttemptRecord.from_dict(json.loads(line))
        except (ValueError, TypeError) as exc:
            if last:
                dropped += 1
                continue
            raise ValueError(f"{path}: line {i + 1} is not an attempt record ({exc}); the file is damaged") from None
        key = rec.cell + (rec.attempt,)
        if key in parsed:
            del parsed[key]
        parsed[key] = rec
    by_cell: "OrderedDict[tuple, list[AttemptRecord]]" = OrderedDict()
    for rec in parsed.values():
        by_cell.setdefault(rec.cell, []).append(rec)
    out: list[AttemptRecord] = []
    for recs in by_cell.values():
        have = {r.attempt for r in recs}
        if attempts is not None and have != set(range(1, attempts + 1)):
            dropped += len(recs)
            continue
        out.extend(sorted(recs, key=lambda r: r.attempt))
    changed = dropped > 0 or len(out) != n_lines or (bool(raw) and not raw.endswith(b"\n"))
    if repair and changed:
        tmp = path.with_suffix(".jsonl.tmp")
        with open(tmp, "w") as f:
            for rec in out:
                f.write(rec.to_json() + "\n")
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    return out, dropped


def prepare_dir(out_dir: str | Path, config: RunConfig) -> None:
    """Create ``out_dir`` and store ``config``, or check it against the stored one (:class:`ConfigMismatch`)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cfg_path = out / CONFIG_NAME
    if cfg_path.exists():
        try:
            stored = json.loads(cfg_path.read_text())
        except ValueError as exc:
            raise ConfigMismatch(f"{cfg_path} is not readable JSON ({exc}); remove it or use another --out") from None
        mine = config.comparable()
        theirs = RunConfig.from_dict(stored).comparable() if isinstance(stored, dict) else {}
        diffs = [f"{k}: stored {theirs.get(k)!r}, now {mine.get(k)!r}" for k in sorted(set(mine) | set(theirs))
                 if mine.get(k) != theirs.get(k)]
        if diffs:
            raise ConfigMismatch(f"{out} holds a run with a different configuration ({'; '.join(diffs)}). "
                                 f"Records of different configurations are never mixed: use another --out "
                                 f"or remove {out}.")
        return
    if (out / RECORDS_NAME).exists():
        raise ConfigMismatch(f"{out / RECORDS_NAME} exists without {CONFIG_NAME}; cannot tell which run it "
                             f"belongs to: use another --out or remove it")
    tmp = cfg_path.with_suffix(".tmp")
    tmp.write_text(json.dumps(config.to_dict(), indent=2) + "\n")
    os.replace(tmp, cfg_path)


def read_config(out_dir: str | Path) -> RunConfig:
    """The configuration stored in a benchmark directory."""
    path = Path(out_dir) / CONFIG_NAME
    if not path.exists():
        raise FileNotFoundError(f"{path} not found: {out_dir} is not a benchmark output directory")
    return RunConfig.from_dict(json.loads(path.read_text()))


# =================================================================================================== backends
class _Writer:
    """Appends records to ``attempts.jsonl``, one flushed line each."""

    def __init__(self, path: Path, progress: Any = None):
        self._f = open(path, "a")
        self._progress = progress
        self.count = 0

    def __call__(self, rec: AttemptRecord) -> None:
        self._f.write(rec.to_json() + "\n")
        self._f.flush()
        self.count += 1
        if self._progress is not None:
            self._progress.update(1)

    def close(self) -> None:
        self._f.close()


def _run_serial(cells: Sequence[Cell], config: RunConfig, emit: Callable, agent_specs: Mapping[str, Any],
                done: Callable[[Cell, CellOutcome], None]) -> None:
    runner = Runner(agent_specs)
    try:
        for cell in cells:
            done(cell, runner.run_cell(cell, config.attempts, config.split, emit))
    finally:
        runner.close()


# process pool: each worker keeps its own Runner and streams records through a queue to the single writer
_WORKER: dict[str, Any] = {}


def _init_worker(queue: Any, agent_specs: Mapping[str, Any]) -> None:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    os.environ.setdefault("MKL_NUM_THREADS", "1")
    _WORKER["queue"] = queue
    _WORKER["runner"] = Runner(agent_specs)
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


def _run_processes(cells: Sequence[Cell], config: RunConfig, emit: Callable, workers: int,
                   agent_specs: Mapping[str, Any], done_cb: Callable[[Cell, CellOutcome], None]) -> None:
    import multiprocessing as mp
    import queue as queue_mod
    from concurrent.futures import ProcessPoolExecutor

    ctx = mp.get_context("spawn")  # fresh interpreters: MuJoCo/EGL and torch state do not survive fork well
    q = ctx.Queue()
    expected = 0
    received = 0
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_init_worker,
                             initargs=(q, dict(agent_specs))) as pool:
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


def _ray_cell(cell: Cell, attempts: int, split: str,
              agent_specs: Mapping[str, Any]) -> tuple[Cell, list[AttemptRecord], CellOutcome]:
    runner = _WORKER.get("ray_runner")
    if runner is None:
        runner = _WORKER["ray_runner"] = Runner(agent_specs)
    out: list[AttemptRecord] = []
    outcome = runner.run_cell(cell, attempts, split, out.append)
    return cell, out, outcome


def _run_ray(cells: Sequence[Cell], config: RunConfig, emit: Callable, workers: int,
             agent_specs: Mapping[str, Any], done_cb: Callable[[Cell, CellOutcome], None]) -> None:
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
        futures = [remote.remote(c, config.attempts, config.split, specs) for c in cells]
        while futures:
            ready, futures = ray.wait(futures, num_returns=1)
            cell, recs, outcome = ray.get(ready[0])
            for rec in recs:
                emit(rec)
            done_cb(cell, outcome)
    finally:
        if started:
            ray.shutdown()


# ====================================================================================================== driver
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
        text = "; ".join(f"{n} ({_short(reason, 160)})" for n, reason in missing)
        if not skip_missing:
            raise ValueError(f"agents not available yet: {text}. Pass --skip-missing to run the others "
                             f"(available agents: {', '.join(phyplan_agents.available())})")
        log(f"skipping agents not available yet: {', '.join(n for n, _ in missing)}")
    if not ok:
        raise ValueError("no agent left to run (all requested agents are missing)")
    return ok, bounds


def check_tasks(names: Sequence[str] | None) -> list[str]:
    """Check task names (default: every registered task); unknown ones raise ``ValueError`` listing the tasks."""
    import phyplan_envs

    if names is None:
        return list(phyplan_envs.TASKS)
    bad = [n for n in names if n not in phyplan_envs.TASKS]
    if bad:
        raise ValueError(f"unknown task(s) {', '.join(map(repr, bad))}; available tasks: "
                         f"{', '.join(phyplan_envs.TASKS)}")
    return list(names)


def run(config: RunConfig, out_dir: str | Path, workers: int = 1, backend: str = "process",
        progress: bool = True, agent_specs: Mapping[str, Any] | None = None,
        log: Callable[[str], None] = print) -> RunResult:
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
    """
    if backend not in ("process", "ray"):
        raise ValueError(f"backend must be 'process' or 'ray', got {backend!r}")
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    out = Path(out_dir)
    prepare_dir(out, config)
    path = out / RECORDS_NAME
    done, dropped = load_records(path, config.attempts, repair=True)
    finished = {r.cell for r in done}
    todo = [c for c in config.cells() if c.key not in finished]
    total = len(config.cells())
    if finished:
        log(f"resuming {out}: {len(finished)}/{total} cells done" +
            (f" ({dropped} records of interrupted cells dropped)" if dropped else ""))
    unavailable: dict[tuple[str, str, int], str] = {}
    if todo:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(todo) * config.attempts, unit="attempt", desc="bench", disable=not progress,
                   dynamic_ncols=True, smoothing=0.05)
        writer = _Writer(path, bar)

        def done(cell: Cell, outcome: CellOutcome) -> None:
            if outcome.unavailable is not None:
                unavailable.setdefault((cell.task, cell.agent, cell.seed), outcome.unavailable)
                bar.update(config.attempts)  # nothing will come for this cell

        try:
            if backend == "ray":
                _run_ray(todo, config, writer, workers, agent_specs or {}, done)
            elif workers > 1:
                _run_processes(todo, config, writer, workers, agent_specs or {}, done)
            else:
                _run_serial(todo, config, writer, agent_specs or {}, done)
        finally:
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
