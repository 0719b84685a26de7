"""AU tracks as the wire frames of ``mimika serve``: ``{"t": seconds, …weights}``.

Every frame carries the track's AU values (``AU12``, ``AU61`` …), the ARKit-52 blendshape
weights mimika's AU → ARKit table gives them (ARKit's names, as Ready Player Me and VRoid
avatars carry them: ``jawOpen``, ``mouthSmileLeft`` …; zeros left out), the head and eye
rotations in radians (``HeadYaw``, ``HeadPitch``, ``HeadRoll``, ``LeftEyeYaw`` …) and, for
speech, the Oculus viseme sounding then (``viseme``: ``PP``, ``aa`` …).
"""

from __future__ import annotations

import functools
import json
from collections.abc import Sequence
from importlib import resources
from typing import Any

import numpy as np

from mimika.tracks import AUTrack

DIGITS = 3  #: decimals of every weight on the wire


def frames(track: AUTrack, *, t0: float = 0.0, cues: Sequence[dict[str, Any]] = ()
           ) -> list[dict[str, Any]]:
    """The frames of ``track`` (frame i at ``t0 + i / fps`` s), with the viseme of ``cues``
    (``viseme_cues`` of the same speech, sentence-local seconds)."""
    from mimika.io.arkit import ARKIT_52, ROTATIONS, aus_to_arkit

    arkit = [n[0].lower() + n[1:] for n in ARKIT_52]  # ARKit's own names: jawOpen …
    v = np.asarray(track.values, np.float64)
    shapes, rot = aus_to_arkit(v, track.channels) if track.channels else (
        np.zeros((len(v), 52)), np.zeros((len(v), 9)))
    starts = np.array([c["start"] for c in cues]) if cues else np.zeros(0)
    out = []
    for i in range(len(v)):
        t = i / track.fps
        f: dict[str, Any] = {"t": round(t0 + t, 4)}
        f.update({c: round(float(x), DIGITS) for c, x in zip(track.channels, v[i], strict=True)})
        f.update({n: round(float(x), DIGITS) for n, x in zip(arkit, shapes[i], strict=True)
                  if x > 5e-4})
        f.update({n: round(float(x), 4) for n, x in zip(ROTATIONS, rot[i], strict=True)
                  if abs(x) > 1e-5})
        if len(starts):
            k = int(np.searchsorted(starts, t, side="right")) - 1
            if k >= 0 and t < cues[k]["end"]:
                f["viseme"] = cues[k]["value"]
        out.append(f)
    return out


@functools.cache
def mood_faces() -> dict[str, tuple[str, float] | None]:
    """The face each mood sets (``serve/data/faces.json``)."""
    d = json.loads(resources.files("mimika.serve").joinpath("data/faces.json")
                   .read_text("utf-8"))["moods"]
    return {k: (tuple(v) if v else None) for k, v in d.items()}


def envelope(aus: dict[str, float], *, duration: float, fade: float, fps: float) -> AUTrack:
    """``aus`` faded in over ``fade`` s, held, and faded out to end at ``duration`` s."""
    n = max(2, round(duration * fps) + 1)
    t = np.arange(n) / fps
    k = max(fade, 1e-3)
    w = np.clip(np.minimum(t / k, (duration - t) / k), 0.0, 1.0)
    w = 0.5 - 0.5 * np.cos(np.pi * w)
    chans = tuple(aus)
    vals = np.outer(w, [aus[c] for c in chans]).astype(np.float32)
    return AUTrack(vals, chans, fps)
