"""The ``mimika serve`` application: the ``/ws`` API, the example page and the player."""

from __future__ import annotations

import hmac
import logging
import threading
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs

from fastapi import FastAPI, Request, WebSocket
from fastapi.responses import FileResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles

import mimika
from mimika import limits

log = logging.getLogger(__name__)

STATIC = Path(__file__).parent / "static"
COOKIE = "mimika_token"


class TokenGuard:
    """ASGI middleware: with a token, every request must carry it (``?token=``, an
    ``Authorization: Bearer`` header or the cookie the page gets on its first visit)."""

    def __init__(self, app: Any, token: str | None):
        self.app, self.token = app, token

    def _ok(self, scope: dict) -> bool:
        given = parse_qs(scope.get("query_string", b"").decode("latin-1")).get("token", [""])[0]
        for k, v in scope.get("headers", []):
            if k == b"authorization" and v.lower().startswith(b"bearer "):
                given = given or v[7:].decode("latin-1").strip()
            if k == b"cookie":
                for part in v.decode("latin-1").split(";"):
                    name, _, val = part.strip().partition("=")
                    if name == COOKIE:
                        given = given or val
        return hmac.compare_digest(given.encode(), self.token.encode())

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if self.token and scope["type"] in ("http", "websocket") and not self._ok(scope):
            from mimika.web.guard import refuse

            await refuse(scope, send, 401, "this mimika serve needs its token: open the "
                                           "address it printed (with ?token=...) or send "
                                           "Authorization: Bearer TOKEN")
            return
        await self.app(scope, receive, send)


class ServeState:
    """What every connection shares: the one head (loaded once, its GLB built once) and the
    lock espeak-ng needs (it is not re-entrant)."""

    def __init__(self, head: str) -> None:
        from mimika.web.heads import HeadCache, check_head

        self.head = check_head(head)
        self._heads = HeadCache(1)
        self.espeak_lock = threading.Lock()

    def glb(self) -> tuple[bytes, str]:
        """The head as GLB (no animation) and its ETag."""
        return self._heads.glb(self.head)


def create_app(*, head: str | None = None, host: str = "127.0.0.1",
               allowed_hosts: tuple[str, ...] | list[str] = (), token: str | None = None,
               max_body: int | None = None, warm_up: bool = False) -> FastAPI:
    """The server: ``/ws`` (:mod:`mimika.serve.session`), ``/`` the example page,
    ``/player.js``, ``/head.glb`` (``head``, default the default character), ``/protocol.json``.
    Only Host names of ``host`` (or ``allowed_hosts``) are answered; ``token`` guards all."""
    from mimika.face.heads import DEFAULT_HEAD
    from mimika.serve.session import Session
    from mimika.web.guard import HostGuard, HostPolicy
    from mimika.web.three import URL, VENDOR, ensure_vendor

    state = ServeState(head or DEFAULT_HEAD)
    app = FastAPI(title="mimika serve", version=mimika.__version__, docs_url=None,
                  redoc_url=None, openapi_url=None)
    app.state.serve = state
    app.state.max_body = max_body or limits.current().max_body
    ensure_vendor()
    app.mount(URL, StaticFiles(directory=VENDOR), name="three")
    app.add_middleware(TokenGuard, token=token)
    app.add_middleware(HostGuard, policy=HostPolicy(host, allowed_hosts),  # outermost
                       command="serve")
    if warm_up:
        threading.Thread(target=_warm, args=(state,), name="serve-warm-up", daemon=True).start()

    @app.get("/")
    def page(request: Request) -> Response:
        r = FileResponse(STATIC / "index.html", media_type="text/html")
        if token:
            r.set_cookie(COOKIE, token, httponly=True, samesite="strict")
        return r

    @app.get("/player.js")
    def player() -> Response:
        return FileResponse(STATIC / "player.js", media_type="text/javascript")

    @app.get("/protocol.json")
    def protocol() -> Response:
        return FileResponse(Path(__file__).parent / "data" / "protocol.json",
                            media_type="application/json")

    @app.get("/head.glb")
    def head_glb(request: Request) -> Response:
        data, etag = state.glb()
        if request.headers.get("if-none-match") == etag:
            return Response(status_code=304, headers={"ETag": etag})
        return Response(data, media_type="model/gltf-binary",
                        headers={"ETag": etag, "Cache-Control": "no-cache"})

    @app.get("/favicon.ico")
    def favicon() -> Response:
        return Response(status_code=204)

    @app.get("/health")
    def health() -> JSONResponse:
        return JSONResponse({"ok": True, "version": mimika.__version__})

    @app.websocket("/ws")
    async def ws(websocket: WebSocket) -> None:
        await Session(websocket, state, max_message=app.state.max_body).run()

    return app


def _warm(state: ServeState) -> None:
    """Load the voice and the head's GLB so the first speak and page load are quick."""
    from mimika.serve.speech import speak_part

    try:
        speak_part(state, "Hello.", False, lang="en", voice=None, rate=175)
        state.glb()
    except Exception:  # warm-up is best effort; the real request reports its error
        log.exception("serve: warm-up failed")
