"""Shared helpers of the routers."""

from __future__ import annotations

from fastapi import Request

from mimika.studio.state import StudioState


def state_of(request: Request) -> StudioState:
    return request.app.state.studio
