"""mimika's AU CSV: ``time,AU01,AU12L,…`` — seconds and intensities in [0, 1] (6 decimals)."""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path

import numpy as np

from mimika.errors import DataError, ParameterError
from mimika.facs import parse_au
from mimika.io.atomic import atomic_write
from mimika.io.csvread import check_frames, fps_from_times, num, read_table
from mimika.tracks import AUTrack, valid_fps

__all__ = ["read_au_csv", "write_au_csv"]


def write_au_csv(track: AUTrack, path: str | os.PathLike) -> Path:
    """``time,AU01,…`` — one row per frame, time in seconds."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["time", *track.channels])
    for i, row in enumerate(track.values):
        w.writerow([repr(round(i / track.fps, 9)), *(f"{float(x):.6f}" for x in row)])
    return atomic_write(path, buf.getvalue())


def read_au_csv(path: str | os.PathLike, *, fps: float | None = None) -> AUTrack:
    """Read ``time,AU…`` (fps from the time column unless given)."""
    t = read_table(path)
    header = t.header
    if header[0].lower() != "time":
        raise DataError(f"{path}:1: the first column must be 'time' (seconds), got "
                        f"{header[0]!r}")
    chans = []
    for j, h in enumerate(header[1:], start=2):
        try:
            chans.append(parse_au(h))
        except ParameterError as e:
            raise DataError(f"{path}:1:{h or f'column {j}'}: {e}") from None
    if len(set(chans)) != len(chans):
        dup = sorted({c for c in chans if chans.count(c) > 1})
        raise DataError(f"{path}:1: {', '.join(dup)} named twice (e.g. AU1 and AU01)")
    if not t.rows:
        raise DataError(f"{path}: no data rows")
    check_frames(len(t.rows), path)
    times = np.zeros(len(t.rows))
    vals = np.zeros((len(t.rows), len(chans)), np.float32)
    for i, (line, r) in enumerate(t.rows):
        if len(r) != len(header):
            raise DataError(f"{path}:{line}: {len(r)} fields, but the header has {len(header)}")
        times[i] = num(path, line, "time", r[0])
        for j, c in enumerate(chans):
            v = num(path, line, c, r[j + 1])
            if not -1e-6 <= v <= 1 + 1e-6:
                raise DataError(f"{path}:{line}:{c}: {v:g} is outside [0, 1]")
            vals[i, j] = min(max(v, 0.0), 1.0)
    lines = [ln for ln, _ in t.rows]
    f = valid_fps(fps) if fps is not None else fps_from_times(path, times, lines)
    return AUTrack(vals, tuple(chans), f, {"source": str(path), "format": "au"})
