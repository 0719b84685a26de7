"""Live Link Face CSV (the iPhone app's takes, ARKit-52 blendshapes + 9 rotations).

``Timecode,BlendShapeCount,EyeBlinkLeft,…,RightEyeRoll``; the timecode ``HH:MM:SS:FF.mmm``
runs on a 60 fps clock (the app writes a row every 2nd frame → 30 fps). Rows with
``BlendShapeCount`` 0 are tracking drop-outs; they and rows missing from the grid are filled.

Timecodes are not trusted: each is checked (fields in range), rows must advance, no gap may
exceed ``max_gap`` seconds, the row rate must be plausible and the frame count bounded —
before anything is allocated. ``timecodes="repair"`` sorts rows, drops duplicates and keeps
the longest stretch without a long gap instead of refusing.

Writing follows what the importers do: Epic's Live Link Face importer takes a file as 60 fps
only if some frame number exceeds 30 (else 30 fps); alexdjulin's MotionBuilder script drops
the ``.mmm`` fraction and keys on the 59.94 fps clock. So rows are written on integer frames
of the clock (rate = clock / k), and a short take starts late enough to reach frame 31.
"""

from __future__ import annotations

import logging
import math
import os
import re
from pathlib import Path

import numpy as np

from mimika.errors import DataError, ParameterError
from mimika.io.arkit import (
    ARKIT_52,
    LIVELINK_COLUMNS,
    ROTATIONS,
    apply_extras,
    arkit_extras,
    arkit_to_aus,
    aus_to_arkit,
    extra_names,
)
from mimika.io.atomic import atomic_write
from mimika.io.csvread import check_frames, num, read_table, snap_fps
from mimika.io.gaps import fill_gaps
from mimika.tracks import AUTrack, valid_fps

log = logging.getLogger(__name__)

__all__ = ["format_timecode", "livelink_rate", "parse_timecode", "read_livelink_csv",
           "write_livelink_csv"]

_TC = re.compile(r"^(\d{1,2}):(\d{1,2}):(\d{1,2}):(\d{1,3})(?:\.(\d{1,6}))?$")
_DAY = 24 * 3600
#: plausible row rates of a take (rows per second)
MIN_RATE, MAX_RATE = 1.0, 240.0
CLOCKS = (30.0, 60.0)
#: the largest magnitude a cell may have: shapes are 0–1 (a little over), rotations ±2π
_LIMIT = np.concatenate([np.full(len(ARKIT_52), 2.0), np.full(len(ROTATIONS), 2 * np.pi)])
TIMECODES = ("strict", "repair")
#: Epic's importer: a frame number above this means a 60 fps clock
EPIC_60FPS_FRAME = 30.0


# -- timecodes ------------------------------------------------------------------------------------
def _fields(text: str) -> tuple[int, int, int, float] | None:
    m = _TC.match(text.strip())
    if not m:
        return None
    h, mi, s, f = (int(x) for x in m.groups()[:4])
    return h, mi, s, f + (float("0." + m.group(5)) if m.group(5) else 0.0)


def parse_timecode(text: str, *, fps: float) -> float:
    """``HH:MM:SS:FF.mmm`` → frames since midnight on an ``fps`` clock (fractional).
    Raises ValueError for a malformed timecode or a field out of range."""
    f = _fields(text)
    if f is None:
        raise ValueError(f"{text.strip()!r} is not a timecode HH:MM:SS:FF.mmm")
    h, mi, s, ff = f
    for v, top, name in ((h, 23, "hour"), (mi, 59, "minute"), (s, 59, "second")):
        if v > top:
            raise ValueError(f"{text.strip()!r}: {name} {v} is not 0–{top}")
    if ff >= fps:
        raise ValueError(f"{text.strip()!r}: frame {ff:g} is not below the clock's "
                         f"{fps:g} fps")
    return ((h * 60 + mi) * 60 + s) * fps + ff


def format_timecode(frames: float, *, fps: float) -> str:
    """Frames on an ``fps`` clock → ``HH:MM:SS:FF.mmm`` (wrapping at midnight)."""
    whole = math.floor(frames + 1e-9)
    ms = min(round(max(0.0, frames - whole) * 1000), 999)
    secs, ff = divmod(whole, round(fps))
    mi, s = divmod(int(secs) % _DAY, 60)
    h, mi = divmod(mi, 60)
    return f"{h:02d}:{mi:02d}:{s:02d}:{int(ff):02d}.{ms:03d}"


def _clock(path, stamps: list[tuple[int, str]]) -> float:
    """Epic's rule: a frame number above 30 anywhere means a 60 fps clock, else 30."""
    top = 0.0
    for line, text in stamps:
        f = _fields(text)
        if f is None:
            raise DataError(f"{path}:{line}:Timecode: {text.strip()[:40]!r} is not a timecode "
                            "HH:MM:SS:FF.mmm")
        top = max(top, f[3])
    return 60.0 if top > EPIC_60FPS_FRAME else 30.0


# -- reading --------------------------------------------------------------------------------------
def _order(path, frames: np.ndarray, lines: list[int], clock: float, max_gap: float,
           mode: str, notes: list[str]) -> np.ndarray:
    """Row indices to keep, in time order; raises (strict) or repairs out-of-order rows,
    duplicates and long gaps. ``frames`` are on the clock; a wrap at midnight is unwrapped."""
    fr = frames.copy()
    gap = max_gap * clock
    for k in range(1, len(fr)):  # a take may cross midnight (once, right at it)
        if fr[k] < fr[k - 1] and fr[k - 1] >= _DAY * clock - gap and fr[k] <= gap:
            fr[k:] += _DAY * clock
    frames[:] = fr
    d = np.diff(fr)
    if mode == "strict":
        bad = np.flatnonzero(d <= 0)
        if len(bad):
            k = int(bad[0]) + 1
            raise DataError(f"{path}:{lines[k]}:Timecode: not after line {lines[k - 1]}'s "
                            f"timecode ({format_timecode(fr[k], fps=clock)} ≤ "
                            f"{format_timecode(fr[k - 1], fps=clock)}); rows must be in time "
                            "order — sort them, or read with --timecodes repair")
        big = np.flatnonzero(d > gap)
        if len(big):
            k = int(big[0]) + 1
            raise DataError(f"{path}:{lines[k]}:Timecode: {d[k - 1] / clock:.3g} s after line "
                            f"{lines[k - 1]}, more than the {max_gap:g} s a take may skip; a "
                            "wrong timecode or two takes in one file — fix or split it, raise "
                            "--max-gap, or read with --timecodes repair")
        return np.arange(len(fr))
    order = np.argsort(fr, kind="stable")
    moved = int(np.sum(order != np.arange(len(fr))))
    keep = [int(order[0])]
    dups = 0
    for i in order[1:]:
        if fr[i] - fr[keep[-1]] < 1e-3:
            dups += 1
        else:
            keep.append(int(i))
    ks = np.array(keep)
    cuts = np.flatnonzero(np.diff(fr[ks]) > gap) + 1
    runs = np.split(ks, cuts)
    best = max(runs, key=len)
    dropped = len(ks) - len(best)
    if moved or dups or dropped:
        notes.append(f"{path}: timecodes repaired: {moved} rows moved into time order, {dups} "
                     f"duplicates dropped, {dropped} rows outside the longest stretch without "
                     f"a gap over {max_gap:g} s dropped")
    return best


def read_livelink_csv(path: str | os.PathLike, *, timecode_fps: float | None = None,
                      fill: str = "linear", timecodes: str = "strict",
                      max_gap: float = 2.0) -> AUTrack:
    """Read a Live Link Face take into an AU track.

    ``timecode_fps``: the timecode clock (default: inferred as Epic's importer does — 60 if a
    frame number exceeds 30, else 30). Each row sits a whole number of row steps (the lower
    median step) after the previous one; missing rows and drop-outs are filled with
    ``fill``. ``timecodes`` ``"strict"`` refuses rows out of order and gaps over ``max_gap``
    seconds; ``"repair"`` sorts, drops
    duplicates and keeps the longest stretch. ``meta``: ``dropouts``, ``missing_rows``,
    ``filled``, ``timecode_start``, ``timecode_fps``, ``notes`` and ``arkit_extra`` (the
    channels no AU carries, for :func:`write_livelink_csv`).
    """
    if timecodes not in TIMECODES:
        raise ParameterError(f"timecodes={timecodes!r} must be one of {', '.join(TIMECODES)}")
    if not (isinstance(max_gap, int | float) and 0 < max_gap < _DAY):
        raise ParameterError(f"max_gap={max_gap!r} must be a positive number of seconds")
    t = read_table(path)
    t.require(LIVELINK_COLUMNS, "a Live Link Face CSV (expected 'Timecode,BlendShapeCount,"
              "EyeBlinkLeft,…')")
    ci = [t.col(n) for n in LIVELINK_COLUMNS[2:]]
    ti, ni = t.col("Timecode"), t.col("BlendShapeCount")
    stamps = [(line, r[ti] if ti < len(r) else "") for line, r in t.rows]
    if not stamps:
        raise DataError(f"{path}: no data rows")
    clock = valid_fps(timecode_fps) if timecode_fps is not None else _clock(path, stamps)
    frames = np.empty(len(stamps))
    for k, (line, text) in enumerate(stamps):
        try:
            frames[k] = parse_timecode(text, fps=clock)
        except ValueError as e:
            raise DataError(f"{path}:{line}:Timecode: {e}") from None
    notes: list[str] = []
    lines = [ln for ln, _ in t.rows]
    keep = _order(path, frames, lines, clock, max_gap, timecodes, notes)
    fr = frames[keep]
    d = np.diff(fr)
    # the lower median of the row steps (a gap in a short take must not set the rate)
    step = float(np.partition(d, (len(d) - 1) // 2)[(len(d) - 1) // 2]) if len(d) \
        else clock / min(30.0, clock)
    if not MIN_RATE <= clock / step <= MAX_RATE:
        raise DataError(f"{path}: rows come {clock / step:.4g} times a second on the {clock:g} "
                        f"fps timecode clock; a take has {MIN_RATE:g}–{MAX_RATE:g}")
    # each row a whole number of steps after the previous one: the app's clock drifts against
    # its labels (steps of 1.999 and 2.000 frames), so rounding from the first row would not do
    idx = np.concatenate([[0], np.cumsum(np.maximum(1, np.round(d / step)))]).astype(np.int64)
    n = int(idx[-1]) + 1
    check_frames(n, path)
    rate = snap_fps(clock * (n - 1) / float(fr[-1] - fr[0]), tolerance=0.01) if n > 1 \
        else clock / step
    data = np.zeros((n, len(ARKIT_52) + len(ROTATIONS)), np.float32)
    ok = np.zeros(n, bool)
    n_drop = 0
    for k, row_i in zip(idx, keep, strict=True):
        line, r = t.rows[row_i]
        count = r[ni].strip() if ni < len(r) else ""
        if count in ("", "0"):
            n_drop += 1
            continue
        if len(r) != len(t.header):
            raise DataError(f"{path}:{line}: {len(r)} fields, but the header has "
                            f"{len(t.header)} (Unreal's importer stops here)")
        row = np.array([num(path, line, LIVELINK_COLUMNS[j + 2], r[c])
                        for j, c in enumerate(ci)])
        bad = np.flatnonzero(np.abs(row) > _LIMIT)
        if len(bad):
            name = LIVELINK_COLUMNS[bad[0] + 2]
            raise DataError(f"{path}:{line}:{name}: {r[ci[bad[0]]].strip()[:40]!r} is out of "
                            "range (blendshapes are 0–1, rotations radians)")
        data[k] = row
        ok[k] = True
    if not ok.any():
        raise DataError(f"{path}: no tracked frames (every row is a drop-out)")
    n_missing = n - len(idx)
    data = fill_gaps(data, ok, method=fill)
    shapes, rot = data[:, :len(ARKIT_52)], data[:, len(ARKIT_52):]
    vals, chans = arkit_to_aus(shapes, rot)
    first = t.rows[int(keep[0])][1][ti]
    meta = {"source": str(path), "format": "arkit", "dropouts": n_drop,
            "missing_rows": n_missing, "filled": int((~ok).sum()), "fill": fill,
            "timecode_start": first.strip(), "timecode_fps": clock, "notes": notes,
            "arkit_extra": arkit_extras(shapes, rot, fps=rate)}
    log.info("%s: %d frames at %g fps, %d drop-outs and %d missing rows filled (%s)",
             path, n, rate, n_drop, n_missing, fill)
    return AUTrack(vals, chans, rate, meta)


# -- writing --------------------------------------------------------------------------------------
def livelink_rate(fps: float, clock: float = 60.0) -> float:
    """The row rate a take at ``fps`` is written at: the slowest ``clock / k`` (k whole) not
    slower than ``fps`` — rows then sit on whole frames of the clock (``fps`` itself when it
    divides the clock: 60, 30, 20, 15 …; 24 and 25 become 30; above the clock, the clock)."""
    if fps >= clock:
        return clock
    return clock / max(1, math.floor(clock / fps + 1e-6))


def _extras_at(extra: dict, n: int, fps: float) -> dict[str, np.ndarray]:
    """``meta["arkit_extra"]`` channels resampled to ``n`` frames at ``fps``."""
    try:
        src_fps = float(extra["fps"])
        out = {}
        for name in extra_names():
            if name in extra:
                v = np.asarray(extra[name], np.float64).reshape(-1)
                t_src = np.arange(len(v)) / src_fps
                out[name] = np.interp(np.arange(n) / fps, t_src, v)
        return out
    except (KeyError, TypeError, ValueError, ZeroDivisionError):
        log.info("ignoring a malformed meta['arkit_extra']")
        return {}


def write_livelink_csv(track: AUTrack, path: str | os.PathLike, *,
                       timecode_fps: float = 60.0, start: str | None = None,
                       fps: float | None = None) -> Path:
    """Live Link Face CSV of ``track``, as Unreal's importer and MotionBuilder read it.

    Rows at ``fps`` (default :func:`livelink_rate` of the track's rate; the track is resampled
    when they differ) on a ``timecode_fps`` clock (30 or 60) starting at ``start`` (default
    ``00:00:00:00.000``, or later for a short take so that Unreal sees a frame number above
    30). Channels no AU carries come from ``track.meta["arkit_extra"]`` when present (a
    Live Link import), else are 0; mimika's AU30 has no direction and writes JawLeft.
    """
    clock = valid_fps(timecode_fps)
    if clock not in CLOCKS:
        raise ParameterError(f"timecode_fps={timecode_fps!r}: Live Link Face timecodes run on a "
                             "30 or 60 fps clock (Unreal's importer knows no other)")
    rate = livelink_rate(track.fps, clock) if fps is None else valid_fps(fps)
    if rate > clock:
        raise ParameterError(f"fps={rate:g} is faster than the {clock:g} fps timecode clock: "
                             "rows would share frame numbers")
    step = clock / rate
    if abs(step - round(step)) > 1e-6:
        log.info("Live Link rows every %.3g clock frames: MotionBuilder (which drops the "
                 "fraction) keys them unevenly", step)
    tr = track if abs(rate - track.fps) < 1e-9 else track.resample(fps=rate)
    n = tr.n_frames
    if start is None:
        f0 = max(0.0, math.ceil(EPIC_60FPS_FRAME + 1 - (n - 1) * step)) if clock == 60 else 0.0
    else:
        try:
            f0 = parse_timecode(start, fps=clock)
        except ValueError as e:
            raise ParameterError(f"start: {e}") from None
    shapes, rot = aus_to_arkit(tr.values, tr.channels)
    extra = track.meta.get("arkit_extra")
    if isinstance(extra, dict):
        apply_extras(shapes, rot, _extras_at(extra, n, rate))
    lines = [",".join(LIVELINK_COLUMNS)]
    count = str(len(ARKIT_52) + len(ROTATIONS))
    for i in range(n):
        tc = format_timecode(f0 + i * step, fps=clock)
        lines.append(",".join([tc, count, *(f"{float(x):.10f}" for x in shapes[i]),
                               *(f"{float(x):.10f}" for x in rot[i])]))
    return atomic_write(path, "\n".join(lines) + "\n")
