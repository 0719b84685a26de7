"""Sampling a :class:`~mimika.timeline.model.Timeline` into an :class:`~mimika.tracks.AUTrack`.

Per channel, events chain (seed 002 §5.4): the first rises from neutral over its onset, each
holds its AU set over its apex, then turns *directly* into the next event's AU set (using the
next event's easing) — no dip to neutral in between, even across a gap (unless the gap exceeds
the channel's ``bridge``) — and the last decays to neutral over its offset. Transient events
(blink, nod, shake) add their own short curves. Channels then add up and are clipped to [0, 1];
an ``override`` channel blends toward its own values by its activity weight instead of adding.
Finally the AU Blender (FACS co-occurrence rules, issue 4) may be applied (``blend=True``).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from mimika.errors import ParameterError
from mimika.facs import BODY_CHANNELS, is_body, parse_au
from mimika.limits import check_timeline
from mimika.timeline.easing import get_interpolator
from mimika.timeline.model import DIRECTIONS, KIND_TIMING, Channel, Event, Timeline
from mimika.tracks import AUTrack, valid_fps

log = logging.getLogger(__name__)

__all__ = ["ExpressionSource", "Resolved", "au_order", "resolve_event", "sample", "sample_times"]


class ExpressionSource(Protocol):
    """Anything with ``get(name)`` returning an object with ``aus``, ``onset``, ``offset`` and
    ``duration`` — :class:`mimika.knowledge.ExpressionLibrary` is one."""

    def get(self, name: str) -> Any: ...


#: head-AU peak of a nod / shake at intensity 1 (AU54 at 1 is a 25° bow; a nod is ≈ 10°)
GESTURE_AMPLITUDE = {"nod": 0.4, "shake": 0.35}


def default_library() -> ExpressionSource:
    """The knowledge base's expression library (built-ins + the user's file)."""
    from mimika.knowledge import ExpressionLibrary

    return ExpressionLibrary()


@dataclass(frozen=True)
class Resolved:
    """An event's AU set (already scaled by intensity) and effective onset/offset (s)."""

    aus: dict[str, float]
    onset: float
    offset: float


def resolve_event(event: Event, library: ExpressionSource | None = None) -> Resolved:
    """AU values and onset/offset of ``event`` (defaults from the library or the kind)."""
    k = event.intensity
    if event.kind == "expression":
        expr = (library or default_library()).get(event.name)
        aus = {parse_au(c): float(v) * k for c, v in expr.aus.items()}
        on_d, off_d = float(expr.onset), float(expr.offset)
    elif event.kind == "aus":
        aus = {c: v * k for c, v in event.aus}
        _, on_d, off_d = KIND_TIMING["aus"]
    elif event.kind in DIRECTIONS:
        aus = dict.fromkeys(DIRECTIONS[event.kind][event.name], k)
        _, on_d, off_d = KIND_TIMING[event.kind]
    else:  # nod, shake: shaped by their own curves
        aus = {}
        on_d = off_d = 0.0
    on = event.onset if event.onset is not None else on_d
    off = event.offset if event.offset is not None else off_d
    if on + off > event.duration:  # defaults longer than a short event: shrink proportionally
        f = event.duration / (on + off)
        on, off = on * f, off * f
    return Resolved({c: min(max(v, 0.0), 1.0) for c, v in aus.items()}, on, off)


def au_order(code: str) -> tuple[int, int]:
    """Sort key: catalogue order, bilateral before L before R; body channels last."""
    if is_body(code):
        return (1000 + list(BODY_CHANNELS).index(code), 0)
    return (int(code[2:4]), ("", "L", "R").index(code[4:]))


def _interp(name: str):
    return get_interpolator(name)


def _channel(ch: Channel, t: np.ndarray, library: ExpressionSource | None
             ) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Curves of one channel: {code: (T,)} and its activity weight (T,) in [0, 1]."""
    chain = [e for e in ch.events if not e.transient]
    res = [resolve_event(e, library) for e in chain]
    trans = [e for e in ch.events if e.transient]
    codes = sorted({c for r in res for c in r.aus} | {c for e in trans
                                                      for c in _transient_codes(e)},
                   key=au_order)
    idx = {c: j for j, c in enumerate(codes)}
    vals = np.zeros((len(t), len(codes) + 1), np.float32)  # last column: activity weight
    chans = (*codes, "weight")

    def vec(r: Resolved) -> np.ndarray:
        v = np.zeros(len(codes) + 1, np.float32)
        for c, x in r.aus.items():
            v[idx[c]] = x
        v[-1] = 1.0
        return v

    zero = np.zeros(len(codes) + 1, np.float32)

    def piece(lo: float, hi: float, a: np.ndarray, b: np.ndarray, ease: str) -> None:
        if hi <= lo:
            return
        m = (t >= lo) & (t <= hi)
        if m.any():
            u = (t[m] - lo) / (hi - lo)
            vals[m] = _interp(ease)(a, b, u, channels=chans, duration=hi - lo)

    for i, (e, r) in enumerate(zip(chain, res, strict=True)):
        ease = e.ease or ch.ease
        a, b = e.start + r.onset, e.end - r.offset
        v = vec(r)
        prev_bridged = i > 0 and e.start - chain[i - 1].end <= ch.bridge
        if not prev_bridged:
            piece(e.start, a, zero, v, ease)
        m = (t >= a) & (t <= b)
        vals[m] = v
        if i + 1 < len(chain) and chain[i + 1].start - e.end <= ch.bridge:
            nxt, rn = chain[i + 1], res[i + 1]
            piece(b, nxt.start + rn.onset, v, vec(rn), nxt.ease or ch.ease)
        else:
            piece(b, e.end, v, zero, ease)
    out = {c: vals[:, j].copy() for c, j in idx.items()}
    weight = vals[:, -1].copy()
    for e in trans:
        w = _transient(e, t, out, library, ch.ease)
        weight = np.maximum(weight, w)
    return out, np.clip(weight, 0.0, 1.0)


def _transient_codes(e: Event) -> tuple[str, ...]:
    if e.kind == "nod":
        return ("AU54",)
    if e.kind == "shake":
        return ("AU51", "AU52")
    return DIRECTIONS[e.kind][e.name]


def _transient(e: Event, t: np.ndarray, out: dict[str, np.ndarray],
               library: ExpressionSource | None, ch_ease: str) -> np.ndarray:
    """Add a transient's curves into ``out``; return its activity (T,)."""
    m = (t >= e.start) & (t <= e.end)
    u = np.clip((t - e.start) / e.duration, 0.0, 1.0)
    k = e.intensity * GESTURE_AMPLITUDE[e.kind] if e.kind in GESTURE_AMPLITUDE else e.intensity
    if e.kind == "nod":  # down and back up, ``count`` times
        out["AU54"] += np.where(m, k * np.sin(np.pi * e.count * u) ** 2, 0.0).astype(np.float32)
    elif e.kind == "shake":  # left-right oscillation in a smooth window
        s = np.sin(2 * np.pi * e.count * u) * np.sin(np.pi * u) * k
        out["AU51"] += np.where(m, np.maximum(s, 0.0), 0.0).astype(np.float32)
        out["AU52"] += np.where(m, np.maximum(-s, 0.0), 0.0).astype(np.float32)
    else:  # blink: onset, apex, offset envelope
        r = resolve_event(e, library)
        env = np.zeros(len(t), np.float32)
        ease = get_interpolator(e.ease or ch_ease)
        a, b = e.start + r.onset, e.end - r.offset
        for lo, hi, x0, x1 in ((e.start, a, 0.0, 1.0), (b, e.end, 1.0, 0.0)):
            mm = (t >= lo) & (t <= hi)
            if hi > lo and mm.any():
                env[mm] = ease(np.array([x0]), np.array([x1]), (t[mm] - lo) / (hi - lo),
                               channels=("env",), duration=hi - lo)[:, 0]
        env[(t >= a) & (t <= b)] = 1.0
        for c, v in r.aus.items():
            out[c] += env * np.float32(v)
    return m.astype(np.float32)


def sample_times(timeline: Timeline, times: np.ndarray, *,
                 library: ExpressionSource | None = None) -> tuple[np.ndarray, tuple[str, ...]]:
    """AU values at arbitrary ``times`` (s): returns (values (T, K) in [0, 1], channels)."""
    t = np.asarray(times, np.float64).reshape(-1)
    lib = library
    if lib is None and any(e.kind == "expression" for _, e in timeline.events):
        lib = default_library()
    total: dict[str, np.ndarray] = {}
    overrides: list[tuple[dict[str, np.ndarray], np.ndarray]] = []
    for ch in timeline.channels:
        curves, weight = _channel(ch, t, lib)
        if ch.override:
            overrides.append((curves, weight))
            continue
        for c, v in curves.items():
            total[c] = total.get(c, np.zeros(len(t), np.float32)) + v
    for curves, w in overrides:
        for c, v in curves.items():
            base = total.get(c, np.zeros(len(t), np.float32))
            total[c] = (1 - w) * np.clip(base, 0, 1) + w * v
    codes = tuple(sorted(total, key=au_order))
    vals = np.zeros((len(t), len(codes)), np.float32)
    for j, c in enumerate(codes):
        vals[:, j] = np.clip(total[c], 0.0, 1.0)
    return vals, codes


def sample(
    timeline: Timeline,
    *,
    fps: float,
    blend: bool = False,
    disabled: Iterable[str] = (),
    library: ExpressionSource | None = None,
    duration: float | None = None,
    channels: Iterable[str] | None = None,
) -> AUTrack:
    """Sample ``timeline`` at ``fps`` into an :class:`AUTrack`.

    Parameters
    ----------
    fps : frames per second (> 0); frame i is at i / fps seconds
    blend : pass the frames through the AU Blender (FACS co-occurrence rules)
    disabled : Blender rules to switch off (with ``blend``)
    library : resolves expression names (default: the knowledge base's library)
    duration : seconds to cover (default ``timeline.end``); the last frame is at or after it
    channels : AU codes the track must have (missing ones are 0)

    Returns
    -------
    AUTrack with ``ceil(duration·fps) + 1`` frames; ``meta["source"] = "timeline"``.
    """
    fps = valid_fps(fps)
    end = timeline.end if duration is None else float(duration)
    if not math.isfinite(end) or end < 0:
        raise ParameterError(f"duration={duration!r} must be ≥ 0 seconds")
    n = check_timeline(end, fps, "the timeline")  # before allocating the frames
    t = np.arange(n) / fps
    vals, codes = sample_times(timeline, t, library=library)
    track = AUTrack(vals if codes else np.zeros((n, 0), np.float32), codes, fps,
                    {"source": "timeline"})
    if blend and codes:
        from mimika.facs.blender import blend_track

        track = blend_track(track, disabled=disabled)
    if channels is not None:
        track = track.with_channels(list(channels))
    log.debug("sampled %d frames × %d AUs at %g fps", n, len(track.channels), fps)
    return track


def values_at(timeline: Timeline, time: float, *,
              library: ExpressionSource | None = None) -> Mapping[str, float]:
    """``{code: value}`` at one time (s) — handy for previews and tests."""
    vals, codes = sample_times(timeline, np.array([time]), library=library)
    return {c: float(vals[0, j]) for j, c in enumerate(codes)}


def order_channels(codes: Iterable[str]) -> list[str]:
    """Canonical codes sorted as the catalogue lists them."""
    return sorted({parse_au(c) for c in codes}, key=au_order)

