"""Texture-space skin shading (seed 004 §4.6).

The skin shader runs in three passes per frame:

(a) irradiance — the skin's diffuse light (wrap lighting incl. the scatter tint) is rendered
    into a texture by drawing the mesh at its UVs (``skin_irradiance.*.glsl``); a second target
    records cm per texel (the stretch map);
(b) blur — ``passes`` iterations of a separable Gaussian (8 importance-sampled taps per
    direction, ping-pong between two textures), radius per iteration in cm (``sigma_cm``),
    converted to texels with the stretch map (``skin_blur.frag.glsl``);
(c) final — the skin drawn from the camera: albedo × (per-channel mix of sharp and blurred
    irradiance; red scatters farthest) + Torrance–Sparrow specular (``skin_final.*.glsl``).

Only parts with a skin-like material (:data:`SKIN_MATERIALS`) of objects with UVs take part;
everything else keeps the standard shader. Triangles whose UVs jump across a seam are drawn by
pass (c) with the sharp irradiance only.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from mimika.render.context import has_uniform
from mimika.render.lighting import V3, Lighting, set_lights

log = logging.getLogger(__name__)

#: materials drawn with the skin shader
SKIN_MATERIALS = ("skin", "lips")
#: the renderer's dynamic vertex buffer: position, normal, occlusion (ambient occlusion,
#: visibility through the mouth opening, inside the mouth)
VERTEX_LAYOUT = "3f 3f 3f"
VERTEX_ATTRIBUTES = ("in_position", "in_normal", "in_occ")


@dataclass(frozen=True)
class SkinParams:
    """Skin shader settings: irradiance texture ``size`` (texels, w × h), blur ``passes``
    (1-D passes of 8 taps, alternating along u and v, ping-pong), Gaussian σ per pass in cm
    (the passes add up: total σ = √Σσ²), per-channel share of the blurred light ``mix`` (RGB),
    Beckmann ``roughness``, a ``specular`` scale, the texture ``dtype`` and whether to blur
    only the texels of camera-facing skin (``cull``). ``refresh`` > 1 reuses the blurred
    irradiance for that many frames (temporal amortisation for video: at 25 fps the diffuse
    light of slowly moving skin changes too little between two frames to see)."""

    size: tuple[int, int] = (256, 128)
    passes: int = 4
    sigma_cm: tuple[float, ...] = (0.2, 0.2, 0.35, 0.35)
    mix: V3 = (0.8, 0.55, 0.4)
    roughness: float = 0.35
    specular: float = 8.0
    dtype: str = "f2"
    cull: bool = True
    refresh: int = 1  #: recompute the blurred irradiance every ``refresh`` frames (video: 3)


def write_wrinkles(prog: Any, depths: bytes | None) -> None:
    """Set ``u_wr``, the wrinkle groups' depths (28 floats; None: all 0), where ``prog`` has it
    (a program with only some groups compiled in keeps the array up to the last it uses)."""
    if has_uniform(prog, "u_wr"):
        u = prog["u_wr"]
        u.write((depths or bytes(4 * 28))[: 4 * u.array_length])


def seam_faces(uv: np.ndarray, faces: np.ndarray, *, limit: float = 0.25) -> np.ndarray:
    """Mask (F,) of triangles whose normalised UVs span more than ``limit`` (seam jumps)."""
    t = uv[faces]  # (F, 3, 2)
    ext = t.max(1) - t.min(1)
    return (ext > limit).any(1)


class _SkinObject:
    """Skin parts of one GPU object: UV buffer, index buffers and VAOs for passes (a), (c)."""

    def __init__(self, ctx: Any, gpu: Any, uv: np.ndarray, raw_uv: np.ndarray, irr: Any,
                 final_for: Callable[[int], Any]) -> None:
        self.gpu = gpu
        self.uv = np.ascontiguousarray(uv, np.float32)  # normalised to the skin's UV frame
        self.uv_vbo = ctx.buffer(np.ascontiguousarray(raw_uv, np.float32).tobytes())
        self.mask: np.ndarray | None = None  # vertices of the skin-shaded parts
        #: first → (ibo, vao_a, vao_c, n, the program of pass (c))
        self.parts: dict[int, tuple[Any, Any, Any, int, Any]] = {}
        self.rest_parts: dict[int, tuple[Any, int]] = {}  # seam triangles: (ibo_std, n)
        faces = gpu.faces
        for mat, first, count, *_ in gpu.parts:
            if mat.name not in SKIN_MATERIALS:
                continue
            f = faces[first // 3: (first + count) // 3]
            seam = seam_faces(uv, f)
            good = np.ascontiguousarray(f[~seam], np.int32)
            if not len(good):
                continue
            ibo = ctx.buffer(good.tobytes())
            face = [(gpu.face_vbo, "3f", "in_face")] if gpu.face_vbo is not None else []
            # pass (c) with the wrinkle groups that reach the part (none off the face) and its
            # detail map if it has one
            final = final_for(gpu.groups.get(first, 0), first in gpu.details)
            vaos = [ctx.vertex_array(p, [(gpu.vbo, VERTEX_LAYOUT, *VERTEX_ATTRIBUTES),
                                         (self.uv_vbo, "2f", "in_uv"), *face], ibo, 4,
                                     skip_errors=True) for p in (irr, final)]
            self.parts[first] = (ibo, vaos[0], vaos[1], 3 * len(good), final)
            if self.mask is None:
                self.mask = np.zeros(len(uv), bool)
            self.mask[good.ravel()] = True
            if seam.any():
                bad = np.ascontiguousarray(f[seam], np.int32)
                ib2 = ctx.buffer(bad.tobytes())
                vao = ctx.vertex_array(final, [(gpu.vbo, VERTEX_LAYOUT, *VERTEX_ATTRIBUTES),
                                               (self.uv_vbo, "2f", "in_uv"), *face], ib2,
                                       4, skip_errors=True)
                self.rest_parts[first] = (ib2, vao, 3 * len(bad))
                log.debug("skin: %d seam triangles of %r drawn without the blurred light",
                          int(seam.sum()), gpu.name)

    def release(self) -> None:
        for ibo, va, vc, *_ in self.parts.values():
            for o in (va, vc, ibo):
                o.release()
        for ibo, vao, _ in self.rest_parts.values():
            vao.release()
            ibo.release()
        self.uv_vbo.release()


class SkinShader:
    """GPU state and passes of the texture-space skin shader for a renderer's objects.

    ``objects`` are the renderer's GPU objects (with ``name``, ``vbo``, ``faces``, ``parts``,
    ``vao``); ``uvs`` maps object names to (N, 2) UVs. Objects without UVs are ignored.
    """

    def __init__(self, ctx: Any, objects: list[Any], uvs: dict[str, np.ndarray],
                 lighting: Lighting, params: SkinParams | None = None,
                 defines: tuple[str, ...] = (), final_defines: tuple[str, ...] = ()) -> None:
        from mimika.render.renderer import _shader

        self.params = p = params or SkinParams()
        self.lighting = lighting
        self.ctx = ctx
        self.irr = ctx.program(vertex_shader=_shader("skin_irradiance.vert.glsl", *defines),
                               fragment_shader=_shader("skin_irradiance.frag.glsl", *defines))
        self.blur = ctx.program(vertex_shader=_shader("background.vert.glsl"),
                                fragment_shader=_shader("skin_blur.frag.glsl"))
        #: pass (c) by the wrinkle groups compiled in (``final_defines`` and WR_GROUPS; 0:
        #: neither, for parts off the face) and whether a detail map is (DETAIL)
        self.finals: dict[tuple[int, bool], Any] = {}

        def final_for(groups: int, detail: bool) -> Any:
            if (groups, detail) not in self.finals:
                fd = (*defines, *final_defines, f"WR_GROUPS {groups}") if groups else defines
                fd += ("DETAIL",) * detail
                self.finals[groups, detail] = ctx.program(
                    vertex_shader=_shader("skin_final.vert.glsl", *fd),
                    fragment_shader=_shader("skin_final.frag.glsl", *fd))
            return self.finals[groups, detail]

        # one UV frame for all skin parts: their bounding box → [0, 1]²
        used = []
        for o in objects:
            if o.name in uvs and any(m.name in SKIN_MATERIALS for m, *_ in o.parts):
                sk = np.concatenate([o.faces[f // 3: (f + c) // 3] for m, f, c, *_ in o.parts
                                     if m.name in SKIN_MATERIALS])
                used.append(np.asarray(uvs[o.name], np.float64)[np.unique(sk)])
        if not used:
            raise ValueError("no skin part has UVs")
        allv = np.concatenate(used)
        lo, hi = allv.min(0), allv.max(0)
        span = np.maximum(hi - lo, 1e-6)
        pad = 0.01 * span
        lo, span = lo - pad, span + 2 * pad
        self.uv_xform = (float(lo[0]), float(lo[1]), float(1 / span[0]), float(1 / span[1]))
        self.objects: dict[str, _SkinObject] = {}
        for o in objects:
            if o.name in uvs:
                raw = np.asarray(uvs[o.name], np.float64)
                so = _SkinObject(ctx, o, (raw - lo) / span, raw, self.irr, final_for)
                if so.parts:
                    self.objects[o.name] = so
                else:
                    so.release()
        for prog in self.programs:
            set_lights(prog, lighting)
            prog["u_uv_xform"].value = self.uv_xform
        w, h = p.size
        self.tex = [ctx.texture((w, h), 4, dtype=p.dtype) for _ in range(2)]
        self.stretch = ctx.texture((w, h), 4, dtype=p.dtype)
        for t in (*self.tex, self.stretch):
            t.filter = (ctx.LINEAR, ctx.LINEAR)
            t.repeat_x = t.repeat_y = False
        self.fbo_irr = ctx.framebuffer(color_attachments=[self.tex[0], self.stretch])
        self.fbos = [ctx.framebuffer(color_attachments=[t]) for t in self.tex]
        self.blur_vao = ctx.vertex_array(self.blur, [])
        self.blur["u_texel"].value = (1.0 / w, 1.0 / h)
        for prog in self.finals.values():
            prog["u_mix"].value = p.mix
            prog["u_roughness"].value = p.roughness
        self.result = self.tex[0]
        self._frame = -1
        log.debug("skin shader: %d object(s), %dx%d texels, %d passes", len(self.objects), w, h,
                  p.passes)

    @property
    def programs(self) -> list[Any]:
        """Every program of the passes that light the skin."""
        return [self.irr, *self.finals.values()]

    def handles(self, gpu: Any, first: int) -> bool:
        """True if the part of ``gpu`` starting at index ``first`` is drawn by the skin shader."""
        so = self.objects.get(gpu.name)
        return so is not None and first in so.parts

    def prepare(self, ctx: Any, view_matrix: np.ndarray) -> None:
        """Passes (a) and (b): irradiance into texture space, then the blur; call after the
        vertex buffers hold this frame's positions. Changes the framebuffer and viewport."""
        p = self.params
        w, h = p.size
        vm = view_matrix.T.astype("f4").tobytes()
        for prog in self.finals.values():
            prog["u_view"].write(vm)
        self._frame += 1
        if p.refresh > 1 and self._frame % p.refresh:
            return  # reuse the blurred irradiance of the previous frame
        self.irr["u_view"].write(vm)
        ctx.disable(ctx.DEPTH_TEST | ctx.BLEND | ctx.CULL_FACE)
        self.fbo_irr.use()
        ctx.viewport = (0, 0, w, h)
        self.fbo_irr.clear(0.0, 0.0, 0.0, 0.0)
        for so in self.objects.values():
            for first, (_, vao_a, _, n, _) in so.parts.items():
                mat = next(m for m, f, *_ in so.gpu.parts if f == first)
                self.irr["u_wrap"].value = mat.wrap
                self.irr["u_scatter"].value = mat.scatter
                vao_a.render(ctx.TRIANGLES, vertices=n)
        self.stretch.use(location=1)
        self.blur["u_stretch"].value = 1
        self.blur["u_src"].value = 0
        self.fbos[1].clear(0.0, 0.0, 0.0, 0.0)
        rect = self._visible_rect(view_matrix) if p.cull else None
        for f in self.fbos:
            f.scissor = rect
        src = 0
        for k in range(p.passes):
            sigma = p.sigma_cm[min(k, len(p.sigma_cm) - 1)]
            dst = 1 - src
            self.fbos[dst].use()
            self.tex[src].use(location=0)
            self.blur["u_dir"].value = (1.0, 0.0) if k % 2 == 0 else (0.0, 1.0)
            self.blur["u_sigma_cm"].value = sigma
            self.blur_vao.render(ctx.TRIANGLES, vertices=3)
            src = dst
        self.result = self.tex[src]

    def invalidate(self) -> None:
        """The next :meth:`prepare` recomputes the irradiance even if ``refresh`` > 1."""
        self._frame = -1

    def _visible_rect(self, view_matrix: np.ndarray) -> tuple[int, int, int, int] | None:
        """Texel rectangle (x, y, w, h) holding the skin that faces the camera, with a margin
        of the blur's reach; None if everything is visible."""
        w, h = self.params.size
        vm = np.asarray(view_matrix, np.float64)
        eye = (-vm[:3, :3].T @ vm[:3, 3]).astype(np.float32)  # camera position, world
        lo = np.array([np.inf, np.inf])
        hi = -lo
        for so in self.objects.values():
            pos, nrm = so.gpu.interleaved[:, :3], so.gpu.interleaved[:, 3:6]
            vis = np.einsum("ij,ij->i", nrm, eye[None, :] - pos) > 0.0
            if so.mask is not None:
                vis &= so.mask
            if vis.any():
                uv = so.uv[vis]
                lo = np.minimum(lo, uv.min(0))
                hi = np.maximum(hi, uv.max(0))
        if not np.isfinite(lo).all():
            return None
        m = 28  # texels: the blur's reach
        x0 = max(int(lo[0] * w) - m, 0)
        y0 = max(int(lo[1] * h) - m, 0)
        x1 = min(int(np.ceil(hi[0] * w)) + m, w)
        y1 = min(int(np.ceil(hi[1] * h)) + m, h)
        return (x0, y0, x1 - x0, y1 - y0)

    def draw(self, ctx: Any, gpu: Any, first: int, mat: Any, proj_matrix: np.ndarray,
             backface: float, albedo: Any = None, wrinkles: bytes | None = None) -> None:
        """Pass (c) for one part (its seam triangles with the sharp irradiance only);
        ``albedo``: the part's texture (RGB colour, alpha a gloss map) or None; ``wrinkles``:
        this frame's wrinkle depths (``u_wr``), None for smooth skin."""
        so = self.objects[gpu.name]
        _, _, vao_c, n, f = so.parts[first]
        self.result.use(location=0)
        write_wrinkles(f, wrinkles)
        f["u_irr"].value = 0
        f["u_textured"].value = albedo is not None
        if albedo is not None:
            albedo.use(location=1)
            f["u_albedo"].value = 1
        if first in gpu.details:
            gpu.details[first].use(location=2)
            f["u_detail"].value = 2
        f["u_proj"].write(proj_matrix.T.astype("f4").tobytes())
        f["u_base"].value = mat.color
        f["u_specular"].value = mat.specular * self.params.specular
        f["u_wrap"].value = mat.wrap
        f["u_scatter"].value = mat.scatter
        f["u_backface"].value = backface
        vao_c.render(ctx.TRIANGLES, vertices=n)
        if first in so.rest_parts:
            _, vao, m = so.rest_parts[first]
            f["u_mix"].value = (0.0, 0.0, 0.0)
            vao.render(ctx.TRIANGLES, vertices=m)
            f["u_mix"].value = self.params.mix

    def release(self) -> None:
        for so in self.objects.values():
            so.release()
        self.objects = {}
        for o in (self.blur_vao, *self.fbos, self.fbo_irr, *self.tex, self.stretch,
                  self.blur, *self.programs):
            o.release()
