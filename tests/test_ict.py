"""The ICT Face Model head and its BlendshapeRig: loading, caching, AU semantics, batches."""

import os
from pathlib import Path

import numpy as np
import pytest

from mimika.errors import DataError, ParameterError
from mimika.face.heads.ict import find_ict_dir

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
    from mimika.face.heads.ict import load_ict_rig

    return load_ict_rig()


def lms(rig, aus):
    pos = rig.deform(aus)
    return rig.head.landmark_points(pos), pos


def lid_gap(L):
    return L[UPPER_LID, 1] - L[LOWER_LID, 1]


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
    from mimika.face.heads.ict import load_ict_data

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
