"""py-feat Detector output (a ``Fex`` saved as CSV): replay a detected video on a head.

One row per face and processed frame: ``FaceRect*``, ``FaceScore``, head ``Pitch, Roll, Yaw``
(radians), ``AU01 … AU43`` (detection probabilities), emotions, ``gaze_pitch, gaze_yaw``
(radians), landmarks, 52 MediaPipe/ARKit-named blendshapes (``browDownLeft …``), ``input``,
``frame`` (the video frame number; with ``skip_frames`` only every n-th) and ``approx_time``
(``MM:SS``, whole seconds). Signs, checked against the landmarks of the shared clips: ``Yaw``
> 0 turns the head to the subject's right, ``Pitch`` > 0 down, ``Roll`` > 0 toward the
subject's right shoulder; ``gaze_pitch`` > 0 looks down and ``gaze_yaw`` > 0 to the subject's
right, in camera space (head + eyes).

``source="blendshapes"`` (default) drives the face from the blendshapes (graded intensities,
left/right, gaze from the eyeLook shapes); ``source="aus"`` from the AU probabilities (a
probability is not an intensity: a detected smile replays near full strength) and the gaze
angles. Both take the head from the pose. The video's frame rate is not in the file: give
``fps``, else it is bracketed from ``approx_time`` (each row says floor(frame / fps)).
"""

from __future__ import annotations

import logging
import math
import os
import re

import numpy as np

from mimika.errors import DataError, ParameterError
from mimika.facs import AU_CATALOGUE, parse_au
from mimika.io.arkit import ARKIT_52, arkit_extras, arkit_to_aus
from mimika.io.csvread import COMMON_FPS, check_frames, num, read_table
from mimika.io.gaps import fill_gaps
from mimika.io.rotations import eye_aus, head_aus
from mimika.tracks import AUTrack, valid_fps

log = logging.getLogger(__name__)

__all__ = ["SOURCES", "is_pyfeat_header", "read_pyfeat_csv", "video_fps_from_times"]

SOURCES = ("blendshapes", "aus")
#: py-feat's column name of each ARKit blendshape (MediaPipe spelling: lower camel case)
_BLEND = {n[0].lower() + n[1:]: n for n in ARKIT_52}
_TIME = re.compile(r"^(\d{1,4}):(\d\d)$")
_DEFAULT_FPS = 30.0


def is_pyfeat_header(cols: list[str]) -> bool:
    """A py-feat Fex header: face box and score columns plus a frame column."""
    return {"FaceRectX", "FaceScore", "frame"} <= set(cols)


def video_fps_from_times(frames: np.ndarray, seconds: np.ndarray) -> tuple[float | None, str]:
    """The video frame rate that makes ``floor(frame / fps) == seconds`` on every row (py-feat's
    ``approx_time``): a common rate inside the bracket, else the bracket's middle; None when
    the rows do not bracket it. Returns (fps, how it was found)."""
    lo, hi = 0.0, math.inf
    for f, s in zip(frames, seconds, strict=True):
        lo = max(lo, f / (s + 1))
        if s > 0:
            hi = min(hi, f / s)
    if lo <= 0 or lo > hi * 1.01:
        return None, "approx_time does not bracket a frame rate"
    inside = [c for c in COMMON_FPS if lo < c <= hi]
    near = inside or [c for c in COMMON_FPS if lo * 0.99 < c <= hi * 1.01]
    if math.isinf(hi):
        pick = _DEFAULT_FPS if lo < _DEFAULT_FPS else (near[0] if near else None)
        return pick, f"approx_time only says > {lo:.4g} fps"
    mid = (lo + hi) / 2
    return (min(near, key=lambda c: abs(c - mid)) if near else round(mid, 3),
            f"approx_time brackets {lo:.4g}–{hi:.4g} fps")


def _maybe(path, line: int, col: str, text: str) -> float | None:
    """A value, or None where py-feat wrote nothing / NaN (no face found)."""
    s = text.strip()
    if s == "" or s.lower() == "nan":
        return None
    return num(path, line, col, s)


def read_pyfeat_csv(path: str | os.PathLike, *, source: str = "blendshapes",
                    fps: float | None = None, fill: str = "linear") -> AUTrack:
    """Read py-feat Detector output into an AU track (see the module docs).

    ``fps`` is the video's frame rate (default: from ``approx_time``, else 30 with a note);
    the track runs at ``fps / frame step``. Frames without a face are filled (``fill``);
    with several faces in a frame, the largest face box is read.
    """
    if source not in SOURCES:
        raise ParameterError(f"source={source!r} must be one of {', '.join(SOURCES)}")
    t = read_table(path)
    if not is_pyfeat_header(t.header):
        raise DataError(f"{path}:1: not py-feat output (expected FaceRectX, FaceScore, … "
                        "frame columns)")
    if source == "blendshapes":
        names = [c for c in t.header if c in _BLEND]
        if not names:
            raise DataError(f"{path}:1: no blendshape columns (browDownLeft …); this py-feat "
                            "file has AUs only — read it with --from aus")
    else:
        names = [c for c in t.header if re.fullmatch(r"AU\d\d", c)]
        if not names:
            raise DataError(f"{path}:1: no AU columns (AU01 …) — read it with --from "
                            "blendshapes")
        for c in names:
            try:
                parse_au(c)
            except ParameterError as e:
                raise DataError(f"{path}:1:{c}: {e}") from None
    head_cols = [c for c in ("Yaw", "Pitch", "Roll") if t.col(c) is not None]
    gaze_cols = ([c for c in ("gaze_yaw", "gaze_pitch") if t.col(c) is not None]
                 if source == "aus" else [])
    value_cols = names + head_cols + gaze_cols
    notes: list[str] = []
    best: dict[int, tuple[float, list[float]]] = {}
    secs: dict[int, int] = {}
    n_faces: dict[int, int] = {}
    fcol, tcol = t.col("frame"), t.col("approx_time")
    for line, r in t.rows:
        if len(r) != len(t.header):
            raise DataError(f"{path}:{line}: {len(r)} fields, but the header has "
                            f"{len(t.header)}")
        f = num(path, line, "frame", r[fcol])
        if f < 0 or f != int(f) or f > 1e9:
            raise DataError(f"{path}:{line}:frame: {r[fcol].strip()!r} is not a frame number")
        frame = int(f)
        if tcol is not None and r[tcol].strip():
            m = _TIME.match(r[tcol].strip())
            if not m:
                raise DataError(f"{path}:{line}:approx_time: {r[tcol].strip()[:20]!r} is not "
                                "MM:SS")
            secs[frame] = int(m.group(1)) * 60 + int(m.group(2))
        n_faces[frame] = n_faces.get(frame, 0) + 1
        score = _maybe(path, line, "FaceScore", r[t.col("FaceScore")])
        vals = [_maybe(path, line, c, r[t.col(c)]) for c in value_cols]
        if not score or any(v is None for v in vals):
            best.setdefault(frame, (-1.0, []))
            continue
        w = _maybe(path, line, "FaceRectWidth", r[t.col("FaceRectWidth")]) \
            if t.col("FaceRectWidth") is not None else 1.0
        h = _maybe(path, line, "FaceRectHeight", r[t.col("FaceRectHeight")]) \
            if t.col("FaceRectHeight") is not None else 1.0
        area = abs((w or 0.0) * (h or 0.0))
        for c, v in zip(value_cols, vals, strict=True):
            if c in names and not -0.01 <= v <= 1.01:
                raise DataError(f"{path}:{line}:{c}: {v:g} is outside [0, 1]")
            if c not in names and abs(v) > 360:
                raise DataError(f"{path}:{line}:{c}: {v:g} is not an angle (radians, or "
                                "degrees in older py-feat)")
        if area > best.get(frame, (-1.0, []))[0]:
            best[frame] = (area, [float(v) for v in vals])
    if not best:
        raise DataError(f"{path}: no data rows")
    multi = sum(1 for c in n_faces.values() if c > 1)
    if multi:
        notes.append(f"{path}: {multi} frames show several faces; the largest face is read")
    frames = np.array(sorted(best))
    step = int(np.median(np.diff(frames))) if len(frames) > 1 else 1
    step = max(step, 1)
    n = int((frames[-1] - frames[0]) // step) + 1
    check_frames(n, path)
    if fps is None:
        if secs:
            fr = np.array(sorted(secs))
            rate, how = video_fps_from_times(fr, np.array([secs[f] for f in fr]))
        else:
            rate, how = None, "no approx_time column (images, not a video)"
        if rate is None:
            rate = _DEFAULT_FPS
            notes.append(f"{path}: the video frame rate is not known ({how}); assumed "
                         f"{rate:g} fps — pass --take-fps")
        else:
            log.info("%s: video at %g fps (%s)", path, rate, how)
    else:
        rate = valid_fps(fps)
    data = np.zeros((n, len(value_cols)))
    ok = np.zeros(n, bool)
    for f, (area, vals) in best.items():
        k = round((f - int(frames[0])) / step)
        if area >= 0 and 0 <= k < n:
            data[k] = vals
            ok[k] = True
    if not ok.any():
        raise DataError(f"{path}: no frame with a detected face")
    data = fill_gaps(data, ok, method=fill)
    angles = data[:, len(names):]
    if angles.size and np.abs(angles[ok]).max() > math.pi:
        data[:, len(names):] = np.radians(angles)
        notes.append(f"{path}: head/gaze angles exceed π, so they are degrees (older py-feat); "
                     "converted to radians")
    cols = _channels(source, names, head_cols, gaze_cols, data)
    chans = tuple(sorted(cols, key=lambda c: (AU_CATALOGUE[c[:4]].number, c)))
    vals_out = np.clip(np.stack([cols[c] for c in chans], axis=1), 0, 1).astype(np.float32)
    meta = {"source": str(path), "format": "pyfeat", "from": source, "video_fps": rate,
            "frame_step": step, "dropouts": int((~ok).sum()), "filled": int((~ok).sum()),
            "fill": fill, "notes": notes}
    if source == "blendshapes":
        shapes = np.zeros((n, len(ARKIT_52)))
        for j, c in enumerate(names):
            shapes[:, ARKIT_52.index(_BLEND[c])] = data[:, j]
        meta["arkit_extra"] = arkit_extras(shapes, None, fps=rate / step)
    for note in notes:
        log.info("%s", note)
    return AUTrack(vals_out, chans, rate / step, meta)


def _channels(source: str, names: list[str], head_cols: list[str], gaze_cols: list[str],
              data: np.ndarray) -> dict[str, np.ndarray]:
    """AU channels from the selected columns of ``data`` (in ``names + head + gaze`` order)."""
    at = {c: data[:, j] for j, c in enumerate(names + head_cols + gaze_cols)}
    zero = np.zeros(len(data))
    yaw, pitch, roll = (at.get(c, zero) for c in ("Yaw", "Pitch", "Roll"))
    if source == "blendshapes":
        vals, chans = arkit_to_aus(np.stack([at[c] for c in names], axis=1),
                                   names=[_BLEND[c] for c in names])
        cols = {c: vals[:, k].astype(np.float64) for k, c in enumerate(chans)}
    else:
        cols = {}
        for c in names:
            code = parse_au(c)
            cols[code] = np.maximum(cols.get(code, zero), np.clip(at[c], 0, 1))
        if gaze_cols:
            cols.update(eye_aus(at.get("gaze_yaw", zero) - yaw,
                                at.get("gaze_pitch", zero) - pitch))
    if head_cols:
        cols.update(head_aus(yaw, pitch, roll))
    return cols
