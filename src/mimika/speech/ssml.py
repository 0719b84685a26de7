"""SSML to the voice: a script's speech as espeak-ng SSML, with words timed as written.

Input is a flat list of items — ``("open", tag, attrs)``, ``("close", tag)``, ``("empty", tag,
attrs)``, ``("text", str)`` — from :func:`parse` (an SSML string) or from a mimika script's
speech tokens. What reaches espeak-ng (its SSML mode):

* ``break`` (time, strength), ``prosody`` (rate, pitch, volume, range), ``emphasis``,
  ``say-as``, ``sub`` (alias), ``voice`` (name, gender, age, variant, xml:lang), ``s``, ``p``,
  ``mark`` — as they are;
* ``lang xml:lang="de"`` → ``voice xml:lang="de"`` (espeak-ng has no ``lang``);
* ``phoneme ph="…"`` → espeak phoneme input ``[[…]]``: ``alphabet="ipa"`` (default) is
  mapped to espeak mnemonics (``data/ipa.json``), ``alphabet="x-espeak"`` taken as it is;
* ``audio src="file.wav"`` → the file's samples are spliced into the speech at that point (its
  content is the fallback when the file cannot be read);
* other elements (``desc``, ``meta``, ``lexicon`` …) are dropped, their text kept where SSML
  speaks it.

Words carry the text the user wrote (``<sub alias="World Wide Web">WWW</sub>`` is one word
``WWW``) and, per item, :func:`speak` returns the time each item position is reached, so
elements of a script anchored at positions stay on the words they wrap.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from xml.parsers import expat
from xml.sax.saxutils import escape, quoteattr, unescape

import numpy as np

from mimika.errors import DataError, ParameterError
from mimika.speech.normalize import say_as
from mimika.speech.phonemes import ipa_to_espeak
from mimika.speech.utterance import Phone, Sentence, Utterance, Word
from mimika.speech.words import Token, read_aloud, tokens, word_spans

log = logging.getLogger(__name__)

Item = tuple  #: ("open", tag, attrs) | ("close", tag) | ("empty", tag, attrs) | ("text", str)

_PASS = {"break", "prosody", "emphasis", "say-as", "sub", "voice", "s", "p", "mark"}
_SILENT = {"desc", "meta", "metadata", "lexicon", "lookup"}
_ATTRS = {"prosody": ("rate", "pitch", "volume", "range"), "voice": (
    "name", "gender", "age", "variant", "xml:lang"), "break": ("time", "strength"),
    "say-as": ("interpret-as", "format"), "sub": ("alias",), "emphasis": ("level",),
    "mark": ("name",)}


class _Phonemes(str):
    """A ``<phoneme>`` in a piece's body: espeak-ng's ``[[mnemonics]]``, with the element's
    ``text`` and its ``ipa`` (None for the x-espeak alphabet) for a Piper voice."""

    text: str
    ipa: str | None

    def __new__(cls, value: str, text: str, ipa: str | None) -> _Phonemes:
        self = super().__new__(cls, value)
        self.text, self.ipa = text, ipa
        return self


#: SSML break strengths and prosody rate words (as espeak-ng reads them)
_STRENGTH = {"none": 0.0, "x-weak": 0.1, "weak": 0.2, "medium": 0.4, "strong": 0.6,
             "x-strong": 1.0}
_RATES = {"x-slow": 0.6, "slow": 0.8, "medium": 1.0, "default": 1.0, "fast": 1.25,
          "x-fast": 1.6}


def _attr(tag: str, name: str) -> str | None:
    m = re.search(rf'\b{name}="([^"]*)"', tag)
    return unescape(m.group(1)) if m else None


def _rate(tag: str) -> float:
    """The pace factor of a ``<prosody rate=…>`` tag (1 when it has none)."""
    r = (_attr(tag, "rate") or "").strip().lower()
    if r in _RATES:
        return _RATES[r]
    m = re.fullmatch(r"([+-]?\d+(?:\.\d*)?)(%?)", r)
    if not m:
        return 1.0
    v = float(m.group(1))
    if m.group(2):
        return max(v / 100.0, 0.1) if not r.startswith(("+", "-")) else max(1 + v / 100, 0.1)
    return max(v, 0.1)


def piper_segments(body: Sequence[str]) -> list[tuple[str, float] | float]:
    """A piece's SSML as a Piper voice speaks it: text runs at their ``<prosody rate>`` and
    ``<break>`` silences (s); IPA ``<phoneme>`` s are spoken as written (``[[…]]``), other
    elements' text as it stands."""
    segs: list[tuple[str, float] | float] = []
    buf: list[str] = []
    rates = [1.0]

    def flush() -> None:
        text = " ".join(unescape("".join(buf)).split())
        if text:
            segs.append((text, rates[-1]))
        buf.clear()

    for part in body:
        if isinstance(part, _Phonemes):
            buf.append(f" [[{part.ipa}]] " if part.ipa else escape(part.text))
        elif part.startswith("<break"):
            flush()
            t = _attr(part, "time")
            segs.append(float(t[:-2]) / 1000 if t else
                        _STRENGTH.get(_attr(part, "strength") or "medium", 0.4))
        elif part.startswith("<prosody"):
            flush()
            rates.append(rates[-1] * _rate(part))
        elif part.startswith("</prosody"):
            flush()
            if len(rates) > 1:
                rates.pop()
        elif not part.startswith("<"):
            buf.append(part)
    flush()
    return segs


@dataclass
class _Piece:
    """One espeak call: its SSML, whether it holds ``[[phonemes]]``, its tokens + items."""

    body: list[str] = field(default_factory=list)
    toks: list[Token] = field(default_factory=list)
    items: list[int] = field(default_factory=list)  # item index of each token
    phonemes: bool = False
    audio: np.ndarray | None = None  # a spliced recording instead of speech


def parse(ssml: str) -> list[Item]:
    """Items of an SSML document (the ``speak`` root left out)."""
    items: list[Item] = []
    depth = [0]

    def start(tag, attrs):
        depth[0] += 1
        if depth[0] == 1 and tag == "speak":
            return
        items.append(("open", tag, dict(zip(attrs[::2], attrs[1::2], strict=True))))

    def end(tag):
        depth[0] -= 1
        if depth[0] == 0 and tag == "speak":
            return
        last = items[-1] if items else None
        if last and last[0] == "open" and last[1] == tag:
            items[-1] = ("empty", tag, last[2])
        else:
            items.append(("close", tag))

    p = expat.ParserCreate()
    p.ordered_attributes = True
    p.buffer_text = True
    p.StartElementHandler = start
    p.EndElementHandler = end
    p.CharacterDataHandler = lambda s: items.append(("text", s))
    text = ssml if ssml.lstrip().startswith("<") else f"<speak>{escape(ssml)}</speak>"
    if not re.match(r"\s*(<\?xml[^>]*\?>\s*)?<speak[\s>/]", text):
        text = f"<speak>{text}</speak>"
    try:
        p.Parse(text, True)
    except expat.ExpatError as e:
        raise ParameterError(f"SSML is not well-formed: {expat.ErrorString(e.code)} at line "
                             f"{e.lineno}, column {e.offset + 1}; escape '<' as &lt; and "
                             "'&' as &amp;") from None
    return items


def _ms(time: str) -> str:
    """``"1.5s"`` → ``"1500ms"``: espeak-ng reads only whole numbers of its unit."""
    m = re.fullmatch(r"\s*(\d+(?:\.\d*)?|\.\d+)\s*(ms|s)?\s*", time)
    if not m:
        raise ParameterError(f"break time={time!r} is not a time; write it like \"1.5s\" or "
                             "\"300ms\"")
    v = float(m.group(1)) * (1.0 if m.group(2) == "ms" else 1000.0)
    return f"{round(v)}ms"


def _open_tag(tag: str, attrs: dict[str, str]) -> str:
    keep = {k: v for k, v in attrs.items() if k in _ATTRS.get(tag, ())}
    if tag == "break" and "time" in keep:
        keep["time"] = _ms(keep["time"])
    return f"<{tag}" + "".join(f" {k}={quoteattr(v)}" for k, v in keep.items()) + ">"


def _read_audio(src: str, base: Path | None, sr: int) -> np.ndarray | None:
    from mimika.speech.audio import read_media, resample

    p = Path(src)
    if not p.is_absolute() and base is not None:
        p = base / p
    try:
        a, r = read_media(p)
    except DataError as e:
        log.warning("<audio src=%r>: %s; speaking its content instead", src, e)
        return None
    return resample(a, orig_sr=r, target_sr=sr)


#: say-as kinds mimika reads itself (mimika.speech.normalize.say_as), in every language
_READ = {"date", "time", "ordinal", "cardinal", "number", "telephone"}


def _pieces(items: Sequence[Item], *, sr: int, base: Path | None, lang: str = "en"
            ) -> list[_Piece]:
    """Split ``items`` into espeak calls (at ``audio`` elements) with their tokens; text is
    given as read aloud (numbers, abbreviations; ``say-as`` date, time, ordinal …)."""
    pieces = [_Piece()]
    stack: list[tuple[str, str]] = []  # (open tag as written for espeak, close tag)
    skip = 0  # inside an element whose text is not spoken
    sub: list[tuple[int, str]] = []  # (item index of the sub's first text, alias)
    spoken: list[str | None] = []  # how the words inside a say-as are read
    i = 0
    while i < len(items):
        it = items[i]
        kind, tag = it[0], it[1]
        cur = pieces[-1]
        if kind == "text":
            if sub and sub[-1][0] < 0:
                sub[-1] = (i, sub[-1][1])
            if not skip:
                text = tag
                say = spoken[-1] if spoken else None
                if isinstance(say, tuple):  # a say-as read by mimika: one token
                    reading = say_as(text, say[0], lang, say[1])
                    cur.body.append(escape(reading))
                    toks = [Token(" ".join(text.split()), 0, reading)] if text.strip() else []
                elif say is None:
                    said, toks = read_aloud(text, lang)
                    cur.body.append(escape(said))
                else:
                    cur.body.append(escape(text))
                    toks = [Token(t.text, t.offset, say) for t in tokens(text)]
                cur.toks += toks
                cur.items += [i] * len(toks)
            i += 1
            continue
        attrs = it[2] if len(it) > 2 else {}
        if kind in ("open", "empty") and tag == "audio" and attrs.get("src"):
            a = _read_audio(attrs["src"], base, sr)
            if a is not None:  # close what is open, splice, reopen it after the sound
                cur.body += [c for _, c in reversed(stack)]
                pieces.append(_Piece(audio=a))
                pieces.append(_Piece(body=[o for o, _ in stack]))
                if kind == "open":  # skip the fallback content
                    depth = 1
                    while depth and i + 1 < len(items):
                        i += 1
                        depth += {"open": 1, "close": -1}.get(items[i][0], 0) \
                            if items[i][1] == "audio" else 0
                i += 1
                continue
        kind_as = attrs.get("interpret-as", "").lower()
        if tag == "say-as" and kind in ("open", "close") and (
                kind_as in _READ if kind == "open" else spoken and isinstance(spoken[-1], tuple)):
            if kind == "open":  # not passed to espeak-ng: mimika reads it
                spoken.append(("cardinal" if kind_as == "number" else kind_as,
                               attrs.get("format")))
            else:
                spoken.pop()
            i += 1
            continue
        if tag in _SILENT:
            skip += {"open": 1, "close": -1}.get(kind, 0)
        elif tag in _PASS or tag == "lang":
            etag = "voice" if tag == "lang" else tag
            a2 = {"xml:lang": attrs.get("xml:lang", attrs.get("lang", ""))} if tag == "lang" \
                else attrs
            if kind == "empty":
                cur.body.append(_open_tag(etag, a2)[:-1] + "/>")
            elif kind == "open":
                o = _open_tag(etag, a2)
                cur.body.append(o)
                stack.append((o, f"</{etag}>"))
                if tag == "sub":
                    cur.body.append(escape(attrs.get("alias", "")))
                    sub.append((-1, attrs.get("alias", "")))
                    skip += 1
                if tag == "say-as":  # balanced with its close; espeak-ng reads the rest
                    spoken.append("*chars*" if kind_as in (
                        "characters", "spell-out", "tts:char") else None)
            else:
                if tag == "sub" and sub:
                    first, alias = sub.pop()
                    skip -= 1
                    text = "".join(x[1] for x in items[first:i] if x[0] == "text") \
                        if first >= 0 else ""
                    if text.strip():
                        cur.toks.append(Token(" ".join(text.split()), 0, alias))
                        cur.items.append(first)
                if tag == "say-as" and spoken:
                    spoken.pop()
                if stack:
                    cur.body.append(stack.pop()[1])
        elif tag == "phoneme" and kind == "open":
            ph = attrs.get("ph", "")
            alpha = attrs.get("alphabet", "ipa").lower()
            mn = ph if alpha in ("x-espeak", "espeak") else ipa_to_espeak(ph)
            if mn:
                text = ""
                j = i + 1
                while j < len(items) and not (items[j][0] == "close"
                                              and items[j][1] == "phoneme"):
                    text += items[j][1] if items[j][0] == "text" else ""
                    j += 1
                cur.body.append(_Phonemes(f"[[{escape(mn)}]]", text,
                                          None if alpha in ("x-espeak", "espeak") else ph))
                cur.phonemes = True
                if text.strip():
                    cur.toks.append(Token(" ".join(text.split()), 0, None))
                    cur.items.append(i + 1)
                i = j + 1
                continue
        i += 1
    for p in pieces:  # a chars say-as is read letter by letter
        p.toks = [Token(t.text, t.offset, " ".join(t.text) if t.spoken == "*chars*"
                        else t.spoken) for t in p.toks]
    return [p for p in pieces if p.audio is not None or "".join(p.body).strip()]


def speak(items: Sequence[Item], *, lang: str = "en", voice: str | None = None,
          rate: int = 175, pitch: int = 50, volume: int = 100,
          base: Path | None = None, engine: str | None = None
          ) -> tuple[Utterance, list[float]]:
    """Synthesise SSML ``items``; return the utterance and, for every item position
    0 … len(items), the time (s) the speech reaches it.

    ``engine``/``voice`` as in :func:`mimika.speech.tts.choose_engine`: espeak-ng reads the
    SSML itself; a Piper voice speaks its text runs at their ``<prosody rate>``, with the
    ``<break>`` silences, ``<audio>`` clips and IPA ``<phoneme>`` s (see
    :func:`piper_segments`). Words are the written tokens (their ``offset`` is -1: positions,
    not characters, locate them); ``base`` resolves relative ``audio src``.
    """
    from mimika.speech import espeak
    from mimika.speech.tts import choose_engine, events_to_phones, split_sentences

    kind, info = choose_engine(engine, lang, voice)
    if kind == "piper":
        from mimika.speech.piper import speak_segments, voice_language, word_spans_ipa

        code, sr = voice_language(info), info.sample_rate
    else:
        code, sr = espeak.check_lang(lang), espeak.sample_rate()
    chunks: list[np.ndarray] = []
    phones: list[Phone] = []
    words: list[Word] = []
    word_item: list[int] = []
    t = 0.0
    for piece in _pieces(items, sr=sr, base=base, lang=code):
        if piece.audio is not None:
            a = piece.audio.astype(np.float32)
            ph = [Phone("_", 0.0, len(a) / sr)]
            ws: list[Word] = []
        elif info is not None:
            a, ph, ipa, _ = speak_segments(info, piper_segments(piece.body), rate=rate)
            a = np.clip(a * (volume / 100.0), -1.0, 1.0)
            spans = word_spans_ipa(info, ph, ipa, piece.toks, code)
            ws = [w for _, w in spans]
            word_item += [piece.items[k] for k, _ in spans]
        else:
            doc = "<speak>" + "".join(piece.body) + "</speak>"
            raw = espeak.synth(doc, lang=code, voice=voice, rate=rate, pitch=pitch,
                               volume=volume, ssml=True, phonemes=piece.phonemes)
            a = raw.audio.astype(np.float32) / 32768.0
            ph = events_to_phones(raw.events, n_samples=len(raw.audio), sr=raw.sr)
            spans = word_spans(ph, piece.toks, lang=code)
            ws = [w for _, w in spans]
            word_item += [piece.items[k] for k, _ in spans]
        ph = [Phone(p.symbol, p.start + t, p.end + t, p.stress) for p in ph]
        if phones and ph and phones[-1].is_pause and ph[0].is_pause:
            phones[-1] = Phone("_", phones[-1].start, ph[0].end)
            ph = ph[1:]
        phones += ph
        words += [Word(w.text, w.start + t, w.end + t, -1) for w in ws]
        chunks.append(a)
        t += len(a) / sr
    if not chunks:
        raise ParameterError("the SSML has nothing to speak")
    audio = np.concatenate(chunks).astype(np.float32)
    positions = _positions(len(items), words, word_item, t)
    plain = plain_text(items)
    sents, pos = [], 0
    for text, _ in split_sentences(plain, code):
        n = len(read_aloud(text, code)[1])
        ws = words[pos:pos + n]
        if ws:
            sents.append(Sentence(text, ws[0].start, ws[-1].end))
        pos += n
    meta = {"source": "piper", "voice": info.name} if info is not None else \
        {"source": "espeak-ng", "voice": voice or code, "pitch": pitch}
    return (Utterance(audio, sr, phones, words, sents, lang=code, text=plain,
                      meta={**meta, "ssml": True, "rate": rate}), positions)


def _positions(n_items: int, words: Sequence[Word], word_item: Sequence[int],
               end: float) -> list[float]:
    """Time at each item position: the start of the first word at or after it, else the end
    of the last word."""
    out = []
    k = 0
    last = words[-1].end if words else end
    for p in range(n_items + 1):
        while k < len(word_item) and word_item[k] < p:
            k += 1
        out.append(words[k].start if k < len(words) else last)
    return out


def items_from_speech(speech: Any) -> list[Item]:
    """Items from a mimika script's :class:`~mimika.timeline.model.Speech` tokens (duck-typed:
    ``Open``/``Close``/``Empty`` have ``tag``/``attrs``, ``Text`` has ``text``)."""
    out: list[Item] = []
    for tok in speech.tokens:
        name = type(tok).__name__
        if name == "Text":
            out.append(("text", tok.text))
        elif name == "Close":
            out.append(("close", tok.tag))
        else:
            out.append(("open" if name == "Open" else "empty", tok.tag, dict(tok.attrs)))
    return out


def plain_text(items: Sequence[Item]) -> str:
    """The written text of ``items`` (what subtitles show)."""
    return " ".join("".join(x[1] for x in items if x[0] == "text").split())


__all__ = ["Item", "ipa_to_espeak", "items_from_speech", "parse", "piper_segments",
           "plain_text", "speak"]
