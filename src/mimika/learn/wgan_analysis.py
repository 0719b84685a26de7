"""Seed 001's analysis of the WGAN controller, as functions over trained models and curves.

* W curves — train and test Wasserstein estimates per generator iteration (they converge
  together unless the model overfits); :func:`overfit_demo` trains on 10 frames to show the
  divergence;
* :func:`latent_sweep` — the latent-dimension sweep with the critic held identical (same
  architecture and initial weights for every ``d``), scored by :func:`p98_last`, the 98th
  percentile of the last 100 W estimates;
* :func:`nn_label_histogram` — 1 000 samples, nearest neighbour in held-out real frames, the
  histogram of the neighbours' labels;
* :func:`self_match_rate` — for the conditional model: N samples per label classified by the
  nearest held-out real frame (and by the labelling prototypes);
* :func:`inversion_error` — how well real frames fit on the sliders;
* ``plot_*`` — the figures (matplotlib, imported only there).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from mimika.learn.gan_data import LABELS, FrameSet, nn_labels, prototype_labels
from mimika.learn.wgan import TrainResult, WGANConfig, downsample, train_wgan

log = logging.getLogger(__name__)

__all__ = ["inversion_error", "latent_sweep", "nn_label_histogram", "overfit_demo",
           "p98_last", "plot_histograms", "plot_sweep", "plot_w_curves", "self_match_rate"]


def p98_last(w: np.ndarray, n: int = 100) -> float:
    """The seed's sweep error: 98th percentile of the last ``n`` W estimates."""
    w = np.asarray(w, np.float64)
    return float(np.percentile(w[-n:], 98))


def overfit_demo(train: FrameSet, test: FrameSet, config: WGANConfig, *, n_frames: int = 10,
                 seed: int = 0) -> TrainResult:
    """Train on only ``n_frames`` random training frames (test W estimated on all of ``test``).

    The normalisation is the full training set's, so curves are comparable with a normal run.
    """
    from mimika.learn.wgan import Normaliser

    rng = np.random.default_rng(seed)
    pick = rng.choice(len(train), n_frames, replace=False)
    return train_wgan(train.values[pick], test.values, config,
                      normaliser=Normaliser.fit(train.values))


def latent_sweep(train: np.ndarray, test: np.ndarray | None, dims: Sequence[int],
                 config: WGANConfig, *, progress: Callable[[int, int], None] | None = None
                 ) -> dict[int, dict[str, Any]]:
    """Train one WGAN per latent dimension; the critic is identical (architecture and init).

    Returns ``{d: {"p98_train", "p98_test", "w_train", "w_test" (downsampled), "seconds"}}``.
    """
    out: dict[int, dict[str, Any]] = {}
    for i, d in enumerate(dims):
        res = train_wgan(train, test, replace(config, latent_dim=int(d)))
        out[int(d)] = {"p98_train": p98_last(res.w_train), "p98_test": p98_last(res.w_test),
                       "w_train": downsample(res.w_train, 500),
                       "w_test": downsample(res.w_test, 500), "seconds": res.seconds}
        log.info("sweep d=%d: p98 train %.5f test %.5f", d, out[int(d)]["p98_train"],
                 out[int(d)]["p98_test"])
        if progress:
            progress(i + 1, len(dims))
    return out


def nn_label_histogram(samples: np.ndarray, reference: FrameSet) -> dict[str, float]:
    """Fractions of each label among the samples' nearest neighbours in ``reference``."""
    lab = nn_labels(samples, reference)
    c = np.bincount(lab, minlength=len(LABELS)) / max(len(lab), 1)
    return {name: float(f) for name, f in zip(LABELS, c, strict=True)}


def self_match_rate(controller: Any, reference: FrameSet, *, n: int = 1000,
                    seed: int = 0, real: FrameSet | None = None) -> dict[str, Any]:
    """Generate ``n`` frames per label; classify each by (a) its nearest held-out real frame's
    label and (b) the labelling prototypes. Returns overall and per-label match rates and the
    confusion matrix of (a) (rows: asked label, columns: found label, over :data:`LABELS`).

    ``real`` (e.g. the training frames) adds ``real_nn``: the rate (a) of real frames of each
    label — what real faces score on this test, its practical ceiling.
    """
    per_nn, per_proto, conf = {}, {}, []
    for i, lab in enumerate(controller.labels):
        _, x = controller.random(n, label=lab, seed=seed + i)
        nn = nn_labels(x, reference)
        pr = prototype_labels(x, controller.channels)
        k = LABELS.index(lab)
        per_nn[lab] = float(np.mean(nn == k))
        per_proto[lab] = float(np.mean(pr == k))
        conf.append(np.bincount(nn, minlength=len(LABELS)).tolist())
    present = [lab for lab in controller.labels if reference.label_counts().get(lab, 0) > 0]
    out: dict[str, Any] = {}
    if real is not None:
        found = nn_labels(real.values, reference)
        out["real_nn"] = {lab: float(np.mean(found[real.labels == LABELS.index(lab)]
                                             == LABELS.index(lab)))
                          for lab in present if np.any(real.labels == LABELS.index(lab))}
        out["real_nn_mean"] = float(np.mean(list(out["real_nn"].values())))
    return out | {"nn": float(np.mean([per_nn[lab] for lab in present])),
            "prototype": float(np.mean(list(per_proto.values()))),
            "per_label_nn": per_nn, "per_label_prototype": per_proto,
            "confusion_nn": conf, "n_per_label": n, "labels_in_reference": present}


def inversion_error(controller: Any, frames: np.ndarray, *, steps: int = 200,
                    restarts: int = 6) -> dict[str, float]:
    """Reconstruction error of real frames put on the sliders (AU units, [0, 1] scale).

    Returns RMSE and mean absolute error over all channels, the mean per-frame maximum
    absolute error, and for comparison the RMSE of the all-zero (neutral) and mean frames.
    """
    x = np.asarray(frames, np.float32)
    _, rec = controller.invert_batch(x, steps=steps, restarts=restarts)
    e = rec - x
    return {"frames": len(x), "rmse": float(np.sqrt(np.mean(e ** 2))),
            "mae": float(np.mean(np.abs(e))),
            "max_abs_mean": float(np.mean(np.abs(e).max(axis=1))),
            "rmse_neutral": float(np.sqrt(np.mean(x ** 2))),
            "rmse_mean_frame": float(np.sqrt(np.mean((x - controller.mean.clip(0, 1)) ** 2)))}


# -- figures ------------------------------------------------------------------------------------
def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(plt, fig, path: str | Path) -> Path:
    """Lay out ``fig``, write it to ``path`` (folders created) and close it."""
    fig.tight_layout()
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(p)
    plt.close(fig)
    return p


def _smooth(w: np.ndarray, k: int) -> np.ndarray:
    if k <= 1 or len(w) < k:
        return w
    c = np.cumsum(np.insert(np.nan_to_num(w), 0, 0.0))
    return (c[k:] - c[:-k]) / k


def plot_w_curves(curves: dict[str, tuple[np.ndarray, np.ndarray]], path: str | Path, *,
                  title: str = "", iters: dict[str, int] | None = None, smooth: int = 1,
                  columns: int = 2) -> Path:
    """One panel per curve set ``{name: (w_train, w_test)}``; x axis in generator iterations
    (``iters[name]`` when the curves are downsampled)."""
    plt = _plt()
    n = len(curves)
    cols = min(columns, n)
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 2.8 * rows), squeeze=False,
                             dpi=80)
    for ax, (name, (wtr, wte)) in zip(axes.flat, curves.items(), strict=False):
        total = (iters or {}).get(name, len(wtr))
        x = np.linspace(0, total, len(wtr))
        for w, lab in ((wtr, "train"), (wte, "test")):
            if w is None or np.all(np.isnan(w)):
                continue
            ws = _smooth(np.asarray(w), smooth)
            ax.plot(x[len(x) - len(ws):], ws, lw=0.8, label=lab)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("generator iteration", fontsize=8)
        ax.set_ylabel("W estimate", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=7)
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    if title:
        fig.suptitle(title, fontsize=10)
    return _save(plt, fig, path)


def plot_sweep(sweeps: dict[str, dict[int, dict[str, Any]]], path: str | Path, *,
               title: str = "") -> Path:
    """98th-percentile error against latent dimension, one line per data selection."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(5, 3.2), dpi=80)
    for name, sw in sweeps.items():
        ds = sorted(sw)
        ax.plot(ds, [sw[d]["p98_train"] for d in ds], "o-", label=f"{name} (train)")
        ax.plot(ds, [sw[d]["p98_test"] for d in ds], "s--", label=f"{name} (test)", alpha=0.7)
    ax.set_xlabel("latent dimension d")
    ax.set_ylabel("98th pct of last 100 W")
    ax.legend(fontsize=7)
    if title:
        ax.set_title(title, fontsize=9)
    return _save(plt, fig, path)


def plot_histograms(hists: dict[str, dict[str, float]], path: str | Path, *,
                    title: str = "") -> Path:
    """Grouped bars: per trained model (x groups), fraction of each NN label (colours)."""
    plt = _plt()
    models = list(hists)
    fig, ax = plt.subplots(figsize=(max(5, 1.1 * len(models) + 2), 3.2), dpi=80)
    w = 0.8 / len(LABELS)
    for j, lab in enumerate(LABELS):
        ax.bar(np.arange(len(models)) + (j - len(LABELS) / 2 + 0.5) * w,
               [100 * hists[m].get(lab, 0.0) for m in models], w, label=lab)
    ax.set_xticks(np.arange(len(models)), models, fontsize=8)
    ax.set_ylabel("% of 1 000 samples")
    ax.legend(fontsize=7, ncol=4)
    if title:
        ax.set_title(title, fontsize=9)
    return _save(plt, fig, path)
