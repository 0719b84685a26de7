"""Articles: plain text (paragraphs separated by blank lines) or a mimika script (``<speak>``),
and their synthesis into one utterance with newsreader pauses between sentences/paragraphs."""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from mimika import limits
from mimika.errors import ParameterError

log = logging.getLogger(__name__)

#: silence added between sentences / paragraphs (s), on top of the TTS's own
SENTENCE_GAP = 0.22
PARAGRAPH_GAP = 0.65
LEAD_IN = 0.45  # silence before the first word (the reader looks up, then speaks)
TAIL = 0.9  # after the last word (a smile, a nod)


@dataclass(frozen=True)
class Article:
    """``paragraphs`` of plain text; ``script`` holds the parsed timeline of a ``<speak>``
    script (its spoken text is the single paragraph), else None."""

    paragraphs: tuple[str, ...]
    script: Any = None
    source: str = "<article>"
    base: Any = None  #: folder that relative ``<audio src>`` paths start from

    @property
    def text(self) -> str:
        return "\n\n".join(self.paragraphs)


def is_script(text: str) -> bool:
    """True if ``text`` is a mimika script (an XML document with a ``<speak`` element)."""
    return re.search(r"<speak[\s>/]", text) is not None


def parse_article(text: str, *, source: str = "<article>") -> Article:
    """An :class:`Article` from plain text or script text; empty input raises ParameterError."""
    if not isinstance(text, str) or not text.strip():
        raise ParameterError(f"article {source} is empty; give at least one sentence to read")
    limits.check_text(text, f"article {source}")
    if is_script(text):
        from mimika.markup import parse_script

        tl = parse_script(text, source=source)
        spoken = tl.speech.text.strip()
        if not spoken:
            raise ParameterError(f"script {source} has no text to speak inside <speak>")
        paras = tuple(p for p in (" ".join(x.split()) for x in re.split(r"\n\s*\n", spoken))
                      if p)
        from pathlib import Path

        base = Path(source).parent if source and not source.startswith("<") else None
        return Article(paras, tl, source, base)
    paras = tuple(" ".join(p.split()) for p in re.split(r"\n\s*\n", text.strip()))
    return Article(tuple(p for p in paras if p), None, source)


def article_sentences(text: str, lang: str = "en") -> list[tuple[str, int]]:
    """``[(sentence, char_offset)]`` of ``text`` read as ``mimika news`` reads an article:
    paragraphs (blank lines), whitespace joined, a ``<speak>`` script's spoken text, each
    paragraph split into sentences as the TTS splits them. Offsets count in the joined text."""
    from mimika.speech.tts import split_sentences

    if not text.strip():
        raise ParameterError("the text is empty; type something to speak")
    out, base = [], 0
    for para in parse_article(text, source="the text").paragraphs:
        out += [(sent, base + off) for sent, off in split_sentences(para, lang) or [(para, 0)]]
        base += len(para) + 2
    return out


def _pad(utt: Any, lead: float, tail: float) -> Any:
    """``utt`` with ``lead`` s of silence before and ``tail`` s after (times shifted)."""
    from mimika.speech import Phone, Utterance

    sr = utt.sr
    n0, n1 = round(lead * sr), round(tail * sr)
    d = n0 / sr
    audio = np.concatenate([np.zeros(n0, np.float32), utt.audio.astype(np.float32),
                            np.zeros(n1, np.float32)])
    ph, ws, ss = utt.shifted(d)
    ph = [Phone("_", 0.0, d), *ph, Phone("_", ph[-1].end if ph else d, len(audio) / sr)]
    merged: list = []
    for p in ph:
        if p.end <= p.start:
            continue
        if merged and p.is_pause and merged[-1].is_pause:
            merged[-1] = Phone("_", merged[-1].start, p.end)
        else:
            merged.append(p)
    meta = dict(utt.meta)
    if "script_positions" in meta:
        meta["script_positions"] = [t + d for t in meta["script_positions"]]
    return Utterance(audio, sr, merged, ws, ss, lang=utt.lang, text=utt.text, meta=meta)


def _speak_script(article: Article, *, lang: str, voice: str | None, rate: int, pitch: int,
                  engine: str | None = None) -> tuple[Any, list[float]]:
    """A ``<speak>`` script spoken as SSML, with the script's positions timed."""
    from mimika.speech.ssml import items_from_speech, speak

    utt, positions = speak(items_from_speech(article.script.speech), lang=lang, voice=voice,
                           rate=rate, pitch=pitch, base=article.base, engine=engine)
    utt.meta["script_positions"] = positions
    utt = _pad(utt, LEAD_IN, TAIL)
    return utt, [utt.words[0].start if utt.words else LEAD_IN]


def align_article(article: Article, audio: np.ndarray, *, sr: int, lang: str = "en"
                  ) -> tuple[Any, list[float]]:
    """Time ``article`` on a recording of it (any voice): ``(utterance, paragraph_starts)``;
    the utterance's audio is the recording, untouched."""
    from mimika.speech.alignment import align

    if article.script is not None:
        from mimika.speech.ssml import items_from_speech

        items = items_from_speech(article.script.speech)
        text, item_of, alias = "", [], None
        for k, it in enumerate(items):
            if it[0] == "open" and it[1] == "sub":  # the recording says the alias
                alias = f" {it[2].get('alias', '')} "
            elif it[0] == "close" and it[1] == "sub":
                alias = None
            elif it[0] == "text":
                said = it[1] if alias is None else alias
                alias = "" if alias is not None else None
                text += said
                item_of += [k] * len(said)
        utt = align(audio, sr=sr, transcript=text, lang=lang)
        from mimika.speech.ssml import _positions

        utt.meta["script_positions"] = _positions(
            len(items), utt.words, [item_of[w.offset] for w in utt.words], utt.duration)
        return utt, [utt.words[0].start if utt.words else 0.0]
    text = article.text
    utt = align(audio, sr=sr, transcript=text, lang=lang)
    starts, pos = [], 0
    for para in article.paragraphs:
        ws = [w for w in utt.words if pos <= w.offset < pos + len(para)]
        if ws:
            starts.append(ws[0].start)
        pos += len(para) + 2
    return utt, starts


def speak_article(article: Article, *, lang: str = "en", voice: str | None = None,
                  rate: int = 165, pitch: int = 50, sentence_gap: float = SENTENCE_GAP,
                  paragraph_gap: float = PARAGRAPH_GAP, engine: str | None = None
                  ) -> tuple[Any, list[float]]:
    """Synthesise every sentence (``engine``/``voice`` as in
    :func:`mimika.speech.tts.synthesize`) and join them with pauses.

    Returns ``(utterance, paragraph_starts)``: one :class:`~mimika.speech.Utterance` (audio
    float32 mono at ``sr``, phones tiling it, words and sentences in seconds) and the start
    times (s) of the first sentence of every paragraph. A ``<speak>`` script goes to espeak-ng
    as SSML in one piece (breaks, prosody, sub … change the speech), and
    ``utterance.meta["script_positions"]`` holds the time of every script position.
    """
    from mimika.speech import Phone, Sentence, Utterance, synthesize
    from mimika.speech.tts import split_sentences

    if article.script is not None:
        return _speak_script(article, lang=lang, voice=voice, rate=rate, pitch=pitch,
                             engine=engine)

    chunks: list[np.ndarray] = []
    phones: list = []
    words: list = []
    sents: list = []
    para_starts: list[float] = []
    sr = None
    t = 0.0
    char_base = 0
    full = article.text
    limits.check_speech(full, rate, f"article {article.source}")

    def silence(d: float) -> None:
        nonlocal t
        n = round(d * (sr or 22050))
        if n <= 0:
            return
        chunks.append(np.zeros(n, np.float32))
        d = n / (sr or 22050)
        if phones and phones[-1].is_pause:
            phones[-1] = Phone("_", phones[-1].start, phones[-1].end + d)
        else:
            phones.append(Phone("_", t, t + d))
        t += d

    for _pi, para in enumerate(article.paragraphs):
        pieces = split_sentences(para, lang) or [(para, 0)]
        for si, (sent, off) in enumerate(pieces):
            u = synthesize(sent, lang=lang, voice=voice, rate=rate, pitch=pitch,
                           engine=engine)
            if sr is None:
                sr = u.sr
                silence(LEAD_IN)
            elif si == 0:
                silence(paragraph_gap)
            else:
                silence(sentence_gap)
            if si == 0:
                para_starts.append(t)
            ph, ws, _ = u.shifted(t, char_base + off)
            if phones and ph and phones[-1].is_pause and ph[0].is_pause:
                phones[-1] = Phone("_", phones[-1].start, ph[0].end)
                ph = ph[1:]
            phones += ph
            words += ws
            chunks.append(u.audio.astype(np.float32))
            t0, t = t, t + len(u.audio) / u.sr
            sents.append(Sentence(sent, t0, t))  # the sentence spans its synthesised chunk
            limits.check_duration(t, f"the speech of article {article.source}")
        char_base += len(para) + 2
    silence(TAIL)
    audio = np.concatenate(chunks).astype(np.float32)
    # phones must end exactly at the audio's end
    dur = len(audio) / sr
    if phones:
        last = phones[-1]
        phones[-1] = Phone(last.symbol, last.start, dur, last.stress)
    utt = Utterance(audio, int(sr), phones, words, sents, lang=u.lang, text=full,
                    meta={**u.meta, "rate": rate, "pitch": pitch})
    log.debug("article: %d paragraphs, %d sentences, %.2f s", len(article.paragraphs),
              len(sents), dur)
    return utt, para_starts
