"""Deterministic noise for painting: smooth 3D value noise (evaluated at bind-pose positions, so
patterns run on across UV seams), fractal sums of it, and per-item random numbers.

Every generator takes an explicit seed; the same seed gives the same bytes on every machine
(numpy's PCG64 and float64 arithmetic only).
"""

from __future__ import annotations

import functools
import hashlib

import numpy as np
from scipy import ndimage

#: lattice cells per axis of the periodic noise volume
_CELLS = 64


def seed_of(*parts: object) -> int:
    """A stable 63-bit seed from any printable parts (not Python's salted ``hash``)."""
    h = hashlib.sha256("|".join(map(str, parts)).encode()).digest()
    return int.from_bytes(h[:8], "little") >> 1


@functools.lru_cache(maxsize=16)
def _volume(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    v = rng.random((_CELLS, _CELLS, _CELLS), dtype=np.float64).astype(np.float32)
    # cubic B-spline prefilter so order-3 sampling interpolates smoothly (periodic)
    return ndimage.spline_filter(v, order=3, mode="grid-wrap").astype(np.float32)


def value3(points: np.ndarray, scale: float, seed: int, order: int = 3) -> np.ndarray:
    """Smooth noise in about [0, 1] (mean 0.5) at ``points`` (..., 3); ``scale`` is the
    feature size in the points' units."""
    p = np.asarray(points, np.float32).reshape(-1, 3) / np.float32(scale)
    out = ndimage.map_coordinates(_volume(seed), p.T, order=order, mode="grid-wrap",
                                  prefilter=False)
    return out.reshape(np.shape(points)[:-1]).astype(np.float32)


def fbm3(points: np.ndarray, scale: float, seed: int, octaves: int = 4,
         gain: float = 0.5) -> np.ndarray:
    """Fractal sum of :func:`value3` (feature sizes scale, scale/2, …), zero mean, roughly
    unit standard deviation."""
    total = np.zeros(np.shape(points)[:-1], np.float32)
    amp, norm = 1.0, 0.0
    for k in range(octaves):
        # rotate the lattice per octave (irrational offsets) so octaves do not align
        total += amp * (value3(points + np.float32(17.13 * k), scale / 2 ** k, seed + k) - 0.5)
        norm += amp * amp
        amp *= gain
    return total / np.float32(0.29 * np.sqrt(norm))


def white(shape: tuple[int, ...], seed: int) -> np.ndarray:
    """Uniform [0, 1) noise of ``shape`` (float32)."""
    return np.random.default_rng(seed).random(shape, dtype=np.float64).astype(np.float32)


def smoothstep(e0: float, e1: float, x: np.ndarray) -> np.ndarray:
    """Hermite step from 0 at ``e0`` to 1 at ``e1``."""
    t = np.clip((np.asarray(x, np.float32) - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)
