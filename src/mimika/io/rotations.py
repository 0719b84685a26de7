"""Head and eye rotations ↔ the head AUs (51–56) and eye AUs (61–64).

One convention inside mimika (the Live Link Face app's, checked on the shared takes), in
radians: **yaw** positive toward the subject's right, **pitch** positive looking down,
**roll** positive tilting toward the subject's right. Each reader converts its tool's
angles to it (``docs/formats.md`` lists the signs per tool). The degrees an AU reaches at
intensity 1 come from ``io/data/arkit_aus.json`` (head 35° yaw, 25° pitch and roll; eyes
30°), the same table the Live Link import uses.
"""

from __future__ import annotations

import numpy as np

from mimika.io.arkit import table

__all__ = ["eye_angles", "eye_aus", "head_angles", "head_aus"]


def _split(angles: dict[str, np.ndarray], spec: dict) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for axis, (neg, pos, deg) in spec.items():
        a = np.asarray(angles[axis], np.float64) / np.radians(deg)
        out[neg] = np.clip(-a, 0.0, 1.0)
        out[pos] = np.clip(a, 0.0, 1.0)
    return out


def _join(col, spec: dict) -> dict[str, np.ndarray]:
    return {axis: (col(pos) - col(neg)) * np.radians(deg) for axis, (neg, pos, deg)
            in spec.items()}


def head_aus(yaw: np.ndarray, pitch: np.ndarray, roll: np.ndarray) -> dict[str, np.ndarray]:
    """Head angles (radians, mimika's convention) → AU51–56 in [0, 1] (clipped at 1)."""
    spec = dict(zip(("yaw", "pitch", "roll"), table()["head"].values(), strict=True))
    return _split({"yaw": yaw, "pitch": pitch, "roll": roll}, spec)


def eye_aus(yaw: np.ndarray, pitch: np.ndarray) -> dict[str, np.ndarray]:
    """Eye-in-head angles (radians) → AU61–64 in [0, 1]."""
    spec = dict(zip(("yaw", "pitch"), table()["eyes"].values(), strict=True))
    return _split({"yaw": yaw, "pitch": pitch}, spec)


def head_angles(col) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Head yaw, pitch, roll (radians) from AU51–56; ``col(code)`` gives a channel (zeros
    when absent)."""
    spec = dict(zip(("yaw", "pitch", "roll"), table()["head"].values(), strict=True))
    a = _join(col, spec)
    return a["yaw"], a["pitch"], a["roll"]


def eye_angles(col) -> tuple[np.ndarray, np.ndarray]:
    """Eye-in-head yaw, pitch (radians) from AU61–64."""
    spec = dict(zip(("yaw", "pitch"), table()["eyes"].values(), strict=True))
    a = _join(col, spec)
    return a["yaw"], a["pitch"]
