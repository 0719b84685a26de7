"""AU tracks as CSV: mimika's AU CSV, OpenFace 2 CSV and Live Link Face (ARKit-52) CSV.

* **AU CSV** — ``time,AU01,AU12L,…``: seconds and intensities in [0, 1] (6 decimals).
* **OpenFace** — ``frame, face_id, timestamp, confidence, success, AU01_r, …, AU01_c, …``:
  intensities on OpenFace's 0–5 scale (2 decimals), presence ``_c`` = 1 from FACS level A (0.2).
  One-sided channels fold into their AU (bilateral + mean of the sides).
* **Live Link Face** — ``Timecode,BlendShapeCount,EyeBlinkLeft,…,RightEyeRoll``: ARKit
  blendshapes (10 decimals), rotations in radians, timecode ``HH:MM:SS:FF.mmm`` on a
  ``timecode_fps`` clock (60 in the iPhone app, which writes a row every 2nd frame → 30 fps).
  Rows with ``BlendShapeCount`` = 0 are tracking drop-outs; missing rows and drop-outs are
  filled by interpolation (``fill="linear"``, ``"nearest"`` or ``"hold"``).

Readers raise :class:`~mimika.errors.DataError` naming ``file:row:column``; writers are atomic.
"""

from __future__ import annotations

import csv
import io
import logging
import math
import os
import re
from pathlib import Path

import numpy as np

from mimika.errors import DataError, MimikaError, ParameterError
from mimika.facs import AU_CATALOGUE, parse_au
from mimika.io.arkit import ARKIT_52, LIVELINK_COLUMNS, ROTATIONS, arkit_to_aus, aus_to_arkit
from mimika.io.atomic import atomic_write
from mimika.tracks import AUTrack, valid_fps

log = logging.getLogger(__name__)

__all__ = ["FORMATS", "OPENFACE_AUS", "detect_format", "fill_gaps", "read_au_csv",
           "read_livelink_csv", "read_openface_csv", "read_track", "write_au_csv",
           "write_livelink_csv", "write_openface_csv", "write_track"]

FORMATS = ("au", "openface", "arkit")
#: AUs OpenFace 2 estimates (intensity ``_r``); ``_c`` adds AU28
OPENFACE_AUS = ("AU01", "AU02", "AU04", "AU05", "AU06", "AU07", "AU09", "AU10", "AU12", "AU14",
                "AU15", "AU17", "AU20", "AU23", "AU25", "AU26", "AU45")
FILLS = ("linear", "nearest", "hold", "quadratic", "cubic")
_LAGRANGE = {"quadratic": 2, "cubic": 3}


# -- helpers ------------------------------------------------------------------------------------
def _read_rows(path: str | os.PathLike) -> tuple[list[str], list[tuple[int, list[str]]]]:
    p = Path(path)
    try:
        text = p.read_text("utf-8-sig")
    except FileNotFoundError:
        raise DataError(f"{p} does not exist") from None
    except (OSError, UnicodeDecodeError) as e:
        raise DataError(f"cannot read {p}: {e}") from None
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        raise DataError(f"{p}: the file is empty; expected a CSV header")
    header = [h.strip() for h in rows[0]]
    body = [(i + 2, r) for i, r in enumerate(rows[1:]) if any(c.strip() for c in r)]
    return header, body


def _num(path, row: int, col: str, text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise DataError(f"{path}:{row}:{col}: {text.strip()!r} is not a number") from None
    if not math.isfinite(v):
        raise DataError(f"{path}:{row}:{col}: {text.strip()!r} is not a finite number")
    return v


_COMMON_FPS = (23.976, 24.0, 25.0, 29.97, 30.0, 48.0, 50.0, 59.94, 60.0, 90.0, 100.0, 120.0)


def _fps_from_times(path, times: np.ndarray) -> float:
    """Frame rate of rows at ``times`` (s): rows / span, snapped to a common rate within 0.2 %
    (times written with few decimals, like OpenFace's milliseconds, stay exact)."""
    if len(times) < 2:
        return 25.0
    d = np.diff(times)
    if np.any(d <= 0):
        bad = int(np.argmax(d <= 0)) + 3
        raise DataError(f"{path}:{bad}: time does not increase; rows must be in time order")
    raw = (len(times) - 1) / float(times[-1] - times[0])
    best = min(_COMMON_FPS, key=lambda f: abs(raw - f) / f)
    return best if abs(raw - best) <= 0.002 * best else float(round(raw, 3))


def _lagrange_fill(v: np.ndarray, ok: np.ndarray, degree: int) -> None:
    """Fill interior gaps of ``v`` (T, K) in place with a Lagrange polynomial of ``degree``
    through the ``degree + 1`` valid rows nearest each gap (half before, half after; fewer
    on one side near the ends). Gaps before the first / after the last valid row are held."""
    t = np.arange(len(v))
    good = t[ok]
    bad = t[~ok]
    if len(good) <= degree:  # not enough support: fall back to linear
        for k in range(v.shape[1]):
            v[~ok, k] = np.interp(bad, good, v[ok, k])
        return
    # runs of consecutive missing rows
    splits = np.flatnonzero(np.diff(bad) > 1) + 1
    for run in np.split(bad, splits):
        lo, hi = int(run[0]), int(run[-1])
        before = good[good < lo]
        after = good[good > hi]
        if len(before) == 0 or len(after) == 0:  # leading / trailing gap: hold
            v[run] = v[after[0]] if len(before) == 0 else v[before[-1]]
            continue
        n = degree + 1
        nb = min(len(before), max(n - len(after), (n + 1) // 2))
        na = n - nb
        xs = np.concatenate([before[len(before) - nb:], after[:na]]).astype(np.float64)
        # Lagrange basis weights, shape (len(run), n)
        w = np.ones((len(run), n))
        for j in range(n):
            for m in range(n):
                if m != j:
                    w[:, j] *= (run - xs[m]) / (xs[j] - xs[m])
        v[run] = w @ v[xs.astype(int)]


def fill_gaps(values: np.ndarray, valid: np.ndarray, *, method: str = "linear") -> np.ndarray:
    """Fill rows of ``values`` (T, K) where ``valid`` (T,) is False.

    ``linear`` interpolates between the nearest valid rows, ``nearest`` copies the closer one,
    ``hold`` repeats the last valid row; ``quadratic`` and ``cubic`` fit a Lagrange polynomial
    of degree 2 / 3 through the 3 / 4 valid rows nearest each gap (seed 000's gap filling; a
    polynomial of that degree is recovered exactly). Before the first and after the last valid
    row values are held. Polynomial fills may overshoot; callers clip to their range.
    """
    if method not in FILLS:
        raise ParameterError(f"fill={method!r} must be one of {', '.join(FILLS)}")
    v = np.array(values, np.float64)
    ok = np.asarray(valid, bool)
    if ok.all() or not ok.any():
        return v.astype(np.float32)
    t = np.arange(len(v))
    good = t[ok]
    if method in _LAGRANGE:
        _lagrange_fill(v, ok, _LAGRANGE[method])
    elif method == "linear":
        for k in range(v.shape[1]):
            v[~ok, k] = np.interp(t[~ok], good, v[ok, k])
    else:
        pos = np.searchsorted(good, t)  # first valid index ≥ t
        prev = good[np.clip(pos - 1, 0, len(good) - 1)]
        nxt = good[np.clip(pos, 0, len(good) - 1)]
        prev = np.where(pos == 0, nxt, prev)
        near = np.where(np.abs(t - prev) <= np.abs(nxt - t), prev, nxt)
        src = prev if method == "hold" else near
        v[~ok] = v[src[~ok]]
    return v.astype(np.float32)


def _fmt(x: float, places: int) -> str:
    return f"{x:.{places}f}"


# -- mimika AU CSV ------------------------------------------------------------------------------
def write_au_csv(track: AUTrack, path: str | os.PathLike) -> Path:
    """``time,AU01,…`` — one row per frame, time in seconds."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["time", *track.channels])
    for i, row in enumerate(track.values):
        w.writerow([repr(round(i / track.fps, 9)), *(_fmt(float(x), 6) for x in row)])
    return atomic_write(path, buf.getvalue())


def read_au_csv(path: str | os.PathLike, *, fps: float | None = None) -> AUTrack:
    """Read ``time,AU…`` (fps from the time column unless given)."""
    header, body = _read_rows(path)
    if not header or header[0].lower() != "time":
        raise DataError(f"{path}:1: the first column must be 'time' (seconds), got "
                        f"{header[0] if header else ''!r}")
    chans = []
    for j, h in enumerate(header[1:], start=2):
        try:
            chans.append(parse_au(h))
        except ParameterError as e:
            raise DataError(f"{path}:1:{h or f'column {j}'}: {e}") from None
    if not body:
        raise DataError(f"{path}: no data rows")
    times = np.zeros(len(body))
    vals = np.zeros((len(body), len(chans)), np.float32)
    for i, (line, r) in enumerate(body):
        if len(r) != len(header):
            raise DataError(f"{path}:{line}: {len(r)} fields, but the header has {len(header)}")
        times[i] = _num(path, line, "time", r[0])
        for j, c in enumerate(chans):
            v = _num(path, line, c, r[j + 1])
            if not -1e-6 <= v <= 1 + 1e-6:
                raise DataError(f"{path}:{line}:{c}: {v:g} is outside [0, 1]")
            vals[i, j] = min(max(v, 0.0), 1.0)
    f = valid_fps(fps) if fps is not None else _fps_from_times(path, times)
    return AUTrack(vals, tuple(chans), f, {"source": str(path), "format": "au"})


# -- OpenFace -----------------------------------------------------------------------------------
def _fold(track: AUTrack) -> dict[str, np.ndarray]:
    """Bilateral values: AUxx + mean(AUxxL, AUxxR), clipped."""
    out: dict[str, np.ndarray] = {}
    for c in track.channels:
        b = c[:4]
        v = track[c].astype(np.float64)
        out[b] = out.get(b, np.zeros(track.n_frames)) + (v if len(c) == 4 else v / 2)
    return {c: np.clip(v, 0, 1) for c, v in out.items()}


def write_openface_csv(track: AUTrack, path: str | os.PathLike) -> Path:
    """OpenFace 2 layout: the 17 standard AUs (and any other face AU of the track)."""
    folded = _fold(track)
    extra = [c for c in folded if c not in OPENFACE_AUS and AU_CATALOGUE[c].number < 50]
    aus = sorted(set(OPENFACE_AUS) | set(extra))
    pres = sorted(set(aus) | {"AU28"})
    zero = np.zeros(track.n_frames)
    lines = [", ".join(["frame", "face_id", "timestamp", "confidence", "success",
                        *(f"{a}_r" for a in aus), *(f"{a}_c" for a in pres)])]
    for i in range(track.n_frames):
        r = [str(i + 1), "0", f"{i / track.fps:.3f}", "0.98", "1"]
        r += [_fmt(5 * float(folded.get(a, zero)[i]), 2) for a in aus]
        r += ["1.00" if folded.get(a, zero)[i] >= 0.2 - 1e-9 else "0.00" for a in pres]
        lines.append(", ".join(r))
    return atomic_write(path, "\n".join(lines) + "\n")


def read_openface_csv(path: str | os.PathLike, *, fill: str = "linear",
                      face_id: int | None = None) -> AUTrack:
    """Read OpenFace output: ``AUxx_r`` / 5 → intensities; rows with success 0 are filled."""
    header, body = _read_rows(path)
    need = ("frame", "timestamp", "success")
    missing = [c for c in need if c not in header]
    if missing:
        raise DataError(f"{path}:1: missing column(s) {', '.join(missing)} — not an OpenFace "
                        "CSV (expected 'frame, face_id, timestamp, confidence, success, "
                        "AU01_r, …')")
    rcols = [(j, h) for j, h in enumerate(header) if re.fullmatch(r"AU\d\d_r", h)]
    if not rcols:
        raise DataError(f"{path}:1: no AU intensity columns (AU01_r …)")
    chans = tuple(parse_au(h[:4]) for _, h in rcols)
    ci = {h: j for j, h in enumerate(header)}
    rows = []
    ids = set()
    for line, r in body:
        if len(r) != len(header):
            raise DataError(f"{path}:{line}: {len(r)} fields, but the header has {len(header)}")
        fid = int(_num(path, line, "face_id", r[ci["face_id"]])) if "face_id" in ci else 0
        ids.add(fid)
        rows.append((line, r, fid))
    if face_id is None:
        face_id = min(ids) if ids else 0
        if len(ids) > 1:
            log.warning("%s: %d faces; reading face_id %d", path, len(ids), face_id)
    rows = [x for x in rows if x[2] == face_id]
    if not rows:
        raise DataError(f"{path}: no rows for face_id {face_id}")
    times = np.array([_num(path, ln, "timestamp", r[ci["timestamp"]]) for ln, r, _ in rows])
    ok = np.array([_num(path, ln, "success", r[ci["success"]]) > 0.5 for ln, r, _ in rows])
    vals = np.zeros((len(rows), len(chans)), np.float32)
    for i, (ln, r, _) in enumerate(rows):
        for k, (j, h) in enumerate(rcols):
            v = _num(path, ln, h, r[j])
            if not -1e-6 <= v <= 5 + 1e-6:
                raise DataError(f"{path}:{ln}:{h}: {v:g} is outside OpenFace's 0–5 scale")
            vals[i, k] = min(max(v / 5.0, 0.0), 1.0)
    fps = _fps_from_times(path, times)
    filled = fill_gaps(vals, ok, method=fill)
    meta = {"source": str(path), "format": "openface", "dropouts": int((~ok).sum())}
    return AUTrack(filled, chans, fps, meta)


# -- Live Link Face -----------------------------------------------------------------------------
_TC = re.compile(r"^(\d+):(\d\d):(\d\d):(\d+)(?:\.(\d+))?$")


def parse_timecode(text: str, *, fps: float) -> float:
    """``HH:MM:SS:FF.mmm`` → frames on an ``fps`` clock (fractional)."""
    m = _TC.match(text.strip())
    if not m:
        raise ValueError(text)
    h, mi, s, f = (int(x) for x in m.groups()[:4])
    frac = float("0." + m.group(5)) if m.group(5) else 0.0
    return ((h * 60 + mi) * 60 + s) * fps + f + frac


def format_timecode(frames: float, *, fps: float) -> str:
    """Frames on an ``fps`` clock → ``HH:MM:SS:FF.mmm``."""
    whole = math.floor(frames + 1e-9)
    frac = max(0.0, frames - whole)
    ms = min(round(frac * 1000), 999)
    secs, ff = divmod(whole, round(fps))
    mi, s = divmod(int(secs), 60)
    h, mi = divmod(mi, 60)
    return f"{h:02d}:{mi:02d}:{s:02d}:{int(ff):02d}.{ms:03d}"


def write_livelink_csv(track: AUTrack, path: str | os.PathLike, *,
                       timecode_fps: float = 60.0, start: str = "00:00:00:00.000") -> Path:
    """Live Link Face CSV of ``track`` (one row per frame; timecode on a ``timecode_fps``
    clock starting at ``start``)."""
    tc_fps = valid_fps(timecode_fps)
    try:
        f0 = parse_timecode(start, fps=tc_fps)
    except ValueError:
        raise ParameterError(f"start={start!r} must look like HH:MM:SS:FF.mmm") from None
    shapes, rot = aus_to_arkit(track.values, track.channels)
    lines = [",".join(LIVELINK_COLUMNS)]
    for i in range(track.n_frames):
        tc = format_timecode(f0 + i * tc_fps / track.fps, fps=tc_fps)
        lines.append(",".join([tc, str(len(ARKIT_52) + len(ROTATIONS)),
                               *(_fmt(float(x), 10) for x in shapes[i]),
                               *(_fmt(float(x), 10) for x in rot[i])]))
    return atomic_write(path, "\n".join(lines) + "\n")


def read_livelink_csv(path: str | os.PathLike, *, timecode_fps: float = 60.0,
                      fill: str = "linear") -> AUTrack:
    """Read a Live Link Face take into an AU track.

    Rows sit on a regular grid of the timecode clock (the median row step: every 2nd frame
    of 60 → 30 fps); missing rows and drop-outs (``BlendShapeCount`` = 0) are filled with
    ``fill``. ``meta`` records ``dropouts``, ``missing_rows``, ``timecode_start``.
    """
    tc_fps = valid_fps(timecode_fps)
    header, body = _read_rows(path)
    missing = [c for c in LIVELINK_COLUMNS if c not in header]
    if missing:
        more = f" and {len(missing) - 5} more" if len(missing) > 5 else ""
        raise DataError(f"{path}:1: missing column(s) {', '.join(missing[:5])}{more} — not a "
                        "Live Link Face CSV (expected 'Timecode,BlendShapeCount,EyeBlinkLeft,…')")
    ci = {h: j for j, h in enumerate(header)}
    frames, valid_rows = [], []
    for line, r in body:
        try:
            fr = parse_timecode(r[0], fps=tc_fps)
        except (ValueError, IndexError):
            raise DataError(f"{path}:{line}:Timecode: {r[0] if r else ''!r} is not a timecode "
                            "HH:MM:SS:FF.mmm") from None
        if frames and fr < frames[-1]:
            fr += 24 * 3600 * tc_fps  # the take crossed midnight
        count = r[1].strip() if len(r) > 1 else "0"
        if count in ("", "0") or len(r) < len(header):
            frames.append(fr)
            valid_rows.append(None)
            continue
        shapes = [_num(path, line, n, r[ci[n]]) for n in ARKIT_52]
        rots = [_num(path, line, n, r[ci[n]]) for n in ROTATIONS]
        frames.append(fr)
        valid_rows.append((shapes, rots))
    if not any(v is not None for v in valid_rows):
        raise DataError(f"{path}: no tracked frames (every row is a drop-out)")
    fr = np.array(frames)
    steps = np.diff(fr)
    step = float(np.median(np.round(steps))) if len(steps) else 1.0
    step = max(step, 1.0)
    fps = tc_fps / step
    idx = np.round((fr - fr[0]) / step).astype(int)
    n = int(idx[-1]) + 1
    data = np.zeros((n, len(ARKIT_52) + len(ROTATIONS)), np.float32)
    ok = np.zeros(n, bool)
    for k, v in zip(idx, valid_rows, strict=True):
        if v is not None:
            data[k] = v[0] + v[1]
            ok[k] = True
    n_drop = sum(v is None for v in valid_rows)
    n_missing = n - len(set(idx.tolist()))
    data = fill_gaps(data, ok, method=fill)
    vals, chans = arkit_to_aus(data[:, :len(ARKIT_52)], data[:, len(ARKIT_52):])
    meta = {"source": str(path), "format": "arkit", "dropouts": n_drop,
            "missing_rows": n_missing, "filled": int((~ok).sum()), "fill": fill,
            "timecode_start": body[0][1][0], "timecode_fps": tc_fps}
    log.info("%s: %d frames at %g fps, %d drop-outs and %d missing rows filled (%s)",
             path, n, fps, n_drop, n_missing, fill)
    return AUTrack(vals, chans, fps, meta)


# -- dispatch -----------------------------------------------------------------------------------
def detect_format(path: str | os.PathLike) -> str:
    """``au``, ``openface`` or ``arkit`` from a CSV's header."""
    p = Path(path)
    try:
        with open(p, encoding="utf-8-sig") as f:
            first = f.readline()
    except FileNotFoundError:
        raise DataError(f"{p} does not exist") from None
    except (OSError, UnicodeDecodeError) as e:
        raise DataError(f"cannot read {p}: {e}") from None
    cols = [c.strip() for c in first.split(",")]
    if cols[:2] == ["Timecode", "BlendShapeCount"]:
        return "arkit"
    if "frame" in cols and "timestamp" in cols:
        return "openface"
    if cols and cols[0].lower() == "time":
        return "au"
    raise DataError(f"{p}:1: unknown CSV layout (header starts {first[:60].strip()!r}); "
                    "expected 'time,AU01,…' (AU CSV), OpenFace ('frame, face_id, timestamp, …') "
                    "or Live Link Face ('Timecode,BlendShapeCount,…')")


def read_track(path: str | os.PathLike, *, format: str | None = None, **kwargs) -> AUTrack:
    """Read any supported CSV (``format`` auto-detected from the header)."""
    fmt = format or detect_format(path)
    readers = {"au": read_au_csv, "openface": read_openface_csv, "arkit": read_livelink_csv}
    if fmt not in readers:
        raise ParameterError(f"format={fmt!r} must be one of {', '.join(FORMATS)}")
    try:
        return readers[fmt](path, **kwargs)
    except (MimikaError, TypeError) as e:
        if isinstance(e, TypeError):
            raise ParameterError(f"{fmt} reader: {e}") from None
        raise


def write_track(track: AUTrack, path: str | os.PathLike, *, format: str = "au",
                **kwargs) -> Path:
    """Write ``track`` as ``au``, ``openface`` or ``arkit`` (Live Link Face) CSV, atomically."""
    writers = {"au": write_au_csv, "openface": write_openface_csv, "arkit": write_livelink_csv}
    if format not in writers:
        raise ParameterError(f"format={format!r} must be one of {', '.join(FORMATS)}")
    return writers[format](track, path, **kwargs)

