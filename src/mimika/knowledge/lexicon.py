"""The emotional-word lexicon (seed 002 App. D.1/D.2, Table 6.13) in English, German and Polish.

``knowledge/data/lexicon.csv`` holds the seed's 126 words, one row each:
``no, category, source, pl, en, de``. ``category`` is one of the 8 categories of App. D.2
(Praise, Pleasure, Curiosity, Assent, Sorrow, Fright, Irritation, Disapproval) or ``-``;
``source`` says whether the seed classified the word (``D.2``) or mimika did (``mimika``).
Each language cell lists patterns separated by ``|``: a lower-case word form, a stem ending in
``*`` (prefix match, at least 3 letters, so ``irritat*`` matches *irritated*, *irritating*) or
a phrase of such tokens (``w porządku``, ``all right``). Matching lower-cases the text and
compares whole tokens; no other stemming is done.
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources

from mimika.errors import DataError, ParameterError

LANGS = ("en", "de", "pl")
CATEGORIES = ("Praise", "Pleasure", "Curiosity", "Assent", "Sorrow", "Fright", "Irritation",
              "Disapproval")


@dataclass(frozen=True)
class LexEntry:
    """One emotional word: its number in App. D.1, category and patterns per language."""

    no: int
    category: str  #: one of CATEGORIES, or "-" (no category)
    source: str  #: "D.2" (the seed's classification) or "mimika"
    patterns: dict[str, tuple[tuple[str, ...], ...]]

    def label(self, lang: str = "en") -> str:
        return " ".join(self.patterns[lang][0]).rstrip("*")


@dataclass(frozen=True)
class WordMatch:
    """A lexicon hit: token indices ``[first, last]`` in the tokenised text and the entry."""

    first: int
    last: int
    text: str
    entry: LexEntry

    @property
    def category(self) -> str:
        return self.entry.category


def _token_matches(pattern: str, token: str) -> bool:
    if pattern.endswith("*"):
        return token.startswith(pattern[:-1])
    return token == pattern


def valid_lang(lang: str) -> str:
    code = str(lang).lower()
    if code not in LANGS:
        raise ParameterError(f"lang={lang!r} must be one of {', '.join(LANGS)}")
    return code


class Lexicon:
    """Emotional words in en/de/pl; :meth:`find` scans tokens for them."""

    def __init__(self, entries: Sequence[LexEntry]):
        self.entries = tuple(entries)

    def __len__(self) -> int:
        return len(self.entries)

    def by_category(self, category: str) -> list[LexEntry]:
        return [e for e in self.entries if e.category == category]

    def lookup(self, word: str, lang: str = "en") -> list[LexEntry]:
        """Entries whose single-token patterns match ``word`` (case-insensitive)."""
        lang = valid_lang(lang)
        w = word.lower()
        return [e for e in self.entries
                if any(len(p) == 1 and _token_matches(p[0], w) for p in e.patterns[lang])]

    def find(self, tokens: Sequence[str], lang: str = "en") -> list[WordMatch]:
        """Every match in ``tokens`` (words, already split); phrases match consecutive tokens.

        At each position the longest pattern of each entry wins; one token may match entries
        of several categories (``dobrze`` is both Praise and Assent).
        """
        lang = valid_lang(lang)
        low = [t.lower() for t in tokens]
        out: list[WordMatch] = []
        for i in range(len(low)):
            for e in self.entries:
                best = 0
                for p in e.patterns[lang]:
                    n = len(p)
                    if n > best and i + n <= len(low) and all(
                            _token_matches(q, t) for q, t in zip(p, low[i:i + n], strict=True)):
                        best = n
                if best:
                    out.append(WordMatch(i, i + best - 1, " ".join(tokens[i:i + best]), e))
        return out


def _parse(text: str, source: str) -> Lexicon:
    entries = []
    rows = csv.DictReader(text.splitlines())
    for n, row in enumerate(rows, start=2):
        where = f"{source}:{n}"
        try:
            cat = row["category"].strip()
            if cat not in (*CATEGORIES, "-"):
                raise DataError(f"{where}: unknown category {cat!r}")
            pats: dict[str, tuple[tuple[str, ...], ...]] = {}
            for lang in LANGS:
                items = tuple(tuple(p.strip().lower().split()) for p in row[lang].split("|")
                              if p.strip())
                for p in items:
                    for q in p:
                        if q.endswith("*") and len(q) < 4:
                            raise DataError(f"{where}: stem {q!r} is too short (≥ 3 letters)")
                if not items:
                    raise DataError(f"{where}: no {lang} patterns")
                pats[lang] = items
            entries.append(LexEntry(int(row["no"]), cat, row["source"].strip(), pats))
        except (KeyError, ValueError, AttributeError) as e:
            raise DataError(f"{where}: malformed lexicon row: {e}") from None
    return Lexicon(entries)


@lru_cache(maxsize=1)
def default_lexicon() -> Lexicon:
    """The built-in lexicon (126 entries, cached)."""
    text = resources.files("mimika.knowledge").joinpath("data/lexicon.csv").read_text("utf-8")
    return _parse(text, "lexicon.csv")
