"""Error messages are one line — what, where (file:line:col), how to fix — with exit 2
(issue 27): project files, JSON and YAML syntax, a glTF whose buffer file is missing."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from mimika.io.jsonpos import locate, parse_path


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mimika", *args], capture_output=True,
                          text=True, timeout=300)


def _one_line(r: subprocess.CompletedProcess) -> str:
    assert r.returncode == 2, (r.returncode, r.stderr[-800:])
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    return lines[0]


def test_every_project_problem_on_one_line_at_its_place(tmp_path):
    p = tmp_path / "talk.json"
    p.write_text('{"format": "mimika-project", "version": 1,\n'
                 ' "settings": {"fps": "x", "view": "top"},\n "extra": 1}\n')
    line = _one_line(_run("render", str(p), "-o", str(tmp_path / "o.csv")))
    assert f"{p}:3:2: extra: unknown key" in line
    assert '2:15: settings.fps: must be a number in (0, 1000], got "x"' in line
    assert "2:27: settings.view: 'top' must be one of front" in line
    assert _one_line(_run("project", "check", str(p))) == line


@pytest.mark.parametrize("text, where, hint", [
    ('{"format": "mimika-project",\n "version": 1,}', ":2:15:", "remove the ','"),
    ("{'format': 1}", ":1:2:", "put every key in double quotes"),
    ('{"a" 1}', ":1:6:", "write ':' between a key and its value"),
    ("", ":1:1:", "the file is empty"),
])
def test_json_syntax_errors_say_how_to_fix_them(tmp_path, text, where, hint):
    p = tmp_path / "bad.json"
    p.write_text(text)
    line = _one_line(_run("project", "check", str(p)))
    assert f"{p}{where} invalid JSON:" in line and hint in line


@pytest.mark.parametrize("text, where, hint", [
    ("aus: [[AU12]\nneutral: true\n", ":2:1:", "close the '[' at 1:6 with ']'"),
    ("aus:\n\t- x\n", ":2:1:", "indent with spaces, not tabs"),
    ('aus: "abc\n', ":2:1:", "close the quote at 1:6"),
    ("a: 1\n b: 2\n", ":2:3:", "put quotes around a value"),
])
def test_yaml_syntax_errors_say_how_to_fix_them(tmp_path, text, where, hint):
    p = tmp_path / "spec.yaml"
    p.write_text(text)
    line = _one_line(_run("batch", str(p), "-o", str(tmp_path / "out")))
    assert f"{p}{where} invalid YAML:" in line and hint in line


def test_a_missing_gltf_buffer_file_is_named(tmp_path):
    doc = {"asset": {"version": "2.0"}, "buffers": [{"uri": "head.bin", "byteLength": 36}],
           "bufferViews": [{"buffer": 0, "byteLength": 36}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                          "min": [0, 0, 0], "max": [1, 1, 0]}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
           "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0}
    p = tmp_path / "head.gltf"
    p.write_text(json.dumps(doc))
    line = _one_line(_run("heads", "--inspect", str(p)))
    assert "the file of buffer 0, 'head.bin', is missing" in line
    assert "copy it next to head.gltf" in line and "accessor" not in line


def test_json_paths_are_found_in_the_text():
    text = ('{"a": {"b": [1, {"c": 2}, [3]]},\n "d": {"e": [{"x": {"y": 1}}, 5]}}')
    assert parse_path("a.b[1].c") == ["a", "b", 1, "c"]
    assert locate(text, "a.b[1].c") == (1, 18)
    assert locate(text, "d.e[1]") == (2, 31)
    assert locate(text, "d.missing") == (2, 2)  # its deepest part that is there
    assert locate(text, "nothing") is None
    assert locate("[" * 50_000 + "]" * 50_000, "a.b") is None  # any depth, linear
