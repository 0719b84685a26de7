"""The controller's figures in docs/controller.md: held-out inversion against PCA.

    MIMIKA_MOTION_DIR=../shared/motion/livelinkface MIMIKA_FACEGOOD_DIR=../shared/motion/facegood \
        .venv/bin/python bench/controller_report.py [--dims 4,6] [--iters N] [--peak W] \
        [--knowledge F] [--takes T1,T2] [--out DIR] [--reuse] [--ship]

Leave-one-take-out over every Live Link Face take: for each take, the controller (the WAE of
mimika.learn.wae) and a PCA of the same size are fitted on the other takes, and every frame of
the held-out take is put on the sliders (encoder guess + optimisation, as Controller.invert)
or projected on the components (clamped to [0, 1]). Figures: RMSE with 95 % intervals (block
bootstrap, 1-second blocks within each take), the WAE/PCA RMSE ratio, and how much of each
strong AU's value its peak frames keep (frames where the AU reaches max(0.3, its take's 98th
percentile)). Leave-one-person-out: the model trained on all five takes, on FACEGOOD's second
person, fitted and scored on the 13 channels that person's rig carries. ``--ship`` trains the
d = 6 controller on all five takes and writes src/mimika/learn/data/controller.pt. Each fold
is cached in ``--out``; ``--reuse`` loads it; ``--takes`` runs only those folds (run two
processes to use two cores, then one with ``--reuse`` for the summary).
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from mimika.learn.controller import Controller
from mimika.learn.gan_data import load_frames, neutral_relative
from mimika.learn.protocol import bootstrap
from mimika.learn.sliders import distinct_rotation, rotate_state
from mimika.learn.wae import WAEConfig, train_wae, wae_state
from mimika.learn.wgan import save_checkpoint

SHIP = ROOT / "src/mimika/learn/data/controller.pt"
BLOCK = 30  # frames per bootstrap block (1 s)


def pca_reconstruct(train: np.ndarray, test: np.ndarray, d: int,
                    fit: np.ndarray | None = None) -> np.ndarray:
    """Least-squares PCA coordinates of ``test`` on the fitted channels, clamped to [0, 1]."""
    mu = train.mean(0)
    V = np.linalg.svd(train - mu, full_matrices=False)[2][:d]  # (d, K)
    keep = np.ones(train.shape[1], bool) if fit is None else fit
    z = np.linalg.lstsq(V[:, keep].T, (test - mu)[:, keep].T, rcond=None)[0].T
    return np.clip(mu + z @ V, 0.0, 1.0)


def evaluate(recons: dict[str, np.ndarray], test: np.ndarray, takes: np.ndarray,
             fit: np.ndarray | None = None) -> dict:
    """RMSE per method with block-bootstrap intervals, ratios to PCA, peak preservation."""
    keep = np.ones(test.shape[1], bool) if fit is None else fit
    se = {m: ((r - test) ** 2)[:, keep].sum(1) for m, r in recons.items()}
    blocks = np.array([f"{t}:{i // BLOCK}" for t in np.unique(takes)
                       for i in range(int(np.sum(takes == t)))])
    ids = {b: np.flatnonzero(blocks == b) for b in np.unique(blocks)}
    names = np.array(list(ids))
    strata = np.array([b.split(":")[0] for b in names])
    n_ch = int(keep.sum())

    def rows(i):
        return np.concatenate([ids[b] for b in names[i]])

    out: dict = {"frames": len(test), "methods": {}}
    for m in recons:
        def rmse(i, m=m):
            r = rows(i)
            return float(np.sqrt(se[m][r].sum() / (len(r) * n_ch)))

        def ratio(i, m=m):
            r = rows(i)
            return float(np.sqrt(se[m][r].sum() / se["pca"][r].sum()))

        all_ = np.arange(len(names))
        out["methods"][m] = {"rmse": rmse(all_), "rmse_ci": bootstrap(rmse, strata, n=1000),
                             "ratio": ratio(all_), "ratio_ci": bootstrap(ratio, strata, n=1000)}
    peaks = {m: {} for m in recons}
    for k in np.flatnonzero(keep):
        idx = np.concatenate([np.flatnonzero((takes == t) & (test[:, k] >= max(
            0.3, np.quantile(test[takes == t, k], 0.98)))) for t in np.unique(takes)])
        if len(idx) < 3:
            continue
        for m, r in recons.items():
            peaks[m][k] = (float(r[idx, k].sum() / test[idx, k].sum()), len(idx))
    out["peaks"] = {m: {str(k): v for k, v in p.items()} for m, p in peaks.items()}
    return out


def invert(state: dict, frames: np.ndarray, fit: np.ndarray | None = None) -> np.ndarray:
    c = Controller(state)
    return c.invert_batch(frames, fit=fit)[1]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", default=os.environ.get("MIMIKA_MOTION_DIR"))
    ap.add_argument("--facegood", default=os.environ.get("MIMIKA_FACEGOOD_DIR"))
    ap.add_argument("--dims", default="6")
    ap.add_argument("--iters", type=int, default=WAEConfig.iters)
    ap.add_argument("--peak", type=float, default=WAEConfig.peak,
                    help="reconstruction weight 1 + peak·x per AU (shipped: %(default)s)")
    ap.add_argument("--knowledge", type=float, default=WAEConfig.knowledge,
                    help="share of each batch drawn from FACS frames (shipped: %(default)s)")
    ap.add_argument("--takes", help="held-out takes to run (comma-separated; default all)")
    ap.add_argument("--out", default="/tmp/mimika-controller")
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--ship", action="store_true")
    a = ap.parse_args()
    if not a.data:
        sys.exit("set MIMIKA_MOTION_DIR or pass --data")
    import torch

    torch.set_num_threads(1)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    fs = load_frames(a.data)
    report: dict = {"loto": {}, "lopo": {}}
    for d in [int(x) for x in a.dims.split(",")]:
        recons, tests, takes = {"wae": [], "pca": []}, [], []
        folds = a.takes.split(",") if a.takes else fs.takes
        for t in folds:
            tag = "" if a.peak == WAEConfig.peak else f"_peak{a.peak:g}"
            tag += "" if a.knowledge == WAEConfig.knowledge else f"_know{a.knowledge:g}"
            key = out / f"loto_d{d}{tag}_{t}.pkl"
            train, test = fs.split([t])
            if a.reuse and key.exists():
                r = pickle.loads(key.read_bytes())
            else:
                res = train_wae(train.values, WAEConfig(latent_dim=d, iters=a.iters,
                                                        peak=a.peak, knowledge=a.knowledge),
                                channels=fs.channels)
                state = wae_state(res, channels=fs.channels, fps=fs.fps)
                t0 = time.perf_counter()
                r = {"wae": invert(state, test.values), "seconds": res.seconds, "state": state,
                     "invert_seconds": time.perf_counter() - t0,
                     "pca": pca_reconstruct(train.values, test.values, d)}
                key.write_bytes(pickle.dumps(r))
            print(f"d={d} held-out {t}: WAE trained in {r['seconds']:.0f} s, inverted "
                  f"{len(test)} frames in {r['invert_seconds']:.0f} s; RMSE WAE "
                  f"{np.sqrt(np.mean((r['wae'] - test.values) ** 2)):.4f}, PCA "
                  f"{np.sqrt(np.mean((r['pca'] - test.values) ** 2)):.4f}", flush=True)
            for m in recons:
                recons[m].append(r[m])
            tests.append(test.values)
            takes += [t] * len(test)
        ev = evaluate({m: np.concatenate(v) for m, v in recons.items()}, np.concatenate(tests),
                      np.array(takes))
        report["loto"][d] = ev
        for t in folds:  # per take (no intervals)
            m = np.array(takes) == t
            x = np.concatenate(tests)[m]
            ev.setdefault("per_take", {})[t] = {
                k: float(np.sqrt(np.mean((np.concatenate(v)[m] - x) ** 2)))
                for k, v in recons.items()}
        print_summary(f"leave-one-take-out, d = {d}", ev, fs.channels)
    if a.ship or a.facegood:
        d = 6
        if a.reuse and SHIP.exists() and not a.ship:
            state = torch.load(SHIP, weights_only=True)
        else:
            res = train_wae(fs.values, WAEConfig(latent_dim=d, iters=a.iters, peak=a.peak,
                                                 knowledge=a.knowledge), channels=fs.channels)
            state = wae_state(res, channels=fs.channels, fps=fs.fps, meta={
                "data": "Live Link Face takes " + ", ".join(fs.takes), "train_frames": len(fs),
                "preprocessing": "fold to 20 bilateral face AUs; subtract per-take median "
                                 "frame; clip to [0, 1]",
                "evaluation": "bench/controller_report.py (docs/controller.md)"})
            # the same model with its sliders turned for distinct ends (mimika.learn.sliders)
            state = rotate_state(state, distinct_rotation(Controller(state)))
            if a.ship:
                save_checkpoint(SHIP, state)
                print(f"shipped {SHIP} ({SHIP.stat().st_size / 1e3:.0f} kB, trained in "
                      f"{res.seconds:.0f} s)", flush=True)
        if a.facegood:
            report["lopo"] = lopo(state, fs, a.facegood)
    (out / "report.json").write_text(json.dumps(report, indent=1, default=float))


def lopo(state: dict, fs, folder: str) -> dict:
    from mimika.learn.facegood import covered_channels, load_facegood

    fit = np.isin(fs.channels, covered_channels(folder))
    takes = load_facegood(folder)
    x = np.concatenate([neutral_relative(t.values) for t in takes])
    names = np.concatenate([[t.name] * t.n_frames for t in takes])
    d = int(state["config"]["latent_dim"])
    t0 = time.perf_counter()
    recons = {"wae": invert(state, x, fit), "pca": pca_reconstruct(fs.values, x, d, fit)}
    print(f"second person: {len(x)} frames inverted in {time.perf_counter() - t0:.0f} s")
    ev = evaluate(recons, x, names, fit)
    print_summary(f"leave-one-person-out (FACEGOOD, {int(fit.sum())} channels), d = {d}", ev,
                  fs.channels)
    return ev


def print_summary(title: str, ev: dict, channels) -> None:
    print(f"\n### {title} — {ev['frames']} frames\n")
    print("| method | RMSE [95 % CI] | RMSE / PCA's [95 % CI] |\n|---|---|---|")
    for m, r in ev["methods"].items():
        print(f"| {m} | {r['rmse']:.4f} [{r['rmse_ci'][0]:.4f} … {r['rmse_ci'][1]:.4f}] | "
              f"{r['ratio']:.2f} [{r['ratio_ci'][0]:.2f} … {r['ratio_ci'][1]:.2f}] |")
    if "per_take" in ev:
        print("\n| held-out take | " + " | ".join(ev["methods"]) + " |\n|---|" +
              "---:|" * len(ev["methods"]))
        for t, r in ev["per_take"].items():
            print(f"| {t} | " + " | ".join(f"{v:.4f}" for v in r.values()) + " |")
    aus = sorted({int(k) for p in ev["peaks"].values() for k in p})
    print("\npeak frames: reconstructed / recorded value (frames)\n")
    print("| AU | " + " | ".join(ev["peaks"]) + " |\n|---|" + "---:|" * len(ev["peaks"]))
    for k in aus:
        cells = [f"{p[str(k)][0]:.2f}" if str(k) in p else "–" for p in ev["peaks"].values()]
        n = next(p[str(k)][1] for p in ev["peaks"].values() if str(k) in p)
        print(f"| {channels[k]} ({n}) | " + " | ".join(cells) + " |")
    for m, p in ev["peaks"].items():
        v = np.array([x[0] for x in p.values()])
        print(f"{m}: {np.sum(v >= 0.9)} of {len(v)} AUs keep ≥ 90 % at their peaks "
              f"(mean {v.mean():.2f}, min {v.min():.2f})")


if __name__ == "__main__":
    main()
