"""Projects (mimika project JSON in the projects folder) and timeline sampling."""

from __future__ import annotations

import contextlib
from datetime import UTC, datetime
from typing import Any

from fastapi import APIRouter, Body, Request

from mimika.errors import DataError, ParameterError
from mimika.studio.names import SUFFIX, check_project_name, project_path
from mimika.studio.routers._deps import state_of
from mimika.studio.schemas import SampleRequest

router = APIRouter(prefix="/api", tags=["projects"])


def _validate(doc: Any, name: str, st: Any) -> Any:
    """The project of ``doc`` as the studio can use it (see :mod:`mimika.studio.checks`)."""
    from mimika.studio.checks import check_project

    with st.library_lock:
        lib = st.library()
    return check_project(doc, name, library=lib, heads=st.head_names())


@router.get("/projects")
def list_projects(request: Request) -> dict[str, Any]:
    """Saved projects, newest first."""
    st = state_of(request)
    out = []
    for p in st.projects_dir.glob("*" + SUFFIX):
        name = p.name[: -len(SUFFIX)]
        with contextlib.suppress(ParameterError):
            check_project_name(name)
            m = p.stat().st_mtime
            out.append({"name": name, "modified": datetime.fromtimestamp(m, UTC).isoformat(),
                        "bytes": p.stat().st_size, "_m": m})
    out.sort(key=lambda d: -d.pop("_m"))
    return {"projects": out}


@router.get("/projects/{name:path}")
def get_project(name: str, request: Request) -> dict[str, Any]:
    """One project as mimika project JSON (validated on the way out)."""
    from mimika.markup.project import load_project, project_to_dict

    p = project_path(state_of(request).projects_dir, name)
    if not p.is_file():
        from fastapi import HTTPException

        raise HTTPException(404, f"no project called {name!r}")
    return project_to_dict(load_project(p))


@router.put("/projects/{name:path}")
def put_project(name: str, request: Request,
                doc: dict[str, Any] = Body(...)) -> dict[str, Any]:  # noqa: B008
    """Validate and save a project atomically (the old file survives any failure)."""
    from mimika.markup.project import project_to_dict, save_project

    st = state_of(request)
    p = project_path(st.projects_dir, name)
    name = p.name[: -len(SUFFIX)]
    proj = _validate(doc, name, st)
    try:
        save_project(proj, p)
    except OSError as e:
        raise DataError(f"cannot save the project “{name}”: {e.strerror or e}") from None
    return {"saved": name, "project": project_to_dict(proj)}


@router.post("/projects/check")
def check_project_doc(request: Request, doc: Any = Body(...)) -> dict[str, Any]:  # noqa: B008
    """Check a project document (e.g. a file opened in the page) without saving it: always
    200, with ``ok``, the ``problems`` in plain words and the normalised ``project``."""
    from mimika.markup.project import ProjectError, project_to_dict

    try:
        proj = _validate(doc, "project", state_of(request))
    except ProjectError as e:
        return {"ok": False, "problems": e.problems}
    except ParameterError as e:
        return {"ok": False, "problems": [str(e)]}
    return {"ok": True, "problems": [], "project": project_to_dict(proj)}


@router.delete("/projects/{name:path}")
def delete_project(name: str, request: Request) -> dict[str, Any]:
    p = project_path(state_of(request).projects_dir, name)
    if not p.is_file():
        from fastapi import HTTPException

        raise HTTPException(404, f"no project called {name!r}")
    p.unlink()
    return {"deleted": name}


@router.post("/timeline/sample")
def sample_timeline(req: SampleRequest, request: Request) -> dict[str, Any]:
    """Sample a project's timeline (expressions, head, gaze, blinks) at ``fps``."""
    import numpy as np

    from mimika.studio.speaking import mix_of
    from mimika.timeline import sample

    st = state_of(request)
    proj = _validate(req.project, "project", st)
    mix = mix_of(req.project, st)
    tl = proj.timeline
    dur = req.duration if req.duration is not None else max(tl.end, 0.04)
    track = sample(tl, fps=req.fps, duration=min(dur, 600.0), blend=mix.blend,
                   disabled=mix.disabled, library=mix.library)
    return {"fps": req.fps, "t0": 0.0, "duration": tl.end, "channels": list(track.channels),
            "values": np.round(track.values.astype(np.float64), 4).tolist()}
