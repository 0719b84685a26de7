"""AU calibration against a physical reference: how far each AU moves each head's face.

For every seed-002 face AU (and mimika's extra ones) at intensity 1, the peak displacement and
its extent (the area-weighted 95th percentile over the face front), in inter-ocular units,
on the four preset characters and the built-in head, each divided by the ICT Face Model's
(light-stage scans of a real actor). Calibrated: both ratios in 0.7–1.4 (FACS exceptions, where
the extent is not compared, are marked "–"). Then how the motion is shaped: per AU and head
the landmark shape error against ICT (0: the 68 landmarks move as ICT's do; 1: as far off as
not moving at all); and how far the lid AUs open or narrow the eyes, against ICT's::

    MIMIKA_ICT_DIR=../shared/ict-facekit .venv/bin/python bench/au_calibration.py [--markdown]
"""

from __future__ import annotations

import argparse
import sys

HEADS = ("amara", "daniel", "mei", "tomas", "builtin")


def main(argv: list[str] | None = None) -> int:
    from mimika.face.calibration import (
        EXTRA_AUS,
        SEED_AUS,
        TOLERANCE,
        au_motion,
        lid_motion,
        ratios,
    )
    from mimika.face.heads import load_head

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--heads", default=",".join(HEADS))
    p.add_argument("--markdown", action="store_true", help="a table for the docs")
    a = p.parse_args(argv)
    heads = a.heads.split(",")
    codes = (*SEED_AUS, *EXTRA_AUS)
    ict = load_head("ict")[1]
    ref = au_motion(ict, codes)
    rigs = {h: load_head(h)[1] for h in heads}
    rows = {h: ratios(au_motion(rigs[h], codes), ref) for h in heads}
    lo, hi = TOLERANCE
    md = a.markdown
    head = ["AU", "ICT peak / extent (% IOD)", *heads]
    print(("| " + " | ".join(head) + " |\n|" + "---|" * len(head)) if md else
          f"{'AU':5s} {'ICT %IOD':>12s}  " + "  ".join(f"{h:>11s}" for h in heads))
    bad = 0
    for c in codes:
        cells = []
        for h in heads:
            if c not in rows[h]:
                cells.append("n/a")
                continue
            rp, re_ = rows[h][c]
            ok = all(x is None or lo <= x <= hi for x in (rp, re_))
            bad += not ok
            cells.append("/".join("–" if x is None else f"{x:.2f}" for x in (rp, re_))
                         + ("" if ok else " ✗"))
        r = f"{100 * ref[c][0]:.1f} / {100 * ref[c][1]:.1f}"
        print(f"| {c} | {r} | " + " | ".join(cells) + " |" if md else
              f"{c:5s} {r:>12s}  " + "  ".join(f"{x:>11s}" for x in cells))
    n = sum(len(r) for r in rows.values())
    print(f"\n{n - bad} of {n} head × AU pairs within {lo}–{hi}× ICT (peak / extent)\n")
    shapes = {h: shape_errors(rigs[h], ict, codes) for h in heads}
    print(("| AU | " + " | ".join(heads) + " |\n|" + "---|" * (len(heads) + 1)) if md else
          f"{'AU':5s} shape error: " + "  ".join(f"{h:>7s}" for h in heads))
    for c in codes:
        cells = [f"{shapes[h][c]:.2f}" if c in shapes[h] else "n/a" for h in heads]
        print(f"| {c} | " + " | ".join(cells) + " |" if md else
              f"{c:5s}              " + "  ".join(f"{x:>7s}" for x in cells))
    ref_lids = lid_motion(ict)
    lids = {h: lid_motion(rigs[h]) for h in heads}
    print(("\n| AU | ICT eye opening (% IOD) | " + " | ".join(heads) + " |\n|"
           + "---|" * (len(heads) + 2)) if md else
          f"\n{'AU':5s} {'eye opening':>12s}  " + "  ".join(f"{h:>7s}" for h in heads))
    for c, r in ref_lids.items():
        cells = [f"{lids[h][c] / r:.2f}" + ("" if lo <= lids[h][c] / r <= hi else " ✗")
                 if c in lids[h] else "n/a" for h in heads]
        print(f"| {c} | {100 * r:+.1f} | " + " | ".join(cells) + " |" if md else
              f"{c:5s} {100 * r:+11.1f}%  " + "  ".join(f"{x:>7s}" for x in cells))
    return 0


def shape_errors(rig, ref_rig, codes) -> dict[str, float]:
    """Landmark shape error of each AU of ``codes`` the rig models against ``ref_rig``'s."""
    from mimika.face.calibration import au_displacement, landmark_motion, shape_error

    def lm(r, c):
        return landmark_motion(au_displacement(r, c), r.head)

    return {c: shape_error(lm(rig, c), lm(ref_rig, c)) for c in codes
            if c in rig.supported and c in ref_rig.supported}


if __name__ == "__main__":
    sys.exit(main())
