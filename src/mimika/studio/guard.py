"""Host validation for the studio: a defence against DNS rebinding.

A page on ``attacker.test`` whose DNS name is re-pointed at 127.0.0.1 reaches the studio with
``Host: attacker.test:PORT`` and a matching ``Origin`` — same-origin as far as the browser
knows. The studio therefore answers only Host names it serves: the address it binds,
``localhost``, any IP literal when it binds every interface (an IP cannot be rebound), and
the names the user allows (``mimika studio --allow-host NAME``,
``MIMIKA_STUDIO_ALLOWED_HOSTS=a.example,*.lan``). Anything else gets 403, on HTTP and
WebSocket alike.
"""

from __future__ import annotations

import ipaddress
import json
import os
import socket
from collections.abc import Iterable
from typing import Any

LOOPBACK_NAMES = ("localhost", "127.0.0.1", "::1")
WILDCARDS = ("0.0.0.0", "::", "")
ENV = "MIMIKA_STUDIO_ALLOWED_HOSTS"


def host_name(header: str) -> str:
    """The name of a Host header, lower-case, without port, brackets or trailing dot."""
    h = header.strip().lower()
    if h.startswith("["):  # [::1]:8765
        return h[1:h.find("]")] if "]" in h else h[1:]
    if h.count(":") == 1:
        h = h.split(":", 1)[0]
    return h.rstrip(".")


def _is_ip(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


class HostPolicy:
    """Which Host names a studio bound to ``bind`` answers (see the module docstring)."""

    def __init__(self, bind: str = "127.0.0.1", allowed: Iterable[str] = ()):
        self.bind = host_name(bind) if bind not in WILDCARDS else bind
        extra = [*allowed, *os.environ.get(ENV, "").split(",")]
        self.allowed = {host_name(a) for a in extra if a.strip()}
        self.names = {"localhost", self.bind}
        if self.bind in ("127.0.0.1", "::1", "localhost"):
            self.names.update(LOOPBACK_NAMES)
        self.any_ip = self.bind in WILDCARDS
        if self.any_ip:
            hostname = socket.gethostname().lower()
            self.names.update({hostname, hostname.split(".")[0]})

    def allows(self, header: str | None) -> bool:
        if header is None:  # not a browser (every browser sends Host): no rebinding
            return True
        name = host_name(header)
        if name in self.names or name in self.allowed:
            return True
        if any(a.startswith("*.") and name.endswith(a[1:]) for a in self.allowed):
            return True
        return self.any_ip and _is_ip(name)


class HostGuard:
    """ASGI middleware: 403 (HTTP) or a refused handshake (WebSocket) for unknown Hosts."""

    def __init__(self, app: Any, policy: HostPolicy):
        self.app = app
        self.policy = policy

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] in ("http", "websocket"):
            host = next((v.decode("latin-1") for k, v in scope.get("headers", [])
                         if k == b"host"), None)
            if not self.policy.allows(host):
                if scope["type"] == "websocket":
                    await send({"type": "websocket.close", "code": 1008})
                    return
                where = self.policy.bind if not self.policy.any_ip else "its address"
                body = json.dumps({"error": f"host {host!r} is not served here; open the "
                                            f"studio at {where} or allow the name with "
                                            "mimika studio --allow-host"}).encode()
                await send({"type": "http.response.start", "status": 403,
                            "headers": [(b"content-type", b"application/json"),
                                        (b"content-length", str(len(body)).encode())]})
                await send({"type": "http.response.body", "body": body})
                return
        await self.app(scope, receive, send)
