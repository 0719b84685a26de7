"""Wavefront OBJ reading: triangulation, groups, UVs and errors naming file and line."""

import numpy as np
import pytest

from mimika.errors import DataError
from mimika.io.obj import read_obj, read_obj_vertices

SMALL = """# a quad, a triangle and a pentagon in two materials
mtllib x.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 2 0.5 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
o thing
usemtl A
f 1/1 2/2 3/3 4/4
s off
usemtl B
f 2/2 5/1 3/3
usemtl A
f 1/1/1 2/2/1 5/1/1 3/3/1 4/4/1
"""


def write(tmp_path, text, name="m.obj"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_reads_vertices_faces_groups_and_uvs(tmp_path):
    m = read_obj(write(tmp_path, SMALL.replace("f 1/1/1 2/2/1 5/1/1 3/3/1 4/4/1\n", "")))
    assert m.vertices.dtype == np.float32 and m.vertices.shape == (5, 3)
    assert m.faces.dtype == np.int32
    np.testing.assert_array_equal(m.faces, [[0, 1, 2], [0, 2, 3], [1, 4, 2]])
    assert m.groups == ("A", "B")
    np.testing.assert_array_equal(m.face_groups, [0, 0, 1])
    np.testing.assert_array_equal(m.group_faces("B"), [[1, 4, 2]])
    assert m.uvs.shape == (4, 2)
    np.testing.assert_array_equal(m.face_uvs, [[0, 1, 2], [0, 2, 3], [1, 0, 2]])
    uv = m.vertex_uvs()
    np.testing.assert_allclose(uv[3], [0, 1])


def test_mixed_corner_forms_and_polygons_fan_triangulated(tmp_path):
    m = read_obj(write(tmp_path, SMALL))
    assert len(m.faces) == 3 + 3  # quad 2 + tri 1 + pentagon 3
    np.testing.assert_array_equal(m.faces[3:], [[0, 1, 4], [0, 4, 2], [0, 2, 3]])
    np.testing.assert_array_equal(m.face_groups, [0, 0, 1, 0, 0, 0])


def test_plain_and_negative_indices_and_no_uvs(tmp_path):
    m = read_obj(write(tmp_path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nf 1 2 3\n"))
    np.testing.assert_array_equal(m.faces, [[0, 1, 2], [0, 1, 2]])
    assert m.uvs is None and m.face_uvs is None and m.vertex_uvs() is None
    assert m.groups == ("default",)


def test_read_obj_vertices(tmp_path):
    v = read_obj_vertices(write(tmp_path, SMALL))
    assert v.shape == (5, 3) and v.dtype == np.float32
    np.testing.assert_allclose(v[4], [2, 0.5, 0])


@pytest.mark.parametrize(
    ("text", "line", "what"),
    [
        ("v 0 0 0\nv 1 x 0\nv 0 1 0\nf 1 2 3\n", 2, "number"),
        ("v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", 2, "3 numbers"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n", 5, "out of range"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", 4, "out of range"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", 4, "at least 3 corners"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 a\n", 4, "integer"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nbogus 1 2\nf 1 2 3\n", 4, "OBJ statement"),
        ("v 0 0 0\nv 1 0 0\nvt 0 0\nv 0 1 0\nf 1/1 2/1 3/2\n", 5, "texture coordinate"),
    ],
)
def test_malformed_input_names_file_and_line(tmp_path, text, line, what):
    p = write(tmp_path, text, "bad.obj")
    with pytest.raises(DataError) as e:
        read_obj(p)
    msg = str(e.value)
    assert "bad.obj" in msg and f"line {line}" in msg and what in msg


def test_missing_file_and_no_vertices(tmp_path):
    with pytest.raises(DataError, match="cannot read"):
        read_obj(tmp_path / "nope.obj")
    with pytest.raises(DataError, match="no vertices"):
        read_obj_vertices(write(tmp_path, "# empty\n"))
