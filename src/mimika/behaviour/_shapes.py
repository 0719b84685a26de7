"""Small curve helpers shared by the behaviour layers (all vectorised over frame times)."""

from __future__ import annotations

import numpy as np


def smoothstep(u: np.ndarray) -> np.ndarray:
    """3u² − 2u³ on [0, 1], clamped outside."""
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


def bump(t: np.ndarray, centre: float, width: float) -> np.ndarray:
    """Raised-cosine bump: 1 at ``centre``, 0 beyond ``±width / 2`` (s)."""
    u = np.clip((t - centre) / max(width, 1e-6) * 2.0, -1.0, 1.0)
    return 0.5 + 0.5 * np.cos(np.pi * u)


def plateau(t: np.ndarray, start: float, end: float, ramp: float) -> np.ndarray:
    """0 → 1 over ``[start, start + ramp]``, 1 until ``end``, → 0 over ``[end, end + ramp]``."""
    r = max(ramp, 1e-6)
    return smoothstep((t - start) / r) * (1.0 - smoothstep((t - end) / r))


def gaussian_smooth(x: np.ndarray, *, sigma_s: float, fps: float) -> np.ndarray:
    """Gaussian low-pass of ``x`` (T,) or (T, K) along time; ``sigma_s`` in seconds."""
    sigma = sigma_s * fps
    if sigma < 0.3:
        return x
    from scipy.ndimage import gaussian_filter1d

    return gaussian_filter1d(x, sigma, axis=0, mode="nearest")


def smooth_noise(n: int, *, fps: float, period_s: float, rng: np.random.Generator) -> np.ndarray:
    """Band-limited noise of unit standard deviation, (n,): a sum of sines with random phases
    around ``period_s`` (never frozen, no popping)."""
    t = np.arange(n) / fps
    out = np.zeros(n)
    for k in range(4):
        period = period_s * rng.uniform(0.6, 1.6) * (1.0 + 0.45 * k)
        out += rng.uniform(0.5, 1.0) * np.sin(2 * np.pi * t / period + rng.uniform(0, 2 * np.pi))
    sd = float(np.sqrt(np.mean(out**2))) or 1.0
    return out / sd


def signed_to_pair(x: np.ndarray, scale_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Signed degrees (T,) → (positive AU, negative AU) intensities in [0, 1]."""
    v = np.asarray(x, np.float64) / scale_deg
    return np.clip(v, 0.0, 1.0), np.clip(-v, 0.0, 1.0)
