"""Expression and AU sheets of every preset and the built-in head (docs/img/expressions-*.png,
docs/img/au-sheet-*.png).

    PYTHONPATH=src python scripts/expression_sheets.py [--out docs/img] [--heads amara,…]

Per head, the library's seven expressions (neutral and the six basic emotions) at intensity
0.6 and 1.0, front and three-quarter, with their appearance changes, in the ``studio`` light
(``mimika pose --expression E --intensity K``); and every modelled AU at full intensity, framed
closer for the wrinkles (``mimika pose --grid --face-height 0.75``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mimika.face.heads import load_head
from mimika.knowledge.expressions import expression_aus
from mimika.pose import au_sheet
from mimika.render import Renderer, contact_sheet, save_png

EXPRESSIONS = ("neutral", "happiness", "sadness", "surprise", "fear", "anger", "disgust")
HEADS = ("amara", "daniel", "mei", "tomas", "builtin")


def expression_sheet(name: str, tile: int = 256):
    _, rig = load_head(name)
    images, labels = [], []
    with Renderer(rig.head, size=(tile, tile)) as r:
        for view in ("front", "three-quarter"):
            for k in (0.6, 1.0):
                for e in EXPRESSIONS:
                    aus = expression_aus(e, k) if e != "neutral" else {}
                    images.append(r.render(rig.deform(aus), view=view, aus=aus))
                    labels.append(f"{e} {k:g}" if e != "neutral" else "neutral")
    return contact_sheet(images, labels, columns=len(EXPRESSIONS),
                         title=f"mimika: {name}, the library's expressions at 0.6 and 1.0, "
                               "front and three-quarter")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=Path("docs/img"))
    p.add_argument("--heads", default=",".join(HEADS))
    a = p.parse_args(argv)
    for name in a.heads.split(","):
        save_png(expression_sheet(name), a.out / f"expressions-{name}.png")
        save_png(au_sheet(head=load_head(name)[1], fill=0.75), a.out / f"au-sheet-{name}.png")
        print(f"wrote {a.out}/expressions-{name}.png and au-sheet-{name}.png", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
