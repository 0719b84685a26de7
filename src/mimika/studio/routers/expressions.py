"""The expression library: list, create from sliders, delete user entries."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, HTTPException, Request

from mimika.errors import ParameterError
from mimika.studio.routers._deps import state_of
from mimika.studio.schemas import ExpressionCreate

router = APIRouter(prefix="/api/expressions", tags=["expressions"])


def _out(e: Any) -> dict[str, Any]:
    d = e.to_dict()
    d["builtin"] = e.builtin
    return d


@router.get("")
def list_expressions(request: Request) -> dict[str, Any]:
    """Every expression (built-ins, then the user's)."""
    st = state_of(request)
    with st.library_lock:
        lib = st.library()
        return {"expressions": [_out(e) for e in lib.list()], "user": lib.user_names()}


@router.post("", status_code=201)
def create_expression(req: ExpressionCreate, request: Request) -> dict[str, Any]:
    """Save the sliders as a user expression (atomic write of the user library)."""
    st = state_of(request)
    with st.library_lock:
        lib = st.library()
        key = req.name.strip().lower().replace(" ", "-")
        if not req.aus:
            raise ParameterError("an expression needs at least one Action Unit: move a slider "
                                 "first")
        if not req.force and key in lib:
            kind = "built-in" if key not in lib.user_names() else "yours"
            raise HTTPException(409, detail={
                "error": f"there is already an expression called “{key}” "
                         f"({'a built-in one' if kind == 'built-in' else 'in your library'}); "
                         "choose another name or replace it",
                "code": "exists", "name": key, "builtin": kind == "built-in"})
        e = lib.create(req.name, req.aus, onset=req.onset, duration=req.duration,
                       offset=req.offset, description=req.description, force=req.force)
    return _out(e)


@router.delete("/{name:path}")
def delete_expression(name: str, request: Request) -> dict[str, Any]:
    """Remove a user expression."""
    if len(name) > 64:
        raise ParameterError("expression name is longer than 64 characters")
    st = state_of(request)
    with st.library_lock:
        st.library().delete(name)
    return {"deleted": name}
