"""Timed speech: phones, words and sentences over an audio signal (the TTS/alignment output).

Times are seconds from the start of ``audio``. The same type comes out of
:func:`mimika.speech.synthesize` and :func:`mimika.speech.align`, so everything downstream
(visemes, AU tracks, exports) is independent of where the timing came from.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mimika.errors import DataError, ParameterError
from mimika.io.atomic import atomic_write
from mimika.limits import loads_json

FORMAT_VERSION = 1


@dataclass(frozen=True)
class Phone:
    """One phoneme: espeak mnemonic without stress marks (``"aI"``, ``"tS"``, ``"_"`` = pause),
    ``start``/``end`` in seconds, ``stress`` 0 (none) | 1 (secondary ``,``) | 2 (primary ``'``)."""

    symbol: str
    start: float
    end: float
    stress: int = 0

    @property
    def duration(self) -> float:
        return self.end - self.start

    @property
    def is_pause(self) -> bool:
        return self.symbol.startswith("_") or self.symbol == ""


@dataclass(frozen=True)
class Word:
    """A word: its ``text``, ``start``/``end`` in seconds and ``offset`` (character index of the
    word in the full input text, 0-based; -1 when unknown)."""

    text: str
    start: float
    end: float
    offset: int = -1


@dataclass(frozen=True)
class Sentence:
    """A sentence as synthesised (or aligned): ``text``, ``start``/``end`` in seconds."""

    text: str
    start: float
    end: float


@dataclass
class Utterance:
    """Audio plus its phoneme, word and sentence timing.

    Attributes
    ----------
    audio : ndarray, shape (n_samples,), float32 in [-1, 1]
    sr : int
        Sample rate of ``audio`` in Hz.
    phonemes, words, sentences : lists of :class:`Phone`, :class:`Word`, :class:`Sentence`
        Phones tile ``[0, duration]`` without gaps (pauses are phones with symbol ``_``).
    lang : str
        espeak language code the phonemes belong to (``en``, ``de``, ``pl`` …).
    text : str
        The full input text.
    """

    audio: np.ndarray
    sr: int
    phonemes: list[Phone]
    words: list[Word] = field(default_factory=list)
    sentences: list[Sentence] = field(default_factory=list)
    lang: str = "en"
    text: str = ""
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def duration(self) -> float:
        """Length in seconds: the audio length, or the last phone's end without audio."""
        if len(self.audio):
            return len(self.audio) / self.sr
        return self.phonemes[-1].end if self.phonemes else 0.0

    def shifted(self, dt: float, char0: int = 0
                ) -> tuple[list[Phone], list[Word], list[Sentence]]:
        """Phones, words and sentences moved by ``dt`` s, word offsets by ``char0``."""
        ph = [Phone(p.symbol, p.start + dt, p.end + dt, p.stress) for p in self.phonemes]
        ws = [Word(w.text, w.start + dt, w.end + dt, w.offset + char0 if w.offset >= 0 else -1)
              for w in self.words]
        ss = [Sentence(x.text, x.start + dt, x.end + dt) for x in self.sentences]
        return ph, ws, ss

    def timing_dict(self) -> dict[str, Any]:
        """The timing as JSON-ready dict (no audio); see ``docs/speech.md`` for the format."""
        r = 4
        return {
            "format": "mimika-speech-timing",
            "version": FORMAT_VERSION,
            "lang": self.lang,
            "text": self.text,
            "sr": self.sr,
            "duration": round(self.duration, r),
            "sentences": [{"text": s.text, "start": round(s.start, r), "end": round(s.end, r)}
                          for s in self.sentences],
            "words": [{"text": w.text, "start": round(w.start, r), "end": round(w.end, r),
                       "offset": w.offset} for w in self.words],
            "phonemes": [{"symbol": p.symbol, "start": round(p.start, r), "end": round(p.end, r),
                          "stress": p.stress} for p in self.phonemes],
            "meta": {k: v for k, v in self.meta.items() if _jsonable(v)},
        }

    @classmethod
    def from_timing_dict(cls, d: dict[str, Any], *, audio: np.ndarray | None = None,
                         sr: int | None = None) -> Utterance:
        """Inverse of :meth:`timing_dict` (audio optional)."""
        try:
            ph = [Phone(p["symbol"], float(p["start"]), float(p["end"]), int(p.get("stress", 0)))
                  for p in d["phonemes"]]
            words = [Word(w["text"], float(w["start"]), float(w["end"]), int(w.get("offset", -1)))
                     for w in d.get("words", [])]
            sents = [Sentence(s["text"], float(s["start"]), float(s["end"]))
                     for s in d.get("sentences", [])]
        except (KeyError, TypeError, ValueError) as e:
            raise DataError(f"timing data is malformed: {e!r}") from None
        a = np.zeros(0, np.float32) if audio is None else np.asarray(audio, np.float32)
        return cls(a, int(sr or d.get("sr", 22050)), ph, words, sents,
                   lang=d.get("lang", "en"), text=d.get("text", ""), meta=dict(d.get("meta", {})))

    def save_timing(self, path: str | os.PathLike) -> None:
        """Write :meth:`timing_dict` as JSON (atomically)."""
        write_text_atomic(path, json.dumps(self.timing_dict(), ensure_ascii=False, indent=1))

    @classmethod
    def load_timing(cls, path: str | os.PathLike) -> Utterance:
        try:
            d = loads_json(Path(path).read_bytes(), str(path))
        except (OSError, DataError) as e:
            raise DataError(f"cannot read timing file {str(path)!r}: {e}") from None
        return cls.from_timing_dict(d)


def _jsonable(v: Any) -> bool:
    try:
        json.dumps(v)
    except (TypeError, ValueError):
        return False
    return True


def write_text_atomic(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` via a temporary file and ``os.replace``."""
    _write_atomic(path, text.encode("utf-8"))


def _write_atomic(path: str | os.PathLike, data: bytes) -> None:
    p = Path(path)
    if p.parent and not p.parent.exists():
        raise ParameterError(f"cannot write {str(p)!r}: folder {str(p.parent)!r} does not exist")
    atomic_write(p, data)
