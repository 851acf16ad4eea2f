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
    (the harness must make a fresh agent after a hang): per process in ``setups``, and one line each appended to
    ``$HANG_SETUPS`` if set (which a worker process's set-ups reach too)."""

    name = "hanging"
    setups = 0

    def setup(self, task, seed):
        super().setup(task, seed)
        HangingAgent.setups += 1
        if os.environ.get("HANG_SETUPS"):
            with open(os.environ["HANG_SETUPS"], "a") as f:
                f.write(f"{seed}\n")
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


# ============================================================================ agents that end their process
class ExitCodeAgent(_Mid):
    """Ends its process with ``os._exit(7)`` in ``act()`` of the second attempt of every context (what a native
    library calling ``exit()`` does: no exception, no cleanup)."""

    name = "exit-code"

    def act(self):
        if len(self.history) == 1:
            os._exit(7)
        return super().act()


class SegfaultAgent(_Mid):
    """Kills its process with SIGSEGV in ``act()`` of the second attempt of every context (a crash in C code)."""

    name = "segfault"

    def act(self):
        if len(self.history) == 1:
            os.kill(os.getpid(), signal.SIGSEGV)
            time.sleep(60)              # not reached: the signal's default action ends the process at once
        return super().act()


class MemoryHogAgent(_Mid):
    """In ``act()`` of the second attempt of every context, allocates and fills 64 MB blocks until it holds
    ``$HOG_MB`` megabytes (default 4096), far beyond the tests' ``--memory-limit``; if nothing stops it, it frees
    them and plays on."""

    name = "memory-hog"

    def act(self):
        if len(self.history) == 1:
            import numpy as np

            blocks = [np.ones(8 * 2**20) for _ in range(int(os.environ.get("HOG_MB", "4096")) // 64)]
            del blocks
        return super().act()


class SetupExitAgent(_Mid):
    """Ends its process with ``os._exit(3)`` in ``setup`` (e.g. a native library failing to load its weights), after
    appending a line to ``$SETUP_EXITS`` if set (to count the attempts)."""

    name = "setup-exit"

    def setup(self, task, seed=0):
        if os.environ.get("SETUP_EXITS"):
            with open(os.environ["SETUP_EXITS"], "a") as f:
                f.write(f"{seed}\n")
        os._exit(3)


class GilStuckAgent(_Mid):
    """In ``act()`` of the first attempt, blocks SIGALRM and sleeps in C while *holding* the interpreter lock (a
    ``ctypes.PyDLL`` call), so that neither the alarm nor the watchdog thread of its process can run."""

    name = "gil-stuck"

    def act(self):
        if not self.history:
            import ctypes

            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGALRM})
            ctypes.PyDLL(None).sleep(3600)
        return super().act()


class ParentKillerAgent(_Mid):
    """Run seed 0: ``act()`` of the second attempt kills the process that started its own (the harness's main
    process) with SIGKILL. Run seed 1: the first ``act()`` takes 1.5 s (so that its cell is still running then)."""

    name = "parent-killer"

    def setup(self, task, seed=0):
        super().setup(task, seed)
        self.run_seed = seed

    def act(self):
        if self.run_seed == 0 and len(self.history) == 1:
            os.kill(os.getppid(), signal.SIGKILL)
            time.sleep(60)              # this worker ends itself once its parent is gone
        if self.run_seed == 1 and not self.history:
            time.sleep(1.5)
        return super().act()
