"""Reproduce every number and plot of docs/transitions.md.

    MIMIKA_MOTION_DIR=../shared/motion/livelinkface .venv/bin/python bench/transitions_report.py \
        [--out /tmp/mimika-transitions] [--reuse] [--ship]

Trains seed 000's model and the RTN model on the training takes (CPU), evaluates them and the
interpolation baselines on the held-out take, prints markdown tables and writes the plots to
docs/img/. ``--reuse`` loads checkpoints from ``--out`` instead of training; ``--ship`` copies
the RTN checkpoint (float16) to src/mimika/learn/data/transitions.pt.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from mimika.learn.data import MODEL_CHANNELS
from mimika.learn.evaluate import baseline_generator, evaluate, l2_at, model_generator
from mimika.learn.metrics import summarise
from mimika.learn.train import TrainConfig, load_model, prepare, save_checkpoint, train

IMG = ROOT / "docs" / "img"
RECIPES = {"rtn": TrainConfig(model="rtn", epochs=40, lr=0.005, threads=2),
           "seed": TrainConfig(model="seed", epochs=6, lr=0.01, threads=2)}


def table(rows: dict[str, dict], keys: list[tuple[str, str, str]]) -> str:
    head = "| method | " + " | ".join(k[1] for k in keys) + " |"
    sep = "|---|" + "---:|" * len(keys)
    lines = [head, sep]
    for name, r in rows.items():
        lines.append(f"| {name} | " + " | ".join(k[2].format(r[k[0]]) for k in keys) + " |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", default=os.environ.get("MIMIKA_MOTION_DIR"))
    ap.add_argument("--out", default="/tmp/mimika-transitions")
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--ship", action="store_true")
    ap.add_argument("--quick", action="store_true", help="1 epoch each (a smoke test)")
    a = ap.parse_args()
    if a.quick:
        for r in RECIPES.values():
            r.epochs, r.windows_per_epoch = 1, 32
    if not a.data:
        sys.exit("set MIMIKA_MOTION_DIR or pass --data")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    IMG.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    data = prepare(a.data)
    print(f"prepared in {time.perf_counter() - t0:.1f} s; split {data.split}")
    for n, t in data.takes.items():
        print(f"  {n}: {t.n_frames} frames, {int((~t.valid).sum())} filled, "
              f"{len(data.holds[n])} holds ({sum(h.length for h in data.holds[n])} frames), "
              f"{len([x for x in data.transitions[n] if x.fill == 'linear'])} transitions")
    models, info = {}, {}
    for kind, cfg in RECIPES.items():
        path = out / f"{kind}.pt"
        if not (a.reuse and path.exists()):
            def show(e, n, r, kind=kind):
                print(f"  {kind} epoch {e}/{n} train {r['train']:.5f} val {r['val']:.5f} "
                      f"{r['time']:.0f} s", flush=True)

            ck = train(data, cfg, progress=show)
            save_checkpoint(ck, path)
        models[kind] = load_model(path)
        c = models[kind].checkpoint
        if kind == "rtn" and a.ship:  # the shipped model: float16 weights
            ship = ROOT / "src/mimika/learn/data/transitions.pt"
            ck = dict(c)
            ck["state_dict"] = models[kind].state_dict()
            save_checkpoint(ck, ship, half=True)
            print(f"shipped {ship} ({ship.stat().st_size / 1e6:.2f} MB)", flush=True)
        info[kind] = {"params": c["n_params"], "seconds": c["train_seconds"],
                      "best_epoch": c["best_epoch"], "best_val": c["best_val"],
                      "mb_fp32": path.stat().st_size / 1e6}
    print(json.dumps(info, indent=1))

    gens = {"linear": baseline_generator("linear"), "cosine": baseline_generator("cosine"),
            "hermite": baseline_generator("hermite"),
            "seed (LSTM)": model_generator(models["seed"]),
            "RTN (ours)": model_generator(models["rtn"])}
    batched = {"seed (LSTM)", "RTN (ours)"}
    keys = [("mse", "MSE", "{:.5f}"), ("l2", "L2", "{:.4f}"), ("jump_pct", "jump %", "{:.2f}"),
            ("endpoint", "endpoint err", "{:.4f}"), ("conspicuous", "conspicuous", "{:d}"),
            ("c_jumps", "· jumps", "{:d}"), ("c_reactivation", "· re-act.", "{:d}"),
            ("c_endpoint", "· endpoint", "{:d}"), ("c_gt_diff", "· |GT−gen|", "{:d}")]
    results = {}
    for part in ("test", "val"):
        items = data.items(part)
        rows = {}
        for name, g in gens.items():
            rows[name] = evaluate(g, items, batched=name in batched)
        fr = [t.frames for t in items]
        rows["ground truth"] = summarise([t.window for t in items], fr, fr)
        take = getattr(data.split, part)[0]
        l2s = {name: l2_at(g, data.takes[take], batched=name in batched)
               for name, g in gens.items()}
        for name in gens:
            rows[name].update({f"l2@{k}": v for k, v in l2s[name].items()})
        rows["ground truth"].update({"l2@5": 0.0, "l2@15": 0.0, "l2@30": 0.0})
        results[part] = rows
        print(f"\n### {part}: {', '.join(getattr(data.split, part))} ({len(items)} segmented "
              "transitions)\n")
        print(table(rows, keys))
        print()
        print(table({k: v for k, v in rows.items() if k != "ground truth"},
                    [("l2@5", "L2@5", "{:.4f}"), ("l2@15", "L2@15", "{:.4f}"),
                     ("l2@30", "L2@30", "{:.4f}")]))
        best = min(rows[b]["mse"] for b in ("linear", "cosine", "hermite"))
        for m in ("seed (LSTM)", "RTN (ours)"):
            print(f"{m}: MSE {100 * (rows[m]['mse'] / best - 1):+.1f} % vs best baseline")
    (out / "results.json").write_text(json.dumps({"info": info, "results": results}, indent=1))
    plots(data, models, gens, batched)
    print(f"\ntotal {time.perf_counter() - t0:.0f} s")


def plots(data, models, gens, batched) -> None:
    # 1. segmentation of a slice of the range-of-motion take
    name = "alex_rom_3" if "alex_rom_3" in data.takes else data.split.train[0]
    x = data.takes[name].values
    lo, hi = 0, min(900, len(x))
    fig, ax = plt.subplots(figsize=(9, 3), dpi=90)
    t = np.arange(lo, hi) / data.takes[name].fps
    top = np.argsort(-x[lo:hi].std(0))[:6]
    for j in top:
        ax.plot(t, x[lo:hi, j], lw=1, label=MODEL_CHANNELS[j])
    for h in data.holds[name]:
        if h.end <= lo or h.start >= hi:
            continue
        ax.axvspan(h.start / 30, h.end / 30, color="0.85" if h.label == "neutral" else "C9",
                   alpha=0.35, lw=0)
        ax.text((h.start + h.end) / 60, 1.02, h.label.removeprefix("template/")[:8],
                fontsize=6, ha="center", rotation=60)
    ax.set_ylim(0, 1.15)
    ax.set_xlabel("time (s)")
    ax.legend(ncol=6, fontsize=7, loc="upper right")
    ax.set_title(f"{name}: holds found by PCA + SOM (shaded; grey = neutral)", fontsize=9)
    fig.tight_layout()
    fig.savefig(IMG / "transitions_segments.png")
    plt.close(fig)
    # 2. held-out transitions: GT vs models vs baselines
    items = sorted(data.items("test"), key=lambda t: -np.abs(t.target - t.start_frame).sum())[:3]
    fig, axes = plt.subplots(1, 3, figsize=(10, 3), dpi=90)
    for ax, it in zip(axes, items, strict=False):
        j = int(np.argmax(np.abs(it.target - it.start_frame)))
        w = np.arange(-len(it.window) + 1, 1)
        ax.plot(w, it.window[:, j], "k", lw=1)
        tt = np.arange(1, it.length + 1)
        ax.plot(tt, it.frames[:, j], "k", lw=2, label="real")
        for (n, g), st in zip(gens.items(), ["C0:", "C1:", "C2:", "C3-", "C4-"], strict=True):
            y = (g(it.window[None], it.target[None], it.length)[0] if n in batched
                 else g(it.window, it.target, it.length))
            ax.plot(tt, y[:, j], st, lw=1.5, label=n)
        ax.set_title(f"{MODEL_CHANNELS[j]}, {it.source[:14]} → {it.target_label[:14]}",
                     fontsize=8)
        ax.set_xlabel("frame")
    axes[0].legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(IMG / "transitions_examples.png")
    plt.close(fig)
    # 3. training curves
    fig, ax = plt.subplots(figsize=(6, 2.6), dpi=90)
    for k, m in models.items():
        h = m.checkpoint["history"]
        ax.semilogy([r["epoch"] / len(h) for r in h], [r["val"] for r in h], label=f"{k} val")
        ax.semilogy([r["epoch"] / len(h) for r in h], [r["train"] for r in h], "--",
                    label=f"{k} train")
    ax.set_xlabel("fraction of run")
    ax.set_ylabel("MSE")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(IMG / "transitions_training.png")
    plt.close(fig)


if __name__ == "__main__":
    main()
