"""Long recordings cut into pieces at pauses, so that an aligner whose memory grows with the
square of the length (pocketsphinx's state alignment keeps a backpointer per frame and per
HMM state: 480 s took 3.6 GB) only ever sees :data:`PIECE` seconds at a time.

Where to cut comes from a first, linear-memory alignment of the whole recording (DTW against
espeak-ng, :mod:`mimika.speech.dtw`): a cut lies in a pause of the recording (the longest one
between :data:`MIN_PIECE` and :data:`PIECE` s after the last cut) where that alignment has no
word, and every word goes to the piece its middle falls in. Phones of the pieces are then
joined into one list tiling the recording.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mimika.speech.utterance import Phone
from mimika.speech.vad import HOP

#: recordings longer than this are aligned piece by piece; no piece is longer (s)
PIECE = 60.0
#: a piece is at least this long, the last one too, where the recording allows (s; at most
#: half of :data:`PIECE`)
MIN_PIECE = 20.0
#: silence at least this long is a place to cut (s)
MIN_PAUSE = 0.15
#: a cut this close to a word's edge still counts as outside it (s)
SLACK = 0.05


def _pauses(act: np.ndarray, hop: float) -> tuple[np.ndarray, np.ndarray]:
    """Middles and lengths (s) of the runs of inactive frames at least :data:`MIN_PAUSE` long."""
    quiet = np.concatenate([[False], ~np.asarray(act, bool), [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(quiet))
    s, e = edges[::2], edges[1::2]
    keep = (e - s) * hop >= MIN_PAUSE
    return (s[keep] + e[keep]) * 0.5 * hop, (e[keep] - s[keep]) * hop


def cut_times(spans: np.ndarray, act: np.ndarray, dur: float, *, hop: float = HOP
              ) -> list[float]:
    """Times (s) to cut a recording of ``dur`` s into pieces of at most :data:`PIECE` s.

    ``spans`` (K, 2): the words' (start, end) from a rough alignment, in order; ``act``: speech
    activity per ``hop`` s (:func:`mimika.speech.vad.activity`). A cut goes in the longest pause
    outside every word in reach, else between two words, else (one word longer than a piece)
    at the furthest point.
    """
    spans = np.asarray(spans, float).reshape(-1, 2)
    mids, lengths = _pauses(act, hop)
    if len(spans):  # pauses inside a word (a stop's closure) are no place to cut
        k = np.searchsorted(spans[:, 0], mids - SLACK) - 1
        inside = (k >= 0) & (mids < spans[np.maximum(k, 0), 1] - SLACK)
        mids, lengths = mids[~inside], lengths[~inside]
    gaps = 0.5 * (spans[:-1, 1] + spans[1:, 0]) if len(spans) > 1 else np.zeros(0)
    out: list[float] = []
    t = 0.0
    while dur - t > PIECE:
        lo, hi = t + MIN_PIECE, min(t + PIECE, dur - MIN_PIECE)  # no stub left at the end
        sel = (mids >= lo) & (mids <= hi)
        if sel.any():
            k = np.flatnonzero(sel)[::-1]  # the longest; of equals, the latest
            t = float(mids[k[np.argmax(lengths[k])]])
        elif ((gaps >= lo) & (gaps <= hi)).any():
            t = float(gaps[(gaps >= lo) & (gaps <= hi)][-1])
        else:
            t = hi
        out.append(t)
    return out


def assign(spans: np.ndarray, cuts: Sequence[float]) -> list[range]:
    """The words (indices into ``spans``) of each piece: the piece their middle falls in."""
    mid = np.asarray(spans, float).reshape(-1, 2).mean(axis=1)
    bounds = [0, *np.searchsorted(mid, np.asarray(cuts, float)).tolist(), len(mid)]
    bounds = np.maximum.accumulate(bounds).tolist()
    return [range(bounds[k], bounds[k + 1]) for k in range(len(bounds) - 1)]


def clip(phones: Sequence[Phone], owner: Sequence[int], t0: float, t1: float
         ) -> tuple[list[Phone], list[int]]:
    """The phones of ``[t0, t1]`` (cut at its edges) and their owners."""
    out, own = [], []
    for p, o in zip(phones, owner, strict=True):
        s, e = max(p.start, t0), min(p.end, t1)
        if e > s:
            out.append(Phone(p.symbol, s, e, p.stress))
            own.append(o)
    return out, own


def shift(phones: Sequence[Phone], owner: Sequence[int], dt: float, dk: int
          ) -> tuple[list[Phone], list[int]]:
    """Phones ``dt`` s later, word owners ``dk`` further on (pauses stay -1)."""
    return ([Phone(p.symbol, p.start + dt, p.end + dt, p.stress) for p in phones],
            [o + dk if o >= 0 else -1 for o in owner])


def join(parts: Sequence[tuple[Sequence[Phone], Sequence[int]]]
         ) -> tuple[list[Phone], list[int]]:
    """The phones of consecutive pieces as one list; pauses meeting at a cut become one."""
    phones: list[Phone] = []
    owner: list[int] = []
    for ps, os_ in parts:
        for p, o in zip(ps, os_, strict=True):
            if phones and p.is_pause and phones[-1].is_pause:
                phones[-1] = Phone("_", phones[-1].start, p.end)
                continue
            phones.append(p)
            owner.append(o)
    return phones, owner
