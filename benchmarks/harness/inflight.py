"""The in-flight marker: the cells a run was running when it died, so that no rerun dies on the same cell forever.

Agents normally run in worker processes (:mod:`~benchmarks.harness.supervise`), and a worker that dies fails only
its cell. This marker covers what that cannot: a death of the run's own process while a cell runs (``--in-process``
runs, where the agent runs in it; the OOM killer or an agent killing the main process; a ``kill -9``).

``DIR/inflight.json`` holds ``running``, the cells handed to a runner and not finished, and ``suspects``, cells that
were running when an earlier run died, with the number of such deaths (strikes). The run rewrites it atomically when
a cell starts and when it finishes; an orderly end (finished, Ctrl-C, an error) empties ``running``, so only a run
that dies outright leaves cells there. On resume each of them gains a strike:

* a suspect runs again *alone* (no other cell in flight meanwhile), so that a death is blamed on it only;
* a cell with :data:`MAX_STRIKES` strikes is not run again: its attempts are recorded as crashed (attempt 1 with the
  reason, the later ones as not run).

So a single ``kill -9`` of a run still just reruns its cells (as resuming always did), and a cell that kills its
run makes at most ``MAX_STRIKES`` runs die before it is recorded and the run goes on.
"""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Callable, Iterable

from .records import AttemptRecord, Cell, RunConfig, missing_attempts

INFLIGHT_NAME = "inflight.json"
MAX_STRIKES = 2
"""Deaths of a run while a cell was running (alone, after the first) before the cell is recorded as crashed."""

Key = tuple


class InFlight:
    """The marker of a results directory (see the module docstring); ``finished``: keys of the finished cells."""

    def __init__(self, out_dir: str | Path, finished: Iterable[Key] = (), log: Callable[[str], None] = print):
        self.path = Path(out_dir) / INFLIGHT_NAME
        self.running: dict[Key, None] = {}
        self.strikes: dict[Key, int] = {}
        if self.path.exists():
            try:
                stored = json.loads(self.path.read_text())
                strikes = {_key(k): int(n) for k, n in stored["suspects"]}
                for k in stored["running"]:
                    strikes[_key(k)] = strikes.get(_key(k), 0) + 1
            except (ValueError, TypeError, KeyError) as exc:
                log(f"ignoring the unreadable {self.path} ({type(exc).__name__}: {exc})")
                strikes = {}
            done = set(finished)
            self.strikes = {k: n for k, n in strikes.items() if k not in done and n > 0}
        self._write()

    def is_suspect(self, cell: Cell | None) -> bool:
        return cell is not None and cell.key in self.strikes

    def start(self, cell: Cell) -> None:
        self.running[cell.key] = None
        self._write()

    def finish(self, cell: Cell) -> None:
        self.running.pop(cell.key, None)
        self.strikes.pop(cell.key, None)
        self._write()

    def close(self) -> None:
        """An orderly end: the running cells did not kill the run (their strikes, if any, stay)."""
        self.running.clear()
        self._write()

    def settle(self, todo: list[Cell], config: RunConfig, emit: Callable[[AttemptRecord], None],
               log: Callable[[str], None] = print) -> list[Cell]:
        """Record the cells that struck out as crashed; the cells left to run, suspects first."""
        out, suspects = [], []
        for cell in todo:
            n = self.strikes.get(cell.key, 0)
            if n >= MAX_STRIKES:
                reason = (f"crashed: the run itself died {n} times while this cell was running (its process was "
                          f"killed: by the agent, by the OOM killer, or from outside); not run again")
                for rec in missing_attempts(cell, config.split, config.attempts, [], reason):
                    emit(rec)
                self.finish(cell)
                log(f"cell {cell.task}/{cell.agent} seed {cell.seed} context {cell.context}: {reason}")
            elif n:
                suspects.append(cell)
            else:
                out.append(cell)
        if suspects:
            log(f"{len(suspects)} cell(s) were running when an earlier run died: each runs again alone first")
        return suspects + out

    def _write(self) -> None:
        if not self.running and not self.strikes:
            if self.path.exists():
                self.path.unlink()
            return
        tmp = self.path.with_suffix(".tmp")
        tmp.write_text(json.dumps({"running": [list(k) for k in self.running],
                                   "suspects": [[list(k), n] for k, n in self.strikes.items()]}) + "\n")
        os.replace(tmp, self.path)


def _key(k: list) -> Key:
    task, agent, seed, context = k
    if not (isinstance(task, str) and isinstance(agent, str) and isinstance(seed, int) and isinstance(context, int)):
        raise TypeError(f"not a cell: {k!r}")
    return (task, agent, seed, context)
