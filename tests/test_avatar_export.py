"""Faithful export (issue 26, item 5): ``render --head avatar.glb … -o out.glb`` writes the
avatar again — materials, textures (their own format, each image once), skeleton, node
names, its own morph names and extensions kept — with the animation on its own morphs and
joints, and morphs added only for what it lacks."""

from __future__ import annotations

import json
import shutil
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest

from avatar_files import vrm
from avatar_kept import JOINTS, arkit_avatar, posed
from blender_app import blender_import, needs_blender
from mimika.cli import main
from mimika.face.heads import load_head
from mimika.face.heads.gltf_export import avatar_export
from mimika.face.morphs import ARKIT_52
from mimika.io.gltf import write_gltf
from mimika.io.gltf_avatar import write_avatar_gltf
from mimika.io.gltf_source import load_source
from mimika.tracks import AUTrack

TOOLS = Path(__file__).resolve().parents[1] / "tools"
NODE = shutil.which("node")
HAS_VALIDATOR = NODE is not None and (TOOLS / "node_modules" / "gltf-validator").is_dir()
GLTF_TRANSFORM = TOOLS / "node_modules" / ".bin" / "gltf-transform"
#: opens the jaw from 0.2 s to 1.2 s, turns the head and the eyes, smiles
SCRIPT = ('<speak><m:aus set="AU26=1" start="0.2s" dur="1s"/>'
          '<m:turn dir="left" start="1s" dur="1s"/><m:gaze dir="left" start="0.5s" dur="1s"/>'
          '<m:expr name="happiness" start="1.5s" dur="1s"/>Hello there, good evening.</speak>')


def _node(script: str, path: Path) -> dict:
    r = subprocess.run([NODE, str(TOOLS / script), str(path)], capture_output=True, text=True,
                       cwd=TOOLS, timeout=180)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def _doc(path: Path) -> tuple[dict, bytes]:
    src = load_source(path)
    return src.doc, src.buffer(0)


def _images(path: Path) -> list[tuple[str, str, int]]:
    src = load_source(path)
    return [(im.get("name", ""), im["mimeType"], len(src.image_bytes(i)))
            for i, im in enumerate(src.doc.get("images", []))]


def _weights(path: Path, node_name: str, morph: str) -> np.ndarray:
    """The animated weight of ``morph`` on node ``node_name`` per key."""
    from mimika.face.heads.gltf_scene import _Reader

    r = _Reader(path)
    doc = r.src.doc
    ni = next(i for i, n in enumerate(doc["nodes"]) if n.get("name") == node_name)
    names = doc["meshes"][doc["nodes"][ni]["mesh"]]["extras"]["targetNames"]
    anim = doc["animations"][0]
    ch = next(c for c in anim["channels"] if c["target"] == {"node": ni, "path": "weights"})
    s = anim["samplers"][ch["sampler"]]
    keys = doc["accessors"][s["input"]]["count"]
    return r.accessor(s["output"]).reshape(keys, len(names))[:, names.index(morph)]


@pytest.fixture(scope="module")
def builtin_glb(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("kept") / "builtin.glb"
    write_gltf(p, load_head("builtin", resolution=0)[1])
    return p


@pytest.fixture(scope="module")
def avatar(builtin_glb) -> Path:
    return arkit_avatar(builtin_glb, builtin_glb.with_name("avatar.glb"))


@pytest.fixture(scope="module")
def rendered(avatar) -> Path:
    script = avatar.with_name("s.xml")
    script.write_text(SCRIPT)
    out = avatar.with_name("out.glb")
    assert main(["render", "--head", str(avatar), str(script), "-o", str(out), "-q"]) == 0
    return out


def test_export_keeps_materials_textures_skeleton_and_names(avatar, rendered):
    a, _ = _doc(avatar)
    b, _ = _doc(rendered)
    # materials as they were: names, PBR factors and maps, MASK, doubleSided, extensions
    assert b["materials"] == a["materials"]
    names = [m["name"] for m in b["materials"]]
    assert "Wolf3D_Skin" in names and "skin" not in names
    brows = next(m for m in b["materials"] if m["name"] == "Wolf3D_Brows")
    assert (brows["alphaMode"], brows["alphaCutoff"], brows["doubleSided"]) == ("MASK", 0.35,
                                                                               True)
    assert b["textures"] == a["textures"] and b["samplers"] == a["samplers"]
    assert set(b["extensionsUsed"]) == set(a["extensionsUsed"])
    # textures in their own format and size; the JPEG two textures show is stored once
    assert _images(rendered) == _images(avatar)
    assert _images(rendered)[0][1] == "image/jpeg"
    assert len({im["bufferView"] for im in b["images"]}) == len(b["images"]) == 4
    # the skeleton and the node hierarchy, names and inverse bind matrices
    assert [n.get("name") for n in b["nodes"]] == [n.get("name") for n in a["nodes"]]
    assert [n.get("children") for n in b["nodes"]] == [n.get("children") for n in a["nodes"]]
    assert [s["joints"] for s in b["skins"]] == [s["joints"] for s in a["skins"]]
    assert [b["nodes"][j]["name"] for j in b["skins"][0]["joints"]] == list(JOINTS)
    src_a, src_b = load_source(avatar), load_source(rendered)
    for sa, sb in zip(a["skins"], b["skins"], strict=True):
        va = a["accessors"][sa["inverseBindMatrices"]]["bufferView"]
        vb = b["accessors"][sb["inverseBindMatrices"]]["bufferView"]
        assert src_a.view(va) == src_b.view(vb)


def test_export_animates_the_avatars_own_morphs(avatar, rendered):
    a, _ = _doc(avatar)
    b, _ = _doc(rendered)
    for ma, mb in zip(a["meshes"], b["meshes"], strict=True):
        assert mb["name"] == ma["name"]
        own = ma.get("extras", {}).get("targetNames", [])
        new = mb.get("extras", {}).get("targetNames", [])
        assert new[:len(own)] == own  # its own morphs first, as they were
        assert set(new[len(own):]) <= set(ARKIT_52)  # only shapes it lacked, ARKit-named
    # the script opens the jaw: jawOpen rises on the face, teeth and tongue; at rest first
    for node in ("Wolf3D_Head", "Wolf3D_TeethLower", "Wolf3D_Tongue"):
        w = _weights(rendered, node, "jawOpen")
        assert w[0] == 0 and w.max() > 0.5, node
    assert _weights(rendered, "Wolf3D_Head", "mouthSmileLeft").max() > 0.3
    assert not np.any(_weights(rendered, "Wolf3D_Head", "customSmirk"))  # not an AU: still
    # the empty mouthFunnel took the generated shape in its own slot
    skin = next(m for m in b["meshes"] if m["name"] == "Wolf3D_Head")
    names = skin["extras"]["targetNames"]
    assert names.count("mouthFunnel") == 1
    filled = b["accessors"][skin["primitives"][0]["targets"][names.index("mouthFunnel")][
        "POSITION"]]
    assert filled.get("sparse", {}).get("count", 0) > 100
    assert "Wolf3D_Head/mouthFunnel" in b["extras"]["mimika"]["filled_morphs"]
    # head and eyes turn on the file's own joints
    anim = b["animations"][0]
    turned = {b["nodes"][c["target"]["node"]]["name"] for c in anim["channels"]
              if c["target"]["path"] == "rotation"}
    assert turned == {"Head", "LeftEye", "RightEye"}


def test_export_moves_as_the_rig(avatar):
    """A player's view of the export (weights, skinning, joint turns) matches the rig's
    deformation: exact for shapes and eyes; head turns differ only where the neck blends
    (linear-blend skinning against the rig's bending neck)."""
    head, rig = load_head(avatar)
    chans = ["AU26", "AU12L", "AU02", "AU61", "AU64", "AU06", "AU45", "AU51"]
    vals = np.r_[np.zeros((1, len(chans))), np.eye(len(chans))].astype(np.float32)
    track = AUTrack(vals, chans, 25.0)
    out = write_avatar_gltf(avatar.with_name("moves.glb"), avatar_export(rig, track), track)
    pos = rig.deform_batch(track.values, track.channels)
    frame = head.meta["gltf"].frame
    p0 = posed(out, 0)
    for k, code in enumerate(chans, 1):
        p = posed(out, k)
        for o in head.objects:
            got = frame.apply(p[o.name]) - frame.apply(p0[o.name])
            want = pos[o.name][k] - pos[o.name][0]
            err = np.linalg.norm(got - want, axis=1).max()
            moved = np.linalg.norm(want, axis=1).max()
            assert err <= (0.05 * moved if code == "AU51" else 1e-3), (code, o.name, err)


@pytest.mark.parametrize("version", [0, 1])
def test_vrm_export_keeps_the_vrm_and_drives_its_expressions(builtin_glb, tmp_path, version):
    p = vrm(builtin_glb, tmp_path / f"v{version}.vrm", version)
    head, rig = load_head(p)
    track = AUTrack(np.array([[0.0], [1.0]], np.float32), ["AU27"], 25.0)
    out = write_avatar_gltf(tmp_path / "out.gltf", avatar_export(rig, track), track)
    a, _ = _doc(p)
    b, _ = _doc(out)
    key = "VRMC_vrm" if version else "VRM"
    assert b["extensions"][key] == a["extensions"][key]
    assert b["extensionsUsed"] == a["extensionsUsed"]
    # 'aa' binds one morph of the face: AU27 drives it, no AU morph is added for it
    binds = (a["extensions"][key]["expressions"]["preset"]["aa"]["morphTargetBinds"]
             if version else next(g for g in a["extensions"][key]["blendShapeMaster"][
                 "blendShapeGroups"] if g["presetName"] == "a")["binds"])
    face = b["nodes"][head.meta["gltf"].scene.meshes[0].node]["name"]
    assert _weights(out, face, f"morph{binds[0]['index']}").tolist() == [0.0, 1.0]
    if HAS_VALIDATOR:
        assert _node("validate.mjs", out)["numErrors"] == 0


@pytest.mark.skipif(not HAS_VALIDATOR, reason="gltf-validator not installed "
                                              "(scripts/setup-node.sh)")
def test_export_passes_the_validator_and_loads_in_three(avatar, rendered):
    rep = _node("validate.mjs", rendered)
    assert rep["numErrors"] == 0, rep["messages"]
    three = _node("three_load.mjs", rendered)
    src = _node("three_load.mjs", avatar)
    assert three["bones"] == len(JOINTS) and three["textured"] == src["textured"] > 0
    assert set(src["morphTargetNames"]) <= set(three["morphTargetNames"])
    assert three["animations"] == 1 and three["tracks"] >= 5


@pytest.mark.skipif(not GLTF_TRANSFORM.exists() or not HAS_VALIDATOR,
                    reason="@gltf-transform/cli not installed (scripts/setup-node.sh)")
def test_packed_and_gltf_avatars_keep_their_images(avatar, rendered, tmp_path):
    webp, packed = tmp_path / "webp.glb", tmp_path / "packed.glb"
    for cmd, a, b in (("webp", avatar, webp), ("meshopt", webp, packed)):
        subprocess.run([str(GLTF_TRANSFORM), cmd, str(a), str(b)], check=True,
                       capture_output=True, timeout=300)
    script = rendered.with_name("s.xml")
    out = tmp_path / "out.glb"
    assert main(["render", "--head", str(packed), str(script), "-o", str(out), "-q"]) == 0
    a, _ = _doc(packed)
    b, _ = _doc(out)
    assert _images(out) == _images(packed)
    assert {m for _, m, _ in _images(out)} == {"image/webp"}
    assert "EXT_texture_webp" in b["extensionsUsed"] and "EXT_texture_webp" in b[
        "extensionsRequired"]
    assert "EXT_meshopt_compression" in a["extensionsRequired"]
    assert "EXT_meshopt_compression" not in b["extensionsUsed"]
    assert b["materials"] == a["materials"]
    assert _weights(out, "Wolf3D_Head", "jawOpen").max() > 0.5
    assert _node("validate.mjs", out)["numErrors"] == 0
    assert _node("three_load.mjs", out)["bones"] == len(JOINTS)
    # a .gltf with its .bin and images beside it: the images are embedded, as they were
    folder = tmp_path / "gltf"
    folder.mkdir()
    subprocess.run([str(GLTF_TRANSFORM), "copy", str(avatar), str(folder / "a.gltf")],
                   check=True, capture_output=True, timeout=300)
    assert (folder / "baseColor_1.jpg").is_file()
    out = tmp_path / "from_gltf.glb"
    assert main(["render", "--head", str(folder / "a.gltf"), str(script), "-o", str(out),
                 "-q"]) == 0
    assert sorted(_images(out)) == sorted(_images(folder / "a.gltf"))
    assert "image/jpeg" in {m for _, m, _ in _images(out)}
    assert _node("validate.mjs", out)["numErrors"] == 0


def test_heads_without_a_file_keep_the_mimika_layout():
    _, rig = load_head("builtin", resolution=0)
    assert avatar_export(rig, None) is None


def test_generic_export_stores_a_shared_image_once(tmp_path):
    """A head whose materials share one texture image (the eyes' sclera and iris) stores
    it once in mimika's own layout too."""
    import copy

    from mimika.face.head import Texture

    head, rig = copy.deepcopy(load_head("builtin", resolution=0))  # the cached head stays as it is
    img = np.full((4, 4, 3), 200, np.uint8)
    img.setflags(write=False)
    for o in head.objects:
        if o.category == "eyes":
            object.__setattr__(o, "parts", tuple(
                type(pt)(pt.material, pt.faces, Texture(img, "eye"), pt.alpha_mode)
                for pt in o.parts))
            object.__setattr__(o, "uvs", np.zeros((o.n_vertices, 2)))
    out = write_gltf(tmp_path / "h.glb", rig)
    d = out.read_bytes()
    doc = json.loads(d[20:20 + struct.unpack_from("<I", d, 12)[0]])
    assert len(doc["images"]) == 1 and len(doc["textures"]) == 1


@needs_blender
def test_blender_imports_the_export(avatar, rendered):
    """Headless Blender (skipped without it): the file's armature and bones, its materials
    with their images, and shape keys under the avatar's own names driven by the action."""
    rep = blender_import(rendered, mimika_timing=True)
    arma = rep.objects("ARMATURE")
    assert len(arma) == 1 and arma[0]["bones"] == list(JOINTS)
    assert rep.action(arma[0]["action"])["fcurves"] == 12  # Head, LeftEye, RightEye
    mesh = {o["mesh"]: o for o in rep.objects("MESH")}
    face = mesh["Wolf3D_Head"]
    assert {"jawOpen", "mouthSmileLeft", "customSmirk", "mouthFunnel", "browOuterUpLeft"} <= set(
        face["shape_keys"])
    assert face["vertex_groups"] == list(JOINTS) and face["modifiers"] == ["ARMATURE"]
    assert 'key_blocks["jawOpen"].value' in rep.action(face["shape_key_action"])["data_paths"]
    assert face["materials"][:2] == ["Wolf3D_Skin", "Wolf3D_Lips"]
    mats = {m["name"]: m for m in rep["materials"]}
    assert mats["Wolf3D_Skin"]["textures"] == ["skin_color", "skin_normal", "skin_orm"]
    assert mats["Wolf3D_Brows"]["textures"] == ["brows"]


def test_studio_download_keeps_the_avatar(avatar, tmp_path):
    """The studio's GLB download of a pose (and of a project) takes the same path; the
    page's own head.glb keeps mimika's layout (its viewer drives AU morphs by name)."""
    from mimika.studio.state import StudioState

    st = StudioState(tmp_path / "projects", head=str(avatar))
    out = tmp_path / "pose.glb"
    out.write_bytes(st.pose_glb(None, {"AU26": 1.0}, fps=25, label="jaw"))
    assert _doc(out)[0]["materials"] == _doc(avatar)[0]["materials"]
    assert _weights(out, "Wolf3D_Head", "jawOpen").tolist() == pytest.approx([0.55, 0.55])
    page = tmp_path / "page.glb"
    page.write_bytes(st.glb()[0])
    assert "AU26" in json.dumps(_doc(page)[0]["meshes"])


def test_a_changed_avatar_file_is_refused(avatar, tmp_path):
    """The export writes the file again by the indices read when the head loaded: a file
    changed since (the studio runs for hours) is one clear error, not a broken GLB."""
    from mimika.errors import DataError

    p = tmp_path / "a.glb"
    p.write_bytes(avatar.read_bytes())
    _, rig = load_head(p)
    p.write_bytes(avatar.read_bytes() + b"    ")
    with pytest.raises(DataError, match="changed since the head was loaded"):
        avatar_export(rig, None)


def test_a_vrm_avatar_exports_as_vrm(builtin_glb, avatar, rendered, tmp_path, capsys):
    p = vrm(builtin_glb, tmp_path / "v.vrm", 1)
    script = rendered.with_name("s.xml")
    out = tmp_path / "out.vrm"
    assert main(["render", "--head", str(p), str(script), "-o", str(out), "-q"]) == 0
    assert out.read_bytes()[:4] == b"glTF"
    assert _doc(out)[0]["extensions"]["VRMC_vrm"] == _doc(p)[0]["extensions"]["VRMC_vrm"]
    # .vrm out of a plain GLB avatar: one line, exit 2, before any work
    assert main(["render", "--head", str(avatar), str(script), "-o",
                 str(tmp_path / "x.vrm")]) == 2
    err = capsys.readouterr().err
    assert "is for a VRM avatar" in err and len(err.strip().splitlines()) == 1
