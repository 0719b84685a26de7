"""The words a user wrote, and their times in speech.

espeak-ng's word events do not follow the text once it expands or re-reads it: "12345" gives
five events, "$100" two, and after punctuation the reported text positions drift ("Yes, it
is." reports ``it`` and ``t``). mimika therefore times the *written* tokens itself:

1. :func:`tokens` splits the text into the words a reader sees (``$100``, ``3.14159``,
   ``z.B.``, ``p.m.``, ``"hello"`` → ``hello``), each with its character offset;
2. :func:`phonemize` asks espeak-ng how each token is spoken (``espeak_TextToPhonemes``);
3. :func:`assign_phones` matches the concatenated token phonemes to the phones of the
   synthesised (or aligned) sentence, so every phone belongs to a token;
4. a word spans its phones: its text is what the user wrote, its time what was spoken.
"""

from __future__ import annotations

import difflib
import functools
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from mimika.speech.phonemes import strip_stress
from mimika.speech.utterance import Phone, Word

#: characters stripped from the ends of a whitespace-separated token
_LEAD = "\"'“”„‟«»‚‘’‹›([{¿¡<*_"
_TRAIL = "\"'“”„‟«»‚‘’‹›)]}>,;:!?…*_"


@dataclass(frozen=True)
class Token:
    """A written word: ``text`` as the user wrote it (punctuation around it removed),
    ``offset`` its character index in the text, ``spoken`` what is read instead (``<sub>``)."""

    text: str
    offset: int
    spoken: str | None = None

    @property
    def say(self) -> str:
        return self.text if self.spoken is None else self.spoken


def _trim(tok: str, start: int) -> tuple[str, int]:
    """Strip quotes, brackets and trailing punctuation; keep the dot of abbreviations
    (``Dr.``, ``z.B.``, ``p.m.``)."""
    from mimika.speech.tts import sentence_abbreviations

    i, j = 0, len(tok)
    while i < j and tok[i] in _LEAD:
        i += 1
    while j > i and tok[j - 1] in _TRAIL:
        j -= 1
    core = tok[i:j]
    while core.endswith("."):
        body = core[:-1]
        if body.lower() in sentence_abbreviations()[0] or ("." in body.strip(".")
                                        and not any(c.isdigit() for c in body)):
            break
        core = body.rstrip(_TRAIL)
    return core, start + i


def tokens(text: str, *, offset: int = 0) -> list[Token]:
    """The written words of ``text`` with their character offsets (+ ``offset``).

    >>> [t.text for t in tokens('He said "hello" to Dr. Smith: $100, 3.14159 — now.')]
    ['He', 'said', 'hello', 'to', 'Dr.', 'Smith', '$100', '3.14159', 'now']
    """
    out: list[Token] = []
    for m in re.finditer(r"\S+", text):
        core, start = _trim(m.group(0), m.start())
        if core and any(c.isalnum() or c in "$€£¥%&+@§#=" for c in core):
            out.append(Token(core, offset + start))
    return out


def read_aloud(text: str, lang: str, *, offset: int = 0) -> tuple[str, list[Token]]:
    """What a voice is given for ``text`` (numbers, currency, abbreviations as a newsreader
    reads them: :func:`mimika.speech.normalize.spoken_text`) and the written tokens (+
    ``offset``) with what is said for each; tokens one reading spans become one token
    (``$3.5 million`` → "3.5 million dollars")."""
    from mimika.speech.normalize import spans

    readings = spans(text, lang)
    toks = tokens(text)
    if not readings:
        return text, [Token(t.text, t.offset + offset) for t in toks]
    out: list[Token] = []
    k = 0
    while k < len(toks):
        a, b = toks[k].offset, toks[k].offset + len(toks[k].text)
        j, grow = k + 1, True
        while grow:
            grow = False
            for s in readings:
                if s.start < b and s.end > a and (s.start < a or s.end > b):
                    a, b, grow = min(a, s.start), max(b, s.end), True
            while j < len(toks) and toks[j].offset < b:
                b, j, grow = max(b, toks[j].offset + len(toks[j].text)), j + 1, True
        inside = [s for s in readings if s.start < b and s.end > a]
        if not inside:
            out.append(Token(toks[k].text, toks[k].offset + offset))
        else:
            written = text[a:b]
            lead = len(written) - len(written.lstrip())
            said, pos = [], a
            for s in inside:
                said += [text[pos:s.start], s.spoken]
                pos = s.end
            said.append(text[pos:b])
            out.append(Token(written.strip(), a + lead + offset,
                             " ".join("".join(said).split())))
        k = j
    return _spoken(text, readings), out


def _spoken(text: str, readings) -> str:
    out, pos = [], 0
    for s in readings:
        out += [text[pos:s.start], s.spoken]
        pos = s.end
    return "".join(out) + text[pos:]


_CURRENCY = re.compile(r"([$€£¥])\s?(\d[\d.,]*\d|\d)")


def as_read(text: str) -> str:
    """How a person reads ``text`` aloud where espeak-ng reads it differently: a currency sign
    before an amount is said after it (``$100`` → ``100 $``, "one hundred dollars"; espeak-ng
    says "dollar one hundred"). For aligning recordings; synthesis keeps espeak's reading."""
    return _CURRENCY.sub(r"\2 \1", text)


@functools.lru_cache(maxsize=4096)
def _phonemize_cached(text: str, lang: str) -> tuple[tuple[str, int], ...]:
    from mimika.speech import espeak

    out: list[tuple[str, int]] = []
    for chunk in espeak.text_to_phonemes(text, lang=lang):
        for word in chunk.split():
            for raw in word.split("|"):
                sym, stress = strip_stress(raw)
                if sym and not sym.startswith("_") and not (sym[0] == "(" and sym[-1] == ")"):
                    out.append((sym, stress))
    return tuple(out)


def phonemize(text: str, *, lang: str) -> list[tuple[str, int]]:
    """How espeak-ng reads ``text`` in ``lang``: ``[(mnemonic, stress), …]`` without pauses."""
    return list(_phonemize_cached(text, lang))


#: how a reader says a token: text → the symbols to match against the phones
Reader = Callable[[str], Sequence[str]]


def assign_phones(phones: Sequence[Phone], toks: Sequence[Token], *, lang: str,
                  read: Reader | None = None, symbols: Sequence[str] | None = None
                  ) -> list[int]:
    """The token index of every phone (-1 for pauses).

    The phones of the whole sentence are matched (``difflib``) against the concatenated
    per-token phonemes; replaced runs are shared out in order, phones espeak added in context
    go to the token before them. ``read`` and ``symbols`` (one per phone) replace espeak-ng's
    mnemonics when the phones come from elsewhere (a Piper voice matches on its own IPA).
    """
    if read is None:
        def read(text: str) -> list[str]:
            return [sym for sym, _ in phonemize(text, lang=lang)]
    seq_b: list[str] = []
    owner_b: list[int] = []
    for k, t in enumerate(toks):
        for sym in read(t.say):
            seq_b.append(sym)
            owner_b.append(k)
    idx = [i for i, p in enumerate(phones) if not p.is_pause]
    seq_a = [(symbols[i] if symbols is not None else phones[i].symbol) for i in idx]
    own = [-1] * len(seq_a)
    sm = difflib.SequenceMatcher(a=seq_a, b=seq_b, autojunk=False)
    for op, i1, i2, j1, j2 in sm.get_opcodes():
        if op == "equal":
            for k in range(i2 - i1):
                own[i1 + k] = owner_b[j1 + k]
        elif op == "replace":
            for k in range(i2 - i1):
                own[i1 + k] = owner_b[j1 + (k * (j2 - j1)) // (i2 - i1)]
    # phones espeak added (delete opcodes) belong to the token before (or after) them
    last = next((o for o in own if o >= 0), 0)
    for k in range(len(own)):
        if own[k] < 0:
            own[k] = last
        last = own[k]
    for k in range(1, len(own)):  # keep ownership monotone
        own[k] = max(own[k], own[k - 1])
    out = [-1] * len(phones)
    for i, o in zip(idx, own, strict=True):
        out[i] = o
    return out


def word_spans(phones: Sequence[Phone], toks: Sequence[Token], *, lang: str,
               read: Reader | None = None, symbols: Sequence[str] | None = None
               ) -> list[tuple[int, Word]]:
    """``(token index, Word)`` for the tokens that were spoken: text as written, times of their
    phones (``read``/``symbols`` as in :func:`assign_phones`)."""
    if not toks:
        return []
    own = assign_phones(phones, toks, lang=lang, read=read, symbols=symbols)
    spans: dict[int, list[float]] = {}
    for p, o in zip(phones, own, strict=True):
        if o >= 0:
            spans.setdefault(o, [p.start, p.end])[1] = p.end
    return [(k, Word(t.text, spans[k][0], spans[k][1], t.offset))
            for k, t in enumerate(toks) if k in spans]


def word_times(phones: Sequence[Phone], toks: Sequence[Token], *, lang: str) -> list[Word]:
    """:class:`Word` s of the tokens that were spoken (see :func:`word_spans`)."""
    return [w for _, w in word_spans(phones, toks, lang=lang)]
