"""Where the teeth sit behind the lips, against the ICT Face Model (a real actor's scan).

Per head, at rest and in four mouth poses: how far the upper incisors' edge lies below the
inner edge of the upper lip (landmark 62), how far the lower incisors' edge stands above that
of the lower lip (66), the gap between the rows and between the lips (mm, at the midline);
``show`` is the share of the lip opening the upper teeth fill; ``behind`` how far each row's
front lies behind the inner edge of its lip (mm, along the face's forward axis). A person's
open smile shows the upper teeth and hides the lower ones (ICT: 6+12+25 shows 0.74 upper,
the lower edge at the lip); both rows edge to edge read as clenched teeth::

    MIMIKA_ICT_DIR=../shared/ict-facekit .venv/bin/python bench/teeth_seating.py
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

POSES = {"rest": {}, "25": {"AU25": 1.0}, "6+12+25": {"AU06": 1.0, "AU12": 1.0, "AU25": 1.0},
         "26": {"AU26": 1.0}, "27": {"AU27": 1.0}}


def incisors(head, rig) -> tuple[list[tuple[str, np.ndarray]], np.ndarray, np.ndarray]:
    """The teeth (vertices of ``teeth`` parts, not gums or tongue) as (object, vertex ids)
    and, over their stacked vertices, masks of the upper and lower front incisors (the lower
    row is what the jaw carries)."""
    sel = []
    for o in head.objects:
        ids = np.unique(np.concatenate([p.faces.ravel() for p in o.parts
                                        if p.material == "teeth"] or [np.zeros(0, int)]))
        if o.category == "teeth" and len(ids):
            sel.append((o.name, ids))
    rest, opened = rig.deform({}), rig.deform({"AU27": 1.0})
    v = np.concatenate([rest[n][i] for n, i in sel])
    moved = np.linalg.norm(np.concatenate([opened[n][i] for n, i in sel]) - v, axis=1)
    lower = moved > 0.3 * moved.max()
    skin = rest[head.objects[0].name]
    lm = head.landmarks
    mid = (np.abs(v[:, 0] - skin[lm[[48, 54]], 0].mean()) < 0.4) & (
        np.abs(v[:, 1] - skin[lm[[62, 66]], 1].mean()) < 1.5)
    rows = []
    for row in (mid & ~lower, mid & lower):
        rows.append(row & (v[:, 2] > v[row, 2].max() - 0.3))
    return sel, rows[0], rows[1]


def main(argv: list[str] | None = None) -> int:
    from mimika.face.heads import load_head

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--heads", default="amara,daniel,mei,tomas")
    a = p.parse_args(argv)
    heads = a.heads.split(",")
    if os.environ.get("MIMIKA_ICT_DIR"):
        heads = ["ict", *heads]
    print(f"{'head':7s} {'pose':8s} {'upper below lip':>16s} {'lower above lip':>16s} "
          f"{'teeth gap':>10s} {'lips gap':>9s} {'show':>5s} {'upper behind':>13s} "
          f"{'lower behind':>13s}")
    for name in heads:
        head, rig = load_head(name)
        sel, up, lo = incisors(head, rig)
        lm = head.landmarks
        for pose, aus in POSES.items():
            pos = rig.deform(aus)
            skin = pos[head.objects[0].name]
            t = np.concatenate([pos[n][i] for n, i in sel])
            ue, le = t[up, 1].min(), t[lo, 1].max()
            ul, ll = skin[lm[62], 1], skin[lm[66], 1]
            show = (ul - ue) / (ul - ll) if ul - ll > 0.3 else float("nan")
            behind = [10 * (skin[lm[k], 2] - t[row, 2].max()) for k, row in ((62, up), (66, lo))]
            print(f"{name:7s} {pose:8s} {10 * (ul - ue):13.1f} mm {10 * (le - ll):13.1f} mm "
                  f"{10 * (ue - le):7.1f} mm {10 * (ul - ll):6.1f} mm {show:5.2f} "
                  f"{behind[0]:10.1f} mm {behind[1]:10.1f} mm")
    return 0


if __name__ == "__main__":
    sys.exit(main())
