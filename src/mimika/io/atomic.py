"""Atomic file writes: nothing half-written is ever left where the user expects a file."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO

__all__ = ["atomic_open", "atomic_write", "make_temp", "pid_alive", "sweep_stale"]


def make_temp(path: str | os.PathLike, suffix: str = ".tmp") -> tuple[int, Path]:
    """A new temporary file ``.NAME.PID.XXXX{suffix}`` beside ``path`` (its folder is
    created): ``(fd, temp path)``. The PID lets :func:`sweep_stale` tell the temp files of
    killed processes from those still being written."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.{os.getpid()}.", suffix=suffix, dir=p.parent)
    return fd, Path(tmp)


def pid_alive(pid: int) -> bool:
    """Whether process ``pid`` runs (or cannot be signalled: another user's)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True
    return True


def sweep_stale(path: str | os.PathLike) -> int:
    """Remove the temporary files :func:`make_temp` made beside ``path`` for processes that
    no longer run (a render or save that was killed); returns how many were removed."""
    p = Path(path)
    head = f".{p.name}."
    removed = 0
    try:
        entries = [e for e in os.scandir(p.parent if str(p.parent) else ".")
                   if e.name.startswith(head)]
    except OSError:
        return 0
    for e in entries:
        pid, _, rest = e.name[len(head):].partition(".")
        if pid.isdigit() and rest and not pid_alive(int(pid)):
            with contextlib.suppress(OSError):
                os.unlink(e.path)
                removed += 1
    return removed


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike) -> Iterator[BinaryIO]:
    """Open a temporary file beside ``path`` for binary writing; on success it is fsynced and
    renamed over ``path``. On any failure the previous file is untouched and the temp file is
    removed. Parent folders are created."""
    p = Path(path)
    fd, tmp = make_temp(p)
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.fchmod(fd, 0o666 & ~umask)  # like a plain open(); mkstemp makes it 0600
        with os.fdopen(fd, "wb") as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, p)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def atomic_write(path: str | os.PathLike, data: bytes | str) -> Path:
    """Write ``data`` (str is written as UTF-8) to ``path`` atomically; returns the path."""
    with atomic_open(path) as f:
        f.write(data.encode("utf-8") if isinstance(data, str) else data)
    return Path(path)
