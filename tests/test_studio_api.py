"""mimika studio API: every endpoint, its errors ({"error": …} with 4xx) and its limits."""

from __future__ import annotations

import json
import struct
import subprocess
import sys
import warnings

import pytest

pytest.importorskip("fastapi")
pytest.importorskip("httpx")

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    from fastapi.testclient import TestClient

from mimika.errors import ParameterError
from mimika.studio.app import create_app
from mimika.studio.names import check_project_name, project_path


def project_doc(text: str = "Hello there.", events: list | None = None) -> dict:
    return {"format": "mimika-project", "version": 1,
            "settings": {"head": "builtin", "fps": 25.0, "lang": "en", "blend": False},
            "timeline": {"rate": 0.16, "mood": None, "duration": None,
                         "speech": {"attrs": [], "tokens": [{"text": text}] if text else []},
                         "channels": [{"name": "face", "override": False, "ease": "cosine",
                                       "bridge": None, "events": events if events is not None else [
                                           {"kind": "expression", "start": 0.2, "duration": 1.2,
                                            "name": "happiness", "intensity": 0.8,
                                            "onset": 0.3, "offset": 0.4}]}]}}


#: the studio answers only the Host names it serves (DNS rebinding): the tests use its address
BASE = "http://127.0.0.1:8765"
LIVE = "ws://127.0.0.1:8765/api/live"


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    d = tmp_path_factory.mktemp("studio")
    return create_app(d / "projects", library_path=d / "expressions.json", head="builtin")


@pytest.fixture(scope="module")
def client(app):
    with TestClient(app, base_url=BASE) as c:
        yield c


def err(r, status: int) -> str:
    assert r.status_code == status, (r.status_code, r.text)
    body = r.json()
    assert isinstance(body.get("error"), str) and body["error"]
    return body["error"]


# -- status, catalogue, head ---------------------------------------------------------------------
def test_status(client):
    d = client.get("/api/status").json()
    assert d["head"] == "builtin"
    assert set(d["features"]) >= {"mp4"}
    assert "cosine" in d["easings"]


def test_aus_catalogue(client):
    aus = {a["code"]: a for a in client.get("/api/aus").json()["aus"]}
    assert aus["AU12"]["group"] == "lower face linear" and aus["AU12"]["sided"]


def test_head_groups_follow_the_facs_manual(client):
    d = client.get("/api/head").json()
    assert [g["name"] for g in d["groups"]] == ["upper face", "lower face linear",
                                                "lower face orbital", "head", "eyes"]
    codes = {a["code"]: a for g in d["groups"] for a in g["aus"]}
    assert codes["AU12"]["sided"] and not codes["AU26"]["sided"]
    assert "AU51" in d["motion"]["head_rot"] and "AU61" in d["motion"]["eye_rot"]


def test_head_glb_and_etag(client):
    r = client.get("/api/head.glb")
    assert r.status_code == 200 and r.content[:4] == b"glTF"
    doc = json.loads(r.content[20:20 + struct.unpack("<I", r.content[12:16])[0]])
    names = {n for m in doc["meshes"] for n in m.get("extras", {}).get("targetNames", [])}
    assert {"AU12", "AU12L", "AU12R", "AU25"} <= names
    r2 = client.get("/api/head.glb", headers={"If-None-Match": r.headers["etag"]})
    assert r2.status_code == 304


# -- blender -------------------------------------------------------------------------------------
def test_blend_applies_rules_and_traces(client):
    d = client.post("/api/blend", json={"aus": {"AU12": 1, "au15": 1}}).json()
    assert d["aus"]["AU12"] == 0.0 and d["trace"][0]["rule"] == "12<15Z"


def test_blend_disabled_rule(client):
    d = client.post("/api/blend", json={"aus": {"AU12": 1, "AU15": 1},
                                        "disabled": ["12<15Z"]}).json()
    assert d["aus"]["AU12"] == 1.0


@pytest.mark.parametrize("body, needle", [
    ({"aus": {"AU99": 1}}, "nknown Action Unit"),
    ({"aus": {"AU12": 1.5}}, "outside [0, 1]"),
    ({"aus": {"AU12": "lots"}}, "Action Units"),
    ({"aus": {f"AU{i:02d}": 0.1 for i in range(1, 67)} | {"x": 1}}, ""),
    ({"aus": {}, "bogus": 1}, "bogus"),
])
def test_blend_rejects_bad_input(client, body, needle):
    assert needle in err(client.post("/api/blend", json=body), 422)


def test_blend_rejects_too_many_aus(client):
    aus = {f"AU12{'LR'[i % 2]}": 0.1 for i in range(2)} | {str(i): 0.1 for i in range(300)}
    err(client.post("/api/blend", json={"aus": aus}), 422)


# -- expressions ---------------------------------------------------------------------------------
def test_expressions_create_list_delete(client):
    names = [e["name"] for e in client.get("/api/expressions").json()["expressions"]]
    assert "happiness" in names
    r = client.post("/api/expressions", json={"name": "smirk-test", "aus": {"AU12L": 0.7}})
    assert r.status_code == 201 and r.json()["aus"] == {"AU12L": 0.7}
    d = client.get("/api/expressions").json()
    assert "smirk-test" in d["user"]
    r = client.post("/api/expressions", json={"name": "smirk-test", "aus": {"AU12": 1}})
    assert "already an expression" in err(r, 409)
    assert r.json()["code"] == "exists" and not r.json()["builtin"]
    assert "/" not in r.json()["error"] and "--" not in r.json()["error"]
    r = client.post("/api/expressions", json={"name": "smirk-test", "aus": {"AU12": 1},
                                              "force": True})
    assert r.status_code == 201 and r.json()["aus"] == {"AU12": 1.0}
    assert client.delete("/api/expressions/smirk-test").json() == {"deleted": "smirk-test"}
    assert "smirk-test" not in client.get("/api/expressions").json()["user"]


def test_expressions_errors(client):
    assert "built-in" in err(client.delete("/api/expressions/happiness"), 400)
    r = client.post("/api/expressions", json={"name": "happiness", "aus": {"AU12": 1}})
    assert "built-in" in err(r, 409) and r.json()["builtin"]
    assert "built-in" in err(client.post("/api/expressions", json={
        "name": "astonishment", "aus": {"AU12": 1}}), 409)
    msg = err(client.post("/api/expressions", json={"name": "../x", "aus": {"AU12": 1}}), 422)
    assert "may only contain letters" in msg and "^[" not in msg  # no regex shown
    assert "at least one Action Unit" in err(client.post("/api/expressions", json={
        "name": "empty", "aus": {}}), 400)


# -- projects ------------------------------------------------------------------------------------
def test_project_roundtrip(client):
    doc = project_doc()
    r = client.put("/api/projects/My talk_1", json=doc)
    assert r.status_code == 200, r.text
    back = client.get("/api/projects/My talk_1").json()
    assert back == r.json()["project"]
    assert back["timeline"]["channels"][0]["events"][0]["name"] == "happiness"
    assert "My talk_1" in [p["name"] for p in client.get("/api/projects").json()["projects"]]
    assert client.delete("/api/projects/My talk_1").json() == {"deleted": "My talk_1"}
    err(client.get("/api/projects/My talk_1"), 404)
    err(client.delete("/api/projects/My talk_1"), 404)


BAD_NAMES = ["..", "../evil", "a/b", "/etc/passwd", "a.b", ".hidden", "a\\b", " lead", "x" * 65,
             "con", "tab\tname", "a:b", "%2e%2e", "trail ", "a\u202eb", "ü" * 101, "x\x00y"]
GOOD_NAMES = ["-dash-first", "Grüße aus Köln", "Zażółć gęślą jaźń", "news_2024-05", "日本語"]


@pytest.mark.parametrize("name", BAD_NAMES)
def test_project_names_cannot_escape(client, app, name, tmp_path):
    with pytest.raises(ParameterError):
        check_project_name(name)
    from urllib.parse import quote

    r = client.put(f"/api/projects/{quote(name, safe='')}", json=project_doc())
    assert 400 <= r.status_code < 500 and "error" in r.json()
    root = app.state.studio.projects_dir
    assert not any(p.name.startswith("evil") for p in root.parent.rglob("*"))


@pytest.mark.parametrize("name", GOOD_NAMES)
def test_project_names_in_any_script(client, app, name):
    from urllib.parse import quote

    assert check_project_name(name) == name
    r = client.put(f"/api/projects/{quote(name, safe='')}", json=project_doc())
    assert r.status_code == 200, r.text
    assert (app.state.studio.projects_dir / f"{name}.json").is_file()
    assert name in [p["name"] for p in client.get("/api/projects").json()["projects"]]


def test_project_path_stays_inside(tmp_path):
    assert project_path(tmp_path, "ok name").parent == tmp_path.resolve()
    with pytest.raises(ParameterError, match="not allowed"):
        project_path(tmp_path, "../up")


def test_project_validation_lists_problems(client):
    doc = project_doc()
    doc["settings"]["fps"] = -1
    doc["timeline"]["channels"][0]["events"][0]["start"] = "soon"
    r = client.put("/api/projects/bad", json=doc)
    msg = err(r, 422)
    assert "settings.fps" in msg and len(r.json()["problems"]) == 2
    doc = project_doc()
    doc["settings"]["head"] = "/etc/some.obj"
    assert "the studio has the heads" in err(client.put("/api/projects/bad", json=doc), 422)
    err(client.put("/api/projects/bad", json=[1, 2]), 422)


def test_failed_save_keeps_the_old_file(client, app, monkeypatch):
    client.put("/api/projects/keep", json=project_doc("first version"))
    path = app.state.studio.projects_dir / "keep.json"
    before = path.read_text()

    def boom(*a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("mimika.io.atomic.os.replace", boom)
    assert "No space left" in err(client.put("/api/projects/keep",
                                             json=project_doc("second")), 400)
    monkeypatch.undo()
    assert path.read_text() == before
    assert [p.name for p in path.parent.iterdir() if p.name.startswith(".keep")] == []


# -- timeline ------------------------------------------------------------------------------------
def test_timeline_sample(client):
    d = client.post("/api/timeline/sample", json={"project": project_doc(), "fps": 20}).json()
    assert d["fps"] == 20 and "AU12" in d["channels"]
    j = d["channels"].index("AU12")
    peak = max(row[j] for row in d["values"])
    assert 0.5 < peak <= 0.8 + 1e-6  # happiness AU12 0.8 × intensity 0.8
    err(client.post("/api/timeline/sample", json={"project": project_doc(), "fps": 0}), 422)


# -- speech --------------------------------------------------------------------------------------
def test_speak_http_wav_and_remix(client):
    d = client.post("/api/speak", json={"text": "Hello there. How are you?",
                                        "project": project_doc()}).json()
    assert len(d["segments"]) == 2 and len(d["sentences"]) == 2
    seg = d["segments"][0]
    assert "AU25" in seg["channels"] and "AU06" in seg["channels"]  # mouth + happiness
    assert d["sentences"][1]["start"] == pytest.approx(d["segments"][1]["t0"], abs=1e-3)
    wav = client.get(d["audio"])
    assert wav.status_code == 200 and wav.content[:4] == b"RIFF"
    r = client.post(f"/api/speech/{d['key']}/frames", json={"project": None}).json()
    assert "AU06" not in r["segments"][0]["channels"]
    err(client.get("/api/speech/nothex.wav"), 400)
    err(client.get("/api/speech/" + "0" * 20 + ".wav"), 404)
    err(client.post("/api/speak", json={"text": "   "}), 422)
    err(client.post("/api/speak", json={"text": "x" * 5001}), 422)
    err(client.post("/api/speak", json={"text": "hi", "lang": "../../etc"}), 422)


def _drain(ws):
    msgs, audio = [], []
    while True:
        m = ws.receive()
        if m.get("bytes") is not None:
            b = m["bytes"]
            n = struct.unpack("<I", b[:4])[0]
            audio.append((json.loads(b[4:4 + n]), len(b) - 4 - n))
            continue
        msg = json.loads(m["text"])
        msgs.append(msg)
        if msg["type"] in ("done", "error"):
            return msgs, audio


def test_live_websocket_streams_per_sentence(client):
    with client.websocket_connect(LIVE) as ws:
        ws.send_text(json.dumps({"type": "ping"}))
        assert json.loads(ws.receive_text()) == {"type": "pong"}
        ws.send_text(json.dumps({"type": "speak", "id": 7, "text": "One. Two three.",
                                 "project": project_doc(), "fps": 25}))
        msgs, audio = _drain(ws)
        kinds = [m["type"] for m in msgs]
        assert kinds[0] == "start" and kinds[-1] == "done"
        assert kinds.count("frames") == 2 and kinds.count("sentence") == 2
        assert [h["index"] for h, _ in audio] == [0, 1]
        assert all(n == 2 * h["samples"] for h, n in audio)
        done = msgs[-1]
        assert done["id"] == 7 and done["timing"]["first_audio_ms"] > 0
        assert client.get(done["audio"]).status_code == 200
        ws.send_text(json.dumps({"type": "speak", "text": ""}))
        assert json.loads(ws.receive_text())["type"] == "error"
        ws.send_text("not json")
        assert "JSON" in json.loads(ws.receive_text())["message"]
        ws.send_text(json.dumps({"type": "dance"}))
        assert "unknown message type" in json.loads(ws.receive_text())["message"]
        bad = project_doc()
        bad["settings"]["fps"] = "x"
        ws.send_text(json.dumps({"type": "speak", "text": "Hi.", "project": bad}))
        msgs, _ = _drain(ws)
        assert msgs[-1]["type"] == "error" and "settings.fps" in msgs[-1]["message"]


def test_live_refuses_other_origins(client):
    from starlette.websockets import WebSocketDisconnect

    with pytest.raises(WebSocketDisconnect), client.websocket_connect(
            LIVE, headers={"Origin": "http://evil.example"}) as ws:
        ws.receive_text()


# -- export --------------------------------------------------------------------------------------
def test_export_gltf_pose_and_project(client):
    r = client.post("/api/export/gltf", json={"aus": {"AU12": 1}, "name": "smile"})
    assert r.status_code == 200 and r.content[:4] == b"glTF"
    assert 'filename="smile.glb"' in r.headers["content-disposition"]
    r = client.post("/api/export/gltf", json={"project": project_doc(), "fps": 25})
    doc = json.loads(r.content[20:20 + struct.unpack("<I", r.content[12:16])[0]])
    assert doc["animations"][0]["channels"]
    err(client.post("/api/export/gltf", json={}), 400)
    err(client.post("/api/export/gltf", json={"aus": {"AU12": 1}, "name": "../x"}), 422)


@pytest.mark.parametrize("fmt, head", [("au", "time,"), ("openface", "frame"),
                                       ("arkit", "Timecode")])
def test_export_csv(client, fmt, head):
    r = client.post("/api/export/csv", json={"project": project_doc(), "format": fmt,
                                             "speech": False})
    assert r.status_code == 200 and r.text.startswith(head)


@pytest.mark.render
def test_export_mp4_unavailable_or_works(client, app):
    r = client.post("/api/export/mp4", json={"aus": {"AU12": 1}, "fps": 4})
    if app.state.studio.mp4_unavailable() is not None:
        assert "isn't available" in err(r, 501)
    else:
        assert r.status_code == 200 and r.content[4:8] == b"ftyp"


# -- latent sliders ------------------------------------------------------------------------------
def test_latent_feature_detected(client):
    d = client.get("/api/latent").json()
    if d["available"]:
        r = client.post("/api/latent/sample", json={"z": [0.0] * d["latent_dim"]}).json()
        assert all(0 <= v <= 1 for v in r["aus"].values())
        err(client.post("/api/latent/sample", json={"z": [0.0] * (d["latent_dim"] + 1)}), 400)
    else:
        assert "unavailable" in d["reason"]
        err(client.post("/api/latent/sample", json={"z": [0.0]}), 501)
    err(client.post("/api/latent/sample", json={"z": [99.0]}), 422)


# -- limits and errors ---------------------------------------------------------------------------
def test_body_size_limit(tmp_path):
    small = create_app(tmp_path / "p", library_path=tmp_path / "e.json", max_body=1000,
                       head="builtin")
    with TestClient(small, base_url=BASE) as c:
        big = {"aus": {"AU12": 0.5}, "disabled": ["x" * 2000]}
        assert "limit" in err(c.post("/api/blend", json=big), 413)

        def chunks():
            yield b'{"aus": {}, "disabled": ["'
            for _ in range(10):
                yield b"y" * 500
            yield b'"]}'

        r = c.post("/api/blend", content=chunks(), headers={"Content-Type": "application/json"})
        assert "limit" in err(r, 413)


def test_cross_origin_writes_refused(client):
    r = client.post("/api/blend", json={"aus": {}}, headers={"Origin": "http://evil.example"})
    assert "not allowed" in err(r, 403)
    ok = client.post("/api/blend", json={"aus": {}}, headers={"Origin": BASE})
    assert ok.status_code == 200


def test_unknown_endpoint_and_method(client):
    assert "no such endpoint" in err(client.get("/api/nothing"), 404)
    err(client.delete("/api/blend"), 405)


def test_index_and_static(client):
    from mimika.web.three import vendor_ready

    r = client.get("/")
    assert r.status_code == (200 if vendor_ready() else 503)
    assert "mimika studio" in r.text
    assert client.get("/static/js/main.js").status_code == 200
    assert client.get("/api/docs").status_code == 200


# -- packaging -----------------------------------------------------------------------------------
def test_import_mimika_does_not_load_fastapi():
    code = ("import sys, mimika, mimika.studio; web = ('fastapi', 'starlette', 'uvicorn'); "
            "print(any(m.split('.')[0] in web for m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_cli_module_registers_studio():
    import argparse

    from mimika.commands import studio

    p = argparse.ArgumentParser()
    studio.register(p.add_subparsers(dest="command"))
    a = p.parse_args(["studio", "--no-browser"])
    assert (a.host, a.port, a.no_browser, a.func) == ("127.0.0.1", 8765, True, studio.cmd_studio)
