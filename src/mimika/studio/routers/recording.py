"""Recorded speech: upload a recording with its text; the mouth follows it (alignment)."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Request
from starlette.concurrency import run_in_threadpool

from mimika.studio import recording, speaking
from mimika.studio.routers._deps import state_of
from mimika.studio.routers.speech import _payload

router = APIRouter(prefix="/api/speech", tags=["speech"])
FPS = 30.0


@router.post("/align")
async def align_recording(request: Request) -> dict[str, Any]:
    """A recording (body: see :mod:`mimika.studio.recording`) aligned to its text: cached like
    spoken text, answered like ``/api/speak`` (frames per sentence, subtitles, audio URL)."""
    st = state_of(request)
    head, audio = recording.parse_upload(await request.body())
    lang = str(head.get("lang") or "en")
    mix = await run_in_threadpool(speaking.mix_of, head.get("project"), st,
                                  blend=bool(head.get("blend")))
    entry = await run_in_threadpool(recording.aligned_entry, st, audio, head["sr"], head["text"],
                                    lang, fps=FPS)
    st.put_speech(entry)
    out = _payload(entry, mix, fps=FPS)
    out["aligned"] = True
    return out
