"""The ICT Face Model head and its BlendshapeRig: loading, caching, AU semantics, batches."""

import os
from pathlib import Path

import numpy as np
import pytest

from mimika.errors import DataError, ParameterError
from mimika.face.ict import find_ict_dir
from mimika.facs import SEED_AUS

ICT = os.environ.get("MIMIKA_ICT_DIR")
needs_ict = pytest.mark.skipif(
    not ICT or not Path(ICT).exists(),
    reason="MIMIKA_ICT_DIR not set or absent: the ICT Face Model is not available",
)

# Multi-PIE landmark ids (subject's right = −x side first)
BROW_OUT, BROW_MID, BROW_IN = [17, 26], [19, 24], [21, 22]
UPPER_LID, LOWER_LID = [37, 38, 43, 44], [41, 40, 47, 46]  # paired top/bottom
NOSE_TIP, NOSTRIL_WINGS, CHIN = 30, [31, 35], 8
CORNER_R, CORNER_L = 48, 54
UPPER_LIP, LOWER_LIP = [50, 51, 52], [56, 57, 58]
IN_UP, IN_LO = 62, 66
MIN = 0.08  # cm


# -- no data needed -----------------------------------------------------------------------------


def test_find_ict_dir_error_says_where_and_how(tmp_path, monkeypatch):
    with pytest.raises(DataError) as e:
        find_ict_dir(tmp_path)
    msg = str(e.value)
    assert "ICT Face Model was not found" in msg and str(tmp_path) in msg
    assert "git clone https://github.com/ICT-VGL/ICT-FaceKit" in msg and "MIMIKA_ICT_DIR" in msg
    monkeypatch.delenv("MIMIKA_ICT_DIR", raising=False)
    with pytest.raises(DataError, match="MIMIKA_ICT_DIR is not set"):
        find_ict_dir()
    monkeypatch.setenv("MIMIKA_ICT_DIR", str(tmp_path / "missing"))
    with pytest.raises(DataError, match="missing"):
        find_ict_dir()


def test_find_ict_dir_accepts_root_or_facexmodel(tmp_path):
    fx = tmp_path / "FaceXModel"
    fx.mkdir()
    (fx / "generic_neutral_mesh.obj").write_text("v 0 0 0\n")
    assert find_ict_dir(tmp_path) == fx.resolve()
    assert find_ict_dir(fx) == fx.resolve()


# -- with the ICT data --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    if not ICT or not Path(ICT).exists():
        pytest.skip("MIMIKA_ICT_DIR not set or absent: the ICT Face Model is not available")
    from mimika.face.blendshape import load_ict_rig

    return load_ict_rig()


def lms(rig, aus):
    pos = rig.deform(aus)
    return rig.head.landmark_points(pos), pos


def lip_gap(L):
    return L[IN_UP, 1] - L[IN_LO, 1]  # grows when the lips part


def lip_height(L):
    return (L[51, 1] - L[IN_UP, 1]) + (L[IN_LO, 1] - L[57, 1])


def lid_gap(L):
    return L[UPPER_LID, 1] - L[LOWER_LID, 1]


def iris_centre(rig, pos, name):
    obj = rig.head[name]
    idx = np.unique(np.concatenate([p.faces.ravel() for p in obj.parts
                                    if p.material in ("iris", "pupil")]))
    return pos[name][idx].mean(0)


def lower_teeth_dy(rig, pos):
    rest = rig.head["teeth"].vertices
    low = rest[:, 1] < np.quantile(rest[:, 1], 0.3)
    return (pos["teeth"][low, 1] - rest[low, 1]).mean()


@pytest.mark.ict
@needs_ict
def test_head_layout(rig):
    h = rig.head
    names = [o.name for o in h.objects]
    assert names == ["skin", "mouth", "sockets", "gums", "teeth", "eye_L", "eye_R", "lashes"]
    assert h["skin"].n_vertices == 11248 and h["eye_L"].n_vertices == 1570
    assert {p.material for p in h["skin"].parts} == {"skin", "lips"}
    assert {p.material for p in h["eye_L"].parts} == {"sclera", "cornea", "iris", "pupil"}
    assert len(h.landmarks) == 68
    L = h.landmark_points()
    assert L[CORNER_L, 0] > 2 > -2 > L[CORNER_R, 0]
    a = h.anchors
    assert a["eye_L"][0] > 2 and a["eye_R"][0] < -2  # +x = subject's left
    np.testing.assert_allclose(a["eye_L"], h["eye_L"].pivot)
    assert a["neck_base"][1] < a["chin"][1] < a["neck_pivot"][1] < a["eye_L"][1]
    for o in h.objects:
        f = o.faces
        assert f.min() >= 0 and f.max() < o.n_vertices
    # lips are a band around the mouth, in front
    lips = h["skin"].vertices[np.unique(h["skin"].parts[1].faces)]
    assert len(lips) > 300 and np.abs(lips[:, 0]).max() < 3.5 and lips[:, 2].min() > 8


@pytest.mark.ict
@needs_ict
def test_rest_is_neutral_and_outputs_every_object(rig):
    pos = rig.deform({})
    assert set(pos) == {o.name for o in rig.head.objects}
    for o in rig.head.objects:
        assert pos[o.name].dtype == np.float32 and pos[o.name].shape == o.vertices.shape
        np.testing.assert_array_equal(pos[o.name], o.vertices)


def check(rig, code):
    L0, rest = lms(rig, {})
    L, pos = lms(rig, {code: 1.0})
    d = L - L0
    dx, dy, dz = d[:, 0], d[:, 1], d[:, 2]
    match code:
        case "AU01":
            assert dy[BROW_IN].min() > MIN and dy[BROW_IN].mean() > dy[BROW_OUT].mean()
        case "AU02":
            assert dy[BROW_OUT].min() > MIN and dy[BROW_OUT].mean() > dy[BROW_IN].mean()
        case "AU04":
            assert dy[BROW_MID].max() < -MIN
            assert L[22, 0] - L[21, 0] < L0[22, 0] - L0[21, 0] - 0.05
        case "AU05":
            assert dy[UPPER_LID].min() > MIN / 2
        case "AU06" | "AU07":
            assert dy[LOWER_LID].min() > MIN / 2
        case "AU09":
            assert dy[NOSTRIL_WINGS].min() > MIN
        case "AU10":
            assert dy[UPPER_LIP].min() > MIN and dy[UPPER_LIP].mean() > dy[LOWER_LIP].mean() + MIN
        case "AU12":
            assert dy[[CORNER_R, CORNER_L]].min() > MIN
            assert dx[CORNER_L] > MIN and dx[CORNER_R] < -MIN
        case "AU15":
            assert dy[[CORNER_R, CORNER_L]].max() < -MIN
        case "AU16":
            assert dy[LOWER_LIP].max() < -MIN and dy[LOWER_LIP].mean() < dy[UPPER_LIP].mean()
        case "AU17":
            assert dy[[CHIN, 57]].min() > MIN / 2
        case "AU18" | "AU22":
            assert dz[[51, 57]].min() > MIN / 2
            assert dx[CORNER_L] < -MIN and dx[CORNER_R] > MIN
        case "AU20":
            assert dx[CORNER_L] > MIN and dx[CORNER_R] < -MIN
        case "AU23" | "AU24":
            assert lip_height(L) < lip_height(L0) - MIN
            assert lip_gap(L) <= lip_gap(L0) + 0.02
        case "AU25":
            assert lip_gap(L) > lip_gap(L0) + 2 * MIN
            assert abs(lower_teeth_dy(rig, pos)) < 0.6  # jaw nearly still
        case "AU26" | "AU27":
            assert lip_gap(L) > lip_gap(L0) + 4 * MIN
            assert dy[CHIN] < -MIN and lower_teeth_dy(rig, pos) < -MIN
            if code == "AU27":
                L26, p26 = lms(rig, {"AU26": 1.0})
                assert lip_gap(L) > lip_gap(L26) + MIN
                assert lower_teeth_dy(rig, pos) < lower_teeth_dy(rig, p26) - MIN
        case "AU28":
            assert lip_height(L) < lip_height(L0) - 4 * MIN
        case "AU43":
            assert lid_gap(L0).mean() > 0.4 and np.all(np.abs(lid_gap(L)) < 0.1)
        case "AU51" | "AU52":
            assert dx[NOSE_TIP] * (1 if code == "AU51" else -1) > 1.0
        case "AU53" | "AU54":
            assert dy[NOSE_TIP] * (1 if code == "AU53" else -1) > 1.0
        case "AU55" | "AU56":
            top = np.argmax(rest["skin"][:, 1])
            shift = pos["skin"][top, 0] - rest["skin"][top, 0]
            assert shift * (1 if code == "AU55" else -1) > 1.0
        case "AU61" | "AU62" | "AU63" | "AU64":
            axis, sign = {"AU61": (0, 1), "AU62": (0, -1), "AU63": (1, 1), "AU64": (1, -1)}[code]
            for eye in ("eye_L", "eye_R"):
                move = iris_centre(rig, pos, eye) - iris_centre(rig, rest, eye)
                assert move[axis] * sign > 0.2
                # rigid rotation about the pivot: distances to it are kept
                pv = rig.head[eye].pivot
                np.testing.assert_allclose(np.linalg.norm(pos[eye] - pv, axis=1),
                                           np.linalg.norm(rest[eye] - pv, axis=1), atol=1e-4)
            np.testing.assert_allclose(L[[NOSE_TIP, CHIN]], L0[[NOSE_TIP, CHIN]], atol=1e-4)
        case _:
            pytest.fail(f"no expectation written for {code}")
    if code < "AU50":  # face AUs: the back of the head and the neck base stay put
        skin0, skin = rest["skin"], pos["skin"]
        back = skin0[:, 2] < -1.0
        base = skin0[:, 1] < rig.head.anchors["neck_base"][1] + 1.0
        assert np.abs(skin[back | base] - skin0[back | base]).max() < 0.01
        for eye in ("eye_L", "eye_R"):  # expression shapes never move the eyeballs
            np.testing.assert_allclose(pos[eye], rest[eye], atol=1e-5)
    if code in {"AU01", "AU02", "AU04", "AU05", "AU07", "AU43"}:  # upper face: mouth still
        assert np.abs(d[[CHIN, 57, CORNER_L, CORNER_R]]).max() < 0.05
    if code >= "AU10" and code < "AU29":  # lower face: brows still
        assert np.abs(d[BROW_MID + BROW_OUT]).max() < 0.05


@pytest.mark.ict
@needs_ict
@pytest.mark.parametrize("code", SEED_AUS)
def test_seed_au_moves_expected_region(rig, code):
    check(rig, code)


@pytest.mark.ict
@needs_ict
@pytest.mark.parametrize("code", ["AU01", "AU02", "AU04", "AU10", "AU12", "AU15", "AU20", "AU43"])
def test_unilateral_variant_moves_only_its_side(rig, code):
    L0, _ = lms(rig, {})
    d = {s: np.abs(lms(rig, {code + s: 1.0})[0] - L0).max(1) for s in "LR"}
    x = L0[:, 0]  # +x = subject's left
    assert d["L"][x > 0.5].max() > MIN / 2 and d["L"][x < -2].max() < 0.03
    assert d["R"][x < -0.5].max() > MIN / 2 and d["R"][x > 2].max() < 0.03
    # the two sides add up to the bilateral AU
    both = rig.deform({code: 1.0})
    lr = rig.deform({code + "L": 1.0, code + "R": 1.0})
    for k in both:
        np.testing.assert_allclose(lr[k], both[k], atol=1e-5)


@pytest.mark.ict
@needs_ict
def test_wink_is_one_sided(rig):
    L, _ = lms(rig, {"AU46": 1.0})
    gap = lid_gap(L)  # right eye pairs first, then left
    assert np.all(np.abs(gap[2:]) < 0.1) and np.all(gap[:2] > 0.3)


@pytest.mark.ict
@needs_ict
def test_neck_bends_smoothly_under_head_turn(rig):
    rest = rig.head["skin"].vertices
    pos = rig.deform({"AU51": 1.0, "AU53": 0.5})["skin"]
    disp = np.linalg.norm(pos - rest, axis=1)
    base = rest[:, 1] < rig.head.anchors["neck_base"][1] + 0.3
    assert disp[base].max() < 0.05  # the neck base stays
    # edge lengths stretch by at most a modest factor anywhere (no tearing)
    f = rig.head["skin"].faces
    e0 = np.linalg.norm(rest[f] - rest[np.roll(f, 1, 1)], axis=2)
    e1 = np.linalg.norm(pos[f] - pos[np.roll(f, 1, 1)], axis=2)
    assert np.max(e1 / np.maximum(e0, 1e-6)) < 2.0


@pytest.mark.ict
@needs_ict
def test_order_shapes_then_eyes_then_head(rig):
    """Head motion is applied last, rigidly to everything above the chin."""
    a = rig.deform({"AU12": 1.0, "AU61": 1.0})
    b = rig.deform({"AU12": 1.0, "AU61": 1.0, "AU51": 1.0})
    from scipy.spatial.transform import Rotation

    r = Rotation.from_rotvec([0, np.radians(35), 0]).as_matrix()
    c = rig.head.anchors["neck_pivot"]
    for name in ("eye_L", "teeth"):
        np.testing.assert_allclose(b[name], (a[name] - c) @ r.T + c, atol=1e-4)


@pytest.mark.ict
@needs_ict
def test_deform_batch_matches_deform(rig, rng):
    chans = ["AU01", "AU04", "AU12L", "AU12", "AU25", "AU26", "AU43", "AU46", "AU61", "AU63",
             "AU51", "AU54", "AU55", "AU57"]
    vals = rng.random((7, len(chans))).astype(np.float32) * 0.6
    out = rig.deform_batch(vals, chans)
    for t in range(len(vals)):
        ref = rig.deform(dict(zip(chans, vals[t].tolist(), strict=True)))
        for k, v in ref.items():
            assert out[k].shape == (len(vals), *v.shape)
            np.testing.assert_allclose(out[k][t], v, atol=2e-5)


@pytest.mark.ict
@needs_ict
def test_rejects_bad_input(rig):
    with pytest.raises(ParameterError, match="outside"):
        rig.deform({"AU12": 1.5})
    with pytest.raises(ParameterError, match="not modelled"):
        rig.deform({"AU13": 1.0})
    with pytest.raises(ParameterError):
        rig.deform_batch(np.full((2, 1), 2.0), ["AU12"])
    with pytest.raises(ParameterError):
        rig.deform_batch(np.zeros((2, 2)), ["AU12"])
    assert not rig.delta_matrix.flags.writeable


@pytest.mark.ict
@needs_ict
def test_cache_roundtrip_and_corrupt_cache_rebuilt(tmp_path, monkeypatch):
    from mimika.face.ict import load_ict_data

    monkeypatch.setenv("MIMIKA_CACHE_DIR", str(tmp_path))
    a = load_ict_data()
    files = list(tmp_path.glob("ict-*.npz"))
    assert len(files) == 1
    b = load_ict_data()
    np.testing.assert_array_equal(a.deltas, b.deltas)
    files[0].write_bytes(b"not a zip")
    c = load_ict_data()
    np.testing.assert_array_equal(a.vertices, c.vertices)
    assert files[0].stat().st_size > 1000  # rewritten
