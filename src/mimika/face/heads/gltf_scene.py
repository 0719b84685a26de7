"""Read a glTF 2.0 / GLB / VRM file into plain arrays (:mod:`mimika.io.gltf_source` reads
the file and its buffers; pygltflib gives the object model).

Every mesh node of the default scene becomes a :class:`SceneMesh` in the file's units and
axes, at its rest pose: node transforms applied, skinned meshes placed by their joints
(linear-blend skinning with the bind matrices, so a bind pose that differs from the rest
pose is honoured), morph target deltas mapped by the same linear part. Materials keep their
base colour, base-colour / normal textures (decoded to uint8 arrays) and alpha mode. VRM
0.x (``VRM``) and 1.0 (``VRMC_vrm``) humanoid bones, expressions, lookAt ranges and MToon
materials are read by :mod:`.vrm`. Skinned meshes keep their bind data (:class:`SkinBind`)
so they can be posed again (:mod:`.gltf_pose`).
"""

from __future__ import annotations

import io
import json
import logging
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mimika.errors import DataError
from mimika.face.heads.vrm import read_vrm, toon_materials, vrm0_base_color
from mimika.io.gltf_ext.webp import texture_source
from mimika.io.gltf_source import load_source
from mimika.limits import current

log = logging.getLogger(__name__)

__all__ = ["GltfScene", "SceneMaterial", "SceneMesh", "SkinBind", "read_gltf"]

_DTYPES = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32,
           5126: np.float32}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
#: most numbers in one accessor (count × components)
_MAX_COUNT = 50_000_000
#: deepest node hierarchy, most mesh instances, most morph targets per mesh
_MAX_DEPTH, _MAX_MESHES, _MAX_MORPHS = 256, 512, 2048
#: largest position coordinate (file units; a head in millimetres is ~300)
_MAX_COORD = 1e6
_NORM = {np.int8: 127.0, np.uint8: 255.0, np.int16: 32767.0, np.uint16: 65535.0}


@dataclass
class SceneMaterial:
    """A glTF material: linear RGBA factor, optional sRGB base-colour and normal images
    ((H, W, C) uint8, row 0 = top), alpha mode (OPAQUE | MASK | BLEND) and cutoff."""

    name: str
    base_color: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)
    base_color_image: np.ndarray | None = None
    normal_image: np.ndarray | None = None
    alpha_mode: str = "OPAQUE"
    alpha_cutoff: float = 0.5
    double_sided: bool = False
    toon: bool = False  #: MToon or unlit (VRM): drawn flat, see :mod:`.vrm`


@dataclass
class SkinBind:
    """How a skinned mesh is placed: its stored (bind-space) positions, per vertex the joint
    slots (N, K) into ``joint_nodes`` and normalised weights (N, K), and per joint its node
    and inverse bind matrix (J, 4, 4)."""

    vertices: np.ndarray
    slots: np.ndarray
    weights: np.ndarray
    joint_nodes: np.ndarray
    ibm: np.ndarray

    def matrices(self, world: np.ndarray) -> np.ndarray:
        """Per-vertex skinning matrices (N, 4, 4) for node world matrices ``world``."""
        mats = world[self.joint_nodes] @ self.ibm
        return np.einsum("nk,nkij->nij", self.weights, mats[self.slots])

    def subset(self, idx: np.ndarray) -> SkinBind:
        return SkinBind(self.vertices[idx], self.slots[idx], self.weights[idx],
                        self.joint_nodes, self.ibm)


@dataclass
class SceneMesh:
    """One mesh node: positions (N, 3), triangles per primitive with a material index,
    UVs (N, 2) or None, morph targets (names, deltas (M, N, 3)), and skin joints/weights
    (``bind``: how the skin placed it, for posing it again)."""

    name: str
    node: int
    vertices: np.ndarray
    primitives: list[tuple[int, np.ndarray]]
    uvs: np.ndarray | None = None
    morph_names: list[str] = field(default_factory=list)
    morph_deltas: np.ndarray | None = None
    joints: np.ndarray | None = None  #: (N, 4) node indices
    weights: np.ndarray | None = None  #: (N, 4)
    mesh_name: str = ""  #: the glTF mesh's own name (``name`` is the node's)
    bind: SkinBind | None = None
    #: glTF primitive index → (first vertex, count) of its vertices in the whole mesh
    ranges: dict[int, tuple[int, int]] = field(default_factory=dict)
    #: the vertices' indices in the whole mesh (None: this is the whole mesh)
    index: np.ndarray | None = None

    def subset(self, prims: list[tuple[int, np.ndarray]], name: str) -> SceneMesh:
        """The mesh of primitives ``prims`` ((material, triangles) over this mesh's vertices)
        only, under ``name``, with the vertices they use renumbered."""
        keep = np.unique(np.concatenate([f.reshape(-1) for _, f in prims]))
        new = np.full(len(self.vertices), -1, np.int64)
        new[keep] = np.arange(len(keep))

        def sub(a: np.ndarray | None, axis: int = 0) -> np.ndarray | None:
            return None if a is None else np.take(a, keep, axis=axis)

        return SceneMesh(name, self.node, self.vertices[keep],
                         [(k, new[f]) for k, f in prims],
                         sub(self.uvs), list(self.morph_names), sub(self.morph_deltas, 1),
                         sub(self.joints), sub(self.weights), self.mesh_name,
                         None if self.bind is None else self.bind.subset(keep), self.ranges,
                         keep if self.index is None else self.index[keep])

    def posed(self, rest: np.ndarray, world: np.ndarray) -> None:
        """Place the mesh again for node world matrices ``world`` (rest: ``rest``): skinned
        meshes through their joints, others with their node; morph deltas follow."""
        if self.bind is not None:
            m0, m1 = self.bind.matrices(rest), self.bind.matrices(world)
            v = self.bind.vertices
            self.vertices = np.einsum("nij,nj->ni", m1[:, :3, :3], v) + m1[:, :3, 3]
            lin = m1[:, :3, :3] @ np.linalg.inv(m0[:, :3, :3])
        else:
            d = world[self.node] @ np.linalg.inv(rest[self.node])
            self.vertices = self.vertices @ d[:3, :3].T + d[:3, 3]
            lin = np.broadcast_to(d[:3, :3], (len(self.vertices), 3, 3))
        if self.morph_deltas is not None:
            self.morph_deltas = np.einsum("nij,mnj->mni", lin, self.morph_deltas
                                          ).astype(np.float32)


@dataclass
class GltfScene:
    """The meshes, materials, node names and world positions, VRM data of one file."""

    path: Path
    meshes: list[SceneMesh]
    materials: list[SceneMaterial]
    node_names: list[str]
    node_world: np.ndarray  #: (nodes, 4, 4) rest-pose world matrices
    node_parent: np.ndarray  #: (nodes,) parent node index or -1
    vrm_version: int | None = None  #: 0 for VRM 0.x, 1 for VRM 1.0, None otherwise
    bones: dict[str, int] = field(default_factory=dict)  #: humanoid bone → node (VRM)
    expressions: dict[str, list[tuple[int, int, float]]] = field(default_factory=dict)
    #: VRM expression preset → [(mesh index in :attr:`meshes`, morph index, weight 0–1)]
    vrm_look_type: str = "bone"  #: VRM lookAt: eye bones turn, or look expressions
    vrm_look: dict[str, float] = field(default_factory=dict)
    #: eye AU → fraction of its turn a 30° gaze gives under the VRM lookAt ranges

    def node_position(self, node: int) -> np.ndarray:
        return self.node_world[node, :3, 3].copy()

    def descendants(self, node: int) -> set[int]:
        """``node`` and every node below it."""
        out = {node}
        changed = True
        while changed:
            changed = False
            for i, p in enumerate(self.node_parent):
                if p in out and i not in out:
                    out.add(i)
                    changed = True
        return out


def _trs(node) -> np.ndarray:
    if node.matrix is not None and len(node.matrix) == 16:
        return np.asarray(node.matrix, float).reshape(4, 4).T
    m = np.eye(4)
    if node.rotation is not None:
        x, y, z, w = (float(c) for c in node.rotation)
        m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    if node.scale is not None:
        m[:3, :3] = m[:3, :3] * np.asarray(node.scale, float)[None, :]
    if node.translation is not None:
        m[:3, 3] = node.translation
    return m


class _Reader:
    """pygltflib's object model over :class:`~mimika.io.gltf_source.GltfSource`'s JSON; the
    bytes come from the source (each bufferView from its own buffer, meshopt decoded)."""

    def __init__(self, path: Path) -> None:
        from pygltflib import GLTF2

        self.path = path
        self.src = load_source(path)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                g = GLTF2.from_json(json.dumps(self.src.doc), infer_missing=True)
        except Exception as e:  # pygltflib raises many kinds on broken input
            raise DataError(f"{path}: not a readable glTF/GLB file ({type(e).__name__}: "
                            f"{str(e)[:120]}); export it again from your tool") from None
        self.g = g

    def accessor(self, idx: int | None) -> np.ndarray:
        """Accessor ``idx`` as an (count, width) array (normalised integers → float)."""
        g = self.g
        try:
            acc = g.accessors[idx]
            dt = np.dtype(_DTYPES[acc.componentType])
            width = _WIDTH[acc.type]
            if (not isinstance(acc.count, int) or acc.count < 0
                    or acc.count * width > _MAX_COUNT):
                raise ValueError(f"count {acc.count!r}")
            out = np.zeros((acc.count, width), dt)
            if acc.bufferView is not None:
                blob = self.src.view(acc.bufferView)
                bv = g.bufferViews[acc.bufferView]
                off = acc.byteOffset or 0
                stride = bv.byteStride or width * dt.itemsize
                need = off + stride * (acc.count - 1) + width * dt.itemsize
                if acc.count and need > len(blob):
                    raise ValueError("runs past the end of its bufferView")
                if acc.count:
                    out[:] = np.ndarray((acc.count, width), dt, blob, off,
                                        (stride, dt.itemsize))
            sp = acc.sparse
            if sp is not None and sp.count:
                if not 0 < sp.count <= acc.count:
                    raise ValueError(f"sparse count {sp.count!r}")
                iblob = self.src.view(sp.indices.bufferView)
                idt = np.dtype(_DTYPES[sp.indices.componentType])
                ids = np.frombuffer(iblob, idt, sp.count, sp.indices.byteOffset or 0)
                if ids.max() >= acc.count:
                    raise ValueError("sparse index past its count")
                vblob = self.src.view(sp.values.bufferView)
                vals = np.frombuffer(vblob, dt, sp.count * width, sp.values.byteOffset or 0)
                out[ids.astype(np.int64)] = vals.reshape(-1, width)
        except (IndexError, KeyError, TypeError, ValueError, AttributeError) as e:
            raise DataError(f"{self.path}: accessor {idx} is broken ({e}); export the file "
                            "again") from None
        if acc.normalized and dt.type in _NORM:
            return out.astype(np.float32) / _NORM[dt.type]
        return out

    def image(self, tex_index: int | None) -> np.ndarray | None:
        """The decoded image of texture ``tex_index`` ((H, W, C) uint8) or None."""
        from PIL import Image

        textures = self.src.items("textures")
        if not isinstance(tex_index, int) or not 0 <= tex_index < len(textures):
            return None
        src = texture_source(textures[tex_index])
        if src is None:
            return None
        try:
            data = self.src.image_bytes(src)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                pic = Image.open(io.BytesIO(data))
                w, h = pic.size
                cap = current().max_texture_pixels
                if w * h > cap:
                    log.warning("%s: image %s is %d×%d, over %d pixels (max_texture_pixels); "
                                "using the material colour", self.path, src, w, h, cap)
                    return None
                pic = pic.convert("RGBA" if "A" in pic.getbands() else "RGB")
            return np.asarray(pic, np.uint8)
        except DataError as e:  # outside the folder, missing: say so, keep the colour
            log.warning("%s; using the material colour", e)
            return None
        except Exception as e:  # an undecodable image: keep the material colour
            log.warning("%s: image %s not decoded (%s); using the material colour",
                        self.path, src, e)
            return None


def _materials(r: _Reader) -> list[SceneMaterial]:
    out = []
    toon = toon_materials(r.g)
    for i, m in enumerate(r.g.materials or []):
        pbr = m.pbrMetallicRoughness
        col = tuple(float(c) for c in (pbr.baseColorFactor if pbr and pbr.baseColorFactor
                                       else (1, 1, 1, 1)))
        bct = pbr.baseColorTexture.index if pbr and pbr.baseColorTexture else None
        if pbr is None and i in toon:  # VRM 0.x without PBR: MToon's colour and texture
            vcol, bct = vrm0_base_color(r.g, i)
            col = vcol or col
        nt = m.normalTexture.index if m.normalTexture else None
        out.append(SceneMaterial(m.name or f"material{i}", col, r.image(bct), r.image(nt),
                                 m.alphaMode or "OPAQUE", float(m.alphaCutoff or 0.5),
                                 bool(m.doubleSided), i in toon))
    return out


def _world(g) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """Rest world matrices and parents of all nodes; the nodes of the default scene. Child
    indices, one parent per node, no cycles and depth ≤ :data:`_MAX_DEPTH` are checked."""
    n = len(g.nodes)
    parent = np.full(n, -1, np.int64)
    for i, nd in enumerate(g.nodes):
        for c in nd.children or []:
            if not isinstance(c, int) or not 0 <= c < n or c == i:
                raise DataError(f"node {i} has child {c!r}, which does not exist")
            if parent[c] >= 0:
                raise DataError(f"node {c} has two parents ({parent[c]} and {i})")
            parent[c] = i
    local = np.stack([_trs(nd) for nd in g.nodes]) if n else np.zeros((0, 4, 4))
    if not np.isfinite(local).all():
        raise DataError("a node transform is not finite")
    world = np.zeros_like(local)
    depth = np.full(n, -1, np.int64)
    for i in range(n):  # iteratively: walk up to a solved node, then down
        chain = []
        j = i
        while j >= 0 and depth[j] < 0:
            chain.append(j)
            if len(chain) > min(n, _MAX_DEPTH):
                raise DataError(f"the node hierarchy has a cycle or is deeper than "
                                f"{_MAX_DEPTH} levels")
            j = parent[j]
        for k in reversed(chain):
            p = parent[k]
            world[k] = local[k] if p < 0 else world[p] @ local[k]
            depth[k] = 0 if p < 0 else depth[p] + 1
            if depth[k] > _MAX_DEPTH:
                raise DataError(f"the node hierarchy is deeper than {_MAX_DEPTH} levels")
    scenes = g.scenes or []
    if scenes:
        si = g.scene or 0
        if not isinstance(si, int) or not 0 <= si < len(scenes):
            raise DataError(f"the default scene {si!r} does not exist")
        roots = scenes[si].nodes or []
        if any(not isinstance(r, int) or not 0 <= r < n for r in roots):
            raise DataError("a scene names a node that does not exist")
        seen: set[int] = set()
        stack = list(roots)
        while stack:  # one parent per node: each is reached once
            i = stack.pop()
            if i in seen:
                continue
            seen.add(i)
            stack += g.nodes[i].children or []
        in_scene = sorted(seen)
    else:
        in_scene = list(range(n))
    return world, parent, in_scene


def _mesh_node(r: _Reader, ni: int, world: np.ndarray) -> SceneMesh | None:
    g = r.g
    node = g.nodes[ni]
    mesh = g.meshes[node.mesh]
    verts, uvs, faces, joints, weights = [], [], [], [], []
    targets: list[list[np.ndarray]] = []
    seen: dict[int, int] = {}
    ranges: dict[int, tuple[int, int]] = {}
    base = 0
    for k_prim, prim in enumerate(mesh.primitives):
        if prim.mode not in (None, 4):
            continue  # only triangle lists
        a = prim.attributes
        if a.POSITION is None:
            continue
        if a.POSITION in seen:  # primitives sharing one vertex array
            off = seen[a.POSITION]
        else:
            off = seen[a.POSITION] = base
            v = r.accessor(a.POSITION)[:, :3].astype(np.float64)
            if not np.isfinite(v).all() or np.abs(v).max(initial=0) > _MAX_COORD:
                raise DataError(f"{r.path}: mesh {mesh.name!r} has positions that are not "
                                f"finite numbers within ±{_MAX_COORD:g}")
            if len(prim.targets or []) > _MAX_MORPHS:
                raise DataError(f"{r.path}: mesh {mesh.name!r} has {len(prim.targets)} morph "
                                f"targets, over {_MAX_MORPHS}")
            verts.append(v)
            uvs.append(r.accessor(a.TEXCOORD_0)[:, :2] if a.TEXCOORD_0 is not None else None)
            joints.append(r.accessor(a.JOINTS_0) if a.JOINTS_0 is not None else None)
            weights.append(r.accessor(a.WEIGHTS_0) if a.WEIGHTS_0 is not None else None)
            tl = []
            for t in prim.targets or []:
                pi = t.get("POSITION") if isinstance(t, dict) else getattr(t, "POSITION", None)
                d = r.accessor(pi)[:, :3] if pi is not None else np.zeros_like(v)
                if d.shape != v.shape or not np.isfinite(d).all():
                    raise DataError(f"{r.path}: mesh {mesh.name!r}: a morph target does not "
                                    "match its vertices or is not finite")
                tl.append(d)
            targets.append(tl)
            base += len(v)
        ranges[k_prim] = (off, len(verts[list(seen).index(a.POSITION)]))
        idx = (r.accessor(prim.indices).reshape(-1) if prim.indices is not None
               else np.arange(len(verts[-1])))
        if len(idx) % 3:
            raise DataError(f"{r.path}: mesh {mesh.name!r} has {len(idx)} indices, not a "
                            "multiple of 3")
        f = idx.astype(np.int64).reshape(-1, 3) + off
        if len(f) and (f.max() >= base):
            raise DataError(f"{r.path}: mesh {mesh.name!r} indexes past its vertices")
        faces.append((prim.material if prim.material is not None else -1, f))
    if not verts:
        return None
    v = np.concatenate(verts)
    n_t = {len(t) for t in targets}
    if len(n_t) > 1:
        raise DataError(f"{r.path}: mesh {mesh.name!r}: primitives have different numbers of "
                        "morph targets")
    n_targets = n_t.pop()
    deltas = (np.concatenate([np.stack(t) if t else np.zeros((0, len(vv), 3))
                              for t, vv in zip(targets, verts, strict=True)], axis=1)
              if n_targets else None)
    names = list((mesh.extras or {}).get("targetNames") or [])
    if not names and mesh.primitives and mesh.primitives[0].extras:
        names = list(mesh.primitives[0].extras.get("targetNames") or [])
    if len(names) != n_targets:
        names = [f"morph{k}" for k in range(n_targets)]
    uv = np.concatenate(uvs) if all(u is not None for u in uvs) else None
    jt = wt = bind = None
    if node.skin is not None and all(j is not None for j in joints) and all(
            w is not None for w in weights):
        if not isinstance(node.skin, int) or not 0 <= node.skin < len(g.skins or []):
            raise DataError(f"{r.path}: node {ni} names skin {node.skin!r}, which does not "
                            "exist")
        skin = g.skins[node.skin]
        jt_local = np.concatenate(joints).astype(np.int64)
        wt = np.concatenate(weights).astype(np.float64)
        jnodes = np.asarray(skin.joints or [], np.int64)
        if jnodes.size and (jnodes.min() < 0 or jnodes.max() >= len(g.nodes)):
            raise DataError(f"{r.path}: skin {node.skin} names a joint node that does not "
                            "exist")
        if jt_local.max(initial=0) >= len(jnodes) or jt_local.min(initial=0) < 0:
            raise DataError(f"{r.path}: skin {node.skin} joint index out of range")
        jt = jnodes[jt_local]
        ibm = (r.accessor(skin.inverseBindMatrices).reshape(-1, 4, 4).transpose(0, 2, 1)
               if skin.inverseBindMatrices is not None else np.tile(np.eye(4), (len(jnodes),
                                                                                1, 1)))
        s = wt.sum(1, keepdims=True)
        wn = wt / np.where(s > 0, s, 1.0)
        bind = SkinBind(v, jt_local, wn, jnodes, ibm)
        m = bind.matrices(world)
        v = np.einsum("nij,nj->ni", m[:, :3, :3], v) + m[:, :3, 3]
        if deltas is not None:
            deltas = np.einsum("nij,mnj->mni", m[:, :3, :3], deltas)
    else:
        m = world[ni]
        v = v @ m[:3, :3].T + m[:3, 3]
        if deltas is not None:
            deltas = deltas @ m[:3, :3].T
    name = node.name or mesh.name or f"mesh{node.mesh}"
    return SceneMesh(name, ni, v, faces, uv, names,
                     None if deltas is None else deltas.astype(np.float32), jt, wt,
                     mesh.name or "", bind, ranges)


def read_gltf(path: str | Path) -> GltfScene:
    """Read ``path`` (.gltf, .glb or .vrm). Raises :class:`DataError` with one line for files
    that are missing, broken or hold no triangle mesh."""
    p = Path(path)
    if not p.is_file():
        raise DataError(f"{p}: no such file")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return _read(p)
    except DataError as e:
        msg = str(e)
        raise DataError(msg if msg.startswith(str(p)) else f"{p}: {msg}; export the file "
                        "again from your tool") from None
    except (IndexError, KeyError, TypeError, ValueError, AttributeError, OverflowError,
            MemoryError, RecursionError, np.linalg.LinAlgError) as e:
        # a structure the checks above did not foresee: still one line, never a traceback
        raise DataError(f"{p}: a malformed glTF ({type(e).__name__}: {str(e)[:100]}); "
                        "export the file again from your tool") from None


def _read(p: Path) -> GltfScene:
    r = _Reader(p)
    g = r.g
    world, parent, in_scene = _world(g)
    if sum(g.nodes[i].mesh is not None for i in in_scene) > _MAX_MESHES:
        raise DataError(f"{p}: more than {_MAX_MESHES} mesh instances")
    meshes: list[SceneMesh] = []
    mesh_of_node: dict[int, list[int]] = {}
    for ni in in_scene:
        if g.nodes[ni].mesh is None:
            continue
        if not isinstance(g.nodes[ni].mesh, int) or not 0 <= g.nodes[ni].mesh < len(g.meshes):
            raise DataError(f"{p}: node {ni} names mesh {g.nodes[ni].mesh}, which does not exist")
        sm = _mesh_node(r, ni, world)
        if sm is not None and any(len(f) for _, f in sm.primitives):
            mesh_of_node.setdefault(ni, []).append(len(meshes))
            meshes.append(sm)
    if not meshes:
        raise DataError(f"{p}: the file holds no triangle mesh (nothing to animate)")
    allv = np.concatenate([m.vertices for m in meshes])
    if not np.isfinite(allv).all() or np.abs(allv).max() > _MAX_COORD or np.ptp(
            allv, axis=0).max() <= 0:
        raise DataError(f"{p}: the placed meshes are not finite, beyond ±{_MAX_COORD:g} or "
                        "have no extent")
    scene = GltfScene(p, meshes, _materials(r), [nd.name or f"node{i}" for i, nd in
                                                 enumerate(g.nodes)], world, parent)
    read_vrm(g, scene, mesh_of_node)
    return scene
