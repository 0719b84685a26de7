"""An improved transition generator: seed 000's LSTM with Harvey et al. (2020)'s RTN ideas.

Per generated frame the LSTM reads three embeddings — the current frame, its offset to the
target and the target — each plus a sinusoidal *time-to-arrival* code; during training the
offset and target codes get *target noise* (σ = ``target_noise``, faded out over the last
frames). The hidden state is *initialised* by an MLP from the seed window's last frame, its
velocity and the target. The decoder predicts an offset from the cubic-Hermite interpolation
(start velocity from the window, target at rest), shaped by ``sin(π·u)`` so the transition
leaves the start smoothly and lands on the target; the loss weights the first and last
``end_frames`` frames ``end_weight`` times.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch import nn


@dataclass
class RTNConfig:
    n_channels: int = 20
    window: int = 20
    embed: int = 128
    hidden: int = 256
    target_noise: float = 0.5
    noise_fade: tuple[int, int] = (5, 30)  # full noise at tta ≥ 30 frames, none at ≤ 5
    end_frames: int = 3
    end_weight: float = 3.0


def _mlp(i: int, h: int, o: int) -> nn.Sequential:
    return nn.Sequential(nn.Linear(i, h), nn.LeakyReLU(0.2), nn.Linear(h, o), nn.LeakyReLU(0.2))


def tta_code(tta: torch.Tensor, dim: int) -> torch.Tensor:
    """Sinusoidal time-to-arrival code (Harvey et al. 2020): tta (B,) frames → (B, dim)."""
    i = torch.arange(0, dim, 2, device=tta.device, dtype=torch.float32)
    freq = torch.exp(-math.log(10000.0) * i / dim)  # (dim/2,)
    a = tta.float()[:, None] * freq[None]
    out = torch.zeros(tta.shape[0], dim, device=tta.device)
    out[:, 0::2] = torch.sin(a)
    out[:, 1::2] = torch.cos(a)
    return out


class RTNTransition(nn.Module):
    """``forward(window (B, S, K), target (B, K), length L, lengths (B,)) → (B, L, K)``.

    ``lengths`` are the true transition lengths (frames to the target) of a padded batch; past
    its length an example holds its target.
    """

    kind = "rtn"

    def __init__(self, config: RTNConfig):
        super().__init__()
        self.config = config
        K, E, H = config.n_channels, config.embed, config.hidden
        self.enc_state = _mlp(K, E, E)
        self.enc_offset = _mlp(K, E, E)
        self.enc_target = _mlp(K, E, E)
        self.init = nn.Sequential(nn.Linear(3 * K, H), nn.LeakyReLU(0.2), nn.Linear(H, 2 * H))
        self.lstm = nn.LSTMCell(3 * E, H)
        self.dec = nn.Sequential(nn.Linear(H, E), nn.LeakyReLU(0.2), nn.Linear(E, K))

    def forward(self, window: torch.Tensor, target: torch.Tensor, length: int,
                lengths: torch.Tensor | None = None) -> torch.Tensor:
        cfg = self.config
        B, _, _ = window.shape
        if lengths is None:
            lengths = torch.full((B,), length, dtype=torch.long, device=window.device)
        Lf = lengths.float()[:, None]  # (B, 1)
        a, v = window[:, -1], window[:, -1] - window[:, -2]  # (B, K)
        hc = torch.tanh(self.init(torch.cat([a, v, target], 1)))  # (B, 2H)
        h, c = hc.chunk(2, dim=1)
        z_t = self.enc_target(target)  # (B, E)
        noise = None
        if self.training and cfg.target_noise > 0:
            noise = torch.randn(B, cfg.embed, device=window.device) * cfg.target_noise
        x = a
        out = []
        lo, hi = cfg.noise_fade
        for t in range(length):
            tta = (lengths - t).clamp_min(0)  # frames still to go (B,)
            zt = tta_code(tta, cfg.embed)
            e_s = self.enc_state(x) + zt
            e_o = self.enc_offset(target - x) + zt
            e_g = z_t + zt
            if noise is not None:
                lam = ((tta.float() - lo) / (hi - lo)).clamp(0, 1)[:, None]
                e_o, e_g = e_o + lam * noise, e_g + lam * noise
            h, c = self.lstm(torch.cat([e_s, e_o, e_g], 1), (h, c))  # (B, H)
            u = ((t + 1) / Lf).clamp(max=1.0)  # progress of this frame (B, 1)
            base = ((2 * u**3 - 3 * u**2 + 1) * a + (u**3 - 2 * u**2 + u) * Lf * v
                    + (-2 * u**3 + 3 * u**2) * target)  # cubic Hermite (B, K)
            y = base + torch.sin(math.pi * u) * self.dec(h)
            out.append(y)
            x = y
        return torch.stack(out, dim=1)  # (B, L, K)

    def loss(self, pred: torch.Tensor, frames: torch.Tensor, mask: torch.Tensor
             ) -> torch.Tensor:
        """MSE with the first and last ``end_frames`` real frames weighted ``end_weight``×."""
        cfg = self.config
        se = ((pred - frames) ** 2).mean(-1)  # (B, L)
        L = mask.sum(1, keepdim=True)  # (B, 1)
        t = torch.arange(mask.shape[1], device=mask.device)[None].float()
        ends = (t < cfg.end_frames) | (t >= L - cfg.end_frames)
        w = mask * torch.where(ends, cfg.end_weight, 1.0)
        return (se * w).sum() / w.sum().clamp_min(1)
