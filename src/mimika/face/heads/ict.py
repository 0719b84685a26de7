"""The ICT Face Model Light (ICT-FaceKit, MIT licence) as a mimika :class:`Head` + shape deltas.

The data is not shipped: point ``MIMIKA_ICT_DIR`` (or ``--head``) at a clone of
https://github.com/ICT-VGL/ICT-FaceKit. Parsing its 54 OBJ files takes seconds, so the parsed
arrays are cached as one ``.npz`` under ``${MIMIKA_CACHE_DIR:-~/.cache/mimika}``, keyed by the
folder path and the sizes/mtimes of the files read.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from mimika.cachedir import cache_dir
from mimika.errors import DataError, ParameterError
from mimika.face.head import Head, MeshObject, Part
from mimika.face.rigs.blendshape import BlendshapeRig, ShapeSet, load_table
from mimika.io.atomic import atomic_open
from mimika.io.obj import read_obj, read_obj_vertices

log = logging.getLogger(__name__)

__all__ = ["IctData", "find_ict_dir", "identity_weights", "load_ict", "load_ict_data",
           "load_ict_head", "load_ict_identities", "with_identity"]

ENV_DIR = "MIMIKA_ICT_DIR"
NEUTRAL = "generic_neutral_mesh.obj"
INDICES = "vertex_indices.json"
_CACHE_VERSION = 1

HOW_TO_GET = (
    "git clone https://github.com/ICT-VGL/ICT-FaceKit (MIT licence), then set "
    "MIMIKA_ICT_DIR=/path/to/ICT-FaceKit or pass --head /path/to/ICT-FaceKit"
)

#: Object name → (first vertex, end vertex) in the ICT vertex order (README table, end exclusive).
RANGES: dict[str, tuple[int, int]] = {
    "skin": (0, 11248),  # face [0:9409] + head & neck [9409:11248]
    "mouth": (11248, 13294),
    "sockets": (13294, 14062),
    "gums": (14062, 17039),
    "teeth": (17039, 21451),
    "eye_L": (21451, 23021),  # sclera [21451:22221], iris [22221:23021]
    "eye_R": (23021, 24591),  # sclera [23021:23791], iris [23791:24591]
    "lashes": (25351, 26719),
}
_IRIS_START = {"eye_L": 22221, "eye_R": 23791}
PUPIL_FRACTION = 0.4  #: pupil radius as a fraction of the iris radius


def find_ict_dir(path: str | os.PathLike | None = None) -> Path:
    """The ICT ``FaceXModel`` folder (the one holding ``generic_neutral_mesh.obj``).

    ``path`` (else ``$MIMIKA_ICT_DIR``) may be the ICT-FaceKit root or its ``FaceXModel``
    folder. Raises :class:`DataError` saying where it looked and how to get the model.
    """
    if path is not None:
        base, source = Path(path).expanduser(), "the given path"
    elif os.environ.get(ENV_DIR):
        base, source = Path(os.environ[ENV_DIR]).expanduser(), f"${ENV_DIR}"
    else:
        raise DataError(
            f"the ICT Face Model was not found: no path was given and ${ENV_DIR} is not set. "
            f"To get it: {HOW_TO_GET}"
        )
    tried = [base, base / "FaceXModel"]
    for d in tried:
        if (d / NEUTRAL).is_file():
            return d.resolve()
    raise DataError(
        f"the ICT Face Model was not found: looked for {NEUTRAL} in "
        f"{' and '.join(str(t) for t in tried)} ({source}). To get it: {HOW_TO_GET}"
    )


# -- raw data + cache ---------------------------------------------------------------------------


@dataclass(frozen=True)
class IctData:
    """Parsed ICT arrays over the full 26 719-vertex topology.

    vertices (V, 3) float32 · faces (F, 3) int32 · face_groups (F,) int32 into ``groups`` ·
    uvs (V, 2) float32 per vertex · landmarks (68,) int64 · shape_names (S,) ·
    deltas (S, V, 3) float32 = shape target − neutral.
    """

    folder: Path
    vertices: np.ndarray
    faces: np.ndarray
    face_groups: np.ndarray
    groups: tuple[str, ...]
    uvs: np.ndarray
    landmarks: np.ndarray
    shape_names: tuple[str, ...]
    deltas: np.ndarray


def _shape_files(folder: Path) -> tuple[list[str], list[Path]]:
    try:
        info = json.loads((folder / INDICES).read_text("utf-8"))
        names = list(info["expressions"])
    except FileNotFoundError:
        raise DataError(f"{folder / INDICES} is missing; the ICT folder is incomplete. "
                        f"{HOW_TO_GET}") from None
    except (ValueError, KeyError, TypeError) as e:
        raise DataError(
            f"{folder / INDICES}: expected JSON with an 'expressions' list ({e})"
        ) from e
    files = [folder / f"{n}.obj" for n in names]
    missing = [str(f.name) for f in files if not f.is_file()]
    if missing:
        raise DataError(f"{folder}: expression shape files missing: {', '.join(missing)}")
    return names, files


def _cache_key(folder: Path, files: list[Path]) -> str:
    h = hashlib.sha256(f"v{_CACHE_VERSION}|{folder}".encode())
    for f in [folder / NEUTRAL, folder / INDICES, *files]:
        st = f.stat()
        h.update(f"|{f.name}:{st.st_size}:{st.st_mtime_ns}".encode())
    return h.hexdigest()[:20]


def _parse(folder: Path, names: list[str], files: list[Path]) -> dict[str, np.ndarray]:
    mesh = read_obj(folder / NEUTRAL)
    info = json.loads((folder / INDICES).read_text("utf-8"))
    landmarks = np.asarray(info["idx_to_landmark_verts"], np.int64)
    n = len(mesh.vertices)
    deltas = np.empty((len(files), n, 3), np.float32)
    for k, f in enumerate(files):
        v = read_obj_vertices(f)
        if v.shape != mesh.vertices.shape:
            raise DataError(f"{f}: has {len(v)} vertices, expected {n} like {NEUTRAL}")
        np.subtract(v, mesh.vertices, out=deltas[k])
    uvs = mesh.vertex_uvs()
    return {
        "vertices": mesh.vertices,
        "faces": mesh.faces,
        "face_groups": mesh.face_groups,
        "groups": np.array(mesh.groups),
        "uvs": uvs if uvs is not None else np.zeros((n, 2), np.float32),
        "landmarks": landmarks,
        "shape_names": np.array(names),
        "deltas": deltas,
    }


def _write_atomic(path: Path, arrays: dict[str, np.ndarray]) -> None:
    with atomic_open(path) as fh:
        np.savez(fh, **arrays)


def load_ict_data(path: str | os.PathLike | None = None, *, cache: bool = True) -> IctData:
    """Parse (or load from cache) the ICT neutral mesh, landmarks and expression deltas."""
    folder = find_ict_dir(path)
    names, files = _shape_files(folder)
    t0 = time.perf_counter()
    arrays: dict[str, np.ndarray] | None = None
    cfile = cache_dir() / f"ict-{_cache_key(folder, files)}.npz"
    if cache and cfile.is_file():
        try:
            with np.load(cfile, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
            if list(arrays["shape_names"]) != names or arrays["deltas"].shape[0] != len(names):
                raise ValueError("shape list differs")
            log.debug("ICT model loaded from cache %s in %.3f s", cfile,
                      time.perf_counter() - t0)
        except Exception as e:  # a corrupt or stale cache is rebuilt
            log.warning("ignoring unreadable ICT cache %s (%s); rebuilding", cfile, e)
            arrays = None
    if arrays is None:
        arrays = _parse(folder, names, files)
        log.info("parsed ICT model from %s in %.2f s", folder, time.perf_counter() - t0)
        if cache:
            try:
                _write_atomic(cfile, arrays)
            except OSError as e:
                log.warning("could not write ICT cache %s: %s", cfile, e)
    return IctData(
        folder=folder,
        vertices=arrays["vertices"].astype(np.float32, copy=False),
        faces=arrays["faces"].astype(np.int32, copy=False),
        face_groups=arrays["face_groups"].astype(np.int32, copy=False),
        groups=tuple(str(g) for g in arrays["groups"]),
        uvs=arrays["uvs"].astype(np.float32, copy=False),
        landmarks=arrays["landmarks"].astype(np.int64, copy=False),
        shape_names=tuple(str(s) for s in arrays["shape_names"]),
        deltas=arrays["deltas"].astype(np.float32, copy=False),
    )


# -- identities (PCA identity modes identity000–009.obj) -----------------------------------------

N_IDENTITIES = 10  #: identity modes in ICT Face Model Light
Identity = int | Sequence[float] | None


def identity_weights(identity: Identity) -> np.ndarray | None:
    """``identity`` → weights (10,) of the identity modes: an int K (0–9) is mode K at weight 1
    (the mesh ``identityK.obj``); a sequence gives the weights (missing trailing ones are 0)."""
    if identity is None:
        return None
    if isinstance(identity, int | np.integer):
        if not 0 <= int(identity) < N_IDENTITIES:
            raise ParameterError(f"identity {identity} must be 0–{N_IDENTITIES - 1}")
        w = np.zeros(N_IDENTITIES)
        w[int(identity)] = 1.0
        return w
    w = np.asarray(list(identity), float).ravel()
    if len(w) > N_IDENTITIES or not np.all(np.isfinite(w)):
        raise ParameterError(f"identity weights must be at most {N_IDENTITIES} finite numbers, "
                             f"got {list(w)}")
    return np.r_[w, np.zeros(N_IDENTITIES - len(w))]


def load_ict_identities(path: str | os.PathLike | None = None, *,
                        cache: bool = True) -> np.ndarray:
    """Identity-mode deltas (10, V, 3) float32 = ``identityK.obj`` − neutral (cached .npz)."""
    folder = find_ict_dir(path)
    files = [folder / f"identity{k:03d}.obj" for k in range(N_IDENTITIES)]
    missing = [f.name for f in files if not f.is_file()]
    if missing:
        raise DataError(f"{folder}: identity files missing: {', '.join(missing)}")
    cfile = cache_dir() / f"ict-id-{_cache_key(folder, files)}.npz"
    if cache and cfile.is_file():
        try:
            with np.load(cfile, allow_pickle=False) as z:
                return z["deltas"].astype(np.float32, copy=False)
        except Exception as e:  # a corrupt cache is rebuilt
            log.warning("ignoring unreadable ICT identity cache %s (%s)", cfile, e)
    neutral = read_obj_vertices(folder / NEUTRAL)
    deltas = np.empty((len(files), *neutral.shape), np.float32)
    for k, f in enumerate(files):
        v = read_obj_vertices(f)
        if v.shape != neutral.shape:
            raise DataError(f"{f}: has {len(v)} vertices, expected {len(neutral)}")
        np.subtract(v, neutral, out=deltas[k])
    if cache:
        try:
            _write_atomic(cfile, {"deltas": deltas})
        except OSError as e:
            log.warning("could not write ICT identity cache %s: %s", cfile, e)
    return deltas


def with_identity(data: IctData, identity: Identity) -> IctData:
    """``data`` with the neutral mesh moved to an identity: vertices + Σₖ wₖ·δₖ (expression
    deltas unchanged — the ICT model adds them to any identity)."""
    w = identity_weights(identity)
    if w is None or not np.any(w):
        return data
    d = load_ict_identities(data.folder)
    v = data.vertices + np.tensordot(w.astype(np.float32), d, axes=1)
    return replace(data, vertices=v.astype(np.float32))


# -- head assembly ------------------------------------------------------------------------------


def _fit_sphere(p: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares sphere (centre (3,), radius) through points (N, 3)."""
    p = p.astype(np.float64)
    a = np.c_[2 * p, np.ones(len(p))]
    sol = np.linalg.lstsq(a, (p**2).sum(1), rcond=None)[0]
    c = sol[:3]
    return c, float(np.sqrt(sol[3] + c @ c))


def _inside_polygon(pts: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Even-odd test of points (N, 2) against a closed polygon (M, 2)."""
    x, y = pts[:, 0:1], pts[:, 1:2]
    x0, y0 = poly[:, 0], poly[:, 1]
    x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
    cross = (y0 > y) != (y1 > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xi = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
    return ((cross & (x < xi)).sum(1) % 2) == 1


def _object_faces(data: IctData, lo: int, hi: int, groups: tuple[str, ...] | None = None):
    f = data.faces
    keep = np.all((f >= lo) & (f < hi), axis=1)
    if groups is not None:
        gi = [data.groups.index(g) for g in groups if g in data.groups]
        keep &= np.isin(data.face_groups, gi)
    return f[keep] - lo


def build_head(data: IctData) -> Head:
    """Assemble the mimika :class:`Head` (objects, landmarks, anchors) from parsed ICT arrays."""
    v = data.vertices
    objs: list[MeshObject] = []

    # skin: face + head & neck, lips split off by the outer lip contour (landmarks 48-59)
    lo, hi = RANGES["skin"]
    sf = _object_faces(data, lo, hi)
    sv = v[lo:hi]
    cen = sv[sf].mean(1)
    lip_poly = sv[data.landmarks[48:60], :2]
    mouth_z = float(v[slice(*RANGES["mouth"])][:, 2].mean())
    lips = _inside_polygon(cen[:, :2], lip_poly) & (cen[:, 2] > mouth_z)
    objs.append(MeshObject("skin", "face", sv, (Part("skin", sf[~lips]), Part("lips", sf[lips])),
                           uvs=data.uvs[lo:hi]))

    for name, material, category in (
        ("mouth", "mouth", "face"),
        ("sockets", "socket", "face"),
        ("gums", "gums", "teeth"),
        ("teeth", "teeth", "teeth"),
    ):
        lo, hi = RANGES[name]
        objs.append(MeshObject(name, category, v[lo:hi],
                               (Part(material, _object_faces(data, lo, hi)),),
                               uvs=data.uvs[lo:hi]))

    anchors: dict[str, np.ndarray] = {}
    for name, side in (("eye_L", "Left"), ("eye_R", "Right")):
        lo, hi = RANGES[name]
        i0 = _IRIS_START[name] - lo
        ev = v[lo:hi]
        pivot, radius = _fit_sphere(ev[:i0])
        sclera = _object_faces(data, lo, hi, (f"M_Sclera{side}",))
        iris = _object_faces(data, lo, hi, (f"M_Iris{side}",))
        axis = ev[i0:].mean(0) - pivot
        axis /= np.linalg.norm(axis)

        def radial(p, pivot=pivot, axis=axis):
            d = p - pivot
            h = d @ axis
            return h, np.linalg.norm(d - h[:, None] * axis, axis=1)

        # The ICT eye is two shells: an outer one ("sclera" group, with the cornea bulge in
        # front) and an inner sphere ("iris" group) that carries the iris texture. Without
        # textures the iris is a disk: its radius is where the cornea bulges out of the
        # outer sphere (fallback: 0.42 of the eyeball radius).
        hs_v, rs_v = radial(ev[:i0])
        body = rs_v > 0.6 * radius
        c2, r2 = _fit_sphere(ev[:i0][body]) if body.sum() > 10 else (pivot, radius)
        excess = np.linalg.norm(ev[:i0] - c2, axis=1) - r2
        bulge = (hs_v > 0) & (excess > 0.02)
        r_iris = float(rs_v[bulge].max()) if bulge.sum() > 5 else 0.42 * radius
        if not 0.2 * radius < r_iris < 0.7 * radius:
            r_iris = 0.42 * radius
        hs, rs = radial(ev[sclera].mean(1))
        cornea = (hs > 0) & (rs < r_iris)
        hi_, ri_ = radial(ev[iris].mean(1))
        pupil = (hi_ > 0) & (ri_ < PUPIL_FRACTION * r_iris)
        disk = (hi_ > 0) & (ri_ < r_iris) & ~pupil
        inner_white = ~(pupil | disk)
        parts = (Part("sclera", np.concatenate([sclera[~cornea], iris[inner_white]])),
                 Part("cornea", sclera[cornea]), Part("iris", iris[disk]),
                 Part("pupil", iris[pupil]))
        objs.append(MeshObject(name, "eyes", ev, parts, pivot=pivot, uvs=data.uvs[lo:hi]))
        log.debug("%s: pivot %s, eyeball radius %.2f cm, iris radius %.2f cm", name, pivot,
                  radius, r_iris)
        anchors[name] = pivot

    # Lashes are strips meant for alpha-textured hair cards; drawn solid, the lower strips read
    # as grey bands under the eyes, so only the upper ones (above the eyeball centres) are drawn.
    lo, hi = RANGES["lashes"]
    lv = v[lo:hi]
    lf = _object_faces(data, lo, hi)
    upper = lv[lf].mean(1)[:, 1] > anchors["eye_L"][1]
    objs.append(MeshObject("lashes", "face", lv, (Part("lash", lf[upper]),), uvs=data.uvs[lo:hi]))

    lm = sv[data.landmarks]
    neck = v[9409:11248]
    bottom = neck[neck[:, 1] < neck[:, 1].min() + 1.0]
    ear_y = 0.5 * (lm[0, 1] + lm[16, 1])
    z_back, z_front = float(v[:11248, 2].min()), float(v[:11248, 2].max())
    anchors.update(
        mouth_corner_L=lm[54],
        mouth_corner_R=lm[48],
        chin=lm[8],
        neck_base=np.array([0.0, bottom[:, 1].mean(), bottom[:, 2].mean()]),
        # top of the spine: midline, ~2.5 cm below the ear / jaw-end level, back third
        neck_pivot=np.array([0.0, ear_y - 2.5, z_back + (z_front - z_back) / 3.0]),
    )
    return Head(
        name="ict",
        objects=tuple(objs),
        landmarks=data.landmarks,
        anchors=anchors,
        landmark_object="skin",
        description="ICT Face Model Light (ICT-FaceKit, MIT licence), generic neutral identity",
        meta={"source": str(data.folder), "ranges": dict(RANGES)},
    )


def object_deltas(data: IctData) -> ShapeSet:
    """The expression deltas sliced per head object: object name → (S, N, 3) float32."""
    return ShapeSet(
        names=data.shape_names,
        deltas={name: np.ascontiguousarray(data.deltas[:, lo:hi]) for name, (lo, hi) in
                RANGES.items()},
    )


def load_ict(path: str | os.PathLike | None = None,
             identity: Identity = None) -> tuple[Head, ShapeSet]:
    """The ICT :class:`Head` (optionally an ``identity``, see :func:`identity_weights`) and its
    expression shape deltas (cached parse)."""
    data = load_ict_data(path)
    return build_head(with_identity(data, identity)), object_deltas(data)


def load_ict_head(path: str | os.PathLike | None = None, identity: Identity = None) -> Head:
    """The ICT Face Model as a :class:`Head` (objects, 68 landmarks into ``skin``, anchors),
    optionally an ``identity`` (int 0–9 or mode weights, see :func:`identity_weights`)."""
    return build_head(with_identity(load_ict_data(path), identity))


def load_ict_rig(path: str | os.PathLike | None = None, identity: Identity = None) -> BlendshapeRig:
    """The ICT Face Model with the shipped ``ict_aus.json`` table; ``identity``: an identity
    mode 0–9 or mode weights (:func:`identity_weights`)."""
    head, shapes = load_ict(path, identity)
    return BlendshapeRig(head, shapes, load_table())
