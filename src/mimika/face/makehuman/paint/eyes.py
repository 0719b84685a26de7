"""Eyes: iris (radial fibres, collarette, crypts, dark limbal ring, the character's eye colour)
and sclera (warm, slightly darker toward the corners, faint vessels, the caruncle's pink in the
inner corner). The eyeball's UVs are
its front projection (:func:`mimika.face.eyeball.eyeball_object`), so both are discs about
(0.5, 0.5): the iris reaches ``IRIS_UV`` and the pupil ``PUPIL_UV``."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from mimika.face.makehuman.paint import color
from mimika.face.makehuman.paint.noise import smoothstep

SIZE = 512
#: iris and pupil radii in UV (the build's eyeball: iris 0.47 R, pupil 0.22 R; UV = x / 2R)
IRIS_UV = 0.235
PUPIL_UV = 0.11
#: the caruncle (the pink flesh in the inner corner) and the plica beside it: centre on the
#: nasal side (UV distance from the middle, height), radii (across, up); where the inner eye
#: corner lies on the presets' eyeballs
CARUNCLE = {"centre": (0.33, -0.05), "radii": (0.06, 0.075), "plica": 0.25,
            "colour": "#c07a74"}


def _polar(size: int) -> tuple[np.ndarray, np.ndarray]:
    y, x = np.mgrid[0:size, 0:size].astype(np.float32)
    u = (x + 0.5) / size - 0.5
    v = 0.5 - (y + 0.5) / size
    return np.hypot(u, v), np.arctan2(v, u)


def _angular(theta: np.ndarray, r: np.ndarray, n: int, rng, smooth: float = 1.0):
    """Radial streaks: periodic noise over the angle with ``n`` samples, drifting with r."""
    tab = ndimage.gaussian_filter1d(rng.random(n).astype(np.float32), smooth, mode="wrap")
    x = (theta / (2 * np.pi) + 0.5) * n + 3.0 * r / IRIS_UV
    i = np.floor(x).astype(np.int64)
    f = x - i
    return tab[i % n] * (1 - f) + tab[(i + 1) % n] * f


def paint_iris(eye_hex: str, seed: int) -> np.ndarray:
    """RGB(A) iris texture (alpha 255)."""
    rng = np.random.default_rng(seed)
    r, th = _polar(SIZE)
    base = color.hex_linear(eye_hex)
    lum = float(color.luminance(base))
    x = np.clip((r - PUPIL_UV) / (IRIS_UV - PUPIL_UV), 0, 1)  # 0 pupil edge … 1 limbus
    fib = 0.55 * _angular(th, r, 180, rng, 1.2) + 0.45 * _angular(th, r, 520, rng, 0.8)
    fib = (fib - fib.mean()) / max(float(fib.std()), 1e-6)
    c = base[None, None, :] * (1.0 + 0.28 * fib[..., None])
    # collarette: a lighter, warmer ring at about a third of the way out
    coll = np.exp(-((x - 0.33 - 0.04 * _angular(th, r, 24, rng, 1.0)) / 0.07) ** 2)
    warm = np.array([1.35, 1.05, 0.55], np.float32) if lum < 0.05 else \
        np.array([1.25, 1.1, 0.7], np.float32)
    c = c * (1 + (warm - 1) * (0.6 * coll + 0.35 * (1 - x) ** 3)[..., None])
    # crypts: a few dark pits, and the dark limbal ring
    pits = ndimage.gaussian_filter(rng.random((SIZE, SIZE)).astype(np.float32), 3.0)
    pits = smoothstep(0.56, 0.6, pits) * smoothstep(0.2, 0.45, x) * (1 - smoothstep(0.8, 0.95, x))
    c = c * (1 - 0.35 * pits[..., None])
    limb = smoothstep(0.78, 1.0, x)
    c = c * (1 - 0.65 * limb)[..., None]
    c = c * (1 - 0.3 * (1 - smoothstep(0.0, 0.08, x)))[..., None]  # pupil margin
    out = np.where((r > IRIS_UV + 0.01)[..., None], _sclera_rgb(r, th, rng), c)
    return color.rgba8(out, np.ones(r.shape, np.float32))


def _sclera_rgb(r: np.ndarray, th: np.ndarray, rng) -> np.ndarray:
    white = color.hex_linear("#ddd3c8")
    edge = smoothstep(IRIS_UV + 0.02, 0.5, r)
    c = white[None, None, :] * (1 - 0.3 * edge)[..., None]
    c = c * (1 + (np.array([1.0, 0.86, 0.82], np.float32) - 1) * edge[..., None] ** 1.5)
    # faint vessels from the corners inward
    vein = _angular(th, r, 90, rng, 0.5)
    vein = smoothstep(0.78, 0.9, vein) * smoothstep(IRIS_UV + 0.08, 0.45, r)
    vein *= np.abs(np.cos(th)) ** 2  # mostly toward the eye corners
    c = c * (1 + (np.array([0.95, 0.6, 0.6], np.float32) - 1) * (0.6 * vein)[..., None])
    # limbal shadow just outside the iris
    c = c * (1 - 0.12 * np.exp(-((r - IRIS_UV - 0.012) / 0.02) ** 2))[..., None]
    return c


def paint_sclera(seed: int, nasal: float = 0.0) -> np.ndarray:
    """RGB(A) sclera texture (alpha: gloss 255); ``nasal``: the side of the inner corner
    along u (-1 for the left eye, whose nose side is toward -x; +1 for the right; 0 none)
    where the caruncle is painted."""
    rng = np.random.default_rng(seed)
    r, th = _polar(SIZE)
    c = _sclera_rgb(r, th, rng)
    if nasal:
        c = _caruncle(c, r * np.cos(th) * nasal, r * np.sin(th), rng)
    return color.rgba8(c, np.ones(r.shape, np.float32))


def _caruncle(c: np.ndarray, x: np.ndarray, y: np.ndarray, rng) -> np.ndarray:
    """The caruncle on sclera colours ``c`` at UV offsets ``x`` (toward the nose), ``y``: a
    pink, finely bumpy mound in the inner corner, and the plica, a pinker fold beside it."""
    (cx, cy), (rx, ry) = CARUNCLE["centre"], CARUNCLE["radii"]
    d = np.hypot((x - cx) / rx, (y - cy) / ry)
    bumps = ndimage.gaussian_filter(rng.random(d.shape).astype(np.float32), 2.0)
    bumps = (bumps - bumps.mean()) / max(float(bumps.std()), 1e-6)
    flesh = color.hex_linear(CARUNCLE["colour"])[None, None, :] * (1 + 0.08 * bumps[..., None])
    w = (1 - smoothstep(0.5, 1.2, d)) * smoothstep(0.0, 0.3, x)
    plica = np.exp(-((x - CARUNCLE["plica"]) / 0.02) ** 2) * np.exp(-((y - cy) / 0.12) ** 2)
    c = c * (1 + (np.array([1.0, 0.8, 0.78], np.float32) - 1) * (0.6 * plica)[..., None])
    return c * (1 - w[..., None]) + flesh * w[..., None]
