"""One client of ``mimika serve``: the ``/ws`` conversation.

Client → server (JSON text messages; the schema is ``serve/data/protocol.json``)::

    {"type": "speak", "id": 1, "text": "Good evening.", "lang": "en", "rate": 175,
     "voice": "joe", "mood": "happy", "expressions": [{"name": "happiness", "intensity": 0.4}]}
    {"type": "speak", "id": 2, "ssml": "<speak>Hello <break time='300ms'/> there.</speak>"}
    {"type": "emote", "expression": "surprise", "intensity": 0.8, "duration": 1.5}
    {"type": "emote", "aus": {"AU12": 0.6}, "duration": 2}
    {"type": "look", "x": 0.3, "y": -0.1}          # -1 … 1: right / up of the viewer
    {"type": "mood", "mood": "happy"}
    {"type": "listen", "id": "mic", "sr": 16000, "data": "<base64 s16le>", "final": false}
    {"type": "interrupt"}     {"type": "ping"}

Server → client: ``ready`` on connect; for a ``speak``, sentence by sentence, ``frames``
(``{"t": s, …weights}`` on the audio clock of that speech: 0 = its first sample; see
:mod:`mimika.serve.frames`) *before* the ``audio`` they belong to (``t`` where the chunk starts,
``sr``, ``samples``, ``data``: base64 of 16-bit little-endian mono PCM), then ``sentence``
(text, words with times), and ``end`` (``interrupted`` true after an interrupt). ``emote``,
``look`` and ``mood`` answer with ``frames`` whose ``relative`` is true: ``t`` counts from when
the client receives them, to be added on top of what plays. A ``listen`` stream (the agent's
own audio, any rate) is answered with ``frames`` on its own clock (0 = its first sample) as
they become final (:mod:`mimika.serve.listen`), and ``end`` after ``final``. Every bad
message is answered with ``error`` (``id`` when the message had one) and the connection stays
open.

Backpressure: a client's messages wait in a bounded queue (:data:`QUEUE`); when it is full,
synthesis for that client waits, so a slow or vanished client costs no memory and never
stalls another client.
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import logging
import time
from typing import Any

from starlette.concurrency import run_in_threadpool
from starlette.websockets import WebSocket, WebSocketDisconnect

from mimika import limits
from mimika.errors import DataError, MimikaError, ParameterError
from mimika.serve.speech import FPS

log = logging.getLogger(__name__)

QUEUE = 32  #: messages waiting for one client before its speech pauses
MAX_EMOTE_S = 30.0
KINDS = ("speak", "listen", "emote", "look", "mood", "interrupt", "ping")
MAX_STREAMS = 4  #: listen streams open at once per client


class Session:
    """The state of one connection: its mood, face, gaze and the speech in progress."""

    def __init__(self, ws: WebSocket, state: Any, *, max_message: int):
        self.ws = ws
        self.state = state
        self.max_message = max_message
        self.queue: asyncio.Queue[dict[str, Any] | None] = asyncio.Queue(QUEUE)
        self.mood: str | None = None
        self.speech: asyncio.Task | None = None
        self.speech_id: Any = None
        self.streams: dict[Any, Any] = {}  # listen id -> ListenStream

    # -- sending ------------------------------------------------------------------------------
    async def send(self, msg: dict[str, Any]) -> None:
        await self.queue.put(msg)

    async def _sender(self) -> None:
        while (msg := await self.queue.get()) is not None:
            await self.ws.send_json(msg)

    async def error(self, message: str, mid: Any = None) -> None:
        await self.send({"type": "error", "message": message,
                         **({"id": mid} if mid is not None else {})})

    # -- the conversation ---------------------------------------------------------------------
    async def run(self) -> None:
        await self.ws.accept()
        sender = asyncio.create_task(self._sender())
        from mimika.speech.tts import choose_engine

        kind, info = choose_engine(None, "en", None)
        await self.send({"type": "ready", "fps": FPS, "voice": info.name if info else "espeak-ng",
                         "engine": kind, "messages": list(KINDS)})
        try:
            while True:
                msg = await self.ws.receive()
                if msg["type"] == "websocket.disconnect":
                    break
                await self.handle(msg)
        except WebSocketDisconnect:
            pass
        finally:
            await self._stop_speech()
            sender.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await sender

    async def handle(self, msg: dict[str, Any]) -> None:
        text = msg.get("text")
        if text is None:
            await self.error("send JSON text messages (binary messages are not taken)")
            return
        if len(text.encode("utf-8", "replace")) > self.max_message:
            await self.error(f"a message may be at most {self.max_message} bytes (max_body)")
            return
        try:
            data = limits.loads_json(text, "message")
        except DataError as e:
            await self.error(str(e))
            return
        if not isinstance(data, dict):
            await self.error("a message is a JSON object with a \"type\"")
            return
        mid = data.get("id")
        kind = data.get("type")
        try:
            if kind == "speak":
                await self._speak(data)
            elif kind == "listen":
                await self._listen(data)
            elif kind == "interrupt":
                await self._interrupt()
            elif kind == "emote":
                await self._emote(data)
            elif kind == "look":
                await self._look(data)
            elif kind == "mood":
                await self._mood(data)
            elif kind == "ping":
                await self.send({"type": "pong", **({"id": mid} if mid is not None else {})})
            else:
                raise ParameterError(f"unknown message type {kind!r}; send one of "
                                     f"{', '.join(KINDS)}")
        except MimikaError as e:
            await self.error(str(e), mid)

    # -- speech -------------------------------------------------------------------------------
    async def _speak(self, data: dict[str, Any]) -> None:
        from mimika.speech.tts import choose_engine

        text, ssml = data.get("text"), data.get("ssml")
        if (text is None) == (ssml is None):
            raise ParameterError("speak needs \"text\" or \"ssml\" (one of them)")
        body = text if ssml is None else ssml
        if not isinstance(body, str) or not body.strip():
            raise ParameterError("speak: the text is empty")
        lang = _str(data, "lang", "en")
        voice = data.get("voice")
        if voice is not None and not isinstance(voice, str):
            raise ParameterError("speak: \"voice\" is a voice name or path")
        rate = _num(data, "rate", 175, 80, 450)
        mood = data.get("mood", self.mood)
        if mood is not None:
            _check_mood(mood)
        faces = [_expression(e) for e in _list(data, "expressions")]
        limits.check_speech(body, rate, "the speak text")
        choose_engine(None, lang, voice)  # an unknown voice or language: refuse now
        await self._stop_speech()
        self.speech_id = data.get("id")
        self.speech = asyncio.create_task(self._speech(
            self.speech_id, body, ssml is not None, lang=lang, voice=voice, rate=int(rate),
            mood=mood, faces=faces))

    async def _speech(self, sid: Any, body: str, ssml: bool, *, lang: str, voice: str | None,
                      rate: int, mood: str | None, faces: list[dict[str, float]]) -> None:
        from mimika.serve import speech

        t_start = time.perf_counter()
        t0 = 0.0
        start: dict[str, float] | None = None
        try:
            parts = await run_in_threadpool(speech.sentences, body, ssml, lang)
            for i, part in enumerate(parts):
                seg = await run_in_threadpool(speech.speak_part, self.state, part, ssml,
                                              lang=lang, voice=voice, rate=rate)
                out = await run_in_threadpool(speech.part_messages, seg, t0, index=i,
                                              mood=mood, faces=faces, start=start,
                                              mood_face=speech.face_of(mood))
                frames_msg, audio_msg, sentence_msg, start = out
                for m in (frames_msg, audio_msg, sentence_msg):
                    m["id"] = sid
                    await self.send(m)
                if i == 0:
                    log.info("serve: first audio %.0f ms after speak",
                             (time.perf_counter() - t_start) * 1000)
                t0 += seg.duration
        except asyncio.CancelledError:
            raise
        except MimikaError as e:
            await self.error(str(e), sid)
            return
        except Exception as e:  # a bug: answer anyway, never leave the agent waiting
            log.exception("serve: speech failed")
            await self.error(f"internal error: {type(e).__name__}: {e}", sid)
            return
        await self.send({"type": "end", "id": sid, "duration": round(t0, 4),
                         "interrupted": False})

    async def _stop_speech(self) -> bool:
        task, self.speech = self.speech, None
        if task is None or task.done():
            return False
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError, Exception):
            await task
        return True

    async def _interrupt(self) -> None:
        sid = self.speech_id
        if await self._stop_speech():
            await self.send({"type": "end", "id": sid, "interrupted": True})
        else:
            await self.send({"type": "end", "id": sid, "interrupted": False, "idle": True})

    # -- listening ----------------------------------------------------------------------------
    async def _listen(self, data: dict[str, Any]) -> None:
        import numpy as np

        from mimika.serve.listen import HOP, LOOKAHEAD, ListenStream

        sid = data.get("id")
        if not isinstance(sid, str | int):
            raise ParameterError("listen needs an \"id\" naming its stream")
        st = self.streams.get(sid)
        if st is None:
            if len(self.streams) >= MAX_STREAMS:
                raise ParameterError(f"at most {MAX_STREAMS} listen streams at once; end one "
                                     "with \"final\": true")
            st = self.streams[sid] = ListenStream(
                int(_num(data, "sr", 16000, 4000, 96000)), lang=_str(data, "lang", "en"),
                hop=_num(data, "hop", HOP, 0.0, 1.0),
                lookahead=_num(data, "lookahead", LOOKAHEAD, 0.0, 1.0))
        raw = data.get("data", "")
        try:
            pcm = base64.b64decode(raw, validate=True) if raw else b""
        except (ValueError, TypeError):
            raise ParameterError("listen: \"data\" must be base64 of 16-bit PCM") from None
        if len(pcm) % 2:
            raise ParameterError("listen: \"data\" must hold whole 16-bit samples")
        final = bool(data.get("final", False))
        a = np.frombuffer(pcm, "<i2").astype(np.float32) / 32768.0
        try:
            out = await run_in_threadpool(st.feed, a, final=final)
        except MimikaError:
            self.streams.pop(sid, None)
            raise
        if out:
            await self.send({"type": "frames", "id": sid, "relative": False,
                             "t0": out[0]["t"], "fps": FPS, "frames": out})
        if final:
            self.streams.pop(sid, None)
            await self.send({"type": "end", "id": sid, "duration": round(st.received, 4),
                             "interrupted": False})

    # -- face ---------------------------------------------------------------------------------
    async def _emote(self, data: dict[str, Any]) -> None:
        from mimika.serve.frames import envelope, frames

        aus = _expression(data) if "aus" not in data else _aus(data["aus"])
        duration = _num(data, "duration", 2.0, 0.1, MAX_EMOTE_S)
        fade = _num(data, "fade", 0.3, 0.0, duration / 2)
        track = envelope(aus, duration=duration, fade=fade, fps=FPS)
        await self.send({"type": "frames", "id": data.get("id"), "relative": True,
                         "fps": FPS, "frames": frames(track)})

    async def _look(self, data: dict[str, Any]) -> None:
        from mimika.serve.frames import envelope, frames

        x, y = _num(data, "x", 0.0, -1.0, 1.0), _num(data, "y", 0.0, -1.0, 1.0)
        aus = {"AU61": max(-x, 0.0), "AU62": max(x, 0.0), "AU63": max(y, 0.0),
               "AU64": max(-y, 0.0)}
        hold = _num(data, "duration", 2.0, 0.1, MAX_EMOTE_S)
        track = envelope(aus, duration=hold, fade=min(0.15, hold / 2), fps=FPS)
        await self.send({"type": "frames", "id": data.get("id"), "relative": True,
                         "fps": FPS, "frames": frames(track)})

    async def _mood(self, data: dict[str, Any]) -> None:
        from mimika.serve.speech import face_of

        mood = _str(data, "mood", "neutral")
        _check_mood(mood)
        self.mood = None if mood == "neutral" else mood
        await self.send({"type": "mood", "id": data.get("id"), "mood": mood,
                         "face": face_of(self.mood)})


# -- message fields ---------------------------------------------------------------------------
def _str(d: dict[str, Any], key: str, default: str) -> str:
    v = d.get(key, default)
    if not isinstance(v, str) or not v.strip():
        raise ParameterError(f"\"{key}\" must be a non-empty string")
    return v.strip()


def _num(d: dict[str, Any], key: str, default: float, lo: float, hi: float) -> float:
    v = d.get(key, default)
    if isinstance(v, bool) or not isinstance(v, int | float) or not lo <= v <= hi:
        raise ParameterError(f"\"{key}\" must be a number within {lo:g}…{hi:g}, not {v!r}")
    return float(v)


def _list(d: dict[str, Any], key: str) -> list[Any]:
    v = d.get(key, [])
    if not isinstance(v, list) or len(v) > 16:
        raise ParameterError(f"\"{key}\" must be a list of at most 16 items")
    return v


def _aus(v: Any) -> dict[str, float]:
    from mimika.facs.catalogue import parse_au

    if not isinstance(v, dict) or not v or len(v) > 64:
        raise ParameterError("\"aus\" must be an object of 1…64 AU intensities "
                             "({\"AU12\": 0.6})")
    out = {}
    for k, x in v.items():
        if isinstance(x, bool) or not isinstance(x, int | float) or not 0 <= x <= 1:
            raise ParameterError(f"AU intensity {k}={x!r} must be within 0…1")
        out[parse_au(str(k))] = float(x)
    return out


def _expression(d: Any) -> dict[str, float]:
    from mimika.knowledge.expressions import get_expression

    if not isinstance(d, dict):
        raise ParameterError("an expression is {\"name\": …, \"intensity\": 0…1}")
    name = d.get("expression", d.get("name"))
    if not isinstance(name, str):
        raise ParameterError("give the expression's name (\"expression\": \"happiness\")")
    return get_expression(name, _num(d, "intensity", 1.0, 0.0, 1.0))


def _check_mood(mood: Any) -> None:
    from mimika.knowledge.mood import get_mood

    if not isinstance(mood, str):
        raise ParameterError("\"mood\" must be a mood name (happy, depressed, nervous …)")
    get_mood(mood)
