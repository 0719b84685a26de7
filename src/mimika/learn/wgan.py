"""Seed 001's WGAN (weight clipping), faithfully: a latent-slider generator of AU frames.

Generator ``z (B, d) → Dense 64 LeakyReLU → Dense K linear``; critic
``x (B, K) → Dense 64 LeakyReLU → Dense 1 linear``; ``z ~ N(0, I)``; RMSProp (Keras
semantics: ρ = 0.9, ε = 1e-7) with learning rate 5e-5; critic weights clipped to ±0.01 after
every critic step; batch 64; ``n_critic`` critic steps per generator step; 50 000 generator
iterations. Dense layers use Keras' defaults (Glorot-uniform weights, zero biases).

Data are z-scored with the training selection's mean/std, which the checkpoint keeps, so
``x = G(z)·σ + μ`` (then clamped to [0, 1] and passed through the AU Blender by
:class:`mimika.learn.controller.Controller`).

The critic update is the hot loop (1 M steps for 50 000 iterations at ``n_critic`` 20); it runs
with hand-written gradients on one flat parameter buffer (forward, backward, RMSProp and
clipping in ~15 tensor operations), checked against autograd in the tests.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from mimika.errors import DataError, ParameterError

log = logging.getLogger(__name__)

__all__ = ["Critic", "Generator", "Normaliser", "TrainResult", "WGANConfig", "load_checkpoint",
           "save_checkpoint", "train_wgan"]

Progress = Callable[[int, int], None]
CHECKPOINT_VERSION = 1


def check_counts(config: Any, *names: str) -> None:
    """Raise a ParameterError unless each of ``config``'s fields ``names`` is an int ≥ 1."""
    for name in names:
        v = getattr(config, name)
        if not isinstance(v, int) or v < 1:
            raise ParameterError(f"{name}={v!r} must be an integer ≥ 1")


@dataclass
class WGANConfig:
    """Hyper-parameters (seed 001 defaults; ``n_critic`` 20 is the seed's final choice)."""

    latent_dim: int = 4
    hidden: int = 64
    n_critic: int = 20
    iters: int = 50_000
    batch: int = 64
    lr: float = 5e-5
    clip: float = 0.01
    rho: float = 0.9  # Keras RMSprop decay
    eps: float = 1e-7  # Keras RMSprop epsilon
    leak: float = 0.2  # LeakyReLU negative slope
    eval_batch: int = 256  # frames per W estimate (train, test and generated)
    seed: int = 0
    critic_seed: int = 1  # critic init: same for every latent_dim (sweep: critic held identical)

    def check(self) -> WGANConfig:
        check_counts(self, "latent_dim", "hidden", "n_critic", "iters", "batch", "eval_batch")
        for name in ("lr", "clip"):
            if not getattr(self, name) > 0:
                raise ParameterError(f"{name}={getattr(self, name)!r} must be > 0")
        return self


def _glorot(layer: nn.Linear, gen: torch.Generator) -> None:
    fan_out, fan_in = layer.weight.shape
    a = math.sqrt(6.0 / (fan_in + fan_out))
    with torch.no_grad():
        layer.weight.uniform_(-a, a, generator=gen)
        layer.bias.zero_()


class Generator(nn.Module):
    """``z (B, d) → Dense hidden LeakyReLU → Dense K`` (normalised AU frames (B, K))."""

    def __init__(self, latent_dim: int, n_channels: int, hidden: int = 64, leak: float = 0.2,
                 *, seed: int = 0):
        super().__init__()
        self.latent_dim, self.n_channels, self.leak = latent_dim, n_channels, leak
        self.l1 = nn.Linear(latent_dim, hidden)
        self.l2 = nn.Linear(hidden, n_channels)
        g = torch.Generator().manual_seed(seed)
        _glorot(self.l1, g)
        _glorot(self.l2, g)

    def forward(self, z: torch.Tensor) -> torch.Tensor:
        return self.l2(nn.functional.leaky_relu(self.l1(z), self.leak))  # (B, K)


class Critic(nn.Module):
    """``x (B, K) → Dense hidden LeakyReLU → Dense 1``; parameters live in one flat buffer.

    ``flat`` = [W1 (hidden·K), b1 (hidden), w2 (hidden), b2 (1)]; ``W1``, ``b1``, ``w2``,
    ``b2`` are views.
    """

    def __init__(self, n_channels: int, hidden: int = 64, leak: float = 0.2, *, seed: int = 1):
        super().__init__()
        self.n_channels, self.hidden, self.leak = n_channels, hidden, leak
        self.sizes = (hidden * n_channels, hidden, hidden, 1)
        self.flat = nn.Parameter(torch.zeros(sum(self.sizes)))
        g = torch.Generator().manual_seed(seed)
        a1 = math.sqrt(6.0 / (n_channels + hidden))
        a2 = math.sqrt(6.0 / (hidden + 1))
        with torch.no_grad():
            self.W1.uniform_(-a1, a1, generator=g)
            self.w2.uniform_(-a2, a2, generator=g)

    def _views(self, t: torch.Tensor) -> tuple[torch.Tensor, ...]:
        W1, b1, w2, b2 = torch.split(t, self.sizes)
        return W1.view(self.hidden, self.n_channels), b1, w2.view(self.hidden, 1), b2

    @property
    def W1(self) -> torch.Tensor:
        return self._views(self.flat)[0]

    @property
    def w2(self) -> torch.Tensor:
        return self._views(self.flat)[2]

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        W1, b1, w2, b2 = self._views(self.flat)
        h = nn.functional.leaky_relu(torch.addmm(b1, x, W1.t()), self.leak)
        return h @ w2 + b2  # (B, 1)


class _CriticTrainer:
    """Manual-gradient RMSProp + clipping steps on a :class:`Critic`'s flat buffer."""

    def __init__(self, critic: Critic, cfg: WGANConfig):
        self.c, self.cfg = critic, cfg
        B = cfg.batch
        self.flat = critic.flat.data
        self.W1, self.b1, self.w2, _ = critic._views(self.flat)
        self.g = torch.zeros_like(self.flat)
        self.gW1, self.gb1, self.gw2, self.gb2 = critic._views(self.g)
        self.v = torch.zeros_like(self.flat)
        self.tmp = torch.empty_like(self.flat)
        # loss = mean C(fake) − mean C(real) (the critic minimises it; −loss is the W estimate)
        self.sign = torch.cat([torch.full((B, 1), -1.0 / B), torch.full((B, 1), 1.0 / B)])
        self.xb = torch.empty(2 * B, critic.n_channels)

    def gradient(self, real: torch.Tensor, fake: torch.Tensor) -> None:
        """Fill ``self.g`` with d loss / d flat for one batch (real (B, K), fake (B, K))."""
        B, leak = self.cfg.batch, self.c.leak
        self.xb[:B] = real
        self.xb[B:] = fake
        h = torch.addmm(self.b1, self.xb, self.W1.t())  # (2B, H)
        slope = torch.where(h > 0, 1.0, leak)
        torch.mm((h * slope).t(), self.sign, out=self.gw2)  # (H, 1)
        self.gb2.zero_()  # d loss / d b2 = Σ sign = 0
        dh = self.sign * self.w2.t() * slope  # (2B, H)
        torch.mm(dh.t(), self.xb, out=self.gW1)  # (H, K)
        torch.sum(dh, 0, out=self.gb1)

    def step(self, real: torch.Tensor, fake: torch.Tensor) -> None:
        cfg = self.cfg
        self.gradient(real, fake)
        self.v.mul_(cfg.rho).addcmul_(self.g, self.g, value=1.0 - cfg.rho)
        torch.sqrt(self.v, out=self.tmp).add_(cfg.eps)
        self.flat.addcdiv_(self.g, self.tmp, value=-cfg.lr)
        self.flat.clamp_(-cfg.clip, cfg.clip)


@dataclass
class Normaliser:
    """Per-channel z-score: ``(x − mean) / std``; ``std`` floored at 1e-3."""

    mean: np.ndarray
    std: np.ndarray

    @classmethod
    def fit(cls, values: np.ndarray) -> Normaliser:
        v = np.asarray(values, np.float32)
        return cls(v.mean(0), np.maximum(v.std(0), 1e-3).astype(np.float32))

    def forward(self, values: np.ndarray) -> np.ndarray:
        return ((np.asarray(values, np.float32) - self.mean) / self.std).astype(np.float32)

    def inverse(self, values: np.ndarray) -> np.ndarray:
        return (np.asarray(values, np.float32) * self.std + self.mean).astype(np.float32)


@dataclass
class TrainResult:
    """A trained WGAN and its curves (one W estimate per generator iteration)."""

    generator: Generator
    critic: Critic
    config: WGANConfig
    normaliser: Normaliser
    w_train: np.ndarray  # (iters,) mean C(train) − mean C(G(z))
    w_test: np.ndarray  # (iters,) mean C(test) − mean C(G(z)); NaN without test data
    seconds: float
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def iters_per_second(self) -> float:
        return len(self.w_train) / max(self.seconds, 1e-9)


def _as_tensor(values: np.ndarray, what: str, k: int | None = None) -> torch.Tensor:
    v = np.asarray(values, np.float32)
    if v.ndim != 2 or (k is not None and v.shape[1] != k) or len(v) == 0:
        raise ParameterError(f"{what} must have shape (N ≥ 1, {k or 'K'}), got {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ParameterError(f"{what} contains NaN or infinity")
    return torch.from_numpy(np.ascontiguousarray(v))


def train_wgan(train: np.ndarray, test: np.ndarray | None = None,
               config: WGANConfig | None = None, *, normaliser: Normaliser | None = None,
               progress: Progress | None = None) -> TrainResult:
    """Train seed 001's WGAN on AU frames.

    Parameters
    ----------
    train : ndarray, shape (N, K), in [0, 1] — training frames (raw AU intensities)
    test : ndarray, shape (M, K), optional — held-out frames for the test W estimate
    normaliser : z-score to use (default: fitted on ``train``)
    progress : ``progress(done, total)`` callback, called every 1 % of iterations
    """
    cfg = (config or WGANConfig()).check()
    _as_tensor(train, "train")
    norm = normaliser or Normaliser.fit(train)
    xr = _as_tensor(norm.forward(train), "train")
    K = xr.shape[1]
    xt = _as_tensor(norm.forward(test), "test", K) if test is not None and len(test) else None
    G = Generator(cfg.latent_dim, K, cfg.hidden, cfg.leak, seed=cfg.seed)
    C = Critic(K, cfg.hidden, cfg.leak, seed=cfg.critic_seed)
    trainer = _CriticTrainer(C, cfg)
    opt = torch.optim.RMSprop(G.parameters(), lr=cfg.lr, alpha=cfg.rho, eps=cfg.eps)
    gen = torch.Generator().manual_seed(cfg.seed)
    B, n_c, E = cfg.batch, cfg.n_critic, cfg.eval_batch
    hist = torch.full((cfg.iters, 2), float("nan"))
    w_eval = torch.cat([torch.full((E, 1), 1.0 / E), torch.full((E, 1), -1.0 / E)])
    every = max(1, cfg.iters // 100)
    t0 = time.perf_counter()
    for it in range(cfg.iters):
        idx = torch.randint(0, len(xr), (n_c, B), generator=gen)
        reals = xr[idx]  # (n_critic, B, K)
        with torch.no_grad():
            fakes = G(torch.randn(n_c, B, cfg.latent_dim, generator=gen))  # G fixed meanwhile
        for k in range(n_c):
            trainer.step(reals[k], fakes[k])
        # generator step: maximise mean C(G(z))
        fake = G(torch.randn(B, cfg.latent_dim, generator=gen))
        loss = -_critic_forward(C, fake).mean()
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        with torch.no_grad():  # W estimates with the current critic and generator
            fe = _critic_forward(C, G(torch.randn(E, cfg.latent_dim, generator=gen)))
            re = _critic_forward(C, xr[torch.randint(0, len(xr), (E,), generator=gen)])
            hist[it, 0] = (torch.cat([re, fe]) * w_eval).sum()
            if xt is not None:
                te = _critic_forward(C, xt[torch.randint(0, len(xt), (E,), generator=gen)])
                hist[it, 1] = (torch.cat([te, fe]) * w_eval).sum()
        if progress and ((it + 1) % every == 0 or it + 1 == cfg.iters):
            progress(it + 1, cfg.iters)
    secs = time.perf_counter() - t0
    h = hist.numpy()
    log.info("WGAN d=%d n_critic=%d: %d iterations in %.1f s (%.1f it/s); final W train %.4f, "
             "test %.4f", cfg.latent_dim, n_c, cfg.iters, secs, cfg.iters / secs,
             float(np.mean(h[-100:, 0])), float(np.mean(h[-100:, 1])))
    return TrainResult(G.eval(), C.eval(), cfg, norm, h[:, 0].copy(), h[:, 1].copy(), secs)


def _critic_forward(C: Critic, x: torch.Tensor) -> torch.Tensor:
    """The critic with its parameters treated as constants: (B, K) → (B, 1)."""
    W1, b1, w2, b2 = C._views(C.flat.detach())
    return nn.functional.leaky_relu(torch.addmm(b1, x, W1.t()), C.leak) @ w2 + b2


# -- checkpoints --------------------------------------------------------------------------------
def downsample(curve: np.ndarray, n: int = 1000) -> np.ndarray:
    """Window means of ``curve`` to at most ``n`` points (for checkpoints and plots)."""
    c = np.asarray(curve, np.float32)
    if len(c) <= n:
        return c
    w = math.ceil(len(c) / n)
    pad = (-len(c)) % w
    c2 = np.concatenate([c, np.full(pad, np.nan, np.float32)])
    return np.nanmean(c2.reshape(-1, w), axis=1).astype(np.float32)


def save_checkpoint(path: str | Path, state: dict[str, Any]) -> Path:
    """Write a checkpoint dict atomically (``torch.save``; tensors, numbers, strings, lists)."""
    from mimika.io.atomic import atomic_open

    p = Path(path)
    state = {"version": CHECKPOINT_VERSION, **state}
    with atomic_open(p) as f:
        torch.save(state, f)
    log.info("wrote %s (%d bytes)", p, p.stat().st_size)
    return p


def load_checkpoint(path: str | Path) -> dict[str, Any]:
    """Read a checkpoint written by :func:`save_checkpoint` (``weights_only`` — no code runs)."""
    p = Path(path)
    if not p.is_file():
        raise DataError(f"model file {p} does not exist (train one with 'mimika train gan')")
    try:
        state = torch.load(p, map_location="cpu", weights_only=True)
    except Exception as e:
        raise DataError(f"{p} is not a mimika GAN checkpoint: {e}") from None
    if not isinstance(state, dict) or "kind" not in state or "generator" not in state:
        raise DataError(f"{p} is not a mimika GAN checkpoint (no 'kind'/'generator')")
    if state.get("version", 0) > CHECKPOINT_VERSION:
        raise DataError(f"{p}: checkpoint version {state['version']} is newer than this mimika "
                        f"({CHECKPOINT_VERSION}); upgrade mimika")
    return state


def wgan_state(res: TrainResult, *, channels: tuple[str, ...], fps: float,
               meta: dict[str, Any] | None = None) -> dict[str, Any]:
    """The checkpoint dict of a trained unconditional WGAN."""
    return {
        "kind": "wgan",
        "config": asdict(res.config),
        "generator": {k: v.clone() for k, v in res.generator.state_dict().items()},
        "critic": {k: v.clone() for k, v in res.critic.state_dict().items()},
        "channels": list(channels),
        "fps": float(fps),
        "mean": torch.from_numpy(res.normaliser.mean.copy()),
        "std": torch.from_numpy(res.normaliser.std.copy()),
        "labels": [],
        "history": {"w_train": torch.from_numpy(downsample(res.w_train)),
                    "w_test": torch.from_numpy(downsample(res.w_test)),
                    "iters": len(res.w_train), "seconds": float(res.seconds)},
        "meta": dict(meta or {}),
    }
