"""``mimika rig`` on heads it was not made for: the output is the input with morphs added
(place, meshes, vertex order and UVs kept), the GLB and OBJ forms of a head give one frame,
and AUs tear and fold the mesh no more than real scans do. Test heads are made from what the
project ships (:mod:`mimika.face.rigging.samples`): the built-in head and a MakeHuman
character's head, written as a bare OBJ and a GLB cut at its UV seams."""

from pathlib import Path

import numpy as np
import pytest

from conftest import needs_ict
from mimika.cli import main
from mimika.face.heads import load_head
from mimika.face.heads.gltf_scene import read_gltf
from mimika.face.rigging.autorig import rig_mesh
from mimika.face.rigging.samples import write_samples

#: the built-in head with its eyes and teeth as a character stands in a scene
SCENE = ("skin", "eye_L", "eye_R", "teeth_upper", "teeth_lower")


@pytest.fixture(scope="module")
def builtin_files(tmp_path_factory) -> dict[str, Path]:
    head, _ = load_head("builtin")
    return write_samples(head, tmp_path_factory.mktemp("rig"), "head", SCENE,
                         offset_m=(0.3, 1.6, -0.2), yaw_deg=25.0)


@pytest.fixture(scope="module")
def character_files(tmp_path_factory) -> dict[str, Path]:
    """amara's head: skin cut at UV seams in the GLB, closed lips and lids (a mouth bag)."""
    head, _ = load_head("amara")
    return write_samples(head, tmp_path_factory.mktemp("rig"), "amara",
                         ("skin", "eye_L", "eye_R", "teeth"))


def test_rigged_glb_keeps_place_meshes_order_and_uvs(builtin_files, tmp_path):
    src = builtin_files["glb"]
    out = tmp_path / "rigged.glb"
    assert main(["rig", str(src), "-o", str(out), "--quiet"]) == 0
    a, b = read_gltf(src), read_gltf(out)
    assert [m.name for m in b.meshes] == [m.name for m in a.meshes]  # one mesh each, as given
    for ma, mb in zip(a.meshes, b.meshes, strict=True):
        assert np.array_equal(ma.vertices, mb.vertices)  # same place and vertex order
        assert np.array_equal(ma.uvs, mb.uvs)
        assert all(np.array_equal(fa, fb) for (_, fa), (_, fb) in
                   zip(ma.primitives, mb.primitives, strict=True))
    skin = b.meshes[0]
    assert {"mouthSmileLeft", "jawOpen", "AU12L", "AU45"} <= set(skin.morph_names)
    # the smile lifts the corners where the head stands: 1.6 m up, turned 25°
    head, rig = load_head(out)
    lm0 = head.landmark_points()
    d = head.landmark_points(rig.deform({"AU12": 1.0})) - lm0
    assert min(d[48, 1], d[54, 1]) > 0.1 and d[54, 0] > 0.05 and d[48, 0] < -0.05


def test_rigged_obj_keeps_vertex_order_and_uvs(builtin_files, tmp_path):
    from mimika.io.obj import read_obj

    src = builtin_files["obj"]
    out = tmp_path / "rigged.glb"
    assert main(["rig", str(src), "-o", str(out), "--quiet"]) == 0
    m = read_obj(src)
    g = read_gltf(out)
    assert len(g.meshes) == 1  # an OBJ is one mesh
    v = g.meshes[0].vertices
    n = len(m.vertices)
    # the OBJ's vertices first, in order, where they were (metres: the OBJ was in metres)
    assert np.abs(v[:n] - m.vertices).max() < 1e-6
    # the copies appended at UV seams sit on an OBJ vertex; map them back to it
    from scipy.spatial import cKDTree

    dist, orig = cKDTree(m.vertices).query(v[n:])
    assert dist.max(initial=0.0) < 1e-6
    back = np.concatenate([np.arange(n), orig])
    faces = np.concatenate([f for _, f in g.meshes[0].primitives])
    got, want = back[faces], m.faces.astype(np.int64)
    i, j = np.lexsort(got.T[::-1]), np.lexsort(want.T[::-1])
    assert np.array_equal(got[i], want[j])  # the same triangles
    # every corner keeps its texture coordinate (glTF's v runs down)
    uv_got = g.meshes[0].uvs[faces[i]].reshape(-1, 2)
    uv_want = m.uvs[m.face_uvs[j]].reshape(-1, 2)
    assert np.abs(uv_got[:, 0] - uv_want[:, 0]).max() < 1e-6
    assert np.abs(1 - uv_got[:, 1] - uv_want[:, 1]).max() < 1e-6


@pytest.mark.parametrize("files", ["builtin_files", "character_files"])
def test_glb_and_obj_forms_give_one_frame(files, request):
    """The same head as a GLB cut at its UV seams and as an OBJ sharing positions: the same
    eyes, the same mouth (the lip opening, not a seam or the mouth bag behind it)."""
    f = request.getfixturevalue(files)
    a, b = rig_mesh(f["glb"]).frame, rig_mesh(f["obj"]).frame
    assert np.allclose(a.rotation, b.rotation, atol=1e-4)  # (a GLB holds float32)
    for k in ("eye_L", "eye_R", "mouth"):
        assert np.linalg.norm(getattr(a.features, k) - getattr(b.features, k)) < 0.05, k


@needs_ict
def test_game_head_mouth_is_the_lip_opening(tmp_path):
    """The ICT head made like a game head (face, mouth bag and eye sockets one mesh): as a
    GLB cut at its seams and as an OBJ, the mouth found is the opening between the lips (the
    ICT landmarks put the lips' inner line 11.3 cm in front), not the bag behind (9.5 cm)."""
    from mimika.face.rigging.samples import ict_game_head

    f = ict_game_head(tmp_path)
    a, b = rig_mesh(f["glb"]).frame, rig_mesh(f["obj"]).frame
    assert np.allclose(a.rotation, b.rotation, atol=1e-4)
    for fr in (a, b):
        assert fr.features.mouth[2] > 10.3 and abs(fr.features.mouth[1] + 3.35) < 0.3
    assert np.linalg.norm(a.features.mouth - b.features.mouth) < 0.05


def test_seams_do_not_open(character_files):
    """Copies of a vertex at a UV seam move as one in every AU."""
    from mimika.face.rigging.quality import measure

    r = rig_mesh(character_files["glb"])
    assert r.head["skin"].weld is not None
    assert max(x["gap_mm"] for x in measure(r.rig)) < 1e-3


@pytest.mark.parametrize("style", ["ict", "makehuman"])
def test_no_tears_and_few_folds_at_au_extremes(builtin_files, style):
    """Every AU at ½ and 1 on the built-in head: no edge torn but where the jaw opens (the
    mouth corners stretch, as in the real scans), and no more folded triangles than the real
    ICT scans fold (40 over their 93 AU shapes, ``bench_rig_quality.py --real``)."""
    from mimika.face.rigging.quality import measure

    rows = measure(rig_mesh(builtin_files["obj"], style=style).rig)
    torn = {x["au"]: x["torn"] for x in rows if x["torn"]}
    assert set(torn) <= {"AU25", "AU25L", "AU25R", "AU26", "AU27"}, torn
    assert sum(x["flips"] for x in rows) <= 40 and max(x["flips"] for x in rows) <= 6
    assert max(x["gap_mm"] for x in rows) == 0.0


def test_strength_scales_the_shapes(builtin_files, tmp_path, capsys):
    r1 = rig_mesh(builtin_files["obj"])
    r2 = rig_mesh(builtin_files["obj"], strength=0.7)
    a, b = r1.shapes["jawOpen"]["skin"], r2.shapes["jawOpen"]["skin"]
    assert np.allclose(b, 0.7 * a, atol=1e-6)
    for bad in ("0", "5", "nan"):
        assert main(["rig", str(builtin_files["obj"]), "-o", str(tmp_path / "x.glb"),
                     "--strength", bad]) == 2
        err = capsys.readouterr().err.strip()
        assert "--strength" in err and len(err.splitlines()) == 1
