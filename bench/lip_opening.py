"""How far the lips part, seen from the front, against a real mouth's.

Per head: the lips' opening on the mouth's midline seen from straight ahead
(:func:`mimika.face.calibration.lip_opening`: full lips that touch in front count as closed,
however far apart their inner edges), in % of the inter-ocular distance, at rest, for AU25
from a trace (0.1) to the maximum, for AU10 and AU16 (which part them too) at 0.3 and 1, and
for the mouth targets of the speech visemes whose lips are apart
(``speech/data/visemes.json``) — each also as a ratio to the ICT Face Model's (a light-stage
scan of an actor), where ICT's lips stand at least 1 % IOD apart::

    MIMIKA_ICT_DIR=../shared/ict-facekit .venv/bin/python bench/lip_opening.py [--markdown]

``--bulletin``: also the example news bulletin's mouth track (``mimika news --example en``),
every 4th frame within a word: how often the lips stand apart (> 1 % IOD) and how far.
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
    p.add_argument("--bulletin", action="store_true", help="the example bulletin's openings")
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
    if a.bulletin:
        bulletin(heads)
    return 0


def bulletin(heads: list[str]) -> None:
    """Print, per head, the lips' openings over the example bulletin's words."""
    import numpy as np

    from mimika.face.calibration import lip_opening
    from mimika.face.heads import load_head
    from mimika.newsreader import example_bulletin, news_track, parse_article, speak_article

    art = parse_article(example_bulletin("en"))
    utt, paras = speak_article(art, lang="en")
    print("\nexample bulletin, every 4th frame within a word:")
    for h in heads:
        rig = load_head(h)[1]
        tr = news_track(art, utterance=utt, paragraph_starts=paras, fps=25.0,
                        supported=rig.supported).track
        t = np.arange(0, tr.n_frames, 4)
        t = t[[any(w.start <= k / tr.fps <= w.end for w in utt.words) for k in t]]
        face = [j for j, c in enumerate(tr.channels) if c[:3] not in ("AU5", "AU6", "bod")]
        op = np.array([lip_opening(rig, {tr.channels[j]: float(tr.values[k, j]) for j in face})
                       for k in t])  # head turns, gaze and body left out
        print(f"{h:8s} lips apart in {100 * np.mean(op > 0.01):3.0f} % of {len(t)} frames, "
              f"median opening {100 * np.median(op):.1f} % IOD")


if __name__ == "__main__":
    sys.exit(main())
