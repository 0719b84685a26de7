"""Put real frames on the sliders: GAN inversion ``frame → z``.

Two stages, for either generator kind:

1. an **encoder** ``[x̂ (B, K), onehot(y) (B, L)] → Dense 64 LeakyReLU → Dense d`` trained after
   the GAN on generated pairs ``(G(z, y), z)``, ``z ~ N(0, I)`` (amortised inversion, a
   starting guess);
2. **optimisation**: from the encoder's guess, ``z = 0`` and a few random draws, Adam minimises
   ``‖clamp(G(z)·σ + μ, 0, 1) − x‖² / K + λ‖z‖² / d`` (AU space; λ keeps ``z`` where the
   generator was trained) and keeps the best restart.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np
import torch
from torch import nn

log = logging.getLogger(__name__)

__all__ = ["Encoder", "fit_encoder", "invert_frames"]

#: generator call: (z (B, d), y (B,) int or None) → normalised frames (B, K)
GenFn = Callable[[torch.Tensor, torch.Tensor | None], torch.Tensor]


class Encoder(nn.Module):
    """``(x̂ (B, K) normalised, y (B,) int | None) → z (B, d)``."""

    def __init__(self, n_channels: int, latent_dim: int, n_labels: int = 0, hidden: int = 64):
        super().__init__()
        self.n_labels = n_labels
        self.net = nn.Sequential(nn.Linear(n_channels + n_labels, hidden), nn.LeakyReLU(0.2),
                                 nn.Linear(hidden, latent_dim))

    def forward(self, x: torch.Tensor, y: torch.Tensor | None = None) -> torch.Tensor:
        if self.n_labels:
            assert y is not None
            x = torch.cat([x, nn.functional.one_hot(y, self.n_labels).float()], dim=-1)
        return self.net(x)


def fit_encoder(gen: GenFn, latent_dim: int, n_channels: int, n_labels: int = 0, *,
                steps: int = 3000, batch: int = 256, seed: int = 0) -> Encoder:
    """Train an :class:`Encoder` on ``(G(z, y), z)`` pairs (MSE on ``z``)."""
    torch.manual_seed(seed)
    enc = Encoder(n_channels, latent_dim, n_labels)
    opt = torch.optim.Adam(enc.parameters(), lr=1e-3)
    for step in range(steps):
        z = torch.randn(batch, latent_dim)
        y = torch.randint(0, n_labels, (batch,)) if n_labels else None
        with torch.no_grad():
            x = gen(z, y)
        loss = ((enc(x, y) - z) ** 2).mean()
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        if step == steps - 1:
            log.info("encoder: %d steps, final z MSE %.4f", steps, float(loss.detach()))
    return enc.eval()


def invert_frames(gen: GenFn, frames: np.ndarray, mean: np.ndarray, std: np.ndarray, *,
                  latent_dim: int, labels: np.ndarray | None = None,
                  encoder: Encoder | None = None, steps: int = 200, restarts: int = 6,
                  prior: float = 1e-3, lr: float = 0.05, seed: int = 0,
                  channels: np.ndarray | None = None, peak: float = 0.0
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Latent vectors whose generated frames best match ``frames``.

    Parameters
    ----------
    frames : ndarray, shape (N, K), AU intensities in [0, 1]
    mean, std : (K,) the generator's normalisation
    labels : (N,) int, for a conditional generator
    channels : (K,) bool, the channels to fit (default all; e.g. the channels a second
        person's rig carries)
    peak : each channel's squared error weighted ``1 + peak·x`` (strong AUs count more, as
        in the WAE's training loss)

    Returns
    -------
    z : ndarray, shape (N, d); recon : ndarray, shape (N, K), clamped generated frames
    """
    x = torch.from_numpy(np.asarray(frames, np.float32))
    N = x.shape[0]
    mu, sd = torch.from_numpy(np.asarray(mean, np.float32)), torch.from_numpy(
        np.asarray(std, np.float32))
    y = torch.from_numpy(np.asarray(labels, np.int64)) if labels is not None else None
    g = torch.Generator().manual_seed(seed)
    starts = [torch.zeros(N, latent_dim)]
    if encoder is not None:
        with torch.no_grad():
            starts.append(encoder((x - mu) / sd, y))
    starts += [torch.randn(N, latent_dim, generator=g) for _ in range(max(0, restarts))]
    R = len(starts)
    z = torch.cat(starts).requires_grad_(True)  # (R·N, d)
    xr = x.repeat(R, 1)
    yr = y.repeat(R) if y is not None else None
    opt = torch.optim.Adam([z], lr=lr)

    keep = (torch.ones(x.shape[1]) if channels is None else
            torch.from_numpy(np.asarray(channels, np.float32)))

    w = keep * (1.0 + peak * xr)

    def err(zz: torch.Tensor) -> torch.Tensor:
        out = torch.clamp(gen(zz, yr) * sd + mu, 0.0, 1.0)
        return ((out - xr) ** 2 * w).sum(dim=1) / keep.sum(), out

    for _ in range(steps):
        e, _ = err(z)
        loss = (e + prior * (z ** 2).mean(dim=1)).sum()
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
    with torch.no_grad():
        e, out = err(z)
        best = (e + prior * (z ** 2).mean(dim=1)).view(R, N).argmin(dim=0)  # (N,)
        pick = best * N + torch.arange(N)
        return z[pick].detach().numpy().copy(), out[pick].numpy().copy()
