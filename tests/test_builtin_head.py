"""The built-in procedural head: structure a user (and the AU rigs) rely on."""


import numpy as np
import pytest
from scipy.spatial import cKDTree

from mimika.errors import ParameterError
from mimika.face import Head
from mimika.face import meshgen as mg
from mimika.face.heads import builtin
from mimika.face.heads.builtin import build_builtin_head

RES = (0, 1, 2)


@pytest.fixture(scope="module")
def head() -> Head:
    return build_builtin_head()


def outer_faces(h: Head) -> np.ndarray:
    """Skin triangles that are not part of the pockets behind the openings."""
    f = h["skin"].faces
    n_outer = h.meta["regions"]["pockets"][0]
    return f[(f < n_outer).all(1)]


def test_objects_categories_and_materials(head):
    need = {
        "skin": ("face", {"skin", "lips", "mouth", "socket"}),
        "brows": ("face", {"brow"}),
        "eye_L": ("eyes", {"sclera", "iris", "pupil"}),
        "eye_R": ("eyes", {"sclera", "iris", "pupil"}),
        "teeth_upper": ("teeth", {"teeth"}),
        "teeth_lower": ("teeth", {"teeth"}),
        "tongue": ("teeth", {"tongue"}),
    }
    for name, (cat, mats) in need.items():
        o = head[name]
        assert o.category == cat
        assert mats <= {p.material for p in o.parts}, name
        assert all(len(p.faces) for p in o.parts)
        assert o.faces.max() < o.n_vertices and o.faces.min() >= 0
        assert np.isfinite(o.vertices).all()
    for side, sx in (("L", 1), ("R", -1)):
        eye = head[f"eye_{side}"]
        np.testing.assert_allclose(eye.pivot, [3.2 * sx, 3.6, 8.4], atol=1e-5)
        np.testing.assert_allclose(head.anchors[f"eye_{side}"], eye.pivot)


@pytest.mark.parametrize("res", RES)
def test_skin_is_a_closed_oriented_sphere(res):
    h = build_builtin_head(res)
    sk = h["skin"]
    f = sk.faces
    v = sk.vertices.astype(float)
    assert mg.is_oriented_manifold(f)
    assert len(mg.boundary_edges(f)) == 0  # openings lead into closed pockets
    n_edges = len(np.unique(np.sort(mg.directed_edges(f), 1), axis=0))
    assert sk.n_vertices - n_edges + len(f) == 2  # genus 0
    assert mg.signed_volume(v, f) > 4000  # outward: positive volume, cm^3
    for o in h.objects:
        if o.name != "skin":
            assert mg.is_oriented_manifold(o.faces), o.name
        if o.name not in ("skin", "brows"):  # closed, but for an eye's clear cornea cap
            closed = np.concatenate([p.faces for p in o.parts if p.material != "cornea"])
            assert len(mg.boundary_edges(closed)) == 0, o.name
            assert mg.signed_volume(o.vertices.astype(float), closed) > 0, o.name


def test_skull_normals_point_away_from_the_head_centre(head):
    sk = head["skin"]
    v = sk.vertices.astype(float)
    f = sk.faces
    c = v[f].mean(1)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    top = c[:, 1] > 9
    assert np.all(np.einsum("ij,ij->i", n[top], c[top] - [0, 5, 0]) > 0)


def test_openings_are_the_eyes_and_the_mouth(head):
    loops = mg.boundary_loops(outer_faces(head))
    assert len(loops) == 3
    R = head.meta["regions"]
    v = head["skin"].vertices
    sets = [set(map(int, lp)) for lp in loops]
    for key in ("lid_upper_margin_L", "lid_lower_margin_L", "eye_corners_L"):
        assert any(set(map(int, R[key])) <= s for s in sets), key
    for key in ("lip_upper_inner", "lip_lower_inner", "mouth_corners"):
        assert any(set(map(int, R[key])) <= s for s in sets), key
    # lips closed at rest but separate rows a hair apart, upper above lower
    up, lo = v[R["lip_upper_inner"]], v[R["lip_lower_inner"]]
    gap = np.linalg.norm(up - lo, axis=1)
    assert np.all(gap > 0) and np.all(gap < 0.05)
    assert np.all(up[:, 1] > lo[:, 1])


def test_scale_matches_the_ict_face_model(head):
    p = head.landmark_points()
    ict = {
        45: (4.46, 3.43, 8.6), 42: (1.84, 3.25, 9.2), 36: (-4.46, 3.43, 8.6),
        30: (0, 0.41, 13.07), 33: (0, -1.2, 11.57), 27: (0, 3.74, 10.73),
        54: (2.53, -3.52, 10.19), 48: (-2.53, -3.52, 10.19), 51: (0, -2.48, 11.84),
        57: (0, -4.38, 11.55), 8: (0, -7.57, 10.43), 24: (3.79, 6.26, 9.83),
        16: (7.36, 3.68, 3.66),
    }
    for i, q in ict.items():
        assert np.linalg.norm(p[i] - q) < 0.6, (i, p[i], q)
    lo, hi = head.bounds("face")
    assert 23 < hi[1] - p[8][1] < 25.5  # skull top to chin
    assert 14.5 < hi[0] - lo[0] < 17.5  # temples / widest
    assert lo[1] < -18.5  # the neck goes down
    assert np.linalg.norm(head.anchors["jaw_pivot"] - [0, 1.5, 2]) < 0.5
    assert np.linalg.norm(head.anchors["neck_pivot"] - [0, -3, 0]) < 1.0
    for a in ("mouth_corner_L", "mouth_corner_R", "eye_L", "eye_R", "chin", "neck_base",
              "neck_pivot", "nose_tip", "brow_L", "brow_R", "jaw_pivot"):
        assert head.anchors[a].shape == (3,)


def test_landmarks_sit_on_their_features(head):
    lm = head.landmarks
    assert lm.shape == (68,)
    n_outer = head.meta["regions"]["pockets"][0]
    assert lm.min() >= 0 and lm.max() < n_outer
    p = head.landmark_points()
    for r, left in ((0, 16), (1, 15), (4, 12), (17, 26), (21, 22), (36, 45), (39, 42),
                    (37, 44), (41, 46), (31, 35), (48, 54), (49, 53), (59, 55), (60, 64)):
        assert p[r, 0] < -0.5 and p[left, 0] > 0.5, (r, left)
        np.testing.assert_allclose(p[r], p[left] * [-1, 1, 1], atol=1e-4)
    for mid in (8, 27, 28, 29, 30, 33, 51, 57, 62, 66):
        assert abs(p[mid, 0]) < 1e-4
    assert p[37, 1] > p[41, 1] and p[38, 1] > p[40, 1]
    assert p[43, 1] > p[47, 1] and p[44, 1] > p[46, 1]
    assert p[27, 1] > p[28, 1] > p[29, 1] > p[30, 1]
    assert p[51, 1] > p[62, 1] >= p[66, 1] > p[57, 1]
    R = head.meta["regions"]
    assert {lm[37], lm[38]} <= set(R["lid_upper_margin_R"])
    assert {lm[40], lm[41]} <= set(R["lid_lower_margin_R"])
    assert {lm[43], lm[44]} <= set(R["lid_upper_margin_L"])
    assert {lm[46], lm[47]} <= set(R["lid_lower_margin_L"])
    assert set(lm[61:64]) <= set(R["lip_upper_inner"])
    assert set(lm[65:68]) <= set(R["lip_lower_inner"])
    assert lm[48] == lm[60] and lm[54] == lm[64]
    # jaw line runs round the chin, lowest at 8
    assert np.argmin(p[:17, 1]) == 8


def test_eyeballs_sit_in_their_sockets(head):
    sk = head["skin"]
    v = sk.vertices.astype(float)
    R = head.meta["regions"]
    for side in ("L", "R"):
        eye = head[f"eye_{side}"]
        c = eye.pivot.astype(float)
        radius = np.linalg.norm(eye.vertices - c, axis=1).max()
        assert 1.15 < radius < 1.25
        for key in (f"lid_upper_margin_{side}", f"lid_lower_margin_{side}"):
            d = np.linalg.norm(v[R[key]] - c, axis=1)
            assert d.min() > radius + 0.04, key  # closing the lid slides over the eyeball
        # the whole eyeball is in the socket cavity, not inside the head's solid
        wn = mg.winding_number(v, sk.faces, eye.vertices[::3].astype(float))
        assert np.all(wn < 0.5)
        # the iris faces forward
        iris = eye.vertices[np.unique(eye.parts[1].faces)] - c
        assert iris[:, 2].min() > 0.9


def test_teeth_and_tongue_sit_in_the_mouth_cavity(head):
    sk = head["skin"]
    v = sk.vertices.astype(float)
    lips_in = v[head.meta["regions"]["lip_upper_inner"]]
    for name in ("teeth_upper", "teeth_lower", "tongue"):
        o = head[name]
        wn = mg.winding_number(v, sk.faces, o.vertices[::3].astype(float))
        assert np.all(wn < 0.5), name
        assert o.vertices[:, 2].max() < lips_in[:, 2].max() - 0.3, name
    up, lo = head["teeth_upper"].vertices, head["teeth_lower"].vertices
    assert up[:, 1].min() < lo[:, 1].max()  # the bite overlaps a little
    assert up[:, 1].mean() > lo[:, 1].mean()


def test_brows_hug_the_skin_above_the_eyes(head):
    b = head["brows"].vertices.astype(float)
    d = builtin.shape().field(b)  # ~ signed distance to the skin surface
    assert d.max() < 0.2 and d.min() > -0.1
    assert b[:, 1].min() > head.anchors["eye_L"][1] + 1.0
    assert (b[:, 0] > 0).sum() == (b[:, 0] < 0).sum()


def _closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray):
    """Closest points on triangles (a, b, c) to points p (all shape (N, 3)); Ericson 5.1.5."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.einsum("ij,ij->i", ab, ap), np.einsum("ij,ij->i", ac, ap)
    bp = p - b
    d3, d4 = np.einsum("ij,ij->i", ab, bp), np.einsum("ij,ij->i", ac, bp)
    cp = p - c
    d5, d6 = np.einsum("ij,ij->i", ab, cp), np.einsum("ij,ij->i", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    den = np.where(np.abs(va + vb + vc) < 1e-20, 1e-20, va + vb + vc)
    v, w = vb / den, vc / den
    out = a + ab * v[:, None] + ac * w[:, None]  # interior
    with np.errstate(divide="ignore", invalid="ignore"):
        cases = [
            ((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0),
             b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))[:, None]),
            ((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + ac * (d2 / (d2 - d6))[:, None]),
            ((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + ab * (d1 / (d1 - d3))[:, None]),
            ((d6 >= 0) & (d5 <= d6), c),
            ((d3 >= 0) & (d4 <= d3), b),
            ((d1 <= 0) & (d2 <= 0), a),
        ]
    for m, q in cases:
        out = np.where(m[:, None], q, out)
    return out


def _distance_to_mesh(q: np.ndarray, v: np.ndarray, f: np.ndarray, k: int = 24) -> np.ndarray:
    tree = cKDTree(v[f].mean(1))
    _, cand = tree.query(q, k=k)
    best = np.full(len(q), np.inf)
    for j in range(k):
        t = f[cand[:, j]]
        cp = _closest_on_triangles(q, v[t[:, 0]], v[t[:, 1]], v[t[:, 2]])
        best = np.minimum(best, np.linalg.norm(cp - q, axis=1))
    return best


def test_resolutions_sample_the_same_surface():
    fine = build_builtin_head(2)
    fv = fine["skin"].vertices.astype(float)
    ff = outer_faces(fine)
    for res in (0, 1):
        h = build_builtin_head(res)
        n_outer = h.meta["regions"]["pockets"][0]
        d = _distance_to_mesh(h["skin"].vertices[:n_outer].astype(float), fv, ff)
        assert np.percentile(d, 99) < 0.05, (res, np.percentile(d, 99))
        assert d.max() < 0.1, res
        # features and anchors stay put across resolutions
        for a in ("mouth_corner_L", "eye_L", "nose_tip", "chin", "brow_L"):
            assert np.linalg.norm(h.anchors[a] - fine.anchors[a]) < 0.35, (res, a)
        tol = 0.7 if res == 0 else 0.4  # about the local vertex spacing
        d = np.linalg.norm(h.landmark_points() - fine.landmark_points(), axis=1)
        assert d.max() < tol, (res, int(np.argmax(d)), d.max())


def test_triangle_budget_and_density():
    n = {r: build_builtin_head(r) for r in RES}
    assert n[1].n_triangles <= 25_500  # the eyes with their clear corneas
    s0 = n[0]["skin"].n_vertices / n[1]["skin"].n_vertices
    s2 = n[2]["skin"].n_vertices / n[1]["skin"].n_vertices
    assert 0.35 < s0 < 0.7
    assert 1.6 < s2 < 2.6


def test_deterministic_and_cached():
    a = build_builtin_head(1)
    assert build_builtin_head(1) is a
    build_builtin_head.cache_clear()
    b = build_builtin_head(1)
    assert b is not a
    for oa, ob in zip(a.objects, b.objects, strict=True):
        np.testing.assert_array_equal(oa.vertices, ob.vertices)
        for pa, pb in zip(oa.parts, ob.parts, strict=True):
            np.testing.assert_array_equal(pa.faces, pb.faces)
    np.testing.assert_array_equal(a.landmarks, b.landmarks)


def test_rejects_unknown_resolution():
    with pytest.raises(ParameterError, match="resolution"):
        build_builtin_head(3)
    assert builtin.RESOLUTIONS == RES
