"""Geometric checks of a dressed character: cloth layers that pass through each other (a collar
through its jacket looks torn and jagged), skin through clothes, over-stretched or flipped cloth
triangles.

Everything works on plain arrays (positions (N, 3), triangles (F, 3)), so the same checks run
on a piece being built, on a posed head, or on any frame of a rig.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree


def weld_key(vertices: np.ndarray, decimals: int = 5) -> np.ndarray:
    """Per vertex, the index of its position among the unique positions (a mesh split at UV
    seams has several vertices per position)."""
    _, key = np.unique(np.round(np.asarray(vertices, np.float64), decimals), axis=0,
                       return_inverse=True)
    return key.ravel()


def _segments_hit(p0: np.ndarray, p1: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Whether each segment p0→p1 (K, 3) crosses the matching triangle (K, 3, 3)."""
    d = p1 - p0
    a = tri[:, 0]
    e1, e2 = tri[:, 1] - a, tri[:, 2] - a
    pv = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, pv)
    ok = np.abs(det) > 1e-14
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = p0 - a
    u = np.einsum("ij,ij->i", s, pv) * inv
    q = np.cross(s, e1)
    v = np.einsum("ij,ij->i", d, q) * inv
    t = np.einsum("ij,ij->i", e2, q) * inv
    return ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= 1)


def candidate_pairs(ca: np.ndarray, ra: np.ndarray, cb: np.ndarray, rb: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (i, j) whose bounding spheres (centres ``c``, radii ``r``) overlap."""
    if not len(ca) or not len(cb):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    near = cKDTree(cb).query_ball_point(ca, ra + rb.max())
    i = np.repeat(np.arange(len(ca)), [len(n) for n in near])
    j = np.fromiter((x for n in near for x in n), np.int64, len(i))
    keep = np.linalg.norm(ca[i] - cb[j], axis=1) <= ra[i] + rb[j]
    return i[keep], j[keep]


def intersecting_pairs(va: np.ndarray, ta: np.ndarray, vb: np.ndarray, tb: np.ndarray, *,
                       key_a: np.ndarray | None = None, key_b: np.ndarray | None = None
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Triangle pairs (i into ``ta``, j into ``tb``) that pass through each other.

    With ``key_a``/``key_b`` (welded vertex ids, e.g. :func:`weld_key` of one mesh for both),
    pairs sharing a vertex are neighbours, not intersections, and are left out.
    """
    A = np.asarray(va, np.float64)[ta]
    B = np.asarray(vb, np.float64)[tb]
    ca, cb = A.mean(1), B.mean(1)
    ra = np.linalg.norm(A - ca[:, None], axis=2).max(1)
    rb = np.linalg.norm(B - cb[:, None], axis=2).max(1)
    i, j = candidate_pairs(ca, ra, cb, rb)
    if key_a is not None and key_b is not None and len(i):
        share = (key_a[ta[i]][:, :, None] == key_b[tb[j]][:, None, :]).any((1, 2))
        i, j = i[~share], j[~share]
    hit = np.zeros(len(i), bool)
    for x, y, ix, iy in ((A, B, i, j), (B, A, j, i)):
        for k in range(3):
            hit |= _segments_hit(x[ix, k], x[ix, (k + 1) % 3], y[iy])
    return i[hit], j[hit]


def self_intersections(v: np.ndarray, tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs i < j of a mesh's triangles that pass through each other (neighbours over a
    shared position do not count)."""
    key = weld_key(v)
    i, j = intersecting_pairs(v, tris, v, tris, key_a=key, key_b=key)
    keep = i < j
    return i[keep], j[keep]


def triangle_normals(v: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Unit normals (F, 3) (zero for degenerate triangles)."""
    p = np.asarray(v, np.float64)[tris]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    return n / np.where(ln > 0, ln, 1.0)


def edge_stretch(rest: np.ndarray, posed: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Per triangle, the largest ratio of an edge's posed length to its rest length, or of
    rest to posed (≥ 1; 1 = no stretch)."""
    def lengths(v: np.ndarray) -> np.ndarray:
        p = np.asarray(v, np.float64)[tris]
        return np.linalg.norm(p - np.roll(p, 1, axis=1), axis=2)

    a, b = lengths(rest), lengths(posed)
    r = np.where(a > 1e-9, b / np.maximum(a, 1e-9), 1.0)
    return np.maximum(r, 1.0 / np.maximum(r, 1e-9)).max(1)


@dataclass
class ClothReport:
    """Offending triangles of one frame (counts; ``pairs`` for a closer look)."""

    cloth_cloth: int  #: cloth triangle pairs passing through each other
    skin_cloth: int  #: skin triangles passing through a cloth triangle
    stretched: int  #: cloth triangles with an edge stretched or squeezed past ``max_stretch``
    flipped: int  #: cloth triangles turned over (normal against their rest normal's turn)
    cloth_tris: np.ndarray  #: indices of the cloth triangles in any of the above
    skin_tris: np.ndarray  #: indices of the skin triangles through cloth

    def total(self) -> int:
        return self.cloth_cloth + self.skin_cloth + self.stretched + self.flipped


def check_cloth(skin_v: np.ndarray, skin_t: np.ndarray, cloth_v: np.ndarray,
                cloth_t: np.ndarray, *, cloth_rest: np.ndarray | None = None,
                turn: np.ndarray | None = None, max_stretch: float = 2.0,
                region: np.ndarray | None = None) -> ClothReport:
    """Check a posed cloth mesh against itself and the posed skin.

    ``cloth_rest``: its rest positions, for stretch and flip checks; ``turn`` (F, 3, 3): each
    cloth triangle's rotation from rest (a flipped triangle's normal points against its turned
    rest normal); ``region``: (lo, hi) corners of a box; only triangles with a corner inside
    count (what a camera sees).
    """
    ct = np.asarray(cloth_t)
    st = np.asarray(skin_t)
    if region is not None:
        lo, hi = np.asarray(region, np.float64)

        def inside(v: np.ndarray, t: np.ndarray) -> np.ndarray:
            p = np.asarray(v)[t]
            return np.any(np.all((p >= lo) & (p <= hi), axis=2), axis=1)

        c_sel = np.flatnonzero(inside(cloth_v, ct))
        s_sel = np.flatnonzero(inside(skin_v, st))
    else:
        c_sel, s_sel = np.arange(len(ct)), np.arange(len(st))
    i, j = self_intersections(cloth_v, ct[c_sel])
    si, sj = intersecting_pairs(skin_v, st[s_sel], cloth_v, ct[c_sel])
    bad = [c_sel[i], c_sel[j], c_sel[sj]]
    stretched = flipped = 0
    if cloth_rest is not None:
        s = edge_stretch(cloth_rest, cloth_v, ct[c_sel]) > max_stretch
        n0 = triangle_normals(cloth_rest, ct[c_sel])
        if turn is not None:
            n0 = np.einsum("fij,fj->fi", turn[c_sel], n0)
        n1 = triangle_normals(cloth_v, ct[c_sel])
        f = np.einsum("ij,ij->i", n0, n1) < 0.0
        stretched, flipped = int(s.sum()), int(f.sum())
        bad += [c_sel[s], c_sel[f]]
    return ClothReport(len(i), len(np.unique(si)), stretched, flipped,
                       np.unique(np.concatenate(bad)), s_sel[np.unique(si)])


_ID_VERT = """
#version 330
uniform mat4 u_mvp;
in vec3 in_pos;
void main() { gl_Position = u_mvp * vec4(in_pos, 1.0); }
"""
_ID_FRAG = """
#version 330
uniform int u_obj;
uniform int u_peel;
uniform sampler2D u_prev;
out ivec2 f_id;
void main() {
    if (u_peel == 1 && gl_FragCoord.z <= texelFetch(u_prev, ivec2(gl_FragCoord.xy), 0).r)
        discard;
    f_id = ivec2(u_obj, gl_PrimitiveID);
}
"""


@dataclass
class IdLayer:
    """One depth layer of an ID render: per pixel (row 0 = top) the object index (−1: none),
    the triangle index within that object and the distance along the view axis (cm; inf)."""

    obj: np.ndarray
    tri: np.ndarray
    depth: np.ndarray


def id_layers(meshes: list[tuple[np.ndarray, np.ndarray]], camera, size: tuple[int, int],
              layers: int = 1) -> list[IdLayer]:
    """Render ``meshes`` ((vertices (N, 3) cm, triangles (F, 3)) each) with ``camera`` into
    object/triangle ID images, front surface first, then each next surface behind it (depth
    peeling), no culling. Needs headless OpenGL (:mod:`mimika.render.context`)."""
    from mimika.render.context import get_context, render_lock

    w, h = size
    mvp = (camera.projection_matrix @ camera.view_matrix).T.astype("f4").tobytes()
    n, f = camera.near, camera.far
    ctx = get_context()
    out: list[IdLayer] = []
    with render_lock, ctx:
        prog = ctx.program(vertex_shader=_ID_VERT, fragment_shader=_ID_FRAG)
        prog["u_mvp"].write(mvp)
        ids = ctx.texture((w, h), 2, dtype="i4")
        depth = ctx.depth_texture((w, h))
        prev = ctx.depth_texture((w, h))
        prev.filter = (ctx.NEAREST, ctx.NEAREST)
        prev.compare_func = ""
        fbo = ctx.framebuffer([ids], depth)
        objs = []
        try:
            for v, t in meshes:
                vbo = ctx.buffer(np.ascontiguousarray(v, np.float32).tobytes())
                ibo = ctx.buffer(np.ascontiguousarray(t, np.int32).tobytes())
                objs.append((vbo, ibo, ctx.vertex_array(prog, [(vbo, "3f", "in_pos")], ibo, 4)))
            prev.write(np.zeros((h, w), np.float32).tobytes())
            for k in range(layers):
                fbo.use()
                ctx.viewport = (0, 0, w, h)
                ctx.disable(ctx.CULL_FACE | ctx.BLEND)
                ctx.enable(ctx.DEPTH_TEST)
                fbo.clear(depth=1.0)
                ids.write(np.full((h, w, 2), -1, np.int32).tobytes())
                prog["u_peel"].value = int(k > 0)
                prev.use(0)
                prog["u_prev"].value = 0
                for i, (_, _, vao) in enumerate(objs):
                    prog["u_obj"].value = i
                    vao.render()
                raw = np.frombuffer(ids.read(), np.int32).reshape(h, w, 2)[::-1]
                z = np.frombuffer(depth.read(), np.float32).reshape(h, w)
                zn = 2.0 * z[::-1].astype(np.float64) - 1.0
                lin = np.where(z[::-1] < 1.0, 2.0 * n * f / (f + n - zn * (f - n)), np.inf)
                out.append(IdLayer(raw[:, :, 0].copy(), raw[:, :, 1].copy(), lin))
                prev.write(z.tobytes())
        finally:
            for o in objs:
                for x in o[::-1]:
                    x.release()
            for x in (fbo, ids, depth, prev, prog):
                x.release()
    return out


#: skin seen less than this in front of a cloth (or hair) surface is poking through it (cm)
POKE_CM = 1.5
#: two surfaces closer than this along a pixel's ray fight for the depth buffer (cm)
ZFIGHT_CM = 0.03


@dataclass
class FrameCheck:
    """Offending pixels of one rendered frame (boolean masks, row 0 = top) and the geometric
    report behind them."""

    cloth_cross: np.ndarray  #: visible cloth on a triangle passing through cloth or skin
    skin_through: np.ndarray  #: skin seen through (in front of and just above) clothes
    hair_gap: np.ndarray  #: skin seen through narrow gaps between hair cards
    zfight: np.ndarray  #: the two nearest surfaces of different pieces almost coincide
    report: ClothReport

    def counts(self) -> dict[str, int]:
        return {"cloth_cross_px": int(self.cloth_cross.sum()),
                "skin_through_px": int(self.skin_through.sum()),
                "hair_gap_px": int(self.hair_gap.sum()),
                "zfight_px": int(self.zfight.sum()),
                "cloth_cloth_tris": self.report.cloth_cloth,
                "skin_cloth_tris": self.report.skin_cloth,
                "stretched_tris": self.report.stretched,
                "flipped_tris": self.report.flipped}

    def mask(self) -> np.ndarray:
        return self.cloth_cross | self.skin_through | self.hair_gap | self.zfight


def _covered(layer: IdLayer, erode: int = 1) -> np.ndarray:
    from scipy import ndimage

    m = layer.obj >= 0
    return ndimage.binary_erosion(m, iterations=erode) if erode else m


def check_frame(head, positions: dict[str, np.ndarray] | None, camera,
                size: tuple[int, int], *, rest: dict[str, np.ndarray] | None = None,
                turn: np.ndarray | None = None, desk: float = 0.0) -> FrameCheck:
    """Render ``head`` at ``positions`` (object → (N, 3) cm; missing objects at rest) with
    ``camera`` into ID images and find offending pixels: cloth passing through cloth or skin,
    skin through clothes or hair, z-fighting. ``rest``: positions the stretch and flip checks
    compare with (default: the head's rest), ``turn``: per cloth triangle rotations from rest;
    ``desk``: the share of the image height a desk covers at the bottom (not checked).
    """
    pos = {o.name: np.asarray((positions or {}).get(o.name, o.vertices), np.float64)
           for o in head.objects}
    objs = [o for o in head.objects if o.parts]
    names = [o.name for o in objs]
    cloth = [k for k, o in enumerate(objs) if o.category == "body"]
    skin_k = names.index("skin")
    hair_k = [k for k, o in enumerate(objs) if o.name == "hair"]
    meshes = [(pos[o.name], o.faces) for o in objs]
    front, second = id_layers(meshes, camera, size, layers=2)
    sk = objs[skin_k]
    # geometry: every cloth piece against itself and the skin, in the camera's view
    lo, hi = _view_box(camera, pos[sk.name])
    reports = []
    bad_tris: dict[int, np.ndarray] = {}
    for k in cloth:
        o = objs[k]
        base = (rest or {}).get(o.name, o.vertices)
        r = check_cloth(pos[sk.name], sk.faces, pos[o.name], o.faces, cloth_rest=base,
                        turn=turn, region=(lo, hi))
        reports.append(r)
        bad_tris[k] = r.cloth_tris
    report = ClothReport(*(sum(getattr(r, a) for r in reports) for a in
                           ("cloth_cloth", "skin_cloth", "stretched", "flipped")),
                         np.concatenate([r.cloth_tris for r in reports] or [np.zeros(0, int)]),
                         np.unique(np.concatenate([r.skin_tris for r in reports]
                                                  or [np.zeros(0, int)])))
    cross = np.zeros(front.obj.shape, bool)
    for k, tris in bad_tris.items():
        cross |= (front.obj == k) & np.isin(front.tri, tris)
    skin_vis = front.obj == skin_k

    (only,) = id_layers([meshes[k] for k in cloth], camera, size)
    with np.errstate(invalid="ignore"):
        gap = only.depth - front.depth
        through = skin_vis & _covered(only) & (gap >= 0) & (gap < POKE_CM)
        zf = ((second.obj >= 0) & (second.obj != front.obj)
              & (np.abs(second.depth - front.depth) < ZFIGHT_CM)
              & np.isin(front.obj, [skin_k, *cloth]) & np.isin(second.obj, [skin_k, *cloth]))
    hair_gap = np.zeros_like(skin_vis)
    if hair_k:
        from scipy import ndimage

        # skin in narrow gaps of the hair one sees (up to ~1 % of the image height wide)
        cov = np.isin(front.obj, hair_k)
        reach = max(2, size[1] // 180)
        hair_gap = ndimage.binary_closing(cov, iterations=reach, border_value=0) & skin_vis

    seen = np.ones(front.obj.shape, bool)
    seen[size[1] - round(desk * size[1]):] = False
    return FrameCheck(cross & seen, through & seen, hair_gap & seen, zf & seen, report)


def _view_box(camera, skin_v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """An axis-aligned box (lo, hi) around what ``camera`` sees of a body (its view frustum
    cut to the body's depth range), padded by 2 cm."""
    v = np.asarray(skin_v, np.float64)
    clip = np.c_[v, np.ones(len(v))] @ (camera.projection_matrix @ camera.view_matrix).T
    ndc = clip[:, :2] / np.where(clip[:, 3:] > 0, clip[:, 3:], 1.0)
    seen = (clip[:, 3] > 0) & (np.abs(ndc) <= 1.0).all(1)
    if not seen.any():
        return v.min(0), v.max(0)
    return v[seen].min(0) - 2.0, v[seen].max(0) + 2.0
