"""Exports: glTF (GLB with morph animation), AU CSV, and MP4 when a video renderer exists."""

from __future__ import annotations

import importlib
from typing import Any

import numpy as np
from fastapi import APIRouter, HTTPException, Request, Response
from starlette.concurrency import run_in_threadpool

from mimika import limits
from mimika.studio import speaking
from mimika.studio.jobs import MP4_WEIGHT, Job, Jobs
from mimika.studio.routers._deps import state_of
from mimika.studio.routers.projects import _validate
from mimika.studio.schemas import ExportRequest
from mimika.studio.state import StudioState
from mimika.web.glb import gltf_bytes, temp_dir

router = APIRouter(prefix="/api/export", tags=["export"])
#: functions a newsreader module may offer, tried in order: f(project, path)
VIDEO_FUNCS = ("render_project", "render_mp4")


def _plan(req: ExportRequest, st: StudioState) -> tuple[Any, int]:
    """The validated project (None for a pose) and how many frames the export makes — refused
    here, before any work, when over the limits (:mod:`mimika.limits`)."""
    if req.project is None:
        if req.aus is None:
            from mimika.errors import ParameterError

            raise ParameterError("give a project or a pose (aus) to export")
        return None, 1
    proj = _validate(req.project, "project", st)
    tl = proj.timeline
    seconds = max(tl.end, 1.0 / req.fps)
    text = tl.speech.text.strip()
    if req.speech and text:
        seconds = max(seconds, limits.speech_seconds(text[:5000], 175))
    return proj, limits.check_timeline(seconds, req.fps, "the project")


def _track(st: StudioState, req: ExportRequest, proj: Any, job: Job) -> Any:
    """The AU track to export (a one-frame pose without a project)."""
    from mimika.tracks import AUTrack

    if proj is None:
        return AUTrack.constant(req.aus or {}, n_frames=1, fps=req.fps)
    tl = proj.timeline
    mix = speaking.mix_of(req.project, st)
    text = tl.speech.text.strip()
    if req.speech and text:
        entry = _speech(st, req, text, proj)
        job.check()
        return speaking.entry_track(entry, mix, fps=req.fps)
    from mimika.timeline import sample

    return sample(tl, fps=req.fps, blend=mix.blend, disabled=mix.disabled, library=mix.library,
                  duration=max(tl.end, 1.0 / req.fps))


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


def _attachment(data: bytes, media: str, filename: str) -> Response:
    return Response(data, media_type=media,
                    headers={"Content-Disposition": f'attachment; filename="{filename}"'})


async def _run(request: Request, req: ExportRequest, kind: str, work: Any, frames: int,
               job: str | None) -> bytes:
    jobs: Jobs = request.app.state.jobs
    return await jobs.run(request, work, kind=kind, name=req.name, frames=frames, job_id=job)


@router.post("/gltf")
async def export_gltf(req: ExportRequest, request: Request, job: str | None = None) -> Response:
    """A GLB of the head animated by the project (speech + timeline) or posed by ``aus``.
    ``?job=ID`` names the export so that ``DELETE /api/export/jobs/ID`` can cancel it."""
    st = state_of(request)
    proj, frames = await run_in_threadpool(_plan, req, st)

    def work(j: Job) -> bytes:
        if proj is None:
            return st.pose_glb(req.head, req.aus or {}, fps=req.fps, label=req.name)
        track = _track(st, req, proj, j)
        j.check()
        return gltf_bytes(_rig(st, req, proj), track, name=req.name, keep=True)

    data = await _run(request, req, "glTF", work, frames, job)
    return _attachment(data, "model/gltf-binary", f"{req.name}.glb")


@router.post("/csv")
async def export_csv(req: ExportRequest, request: Request, job: str | None = None) -> Response:
    """The project's AU track as CSV (``format``: au, openface or arkit / Live Link)."""
    from mimika.io.tracks import write_track

    st = state_of(request)
    proj, frames = await run_in_threadpool(_plan, req, st)

    def work(j: Job) -> bytes:
        track = _track(st, req, proj, j)
        j.check()
        with temp_dir() as d:
            p = d / f"{req.name}.csv"
            write_track(track, p, format=req.format)
            return p.read_bytes()

    return _attachment(await _run(request, req, "CSV", work, frames, job), "text/csv",
                       f"{req.name}.csv")


@router.post("/mp4")
async def export_mp4(req: ExportRequest, request: Request, job: str | None = None) -> Response:
    """An MP4 (H.264 + AAC speech) of the project or pose; 501 when no renderer is installed."""
    st = state_of(request)
    name = st.video_module()
    why = None if name else st.mp4_unavailable()
    if why is not None:
        raise HTTPException(501, f"{why}; export glTF or CSV instead")
    proj, frames = await run_in_threadpool(_plan, req, st)

    def work(j: Job) -> bytes:
        with temp_dir() as d:
            p = d / f"{req.name}.mp4"
            if name is not None and proj is not None:
                mod = importlib.import_module(name)
                func = next(getattr(mod, f) for f in VIDEO_FUNCS if callable(getattr(mod, f, None)))
                func(proj, p)
                return p.read_bytes()
            from mimika.studio.video import render_mp4

            track = _track(st, req, proj, j)
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
            j.check()
            render_mp4(_rig(st, req, proj), track, p, audio=audio, sr=sr, size=size, view=view,
                       look=look, progress=j.check)
            return p.read_bytes()

    data = await _run(request, req, "MP4", work, max(frames, int(req.fps)) * MP4_WEIGHT, job)
    return _attachment(data, "video/mp4", f"{req.name}.mp4")


@router.get("/jobs")
def list_jobs(request: Request) -> dict[str, Any]:
    """The exports running now (id, kind, name, frames, lane, seconds, done_frames)."""
    return {"jobs": request.app.state.jobs.list()}


@router.delete("/jobs/{job_id}")
def cancel_job(job_id: str, request: Request) -> dict[str, Any]:
    """Cancel a running export; its request answers 409 at once, its work stops at the next
    frame."""
    if not request.app.state.jobs.cancel(job_id):
        raise HTTPException(404, f"no running export {job_id!r}")
    return {"cancelled": job_id}
