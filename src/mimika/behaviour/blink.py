"""Stochastic blinking (AU45), biased toward phrase and sentence boundaries.

Blink onsets are a renewal process — gamma intervals with mean ``speaking_interval_s`` while
talking and ``rest_interval_s`` in pauses, coefficient of variation ``spread`` — of which a
fraction ``boundary_bias`` is moved next to the nearest communicative event (sentence end or
phrase-final pause, within ``boundary_search_s``), landing within ``±boundary_window_s`` of it
(Ford 2013: 71 % of blinks within ±375 ms). Each blink closes fast (``close_fraction`` of its
duration, ease-in), holds shut, and opens more slowly (ease-out); durations are normal around
208 ms (Hömke 2018), clipped to ``duration_range_s``. The closed plateau is put on a frame time,
so every blink is complete (AU45 reaches ``peak``) at any frame rate.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from mimika.behaviour.cues import SpeechCues
from mimika.tracks import AUTrack

CHANNELS = ("AU45",)


@dataclass(frozen=True)
class Blink:
    """One blink: ``start`` (s), ``duration`` (s), closing/holding/opening seconds."""

    start: float
    duration: float
    close: float
    hold: float

    @property
    def opening(self) -> float:
        return self.duration - self.close - self.hold

    @property
    def apex(self) -> float:
        """Middle of the closed plateau (s)."""
        return self.start + self.close + 0.5 * self.hold


def _is_speaking(t: float, cues: SpeechCues) -> bool:
    if not cues.words or t < cues.words[0][0] or t > cues.words[-1][1]:
        return False
    return not any(p0 <= t <= p1 for p0, p1 in cues.pauses)


def blink_times(cues: SpeechCues, *, rng: np.random.Generator, params: dict[str, Any]
                ) -> list[float]:
    """Blink onset times (s), sorted, at least ``min_gap_s`` apart."""
    p = params
    cv = max(float(p["spread"]), 0.05)
    shape = 1.0 / (cv * cv)
    bounds = np.asarray(cues.boundaries)
    t = float(rng.uniform(0.3, 1.2))  # the first blink comes soon after the start
    raw: list[float] = []
    while t < cues.duration:
        raw.append(t)
        mean = p["speaking_interval_s"] if _is_speaking(t, cues) else p["rest_interval_s"]
        t += max(float(rng.gamma(shape, mean / shape)), p["min_gap_s"])
    out: list[float] = []
    for t in raw:
        if len(bounds) and rng.random() < p["boundary_bias"]:
            j = int(np.argmin(np.abs(bounds - t)))
            if abs(bounds[j] - t) <= p["boundary_search_s"]:
                w = p["boundary_window_s"]
                # mostly just after the boundary (in the pause), sometimes just before
                t = float(bounds[j] + rng.uniform(-0.35 * w, 0.9 * w))
        out.append(t)
    out = sorted(x for x in out if 0.0 <= x < cues.duration - 0.15)
    kept: list[float] = []
    for x in out:
        if not kept or x - kept[-1] >= p["min_gap_s"]:
            kept.append(x)
    return kept


def make_blinks(cues: SpeechCues, *, fps: float, rng: np.random.Generator,
                params: dict[str, Any]) -> list[Blink]:
    """The blinks of ``cues`` with durations and phases, plateaus on frame times."""
    p = params
    lo, hi = p["duration_range_s"]
    blinks = []
    for t in blink_times(cues, rng=rng, params=p):
        if rng.random() < p["long_probability"]:
            d = p["long_duration_s"] * rng.uniform(0.9, 1.1)
        else:
            d = rng.normal(p["duration_mean_s"], p["duration_sd_s"])
        d = float(np.clip(d, lo, hi))
        close = p["close_fraction"] * d
        hold = max(p["hold_fraction"] * d, 0.02)
        apex = t + close + 0.5 * hold
        apex = round(apex * fps) / fps  # a frame lands in the middle of the closed plateau
        blinks.append(Blink(apex - close - 0.5 * hold, d, close, hold))
    return [b for b in blinks if b.start >= 0.0]


def blink_curve(t: np.ndarray, blinks: list[Blink], *, peak: float = 1.0) -> np.ndarray:
    """AU45 over frame times ``t`` (T,) for ``blinks``: fast close, hold, slower open."""
    out = np.zeros_like(t, dtype=np.float64)
    for b in blinks:
        u = t - b.start
        c = np.clip(u / b.close, 0.0, 1.0)
        closing = c * c * (3 - 2 * c)  # smooth but quick
        o = np.clip((u - b.close - b.hold) / max(b.opening, 1e-6), 0.0, 1.0)
        opening = 1.0 - (1.0 - (1.0 - o) ** 2)  # ease-out: the lid lifts fast, then settles
        v = np.where(u < b.close, closing, np.where(u < b.close + b.hold, 1.0, opening))
        v[(u < 0) | (u > b.duration)] = 0.0
        out = np.maximum(out, v)
    return np.clip(out * peak, 0.0, 1.0)


def blink_layer(cues: SpeechCues, *, fps: float, rng: np.random.Generator,
                params: dict[str, Any]) -> AUTrack:
    """AU45 track, shape (n_frames, 1); ``meta["blinks"]`` lists (start, duration)."""
    p = params["blink"]
    blinks = make_blinks(cues, fps=fps, rng=rng, params=p)
    v = blink_curve(cues.times(fps=fps), blinks, peak=p["peak"])
    return AUTrack(v[:, None].astype(np.float32), CHANNELS, fps,
                   {"layer": "blink", "blinks": [(b.start, b.duration) for b in blinks]})
