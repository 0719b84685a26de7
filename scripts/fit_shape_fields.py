"""Refit the shipped per-shape fields (src/mimika/face/data/ict_shape_fields.json) from the ICT
Face Model's 53 expression shapes, rich family, and write their accuracy report
(docs/fit/accuracy_shapes.md). ≈ 10 min on 2 shared cores.

    MIMIKA_ICT_DIR=~/ICT-FaceKit python scripts/fit_shape_fields.py
"""

import json
import logging
import sys
from pathlib import Path

from mimika.face.fitting.report import report_markdown
from mimika.face.fitting.shapes import fit_ict_shapes

ROOT = Path(__file__).resolve().parents[1]

if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    res = fit_ict_shapes()
    out = ROOT / "src" / "mimika" / "face" / "data" / "ict_shape_fields.json"
    out.write_text(json.dumps(res.document, separators=(",", ":")))
    (ROOT / "docs" / "fit" / "accuracy_shapes.md").write_text(report_markdown(res.accuracy))
    print(f"wrote {out}: {len(res.document['shapes'])} shapes in {res.seconds:.0f} s; mean "
          f"e/d_max (held-out vertices) {100 * res.mean_e_rel:.2f} %")
    sys.exit(0)
