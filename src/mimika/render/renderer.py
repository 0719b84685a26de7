"""Headless OpenGL renderer for a :class:`~mimika.face.head.Head`.

Each frame recomputes smooth vertex normals from the given positions (one sparse
vertex–face product per object) and the light reaching the inside of the mouth through the
lips (:mod:`.mouth`), rewrites a dynamic vertex buffer, draws the key light's shadow map, then
every part with its material into a multisample framebuffer over a studio backdrop, resolves
and reads back RGB. Ambient occlusion is baked once per head (:mod:`.occlusion`); the lights
come from a :class:`~mimika.render.lighting.Lighting` (``--light``).
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

from mimika import normals
from mimika.errors import ParameterError, RenderError
from mimika.face.head import Head, MeshObject, Part
from mimika.render.camera import FILL, Camera, check_view, frame_head
from mimika.render.context import get_context, has_uniform, render_lock
from mimika.render.lighting import Lighting, parse_light, set_lights, unit
from mimika.render.mouth import MouthCavity
from mimika.render.occlusion import light_view, ortho
from mimika.render.skin import VERTEX_ATTRIBUTES, VERTEX_LAYOUT, write_wrinkles
from mimika.render.wrinkles import Wrinkles

log = logging.getLogger(__name__)

BACKFACE = 0.3  # brightness of back faces (the inside of the skin seen through openings)
#: materials that take the colour of the oral mucosa inside the mouth
SKIN_LIKE = ("skin", "lips", "skin_body")
#: linear colour of the oral mucosa (sRGB #a5524f)
MUCOSA = (0.376, 0.085, 0.077)
#: object categories drawn after the skin: they lie mostly behind it
INNER = ("eyes", "teeth")
#: the key light's penumbra (cm) for soft and hard shadows
PENUMBRA = {"soft": 0.45, "hard": 0.1}
#: soft shadows on skin: the penumbra's growth per cm from what casts the shadow to what
#: receives it (the tangent of the key's angular radius: a softbox 0.5 m across at 2.5 m),
#: and the widest (cm)
SOFTBOX = (0.1, 1.2)
#: the mesh shader's variant (a ``#define``) of each shading model but the standard one:
#: hair strands (textured parts only), the eye's sclera and iris, the cornea
MODEL_DEFINES = {"hair": "HAIR", "eye": "EYE", "iris": "IRIS", "cornea": "CORNEA"}


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
    #: a blended part drawn with its texture's alpha throughout (fine hairs lying on the
    #: skin: brows, lashes), not as an opaque core with a soft fringe (hair)
    soft: bool = False
    #: shading model: standard, hair (Kajiya-Kay strands), eye, iris, cornea (:data:`MODEL_DEFINES`)
    model: str = "standard"


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
            soft=bool(m.get("soft", False)),
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
#: soft (blended with its alpha throughout, no depth write), blend fringe (only the soft edge
#: below 0.5, blended, no depth write)
_OPAQUE, _CUT, _SOFT, _FRINGE = 0, 1, 2, 3


class _GpuObject:
    """GPU state of one drawable object: dynamic VBO, index buffer, VAO and part ranges."""

    def __init__(self, ctx: Any, prog: Any, obj: MeshObject,
                 face: np.ndarray | None = None, reach: np.ndarray | None = None) -> None:
        self.name = obj.name
        self.category = obj.category
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
        ranges = _split_by_wrinkles(obj, faces, face, reach)
        if len(faces):
            faces = np.concatenate([f for _, f, _ in ranges])
        self.faces = faces
        # normals: on the welded mesh when the object is split at UV seams; the triangles
        # summed in an order of their own (by corners), so that a normal does not depend to
        # the last bit on the order they are drawn in (cropped, split by wrinkle reach)
        nf = faces[np.lexsort(faces.T[::-1])] if len(faces) else faces
        if obj.weld is not None:
            self.weld_ids, self.weld_inv = np.unique(obj.weld, return_inverse=True)
            wf = self.weld_inv[nf].astype(np.int32)
            self.corners = tuple(np.ascontiguousarray(wf[:, k]) for k in range(3))
            self.first_of = np.zeros(len(self.weld_ids), np.int64)
            self.first_of[self.weld_inv[::-1]] = np.arange(obj.n_vertices)[::-1]
            self.incidence = incidence_matrix(wf, len(self.weld_ids))
        else:
            self.weld_inv = None
            self.corners = tuple(np.ascontiguousarray(nf[:, k]) for k in range(3))
            self.incidence = incidence_matrix(nf, obj.n_vertices)
        #: material, first index, index count, texture (or None), alpha mode
        self.parts: list[tuple[Material, int, int, Any, str]] = []
        #: the wrinkle groups (``WR_GROUPS``) of skin-like parts by first index: only those
        #: that reach the part are compiled into its program; 0 off the face (no wrinkles)
        self.groups: dict[int, int] = {}
        textured = obj.uvs is not None and any(p.texture is not None for p in obj.parts)
        self.textures: list[Any] = []
        #: detail maps by first index (normal and roughness, or hair's strand flow:
        #: :class:`~mimika.face.head.Texture`)
        self.details: dict[int, Any] = {}
        texs, details = [], []
        for p in obj.parts:
            texs.append(_upload_texture(ctx, p.texture.image)
                        if textured and p.texture is not None else None)
            second = None if texs[-1] is None else (
                p.texture.normal if p.texture.normal is not None else p.texture.flow)
            details.append(None if second is None else _upload_texture(ctx, second))
            self.textures += [t for t in (texs[-1], details[-1]) if t is not None]
        first = 0
        for i, f, groups in ranges:
            p, tex = obj.parts[i], texs[i]
            if groups is not None:
                self.groups[first] = groups
            if details[i] is not None:
                self.details[first] = details[i]
            self.parts.append((material(p.material), first, 3 * len(f), tex,
                               p.alpha_mode if tex is not None else "opaque"))
            first += 3 * len(f)
        #: position, normal, occlusion (ambient occlusion, mouth visibility, inside the mouth)
        self.interleaved = np.empty((obj.n_vertices, 9), np.float32)
        self.interleaved[:, 6:] = (1.0, 1.0, 0.0)
        #: vertices inside the mouth and their visibility this frame (set by the renderer)
        self.inside_ids: np.ndarray | None = None
        self.vbo = ctx.buffer(reserve=self.interleaved.nbytes, dynamic=True)
        self.ibo = ctx.buffer(faces.tobytes())
        layout = [(self.vbo, VERTEX_LAYOUT, *VERTEX_ATTRIBUTES)]
        self.uv_vbo = None
        if textured:
            self.uv_vbo = ctx.buffer(np.ascontiguousarray(obj.uvs, np.float32).tobytes())
            layout.append((self.uv_vbo, "2f", "in_uv"))
        #: face units per vertex for the wrinkles (:mod:`mimika.render.wrinkles`)
        self.face_vbo = None if face is None else ctx.buffer(
            np.ascontiguousarray(face, np.float32).tobytes())
        if self.face_vbo is not None:
            layout.append((self.face_vbo, "3f", "in_face"))
        #: the attribute buffers besides the dynamic one (the skin shader's VAOs take them)
        self.extra_layout = layout[1:]
        # skip_errors: variants without textures have no in_uv attribute
        self.vao = ctx.vertex_array(prog, layout, self.ibo, 4, skip_errors=True)
        self._ctx, self._layout = ctx, layout
        #: VAOs of the same buffers for the other variants of the mesh program
        self._vaos: dict[int, Any] = {id(prog): self.vao}
        self.rest = obj.vertices
        self.holds_rest = False
        #: hair: the smoothing of its normals (:func:`mimika.normals.smoothing`), else None
        self.smooth = normals.smoothing(obj.vertices, self._normals(obj.vertices)) \
            if normals.is_hair(obj) and len(faces) else None

    def vao_for(self, prog: Any) -> Any:
        """This object's vertex array for ``prog`` (a variant of the mesh program)."""
        if id(prog) not in self._vaos:
            self._vaos[id(prog)] = self._ctx.vertex_array(prog, self._layout, self.ibo, 4,
                                                          skip_errors=True)
        return self._vaos[id(prog)]

    def update(self, positions: np.ndarray | None, inside: np.ndarray | None = None) -> None:
        """Write ``positions`` (N, 3) and their normals, and the visibility of the vertices
        inside the mouth (``inside``, for :attr:`inside_ids`); ``None`` means the rest pose."""
        if inside is not None:
            self.interleaved[self.inside_ids, 7] = inside
        if positions is None:
            if self.holds_rest and inside is None:
                return
            positions = self.rest
        self.interleaved[:, :3] = positions
        n = self._normals(positions)
        self.interleaved[:, 3:6] = n if self.smooth is None else normals.smooth(n, self.smooth)
        self.vbo.write(self.interleaved)
        self.holds_rest = positions is self.rest

    def _normals(self, positions: np.ndarray) -> np.ndarray:
        """Smooth vertex normals (N, 3) of ``positions`` (on the welded mesh if split)."""
        if self.weld_inv is None:
            return vertex_normals(positions, self.corners, self.incidence)
        n = vertex_normals(np.asarray(positions)[self.first_of], self.corners, self.incidence)
        return n[self.weld_inv]

    def release(self) -> None:
        for o in (*self._vaos.values(), self.ibo, self.vbo, self.uv_vbo, self.face_vbo,
                  *self.textures):
            if o is not None:
                o.release()


#: every wrinkle group (``WR_GROUPS`` of shaders/wrinkles.glsl: bit k for group k)
ALL_GROUPS = (1 << 14) - 1
#: face units per texel of the pass that finds which wrinkle groups reach which triangles
REACH_TEXEL = 0.008
#: wrinkle variants of the skin's programs at most (every rendering process compiles them)
MAX_VARIANTS = 6


def _split_by_wrinkles(obj: MeshObject, faces: np.ndarray, face: np.ndarray | None,
                       reach: np.ndarray | None) -> list[tuple[int, np.ndarray, int | None]]:
    """The triangles of each part of ``obj`` (``faces``: all parts' in order) as (part index,
    triangles, wrinkle groups). A skin-like part of the object with the face units ``face``
    comes in pieces by the groups that reach its triangles (``reach``, per triangle of
    ``faces``; 0 for those with no corner on the face: drawn without the wrinkles — llvmpipe
    runs every branch of a shader, taken or not); other parts come whole, groups None.
    Empty pieces are left out."""
    if face is not None:
        groups = np.where((face[:, 2] > 0.0)[faces].any(axis=1),
                          ALL_GROUPS if reach is None else reach, 0)
        groups = _merge_variants(groups, MAX_VARIANTS)
    out = []
    first = 0
    for i, p in enumerate(obj.parts):
        f = faces[first: first + len(p.faces)]
        if face is None or p.material not in SKIN_LIKE:
            out.append((i, f, None))
        else:
            g = groups[first: first + len(p.faces)]
            out += [(i, f[g == k], int(k)) for k in np.unique(g)]
        first += len(p.faces)
    return [r for r in out if len(r[1])]


def _merge_variants(groups: np.ndarray, k: int) -> np.ndarray:
    """``groups`` (wrinkle group bits per triangle) with at most ``k`` distinct non-zero values,
    each a superset of the bits it replaces: pairs are merged while there are more, the pair
    that adds the least work (groups × triangles) first."""
    vals, counts = np.unique(groups[groups != 0], return_counts=True)
    n = dict(zip(vals.tolist(), counts.tolist(), strict=True))
    into = {v: v for v in n}
    bits = lambda m: bin(m).count("1")  # noqa: E731
    while len(n) > k:
        items = sorted(n.items())
        _, a, b = min((bits(a | b) * (na + nb) - bits(a) * na - bits(b) * nb, a, b)
                      for i, (a, na) in enumerate(items) for b, nb in items[i + 1:])
        u = a | b
        n[u] = n.pop(a) + n.pop(b) + n.get(u, 0) * (u not in (a, b))
        into = {v: u if w in (a, b) else w for v, w in into.items()}
    out = groups.copy()
    for v, w in into.items():
        out[groups == v] = w
    return out


def wrinkle_reach(ctx: Any, face: np.ndarray, faces: np.ndarray,
                  landmarks: Mapping[str, Any]) -> np.ndarray:
    """The wrinkle groups (``WR_GROUPS`` bits) that reach each triangle of ``faces`` (F, 3), or
    its neighbours (a margin), on a mesh with face units ``face`` (N, 3) and the wrinkles'
    ``landmarks`` uniforms. Found with the wrinkles' own code: the mesh drawn in face units,
    and its vertices as points, every group whose branch a fragment enters or-ed into its
    triangle (or vertex). All groups everywhere without GL 4.3 (storage buffers)."""
    if ctx.version_code < 430 or not len(faces):
        return np.full(len(faces), ALL_GROUPS, np.uint32)
    used = face[np.unique(faces), :2]
    lo, hi = used.min(0) - 0.05, used.max(0) + 0.05
    size = tuple(int(x) for x in np.clip(np.ceil((hi - lo) / REACH_TEXEL), 1, 2048))
    prog = ctx.program(vertex_shader=_shader("wrinkle_reach.vert.glsl"),
                       fragment_shader=_shader("wrinkle_reach.frag.glsl"))
    vbo = ctx.buffer(np.ascontiguousarray(face, np.float32).tobytes())
    ibo = ctx.buffer(np.ascontiguousarray(faces, np.int32).tobytes())
    tris = ctx.vertex_array(prog, [(vbo, "3f", "in_face")], ibo, 4)
    points = ctx.vertex_array(prog, [(vbo, "3f", "in_face")])
    slots = ctx.buffer(np.zeros(len(faces) + len(face), np.uint32).tobytes())
    target = ctx.renderbuffer(size, components=1)
    fbo = ctx.framebuffer(target)
    try:
        fbo.use()
        ctx.viewport = (0, 0, *size)
        ctx.disable(ctx.DEPTH_TEST | ctx.CULL_FACE | ctx.BLEND)
        slots.bind_to_storage_buffer(0)
        prog["u_box"].value = (*lo, *(1.0 / (hi - lo)))
        write_wrinkles(prog, np.ones(28, np.float32).tobytes())  # every group has depth
        for name, value in landmarks.items():
            if has_uniform(prog, name):
                prog[name].value = value
        prog["u_first"].value = 0
        tris.render(ctx.TRIANGLES)
        prog["u_first"].value = len(faces)
        points.render(ctx.POINTS)
        ctx.memory_barrier()
        hit = np.frombuffer(slots.read(), np.uint32)
    finally:
        for o in (tris, points, fbo, target, slots, ibo, vbo, prog):
            o.release()
    tri = hit[: len(faces)] | np.bitwise_or.reduce(hit[len(faces) + faces], axis=1)
    # a margin: or-ed over the triangles around each vertex, then over each one's corners
    vert = np.zeros(len(face), np.uint32)
    np.bitwise_or.at(vert, faces.ravel(), np.repeat(tri, 3))
    return np.bitwise_or.reduce(vert[faces], axis=1)


def _upload_texture(ctx: Any, image: np.ndarray) -> Any:
    """An RGBA8 texture with mipmaps from an (H, W, 3|4) uint8 image (row 0 = top)."""
    img = np.asarray(image, np.uint8)
    if img.shape[2] == 3:
        img = np.concatenate([img, np.full((*img.shape[:2], 1), 255, np.uint8)], axis=2)
    h, w = img.shape[:2]
    tex = ctx.texture((w, h), 4, np.ascontiguousarray(img[::-1]).tobytes())
    tex.build_mipmaps()
    # the nearest mip level, filtered bilinearly: 7 % less drawing than trilinear on llvmpipe
    # (texture look-ups are much of a pixel's cost); a 720p news frame keeps 97.9 % of its
    # pixels within 1/255 and 99.6 % within 4/255 (PSNR 56 dB)
    tex.filter = (ctx.LINEAR_MIPMAP_NEAREST, ctx.LINEAR)
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


_GL_KEYS = ("bg_vao", "bg_prog", "fbo", "resolve", "desk_vao", "desk_prog", "bg_fbo",
            "shadow_fbo")
#: texels of the key light's shadow map: soft shadows are filtered over a few texels of a
#: coarse map, hard ones need a fine one
SHADOW_MAP = {"soft": 512, "hard": 1536}


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
        Lights, shadows, occlusion and backdrop: a :class:`~mimika.render.lighting.Lighting`
        or a ``--light`` spec (``"studio"``, ``"news,shadows=off"`` …); default: ``studio``.
    hidden
        Names of objects not to draw (e.g. ``("hair",)``).
    crop
        For a fixed shot (a video with one camera): triangles whose rest-pose corners all lie
        more than a quarter of the image outside the first frame's view are never drawn — a
        seated newsreader's legs and lower body.
    fill
        Share of the image height the face (hairline to chin) fills in the named views
        (:func:`~mimika.render.camera.frame_head`; default a portrait, 0.6).

    The GL context is created on the first :meth:`render`; ``close()`` (or leaving a
    ``with`` block) frees this renderer's GPU objects.
    """

    def __init__(self, head: Head, size: tuple[int, int] = (640, 480), samples: int = 4,
                 skin_shader: Any = False, lighting: Any = None,
                 hidden: Any = (), crop: bool = False, fill: float = FILL) -> None:
        try:
            w, h = (int(s) for s in size)
        except (TypeError, ValueError):
            raise ParameterError(f"size={size!r} must be (width, height) in pixels") from None
        if not (1 <= w <= 8192 and 1 <= h <= 8192):
            raise ParameterError(f"size={size!r}: width and height must be in 1..8192 pixels")
        if int(samples) < 0:
            raise ParameterError(f"samples={samples!r} must be 0 (no anti-aliasing) or more")
        if not 0.05 <= fill <= 1.0:
            raise ParameterError(f"fill={fill} must be in [0.05, 1]: the share of the image "
                                 "height the face fills")
        self.fill = float(fill)
        self.head = head
        self.size = (w, h)
        self.samples = int(samples)
        self.skin_shader = skin_shader
        self.lighting: Lighting = parse_light(lighting)
        names = {o.name for o in head.objects}
        unknown = sorted(set(hidden) - names)
        if unknown:
            raise ParameterError(f"hidden: head {head.name!r} has no object {unknown[0]!r}; "
                                 f"objects: {', '.join(sorted(names))}")
        self.hidden = frozenset(hidden)
        self.crop = bool(crop)
        self._skin: Any = None
        self._mouth: MouthCavity | None = None
        self._frame = 0
        self._refresh = max(1, int(getattr(skin_shader, "refresh", 1)))
        self._wrinkles: Wrinkles | None = None
        self._wr: bytes | None = None  # this frame's wrinkle depths (u_wr), None if smooth
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
            self._cameras[view] = frame_head(self.head, view, aspect=self.aspect,
                                             fill=self.fill)
        return self._cameras[view]

    def render(
        self,
        positions: Mapping[str, np.ndarray] | None = None,
        view: str = "front",
        camera: Camera | None = None,
        aus: Mapping[str, float] | None = None,
        out: np.ndarray | None = None,
    ) -> np.ndarray:
        """Draw the head and return the image, shape (H, W, 3) uint8 RGB, top row first.

        ``positions`` maps object names to vertex positions (N, 3) in cm; objects not in it
        are drawn at rest. ``camera`` overrides the camera of ``view``. ``aus``, the AU
        intensities the positions were made from, add their appearance changes — furrows
        and lines (:mod:`mimika.render.wrinkles`); without them the skin stays smooth.
        ``out``: an (H, W, 3) uint8 array the image is written into (and returned), e.g. a
        slot of shared memory — no new image is allocated.
        """
        cam = camera if camera is not None else self.camera(view)
        pos = self._check_positions(positions)
        if out is not None and (out.shape != (self.size[1], self.size[0], 3)
                                or out.dtype != np.uint8):
            raise ParameterError(f"out has shape {out.shape} {out.dtype}; expected "
                                 f"({self.size[1]}, {self.size[0]}, 3) uint8")
        ctx = get_context()
        # the context is shared by every renderer of the process: make it current and keep
        # other threads out while this frame is drawn (GL contexts are not thread-safe)
        with render_lock, ctx:
            gl = self._setup(cam)
            self._wr = None
            if self._wrinkles is not None:
                w = self._wrinkles.weights(aus)
                self._wr = w.tobytes() if w.any() else None
            return self._draw(gl, ctx, cam, pos, out)

    def _draw(self, gl: dict, ctx: Any, cam: Camera, pos: dict,
              out: np.ndarray | None) -> np.ndarray:
        try:
            inside = {} if self._mouth is None else self._mouth.visibility(pos)
            for o in self._objects:
                o.update(pos.get(o.name), inside.get(o.name))
            # the shadow map is redrawn as often as the skin's blurred light (video: every
            # third frame; the shadows of a speaking head move too little in between)
            if "shadow_fbo" in gl and (self._frame % self._refresh == 0 or "shadow" not in gl):
                self._shadow_pass(gl, ctx, cam)
            self._frame += 1
            skin = self._skin
            if skin is not None:
                skin.prepare(ctx, cam.view_matrix)
            fbo = gl["fbo"]
            fbo.use()
            ctx.viewport = (0, 0, *self.size)
            fbo.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
            ctx.disable(ctx.DEPTH_TEST | ctx.BLEND | ctx.CULL_FACE)
            self._backdrop(gl, ctx, fbo)
            fbo.scissor = gl.get("above_desk")
            ctx.enable(ctx.DEPTH_TEST)
            self._view = (cam.view_matrix.T.astype("f4").tobytes(),
                          cam.projection_matrix.T.astype("f4").tobytes())
            for p in gl["progs"].values():
                p["u_view"].write(self._view[0])
                p["u_proj"].write(self._view[1])
            opaque, glass, cut, soft, fringe = [], [], [], [], []
            for o in self._opaque_order():
                for mat, first, count, tex, mode in o.parts:
                    part = (o, mat, first, count, tex)
                    if mat.alpha < 1.0:
                        glass.append(part)
                    elif mode == "blend" and mat.soft:
                        soft.append(part)
                    elif mode != "opaque":
                        cut.append(part)
                        if mode == "blend":
                            fringe.append(part)
                    else:
                        opaque.append(part)
            # cut-outs and the opaque core of blended parts (hair, lashes): their depth first
            # (a texture look-up each; before the opaque parts, whose pixels under the hair then
            # fail the depth test unshaded), then shaded once per pixel where they are in
            # front — stacked hair cards would otherwise be lit layer after layer
            fbo.color_mask = False, False, False, False
            for o, mat, first, count, tex in cut:
                self._draw_part(gl, ctx, o, mat, first, count, tex, _CUT, depth_only=True)
            fbo.color_mask = True, True, True, True
            for o, mat, first, count, tex in opaque:
                if mat.cull:
                    ctx.enable(ctx.CULL_FACE)
                else:
                    ctx.disable(ctx.CULL_FACE)
                if skin is not None and skin.handles(o, first):
                    skin.draw(ctx, o, first, mat, cam.projection_matrix, BACKFACE, tex,
                              self._wr if o.face_vbo is not None else None)
                    continue
                self._draw_part(gl, ctx, o, mat, first, count, tex, _OPAQUE)
            ctx.disable(ctx.CULL_FACE)
            if cut:
                ctx.depth_func = "=="
                for o, mat, first, count, tex in cut:
                    self._draw_part(gl, ctx, o, mat, first, count, tex, _CUT)
                ctx.depth_func = "<"
            if glass or soft or fringe:
                ctx.enable(ctx.BLEND)
                ctx.depth_mask = False
                ctx.blend_func = ctx.ONE, ctx.ONE_MINUS_SRC_ALPHA
                for o, mat, first, count, tex in glass:
                    self._draw_part(gl, ctx, o, mat, first, count, tex, _OPAQUE)
                # fine hairs on the skin (brows, lashes), under the hair's soft edges
                for o, mat, first, count, tex in soft:
                    self._draw_part(gl, ctx, o, mat, first, count, tex, _SOFT)
                # soft edges of blended parts over everything drawn so far (premultiplied)
                for o, mat, first, count, tex in fringe:
                    self._draw_part(gl, ctx, o, mat, first, count, tex, _FRINGE)
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
            w, h = self.size
            if "readback" not in gl:  # one buffer for every frame: no new pages each time
                gl["readback"] = bytearray(w * h * 3)
            gl["resolve"].read_into(gl["readback"], components=3, alignment=1)
        except RenderError:
            raise
        except Exception as exc:  # moderngl raises plain Errors
            raise RenderError(f"rendering {self.head.name!r} failed: {exc}") from exc
        img = np.frombuffer(gl["readback"], np.uint8).reshape(h, w, 3)[::-1]
        if out is None:
            return img.copy()
        np.copyto(out, img)
        return out

    def _opaque_order(self) -> list[_GpuObject]:
        """The objects in the order their opaque parts are drawn: clothes and the like, the
        skin (a head's first object; where clothes cover it, it fails the depth test before
        it is shaded), then what lies mostly behind it (eyes, teeth, tongue)."""
        rest = self._objects[1:]
        return ([o for o in rest if o.category not in INNER] + self._objects[:1]
                + [o for o in rest if o.category in INNER])

    def invalidate(self) -> None:
        """Forget state reused between frames (the skin shader's blurred irradiance): the
        next frame computes everything afresh, as after a cut. Rendering a video in chunks
        calls this at each chunk so the images do not depend on how the chunks are shared
        out among processes."""
        self._frame = 0
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
                            ("u_backface", BACKFACE if mode == _OPAQUE else 1.0),
                            ("u_tint", float(m.name in SKIN_LIKE))):
            if has_uniform(prog, name):  # a variant may have compiled a uniform away
                prog[name].value = value
        if tex is not None:
            tex.use(location=0)
            prog["u_tex"].value = 0

    @property
    def _shadows(self) -> bool:
        return self.lighting.shadows != "off"

    @property
    def _soft(self) -> bool:
        """Shadows on skin widen with the distance from what casts them (a separate program
        variant: llvmpipe runs every branch of a shader, taken or not)."""
        return self.lighting.shadows == "soft"

    def _program(self, gl: dict, textured: bool, model: str = "standard",
                 depth_only: bool = False, groups: int = 0, detail: bool = False,
                 skin: bool = False) -> Any:
        """The mesh program variant: ``textured``, the shading ``model`` (a material's:
        :data:`MODEL_DEFINES`), ``depth_only`` (texture coverage only, for a depth pre-pass),
        ``groups`` (the skin's appearance changes: the wrinkle groups compiled in, 0 for none),
        ``detail`` (a normal and roughness map; hair: its strand flow), ``skin`` (a skin-like
        material: soft shadows widen with distance on it); compiled on first use with the
        lights set."""
        shading = (MODEL_DEFINES[model],) if model in MODEL_DEFINES else ()
        shadows = self._shadows and not depth_only
        key = (("TEXTURED",) * textured + shading + ("DEPTH_ONLY",) * depth_only
               + ("SHADOWS",) * shadows + ("SOFT_SHADOWS",) * (shadows and skin and self._soft)
               + ("WRINKLES", f"WR_GROUPS {groups}") * bool(groups and not depth_only)
               + (("FLOW",) if model == "hair" else ("DETAIL",)) * (detail and not depth_only))
        progs = gl["progs"]
        if key not in progs:
            ctx = gl["ctx"]
            shadows = ("SHADOWS",) if "SHADOWS" in key else ()
            p = ctx.program(vertex_shader=_shader("mesh.vert.glsl", *shadows),
                            fragment_shader=_shader("mesh.frag.glsl", *key))
            set_lights(p, self.lighting)
            for name, value in (("u_backface", BACKFACE), ("u_mucosa", MUCOSA)):
                if has_uniform(p, name):  # the depth-only variant has no lights
                    p[name].value = value
            if getattr(self, "_view", None) is not None:
                p["u_view"].write(self._view[0])
                p["u_proj"].write(self._view[1])
            if shadows and "shadow" in gl:
                self._set_shadow(p, gl["shadow"])
            if "WRINKLES" in key:
                self._set_landmarks(p)
            progs[key] = p
        return progs[key]

    def _depth_program(self, gl: dict, textured: bool) -> Any:
        """The depth-only program (shadow map, occlusion views); ``textured`` cuts at alpha
        0.5."""
        key = ("DEPTH", textured)
        if key not in gl["progs"]:
            defines = ("TEXTURED",) if textured else ()
            gl["progs"][key] = gl["ctx"].program(
                vertex_shader=_shader("depth.vert.glsl"),
                fragment_shader=_shader("depth.frag.glsl", *defines))
        return gl["progs"][key]

    def _draw_depth(self, gl: dict, view: np.ndarray, proj: np.ndarray,
                    inner: bool = True) -> None:
        """Every opaque, cut-out and blended part's depth (not glass), seen by ``view``;
        without the objects inside the head (eyes, teeth) unless ``inner``."""
        ctx = gl["ctx"]
        ctx.enable(ctx.DEPTH_TEST)
        ctx.disable(ctx.CULL_FACE | ctx.BLEND)
        vb, pb = view.T.astype("f4").tobytes(), proj.T.astype("f4").tobytes()
        for textured in (False, True):
            prog = self._depth_program(gl, textured)
            prog["u_view"].write(vb)
            prog["u_proj"].write(pb)
            for o in self._objects:
                if not inner and o.category in INNER:
                    continue
                for mat, first, count, tex, mode in o.parts:
                    if mat.alpha < 1.0 or (mode != "opaque") != textured:
                        continue
                    if textured:
                        tex.use(location=0)
                        prog["u_tex"].value = 0
                    o.vao_for(prog).render(ctx.TRIANGLES, vertices=count, first=first)

    def _shadow_pass(self, gl: dict, ctx: Any, cam: Camera) -> None:
        """The key light's depth map over what ``cam`` sees, and its uniforms everywhere."""
        sh = gl["shadow_fbo"]
        view_rot = cam.view_matrix[:3, :3]
        key = view_rot.T @ np.asarray(unit(self.lighting.key_dir))  # camera → world
        dist = float(np.linalg.norm(cam.eye - cam.target))
        h = 2.0 * dist * np.tan(np.radians(cam.fov_y) / 2.0)
        half = 0.55 * h * max(1.0, cam.aspect)
        view = light_view(key, cam.target, gl["extent"] + half)
        proj = ortho(half, 0.0, 2.0 * (gl["extent"] + half))
        size = sh.size[0]
        texel = 2.0 * half / size
        sh.use()
        ctx.viewport = (0, 0, size, size)
        sh.clear(depth=1.0)
        # the eyes and teeth cast no key-light shadow worth their triangles (a third of the
        # pass; the images change by 5/255 at most, inside an open mouth)
        self._draw_depth(gl, view, proj, inner=False)
        # sampled toward the light and along the normal (against acne): the wider the
        # filter, the farther its taps reach over a curved surface, the more
        pen = PENUMBRA[self.lighting.shadows]
        spread, widest = SOFTBOX
        toward = np.eye(4)
        toward[2, 3] = 1.5 * texel + 0.6 * pen
        depth_cm = 2.0 * (gl["extent"] + half)  # one unit of the map's depth
        gl["shadow"] = {"u_shadow_matrix": (proj @ toward @ view).T.astype("f4").tobytes(),
                        "u_shadow_offset": 1.5 * texel + 0.3 * pen,
                        "u_shadow_radius": pen / texel,
                        "u_shadow_max": widest / texel,
                        "u_shadow_spread": spread * depth_cm / texel,
                        "u_shadow_slope": texel / depth_cm,
                        "u_shadow_texel": (1.0 / size, 1.0 / size)}
        gl["shadow_tex"].use(location=3)
        gl["shadow_depth"].use(location=4)
        progs = [p for k, p in gl["progs"].items() if "SHADOWS" in k]
        if self._skin is not None:
            progs += self._skin.programs
        for p in progs:
            self._set_shadow(p, gl["shadow"])

    @staticmethod
    def _set_shadow(prog: Any, shadow: dict) -> None:
        for name, value in shadow.items():
            if not has_uniform(prog, name):
                continue
            if name == "u_shadow_matrix":
                prog[name].write(value)
            else:
                prog[name].value = value
        if has_uniform(prog, "u_shadow_map"):
            prog["u_shadow_map"].value = 3
        if has_uniform(prog, "u_shadow_depth"):
            prog["u_shadow_depth"].value = 4

    def _set_landmarks(self, prog: Any) -> None:
        for name, value in self._wrinkles.uniforms.items():
            if has_uniform(prog, name):
                prog[name].value = value

    def _draw_part(self, gl: dict, ctx: Any, o: _GpuObject, mat: Material, first: int,
                   count: int, tex: Any, mode: int, depth_only: bool = False) -> None:
        """Draw the part of ``o`` at index ``first`` (``count`` indices)."""
        self._part(gl, o, mat, first, tex, mode, depth_only).render(
            ctx.TRIANGLES, vertices=count, first=first)

    def _part(self, gl: dict, o: _GpuObject, mat: Material, first: int, tex: Any, mode: int,
              depth_only: bool = False) -> Any:
        """Set up the program for the part of ``o`` at index ``first`` and return the
        object's vertex array for it."""
        textured = tex is not None
        groups = o.groups.get(first, 0) if self._wr is not None else 0
        detail = None if depth_only else o.details.get(first)
        model = mat.model if textured or mat.model != "hair" else "standard"
        prog = self._program(gl, textured, model, textured and depth_only, groups,
                             detail is not None, mat.name in SKIN_LIKE)
        self._set_material(prog, mat, tex, mode)
        if detail is not None:
            detail.use(location=2)
            prog["u_detail"].value = 2
        if groups and not depth_only:
            write_wrinkles(prog, self._wr)
        return o.vao_for(prog)

    def _gpu_object(self, ctx: Any, prog: Any, obj: MeshObject, landmarks: bool
                    ) -> _GpuObject:
        """The GPU object of ``obj``; the landmark object (``landmarks``) carries the face
        units, and its skin the wrinkle groups that reach each triangle (in videos, whose
        many frames repay finding them)."""
        if not landmarks:
            return _GpuObject(ctx, prog, obj)
        face = self._wrinkles.face
        reach = None
        if self.crop:
            faces = np.concatenate([p.faces for p in obj.parts]).astype(np.int32)
            reach = wrinkle_reach(ctx, face, faces, self._wrinkles.uniforms)
        return _GpuObject(ctx, prog, obj, face, reach)

    def _shadow_size(self, crop: Camera | None) -> tuple[int, int]:
        n = SHADOW_MAP[self.lighting.shadows]
        return (n, n)

    def _occlusion(self, gl: dict, ctx: Any) -> None:
        """Find the inside of the mouth and bake the ambient occlusion (when the lighting
        uses it) into the objects' vertex buffers, which hold the rest pose."""
        from mimika.render import occlusion
        from mimika.render.camera import face_frame

        centre, height, _ = face_frame(self.head)
        pts = np.concatenate([o.rest for o in self._objects])
        gl["extent"] = float(np.linalg.norm(pts - centre, axis=1).max())
        self._mouth = MouthCavity(self.head)
        for o in self._objects:
            if o.name in self._mouth.ids:
                o.inside_ids = self._mouth.ids[o.name]
                o.interleaved[o.inside_ids, 8] = self._mouth.inside[o.name]
        if self.lighting.ao > 0:
            key = (id(self.head), tuple(o.name for o in self._objects))
            ao = occlusion.bake(key, ctx, self._objects,
                                lambda view, proj: self._draw_depth(gl, view, proj),
                                centre, 1.2 * height, gl["extent"])
            ao = {**ao, **occlusion.eye_occlusion(self.head, self._objects)}
            for o in self._objects:
                o.interleaved[:, 6] = ao[o.name]
        for o in self._objects:
            o.vbo.write(o.interleaved)

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
        prog = self._program(gl, False)
        lit = self.lighting
        studio = lit.backdrop == "studio"
        bg = ctx.program(
            vertex_shader=_shader("background.vert.glsl"),
            fragment_shader=_shader("studio.frag.glsl" if studio else "background.frag.glsl"),
        )
        bg["u_top"].value = lit.bg_top
        bg["u_bottom"].value = lit.bg_bottom
        bg["u_glow"].value = lit.bg_glow
        bg["u_aspect"].value = self.aspect
        if lit.desk > 0:
            desk = ctx.program(vertex_shader=_shader("background.vert.glsl"),
                               fragment_shader=_shader("desk.frag.glsl"))
            desk["u_top"].value = lit.desk
            gl["desk_prog"] = desk
            gl["desk_vao"] = ctx.vertex_array(desk, [])
            rows = min(int(np.ceil((lit.desk + 0.006) * self.size[1])) + 1, self.size[1])
            gl["desk_rect"] = (0, 0, self.size[0], rows)
            # the rows the desk covers opaquely (its alpha is 1 up to u_top - 0.001; one row
            # of margin) are not worth drawing anything into before it
            hidden = max(int(np.floor((lit.desk - 0.001) * self.size[1] - 0.5)), 0)
            gl["above_desk"] = (0, hidden, self.size[0], self.size[1] - hidden)
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
        self._wrinkles = Wrinkles(self.head)
        lmo = self.head.landmark_object
        self._objects = [self._gpu_object(ctx, prog, o, o.name == lmo)
                         for o in shown if o.parts]
        for o in self._objects:
            o.update(None)
        self._occlusion(gl, ctx)
        if self._shadows:
            tex = ctx.depth_texture(self._shadow_size(crop))
            tex.compare_func = "<="
            tex.filter = (ctx.LINEAR, ctx.LINEAR)
            tex.repeat_x = tex.repeat_y = False
            gl["attachments"].append(tex)
            gl["shadow_tex"] = tex
            # the same depths read as numbers, for the blocker search
            gl["shadow_depth"] = ctx.sampler(texture=tex, compare_func="",
                                             filter=(ctx.NEAREST, ctx.NEAREST),
                                             repeat_x=False, repeat_y=False)
            gl["attachments"].append(gl["shadow_depth"])
            gl["shadow_fbo"] = ctx.framebuffer(depth_attachment=tex)
        if self.skin_shader:
            from mimika.render.skin import SkinShader

            uvs = {o.name: o.uvs for o in self.head.objects if o.uvs is not None}
            if uvs:
                params = None if isinstance(self.skin_shader, bool) else self.skin_shader
                shadows = ("SHADOWS",) * self._shadows + ("SOFT_SHADOWS",) * self._soft
                self._skin = SkinShader(ctx, self._objects, uvs, lit, params, shadows,
                                        ("WRINKLES",))
                for p in self._skin.programs:
                    if has_uniform(p, "u_mucosa"):
                        p["u_mucosa"].value = MUCOSA
                    self._set_landmarks(p)
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
    the image outside ``cam``'s view (corners behind the camera count as in view). Opaque
    two-sided parts (clothes) get their triangles sorted front to back: the far side of a
    garment then fails the depth test instead of being shaded and covered (one-sided parts
    keep their order, which reuses more of the shaded vertices)."""
    clip = np.c_[obj.vertices, np.ones(obj.n_vertices)] @ (
        cam.projection_matrix @ cam.view_matrix).T
    ndc = clip[:, :2] / np.where(clip[:, 3:] > 0, clip[:, 3:], 1.0)
    # a quarter of the image beyond each edge is 1.5 in normalised device coordinates
    out = (clip[:, 3] > 0) & (np.abs(ndc) > 1.5).any(axis=1)

    def kept(p: Part) -> Part:
        f = p.faces[~out[p.faces].all(axis=1)]
        m = material(p.material)
        if p.alpha_mode == "opaque" and m.alpha >= 1.0 and not m.cull:
            f = f[np.argsort(clip[f, 3].min(axis=1), kind="stable")]
        return replace(p, faces=f)

    parts = (kept(p) for p in obj.parts)
    return replace(obj, parts=tuple(p for p in parts if len(p.faces)))

