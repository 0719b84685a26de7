"""Filling missing frames of a take: drop-outs and rows missing from the frame grid."""

from __future__ import annotations

import numpy as np

from mimika.errors import ParameterError

__all__ = ["FILLS", "fill_gaps"]

FILLS = ("linear", "nearest", "hold", "quadratic", "cubic")
_LAGRANGE = {"quadratic": 2, "cubic": 3}


def _lagrange_fill(v: np.ndarray, ok: np.ndarray, degree: int) -> None:
    """Fill interior gaps of ``v`` (T, K) in place with a Lagrange polynomial of ``degree``
    through the ``degree + 1`` valid rows nearest each gap (half before, half after; fewer
    on one side near the ends). Gaps before the first / after the last valid row are held."""
    t = np.arange(len(v))
    good = t[ok]
    bad = t[~ok]
    if len(good) <= degree:  # not enough support: fall back to linear
        for k in range(v.shape[1]):
            v[~ok, k] = np.interp(bad, good, v[ok, k])
        return
    # runs of consecutive missing rows
    splits = np.flatnonzero(np.diff(bad) > 1) + 1
    for run in np.split(bad, splits):
        lo, hi = int(run[0]), int(run[-1])
        before = good[good < lo]
        after = good[good > hi]
        if len(before) == 0 or len(after) == 0:  # leading / trailing gap: hold
            v[run] = v[after[0]] if len(before) == 0 else v[before[-1]]
            continue
        n = degree + 1
        nb = min(len(before), max(n - len(after), (n + 1) // 2))
        na = n - nb
        xs = np.concatenate([before[len(before) - nb:], after[:na]]).astype(np.float64)
        # Lagrange basis weights, shape (len(run), n)
        w = np.ones((len(run), n))
        for j in range(n):
            for m in range(n):
                if m != j:
                    w[:, j] *= (run - xs[m]) / (xs[j] - xs[m])
        v[run] = w @ v[xs.astype(int)]


def fill_gaps(values: np.ndarray, valid: np.ndarray, *, method: str = "linear") -> np.ndarray:
    """Fill rows of ``values`` (T, K) where ``valid`` (T,) is False.

    ``linear`` interpolates between the nearest valid rows, ``nearest`` copies the closer one,
    ``hold`` repeats the last valid row; ``quadratic`` and ``cubic`` fit a Lagrange polynomial
    of degree 2 / 3 through the 3 / 4 valid rows nearest each gap (seed 000's gap filling; a
    polynomial of that degree is recovered exactly). Before the first and after the last valid
    row values are held. Polynomial fills may overshoot; callers clip to their range.
    """
    if method not in FILLS:
        raise ParameterError(f"fill={method!r} must be one of {', '.join(FILLS)}")
    v = np.array(values, np.float64)
    ok = np.asarray(valid, bool)
    if ok.all() or not ok.any():
        return v.astype(np.float32)
    t = np.arange(len(v))
    good = t[ok]
    if method in _LAGRANGE:
        _lagrange_fill(v, ok, _LAGRANGE[method])
    elif method == "linear":
        for k in range(v.shape[1]):
            v[~ok, k] = np.interp(t[~ok], good, v[ok, k])
    else:
        pos = np.searchsorted(good, t)  # first valid index ≥ t
        prev = good[np.clip(pos - 1, 0, len(good) - 1)]
        nxt = good[np.clip(pos, 0, len(good) - 1)]
        prev = np.where(pos == 0, nxt, prev)
        near = np.where(np.abs(t - prev) <= np.abs(nxt - t), prev, nxt)
        src = prev if method == "hold" else near
        v[~ok] = v[src[~ok]]
    return v.astype(np.float32)
