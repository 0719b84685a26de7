"""The studio's FastAPI application: routers by topic, JSON errors, request limits, static page.

Every error reaches the client as ``{"error": "…"}`` with a 4xx status (5xx only for bugs and
exports past their time limit); request bodies are limited to :data:`MAX_BODY` bytes;
requests naming a Host the studio does not serve (DNS rebinding, :mod:`mimika.web.guard`)
and writes from another origin are refused.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, HTMLResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.requests import ClientDisconnect

import mimika
from mimika import limits
from mimika.errors import MimikaError
from mimika.face.heads import DEFAULT_HEAD
from mimika.studio.state import StudioState
from mimika.web.three import URL as THREE_URL
from mimika.web.three import VENDOR, vendor_ready

log = logging.getLogger(__name__)

STATIC = Path(__file__).parent / "static"
#: largest accepted request body (bytes) and WebSocket message (mimika.limits: max_body)
MAX_BODY = limits.DEFAULTS.max_body


def error_response(status: int, message: str, **extra: Any) -> JSONResponse:
    return JSONResponse({"error": message, **extra}, status_code=status)


def _status_of(e: MimikaError) -> int:
    from mimika.markup.project import ProjectError
    from mimika.studio.jobs import Cancelled

    if isinstance(e, Cancelled):
        return 409
    if isinstance(e, limits.LimitError) and e.limit == "max_export_seconds":
        return 503
    return 422 if isinstance(e, ProjectError) else 400


class LimitsMiddleware:
    """Refuse bodies over ``max_body`` bytes (413) and unsafe requests from other origins (403)."""

    def __init__(self, app: Any, max_body: int = MAX_BODY):
        self.app = app
        self.max_body = max_body

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        headers = {k.decode("latin-1").lower(): v.decode("latin-1")
                   for k, v in scope.get("headers", [])}
        origin = headers.get("origin")
        unsafe = scope["type"] == "websocket" or scope.get("method") not in ("GET", "HEAD",
                                                                             "OPTIONS")
        if origin and unsafe and not _same_origin(origin, headers.get("host", "")):
            if scope["type"] == "websocket":
                await send({"type": "websocket.close", "code": 1008})
                return None
            return await _send_json(send, 403, f"requests from {origin} are not allowed")
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        length = headers.get("content-length")
        if length is not None and length.isdigit() and int(length) > self.max_body:
            return await _send_json(send, 413, f"request body of {int(length)} bytes is over "
                                    f"the limit of {self.max_body} bytes")
        seen = 0
        started = False
        refused = False

        async def limited_receive() -> dict:
            nonlocal seen, refused
            msg = await receive()
            if msg["type"] == "http.request":
                seen += len(msg.get("body", b""))
                if seen > self.max_body:
                    if not started and not refused:
                        refused = True
                        await _send_json(send, 413, f"request body is over the limit of "
                                         f"{self.max_body} bytes")
                    return {"type": "http.disconnect"}
            return msg

        async def guarded_send(msg: dict) -> None:
            nonlocal started
            if refused:
                return  # the 413 went out already
            if msg["type"] == "http.response.start":
                started = True
            await send(msg)

        await self.app(scope, limited_receive, guarded_send)


def _same_origin(origin: str, host: str) -> bool:
    return origin.split("://", 1)[-1].rstrip("/") == host


async def _send_json(send: Any, status: int, message: str) -> None:
    body = json.dumps({"error": message}).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"),
                            (b"content-length", str(len(body)).encode())]})
    await send({"type": "http.response.body", "body": body})


def _validation_message(exc: RequestValidationError) -> str:
    from mimika.studio.messages import validation_message

    return validation_message(list(exc.errors()))


def create_app(projects_dir: str | Path, *, head: str = DEFAULT_HEAD,
               library_path: str | Path | None = None,
               controller_path: str | Path | None = None, max_body: int | None = None,
               warm_up: bool = False, host: str = "127.0.0.1",
               allowed_hosts: Iterable[str] = ()) -> FastAPI:
    """The studio app serving ``projects_dir``.

    Parameters
    ----------
    projects_dir : folder of project files (``NAME.json``); created if missing
    head : the head the page opens with (a name from ``mimika heads`` or a file; default the
        default character)
    library_path : user expression library (default ``$MIMIKA_DATA_DIR/expressions.json``)
    controller_path : a WGAN checkpoint for the latent sliders (default: the shipped one)
    max_body : request size limit in bytes (default: ``mimika.limits`` max_body)
    warm_up : load the head and espeak-ng in the background at start-up
    host : the address the server binds; requests must name it (or an allowed name) as Host
    allowed_hosts : more Host names to answer (``*.example.org`` matches subdomains)
    """
    from contextlib import asynccontextmanager

    from mimika.studio.jobs import Jobs
    from mimika.studio.routers import ROUTERS
    from mimika.web.glb import sweep_temp_dirs
    from mimika.web.guard import HostGuard, HostPolicy

    state = StudioState(projects_dir, head=head, library_path=library_path,
                        controller_path=controller_path)

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        if warm_up:
            import threading

            threading.Thread(target=_warm, args=(state,), name="studio-warm-up",
                             daemon=True).start()
        yield
        app.state.jobs.cancel_all("the studio is stopping")

    app = FastAPI(title="mimika studio", version=mimika.__version__, lifespan=lifespan,
                  docs_url="/api/docs", redoc_url=None, openapi_url="/api/openapi.json")
    max_body = max_body or limits.current().max_body
    sweep_temp_dirs()  # export folders of a studio that was killed
    app.state.studio = state
    app.state.max_body = max_body
    app.state.jobs = Jobs()
    app.add_middleware(LimitsMiddleware, max_body=max_body)
    app.add_middleware(HostGuard, policy=HostPolicy(host, allowed_hosts))  # outermost

    @app.exception_handler(RequestValidationError)
    async def _invalid(request: Request, exc: RequestValidationError) -> JSONResponse:
        return error_response(422, _validation_message(exc))

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        extra = dict(exc.detail) if isinstance(exc.detail, dict) else {}
        msg = (exc.detail if isinstance(exc.detail, str) else
               str(extra.pop("error", "")) or json.dumps(exc.detail))
        if exc.status_code == 404 and msg == "Not Found":
            msg = f"no such endpoint or file: {request.url.path}"
        if exc.status_code == 405:
            msg = f"{request.method} is not allowed on {request.url.path}"
        return error_response(exc.status_code, msg, **extra)

    @app.exception_handler(MimikaError)
    async def _mimika(request: Request, exc: MimikaError) -> JSONResponse:
        problems = getattr(exc, "problems", None)
        extra = {"problems": problems} if problems else {}
        from mimika.studio.messages import plain

        return error_response(_status_of(exc), plain(str(exc)), **extra)

    @app.exception_handler(ClientDisconnect)
    async def _gone(request: Request, exc: ClientDisconnect) -> Response:
        return Response(status_code=499)  # nobody is left to answer (refused uploads: 413 sent)

    @app.exception_handler(Exception)
    async def _bug(request: Request, exc: Exception) -> JSONResponse:
        log.exception("studio: unexpected error on %s %s", request.method, request.url.path)
        return error_response(500, f"internal error: {type(exc).__name__}: {exc}")

    for router in ROUTERS:
        app.include_router(router)

    @app.get("/", include_in_schema=False)
    def index() -> Any:
        if not vendor_ready():
            return HTMLResponse(_MISSING, status_code=503)
        return FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-cache"})

    app.mount(THREE_URL, StaticFiles(directory=VENDOR, check_dir=False), name="three")
    app.mount("/static", StaticFiles(directory=STATIC), name="static")
    return app


def _warm(state: StudioState) -> None:
    """Load the head, build its GLB and start espeak-ng so the first request is fast."""
    try:
        state.glb()
        from mimika.studio.speaking import warm

        warm(state)
        log.info("studio: warm")
    except MimikaError as e:  # reported again on first use
        log.warning("studio: warm-up failed: %s", e)


_MISSING = """<!doctype html><meta charset="utf-8"><title>mimika studio</title>
<body style="font:16px system-ui;background:#1d2026;color:#ddd;padding:3em">
<h1>mimika studio: three.js is not installed</h1>
<p>The page needs three.js from npm. Run <code>bash scripts/setup-studio.sh</code>
(needs node + npm) and reload.</p></body>"""
