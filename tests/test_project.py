"""Project files: exact save/load, every problem reported, versions, atomic writes."""

import json
import os

import pytest

from mimika.markup import parse_script
from mimika.markup.project import (
    Project,
    ProjectError,
    load_project,
    project_from_dict,
    project_to_dict,
    save_project,
)
from mimika.timeline import Channel, Event, Timeline

SCRIPT = """<speak xmlns:m="https://mimika.dev/ns/1"><m:settings rate="0.14" mood="happy"/>
<m:channel name="head" override="true" bridge="2s"/>
<p>Hi <m:expr name="happiness" intensity="0.5" onset="0.1s">there</m:expr>!
<m:tilt dir="left" channel="head" ease="linear"/><m:aus set="AU01=0.3 AU02"/></p>
<m:blink start="1.25s"/></speak>"""


@pytest.fixture
def project():
    tl = parse_script(SCRIPT)
    tl = tl.with_event(Event("nod", 3.0, 0.6, count=2))
    return Project(tl, {"head": "builtin", "fps": 30.0, "view": "profile", "lang": "de",
                        "blend": True, "size": [320, 240]})


def test_save_load_roundtrip_is_exact(tmp_path, project):
    p = save_project(project, tmp_path / "a.json")
    again = load_project(p)
    assert again == project
    data = json.loads(p.read_text())
    assert data["format"] == "mimika-project" and data["version"] == 1
    save_project(again, tmp_path / "b.json")
    assert (tmp_path / "b.json").read_text() == p.read_text()


def test_every_problem_is_reported(project):
    d = project_to_dict(project)
    d["settings"]["fps"] = -1
    d["settings"]["view"] = "top"
    d["timeline"]["channels"][0]["events"][0]["start"] = -3
    d["timeline"]["channels"][1]["events"][0]["bogus"] = 1
    d["timeline"]["mood"] = "hapy"
    d["extra"] = True
    with pytest.raises(ProjectError) as ei:
        project_from_dict(d, source="p.json")
    probs = ei.value.problems
    assert len(probs) == 6, probs
    joined = "\n".join(probs)
    for part in ("settings.fps", "settings.view", "timeline.channels[0].events[0]",
                 "timeline.channels[1].events[0].bogus: unknown key", "timeline.mood", "extra"):
        assert part in joined


def test_versions(project):
    d = project_to_dict(project)
    d["version"] = 7
    with pytest.raises(ProjectError, match="written by a newer mimika"):
        project_from_dict(d)
    d["version"] = 0
    with pytest.raises(ProjectError, match="too old"):
        project_from_dict(d)
    d["format"] = "something"
    with pytest.raises(ProjectError, match="not a mimika project"):
        project_from_dict(d)


def test_bad_json_names_line_and_col(tmp_path):
    p = tmp_path / "bad.json"
    p.write_text('{"format": "mimika-project",\n "version": 1,,}')
    with pytest.raises(Exception, match=r"bad.json:2:\d+: invalid JSON"):
        load_project(p)


def test_atomic_save_keeps_old_file_on_failure(tmp_path, project, monkeypatch):
    p = save_project(project, tmp_path / "a.json")
    before = p.read_text()

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", boom)
    with pytest.raises(OSError):
        save_project(Project(Timeline((Channel("x"),))), p)
    assert p.read_text() == before
    assert sorted(os.listdir(tmp_path)) == ["a.json"]


def test_schema_file_is_valid_json_schema(project):
    from importlib import resources

    schema = json.loads(resources.files("mimika.markup").joinpath(
        "data/project.schema.json").read_text())
    assert schema["properties"]["format"]["const"] == "mimika-project"
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(project_to_dict(project), schema)


def test_doc_python_example_runs(tmp_path, monkeypatch):
    import re
    from pathlib import Path

    doc = Path(__file__).resolve().parents[1] / "docs" / "project.md"
    blocks = re.findall(r"```python\n(.*?)```", doc.read_text("utf-8"), re.DOTALL)
    assert blocks
    monkeypatch.chdir(tmp_path)
    for b in blocks:
        exec(compile(b, "docs/project.md", "exec"), {})
    json_block = re.findall(r"```json\n(.*?)```", doc.read_text("utf-8"), re.DOTALL)[0]
    project_from_dict(json.loads(json_block))
