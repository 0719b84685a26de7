"""Reproduce every number and figure of docs/controller.md (seed 001's analysis + beyond).

Run (stages cache their results in ``out/wgan_report/``; ``plots`` draws from the caches)::

    MIMIKA_MOTION_DIR=../shared/motion/livelinkface .venv/bin/python bench/wgan_report.py all
    .venv/bin/python bench/wgan_report.py main cgan      # only some stages

Stages and budgets (2 shared CPU cores; the seed ran 50 000 iterations everywhere):

* ``main``     — the shipped WGAN: d = 4, n_critic 20, the seed's 50 000 iterations (≈ 6 min
                 on one thread; timed alone by bench/bench_gan.py);
                 writes ``src/mimika/learn/data/gan.pt``;
* ``ncritic``  — n_critic 5 / 10 / 50 for 6 000 iterations each (20: the first 6 000 of
                 ``main``);
* ``overfit``  — the same WGAN trained on 10 frames, 5 000 iterations;
* ``sweep``    — d ∈ {1, 2, 4, 8}, 1 000 iterations each (not 50 000), critic
                 identical, on two selections: all training frames, and the five basic
                 emotions balanced as in the seed (happiness, sadness, surprise, fear, anger);
* ``nnlabels`` — one WGAN per label (d = 4, 1 000 iterations) + the main model, 1 000 samples
                 each, nearest neighbour in the held-out take;
* ``cgan``     — the conditional WGAN-GP with its auxiliary classifier (15 000 iterations,
                 n_critic 5), writes
                 ``src/mimika/learn/data/cgan.pt``; self-match rate and inversion error;
* ``grids``    — latent traversal grids on the built-in head (PNG);
* ``plots``    — W curves, sweep and label histograms (PNG) and ``summary.json``.

Split by take: ``apfel`` is held out (test); the other four takes train.
"""

from __future__ import annotations

import json
import logging
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import single_core

single_core()

import numpy as np
import torch

torch.set_num_threads(1)

from mimika.learn.gan_data import LABELS, load_frames
from mimika.learn.wgan import WGANConfig, downsample, save_checkpoint, train_wgan

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "out" / "wgan_report"
IMG = ROOT / "docs" / "img"
SHIP = ROOT / "src" / "mimika" / "learn" / "data"
#: WGAN_REPORT_SMOKE=DIR: 1/100 of every iteration count, all outputs under DIR (a dry run)
SMOKE = os.environ.get("WGAN_REPORT_SMOKE")
if SMOKE:
    OUT = IMG = SHIP = Path(SMOKE)


def it(n: int) -> int:
    """An iteration budget (÷100 in a smoke run)."""
    return max(n // 100, 20) if SMOKE else n
#: iteration budgets of the shorter runs (2 shared cores; see the module docstring)
MAIN_ITERS, NC_ITERS, SWEEP_ITERS, LABEL_ITERS, CGAN_ITERS = 50_000, 6_000, 1_000, 1_000, 15_000
SWEEP_DIMS = (1, 2, 4, 8)
FIVE = ("happiness", "sadness", "surprise", "fear", "anger")
log = logging.getLogger("wgan_report")


def _save(name: str, obj: dict) -> None:
    OUT.mkdir(parents=True, exist_ok=True)

    def conv(o):
        if isinstance(o, np.ndarray):
            return [None if not np.isfinite(v) else float(v) for v in o.ravel()]
        if isinstance(o, (np.floating, np.integer)):
            return o.item()
        raise TypeError(type(o))

    (OUT / f"{name}.json").write_text(json.dumps(obj, default=conv))


def _load(name: str) -> dict:
    p = OUT / f"{name}.json"
    return json.loads(p.read_text()) if p.exists() else {}


def _arr(v) -> np.ndarray:
    return np.array([np.nan if x is None else x for x in v], np.float64)


def data():
    fs = load_frames()
    train, test = fs.split(("apfel",))
    return fs, train, test


def stage_main() -> None:
    from mimika.learn.controller import train_controller

    t0 = time.perf_counter()
    state, res = train_controller(latent_dim=4, n_critic=20, iters=it(MAIN_ITERS))
    p = save_checkpoint(SHIP / "gan.pt", state)
    _save("main", {"w_train": downsample(res.w_train, 2000), "w_test": downsample(res.w_test, 2000),
                   "w_train_nc": downsample(res.w_train[:NC_ITERS], 600),
                   "w_test_nc": downsample(res.w_test[:NC_ITERS], 600),
                   "seconds": res.seconds, "iters": len(res.w_train),
                   "iters_per_s": res.iters_per_second, "total_seconds": time.perf_counter() - t0,
                   "p98_train": float(np.percentile(res.w_train[-100:], 98)),
                   "p98_test": float(np.percentile(res.w_test[-100:], 98)),
                   "final_train": float(res.w_train[-1000:].mean()),
                   "final_test": float(res.w_test[-1000:].mean()),
                   "first_train": float(res.w_train[:100].mean()),
                   "size_bytes": p.stat().st_size, "meta": state["meta"]})


def stage_ncritic() -> None:
    _, train, test = data()
    out = {}
    for n in (5, 10, 50):
        res = train_wgan(train.values, test.values, WGANConfig(n_critic=n, iters=it(NC_ITERS)))
        out[str(n)] = {"w_train": downsample(res.w_train, 600),
                       "w_test": downsample(res.w_test, 600),
                       "seconds": res.seconds, "iters_per_s": res.iters_per_second}
        print(f"n_critic {n}: {res.seconds:.0f} s", flush=True)
    _save("ncritic", out)


def stage_overfit() -> None:
    from mimika.learn.wgan_analysis import overfit_demo

    _, train, test = data()
    res = overfit_demo(train, test, WGANConfig(n_critic=20, iters=it(5_000)), n_frames=10)
    gap = res.w_test[-500:].mean() - res.w_train[-500:].mean()
    _save("overfit", {"w_train": downsample(res.w_train, 500),
                      "w_test": downsample(res.w_test, 500),
                      "final_train": float(res.w_train[-500:].mean()),
                      "final_test": float(res.w_test[-500:].mean()), "gap": float(gap)})


def stage_sweep() -> None:
    from mimika.learn.wgan_analysis import latent_sweep

    _, train, test = data()
    rng = np.random.default_rng(0)
    cfg = WGANConfig(n_critic=20, iters=it(SWEEP_ITERS))
    dims = SWEEP_DIMS
    five_tr = train.balanced(FIVE, rng)
    five_te = test.balanced(FIVE, rng)
    out = {}
    for name, tr, te in (("all frames", train, test), ("five emotions", five_tr, five_te)):
        sw = latent_sweep(tr.values, te.values, dims, cfg)
        out[name] = {str(d): v for d, v in sw.items()}
        out[name]["_frames"] = [len(tr), len(te)]
        print(name, {d: round(v["p98_train"], 5) for d, v in sw.items()}, flush=True)
    _save("sweep", out)


def stage_nnlabels() -> None:
    from mimika.learn.controller import Controller
    from mimika.learn.wgan_analysis import nn_label_histogram

    _, train, test = data()
    hists = {}
    c = Controller.load(SHIP / "gan.pt")
    _, x = c.random(1000, seed=1)
    hists["all (main)"] = nn_label_histogram(x, test)
    for lab in LABELS:
        sel = train.with_label(lab)
        res = train_wgan(sel.values, test.with_label(lab).values,
                         WGANConfig(n_critic=20, iters=it(LABEL_ITERS)))
        z = torch.randn(1000, 4, generator=torch.Generator().manual_seed(1))
        with torch.no_grad():
            xs = res.generator(z).numpy()
        xs = np.clip(res.normaliser.inverse(xs), 0, 1)
        hists[lab] = nn_label_histogram(xs, test)
        hists[lab]["_frames"] = len(sel)
        print(lab, len(sel), {k: round(v, 2) for k, v in hists[lab].items()}, flush=True)
    real = np.bincount(test.labels, minlength=len(LABELS)) / len(test)
    hists["held-out data"] = {lab: float(f) for lab, f in zip(LABELS, real, strict=True)}
    _save("nnlabels", hists)


def stage_cgan() -> None:
    from mimika.learn.controller import Controller, train_controller
    from mimika.learn.wgan_analysis import inversion_error, self_match_rate

    t0 = time.perf_counter()
    state, res = train_controller(latent_dim=4, conditional=True, iters=it(CGAN_ITERS))
    p = save_checkpoint(SHIP / "cgan.pt", state)
    secs = time.perf_counter() - t0
    _, train, test = data()
    cc = Controller.load(p)
    sm = self_match_rate(cc, test, n=1000, real=train)
    rng = np.random.default_rng(0)
    pick = np.sort(rng.choice(len(test), 500, replace=False))
    frames = test.values[pick]
    inv_c = inversion_error(cc, frames)
    cu = Controller.load(SHIP / "gan.pt")
    inv_u = inversion_error(cu, frames)
    z, x = cu.random(500, seed=3)
    zh, rec = cu.invert_batch(x)
    gen_err = {"rmse": float(np.sqrt(np.mean((rec - x) ** 2))),
               "z_rmse": float(np.sqrt(np.mean((zh - z) ** 2)))}
    _save("cgan", {"w_train": downsample(res.w_train, 500), "w_test": downsample(res.w_test, 500),
                   "seconds": res.seconds, "total_seconds": secs, "size_bytes": p.stat().st_size,
                   "self_match": sm, "inversion_cgan": inv_c, "inversion_wgan": inv_u,
                   "inversion_generated": gen_err, "iters": len(res.w_train)})
    print(json.dumps({"self_match": {k: sm[k] for k in ("nn", "prototype", "real_nn_mean")},
                      "per_label_nn": sm["per_label_nn"], "inv_c": inv_c, "inv_u": inv_u,
                      "gen": gen_err}, indent=1), flush=True)


def stage_grids() -> None:
    from mimika.learn.controller import Controller
    from mimika.render import save_png

    c = Controller.load(SHIP / "gan.pt")
    save_png(c.render_grid(tile=(112, 112)), IMG / "gan_grid.png")
    cc = Controller.load(SHIP / "cgan.pt")
    for lab in ("surprise", "happiness", "anger"):
        save_png(cc.render_grid(label=lab, tile=(96, 96)), IMG / f"cgan_grid_{lab}.png")
    # one face per label at z = 0 (the conditional model's answer to "more <label>")
    from mimika.render import contact_sheet

    imgs = [cc.render(np.zeros(cc.latent_dim), label=lab, size=(128, 128)) for lab in cc.labels]
    save_png(contact_sheet(imgs, list(cc.labels), columns=len(imgs),
                           title="conditional model, z = 0, one label each"),
             IMG / "cgan_labels.png")


def stage_plots() -> None:
    from mimika.learn.wgan_analysis import plot_histograms, plot_sweep, plot_w_curves

    summary: dict = {}
    m = _load("main")
    if m:
        name = f"d=4, n_critic 20, {m['iters']} iterations"
        plot_w_curves({name: (_arr(m["w_train"]), _arr(m["w_test"]))}, IMG / "gan_w_main.png",
                      iters={name: m["iters"]}, smooth=5, columns=1)
        summary["main"] = {k: m[k] for k in ("seconds", "iters_per_s", "p98_train", "p98_test",
                                             "final_train", "final_test", "first_train",
                                             "size_bytes")}
    nc = _load("ncritic")
    if nc and m:
        curves = {f"n_critic {n}": (_arr(nc[n]["w_train"]), _arr(nc[n]["w_test"]))
                  for n in ("5", "10")}
        if "w_train_nc" in m:
            curves["n_critic 20"] = (_arr(m["w_train_nc"]), _arr(m["w_test_nc"]))
        else:  # the first NC_ITERS iterations of the downsampled 50 000-iteration curves
            k = int(len(m["w_train"]) * NC_ITERS / m["iters"])
            curves["n_critic 20"] = (_arr(m["w_train"])[:k], _arr(m["w_test"])[:k])
        curves["n_critic 50"] = (_arr(nc["50"]["w_train"]), _arr(nc["50"]["w_test"]))
        plot_w_curves(curves, IMG / "gan_w_ncritic.png", iters=dict.fromkeys(curves, NC_ITERS),
                      smooth=5, title=f"W estimate vs n_critic (first {NC_ITERS} iterations)")
        summary["ncritic"] = {n: {"iters_per_s": nc[n]["iters_per_s"],
                                  "std_last_half": float(np.nanstd(_arr(nc[n]["w_train"])[300:]))}
                              for n in ("5", "10", "50")}
        w20 = curves["n_critic 20"][0]
        summary["ncritic"]["20"] = {"iters_per_s": m["iters_per_s"],
                                    "std_last_half": float(np.nanstd(w20[len(w20) // 2:]))}
    of = _load("overfit")
    if of:
        plot_w_curves({"trained on 10 frames": (_arr(of["w_train"]), _arr(of["w_test"]))},
                      IMG / "gan_w_overfit.png", iters={"trained on 10 frames": 5000}, smooth=3,
                      columns=1)
        summary["overfit"] = {k: of[k] for k in ("final_train", "final_test", "gap")}
    sw = _load("sweep")
    if sw:
        sweeps = {name: {int(d): v for d, v in s.items() if not d.startswith("_")}
                  for name, s in sw.items()}
        plot_sweep(sweeps, IMG / "gan_sweep.png",
                   title=f"latent sweep: 98th pct of last 100 W ({SWEEP_ITERS} it.)")
        summary["sweep"] = {name: {d: [round(v["p98_train"], 5), round(v["p98_test"], 5)]
                                   for d, v in s.items()} for name, s in sweeps.items()}
    nl = _load("nnlabels")
    if nl:
        plot_histograms({k: v for k, v in nl.items()}, IMG / "gan_nn_labels.png",
                        title="labels of the nearest held-out frame (1 000 samples per model)")
        summary["nnlabels"] = {k: {lab: round(f, 3) for lab, f in v.items()
                                   if not lab.startswith("_")} for k, v in nl.items()}
    cg = _load("cgan")
    if cg:
        plot_w_curves({"conditional WGAN-GP": (_arr(cg["w_train"]), _arr(cg["w_test"]))},
                      IMG / "cgan_w.png", iters={"conditional WGAN-GP": cg["iters"]}, smooth=5,
                      columns=1)
        summary["cgan"] = {k: cg[k] for k in ("seconds", "self_match", "inversion_cgan",
                                              "inversion_wgan", "inversion_generated",
                                              "size_bytes")}
    (OUT / "summary.json").write_text(json.dumps(summary, indent=1))
    print(json.dumps(summary, indent=1))


STAGES = {"main": stage_main, "ncritic": stage_ncritic, "overfit": stage_overfit,
          "sweep": stage_sweep, "nnlabels": stage_nnlabels, "cgan": stage_cgan,
          "grids": stage_grids, "plots": stage_plots}

if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s: %(message)s")
    names = sys.argv[1:] or ["all"]
    if names == ["all"]:
        names = list(STAGES)
    for n in names:
        if n not in STAGES:
            sys.exit(f"unknown stage {n!r}; use {', '.join(STAGES)} or all")
    for n in names:
        t = time.perf_counter()
        STAGES[n]()
        print(f"== stage {n}: {time.perf_counter() - t:.0f} s", flush=True)
