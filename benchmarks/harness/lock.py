"""One writer per results directory: an exclusive lock on ``--out`` for the whole run.

Two runs appending to (and, on resume, rewriting) the same ``attempts.jsonl`` lose records: the second run's resume
replaces the file while the first keeps appending to the replaced one. :class:`DirLock` makes the second run refuse.

The lock is ``DIR/run.lock``: an advisory ``flock`` held for the whole run (the kernel releases it when the owner
exits, however it exits), and in the file the owner's pid, host and start time for the message. A lock file left by
a process that died is stale: nobody holds its ``flock``, so the next run takes it over. A lock held by a live
process is refused with :class:`DirLocked`, naming the owner. (``flock`` is per host: two hosts writing one
directory over a network file system are not protected; the file's host field says who wrote it.)
"""
from __future__ import annotations

import json
import os
import socket
import time
from pathlib import Path

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX
    fcntl = None

LOCK_NAME = "run.lock"


class DirLocked(RuntimeError):
    """Another live process holds the results directory's lock."""


class DirLock:
    """The exclusive lock of a results directory; use as a context manager (``with DirLock(out): ...``)."""

    def __init__(self, out_dir: str | Path):
        self.path = Path(out_dir) / LOCK_NAME
        self._fd: int | None = None

    def acquire(self) -> "DirLock":
        if fcntl is None:
            raise RuntimeError("the results-directory lock needs fcntl (POSIX)")
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                owner = _read_owner(fd)
                os.close(fd)
                raise DirLocked(f"{self.path.parent} is in use by another benchmark run ({owner}); one directory "
                                f"has one writer: wait for it to finish, or use another --out") from None
            try:             # the file may have been replaced between our open and our lock: lock the current one
                same = os.fstat(fd).st_ino == os.stat(self.path).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        os.ftruncate(fd, 0)
        os.write(fd, (json.dumps({"pid": os.getpid(), "host": socket.gethostname(),
                                  "started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}) + "\n").encode())
        os.fsync(fd)
        self._fd = fd
        return self

    def release(self) -> None:
        if self._fd is None:
            return
        try:
            os.unlink(self.path)
        except FileNotFoundError:
            pass
        os.close(self._fd)       # closing drops the flock
        self._fd = None

    def __enter__(self) -> "DirLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


def _read_owner(fd: int) -> str:
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        info = json.loads(os.read(fd, 4096).decode() or "{}")
        return f"pid {info.get('pid')} on host {info.get('host')}, started {info.get('started')}"
    except (OSError, ValueError):
        return "owner unknown"
