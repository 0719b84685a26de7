"""Timelines: channels of timed expressions, AU sets, gaze, head gestures and blinks.

``Timeline`` → :func:`sample` → :class:`~mimika.tracks.AUTrack`. Events chain within a channel
without returning to neutral (seed 002 §5.4); channels add and are clipped to [0, 1];
:func:`synchronise` applies the knowledge base's timing rules; easing curves and learned
transition models register in :mod:`mimika.timeline.easing`.
"""

from mimika.timeline.easing import (
    Interpolator,
    easing_names,
    get_interpolator,
    register_easing,
    register_interpolator,
)
from mimika.timeline.model import (
    DEFAULT_CHANNEL,
    KINDS,
    Channel,
    Event,
    Speech,
    Timeline,
    timeline_from_events,
)
from mimika.timeline.player import resolve_event, sample, sample_times, values_at
from mimika.timeline.sync import SyncFinding, SyncResult, synchronise

__all__ = [
    "DEFAULT_CHANNEL",
    "KINDS",
    "Channel",
    "Event",
    "Interpolator",
    "Speech",
    "SyncFinding",
    "SyncResult",
    "Timeline",
    "easing_names",
    "get_interpolator",
    "register_easing",
    "register_interpolator",
    "resolve_event",
    "sample",
    "sample_times",
    "synchronise",
    "timeline_from_events",
    "values_at",
]
