"""Behaviour sentence by sentence, for speech that arrives one sentence at a time (the studio,
``mimika serve``): the newsreader's layers (blink, gaze, head, brows, smile) of each sentence,
joined to where the previous one ended.

One adapter, :func:`behaviour_track`, over the library's own function for an utterance's
behaviour (:func:`mimika.behaviour.speaking.speaking_behaviour`, which the newsreader runs too).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from mimika.tracks import AUTrack

#: the layers sentence-wise speech offers, in the order of the studio's switches
SPEECH_LAYERS = ("blink", "gaze", "head", "brows", "smile")
#: seconds over which a sentence's behaviour starts from where the previous one ended
JOIN_S = 0.3


def behaviour_track(utterance: Any, *, fps: float, layers: Iterable[str], seed: int = 0,
                    start: dict[str, float] | None = None, mood: str | None = None
                    ) -> AUTrack | None:
    """The merged behaviour layers of ``utterance`` (None when no layer is on).

    ``seed`` varies the random streams (e.g. by sentence); ``start`` ({AU: value}, the last
    frame of the previous sentence) is faded into the first :data:`JOIN_S` seconds so
    sentences join without a jump; ``mood`` changes how often and how strongly they act.
    """
    from mimika.behaviour import behaviour_params
    from mimika.behaviour.speaking import speaking_behaviour

    names = [x for x in SPEECH_LAYERS if x in set(layers)]
    if not names:
        return None
    track, _ = speaking_behaviour(utterance, fps=fps, layers=names, mood=mood,
                                  seed=behaviour_params()["seed"] + seed)
    if start:
        track = _join(track, start, fps)
    return track


def _join(track: AUTrack, start: dict[str, float], fps: float) -> AUTrack:
    chans = list(track.channels) + [c for c in start if c not in track.channels]
    v = np.zeros((track.n_frames, len(chans)), np.float32)
    v[:, : len(track.channels)] = track.values
    n = min(track.n_frames, max(1, round(JOIN_S * fps)))
    w = 0.5 - 0.5 * np.cos(np.linspace(0.0, np.pi, n))  # 0 → 1
    for j, c in enumerate(chans):
        s = start.get(c, 0.0)
        v[:n, j] = (1 - w) * s + w * v[:n, j]
    return AUTrack(v, tuple(chans), fps, dict(track.meta))
