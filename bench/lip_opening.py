"""How far the lips part, seen from the front, against a real mouth's.

Per head: the lips' opening on the mouth's midline seen from straight ahead
(:func:`mimika.face.calibration.lip_opening`: full lips that touch in front count as closed,
however far apart their inner edges), in % of the inter-ocular distance, at rest, for AU25
from a trace (0.1) to the maximum, for AU10 and AU16 (which part them too) at 0.3 and 1, and
for the mouth targets of the speech visemes whose lips are apart
(``speech/data/visemes.json``) — each also as a ratio to the ICT Face Model's (a light-stage
scan of an actor), where ICT's lips stand at least 1 % IOD apart::

    MIMIKA_ICT_DIR=../shared/ict-facekit .venv/bin/python bench/lip_opening.py [--markdown]
"""

from __future__ import annotations

import argparse
import json
import sys
from importlib import resources

HEADS = ("ict", "amara", "daniel", "mei", "tomas", "builtin")
AU25 = (0.1, 0.2, 0.36, 0.6, 1.0)


def cases() -> dict[str, dict[str, float]]:
    """Label → AU values: rest, AU25 at each of :data:`AU25`, AU10 and AU16, the visemes with
    lips apart."""
    classes = json.loads(resources.files("mimika.speech").joinpath(
        "data", "visemes.json").read_text("utf-8"))["classes"]
    out: dict[str, dict[str, float]] = {"rest": {}}
    out.update({f"AU25 {k:g}": {"AU25": k} for k in AU25})
    out.update({f"{c} {k:g}": {c: k} for c in ("AU10", "AU16") for k in (0.3, 1.0)})
    out.update({name: c["targets"] for name, c in classes.items()
                if name not in ("sil", "bilabial")})
    return out


def main(argv: list[str] | None = None) -> int:
    from mimika.face.calibration import TOLERANCE, lip_opening
    from mimika.face.heads import load_head

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--heads", default=",".join(HEADS))
    p.add_argument("--markdown", action="store_true", help="a table for the docs")
    a = p.parse_args(argv)
    heads = a.heads.split(",")
    table = {h: {c: lip_opening(load_head(h)[1], aus) for c, aus in cases().items()}
             for h in heads}
    ref = table.get("ict")
    lo, hi = TOLERANCE
    cols = [f"{h} (× ICT)" if ref and h != "ict" else h for h in heads]
    print(("| pose | " + " | ".join(cols) + " |\n|" + "---|" * (len(heads) + 1)) if a.markdown
          else f"{'pose (% IOD)':24s}" + "".join(f"{c:>18s}" for c in cols))
    n = ok = 0
    for c in cases():
        cells = []
        for h in heads:
            x = table[h][c]
            cell = f"{100 * x:.1f}"
            if ref and h != "ict" and ref[c] >= 0.01:
                r = x / ref[c]
                n += 1
                ok += lo <= r <= hi
                cell += f" ({r:.2f})"
            cells.append(cell)
        print(f"| {c} | " + " | ".join(cells) + " |" if a.markdown else
              f"{c:24s}" + "".join(f"{x:>18s}" for x in cells))
    if ref:
        print(f"\n{ok} of {n} head × pose pairs within {lo}–{hi}× ICT's opening")
    return 0


if __name__ == "__main__":
    sys.exit(main())
