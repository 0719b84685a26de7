"""Head motion while speaking (AU51–56): small nods on stressed syllables, a settling nod at
phrase ends and a slowly changing head pose per sentence — reduced, as the seed 004 survey asked.

Nods: raised-cosine dips of ``nod_deg`` (head down, AU54) lasting ``nod_duration_s`` and peaking
``nod_lead_s`` after the stressed vowel's onset, on a ``nod_probability`` share of stresses at
least ``nod_min_gap_s`` apart. Phrase ends (sentence ends, pauses): a ``phrase_end_deg`` dip.
Pose: each sentence eases (``pose_transition_s``) to a new small yaw/roll/pitch offset drawn
within ``±pose_*_deg``. Everything except the pose is scaled by the speech activity (motion
calms in pauses), then multiplied by ``amplitude`` and low-passed (``smooth_s``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mimika.behaviour._shapes import bump, gaussian_smooth, signed_to_pair, smoothstep
from mimika.behaviour.cues import SpeechCues
from mimika.tracks import AUTrack

CHANNELS = ("AU51", "AU52", "AU53", "AU54", "AU55", "AU56")


def head_angles(cues: SpeechCues, *, fps: float, rng: np.random.Generator,
                params: dict[str, Any]) -> np.ndarray:
    """Head (yaw left +, pitch down +, roll left +) in degrees, shape (T, 3)."""
    p = params["head"]
    t = cues.times(fps=fps)
    act = cues.activity(fps=fps, ramp=p["pause_ramp_s"])
    pitch = np.zeros_like(t)
    last = -1e9
    nods = []
    for ts in cues.stresses:
        if ts - last < p["nod_min_gap_s"] or rng.random() >= p["nod_probability"]:
            continue
        amp = p["nod_deg"] * rng.uniform(0.55, 1.0)
        pitch += amp * bump(t, ts + p["nod_lead_s"], p["nod_duration_s"])
        nods.append(ts)
        last = ts
    for tb in cues.boundaries:
        amp = p["phrase_end_deg"] * rng.uniform(0.6, 1.0)
        pitch += amp * bump(t, tb - 0.1, p["phrase_end_duration_s"])
    pitch *= act
    # per-sentence pose: the reader settles into a slightly different attitude per sentence
    pose = np.zeros((len(t), 3))
    cur = np.zeros(3)
    lim = np.array([p["pose_yaw_deg"], p["pose_pitch_deg"], p["pose_roll_deg"]])
    for s0, _, _ in cues.sentences:
        new = rng.uniform(-1.0, 1.0, 3) * lim
        new = 0.5 * new + 0.5 * new * rng.random()  # mostly near the middle
        w = smoothstep((t - (s0 - 0.1)) / p["pose_transition_s"])
        pose += (new - cur)[None, :] * w[:, None]
        cur = new
    out = np.stack([pose[:, 0], pitch + pose[:, 1], pose[:, 2]], 1) * p["amplitude"]
    return gaussian_smooth(out, sigma_s=p["smooth_s"], fps=fps)


def angles_to_head_aus(angles: np.ndarray, scales: dict[str, float]) -> np.ndarray:
    """(T, 3) degrees (yaw left +, pitch down +, roll left +) → AU51–56 values (T, 6)."""
    left, right = signed_to_pair(angles[:, 0], scales["head_yaw_deg"])
    down, up = signed_to_pair(angles[:, 1], scales["head_pitch_deg"])
    tilt_l, tilt_r = signed_to_pair(angles[:, 2], scales["head_roll_deg"])
    return np.stack([left, right, up, down, tilt_l, tilt_r], 1)


def head_aus_to_angles(values: np.ndarray, scales: dict[str, float]) -> np.ndarray:
    """Inverse of :func:`angles_to_head_aus`: AU51–56 (T, 6) → degrees (T, 3)."""
    v = np.asarray(values, np.float64)
    return np.stack([(v[:, 0] - v[:, 1]) * scales["head_yaw_deg"],
                     (v[:, 3] - v[:, 2]) * scales["head_pitch_deg"],
                     (v[:, 4] - v[:, 5]) * scales["head_roll_deg"]], 1)


def head_layer(cues: SpeechCues, *, fps: float, rng: np.random.Generator,
               params: dict[str, Any]) -> AUTrack:
    """AU51–56 track, shape (n_frames, 6)."""
    ang = head_angles(cues, fps=fps, rng=rng, params=params)
    v = angles_to_head_aus(ang, params["scales"]).astype(np.float32)
    return AUTrack(v, CHANNELS, fps, {"layer": "head"})
