"""The knowledge base's text defaults (question → surprise, emotional words …) as a layer,
at the intensities of a context (``news``: subtle), timed by the real speech timing."""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from mimika.behaviour.cues import SpeechCues
from mimika.tracks import AUTrack

log = logging.getLogger(__name__)


def knowledge_events(cues: SpeechCues, *, params: dict[str, Any]) -> list[Any]:
    """Suggested expression events (``mimika.timeline.Event``) for every sentence of ``cues``.

    Each sentence is checked with :func:`mimika.knowledge.check` (``context`` from the params),
    its text timing stretched to the sentence's spoken span.
    """
    from mimika.knowledge import check
    from mimika.knowledge.textsync import sync_text
    from mimika.timeline.model import Event

    p = params["knowledge"]
    lang = cues.lang.split("-")[0].lower()
    if lang not in p["langs"]:
        log.info("no knowledge-base text rules for language %r; layer left empty", cues.lang)
        return []
    out: list[Event] = []
    for s0, s1, text in cues.sentences:
        words = [w for w in cues.words if s0 - 1e-6 <= w[0] < s1]
        if not words or not text.strip():
            continue
        w0, w1 = words[0][0], words[-1][1]
        units = sum(c.units for c in sync_text(text, start=0.0)[0].components) if text else 1
        rate = max((w1 - w0) / max(units, 1), 1e-3)
        rep = check(text=text, lang=lang, context=p["context"], start=w0, rate=rate)
        for s in rep.suggestions:
            e = s.event
            start = max(0.0, min(e.start, cues.duration - 0.05))
            dur = max(min(e.duration, cues.duration - start), 0.05)
            out.append(Event("expression", start, dur, name=e.name, intensity=e.intensity))
    return out


def knowledge_layer(cues: SpeechCues, *, fps: float, rng: np.random.Generator,
                    params: dict[str, Any]) -> AUTrack:
    """The suggested expressions sampled at ``fps`` over ``cues.duration`` (any AUs)."""
    from mimika.timeline.model import Channel, Timeline
    from mimika.timeline.player import sample

    events = knowledge_events(cues, params=params)
    n = cues.n_frames(fps=fps)
    if not events:
        return AUTrack(np.zeros((n, 0), np.float32), (), fps, {"layer": "knowledge"})
    tl = Timeline(channels=(Channel("knowledge", tuple(sorted(events, key=lambda e: e.start))),))
    tr = sample(tl, fps=fps, duration=cues.duration)
    v = tr.values[:n]
    if len(v) < n:
        v = np.vstack([v, np.repeat(v[-1:], n - len(v), 0)])
    return AUTrack(v, tr.channels, fps, {"layer": "knowledge",
                                         "events": [(e.name, e.start, e.duration, e.intensity)
                                                    for e in events]})
