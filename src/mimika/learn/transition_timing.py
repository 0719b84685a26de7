"""A learned transition *timing* model: when the movement starts and how fast it goes.

Real transitions between expression holds wait a few frames, then snap most of the way in a
handful of frames and settle slowly; an interpolator spreads the change evenly over the gap.
This model keeps the interpolators' shape — every AU of a group follows one progress curve from
its start value to its target — and learns the curve's timing from recordings:

``p(t) ∝ w·σ(k·(t − τ − r/2)/r) + (1 − w)·t/L``, normalised so p(0) = 0 and p(L) = 1, with
onset latency ``τ`` (frames), rise time ``r`` (10 → 90 % of the snap, frames), snap fraction
``w`` and the slow remainder spread linearly over the ``L`` frames. A start velocity ``v``
(from the window) carries on and dies out: ``+ v·t·(1 − t/L)²·e^(−t/κ)``.

Each of τ, r, w, κ is a linear function of the transition's features (bias, log length, the
group's largest change, its direction, its start speed): one shared function plus a deviation
per AU group (brows, lids, cheeks, lip corners, lips, jaw) under a ridge penalty
(``group_penalty``) — held-out takes showed free per-group timings do not carry over from one
take to the next, shared ones do. 192 numbers, fitted by MSE to segmented transitions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import torch
from torch import nn

from mimika.learn.data import MODEL_CHANNELS

#: AU groups that share one timing (face regions; channels outside every group ease alone)
GROUPS: dict[str, tuple[str, ...]] = {
    "brows": ("AU01", "AU02", "AU04"),
    "lids": ("AU05", "AU07"),
    "cheeks": ("AU06", "AU09", "AU10", "AU11"),
    "corners": ("AU12", "AU14", "AU15", "AU20"),
    "lips": ("AU16", "AU17", "AU18", "AU22", "AU24", "AU28"),
    "jaw": ("AU27",),
}
#: σ(±K/2) = 10 % / 90 %: the logistic's 10 → 90 % rise takes r frames
_K = 2.0 * math.log(9.0)
#: features per group: bias, log(L/15), change, direction, start speed
#: initial parameters: onset 2 frames, rise 6 frames, snap fraction 0.8, velocity decay 5
_INIT = (2.0, 5.0, 0.8, 4.0)


def _inv_softplus(y: float) -> float:
    return math.log(math.expm1(y))


@dataclass
class TimingConfig:
    n_channels: int = 20
    channels: tuple[str, ...] = MODEL_CHANNELS
    groups: dict[str, tuple[str, ...]] = field(default_factory=lambda: dict(GROUPS))
    features: tuple[int, ...] = (0, 1, 2, 3, 4)
    group_penalty: float = 1.0  # ridge on each group's deviation from the shared timing


class TimingTransition(nn.Module):
    """``forward(window (B, S, K), target (B, K), length L, lengths (B,)) → (B, L, K)``."""

    kind = "timing"

    def __init__(self, config: TimingConfig):
        super().__init__()
        self.config = config
        names = list(config.groups)
        gid = [next((g for g, n in enumerate(names) if c in config.groups[n]), len(names))
               for c in config.channels]
        self.register_buffer("group_of", torch.tensor(gid, dtype=torch.long), persistent=False)
        G, F = len(names) + 1, len(config.features)  # the last group: channels in no group
        tau, r, w, kappa = _INIT
        self.shared_b = nn.Parameter(torch.tensor([
            _inv_softplus(tau), _inv_softplus(r - 1.0), math.log(w / (1 - w)),
            _inv_softplus(kappa - 1.0)]))
        self.shared_w = nn.Parameter(torch.zeros(F, 4))
        self.group_b = nn.Parameter(torch.zeros(G, 4))
        self.group_w = nn.Parameter(torch.zeros(G, F, 4))
        self.n_groups = G

    def _pool(self, x: torch.Tensor) -> torch.Tensor:
        """Per-group maximum of x (B, K) ≥ 0 → (B, G)."""
        out = x.new_zeros(x.shape[0], self.n_groups)
        return out.scatter_reduce(1, self.group_of.expand_as(x), x, "amax")

    def parameters_for(self, a: torch.Tensor, v: torch.Tensor, target: torch.Tensor,
                       lengths: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """Onset τ, rise r, snap fraction w, velocity decay κ per group: 4 × (B, G)."""
        d = target - a
        size = self._pool(d.abs())
        pos = self._pool(d.clamp_min(0))
        direction = (pos - self._pool((-d).clamp_min(0))) / size.clamp_min(1e-3)
        speed = self._pool(v.abs()) * 10.0
        logl = torch.log(lengths.float() / 15.0)[:, None].expand_as(size)
        fs = (torch.ones_like(size), logl, size, direction, speed)
        f = torch.stack([fs[i] for i in self.config.features], -1)  # (B, G, F)
        raw = (torch.einsum("bgf,gfo->bgo", f, self.shared_w[None] + self.group_w)
               + self.shared_b + self.group_b)  # (B, G, 4)
        tau = nn.functional.softplus(raw[..., 0])
        r = 1.0 + nn.functional.softplus(raw[..., 1])
        w = torch.sigmoid(raw[..., 2])
        kappa = 1.0 + nn.functional.softplus(raw[..., 3])
        return tau, r, w, kappa

    def progress(self, tau, r, w, t: torch.Tensor, lengths: torch.Tensor) -> torch.Tensor:
        """Progress (B, T, G) at frames ``t`` (T,) for transitions of ``lengths`` (B,)."""
        L = lengths.float()[:, None, None]

        def s(x):  # x (B, T or 1, 1) frames
            return (w[:, None] * torch.sigmoid(_K * (x - tau[:, None] - 0.5 * r[:, None])
                                               / r[:, None])
                    + (1 - w[:, None]) * x / L)

        s0, s1 = s(torch.zeros_like(L)), s(L)
        p = (s(t[None, :, None]) - s0) / (s1 - s0).clamp_min(1e-6)
        return torch.where(t[None, :, None] >= L, torch.ones_like(p), p)

    def forward(self, window: torch.Tensor, target: torch.Tensor, length: int,
                lengths: torch.Tensor | None = None) -> torch.Tensor:
        B = window.shape[0]
        if lengths is None:
            lengths = torch.full((B,), length, dtype=torch.long, device=window.device)
        a, v = window[:, -1], window[:, -1] - window[:, -2]
        tau, r, w, kappa = self.parameters_for(a, v, target, lengths)
        t = torch.arange(1, length + 1, dtype=torch.float32, device=window.device)
        p = self.progress(tau, r, w, t, lengths)  # (B, L, G)
        idx = self.group_of[None, None].expand(B, length, -1)
        pk = torch.gather(p, 2, idx)  # (B, L, K)
        L = lengths.float()[:, None, None]
        tt = t[None, :, None]
        carry = tt * (1 - tt / L).clamp_min(0) ** 2 * torch.exp(
            -tt / torch.gather(kappa, 1, self.group_of[None].expand(B, -1))[:, None])
        return a[:, None] + (target - a)[:, None] * pk + v[:, None] * carry

    def loss(self, pred: torch.Tensor, frames: torch.Tensor, mask: torch.Tensor
             ) -> torch.Tensor:
        """Sequence MSE over real frames and all AUs, plus the ridge on group deviations."""
        se = ((pred - frames) ** 2).mean(-1)
        ridge = (self.group_w ** 2).sum() + (self.group_b ** 2).sum()
        return (se * mask).sum() / mask.sum().clamp_min(1) + 1e-4 * self.config.group_penalty \
            * ridge
