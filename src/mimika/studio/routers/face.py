"""The head, the AU catalogue, the AU Blender and studio status."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Request, Response

import mimika
from mimika.studio.routers._deps import state_of
from mimika.studio.schemas import BlendRequest

router = APIRouter(prefix="/api", tags=["face"])


@router.get("/status")
def status(request: Request) -> dict[str, Any]:
    """Version, head and which optional features are present."""
    from mimika.timeline import easing_names

    st = state_of(request)
    video = st.video_module()
    why = None if video else st.mp4_unavailable()
    return {"version": mimika.__version__, "head": st.head_name,
            "features": {"mp4": why is None, "mp4_reason": why, "video_module": video},
            "easings": list(easing_names()),
            "limits": {"max_body": request.app.state.max_body, "max_text": 5000}}


@router.get("/aus")
def aus() -> dict[str, Any]:
    """The FACS catalogue: code, name, group, sided."""
    from mimika.facs import AU_CATALOGUE

    return {"aus": [{"code": a.code, "name": a.name, "group": a.group, "sided": a.sided,
                     "seed": a.seed} for a in AU_CATALOGUE.values()]}


@router.get("/head")
def head(request: Request) -> dict[str, Any]:
    """The loaded head: supported AUs by FACS group and the joint motions per AU."""
    return state_of(request).head_info()


@router.get("/head.glb")
def head_glb(request: Request) -> Response:
    """The head as binary glTF: one morph target per AU (+L/R), head and eye joints."""
    data, etag = state_of(request).glb()
    if request.headers.get("if-none-match") == etag:
        return Response(status_code=304, headers={"ETag": etag})
    return Response(data, media_type="model/gltf-binary",
                    headers={"ETag": etag, "Cache-Control": "no-cache"})


@router.post("/blend")
def blend(req: BlendRequest) -> dict[str, Any]:
    """Run the AU Blender (FACS co-occurrence rules) on ``aus``: blended values and trace."""
    from mimika.facs.blender import blend as run

    return run(req.aus, disabled=req.disabled).to_dict()
