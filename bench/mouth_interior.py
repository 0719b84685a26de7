"""What an open mouth shows, per head: the dark of the mouth over the tongue, no unlit lining.

Renders each head (480 × 480, the studio light) with the jaw dropped (AU26, AU27) from the
front and from three-quarter and measures, inside the lip opening (landmarks 60–67): the mean
luma of its upper half over its lower half from the front (a photograph: the dark of the mouth
above, the tongue behind the lower teeth below; a wall of tongue filling the opening is near
1), the share of its pixels that are pure black (luma < 6: unlit lining, a void) from
three-quarter, and how many pixels of teeth or tongue show outside the opening (through the
skin)::

    .venv/bin/python bench/mouth_interior.py
    .venv/bin/python bench/mouth_interior.py --heads amara,builtin
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

HEADS = ("amara", "daniel", "mei", "tomas", "builtin")
SIZE = (480, 480)


def measure(name: str, au: str) -> dict[str, float]:
    """The measures of ``name`` with ``au`` at 1.0 (see the module's docstring)."""
    from scipy import ndimage

    from mimika.face.heads import load_head
    from mimika.render import Renderer
    from mimika.render.artefacts import id_layers

    head, rig = load_head(name)
    aus = rig.check({au: 1.0})
    pos = rig.deform(aus)
    objs = list(rig.head.objects)
    inner = [k for k, o in enumerate(objs) if o.category == "teeth"]
    meshes = [(pos[o.name], o.faces) for o in objs]
    out = {}
    with Renderer(rig.head, size=SIZE) as r:
        for view in ("front", "three-quarter"):
            luma = r.render(pos, view=view, aus=aus).astype(float).mean(2)
            cam = r.camera(view)
            mouth = cam.outline_mask(head.landmark_points(pos)[60:68], SIZE)
            if view == "front":
                rows = np.nonzero(mouth)[0]
                upper = mouth & (np.arange(SIZE[1])[:, None] < np.median(rows))
                out["upper/lower"] = luma[upper].mean() / max(luma[mouth & ~upper].mean(), 1e-6)
            else:
                out["black ¾"] = float((luma[mouth] < 6).mean())
            top = id_layers(meshes, cam, SIZE)[0].obj
            near = ndimage.binary_dilation(mouth, iterations=3)
            out[f"through skin {view[0]}"] = int((np.isin(top, inner) & ~near).sum())
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--heads", default=",".join(HEADS))
    args = p.parse_args(argv)
    cols = ("upper/lower", "black ¾", "through skin f", "through skin t")
    print(f"{'head':8s} {'AU':5s} " + " ".join(f"{c:>15s}" for c in cols))
    for name in args.heads.split(","):
        for au in ("AU26", "AU27"):
            m = measure(name, au)
            cells = " ".join(f"{m[c]:15.2f}" if isinstance(m[c], float) else f"{m[c]:15d}"
                             for c in cols)
            print(f"{name:8s} {au:5s} {cells}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
