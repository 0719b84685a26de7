"""What each object of an avatar is: skin, eyes, teeth, tongue, hair, brows, lashes, beard,
glasses, body or clothes.

Names first — rules in ``face/data/avatar_roles.json`` for the usual conventions (Ready Player
Me ``Wolf3D_*``, VRoid/VRM materials, MPFB/MakeHuman, Avaturn, Character Creator, Mixamo),
tried on each primitive's material and then on its node and mesh names; then shape and place
in the head frame (:func:`geometry_role`) for objects whose names say nothing. A role sets the
head category and how the fallback fields move the object (``motion``: skin only, with brows,
lashes and beard following the skin; hair, glasses, body and clothes never).
"""

from __future__ import annotations

import functools
import json
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from importlib import resources

import numpy as np

__all__ = ["ROLES", "Role", "bone_pattern", "category", "geometry_role", "motion",
           "name_role", "objects_of_role", "table"]


@functools.cache
def table() -> dict:
    """``face/data/avatar_roles.json``."""
    return json.loads(resources.files("mimika.face").joinpath("data/avatar_roles.json")
                      .read_text("utf-8"))


ROLES: tuple[str, ...] = tuple(table()["roles"])


@dataclass(frozen=True)
class Role:
    """An object's role and how it was found (``how``: the name and rule, or the shape)."""

    role: str
    how: str


@functools.cache
def _rules() -> tuple[tuple[str, re.Pattern], ...]:
    return tuple((r["role"], re.compile(r["pattern"], re.I)) for r in table()["names"])


def _bare(name: str) -> str:
    """The name without a namespace (``Human.eyebrow001`` → ``eyebrow001``)."""
    parts = [p for p in re.split(r"[.:|]", name) if p.strip()]
    return parts[-1].strip() if parts else name


def name_role(*names: str, what: str = "name") -> Role | None:
    """The role the first of ``names`` that a naming rule matches gives, or None; ``what``
    the names are (for :attr:`Role.how`)."""
    for raw in names:
        if not raw:
            continue
        for cand in dict.fromkeys((_bare(raw), raw)):
            for role, rx in _rules():
                if rx.search(cand):
                    return Role(role, f"{what} {raw!r}")
    return None


def category(role: str) -> str:
    """The head category (face | eyes | teeth | body) of ``role``."""
    return table()["category"][role]


def motion(role: str) -> str:
    """How ``role`` takes the fallback fields: fields | skin | none."""
    return table()["motion"][role]


def bone_pattern(kind: str) -> re.Pattern:
    """The joint-name rule for ``kind`` (head, neck, eye_L, eye_R, upper_arm)."""
    return re.compile(table()["bones"][kind], re.I)


def objects_of_role(head, role: str) -> list[str]:
    """Names of ``head``'s objects with ``role`` (``head.meta["roles"]``; heads without
    roles: objects named after the role, e.g. a character's ``hair``)."""
    roles: Mapping[str, str] | None = head.meta.get("roles")
    if roles is not None:
        return [o.name for o in head.objects if roles.get(o.name) == role]
    return [o.name for o in head.objects if o.name == role]


#: a piece whose median distance to the skin is below this (cm) lies on it (brows, lashes)
ON_SKIN_CM = 0.6


def geometry_role(v: np.ndarray, skin_dist: np.ndarray, features: Mapping[str, np.ndarray],
                  head_box: tuple[np.ndarray, np.ndarray]) -> Role:
    """The role of an object no name explains, from its vertices ``v`` (cm, head frame),
    their distances to the skin, the eye, mouth and chin points (``eye_L``, ``eye_R``,
    ``mouth``, ``chin``) and the bounds of the head above the chin: a small round piece at
    an eye is an eye, one behind the mouth teeth; a piece on the skin is brows above the
    eyes, lashes at them, beard below the mouth; a thin piece across both eyes in front of
    them glasses, a cap over the crown hair, anything reaching far below the chin body;
    else skin."""
    lo, hi = v.min(0), v.max(0)
    ext, c = hi - lo, v.mean(0)
    eye_l, eye_r = np.asarray(features["eye_L"]), np.asarray(features["eye_R"])
    mouth, chin = np.asarray(features["mouth"]), np.asarray(features["chin"])
    eye_d = float(np.linalg.norm(eye_l - eye_r))
    eye_y, eye_z = 0.5 * (eye_l[1] + eye_r[1]), max(eye_l[2], eye_r[2])
    on_skin = float(np.median(skin_dist)) < ON_SKIN_CM
    if ext.max() < 0.7 * eye_d and min(np.linalg.norm(c - eye_l), np.linalg.norm(c - eye_r)) \
            < 0.3 * eye_d:
        return Role("eyes", "shape: a small piece at an eye")
    if ext.max() < 1.3 * eye_d and abs(c[0] - mouth[0]) < 0.4 * eye_d and \
            abs(c[1] - mouth[1]) < 0.7 * eye_d and c[2] < mouth[2] and not on_skin:
        return Role("teeth", "shape: a small piece behind the mouth")
    if lo[1] < chin[1] - 3.5 * eye_d:
        return Role("body", "shape: reaches far below the chin")
    if on_skin and ext[1] < 0.6 * eye_d:
        if eye_y + 0.15 * eye_d < c[1] < eye_y + 0.7 * eye_d:
            return Role("brows", "shape: on the skin above the eyes")
        if abs(c[1] - eye_y) <= 0.15 * eye_d:
            return Role("lashes", "shape: on the skin at the eyes")
    if on_skin and c[1] < mouth[1] and hi[1] < eye_y:
        return Role("beard", "shape: on the skin below the mouth")
    if not on_skin and ext[0] > 1.3 * eye_d and ext[1] < 1.3 * eye_d and \
            abs(c[1] - eye_y) < 0.5 * eye_d and np.median(v[:, 2]) > eye_z:
        return Role("glasses", "shape: a thin piece across both eyes, in front of them")
    box_lo, box_hi = head_box
    if c[1] > eye_y + 0.3 * eye_d and hi[1] > box_hi[1] - 0.3 * eye_d and \
            ext[0] > 0.6 * (box_hi[0] - box_lo[0]):
        return Role("hair", "shape: a cap over the crown")
    return Role("skin", "shape: on the face")


def split_groups(roles: Iterable[str | None]) -> dict[str | None, list[int]]:
    """Primitive indices grouped by role; a mesh with skin keeps its body primitives as skin
    (one surface: CC's Std_Skin_Body, a MakeHuman body's skin_body)."""
    roles = list(roles)
    if "skin" in roles:
        roles = ["skin" if r == "body" else r for r in roles]
    out: dict[str | None, list[int]] = {}
    for i, r in enumerate(roles):
        out.setdefault(r, []).append(i)
    return out
