"""Lip-sync from an agent's own audio as it streams in (``listen``).

Audio arrives in chunks (any rate: resampled to 16 kHz). Whenever :data:`HOP` s of new audio
have come, the last :data:`WINDOW` s are run through the phone recogniser (pocketsphinx's
en-us phone model on the whole window, as ``mimika align`` without a transcript does: its
incremental mode, tried, closed the lips for half as many /p b m/) and the mouth track of
those phones is computed; frames up to :data:`LOOKAHEAD` s before the newest sample are final
and sent. So a frame leaves the server ``LOOKAHEAD`` to ``HOP + LOOKAHEAD`` s of audio after
its instant, plus the decoding time (≈ 85 ms per window). Only the window is kept: memory is
flat however long the stream runs.
"""

from __future__ import annotations

import numpy as np

from mimika import limits
from mimika.errors import ParameterError
from mimika.serve.speech import FPS

SR = 16000
WINDOW = 1.5  #: seconds of audio decoded each time (left context for the newest frames)
HOP = 0.2  #: decode when this much new audio has arrived (s; a stream may choose 0.05…1)
LOOKAHEAD = 0.1  #: a frame is final this long after its instant (s; a stream may choose 0…1)


class ListenStream:
    """One ``listen`` stream: feed PCM chunks, get the frames that became final."""

    def __init__(self, sr: int, *, lang: str = "en", fps: float = FPS, hop: float = HOP,
                 lookahead: float = LOOKAHEAD):
        if not 4000 <= sr <= 96000:
            raise ParameterError(f"listen: \"sr\" {sr} must be within 4000…96000 Hz")
        self.sr, self.lang, self.fps = int(sr), lang, fps
        self.hop, self.lookahead = hop, lookahead
        self.buf = np.zeros(0, np.float32)  # the last WINDOW s (at SR)
        self.offset = 0.0  # stream time of buf[0] (s)
        self.received = 0.0  # seconds received
        self.decoded = 0.0  # stream time of the last decode
        self.sent = 0  # frames sent

    def feed(self, pcm: np.ndarray, *, final: bool = False) -> list[dict]:
        """Add ``pcm`` (float32 mono at the stream's rate); the frames now final."""
        from mimika.speech.audio import resample

        a = np.asarray(pcm, np.float32)
        self.received += len(a) / self.sr
        limits.check_recording(self.received, self.sr, 1, "the listen stream")
        if self.sr != SR and len(a):
            a = resample(a, orig_sr=self.sr, target_sr=SR)
        self.buf = np.concatenate([self.buf, a])
        if not final and self.received - self.decoded < self.hop:
            return []
        self.decoded = self.received
        out = self._frames(final)
        keep = int(WINDOW * SR)
        if len(self.buf) > keep:
            self.offset += (len(self.buf) - keep) / SR
            self.buf = self.buf[-keep:]
        return out

    def _frames(self, final: bool) -> list[dict]:
        from mimika.serve.frames import frames
        from mimika.speech import Phone, Utterance, mouth_track
        from mimika.speech.sphinx import recognise_phones
        from mimika.tracks import AUTrack

        end = self.offset + len(self.buf) / SR
        upto = end if final else end - self.lookahead
        k_end = int(np.floor(upto * self.fps + 1e-9)) + 1
        if k_end <= self.sent:
            return []
        ks = int(np.ceil(self.offset * self.fps - 1e-9))  # the window's first whole frame
        start = ks / self.fps
        skip = start - self.offset
        if len(self.buf) >= 0.1 * SR:
            phones = [Phone(p.symbol, max(p.start - skip, 0.0), p.end - skip, p.stress)
                      for p in recognise_phones(self.buf, sr=SR) if p.end > skip]
        else:
            phones = [Phone("_", 0.0, end - start)]
        track = mouth_track(Utterance(np.zeros(0, np.float32), SR, phones, lang=self.lang),
                            fps=self.fps)
        k0, k1 = max(self.sent, ks), min(k_end, ks + track.n_frames)
        if k1 <= k0:
            return []
        self.sent = k1
        part = track.values[k0 - ks:k1 - ks]
        return frames(AUTrack(part, track.channels, self.fps), t0=k0 / self.fps)
