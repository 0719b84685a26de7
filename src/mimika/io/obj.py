"""Wavefront OBJ reading: vertices, texture coordinates, faces and ``usemtl`` groups.

Parsing is vectorised: lines are classified once, then all numbers of one kind are converted
by a single numpy call. Only when that fast path fails does a line-by-line pass run, to report
the first bad line (1-based) in a :class:`~mimika.errors.DataError`.
"""

from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mimika.errors import DataError

log = logging.getLogger(__name__)

__all__ = ["ObjMesh", "read_obj", "read_obj_vertices"]


@dataclass(frozen=True)
class ObjMesh:
    """A parsed OBJ file; polygons are fan-triangulated.

    Attributes
    ----------
    vertices : (N, 3) float32
    faces : (F, 3) int32, 0-based vertex indices, counter-clockwise as in the file
    uvs : (M, 2) float32 texture coordinates or None when the file has no ``vt``
    face_uvs : (F, 3) int32 indices into ``uvs`` per triangle corner, or None
    face_groups : (F,) int32, index into ``groups`` of each triangle's ``usemtl`` material
    groups : material names in order of first use (``"default"`` for faces before any usemtl)
    """

    vertices: np.ndarray
    faces: np.ndarray
    uvs: np.ndarray | None
    face_uvs: np.ndarray | None
    face_groups: np.ndarray
    groups: tuple[str, ...]

    def group_faces(self, name: str) -> np.ndarray:
        """Triangles of material group ``name``, shape (F_g, 3)."""
        return self.faces[self.face_groups == self.groups.index(name)]

    def vertex_uvs(self) -> np.ndarray | None:
        """One texture coordinate per vertex, shape (N, 2) (first corner wins at UV seams)."""
        if self.uvs is None or self.face_uvs is None:
            return None
        out = np.zeros((len(self.vertices), 2), np.float32)
        v = self.faces.ravel()[::-1]  # reversed so that the first occurrence is written last
        t = self.face_uvs.ravel()[::-1]
        out[v] = self.uvs[t]
        return out


# -- helpers ------------------------------------------------------------------------------------


def _read_lines(path: Path) -> list[bytes]:
    try:
        data = path.read_bytes()
    except OSError as e:
        raise DataError(f"cannot read OBJ file {path}: {e.strerror or e}") from e
    return data.splitlines()


def _fail(path: Path, lineno: int, msg: str) -> DataError:
    return DataError(f"{path}, line {lineno}: {msg}")


def _fast_floats(chunks: list[bytes], count: int) -> np.ndarray | None:
    """Parse ``count`` numbers from the joined chunks, or None if anything is off."""
    if not chunks:
        return np.zeros(0, np.float64)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            arr = np.fromstring(b" ".join(chunks), dtype=np.float64, sep=" ")
        except (ValueError, DeprecationWarning):
            return None
    if arr.size != count or not np.all(np.isfinite(arr)):
        return None
    return arr


def _slow_floats(path: Path, lines: list[bytes], idx: list[int], n: int, what: str) -> None:
    """Find and raise on the first line of ``idx`` that does not hold ``n`` numbers."""
    for i in idx:
        toks = lines[i].split()[1:]
        if len(toks) < n:
            raise _fail(path, i + 1, f"expected {n} numbers ({what}), got {len(toks)}")
        for t in toks[:n]:
            try:
                x = float(t)
            except ValueError:
                got = t.decode(errors="replace")
                raise _fail(path, i + 1, f"expected a number ({what}), got {got!r}") from None
            if not np.isfinite(x):
                raise _fail(path, i + 1, f"expected a finite number ({what}), got {x}")
    raise DataError(f"{path}: could not parse {what} lines")  # pragma: no cover


def _parse_coords(path: Path, lines: list[bytes], idx: list[int], n: int, what: str) -> np.ndarray:
    """The first ``n`` numbers of each line in ``idx`` as (len(idx), n) float32."""
    chunks = [lines[i][2:] for i in idx]
    arr = _fast_floats(chunks, n * len(idx))
    if arr is None:
        # extra components (``v x y z w``, vertex colours, ``vt u v w``): per-line trim
        trimmed = []
        for i in idx:
            toks = lines[i].split()[1:]
            if len(toks) < n:
                raise _fail(path, i + 1, f"expected {n} numbers ({what}), got {len(toks)}")
            trimmed.append(b" ".join(toks[:n]))
        arr = _fast_floats(trimmed, n * len(idx))
        if arr is None:
            _slow_floats(path, lines, idx, n, what)
    return arr.reshape(len(idx), n).astype(np.float32)


# -- public API ---------------------------------------------------------------------------------


def read_obj_vertices(path: str | Path) -> np.ndarray:
    """Only the ``v`` lines of an OBJ file, shape (N, 3) float32 (for blendshape targets)."""
    path = Path(path)
    lines = _read_lines(path)
    idx = [i for i, ln in enumerate(lines) if ln[:2] == b"v "]
    if not idx:
        raise DataError(f"{path}: no vertices ('v x y z' lines) found")
    return _parse_coords(path, lines, idx, 3, "vertex x y z")


def read_obj(path: str | Path) -> ObjMesh:
    """Parse ``v``, ``vt``, ``f`` and ``usemtl`` of an OBJ file; other statements are ignored.

    Faces may be ``a``, ``a/t``, ``a//n`` or ``a/t/n`` with 1-based or negative (relative)
    indices; polygons are fan-triangulated. Raises :class:`DataError` naming the file and
    line for bad numbers, out-of-range indices and faces with fewer than 3 corners.
    """
    path = Path(path)
    lines = _read_lines(path)
    v_idx: list[int] = []
    vt_idx: list[int] = []
    f_idx: list[int] = []
    f_group: list[int] = []
    groups: list[str] = []
    current = -1
    ignored = (b"#", b"vn", b"vp", b"o", b"g", b"s", b"mtllib", b"l", b"p", b"cstype", b"deg",
               b"curv", b"surf", b"parm", b"end", b"usemap", b"lod", b"bevel", b"shadow_obj",
               b"trace_obj", b"c_interp", b"d_interp", b"maplib", b"call", b"csh")
    for i, ln in enumerate(lines):
        head = ln[:2]
        if head == b"v ":
            v_idx.append(i)
        elif head == b"f ":
            if current < 0:
                groups.append("default")
                current = len(groups) - 1
            f_idx.append(i)
            f_group.append(current)
        elif head == b"vt" and ln[2:3] == b" ":
            vt_idx.append(i)
        else:
            toks = ln.split(None, 1)
            if not toks:
                continue
            key = toks[0]
            if key == b"usemtl":
                name = toks[1].strip().decode("utf-8", "replace") if len(toks) > 1 else ""
                if not name:
                    raise _fail(path, i + 1, "expected a material name after 'usemtl'")
                if name not in groups:
                    groups.append(name)
                current = groups.index(name)
            elif key in (b"v", b"f", b"vt"):  # tab-separated forms: rare, take the slow way
                raise _fail(path, i + 1, f"expected a single space after {key.decode()!r}")
            elif key.startswith(b"#") or key in ignored:
                continue
            else:
                raise _fail(
                    path, i + 1,
                    f"expected an OBJ statement (v, vt, f, usemtl …), "
                    f"got {ln[:40].decode('utf-8', 'replace')!r}",
                )
    if not v_idx:
        raise DataError(f"{path}: no vertices ('v x y z' lines) found")
    verts = _parse_coords(path, lines, v_idx, 3, "vertex x y z")
    uvs = _parse_coords(path, lines, vt_idx, 2, "texture u v") if vt_idx else None
    faces, face_uvs, fg = _parse_faces(path, lines, f_idx, np.asarray(f_group, np.int32),
                                       np.asarray(v_idx), np.asarray(vt_idx))
    if face_uvs is not None and uvs is None:
        face_uvs = None
    log.debug("read %s: %d vertices, %d triangles, groups %s", path, len(verts), len(faces),
              groups)
    return ObjMesh(verts, faces, uvs, face_uvs, fg, tuple(groups))


def _face_tokens_fast(lines: list[bytes], f_idx: list[int]) -> tuple[np.ndarray, np.ndarray] | None:
    """(corners (C, fields) int64, corners-per-face (F,)) if all faces share one index form."""
    bodies = [lines[i][2:].split() for i in f_idx]
    counts = np.fromiter((len(b) for b in bodies), np.int64, len(bodies))
    if not bodies[0]:
        return None
    first = bodies[0][0]
    dbl = b"//" in first
    fields = 2 if dbl else first.count(b"/") + 1
    joined = b" ".join(b" ".join(b) for b in bodies)
    n_corners = int(counts.sum())
    n_slash = joined.count(b"/")
    if dbl:
        if joined.count(b"//") != n_corners or n_slash != 2 * n_corners:
            return None
        joined = joined.replace(b"//", b" ")
    elif fields > 1:
        if b"//" in joined or n_slash != n_corners * (fields - 1):
            return None
        joined = joined.replace(b"/", b" ")
    elif n_slash:
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            arr = np.fromstring(joined, dtype=np.int64, sep=" ")
        except (ValueError, DeprecationWarning):
            return None
    if arr.size != n_corners * fields:
        return None
    return arr.reshape(n_corners, fields), counts


def _face_tokens_slow(
    path: Path, lines: list[bytes], f_idx: list[int]
) -> tuple[np.ndarray, np.ndarray]:
    """Per-token parse (mixed forms or errors); returns (corners (C, 2) [v, vt or 0], counts)."""
    rows: list[tuple[int, int]] = []
    counts = []
    for i in f_idx:
        toks = lines[i].split()[1:]
        for t in toks:
            parts = t.split(b"/")
            try:
                vi = int(parts[0])
                ti = int(parts[1]) if len(parts) > 1 and parts[1] else 0
                if len(parts) > 2 and parts[2]:
                    int(parts[2])
                if len(parts) > 3:
                    raise ValueError
            except ValueError:
                raise _fail(
                    path, i + 1,
                    f"expected face corners 'v', 'v/t', 'v//n' or 'v/t/n' with integer "
                    f"indices, got {t.decode('utf-8', 'replace')!r}",
                ) from None
            rows.append((vi, ti))
        counts.append(len(toks))
    return np.asarray(rows, np.int64).reshape(-1, 2), np.asarray(counts, np.int64)


def _parse_faces(path, lines, f_idx, f_group, v_lines, vt_lines):
    if not f_idx:
        return np.zeros((0, 3), np.int32), None, np.zeros(0, np.int32)
    fast = _face_tokens_fast(lines, f_idx)
    if fast is not None:
        corners, counts = fast
        has_t = corners.shape[1] >= 2 and b"//" not in lines[f_idx[0]]
        vi = corners[:, 0]
        ti = corners[:, 1] if has_t else None
    else:
        corners, counts = _face_tokens_slow(path, lines, f_idx)
        vi = corners[:, 0]
        ti = corners[:, 1] if np.any(corners[:, 1] != 0) else None
    f_lines = np.asarray(f_idx)
    bad = np.flatnonzero(counts < 3)
    if bad.size:
        i = f_lines[bad[0]]
        raise _fail(path, i + 1, f"expected a face with at least 3 corners, got {counts[bad[0]]}")
    face_of_corner = np.repeat(np.arange(len(counts)), counts)
    vi = _resolve(path, vi, f_lines, face_of_corner, v_lines, "vertex")
    if ti is not None:
        ti = _resolve(path, ti, f_lines, face_of_corner, vt_lines, "texture coordinate")
    # fan triangulation: corners (0, j, j+1), j = 1 … k-2
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    n_tri = counts - 2
    tri_face = np.repeat(np.arange(len(counts)), n_tri)
    j = np.arange(n_tri.sum()) - np.repeat(np.cumsum(n_tri) - n_tri, n_tri) + 1
    s = starts[tri_face]
    corner_ids = np.stack([s, s + j, s + j + 1], axis=1)
    faces = vi[corner_ids].astype(np.int32)
    face_uvs = ti[corner_ids].astype(np.int32) if ti is not None else None
    return faces, face_uvs, f_group[tri_face]


def _resolve(path, idx, f_lines, face_of_corner, def_lines, what):
    """1-based / negative OBJ indices → 0-based; raise on 0 or out of range."""
    n_total = len(def_lines)
    out = idx - 1
    neg = idx < 0
    if np.any(neg):
        # relative to the elements defined before that face's line
        before = np.searchsorted(def_lines, f_lines[face_of_corner[neg]])
        out[neg] = before + idx[neg]
    bad = np.flatnonzero((idx == 0) | (out < 0) | (out >= n_total))
    if bad.size:
        k = bad[0]
        line = int(f_lines[face_of_corner[k]]) + 1
        raise _fail(
            path, line,
            f"{what} index {int(idx[k])} is out of range; expected 1 … {n_total} "
            f"(or a negative relative index)",
        )
    return out
