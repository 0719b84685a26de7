"""Contact sheet of the controller's sliders on the default head, and how distinct they are.

    .venv/bin/python bench/controller_sheet.py [--model default|seed|PATH] [--head HEAD] \
        [-o docs/img/controller_sheet.png]

Rows = sliders z1…zd, columns = −3 … 3 (the others at 0), rendered on ``--head`` (default:
whatever ``mimika.face.heads.load_head()`` loads — re-run after the default head changes).
Prints, per slider, how far its ends move the face from the middle one (largest AU change, and
the mean absolute pixel change over the pixels where the face changes) and, over every pair of
slider ends, the smallest difference — a slider that duplicates another, or does nothing
visible on this head, shows up there.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from mimika.face.heads import load_head
from mimika.learn.controller import TRAVERSAL, Controller
from mimika.render import contact_sheet


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--model", default=None, help="shipped name or checkpoint (default: the "
                                                   "shipped controller)")
    ap.add_argument("--head", default=None, help="head (default: load_head()'s default)")
    ap.add_argument("-o", "--output", default=str(ROOT / "docs/img/controller_sheet.png"))
    a = ap.parse_args()
    c = Controller.load(a.model)
    head, rig = load_head() if a.head is None else load_head(a.head)
    n = len(TRAVERSAL)
    # 240-pixel renders cropped to the face (brows to chin), so small changes show
    images = [np.ascontiguousarray(im[60:210, 50:190])
              for im in c.traversal_images(head=rig, tile=(240, 240))]
    names = [f"z{k // n + 1}={TRAVERSAL[k % n]:+g}" for k in range(len(images))]
    sheet = contact_sheet(images, names, columns=n, title=(
        f"mimika controller ({c.kind.upper()}, {c.latent_dim} sliders) on the {head.name} "
        "head: rows z1..z%d, columns -3 .. 3, others 0" % c.latent_dim))
    from PIL import Image  # a quantised PNG keeps the docs small

    Image.fromarray(sheet).quantize(colors=48, method=Image.Quantize.MEDIANCUT).save(
        a.output, optimize=True)
    print(f"wrote {a.output} ({sheet.shape[1]}x{sheet.shape[0]})")
    img = np.array(images, np.float32).reshape(c.latent_dim, n, *images[0].shape)
    grid = c.traversal()  # (d, n, K) AU frames
    mid = n // 2
    print("\n| slider | largest AU change at −3 / +3 | pixel change at −3 / +3 (mean |Δ| over "
          "changed pixels, % of pixels) |\n|---|---|---|")
    ends = []
    for i in range(c.latent_dim):
        cells_au, cells_px = [], []
        for j in (0, n - 1):
            du = grid[i, j] - grid[i, mid]
            k = int(np.argmax(np.abs(du)))
            cells_au.append(f"{c.channels[k]} {du[k]:+.2f}")
            diff = np.abs(img[i, j] - img[i, mid]).mean(axis=2)
            changed = diff > 2.0
            cells_px.append(f"{diff[changed].mean() if changed.any() else 0:.1f} "
                            f"({100 * changed.mean():.1f} %)")
            ends.append((f"z{i + 1}{'−' if j == 0 else '+'}", img[i, j]))
        print(f"| z{i + 1} | {' / '.join(cells_au)} | {' / '.join(cells_px)} |")
    pairs = [(float(np.abs(a[1] - b[1]).mean()), a[0], b[0])
             for x, a in enumerate(ends) for b in ends[x + 1:]]
    worst = sorted(pairs)[:3]
    print("\nmost similar slider ends (mean |Δ| over the whole image): " +
          ", ".join(f"{a} vs {b}: {d:.2f}" for d, a, b in worst))


if __name__ == "__main__":
    main()
