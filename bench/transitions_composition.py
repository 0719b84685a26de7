"""Seed 000's training-composition study (models a–i), on the transitions our takes contain.

    MIMIKA_MOTION_DIR=../shared/motion/livelinkface .venv/bin/python \
        bench/transitions_composition.py [--models seed,timing] [--out DIR] [--reuse] \
        [--only abcdefghi] [--seed-epochs N]

The seed trained its LSTM nine times on different selections of its transitions and compared
transitions from and to one expression ("happy", the one recorded with every other):
a — none of them; b–e — both directions with one more partner expression each; f — only the
from-transitions; g / h — one / three variants of every pair; i — everything. Our takes have
no recorded expression set, so the nearest we can do is on the segmented holds' library labels:
the *focal* class is the labelled class with the most partner classes (as "happy" was), the
test set holds out the last two occurrences of every focal pair (one if it occurs twice; the
seed evaluated two variants of each), and the compositions are drawn from the rest.
Models are trained with the shipped recipes (seed LSTM: up to 60 epochs, early stopping on 10 %
of the other transitions); ``--seed-epochs N`` runs a reduced study (the seed LSTM for N epochs,
lr ×0.1 after half of them, no early stop); each model is cached in ``--out``, and ``--only``
trains a subset of a–i (e.g. two processes on two cores, then one ``--reuse`` run for the tables).
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import sys
import time
from collections import Counter, defaultdict
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from mimika.learn.data import FILLS, Split, list_takes, load_take
from mimika.learn.evaluate import baseline_generator, model_generator
from mimika.learn.metrics import conspicuous, jump_percent
from mimika.learn.train import RECIPES, Prepared, load_state, segment_takes, train

MODELS = "abcdefghi"


def label(x: str) -> str:
    return x.removeprefix("template/")


def compositions(units: dict, focal: str):
    """(test unit keys, {model: train unit keys}, val keys, partner order, description)."""
    pairs = defaultdict(list)  # (from, to) → unit keys in (take, start) order
    for k in sorted(units):
        s, t = units[k]
        if focal in (s, t) and s != t and "unlabelled" not in (s, t):
            pairs[(s, t)].append(k)
    test = {k for v in pairs.values() for k in v[len(v) - min(2, len(v) - 1):]}
    focal_keys = {k for v in pairs.values() for k in v}
    base = [k for k in sorted(units) if k not in focal_keys]
    val = set(base[::10])
    base = [k for k in base if k not in val]
    pool = {p: [k for k in v if k not in test] for p, v in pairs.items()}
    partner = Counter()
    for (s, t), v in pool.items():
        partner[t if s == focal else s] += len(v)
    order = [p for p, _ in partner.most_common()]

    def with_partners(ps):
        return [k for (s, t), v in pool.items() if (t if s == focal else s) in ps for k in v]

    comp = {"a": list(base)}
    steps = [order[:1], order[:2], order[:3], order]
    for name, ps in zip("bcde", steps, strict=True):
        comp[name] = base + with_partners(ps)
    comp["f"] = base + [k for (s, _), v in pool.items() if s == focal for k in v]
    comp["g"] = base + [v[0] for v in pool.values() if v]
    comp["h"] = base + [k for v in pool.values() for k in v[:3]]
    comp["i"] = base + [k for v in pool.values() for k in v]
    return sorted(test), comp, sorted(val), order


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", default=os.environ.get("MIMIKA_MOTION_DIR"))
    ap.add_argument("--models", default="seed,timing")
    ap.add_argument("--out", default="/tmp/mimika-composition")
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--only", default=MODELS, help="train only these of a–i (then stop)")
    ap.add_argument("--seed-epochs", type=int, default=0,
                    help="reduced study: the seed LSTM for this many epochs (0: its recipe)")
    a = ap.parse_args()
    recipes = dict(RECIPES)
    if a.seed_epochs:
        n = a.seed_epochs
        recipes["seed"] = replace(RECIPES["seed"], epochs=n, decay_every=max(1, n // 2),
                                  restore_every=max(1, n // 4), patience=0)
    if not a.data:
        sys.exit("set MIMIKA_MOTION_DIR or pass --data")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    takes = {p.stem: load_take(p, fills=FILLS) for p in list_takes(a.data)}
    seg, holds, trans = segment_takes(takes)
    variants = defaultdict(list)
    for v in trans.values():
        for x in v:
            variants[(x.take, x.start, x.length)].append(x)
    units = {k: (label(v[0].source), label(v[0].target_label)) for k, v in variants.items()}
    partners = defaultdict(set)
    for s, t in units.values():
        if s != t and "unlabelled" not in (s, t):
            partners[s].add(t)
            partners[t].add(s)
    count = Counter(c for st in units.values() for c in st)
    focal = max(partners, key=lambda c: (len(partners[c]), count[c]))
    test, comp, val, order = compositions(units, focal)
    print(f"focal class: {focal} (partners, most transitions first: {', '.join(order)}); "
          f"{len(test)} held-out test transitions, {len(val)} validation")
    print("\n| model | training transitions | of them focal ↔ partner |\n|---|---:|---:|")
    for m in MODELS:
        nf = sum(focal in units[k] and units[k][0] != units[k][1]
                 and "unlabelled" not in units[k] for k in comp[m])
        print(f"| {m} | {len(comp[m])} | {nf} |")

    def linear(k):
        return variants[k][0]

    test_items = [linear(k) for k in test]
    gens = {"linear": baseline_generator("linear")}
    results = {}
    for kind in a.models.split(","):
        for m in MODELS:
            key = out / f"{kind}_{m}.pkl"
            if m not in a.only:
                continue
            if a.reuse and key.exists():
                ck = pickle.loads(key.read_bytes())
            else:
                t0 = time.perf_counter()
                data = Prepared(takes, Split(("train",), ("val",), ()), seg, holds,
                                {"train": [x for k in comp[m] for x in variants[k]],
                                 "val": [linear(k) for k in val]})
                ck = train(data, recipes[kind])
                key.write_bytes(pickle.dumps(ck))
                print(f"  {kind} {m}: {len(ck['history'])} epochs, best {ck['best_epoch']}, "
                      f"{time.perf_counter() - t0:.0f} s", flush=True)
            gens[f"{kind} {m}"] = model_generator(load_state(ck))
        results[kind] = True
    if set(a.only) != set(MODELS):
        return
    rows = {}
    for name, g in gens.items():
        out_frames = [g(t.window, t.target, t.length) for t in test_items]
        rows[name] = [{"mse": float(np.mean((o - t.frames) ** 2)),
                       "jump": jump_percent(t.window, o),
                       "consp": conspicuous(t.window, o, t.frames).any}
                      for o, t in zip(out_frames, test_items, strict=True)]
    for kind in results:
        print(f"\n### {kind}: MSE ×10³ per held-out transition (* conspicuous; ° the pair is in "
              "no training set of this model)\n")
        print("| from → to | " + " | ".join(MODELS) + " | linear |\n|---|" + "---:|" * 10)
        for j, k in enumerate(test):
            s, t = units[k]
            cells = []
            for m in MODELS:
                r = rows[f"{kind} {m}"][j]
                seen = any(units[q] in ((s, t), (t, s)) for q in comp[m])
                cells.append(f"{1e3 * r['mse']:.1f}{'*' if r['consp'] else ''}"
                             f"{'' if seen else '°'}")
            lin = rows["linear"][j]
            print(f"| {s} → {t} | " + " | ".join(cells) + f" | {1e3 * lin['mse']:.1f} |")
        mean = {m: np.mean([r["mse"] for r in rows[f"{kind} {m}"]]) for m in MODELS}
        jump = {m: np.mean([r["jump"] for r in rows[f"{kind} {m}"]]) for m in MODELS}
        cons = {m: sum(r["consp"] for r in rows[f"{kind} {m}"]) for m in MODELS}
        print("| **mean** | " + " | ".join(f"{1e3 * mean[m]:.1f}" for m in MODELS) +
              f" | {1e3 * np.mean([r['mse'] for r in rows['linear']]):.1f} |")
        print("| jump % | " + " | ".join(f"{jump[m]:.2f}" for m in MODELS) + " | |")
        print("| conspicuous | " + " | ".join(str(cons[m]) for m in MODELS) + " | |")
        sym = "abcde"
        r = np.corrcoef([len(comp[m]) for m in sym], [jump[m] for m in sym])[0, 1]
        print(f"\ncorrelation of jump % with training transitions over a–e: r = {r:+.2f} "
              "(seed: −0.92)")
        fr = [j for j, k in enumerate(test) if units[k][0] == focal]
        to = [j for j, k in enumerate(test) if units[k][1] == focal]
        for m in ("f", "i"):
            print(f"model {m}: MSE ×10³ from-{focal} {1e3 * np.mean([rows[f'{kind} {m}'][j]['mse'] for j in fr]):.1f}, "  # noqa: E501
                  f"to-{focal} {1e3 * np.mean([rows[f'{kind} {m}'][j]['mse'] for j in to]):.1f}")
    (out / "composition.json").write_text(json.dumps(
        {"focal": focal, "partners": order, "test": [list(units[k]) for k in test],
         "sizes": {m: len(comp[m]) for m in MODELS}, "rows": rows}, indent=1, default=float))


if __name__ == "__main__":
    main()
