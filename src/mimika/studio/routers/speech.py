"""Speaking: text → speech audio + mixed AU frames, over HTTP or streamed over a WebSocket.

WebSocket ``/api/live`` protocol (client → server: JSON text messages)::

    {"type": "speak", "id": 1, "text": "…", "lang": "en", "rate": 175, "fps": 30,
     "blend": false, "project": {…mimika project…}}
    {"type": "stop"}   {"type": "ping"}

server → client, per sentence as soon as it is synthesised: a binary ``audio`` message
(uint32 LE header length, JSON header ``{"type": "audio", "index", "t0", "sr", "samples"}``,
int16 LE PCM), a ``frames`` message (``t0``, ``fps``, ``channels``, ``values``) and a
``sentence`` message (text, start, end, words); first ``start``, last ``done`` (with the
server-side timings ``first_audio_ms`` and ``total_ms``), or ``error`` with a message.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import struct
import time
from typing import Any

from fastapi import APIRouter, HTTPException, Request, Response, WebSocket, WebSocketDisconnect
from pydantic import ValidationError
from starlette.concurrency import run_in_threadpool

from mimika import limits
from mimika.errors import DataError, MimikaError
from mimika.newsreader.article import article_sentences
from mimika.studio import speaking
from mimika.studio.messages import plain
from mimika.studio.routers._deps import state_of
from mimika.studio.schemas import FramesRequest, SpeakRequest
from mimika.studio.state import SpeechEntry, StudioState, speech_key

log = logging.getLogger(__name__)
router = APIRouter(prefix="/api", tags=["speech"])


def _entry(st: StudioState, req: SpeakRequest) -> SpeechEntry:
    key = speech_key(req.text, req.lang, req.rate)
    cached = st.get_speech(key)
    if cached is not None and cached.done:
        return cached
    entry = speaking.synth_all(st, SpeechEntry(key, req.text, req.lang, req.rate), fps=req.fps)
    st.put_speech(entry)
    return entry


def _payload(entry: SpeechEntry, mix: speaking.Mix, *, fps: float) -> dict[str, Any]:
    return {"key": entry.key, "duration": round(entry.duration, 4),
            "audio": f"/api/speech/{entry.key}.wav",
            "segments": speaking.entry_frames(entry, mix, fps=fps),
            "sentences": [speaking.segment_info(s, i) for i, s in enumerate(entry.segments)]}


@router.post("/speak")
def speak(req: SpeakRequest, request: Request) -> dict[str, Any]:
    """Synthesise ``text`` (cached) and return frames per sentence, subtitles and the audio URL."""
    st = state_of(request)
    mix = speaking.mix_of(req.project, st, blend=req.blend)
    t = time.perf_counter()
    entry = _entry(st, req)
    out = _payload(entry, mix, fps=req.fps)
    out["server_ms"] = round((time.perf_counter() - t) * 1000, 1)
    return out


def _cached(request: Request, key: str) -> SpeechEntry:
    if not (len(key) == 20 and all(c in "0123456789abcdef" for c in key)):
        raise HTTPException(400, f"speech key {key[:24]!r} is malformed")
    entry = state_of(request).get_speech(key)
    if entry is None or not entry.done:
        raise HTTPException(404, "this speech is no longer cached; press Speak again")
    return entry


@router.get("/speech/{key}.wav")
def speech_wav(key: str, request: Request) -> Response:
    """The whole spoken text as a 16-bit WAV (for the page's <audio> element)."""
    return Response(speaking.wav_bytes(_cached(request, key)), media_type="audio/wav",
                    headers={"Cache-Control": "private, max-age=3600"})


@router.post("/speech/{key}/frames")
def speech_frames(key: str, req: FramesRequest, request: Request) -> dict[str, Any]:
    """Frames of a cached speech re-mixed with the (edited) timeline."""
    entry = _cached(request, key)
    return _payload(entry, speaking.mix_of(req.project, state_of(request), blend=req.blend),
                    fps=req.fps)


# -- live ----------------------------------------------------------------------------------------
class _Sender:
    def __init__(self, ws: WebSocket):
        self.ws = ws
        self.lock = asyncio.Lock()

    async def json(self, msg: dict[str, Any]) -> None:
        async with self.lock:
            await self.ws.send_text(json.dumps(msg, separators=(",", ":")))

    async def audio(self, header: dict[str, Any], pcm: bytes) -> None:
        h = json.dumps(header, separators=(",", ":")).encode()
        async with self.lock:
            await self.ws.send_bytes(struct.pack("<I", len(h)) + h + pcm)


async def _speak(send: _Sender, st: StudioState, req: SpeakRequest, sid: Any,
                 t_recv: float) -> None:
    def ms() -> float:
        return round((time.perf_counter() - t_recv) * 1000, 1)

    try:
        mix = await run_in_threadpool(speaking.mix_of, req.project, st, blend=req.blend)
        sents = article_sentences(req.text, req.lang)
    except MimikaError as e:
        await send.json({"type": "error", "id": sid, "message": plain(str(e))})
        return
    except Exception as e:  # a bug: answer anyway, never leave the page waiting
        log.exception("studio: live speech could not read the project")
        await send.json({"type": "error", "id": sid,
                         "message": f"internal error: {type(e).__name__}: {e}"})
        return
    key = speech_key(req.text, req.lang, req.rate)
    cached = st.get_speech(key)
    reuse = cached.segments if cached is not None and cached.done else None
    entry = SpeechEntry(key, req.text, req.lang, req.rate)
    await send.json({"type": "start", "id": sid, "key": key, "sentences": len(sents),
                     "server_ms": ms()})
    first_audio = None
    t0 = 0.0
    try:
        for i, (sent, char0) in enumerate(sents):
            if reuse is not None and i < len(reuse):
                seg = reuse[i]
            else:
                seg = await run_in_threadpool(speaking.synth_segment, st, sent, char0, t0,
                                              lang=req.lang, rate=req.rate, fps=req.fps)
            entry.segments.append(seg)
            await send.audio({"type": "audio", "id": sid, "index": i, "t0": round(t0, 6),
                              "sr": int(seg.utterance.sr), "samples": len(seg.utterance.audio),
                              "server_ms": ms()}, speaking.pcm16(seg))
            if first_audio is None:
                first_audio = ms()
            beh = await run_in_threadpool(speaking.segment_behaviour, entry.segments, i, mix,
                                          fps=req.fps)
            frames = await run_in_threadpool(speaking.segment_frames, seg, mix, fps=req.fps,
                                             behaviour=beh)
            frames.update(id=sid, index=i)
            await send.json(frames)
            info = speaking.segment_info(seg, i)
            info["id"] = sid
            await send.json(info)
            t0 += seg.duration
    except MimikaError as e:
        await send.json({"type": "error", "id": sid, "message": plain(str(e))})
        return
    except Exception as e:  # a bug: tell the page instead of leaving it waiting
        log.exception("studio: live speech failed")
        await send.json({"type": "error", "id": sid,
                         "message": f"internal error: {type(e).__name__}: {e}"})
        return
    entry.done = True
    st.put_speech(entry)
    log.info("studio: spoke %d sentence(s), first audio after %.1f ms", len(sents),
             first_audio or 0.0)
    await send.json({"type": "done", "id": sid, "key": key, "duration": round(entry.duration, 4),
                     "audio": f"/api/speech/{key}.wav",
                     "timing": {"first_audio_ms": first_audio, "total_ms": ms()}})


@router.websocket("/live")
async def live(ws: WebSocket) -> None:
    """Live speaking: see the module docstring for the protocol."""
    await ws.accept()
    st: StudioState = ws.app.state.studio
    limit: int = ws.app.state.max_body
    send = _Sender(ws)
    task: asyncio.Task | None = None
    try:
        while True:
            msg = await ws.receive()
            if msg["type"] == "websocket.disconnect":
                break
            t_recv = time.perf_counter()
            text = msg.get("text")
            if text is None or len(text) > limit:
                await send.json({"type": "error", "message": "messages must be JSON text under "
                                 f"{limit} bytes"})
                continue
            try:
                data = limits.loads_json(text, "message")  # no NaN, huge integers, deep nests
            except DataError as e:
                await send.json({"type": "error", "message": str(e)})
                continue
            if not isinstance(data, dict):
                await send.json({"type": "error", "message": "message is not a JSON object"})
                continue
            kind = data.get("type")
            if kind == "ping":
                await send.json({"type": "pong"})
            elif kind == "stop":
                if task is not None:
                    task.cancel()
                await send.json({"type": "stopped"})
            elif kind == "speak":
                sid = data.get("id")
                body = {k: v for k, v in data.items() if k not in ("type", "id")}
                try:
                    req = SpeakRequest.model_validate(body)
                except ValidationError as e:
                    from mimika.studio.messages import validation_message

                    err = validation_message(list(e.errors()))
                    await send.json({"type": "error", "id": sid, "message": err})
                    continue
                if task is not None:
                    task.cancel()
                task = asyncio.create_task(_speak(send, st, req, sid, t_recv))
            else:
                await send.json({"type": "error",
                                 "message": f"unknown message type {kind!r} (speak, stop, ping)"})
    except WebSocketDisconnect:
        pass
    finally:
        if task is not None:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
