"""Dynamic time warping in memory linear in the length of the signals.

Symmetric step pattern (diagonal weight 2, horizontal/vertical :data:`HV_WEIGHT`), Euclidean
local cost, restricted to a band of columns per row. :func:`warp` runs it as a pyramid: the
signals averaged over :data:`COARSE` frames are warped inside a Sakoe–Chiba band of ±(25 % +
1 s), then the full-rate signals within :data:`RADIUS` frames of that path. When the band would
hold more than :data:`MAX_CELLS` cells (recordings over about two minutes) the coarse level is
itself found through a coarser one (and refined within :data:`WIDE_RADIUS`), so every level
holds O(N) cells and the coarsest at most :data:`MAX_CELLS` — a 30-minute recording needs tens
of megabytes, not gigabytes. Each row is vectorised (the horizontal recursion is a running
minimum): cost O(cells) in numpy.
"""

from __future__ import annotations

import numpy as np

from mimika.errors import ParameterError

COARSE = 4  #: frames per frame of the next coarser level
RADIUS = 10  #: half-width around the coarser path, in frames of the finer level
#: the same between levels below the coarse one (a path found on 80 ms frames or coarser
#: strays further: ±0.8 s at 20 ms)
WIDE_RADIUS = 40
#: weight of a horizontal or vertical step (a diagonal step weighs 2): above 1 it costs to
#: stretch one signal against the other, so real speech cannot squeeze three words into 30 ms
#: and stretch the next across a second (GRID dev, 60 utterances: 58.9 % → 73.3 % of word
#: boundaries within 50 ms; synthetic bench p90 15.7 → 12.6 ms)
HV_WEIGHT = 1.5
#: most cells (one backpointer byte each) the banded coarsest level may hold
MAX_CELLS = 1 << 24


def dtw_path(x: np.ndarray, y: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """DTW between feature rows ``x`` (N, F) and ``y`` (M, F) restricted to columns
    ``[lo[i], hi[i])`` of row *i* (both non-decreasing); Euclidean local cost, symmetric steps.

    Holds one backpointer byte per cell of the band and two rows of costs. Returns the warping
    path, shape (L, 2) of (i, j) from (0, 0) to (N−1, M−1).
    """
    n, m = len(x), len(y)
    inf = np.inf
    lo = np.asarray(lo, np.int64)
    hi = np.asarray(hi, np.int64)
    offs = np.concatenate([[0], np.cumsum(hi - lo)])
    ptrs = np.empty(int(offs[-1]), np.int8)
    prev = None
    prev_lo = 0
    for i in range(n):
        a, b = int(lo[i]), int(hi[i])
        c = np.sqrt(((y[a:b] - x[i]) ** 2).sum(axis=1))
        if prev is None:
            d = np.cumsum(HV_WEIGHT * c) if a == 0 else np.full(b - a, inf)
            p = np.full(b - a, 2, np.int8)
        else:
            ext = np.full(b - a + 1, inf)  # D_prev at columns a−1 … b−1
            s0, s1 = max(a - 1, prev_lo), min(b, prev_lo + len(prev))
            if s1 > s0:
                ext[s0 - (a - 1):s1 - (a - 1)] = prev[s0 - prev_lo:s1 - prev_lo]
            diag = ext[:-1] + 2 * c
            vert = ext[1:] + HV_WEIGHT * c
            bmin = np.minimum(diag, vert)
            s = np.cumsum(HV_WEIGHT * c)
            with np.errstate(invalid="ignore"):
                d = s + np.minimum.accumulate(bmin - s)
            d = np.where(np.isnan(d), inf, d)
            p = np.where(diag <= vert, 0, 1).astype(np.int8)
            p[d < bmin - 1e-9] = 2
        ptrs[offs[i]:offs[i + 1]] = p
        prev, prev_lo = d, a
    if not np.isfinite(prev[m - 1 - prev_lo]):
        raise ParameterError("alignment failed: the recording and transcript cannot be matched")
    i, j = n - 1, m - 1
    path = [(i, j)]
    while i > 0 or j > 0:
        step = ptrs[offs[i] + j - lo[i]]
        if step == 0:
            i, j = i - 1, j - 1
        elif step == 1:
            i -= 1
        else:
            j -= 1
        if i < 0 or j < 0:
            break
        path.append((i, j))
    return np.array(path[::-1])


def band(n: int, m: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    """Columns ``[lo, hi)`` of each of ``n`` rows within ``width`` of the diagonal to
    (n − 1, m − 1)."""
    centre = np.arange(n) * (m - 1) / max(n - 1, 1)
    lo = np.clip(np.floor(centre - width), 0, m - 1).astype(int)
    hi = np.clip(np.ceil(centre + width) + 1, 1, m).astype(int)
    lo[0], hi[-1] = 0, m
    return lo, hi


def _pool(f: np.ndarray) -> np.ndarray:
    k = len(f) // COARSE * COARSE
    g = f[:k].reshape(-1, COARSE, f.shape[1]).mean(axis=1)
    return g if k == len(f) else np.vstack([g, f[k:].mean(axis=0)])


def _around(cpath: np.ndarray, n: int, m: int, radius: int) -> tuple[np.ndarray, np.ndarray]:
    """The band of the finer level: within ``radius`` frames of the coarse path ``cpath``."""
    lo = np.full(n, m, int)
    hi = np.zeros(n, int)
    for ci, cj in cpath:
        r0, r1 = ci * COARSE, min(n, (ci + 1) * COARSE)
        lo[r0:r1] = np.minimum(lo[r0:r1], cj * COARSE - radius)
        hi[r0:r1] = np.maximum(hi[r0:r1], (cj + 1) * COARSE + radius)
    lo = np.clip(np.minimum.accumulate(lo[::-1])[::-1], 0, m - 1)
    hi = np.clip(np.maximum.accumulate(hi), 1, m)
    lo[0], hi[-1] = 0, m
    return lo, hi


def warp(ref: np.ndarray, rec: np.ndarray, *, hop: float, radius: int = RADIUS) -> np.ndarray:
    """Path of ``ref`` (N, F) against ``rec`` (M, F), frames ``hop`` s apart: the coarse level
    (frames ``COARSE·hop``) in a band of ±(25 % + 1 s) — or, while that band is over
    :data:`MAX_CELLS`, warped through coarser levels and refined within :data:`WIDE_RADIUS` —
    then refined within ``radius``. Shape (L, 2)."""
    cx, cy = _pool(ref), _pool(rec)
    width = int(0.25 * max(len(cx), len(cy)) + 1.0 / (hop * COARSE))
    lo, hi = band(len(cx), len(cy), width)
    if int((hi - lo).sum()) > MAX_CELLS and min(len(cx), len(cy)) > COARSE * WIDE_RADIUS:
        cpath = warp(cx, cy, hop=hop * COARSE, radius=WIDE_RADIUS)
    else:
        cpath = dtw_path(cx, cy, lo, hi)
    return dtw_path(ref, rec, *_around(cpath, len(ref), len(rec), radius))


def time_map(path: np.ndarray, *, hop: float) -> tuple[np.ndarray, np.ndarray]:
    """Monotone piecewise-linear map ref time → recording time from a DTW path:
    knots at ref frame edges ``(i − ½)·hop`` mapped to the middle of the recording frames
    between ``max j(i−1)`` and ``min j(i)``. Returns ``(ref_knots, rec_knots)`` in seconds."""
    i, j = path[:, 0], path[:, 1]
    n = int(i.max()) + 1
    jmin = np.full(n, np.iinfo(np.int64).max)
    jmax = np.full(n, -1)
    np.minimum.at(jmin, i, j)
    np.maximum.at(jmax, i, j)
    ref = (np.arange(1, n) - 0.5) * hop
    rec = (jmax[:-1] + jmin[1:]) * 0.5 * hop
    return ref, np.maximum.accumulate(rec)
