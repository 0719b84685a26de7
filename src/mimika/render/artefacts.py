"""Pixel checks of a dressed character in a rendered frame: object/triangle ID images with depth
peeling (:func:`id_layers`) and :func:`check_frame`, which finds visible cloth passing through
cloth or skin, skin through clothes or between hair cards, and z-fighting. The geometric checks
behind them are in :mod:`mimika.face.makehuman.artefacts`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mimika.face.makehuman.artefacts import ClothReport, check_cloth
from mimika.render.context import get_context, render_lock

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
