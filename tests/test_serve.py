"""mimika serve: the /ws API (speak, interrupt, emote, look, mood, errors), its guards, and
the player page in Chromium."""

import base64
import json

import numpy as np
import pytest

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from mimika.errors import DataError

WS = "ws://127.0.0.1:8787/ws"
#: closure_ok's tolerance on wire frames: weights travel with 3 decimals, so a closure that
#: holds exactly (AU24 = 0.4 + 0.3·AU12) may miss by rounding
WIRE_TOL = 2e-3


@pytest.fixture(scope="module")
def app():
    from mimika.serve.app import create_app

    try:
        return create_app(head="builtin")
    except DataError as e:  # three.js not vendored: scripts/setup-studio.sh
        pytest.skip(str(e))


@pytest.fixture
def client(app):
    with TestClient(app, base_url="http://127.0.0.1") as c:
        yield c


def _until(ws, kind):
    out = []
    while True:
        m = ws.receive_json()
        out.append(m)
        if m["type"] in (kind, "error"):
            return out


def test_speak_streams_frames_ahead_of_audio_covering_the_speech(client):
    with client.websocket_connect(WS) as ws:
        ready = ws.receive_json()
        assert ready["type"] == "ready" and ready["fps"] == 30
        ws.send_json({"type": "speak", "id": 7, "text": "Good evening. Bob bought a big map."})
        msgs = _until(ws, "end")
    kinds = [(m["type"], m.get("index")) for m in msgs]
    assert kinds == [("frames", 0), ("audio", 0), ("sentence", 0),
                     ("frames", 1), ("audio", 1), ("sentence", 1), ("end", None)]
    assert all(m["id"] == 7 for m in msgs)
    end = msgs[-1]
    assert not end["interrupted"]
    audio = [m for m in msgs if m["type"] == "audio"]
    pcm = b"".join(base64.b64decode(m["data"]) for m in audio)
    assert len(pcm) == 2 * sum(m["samples"] for m in audio)
    assert sum(m["samples"] for m in audio) / audio[0]["sr"] == pytest.approx(end["duration"],
                                                                              abs=1e-3)
    frames = [f for m in msgs if m["type"] == "frames" for f in m["frames"]]
    ts = [f["t"] for f in frames]
    assert ts[0] == 0 and ts == sorted(ts) and ts[-1] >= end["duration"] - 2 / 30
    assert audio[1]["t"] == pytest.approx(msgs[3]["t0"])
    # the lips close for Bob / bought / big / map (the bilabial viseme), and open between
    sent = msgs[5]
    for w in sent["words"]:
        inside = [f for f in frames if w["start"] <= f["t"] <= w["end"]]
        if w["text"] in ("Bob", "bought", "big", "map"):
            assert any(f.get("viseme") == "PP" for f in inside), w
    assert max(f.get("jawOpen", 0) for f in frames) > 0.2
    assert any("HeadYaw" in f for f in frames)  # the behaviour layers move the head


def test_interrupt_stops_the_speech(client):
    with client.websocket_connect(WS) as ws:
        ws.receive_json()
        text = " ".join(["This sentence goes on for a while."] * 8)
        ws.send_json({"type": "speak", "id": 1, "text": text})
        first = _until(ws, "audio")
        assert first[-1]["type"] == "audio"
        ws.send_json({"type": "interrupt"})
        rest = _until(ws, "end")
        assert rest[-1] == {"type": "end", "id": 1, "interrupted": True}
        assert sum(m["type"] == "audio" for m in first + rest) < 8
        ws.send_json({"type": "ping", "id": "p"})
        assert ws.receive_json() == {"type": "pong", "id": "p"}


def test_emote_look_and_mood_answer_with_relative_frames(client):
    with client.websocket_connect(WS) as ws:
        ws.receive_json()
        ws.send_json({"type": "emote", "id": 1, "expression": "happiness", "intensity": 0.8,
                      "duration": 1.0})
        m = ws.receive_json()
        assert m["type"] == "frames" and m["relative"] and len(m["frames"]) == 31
        peak = max(f.get("AU12", 0) for f in m["frames"])
        assert peak == pytest.approx(0.8, abs=0.01) and m["frames"][0].get("AU12", 0) == 0
        assert max(f.get("mouthSmileLeft", 0) for f in m["frames"]) > 0.3
        ws.send_json({"type": "look", "x": 1.0, "y": 0.0, "duration": 1.0})
        m = ws.receive_json()
        mid = m["frames"][15]
        assert mid["AU62"] == pytest.approx(1.0) and mid["LeftEyeYaw"] != 0
        ws.send_json({"type": "mood", "mood": "happy"})
        m = ws.receive_json()
        assert m["type"] == "mood" and m["face"]["AU12"] > 0
        ws.send_json({"type": "speak", "id": 2, "text": "Hello there."})
        msgs = _until(ws, "end")
        frames = [f for x in msgs if x["type"] == "frames" for f in x["frames"]]
        assert min(f.get("AU06", 0) for f in frames) > 0.1  # the happy face stays under speech


@pytest.mark.parametrize(("msg", "says"), [
    ("not json", "invalid JSON"),
    ("[1, 2]", "JSON object"),
    ('{"type": "sing"}', "unknown message type 'sing'"),
    ('{"type": "speak", "id": 3}', "needs \"text\" or \"ssml\""),
    ('{"type": "speak", "text": "hi", "rate": 1000}', "\"rate\" must be a number within 80…450"),
    ('{"type": "speak", "text": "hi", "lang": "klingon"}', "unknown language 'klingon'"),
    ('{"type": "emote", "expression": "glee"}', "glee"),
    ('{"type": "emote", "aus": {"AU12": 3}}', "within 0…1"),
    ('{"type": "mood", "mood": "grumpy"}', "grumpy"),
    ('{"type": "look", "x": "left"}', "\"x\" must be a number"),
])
def test_every_bad_message_gets_one_error_and_the_connection_stays(client, msg, says):
    with client.websocket_connect(WS) as ws:
        ws.receive_json()
        ws.send_text(msg)
        m = ws.receive_json()
        assert m["type"] == "error" and says in m["message"], m
        if '"id": 3' in msg:
            assert m["id"] == 3
        ws.send_json({"type": "ping"})
        assert ws.receive_json()["type"] == "pong"


def test_message_size_is_bounded(app, client):
    with client.websocket_connect(WS) as ws:
        ws.receive_json()
        ws.send_text(json.dumps({"type": "speak", "text": "a" * (app.state.max_body + 1)}))
        m = ws.receive_json()
        assert m["type"] == "error" and "at most" in m["message"]


def test_foreign_host_and_missing_token_are_refused():
    from mimika.serve.app import create_app

    app = create_app(head="builtin", host="0.0.0.0", token="s3cret")
    with TestClient(app, base_url="http://evil.attacker.test") as c:
        r = c.get("/health")
        assert r.status_code == 403 and "mimika serve --allow-host" in r.text
    with TestClient(app, base_url="http://127.0.0.1") as c:
        assert c.get("/health").status_code == 401
        assert c.get("/health?token=s3cret").status_code == 200
        assert c.get("/health", headers={"Authorization": "Bearer s3cret"}).status_code == 200
        with pytest.raises(WebSocketDisconnect), c.websocket_connect(WS) as ws:
            ws.receive_json()
        with c.websocket_connect(WS + "?token=s3cret") as ws:
            assert ws.receive_json()["type"] == "ready"
        page = c.get("/?token=s3cret")
        assert page.status_code == 200 and "mimika_token" in page.headers["set-cookie"]


def test_schema_describes_every_message(client):
    schema = client.get("/protocol.json").json()
    titles = " ".join(s["title"] for s in schema["oneOf"])
    for kind in ("speak", "listen", "emote", "look", "mood", "interrupt", "frames", "audio", "end",
                 "error"):
        assert kind in titles


def test_cli_refuses_a_bad_port(capsys):
    from mimika.cli import main

    assert main(["serve", "--port", "70000"]) == 2
    assert "--port 70000" in capsys.readouterr().err


# -- the player in a browser ------------------------------------------------------------------
pytest_plugins = ["studio_pages"]  # the browser fixture (Chromium through Playwright)


@pytest.fixture(scope="module")
def served(app):
    import socket
    import threading
    import time

    import uvicorn

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    srv = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning"))
    th = threading.Thread(target=srv.run, daemon=True)
    th.start()
    t0 = time.time()
    while not srv.started and time.time() - t0 < 60:
        time.sleep(0.05)
    yield f"http://127.0.0.1:{port}/"
    srv.should_exit = True
    th.join(10)


def _player(browser, url: str):
    """The player page, loaded; and the list its page errors and console errors go to."""
    page = browser.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.goto(url)
    page.wait_for_function("window.mimikaReady === true", timeout=120_000)
    return page, errors


def test_the_player_page_speaks_and_moves_the_mouth(browser, served):
    page, errors = _player(browser, served)
    n_morphs = page.evaluate("window.mimikaHead.meshes.reduce((n, m) => n + "
                             "Object.keys(m.morphTargetDictionary).length, 0)")
    assert n_morphs > 20
    page.evaluate("() => { window.spoken = false; window.mimikaHead.speak('Good evening. "
                  "Here is the news.').then(() => { window.spoken = true; }); }")
    page.wait_for_function("window.mimikaHead.stats.maxMouth > 0.15", timeout=60_000)
    page.wait_for_function("window.spoken === true", timeout=60_000)  # played to its end
    stats = page.evaluate("window.mimikaHead.stats")
    assert stats["errors"] == [] and stats["frames"] > 10
    assert errors == []
    page.close()


def test_the_player_streams_audio_it_plays_itself_and_moves_the_mouth(browser, served):
    """head.stream(node): a page's own audio (an AudioBufferSourceNode) goes to ``listen``;
    the frames that come back move the mouth in time with the (delayed) sound."""
    from mimika.speech.tts import synthesize

    u = synthesize("Bob bought a big map, and a blue pub.", engine="espeak")
    pcm = base64.b64encode((np.clip(u.audio, -1, 1) * 32767).astype("<i2").tobytes()).decode()
    page, errors = _player(browser, served)
    page.evaluate("""async ([data, sr]) => {
        const head = window.mimikaHead, ctx = head.audioContext;
        const bytes = Uint8Array.from(atob(data), (c) => c.charCodeAt(0));
        const pcm = new Int16Array(bytes.buffer);
        const buf = ctx.createBuffer(1, pcm.length, sr);
        const ch = buf.getChannelData(0);
        for (let i = 0; i < pcm.length; i++) ch[i] = pcm[i] / 32768;
        const src = ctx.createBufferSource();
        src.buffer = buf;
        const live = await head.stream(src);
        window.streamed = false;
        src.onended = () => live.stop();
        live.done.then(() => { window.streamed = true; });
        src.start();
    }""", [pcm, u.sr])
    page.wait_for_function("window.streamed === true", timeout=60_000)
    stats = page.evaluate("window.mimikaHead.stats")
    assert stats["errors"] == [] and stats["maxMouth"] > 0.15
    assert errors == []
    page.close()


def test_listen_streams_lipsync_from_audio_alone(client):
    """The agent's own audio (a neural voice) in 50 ms chunks: frames cover it on its clock,
    the lips close for most of Bob / bought / big / map / blue / pub, as offline."""
    from mimika.speech import piper
    from mimika.speech.coarticulation import bilabial_apex_times, closure_ok
    from mimika.speech.tts import synthesize

    if not piper.default_voice("en"):
        pytest.skip("the Piper voice is not installed")
    u = synthesize("Bob bought a big map, and a blue pub.", engine="piper", rate=140)
    with client.websocket_connect(WS) as ws:
        ws.receive_json()
        pcm = (np.clip(u.audio, -1, 1) * 32767).astype("<i2").tobytes()
        step = 2 * int(0.05 * u.sr)
        for k in range(0, len(pcm), step):
            ws.send_json({"type": "listen", "id": "mic", "sr": u.sr,
                          "final": k + step >= len(pcm),
                          "data": base64.b64encode(pcm[k:k + step]).decode()})
        frames, end = [], None
        while end is None:
            m = ws.receive_json()
            assert m["type"] != "error", m
            if m["type"] == "frames":
                frames += m["frames"]
            else:
                end = m
    assert end == {"type": "end", "id": "mic", "duration": pytest.approx(u.duration, abs=1e-3),
                   "interrupted": False}
    ts = [f["t"] for f in frames]
    assert ts[0] == 0 and np.allclose(np.diff(ts), 1 / 30, atol=2e-4)
    assert ts[-1] >= u.duration - 2 / 30
    assert max(f.get("AU26", 0) + f.get("AU25", 0) for f in frames) > 0.3
    apex = bilabial_apex_times(u)
    hit = sum(any(closure_ok(frames[j], tol=WIRE_TOL) for j in range(max(0, round(t * 30) - 1),
                                                      min(len(frames), round(t * 30) + 2)))
              for t in apex)
    assert len(apex) >= 6 and hit / len(apex) >= 0.5, (hit, len(apex))


def _held_out_grid(n: int):
    """``n`` GRID recordings the shipped class model never saw: (audio, sr, words)."""
    import os
    from pathlib import Path

    from mimika.speech.audio import read_wav
    from mimika.speech.streaming import model

    d = Path(os.environ.get("MIMIKA_SPEECH_DIR", "/nonexistent"))
    if not (d / "wav").is_dir():
        pytest.skip("MIMIKA_SPEECH_DIR not set: no GRID recordings")
    seen = set(model().meta["train"]) | set(model().meta["validation"])
    out = []
    for p in sorted((d / "wav").glob("*.wav")):
        if p.stem not in seen and len(out) < n:
            a, sr = read_wav(p)
            words = [ln.split()[2] for ln in (d / "align" / f"{p.stem}.align").read_text()
                     .splitlines() if ln.split()[2] not in ("sil", "sp")]
            out.append((a, sr, words))
    return out


def _stream(a: np.ndarray, sr: int, **kw) -> list[dict]:
    from mimika.serve.listen import ListenStream

    st = ListenStream(sr, **kw)
    frames = []
    step = int(0.05 * sr)
    for k in range(0, len(a), step):
        frames += st.feed(a[k:k + step], final=k + step >= len(a))
    return frames


def test_listen_on_real_recordings_closes_the_lips_for_bilabials():
    """GRID recordings the recogniser was not trained on, streamed in 50 ms chunks: the lips
    close at most /p b m/ of the aligned transcript, as often as offline audio-only lip-sync
    of the same recording; the visemes are those of offline recognition."""
    from mimika.serve.frames import frames as wire
    from mimika.speech.alignment import align, recognise
    from mimika.speech.coarticulation import bilabial_apex_times, closure_ok, mouth_track
    from mimika.speech.export import viseme_cues

    n = hit = off = same = total = 0
    for a, sr, words in _held_out_grid(8):
        frames = _stream(a, sr)
        u = recognise(a, sr=sr)
        offline = wire(mouth_track(u, fps=30), cues=viseme_cues(u))
        assert len(frames) == len(offline)
        same += sum(f.get("viseme") == g.get("viseme")
                    for f, g in zip(frames, offline, strict=True))
        total += len(frames)
        for t in bilabial_apex_times(align(a, sr=sr, transcript=" ".join(words))):
            n += 1
            near = range(max(0, round(t * 30) - 1), min(len(frames), round(t * 30) + 2))
            hit += any(closure_ok(frames[j], tol=WIRE_TOL) for j in near)
            off += any(closure_ok(offline[j], tol=WIRE_TOL) for j in near)
    assert n >= 8 and hit / n >= 0.6 and hit >= off - 0.1 * n, (hit, off, n)
    assert same / total >= 0.95


def test_listen_sends_each_frame_once_a_fixed_lookahead_after_its_instant():
    """Frames leave as soon as the audio a look-ahead past them has come, whatever the chunk
    size, and the stream keeps only what the next frames need (memory stays flat)."""
    from mimika.serve.listen import ListenStream
    from mimika.speech.tts import synthesize

    u = synthesize("Bob bought a big map, and a blue pub.", engine="espeak")
    a = np.tile(u.audio, 6)  # ~12 s
    for la in (0.1, 0.3):
        st = ListenStream(u.sr, lookahead=la)
        assert st.lookahead == pytest.approx(max(la, st.rec.lookahead))
        sent, step, runs = [], int(0.02 * u.sr), []
        for k in range(0, len(a), step):
            sent += st.feed(a[k:k + step], final=k + step >= len(a))
            heard = min(k + step, len(a)) / u.sr
            if st.lookahead + 0.05 < heard and k + step < len(a):
                # every frame whose instant lies a look-ahead (+ one 10 ms decision) back is out
                assert sent and sent[-1]["t"] >= heard - st.lookahead - 0.01 - 1 / 30
                assert sent[-1]["t"] <= heard - st.lookahead + 1e-6
                runs.append(len(st.runs))
        assert [f["t"] for f in sent] == pytest.approx([k / 30 for k in range(len(sent))],
                                                         abs=1e-4)
        assert max(runs) < 40 and len(st.rec.features.buf) < u.sr


def test_listen_streams_per_client_are_bounded(client):
    """At most MAX_STREAMS listen streams at once per client; a final chunk frees one."""
    from mimika.serve.session import MAX_STREAMS

    chunk = base64.b64encode(np.zeros(800, "<i2").tobytes()).decode()
    with client.websocket_connect(WS) as ws:
        ws.receive_json()
        for i in range(MAX_STREAMS):
            ws.send_json({"type": "listen", "id": i, "sr": 16000, "data": chunk})
        ws.send_json({"type": "listen", "id": "one too many", "sr": 16000, "data": chunk})
        m = ws.receive_json()
        while m["type"] == "frames":
            m = ws.receive_json()
        assert m["type"] == "error" and f"at most {MAX_STREAMS}" in m["message"]
        ws.send_json({"type": "listen", "id": 0, "sr": 16000, "data": chunk, "final": True})
        while (m := ws.receive_json())["type"] != "end":
            assert m["type"] == "frames"
        ws.send_json({"type": "listen", "id": "now room", "sr": 16000, "data": chunk})
        ws.send_json({"type": "ping"})
        while (m := ws.receive_json())["type"] != "pong":
            assert m["type"] == "frames", m
