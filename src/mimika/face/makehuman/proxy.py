"""MakeHuman proxies (``.mhclo``): clothes, hair, brows, lashes, teeth fitted to the base mesh.

Each proxy vertex is bound either rigidly to one base vertex or to a base triangle by three
barycentric weights plus an offset (``d1 d2 d3``) scaled per axis by the base mesh's current
size: ``s_axis = |v_a[axis] − v_b[axis]| / den`` from the ``x_scale``/``y_scale``/``z_scale``
lines. Fitting is linear in the base vertices, so a proxy follows any deformation of the body
(phenotype, faceunits, skinning) through one sparse matrix; only the offset term depends on
the body's scale, which is measured once on the shaped body at rest.
``delete_verts`` lists base vertices the proxy hides (body under a suit).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from mimika.errors import DataError
from mimika.io.obj import ObjMesh, read_obj


@dataclass(frozen=True)
class Proxy:
    """A parsed ``.mhclo`` file and its ``.obj`` (topology and UVs)."""

    name: str
    path: Path
    refs: np.ndarray  #: (P, 3) int64 base vertex indices (rigid: the same index three times)
    weights: np.ndarray  #: (P, 3) float64
    offsets: np.ndarray  #: (P, 3) float64, in units of the per-axis scales
    scales: tuple[tuple[int, int, float], ...]  #: (vertex a, vertex b, den) for x, y, z
    delete_verts: np.ndarray  #: base vertex indices hidden under the proxy
    mesh: ObjMesh
    material: str = ""  #: the ``.mhmat`` file named in the header
    z_depth: int = 50

    @property
    def n_vertices(self) -> int:
        return len(self.refs)

    def binding(self, n_base: int) -> sp.csr_matrix:
        """The sparse (P, n_base) matrix of barycentric weights."""
        rows = np.repeat(np.arange(self.n_vertices), 3)
        return sp.csr_matrix((self.weights.ravel(), (rows, self.refs.ravel())),
                             shape=(self.n_vertices, n_base))

    def offset_vectors(self, base: np.ndarray) -> np.ndarray:
        """The scaled offsets (P, 3) on a base mesh at ``base`` (N, 3)."""
        s = np.array([abs(float(base[a, k]) - float(base[b, k])) / den
                      for k, (a, b, den) in enumerate(self.scales)])
        return self.offsets * s

    def fit(self, base: np.ndarray) -> np.ndarray:
        """Proxy vertex positions (P, 3) float32 on ``base`` (N, 3)."""
        b = np.asarray(base, np.float64)
        pos = (self.weights[:, :, None] * b[self.refs]).sum(1) + self.offset_vectors(b)
        return pos.astype(np.float32)


def _ranges(tokens: list[str], where: str) -> list[int]:
    """``["3", "5", "-", "9"]`` → [3, 5, 6, 7, 8, 9] (MakeHuman's ``a - b`` ranges)."""
    out: list[int] = []
    i = 0
    try:
        while i < len(tokens):
            if i + 2 < len(tokens) and tokens[i + 1] == "-":
                out.extend(range(int(tokens[i]), int(tokens[i + 2]) + 1))
                i += 3
            else:
                out.append(int(tokens[i]))
                i += 1
    except ValueError:
        raise DataError(f"{where}: delete_verts must list vertex numbers and 'a - b' ranges"
                        ) from None
    return out


def read_mhclo(path: str | Path) -> Proxy:
    """Parse ``path`` (``.mhclo``) and the ``.obj`` it names."""
    p = Path(path)
    try:
        lines = p.read_text("utf-8", "replace").splitlines()
    except OSError as e:
        raise DataError(f"cannot read proxy file {p}: {e.strerror}") from None
    head: dict[str, str] = {}
    scales: dict[str, tuple[int, int, float]] = {}
    refs, weights, offsets, deleted = [], [], [], []
    section = ""
    for no, raw in enumerate(lines, 1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        tok = line.split()
        if tok[0] == "verts":
            section = "verts"
            continue
        if tok[0] == "delete_verts":
            section = "delete"
            continue
        if section == "verts" and tok[0].lstrip("-").isdigit():
            try:
                nums = [float(t) for t in tok]
            except ValueError:
                raise DataError(f"{p}, line {no}: expected numbers") from None
            if len(nums) == 1:
                refs.append([int(nums[0])] * 3)
                weights.append([1.0, 0.0, 0.0])
                offsets.append([0.0, 0.0, 0.0])
            elif len(nums) >= 9:
                refs.append([int(x) for x in nums[:3]])
                weights.append(nums[3:6])
                offsets.append(nums[6:9])
            else:
                raise DataError(f"{p}, line {no}: a vertex binding has 1 or 9 numbers, "
                                f"got {len(nums)}")
            continue
        if section == "delete" and (tok[0].isdigit() or tok[0] == "-"):
            deleted += _ranges(tok, f"{p}, line {no}")
            continue
        if tok[0] in ("x_scale", "y_scale", "z_scale") and len(tok) == 4:
            scales[tok[0][0]] = (int(tok[1]), int(tok[2]), float(tok[3]))
        elif len(tok) >= 2:
            head.setdefault(tok[0], " ".join(tok[1:]))
    if not refs:
        raise DataError(f"{p}: no vertex bindings (no 'verts 0' section)")
    missing = [a for a in "xyz" if a not in scales]
    if missing:
        raise DataError(f"{p}: missing {', '.join(a + '_scale' for a in missing)} line")
    obj = p.with_name(head.get("obj_file", p.stem + ".obj"))
    mesh = read_obj(obj)
    if len(mesh.vertices) != len(refs):
        raise DataError(f"{p}: {len(refs)} vertex bindings but {obj.name} has "
                        f"{len(mesh.vertices)} vertices")
    return Proxy(
        name=head.get("name", p.stem), path=p,
        refs=np.asarray(refs, np.int64), weights=np.asarray(weights, np.float64),
        offsets=np.asarray(offsets, np.float64),
        scales=tuple(scales[a] for a in "xyz"),
        delete_verts=np.unique(np.asarray(deleted, np.int64)), mesh=mesh,
        material=head.get("material", ""), z_depth=int(float(head.get("z_depth", 50))),
    )
