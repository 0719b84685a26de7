"""Seed 000's LSTM as shipped (``transitions_seed.pt``) against the interpolators and the timing
model, by the evaluation protocol: on its held-out test take, and on the second person.

    MIMIKA_MOTION_DIR=../shared/motion/livelinkface MIMIKA_FACEGOOD_DIR=../shared/motion/facegood \
        .venv/bin/python bench/transitions_seed_eval.py [--model PATH]

The shipped seed model is trained once (``mimika train transitions --model seed``: train
``S07-001``, ``S88-001``, ``alex_rom_3``, early stopping on ``facial``), so it is scored on the
one take it never saw (``apfel``) — one fold of the leave-one-take-out protocol, with the timing
model retrained for that fold as in ``bench/transitions_report.py`` — and on FACEGOOD's second
person (the 13 channels its rig maps to). Tables as ``transitions_report.py`` prints them.
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT / "src"))

from mimika.learn.evaluate import model_generator
from mimika.learn.facegood import covered_channels
from mimika.learn.protocol import (
    SIZE_BINS,
    Baseline,
    Fold,
    leave_one_person_out,
    mask_take,
    run_protocol,
    summarise,
)
from mimika.learn.train import load_model
from transitions_report import BASELINES, learned, load_pool, table

TRAIN, VAL, TEST = ("S07-001", "S88-001", "alex_rom_3"), ("facial",), ("apfel",)


@dataclass
class Fixed:
    """A model trained beforehand (nothing to fit per fold)."""

    name: str
    path: Path
    batched: bool = True

    def fit(self, data):
        return model_generator(load_model(self.path))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", default=os.environ.get("MIMIKA_MOTION_DIR"))
    ap.add_argument("--facegood", default=os.environ.get("MIMIKA_FACEGOOD_DIR"))
    ap.add_argument("--model", default=str(ROOT / "src/mimika/learn/data/transitions_seed.pt"))
    a = ap.parse_args()
    if not a.data:
        sys.exit("set MIMIKA_MOTION_DIR or pass --data")
    takes, fg = load_pool(a.data, a.facegood)
    seed = Fixed("seed (LSTM)", Path(a.model))
    fold = Fold(f"take {TEST[0]}", TRAIN, TEST, VAL)
    res = run_protocol(takes, [fold], [*(Baseline(b) for b in BASELINES), learned("timing"),
                                       seed])
    print(table(summarise(res), f"held-out take {TEST[0]}"))
    for name, _, _ in SIZE_BINS:
        print(table(summarise(res.size_bin(name)), f"held-out take {TEST[0]}, {name}"))
    if fg:
        ch = covered_channels(a.facegood)
        pool = {**{n: mask_take(t, ch) for n, t in takes.items()}, **fg}
        lopo = leave_one_person_out(list(takes), list(fg), ch, name="FACEGOOD")
        res = run_protocol(pool, [lopo], [*(Baseline(b) for b in BASELINES), seed])
        print(table(summarise(res), "second person (FACEGOOD)"))


if __name__ == "__main__":
    main()
