"""Text → sentences → speech audio with phoneme, word and sentence timing (espeak-ng).

Each sentence is synthesised on its own (offline, as seed 004 §4.2 does, so that the viseme
layer can look ahead) and the results are concatenated.
"""

from __future__ import annotations

import logging
import re

import numpy as np

from mimika.errors import ParameterError
from mimika.limits import check_speech
from mimika.speech.phonemes import strip_stress
from mimika.speech.utterance import Phone, Sentence, Utterance, Word

log = logging.getLogger(__name__)

#: abbreviations that end with a dot but do not end a sentence (lower case, without the dot)
_ABBREV = {
    "dr", "mr", "mrs", "ms", "prof", "st", "vs", "etc", "e.g", "i.e", "no", "nr", "fig", "approx",
    "z.b", "bzw", "usw", "ca", "vgl", "hr", "fr", "str", "d.h", "u.a", "inż", "np", "ok",
    "tzn", "wg", "ul", "itd", "itp", "tj", "jr", "sr", "co", "inc", "ltd", "a.m", "p.m",
}
_SENT_END = re.compile(r"[.!?…]+[\"'»”)\]]*(?=\s+|$)")


def split_sentences(text: str) -> list[tuple[str, int]]:
    """Split ``text`` into sentences; returns ``[(sentence, char_offset), …]``.

    Breaks after ``. ! ? …`` followed by white space, except after common abbreviations
    (``Dr.``, ``z.B.``, ``np.`` …) and single capital initials; blank lines also break.
    """
    out: list[tuple[str, int]] = []
    for para in re.finditer(r"\S(?:.*?\S)?(?=\s*\n\s*\n|\s*$)", text, flags=re.S):
        start = para.start()
        seg = para.group(0)
        pos = 0
        for m in _SENT_END.finditer(seg):
            before = seg[pos:m.start()].split()
            last = before[-1].lower().rstrip(".") if before else ""
            if m.group(0).startswith(".") and len(m.group(0)) == 1 and (
                last in _ABBREV or (len(last) == 1 and last.isalpha())
            ):
                continue
            piece = seg[pos:m.end()]
            s = piece.strip()
            if s:
                out.append((s, start + pos + (len(piece) - len(piece.lstrip()))))
            pos = m.end()
        rest = seg[pos:]
        if rest.strip():
            out.append((rest.strip(), start + pos + (len(rest) - len(rest.lstrip()))))
    return out


def events_to_phones(events, *, n_samples: int, sr: int, t0: float = 0.0) -> list[Phone]:
    """Turn raw espeak phoneme events into phones tiling the audio (times offset by ``t0`` s).

    ``events`` are ``(type, text_position, length, sample, payload)`` tuples as produced by
    :func:`mimika.speech.espeak.synth`. Words are timed from the phones by
    :mod:`mimika.speech.words` (espeak's word events do not follow expanded text).
    """
    from mimika.speech.espeak import EV_PHONEME

    starts: list[tuple[int, str, int]] = []
    for typ, _tpos, _length, sample, payload in events:
        if typ == EV_PHONEME:
            sym, stress = strip_stress(str(payload))
            if not sym or (sym.startswith("(") and sym.endswith(")")):
                continue  # language-switch markers such as "(en)"
            if sym.startswith("_"):
                sym = "_"
            starts.append((int(sample), sym, stress))
    starts.sort(key=lambda s: s[0])
    bounds: list[tuple[int, int, str, int]] = []
    prev = 0
    if starts and starts[0][0] > 0:
        bounds.append((0, starts[0][0], "_", 0))
    for i, (s, sym, st) in enumerate(starts):
        e = starts[i + 1][0] if i + 1 < len(starts) else n_samples
        s, e = max(s, prev), min(max(e, s), n_samples)
        if e > s:
            if bounds and sym == "_" and bounds[-1][2] == "_":
                bounds[-1] = (bounds[-1][0], e, "_", 0)
            else:
                bounds.append((s, e, sym, st))
            prev = e
    if bounds and bounds[-1][1] < n_samples:
        s, _, sym, st = bounds[-1]
        if sym == "_":
            bounds[-1] = (s, n_samples, "_", 0)
        else:
            bounds.append((bounds[-1][1], n_samples, "_", 0))
    if not bounds and n_samples > 0:
        bounds = [(0, n_samples, "_", 0)]
    return [Phone(sym, t0 + s / sr, t0 + e / sr, st) for s, e, sym, st in bounds]


def synthesize(text: str, *, lang: str = "en", voice: str | None = None, rate: int = 175,
               pitch: int = 50, volume: int = 100, ssml: bool = False) -> Utterance:
    """Speak ``text`` with espeak-ng; return audio (float32 mono, 22 050 Hz) and timing.

    Parameters
    ----------
    text : str
        Plain text (split into sentences, each synthesised on its own) or, with ``ssml=True``,
        an SSML document (see :mod:`mimika.speech.ssml`: break, prosody, emphasis, sub,
        phoneme, say-as, lang, voice, audio). Words carry the text as written.
    lang : str
        espeak-ng language code: ``en``, ``en-us``, ``de``, ``pl`` … (``mimika voices``).
    voice : str, optional
        A variant (``f3``, ``m2``, ``klatt``), ``lang+variant``, or a voice name.
    rate : int
        Words per minute, 80–450 (espeak default 175).
    pitch : int
        Base pitch 0–100 (default 50).

    Returns
    -------
    Utterance
        ``audio`` shape (n_samples,), ``sr`` 22 050; phones tile the whole audio.
    """
    from mimika.speech import espeak
    from mimika.speech.words import tokens, word_times

    if not isinstance(text, str) or not text.strip():
        raise ParameterError("text is empty; give at least one word to speak")
    check_speech(text, rate)  # before synthesising (mimika.limits)
    code = espeak.check_lang(lang)
    if ssml:
        from mimika.speech.ssml import parse, speak

        return speak(parse(text), lang=code, voice=voice, rate=rate, pitch=pitch,
                     volume=volume)[0]
    pieces = split_sentences(text)
    if not pieces:
        raise ParameterError("text is empty; give at least one word to speak")
    chunks: list[np.ndarray] = []
    phones: list[Phone] = []
    words: list[Word] = []
    sents: list[Sentence] = []
    n_total = 0
    sr = espeak.sample_rate()
    for sent, char0 in pieces:
        raw = espeak.synth(sent, lang=code, voice=voice, rate=rate, pitch=pitch, volume=volume)
        sr = raw.sr
        t0 = n_total / sr
        ph = events_to_phones(raw.events, n_samples=len(raw.audio), sr=sr, t0=t0)
        ws = word_times(ph, tokens(sent, offset=char0), lang=code)
        if phones and ph and phones[-1].is_pause and ph[0].is_pause:
            phones[-1] = Phone("_", phones[-1].start, ph[0].end)
            ph = ph[1:]
        phones += ph
        words += ws
        chunks.append(raw.audio)
        n_total += len(raw.audio)
        sents.append(Sentence(sent, t0, n_total / sr))
    audio = (np.concatenate(chunks).astype(np.float32) / 32768.0) if chunks else np.zeros(0)
    log.debug("synthesised %d sentences, %.2f s, %d phones", len(sents), n_total / sr,
              len(phones))
    if not any(not p.is_pause for p in phones):
        log.warning("espeak-ng produced no phonemes for %r", text[:40])
    return Utterance(audio.astype(np.float32), sr, phones, words, sents, lang=code, text=text,
                     meta={"source": "espeak-ng", "voice": voice or code, "rate": rate,
                           "pitch": pitch})
