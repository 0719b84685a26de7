"""The head, the AU catalogue, the AU Blender and studio status."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Query, Request, Response

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


@router.get("/heads")
def heads(request: Request) -> dict[str, Any]:
    """Every head :func:`mimika.face.heads.list_heads` knows, whether it is installed here, and
    the studio's default head."""
    st = state_of(request)
    return {"default": st.head_name,
            "heads": [{"name": h.name, "rig": h.rig, "available": h.available,
                       "description": h.description} for h in st.head_infos()]}


HeadName = Query(None, max_length=200, description="a head from /api/heads (default: the "
                 "studio's head)")


@router.get("/head")
def head(request: Request, name: str | None = HeadName) -> dict[str, Any]:
    """A head: supported AUs by FACS group, the joint motions per AU and the face's frame."""
    return state_of(request).head_info(name)


@router.get("/head.glb")
def head_glb(request: Request, name: str | None = HeadName) -> Response:
    """The head as binary glTF: one morph target per AU (+L/R), head and eye joints."""
    data, etag = state_of(request).glb(name)
    if request.headers.get("if-none-match") == etag:
        return Response(status_code=304, headers={"ETag": etag})
    return Response(data, media_type="model/gltf-binary",
                    headers={"ETag": etag, "Cache-Control": "no-cache"})


@router.post("/blend")
def blend(req: BlendRequest) -> dict[str, Any]:
    """Run the AU Blender (FACS co-occurrence rules) on ``aus``: blended values and trace."""
    from mimika.facs.blender import blend as run

    return run(req.aus, disabled=req.disabled).to_dict()


@router.get("/blend/rules")
def blend_rules() -> dict[str, Any]:
    """Every AU Blender rule with a plain-language title and explanation (for the switches)."""
    from mimika.studio.rules import rules_info

    return {"rules": rules_info()}
