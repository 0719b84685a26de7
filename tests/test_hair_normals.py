"""Hair is shaded by its volume, not by its cards: card outlines drew highlights as blocks."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from conftest import needs_makehuman
from mimika import normals

pytestmark = needs_makehuman


@pytest.fixture(scope="module")
def daniel():
    from mimika.face.heads import load_head

    return load_head("daniel")[1]


def _spread(points: np.ndarray, n: np.ndarray) -> float:
    """90th percentile of the angle (degrees) between the normals of vertices < 6 mm apart
    (either side: cards are double-sided)."""
    pairs = cKDTree(points).query_pairs(0.6, output_type="ndarray")
    cos = np.abs(np.einsum("ij,ij->i", n[pairs[:, 0]], n[pairs[:, 1]]))
    return float(np.degrees(np.arccos(np.clip(np.percentile(cos, 10), 0.0, 1.0))))


def test_renderer_and_export_shade_hair_by_its_volume(daniel):
    from mimika.io.gltf import build_gltf
    from mimika.render import Renderer
    from mimika.render.renderer import vertex_normals

    hair = next(o for o in daniel.head.objects if o.name == "hair")
    assert normals.is_hair(hair)
    raw = vertex_normals(hair.vertices, hair.faces)
    with Renderer(daniel.head, size=(64, 64)) as r:
        r.render(None)
        gpu = next(o for o in r._objects if o.name == "hair")
        drawn = gpu.interleaved[:, 3:6]
    assert _spread(hair.vertices, raw) > 15.0  # the cards' own normals
    assert _spread(hair.vertices, drawn) < 0.5 * _spread(hair.vertices, raw)
    # every normal stays on its card's side (back faces flip them in the shader)
    assert (np.einsum("ij,ij->i", drawn, raw) > 0).mean() > 0.95
    doc, blob = build_gltf(daniel)
    mesh = next(m for m in doc["meshes"] if m["name"] == "hair")
    acc = doc["accessors"][mesh["primitives"][0]["attributes"]["NORMAL"]]
    view = doc["bufferViews"][acc["bufferView"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    exported = np.frombuffer(blob, np.float32, acc["count"] * 3, start).reshape(-1, 3)
    assert np.allclose(exported, drawn, atol=1e-3)


def test_hair_materials_are_those_the_renderer_shades_as_hair():
    """One list for the glTF writer (which may not import the renderer) and the renderer's
    own material table: a new hair material in one is a hair material in both."""
    import json
    from importlib import resources

    table = json.loads(resources.files("mimika.render").joinpath(
        "data", "materials.json").read_text("utf-8"))
    table = table.get("materials", table)
    hair = {k for k, v in table.items() if isinstance(v, dict) and v.get("model") == "hair"}
    assert hair == set(normals.HAIR_MATERIALS)
