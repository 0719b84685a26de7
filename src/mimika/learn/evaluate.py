"""Evaluate transition generators (learned models and interpolation baselines) on a split.

``evaluate(gen, items)`` runs a generator over transitions and summarises the metrics of
:mod:`mimika.learn.metrics`; ``l2_at(gen, take)`` is Harvey et al.'s L2 at fixed transition
lengths (5, 15, 30 frames) over every window of a take (stride 10).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from mimika.learn.baselines import BASELINES
from mimika.learn.data import Take, Transition, fixed_windows
from mimika.learn.metrics import l2, summarise

__all__ = ["Generator", "baseline_generator", "evaluate", "l2_at", "model_generator"]

#: window (S, K), target (K,), length → frames (L, K)
Generator = Callable[[np.ndarray, np.ndarray, int], np.ndarray]


def baseline_generator(name: str) -> Generator:
    f = BASELINES[name]
    return lambda w, g, n: f(np.asarray(w, np.float64), np.asarray(g, np.float64), n)


def model_generator(model) -> Generator:
    from mimika.learn.train import generate

    return lambda w, g, n: generate(model, w, g, n)


def _run(gen: Generator, items: Sequence[Transition], batch=None) -> list[np.ndarray]:
    if batch is not None:  # batched model inference, grouped by length
        out: dict[int, np.ndarray] = {}
        by_len: dict[int, list[int]] = {}
        for i, t in enumerate(items):
            by_len.setdefault(t.length, []).append(i)
        for L, ids in by_len.items():
            res = batch(np.stack([items[i].window for i in ids]),
                        np.stack([items[i].target for i in ids]), L)
            for i, r in zip(ids, res, strict=True):
                out[i] = r
        return [out[i] for i in range(len(items))]
    return [gen(t.window, t.target, t.length) for t in items]


def evaluate(gen: Generator, items: Sequence[Transition], *, batched: bool = False
             ) -> dict[str, float]:
    """Metrics of ``gen`` over ``items`` (see :func:`mimika.learn.metrics.summarise`)."""
    gens = _run(gen, items, gen if batched else None)
    return summarise([t.window for t in items], gens, [t.frames for t in items])


def l2_at(gen: Generator, take: Take, lengths: Sequence[int] = (5, 15, 30), *,
          stride: int = 10, batched: bool = False) -> dict[int, float]:
    """Mean L2 (per frame, over AUs) for transitions of each length in ``lengths``."""
    out = {}
    for L in lengths:
        items = fixed_windows(take, L, stride=stride)
        gens = _run(gen, items, gen if batched else None)
        out[L] = float(np.mean([l2(g, t.frames) for g, t in zip(gens, items, strict=True)]))
    return out
