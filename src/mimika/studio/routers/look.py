"""What the renderer draws: its look for the live view, PNG stills of a pose and contact
sheets of the expression library (rendered on the server, headless OpenGL)."""

from __future__ import annotations

import io
from typing import Any

from fastapi import APIRouter, HTTPException, Request, Response

from mimika.studio import look
from mimika.studio.routers._deps import state_of
from mimika.studio.schemas import SheetRequest, StillRequest

router = APIRouter(prefix="/api", tags=["look"])


@router.get("/look")
def look_info() -> dict[str, Any]:
    """Lights, materials, skin shader settings and framing of the ``plain`` and ``news`` looks."""
    return look.look_info()


def _png_bytes(img: Any) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(img).save(buf, format="PNG")
    return buf.getvalue()


async def _picture(request: Request, work: Any, filename: str, frames: int) -> Response:
    """Run ``work`` (→ an RGB image) as an export job (:mod:`mimika.studio.jobs`: bounded in
    time, in the lanes of the other exports); answer a PNG."""
    import importlib.util

    if importlib.util.find_spec("moderngl") is None:
        raise HTTPException(501, "pictures need mimika's renderer (moderngl), which is not "
                                 "installed here; export glTF instead")
    data = await request.app.state.jobs.run(request, lambda job: _png_bytes(work()), kind="PNG",
                                            name=filename, frames=frames, job_id=None)
    return Response(data, media_type="image/png",
                    headers={"Content-Disposition": f'attachment; filename="{filename}"'})


@router.post("/export/png")
async def export_png(req: StillRequest, request: Request) -> Response:
    """The pose ``aus`` on the head as a PNG, drawn by the renderer in the chosen look."""
    st = state_of(request)

    def work() -> Any:
        from mimika.facs.blender import blend

        rig = st.rig(req.head)
        aus = blend(req.aus, disabled=req.disabled).aus if req.blend else req.aus
        aus = {k: v for k, v in aus.items() if k in set(rig.supported)}
        size = (req.width, req.height)
        with look.renderer(rig, req.look, size) as r:
            return r.render(rig.deform(aus), camera=look.camera(rig, req.look, req.view, size),
                            aus=aus)

    return await _picture(request, work, "pose.png", 1)


@router.post("/export/sheet")
async def export_sheet(req: SheetRequest, request: Request) -> Response:
    """A labelled contact sheet: one tile per library expression at full intensity."""
    st = state_of(request)

    def work() -> Any:
        from mimika.render import contact_sheet

        rig = st.rig(req.head)
        with st.library_lock:
            lib = st.library()
        names = req.names if req.names is not None else lib.names()
        exprs = [lib.get(n) for n in names]
        sup = set(rig.supported)
        size = (req.tile, req.tile)
        images = []
        with look.renderer(rig, req.look, size) as r:
            cam = look.camera(rig, req.look, req.view, size)
            for e in exprs:
                aus = {k: float(v) for k, v in e.aus.items() if k in sup}
                images.append(r.render(rig.deform(aus), camera=cam, aus=aus))
        title = f"mimika: the expression library on the {st.head(req.head)} head"
        return contact_sheet(images, [e.name for e in exprs], columns=req.columns, title=title)

    return await _picture(request, work, "expressions.png", len(req.names or ()) or 50)
