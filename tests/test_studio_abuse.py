"""The studio under hostile but fair use (issue 20): DNS rebinding, oversize and malformed
input, long exports, bad WebSocket messages. A real uvicorn server on 127.0.0.1, driven with
httpx and websockets, so that Host headers, disconnects and concurrency are the real ones."""

from __future__ import annotations

import asyncio
import json
import threading
import time

import pytest

pytest.importorskip("fastapi")
uvicorn = pytest.importorskip("uvicorn")
httpx = pytest.importorskip("httpx")
websockets = pytest.importorskip("websockets")

EVIL = "attacker.test"


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    from conftest import serve_app
    from mimika.studio.app import create_app

    d = tmp_path_factory.mktemp("studio-abuse")
    app = create_app(d / "projects", library_path=d / "expressions.json",
                     allowed_hosts=["studio.example.org"], head="builtin")
    with serve_app(app) as port:
        yield {"base": f"http://127.0.0.1:{port}", "port": port, "app": app}


@pytest.fixture(scope="module")
def http(server):
    with httpx.Client(base_url=server["base"], timeout=120) as c:
        yield c


def project(events=None, **timeline) -> dict:
    evs = events if events is not None else [
        {"kind": "expression", "start": 0.2, "duration": 1.0, "name": "happiness"}]
    return {"format": "mimika-project", "version": 1, "settings": {"head": "builtin"},
            "timeline": {"channels": [{"name": "face", "events": evs}], **timeline}}


def error_of(r, *status: int) -> str:
    assert r.status_code in status, (r.status_code, r.text[:300])
    return r.json()["error"]


# -- DNS rebinding -------------------------------------------------------------------------------
@pytest.mark.parametrize(("method", "path", "body"), [
    ("GET", "/", None),
    ("GET", "/api/projects", None),
    ("PUT", "/api/projects/stolen", project()),
    ("POST", "/api/expressions", {"name": "evil", "aus": {"AU12": 1}}),
    ("POST", "/api/export/csv", {"project": project()}),
])
def test_rebound_host_names_are_refused(server, http, method, path, body):
    evil = f"{EVIL}:{server['port']}"
    r = http.request(method, path, json=body,
                     headers={"Host": evil, "Origin": f"http://{evil}"})
    assert "not served here" in error_of(r, 403)


def test_rebound_websocket_is_refused(server):
    evil = f"{EVIL}:{server['port']}"

    async def go():  # the handshake names the attacker's host; the socket is ours
        async with websockets.connect(f"ws://{evil}/api/live", origin=f"http://{evil}",
                                      host="127.0.0.1", port=server["port"]):
            pass

    with pytest.raises(websockets.exceptions.InvalidStatus) as e:
        asyncio.run(go())
    assert e.value.response.status_code == 403


@pytest.mark.parametrize("host", ["127.0.0.1:{port}", "localhost:{port}", "[::1]:{port}",
                                  "studio.example.org", "LOCALHOST."])
def test_the_served_names_and_the_allow_list_pass(server, http, host):
    r = http.get("/api/projects", headers={"Host": host.format(port=server["port"])})
    assert r.status_code == 200, r.text


def test_a_studio_bound_to_every_interface_serves_ip_literals_but_not_names():
    from mimika.web.guard import HostPolicy

    p = HostPolicy("0.0.0.0")
    assert p.allows("192.168.1.20:8765") and p.allows("[fe80::1]:8765")
    assert not p.allows(f"{EVIL}:8765")
    assert HostPolicy("127.0.0.1", ["*.lan"]).allows("studio.lan:8765")


@pytest.mark.parametrize("host", [
    "[::1].attacker.test:8765", "localhost:8765@attacker.test", "attacker.test@localhost",
    "localhost:80:80", "localhost:http", "[::1]x", "[127.0.0.1]:8765", "local host", "",
    "localhost/evil", "127.0.0.1.attacker.test"])
def test_host_headers_are_parsed_as_authorities(host):
    from mimika.web.guard import HostPolicy

    assert not HostPolicy("127.0.0.1", ["studio.lan"]).allows(host)
    assert not HostPolicy("0.0.0.0").allows(host)


def test_userinfo_and_suffixed_ipv6_hosts_are_refused_by_the_server(server, http):
    for host in (f"[::1].{EVIL}:{server['port']}", f"localhost:{server['port']}@{EVIL}"):
        r = http.put("/api/projects/stolen", json=project(),
                     headers={"Host": host, "Origin": f"http://{host}"})
        assert "not served here" in error_of(r, 403), host


# -- oversize and malformed bodies ---------------------------------------------------------------
def test_oversize_bodies_get_413(http):
    big = b'{"aus": {}, "disabled": ["' + b"x" * (3 * 1024 * 1024) + b'"]}'
    r = http.post("/api/blend", content=big, headers={"content-type": "application/json"})
    assert "limit" in error_of(r, 413)


def _upload(header: bytes, pcm: bytes = b"\0\0" * 16000) -> bytes:
    import struct

    return struct.pack("<I", len(header)) + header + pcm


@pytest.mark.parametrize("header", [
    b'{"text": "Hi.", "sr": 16000, "x": ' + b"[" * 30000 + b"]" * 30000 + b"}",
    b'{"text": "Hi.", "sr": 1' + b"0" * 400 + b"}",
    b'{"text": "Hi.", "sr": 16000.5}',
    b'{"text": "Hi.", "sr": NaN}',
    b'{"text": "Hi.", "sr": 16000, "project": {"format": "nope"}}',
    b'{"text": "Hi.", "sr": 16000, "lang": "xx-nowhere"}',
    b'\xff\xfe',
])
def test_hostile_recording_uploads_are_a_4xx_never_a_500(http, header):
    r = http.post("/api/speech/align", content=_upload(header))
    assert 400 <= r.status_code < 500, (r.status_code, r.text[:200])
    assert "internal error" not in r.json()["error"]


def test_an_oversize_chunked_upload_gets_413_and_leaves_no_traceback(http, caplog):
    def chunks():
        for _ in range(40):
            yield b"x" * 100_000

    with caplog.at_level("DEBUG"):
        r = http.post("/api/speech/align", content=chunks())
        time.sleep(0.5)  # the endpoint sees the disconnect after the answer went out
    assert "limit" in error_of(r, 413)
    assert not [rec for rec in caplog.records if rec.exc_info], caplog.text[-2000:]


@pytest.mark.parametrize("raw", [
    '{"format": "mimika-project", "version": 1, "settings": {"fps": 1' + "0" * 400 + "}}",
    '{"format": "mimika-project", "version": 1, "settings": {"fps": 1' + "0" * 5000 + "}}",
    '{"format": "mimika-project", "version": 1, "settings": {"fps": NaN}}',
    '{"format": "mimika-project", "version": 1, "timeline": {"rate": Infinity}}',
    '{"format": "mimika-project", "version": 1, "timeline": ' + "[" * 5000 + "]" * 5000 + "}",
    '{"format": "mimika-project", "version": 1, "x": ' + "[" * 50 + "]" * 50 + "}",
])
def test_hostile_project_json_is_a_clear_4xx_never_a_500(http, raw):
    r = http.put("/api/projects/hostile", content=raw,
                 headers={"content-type": "application/json"})
    assert 400 <= r.status_code < 500, (r.status_code, r.text[:200])
    assert r.json()["error"]
    assert http.get("/api/projects/hostile").status_code == 404  # nothing was saved


def test_an_infinite_intensity_is_refused(http):
    r = http.post("/api/blend", content='{"aus": {"AU12": Infinity}}',
                  headers={"content-type": "application/json"})
    error_of(r, 422)


# -- long exports --------------------------------------------------------------------------------
@pytest.mark.parametrize(("start", "fps", "limit"), [(36000, 120, "max_duration"),
                                                     (1e7, 120, "max_duration"),
                                                     (3000, 120, "max_frames")])
def test_exports_past_the_limits_are_refused_before_any_work(http, start, fps, limit):
    ev = [{"kind": "expression", "start": start, "duration": 1.0, "name": "happiness"}]
    r = http.post("/api/export/csv?job=far", json={"project": project(ev), "fps": fps,
                                                   "speech": False})
    msg = error_of(r, 400, 422)  # (232 s and 3.1 GB, then a dropped connection, before)
    assert limit in msg and "raise it with" in msg
    assert http.get("/api/export/jobs").json() == {"jobs": []}  # no job was started


def test_an_export_within_the_limits_is_complete(http):
    ev = [{"kind": "aus", "start": 590.0, "duration": 1.0, "aus": [["AU12", 1.0]]}]
    r = http.post("/api/export/csv", json={"project": project(ev), "fps": 30, "speech": False})
    assert r.status_code == 200, r.text[:200]
    rows = r.text.strip().splitlines()
    assert len(rows) == 1 + 591 * 30 + 1  # header + frames 0 … 591 s
    assert float(rows[-1].split(",")[0]) == pytest.approx(591.0)


def _mp4_available(server) -> bool:
    from mimika.render.context import egl_available

    return server["app"].state.studio.mp4_unavailable() is None and egl_available()


def _long_mp4(http, job: str, timeout: float | None = None):
    body = {"project": project([{"kind": "aus", "start": 0.0, "duration": 59.0,
                                  "aus": [["AU12", 1.0]]}]), "fps": 30, "speech": False}
    return http.post(f"/api/export/mp4?job={job}", json=body, timeout=timeout)


def _wait_for_job(http, job: str, present: bool, within: float = 60.0) -> None:
    t0 = time.time()
    while time.time() - t0 < within:
        ids = [j["id"] for j in http.get("/api/export/jobs").json()["jobs"]]
        if (job in ids) == present:
            return
        time.sleep(0.1)
    pytest.fail(f"export {job} {'never started' if present else 'still runs'}")


@pytest.mark.render
@pytest.mark.slow
def test_a_long_export_can_be_cancelled_and_does_not_stall_short_ones(server, http):
    if not _mp4_available(server):
        pytest.skip("MP4 export needs PyAV and headless OpenGL")
    out: dict = {}
    th = threading.Thread(target=lambda: out.setdefault("r", _long_mp4(http, "long1")))
    th.start()
    _wait_for_job(http, "long1", present=True)
    r = http.post("/api/export/csv", json={"project": project(), "fps": 30})
    assert r.status_code == 200  # a short export while the long one renders …
    jobs = http.get("/api/export/jobs").json()["jobs"]
    assert [j["id"] for j in jobs] == ["long1"]  # … did not wait for it to end
    assert http.delete("/api/export/jobs/long1").json() == {"cancelled": "long1"}
    th.join(30)
    assert "cancelled" in error_of(out["r"], 409)
    _wait_for_job(http, "long1", present=False, within=30)  # the work stopped, too
    assert http.delete("/api/export/jobs/long1").status_code == 404


@pytest.mark.render
@pytest.mark.slow
def test_a_client_that_goes_away_cancels_its_export(server, http):
    if not _mp4_available(server):
        pytest.skip("MP4 export needs PyAV and headless OpenGL")
    with pytest.raises(httpx.ReadTimeout):
        _long_mp4(http, "gone1", timeout=3.0)
    _wait_for_job(http, "gone1", present=False, within=30)


@pytest.mark.render
@pytest.mark.slow
def test_an_export_past_its_time_limit_stops(server, http):
    if not _mp4_available(server):
        pytest.skip("MP4 export needs PyAV and headless OpenGL")
    from mimika import limits

    with limits.override(max_export_seconds=2):
        r = _long_mp4(http, "slow1")
    msg = error_of(r, 503)
    assert "max_export_seconds" in msg and "--max-export-seconds" in msg
    _wait_for_job(http, "slow1", present=False, within=30)


# -- WebSocket -----------------------------------------------------------------------------------
BAD_MESSAGES = [
    ("binary", b"\x00\x01"),
    ("not json", "{speak"),
    ("not an object", "[1, 2]"),
    ("deep", "[" * 100_000 + "]" * 100_000),
    ("huge int", '{"type": "speak", "id": ' + "9" * 5000 + "}"),
    ("nan", '{"type": "speak", "text": "hi", "rate": NaN}'),
    ("unknown type", '{"type": "explode"}'),
    ("bad field", '{"type": "speak", "text": "hi", "rate": 9999}'),
    ("bad project: huge int", json.dumps({"type": "speak", "id": 7, "text": "Hi.",
                                          "project": project()}).replace(
        '"start": 0.2', '"start": 1' + "0" * 400)),
    ("bad project: deep", json.dumps({"type": "speak", "id": 7, "text": "Hi.",
                                      "project": project()}).replace(
        '"channels": [', '"channels": [' + "[" * 200 + "]" * 200 + ", ", 1)),
    ("bad project: far event", json.dumps({"type": "speak", "id": 7, "text": "Hi.",
                                           "project": project([{"kind": "blink", "start": 1e7,
                                                                "duration": 0.3}])})),
    ("bad project: not one", json.dumps({"type": "speak", "id": 7, "text": "Hi.",
                                         "project": {"format": "nope"}})),
    ("oversize", "x" * (3 * 1024 * 1024)),
    ("oversize in fragments", ["x" * 4000] * 1000),
]


@pytest.mark.parametrize(("what", "message"), BAD_MESSAGES, ids=[m[0] for m in BAD_MESSAGES])
def test_bad_websocket_messages_get_an_error_and_the_socket_stays_usable(server, what, message):
    async def go():
        async with websockets.connect(f"ws://127.0.0.1:{server['port']}/api/live",
                                      max_size=None) as ws:
            await ws.send(message)
            reply = json.loads(await asyncio.wait_for(ws.recv(), 30))
            if what.startswith("oversize"):  # the server closes over-limit messages (1009)
                return reply
            await ws.send('{"type": "ping"}')
            pong = json.loads(await asyncio.wait_for(ws.recv(), 30))
            return reply, pong

    if what.startswith("oversize"):
        with pytest.raises(websockets.exceptions.ConnectionClosed) as e:
            asyncio.run(go())
        assert e.value.rcvd is not None and e.value.rcvd.code == 1009
        return
    reply, pong = asyncio.run(go())
    assert reply["type"] == "error" and reply["message"], reply
    assert "internal error" not in reply["message"]
    assert pong == {"type": "pong"}
