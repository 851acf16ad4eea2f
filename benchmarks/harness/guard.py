"""Agent calls under a time limit, and every exception an agent raises (``BaseException`` too) becomes data.

:meth:`Guard.call` runs one agent call (``begin_context``, ``act``, ``observe``) and returns ``(value, error)``.

* Time limit: ``SIGALRM`` (``setitimer``) interrupts a call that runs past ``timeout`` seconds with
  :class:`AttemptTimeout`, a ``BaseException``, so an agent's ``except Exception`` does not swallow it. This works
  while the call runs Python code or blocks in an interruptible system call (sleep, I/O, locks), in the main thread
  of the process (the serial runner and every worker process run cells there). No extra thread or process runs the
  agent, so a normal run computes exactly what it did without the limit.
* Backstop: a call that has not returned ``grace`` seconds after the alarm (stuck in C code that never returns to
  Python, or swallowing the timeout with a bare ``except``) cannot be stopped inside the process. A watchdog thread
  then calls ``on_stuck`` (the runner records the cell's attempts as failed and flushes them) and ends the process
  with exit code :data:`STUCK_EXIT`. In a worker process (the default, :mod:`~benchmarks.harness.supervise`) only
  the worker ends and the run goes on; in the run's own process (``--in-process``) the run ends, and rerunning the
  same command resumes after that cell. C code that also holds the interpreter lock stops the watchdog thread too:
  the supervising main process kills such a worker ``2 * grace`` after the limit.
* ``BaseException``: ``SystemExit``, ``KeyboardInterrupt`` raised by the agent's code, ``GeneratorExit`` ... are
  recorded like any exception. A Ctrl-C of the user is not: :func:`interrupts_marked` (the drivers run in it; the
  worker processes install :func:`install_interrupt_handler`) marks a real SIGINT, and the interrupt then
  propagates and stops the run (every finished record is already on disk).
"""
from __future__ import annotations

import contextlib
import os
import signal
import threading
import time
from typing import Any, Callable, Iterator

DEFAULT_ATTEMPT_TIMEOUT = 300.0
"""Seconds one agent call of an attempt may take (``--attempt-timeout``; 0 or None: no limit)."""
GRACE = 30.0
"""Seconds after the time limit before a call that ignored it ends the process (see the module docstring)."""
STUCK_EXIT = 75


class AttemptTimeout(BaseException):
    """An agent call ran past the time limit (a ``BaseException``: ``except Exception`` does not catch it)."""


_USER_INTERRUPT = threading.Event()


@contextlib.contextmanager
def interrupts_marked() -> Iterator[None]:
    """While inside: a real SIGINT is marked (:func:`install_interrupt_handler`); the previous handler and an
    unmarked state come back afterwards. The drivers (:func:`benchmarks.harness.run`, ``evaluate``) run in it."""
    main = threading.current_thread() is threading.main_thread()
    previous = signal.getsignal(signal.SIGINT) if main else None
    _USER_INTERRUPT.clear()
    install_interrupt_handler()
    try:
        yield
    finally:
        if main and previous is not None and signal.getsignal(signal.SIGINT) is _on_sigint:
            try:
                signal.signal(signal.SIGINT, previous)
            except ValueError:
                pass
        _USER_INTERRUPT.clear()


def install_interrupt_handler() -> None:
    """In the main thread: a real SIGINT (Ctrl-C) is marked before it raises ``KeyboardInterrupt``, so that
    :meth:`Guard.call` tells it from a ``KeyboardInterrupt`` that an agent raises itself."""
    if threading.current_thread() is not threading.main_thread():
        return
    if signal.getsignal(signal.SIGINT) is _on_sigint:
        return
    try:
        signal.signal(signal.SIGINT, _on_sigint)
    except ValueError:  # not the main interpreter
        pass


def _on_sigint(signum: int, frame: Any) -> None:
    _USER_INTERRUPT.set()
    raise KeyboardInterrupt


def user_interrupted() -> bool:
    return _USER_INTERRUPT.is_set()


class Guard:
    """Runs agent calls with a time limit (see the module docstring).

    Args:
        timeout: seconds per call (``None`` or 0: no limit).
        grace: seconds after the limit before the backstop ends the process (default: the environment variable
            ``PHYPLAN_TIMEOUT_GRACE``, else :data:`GRACE`).
        on_stuck: called (from the watchdog thread) with the phase name before the backstop ends the process.
    """

    def __init__(self, timeout: float | None = DEFAULT_ATTEMPT_TIMEOUT, grace: float | None = None,
                 on_stuck: Callable[[str], None] | None = None):
        if timeout is not None and (isinstance(timeout, bool) or not isinstance(timeout, (int, float))
                                    or not timeout >= 0):
            raise ValueError(f"attempt timeout must be a non-negative number of seconds, got {timeout!r}")
        self.timeout = float(timeout) if timeout else None
        self.grace = float(os.environ.get("PHYPLAN_TIMEOUT_GRACE", GRACE) if grace is None else grace)
        self.on_stuck = on_stuck
        self._alarm = (self.timeout is not None and hasattr(signal, "setitimer")
                       and threading.current_thread() is threading.main_thread())

    def call(self, phase: str, fn: Callable[..., Any], *args: Any) -> tuple[Any, BaseException | None]:
        """``(fn(*args), None)``, or ``(None, exc)`` for any exception it raised (``AttemptTimeout`` when it ran
        past the limit). A user's Ctrl-C is re-raised."""
        if not self._alarm:
            try:
                return fn(*args), None
            except BaseException as exc:  # noqa: BLE001 - agents' failures are data
                return None, self.keep(exc)
        active = [True]

        def on_alarm(signum: int, frame: Any) -> None:
            if active[0]:                 # an alarm after the call returned is ignored
                raise AttemptTimeout()

        old = signal.signal(signal.SIGALRM, on_alarm)
        watchdog = _Watchdog(self.timeout + self.grace, phase, self.on_stuck)
        signal.setitimer(signal.ITIMER_REAL, self.timeout)
        try:
            value = fn(*args)
            active[0] = False
            return value, None
        except BaseException as exc:  # noqa: BLE001
            active[0] = False
            return None, self.keep(exc)
        finally:
            active[0] = False
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, old)
            watchdog.cancel()

    def describe_timeout(self, phase: str) -> str:
        return f"timeout: {phase}() did not return within {self.timeout:g} s (--attempt-timeout)"

    @staticmethod
    def keep(exc: BaseException) -> BaseException:
        """``exc``, unless it is the user's Ctrl-C: then it is re-raised."""
        if isinstance(exc, KeyboardInterrupt) and user_interrupted():
            raise exc
        return exc


class _Watchdog:
    """Ends the process if a call outlives ``after`` seconds (the backstop of :class:`Guard`)."""

    def __init__(self, after: float, phase: str, on_stuck: Callable[[str], None] | None):
        self._timer = threading.Timer(after, self._fire, args=(phase, on_stuck))
        self._timer.daemon = True
        self._timer.start()

    def cancel(self) -> None:
        self._timer.cancel()

    @staticmethod
    def _fire(phase: str, on_stuck: Callable[[str], None] | None) -> None:
        try:
            if on_stuck is not None:
                on_stuck(phase)
        finally:
            time.sleep(0.2)
            os._exit(STUCK_EXIT)
