"""Agents defined outside the package, used by tests/test_harness.py through "tests.third_party_agent:Class".

They show that an agent needs nothing from phyplan but the protocol (subclassing ``phyplan_agents.Agent`` is optional).
"""
from __future__ import annotations

import time

import numpy as np

from phyplan_agents import Agent


class MyAgent(Agent):
    """A small deterministic hill-climber: starts at the centre of the action box and, after each attempt, moves
    around the best action so far along one axis at a time with a step that halves every full sweep.

    Uses no random numbers at all, so its records are the same for every run seed; it reports one "skill
    evaluation" per attempt so that the harness's accounting can be tested.
    """

    name = "my-agent"

    def begin_context(self, obs, info, simulator=None):
        super().begin_context(obs, info, simulator)
        lo, hi = self.task.action_low, self.task.action_high
        self.best_action = (lo + hi) / 2
        self.best_reward = -np.inf
        self.step = (hi - lo) / 4
        self.n = 0

    def act(self):
        self.count("skill_evals", 1)
        if self.n == 0:
            return self.best_action.copy()
        axis = (self.n - 1) % self.task.action_dim
        sign = 1 if ((self.n - 1) // self.task.action_dim) % 2 == 0 else -1
        a = self.best_action.copy()
        a[axis] += sign * self.step[axis]
        return self.clip(a)

    def observe(self, action, reward, info):
        super().observe(action, reward, info)
        if reward > self.best_reward:
            self.best_reward, self.best_action = reward, np.asarray(action, dtype=np.float64).copy()
        self.n += 1
        if self.n > 1 and (self.n - 1) % (2 * self.task.action_dim) == 0:
            self.step = self.step / 2


class MisbehavingAgent(Agent):
    """Returns a bad action or raises, by attempt: 1 NaN, 2 wrong shape, 3 out of bounds, 4 raises, 5+ a valid one."""

    name = "misbehaving"

    def act(self):
        n = len(self.history) + getattr(self, "_failures", 0)
        self._failures = getattr(self, "_failures", 0)
        lo, hi = self.task.action_low, self.task.action_high
        kind = n % 5
        if kind < 4:
            self._failures += 1
        if kind == 0:
            return np.full(self.task.action_dim, np.nan)
        if kind == 1:
            return np.zeros(self.task.action_dim + 1)
        if kind == 2:
            return hi + 1.0
        if kind == 3:
            raise RuntimeError("planner exploded")
        return (lo + hi) / 2

    def begin_context(self, obs, info, simulator=None):
        super().begin_context(obs, info, simulator)
        self._failures = 0


class SetupFailsAgent(Agent):
    """An agent whose ``setup`` raises (e.g. missing weights): every attempt must be recorded as failed."""

    name = "setup-fails"

    def setup(self, task, seed=0):
        raise FileNotFoundError("weights.pt not found")

    def act(self):  # pragma: no cover - never reached
        return np.zeros(2)


class SlowRandomAgent(Agent):
    """Uniform random actions, 30 ms of "thinking" per attempt (long enough to kill a run in the middle)."""

    name = "slow-random"

    def act(self):
        time.sleep(0.03)
        return self.uniform_actions(1)[0]


class SimAgent(Agent):
    """Uses the harness's counted simulator: 3 calls in begin_context and 2 per attempt; plays the best seen."""

    name = "sim-agent"
    needs_simulator = True

    def begin_context(self, obs, info, simulator=None):
        super().begin_context(obs, info, simulator)
        cands = self.uniform_actions(3)
        self.scored = [(simulator.evaluate(a)[0], tuple(a)) for a in cands]

    def act(self):
        for a in self.uniform_actions(2):
            self.scored.append((self.simulator.evaluate(a)[0], tuple(a)))
        return np.array(max(self.scored)[1])


class ImageAgent(Agent):
    """Asks the harness for a small state+image observation through ``env_kwargs`` and checks that it got it."""

    name = "image-agent"
    env_kwargs = {"obs_mode": "state_image", "image_size": 32}

    def begin_context(self, obs, info, simulator=None):
        super().begin_context(obs, info, simulator)
        if self.task.obs_mode != "state_image" or obs["image"].shape != (32, 32, 3) or obs["image"].max() == 0:
            raise AssertionError(f"wrong observation: {self.task.obs_mode}, {obs['image'].shape}")

    def act(self):
        return self.uniform_actions(1)[0]


class ObserveFailsAgent(Agent):
    """Plays random actions but its ``observe`` raises: the attempts ran, so their rewards must still count."""

    name = "observe-fails"

    def act(self):
        return self.uniform_actions(1)[0]

    def observe(self, action, reward, info):
        raise KeyError("no such skill")
