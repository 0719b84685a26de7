"""WGAN training speed: 50 000 generator iterations at n_critic 20 (issue 9 goal ≤ 15 min on
2 cores; seed 001: ≈ 50 min on a 6-core Ryzen 1600 in Keras).

Run: ``MIMIKA_MOTION_DIR=../shared/motion/livelinkface .venv/bin/python bench/bench_gan.py``
(``--iters 5000`` times 5 000 iterations and extrapolates to 50 000, saying so). Without the
data it trains on random frames of the same shape (9 918 × 20).
"""

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import report, single_core

single_core()

import numpy as np
import torch

from mimika.learn.wgan import WGANConfig, train_wgan

GOAL_S = 15 * 60
FULL = 50_000


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--iters", type=int, default=FULL)
    ap.add_argument("--n-critic", type=int, default=20)
    ap.add_argument("--threads", type=int, default=1)
    a = ap.parse_args()
    torch.set_num_threads(a.threads)
    if os.environ.get("MIMIKA_MOTION_DIR"):
        from mimika.learn.gan_data import load_frames

        train, test = load_frames().split()
        x, xt, what = train.values, test.values, "Live Link takes (test: apfel)"
    else:
        rng = np.random.default_rng(0)
        x = rng.uniform(0, 1, (9918, 20)).astype(np.float32)
        xt, what = x[:1928], "random frames"
    train_wgan(x[:256], xt[:64], WGANConfig(iters=50, n_critic=a.n_critic))  # warm-up
    t0 = time.perf_counter()
    res = train_wgan(x, xt, WGANConfig(iters=a.iters, n_critic=a.n_critic))
    wall = time.perf_counter() - t0
    rate = a.iters / wall
    full = FULL / rate
    print(f"WGAN d=4 n_critic {a.n_critic}, batch 64, {len(x)} frames × {x.shape[1]} channels "
          f"({what}), {a.threads} torch thread(s), load average {os.getloadavg()[0]:.1f}")
    report("generator iterations/s", rate, "it/s")
    report("critic steps/s", rate * a.n_critic, "steps/s")
    kind = "measured" if a.iters >= FULL else f"extrapolated from {a.iters} iterations"
    print(f"{FULL} iterations: {full / 60:.1f} min ({kind}); goal {GOAL_S / 60:.0f} min → "
          f"ratio {full / GOAL_S:.2f} (< 1 meets it); seed ≈ 50 min → {50 * 60 / full:.1f}× "
          f"faster; final W train {np.mean(res.w_train[-100:]):.4f}")


if __name__ == "__main__":
    main()
