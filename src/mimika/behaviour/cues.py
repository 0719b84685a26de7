"""What the behaviour layers react to: the timing of an utterance, boiled down.

:class:`SpeechCues` holds sentences, words, stressed syllables, pauses and paragraph starts in
seconds; every layer takes one. It is built from a :class:`~mimika.speech.Utterance` (TTS or
alignment) by :func:`cues_from_utterance`, or by hand in tests.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mimika.errors import ParameterError

#: pauses shorter than this (s) are not phrase boundaries
MIN_PAUSE = 0.12


@dataclass(frozen=True)
class SpeechCues:
    """Timing of a spoken text, in seconds.

    Attributes
    ----------
    duration : length of the audio (s), > 0
    sentences : (start, end, text) per sentence
    words : (start, end, text) per word
    stresses : onset times of primary-stressed vowels
    pauses : (start, end) of silent stretches ≥ :data:`MIN_PAUSE`
    paragraph_starts : start times of the sentences that open a paragraph
    lang : language code (``en``, ``de``, ``pl`` …)
    """

    duration: float
    sentences: tuple[tuple[float, float, str], ...] = ()
    words: tuple[tuple[float, float, str], ...] = ()
    stresses: tuple[float, ...] = ()
    pauses: tuple[tuple[float, float], ...] = ()
    paragraph_starts: tuple[float, ...] = ()
    lang: str = "en"
    meta: dict[str, Any] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        d = float(self.duration)
        if not (math.isfinite(d) and d > 0):
            raise ParameterError(f"duration={self.duration!r} s must be > 0")
        object.__setattr__(self, "duration", d)

    def n_frames(self, *, fps: float) -> int:
        """Frames covering the duration: ``ceil(duration · fps)`` (frame i at i / fps)."""
        return max(1, math.ceil(self.duration * fps - 1e-9))

    def times(self, *, fps: float) -> np.ndarray:
        """Frame times in seconds, shape (n_frames,)."""
        return np.arange(self.n_frames(fps=fps)) / fps

    @property
    def boundaries(self) -> list[float]:
        """Communicative events: sentence ends and the starts of pauses (phrase ends), sorted."""
        ts = [s[1] for s in self.sentences] + [p[0] for p in self.pauses if p[0] > 0.05]
        ts = sorted(t for t in ts if 0 < t < self.duration)
        out: list[float] = []
        for t in ts:
            if not out or t - out[-1] > 0.2:
                out.append(t)
        return out

    def activity(self, *, fps: float, ramp: float = 0.25) -> np.ndarray:
        """1 while speaking, easing to 0 inside pauses (cosine ramps of ``ramp`` s); (T,)."""
        t = self.times(fps=fps)
        a = np.ones_like(t)
        if not self.words:
            return np.zeros_like(t)
        spans = [(0.0, self.words[0][0])] + [(p0, p1) for p0, p1 in self.pauses]
        spans.append((self.words[-1][1], self.duration + 10.0))
        for s, e in spans:
            if e - s < 0.2:
                continue
            inside = np.minimum(t - s, e - t)
            w = np.clip(inside / max(ramp, 1e-6), 0.0, 1.0)
            a = np.minimum(a, 0.5 + 0.5 * np.cos(np.pi * w))
        return a


def cues_from_utterance(utterance: Any, *, paragraph_starts: Sequence[float] = ()) -> SpeechCues:
    """:class:`SpeechCues` of an utterance (``.phonemes``, ``.words``, ``.sentences``)."""
    stresses = tuple(p.start for p in utterance.phonemes if p.stress == 2 and not p.is_pause)
    pauses = tuple((p.start, p.end) for p in utterance.phonemes
                   if p.is_pause and p.duration >= MIN_PAUSE)
    return SpeechCues(
        duration=utterance.duration,
        sentences=tuple((s.start, s.end, s.text) for s in utterance.sentences),
        words=tuple((w.start, w.end, w.text) for w in utterance.words),
        stresses=stresses,
        pauses=pauses,
        paragraph_starts=tuple(float(t) for t in paragraph_starts),
        lang=str(getattr(utterance, "lang", "en")),
    )
