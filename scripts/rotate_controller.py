"""Turn the shipped controller's sliders so every slider end gives a distinct face
(:mod:`mimika.learn.sliders`: a rotation of the WAE's latent space, the same model).

    .venv/bin/python scripts/rotate_controller.py [--model PATH] [-o PATH] [--steps 400]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import torch

from mimika.learn.controller import Controller, shipped_model
from mimika.learn.sliders import distinct_rotation, distinctness, rotate_state
from mimika.learn.wgan import load_checkpoint, save_checkpoint

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default=None, help="checkpoint (default: the shipped WAE)")
    ap.add_argument("-o", "--output", default=None, help="default: overwrite --model")
    ap.add_argument("--steps", type=int, default=400)
    a = ap.parse_args()
    src = Path(a.model) if a.model else shipped_model()
    state = load_checkpoint(src)
    c = Controller(state, path=src)
    _, w0, p0 = distinctness(c, torch.eye(c.latent_dim))
    r = distinct_rotation(c, a.steps)
    _, w1, p1 = distinctness(c, torch.from_numpy(r).float())
    print(f"weakest end change {w0:.3f} → {w1:.3f}, closest pair of ends {p0:.3f} → {p1:.3f} "
          "(AU units, L2 over 20 AUs)")
    print(f"wrote {save_checkpoint(a.output or src, rotate_state(state, r))}")
    sys.exit(0)
