"""Segment recordings into expression holds and transitions (seed 002 Ch. 7, on AU frames).

Seed 002 segments tracked 2-D points: PCA (90 % variance) → drop the 80 % most-neutral frames →
10×10 SOM → neurons assigned to templates → per-neuron acceptance distance → fill 1-frame gaps,
drop runs < 5 frames, merge gaps ≤ 12 frames. We run the same chain on AU frames (the Live Link
takes carry no 2-D points) with two documented changes:

* neurons are grouped into ``n_groups`` expression classes by k-means over their weights (the
  takes have no templates to assign them to); each class is labelled afterwards against the
  expression library (nearest prototype, distance threshold → ``unlabelled``);
* a frame counts toward a hold only while the face is (nearly) still — its smoothed speed is
  below ``speed_quantile`` of all speeds — so the moving frames between holds are left to the
  transitions. Frames near the actor's rest face are labelled ``neutral`` (a hold, too).

All fitting is numpy; :class:`Segmenter` is fitted on training takes and applied to any take.
"""

from __future__ import annotations

import hashlib
import itertools
import logging
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mimika.errors import ParameterError
from mimika.learn.data import MODEL_CHANNELS, SEED_FRAMES, Transition, window_at

log = logging.getLogger(__name__)

__all__ = [
    "SOM",
    "Hold",
    "Segmenter",
    "clean_runs",
    "label_prototype",
    "pca_fit",
    "transitions_between",
]

NEUTRAL = -2
NONE = -1


def pca_fit(x: np.ndarray, variance: float = 0.9) -> tuple[np.ndarray, np.ndarray]:
    """PCA of frames ``x`` (N, K): returns (mean (K,), components (K, d)) keeping the fewest
    components that explain ``variance`` of the total."""
    mu = x.mean(0)
    _, s, vt = np.linalg.svd(x - mu, full_matrices=False)
    ratio = np.cumsum(s**2) / max(float(np.sum(s**2)), 1e-12)
    d = int(np.searchsorted(ratio, variance) + 1)
    return mu, vt[:d].T


class SOM:
    """A rectangular self-organising map (numpy; Gaussian neighbourhood, batch updates).

    ``weights``: shape (rows·cols, d).
    """

    def __init__(self, rows: int = 10, cols: int = 10, *, seed: int = 0):
        self.rows, self.cols = rows, cols
        self.rng = np.random.default_rng(seed)
        gy, gx = np.mgrid[0:rows, 0:cols]
        self.grid = np.stack([gy.ravel(), gx.ravel()], 1).astype(np.float64)
        self.weights = np.zeros((rows * cols, 0))

    def fit(self, z: np.ndarray, *, epochs: int = 30) -> SOM:
        """Batch SOM on ``z`` (N, d); the radius shrinks from half the map to 0.5."""
        n = rows_cols = self.rows * self.cols
        idx = self.rng.choice(len(z), size=min(n, len(z)), replace=len(z) < n)
        self.weights = z[idx].astype(np.float64) + 1e-3 * self.rng.standard_normal(
            (rows_cols, z.shape[1]))
        d2grid = ((self.grid[:, None] - self.grid[None]) ** 2).sum(-1)
        r0 = max(self.rows, self.cols) / 2
        for e in range(epochs):
            r = r0 * (0.5 / r0) ** (e / max(epochs - 1, 1))
            h = np.exp(-d2grid / (2 * r * r))  # (n, n)
            bmu = self.bmu(z)
            onehot = np.zeros((len(z), n))
            onehot[np.arange(len(z)), bmu] = 1.0
            num = h @ (onehot.T @ z)
            den = h @ onehot.sum(0)
            ok = den > 1e-9
            self.weights[ok] = num[ok] / den[ok, None]
        return self

    def distances(self, z: np.ndarray) -> np.ndarray:
        """Squared distances (N, n_neurons)."""
        return ((z[:, None, :] - self.weights[None]) ** 2).sum(-1)

    def bmu(self, z: np.ndarray) -> np.ndarray:
        """Best-matching neuron per frame, shape (N,)."""
        out = np.empty(len(z), np.int64)
        for i in range(0, len(z), 4096):
            out[i:i + 4096] = self.distances(z[i:i + 4096]).argmin(1)
        return out


def _kmeans(x: np.ndarray, k: int, rng: np.random.Generator, iters: int = 50) -> np.ndarray:
    """k-means++ labels of rows of ``x``."""
    c = [x[rng.integers(len(x))]]
    for _ in range(1, min(k, len(x))):
        d = np.min(((x[:, None] - np.array(c)[None]) ** 2).sum(-1), 1)
        c.append(x[rng.choice(len(x), p=d / d.sum()) if d.sum() > 0 else rng.integers(len(x))])
    cent = np.array(c)
    for _ in range(iters):
        lab = ((x[:, None] - cent[None]) ** 2).sum(-1).argmin(1)
        new = np.array([x[lab == j].mean(0) if np.any(lab == j) else cent[j]
                        for j in range(len(cent))])
        if np.allclose(new, cent):
            break
        cent = new
    return ((x[:, None] - cent[None]) ** 2).sum(-1).argmin(1)


def clean_runs(labels: np.ndarray, *, min_length: int = 5, max_gap: int = 12) -> np.ndarray:
    """Seed 002's run rules on per-frame labels (``-1`` = no label): fill 1-frame gaps (a frame
    between two equal labels takes them), merge runs of one label separated by ≤ ``max_gap``
    frames, drop runs shorter than ``min_length``. Returns a new label array (T,)."""
    lab = np.asarray(labels).copy()
    T = len(lab)
    for t in range(1, T - 1):  # 1-frame gaps
        if lab[t] != lab[t - 1] and lab[t - 1] == lab[t + 1] and lab[t - 1] != NONE:
            lab[t] = lab[t - 1]
    runs = _runs(lab)
    # drop short runs first (noise), then merge close runs of one label
    for a, b, v in runs:
        if v != NONE and b - a < min_length:
            lab[a:b] = NONE
    runs = [r for r in _runs(lab) if r[2] != NONE]
    for (_a0, b0, v0), (a1, _, v1) in itertools.pairwise(runs):
        if v0 == v1 and a1 - b0 <= max_gap:
            lab[b0:a1] = v0
    return lab


def _runs(lab: np.ndarray) -> list[tuple[int, int, int]]:
    """Runs as (start, end-exclusive, label)."""
    if len(lab) == 0:
        return []
    cut = np.flatnonzero(np.diff(lab) != 0) + 1
    starts = np.r_[0, cut]
    ends = np.r_[cut, len(lab)]
    return [(int(a), int(b), int(lab[a])) for a, b in zip(starts, ends, strict=True)]


def label_prototype(aus: np.ndarray, *, channels: Sequence[str] = MODEL_CHANNELS,
                    threshold: float = 0.5, names: Sequence[str] | None = None
                    ) -> tuple[str, float]:
    """Nearest library expression to the AU vector ``aus`` (K,) over ``channels``.

    Library AUs outside ``channels`` map onto the nearest modelled one (AU26 jaw drop and AU25
    lips part → AU27 jaw open; AU23 lip tightener → AU24 lip presser). The distance counts the
    prototype's AUs fully and other active AUs at weight ¼ (real holds carry extra AUs, e.g.
    speech). Returns (name, distance)
    — ``("unlabelled", d)`` when the Euclidean distance exceeds ``threshold``.
    """
    protos = library_prototypes(channels, names)
    x = np.asarray(aus, np.float64)
    d = {}
    for n, p in protos.items():
        on = p > 0  # the prototype's AUs count fully, any other active AU at a quarter
        d[n] = float(np.sqrt(np.sum((x[on] - p[on]) ** 2) + 0.25 * np.sum(x[~on] ** 2)))
    best = min(d, key=d.__getitem__)
    return (best if d[best] <= threshold else "unlabelled"), d[best]


def library_prototypes(channels: Sequence[str] = MODEL_CHANNELS,
                       names: Sequence[str] | None = None) -> dict[str, np.ndarray]:
    """Expression-library entries as AU vectors over ``channels``
    (:func:`mimika.learn.gan_data.expression_vector`)."""
    from mimika.knowledge.expressions import builtin_expressions
    from mimika.learn.gan_data import expression_vector

    return {n: expression_vector(e.aus, channels) for n, e in builtin_expressions().items()
            if (names is None or n in names) and e.aus}  # neutral is decided by activation


@dataclass(frozen=True)
class Hold:
    """An expression hold: frames ``[start, end)`` of one class; ``label`` from the library."""

    start: int
    end: int
    group: int
    label: str
    mean: np.ndarray

    @property
    def length(self) -> int:
        return self.end - self.start


def canonical_order(takes: Sequence[np.ndarray]) -> list[np.ndarray]:
    """``takes`` sorted by a digest of their frames: one order whatever order they came in."""
    def key(x: np.ndarray) -> str:
        return hashlib.sha256(np.ascontiguousarray(x, np.float32).tobytes()).hexdigest()

    return sorted((np.asarray(x) for x in takes), key=key)


class Segmenter:
    """PCA + SOM segmentation fitted on training frames (see the module docstring).

    Parameters
    ----------
    keep : fraction of the most expressive frames the SOM is trained on (seed 002: 0.2; the
        performance takes here are mostly speech, so more frames are kept)
    neutral_quantile : frames whose distance from the take's rest face is below this quantile
        of the take's own distances are ``neutral``
    speed_quantile : frames faster than this quantile of the take's own speeds are never part
        of a hold
    accept_quantile : per-neuron acceptance distance (this quantile of its training frames)
    min_speed, min_activation : floors of the two relative thresholds (AU-space norms), so a
        take that is mostly holds (or mostly neutral) still gets its holds
    """

    def __init__(self, *, rows: int = 10, cols: int = 10, n_groups: int = 12,
                 variance: float = 0.9, keep: float = 0.5, neutral_quantile: float = 0.2,
                 speed_quantile: float = 0.5, accept_quantile: float = 0.99,
                 min_length: int = 5, max_gap: int = 12, label_threshold: float = 0.5,
                 min_speed: float = 0.02, min_activation: float = 0.1, seed: int = 0):
        if not 0 < keep <= 1:
            raise ParameterError(f"keep={keep!r} must be in (0, 1]")
        self.rows, self.cols, self.n_groups = rows, cols, n_groups
        self.variance, self.keep = variance, keep
        self.neutral_quantile, self.speed_quantile = neutral_quantile, speed_quantile
        self.accept_quantile = accept_quantile
        self.min_length, self.max_gap = min_length, max_gap
        self.label_threshold = label_threshold
        self.min_speed, self.min_activation = min_speed, min_activation
        self.seed = seed

    # -- features ------------------------------------------------------------------------------
    @staticmethod
    def rest_face(x: np.ndarray) -> np.ndarray:
        """The actor's rest face: per-channel 10th percentile of frames (K,)."""
        return np.percentile(x, 10, axis=0)

    @staticmethod
    def speed(x: np.ndarray) -> np.ndarray:
        """Smoothed frame-to-frame speed (T,): |x_t − x_{t−1}| averaged over 5 frames."""
        v = np.r_[0.0, np.linalg.norm(np.diff(x, axis=0), axis=1)]
        return np.convolve(v, np.ones(5) / 5, mode="same")

    def fit(self, takes: Sequence[np.ndarray]) -> Segmenter:
        """Fit on frames of ``takes`` (each (T, K)); the result does not depend on their order
        (takes are put in a canonical order — by content — before any random draw)."""
        takes = canonical_order(takes)
        acts, zs, speeds = [], [], []
        self.mu, self.comp = pca_fit(np.concatenate(takes), self.variance)
        for x in takes:
            acts.append(np.linalg.norm(x - self.rest_face(x), axis=1))
            zs.append((x - self.mu) @ self.comp)
            speeds.append(self.speed(x))
        act, z = np.concatenate(acts), np.concatenate(zs)
        self.neutral_act = float(np.quantile(act, self.neutral_quantile))
        self.max_speed = float(np.quantile(np.concatenate(speeds), self.speed_quantile))
        expressive = act >= np.quantile(act, 1 - self.keep)
        self.som = SOM(self.rows, self.cols, seed=self.seed).fit(z[expressive])
        rng = np.random.default_rng(self.seed)
        self.groups = _kmeans(self.som.weights, self.n_groups, rng)
        d = self.som.distances(z[expressive])
        b = d.argmin(1)
        dmin = d[np.arange(len(b)), b]
        glob = float(np.quantile(dmin, self.accept_quantile))
        self.accept = np.array([float(np.quantile(dmin[b == j], self.accept_quantile))
                                if np.sum(b == j) >= 5 else glob for j in range(len(d[0]))])
        # class means in AU space and their library labels
        xs = np.concatenate(takes)[expressive]
        g = self.groups[b]
        self.group_means = np.array([xs[g == j].mean(0) if np.any(g == j)
                                     else self.som.weights[self.groups == j].mean(0) @ self.comp.T
                                     + self.mu for j in range(self.groups.max() + 1)])
        self.group_labels = [label_prototype(m, threshold=self.label_threshold)[0]
                             for m in self.group_means]
        log.info("segmenter: PCA %d components, SOM %dx%d on %d frames, %d classes",
                 self.comp.shape[1], self.rows, self.cols, int(expressive.sum()),
                 len(self.group_means))
        return self

    def frame_labels(self, x: np.ndarray) -> np.ndarray:
        """Per-frame class (T,): a group id, ``NEUTRAL`` (−2) or ``NONE`` (−1, moving or not
        accepted by its neuron), before the run rules."""
        z = (x - self.mu) @ self.comp
        d = self.som.distances(z)
        b = d.argmin(1)
        ok = d[np.arange(len(b)), b] <= self.accept[b]
        act = np.linalg.norm(x - self.rest_face(x), axis=1)
        sp = self.speed(x)
        # thresholds relative to the take itself (a calm take and a talking one both have holds)
        still = sp <= max(float(np.quantile(sp, self.speed_quantile)), self.min_speed)
        neutral = act < max(float(np.quantile(act, self.neutral_quantile)), self.min_activation)
        lab = np.where(ok, self.groups[b], NONE)
        lab = np.where(neutral, NEUTRAL, lab)
        return np.where(still, lab, NONE)

    def holds(self, x: np.ndarray) -> list[Hold]:
        """The holds of one take ``x`` (T, K), in time order."""
        lab = clean_runs(self.frame_labels(x), min_length=self.min_length,
                         max_gap=self.max_gap)
        out = []
        for a, b, g in _runs(lab):
            if g == NONE:
                continue
            m = x[a:b].mean(0)
            name = "neutral" if g == NEUTRAL else self.group_labels[g]
            if g != NEUTRAL and name == "unlabelled":
                name = label_prototype(m, threshold=self.label_threshold)[0]
            out.append(Hold(a, b, int(g), name, m))
        return out


def transitions_between(x: np.ndarray, holds: Sequence[Hold], *, take: str = "",
                        fill: str = "linear", min_length: int = 3, max_length: int = 60
                        ) -> list[Transition]:
    """Transition examples between consecutive holds of one take.

    The start frame is the last frame of a hold, the target the first frame of the next; the
    seed window is the 20 frames ending at the start. Pairs whose gap is outside
    ``[min_length, max_length]`` frames or without room for the seed window are skipped.
    """
    out = []
    for h0, h1 in itertools.pairwise(holds):
        s, e = h0.end - 1, h1.start
        L = e - s
        if min_length > L or max_length < L or s < SEED_FRAMES - 1 or e >= len(x):
            continue
        out.append(window_at(x, s, L, take=take, fill=fill, source=h0.label,
                             target_label=h1.label))
    return out
