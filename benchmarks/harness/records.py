"""What a benchmark run is made of: its configuration, its cells, and one record per attempt (``attempts.jsonl``)."""
from __future__ import annotations

import dataclasses
import json
import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from .. import splits

HARNESS_VERSION = 1
"""Bumped whenever the protocol or the record format changes (stored in ``config.json``)."""

DEFAULT_AGENTS: tuple[str, ...] = ("phyplan", "dqn-adapted", "dqn-simple", "random", "oracle")
"""The agents of ``make bench``: ours, the two DQN baselines, random, and the oracle bound."""

BOUND_AGENTS: frozenset[str] = frozenset({"oracle"})
"""Agents shown as the upper bound in tables (besides agents whose class sets ``is_bound = True``)."""

TIMING_FIELDS: tuple[str, ...] = ("begin_time", "act_time", "step_time", "observe_time")
"""Wall-clock fields of a record: with :data:`TIMING_SUFFIXES`, the only fields that differ between two runs of the
same configuration."""

TIMING_SUFFIXES: tuple[str, ...] = ("_time", "_seconds")
"""Keys of ``agent_stats`` and ``training`` ending in one of these are wall-clock figures (e.g. PhyPlan's
``plan_seconds``), left out of :meth:`AttemptRecord.without_timing`."""

ACTION_TOL = 1e-6
"""Actions within this of a bound are accepted and clipped (float32 rounding of the Box bounds, as the env does)."""

CONFIG_NAME = "config.json"
RECORDS_NAME = "attempts.jsonl"
_MAX_ERROR_CHARS = 600


# ==================================================================================================== records
def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_real(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


_KINDS = {
    "str": lambda v: isinstance(v, str), "int": _is_int, "number": _is_real, "bool": lambda v: isinstance(v, bool),
    "list of numbers": lambda v: isinstance(v, list) and all(_is_real(x) for x in v),
    "dict of numbers": lambda v: isinstance(v, dict) and all(isinstance(k, str) and _is_real(x) for k, x in v.items()),
    "dict": lambda v: isinstance(v, dict),
}
_FIELD_TYPES: dict[str, tuple[str, ...]] = {
    "task": ("str",), "agent": ("str",), "seed": ("int",), "context": ("int",), "split": ("str",),
    "attempt": ("int",), "action": ("list of numbers", "none"), "reward": ("number", "none"),
    "best": ("number", "none"), "regret": ("number",), "success": ("bool",), "solved": ("bool",),
    "distance": ("number", "none"), "begin_time": ("number",), "act_time": ("number",), "step_time": ("number",),
    "observe_time": ("number",), "sim_calls": ("int",), "skill_evals": ("number",),
    "agent_stats": ("dict of numbers",), "training": ("dict",), "error": ("str", "none"),
}
"""The type of every record field as written by the runner (what :meth:`AttemptRecord.check_types` enforces)."""


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
        rec = cls(**{k: v for k, v in d.items() if k in names})
        rec.check_types()
        return rec

    def check_types(self) -> None:
        """Raise ``TypeError`` naming the first field whose value has the wrong type (a damaged or foreign line)."""
        for name, kinds in _FIELD_TYPES.items():
            v = getattr(self, name)
            ok = (v is None and "none" in kinds) or any(_KINDS[k](v) for k in kinds if k != "none")
            if not ok:
                raise TypeError(f"field {name!r} must be {' or '.join(kinds)}, got {type(v).__name__} "
                                f"{shorten(repr(v), 60)}")
        if self.attempt < 1:
            raise TypeError(f"field 'attempt' must be a positive integer, got {self.attempt}")

    def without_timing(self) -> dict[str, Any]:
        """The record as a dict without its wall-clock fields (what must agree between equivalent runs)."""
        d = dataclasses.asdict(self)
        for k in TIMING_FIELDS:
            d.pop(k)
        d["agent_stats"] = {k: v for k, v in d["agent_stats"].items() if not k.endswith(TIMING_SUFFIXES)}
        d["training"] = {k: v for k, v in d["training"].items() if not k.endswith(TIMING_SUFFIXES)}
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
def missing_attempts(cell: Cell, split: str, attempts: int, received: list[AttemptRecord],
                     reason: str) -> list[AttemptRecord]:
    """Records for the attempts ``1..attempts`` of ``cell`` that ``received`` lacks, when the cell cannot go on (its
    process died, or it was killed): the first fails with ``reason``, the later ones are recorded as not run, as
    after a timeout. ``best``, ``regret``, ``solved`` and ``training`` carry on from the last received record."""
    last = max(received, key=lambda r: r.attempt) if received else None
    have = {r.attempt for r in received}
    later = "timed out" if reason.startswith("timeout") else "crashed"
    out: list[AttemptRecord] = []
    for k in range(1, attempts + 1):
        if k in have:
            continue
        error = reason if not out else f"not run: an earlier call {later} ({shorten(reason, 120)})"
        out.append(AttemptRecord(
            task=cell.task, agent=cell.agent, seed=cell.seed, context=cell.context, split=split, attempt=k,
            action=None, reward=None, best=last.best if last else None, regret=last.regret if last else 1.0,
            success=False, solved=last.solved if last else False, distance=None, begin_time=0.0, act_time=0.0,
            step_time=0.0, observe_time=0.0, sim_calls=0, skill_evals=0.0, agent_stats={},
            training=dict(last.training) if last else {}, error=shorten(error)))
    return out


def shorten(text: str, n: int = _MAX_ERROR_CHARS) -> str:
    return text if len(text) <= n else text[: n - 3] + "..."

def jsonable(x: Any) -> Any:
    """Numbers, strings, lists and dicts only (NumPy scalars and arrays converted; non-finite floats to None)."""
    if isinstance(x, Mapping):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(float(x)) else None
    if x is None or isinstance(x, str):
        return x
    return shorten(repr(x), 200)
