"""Latent sliders of the WGAN controller (only when ``mimika.learn`` and a model load)."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, HTTPException, Request
from starlette.concurrency import run_in_threadpool

from mimika.studio.routers._deps import state_of
from mimika.studio.schemas import LatentRequest

router = APIRouter(prefix="/api/latent", tags=["latent"])


@router.get("")
async def latent_info(request: Request) -> dict[str, Any]:
    """Whether latent sliders are available, their count and the model's labels."""
    ctl, reason = await run_in_threadpool(state_of(request).controller)
    if ctl is None:
        return {"available": False, "reason": reason}
    return {"available": True, "latent_dim": int(ctl.latent_dim), "labels": list(ctl.labels),
            "kind": getattr(ctl, "kind", "")}


@router.post("/sample")
async def latent_sample(req: LatentRequest, request: Request) -> dict[str, Any]:
    """AU intensities the generator makes for one slider setting ``z``."""
    ctl, reason = await run_in_threadpool(state_of(request).controller)
    if ctl is None:
        raise HTTPException(501, reason or "latent sliders are unavailable")
    aus = await run_in_threadpool(ctl.sample, req.z, req.label)
    return {"aus": aus}
