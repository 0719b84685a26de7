"""Turn a WAE controller's sliders so every slider end gives a distinct face.

The WAE's prior is N(0, I), so any rotation R of its latent space is the same model: the
decoder reads z_model = R·z (folded into its first layers' weights: W ← W·R) and the encoder
writes z = Rᵀ·z_model (W ← Rᵀ·W, b ← Rᵀ·b). Reconstruction, inversion error and samples do
not change; only the direction each slider moves along does. :func:`distinct_rotation` picks
R to make the weakest slider end as strong as possible and the two most alike ends as
different as possible (soft minima, in AU units, of |G(±3·eᵢ) − G(0)| over the 2d ends and of
|G(a) − G(b)| over every pair of ends), by gradient ascent on R = exp(A − Aᵀ) from the
identity. ``scripts/rotate_controller.py`` applies it to the shipped model.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import torch

if TYPE_CHECKING:
    from mimika.learn.controller import Controller

__all__ = ["distinct_rotation", "distinctness", "rotate_state"]


def _softmin(x: torch.Tensor, tau: float) -> torch.Tensor:
    return -tau * torch.logsumexp(-x / tau, dim=0)


def distinctness(c: Controller, r: torch.Tensor, end: float = 3.0, tau: float = 0.05
                 ) -> tuple[torch.Tensor, float, float]:
    """(objective, weakest end's change, closest pair of ends) for rotation ``r`` (d, d)."""
    d = c.latent_dim
    mu, sd = torch.from_numpy(c.mean), torch.from_numpy(c.std)
    z = torch.cat([end * r.T, -end * r.T, torch.zeros(1, d)])  # rows: R·(±end·eᵢ), 0
    x = torch.clamp(c._g(z) * sd + mu, 0.0, 1.0)
    ends, mid = x[:-1], x[-1]
    change = torch.linalg.norm(ends - mid, dim=1)
    i, j = torch.triu_indices(len(ends), len(ends), 1)
    pair = torch.linalg.norm(ends[i] - ends[j], dim=1)
    return (_softmin(change, tau) + _softmin(pair, tau), float(change.detach().min()),
            float(pair.detach().min()))


def distinct_rotation(c: Controller, steps: int = 400, lr: float = 0.02) -> np.ndarray:
    """The rotation (d, d) of ``c``'s latent space whose slider ends are most distinct."""
    if c.kind != "wae":
        raise ValueError("only a WAE controller can be turned (its prior is N(0, I))")
    for p in c._g.parameters():
        p.requires_grad_(False)
    a = torch.zeros(c.latent_dim, c.latent_dim, requires_grad=True)
    opt = torch.optim.Adam([a], lr=lr)
    for _ in range(steps):
        obj, _, _ = distinctness(c, torch.linalg.matrix_exp(a - a.T))
        opt.zero_grad()
        (-obj).backward()
        opt.step()
    with torch.no_grad():
        return torch.linalg.matrix_exp(a - a.T).numpy().astype(np.float64)


def rotate_state(state: dict[str, Any], r: np.ndarray) -> dict[str, Any]:
    """A WAE checkpoint whose slider vector z is ``r``ᵀ·(the old one): the same model."""
    rt = torch.from_numpy(np.asarray(r, np.float32))
    gen = dict(state["generator"])
    for k in ("lin.weight", "mlp.0.weight"):
        gen[k] = gen[k] @ rt
    enc = dict(state["encoder"])
    for k in ("lin", "mlp.4"):
        enc[f"{k}.weight"] = rt.T @ enc[f"{k}.weight"]
        enc[f"{k}.bias"] = rt.T @ enc[f"{k}.bias"]
    meta = dict(state.get("meta", {}))
    meta["slider_rotation"] = np.round(np.asarray(r, float), 6).tolist()
    return {**state, "generator": gen, "encoder": enc, "meta": meta}
