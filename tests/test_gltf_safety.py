"""Hostile glTF files: each is one line and exit 2, never a traceback or a runaway."""

from __future__ import annotations

import copy
import json
import random

import numpy as np
import pytest
from tests.test_gltf_source import _split_gltf

from mimika.cli import main

NAN = np.array([[np.nan, 0, 0]] * 4, np.float32)


def _hostile(doc: dict, kind: str) -> dict:
    d = copy.deepcopy(doc)
    if kind == "node cycle":
        d["nodes"] = [{"children": [1]}, {"children": [0], "mesh": 0}]
    elif kind == "deep chain":
        d["nodes"] = [{"children": [i + 1]} for i in range(5000)] + [{"mesh": 0}]
    elif kind == "two parents":
        d["nodes"] = [{"children": [2]}, {"children": [2]}, {"mesh": 0}]
        d["scenes"] = [{"nodes": [0, 1]}]
    elif kind == "child out of range":
        d["nodes"][0]["children"] = [99]
    elif kind == "mesh out of range":
        d["nodes"][0]["mesh"] = 7
    elif kind == "skin out of range":
        d["nodes"][0]["skin"] = 3
    elif kind == "scene out of range":
        d["scene"] = 5
    elif kind == "accessor type":
        d["accessors"][0]["type"] = "VEC9"
    elif kind == "huge count":
        d["accessors"][0] = {"componentType": 5126, "count": 10**9, "type": "MAT4"}
    elif kind == "negative offset":
        d["bufferViews"][0]["byteOffset"] = -8
    elif kind == "view past buffer":
        d["bufferViews"][0]["byteLength"] = 10**6
    elif kind == "buffer index":
        d["bufferViews"][0]["buffer"] = 9
    elif kind == "index past vertices":
        d["accessors"][1]["count"] = 6
        d["accessors"][0]["count"] = 2
    elif kind == "string where a number goes":
        d["accessors"][0]["count"] = "4"
    elif kind == "many instances":
        d["nodes"] = [{"mesh": 0} for _ in range(1000)]
        d["scenes"] = [{"nodes": list(range(1000))}]
    elif kind == "not a list":
        d["meshes"] = {"a": 1}
    elif kind == "version 1":
        d["asset"]["version"] = "1.0"
    return d


KINDS = ["node cycle", "deep chain", "two parents", "child out of range", "mesh out of range",
         "skin out of range", "scene out of range", "accessor type", "huge count",
         "negative offset", "view past buffer", "buffer index", "index past vertices",
         "string where a number goes", "many instances", "not a list", "version 1"]


def _one_line_exit_2(p, capsys) -> str:
    assert main(["heads", "--inspect", str(p)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    return err


@pytest.mark.parametrize("kind", KINDS)
def test_hostile_file_is_one_line_exit_2(tmp_path, kind, capsys):
    p, doc = _split_gltf(tmp_path)
    p.write_text(json.dumps(_hostile(doc, kind)))
    _one_line_exit_2(p, capsys)


def test_nan_positions_are_refused(tmp_path, capsys):
    p, _ = _split_gltf(tmp_path)
    (tmp_path / "a.bin").write_bytes(NAN.tobytes())
    assert "finite" in _one_line_exit_2(p, capsys)


def _mutate(value, rng: random.Random):
    choices = [-1, 0, 1, 2**31, 10**12, 3.5, "x", None, [], {}, [0, 0], True]
    return rng.choice(choices)


def test_mutation_fuzz_never_tracebacks(tmp_path, capsys):
    """Every number, string and list in a good file, replaced one at a time by nonsense."""
    p, doc = _split_gltf(tmp_path)
    rng = random.Random(26)
    paths: list[list] = []

    def walk(v, path):
        if isinstance(v, dict):
            for k, x in v.items():
                walk(x, [*path, k])
        elif isinstance(v, list):
            for i, x in enumerate(v):
                walk(x, [*path, i])
        paths.append(path)

    walk(doc, [])
    for path in paths[:-1]:
        for _ in range(2):
            d = copy.deepcopy(doc)
            holder = d
            for k in path[:-1]:
                holder = holder[k]
            holder[path[-1]] = _mutate(holder[path[-1]], rng)
            p.write_text(json.dumps(d))
            rc = main(["heads", "--inspect", str(p)])
            err = capsys.readouterr().err
            assert rc in (0, 2) and "Traceback" not in err, (path, err[-300:])
