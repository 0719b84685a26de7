"""Text synchronisation without audio: the vowel-unit method of seed 002 §6.4.1 (Eq 6.4–6.13).

A text is split into *constituents* (sentences) and each constituent into *components*: words
and runs of punctuation (``?!``, ``...``). Every component gets a number of units (Eq 6.6):
its vowel letters, or 1 for punctuation and vowelless words. A constituent's time span is then
divided between its components in proportion to their units (Eq 6.7–6.10). Without audio the
constituents are timed by a speaking rate (seconds per unit); with known sentence times (TTS,
a recording) pass ``sentence_times``.

>>> [(c.text, c.units) for c in sync_text("Yes, sure!")[0].components]
[('Yes', 2), (',', 1), ('sure', 2), ('!', 1)]
"""

from __future__ import annotations

import re
import unicodedata
from collections.abc import Sequence
from dataclasses import dataclass

from mimika.errors import ParameterError

#: vowel letters (lower case): Latin plus German and Polish vowels and common accented ones
VOWELS = frozenset("aeiouyäöüąęóáéíúýàèìòùâêîôûëïÿåæøœ")
#: default speaking rate: seconds per vowel unit (≈ 4–5 syllables per second with letters)
DEFAULT_RATE = 0.16
#: Eq 6.13: a word and an expression are linked when at most this many frames apart
LINK_FRAMES = 12

_TOKEN_RE = re.compile(r"[^\W_]+(?:['’\-][^\W_]+)*|[^\w\s]+", re.UNICODE)
_SENTENCE_END = re.compile(r"[.!?…]")


@dataclass(frozen=True)
class Component:
    """A word or a run of punctuation with its time range (seconds)."""

    text: str
    kind: str  #: "word" or "punct"
    units: int
    start: float
    end: float

    @property
    def is_word(self) -> bool:
        return self.kind == "word"


@dataclass(frozen=True)
class Constituent:
    """A sentence: its components and its time range (seconds)."""

    components: tuple[Component, ...]
    start: float
    end: float

    @property
    def text(self) -> str:
        out = ""
        for c in self.components:
            out += c.text if (c.kind == "punct" and c.text[0] in ",.;:!?…)") or not out \
                else " " + c.text
        return out

    @property
    def units(self) -> int:
        return sum(c.units for c in self.components)

    @property
    def final_punct(self) -> str:
        """The punctuation run that ends the sentence (``""`` if none)."""
        last = self.components[-1] if self.components else None
        return last.text if last is not None and last.kind == "punct" else ""

    @property
    def is_question(self) -> bool:
        return "?" in self.final_punct

    @property
    def is_exclamation(self) -> bool:
        return "!" in self.final_punct

    @property
    def words(self) -> list[Component]:
        return [c for c in self.components if c.is_word]


def vowel_units(component: str, *, mode: str = "letters") -> int:
    """Units of a component (Eq 6.6): vowel letters, or 1 for punctuation / no vowels.

    ``mode="letters"`` counts every vowel letter (the seed's rule for Polish);
    ``mode="groups"`` counts runs of adjacent vowels (``"nie"`` → 1, ``"Liebe"`` → 2), a closer
    syllable estimate for English and German diphthongs.
    """
    if mode not in ("letters", "groups"):
        raise ParameterError(f"mode={mode!r} must be 'letters' or 'groups'")
    s = unicodedata.normalize("NFC", component.lower())
    flags = [ch in VOWELS for ch in s]
    if mode == "letters":
        n = sum(flags)
    else:
        n = sum(1 for i, f in enumerate(flags) if f and (i == 0 or not flags[i - 1]))
    return max(n, 1)


def tokenize(text: str) -> list[tuple[str, str]]:
    """Words and punctuation runs: ``"Oh, really?!"`` → Oh / , / really / ?!."""
    out = []
    for m in _TOKEN_RE.finditer(unicodedata.normalize("NFC", text)):
        tok = m.group(0)
        out.append((tok, "word" if tok[0].isalnum() else "punct"))
    return out


def split_sentences(text: str) -> list[list[tuple[str, str]]]:
    """Tokens grouped into sentences: a sentence ends with a punctuation run holding
    ``. ! ? …`` or at a blank line."""
    sentences: list[list[tuple[str, str]]] = []
    for para in re.split(r"\n\s*\n", text):
        cur: list[tuple[str, str]] = []
        for tok, kind in tokenize(para):
            cur.append((tok, kind))
            if kind == "punct" and _SENTENCE_END.search(tok):
                sentences.append(cur)
                cur = []
        if cur:
            sentences.append(cur)
    return [s for s in sentences if any(k == "word" for _, k in s)]


def unit_ranges(units: Sequence[int]) -> list[tuple[int, int]]:
    """First and last unit of each component (Eq 6.7, 6.8), 1-based inclusive."""
    out, total = [], 0
    for a in units:
        out.append((total + 1, total + a))
        total += a
    return out


def frame_ranges(units: Sequence[int], first: int, last: int) -> list[tuple[float, float]]:
    """Eq 6.5, 6.9, 6.10 in frames: the constituent spans frames ``first``…``last``
    (inclusive); returns each component's (t_s, t_e) frame, not rounded."""
    length = last - first + 1  # Eq 6.5
    u_c = sum(units)
    return [(first + (us - 1) * length / u_c, first - 1 + ue * length / u_c)
            for us, ue in unit_ranges(units)]


def time_components(tokens: Sequence[tuple[str, str]], start: float, end: float, *,
                    mode: str = "letters") -> Constituent:
    """Divide [start, end] seconds between ``tokens`` in proportion to their units
    (Eq 6.9/6.10 in continuous time: t_s = T_s + (u_s − 1)·L/u_c, t_e = T_s + u_e·L/u_c)."""
    if end < start:
        raise ParameterError(f"constituent end={end:g} s is before start={start:g} s")
    units = [1 if k == "punct" else vowel_units(t, mode=mode) for t, k in tokens]
    u_c = sum(units)
    step = (end - start) / u_c if u_c else 0.0
    comps = tuple(
        Component(t, k, a, start + (us - 1) * step, start + ue * step)
        for (t, k), a, (us, ue) in zip(tokens, units, unit_ranges(units), strict=True)
    )
    return Constituent(comps, start, end)


def sync_text(
    text: str,
    *,
    start: float = 0.0,
    rate: float = DEFAULT_RATE,
    pause: float = 0.0,
    sentence_times: Sequence[tuple[float, float]] | None = None,
    mode: str = "letters",
) -> list[Constituent]:
    """Time every word and punctuation run of ``text``.

    Parameters
    ----------
    text : the script
    start : time of the first sentence (s)
    rate : seconds per unit (> 0) when sentence times are not given
    pause : extra silence between sentences (s, ≥ 0; the seed's Eq 6.4 uses 0)
    sentence_times : optional (start, end) seconds per sentence, e.g. from TTS
    mode : unit counting, see :func:`vowel_units`
    """
    if not rate > 0:
        raise ParameterError(f"rate={rate!r} seconds per unit must be > 0")
    if pause < 0:
        raise ParameterError(f"pause={pause!r} must be ≥ 0")
    sentences = split_sentences(text)
    if sentence_times is not None and len(sentence_times) != len(sentences):
        raise ParameterError(f"sentence_times has {len(sentence_times)} entries but the text "
                             f"has {len(sentences)} sentences")
    out, t = [], float(start)
    for i, toks in enumerate(sentences):
        if sentence_times is not None:
            s, e = (float(x) for x in sentence_times[i])
        else:
            units = sum(1 if k == "punct" else vowel_units(w, mode=mode) for w, k in toks)
            s, e = t, t + units * rate
        out.append(time_components(toks, s, e, mode=mode))
        t = e + pause
    return out


def gap_frames(a: tuple[float, float], b: tuple[float, float], *, fps: float = 25.0) -> float:
    """Neutral frames between two time ranges (Eq 6.12 in continuous time); 0 if they touch."""
    gap = max(0.0, b[0] - a[1], a[0] - b[1])
    return gap * fps


def linked(a: tuple[float, float], b: tuple[float, float], *, fps: float = 25.0,
           max_frames: float = LINK_FRAMES) -> bool:
    """Eq 6.13: a word and an expression are linked when at most ``max_frames`` apart."""
    return gap_frames(a, b, fps=fps) <= max_frames + 1e-6
