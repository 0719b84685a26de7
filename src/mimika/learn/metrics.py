"""Transition metrics (seed 000 + Harvey et al. 2020).

All functions take arrays of one transition: ``gen`` and ``gt`` (L, K) — the generated and the
real frames after the start (the last is the target) — and ``window`` (S, K), the seed frames.
Intensities are on mimika's [0, 1] scale (``max_intensity`` = 1; the seed's was 1.20, so its
absolute threshold |GT − gen| > 1.00 becomes > 1.00 / 1.20 = 0.833 here).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["Conspicuous", "conspicuous", "endpoint_error", "jump_percent", "mse",
           "reactivation", "summarise"]

MAX_INTENSITY = 1.0
#: seed 000's thresholds, as fractions of the maximum intensity
GT_DIFF = 1.00 / 1.20
ONE_JUMP, THREE_JUMPS, REACTIVATION, ENDPOINT = 0.40, 0.20, 0.25, 0.25


def mse(gen: np.ndarray, gt: np.ndarray) -> float:
    """Mean squared error over frames and AUs."""
    return float(np.mean((np.asarray(gen, np.float64) - gt) ** 2))


def l2(gen: np.ndarray, gt: np.ndarray) -> float:
    """Mean over frames of the Euclidean distance between AU vectors (Harvey's L2)."""
    return float(np.mean(np.linalg.norm(np.asarray(gen, np.float64) - gt, axis=1)))


def jump_percent(window: np.ndarray, gen: np.ndarray) -> float:
    """Seed 000's jump: mean over AUs of |first generated − last seed frame| / max × 100."""
    return float(np.mean(np.abs(np.asarray(gen[0], np.float64) - window[-1])) /
                 MAX_INTENSITY * 100)


def steps(window: np.ndarray, gen: np.ndarray) -> np.ndarray:
    """Frame-to-frame steps |Δ| from the last seed frame through the generated frames,
    shape (L, K), as fractions of the maximum intensity."""
    seq = np.concatenate([np.asarray(window[-1:], np.float64), gen])
    return np.abs(np.diff(seq, axis=0)) / MAX_INTENSITY


def reactivation(gen: np.ndarray) -> np.ndarray:
    """Per AU (K,): how far a curve rises again after falling, beyond the rise the target
    needs: max_t(x_t − min_{s≤t} x_s) − max(0, x_end − min_s x_s)."""
    x = np.asarray(gen, np.float64)
    run_min = np.minimum.accumulate(x, axis=0)
    rise = np.max(x - run_min, axis=0)
    need = np.maximum(0.0, x[-1] - x.min(0))
    return np.maximum(rise - need, 0.0) / MAX_INTENSITY


def endpoint_error(gen: np.ndarray, target: np.ndarray) -> float:
    """Mean |last generated frame − target| over AUs."""
    return float(np.mean(np.abs(np.asarray(gen[-1], np.float64) - target)))


@dataclass(frozen=True)
class Conspicuous:
    """Which of seed 000's "visually conspicuous" criteria a transition meets."""

    gt_diff: bool
    jumps: bool
    reactivation: bool
    endpoint: bool

    @property
    def any(self) -> bool:
        return self.gt_diff or self.jumps or self.reactivation or self.endpoint


def conspicuous(window: np.ndarray, gen: np.ndarray, gt: np.ndarray | None = None
                ) -> Conspicuous:
    """Seed 000's criteria: |GT − gen| > 1.00/1.20 anywhere; one step > 40 % or three > 20 %;
    re-activation > 25 %; end frame > 25 % away from the target in any AU (the seed compared
    with every recorded variant of the expression; we have one: the target)."""
    st = steps(window, gen)
    target = gt[-1] if gt is not None else gen[-1]
    return Conspicuous(
        gt_diff=bool(gt is not None and np.max(np.abs(gen - gt)) > GT_DIFF),
        jumps=bool(st.max() > ONE_JUMP or np.sum(st > THREE_JUMPS) >= 3),
        reactivation=bool(np.max(reactivation(gen)) > REACTIVATION),
        endpoint=bool(np.max(np.abs(gen[-1] - target)) > ENDPOINT),
    )


def summarise(windows: Sequence[np.ndarray], gens: Sequence[np.ndarray],
              gts: Sequence[np.ndarray]) -> dict[str, float]:
    """Mean metrics over transitions: mse (per frame and AU, pooled), l2, jump_pct,
    gt_jump_pct, endpoint, conspicuous (count) and each criterion's count, n."""
    num = sum(float(np.sum((g - t) ** 2)) for g, t in zip(gens, gts, strict=True))
    den = sum(g.size for g in gens)
    cs = [conspicuous(w, g, t) for w, g, t in zip(windows, gens, gts, strict=True)]
    return {
        "n": len(gens),
        "mse": num / max(den, 1),
        "l2": float(np.mean([l2(g, t) for g, t in zip(gens, gts, strict=True)])),
        "jump_pct": float(np.mean([jump_percent(w, g) for w, g in zip(windows, gens,
                                                                       strict=True)])),
        "gt_jump_pct": float(np.mean([jump_percent(w, t) for w, t in zip(windows, gts,
                                                                          strict=True)])),
        "endpoint": float(np.mean([endpoint_error(g, t[-1]) for g, t in zip(gens, gts,
                                                                              strict=True)])),
        "conspicuous": sum(c.any for c in cs),
        "c_gt_diff": sum(c.gt_diff for c in cs),
        "c_jumps": sum(c.jumps for c in cs),
        "c_reactivation": sum(c.reactivation for c in cs),
        "c_endpoint": sum(c.endpoint for c in cs),
    }
