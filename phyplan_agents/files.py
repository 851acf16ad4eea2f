"""Files on disk: SHA-256 checksums and atomic writes, the one place for both.

Every file the package ships or writes for later runs goes through here: the skill models
(:mod:`phyplan_agents.skills.io`: a ``.pt`` plus a ``.json`` sidecar holding its checksum), the DQN models
(:mod:`phyplan_agents.dqn.models`: ``<task>.pt`` files plus a ``manifest.json`` of checksums) and the DQN simulation
cache (:mod:`phyplan_agents.dqn.cache`). The benchmark harness may use it too (``benchmarks`` imports
``phyplan_agents``, never the other way round).

* :func:`sha256_file`: the hex SHA-256 of a file, read in 1 MiB blocks.
* :func:`sha256_matches`: whether a file has an expected checksum (and its actual one, for the error message the
  caller writes: each file kind names its own rebuild command); :func:`require_sha256` raises the caller's error.
* :func:`atomic_path`: a context manager giving a temporary path next to the target; on success the temporary file
  replaces the target in one ``os.replace`` (readers see the old file or the new one, never half of one), on an
  exception it is removed.
* :func:`atomic_write_bytes`, :func:`atomic_write_text`, :func:`atomic_write_json` on top of it.

The temporary name is ``<name>.tmp<pid>``, so two processes writing the same file never share a temporary file.
(``torch.save`` to a path names the records inside its zip archive after the file name up to its last dot; for
``x.pt.tmp<pid>`` that is ``x.pt``, the same as when saving to ``x.pt.tmp``, so a model saved through
:func:`atomic_path` has the same bytes as before this module existed.)
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
from pathlib import Path
from typing import Any, Callable, Iterator

BLOCK = 1 << 20


def sha256_file(path: str | os.PathLike) -> str:
    """The SHA-256 of the file at ``path`` as 64 hex digits."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(BLOCK), b""):
            h.update(block)
    return h.hexdigest()


def sha256_matches(path: str | os.PathLike, expected: Any) -> tuple[bool, str]:
    """``(the file's SHA-256 equals expected, the file's SHA-256)``; ``expected`` may be anything (e.g. a missing
    metadata entry), which simply does not match."""
    digest = sha256_file(path)
    return digest == expected, digest


def require_sha256(path: str | os.PathLike, expected: Any, error: Callable[[str], Exception]) -> None:
    """Raise ``error(the file's SHA-256)`` unless the file at ``path`` has the SHA-256 ``expected`` (the caller's
    error names the file kind and its rebuild command)."""
    ok, digest = sha256_matches(path, expected)
    if not ok:
        raise error(digest)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; write the file there. On exit it atomically replaces ``path``
    (the parent folder must exist); on an exception it is deleted and ``path`` is left as it was."""
    path = Path(path)
    tmp = path.with_name(f"{path.name}.tmp{os.getpid()}")
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically; returns the path."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_json(path: str | os.PathLike, obj: Any, *, indent: int | None = 2, sort_keys: bool = True) -> Path:
    """Write ``json.dumps(obj, indent=indent, sort_keys=sort_keys)`` plus a newline to ``path`` atomically."""
    return atomic_write_text(path, json.dumps(obj, indent=indent, sort_keys=sort_keys) + "\n")
