"""Text → sentences → speech audio with phoneme, word and sentence timing.

Two engines: a Piper neural voice (:mod:`mimika.speech.piper`, timed by the model) where
one speaks the language, espeak-ng (timed by its phoneme events) for every other language.

Each sentence is synthesised on its own (offline, as seed 004 §4.2 does, so that the viseme
layer can look ahead) and the results are concatenated.
"""

from __future__ import annotations

import functools
import json
import logging
import os
import re
from importlib import resources
from typing import TYPE_CHECKING

import numpy as np

from mimika.errors import ParameterError
from mimika.limits import check_speech
from mimika.speech.phonemes import strip_stress
from mimika.speech.utterance import Phone, Sentence, Utterance, Word

if TYPE_CHECKING:
    from mimika.speech.piper import VoiceInfo

log = logging.getLogger(__name__)

ENGINES = ("auto", "espeak", "piper")
ENV_ENGINE = "MIMIKA_TTS"  #: default engine for every command (auto | espeak | piper)
SENTENCE_PAUSE = 0.3  #: seconds of silence at least between two spoken sentences

@functools.cache
def sentence_abbreviations() -> tuple[frozenset[str], frozenset[str]]:
    """Abbreviations after which a '.' ends no sentence, in any language, and those of them
    that may end one before a capitalised word (``data/sentence_ends.json``)."""
    path = resources.files("mimika.speech").joinpath("data/sentence_ends.json")
    d = json.loads(path.read_text(encoding="utf-8"))
    return frozenset(d["no_break"]), frozenset(d["may_end"])


_SENT_END = re.compile(r"[.!?…]+[\"'»”)\]]*(?=\s+|$)")


def split_sentences(text: str, lang: str = "en") -> list[tuple[str, int]]:
    """Split ``text`` into sentences; returns ``[(sentence, char_offset), …]``.

    Breaks after ``. ! ? …`` followed by white space, except after common abbreviations
    (``Dr.``, ``z.B.``, ``np.`` …), single capital initials and what
    :func:`mimika.speech.normalize.no_break_after` knows for ``lang`` (German ordinals:
    "am 3. Oktober"); blank lines also break.
    """
    from mimika.speech.normalize import no_break_after

    abbreviations, may_end = sentence_abbreviations()
    out: list[tuple[str, int]] = []
    for para in re.finditer(r"\S(?:.*?\S)?(?=\s*\n\s*\n|\s*$)", text, flags=re.S):
        start = para.start()
        seg = para.group(0)
        pos = 0
        for m in _SENT_END.finditer(seg):
            before = seg[pos:m.start()].split()
            last = before[-1].lower().rstrip(".") if before else ""
            after = seg[m.end():].lstrip()[:1]
            if m.group(0).startswith(".") and len(m.group(0)) == 1 and (
                (last in abbreviations and not (last in may_end and after.isupper()))
                or (len(last) == 1 and last.isalpha())
                or no_break_after(seg, m.start(), lang)
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


def choose_engine(engine: str | None, lang: str, voice: str | None
                  ) -> tuple[str, VoiceInfo | None]:
    """Which engine speaks: ``("piper", voice)`` or ``("espeak", None)``.

    ``engine`` ``auto`` (default, or ``$MIMIKA_TTS``): a Piper voice when ``voice`` names one
    (a path to ``.onnx`` or a voice name) or, without ``voice``, when one speaks ``lang`` (the
    bundled English voice, or one in the voice folders); espeak-ng otherwise. ``espeak`` and
    ``piper`` force one (``piper`` without a voice for ``lang`` is an error).
    """
    from mimika.speech import piper

    eng = (engine or os.environ.get(ENV_ENGINE) or "auto").strip().lower()
    if eng not in ENGINES:
        raise ParameterError(f"unknown speech engine {eng!r}; use {', '.join(ENGINES)}")
    if eng == "espeak":
        return "espeak", None
    if voice and (voice.lower().endswith(".onnx") or os.sep in voice) and not piper.available():
        raise ParameterError(f"voice {voice!r} is a Piper voice, and Piper is not installed; "
                             "run: pip install 'mimika[speech]'")
    info = piper.find_voice(voice) if voice and piper.available() else None
    if info is None and not voice:
        info = piper.default_voice(lang)
    if info is not None:
        return "piper", info
    if eng == "piper":
        where = " or ".join(str(d) for d in piper.voice_dirs())
        what = f"named {voice!r}" if voice else f"for language {lang!r}"
        raise ParameterError(f"no Piper voice {what}; put NAME.onnx and NAME.onnx.json in "
                             f"{where}, give --voice PATH.onnx, or use --engine espeak")
    if not voice:
        log.info("no neural voice for %s; speaking with espeak-ng", lang)
    return "espeak", None


def _espeak_sentence(sent: str, char0: int, *, lang: str, voice: str | None, rate: int,
                     pitch: int, volume: int) -> Utterance:
    from mimika.speech import espeak
    from mimika.speech.words import read_aloud, word_times

    said, toks = read_aloud(sent, lang, offset=char0)
    raw = espeak.synth(said, lang=lang, voice=voice, rate=rate, pitch=pitch, volume=volume)
    ph = events_to_phones(raw.events, n_samples=len(raw.audio), sr=raw.sr)
    ws = word_times(ph, toks, lang=lang)
    dur = len(raw.audio) / raw.sr
    return Utterance(raw.audio.astype(np.float32) / 32768.0, raw.sr, ph, ws,
                     [Sentence(sent, 0.0, dur)], lang=lang, text=sent)


def join_sentences(parts: list[Utterance], *, pause: float = SENTENCE_PAUSE
                   ) -> tuple[np.ndarray, list[Phone], list[Word], list[Sentence]]:
    """Audio and timing of sentences spoken one after another, with at least ``pause`` s of
    silence between two (the pauses the voice left at their ends count)."""
    chunks: list[np.ndarray] = []
    phones: list[Phone] = []
    words: list[Word] = []
    sents: list[Sentence] = []
    n = 0
    for u in parts:
        sr = u.sr
        if phones:
            lead = u.phonemes[0].duration if u.phonemes and u.phonemes[0].is_pause else 0.0
            tail = phones[-1].duration if phones[-1].is_pause else 0.0
            k = round(max(pause - lead - tail, 0.0) * sr)
            if k:
                chunks.append(np.zeros(k, np.float32))
                start = phones[-1].start if phones[-1].is_pause else n / sr
                phones[-1:] = [*([] if phones[-1].is_pause else phones[-1:]),
                               Phone("_", start, (n + k) / sr)]
                n += k
        ph, ws, ss = u.shifted(n / sr)
        if phones and ph and phones[-1].is_pause and ph[0].is_pause:
            phones[-1] = Phone("_", phones[-1].start, ph[0].end)
            ph = ph[1:]
        phones += ph
        words += ws
        sents += ss
        chunks.append(u.audio.astype(np.float32))
        n += len(u.audio)
    audio = np.concatenate(chunks) if chunks else np.zeros(0, np.float32)
    return audio, phones, words, sents


def synthesize(text: str, *, lang: str = "en", voice: str | None = None, rate: int = 175,
               pitch: int = 50, volume: int = 100, ssml: bool = False,
               engine: str | None = None) -> Utterance:
    """Speak ``text``; return audio (float32 mono) and its phone, word and sentence timing.

    Parameters
    ----------
    text : str
        Plain text (split into sentences, each synthesised on its own, at least
        :data:`SENTENCE_PAUSE` s apart) or, with ``ssml=True``, an SSML document (see
        :mod:`mimika.speech.ssml`: break, prosody, emphasis, sub, phoneme, say-as, lang,
        voice, audio; spoken by espeak-ng). Words carry the text as written.
    lang : str
        Language code: ``en``, ``en-us``, ``de``, ``pl`` … (``mimika voices``).
    voice : str, optional
        A Piper voice (``PATH.onnx``, or a name in the voice folders: ``en_US-joe-medium``,
        ``joe``), or an espeak-ng variant (``f3``, ``m2``, ``klatt``), ``lang+variant`` or
        voice name. A Piper voice speaks its own language.
    rate : int
        Words per minute, 80–450 (175 is a Piper voice's natural pace).
    pitch : int
        Base pitch 0–100 (default 50; espeak-ng only).
    engine : ``auto`` | ``espeak`` | ``piper``, optional
        See :func:`choose_engine`; default ``$MIMIKA_TTS`` or ``auto``.

    Returns
    -------
    Utterance
        ``audio`` shape (n_samples,) at ``sr`` (22 050 Hz for espeak-ng and most Piper
        voices); phones tile the whole audio; ``meta["source"]`` names the engine.
    """
    from mimika.speech import espeak

    if not isinstance(text, str) or not text.strip():
        raise ParameterError("text is empty; give at least one word to speak")
    check_speech(text, rate)  # before synthesising (mimika.limits)
    kind, info = choose_engine(engine, lang, voice)
    if ssml:
        from mimika.speech.ssml import parse, speak

        return speak(parse(text), lang=lang, voice=voice, rate=rate, pitch=pitch,
                     volume=volume, engine=engine)[0]
    pieces = split_sentences(text, lang)
    if not pieces:
        raise ParameterError("text is empty; give at least one word to speak")
    if kind == "piper":
        from mimika.speech.piper import synthesize_sentence, voice_language

        code = voice_language(info)
        if code.split("-")[0] != espeak.normalize_lang(lang).split("-")[0] and voice:
            log.info("voice %s speaks %s; reading the text as %s", info.name, code, code)
        parts = [synthesize_sentence(info, s, offset=c, rate=rate, volume=volume)
                 for s, c in pieces]
        meta = {"source": "piper", "voice": info.name, "rate": rate}
    else:
        code = espeak.check_lang(lang)
        parts = [_espeak_sentence(s, c, lang=code, voice=voice, rate=rate, pitch=pitch,
                                  volume=volume) for s, c in pieces]
        meta = {"source": "espeak-ng", "voice": voice or code, "rate": rate, "pitch": pitch}
    audio, phones, words, sents = join_sentences(parts)
    sr = parts[0].sr
    log.debug("synthesised %d sentences, %.2f s, %d phones (%s)", len(sents), len(audio) / sr,
              len(phones), meta["source"])
    if not any(not p.is_pause for p in phones):
        log.warning("%s produced no phonemes for %r", meta["source"], text[:40])
    return Utterance(audio, sr, phones, words, sents, lang=code, text=text, meta=meta)
