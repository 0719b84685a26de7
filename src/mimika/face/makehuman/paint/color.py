"""Colour helpers: paint is mixed in linear RGB and stored as sRGB bytes."""

from __future__ import annotations

import numpy as np


def hex_linear(hex_color: str) -> np.ndarray:
    """``"#rrggbb"`` (sRGB) → linear RGB (3,) float32."""
    h = hex_color.lstrip("#")
    c = np.array([int(h[i:i + 2], 16) for i in (0, 2, 4)], np.float32) / 255.0
    return to_linear(c)


def to_linear(c: np.ndarray) -> np.ndarray:
    c = np.asarray(c, np.float32)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)


def to_srgb8(c: np.ndarray) -> np.ndarray:
    """Linear RGB (..., 3) → sRGB uint8."""
    c = np.clip(np.asarray(c, np.float32), 0.0, 1.0)
    s = np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)
    return np.round(s * 255.0).astype(np.uint8)


def luminance(c: np.ndarray) -> np.ndarray:
    """Relative luminance of linear RGB (..., 3)."""
    return np.asarray(c, np.float32) @ np.array([0.2126, 0.7152, 0.0722], np.float32)


def pale(hair: np.ndarray) -> float:
    """How light a hair colour (linear RGB) is: 0 for black and browns, 1 from dark blond
    and grey up. Light hairs are translucent and fine ones vanish against skin."""
    x = np.clip((float(luminance(hair)) - 0.04) / 0.31, 0.0, 1.0)
    return float(x * x * (3.0 - 2.0 * x))


def tint(c: np.ndarray, w: np.ndarray, factor) -> np.ndarray:
    """Multiply linear colours (T, 3) by ``factor`` (3,) to the power ``w`` (T,): a tint of
    strength ``w`` (0 none, 1 full, fractional and negative values allowed)."""
    f = np.log(np.asarray(factor, np.float32))
    return c * np.exp(np.asarray(w, np.float32)[:, None] * f[None, :])


def mix(a: np.ndarray, b, w: np.ndarray) -> np.ndarray:
    """Per-row blend of colours ``a`` (T, 3) toward ``b`` ((3,) or (T, 3)) by ``w`` (T,)."""
    w = np.clip(np.asarray(w, np.float32), 0.0, 1.0)[:, None]
    return a * (1.0 - w) + np.asarray(b, np.float32) * w


def rgba8(rgb_linear: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Linear RGB (..., 3) and alpha (...) in [0, 1] → sRGB RGBA uint8 (..., 4)."""
    a = np.round(np.clip(alpha, 0.0, 1.0) * 255.0).astype(np.uint8)
    return np.concatenate([to_srgb8(rgb_linear), a[..., None]], axis=-1)
