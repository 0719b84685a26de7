"""``mimika rig`` on several heads: does any AU tear or flip the mesh?

Each head is written as a bare file a user would bring (:mod:`mimika.face.rigging.samples`),
rigged with each field style, and every AU and side is measured at intensities 0 → 1
(:mod:`mimika.face.rigging.quality`: worst edge stretch, torn edges — over 3× and 2 mm
longer —, folded triangles, seam gaps; on the surface seen from the front). ``--real``
measures the ICT head's and a MakeHuman character's own shapes the same way, for reference.

Heads: the built-in head (OBJ; GLB with eyes and teeth, standing 1.6 m up and turned 25°;
decimated), a MakeHuman character's head (GLB with eyes and teeth, cut at UV seams;
remeshed), the ICT head as a game head has it (face, mouth bag and eye sockets in one mesh
cut at UV seams, with eyes and teeth; decimated — needs ``MIMIKA_ICT_DIR``).

    MIMIKA_ICT_DIR=… nice python bench/bench_rig_quality.py [--styles ict,makehuman] [--all]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from _common import ict_available, single_core

single_core()

def heads(tmp: Path) -> list[tuple[str, Path]]:
    """(label, file) of the sample heads."""
    from mimika.face.heads import load_head
    from mimika.face.rigging.export import write_obj
    from mimika.face.rigging.samples import decimated, ict_game_head, remeshed, write_samples

    out = []
    b, _ = load_head("builtin")
    files = write_samples(b, tmp, "builtin")
    out.append(("builtin (OBJ)", files["obj"]))
    files = write_samples(b, tmp, "builtin_scene", ("skin", "eye_L", "eye_R", "teeth_upper",
                                                    "teeth_lower"),
                          offset_m=(0.3, 1.6, -0.2), yaw_deg=25.0)
    out.append(("builtin + eyes, teeth (GLB, 1.6 m up, turned 25°)", files["glb"]))
    v, f = decimated(b["skin"].vertices * 0.01, b["skin"].faces, 0.35)
    out.append(("builtin, decimated to 35 % (OBJ)", write_obj(tmp / "builtin_dec.obj", v, f)))
    a, _ = load_head("amara")
    files = write_samples(a, tmp, "amara", ("skin", "eye_L", "eye_R", "teeth"))
    out.append(("amara + eyes, teeth (GLB cut at UV seams)", files["glb"]))
    files = write_samples(a, tmp, "amara_skin")
    sv, sf = _read_obj(files["obj"])
    v, f = remeshed(sv, sf)
    out.append(("amara, remeshed (OBJ)", write_obj(tmp / "amara_remeshed.obj", v, f)))
    if ict_available():
        out.append(("ICT: face + mouth bag + sockets in one mesh, eyes, teeth (GLB, seams)",
                    ict_game_head(tmp)["glb"]))
        v, f = ict_skin()
        v, f = decimated(v, f, 0.4)
        out.append(("ICT skin, decimated to 40 % (OBJ)", write_obj(tmp / "ict_dec.obj", v, f)))
    else:
        print("ICT heads skipped: set MIMIKA_ICT_DIR", file=sys.stderr)
    return out


def _read_obj(path: Path) -> tuple[np.ndarray, np.ndarray]:
    from mimika.io.obj import read_obj

    m = read_obj(path)
    return m.vertices.astype(float), m.faces.astype(np.int64)


def ict_skin() -> tuple[np.ndarray, np.ndarray]:
    """The ICT skin (cm): vertices and triangles."""
    from mimika.face.heads.ict import RANGES, load_ict_data

    d = load_ict_data()
    lo, hi = RANGES["skin"]
    f = d.faces[np.all((d.faces >= lo) & (d.faces < hi), axis=1)] - lo
    return d.vertices[lo:hi].astype(float), f.astype(np.int64)


def report(label: str, rows: list[dict], every: bool) -> None:
    worst = max(rows, key=lambda x: x["stretch"])
    bad = [x for x in rows if x["torn"] or x["flips"] or x["gap_mm"] > 0.01]
    print(f"{label}: {len(rows)} AU shapes; worst stretch {worst['stretch']:.2f}× "
          f"({worst['au']}); torn edges {sum(x['torn'] for x in rows)}, flipped triangles "
          f"{sum(x['flips'] for x in rows)} in {len(bad)} AUs; seam gap "
          f"{max(x['gap_mm'] for x in rows):.3f} mm", flush=True)
    for x in rows if every else bad:
        print(f"    {x['au']:<7} stretch {x['stretch']:5.2f}×  torn {x['torn']:4d}  "
              f"flips {x['flips']:4d}  seam gap {x['gap_mm']:.3f} mm")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--styles", default="ict,makehuman")
    ap.add_argument("--all", action="store_true", help="print every AU, not only the faulty")
    ap.add_argument("--real", action="store_true", help="also measure the real shapes of the "
                    "ICT head and a MakeHuman character, for reference")
    args = ap.parse_args()
    from mimika.face.rigging.autorig import rig_mesh
    from mimika.face.rigging.quality import measure

    total = {"torn": 0, "flips": 0}
    if args.real:
        from mimika.face.heads import load_head

        for name in ("ict", "amara") if ict_available() else ("amara",):
            rows = measure(load_head(name)[1])
            report(f"real shapes of {name}", rows, args.all)
    with tempfile.TemporaryDirectory() as tmp:
        for label, path in heads(Path(tmp)):
            for style in args.styles.split(","):
                t0 = time.perf_counter()
                r = rig_mesh(path, style=style)
                rows = measure(r.rig)
                total["torn"] += sum(x["torn"] for x in rows)
                total["flips"] += sum(x["flips"] for x in rows)
                report(f"{label} [{style}] ({time.perf_counter() - t0:.0f} s)", rows, args.all)
    print(f"all heads: torn edges {total['torn']}, flipped triangles {total['flips']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
