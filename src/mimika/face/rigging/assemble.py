"""Turn a head's shapes — its own morphs and shapes generated from fields — into an AU rig.

Every AU takes the first source that covers it:

1. **FACS morphs** named for the AU (``AU12``, ``AU12_L``/``AU12_R``);
2. **ARKit morphs**: all the shapes ``facs/data/ict_aus.json`` composes the AU from;
3. **visemes** (``morph_names.json``'s ``viseme_aus``: jaw opening, rounding, pressing), then
   **VRM expressions** (``vrm.json``'s ``aus``: an emotion preset shared by its AUs);
4. **seed-002 fields**: the AU's ARKit shapes generated on the mesh
   (:func:`~mimika.face.rigging.generate.generate_shapes`) where the avatar lacks them.

Head AUs 51–58 rotate about the neck pivot (per-vertex weights from the skin's head bone when
there is one, else the chin → neck-base fall-off); eye AUs 61–64 rotate eye meshes about their
centres, with the eyeLook lid shapes.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping

import numpy as np

from mimika.face.head import Head
from mimika.face.heads.vrm import table as vrm_table
from mimika.face.morphs import table as morph_table
from mimika.face.rigging.generate import Shapes, available, generate_shapes
from mimika.face.rigs.blendshape import BlendshapeRig, ShapeSet, load_table

__all__ = ["AvatarRig", "Coverage", "SparseShapes", "build_rig", "head_anchors"]

#: AU → (source, detail) — source: facs | arkit | viseme | fields | mixed | rotation
Coverage = dict[str, tuple[str, str]]


#: generated shapes kept sparse: name → object → (moving vertex indices, their deltas in cm)
SparseShapes = dict[str, dict[str, tuple[np.ndarray, np.ndarray]]]


class AvatarRig(BlendshapeRig):
    """A :class:`BlendshapeRig` whose head-motion weight may come from a skin (the weight of
    the head bone and its children per vertex) instead of the chin → neck fall-off. It keeps
    its AU ``table`` and the shapes it ``generated`` (for an export that adds only those to
    the avatar's own morphs)."""

    def __init__(self, head: Head, shapes: ShapeSet, table: Mapping,
                 head_weight: np.ndarray | None = None) -> None:
        super().__init__(head, shapes, table)
        self.table = table
        self.generated: SparseShapes = {}
        if head_weight is not None:
            w = np.clip(np.asarray(head_weight, np.float32), 0.0, 1.0)
            self.neck_weight = w
            self._partial = np.flatnonzero(w < 1.0 - 1e-9)
            self._wp = w[self._partial]


def _resolve(name: str, have: Mapping[str, str]) -> list[str] | None:
    """The shapes that realise table shape ``name`` (itself, or its _L and _R), or None."""
    if name in have:
        return [name]
    if name + "_L" in have and name + "_R" in have:
        return [name + "_L", name + "_R"]
    return None


def _plan(have: Mapping[str, str]) -> tuple[dict, Coverage, set[str]]:
    """AU table, coverage and the shapes to generate, for shapes ``have`` (name → origin)."""
    base = load_table()
    alts: dict[str, list[tuple[str, dict]]] = {}  # visemes, then VRM expressions
    for k, v in morph_table()["viseme_aus"].items():
        if not k.startswith("_"):
            alts.setdefault(k, []).append(("viseme", v))
    for k, vs in vrm_table()["aus"].items():
        alts.setdefault(k, []).extend(("vrm", v) for v in vs)
    gen_ok = set(available())
    table = {"side_mask_width_cm": base.get("side_mask_width_cm", 0.8), "aus": {}}
    cover: Coverage = {}
    need: set[str] = set()
    for code, spec in base["aus"].items():
        entry = {k: copy.deepcopy(v) for k, v in spec.items() if k not in ("shapes", "note")}
        shapes = spec.get("shapes") or {}
        facs = [n for n in (code, code + "_L", code + "_R") if n in have]
        if facs:
            entry["shapes"] = {code: 1.0}
            cover[code] = ("facs", ", ".join(have[n] for n in facs))
        elif shapes:
            got = {n: _resolve(n, have) for n in shapes}
            if all(got.values()):
                entry["shapes"] = dict(shapes)
                cover[code] = ("arkit", ", ".join(dict.fromkeys(
                    have[s] for n in shapes for s in got[n])))
            elif alt := next((a for a in alts.get(code, ()) if all(_resolve(n, have)
                                                                   for n in a[1])), None):
                entry["shapes"] = dict(alt[1])
                cover[code] = (alt[0], ", ".join(have.get(n, n) for n in alt[1]))
            else:
                missing = [n for n in shapes if not got[n]]
                gen = [s for n in missing for s in ((n,) if n in gen_ok else
                                                    (n + "_L", n + "_R"))]
                if not all(s in gen_ok for s in gen):
                    continue  # neither morphs nor fields: the AU is not modelled
                need.update(gen)
                entry["shapes"] = dict(shapes)
                mine = [have[s] for n in shapes if got[n] for s in got[n]]
                cover[code] = ("mixed" if mine else "fields",
                               ", ".join([*dict.fromkeys(mine), *(f"{s} (fields)"
                                                                  for s in gen)]))
        if "shapes" not in entry and not ({"eye_rotate_deg", "head_rotate_deg",
                                           "head_translate_cm"} & set(entry)):
            continue
        if "eye_rotate_deg" in entry or "head_rotate_deg" in entry or \
                "head_translate_cm" in entry:
            kind = "eye rotation" if "eye_rotate_deg" in entry else "head motion"
            src, det = cover.get(code, ("", ""))
            cover[code] = (src or "rotation",
                           f"{kind}" + (f" + {det}" if det else ""))
        table["aus"][code] = entry
    return table, cover, need


def build_rig(head: Head, shapes: Shapes, origins: Mapping[str, str], *,
              head_weight: np.ndarray | None = None, generate: bool = True,
              generator: Callable[[Head, list[str]], Shapes] = generate_shapes,
              eye_turn: Mapping[str, float] | None = None) -> tuple[AvatarRig, Coverage]:
    """The AU rig of ``head`` from its ``shapes`` (canonical name → object → deltas) whose
    ``origins`` name the morph each came from; missing shapes are made by ``generator``
    (default: from fields on every object they move). ``eye_turn``: a factor on eye AUs'
    turns (a VRM's lookAt ranges)."""
    have = {n: origins.get(n, n) for n in shapes}
    table, cover, need = _plan(have)
    for code, f in (eye_turn or {}).items():
        spec = table["aus"].get(code, {})
        if "eye_rotate_deg" in spec:
            spec["eye_rotate_deg"] = [f * a for a in spec["eye_rotate_deg"]]
    all_shapes = dict(shapes)
    if need and generate:
        gen = generator(head, sorted(need))
        all_shapes.update(gen)
    elif need:
        table["aus"] = {c: e for c, e in table["aus"].items()
                        if cover.get(c, ("",))[0] not in ("fields", "mixed")}
        cover = {c: v for c, v in cover.items() if c in table["aus"]}
    names = tuple(all_shapes)
    deltas = {}
    for o in head.objects:
        arr = np.zeros((len(names), o.n_vertices, 3), np.float32)
        for k, n in enumerate(names):
            d = all_shapes[n].get(o.name)
            if d is not None:
                arr[k] = d
        deltas[o.name] = arr
    rig = AvatarRig(head, ShapeSet(names, deltas), table, head_weight)
    for n in (n for n in names if n not in shapes):
        rig.generated[n] = {}
        for obj, d in all_shapes[n].items():
            idx = np.flatnonzero(np.abs(d).max(1) > 0)
            if len(idx):
                rig.generated[n][obj] = (idx, np.asarray(d[idx], np.float32))
    return rig, cover


def head_anchors(skin: np.ndarray, lm: np.ndarray, eyes: Mapping[str, np.ndarray]) -> dict:
    """Anchors from the face vertices ``skin`` (cm, head frame), its 68 landmark points and
    eye centres: mouth corners, chin, the neck base 12 cm below the chin (or the mesh's
    lowest point when higher) and the neck pivot (as the ICT head: midline, 2.5 cm below
    the ear level, a third of the head's depth from the back)."""
    head_part = skin[skin[:, 1] > lm[8, 1] - 1.0]
    z_back, z_front = float(head_part[:, 2].min()), float(head_part[:, 2].max())
    ear_y = 0.5 * (lm[0, 1] + lm[16, 1])
    base_y = max(float(skin[:, 1].min()), float(lm[8, 1]) - 12.0)
    out = {"mouth_corner_L": lm[54], "mouth_corner_R": lm[48], "chin": lm[8],
           "neck_base": np.array([0.0, base_y, 0.5 * (z_back + z_front) - 2.0]),
           "neck_pivot": np.array([0.0, ear_y - 2.5, z_back + (z_front - z_back) / 3.0])}
    out.update({k: np.asarray(v, float) for k, v in eyes.items()})
    return out
