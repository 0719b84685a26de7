"""mimika studio API for the editor's tools: heads, look, Blender rules, project checks,
speech with behaviour layers, PNG stills and contact sheets."""

from __future__ import annotations

import io
import itertools
import json
import struct
import warnings

import numpy as np
import pytest

pytest.importorskip("fastapi")
pytest.importorskip("httpx")

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    from fastapi.testclient import TestClient

from conftest import needs_ict
from mimika.studio.app import create_app
from test_studio_api import err, project_doc


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    d = tmp_path_factory.mktemp("studio-tools")
    with TestClient(create_app(d / "projects", library_path=d / "expressions.json", head="builtin"),
                    base_url="http://127.0.0.1:8765") as c:
        yield c


def glb_json(data: bytes) -> dict:
    return json.loads(data[20:20 + struct.unpack("<I", data[12:16])[0]])


# -- heads ---------------------------------------------------------------------------------------
def test_heads_list_what_list_heads_returns(client):
    from mimika.face.heads import list_heads

    d = client.get("/api/heads").json()
    assert d["default"] == "builtin"
    assert [h["name"] for h in d["heads"]] == [h.name for h in list_heads()]
    assert all(set(h) == {"name", "rig", "available", "description"} for h in d["heads"])


def test_unknown_head_is_refused(client):
    assert "no head called" in err(client.get("/api/head", params={"name": "martian"}), 400)
    err(client.get("/api/head.glb", params={"name": "martian"}), 400)


def test_a_head_not_installed_says_so_plainly(client, monkeypatch):
    from mimika.face import heads

    real = heads.list_heads()
    monkeypatch.setattr(heads, "list_heads", lambda: [
        *real, heads.HeadInfo("avatar", "GltfRig", False, "not found: set MIMIKA_X (see 'x')")])
    msg = err(client.get("/api/head", params={"name": "avatar"}), 400)
    assert msg == "the avatar head is not installed on this computer"
    assert [h["name"] for h in client.get("/api/heads").json()["heads"]][-1] == "avatar"


def test_head_info_has_a_frame_for_the_camera(client):
    f = client.get("/api/head").json()["frame"]
    assert 0.1 < f["height"] < 0.4 and 0.05 < f["width"] < 0.3  # metres: a human face
    assert len(f["centre"]) == 3


@needs_ict
def test_ict_head_by_name(client):
    info = client.get("/api/head", params={"name": "ict"}).json()
    assert info["head"] == "ict" and "AU12" in info["aus"]
    r = client.get("/api/head.glb", params={"name": "ict"})
    assert r.status_code == 200 and r.content[:4] == b"glTF"
    builtin = client.get("/api/head.glb")
    assert r.headers["etag"] != builtin.headers["etag"]
    doc = project_doc()
    doc["settings"]["head"] = "ict"
    r = client.post("/api/export/gltf", json={"project": doc, "speech": False})
    assert r.status_code == 200
    n_ict = max(a["count"] for a in glb_json(r.content)["accessors"])
    assert n_ict > 20000  # the ICT mesh, not the built-in head


# -- look and rules ------------------------------------------------------------------------------
def test_look_comes_from_the_renderer(client):
    from mimika.render.lighting import NEWS as NEWS_LIGHTING
    from mimika.render.renderer import load_materials

    d = client.get("/api/look").json()
    assert set(d["looks"]) == {"plain", "news"}
    assert d["looks"]["news"]["key_col"] == list(NEWS_LIGHTING.key_col)
    assert d["looks"]["news"]["skin_shader"] and not d["looks"]["plain"]["skin_shader"]
    assert d["materials"]["skin"]["wrap"] == load_materials()["skin"].wrap
    assert "skin" in d["skin"]["materials"]


def test_blender_rules_are_explained(client):
    from mimika.facs.blender import Blender

    rules = client.get("/api/blend/rules").json()["rules"]
    assert [r["rule"] for r in rules] == [r.notation for r in Blender.default().rules]
    r = next(r for r in rules if r["rule"] == "12<15Z")
    assert "Lip Corner Depressor (AU15)" in r["text"] and "Lip Corner Puller" in r["text"]
    assert r["kind"] == "strong" and "0.9" in r["text"]
    assert all("{" not in x["text"] and "{" not in x["title"] for x in rules)


# -- projects ------------------------------------------------------------------------------------
def test_project_with_a_missing_expression_is_refused(client):
    doc = project_doc(events=[{"kind": "expression", "start": 0.5, "duration": 1.0,
                               "name": "no-such-face", "intensity": 0.8}])
    r = client.put("/api/projects/missing", json=doc)
    assert "no expression called “no-such-face”" in err(r, 422)
    assert r.json()["problems"] == ["Expressions track, trigger 1 (at 0.50 s): there is no "
                                    "expression called “no-such-face” in your library"]
    d = client.post("/api/projects/check", json=doc).json()
    assert d["ok"] is False and "no-such-face" in d["problems"][0]
    err(client.post("/api/timeline/sample", json={"project": doc}), 422)


def test_project_check_speaks_plainly(client):
    doc = project_doc()
    doc["timeline"]["channels"][0]["events"][0]["start"] = "soon"
    d = client.post("/api/projects/check", json=doc).json()
    assert not d["ok"] and d["problems"][0].startswith("Expressions track, trigger 1, start:")
    d = client.post("/api/projects/check", json=project_doc()).json()
    assert d["ok"] and d["project"]["format"] == "mimika-project"
    assert not client.post("/api/projects/check", json=[1]).json()["ok"]
    doc = project_doc()
    doc["settings"].update(behaviour=["blink", "dance"], blender_off=["99<1"], look="noir")
    probs = client.post("/api/projects/check", json=doc).json()["problems"]
    assert len(probs) == 3


def test_user_expressions_resolve_on_the_timeline(client):
    """The studio's own library (--library) names expressions for the timeline too."""
    assert client.post("/api/expressions", json={"name": "my-brows", "aus": {"AU01": 0.9}}
                       ).status_code == 201
    doc = project_doc(events=[{"kind": "expression", "start": 0.0, "duration": 1.0,
                               "name": "my-brows", "intensity": 1.0, "onset": 0.2,
                               "offset": 0.2}])
    d = client.post("/api/timeline/sample", json={"project": doc, "fps": 10}).json()
    j = d["channels"].index("AU01")
    assert max(row[j] for row in d["values"]) == pytest.approx(0.9, abs=0.01)


def test_disabled_blender_rules_apply_to_the_timeline(client):
    ev = [{"kind": "aus", "start": 0.0, "duration": 1.0, "aus": [["AU12", 1.0], ["AU15", 1.0]],
           "intensity": 1.0, "onset": 0.1, "offset": 0.1}]
    doc = project_doc(events=ev)
    doc["settings"]["blend"] = True
    peak = {}
    for off in ([], ["12<15Z"]):
        doc["settings"]["blender_off"] = off
        d = client.post("/api/timeline/sample", json={"project": doc, "fps": 10}).json()
        j = d["channels"].index("AU12")
        peak[bool(off)] = max(row[j] for row in d["values"])
    assert peak[False] < 0.05 and peak[True] > 0.95


# -- speech --------------------------------------------------------------------------------------
def test_speak_with_behaviour_layers(client):
    doc = project_doc("Good evening. Here is the news. Goodbye.", events=[])
    doc["settings"]["behaviour"] = ["blink", "gaze", "head", "brows", "smile"]
    d = client.post("/api/speak", json={"text": "Good evening. Here is the news. Goodbye.",
                                        "project": doc}).json()
    chans = set().union(*(s["channels"] for s in d["segments"]))
    assert {"AU45", "AU12"} <= chans and chans & {"AU51", "AU52", "AU53", "AU54", "AU55"}
    doc["settings"]["behaviour"] = []
    d2 = client.post(f"/api/speech/{d['key']}/frames", json={"project": doc}).json()
    chans2 = set().union(*(s["channels"] for s in d2["segments"]))
    assert "AU45" not in chans2  # blink switched off: the mouth only
    # sentences join without a jump in the head's motion
    segs = d["segments"]
    for a, b in itertools.pairwise(segs):
        for c in set(a["channels"]) & set(b["channels"]) & {"AU51", "AU52", "AU53", "AU54"}:
            last = a["values"][-1][a["channels"].index(c)]
            first = b["values"][0][b["channels"].index(c)]
            assert abs(last - first) < 0.1, c


def test_long_text_is_refused_not_cut(client):
    text = ("word " * 1100).strip()
    assert len(text) > 5000
    msg = err(client.post("/api/export/csv", json={"project": project_doc(text, events=[])}), 400)
    assert "5,499 characters" in msg and "at most 5,000" in msg


# -- stills --------------------------------------------------------------------------------------
def _png(r) -> np.ndarray:
    from PIL import Image

    assert r.status_code == 200, r.text
    assert r.headers["content-type"] == "image/png"
    return np.asarray(Image.open(io.BytesIO(r.content)).convert("RGB"))


@pytest.mark.render
def test_png_still_of_the_pose(client):
    neutral = _png(client.post("/api/export/png", json={"aus": {}, "width": 320,
                                                         "height": 240}))
    smile = _png(client.post("/api/export/png", json={"aus": {"AU12": 1, "AU06": 0.6},
                                                       "width": 320, "height": 240}))
    assert neutral.shape == (240, 320, 3)
    assert np.abs(neutral.astype(int) - smile).mean() > 0.3  # the pose shows
    news = _png(client.post("/api/export/png", json={"aus": {}, "look": "news", "width": 320,
                                                      "height": 240}))
    assert np.abs(neutral.astype(int) - news).mean() > 5  # another set and light
    blocked = _png(client.post("/api/export/png", json={
        "aus": {"AU12": 1, "AU15": 1}, "blend": True, "width": 320, "height": 240}))
    sad = _png(client.post("/api/export/png", json={"aus": {"AU15": 1}, "width": 320,
                                                     "height": 240}))
    assert np.abs(blocked.astype(int) - sad).max() <= 2  # 12<15Z: AU12 is blended away


@pytest.mark.render
def test_contact_sheet_of_the_library(client):
    sheet = _png(client.post("/api/export/sheet", json={
        "names": ["neutral", "happiness", "surprise"], "tile": 128, "columns": 3}))
    assert sheet.shape[1] > 3 * 128 and sheet.shape[0] > 128
    err(client.post("/api/export/sheet", json={"names": ["nope"], "tile": 128}), 400)


# -- recorded speech -----------------------------------------------------------------------------
def upload(text: str, audio: np.ndarray, sr: int, **extra) -> bytes:
    head = json.dumps({"text": text, "lang": "en", "sr": sr, **extra}).encode()
    pcm = (np.clip(audio, -1, 1) * 32767).astype("<i2").tobytes()
    return struct.pack("<I", len(head)) + head + pcm


def test_recording_is_aligned_to_its_text(client):
    from mimika.speech import synthesize

    text = "Good evening. The weather stays dry and mild."
    rec = synthesize(text, rate=130)  # a "recording": slower than the aligner's reference
    doc = project_doc(text, events=[])
    doc["settings"]["behaviour"] = ["blink"]
    r = client.post("/api/speech/align", content=upload(text, rec.audio, rec.sr, project=doc))
    assert r.status_code == 200, r.text
    d = r.json()
    assert d["aligned"] and len(d["segments"]) == len(d["sentences"]) == 2
    assert d["duration"] == pytest.approx(rec.duration, abs=0.01)
    words = [w["text"].strip() for s in d["sentences"] for w in s["words"]]
    assert words[:2] == ["Good", "evening"] and words[-1] == "mild"
    assert "AU45" in d["segments"][0]["channels"]  # behaviour layers run on recordings too
    wav = client.get(d["audio"])
    assert wav.status_code == 200 and len(wav.content) > 2 * rec.sr * rec.duration * 0.9
    # exports use the recording, not a synthesis of the text
    r = client.post("/api/export/csv", json={"project": doc, "fps": 25,
                                             "speech_key": d["key"]})
    rows = r.text.strip().splitlines()
    assert len(rows) - 1 == pytest.approx(rec.duration * 25, abs=2)
    assert "load it again" in err(client.post("/api/export/csv", json={
        "project": doc, "speech_key": "0" * 20}), 400)


def test_recording_upload_errors_are_plain(client):
    a = np.zeros(22050, np.float32)
    assert "choose the file again" in err(client.post("/api/speech/align", content=b"xx"), 400)
    assert "type the words" in err(client.post("/api/speech/align",
                                               content=upload(" ", a, 22050)), 400)
    assert "choose the file again" in err(client.post("/api/speech/align",
                                                      content=upload("Hi.", a, 5)), 400)
