"""Idle micro-motion that never freezes: breathing (a slow, tiny head-pitch sway) plus slow
band-limited sway in yaw and roll, during speech and pauses alike (AU51–56)."""

from __future__ import annotations

from typing import Any

import numpy as np

from mimika.behaviour._shapes import smooth_noise
from mimika.behaviour.cues import SpeechCues
from mimika.behaviour.head import CHANNELS, angles_to_head_aus
from mimika.tracks import AUTrack


def idle_angles(cues: SpeechCues, *, fps: float, rng: np.random.Generator,
                params: dict[str, Any]) -> np.ndarray:
    """Idle head angles (yaw left +, pitch down +, roll left +) in degrees, shape (T, 3)."""
    p = params["idle"]
    n = cues.n_frames(fps=fps)
    t = np.arange(n) / fps
    period = p["breath_period_s"] * rng.uniform(0.9, 1.1)
    phase = rng.uniform(0, 2 * np.pi)
    # breathing: inhale lifts the head a little (pitch up), a slightly asymmetric cycle
    br = np.sin(2 * np.pi * t / period + phase)
    br = br + 0.25 * np.sin(4 * np.pi * t / period + 2 * phase)
    pitch = -p["breath_pitch_deg"] * br / 1.1
    yaw = p["sway_yaw_deg"] * smooth_noise(n, fps=fps, period_s=p["sway_period_s"], rng=rng)
    roll = p["sway_roll_deg"] * smooth_noise(n, fps=fps, period_s=p["sway_period_s"], rng=rng)
    return np.stack([yaw, pitch, roll], 1)


def idle_layer(cues: SpeechCues, *, fps: float, rng: np.random.Generator,
               params: dict[str, Any]) -> AUTrack:
    """AU51–56 track, shape (n_frames, 6): breathing and sway."""
    ang = idle_angles(cues, fps=fps, rng=rng, params=params)
    v = angles_to_head_aus(ang, params["scales"]).astype(np.float32)
    return AUTrack(v, CHANNELS, fps, {"layer": "idle"})
