"""Text normalisation: the words a newsreader says for what is written, in en / de / pl.

espeak-ng reads plain digits well, but not currency symbols before a number ("$3.5 million"),
German ordinals ("am 3. Oktober"), abbreviations ("z. B.", "np."), German years ("1999" as
*neunzehnhundertneunundneunzig*), Polish years and days, which are ordinals in their case
("w 1999 r." as *w tysiąc dziewięćset dziewięćdziesiątym dziewiątym roku*, "3 października"
as *trzeciego października*), clock times ("um 14:30 Uhr" as *vierzehn Uhr dreißig*, not
*vierzehn Uhr dreißig Uhr*) or dates in digits ("am 1.1.2025", "3/10/2024"). :func:`spans`
finds those places, each with its character offsets in the original text and its spoken form;
:func:`spoken_text` is the text the TTS is given. :func:`say_as` reads SSML ``<say-as>`` content and
:func:`no_break_after` tells whether a ``.`` ends a sentence.

Number words (cardinals and ordinals, 0–999 999 999) are written here: ``num2words`` is not a
dependency of mimika and does not cover the German ordinal endings (*am dritten*, *der
zweite*, *dritter März*) or the Polish genitive and feminine ordinals (*dziesiątego marca*,
*czternasta*) this module needs. Words, month names, abbreviations and currencies live in
``data/normalize.json``; the rules are in the code below.

``lang`` is an espeak-ng voice code ("en-us", "de", "pl"): only the part before "-" counts.
Languages without data get no spans; :func:`say_as` returns their text unchanged, except
``characters`` and ``telephone``, which only space the characters.
"""

from __future__ import annotations

import functools
import json
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from importlib import resources
from typing import Any

from mimika.errors import ParameterError

Table = dict[str, Any]

_NUM = r"\d+(?:[.,]\d+)*"
_INTERPRET_AS = ("date", "time", "ordinal", "cardinal", "characters", "telephone")


@dataclass(frozen=True)
class Span:
    """``text[start:end]`` is read as ``spoken``."""

    start: int
    end: int
    spoken: str


@functools.cache
def _data() -> dict[str, Table]:
    path = resources.files("mimika.speech").joinpath("data/normalize.json")
    return json.loads(path.read_text(encoding="utf-8"))


def _base(lang: str) -> str:
    return lang.replace("_", "-").split("-")[0].lower()


def _table(lang: str) -> Table | None:
    return _data().get(_base(lang))


# --------------------------------------------------------------------------- numbers


def _plural(forms: dict[str, str], n: int | None) -> str:
    """The form of a noun after the number ``n`` (None: a fraction), Polish rules."""
    if n is None:
        key = "fraction"
    elif n == 1:
        key = "one"
    elif 2 <= n % 10 <= 4 and not 12 <= n % 100 <= 14:
        key = "few"
    else:
        key = "many"
    for k in (key, "many", "one"):
        if k in forms:
            return forms[k]
    raise KeyError(key)


def _en_cardinal(n: int, t: Table) -> str:
    if n < 20:
        return t["ones"][n]
    if n < 100:
        unit = n % 10
        return t["tens"][n // 10] + (f"-{t['ones'][unit]}" if unit else "")
    if n < 1000:
        rest = n % 100
        head = f"{t['ones'][n // 100]} {t['hundred']}"
        return head + (f" {_en_cardinal(rest, t)}" if rest else "")
    for value, word in t["large"]:
        if n >= value:
            head, rest = divmod(n, value)
            words = f"{_en_cardinal(head, t)} {word}"
            return words + (f" {_en_cardinal(rest, t)}" if rest else "")
    raise AssertionError(n)


def _en_ordinal(n: int, t: Table) -> str:
    words = _en_cardinal(n, t)
    cut = max(words.rfind(" "), words.rfind("-")) + 1
    head, last = words[:cut], words[cut:]
    if last in t["ordinal_irregular"]:
        return head + t["ordinal_irregular"][last]
    if last.endswith("y"):
        return head + last[:-1] + t["ordinal_y_suffix"]
    return head + last + t["ordinal_suffix"]


def _de_below_100(n: int, t: Table, final: bool = True) -> str:
    """1–99; ``final`` False gives *ein* instead of *eins* (before *hundert*, *tausend*)."""
    if n == 1 and not final:
        return t["one_compound"]
    if n < 20:
        return t["ones"][n]
    unit = n % 10
    head = (_de_below_100(unit, t, final=False) + t["and"]) if unit else ""
    return head + t["tens"][n // 10]


def _de_below_1000(n: int, t: Table, final: bool = True) -> str:
    hundreds, rest = divmod(n, 100)
    words = _de_below_100(hundreds, t, final=False) + t["hundred"] if hundreds else ""
    return words + (_de_below_100(rest, t, final) if rest else "")


def _de_cardinal(n: int, t: Table) -> str:
    if n == 0:
        return t["ones"][0]
    millions, n = divmod(n, 1_000_000)
    parts = []
    if millions:
        forms = t["million"]
        parts.append(forms["one"] if millions == 1 else
                     f"{_de_cardinal(millions, t)} {forms['many']}")
    thousands, rest = divmod(n, 1000)
    words = _de_below_1000(thousands, t, final=False) + t["thousand"] if thousands else ""
    words += _de_below_1000(rest, t) if rest else ""
    if words:
        parts.append(words)
    return " ".join(parts)


def _de_ordinal_stem(n: int, t: Table) -> str:
    """*dritt*, *zwanzigst*, *einhunderterst*: add -e, -en, -er."""
    words = _de_cardinal(n, t)
    small = n % 100
    if not 0 < small < 20:
        return words + t["ordinal_suffix_large"]
    tail = t["ones"][small]
    stem = t["ordinal_stems"].get(str(small), tail + t["ordinal_suffix_small"])
    return words[: len(words) - len(tail)] + stem


def _pl_below_1000(n: int, t: Table) -> list[str]:
    hundreds, rest = divmod(n, 100)
    words = [t["hundreds"][hundreds]] if hundreds else []
    if rest >= 20:
        words.append(t["tens"][rest // 10])
        rest %= 10
    if rest:
        words.append(t["ones"][rest])
    return words


def _pl_cardinal(n: int, t: Table) -> str:
    if n == 0:
        return t["ones"][0]
    words: list[str] = []
    for value, forms in t["large"]:
        count, n = divmod(n, value)
        if count:
            words += ([] if count == 1 else _pl_below_1000(count, t)) + [_plural(forms, count)]
    return " ".join(words + _pl_below_1000(n, t))


def _pl_ordinal_parts(n: int, t: Table) -> list[tuple[str, bool]]:
    """Words of the ordinal ``n``, each flagged True when it takes the case ending."""
    small, big = n % 100, n - n % 100
    if small:
        head = [(_pl_cardinal(big, t), False)] if big else []
        if small < 20:
            return [*head, (t["ordinal_ones"][small], True)]
        tens = [(t["ordinal_tens"][small // 10], True)]
        units = [(t["ordinal_ones"][small % 10], True)] if small % 10 else []
        return head + tens + units
    hundreds, thousands = (n % 1000) // 100, n - n % 1000
    if hundreds:
        head = [(_pl_cardinal(thousands, t), False)] if thousands else []
        return [*head, (t["ordinal_hundreds"][hundreds], True)]
    if n % 1000 == 0 and 1 <= n // 1000 < len(t["ordinal_thousands"]):
        return [(t["ordinal_thousands"][n // 1000], True)]
    if n == 0:
        return [(t["ordinal_ones"][0], True)]
    return [(_pl_cardinal(n, t), False)]


def _pl_ordinal(n: int, t: Table, form: str = "nom") -> str:
    rules = t["ordinal_forms"][form]

    def inflect(word: str) -> str:
        for old, new in rules:
            if word.endswith(old):
                return word[: len(word) - len(old)] + new
        return word

    return " ".join(inflect(w) if flagged else w for w, flagged in _pl_ordinal_parts(n, t))


def cardinal_words(n: int, lang: str) -> str:
    """``n`` (0–999 999 999) in words; negative numbers start with *minus*."""
    table = _table(lang)
    if table is None:
        return str(n)
    if n < 0:
        return f"{table['minus']} {cardinal_words(-n, lang)}"
    if n >= 1_000_000_000 and _base(lang) != "en":
        raise ParameterError(f"number {n}: words are written for 0–999 999 999 only")
    writer = {"en": _en_cardinal, "de": _de_cardinal, "pl": _pl_cardinal}[_base(lang)]
    return writer(n, table["numbers"])


def ordinal_words(n: int, lang: str, form: str = "") -> str:
    """The ordinal ``n`` in words.

    ``form`` is the German ending ("e", "en", "er"; default "e") or the Polish case
    ("nom", "gen", "loc", "fem", "fem_obl"; default "nom"); English ignores it.
    """
    table = _table(lang)
    if table is None or n < 0:
        return f"{n}."
    if n >= 1_000_000 and _base(lang) != "en":
        raise ParameterError(f"ordinal {n}: words are written for 0–999 999 only")
    t = table["numbers"]
    base = _base(lang)
    if base == "en":
        return _en_ordinal(n, t)
    if base == "de":
        return _de_ordinal_stem(n, t) + (form or "e")
    return _pl_ordinal(n, t, form or "nom")


def year_words(year: int, lang: str) -> str:
    """A year as read aloud: *nineteen ninety-nine*, *neunzehnhundertneunundneunzig*."""
    table = _table(lang)
    base = _base(lang)
    if table is None or not 1000 <= year <= 9999 or base == "pl":
        return cardinal_words(year, lang) if table else str(year)
    t = table["numbers"]
    high, low = divmod(year, 100)
    if base == "de":
        if not 1100 <= year <= 1999:
            return _de_cardinal(year, t)
        return _de_below_100(high, t, final=False) + t["hundred"] + (
            _de_below_100(low, t) if low else "")
    if high % 10 == 0 and low < 10:  # 1000–1009, 2000–2009
        return _en_cardinal(year, t)
    if low == 0:
        return f"{_en_cardinal(high, t)} {t['hundred']}"
    if low < 10:
        return f"{_en_cardinal(high, t)} {t['year_oh']} {_en_cardinal(low, t)}"
    return f"{_en_cardinal(high, t)} {_en_cardinal(low, t)}"


def _number_value(written: str, table: Table) -> int | None:
    """The integer a written number stands for; None for a fraction ("3.5", "2,50")."""
    decimal = table["decimal"]
    groups = written.replace("." if decimal == "," else ",", "")
    return None if decimal in groups else int(groups)


# --------------------------------------------------------------------------- span rules


def _alternation(words: list[str]) -> str:
    return "|".join(re.escape(w) for w in sorted(words, key=len, reverse=True))


def _starts_sentence(text: str, end: int) -> bool:
    """Whether what follows ``text[:end]`` looks like a new sentence (or nothing)."""
    rest = text[end:].lstrip()
    return not rest or rest[0].isupper()


def _currency_spans(text: str, table: Table) -> Iterator[Span]:
    currencies, scales = table["currencies"], table["scales"]
    symbols = _alternation(list(currencies))
    prefix = _alternation([s for s, c in currencies.items() if c["prefix"]])
    scale = _alternation(list(scales))
    patterns = [
        rf"(?<![\w.,])(?P<num>{_NUM})\s?(?:(?P<scale>{scale})\s?)?(?P<sym>{symbols})(?!\w)",
        rf"(?P<sym>{prefix})\s?(?P<num>{_NUM})(?:\s?(?P<scale>{scale})(?!\w))?",
    ]
    for pattern in patterns:
        for m in re.finditer(pattern, text):
            value = _number_value(m["num"], table)
            words = [m["num"]]
            if m["scale"]:
                words.append(_plural(scales[m["scale"]], value))
                value = 0  # "5 million dollars", "5 mln złotych"
            if _attributive(text, m.start(), m.end(), table):
                value = 1  # "a 3.5 million dollar deal"
            words.append(_plural(currencies[m["sym"]], value))
            yield Span(m.start(), m.end(), " ".join(words))


def _attributive(text: str, start: int, end: int, table: Table) -> bool:
    """Whether an amount stands before its noun ("a $3 million deal", "the $20 fee"), where
    English names the currency in the singular."""
    rules = table.get("attributive")
    if rules is None or _previous_word(text, start) not in rules["after"]:
        return False
    following = re.match(r"\s+([a-z]+)\b", text[end:])
    return bool(following) and following[1] not in rules["not_before"]


def _percent_spans(text: str, table: Table) -> Iterator[Span]:
    for m in re.finditer(r"(?<=\d)\s?%", text):
        yield Span(m.start(), m.end(), f" {table['percent']}")


def _scale_spans(text: str, table: Table) -> Iterator[Span]:
    """Abbreviated scale words after a number: "5 mln" → "5 milionów"."""
    scale = _alternation(list(table["scales"]))
    for m in re.finditer(rf"(?<![\w.,])(?P<num>{_NUM})\s?(?P<scale>{scale})(?!\w)", text):
        spoken = _plural(table["scales"][m["scale"]], _number_value(m["num"], table))
        if spoken != m["scale"]:
            yield Span(m.start("scale"), m.end(), spoken)


def _year_spans(text: str, table: Table) -> Iterator[Span]:
    if "years" not in table:
        return
    low, high = table["years"]
    for m in re.finditer(r"(?<![\w.,:/$€£¥-])\d{4}(?![\w%-]|[.,:/]\d|\s%)", text):
        if low <= int(m[0]) <= high:
            yield Span(m.start(), m.end(), year_words(int(m[0]), table["_lang"]))


def _en_ordinal_spans(text: str, table: Table) -> Iterator[Span]:
    suffixes = _alternation(table.get("ordinal_suffixes", []))
    if not suffixes:
        return
    for m in re.finditer(rf"(?<![\w.,])(\d+)(?:{suffixes})\b", text):
        yield Span(m.start(), m.end(), _en_ordinal(int(m[1]), table["numbers"]))


@dataclass(frozen=True)
class _Ordinal:
    start: int
    dot: int  # offset of the ordinal's "."
    value: int
    ending: str


def _de_ordinals(text: str, table: Table) -> Iterator[_Ordinal]:
    """German ordinals "3." before a month, or after an article or preposition."""
    rules = table.get("ordinals")
    if rules is None:
        return
    endings, months = rules["endings"], table["months"]
    for m in re.finditer(r"(?<![\w.,:/])(\d{1,3})\.(?!\d)", text):
        before = re.search(r"(?:([^\W\d_]+)\s+)?([^\W\d_]+)\s+$", text[: m.start()])
        preposition, previous = (before[1] or "", before[2].lower()) if before else ("", "")
        following = re.match(r"\s+([^\W\d_]+)", text[m.end():])
        if previous in rules["after_preposition"] and preposition.lower() in rules[
                "prepositions"]:
            ending = rules["after_preposition"][previous]
        elif previous in endings:
            ending = endings[previous]
        elif following and following[1] in months:
            ending = rules["before_month"]
        else:
            continue
        yield _Ordinal(m.start(), m.end() - 1, int(m[1]), ending)


def _de_ordinal_spans(text: str, table: Table) -> Iterator[Span]:
    for o in _de_ordinals(text, table):
        words = _de_ordinal_stem(o.value, table["numbers"]) + o.ending
        final = not text[o.dot + 1:].strip()
        yield Span(o.start, o.dot + 1, words + ("." if final else ""))


@dataclass(frozen=True)
class _Abbreviation:
    start: int
    end: int
    entry: dict[str, Any]
    capital: bool  # written with a capital although listed in lower case


@functools.cache
def _abbreviation_pattern(written: str) -> re.Pattern[str]:
    parts = [re.escape(p) for p in written.split(" ")]
    first = written[0]
    if first.islower():
        parts[0] = f"[{first}{first.upper()}]" + parts[0][len(re.escape(first)):]
    right = r"(?!\w)" if written[-1].isalnum() else ""
    return re.compile(r"(?<![\w.])" + r"\s*".join(parts) + right)


_BEFORE = {"name": re.compile(r"\s+[^\W\d_]"), "digit": re.compile(r"[\s:]*[+(]?\d")}


def _fits_context(text: str, start: int, end: int, entry: dict[str, Any]) -> bool:
    """Whether an abbreviation's ``before``/``after`` condition holds (a name, a digit)."""
    before = entry.get("before")
    if before and not _BEFORE[before].match(text, end):
        return False
    if before == "name" and not text[end:].lstrip()[:1].isupper():
        return False
    return entry.get("after") != "digit" or bool(re.search(r"\d\s*$", text[:start]))


def _abbreviations(text: str, table: Table) -> Iterator[_Abbreviation]:
    for entry in table["abbreviations"]:
        for m in _abbreviation_pattern(entry["written"]).finditer(text):
            if _fits_context(text, m.start(), m.end(), entry):
                yield _Abbreviation(m.start(), m.end(), entry, m[0][0] != entry["written"][0])


def _abbreviation_spans(text: str, table: Table) -> Iterator[Span]:
    for a in _abbreviations(text, table):
        spoken = a.entry["spoken"]
        if a.capital:
            spoken = spoken[0].upper() + spoken[1:]
        if a.entry.get("final") and text[a.end - 1] == "." and _starts_sentence(text, a.end):
            spoken += "."
        yield Span(a.start, a.end, spoken)


def _previous_word(text: str, start: int) -> str:
    """The word (with a trailing ".", lower case) just before ``text[start:]``."""
    m = re.search(r"([^\W\d_]+\.?)\s*$", text[:start])
    return m[1].lower() if m else ""


def _time_spans(text: str, table: Table) -> Iterator[Span]:
    """Clock times: "um 14:30 Uhr", "at 7:05 p.m.", "o godz. 14:30" — where the words
    around say it is a time (a score "3:1" or a ratio is left alone)."""
    t, base = table["time"], table["_lang"]
    pattern = (r"(?<![\w.,:])(?P<h>\d{1,2})(?P<sep>[:.])(?P<m>\d{2})"
               r"(?:\s?(?P<ampm>[ap]\.?m\.?)(?!\w))?(?P<uhr>\s+Uhr\b)?(?![\w:]|[.,]\d)")
    for m in re.finditer(pattern, text, re.IGNORECASE if base == "en" else 0):
        previous = _previous_word(text, m.start())
        if int(m["h"]) > 24 or int(m["m"]) > 59:
            continue
        if base == "de" and not (m["uhr"] or (m["sep"] == ":" and previous in t["after"])):
            continue
        if base == "en" and not (m["sep"] == ":" and (m["ampm"] or previous in t["after"])):
            continue
        if base == "pl" and m["sep"] != ":":
            continue
        form = "fem_obl" if previous in t.get("oblique_after", ()) else "fem"
        clock = f"{m['h']}:{m['m']}" + (f" {m['ampm']}" if m["ampm"] else "")
        end = m.end()
        if m["ampm"] and m["ampm"].endswith(".") and _starts_sentence(text, end):
            end -= 1  # "p.m." ends the sentence too: its dot stays
        yield Span(m.start(), end, _say_time(clock, table, base, form))
    if base == "pl":  # "o godz. 8": the hour alone
        for m in re.finditer(r"(?<=godz\.)\s*(\d{1,2})(?![\d:.,]|\.\d)", text):
            if int(m[1]) <= 24:
                yield Span(m.start(1), m.end(1), _say_time(f"{m[1]}:00", table, base, "fem_obl"))


def _pl_year_spans(text: str, table: Table) -> Iterator[Span]:
    """Polish years are ordinals: "w 1999 r." → *w tysiąc dziewięćset dziewięćdziesiątym
    dziewiątym roku* (locative after *w*, *po*), "od 2020 roku", "3 października 2024"
    (genitive), "rok 1999" (nominative)."""
    rules = table.get("years_ordinal")
    if rules is None:
        return
    before = _alternation(rules["before"])
    months = _alternation(table["months_genitive"])
    for m in re.finditer(r"(?<![\w.,:/])(\d{4})(?![\w%]|[.,:/]\d)", text):
        previous = _previous_word(text, m.start())
        after_month = re.search(rf"(?:{months})\s+$", text[:m.start()])
        if after_month:
            form = "gen"
        elif previous in rules["after"]:  # "rok 1999", "do końca roku 2024"
            form = rules["after"][previous]
        elif re.match(rf"\s*(?:{before})(?!\w)", text[m.end():]):
            form = "loc" if previous in rules["loc_after"] else "gen"
        else:
            continue
        yield Span(m.start(), m.end(), _pl_ordinal(int(m[1]), table["numbers"], form))


def _pl_day_spans(text: str, table: Table) -> Iterator[Span]:
    """A Polish day before a month is an ordinal in the genitive: "3 października" →
    *trzeciego października*."""
    if "months_genitive" not in table:
        return
    months = _alternation(table["months_genitive"])
    for m in re.finditer(rf"(?<![\w.,:/])(\d{{1,2}})(?=\s+(?:{months})(?!\w))", text):
        if 1 <= int(m[1]) <= 31:
            yield Span(m.start(), m.end(), ordinal_words(int(m[1]), "pl", "gen"))


def _numeric_date_spans(text: str, table: Table) -> Iterator[Span]:
    """Dates in digits: "am 1.1.2025" (de), "3.10.2024 r." (pl), "3/10/2024" (en, month
    first), "2024-03-10" (every language) — read with the month's name, as :func:`say_as`
    reads a date."""
    base = table["_lang"]
    pattern = r"(?<![\w/])(\d{1,2})/(\d{1,2})/(\d{4})(?![\w/])" if base == "en" else \
        r"(?<![\w.,:/])(\d{1,2})\.(\d{1,2})\.(\d{4})(?![\w%]|[.,]\d)"
    iso = r"(?<![\w.,:/-])(\d{4})-(\d{2})-(\d{2})(?![\w/-])"
    found = [(m, table["date_format"]) for m in re.finditer(pattern, text)]
    found += [(m, "ymd") for m in re.finditer(iso, text)]
    for m, fmt in found:
        values = dict(zip(fmt, map(int, m.groups()), strict=True))
        if not (1 <= values["m"] <= 12 and 1 <= values["d"] <= 31):
            continue
        ending = ""
        if base == "de":  # the day's ending from the word before it: "am ersten Januar"
            rules = table["ordinals"]
            ending = rules["endings"].get(_previous_word(text, m.start()),
                                          rules["before_month"])
        yield Span(m.start(), m.end(), _date_words(values, table, table["_code"], ending))


def _decade_spans(text: str, table: Table) -> Iterator[Span]:
    """Decades: "the 1990s", "the '80s" → *the nineteen nineties*, *the eighties*; German
    "1990er", "20er" → *neunzehnhundertneunziger*, *zwanziger*; Polish "w latach 90." →
    *w latach dziewięćdziesiątych*."""
    base = table["_lang"]
    if base == "pl":
        yield from _pl_decade_spans(text, table)
        return
    suffix = "s" if base == "en" else "er"
    for m in re.finditer(rf"(?<![\w.,])'?(\d{{2}}|\d{{4}})'?{suffix}(?![^\W_])", text):
        n = int(m[1])
        if n % 10:
            continue
        words = year_words(n, base) if len(m[1]) == 4 else cardinal_words(n, base)
        if base == "de":
            yield Span(m.start(), m.end(), words + "er")
            continue
        head, _, last = words.rpartition(" ")
        last = last[:-1] + "ies" if last.endswith("y") else last + "s"
        yield Span(m.start(), m.end(), f"{head} {last}".strip())


def _pl_decade_spans(text: str, table: Table) -> Iterator[Span]:
    """Polish decades after a form of *lata*: an ordinal plural in its case."""
    endings = table.get("decades", {})
    words = _alternation(list(endings))
    for m in re.finditer(rf"(?<!\w)({words})\s+(\d0)(\.|-(?:e|te|tych|ych))?(?!\w)", text,
                         re.IGNORECASE):
        stem = _pl_ordinal(int(m[2]), table["numbers"])[:-1]  # dziewięćdziesiąt(y)
        final = "." if m[3] == "." and _starts_sentence(text, m.end()) else ""
        yield Span(m.start(2), m.end(), stem + endings[m[1].lower()] + final)


_PHONE_GROUP = r"\(?\d+\)?\d*"
_PHONE = re.compile(rf"(?<![\w+,.])(?P<n>\+?{_PHONE_GROUP}(?:[ \-/]{_PHONE_GROUP})*)"
                    r"(?![\w%]|[.,]\d)")
_SLASH_DATE = re.compile(r"\d{1,2}/\d{1,4}(?:/\d{2,4})?")
_THOUSANDS = re.compile(r"\d{1,3}(?: \d{3})+")
_WORD = re.compile(r"[^\W\d_]+\.?")


def _telephone_spans(text: str, table: Table) -> Iterator[Span]:
    """Telephone numbers in running text, digit by digit in their written groups: an
    international "+49 30 1234567", a trunk-prefixed "0800 123 456" or "030/1234567", or any
    three or more digits within three words after "Tel.", "call", "Telefon", "infolinia" …
    (``telephone_after``). Thousands written with spaces ("1 000 000") and dates stay."""
    after = table.get("telephone_after", ())
    for m in _PHONE.finditer(text):
        written = m["n"]
        if _SLASH_DATE.fullmatch(written):
            continue
        digits = sum(ch.isdigit() for ch in written)
        before = _WORD.findall(text, max(0, m.start() - 40), m.start())[-3:]
        cue = any(w.lower().rstrip(".") in after for w in before)
        shaped = (written.startswith("+") or written.lstrip("(").startswith("0")) and digits >= 6
        if (cue and digits >= 3) or (shaped and not _THOUSANDS.fullmatch(written)):
            yield Span(m.start(), m.end(), _say_telephone(written, table))


_RULES: tuple[Callable[[str, Table], Iterator[Span]], ...] = (
    _numeric_date_spans, _time_spans, _decade_spans, _currency_spans, _percent_spans,
    _de_ordinal_spans, _abbreviation_spans, _telephone_spans, _scale_spans, _year_spans,
    _pl_year_spans, _pl_day_spans, _en_ordinal_spans,
)


def _date_format(table: Table, lang: str) -> str:
    """The order of day, month and year in ``lang``'s dates: the language's, or its region's
    (British English writes the day first)."""
    code = lang.replace("_", "-").lower()
    for region, fmt in table.get("date_format_regions", {}).items():
        if code.startswith(region):
            return fmt
    return table["date_format"]


def _lang_table(lang: str) -> Table | None:
    table = _table(lang)
    return None if table is None else {**table, "_lang": _base(lang), "_code": lang,
                                       "date_format": _date_format(table, lang)}


def spans(text: str, lang: str) -> list[Span]:
    """Non-overlapping, sorted spans of ``text`` whose reading differs from the letters.

    Rules earlier in ``_RULES`` win where two overlap (currency before year, ...).
    """
    table = _lang_table(lang)
    if table is None:
        return []
    taken: list[Span] = []
    for rule in _RULES:
        for span in rule(text, table):
            if all(span.end <= s.start or span.start >= s.end for s in taken):
                taken.append(span)
    return sorted(taken, key=lambda s: s.start)


def spoken_text(text: str, lang: str) -> str:
    """``text`` with every span replaced by its spoken form (what the TTS is given)."""
    out, pos = [], 0
    for span in spans(text, lang):
        out += [text[pos:span.start], span.spoken]
        pos = span.end
    return "".join([*out, text[pos:]])


# --------------------------------------------------------------------------- sentence ends


def no_break_after(text: str, pos: int, lang: str) -> bool:
    """True when a '.' at ``text[pos]`` does NOT end a sentence.

    Decimal points, German ordinals before a noun or month ("am 3. Oktober"), a number's dot
    before a word in lower case ("w latach 90. było"), abbreviations ("Dr.", "z. B.", "np.";
    "usw."/"etc." only when the text goes on in lower case) and single initials ("J. Smith").
    """
    if not 0 <= pos < len(text) or text[pos] != ".":
        return False
    if 0 < pos < len(text) - 1 and text[pos - 1].isdigit() and text[pos + 1].isdigit():
        return True
    # only the words around the '.' decide: look at them alone (a long article has thousands)
    lo = text.rfind(" ", 0, max(pos - _CONTEXT, 0)) + 1
    hi = text.find(" ", min(pos + _CONTEXT, len(text)))
    hi = len(text) if hi < 0 else hi
    more = _NON_SPACE.search(text, hi) is not None
    return _no_break_after(text[lo:hi], pos - lo, lang, more)


#: characters either side of a '.' that :func:`no_break_after` looks at (whole words)
_CONTEXT = 80
_NON_SPACE = re.compile(r"\S")


def _no_break_after(text: str, pos: int, lang: str, more: bool) -> bool:
    """:func:`no_break_after` on the words around the '.'; ``more``: text follows them."""
    table = _lang_table(lang)
    if pos and text[pos - 1].isdigit() and re.match(r"\s+[^\W\d_]", text[pos + 1:]) and \
            text[pos + 1:].lstrip()[0].islower():
        return True  # an ordinal's dot: "w latach 90. było", "am 3. oder 4. Mai"
    if table is not None:
        for a in _abbreviations(text, table):
            if a.start <= pos < a.end:
                is_last = pos == a.end - 1
                return not (a.entry.get("final") and is_last and _starts_sentence(text, a.end))
        for o in _de_ordinals(text, table):
            if o.dot == pos:
                return more or bool(text[pos + 1:].strip())
    return bool(re.search(r"(?<![\w.])[^\W\d_]$", text[:pos])) and text[pos - 1].isupper()


# --------------------------------------------------------------------------- say-as


def _parse_int(text: str) -> int:
    """A whole number, digits grouped by threes or not ("1,234", "1 234", "1234")."""
    written = text.strip()
    if not re.fullmatch(r"[+-]?(?:\d{1,3}(?:[\s\u00a0,.'’]\d{3})+|\d+)", written):
        raise ParameterError(f"say-as: {text!r} is not a whole number")
    return int(re.sub(r"[\s\u00a0,.'’]", "", written))


def _date_words(values: dict[str, int], table: Table, lang: str, ending: str = "") -> str:
    """The date ``values`` (d, m, y) in words; ``ending``: the German day's (default the
    table's ``date_day``: *zehnter März*; after "am": *zehnten*)."""
    day, month, year = values.get("d"), values.get("m"), values.get("y")
    base = _base(lang)
    year_text = year_words(year, lang) if year is not None else None
    if base == "en":
        if day and month and _date_format(table, lang).startswith("d"):  # British
            head = f"the {ordinal_words(day, lang)} of {table['months'][month - 1]}"
            return f"{head}, {year_text}" if year_text else head
        head = " ".join(w for w in (
            table["months"][month - 1] if month else None,
            ordinal_words(day, lang) if day else None) if w)
        return f"{head}, {year_text}" if head and year_text and day else " ".join(
            w for w in (head, year_text) if w)
    if base == "de":
        words = [ordinal_words(day, lang, ending or table["ordinals"]["date_day"]) if day
                 else None,
                 table["months"][month - 1] if month else None, year_text]
    else:
        months = table["months_genitive"] if day else table["months"]
        words = [ordinal_words(day, lang, "gen") if day else None,
                 months[month - 1] if month else None,
                 _pl_ordinal(year, table["numbers"], "gen") if year is not None else None]
    return " ".join(w for w in words if w)


def _say_date(text: str, table: Table, lang: str, format: str | None) -> str:
    fmt = (format or _date_format(table, lang)).lower()
    numbers = re.findall(r"\d+", text)
    if not fmt or set(fmt) - set("dmy") or len(set(fmt)) != len(fmt) or len(numbers) != len(
            fmt):
        raise ParameterError(f"say-as date: {text!r} does not match format {fmt!r}")
    values = dict(zip(fmt, map(int, numbers), strict=True))
    if not 1 <= values.get("m", 1) <= 12 or not 1 <= values.get("d", 1) <= 31:
        raise ParameterError(f"say-as date: {text!r} has no such day or month ({fmt})")
    return _date_words(values, table, lang)


def _say_time(text: str, table: Table, lang: str, form: str = "fem") -> str:
    """``text`` (14:30, 9:05 pm) read as a time; ``form``: the Polish hour's case ("fem",
    "fem_obl" after *o*, *od*, *do*: *o czternastej*)."""
    m = re.fullmatch(r"\s*(\d{1,2})[:.h](\d{2})\s*([ap]\.?m\.?)?\s*", text, re.IGNORECASE)
    if m is None or int(m[1]) > 24 or int(m[2]) > 59:
        raise ParameterError(f"say-as time: {text!r} is not a time such as 14:30")
    hour, minute, base, t = int(m[1]), int(m[2]), _base(lang), table["time"]
    if base == "en":
        if minute == 0:
            words = f"{cardinal_words(hour, lang)} {t['full_hour']}"
        elif minute < 10:
            words = f"{cardinal_words(hour, lang)} {t['oh']} {cardinal_words(minute, lang)}"
        else:
            words = f"{cardinal_words(hour, lang)} {cardinal_words(minute, lang)}"
        if m[3]:
            words += " " + t["pm" if m[3][0].lower() == "p" else "am"]
        return words
    if base == "de":
        hour_word = _de_below_100(hour, table["numbers"], final=False) if hour else \
            cardinal_words(0, lang)
        minutes = f" {cardinal_words(minute, lang)}" if minute else ""
        return f"{hour_word} {t['hour']}{minutes}"
    hour_word = ordinal_words(hour, lang, form) if hour else t["midnight"]
    if not minute:
        return hour_word
    minutes = cardinal_words(minute, lang)
    return f"{hour_word} {cardinal_words(0, lang)} {minutes}" if minute < 10 else \
        f"{hour_word} {minutes}"


def _say_ordinal(text: str, lang: str) -> str:
    digits = re.sub(r"(?i)(st|nd|rd|th|\.)$", "", text.strip())
    return ordinal_words(_parse_int(digits), lang)


def _say_characters(text: str) -> str:
    return " ".join(ch for ch in text if ch.isalnum())


def _say_telephone(text: str, table: Table | None) -> str:
    if text.lstrip().startswith("+"):  # "+49 (0)30 …": the trunk 0 is not dialled from abroad
        text = re.sub(r"\(0\)", " ", text)
    groups = [g for g in re.split(r"[\s\-./()]+", text.strip()) if g]
    plus = table["plus"] if table else "+"
    spoken = [" ".join(plus if ch == "+" else ch for ch in g if ch.isalnum() or ch == "+")
              for g in groups]
    return ", ".join(s for s in spoken if s)


def say_as(text: str, interpret_as: str, lang: str, format: str | None = None) -> str:
    """The reading of SSML ``<say-as interpret-as=…>`` content.

    ``date`` (``format`` one of the orders of d, m, y such as mdy, dmy, ymd, md, ym, y;
    default en mdy, de/pl dmy), ``time``, ``ordinal``, ``cardinal``, ``characters`` (letters
    and digits one by one, separated by spaces) and ``telephone`` (digit by digit, groups as
    written separated by ", ").
    """
    kind = interpret_as.strip().lower()
    if kind not in _INTERPRET_AS:
        raise ParameterError(f"say-as interpret-as={interpret_as!r}: expected one of "
                             f"{', '.join(_INTERPRET_AS)}")
    table = _table(lang)
    if kind == "characters":
        return _say_characters(text)
    if kind == "telephone":
        return _say_telephone(text, table)
    if table is None:
        return text
    if kind == "date":
        return _say_date(text, table, lang, format)
    if kind == "time":
        return _say_time(text, table, lang)
    if kind == "ordinal":
        return _say_ordinal(text, lang)
    return cardinal_words(_parse_int(text), lang)
