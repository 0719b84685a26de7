"""Expression library: built-ins, name resolution, user library round trip and atomic writes."""

import json
import os

import pytest

from mimika.errors import DataError, ParameterError
from mimika.knowledge import expressions as ex
from mimika.knowledge.expressions import ExpressionLibrary, builtin_expressions, get_expression
from mimika.knowledge.timing import timing_limits


@pytest.fixture
def lib(tmp_path):
    return ExpressionLibrary(tmp_path / "lib" / "expressions.json")


def test_basic_emotions_are_emfacs_prototypes():
    b = builtin_expressions()
    aus = {n: sorted(c for c in b[n].aus) for n in
           ("happiness", "sadness", "surprise", "fear", "anger", "disgust", "contempt")}
    assert aus == {"happiness": ["AU06", "AU12", "AU25"],
                   "sadness": ["AU01", "AU04", "AU15", "AU17", "AU41", "AU54", "AU64"],
                   "surprise": ["AU01", "AU02", "AU05", "AU26"],
                   "fear": ["AU01", "AU02", "AU04", "AU05", "AU20", "AU25"],
                   "anger": ["AU04", "AU05", "AU07", "AU10", "AU23", "AU25"],
                   "disgust": ["AU09", "AU17"],
                   "contempt": ["AU12R", "AU14R"]}
    # complete at apex: each prototype's main AUs at E, an AU the prototype letters at its
    # letter (5B), nothing weaker than B
    for name in ("happiness", "sadness", "surprise", "fear", "anger", "disgust"):
        assert max(b[name].aus.values()) == 1.0 and min(b[name].aus.values()) >= 0.4, name
    assert b["happiness"].aus["AU06"] == b["happiness"].aus["AU12"] == 1.0
    assert b["contempt"].aus["AU14R"] == 1.0
    assert b["surprise"].aus["AU05"] == pytest.approx(0.4)  # 5B
    assert b["neutral"].aus == {}
    # the AU Blender (seed 002's rules) leaves every prototype as it is
    from mimika.facs.blender import blend

    for name in ("happiness", "sadness", "surprise", "fear", "anger", "disgust", "contempt"):
        assert blend(b[name].aus).aus == pytest.approx(b[name].aus), name


def test_the_twelve_seed_templates():
    t = {n.removeprefix("template/"): sorted(int(c[2:4]) for c in e.aus)
         for n, e in builtin_expressions().items() if n.startswith("template/")}
    assert t == {"astonishment": [1, 2, 5], "surprise": [1, 2], "sadness": [15, 17],
                 "disbelief": [4, 20], "regret": [20, 23], "grief": [1, 4], "anger": [4],
                 "disgust": [9], "happiness": [6, 12, 25], "understanding": [1, 2, 25, 53],
                 "satisfaction": [12, 17], "ironic-smile": [10, 12]}


def test_template_durations_lie_in_the_probable_range():
    for kind, lim in timing_limits().items():
        e = builtin_expressions()["template/" + kind]
        assert lim.probable[0] <= e.duration <= lim.probable[1], kind
        assert e.onset + e.offset <= e.duration and e.apex >= 0


def test_name_resolution_and_scaling():
    assert get_expression("happiness", 0.5) == {"AU06": 0.5, "AU12": 0.5, "AU25": 0.3}
    assert get_expression("astonishment") == get_expression("template/astonishment")
    assert get_expression("Ironic Smile") == {"AU10": 0.5, "AU12": 0.6}
    assert ex.expression_aus("anger", 0.0) == {c: 0.0 for c in get_expression("anger")}
    with pytest.raises(ParameterError, match=r"unknown expression 'hapiness'; did you mean"):
        get_expression("hapiness")
    with pytest.raises(ParameterError, match="intensity"):
        get_expression("happiness", 1.5)


def test_default_path_honours_mimika_data_dir(monkeypatch, tmp_path):
    monkeypatch.setenv("MIMIKA_DATA_DIR", str(tmp_path))
    assert ex.default_library_path() == tmp_path / "expressions.json"
    monkeypatch.delenv("MIMIKA_DATA_DIR")
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "x"))
    assert ex.default_library_path() == tmp_path / "x" / "mimika" / "expressions.json"


def test_user_library_round_trip(lib):
    lib.create("smirk", {"12R": 0.6, "AU14R": "B"}, duration=0.8, description="one-sided")
    again = ExpressionLibrary(lib.path)
    e = again.get("smirk")
    assert e.aus == {"AU12R": 0.6, "AU14R": 0.4} and e.duration == 0.8 and not e.builtin
    assert "smirk" in again.names() and again.user_names() == ["smirk"]
    assert get_expression("smirk", 0.5, library=again) == {"AU12R": 0.3, "AU14R": 0.2}
    again.delete("smirk")
    assert "smirk" not in ExpressionLibrary(lib.path)
    assert json.loads(lib.path.read_text())["expressions"] == []


def test_user_entries_do_not_silently_shadow_builtins(lib):
    with pytest.raises(ParameterError, match=r"would shadow the built-in 'anger'.*--force"):
        lib.create("anger", {"AU04": 1.0})
    with pytest.raises(ParameterError, match="would shadow the built-in 'template/grief'"):
        lib.create("grief", {"AU01": 1.0})
    lib.create("anger", {"AU04": 1.0}, force=True)
    assert ExpressionLibrary(lib.path).get("anger").aus == {"AU04": 1.0}
    lib.create("mine", {"AU01": 1.0})
    with pytest.raises(ParameterError, match="already exists"):
        lib.create("mine", {"AU02": 1.0})
    with pytest.raises(ParameterError, match="built-in expression and cannot be deleted"):
        lib.delete("happiness")
    with pytest.raises(ParameterError, match="did you mean"):
        lib.delete("mien")


@pytest.mark.parametrize(("kw", "msg"), [
    ({"name": "Bad Name!", "aus": {"AU01": 1}}, "must be lower-case"),
    ({"name": "template/x", "aus": {"AU01": 1}}, "not starting with 'template/'"),
    ({"name": "x", "aus": {}}, "at least one AU"),
    ({"name": "x", "aus": {"AU03": 1}}, "unknown Action Unit"),
    ({"name": "x", "aus": {"AU01": 1}, "duration": 0.2, "onset": 0.2, "offset": 0.2}, "fit into"),
])
def test_bad_user_entries(lib, kw, msg):
    with pytest.raises(ParameterError, match=msg):
        lib.create(**kw)


def test_atomic_write_keeps_the_old_file_on_failure(lib, monkeypatch):
    lib.create("first", {"AU01": 0.5})
    before = lib.path.read_bytes()

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(ex.os, "replace", boom)
    with pytest.raises(OSError, match="disk full"):
        lib.create("second", {"AU02": 0.5})
    assert lib.path.read_bytes() == before
    assert os.listdir(lib.path.parent) == ["expressions.json"]  # no temp file left


def test_atomic_write_failing_mid_write(lib, monkeypatch):
    lib.create("first", {"AU01": 0.5})
    before = lib.path.read_bytes()
    real_fsync = os.fsync

    def fail(fd):
        real_fsync(fd)
        raise OSError("I/O error")

    monkeypatch.setattr(ex.os, "fsync", fail)
    with pytest.raises(OSError):
        lib.create("second", {"AU02": 0.5})
    assert lib.path.read_bytes() == before


def test_corrupt_library_is_a_clear_error(tmp_path):
    p = tmp_path / "expressions.json"
    p.write_text("{not json")
    with pytest.raises(DataError, match="cannot read expression library"):
        ExpressionLibrary(p)


def test_docstring_examples_run(monkeypatch, tmp_path):
    import doctest

    monkeypatch.setenv("MIMIKA_DATA_DIR", str(tmp_path))
    assert doctest.testmod(ex).failed == 0


def test_the_docs_table_lists_the_library_as_it_is():
    """docs/expressions.md's table of the basic emotions says what the data file holds (its
    fear row still said AU26 after fear became 1+2+4+5+20+25)."""
    import re
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[1] / "docs" / "expressions.md").read_text()
    b = builtin_expressions()
    for name in ("happiness", "sadness", "surprise", "fear", "anger", "disgust", "contempt"):
        row = re.search(rf"^\| `{name}` \| ([^|]+) \|", doc, re.M)
        assert row, name
        listed = dict(kv.split("=") for kv in row.group(1).split())
        assert {k: float(v) for k, v in listed.items()} == b[name].aus, name
