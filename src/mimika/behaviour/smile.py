"""Slight smiles (AU06 + AU12 ≈ 0.3) during greeting and farewell sentences.

Sentences that begin with a phrase of ``data/phrases.json`` (``Good evening``, ``Guten Abend``,
``Dobry wieczór``, ``Goodbye``, ``Auf Wiedersehen``, ``Do widzenia`` …) smile from just before
they start until ``hold_after_s`` after they end; a farewell near the end holds the smile to
the last frame.
"""

from __future__ import annotations

import functools
import json
import re
from importlib import resources
from typing import Any

import numpy as np

from mimika.behaviour._shapes import plateau
from mimika.behaviour.cues import SpeechCues
from mimika.tracks import AUTrack

CHANNELS = ("AU06", "AU12")


@functools.cache
def phrases() -> dict[str, dict[str, list[str]]]:
    """``{"greeting": {lang: [phrase, …]}, "farewell": {…}}`` from ``data/phrases.json``."""
    text = resources.files("mimika.behaviour").joinpath("data/phrases.json").read_text("utf-8")
    return {k: v for k, v in json.loads(text).items() if not k.startswith("_")}


def _norm(text: str) -> str:
    return " ".join(re.sub(r"[^\w\s']", " ", text.lower().replace("’", "'")).split())


def sentence_kind(text: str, lang: str = "en") -> str | None:
    """``"greeting"``, ``"farewell"`` or None for a sentence in ``lang`` (any language's
    phrases are tried when ``lang`` has none)."""
    s = _norm(text)
    base = lang.split("-")[0].lower()
    for kind in ("farewell", "greeting"):
        table = phrases()[kind]
        pool = table.get(base) or [x for v in table.values() for x in v]
        for ph in pool:
            ph = _norm(ph)
            if s == ph or s.startswith(ph + " "):
                return kind
    return None


def smile_layer(cues: SpeechCues, *, fps: float, rng: np.random.Generator,
                params: dict[str, Any]) -> AUTrack:
    """AU06 + AU12 track, shape (n_frames, 2); ``meta["smiles"]`` lists (kind, start, end)."""
    p = params["smile"]
    t = cues.times(fps=fps)
    v = np.zeros_like(t)
    smiles = []
    for s0, s1, text in cues.sentences:
        kind = sentence_kind(text, cues.lang)
        if kind is None:
            continue
        start = max(0.0, s0 - 0.5 * p["ramp_s"])
        end = s1 + p["hold_after_s"]
        if kind == "farewell" and cues.duration - s1 < 3.0:
            end = cues.duration + 1.0
        k = p["intensity"] * rng.uniform(0.9, 1.1)
        v = np.maximum(v, k * plateau(t, start, end, p["ramp_s"]))
        smiles.append((kind, start, min(end, cues.duration)))
    cols = [np.clip(v * p["aus"][c], 0, 1) for c in CHANNELS]
    return AUTrack(np.stack(cols, 1).astype(np.float32), CHANNELS, fps,
                   {"layer": "smile", "smiles": smiles})
