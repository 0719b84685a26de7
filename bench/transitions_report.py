"""Every transition figure of docs/transitions.md, from the evaluation protocol.

    MIMIKA_MOTION_DIR=../shared/motion/livelinkface MIMIKA_FACEGOOD_DIR=../shared/motion/facegood \
        .venv/bin/python bench/transitions_report.py [--models timing,seed] [--out DIR] \
        [--reuse] [--ship]

Leave-one-take-out over every Live Link Face take and leave-one-person-out (train on the Live
Link takes, test on FACEGOOD's second person, on the 13 channels its rig maps to) for the
interpolation baselines and the learned models (``--models``: timing, seed, rtn), with
bootstrap intervals, per transition size; markdown tables on stdout, plots in docs/img/,
``results.json`` in ``--out``. Each method's results are cached in ``--out``; ``--reuse``
loads them instead of retraining. ``--ship`` trains the timing model on all five takes (and,
with ``--models …,seed``, seed 000's LSTM on four, early-stopping on the fifth) and writes it,
with the leave-one-take-out validation record the ``learned`` easing reads, to
src/mimika/learn/data/transitions.pt (transitions_seed.pt).
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

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from mimika.learn.data import FILLS, MODEL_CHANNELS, Split, list_takes, load_take
from mimika.learn.facegood import covered_channels, load_facegood
from mimika.learn.protocol import (
    SIZE_BINS,
    Baseline,
    Learned,
    concat,
    leave_one_person_out,
    leave_one_take_out,
    mask_take,
    merge_methods,
    run_protocol,
    summarise,
    validation_record,
)
from mimika.learn.train import RECIPES, load_state, save_checkpoint, segment_split, train

IMG = ROOT / "docs" / "img"
BASELINES = ("linear", "cosine", "hermite")
SHIP = {"timing": ROOT / "src/mimika/learn/data/transitions.pt",
        "seed": ROOT / "src/mimika/learn/data/transitions_seed.pt"}


def cached(out: Path, key: str, reuse: bool, make):
    path = out / f"{key}.pkl"
    if reuse and path.exists():
        return pickle.loads(path.read_bytes())
    t0 = time.perf_counter()
    res = make()
    print(f"  {key}: {time.perf_counter() - t0:.0f} s", flush=True)
    path.write_bytes(pickle.dumps(res))
    return res


def ci(x, scale=1.0, fmt="{:.2f}"):
    return f"{fmt.format(x[0] * scale)} … {fmt.format(x[1] * scale)}"


def table(s: dict, title: str) -> str:
    if not s.get("n"):
        return f"**{title}**: no transitions\n"
    lines = [f"**{title}** — {s['n']} transitions; best interpolator: {s['best_baseline']}", "",
             "| method | MSE ×10³ [95 % CI] | vs best interpolator [95 % CI] | jump % | "
             "conspicuous | L2@5 | L2@15 | L2@30 |", "|---|---|---|---:|---:|---:|---:|---:|"]
    for name, r in s["methods"].items():
        lines.append(
            f"| {name} | {r['mse'] * 1e3:.2f} [{ci(r['mse_ci'], 1e3)}] | "
            f"{100 * r['rel']:+.1f} % [{ci(r['rel_ci'], 100, '{:+.1f}')}] | {r['jump']:.2f} | "
            f"{r['consp_n']} ({r['consp']:.0f} %) | "
            + " | ".join(f"{r[k]:.3f}" if k in r else "–" for k in ("l2@5", "l2@15", "l2@30"))
            + " |")
    lines.append(f"| ground truth | 0 | | {s['gt_jump']:.2f} | | | | |")
    return "\n".join(lines) + "\n"


def timing_table(s: dict) -> str:
    t = s["timing"]
    head = "| | " + " | ".join(t["groups"]) + " |"
    lines = [head, "|---|" + "---:|" * len(t["groups"])]
    for key, unit in (("onset", "onset latency (frames)"), ("peak", "peak velocity (AU/frame)")):
        for name, vals in t[key].items():
            cells = " | ".join("–" if np.isnan(v) else (f"{v:.1f}" if key == "onset" else
                                                          f"{v:.3f}") for v in vals)
            lines.append(f"| {unit}: {name} | {cells} |")
    return "\n".join(lines) + "\n"


def learned(model: str) -> Learned:
    """A learned method with its recipe; the LSTMs early-stop on an inner validation take."""
    def show(epoch, total, rec):
        print(f"    {model} epoch {epoch}/{total} train {rec['train']:.5f} val {rec['val']:.5f} "
              f"{rec['time']:.0f} s", flush=True)

    return Learned(model, RECIPES[model], inner_val=model != "timing",
                   progress=show if model != "timing" else None)


def load_pool(motion: str, facegood: str | None):
    takes = {p.stem: load_take(p, fills=FILLS) for p in list_takes(motion)}
    fg = {f"facegood/{t.name}": t for t in load_facegood(facegood)} if facegood else {}
    return takes, fg


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", default=os.environ.get("MIMIKA_MOTION_DIR"))
    ap.add_argument("--facegood", default=os.environ.get("MIMIKA_FACEGOOD_DIR"))
    ap.add_argument("--models", default="timing", help="learned models (timing,seed,rtn)")
    ap.add_argument("--out", default="/tmp/mimika-transitions")
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--ship", action="store_true")
    a = ap.parse_args()
    if not a.data:
        sys.exit("set MIMIKA_MOTION_DIR or pass --data")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    IMG.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    takes, fg = load_pool(a.data, a.facegood)
    models = [m for m in a.models.split(",") if m]
    folds = leave_one_take_out(list(takes))
    loto = cached(out, "loto_baselines", a.reuse, lambda: run_protocol(
        takes, folds, [Baseline(b) for b in BASELINES]))
    for m in models:  # one cache file per fold: long trainings can be resumed
        loto = merge_methods(loto, concat([cached(
            out, f"loto_{m}_{f.test[0]}", a.reuse,
            lambda m=m, f=f: run_protocol(takes, [f], [learned(m)])) for f in folds]))
    results = {"loto": {"all": summarise(loto)}}
    print(f"\n## Leave-one-take-out ({len(folds)} folds)\n")
    print(table(results["loto"]["all"], "all held-out takes"))
    for name, _, _ in SIZE_BINS:
        results["loto"][name] = summarise(loto.size_bin(name))
        print(table(results["loto"][name], f"{name} transitions"))
    for t in sorted(takes):
        results["loto"][t] = summarise(loto.of_take(t))
        print(table(results["loto"][t], f"held-out take {t}"))
    print(timing_table(results["loto"]["all"]))
    if fg:
        ch = covered_channels(a.facegood)
        pool = {**{n: mask_take(t, ch) for n, t in takes.items()}, **fg}
        fold = [leave_one_person_out(list(takes), list(fg), ch, name="FACEGOOD")]
        lopo = cached(out, "lopo_baselines", a.reuse, lambda: run_protocol(
            pool, fold, [Baseline(b) for b in BASELINES]))
        for m in models:
            lopo = merge_methods(lopo, cached(out, f"lopo_{m}", a.reuse, lambda m=m: run_protocol(
                pool, fold, [learned(m)])))
        results["lopo"] = {"all": summarise(lopo)}
        print(f"\n## Leave-one-person-out (FACEGOOD, channels {' '.join(ch)})\n")
        print(table(results["lopo"]["all"], "second person"))
        for name, _, _ in SIZE_BINS:
            results["lopo"][name] = summarise(lopo.size_bin(name))
            print(table(results["lopo"][name], f"second person, {name} transitions"))
        print(timing_table(results["lopo"]["all"]))
    (out / "results.json").write_text(json.dumps(results, indent=1, default=float))
    for m in models:
        record = validation_record(loto, m, source=(
            f"leave-one-take-out over {len(takes)} Live Link Face takes"))
        print(m, json.dumps([{k: b.get(k) for k in ("name", "n", "rel", "use_model")}
                             for b in record["bins"]]))
        if a.ship and m in SHIP:
            ship(takes, m, record)
    plots(takes, loto, results, models)
    print(f"\ntotal {time.perf_counter() - t0:.0f} s")


def ship(takes, model: str, record) -> None:
    """Train ``model`` on every take (the seed LSTM early-stops on the last one) and write it
    with its leave-one-take-out validation record; the LSTM as float16 (half the size)."""
    names = tuple(sorted(takes))
    split = Split(names, (), ()) if model == "timing" else Split(names[:-1], names[-1:], ())
    ck = train(segment_split(takes, split), RECIPES[model],
               progress=learned(model).progress)
    ck["validation"] = record
    save_checkpoint(ck, SHIP[model], half=model != "timing")
    print(f"shipped {SHIP[model]} ({SHIP[model].stat().st_size / 1e3:.0f} kB, "
          f"{ck['n_params']} parameters, {ck['train_seconds']:.1f} s, best epoch "
          f"{ck['best_epoch']} of {len(ck['history'])})", flush=True)


def plots(takes, loto, results, models) -> None:
    # 1. change vs the best interpolator per size bin, with intervals
    fig, ax = plt.subplots(figsize=(7, 2.8), dpi=90)
    names = [m for m in loto.methods if m not in ("linear",)]
    parts = [("all", "all")] + [(b[0], b[0]) for b in SIZE_BINS]
    if "lopo" in results:
        parts.append(("lopo", "2nd person"))
    width = 0.8 / len(names)
    for k, name in enumerate(names):
        xs, ys, lo, hi = [], [], [], []
        for i, (key, _) in enumerate(parts):
            s = results["lopo"]["all"] if key == "lopo" else results["loto"][key]
            if not s.get("n") or name not in s["methods"]:
                continue
            r = s["methods"][name]
            xs.append(i + (k - (len(names) - 1) / 2) * width)
            ys.append(100 * r["rel"])
            lo.append(100 * (r["rel"] - r["rel_ci"][0]))
            hi.append(100 * (r["rel_ci"][1] - r["rel"]))
        ax.bar(xs, ys, width, yerr=[lo, hi], capsize=2, label=name)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(range(len(parts)), [p[1] for p in parts])
    ax.set_ylabel("MSE vs best\ninterpolator (%)")
    ax.legend(fontsize=7, ncol=len(names))
    ax.set_title("held-out takes (and the second person): change in MSE, 95 % bootstrap "
                 "intervals", fontsize=9)
    fig.tight_layout()
    fig.savefig(IMG / "transitions_protocol.png")
    plt.close(fig)
    # 2. timing: onset latency and peak velocity per AU group
    t = results["loto"]["all"]["timing"]
    fig, axes = plt.subplots(1, 2, figsize=(9, 2.8), dpi=90)
    keys = list(t["onset"])
    for ax, key, label in ((axes[0], "onset", "onset latency (frames)"),
                           (axes[1], "peak", "peak velocity (AU / frame)")):
        w = 0.8 / len(keys)
        for k, name in enumerate(keys):
            ax.bar(np.arange(len(t["groups"])) + (k - (len(keys) - 1) / 2) * w, t[key][name], w,
                   label=name, color="k" if name == "ground truth" else None)
        ax.set_xticks(range(len(t["groups"])), t["groups"], fontsize=8)
        ax.set_title(label + " — median over held-out transitions", fontsize=8)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="lower center", ncol=len(keys),
               fontsize=7)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    fig.savefig(IMG / "transitions_timing.png")
    plt.close(fig)
    # 3. examples: the largest held-out transitions of the range-of-motion take
    test = "alex_rom_3" if "alex_rom_3" in takes else sorted(takes)[0]
    rest = tuple(n for n in sorted(takes) if n != test)
    data = segment_split(takes, Split(rest, (), (test,)))
    model = load_state(train(data, RECIPES["timing"]))
    from mimika.learn.evaluate import baseline_generator
    from mimika.learn.train import generate

    items = sorted(data.items("test"), key=lambda x: -np.abs(x.target - x.start_frame).max())[:4]
    fig, axes = plt.subplots(1, 4, figsize=(12, 2.8), dpi=90)
    for ax, it in zip(axes, items, strict=False):
        j = int(np.argmax(np.abs(it.target - it.start_frame)))
        tt = np.arange(0, it.length + 1)
        ax.plot(np.arange(-6, 1), it.window[-7:, j], "k", lw=1)
        ax.plot(tt, np.r_[it.start_frame[j], it.frames[:, j]], "k", lw=2, label="recorded")
        for name, st in (("linear", "C0:"), ("hermite", "C2:")):
            y = baseline_generator(name)(it.window, it.target, it.length)
            ax.plot(tt, np.r_[it.start_frame[j], y[:, j]], st, lw=1.5, label=name)
        y = generate(model, it.window, it.target, it.length)
        ax.plot(tt, np.r_[it.start_frame[j], y[:, j]], "C3-", lw=1.5, label="timing (learned)")
        ax.set_title(f"{MODEL_CHANNELS[j]}: {it.source[-12:]} → {it.target_label[-12:]}",
                     fontsize=8)
        ax.set_xlabel("frame")
    axes[0].legend(fontsize=6)
    fig.suptitle(f"held-out take {test}: the four largest transitions (model trained on the "
                 "other takes)", fontsize=9)
    fig.tight_layout()
    fig.savefig(IMG / "transitions_examples.png")
    plt.close(fig)


if __name__ == "__main__":
    main()
