"""AUs are fields over space (seed 002): the same FieldRig parameters give the same
displacement at the same surface points, whatever the mesh resolution."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from mimika.face.heads.builtin import build_builtin_head
from mimika.face.rigs.field import load_field_rig
from mimika.facs import SEED_AUS

TOL = 0.02  # cm: 0.2 mm, about 1.5 % of the largest AU displacement (AU27, 1.45 cm)


@pytest.fixture(scope="module")
def rigs():
    return {res: load_field_rig(build_builtin_head(res)) for res in (0, 1, 2)}


def sides(rig, v):
    return np.stack([s.upper_weight(v) > 0.5 for s in rig.fields.splits.values()], 1)


@pytest.mark.parametrize("coarse", [0, 1])
@pytest.mark.parametrize("code", SEED_AUS)
def test_same_displacement_at_same_points_across_resolutions(rigs, coarse, code):
    fine, rough = rigs[2], rigs[coarse]
    vf, vc = fine.head["skin"].vertices, rough.head["skin"].vertices
    dist, idx = cKDTree(vc).query(vf)
    # the same surface point: fine vertices within 0.01 cm of a coarse vertex, on the same
    # side of the lip and lid splits (a point on the upper lip is not one on the lower lip)
    same = (dist < 0.01) & np.all(sides(fine, vf) == sides(rough, vc[idx]), axis=1)
    assert same.sum() > 300
    df = fine.deform({code: 1.0})["skin"] - vf
    dc = rough.deform({code: 1.0})["skin"] - vc
    err = np.linalg.norm(df[same] - dc[idx[same]], axis=1)
    assert err.max() < TOL, f"{code}: max {err.max():.4f} cm"
