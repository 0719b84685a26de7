"""OpenFace 2 CSV (``FeatureExtraction``'s RecorderCSV layout): read and write.

Columns (``, ``-separated): ``frame, face_id, timestamp, confidence, success``, the gaze
block ``gaze_0_x … gaze_1_z, gaze_angle_x, gaze_angle_y``, the pose block ``pose_Tx …
pose_Rz``, then ``AUxx_r`` (17 intensities on OpenFace's 0–5 scale) and ``AUxx_c`` (18
presences). OpenFace's signs (camera coordinates: x right in the image, y down, z away from
the camera; checked against the 2-D landmarks of a real file): ``pose_Ry`` > 0 turns the
head to the subject's right, ``pose_Rx`` > 0 tilts it down, ``pose_Rz`` > 0 tilts it toward
the subject's left shoulder; ``gaze_angle_x`` > 0 looks to the subject's left (image right),
``gaze_angle_y`` > 0 looks down; gaze is in camera space (head + eyes).
"""

from __future__ import annotations

import logging
import os
import re
from pathlib import Path

import numpy as np

from mimika.errors import DataError, ParameterError
from mimika.facs import AU_CATALOGUE, is_body, parse_au
from mimika.io.atomic import atomic_write
from mimika.io.csvread import check_frames, fps_from_times, num, read_table
from mimika.io.gaps import fill_gaps
from mimika.io.rotations import eye_angles, eye_aus, head_angles, head_aus
from mimika.tracks import AUTrack, valid_fps

log = logging.getLogger(__name__)

__all__ = ["OPENFACE_AUS", "OPENFACE_PRESENCE", "read_openface_csv", "write_openface_csv"]

#: AUs OpenFace 2 estimates an intensity for (``_r``), in its column order
OPENFACE_AUS = ("AU01", "AU02", "AU04", "AU05", "AU06", "AU07", "AU09", "AU10", "AU12", "AU14",
                "AU15", "AU17", "AU20", "AU23", "AU25", "AU26", "AU45")
#: AUs it writes a presence for (``_c``): the same plus AU28
OPENFACE_PRESENCE = tuple(sorted((*OPENFACE_AUS, "AU28")))
_GAZE = ("gaze_0_x", "gaze_0_y", "gaze_0_z", "gaze_1_x", "gaze_1_y", "gaze_1_z",
         "gaze_angle_x", "gaze_angle_y")
_POSE = ("pose_Tx", "pose_Ty", "pose_Tz", "pose_Rx", "pose_Ry", "pose_Rz")
SCALES = ("auto", "5", "1")
_TWO_DECIMALS = re.compile(r"^\s*\d+(\.\d{1,2})?\s*$")


# -- writing --------------------------------------------------------------------------------------
def _fold(track: AUTrack) -> dict[str, np.ndarray]:
    """Bilateral values: AUxx + mean(AUxxL, AUxxR), clipped (body channels: no column)."""
    out: dict[str, np.ndarray] = {}
    for c in track.channels:
        if is_body(c):
            continue
        b = c[:4]
        v = track[c].astype(np.float64)
        out[b] = out.get(b, np.zeros(track.n_frames)) + (v if len(c) == 4 else v / 2)
    return {c: np.clip(v, 0, 1) for c, v in out.items()}


def write_openface_csv(track: AUTrack, path: str | os.PathLike, *, gaze: bool = True,
                       pose: bool = True) -> Path:
    """Write ``track`` in OpenFace 2's RecorderCSV layout, with its number formats.

    The 17 ``_r`` and 18 ``_c`` columns OpenFace writes, nothing else (other AUs are left out,
    with a log message); one-sided channels fold into their AU. ``pose`` adds the head pose
    from AU51–56 (rotation in radians; translation 0: mimika has no camera), ``gaze`` the gaze
    of both eyes in camera space from AU61–64 plus the head. The block of eye landmarks that
    ``FeatureExtraction -gaze`` also writes is not (mimika has no image); with both off the
    columns are exactly those of ``FeatureExtraction -aus``.
    """
    folded = _fold(track)
    zero = np.zeros(track.n_frames)

    def col(code: str) -> np.ndarray:
        return folded.get(code, zero)

    left_out = sorted(c for c in folded if c not in OPENFACE_PRESENCE
                      and AU_CATALOGUE[c].group not in ("head", "eyes"))
    if left_out:
        log.info("OpenFace CSV: OpenFace has no column for %s; left out", ", ".join(left_out))
    head = [c for c in folded if AU_CATALOGUE[c].group == "head"]
    eyes = [c for c in folded if AU_CATALOGUE[c].group == "eyes"]
    yaw, pitch, roll = head_angles(col)
    eye_yaw, eye_pitch = eye_angles(col)
    ax = -(yaw + eye_yaw)  # camera space: + looks to the subject's left (image right)
    ay = pitch + eye_pitch  # + looks down
    g = np.stack([np.tan(ax), np.tan(ay), -np.ones_like(ax)], axis=1)
    g /= np.linalg.norm(g, axis=1, keepdims=True)
    cols = ["frame", "face_id", "timestamp", "confidence", "success"]
    cols += list(_GAZE) if gaze else []
    cols += list(_POSE) if pose else []
    cols += [f"{a}_r" for a in OPENFACE_AUS] + [f"{a}_c" for a in OPENFACE_PRESENCE]
    lines = [", ".join(cols)]
    r_vals = np.stack([5 * col(a) for a in OPENFACE_AUS], axis=1)
    c_vals = np.stack([col(a) >= 0.2 - 1e-9 for a in OPENFACE_PRESENCE], axis=1)
    for i in range(track.n_frames):
        r = [str(i + 1), "0", f"{i / track.fps:.3f}", "0.98", "1"]
        if gaze:
            r += [f"{x:.6f}" for x in (*g[i], *g[i])] + [f"{ax[i]:.3f}", f"{ay[i]:.3f}"]
        if pose:
            r += ["0.0", "0.0", "0.0", f"{pitch[i]:.3f}", f"{yaw[i]:.3f}", f"{-roll[i]:.3f}"]
        r += [f"{x:.2f}" for x in r_vals[i]] + ["1.0" if x else "0.0" for x in c_vals[i]]
        lines.append(", ".join(r))
    if (head or eyes) and not (pose and gaze):
        log.info("OpenFace CSV without %s: %s not written", "pose" if not pose else "gaze",
                 ", ".join(head if not pose else eyes))
    return atomic_write(path, "\n".join(lines) + "\n")


# -- reading --------------------------------------------------------------------------------------
def _scale(path, r_max: float, two_decimals: bool, scale: str, notes: list[str]) -> float:
    if scale not in SCALES:
        raise ParameterError(f"scale={scale!r} must be one of {', '.join(SCALES)}")
    if scale == "5":
        return 5.0
    if scale == "1":
        if r_max > 1 + 1e-6:
            raise DataError(f"{path}: AU intensities reach {r_max:g}, so they are on OpenFace's "
                            "0–5 scale, not 0–1; drop --scale 1 (or use --scale 5)")
        return 1.0
    if r_max > 1 + 1e-6:
        return 5.0
    if two_decimals:  # RecorderCSV's own number format: OpenFace output of a calm face
        notes.append(f"{path}: every AUxx_r is ≤ 1 (largest {r_max:g}) but written with "
                     "OpenFace's 2 decimals: read on OpenFace's 0–5 scale; if the file is "
                     "normalised to 0–1, pass --scale 1")
        return 5.0
    notes.append(f"{path}: every AUxx_r is ≤ 1 (largest {r_max:g}) with more than 2 decimals: "
                 "read as already normalised to 0–1 (as FACSvatar writes them), not divided by "
                 "5; if this is OpenFace's 0–5 output, pass --scale 5")
    return 1.0


def read_openface_csv(path: str | os.PathLike, *, fill: str = "linear",
                      face_id: int | None = None, scale: str = "auto",
                      fps: float | None = None) -> AUTrack:
    """Read OpenFace output into AUs, head AUs (from the pose) and eye AUs (from the gaze).

    ``scale``: ``"5"`` divides ``AUxx_r`` by 5 (OpenFace's scale), ``"1"`` takes them as
    0–1 (files normalised by e.g. FACSvatar), ``"auto"`` (default) picks 5 when any value
    exceeds 1 or all are written with OpenFace's 2 decimals, else reads 0–1 — with a note in
    ``meta["notes"]`` whenever every value is ≤ 1. Rows with ``success``
    0 are filled (``fill``); the first ``face_id`` is read when there are several. ``fps``
    overrides the rate the timestamps give (image sequences carry 1 ms steps).
    """
    t = read_table(path)
    t.require(("frame", "timestamp", "success"), "an OpenFace CSV (expected 'frame, face_id, "
              "timestamp, confidence, success, …, AU01_r, …')")
    rcols = [(j, h) for j, h in enumerate(t.header) if re.fullmatch(r"AU\d\d_r", h)]
    if not rcols:
        raise DataError(f"{path}:1: no AU intensity columns (AU01_r …)")
    try:
        aus = [parse_au(h[:4]) for _, h in rcols]
    except ParameterError as e:
        raise DataError(f"{path}:1: {e}") from None
    fid_col = t.col("face_id")
    rows = []
    ids = set()
    for line, r in t.rows:
        if len(r) != len(t.header):
            raise DataError(f"{path}:{line}: {len(r)} fields, but the header has "
                            f"{len(t.header)}")
        fid = num(path, line, "face_id", r[fid_col]) if fid_col is not None else 0.0
        ids.add(fid)
        rows.append((line, r, fid))
    notes: list[str] = []
    if face_id is None:
        face_id = int(min(ids)) if ids else 0
        if len(ids) > 1:
            notes.append(f"{path}: {len(ids)} faces; reading face_id {face_id}")
    rows = [x for x in rows if x[2] == face_id]
    if not rows:
        raise DataError(f"{path}: no rows for face_id {face_id}")
    check_frames(len(rows), path)

    def column(name: str) -> np.ndarray:
        j = t.col(name)
        return np.array([num(path, ln, name, r[j]) for ln, r, _ in rows])

    lines = [ln for ln, _, _ in rows]
    times = column("timestamp")
    ok = column("success") > 0.5
    raw = np.stack([column(h) for _, h in rcols], axis=1)
    for k, (_, h) in enumerate(rcols):
        bad = np.flatnonzero((raw[:, k] < -1e-6) | (raw[:, k] > 5 + 1e-6))
        if len(bad):
            raise DataError(f"{path}:{lines[bad[0]]}:{h}: {raw[bad[0], k]:g} is outside "
                            "OpenFace's 0–5 scale")
    two = all(_TWO_DECIMALS.match(r[j]) for _, r, _ in rows for j, _ in rcols)
    s = _scale(path, float(raw[ok].max()) if ok.any() else 0.0, two, scale, notes)
    cols: dict[str, np.ndarray] = {a: np.clip(raw[:, k] / s, 0, 1) for k, a in enumerate(aus)}
    yaw = pitch = None
    if all(t.col(c) is not None for c in ("pose_Rx", "pose_Ry", "pose_Rz")):
        pitch, yaw, roll = (_angles(path, lines, c, column(c)) * sign for c, sign in
                            (("pose_Rx", 1), ("pose_Ry", 1), ("pose_Rz", -1)))
        cols.update(head_aus(yaw, pitch, roll))
    gaze = _gaze_angles(t, column, lines)
    if gaze is not None:
        ax, ay = gaze
        eye_yaw = -ax - (yaw if yaw is not None else 0.0)
        eye_pitch = ay - (pitch if pitch is not None else 0.0)
        cols.update(eye_aus(eye_yaw, eye_pitch))
    chans = tuple(sorted(cols, key=lambda c: (AU_CATALOGUE[c[:4]].number, c)))
    vals = np.stack([cols[c] for c in chans], axis=1).astype(np.float32)
    rate = valid_fps(fps) if fps is not None else fps_from_times(path, times, lines)
    if fps is None and rate > 240:
        notes.append(f"{path}: timestamps say {rate:g} fps (OpenFace writes 1 ms steps for "
                     "image sequences); pass --take-fps with the real rate")
    if not ok.any():
        raise DataError(f"{path}: no frame was tracked (success is 0 on every row)")
    meta = {"source": str(path), "format": "openface", "dropouts": int((~ok).sum()),
            "filled": int((~ok).sum()), "fill": fill, "scale": s, "notes": notes,
            "pose": yaw is not None, "gaze": gaze is not None}
    for n in notes:
        log.info("%s", n)
    return AUTrack(fill_gaps(vals, ok, method=fill), chans, rate, meta)


def _angles(path, lines: list[int], name: str, v: np.ndarray) -> np.ndarray:
    """``v`` (radians) checked to lie within ±2π."""
    bad = np.flatnonzero(np.abs(v) > 2 * np.pi)
    if len(bad):
        raise DataError(f"{path}:{lines[bad[0]]}:{name}: {v[bad[0]]:g} is not an angle in "
                        "radians")
    return v


def _gaze_angles(t, column, lines: list[int]) -> tuple[np.ndarray, np.ndarray] | None:
    """Camera-space gaze angles (``gaze_angle_x/y``, or computed from the two gaze vectors as
    OpenFace does for older files that lack them)."""
    if t.col("gaze_angle_x") is not None and t.col("gaze_angle_y") is not None:
        return tuple(_angles(t.path, lines, c, column(c)) for c in ("gaze_angle_x",
                                                                      "gaze_angle_y"))
    if all(t.col(c) is not None for c in _GAZE[:6]):
        g = sum(np.stack([column(f"gaze_{e}_{a}") for a in "xyz"], axis=1) for e in (0, 1))
        return np.arctan2(g[:, 0], -g[:, 2]), np.arctan2(g[:, 1], -g[:, 2])
    return None
