"""Interpolation baselines for transitions: linear, cosine and cubic Hermite.

Each takes the seed window (its last frame is the start) and the target and returns the L
generated frames (the last equals the target), like the learned models.
"""

from __future__ import annotations

import numpy as np

from mimika.errors import ParameterError

__all__ = ["BASELINES", "baseline", "cosine", "hermite", "linear"]


def _u(length: int) -> np.ndarray:
    """Progress of the generated frames 1…L: u = i / L, shape (L, 1)."""
    if length < 1:
        raise ParameterError(f"length={length!r} must be ≥ 1")
    return (np.arange(1, length + 1) / length)[:, None]


def linear(window: np.ndarray, target: np.ndarray, length: int) -> np.ndarray:
    """``a + (b − a)·u`` — window (S, K), target (K,) → (L, K)."""
    a = window[-1]
    return (a + (target - a) * _u(length)).astype(np.float32)


def cosine(window: np.ndarray, target: np.ndarray, length: int) -> np.ndarray:
    """``a + (b − a)·(1 − cos πu)/2`` (seed 002's default easing)."""
    a = window[-1]
    return (a + (target - a) * (0.5 - 0.5 * np.cos(np.pi * _u(length)))).astype(np.float32)


def hermite(window: np.ndarray, target: np.ndarray, length: int) -> np.ndarray:
    """Cubic Hermite from the start with the window's last velocity (per frame) to the target
    at rest: p(u) = h00·a + h10·L·v + h01·b (end tangent 0)."""
    a = window[-1]
    v = window[-1] - window[-2] if len(window) > 1 else np.zeros_like(a)
    u = _u(length)
    h00 = 2 * u**3 - 3 * u**2 + 1
    h10 = u**3 - 2 * u**2 + u
    h01 = -2 * u**3 + 3 * u**2
    return (h00 * a + h10 * length * v + h01 * target).astype(np.float32)


BASELINES = {"linear": linear, "cosine": cosine, "hermite": hermite}


def baseline(name: str, window: np.ndarray, target: np.ndarray, length: int) -> np.ndarray:
    """One of :data:`BASELINES` by name."""
    if name not in BASELINES:
        raise ParameterError(f"baseline {name!r} must be one of {', '.join(BASELINES)}")
    return BASELINES[name](np.asarray(window, np.float64), np.asarray(target, np.float64),
                           length)
