"""Where a recording has speech: frame energy, sustained activity, and word edges that follow it.

Frame energy is the mean of the log mel band powers (every band weighs the same, so /s/ and
/f/ count as much as vowels), in dB, every 10 ms. A frame is active when it is more than
``threshold`` of the way from the noise floor (10th percentile) to the speech level (95th
percentile, of frames within 45 dB of it, so padding with digital silence does not lower
it); only runs of at least ``min_run`` seconds count, so clicks, lip smacks and short breaths
in the silence around an utterance do not start it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from mimika.speech.utterance import Phone

HOP = 0.01  #: activity frame step (s)
THRESHOLD = 0.3
MIN_RUN = 0.06
#: frames more than this far below the speech level do not count for the noise floor (dB)
RANGE_DB = 45.0
#: how far a word edge next to a pause may move to meet the energy (s)
EDGE_WINDOW = 0.15
#: silent closure allowed before the first sound of a word after a pause (a stop's closure)
CLOSURE = 0.05
#: the same for a word that starts with another sound: its first frames are weak (s)
ONSET = 0.025
#: ``refine_edges``'s ``ends`` apply before pauses at least this long (s): a short one may be
#: a stop's closure after a weak word ending
LONG_PAUSE = 0.15
#: a silence this long before the end of a pause phone: what sounds after it is the next word
NEXT_GAP = 0.1
#: frame energy (:func:`frame_energy`) of all-zero samples: the 1e-10 floor's −100 dB
SILENCE_DB = -99.0
#: a burst this close after sustained sound belongs to it (s): a weak word ending's last
#: syllable, too short to count on its own (German "regnen" after its /g/)
TRAIL_GAP = 0.15


def frame_energy(audio: np.ndarray, *, sr: int, hop: float = HOP) -> np.ndarray:
    """Mean log mel power per frame in dB, shape (n_frames,); frame i centred at i·hop s."""
    from mimika.speech.alignment import mel_power

    return 10.0 * np.log10(mel_power(audio, sr=sr, hop=hop) + 1e-10).mean(axis=1)


def activity(audio: np.ndarray, *, sr: int, hop: float = HOP, threshold: float = THRESHOLD,
             min_run: float = MIN_RUN) -> np.ndarray:
    """Boolean speech activity per frame (runs shorter than ``min_run`` s removed)."""
    return sustained(above(frame_energy(audio, sr=sr, hop=hop), threshold), hop=hop,
                     min_run=min_run)


def above(e: np.ndarray, threshold: float = THRESHOLD) -> np.ndarray:
    """Frames of energy ``e`` (:func:`frame_energy`) more than ``threshold`` of the way from
    the noise floor to the speech level."""
    hi = np.percentile(e, 95)
    # the floor of the recording's own background: digital silence (padding, a muted
    # stretch) far below it must not make that background look like speech
    lo = np.percentile(e[e > hi - RANGE_DB], 10)
    return e > lo + threshold * (hi - lo)


def sustained(act: np.ndarray, *, hop: float = HOP, min_run: float = MIN_RUN) -> np.ndarray:
    """``act`` without its active runs shorter than ``min_run`` s."""
    n = max(1, round(min_run / hop))
    out = np.zeros_like(act)
    k = 0
    while k < len(act):
        if act[k]:
            j = k
            while j < len(act) and act[j]:
                j += 1
            if j - k >= n:
                out[k:j] = True
            k = j
        else:
            k += 1
    return out


def trailing(act: np.ndarray, raw: np.ndarray, *, hop: float = HOP, gap: float = TRAIL_GAP
             ) -> np.ndarray:
    """``act`` (sustained activity) extended by the bursts of ``raw`` (frames above the
    threshold) that follow it within ``gap`` s of its last frame, chained."""
    out = act.copy()
    reach = round(gap / hop)
    last = -reach - 1
    for i in np.flatnonzero(act | raw):
        if act[i]:
            last = i
        elif i - last <= reach:
            out[last + 1:i + 1] = True
            last = i
    return out


def to_silence(act: np.ndarray, e: np.ndarray, *, hop: float = HOP, reach: float = EDGE_WINDOW
               ) -> np.ndarray:
    """``act`` with each active run extended through the quiet frames after it when digital
    silence (:data:`SILENCE_DB`, the all-zero samples TTS output and edited audio carry between
    sentences) begins within ``reach`` s: nothing there is a pause yet, so a word's faint end —
    a devoiced final vowel under the activity threshold — still belongs to it."""
    out = act.copy()
    silent = e <= SILENCE_DB
    n, k = len(act), round(reach / hop)
    for i in np.flatnonzero(act[:-1] & ~act[1:]):
        j = i + 1
        while j < n and j - i <= k and not silent[j] and not act[j]:
            j += 1
        if j < n and j - i <= k and silent[j]:
            out[i + 1:j] = True
    return out


def speech_span(act: np.ndarray, *, hop: float = HOP) -> tuple[float, float] | None:
    """(start, end) in seconds of the first and last active frame; None when all is silent."""
    on = np.flatnonzero(act)
    if not len(on):
        return None
    return float(on[0] * hop), float((on[-1] + 1) * hop)


def _next_word_at_end(seg: np.ndarray, gap: int) -> int | None:
    """Where the last run of active frames starts in ``seg`` (a word's end up to the end of
    the pause after it) when it reaches the segment's end after at least ``gap`` silent frames
    — the next word's first sound, the pause mapped a little late; else None."""
    on = np.flatnonzero(seg)
    if not len(on) or on[-1] != len(seg) - 1:
        return None
    jumps = np.flatnonzero(np.diff(on) > 1)
    if not len(jumps) or on[jumps[-1] + 1] - on[jumps[-1]] <= gap:
        return None
    return int(on[jumps[-1] + 1])


def refine_edges(phones: Sequence[Phone], act: np.ndarray, *, hop: float = HOP,
                 window: float = EDGE_WINDOW, closure: float = CLOSURE,
                 is_stop: Callable[[str], bool] | None = None,
                 ends: np.ndarray | None = None) -> list[Phone]:
    """Move the boundaries between pauses and speech to where the energy starts and stops,
    earlier or later.

    After a pause (or at the start of the recording), a word begins at its first active frame
    after the pause began — ``closure`` s before it when the word starts with a stop (its
    silent closure; every word when ``is_stop`` is not given), :data:`ONSET` s before it
    otherwise — at most 2·``window`` from where it was; before a pause (or the end), a word
    lasts until its last active frame before the pause ends, at most ``window`` from where it
    was — but not onto a sound that begins after :data:`NEXT_GAP` s of silence at the pause's
    end (the next word's); ``ends``: the activity those ends follow instead of ``act`` before
    a pause of at least :data:`LONG_PAUSE` (a reverberant room's, at a higher threshold, the
    next word then starting after the tail ``act`` still holds; a dry one's
    :func:`trailing`). A phone keeps at least 30 ms.
    Returns as many phones as given, in the same order; a zero-length pause at either end
    (see :func:`pad`) lets the first and last word move too.
    """
    keep = 0.03
    n = len(act)
    out = list(phones)

    def frame(t: float) -> int:
        return int(np.clip(round(t / hop), 0, n))

    for k in range(1, len(out)):
        a, b = out[k - 1], out[k]
        if a.is_pause == b.is_pause:
            continue
        t = a.end
        if a.is_pause:  # speech starts: the first sound after the pause began
            lo = frame(max(a.start, t - 2 * window))
            if ends is not None and a.end - phones[k - 1].start >= LONG_PAUSE:
                # the previous word's last sound (in a room, its tail) is no onset
                tail = frame(a.start)
                while tail < frame(t) and act[tail]:
                    tail += 1
                lo = max(lo, tail)
            on = np.flatnonzero(act[lo:frame(b.end + window)])
            if not len(on):
                continue
            c = closure if is_stop is None or is_stop(b.symbol) else ONSET
            new = float(np.clip((lo + on[0]) * hop - c, t - 2 * window, t + 2 * window))
        else:  # speech stops: the last sound before the pause ends
            lo = frame(a.start - window)
            src = act if ends is None or b.end - b.start < LONG_PAUSE else ends
            seg = src[lo:frame(min(b.end, t + window))]
            nxt = _next_word_at_end(seg, round(NEXT_GAP / hop))
            on = np.flatnonzero(seg[:nxt])
            if not len(on):
                continue
            new = float(np.clip((lo + on[-1] + 1) * hop, t - window, t + window))
            if nxt is not None:  # the silence before the next word's sound: only later
                new = max(new, t)
        lo_t, hi_t = a.start + keep, b.end - keep
        if b.end <= t:  # a zero-length end pause: only the word before it moves
            hi_t = t
        if a.end <= a.start:  # a zero-length start pause
            lo_t = t
        new = min(max(new, lo_t), hi_t)
        if abs(new - t) < 1e-9 or hi_t < lo_t:
            continue
        out[k - 1] = Phone(a.symbol, a.start, new, a.stress)
        out[k] = Phone(b.symbol, new, b.end, b.stress)
    return out


def pad(phones: Sequence[Phone], owner: Sequence[int]) -> tuple[list[Phone], list[int]]:
    """Zero-length pauses at both ends (owner -1), for :func:`refine_edges`."""
    dur = phones[-1].end if phones else 0.0
    return ([Phone("_", 0.0, 0.0), *phones, Phone("_", dur, dur)], [-1, *owner, -1])


def unpad(phones: Sequence[Phone], owner: Sequence[int]) -> tuple[list[Phone], list[int]]:
    """Drop empty phones and merge neighbouring pauses (inverse of :func:`pad`)."""
    out: list[Phone] = []
    own: list[int] = []
    for p, o in zip(phones, owner, strict=True):
        if p.end <= p.start:
            continue
        if out and p.is_pause and out[-1].is_pause:
            out[-1] = Phone("_", out[-1].start, p.end)
            continue
        out.append(p)
        own.append(o)
    return out, own
