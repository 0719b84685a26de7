"""The newsreader's behaviour for any spoken utterance, in one call.

:func:`speaking_behaviour` is what the newsreader runs for an article and what the studio's
Speak can run for its text: blinks, gaze, head motion, brows, smiles, idle motion and the
knowledge base's defaults, each switchable, with a mood.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

from mimika.behaviour import LAYERS, behaviour_layers, cues_from_utterance, merge_layers
from mimika.tracks import AUTrack


def speaking_behaviour(utterance: Any, *, fps: float = 25.0,
                       layers: Iterable[str] | None = None, mood: str | None = None,
                       seed: int | None = None, params: dict[str, Any] | None = None,
                       paragraph_starts: Sequence[float] | None = None,
                       n_frames: int | None = None) -> tuple[AUTrack, dict[str, AUTrack]]:
    """Behaviour layers for ``utterance`` (TTS or aligned recording), merged.

    Parameters
    ----------
    layers : names from :data:`mimika.behaviour.LAYERS` (default all: head, idle, gaze,
        blink, brows, smile, knowledge); an empty list gives an empty track.
    mood : a knowledge-base mood (``happy``, ``depressed`` …) changing how often and how
        strongly the layers act (:func:`mimika.behaviour.mood.mood_params`).
    paragraph_starts : times (s) where paragraphs start (gaze to the notes, pauses).

    Returns ``(merged, {layer: track})``, ``ceil(duration · fps)`` frames unless ``n_frames``.
    """
    from mimika.behaviour.mood import mood_params

    names = list(LAYERS) if layers is None else list(layers)
    p = mood_params(mood, params)
    cues = cues_from_utterance(utterance, paragraph_starts=list(paragraph_starts or []))
    tracks = behaviour_layers(cues, fps=fps, seed=seed, params=p, layers=names)
    if n_frames is not None:
        tracks = {k: _fit(v, n_frames) for k, v in tracks.items()}
    n = n_frames if n_frames is not None else cues.n_frames(fps=fps)
    return merge_layers(tracks, params=p, n_frames=n, fps=fps), tracks


def _fit(track: AUTrack, n: int) -> AUTrack:
    import numpy as np

    v = track.values[:n]
    if len(v) < n:
        v = np.vstack([v, np.repeat(v[-1:], n - len(v), axis=0)]) if len(v) else \
            np.zeros((n, len(track.channels)), np.float32)
    return AUTrack(v, track.channels, track.fps, track.meta)
