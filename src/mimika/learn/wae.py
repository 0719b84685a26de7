"""The default latent-slider controller: a Wasserstein auto-encoder (WAE-MMD) on AU frames.

Seed 001's WGAN (:mod:`mimika.learn.wgan`) finds sliders bottom-up, but its 64-unit generator,
trained by a weight-clipped critic alone, covers the data loosely: held-out frames put on its
sliders lose their strong AUs, and a linear PCA of the same size reconstructs them nearly as
well. This model keeps the sliders (``z ~ N(0, I)``, ``d`` of them) and the Wasserstein view —
a WAE (Tolstikhin et al. 2018) minimises a Wasserstein distance between the data and the model
through an encoder — and trains the encoder inversion needs together with the generator:

* decoder / generator ``G(z) = clamp(A z + b + MLP(z), 0, 1)`` and encoder
  ``E(x) = C x + c + MLP(x)`` (two hidden layers, LeakyReLU) — the linear parts start at the
  whitened PCA of the training frames, the MLPs at zero, so training starts from PCA and only
  improves on it;
* reconstruction ``‖G(E(x)) − x‖²`` weighted ``1 + peak·x`` per AU (strong AUs count more),
  plus ``mmd`` × MMD(E(x), N(0, I)) with the inverse multiquadric kernel: the encoded frames
  fill the sliders' prior, so slider settings land where the data are.
* a share ``knowledge`` of each batch is drawn from FACS frames
  (:mod:`mimika.learn.facs_frames`: every AU alone, the expression library, sparse mixes,
  training frames with one more AU — through the AU Blender), so the sliders also reach
  actions and combinations the recordings never show.

A WGAN-GP critic on decoded prior samples (the seed's adversarial objective on top) was tried
and left out: at weights 0.05 / 0.5 it moved prior samples no closer to real frames (mean
nearest-frame distance 0.162 / 0.159 vs 0.169), made held-out inversion worse (RMSE 0.015 /
0.019 vs 0.012) and training 2–5× slower (docs/controller.md).

Frames are the raw neutral-relative AU intensities in [0, 1] (no z-score: the checkpoint keeps
mean 0, std 1 so :class:`~mimika.learn.controller.Controller` treats it as the other kinds).
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import torch
from torch import nn

from mimika.errors import ParameterError
from mimika.learn.data import MODEL_CHANNELS
from mimika.learn.facs_frames import facs_frames
from mimika.learn.wgan import _as_tensor, check_counts, downsample

log = logging.getLogger(__name__)

__all__ = ["WAEConfig", "WAEDecoder", "WAEEncoder", "train_from_takes", "train_wae",
           "wae_state"]

Progress = Callable[[int, int], None]


@dataclass
class WAEConfig:
    """Hyper-parameters (the shipped controller's recipe)."""

    latent_dim: int = 6
    hidden: int = 128
    iters: int = 10_000
    batch: int = 256
    lr: float = 1e-3
    peak: float = 4.0  #: reconstruction weight 1 + peak·x per AU
    mmd: float = 1.0  #: weight of MMD(E(x), N(0, I))
    knowledge: float = 0.25  #: share of each batch drawn from FACS frames (facs_frames)
    leak: float = 0.2
    seed: int = 0

    def check(self) -> WAEConfig:
        check_counts(self, "latent_dim", "hidden", "iters", "batch")
        if not self.lr > 0 or min(self.peak, self.mmd) < 0 or not 0 <= self.knowledge < 1:
            raise ParameterError(f"lr={self.lr!r} must be > 0, peak={self.peak!r} and "
                                 f"mmd={self.mmd!r} ≥ 0, knowledge={self.knowledge!r} in [0, 1)")
        return self


class _Residual(nn.Module):
    """``x → W x + b + MLP(x)``; the MLP's last layer starts at zero."""

    def __init__(self, n_in: int, n_out: int, hidden: int, leak: float):
        super().__init__()
        self.lin = nn.Linear(n_in, n_out)
        self.mlp = nn.Sequential(nn.Linear(n_in, hidden), nn.LeakyReLU(leak),
                                 nn.Linear(hidden, hidden), nn.LeakyReLU(leak),
                                 nn.Linear(hidden, n_out))
        nn.init.zeros_(self.mlp[-1].weight)
        nn.init.zeros_(self.mlp[-1].bias)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.lin(x) + self.mlp(x)


class WAEDecoder(_Residual):
    """``z (B, d) → AU frames (B, K)`` (not clamped; the controller clamps to [0, 1])."""

    def __init__(self, latent_dim: int, n_channels: int, hidden: int = 128, leak: float = 0.2):
        super().__init__(latent_dim, n_channels, hidden, leak)


class WAEEncoder(_Residual):
    """``(x (B, K), y=None) → z (B, d)`` (the signature of :class:`inversion.Encoder`)."""

    def __init__(self, n_channels: int, latent_dim: int, hidden: int = 128, leak: float = 0.2):
        super().__init__(n_channels, latent_dim, hidden, leak)

    def forward(self, x: torch.Tensor, y: torch.Tensor | None = None) -> torch.Tensor:
        return super().forward(x)


def _pca_init(enc: WAEEncoder, dec: WAEDecoder, x: np.ndarray) -> None:
    """Linear parts = the whitened PCA of ``x``: E(x) = scores / σ, G(z) = μ + V σ z."""
    d = dec.lin.in_features
    mu = x.mean(0)
    _, s, vt = np.linalg.svd(x - mu, full_matrices=False)
    V = vt[:d]  # (d, K)
    sd = np.maximum(s[:d] / np.sqrt(len(x)), 1e-4)
    with torch.no_grad():
        enc.lin.weight.copy_(torch.from_numpy((V / sd[:, None]).astype(np.float32)))
        enc.lin.bias.copy_(torch.from_numpy((-(V @ mu) / sd).astype(np.float32)))
        dec.lin.weight.copy_(torch.from_numpy((V.T * sd).astype(np.float32)))
        dec.lin.bias.copy_(torch.from_numpy(mu.astype(np.float32)))


def _mmd(z: torch.Tensor, p: torch.Tensor) -> torch.Tensor:
    """MMD with the inverse multiquadric kernel k = C / (C + ‖a − b‖²), C = 2d (WAE-MMD)."""
    c = 2.0 * z.shape[1]

    def k(a, b):
        return (c / (c + torch.cdist(a, b) ** 2)).mean()

    return k(z, z) + k(p, p) - 2 * k(z, p)


@dataclass
class WAEResult:
    encoder: WAEEncoder
    decoder: WAEDecoder
    config: WAEConfig
    history: dict[str, np.ndarray]
    seconds: float


def train_wae(train: np.ndarray, config: WAEConfig | None = None, *,
              channels: Sequence[str] = MODEL_CHANNELS,
              progress: Progress | None = None) -> WAEResult:
    """Train on AU frames ``train`` (N, K) in [0, 1] over ``channels``; see the module
    docstring."""
    cfg = (config or WAEConfig()).check()
    x = _as_tensor(train, "train")
    n, K = x.shape
    if n <= cfg.latent_dim:
        raise ParameterError(f"{n} frames cannot fit {cfg.latent_dim} sliders")
    n_known = round(cfg.batch * cfg.knowledge)
    if n_known:
        if len(channels) != K:
            raise ParameterError(f"{K} channels in the frames, {len(channels)} named")
        known = torch.from_numpy(facs_frames(channels=channels, seed=cfg.seed, base=train))
    torch.manual_seed(cfg.seed)
    enc = WAEEncoder(K, cfg.latent_dim, cfg.hidden, cfg.leak)
    dec = WAEDecoder(cfg.latent_dim, K, cfg.hidden, cfg.leak)
    _pca_init(enc, dec, np.asarray(train, np.float64))
    opt = torch.optim.Adam([*enc.parameters(), *dec.parameters()], lr=cfg.lr)
    sched = torch.optim.lr_scheduler.StepLR(opt, step_size=max(1, cfg.iters // 3), gamma=0.3)
    gen = torch.Generator().manual_seed(cfg.seed)
    hist = np.zeros((cfg.iters, 2), np.float32)  # reconstruction, MMD
    every = max(1, cfg.iters // 100)
    t0 = time.perf_counter()
    for it in range(cfg.iters):
        real = x[torch.randint(0, n, (cfg.batch - n_known,), generator=gen)]
        if n_known:
            real = torch.cat([real, known[torch.randint(0, len(known), (n_known,),
                                                         generator=gen)]])
        z = enc(real)
        rec = ((dec(z).clamp(0, 1) - real) ** 2 * (1 + cfg.peak * real)).mean()
        mmd = _mmd(z, torch.randn(cfg.batch, cfg.latent_dim, generator=gen))
        loss = rec + cfg.mmd * mmd
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        sched.step()
        hist[it] = float(rec.detach()), float(mmd.detach())
        if progress and ((it + 1) % every == 0 or it + 1 == cfg.iters):
            progress(it + 1, cfg.iters)
    secs = time.perf_counter() - t0
    log.info("WAE d=%d: %d iterations in %.1f s; reconstruction %.5f, MMD %.4f", cfg.latent_dim,
             cfg.iters, secs, float(hist[-100:, 0].mean()), float(hist[-100:, 1].mean()))
    return WAEResult(enc.eval(), dec.eval(), cfg,
                     {"reconstruction": hist[:, 0], "mmd": hist[:, 1]}, secs)


def wae_state(res: WAEResult, *, channels: tuple[str, ...], fps: float,
              meta: dict[str, Any] | None = None) -> dict[str, Any]:
    """The checkpoint dict (the layout of :func:`mimika.learn.wgan.wgan_state`)."""
    K = len(channels)
    return {
        "kind": "wae",
        "config": asdict(res.config),
        "generator": {k: v.clone() for k, v in res.decoder.state_dict().items()},
        "encoder": {k: v.clone() for k, v in res.encoder.state_dict().items()},
        "channels": list(channels),
        "fps": float(fps),
        "mean": torch.zeros(K),
        "std": torch.ones(K),
        "labels": [],
        "history": {k: torch.from_numpy(downsample(v)) for k, v in res.history.items()}
        | {"iters": res.config.iters, "seconds": float(res.seconds)},
        "meta": dict(meta or {}),
    }


def train_from_takes(data: str | os.PathLike | None = None, *, latent_dim: int = 6,
                     iters: int | None = None, test_takes: Sequence[str] = (), seed: int = 0,
                     progress: Progress | None = None, turn_sliders: bool = True
                     ) -> tuple[dict[str, Any], WAEResult]:
    """Train the controller on a folder of takes (default ``$MIMIKA_MOTION_DIR``; frames as
    :func:`mimika.learn.gan_data.load_frames` prepares them), holding out ``test_takes``, and
    turn its sliders for distinct ends (:mod:`mimika.learn.sliders`); returns ``(checkpoint
    dict, result)`` — save it with :func:`mimika.learn.wgan.save_checkpoint`."""
    from mimika.learn.gan_data import load_frames

    fs = load_frames(data)
    train = fs.split(list(test_takes))[0] if test_takes else fs
    cfg = WAEConfig(latent_dim=latent_dim, seed=seed)
    if iters is not None:
        cfg.iters = iters
    res = train_wae(train.values, cfg, channels=fs.channels, progress=progress)
    meta = {"data": str(fs.meta.get("folder", "")), "train_takes": sorted(
        {fs.takes[i] for i in np.unique(train.take)}), "test_takes": list(test_takes),
        "train_frames": len(train), "preprocessing": "fold to 20 bilateral face AUs; subtract "
        "per-take median frame; clip to [0, 1]"}
    state = wae_state(res, channels=fs.channels, fps=fs.fps, meta=meta)
    if turn_sliders:  # the same model, its slider ends as distinct as they go
        from mimika.learn.controller import Controller
        from mimika.learn.sliders import distinct_rotation, rotate_state

        state = rotate_state(state, distinct_rotation(Controller(state)))
    return state, res
