"""VRM 0.x (extension ``VRM``) and 1.0 (``VRMC_vrm``): humanoid bones, expressions, the
lookAt ranges and MToon materials, read into a :class:`~mimika.face.heads.gltf_scene.GltfScene`.

Expressions become shapes (``face/data/vrm.json``): blink and the vowels as eyeBlink and
visemes (``morph_names.json``), the emotion presets (happy, angry, sad, relaxed, surprised;
0.x joy, sorrow, fun) and the look presets as ``vrm_*`` shapes that
:func:`~mimika.face.rigging.assemble.build_rig` gives to the AUs of their prototypes. A
gaze of 30° (an eye AU at 1) turns eye bones, or drives look expressions, as the file's
lookAt range maps say. MToon and unlit materials are drawn with the renderer's flat ``toon``
material (lit softly, no gloss), their base colour taken from the glTF material or, in 0.x,
from the MToon ``_Color`` and ``_MainTex``.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Mapping
from importlib import resources
from typing import Any

from mimika.face.morphs import classify

__all__ = ["expression_shape", "look_au", "look_scale", "read_vrm", "table", "toon_materials",
           "vrm0_base_color"]


@functools.cache
def table() -> dict:
    """``face/data/vrm.json``."""
    return json.loads(resources.files("mimika.face").joinpath("data/vrm.json")
                      .read_text("utf-8"))


def expression_shape(name: str) -> tuple[str, str] | None:
    """(kind, shape) of VRM expression ``name``: ``("arkit", "eyeBlink")``,
    ``("viseme", "viseme_aa")``, ``("vrm", "vrm_happy")`` …; None for others."""
    mt = classify(name, expression=True)
    if mt is not None:
        return ("arkit" if mt.kind == "expression" else mt.kind), mt.name
    shape = table()["expressions"].get(name.lower())
    return ("vrm", shape) if shape else None


def _index(x: Any, n: int) -> int | None:
    """``x`` as an index below ``n``, or None."""
    return x if isinstance(x, int) and not isinstance(x, bool) and 0 <= x < n else None


def _dict(x: Any) -> dict:
    return x if isinstance(x, dict) else {}


def _list(x: Any) -> list:
    return x if isinstance(x, list) else []


def _weight(x: Any, scale: float) -> float:
    try:
        w = float(x) / scale
    except (TypeError, ValueError):
        return 0.0
    return w if abs(w) <= 10.0 else 0.0


def read_vrm(g: Any, scene: Any, mesh_of_node: Mapping[int, list[int]]) -> None:
    """Fill ``scene``'s VRM data (version, humanoid bones, expressions, look ranges) from the
    pygltflib document ``g``; broken entries are skipped."""
    ext = _dict(g.extensions)
    n_nodes = len(g.nodes or [])
    if "VRMC_vrm" in ext:
        vrm = _dict(ext["VRMC_vrm"])
        scene.vrm_version = 1
        for bone, spec in _dict(_dict(vrm.get("humanoid")).get("humanBones")).items():
            node = _index(_dict(spec).get("node"), n_nodes)
            if node is not None:
                scene.bones[str(bone)] = node
        exprs = _dict(vrm.get("expressions"))
        for group in ("preset", "custom"):
            for name, spec in _dict(exprs.get(group)).items():
                binds = []
                for b in _list(_dict(spec).get("morphTargetBinds")):
                    b = _dict(b)
                    node, k = _index(b.get("node"), n_nodes), b.get("index")
                    if node is None or not isinstance(k, int):
                        continue
                    w = _weight(b.get("weight", 1.0), 1.0)
                    binds += [(mi, k, w) for mi in mesh_of_node.get(node, [])]
                scene.expressions[str(name)] = binds
        look = _dict(vrm.get("lookAt"))
        scene.vrm_look_type = "bone" if look.get("type", "bone") == "bone" else "expression"
        scene.vrm_look = look_scale(look, 0)
    elif "VRM" in ext:
        vrm = _dict(ext["VRM"])
        scene.vrm_version = 0
        for hb in _list(_dict(vrm.get("humanoid")).get("humanBones")):
            hb = _dict(hb)
            node = _index(hb.get("node"), n_nodes)
            if "bone" in hb and node is not None:
                scene.bones[str(hb["bone"])] = node
        nodes_of_mesh: dict[int, list[int]] = {}
        for ni, nd in enumerate(g.nodes or []):
            if nd.mesh is not None:
                nodes_of_mesh.setdefault(nd.mesh, []).append(ni)
        for grp in _list(_dict(vrm.get("blendShapeMaster")).get("blendShapeGroups")):
            grp = _dict(grp)
            name = grp.get("presetName")
            if not name or name == "unknown":
                name = grp.get("name")
            binds = []
            for b in _list(grp.get("binds")):
                b = _dict(b)
                k = b.get("index")
                if not isinstance(k, int) or not isinstance(b.get("mesh"), int):
                    continue
                w = _weight(b.get("weight", 100), 100.0)
                for ni in nodes_of_mesh.get(b["mesh"], []):
                    binds += [(mi, k, w) for mi in mesh_of_node.get(ni, [])]
            if name:
                scene.expressions[str(name)] = binds
        fp = _dict(vrm.get("firstPerson"))
        scene.vrm_look_type = ("expression" if str(fp.get("lookAtTypeName", "Bone")).lower()
                               == "blendshape" else "bone")
        scene.vrm_look = look_scale(fp, 1)


def look_scale(look: Mapping, which: int) -> dict[str, float]:
    """Per eye AU, the fraction of its turn (bones: of mimika's 30°, expressions: of the
    look preset) that a 30° gaze gives under the file's range maps; ``which``: 0 for 1.0's
    ``rangeMap*`` (inputMaxValue, outputScale), 1 for 0.x's ``lookAt*`` (xRange, yRange)."""
    gaze = float(table()["gaze_deg"])
    bone = (look.get("type", "bone") == "bone") if which == 0 else (
        str(look.get("lookAtTypeName", "Bone")).lower() != "blendshape")
    out = {}
    for au, keys in table()["look_ranges"].items():
        spec = _dict(look.get(keys[which]))
        try:
            top = float(spec["inputMaxValue" if which == 0 else "xRange"])
            scale = float(spec["outputScale" if which == 0 else "yRange"])
        except (KeyError, TypeError, ValueError):
            continue
        if not (0 < top <= 180 and 0 <= scale <= 180):
            continue
        frac = min(gaze / top, 1.0) * scale
        out[au] = frac / gaze if bone else min(frac, 1.0)
    return out


def toon_materials(g: Any) -> set[int]:
    """Indices of the materials drawn as toon: MToon (1.0 ``VRMC_materials_mtoon``, 0.x
    ``materialProperties`` shader) and unlit (``KHR_materials_unlit``, VRM/Unlit*)."""
    out = set()
    mats = g.materials or []
    for i, m in enumerate(mats):
        ext = _dict(m.extensions)
        if "VRMC_materials_mtoon" in ext or "KHR_materials_unlit" in ext:
            out.add(i)
    props = _list(_dict(_dict(g.extensions).get("VRM")).get("materialProperties"))
    by_name = {m.name: i for i, m in enumerate(mats) if m.name}
    for k, p in enumerate(props):
        p = _dict(p)
        i = by_name.get(p.get("name"), k if k < len(mats) else None)
        if i is not None and p.get("shader") in table()["toon_shaders"]:
            out.add(i)
    return out


def vrm0_base_color(g: Any, material: int) -> tuple[tuple[float, ...] | None, int | None]:
    """A VRM 0.x material's MToon ``_Color`` (linear RGBA) and ``_MainTex`` texture index,
    for materials whose glTF base colour is missing (either may be None)."""
    mats = g.materials or []
    props = _list(_dict(_dict(g.extensions).get("VRM")).get("materialProperties"))
    name = mats[material].name if 0 <= material < len(mats) else None
    p = next((_dict(q) for q in props if _dict(q).get("name") == name), None)
    if p is None:
        return None, None
    col = _dict(p.get("vectorProperties")).get("_Color")
    tex = _dict(p.get("textureProperties")).get("_MainTex")
    ok = isinstance(col, list) and len(col) == 4 and all(
        isinstance(c, (int, float)) and 0 <= c <= 1 for c in col)
    return (tuple(float(c) for c in col) if ok else None,
            tex if isinstance(tex, int) and not isinstance(tex, bool) else None)


def look_au(shape: str) -> str | None:
    """The eye AU a ``vrm_look*`` shape shows (``vrm_lookLeft`` → AU61), or None."""
    for au, alts in table()["aus"].items():
        if au in table()["look_ranges"] and any(shape in a for a in alts):
            return au
    return None
