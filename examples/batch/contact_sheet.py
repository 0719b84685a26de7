"""A labelled contact sheet of part of a batch output, chosen from its labels.csv.

    python examples/batch/contact_sheet.py stimuli/ docs/img/batch-stimuli-sheet.png \
        --aus AU01 AU02 AU04 AU06 AU12 AU15 --view front --tile 192x144

Rows are the chosen single-AU items, columns their intensities (as rendered, in plan order).
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np
from PIL import Image

from mimika.render import contact_sheet, save_png

LETTERS = {"0.2": "A", "0.4": "B", "0.6": "C", "0.8": "D", "1": "E"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("batch", type=Path, help="a mimika batch output folder")
    ap.add_argument("output", type=Path, help="PNG to write")
    ap.add_argument("--aus", nargs="+", required=True, help="AU sets (content column) to show")
    ap.add_argument("--view", default="front")
    ap.add_argument("--tile", default="192x144", help="tile size WxH")
    args = ap.parse_args()
    w, h = (int(x) for x in args.tile.split("x"))
    with open(args.batch / "labels.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f)
                if r["view"] == args.view and r["content"] in args.aus]
    rows.sort(key=lambda r: (args.aus.index(r["content"]), float(r["intensity"] or 0)))
    if not rows:
        raise SystemExit(f"no items of {args.aus} in view {args.view!r} in {args.batch}")
    images, labels = [], []
    for r in rows:
        with Image.open(args.batch / r["file"]) as im:
            images.append(np.asarray(im.convert("RGB").resize((w, h), Image.Resampling.LANCZOS)))
        k = r["intensity"]
        labels.append(f"{r['content']} {LETTERS.get(k, k)} ({k})")
    columns = len({r["intensity"] for r in rows})
    sheet = contact_sheet(images, labels, columns=columns,
                          title=f"mimika batch: {', '.join(args.aus)} at A to E ({args.view})")
    save_png(sheet, args.output)
    print(f"wrote {args.output} ({len(images)} tiles)")


if __name__ == "__main__":
    main()
