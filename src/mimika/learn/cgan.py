"""Beyond seed 001: a conditional WGAN-GP so the sliders can be asked for an emotion.

The seed names a conditional GAN with emotion labels as future work. This model keeps the
seed's latent sliders ``z ~ N(0, I)`` and adds a label embedding:

* generator ``[z (B, d), e(y) (B, E)] → Dense H LeakyReLU → Dense H LeakyReLU → Dense K``;
* critic ``[x (B, K), e'(y) (B, E)] → Dense H LeakyReLU → Dense H LeakyReLU → Dense 1``;
* WGAN-GP (Gulrajani et al. 2017): gradient penalty λ = 10 on label-matched interpolates instead
  of weight clipping, Adam (1e-4, β = 0.5, 0.9), ``n_critic`` 5;
* class-balanced batches (label uniform, frame uniform within the label), since neutral frames
  outnumber the rest several times over;
* an auxiliary classifier (AC-GAN, Odena et al. 2017) ``x (B, K) → label logits`` learns the
  labels of real frames, and the generator's loss adds ``classifier`` × its cross-entropy on
  generated frames, so a frame asked for "surprise" looks like the real surprise frames, not
  like a neutral face near the class border (the classifier is not saved).

Labels are those of :mod:`mimika.learn.gan_data` (nearest library prototype). Checkpoints have
the same layout as :mod:`mimika.learn.wgan`'s with ``kind = "cgan"`` and ``labels``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import torch
from torch import nn

from mimika.errors import ParameterError
from mimika.learn.wgan import Normaliser, _as_tensor, check_counts, downsample

log = logging.getLogger(__name__)

__all__ = ["CGANConfig", "CGANResult", "CondCritic", "CondGenerator", "cgan_state",
           "train_cgan"]

Progress = Callable[[int, int], None]


@dataclass
class CGANConfig:
    """Hyper-parameters of the conditional WGAN-GP."""

    latent_dim: int = 4
    hidden: int = 128
    embed: int = 8
    n_critic: int = 5
    iters: int = 20_000
    batch: int = 64
    lr: float = 1e-4
    betas: tuple[float, float] = (0.5, 0.9)
    gp: float = 10.0
    classifier: float = 10.0  #: weight of the auxiliary classifier loss (0: plain WGAN-GP)
    leak: float = 0.2
    eval_batch: int = 256
    seed: int = 0

    def check(self) -> CGANConfig:
        check_counts(self, "latent_dim", "hidden", "embed", "n_critic", "iters", "batch",
                     "eval_batch")
        if not self.lr > 0 or self.gp < 0 or self.classifier < 0:
            raise ParameterError(f"lr={self.lr!r} must be > 0, gp={self.gp!r} and "
                                 f"classifier={self.classifier!r} ≥ 0")
        return self


def _mlp(n_in: int, hidden: int, n_out: int, leak: float) -> nn.Sequential:
    return nn.Sequential(nn.Linear(n_in, hidden), nn.LeakyReLU(leak),
                         nn.Linear(hidden, hidden), nn.LeakyReLU(leak),
                         nn.Linear(hidden, n_out))


class CondGenerator(nn.Module):
    """``(z (B, d), y (B,) int) → normalised AU frames (B, K)``."""

    def __init__(self, latent_dim: int, n_channels: int, n_labels: int, hidden: int = 128,
                 embed: int = 8, leak: float = 0.2):
        super().__init__()
        self.latent_dim, self.n_channels, self.n_labels = latent_dim, n_channels, n_labels
        self.emb = nn.Embedding(n_labels, embed)
        self.net = _mlp(latent_dim + embed, hidden, n_channels, leak)

    def forward(self, z: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
        return self.net(torch.cat([z, self.emb(y)], dim=-1))


class CondCritic(nn.Module):
    """``(x (B, K), y (B,) int) → score (B, 1)``."""

    def __init__(self, n_channels: int, n_labels: int, hidden: int = 128, embed: int = 8,
                 leak: float = 0.2):
        super().__init__()
        self.emb = nn.Embedding(n_labels, embed)
        self.net = _mlp(n_channels + embed, hidden, 1, leak)

    def forward(self, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
        return self.net(torch.cat([x, self.emb(y)], dim=-1))


@dataclass
class CGANResult:
    generator: CondGenerator
    critic: CondCritic
    config: CGANConfig
    normaliser: Normaliser
    labels: tuple[str, ...]
    w_train: np.ndarray  # (iters,)
    w_test: np.ndarray  # (iters,)
    seconds: float
    extra: dict[str, Any] = field(default_factory=dict)


def train_cgan(train: np.ndarray, train_labels: np.ndarray, labels: Sequence[str],
               test: np.ndarray | None = None, test_labels: np.ndarray | None = None,
               config: CGANConfig | None = None, *, progress: Progress | None = None
               ) -> CGANResult:
    """Train the conditional WGAN-GP.

    Parameters
    ----------
    train : ndarray, shape (N, K), in [0, 1]; train_labels : (N,) int indices into ``labels``
    test, test_labels : held-out frames for the test W estimate (optional)
    labels : names of the label indices; every label needs at least one training frame
    """
    cfg = (config or CGANConfig()).check()
    _as_tensor(train, "train")
    norm = Normaliser.fit(train)
    xr = _as_tensor(norm.forward(train), "train")
    yr = np.asarray(train_labels, np.int64)
    L, K = len(labels), xr.shape[1]
    if yr.shape != (len(xr),) or yr.min() < 0 or yr.max() >= L:
        raise ParameterError(f"train_labels must be (N,) ints in [0, {L}), got shape {yr.shape}")
    by_label = [torch.from_numpy(np.flatnonzero(yr == i)) for i in range(L)]
    empty = [labels[i] for i, b in enumerate(by_label) if len(b) == 0]
    if empty:
        raise ParameterError(f"no training frames labelled {', '.join(empty)}")
    counts = torch.tensor([len(b) for b in by_label])
    starts = torch.cumsum(counts, 0) - counts
    order = torch.cat(by_label)  # frames grouped by label
    xt = yt = None
    if test is not None and len(test):
        xt = _as_tensor(norm.forward(test), "test", K)
        yt = torch.from_numpy(np.asarray(test_labels, np.int64))
    torch.manual_seed(cfg.seed)
    G = CondGenerator(cfg.latent_dim, K, L, cfg.hidden, cfg.embed, cfg.leak)
    C = CondCritic(K, L, cfg.hidden, cfg.embed, cfg.leak)
    Q = _mlp(K, cfg.hidden, L, cfg.leak)  # auxiliary classifier: frame → label logits
    og = torch.optim.Adam(G.parameters(), lr=cfg.lr, betas=cfg.betas)
    oc = torch.optim.Adam(C.parameters(), lr=cfg.lr, betas=cfg.betas)
    oq = torch.optim.Adam(Q.parameters(), lr=cfg.lr, betas=cfg.betas)
    ce = nn.functional.cross_entropy
    gen = torch.Generator().manual_seed(cfg.seed)
    B, d, E = cfg.batch, cfg.latent_dim, cfg.eval_batch

    def real_batch(n: int) -> tuple[torch.Tensor, torch.Tensor]:
        y = torch.randint(0, L, (n,), generator=gen)
        j = (torch.rand(n, generator=gen) * counts[y]).long()
        return xr[order[starts[y] + j]], y

    hist = torch.full((cfg.iters, 2), float("nan"))
    every = max(1, cfg.iters // 100)
    t0 = time.perf_counter()
    for it in range(cfg.iters):
        for _ in range(cfg.n_critic):
            x, y = real_batch(B)
            with torch.no_grad():
                f = G(torch.randn(B, d, generator=gen), y)
            a = torch.rand(B, 1, generator=gen)
            xi = (a * x + (1 - a) * f).requires_grad_(True)
            gi, = torch.autograd.grad(C(xi, y).sum(), xi, create_graph=True)
            penalty = ((gi.norm(dim=1) - 1.0) ** 2).mean()
            loss = C(f, y).mean() - C(x, y).mean() + cfg.gp * penalty
            oc.zero_grad(set_to_none=True)
            loss.backward()
            oc.step()
        if cfg.classifier > 0:  # the classifier learns the labels of real frames
            x, y = real_batch(B)
            oq.zero_grad(set_to_none=True)
            ce(Q(x), y).backward()
            oq.step()
        y = torch.randint(0, L, (B,), generator=gen)
        f = G(torch.randn(B, d, generator=gen), y)
        gl = -C(f, y).mean()
        if cfg.classifier > 0:  # AC-GAN: generated frames should be classified as asked
            gl = gl + cfg.classifier * ce(Q(f), y)
        og.zero_grad(set_to_none=True)
        gl.backward()
        og.step()
        with torch.no_grad():
            x, y = real_batch(E)
            fe = C(G(torch.randn(E, d, generator=gen), y), y).mean()
            hist[it, 0] = C(x, y).mean() - fe
            if xt is not None:
                j = torch.randint(0, len(xt), (E,), generator=gen)
                yj = yt[j]
                hist[it, 1] = C(xt[j], yj).mean() - C(G(torch.randn(E, d, generator=gen), yj),
                                                       yj).mean()
        if progress and ((it + 1) % every == 0 or it + 1 == cfg.iters):
            progress(it + 1, cfg.iters)
    secs = time.perf_counter() - t0
    h = hist.numpy()
    log.info("cGAN d=%d: %d iterations in %.1f s; final W train %.4f%s", d, cfg.iters, secs,
             float(np.mean(h[-100:, 0])),
             "" if xt is None else f" test {float(np.mean(h[-100:, 1])):.4f}")
    return CGANResult(G.eval(), C.eval(), cfg, norm, tuple(labels), h[:, 0].copy(),
                      h[:, 1].copy(), secs)


def cgan_state(res: CGANResult, *, channels: tuple[str, ...], fps: float,
               meta: dict[str, Any] | None = None) -> dict[str, Any]:
    """The checkpoint dict of a trained conditional WGAN-GP."""
    cfg = asdict(res.config)
    cfg["betas"] = list(cfg["betas"])
    return {
        "kind": "cgan",
        "config": cfg,
        "generator": {k: v.clone() for k, v in res.generator.state_dict().items()},
        "critic": {k: v.clone() for k, v in res.critic.state_dict().items()},
        "channels": list(channels),
        "fps": float(fps),
        "mean": torch.from_numpy(res.normaliser.mean.copy()),
        "std": torch.from_numpy(res.normaliser.std.copy()),
        "labels": list(res.labels),
        "history": {"w_train": torch.from_numpy(downsample(res.w_train)),
                    "w_test": torch.from_numpy(downsample(res.w_test)),
                    "iters": len(res.w_train), "seconds": float(res.seconds)},
        "meta": dict(meta or {}),
    }
