"""Mood in the behaviour layers: how often and how strongly the newsreader's layers act.

A mood of the knowledge base (seed 002 §6.3.2: ``interval_s``, ``duration_scale``, ``variety``)
becomes parameter changes listed in ``behaviour.json → mood``: a *rate* (the neutral interval
over the mood's: 0.63 for the rare moods, 1.3 for happy/excited) multiplies probabilities and
divides intervals and minimum gaps; a *strength* by variety (limited 0.7, normal 1, large 1.3)
multiplies amplitudes; ``duration_scale`` multiplies gesture durations. The type of behaviour
never changes — only frequency, size and length, as the seed has it.
"""

from __future__ import annotations

from typing import Any

from mimika.behaviour import behaviour_params


def mood_factors(mood: str | None) -> tuple[float, float, float]:
    """``(rate, strength, duration_scale)`` of a mood (None: neutral → 1, 1, 1)."""
    from mimika.knowledge import get_mood

    m = get_mood(mood)
    spec = behaviour_params()["mood"]
    return (float(spec["neutral_interval_s"]) / m.interval_s,
            float(spec["strength"].get(m.variety, 1.0)), float(m.duration_scale))


def mood_params(mood: str | None, params: dict[str, Any] | None = None) -> dict[str, Any]:
    """Behaviour parameters (a copy of ``params`` or the defaults) changed by ``mood``."""
    import copy

    p = copy.deepcopy(params if params is not None else behaviour_params())
    rate, strength, dur = mood_factors(mood)
    spec = p["mood"]

    def scale(keys: list[str], f, cap: float | None = None) -> None:
        for key in keys:
            sec, name = key.split(".")
            v = p[sec][name] * f
            p[sec][name] = min(v, cap) if cap is not None else v

    scale(spec["probabilities"], rate, 0.95)
    scale(spec["intervals"], 1.0 / rate)
    scale(spec["amplitudes"], strength)
    scale(spec["durations"], dur)
    return p
