"""FieldRig: seed 002's displacement-field model on a synthetic head."""

import json

import numpy as np
import pytest

from mimika import DataError, ParameterError
from mimika.face.head import Head, MeshObject, Part
from mimika.face.rigs.field import (
    Cubic,
    FieldRig,
    Gaussian,
    LinearField,
    angles_of,
    direction,
    load_fields,
    parse_fields,
)


def grid_head(n: int = 21) -> Head:
    """A flat 'face' sheet in the z=10 plane spanning x, y ∈ [−5, 5], an 'eye' and 'teeth'."""
    xs = np.linspace(-5, 5, n)
    X, Y = np.meshgrid(xs, xs)
    verts = np.stack([X.ravel(), Y.ravel(), np.full(X.size, 10.0)], 1)
    idx = np.arange(n * n).reshape(n, n)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    eye = np.array([[3.0, 3.0, 9.0], [3.2, 3.0, 9.0], [3.0, 3.2, 9.0]])
    teeth = np.array([[0.0, -3.0, 9.0], [0.5, -3.0, 9.0], [0.0, -3.5, 9.0]])
    tri = [Part("x", [[0, 1, 2]])]
    return Head(
        "grid",
        (
            MeshObject("skin", "face", verts, (Part("skin", faces),)),
            MeshObject("eye_L", "eyes", eye, tuple(tri), pivot=[3.0, 3.0, 8.0]),
            MeshObject("teeth_lower", "teeth", teeth, tuple(tri)),
        ),
        landmarks=np.arange(68),
        anchors={},
    )


def doc(aus: dict) -> dict:
    return {"format": "mimika-fields", "version": 1,
            "split": {"point": [0, -2, 10], "normal": [0, 1, 0]}, "aus": aus}


UP = {"psi": {"direction": [0, 1, 0]}, "phi": [{"eta": 1.0, "mean": [2, 2, 10], "sigma": 1.5}]}
RIGHTWARD = {"psi": {"direction": [1, 0, 0]},
             "phi": [{"eta": 1.0, "mean": [2, 2, 10], "sigma": 3.0}]}


def test_direction_is_unit_and_inverts():
    rng = np.random.default_rng(0)
    a, b = rng.uniform(-3, 3, 50), rng.uniform(-1.5, 1.5, 50)
    d = direction(a, b)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1, atol=1e-12)
    for v in ([0, 1, 0.2], [1, 0, 0], [0.3, -0.5, 0.8]):
        aa, bb = angles_of(v)
        np.testing.assert_allclose(direction(np.array([aa]), np.array([bb]))[0],
                                   np.asarray(v) / np.linalg.norm(v), atol=1e-12)


def test_cubic_matches_seed_formula():
    rng = np.random.default_rng(1)
    A1, A3 = rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    A2, A4 = rng.normal(size=3), rng.normal(size=3)
    poly = Cubic(A1, A2, A3, A4, 0.7)
    v = rng.normal(size=(5, 3))
    expect = [(x @ A1 @ x) * (A2 @ x) + x @ A3 @ x + A4 @ x + 0.7 for x in v]
    np.testing.assert_allclose(poly(v), expect)
    np.testing.assert_allclose(Cubic.from_json(poly.to_json())(v), expect, atol=1e-6)


def test_linear_au_moves_its_region_by_psi_phi_tau():
    rig = FieldRig(grid_head(), parse_fields(doc({"AU01": {"objects": {"face": UP}}})))
    rest = rig.head["skin"].vertices
    out = rig.deform({"AU01": 0.5})["skin"]
    d = out - rest
    i = np.argmin(np.linalg.norm(rest - [2, 2, 10], axis=1))
    np.testing.assert_allclose(d[i], [0, 0.5, 0], atol=1e-6)  # peak: η·τ straight up
    far = np.linalg.norm(rest - [2, 2, 10], axis=1) > 7
    assert np.abs(d[far]).max() < 1e-3
    # other objects are not in the AU's categories: untouched
    np.testing.assert_array_equal(rig.deform({"AU01": 1})["eye_L"], rig.head["eye_L"].vertices)


def test_additive_mixer_is_order_free_and_successive_is_not():
    fs = parse_fields(doc({"AU01": {"objects": {"face": UP}},
                           "AU02": {"objects": {"face": RIGHTWARD}}}))
    head = grid_head()
    aus = {"AU01": 1.0, "AU02": 1.0}
    add_a = FieldRig(head, fs, order=["AU01", "AU02"]).deform(aus)["skin"]
    add_b = FieldRig(head, fs, order=["AU02", "AU01"]).deform(aus)["skin"]
    np.testing.assert_array_equal(add_a, add_b)
    succ = {"AU01": "successive", "AU02": "successive"}
    s_a = FieldRig(head, fs, mixers=succ, order=["AU01", "AU02"]).deform(aus)["skin"]
    s_b = FieldRig(head, fs, mixers=succ, order=["AU02", "AU01"]).deform(aus)["skin"]
    assert np.abs(s_a - s_b).max() > 0.05  # the second AU sees the already moved mesh


def test_subobject_halves_split_by_mouth_corner_plane():
    au = {"objects": {
        "face": {"upper": {"psi": {"direction": [0, 1, 0]},
                           "phi": [{"eta": 1, "mean": [0, -2, 10], "sigma": 2}]},
                 "lower": {"psi": {"direction": [0, -1, 0]},
                           "phi": [{"eta": 1, "mean": [0, -2, 10], "sigma": 2}]}},
        "teeth": {"lower": {"psi": {"direction": [0, -1, 0]},
                            "phi": [{"eta": 0.8, "mean": [0, -3, 9], "sigma": 10}]}}}}
    rig = FieldRig(grid_head(), parse_fields(doc({"AU25": au})))
    rest = rig.head["skin"].vertices
    d = rig.deform({"AU25": 1})["skin"] - rest
    near = np.abs(rest[:, 0]) < 1.5
    assert np.all(d[near & (rest[:, 1] > -1.9), 1] > 0)  # upper half opens upward
    assert np.all(d[near & (rest[:, 1] < -2.1), 1] < 0)  # lower half downward
    teeth = rig.deform({"AU25": 1})["teeth_lower"] - rig.head["teeth_lower"].vertices
    np.testing.assert_allclose(teeth[:, 1], -0.8, atol=0.01)  # rigid: whole object below plane


def test_unilateral_variants_move_one_side():
    fs = parse_fields(doc({"AU12": {"objects": {"face": {
        "mirror": True, "psi": {"direction": [0, 1, 0]},
        "phi": [{"eta": 1, "mean": [3, 0, 10], "sigma": 1.5}]}}}}))
    rig = FieldRig(grid_head(), fs)
    rest = rig.head["skin"].vertices
    both = rig.deform({"AU12": 1})["skin"] - rest
    left = rig.deform({"AU12L": 1})["skin"] - rest
    lpt = np.argmin(np.linalg.norm(rest - [3, 0, 10], axis=1))
    rpt = np.argmin(np.linalg.norm(rest - [-3, 0, 10], axis=1))
    assert both[lpt, 1] == pytest.approx(1, abs=1e-3)
    assert both[rpt, 1] == pytest.approx(1, abs=1e-3)  # mirrored to the right
    assert left[lpt, 1] > 0.99 and abs(left[rpt, 1]) < 0.01
    assert "AU12L" in rig.supported


def test_rotation_au_turns_head_with_neck_falloff_and_eyes_about_their_centre():
    fs = parse_fields(doc({
        "AU51": {"kind": "rotation", "axis": [0, 1, 0], "angle": 30, "pivot": [0, 0, 0],
                 "falloff": {"top": 0, "bottom": -4}, "objects": ["face", "eyes", "teeth"]},
        "AU61": {"kind": "rotation", "axis": [0, 1, 0], "angle": 30, "objects": ["eyes"]},
    }))
    rig = FieldRig(grid_head(), fs)
    rest = rig.head["skin"].vertices
    out = rig.deform({"AU51": 1})["skin"]
    top = rest[:, 1] > 0.5
    np.testing.assert_allclose(np.linalg.norm(out[top] - [0, 0, 0], axis=1),
                               np.linalg.norm(rest[top], axis=1), atol=1e-4)
    assert np.all(out[top, 0] > rest[top, 0])  # the face (z=10) turns toward +x
    assert np.abs(out[rest[:, 1] < -4.1] - rest[rest[:, 1] < -4.1]).max() < 1e-6
    eye = rig.deform({"AU61": 1})["eye_L"]
    piv = rig.head["eye_L"].pivot
    np.testing.assert_allclose(np.linalg.norm(eye - piv, axis=1),
                               np.linalg.norm(rig.head["eye_L"].vertices - piv, axis=1), atol=1e-5)
    assert eye[0, 0] > rig.head["eye_L"].vertices[0, 0]  # gaze toward the subject's left


def test_mesh_independence_on_grids():
    fs = parse_fields(doc({"AU01": {"objects": {"face": UP}}}))
    coarse, fine = FieldRig(grid_head(11), fs), FieldRig(grid_head(41), fs)
    # vertices shared by both grids (every 4th of the fine grid) move identically
    dc = coarse.deform({"AU01": 1})["skin"] - coarse.head["skin"].vertices
    df = fine.deform({"AU01": 1})["skin"] - fine.head["skin"].vertices
    np.testing.assert_allclose(dc, df.reshape(41, 41, 3)[::4, ::4].reshape(-1, 3), atol=1e-6)


def test_bad_fields_files(tmp_path):
    p = tmp_path / "f.json"
    p.write_text('{"format": "mimika-fields",\n "version": 1,\n "aus": {,}}')
    with pytest.raises(DataError, match=r"f.json:3:\d+: invalid JSON"):
        load_fields(p)
    with pytest.raises(DataError, match="not a mimika fields file"):
        parse_fields({"aus": {}})
    with pytest.raises(DataError, match=r"aus.AU99: unknown Action Unit"):
        parse_fields(doc({"AU99": {"objects": {}}}))
    with pytest.raises(DataError, match=r"aus.AU01: a phi Gaussian needs eta"):
        parse_fields(doc({"AU01": {"objects": {"face": {"phi": [{"mean": [0, 0, 0]}]}}}}))
    with pytest.raises(DataError, match="version 7"):
        parse_fields({"format": "mimika-fields", "version": 7})
    rig = FieldRig(grid_head(), parse_fields(doc({"AU01": {"objects": {"face": UP}}})))
    with pytest.raises(ParameterError, match=r"AU12 .* not modelled"):
        rig.deform({"AU12": 1})
    with pytest.raises(ParameterError, match=r"outside \[0, 1\]"):
        rig.deform({"AU01": 2})
    json.dumps(LinearField((c := Cubic.from_json(0)), c, (Gaussian.from_json(
        {"eta": 1, "mean": [0, 0, 0], "sigma": 1}),)).to_json())


def test_deform_batch_matches_deform(rng):
    fs = parse_fields(doc({
        "AU01": {"objects": {"face": UP}},
        "AU02": {"objects": {"face": RIGHTWARD}, "mixer": "successive"},
        "AU12": {"objects": {"face": {"mirror": True, **UP}}},
        "AU61": {"kind": "rotation", "axis": [0, 1, 0], "angle": 30, "objects": ["eyes"]},
    }))
    rig = FieldRig(grid_head(), fs)
    chans = ["AU01", "AU02", "AU12L", "AU61"]
    vals = rng.uniform(0, 1, (6, 4)).astype(np.float32)
    vals[2] = [0.5, 0, 0.3, 0]
    batch = rig.deform_batch(vals, chans)
    for t in range(6):
        one = rig.deform(dict(zip(chans, vals[t].tolist(), strict=True)))
        for name in one:
            np.testing.assert_allclose(batch[name][t], one[name], atol=1e-5)


def test_deform_batch_rotations_match_deform(rng):
    fs = parse_fields(doc({
        "AU01": {"objects": {"face": UP}},
        "AU51": {"kind": "rotation", "axis": [0, 1, 0], "angle": 30, "pivot": [0, 0, 0],
                 "falloff": {"top": 0, "bottom": -4}, "objects": ["face", "eyes", "teeth"]},
        "AU53": {"kind": "rotation", "axis": [1, 0, 0], "angle": -20, "pivot": [0, 0, 0],
                 "falloff": {"top": 0, "bottom": -4}, "objects": ["face", "eyes", "teeth"]},
        "AU61": {"kind": "rotation", "axis": [0, 1, 0], "angle": 30, "objects": ["eyes"]},
    }))
    rig = FieldRig(grid_head(), fs)
    # reference: a successive linear AU sends every frame down the frame-by-frame path;
    # applied first, on the rest mesh, it equals the additive one
    ref = FieldRig(grid_head(), fs, mixers={"AU01": "successive"})
    chans = ["AU01", "AU51", "AU53", "AU61"]
    vals = rng.uniform(0, 1, (5, 4)).astype(np.float32)
    vals[1, 1:] = 0
    batch = rig.deform_batch(vals, chans)
    expect = ref.deform_batch(vals, chans)
    for name in batch:
        np.testing.assert_allclose(batch[name], expect[name], atol=1e-4)
    assert np.abs(batch["eye_L"][0] - rig.head["eye_L"].vertices).max() > 0.1  # it moved
