"""Lip-sync from an agent's own audio as it streams in (``listen``).

Audio arrives in chunks (any rate, no resampling). :class:`mimika.speech.streaming.Recogniser`
decides the mouth class of every 10 ms as soon as it has heard a fixed look-ahead past it
(≈ 72 ms: a 12.5 ms half window, 4 frames of model context, a 2-frame decoder lag) and never
revises it. The face frames (at :data:`FPS`) are the mouth track of those classes
(:func:`mimika.speech.coarticulation.mouth_frames`, the same Cohen–Massaro blend and closure
rules as offline); a frame is sent once the classes :data:`LOOKAHEAD` s past it are known —
segments that start later (their anticipation) are not yet heard. Only the segments within
the coarticulation reach are kept: memory is flat however long the stream runs.

Offline, :func:`mimika.speech.recognise` gives the same classes for the whole recording.
"""

from __future__ import annotations

import math

import numpy as np

from mimika import limits
from mimika.errors import ParameterError
from mimika.serve.speech import FPS

LOOKAHEAD = 0.09  #: a frame is sent once this much audio past it has come (s; 0…1)
HOP = 0.0  #: send at most this often (s of audio; 0: whenever frames are final)
EXTEND = 0.1  #: an open segment is taken to last at least this long (s): a typical phone


class ListenStream:
    """One ``listen`` stream: feed PCM chunks, get the frames that became final."""

    def __init__(self, sr: int, *, lang: str = "en", fps: float = FPS, hop: float = HOP,
                 lookahead: float = LOOKAHEAD):
        from mimika.speech.coarticulation import max_reach
        from mimika.speech.streaming import Recogniser

        if not limits.MIN_SAMPLE_RATE <= sr <= 96000:
            raise ParameterError(f"listen: \"sr\" {sr} must be within 4000…96000 Hz")
        self.sr, self.lang, self.fps = int(sr), lang, fps
        self.rec = Recogniser(self.sr)
        self.hop = hop
        #: past the recogniser's own look-ahead, how far the known classes must reach
        self.extra = max(0.0, lookahead - self.rec.lookahead)
        self.runs: list[list] = []  # [class, first 10 ms frame, end frame] of recent segments
        self.samples = 0  # samples received
        self.last_send = 0.0  # seconds of audio when frames were last sent
        self.sent = 0  # face frames sent
        self.reach = max_reach()  # older segments no longer move a frame

    @property
    def received(self) -> float:
        """Seconds of audio received."""
        return self.samples / self.sr

    @property
    def lookahead(self) -> float:
        """Seconds of audio past a frame's instant before it is sent."""
        return self.rec.lookahead + self.extra

    def feed(self, pcm: np.ndarray, *, final: bool = False) -> list[dict]:
        """Add ``pcm`` (float32 mono at the stream's rate); the frames now final."""
        from mimika.speech.phonemes import classify
        from mimika.speech.streaming import RATE, SYMBOL

        a = np.asarray(pcm, np.float32)
        self.samples += len(a)
        limits.check_recording(self.received, self.sr, 1, "the listen stream")
        k = self.rec.n
        for c in self.rec.push(a, final=final):
            cls = classify(SYMBOL[c], self.lang)[0]
            if self.runs and self.runs[-1][0] == cls:
                self.runs[-1][2] += 1
            else:
                self.runs.append([cls, k, k + 1])
            k += 1
        now = self.received
        if not final and now - self.last_send < self.hop:
            return []
        if final:
            k_end = max(1, math.ceil(now * self.fps - 1e-9))
        else:
            known = self.rec.n / RATE - self.extra  # frames up to here are final
            k_end = math.floor(known * self.fps + 1e-9) + 1
        if k_end <= self.sent:
            return []
        self.last_send = now
        out = self._frames(self.sent, k_end, end=now if final else None)
        self.sent = k_end
        keep = (self.sent - 1) / self.fps - self.reach  # a frame spans ± half a frame
        while len(self.runs) > 1 and self.runs[0][2] / RATE < keep:
            self.runs.pop(0)
        return out

    def _frames(self, k0: int, k1: int, end: float | None) -> list[dict]:
        from mimika.serve.frames import frames
        from mimika.speech.coarticulation import mouth_aus, mouth_frames
        from mimika.speech.export import viseme_cues
        from mimika.speech.phonemes import Segment
        from mimika.speech.streaming import RATE, SYMBOL
        from mimika.speech.utterance import Phone, Utterance
        from mimika.tracks import AUTrack

        segs = [Segment(c, s / RATE, e / RATE, SYMBOL[c], 2 if c.startswith("vowel_") else 0)
                for c, s, e in self.runs]
        if segs:  # the last segment ends with the stream, else lasts at least EXTEND s
            last = segs[-1]
            e = max(min(last.end, end), last.start) if end is not None else \
                max(last.end, last.start + EXTEND)
            segs[-1] = Segment(last.cls, last.start, e, last.symbol, last.stress)
        vals = mouth_frames(segs, fps=self.fps, k0=k0, n=k1 - k0)
        t0 = k0 / self.fps
        u = Utterance(np.zeros(0, np.float32), 16000,  # SYMBOL is each class in English
                      [Phone(s.symbol, s.start - t0, s.end - t0, s.stress) for s in segs])
        return frames(AUTrack(vals, mouth_aus(), self.fps), t0=t0, cues=viseme_cues(u))
