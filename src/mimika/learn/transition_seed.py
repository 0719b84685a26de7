"""Seed 000's LSTM expression generator, faithfully (Walczak 2021).

20-frame window → LSTM encoder (256) → last hidden ⊕ raw target → LSTM generator (512), one step
per generated frame, state carried, zero-initialised → linear decoder → the *absolute* next
frame. Rollout is a FIFO window: append the prediction, drop the oldest frame (no teacher
forcing). ≈ 1.9 M parameters for 20 channels.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn


@dataclass
class SeedConfig:
    n_channels: int = 20
    window: int = 20
    enc_hidden: int = 256
    gen_hidden: int = 512


class SeedTransition(nn.Module):
    """``forward(window (B, S, K), target (B, K), length L) → frames (B, L, K)``."""

    kind = "seed"

    def __init__(self, config: SeedConfig):
        super().__init__()
        self.config = config
        K = config.n_channels
        self.encoder = nn.LSTM(K, config.enc_hidden, batch_first=True)
        self.generator = nn.LSTMCell(K + config.enc_hidden, config.gen_hidden)
        self.decoder = nn.Linear(config.gen_hidden, K)

    def forward(self, window: torch.Tensor, target: torch.Tensor, length: int,
                lengths: torch.Tensor | None = None) -> torch.Tensor:
        B = window.shape[0]
        h = window.new_zeros(B, self.config.gen_hidden)
        c = window.new_zeros(B, self.config.gen_hidden)
        win = window  # (B, S, K)
        out = []
        for _ in range(length):
            _, (h_e, _) = self.encoder(win)  # h_e: (1, B, 256)
            x_r = torch.cat([target, h_e[-1]], dim=1)  # (B, K + 256)
            h, c = self.generator(x_r, (h, c))  # (B, 512)
            y = self.decoder(h)  # (B, K) absolute frame
            out.append(y)
            win = torch.cat([win[:, 1:], y[:, None]], dim=1)  # FIFO
        return torch.stack(out, dim=1)  # (B, L, K)

    def loss(self, pred: torch.Tensor, frames: torch.Tensor, mask: torch.Tensor
             ) -> torch.Tensor:
        """Sequence MSE over real frames and all AUs (seed 000)."""
        se = ((pred - frames) ** 2).mean(-1)  # (B, L)
        return (se * mask).sum() / mask.sum().clamp_min(1)
