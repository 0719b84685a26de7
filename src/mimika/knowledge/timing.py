"""Expression timing limits (seed 002 Table 6.15): possible and probable durations.

A duration outside the *possible* range is an error, outside the *probable* range a warning.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mimika.knowledge._data import section
from mimika.knowledge.expressions import TEMPLATE_PREFIX


@dataclass(frozen=True)
class TimingLimit:
    """Durations in seconds; ``math.inf`` where the seed gives ∞."""

    name: str
    possible: tuple[float, float]
    probable: tuple[float, float]

    def clamp(self, duration: float, *, probable: bool = False) -> float:
        lo, hi = self.probable if probable else self.possible
        return min(max(duration, lo), hi)


def _pair(v: list) -> tuple[float, float]:
    return float(v[0]), (math.inf if v[1] is None else float(v[1]))


def timing_limits() -> dict[str, TimingLimit]:
    """Table 6.15 by expression kind (``astonishment`` … ``happiness``)."""
    return {k: TimingLimit(k, _pair(v["possible"]), _pair(v["probable"]))
            for k, v in section("timing").items()}


def timing_limit(name: str) -> TimingLimit | None:
    """The limit for ``name`` (``template/`` prefix ignored), or None if the seed gives none."""
    return timing_limits().get(name.removeprefix(TEMPLATE_PREFIX))


def fmt_range(r: tuple[float, float]) -> str:
    return f"{r[0]:g}–{'∞' if math.isinf(r[1]) else f'{r[1]:g}'} s"
