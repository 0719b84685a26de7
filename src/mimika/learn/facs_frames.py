"""AU frames that FACS knowledge gives without a recording: a prior for the controller.

Recorded takes show the expressions their performer happened to make; a range-of-motion take
shows each action alone, performance takes mostly speech and a few emotions. A controller
trained on performance takes alone cannot place an action none of them shows (lip press,
dimpler, nasolabial deepener) and flattens it. FACS says what the space of faces is made of —
every AU can be shown alone, at any intensity, and combines with others under the
co-occurrence rules — so the controller also trains on frames drawn from that knowledge:

* **single AUs**: each channel alone, intensity uniform in [0.2, 1];
* **the expression library** (seed 002's prototypes and templates, built-ins only), scaled
  by a uniform intensity in [0.3, 1];
* **sparse mixes**: two or three AUs drawn at random, each uniform in [0.2, 1];

a third each, with a small non-negative jitter on every channel (recorded frames are never
exactly zero); given recorded frames, a quarter of all are instead

* **recordings plus one action**: a recorded frame with one AU drawn at random raised to at
  least a uniform intensity in [0.2, 1] — AUs combine, so a face the performer made with one
  more action is a face too;

all passed through the AU Blender (Appendix C co-occurrence rules). Codes the
channels lack go to their closest channel as in :data:`mimika.learn.gan_data.PROTOTYPE_MAP`
(AU25/AU26 → AU27 jaw, AU23 → AU24 lips); sided codes count for their bilateral AU.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mimika.learn.data import MODEL_CHANNELS

__all__ = ["facs_frames"]

#: intensity range of single AUs and mixes / of library expressions
AU_RANGE = (0.2, 1.0)
EXPRESSION_RANGE = (0.3, 1.0)
#: scale of the half-normal jitter on every channel
JITTER = 0.02


def _library(channels: Sequence[str]) -> np.ndarray:
    """The built-in expressions (but neutral) over ``channels``: (E, K) at full intensity."""
    from mimika.knowledge.expressions import builtin_expressions
    from mimika.learn.gan_data import expression_vector

    rows = [expression_vector(e.scaled(1.0), channels) for e in builtin_expressions().values()]
    return np.array([r for r in rows if r.any()], np.float32)


def facs_frames(n: int = 3000, channels: Sequence[str] = MODEL_CHANNELS, *,
                seed: int = 0, base: np.ndarray | None = None) -> np.ndarray:
    """``n`` frames (n, K) in [0, 1] over ``channels``, drawn as the module docstring says;
    given recorded ``base`` frames, a quarter are those frames with one more AU."""
    from mimika.facs.blender import blend_frames

    rng = np.random.default_rng(seed)
    K = len(channels)
    n0 = 0 if base is None else n // 4
    n -= n0
    n1 = n2 = n // 3  # single AUs, library expressions; the rest are mixes
    x = np.zeros((n, K), np.float32)
    x[np.arange(n1), np.arange(n1) % K] = rng.uniform(*AU_RANGE, n1)
    lib = _library(channels)
    x[n1:n1 + n2] = lib[np.arange(n2) % len(lib)] * rng.uniform(*EXPRESSION_RANGE, (n2, 1))
    for i in range(n1 + n2, n):
        aus = rng.choice(K, size=rng.integers(2, 4), replace=False)
        x[i, aus] = rng.uniform(*AU_RANGE, len(aus))
    x = np.clip(x + np.abs(rng.normal(0.0, JITTER, x.shape)), 0.0, 1.0)
    if n0:
        more = np.asarray(base, np.float32)[rng.integers(0, len(base), n0)]
        k = rng.integers(0, K, n0)
        more[np.arange(n0), k] = np.maximum(more[np.arange(n0), k], rng.uniform(*AU_RANGE, n0))
        x = np.concatenate([x, more])
    blended, chans = blend_frames(x, channels)
    return blended[:, [chans.index(c) for c in channels]]
