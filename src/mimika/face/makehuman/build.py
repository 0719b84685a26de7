"""Assemble a MakeHuman character: shaped body, fitted proxies, eyes, faceunit shapes, skeleton.

Steps (all deterministic):

1. the hm08 base mesh shaped by the macro targets of the phenotype (:mod:`.targets`);
2. the reduced skeleton on it (:mod:`.skeleton`) and a seated rest pose (arms lowered);
3. proxies (clothes, hair, brows, lashes, teeth, tongue) fitted by their ``.mhclo`` bindings;
   body faces a proxy hides (``delete_verts``) are dropped;
4. eyeballs placed on the base mesh's eye helpers;
5. the 52 ARKit faceunits as per-object shape deltas (proxies follow through their bindings);
6. everything scaled to cm and moved so the eyes sit where the built-in head's do.

The skin is split at UV seams (one render vertex per position × UV); ``weld`` remembers the
position each render vertex came from, so normals stay smooth across seams.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from mimika.errors import DataError
from mimika.face.eyeball import eyeball_object
from mimika.face.makehuman.base import BaseMesh, load_base
from mimika.face.makehuman.proxy import Proxy, read_mhclo
from mimika.face.makehuman.skeleton import Skeleton, build_skeleton, rest_pose, skin
from mimika.face.makehuman.targets import (
    apply_macros,
    apply_modifiers,
    faceunit_names,
    read_faceunit,
)

log = logging.getLogger(__name__)

ASSETS = Path(__file__).parent / "assets"
#: dm → cm
SCALE = 10.0
#: where the eye centres' midpoint goes (the built-in head's eyes), cm
EYE_MID = np.array([0.0, 3.6, 8.4])


@dataclass
class Piece:
    """One object under construction: positions in base units, faces per material, UVs, the
    sparse map from base vertices (for faceunits and skin weights) and an extra offset."""

    name: str
    category: str
    vertices: np.ndarray
    parts: dict[str, np.ndarray]
    uvs: np.ndarray | None
    binding: sp.csr_matrix | None  #: (n, N_base) — vertices = binding @ base + offsets
    weld: np.ndarray | None = None
    pivot: np.ndarray | None = None
    meta: dict = field(default_factory=dict)


def asset_path(kind: str, name: str) -> Path:
    """``assets/<kind>/<name>/<name>.mhclo``, or a DataError listing what is there."""
    p = ASSETS / kind / name / f"{name}.mhclo"
    if not p.is_file():
        have = sorted(d.name for d in (ASSETS / kind).iterdir() if d.is_dir())
        raise DataError(f"unknown {kind} {name!r}; available: {', '.join(have)}")
    return p


def split_by_uv(quads: np.ndarray, quad_uvs: np.ndarray, uvs: np.ndarray):
    """Render vertices for quads with per-corner UVs: returns (source vertex (R,), UV (R, 2),
    triangles (2Q, 3) into the render vertices)."""
    pairs = np.stack([quads.ravel(), quad_uvs.ravel()], 1)
    uniq, inv = np.unique(pairs, axis=0, return_inverse=True)
    q = inv.reshape(-1, 4)
    tris = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    return uniq[:, 0], uvs[uniq[:, 1]], tris


def triangulate(faces: np.ndarray) -> np.ndarray:
    """Quads (or triangles) (F, 3|4) → triangles."""
    f = np.asarray(faces)
    return f if f.shape[1] == 3 else np.concatenate([f[:, [0, 1, 2]], f[:, [0, 2, 3]]])


def proxy_piece(proxy: Proxy, name: str, category: str, material: str, n_base: int,
                base: np.ndarray) -> Piece:
    """A fitted proxy as a piece (faces from its OBJ, UVs split at seams)."""
    mesh = proxy.mesh
    if mesh.uvs is not None and mesh.face_uvs is not None:
        pairs = np.stack([mesh.faces.ravel(), mesh.face_uvs.ravel()], 1)
        uniq, inv = np.unique(pairs, axis=0, return_inverse=True)
        src, uv, tris = uniq[:, 0], mesh.uvs[uniq[:, 1]], inv.reshape(-1, 3)
    else:
        src, uv, tris = np.arange(len(mesh.vertices)), None, mesh.faces
    bind = proxy.binding(n_base)[src]
    offs = proxy.offset_vectors(base)[src]
    return Piece(name, category, (bind @ base + offs).astype(np.float32), {material: tris}, uv,
                 sp.csr_matrix(bind), weld=src, meta={"offsets": offs, "proxy": proxy.name})


def _eye_piece(base: BaseMesh, verts: np.ndarray, side: str) -> Piece:
    ids = base.group(f"helper-{side[0].lower()}-eye")
    p = verts[ids]
    c = p.mean(0)
    r = 0.5 * float((p.max(0) - p.min(0)).mean())
    name = f"eye_{side[0]}"
    o = eyeball_object(name, c, r, pupil_radius=0.22 * r, iris_radius=0.47 * r,
                       iris_depth=0.03 * r, rings=(3, 4, 14), n_lon=32, cornea=0.2 * r)
    parts = {p_.material: p_.faces for p_ in o.parts}
    # an eyeball moves rigidly with the head: bind every vertex to the eye helper's centroid
    nv = o.n_vertices
    bind = sp.csr_matrix((np.full(nv * len(ids), 1.0 / len(ids)),
                          (np.repeat(np.arange(nv), len(ids)), np.tile(ids, nv))),
                         shape=(nv, len(verts)))
    return Piece(name, "eyes", o.vertices, parts, o.uvs, bind, pivot=c,
                 meta={"offsets": o.vertices - c, "rigid": True})


def _first_hit(orig: np.ndarray, dirs: np.ndarray, tris: np.ndarray, reach: float
               ) -> np.ndarray:
    """Distance along each ray (orig, dirs: (N, 3)) to the nearest of ``tris`` (M, 3, 3)
    within ``reach``, or inf (Möller–Trumbore over all candidate triangles)."""
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    e1, e2 = b - a, c - a
    out = np.full(len(orig), np.inf)
    for k in range(len(orig)):
        d = dirs[k]
        p = np.cross(d, e2)
        det = (e1 * p).sum(1)
        ok = np.abs(det) > 1e-12
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = orig[k] - a
        u = (s * p).sum(1) * inv
        q = np.cross(s, e1)
        v = (q @ d) * inv
        t = (e2 * q).sum(1) * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0) & (t < reach)
        if hit.any():
            out[k] = t[hit].min()
    return out


def tuck_under(skin_piece: Piece, cloth: Piece, *, skin_w: sp.csr_matrix,
               cloth_w: sp.csr_matrix, pose: np.ndarray, reach: float = 0.15,
               margin: float = 0.03) -> int:
    """Push skin vertices that poke through ``cloth`` back under it, in place, as seen in the
    rest pose (bone transforms ``pose``, (B, 3, 4); skin weights ``skin_w``/``cloth_w``): a
    vertex whose inward ray meets the cloth within ``reach`` (base units) moves inward past it
    by ``margin``, under every layer; the move is carried back to bind space through the
    vertex's blended rotation. Returns how many moves it made. (``delete_verts`` hides most
    of the covered body; this fixes the edges: collars, cuffs, armpits.)"""
    from scipy.spatial import cKDTree

    from mimika.face.meshgen import vertex_normals

    # one normal and one move per position: the skin is split at UV seams (weld)
    ids, inv = np.unique(skin_piece.weld, return_inverse=True)
    first = np.zeros(len(ids), np.int64)
    first[inv[::-1]] = np.arange(len(inv))[::-1]
    bind = skin_piece.vertices.astype(np.float64)[first]
    v = skin(bind, skin_w[first], pose)
    tris_all = inv[np.concatenate(list(skin_piece.parts.values()))]
    n = vertex_normals(v, tris_all)
    cf = np.concatenate(list(cloth.parts.values()))
    tri = skin(cloth.vertices.astype(np.float64), cloth_w, pose)[cf]
    kd = cKDTree(tri.mean(1))
    near = np.flatnonzero(kd.query(v, distance_upper_bound=reach * 4)[0] < np.inf)
    rot = (skin_w[first] @ pose[:, :, :3].reshape(len(pose), 9)).reshape(-1, 3, 3)
    moved = 0
    for i in near:
        step = np.zeros(3)
        for _ in range(4):  # layered clothes (collar over shirt): tuck under each layer
            cand = kd.query_ball_point(v[i] + step, reach * 6)
            t = _first_hit(v[i:i + 1] + step, -n[i:i + 1], tri[cand], reach)[0]
            if not np.isfinite(t):
                break
            step -= n[i] * (t + margin)
            moved += 1
        if step.any():
            bind[i] += np.linalg.solve(rot[i], step)
    skin_piece.vertices = bind[inv].astype(np.float32)
    return moved


def settle_cloth(cloth: Piece, weights: sp.csr_matrix, pose: np.ndarray, body: np.ndarray,
                 body_tris: np.ndarray) -> int:
    """Make a fitted garment lie right, in place, as seen in the rest pose (bone transforms
    ``pose``): vertices sunk into the body (``body``, the posed base mesh, whose ``body_tris``
    are the whole body, hidden parts included) rest on it, then panels that cross others are
    lifted clear of them and a panel crumpled through itself is smoothed (:mod:`.layers`). The
    moves are carried back to bind space through each vertex's blended rotation. Returns how
    many vertices moved."""
    from mimika.face.makehuman.layers import layer_offsets, lift_over, smooth_crumples, welded
    from mimika.face.makehuman.paint.regions import uv_islands

    tris = np.concatenate(list(cloth.parts.values()))
    islands = uv_islands(tris, len(cloth.vertices))[tris[:, 0]]
    posed = skin(cloth.vertices.astype(np.float64), weights, pose)
    pos, wtris, inv = welded(posed, tris)
    move = lift_over(pos, wtris, body, body_tris)
    move += layer_offsets(pos + move, wtris, islands)
    move += smooth_crumples(pos + move, wtris, islands)
    moved = _carry_back(cloth, weights, pose, move[inv])
    log.debug("%s: %d vertices settled on the body and clear of other layers", cloth.name,
              moved)
    return moved


#: how far hair rests above the skin at least, how deep under it a dip is mended, and how
#: far above a lifted spot the hair rises with it (base units: 1.5 mm, 3 mm, 2 mm; lifting
#: 1–4 cm of it, as cloth's layers are, turned a card at daniel's temple into a white streak)
HAIR_CLEARANCE = (0.015, 0.03, 0.02)


def settle_hair(hair: Piece, weights: sp.csr_matrix, pose: np.ndarray, body: np.ndarray,
                body_tris: np.ndarray) -> int:
    """Lift hair off the skin where it lies within :data:`HAIR_CLEARANCE` of it or dips
    just under it. The proxies' shells hug the scalp within a millimetre at the hairline;
    where one passes under the forehead's flat triangles the depth test cuts the hairline
    into a jagged edge and its strand tips never show. Deeper parts (a lock meant to pass
    behind an ear) stay. Returns how many vertices moved."""
    from mimika.face.makehuman.layers import lift_over, welded

    tris = np.concatenate(list(hair.parts.values()))
    posed = skin(hair.vertices.astype(np.float64), weights, pose)
    pos, wtris, inv = welded(posed, tris)
    margin, depth, stack = HAIR_CLEARANCE
    move = lift_over(pos, wtris, body, body_tris, margin=margin, depth=depth, stack=stack)
    return _carry_back(hair, weights, pose, move[inv])


def _carry_back(piece: Piece, weights: sp.csr_matrix, pose: np.ndarray, step: np.ndarray
                ) -> int:
    """Move ``piece``'s vertices by ``step`` (N, 3), given in the posed space of bone
    transforms ``pose``, carried back to bind space through each vertex's blended rotation.
    Returns how many moved."""
    sel = np.flatnonzero(np.abs(step).max(1) > 0)
    if not len(sel):
        return 0
    rot = (weights @ pose[:, :, :3].reshape(len(pose), 9)).reshape(-1, 3, 3)
    bind = piece.vertices.astype(np.float64)
    bind[sel] += np.linalg.solve(rot[sel], step[sel][:, :, None])[:, :, 0]
    piece.vertices = bind.astype(np.float32)
    return len(sel)


def blend_cloth_weights(cloth: Piece, weights: sp.csr_matrix, radius: float = 0.3
                        ) -> sp.csr_matrix:
    """Skin weights of a garment averaged over ``radius`` (base units) in space, so panels
    lying on each other (a collar wing on the jacket, a lapel on the front, a sleeve on the
    torso under the arm) bend alike and do not slide through each other when the head turns or
    the shoulders shrug; the fitted weights (from the body under each vertex) differ between
    such layers. 3 cm: at 1.5 cm a full shrug pushed sleeves through jackets and turned
    triangles over under the arms (whole cast 1 544 → 781 px of crossing cloth). Each row is
    renormalised and cut to :data:`MAX_INFLUENCES`."""
    from scipy.spatial import cKDTree

    v = cloth.vertices.astype(np.float64)
    tree = cKDTree(v)
    d = tree.sparse_distance_matrix(tree, radius, output_type="coo_matrix")
    k = sp.csr_matrix((1.0 - d.data / radius, (d.row, d.col)), shape=(len(v), len(v)))
    k = k + sp.identity(len(v), format="csr")
    k = sp.diags(1.0 / np.asarray(k.sum(1)).ravel()) @ k
    return top_influences(sp.csr_matrix(k @ weights))


#: skin influences per vertex (what glTF players and game engines take)
MAX_INFLUENCES = 4


def top_influences(w: sp.csr_matrix, k: int = MAX_INFLUENCES) -> sp.csr_matrix:
    """Keep each row's ``k`` largest weights, renormalised to sum to 1."""
    dense = np.asarray(w.todense(), np.float64)
    if dense.shape[1] > k:
        cut = -np.sort(-dense, axis=1)[:, k - 1:k]
        dense = np.where(dense >= cut, dense, 0.0)
        # ties at the cut could leave more than k: keep the first k in bone order
        over = np.cumsum(dense > 0, axis=1) > k
        dense[over] = 0.0
    s = dense.sum(1, keepdims=True)
    out = sp.csr_matrix(dense / np.where(s > 0, s, 1.0))
    out.eliminate_zeros()
    return out


@dataclass(frozen=True)
class Outfit:
    """What the character wears: asset names (``None`` for none)."""

    hair: str | None = "short02"
    eyebrows: str | None = "eyebrow001"
    eyelashes: str | None = "eyelashes01"
    clothes: tuple[str, ...] = ("male_elegantsuit01",)


@dataclass
class Built:
    """A character in bind space (base units, before the rest pose): pieces, skeleton,
    faceunit shape deltas per piece (S, n, 3), and skin weights per piece (n, B);
    ``lip_seal``: how much of ``mouthClose`` the rest pose took to close the lips (lips.py)."""

    pieces: list[Piece]
    skeleton: Skeleton
    shape_names: tuple[str, ...]
    deltas: dict[str, np.ndarray]
    weights: dict[str, sp.csr_matrix]
    base_vertices: np.ndarray
    lip_seal: float = 0.0


def _skin_piece(base: BaseMesh, verts: np.ndarray, hidden: np.ndarray) -> Piece:
    body = base.faces_of("body")
    keep = ~np.any(np.isin(base.quads[body], hidden), axis=1)
    quads = base.quads[body][keep]
    src, uv, tris = split_by_uv(quads, base.quad_uvs[body][keep], base.uvs)
    n = len(verts)
    bind = sp.csr_matrix((np.ones(len(src)), (np.arange(len(src)), src)), shape=(len(src), n))
    return Piece("skin", "face", verts[src], {"skin": tris}, uv, bind, weld=src,
                 meta={"offsets": np.zeros((len(src), 3))})


def _helper_piece(base: BaseMesh, verts: np.ndarray, group: str, name: str, category: str,
                  material: str) -> Piece:
    """A piece made of the base mesh's own helper faces (e.g. the tongue)."""
    quads = base.quads[base.faces_of(group)]
    src, inv = np.unique(quads, return_inverse=True)
    tris = triangulate(inv.reshape(-1, 4))
    bind = sp.csr_matrix((np.ones(len(src)), (np.arange(len(src)), src)),
                         shape=(len(src), len(verts)))
    return Piece(name, category, verts[src], {material: tris}, None, bind, weld=None,
                 meta={"offsets": np.zeros((len(src), 3))})


def build(phenotype: dict[str, float], outfit: Outfit,
          modifiers: dict[str, float] | None = None) -> Built:
    """The character for ``phenotype`` values and face ``modifiers`` (see :mod:`.targets`)
    wearing ``outfit``."""
    base = load_base()
    verts = apply_modifiers(apply_macros(base.vertices, phenotype), modifiers or {})
    skel = build_skeleton(base, verts)
    n = len(verts)
    proxies: list[tuple[str, str, str, Proxy]] = []
    for kind, name, obj, cat, mat in (
        ("hair", outfit.hair, "hair", "face", "hair"),
        ("eyebrows", outfit.eyebrows, "brows", "face", "brow"),
        ("eyelashes", outfit.eyelashes, "lashes", "face", "lash"),
    ):
        if name:
            proxies.append((obj, cat, mat, read_mhclo(asset_path(kind, name))))
    for k, name in enumerate(outfit.clothes):
        proxies.append((f"clothes{k}" if k else "clothes", "body", "cloth",
                        read_mhclo(asset_path("clothes", name))))
    hidden = np.unique(np.concatenate([p.delete_verts for *_, p in proxies] or
                                      [np.zeros(0, np.int64)]))
    pieces = [_skin_piece(base, verts, hidden)]
    pieces += [_eye_piece(base, verts, "L"), _eye_piece(base, verts, "R")]
    teeth = read_mhclo(asset_path("teeth", "teeth_base"))
    pieces.append(proxy_piece(teeth, "teeth", "teeth", "teeth", n, verts))
    pieces.append(_helper_piece(base, verts, "helper-tongue", "tongue", "teeth", "tongue"))
    for obj, cat, mat, proxy in proxies:
        pieces.append(proxy_piece(proxy, obj, cat, mat, n, verts))

    names = faceunit_names()
    dense = np.stack([read_faceunit(s).dense(n) for s in names])  # (S, N, 3)
    deltas, weights = {}, {}
    for p in pieces:
        if p.category == "eyes":  # eyes turn by rotation (the rig), not by faceunit offsets
            deltas[p.name] = np.zeros((len(names), len(p.vertices), 3), np.float32)
        else:
            deltas[p.name] = np.stack([p.binding @ d for d in dense]).astype(np.float32)
        weights[p.name] = top_influences(sp.csr_matrix(p.binding @ skel.weights))
    rest = skel.transforms(rest_pose(skel))
    for p in pieces:
        if p.category == "body":
            weights[p.name] = blend_cloth_weights(p, weights[p.name])
    body = skin(verts, top_influences(skel.weights), rest)
    body_tris = triangulate(base.quads[base.faces_of("body")])
    for p in pieces:
        if p.category == "body":
            settle_cloth(p, weights[p.name], rest, body, body_tris)
        elif p.name == "hair":
            settle_hair(p, weights[p.name], rest, body, body_tris)
    for _ in range(2):  # a second pass catches skin the first one's moves turned outward
        for p in pieces:
            if p.category == "body":
                tuck_under(pieces[0], p, skin_w=weights["skin"], cloth_w=weights[p.name],
                           pose=rest)
    log.debug("character: %d pieces, %d vertices", len(pieces),
              sum(len(p.vertices) for p in pieces))
    return Built(pieces, skel, names, deltas, weights, verts)
