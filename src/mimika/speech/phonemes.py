"""The common phoneme inventory: espeak-ng mnemonics → mimika phoneme classes.

Tables live in ``speech/data/phonemes.json`` (mnemonic → class, per-language overrides,
multi-target phonemes such as diphthongs) and ``speech/data/visemes.json`` (per-class AU
targets, dominance and export visemes). Unknown mnemonics never raise: they fall back to
espeak-ng's own phoneme type and place of articulation (read from its ``phontab``), then to
the first character, with one logged warning per symbol.
"""

from __future__ import annotations

import json
import logging
import os
import struct
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any

from mimika.speech.utterance import Utterance

log = logging.getLogger(__name__)

_warned: set[tuple[str, str]] = set()


@cache
def phoneme_table() -> dict[str, Any]:
    """The parsed ``phonemes.json``."""
    return json.loads(resources.files("mimika.speech").joinpath("data/phonemes.json")
                      .read_text("utf-8"))


@cache
def viseme_table() -> dict[str, Any]:
    """The parsed ``visemes.json``."""
    return json.loads(resources.files("mimika.speech").joinpath("data/visemes.json")
                      .read_text("utf-8"))


@cache
def ipa_table() -> dict[str, str]:
    """IPA → espeak-ng mnemonic (``speech/data/ipa.json``)."""
    return json.loads(resources.files("mimika.speech").joinpath("data/ipa.json")
                      .read_text("utf-8"))["ipa"]


def ipa_to_espeak(ph: str) -> str:
    """IPA → espeak mnemonics, longest match first (``"təˈmɑːtoʊ"`` → ``"t@'mA:toU"``);
    characters the table lacks are dropped."""
    table = ipa_table()
    longest = max(map(len, table))
    out, i = [], 0
    while i < len(ph):
        for n in range(min(longest, len(ph) - i), 0, -1):
            if ph[i:i + n] in table:
                out.append(table[ph[i:i + n]])
                i += n
                break
        else:
            i += 1
    return "".join(out)


def class_names() -> list[str]:
    """All phoneme class names, in table order."""
    return list(viseme_table()["classes"])


@cache
def _espeak_phontab() -> dict[str, dict[str, tuple[int, int]]]:
    """espeak-ng's phoneme tables: ``{table: {mnemonic: (type, place)}}`` with inheritance
    resolved; empty when espeak-ng data is not installed."""
    try:
        import espeakng_loader

        with open(os.path.join(espeakng_loader.get_data_path(), "phontab"), "rb") as f:
            data = f.read()
    except (ImportError, OSError):  # pragma: no cover
        return {}
    n = struct.unpack_from("<i", data, 0)[0]
    off, raw = 4, []
    for _ in range(n):
        nph, inc = data[off], data[off + 1]
        name = data[off + 4:off + 36].split(b"\0")[0].decode("latin-1")
        off += 36
        ph = {}
        for _ in range(nph):
            mn, fl, _prog, code, typ = struct.unpack_from("<IIHBB", data, off)
            off += 16
            if code:
                sym = mn.to_bytes(4, "little").rstrip(b"\0").decode("latin-1")
                ph[sym] = (typ, (fl >> 16) & 0xF)
        raw.append((name, inc, ph))
    out: dict[str, dict[str, tuple[int, int]]] = {}
    for name, inc, ph in raw:
        merged = dict(out[raw[inc - 1][0]]) if inc else {}
        merged.update(ph)
        out[name] = merged
    return out


def espeak_inventory(lang: str) -> dict[str, tuple[int, int]]:
    """Every phoneme espeak-ng's table for ``lang`` defines: ``{mnemonic: (type, place)}``
    (type 0 pause, 2 vowel, 3 liquid, 4/5 stop, 6/7 fricative, 8 nasal)."""
    tabs = _espeak_phontab()
    code = lang.lower()
    while code:
        if code in tabs:
            return tabs[code]
        code = code.rpartition("-")[0]
    return {}


def is_stop(symbol: str, lang: str) -> bool:
    """Whether an espeak-ng mnemonic is a stop or affricate in ``lang`` (stress marks
    ignored): a sound that begins with a silent closure."""
    return espeak_inventory(lang).get(strip_stress(symbol)[0], (-1, 0))[0] in (4, 5)


def _lang_overrides(lang: str) -> dict[str, Any]:
    table = phoneme_table()["languages"]
    out: dict[str, Any] = {}
    code = lang.lower()
    chain = []
    while code:
        chain.append(code)
        code = code.rpartition("-")[0]
    for c in reversed(chain):
        out.update(table.get(c, {}))
    return out


def strip_stress(sym: str) -> tuple[str, int]:
    """An espeak-ng phoneme without its stress marks, and the stress (2 primary, 1 secondary,
    0 none)."""
    stress = 0
    while sym and sym[0] in "',%=":
        stress = max(stress, 2 if sym[0] == "'" else 1 if sym[0] == "," else 0)
        sym = sym[1:]
    return sym, stress


def classify(symbol: str, lang: str = "en") -> tuple[str, ...]:
    """Phoneme classes of one espeak mnemonic (one class, or several for diphthongs).

    Stress marks are ignored; unknown symbols fall back (logged once) and never raise.
    """
    return _classify(symbol.lstrip("',%="), lang.lower())


@cache
def _classify(sym: str, lang: str) -> tuple[str, ...]:
    if not sym or sym.startswith("_"):
        return ("sil",)
    over = _lang_overrides(lang)
    val = over.get(sym, phoneme_table()["phonemes"].get(sym))
    if val is not None:
        return tuple(val) if isinstance(val, list) else (val,)
    fb = phoneme_table()["fallback"]
    typ, place = espeak_inventory(lang).get(sym, (-1, 0))
    if typ == 0:
        cls = "sil"
    elif typ not in (2, 3, -1) and str(place) in fb["place"]:
        cls = fb["place"][str(place)]
    else:
        cls = fb["first_char"].get(sym[0], fb["default"])
    if (sym, lang) not in _warned:
        _warned.add((sym, lang))
        log.warning("phoneme %r (lang %s) is not in phonemes.json; treating it as %s",
                    sym, lang, cls)
    return (cls,)


@dataclass(frozen=True)
class Segment:
    """A stretch of time with one phoneme class (a phone, or one part of a diphthong)."""

    cls: str
    start: float
    end: float
    symbol: str
    stress: int = 0
    phone: int = -1  #: index into ``utterance.phonemes``

    @property
    def duration(self) -> float:
        return self.end - self.start


def segments(utterance: Utterance) -> list[Segment]:
    """The utterance's phones expanded into class segments (diphthongs split equally)."""
    out: list[Segment] = []
    for i, p in enumerate(utterance.phonemes):
        classes = classify(p.symbol, utterance.lang)
        n = len(classes)
        d = (p.end - p.start) / n
        for k, c in enumerate(classes):
            out.append(Segment(c, p.start + k * d, p.start + (k + 1) * d, p.symbol, p.stress, i))
    return out
