"""Easing curves and transition interpolators: how one AU set turns into the next.

An *easing* is a curve ``f: [0, 1] → [0, 1]`` with ``f(0) = 0`` and ``f(1) = 1`` applied to the
progress of a transition (linear, cosine, smoothstep are built in; seed 002 Ch. 3 found cosine
"superior" to linear, so it is the default). An :class:`Interpolator` is the general form: it gets
both AU vectors and the progress and returns whole frames — the hook a learned transition model
plugs into with :func:`register_interpolator`.

This module is the registry only: it never imports the layers above it. Plug-ins register from
above — ``import mimika.learn`` registers the ``learned`` easing, and the command line (and
batch workers) do so at start-up through :func:`mimika.plugins.load_plugins`.

>>> ease = get_interpolator("cosine")
>>> ease(np.zeros(1), np.ones(1), np.array([0.0, 0.5, 1.0]), channels=("AU12",), duration=1.0)
array([[0. ],
       [0.5],
       [1. ]], dtype=float32)
"""

from __future__ import annotations

import difflib
from collections.abc import Callable, Sequence
from typing import Protocol, runtime_checkable

import numpy as np

from mimika.errors import ParameterError

__all__ = [
    "DEFAULT_EASING",
    "EasingFn",
    "Interpolator",
    "easing_names",
    "get_interpolator",
    "register_easing",
    "register_interpolator",
]

#: the easing events use when neither they nor their channel name one
DEFAULT_EASING = "cosine"

EasingFn = Callable[[np.ndarray], np.ndarray]


@runtime_checkable
class Interpolator(Protocol):
    """A transition between two AU vectors.

    Parameters
    ----------
    a, b : ndarray, shape (K,)
        AU intensities at the start and the end of the transition, in [0, 1].
    u : ndarray, shape (T,)
        Progress of each output frame in [0, 1] (0 → ``a``, 1 → ``b``).
    channels : the K AU codes (a learned model may condition on them)
    duration : length of the whole transition in seconds

    Returns
    -------
    ndarray, shape (T, K), float32 — must equal ``a`` at u = 0 and ``b`` at u = 1.
    """

    def __call__(self, a: np.ndarray, b: np.ndarray, u: np.ndarray, *,
                 channels: Sequence[str], duration: float) -> np.ndarray: ...


class _CurveInterpolator:
    """An :class:`Interpolator` from an easing curve: ``a + (b − a)·f(u)``."""

    def __init__(self, name: str, fn: EasingFn):
        self.name = name
        self.fn = fn

    def __call__(self, a: np.ndarray, b: np.ndarray, u: np.ndarray, *,
                 channels: Sequence[str] = (), duration: float = 1.0) -> np.ndarray:
        w = np.asarray(self.fn(np.clip(np.asarray(u, np.float64), 0.0, 1.0)), np.float64)
        a = np.asarray(a, np.float64)
        b = np.asarray(b, np.float64)
        return (a[None, :] + (b - a)[None, :] * w[:, None]).astype(np.float32)

    def __repr__(self) -> str:
        return f"<easing {self.name}>"


def _linear(u: np.ndarray) -> np.ndarray:
    return u


def _cosine(u: np.ndarray) -> np.ndarray:
    return 0.5 - 0.5 * np.cos(np.pi * u)


def _smoothstep(u: np.ndarray) -> np.ndarray:
    return u * u * (3.0 - 2.0 * u)


_REGISTRY: dict[str, Interpolator] = {}


def register_easing(name: str, fn: EasingFn, *, replace: bool = False) -> None:
    """Register an easing curve ``fn`` (array in [0, 1] → array) under ``name``.

    The curve must map 0 → 0 and 1 → 1 (checked). ``replace`` allows re-registering a name.
    """
    u = np.array([0.0, 1.0])
    try:
        ends = np.asarray(fn(u), float)
    except Exception as e:  # a user callable: report, never crash obscurely
        raise ParameterError(f"easing {name!r} failed on [0, 1]: {e}") from None
    if ends.shape != (2,) or not np.allclose(ends, [0.0, 1.0], atol=1e-6):
        raise ParameterError(f"easing {name!r} must map 0 → 0 and 1 → 1, got {ends.tolist()}")
    register_interpolator(name, _CurveInterpolator(name, fn), replace=replace)


def register_interpolator(name: str, interpolator: Interpolator, *,
                          replace: bool = False) -> None:
    """Register a full transition model (see :class:`Interpolator`) under ``name``.

    Scripts then select it with ``ease="NAME"``; a learned model registers itself this way.
    """
    key = str(name).strip().lower()
    if not key or not key.replace("-", "").replace("_", "").isalnum():
        raise ParameterError(f"easing name {name!r} must be letters, digits, '-' or '_'")
    if key in _REGISTRY and not replace:
        raise ParameterError(f"easing {key!r} is already registered; pass replace=True")
    if not callable(interpolator):
        raise ParameterError(f"interpolator for {key!r} must be callable")
    _REGISTRY[key] = interpolator


def easing_names() -> tuple[str, ...]:
    """Every registered easing / interpolator name."""
    return tuple(_REGISTRY)


def get_interpolator(name: str) -> Interpolator:
    """The interpolator registered as ``name``; unknown names raise with suggestions."""
    key = str(name).strip().lower()
    if key in _REGISTRY:
        return _REGISTRY[key]
    close = difflib.get_close_matches(key, list(_REGISTRY), n=3)
    hint = f"; did you mean {', '.join(close)}?" if close else ""
    raise ParameterError(f"unknown easing {name!r}{hint} (known: {', '.join(_REGISTRY)}; "
                         "plug-ins register when imported, e.g. 'learned' with import "
                         "mimika.learn — the mimika command does this itself)")


def check_easing(name: str) -> str:
    """Canonical (lower-case) easing name, or :class:`ParameterError`."""
    get_interpolator(name)
    return str(name).strip().lower()


register_easing("linear", _linear)
register_easing("cosine", _cosine)
register_easing("smoothstep", _smoothstep)
