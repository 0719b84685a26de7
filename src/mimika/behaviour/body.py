"""Whole-body idle of a seated speaker (seed 004's "whole-body idle"): breathing that takes a
deeper breath before each sentence, occasional shoulder shifts, and slow posture changes —
leaning, swaying (weight shifts) and turning a little. Body channels (``body.*``, see
``facs/data/body.csv``); only heads with a skinned body move them.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mimika.behaviour._shapes import bump, plateau, smooth_noise
from mimika.behaviour.cues import SpeechCues
from mimika.tracks import AUTrack

CHANNELS = ("body.breath", "body.shrug_l", "body.shrug_r", "body.lean_fwd", "body.lean_back",
            "body.sway_l", "body.sway_r", "body.turn_l", "body.turn_r")


def _signed(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A signed curve as a (positive, negative) pair of channels in [0, 1]."""
    return np.clip(x, 0, 1), np.clip(-x, 0, 1)


def body_layer(cues: SpeechCues, *, fps: float, rng: np.random.Generator,
               params: dict[str, Any]) -> AUTrack:
    """Body channels over the cues' duration, shape (n_frames, 9)."""
    p = params["body"]
    n = cues.n_frames(fps=fps)
    t = cues.times(fps=fps)
    # breathing: a slow cycle, plus an inhalation just before every sentence
    period = p["breath_period_s"] * rng.uniform(0.9, 1.1)
    cycle = 0.5 + 0.5 * np.sin(2 * np.pi * t / period + rng.uniform(0, 2 * np.pi))
    breath = p["breath_rest"] * cycle
    for start, _end, _text in cues.sentences:
        breath = np.maximum(breath, p["breath_intake"] * bump(t, start - 0.25, 1.1))
    # shoulder shifts: a small raise of one or both shoulders every few seconds
    shrug_l, shrug_r = np.zeros(n), np.zeros(n)
    s = rng.uniform(*p["shrug_interval_s"])
    while s < cues.duration:
        hold = rng.uniform(0.4, 1.4)
        amp = rng.uniform(*p["shrug_amount"])
        side = rng.random()
        bump_ = amp * plateau(t, s, s + hold, 0.35)
        if side < 0.4:
            shrug_l = np.maximum(shrug_l, bump_)
        elif side < 0.8:
            shrug_r = np.maximum(shrug_r, bump_)
        else:
            shrug_l, shrug_r = np.maximum(shrug_l, bump_), np.maximum(shrug_r, bump_)
        s += hold + rng.uniform(*p["shrug_interval_s"])
    # posture: slow band-limited drift, a little more while speaking
    act = 0.6 + 0.4 * cues.activity(fps=fps)
    lean = p["lean"] * act * smooth_noise(n, fps=fps, period_s=p["posture_period_s"], rng=rng)
    sway = p["sway"] * smooth_noise(n, fps=fps, period_s=p["posture_period_s"], rng=rng)
    turn = p["turn"] * act * smooth_noise(n, fps=fps, period_s=p["posture_period_s"], rng=rng)
    cols = [breath, shrug_l, shrug_r, *_signed(lean), *_signed(sway), *_signed(turn)]
    v = np.clip(np.stack(cols, 1), 0, 1).astype(np.float32)
    return AUTrack(v, CHANNELS, fps, {"layer": "body"})
