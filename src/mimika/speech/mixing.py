"""Speech + emotion → one AU track, by per-AU priority rules (``visemes.json`` → ``combine``).

* ``speech`` AUs (lip shape and jaw: AU10 16 18 22 24 25 26 27 28): the speech value while
  talking; inside long pauses (≥ 0.35 s, 0.1 s ramps) the emotion's value shows through.
* ``max_unrounded`` (AU12 13 14 20): ``max(speech, emotion·(1 − 0.7·rounding))`` where rounding
  is the speech track's ``max(AU18, AU22)`` — a smile persists but gives way to /u o w ʃ/.
* ``max`` (AU17, AU23): the larger value.
* every other AU (brows, eyes, cheeks, nose, head …): the emotion's value.

Afterwards the closure rules are applied again on the combined frames (with the combined
AU12, so a smile needs more lip press), so /p b m/ close even on a broad smile.
"""

from __future__ import annotations

import numpy as np

from mimika.speech.coarticulation import apply_closures
from mimika.speech.phonemes import viseme_table
from mimika.tracks import AUTrack


def speech_activity(pauses, *, fps: float, n_frames: int) -> np.ndarray:
    """1 while talking, 0 inside pauses ≥ ``pause_min`` (ramped); shape (n_frames,)."""
    cfg = viseme_table()["combine"]
    t = np.arange(n_frames) / fps
    a = np.ones(n_frames)
    r = cfg["pause_ramp"]
    for s, e in pauses:
        if e - s < cfg["pause_min"]:
            continue
        inside = np.minimum(t - s, e - t)  # distance into the pause
        a = np.minimum(a, np.clip(1.0 - inside / r, 0.0, 1.0))
    return a


def _fit(track: AUTrack, *, fps: float, n_frames: int) -> np.ndarray:
    tr = track if track.fps == fps else track.resample(fps=fps)
    v = tr.values
    if len(v) >= n_frames:
        return v[:n_frames]
    pad = np.repeat(v[-1:] if len(v) else np.zeros((1, v.shape[1])), n_frames - len(v), axis=0)
    return np.vstack([v, pad])


def combine(speech: AUTrack, emotion: AUTrack) -> AUTrack:
    """Mix a speech mouth track with an emotion/expression track (same or any fps).

    The result has the speech track's fps and length (the emotion track is resampled, and
    held at its last frame if shorter) and the union of both channel sets. Closure windows
    and pauses are read from ``speech.meta`` (as :func:`mouth_track` writes them); without
    them the whole track counts as talking and bilabial closures are taken from frames where
    the speech track has lips pressed and not parted.
    """
    cfg = viseme_table()["combine"]
    fps, n = speech.fps, speech.n_frames
    emo = _fit(emotion, fps=fps, n_frames=n)
    chans = list(speech.channels) + [c for c in emotion.channels if c not in speech.channels]
    out = np.zeros((n, len(chans)))
    act = speech_activity(speech.meta.get("pauses", []), fps=fps, n_frames=n)
    sp = {c: speech.values[:, i].astype(np.float64) for i, c in enumerate(speech.channels)}
    em = {c: emo[:, i].astype(np.float64) for i, c in enumerate(emotion.channels)}
    zero = np.zeros(n)
    rounding = np.maximum(sp.get("AU18", zero), sp.get("AU22", zero))
    for j, c in enumerate(chans):
        s, e = sp.get(c), em.get(c)
        if s is None or e is None:
            out[:, j] = s if s is not None else e
            continue
        rule = cfg["rules"].get(c, "emotion")
        if rule == "speech":
            out[:, j] = act * s + (1 - act) * e
        elif rule == "max":
            out[:, j] = np.maximum(s, e)
        elif rule == "max_unrounded":
            out[:, j] = np.maximum(s, e * (1 - cfg["rounding_attenuation"] * rounding))
        else:
            out[:, j] = e
    bil = speech.meta.get("bilabial")
    lab = speech.meta.get("labiodental", [])
    if bil is None and {"AU24", "AU25"} <= set(speech.channels):
        closed = (sp["AU24"] >= 0.4) & (sp["AU25"] <= 1e-6)
        bil = [(i / fps, i / fps, i / fps) for i in np.nonzero(closed)[0]]
    if {"AU24", "AU25", "AU26"} <= set(chans):
        out = apply_closures(out, chans, fps=fps, bilabial=bil or [], labiodental=lab)
    meta = {**emotion.meta, **speech.meta, "combined": True}
    return AUTrack(np.clip(out, 0, 1).astype(np.float32), tuple(chans), fps, meta)
