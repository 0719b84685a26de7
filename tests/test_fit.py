"""Fitting seed-002 fields (mimika.face.fitting): synthetic recovery, real ICT data, transfer,
identities, the frame rotation / RBF extensions of the fields file, CLI errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import needs_ict
from mimika.errors import DataError, ParameterError
from mimika.face.fitting import (
    FitOptions,
    fit_field,
    fit_phi,
    fit_psi,
    landmark_agreement,
    similarity_transform,
    transfer_fields,
)
from mimika.face.rigs.field import Cubic, FieldRig, Gaussian, LinearField, parse_fields


def _surface(rng, n=600):
    """Points on a curved face-like patch (u units, |u| ≲ 1.5)."""
    x, y = rng.uniform(-1.5, 1.5, n), rng.uniform(-1.2, 1.2, n)
    z = 1.0 - 0.25 * x**2 - 0.15 * y**2
    return np.c_[x, y, z]


def _known_field() -> LinearField:
    z33 = np.zeros((3, 3))
    alpha = Cubic(np.diag([0.1, 0.0, 0.05]), np.array([0.1, 0.25, 0.05]), z33,
                  np.array([0.4, 0.1, 0.0]), 0.3)
    beta = Cubic(z33, np.zeros(3), np.array([[0.1, 0, 0], [0, -0.1, 0], [0, 0, 0]]),
                 np.array([0.0, 0.2, 0.1]), 0.6)
    gs = (Gaussian(0.5, np.array([0.7, 0.2, 0.8]), np.diag([4.0, 3.0, 2.0])),
          Gaussian(0.4, np.array([-0.7, 0.1, 0.8]), np.diag([3.0, 4.0, 2.0])))
    return LinearField(alpha, beta, gs)


# --- synthetic recovery (no data needed) ---------------------------------------------------------


def test_fit_psi_recovers_known_directions(rng):
    u = _surface(rng)
    f = _known_field()
    d = f(u)
    alpha, beta = fit_psi(u, d, max_evals=2000)
    psi = LinearField(alpha, beta, f.gaussians).psi(u)
    # compare directions (the cubic's parametrisation is not unique): weighted mean angle < 1°
    true = d / np.linalg.norm(d, axis=1, keepdims=True)
    ang = np.degrees(np.arccos(np.clip((psi * true).sum(1), -1, 1)))
    w = np.linalg.norm(d, axis=1)
    assert (ang * w).sum() / w.sum() < 1.0


def test_fit_phi_recovers_two_gaussians(rng):
    u = _surface(rng)
    f = _known_field()
    mag = f.phi(u)
    groups = [u[:, 0] >= 0, u[:, 0] < 0]
    gs = fit_phi(u, mag, groups=groups, sigma_min=0.05, max_evals=2000)
    fitted = sum(g(u) for g in gs)
    assert np.abs(fitted - mag).max() < 0.05 * mag.max()
    assert np.abs(fitted - mag).mean() < 0.01 * mag.max()


def test_fit_field_displacements_within_2_percent(rng):
    u = _surface(rng)
    f = _known_field()
    d = f(u)
    for family, bound in (("seed", 0.02), ("rich", 0.01)):
        g = fit_field(u, d, bilateral=True, family=family, sigma_min=0.05, psi_evals=2000,
                      phi_evals=1500, rbf_centers=60)
        err = np.linalg.norm(g(u) - d, axis=1)
        assert err.mean() / np.linalg.norm(d, axis=1).max() < bound, family


def test_similarity_transform_roundtrip(rng):
    p = rng.normal(size=(68, 3))
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    r = q * np.sign(np.linalg.det(q))
    s, r2, t = similarity_transform(p, 1.3 * p @ r.T + [1, 2, 3])
    assert s == pytest.approx(1.3)
    assert np.allclose(r2, r, atol=1e-9)
    assert np.allclose(t, [1, 2, 3])


# --- the file-format extensions ------------------------------------------------------------------


def _doc(field: dict, frame: dict | None = None) -> dict:
    return {"format": "mimika-fields", "version": 1, "frame": frame or {},
            "aus": {"AU12": {"kind": "linear", "objects": {"face": field}}}}


def test_frame_rotation_and_rbf_parse_and_apply(builtin_rig):
    head = builtin_rig.head
    field = {"psi": {"direction": [0, 1, 0]}, "phi": [{"eta": 0.5, "mean": [2, -3, 10],
                                                       "sigma": 2.0}],
             "rbf": {"sigma": 1.0, "centers": [[2, -3, 10]], "weights": [[0.1, 0, 0]]}}
    plain = FieldRig(head, parse_fields(_doc(field)))
    assert plain.fields.rotation is None  # backward compatible: no rotation, no change
    ang = np.radians(20)
    rot = np.array([[np.cos(ang), 0, np.sin(ang)], [0, 1, 0], [-np.sin(ang), 0, np.cos(ang)]])
    rotated = FieldRig(head, parse_fields(_doc(field, {"origin": [0, 0, 0], "scale": 1.0,
                                                       "rotation": rot.tolist()})))
    v = head["skin"].vertices.astype(float)
    d0 = plain.field_at("AU12", "skin", head["skin"].vertices)
    d1 = rotated.field_at("AU12", "skin", head["skin"].vertices)
    # u = R·v: the rotated file sees the head turned by R, and maps directions back by Rᵀ
    f = parse_fields(_doc(field)).linear["AU12"]["face"]
    assert np.allclose(d1, f(v @ rot.T) @ rot, atol=1e-6)
    assert np.abs(d0 - f(v)).max() < 1e-6
    assert np.abs(f(v) - f.psi(v) * f.phi(v)[:, None]).max() > 1e-3  # the residual acts
    with pytest.raises(DataError, match="rotation"):
        parse_fields(_doc(field, {"rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 2]]}))
    with pytest.raises(DataError, match="rbf"):
        parse_fields(_doc({**field, "rbf": {"sigma": 1, "centers": [[0, 0, 0]],
                                            "weights": []}}))


def test_transfer_to_rotated_head_moves_points_alike(builtin_rig):
    """A file carried to a rotated, scaled, shifted copy of its head gives the same motion,
    rotated and scaled."""
    from dataclasses import replace

    head = builtin_rig.head
    lm = head.landmark_points().astype(float)
    doc = _doc({"psi": {"direction": [0.3, 1, 0.2]},
                "phi": [{"eta": 0.5, "mean": [2, -3, 10], "sigma": [1.5, 1.0, 2.0]}]},
               {"origin": lm.mean(0).tolist(), "scale": 5.0})
    doc["source"] = {"landmarks": lm.tolist()}
    ang = np.radians(15)
    r = np.array([[1, 0, 0], [0, np.cos(ang), -np.sin(ang)], [0, np.sin(ang), np.cos(ang)]])
    s, t = 1.2, np.array([0.5, -1.0, 2.0])
    moved = replace(head, objects=tuple(replace(o, vertices=s * o.vertices @ r.T + t,
                                                pivot=None if o.pivot is None else
                                                s * r @ o.pivot + t) for o in head.objects),
                    anchors={k: s * r @ v + t for k, v in head.anchors.items()})
    out = transfer_fields(doc, moved)
    a = FieldRig(head, parse_fields(doc)).field_at("AU12", "skin", head["skin"].vertices)
    b = FieldRig(moved, parse_fields(out)).field_at("AU12", "skin", moved["skin"].vertices)
    assert np.allclose(b, s * a @ r.T, atol=1e-5)


# --- real data (ICT) -----------------------------------------------------------------------------

#: stated e/d_max bounds (this test's reduced budget; measured: rich 2.5 % AU12, 1.6 % AU27 on
#: held-out vertices; its seed part alone 10.9 % / 6.9 % on all moving face vertices)
SEED_BOUND, RICH_BOUND = 0.12, 0.05
#: mean landmark-direction cosine ICT → built-in head per AU (measured 0.991 AU12, 0.997 AU27)
COSINE_BOUND = 0.9


@pytest.fixture(scope="module")
def ict_fit():
    from conftest import ict_dir

    if ict_dir() is None:
        pytest.skip("MIMIKA_ICT_DIR not set: no ICT data")
    from mimika.face.fitting import fit_ict

    return fit_ict(aus=["AU12", "AU27"], options=FitOptions(
        family="rich", psi_evals=2000, phi_evals=1500, max_vertices=800))


@needs_ict
def test_real_fit_under_error_bound(ict_fit):
    rows = {r.code: r for r in ict_fit.accuracy if r.obj == "face"}
    assert set(rows) == {"AU12", "AU27"}
    for r in rows.values():
        assert r.n > 100 and r.e_rel < RICH_BOUND, r
    doc = ict_fit.document
    fs = parse_fields(json.loads(json.dumps(doc)))  # the written file loads
    assert {"AU12", "AU27", "AU51", "AU61"} <= set(fs.aus)
    assert set(fs.linear["AU27"]["face"].__dict__) >= {"upper", "lower"}
    assert "teeth" in fs.linear["AU27"]
    # the seed part alone (the residual dropped) stays under the seed bound
    seed_doc = json.loads(json.dumps(doc))
    for spec in seed_doc["aus"].values():
        for f in spec.get("objects", {}).values() if spec["kind"] == "linear" else []:
            for part in (f, f.get("upper", {}), f.get("lower", {})):
                part.pop("rbf", None)
    for code, e_rel in _face_errors(seed_doc, ["AU12", "AU27"]).items():
        assert e_rel < SEED_BOUND, (code, e_rel)


def _face_errors(doc: dict, codes) -> dict[str, float]:
    """e/d_max over all moving ICT face vertices (≥ 5 % of d_max) of ``doc`` on the ICT head."""
    from mimika.face.heads.ict import load_ict_rig

    rig = load_ict_rig()
    head = rig.head
    fr = FieldRig(head, parse_fields(doc))
    out = {}
    for code in codes:
        meas = rig.deform({code: 1.0})["skin"][:9409] - head["skin"].vertices[:9409]
        model = fr.field_at(code, "skin", head["skin"].vertices)[:9409]
        mag = np.linalg.norm(meas, axis=1)
        sel = mag >= 0.05 * mag.max()
        out[code] = float(np.linalg.norm(meas[sel] - model[sel], axis=1).mean() / mag.max())
    return out


@needs_ict
def test_transfer_to_builtin_moves_landmarks_alike(ict_fit, builtin_rig, ict_rig):
    out = transfer_fields(ict_fit.document, builtin_rig.head)
    rig = FieldRig(builtin_rig.head, parse_fields(out))
    rot = np.asarray(out["source"]["similarity"]["rotation"])
    agree = landmark_agreement(ict_rig, rig, ["AU12", "AU27"], rotation=rot)
    for code, (mean, _, n) in agree.items():
        assert n >= 3 and mean > COSINE_BOUND, (code, agree[code])


@needs_ict
def test_identities_change_shape_but_aus_still_move(ict_fit):
    from mimika.face.fitting import load_fitted_rig
    from mimika.face.heads.ict import identity_weights, load_ict_head, load_ict_rig

    base = load_ict_head()
    rig = load_ict_rig(identity=[0, 2.0, -1.5])
    moved = np.linalg.norm(rig.head["skin"].vertices - base["skin"].vertices, axis=1)
    assert moved.max() > 0.5  # a different face
    lm0 = rig.head.landmark_points()
    up = rig.head.landmark_points(rig.deform({"AU12": 1.0})) - lm0
    assert up[[48, 54], 1].min() > 0.3  # mouth corners rise on the new face
    path = "/tmp/_mimika_test_fit_fields.json"
    with open(path, "w") as fh:
        json.dump(ict_fit.document, fh)
    frig = load_fitted_rig(rig.head, path)
    fup = rig.head.landmark_points(frig.deform({"AU12": 1.0})) - lm0
    assert fup[[48, 54], 1].min() > 0.3
    with pytest.raises(ParameterError):
        identity_weights(12)


# --- errors --------------------------------------------------------------------------------------


def _cli(argv, monkeypatch, capsys):
    import mimika.cli as cli

    if "fit" not in cli.MODULES:
        monkeypatch.setattr(cli, "MODULES", (*cli.MODULES, "fit"))
    code = cli.main(argv)
    return code, capsys.readouterr()


def test_cli_missing_shapes_dir(monkeypatch, capsys, tmp_path):
    code, out = _cli(["fit", "--shapes", str(tmp_path / "nope"), "-o",
                      str(tmp_path / "f.json")], monkeypatch, capsys)
    assert code == 2
    assert out.err.count("\n") == 1 and "no such folder" in out.err


@needs_ict
def test_cli_unknown_or_unfittable_au(monkeypatch, capsys, tmp_path):
    import os

    for au, msg in (("AU99", "AU99"), ("AU51", "cannot be fitted")):
        code, out = _cli(["fit", "--shapes", os.environ["MIMIKA_ICT_DIR"], "--au", au, "-o",
                          str(tmp_path / "f.json")], monkeypatch, capsys)
        assert code == 2 and out.err.count("\n") == 1 and msg in out.err, out.err


def test_transfer_needs_source_landmarks(builtin_rig):
    with pytest.raises(DataError, match="source landmarks"):
        transfer_fields(_doc({"psi": {"direction": [0, 1, 0]},
                              "phi": [{"eta": 1, "mean": [0, 0, 0], "sigma": 1}]}),
                        builtin_rig.head)


def test_fields_fit_on_makehuman_faceunits():
    """Per-shape fields fitted on a MakeHuman character's faceunits (not only ICT's scans)
    reproduce held-out vertices within 10 % and open the jaw downwards."""
    from mimika.face.fitting.shapes import fit_character_shapes, shape_fields

    res = fit_character_shapes(names=["jawOpen", "mouthSmile_L"])
    assert res.document["source"]["head"] == "makehuman"
    assert {r.code for r in res.accuracy} == {"jawOpen", "mouthSmile_L"}
    assert all(r.e_rel < 0.10 for r in res.accuracy if r.obj == "face"), res.accuracy
    fs = shape_fields(res.document)
    chin = fs.to_u(np.asarray(res.document["source"]["landmarks"])[8:9])
    assert fs.to_head(fs.linear["jawOpen"]["face"].lower(chin))[0, 1] < -0.5  # cm down
