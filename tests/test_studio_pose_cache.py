"""Pose exports under load (issue 27): what a head's export derives from arrays that cannot
change — texture PNGs, morph targets and their bounds — is computed once, not in every export
(2.4 of a character's 2.6 s), and the last few poses are kept whole. Load figures (30 clients:
p50/p99, 503s): bench/bench_studio_load.py."""

from __future__ import annotations

import gc
import json
import struct

import numpy as np
import pytest

from mimika.io import gltf


def test_a_frozen_texture_is_encoded_once_and_forgotten_with_it(monkeypatch):
    img = np.random.default_rng(0).integers(0, 255, (64, 64, 4), np.uint8)
    img.setflags(write=False)
    calls = []
    from PIL import Image

    save = Image.Image.save
    monkeypatch.setattr(Image.Image, "save", lambda *a, **k: (calls.append(1), save(*a, **k)))
    a = gltf._png(img, True)
    b = gltf._png(img, True)
    assert a is b and len(calls) == 1
    assert gltf._png(img, False) != a and len(calls) == 2  # with its alpha: another PNG
    key = (id(img), "png1")
    assert key in gltf._DERIVED
    del img
    gc.collect()
    assert key not in gltf._DERIVED


def test_a_writable_image_or_a_view_is_not_kept():
    img = np.zeros((8, 8, 3), np.uint8)
    gltf._png(img, False)
    view = np.zeros((8, 8, 4), np.uint8)[:, :, :3]
    view.setflags(write=False)  # its base can still change
    gltf._png(view, False)
    assert (id(img), "png0") not in gltf._DERIVED and (id(view), "png0") not in gltf._DERIVED


@pytest.fixture(scope="module")
def state(tmp_path_factory):
    from mimika.studio.state import StudioState

    d = tmp_path_factory.mktemp("studio")
    return StudioState(d / "projects", head="builtin", library_path=d / "lib.json")


def _doc(glb: bytes) -> dict:
    return json.loads(glb[20:20 + struct.unpack("<I", glb[12:16])[0]])


def test_pose_exports_are_kept_per_head_and_pose(state, monkeypatch):
    from mimika.studio import state as mod

    built = []
    real = mod.gltf_bytes
    monkeypatch.setattr(mod, "gltf_bytes", lambda *a, **k: (built.append(1), real(*a, **k))[1])
    smile = state.pose_glb(None, {"AU12": 0.8}, fps=30, label="smile")
    assert state.pose_glb("builtin", {"AU12": 0.8}, fps=30, label="smile") is smile
    assert len(built) == 1
    frown = state.pose_glb(None, {"AU15": 0.8}, fps=30, label="smile")
    assert frown != smile and len(built) == 2
    assert _doc(smile)["scenes"][0]["name"] == "smile"
    for k in range(mod.POSES):  # the oldest poses go
        state.pose_glb(None, {"AU01": 0.1 * (k + 1)}, fps=30, label="x")
    state.pose_glb(None, {"AU12": 0.8}, fps=30, label="smile")
    assert len(built) == 3 + mod.POSES
    assert len(state._poses) == mod.POSES


def test_a_character_export_reuses_its_morph_targets_byte_for_byte():
    from mimika.face.heads import load_head
    from mimika.io.gltf_skinned import _targets
    from mimika.tracks import AUTrack
    from mimika.web.glb import gltf_bytes

    _, rig = load_head("amara")
    pose = AUTrack.constant({"AU12": 0.6}, n_frames=1, fps=30)
    first = gltf_bytes(rig, pose)
    codes, morphs = _targets(rig)
    assert _targets(rig)[1] is morphs and codes
    assert all(not d.flags.writeable for ts in morphs.values() for _, d in ts)
    assert gltf_bytes(rig, pose) == first
