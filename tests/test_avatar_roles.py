"""Avatars as people bring them: object roles from naming conventions or shape, fields on the
skin only, hair that --no-hair hides, arms lowered for the head-and-shoulders shot, eyes
turned once, and VRM 0.x / 1.0 files (bones, expressions, lookAt, MToon).

The avatars are mimika's own exports renamed and posed as other tools write them
(``avatar_files.py``); no third-party file is used."""

from __future__ import annotations

import numpy as np
import pytest

from avatar_files import LOOK_RANGE, Glb, ready_player_me, vrm
from mimika.cli import main
from mimika.face.heads import load_head
from mimika.face.heads.roles import name_role, objects_of_role
from mimika.io.gltf import write_gltf

# --- naming conventions ---------------------------------------------------------------------

NAMES = [
    # Ready Player Me
    ("Wolf3D_Head", "skin"), ("Wolf3D_Teeth", "teeth"), ("Wolf3D_Hair", "hair"),
    ("Wolf3D_Glasses", "glasses"), ("Wolf3D_Body", "body"), ("Wolf3D_Outfit_Top", "clothes"),
    ("Wolf3D_Outfit_Footwear", "clothes"), ("Wolf3D_Headwear", "clothes"),
    ("Wolf3D_Beard", "beard"), ("EyeLeft", "eyes"), ("EyeRight", "eyes"),
    # VRoid / VRM materials and meshes
    ("N00_000_00_FaceMouth_00_FACE (Instance)", "teeth"),
    ("N00_000_00_EyeIris_00_EYE (Instance)", "eyes"),
    ("N00_000_00_EyeHighlight_00_EYE", "eyes"), ("N00_000_00_EyeWhite_00_EYE", "eyes"),
    ("N00_000_00_FaceBrow_00_FACE", "brows"), ("N00_000_00_FaceEyelash_00_FACE", "lashes"),
    ("N00_000_00_FaceEyeline_00_FACE", "lashes"), ("N00_000_00_Face_00_SKIN", "skin"),
    ("N00_000_00_Body_00_SKIN", "body"), ("N00_000_00_HairBack_00_HAIR", "hair"),
    ("N00_001_01_Tops_01_CLOTH (Instance)", "clothes"), ("Face", "skin"), ("Hair", "hair"),
    # MPFB / MakeHuman
    ("Human", "skin"), ("Human.eyebrow001", "brows"), ("Human.eyelashes01", "lashes"),
    ("Human.high-poly", "eyes"), ("Human.teeth_base", "teeth"), ("Human.tongue01", "tongue"),
    ("Human.short02", "hair"), ("Human.bob02", "hair"), ("Human.male_casualsuit01", "clothes"),
    # Avaturn
    ("avaturn_hair_0", "hair"), ("avaturn_look_0", "clothes"), ("avaturn_shoes_0", "clothes"),
    ("avaturn_glasses_0", "glasses"),
    # Character Creator
    ("CC_Base_Body", "body"), ("CC_Base_Eye", "eyes"), ("CC_Base_Teeth", "teeth"),
    ("CC_Base_Tongue", "tongue"), ("CC_Base_EyeOcclusion", "lashes"),
    ("CC_Base_TearLine", "lashes"), ("Std_Skin_Head", "skin"), ("Std_Eyelash", "lashes"),
    # Mixamo
    ("Beta_Surface", "skin"), ("Beta_Joints", "body"), ("Tops", "clothes"),
    ("Bottoms", "clothes"), ("Shoes", "clothes"), ("Eyelashes", "lashes"),
    ("Beards", "beard"), ("mixamorig:Body", "body"),
    # mimika's own exports
    ("skin", "skin"), ("eye_L", "eyes"), ("teeth_upper", "teeth"), ("hair_coily", "hair"),
    ("brows", "brows"), ("lashes", "lashes"), ("clothes", "clothes"), ("skin_body", "body"),
]


@pytest.mark.parametrize(("name", "role"), NAMES)
def test_naming_conventions(name, role):
    assert name_role(name).role == role


@pytest.mark.parametrize("name", ["Material.001", "Object_3", "mesh0", "lips", "mouth"])
def test_names_that_say_nothing(name):
    assert name_role(name) is None


# --- a Ready Player Me avatar (mimika's amara, renamed) --------------------------------------

@pytest.fixture(scope="module")
def amara_glb(tmp_path_factory):
    p = tmp_path_factory.mktemp("rpm") / "amara.glb"
    write_gltf(p, load_head("amara")[1])
    return p


@pytest.fixture(scope="module")
def rpm_bare(amara_glb):
    """T-posed, glasses on, no morphs at all: every face AU from the fallback fields."""
    p = ready_player_me(amara_glb, amara_glb.with_name("rpm_bare.glb"), t_pose=True,
                        morphs=False, with_glasses=True)
    return p, *load_head(p)


@pytest.mark.slow
def test_inspect_lists_the_roles(rpm_bare, capsys):
    p = rpm_bare[0]
    assert main(["heads", "--inspect", str(p)]) == 0
    out = capsys.readouterr().out
    for obj, role, cat, fields in (("Wolf3D_Head", "skin", "face", "fields"),
                                   ("EyeLeft", "eyes", "eyes", "none"),
                                   ("Wolf3D_Teeth", "teeth", "teeth", "fields"),
                                   ("Wolf3D_Hair", "hair", "face", "none"),
                                   ("brows", "brows", "face", "skin"),
                                   ("Wolf3D_Glasses", "glasses", "face", "none"),
                                   ("Wolf3D_Outfit_Top", "clothes", "body", "none")):
        assert any(line.split()[:4] == [obj, role, cat, fields] for line in out.splitlines()
                   ), (obj, out)
    assert "pose: lowered 'LeftArm'" in out and "pose: lowered 'RightArm'" in out


@pytest.mark.slow
def test_fields_move_the_skin_only(rpm_bare):
    """Glasses, hair and clothes stay still under every AU the fields give; brows follow the
    skin (AU02), lashes the lids (AU43)."""
    _, head, rig = rpm_bare
    moved: dict[str, float] = {}
    for code in rig.supported_bilateral:
        if not "AU51" <= code <= "AU58":
            pos = rig.deform({code: 1.0})
            for o in head.objects:
                d = float(np.linalg.norm(pos[o.name] - o.vertices, axis=1).max())
                moved[o.name] = max(moved.get(o.name, 0.0), d)
    for still in ("Wolf3D_Glasses", "Wolf3D_Hair", "Wolf3D_Outfit_Top"):
        assert moved[still] == 0.0, (still, moved)
    assert moved["Wolf3D_Head"] > 2.0 and moved["brows"] > 0.5 and moved["lashes"] > 0.5
    # the glasses still turn with the head
    turned = rig.deform({"AU51": 1.0})["Wolf3D_Glasses"] - head["Wolf3D_Glasses"].vertices
    assert np.linalg.norm(turned, axis=1).min() > 0.5


@pytest.mark.slow
def test_arms_lowered_for_the_news_shot(rpm_bare, tmp_path):
    """The T pose is lowered through the upper arms (hands by the hips, not 70 cm out), and
    the news camera is a head-and-shoulders shot in which no arm reaches the image sides."""
    from PIL import Image

    from mimika.newsreader.pipeline import news_camera
    from mimika.render import Renderer

    p, head, _ = rpm_bare
    raw = Glb(p)
    assert raw.doc["nodes"][raw.node("LeftArm")].get("matrix")  # the file is T-posed
    skin = head["Wolf3D_Head"].vertices
    below = skin[skin[:, 1] < head.anchors["chin"][1] - 30.0]
    assert np.abs(below[:, 0]).max() < 35.0  # T pose: ±70 cm
    assert head.meta["body"]
    cam = news_camera(head, "front", 4 / 3)
    with Renderer(head, (320, 240), samples=0, lighting="news") as r:
        img = r.render(camera=cam)
    Image.fromarray(img).save(tmp_path / "news.png")
    xy = cam.project(head["Wolf3D_Outfit_Top"].vertices, (320, 240))
    shown = xy[(xy[:, 1] > 0) & (xy[:, 1] < 240)]
    assert len(shown) and (shown[:, 1] > 150).any()  # shoulders in the shot
    lm = cam.project(head.landmark_points(), (320, 240))
    assert 0.3 < lm[36:48, 1].mean() / 240 < 0.45  # eyes on the news eye line
    # arms hang: in the shot's lower half the clothes stay within the shoulders' width
    assert np.abs(shown[:, 0] - 160).max() < 160


@pytest.mark.slow
def test_no_hair_hides_the_avatars_hair(rpm_bare):
    from mimika.newsreader.pipeline import render_frames
    from mimika.tracks import AUTrack

    _, head, rig = rpm_bare
    assert objects_of_role(head, "hair") == ["Wolf3D_Hair"]
    track = AUTrack(np.zeros((1, 1)), ("AU12",), 25.0)
    on, off = (next(render_frames(rig, track, size=(160, 120), hair=h, skin_shader=False))
               for h in (True, False))
    changed = np.abs(on.astype(int) - off.astype(int)).sum(2) > 30
    assert changed.sum() > 300, changed.sum()
    rows = np.flatnonzero(changed.any(1))
    assert rows.min() < 40  # the top of the head, where the hair was


# --- eyes turned once --------------------------------------------------------------------


def _eye_turn(head, rig, au: str, eye: str) -> float:
    o = head[eye]
    pupil = np.unique(np.concatenate([p.faces.reshape(-1) for p in o.parts
                                      if p.material == "pupil"]))
    a = o.vertices[pupil].mean(0) - o.pivot
    b = rig.deform({au: 1.0})[eye][pupil].mean(0) - o.pivot
    return float(np.degrees(np.arccos(a @ b / np.linalg.norm(a) / np.linalg.norm(b))))


@pytest.mark.slow
def test_eye_turns_the_same_in_pose_and_export(amara_glb, tmp_path, capsys):
    """Eye meshes that carry eyeLook morphs (as Ready Player Me's do) turn once — 30° by
    rotation, not 30° plus the morph's 26° — in pose and in the exported GLB alike."""
    p = ready_player_me(amara_glb, tmp_path / "rpm_eyes.glb", eye_morphs=True)
    head, rig = load_head(p)
    out = tmp_path / "out.glb"
    write_gltf(out, rig)
    head2, rig2 = load_head(out)
    for au in ("AU61", "AU62", "AU63", "AU64"):
        pose = _eye_turn(head, rig, au, "EyeLeft")
        assert pose == pytest.approx(30.0, abs=0.5), au
        assert _eye_turn(head2, rig2, au, "EyeLeft") == pytest.approx(pose, abs=0.5), au
    rows = [r for r in head.meta["morphs"] if r["morph"] == "eyeLookOutLeft"]
    assert rows and rows[0]["kind"] == "eye turn"
    # inspect, pose and render agree on what is modelled
    assert main(["heads", "--inspect", str(p)]) == 0
    listed = [ln.split()[0] for ln in capsys.readouterr().out.splitlines()
              if ln[:2] == "AU" and len(ln.split()) > 1 and ln.split()[1] in (
                  "facs", "arkit", "viseme", "vrm", "fields", "mixed", "rotation")]
    assert listed == list(rig.supported_bilateral)
    assert main(["pose", "--head", str(p), "--au", "AU61=1", "--size", "96x72", "-o",
                 str(tmp_path / "eyes.png"), "-q"]) == 0


# --- roles from shape ---------------------------------------------------------------------


@pytest.mark.slow
def test_roles_from_shape_when_names_say_nothing(amara_glb, tmp_path):
    p = ready_player_me(amara_glb, tmp_path / "g.glb", with_glasses=True)
    g = Glb(p)
    for key in ("nodes", "meshes", "materials"):
        for i, it in enumerate(g.doc[key]):
            if key != "nodes" or "mesh" in it:
                it["name"] = f"Object_{i}"
    head, _ = load_head(g.save(tmp_path / "anon.glb"))
    got = sorted(head.meta["roles"].values())
    assert got == sorted(["skin", "eyes", "eyes", "teeth", "teeth", "hair", "brows",
                          "lashes", "body", "glasses"])


# --- VRM 0.x and 1.0 ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def builtin_glb(tmp_path_factory):
    p = tmp_path_factory.mktemp("vrm") / "builtin.glb"
    write_gltf(p, load_head("builtin", resolution=0)[1])
    return p


def _lid_gap(head, pos=None) -> float:
    lm = head.landmark_points(pos)
    return float(np.mean(lm[[37, 38, 43, 44], 1] - lm[[41, 40, 47, 46], 1]))


@pytest.mark.parametrize("version", [0, 1])
def test_vrm_bones_expressions_lookat_and_mtoon(builtin_glb, tmp_path, version):
    p = vrm(builtin_glb, tmp_path / f"v{version}.vrm", version)
    head, rig = load_head(p)
    _, own = load_head(builtin_glb)
    cover = head.meta["coverage"]
    assert head.meta["head_bone"] == "head"
    # blink closes the lids, as the morph it binds does on the original
    assert cover["AU45"] == ("arkit", "VRM blink")
    assert _lid_gap(head) > 0.3 and _lid_gap(head, rig.deform({"AU45": 1.0})) < 0.05
    a = rig.deform({"AU45": 1.0})["Face"] - head["Face"].vertices
    b = own.deform({"AU45": 1.0})["skin"] - own.head["skin"].vertices
    assert np.abs(np.linalg.norm(a, axis=1).max() - np.linalg.norm(b, axis=1).max()) < 0.02
    # emotions shared by their AUs, vowels as visemes
    happy = "happy" if version else "joy"
    assert cover["AU06"] == cover["AU12"] == ("vrm", f"VRM {happy}")
    assert cover["AU01"][0] == cover["AU02"][0] == cover["AU04"][0] == "vrm"
    assert cover["AU26"] == ("viseme", "VRM " + ("aa" if version else "a"))
    both = rig.deform({"AU06": 1.0, "AU12": 1.0})["Face"] - head["Face"].vertices
    ref = own.deform({"AU06": 1.0, "AU12": 1.0})["skin"] - own.head["skin"].vertices
    assert np.linalg.norm(both, axis=1).max() == pytest.approx(
        np.linalg.norm(ref, axis=1).max(), rel=0.03)
    # eye bones turn as the lookAt range maps say (30° gaze → 30/90 · 10°)
    top, scale = LOOK_RANGE
    pivot = head["eye_L"].pivot
    v0 = head["eye_L"].vertices - pivot
    v1 = rig.deform({"AU61": 1.0})["eye_L"] - pivot
    ang = np.degrees(np.arccos(np.clip((v0 * v1).sum(1) / np.linalg.norm(v0, axis=1)
                                       / np.linalg.norm(v1, axis=1), -1, 1))).max()
    assert ang == pytest.approx(30 / top * scale, abs=0.05)
    # VRoid's material names: the eye white leaves the face mesh and does not turn
    roles = head.meta["roles"]
    assert roles["Face"] == "skin" and roles["brows"] == "brows"
    assert roles["Face.eyes.L"] == roles["Face.eyes.R"] == "eyes"
    assert head["Face.eyes.L"].pivot is None
    # MToon: drawn with the flat toon material in the file's colour
    assert {pt.material for o in head.objects for pt in o.parts} == {"toon"}
    skin_rgb = head["Face"].parts[0].texture.image[0, 0, :3]
    assert skin_rgb[0] > skin_rgb[2] + 40  # the skin's own colour, not white
