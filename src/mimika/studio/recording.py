"""Recorded speech in the studio: a recording and its text → timed speech through
:func:`mimika.speech.alignment.align`, cut into sentences like synthesised speech, so playback,
subtitles, behaviour layers and exports treat both alike.

Upload format (one request body, as the live WebSocket frames audio): uint32 LE header length,
a JSON header ``{"text", "lang", "sr", "project", "blend"}``, then mono int16 LE PCM at ``sr``.
"""

from __future__ import annotations

import hashlib
import struct
from typing import Any

import numpy as np

from mimika import limits
from mimika.errors import ParameterError
from mimika.studio.state import SpeechEntry, SpeechSegment, StudioState


def parse_upload(body: bytes) -> tuple[dict[str, Any], np.ndarray]:
    """``(header, audio float32)`` of an upload; malformed bodies raise ParameterError."""
    bad = ParameterError("the recording did not arrive whole; choose the file again")
    if len(body) < 4:
        raise bad
    n = struct.unpack("<I", body[:4])[0]
    if n > len(body) - 4 or n > 64 * 1024:
        raise bad
    try:
        head = limits.loads_json(body[4:4 + n].decode("utf-8"), "the upload's header")
    except UnicodeDecodeError:
        raise bad from None
    pcm = body[4 + n:]
    if not isinstance(head, dict) or len(pcm) % 2:
        raise bad
    text = head.get("text")
    if not isinstance(text, str) or not text.strip():
        raise ParameterError("type the words of the recording into the text box first: the "
                             "studio lines the mouth up with them")
    sr = head.get("sr")
    if not isinstance(sr, int) or not 8000 <= sr <= 96000:
        raise bad
    return head, np.frombuffer(pcm, "<i2").astype(np.float32) / 32768.0


def _slice(utt: Any, i0: int, i1: int, text: str) -> Any:
    """The part of ``utt`` from sample ``i0`` to ``i1`` with its own times from 0."""
    from mimika.speech import Phone, Sentence, Utterance, Word

    t0, t1 = i0 / utt.sr, i1 / utt.sr
    phones = [Phone(p.symbol, max(p.start, t0) - t0, min(p.end, t1) - t0, p.stress)
              for p in utt.phonemes if p.end > t0 and p.start < t1]
    words = [Word(w.text, w.start - t0, w.end - t0, w.offset) for w in utt.words
             if t0 <= 0.5 * (w.start + w.end) < t1]
    return Utterance(utt.audio[i0:i1], utt.sr, phones, words, [Sentence(text, 0.0, t1 - t0)],
                     lang=utt.lang, text=text, meta=dict(utt.meta))


def aligned_entry(state: StudioState, audio: np.ndarray, sr: int, text: str, lang: str, *,
                  fps: float) -> SpeechEntry:
    """The recording aligned to ``text`` as a complete :class:`SpeechEntry`, one segment per
    sentence (cut where the alignment puts the sentence boundaries)."""
    from mimika.speech import mouth_track
    from mimika.speech.alignment import align

    if len(text) > 5000:
        raise ParameterError(f"the text is {len(text):,} characters long; the studio takes at "
                             "most 5,000 at a time")
    with state.espeak_lock:  # the alignment renders the text with espeak-ng
        utt = align(audio, sr=sr, transcript=text, lang=lang)
    digest = hashlib.sha1(audio.tobytes() + f"|{lang}|{text}".encode()).hexdigest()[:20]
    entry = SpeechEntry(digest, text, lang, 0)
    n = len(utt.audio)
    sents = utt.sentences or []
    cuts = [0] + [min(n, max(0, round(s.start * sr))) for s in sents[1:]] + [n]
    cuts = [int(c) for c in np.maximum.accumulate(cuts)]
    names = [s.text for s in sents] or [text]
    for k, name in enumerate(names):
        i0, i1 = cuts[k], cuts[k + 1]
        if i1 <= i0:
            continue
        part = _slice(utt, i0, i1, name)
        entry.segments.append(SpeechSegment(name, 0, i0 / sr, part, mouth_track(part, fps=fps)))
    entry.done = True
    return entry
