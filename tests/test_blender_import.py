"""Our glTF as headless Blender imports it (Debian's blender; skipped with the reason when it
is not installed): shape keys, actions, armature, frame rate and range."""

import numpy as np
import pytest

from blender_app import blender_import, needs_blender
from mimika.io.gltf import write_gltf
from mimika.tracks import AUTrack

pytestmark = needs_blender


@pytest.fixture(scope="module")
def glb(tmp_path_factory):
    from mimika.face.heads import load_head

    rig = load_head("builtin", resolution=0)[1]
    t = np.linspace(0, 1, 31)[:, None]
    track = AUTrack(np.hstack([t, 1 - t, 0.5 * t, 0.3 * t]), ("AU12", "AU26", "AU52", "AU61"),
                    25)
    p = tmp_path_factory.mktemp("blender") / "head.glb"
    write_gltf(p, rig, track)
    return p, rig, track


def test_blender_imports_shape_keys_actions_and_range(glb):
    path, _, track = glb
    rep = blender_import(path, mimika_timing=True)
    scene = rep["scene"]
    assert (scene["fps"], scene["fps_base"]) == (25, 1.0)
    assert (scene["frame_start"], scene["frame_end"]) == (0, track.n_frames - 1)
    assert not [o["name"] for o in rep.objects() if o["name"].endswith(".001")]
    skin = rep.object("skin")
    assert skin["type"] == "MESH" and skin["parent"] == "neck-head"
    assert {"AU12", "AU12L", "AU12R", "AU26"} <= set(skin["shape_keys"])
    assert skin["modifiers"] == ["ARMATURE"] and set(skin["vertex_groups"]) == {"neck", "head"}
    shape = rep.action(skin["shape_key_action"])
    last = track.n_frames - 1
    assert shape["id_root"] == "KEY" and shape["frame_range"] == pytest.approx([0, last])
    assert 'key_blocks["AU12"].value' in shape["data_paths"]
    arma = rep.object("neck-head")
    assert arma["bones"] == ["neck", "head"]
    assert rep.action(arma["action"])["frame_range"] == pytest.approx([0, last])
    assert rep.action(rep.object("eye_L")["action"])["fcurves"] == 4  # a rotation quaternion


def test_plain_import_carries_the_hint(glb):
    path, _, track = glb
    rep = blender_import(path)  # File ▸ Import ▸ glTF without the recipe
    props = rep["scene"]["props"]
    assert props["fps"] == 25 and props["frame_end"] == track.n_frames - 1
    assert rep["scene"]["fps"] == 24  # Blender's default: why the docs say to set it first
