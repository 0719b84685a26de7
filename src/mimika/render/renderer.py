"""Headless OpenGL renderer for a :class:`~mimika.face.head.Head`.

Each frame recomputes smooth vertex normals from the given positions (one sparse
vertex–face product per object), rewrites a dynamic vertex buffer, draws every part with its
material into a multisample framebuffer over a studio backdrop, resolves and reads back RGB.
"""

from __future__ import annotations

import functools
import json
import logging
import re
from collections.abc import Mapping
from dataclasses import dataclass, replace
from importlib import resources
from typing import Any

import numpy as np
import scipy.sparse as sp

from mimika.errors import ParameterError, RenderError
from mimika.face.head import Head, MeshObject
from mimika.render.camera import Camera, check_view, frame_head
from mimika.render.context import get_context, render_lock

log = logging.getLogger(__name__)

# Lights in camera space (x right, y up, +z toward the viewer); colours are linear.
KEY_DIR, KEY_COL = (-0.55, 0.55, 0.62), (1.0, 0.93, 0.85)
FILL_DIR, FILL_COL = (0.75, 0.05, 0.55), (0.30, 0.34, 0.40)
RIM_DIR, RIM_COL = (0.45, 0.55, -0.7), (0.55, 0.55, 0.6)
SKY, GROUND = (0.24, 0.26, 0.30), (0.10, 0.085, 0.075)
EXPOSURE = 1.05
BACKFACE = 0.3  # brightness of back faces (the inside of the skin seen through openings)
# Backdrop, sRGB.
BG_TOP, BG_BOTTOM, BG_GLOW = (0.25, 0.28, 0.33), (0.09, 0.10, 0.12), (0.05, 0.055, 0.06)


def srgb_to_linear(hex_color: str) -> tuple[float, float, float]:
    """``"#rrggbb"`` (sRGB) to a linear RGB triple in [0, 1]."""
    h = hex_color.lstrip("#")
    if len(h) != 6:
        raise ValueError(f"colour {hex_color!r} is not #rrggbb")
    c = np.array([int(h[i : i + 2], 16) for i in (0, 2, 4)]) / 255.0
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return (float(lin[0]), float(lin[1]), float(lin[2]))


@dataclass(frozen=True)
class Material:
    """Shading parameters of one material; colours linear RGB."""

    name: str
    color: tuple[float, float, float]
    specular: float = 0.2
    shininess: float = 20.0
    wrap: float = 0.0
    scatter: tuple[float, float, float] = (1.0, 1.0, 1.0)
    alpha: float = 1.0
    cull: bool = False  #: skip back faces (closed, outward-facing surfaces only)
    model: str = "standard"  #: shading model: standard, or hair (Kajiya-Kay strands)


@functools.cache
def load_materials() -> dict[str, Material]:
    """The materials of ``render/data/materials.json`` by name (``_default`` included)."""
    text = resources.files("mimika.render").joinpath("data/materials.json").read_text("utf-8")
    out = {}
    for name, m in json.loads(text).items():
        if not isinstance(m, dict):
            continue  # documentation entries
        out[name] = Material(
            name=name,
            color=srgb_to_linear(m["color"]),
            specular=float(m.get("specular", 0.2)),
            shininess=float(m.get("shininess", 20.0)),
            wrap=float(m.get("wrap", 0.0)),
            cull=bool(m.get("cull", False)),
            scatter=srgb_to_linear(m.get("scatter", "#ffffff")),
            alpha=float(m.get("alpha", 1.0)),
            model=str(m.get("model", "standard")),
        )
    return out


@functools.cache
def _warn_unknown_material(name: str) -> None:
    log.warning("unknown material %r: drawing it neutral grey (see render/data/materials.json)",
                name)


def material(name: str) -> Material:
    """The material ``name``; unknown names give a neutral grey and a logged warning."""
    mats = load_materials()
    if name in mats:
        return mats[name]
    _warn_unknown_material(name)
    return mats["_default"]


_INCLUDE = re.compile(r'^#include "([\w.]+)"[ \t]*$', re.MULTILINE)


def _shader(name: str, *defines: str) -> str:
    """The source of ``shaders/name`` with its ``#include "file"`` lines expanded and a
    ``#define`` for each of ``defines`` after the ``#version`` line."""
    text = resources.files("mimika.render").joinpath(f"shaders/{name}").read_text("utf-8")
    if defines:
        head, _, rest = text.partition("\n")
        text = head + "\n" + "".join(f"#define {d}\n" for d in defines) + rest
    return _INCLUDE.sub(lambda m: _shader(m.group(1)).rstrip("\n"), text)


def incidence_matrix(faces: np.ndarray, n_vertices: int) -> sp.csr_matrix:
    """Vertex–face incidence, shape (N, F), CSR, float32: entry (v, f) = 1 if f uses v."""
    faces = np.asarray(faces, np.int64).reshape(-1, 3)
    rows = faces.ravel()
    cols = np.repeat(np.arange(len(faces)), 3)
    data = np.ones(len(rows), np.float32)
    m = sp.csr_matrix((data, (rows, cols)), shape=(n_vertices, len(faces)), dtype=np.float32)
    m.sum_duplicates()
    return m


def vertex_normals(
    positions: np.ndarray,
    faces: np.ndarray | tuple[np.ndarray, ...],
    incidence: sp.csr_matrix | None = None,
) -> np.ndarray:
    """Area-weighted smooth unit normals, shape (N, 3) float32, of ``positions`` (N, 3).

    ``faces`` (F, 3) are counter-clockwise seen from outside; a tuple of the three corner
    index columns, each contiguous, is faster (what the renderer passes every frame).
    Vertices in no (or only degenerate) faces get (0, 0, 1).
    """
    v = np.asarray(positions, np.float32)
    corners = faces if isinstance(faces, tuple) else tuple(
        np.ascontiguousarray(faces[:, k]) for k in range(3))
    if incidence is None:
        incidence = incidence_matrix(np.stack(corners, 1), len(v))
    a, e1, e2 = (np.take(v, c, axis=0) for c in corners)
    e1 -= a
    e2 -= a
    n = np.asarray(incidence @ np.cross(e1, e2), np.float32)  # face normals: twice the area
    n[:, 2] += 1e-15  # zero normals become +z after normalising
    n /= np.sqrt(np.einsum("ij,ij->i", n, n))[:, None]
    return n


#: alpha modes as the mesh shader's u_alpha_mode: opaque (texture alpha = gloss), a cut-out
#: part (its depth pre-pass cut at alpha 0.5, then shaded where the depth test equals it),
#: blend fringe (only the soft edge below 0.5, blended, no depth write)
_OPAQUE, _CUT, _FRINGE = 0, 1, 3


class _GpuObject:
    """GPU state of one drawable object: dynamic VBO, index buffer, VAO and part ranges."""

    def __init__(self, ctx: Any, prog: Any, obj: MeshObject) -> None:
        self.name = obj.name
        self.n_vertices = obj.n_vertices
        faces = np.concatenate([p.faces for p in obj.parts]).astype(np.int32)
        if len(faces) and (faces.min() < 0 or faces.max() >= obj.n_vertices):
            raise ParameterError(
                f"object {obj.name!r}: face indices must be in [0, {obj.n_vertices}), "
                f"got [{faces.min()}, {faces.max()}]"
            )
        if not obj.oriented and _winding_inward(obj.vertices, faces):
            log.info("object %r: faces wind clockwise seen from outside; flipping", obj.name)
            faces = faces[:, [0, 2, 1]].copy()
        self.faces = faces
        # normals: on the welded mesh when the object is split at UV seams
        if obj.weld is not None:
            self.weld_ids, self.weld_inv = np.unique(obj.weld, return_inverse=True)
            wf = self.weld_inv[faces].astype(np.int32)
            self.corners = tuple(np.ascontiguousarray(wf[:, k]) for k in range(3))
            self.first_of = np.zeros(len(self.weld_ids), np.int64)
            self.first_of[self.weld_inv[::-1]] = np.arange(obj.n_vertices)[::-1]
            self.incidence = incidence_matrix(wf, len(self.weld_ids))
        else:
            self.weld_inv = None
            self.corners = tuple(np.ascontiguousarray(faces[:, k]) for k in range(3))
            self.incidence = incidence_matrix(faces, obj.n_vertices)
        #: material, first index, index count, texture (or None), alpha mode
        self.parts: list[tuple[Material, int, int, Any, str]] = []
        textured = obj.uvs is not None and any(p.texture is not None for p in obj.parts)
        self.textures: list[Any] = []
        first = 0
        for p in obj.parts:
            tex = None
            if textured and p.texture is not None:
                tex = _upload_texture(ctx, p.texture.image)
                self.textures.append(tex)
            self.parts.append((material(p.material), first, 3 * len(p.faces), tex,
                               p.alpha_mode if tex is not None else "opaque"))
            first += 3 * len(p.faces)
        self.interleaved = np.empty((obj.n_vertices, 6), np.float32)
        self.vbo = ctx.buffer(reserve=self.interleaved.nbytes, dynamic=True)
        self.ibo = ctx.buffer(faces.tobytes())
        layout = [(self.vbo, "3f 3f", "in_position", "in_normal")]
        self.uv_vbo = None
        if textured:
            self.uv_vbo = ctx.buffer(np.ascontiguousarray(obj.uvs, np.float32).tobytes())
            layout.append((self.uv_vbo, "2f", "in_uv"))
        # skip_errors: variants without textures have no in_uv attribute
        self.vao = ctx.vertex_array(prog, layout, self.ibo, 4, skip_errors=True)
        self._ctx, self._layout = ctx, layout
        #: VAOs of the same buffers for the other variants of the mesh program
        self._vaos: dict[int, Any] = {id(prog): self.vao}
        self.rest = obj.vertices
        self.holds_rest = False

    def vao_for(self, prog: Any) -> Any:
        """This object's vertex array for ``prog`` (a variant of the mesh program)."""
        if id(prog) not in self._vaos:
            self._vaos[id(prog)] = self._ctx.vertex_array(prog, self._layout, self.ibo, 4,
                                                          skip_errors=True)
        return self._vaos[id(prog)]

    def update(self, positions: np.ndarray | None) -> None:
        """Write ``positions`` (N, 3) and their normals; ``None`` means the rest pose."""
        if positions is None:
            if self.holds_rest:
                return
            positions = self.rest
        self.interleaved[:, :3] = positions
        if self.weld_inv is None:
            self.interleaved[:, 3:] = vertex_normals(positions, self.corners, self.incidence)
        else:
            n = vertex_normals(np.asarray(positions)[self.first_of], self.corners,
                               self.incidence)
            self.interleaved[:, 3:] = n[self.weld_inv]
        self.vbo.write(self.interleaved)
        self.holds_rest = positions is self.rest

    def release(self) -> None:
        for o in (*self._vaos.values(), self.ibo, self.vbo, self.uv_vbo, *self.textures):
            if o is not None:
                o.release()


def _upload_texture(ctx: Any, image: np.ndarray) -> Any:
    """An RGBA8 texture with mipmaps from an (H, W, 3|4) uint8 image (row 0 = top)."""
    img = np.asarray(image, np.uint8)
    if img.shape[2] == 3:
        img = np.concatenate([img, np.full((*img.shape[:2], 1), 255, np.uint8)], axis=2)
    h, w = img.shape[:2]
    tex = ctx.texture((w, h), 4, np.ascontiguousarray(img[::-1]).tobytes())
    tex.build_mipmaps()
    tex.filter = (ctx.LINEAR_MIPMAP_LINEAR, ctx.LINEAR)
    # cards seen at a slant (lashes, brows, hair) keep their strands instead of blurring
    # tex.anisotropy = 8.0
    return tex


def _winding_inward(vertices: np.ndarray, faces: np.ndarray) -> bool:
    """True if most face area points toward the object's centre (clockwise winding)."""
    if len(faces) == 0:
        return False
    v = np.asarray(vertices, np.float64)
    a, b, c = v[faces[:, 0]], v[faces[:, 1]], v[faces[:, 2]]
    fn = np.cross(b - a, c - a)
    centre = v[np.unique(faces)].mean(0)
    return float(np.einsum("ij,ij->", fn, (a + b + c) / 3.0 - centre)) < 0.0


_GL_KEYS = ("bg_vao", "bg_prog", "fbo", "resolve", "desk_vao", "desk_prog", "bg_fbo")


class Renderer:
    """Renders a :class:`Head` to RGB images with headless OpenGL.

    Parameters
    ----------
    head
        The head to draw. Objects with no parts are not drawn.
    size
        Image (width, height) in pixels.
    samples
        Multisample anti-aliasing samples (0 disables it).
    skin_shader
        Draw skin-like parts with the texture-space skin shader (:mod:`mimika.render.skin`;
        objects need UVs), else with the standard shader; a ``SkinParams`` turns it on with
        those settings.
    lighting
        Lights and backdrop (:class:`mimika.render.skin.Lighting`); default: mimika's look.
    hidden
        Names of objects not to draw (e.g. ``("hair",)``).
    crop
        For a fixed shot (a video with one camera): triangles whose rest-pose corners all lie
        more than a quarter of the image outside the first frame's view are never drawn — a
        seated newsreader's legs and lower body.

    The GL context is created on the first :meth:`render`; ``close()`` (or leaving a
    ``with`` block) frees this renderer's GPU objects.
    """

    def __init__(self, head: Head, size: tuple[int, int] = (640, 480), samples: int = 4,
                 skin_shader: Any = False, lighting: Any = None,
                 hidden: Any = (), crop: bool = False) -> None:
        try:
            w, h = (int(s) for s in size)
        except (TypeError, ValueError):
            raise ParameterError(f"size={size!r} must be (width, height) in pixels") from None
        if not (1 <= w <= 8192 and 1 <= h <= 8192):
            raise ParameterError(f"size={size!r}: width and height must be in 1..8192 pixels")
        if int(samples) < 0:
            raise ParameterError(f"samples={samples!r} must be 0 (no anti-aliasing) or more")
        self.head = head
        self.size = (w, h)
        self.samples = int(samples)
        self.skin_shader = skin_shader
        self.lighting = lighting
        names = {o.name for o in head.objects}
        unknown = sorted(set(hidden) - names)
        if unknown:
            raise ParameterError(f"hidden: head {head.name!r} has no object {unknown[0]!r}; "
                                 f"objects: {', '.join(sorted(names))}")
        self.hidden = frozenset(hidden)
        self.crop = bool(crop)
        self._skin: Any = None
        self._cameras: dict[str, Camera] = {}
        self._gl: dict[str, Any] | None = None
        self._objects: list[_GpuObject] = []
        self._sizes = {o.name: o.n_vertices for o in head.objects}

    # ------------------------------------------------------------------ public API
    @property
    def aspect(self) -> float:
        """Width / height of the image."""
        return self.size[0] / self.size[1]

    def camera(self, view: str = "front") -> Camera:
        """The camera of ``view`` (framed on the rest-pose face, cached)."""
        check_view(view)
        if view not in self._cameras:
            self._cameras[view] = frame_head(self.head, view, aspect=self.aspect)
        return self._cameras[view]

    def render(
        self,
        positions: Mapping[str, np.ndarray] | None = None,
        view: str = "front",
        camera: Camera | None = None,
    ) -> np.ndarray:
        """Draw the head and return the image, shape (H, W, 3) uint8 RGB, top row first.

        ``positions`` maps object names to vertex positions (N, 3) in cm; objects not in it
        are drawn at rest. ``camera`` overrides the camera of ``view``.
        """
        cam = camera if camera is not None else self.camera(view)
        pos = self._check_positions(positions)
        ctx = get_context()
        # the context is shared by every renderer of the process: make it current and keep
        # other threads out while this frame is drawn (GL contexts are not thread-safe)
        with render_lock, ctx:
            gl = self._setup(cam)
            return self._draw(gl, ctx, cam, pos)

    def _draw(self, gl: dict, ctx: Any, cam: Camera, pos: dict) -> np.ndarray:
        try:
            for o in self._objects:
                o.update(pos.get(o.name))
            skin = self._skin
            if skin is not None:
                skin.prepare(ctx, cam.view_matrix)
            fbo = gl["fbo"]
            fbo.use()
            ctx.viewport = (0, 0, *self.size)
            fbo.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
            ctx.disable(ctx.DEPTH_TEST | ctx.BLEND | ctx.CULL_FACE)
            self._backdrop(gl, ctx, fbo)
            ctx.enable(ctx.DEPTH_TEST)
            self._view = (cam.view_matrix.T.astype("f4").tobytes(),
                          cam.projection_matrix.T.astype("f4").tobytes())
            for p in gl["progs"].values():
                p["u_view"].write(self._view[0])
                p["u_proj"].write(self._view[1])
            glass, cut, fringe = [], [], []
            # the skin (a head's first object) goes last of the opaque ones: where clothes and
            # eyes cover it, it then fails the depth test before it is shaded
            for o in self._objects[1:] + self._objects[:1]:
                for mat, first, count, tex, mode in o.parts:
                    if mat.alpha < 1.0:
                        glass.append((o, mat, first, count, tex))
                        continue
                    if mode != "opaque":
                        cut.append((o, mat, first, count, tex))
                        if mode == "blend":
                            fringe.append((o, mat, first, count, tex))
                        continue
                    if mat.cull:
                        ctx.enable(ctx.CULL_FACE)
                    else:
                        ctx.disable(ctx.CULL_FACE)
                    if skin is not None and skin.handles(o, first):
                        skin.draw(ctx, o, first, mat, cam.projection_matrix, BACKFACE, tex)
                        continue
                    self._part(gl, o, mat, tex, _OPAQUE).render(ctx.TRIANGLES, vertices=count,
                                                               first=first)
            ctx.disable(ctx.CULL_FACE)
            if cut:
                # cut-outs and the opaque core of blended parts (hair, lashes): their depth
                # first (a texture look-up each), then shaded once per pixel where they are in
                # front — stacked hair cards would otherwise be lit layer after layer
                fbo.color_mask = False, False, False, False
                for o, mat, first, count, tex in cut:
                    self._part(gl, o, mat, tex, _CUT, depth_only=True).render(
                        ctx.TRIANGLES, vertices=count, first=first)
                fbo.color_mask = True, True, True, True
                ctx.depth_func = "=="
                for o, mat, first, count, tex in cut:
                    self._part(gl, o, mat, tex, _CUT).render(ctx.TRIANGLES, vertices=count,
                                                            first=first)
                ctx.depth_func = "<"
            if glass or fringe:
                ctx.enable(ctx.BLEND)
                ctx.depth_mask = False
                ctx.blend_func = ctx.ONE, ctx.ONE_MINUS_SRC_ALPHA
                for o, mat, first, count, tex in glass:
                    self._part(gl, o, mat, tex, _OPAQUE).render(ctx.TRIANGLES, vertices=count,
                                                               first=first)
                # soft edges of blended parts over everything drawn so far (premultiplied)
                for o, mat, first, count, tex in fringe:
                    self._part(gl, o, mat, tex, _FRINGE).render(ctx.TRIANGLES, vertices=count,
                                                               first=first)
                ctx.depth_mask = True
                ctx.disable(ctx.BLEND)
            if "desk_vao" in gl:
                ctx.disable(ctx.DEPTH_TEST)
                ctx.enable(ctx.BLEND)
                ctx.blend_func = ctx.SRC_ALPHA, ctx.ONE_MINUS_SRC_ALPHA
                fbo.scissor = gl["desk_rect"]  # shade only the rows the desk covers
                gl["desk_vao"].render(ctx.TRIANGLES, vertices=3)
                fbo.scissor = None
                ctx.disable(ctx.BLEND)
            if gl["resolve"] is not fbo:
                ctx.copy_framebuffer(gl["resolve"], fbo)
            data = gl["resolve"].read(components=3, alignment=1)
        except RenderError:
            raise
        except Exception as exc:  # moderngl raises plain Errors
            raise RenderError(f"rendering {self.head.name!r} failed: {exc}") from exc
        w, h = self.size
        return np.frombuffer(data, np.uint8).reshape(h, w, 3)[::-1].copy()

    def invalidate(self) -> None:
        """Forget state reused between frames (the skin shader's blurred irradiance): the
        next frame computes everything afresh, as after a cut. Rendering a video in chunks
        calls this at each chunk so the images do not depend on how the chunks are shared
        out among processes."""
        if self._skin is not None:
            self._skin.invalidate()

    def _backdrop(self, gl: dict, ctx: Any, fbo: Any) -> None:
        """Draw the backdrop; without MSAA it is drawn once and then copied (a blit is far
        cheaper than shading every pixel on a software rasteriser)."""
        if gl["fbo"] is not gl["resolve"]:  # multisampled: no blit into it
            gl["bg_vao"].render(ctx.TRIANGLES, vertices=3)
            return
        if "bg_fbo" not in gl:
            rb = ctx.renderbuffer(self.size, components=3)
            gl["attachments"].append(rb)
            gl["bg_fbo"] = ctx.framebuffer(rb)
            gl["bg_fbo"].use()
            gl["bg_vao"].render(ctx.TRIANGLES, vertices=3)
            fbo.use()
        ctx.copy_framebuffer(fbo, gl["bg_fbo"])

    def close(self) -> None:
        """Free this renderer's GPU objects (the shared GL context stays)."""
        ctx = self._gl.get("ctx") if self._gl is not None else None
        if ctx is None:
            self._release()
            return
        with render_lock, ctx:  # current in this thread: another may be drawing
            self._release()

    def _release(self) -> None:
        if self._skin is not None:
            self._skin.release()
            self._skin = None
        for o in self._objects:
            o.release()
        self._objects = []
        if self._gl is not None:
            gl, self._gl = self._gl, None
            done: set[int] = set()
            for obj in (*(gl.get(k) for k in _GL_KEYS), *gl["progs"].values(),
                        *gl["attachments"]):
                if obj is not None and id(obj) not in done:
                    done.add(id(obj))
                    obj.release()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ internals
    def _check_positions(self, positions: Mapping[str, np.ndarray] | None) -> dict:
        if not positions:
            return {}
        out = {}
        for name, p in positions.items():
            if name not in self._sizes:
                raise ParameterError(
                    f"positions for unknown object {name!r}; objects of head "
                    f"{self.head.name!r}: {', '.join(self._sizes)}"
                )
            a = np.asarray(p, np.float32)
            if a.shape != (self._sizes[name], 3):
                raise ParameterError(
                    f"positions[{name!r}] has shape {a.shape}, expected ({self._sizes[name]}, 3)"
                )
            out[name] = a
        return out

    @staticmethod
    def _set_material(prog: Any, m: Material, tex: Any = None, mode: int = _OPAQUE) -> None:
        # cut-outs and cards are seen from both sides: no darkening of their back faces
        for name, value in (("u_base", m.color), ("u_specular", m.specular),
                            ("u_shininess", m.shininess), ("u_wrap", m.wrap),
                            ("u_scatter", m.scatter), ("u_alpha", m.alpha),
                            ("u_alpha_mode", mode),
                            ("u_backface", BACKFACE if mode == _OPAQUE else 1.0)):
            if name in prog:  # a variant may have compiled a uniform away
                prog[name].value = value
        if tex is not None:
            tex.use(location=0)
            prog["u_tex"].value = 0

    def _program(self, gl: dict, textured: bool, hair: bool, depth_only: bool = False) -> Any:
        """The mesh program variant: ``textured``, ``hair`` (strand shading), ``depth_only``
        (texture coverage only, for a depth pre-pass); compiled on first use with the lights
        set."""
        key = ("TEXTURED",) * textured + ("HAIR",) * hair + ("DEPTH_ONLY",) * depth_only
        progs = gl["progs"]
        if key not in progs:
            ctx = gl["ctx"]
            p = ctx.program(vertex_shader=_shader("mesh.vert.glsl"),
                            fragment_shader=_shader("mesh.frag.glsl", *key))
            for name, value in (
                ("u_key_dir", _unit(KEY_DIR)), ("u_key_col", KEY_COL),
                ("u_fill_dir", _unit(FILL_DIR)), ("u_fill_col", FILL_COL),
                ("u_rim_dir", _unit(RIM_DIR)), ("u_rim_col", RIM_COL),
                ("u_sky", SKY), ("u_ground", GROUND), ("u_exposure", EXPOSURE),
                ("u_backface", BACKFACE),
            ):
                if name in p:  # the depth-only variant has no lights
                    p[name].value = value
            if self.lighting is not None:
                from mimika.render.skin import set_lights

                set_lights(p, self.lighting)
            if getattr(self, "_view", None) is not None:
                p["u_view"].write(self._view[0])
                p["u_proj"].write(self._view[1])
            progs[key] = p
        return progs[key]

    def _part(self, gl: dict, o: _GpuObject, mat: Material, tex: Any, mode: int,
              depth_only: bool = False) -> Any:
        """Set up the program for one part and return the object's vertex array for it."""
        textured = tex is not None
        prog = self._program(gl, textured, textured and mat.model == "hair",
                             textured and depth_only)
        self._set_material(prog, mat, tex, mode)
        return o.vao_for(prog)

    def _setup(self, cam: Camera | None = None) -> dict[str, Any]:
        if self._gl is not None:
            return self._gl
        ctx = get_context()
        try:
            self._gl = self._create(ctx, cam if self.crop else None)
        except RenderError:
            raise
        except Exception as exc:
            self.close()
            raise RenderError(f"setting up OpenGL objects failed: {exc}") from exc
        return self._gl

    def _create(self, ctx: Any, crop: Camera | None = None) -> dict[str, Any]:
        gl: dict[str, Any] = {"ctx": ctx, "attachments": []}
        gl["progs"] = {}
        prog = self._program(gl, False, False)
        lit = self.lighting
        studio = lit is not None and lit.backdrop == "studio"
        bg = ctx.program(
            vertex_shader=_shader("background.vert.glsl"),
            fragment_shader=_shader("studio.frag.glsl" if studio else "background.frag.glsl"),
        )
        bg["u_top"].value = BG_TOP if lit is None else lit.bg_top
        bg["u_bottom"].value = BG_BOTTOM if lit is None else lit.bg_bottom
        bg["u_glow"].value = BG_GLOW if lit is None else lit.bg_glow
        bg["u_aspect"].value = self.aspect
        if lit is not None and lit.desk > 0:
            desk = ctx.program(vertex_shader=_shader("background.vert.glsl"),
                               fragment_shader=_shader("desk.frag.glsl"))
            desk["u_top"].value = lit.desk
            gl["desk_prog"] = desk
            gl["desk_vao"] = ctx.vertex_array(desk, [])
            rows = min(int(np.ceil((lit.desk + 0.006) * self.size[1])) + 1, self.size[1])
            gl["desk_rect"] = (0, 0, self.size[0], rows)
        gl["bg_prog"] = bg
        gl["bg_vao"] = ctx.vertex_array(bg, [])

        samples = min(self.samples, int(ctx.max_samples))
        if samples < self.samples:
            log.warning("samples=%d not supported, using %d", self.samples, samples)
        if samples == 1:
            samples = 0
        resolve_color = ctx.renderbuffer(self.size, components=3)
        gl["attachments"].append(resolve_color)
        if samples:
            color = ctx.renderbuffer(self.size, components=3, samples=samples)
            depth = ctx.depth_renderbuffer(self.size, samples=samples)
            gl["attachments"] += [color, depth]
            gl["fbo"] = ctx.framebuffer(color, depth)
            gl["resolve"] = ctx.framebuffer(resolve_color)
        else:
            depth = ctx.depth_renderbuffer(self.size)
            gl["attachments"].append(depth)
            gl["fbo"] = gl["resolve"] = ctx.framebuffer(resolve_color, depth)

        shown = [o for o in self.head.objects if o.name not in self.hidden]
        if crop is not None:
            shown = [_in_shot(o, crop, self.size) for o in shown]
        self._objects = [_GpuObject(ctx, prog, o) for o in shown if o.parts]
        if self.skin_shader:
            from mimika.render.skin import DEFAULT_LIGHTING, SkinShader

            uvs = {o.name: o.uvs for o in self.head.objects if o.uvs is not None}
            if uvs:
                params = None if isinstance(self.skin_shader, bool) else self.skin_shader
                self._skin = SkinShader(ctx, self._objects, uvs, lit or DEFAULT_LIGHTING,
                                        params)
            else:
                log.warning("head %r has no UVs: skin shader off", self.head.name)
        log.debug(
            "renderer for %r: %d objects, %d triangles, %dx%d, %d samples",
            self.head.name,
            len(self._objects),
            self.head.n_triangles,
            *self.size,
            samples,
        )
        return gl


def _in_shot(obj: MeshObject, cam: Camera, size: tuple[int, int]) -> MeshObject:
    """``obj`` without the triangles whose rest-pose corners all lie more than a quarter of
    the image outside ``cam``'s view (corners behind the camera count as in view)."""
    clip = np.c_[obj.vertices, np.ones(obj.n_vertices)] @ (
        cam.projection_matrix @ cam.view_matrix).T
    ndc = clip[:, :2] / np.where(clip[:, 3:] > 0, clip[:, 3:], 1.0)
    # a quarter of the image beyond each edge is 1.5 in normalised device coordinates
    out = (clip[:, 3] > 0) & (np.abs(ndc) > 1.5).any(axis=1)
    parts = (replace(p, faces=p.faces[~out[p.faces].all(axis=1)]) for p in obj.parts)
    return replace(obj, parts=tuple(p for p in parts if len(p.faces)))


def _unit(v: tuple[float, float, float]) -> tuple[float, float, float]:
    a = np.asarray(v, np.float64)
    a = a / np.linalg.norm(a)
    return (float(a[0]), float(a[1]), float(a[2]))
