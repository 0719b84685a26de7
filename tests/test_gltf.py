"""glTF/GLB export: checked by the Khronos glTF-Validator and loaded by three.js (node)."""

import json
import shutil
import struct
import subprocess
from pathlib import Path

import pytest

from mimika.io.gltf import build_gltf, write_gltf
from mimika.markup import parse_script
from mimika.timeline import sample

TOOLS = Path(__file__).resolve().parents[1] / "tools"
NODE = shutil.which("node")


def _node_ready() -> str | None:
    if NODE is None:
        return "node is not installed"
    if not (TOOLS / "node_modules" / "gltf-validator").is_dir():
        r = subprocess.run(["bash", str(TOOLS.parent / "scripts" / "setup-node.sh")],
                           capture_output=True, text=True)
        if r.returncode or not (TOOLS / "node_modules" / "gltf-validator").is_dir():
            return f"tools/node_modules missing (scripts/setup-node.sh failed: {r.stderr[-200:]})"
    return None


SKIP = _node_ready()
needs_node = pytest.mark.skipif(SKIP is not None, reason=SKIP or "")


@pytest.fixture(scope="module")
def small_rig():
    from mimika.face.heads import load_head

    return load_head("builtin", resolution=0)[1]


@pytest.fixture(scope="module")
def track():
    tl = parse_script('<speak><m:expr name="happiness">Hello there</m:expr> <m:nod/>'
                      '<m:gaze dir="left" start="0.5s"/><m:turn dir="right" start="1s"/>'
                      '<m:aus set="AU12L=0.7" start="1.5s"/></speak>')
    return sample(tl, fps=25)


@pytest.fixture(scope="module")
def glb(tmp_path_factory, small_rig, track):
    p = tmp_path_factory.mktemp("gltf") / "head.glb"
    write_gltf(p, small_rig, track)
    return p


def _node(script: str, path: Path) -> dict:
    r = subprocess.run([NODE, str(TOOLS / script), str(path)], capture_output=True, text=True,
                       cwd=TOOLS, timeout=120)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def test_glb_structure(glb, small_rig, track):
    data = glb.read_bytes()
    magic, version, length = struct.unpack("<III", data[:12])
    assert (magic, version, length) == (0x46546C67, 2, len(data))
    doc, _ = build_gltf(small_rig, track)
    skin = next(m for m in doc["meshes"] if m["name"] == "skin")
    names = skin["extras"]["targetNames"]
    assert {"AU12", "AU12L", "AU12R", "AU26"} <= set(names)
    assert not {"AU51", "AU61"} & set(names)  # rotations are nodes, not morphs
    assert {n["name"] for n in doc["nodes"]} >= {"neck", "head", "eye_L", "eye_R"}
    mats = {m["name"] for m in doc["materials"]}
    assert {"skin", "lips", "iris", "sclera", "teeth"} <= mats


@needs_node
def test_glb_passes_khronos_validator(glb):
    rep = _node("validate.mjs", glb)
    assert rep["numErrors"] == 0, rep["messages"]
    assert rep["numWarnings"] == 0, rep["messages"]


@needs_node
def test_gltf_text_passes_khronos_validator(tmp_path, small_rig, track):
    p = write_gltf(tmp_path / "head.gltf", small_rig, track)
    rep = _node("validate.mjs", p)
    assert rep["numErrors"] == 0, rep["messages"]


@needs_node
def test_glb_plays_in_threejs(glb, small_rig, track):
    doc, _ = build_gltf(small_rig, None)
    n_targets = max(len(m.get("weights", [])) for m in doc["meshes"])
    out = _node("three_load.mjs", glb)
    assert out["morphTargets"] == n_targets
    assert "AU12" in out["morphTargetNames"]
    assert out["animations"] == 1
    assert out["duration"] == pytest.approx((track.n_frames - 1) / track.fps, abs=1e-4)
    assert out["skinned"] > 0


def test_timing_extras_and_node_names_for_blender(small_rig, track):
    doc, _ = build_gltf(small_rig, track)
    last = track.n_frames - 1
    want = {"fps": 25.0, "frame_start": 0, "frame_end": last, "duration_s": last / 25}
    assert doc["scenes"][0]["extras"] == want == doc["animations"][0]["extras"]
    names = {n["name"] for n in doc["nodes"]}
    meshes = {m["name"] for m in doc["meshes"]}
    # a skinned node with morph animation: Blender splits it into an empty (node name) and a
    # mesh object (mesh name), so the two differ and the mesh keeps the object's name
    assert {"skin_morphs", "brows_morphs"} <= names and "skin" in meshes
    skinned = [n for n in doc["nodes"] if "skin" in n and "mesh" in n]
    assert all(n["name"] != doc["meshes"][n["mesh"]]["name"] for n in skinned
               if doc["meshes"][n["mesh"]].get("weights"))
    static, _ = build_gltf(small_rig, None)
    assert "skin" in {n["name"] for n in static["nodes"]}  # nothing animated: no split
    assert "extras" not in static["scenes"][0]


def test_bad_extension(tmp_path, small_rig):
    with pytest.raises(Exception, match=r"\.glb or \.gltf"):
        write_gltf(tmp_path / "x.obj", small_rig)


def test_morph_targets_store_only_the_vertices_they_move(small_rig):
    """Sparse targets: an AU moves part of the head, so only those vertices are written (the
    file is about half the size); decoded, a target is the rig's displacement at τ = 1."""
    import numpy as np

    from mimika.io.gltf import SCALE

    doc, binary = build_gltf(small_rig, None)
    acc, views = doc["accessors"], doc["bufferViews"]

    def array(view: int, dtype, width: int = 1) -> np.ndarray:
        v = views[view]
        return np.frombuffer(binary, dtype, count=v["byteLength"] // np.dtype(dtype).itemsize,
                             offset=v["byteOffset"]).reshape(-1, width)

    skin = next(m for m in doc["meshes"] if m["name"] == "skin")
    stored = dense = 0
    for name, t in zip(skin["extras"]["targetNames"], skin["primitives"][0]["targets"],
                       strict=True):
        a = acc[t["POSITION"]]
        assert "bufferView" not in a and 0 < a["sparse"]["count"] < a["count"], name
        stored += 16 * a["sparse"]["count"]
        dense += 12 * a["count"]
        if name == "AU12":
            got = np.zeros((a["count"], 3), np.float32)
            ids = array(a["sparse"]["indices"]["bufferView"], np.uint32)[:, 0]
            got[ids] = array(a["sparse"]["values"]["bufferView"], np.float32, 3)
            want = (small_rig.deform({"AU12": 1.0})["skin"] - small_rig.head.rest["skin"]) * SCALE
            assert np.allclose(got, want, atol=1e-7)
            assert np.allclose(a["min"], got.min(0)) and np.allclose(a["max"], got.max(0))
    assert stored < 0.7 * dense
