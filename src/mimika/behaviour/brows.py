"""Eyebrow raises (AU01 + AU02, small) on accented words and at the end of questions.

Accented words: words of at least ``min_word_letters`` letters (or with digits) that hold a
primary stress; a ``probability`` share of them, ``min_gap_s`` apart, raise the brows by
``raise`` for ``duration_s`` around the stressed vowel. Questions raise them by
``question_raise`` over their last ``question_tail_s``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mimika.behaviour._shapes import bump, plateau
from mimika.behaviour.cues import SpeechCues
from mimika.tracks import AUTrack

CHANNELS = ("AU01", "AU02")


def accented_words(cues: SpeechCues, *, min_letters: int = 6) -> list[tuple[float, float]]:
    """(word start, stress time) of content words carrying a primary stress."""
    st = np.asarray(cues.stresses)
    out = []
    for w0, w1, text in cues.words:
        letters = sum(ch.isalpha() for ch in text)
        if letters < min_letters and not any(ch.isdigit() for ch in text):
            continue
        inside = st[(st >= w0 - 1e-6) & (st < w1)] if len(st) else st
        out.append((w0, float(inside[0]) if len(inside) else w0 + 0.3 * (w1 - w0)))
    return out


def brow_layer(cues: SpeechCues, *, fps: float, rng: np.random.Generator,
               params: dict[str, Any]) -> AUTrack:
    """AU01 + AU02 track, shape (n_frames, 2); ``meta["raises"]`` lists raise times (s)."""
    p = params["brows"]
    t = cues.times(fps=fps)
    v = np.zeros_like(t)
    last = -1e9
    raises = []
    for _, ts in accented_words(cues, min_letters=p["min_word_letters"]):
        if ts - last < p["min_gap_s"] or rng.random() >= p["probability"]:
            continue
        v = np.maximum(v, p["raise"] * rng.uniform(0.75, 1.15) * bump(t, ts, p["duration_s"]))
        raises.append(ts)
        last = ts
    for s0, s1, text in cues.sentences:
        if text.rstrip().endswith("?"):
            end = max((w[1] for w in cues.words if s0 <= w[0] < s1), default=s1)
            v = np.maximum(v, p["question_raise"] * plateau(t, end - p["question_tail_s"],
                                                            end, 0.25))
    v = np.clip(v, 0, 1).astype(np.float32)
    return AUTrack(np.stack([v, 0.85 * v], 1), CHANNELS, fps,
                   {"layer": "brows", "raises": raises})
