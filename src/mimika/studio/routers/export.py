"""Exports: glTF (GLB with morph animation), AU CSV, and MP4 when a video renderer exists."""

from __future__ import annotations

import importlib
import tempfile
import threading
from pathlib import Path
from typing import Any

import numpy as np
from fastapi import APIRouter, HTTPException, Request, Response
from starlette.concurrency import run_in_threadpool

from mimika.studio import speaking
from mimika.studio.routers._deps import state_of
from mimika.studio.routers.projects import _validate
from mimika.studio.schemas import ExportRequest
from mimika.studio.state import StudioState, gltf_bytes

router = APIRouter(prefix="/api/export", tags=["export"])
#: exports are CPU-heavy (a glTF rebuilds every morph target): one at a time keeps the
#: editor responsive under load
_EXPORTS = threading.Semaphore(1)
#: functions a newsreader module may offer, tried in order: f(project, path)
VIDEO_FUNCS = ("render_project", "render_mp4")


def _track(st: StudioState, req: ExportRequest) -> tuple[Any, Any]:
    """The AU track to export and the project (None for a bare pose)."""
    from mimika.tracks import AUTrack

    if req.project is None:
        if req.aus is None:
            from mimika.errors import ParameterError

            raise ParameterError("give a project or a pose (aus) to export")
        return AUTrack.constant(req.aus, n_frames=1, fps=req.fps), None
    proj = _validate(req.project, "project", st)
    tl = proj.timeline
    mix = speaking.mix_of(req.project, st)
    text = tl.speech.text.strip()
    if req.speech and text:
        return speaking.entry_track(_speech(st, req, text, proj), mix, fps=req.fps), proj
    from mimika.timeline import sample

    return sample(tl, fps=req.fps, blend=mix.blend, disabled=mix.disabled, library=mix.library,
                  duration=max(tl.end, 1.0 / req.fps)), proj


def _speech(st: StudioState, req: ExportRequest, text: str, proj: Any) -> Any:
    """The project's speech: the recording the page names (``speech_key``), else its text
    spoken by espeak-ng (cached)."""
    if req.speech_key:
        entry = st.get_speech(req.speech_key)
        if entry is None or not entry.done:
            from mimika.errors import ParameterError

            raise ParameterError("the recording is no longer on the server; load it again")
        return entry
    from mimika.studio.routers.speech import _entry

    return _entry(st, speaking.speak_request(text, proj, fps=req.fps))


def _rig(st: StudioState, req: ExportRequest, proj: Any) -> Any:
    """The rig of the project's head (a pose: the request's head)."""
    return st.rig(str(proj.settings["head"]) if proj is not None else req.head)


def _one_at_a_time(work: Any) -> bytes:
    with _EXPORTS:
        return work()


def _attachment(data: bytes, media: str, filename: str) -> Response:
    return Response(data, media_type=media,
                    headers={"Content-Disposition": f'attachment; filename="{filename}"'})


@router.post("/gltf")
async def export_gltf(req: ExportRequest, request: Request) -> Response:
    """A GLB of the head animated by the project (speech + timeline) or posed by ``aus``."""
    st = state_of(request)

    def work() -> bytes:
        track, proj = _track(st, req)
        return gltf_bytes(_rig(st, req, proj), track, name=req.name)

    data = await run_in_threadpool(_one_at_a_time, work)
    return _attachment(data, "model/gltf-binary", f"{req.name}.glb")


@router.post("/csv")
async def export_csv(req: ExportRequest, request: Request) -> Response:
    """The project's AU track as CSV (``format``: au, openface or arkit / Live Link)."""
    from mimika.io.tracks import write_track

    st = state_of(request)

    def work() -> bytes:
        track, _ = _track(st, req)
        with tempfile.TemporaryDirectory(prefix="mimika-studio-") as d:
            p = Path(d) / f"{req.name}.csv"
            write_track(track, p, format=req.format)
            return p.read_bytes()

    return _attachment(await run_in_threadpool(_one_at_a_time, work), "text/csv", f"{req.name}.csv")


@router.post("/mp4")
async def export_mp4(req: ExportRequest, request: Request) -> Response:
    """An MP4 (H.264 + AAC speech) of the project or pose; 501 when no renderer is installed."""
    st = state_of(request)
    name = st.video_module()
    why = None if name else st.mp4_unavailable()
    if why is not None:
        raise HTTPException(501, f"{why}; export glTF or CSV instead")

    def work() -> bytes:
        with tempfile.TemporaryDirectory(prefix="mimika-studio-") as d:
            p = Path(d) / f"{req.name}.mp4"
            if name is not None and req.project is not None:
                mod = importlib.import_module(name)
                func = next(getattr(mod, f) for f in VIDEO_FUNCS if callable(getattr(mod, f, None)))
                func(_validate(req.project, "project", st), p)
                return p.read_bytes()
            from mimika.studio.video import render_mp4

            track, proj = _track(st, req)
            audio = sr = None
            text = proj.timeline.speech.text.strip() if proj is not None else ""
            if req.speech and text:
                audio, sr = _speech(st, req, text, proj).audio()
            if track.n_frames < 2:  # a pose: one second of it
                from mimika.tracks import AUTrack

                track = AUTrack(np.repeat(track.values, int(req.fps), axis=0), track.channels,
                                req.fps)
            size = tuple(proj.settings.get("size", (640, 480))) if proj else (640, 480)
            view = str(proj.settings.get("view", "front")) if proj else "front"
            look = str(proj.settings.get("look", "plain")) if proj else req.look
            render_mp4(_rig(st, req, proj), track, p, audio=audio, sr=sr, size=size, view=view,
                       look=look)
            return p.read_bytes()

    data = await run_in_threadpool(_one_at_a_time, work)
    return _attachment(data, "video/mp4", f"{req.name}.mp4")
