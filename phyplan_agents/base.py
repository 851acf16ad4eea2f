"""The agent protocol: the few methods every phyplan agent implements.

The harness (``benchmarks``) knows agents only through this file. One *context* is one task instance (goal and
scene, fixed by ``env.reset``); an agent gets up to ``k`` *attempts* at it and is scored by its regret
``max(0, 1 - best reward so far)`` after each attempt.

Life cycle, driven by the harness::

    agent = phyplan_agents.make("random")
    agent.setup(task, seed=0)                 # once per (task, run seed): load models, seed generators
    for context in contexts:
        agent.begin_context(obs, info, simulator)   # the context observation from env.reset
        for attempt in range(k):
            action = agent.act()              # an action inside task.action_space
            ...env.reset(same context); env.step(action)...
            agent.observe(action, reward, info)      # the outcome of that attempt

Agents that need the real simulator for planning (the oracle, ``phyplan-sim``) set ``needs_simulator = True`` and
receive a :class:`Simulator` in ``begin_context``; every call they make through it is counted. Agents report what
they spent through :meth:`Agent.stats` (simulator calls, skill-model evaluations), which the harness records per
attempt.
"""
from __future__ import annotations

import abc
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

import numpy as np


def check_scene(cls, scene) -> dict:
    """``scene`` as a dict of ``cls``'s scene arguments (its ``scene_args``); ``ValueError`` naming any other."""
    scene = dict(scene or {})
    allowed = tuple(getattr(cls, "scene_args", ()))
    unknown = sorted(set(scene) - set(allowed))
    if unknown:
        raise ValueError(f"{cls.__name__} has no scene argument {', '.join(unknown)}; its scene arguments: "
                         f"{', '.join(allowed) or 'none'}")
    return scene


def scene_arguments(task: str, env_kwargs: Mapping[str, Any] | None) -> dict:
    """The scene arguments of task ``task`` among an env's ``gym.make`` keywords (e.g. ``{"paddles": 4}``)."""
    import phyplan_envs

    allowed = getattr(phyplan_envs.task_class(task), "scene_args", ())
    return {k: v for k, v in dict(env_kwargs or {}).items() if k in allowed}


@dataclass(frozen=True)
class TaskInfo:
    """What an agent is told about a task before it sees any context.

    Attributes:
        env_id: the Gymnasium id, e.g. ``"PhyPlan/Launch-v0"``.
        task: the short task name (``"launch"``, ``"slide"``, ``"bounce"``, ``"bridge"``).
        action_names: one name per action dimension, e.g. ``("phi", "theta")``.
        action_low, action_high: the bounds of the action ``Box`` in physical units (radians, metres).
        obs_mode: the observation mode of the env the agent is given (``"state"``, ``"image"``, ``"state_image"``).
        state_names: the names of the entries of the state vector (empty when the obs has no state part).
        env_kwargs: the keyword arguments the env was made with (so an agent can make its own copy).
    """

    env_id: str
    task: str
    action_names: tuple[str, ...]
    action_low: np.ndarray
    action_high: np.ndarray
    obs_mode: str = "state"
    state_names: tuple[str, ...] = ()
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)

    @property
    def action_dim(self) -> int:
        return len(self.action_names)

    @classmethod
    def from_env(cls, env) -> "TaskInfo":
        """Build the task description from a (possibly wrapped) phyplan env."""
        base = env.unwrapped
        spec = getattr(env, "spec", None) or getattr(base, "spec", None)
        env_id = spec.id if spec is not None else f"PhyPlan/{base.task_name.capitalize()}-v0"
        kwargs = dict(spec.kwargs) if spec is not None else {}
        return cls(
            env_id=env_id,
            task=base.task_name,
            action_names=tuple(base.action_names),
            action_low=np.asarray(base.action_space.low, dtype=np.float64).copy(),
            action_high=np.asarray(base.action_space.high, dtype=np.float64).copy(),
            obs_mode=base.obs_mode,
            state_names=tuple(base.state_names) if base.obs_mode != "image" else (),
            env_kwargs=kwargs,
        )


class Simulator:
    """Counted access to the real simulator, fixed to the current context.

    ``evaluate(action)`` resets a private env to the context and steps it, returning ``(reward, info)``;
    ``evaluate_batch(actions)`` does the same for many actions at once (:func:`phyplan_envs.batch.simulate_batch`:
    bit-identical outcomes, spread over ``workers`` processes when ``workers > 1``). The number of calls (one per
    action) is available as ``calls``; an agent's :meth:`Agent.stats` should include it.

    Args:
        env: the private env (made by ``gym.make``, possibly unwrapped).
        context: the context every call is reset to.
        workers: processes for :meth:`evaluate_batch` (default 1: this process, on ``env``).
    """

    def __init__(self, env, context: Mapping[str, Any], workers: int = 1):
        if not (isinstance(workers, (int, np.integer)) and not isinstance(workers, bool) and workers >= 1):
            raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
        self._env = env
        self._context = dict(context)
        self.workers = int(workers)
        self.calls = 0

    def evaluate(self, action: Sequence[float]) -> tuple[float, dict]:
        self._env.reset(options={"context": self._context})
        _, reward, _, _, info = self._env.step(np.asarray(action, dtype=np.float64))
        self.calls += 1
        return float(reward), info

    def evaluate_batch(self, actions: np.ndarray) -> tuple[np.ndarray, list[dict]]:
        """``(rewards (N,), infos)`` of several actions, one simulation each, equal to N :meth:`evaluate` calls.

        Several threads may call it at once, on one Simulator or on several: the calls on one Simulator take turns
        (they share its env and its count of calls); :meth:`evaluate` is for one thread at a time.
        """
        import threading

        from phyplan_envs.batch import run_episodes, simulate_batch

        acts = np.atleast_2d(np.asarray(actions, dtype=np.float64))
        lock = self.__dict__.get("_batch_lock") or self.__dict__.setdefault("_batch_lock", threading.Lock())
        with lock:
            if self.workers == 1 or len(acts) < 2:
                rows = run_episodes(self._env, [self._context] * len(acts), acts)
                rewards, infos = np.array([r[0] for r in rows], dtype=np.float64), [r[1] for r in rows]
            else:
                spec = getattr(self._env, "spec", None) or getattr(self._env.unwrapped, "spec", None)
                if spec is None:
                    raise ValueError("Simulator(workers > 1) needs an env made by gym.make (its spec names the env)")
                res = simulate_batch(spec.id, self._context, acts, workers=self.workers, **spec.kwargs)
                rewards, infos = res.reward, list(res.info)
            self.calls += len(acts)
        return rewards, infos

    def evaluate_many(self, actions: np.ndarray) -> np.ndarray:
        """Rewards of several actions (one simulation each): :meth:`evaluate_batch` without the infos."""
        return self.evaluate_batch(actions)[0]


class Agent(abc.ABC):
    """Base class of every agent. Subclasses implement :meth:`act` and usually :meth:`observe`.

    Class attributes (all optional for third-party agents; the harness reads them with defaults):
        name: the registry name.
        needs_simulator: if true, the harness passes a counted :class:`Simulator` to :meth:`begin_context`.
        env_kwargs: ``gym.make`` keywords of the env the agent wants to see, e.g. ``{"obs_mode": "image",
            "image_size": 64}`` (default: the state observation).
        is_bound: if true, tables show the agent as an upper bound (the oracle), not as a competitor.

    Hooks the harness calls when present: :meth:`reseed` before every context (so that a context's outcome depends
    only on (run seed, context), whatever ran before it or in which worker process).
    """

    name: str = "agent"
    needs_simulator: bool = False
    env_kwargs: dict[str, Any] = {}
    is_bound: bool = False

    def __init__(self, **kwargs: Any) -> None:
        if kwargs:
            raise TypeError(f"{type(self).__name__} got unknown options: {sorted(kwargs)}")
        self.task: TaskInfo | None = None
        self.rng = np.random.default_rng(0)
        self._counters: dict[str, float] = {}

    # -- life cycle ---------------------------------------------------------------------------------------------
    def setup(self, task: TaskInfo, seed: int = 0) -> None:
        """Called once per task and run seed, before any context. Load models and seed generators here."""
        self.task = task
        self.rng = np.random.default_rng(seed)
        self._counters = {"sim_calls": 0, "skill_evals": 0}

    def begin_context(self, obs: Any, info: Mapping[str, Any], simulator: Simulator | None = None) -> None:
        """Called at the start of each context with the observation and info of ``env.reset``."""
        self.obs = obs
        self.context_info = dict(info)
        self.simulator = simulator
        self.history: list[tuple[np.ndarray, float, dict]] = []

    @abc.abstractmethod
    def act(self) -> np.ndarray:
        """The next attempt's action, inside the task's action bounds."""

    def observe(self, action: np.ndarray, reward: float, info: Mapping[str, Any]) -> None:
        """The outcome of the attempt just made (reward and the env's ``info``)."""
        self.history.append((np.asarray(action, dtype=np.float64), float(reward), dict(info)))

    def reseed(self, seed: int) -> None:
        """Re-seed every random generator the agent uses (default: ``self.rng``). Override if there are more."""
        self.rng = np.random.default_rng(seed)

    # -- accounting ---------------------------------------------------------------------------------------------
    def count(self, key: str, n: float = 1) -> None:
        self._counters[key] = self._counters.get(key, 0) + n

    def stats(self) -> dict[str, float]:
        """Cumulative resources spent so far: ``sim_calls`` and ``skill_evals`` at least."""
        out = dict(self._counters)
        if getattr(self, "simulator", None) is not None:
            out["sim_calls"] = out.get("sim_calls", 0) + self.simulator.calls
        return out

    def training_stats(self) -> dict[str, float]:
        """Resources spent on training before evaluation (simulations, wall time); empty if none."""
        return {}

    # -- helpers for subclasses -----------------------------------------------------------------------------------
    def clip(self, action: np.ndarray) -> np.ndarray:
        assert self.task is not None, "setup() must be called before act()"
        return np.clip(np.asarray(action, dtype=np.float64), self.task.action_low, self.task.action_high)

    def uniform_actions(self, n: int) -> np.ndarray:
        assert self.task is not None, "setup() must be called before act()"
        lo, hi = self.task.action_low, self.task.action_high
        return lo + (hi - lo) * self.rng.random((n, len(lo)))


AgentFactory = Callable[..., Agent]
