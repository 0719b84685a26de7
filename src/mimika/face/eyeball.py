"""An eyeball mesh: sclera, a flattened slightly concave iris disc, the pupil, and optionally a
clear cornea shell in front of the iris (for the wet highlight)."""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import numpy as np

from mimika.face import meshgen as mg
from mimika.face.head import MeshObject, Part


def _cap_faces(rings: list[np.ndarray], first: int, last: int | None) -> list[np.ndarray]:
    nl = len(rings[0])
    faces = [np.stack([rings[0], np.roll(rings[0], -1), np.full(nl, first)], 1)]
    for r0, r1 in itertools.pairwise(rings):
        faces.append(np.concatenate([np.stack([r0, r1, np.roll(r1, -1)], 1),
                                     np.stack([r0, np.roll(r1, -1), np.roll(r0, -1)], 1)]))
    if last is not None:
        faces.append(np.stack([rings[-1], np.full(nl, last), np.roll(rings[-1], -1)], 1))
    return faces


def eyeball_object(name: str, centre: Sequence[float], radius: float, *, pupil_radius: float,
                   iris_radius: float, iris_depth: float = 0.0,
                   rings: tuple[int, int, int] = (2, 3, 12), n_lon: int = 24,
                   cornea: float = 0.0) -> MeshObject:
    """An eyeball looking toward +z, centred at ``centre`` (its rotation pivot), in cm.

    ``rings``: latitude rings over the pupil, the iris and the sclera. ``cornea`` > 0 adds a
    clear cap over the iris bulging that far (cm) in front of the eyeball (material ``cornea``).
    UVs are the front projection ((x, y) / (2·radius) + 0.5), so an iris texture is a disc.
    """
    R = float(radius)
    c = np.asarray(centre, float)
    th_p = np.arcsin(pupil_radius / R)
    th_i = np.arcsin(iris_radius / R)
    n_p, n_i, n_s = rings
    th = np.concatenate([np.linspace(0, th_p, n_p + 1)[1:], np.linspace(th_p, th_i, n_i + 1)[1:],
                         np.linspace(th_i, np.pi, n_s + 1)[1:-1]])
    ph = np.linspace(0, 2 * np.pi, n_lon, endpoint=False)
    TH, PH = np.meshgrid(th, ph, indexing="ij")
    rho = R * np.sin(TH)
    z = R * np.cos(TH)
    zi = R * np.cos(th_i) - iris_depth * (1 - (rho / (R * np.sin(th_i))) ** 2)
    z = np.where(th_i + 1e-9 >= TH, zi, z)
    pts = np.stack([rho * np.cos(PH), rho * np.sin(PH), z], -1).reshape(-1, 3)
    front = np.array([[0, 0, R * np.cos(th_i) - iris_depth]])
    back = np.array([[0, 0, -R]])
    v = np.concatenate([front, pts, back])
    ring_ids = [1 + k * n_lon + np.arange(n_lon) for k in range(len(th))]
    faces = _cap_faces(ring_ids, 0, len(v) - 1)
    if mg.signed_volume(v, np.concatenate(faces)) < 0:
        faces = [f[:, ::-1] for f in faces]
    parts = [Part("sclera", np.concatenate(faces[n_p + n_i:])),
             Part("iris", np.concatenate(faces[n_p:n_p + n_i])),
             Part("pupil", np.concatenate(faces[:n_p]))]
    if cornea > 0:
        # a clear spherical cap from just outside the limbus to ``cornea`` in front of it
        r_l, z0 = 1.04 * R * np.sin(th_i), R * np.cos(th_i) + 0.005
        rc = (r_l ** 2 + cornea ** 2) / (2 * cornea)  # the cap's sphere through ring and apex
        zc = z0 + cornea - rc
        alphas = np.arcsin(r_l / rc) * np.linspace(1, 0, 5)[:-1]
        dv = np.concatenate([np.c_[rc * np.sin(a) * np.cos(ph), rc * np.sin(a) * np.sin(ph),
                                   np.full(n_lon, zc + rc * np.cos(a))] for a in alphas]
                            + [[[0.0, 0.0, z0 + cornea]]])
        ids = [len(v) + k * n_lon + np.arange(n_lon) for k in range(len(alphas))]
        cf = np.concatenate(_cap_faces(ids[::-1], len(v) + len(dv) - 1, None))
        v = np.concatenate([v, dv])
        n = np.cross(v[cf[:, 1]] - v[cf[:, 0]], v[cf[:, 2]] - v[cf[:, 0]])
        parts.append(Part("cornea", cf if n[:, 2].sum() > 0 else cf[:, ::-1]))
    uv = (v[:, :2] / (2 * R) + 0.5).astype(np.float32)
    return MeshObject(name, "eyes", v + c, tuple(parts), pivot=c, uvs=uv)
