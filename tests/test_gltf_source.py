"""glTF read by the spec and safely: buffers per bufferView, URIs only beside the file,
extensionsRequired, EXT_meshopt_compression, EXT_texture_webp, sparse accessors."""

from __future__ import annotations

import base64
import io
import json
import os
import struct

import numpy as np
import pytest
from PIL import Image

from mimika.cli import main
from mimika.errors import DataError
from mimika.face.heads.gltf_scene import read_gltf

POS = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], np.float32)
IDX = np.array([0, 1, 2, 1, 3, 2], np.uint16)
UV = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], np.float32)


def _doc(views: list[dict], buffers: list[dict], **extra) -> dict:
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
           "nodes": [{"mesh": 0, "name": "face"}],
           "meshes": [{"name": "face", "primitives": [
               {"attributes": {"POSITION": 0, "TEXCOORD_0": 2}, "indices": 1,
                "material": 0}]}],
           "materials": [{"name": "skin", "pbrMetallicRoughness": {"baseColorTexture":
                                                                   {"index": 0}}}],
           "accessors": [
               {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                "min": [0, 0, 0], "max": [1, 1, 0]},
               {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"},
               {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"}],
           "bufferViews": views, "buffers": buffers}
    doc.update(extra)
    return doc


def _glb(path, doc: dict, blob: bytes) -> None:
    j = json.dumps(doc).encode()
    j += b" " * (-len(j) % 4)
    blob += b"\0" * (-len(blob) % 4)
    body = struct.pack("<II", len(j), 0x4E4F534A) + j + struct.pack("<II", len(blob),
                                                                     0x004E4942) + blob
    path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)


def _png(rgb=(200, 40, 40), fmt="PNG") -> bytes:
    b = io.BytesIO()
    Image.new("RGB", (4, 4), rgb).save(b, fmt)
    return b.getvalue()


def _split_gltf(tmp_path, image_uri="tex.png"):
    """A .gltf with positions in one external buffer, indices and UVs in another."""
    (tmp_path / "a.bin").write_bytes(POS.tobytes())
    (tmp_path / "b.bin").write_bytes(b"\0" * 4 + IDX.tobytes() + UV.tobytes())
    (tmp_path / "tex.png").write_bytes(_png())
    doc = _doc([{"buffer": 0, "byteLength": 48},
                {"buffer": 1, "byteOffset": 4, "byteLength": 12},
                {"buffer": 1, "byteOffset": 16, "byteLength": 32}],
               [{"uri": "a.bin", "byteLength": 48}, {"uri": "b.bin", "byteLength": 48}],
               textures=[{"source": 0}], images=[{"uri": image_uri}])
    p = tmp_path / "two.gltf"
    p.write_text(json.dumps(doc))
    return p, doc


def test_each_buffer_view_reads_its_own_buffer(tmp_path):
    p, _ = _split_gltf(tmp_path)
    s = read_gltf(p)
    np.testing.assert_array_equal(s.meshes[0].vertices, POS)
    assert s.meshes[0].primitives[0][1].tolist() == [[0, 1, 2], [1, 3, 2]]
    assert s.materials[0].base_color_image[0, 0].tolist() == [200, 40, 40]


@pytest.mark.parametrize("uri", ["/etc/passwd", "../outside.bin", "%2e%2e/outside.bin",
                                 "file:///etc/passwd", "/dev/zero", "sub/../../outside.bin"])
def test_buffer_uri_outside_the_folder_is_refused(tmp_path, uri, capsys):
    d = tmp_path / "in"
    d.mkdir()
    (tmp_path / "outside.bin").write_bytes(POS.tobytes())
    p, doc = _split_gltf(d)
    doc["buffers"][0]["uri"] = uri
    p.write_text(json.dumps(doc))
    with pytest.raises(DataError, match="outside the file's folder"):
        read_gltf(p)
    assert main(["heads", "--inspect", str(p)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err


@pytest.mark.skipif(not hasattr(os, "symlink"), reason="no symlinks")
def test_symlink_leading_out_is_refused(tmp_path):
    d = tmp_path / "in"
    d.mkdir()
    (tmp_path / "secret.bin").write_bytes(POS.tobytes())
    p, _ = _split_gltf(d)
    (d / "a.bin").unlink()
    (d / "a.bin").symlink_to(tmp_path / "secret.bin")
    with pytest.raises(DataError, match="leads out"):
        read_gltf(p)


def test_image_uri_outside_keeps_the_material_colour(tmp_path, caplog):
    p, _ = _split_gltf(tmp_path, image_uri="/etc/passwd")
    s = read_gltf(p)
    assert s.materials[0].base_color_image is None
    assert "outside the file's folder" in caplog.text


@pytest.mark.parametrize("ext, fix", [("KHR_draco_mesh_compression", "decompress"),
                                      ("EXT_something_new", "without it")])
def test_unsupported_required_extension_is_named(tmp_path, ext, fix, capsys):
    p, doc = _split_gltf(tmp_path)
    doc["extensionsRequired"] = [ext]
    p.write_text(json.dumps(doc))
    assert main(["heads", "--inspect", str(p)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and ext in err and fix in err


def test_meshopt_quantized_webp_glb_reads(tmp_path):
    meshopt = pytest.importorskip("meshopt")
    qpos = (POS * 1000).astype(np.int16)  # KHR_mesh_quantization: int16 positions
    qpos4 = np.c_[qpos, np.zeros(4, np.int16)]  # attributes padded to 4-byte strides
    quv = (UV * 65535).astype(np.uint16)
    parts = [meshopt.encode_gltf_buffer(qpos4, "ATTRIBUTES"),
             meshopt.encode_gltf_buffer(IDX.reshape(-1, 3), "TRIANGLES"),
             meshopt.encode_gltf_buffer(quv, "ATTRIBUTES"), _png((20, 180, 60), "WEBP")]
    blob, views = b"", []
    for data, (count, stride, mode) in zip(parts[:3], [(4, 8, "ATTRIBUTES"),
                                                       (6, 2, "TRIANGLES"),
                                                       (4, 4, "ATTRIBUTES")], strict=True):
        ext = {"buffer": 0, "byteOffset": len(blob), "byteLength": len(data), "count": count,
               "byteStride": stride, "mode": mode}
        view = {"buffer": 1, "byteLength": count * stride,
                "extensions": {"EXT_meshopt_compression": ext}}
        if mode == "ATTRIBUTES":
            view["byteStride"] = stride
        views.append(view)
        blob += data + b"\0" * (-len(data) % 4)
    views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(parts[3])})
    blob += parts[3]
    doc = _doc(views, [{"byteLength": len(blob)},
                       {"byteLength": 96, "extensions": {"EXT_meshopt_compression":
                                                         {"fallback": True}}}],
               textures=[{"extensions": {"EXT_texture_webp": {"source": 0}}}],
               images=[{"bufferView": 3, "mimeType": "image/webp"}],
               extensionsUsed=["EXT_meshopt_compression", "KHR_mesh_quantization",
                               "EXT_texture_webp"],
               extensionsRequired=["EXT_meshopt_compression", "KHR_mesh_quantization",
                                   "EXT_texture_webp"])
    doc["accessors"][0].update(componentType=5122)
    doc["accessors"][2].update(componentType=5123, normalized=True)
    p = tmp_path / "packed.glb"
    _glb(p, doc, blob)
    s = read_gltf(p)
    np.testing.assert_array_equal(s.meshes[0].vertices, POS * 1000)
    tris = {tuple(np.roll(t, -int(np.argmin(t)))) for t in s.meshes[0].primitives[0][1]}
    assert tris == {(0, 1, 2), (1, 3, 2)}  # the codec may rotate a triangle, not flip it
    np.testing.assert_allclose(s.meshes[0].uvs, UV, atol=1e-4)
    assert s.materials[0].base_color_image[0, 0, 1] > 150  # the WebP's green


def test_sparse_accessor_and_bad_sparse_index(tmp_path):
    p, doc = _split_gltf(tmp_path)
    extra = np.array([3], np.uint16).tobytes() + b"\0\0" + np.array([0, 0, 5], np.float32
                                                                    ).tobytes()
    (tmp_path / "c.bin").write_bytes(extra)
    doc["buffers"].append({"uri": "c.bin", "byteLength": 16})
    doc["bufferViews"] += [{"buffer": 2, "byteLength": 2},
                           {"buffer": 2, "byteOffset": 4, "byteLength": 12}]
    doc["accessors"][0]["sparse"] = {"count": 1, "indices": {"bufferView": 3,
                                                             "componentType": 5123},
                                     "values": {"bufferView": 4}}
    p.write_text(json.dumps(doc))
    assert read_gltf(p).meshes[0].vertices[3].tolist() == [0, 0, 5]
    (tmp_path / "c.bin").write_bytes(np.array([9], np.uint16).tobytes() + extra[2:])
    with pytest.raises(DataError, match="sparse"):
        read_gltf(p)


def test_data_uri_buffer_and_bad_base64(tmp_path):
    p, doc = _split_gltf(tmp_path)
    doc["buffers"][0]["uri"] = ("data:application/octet-stream;base64," +
                                base64.b64encode(POS.tobytes()).decode())
    p.write_text(json.dumps(doc))
    np.testing.assert_array_equal(read_gltf(p).meshes[0].vertices, POS)
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64,@@@"
    p.write_text(json.dumps(doc))
    with pytest.raises(DataError, match="base64"):
        read_gltf(p)
