"""MakeHuman characters as heads: a person with hair, brows, lashes, clothes and a skinned body.

A character comes from a character file (:mod:`mimika.face.makehuman.character_file`) or a
shipped preset. Its geometry is assembled by :mod:`mimika.face.makehuman.build`, posed (arms
lowered) and moved into mimika's head frame (cm, the eyes where the built-in head's are), and
driven by a :class:`~mimika.face.rigs.skinned.SkinnedRig`: the ARKit faceunits through the AU
table ``face/data/makehuman_aus.json`` and head/body motion by skinning.
"""

from __future__ import annotations

import copy
import logging
from collections.abc import Mapping

import numpy as np

from mimika.face.calibration import inter_ocular
from mimika.face.head import Head, MeshObject, Part
from mimika.face.landmark_match import match_landmarks
from mimika.face.makehuman import cache
from mimika.face.makehuman.base import first_copies, landmark_ids
from mimika.face.makehuman.build import EYE_MID, SCALE, Built, Outfit, build
from mimika.face.makehuman.character_file import Character, load_character_spec
from mimika.face.makehuman.jaw import tongue_follows_jaw
from mimika.face.makehuman.lips import lower_lip_follows_jaw, seal_lips
from mimika.face.makehuman.paint import parts_of
from mimika.face.makehuman.paint.regions import mouth_lining
from mimika.face.makehuman.skeleton import rest_pose, skin
from mimika.face.makehuman.teeth import seat_teeth
from mimika.face.rigs.blendshape import ShapeSet, load_table
from mimika.face.rigs.skinned import SkinnedRig, Skinning

log = logging.getLogger(__name__)

#: prefix of the shapes generated on a character in the ``ict`` style (the per-shape fields
#: fitted on the ICT Face Model's light-stage scans, carried by the 68 landmarks): the AU table
#: mixes them with MakeHuman's faceunits where those move too little or too much of the face
ICT_STYLE = "ict."


def arkit_to_table_name(name: str) -> str:
    """``browDownLeft`` → ``browDown_L`` (the AU tables' convention); ``jawLeft``,
    ``mouthLeft`` … (directions, not sides) stay."""
    for word, side in (("Left", "_L"), ("Right", "_R")):
        if name.endswith(word) and name not in ("jawLeft", "jawRight", "mouthLeft",
                                                 "mouthRight"):
            return name[: -len(word)] + side
    return name


def _to_head_frame(built: Built) -> tuple[float, np.ndarray]:
    """Scale and offset taking base units to mimika's frame: cm, eye midpoint at EYE_MID."""
    eyes = [p.pivot for p in built.pieces if p.category == "eyes"]
    mid = np.mean(eyes, axis=0)
    return SCALE, EYE_MID - SCALE * mid


def _landmark_ids(skin_weld: np.ndarray) -> np.ndarray:
    """The 68 landmarks as skin vertex indices."""
    return first_copies(skin_weld, landmark_ids())


#: shapes of an AU recipe that stay MakeHuman's when the AU is mixed with the ict style: the
#: jaw (it carries the teeth and tongue, which the generated shapes leave still) and the lids
#: (blink, squint, wide: the generated shapes are too smooth to move a lid, see
#: docs/rigs.md#calibration)
_NATIVE = ("jaw", "eyeBlink", "eyeLook", "eyeSquint", "eyeWide")


def calibrated_table(table: Mapping, calibration: Mapping[str, Mapping] | None = None) -> dict:
    """``table`` with each AU's ``calibration`` (``{"ict": w, "gain": g}``, overridden per AU by
    ``calibration``) folded into its shapes: gain · ((1 − w) · faceunits + w · ICT's recipe on
    the ict-style shapes); jaw and lid shapes stay the faceunits' (× gain). See
    ``scripts/calibrate_characters.py``, which measures and writes the calibration."""
    out = copy.deepcopy(dict(table))
    ict = load_table("ict_aus.json")["aus"]
    for code, entry in out["aus"].items():
        cal = {**entry.get("calibration", {}), **(calibration or {}).get(code, {})}
        if not cal or "shapes" not in entry:
            continue
        w, g = float(cal.get("ict", 0.0)), float(cal.get("gain", 1.0))
        mixed: dict[str, float] = {}
        for name, x in entry["shapes"].items():
            keep = name.startswith(_NATIVE) or w == 0.0
            mixed[name] = mixed.get(name, 0.0) + g * x * (1.0 if keep else 1.0 - w)
        if w > 0.0:
            for name, x in ict.get(code, {}).get("shapes", {}).items():
                if not name.startswith(_NATIVE):
                    key = ICT_STYLE + name
                    mixed[key] = mixed.get(key, 0.0) + g * w * x
        entry["shapes"] = {k: round(v, 6) for k, v in mixed.items() if v != 0.0}
    return out


def assemble(built: Built, character: Character, parts_of=None,
             calibration: Mapping[str, Mapping] | None = None) -> tuple[Head, SkinnedRig]:
    """The posed head and its rig. ``parts_of(piece)`` → Parts lets a painter attach textures
    (default: one untextured part per material); ``calibration`` overrides the AU table's
    (see :func:`calibrated_table`)."""
    scale, offset = _to_head_frame(built)
    sk = built.skeleton
    pose = rest_pose(sk)
    tf_rest = sk.transforms(pose)
    bind_objs, posed_objs = [], []
    for p in built.pieces:
        bind_v = p.vertices * scale + offset
        posed_v = skin(p.vertices, built.weights[p.name], tf_rest) * scale + offset
        parts = parts_of(p) if parts_of else tuple(Part(m, f) for m, f in p.parts.items())
        pivot = None if p.pivot is None else p.pivot * scale + offset
        for dst, v in ((bind_objs, bind_v), (posed_objs, posed_v)):
            dst.append(MeshObject(p.name, p.category, v, parts, pivot=pivot, uvs=p.uvs,
                                  weld=p.weld if p.name == "skin" else None, oriented=True))
    skin_piece = built.pieces[0]
    lm = _landmark_ids(skin_piece.weld)
    lmp = posed_objs[0].vertices[lm]
    heads_cm = sk.heads * scale + offset
    a = {
        "mouth_corner_L": lmp[54], "mouth_corner_R": lmp[48],
        "eye_L": posed_objs[1].pivot, "eye_R": posed_objs[2].pivot,
        "chin": lmp[8], "nose_tip": lmp[30], "brow_L": lmp[24], "brow_R": lmp[19],
        "neck_base": heads_cm[sk.index("neck01")], "neck_pivot": heads_cm[sk.index("neck03")],
        "jaw_pivot": heads_cm[sk.index("head")],
    }
    meta = {"character": character.name, "phenotype": dict(character.phenotype),
            "outfit": character.outfit_dict(),
            "mouth_lining": mouth_lining(skin_piece.meta.get("uv_layout", skin_piece.uvs))}
    desc = character.description or f"MakeHuman character {character.name!r}"
    head = Head(character.name, tuple(posed_objs), lm, a, description=desc, meta=meta)
    bind_head = Head(character.name, tuple(bind_objs), lm, a, description=desc, meta=meta)
    shapes = _shape_set(built, scale)
    table = calibrated_table(load_table("makehuman_aus.json"), calibration)
    if built.lip_seal > 0:  # parting the lips releases what closed them at rest (lips.py)
        table["release"] = {**table["lip_release"], "shapes": {"mouthClose": -built.lip_seal}}
    skinning = Skinning(sk.names, heads_cm, sk.parents, built.weights,
                        {k: np.asarray(v) for k, v in pose.items()}, table["head_share"],
                        table.get("body", {}))
    rig = SkinnedRig(head, bind_head, shapes, table, skinning)
    codes = [c for c, e in table["aus"].items() if e.get("match_landmarks")]
    if codes:  # AUs that move the landmarks as ICT's actor does (face/landmark_match.py)
        shapes, table = match_landmarks(rig, bind_objs[0], lm, inter_ocular(head), shapes,
                                        table, codes, _back_fade(bind_objs[0].vertices))
        rig = SkinnedRig(head, bind_head, shapes, table, skinning)
    return head, rig


def _shape_set(built: Built, scale: float) -> ShapeSet:
    """The faceunits as AU-table shape names and head-frame deltas (cm)."""
    names = tuple(n if n.startswith(ICT_STYLE) else arkit_to_table_name(n)
                  for n in built.shape_names)
    return ShapeSet(names, {k: v * scale for k, v in built.deltas.items()})


def _back_fade(v: np.ndarray) -> np.ndarray:
    """(N,) weights of head-frame vertices ``v``: 1 in front, fading to 0 behind the ears — as
    on ICT itself (its table's ``still_back_z_cm``), generated shapes leave the skull and
    neck still."""
    z0, z1 = load_table("ict_aus.json")["still_back_z_cm"]
    t = np.clip((np.asarray(v)[:, 2] - z0) / (z1 - z0), 0.0, 1.0)
    return t * t * (3 - 2 * t)


def _with_ict_style(built: Built) -> Built:
    """``built`` with the ``ict`` style's shapes (:data:`ICT_STYLE` + name) generated on its
    skin and carried to the other pieces through their bindings, as the faceunits are (eyes
    turn by rotation and take none)."""
    from mimika.face.rigging.generate import generate_shapes

    scale, offset = _to_head_frame(built)
    sk = built.pieces[0]
    skin = MeshObject("skin", "face", sk.vertices * scale + offset,
                      tuple(Part(m, f) for m, f in sk.parts.items()), weld=sk.weld,
                      oriented=True)
    head = Head("bind", (skin,), _landmark_ids(sk.weld), {})
    shapes = generate_shapes(head)
    fade = _back_fade(skin.vertices)[:, None]
    n_base = len(built.base_vertices)
    dense = np.zeros((len(shapes), n_base, 3), np.float32)
    for k, per in enumerate(shapes.values()):
        if "skin" in per:
            dense[k, sk.weld] = per["skin"] * fade / scale
    deltas = {}
    for p in built.pieces:
        extra = (np.zeros((len(shapes), len(p.vertices), 3), np.float32)
                 if p.category == "eyes" else
                 np.stack([p.binding @ d for d in dense]).astype(np.float32))
        deltas[p.name] = np.concatenate([built.deltas[p.name], extra])
    names = (*built.shape_names, *(ICT_STYLE + n for n in shapes))
    return Built(built.pieces, built.skeleton, names, deltas, built.weights,
                 built.base_vertices)


def built_character(character: Character) -> Built:
    """The character's geometry, from the cache or built (and cached), teeth seated behind
    the lips and the lips then together at rest."""
    path = cache.cache_path(character.geometry_key())
    built = cache.load(path)
    if built is None:
        built = _with_ict_style(build(character.phenotype_values(),
                                      Outfit(character.hair, character.eyebrows,
                                             character.eyelashes, character.clothes),
                                      character.modifiers))
        try:
            cache.save(path, built)
        except OSError as e:
            log.warning("cannot cache character %r in %s: %s", character.name, path, e)
    return seal_lips(lower_lip_follows_jaw(tongue_follows_jaw(seat_teeth(built))))


_LOADED: dict[str, tuple[Head, SkinnedRig]] = {}


def load_character(spec: str) -> tuple[Head, SkinnedRig]:
    """``(head, rig)`` for a preset name or a character file path (kept per process: a rig
    holds no state between calls)."""
    character = load_character_spec(spec)
    key = character.key()
    if key not in _LOADED:
        built = built_character(character)
        if len(_LOADED) >= 4:
            _LOADED.pop(next(iter(_LOADED)))
        _LOADED[key] = assemble(built, character,
                                lambda piece: parts_of(piece, character))
    return _LOADED[key]


def character_rig(spec: str, calibration: Mapping[str, Mapping]) -> SkinnedRig:
    """The (untextured) rig of a character with its AU calibration overridden per AU."""
    character = load_character_spec(spec)
    return assemble(built_character(character), character, calibration=calibration)[1]


def base_character() -> Character:
    """MakeHuman's average person without hair or clothes (what the ``makehuman`` shape
    fields are fitted on)."""
    from mimika.face.makehuman.character_file import character_from_dict

    return character_from_dict({"name": "makehuman", "hair": "none", "clothes": []},
                               "makehuman base")


def character_shapes(spec: str | Character) -> tuple[Head, ShapeSet]:
    """The character's head (untextured) and its faceunits as a shape set (per object, cm):
    what a fit of per-shape fields needs."""
    character = spec if isinstance(spec, Character) else load_character_spec(spec)
    built = built_character(character)
    head, _ = assemble(built, character)
    shapes = _shape_set(built, _to_head_frame(built)[0])
    own = [k for k, n in enumerate(shapes.names) if not n.startswith(ICT_STYLE)]
    return head, ShapeSet(tuple(shapes.names[k] for k in own),
                          {o: d[own] for o, d in shapes.deltas.items()})
