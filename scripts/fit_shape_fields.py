"""Refit the shipped per-shape fields from a rig's expression shapes (rich family) and write
their accuracy report:

* ``ict`` (default): the ICT Face Model's 53 shapes → ``face/data/ict_shape_fields.json``,
  ``docs/fit/accuracy_shapes.md`` (≈ 10 min on 2 shared cores; needs ``$MIMIKA_ICT_DIR``);
* ``makehuman``: MakeHuman's ARKit faceunits on its average person (no hair, no clothes)
  → ``face/data/makehuman_shape_fields.json``, ``docs/fit/accuracy_shapes_makehuman.md``
  (≈ 4 min).

    MIMIKA_ICT_DIR=~/ICT-FaceKit python scripts/fit_shape_fields.py [--style makehuman]
"""

import argparse
import json
import logging
import sys
from pathlib import Path

from mimika.face.fitting.report import report_markdown
from mimika.face.fitting.shapes import fit_character_shapes, fit_ict_shapes
from mimika.face.heads import load_head
from mimika.face.heads.character import base_character, character_shapes
from mimika.face.rigging.template import face_template

ROOT = Path(__file__).resolve().parents[1]

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--style", choices=("ict", "makehuman"), default="ict")
    style = ap.parse_args().style
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    # each style keeps its template for placing landmarks: openings as found, face surface
    if style == "ict":
        res = fit_ict_shapes()
        res.document["source"].update(face_template(load_head("ict")[0]))
    else:
        res = fit_character_shapes()
        res.document["source"].update(face_template(character_shapes(base_character())[0]))
    out = ROOT / "src" / "mimika" / "face" / "data" / f"{style}_shape_fields.json"
    out.write_text(json.dumps(res.document, separators=(",", ":")))
    report = "accuracy_shapes.md" if style == "ict" else f"accuracy_shapes_{style}.md"
    (ROOT / "docs" / "fit" / report).write_text(report_markdown(res.accuracy))
    print(f"wrote {out}: {len(res.document['shapes'])} shapes in {res.seconds:.0f} s; mean "
          f"e/d_max (held-out vertices) {100 * res.mean_e_rel:.2f} %")
    sys.exit(0)
