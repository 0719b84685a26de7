"""Reading the CSV files of other tools without trusting them.

Every problem becomes one :class:`~mimika.errors.DataError` naming ``file:line[:column]``:
unreadable or non-UTF-8 files, NUL bytes, over-long fields, ragged rows, duplicate columns,
non-numbers, infinities and tables too large to hold. Nothing here allocates more than the
file's own size before the checks.
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mimika.errors import DataError

__all__ = ["COMMON_FPS", "MAX_FPS", "MAX_FRAMES", "MIN_FPS", "Table", "check_frames",
           "fps_from_times", "num", "read_table", "snap_fps"]

#: most frames a reader builds (rows plus filled gaps); larger takes are refused
MAX_FRAMES = 250_000
#: plausible frame rates of a take
MIN_FPS, MAX_FPS = 0.1, 1000.0
#: frame rates times are snapped to (within 0.2 %)
COMMON_FPS = (23.976, 24.0, 25.0, 29.97, 30.0, 48.0, 50.0, 59.94, 60.0, 90.0, 100.0, 120.0)


@dataclass
class Table:
    """A CSV file: stripped header names and the non-blank rows with their line numbers."""

    path: Path
    header: list[str]
    rows: list[tuple[int, list[str]]]

    def col(self, name: str) -> int | None:
        """Index of column ``name`` (None if absent)."""
        return self._index.get(name)

    def require(self, names: Sequence[str], what: str) -> None:
        """Raise unless every column of ``names`` is present (``what`` describes the layout)."""
        missing = [c for c in names if c not in self._index]
        if missing:
            more = f" and {len(missing) - 5} more" if len(missing) > 5 else ""
            raise DataError(f"{self.path}:1: missing column(s) {', '.join(missing[:5])}{more} "
                            f"— not {what}")

    def __post_init__(self) -> None:
        self._index: dict[str, int] = {}
        for j, h in enumerate(self.header):
            if h in self._index and h:
                raise DataError(f"{self.path}:1:{h}: the column appears twice (columns "
                                f"{self._index[h] + 1} and {j + 1}); rename or remove one")
            self._index.setdefault(h, j)


def read_table(path: str | os.PathLike) -> Table:
    """Read a comma-separated file (UTF-8, optional BOM)."""
    p = Path(path)
    try:
        text = p.read_text("utf-8-sig")
    except FileNotFoundError:
        raise DataError(f"{p} does not exist") from None
    except IsADirectoryError:
        raise DataError(f"{p} is a folder, not a CSV file") from None
    except UnicodeDecodeError as e:
        raise DataError(f"{p}: not UTF-8 text (byte {e.start}); save the file as UTF-8 "
                        "CSV") from None
    except OSError as e:
        raise DataError(f"cannot read {p}: {e.strerror or e}") from None
    reader = csv.reader(io.StringIO(text, newline=""))
    rows: list[tuple[int, list[str]]] = []
    header: list[str] | None = None
    try:
        for r in reader:
            if header is None:
                header = [h.strip() for h in r]
            elif any(c.strip() for c in r):
                rows.append((reader.line_num, r))
    except csv.Error as e:
        raise DataError(f"{p}:{reader.line_num}: malformed CSV ({e})") from None
    if header is None or not any(header):
        raise DataError(f"{p}:1: the file is empty; expected a CSV header")
    broken = next((j for j, h in enumerate(header) if "\n" in h or "\r" in h), None)
    if broken is not None:
        raise DataError(f"{p}:1: column {broken + 1}'s name contains a line break (an "
                        "unclosed quote?)")
    return Table(p, header, rows)


def num(path, line: int, col: str, text: str) -> float:
    """``text`` as a finite float, or a DataError naming ``path:line:col``."""
    try:
        v = float(text)
    except ValueError:
        shown = text.strip()
        shown = shown if len(shown) <= 40 else shown[:40] + "…"
        raise DataError(f"{path}:{line}:{col}: {shown!r} is not a number") from None
    if not math.isfinite(v):
        raise DataError(f"{path}:{line}:{col}: {text.strip()!r} is not a finite number")
    return v


def check_frames(n: int, path, what: str = "the take") -> None:
    """Refuse building more than :data:`MAX_FRAMES` frames (before allocating them)."""
    if n > MAX_FRAMES:
        raise DataError(f"{path}: {what} would need {n:,} frames, more than the "
                        f"{MAX_FRAMES:,} a take may have; split the file")


def snap_fps(raw: float, tolerance: float = 0.002) -> float:
    """``raw`` snapped to a :data:`COMMON_FPS` rate within ``tolerance`` (relative), else
    rounded to 3 decimals."""
    best = min(COMMON_FPS, key=lambda f: abs(raw - f) / f)
    return best if abs(raw - best) <= tolerance * best else float(round(raw, 3))


def fps_from_times(path, times: np.ndarray, lines: Sequence[int] | None = None) -> float:
    """Frame rate of rows at ``times`` (s): rows / span, snapped (times written with few
    decimals, like OpenFace's milliseconds, stay exact). Times must increase."""
    if len(times) < 2:
        return 25.0
    d = np.diff(times)
    if np.any(d <= 0):
        k = int(np.argmax(d <= 0)) + 1
        where = lines[k] if lines is not None else k + 2
        raise DataError(f"{path}:{where}: time {times[k]:g} does not increase (previous row "
                        f"{times[k - 1]:g}); rows must be in time order")
    fps = snap_fps((len(times) - 1) / float(times[-1] - times[0]))
    if not MIN_FPS <= fps <= MAX_FPS:
        raise DataError(f"{path}: the time column gives {fps:g} frames per second "
                        f"({len(times)} rows over {times[-1] - times[0]:g} s); a take must "
                        f"have {MIN_FPS:g}–{MAX_FPS:g} fps — are the times in seconds?")
    return fps
