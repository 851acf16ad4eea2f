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
