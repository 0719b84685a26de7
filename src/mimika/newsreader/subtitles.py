"""SRT subtitles from word timings: one cue per sentence."""

from __future__ import annotations

import os
import textwrap
from dataclasses import dataclass
from typing import Any

from mimika.io.atomic import atomic_write

#: a cue stays this long after its last word (s), unless the next cue starts first
LINGER = 0.35
LINE = 42


@dataclass(frozen=True)
class Cue:
    """One subtitle: ``start``/``end`` in seconds and its ``text``."""

    start: float
    end: float
    text: str


def sentence_cues(utterance: Any, *, linger: float = LINGER) -> list[Cue]:
    """One :class:`Cue` per sentence: first word start → last word end (+ ``linger``)."""
    cues: list[Cue] = []
    sents = list(utterance.sentences)
    for i, s in enumerate(sents):
        ws = [w for w in utterance.words if s.start - 1e-6 <= w.start < s.end]
        start = ws[0].start if ws else s.start
        end = ws[-1].end if ws else s.end
        nxt = None
        if i + 1 < len(sents):
            nw = [w for w in utterance.words if sents[i + 1].start - 1e-6 <= w.start]
            nxt = nw[0].start if nw else sents[i + 1].start
        end = min(end + linger, nxt - 0.04) if nxt is not None else min(
            end + linger, utterance.duration)
        cues.append(Cue(start, max(end, start + 0.1), " ".join(s.text.split())))
    return cues


def _stamp(t: float) -> str:
    ms = max(0, round(t * 1000))
    h, ms = divmod(ms, 3_600_000)
    m, ms = divmod(ms, 60_000)
    s, ms = divmod(ms, 1000)
    return f"{h:02d}:{m:02d}:{s:02d},{ms:03d}"


def srt_text(cues: list[Cue]) -> str:
    """The SRT document of ``cues`` (lines wrapped at 42 characters)."""
    out = []
    for i, c in enumerate(cues, 1):
        body = "\n".join(textwrap.wrap(c.text, LINE)) or c.text
        out.append(f"{i}\n{_stamp(c.start)} --> {_stamp(c.end)}\n{body}\n")
    return "\n".join(out)


def parse_srt(text: str) -> list[Cue]:
    """Read cues back from SRT text (for tests and round trips)."""
    cues = []
    for block in text.strip().split("\n\n"):
        lines = block.strip().splitlines()
        if len(lines) < 2:
            continue
        a, b = (x.strip() for x in lines[1].split("-->"))

        def sec(s: str) -> float:
            hh, mm, rest = s.split(":")
            ss, ms = rest.split(",")
            return int(hh) * 3600 + int(mm) * 60 + int(ss) + int(ms) / 1000

        cues.append(Cue(sec(a), sec(b), " ".join(" ".join(lines[2:]).split())))
    return cues


def write_srt(path: str | os.PathLike, cues: list[Cue]) -> None:
    """Write ``cues`` as an SRT file (UTF-8, atomically)."""
    atomic_write(path, srt_text(cues))
