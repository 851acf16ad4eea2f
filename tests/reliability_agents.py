"""Agents that misbehave on purpose, for tests/test_harness_reliability.py ("tests.reliability_agents:Class")."""
from __future__ import annotations

import os
import signal
import time

from phyplan_agents import Agent


class _Mid(Agent):
    def act(self):
        return (self.task.action_low + self.task.action_high) / 2


class HangingAgent(_Mid):
    """With run seed 0, ``act()`` of the second attempt never returns (sleeps); run seed 1 behaves. Counts set-ups
    per process (the harness must make a fresh agent after a hang)."""

    name = "hanging"
    setups = 0

    def setup(self, task, seed):
        super().setup(task, seed)
        HangingAgent.setups += 1
        self.run_seed = seed

    def act(self):
        if self.run_seed == 0 and len(self.history) == 1:
            time.sleep(3600)
        return super().act()


class SpinningAgent(_Mid):
    """``act()`` loops forever in Python on the first attempt, catching ``Exception`` (not the harness's timeout)."""

    name = "spinning"

    def act(self):
        if not self.history:
            while True:
                try:
                    pass
                except Exception:
                    pass
        return super().act()


class ExitingAgent(_Mid):
    """Raises ``SystemExit`` in attempt 1, ``KeyboardInterrupt`` (its own, not a user's Ctrl-C) in attempt 2 and
    ``GeneratorExit`` in ``observe`` of attempt 3; behaves otherwise."""

    name = "exiting"

    def begin_context(self, obs, info, simulator=None):
        super().begin_context(obs, info, simulator)
        self.n = 0

    def act(self):
        self.n += 1
        if self.n == 1:
            raise SystemExit(3)
        if self.n == 2:
            raise KeyboardInterrupt("raised by the agent")
        return super().act()

    def observe(self, action, reward, info):
        super().observe(action, reward, info)
        if self.n == 3:
            raise GeneratorExit()


class StuckAgent(_Mid):
    """Blocks SIGALRM and sleeps in ``act()`` (a stand-in for C code that never returns to Python), once per marker
    file: only if ``$STUCK_MARKER`` does not exist yet (it creates it)."""

    name = "stuck"

    def act(self):
        marker = os.environ.get("STUCK_MARKER")
        if marker and not os.path.exists(marker):
            open(marker, "w").close()
            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGALRM})
            time.sleep(3600)
        return super().act()


class SlowAgent(_Mid):
    """Each ``act()`` takes 0.3 s (for interrupting a run midway)."""

    name = "slow"

    def act(self):
        time.sleep(0.3)
        return super().act()
