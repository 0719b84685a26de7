"""A mimika export recompressed as people ship avatars (glTF-Transform: WebP textures,
meshopt + quantized geometry) reads, renders in colour and animates like the original."""

from __future__ import annotations

import json
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from mimika.cli import main
from mimika.face.heads import load_head
from mimika.io.gltf import write_gltf

GLTF_TRANSFORM = (Path(__file__).resolve().parents[1] / "tools" / "node_modules" / ".bin"
                  / "gltf-transform")
pytestmark = pytest.mark.skipif(not GLTF_TRANSFORM.exists(),
                                reason="@gltf-transform/cli not installed (scripts/setup-node.sh)")


def _json(p: Path) -> dict:
    d = p.read_bytes()
    return json.loads(d[20:20 + struct.unpack_from("<I", d, 12)[0]])


@pytest.fixture(scope="module")
def packed(tmp_path_factory):
    d = tmp_path_factory.mktemp("packed")
    write_gltf(d / "plain.glb", load_head("amara")[1])
    for cmd, a, b in (("webp", "plain", "webp"), ("meshopt", "webp", "packed")):
        subprocess.run([str(GLTF_TRANSFORM), cmd, str(d / f"{a}.glb"), str(d / f"{b}.glb")],
                       check=True, capture_output=True, timeout=300)
    return d / "plain.glb", d / "packed.glb"


@pytest.mark.slow
def test_packed_avatar_reads_renders_and_morphs(packed, tmp_path, capsys):
    plain, p = packed
    assert {"EXT_meshopt_compression", "KHR_mesh_quantization", "EXT_texture_webp"} <= set(
        _json(p)["extensionsRequired"])
    h0, r0 = load_head(plain)
    h1, r1 = load_head(p)
    assert [o.name for o in h1.objects] == [o.name for o in h0.objects]
    skin0, skin1 = h0[h0.landmark_object], h1[h1.landmark_object]
    # WebP textures decoded: the skin keeps its colour (not the white of a lost texture)
    tex = [pt.texture.image for pt in skin1.parts if pt.texture is not None]
    assert tex and tex[0].shape[0] > 1 and tex[0][..., :3].mean() < 200
    for aus in ({"AU26": 1.0}, {"AU12": 1.0}):  # the morphs move the same (vertices reordered)
        m0 = np.linalg.norm(r0.deform(aus)[skin0.name] - skin0.vertices, axis=1)
        m1 = np.linalg.norm(r1.deform(aus)[skin1.name] - skin1.vertices, axis=1)
        assert m1.max() == pytest.approx(m0.max(), rel=0.05)
        assert np.sort(m1)[-500:].mean() == pytest.approx(np.sort(m0)[-500:].mean(), rel=0.05)
    out = tmp_path / "p.png"
    assert main(["pose", "--head", str(p), "--au", "AU26=1", "--size", "160x120", "-o",
                 str(out)]) == 0
    img = np.asarray(Image.open(out).convert("RGB")).astype(int)
    face = img[20:100, 50:110]
    assert (face.min(2) > 245).mean() < 0.05 and face.std() > 10  # coloured, not flat white
    assert "warn" not in capsys.readouterr().err.lower()
