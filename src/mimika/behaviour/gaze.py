"""Gaze at the camera (eye AUs 61–64 ≈ 0) with small saccades and glances down at the notes.

Fixations last ``fixation_s`` (uniform); each saccade jumps to a new target: back to the
camera with ``centre_probability``, else an offset of ``saccade_min_deg``…``saccade_max_deg`` in
a random direction, in ``saccade_s`` (one or two frames). At paragraph starts (probability
``notes_probability``; at other sentence starts ``notes_sentence_probability``; never closer
than ``notes_min_gap_s``) the eyes drop ``notes_deg`` (AU64 ≈ 0.3) for ``notes_duration_s``,
looking back up just as the sentence begins. Angles become AUs through ``scales``.
Keeping the eyes on the camera while the head moves (vestibulo-ocular reflex) is done when
the layers are merged (see :func:`mimika.behaviour.merge_layers`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mimika.behaviour._shapes import plateau, signed_to_pair, smoothstep
from mimika.behaviour.cues import SpeechCues
from mimika.tracks import AUTrack

CHANNELS = ("AU61", "AU62", "AU63", "AU64")


def notes_glances(cues: SpeechCues, *, rng: np.random.Generator, params: dict[str, Any]
                  ) -> list[tuple[float, float]]:
    """(start, end) seconds of each glance down at the notes."""
    p = params
    paras = set(round(t, 3) for t in cues.paragraph_starts)
    out: list[tuple[float, float]] = []
    last = -1e9
    for s0, _, _ in cues.sentences:
        first_word = next((w[0] for w in cues.words if w[0] >= s0 - 1e-6), s0)
        is_para = round(s0, 3) in paras or any(abs(s0 - q) < 0.05 for q in paras)
        prob = p["notes_probability"] if is_para else p["notes_sentence_probability"]
        if first_word - last < p["notes_min_gap_s"] or rng.random() >= prob:
            continue
        end = first_word + 0.1 * rng.uniform(0.5, 1.5)
        start = max(0.0, end - p["notes_duration_s"] * rng.uniform(0.85, 1.2))
        if end - start < 0.2:
            continue
        out.append((start, end))
        last = first_word
    return out


def gaze_angles(cues: SpeechCues, *, fps: float, rng: np.random.Generator,
                params: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, list]:
    """Eye yaw (left +) and pitch (down +) in degrees, (T,) each, and the notes glances."""
    p = params["gaze"]
    t = cues.times(fps=fps)
    yaw = np.zeros_like(t)
    pitch = np.zeros_like(t)
    cur = np.zeros(2)
    tk = float(rng.uniform(*p["fixation_s"]))
    while tk < cues.duration:
        if rng.random() < p["centre_probability"] or np.hypot(*cur) > 0.6 * p["saccade_max_deg"]:
            new = np.zeros(2)
        else:
            ang = rng.uniform(0, 2 * np.pi)
            mag = rng.uniform(p["saccade_min_deg"], p["saccade_max_deg"])
            new = mag * np.array([np.cos(ang), 0.6 * np.sin(ang)])  # mostly horizontal
        s = smoothstep((t - tk) / p["saccade_s"])
        yaw += (new[0] - cur[0]) * s
        pitch += (new[1] - cur[1]) * s
        cur = new
        tk += float(rng.uniform(*p["fixation_s"]))
    glances = notes_glances(cues, rng=rng, params=p)
    for g0, g1 in glances:
        w = plateau(t, g0, g1 - 0.12, 0.12)
        pitch = pitch * (1 - w) + p["notes_deg"] * w
        yaw = yaw * (1 - w)
    return yaw, pitch, glances


def gaze_layer(cues: SpeechCues, *, fps: float, rng: np.random.Generator,
               params: dict[str, Any]) -> AUTrack:
    """AU61–64 track, shape (n_frames, 4); ``meta["glances"]`` lists notes glances (s)."""
    sc = params["scales"]
    yaw, pitch, glances = gaze_angles(cues, fps=fps, rng=rng, params=params)
    left, right = signed_to_pair(yaw, sc["eye_yaw_deg"])
    down, up = signed_to_pair(pitch, sc["eye_pitch_deg"])
    v = np.stack([left, right, up, down], 1).astype(np.float32)
    return AUTrack(v, CHANNELS, fps, {"layer": "gaze", "glances": glances})
