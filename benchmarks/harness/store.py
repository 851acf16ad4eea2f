"""The records on disk: ``DIR/config.json`` and the append-only ``DIR/attempts.jsonl`` (write, load, resume, repair).

A run appends one flushed line per attempt (:class:`Writer`). :func:`load_records` reads the file back keeping only
finished cells, dropping a truncated last line (a run killed mid-write) and the records of interrupted cells, and with
``repair=True`` rewrites the file atomically to hold exactly those: that is what makes resuming exact.
:func:`prepare_dir` refuses to mix records of different configurations in one directory.
"""
from __future__ import annotations

import json
import os
from collections import OrderedDict
from pathlib import Path
from typing import Any

from .records import CONFIG_NAME, RECORDS_NAME, AttemptRecord, ConfigMismatch, RunConfig


REJECTED_NAME = "attempts.rejected.jsonl"
"""Where ``--repair`` moves the damaged lines of ``attempts.jsonl`` (appended, each line as it was)."""


class DamagedRecords(ValueError):
    """``attempts.jsonl`` holds lines that are not attempt records of this run (edited, corrupted, or foreign).

    Attributes:
        path: the file; bad: ``(line number, reason)`` of each damaged line.
    """

    def __init__(self, path: Path, bad: list[tuple[int, str]]):
        self.path, self.bad = path, bad
        shown = "; ".join(f"line {n}: {why}" for n, why in bad[:5]) + (f"; and {len(bad) - 5} more"
                                                                        if len(bad) > 5 else "")
        super().__init__(f"{path} is damaged: {shown}. Rerun the benchmark with --repair to move the damaged "
                         f"lines to {path.parent / REJECTED_NAME} and rerun their cells")


class _Unreadable(ValueError):
    """A line that is not UTF-8 JSON (what a write cut short leaves)."""


def _parse_line(line: bytes, attempts: int | None) -> AttemptRecord:
    """One line as a record; ``ValueError``/``TypeError`` saying what is wrong with it."""
    try:
        text = line.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise _Unreadable(f"not UTF-8 text (byte {exc.start})") from None
    try:
        d = json.loads(text)
    except ValueError as exc:
        raise _Unreadable(f"not valid JSON ({exc})") from None
    if not isinstance(d, dict):
        raise ValueError(f"not a JSON object (a {type(d).__name__})")
    rec = AttemptRecord.from_dict(d)
    if attempts is not None and not 1 <= rec.attempt <= attempts:
        raise ValueError(f"attempt {rec.attempt} is out of range: this run has attempts 1..{attempts}")
    return rec


def load_records(path: str | Path, attempts: int | None = None, repair: bool = False,
                 quarantine: bool = False) -> tuple[list[AttemptRecord], int]:
    """Read ``attempts.jsonl``: the records of finished cells and the number of lines dropped.

    A cell is finished when it has a record for every attempt ``1..attempts`` (``attempts`` None: keep everything).
    Dropped: a truncated or unreadable last line (a run killed mid-write), and the records of unfinished cells. A
    duplicate of an attempt (a cell that ran again after an interruption) replaces the earlier one. With
    ``repair=True`` the file is rewritten (atomically) to hold exactly the returned records if anything was dropped
    or duplicated.

    Any other line that is not a record of this run (not UTF-8, not JSON, a field of the wrong type, an attempt
    outside ``1..attempts``) raises :class:`DamagedRecords` naming the lines, unless ``quarantine=True`` (what
    ``--repair`` does): then those lines are appended to ``attempts.rejected.jsonl`` beside the file, left out
    (their cells become unfinished and are rerun) and the file is rewritten without them.
    """
    path = Path(path)
    if not path.exists():
        return [], 0
    raw = path.read_bytes()
    lines = raw.split(b"\n")
    parsed: "OrderedDict[tuple, AttemptRecord]" = OrderedDict()
    dropped = 0
    n_lines = 0
    bad: list[tuple[int, str]] = []
    rejected: list[bytes] = []
    last_i = max((i for i, line in enumerate(lines) if line.strip()), default=-1)
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        n_lines += 1
        try:
            rec = _parse_line(line, attempts)
        except (ValueError, TypeError) as exc:
            if i == last_i and (not raw.endswith(b"\n") or isinstance(exc, _Unreadable)):
                dropped += 1            # a write cut short by a kill: its cell is unfinished and reruns
                continue
            bad.append((i + 1, str(exc)))
            rejected.append(line)
            continue
        key = rec.cell + (rec.attempt,)
        if key in parsed:
            del parsed[key]
        parsed[key] = rec
    if bad and not quarantine:
        raise DamagedRecords(path, bad)
    if rejected:
        with open(path.parent / REJECTED_NAME, "ab") as f:
            for line in rejected:
                f.write(line + b"\n")
            f.flush()
            os.fsync(f.fileno())
        dropped += len(rejected)
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
    if (repair or rejected) and changed:
        tmp = path.with_suffix(".jsonl.tmp")
        with open(tmp, "w") as f:
            for rec in out:
                f.write(rec.to_json() + "\n")
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    return out, dropped


def check_out_dir(out_dir: str | Path) -> Path:
    """``out_dir`` created if needed; :class:`OutDirError` if it is a file or cannot be created or written."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise OutDirError(f"--out {out} is a file, not a directory: pass a directory (it is created if missing)")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutDirError(f"--out {out}: cannot create the directory ({exc.strerror or exc})") from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise OutDirError(f"--out {out}: the directory is not writable")
    return out


class OutDirError(ValueError):
    """The output directory is a file, cannot be created, or is not writable."""


def prepare_dir(out_dir: str | Path, config: RunConfig) -> None:
    """Create ``out_dir`` and store ``config``, or check it against the stored one (:class:`ConfigMismatch`)."""
    out = check_out_dir(out_dir)
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


class Writer:
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
